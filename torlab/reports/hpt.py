"""HPT figures: shear stress and friction against displacement (thesis Fig. 5.10)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from torlab.reports.plotting import PALETTE, decimate, legend, pixel_columns, subplots

__all__ = ["hpt_figure"]


def hpt_figure(results: Sequence[Any], title: str = "") -> Any:
    """Shear stress and friction against displacement, every run on one figure.

    Parameters
    ----------
    results
        :class:`torlab.reduce.hpt.HptResult` objects.
    title
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels: ``tau`` (MPa) and ``f`` (-) against displacement (um); the
        window of the reported friction is shaded on the friction panel for
        each run, and the reported value marked.
    """
    import matplotlib

    many = len(results) > 8
    fig, (ax1, ax2) = subplots(2, 1, sharex=True, figsize=(7.5, 6.5))
    cmap = matplotlib.colormaps["viridis"]
    n = len(results)
    labels = [str(r.meta.label) for r in results]
    for i, r in enumerate(results):
        d = r.data
        u = d["displacement_m"].to_numpy()
        color = cmap(i / (n - 1)) if n > 1 else PALETTE[0]
        label = labels[i]
        if labels.count(label) > 1:  # repeated runs: each named by its file
            label = f"{label}: {getattr(r.meta, 'source', '') or f'run {i + 1}'}"
        cols = pixel_columns(ax1)  # a long log: the points its pixel columns can show
        x, y = decimate(u, d["shear_stress_Pa"].to_numpy(), cols)  # in SI, scaled once thin
        ax1.plot(x * 1e6, y / 1e6, lw=1.0, color=color, label=label)
        x, y = decimate(u, d["friction"].to_numpy(), cols)
        ax2.plot(x * 1e6, y, lw=1.0, color=color)
        umax = r.u_max_m * 1e6
        ax2.axvspan(umax - r.window_m * 1e6, umax, color=color, alpha=min(0.08, 0.5 / n), lw=0)
        ax2.plot([umax - r.window_m * 1e6, umax], [r.f_window, r.f_window], color=color,
                 lw=2.5, solid_capstyle="butt")
    ax1.set_ylabel("shear stress τ (MPa)")
    ax2.set_ylabel("friction coefficient f (–)")
    xl = "displacement u at r_e" + (", rig compliance subtracted" if results and
                                     results[0].compliance else "") + " (µm)"
    ax2.set_xlabel(xl)
    ax1.set_ylim(bottom=0)
    ax2.set_ylim(bottom=0)
    if results:
        legend(ax1, fontsize=6 if many else None, ncol=1 + len(results) // 25)
    if results:
        ax2.plot([], [], "-", lw=2.5, color="0.35", solid_capstyle="butt",
                 label="mean f over the window before the maximum displacement (shaded)")
        legend(ax2)
    if title:
        fig.suptitle(title)
    return fig
