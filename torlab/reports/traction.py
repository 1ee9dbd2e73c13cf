"""Traction report: measured and/or predicted μ against creepage, trend after saturation (H4.1).

Predicted curves come from :func:`torlab.model.predict.predict_traction` on the
protocol's scenes with the fitted parameter sets applied; measured curves are the
optical tribometer's folded traction points (|SRR|, one curve per rolling speed)
or MTM traction steps.  Every curve's trend after saturation is classified by
:func:`torlab.model.prediction.classify_trend` (negative / neutral / positive /
not saturated in this range, too few points; thesis H4.1, Fig. 2.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.reports.html import Figure, Section, Table

__all__ = ["TractionCurve", "traction_figures", "traction_report_figure", "traction_section"]


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
        :func:`~torlab.model.prediction.classify_trend` of the curve.
    source
        Scene and parameter sets, or the measured file.
    speed_m_s
        Rolling speed of the curve.
    boundary
        The layer of a modelled curve (its ``boundary:`` values), for the table.
    modelled
        What the prediction modelled.
    group
        Curves of one group (a modelled curve and the measured points at its
        speed) share a colour.
    band
        The prediction's band summary (``summary["band"]`` of
        :func:`~torlab.model.predict.predict_traction`: method, dominant
        parameters, notes); empty for measured curves.
    choices
        Model-selection choices of the fits behind a modelled curve (a
        coefficient fixed to 0 is exact in the prediction): the verdict is
        conditional on them, and the report says so.
    theory
        A modelled curve's boundary method and theory error (``summary["method"]`` and
        ``summary["theory_error"]`` of the prediction): the model's own error against
        Kalker's exact theory, apart from the band.
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
    band: dict[str, Any] = field(default_factory=dict)
    choices: list[str] = field(default_factory=list)
    theory: dict[str, Any] = field(default_factory=dict)


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

    from torlab.model.layers import DEFAULT_LAW, get_law

    figs = traction_figures(curves, cfg)
    threshold = getattr(cfg, "trend_probability", 0.9)
    # the layer columns: the parameters of the laws of the modelled curves (in order)
    laws = list(dict.fromkeys(get_law(c.boundary.get("law")) for c in curves if c.boundary)) \
        or [get_law()]
    several_laws = len(laws) > 1 or laws[0] is not get_law()
    layer_params = {p.name: p for lw in laws for p in lw.params}
    rows = []
    for c in curves:
        t = c.trend
        mu = np.abs(c.table["mu"].to_numpy(dtype=float))
        xi = c.table["creepage"].to_numpy(dtype=float)
        i = int(np.argmax(mu))
        probs = t.get("probabilities") or {}
        lo, hi = _mu_band(c.table, i)
        rows.append({"curve": c.label, "kind": c.kind, "source": c.source,
                     "speed_m_s": c.speed_m_s if c.speed_m_s is not None else float("nan"),
                     "mu_max": float(mu[i]), "mu_max_low95": lo, "mu_max_high95": hi,
                     "creepage_at_mu_max": float(xi[i]),
                     "mu_at_max_creepage": float(mu[int(np.argmax(np.abs(xi)))]),
                     "trend": t["trend"], "trend_point": t.get("trend_point", t["trend"]),
                     "p_negative": _nanf(probs.get("negative")),
                     "p_neutral": _nanf(probs.get("neutral")),
                     "p_positive": _nanf(probs.get("positive")),
                     "trend_probability_threshold": t.get("probability_threshold", threshold),
                     "trend_basis": t.get("basis", ""),
                     "points_in_trend": int(np.sum(np.abs(xi) >= t["trend_from_creepage"]))
                     if t.get("trend_from_creepage") is not None else 0,
                     "saturation_creepage": _nanf(t.get("saturation_creepage")),
                     "relative_change": _nanf(t.get("relative_change")),
                     "relative_change_low95": _nanf(t.get("relative_change_low95")),
                     "relative_change_high95": _nanf(t.get("relative_change_high95")),
                     "band_method": c.band.get("method", "") if c.kind == "model" else "",
                     "boundary_method": (c.theory.get("method") or {}).get("method", "")
                     if c.kind == "model" else "",
                     "mu_max_theory_error95": float(c.table["mu_theory_error_95"].iloc[i])
                     if "mu_theory_error_95" in c.table else float("nan"),
                     "band_dominated_by": _dominant_text(c.band) if c.kind == "model" else "",
                     **({"law": c.boundary.get("law", DEFAULT_LAW)} if several_laws else {}),
                     **{f"{n}{p.column}": c.boundary.get(n, float("nan"))
                        for n, p in layer_params.items()}})
    table = pd.DataFrame(rows)
    curves_df = _long_table(curves)
    show = {"curve": ("curve", ""), "kind": ("kind", ""), "speed (m/s)": ("speed_m_s", ".3g"),
            "μ max": ("mu_max", ".4f"), "95 % low": ("mu_max_low95", ".4f"),
            "95 % high": ("mu_max_high95", ".4f"),
            "theory error (95 %)": ("mu_max_theory_error95", ".2g"),
            "method": ("boundary_method", ""), "at creepage": ("creepage_at_mu_max", ".4g"),
            "trend after saturation": ("trend", ""),
            "P(negative)": ("p_negative", ".3f"), "P(neutral)": ("p_neutral", ".3f"),
            "P(positive)": ("p_positive", ".3f"),
            "relative change": ("relative_change", "+.4f"),
            "points": ("points_in_trend", "d"),
            "band variance shares": ("band_dominated_by", "")}
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
        f"Evidence: a modelled curve whose parameters come from fits carries their "
        f"uncertainty (the fits' covariances propagated through the model: the 95 % band "
        f"columns mu_low95/mu_high95 in curves.csv); a measured curve, the scatter of its "
        f"points about the trend line. Each class gets its probability, and a class is called "
        f"only when its probability is at least {threshold:g}; otherwise the trend is "
        f"'undetermined' and the probabilities say how it leans.",
        "Theory error: a modelled curve's boundary method (fastsim: FASTSIM corrected by "
        "Kalker's exact theory; fastsim-kalker: the thesis's FASTSIM; exact: Kalker's exact "
        "theory) has an error of its own at exact parameters, stated apart from the band "
        "(column mu_theory_error_95 in curves.csv; 'theory error' at the maximum above), "
        "never added to it.",
    ]
    for r, c in zip(rows, curves, strict=True):
        paragraphs.append(_curve_sentence(r, c))
    notes = sorted({m for c in curves for m in c.modelled if "not modelled" in m})
    notes += [f"traction {c.label}: {n}" for c in curves for n in c.band.get("notes", [])
              if n.startswith("no band") or "taken as exact" in n]
    summary = {"trend_tolerance": cfg.trend_tolerance, "trend_probability": threshold,
               "curves": {r["curve"]: {**{k: _f(v) for k, v in r.items() if k != "curve"},
                                       "probabilities": c.trend.get("probabilities"),
                                       "band": _band_summary(c.band),
                                       "model_selection": list(c.choices)}
                          for r, c in zip(rows, curves, strict=True)}}
    optional = tuple(c for c in table.columns
                     if c not in ("curve", "kind", "source", "trend", "points_in_trend"))
    return Section(
        key="traction", title="Traction curves", paragraphs=paragraphs,
        figures=[Figure(name, fig, "Traction coefficient against creepage: modelled "
                        "(lines, with the 95 % band of the fit's uncertainty where the "
                        "parameters carry one) and measured (circles)"
                        + (f" (continued, figure {k + 1} of {len(figs)})" if k else ""))
                 for k, (name, fig) in enumerate(figs)],
        tables=[Table("trends", table, "Trend after saturation per curve", show,
                      allow_missing=optional),
                Table("curves", curves_df, "Every curve point (long format)", {
                    "curve": ("curve", ""), "creepage": ("creepage", ".4g"), "μ": ("mu", ".4f")},
                    allow_missing=tuple(c for c in curves_df.columns
                                        if c not in ("curve", "kind")), inline=False)],
        summary=summary, notes=notes)


def _long_table(curves: list[TractionCurve]) -> Any:
    """Every curve's points in one table: ``curve``, ``kind``, then the curves' columns
    (a column some curves lack is empty there; one empty in every curve is left out).

    The curves' tables are joined as they are and the two label columns added to the
    result, so the points are copied once (a 128x campaign's 768 curves: about 3 MB).
    """
    import pandas as pd

    long = pd.concat([c.table for c in curves], ignore_index=True)
    lengths = [len(c.table) for c in curves]
    for at, (name, values) in enumerate((("curve", [c.label for c in curves]),
                                          ("kind", [c.kind for c in curves]))):
        long.insert(at, name, pd.Series(values).repeat(lengths).to_numpy())
    dead = [c for c in long.columns if long[c].dtype != object and not long[c].notna().any()]
    return long.drop(columns=dead) if dead else long


def _nanf(v: Any) -> float:
    return float(v) if v is not None else float("nan")


def _mu_band(table: Any, i: int) -> tuple[float, float]:
    """The 95 % band of |mu| at row ``i`` (NaN without a band)."""
    if "mu_low95" not in table or "mu_high95" not in table:
        return float("nan"), float("nan")
    lo = float(table["mu_low95"].iloc[i])
    hi = float(table["mu_high95"].iloc[i])
    if float(table["mu"].iloc[i]) < 0:  # |mu| of a negative creepage: the band flips
        lo, hi = -hi, -lo
    return lo, hi


def _dominant_text(band: dict[str, Any], output: str = "mu") -> str:
    """``"mu_c2 62 %, L_mup 30 %"``: the parameters that dominate a band."""
    dom = (band.get("dominant") or {}).get(output) or []
    return shares_text(dom, (band.get("explained") or {}).get(output))


def shares_text(dominant: list[dict[str, Any]], explained: float | None = None) -> str:
    """``"mu_c2 79 %, L_mup 11 %"``: the parameters' shares of a band's variance (Shapley
    effects, :func:`torlab.uncertainty.shapley_shares`: never negative, at most 100 %
    together), and, where the parameters' linear effects explain less than all of it
    (a sampled band), how much they explain."""
    text = ", ".join(f"{d['parameter']} {100 * d['share']:.0f} %" for d in dominant)
    if text and explained is not None and explained < 0.995:
        text += f" (of the {100 * explained:.0f} % its parameters explain linearly)"
    return text


def _band_summary(band: dict[str, Any]) -> dict[str, Any] | None:
    """The band entry of a curve for ``summary.json`` (method, check, dominant, notes)."""
    if not band:
        return None
    keep = ("method", "confidence", "nonlinearity", "n_evaluations", "parameters", "dominant",
            "explained", "notes")
    return {k: band[k] for k in keep if k in band}


def _pct(v: float) -> str:
    return f"{100 * v:+.2f} %"


def _curve_sentence(r: dict[str, Any], c: TractionCurve) -> str:
    """One curve's verdict with its evidence, in words."""
    mu = f"max μ {r['mu_max']:.4f}"
    if math.isfinite(r["mu_max_low95"]):
        mu += f" [{r['mu_max_low95']:.4f}, {r['mu_max_high95']:.4f}]"
    t = c.trend
    probs = t.get("probabilities")
    trend = t["trend"]
    if probs:
        pr = ", ".join(f"{k} {v:.2f}" for k, v in probs.items())
        iv = ""
        if t.get("relative_change_low95") is not None and t.get("relative_change") is not None:
            iv = (f"; relative change {_pct(t['relative_change'])}, 95 % interval "
                  f"[{_pct(t['relative_change_low95'])}, {_pct(t['relative_change_high95'])}]")
        if trend == "undetermined":
            verdict = (f"trend after saturation undetermined: no class reaches probability "
                       f"{t['probability_threshold']:g} ({pr}{iv})")
        elif trend not in probs:  # a rise of a layer that cannot soften (rises_only)
            verdict = (f"trend after saturation: {trend} (still rising: {pr}{iv}; an "
                       "isothermal layer's curve that rises has not levelled off, which is "
                       "not a positive characteristic)")
        else:
            verdict = (f"trend after saturation {trend} with probability {probs[trend]:.2f} "
                       f"({pr}{iv})")
        verdict += f"; probabilities from {t.get('basis', 'the uncertainty')}"
    elif trend in ("negative", "neutral", "positive"):
        why = t.get("basis") or "no uncertainty given"
        verdict = (f"trend after saturation {trend} for the curve itself, without a "
                   f"probability ({why})")
        if r["kind"] == "model":
            verdict += ": its parameters carry no covariance"
        if r["relative_change"] == r["relative_change"]:
            verdict += f"; relative change {_pct(r['relative_change'])}"
    else:
        verdict = f"trend after saturation: {trend}"
    out = f"{r['curve']} ({r['kind']}): {mu}; {verdict}."
    if c.kind == "model" and c.band:
        m = c.band.get("method", "")
        if m in ("linear", "sampling"):
            dom = _dominant_text(c.band)
            out += (f" Band: {m} propagation of {', '.join(c.band.get('parameters', []))}"
                    + (f"; shares of its variance: {dom}." if dom else "."))
        elif m == "none":
            out += " Band: none (the fitted parameters have zero variance)."
        else:
            why = "; ".join(n for n in c.band.get("notes", []) if n.startswith("no band"))
            out += f" No band ({why or 'no fit covariance'})."
    fixed = [ch for ch in c.choices if "fixed" in ch]
    if fixed:
        out += (" Conditional on the fits' model selection (fixed values are exact in the "
                "prediction): " + "; ".join(fixed) + ".")
    return out


#: the most curve groups (a colour each) in one panel of the traction figure: more are
#: drawn in facets of this many, each with its own legend
PER_PANEL = 7
#: the most panels in one traction figure: more curves go on to further figures
#: (``traction_2``, ...), each a page of at most 14 panels (about 2000 x 5000 pixels; one
#: figure of 384 curves was 1980 x 13725 pixels and 150 MB of canvas)
PANELS_PER_FIGURE = 14


def traction_figures(curves: list[TractionCurve], cfg: Any) -> list[tuple[str, Any]]:
    """The traction figure(s) of ``curves``, declared: ``[("traction", Plot), ("traction_2",
    Plot), ...]``, a further figure for every :data:`PANELS_PER_FIGURE` panels."""
    from torlab.reports.render import plot

    curves = [_drawn(c) for c in curves]
    groups = list(dict.fromkeys(c.group or c.label for c in curves))
    per = PER_PANEL * PANELS_PER_FIGURE
    if len(groups) <= per:
        return [("traction", plot(traction_report_figure, curves, cfg))]
    pages = [groups[i:i + per] for i in range(0, len(groups), per)]
    out = []
    for k, page in enumerate(pages):
        mine = set(page)
        out.append(("traction" if k == 0 else f"traction_{k + 1}",
                    plot(traction_report_figure, [c for c in curves if (c.group or c.label) in mine],
                         cfg, first=k * per, total=len(groups), page=(k + 1, len(pages)))))
    return out


#: the columns of a curve's table that its figure draws (:func:`_traction_panel`)
DRAWN_COLUMNS = ("creepage", "mu", "mu_low95", "mu_high95", "mu_sd")


def _drawn(c: TractionCurve) -> TractionCurve:
    """What the figure draws of a curve: its label, kind, group and the drawn columns.

    A declared figure is kept until the run's figures are written, and with it what it
    was given: the whole curve would keep its trend, band, theory and every column of its
    table to the end of the run (a 128x campaign: 768 curves).  The columns are copied: a
    selection of them is a view that would keep the table's whole block of numbers.
    """
    cols = [k for k in DRAWN_COLUMNS if k in c.table]
    return TractionCurve(c.label, c.kind, c.table[cols].copy(), {}, "", group=c.group)


def traction_report_figure(curves: list[TractionCurve], cfg: Any, *, first: int = 0,
                           total: int | None = None,
                           page: tuple[int, int] | None = None) -> Any:
    """|μ| against creepage (%): modelled lines with their 95 % bands, measured circles, one
    colour per group (:class:`~torlab.reports.render.Plot` function).

    More than :data:`PER_PANEL` groups are drawn in facets of :data:`PER_PANEL`, each with
    its own colours and legend (a campaign of 96 curves in one panel had a legend cut off
    after 24 entries and repeated colours).  ``page``: this figure is page ``(k, n)`` of a
    campaign's traction figures (:func:`traction_figures`), its curves the groups
    ``first + 1`` onwards of ``total``.
    """
    from torlab.reports.plotting import facet_legend, facets, legend, subplots

    groups = list(dict.fromkeys(c.group or c.label for c in curves))
    total = len(groups) if total is None else total
    kinds = {c.kind for c in curves}
    parts = [p for k, p in (("model", "modelled (lines)"), ("measured", "measured (circles)"))
             if k in kinds]
    title = "Traction curves: " + " and ".join(parts)
    if len(groups) <= PER_PANEL and page is None:
        fig, ax = subplots(figsize=(7.0, 4.6))
        _traction_panel(ax, curves, cfg)
        legend(ax)
        ax.set_title(title)
        return fig
    chunks = [groups[i:i + PER_PANEL] for i in range(0, len(groups), PER_PANEL)]
    fig, axes = facets(len(chunks), ncols=2)
    for k, (chunk, (ax,)) in enumerate(zip(chunks, axes, strict=True)):
        mine = set(chunk)
        _traction_panel(ax, [c for c in curves if (c.group or c.label) in mine], cfg)
        facet_legend(ax)
        a = first + k * PER_PANEL + 1
        ax.set_title(f"curves {a}–{a + len(chunk) - 1} of {total}", fontsize=9)
    if page is None:
        fig.suptitle(f"{title}, {len(groups)} curves in {len(chunks)} panels")
    else:
        fig.suptitle(f"{title}, curves {first + 1}–{first + len(groups)} of {total} "
                     f"(figure {page[0]} of {page[1]})")
    return fig


def _traction_panel(ax: Any, curves: list[TractionCurve], cfg: Any) -> None:
    """One panel of the traction figure: its curves, the band, the axes' labels."""
    from torlab.reports.plotting import axis_label, band, band_style, colours, points

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
        rgb, a = band_style("0.5")
        ax.fill_between([], [], [], color=rgb, alpha=a, lw=0,
                        label="95 % band (fit uncertainty)")
    ax.set_xlabel(axis_label("creepage ξ = SRR", "", "%"))
    ax.set_ylabel(axis_label("traction coefficient", "|μ|"))
    ax.set_ylim(bottom=0)
    ax.set_xlim(left=0)
