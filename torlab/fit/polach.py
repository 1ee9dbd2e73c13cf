"""Polach's parameters from torlab's predicted creep forces of a measured product.

A fitted TOR product (its third-body layer, and the temperature coefficients if the
scene has ``thermal:``) gives torlab's creep forces (:mod:`torlab.model.creep`);
:func:`fit_polach` finds Polach's ``mu0, A, B, kA, kS`` (:mod:`torlab.model.polach`)
that reproduce them over a stated range of creepage and rolling speed, so the
product's behaviour can be handed to any vehicle-dynamics code that accepts
Polach's law.

* Data: ``mu_x = Fx/N`` of torlab's model on the grid creepage x speed (longitudinal
  creepage: where Polach's parameters are identified and where traction and braking
  are decided), optionally with lateral creepage and spin points (then ``mu_y`` too).
* Fit: bounded least squares (``scipy.optimize.least_squares``, trust-region
  reflective) in ``mu0, A, B, kA, kS`` with ``0 < kA, kS <= 1``, ``A > 0``,
  ``B >= 0``; start from the data (``mu0`` at the curve's maximum, ``kA = kS`` from the
  initial slope against Kalker's, ``A`` from the fall after the maximum).
* Uncertainty: the linearised covariance ``s^2 (J^T J)^-1``; it describes how well the
  five numbers pin down torlab's curve, not a measurement's scatter (the data are a
  model's, without noise): the intervals are those of the approximation.
* Fit error: the curve (``data``: torlab, Polach, residual per point) and the numbers
  (RMS and largest residual in ``mu``).  Polach's ``kS <= kA`` is checked.
* The layer's uncertainty (:func:`fit_polach_scene`): when the product's parameter
  file carries its fit's covariance (``fit: covariance:``), the layer's parameters
  are drawn from it as for the traction bands (:func:`torlab.model.bands.scene_uncertainty`,
  :func:`torlab.uncertainty.propagate` with ``method="sampling"``: seeded draws, positive
  parameters on the log scale, evaluated in the fixed blocks and rounds of the executor
  in use, so serial and parallel runs give the same numbers), Polach's law is refitted
  to torlab's curve of each drawn layer, and the 2.5 % and 97.5 % percentiles of each
  refitted parameter are its 95 % interval (a percentile interval is the same on the
  log scale and on the natural one).  The method, the draws, the failed draws, the
  layer parameters that dominate (regression shares of the variance) and the
  correlation of each Polach parameter with each drawn layer parameter are reported in
  ``meta["layer_uncertainty"]``, apart from the approximation's intervals above.

Without ``thermal:`` torlab's forces do not depend on speed, while Polach's depend
on the slip velocity ``s V``: at several speeds the fit then compromises, which the
residuals show; ``B`` is determined only where the curve falls after its maximum.

References
----------
.. [1] Polach, O. (2005). Creep forces in simulations of traction vehicles running on
   adhesion limit. Wear 258(7-8), 992-1000. https://doi.org/10.1016/j.wear.2004.03.046
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import FitError, TorlabInputError
from torlab.fit.result import FitResult, covariance_from_jacobian
from torlab.model.creep import CreepGrid, CreepProblem, creep_forces
from torlab.model.polach import PolachParams, polach_contact, polach_forces

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["NAMES", "N_DRAWS", "fit_polach", "fit_polach_data", "fit_polach_scene",
           "layer_interval_table", "layer_uncertainty", "polach_data"]

NAMES = ("mu0", "A", "B", "kA", "kS")
_LOWER = np.array([1e-4, 1e-3, 0.0, 1e-4, 1e-4])
_UPPER = np.array([3.0, 5.0, 1e3, 1.0, 1.0])
#: layer draws of the Polach refit by default (``--draws``): a fit takes about 0.1 s, so
#: 200 draws keep 'torlab fit polach' near half a minute on two busy cores (docs/model/
#: boundary.md); the percentiles of 200 draws place a 95 % edge to about 0.2 standard
#: deviations
N_DRAWS = 200
#: fewer draws than this place a 95 % percentile interval poorly (a note says so)
_FEW_DRAWS = 100
#: the report's wording when the layer's uncertainty is not carried
NOT_CARRIED = "layer uncertainty not carried"


def polach_data(problem: CreepProblem, creepage: Any, speed: Any, *, lateral: Any = None,
                spin: Any = None, grid: CreepGrid | None = None, exact: Any = None,
                shift: Any = None) -> Any:
    """torlab's creep forces on the fit grid: a long DataFrame.

    Columns ``creepage, lateral, spin_1_m, speed_m_s, mu_x, mu_y`` (``mu = F/N``); one
    row per (creepage, speed), plus, where given, the lateral creepages and spins at
    each creepage and speed.  FASTSIM (corrected by the exact theory where
    ``problem.calibrated``), or with ``exact`` -- ``(ExactContact, ExactGrid)`` -- Kalker's
    exact theory (the same forces at every speed unless the contact temperature enters
    the layer's limits, then solved at each speed; columns ``mu_x_error``,
    ``mu_y_error``, its discretisation errors).  ``shift`` (rows x 2) is added to
    ``mu_x, mu_y`` (a layer draw moved onto the exact theory, :func:`layer_uncertainty`).
    """
    from dataclasses import replace

    import pandas as pd

    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    v = np.atleast_1d(np.asarray(speed, dtype=float))
    if xi.size < 3:
        raise TorlabInputError("a Polach fit needs at least three creepages", key="creepage")
    if np.any(v <= 0) or not np.all(np.isfinite(v)):
        raise TorlabInputError("speeds must be positive and finite", key="speed")
    et = np.atleast_1d(np.asarray(lateral if lateral is not None else [0.0], dtype=float))
    ph = np.atleast_1d(np.asarray(spin if spin is not None else [0.0], dtype=float))
    X, E, P = (g.ravel() for g in np.meshgrid(xi, et, ph, indexing="ij"))
    rows = []
    ex = None
    if exact is not None:
        from torlab.model.exact.rolling import exact_creep_forces

        if not exact[0].coupled:  # the same forces at every speed
            ex = exact_creep_forces(exact[0], X, E, P, exact[1])
    for vv in v:
        if exact is not None and exact[0].coupled:  # the heating, and so the forces, follow v
            ex = exact_creep_forces(exact[0].at_speed(float(vv)), X, E, P, exact[1])
        if ex is not None:
            rows.append(pd.DataFrame({"creepage": X, "lateral": E, "spin_1_m": P,
                                      "speed_m_s": vv, "mu_x": ex.mu_x, "mu_y": ex.mu_y,
                                      "mu_x_error": ex.Fx_error / ex.load,
                                      "mu_y_error": ex.Fy_error / ex.load}))
            continue
        pv = replace(problem, speed=float(vv))
        r = creep_forces(pv, X, E, P, grid)
        rows.append(pd.DataFrame({"creepage": X, "lateral": E, "spin_1_m": P,
                                  "speed_m_s": vv, "mu_x": r.mu_x, "mu_y": r.mu_y}))
    df = pd.concat(rows, ignore_index=True)
    if shift is not None:
        sh = np.asarray(shift, dtype=float)
        df["mu_x"] = df["mu_x"].to_numpy() + sh[:, 0]
        df["mu_y"] = df["mu_y"].to_numpy() + sh[:, 1]
    return df


def _start(df: Any, contact: Any) -> np.ndarray:
    # the start values from the curve nearest to pure longitudinal creepage (the fit range
    # need not hold lateral = spin = 0: '--lateral 0.005' alone is a range of its own)
    e0 = df["lateral"].to_numpy()[np.argmin(np.abs(df["lateral"].to_numpy()))]
    p0 = df["spin_1_m"].to_numpy()[np.argmin(np.abs(df["spin_1_m"].to_numpy()))]
    lon = df[(df["lateral"] == e0) & (df["spin_1_m"] == p0)]
    v0 = lon["speed_m_s"].min()
    c = lon[lon["speed_m_s"] == v0].sort_values("creepage")
    x = c["creepage"].to_numpy()
    y = np.hypot(c["mu_x"].to_numpy(), c["mu_y"].to_numpy())
    k = int(np.argmax(y))
    mu0 = max(float(y[k]), 1e-3)
    kal = contact.G_C11 * contact.a * contact.b / contact.Q  # Kalker's slope of mu_x
    pos = (x > 0) & (y < 0.3 * mu0)
    slope = float(np.median(y[pos] / x[pos])) if pos.any() else kal
    kk = float(np.clip(slope / kal, 1e-3, 1.0))
    tail = y[-1] / mu0
    A = float(np.clip(tail, 0.05, 1.0))
    B = 0.0 if A > 0.98 else 1.0 / max(float(x[-1] * v0), 1e-6)
    return np.array([mu0 * 1.02, A, B, kk, kk])


def fit_polach(problem: CreepProblem, creepage: Any, speed: Any, *, lateral: Any = None,
               spin: Any = None, grid: CreepGrid | None = None, source: str = "",
               ordered: bool = True, exact: Any = None, shift: Any = None) -> FitResult:
    """Fit Polach's ``mu0, A, B, kA, kS`` to torlab's creep forces of ``problem``.

    Parameters
    ----------
    problem
        The contact and the fitted product (:func:`torlab.model.creep.creep_problem`).
    creepage
        Longitudinal creepages of the fit range (fractions, >= 3 values).
    speed
        Rolling speeds [m/s] of the fit range.
    lateral, spin
        Optional lateral creepages and spins [1/m] added at each creepage and speed
        (then ``mu_y`` is fitted too).
    grid
        Resolution of torlab's creep-force scheme.
    source
        Label for the provenance (scene name).
    ordered
        Keep Polach's ``kS <= kA`` (fitted as ``kA`` and ``kS/kA`` in (0, 1]); False lets
        both range over (0, 1] (then a violation is reported).
    exact, shift
        torlab's forces by Kalker's exact theory, or FASTSIM's shifted
        (:func:`polach_data`).

    Returns
    -------
    FitResult
        ``kind="polach"``; ``data`` holds per point ``component, creepage, lateral,
        spin_1_m, speed_m_s, curve, mu_torlab, mu_polach, residual``; ``meta`` the fit
        range, the RMS and the largest residual.

    Raises
    ------
    TorlabInputError
        Too few creepages, bad speeds, spin without the contact shape.
    FitError
        The optimiser failed.
    """
    df = polach_data(problem, creepage, speed, lateral=lateral, spin=spin, grid=grid,
                     exact=exact, shift=shift)
    res = fit_polach_data(df, polach_contact(problem), source=source, ordered=ordered)
    lay = problem.layer
    if len(np.unique(df["speed_m_s"])) > 1 and (
            problem.thermal is None or not any(lay.law.temperature_coefficients(lay))):
        res.warnings.append(
            "torlab's forces do not depend on speed here (no thermal: section or zero "
            "temperature coefficients) while Polach's depend on the slip velocity s V: the fit "
            "compromises between the speeds (see the residuals per speed)")
    return res


def fit_polach_data(df: Any, contact: Any, *, source: str = "", ordered: bool = True  # noqa: C901 (each input form of a measured creep curve and each fixed parameter is a case)
                    ) -> FitResult:
    """Fit Polach's law to creep forces given as a table (see :func:`polach_data`).

    ``df`` has columns ``creepage, lateral, spin_1_m, speed_m_s, mu_x, mu_y`` (``mu = F/Q``);
    ``contact`` is Polach's :class:`~torlab.model.polach.PolachContact`.  ``mu_y`` is
    fitted where any lateral creepage or spin is non-zero.
    """
    import pandas as pd
    from scipy.optimize import least_squares

    N = contact.Q
    use_y = bool(np.any(df["lateral"] != 0) or np.any(df["spin_1_m"] != 0))
    X, E, P, V = (df[c].to_numpy() for c in ("creepage", "lateral", "spin_1_m", "speed_m_s"))
    target = df["mu_x"].to_numpy()
    if use_y:
        target = np.concatenate([target, df["mu_y"].to_numpy()])
    n_eval = [0]

    def model(p: np.ndarray) -> np.ndarray:
        n_eval[0] += 1
        fx, fy = polach_forces(PolachParams(*p), contact, X, E, P, V)
        out = fx / N
        return np.concatenate([out, fy / N]) if use_y else out

    def resid(p: np.ndarray) -> np.ndarray:
        return model(p) - target

    # internal parameters: kS as the fraction q = kS/kA when ordered
    def to_p(t: np.ndarray) -> np.ndarray:
        return np.array([t[0], t[1], t[2], t[3], t[4] * t[3] if ordered else t[4]])

    x0 = _start(df, contact)
    if ordered:
        x0[4] = 1.0
    x0 = np.clip(x0, _LOWER + 1e-9, _UPPER - 1e-9)

    def resid_t(t: np.ndarray) -> np.ndarray:
        return resid(to_p(t))

    try:
        sol = least_squares(resid_t, x0, bounds=(_LOWER, _UPPER), method="trf", x_scale="jac",
                            xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
    except (ValueError, FloatingPointError) as e:  # pragma: no cover - defensive
        raise FitError(f"Polach fit failed: {e}") from None
    if not np.all(np.isfinite(sol.x)):
        raise FitError("Polach fit failed: non-finite parameters")
    t = sol.x
    p = to_p(t)
    r = sol.fun
    cov_t, _ = covariance_from_jacobian(sol.jac, r, len(NAMES))
    # a parameter at its bound is held there by the constraint: its interval is not a
    # least-squares one
    at_bound = (np.abs(t - _LOWER) < 1e-8 * np.maximum(1, np.abs(_LOWER))) | \
        (np.abs(t - _UPPER) < 1e-8 * np.maximum(1, np.abs(_UPPER)))
    for i in np.flatnonzero(at_bound):
        cov_t[i, :] = np.inf
        cov_t[:, i] = np.inf
    Jt = np.eye(len(NAMES))
    if ordered:
        Jt[4, 3], Jt[4, 4] = t[4], t[3]
    with np.errstate(invalid="ignore"):
        cov = Jt @ np.where(np.isfinite(cov_t), cov_t, 0.0) @ Jt.T
    inf_rows = ~np.isfinite(np.diag(cov_t))
    for i in range(len(NAMES)):
        if np.any(inf_rows[np.flatnonzero(Jt[i])]):
            cov[i, :] = np.inf
            cov[:, i] = np.inf
    warnings: list[str] = []
    labels = list(NAMES[:4]) + (["kS/kA"] if ordered else ["kS"])
    for i, n in enumerate(labels):
        if at_bound[i]:
            side = "lower" if abs(t[i] - _LOWER[i]) < abs(t[i] - _UPPER[i]) else "upper"
            warnings.append(f"{n} not determined: held at its {side} bound {t[i]:.4g} "
                            "(the fit would go beyond Polach's range)")
    for i, n in enumerate(NAMES):
        if at_bound[i] or (i == 4 and at_bound[4]):
            continue
        if not math.isfinite(cov[i, i]):
            warnings.append(f"{n} not determined by torlab's curve over this range")
        elif math.sqrt(cov[i, i]) > 0.5 * abs(p[i]) and p[i] != 0:
            warnings.append(f"{n} poorly determined (standard error "
                            f"{math.sqrt(cov[i, i]):.2g} for {p[i]:.4g})")
    if not ordered and p[4] > p[3] * (1 + 1e-9):
        warnings.append(f"kS = {p[4]:.3g} > kA = {p[3]:.3g}: outside Polach's kS <= kA <= 1 "
                        "(the curve's initial slope is not split the way his law assumes)")
    mod = model(p)
    n = X.size
    comps = ["x"] + (["y"] if use_y else [])
    data = pd.concat([pd.DataFrame({
        "component": c, "creepage": X, "lateral": E, "spin_1_m": P, "speed_m_s": V,
        "curve": [f"v = {vv:g} m/s" for vv in V],
        "mu_torlab": target[i * n:(i + 1) * n], "mu_polach": mod[i * n:(i + 1) * n],
        "residual": r[i * n:(i + 1) * n]}) for i, c in enumerate(comps)], ignore_index=True)
    dof = max(r.size - len(NAMES), 1)
    meta = {"source": source, "creepage_range": [float(np.min(X)), float(np.max(X))],
            "speed_range_m_s": [float(np.min(V)), float(np.max(V))],
            "lateral_range": [float(np.min(E)), float(np.max(E))],
            "spin_range_1_m": [float(np.min(P)), float(np.max(P))],
            "max_abs_residual": float(np.max(np.abs(r))),
            "rms_residual": float(math.sqrt(float(np.mean(r * r)))),
            "components": comps, "model": "Polach 2005 (mu0, A, B, kA, kS), spin of Polach 1999",
            "kS_le_kA_enforced": bool(ordered),
            "optimizer": sol.message}
    return FitResult.from_covariance(
        "polach", NAMES, p, cov, dof=dof, residual_norm=float(math.sqrt(float(np.mean(r * r)))),
        n_points=int(r.size), warnings=warnings, data=data, meta=meta, residual_unit="-",
        n_evaluations=int(sol.nfev), x_column="creepage", y_column="mu_torlab")


# ---------------------------------------------------------------------------------------------
# the layer's uncertainty carried into Polach's parameters
# ---------------------------------------------------------------------------------------------
@dataclass
class _PolachRefit:
    """Polach's parameters refitted to torlab's curve of the layer with its parameters
    replaced by one draw (a picklable model for :func:`torlab.uncertainty.propagate`, whose
    draws may be evaluated on worker processes)."""

    problem: CreepProblem
    creepage: np.ndarray
    speed: np.ndarray
    lateral: np.ndarray | None
    spin: np.ndarray | None
    grid: CreepGrid | None
    ordered: bool
    shift: np.ndarray | None = None

    def __call__(self, p: dict[str, float]) -> dict[str, np.ndarray]:
        layer = self.problem.layer.replace(**{k: float(v) for k, v in p.items()})
        res = fit_polach(replace(self.problem, layer=layer), self.creepage, self.speed,
                         lateral=self.lateral, spin=self.spin, grid=self.grid,
                         ordered=self.ordered, shift=self.shift)
        return {n: np.asarray(res.params[n], dtype=float) for n in NAMES}


def _finite(x: Any) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _not_carried(reason: str, notes: list[str] | None = None, *, draws: int = 0,
                 seed: int = 0) -> dict[str, Any]:
    return {"carried": False, "method": "not carried", "reason": f"{NOT_CARRIED}: {reason}",
            "n_draws": int(draws), "n_failed": 0, "seed": int(seed), "confidence": None,
            "layer_parameters": [], "interval": None, "sd": None, "dominant": {},
            "correlation": {}, "notes": [f"{NOT_CARRIED}: {reason}", *(notes or [])]}


def layer_uncertainty(scene: Scene, estimate: FitResult, creepage: Any, speed: Any, *,
                      lateral: Any = None, spin: Any = None, grid: CreepGrid | None = None,
                      draws: int = N_DRAWS, seed: int = 0, ordered: bool = True,
                      problem: CreepProblem | None = None, shift: Any = None
                      ) -> dict[str, Any]:
    """The layer's uncertainty carried into Polach's parameters (module docstring).

    The layer's parameters are drawn from the scene's ``fit: covariance:`` blocks
    (:func:`torlab.model.bands.scene_uncertainty`: the parameters whose value in
    the scene is the fitted one, the temperature coefficients only with
    ``thermal:``) with :func:`torlab.uncertainty.propagate` (``method="sampling"``),
    and Polach's law is refitted to torlab's creep forces of each drawn layer over
    the same range; each parameter's 95 % interval is the 2.5 % and 97.5 %
    percentile of its refits (widened to contain the estimate).

    Parameters
    ----------
    scene
        The dry :class:`~torlab.scene.Scene` with the product's layer.
    estimate
        The Polach fit at the layer's estimate (:func:`fit_polach`).
    creepage, speed, lateral, spin, grid, ordered
        The fit range and options of ``estimate`` (see :func:`fit_polach`).
    draws
        Number of layer draws (0: not carried).
    seed
        Seed of the draws.
    problem
        The scene's :class:`~torlab.model.creep.CreepProblem` if the caller has it.
    shift
        Added to each draw's forces (rows x 2: the exact theory minus the fast method at
        the estimate, when the estimate is the exact theory's): the draws are computed by
        the fast method and moved onto the exact curve.

    Returns
    -------
    dict
        JSON-ready: ``carried``, ``method`` (``sampling``; ``none`` when every variance
        is zero, the interval then being the estimate; ``not carried``), ``reason``,
        ``n_draws``, ``n_failed``, ``seed``, ``confidence``, ``layer_parameters``,
        ``interval`` and ``sd`` per Polach parameter, ``dominant`` (layer parameters
        with at least 10 % of a parameter's variance: regression shares, see
        :meth:`torlab.uncertainty.Propagation.dominant`), ``correlation``
        (``{polach: {layer: r}}`` over the draws, layer parameters on the scale they
        are drawn on: ``ln p`` for positive ones) and ``notes``.
    """
    from torlab.errors import NumericalError
    from torlab.model.bands import scene_uncertainty
    from torlab.model.creep import creep_problem
    from torlab.uncertainty import CONFIDENCE, propagate

    draws = int(draws)
    if draws < 0:
        raise TorlabInputError("the number of draws must be >= 0", key="draws")
    su = scene_uncertainty(scene)
    if not su.has_covariance:
        return _not_carried("no covariance (the scene's parameter files carry no fit "
                            "covariance: use the params.yaml of a torlab fit)", seed=seed)
    if su.dist is None:
        # the band's reason ("no band: ...") said for Polach's parameters
        why = su.notes[0].removeprefix("no band: ") if su.notes else "no parameter to draw"
        return _not_carried(why, su.notes[1:], seed=seed)
    if draws == 0:
        return _not_carried("no draws asked for (draws = 0)", su.notes, seed=seed)
    prob = problem if problem is not None else creep_problem(scene)

    def arr(x: Any) -> np.ndarray | None:
        return None if x is None else np.atleast_1d(np.asarray(x, dtype=float))

    model = _PolachRefit(prob, arr(creepage), arr(speed), arr(lateral), arr(spin), grid,
                         ordered, None if shift is None else np.asarray(shift, dtype=float))
    f0 = {n: np.asarray(estimate.params[n], dtype=float) for n in NAMES}
    try:
        band = propagate(model, su.dist, method="sampling", n_samples=draws, seed=seed, f0=f0)
    except NumericalError as e:
        return _not_carried(str(e), su.notes, draws=draws, seed=seed)
    layer = list(band.names)
    corr: dict[str, dict[str, float | None]] = {}
    if band.method == "sampling":
        th = np.asarray(band._design["draws"], dtype=float)
        for n in NAMES:
            y = np.asarray(band._design["stacked"][n], dtype=float).reshape(-1)
            row: dict[str, float | None] = {}
            for j, ln in enumerate(layer):
                x = th[:, j]
                ok = np.std(x) > 0 and np.std(y) > 0
                row[ln] = _finite(np.corrcoef(x, y)[0, 1]) if ok else None
            corr[n] = row
    s = band.summary(list(NAMES))
    notes = list(su.notes) + [n for n in band.notes
                              if n != "no parameter uncertainty: the band is the curve"]
    if band.method == "none":
        notes.append("every layer variance is zero: the intervals are the estimate")
    elif draws < _FEW_DRAWS:
        notes.append(f"only {draws} draws: the 2.5 % and 97.5 % percentiles lie near the "
                     f"extreme draws (use {_FEW_DRAWS} or more for a 95 % interval)")
    return {"carried": True, "method": band.method, "reason": "",
            "n_draws": draws if band.method == "sampling" else 0,
            "n_failed": int(band.n_failed), "seed": int(seed),
            "confidence": float(CONFIDENCE), "layer_parameters": layer,
            "interval": {n: [_finite(band.low(n)), _finite(band.high(n))] for n in NAMES},
            "sd": {n: _finite(band.sd[n]) for n in NAMES},
            "dominant": s["dominant"], "correlation": corr, "notes": notes}


def fit_polach_scene(scene: Scene, creepage: Any, speed: Any, *, lateral: Any = None,
                     spin: Any = None, grid: CreepGrid | None = None, draws: int = N_DRAWS,
                     seed: int = 0, source: str = "", ordered: bool = True,
                     method: str | None = None) -> FitResult:
    """Polach's parameters of a dry scene's product, with the layer's uncertainty.

    :func:`fit_polach` at the layer's estimate, then :func:`layer_uncertainty`
    (``draws`` refits on the executor in use, :mod:`torlab.parallel`), whose result
    is ``meta["layer_uncertainty"]``; when it is not carried (no covariance,
    ``draws=0``, a parameter the layer's fit did not determine, too many failed
    draws) the reason is also a warning.

    Parameters
    ----------
    scene
        The dry :class:`~torlab.scene.Scene` with the product's layer (and its fit's
        covariance, if any).
    creepage, speed, lateral, spin, grid, source, ordered
        As :func:`fit_polach`.
    draws, seed
        As :func:`layer_uncertainty`.
    method
        The boundary method of torlab's forces (None: the scene's ``grid: method``):
        ``fastsim``, ``fastsim-kalker``, ``exact`` (Kalker's exact theory, with the contact
        temperature where the scene couples it to the limits; the layer's draws by the fast method moved onto it) or ``auto`` (the exact theory
        where the fast forces' theory error exceeds the half-width of the scene's traction
        band, :func:`torlab.model.predict.choose_method`'s rule; without a band, exact).

    Returns
    -------
    FitResult
        As :func:`fit_polach`, its ``stderr`` and ``ci95`` those of the approximation,
        plus ``meta["layer_uncertainty"]``, ``meta["boundary_method"]`` and
        ``meta["theory_error_95"]`` (the largest theory error of torlab's forces in
        ``mu``; per point ``mu_theory_error_95`` in the data).
    """
    from torlab.model.calibrated import creep_error
    from torlab.model.creep import creep_problem
    from torlab.model.predict import with_method

    scene = with_method(scene, method)
    asked = scene.grid.method
    prob = creep_problem(scene)
    used, why = asked, ""
    if asked == "auto":
        used, why = _auto_polach(scene, prob, creepage, speed, lateral, spin, grid)
    exact = shift = None
    if used == "exact":
        from torlab.model.exact.rolling import ExactGrid
        from torlab.model.exact.scene import exact_contact

        exact = (exact_contact(scene), ExactGrid(n=scene.grid.exact_n))
    res = fit_polach(prob, creepage, speed, lateral=lateral, spin=spin, grid=grid,
                     source=source, ordered=ordered, exact=exact)
    df = res.data
    fast = None
    if exact is not None:
        fast = polach_data(prob, creepage, speed, lateral=lateral, spin=spin, grid=grid)
        ex = polach_data(prob, creepage, speed, lateral=lateral, spin=spin, grid=grid,
                         exact=exact)
        shift = np.stack([ex["mu_x"] - fast["mu_x"], ex["mu_y"] - fast["mu_y"]], axis=1)
        te = np.hypot(ex["mu_x_error"].to_numpy(), ex["mu_y_error"].to_numpy())
    else:
        fast = polach_data(prob, creepage, speed, lateral=lateral, spin=spin, grid=grid)
        X, E, P = (fast[c].to_numpy() for c in ("creepage", "lateral", "spin_1_m"))
        ex_, ey_, _ = creep_error(prob, X, E, P, fast["mu_x"].to_numpy() * prob.load,
                                  fast["mu_y"].to_numpy() * prob.load, np.zeros(len(X)),
                                  calibrated=prob.calibrated)
        te = np.hypot(ex_, ey_) / prob.load
    if "component" in df and len(df) == 2 * len(te):
        df["mu_theory_error_95"] = np.concatenate([te, te])
    elif len(df) == len(te):
        df["mu_theory_error_95"] = te
    res.meta["boundary_method"] = used
    if asked == "auto":
        res.meta["boundary_method_auto"] = why
    res.meta["theory_error_95"] = float(np.max(te)) if len(te) else None
    lu = layer_uncertainty(scene, res, creepage, speed, lateral=lateral, spin=spin, grid=grid,
                           draws=draws, seed=seed, ordered=ordered, problem=prob, shift=shift)
    if shift is not None and lu.get("carried"):
        lu["notes"].append("the layer's draws are computed by the fast method (FASTSIM "
                           "corrected by the exact theory) and moved onto the exact curve")
    res.meta["layer_uncertainty"] = lu
    if not lu["carried"]:
        res.warnings.append(lu["reason"])
    elif lu["method"] == "sampling" and lu["n_draws"] < _FEW_DRAWS:
        res.warnings.append(lu["notes"][-1])
    if lu["carried"] and lu["n_failed"]:
        res.warnings.append(f"{lu['n_failed']} of {lu['n_draws']} layer draws failed in the "
                            "Polach refit and were left out")
    return res


def _auto_polach(scene: Any, prob: CreepProblem, creepage: Any, speed: Any, lateral: Any,
                 spin: Any, grid: CreepGrid | None) -> tuple[str, str]:
    """``auto`` for Polach's fit: the fast forces where their theory error (longitudinal
    creepage) is below the half-width of the scene's traction band there; else exact."""
    from torlab.model.predict import choose_method, predict_traction, with_method

    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    sc = with_method(scene, "fastsim")
    pred = predict_traction(sc, xi)
    return choose_method(scene, pred)


def layer_interval_table(result: FitResult) -> Any:
    """``layer_intervals.csv``: per Polach parameter its value, the 95 % interval from the
    layer's draws (``layer_low95, layer_high95, layer_sd``), the approximation's interval
    (``approx_ci95_low, approx_ci95_high``), the dominant layer parameter and the
    correlation with each drawn layer parameter (``corr_<name>``).  Empty cells where
    the layer's uncertainty is not carried."""
    import pandas as pd

    lu = result.meta.get("layer_uncertainty") or {}
    carried = bool(lu.get("carried"))
    rows = []
    for n in NAMES:
        lo, hi = (lu["interval"][n] if carried else (None, None))
        dom = (lu.get("dominant") or {}).get(n) or []
        row = {"parameter": n, "value": result.params[n],
               "layer_low95": math.nan if lo is None else lo,
               "layer_high95": math.nan if hi is None else hi,
               "layer_sd": math.nan if not carried or lu["sd"][n] is None else lu["sd"][n],
               "approx_ci95_low": result.ci95[n][0], "approx_ci95_high": result.ci95[n][1],
               "dominant": dom[0]["parameter"] if dom else "",
               "method": lu.get("method", "not carried"),
               "n_draws": int(lu.get("n_draws", 0)), "n_failed": int(lu.get("n_failed", 0))}
        for ln in lu.get("layer_parameters", []):
            r = (lu.get("correlation") or {}).get(n, {}).get(ln)
            row[f"corr_{ln}"] = math.nan if r is None else r
        rows.append(row)
    df = pd.DataFrame(rows)
    for c in ("approx_ci95_low", "approx_ci95_high"):
        df[c] = df[c].where(np.isfinite(df[c].to_numpy(dtype=float)))
    return df
