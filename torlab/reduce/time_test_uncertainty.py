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
  bootstrap of the record's scatter about its background, the running median over
  120 s (which follows the drop's end and the recovery but not the slow
  fluctuation of the friction).  The residuals after the application are resampled
  in blocks (twice the longer of the smoothing window and twice the residuals'
  integrated autocorrelation time), added back to the background, and the figures
  are read again from every replicate with the same options and the same
  application moment.  The figures of a noisy record are biased (a noisy curve's
  minimum lies below the curve's, a noisy rise crosses a level early); the basic
  bootstrap interval corrects for it (centred on the figure less the replicates'
  median bias against the background's own figure).  The fraction of replicates
  that recover is the probability that the record shows a recovery.  Over 200
  simulated records per composition the minimum's interval holds the true value in
  93-100 % of them, the crossings' in 77-97 % (docs/uncertainty.md): a 20 s
  fluctuation moves a crossing by tens of seconds and one record holds too few of
  its periods to say by how much; the basis says so.

What the intervals hold: the record's own noise.  They do not hold the scatter
from test to test (a second application on a new track), which only repeated
tests measure; the report says so.  Deterministic for a given ``seed``.

Repeated tests (:func:`repeat_scatter`, :func:`apply_repeats`): where a
campaign repeats compositions, a one-way random-effects model
``x_ij = mu_i + b_ij + e_ij`` (composition ``i``, test ``j``; ``b`` the
test-to-test offset with variance ``tau^2``, ``e`` the record's own error)
gives the scatter of one test's figure about its composition's mean from the
pooled within-composition variance of the repeats,
``s^2 = sum_i sum_j (x_ij - xbar_i)^2 / sum_i (n_i - 1)``, which estimates
``tau^2 + sigma_e^2`` on ``sum_i (n_i - 1)`` degrees of freedom (Searle, Casella
& McCulloch 1992, Variance Components, ch. 3).  Where ``s`` is larger than the
record's own standard error, a test's interval becomes ``x_ij +- t s`` and a
repeated composition gets ``xbar_i +- t s / sqrt(n_i)``; the verdicts use them.
The pooled ``s`` assumes one test-to-test scatter for every composition of the
campaign, so it is applied to the tests that were not repeated too.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

# the pooled one-way random-effects scatter of one test's figure (module docstring): the
# REML of every repeated measurement in torlab, under the name the time tests use
from torlab.random_effects import one_way as repeat_scatter

__all__ = ["MEAN_BATCHES", "REPEAT_FIGURES", "TIME_TEST_PROBABILITY", "apply_repeats",
           "hac_mean", "measured_retention", "repeat_scatter", "time_test_uncertainty"]

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
               basis=f"mean after recovery: the record's own noise (autocorrelated mean); "
                     f"minimum and crossings: {BOOTSTRAP_BASIS}; not the scatter from test "
                     "to test")
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
    out.update(_bootstrap_figures(t, mu, result, options, replicates, seed))
    p_rec = out.pop("_p_recovered")
    if math.isfinite(p_rec):
        out.update(p_recovered=p_rec, recovered_verdict=(
            "recovered" if p_rec >= probability else
            "not recovered" if 1 - p_rec >= probability else "undetermined"))
    return out


#: running-median window [s] of the record's background in the block bootstrap: long
#: against the slow fluctuation (tens of seconds), so that the residuals about it hold it
BACKGROUND_S = 120.0
#: blocks of the bootstrap: this many times the residuals' integrated autocorrelation time
#: (twice it, see _block_length), so that a block holds the slow fluctuation whole
BLOCK_FACTOR = 2
#: residuals beyond this many robust standard deviations are the drop's own samples, not
#: noise: clipped before they are resampled
CLIP_SD = 4.0
#: what the bootstrap figures' intervals hold, and how well (docs/uncertainty.md)
BOOTSTRAP_BASIS = (
    "the record's own noise (block bootstrap of the residuals about its 120 s running "
    "median, intervals corrected for the estimator's bias); from one record the time to "
    "recover and the time below the threshold are resolved only roughly: their 95 % "
    "intervals held the true value in 77-97 % of simulated records (the minimum's in "
    "93-100 %), because a slow fluctuation of the friction moves the crossings by tens of "
    "seconds and one record holds few of its periods; repeated tests measure it")


def _bootstrap_figures(t: np.ndarray, mu: np.ndarray, result: Any, options: dict[str, Any],
                       replicates: int, seed: int) -> dict[str, Any]:
    """Block-bootstrap intervals of the minimum, the time to recover and the time below
    the threshold, corrected for the estimator's bias (module docstring).

    The record after the application is split into a background, its running median over
    :data:`BACKGROUND_S` (on a monotone stretch the running median is the trend's central
    value, so it follows the drop's end and the recovery without the fluctuation), and
    residuals (clipped at :data:`CLIP_SD` robust standard deviations, the rest left in the
    background: the drop's first seconds are the curve, not noise).  Each replicate is the background plus the residuals resampled
    in circular blocks of :data:`BLOCK_FACTOR` times twice their integrated
    autocorrelation time, read with the same options and application moment.  The
    minimum read from a noisy record lies below the curve's, and the replicates show by
    how much against the background's own minimum ``f_b`` (``*_bias``: median replicate
    - ``f_b``): its interval is the basic bootstrap's, ``[f - (q97.5 - f_b), f - (q2.5 -
    f_b)]`` (Davison & Hinkley 1997, Eq. 5.6), centred on the bias-corrected minimum.  The
    crossings' biases are small against their scatter and their estimates noisy, so their
    intervals are the percentile ones, widened by one sample spacing on each side: a
    crossing is read at a sample, and the curve crosses somewhere within the spacing
    before it.
    """
    from torlab.reduce.mtm import _window_samples, running_median, time_test_metrics

    nan = float("nan")
    out: dict[str, Any] = {"_p_recovered": nan}
    t_app, end = float(result.application_time_s), float(result.evaluated_until_s)
    dt = float(np.median(np.diff(t)))
    ks = _window_samples(float(options.get("smooth", 10.0)), dt)
    post = np.nonzero((t >= t_app) & (t <= end))[0]
    n = post.size
    if n < 8:
        return out
    background = running_median(mu[post], _window_samples(BACKGROUND_S, dt))
    r = mu[post] - background
    sd = 1.4826 * float(np.median(np.abs(r - np.median(r))))
    if sd > 0:  # the drop's samples stay in the background, beyond the clipped residual
        r = np.clip(r, -CLIP_SD * sd, CLIP_SD * sd)
        background = mu[post] - r
    L = min(BLOCK_FACTOR * _block_length(r, ks), max(1, n // 2))
    rng = np.random.default_rng(seed)
    opts = {k: v for k, v in options.items() if k != "application_time"}
    y = mu.copy()
    y[post] = background
    ref = time_test_metrics(t, y, application_time=t_app, **opts)
    keys = {"minimum": "minimum", "recovery_time": "recovery_time_s",
            "time_below_threshold": "time_below_threshold_s"}
    figs: dict[str, list[float]] = {k: [] for k in keys}
    recovered = []
    nb = math.ceil(n / L)
    for _ in range(int(replicates)):
        starts = rng.integers(0, n, size=nb)
        idx = (starts[:, None] + np.arange(L)[None, :]).ravel()[:n] % n  # circular blocks
        y[post] = background + r[idx]
        rep = time_test_metrics(t, y, application_time=t_app, **opts)
        for k, a in keys.items():
            figs[k].append(getattr(rep, a))
        recovered.append(float(rep.recovered))
    for k, a in keys.items():
        v = np.asarray(figs[k], dtype=float)
        v = v[np.isfinite(v)]
        f, fb = float(getattr(result, a)), float(getattr(ref, a))
        if v.size < 0.5 * replicates or not math.isfinite(f):
            out[f"{k}_low95"] = out[f"{k}_high95"] = out[f"{k}_bias"] = nan
            continue
        lo, hi = (float(x) for x in np.quantile(v, [0.025, 0.975]))
        out[f"{k}_bias"] = float(np.median(v)) - fb if math.isfinite(fb) else nan
        if k == "minimum" and not result.recovered:
            # a record that stays low is a level with a slow fluctuation: its minimum is the
            # fluctuation's deepest point, which the bootstrap does not resolve (its interval
            # held the level in 20 % of simulated over-applications): no interval
            out["minimum_low95"] = out["minimum_high95"] = nan
            out["minimum_note"] = ("not recovered: the record stays at a level; its minimum "
                                   "is the deepest point of the fluctuation about it, which "
                                   "one record does not resolve (no interval)")
            continue
        if k == "minimum" and math.isfinite(fb):
            # basic bootstrap: centred on the figure less its bias (a noisy minimum is low)
            lo, hi = f - (hi - fb), f - (lo - fb)
        elif k != "minimum":  # a crossing is known to one sample: the time axis's resolution
            lo, hi = lo - dt, hi + dt
        out[f"{k}_low95"], out[f"{k}_high95"] = lo, hi
    out.update(_p_recovered=float(np.mean(recovered)), replicates=int(replicates),
               block_s=float(L * dt), background_s=BACKGROUND_S)
    return out


# ---------------------------------------------------------------------------------------------
# repeated tests: the scatter from test to test
# ---------------------------------------------------------------------------------------------
#: the figures whose test-to-test scatter repeats estimate: evidence key -> figure attribute
#: of :class:`~torlab.reduce.mtm.TimeTestResult`
REPEAT_FIGURES = {"mean_after_recovery": "mean_after_recovery", "minimum": "minimum",
                  "recovery_time": "recovery_time_s",
                  "time_below_threshold": "time_below_threshold_s"}


def apply_repeats(evidence: dict[Any, dict[str, Any]], results: dict[Any, Any],
                  composition: dict[Any, str], *, band: tuple[float, float] = (0.15, 0.25),
                  probability: float = TIME_TEST_PROBABILITY) -> dict[str, Any]:
    """Widen the tests' intervals by the test-to-test scatter of the repeats, where larger.

    Parameters
    ----------
    evidence
        ``key -> time_test_uncertainty(...)`` of every test (updated in place).
    results
        ``key -> TimeTestResult`` (the figures).
    composition
        ``key -> composition``; tests of one composition are repeats.
    band, probability
        As :func:`time_test_uncertainty` (the "in band" verdicts are called again).

    Returns
    -------
    dict
        ``repeated`` (``{composition: n}`` with ``n >= 2``), per figure the
        :func:`repeat_scatter` (``figures``), and per repeated composition the
        mean of each figure over its repeats with its 95 % interval, and for the mean
        after recovery ``p_in_band`` and ``in_band_verdict`` (``compositions``).
        Without a repeat: ``repeated`` is empty and nothing changes.
    """
    from torlab._stats import t_cdf, t_ppf

    keys = [k for k in evidence if k in results and k in composition]
    counts: dict[str, int] = {}
    for k in keys:
        counts[composition[k]] = counts.get(composition[k], 0) + 1
    out: dict[str, Any] = {"repeated": {c: n for c, n in counts.items() if n >= 2},
                           "figures": {}, "compositions": {}}
    if not out["repeated"]:
        return out
    for fig, attr in REPEAT_FIGURES.items():
        vals = [float(getattr(results[k], attr)) for k in keys]
        if fig == "mean_after_recovery":
            rsd = [float(evidence[k].get("mean_after_recovery_se", math.nan)) for k in keys]
        else:  # the bootstrap interval's half-width over the normal quantile
            rsd = [(float(evidence[k].get(f"{fig}_high95", math.nan))
                    - float(evidence[k].get(f"{fig}_low95", math.nan))) / (2 * 1.959964)
                   for k in keys]
        sc = repeat_scatter(vals, [composition[k] for k in keys], rsd)
        out["figures"][fig] = {k: v for k, v in sc.items() if k != "means"}
        s, dof = sc["sd_test"], sc["dof"]
        if not (math.isfinite(s) and dof > 0):
            continue
        tq = float(t_ppf(0.975, dof))
        for k, v, r in zip(keys, vals, rsd, strict=True):
            ev = evidence[k]
            if not math.isfinite(v) or (math.isfinite(r) and r >= s):
                continue  # the record's own interval is the wider: kept
            ev[f"{fig}_low95"], ev[f"{fig}_high95"] = v - tq * s, v + tq * s
            ev.setdefault("widened_by_repeats", []).append(fig)
            if fig == "mean_after_recovery" and ev.get("in_band_verdict"):
                cdf = t_cdf((np.asarray(band, dtype=float) - v) / s, dof)
                p_in = float(cdf[1] - cdf[0])
                ev.update(mean_after_recovery_se=s, mean_after_recovery_dof=float(dof),
                          p_in_band=p_in, in_band_verdict=_band_verdict(p_in, probability))
        for c, (m, n) in sc["means"].items():
            if n < 2:
                continue
            e = out["compositions"].setdefault(c, {"n_tests": counts[c]})
            half = tq * s / math.sqrt(n)
            e[fig] = {"mean": m, "n": n, "low95": m - half, "high95": m + half}
            if fig == "mean_after_recovery":
                cdf = t_cdf((np.asarray(band, dtype=float) - m) / (s / math.sqrt(n)), dof)
                p_in = float(cdf[1] - cdf[0])
                e[fig].update(p_in_band=p_in, in_band_verdict=_band_verdict(p_in, probability))
    for k in keys:
        if evidence[k].get("widened_by_repeats"):
            evidence[k]["basis"] = (
                "the test-to-test scatter of the repeated compositions (one-way random effects, "
                "pooled) where it is larger than the record's own noise ("
                + ", ".join(evidence[k]["widened_by_repeats"]) + "); the record's own noise "
                "elsewhere")
    return out


def _band_verdict(p_in: float, probability: float) -> str:
    return ("in band" if p_in >= probability else "outside the band" if 1 - p_in >= probability
            else "undetermined")


# ---------------------------------------------------------------------------------------------
# a time test after application in the shape labs report (retention)
# ---------------------------------------------------------------------------------------------
def measured_retention(passes: np.ndarray, mu: np.ndarray, *, band: tuple[float, float],
                       mu_dry: float | None = None, retentivity: Any = "band",
                       smooth: int = 21, replicates: int = 200, seed: int = 0
                       ) -> dict[str, Any]:
    """The retention figures of one measured test after application (the shape of
    EN 15427-2-1 Annex H; CEN/TS 15427-2-2), each with its 95 % interval from the record.

    * **effective friction level**: the mean coefficient over the test from the
      application on, Student t on its batch-means standard error (:func:`hac_mean`);
    * **fraction of the passes in the band**: the mean of the in-band indicator, its
      interval likewise (batch means of the indicator);
    * **retentivity**: the passes (disc revolutions) until the running median of the
      coefficient leaves the band (rises above its upper bound) or, with a fraction ``f``,
      returns to ``f`` times ``mu_dry``; its interval from a moving-block bootstrap of the
      record's scatter about that median (as the time-test figures); None (never) where
      the record does not get there.

    Parameters
    ----------
    passes, mu
        Passes since the application and the coefficient.
    band
        ``(low, high)``.
    mu_dry
        The dry coefficient (for ``retentivity`` as a fraction).
    retentivity
        ``"band"`` or a fraction of dry.
    smooth
        Samples of the running median.
    replicates, seed
        Block-bootstrap replicates of the retentivity and their seed.

    Returns
    -------
    dict
        ``effective_friction``, ``fraction_in_band``, ``retentivity`` (``value``, ``low95``,
        ``high95``; the retentivity's ``definition``, ``level``, ``p_reached``),
        ``window_passes``, ``band``, ``holds``.
    """
    from torlab._stats import t_ppf
    from torlab.reduce.mtm import running_median

    N = np.asarray(passes, dtype=float)
    y = np.asarray(mu, dtype=float)
    ok = np.isfinite(N) & np.isfinite(y)
    N, y = N[ok], y[ok]

    def mean_entry(v: np.ndarray) -> dict[str, Any]:
        m, se, dof = hac_mean(v)
        if not math.isfinite(se):
            return {"value": m, "low95": None, "high95": None}
        tq = float(t_ppf(0.975, dof))
        return {"value": m, "low95": m - tq * se, "high95": m + tq * se}

    if retentivity == "band" or retentivity is None:
        level, definition = band[1], f"passes until mu leaves the band (rises above {band[1]:g})"
    else:
        if mu_dry is None:
            raise ValueError("retentivity as a fraction of dry needs the dry coefficient")
        level = float(retentivity) * float(mu_dry)
        definition = f"passes until mu returns to {float(retentivity):g} of dry ({level:.4g})"
    inside = ((y >= band[0]) & (y <= band[1])).astype(float)
    med = running_median(y, smooth)

    def first_above(s: np.ndarray) -> float:
        hit = np.flatnonzero(s > level)
        return float(N[hit[0]]) if hit.size else math.inf

    r0 = first_above(med)
    rets = []
    r = y - med
    if replicates > 0 and r.size >= 8:
        L = _block_length(r, smooth)
        rng = np.random.default_rng(seed)
        nb = math.ceil(r.size / L)
        for _ in range(int(replicates)):
            starts = rng.integers(0, r.size, size=nb)
            idx = (starts[:, None] + np.arange(L)[None, :]).ravel()[:r.size] % r.size
            rets.append(first_above(running_median(med + r[idx], smooth)))
    ret: dict[str, Any] = {"value": r0 if math.isfinite(r0) else None, "low95": None,
                           "high95": None, "definition": definition, "level": float(level)}
    if rets:
        a = np.asarray(rets)
        # "never" ranks above every number (a stand-in keeps the quantiles' arithmetic finite)
        lo, hi = (math.inf if v >= 1e300 else float(v)
                  for v in np.quantile(np.where(np.isfinite(a), a, 1e300), [0.025, 0.975]))
        ret.update(low95=float(lo) if math.isfinite(lo) else None,
                   high95=float(hi) if math.isfinite(hi) else None,
                   p_reached=float(np.mean(np.isfinite(a))))
    return {"effective_friction": mean_entry(y), "fraction_in_band": mean_entry(inside),
            "retentivity": ret, "window_passes": [float(N[0]), float(N[-1])],
            "band": list(band),
            "holds": "the record's own noise (batch means; block bootstrap of the scatter about "
                     "its running median); one test: not the scatter between tests"}
