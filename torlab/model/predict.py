"""Predictions from a scene: traction curves (and Stribeck curves, :mod:`torlab.model.mixed`).

:func:`predict_traction` models only what the scene needs and says what it
modelled:

* a dry scene (no ``lubricant:``): Hertz + FASTSIM with the third-body layer,
  plus the contact temperature when the scene has ``thermal:``;
* a lubricated scene: see :mod:`torlab.model.mixed` (film, asperity load
  sharing, FASTSIM only where the asperities carry load).

The traction-curve trend after saturation (thesis H4.1) is classified by
:func:`classify_trend`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from torlab.model.contact import build_contact
from torlab.model.fastsim import boundary_traction

# the pieces traction predictions share live in torlab.model.prediction (torlab.model.mixed
# uses them too, without importing this module); re-exported here under their old names
from torlab.model.prediction import (
    TractionPrediction,
    _summary,
    _temperature_note,
    classify_trend,
    fastsim_grid,
    fastsim_problem,
)

__all__ = [
    "TractionPrediction",
    "classify_trend",
    "fastsim_problem",
    "predict_traction",
]


def predict_traction(scene: Any, creepage: Any, *, trend_tolerance: float = 0.01) -> TractionPrediction:
    """Predict ``mu`` against creepage for a scene.

    Parameters
    ----------
    scene
        A validated :class:`~torlab.scene.Scene`.
    creepage
        Creepages (fractions; SRR as a fraction), any sign.
    trend_tolerance
        Relative change after saturation below which the trend is neutral.

    Returns
    -------
    TractionPrediction
    """
    import pandas as pd

    if scene.lubricant is not None:
        from torlab.model.mixed import predict_traction_mixed

        return predict_traction_mixed(scene, creepage, trend_tolerance=trend_tolerance)
    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    if scene.boundary is None:
        from torlab.errors import TorlabInputError

        raise TorlabInputError("a dry scene (no lubricant:) needs a boundary: section "
                               "(mu_c1, mu_c2, L_mue, L_mup)", key="boundary")
    contact = build_contact(scene)
    prob = fastsim_problem(scene, contact)
    res = boundary_traction(prob, xi, fastsim_grid(scene))
    table = pd.DataFrame({"creepage": xi, "mu": res.mu, "mu_boundary": res.mu,
                          "adhesion_fraction": res.adhesion_fraction})
    if res.max_temperature_C is not None:
        table["max_temperature_C"] = res.max_temperature_C
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
