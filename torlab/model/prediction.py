"""What traction predictions share: the result type, the FASTSIM set-up of a scene, the
trend after saturation (thesis H4.1) and the summary.

Used by :mod:`torlab.model.predict` (dry scenes) and :mod:`torlab.model.mixed`
(lubricated scenes), so neither imports the other for them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.model.contact import ContactModel, build_contact
from torlab.model.fastsim import FastsimGrid, FastsimProblem, ThermalParams
from torlab.model.layer import LayerParams

__all__ = ["TractionPrediction", "classify_trend", "fastsim_grid", "fastsim_problem"]


@dataclass
class TractionPrediction:
    """A predicted traction curve.

    Attributes
    ----------
    table
        DataFrame with the scene-contract columns ``creepage`` (fraction) and
        ``mu``, and where the scene has them ``mu_boundary``, ``mu_ehl``,
        ``load_share_asperity``, ``film_thickness_m``, ``max_temperature_C``;
        also ``adhesion_fraction`` (load fraction still elastic).
    contact
        The resolved contact.
    modelled
        Human-readable list of what was modelled (and what was skipped, why).
    trend
        Trend after saturation (:func:`classify_trend`).
    summary
        Key numbers for ``summary.json``.
    """

    table: Any
    contact: ContactModel
    modelled: list[str]
    trend: dict[str, Any]
    summary: dict[str, Any] = field(default_factory=dict)


def fastsim_problem(scene: Any, contact: ContactModel | None = None) -> FastsimProblem:
    """The :class:`FastsimProblem` of a scene's boundary part."""
    contact = contact or build_contact(scene)
    b = scene.boundary
    layer = LayerParams(b.mu_c1, b.mu_c2, b.L_mue, b.L_mup, b.mu_c1_T, b.mu_c2_T)
    th = scene.thermal
    thermal = None if th is None else ThermalParams(
        th.conductivity, th.density, th.heat_capacity, th.partition, th.slip_velocity,
        th.tolerance, th.max_iterations)
    p = contact.patch
    return FastsimProblem(a=p.a, b=p.b, p0=p.p0, L1=contact.L1, layer=layer,
                          speed=scene.kinematics.speed,
                          ambient_temperature=scene.kinematics.ambient_temperature, thermal=thermal)


def fastsim_grid(scene: Any) -> FastsimGrid:
    """The FASTSIM grid of a scene's ``grid:`` section."""
    g = scene.grid
    return FastsimGrid(n=g.n, m=g.m, temperature_nodes=g.temperature_nodes)


def classify_trend(creepage: np.ndarray, mu: np.ndarray, *, saturation: float = 0.95,
                   tolerance: float = 0.01) -> dict[str, Any]:
    """Trend of the traction curve after saturation (thesis H4.1, Fig. 2.2).

    The saturation point is the smallest positive creepage at which ``|mu|``
    reaches ``saturation`` times its maximum over the curve; if it lies in the
    second half of the creepage range the curve has not levelled off
    (``not saturated``).  A straight line is fitted to ``|mu|`` over the second
    half of the range after saturation (so the knee of the curve does not tilt it);
    its change over that range relative to ``|mu|`` at its start is the trend:
    ``negative`` below ``-tolerance``, ``positive`` above ``+tolerance``,
    ``neutral`` between.  Fewer than two points in that second half (a sparse
    measured curve) give ``too few points`` rather than a line through the knee.

    Returns
    -------
    dict
        ``trend`` (``negative``/``neutral``/``positive``/``not saturated``/
        ``too few points``),
        ``saturation_creepage``, ``mu_saturation``, ``trend_from_creepage``,
        ``slope_per_unit_creepage``, ``relative_change``, ``tolerance``.
    """
    x = np.abs(np.asarray(creepage, dtype=float))
    y = np.abs(np.asarray(mu, dtype=float))
    keep = x > 0
    # negative creepages fold onto positive ones: one point per distinct |creepage|
    x, inv = np.unique(x[keep], return_inverse=True)
    y = np.bincount(inv, weights=y[keep]) / np.bincount(inv)
    out: dict[str, Any] = {"tolerance": tolerance, "saturation_fraction": saturation}
    if len(x) < 3 or y.max() <= 0:
        out.update(trend="not saturated", saturation_creepage=None, mu_saturation=None,
                   slope_per_unit_creepage=None, relative_change=None)
        return out
    k = int(np.argmax(y >= saturation * y.max()))
    xs, ys = x[k:], y[k:]
    out["saturation_creepage"] = float(x[k])
    out["mu_saturation"] = float(y[k])
    if len(xs) < 3 or x[k] > 0.5 * x[-1]:
        # a curve that reaches 95 % of its maximum only in the second half of the
        # range has not levelled off (a linear, film-dominated curve reaches it at 95 %)
        out.update(trend="not saturated", slope_per_unit_creepage=None, relative_change=None)
        return out
    # the trend is read on the second half of the post-saturation range, where the
    # approach to saturation itself (a tanh-like knee) no longer tilts the line
    mid = 0.5 * (x[k] + x[-1])
    tail = x >= mid
    if tail.sum() < 2:
        out.update(trend="too few points", slope_per_unit_creepage=None, relative_change=None)
        return out
    xs, ys = x[tail], y[tail]
    out["trend_from_creepage"] = float(xs[0])
    slope = float(np.polyfit(xs, ys, 1)[0])
    change = slope * (xs[-1] - xs[0]) / ys[0]
    trend = "negative" if change < -tolerance else "positive" if change > tolerance else "neutral"
    out.update(trend=trend, slope_per_unit_creepage=slope, relative_change=float(change))
    return out


def _temperature_note(loop: str, scene: Any) -> str:
    if loop == "off":
        return "contact temperature: not modelled (no thermal: section)"
    if loop == "single pass":
        b = scene.boundary
        why = ("the temperature coefficients are zero" if b.mu_c1_T == 0 and b.mu_c2_T == 0
               else "the heating changes the limits by less than 1e-6")
        return f"contact temperature: computed once, no tau-T loop ({why})"
    return "contact temperature: coupled to the limits, iterated to convergence"


def _summary(scene: Any, contact: ContactModel, modelled: list[str], trend: dict[str, Any],
             table: Any) -> dict[str, Any]:
    from torlab import __version__
    from torlab.model.plausible import result_notes

    mu = table["mu"].to_numpy()
    s = {
        "torlab_version": __version__,
        "scene": scene.name,
        "contact": contact.summary(),
        "modelled": modelled,
        "notes": list(contact.notes) + result_notes(table),
        "mu_max": float(np.max(np.abs(mu))) if len(mu) else None,
        "trend_after_saturation": trend,
    }
    if scene.boundary is not None:
        s["boundary"] = scene.boundary.model_dump()
    return s
