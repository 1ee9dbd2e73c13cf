"""MTM/ETM figures: time tests (thesis Fig. 5.9), traction and Stribeck curves per step."""

from __future__ import annotations

from typing import Any

import numpy as np

from torlab.reports.plotting import subplots

__all__ = ["curve_figure", "time_test_figure"]

_LABELS = {
    "traction": ("SRR (%)", 100.0, "srr"),
    "stribeck": ("rolling speed (m/s)", 1.0, "rolling_speed_m_s"),
    "timed": ("step time (s)", 1.0, "step_time_s"),
    "film": ("rolling speed (m/s)", 1.0, "rolling_speed_m_s"),
}


def curve_figure(red: Any, kind: str) -> Any:
    """One curve type of a reduced PCS file, every step on one figure.

    Traction: coefficient against SRR (%); Stribeck: against rolling speed
    (log axis); timed: against step time; film (EHD2): film thickness (nm) and
    coefficient against rolling speed (log axes).  Steps are coloured in file
    order (viridis); many steps are drawn thin.
    """
    import matplotlib

    d = red.curves[kind]
    xl, xs, xcol = _LABELS[kind]
    steps = list(dict.fromkeys(d["step"].tolist()))
    n = len(steps)
    cmap = matplotlib.colormaps["viridis"]
    film = kind == "film"
    if film:
        fig, (ax, ax2) = subplots(2, 1, sharex=True, figsize=(7.5, 6.5))
    else:
        fig, ax = subplots(figsize=(7.5, 4.8))
        ax2 = None
    lw = 1.2 if n <= 20 else 0.4
    step_arr = d["step"].to_numpy()
    for i, st in enumerate(steps):
        sel = step_arr == st
        x = d.loc[sel, xcol].to_numpy() * xs
        color = cmap(i / max(1, n - 1)) if n > 1 else "C0"
        label = f"step {st}" if n <= 12 else None
        if film:
            ax.plot(x, d.loc[sel, "film_thickness_m"].to_numpy() * 1e9, "o-", ms=3, lw=lw,
                    color=color, label=label)
            if "traction_coefficient" in d:
                ax2.plot(x, d.loc[sel, "traction_coefficient"].to_numpy(), "o-", ms=3, lw=lw,
                         color=color)
        else:
            ax.plot(x, d.loc[sel, "traction_coefficient"].to_numpy(), "-", lw=lw, color=color,
                    label=label, marker="o" if sel.sum() < 60 else None, ms=2)
    ax.set_xlabel(xl) if not film else ax2.set_xlabel(xl)
    if film:
        ax.set_ylabel("film thickness h (nm)")
        ax2.set_ylabel("traction coefficient (–)")
        ax.set_xscale("log")
        ax.set_yscale("log")
    else:
        ax.set_ylabel("traction coefficient μ (–)")
        if kind == "stribeck":
            ax.set_xscale("log")
    if n <= 12:
        ax.legend(loc="best")
    else:
        sm = matplotlib.cm.ScalarMappable(cmap=cmap, norm=matplotlib.colors.Normalize(
            vmin=min(steps), vmax=max(steps)))
        fig.colorbar(sm, ax=ax, label="step number")
    fig.suptitle(f"{red.label}: {kind} steps ({n})")
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
        color = f"C{i % 10}"
        ax.plot(t, mu, lw=0.8, color=color, label=f"step {st}")
        r = by_step.get(st)
        if r is None:
            continue
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
    ax.legend(loc="lower right")
    fig.suptitle(f"{red.label}: time test after application (thesis Fig. 5.9)")
    return fig
