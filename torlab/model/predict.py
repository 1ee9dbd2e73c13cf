"""Predictions from a scene: traction curves (and Stribeck curves, :mod:`torlab.model.mixed`).

:func:`predict_traction` models only what the scene needs and says what it
modelled:

* a dry scene (no ``lubricant:``): Hertz + FASTSIM with the third-body layer,
  plus the contact temperature when the scene has ``thermal:``;
* a lubricated scene: see :mod:`torlab.model.mixed` (film, asperity load
  sharing, FASTSIM only where the asperities carry load).

The traction-curve trend after saturation (thesis H4.1) is classified by
:func:`classify_trend`.  A scene that carries a fit's covariance (``fit:
covariance:`` from ``torlab fit``) gets a 95 % band and a trend with the
probability of each class (:mod:`torlab.model.bands`, :mod:`torlab.uncertainty`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from torlab.model.contact import build_contact
from torlab.model.fastsim import boundary_traction

# the pieces traction predictions share live in torlab.model.prediction (torlab.model.mixed
# uses them too, without importing this module); re-exported here under their old names
from torlab.model.prediction import (
    TREND_CLASSES,
    TREND_PROBABILITY,
    TREND_TOLERANCE,
    TractionPrediction,
    _summary,
    _temperature_note,
    classify_trend,
    fastsim_grid,
    fastsim_problem,
)

__all__ = [
    "TREND_CLASSES",
    "TREND_PROBABILITY",
    "TREND_TOLERANCE",
    "TractionPrediction",
    "classify_trend",
    "fastsim_problem",
    "predict_traction",
    "predict_traction_deferred",
]


def predict_traction(scene: Any, creepage: Any, *, trend_tolerance: float = TREND_TOLERANCE,
                     trend_threshold: float = TREND_PROBABILITY, band: bool = True,
                     seed: int = 0, as_frame: bool = True) -> TractionPrediction:
    """Predict ``mu`` against creepage for a scene.

    Parameters
    ----------
    scene
        A validated :class:`~torlab.scene.Scene`.
    creepage
        Creepages (fractions; SRR as a fraction), any sign.
    trend_tolerance
        Relative change after saturation below which the trend is neutral
        (:data:`TREND_TOLERANCE`).
    trend_threshold
        Probability a trend class needs when the scene carries a covariance
        (:data:`TREND_PROBABILITY`).
    band
        Propagate the scene's fit covariance (``fit: covariance:``) into a 95 %
        band (:mod:`torlab.model.bands`): ``mu_low95``/``mu_high95`` (and the
        film and temperature bands) in the table, ``band`` in the summary, the
        trend with its probabilities.  Without a covariance nothing is added
        but the summary's note.
    seed
        Seed of the band's parameter draws (when it samples).
    as_frame
        ``table`` as a pandas DataFrame (default); False: a dict of numpy columns
        (no pandas import: what a command that only writes the CSV needs).  With a
        band the table is a DataFrame either way.

    Returns
    -------
    TractionPrediction
    """
    if scene.lubricant is not None:
        from torlab.model.mixed import predict_traction_mixed

        pred = predict_traction_mixed(scene, creepage, trend_tolerance=trend_tolerance,
                                      as_frame=as_frame)
    else:
        pred = _predict_traction_dry(scene, creepage, trend_tolerance, as_frame)
    if band:
        _attach_band(scene, pred, trend_tolerance, trend_threshold, seed)
    return pred


def _attach_band(scene: Any, pred: TractionPrediction, tolerance: float, threshold: float,
                 seed: int, defer: bool = False) -> Any:
    """The band, its summary and the trend with probabilities (:mod:`torlab.model.bands`).

    With ``defer`` a band that samples is not finished: the :class:`_PendingBand` is
    returned (None otherwise).
    """
    fit = getattr(scene, "fit", None)
    if fit is None or not fit.covariances:  # nothing to propagate (the band code stays unloaded)
        pred.summary["band"] = {"method": "not computed", "notes": [NO_COVARIANCE]}
        return None
    from torlab.model.bands import band_summary, scene_uncertainty, traction_band

    su = scene_uncertainty(scene)
    if su.dist is None:
        pred.summary["band"] = band_summary(None, su)
        return None
    from torlab.errors import NumericalError

    if not hasattr(pred.table, "columns"):  # columns of as_frame=False: the band needs a frame
        import pandas as pd

        pred.table = pd.DataFrame(pred.table)
    xi = pred.table["creepage"].to_numpy(dtype=float)
    try:
        band = traction_band(scene, xi, pred.table, su, seed=seed, defer=defer)
    except NumericalError as e:
        _no_band(pred, su, e)
        return None
    if not hasattr(band, "center"):  # deferred: the draws are still to be evaluated
        return _PendingBand(pred, su, band, tolerance, threshold)
    _finish_band(pred, su, band, tolerance, threshold)
    return None


def _no_band(pred: TractionPrediction, su: Any, e: Exception) -> None:
    """The fit's uncertainty reaches parameters where the model has no solution: no band."""
    from torlab.model.bands import band_summary

    su.notes.insert(0, f"no band: {e}")
    pred.summary["band"] = band_summary(None, su)


def _finish_band(pred: TractionPrediction, su: Any, band: Any, tolerance: float,
                 threshold: float) -> None:
    """The trend with probabilities from the band, the band's columns and summary."""
    from torlab.errors import NumericalError
    from torlab.model.bands import add_band_columns, band_summary

    try:
        trend = classify_trend(pred.table["creepage"].to_numpy(dtype=float),
                               pred.table["mu"].to_numpy(dtype=float), tolerance=tolerance,
                               threshold=threshold, uncertainty=band)
    except NumericalError as e:
        _no_band(pred, su, e)
        return
    pred.band, pred.trend = band, trend
    add_band_columns(pred.table, pred.band)
    pred.summary["band"] = band_summary(pred.band, su)
    pred.summary["trend_after_saturation"] = pred.trend
    pred.modelled.append(f"uncertainty: 95 % band from the fit's covariance "
                         f"({pred.band.method} propagation of {', '.join(pred.band.names)})")


@dataclass
class _PendingBand:
    """A prediction whose sampled band waits for its draws (:func:`predict_traction_deferred`)."""

    pred: TractionPrediction
    su: Any
    sampling: Any  # torlab.uncertainty.PendingSampling
    tolerance: float
    threshold: float

    def __call__(self, results: list[Any]) -> TractionPrediction:
        """The prediction, finished as :func:`predict_traction` finishes it."""
        from torlab.errors import NumericalError

        try:
            band = self.sampling.finish(results)
        except NumericalError as e:
            _no_band(self.pred, self.su, e)
            return self.pred
        _finish_band(self.pred, self.su, band, self.tolerance, self.threshold)
        return self.pred


def predict_traction_deferred(scene: Any, creepage: Any, *,
                              trend_tolerance: float = TREND_TOLERANCE,
                              trend_threshold: float = TREND_PROBABILITY, seed: int = 0) -> Any:
    """:func:`predict_traction` (with its band) as a task whose draws others may evaluate.

    Returns the prediction -- or, when its band is sampled, a
    :class:`torlab.parallel.Deferred`: the band's blocks of parameter draws as
    independent tasks, and the step that finishes the prediction from their results
    (:func:`torlab.parallel.map_deferred` runs the blocks of several predictions on
    every worker).  The finished prediction is the one :func:`predict_traction` gives,
    bit for bit (the same draws, blocks and arithmetic).
    """
    pred = predict_traction(scene, creepage, trend_tolerance=trend_tolerance, band=False)
    pending = _attach_band(scene, pred, trend_tolerance, trend_threshold, seed, defer=True)
    if pending is None:
        return pred
    from torlab.parallel import Deferred

    fn, blocks = pending.sampling.tasks()
    return Deferred(fn, blocks, pending)


#: the band's note for a scene without a fit covariance (as :mod:`torlab.model.bands` says it)
NO_COVARIANCE = ("no band: the scene carries no fit covariance (its parameters are taken as "
                 "exact); predict with the params.yaml of a torlab fit to get one")


def _predict_traction_dry(scene: Any, creepage: Any, trend_tolerance: float,
                          as_frame: bool = True) -> TractionPrediction:
    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    if scene.boundary is None:
        from torlab.errors import TorlabInputError

        raise TorlabInputError("a dry scene (no lubricant:) needs a boundary: section "
                               "(mu_c1, mu_c2, L_mue, L_mup)", key="boundary")
    contact = build_contact(scene)
    prob = fastsim_problem(scene, contact)
    res = boundary_traction(prob, xi, fastsim_grid(scene))
    table: Any = {"creepage": xi, "mu": res.mu, "mu_boundary": res.mu,
                  "adhesion_fraction": res.adhesion_fraction}
    if res.max_temperature_C is not None:
        table["max_temperature_C"] = res.max_temperature_C
    if as_frame:
        import pandas as pd

        table = pd.DataFrame(table)
    modelled = [f"Hertz contact ({contact.patch.method})",
                "boundary friction: FASTSIM with the third-body layer (elastic + Voce)",
                "EHL film: not modelled (dry scene, no lubricant:)",
                "asperity load sharing: not modelled (dry scene)"]
    modelled.append(_temperature_note(res.temperature_loop, scene))
    trend = classify_trend(xi, res.mu, tolerance=trend_tolerance)
    summary = _summary(scene, contact, modelled, trend, table)
    if res.temperature_iterations is not None:
        summary["temperature_iterations_max"] = int(np.max(res.temperature_iterations))
    return TractionPrediction(table=table, contact=contact, modelled=modelled, trend=trend,
                              summary=summary)
