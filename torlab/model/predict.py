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
* the **boundary method** and its **theory error**: the error of the model itself
  against Kalker's exact theory, at exact parameters (:func:`theory_error`): a separate
  figure beside the band, never added to it.  ``method`` (or the scene's
  ``grid: method``) chooses FASTSIM corrected by the exact theory (``fastsim``, the
  default, :mod:`torlab.model.calibrated`), Kalker's FASTSIM (``fastsim-kalker``, the
  thesis's model), the exact solver (``exact``, :mod:`torlab.model.exact`) or ``auto``:
  ``fastsim`` where its theory error is below the band's half-width at every point,
  ``exact`` elsewhere (:func:`choose_method`).

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

__all__ = ["NO_COVARIANCE", "choose_method", "predict_creep", "predict_stribeck",
           "predict_traction", "predict_traction_deferred", "theory_error", "with_method"]


def with_method(scene: Scene, method: str | None) -> Scene:
    """The scene with its boundary method (``grid: method``) set to ``method`` (None: as
    it is).

    Raises
    ------
    TorlabInputError
        An unknown method.
    """
    if method is None or method == scene.grid.method:
        return scene
    from torlab.model.calibrated import METHODS

    if method not in METHODS:
        from torlab._suggest import did_you_mean
        from torlab.errors import TorlabInputError

        raise TorlabInputError(f"unknown boundary method {method!r}: one of "
                               f"{', '.join(METHODS)}{did_you_mean(method, METHODS)}",
                               key="method")
    return scene.model_copy(update={"grid": scene.grid.model_copy(update={"method": method})})


def predict_traction(scene: Scene, creepage: ArrayLike, *,
                     trend_tolerance: float = TREND_TOLERANCE,
                     trend_threshold: float = TREND_PROBABILITY, band: bool = True,
                     seed: int = 0, as_frame: bool = True,
                     method: str | None = None) -> TractionPrediction:
    """Predict ``mu`` against creepage for a scene, with its band and its theory error.

    The curve is :func:`torlab.model.traction.traction_curve`'s (or, by the method,
    the exact solver's); this adds its errors.

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
        band, or by the exact solver, the table is a DataFrame either way.
    method
        The boundary method (``fastsim``, ``fastsim-kalker``, ``exact``, ``auto``);
        None: the scene's ``grid: method`` (default ``fastsim``).

    Returns
    -------
    TractionPrediction
        With ``summary["method"]`` (the method used, and the one asked for) and
        ``summary["theory_error"]``; the table's ``mu_theory_error_95``.
    """
    scene = with_method(scene, method)
    state: dict[str, Any] = {}  # the solver's state at the estimate, where the band starts
    pred = traction_curve(scene, creepage, trend_tolerance=trend_tolerance, as_frame=as_frame,
                          state=state)
    if band:
        _attach_band(scene, pred, trend_tolerance, trend_threshold, seed, state=state)
    _finish_method(scene, pred, lambda: _exact_traction(scene, creepage), trend_tolerance)
    _attach_theory_error(scene, pred)
    return pred


def predict_creep(scene: Scene, creepage: ArrayLike, lateral: float = 0.0, spin: float = 0.0,
                  *, method: str | None = None) -> TractionPrediction:
    """Creep forces of a dry scene along a creepage curve at one lateral creepage and
    spin (:func:`torlab.model.creep.predict_creep`), by the boundary method, with its
    theory error (``Fx_theory_error_95_N`` ... in the table, ``theory_error`` in the
    summary).  No band: the fit's covariance is propagated in longitudinal creepage
    only (:func:`predict_traction`); ``auto`` therefore uses the exact solver."""
    from torlab.model.creep import predict_creep as _creep

    scene = with_method(scene, method)
    pred = _creep(scene, creepage, lateral, spin)
    pred.summary["band"] = {"method": "not computed", "notes": [
        "no band: the fit's uncertainty is propagated for traction curves in longitudinal "
        "creepage (predict traction without --lateral/--spin)"]}

    def exact() -> Any:
        from torlab.model.exact.rolling import ExactGrid
        from torlab.model.exact.scene import predict_exact

        return predict_exact(scene, creepage, lateral, spin, ExactGrid(n=scene.grid.exact_n))

    _finish_method(scene, pred, exact, TREND_TOLERANCE)
    _attach_theory_error(scene, pred)
    return pred


def _attach_band(scene: Scene, pred: TractionPrediction, tolerance: float, threshold: float,
                 seed: int, defer: bool = False, state: dict[str, Any] | None = None) -> Any:
    """The band, its summary and the trend with probabilities (:mod:`torlab.model.bands`).

    With ``defer`` a band that samples is not finished: the :class:`_PendingBand` is
    returned (None otherwise).  ``state`` is the curve's solver state
    (:func:`~torlab.model.traction.traction_curve`), where the band's evaluations start.
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
        band = traction_band(scene, xi, pred.table, su, seed=seed, defer=defer,
                             start=(state or {}).get("temperature_rise"))
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
    if scene.grid.method in ("exact", "auto"):  # the choice needs the finished band
        return predict_traction(scene, creepage, trend_tolerance=trend_tolerance,
                                trend_threshold=trend_threshold, seed=seed)
    state: dict[str, Any] = {}
    pred = traction_curve(scene, creepage, trend_tolerance=trend_tolerance, state=state)
    pending = _attach_band(scene, pred, trend_tolerance, trend_threshold, seed, defer=True,
                           state=state)
    _finish_method(scene, pred, None, trend_tolerance)
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

    if scene.grid.method == "exact":
        from torlab.errors import TorlabInputError

        raise TorlabInputError("the exact solver models dry contacts: a Stribeck curve's "
                               "boundary part is FASTSIM's (method fastsim or fastsim-kalker)",
                               key="method")
    pred = stribeck_curve(scene, speed, creepage)
    if band:
        _attach_stribeck_band(scene, pred, np.asarray(pred.table["speed_m_s"], dtype=float),
                              seed)
    _finish_method(scene, pred, None, TREND_TOLERANCE)
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


# ------------------------------------------------------------------- method and theory error
def _half_width(table: Any) -> Any:
    """The band's half-width of ``mu`` per point (None without a band)."""
    import numpy as np

    if "mu_low95" not in table:
        return None
    return 0.5 * np.abs(np.asarray(table["mu_high95"], dtype=float)
                        - np.asarray(table["mu_low95"], dtype=float))


def choose_method(scene: Scene, pred: Any) -> tuple[str, str]:
    """What ``auto`` uses for a prediction made by the fast method: ``(method, why)``.

    ``fastsim`` where its theory error (:func:`theory_error`) is below the band's
    half-width at every point; ``exact`` elsewhere -- and where there is no band (no fit
    covariance, creep forces with lateral creepage or spin), since then nothing says the
    theory error is negligible.  The fast method stays where the exact solver does not
    model the scene: a lubricated contact.  A contact temperature that changes the
    layer's limits is modelled by both (:mod:`torlab.model.exact.thermal`), so such a
    scene follows the same rule.
    """
    import numpy as np

    if scene.lubricant is not None:
        return "fastsim", ("the exact solver models dry contacts; the boundary part of a "
                           "lubricated contact is FASTSIM's")
    err = _theory_error_points(scene, pred, "fastsim")
    hw = _half_width(pred.table)
    if err is None:
        return "fastsim", "no theory error stated for this prediction"
    if hw is None:
        return "exact", ("no band to compare the theory error with (no fit covariance): "
                         "the exact solver")
    worst = float(np.max(err - hw))
    if worst < 0:
        return "fastsim", (f"its theory error is below the band's half-width at every point "
                           f"(largest theory error {float(np.max(err)):.2g})")
    i = int(np.argmax(err - hw))
    return "exact", (f"its theory error {float(err[i]):.2g} exceeds the band's half-width "
                     f"{float(hw[i]):.2g} at creepage "
                     f"{float(np.asarray(pred.table['creepage'])[i]):.4g}")


def _exact_traction(scene: Scene, creepage: ArrayLike) -> Any:
    from torlab.model.exact.rolling import ExactGrid
    from torlab.model.exact.scene import predict_exact

    return predict_exact(scene, creepage, grid=ExactGrid(n=scene.grid.exact_n))


def _finish_method(scene: Scene, pred: Any, exact: Any, tolerance: float) -> None:
    """Apply the boundary method: the summary's ``method``; for ``exact`` (or ``auto``
    choosing it) the exact solver's curve in place of the fast one, the fast band moved
    onto it."""
    from torlab.model.calibrated import method_note

    asked = scene.grid.method
    used, why = asked, ""
    if asked == "exact" and scene.lubricant is not None:
        from torlab.errors import TorlabInputError

        raise TorlabInputError("the exact solver models dry contacts (no lubricant:): use "
                               "method fastsim or auto", key="method")
    if asked == "auto":
        used, why = choose_method(scene, pred)
    if exact is None and used == "exact":  # a prediction the exact solver does not make
        used, why = "fastsim", "the exact solver does not compute this prediction"
    if used == "exact":
        _use_exact(pred, exact(), tolerance)
    fast = "fastsim" if asked in ("exact", "auto") else asked
    banded = pred.summary.get("band", {}).get("method") not in (None, "not computed")
    pred.summary["method"] = {"method": used, "asked": asked, "why": why,
                              "band_method": fast if banded else None}
    pred.modelled.insert(1, method_note(used) + (f" (auto: {why})" if asked == "auto" else ""))


def _use_exact(pred: Any, ex: Any, tolerance: float) -> None:
    """Put the exact solver's curve ``ex`` (a TractionPrediction) in place of ``pred``'s,
    keeping the band's width about it."""
    import numpy as np
    import pandas as pd

    from torlab.model.prediction import classify_trend

    fast = pd.DataFrame(pred.table) if not hasattr(pred.table, "columns") else pred.table
    et = ex.table
    table = et.copy()
    for centre, cols in (("mu", ("mu_low95", "mu_high95")),
                         ("max_temperature_C", ("max_temperature_low95_C",
                                                "max_temperature_high95_C"))):
        for col in cols:
            if col in fast and centre in fast and centre in et:
                table[col] = et[centre].to_numpy() + (fast[col].to_numpy()
                                                      - fast[centre].to_numpy())
    if "mu_boundary" in fast and "mu_boundary" not in table:
        table.insert(2, "mu_boundary", et["mu"].to_numpy())
    pred.table = table
    xi = table["creepage"].to_numpy(dtype=float)
    pred.trend = classify_trend(xi, table["mu"].to_numpy(dtype=float), tolerance=tolerance)
    if "band" in pred.summary and pred.summary["band"].get("method") not in (None, "not computed"):
        pred.trend["basis"] = ("the exact curve alone: the band is the fast method's, moved "
                               "onto it (no probabilities)")
        pred.summary["band"].setdefault("notes", []).append(
            "the band's width is propagated through the fast method (FASTSIM corrected by "
            "the exact theory) and centred on the exact solver's curve")
    keep = {k: v for k, v in pred.summary.items() if k in ("band", "method")}
    pred.summary = dict(ex.summary, **keep)
    pred.summary["trend_after_saturation"] = pred.trend
    pred.summary["mu_max"] = float(np.max(np.abs(table["mu"].to_numpy())))
    pred.modelled = [m for m in ex.modelled]


def _theory_error_points(scene: Scene, pred: Any, method: str) -> Any:
    """The theory error (95 %) of ``mu`` per point of a prediction by a fast method
    (None where none is stated)."""
    import numpy as np

    from torlab.model.calibrated import creep_error, longitudinal_error
    from torlab.model.prediction import fastsim_problem

    if scene.boundary is None or ("mu_boundary" not in pred.table and scene.lubricant is not None):
        return None
    table = pred.table
    cal = method != "fastsim-kalker"
    if "Fy_N" in table:  # creep forces in three creepages
        from torlab.model.creep import creep_problem

        prob = creep_problem(scene)
        cols = [np.asarray(table[c], dtype=float) for c in
                ("creepage", "lateral", "spin_1_m", "Fx_N", "Fy_N", "Mz_Nm")]
        ex, _, _ = creep_error(prob, *cols, calibrated=cal,
                               adhesion=_column(table, "adhesion_fraction"))
        return ex / prob.load
    prob = fastsim_problem(scene)
    mub = np.asarray(table["mu_boundary"] if "mu_boundary" in table else table["mu"],
                     dtype=float)
    if "creepage" in table:
        xi = np.asarray(table["creepage"], dtype=float)
    else:  # a Stribeck curve: one creepage at every speed
        xi = np.full(mub.shape, float(pred.creepage))
    ok = np.isfinite(mub)
    e = np.zeros(mub.shape)
    adh = _column(table, "adhesion_fraction")
    e[ok] = longitudinal_error(prob, np.broadcast_to(xi, mub.shape)[ok], mub[ok],
                               calibrated=cal, adhesion=None if adh is None else adh[ok])
    if "load_share_asperity" in table:
        e = e * np.nan_to_num(np.asarray(table["load_share_asperity"], dtype=float))
    return e


def theory_error(scene: Scene, pred: TractionPrediction | StribeckPrediction
                 ) -> dict[str, Any] | None:
    """The error of the boundary method itself for this prediction, against Kalker's
    exact theory, at exact parameters.

    The band is the error of the parameters; this is the error of the theory: FASTSIM
    against the exact theory (:func:`torlab.model.calibrated.longitudinal_error`,
    :func:`~torlab.model.calibrated.creep_error`), or the exact solver's discretisation
    error (Richardson from two grids).  Added to the summary as ``theory_error``
    (``method``, ``theory_error_95``: the largest over the curve, in ``mu``;
    ``relative_95``: the largest relative to ``|mu|``; ``basis``, ``notes``) and to the
    table as ``mu_theory_error_95`` (creep forces: ``Fx/Fy_theory_error_95_N``,
    ``Mz_theory_error_95_Nm``).  None where no error is stated (no boundary part).
    """
    import numpy as np

    method = pred.summary.get("method", {}).get("method", scene.grid.method)
    table = pred.table
    notes: list[str] = []
    if method == "exact":
        e = np.asarray(table["mu_x_error"], dtype=float)
        basis = ("the exact solver's discretisation error: Richardson's rule from its two "
                 "grids (docs/model/exact.md)")
        if "max_temperature_C" in table:
            notes.append("the contact temperature is the exact solver's (Ertz-Knothe on its "
                         "grid, coupled to the limits on both grids): the Richardson estimate "
                         "covers the coupled solution; the coupling's tolerance on the "
                         "temperature is not added")
        if "Fx_error_N" in table:
            extra = {"Fx_theory_error_95_N": table["Fx_error_N"],
                     "Fy_theory_error_95_N": table["Fy_error_N"],
                     "Mz_theory_error_95_Nm": table["Mz_error_Nm"]}
        else:
            extra = {}
    else:
        e = _theory_error_points(scene, pred, method)
        if e is None and scene.lubricant is not None:
            n = len(table["mu"])
            e = np.zeros(n)
            notes.append("the asperities carry no load here: the boundary method does not "
                         "enter; the film model's own error is not stated")
        if e is None:
            return None
        extra = {}
        if "Fy_N" in table:
            from torlab.model.calibrated import creep_error
            from torlab.model.creep import creep_problem

            cols = [np.asarray(table[c], dtype=float) for c in
                    ("creepage", "lateral", "spin_1_m", "Fx_N", "Fy_N", "Mz_Nm")]
            ex, ey, ez = creep_error(creep_problem(scene), *cols,
                                     calibrated=method != "fastsim-kalker",
                                     adhesion=_column(table, "adhesion_fraction"))
            extra = {"Fx_theory_error_95_N": ex, "Fy_theory_error_95_N": ey,
                     "Mz_theory_error_95_Nm": ez}
        basis = ("FASTSIM corrected by Kalker's exact theory: the calibration tables' own "
                 "error and the error measured where the correction is carried over "
                 "(docs/model/boundary.md)" if method != "fastsim-kalker" else
                 "Kalker's FASTSIM: the correction by the exact theory it leaves out "
                 "(torlab.model.calibrated), with that correction's own error")
        if scene.thermal is not None:
            notes.append("the contact temperature is FASTSIM's: the correction changes the "
                         "forces, not the heat flux")
        if scene.lubricant is not None:
            notes.append("lubricated contact: the boundary part's error, weighted by the "
                         "asperities' load share; the film's model error is not stated")
    mu = np.abs(np.asarray(table["mu"], dtype=float))
    e = np.asarray(e, dtype=float)
    fin = np.isfinite(e)
    rel = np.where(mu > 1e-12, e / np.where(mu > 1e-12, mu, 1.0), 0.0)
    out = {"method": method,
           "theory_error_95": float(np.max(e[fin])) if fin.any() else None,
           "relative_95": float(np.max(rel[fin])) if fin.any() else None,
           "basis": basis, "notes": notes}
    hw = _half_width(table)
    if hw is not None and fin.any():
        out["band_half_width_min"] = float(np.min(hw))
    out["columns"] = ["mu_theory_error_95", *extra]
    _set_column(pred, "mu_theory_error_95", e)
    for k, v in extra.items():
        _set_column(pred, k, np.asarray(v, dtype=float))
    return out


def _column(table: Any, name: str) -> Any:
    """A column as a float array (None where the table has none)."""
    import numpy as np

    return np.asarray(table[name], dtype=float) if name in table else None


def _set_column(pred: Any, name: str, values: Any) -> None:
    if hasattr(pred.table, "columns"):
        pred.table[name] = values
    else:
        pred.table[name] = values


def _attach_theory_error(scene: Scene, pred: TractionPrediction | StribeckPrediction) -> None:
    err = theory_error(scene, pred)
    if err is not None:
        pred.summary["theory_error"] = err
