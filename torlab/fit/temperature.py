"""Temperature coefficients ``mu_c1_T``, ``mu_c2_T`` from HPT runs at several temperatures.

The layer limits follow ``tau_ci = mu_ci p exp(mu_ci_T (T - T_A))`` (thesis
Eqs. 5.26-5.27).  A run at temperature ``T`` therefore shows the apparent
coefficient ``mu_ci(T) = mu_ci(T_ref) exp(mu_ci_T (T - T_ref))``; with one
layer fit per run (:func:`torlab.fit.layer.fit_layer_hpt`),
``ln mu_ci(T)`` is a straight line in ``T`` whose slope is ``mu_ci_T``.

The line is fitted by ordinary least squares with the scatter of the runs
about it as the error (run-to-run scatter of a product's layer, a few per cent,
is far larger than one curve's fitting error, so weighting by the latter would
be wrong); the intervals are Student-t with ``n - 2`` degrees of freedom, which
is why at least three temperatures are needed.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.fit.result import FitResult, student_t
from torlab.threads import small_problem

__all__ = ["fit_temperature_coefficients"]

ZERO_CELSIUS_K = 273.15


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_temperature_coefficients(fits_or_curves: Any, temperatures_K: Any = None, *,
                                 reference_temperature_C: float = 25.0) -> FitResult:
    """Fit ``mu_c1_T`` and ``mu_c2_T`` (1/K) from layer fits at several temperatures.

    Parameters
    ----------
    fits_or_curves
        :class:`~torlab.fit.result.FitResult` of ``fit_layer_hpt`` (one per run),
        or HPT curves (:class:`~torlab.reduce.hpt.HptResult`) that are fitted here.
    temperatures_K
        Test temperatures (K), one per item; default: each fit's
        ``meta["temperature_C"]`` (from the log header).
    reference_temperature_C
        ``T_ref`` of the intercepts ``mu_c1_Tref``, ``mu_c2_Tref``.

    Returns
    -------
    FitResult
        ``kind="temperature"``; parameters ``mu_c1_T``, ``mu_c2_T`` (the scene's
        ``boundary:`` keys) and ``mu_c1_Tref``, ``mu_c2_Tref`` (coefficients at
        ``T_ref``, reported, not written to the scene).

    Raises
    ------
    TorlabInputError
        Fewer than three distinct temperatures, a missing temperature.
    """
    import pandas as pd

    from torlab.fit.layer import fit_layer_hpt

    items = list(fits_or_curves)
    fits = [it if isinstance(it, FitResult) else fit_layer_hpt(it) for it in items]
    if temperatures_K is None:
        T = []
        for f in fits:
            t = f.meta.get("temperature_C")
            if t is None or not math.isfinite(float(t)):
                raise TorlabInputError(f"no temperature for {f.meta.get('source', 'a run')}: give "
                                       "the temperatures", key="temperature")
            T.append(float(t))
        T_C = np.array(T)
    else:
        T_C = np.asarray(temperatures_K, dtype=float).ravel() - ZERO_CELSIUS_K
        if T_C.size != len(fits):
            raise TorlabInputError(f"{len(fits)} runs but {T_C.size} temperatures", key="temperature")
    if np.unique(np.round(T_C, 6)).size < 3:
        raise TorlabInputError(f"temperature coefficients with an uncertainty need runs at three or "
                               f"more temperatures; got {sorted(set(np.round(T_C, 2).tolist()))} degC")
    x = T_C - reference_temperature_C
    X = np.column_stack((np.ones_like(x), x))
    XtX_inv = np.linalg.inv(X.T @ X)
    n = x.size
    dof = n - 2
    tq = student_t(dof)
    names = ("mu_c1_T", "mu_c2_T", "mu_c1_Tref", "mu_c2_Tref")
    params: dict[str, float] = {}
    stderr: dict[str, float] = {}
    ci: dict[str, tuple[float, float]] = {}
    cols: dict[str, Any] = {"temperature_C": T_C}
    rms = []
    for key in ("mu_c1", "mu_c2"):
        mu = np.array([f.params[key] for f in fits])
        if np.any(mu <= 0):
            raise TorlabInputError(f"{key} must be positive in every run for ln {key}(T)")
        y = np.log(mu)
        coef = XtX_inv @ X.T @ y
        r = y - X @ coef
        s2 = float(r @ r) / dof
        cov = s2 * XtX_inv
        b, se_b = float(coef[1]), math.sqrt(cov[1, 1])
        a, se_a = float(coef[0]), math.sqrt(cov[0, 0])
        params[f"{key}_T"] = b
        stderr[f"{key}_T"] = se_b
        ci[f"{key}_T"] = (b - tq * se_b, b + tq * se_b)
        params[f"{key}_Tref"] = math.exp(a)
        stderr[f"{key}_Tref"] = math.exp(a) * se_a
        ci[f"{key}_Tref"] = (math.exp(a - tq * se_a), math.exp(a + tq * se_a))
        cols[f"{key}_measured"] = mu
        cols[f"{key}_model"] = np.exp(X @ coef)
        cols[f"residual_{key}"] = mu - np.exp(X @ coef)
        rms.append(np.sqrt(np.mean((mu - np.exp(X @ coef)) ** 2)))
    warnings = []
    for key in ("mu_c1_T", "mu_c2_T"):
        lo, hi = ci[key]
        if lo <= 0 <= hi:
            warnings.append(f"{key} poorly determined: its 95 % interval [{lo:.2g}, {hi:.2g}] 1/K "
                            "includes 0 (the run-to-run scatter is larger than the temperature "
                            "effect over this range)")
    corr = np.full((4, 4), np.nan)
    np.fill_diagonal(corr, 1.0)
    c_ab = XtX_inv[0, 1] / math.sqrt(XtX_inv[0, 0] * XtX_inv[1, 1])
    corr[0, 2] = corr[2, 0] = c_ab
    corr[1, 3] = corr[3, 1] = c_ab
    data = pd.DataFrame(cols)
    meta = {"method": "least squares of ln mu_ci on T (Eqs. 5.26-5.27), run scatter as the error",
            "reference_temperature_C": reference_temperature_C,
            "runs": [str(f.meta.get("source", "")) for f in fits],
            "product": fits[0].meta.get("product"),
            "temperatures_C": [float(t) for t in T_C]}
    return FitResult(kind="temperature", names=names, params=params, stderr=stderr, ci95=ci,
                     correlation=corr, residual_norm=float(np.sqrt(np.mean(np.square(rms)))),
                     n_points=int(n), warnings=warnings, data=data, meta=meta, residual_unit="-",
                     n_evaluations=0, dof=dof, x_column="temperature_C", y_column="mu_c2_measured")
