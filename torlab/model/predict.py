"""Predictions with their errors: the one place that adds bands, regime transitions and the
model's own error to a curve.

The physics gives a curve at the scene's values (:func:`torlab.model.traction.traction_curve`,
:func:`torlab.model.mixed.stribeck_curve`); a prediction here adds what is known of its
error, each stated in its summary:

* the **band**: a scene that carries a fit's covariance (``fit: covariance:`` from
  ``torlab fit``) gets the 95 % band of ``mu`` (and of the film thickness and the
  contact temperature where they are modelled), propagated through the same model
  (:mod:`torlab.model.bands`, :mod:`torlab.uncertainty`); the traction trend after
  saturation gets the probability of each class;
* the **regime transitions** of a rough lubricated scene's Stribeck curve, with their
  95 % intervals (:func:`torlab.model.regimes.transition_evidence`);
* the **theory error**: the error of the model itself against an exact solution
  (:func:`theory_error`; no model states one yet, and then nothing is added).

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

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from torlab.model.prediction import (
    TREND_PROBABILITY,
    TREND_TOLERANCE,
    TractionPrediction,
    classify_trend,
)
from torlab.model.traction import traction_curve

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from torlab.model.mixed import StribeckPrediction
    from torlab.scene import Scene

__all__ = ["NO_COVARIANCE", "predict_stribeck", "predict_traction", "predict_traction_deferred",
           "theory_error"]


def predict_traction(scene: Scene, creepage: ArrayLike, *,
                     trend_tolerance: float = TREND_TOLERANCE,
                     trend_threshold: float = TREND_PROBABILITY, band: bool = True,
                     seed: int = 0, as_frame: bool = True) -> TractionPrediction:
    """Predict ``mu`` against creepage for a scene, with its band.

    The curve is :func:`torlab.model.traction.traction_curve`'s; this adds its error.

    Parameters
    ----------
    scene
        A validated :class:`~torlab.scene.Scene`.
    creepage
        Creepages [-] (fractions; SRR as a fraction), any sign.
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
    pred = traction_curve(scene, creepage, trend_tolerance=trend_tolerance, as_frame=as_frame)
    if band:
        _attach_band(scene, pred, trend_tolerance, trend_threshold, seed)
    _attach_theory_error(scene, pred)
    return pred


def _attach_band(scene: Scene, pred: TractionPrediction, tolerance: float, threshold: float,
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
                               threshold=threshold, uncertainty=band,
                               rises_only=bool(pred.trend.get("rises_only")))
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


def predict_traction_deferred(scene: Scene, creepage: ArrayLike, *,
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
    pred = traction_curve(scene, creepage, trend_tolerance=trend_tolerance)
    pending = _attach_band(scene, pred, trend_tolerance, trend_threshold, seed, defer=True)
    _attach_theory_error(scene, pred)
    if pending is None:
        return pred
    from torlab.parallel import Deferred

    fn, blocks = pending.sampling.tasks()
    return Deferred(fn, blocks, pending)


#: the band's note for a scene without a fit covariance (as :mod:`torlab.model.bands` says it)
NO_COVARIANCE = ("no band: the scene carries no fit covariance (its parameters are taken as "
                 "exact); predict with the params.yaml of a torlab fit to get one")


def predict_stribeck(scene: Scene, speed: ArrayLike, creepage: float, *, band: bool = True,
                     seed: int = 0) -> StribeckPrediction:
    """Stribeck curve of a lubricated scene (thesis Eq. 5.47) with its band and its regime
    transitions.

    The curve is :func:`torlab.model.mixed.stribeck_curve`'s; this adds its error.

    Parameters
    ----------
    scene
        A validated scene with ``lubricant:``.
    speed
        Rolling speeds [m/s], >= 0.
    creepage
        Creepage [-] (fraction, SRR/100), any sign.
    band
        Propagate the scene's fit covariance into 95 % bands of ``mu``, the film
        thickness and the temperature (:mod:`torlab.model.bands`; columns
        ``mu_low95`` ...; ``band`` in the summary), and into 95 % intervals of the
        regime transition speeds (rough surfaces; ``transitions`` in the summary,
        :func:`torlab.model.regimes.transition_evidence`).
    seed
        Seed of the band's parameter draws (when it samples).

    Returns
    -------
    StribeckPrediction
    """
    import numpy as np

    from torlab.model.mixed import stribeck_curve

    pred = stribeck_curve(scene, speed, creepage)
    if band:
        _attach_stribeck_band(scene, pred, np.asarray(pred.table["speed_m_s"], dtype=float),
                              seed)
    _attach_theory_error(scene, pred)
    return pred


def _attach_stribeck_band(scene: Scene, pred: StribeckPrediction, v: Any, seed: int) -> None:
    """The band of a Stribeck curve, its summary and the regime transitions with their
    intervals (rough surfaces)."""
    from torlab.errors import NumericalError
    from torlab.model.bands import add_band_columns, band_summary, scene_uncertainty, stribeck_band

    table, summary, xi = pred.table, pred.summary, pred.creepage
    su = scene_uncertainty(scene)
    if su.dist is not None:
        try:
            pred.band = stribeck_band(scene, v, xi, table, su, seed=seed)
        except NumericalError as e:  # the uncertainty reaches where the model fails
            su.notes.insert(0, f"no band: {e}")
    if pred.band is not None:
        add_band_columns(table, pred.band)
        pred.modelled.append(f"uncertainty: 95 % band from the fit's covariance "
                             f"({pred.band.method} propagation of {', '.join(pred.band.names)})")
    summary["band"] = band_summary(pred.band, su)
    if scene.roughness is not None:  # regime transitions with their intervals
        from torlab.model.regimes import transition_evidence

        pos = v[v > 0]
        try:
            summary["transitions"] = transition_evidence(
                scene, (float(pos.min()), float(pos.max())) if pos.size else None, seed=seed)
        except NumericalError as e:
            summary["transitions"] = {"error": str(e)}


# ------------------------------------------------------------------------------ theory error
def theory_error(scene: Scene, pred: TractionPrediction | StribeckPrediction
                 ) -> dict[str, Any] | None:
    """The error of the model itself for this prediction, where a model states one.

    The band is the error of the parameters; this is the error of the theory at exact
    parameters (a simplified theory against an exact solution of the same contact, say
    FASTSIM against Kalker's exact theory).  It is the hook where a model module that
    can state such an error for a scene returns it: ``{"method": ..., "value": ...,
    "notes": [...]}``, added to the summary as ``theory_error``.  No model states one
    yet: None, and the summary is unchanged.
    """
    return None


def _attach_theory_error(scene: Scene, pred: TractionPrediction | StribeckPrediction) -> None:
    err = theory_error(scene, pred)
    if err is not None:
        pred.summary["theory_error"] = err
