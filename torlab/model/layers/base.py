"""The interface of a third-body layer law: what every law shares, what each law says.

A layer law (``docs/model/layers.md``) is one object, :class:`LayerLaw`, that declares

* its parameters (:class:`Param`): scene key, unit, symbol for reports, what it
  means, the scene's hard limits and plausible range, the HPT fit's bounds, scale and
  whether it is positive (uncertainty and interpolation on ``ln p``);
* its stress along a monotone loading path at constant normal stress (the HPT curve,
  :meth:`LayerLaw.hpt_tau`) and along a FASTSIM strip (:meth:`LayerLaw.strip_plastic`);
* its yield stress against the accumulated plastic slip and a vectorised per-element
  plastic update (:meth:`LayerLaw.yield_stress`, :meth:`LayerLaw.return_map`) for
  solvers that discretise the contact into elements.

Every law shares the *elastic part and the onset of yield* (thesis Eqs. 5.26, 5.28):
the layer is elastic with the flexibility ``L_e = L_mue / p`` in series with the bodies
until the shear stress reaches ``tau_c1 = mu_c1 p exp(mu_c1_T (T - T_A))``; only what
follows (hardening, softening, perfect plasticity) is the law's own.  That shared
structure is what lets FASTSIM's closed forms (elastic stress, yield angle) and the
creep forces serve every law unchanged.

The solvers, fits, bands, scene schema, ranges table and virtual experiments take
their parameter lists from the registry (:mod:`torlab.model.layers`), never from a
list of their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from torlab.model.layers import LayerParams

__all__ = ["L_MUE", "MU_C1", "MU_C1_T", "LayerLaw", "Param"]


@dataclass(frozen=True)
class Param:
    """One parameter of a layer law.

    Attributes
    ----------
    name
        The scene key (``boundary:``) and the fit's parameter name.
    kind
        The quantity kind users write it in (:data:`torlab.units.KINDS`).
    unit
        Its SI unit in tables and parameter files (``"-"``, ``"m"``, ``"1/m"``, ``"1/K"``).
    symbol
        Symbol for reports and figures (``"μc1"``).
    meaning
        One line: what it is.
    default
        Value when a scene leaves it out; None: required.
    ge, le
        Hard limits of the scene schema (None: none).
    range
        Plausible range checked on a scene value: a quantity of :data:`torlab.units.RANGES`,
        or the fields of a :class:`torlab.units.Range` for a quantity of the law's own
        (None: the hard limits only).
    fit
        ``(lower, upper)`` bounds of the HPT fit, in units of ``scale``; None: not
        fitted from a single curve (a temperature coefficient).
    traction
        The traction fit's bounds (units of ``scale``); None: those of ``fit``.
    scale
        The fits' internal scale (SI value / scale is of order one).
    positive
        A positive quantity: fit uncertainty, bands and interpolation over amounts
        on ``ln p``.
    temperature_of
        For a temperature coefficient: the coefficient it multiplies
        (``exp(coef (T - T_A))``); its fit is :func:`torlab.fit.temperature`.
    column
        Column suffix of the unit in tables (``"_m"``, ``"_per_K"``).
    """

    name: str
    kind: str
    unit: str
    symbol: str
    meaning: str
    default: float | None = None
    ge: float | None = None
    le: float | None = None
    range: str | dict[str, Any] | None = None
    fit: tuple[float, float] | None = None
    traction: tuple[float, float] | None = None
    scale: float = 1.0
    positive: bool = False
    temperature_of: str | None = None
    column: str = ""


# --- the parameters every law shares: the elastic part and the onset of yield -----------------
MU_C1 = Param("mu_c1", "dimensionless", "-", "μc1",
              "elastic limit coefficient: yield starts at tau_c1 = mu_c1 p (Eq. 5.26)",
              ge=0.0, le=5.0, fit=(1e-4, 5.0), traction=(1e-4, 3.0), positive=True)
L_MUE = Param("L_mue", "length", "m", "Lμe",
              "elastic length of the layer: flexibility L_e = L_mue / p in series with the "
              "bodies (Eq. 5.28)", default=0.0, ge=0.0, range="layer_length",
              fit=(1e-3, 1e3), traction=(1e-4, 1e3), scale=1e-6, positive=True, column="_m")
MU_C1_T = Param("mu_c1_T", "inverse_temperature", "1/K", "μc1,T",
                "temperature coefficient of mu_c1: x exp(mu_c1_T (T - T_A)) (Eq. 5.26)",
                default=0.0, range="temperature_coefficient", temperature_of="mu_c1",
                column="_per_K")


# --------------------------------------------------------------------------------------------
# the law
# --------------------------------------------------------------------------------------------
class LayerLaw:
    """A third-body layer law (module docstring).  Subclasses set the class attributes
    and implement the plastic branch; the elastic part and the onset are shared.

    Attributes
    ----------
    name
        The scene's ``boundary: law:`` value and ``fit hpt --law``.
    title
        A few words for reports (``"Voce hardening/softening"``).
    reference
        Where the law comes from (thesis equation, CONTACT's user guide).
    limit_text
        Its plastic limit in a few words, for model descriptions.
    reference_name
        The parameter :meth:`reference_mu` returns (normalised tables' ``mu``).
    params
        Its parameters, in order (the positional order of :class:`LayerParams`).
    """

    name: str = ""
    title: str = ""
    reference: str = ""
    params: tuple[Param, ...] = ()
    #: the plastic limit in a few words ("Voce limit"), for model descriptions
    limit_text: str = ""
    #: the plastic branch in a word or two ("Voce"), for the lists of what was modelled
    short: str = ""
    #: the parameter :meth:`reference_mu` returns, for table attributes
    reference_name: str = "mu_c1"

    # -- parameter lists --------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """Every parameter name, in order."""
        return tuple(p.name for p in self.params)

    @property
    def fit_names(self) -> tuple[str, ...]:
        """The parameters an HPT (or traction) curve at one temperature determines."""
        return tuple(p.name for p in self.params if p.fit is not None)

    @property
    def temperature_names(self) -> tuple[str, ...]:
        """The temperature coefficients."""
        return tuple(p.name for p in self.params if p.temperature_of is not None)

    def param(self, name: str) -> Param:
        """The :class:`Param` called ``name`` (KeyError if the law has none)."""
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)

    def __repr__(self) -> str:
        return f"<layer law {self.name}>"

    # -- the shared elastic part and onset (Eqs. 5.26, 5.28) ---------------------------------
    def f1(self, lay: LayerParams, dT: Any) -> Any:
        """Temperature factor of the elastic limit ``exp(mu_c1_T dT)`` (1.0 when zero)."""
        return np.exp(lay.mu_c1_T * dT) if lay.mu_c1_T else 1.0

    @staticmethod
    def elastic_flexibility(lay: LayerParams, p: Any) -> np.ndarray:
        """The layer's flexibility ``L_e = L_mue / p`` [m/Pa] (Eq. 5.28)."""
        return lay.L_mue / np.asarray(p, dtype=float)

    def onset_excess(self, lay: LayerParams, u: Any, pL: Any, f1: Any) -> Any:
        """``d = u - tau_c1 L``: the slip past the elastic limit [m] of a particle that has
        slipped ``u`` where ``pL = p L`` (``L`` the flexibility in series, layer included)
        and the limit carries the temperature factor ``f1``."""
        return u - lay.mu_c1 * f1 * pL

    # -- what each law says ------------------------------------------------------------------
    def hpt_plastic(self, s: np.ndarray, sigma: float, lay: LayerParams) -> np.ndarray:
        """Shear stress [Pa] at the displacement ``s >= 0`` [m] past the elastic limit,
        monotone loading at the constant normal stress ``sigma`` [Pa] (the HPT test)."""
        raise NotImplementedError

    def hpt_length(self, lay: LayerParams) -> float | None:
        """The plastic branch's own length [m] (the fits tabulate it on a grid graded
        with it), or None when the branch has none (it is then tabulated uniformly)."""
        return None

    def strip_plastic(self, lay: LayerParams, p: Any, u: Any, pL: Any, dT: Any,
                      grouped: bool = False) -> Any:
        """Shear stress [Pa] of a yielded particle along a FASTSIM strip.

        Parameters
        ----------
        lay
            The layer (arrays broadcasting with ``p`` when ``grouped``).
        p
            Pressure [Pa].
        u
            The particle's accumulated rigid slip [m] (``xi X``, or the slip path ``S``
            with lateral creepage and spin).
        pL
            ``p L`` [m]: pressure times the flexibility in series (bodies plus layer,
            ``L1 p + L_mue``).
        dT
            Temperature above ambient [K].
        grouped
            The layer's values are arrays (one layer per point).
        """
        raise NotImplementedError

    def strip_partials(self, lay: LayerParams, p: float, u: float, pL: float
                       ) -> tuple[float, float, float]:
        """Partial derivatives ``(dg/dp, dg/du, dg/dpL)`` of :meth:`strip_plastic`
        (isothermal, scalars): the grid-free references integrate with them."""
        raise NotImplementedError

    def strip_kinks(self, lay: LayerParams) -> list[Any]:
        """Slips past the limit [m] where :meth:`strip_plastic` has a kink (NaN where a
        layer has none): FASTSIM puts a panel edge there.  None by default."""
        return []

    def grading_length(self, lay: LayerParams) -> Any:
        """Length [m] over which the plastic stress changes fastest after the limit (the
        FASTSIM panels are graded with it); 0 when the branch has none."""
        return 0.0

    def hardens(self, lay: LayerParams) -> bool:
        """Whether the plastic stress depends on the slip past the limit (False: it stays
        at ``tau_c1`` and the solvers skip the clamped zone)."""
        return True

    def softens(self, lay: LayerParams) -> bool:
        """Whether the layer's strength falls after the elastic limit (its traction curve
        can then fall where the contact saturates)."""
        return False

    def reference_mu(self, lay: LayerParams) -> Any:
        """The coefficient that scales the law's traction (normalised tables use
        ``F/(mu N)``): its full-slip level where it has one, else ``mu_c1``."""
        return lay.mu_c1

    def limits(self) -> list[tuple[str, str]]:
        """The coefficients drawn as levels on traction and amount figures:
        ``[(parameter, label), ...]``."""
        return [("mu_c1", "μ_c1 (yield limit)")]

    def temperature_coefficients(self, lay: LayerParams) -> list[Any]:
        """The values of the temperature coefficients (arrays with groups)."""
        return [getattr(lay, n) for n in self.temperature_names]

    def temperature_sensitivity(self, lay: LayerParams) -> Any:
        """The largest ``|temperature coefficient|`` [1/K] (elementwise with groups)."""
        coefs = [np.abs(c) for c in self.temperature_coefficients(lay)]
        out = coefs[0]
        for c in coefs[1:]:
            out = np.maximum(out, c)
        return out

    def temperature_text(self, lay: LayerParams) -> str:
        """``"mu_c1_T = -0.001, mu_c2_T = 0 1/K"`` for messages."""
        return ", ".join(f"{n} = {getattr(lay, n):g}" for n in self.temperature_names) + " 1/K"

    def yield_stress(self, lay: LayerParams, p: Any, kappa: Any, dT: Any = 0.0) -> np.ndarray:
        """Yield stress ``tau_c(p, kappa)`` [Pa] against the accumulated plastic slip
        ``kappa`` [m] (CONTACT's ``u*_pl``), for element solvers."""
        raise NotImplementedError

    def hardening_modulus(self, lay: LayerParams, p: Any, kappa: Any, dT: Any = 0.0
                          ) -> np.ndarray:
        """``d tau_c / d kappa`` [Pa/m] (negative: softening)."""
        raise NotImplementedError

    def plastic_reach(self, lay: LayerParams, p: Any, tau: Any, dT: Any = 0.0) -> np.ndarray:
        """The smallest accumulated plastic slip ``kappa >= 0`` [m] at which the yield stress
        reaches ``tau`` [Pa] (``inf`` where it never does)."""
        raise NotImplementedError

    def return_map(self, lay: LayerParams, p: Any, tau_trial: Any, kappa: Any,
                   stiffness: Any, dT: Any = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """The plastic update of contact elements (vectorised; radial return).

        An element carries the traction ``tau`` (its last axis: components) and the
        accumulated plastic slip ``kappa``.  Given the *trial* traction of a step (the
        traction if the step added no plastic slip) and the element's elastic stiffness
        against its own plastic slip, the yield condition ``|tau| <= tau_c(kappa)``
        (:meth:`yield_stress`) is restored by a plastic slip ``dk >= 0`` along the trial
        direction: ``|tau| = |tau_trial| - k dk = tau_c(kappa + dk)``.

        Parameters
        ----------
        lay
            The layer.
        p
            Pressure of each element [Pa] (broadcasts with ``kappa``).
        tau_trial
            Trial traction [Pa]: shape ``kappa.shape`` (a magnitude with sign, 1-D
            problems) or ``kappa.shape + (2,)``.
        kappa
            Accumulated plastic slip before the step [m].
        stiffness
            ``k`` [Pa/m]: traction lost per unit plastic slip of the element itself
            (``1/(L_bodies + L_e)`` for one element; CONTACT's diagonal influence
            coefficient plus the layer).
        dT
            Temperature above ambient [K].

        Returns
        -------
        tuple
            ``(tau, dk)``: the traction after the step, the plastic slip it added [m].

        Raises
        ------
        ConvergenceError
            The scalar plastic-slip equation did not converge (laws without a closed form).
        """
        tt = np.asarray(tau_trial, dtype=float)
        kap = np.asarray(kappa, dtype=float)
        vec = tt.ndim == kap.ndim + 1 and tt.ndim > 0 and tt.shape[-1] == 2
        mag = np.linalg.norm(tt, axis=-1) if vec else np.abs(tt)
        k = np.asarray(stiffness, dtype=float)
        dk = self._plastic_slip(lay, p, mag, kap, k, dT)
        new = np.maximum(mag - k * dk, 0.0)
        ratio = np.where(mag > 0, new / np.where(mag > 0, mag, 1.0), 0.0)
        tau = tt * (ratio[..., None] if vec else ratio)
        return tau, dk

    def _plastic_slip(self, lay: LayerParams, p: Any, mag: np.ndarray, kappa: np.ndarray,
                      k: np.ndarray, dT: Any) -> np.ndarray:
        """``dk >= 0`` with ``mag - k dk = tau_c(kappa + dk)`` where ``mag > tau_c(kappa)``
        (0 elsewhere): safeguarded Newton on the decreasing ``f(dk) = mag - k dk -
        tau_c(kappa + dk)``, vectorised.  Laws with a closed form override it."""
        from torlab.errors import ConvergenceError

        tc = self.yield_stress(lay, p, kappa, dT)
        f0 = mag - tc
        act = f0 > 0
        dk = np.zeros(np.broadcast_shapes(np.shape(mag), np.shape(kappa), np.shape(tc)))
        if not np.any(act):
            return dk
        mag_b = np.broadcast_to(mag, dk.shape)
        kap_b = np.broadcast_to(kappa, dk.shape)
        k_b = np.broadcast_to(k, dk.shape)
        lo = np.zeros(dk.shape)
        hi = np.where(act, mag_b / np.maximum(k_b, 1e-300), 0.0)  # tau >= 0 at most this far
        x = np.where(act, np.minimum(f0 / np.maximum(k_b, 1e-300), hi), 0.0)
        for _ in range(100):
            f = mag_b - k_b * x - self.yield_stress(lay, p, kap_b + x, dT)
            df = -k_b - self.hardening_modulus(lay, p, kap_b + x, dT)
            lo = np.where(act & (f > 0), x, lo)
            hi = np.where(act & (f <= 0), x, hi)
            new = x - f / np.where(df < 0, df, -1.0)
            bad = ~np.isfinite(new) | (new <= lo) | (new >= hi) | (df >= 0)
            new = np.where(bad, 0.5 * (lo + hi), new)
            new = np.where(act, new, 0.0)
            step = np.abs(new - x)
            x = new
            if np.all(step <= 1e-14 * np.maximum(np.abs(x), 1e-300) + 1e-300):
                return x
        raise ConvergenceError(f"{self.name} layer law: the plastic slip of a contact element "
                               "did not converge in 100 steps")

    # -- the HPT curve at constant normal stress --------------------------------------------
    def hpt_tau(self, u: np.ndarray, sigma: float, lay: LayerParams, dT: float = 0.0
                ) -> np.ndarray:
        """Shear stress [Pa] of the layer against its displacement ``u >= 0`` [m] at the
        constant normal stress ``sigma`` [Pa] (monotone loading; rig compliance not
        included): elastic ``tau = u / L_e`` up to ``tau_c1``, then the law's branch."""
        u = np.asarray(u, dtype=float)
        lay_T = self._at_temperature(lay, dT)
        t1 = float(lay_T.mu_c1 * sigma)
        if lay.L_mue <= 0:
            u_y = 0.0
            elastic = np.where(u > 0, t1, 0.0)
        else:
            le = lay.L_mue / sigma
            u_y = t1 * le
            elastic = u / le
        plastic = self.hpt_plastic(np.maximum(u - u_y, 0.0), sigma, lay_T)
        return np.where(u <= u_y, elastic, plastic)

    def _at_temperature(self, lay: LayerParams, dT: float) -> LayerParams:
        """The layer with its temperature coefficients applied at ``dT`` (and zeroed)."""
        if not dT or not any(self.temperature_coefficients(lay)):
            return lay
        upd: dict[str, float] = {}
        for p in self.params:
            if p.temperature_of is not None:
                coef = getattr(lay, p.name)
                upd[p.temperature_of] = getattr(lay, p.temperature_of) * math.exp(coef * dT)
                upd[p.name] = 0.0
        return lay.replace(**upd)

    def hpt_start(self, t1: float, t2: float, uy: float, ul: np.ndarray, tau: np.ndarray,
                  sigma: float) -> dict[str, float]:
        """Start values of the law's own parameters (those after ``mu_c1``, ``L_mue``) for
        an HPT fit, from the data: the elastic limit ``t1`` [Pa], the final stress ``t2``
        [Pa], the yield displacement ``uy`` [m] and the curve ``(ul, tau)`` (layer
        displacement, stress)."""
        return {}

    def traction_start(self, mu1: float, mu2: float, lme: float) -> dict[str, float]:
        """Start of a traction-curve fit from the curve's knee ``mu1``, plateau ``mu2`` and
        the layer length ``lme`` [m] its initial slope suggests."""
        return {"mu_c1": mu1, "L_mue": lme}

    def elastic_probe(self) -> dict[str, float]:
        """Values that keep the layer elastic (a limit far above any stress, no layer
        flexibility): the traction fit's probe of Kalker's initial slope."""
        return {"mu_c1": 10.0, "L_mue": 0.0}

    def traction_warnings(self, res: Any) -> list[str]:
        """Law-specific warnings of a traction-curve fit."""
        return []

    def fit_warnings(self, res: Any, ends: list[float]) -> tuple[list[str], set[str]]:
        """Law-specific warnings of an HPT fit: ``(warnings, names not to warn about
        again)``; ``ends`` is each curve's last layer displacement [m]."""
        return [], set()
