"""Figures of predictions: traction curves and Stribeck curves (``torlab predict``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from torlab.reports.plotting import subplots

__all__ = ["REGIME_COLOURS", "shade_regimes", "stribeck_figure", "traction_figure"]

#: Background colours of the lubrication regimes on Stribeck figures.
REGIME_COLOURS = {"boundary": "#f4cccc", "mixed": "#fff2cc", "full_film": "#d9ead3",
                  "smooth": "#d9ead3"}


def traction_figure(curves: Sequence[tuple[str, Any]], *, boundary: Any = None,
                    title: str = "", measured: Sequence[tuple[str, Any, Any]] = ()) -> Any:
    """``mu`` against creepage (%) for one or more predictions.

    Parameters
    ----------
    curves
        ``(label, table)`` pairs; ``table`` has ``creepage`` and ``mu`` and optionally
        ``mu_boundary`` and ``mu_ehl`` (drawn thin and dashed when they differ from ``mu``)
        and the 95 % band ``mu_low95``, ``mu_high95`` (shaded).
    boundary
        The scene's ``boundary:`` (``mu_c1``, ``mu_c2``): drawn as the layer's limits.
    title
        Figure title.
    measured
        Optional ``(label, creepage, mu)`` measured points.
    """
    fig, ax = subplots()
    for label, t in curves:
        x = 100.0 * np.asarray(t["creepage"], dtype=float)
        (line,) = ax.plot(x, t["mu"], lw=1.8, label=label)
        if "mu_low95" in t and "mu_high95" in t:
            ax.fill_between(x, t["mu_low95"], t["mu_high95"], color=line.get_color(), alpha=0.25,
                            lw=0, label=f"{label}: 95 % band (fit uncertainty)")
        if "mu_boundary" in t and "mu_ehl" in t:
            ax.plot(x, t["mu_boundary"], lw=0.9, ls="--", color=line.get_color(),
                    label=f"{label}: boundary part μ_BL")
            ax.plot(x, t["mu_ehl"], lw=0.9, ls=":", color=line.get_color(),
                    label=f"{label}: film part μ_EHL")
    for label, x, y in measured:
        ax.plot(100.0 * np.asarray(x, dtype=float), y, "o", ms=4, mfc="none", label=label)
    if boundary is not None:
        for name, val, ls in (("μ_c1 (elastic limit)", boundary.mu_c1, "-."),
                              ("μ_c2 (plastic limit)", boundary.mu_c2, "--")):
            for sgn in (1, -1):
                xs = np.concatenate([np.asarray(t["creepage"]) for _, t in curves])
                if sgn < 0 and not np.any(xs < 0):
                    continue
                ax.axhline(sgn * val, color="0.35", lw=0.9, ls=ls,
                           label=f"{name} = {val:g}" if sgn > 0 else None)
    ax.set_xlabel("creepage = SRR (%)")
    ax.set_ylabel("traction coefficient μ (-)")
    if title:
        ax.set_title(title)
    ax.legend(loc="best")
    return fig


def _runs(values: Sequence[str]) -> list[tuple[int, int, str]]:
    out: list[tuple[int, int, str]] = []
    start = 0
    for i in range(1, len(values) + 1):
        if i == len(values) or values[i] != values[start]:
            out.append((start, i - 1, values[start]))
            start = i
    return out


def shade_regimes(ax: Any, speed: np.ndarray, regime: Sequence[str], *, label: bool = True) -> None:
    """Shade the lubrication regimes along a speed axis (geometric midpoints as borders)."""
    speed = np.asarray(speed, dtype=float)
    seen: set[str] = set()
    for i0, i1, r in _runs([str(x) for x in regime]):
        lo = speed[i0] if i0 == 0 else np.sqrt(max(speed[i0 - 1], 1e-300) * speed[i0])
        hi = speed[i1] if i1 == len(speed) - 1 else np.sqrt(speed[i1] * speed[i1 + 1])
        ax.axvspan(lo, hi, color=REGIME_COLOURS.get(r, "#eeeeee"), alpha=0.7, lw=0,
                   label=(r.replace("_", " ") + " regime") if label and r not in seen else None)
        seen.add(r)


def stribeck_figure(table: Any, *, title: str = "", creepage: float | None = None,
                    measured: Sequence[tuple[str, Any, Any]] = ()) -> Any:
    """Stribeck figure: ``mu``, film parameter Lambda and asperity load share against speed.

    Regimes (boundary / mixed / full film) are shaded.  Speeds of 0 are left out of
    the logarithmic axis.  The 95 % bands of ``mu`` and the film thickness
    (``mu_low95`` ... from the fit's covariance) are drawn where the table has them.
    """
    t = table[table["speed_m_s"] > 0]
    v = t["speed_m_s"].to_numpy(dtype=float)
    fig, axes = subplots(3, 1, sharex=True, figsize=(7.0, 8.0))
    ax_mu, ax_lam, ax_sh = axes
    for ax in axes:
        shade_regimes(ax, v, list(t["regime"]), label=ax is ax_mu)
        ax.set_xscale("log")
    ax_mu.plot(v, t["mu"], lw=1.8, color="k", label="μ (mixed, Eq. 5.47)")
    if "mu_low95" in t and "mu_high95" in t:
        ax_mu.fill_between(v, t["mu_low95"], t["mu_high95"], color="0.3", alpha=0.3, lw=0,
                           label="95 % band of μ (fit uncertainty)")
    hb = ("film_thickness_low95_m" in t and "film_thickness_high95_m" in t)
    if "mu_ehl" in t and t["mu_ehl"].notna().any():
        ax_mu.plot(v, t["mu_ehl"], lw=0.9, ls=":", color="C0", label="film part μ_EHL")
    if "mu_boundary" in t and t["mu_boundary"].notna().any():
        ax_mu.plot(v, t["mu_boundary"], lw=0.9, ls="--", color="C3", label="boundary part μ_BL")
    for label, x, y in measured:
        ax_mu.plot(x, y, "o", ms=4, mfc="none", label=label)
    ax_mu.set_ylabel("traction coefficient μ (-)")
    ttl = title + (f" (creepage {100 * creepage:g} %)" if creepage is not None else "")
    if ttl:
        ax_mu.set_title(ttl)
    ax_mu.legend(loc="best")
    lam = t["lambda"].to_numpy(dtype=float)
    h = t["film_thickness_m"].to_numpy(dtype=float)
    if np.isfinite(lam).any():
        ax_lam.plot(v, lam, color="C2")
        if hb:
            with np.errstate(divide="ignore", invalid="ignore"):
                per_h = np.where(h > 0, lam / h, np.nan)
            ax_lam.fill_between(v, t["film_thickness_low95_m"] * per_h,
                                t["film_thickness_high95_m"] * per_h, color="C2", alpha=0.25,
                                lw=0)
        ax_lam.set_yscale("log")
        ax_lam.set_ylabel("film parameter Λ = h/σ (-)")
    else:
        ax_lam.plot(v, h * 1e9, color="C2")
        if hb:
            ax_lam.fill_between(v, t["film_thickness_low95_m"] * 1e9,
                                t["film_thickness_high95_m"] * 1e9, color="C2", alpha=0.25, lw=0)
        ax_lam.set_yscale("log")
        ax_lam.set_ylabel("film thickness h (nm)\n(smooth: Λ undefined)")
    ax_sh.plot(v, t["load_share_asperity"], color="C1")
    ax_sh.set_ylim(-0.02, 1.02)
    ax_sh.set_ylabel("asperity load share F_BL/F (-)")
    ax_sh.set_xlabel("rolling speed v (m/s)")
    return fig
