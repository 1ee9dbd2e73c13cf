"""Stribeck and film-thickness reports: μ against speed and Λ, regimes, asperity load share.

Modelled curves come from :func:`torlab.model.mixed.predict_stribeck` (film
thickness Eq. 5.31/5.32, Greenwood-Williamson asperities, load sharing, mixed
friction Eq. 5.47); measured points are the optical tribometer's Stribeck
points (or MTM Stribeck steps).  A measured point is placed on the Λ axis at the
film parameter the model gives at its rolling speed (interpolated in log speed),
so the measured and modelled curves compare against Λ as well as speed.

The film report plots the measured central film thickness against rolling
speed with the model's ``hc`` and the fitted power law ``h = C U^n``
(:func:`torlab.fit.film.fit_film_thickness`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.reports.html import Figure, Section, Table
from torlab.reports.plotting import subplots

__all__ = ["FILM_RATIO_MIN_NM", "StribeckCurve", "film_ratio", "film_section", "stribeck_section"]


@dataclass
class StribeckCurve:
    """One curve of the Stribeck report: a model table and/or measured points."""

    label: str
    table: Any = None             # predict_stribeck table (speed_m_s, mu, lambda, ...)
    creepage: float | None = None
    measured: Any = None          # DataFrame rolling_speed_m_s, traction_coefficient
    measured_label: str = ""
    source: str = ""
    modelled: list[str] = field(default_factory=list)
    band: dict[str, Any] = field(default_factory=dict)  # the prediction's band summary


def _lambda_at(table: Any, speed: np.ndarray) -> np.ndarray:
    """Model Λ at ``speed`` (linear in log speed and log Λ); NaN without Λ."""
    t = table[(table["speed_m_s"] > 0) & table["lambda"].notna()]
    if len(t) < 2:
        return np.full(np.shape(speed), np.nan)
    lv = np.log(t["speed_m_s"].to_numpy(dtype=float))
    ll = np.log(t["lambda"].to_numpy(dtype=float))
    s = np.log(np.asarray(speed, dtype=float))
    out = np.exp(np.interp(s, lv, ll))
    out[(s < lv.min()) | (s > lv.max())] = np.nan
    return out


def _transition(table: Any, a: str, b: str) -> float:
    """Speed (geometric midpoint) where the regime changes from ``a`` to ``b``."""
    r = table["regime"].astype(str).to_numpy()
    v = table["speed_m_s"].to_numpy(dtype=float)
    for i in range(len(r) - 1):
        if r[i] == a and r[i + 1] == b and v[i] > 0:
            return float(math.sqrt(v[i] * v[i + 1]))
    return float("nan")


def _nan_none(v: Any) -> Any:
    return None if isinstance(v, float) and not math.isfinite(v) else v


def stribeck_section(curves: list[StribeckCurve]) -> Section:
    """The Stribeck report (figures per curve, μ-Λ figure, summary table)."""
    import pandas as pd

    from torlab.reports.predict import stribeck_figure

    figs: list[Figure] = []
    rows, long = [], []
    fig_l, ax_l = subplots(figsize=(7.5, 4.8))
    for i, c in enumerate(curves):
        color = f"C{i % 10}"
        meas = []
        mv = mm = None
        if c.measured is not None and len(c.measured):
            mv = c.measured["rolling_speed_m_s"].to_numpy(dtype=float)
            mm = np.abs(c.measured["traction_coefficient"].to_numpy(dtype=float))
            meas = [(c.measured_label or "measured", mv, mm)]
        row: dict[str, Any] = {"curve": c.label, "source": c.source,
                               "creepage": c.creepage if c.creepage is not None else float("nan")}
        if c.table is not None:
            t = c.table
            figs.append(Figure(f"stribeck_{_safe(c.label)}",
                               stribeck_figure(t, title=f"Stribeck: {c.label}", creepage=c.creepage,
                                               measured=meas),
                               f"{c.label}: μ, film parameter Λ and asperity load share against "
                               "rolling speed, regimes shaded"))
            ok = t["lambda"].notna() & (t["speed_m_s"] > 0)
            if ok.any():
                ax_l.plot(t.loc[ok, "lambda"], t.loc[ok, "mu"].abs(), color=color, lw=1.6,
                          label=f"{c.label} (model)")
            mu = t["mu"].abs().to_numpy(dtype=float)
            row.update({
                "mu_min": float(mu.min()), "mu_max": float(mu.max()),
                "speed_min_m_s": float(t["speed_m_s"].min()),
                "speed_max_m_s": float(t["speed_m_s"].max()),
                "lambda_min": float(t["lambda"].min()) if t["lambda"].notna().any() else float("nan"),
                "lambda_max": float(t["lambda"].max()) if t["lambda"].notna().any() else float("nan"),
                "boundary_to_mixed_m_s": _transition(t, "boundary", "mixed"),
                "mixed_to_full_film_m_s": _transition(t, "mixed", "full_film"),
                "regimes": ", ".join(f"{k}: {n}" for k, n in
                                     t["regime"].astype(str).value_counts(sort=False).items()),
            })
            d = t.copy()
            d.insert(0, "curve", c.label)
            d.insert(1, "kind", "model")
            long.append(d)
        if mv is not None:
            row["n_measured"] = len(mv)
            row["measured_mu_min"] = float(mm.min())
            row["measured_mu_max"] = float(mm.max())
            lam = _lambda_at(c.table, mv) if c.table is not None else np.full(mv.shape, np.nan)
            if c.table is not None:
                lsp = np.log(c.table["speed_m_s"].clip(lower=1e-300))
                model_at = np.interp(np.log(mv), lsp, c.table["mu"].abs())
                row["rms_measured_minus_model"] = float(np.sqrt(np.mean((mm - model_at) ** 2)))
                if "mu_low95" in c.table:
                    lo = np.interp(np.log(mv), lsp, c.table[["mu_low95", "mu_high95"]].abs()
                                   .min(axis=1))
                    hi = np.interp(np.log(mv), lsp, c.table[["mu_low95", "mu_high95"]].abs()
                                   .max(axis=1))
                    row["measured_in_band"] = int(np.sum((mm >= lo) & (mm <= hi)))
            if np.isfinite(lam).any():
                ax_l.plot(lam, mm, "o", ms=4, mfc="none", color=color,
                          label=f"{c.measured_label or c.label} (measured, Λ of the model)")
            d = pd.DataFrame({"curve": c.label, "kind": "measured", "speed_m_s": mv, "mu": mm,
                              "lambda": lam})
            long.append(d)
            if c.table is None:
                f2, a2 = subplots()
                a2.plot(mv, mm, "o-", ms=4)
                a2.set_xscale("log")
                a2.set_xlabel("rolling speed v (m/s)")
                a2.set_ylabel("traction coefficient μ (-)")
                figs.append(Figure(f"stribeck_{_safe(c.label)}", f2,
                                   f"{c.label}: measured μ against rolling speed"))
        rows.append(row)
    ax_l.set_xscale("log")
    ax_l.set_xlabel("film parameter Λ = h/σ (-)")
    ax_l.set_ylabel("traction coefficient μ (-)")
    ax_l.set_title("μ against Λ")
    ax_l.legend(loc="best", fontsize=7)
    if ax_l.lines:
        figs.append(Figure("stribeck_lambda", fig_l, "Traction coefficient against the film "
                           "parameter Λ: model and measured points"))
    else:
        import matplotlib.pyplot as plt

        plt.close(fig_l)
    table = pd.DataFrame(rows)
    curves_df = pd.concat(long, ignore_index=True) if long else pd.DataFrame()
    show = {"curve": ("curve", ""), "creepage": ("creepage", ".3g"), "μ min": ("mu_min", ".4f"),
            "μ max": ("mu_max", ".4f"), "boundary→mixed (m/s)": ("boundary_to_mixed_m_s", ".3g"),
            "mixed→full film (m/s)": ("mixed_to_full_film_m_s", ".3g"),
            "RMS meas.−model": ("rms_measured_minus_model", ".2g"), "regimes": ("regimes", "")}
    show = {k: v for k, v in show.items() if v[0] in table.columns}
    summary = {"curves": {r["curve"]: {k: _nan_none(v) for k, v in r.items() if k != "curve"}
                          for r in rows}}
    notes = sorted({m for c in curves for m in c.modelled if "not modelled" in m})
    paragraphs = [
        "Stribeck curves: traction coefficient against rolling speed at one creepage "
        "(mixed lubrication, Eq. 5.47: film part μ_EHL and asperity part μ_BL weighted by "
        "the load they carry), film parameter Λ = h/σ and asperity load share F_BL/F; "
        "regimes boundary / mixed / full film shaded. Measured points are placed on the Λ "
        "axis at the model's Λ for their speed."]
    for r, c in zip(rows, curves, strict=True):
        paragraphs.append(_stribeck_sentence(r, c))
    summary["bands"] = {c.label: _band_entry(c.band) for c in curves if c.table is not None}
    optional = tuple(c for c in table.columns if c not in ("curve", "source", "regimes"))
    tables = [Table("stribeck_summary", table, "Per curve: range, regime transitions, "
                    "measured against model", show, allow_missing=optional)]
    if len(curves_df):
        tables.append(Table("curves", curves_df, "Every curve point (long format)",
                            allow_missing=tuple(c for c in curves_df.columns
                                                if c not in ("curve", "kind", "regime")),
                            inline=False))
    return Section(key="stribeck", title="Stribeck curves", paragraphs=paragraphs, figures=figs,
                   tables=tables, summary=summary, notes=notes)


def _band_entry(band: dict[str, Any]) -> dict[str, Any] | None:
    keep = ("method", "confidence", "nonlinearity", "n_evaluations", "parameters", "dominant",
            "notes")
    return {k: band[k] for k in keep if k in band} if band else None


def _band_words(band: dict[str, Any], output: str = "mu") -> str:
    """The band's method and the parameters dominating it, in words."""
    m = band.get("method", "") if band else ""
    if m in ("linear", "sampling"):
        dom = (band.get("dominant") or {}).get(output) or []
        d = ", ".join(f"{x['parameter']} {100 * x['share']:.0f} %" for x in dom)
        return (f"95 % band by {m} propagation of {', '.join(band.get('parameters', []))}"
                + (f", dominated by {d}" if d else ""))
    if m == "none":
        return "no band (the fitted parameters have zero variance)"
    why = "; ".join(n for n in (band or {}).get("notes", []) if n.startswith("no band"))
    return why or "no band (no fit covariance: the parameters are taken as exact)"


def _stribeck_sentence(r: dict[str, Any], c: StribeckCurve) -> str:
    if c.table is None:
        return f"{c.label}: measured only."
    out = f"{c.label}: modelled μ {r['mu_min']:.4f}–{r['mu_max']:.4f}"
    if "mu_low95" in c.table:
        lo = c.table[["mu_low95", "mu_high95"]].abs().min(axis=1)
        hi = c.table[["mu_low95", "mu_high95"]].abs().max(axis=1)
        out += f" (band {float(lo.min()):.4f}–{float(hi.max()):.4f})"
    out += f"; {_band_words(c.band)}"
    if r.get("rms_measured_minus_model") is not None and "n_measured" in r:
        out += (f". Measured: {r['n_measured']} points, RMS measured − model "
                f"{r['rms_measured_minus_model']:.2g}")
        if "measured_in_band" in r:
            out += (f", {r['measured_in_band']} of them inside the model's band (the band holds "
                    "the parameters' uncertainty only, not the measurement's scatter)")
    return out + "."


def film_section(measured: list[tuple[str, Any]], models: list[tuple[str, Any]],
                 fits: list[tuple[str, Any]]) -> Section:
    """The film-thickness report.

    Parameters
    ----------
    measured
        ``(label, DataFrame)`` with ``rolling_speed_m_s`` and ``film_thickness_m``.
    models
        ``(label, predict_stribeck table)`` (its ``film_thickness_m``).
    fits
        ``(label, FitResult)`` of :func:`torlab.fit.film.fit_film_thickness`.
    """
    import pandas as pd

    fig, ax = subplots(figsize=(7.0, 4.8))
    for i, (label, d) in enumerate(measured):
        ax.plot(d["rolling_speed_m_s"], d["film_thickness_m"] * 1e9, "o", ms=4, mfc="none",
                color=f"C{i}", label=f"{label} (measured)")
    for label, t in models:
        ax.plot(t["speed_m_s"], t["film_thickness_m"] * 1e9, lw=1.6, label=f"{label} (model hc)")
    rows = []
    for i, (label, fr) in enumerate(fits):
        d = fr.data
        xcol = fr.x_column or d.columns[0]
        mcol = next((c for c in d.columns if c.endswith("_model") or "model" in c), None)
        if mcol is not None:
            ax.plot(d[xcol], d[mcol] * 1e9, ls="--", lw=1.0, color=f"C{i}",
                    label=f"{label}: fitted power law")
        row = {"curve": label, "n_points": fr.n_points, "residual_rms": fr.residual_norm,
               "residual_unit": fr.residual_unit}
        for n in fr.names:
            row[n] = fr.params[n]
            row[f"{n}_ci95_low"], row[f"{n}_ci95_high"] = fr.ci95[n]
        rows.append(row)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("rolling speed U (m/s)")
    ax.set_ylabel("central film thickness h (nm)")
    ax.legend(loc="best", fontsize=7)
    ax.set_title("Film thickness against rolling speed")
    table = pd.DataFrame(rows)
    summary = {"fits": {r["curve"]: {k: _nan_none(v) if isinstance(v, float) else v
                                     for k, v in r.items() if k != "curve"} for r in rows}}
    paragraphs = [
        "Central film thickness against rolling speed: measured (optical interferometry), "
        "modelled hc (Eq. 5.31 iso-viscous or 5.32 Hamrock–Dowson) and the fitted power law."]
    ratios = {}
    for (label, d), (mlabel, t) in zip(measured, models, strict=False):
        rr = film_ratio(d, t)
        if rr is None:
            continue
        ratios[label] = rr
        paragraphs.append(
            f"{label}: measured / modelled film ({mlabel}) {rr['ratio']:.3g}, 95 % interval "
            f"[{rr['ratio_low95']:.3g}, {rr['ratio_high95']:.3g}] (geometric mean over "
            f"{rr['n_points']} speeds from {rr['min_speed_m_s']:.3g} m/s, where the film is at "
            f"least {FILM_RATIO_MIN_NM:g} nm; Student t on the log ratios).")
    if ratios:
        summary["measured_to_model"] = ratios
    for label, fr in fits:
        for w in fr.warnings:
            paragraphs.append(f"{label}: {w}.")
    tables = []
    if len(table):
        tables.append(Table("film_fits", table, "Fitted film-thickness power law h = C U^n",
                            allow_missing=tuple(c for c in table.columns if c != "curve")))
    return Section(key="film", title="Film thickness", paragraphs=paragraphs,
                   figures=[Figure("film", fig, "Film thickness against rolling speed (log–log)")],
                   tables=tables, summary=summary)


#: films thinner than this (nm) are left out of the measured/model ratio: an
#: interferometer's nanometre of scatter would dominate them
FILM_RATIO_MIN_NM = 2.0


def film_ratio(measured: Any, model: Any) -> dict[str, Any] | None:
    """Measured over modelled film thickness: geometric mean and its 95 % interval.

    The model's ``film_thickness_m`` is interpolated (log-log) to the measured
    speeds; points below :data:`FILM_RATIO_MIN_NM` or outside the modelled
    speed range are left out.  The interval is Student t on the log ratios
    (``n - 1`` degrees of freedom).  None with fewer than three points.
    """
    from scipy.stats import t as student

    v = measured["rolling_speed_m_s"].to_numpy(dtype=float)
    h = measured["film_thickness_m"].to_numpy(dtype=float)
    mv = model["speed_m_s"].to_numpy(dtype=float)
    mh = model["film_thickness_m"].to_numpy(dtype=float)
    ok_m = (mv > 0) & (mh > 0)
    if ok_m.sum() < 2:
        return None
    lv, lh = np.log(mv[ok_m]), np.log(mh[ok_m])
    ok = (v > 0) & (h > FILM_RATIO_MIN_NM * 1e-9) & (v >= mv[ok_m].min()) & (v <= mv[ok_m].max())
    if ok.sum() < 3:
        return None
    lr = np.log(h[ok]) - np.interp(np.log(v[ok]), lv, lh)
    n = int(lr.size)
    m, se = float(lr.mean()), float(lr.std(ddof=1) / math.sqrt(n))
    tq = float(student.ppf(0.975, n - 1))
    return {"ratio": math.exp(m), "ratio_low95": math.exp(m - tq * se),
            "ratio_high95": math.exp(m + tq * se), "n_points": n,
            "min_speed_m_s": float(v[ok].min())}


def _safe(s: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in s)
