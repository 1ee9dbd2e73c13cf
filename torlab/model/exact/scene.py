"""A scene's creep forces by Kalker's exact theory: the entry the rest of torlab calls.

:func:`exact_contact` resolves a dry scene (``boundary:``, no ``lubricant:``) into the
exact solver's :class:`~torlab.model.exact.rolling.ExactContact`: the Hertz patch and
Kalker's combined ``G`` and ``nu`` of :func:`torlab.model.contact.build_contact`, and the
third-body layer of the ``boundary:`` section in series with the half-space:

* its elastic flexibility ``L_mue / p`` (thesis Eq. 5.28), element by element;
* its yield stress after the accumulated plastic deformation ``kappa``: the onset
  ``tau_c1 = mu_c1 p`` (Eq. 5.26) hardening or softening towards ``tau_c2 = mu_c2 p``
  (Eq. 5.27) with Voce's law over the length ``L_mup`` (Eqs. 5.24, 5.29), at the ambient
  temperature (the exact solver has no thermal model: the limits' temperature
  coefficients are not applied, and the output says so).  Voce's law is written for
  the layer's displacement past the elastic limit, ``s = (tau - tau_c1) L_e + kappa``
  (its elastic part beyond the limit plus its plastic part), so that one element
  loaded at a constant pressure follows the HPT curve of :func:`torlab.model.layers.hpt_tau`:
  ``tau = tau_c1 + (tau_c2 - tau_c1)(1 - exp(-s/L_mup))``, solved for ``tau`` at a given
  ``kappa`` (:class:`LawYield`, the one place the exact solver reads the layer law).

The layer's yield stress is the friction: there is no separate Coulomb coefficient
(``mu = inf``).  :func:`predict_exact` returns the same
:class:`~torlab.model.prediction.TractionPrediction` as the FASTSIM path
(:func:`torlab.model.creep.predict_creep`), with the forces' discretisation errors in
the table.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from torlab.errors import ConvergenceError, TorlabInputError
from torlab.model.exact.rolling import ExactContact, ExactGrid, ExactLayer, exact_creep_forces

__all__ = ["LawYield", "exact_contact", "predict_exact", "scene_layer", "voce_yield_stress"]


def voce_yield_stress(mu_c1: float, mu_c2: float, L_mue: float, L_mup: float, p: Any,
                      kappa: Any) -> tuple[np.ndarray, np.ndarray]:
    """Voce's yield stress and its slope against the plastic deformation (module docstring).

    ``z = tau - tau_c1`` solves ``z = D (1 - exp(-(z L_e + kappa)/L_mup))`` with
    ``D = tau_c2 - tau_c1`` and ``L_e = L_mue/p``; the slope is
    ``dtau/dkappa = g/(1 - g L_e)``, ``g = (tau_c2 - tau)/L_mup``.  Needs the plastic
    branch less steep than the elastic one (``|D| L_e < L_mup``).

    Returns
    -------
    tuple
        ``(tau, dtau/dkappa)`` [Pa, Pa/m].
    """
    p = np.asarray(p, dtype=float)
    kap = np.maximum(np.asarray(kappa, dtype=float), 0.0)
    t1, t2 = mu_c1 * p, mu_c2 * p
    D = t2 - t1
    if L_mup <= 0:
        return np.where(kap > 0, t2, t1) + 0.0 * kap, np.zeros(np.broadcast(p, kap).shape)
    Le = L_mue / np.where(p > 0, p, np.inf)
    if np.any(np.abs(D) * Le >= L_mup):
        raise TorlabInputError("Voce layer: the plastic branch is steeper than the elastic one "
                               "((mu_c2 - mu_c1) L_mue >= L_mup): the exact solver cannot split "
                               "the layer's slip into an elastic and a plastic part",
                               key="boundary")
    z = D * -np.expm1(-kap / L_mup)
    for _ in range(60):
        e = np.exp(-(z * Le + kap) / L_mup)
        f = z - D * (1 - e)
        if np.all(np.abs(f) <= 1e-13 * (np.abs(D) + np.abs(t1))):
            break
        df = 1 - D * e * Le / L_mup
        new = z - f / df
        if np.all(np.abs(new - z) <= 1e-14 * (np.abs(D) + 1e-300)):
            z = new
            break
        z = new
    else:
        raise ConvergenceError("Voce layer: the yield stress of an element did not converge")
    tau = t1 + z
    g = (t2 - tau) / L_mup
    return tau, g / (1.0 - g * Le)


class LawYield:
    """The exact solver's yield law (:class:`~torlab.model.exact.local.YieldLaw`) of a
    scene's layer: the element parameter ``c1`` is the pressure [Pa]."""

    def __init__(self, boundary: Any) -> None:
        self.params = (float(boundary.mu_c1), float(boundary.mu_c2), float(boundary.L_mue),
                       float(boundary.L_mup))

    def stress(self, kappa, c1, c2):
        return voce_yield_stress(*self.params, c1, kappa)

    def plastic_step(self, mag, kappa0, r, c1, c2):
        """A yielding element's step: ``tau`` solves
        ``tau - t1 = D (1 - exp(-((tau - t1) L_e + kappa0 + (mag - tau)/r)/L_mup))``
        between the yield stress before the step and the trial (hardening) or the
        saturation (softening); ``dk = (mag - tau)/r``."""
        mu1, mu2, lme, lmp = self.params
        p = np.asarray(c1, dtype=float)
        t1, t2 = mu1 * p, mu2 * p
        D = t2 - t1
        tc0, _ = self.stress(kappa0, p, None)
        if lmp <= 0:
            tau = np.minimum(mag, t2)
            return tau, (mag - tau) / r, np.zeros_like(tau)
        Le = lme / p
        lo = np.minimum(tc0, np.where(D >= 0, mag, t2))
        hi = np.maximum(tc0, np.where(D >= 0, mag, t2))
        lo, hi = np.minimum(lo, mag), np.minimum(hi, mag)
        t = np.clip(tc0, lo, hi)
        for _ in range(60):
            e = np.exp(-((t - t1) * Le + kappa0 + (mag - t) / r) / lmp)
            f = t - t1 - D * (1 - e)
            if np.all(np.abs(f) <= 1e-13 * (np.abs(D) + np.abs(t1))):
                break
            df = 1 - D * e * (Le - 1 / r) / lmp
            lo = np.where(f < 0, t, lo)
            hi = np.where(f >= 0, t, hi)
            new = t - f / np.where(df != 0, df, 1.0)
            bad = ~np.isfinite(new) | (new <= lo) | (new >= hi)
            new = np.where(bad, 0.5 * (lo + hi), new)
            step = np.abs(new - t)
            t = new
            if np.all(step <= 1e-14 * np.abs(mag) + 1e-300):
                break
        else:
            raise ConvergenceError("Voce layer: an element's plastic step did not converge")
        g = (t2 - t) / lmp
        return t, (mag - t) / r, g / (1.0 - g * Le)

    def reaching(self, tau, c1, c2):
        """The plastic deformation at which the yield stress reaches ``tau`` (bisection)."""
        tau = np.asarray(tau, dtype=float)
        lo = np.zeros(tau.shape)
        hi = np.full(tau.shape, 1.0)
        reach = np.full(tau.shape, np.inf)
        t_hi, _ = self.stress(hi, c1, c2)
        ok = (t_hi >= tau) & (self.stress(lo, c1, c2)[0] < tau)
        if not ok.any():
            return reach
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            below = self.stress(mid, c1, c2)[0] < tau
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return np.where(ok, 0.5 * (lo + hi), reach)


def scene_layer(boundary: Any) -> ExactLayer:
    """The exact solver's layer of a scene's ``boundary:`` section (module docstring)."""
    return ExactLayer(flexibility=None, flexibility_pressure=float(boundary.L_mue),
                      law=LawYield(boundary), c1=1.0, per_pressure=True,
                      name="third-body layer in series (Voce: mu_c1, mu_c2, L_mue, L_mup)")


def exact_contact(scene: Any, contact: Any = None) -> ExactContact:
    """The :class:`ExactContact` of a dry scene (module docstring).

    Raises
    ------
    TorlabInputError
        The scene has no ``boundary:`` section or is lubricated.
    """
    from torlab.model.contact import build_contact

    if scene.boundary is None:
        raise TorlabInputError("the exact solver needs a boundary: section (mu_c1, mu_c2, "
                               "L_mue, L_mup)", key="boundary")
    if scene.lubricant is not None:
        raise TorlabInputError("the exact solver models dry (third-body layer) scenes only: "
                               "remove the lubricant: section", key="lubricant")
    contact = contact or build_contact(scene)
    p = contact.patch
    return ExactContact(a=p.a, b=p.b, load=p.F, G=contact.G, nu=contact.nu, mu=math.inf,
                        layer=scene_layer(scene.boundary))


def predict_exact(scene: Any, creepage: Any, lateral: float = 0.0, spin: float = 0.0,
                  grid: ExactGrid | None = None) -> Any:
    """Creep forces of a dry scene by Kalker's exact theory along a creepage curve.

    Parameters
    ----------
    scene
        A validated dry :class:`~torlab.scene.Scene`.
    creepage
        Longitudinal creepages (fractions).
    lateral, spin
        Lateral creepage (fraction) and spin (1/m), the same for every point.
    grid
        The two grids (:class:`~torlab.model.exact.rolling.ExactGrid`).

    Returns
    -------
    torlab.model.prediction.TractionPrediction
        ``table`` with ``creepage``, ``mu`` (= ``mu_x``), ``lateral``, ``spin_1_m``,
        ``mu_x``, ``mu_y``, ``Fx_N``, ``Fy_N``, ``Mz_Nm``, their errors ``Fx_error_N``,
        ``Fy_error_N``, ``Mz_error_Nm`` and ``mu_x_error``, ``adhesion_fraction``,
        ``plastic_fraction``.
    """
    from torlab import __version__
    from torlab.model.contact import build_contact
    from torlab.model.prediction import TractionPrediction, classify_trend

    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    contact = build_contact(scene)
    ec = exact_contact(scene, contact)
    grid = grid or ExactGrid()
    r = exact_creep_forces(ec, xi, lateral, spin, grid)
    table = r.table()
    table.insert(1, "mu", r.mu_x)
    table.insert(table.columns.get_loc("mu_y") + 1, "mu_x_error", r.Fx_error / r.load)
    thermal = ("contact temperature: not modelled (the exact solver is isothermal; the "
               "layer's limits at the ambient temperature)" if scene.thermal is not None
               else "contact temperature: not modelled (no thermal: section)")
    modelled = [f"Hertz contact ({contact.patch.method})", *r.notes,
                "EHL film: not modelled (dry scene, no lubricant:)", thermal]
    trend = classify_trend(xi, r.mu_x)
    summary = {"torlab_version": __version__, "scene": scene.name, "method": "exact",
               "contact": contact.summary(), "modelled": modelled, "notes": list(contact.notes),
               "lateral": float(lateral), "spin_1_m": float(spin),
               "grid": {"n": grid.n, "coarse": grid.n_coarse, "normal": grid.normal},
               "mu_max": float(np.max(np.hypot(r.mu_x, r.mu_y))),
               "discretisation_error_mu_max": float(np.max(r.Fx_error / r.load)),
               "trend_after_saturation": trend, "boundary": scene.boundary.model_dump()}
    return TractionPrediction(table=table, contact=contact, modelled=modelled, trend=trend,
                              summary=summary)
