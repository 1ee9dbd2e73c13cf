"""Optical tribometer figures: Tab. 5.2 test types (traction, Stribeck, film thickness)."""

from __future__ import annotations

import textwrap
from typing import Any

import numpy as np

from torlab.reports.plotting import PALETTE, legend, points, subplots

__all__ = ["optical_figure"]

_TEST_TITLES = {"traction": "traction curve", "dry_traction": "dry traction curve",
                "stribeck": "Stribeck curve", "film_thickness": "film thickness"}


def optical_figure(res: Any) -> Any:
    """The figure of one reduced log, by test type.

    * traction / dry traction: coefficient against SRR (%) per rolling speed,
      and the folded curve (|SRR|, negative side hollow) with the symmetry
      verdict;
    * Stribeck: coefficient against rolling speed (log axis);
    * film thickness: film thickness (nm) against rolling speed (log-log), with
      the coefficient where measured.
    """
    p = res.points
    title = _TEST_TITLES.get(res.test, res.test.replace('_', ' ')).capitalize()
    if res.test in ("traction", "dry_traction") and "traction_coefficient" in p:
        from torlab.reduce.optical import speed_groups

        fig, (ax1, ax2) = subplots(1, 2, figsize=(11.0, 4.6))
        g = speed_groups(p["rolling_speed_m_s"].to_numpy())
        for k in np.unique(g):
            sel = g == k
            U = float(p.loc[sel, "rolling_speed_m_s"].mean())
            sub = p.loc[sel].sort_values("srr")
            ax1.plot(sub["srr"] * 100, sub["traction_coefficient"], "o-", ms=3, lw=1,
                     color=PALETTE[k % len(PALETTE)], label=f"{U:.3g} m/s")
        ax1.axhline(0, color="k", lw=0.5)
        ax1.axvline(0, color="k", lw=0.5)
        ax1.set_xlabel("slide-to-roll ratio SRR (%)")
        ax1.set_ylabel("traction coefficient μ (–)")
        legend(ax1, outside=False, loc="upper left", title="rolling speed")
        f = res.folded
        if f is not None:
            fg = speed_groups(f["rolling_speed_m_s"].to_numpy())
            for k in np.unique(fg):
                sub = f.loc[fg == k]
                c = PALETTE[k % len(PALETTE)]
                ax2.plot(sub["srr"] * 100, sub["traction_coefficient_pos"], "o-", ms=4, lw=1,
                         color=c)
                ax2.plot(sub["srr"] * 100, sub["traction_coefficient_neg_folded"], "o", ms=6,
                         mfc="none", color=c)
            sym = res.symmetry
            verdict = _symmetry_words(sym)
            ax2.set_title(textwrap.fill(f"folded: filled +SRR, hollow −SRR → |SRR|, −μ; "
                                        f"{verdict}", 60), fontsize=8)
        ax2.set_xlabel("slide-to-roll ratio |SRR| (%)")
        ax2.set_ylabel("traction coefficient μ (–)")
    elif res.test == "film_thickness":
        fig, (ax1, ax2) = subplots(2, 1, sharex=True, figsize=(7.0, 6.5))
        groups = p.groupby("step", sort=False) if "step" in p else [("", p)]
        for k, (st, g) in enumerate(groups):
            sub = g.sort_values("rolling_speed_m_s")
            label = f"step {st}" if st != "" else None
            tcol = "lube_temperature_C" if "lube_temperature_C" in sub else \
                "temperature_C" if "temperature_C" in sub else None
            if label and tcol:
                label += f", {sub[tcol].mean():.1f} °C"
            ax1.plot(sub["rolling_speed_m_s"], sub["film_thickness_m"] * 1e9, "o-", ms=4,
                     color=PALETTE[k % len(PALETTE)], label=label)
            if "traction_coefficient" in sub:
                ax2.plot(sub["rolling_speed_m_s"], sub["traction_coefficient"], "o-", ms=4,
                         color=PALETTE[k % len(PALETTE)])
        ax1.set_xscale("log")
        ax1.set_yscale("log")
        ax1.set_ylabel("film thickness h (nm)")
        if "step" in p:
            legend(ax1)
        ax2.set_ylabel("traction coefficient μ (–)")
        ax2.set_xlabel("rolling speed U (m/s)")
    else:
        fig, ax1 = subplots(figsize=(7.0, 4.6))
        sub = p.sort_values("rolling_speed_m_s")
        if "traction_coefficient" in sub:
            sd = sub.get("traction_coefficient_sd")
            points(ax1, sub["rolling_speed_m_s"].to_numpy(dtype=float),
                   sub["traction_coefficient"].to_numpy(dtype=float),
                   None if sd is None else sd.to_numpy(dtype=float), color=PALETTE[0])
            ax1.plot(sub["rolling_speed_m_s"], sub["traction_coefficient"], "-", lw=1.0,
                     color=PALETTE[0])
        ax1.set_xscale("log")
        ax1.set_xlabel("rolling speed U (m/s)")
        ax1.set_ylabel("traction coefficient μ (–)")
        srr = float(np.median(p["srr"]))
        title += f" at SRR {srr * 100:.3g} %"
    fig.suptitle(f"{title}: {res.label}")
    return fig


def _symmetry_words(sym: dict) -> str:
    """The fold's symmetry in words: the offset with its interval and the verdict."""
    v = sym.get("symmetry_verdict", "")
    head = (f"{sym.get('pairs', 0)} pairs, max |Δμ| = {sym.get('max_abs_diff', float('nan')):.3g}")
    lo, hi = sym.get("offset_low95", float("nan")), sym.get("offset_high95", float("nan"))
    if lo == lo and hi == hi:
        p = sym.get("p_symmetric", float("nan"))
        return (f"offset {sym.get('offset'):+.3g} [{lo:+.3g}, {hi:+.3g}] within "
                f"±{sym.get('offset_tolerance'):.3g}: {v} (P = {p:.2f}; {head})")
    return f"{v or 'symmetry not tested'} (too few pairs for an interval; {head})"

