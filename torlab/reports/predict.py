"""Figures of predictions: traction curves and Stribeck curves (``torlab predict``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from torlab.reports.plotting import subplots

__all__ = ["REGIME_COLOURS", "shade_regimes", "stribeck_figure", "stribeck_overlay_figure",
           "traction_figure"]

#: Background colours of the lubrication regimes on Stribeck figures.
REGIME_COLOURS = {"boundary": "#f4cccc", "mixed": "#fff2cc", "full_film": "#d9ead3",
                  "smooth": "#d9ead3"}


def _columns(table: Any) -> dict[str, np.ndarray]:
    """A table's columns as arrays (a DataFrame or a mapping of columns)."""
    if hasattr(table, "columns") and hasattr(table, "to_numpy"):
        return {str(c): table[c].to_numpy() for c in table.columns}
    return {str(k): np.asarray(v) for k, v in table.items()}


def traction_figure(curves: Sequence[tuple[str, Any]], *, boundary: Any = None,
                    title: str = "", measured: Sequence[tuple[Any, ...]] = ()) -> Any:
    """``mu`` against creepage (%) for one or more predictions.

    Parameters
    ----------
    curves
        ``(label, table)`` pairs; ``table`` (a DataFrame or a mapping of columns) has
        ``creepage`` and ``mu`` and optionally ``mu_boundary`` and ``mu_ehl`` (drawn thin
        and dashed) and the 95 % band ``mu_low95``, ``mu_high95`` (shaded).
    boundary
        The scene's ``boundary:``: its layer law's limits (Voce: ``mu_c1``, ``mu_c2``) are
        drawn as levels.
    title
        Figure title.
    measured
        Optional ``(label, creepage, mu[, mu_sd])`` measured points (error bars: the spread).
    """
    from torlab.reports.plotting import axis_label, band, colours, legend, points

    fig, ax = subplots()
    col = colours([lab for lab, _ in curves] + [m[0] for m in measured])
    xs_all = []
    for label, table in curves:
        t = _columns(table)
        c = col[label]
        x = 100.0 * np.asarray(t["creepage"], dtype=float)
        xs_all.append(x)
        ax.plot(x, t["mu"], lw=1.7, color=c, label=label)
        if "mu_low95" in t and "mu_high95" in t:
            band(ax, x, t["mu_low95"], t["mu_high95"], color=c,
                 label=f"{label}: 95 % band (fit uncertainty)")
        if "mu_boundary" in t and "mu_ehl" in t:
            ax.plot(x, t["mu_boundary"], lw=0.9, ls="--", color=c,
                    label=f"{label}: boundary part μ_BL")
            ax.plot(x, t["mu_ehl"], lw=0.9, ls=":", color=c, label=f"{label}: film part μ_EHL")
    for m in measured:
        label, x, y = m[:3]
        sd = m[3] if len(m) > 3 else None
        points(ax, 100.0 * np.asarray(x, dtype=float), y, sd, color=col[label], label=label)
    if boundary is not None:
        xs = np.concatenate(xs_all) if xs_all else np.zeros(1)
        lay = boundary.layer
        for (key, name), ls in zip(lay.law.limits(), ("-.", "--", ":"), strict=False):
            val = getattr(lay, key)
            for sgn in (1, -1):
                if sgn < 0 and not np.any(xs < 0):
                    continue
                ax.axhline(sgn * val, color="0.35", lw=0.9, ls=ls,
                           label=f"{name} = {val:g}" if sgn > 0 else None)
    ax.set_xlabel(axis_label("creepage ξ = SRR", "", "%"))
    ax.set_ylabel(axis_label("traction coefficient", "μ"))
    if title:
        ax.set_title(title)
    legend(ax)
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
                    measured: Sequence[tuple[Any, ...]] = ()) -> Any:
    """Stribeck figure: ``mu``, film parameter Lambda and asperity load share against speed.

    Regimes (boundary / mixed / full film) are shaded.  Speeds of 0 are left out of
    the logarithmic axis.  The 95 % bands of ``mu`` and the film thickness
    (``mu_low95`` ... from the fit's covariance) are drawn where the table has them;
    measured points ``(label, speed, mu[, mu_sd])`` with error bars from their spread.
    """
    from torlab.reports.plotting import PALETTE, axis_label, band, legend, points

    t0 = _columns(table)
    keep = np.asarray(t0["speed_m_s"], dtype=float) > 0
    t = {k: v[keep] for k, v in t0.items()}
    v = t["speed_m_s"].astype(float)
    fig, axes = subplots(3, 1, sharex=True, figsize=(7.0, 7.6), height_ratios=[2.2, 1, 1])
    ax_mu, ax_lam, ax_sh = axes
    for ax in axes:
        shade_regimes(ax, v, [str(r) for r in t["regime"]], label=ax is ax_mu)
        ax.set_xscale("log")
    ax_mu.plot(v, t["mu"], lw=1.8, color="k", label="μ (mixed, Eq. 5.47)")
    if "mu_low95" in t and "mu_high95" in t:
        band(ax_mu, v, t["mu_low95"], t["mu_high95"], color="0.3", alpha=0.3,
             label="95 % band of μ (fit uncertainty)")
    hb = "film_thickness_low95_m" in t and "film_thickness_high95_m" in t
    if "mu_ehl" in t and np.isfinite(np.asarray(t["mu_ehl"], dtype=float)).any():
        ax_mu.plot(v, t["mu_ehl"], lw=0.9, ls=":", color=PALETTE[0], label="film part μ_EHL")
    if "mu_boundary" in t and np.isfinite(np.asarray(t["mu_boundary"], dtype=float)).any():
        ax_mu.plot(v, t["mu_boundary"], lw=0.9, ls="--", color=PALETTE[1],
                   label="boundary part μ_BL")
    for k, m in enumerate(measured):
        label, x, y = m[:3]
        sd = m[3] if len(m) > 3 else None
        points(ax_mu, x, y, sd, color=PALETTE[(k + 2) % len(PALETTE)], label=label)
    ax_mu.set_ylabel(axis_label("traction coefficient", "μ"))
    ttl = title + (f" (creepage {100 * creepage:g} %)" if creepage is not None else "")
    if ttl:
        ax_mu.set_title(ttl)
    legend(ax_mu)
    lam = np.asarray(t["lambda"], dtype=float) if "lambda" in t else np.full(v.shape, np.nan)
    h = np.asarray(t["film_thickness_m"], dtype=float)
    green = PALETTE[2]
    if np.isfinite(lam).any():
        ax_lam.plot(v, lam, color=green)
        if hb:
            with np.errstate(divide="ignore", invalid="ignore"):
                per_h = np.where(h > 0, lam / h, np.nan)
            band(ax_lam, v, np.asarray(t["film_thickness_low95_m"], dtype=float) * per_h,
                 np.asarray(t["film_thickness_high95_m"], dtype=float) * per_h, color=green)
        ax_lam.set_yscale("log")
        ax_lam.set_ylabel("film parameter\n" + axis_label("Λ = h/σ", ""))
    else:
        ax_lam.plot(v, h * 1e9, color=green)
        if hb:
            band(ax_lam, v, np.asarray(t["film_thickness_low95_m"], dtype=float) * 1e9,
                 np.asarray(t["film_thickness_high95_m"], dtype=float) * 1e9, color=green)
        ax_lam.set_yscale("log")
        ax_lam.set_ylabel("film thickness\nh (nm), Λ undefined")
    ax_sh.plot(v, t["load_share_asperity"], color=PALETTE[4])
    ax_sh.set_ylim(-0.02, 1.02)
    ax_sh.set_ylabel("asperity load\n" + axis_label("share F_BL/F", ""))
    ax_sh.set_xlabel(axis_label("rolling speed", "v", "m/s"))
    return fig


def stribeck_overlay_figure(curves: Sequence[tuple[str, Any]], *, title: str = "",
                            creepage: float | None = None) -> Any:
    """Several Stribeck curves: ``mu`` (top) and the central film thickness (bottom)
    against speed, one colour per labelled curve, each with its 95 % bands where the
    table has them.

    Parameters
    ----------
    curves
        ``(label, table)`` pairs of :func:`torlab.model.predict.predict_stribeck` tables.
    title, creepage
        Figure title (the creepage appended).
    """
    from torlab.reports.plotting import axis_label, band, colours, legend

    fig, (ax_mu, ax_h) = subplots(2, 1, sharex=True, figsize=(7.0, 6.4), height_ratios=[2, 1.3])
    col = colours([lab for lab, _ in curves])
    for label, table in curves:
        t = _columns(table)
        keep = np.asarray(t["speed_m_s"], dtype=float) > 0
        v = np.asarray(t["speed_m_s"], dtype=float)[keep]
        c = col[label]
        ax_mu.plot(v, np.asarray(t["mu"], dtype=float)[keep], lw=1.7, color=c, label=label)
        if "mu_low95" in t and "mu_high95" in t:
            band(ax_mu, v, np.asarray(t["mu_low95"], dtype=float)[keep],
                 np.asarray(t["mu_high95"], dtype=float)[keep], color=c,
                 label=f"{label}: 95 % band (fit uncertainty)")
        h = np.asarray(t["film_thickness_m"], dtype=float)[keep] * 1e9
        ax_h.plot(v, h, lw=1.5, color=c)
        if "film_thickness_low95_m" in t and "film_thickness_high95_m" in t:
            band(ax_h, v, np.asarray(t["film_thickness_low95_m"], dtype=float)[keep] * 1e9,
                 np.asarray(t["film_thickness_high95_m"], dtype=float)[keep] * 1e9, color=c)
    for ax in (ax_mu, ax_h):
        ax.set_xscale("log")
    ax_h.set_yscale("log")
    ax_mu.set_ylabel(axis_label("traction coefficient", "μ"))
    ax_h.set_ylabel(axis_label("central film", "h_c", "nm"))
    ax_h.set_xlabel(axis_label("rolling speed", "v", "m/s"))
    ttl = title + (f" (creepage {100 * creepage:g} %)" if creepage is not None else "")
    if ttl:
        ax_mu.set_title(ttl)
    legend(ax_mu)
    return fig
