"""Prediction bands: a fit's parameter uncertainty carried through ``torlab predict``.

A parameter file written by ``torlab fit`` carries the covariance of its
estimates (``fit: covariance:``, validated by :class:`torlab.scene.FitCovariance`).
When the scene has one, :func:`torlab.model.predict.predict_traction` and
:func:`torlab.model.predict.predict_stribeck` propagate it through the same model
(:func:`torlab.uncertainty.propagate`, which receives the model as a callable of the
parameters: linearised where that is accurate, sampled where it is not) and add the
95 % band of ``mu`` and, where the scene models them, of the film thickness and the
contact temperature:

=================================  =============================================
column                             band of
=================================  =============================================
``mu_low95``, ``mu_high95``        ``mu``
``film_thickness_low95_m``,        ``film_thickness_m`` (lubricated scenes)
``film_thickness_high95_m``
``max_temperature_low95_C``,       ``max_temperature_C`` (``thermal:``)
``max_temperature_high95_C``
=================================  =============================================

Which parameters are uncertain
------------------------------
Only the scene's own keys (:mod:`torlab.model.parameters`: ``boundary:``: its layer
law's parameters; ``lubricant:``: ``eta0``, ``alpha``, ``Z``) whose value in the scene is the
value the covariance belongs to; a value that a later file (or the user)
changed is taken as exact and the summary says so.  Parameters that cannot
change the prediction are left out (temperature coefficients without a
``thermal:`` section, a viscosity parameter the scene's laws do not use).
Several parameter files give independent blocks (one fit each; a later file's
parameter replaces an earlier file's).  A parameter the fit did not determine
(``not_determined``) that the prediction depends on means no band can be
drawn; the summary gives the reason instead.

Positive parameters (limits, lengths, viscosity parameters) are propagated on
a log scale, so no draw leaves their physical range.

Evaluating the draws
--------------------
A sampled traction band evaluates its draws many at a time (``evaluate_many``,
in fixed blocks, :mod:`torlab.uncertainty`): FASTSIM takes every (draw,
creepage) pair as one point with its own layer
(:func:`torlab.model.fastsim.boundary_traction_draws`), and a lubricated scene
solves its film and load sharing once for all the draws with the same
lubricant (:func:`torlab.model.mixed.traction_draws`).  Each draw goes through
the same iterations as alone (they stop per draw), so the band is the one the
draws give one by one, to round-off; a draw that fails is left out as before.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.model.parameters import (
    BOUNDARY_KEYS,
    LUBRICANT_KEYS,
    POSITIVE,
    with_params,
)
from torlab.uncertainty import ParameterDistribution, Propagation, propagate

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["BAND_COLUMNS", "SceneUncertainty", "add_band_columns", "band_summary",
           "scene_uncertainty", "stribeck_band", "traction_band"]
#: output -> (low column, high column) of the CSV
BAND_COLUMNS = {"mu": ("mu_low95", "mu_high95"),
                "film_thickness_m": ("film_thickness_low95_m", "film_thickness_high95_m"),
                "max_temperature_C": ("max_temperature_low95_C", "max_temperature_high95_C")}


@dataclass
class SceneUncertainty:
    """The uncertain parameters of a scene (from its ``fit: covariance:`` blocks).

    ``dist`` is None when there is nothing to propagate (no covariance, no
    parameter left) or when ``missing`` is not empty (a parameter the
    prediction depends on was not determined by its fit).
    """

    dist: ParameterDistribution | None
    notes: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    has_covariance: bool = False


def _used_keys(scene: Scene) -> dict[str, str]:
    """Scene keys that can change a prediction -> their section."""
    keys: dict[str, str] = {}
    if scene.boundary is not None:
        law = scene.boundary.layer.law
        for k in law.names:
            if k in law.temperature_names and scene.thermal is None:
                continue
            keys[k] = "boundary"
    lub = scene.lubricant
    if lub is not None:
        keys["eta0"] = "lubricant"
        if lub.alpha is not None and (lub.viscosity == "barus" or lub.film_law == "piezo"):
            keys["alpha"] = "lubricant"
        if lub.Z is not None and lub.viscosity == "roelands":
            keys["Z"] = "lubricant"
    return keys


def scene_uncertainty(scene: Scene) -> SceneUncertainty:
    """Collect the uncertain parameters of a scene (module docstring)."""
    fit = getattr(scene, "fit", None)
    blocks = fit.covariances if fit is not None else []
    if not blocks:
        return SceneUncertainty(None, ["no band: the scene carries no fit covariance (its "
                                       "parameters are taken as exact); predict with the "
                                       "params.yaml of a torlab fit to get one"])
    used = _used_keys(scene)
    notes: list[str] = []
    missing: list[str] = []
    taken: set[str] = set()
    parts: list[ParameterDistribution] = []
    for blk in reversed(blocks):  # later files take precedence
        keep: list[int] = []
        for i, n in enumerate(blk.names):
            if n not in used or n in taken:
                continue
            section = getattr(scene, used[n])
            val = getattr(section, n)
            ref = blk.values[i]
            if val is None or not math.isclose(float(val), ref, rel_tol=1e-9, abs_tol=1e-300):
                notes.append(f"{n} = {val!r} in the scene differs from the fitted value "
                             f"{ref:.6g} its covariance belongs to: taken as exact")
                taken.add(n)
                continue
            keep.append(i)
            taken.add(n)
        for n in blk.not_determined:
            if n in used and n not in taken:
                missing.append(n)
                taken.add(n)
        if not keep:
            continue
        names = [blk.names[i] for i in keep]
        cov = np.asarray(blk.matrix, dtype=float)[np.ix_(keep, keep)]
        vals = [blk.values[i] for i in keep]
        logs = [n for n, v in zip(names, vals, strict=True)
                if (n in blk.log_scale or n in POSITIVE) and v > 0]
        parts.append(ParameterDistribution.from_covariance(names, vals, cov, log_scale=logs,
                                                           dof=blk.dof))
    if missing:
        why = (f"no band: {', '.join(missing)} not determined by the fit (fix it in the fit, "
               "e.g. torlab fit traction --fix, and refit)")
        return SceneUncertainty(None, [why, *notes], missing, True)
    if not parts:
        why = "no band: none of the fitted parameters with a covariance enters this prediction"
        return SceneUncertainty(None, [why, *notes], [], True)
    return SceneUncertainty(ParameterDistribution.combine(parts[::-1]), notes, [], True)


def _outputs(table: Any, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    return {k: table[k].to_numpy(dtype=float) for k in names if k in table}


def traction_band(scene: Scene, creepage: np.ndarray, table: Any, su: SceneUncertainty, *,
                  seed: int = 0, start: np.ndarray | None = None, **options: Any
                  ) -> Propagation:
    """Band of a traction curve (``table`` is the curve at the estimate).

    A dry scene evaluates FASTSIM directly with the layer replaced; a
    lubricated one the whole mixed model (:func:`torlab.model.mixed.mixed_traction_curve`).
    ``start`` is the dry curve's converged flash-temperature rise (its
    ``temperature_rise``, :func:`torlab.model.traction.dry_traction_curve`'s ``state``),
    where the design points of a linear or second-order band start their temperature
    iteration (:meth:`DryTractionModel.evaluate_near`); None: from zero.
    ``options`` go to :func:`torlab.uncertainty.propagate` (``method``,
    ``n_samples``, ``defer`` ...: with ``defer=True`` a sampled band comes back as
    the :class:`~torlab.uncertainty.PendingSampling` of its draws).
    """
    from torlab.model.prediction import fastsim_grid, fastsim_problem

    xi = np.asarray(creepage, dtype=float)
    outs = tuple(k for k in BAND_COLUMNS if k in table)
    f0 = _outputs(table, outs)
    if scene.lubricant is None:
        model: Any = DryTractionModel(fastsim_problem(scene), fastsim_grid(scene), xi, outs,
                                      start)
    else:
        from torlab.model.mixed import mixed_traction_curve

        model = MixedTractionModel(mixed_traction_curve, scene, xi, (), outs)
    return propagate(model, su.dist, f0=f0, seed=seed, **options)


def stribeck_band(scene: Scene, speed: np.ndarray, creepage: float, table: Any,
                  su: SceneUncertainty, *, seed: int = 0) -> Propagation:
    """Band of a Stribeck curve (``table`` is the curve at the estimate)."""
    from torlab.model.mixed import stribeck_curve

    outs = tuple(k for k in BAND_COLUMNS if k in table)
    f0 = _outputs(table, outs)
    return propagate(_SceneModel(stribeck_curve, scene, np.asarray(speed, dtype=float),
                                 (creepage,), outs), su.dist, f0=f0, seed=seed)


# the models of the bands: picklable objects (their draws may be evaluated on worker
# processes, torlab.parallel), called with a parameter dict; the traction models also
# evaluate a block of draws in one call (``evaluate_many``, torlab.uncertainty._Block),
# each draw to round-off as the call with its parameters alone
@dataclass
class DryTractionModel:
    """FASTSIM of a dry scene with the layer's parameters replaced (one draw per call, or
    many: :meth:`evaluate_many`; the design points near the estimate:
    :meth:`evaluate_near`).

    ``start`` is the curve's converged flash-temperature rise at the estimate
    (creepages, strips, temperature nodes) [K], or None.  It is not pickled: the
    draws of a sampled band (evaluated on workers) start from zero, as alone.
    """

    prob: Any
    grid: Any
    xi: np.ndarray
    outs: tuple[str, ...]
    start: np.ndarray | None = field(default=None, repr=False)

    def __getstate__(self) -> dict[str, Any]:
        """Picklable without ``start`` (a sampled band's draws do not use it)."""
        return {**self.__dict__, "start": None}

    def __call__(self, p: dict[str, float]) -> dict[str, np.ndarray]:
        from torlab.model.fastsim import boundary_traction

        layer = self.prob.layer.replace(**{k: v for k, v in p.items() if k in BOUNDARY_KEYS})
        res = boundary_traction(replace(self.prob, layer=layer), self.xi, self.grid)
        out = {"mu": res.mu}
        if "max_temperature_C" in self.outs:
            out["max_temperature_C"] = res.max_temperature_C
        return out

    def evaluate_many(self, p: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], list[Any]]:
        """Every draw of ``p`` (``{name: (m,) array}``) in one vectorised FASTSIM call
        (:func:`torlab.model.fastsim.boundary_traction_draws`): outputs ``(m, n)`` and,
        per draw, None or the error it failed with."""
        return self._draws(p, None)

    def evaluate_near(self, p: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], list[Any]]:
        """:meth:`evaluate_many` for parameter sets near the estimate (the steps, probes
        and check points of a linear or second-order band, :mod:`torlab.uncertainty`):
        each point's temperature iteration starts from the estimate's solution
        (``start``) instead of zero.  It still stops only where the point's own residual
        is below the tolerance (:func:`torlab.model.flash.converge_flash_temperature_groups`),
        so the results are the same fixed points to that tolerance, reached in fewer
        steps (``tests/test_band_draws.py``: on the WFM-wet curve at two standard
        deviations both are within 0.05 K of the fixed point at a 1e-7 K tolerance).
        Without ``start`` it is :meth:`evaluate_many`."""
        return self._draws(p, self.start)

    def _draws(self, p: dict[str, np.ndarray], start: np.ndarray | None
               ) -> tuple[dict[str, np.ndarray], list[Any]]:
        from torlab.errors import ConvergenceError
        from torlab.model.fastsim import boundary_traction_draws

        res = boundary_traction_draws(self.prob, {k: v for k, v in p.items()
                                                  if k in BOUNDARY_KEYS}, self.xi, self.grid,
                                      start=start)
        out = {"mu": res.mu}
        if "max_temperature_C" in self.outs:
            out["max_temperature_C"] = res.max_temperature_C
        return out, [ConvergenceError(e) if e else None for e in res.errors]


@dataclass
class _SceneModel:
    """A curve of the scene with the parameters replaced: ``curve(scene, x, *args)`` (a
    module-level physics function: :func:`torlab.model.mixed.mixed_traction_curve` at
    creepages ``x``, :func:`torlab.model.mixed.stribeck_curve` at speeds ``x`` and one
    creepage), its ``outs`` columns."""

    curve: Callable[..., Any]
    scene: Scene
    x: np.ndarray
    args: tuple[Any, ...]
    outs: tuple[str, ...]

    def __call__(self, p: dict[str, float]) -> dict[str, np.ndarray]:
        return _outputs(self.curve(with_params(self.scene, p), self.x, *self.args).table,
                        self.outs)


@dataclass
class MixedTractionModel(_SceneModel):
    """The traction curve of a lubricated scene (:class:`_SceneModel` of
    :func:`~torlab.model.mixed.mixed_traction_curve`), which also evaluates many draws in
    one call (:meth:`evaluate_many`)."""

    def evaluate_many(self, p: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], list[Any]]:
        """The draws of ``p`` (``{name: (m,) array}``): those with the same lubricant
        parameters share one load-sharing solve and one FASTSIM call over their layers
        (:func:`torlab.model.mixed.traction_draws`); outputs ``(m, n)`` and, per draw,
        None or the error it failed with (an error of the shared part fails its draws)."""
        from torlab.errors import NumericalError, TorlabInputError
        from torlab.model.mixed import traction_draws

        m = int(np.broadcast_shapes(*(np.shape(v) for v in p.values()), (1,))[0])
        lub_keys = [k for k in LUBRICANT_KEYS if k in p]
        lub = np.stack([np.broadcast_to(np.asarray(p[k], dtype=float), (m,)) for k in lub_keys],
                       axis=1) if lub_keys else np.zeros((m, 0))
        layer_p = {k: np.broadcast_to(np.asarray(v, dtype=float), (m,))
                   for k, v in p.items() if k in BOUNDARY_KEYS}
        _, first, inv = np.unique(lub, axis=0, return_index=True, return_inverse=True)
        inv = inv.reshape(-1)
        out = {k: np.full((m, self.x.size), np.nan) for k in self.outs}
        errors: list[Any] = [None] * m
        for g in range(first.size):
            idx = np.flatnonzero(inv == g)
            scene = self.scene if not lub_keys else with_params(
                self.scene, {k: float(lub[first[g], j]) for j, k in enumerate(lub_keys)})
            try:
                res, errs = traction_draws(scene, self.x, {k: v[idx] for k, v in layer_p.items()})
                missing = [k for k in self.outs if k not in res]
                if missing:
                    raise NumericalError(f"{', '.join(missing)} not modelled at these "
                                         "parameters")
            except (NumericalError, TorlabInputError, FloatingPointError, ValueError) as e:
                for i in idx:
                    errors[i] = e
                continue
            for k in self.outs:
                out[k][idx] = res[k]
            for i, e in zip(idx, errs, strict=True):
                errors[i] = e
        return out, errors


def add_band_columns(table: Any, band: Propagation) -> Any:
    """The table with the ``*_low95`` / ``*_high95`` columns of :data:`BAND_COLUMNS`."""
    for out, (lo, hi) in BAND_COLUMNS.items():
        if out in band.center:
            table[lo] = band.low(out)
            table[hi] = band.high(out)
    return table


def band_summary(band: Propagation | None, su: SceneUncertainty) -> dict[str, Any]:
    """``summary.json``'s ``band``: method, check, dominant parameters, notes."""
    if band is None:
        return {"method": "not computed", "notes": list(su.notes)}
    s = band.summary()
    s["notes"] = list(su.notes) + s["notes"]
    s["columns"] = {k: list(v) for k, v in BAND_COLUMNS.items() if k in band.center}
    return s
