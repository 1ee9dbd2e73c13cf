"""Figures a tribologist would publish: units on every axis, µL, titles in words, error bars
where the data have a spread, the 95 % band on every predicted curve, distinct colours and
a legend that leaves the data alone; drawn without pyplot; cached by what they show."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from figure_checks import figure_problems

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
HPT = ROOT / "sample_data" / "hpt"

_UNIT = re.compile(r"\((?:[^()]|\([^()]*\))+\)$")  # "... (unit)" at the end, e.g. (W/(m K))
_MICROLITRE_WRONG = re.compile(r"\d\s*[uμ][lL]\b|\bu[lL]\b")
_INTERNAL = re.compile(r"\b[a-z]+_[a-z_]+\b")  # snake_case words: layer_hpt, amount_crossing


def _texts(fig):
    out = [t.get_text() for t in fig.texts]
    for ax in fig.axes:
        out += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel()]
        lg = ax.get_legend()
        if lg is not None:
            out += [t.get_text() for t in lg.get_texts()]
    if getattr(fig, "_suptitle", None) is not None:
        out.append(fig._suptitle.get_text())
    return [t for t in out if t]


def assert_publishable(fig, *, file_names=()):
    """Every axis with data labelled with a unit; no 'uL'; titles in words; the legend
    outside the plotting area (or inside at a fixed corner) and inside the figure."""
    axes = [ax for ax in fig.axes if ax.has_data()]
    assert axes
    for ax in axes:
        assert _UNIT.search(ax.get_ylabel().strip()), ax.get_ylabel()
        # an x axis shared by stacked panels is labelled once, on one of them
        shared = ax.get_shared_x_axes().get_siblings(ax)
        label = ax.get_xlabel() or next((a.get_xlabel() for a in shared if a.get_xlabel()), "")
        assert _UNIT.search(label.strip()), label
    for t in _texts(fig):
        clean = t
        for f in file_names:
            clean = clean.replace(f, "")
        assert not _MICROLITRE_WRONG.search(clean), t
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    if getattr(fig, "_suptitle", None) is not None:
        titles.append(fig._suptitle.get_text())
    assert titles, "no title"
    for t in titles:
        head = t.split("\n")[0].split(":")[0]  # the words before a source or file name
        assert not _INTERNAL.search(head), t
    r = fig.canvas.get_renderer()
    fw = fig.bbox.width
    for ax in fig.axes:
        lg = ax.get_legend()
        if lg is None:
            continue
        lb, ab = lg.get_window_extent(r), ax.get_window_extent(r)
        assert lb.x1 <= fw + 1, "legend cut off"
        if getattr(lg, "_torlab_outside", False):
            assert lb.x0 >= ab.x1, "legend over the data"
    assert figure_problems(fig, file_names=tuple(file_names)) == []


def _draw(p):
    from torlab.reports.render import render

    fig = p.draw()
    assert render(fig, "png")[:8] == b"\x89PNG\r\n\x1a\n"
    return fig


def _bands(ax):
    from matplotlib.collections import PolyCollection

    return [c for c in ax.collections if isinstance(c, PolyCollection)]  # fill_between


def _errorbars(ax):
    from matplotlib.container import ErrorbarContainer

    return [c for c in ax.containers if isinstance(c, ErrorbarContainer)
            and c.has_yerr and len(c.lines[2]) and len(c.lines[2][0].get_segments())]


# ------------------------------------------------------------------------------ predictions
def _banded_table():
    from torlab.model.predict import predict_traction
    from torlab.scene import load_scene

    sc = load_scene(SCENE)
    p = predict_traction(sc, np.linspace(0, 0.05, 41))
    t = p.table.copy()
    t["mu_low95"], t["mu_high95"] = 0.95 * t["mu"], 1.05 * t["mu"]
    return sc, t


def test_traction_figure_has_band_units_limits_and_measured_error_bars():
    from torlab.reports.predict import traction_figure
    from torlab.reports.render import plot

    sc, t = _banded_table()
    meas = ("measured 5 uL", np.array([0.01, 0.02]), np.array([0.3, 0.4]),
            np.array([0.01, 0.02]))
    fig = _draw(plot(traction_figure, [("product A", t), ("product B", t.assign(mu=t["mu"] * 0.8))],
                     boundary=sc.boundary, title="Traction: wheel-rail", measured=[meas]))
    assert_publishable(fig)
    (ax,) = fig.axes
    assert len(_bands(ax)) == 2                      # one band per predicted curve
    assert len(_errorbars(ax)) == 1                  # the measured points' spread
    lines = [ln for ln in ax.lines if ln.get_label() in ("product A", "product B")]
    assert len({ln.get_color() for ln in lines}) == 2  # distinct colours
    assert any("5 µL" in t.get_text() for t in ax.get_legend().get_texts())


def test_stribeck_figure_bands_and_units():
    from torlab.model.predict import predict_stribeck
    from torlab.reports.predict import stribeck_figure
    from torlab.reports.render import plot
    from torlab.scene import load_scene

    sc = load_scene(ROOT / "protocols" / "scenes" / "optical_paper_a_rough.yaml")
    t = predict_stribeck(sc, np.geomspace(0.01, 2, 20), 0.05).table
    t["mu_low95"], t["mu_high95"] = 0.9 * t["mu"], 1.1 * t["mu"]
    t["film_thickness_low95_m"] = 0.9 * t["film_thickness_m"]
    t["film_thickness_high95_m"] = 1.1 * t["film_thickness_m"]
    meas = [("measured", np.array([0.1, 0.5]), np.array([0.08, 0.05]), np.array([0.004, 0.003]))]
    fig = _draw(plot(stribeck_figure, t, title="Stribeck curve: rough ball", creepage=0.05,
                     measured=meas))
    assert_publishable(fig)
    assert _bands(fig.axes[0]) and _bands(fig.axes[1])
    assert _errorbars(fig.axes[0])


def test_prediction_figures_accept_plain_columns():
    """The CLI passes the columns without pandas (--no-plot's path draws from the same)."""
    from torlab.model.predict import predict_traction
    from torlab.reports.predict import traction_figure
    from torlab.reports.render import plot
    from torlab.scene import load_scene

    sc = load_scene(SCENE)
    cols = predict_traction(sc, np.linspace(0, 0.05, 21), as_frame=False).table
    assert isinstance(cols, dict) and "pandas" not in type(cols["mu"]).__module__
    assert_publishable(_draw(plot(traction_figure, [("wheel-rail", cols)], boundary=sc.boundary,
                                  title="Traction: wheel-rail")))


# ------------------------------------------------------------------------------ reports
@pytest.fixture(scope="module")
def amount_inputs():
    from torlab.fit.crossing import amount_series, fit_crossings
    from torlab.parsers.hpt import read_hpt
    from torlab.protocols.schema import AmountReport
    from torlab.reduce.hpt import reduce_hpt

    files = sorted(HPT.glob("hpt_OFM[12]_*uL_25C.txt")) + sorted(HPT.glob("hpt_SFM_*mg_25C.txt"))
    res = [reduce_hpt(*read_hpt(f)) for f in files]
    cfg = AmountReport()
    series = amount_series(res, {}, temperature=25.0, temperature_tolerance=2.0)
    fits = fit_crossings(series, threshold=cfg.threshold, band=tuple(cfg.band))
    return series, fits, cfg


def test_amount_figure_error_bars_band_colours_and_one_unit_per_axis(amount_inputs):
    """Liquids (µL) and the solid (mg) in panels of their own, each axis in one unit; every
    product's f with its sd, the fitted curves' bands, distinct colours, plain amounts; each
    crossing on its own row of the strip below, with its interval (drawn on the threshold
    line the crossings lay on top of each other)."""
    from matplotlib.container import ErrorbarContainer

    from torlab.reports.amount import amount_figure
    from torlab.reports.plotting import finish
    from torlab.reports.render import plot

    series, fits, cfg = amount_inputs
    fig = _draw(plot(amount_figure, series, fits, cfg, mass=False))
    assert figure_problems(fig) == []
    panels = [ax for ax in fig.axes if ax.get_ylabel().startswith("friction")]
    strips = [ax for ax in fig.axes if ax not in panels and ax.get_visible()]
    assert len(panels) == 2 and len(strips) == 2
    assert [s.get_xlabel() for s in strips] == ["applied volume V (µL)", "applied mass m (mg)"]
    bars = [c for ax in panels for c in _errorbars(ax)]
    assert len(bars) >= 3                              # every product's measured f with its sd
    assert sum(len(_bands(ax)) for ax in panels) == sum(cf.cov is not None for cf in fits)
    colours = {c.lines[0].get_color() for c in bars}
    assert len(colours) == len(fits)
    ticks = [t.get_text() for t in strips[0].get_xticklabels()]
    assert "16" in ticks and "1" in ticks             # plain amounts, not 10^0, 10^1
    # the strip: one row per product, a crossing where the product crosses, at its value
    crossing = {cf.product: cf for cf in fits}
    for st in strips:
        rows = [t.get_text() for t in st.get_yticklabels()]
        marks = [c for c in st.containers if isinstance(c, ErrorbarContainer)]
        crossed = [r for r in rows if not r.endswith("no crossing")]
        assert len(marks) == len(crossed) >= 1
        for c in marks:
            y = round(float(c.lines[0].get_ydata()[0]))
            assert c.lines[0].get_xdata()[0] == pytest.approx(crossing[rows[y]].crossing)
    # the mass figure: one panel (every product in mg)
    fig = finish(plot(amount_figure, series, fits, cfg, mass=True).draw())
    assert figure_problems(fig) == []
    assert [ax.get_xlabel() for ax in fig.axes if ax.get_xlabel()] == ["applied mass m (mg)"]


def test_amount_mass_figure_of_products_of_other_densities_has_ticks_apart(amount_inputs):
    """Against the applied mass, the liquids of a panel (OFM1 and OFM2, of other densities)
    have their amounts at nearby masses: the axis is ticked at one product's masses, not
    at both (their labels printed over each other), and the figure has no overlapping
    texts."""
    import numpy as np

    from torlab.reports.amount import amount_figure
    from torlab.reports.render import plot

    series, fits, cfg = amount_inputs
    liquids = series[series["amount_kind"] == "volume"]
    masses = np.unique(liquids["mass_mg"].to_numpy(float))
    assert liquids["density_kg_m3"].nunique() > 1 and np.min(np.diff(np.log(masses))) < 0.05
    assert masses.size <= 12  # few enough to be ticked at their values
    mine = set(liquids["product"])
    fig = _draw(plot(amount_figure, liquids, [cf for cf in fits if cf.product in mine], cfg,
                     mass=True))
    assert figure_problems(fig) == []
    drawn = 0
    for ax in fig.axes:
        if ax.get_xscale() != "log" or not ax.has_data():
            continue
        lo, hi = ax.get_xlim()
        ticks = np.asarray(ax.xaxis.get_major_locator()(), float)
        ticks = ticks[(ticks >= lo) & (ticks <= hi)]
        assert ticks.size > 1 and np.all(np.diff(np.log(ticks)) >= np.log(hi / lo) / 13)
        drawn += bool(np.isin(np.round(ticks, 9), np.round(masses, 9)).sum() >= 2)
    assert drawn  # the liquids' panel, ticked at masses of theirs


def test_fit_figure_titles_in_words():
    from torlab.fit.layer import fit_layer_hpt
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import reduce_hpt
    from torlab.reports.fit import fit_figure
    from torlab.reports.render import plot

    f = HPT / "hpt_OFM1_4uL_25C.txt"
    res = fit_layer_hpt([reduce_hpt(*read_hpt(f))])
    fig = _draw(plot(fit_figure, res))
    assert_publishable(fig, file_names=(f.name,))
    assert fig.axes[0].get_title().startswith("Third-body layer from HPT tests")


def test_fit_figure_title_of_runs_with_long_file_names_stays_on_the_figure():
    """A layer fitted to four runs of a campaign (``hpt_s01_WFM-dry_4uL_25C_run4.txt`` ...)
    has a title wider than its figure: it is broken at spaces into lines that fit (it ran
    off the left edge), and drawn into a kept figure it is the same picture."""
    import dataclasses

    from torlab.fit.layer import fit_layer_hpt
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import reduce_hpt
    from torlab.reports.fit import fit_figure
    from torlab.reports.render import draw_task, plot

    f = HPT / "hpt_OFM1_4uL_25C.txt"
    res = fit_layer_hpt([reduce_hpt(*read_hpt(f))])
    names = [f"hpt_s01_WFM-dry_4uL_25C{s}.txt" for s in ("", "_run2", "_run3", "_run4")]
    long = dataclasses.replace(res, meta={**res.meta, "source": ", ".join(names)})
    fig = _draw(plot(fit_figure, long))
    title = fig.axes[0].get_title()
    assert title.startswith("Third-body layer from HPT tests") and title.count("\n") >= 2
    assert names[0] in title.replace("\n", " ") and names[-1] in title.replace("\n", " ")
    assert figure_problems(fig, file_names=tuple(names)) == []
    fig = _draw(plot(fit_figure, res))  # a short title: one line and the numbers
    assert fig.axes[0].get_title().count("\n") == 1
    new = draw_task((plot(fit_figure, long), ("png",), None))
    assert draw_task((plot(fit_figure, long), ("png",), None)) == new  # kept figure: same


# ------------------------------------------------------------------------------ machinery
def test_pretty_writes_microlitres_and_leaves_file_names():
    from torlab.reports.plotting import pretty, unit

    assert pretty("base medium 5 uL") == "base medium 5 µL"
    assert pretty("TOR A 20ul") == "TOR A 20µL"
    assert pretty("hpt_OFM1_4uL_25C.txt") == "hpt_OFM1_4uL_25C.txt"
    assert unit("uL") == unit("ul") == "µL" and unit("um") == "µm" and unit("mg") == "mg"


def test_formats_and_reproducible_bytes(tmp_path):
    from torlab.reports.predict import traction_figure
    from torlab.reports.render import parse_formats, plot, render_figures

    _, t = _banded_table()
    p = plot(traction_figure, [("a", t)], title="Traction")
    a, st = render_figures([("x", p)], parse_formats("png,svg,pdf"))
    b, _ = render_figures([("x", p)], ("png", "svg", "pdf"))
    assert st.drawn == 1
    assert a["x"]["svg"] == b["x"]["svg"] and a["x"]["pdf"] == b["x"]["pdf"]  # reproducible
    assert a["x"]["png"] == b["x"]["png"]
    assert a["x"]["pdf"][:5] == b"%PDF-" and b"<svg" in a["x"]["svg"][:400]
    from torlab.errors import TorlabInputError

    with pytest.raises(TorlabInputError, match="jpeg"):
        parse_formats("png, jpeg")


def test_figure_key_follows_the_data_not_the_object():
    from torlab.reports.predict import traction_figure
    from torlab.reports.render import figure_key, plot

    _, t = _banded_table()
    k1 = figure_key(plot(traction_figure, [("a", t)], title="T"), "png")
    k2 = figure_key(plot(traction_figure, [("a", t.copy())], title="T"), "png")
    assert k1 == k2 and len(k1) == 40
    t2 = t.copy()
    t2.loc[3, "mu"] += 1e-12                          # any change of a plotted number
    assert figure_key(plot(traction_figure, [("a", t2)], title="T"), "png") != k1
    assert figure_key(plot(traction_figure, [("a", t)], title="T2"), "png") != k1
    assert figure_key(plot(traction_figure, [("a", t)], title="T"), "svg") != k1


def test_figures_need_no_pyplot():
    code = ("import sys, numpy as np\n"
            "from torlab.reports.plotting import subplots\n"
            "from torlab.reports.render import render\n"
            "fig, ax = subplots(); ax.plot([0, 1], [0, 1]); ax.set_title('t')\n"
            "assert render(fig, 'png')[:4] == b'\\x89PNG'\n"
            "print('matplotlib.pyplot' in sys.modules)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip() == "False"


def test_reduction_figures_declared_and_drawn():
    """Instrument figures are declared plots; Reduction.figures() still gives drawn figures."""
    from torlab.api import reduce_file
    from torlab.reports.render import Plot

    red = reduce_file(ROOT / "sample_data" / "optical" / "stribeck_rough.csv")
    plots = red.plots()
    assert plots and all(isinstance(p, Plot) for p in plots.values())
    figs = red.figures()
    assert set(figs) == set(plots)
    for fig in figs.values():
        assert_publishable(fig, file_names=("stribeck_rough.csv",))
        assert _errorbars(fig.axes[0])     # each point's spread over its averaging window
    pd.testing.assert_index_equal(pd.Index(sorted(figs)), pd.Index(sorted(plots)))


# ------------------------------------------------------------------------------ the checks
def test_figure_checks_find_each_defect():
    """tests/figure_checks.py finds each defect it names in a figure made to have them, and
    none in the same figure made right."""
    from torlab.reports.plotting import band, finish, legend, subplots

    def make(bad):
        fig, ax = subplots()
        x = np.linspace(1, 16, 20)
        ax.plot(x, 0.3 - 0.01 * x, label="OFM1")
        ax.plot(x, 0.25 - 0.01 * x, label="OFM1" if bad else "OFM2")
        ax.errorbar([4.0], [0.2], yerr=[0.01], fmt="o", ms=6, capsize=2 if bad else 4,
                    label="measured")
        if bad:  # a pale colour at low opacity
            ax.fill_between(x, 0.1, 0.12, color="#F0E442", alpha=0.12, lw=0)
        else:  # torlab's band: made dark enough (band_style)
            band(ax, x, 0.1, 0.12, color="#F0E442")
        ax.set_xlabel("applied amount (mg or µL)" if bad else "applied volume V (µL)")
        ax.set_ylabel("friction coefficient f (–)")
        ax.set_title("Layer: mu_c1 = 0.15, μc1,T = −5×10⁻⁴" if bad else
                     "Layer: μc1 = 0.15, μc1,T = −5×10⁻⁴ 1/K")
        if bad:
            ax.text(8.0, 0.22, "an annotation on the data")
            fig.text(0.5, 1.05, "a text above the figure")
        legend(ax)
        return finish(fig)

    found = "\n".join(figure_problems(make(True)))
    for what in ("legend repeats ['OFM1']", "caps of 'measured'", "nearly invisible",
                 "more than one unit (mg or µL)", "parameter names ['mu_c1']",
                 "μc1,T has no unit", "lies on the line", "runs off the figure"):
        assert what in found, what
    assert figure_problems(make(False)) == []


def test_parameter_text_symbols_and_units():
    """Figures write the thesis's symbols with units, from the layer laws' registry and the
    fits' unit table: μc1 (not mu_c1), Lμe in µm, the temperature coefficients in 1/K."""
    from torlab.reports.plotting import number, param_label, param_text

    assert param_text("mu_c1", 0.14622) == "μc1 = 0.1462"
    assert param_text("L_mue", 8.31e-6) == "Lμe = 8.31 µm"
    assert param_text("mu_c2_T", -3.944e-4) == "μc2,T = −3.944×10⁻⁴ 1/K"
    assert param_text("mu_c1_Tref", 0.1469) == "μc1(T_ref) = 0.1469"
    assert param_text("alpha", 1.9e-8, si="1/Pa") == "α = 19 1/GPa"
    assert param_text("k1", 9.83e-7, 3, si="m^2/J") == "k1 = 9.83×10⁻⁷ m²/J"
    assert param_label("L_mup") == "Lμp (µm)" and param_label("mu_c2") == "μc2 (–)"
    assert number(-0.002525) == "−0.002525" and number(123456.0, 3) == "1.23×10⁵"


def test_time_test_figure_marks_in_the_legend_with_intervals():
    """The time test's marks are explained in the legend (the key written over the plotting
    area lay on the trace) and carry the 95 % intervals of the evidence."""
    from torlab.api import reduce_file
    from torlab.reports.mtm import time_test_figure
    from torlab.reports.render import plot

    red = reduce_file(ROOT / "sample_data" / "mtm" / "mtm_TOR-A_5uL.txt")
    d = red.detail
    ev = {t.step: {"minimum_low95": t.minimum - 0.005, "minimum_high95": t.minimum + 0.007,
                   "recovery_time_low95": t.recovery_time_s - 20.0,
                   "recovery_time_high95": t.recovery_time_s + 30.0,
                   "mean_after_recovery_low95": t.mean_after_recovery - 0.003,
                   "mean_after_recovery_high95": t.mean_after_recovery + 0.003}
          for t in d.time_tests}
    fig = _draw(plot(time_test_figure, d, d.time_tests, ev))
    assert_publishable(fig, file_names=(d.label,))
    (ax,) = fig.axes
    assert not ax.texts
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "minimum (95 % interval)" in labels and "recovery (95 % interval)" in labels
    t = d.time_tests[0]
    (bar,) = [c for c in ax.containers if len(c.lines[0].get_xdata())
              and c.lines[0].get_marker() == "o"]
    seg = bar.lines[2][0].get_segments()[0]
    assert seg[0][1] == pytest.approx(ev[t.step]["minimum_low95"])
    assert seg[1][1] == pytest.approx(ev[t.step]["minimum_high95"])


@pytest.mark.parametrize("n", [15, pytest.param(96, marks=pytest.mark.slow)])  # 96: 14 facets
def test_traction_figure_of_a_large_campaign_in_facets(n):
    """Many curves: facets of at most PER_PANEL curves, each with its own legend and colours,
    every entry inside the figure (one legend of 96 was cut off after 24)."""
    from types import SimpleNamespace

    from torlab.reports.render import plot
    from torlab.reports.traction import PER_PANEL, TractionCurve, traction_report_figure

    x = np.linspace(0, 0.05, 11)
    curves = [TractionCurve(f"product {k} (Tab. 5.4)", "measured",
                            pd.DataFrame({"creepage": x, "mu": 0.3 * np.tanh(80 * x) * (1 + k / 200),
                                          "mu_sd": np.full(x.size, 0.004)}), {}, "file")
              for k in range(n)]
    fig = _draw(plot(traction_report_figure, curves, SimpleNamespace(band=(0.15, 0.25))))
    assert figure_problems(fig) == []
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == -(-n // PER_PANEL)
    shown = [t.get_text() for lg in legends for t in lg.get_texts()]
    assert sorted(x for x in shown if x.startswith("product")) == sorted(c.label for c in curves)


def test_a_large_campaigns_traction_figures_come_in_pages():
    """More curves than PANELS_PER_FIGURE panels of PER_PANEL hold: further figures
    (traction_2, ...), every curve on exactly one, each page titled with its curves; up to
    that many, one figure named traction as before."""
    from types import SimpleNamespace

    from torlab.reports.traction import (
        PANELS_PER_FIGURE,
        PER_PANEL,
        TractionCurve,
        traction_figures,
    )

    x = np.linspace(0, 0.05, 11)
    per = PER_PANEL * PANELS_PER_FIGURE

    def curves(n):
        return [TractionCurve(f"product {k}", "measured",
                              pd.DataFrame({"creepage": x, "mu": 0.3 * np.tanh(80 * x),
                                            "mu_sd": np.full(x.size, 0.004)}), {}, "file")
                for k in range(n)]

    cfg = SimpleNamespace(band=(0.15, 0.25))
    assert [n for n, _ in traction_figures(curves(per), cfg)] == ["traction"]
    cs = curves(2 * per + 9)
    figs = traction_figures(cs, cfg)
    assert [n for n, _ in figs] == ["traction", "traction_2", "traction_3"]
    on = [c.label for _, p in figs for c in p.args[0]]
    assert sorted(on) == sorted(c.label for c in cs) and len(on) == len(cs)
    fig = _draw(figs[2][1])  # the last page: 9 curves in two panels
    assert figure_problems(fig) == []
    assert "curves 197–205 of 205 (figure 3 of 3)" in fig._suptitle.get_text()
    titles = [ax.get_title() for ax in fig.axes if ax.get_title()]
    assert titles == ["curves 197–203 of 205", "curves 204–205 of 205"]


def test_the_traction_figure_keeps_only_what_it_draws_and_draws_the_same():
    """A declared traction figure (kept until the run's figures are written) holds each
    curve's label, kind, group and drawn columns only -- not its trend, band summary,
    theory or other columns -- and its pixels are those of the figure of the whole curves."""
    from types import SimpleNamespace

    from torlab.reports.render import plot, render
    from torlab.reports.traction import (
        DRAWN_COLUMNS,
        TractionCurve,
        traction_figures,
        traction_report_figure,
    )

    x = np.linspace(0.0, 0.05, 21)
    mu = 0.3 * np.tanh(80 * x)
    model = pd.DataFrame({"creepage": x, "mu": mu, "mu_low95": 0.95 * mu, "mu_high95": 1.05 * mu,
                          "mu_theory_error_95": 1e-4, "max_temperature_C": 40.0})
    measured = pd.DataFrame({"creepage": x[::3], "mu": 0.9 * mu[::3], "mu_sd": 0.004,
                             "speed_m_s": 0.5})
    big = {"dominant": {"mu": [{"parameter": "mu_c2", "share": 0.7}]}, "method": "sampled"}
    curves = [TractionCurve(f"set {k}", "model", model, {"trend": "neutral", "probabilities": {}},
                            "scene", band=big, group=f"g{k}", theory={"method": "fastsim"},
                            choices=["law"], boundary={"mu_c1": 0.2}) for k in range(3)]
    curves.append(TractionCurve("measured", "measured", measured, {"trend": "neutral"}, "file"))
    cfg = SimpleNamespace(band=(0.15, 0.25))
    [(name, kept)] = traction_figures(curves, cfg)
    assert name == "traction"
    for c, k in zip(curves, kept.args[0], strict=True):
        assert (k.label, k.kind, k.group) == (c.label, c.kind, c.group)
        assert list(k.table.columns) == [n for n in DRAWN_COLUMNS if n in c.table]
        assert not np.shares_memory(k.table["mu"].to_numpy(), c.table["mu"].to_numpy())
        assert not (k.trend or k.band or k.theory or k.choices or k.boundary)
    whole = plot(traction_report_figure, curves, cfg)
    assert render(kept.draw(), "png") == render(whole.draw(), "png")


def test_a_large_campaigns_amount_figures_come_in_pages(amount_inputs):
    """More products than PANELS_PER_FIGURE panels hold: amount_applied, amount_applied_2,
    ... each drawn from its own products' rows, every product on exactly one page."""
    import dataclasses

    from torlab.reports.amount import PANELS_PER_FIGURE, PER_PANEL, _pages

    series, fits, cfg = amount_inputs
    copies = -(-(PANELS_PER_FIGURE * PER_PANEL + 1) // len(fits))
    k_series, k_fits = [], []
    for k in range(copies):
        k_series.append(series.assign(product=series["product"] + f"-{k + 1}"))
        k_fits += [dataclasses.replace(cf, product=f"{cf.product}-{k + 1}") for cf in fits]
    many = pd.concat(k_series, ignore_index=True)
    assert len(_pages("amount_applied", series, fits, cfg, False, "c")) == 1
    figs = _pages("amount_applied", many, k_fits, cfg, False, "caption")
    assert [f.name for f in figs][:2] == ["amount_applied", "amount_applied_2"]
    on = [cf.product for f in figs for cf in f.fig.args[1]]
    assert sorted(on) == sorted(cf.product for cf in k_fits)
    for f in figs:
        rows = f.fig.args[0]
        assert set(rows["product"]) == {cf.product for cf in f.fig.args[1]}
    fig = _draw(figs[-1].fig)
    assert figure_problems(fig) == []
    assert f"(figure {len(figs)} of {len(figs)})" in fig._suptitle.get_text() + " ".join(
        ax.get_title() for ax in fig.axes)
