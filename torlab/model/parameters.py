"""The scene's model parameters: which keys of a scene a fit determines and a band varies.

A fit writes its estimates into a scene's ``boundary:`` (the third-body layer) and
``lubricant:`` (the viscosity law) sections (:meth:`torlab.fit.result.FitResult.to_scene_dict`);
a prediction band draws those same keys (:mod:`torlab.model.bands`,
:mod:`torlab.model.regimes`).  The key lists live here, once:

* :data:`BOUNDARY_KEYS`: the layer laws' parameters, from their registry
  (:mod:`torlab.model.layers`; Voce, thesis Eqs. 5.26-5.29: limits ``mu_c1``, ``mu_c2``
  [-], lengths ``L_mue``, ``L_mup`` [m], temperature coefficients ``mu_c1_T``,
  ``mu_c2_T`` [1/K]);
* :data:`LUBRICANT_KEYS`: the viscosity parameters (``eta0`` [Pa s], ``alpha`` [1/Pa],
  ``Z`` [-]; thesis Eqs. 5.38-5.39);
* :data:`POSITIVE`: those that must stay positive (a band draws them on a log scale).

:func:`with_params` puts values for these keys into a scene.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from torlab.model.layers import all_params

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["BOUNDARY_KEYS", "LUBRICANT_KEYS", "POSITIVE", "TEMPERATURE_KEYS", "with_params"]

#: keys of the scene's ``boundary:`` section (every layer law's parameters)
BOUNDARY_KEYS = tuple(all_params())
#: the layer's temperature coefficients (they change a prediction only with ``thermal:``)
TEMPERATURE_KEYS = tuple(n for n, p in all_params().items() if p.temperature_of is not None)
#: keys of the scene's ``lubricant:`` section that a viscosity fit determines
LUBRICANT_KEYS = ("eta0", "alpha", "Z")
#: parameters that must stay positive: propagated as ``ln p``
POSITIVE = frozenset({n for n, p in all_params().items() if p.positive} | {"eta0", "alpha", "Z"})


def with_params(scene: Scene, params: Mapping[str, float]) -> Scene:
    """The scene with ``boundary:`` / ``lubricant:`` values replaced (no re-validation:
    the values are a band's draws of validated estimates).

    Parameters
    ----------
    scene
        A validated scene.
    params
        ``{key: value}`` of :data:`BOUNDARY_KEYS` and :data:`LUBRICANT_KEYS` (SI); other
        keys are ignored.

    Returns
    -------
    Scene
        A copy; ``scene`` is unchanged.
    """
    b = {k: float(v) for k, v in params.items() if k in BOUNDARY_KEYS}
    lub = {k: float(v) for k, v in params.items() if k in LUBRICANT_KEYS}
    upd: dict[str, object] = {}
    if b:
        upd["boundary"] = scene.boundary.model_copy(update=b)
    if lub:
        upd["lubricant"] = scene.lubricant.model_copy(update=lub)
    return scene.model_copy(update=upd)
