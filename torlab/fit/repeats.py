"""One parameter set from repeated runs: each run fitted alone, pooled with random effects.

Repeats of one product and condition (four HPT runs at 25 degC, two traction curves of one
test, film steps of one oil) give one fit each.  Their parameters scatter from run to run
by more than each fit's own interval says (a new sample, a new track), so one least-squares
fit of shared parameters to all points -- whose uncertainty sees only the noise within a
record -- would state an interval many times too narrow: OFM1's four 25 degC runs fitted
together gave ``mu_c2`` 0.2355 [0.2348, 0.2363] while the four runs alone spread over
0.223-0.245.  :func:`pool_fits` pools the runs' estimates with the random-effects model of
:mod:`torlab.random_effects` (REML between-run variance, Hartung-Knapp interval on
``runs - 1`` degrees of freedom) and keeps, per parameter, how much of its variance is
the runs' own noise and how much the scatter between them (``meta["random_effects"]``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.fit.result import FitResult

__all__ = ["pool_fits", "scatter_note"]


def pool_fits(fits: list[FitResult], *, source: str | None = None) -> FitResult:
    """One :class:`FitResult` from the fits of repeated runs (module docstring).

    Parameters
    ----------
    fits
        One fit per run, all of one kind with the same parameters (and the same fixed
        ones).
    source
        The pooled result's source (default: the runs' sources joined).

    Returns
    -------
    FitResult
        Of the runs' kind: the pooled values, their covariance (the runs' own
        covariances plus the between-run covariance, each variance Hartung-Knapp's),
        every parameter's interval on ``runs - 1`` degrees of freedom
        (``meta["interval_dof"]``), ``meta["random_effects"]`` (per parameter: runs,
        between-run standard deviation, the shares of its variance within and between
        runs; on ``ln p`` for the positive parameters), ``meta["runs"]`` (each run's
        source and values), ``meta["scatter"]`` in words.  The data are every run's
        data and model (``curve``: the run).  With one fit: that fit, with
        ``meta["scatter"]`` saying that its intervals hold for that record alone.

    Raises
    ------
    TorlabInputError
        No fit, fits of different kinds or parameters.
    """
    import pandas as pd

    from torlab.random_effects import METHOD, ONE_RUN, pool_vectors

    if not fits:
        raise TorlabInputError("no fit to pool")
    if len(fits) == 1:
        f = fits[0]
        f.meta.setdefault("scatter", ONE_RUN)
        return f
    first = fits[0]
    names = first.names
    for f in fits[1:]:
        if f.kind != first.kind or f.names != names or set(f.fixed) != set(first.fixed):
            raise TorlabInputError(
                f"repeats must be fits of one kind with the same parameters: "
                f"{first.meta.get('source', 'run 1')} ({first.kind}: {', '.join(names)}) and "
                f"{f.meta.get('source', 'a run')} ({f.kind}: {', '.join(f.names)})")
    vals = np.array([[f.params[n] for n in names] for f in fits])
    covs = np.array([np.asarray(f.covariance, dtype=float) if f.covariance is not None
                     else np.diag([f.stderr[n] ** 2 for n in names]) for f in fits])
    logm = np.array([n in first.log_scale for n in names])
    est, cov, pooled = pool_vectors(vals, covs, logm)
    k = len(fits)
    dof = np.array([pl.dof for pl in pooled])
    srcs = [str(f.meta.get("source", f"run {i + 1}")) for i, f in enumerate(fits)]
    re = {}
    for n, pl, lg in zip(names, pooled, logm, strict=True):
        d = pl.as_dict()
        d["scale"] = "ln" if lg else "linear"
        if lg and math.isfinite(pl.tau):
            d["between_run_relative_sd"] = pl.tau  # sd of ln p: relative
        re[n] = d
    frames = []
    for i, f in enumerate(fits):
        if f.data is not None and hasattr(f.data, "columns"):
            d = f.data.copy()
            d["curve"] = srcs[i]
            frames.append(d)
    data = pd.concat(frames, ignore_index=True) if frames else None
    rows = [{"source": s, **{n: float(f.params[n]) for n in names},
             **{f"{n}_stderr": float(f.stderr[n]) for n in names}}
            for s, f in zip(srcs, fits, strict=True)]
    shares = ", ".join(f"{n} {100 * (1 - re[n]['share_between']):.0f} % within / "
                       f"{100 * re[n]['share_between']:.0f} % between"
                       for n in names if re[n]["share_between"] is not None)
    meta: dict[str, Any] = {
        **{k2: v for k2, v in first.meta.items()
           if k2 in ("product", "condition", "applied_amount", "applied_amount_unit",
                     "product_density", "temperature_C", "compliance", "scene", "model",
                     "normal_stress_Pa")},
        "method": f"{k} runs fitted one by one ({first.meta.get('method', first.kind)}); "
                  f"pooled by {METHOD}",
        "runs": rows,
        "random_effects": re,
        "interval_dof": {n: float(d) for n, d in zip(names, dof, strict=True)},
        "scatter": (f"{k} runs pooled: the intervals hold the scatter between runs as well as "
                    f"each run's own noise (share of each variance: {shares})"),
        "source": source or ", ".join(srcs),
    }
    warnings = [f"{s}: {w}" for s, f in zip(srcs, fits, strict=True) for w in f.warnings]
    res = FitResult.from_covariance(
        first.kind, names, est, cov, dof=k - 1, param_dof=dof, log_scale=first.log_scale,
        residual_norm=float(np.sqrt(np.mean([f.residual_norm ** 2 for f in fits]))),
        n_points=int(sum(f.n_points for f in fits)), warnings=warnings, data=data, meta=meta,
        fixed=dict(first.fixed), residual_unit=first.residual_unit,
        n_evaluations=int(sum(f.n_evaluations for f in fits)), x_column=first.x_column,
        y_column=first.y_column)
    return res


def scatter_note(result: FitResult) -> str:
    """What a result's intervals hold, in words (the runs' scatter, or one record's)."""
    from torlab.random_effects import ONE_RUN

    return str(result.meta.get("scatter") or ONE_RUN)
