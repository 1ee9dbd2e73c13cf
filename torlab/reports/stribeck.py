"""Stribeck and film-thickness reports: μ against speed and Λ, regimes, asperity load share.

Modelled curves come from :func:`torlab.model.predict.predict_stribeck` (film
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
from torlab.reports.traction import shares_text

__all__ = ["FILM_RATIO_MIN_NM", "StribeckCurve", "film_figure", "film_ratio", "film_section",
           "lambda_figure", "measured_stribeck_figure", "stribeck_section"]


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
    # regime transition speeds with their intervals (torlab.model.regimes.transition_evidence)
    transitions: dict[str, Any] = field(default_factory=dict)


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


_TRANSITION_WORDS = {"boundary_to_mixed": "boundary → mixed",
                     "mixed_to_full_film": "mixed → full film"}


def _transition_columns(tr: dict[str, Any]) -> dict[str, Any]:
    """The summary table's transition columns: the exact crossing (not the grid midpoint)
    with its 95 % interval and verdict, where the prediction computed them."""
    out: dict[str, Any] = {}
    for key in _TRANSITION_WORDS:
        e = tr.get(key) if isinstance(tr, dict) else None
        if not isinstance(e, dict):
            continue
        nan = float("nan")
        out[f"{key}_m_s"] = nan if e.get("speed_m_s") is None else e["speed_m_s"]
        out[f"{key}_low95_m_s"] = nan if e.get("low95_m_s") is None else e["low95_m_s"]
        out[f"{key}_high95_m_s"] = nan if e.get("high95_m_s") is None else e["high95_m_s"]
        out[f"{key}_status"] = e.get("status", "")
        out[f"{key}_verdict"] = e.get("verdict", "")
    return out


def transition_words(tr: dict[str, Any]) -> str:
    """The regime transitions with their intervals, verdicts and what they rest on."""
    if not tr:
        return ""
    if "error" in tr:
        return f"not computed ({tr['error']})"
    parts = []
    for key, name in _TRANSITION_WORDS.items():
        e = tr.get(key)
        if not e:
            continue
        v = e.get("speed_m_s")
        if v is None:
            parts.append(f"{name}: none at a positive speed ({'; '.join(e.get('notes', []))})")
            continue
        st = e.get("status", "")
        if st == "resolved":
            dom = shares_text(e.get("dominant", []), e.get("explained"))
            iv = (f" (95 % interval {e['low95_m_s']:.3g}–{e['high95_m_s']:.3g} m/s, "
                  f"{e.get('method')} propagation"
                  + (f", shares of its variance: {dom}" if dom else "") + ")")
        elif st == "exact":
            iv = (" (exact given the scene: the lubricant's parameters carry no fit "
                  "covariance)")
        else:
            why = "; ".join(n for n in e.get("notes", []) if n.startswith("not resolved"))
            iv = f" (the data cannot resolve it: {why or 'no interval'})"
        p = e.get("p_within")
        verdict = e.get("verdict", "")
        if p is not None and st == "exact":
            verdict = verdict if p in (0.0, 1.0) else "undetermined"
        elif p is not None:
            verdict = (f"{verdict} (P = {p:.2f})" if verdict != "undetermined" else
                       f"within the modelled speeds undetermined (P = {p:.2f})")
        parts.append(f"{name} at {v:.3g} m/s{iv}" + (f", {verdict}" if verdict else ""))
    return "; ".join(parts)


def _nan_none(v: Any) -> Any:
    return None if isinstance(v, float) and not math.isfinite(v) else v


def stribeck_section(curves: list[StribeckCurve]) -> Section:
    """The Stribeck report (figures per curve, μ-Λ figure, summary table)."""
    import pandas as pd

    from torlab.reports.predict import stribeck_figure
    from torlab.reports.render import plot

    figs: list[Figure] = []
    rows, long = [], []
    lam_lines: list[tuple[str, Any, Any, str]] = []  # (label, Λ, |μ|, "model"/"measured")
    for c in curves:
        meas = []
        mv = mm = sd = None
        if c.measured is not None and len(c.measured):
            mv = c.measured["rolling_speed_m_s"].to_numpy(dtype=float)
            mm = np.abs(c.measured["traction_coefficient"].to_numpy(dtype=float))
            if "traction_coefficient_sd" in c.measured:
                sd = c.measured["traction_coefficient_sd"].to_numpy(dtype=float)
            meas = [(c.measured_label or "measured", mv, mm, sd)]
        row: dict[str, Any] = {"curve": c.label, "source": c.source,
                               "creepage": c.creepage if c.creepage is not None else float("nan")}
        if c.table is not None:
            t = c.table
            figs.append(Figure(f"stribeck_{_safe(c.label)}",
                               plot(stribeck_figure, t, title=f"Stribeck curve: {c.label}",
                                    creepage=c.creepage, measured=meas),
                               f"{c.label}: μ, film parameter Λ and asperity load share against "
                               "rolling speed, regimes shaded"))
            ok = t["lambda"].notna() & (t["speed_m_s"] > 0)
            if ok.any():
                lam_lines.append((f"{c.label} (model)", t.loc[ok, "lambda"].to_numpy(dtype=float),
                                  t.loc[ok, "mu"].abs().to_numpy(dtype=float), c.label))
            mu = t["mu"].abs().to_numpy(dtype=float)
            row.update({
                "mu_min": float(mu.min()), "mu_max": float(mu.max()),
                "speed_min_m_s": float(t["speed_m_s"].min()),
                "speed_max_m_s": float(t["speed_m_s"].max()),
                "lambda_min": float(t["lambda"].min()) if t["lambda"].notna().any() else float("nan"),
                "lambda_max": float(t["lambda"].max()) if t["lambda"].notna().any() else float("nan"),
                "boundary_to_mixed_m_s": _transition(t, "boundary", "mixed"),
                "mixed_to_full_film_m_s": _transition(t, "mixed", "full_film"),
                **_transition_columns(c.transitions),
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
                lam_lines.append((f"{c.measured_label or c.label} (measured, Λ of the model)",
                                  lam, mm, c.label))
            d = pd.DataFrame({"curve": c.label, "kind": "measured", "speed_m_s": mv, "mu": mm,
                              "lambda": lam})
            long.append(d)
            if c.table is None:
                figs.append(Figure(f"stribeck_{_safe(c.label)}",
                                   plot(measured_stribeck_figure, c.label, mv, mm, sd),
                                   f"{c.label}: measured μ against rolling speed"))
        rows.append(row)
    if lam_lines:
        figs.append(Figure("stribeck_lambda", plot(lambda_figure, lam_lines),
                           "Traction coefficient against the film parameter Λ: model (lines) "
                           "and measured points"))
    table = pd.DataFrame(rows)
    curves_df = pd.concat(long, ignore_index=True) if long else pd.DataFrame()
    show = {"curve": ("curve", ""), "creepage": ("creepage", ".3g"), "μ min": ("mu_min", ".4f"),
            "μ max": ("mu_max", ".4f"), "boundary→mixed (m/s)": ("boundary_to_mixed_m_s", ".3g"),
            "mixed→full film (m/s)": ("mixed_to_full_film_m_s", ".3g"),
            "→full film 95 % low": ("mixed_to_full_film_low95_m_s", ".3g"),
            "→full film 95 % high": ("mixed_to_full_film_high95_m_s", ".3g"),
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
    summary["transitions"] = {c.label: c.transitions for c in curves if c.transitions}
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
            "explained", "notes")
    return {k: band[k] for k in keep if k in band} if band else None


def _band_words(band: dict[str, Any], output: str = "mu") -> str:
    """The band's method and the parameters dominating it, in words."""
    m = band.get("method", "") if band else ""
    if m in ("linear", "sampling"):
        dom = (band.get("dominant") or {}).get(output) or []
        d = shares_text(dom, (band.get("explained") or {}).get(output))
        return (f"95 % band by {m} propagation of {', '.join(band.get('parameters', []))}"
                + (f", shares of its variance: {d}" if d else ""))
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
    tw = transition_words(c.transitions)
    if tw:
        out += f". Regime transitions: {tw}"
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

    from torlab.reports.render import plot

    fig = plot(film_figure, measured, models, fits)
    rows = []
    for label, fr in fits:
        row = {"curve": label, "n_points": fr.n_points, "residual_rms": fr.residual_norm,
               "residual_unit": fr.residual_unit}
        for n in fr.names:
            row[n] = fr.params[n]
            row[f"{n}_ci95_low"], row[f"{n}_ci95_high"] = fr.ci95[n]
        rows.append(row)
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
    from torlab._stats import t_ppf  # scipy.stats.t.ppf, without its import

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
    tq = float(t_ppf(0.975, n - 1))
    return {"ratio": math.exp(m), "ratio_low95": math.exp(m - tq * se),
            "ratio_high95": math.exp(m + tq * se), "n_points": n,
            "min_speed_m_s": float(v[ok].min())}


def _safe(s: str) -> str:
    """A figure-name part made from a label (:func:`torlab.files.plain_name`: at most 80
    characters; the protocol checks before the run that labels make different names)."""
    from torlab.files import plain_name

    return plain_name(s)


# ------------------------------------------------------------------------------ figures
def lambda_figure(lines: list[tuple[str, Any, Any, str]]) -> Any:
    """|μ| against the film parameter Λ: model lines and measured points, a colour per curve
    (:class:`~torlab.reports.render.Plot` function)."""
    from torlab.reports.plotting import axis_label, colours, legend, points

    fig, ax = subplots(figsize=(7.0, 4.6))
    col = colours(group for _, _, _, group in lines)
    for label, lam, mu, group in lines:
        if label.endswith("(model)"):
            ax.plot(lam, mu, color=col[group], lw=1.6, label=label)
        else:
            points(ax, lam, mu, color=col[group], label=label)
    ax.set_xscale("log")
    ax.set_xlabel(axis_label("film parameter", "Λ = h/σ"))
    ax.set_ylabel(axis_label("traction coefficient", "|μ|"))
    ax.set_title("Traction coefficient against the film parameter")
    legend(ax)
    return fig


def measured_stribeck_figure(label: str, speed: Any, mu: Any, sd: Any = None) -> Any:
    """Measured |μ| against rolling speed, error bars from the per-point spread."""
    from torlab.reports.plotting import PALETTE, axis_label, legend, points

    fig, ax = subplots(figsize=(7.0, 4.4))
    points(ax, speed, mu, sd, color=PALETTE[0], label=f"{label} (measured)")
    ax.plot(speed, mu, color=PALETTE[0], lw=0.7, alpha=0.6)
    ax.set_xscale("log")
    ax.set_xlabel(axis_label("rolling speed", "v", "m/s"))
    ax.set_ylabel(axis_label("traction coefficient", "|μ|"))
    ax.set_title(f"Measured Stribeck curve: {label}")
    legend(ax)
    return fig


def film_figure(measured: list[tuple[str, Any]], models: list[tuple[str, Any]],
                fits: list[tuple[str, Any]]) -> Any:
    """Film thickness against rolling speed (log-log): measured points with their spread,
    the model's hc with its 95 % band where the parameters carry one, the fitted power law."""
    from torlab.reports.plotting import axis_label, band, colours, legend, points

    fig, ax = subplots(figsize=(7.0, 4.6))
    col = colours([lab for lab, _ in measured] + [lab for lab, _ in models]
                  + [lab for lab, _ in fits])
    for label, d in measured:
        sd = d["film_thickness_sd_m"].to_numpy(dtype=float) * 1e9 \
            if "film_thickness_sd_m" in d else None
        points(ax, d["rolling_speed_m_s"].to_numpy(dtype=float),
               d["film_thickness_m"].to_numpy(dtype=float) * 1e9, sd, color=col[label],
               label=f"{label} (measured)")
    for label, t in models:
        v = t["speed_m_s"].to_numpy(dtype=float)
        ax.plot(v, t["film_thickness_m"].to_numpy(dtype=float) * 1e9, lw=1.6,
                color=col[label], label=f"{label} (model hc)")
        if "film_thickness_low95_m" in t and "film_thickness_high95_m" in t:
            band(ax, v, t["film_thickness_low95_m"].to_numpy(dtype=float) * 1e9,
                 t["film_thickness_high95_m"].to_numpy(dtype=float) * 1e9, color=col[label],
                 label=f"{label}: 95 % band (fit uncertainty)")
    for label, fr in fits:
        d = fr.data
        xcol = fr.x_column or d.columns[0]
        mcol = next((c for c in d.columns if c.endswith("_model") or "model" in c), None)
        if mcol is not None:
            o = np.argsort(d[xcol].to_numpy(dtype=float))
            ax.plot(d[xcol].to_numpy(dtype=float)[o], d[mcol].to_numpy(dtype=float)[o] * 1e9,
                    ls="--", lw=1.0, color=col[label], label=f"{label}: fitted power law")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(axis_label("rolling speed", "U", "m/s"))
    ax.set_ylabel(axis_label("central film thickness", "h", "nm"))
    ax.set_title("Film thickness against rolling speed")
    legend(ax)
    return fig
