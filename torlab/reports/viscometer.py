"""Viscometer figures: falls with their steady parts, ln eta against pressure with the fits."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from torlab.reports.plotting import PALETTE, decimate, legend, pixel_columns, subplots

__all__ = ["falls_figure", "fit_figure"]


def falls_figure(res: Any) -> Any:
    """Position against time of every fall, the steady part used for the velocity in bold."""
    d = res.trace
    t = d["time_s"].to_numpy()
    x = d["position_m"].to_numpy() * 1e3
    fig, (ax1, ax2) = subplots(2, 1, sharex=True, figsize=(9.0, 6.0),
                               gridspec_kw={"height_ratios": [3, 1]})
    cols = pixel_columns(ax1)  # a long trace: the points its pixel columns can show
    ax1.plot(*decimate(t, x, cols), lw=0.6, color="0.6", label="LVDT trace")
    for k, f in enumerate(res.fall_list):
        ax1.plot(*decimate(t[f.s0:f.s1], x[f.s0:f.s1], cols), lw=1.6, color=PALETTE[0],
                 label="steady parts (terminal velocity fits)" if k == 0 else None)
    ax1.set_ylabel("position x, downward (mm)")
    legend(ax1)
    ax2.plot(*decimate(t, d["pressure_Pa"].to_numpy() / 1e6, cols), lw=0.8, color=PALETTE[1])
    ax2.set_ylabel("pressure p (MPa)")
    ax2.set_xlabel("time t (s)")
    fig.suptitle(f"Falling-body runs: {res.label}")
    return fig


def fit_figure(res: Any, fits: Sequence[Any]) -> Any:
    """ln eta against pressure (each fall), the fitted laws, and their residuals."""
    p = res.falls["pressure_Pa"].to_numpy()
    eta = res.falls["viscosity_Pa_s"].to_numpy()
    fig, (ax1, ax2) = subplots(2, 1, sharex=True, figsize=(7.0, 6.5),
                               gridspec_kw={"height_ratios": [3, 1.2]})
    ax1.semilogy(p / 1e6, eta * 1e3, "o", ms=4, color="k", label="falls")
    pp = np.linspace(0.0, max(float(p.max()), 1.0), 200)
    for i, f in enumerate(fits):
        lab = (f"Barus α = {f.alpha * 1e9:.3g} ± {f.alpha_se * 1e9:.2g} 1/GPa" if f.law == "barus"
               else f"Roelands Z = {f.Z:.3g} ± {f.Z_se:.2g} (α* = {f.alpha * 1e9:.3g} 1/GPa)")
        ax1.semilogy(pp / 1e6, f.predict(pp) * 1e3, lw=1.2, color=PALETTE[i % len(PALETTE)], label=lab)
        ax2.plot(f.pressures_Pa / 1e6, f.residuals * 100, "o", ms=3, color=PALETTE[i % len(PALETTE)])
    ax2.axhline(0, color="k", lw=0.5)
    ax1.set_ylabel("viscosity η (mPa·s)")
    ax2.set_ylabel("residual Δln η (%)")
    ax2.set_xlabel("pressure p (MPa)")
    legend(ax1)
    fig.suptitle(f"Pressure–viscosity law (Eqs. 5.38–5.39): {res.label}")
    return fig
