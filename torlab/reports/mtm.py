"""MTM/ETM figures: time tests (thesis Fig. 5.9), traction and Stribeck curves per step."""

from __future__ import annotations

from typing import Any

import numpy as np

from torlab.reports.plotting import (
    PALETTE,
    band,
    colours,
    decimate,
    legend,
    pixel_columns,
    subplots,
)

__all__ = ["axis_label", "curve_figure", "time_test_figure", "traction_evolution_figure",
           "traction_map_figure"]

#: axis label and scale of the usual columns
_AXES = {
    "srr": ("slide-to-roll ratio SRR (%)", 100.0),
    "rolling_speed_m_s": ("rolling speed U (m/s)", 1.0),
    "sliding_speed_m_s": ("sliding speed Δu (m/s)", 1.0),
    "step_time_s": ("step time t (s)", 1.0),
    "traction_coefficient": ("traction coefficient μ (–)", 1.0),
    "film_thickness_m": ("film thickness h (nm)", 1e9),
    "traction_force_N": ("traction force F_T (N)", 1.0),
}
_UNITS = (("_m_s", "m/s"), ("_Pa", "Pa"), ("_N", "N"), ("_C", "°C"), ("_s", "s"), ("_m", "m"),
          ("_Hz", "Hz"))


def axis_label(column: str) -> tuple[str, float]:
    """Axis label and scale of a torlab column (the unit from its name's suffix)."""
    if column in _AXES:
        return _AXES[column]
    for suffix, unit in _UNITS:
        if column.endswith(suffix):
            return f"{column[:-len(suffix)].replace('_', ' ')} ({unit})", 1.0
    return f"{column.replace('_', ' ')} (–)", 1.0


def curve_figure(red: Any, kind: str) -> Any:
    """One step kind of a reduced PCS file, every step on one figure.

    The y column (coefficient, or film thickness) against the x column of the
    steps' own header: traction steps against SRR (%), Stribeck steps against
    rolling speed (log axis), timed steps against step time, film steps (EHD2)
    film thickness (nm), and a coefficient where the steps have one, against rolling speed
    (log axes).
    Steps are labelled (film steps by temperature) and coloured in file order;
    more than ten are drawn thin in viridis with a colour bar.  More than
    :data:`_MANY` traction steps (a long series of sweeps) are drawn as the median
    and the 5-95 % range of the steps per SRR bin, with five of the steps
    (:func:`_many_sweeps_figure`).  Readings the reduction left out (fringe-order
    misassignments, speed glitches) are crosses.
    """
    import matplotlib

    if kind == "traction" and getattr(red, "traction_map", None) is not None \
            and red.curves[kind]["step"].nunique() > _MANY:
        return _many_sweeps_figure(red)
    d = red.curves[kind]
    xcol, ycol = red.curve_x[kind], red.curve_y[kind]
    xl, xs = axis_label(xcol)
    yl, ys = axis_label(ycol)
    steps = list(dict.fromkeys(d["step"].tolist()))
    n = len(steps)
    cmap = matplotlib.colormaps["viridis"]
    second = ycol != "traction_coefficient" and "traction_coefficient" in d
    if second:
        fig, (ax, ax2) = subplots(2, 1, sharex=True, figsize=(7.5, 6.5))
    else:
        fig, ax = subplots(figsize=(7.5, 4.8))
        ax2 = None
    lw = 1.2 if n <= 20 else 0.4
    step_arr = d["step"].to_numpy()
    labels = d["label"].to_numpy() if "label" in d else None
    outlier = np.zeros(len(d), dtype=bool)
    for flag, what in (("interference_order_outlier", "fringe-order misassignment"),
                       ("speed_outlier", "speed glitch")):
        if flag in d and d[flag].any():
            bad = d[flag].to_numpy(dtype=bool)
            ax.plot(d.loc[bad, xcol].to_numpy() * xs, d.loc[bad, ycol].to_numpy() * ys, "x",
                    ms=5, color="0.35", label=f"{what} (left out)")
            outlier |= bad
    for i, st in enumerate(steps):
        sel = (step_arr == st) & ~outlier
        x = d.loc[sel, xcol].to_numpy() * xs
        color = PALETTE[i] if n <= 10 else cmap(i / max(1, n - 1))
        label = (str(labels[sel][0]) if labels is not None else f"step {st}") if n <= 12 else None
        marker = "o" if sel.sum() < 60 else None
        ax.plot(x, d.loc[sel, ycol].to_numpy() * ys, "-", lw=lw, color=color, label=label,
                marker=marker, ms=3)
        if ax2 is not None:
            ax2.plot(x, d.loc[sel, "traction_coefficient"].to_numpy(), "-", marker=marker, ms=3,
                     lw=lw, color=color)
    (ax2 if ax2 is not None else ax).set_xlabel(xl)
    ax.set_ylabel(yl)
    if ax2 is not None:
        ax2.set_ylabel("traction coefficient μ (–)")
    if xcol == "rolling_speed_m_s" and np.nanmin(d[xcol]) > 0:
        ax.set_xscale("log")
    if ycol == "film_thickness_m" and np.nanmin(d[ycol]) > 0:
        ax.set_yscale("log")
    if n <= 12 or outlier.any():
        legend(ax)
    else:
        sm = matplotlib.cm.ScalarMappable(cmap=cmap, norm=matplotlib.colors.Normalize(
            vmin=min(steps), vmax=max(steps)))
        fig.colorbar(sm, ax=ax, label="step number")
    fig.suptitle(f"{kind.replace('_', ' ').capitalize()} steps ({n}): {red.label}")
    return fig


def time_test_figure(red: Any, results: list[Any],
                     evidence: dict[Any, dict[str, Any]] | None = None) -> Any:
    """Coefficient against time of the timed steps with the time-test figures marked.

    Marks (per step): the application moment (dashed), the minimum (dot), the
    recovery (triangle) and the mean after recovery (bar to the end), and the
    low-adhesion threshold (dotted line); the time below it is shaded.  With
    ``evidence`` (step -> the intervals of
    :func:`torlab.reduce.time_test_uncertainty.time_test_uncertainty`) the minimum
    and the recovery carry their 95 % intervals as error bars and the mean after
    recovery its 95 % band.  What each mark means is in the legend.
    """
    from torlab.reports.plotting import band_style, cap

    d = red.curves["timed"]
    fig, ax = subplots(figsize=(8.0, 4.8))
    step_arr = d["step"].to_numpy()
    by_step = {r.step: r for r in results}
    evidence = evidence or {}
    shown = False
    for i, st in enumerate(dict.fromkeys(step_arr.tolist())):
        sel = step_arr == st
        t = d.loc[sel, "step_time_s"].to_numpy()
        mu = d.loc[sel, "traction_coefficient"].to_numpy()
        color = PALETTE[i % len(PALETTE)]
        r = by_step.get(st)
        if r is None:
            continue
        shown = True
        ev = evidence.get(st, {})
        ax.plot(*decimate(t, mu, pixel_columns(ax)), lw=0.8, color=color, label=f"step {st}")
        ax.axvline(r.application_time_s, color=color, ls="--", lw=0.8)
        lo, hi = ev.get("minimum_low95", np.nan), ev.get("minimum_high95", np.nan)
        yerr = [[max(r.minimum - lo, 0.0)], [max(hi - r.minimum, 0.0)]] \
            if np.isfinite(lo) and np.isfinite(hi) else None
        ax.errorbar([r.minimum_time_s], [r.minimum], yerr=yerr, fmt="o", color=color, ms=6,
                    capsize=cap(6), mfc="white", mew=1.5, zorder=5)
        if r.recovered:
            lo, hi = ev.get("recovery_time_low95", np.nan), ev.get("recovery_time_high95", np.nan)
            xerr = [[max(r.recovery_time_s - lo, 0.0)], [max(hi - r.recovery_time_s, 0.0)]] \
                if np.isfinite(lo) and np.isfinite(hi) else None
            ax.errorbar([r.recovery_at_s], [r.recovery_level], xerr=xerr, fmt="^", color=color,
                        ms=7, capsize=cap(7), mfc="white", mew=1.5, zorder=5)
            ax.plot([r.recovery_at_s, r.evaluated_until_s], [r.mean_after_recovery] * 2,
                    color=color, lw=2.5, solid_capstyle="butt")
            lo, hi = (ev.get("mean_after_recovery_low95", np.nan),
                      ev.get("mean_after_recovery_high95", np.nan))
            if np.isfinite(lo) and np.isfinite(hi):
                band(ax, [r.recovery_at_s, r.evaluated_until_s], [lo, lo], [hi, hi],
                     color=color)
        below = np.where(mu < r.threshold, mu, np.nan)
        rgb, a = band_style(color, 0.15)
        ax.fill_between(t, below, r.threshold, where=np.isfinite(below) & (t >= r.application_time_s),
                        color=rgb, alpha=a, lw=0)
    if results:
        ax.axhline(results[0].threshold, color="k", ls=":", lw=0.8)
    ax.set_xlabel("step time t (s)")
    ax.set_ylabel("traction coefficient μ (–)")
    if shown:  # the marks, once, in grey
        g = "0.35"
        ax.plot([], [], "--", color=g, lw=0.8, label="application")
        iv = " (95 % interval)" if evidence else ""
        ax.errorbar([], [], yerr=[], fmt="o", color=g, ms=6, mfc="white", mew=1.5,
                    capsize=cap(6), label=f"minimum{iv}")
        ax.errorbar([], [], xerr=[], fmt="^", color=g, ms=7, mfc="white", mew=1.5,
                    capsize=cap(7), label=f"recovery{iv}")
        ax.plot([], [], "-", color=g, lw=2.5, label="mean after recovery"
                + (" (95 % band)" if evidence else ""))
        ax.plot([], [], ":", color="k", lw=0.8, label=f"low-adhesion threshold "
                f"{results[0].threshold:g}")
        rgb, a = band_style(g, 0.15)
        ax.fill_between([], [], [], color=rgb, alpha=a, lw=0, label="time below the threshold")
    legend(ax)
    fig.suptitle(f"Time test after application (thesis Fig. 5.9): {red.label}")
    return fig


#: more traction steps than this are drawn as a band with a few steps (and mapped)
_MANY = 20


def _selected_steps(steps: list[Any], k: int = 5) -> list[Any]:
    """``k`` steps evenly spread over the series (first and last included)."""
    if len(steps) <= k:
        return list(steps)
    idx = np.unique(np.round(np.linspace(0, len(steps) - 1, k)).astype(int))
    return [steps[i] for i in idx]


def _step_time_label(tm: Any, st: Any) -> str:
    t = tm.loc[tm["step"] == st, "time_h"]
    return f"step {st}" + (f" (t = {float(t.iloc[0]):.1f} h)" if len(t) and np.isfinite(
        float(t.iloc[0])) else "")


def _many_sweeps_figure(red: Any) -> Any:
    """A long series of traction sweeps: median and 5-95 % range over the steps per SRR bin
    (the traction map's bins), and five of the steps drawn whole."""
    import matplotlib

    d = red.curves["traction"]
    if "speed_outlier" in d:
        d = d[~d["speed_outlier"]]
    tm = red.traction_map
    fig, ax = subplots(figsize=(7.5, 4.8))
    q = tm.groupby("srr")["traction_coefficient"].quantile([0.05, 0.5, 0.95]).unstack()
    x = q.index.to_numpy() * 100.0
    band(ax, x, q[0.05], q[0.95], color="0.55", label="5–95 % of the steps (per SRR bin)")
    ax.plot(x, q[0.5], "-", lw=2.0, color="0.15", label="median of the steps")
    steps = list(dict.fromkeys(d["step"].tolist()))
    cmap = matplotlib.colormaps["viridis"]
    chosen = _selected_steps(steps)
    for i, st in enumerate(chosen):
        sub = d[d["step"] == st]
        ax.plot(sub["srr"].to_numpy() * 100.0, sub["traction_coefficient"].to_numpy(), "-",
                marker="o", ms=2.5, lw=0.9, color=cmap(i / max(1, len(chosen) - 1)),
                label=_step_time_label(tm, st))
    ax.set_xlabel("slide-to-roll ratio SRR (%)")
    ax.set_ylabel("traction coefficient μ (–)")
    legend(ax)
    fig.suptitle(f"Traction steps ({len(steps)}): {red.label}")
    return fig


def traction_map_figure(red: Any) -> Any:
    """The traction map of a long series of sweeps: the median coefficient of each step
    in each SRR bin (colour) over the step number and SRR; the steps without a curve
    (mapper images ...) are marked as thin lines."""

    tm = red.traction_map
    steps = np.sort(tm["step"].unique())
    bins = np.sort(tm["srr_low"].unique())
    w = float(tm["srr_high"].iloc[0] - tm["srr_low"].iloc[0])
    grid = np.full((bins.size, steps.size), np.nan)
    i = np.searchsorted(bins, tm["srr_low"].to_numpy())
    j = np.searchsorted(steps, tm["step"].to_numpy())
    grid[i, j] = tm["traction_coefficient"].to_numpy()
    # cells between the steps (a step number without a sweep) stay empty, drawn by edges
    xe = np.concatenate((steps - 0.5, [steps[-1] + 0.5]))
    ye = np.concatenate((bins, [bins[-1] + w])) * 100.0
    fig, ax = subplots(figsize=(7.5, 4.8))
    finite = grid[np.isfinite(grid)]
    lo, hi = np.quantile(finite, [0.01, 0.99]) if finite.size else (0.0, 1.0)
    mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(grid), cmap="viridis", vmin=lo, vmax=hi,
                         shading="flat", rasterized=True)
    fig.colorbar(mesh, ax=ax, label="traction coefficient μ (–)", extend="both")
    other = getattr(red, "other_steps", None)
    xl = "step number (–)"
    if other is not None and len(other):
        marks = other[(other["step"] > steps[0]) & (other["step"] < steps[-1])]
        if len(marks):
            # a triangle above the map at each step without a sweep (no data to map)
            ax.plot(marks["step"], np.ones(len(marks)), "v", ms=4, color="0.3", clip_on=False,
                    transform=ax.get_xaxis_transform())
            kinds = ", ".join(dict.fromkeys(marks["step_type"]))
            xl += f";  ▼ above: {kinds} steps (no sweep)"
    ax.set_xlabel(xl)
    ax.set_ylabel("slide-to-roll ratio SRR (%)")
    ax.set_xlim(xe[0], xe[-1])
    fig.suptitle(f"Traction map ({steps.size} steps, median μ per SRR bin): {red.label}")
    return fig


def _levels(tm: Any) -> list[float]:
    """Four SRR bins of the map, at about 10, 25, 50 and 90 % of its largest |SRR| on the
    side with more readings (the centres, fractions)."""
    c = np.sort(tm["srr"].unique())
    pos = c[c > 0]
    neg = c[c < 0]
    side = pos if pos.size >= neg.size else neg
    if side.size == 0:
        return []
    top = float(np.max(np.abs(side)))
    out = []
    for f in (0.1, 0.25, 0.5, 0.9):
        k = int(np.argmin(np.abs(np.abs(side) - f * top)))
        if side[k] not in out:
            out.append(float(side[k]))
    return out


def traction_evolution_figure(red: Any) -> Any:
    """The coefficient of a long series of sweeps against time (or the step number): the
    median of each step at four SRR bins, with the steps without a curve (mapper images
    ...) marked."""
    tm = red.traction_map
    timed = tm["time_h"].notna().all()
    xcol, xl = ("time_h", "time since the first data step t (h)") if timed else \
        ("step", "step number (–)")
    fig, ax = subplots(figsize=(8.0, 4.8))
    col = colours(_levels(tm))
    for lev, c in col.items():
        sub = tm[np.isclose(tm["srr"], lev)].sort_values(xcol)
        ax.plot(sub[xcol], sub["traction_coefficient"], "o", ms=2.2, mew=0, color=c,
                alpha=0.55)
        roll = sub["traction_coefficient"].rolling(9, center=True, min_periods=3).median()
        half = 50.0 * float(tm["srr_high"].iloc[0] - tm["srr_low"].iloc[0])
        ax.plot(sub[xcol], roll, "-", lw=1.4, color=c,
                label=f"SRR {100 * lev - half:.3g}–{100 * lev + half:.3g} %")
    other = getattr(red, "other_steps", None)
    if other is not None and len(other):
        col_x = other[xcol] if timed else other["step"]
        lo, hi = float(tm[xcol].min()), float(tm[xcol].max())
        shown = [(x, k) for x, k in zip(col_x, other["step_type"], strict=True)
                 if np.isfinite(x) and lo < x < hi]
        for n, (x, kind) in enumerate(shown):
            ax.axvline(x, color="0.6", lw=0.6, ls=":", label=f"{kind} step" if n == 0 else None)
    ax.set_xlabel(xl)
    ax.set_ylabel("traction coefficient μ (–)")
    legend(ax, title="median of each step at")
    fig.suptitle(f"Traction against {'time' if timed else 'step'} "
                 f"({tm['step'].nunique()} steps; lines: running median of 9): {red.label}")
    return fig

