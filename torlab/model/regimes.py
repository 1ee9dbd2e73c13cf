"""Regime transition speeds of a lubricated contact and their uncertainty.

A Stribeck curve passes from the boundary regime (the asperities carry all the
load) through mixed lubrication to full film (the film carries it all).
:func:`torlab.model.loadshare.solve_load_sharing` labels each speed with the
load share ``F_BL/F`` of the Greenwood-Williamson asperities (Eqs. 5.41-5.46):
``boundary`` when the film's share is below ``share_tol`` (1e-9), ``full_film``
when the asperities' share is.  :func:`transition_speeds` finds the two speeds
where the label changes *exactly*, not at the grid of a curve, from the
solution's closed form:

* **mixed -> full film**: the asperities carry ``share_tol`` of the load, so the
  separation is ``t_f = F_n^-1(share_tol / A)`` roughness heights (``A`` the
  Greenwood-Williamson coefficient times the Hertz area over the load) and the
  film, which carries the rest, is ``h = hc(v, F (1 - share_tol))``;
* **boundary -> mixed**: the film carries ``share_tol`` of the load, so
  ``t_b = F_n^-1((1 - share_tol) / A)`` and ``h = hc(v, F share_tol)``.

Each is one equation ``hc(v, F_EHL) = t psi`` for the speed, solved by a
bracketed root in ``ln v`` (``hc`` of Eq. 5.31/5.32 grows with speed).  When
``t_b <= 0`` no film at a positive speed is thin enough: the asperities carry
everything only at ``v = 0`` and there is no boundary -> mixed transition at a
positive speed (reported as ``None``, with the reason).

Uncertainty
-----------
The transitions depend on the roughness and the contact (taken as given) and on
the lubricant's viscosity parameters (``eta0``, ``alpha``, ``Z``).  Those that
carry a fit's covariance in the scene (:func:`torlab.model.bands.scene_uncertainty`)
are propagated with :func:`torlab.uncertainty.propagate` to ``ln v`` of each
transition (linearised and checked, or sampled), so every transition gets a
95 % interval and the parameters that dominate it, and the probability that it
lies within the modelled speeds.  The boundary parameters do not move the load
sharing and are left out.  What the data cannot resolve is said:

* ``exact``: no parameter the transition depends on carries a covariance (the
  interval is the value; the scene's numbers are taken as exact);
* ``not resolved``: a parameter it depends on was not determined by its fit, the
  model fails within the parameters' uncertainty, or the 95 % interval spans
  more than :data:`RESOLUTION_FACTOR` (a factor of 100, two decades of speed);
* ``resolved`` otherwise.

The verdict ``within the modelled speeds`` / ``outside the modelled speeds`` is
called when its probability reaches ``threshold``
(:data:`TRANSITION_PROBABILITY`, 0.9), else ``undetermined``.

References
----------
.. [1] Kvarda, D., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J., Krupka, I.,
   Hartl, M. (2021). Asperity-based model for prediction of traction in
   water-contaminated wheel-rail contact. Tribology International 157, 106900.
   https://doi.org/10.1016/j.triboint.2021.106900
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["RESOLUTION_FACTOR", "TRANSITIONS", "TRANSITION_PROBABILITY", "transition_evidence",
           "transition_speeds"]

#: the transitions: key -> (from regime, to regime)
TRANSITIONS = {"boundary_to_mixed": ("boundary", "mixed"),
               "mixed_to_full_film": ("mixed", "full_film")}
#: probability a transition verdict (within / outside the modelled speeds) needs to be called
TRANSITION_PROBABILITY = 0.9
#: a transition whose 95 % interval spans more than this factor of speed is "not resolved"
RESOLUTION_FACTOR = 100.0

_V_LO, _V_HI = 1e-12, 1e9  # bracket of the speed root (m/s)


def _speed_for_film(film: Any, h: float, F_ehl: float) -> float:
    """The speed at which ``film.hc(v, F_ehl) = h`` (bracketed root in ``ln v``)."""
    from scipy.optimize import brentq

    from torlab.errors import NumericalError

    def g(lv: float) -> float:
        return math.log(float(film.hc(math.exp(lv), F_ehl))) - math.log(h)

    a, b = math.log(_V_LO), math.log(_V_HI)
    ga, gb = g(a), g(b)
    if ga > 0 or gb < 0:
        raise NumericalError(f"no speed between {_V_LO:g} and {_V_HI:g} m/s gives a film of "
                             f"{h:.3g} m")
    return math.exp(brentq(g, a, b, xtol=1e-12, rtol=1e-12))


def transition_speeds(scene: Scene, *, share_tol: float | None = None) -> dict[str, float | None]:
    """Speeds [m/s] where the regime of :func:`~torlab.model.loadshare.solve_load_sharing`
    changes (module docstring): ``boundary_to_mixed`` and ``mixed_to_full_film``.

    ``None`` for a transition that does not happen at a positive speed; an empty
    dict for smooth surfaces (no regimes but ``smooth``).
    """
    from torlab.model.asperity import F_n, F_n_inverse
    from torlab.model.mixed import SHARE_TOL, mixed_contact

    tol = SHARE_TOL if share_tol is None else float(share_tol)
    mc = mixed_contact(scene)
    if mc.asperity is None:
        return {}
    p = mc.contact.patch
    F = float(p.F)
    A = mc.asperity.coefficient * math.pi * p.a * p.b / F
    n, psi = mc.asperity.n, mc.asperity.sigma
    out: dict[str, float | None] = {}
    if A * float(F_n(n, 0.0)) <= tol:  # the asperities never carry a share of the load
        out["mixed_to_full_film"] = None  # (a very soft surface): full film at every speed
    else:
        t_f = float(F_n_inverse(n, np.array([tol / A]))[0])
        out["mixed_to_full_film"] = _speed_for_film(mc.film, t_f * psi, F * (1.0 - tol))
    if A * float(F_n(n, 0.0)) > 1.0 - tol:
        t_b = float(F_n_inverse(n, np.array([(1.0 - tol) / A]))[0])
        out["boundary_to_mixed"] = _speed_for_film(mc.film, t_b * psi, F * tol) \
            if t_b > 0 else None
    else:
        out["boundary_to_mixed"] = None
    return {k: out[k] for k in TRANSITIONS}


@dataclass
class _TransitionModel:
    """``ln v`` of each transition of the scene with the lubricant's parameters replaced
    (picklable: the draws may run on worker processes)."""

    scene: Scene
    keys: tuple[str, ...]

    def __call__(self, p: dict[str, float]) -> dict[str, np.ndarray]:
        from torlab.model.parameters import with_params

        v = transition_speeds(with_params(self.scene, p))
        return {k: np.asarray(math.log(v[k]) if v.get(k) else math.nan) for k in self.keys}


def transition_evidence(scene: Scene, speed_range: tuple[float, float] | None = None, *,
                        threshold: float = TRANSITION_PROBABILITY, seed: int = 0
                        ) -> dict[str, dict[str, Any]]:
    """Each regime transition with its 95 % interval, dominant parameters and verdict.

    Parameters
    ----------
    scene
        A validated lubricated scene (with ``roughness:``; smooth surfaces give ``{}``).
    speed_range
        The modelled speeds ``(v_min, v_max)`` [m/s] the verdict refers to.
    threshold
        Probability needed to call "within" / "outside the modelled speeds".
    seed
        Seed of the parameter draws (when the propagation samples).

    Returns
    -------
    dict
        ``{transition: {speed_m_s, low95_m_s, high95_m_s, status, method, parameters,
        dominant, p_within, verdict, notes}}`` (speeds ``None`` where the transition
        does not happen at a positive speed); ``status`` is ``exact``, ``resolved``
        or ``not resolved`` (module docstring).
    """
    from torlab.errors import NumericalError
    from torlab.model.bands import scene_uncertainty
    from torlab.model.parameters import LUBRICANT_KEYS
    from torlab.uncertainty import propagate

    v0 = transition_speeds(scene)
    if not v0:
        return {}
    su = scene_uncertainty(scene)
    live = tuple(k for k, v in v0.items() if v is not None)
    dist = None
    why = ""
    if su.missing and any(m in LUBRICANT_KEYS for m in su.missing):
        why = (f"{', '.join(m for m in su.missing if m in LUBRICANT_KEYS)} not determined by "
               "its fit")
    elif su.dist is not None:
        keep = [n for n in su.dist.names if n in LUBRICANT_KEYS]
        dist = su.dist.subset(keep) if keep else None
    band = None
    if dist is not None and live:
        try:
            band = propagate(_TransitionModel(scene, live), dist, seed=seed,
                             f0={k: np.asarray(math.log(v0[k])) for k in live})
        except NumericalError as e:
            why = f"the model fails within the parameters' uncertainty ({e})"
    out: dict[str, dict[str, Any]] = {}
    for key in TRANSITIONS:
        v = v0[key]
        e: dict[str, Any] = {"speed_m_s": v, "low95_m_s": v, "high95_m_s": v, "method": "none",
                             "parameters": [], "dominant": [], "p_within": None,
                             "verdict": "", "notes": []}
        if v is None:
            e.update(status="none", notes=[
                "the asperities carry the whole load only at v = 0: no boundary regime at a "
                "positive speed" if key == "boundary_to_mixed" else
                "the asperities carry less than the mixed regime's share of the load even in "
                "contact (a very soft surface): full film at every positive speed"])
            out[key] = e
            continue
        if why:
            e.update(status="not resolved", low95_m_s=None, high95_m_s=None,
                     notes=[f"not resolved: {why}"])
        elif band is None or band.method == "none":
            e.update(status="exact", notes=[
                "exact given the scene: none of the parameters it depends on (the lubricant's "
                "eta0, alpha, Z; roughness and contact are given) carries a fit covariance"])
        else:
            lo, hi = float(np.exp(band.low(key))), float(np.exp(band.high(key)))
            e.update(low95_m_s=lo, high95_m_s=hi, method=band.method,
                     parameters=list(band.names),
                     dominant=[{"parameter": n, "share": round(s, 4)}
                               for n, s in band.dominant(key)],
                     explained=round(band.explained(key), 4),
                     notes=list(band.notes))
            if not (math.isfinite(lo) and math.isfinite(hi)):
                e.update(status="not resolved", low95_m_s=None, high95_m_s=None)
                e["notes"].append("not resolved: the transition leaves the model's range in "
                                  "some parameter draws")
            elif hi / lo > RESOLUTION_FACTOR:
                e["status"] = "not resolved"
                e["notes"].append(f"not resolved: the 95 % interval spans a factor {hi / lo:.3g} "
                                  f"of speed (> {RESOLUTION_FACTOR:g})")
            else:
                e["status"] = "resolved"
        if speed_range is not None and e["status"] != "not resolved":
            a, b = (float(x) for x in speed_range)
            if band is not None and band.method != "none" and a > 0:
                pr = band.class_probabilities((math.log(a), math.log(b)), key)
                p_in = float(pr[1])
            else:
                p_in = float(a <= v <= b)
            e["p_within"] = p_in
            e["verdict"] = ("within the modelled speeds" if p_in >= threshold else
                            "outside the modelled speeds" if 1 - p_in >= threshold else
                            "undetermined")
        elif speed_range is not None:
            e["verdict"] = "undetermined"
        out[key] = e
    return out
