"""MTM/ETM reductions: time tests after application (Paper B), traction and Stribeck curves.

Time test after application (thesis 5.3.2, Fig. 5.9)
----------------------------------------------------
Paper B applies a TOR lubricant to the running MTM contact (800 MPa, 2 % SRR,
1 m/s) and follows the coefficient for 20 minutes: it drops at the application,
recovers, and is averaged "after initial drop recovery until the end of the
test".  :func:`time_test_metrics` computes, from the coefficient ``mu(t)``:

* the **application moment** ``t_app`` (given, or detected: the largest drop of
  the mean coefficient between two adjacent windows of ``application_window``;
  ``t_app`` is the last sample before the smoothed coefficient has fallen by a
  quarter of that drop.  A largest drop under ``min_drop`` means the record
  holds no application and it is evaluated from its start);
* the **minimum** of the smoothed coefficient after ``t_app`` and its time;
* the **plateau**: the median coefficient over the last ``tail`` of the
  evaluated record;
* the **time to recover**: from ``t_app`` to the first sample after the minimum
  where the smoothed coefficient reaches the *recovery level*.  By default the
  level is ``min + 0.9 (plateau - min)`` -- 90 % of the way back from the
  minimum to the level the coefficient settles at (a rise time, which does not
  depend on how high the plateau is); ``recovery_level=`` gives a fixed level
  instead.  A record whose plateau is less than ``min_rise`` above its minimum
  has *not recovered* (over-application: the coefficient stays low), and the
  recovery figures are left empty;
* the **mean after recovery** (and its standard deviation) from the recovery
  time to the end -- the figure Paper B reports;
* the **time below the low-adhesion threshold** (0.15 by default, the value
  used in the literature for sufficient adhesion): the time from ``t_app`` to the
  end during which the smoothed coefficient is below it (each sample counts
  until the next one).

"Smoothed" is a running median over ``smooth`` (10 s by default; ``0`` uses the
raw samples), so one noisy sample does not make a minimum or a crossing.

The analysis is for records with an application: :func:`reduce_pcs` runs it on
the timed steps whose description marks one (``"time test after
application"``), or on every timed step when asked (``after_application=True``,
``--after-application``); a plain timed run (a 3-hour ball-on-disc test) is
reduced as a curve with its mean and spread only.

Curves
------
:func:`reduce_pcs` turns every data step of a PCS file into tidy curves, one
table per step kind: traction steps -> mu against SRR, Stribeck steps -> mu
against rolling speed, timed steps (ball or pin on disc) -> mu against time,
film steps (EHD2) -> film thickness against rolling speed (their ``Traction Force
1 / Ball Load`` at pure rolling is the load cell's offset: noted, not a coefficient), mapper
and unknown step types -> mu against the x column of their own header; each row
with every column the step logged.  The coefficient is the signed one (see
:mod:`torlab.parsers.pcs`); SRR is a fraction as PCS defines it.  EHD2 film
steps are labelled by their temperature.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.parsers.pcs import PcsMetadata, coefficient_column

__all__ = [
    "DEFAULT_THRESHOLD",
    "PcsReduction",
    "TimeTestResult",
    "application_marked",
    "mu_series",
    "reduce_pcs",
    "running_median",
    "step_kind",
    "step_label",
    "time_test_metrics",
]

DEFAULT_THRESHOLD = 0.15
DEFAULT_RECOVERY_FRACTION = 0.9
DEFAULT_SMOOTH_S = 10.0
DEFAULT_MIN_DROP = 0.05
DEFAULT_MIN_RISE = 0.03
DEFAULT_TAIL_S = 120.0
DEFAULT_APPLICATION_WINDOW_S = 30.0

#: x column of each step kind when its header's plot column is not logged
CURVE_X = {"traction": "srr", "stribeck": "rolling_speed_m_s", "timed": "step_time_s",
           "film": "rolling_speed_m_s", "mapper": "srr"}


@dataclass
class TimeTestResult:
    """Figures of one time test after application (see the module docstring).

    Times ``*_s`` are step times (s) except ``recovery_time_s`` (from the
    application) and ``time_below_threshold_s`` (a duration).  Figures that do
    not exist (no recovery) are NaN.
    """

    label: str
    step: int
    n: int
    application_time_s: float
    application_source: str
    pre_application_mean: float
    minimum: float
    minimum_time_s: float
    plateau: float
    recovery_level: float
    recovered: bool
    recovery_at_s: float
    recovery_time_s: float
    mean_after_recovery: float
    sd_after_recovery: float
    mean_after_application: float
    time_below_threshold_s: float
    threshold: float
    evaluated_until_s: float
    smooth_s: float
    notes: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """One row for ``time_tests.csv``."""
        d = asdict(self)
        d["notes"] = "; ".join(self.notes)
        return d


#: columns of time_tests.csv that may be empty (figure does not exist)
TIME_TEST_OPTIONAL = ("pre_application_mean", "recovery_at_s", "recovery_time_s",
                      "mean_after_recovery", "sd_after_recovery")


def running_median(y: np.ndarray, k: int) -> np.ndarray:
    """Running median over ``k`` samples (made odd; edges mirror the record)."""
    y = np.asarray(y, dtype=float)
    if k <= 1 or y.size < 3:
        return y.copy()
    k = k if k % 2 else k + 1
    if k > y.size:
        k = y.size if y.size % 2 else y.size - 1
    from scipy.ndimage import median_filter

    return median_filter(y, size=k, mode="mirror")


def _window_samples(seconds: float, dt: float) -> int:
    return max(1, round(seconds / dt)) if seconds > 0 else 1


def time_test_metrics(  # noqa: C901 (the time test's figures in the order Paper B reports them)
    t: np.ndarray,
    mu: np.ndarray,
    *,
    application_time: float | None = None,
    threshold: float = DEFAULT_THRESHOLD,
    recovery_fraction: float = DEFAULT_RECOVERY_FRACTION,
    recovery_level: float | None = None,
    smooth: float = DEFAULT_SMOOTH_S,
    min_drop: float = DEFAULT_MIN_DROP,
    min_rise: float = DEFAULT_MIN_RISE,
    tail: float = DEFAULT_TAIL_S,
    application_window: float = DEFAULT_APPLICATION_WINDOW_S,
    duration: float | None = None,
    label: str = "",
    step: int = 0,
) -> TimeTestResult:
    """Figures of a time test after application (thesis Fig. 5.9, Paper B).

    Parameters
    ----------
    t, mu
        Time (s, increasing) and coefficient.
    application_time
        Application moment (s, on the ``t`` axis); detected when ``None``.
    threshold
        Low-adhesion threshold (default 0.15).
    recovery_fraction
        Recovery level as the fraction of the way from the minimum back to the
        plateau (default 0.9); ignored when ``recovery_level`` is given.
    recovery_level
        Fixed recovery level (coefficient) instead.
    smooth
        Running-median window (s) for minimum, crossings and detection.
    min_drop
        Smallest drop taken as an application when detecting it.
    min_rise
        Smallest plateau - minimum taken as a recovery (relative definition).
    tail
        Window (s) at the end over which the plateau is the median.
    application_window
        Window (s) of the drop detector.
    duration
        Evaluate up to ``t_app + duration`` (Paper B: 20 min); default the end.
    label, step
        Carried into the result.

    Returns
    -------
    TimeTestResult

    Raises
    ------
    TorlabInputError
        Fewer than 5 samples, non-increasing time, bad options, or an
        application time outside the record.
    """
    t = np.asarray(t, dtype=float)
    mu = np.asarray(mu, dtype=float)
    ok = np.isfinite(t) & np.isfinite(mu)
    t, mu = t[ok], mu[ok]
    if t.size < 5:
        raise TorlabInputError(f"{label or 'time test'}: needs at least 5 samples with a "
                               f"coefficient, got {t.size}")
    if np.any(np.diff(t) <= 0):
        raise TorlabInputError(f"{label or 'time test'}: time does not increase")
    for nm, v in (("threshold", threshold), ("smooth", smooth), ("tail", tail),
                  ("min_drop", min_drop), ("min_rise", min_rise),
                  ("application_window", application_window)):
        if not (math.isfinite(v) and v >= 0):
            raise TorlabInputError(f"must be a non-negative number, got {v}", key=nm)
    if not (0 < recovery_fraction <= 1):
        raise TorlabInputError(f"must be in (0, 1], got {recovery_fraction}", key="recovery_fraction")
    notes: list[str] = []
    dt = float(np.median(np.diff(t)))
    ks = _window_samples(smooth, dt)
    mus = running_median(mu, ks)

    # -- application moment
    if application_time is not None:
        if not (t[0] <= application_time < t[-1]):
            raise TorlabInputError(f"application time {application_time:g} s is outside the record "
                                   f"({t[0]:g}-{t[-1]:g} s)", key="application_time")
        i_app = int(np.searchsorted(t, application_time, side="right") - 1)
        t_app = float(application_time)
        source = "given"
    else:
        w = max(2, _window_samples(application_window, dt))
        i_app, t_app, source = 0, float(t[0]), "start (no drop found)"
        if t.size >= 2 * w + 1:
            c = np.concatenate(([0.0], np.cumsum(mu)))
            idx = np.arange(w, t.size - w + 1)
            after = (c[idx + w] - c[idx]) / w
            before = (c[idx] - c[idx - w]) / w
            contrast = after - before
            k = int(np.argmin(contrast))
            drop = -float(contrast[k])
            if drop >= min_drop:
                i0 = int(idx[k])
                pre = float(np.median(mu[i0 - w:i0]))
                low = float(np.min(mus[i0:i0 + w]))
                level = pre - 0.25 * (pre - low)
                lo = max(1, i0 - w)
                below = np.nonzero(mus[lo:i0 + w] < level)[0]
                j = lo + int(below[0]) if below.size else i0
                i_app = max(0, j - 1)
                t_app = float(t[i_app])
                source = "detected"
        if source != "detected":
            notes.append(f"no drop of at least {min_drop:g} found; evaluated from the start")
    # -- evaluated range
    end = t[-1] if duration is None else min(t[-1], t_app + duration)
    if duration is not None and t_app + duration > t[-1] + dt:
        notes.append(f"record ends {t_app + duration - t[-1]:.0f} s before the requested duration")
    sel = (t >= t_app) & (t <= end)
    if np.count_nonzero(sel) < 3:
        raise TorlabInputError(f"{label or 'time test'}: fewer than 3 samples after the "
                               "application moment")
    ia = np.nonzero(sel)[0]
    tt, mm, ms = t[ia], mu[ia], mus[ia]
    pre_mean = float(np.mean(mu[:i_app])) if i_app > 0 and source != "start (no drop found)" \
        else float("nan")
    k_min = int(np.argmin(ms))
    mu_min, t_min = float(ms[k_min]), float(tt[k_min])
    tail_sel = tt >= tt[-1] - tail
    plateau = float(np.median(mm[tail_sel]))
    if recovery_level is not None:
        level = float(recovery_level)
        can = True
    else:
        level = mu_min + recovery_fraction * (plateau - mu_min)
        can = plateau - mu_min >= min_rise
        if not can:
            notes.append(f"plateau {plateau:.3f} is less than {min_rise:g} above the minimum "
                         f"{mu_min:.3f}: not recovered")
    recovered = False
    rec_at = rec_time = mean_rec = sd_rec = float("nan")
    if can:
        up = np.nonzero(ms[k_min:] >= level)[0]
        if up.size:
            kr = k_min + int(up[0])
            recovered = True
            rec_at = float(tt[kr])
            rec_time = rec_at - t_app
            mean_rec = float(np.mean(mm[kr:]))
            sd_rec = float(np.std(mm[kr:], ddof=1)) if mm[kr:].size > 1 else 0.0
        else:
            notes.append(f"never reaches the recovery level {level:.3f}")
    # time below threshold: each sample holds until the next one
    dts = np.diff(tt, append=tt[-1] + dt)
    below_time = float(np.sum(dts[ms < threshold]))
    return TimeTestResult(
        label=label, step=step, n=int(tt.size), application_time_s=t_app,
        application_source=source, pre_application_mean=pre_mean, minimum=mu_min,
        minimum_time_s=t_min, plateau=plateau, recovery_level=level, recovered=recovered,
        recovery_at_s=rec_at, recovery_time_s=rec_time, mean_after_recovery=mean_rec,
        sd_after_recovery=sd_rec, mean_after_application=float(np.mean(mm)),
        time_below_threshold_s=below_time, threshold=threshold, evaluated_until_s=float(tt[-1]),
        smooth_s=float(ks * dt if ks > 1 else 0.0), notes=notes,
    )


def mu_series(df: Any, meta: Any = None) -> tuple[np.ndarray | None, str]:
    """The signed traction coefficient of PCS rows and where it comes from.

    Row by row, the first available of: the coefficient column (signed, see
    :func:`torlab.parsers.pcs.coefficient_column`); ``Traction Force / Ball
    Load``; ``Traction Force 1 / Ball Load`` (EHD2 film steps, which log only
    that force).  A blank coefficient cell is filled from the forces of its own
    row, so one blank cell never blanks other rows.  A row whose Ball Load is
    zero or negative gets no coefficient from the forces; with ``meta`` given,
    such rows are reported in ``meta.warnings`` with their lines.  ``(None, "")``
    when no row has a coefficient source.
    """
    n = len(df)
    mu = np.full(n, np.nan)
    parts: list[str] = []
    col, src = coefficient_column(df)
    if col:
        c = df[col].to_numpy(dtype=float)
        have = np.isfinite(c)
        mu[have] = c[have]
        if have.any():
            parts.append(src)
    if "ball_load_N" in df:
        w = df["ball_load_N"].to_numpy(dtype=float)
        zero = np.isfinite(w) & (w <= 0)
        for fcol, label in (("traction_force_N", "Traction Force / Ball Load"),
                            ("traction_force_1_N", "Traction Force 1 / Ball Load")):
            if fcol not in df:
                continue
            f = df[fcol].to_numpy(dtype=float)
            fill = ~np.isfinite(mu) & np.isfinite(f) & np.isfinite(w) & (w > 0)
            if fill.any():
                mu[fill] = f[fill] / w[fill]
                parts.append(label if not parts else f"{label} ({int(fill.sum())} rows)")
        if zero.any() and meta is not None:
            kept = "the coefficient column is kept as written" if col and \
                np.isfinite(mu[zero]).all() else "no coefficient from the forces there"
            meta.warnings.append(f"Ball Load is zero or negative in {int(zero.sum())} of {n} "
                                 f"rows ({_lines(df, zero)}): {kept}")
    if not parts:
        return None, ""
    return mu, " + ".join(parts)


def _lines(df: Any, sel: np.ndarray) -> str:
    """``lines a-b`` (or ``line a``) of the selected rows, for messages."""
    if "line" not in df:
        return f"{int(sel.sum())} rows"
    ln = df["line"].to_numpy()[sel]
    return f"line {ln[0]}" if len(ln) == 1 else f"lines {ln.min()}-{ln.max()}"


@dataclass
class PcsReduction:
    """Reduced PCS file.

    Attributes
    ----------
    meta
        The file's :class:`~torlab.parsers.pcs.PcsMetadata`.
    curves
        Step kind (``traction``, ``stribeck``, ``timed``, ``film``, ``mapper``,
        or an unknown step type's own name) -> tidy DataFrame of its steps:
        ``step``, ``label``, ``traction_coefficient`` (signed) and every column
        the steps logged (the file's own header), ``line``.
    steps
        One summary row per data step (kind, label, x column, load,
        temperatures, coefficient mean/sd/range, film range ...).
    time_tests
        :class:`TimeTestResult` of every timed step analysed as a time test
        after application.
    mu_source
        Where the coefficient came from.
    curve_x, curve_y
        Kind -> the x and y column of its curves (x from the steps' own
        header: PCS writes each step's plot x column first).
    notes
        What the reduction decided (unknown kinds, timed steps not analysed ...).
    traction_map
        With :data:`MAP_MIN_STEPS` traction steps or more (a long series of sweeps):
        :func:`traction_map`, the median coefficient per step and SRR bin, with the
        time of each step; else None.
    other_steps
        ``step, step_type, time_h`` of the steps without a curve (mapper images,
        heating ...), for marking them on the time axis of a long series; or None.
    """

    meta: PcsMetadata
    curves: dict[str, Any]
    steps: Any
    time_tests: list[TimeTestResult]
    mu_source: str
    curve_x: dict[str, str] = field(default_factory=dict)
    curve_y: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    traction_map: Any = None
    other_steps: Any = None

    @property
    def label(self) -> str:
        """File name for tables and figures."""
        return Path(self.meta.source).name


def _nan_stat(fn: Any, v: np.ndarray) -> float:
    v = v[np.isfinite(v)]
    return float(fn(v)) if v.size else float("nan")


def step_kind(step: Any) -> str:
    """The kind a step is reduced as: its normalised type, or its own type name when unknown."""
    if step.type != "other":
        return step.type
    from torlab.parsers.pcs import sanitise

    return sanitise(step.type_raw) or "other"


def application_marked(step: Any, meta: PcsMetadata) -> bool:
    """Whether the file marks an application in this step (its description or the profile's).

    The time-test analysis after application (Paper B) is meant for records
    with an application; PCS exports carry no flag for it, so the words of
    the step description or the profile description (``"... after
    application"``) are the mark.
    """
    import re

    text = f"{step.description} {meta.profile}".lower()
    return re.search(r"\bappli(?:cation|ed)\b", text) is not None


def step_label(step: Any, sub: Any) -> str:
    """A readable label: film steps by their temperature (``"40.2 °C"``), others by number."""
    if step.type == "film":
        for c in ("lube_temperature_C", "pot_temperature_C"):
            if c in sub and sub[c].notna().any():
                return f"{float(sub[c].mean()):.1f} °C"
    return f"step {step.number}"


def reduce_pcs(df: Any, meta: PcsMetadata, *, time_tests: bool = True,  # noqa: C901 (one pass over the file's steps: each kind's curve, row and time test)
               after_application: bool | None = None, **time_test_options: Any) -> PcsReduction:
    """Reduce a parsed PCS file: curves per step kind, step summaries, time tests.

    Every data step is reduced the same way, whatever its kind: its rows with
    every column it logged, the signed coefficient (:func:`mu_series`) and a
    summary row; the x column of its curve is the first column of its own
    header (the step's plot x in the PCS software).  Unknown step types are
    reduced the same way under their own name, with a note.

    Parameters
    ----------
    df, meta
        From :func:`torlab.parsers.pcs.read_pcs`.
    time_tests
        Allow the time-test analysis after application.
    after_application
        ``True``: analyse every timed step as a time test after application
        (:func:`time_test_metrics`); ``None`` (default): only the timed steps
        whose description (or the profile's) marks an application, or every
        one when ``application_time`` is given; ``False``: none.
    **time_test_options
        Passed to :func:`time_test_metrics` (``threshold``, ``application_time``,
        ``recovery_fraction``, ``recovery_level``, ``smooth``, ``duration`` ...).

    Returns
    -------
    PcsReduction

    Raises
    ------
    TorlabInputError
        The file has no data step with a traction coefficient, traction force
        or film thickness to reduce.
    """
    import pandas as pd

    if len(df) == 0:
        raise TorlabInputError("no data rows in any step (nothing to reduce)", path=meta.source)
    mu, src = mu_series(df, meta)
    has_film = "film_thickness_m" in df and df["film_thickness_m"].notna().any()
    if (mu is None or not np.isfinite(mu).any()) and not has_film:
        raise TorlabInputError("no traction coefficient, traction force or film thickness in any "
                               "step: no traction, Stribeck, timed or film curve to reduce (every "
                               "Traction Coeff cell is blank and Traction Force / Ball Load cannot "
                               "be formed: no force or a zero Ball Load)", path=meta.source)
    if after_application is None and time_test_options.get("application_time") is not None:
        after_application = True
    step_no = df["step"].to_numpy()
    line = df["line"].to_numpy()
    value_cols = [c for c in df.columns if c not in ("step", "step_type", "line",
                                                     "traction_coefficient",
                                                     "traction_coefficient_signed")]
    parts: dict[str, list[Any]] = {}
    xcols: dict[str, list[str]] = {}
    rows, tts, notes = [], [], []
    plain_timed = []
    rolling_offsets: list[tuple[int, float, float, float]] = []
    glitches: list[tuple[int, Any, np.ndarray]] = []
    for st in meta.steps:
        if not st.has_data:
            continue
        sel = (step_no == st.number) & (line >= st.first_line) & (line <= st.last_line)
        if not sel.any():
            continue
        sub = df.loc[sel]
        kind = step_kind(st)
        m = mu[sel] if mu is not None else np.full(int(sel.sum()), np.nan)
        if kind == "film":
            m, offset = _rolling_force_ratio(sub, m)
            if offset is not None:
                rolling_offsets.append((st.number, *offset))
        logged = [c for c in value_cols if sub[c].notna().any()]
        x = st.plot_x if st.plot_x in logged and st.plot_x != "traction_coefficient" else \
            CURVE_X.get(kind, "step_time_s")
        if x not in logged:
            x = next((c for c in ("step_time_s", *logged) if c in logged), "")
        if st.type == "other":
            notes.append(f"step {st.number}: step type {st.type_raw!r} is not one torlab knows; "
                         f"reduced generically as {kind!r} (every logged column, x: {x or 'none'})")
        label = step_label(st, sub)
        cur = {"step": sub["step"].to_numpy(), "label": np.full(int(sel.sum()), label,
                                                                  dtype=object)}
        if np.isfinite(m).any():
            cur["traction_coefficient"] = m
        for c in logged:
            cur[c] = sub[c].to_numpy()
        cur["line"] = sub["line"].to_numpy()
        if kind == "film":
            bad = film_order_outliers(sub)
            if bad.any():
                cur["interference_order_outlier"] = bad
                notes.append(_order_note(st.number, label, sub, bad))
        if kind == "traction":
            bad = speed_glitches(sub)
            if bad.any():
                cur["speed_outlier"] = bad
                glitches.append((st.number, sub, bad))
        parts.setdefault(kind, []).append(pd.DataFrame(cur))
        xcols.setdefault(kind, []).append(x)
        rows.append(_step_row(meta, st, kind, label, x, sub, m))
        if st.type != "timed" or not time_tests or "step_time_s" not in sub:
            continue
        if after_application is False or (after_application is None
                                           and not application_marked(st, meta)):
            plain_timed.append(st.number)
            continue
        if st is meta.unfinished_step and time_test_options.get("duration") is None:
            raise TorlabInputError(
                f"step {st.number}: the test stopped during this time test (the export "
                f"{'has no end line' if meta.completed_at is None else 'ends ' + repr(meta.end_text)}"
                f"), so its record is shorter than the test and would be analysed as a "
                f"finished one; give --duration up to the recorded "
                f"{np.nanmax(sub['step_time_s'].to_numpy(dtype=float)):.0f} s to analyse the "
                "part recorded", path=meta.source, line=st.last_line)
        tt = _time_test(meta, st, sub["step_time_s"].to_numpy(dtype=float), m, time_test_options)
        if tt is not None:
            tts.append(tt)
    if glitches:
        notes.append(_glitch_note(glitches))
    if rolling_offsets:
        lo = min(o[1] for o in rolling_offsets)
        hi = max(o[2] for o in rolling_offsets)
        srr = max(o[3] for o in rolling_offsets)
        notes.append(f"film step(s) {', '.join(str(o[0]) for o in rolling_offsets)}: Traction "
                     f"Force 1 / Ball Load is {lo:.3f}-{hi:.3f} at pure rolling (|SRR| at most "
                     f"{100 * srr:.2g} %), where there is no traction to measure: it is the load "
                     "cell's offset, not a traction coefficient, and is neither tabled nor "
                     "plotted as one (traction_force_1_N and ball_load_N are kept)")
        if not any(np.isfinite(r["traction_coefficient_mean"]) for r in rows
                   if "traction_coefficient_mean" in r):
            src = ""
    if plain_timed:
        notes.append(f"timed step(s) {', '.join(map(str, plain_timed))}: no application marked, "
                     "reduced as plain timed runs (ask for the time-test analysis after "
                     "application with --after-application)")
    curves, curve_x, curve_y = {}, {}, {}
    for kind, frames in parts.items():
        cdf = pd.concat(frames, ignore_index=True, sort=False)
        x = max(set(xcols[kind]), key=xcols[kind].count)
        y = "traction_coefficient" if "traction_coefficient" in cdf else ""
        if kind == "film" and "film_thickness_m" in cdf:
            y = "film_thickness_m"
        if not y:
            y = next((c for c in ("film_thickness_m", "traction_force_N") if c in cdf), "")
        if not x or not y:
            notes.append(f"{kind} steps: no {'x' if not x else 'y'} column, no curve")
            continue
        for flag in ("interference_order_outlier", "speed_outlier"):
            if flag in cdf:
                cdf[flag] = cdf[flag].astype("boolean").fillna(False).astype(bool)
        keep = cdf[x].notna() & cdf[y].notna()
        if not keep.all():
            lost = ~keep.to_numpy()
            meta.warnings.append(f"{kind} steps: {int(lost.sum())} of {len(cdf)} rows have no "
                                 f"{y} or no {x} and are left out ({_lines(cdf, lost)})")
        if not keep.any():
            continue
        curves[kind] = cdf.loc[keep].reset_index(drop=True)
        curve_x[kind], curve_y[kind] = x, y
    steps = pd.DataFrame(rows)
    # summary columns never filled in this file are dropped
    steps = steps[[c for c in steps.columns if steps[c].dtype == object or steps[c].notna().any()]]
    tmap = others = None
    tr = curves.get("traction")
    if tr is not None and tr["step"].nunique() >= MAP_MIN_STEPS and "srr" in tr \
            and "traction_coefficient" in tr:
        times = step_times(meta)
        tmap = traction_map(tr, times)
        others = pd.DataFrame([{"step": st.number, "step_type": step_kind(st),
                                "time_h": times.get(st.number, float("nan"))}
                               for st in meta.steps if step_kind(st) not in curves])
    return PcsReduction(meta=meta, curves=curves, steps=steps, time_tests=tts, mu_source=src,
                        traction_map=tmap, other_steps=others, curve_x=curve_x, curve_y=curve_y, notes=notes)


#: a traction step's reading whose rolling speed is off the step's median by more than this
#: fraction is a speed-control glitch (the steps run at one speed)
SPEED_GLITCH = 0.1
#: from this many traction steps on, the reduction adds the traction map (a long series)
MAP_MIN_STEPS = 10


def speed_glitches(sub: Any) -> np.ndarray:
    """Readings of a traction step whose rolling speed is off the step's median by more than
    :data:`SPEED_GLITCH` (a traction step holds one speed; such a reading has its SRR from
    the glitch, e.g. -27.8 % in a 0-20 % sweep).  Boolean mask (all False without speeds)."""
    if "rolling_speed_m_s" not in sub:
        return np.zeros(len(sub), dtype=bool)
    v = sub["rolling_speed_m_s"].to_numpy(dtype=float)
    ok = np.isfinite(v)
    if ok.sum() < 3:
        return np.zeros(len(sub), dtype=bool)
    med = float(np.median(v[ok]))
    return ok & (np.abs(v - med) > SPEED_GLITCH * abs(med)) if med != 0 else np.zeros(len(sub),
                                                                                      dtype=bool)


def _glitch_note(glitches: list[tuple[int, Any, np.ndarray]]) -> str:
    """The note on traction readings at a glitch of the speed control."""
    parts = []
    for st, sub, bad in glitches:
        v = sub["rolling_speed_m_s"].to_numpy(dtype=float)
        srr = sub["srr"].to_numpy(dtype=float) if "srr" in sub else np.full(len(sub), np.nan)
        for i in np.nonzero(bad)[0]:
            parts.append(f"step {st} line {int(sub['line'].to_numpy()[i])} ({1e3 * v[i]:.4g} mm/s "
                         f"against {1e3 * float(np.median(v)):.4g}, SRR {100 * srr[i]:.3g} %)")
    shown = "; ".join(parts[:5]) + (f"; and {len(parts) - 5} more" if len(parts) > 5 else "")
    return (f"traction steps: {len(parts)} reading(s) at a glitch of the speed control, rolling "
            f"speed more than {100 * SPEED_GLITCH:g} % off the step's median: {shown}; left out "
            "of the traction curves, map and fits (kept in the table: speed_outlier)")


def step_times(meta: PcsMetadata) -> dict[int, float]:
    """Hours from the first data step's start to each step's start (steps with a date)."""
    starts = {st.number: st.started_at for st in meta.steps if st.started_at is not None}
    data = [starts[st.number] for st in meta.steps if st.has_data and st.number in starts]
    if not data:
        return {}
    t0 = min(data)
    return {k: (t - t0).total_seconds() / 3600.0 for k, t in starts.items()}


def _nice_width(span: float) -> float:
    """A bin width from 1, 2, 2.5, 5 x 10^k near ``span`` / 12."""
    raw = max(span / 12.0, 1e-6)
    k = math.floor(math.log10(raw))
    for m in (1.0, 2.0, 2.5, 5.0, 10.0):
        if m * 10**k >= raw:
            return m * 10**k
    return 10.0 ** (k + 1)


def traction_map(d: Any, times: dict[int, float] | None = None) -> Any:
    """The median coefficient of each traction step in bins of SRR: a long table.

    A long series of sweeps (the ETM's 500) is too many curves to draw one by one; binned,
    it is a map (step x SRR, the coefficient as colour) and, row by row, the coefficient
    at one SRR against the step or the time.  The bins are 1, 2, 2.5 or 5 x 10^k wide,
    about 12 over the range holding 99.8 % of the readings (a sweep of about 40 readings
    then puts three or four in each); a bin's value is the median of the step's readings
    in it (both branches of a down-and-up sweep), so one stray reading does not move it.
    Readings flagged as speed glitches are left out, and so are bins that fewer than half
    of the steps read (the ends of the sweeps).

    Returns
    -------
    pandas.DataFrame
        ``step``, ``time_h`` (hours from the first data step's start; NaN without
        dates), ``srr_low``, ``srr_high``, ``srr`` (the bin's centre; fractions as
        PCS SRR), ``traction_coefficient`` (median), ``n_points``.
    """
    import pandas as pd

    keep = ~d["speed_outlier"].to_numpy(dtype=bool) if "speed_outlier" in d else \
        np.ones(len(d), dtype=bool)
    srr = d["srr"].to_numpy(dtype=float)[keep]
    mu = d["traction_coefficient"].to_numpy(dtype=float)[keep]
    step = d["step"].to_numpy()[keep]
    ok = np.isfinite(srr) & np.isfinite(mu)
    srr, mu, step = srr[ok], mu[ok], step[ok]
    lo, hi = np.quantile(srr, [0.001, 0.999])
    w = _nice_width(float(hi - lo) if hi > lo else 0.01)
    edges = np.arange(math.floor(lo / w) * w, (math.floor(hi / w) + 1) * w + w / 2, w)
    idx = np.digitize(srr, edges) - 1
    inside = (idx >= 0) & (idx < edges.size - 1)
    t = pd.DataFrame({"step": step[inside], "bin": idx[inside], "mu": mu[inside]})
    # a bin read in fewer than half of the steps (the sweep's ends) is left out
    cover = t.groupby("bin")["step"].nunique()
    t = t[t["bin"].isin(cover.index[cover >= 0.5 * np.unique(step).size])]
    g = t.groupby(["step", "bin"], sort=True)["mu"]
    out = pd.concat([g.median().rename("traction_coefficient"), g.size().rename("n_points")],
                    axis=1).reset_index()
    times = times or {}
    out.insert(1, "time_h", out["step"].map(lambda s: times.get(int(s), float("nan"))))
    b = out.pop("bin").to_numpy()
    out.insert(2, "srr_low", edges[b])
    out.insert(3, "srr_high", edges[b + 1])
    out.insert(4, "srr", 0.5 * (edges[b] + edges[b + 1]))
    return out


#: a film reading more than this factor off a reading of the step's usual interference
#: order, on the wrong side of it for its speed, is a fringe-order misassignment
ORDER_JUMP = 2.0


def film_order_outliers(sub: Any) -> np.ndarray:
    """Rows of an EHD2 film step whose film is a fringe-order misassignment.

    The EHD2 finds the film from the wavelength of an interference peak and its order;
    the order changes legitimately as the film grows (a thicker film at a higher
    order), but a misassigned order shifts the film by a whole fringe (about 200 nm at
    order 3-4).  A row is flagged when its order is not the step's most common one *and*
    its film breaks the film's rise with speed by more than :data:`ORDER_JUMP` against a
    row of the common order: more than twice the film at a faster speed, or less than
    half the film at a slower one.  A row at another order that continues the curve (the
    thick films of ``demo_3.txt``) is not flagged.

    Returns
    -------
    numpy.ndarray
        Boolean mask over the rows of ``sub`` (all False without the columns).
    """
    n = len(sub)
    if "interference_order" not in sub or "film_thickness_m" not in sub \
            or "rolling_speed_m_s" not in sub:
        return np.zeros(n, dtype=bool)
    order = sub["interference_order"].to_numpy(dtype=float)
    h = sub["film_thickness_m"].to_numpy(dtype=float)
    v = sub["rolling_speed_m_s"].to_numpy(dtype=float)
    ok = np.isfinite(order) & np.isfinite(h) & np.isfinite(v) & (h > 0)
    if ok.sum() < 3:
        return np.zeros(n, dtype=bool)
    vals, counts = np.unique(order[ok], return_counts=True)
    common = vals[np.argmax(counts)]
    ref = ok & (order == common)
    out = np.zeros(n, dtype=bool)
    for i in np.nonzero(ok & (order != common))[0]:
        faster = ref & (v > v[i])
        slower = ref & (v < v[i])
        out[i] = bool((faster.any() and h[i] > ORDER_JUMP * np.min(h[faster]))
                      or (slower.any() and h[i] < np.max(h[slower]) / ORDER_JUMP))
    return out


def _order_note(step: int, label: str, sub: Any, bad: np.ndarray) -> str:
    """The note on a film step's fringe-order misassignments."""
    order = sub["interference_order"].to_numpy(dtype=float)
    vals, counts = np.unique(order[np.isfinite(order)], return_counts=True)
    common = vals[np.argmax(counts)]
    h = sub["film_thickness_m"].to_numpy(dtype=float)[bad] * 1e9
    v = sub["rolling_speed_m_s"].to_numpy(dtype=float)[bad] * 1e3
    orders = ", ".join(f"{o:g}" for o in sorted(set(order[bad])))
    return (f"film step {step} ({label}): {int(bad.sum())} row(s) ({_lines(sub, bad)}; "
            f"{v.min():.0f}-{v.max():.0f} mm/s, {h.min():.1f}-{h.max():.1f} nm) at interference "
            f"order {orders} where the step's others are at {common:g}, breaking the film's rise "
            f"with speed by more than a factor {ORDER_JUMP:g}: a fringe-order misassignment, "
            "left out of the film curves and fits (kept in the table: "
            "interference_order_outlier)")


#: a film step whose rows all slide less than this (|SRR|, fraction) is at pure rolling
ROLLING_SRR = 0.02


def _rolling_force_ratio(sub: Any, m: np.ndarray) -> tuple[np.ndarray, tuple[float, float, float]
                                                            | None]:
    """A film step's coefficient, blanked where it is ``Traction Force 1 / Ball Load`` at
    pure rolling.

    The EHD2 logs one traction force in its film steps; at ``|SRR| <= 2 %`` (the
    rolling the film is measured at) the contact carries no traction to speak of, and
    the ratio (0.04-0.18 in real exports) is the load cell's zero offset.  Rows with a
    coefficient of their own (a ``Traction Coeff`` or ``Traction Force`` column) keep it.

    Returns
    -------
    (coefficient, (min, max, largest |SRR|) of the blanked ratios or None)
    """
    if "traction_force_1_N" not in sub or "srr" not in sub:
        return m, None
    own = np.zeros(len(sub), dtype=bool)
    for c in ("traction_coefficient_signed", "traction_coefficient", "traction_force_N"):
        if c in sub:
            own |= np.isfinite(sub[c].to_numpy(dtype=float))
    srr = np.abs(sub["srr"].to_numpy(dtype=float))
    ratio = np.isfinite(m) & ~own
    if not ratio.any() or not np.all(np.isfinite(srr[ratio]) & (srr[ratio] <= ROLLING_SRR)):
        return m, None
    out = m.copy()
    out[ratio] = np.nan
    return out, (float(np.min(m[ratio])), float(np.max(m[ratio])), float(np.max(srr[ratio])))


def _step_row(meta: PcsMetadata, st: Any, kind: str, label: str, x: str, sub: Any,
              m: np.ndarray) -> dict[str, Any]:
    """One row of the steps table."""
    from torlab.parsers.pcs import step_geometry

    def col(c: str) -> np.ndarray:
        return sub[c].to_numpy(dtype=float) if c in sub else np.array([])

    return {
        "file": Path(meta.source).name,
        "instrument": meta.instrument,
        "step": st.number,
        "step_type": kind,
        "step_type_raw": st.type_raw,
        "geometry": step_geometry(st.type_raw),
        "label": label,
        "description": st.description,
        "x_column": x,
        "started_at": "" if st.started_at is None else st.started_at.isoformat(sep=" "),
        "n_rows": len(sub),
        "duration_s": _nan_stat(np.max, col("step_time_s")),
        "ball_load_N": _nan_stat(np.mean, col("ball_load_N")),
        "lube_temperature_C": _nan_stat(np.mean, col("lube_temperature_C")),
        "pot_temperature_C": _nan_stat(np.mean, col("pot_temperature_C")),
        "rolling_speed_min_m_s": _nan_stat(np.min, col("rolling_speed_m_s")),
        "rolling_speed_max_m_s": _nan_stat(np.max, col("rolling_speed_m_s")),
        "srr_min": _nan_stat(np.min, col("srr")),
        "srr_max": _nan_stat(np.max, col("srr")),
        "traction_coefficient_mean": _nan_stat(np.mean, m),
        "traction_coefficient_sd": _nan_stat(lambda v: np.std(v, ddof=1) if v.size > 1
                                             else np.nan, m),
        "traction_coefficient_min": _nan_stat(np.min, m),
        "traction_coefficient_max": _nan_stat(np.max, m),
        "film_thickness_min_m": _nan_stat(np.min, col("film_thickness_m")),
        "film_thickness_max_m": _nan_stat(np.max, col("film_thickness_m")),
        "first_line": st.first_line,
        "last_line": st.last_line,
    }


def _time_test(meta: PcsMetadata, st: Any, t: np.ndarray, m: np.ndarray,
               options: dict[str, Any]) -> TimeTestResult | None:
    """The time-test figures of one timed step (None with fewer than 5 samples)."""
    ok = np.isfinite(t) & np.isfinite(m)
    if ok.sum() < 5:
        return None
    try:
        return time_test_metrics(t[ok], m[ok], label=Path(meta.source).name, step=st.number,
                                 **options)
    except TorlabInputError as e:
        if e.key is not None:  # a bad option: the user's error, not the file's
            raise
        raise TorlabInputError(f"step {st.number}: {e.message}", path=meta.source,
                               line=st.first_line) from None
