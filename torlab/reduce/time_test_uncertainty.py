"""Intervals and verdict probabilities of the time-test figures (Paper B, Fig. 5.9).

:func:`torlab.reduce.mtm.time_test_metrics` reads its figures -- minimum, time
to recover, mean after recovery, time below the low-adhesion threshold -- from
one noisy record.  :func:`time_test_uncertainty` says how well that record
determines them:

* **Mean after recovery** (the figure Paper B reports): its standard error from
  the samples after recovery with their autocorrelation (:func:`hac_mean`: batch
  means, ten consecutive batches), a Student-t 95 % interval, and the
  probability that the mean lies in the optimal band.  A coefficient that
  wanders slowly (a 20 s fluctuation) makes neighbouring samples alike, and the
  plain ``sd / sqrt(n)`` would be several times too small.
* **Minimum, time to recover, time below the threshold**: a moving-block
  bootstrap of the record's scatter about its running median.  The residuals
  after the application are resampled in blocks (the longer of the smoothing
  window and twice the residuals' integrated autocorrelation time), added back
  to the running median, and the figures are read again from every replicate
  with the same options and the same application moment.  The 2.5 and 97.5 %
  quantiles are the interval; the fraction of replicates that recover is the
  probability that the record shows a recovery.

What the intervals hold: the record's own noise.  They do not hold the scatter
from test to test (a second application on a new track), which only repeated
tests measure; the report says so.  Deterministic for a given ``seed``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["MEAN_BATCHES", "TIME_TEST_PROBABILITY", "hac_mean", "time_test_uncertainty"]

#: probability a time-test verdict (recovered, in the band) needs to be called
TIME_TEST_PROBABILITY = 0.9


#: batches of the mean's standard error (non-overlapping batch means)
MEAN_BATCHES = 10


def hac_mean(y: np.ndarray, batches: int = MEAN_BATCHES) -> tuple[float, float, float]:
    """Mean of an autocorrelated series, its standard error and degrees of freedom.

    Non-overlapping batch means: the series is cut into ``batches`` equal
    consecutive pieces, and the spread of their means gives the standard error
    of the overall mean, ``sd(batch means) / sqrt(batches)``, with Student t on
    ``batches - 1`` degrees of freedom (Schmeiser 1982, Operations Research 30,
    556).  It holds whatever the correlation, as long as a batch is several
    correlation times long (90 s batches of a 15-minute record against a 20 s
    fluctuation); a kernel (Newey-West) estimate was far too optimistic for a
    coefficient that wanders slowly under white noise (its 95 % interval held
    the mean of 400 simulated records in 63 % of them, batch means in 94 %;
    docs/uncertainty.md).  A short series gets fewer batches (two samples each
    at least).

    Returns
    -------
    mean, se, dof
        ``se`` NaN with fewer than 4 samples.
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    m = float(np.mean(y)) if n else float("nan")
    if n < 4:
        return m, float("nan"), float("nan")
    b = int(max(2, min(batches, n // 2)))
    L = n // b
    means = y[n - b * L:].reshape(b, L).mean(axis=1)  # the last b*L samples: whole batches
    se = float(np.std(means, ddof=1) / math.sqrt(b))
    se = max(se, float(np.std(y, ddof=1) / math.sqrt(n)))  # never below independent samples
    return m, se, float(b - 1)


def _block_length(r: np.ndarray, minimum: int) -> int:
    """Twice the integrated autocorrelation time of ``r`` (samples), at least ``minimum``."""
    n = r.size
    e = r - r.mean()
    v = float(e @ e)
    if n < 4 or v <= 0:
        return max(1, minimum)
    tau = 1.0
    for lag in range(1, min(n // 4, 200)):
        c = float(e[lag:] @ e[:-lag]) / v
        if c <= 0.05:
            break
        tau += 2 * c
    return int(min(max(minimum, math.ceil(2 * tau)), max(1, n // 4)))


def time_test_uncertainty(t: np.ndarray, mu: np.ndarray, result: Any, options: dict[str, Any],
                          *, band: tuple[float, float] = (0.15, 0.25), replicates: int = 200,
                          probability: float = TIME_TEST_PROBABILITY, seed: int = 0
                          ) -> dict[str, Any]:
    """The intervals and verdict probabilities of one time test (module docstring).

    Parameters
    ----------
    t, mu
        The record (s, coefficient) the figures were read from.
    result
        Its :class:`~torlab.reduce.mtm.TimeTestResult`.
    options
        The options it was computed with (``torlab.reduce.mtm.time_test_metrics``
        keywords: ``threshold``, ``smooth``, ``duration`` ...).
    band
        Optimal band for the "mean after recovery in the band" verdict.
    replicates
        Bootstrap replicates (0: only the mean's interval).
    probability
        Probability a verdict needs to be called.
    seed
        Seed of the block bootstrap.

    Returns
    -------
    dict
        ``mean_after_recovery_se``, ``..._low95``, ``..._high95``, ``..._dof``;
        ``p_in_band`` and ``in_band_verdict`` (``in band``, ``outside the band``
        or ``undetermined``); ``minimum_low95/high95``,
        ``recovery_time_low95/high95``, ``time_below_threshold_low95/high95``,
        ``p_recovered`` and ``recovered_verdict``; ``replicates``,
        ``block_s``; ``basis`` (what the intervals hold).
    """
    from torlab._stats import t_cdf, t_ppf  # scipy.stats.t, without its import
    from torlab.reduce.mtm import _window_samples, running_median, time_test_metrics

    nan = float("nan")
    t = np.asarray(t, dtype=float)
    mu = np.asarray(mu, dtype=float)
    ok = np.isfinite(t) & np.isfinite(mu)
    t, mu = t[ok], mu[ok]
    out: dict[str, Any] = {k: nan for k in (
        "mean_after_recovery_se", "mean_after_recovery_low95", "mean_after_recovery_high95",
        "mean_after_recovery_dof", "p_in_band", "minimum_low95", "minimum_high95",
        "recovery_time_low95", "recovery_time_high95", "time_below_threshold_low95",
        "time_below_threshold_high95", "p_recovered", "block_s")}
    out.update(in_band_verdict="", recovered_verdict="", replicates=0, probability=probability,
               basis="the record's own noise (autocorrelated mean; block bootstrap of the scatter "
                     "about the running median); not the scatter from test to test")
    t_app = float(result.application_time_s)
    end = float(result.evaluated_until_s)
    if result.recovered and math.isfinite(result.recovery_at_s):
        after = (t >= result.recovery_at_s) & (t <= end)
        m, se, dof = hac_mean(mu[after])
        if math.isfinite(se):
            tq = float(t_ppf(0.975, dof))
            cdf = t_cdf((np.array(band, dtype=float) - m) / se, dof) if se > 0 else \
                np.array([float(band[0] > m), float(band[1] >= m)])
            p_in = float(cdf[1] - cdf[0])
            out.update(mean_after_recovery_se=se, mean_after_recovery_low95=m - tq * se,
                       mean_after_recovery_high95=m + tq * se, mean_after_recovery_dof=dof,
                       p_in_band=p_in)
            out["in_band_verdict"] = ("in band" if p_in >= probability else
                                      "outside the band" if 1 - p_in >= probability
                                      else "undetermined")
    if replicates <= 0:
        return out
    dt = float(np.median(np.diff(t)))
    ks = _window_samples(float(options.get("smooth", 10.0)), dt)
    smooth = running_median(mu, ks)
    post = np.nonzero((t >= t_app) & (t <= end))[0]
    r = mu[post] - smooth[post]
    n = r.size
    if n < 8:
        return out
    L = _block_length(r, ks)
    rng = np.random.default_rng(seed)
    opts = {k: v for k, v in options.items() if k != "application_time"}
    figs: dict[str, list[float]] = {"minimum": [], "recovery_time": [], "time_below": [],
                                    "recovered": []}
    nb = math.ceil(n / L)
    for _ in range(int(replicates)):
        starts = rng.integers(0, n, size=nb)
        idx = (starts[:, None] + np.arange(L)[None, :]).ravel()[:n] % n  # circular blocks
        y = mu.copy()
        y[post] = smooth[post] + r[idx]
        rep = time_test_metrics(t, y, application_time=t_app, **opts)
        figs["minimum"].append(rep.minimum)
        figs["recovery_time"].append(rep.recovery_time_s)
        figs["time_below"].append(rep.time_below_threshold_s)
        figs["recovered"].append(float(rep.recovered))

    def q(key: str) -> tuple[float, float]:
        v = np.asarray(figs[key], dtype=float)
        v = v[np.isfinite(v)]
        if v.size < 0.5 * replicates:
            return nan, nan
        lo, hi = np.quantile(v, [0.025, 0.975])
        return float(lo), float(hi)

    out["minimum_low95"], out["minimum_high95"] = q("minimum")
    out["recovery_time_low95"], out["recovery_time_high95"] = q("recovery_time")
    out["time_below_threshold_low95"], out["time_below_threshold_high95"] = q("time_below")
    p_rec = float(np.mean(figs["recovered"]))
    out.update(p_recovered=p_rec, replicates=int(replicates), block_s=float(L * dt),
               recovered_verdict=("recovered" if p_rec >= probability else
                                  "not recovered" if 1 - p_rec >= probability
                                  else "undetermined"))
    return out
