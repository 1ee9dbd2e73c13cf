"""Creep forces in longitudinal creepage, lateral creepage and spin: FASTSIM with the layer.

Vehicle-dynamics codes take a creep-force law in the longitudinal creepage
``xi``, the lateral creepage ``eta`` and the spin ``phi`` [1/m].  This module
extends the longitudinal boundary model of :mod:`torlab.model.fastsim` (thesis
5.2.2, Eqs. 5.14-5.30; model-notes section 3) to all three, keeping the
third-body layer and the contact temperature.

The model
---------
Elliptical Hertz contact, semi-axes ``a`` (rolling direction) and ``b``; a strip
at lateral position ``y`` has half-length ``a(y) = a sqrt(1 - y^2/b^2)``; a
particle enters at the leading edge ``x = a(y)`` with zero traction and travels
the distance ``X = a(y) - x``.  The rigid slip (per unit rolling distance) is
``w = (xi - phi y, eta + phi x)``.  Signs: the traction is the one the creepage
drives, positive for positive creepage (torlab's ``mu``); Kalker's and CONTACT's
forces are these with the sign reversed.

* Elastic (stick): Kalker's simplified theory with three flexibilities
  (Kalker 1982, Vehicle System Dynamics 11) and the layer's flexibility
  ``L_mue/p`` (Eq. 5.28) in series with each of them::

      d tau_x/dX = xi/(L1 + Le) - phi y/(L3 + Le)
      d tau_y/dX = eta/(L2 + Le) + phi x/(L3 + Le),     Le = L_mue / p

  ``L1 = 8a/(3 C11 G)``, ``L2 = 8a/(3 C22 G)``, ``L3 = pi a sqrt(a/b)/(4 C23 G)``
  (:mod:`torlab.model.kalker`).  In the angle ``theta`` with
  ``X = a(y)(1 - cos theta)``, ``p = P(y) sin theta`` the stick traction has a
  closed form: ``tau_x = (xi a(y)/L1) e(theta; r1) - (phi y a(y)/L3) e(theta; r3)``,
  ``tau_y = (eta a(y)/L2) e(theta; r2) + (phi a(y)^2/L3) G(sin theta; r3)`` with
  ``e = integral sin^2/(sin + r)``, ``G(s) = integral_0^s x^2/(x + r) dx`` and
  ``r_i = L_mue/(L_i P(y))``.
* The particle yields where ``|tau|`` first reaches ``tau_c1 = mu_c1 p f1(T)``
  (Eq. 5.26).  From then on its traction has the magnitude of the Voce limit
  (Eq. 5.24 as the notes read it, 5.27)::

      g = tau_c1 + (tau_c2 - tau_c1) (1 - exp(-kappa / L_mup)),
      kappa = max(S(X) - tau_c1 (L_K + Le), 0),   S(X) = integral_0^X |w| dX'

  ``S`` is the accumulated rigid slip (path length) and ``tau_c1 (L_K + Le)``
  the elastic displacement at the limit, with Kalker's (1982) weighted
  flexibility ``L_K = (|xi| L1 + |eta| L2 + c |phi| L3)/sqrt(xi^2 + eta^2 + c^2 phi^2)``,
  ``c = sqrt(ab)``.  With ``eta = phi = 0`` this is exactly the longitudinal
  ``kappa = xi X - tau_c1 L`` of :mod:`torlab.model.fastsim`.
* Its direction is FASTSIM's: the direction of the trial traction (the traction
  plus the elastic increment), whose continuous limit is
  ``d psi/d theta = (n . T)/g`` with ``T = d tau_el/d theta`` and ``n`` the
  normal to the traction.
* A yielded particle stays on the limit while it is loaded (the thesis: "the
  state stays plastic"); when the rigid slip turns against its traction (spin)
  it unloads elastically and sticks again until its traction reaches the limit
  once more: ``restick="thesis"`` (default).  ``restick="kalker"`` is FASTSIM's
  own rule (stick whenever the trial traction is inside the limit), which is the
  same for a Coulomb contact in pure creepage and is what CONTACT computes.

``Fx = integral tau_x dA``, ``Fy = integral tau_y dA``,
``Mz = integral (x tau_y - y tau_x) dA``.  With ``eta = phi = 0`` the model is the
longitudinal one of :func:`torlab.model.fastsim.boundary_traction`.

The numerical scheme
--------------------
* Strips: ``y = b sin(phi_s)``.  Without spin the Gauss nodes of each half contact
  (``n`` per half, mirrored: the longitudinal model's strips); with spin 8 equal
  panels in ``phi_s`` with 4 Gauss strips each, because spin makes the strip forces
  kink across the contact, which low-order panels integrate better.
* First yield: a table of ``|tau_el| - tau_c1`` at 64 angles per strip brackets
  the first crossing (spin can make ``|tau_el|/tau_c1`` non-monotone); a safeguarded
  Newton iteration from the regula-falsi point (bisection whenever a step leaves the
  bracket) converges to 1e-13 rad.  The end of the clamped zone (``kappa`` turning
  positive) is found the same way.
* Elastic zone ``[0, theta_y]``: by parts, its forces need ``T = d tau_el/d theta``
  (explicit) at Gauss nodes only (8 panels of ``m`` nodes) and the stick traction at
  the yield point: ``integral tau_el sin = tau_el(theta_y)(1 - cos theta_y) -
  integral T (1 - cos)``, likewise with ``sin cos`` and ``sin^2/2`` for the moment.
* Plastic zone: a clamp panel, 6 panels graded with the Voce length ``L_mup/|w|`` from
  the clamp end (as in the longitudinal scheme) and 16 uniform panels, ``m`` Gauss
  nodes each (``m = 4``, a scene's ``grid: m``).  The stick traction and the slip path
  ``S`` at the nodes are integrated panel by panel from ``T`` and ``|w|`` (explicit),
  with each panel's integration matrix through its ends and Gauss nodes.
* The traction along the plastic zone follows FASTSIM's rules node by node.  The
  magnitude is the explicit limit ``g``.  The direction over a step is the
  exact solution of ``d chi/d theta = -(k sin chi + beta')`` (``chi`` the angle
  between the traction and ``T``, ``k = |T|/g`` averaged over the step,
  ``beta'`` the turning rate of ``T`` over the step), a Riccati equation whose
  solution over a step is a Moebius map of ``u = tan(chi/2)``, a 2x2 matrix: second
  order, and exact in the stiff limit where the traction trails the slip direction
  by ``beta'/k``.  Stick and slip switch at the nodes (FASTSIM's test on the trial
  traction ``tau + Delta tau_el``, the increment exact).
* The march is not a loop over nodes with the stick/slip logic in it
  (:func:`_march_lanes`): every strip is first taken to slip from its yield point to
  the trailing edge -- its directions are products of the step matrices, a
  log-depth prefix product for a few strips, a loop of six array operations per node
  for many -- and the unloading test is applied at all nodes at once.  Strips where a
  particle unloads (spin) go on from the first node that fails it: a stick segment is
  the stick traction shifted by a constant, the next slip segment another product;
  there are as many such rounds as stick/slip switches on a strip (two or three).
  The result is the node-by-node march's, to round-off.
* Points: each distinct triple up to the symmetries (``(-xi, eta, phi)`` reverses
  ``Fx``, ``(xi, -eta, -phi)`` reverses ``Fy`` and ``Mz``; :func:`canonical_creepages`)
  is solved once; points with spin and without are solved apart, each group on its own
  strips, in chunks of about 512 strips (larger arrays spend their time faulting in
  fresh memory).  A point's numbers do not depend on the other points of the call.
* Temperature: as in :mod:`torlab.model.fastsim` (flash temperature on 48
  uniform angles per strip, heat flux ``|tau| |w| v`` with the rigid slip
  ``w``, or zero in stick with ``slip_velocity: local``; an adaptively
  under-relaxed fixed point per point to ``thermal.tolerance``, a point leaving the
  iteration when it has converged, or :class:`~torlab.errors.ConvergenceError`
  naming the point).

:func:`torlab.model.reference_solvers.creep_forces_reference` integrates the same model
without a grid (an ODE per strip with event location, adaptive quadrature across the
strips) for tests and the benchmark.

References
----------
.. [1] Kalker, J. J. (1982). A fast algorithm for the simplified theory of rolling
   contact. Vehicle System Dynamics 11(1), 1-13. https://doi.org/10.1080/00423118208968684
.. [2] Kalker, J. J. (1990). Three-Dimensional Elastic Bodies in Rolling Contact. Solid
   Mechanics and its Applications 2, Kluwer, Dordrecht.
   https://doi.org/10.1007/978-94-015-7889-9
.. [3] Kvarda, D., Galas, R., Omasta, M., Dzimko, M., Krupka, I., Hartl, M. (2022). Shear
   properties of top-of-rail products in numerical modelling. Proceedings of the
   Institution of Mechanical Engineers, Part F: Journal of Rail and Rapid Transit.
   https://doi.org/10.1177/09544097221138374
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cache, lru_cache
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from torlab.errors import NumericalError, TorlabInputError
from torlab.model.fastsim import FastsimProblem
from torlab.model.flash import ThermalParams, converge_flash_temperature, flash_temperature_matrix
from torlab.model.layers import LayerParams
from torlab.model.strip import G_strip, e_strip, gauss_legendre, interp_uniform

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = [
    "CreepGrid",
    "CreepProblem",
    "CreepResult",
    "canonical_creepages",
    "creep_forces",
    "creep_problem",
    "kalker_weighted_flexibility",
    "predict_creep",
]

Restick = Literal["thesis", "kalker"]
Bound = Literal["elliptic", "parabolic"]


# -------------------------------------------------------------------------------------------
# problem definition
# -------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CreepGrid:
    """Resolution of the creep-force scheme.

    Attributes
    ----------
    n
        Gauss strips per half contact (``2 n`` strips) without spin: the longitudinal
        scheme's strips (a scene's ``grid: n``).
    spin_panels, spin_strips
        With spin: equal panels in ``phi`` (``y = b sin phi``) over the contact and
        Gauss strips per panel.  Spin makes the strip forces kink across the
        contact (where the stick/slip pattern of the strips changes), which
        low-order panels integrate better than one high-order rule.
    m
        Gauss nodes per panel along a strip (a scene's ``grid: m``, default 4 as in the
        longitudinal scheme).
    elastic_panels, clamp_panels, graded_panels, uniform_panels
        Panels of the elastic zone, the clamped zone, the Voce-graded start of
        the plastic zone and the rest of it.
    yield_table
        Angles per strip of the table that brackets the first yield.
    temperature_nodes
        Nodes per strip of the temperature grid (a scene's ``grid: temperature_nodes``).
    """

    n: int = 6
    spin_panels: int = 8
    spin_strips: int = 4
    m: int = 4
    elastic_panels: int = 8
    clamp_panels: int = 1
    graded_panels: int = 6
    uniform_panels: int = 16
    yield_table: int = 64
    temperature_nodes: int = 48


@dataclass(frozen=True)
class CreepProblem:
    """Everything the creep-force model needs, SI units.

    Attributes
    ----------
    a, b
        Semi-axes [m], ``a`` in the rolling direction.
    p0
        Maximum Hertz pressure [Pa].
    L1, L2, L3
        Kalker's flexibilities [m/Pa] for longitudinal, lateral creepage and
        spin; ``L2``/``L3`` may be None when the contact's shape and elastic
        constants are unknown: then only the creepages they do not need can
        be computed.
    layer
        Third-body layer parameters.
    speed
        Rolling speed [m/s], needed with ``thermal``.
    ambient_temperature
        ``T_A`` [degC].
    thermal
        Flash-temperature model, or None.
    traction_bound
        ``elliptic`` (Hertz pressure, the thesis) or ``parabolic`` (Kalker's
        FASTSIM bound ``p = 2N/(pi a b)(1 - x^2/a^2 - y^2/b^2)``, for comparisons
        with FASTSIM codes; only without layer flexibility, ``L_mue = 0``).
    restick
        ``thesis`` (a yielded particle stays on the limit while loaded) or
        ``kalker`` (FASTSIM's rule); see the module docstring.
    calibrated
        Correct the forces by Kalker's exact theory (:mod:`torlab.model.calibrated`,
        the ``fastsim`` boundary method, a scene's default; elliptic bound only); False:
        Kalker's FASTSIM (``fastsim-kalker``).
    """

    a: float
    b: float
    p0: float
    L1: float
    layer: LayerParams
    L2: float | None = None
    L3: float | None = None
    speed: float = 1.0
    ambient_temperature: float = 20.0
    thermal: ThermalParams | None = None
    traction_bound: Bound = "elliptic"
    restick: Restick = "thesis"
    calibrated: bool = False

    @property
    def load(self) -> float:
        """Normal load ``2 pi a b p0 / 3`` [N]."""
        return 2.0 * math.pi * self.a * self.b * self.p0 / 3.0

    @classmethod
    def from_fastsim(cls, prob: FastsimProblem, *, L2: float | None = None,
                     L3: float | None = None, **kw: Any) -> CreepProblem:
        """The creep problem of a longitudinal :class:`FastsimProblem` plus ``L2``, ``L3``."""
        return cls(a=prob.a, b=prob.b, p0=prob.p0, L1=prob.L1, L2=L2, L3=L3, layer=prob.layer,
                   speed=prob.speed, ambient_temperature=prob.ambient_temperature,
                   thermal=prob.thermal, **{"calibrated": prob.calibrated, **kw})


@dataclass
class CreepResult:
    """Creep forces over a set of creepage triples (arrays of the broadcast input shape).

    Attributes
    ----------
    creepage, lateral, spin
        The creepages as given (fractions; spin in 1/m).
    Fx, Fy
        Tangential forces [N], positive along positive creepage.
    Mz
        Spin moment about the contact centre [N m].
    mu_x, mu_y
        ``Fx/N``, ``Fy/N``.
    adhesion_fraction
        Fraction of the load carried in stick.
    max_temperature_C, temperature_iterations, temperature_loop
        As in :class:`~torlab.model.fastsim.BoundaryResult`.
    load
        Normal load N [N].
    notes
        Messages for the user.
    """

    creepage: np.ndarray
    lateral: np.ndarray
    spin: np.ndarray
    Fx: np.ndarray
    Fy: np.ndarray
    Mz: np.ndarray
    mu_x: np.ndarray
    mu_y: np.ndarray
    adhesion_fraction: np.ndarray
    load: float
    max_temperature_C: np.ndarray | None = None
    temperature_iterations: np.ndarray | None = None
    temperature_loop: str = "off"
    notes: list[str] = field(default_factory=list)

    def table(self) -> Any:
        """Long DataFrame: ``creepage, lateral, spin_1_m, Fx_N, Fy_N, Mz_Nm, mu_x, mu_y, ...``."""
        import pandas as pd

        d = {"creepage": self.creepage.ravel(), "lateral": self.lateral.ravel(),
             "spin_1_m": self.spin.ravel(), "Fx_N": self.Fx.ravel(), "Fy_N": self.Fy.ravel(),
             "Mz_Nm": self.Mz.ravel(), "mu_x": self.mu_x.ravel(), "mu_y": self.mu_y.ravel(),
             "adhesion_fraction": self.adhesion_fraction.ravel()}
        if self.max_temperature_C is not None:
            d["max_temperature_C"] = self.max_temperature_C.ravel()
        return pd.DataFrame(d)


def kalker_weighted_flexibility(prob: CreepProblem, xi: Any, eta: Any, phi: Any) -> np.ndarray:
    """Kalker's (1982) single weighted flexibility ``(|xi| L1 + |eta| L2 + c|phi| L3)/|v|``.

    ``|v| = sqrt(xi^2 + eta^2 + c^2 phi^2)``, ``c = sqrt(ab)``; ``L1`` where all
    creepages vanish.  Used for the elastic displacement at the limit in the Voce
    slip ``kappa``.
    """
    xi, eta, phi = (np.asarray(v, dtype=float) for v in (xi, eta, phi))
    c = math.sqrt(prob.a * prob.b)
    L2 = prob.L2 if prob.L2 is not None else prob.L1
    L3 = prob.L3 if prob.L3 is not None else prob.L1
    num = np.abs(xi) * prob.L1 + np.abs(eta) * L2 + c * np.abs(phi) * L3
    den = np.sqrt(xi * xi + eta * eta + (c * phi) ** 2)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), prob.L1)


def creep_problem(scene: Scene, contact: Any = None) -> CreepProblem:
    """The :class:`CreepProblem` of a (dry) scene: Hertz patch, C11, C22, C23, layer, thermal.

    Raises
    ------
    TorlabInputError
        The scene has no ``boundary:`` section or is lubricated (the creep-force
        model is the dry/third-body boundary model; a film's contribution is not
        modelled in three creepages).
    """
    import warnings

    from torlab.model.calibrated import coefficient_interpolation
    from torlab.model.contact import build_contact
    from torlab.model.kalker import C22, C23, L2, L3, ExtremeContactWarning
    from torlab.model.prediction import fastsim_problem

    if scene.boundary is None:
        raise TorlabInputError("creep forces need a boundary: section (the third-body layer)",
                               key="boundary")
    if scene.lubricant is not None:
        raise TorlabInputError("creep forces in lateral creepage and spin are modelled for dry "
                               "(third-body layer) scenes only: remove the lubricant: section or "
                               "use 'torlab predict traction' for the longitudinal mixed model",
                               key="lubricant")
    contact = contact or build_contact(scene)
    prob = fastsim_problem(scene, contact)
    p = contact.patch
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtremeContactWarning)  # build_contact noted it
        how = coefficient_interpolation(scene.grid.method)
        c22 = C22(p.a / p.b, contact.nu, interpolation=how)
        c23 = C23(p.a / p.b, contact.nu, interpolation=how)
    return CreepProblem.from_fastsim(prob, L2=L2(p.a, c22, contact.G), L3=L3(p.a, p.b, c23, contact.G))


def scene_grid(scene: Scene) -> CreepGrid:
    """The creep-force grid of a scene's ``grid:`` section.

    The keys mean what they mean for the longitudinal scheme and carry over: ``n``
    (Gauss strips per half contact, the strips of a point without spin), ``m`` (Gauss
    nodes per panel along a strip) and ``temperature_nodes``.  The panel counts along a
    strip and the strips of a point with spin are the creep scheme's own
    (:class:`CreepGrid`): the scene contract has no keys for them.
    """
    g = scene.grid
    return CreepGrid(n=g.n, m=g.m, temperature_nodes=g.temperature_nodes)


def predict_creep(scene: Scene, creepage: Any, lateral: float = 0.0, spin: float = 0.0) -> Any:
    """Creep forces of a dry scene along a creepage curve at a lateral creepage and a spin.

    Parameters
    ----------
    scene
        A validated dry :class:`~torlab.scene.Scene` (``boundary:``, no ``lubricant:``).
    creepage
        Longitudinal creepages (fractions).
    lateral, spin
        Lateral creepage (fraction) and spin [1/m], the same for every point.

    Returns
    -------
    torlab.model.predict.TractionPrediction
        ``table`` with the scene contract's ``creepage`` and ``mu`` (= ``mu_x``) and
        ``lateral, spin_1_m, mu_x, mu_y, Fx_N, Fy_N, Mz_Nm, adhesion_fraction``
        (``max_temperature_C`` with ``thermal:``).
    """
    from torlab.model.contact import build_contact
    from torlab.model.prediction import TractionPrediction, scene_trend

    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    contact = build_contact(scene)
    prob = creep_problem(scene, contact)
    r = creep_forces(prob, xi, lateral, spin, scene_grid(scene))
    table = r.table()
    table.insert(1, "mu", r.mu_x)
    loop = {"off": "contact temperature: not modelled (no thermal: section)",
            "single pass": "contact temperature: computed once, no tau-T loop",
            "iterated": "contact temperature: coupled to the limits, iterated to convergence"}
    modelled = [f"Hertz contact ({contact.patch.method})",
                "boundary friction: FASTSIM with the third-body layer in longitudinal creepage, "
                "lateral creepage and spin (Kalker's three flexibilities; "
                f"{prob.layer.law.limit_text})",
                "EHL film: not modelled (dry scene, no lubricant:)",
                loop[r.temperature_loop]]
    trend = scene_trend(scene, xi, r.mu_x)
    from torlab import __version__

    summary = {"torlab_version": __version__, "scene": scene.name, "contact": contact.summary(),
               "modelled": modelled, "notes": list(contact.notes),
               "lateral": float(lateral), "spin_1_m": float(spin),
               "flexibilities_m_Pa": {"L1": prob.L1, "L2": prob.L2, "L3": prob.L3},
               "mu_max": float(np.max(np.hypot(r.mu_x, r.mu_y))),
               "trend_after_saturation": trend, "boundary": scene.boundary.model_dump()}
    return TractionPrediction(table=table, contact=contact, modelled=modelled, trend=trend,
                              summary=summary)


@cache
def _gauss_integration(n: int) -> np.ndarray:
    """Integration matrix of a panel from its start to its ``n`` Gauss nodes.

    ``S[k, :] @ [f(0), f(x_1) ... f(x_n), f(1)]`` integrates the interpolant of ``f``
    through the panel's two ends and its Gauss nodes from 0 to ``x_k`` (order ``n + 2``).
    """
    x, _ = gauss_legendre(n)
    pts = np.concatenate([[0.0], x, [1.0]])
    k = pts.size
    coef = np.linalg.inv(np.vander(pts, k, increasing=True))  # l_j(x) = sum_i coef[i, j] x^i
    powers = np.arange(1, k + 1)
    P = x[:, None] ** powers[None, :] / powers[None, :]  # integral_0^{x_k} x^i dx
    return P @ coef


@cache
def _panel_strips(panels: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Strips of ``panels`` equal panels in ``phi`` over (-pi/2, pi/2), ``n`` Gauss nodes each."""
    x, w = gauss_legendre(n)
    edges = np.linspace(-0.5 * math.pi, 0.5 * math.pi, panels + 1)
    h = np.diff(edges)
    ph = (edges[:-1, None] + h[:, None] * x[None, :]).ravel()
    ww = (h[:, None] * w[None, :]).ravel()
    return np.sin(ph), np.cos(ph), ww


@cache
def _strips(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``sin phi``, ``cos phi`` and weights of the strips over the whole contact (``y = b sin phi``).

    The Gauss rule of each half, mirrored: with ``eta = phi = 0`` the two halves
    give the same strips, so the longitudinal model is reproduced node for node.
    """
    x, w = gauss_legendre(n)
    ph = 0.5 * math.pi * x
    ph = np.concatenate([-ph[::-1], ph])
    ww = np.concatenate([w[::-1], w]) * 0.5 * math.pi
    return np.sin(ph), np.cos(ph), ww


def _e(theta: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``e(theta; r)`` (:func:`torlab.model.strip.e_strip`); ``1 - cos`` when ``r = 0``."""
    if not np.any(r):
        return 2.0 * np.sin(0.5 * np.asarray(theta, dtype=float)) ** 2 + 0.0 * r
    return e_strip(theta, r)


# -------------------------------------------------------------------------------------------
# the solver
# -------------------------------------------------------------------------------------------
@lru_cache(maxsize=16)
def _tables(prob: CreepProblem, grid: CreepGrid, spin: bool, lateral: bool
            ) -> tuple[np.ndarray, tuple[np.ndarray, ...], np.ndarray, tuple[np.ndarray, ...]]:
    """Closed forms ``e(theta; r1..3)``, ``G(sin theta; r3)`` at the yield table's and the
    temperature grid's angles, per strip: they depend on the problem only, not the creepages."""
    ln = _Lanes(prob, grid, np.zeros(1), np.full(1, float(lateral)), np.full(1, float(spin)))
    tab = np.linspace(0.0, math.pi, grid.yield_table + 1)[1:]
    thT, _ = flash_temperature_matrix(grid.temperature_nodes)
    shape = ln.Pj[..., None].shape
    ex_tab = ln._ex(np.broadcast_to(tab, shape[:-1] + tab.shape))
    ex_T = ln._ex(np.broadcast_to(thT, shape[:-1] + thT.shape))
    return tab, ex_tab, thT, ex_T


class _Lanes:
    """Per (case, strip) constants; arrays (nc, ns) and closed forms at angles (nc, ns, k)."""

    def __init__(self, prob: CreepProblem, grid: CreepGrid, xi: np.ndarray, eta: np.ndarray,
                 phi: np.ndarray) -> None:
        self.prob, self.grid = prob, grid
        lay = prob.layer
        self.spin = bool(np.any(phi != 0))
        self.lateral = bool(np.any(eta != 0))
        if self.spin:
            sphi, cphi, wy = _panel_strips(grid.spin_panels, grid.spin_strips)
        else:
            sphi, cphi, wy = _strips(grid.n)
        self.wy = wy
        self.cphi = cphi[None, :]
        self.y = prob.b * sphi[None, :]
        self.aj = prob.a * self.cphi
        parabolic = prob.traction_bound == "parabolic"
        self.parabolic = parabolic
        if parabolic:
            self.Pj = (4.0 / 3.0) * prob.p0 * self.cphi**2  # 2N/(pi a b) (1 - y^2/b^2)
        else:
            self.Pj = prob.p0 * self.cphi
        self.xi, self.eta, self.phi = xi[:, None], eta[:, None], phi[:, None]
        L1 = prob.L1
        L2 = prob.L2 if prob.L2 is not None else L1
        L3 = prob.L3 if prob.L3 is not None else L1
        self.L = (L1, L2, L3)
        zero = np.zeros_like(self.Pj)
        self.has_layer = lay.L_mue > 0
        if lay.L_mue > 0:
            self.r = tuple(lay.L_mue / (Li * self.Pj) for Li in self.L)
        else:
            self.r = (zero, zero, zero)
        aj = self.aj
        self.Ax1 = self.xi * aj / L1
        self.Ax3 = -self.phi * self.y * aj / L3
        self.Ay2 = self.eta * aj / L2
        self.Ay3 = self.phi * aj * aj / L3
        self.wx = self.xi - self.phi * self.y
        self.LK = kalker_weighted_flexibility(prob, xi, eta, phi)[:, None]

    # -- closed forms ---------------------------------------------------------------------
    def _ex(self, theta: np.ndarray, cache: dict | None = None) -> tuple[np.ndarray, ...]:
        """``e(theta; r1), e(theta; r2), e(theta; r3), G(sin theta; r3)`` broadcast with theta."""
        r1, r2, r3 = (r[..., None] if theta.ndim == 3 else r for r in self.r)
        e1 = _e(theta, r1)
        e2 = e1 if r2 is r1 or (self.L[1] == self.L[0]) or not self.lateral else _e(theta, r2)
        e3 = e1 if (self.L[2] == self.L[0]) or not self.spin else _e(theta, r3)
        G3 = G_strip(np.sin(theta), r3) if self.spin else 0.0 * e1
        return e1, e2, e3, G3

    def _coef(self, ndim: int) -> tuple[np.ndarray, ...]:
        if ndim == 3:
            return (self.Ax1[..., None], self.Ax3[..., None], self.Ay2[..., None],
                    self.Ay3[..., None])
        return self.Ax1, self.Ax3, self.Ay2, self.Ay3

    def tau_el(self, theta: np.ndarray, ex: tuple[np.ndarray, ...] | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        """Stick traction ``(tau_x, tau_y)`` at angles ``theta`` from the leading edge."""
        e1, e2, e3, G3 = ex if ex is not None else self._ex(theta)
        Ax1, Ax3, Ay2, Ay3 = self._coef(np.ndim(theta) if np.ndim(theta) == 3 else 2)
        tx = Ax1 * e1 + Ax3 * e3
        ty = Ay2 * e2 + Ay3 * G3
        return tx, ty

    def T(self, theta: np.ndarray, st: np.ndarray | None = None, ct: np.ndarray | None = None
          ) -> tuple[np.ndarray, np.ndarray]:
        """``d tau_el / d theta`` at angles of shape (nc, ns, ...) (sin, cos if known)."""
        extra = (None,) * (np.ndim(theta) - 2)
        r1, r2, r3 = (r[(..., *extra)] for r in self.r)
        st = np.sin(theta) if st is None else st
        layer = self.has_layer
        st2 = st * st if layer else None
        q1 = st2 / (st + r1) if layer else st
        q2 = q1 if (self.L[1] == self.L[0]) or not self.lateral or not layer else st2 / (st + r2)
        q3 = q1 if (self.L[2] == self.L[0]) or not self.spin or not layer else st2 / (st + r3)
        Ax1, Ax3, Ay2, Ay3 = (c[(..., *extra)] for c in (self.Ax1, self.Ax3, self.Ay2, self.Ay3))
        tx = Ax1 * q1 if not self.spin else Ax1 * q1 + Ax3 * q3
        if self.spin:
            ty = Ay2 * q2 + Ay3 * (np.cos(theta) if ct is None else ct) * q3
        else:
            ty = Ay2 * q2
        return tx, ty

    def pressure(self, theta: np.ndarray, st: np.ndarray | None = None) -> np.ndarray:
        P = self.Pj[(..., *(None,) * (np.ndim(theta) - 2))]
        st = np.sin(theta) if st is None else st
        return P * (st * st if self.parabolic else st)

    def dpressure(self, theta: np.ndarray, st: np.ndarray | None = None,
                  ct: np.ndarray | None = None) -> np.ndarray:
        P = self.Pj[..., None] if np.ndim(theta) == 3 else self.Pj
        ct = np.cos(theta) if ct is None else ct
        if not self.parabolic:
            return P * ct
        return P * 2.0 * (np.sin(theta) if st is None else st) * ct

    def slip_path(self, theta: np.ndarray, ct: np.ndarray | None = None) -> np.ndarray:
        """``S = integral_0^X |w| dX'``, the accumulated rigid slip (closed form; cos theta
        if known)."""
        ex3 = np.ndim(theta) == 3
        aj = self.aj[..., None] if ex3 else self.aj
        wx = np.abs(self.wx[..., None] if ex3 else self.wx)
        eta = self.eta[..., None] if ex3 else self.eta
        phi = self.phi[..., None] if ex3 else self.phi
        X = aj * (1.0 - (np.cos(theta) if ct is None else ct))
        x1 = aj - X
        z0 = eta + phi * aj
        z1 = eta + phi * x1
        zm = eta + phi * (aj - 0.5 * X)

        wx2 = wx * wx

        def absw(z):
            return np.sqrt(wx2 + z * z)

        simpson = X / 6.0 * (absw(z0) + 4.0 * absw(zm) + absw(z1))
        if not self.spin:
            return simpson
        small = np.abs(phi) * X <= 1e-4 * (wx + np.abs(zm))
        if small.all():
            return simpson
        pos = wx > 0
        wxs = np.where(pos, wx, 1.0)

        def H(z):  # antiderivative of sqrt(wx^2 + z^2)
            return 0.5 * (z * absw(z) + np.where(pos, wx2 * np.arcsinh(z / wxs), 0.0))

        closed = (H(z0) - H(z1)) / np.where(phi != 0, phi, 1.0)
        return np.where(small, simpson, closed)

    def rigid_slip(self, theta: np.ndarray, ct: np.ndarray | None = None) -> np.ndarray:
        """``|w|`` at angles ``theta`` of shape (nc, ns, ...) (cos theta if known)."""
        ex = (..., *(None,) * (np.ndim(theta) - 2))
        ct = np.cos(theta) if ct is None else ct
        wy = self.eta[ex] + self.phi[ex] * self.aj[ex] * ct
        wx = self.wx[ex]
        return np.sqrt(wx * wx + wy * wy)

    def limits(self, theta: np.ndarray, dT: np.ndarray | float, S: np.ndarray | None = None,
               st: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(tau_c1, g)``: the elastic limit and the layer law's limit at angles ``theta``.

        ``S`` is the accumulated rigid slip there (closed form when not given).
        """
        lay = self.prob.layer
        p = self.pressure(theta, st)
        f1 = lay.law.f1(lay, dT)
        t1 = lay.mu_c1 * p * f1
        LK = self.LK[(..., *(None,) * (np.ndim(theta) - 2))]
        S = self.slip_path(theta) if S is None else S
        return t1, lay.law.strip_plastic(lay, p, S, LK * p + lay.L_mue, dT)

    def kappa(self, theta: np.ndarray, dT: np.ndarray | float, st: np.ndarray | None = None,
              ct: np.ndarray | None = None) -> np.ndarray:
        """The Voce slip before the clamp, ``S - tau_c1 (L_K + Le)`` (sin, cos theta if known)."""
        lay = self.prob.layer
        p = self.pressure(theta, st)
        f1 = np.exp(lay.mu_c1_T * dT) if lay.mu_c1_T else 1.0
        LK = self.LK[..., None] if np.ndim(theta) == 3 else self.LK
        return self.slip_path(theta, ct) - lay.mu_c1 * f1 * (LK * p + lay.L_mue)


def _pick(a: np.ndarray, k: np.ndarray) -> np.ndarray:
    """``a[..., k]`` per lane: ``a`` (..., K), ``k`` (...) integer."""
    K = a.shape[-1]
    return a.reshape(-1, K)[np.arange(k.size), k.ravel()].reshape(k.shape)


def _first_root(f_table: np.ndarray, grid: np.ndarray, start: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bracket of the first sign change (- to +) of tabulated ``f`` after ``start``.

    ``f_table`` (nc, ns, K) at ``grid`` (K,) angles in (0, pi].  Returns
    ``(lo, hi, found)``; ``found`` False where ``f`` stays negative.
    """
    after = grid[None, None, :] > start[..., None]
    pos = (f_table >= 0) & after
    found = pos.any(axis=-1)
    k = np.argmax(pos, axis=-1)
    edges = np.r_[0.0, grid]
    lo = np.maximum(edges[k], start)
    hi = edges[k + 1]
    return lo, hi, found


def _newton_bracketed(f_and_df, lo: np.ndarray, hi: np.ndarray, found: np.ndarray,
                      iters: int = 60, start: np.ndarray | None = None) -> np.ndarray:
    """Safeguarded Newton on brackets ``[lo, hi]`` with ``f(lo) < 0 <= f(hi)``.

    Lanes without a bracket (``found`` False) are returned as ``hi``.  A step that
    leaves the bracket is replaced by bisection; the iteration stops when every
    step is below 1e-13 rad.  ``start`` (inside the bracket) defaults to its middle.
    """
    lo = np.where(found, lo, hi)
    th = 0.5 * (lo + hi) if start is None else np.clip(start, lo, hi)
    for _ in range(iters):
        f, df = f_and_df(th)
        neg = f < 0
        lo = np.where(neg, th, lo)
        hi = np.where(neg, hi, th)
        new = th - f / np.where(df != 0, df, np.nan)  # NaN (no step) where df = 0
        bad = ~np.isfinite(new) | (new < lo) | (new > hi)
        new = np.where(bad, 0.5 * (lo + hi), new)
        new = np.where(found, new, hi)
        step = np.abs(new - th).max(initial=0.0)
        th = new
        if step <= 1e-13:
            break
    return th


@dataclass
class _Solution:
    Fx: np.ndarray
    Fy: np.ndarray
    Mz: np.ndarray
    stick: np.ndarray
    th_y: np.ndarray
    nodes: np.ndarray | None = None  # plastic nodes (nc, ns, M)
    rho: np.ndarray | None = None  # |tau|/g at the nodes
    plastic: np.ndarray | None = None


class _Solver:
    def __init__(self, prob: CreepProblem, grid: CreepGrid, xi: np.ndarray, eta: np.ndarray,
                 phi: np.ndarray) -> None:
        self.prob, self.grid = prob, grid
        self.ln = _Lanes(prob, grid, xi, eta, phi)
        self.tab, self._tab_ex, self.thetaT, self._T_ex = _tables(prob, grid, self.ln.spin,
                                                                  self.ln.lateral)
        self.tab_st, self.tab_ct = np.sin(self.tab), np.cos(self.tab)

    def subset(self, rows: np.ndarray) -> _Solver:
        """The solver of the points ``rows`` (same strips: the points share spin or not)."""
        ln = self.ln
        return _Solver(self.prob, self.grid, ln.xi[rows, 0], ln.eta[rows, 0], ln.phi[rows, 0])

    # -- first yield -------------------------------------------------------------------------
    def yield_angle(self, dT_grid: np.ndarray | None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """First angle where ``|tau_el|`` reaches ``tau_c1`` (pi where it never does), and the
        stick traction ``(tau_x, tau_y)`` there."""
        ln, lay = self.ln, self.prob.layer
        nc, ns = ln.xi.shape[0], ln.Pj.shape[1]
        if lay.mu_c1 == 0.0:
            return np.zeros((nc, ns)), np.zeros((nc, ns)), np.zeros((nc, ns))
        tab = np.broadcast_to(self.tab, (nc, ns, self.tab.size))
        dTt = 0.0 if dT_grid is None else interp_uniform(tab, dT_grid)
        tx, ty = ln.tau_el(tab, self._tab_ex)
        mu1T = lay.mu_c1_T
        t1 = lay.mu_c1 * ln.pressure(tab, self.tab_st) * (np.exp(mu1T * dTt) if mu1T else 1.0)
        f = np.sqrt(tx * tx + ty * ty) - t1
        lo, hi, found = _first_root(f, self.tab, np.zeros((nc, ns)))
        # the stick traction at the bracket's start, then tau_el(theta) = tau_lo + integral of T
        k = np.argmax((f >= 0), axis=-1)
        km = np.maximum(k - 1, 0)
        tx0 = np.where(k > 0, _pick(tx, km), 0.0)
        ty0 = np.where(k > 0, _pick(ty, km), 0.0)
        lo0 = lo.copy()
        xg, wg = gauss_legendre(6)
        last = {}
        # start: regula falsi between the bracketing table values
        fk = _pick(f, k)
        fkm = np.where(k > 0, _pick(f, km), 0.0)
        ok = (k > 0) & (fk > fkm)
        start = np.where(ok, lo + (hi - lo) * (-fkm) / np.where(ok, fk - fkm, 1.0),
                         0.5 * (lo + hi))

        def fdf(th):
            h = (th - lo0)[..., None]
            pts = np.concatenate([lo0[..., None] + h * xg, th[..., None]], axis=-1)
            sp, cp = np.sin(pts), np.cos(pts)
            Tx, Ty = ln.T(pts, sp, cp)
            txx = tx0 + np.sum(Tx[..., :-1] * wg, axis=-1) * h[..., 0]
            tyy = ty0 + np.sum(Ty[..., :-1] * wg, axis=-1) * h[..., 0]
            last["tau"] = (th, txx, tyy)
            m = np.sqrt(txx * txx + tyy * tyy)
            Tx1, Ty1 = Tx[..., -1], Ty[..., -1]
            dT = 0.0 if dT_grid is None else interp_uniform(th[..., None], dT_grid)[..., 0]
            f1 = np.exp(mu1T * dT) if mu1T else 1.0
            dm = np.where(m > 0, (txx * Tx1 + tyy * Ty1) / np.where(m > 0, m, 1.0), 0.0)
            return (m - lay.mu_c1 * ln.pressure(th, sp[..., -1]) * f1,
                    dm - lay.mu_c1 * ln.dpressure(th, sp[..., -1], cp[..., -1]) * f1)

        th = _newton_bracketed(fdf, lo, hi, found, start=start)
        th = np.where(found, th, math.pi)
        # the stick traction at the last iterate (within 1e-13 rad of the root)
        _, txy, tyy = last["tau"]
        txy = np.where(found, txy, tx[..., -1])
        tyy = np.where(found, tyy, ty[..., -1])
        return th, txy, tyy

    def clamp_end(self, th_y: np.ndarray, dT_grid: np.ndarray | None) -> np.ndarray:
        """First angle after the yield point where the Voce slip ``kappa`` turns positive."""
        ln, lay = self.ln, self.prob.layer
        nc, ns = th_y.shape
        if not lay.law.hardens(lay):
            return th_y  # no hardening: the clamp does not change g
        dTy = 0.0 if dT_grid is None else interp_uniform(th_y[..., None], dT_grid)[..., 0]
        k_y = ln.kappa(th_y, dTy)
        if (k_y >= 0).all():
            return th_y  # every strip yields past the clamp (its leading half)
        tab = np.broadcast_to(self.tab, (nc, ns, self.tab.size))
        dTt = 0.0 if dT_grid is None else interp_uniform(tab, dT_grid)
        kt = ln.kappa(tab, dTt, self.tab_st, self.tab_ct)
        lo, hi, found = _first_root(kt, self.tab, th_y)
        mu1T = lay.mu_c1_T
        # start: regula falsi between kappa at the bracket's ends
        kk = np.argmax((kt >= 0) & (self.tab > th_y[..., None]), axis=-1)
        k_hi = _pick(kt, kk)
        k_lo = np.where(lo <= th_y, k_y, _pick(kt, np.maximum(kk - 1, 0)))
        ok = k_hi > k_lo
        start = np.where(ok, lo + (hi - lo) * (-k_lo) / np.where(ok, k_hi - k_lo, 1.0),
                         0.5 * (lo + hi))

        def fdf(th):
            dT = 0.0 if dT_grid is None else interp_uniform(th[..., None], dT_grid)[..., 0]
            f1 = np.exp(mu1T * dT) if mu1T else 1.0
            st, ct = np.sin(th), np.cos(th)
            k = ln.kappa(th, dT, st, ct)
            dk = (ln.rigid_slip(th, ct) * ln.aj * st
                  - lay.mu_c1 * f1 * ln.LK * ln.dpressure(th, st, ct))
            return k, dk

        lo = np.minimum(lo, hi)
        th = _newton_bracketed(fdf, lo, hi, found & (k_y < 0), iters=40, start=start)
        th = np.where(found, th, math.pi)
        return np.where(k_y >= 0, th_y, np.maximum(th, th_y))

    # -- panels ------------------------------------------------------------------------------
    def plastic_edges(self, th_y: np.ndarray, th_s: np.ndarray) -> np.ndarray:
        """Panel edges of the plastic zone (nc, ns, P+1): clamp, Voce-graded and uniform."""
        g, ln, lay = self.grid, self.ln, self.prob.layer
        aj = ln.aj
        w_s = ln.rigid_slip(th_s)
        Lg = lay.law.grading_length(lay)
        ell = np.where(w_s > 0, Lg / np.where(w_s > 0, w_s, 1.0), 2.0 * aj) \
            if Lg > 0 else np.zeros_like(th_s)
        Xs = aj * (1.0 - np.cos(th_s))
        grades, uni01, cl01 = _edge_fractions(g.graded_panels, g.uniform_panels, g.clamp_panels)
        Xb = np.minimum(Xs[..., None] + ell[..., None] * grades, 2.0 * aj[..., None])
        thb = np.maximum(np.arccos(np.clip(1.0 - Xb / aj[..., None], -1.0, 1.0)), th_s[..., None])
        # uniform panels over the whole plastic zone, refined by the Voce-graded edges near its
        # start (edges beyond pi collapse into empty panels at the trailing edge)
        uni = th_s[..., None] + (math.pi - th_s[..., None]) * uni01
        cl = th_y[..., None] + (th_s - th_y)[..., None] * cl01
        edges = np.concatenate([cl, np.sort(np.concatenate([thb, uni[..., 1:]], axis=-1), axis=-1)],
                               axis=-1)
        return edges

    # -- solution ----------------------------------------------------------------------------
    def solve(self, dT_grid: np.ndarray | None, want_rho: bool = False) -> _Solution:
        """Forces and adhesion per case; ``|tau|/g`` at the plastic nodes with ``want_rho``
        (the temperature loop's heat flux)."""
        ln, g, prob = self.ln, self.grid, self.prob
        th_y, txy, tyy = self.yield_angle(dT_grid)
        th_s = self.clamp_end(th_y, dT_grid)
        aj, y = ln.aj, ln.y
        # elastic zone [0, theta_y], by parts: with tau_el = integral of T and 1 - cos, sin^2/2
        # the antiderivatives of sin, sin cos that vanish at the leading edge,
        #   integral tau_el sin = tau_el(theta_y) (1 - cos theta_y) - integral T (1 - cos),
        #   integral tau_el sin cos = tau_el(theta_y) sin^2(theta_y)/2 - integral T sin^2/2,
        # so the elastic forces need T (explicit, analytic) at Gauss nodes only
        xe, we = _composite_gauss(g.elastic_panels, g.m)
        th = th_y[..., None] * xe
        st, ct = np.sin(th), np.cos(th)
        Tx, Ty = ln.T(th, st, ct)
        wgt = th_y[..., None] * we
        omc = 2.0 * np.sin(0.5 * th) ** 2  # 1 - cos without cancellation
        hs2 = 0.5 * st * st
        sy = np.sin(th_y)
        omcy = 2.0 * np.sin(0.5 * th_y) ** 2
        Fx = aj * (txy * omcy - np.sum(Tx * omc * wgt, axis=-1))
        Fy = aj * (tyy * omcy - np.sum(Ty * omc * wgt, axis=-1))
        Mz = aj * aj * (0.5 * tyy * sy * sy - np.sum(Ty * hs2 * wgt, axis=-1)) - y * Fx
        if ln.parabolic:
            c = np.cos(th_y)
            stick = ln.Pj * aj * (2.0 / 3.0 - c + c**3 / 3.0)
        else:
            stick = ln.Pj * aj * (0.5 * th_y - 0.25 * np.sin(2.0 * th_y))
        # plastic zone
        edges = self.plastic_edges(th_y, th_s)
        # panels empty in every lane (a clamp that does not occur, graded edges beyond the
        # trailing edge) cost march steps for nothing: drop them
        keep = np.any(np.diff(edges, axis=-1) > 0, axis=(0, 1))
        if not keep.all():
            idx = np.concatenate([[0], np.flatnonzero(keep) + 1])
            edges = np.maximum.accumulate(edges[..., idx], axis=-1)
        S_y = ln.slip_path(th_y)
        pl = self.plastic_nodes(edges, txy, tyy, S_y)
        thp = pl["theta"]
        tau_x, tau_y, plastic, gvals = self.march(th_y, txy, tyy, S_y, pl, dT_grid)
        jac = aj[..., None] * pl["st"] * pl["weight"]
        xx = aj[..., None] * pl["ct"]
        Fx = Fx + np.sum(tau_x * jac, axis=-1)
        Fy = Fy + np.sum(tau_y * jac, axis=-1)
        Mz = Mz + np.sum((xx * tau_y - y[..., None] * tau_x) * jac, axis=-1)
        stick = stick + np.sum(np.where(plastic, 0.0, ln.pressure(thp, pl["st"])) * jac, axis=-1)
        wstrip = ln.wy * prob.b * ln.cphi
        rho = None if not want_rho else np.where(
            gvals > 0, np.sqrt(tau_x * tau_x + tau_y * tau_y) / np.where(gvals > 0, gvals, 1.0),
            1.0)
        return _Solution(Fx=np.sum(wstrip * Fx, axis=-1), Fy=np.sum(wstrip * Fy, axis=-1),
                         Mz=np.sum(wstrip * Mz, axis=-1),
                         stick=np.sum(wstrip * stick, axis=-1) / prob.load, th_y=th_y,
                         nodes=thp, rho=rho, plastic=plastic)

    def plastic_nodes(self, edges: np.ndarray, tx0: np.ndarray, ty0: np.ndarray,
                      S0: np.ndarray) -> dict[str, np.ndarray]:
        """Gauss nodes of the plastic panels ``edges`` (nc, ns, P+1), their weights, and there
        the stick traction, ``T`` and the accumulated rigid slip ``S``.

        ``tau_el`` and ``S`` are integrated from their values at ``edges[..., 0]``: panel by
        panel with the Gauss weights (order 2m), inside a panel with the integration matrix
        through its ends and Gauss nodes (order m + 2) -- from ``T`` and ``|w| dX/dtheta``,
        explicit, in one stacked array.
        """
        ln, m = self.ln, self.grid.m
        x, w = gauss_legendre(m)
        SmT = _gauss_integration(m).T
        lo, hv = edges[..., :-1, None], np.diff(edges, axis=-1)[..., None]
        th = lo + hv * x  # (nc, ns, P, m)
        st, ct = np.sin(th), np.cos(th)
        se, ce = np.sin(edges), np.cos(edges)
        Tx, Ty = ln.T(th, st, ct)
        Tex, Tey = ln.T(edges, se, ce)
        aj = ln.aj[..., None]
        f = np.empty((3, *th.shape))
        f[0], f[1], f[2] = Tx, Ty, ln.rigid_slip(th, ct) * aj[..., None] * st
        fe = np.empty((3, *edges.shape))
        fe[0], fe[1], fe[2] = Tex, Tey, ln.rigid_slip(edges, ce) * aj * se
        # inside each panel: the integration matrix through its start, its Gauss nodes, its end
        within = (f @ SmT[1:-1] + fe[..., :-1, None] * SmT[0] + fe[..., 1:, None] * SmT[-1]) * hv
        total = np.cumsum((f @ w) * hv[..., 0], axis=-1)
        f0 = np.empty((3, *tx0.shape))
        f0[0], f0[1], f0[2] = tx0, ty0, S0
        start = f0[..., None] + np.concatenate([np.zeros((*f0.shape, 1)), total[..., :-1]], axis=-1)
        cum = (start[..., None] + within).reshape(*f.shape[:3], -1)
        shape = (*th.shape[:2], -1)
        return {"theta": th.reshape(shape), "weight": np.broadcast_to(hv * w, th.shape).reshape(shape),
                "st": st.reshape(shape), "ct": ct.reshape(shape), "tx": cum[0], "ty": cum[1],
                "S": cum[2], "Tx": Tx.reshape(shape), "Ty": Ty.reshape(shape)}

    def march(self, th_y: np.ndarray, txy: np.ndarray, tyy: np.ndarray, S_y: np.ndarray,
              pl: dict, dT_grid: np.ndarray | None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Traction ``(tau_x, tau_y)`` at the plastic-zone nodes, slip flags and ``g`` there."""
        ln, prob = self.ln, self.prob
        thp = pl["theta"]
        pts = np.concatenate([th_y[..., None], thp], axis=-1)  # (nc, ns, M+1)
        telx = np.concatenate([txy[..., None], pl["tx"]], axis=-1)
        tely = np.concatenate([tyy[..., None], pl["ty"]], axis=-1)
        dT_p = 0.0 if dT_grid is None else interp_uniform(pts, dT_grid)
        S = np.concatenate([S_y[..., None], pl["S"]], axis=-1)
        st = np.concatenate([np.sin(th_y)[..., None], pl["st"]], axis=-1)
        _, gp = ln.limits(pts, dT_p, S, st)
        Tyx, Tyy = ln.T(np.maximum(th_y, 1e-9))
        Tpx = np.concatenate([Tyx[..., None], pl["Tx"]], axis=-1)
        Tpy = np.concatenate([Tyy[..., None], pl["Ty"]], axis=-1)
        yielded = th_y < math.pi
        direction_fixed = not ln.spin and (not ln.lateral or not np.any(ln.r[0] != ln.r[1])) \
            and prob.restick == "thesis"
        if direction_fixed:
            # one rigid-slip direction along every strip, equal flexibilities in x and y:
            # the stick traction, the slip and so the traction keep one direction, and
            # a loaded particle never unloads; a yielded particle takes the Voce limit at
            # once (a jump where kappa > 0, as in the longitudinal model)
            mag0 = np.sqrt(txy * txy + tyy * tyy)
            aT0 = np.sqrt(Tyx * Tyx + Tyy * Tyy)
            dx = np.where(mag0 > 0, txy / np.where(mag0 > 0, mag0, 1.0),
                          np.where(aT0 > 0, Tyx / np.where(aT0 > 0, aT0, 1.0), 1.0))
            dy = np.where(mag0 > 0, tyy / np.where(mag0 > 0, mag0, 1.0),
                          np.where(aT0 > 0, Tyy / np.where(aT0 > 0, aT0, 1.0), 0.0))
            plast = np.broadcast_to(yielded[..., None], thp.shape)
            g1 = gp[..., 1:]
            return (np.where(plast, g1 * dx[..., None], pl["tx"]),
                    np.where(plast, g1 * dy[..., None], pl["ty"]), plast, g1)
        shape = pts.shape
        L = shape[0] * shape[1]
        tx, ty, plast = _march_lanes(*(a.reshape(L, -1) for a in (pts, telx, tely, gp, Tpx, Tpy)),
                                     prob.restick == "kalker")
        return (tx[:, 1:].reshape(thp.shape), ty[:, 1:].reshape(thp.shape),
                plast[:, 1:].reshape(thp.shape), gp[..., 1:])


@cache
def _edge_fractions(graded: int, uniform: int, clamp: int
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Voce grading factors and the unit edges of the uniform and the clamp panels."""
    return (0.25 * 2.0 ** np.arange(graded), np.linspace(0.0, 1.0, uniform + 1),
            np.linspace(0.0, 1.0, clamp + 1))


@cache
def _composite_gauss(panels: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on [0, 1] of ``panels`` equal panels with ``m`` Gauss nodes each."""
    x, w = gauss_legendre(m)
    lo = np.arange(panels)[:, None] / panels
    return (lo + x / panels).ravel(), np.tile(w / panels, panels)


#: lanes x steps below which the direction chain is a log-depth scan (fewer numpy calls)
#: rather than a loop over the steps (less arithmetic)
_SCAN_SIZE = 4096


def _moebius_chain(m11: np.ndarray, m12: np.ndarray, m22: np.ndarray, A0: np.ndarray,
                   B0: np.ndarray, start: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``(A, B)`` at nodes 0..M of ``(A, B)_(i+1) = M_i (A, B)_i`` from ``(A0, B0)`` at ``start``.

    ``u = A/B`` (a projective pair: only the ratio matters) is carried over step ``i`` by
    the 2x2 matrix ``M_i = [[m11, m12], [-m12, m22]]`` (arrays (L, M)); ``start`` (L,) is
    each lane's first node (default 0), before which the pair stays ``(A0, B0)``.  Small
    problems use a Hillis-Steele prefix product (log2(M) rounds of array operations), large
    ones a loop over the steps; each product is rescaled so nothing over- or underflows.
    """
    L, M = m11.shape
    if start is not None:  # identity before the start: the product from node 0 is the chain
        before = np.arange(M)[None, :] < start[:, None]
        m11, m22 = np.where(before, 1.0, m11), np.where(before, 1.0, m22)
        m12 = np.where(before, 0.0, m12)
    m21 = -m12
    A = np.empty((L, M + 1))
    B = np.empty((L, M + 1))
    A[:, 0], B[:, 0] = A0, B0
    if L * M <= _SCAN_SIZE:
        p11, p12, p21, p22 = (np.array(a, dtype=float) for a in (m11, m12, m21, m22))
        d, level = 1, 0
        while d < M:  # P_j <- P_j P_(j-d): the product of the maps from node j-2d+1 to j+1
            a11, a12, a21, a22 = p11[:, d:], p12[:, d:], p21[:, d:], p22[:, d:]
            b11, b12, b21, b22 = p11[:, :-d], p12[:, :-d], p21[:, :-d], p22[:, :-d]
            q11 = a11 * b11 + a12 * b21
            q12 = a11 * b12 + a12 * b22
            q21 = a21 * b11 + a22 * b21
            q22 = a21 * b12 + a22 * b22
            if level % 2:  # every other round: products of at most four rescaled ones
                s = 1.0 / (np.abs(q11) + np.abs(q12) + np.abs(q21) + np.abs(q22) + 1e-300)
                q11, q12, q21, q22 = q11 * s, q12 * s, q21 * s, q22 * s
            p11[:, d:], p12[:, d:], p21[:, d:], p22[:, d:] = q11, q12, q21, q22
            d, level = 2 * d, level + 1
        A[:, 1:] = p11 * A0[:, None] + p12 * B0[:, None]
        B[:, 1:] = p21 * A0[:, None] + p22 * B0[:, None]
        return A, B
    s11, s12, s22 = (np.ascontiguousarray(a.T) for a in (m11, m12, m22))
    a, b = np.array(A0, dtype=float), np.array(B0, dtype=float)
    At, Bt = np.empty((M, L)), np.empty((M, L))
    for i in range(M):
        a, b = s11[i] * a + s12[i] * b, s22[i] * b - s12[i] * a
        if i % 4 == 3:
            n = np.abs(a) + np.abs(b)
            n[n == 0] = 1.0
            a /= n
            b /= n
        At[i], Bt[i] = a, b
    A[:, 1:], B[:, 1:] = At.T, Bt.T
    return A, B


def _norm2(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return x * x + y * y


def _chain_start(dx: np.ndarray, dy: np.ndarray, ux: np.ndarray, uy: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The pair ``(A, B)``, ``A/B = tan(chi/2)``, of the direction ``d`` at angle ``chi`` from ``u``."""
    c = dx * ux + dy * uy
    s = dy * ux - dx * uy
    pos = c >= 0  # tan(chi/2) = s/(1 + c) = (1 - c)/s: the better-conditioned form
    return np.where(pos, s, 1.0 - c), np.where(pos, 1.0 + c, s)


def _chain_direction(A: np.ndarray, B: np.ndarray, ux: np.ndarray, uy: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The unit direction ``exp(i (beta + chi))``, ``tan(chi/2) = A/B``, ``exp(i beta) = u``."""
    A2, B2 = A * A, B * B
    n = A2 + B2
    if not n.all():  # a pair that collapsed to zero: along T
        B2 = np.where(n > 0, B2, 1.0)
        n = np.where(n > 0, n, 1.0)
    inv = 1.0 / n
    c = (B2 - A2) * inv
    s = 2.0 * A * B * inv
    return ux * c - uy * s, ux * s + uy * c


def _march_lanes(pts: np.ndarray, telx: np.ndarray, tely: np.ndarray, gp: np.ndarray,
                 Tx: np.ndarray, Ty: np.ndarray, kalker: bool
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The traction march along the plastic zone of ``L`` lanes (arrays (L, M+1); node 0 is
    the yield point): ``(tau_x, tau_y, slipping)`` at the nodes.

    FASTSIM's rules (module docstring), node by node: a slipping particle stays on the
    limit ``g`` while the trial traction ``tau + Delta tau_el`` is not inside
    ``min(|tau|, g)`` (the thesis; Kalker: ``g``), its direction carried over the step by
    the exact solution of ``d chi/d theta = -(k sin chi + beta')`` (``chi`` the angle
    between the traction and ``T = d tau_el/d theta``, ``k = |T|/g`` averaged over the
    step, ``beta'`` the turning of ``T``), a Riccati equation whose solution is a Moebius
    map of ``u = tan(chi/2)``; a sticking particle takes the trial traction and slips
    again when that reaches ``g``.

    Nothing is marched node by node where it need not be: first every lane is assumed to
    slip from its yield point to the trailing edge (the direction chain is a product of
    2x2 matrices, :func:`_moebius_chain`), and the unloading test is applied to all nodes
    at once.  Lanes where a particle unloads (spin) continue from the first node that
    fails the test: their stick segment is the stick traction shifted by a constant,
    their next slip segment again a chain; each round of segments is array operations
    over the nodes, and there are as many rounds as stick/slip switches (a few).
    """
    L, M1 = pts.shape
    h = np.diff(pts, axis=-1)
    aT = np.sqrt(Tx * Tx + Ty * Ty)
    nz = aT > 0
    inv = 1.0 / np.where(nz, aT, 1.0)
    ux, uy = Tx * inv, Ty * inv  # exp(i beta) at the nodes
    if not nz.all():
        ux[~nz] = 1.0
    # k = |T|/g (large where g = 0, at the trailing edge); steps of zero length (empty
    # panels) have kh = 0 and beta' = 0: the identity
    with np.errstate(over="ignore"):  # g = 0 (a softened layer's zero strength): k = inf
        kp = aT / np.maximum(gp, 1e-300)
        kh = np.minimum(0.5 * (kp[:, 1:] + kp[:, :-1]) * h, 1e8)
    dbeta = np.arctan2(ux[:, :-1] * uy[:, 1:] - uy[:, :-1] * ux[:, 1:],
                       ux[:, :-1] * ux[:, 1:] + uy[:, :-1] * uy[:, 1:])
    # chi obeys d chi/dt = -(k sin chi + beta'); with u = tan(chi/2) that is a Riccati
    # equation, u = A/B with (A, B)' = [[-k/2, -b/2], [b/2, k/2]] (A, B) (b = beta'):
    # exp of the step's matrix, scaled by cosh (only the ratio matters)
    lam2 = 0.25 * (kh * kh - dbeta * dbeta)
    lam = np.maximum(np.sqrt(np.abs(lam2)), 1e-12)
    Sh = np.tanh(lam) / lam  # tanh(lam)/lam, or sin(lam)/lam where lam2 < 0; 1 at lam = 0
    neg = lam2 < -1e-24
    if neg.any():
        C = np.ones(lam.shape)
        ln_ = lam[neg]
        C[neg] = np.cos(ln_)
        Sh[neg] = np.sin(ln_) / ln_
    else:
        C = 1.0
    hs = 0.5 * Sh
    hk = hs * kh
    m11, m22 = C - hk, C + hk
    m12 = -hs * dbeta
    DTx, DTy = np.diff(telx, axis=-1), np.diff(tely, axis=-1)
    # the tests compare squares (g >= 0)
    lim2 = ((gp[:, 1:] if kalker else np.minimum(gp[:, :-1], gp[:, 1:])) * (1.0 - 1e-12)) ** 2
    gp2 = gp * gp
    # round 1: every lane slips from its yield point (a yielded particle takes the Voce limit
    # at once, in the direction of its stick traction, or of T where that is zero); a lane
    # that never yields has all its nodes at the trailing edge, where g = 0 and the traction
    # is zero either way
    mag0 = np.sqrt(telx[:, 0] ** 2 + tely[:, 0] ** 2)
    m0 = mag0 > 0
    dx0 = np.where(m0, telx[:, 0] / np.where(m0, mag0, 1.0), ux[:, 0])
    dy0 = np.where(m0, tely[:, 0] / np.where(m0, mag0, 1.0), uy[:, 0])
    A, B = _moebius_chain(m11, m12, m22, *_chain_start(dx0, dy0, ux[:, 0], uy[:, 0]))
    dx, dy = _chain_direction(A, B, ux, uy)
    tx, ty = gp * dx, gp * dy
    plast = np.ones((L, M1), dtype=bool)
    ok = _norm2(tx[:, :-1] + DTx, ty[:, :-1] + DTy) >= lim2  # step i: node i+1 stays slipping
    bad = ~ok.all(axis=1)
    if not bad.any():
        return tx, ty, plast
    # lanes that unload: rounds of a stick segment and a slip segment
    lanes = np.flatnonzero(bad)
    k = np.argmin(ok[lanes], axis=1) + 1  # first node that fails the slip test
    node = np.arange(M1)[None, :]
    while lanes.size:
        sub = (lanes, slice(None))
        # stick from node k: tau_j = tau_(k-1) + tel_j - tel_(k-1)
        r = np.arange(lanes.size)
        bx = tx[lanes, k - 1] - telx[lanes, k - 1]
        by = ty[lanes, k - 1] - tely[lanes, k - 1]
        sx, sy = bx[:, None] + telx[sub], by[:, None] + tely[sub]
        yield_ = (_norm2(sx, sy) >= gp2[sub]) & (node > k[:, None])
        again = yield_.any(axis=1)
        j = np.where(again, np.argmax(yield_, axis=1), M1)  # first node slipping again
        seg = (node >= k[:, None]) & (node < j[:, None])
        tx[sub] = np.where(seg, sx, tx[sub])
        ty[sub] = np.where(seg, sy, ty[sub])
        plast[sub] = ~seg & plast[sub]
        lanes, j, r = lanes[again], j[again], r[again]
        if not lanes.size:
            break
        sub = (lanes, slice(None))
        # slip from node j in the direction of the trial traction there
        sxj, syj = sx[r, j], sy[r, j]
        mj = np.sqrt(sxj * sxj + syj * syj) + 1e-300
        A, B = _moebius_chain(m11[lanes], m12[lanes], m22[lanes],
                              *_chain_start(sxj / mj, syj / mj, ux[lanes, j], uy[lanes, j]),
                              start=j)
        dx, dy = _chain_direction(A, B, ux[sub], uy[sub])
        cx, cy = gp[sub] * dx, gp[sub] * dy
        ok = (_norm2(cx[:, :-1] + DTx[lanes], cy[:, :-1] + DTy[lanes]) >= lim2[lanes]) \
            | (node[:, 1:] <= j[:, None])
        fail = ~ok.all(axis=1)
        k = np.where(fail, np.argmin(ok, axis=1) + 1, M1)
        seg = (node >= j[:, None]) & (node < k[:, None])
        tx[sub] = np.where(seg, cx, tx[sub])
        ty[sub] = np.where(seg, cy, ty[sub])
        plast[sub] = seg | plast[sub]
        lanes, k = lanes[fail], k[fail]
    return tx, ty, plast


def canonical_creepages(xi: np.ndarray, eta: np.ndarray, phi: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The distinct creepage triples up to the model's symmetries.

    ``(-xi, eta, phi)`` reverses ``Fx``; the mirror ``y -> -y``, ``(xi, -eta, -phi)``,
    reverses ``Fy`` and ``Mz``.  Returns ``(unique, inverse, sx, sy)``: ``unique`` (k, 3)
    has ``xi >= 0``, ``eta >= 0`` (``phi >= 0`` where ``eta = 0``), and
    ``Fx = sx * Fx_unique[inverse]``, ``Fy = sy * Fy_unique[inverse]``, ``Mz = sy * ...``.
    """
    sx = np.where(xi < 0, -1.0, 1.0)
    sy = np.where((eta < 0) | ((eta == 0) & (phi < 0)), -1.0, 1.0)
    canon = np.stack([np.abs(xi), sy * eta, sy * phi], axis=1)
    # values equal to 1e-12 of their column's range count as one (an axis such as
    # linspace(-1, 1, 21) is symmetric only to round-off); the first of them is solved
    scale = np.max(np.abs(canon), axis=0)
    key = np.round(canon / np.where(scale > 0, scale * 1e-12, 1.0))
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return canon[first], inv.ravel(), sx, sy


def creep_forces(problem: CreepProblem, creepage: Any, lateral: Any = 0.0, spin: Any = 0.0,
                 grid: CreepGrid | None = None, *, symmetry: bool = True) -> CreepResult:
    """Creep forces ``Fx, Fy, Mz`` for creepages ``xi``, ``eta`` and spin ``phi`` [1/m].

    Parameters
    ----------
    problem
        Contact, flexibilities and layer (:class:`CreepProblem`, :func:`creep_problem`).
    creepage, lateral, spin
        Longitudinal and lateral creepage (fractions) and spin [1/m]; broadcast
        against each other (vectorised: a whole table is one call).
    grid
        Resolution (default :class:`CreepGrid`).
    symmetry
        Solve each creepage triple once up to the model's symmetries
        (:func:`canonical_creepages`; exact, the strips are mirrored); False solves every
        triple as given (tests of the symmetries).

    Returns
    -------
    CreepResult

    Raises
    ------
    TorlabInputError
        Lateral creepage or spin without the flexibility they need (the contact
        shape), non-finite creepages, a parabolic bound with a layer flexibility.
    ConvergenceError
        The contact-temperature iteration did not converge.
    """
    grid = grid or CreepGrid()
    xi_in, eta_in, phi_in = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                                  for v in (creepage, lateral, spin)))
    shape = xi_in.shape
    xi, eta, phi = (v.ravel() for v in (xi_in, eta_in, phi_in))
    for name, v in (("creepage", xi), ("lateral creepage", eta), ("spin", phi)):
        if not np.all(np.isfinite(v)):
            raise TorlabInputError(f"{name} must be finite", key=name)
    if np.any(phi != 0) and problem.L3 is None:
        raise TorlabInputError("spin needs the contact shape: the semi-axes a, b and the elastic "
                               "constants for Kalker's C23 and L3 = pi a sqrt(a/b)/(4 C23 G) "
                               "(build the problem with creep_problem(scene) or give L3)",
                               key="spin")
    if np.any(eta != 0) and problem.L2 is None:
        raise TorlabInputError("lateral creepage needs Kalker's C22 and L2 = 8a/(3 C22 G) of the "
                               "contact (build the problem with creep_problem(scene) or give L2)",
                               key="lateral")
    if problem.traction_bound == "parabolic" and problem.layer.L_mue > 0:
        raise TorlabInputError("the parabolic traction bound is Kalker's FASTSIM bound for "
                               "comparisons; it is not defined with a layer flexibility (L_mue > 0)",
                               key="traction_bound")
    prob = problem
    N = prob.load
    Fx = np.zeros(xi.shape)
    Fy = np.zeros(xi.shape)
    Mz = np.zeros(xi.shape)
    stick = np.ones(xi.shape)
    tmax = None if prob.thermal is None else np.full(xi.shape, prob.ambient_temperature)
    iters = None if prob.thermal is None else np.zeros(xi.shape, dtype=int)
    loop = "off" if prob.thermal is None else "single pass"
    nz = (xi != 0) | (eta != 0) | (phi != 0)
    if nz.any():
        # symmetries of the model (exact on the mirrored strips): (-xi, eta, phi) reverses Fx;
        # the mirror y -> -y, (xi, -eta, -phi), reverses Fy and Mz.  Each triple is mapped to
        # one with xi >= 0, eta >= 0 (and phi >= 0 where eta = 0) and each distinct one is
        # solved once: a table symmetric about zero costs a quarter.
        if symmetry and np.count_nonzero(nz) > 1:
            uniq, inv, sx, sy = canonical_creepages(xi[nz], eta[nz], phi[nz])
        else:
            uniq = np.stack([xi[nz], eta[nz], phi[nz]], axis=1)
            inv, sx, sy = np.arange(uniq.shape[0]), np.ones(uniq.shape[0]), np.ones(uniq.shape[0])
        out = _solve_points(prob, grid, uniq[:, 0], uniq[:, 1], uniq[:, 2])
        if prob.calibrated and prob.traction_bound == "elliptic":
            from torlab.model.calibrated import correct_creep

            out["Fx"], out["Fy"], out["Mz"] = correct_creep(
                prob, uniq[:, 0], uniq[:, 1], uniq[:, 2], out["Fx"], out["Fy"], out["Mz"])
        Fx[nz] = sx * out["Fx"][inv]
        Fy[nz] = sy * out["Fy"][inv]
        Mz[nz] = sy * out["Mz"][inv]
        stick[nz] = out["stick"][inv]
        if prob.thermal is not None:
            iters[nz] = out["iterations"][inv]
            tmax[nz] = out["tmax"][inv]
            loop = out["loop"]
    for name, arr in (("Fx", Fx), ("Fy", Fy), ("Mz", Mz)):
        if not np.all(np.isfinite(arr)):
            raise NumericalError(f"creep forces: non-finite {name}; please report this scene")

    def r(arr: np.ndarray) -> np.ndarray:
        return arr.reshape(shape)

    return CreepResult(creepage=xi_in.copy(), lateral=eta_in.copy(), spin=phi_in.copy(),
                       Fx=r(Fx), Fy=r(Fy), Mz=r(Mz), mu_x=r(Fx / N), mu_y=r(Fy / N),
                       adhesion_fraction=r(stick), load=N,
                       max_temperature_C=None if tmax is None else r(tmax),
                       temperature_iterations=None if iters is None else r(iters),
                       temperature_loop=loop)


#: creepage points per array pass: the scheme's arrays stay a few hundred kB (a pass over
#: thousands of points spends much of its time faulting in fresh memory for each temporary)
_CHUNK_LANES = 512


def _solve_points(prob: CreepProblem, grid: CreepGrid, xi: np.ndarray, eta: np.ndarray,
                  phi: np.ndarray) -> dict[str, Any]:
    """Forces, adhesion and temperature of distinct creepage points, each as if alone.

    The points with spin and those without are solved apart (their strips differ), in
    chunks of about ``_CHUNK_LANES`` strips; a point's temperature iteration ends when it
    has converged.  So a point gets the same numbers in a curve or a table as on its own.
    """
    n = xi.size
    out: dict[str, Any] = {"Fx": np.zeros(n), "Fy": np.zeros(n), "Mz": np.zeros(n),
                           "stick": np.ones(n), "iterations": np.zeros(n, dtype=int),
                           "tmax": np.full(n, prob.ambient_temperature), "loop": "single pass"}
    spin = phi != 0
    for group in (np.flatnonzero(~spin), np.flatnonzero(spin)):
        if not group.size:
            continue
        ns = 2 * grid.n if not spin[group[0]] else grid.spin_panels * grid.spin_strips
        size = max(1, _CHUNK_LANES // ns)
        for s in range(0, group.size, size):
            rows = group[s:s + size]
            solver = _Solver(prob, grid, xi[rows], eta[rows], phi[rows])
            dT_grid = None
            if prob.thermal is not None:
                dT_grid, it, loop, tm = _temperature(solver, prob, grid)
                out["iterations"][rows] = it
                out["tmax"][rows] = tm
                if loop == "iterated":
                    out["loop"] = loop
                if not any(prob.layer.law.temperature_coefficients(prob.layer)):
                    dT_grid = None
            sol = solver.solve(dT_grid)
            out["Fx"][rows], out["Fy"][rows], out["Mz"][rows] = sol.Fx, sol.Fy, sol.Mz
            out["stick"][rows] = sol.stick
    return out


def _temperature(solver: _Solver, prob: CreepProblem, grid: CreepGrid
                 ) -> tuple[np.ndarray, np.ndarray, str, np.ndarray]:
    """Converge the flash temperature on the per-strip grid, every point at once.

    As the longitudinal model's temperature (:mod:`torlab.model.fastsim`): each point has its own adaptively
    under-relaxed fixed-point iteration; the points iterate together in one array, and a
    point leaves the active set as soon as it has converged, so its result does not depend
    on the other points computed with it.

    Returns
    -------
    tuple
        ``(dT grid (nc, ns, nT), iterations per point, mode, Tmax per point)``.
    """
    th, lay, ln = prob.thermal, prob.layer, solver.ln
    thetaT, K = flash_temperature_matrix(grid.temperature_nodes)
    KT = K.T
    nc, ns = ln.xi.shape[0], ln.Pj.shape[1]
    nT = thetaT.size
    if prob.speed <= 0:
        return (np.zeros((nc, ns, nT)), np.zeros(nc, dtype=int), "single pass",
                np.full(nc, prob.ambient_temperature))
    coef = th.partition / math.sqrt(math.pi * th.conductivity * th.density * th.heat_capacity
                                    * prob.speed)
    scale = coef * np.sqrt(ln.aj)[..., None]
    coupled = any(lay.law.temperature_coefficients(lay))
    thT = np.broadcast_to(thetaT, (nc, ns, nT))
    w_all = ln.rigid_slip(thT) * prob.speed
    tx_all, ty_all = ln.tau_el(thT, solver._T_ex)  # stick traction at the temperature nodes
    mag_el = np.sqrt(tx_all * tx_all + ty_all * ty_all)

    def where(i: int) -> str:
        return (f"creepage {ln.xi[i, 0]:.4g}, lateral creepage {ln.eta[i, 0]:.4g} and spin "
                f"{ln.phi[i, 0]:.4g} 1/m")

    def G(dT: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Flash temperature rise of the points ``rows`` given their temperature ``dT``."""
        sub = solver if rows.size == nc else solver.subset(rows)
        k = rows.size
        sol = sub.solve(dT if coupled else None, want_rho=True)
        tT = thT[:k]
        _, gT = sub.ln.limits(tT, dT)
        before = tT < sol.th_y[..., None]
        # piecewise-linear |tau|/g (and the slip flag) between the march's nodes, all lanes at
        # once: lanes are shifted apart along one axis so a single np.interp serves them all
        off = 4.0 * np.arange(k * ns).reshape(k, ns, 1)
        xp = np.concatenate([sol.th_y[..., None], sol.nodes], axis=-1) + off
        rp = np.concatenate([sol.rho[..., :1], sol.rho], axis=-1)
        pp = np.concatenate([np.ones((k, ns, 1)), sol.plastic.astype(float)], axis=-1)
        xq = (tT + off).ravel()
        rho = np.interp(xq, xp.ravel(), rp.ravel()).reshape(tT.shape)
        plast = np.interp(xq, xp.ravel(), pp.ravel()).reshape(tT.shape) >= 0.5
        q = np.where(before, mag_el[rows], rho * gT) * w_all[rows]
        if th.slip_velocity == "local":
            q = np.where(before | ~plast, 0.0, q)
        return scale * (q @ KT)

    return converge_flash_temperature(G, np.zeros((nc, ns, nT)), np.ones(nc, dtype=int),
                                      np.ones(nc, dtype=bool), th, lay, where,
                                      prob.ambient_temperature)


