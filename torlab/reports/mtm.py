"""MTM/ETM figures: time tests (thesis Fig. 5.9), traction and Stribeck curves per step."""

from __future__ import annotations

from typing import Any

import numpy as np

from torlab.reports.plotting import PALETTE, decimate, legend, pixel_columns, subplots

__all__ = ["axis_label", "curve_figure", "time_test_figure"]

#: axis label and scale of the usual columns
_AXES = {
    "srr": ("slide-to-roll ratio SRR (%)", 100.0),
    "rolling_speed_m_s": ("rolling speed (m/s)", 1.0),
    "sliding_speed_m_s": ("sliding speed (m/s)", 1.0),
    "step_time_s": ("step time (s)", 1.0),
    "traction_coefficient": ("traction coefficient μ (–)", 1.0),
    "film_thickness_m": ("film thickness h (nm)", 1e9),
    "traction_force_N": ("traction force (N)", 1.0),
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
    more than ten are drawn thin in viridis with a colour bar.
    """
    import matplotlib

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
    outlier = d["interference_order_outlier"].to_numpy(dtype=bool) \
        if "interference_order_outlier" in d else np.zeros(len(d), dtype=bool)
    if outlier.any():
        ax.plot(d.loc[outlier, xcol].to_numpy() * xs, d.loc[outlier, ycol].to_numpy() * ys, "x",
                ms=5, color="0.35", label="fringe-order misassignment (left out)")
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


def time_test_figure(red: Any, results: list[Any]) -> Any:
    """Coefficient against time of the timed steps with the time-test figures marked.

    Marks (per step): the application moment (dashed), the minimum (dot), the
    recovery (triangle) and the mean after recovery (bar to the end), and the
    low-adhesion threshold (dotted line); the time below it is shaded.
    """
    d = red.curves["timed"]
    fig, ax = subplots(figsize=(8.0, 4.8))
    step_arr = d["step"].to_numpy()
    by_step = {r.step: r for r in results}
    for i, st in enumerate(dict.fromkeys(step_arr.tolist())):
        sel = step_arr == st
        t = d.loc[sel, "step_time_s"].to_numpy()
        mu = d.loc[sel, "traction_coefficient"].to_numpy()
        color = PALETTE[i % len(PALETTE)]
        r = by_step.get(st)
        if r is None:
            continue
        ax.plot(*decimate(t, mu, pixel_columns(ax)), lw=0.8, color=color, label=f"step {st}")
        ax.axvline(r.application_time_s, color=color, ls="--", lw=0.8)
        ax.plot([r.minimum_time_s], [r.minimum], "o", color=color, ms=5)
        if r.recovered:
            ax.plot([r.recovery_at_s], [r.recovery_level], "^", color=color, ms=6)
            ax.plot([r.recovery_at_s, r.evaluated_until_s], [r.mean_after_recovery] * 2,
                    color=color, lw=2.5, solid_capstyle="butt")
        below = np.where(mu < r.threshold, mu, np.nan)
        ax.fill_between(t, below, r.threshold, where=np.isfinite(below) & (t >= r.application_time_s),
                        color=color, alpha=0.12, lw=0)
    if results:
        ax.axhline(results[0].threshold, color="k", ls=":", lw=0.8)
    ax.set_xlabel("step time (s)")
    ax.set_ylabel("traction coefficient μ (–)")
    ax.text(0.01, 0.98, "dashed: application · dot: minimum · triangle: recovery · bar: mean "
            "after recovery · dotted: low-adhesion threshold (shaded: below)",
            transform=ax.transAxes, fontsize=7, va="top", alpha=0.7)
    legend(ax)
    fig.suptitle(f"Time test after application (thesis Fig. 5.9): {red.label}")
    return fig
