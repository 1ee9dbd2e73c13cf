"""Temperature coefficients (Voce: ``mu_c1_T``, ``mu_c2_T``) from HPT runs at several
temperatures.

The layer limits follow ``tau_ci = mu_ci p exp(mu_ci_T (T - T_A))`` (thesis
Eqs. 5.26-5.27); which coefficients carry a temperature coefficient is the layer law's
(:attr:`~torlab.model.layers.base.Param.temperature_of`: Voce's ``mu_c1`` and ``mu_c2``,
the other laws' ``mu_c1``).  A run at temperature ``T`` therefore shows the apparent
coefficient ``mu_ci(T) = mu_ci(T_ref) exp(mu_ci_T (T - T_ref))``; with one
layer fit per run (:func:`torlab.fit.layer.fit_layer_hpt`),
``ln mu_ci(T)`` is a straight line in ``T`` whose slope is ``mu_ci_T``.

The line is fitted by least squares with the scatter of the runs about it as
the error (run-to-run scatter of a product's layer, a few per cent, is far
larger than one curve's fitting error, so weighting by the latter would be
wrong).  A scatter proportional to ``mu`` is constant in ``ln mu``; one of
constant size in ``mu`` grows as ``1/mu`` there, and with enough runs a
variance function estimated from the residuals weights the points
(:func:`torlab.fit._noise.linear_least_squares`; it is used only when a
likelihood-ratio test prefers it).  The intervals are Student-t with ``n - 2``
degrees of freedom, which is why at least three temperatures are needed; the
intercepts ``mu_ci(T_ref)`` have log-scale intervals.

Three temperatures with a few per cent of scatter rarely resolve a coefficient
of ``1e-3`` 1/K.  Each coefficient is therefore tested against 0 (likelihood
ratio of the line against a constant: the F-test, exact for this Gaussian
linear model): resolved coefficients are kept; the others are fixed to 0 and
the result says so (``selection="lr"``, the default), or kept with their whole
uncertainty for the predictions to carry (``selection="none"``).  The lines
are fitted to the same runs, so their scatter is correlated; the
covariance written for the predictions includes that correlation.

References
----------
.. [1] Kvarda, D., Galas, R., Omasta, M., Dzimko, M., Krupka, I., Hartl, M. (2022). Shear
   properties of top-of-rail products in numerical modelling. Proceedings of the
   Institution of Mechanical Engineers, Part F: Journal of Rail and Rapid Transit.
   https://doi.org/10.1177/09544097221138374
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.fit._noise import linear_least_squares
from torlab.fit.result import FitResult, student_t
from torlab.model.layers import get_law
from torlab.threads import small_problem

__all__ = ["SELECTION_LEVEL", "fit_temperature_coefficients"]

ZERO_CELSIUS_K = 273.15
#: significance level of the likelihood-ratio test that keeps a temperature coefficient
SELECTION_LEVEL = 0.05


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_temperature_coefficients(fits_or_curves: Any, temperatures_K: Any = None, *,  # noqa: C901 (each selection rule and undetermined coefficient is a case)
                                 reference_temperature_C: float = 25.0,
                                 selection: str = "lr",
                                 selection_level: float = SELECTION_LEVEL,
                                 law: Any = None) -> FitResult:
    """Fit the layer law's temperature coefficients (Voce: ``mu_c1_T`` and ``mu_c2_T``, 1/K)
    from layer fits at several temperatures.

    Parameters
    ----------
    fits_or_curves
        :class:`~torlab.fit.result.FitResult` of ``fit_layer_hpt`` (one per run),
        or HPT curves (:class:`~torlab.reduce.hpt.HptResult`) that are fitted here.
    temperatures_K
        Test temperatures [K], one per item; default: each fit's
        ``meta["temperature_C"]`` (from the log header).
    reference_temperature_C
        ``T_ref`` of the intercepts ``mu_c1_Tref``, ``mu_c2_Tref``.
    selection
        ``"lr"`` (or its synonym ``"test"``, the CLI's name): a coefficient
        that the likelihood-ratio test (the F-test of the line against a
        constant) does not resolve at ``selection_level`` is fixed to 0
        (written as 0, listed in :attr:`FitResult.fixed`);
        ``"none"``: every coefficient is kept with its uncertainty, which the
        predictions carry.  Either way ``meta["model_selection"]`` and the
        warnings state the test, the p-value and the decision.
    selection_level
        Significance level of the test (0.05).
    law
        The layer law curves are fitted with (:func:`torlab.fit.layer.fit_layer_hpt`;
        default Voce); ignored for given fits, which must share one law.

    Returns
    -------
    FitResult
        ``kind="temperature"``; parameters ``mu_c1_T``, ``mu_c2_T`` (the scene's
        ``boundary:`` keys; in :attr:`~FitResult.fixed` at 0 when not resolved)
        and ``mu_c1_Tref``, ``mu_c2_Tref`` (coefficients at ``T_ref``, reported,
        not written to the scene; log-scale intervals).  The covariance is
        joint: the two lines' scatter is correlated (the same runs).

    Raises
    ------
    TorlabInputError
        Fewer than three distinct temperatures, a missing temperature, an
        unknown ``selection``.
    """
    import pandas as pd

    from torlab._stats import f_sf  # scipy.stats.f.sf, without its import
    from torlab.fit.layer import run_estimates

    if selection == "test":
        selection = "lr"
    if selection not in ("lr", "none"):
        raise TorlabInputError(f"selection must be 'test' (or 'lr') or 'none', not "
                               f"{selection!r}", key="selection")
    items = list(fits_or_curves)
    # of each run the estimates and standard errors (the whole fit's, without its table)
    fits = [it if isinstance(it, FitResult) else run_estimates(it, law=law) for it in items]
    laws = {f.meta.get("law") for f in fits}
    if len(laws) > 1:
        raise TorlabInputError(f"the runs were fitted with different layer laws "
                               f"({', '.join(sorted(str(v or get_law().name) for v in laws))}): "
                               "fit every run with one law")
    law = get_law(laws.pop() if laws else None)
    keys = [law.param(t).temperature_of for t in law.temperature_names]
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
    n = x.size
    fitted: dict[str, Any] = {}
    cols: dict[str, Any] = {"temperature_C": T_C}
    for key in keys:
        mu = np.array([f.params[key] for f in fits])
        if np.any(mu <= 0):
            raise TorlabInputError(f"{key} must be positive in every run for ln {key}(T)")
        # noise of constant size in mu is 1/mu in ln mu (the variance function's scale)
        full = linear_least_squares(X, np.log(mu), lambda lnm: np.exp(-lnm))
        fitted[key] = (mu, full)
        cols[f"{key}_measured"] = mu
    # --- model selection: keep each coefficient, or fix it to 0 -------------------------
    selection_info: dict[str, Any] = {}
    warnings: list[str] = []
    keep: dict[str, bool] = {}
    for key in keys:
        full = fitted[key][1]
        b, se_b = float(full.coef[1]), math.sqrt(full.cov[1, 1])
        tq = student_t(full.dof)
        lo, hi = b - tq * se_b, b + tq * se_b
        fstat = (b / se_b) ** 2 if se_b > 0 else math.inf
        pval = float(f_sf(fstat, 1, max(full.dof, 1))) if math.isfinite(fstat) else 0.0
        resolved = pval < selection_level
        keep[key] = selection == "none" or resolved
        decision = ("kept" if resolved else
                    "kept; its uncertainty is carried into predictions" if selection == "none"
                    else "fixed to 0")
        selection_info[f"{key}_T"] = {
            "decision": decision, "test": f"likelihood ratio (F-test) against {key}_T = 0",
            "statistic": float(fstat) if math.isfinite(fstat) else None, "p_value": pval,
            "level": selection_level, "estimate_1_per_K": b, "ci95_full_model": [lo, hi]}
        if not resolved:
            what = ("fixed to 0 in the parameter file (selection 'none' keeps it and carries its "
                    "uncertainty into predictions)" if selection != "none" else
                    "kept, and its uncertainty is carried into predictions")
            warnings.append(
                f"{key}_T not resolved by these temperatures: likelihood-ratio test against 0 "
                f"p = {pval:.2g} >= {selection_level:g} (estimate {b:.2g} 1/K, 95 % interval "
                f"[{lo:.2g}, {hi:.2g}] includes 0: the run-to-run scatter is larger than the "
                f"temperature effect over this range); {what}")
    # --- final estimates: each line with its slope, or its mean ------------------------
    lines: dict[str, Any] = {}
    for key in keys:
        mu, full = fitted[key]
        lines[key] = full if keep[key] else linear_least_squares(
            X[:, :1], np.log(mu), lambda lnm: np.exp(-lnm))
    names: list[str] = [f"{k}_T" for k in keys if keep[k]] + [f"{k}_Tref" for k in keys]
    # joint covariance of (ln mu_ci(Tref), mu_ci_T) of both lines: the same runs give both
    # coefficients, so their scatter is correlated (seemingly unrelated regressions)
    pos: dict[str, int] = {}
    blocks = []
    for key in keys:
        ln = lines[key]
        pos[f"{key}_lnref"] = sum(b.A.shape[0] for b in blocks)
        if keep[key]:
            pos[f"{key}_T"] = pos[f"{key}_lnref"] + 1
        blocks.append(ln)
    e = {k: lines[k].residuals / np.sqrt(lines[k].weights * lines[k].s2) for k in keys}
    sd = {k: np.sqrt(lines[k].weights * lines[k].s2) for k in keys}
    m = sum(b.A.shape[0] for b in blocks)
    big = np.zeros((m, m))
    rhos: dict[str, float] = {}
    for i, ki in enumerate(keys):
        oi, ni = pos[f"{ki}_lnref"], lines[ki].A.shape[0]
        big[oi:oi + ni, oi:oi + ni] = lines[ki].cov
        for kj in keys[i + 1:]:
            oj, nj = pos[f"{kj}_lnref"], lines[kj].A.shape[0]
            den = math.sqrt(float(e[ki] @ e[ki]) * float(e[kj] @ e[kj]))
            rho = float(e[ki] @ e[kj]) / den if den > 0 else 0.0
            rhos[f"scatter_correlation_{ki}_{kj}"] = rho
            cross = lines[ki].A @ np.diag(rho * sd[ki] * sd[kj]) @ lines[kj].A.T
            big[oi:oi + ni, oj:oj + nj] = cross
            big[oj:oj + nj, oi:oi + ni] = cross.T
    order = [pos[f"{k}_T"] for k in keys if keep[k]] + [pos[f"{k}_lnref"] for k in keys]
    values_t = np.concatenate([lines[k].coef for k in keys])[order]
    cov_t = big[np.ix_(order, order)]
    # natural units: mu_ci(Tref) = exp(ln mu_ci(Tref))
    n_slopes = len(names) - len(keys)
    values = values_t.copy()
    values[n_slopes:] = np.exp(values_t[n_slopes:])
    jac = np.ones(len(names))
    jac[n_slopes:] = values[n_slopes:]
    cov = cov_t * np.outer(jac, jac)
    # the scatter about each line is the runs' own noise plus the scatter between runs:
    # its REML split (the runs' own variances of ln mu from their layer fits)
    between: dict[str, Any] = {}
    for key in keys:
        between[key] = _scatter_split(fits, key, X if keep[key] else X[:, :1], lines[key])
    dof = min(lines[k].dof for k in keys)
    rms = []
    for key in keys:
        mu = fitted[key][0]
        Xk = X if keep[key] else X[:, :1]
        model = np.exp(Xk @ lines[key].coef)
        cols[f"{key}_model"] = model
        cols[f"residual_{key}"] = mu - model
        rms.append(np.sqrt(np.mean((mu - model) ** 2)))
    fixed = {f"{k}_T": 0.0 for k in keys if not keep[k]}
    noise = {k: (lines[k].variance.describe() if lines[k].variance is not None
                 else "constant in ln mu (run-to-run scatter proportional to mu)")
             for k in keys}
    data = pd.DataFrame(cols)
    meta = {"method": "least squares of ln mu_ci on T (Eqs. 5.26-5.27), run scatter as the error; "
                      "each coefficient kept or fixed to 0 by a likelihood-ratio test",
            "reference_temperature_C": reference_temperature_C,
            "runs": [str(f.meta.get("source", "")) for f in fits],
            "product": fits[0].meta.get("product"),
            "temperatures_C": [float(t) for t in T_C],
            "selection": selection,
            "model_selection": selection_info,
            "noise_model": "; ".join(f"{k}: {v}" for k, v in noise.items()),
            **rhos,
            "random_effects": between,
            "scatter": (f"{n} runs: the scatter about each line holds the scatter between runs "
                        "as well as each run's own noise (" + "; ".join(
                            f"{k}: {100 * b['share_between']:.0f} % between runs"
                            for k, b in between.items() if b["share_between"] is not None)
                        + ")")}
    if law is not get_law():
        meta["law"] = law.name
    res = FitResult.from_covariance(
        "temperature", tuple(names), values, cov, dof=dof,
        log_scale=tuple(f"{k}_Tref" for k in keys),
        residual_norm=float(np.sqrt(np.mean(np.square(rms)))), n_points=int(n),
        warnings=warnings, data=data, meta=meta, fixed=fixed, residual_unit="-",
        n_evaluations=0, x_column="temperature_C", y_column=f"{keys[-1]}_measured")
    return res


def _scatter_split(fits: list[FitResult], key: str, X: np.ndarray, line: Any) -> dict[str, Any]:
    """How much of the scatter of ``ln key`` about its line is the runs' own noise and how
    much the scatter between runs (:func:`torlab.random_effects.reml_between` with each
    run's own variance ``(se/mu)^2``).  The line's interval rests on the residual scatter,
    which holds both (for equal own variances its REML is ``tau^2 + v``)."""
    from torlab.random_effects import reml_between

    mu = np.array([f.params[key] for f in fits])
    se = np.array([f.stderr.get(key, math.nan) for f in fits])
    v = np.where(np.isfinite(se), (se / mu) ** 2, 0.0)
    tau2 = reml_between(np.log(mu), v, X)
    vw = float(np.mean(v))
    tot = tau2 + vw
    resid = float(np.sqrt(np.mean(line.residuals ** 2)))
    return {"runs": int(mu.size), "residual_relative_sd": resid,
            "within_run_relative_sd": math.sqrt(vw) if np.isfinite(se).any() else None,
            "between_run_relative_sd": math.sqrt(tau2),
            "share_between": tau2 / tot if tot > 0 and np.isfinite(se).any() else None,
            "method": "REML of the between-run variance of ln mu about the line"}
