"""Amount-dependency report (Paper C): friction against applied amount per product.

The report draws what :mod:`torlab.fit.crossing` computed for an amount series (one row
per HPT run: the friction ``f`` against the applied amount, µL for liquids, mg for
solids):

* ``f`` against the amount as applied and against the applied *mass* (volume x
  product density), so liquid and solid products compare on one axis;
* the optimal band (0.15-0.25 by default, thesis chapter 6) and the
  low-friction threshold (0.15 by default);
* the amount at which each product's friction falls below the threshold, with
  a confidence interval and the evidence for the verdict
  (:func:`torlab.fit.crossing.crossing_probabilities`), and whether the products cross
  at one applied mass (thesis H3.2).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from torlab.fit.crossing import (
    CROSSING_PROBABILITY,
    CrossingFit,
    crossing_row,
    logistic,
    logistic_band,
    mass_factor,
)
from torlab.reports.html import Figure, Section, Table
from torlab.reports.plotting import subplots
from torlab.reports.render import plot

__all__ = ["amount_figure", "amount_section"]

_NAN = float("nan")


def _f_by_run(series: Any) -> dict[str, float]:
    """f of every run, keyed by product and amount (and the file, for repeats)."""
    keys = [f"{r.product} {r.applied_amount:g} {r.applied_amount_unit}" for r in series.itertuples()]
    out = {}
    for k, r in zip(keys, series.itertuples(), strict=True):
        out[k if keys.count(k) == 1 else f"{k} ({r.file})"] = float(r.f)
    return out


def amount_section(series: Any, cfg: Any, fits: list[CrossingFit] | None,
                   stats: dict[str, Any] | None) -> Section:
    """The amount-dependency report (figures, tables, key numbers) of an amount series.

    Parameters
    ----------
    series
        From :func:`torlab.fit.crossing.amount_series` (empty: an input error naming
        ``reports.amount``).
    cfg
        The protocol's ``reports.amount`` (:class:`~torlab.protocols.schema.AmountReport`).
    fits
        :func:`torlab.fit.crossing.fit_crossings` of the series with ``cfg``'s settings
        (None only for an empty series).
    stats
        :func:`torlab.fit.crossing.amount_statistics` of ``series`` and ``fits`` with
        ``cfg``'s settings (None only for an empty series).
    """
    import pandas as pd

    from torlab.errors import TorlabInputError

    if series is None or len(series) == 0:
        raise TorlabInputError(
            f"reports.amount: no HPT run with an applied amount at {cfg.temperature:g} ± "
            f"{cfg.temperature_tolerance:g} °C", key="reports.amount")
    if fits is None or stats is None:
        raise ValueError("amount_section draws the crossing fits and statistics it is given")
    band, thr = tuple(cfg.band), cfg.threshold
    prob = getattr(cfg, "probability", CROSSING_PROBABILITY)
    pooled = (stats["pooled"][0], stats["pooled"][1])
    rows, key = [], {}
    notes: list[str] = []
    for cf in fits:
        row = crossing_row(series, cf)
        row.update(stats["status"][cf.product])
        for n in ("f_low", "f_high", "k", "c"):
            row[f"logistic_{n}"] = cf.params.get(n, float("nan"))
        rows.append(row)
        notes += cf.notes
        key[cf.product] = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                           for k, v in row.items() if k != "product"}
    table = pd.DataFrame(rows)
    num_optional = tuple(c for c in table.columns if c not in ("product", "n_amounts"))
    lev = f"{100 * cfg.confidence:g} %"
    paragraphs = [
        f"HPT friction f (mean over the window before the maximum displacement, thesis "
        f"Fig. 5.10) against the applied amount at {cfg.temperature:g} °C, per product. "
        f"Optimal band {band[0]:g}–{band[1]:g}; low-friction threshold {thr:g}.",
        ("Crossing of the threshold: four-parameter logistic in log amount per product, "
         f"residual variance pooled over the products, {lev} delta-method interval on the "
         "log crossing amount (Student t on the pooled degrees of freedom). Reported only "
         "where the measured series brackets the threshold.")
        if cfg.curve == "logistic" else
        "Crossing of the threshold: linear interpolation in log amount between the "
        "bracketing runs (no interval).",
        "Mass basis: volumes times the product density (protocol products: or the log's "
        "product_density); solids as applied.",
    ]
    sc = stats.get("scatter")
    if sc:
        paragraphs.append(f"What the crossing intervals hold: {sc['holds']}.")
    for r in rows:
        if r["status"] != "crosses" or not math.isfinite(r["crossing_amount"]):
            ev = ""
            if math.isfinite(r.get("p_status", _NAN)):
                ev = (f" Evidence: at its lowest-friction amount the series is "
                      f"{'above' if r['status'].startswith('above') else 'below'} the threshold "
                      f"with probability {r['p_status']:.3f} (pooled run-to-run scatter "
                      f"{pooled[0]:.3g}, Student t on {pooled[1]} degrees of freedom; verdict "
                      f"called at ≥ {prob:g}: {r['status_verdict']}).")
            paragraphs.append(f"{r['product']}: {r['status']} (no crossing reported).{ev}")
            continue
        iv = "" if not math.isfinite(r["crossing_amount_low"]) else \
            f" [{r['crossing_amount_low']:.3g}, {r['crossing_amount_high']:.3g}]"
        ms = "" if not math.isfinite(r["crossing_mass_mg"]) else f" = {r['crossing_mass_mg']:.3g} mg"
        ev = ""
        if math.isfinite(r["p_crossing_in_range"]):
            ev = (f" Probability that the crossing lies within the tested amounts "
                  f"{r['p_crossing_in_range']:.3f} (verdict, called at ≥ {prob:g}: "
                  f"{r['crossing_verdict']}); friction below the threshold at the largest amount "
                  f"with probability {r['p_below_at_largest']:.3f}.")
        paragraphs.append(f"{r['product']}: f falls below {thr:g} at {r['crossing_amount']:.3g}"
                          f"{iv} {r['amount_unit']}{ms} ({r['method']}).{ev}")
    same = stats["mass_homogeneity"]
    if same is not None:
        paragraphs.append(
            f"Same mass for every product (thesis H3.2)? The crossing masses of "
            f"{', '.join(same['products'])} against one common mass: χ² = {same['chi2']:.3g} on "
            f"{same['dof']} degrees of freedom, p = {same['p_value']:.3g} "
            f"({'consistent with one mass' if same['p_value'] >= 0.05 else 'different masses'} "
            f"at the 5 % level; common mass {same['mass_mg']:.3g} mg, 95 % interval "
            f"[{same['mass_low_mg']:.3g}, {same['mass_high_mg']:.3g}] mg; the crossings share "
            "the pooled scatter, which the test neglects).")
    figs = _pages("amount_applied", series, fits, cfg, False,
                  "Friction f against the applied amount (µL for liquids, mg for solids, "
                  "each unit in a panel of its own), error bars one standard deviation of f "
                  "over the reduction window, with the fitted curves and their 95 % bands, "
                  "the optimal band and, below, each product's crossing of the threshold "
                  "with its interval")
    missing = sorted(set(series.loc[series["mass_mg"].isna(), "product"]))
    if cfg.basis == "mass" and series["mass_mg"].notna().any():
        figs += _pages("amount_mass", series, fits, cfg, True,
                       "Mass-based comparison across product types: f against applied mass")
        if missing:
            notes.append(f"no density for {', '.join(missing)}: left out of the mass comparison "
                         "(give products.<name>.density)")
    elif cfg.basis == "mass":
        notes.append("no product density known: no mass-based comparison")
    show = {"product": ("product", ""), "status": ("status", ""),
            "crossing": ("crossing_amount", ".3g"), f"{lev} low": ("crossing_amount_low", ".3g"),
            f"{lev} high": ("crossing_amount_high", ".3g"), "unit": ("amount_unit", ""),
            "crossing (mg)": ("crossing_mass_mg", ".3g"),
            "in band from": ("band_amount_from", ".3g"), "in band to": ("band_amount_to", ".3g"),
            "P(crossing in range)": ("p_crossing_in_range", ".3f"),
            "verdict": ("crossing_verdict", "")}
    series_show = {"product": ("product", ""), "amount": ("applied_amount", "g"),
                   "unit": ("applied_amount_unit", ""), "mass (mg)": ("mass_mg", ".3g"),
                   "f": ("f", ".4f"), "sd": ("f_sd", ".4f"), "file": ("file", "")}
    summary = {
        "temperature_C": cfg.temperature, "band": list(band), "threshold": thr,
        "curve": cfg.curve, "confidence": cfg.confidence, "probability": prob,
        "n_runs": len(series), "products": key,
        "pooled_scatter": {"sd": pooled[0], "dof": pooled[1]},
        "scatter": None if not sc else {k: (None if isinstance(v, float) and not math.isfinite(v)
                                            else v) for k, v in sc.items()},
        "mass_homogeneity": same,
        "f_by_run": _f_by_run(series),
    }
    return Section(
        key="amount", title="Amount dependency (Paper C)", paragraphs=paragraphs, figures=figs,
        tables=[Table("crossings", table, "Threshold crossing per product", show,
                      allow_missing=num_optional),
                Table("series", series, "Amount series (one HPT run per row)", series_show,
                      allow_missing=("temperature_C", "density_kg_m3", "mass_mg"))],
        summary=summary, notes=notes)


#: the most products in one panel of the amount figure (more: facets of this many)
PER_PANEL = 7
#: the most panels in one amount figure: more products go on to further figures
#: (``amount_applied_2``, ...), each a page of at most 6 panels (about 2040 x 2400 pixels,
#: 18 MB of canvas where the worker drawing it holds it; 12 panels were 2040 x 4650 pixels
#: and 36 MB, one figure of 256 products 2040 x 18192 pixels and 150 MB)
PANELS_PER_FIGURE = 6


def _panels(series: Any, fits: list[CrossingFit], mass: bool) -> list[tuple[str, list[CrossingFit]]]:
    """The amount figure's panels: ``(unit, products)``, at most :data:`PER_PANEL` each,
    the products of each unit in order."""
    from torlab.reports.plotting import unit

    shown = [cf for cf in fits if len(series[series["product"] == cf.product])
             and math.isfinite(mass_factor(series, cf.product) if mass else 1.0)]
    by_unit: dict[str, list[CrossingFit]] = {}
    for cf in shown:
        by_unit.setdefault("mg" if mass else unit(cf.unit), []).append(cf)
    return [(u, group[i:i + PER_PANEL]) for u, group in by_unit.items()
            for i in range(0, len(group), PER_PANEL)]


def _pages(name: str, series: Any, fits: list[CrossingFit], cfg: Any, mass: bool,
           caption: str) -> list[Figure]:
    """The amount figure(s) of one basis, declared: ``name``, then ``name_2`` ... for every
    :data:`PANELS_PER_FIGURE` panels, each drawn from its own products' rows."""
    panels = _panels(series, fits, mass)
    if len(panels) <= PANELS_PER_FIGURE:
        return [Figure(name, plot(amount_figure, series, fits, cfg, mass=mass), caption)]
    pages = [panels[i:i + PANELS_PER_FIGURE] for i in range(0, len(panels), PANELS_PER_FIGURE)]
    out = []
    for k, page in enumerate(pages):
        mine = {cf.product for _, group in page for cf in group}
        out.append(Figure(
            name if k == 0 else f"{name}_{k + 1}",
            plot(amount_figure, series[series["product"].isin(mine)],
                 [cf for cf in fits if cf.product in mine], cfg, mass=mass,
                 page=(k + 1, len(pages))),
            caption + ("" if k == 0 else f" (continued, figure {k + 1} of {len(pages)})")))
    return out


def amount_figure(series: Any, fits: list[CrossingFit], cfg: Any, *, mass: bool,
                  page: tuple[int, int] | None = None) -> Any:
    """Friction f against the applied amount (or mass) per product (:class:`Plot` function).

    Measured f with error bars (the standard deviation of f over the reduction's
    window), the fitted logistic with its 95 % band, the optimal band and the threshold;
    below, a strip with each product's crossing of the threshold and its interval, one
    row per product (the crossings lie close together: drawn on the threshold line they
    overlapped).  One unit per axis: products applied in different units (µL of a
    liquid, mg of a solid) are drawn in panels side by side, and more than
    :data:`PER_PANEL` products in facets of that many; ``page``: this figure is page
    ``(k, n)`` of the products' figures (:data:`PANELS_PER_FIGURE` panels each).
    """
    from torlab.reports.plotting import facet_legend, facets, figure_legend, legend

    panels = _panels(series, fits, mass) or [("mg" if mass else "–", [])]
    shown = [cf for _, group in panels for cf in group]
    title = ("Friction against applied mass" if mass else
             "Friction against applied amount") + f" at {cfg.temperature:g} °C" + (
        f" (figure {page[0]} of {page[1]})" if page is not None else "")
    strip = [0.3 + 0.19 * len(g) for _, g in panels]
    if len(panels) == 1:
        # room on the left for the strip's product names (8-pt labels, about 0.065 in a
        # character) and the axis labels
        name = max((len(_strip_name(cf)) + 4 for cf in panels[0][1]), default=8)
        fig, (ax, st) = subplots(2, 1, sharex=True, figsize=(7.0, 3.9 + strip[0]),
                                 height_ratios=[3.4, strip[0]],
                                 left=max(0.78, 0.3 + 0.065 * name))
        _amount_panel(ax, st, series, panels[0][1], cfg, mass, panels[0][0], fits)
        legend(ax)
        ax.set_title(title)
        return fig
    one = len(shown) <= PER_PANEL  # few products: one legend for the figure
    fig, axes = facets(len(panels), ncols=2, panel=(3.6, 2.6), strips=strip,
                       shared_legend=one)
    for k, ((u, group), (ax, st)) in enumerate(zip(panels, axes, strict=True)):
        _amount_panel(ax, st, series, group, cfg, mass, u, fits,
                      marks=not one or k == len(panels) - 1)
        if not one:
            facet_legend(ax)
        k = sum(1 for (v, _), _a in zip(panels, axes, strict=True) if v == u)
        ax.set_title(f"products applied in {u}" + (
            f": {group[0].product} … {group[-1].product}" if k > 1 else ""), fontsize=9)
    if one:
        figure_legend(fig, [a[0] for a in axes])
    fig.suptitle(title)
    return fig


def _strip_name(cf: CrossingFit) -> str:
    """A product's row in the strip of crossings."""
    return cf.product if math.isfinite(cf.crossing) else f"{cf.product}: no crossing"


def _amount_panel(ax: Any, st: Any, series: Any, group: list[CrossingFit], cfg: Any,
                  mass: bool, unit_: str, fits: list[CrossingFit], marks: bool = True) -> None:
    """One panel of the amount figure (``ax``) and its strip of crossings (``st``);
    ``marks``: the legend entries of the fitted curve and the crossing."""
    from torlab.reports.plotting import (
        axis_label,
        band,
        cap,
        colours,
        plain_log_ticks,
        points,
    )

    lo_b, hi_b = cfg.band
    thr = cfg.threshold
    ax.axhspan(lo_b, hi_b, color="#d9ead3", alpha=0.6, lw=0,
               label=f"optimal band {lo_b:g}–{hi_b:g}")
    ax.axhline(thr, color="#7f7f7f", ls="--", lw=1.0, label=f"low-friction threshold {thr:g}")
    col = colours(cf.product for cf in fits)  # the same colour in every panel and figure
    xs_all, rows = [], []
    for cf in group:
        g = series[series["product"] == cf.product].sort_values("applied_amount")
        mf = mass_factor(series, cf.product) if mass else 1.0
        a = g["applied_amount"].to_numpy(dtype=float)
        xs_all.append(a * mf)
        color = col[cf.product]
        points(ax, a * mf, g["f"].to_numpy(dtype=float), g["f_sd"].to_numpy(dtype=float),
               color=color, label=cf.product, filled=True, ms=3.5)
        if cf.params and cf.method == "logistic":
            xs = np.geomspace(a.min(), a.max(), 100)
            ax.plot(xs * mf, logistic(np.log(xs), **cf.params), color=color, lw=1.3)
            b = logistic_band(np.log(xs), cf)
            if b is not None:
                band(ax, xs * mf, b[0], b[1], color=color)
        else:
            ax.plot(a * mf, g["f"], color=color, lw=0.8, alpha=0.6)
        rows.append((cf, mf, color))
    ax.set_xscale("log")
    if xs_all:
        plain_log_ticks(ax.xaxis, np.concatenate(xs_all))
    ax.set_ylabel(axis_label("friction coefficient", "f"))
    ax.set_ylim(bottom=0)
    if marks:
        ax.plot([], [], "-", color="0.3", lw=1.3, label="fitted logistic (95 % band shaded)"
                if cfg.curve == "logistic" else "interpolation")
    # the strip: each product's crossing of the threshold on a row of its own
    names = []
    for k, (cf, mf, color) in enumerate(rows):
        names.append(_strip_name(cf))
        if not math.isfinite(cf.crossing):
            continue
        lo = cf.crossing - cf.crossing_low if math.isfinite(cf.crossing_low) else 0.0
        hi = cf.crossing_high - cf.crossing if math.isfinite(cf.crossing_high) else 0.0
        st.errorbar([cf.crossing * mf], [k], xerr=[[lo * mf], [hi * mf]], fmt="D", ms=5,
                    color=color, mfc="white", capsize=cap(5), elinewidth=1.0)
    st.set_yticks(range(len(names)), names)
    st.set_ylim(len(names) - 0.4, -0.6)
    st.grid(False, axis="y")
    st.tick_params(axis="y", length=0)
    if marks:
        ax.errorbar([], [], xerr=[], fmt="D", ms=5, color="0.3", mfc="white", capsize=cap(5),
                    label=f"crossing of f = {thr:g} (strip below"
                    + (f"; {100 * cfg.confidence:g} % interval)" if cfg.curve == "logistic"
                       else ")"))
    st.set_xlabel(axis_label("applied mass", "m", "mg") if mass or unit_ == "mg"
                  else axis_label("applied volume", "V", unit_))
