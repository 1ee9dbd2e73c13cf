"""Comparison report: differences (or ratios) with their intervals, P(A better), rankings.

The statistics are :mod:`torlab.comparison`'s; this draws and writes them: one panel per
quantity with every pair's difference (or ratio) and its 95 % interval against a line at
no difference (0, or 1 for a ratio), the symbol and unit on the axis; tables of the
comparisons, the items' values and the rankings; a report section for protocols.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["compare_figure", "compare_section", "compare_tables", "verdict_text",
           "write_compare"]


def _axis(quantity: str, kind: str) -> tuple[str, float, bool]:
    """Axis label, display factor and log axis of a quantity's panel."""
    from torlab.comparison import spec
    from torlab.reports.plotting import unit

    sp = spec(quantity)
    if kind == "ratio":
        return f"ratio {sp.label}(A) / {sp.label}(B) (–)", 1.0, True
    u = sp.display_unit
    return f"difference Δ{sp.label} = A − B ({unit(u) if u not in ('', '-') else '–'})", \
        sp.factor, False


def compare_figure(table: Any, title: str = "") -> Any:
    """Every comparison's difference (or ratio) with its 95 % interval, one panel per
    quantity, with the line of no difference; called verdicts filled, undetermined open.

    Parameters
    ----------
    table
        :meth:`torlab.comparison.CompareResult.table`.
    title
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import textwrap

    from torlab.reports.plotting import cap, plain_log_ticks, pretty, subplots

    qs = list(dict.fromkeys(table["quantity"]))
    rows = [table[table["quantity"] == q] for q in qs]
    heights = [max(len(r), 1) * 0.32 + 0.45 for r in rows]
    names = [pretty(f"{a} vs {b}") for a, b in zip(table["a"], table["b"], strict=True)]
    left = min(3.6, 0.35 + 0.068 * max((len(n) for n in names), default=10))
    fig, axes = subplots(len(qs), 1, figsize=(6.6 + left, sum(heights) + 0.75 * len(qs) + 0.4),
                         height_ratios=heights, left=left)
    axes = np.atleast_1d(axes)
    for ax, q, sub in zip(axes, qs, rows, strict=True):
        kind = str(sub["kind"].iloc[0])
        label, f, log = _axis(q, kind)
        y = np.arange(len(sub))[::-1]
        est = sub["estimate"].to_numpy(dtype=float) * (1 if log else f)
        lo = sub["ci95_low"].to_numpy(dtype=float) * (1 if log else f)
        hi = sub["ci95_high"].to_numpy(dtype=float) * (1 if log else f)
        called = np.array([not str(v).startswith("undetermined") for v in sub["verdict"]])
        for yi, e, a, b, c in zip(y, est, lo, hi, called, strict=True):
            col = "#1f4e9c" if c else "#888888"
            ax.errorbar([e], [yi], xerr=[[e - a], [b - e]], fmt="o", ms=5, color=col,
                        mfc=col if c else "white", mew=1.0, elinewidth=1.1, capsize=cap(5))
        ax.axvline(1.0 if log else 0.0, color="#b22222", lw=1.0, ls="--")
        if log:
            ax.set_xscale("log")
        ax.set_yticks(y)
        ax.set_yticklabels([pretty(f"{a} vs {b}") for a, b in zip(sub["a"], sub["b"],
                                                                     strict=True)])
        ax.set_ylim(-0.7, len(sub) - 0.3)
        ax.set_xlabel(textwrap.fill(label, 80))
        lim = np.concatenate([lo, hi, [1.0 if log else 0.0]])
        lim = lim[np.isfinite(lim) & ((lim > 0) if log else True)]
        if lim.size:
            a, b = float(lim.min()), float(lim.max())
            if log:
                pad = (b / a) ** 0.06 if b > a else 1.1
                ax.set_xlim(a / pad, b * pad)
                plain_log_ticks(ax.xaxis, _nice_ratios(a / pad, b * pad))
                from matplotlib.ticker import FormatStrFormatter

                ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
            else:
                pad = 0.06 * (b - a) if b > a else 0.1 * max(abs(a), 1e-12)
                ax.set_xlim(a - pad, b + pad)
    if title:
        fig.suptitle(title)
    return fig


def _nice_ratios(lo: float, hi: float) -> list[float]:
    """A few round ratios between ``lo`` and ``hi`` (1 among them when inside) for a log
    axis."""
    if not hi > lo > 0:
        return [1.0]
    if hi / lo > 30:
        return [10.0 ** k * m for k in range(-6, 7) for m in (1, 2, 5) if lo <= 10.0 ** k * m <= hi]
    for step in (0.01, 0.02, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0):
        v = [round(step * k, 6) for k in range(math.ceil(lo / step), math.floor(hi / step) + 1)]
        if len(v) <= 7:
            return [x for x in v if x > 0]
    return [1.0]


def verdict_text(row: Any) -> str:
    """One comparison in words: the estimate with its interval and the probabilities."""
    from torlab.comparison import spec

    sp = spec(row["quantity"])
    if row["kind"] == "ratio":
        what = (f"{sp.label}: {row['a']} / {row['b']} = {row['estimate']:.4g} "
                f"[{row['ci95_low']:.4g}, {row['ci95_high']:.4g}]")
    else:
        u = sp.display_unit
        f = sp.factor
        what = (f"{sp.label}: {row['a']} − {row['b']} = {row['estimate'] * f:.4g} "
                f"[{row['ci95_low'] * f:.4g}, {row['ci95_high'] * f:.4g}]"
                + (f" {u}" if u not in ("", "-") else ""))
    p = f"P({row['a']} higher) = {row['p_a_higher']:.3f}"
    if row.get("better"):
        p += f", P({row['a']} better; {row['better']} is better) = {row['p_a_better']:.3f}"
    return f"{what}; {p}: {row['verdict']}"


def compare_tables(res: Any) -> dict[str, Any]:
    """The result's tables by name: ``compare``, ``values`` and (more than two items)
    ``ranking``."""
    out = {"compare": res.table(), "values": res.values_table()}
    rk = res.ranking_table()
    if len(rk):
        out["ranking"] = rk
    return out


def write_compare(dest: Any, res: Any, *, title: str = "", formats: Any = None,
                  xlsx: bool = False) -> list[str]:
    """``compare.csv``, ``values.csv``, ``ranking.csv`` (more than two items),
    ``compare.png`` (``formats``) and ``summary.json`` into an OutputDir; with ``xlsx``
    every table in ``tables.xlsx`` too.  Returns the names written."""
    from torlab.reports.render import parse_formats, plot, write_figures

    tabs = compare_tables(res)
    names = []
    for name, tab in tabs.items():
        dest.write_csv(f"{name}.csv", tab, allow_missing=tuple(
            c for c in tab.columns if c not in ("quantity", "a", "b", "item", "label")))
        names.append(f"{name}.csv")
    dest.write_json("summary.json", res.summary())
    names.append("summary.json")
    names += write_figures(dest, [("compare", plot(compare_figure, tabs["compare"],
                                                   title=title))], parse_formats(formats))[0]
    if xlsx:
        dest.write_xlsx("tables.xlsx", tabs)
        names.append("tables.xlsx")
    return names


def compare_section(results: list[tuple[str, Any]]) -> Any:
    """The protocol's ``compare`` section: per comparison asked for, the differences with
    their intervals and probabilities, the rankings, and what the intervals hold."""
    from torlab.comparison import item_to_dict, spec
    from torlab.reports.html import Figure, Section, Table
    from torlab.reports.render import plot

    paragraphs = [
        "Each quantity the items share: the difference A − B (the ratio A / B for a positive "
        "quantity whose scatter is relative) with its 95 % interval (Student t on the "
        "Welch-Satterthwaite degrees of freedom), the probability that A's true value is the "
        "higher (flat prior on the true difference: one minus the one-sided p-value), and "
        "where a direction is stated the probability that A is better; a verdict is called "
        "at the stated probability, else 'undetermined'. Repeated runs of an item are pooled "
        "with random effects first, so their scatter is in its interval; an item measured "
        "once has an interval that holds for that record alone, and a difference to it may "
        "be the scatter between runs. With more than two items, each is ranked with the "
        "probability of every rank (seeded draws of every item's value)."]
    figs, tables, notes = [], [], []
    summary: dict[str, Any] = {"comparisons": {}}
    for name, res in results:
        key = _key(name)
        tab = res.table()
        paragraphs.append(f"**{name}**" + (f" (against {res.reference})" if res.reference
                                           else " (every pair)") + ":")
        paragraphs += [verdict_text(r) for r in tab.to_dict("records")]
        for q, rows in res.rankings.items():
            order = (f"best first: {res.better[q]} is better" if q in res.better
                     else "highest first")
            paragraphs.append(f"Ranking on {spec(q).label} ({order}): " + "; ".join(
                f"{r['label']} (P(rank 1) = {r['p_best']:.2f}, expected rank "
                f"{r['expected_rank']:.2f})" for r in rows))
        notes += [f"{name}: {n}" for n in res.notes]
        figs.append(Figure(f"compare_{key}", plot(compare_figure, tab, title=name),
                           f"{name}: differences (ratios) with their 95 % intervals; filled: "
                           "verdict called"))
        tables.append(Table(f"compare_{key}", tab, f"{name}: comparisons", {
            "quantity": ("symbol", ""), "A": ("a", ""), "B": ("b", ""), "kind": ("kind", ""),
            "estimate": ("estimate", ".4g"), "95 % low": ("ci95_low", ".4g"),
            "95 % high": ("ci95_high", ".4g"), "P(A higher)": ("p_a_higher", ".3f"),
            "P(A better)": ("p_a_better", ".3f"), "verdict": ("verdict", "")},
            allow_missing=("p_a_better", "dof")))
        rk = res.ranking_table()
        if len(rk):
            tables.append(Table(f"ranking_{key}", rk, f"{name}: rankings",
                                allow_missing=tuple(c for c in rk.columns
                                                    if c not in ("quantity", "label"))))
        summary["comparisons"][name] = res.summary()
    summary["items_estimates"] = [item_to_dict(it) for _, r in results for it in r.items]
    return Section(key="compare", title="Comparisons", paragraphs=paragraphs, figures=figs,
                   tables=tables, summary=summary, notes=notes)


def _key(name: str) -> str:
    from torlab.files import safe_name

    k = safe_name(name.lower().replace(" ", "_"))
    return k[:60] or "items"
