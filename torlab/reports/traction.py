"""Traction report: measured and/or predicted μ against creepage, trend after saturation (H4.1).

Predicted curves come from :func:`torlab.model.predict.predict_traction` on the
protocol's scenes with the fitted parameter sets applied; measured curves are the
optical tribometer's folded traction points (|SRR|, one curve per rolling speed)
or MTM traction steps.  Every curve's trend after saturation is classified by
:func:`torlab.model.predict.classify_trend` (negative / neutral / positive /
not saturated; thesis H4.1, Fig. 2.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.reports.html import Figure, Section, Table

__all__ = ["TractionCurve", "traction_report_figure", "traction_section"]


@dataclass
class TractionCurve:
    """One curve of the traction report.

    Attributes
    ----------
    label
        Legend label.
    kind
        ``"model"`` or ``"measured"``.
    table
        DataFrame with ``creepage`` and ``mu`` (and the model's other columns).
    trend
        :func:`~torlab.model.predict.classify_trend` of the curve.
    source
        Scene and parameter sets, or the measured file.
    speed_m_s
        Rolling speed of the curve.
    boundary
        The layer of a modelled curve (``mu_c1``, ``mu_c2`` ...), for the table.
    modelled
        What the prediction modelled.
    group
        Curves of one group (a modelled curve and the measured points at its
        speed) share a colour.
    """

    label: str
    kind: str
    table: Any
    trend: dict[str, Any]
    source: str
    speed_m_s: float | None = None
    boundary: dict[str, float] = field(default_factory=dict)
    modelled: list[str] = field(default_factory=list)
    group: str = ""


def _f(v: Any) -> Any:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return None
    return float(v) if isinstance(v, (float, np.floating)) else v


def traction_section(curves: list[TractionCurve], cfg: Any) -> Section:
    """The traction report of modelled and measured curves.

    Parameters
    ----------
    curves
        Every curve (modelled ones first, then measured, in protocol order).
    cfg
        The protocol's ``reports.traction``.
    """
    import pandas as pd

    from torlab.reports.render import plot

    fig = plot(traction_report_figure, curves, cfg)
    rows, long = [], []
    for c in curves:
        t = c.trend
        mu = np.abs(c.table["mu"].to_numpy(dtype=float))
        xi = c.table["creepage"].to_numpy(dtype=float)
        i = int(np.argmax(mu))
        rows.append({"curve": c.label, "kind": c.kind, "source": c.source,
                     "speed_m_s": c.speed_m_s if c.speed_m_s is not None else float("nan"),
                     "mu_max": float(mu[i]), "creepage_at_mu_max": float(xi[i]),
                     "mu_at_max_creepage": float(mu[int(np.argmax(np.abs(xi)))]),
                     "trend": t["trend"],
                     "points_in_trend": int(np.sum(np.abs(xi) >= t["trend_from_creepage"]))
                     if t.get("trend_from_creepage") is not None else 0,
                     "saturation_creepage": _nanf(t.get("saturation_creepage")),
                     "relative_change": _nanf(t.get("relative_change")),
                     "mu_c1": c.boundary.get("mu_c1", float("nan")),
                     "mu_c2": c.boundary.get("mu_c2", float("nan")),
                     "L_mue_m": c.boundary.get("L_mue", float("nan")),
                     "L_mup_m": c.boundary.get("L_mup", float("nan"))})
        d = c.table.copy()
        d.insert(0, "curve", c.label)
        d.insert(1, "kind", c.kind)
        long.append(d)
    table = pd.DataFrame(rows)
    curves_df = pd.concat(long, ignore_index=True)
    curves_df = curves_df[[c for c in curves_df.columns if curves_df[c].dtype == object
                           or curves_df[c].notna().any()]]
    show = {"curve": ("curve", ""), "kind": ("kind", ""), "speed (m/s)": ("speed_m_s", ".3g"),
            "μ max": ("mu_max", ".4f"), "at creepage": ("creepage_at_mu_max", ".4g"),
            "trend after saturation": ("trend", ""), "saturated at": ("saturation_creepage", ".3g"),
            "relative change": ("relative_change", "+.3f"),
            "points": ("points_in_trend", "d"), "μ_c1": ("mu_c1", ".4g"),
            "μ_c2": ("mu_c2", ".4g")}
    paragraphs = [
        "Traction coefficient against creepage (= SRR as a fraction): modelled curves "
        "(Hertz + FASTSIM with the third-body layer; film and asperity load sharing for "
        "lubricated scenes, Eq. 5.47) and measured points (negative SRR folded onto positive).",
        f"Trend after saturation (thesis H4.1): a straight line over the second half of the "
        f"range after the curve reaches 95 % of its maximum; its relative change beyond "
        f"±{cfg.trend_tolerance:g} is a negative or positive trend, within it neutral. "
        "'points' is how many points that line rests on: with fewer than three in the second "
        "half (sparse measured curves) the line spans the whole range after saturation and "
        "the knee of the curve can tilt it.",
    ]
    for r in rows:
        paragraphs.append(f"{r['curve']} ({r['kind']}): max μ {r['mu_max']:.4f}, trend "
                          f"{r['trend']}.")
    notes = sorted({m for c in curves for m in c.modelled if "not modelled" in m})
    summary = {"trend_tolerance": cfg.trend_tolerance,
               "curves": {r["curve"]: {k: _f(v) for k, v in r.items() if k != "curve"}
                          for r in rows}}
    optional = tuple(c for c in table.columns
                     if c not in ("curve", "kind", "source", "trend", "points_in_trend"))
    return Section(
        key="traction", title="Traction curves", paragraphs=paragraphs,
        figures=[Figure("traction", fig, "Traction coefficient against creepage: modelled "
                        "(lines, with the 95 % band of the fit's uncertainty where the "
                        "parameters carry one) and measured (circles)")],
        tables=[Table("trends", table, "Trend after saturation per curve", show,
                      allow_missing=optional),
                Table("curves", curves_df, "Every curve point (long format)", {
                    "curve": ("curve", ""), "creepage": ("creepage", ".4g"), "μ": ("mu", ".4f")},
                    allow_missing=tuple(c for c in curves_df.columns
                                        if c not in ("curve", "kind")), inline=False)],
        summary=summary, notes=notes)


def _nanf(v: Any) -> float:
    return float(v) if v is not None else float("nan")


def traction_report_figure(curves: list[TractionCurve], cfg: Any) -> Any:
    """|μ| against creepage (%): modelled lines with their 95 % bands, measured circles, one
    colour per group (:class:`~torlab.reports.render.Plot` function)."""
    from torlab.reports.plotting import axis_label, band, colours, legend, points, subplots

    fig, ax = subplots(figsize=(7.0, 4.6))
    col = colours(c.group or c.label for c in curves)
    banded = False
    for c in curves:
        color = col[c.group or c.label]
        x = 100.0 * np.abs(c.table["creepage"].to_numpy(dtype=float))
        y = np.abs(c.table["mu"].to_numpy(dtype=float))
        order = np.argsort(x, kind="stable")
        if c.kind == "model":
            ax.plot(x[order], y[order], lw=1.6, color=color, label=c.label)
            if "mu_low95" in c.table and "mu_high95" in c.table:
                lo = np.abs(c.table["mu_low95"].to_numpy(dtype=float))
                hi = np.abs(c.table["mu_high95"].to_numpy(dtype=float))
                band(ax, x[order], np.minimum(lo, hi)[order], np.maximum(lo, hi)[order],
                     color=color)
                banded = True
        else:
            err = c.table["mu_sd"].to_numpy(dtype=float) if "mu_sd" in c.table else None
            points(ax, x, y, err, color=color, label=c.label)
    if cfg.band is not None:
        ax.axhspan(cfg.band[0], cfg.band[1], color="#d9ead3", alpha=0.5, lw=0,
                   label=f"optimal band {cfg.band[0]:g}–{cfg.band[1]:g}")
    if banded:
        ax.fill_between([], [], [], color="0.5", alpha=0.22, lw=0,
                        label="95 % band (fit uncertainty)")
    ax.set_xlabel(axis_label("creepage ξ = SRR", "", "%"))
    ax.set_ylabel(axis_label("traction coefficient", "|μ|"))
    ax.set_ylim(bottom=0)
    ax.set_xlim(left=0)
    legend(ax)
    kinds = {c.kind for c in curves}
    parts = [p for k, p in (("model", "modelled (lines)"), ("measured", "measured (circles)"))
             if k in kinds]
    ax.set_title("Traction curves: " + " and ".join(parts))
    return fig
