"""Traction curves of a scene: the physics, without its uncertainty.

:func:`traction_curve` models only what the scene needs and says what it modelled
(``modelled``):

* a dry scene (no ``lubricant:``): Hertz + FASTSIM with the third-body layer
  (:func:`dry_traction_curve`), plus the contact temperature when the scene has
  ``thermal:``;
* a lubricated scene: :func:`torlab.model.mixed.mixed_traction_curve` (film, asperity
  load sharing, FASTSIM only where the asperities carry load).

The trend after saturation (thesis H4.1) is classified on the curve alone
(:func:`~torlab.model.prediction.scene_trend`, as for every model's curve: an isothermal
layer's rise is 'not saturated in this range').  The prediction with its band, the
trend's probabilities and what else is known of its error is
:func:`torlab.model.predict.predict_traction`, which calls this.

References
----------
.. [1] Kalker, J. J. (1982). A fast algorithm for the simplified theory of rolling
   contact. Vehicle System Dynamics 11(1), 1-13. https://doi.org/10.1080/00423118208968684
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.model.contact import build_contact
from torlab.model.fastsim import boundary_traction
from torlab.model.prediction import (
    TREND_TOLERANCE,
    TractionPrediction,
    _summary,
    fastsim_grid,
    fastsim_problem,
    scene_trend,
    temperature_note,
)

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from torlab.scene import Scene

__all__ = ["dry_traction_curve", "traction_curve"]


def traction_curve(scene: Scene, creepage: ArrayLike, *,
                   trend_tolerance: float = TREND_TOLERANCE,
                   as_frame: bool = True, state: dict[str, Any] | None = None
                   ) -> TractionPrediction:
    """Predicted ``mu`` against creepage for a scene, without a band.

    Parameters
    ----------
    scene
        A validated :class:`~torlab.scene.Scene`.
    creepage
        Creepages [-] (fractions; SRR as a fraction), any sign.
    trend_tolerance
        Relative change after saturation below which the trend is neutral
        (:data:`~torlab.model.prediction.TREND_TOLERANCE`).
    as_frame
        ``table`` as a pandas DataFrame (default); False: a dict of numpy columns
        (no pandas import).
    state
        A dict that receives the solver's converged state where a band's evaluations
        can start from it (a dry scene: :func:`dry_traction_curve`); None: not kept.

    Returns
    -------
    TractionPrediction
        ``band`` is None; the summary has no ``band`` entry.
    """
    if scene.lubricant is not None:
        from torlab.model.mixed import mixed_traction_curve

        return mixed_traction_curve(scene, creepage, trend_tolerance=trend_tolerance,
                                    as_frame=as_frame)
    return dry_traction_curve(scene, creepage, trend_tolerance=trend_tolerance,
                              as_frame=as_frame, state=state)


def dry_traction_curve(scene: Scene, creepage: ArrayLike, *,
                       trend_tolerance: float = TREND_TOLERANCE,
                       as_frame: bool = True, state: dict[str, Any] | None = None
                       ) -> TractionPrediction:
    """Traction curve of a dry scene: Hertz contact and FASTSIM with the third-body layer
    (thesis 5.2.2, Eqs. 5.26-5.29), with the flash temperature under ``thermal:``.

    Parameters
    ----------
    scene
        A validated scene without ``lubricant:`` (with ``boundary:``).
    creepage
        Creepages [-] (fractions), any sign.
    trend_tolerance
        See :func:`~torlab.model.prediction.classify_trend`.
    as_frame
        ``table`` as a pandas DataFrame; False: a dict of numpy columns.
    state
        A dict that receives ``temperature_rise``: FASTSIM's converged flash-temperature
        rise (:attr:`~torlab.model.fastsim.BoundaryResult.temperature_rise`; None
        without ``thermal:``), where the band's evaluations at nearby parameters start
        their temperature iteration (:class:`torlab.model.bands.DryTractionModel`).

    Returns
    -------
    TractionPrediction
        ``creepage`` [-], ``mu`` [-], ``mu_boundary`` [-], ``adhesion_fraction`` [-]
        (and ``max_temperature_C`` [°C] with ``thermal:``); no band.
    """
    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    if scene.boundary is None:
        from torlab.errors import TorlabInputError

        raise TorlabInputError("a dry scene (no lubricant:) needs a boundary: section "
                               "(the third-body layer)", key="boundary")
    contact = build_contact(scene)
    prob = fastsim_problem(scene, contact)
    res = boundary_traction(prob, xi, fastsim_grid(scene))
    if state is not None:
        state["temperature_rise"] = res.temperature_rise
    table: Any = {"creepage": xi, "mu": res.mu, "mu_boundary": res.mu,
                  "adhesion_fraction": res.adhesion_fraction}
    if res.max_temperature_C is not None:
        table["max_temperature_C"] = res.max_temperature_C
    if as_frame:
        import pandas as pd

        table = pd.DataFrame(table)
    modelled = [f"Hertz contact ({contact.patch.method})",
                "boundary friction: FASTSIM with the third-body layer (elastic + "
                f"{scene.boundary.layer.law.short})",
                "EHL film: not modelled (dry scene, no lubricant:)",
                "asperity load sharing: not modelled (dry scene)"]
    modelled.append(temperature_note(res.temperature_loop, prob.layer))
    trend = scene_trend(scene, xi, res.mu, tolerance=trend_tolerance)
    summary = _summary(scene, contact, modelled, trend, table)
    if res.temperature_iterations is not None:
        summary["temperature_iterations_max"] = int(np.max(res.temperature_iterations))
    return TractionPrediction(table=table, contact=contact, modelled=modelled, trend=trend,
                              summary=summary)
