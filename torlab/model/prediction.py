"""What traction predictions share: the result type, the FASTSIM set-up of a scene, the
trend after saturation (thesis H4.1) and the summary.

Used by :mod:`torlab.model.predict` (dry scenes) and :mod:`torlab.model.mixed`
(lubricated scenes), so neither imports the other for them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.model.contact import ContactModel, build_contact
from torlab.model.fastsim import FastsimGrid, FastsimProblem
from torlab.model.flash import ThermalParams

if TYPE_CHECKING:
    from torlab.model.layers import LayerParams
    from torlab.scene import Scene

__all__ = ["NOT_SATURATED", "TOO_FEW_POINTS", "TREND_CLASSES", "TREND_PROBABILITY",
           "TREND_TOLERANCE", "TractionPrediction",
           "classify_trend", "fastsim_grid", "fastsim_problem", "rises_only", "scene_trend"]


@dataclass
class TractionPrediction:
    """A predicted traction curve.

    Attributes
    ----------
    table
        DataFrame (a dict of numpy columns with ``as_frame=False``) with the
        scene-contract columns ``creepage`` (fraction) and
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
    band
        The :class:`~torlab.uncertainty.Propagation` of the scene's fit
        covariance (None without one).
    """

    table: Any
    contact: ContactModel
    modelled: list[str]
    trend: dict[str, Any]
    summary: dict[str, Any] = field(default_factory=dict)
    band: Any = None


def fastsim_problem(scene: Scene, contact: ContactModel | None = None) -> FastsimProblem:
    """The :class:`FastsimProblem` of a scene's boundary part: corrected by the exact theory
    (``calibrated``) unless the scene's ``grid: method`` is ``fastsim-kalker``."""
    contact = contact or build_contact(scene)
    layer = scene.boundary.layer
    th = scene.thermal
    thermal = None if th is None else ThermalParams(
        th.conductivity, th.density, th.heat_capacity, th.partition, th.slip_velocity,
        th.tolerance, th.max_iterations)
    p = contact.patch
    return FastsimProblem(a=p.a, b=p.b, p0=p.p0, L1=contact.L1, layer=layer,
                          speed=scene.kinematics.speed,
                          ambient_temperature=scene.kinematics.ambient_temperature, thermal=thermal,
                          calibrated=scene.grid.method != "fastsim-kalker")


def fastsim_grid(scene: Scene) -> FastsimGrid:
    """The FASTSIM grid of a scene's ``grid:`` section."""
    g = scene.grid
    return FastsimGrid(n=g.n, m=g.m, temperature_nodes=g.temperature_nodes)


#: relative change of mu over the trend window (second half of the range after saturation)
#: within which the trend after saturation is neutral (thesis H4.1); configurable per call,
#: in protocols as ``reports.traction.trend_tolerance``
TREND_TOLERANCE = 0.01
#: probability a trend class needs to be called; below it the trend is ``undetermined``
TREND_PROBABILITY = 0.9
#: the trend classes in the order of :meth:`~torlab.uncertainty.Propagation.class_probabilities`
TREND_CLASSES = ("negative", "neutral", "positive")
#: the class of a curve that has not levelled off within its creepage range
NOT_SATURATED = "not saturated in this range"
#: the class of a curve with too few creepages to read a trend
TOO_FEW_POINTS = "too few points"
#: why a rise of an isothermal layer's curve is not a positive trend (``rises_only``)
RISES_ONLY_NOTE = ("an isothermal layer (no temperature effect modelled) only approaches its "
                   "plateau from below, so a rise after the saturation point means the curve "
                   "has not saturated in this range; it is not a positive characteristic "
                   "(thesis H4.1)")


def _fold(creepage: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Distinct positive ``|creepage|``, the point -> distinct index map, kept points, counts."""
    x = np.abs(np.asarray(creepage, dtype=float))
    keep = x > 0
    xu, inv = np.unique(x[keep], return_inverse=True)
    return xu, inv, keep, np.bincount(inv, minlength=xu.size)


def _relative_change(x: np.ndarray, y: np.ndarray) -> float:
    """Least-squares line through ``(x, y)``: its change over ``x`` relative to ``y[0]``."""
    xc = x - x.mean()
    slope = float(np.sum(xc * (y - y.mean())) / np.sum(xc * xc))
    return slope * (x[-1] - x[0]) / y[0]


def classify_trend(creepage: np.ndarray, mu: np.ndarray, *, saturation: float = 0.95,
                   tolerance: float = TREND_TOLERANCE, threshold: float = TREND_PROBABILITY,
                   uncertainty: Any = None, output: str = "mu",
                   measured: bool = False, rises_only: bool = False) -> dict[str, Any]:
    """Trend of the traction curve after saturation (thesis H4.1, Fig. 2.2), with its evidence.

    The saturation point is the smallest positive creepage at which ``|mu|``
    reaches ``saturation`` times its maximum over the curve; if it lies in the
    second half of the creepage range the curve has not levelled off
    (``not saturated in this range``).  A straight line is fitted to ``|mu|`` over the
    second half of the range after saturation (so the knee of the curve does not tilt it);
    its change over that range relative to ``|mu|`` at its start is the trend
    statistic: ``negative`` below ``-tolerance``, ``positive`` above
    ``+tolerance``, ``neutral`` between (:data:`TREND_TOLERANCE`, 1 %, by
    default).  Fewer than three creepages, or fewer than two points in that second
    half (a sparse measured curve), give ``too few points`` rather than a line through
    the knee.  A curve that can only rise towards its plateau (``rises_only``: an
    isothermal layer) and still rises is ``not saturated in this range``, not positive.

    With an uncertainty, each class gets its probability and a class is
    called only when its probability is at least ``threshold``
    (:data:`TREND_PROBABILITY`, 0.9); otherwise the trend is ``undetermined``
    and the probabilities say how it leans.  The statistic is evaluated on the
    window of the curve at the estimate (saturation point and trend window
    fixed), so it is a smooth function of the curve.

    Parameters
    ----------
    creepage, mu
        The curve (any sign; negative creepages fold onto positive ones).
    saturation
        Fraction of the maximum that counts as saturated.
    tolerance
        Relative change within which the trend is neutral.
    threshold
        Probability needed to call a class.
    uncertainty
        A :class:`~torlab.uncertainty.Propagation` of the predicted curve (the
        parameters' uncertainty, e.g. ``TractionPrediction.band``); its
        ``output`` is ``mu`` at the same creepages.
    output
        Name of ``mu`` among the propagation's outputs.
    measured
        A measured curve: the probabilities come from the scatter of the
        points about the trend line (Student t with ``n - 2`` degrees of
        freedom; three or more points in the window).
    rises_only
        The model's curve can only approach its plateau from below (an isothermal
        layer: no temperature effect modelled): the ``positive`` class is then called
        ``not saturated in this range`` (its probability is still the ``positive``
        entry of ``probabilities``), and ``note`` says why.

    Returns
    -------
    dict
        ``trend`` (``negative``/``neutral``/``positive``/``undetermined``/
        ``not saturated in this range``/``too few points``), ``trend_point`` (the class of
        the curve itself), ``probabilities`` (``{class: p}`` or None),
        ``probability_threshold``, ``basis`` (what the probabilities rest on),
        ``saturation_creepage``, ``mu_saturation``, ``trend_from_creepage``
        (None when no window), ``slope_per_unit_creepage``,
        ``relative_change`` and its ``relative_change_low95`` /
        ``relative_change_high95``, ``tolerance``, ``saturation_fraction``.
    """
    x, inv, keep, counts = _fold(creepage)
    y = np.bincount(inv, weights=np.abs(np.asarray(mu, dtype=float))[keep],
                    minlength=x.size) / np.maximum(counts, 1)
    out: dict[str, Any] = {"tolerance": tolerance, "saturation_fraction": saturation,
                           "probability_threshold": threshold, "probabilities": None,
                           "basis": "the curve alone (no uncertainty given)",
                           "trend_from_creepage": None, "relative_change_low95": None,
                           "relative_change_high95": None}
    if rises_only:
        out.update(rises_only=True, note=RISES_ONLY_NOTE)
    if len(x) < 3 or y.max() <= 0:
        cls = TOO_FEW_POINTS if len(x) < 3 else NOT_SATURATED
        out.update(trend=cls, trend_point=cls, saturation_creepage=None,
                   mu_saturation=None, slope_per_unit_creepage=None, relative_change=None)
        return out
    k = int(np.argmax(y >= saturation * y.max()))
    xs, ys = x[k:], y[k:]
    out["saturation_creepage"] = float(x[k])
    out["mu_saturation"] = float(y[k])
    if len(xs) < 3 or x[k] > 0.5 * x[-1]:
        # a curve that reaches 95 % of its maximum only in the second half of the
        # range has not levelled off (a linear, film-dominated curve reaches it at 95 %)
        out.update(trend=NOT_SATURATED, trend_point=NOT_SATURATED,
                   slope_per_unit_creepage=None, relative_change=None)
        return out
    # the trend is read on the second half of the post-saturation range, where the
    # approach to saturation itself (a tanh-like knee) no longer tilts the line
    mid = 0.5 * (x[k] + x[-1])
    tail = x >= mid
    if tail.sum() < 2:
        out.update(trend=TOO_FEW_POINTS, trend_point=TOO_FEW_POINTS,
                   slope_per_unit_creepage=None, relative_change=None)
        return out
    xs, ys = x[tail], y[tail]
    out["trend_from_creepage"] = float(xs[0])
    change = _relative_change(xs, ys)
    slope = change * ys[0] / (xs[-1] - xs[0])
    point = "negative" if change < -tolerance else "positive" if change > tolerance else "neutral"
    out.update(trend=point, trend_point=point, slope_per_unit_creepage=float(slope),
               relative_change=float(change))
    probs = None
    edges = (-tolerance, tolerance)
    if uncertainty is not None:
        mu_shape = np.asarray(mu).shape

        def stat(o: dict[str, np.ndarray]) -> float:
            m = np.abs(np.asarray(o[output], dtype=float).reshape(mu_shape))[keep]
            yy = np.bincount(inv, weights=m, minlength=x.size) / np.maximum(counts, 1)
            return _relative_change(xs, yy[tail])

        d = uncertainty.derive(stat)
        probs = d.class_probabilities(edges)
        out["relative_change_low95"] = float(np.ravel(d.low())[0])
        out["relative_change_high95"] = float(np.ravel(d.high())[0])
        out["basis"] = f"the parameters' uncertainty ({d.method} propagation)"
    elif measured and xs.size >= 3:
        from torlab._stats import t_cdf, t_ppf  # scipy.stats.t, without its import

        xc = xs - xs.mean()
        resid = ys - ys.mean() - slope * xc
        dof = xs.size - 2
        se_slope = math.sqrt(float(resid @ resid) / dof / float(xc @ xc))
        se = se_slope * (xs[-1] - xs[0]) / ys[0]
        if se > 0:
            cdf = t_cdf((np.array(edges) - change) / se, dof)
            probs = np.diff(np.concatenate(([0.0], cdf, [1.0])))
            tq = float(t_ppf(0.975, dof))
            out["relative_change_low95"] = float(change - tq * se)
            out["relative_change_high95"] = float(change + tq * se)
        else:
            probs = np.array([float(point == c) for c in TREND_CLASSES])
        out["basis"] = (f"the scatter of the {xs.size} points about the trend line "
                        f"(Student t, {dof} degrees of freedom)")
    elif measured:
        # two points give a line but no scatter: a measured trend without evidence is not called
        out["basis"] = "two points in the trend window: no scatter to judge the trend by"
        out["trend"] = "undetermined"
    if probs is not None:
        p = {c: float(v) for c, v in zip(TREND_CLASSES, probs, strict=True)}
        out["probabilities"] = p
        best = max(p, key=p.get)
        out["trend"] = best if p[best] >= threshold else "undetermined"
    if rises_only:
        for k in ("trend", "trend_point"):
            if out[k] == "positive":
                out[k] = NOT_SATURATED
    return out


def rises_only(scene: Any, *, temperature: bool | None = None) -> bool:
    """Whether the scene's modelled traction curve can only approach its plateau from below.

    True for a dry contact whose layer does not soften (its law's ``softens``: the strength
    never falls after the elastic limit; for Voce ``mu_c1 <= mu_c2``, Eqs. 5.26-5.29) and
    whose limits do not change with the contact's temperature in the
    model (no ``thermal:``, both temperature coefficients 0, or a model that does not
    compute the temperature).  Such a curve still rising after its saturation point has
    not saturated in the range (thesis H4.1); it is not positive.  A lubricated contact
    is not: the film's shear grows with the sliding speed.

    Parameters
    ----------
    scene
        The validated scene.
    temperature
        Whether the model computes the contact temperature (None: it does when the scene
        has ``thermal:``, FASTSIM's path and the exact solver alike).
    """
    b = scene.boundary
    if b is None or scene.lubricant is not None:
        return False
    lay, law = b.layer, b.layer.law
    heats = scene.thermal is not None if temperature is None else bool(temperature)
    if heats and any(np.any(np.asarray(c) != 0) for c in law.temperature_coefficients(lay)):
        return False
    return not law.softens(lay)


def scene_trend(scene: Any, creepage: np.ndarray, mu: np.ndarray, *,
                temperature: bool | None = None, **options: Any) -> dict[str, Any]:
    """The trend after saturation of a modelled curve of ``scene`` (thesis H4.1): the one
    classification every model's prediction uses (the dry and mixed traction curves, the
    creep forces, the exact solver): :func:`classify_trend` with ``rises_only`` from
    :func:`rises_only`, so an isothermal layer's rise is ``not saturated in this range``
    in every one of them.

    Parameters
    ----------
    scene
        The scene the curve was modelled for.
    creepage, mu
        The curve.
    temperature
        Whether the model computes the contact temperature (:func:`rises_only`).
    options
        :func:`classify_trend`'s keywords (``tolerance``, ``threshold``,
        ``uncertainty`` ...).
    """
    return classify_trend(creepage, mu, rises_only=rises_only(scene, temperature=temperature),
                          **options)


def temperature_note(loop: str, layer: LayerParams | None) -> str:
    """What ``modelled`` says of the contact temperature, from the FASTSIM result's
    ``temperature_loop`` and the boundary layer's values."""
    if loop == "off":
        return "contact temperature: not modelled (no thermal: section)"
    if loop == "single pass":
        lay = layer
        why = ("the temperature coefficients are zero"
               if not any(lay.law.temperature_coefficients(lay)) else "the heating changes the limits by less than 1e-6")
        return f"contact temperature: computed once, no tau-T loop ({why})"
    return "contact temperature: coupled to the limits, iterated to convergence"


def _summary(scene: Scene, contact: ContactModel, modelled: list[str], trend: dict[str, Any],
             table: Any) -> dict[str, Any]:
    from torlab import __version__
    from torlab.model.plausible import result_notes

    mu = np.asarray(table["mu"])
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
