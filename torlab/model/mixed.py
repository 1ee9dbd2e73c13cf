"""Mixed lubrication: traction and Stribeck curves of lubricated scenes (thesis 5.2.3-5.2.4).

The pieces (each in its own module) are put together here:

1. Hertz contact (:mod:`torlab.model.contact`);
2. central film thickness ``hc`` (Eq. 5.31 or 5.32, :class:`torlab.model.ehl.FilmThickness`);
3. Greenwood-Williamson asperity pressure (Eq. 5.41/5.42, :mod:`torlab.model.asperity`);
4. the bracketed load-sharing solve ``hc(F - F_BL(h)) = h`` (docs/model/thesis-reading.md,
   :func:`torlab.model.loadshare.solve_load_sharing`), which does not depend on the
   creepage, so a traction curve needs it once;
5. ``mu_EHL`` of the film (Eq. 5.37/5.40 with the scene's shear law,
   :func:`torlab.model.ehl.mu_ehl`) at the rigid slip ``w = creepage * v``;
6. ``mu_BL`` of the asperity contacts: FASTSIM with the third-body layer on the
   Hertz contact (:func:`torlab.model.fastsim.boundary_traction`);
7. ``mu = (mu_EHL W_EHL + mu_BL W_BL)/W`` (Eq. 5.47).

Model only what the scene needs (and say so in ``modelled``):

* no ``roughness:`` -> smooth surfaces: film only, no asperities, no FASTSIM;
* asperity share below ``share_tol`` (1e-9; regime ``full_film``) -> FASTSIM skipped;
* film share below ``share_tol`` (regime ``boundary``, e.g. ``v = 0``) -> no film traction;
* ``thermal:`` -> the flash temperature of the boundary part, with the heat flux of
  the mixed shear stress ``q = tau w`` (Eq. 5.48: ``tau = (tau_EHL W_EHL + tau_BL W_BL)/W``);
  without a ``thermal:`` section no temperature is computed.

A Newtonian film under a Barus or Roelands viscosity can give an absurd traction
coefficient at high pressure and slip (thesis 5.2.3; the reason for the
``limiting`` and ``eyring`` laws).  Above ``mu_EHL = 0.5`` the prediction says so
in its notes and recommends ``shear: limiting``; a traction that overflows raises
:class:`torlab.model.ehl.NonPhysicalTractionError`.

References
----------
.. [1] Kvarda, D. Experimental investigation and numerical modelling of top of rail
   products. PhD thesis, Brno University of Technology, Faculty of Mechanical
   Engineering (the model: section 5.2; no DOI).
.. [2] Kvarda, D., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J., Krupka, I.,
   Hartl, M. (2021). Asperity-based model for prediction of traction in
   water-contaminated wheel-rail contact. Tribology International 157, 106900.
   https://doi.org/10.1016/j.triboint.2021.106900
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import TorlabInputError

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["MixedContact", "StribeckPrediction", "mixed_contact", "mixed_traction_curve",
           "stribeck_curve", "traction_draws"]

#: Asperity (or film) load share below which that part is not modelled.
SHARE_TOL = 1e-9
#: |mu_EHL| above which the film traction is flagged as implausible.
MU_EHL_PLAUSIBLE = 0.5


@dataclass
class MixedContact:
    """The lubricated contact of a scene, resolved once (SI units)."""

    contact: Any
    lubricant: Any
    film: Any
    asperity: Any | None
    problem: Any | None
    grid: Any

    @property
    def sigma(self) -> float | None:
        """Roughness ``psi`` [m], None for smooth surfaces."""
        return None if self.asperity is None else self.asperity.sigma


@dataclass
class StribeckPrediction:
    """A predicted Stribeck curve.

    Attributes
    ----------
    table
        DataFrame with the scene-contract columns ``speed_m_s``, ``mu``,
        ``film_thickness_m``, ``lambda`` (h/psi; empty for smooth surfaces) and
        ``load_share_asperity``; also ``mu_ehl``, ``mu_boundary`` (empty where not
        modelled), ``separation_m``, ``regime`` and ``max_temperature_C`` with
        ``thermal:``.
    contact
        The resolved contact.
    creepage
        The creepage of the curve (fraction).
    modelled
        What was modelled (and what was skipped, why).
    summary
        Key numbers for ``summary.json``.
    band
        The :class:`~torlab.uncertainty.Propagation` of the scene's fit
        covariance (None without one; set by :func:`torlab.model.predict.predict_stribeck`).
    """

    table: Any
    contact: Any
    creepage: float
    modelled: list[str]
    summary: dict[str, Any] = field(default_factory=dict)
    band: Any = None


def mixed_contact(scene: Scene) -> MixedContact:
    """Resolve contact, film, asperity and boundary models of a lubricated scene."""
    from torlab.model.asperity import Roughness
    from torlab.model.contact import build_contact
    from torlab.model.ehl import FilmThickness, Lubricant
    from torlab.model.prediction import fastsim_grid, fastsim_problem

    if scene.lubricant is None:
        raise TorlabInputError("the scene has no lubricant: section", key="lubricant")
    contact = build_contact(scene)
    if not math.isfinite(contact.rx):
        raise TorlabInputError(
            "a lubricated scene needs the rolling radii (r1x/r2x) for the film thickness "
            "(Eqs. 5.31/5.32 use the reduced radius rx)", key="contact.r1x")
    sl = scene.lubricant
    lub = Lubricant(eta0=sl.eta0, viscosity=sl.viscosity, alpha=sl.alpha, Z=sl.Z, shear=sl.shear,
                    gamma_L=sl.gamma_L, tau0=sl.tau0, film=sl.film)
    p = contact.patch
    film = FilmThickness.from_contact(lub, contact.E_star, contact.rx, p.a, p.b)
    asperity = None
    if scene.roughness is not None:
        r = scene.roughness
        asperity = Roughness(r.sigma, r.beta, r.density, r.model, r.hardness).asperity_model(
            contact.E_star)
    problem = fastsim_problem(scene, contact) if scene.boundary is not None else None
    return MixedContact(contact, lub, film, asperity, problem, fastsim_grid(scene))


def _need_boundary(mc: MixedContact, share: np.ndarray, where: str) -> None:
    if mc.problem is None and np.any(share >= SHARE_TOL):
        k = int(np.argmax(share))
        raise TorlabInputError(
            f"the asperities carry {share.flat[k]:.3g} of the load {where}, but the scene has "
            "no boundary: section (the third-body layer) for their friction",
            key="boundary")


def _heat_of_film(mc: MixedContact, v: Any, h: Any, share: Any):
    """``extra_heat_flux`` for FASTSIM: boundary heat weighted by the asperity share plus
    the film's ``(1 - share) tau_EHL w`` at each temperature node (Eq. 5.48).

    ``v``, ``h`` and ``share`` are scalars (one speed) or arrays with one entry per
    point of the FASTSIM call (a Stribeck curve: one point per speed).
    """
    from torlab.model.ehl import tau_ehl

    p0 = mc.contact.patch.p0
    v, h, share = (np.asarray(x, dtype=float).reshape(-1, 1, 1) for x in (v, h, share))
    film_share = 1.0 - share
    film = (film_share > 0.0) & (h > 0.0)

    def flux(X_over_a: np.ndarray, cphi: np.ndarray, xi: np.ndarray):
        if not film.any():
            return share, 0.0
        s_theta = np.sqrt(np.clip(X_over_a * (2.0 - X_over_a), 0.0, None))
        p = p0 * cphi * s_theta
        w = xi * v
        tau = tau_ehl(p, w, np.where(film, h, 1.0), mc.lubricant)  # h = 1 m: placeholder
        return share, np.where(film, film_share * tau * w, 0.0)

    return flux


def boundary_part(mc: MixedContact, creepage: np.ndarray, v: Any, h: Any, share: Any):
    """FASTSIM for the asperity part (with the film's heat when thermal).

    ``v``, ``h``, ``share``: one speed (scalars) for a traction curve, or one per
    creepage (arrays) for a Stribeck curve with temperature.
    """
    from torlab.model.fastsim import boundary_traction

    if mc.problem.thermal is None:
        return boundary_traction(mc.problem, creepage, mc.grid)
    return boundary_traction(mc.problem, creepage, mc.grid, speed=v,
                             extra_heat_flux=_heat_of_film(mc, v, h, share))


def _ehl_notes(mu_e: np.ndarray, lub: Any) -> list[str]:
    if mu_e.size and np.nanmax(np.abs(mu_e)) > MU_EHL_PLAUSIBLE:
        return [f"the {lub.shear} film traction reaches |mu_EHL| = "
                f"{np.nanmax(np.abs(mu_e)):.3g}, which is not physical for a lubricant film; "
                "use shear: limiting (gamma_L) or eyring (tau0) in lubricant:"]
    return []


def _modelled(mc: MixedContact, regimes: set[str], boundary_done: bool, loop: str) -> list[str]:
    from torlab.model.prediction import temperature_note

    c = mc.contact
    lub = mc.lubricant
    film = ("iso-viscous film, Esfahanian-Hamrock (Eq. 5.31)" if mc.film.formula == "iso"
            else "piezo-viscous film, Hamrock-Dowson (Eq. 5.32)")
    out = [f"Hertz contact ({c.patch.method})",
           f"EHL film: {film}; viscosity {lub.viscosity}; shear law {lub.shear}"]
    if mc.asperity is None:
        out.append("asperity load sharing: not modelled (no roughness: section, smooth surfaces)")
    else:
        out.append(f"asperity load sharing: Greenwood-Williamson, {mc.asperity.model} asperities "
                   "(bracketed solve, docs/model/thesis-reading.md)")
    if boundary_done:
        out.append("boundary friction: FASTSIM with the third-body layer where the asperities "
                   "carry load")
    else:
        why = ("smooth surfaces" if mc.asperity is None
               else f"asperity load share below {SHARE_TOL:g} (full film)")
        out.append(f"boundary friction: not modelled ({why})")
    out.append(f"regimes: {', '.join(sorted(regimes))}")
    if loop == "off" and mc.problem is not None and mc.problem.thermal is not None:
        out.append("contact temperature: not needed (no boundary part computed)")
    else:
        out.append(temperature_note(loop, mc.problem.layer if mc.problem is not None else None))
    return out


def _creepages(creepage: Any) -> np.ndarray:
    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    if not np.all(np.isfinite(xi)):
        raise TorlabInputError("creepage must be finite", key="creepage")
    return xi


def _at_scene_speed(scene: Scene) -> tuple[MixedContact, Any, float, Any, float, float]:
    """The contact, its patch, the speed, the load sharing there, the asperities' share
    and the film thickness of a lubricated scene at its own speed."""
    from torlab.model.loadshare import solve_load_sharing

    mc = mixed_contact(scene)
    p = mc.contact.patch
    v = float(scene.kinematics.speed)
    ls = solve_load_sharing(v, p.F, p.a, p.b, mc.film, mc.asperity, share_tol=SHARE_TOL)
    share = float(ls.load_share_asperity)
    _need_boundary(mc, np.array([share]), f"at {v:g} m/s")
    return mc, p, v, ls, share, float(ls.film_thickness)


def mixed_traction_curve(scene: Scene, creepage: Any, *, trend_tolerance: float = 0.01,
                         as_frame: bool = True):
    """Traction curve of a lubricated scene at the scene's speed (Eq. 5.47).

    Parameters
    ----------
    scene
        A validated scene with ``lubricant:``.
    creepage
        Creepages (fractions), any sign.
    trend_tolerance
        See :func:`torlab.model.prediction.classify_trend`.

    Returns
    -------
    torlab.model.predict.TractionPrediction
        ``table`` adds ``mu_boundary`` (where the asperities carry load),
        ``mu_ehl`` (where the film does), ``load_share_asperity`` and
        ``film_thickness_m`` to ``creepage`` and ``mu`` (a dict of numpy columns with
        ``as_frame=False``).
    """
    from torlab.model.ehl import mu_ehl
    from torlab.model.prediction import TractionPrediction, _summary, scene_trend

    xi = _creepages(creepage)
    mc, p, v, ls, share, h = _at_scene_speed(scene)
    table: Any = {"creepage": xi}
    mu = np.zeros_like(xi)
    mu_e = None
    if ls.F_EHL > 0:
        mu_e = mu_ehl(xi * v, h, p.p0, mc.lubricant)
        mu += (1.0 - share) * mu_e
    loop = "off"
    bl = None
    if share >= SHARE_TOL:
        bl = boundary_part(mc, xi, v, h, share)
        mu += share * bl.mu
        loop = bl.temperature_loop
    table["mu"] = mu
    if bl is not None:
        table["mu_boundary"] = bl.mu
        table["adhesion_fraction"] = bl.adhesion_fraction
    if mu_e is not None:
        table["mu_ehl"] = mu_e
    table["load_share_asperity"] = np.full(xi.shape, share)
    table["film_thickness_m"] = np.full(xi.shape, h)
    if bl is not None and bl.max_temperature_C is not None:
        table["max_temperature_C"] = bl.max_temperature_C
    if as_frame:
        import pandas as pd

        table = pd.DataFrame(table)
    modelled = _modelled(mc, {str(ls.regime)}, bl is not None, loop)
    trend = scene_trend(scene, xi, mu, tolerance=trend_tolerance)
    summary = _summary(scene, mc.contact, modelled, trend, table)
    notes = _ehl_notes(np.asarray(mu_e) if mu_e is not None else np.array([]), mc.lubricant)
    summary["notes"] = summary["notes"] + notes
    summary["load_sharing"] = {
        "speed_m_s": v, "regime": str(ls.regime), "load_share_asperity": share,
        "film_thickness_m": h, "separation_m": float(ls.h),
        "lambda": float(ls.lam) if math.isfinite(ls.lam) else None,
        "h_star_m": float(ls.h_star) if math.isfinite(ls.h_star) else None,
        "solver_evaluations": int(ls.evaluations)}
    return TractionPrediction(table=table, contact=mc.contact, modelled=modelled, trend=trend,
                              summary=summary)


def traction_draws(scene: Scene, creepage: Any, layers: dict[str, np.ndarray]
                   ) -> tuple[dict[str, np.ndarray], list[Any]]:
    """The traction curve of :func:`mixed_traction_curve` for many boundary layers at once.

    The film, the load sharing and ``mu_EHL`` do not depend on the layer: they are
    computed once; FASTSIM takes every layer in one call
    (:func:`torlab.model.fastsim.boundary_traction_draws`).  Each draw gets what
    :func:`mixed_traction_curve` gives with its layer (to round-off).

    Parameters
    ----------
    scene
        A validated scene with ``lubricant:`` (its lubricant is used as it is).
    creepage
        Creepages (fractions), any sign.
    layers
        ``{name: (m,) array}`` of ``boundary:`` keys, one entry per draw.

    Returns
    -------
    tuple
        ``({"mu", "film_thickness_m", "load_share_asperity" (and "mu_boundary",
        "max_temperature_C" where modelled): (m, n) arrays}, errors)`` with, per draw,
        None or the error of its FASTSIM evaluation (a failed draw's rows are NaN).
    """
    from torlab.errors import ConvergenceError
    from torlab.model.ehl import mu_ehl
    from torlab.model.fastsim import boundary_traction_draws

    xi = _creepages(creepage)
    m = int(np.broadcast_shapes(*(np.shape(v) for v in layers.values()), (1,))[0])
    mc, p, v, ls, share, h = _at_scene_speed(scene)
    mu = np.zeros_like(xi)
    if ls.F_EHL > 0:
        mu += (1.0 - share) * mu_ehl(xi * v, h, p.p0, mc.lubricant)
    out: dict[str, np.ndarray] = {}
    errors: list[Any] = [None] * m
    if share >= SHARE_TOL:
        heat = None if mc.problem.thermal is None else _heat_of_film(mc, v, h, share)
        bl = boundary_traction_draws(mc.problem, layers, xi, mc.grid, extra_heat_flux=heat)
        out["mu"] = mu[None, :] + share * bl.mu
        out["mu_boundary"] = bl.mu
        if bl.max_temperature_C is not None:
            out["max_temperature_C"] = bl.max_temperature_C
        errors = [ConvergenceError(e) if e else None for e in bl.errors]
    else:
        out["mu"] = np.repeat(mu[None, :], m, axis=0)
    out["load_share_asperity"] = np.full((m, xi.size), share)
    out["film_thickness_m"] = np.full((m, xi.size), h)
    return out, errors

def stribeck_curve(scene: Scene, speed: Any, creepage: float) -> StribeckPrediction:
    """Stribeck curve: ``mu`` against rolling speed at one creepage (Eq. 5.47).

    The load sharing is solved for all speeds at once (vectorised bracketed root);
    FASTSIM runs once for the creepage when the scene has no ``thermal:`` section
    (``mu_BL`` does not depend on speed then), else once for all the speeds where the
    asperities carry load, one point per speed (each with its own contact-temperature
    iteration, vectorised across speeds).

    Parameters
    ----------
    scene
        A validated scene with ``lubricant:``.
    speed
        Rolling speeds [m/s], >= 0.
    creepage
        Creepage (fraction, SRR/100), any sign.

    Returns
    -------
    StribeckPrediction
        Without a band (:func:`torlab.model.predict.predict_stribeck` adds the band and
        the regime transitions with their intervals).
    """
    import pandas as pd

    from torlab import __version__
    from torlab.model.ehl import mu_ehl
    from torlab.model.loadshare import solve_load_sharing

    v = np.atleast_1d(np.asarray(speed, dtype=float))
    if v.size == 0 or not np.all(np.isfinite(v)) or np.any(v < 0):
        raise TorlabInputError("speeds must be finite and >= 0 (m/s)", key="speed")
    xi = float(creepage)
    if not math.isfinite(xi):
        raise TorlabInputError("creepage must be finite", key="creepage")
    mc = mixed_contact(scene)
    p = mc.contact.patch
    ls = solve_load_sharing(v, p.F, p.a, p.b, mc.film, mc.asperity, share_tol=SHARE_TOL)
    share = np.asarray(ls.load_share_asperity, dtype=float)
    _need_boundary(mc, share, "at some speeds")
    h = np.asarray(ls.film_thickness, dtype=float)
    has_film = np.asarray(ls.F_EHL) > 0
    mu_e = np.full(v.shape, np.nan)
    if has_film.any():
        mu_e[has_film] = mu_ehl(xi * v[has_film], h[has_film], p.p0, mc.lubricant)
    mu_b = np.full(v.shape, np.nan)
    tmax = np.full(v.shape, np.nan)
    need = share >= SHARE_TOL
    loop = "off"
    if need.any():
        if mc.problem.thermal is None:
            bl = boundary_part(mc, np.array([xi]), mc.problem.speed, 0.0, 1.0)
            mu_b[need] = bl.mu[0]
            loop = bl.temperature_loop
        else:
            # one point per speed, all speeds in one call (each has its own tau-T loop)
            i = np.flatnonzero(need)
            bl = boundary_part(mc, np.full(i.size, xi), v[i], h[i], share[i])
            mu_b[i] = bl.mu
            tmax[i] = bl.max_temperature_C
            loop = bl.temperature_loop
    mu = np.where(has_film, (1.0 - share) * np.nan_to_num(mu_e), 0.0) + \
        np.where(need, share * np.nan_to_num(mu_b), 0.0)
    lam = np.asarray(ls.lam, dtype=float)
    table = pd.DataFrame({
        "speed_m_s": v, "mu": mu, "film_thickness_m": h,
        "lambda": np.where(np.isfinite(lam), lam, np.nan),
        "load_share_asperity": share, "mu_ehl": mu_e, "mu_boundary": mu_b,
        "separation_m": np.asarray(ls.h, dtype=float),
        "regime": np.asarray(ls.regime, dtype=object)})
    if mc.problem is not None and mc.problem.thermal is not None and need.any():
        table["max_temperature_C"] = tmax
    regimes = {str(r) for r in np.atleast_1d(ls.regime)}
    modelled = _modelled(mc, regimes, bool(need.any()), loop)
    if mc.asperity is None:
        modelled.append("lambda: not defined (smooth surfaces), column left empty")
    from torlab.model.plausible import result_notes

    notes = list(mc.contact.notes) + _ehl_notes(mu_e[np.isfinite(mu_e)], mc.lubricant) \
        + result_notes(table)
    summary = {
        "torlab_version": __version__, "scene": scene.name, "creepage": xi,
        "contact": mc.contact.summary(), "modelled": modelled, "notes": notes,
        "speed_range_m_s": [float(v.min()), float(v.max())],
        "mu_min": float(np.min(np.abs(mu))), "mu_max": float(np.max(np.abs(mu))),
        "regimes": {r: int(np.sum(np.asarray(ls.regime, dtype=object) == r)) for r in regimes},
        "h_star_m": float(ls.h_star) if math.isfinite(ls.h_star) else None,
        "load_sharing_evaluations_per_speed": float(np.mean(np.asarray(ls.evaluations))),
    }
    if scene.boundary is not None:
        summary["boundary"] = scene.boundary.model_dump()
    summary["lubricant"] = scene.lubricant.model_dump()
    return StribeckPrediction(table=table, contact=mc.contact, creepage=xi, modelled=modelled,
                              summary=summary)
