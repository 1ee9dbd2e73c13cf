"""Figures and the report section of product retention (removal fit, prediction, slip sweep).

* :func:`removal_figure`: measured against modelled coefficient after the
  application, and the modelled remaining amount (``torlab fit removal``);
* :func:`layer_figure`: the layer limits of the HPT amount series against the
  amount, with the monotone interpolation and the dry anchor;
* :func:`retention_figure`: the coefficient against axle passes (disc
  revolutions, or time) with its 95 % interval, the band and the crossings,
  and the remaining amount (``torlab predict retention``);
* :func:`sweep_figure`: the traction curve recorded during a slip sweep while
  product is removed, beside the steady curve (``predict traction --sweep``);
* :func:`retention_section`: the ``retention`` report of a protocol.

Every axis is labelled with its quantity and unit.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from torlab.reports.plotting import PALETTE, band, cap, legend, subplots
from torlab.reports.render import plot

__all__ = ["crossing_text", "layer_figure", "removal_figure", "retention_figure", "retention_section",
           "sweep_figure", "write_retention", "write_sweep"]

#: x axes of the retention figure: column, label, factor
_AXES = {"passes": ("passes", "axle passes N (–)", 1.0),
         "cycles": ("passes", "disc revolutions N (cycles)", 1.0),
         "time": ("time_s", "time after application t (h)", 1.0 / 3600.0)}


def removal_figure(result: Any, title: str | None = None) -> Any:
    """Measured against modelled coefficient after application (top), remaining amount (bottom).

    Per time test: the measured coefficient (points), the model over the fit
    window (line) and before it (dotted: the film phase, not fitted).
    """
    from torlab.reports.plotting import fit_units, param_text

    d = result.data
    fig, (ax, axm) = subplots(2, 1, sharex=True, figsize=(7.5, 6.0),
                              gridspec_kw={"height_ratios": [3, 1.4]})
    for i, (name, g) in enumerate(d.groupby("test", sort=False)):
        col = PALETTE[i % len(PALETTE)]
        t = g["time_s"].to_numpy()
        win = g["in_fit"].to_numpy(dtype=bool)
        ax.plot(t, g["mu_measured"], ".", ms=2, color=col, alpha=0.35, label=f"{name}")
        ax.plot(t[win], g["mu_model"].to_numpy()[win], "-", lw=1.6, color=col)
        ax.plot(t[~win], g["mu_model"].to_numpy()[~win], ":", lw=1.0, color=col)
        axm.plot(t, g["amount_mg_m2"], "-", lw=1.2, color=col)
    ax.plot([], [], "-", lw=1.6, color="0.2", label="model over the fit window (each test's "
            "colour)")
    ax.plot([], [], ":", lw=1.0, color="0.2", label="model in the film phase (not fitted)")
    ax.set_ylabel("traction coefficient μ (–)")
    ax.set_ylim(bottom=0)
    legend(ax)
    axm.set_xlabel("time after application t (s)")
    axm.set_ylabel("remaining amount m (mg/m²)")
    if (d["amount_mg_m2"] > 0).any():
        axm.set_yscale("log")
    law = str(result.meta.get("law", "")).replace("_", "-")
    units = fit_units(result)
    pars = ", ".join(param_text(n, result.params[n], 3, si=units.get(n)) for n in result.names)
    ax.set_title(title or f"Removal fit: {law} law ({pars})", fontsize=9)
    return fig


def layer_figure(layer: Any, title: str = "") -> Any:
    """The layer limits (Voce: μc1, μc2) of the amount series against the areal density.

    Points with 95 % error bars (±1.96 standard errors of each fit, with the
    run-to-run scatter where given) at the tested amounts and the dry anchor;
    the monotone interpolation in ln m (PCHIP) between them.
    """
    from torlab.model.amount import MG_M2

    nodes = layer.nodes
    allp = np.vstack([layer.dry_params, layer.params])
    limits = layer.law.limits()
    idx = [layer.names.index(k) for k, _ in limits]
    se = np.sqrt(np.clip(np.concatenate([layer.dry_cov[None], layer.covs])[:, idx, idx],
                         0.0, None))
    m = np.geomspace(nodes[0], nodes[-1], 200)
    p = layer.params_at(m)
    fig, ax = subplots()
    for i, ((_, label), mk) in enumerate(zip(limits, ("s", "o", "^"), strict=False)):
        name = label.replace("μ_c", "μc")
        col = PALETTE[i]
        j = idx[i]
        ax.plot(m / MG_M2, p[:, j], "-", color=col, lw=1.2)
        ax.errorbar(nodes[1:] / MG_M2, allp[1:, j], yerr=1.96 * se[1:, i], fmt=mk, ms=4,
                    color=col, capsize=cap(4), label=f"{name}, HPT fit ±95 %")
        ax.errorbar(nodes[:1] / MG_M2, allp[:1, j], yerr=1.96 * se[:1, i], fmt=mk, ms=5,
                    mfc="none", color=col, capsize=cap(5),
                    label="dry fit at the assumed anchor" if i == len(limits) - 1 else None)
    ax.axvspan(nodes[0] / MG_M2, layer.m_min / MG_M2, color="0.9", lw=0,
               label="below the smallest tested amount")
    ax.set_xscale("log")
    ax.set_xlabel("areal density of product m (mg/m²)")
    ax.set_ylabel("layer limit μc (–)")
    ax.set_ylim(bottom=0)
    legend(ax)
    ax.set_title(title or "Layer of the remaining amount (HPT amount series, PCHIP in ln m)",
                 fontsize=9)
    return fig


def _xaxis(table: Any, axis: str) -> tuple[np.ndarray, str]:
    col, label, f = _AXES[axis]
    if col not in table:
        col, label, f = _AXES["passes"]
    x = table[col].to_numpy(dtype=float) * f
    if axis == "time" and col == "time_s" and x.size and x[-1] < 1.0:
        x, label = x * 60.0, "time after application t (min)"
    return x, label


def retention_figure(pred: Any, *, axis: str = "passes", title: str = "") -> Any:
    """Coefficient against passes after one application (top) and the remaining amount (bottom).

    The 95 % interval of the coefficient is shaded, the band (0.15-0.25 by
    default) is marked, and the passes at which the coefficient enters and
    leaves the band are drawn with their 95 % intervals.  ``axis``: ``passes``
    (axle passes), ``cycles`` (disc revolutions) or ``time`` (hours, or minutes
    for short predictions).
    """
    t = pred.table
    s = pred.summary
    x, xlabel = _xaxis(t, axis)
    scale = float(x[-1] / t["passes"].iloc[-1]) if t["passes"].iloc[-1] > 0 else 1.0
    fig, (ax, axm) = subplots(2, 1, sharex=True, figsize=(7.5, 6.2),
                              gridspec_kw={"height_ratios": [3, 1.4]})
    lo, hi = s["band"]
    ax.axhspan(lo, hi, color="#d9ead3", alpha=0.6, lw=0, label=f"band {lo:g}–{hi:g}")
    if t["mu_low95"].notna().all():
        band(ax, x, t["mu_low95"], t["mu_high95"], color=PALETTE[0], alpha=0.25,
             label=f"{100 * s.get('confidence', 0.95):g} % interval")
    ax.plot(x, t["mu"], color=PALETTE[0], lw=1.8, label="μ (estimate)")
    ax.axhline(s["mu_dry"], color="0.4", ls=":", lw=0.9, label=f"dry μ = {s['mu_dry']:.3f}")
    for key, col, word in (("passes_to_enter_band", PALETTE[2], "enters"),
                           ("passes_to_leave_band", PALETTE[1], "leaves")):
        cr = s[key]
        if cr["passes"] is None or cr["passes"] == 0.0:
            continue
        xc = cr["passes"] * scale
        xerr = None
        if cr.get("low95") is not None:
            hi95 = cr["high95"] if cr.get("high95") is not None else cr["passes"]
            xerr = [[xc - cr["low95"] * scale], [max(hi95 * scale - xc, 0.0)]]
        ax.errorbar([xc], [cr["level"]], xerr=xerr, fmt="o", color=col, ms=5, capsize=cap(5),
                    label=f"{word} the band: {cr['passes']:.3g} passes")
    ax.set_ylabel("traction coefficient μ (–)")
    ax.set_ylim(bottom=0)
    legend(ax)
    axm.plot(x, t["amount_mg_m2"], color=PALETTE[4], lw=1.4)
    for v, lab in ((min(s["tested_amounts_mg_m2"]), "smallest tested amount"),
                   (s["dry_anchor_mg_m2"], "dry anchor")):
        axm.axhline(v, color="0.5", lw=0.8, ls="--" if lab.startswith("smallest") else ":",
                    label=lab)
    if (t["amount_mg_m2"] > 0).all():
        axm.set_yscale("log")
    axm.set_ylabel("remaining amount m (mg/m²)")
    axm.set_xlabel(xlabel)
    legend(axm)
    ax.set_title(title or f"Retention: {s.get('scene', '')}, creepage "
                 f"{100 * s['creepage']:.3g} %, {s['law']}", fontsize=9)
    return fig


def sweep_figure(sweep: Any, title: str = "") -> Any:
    """The traction curve recorded during a sweep (product removed meanwhile) beside the
    steady curve at the applied amount (top), and the remaining amount (bottom)."""
    t = sweep.table
    s = sweep.summary
    x = 100.0 * t["creepage"].to_numpy(dtype=float)
    fig, (ax, axm) = subplots(2, 1, sharex=True, figsize=(7.5, 6.2),
                              gridspec_kw={"height_ratios": [3, 1.4]})
    for col, name, c in (("mu_steady", "steady (applied amount, no removal)", PALETTE[0]),
                         ("mu_sweep", f"recorded during a {s['seconds']:g} s sweep", PALETTE[1])):
        if f"{col}_low95" in t:
            band(ax, x, t[f"{col}_low95"], t[f"{col}_high95"], color=c)
        ax.plot(x, t[col], color=c, lw=1.8, label=f"{name}: {_trend(s, col)}")
    ax.set_ylabel("traction coefficient μ (–)")
    ax.set_ylim(bottom=0)
    legend(ax)
    axm.plot(x, t["amount_mg_m2"], color=PALETTE[4], lw=1.4)
    axm.set_ylabel("remaining amount m (mg/m²)")
    axm.set_xlabel("creepage ξ = SRR, rising linearly with time (%)")
    p = s.get("probability_sweep_positive")
    ax.set_title(title or (f"Slip sweep with removal ({s['law']}); shaded: 95 % of the "
                           "parameter draws" + ("" if p is None else
                                                f"; P(recorded curve positive) = {p:.2f}")),
                 fontsize=9)
    return fig


def _trend(s: dict[str, Any], col: str) -> str:
    tr = s["trend_sweep" if col == "mu_sweep" else "trend_steady"]
    return str(tr.get("trend", ""))


def retention_overlay_figure(curves: list[tuple[str, Any]], *, band: Any, axis: str = "passes",
                             title: str = "") -> Any:
    """Several products' coefficient against passes after one application: one colour per
    labelled curve with its 95 % interval shaded, the band marked.

    Parameters
    ----------
    curves
        ``(label, table)`` pairs of retention tables (``passes``, ``mu``, ``mu_low95``,
        ``mu_high95`` [, ``time_s``]).
    band
        ``(low, high)``.
    axis, title
        As :func:`retention_figure`.
    """
    from torlab.reports.plotting import band as shade
    from torlab.reports.plotting import colours

    fig, ax = subplots(figsize=(7.5, 4.8))
    col = colours([lab for lab, _ in curves])
    lo, hi = band
    ax.axhspan(lo, hi, color="#d9ead3", alpha=0.6, lw=0, label=f"band {lo:g}–{hi:g}")
    xlabel = ""
    for label, t in curves:
        x, xlabel = _xaxis(t, axis)
        c = col[label]
        if t["mu_low95"].notna().all():
            shade(ax, x, t["mu_low95"], t["mu_high95"], color=c,
                  label=f"{label}: 95 % interval")
        ax.plot(x, t["mu"], color=c, lw=1.8, label=label)
    ax.set_ylabel("traction coefficient μ (–)")
    ax.set_xlabel(xlabel)
    ax.set_ylim(bottom=0)
    if title:
        ax.set_title(title)
    legend(ax)
    return fig


def write_retention_overlay(dest: Any, preds: list[tuple[str, Any]], *, axis: str = "passes",
                            title: str = "", formats: Any = None) -> list[str]:
    """Several products' predictions: one long ``retention.csv`` (``curve`` first), one
    ``summary.json`` (``curves``) and one figure."""
    import pandas as pd

    from torlab.reports.render import parse_formats, write_figures

    long = pd.concat([p.table.assign(curve=lab) for lab, p in preds], ignore_index=True)
    long = long[["curve", *[c for c in long.columns if c != "curve"]]]
    dest.write_csv("retention.csv", long, allow_missing=("mu_low95", "mu_high95"))
    dest.write_json("summary.json", {"curves": {lab: p.summary for lab, p in preds}})
    band = preds[0][1].summary["band"]
    names, _ = write_figures(dest, [("retention", plot(
        retention_overlay_figure, [(lab, p.table) for lab, p in preds], band=band, axis=axis,
        title=title))], parse_formats(formats))
    return ["retention.csv", *names, "summary.json"]


# --------------------------------------------------------------------------- command outputs
def write_retention(dest: Any, pred: Any, *, axis: str = "passes", title: str = "",
                    formats: Any = None) -> list[str]:
    """``retention.csv``, ``summary.json``, ``retention.png`` (and the other ``formats``) of a
    prediction."""
    from torlab.reports.render import parse_formats, write_figures

    dest.write_csv("retention.csv", pred.table, allow_missing=("mu_low95", "mu_high95"))
    dest.write_json("summary.json", pred.summary)
    names, _ = write_figures(dest, [("retention", plot(retention_figure, pred, axis=axis,
                                                       title=title))], parse_formats(formats))
    return ["retention.csv", *names, "summary.json"]


def write_sweep(dest: Any, sweep: Any, *, title: str = "", formats: Any = None) -> list[str]:
    """``traction.csv`` (the steady curve as ``mu``, the recorded one as ``mu_sweep``),
    ``sweep.csv`` (every column), ``summary.json`` and ``traction.png`` (and the other
    ``formats``)."""
    from torlab.reports.render import parse_formats, write_figures

    t = sweep.table
    keep = [c for c in t.columns if c != "time_s"]
    tab = t[["creepage", "mu_steady", *[c for c in keep if c not in ("creepage", "mu_steady")]]]
    dest.write_csv("traction.csv", tab.rename(columns={"mu_steady": "mu"}))
    dest.write_csv("sweep.csv", t)
    dest.write_json("summary.json", sweep.summary)
    names, _ = write_figures(dest, [("traction", plot(sweep_figure, sweep, title=title))],
                             parse_formats(formats))
    return ["traction.csv", "sweep.csv", *names, "summary.json"]


# --------------------------------------------------------------------------- protocol section
def _crossing_rows(summary: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for key, what in (("passes_to_enter_band", "enter the band (μ rises above its lower limit)"),
                      ("passes_to_leave_band", "leave the band (μ back above its upper limit)")):
        cr = summary[key]
        rows.append({"crossing": what, "level": cr["level"],
                     "passes": _nan(cr["passes"]), "low95": _nan(cr.get("low95")),
                     "high95": _nan(cr.get("high95")), "amount_mg_m2": _nan(cr["amount_mg_m2"]),
                     "status": cr["status"]})
    return rows


def _nan(v: Any) -> float:
    return float("nan") if v is None else float(v)


def metrics_text(m: dict[str, Any]) -> str:
    """The retention figures labs report, in words: effective friction level, retentivity and
    fraction of passes in the band, each with its 95 % interval."""
    def iv(e: dict[str, Any], fmt: str) -> str:
        if e.get("value") is None:
            return "never"
        lo, hi = e.get("low95"), e.get("high95")
        rng = "" if lo is None else (f" (95 %: {format(lo, fmt)}–"
                                     f"{'open' if hi is None else format(hi, fmt)})")
        return format(e["value"], fmt) + rng

    a, b = m["window_passes"]
    r = m["retentivity"]
    reached = f", reached in {100 * r['p_reached']:.0f} % of the draws" \
        if r.get("p_reached") is not None and r["p_reached"] < 1 else ""
    return (f"effective friction level over passes {a:.4g}–{b:.4g}: "
            f"{iv(m['effective_friction'], '.4f')}; retentivity ({r['definition']}): "
            f"{iv(r, '.4g')} passes{reached}; fraction of those passes in the band "
            f"{m['band'][0]:g}–{m['band'][1]:g}: {iv(m['fraction_in_band'], '.3f')}")


def crossing_text(cr: dict[str, Any]) -> str:
    """``"244 passes (95 %: 207-289)"`` of a crossing of the retention summary."""
    if cr["passes"] is None:
        return "never"
    if cr.get("above_band_at_application"):
        return "never (above the band from the application on)"
    if cr["passes"] == 0.0 and not cr.get("high95"):
        return "from the application on"
    lo, hi = cr.get("low95"), cr.get("high95")
    iv = "" if lo is None else f" (95 %: {lo:.3g}–{'open' if hi is None else f'{hi:.3g}'})"
    return f"{cr['passes']:.3g} passes{iv}"


def retention_section(product: str, fit: Any, layer: Any, pred: Any, sweep: Any = None,
                      *, axis: str = "passes") -> Any:
    """The ``retention`` report of a protocol.

    Parameters
    ----------
    product
        The product's name.
    fit
        The removal fit (:func:`torlab.fit.removal.fit_removal`).
    layer
        Its :class:`~torlab.model.amount.AmountLayer`.
    pred
        The :class:`~torlab.model.retention.RetentionPrediction`.
    sweep
        Optional :class:`~torlab.model.retention.SweepPrediction`.
    axis
        x axis of the prediction figure (``passes``, ``cycles``, ``time``).
    """
    import pandas as pd

    from torlab.model.removal import LAW_UNITS
    from torlab.reports.html import Figure, Section, Table

    s = pred.summary
    law = fit.meta["law"]
    sel = pd.DataFrame(fit.meta["law_selection"])
    pars = "; ".join(f"{n} = {fit.params[n]:.3g} {LAW_UNITS.get(n, '')} (95 %: "
                     f"{fit.ci95[n][0]:.3g}–{fit.ci95[n][1]:.3g})" for n in fit.names)
    weight = float(sel.loc[sel["law"] == law, "weight"].iloc[0])
    paras = [
        f"Product {product}: the layer of the remaining amount from the HPT amount series "
        f"({len(layer.amounts)} amounts, {', '.join(f'{v:.3g}' for v in s['tested_amounts_mg_m2'])}"
        " mg/m², and the dry fit as the limit), the removal law from the MTM time tests after "
        "application, and the coefficient against passes on the prediction scene "
        "(docs/model/retention.md).",
        f"Removal law chosen by the small-sample Akaike criterion: {law} (Akaike weight "
        f"{weight:.2f}); {pars}.",
        f"Prediction on '{s['scene']}' at creepage {100 * s['creepage']:.3g} %: applied "
        f"{s['applied']}, i.e. {s['initial_amount_mg_m2']:.4g} mg/m² in the band "
        f"({s['initial_amount_from']}); μ from {s['mu_initial']:.3f} to the dry {s['mu_dry']:.3f}. "
        f"Band {s['band'][0]:g}–{s['band'][1]:g}: " + (
            "never entered: μ is above it from the application on."
            if s["passes_to_enter_band"].get("above_band_at_application") else
            f"entered after {crossing_text(s['passes_to_enter_band'])}, left after "
            f"{crossing_text(s['passes_to_leave_band'])}."),
        "As labs report it (the twin-disc practice of EN 15427-2-1, Annex H, and CEN/TS "
        "15427-2-2): " + metrics_text(s["retention_metrics"]) + ".",
        *(f"Measured, {t['label']} (after the application): "
          f"{metrics_text(t['retention_metrics'])}." for t in fit.meta.get("tests", [])
          if t.get("retention_metrics")),
        "Modelled: " + "; ".join(m for m in s["modelled"] if m not in pred.notes) + ".",
    ]
    figs = [Figure("removal_fit", plot(removal_figure, fit),
                   "Time tests after application: measured coefficient (points) against the "
                   "fitted removal model (lines; dotted: the film phase, not fitted) and the "
                   "modelled remaining amount"),
            Figure("amount_layer", plot(layer_figure, layer),
                   "Layer limits of the HPT amount series against the areal density, with their "
                   "95 % error bars and the monotone interpolation"),
            Figure("retention", plot(retention_figure, pred, axis=axis),
                   "Coefficient against passes after one application with its 95 % interval "
                   "(layer and law drawn together), the band and its crossings; remaining "
                   "amount below")]
    summary: dict[str, Any] = {
        "product": product, "law": law, "parameters": {
            n: {"value": fit.params[n], "low95": fit.ci95[n][0], "high95": fit.ci95[n][1],
                "unit": LAW_UNITS.get(n, "")} for n in fit.names},
        "law_selection": {r["law"]: {"delta_aicc": r["delta_aicc"], "weight": r["weight"]}
                          for r in fit.meta["law_selection"]},
        "tested_amounts_mg_m2": s["tested_amounts_mg_m2"],
        "prediction": {k: s[k] for k in (
            "scene", "creepage", "band", "applied", "initial_amount_mg_m2", "mu_initial",
            "mu_dry", "passes_to_dry_anchor", "passes_to_enter_band", "passes_to_leave_band",
            "retention_metrics")},
    }
    tables = [
        Table("removal_fit", fit.table(), "Removal law: parameters, standard errors and 95 % "
              "intervals", allow_missing=("stderr", "ci95_low", "ci95_high")),
        Table("law_selection", sel, "Candidate laws: residual sum of squares, AICc, difference "
              "to the best and Akaike weight",
              {"law": ("law", ""), "parameters": ("parameters", ""), "AICc": ("aicc", ".1f"),
               "ΔAICc": ("delta_aicc", ".1f"), "weight": ("weight", ".3f")}),
        Table("amount_layer", layer.table(), "Layer nodes: the dry anchor and the tested "
              "amounts", {"node": ("node", ""), "amount (mg/m²)": ("amount_mg_m2", ".4g"),
                          **{label.split(" ")[0].replace("μ_c", "μc"): (k, ".4f")
                             for k, label in layer.law.limits()},
                          "source": ("source", "")}),
        Table("crossings", pd.DataFrame(_crossing_rows(s)), "Passes to enter and to leave "
              "the band, with 95 % intervals",
              {"crossing": ("crossing", ""), "passes": ("passes", ".4g"),
               "95 % low": ("low95", ".4g"), "95 % high": ("high95", ".4g"),
               "status": ("status", "")},
              allow_missing=("passes", "low95", "high95", "amount_mg_m2")),
        Table("retention", pred.table, "Coefficient against passes (retention.csv columns)",
              allow_missing=("mu_low95", "mu_high95"), inline=False),
    ]
    if sweep is not None:
        ss = sweep.summary
        figs.append(Figure("sweep", plot(sweep_figure, sweep),
                           "Traction curve recorded during a slip sweep while product is "
                           "removed, beside the steady curve at the applied amount (thesis "
                           "H4.1)"))
        tables.append(Table("sweep", sweep.table, "Slip sweep: creepage, recorded and steady "
                            "coefficient, remaining amount against time", inline=False))
        paras.append(f"Slip sweep over {ss['seconds']:g} s ({ss['passes_during_sweep']:.4g} "
                     f"passes, creepage {100 * ss['creepage_range'][0]:g}–"
                     f"{100 * ss['creepage_range'][1]:g} %): {ss['verdict']}.")
        summary["sweep"] = {k: ss[k] for k in ("seconds", "creepage_range",
                                                "passes_during_sweep", "verdict",
                                                "probability_sweep_positive",
                                                "probability_positive_by_removal",
                                                "verdict_probabilities")
                            if k in ss}
        summary["sweep"]["trend_sweep"] = ss["trend_sweep"]["trend"]
        summary["sweep"]["trend_steady"] = ss["trend_steady"]["trend"]
    notes = [*fit.warnings, *pred.notes]
    if sweep is not None:
        notes += list(sweep.summary.get("notes", []))
    return Section(key="retention", title=f"Product retention ({product})", paragraphs=paras,
                   figures=figs, tables=tables, summary=summary,
                   notes=list(dict.fromkeys(notes)))
