"""What makes figures cheaper must not change what they show.

* :func:`torlab.reports.plotting.decimate` (M4): every extreme of every bin and both
  endpoints kept, in order; gaps kept; short lines and loops unchanged; the drawn line
  covers the same pixels, column by column, as the full line.
* The lean matplotlib import of a command draws the same pixels as the full import.
* The style's fixed title height keeps titles above the plotting area.
"""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from torlab.reports.plotting import PALETTE, STYLE, decimate, pixel_columns, subplots

ROOT = Path(__file__).resolve().parents[1]


def _walk(n, seed=0):
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 50.0, n)
    y = np.cumsum(rng.normal(size=n)) + 20 * np.sin(x / 3)
    y[rng.integers(0, n, 5)] += 150.0  # isolated spikes: single-sample extremes
    return x, y


def _bins(x, columns, log_x=False):
    xs = np.log10(x) if log_x else x
    return np.minimum(((xs - xs.min()) / (xs.max() - xs.min()) * columns).astype(int),
                      columns - 1)


def _kept_indices(x, y, xd, yd):
    """Indices of the kept points in the original arrays (kept points are a subsequence)."""
    out, j = [], 0
    for a, b in zip(xd, yd, strict=True):
        while not (x[j] == a and (y[j] == b or (np.isnan(y[j]) and np.isnan(b)))):
            j += 1  # raises IndexError if a kept point is not in the original, in order
        out.append(j)
        j += 1
    return np.array(out)


@pytest.mark.parametrize("log_x", [False, True])
def test_decimate_keeps_every_bins_extremes_and_ends_in_order(log_x):
    x, y = _walk(100_003)
    if log_x:
        x = np.geomspace(0.01, 100.0, x.size)
    columns = 700
    xd, yd = decimate(x, y, columns, log_x=log_x)
    assert 4 * columns >= xd.size > 2 * columns  # thinned, to at most 4 points per bin
    kept = _kept_indices(x, y, xd, yd)
    assert kept[0] == 0 and kept[-1] == x.size - 1  # both endpoints
    assert y.max() in yd and y.min() in yd
    b = _bins(x, columns, log_x)
    for k in range(columns):  # the reference: each bin by itself, with a plain loop
        idx = np.flatnonzero(b == k)
        if idx.size == 0:
            continue
        mine = kept[b[kept] == k]
        assert idx[0] in mine and idx[-1] in mine
        assert y[mine].max() == y[idx].max() and y[mine].min() == y[idx].min()
        assert mine.size <= 4


def test_decimate_leaves_short_lines_and_loops_alone():
    x, y = _walk(2_000)
    xd, yd = decimate(x, y, 500)  # 2000 <= 4 * 500
    np.testing.assert_array_equal(xd, x)
    np.testing.assert_array_equal(yd, y)
    t = np.linspace(0, 20 * np.pi, 50_000)  # a loop: x goes back and forth
    xd, yd = decimate(np.cos(t), np.sin(t), 100)
    np.testing.assert_array_equal(xd, np.cos(t))
    np.testing.assert_array_equal(yd, np.sin(t))
    xd, yd = decimate(x[::-1], y[::-1], 100)  # decreasing x is monotonic: thinned
    assert xd.size < x.size and xd[0] == x[-1] and xd[-1] == x[0]


def test_decimate_keeps_gaps():
    x, y = _walk(60_000, seed=4)
    y[[10, 11, 30_000, 59_998]] = np.nan  # gaps, one of them inside a bin
    xd, yd = decimate(x, y, 300)
    kept = _kept_indices(x, y, xd, yd)
    assert {10, 11, 30_000, 59_998} <= set(kept.tolist())
    # the points next to each gap are kept, so each piece of the line ends where it did
    assert {9, 12, 29_999, 30_001, 59_997, 59_999} <= set(kept.tolist())
    with pytest.raises(ValueError, match="differ in length"):
        decimate(x, y[:-1], 300)


def _ink_extent(png):
    """Per pixel column: the top and bottom row of dark pixels (-1 where none)."""
    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png)).convert("L")).astype(int)
    ink = a < 150
    rows = np.arange(ink.shape[0])[:, None]
    top = np.where(ink, rows, ink.shape[0]).min(axis=0)
    bottom = np.where(ink, rows, -1).max(axis=0)
    return top, bottom


def _within_a_pixel(top_a, bot_a, top_b, bot_b):
    """Whether line a reaches, in every column, no further up or down than line b does in
    that column or a neighbouring one, plus one pixel."""
    def near(v, f):
        p = np.pad(v, 1, mode="edge")
        return f(np.stack([p[:-2], p[1:-1], p[2:]]), axis=0)

    return bool(np.all(top_a >= near(top_b, np.min) - 1)
                and np.all(bot_a <= near(bot_b, np.max) + 1))


def test_decimated_line_covers_the_same_pixels():
    """Drawn at torlab's size and resolution, the decimated line reaches, in every pixel
    column, the same top and bottom pixel as the full line, to within the one pixel
    that antialiasing spreads a sub-pixel spike over (axes hidden so only the line
    is ink)."""
    from torlab.reports.render import render

    x, y = _walk(300_000, seed=7)
    pngs = []
    for thin in (False, True):
        fig, ax = subplots()
        ax.axis("off")
        xx, yy = decimate(x, y, pixel_columns(ax)) if thin else (x, y)
        ax.plot(xx, yy, lw=0.8, color="k")
        pngs.append(render(fig, "png"))
        if thin:
            assert xx.size < x.size / 20
    (t0, b0), (t1, b1) = (_ink_extent(p) for p in pngs)
    np.testing.assert_array_equal(b0 >= 0, b1 >= 0)  # the same columns carry the line
    assert (b0 >= 0).sum() > 500
    assert _within_a_pixel(t1, b1, t0, b0) and _within_a_pixel(t0, b0, t1, b1)
    # a coarser thinning (a tenth of the pixel columns) does not pass the same check
    fig, ax = subplots()
    ax.axis("off")
    ax.plot(*decimate(x, y, pixel_columns(ax) // 20), lw=0.8, color="k")
    t2, b2 = _ink_extent(render(fig, "png"))
    assert not (_within_a_pixel(t2, b2, t0, b0) and _within_a_pixel(t0, b0, t2, b2))


def test_long_trace_figure_is_thinned_and_labelled():
    """The viscometer's LVDT trace (a long time series) is drawn decimated, from its first
    to its last sample, on labelled axes with units."""
    from test_figures import assert_publishable

    from torlab.parsers.viscometer import read_viscometer
    from torlab.reduce.viscometer import calibrate, reduce_viscometer
    from torlab.reports.viscometer import falls_figure

    f = ROOT / "sample_data" / "visc" / "visc_ester_25C.txt"
    cal = calibrate(*read_viscometer(f.with_name("visc_reference_25C.txt")))
    res = reduce_viscometer(*read_viscometer(f), calibration=cal)
    t = res.trace["time_s"].to_numpy()
    xs = res.trace["position_m"].to_numpy() * 1e3
    fig = falls_figure(res)
    trace = fig.axes[0].lines[0]
    xd = trace.get_xdata()
    assert t.size > 4 * pixel_columns(fig.axes[0]) and xd.size < t.size / 2
    assert xd[0] == t[0] and xd[-1] == t[-1]
    assert trace.get_ydata().max() == xs.max() and trace.get_ydata().min() == xs.min()
    from torlab.reports.plotting import finish

    finish(fig)
    assert_publishable(fig, file_names=(f.name,))


def test_lean_import_draws_the_same_figure(tmp_path):
    """A command's lean matplotlib import (no docstring tables) gives the same PNG, and
    artists' ``set()`` still accepts and checks properties."""
    code = """
import sys
from torlab.reports import plotting
plotting.LEAN_IMPORT[0] = sys.argv[1] == "1"
from torlab.reports.plotting import subplots, finish
from torlab.reports.render import render
fig, ax = subplots()
(ln,) = ax.plot([0, 1, 2], [0, 1, 0], label="a")
ln.set(lw=2.5, color="#D55E00")
try:
    ln.set(no_such_property=1)
except AttributeError:
    pass
else:
    raise SystemExit("set() accepted an unknown property")
ax.set_xlabel("x (m)"); ax.set_ylabel("y (-)"); ax.set_title("t"); plotting.legend(ax)
finish(fig)
import matplotlib.artist
print(getattr(matplotlib.artist, "_torlab_lean", False), file=sys.stderr)
sys.stdout.buffer.write(render(fig, "png"))
"""
    out = {}
    for lean in ("0", "1"):
        r = subprocess.run([sys.executable, "-c", code, lean], capture_output=True, check=True)
        out[lean] = r.stdout
        assert r.stderr.decode().strip().endswith("True" if lean == "1" else "False")
    from PIL import Image

    a, b = (np.asarray(Image.open(io.BytesIO(out[k]))) for k in ("0", "1"))
    np.testing.assert_array_equal(a, b)


def test_style_defaults_and_title_above_the_axes():
    """matplotlib's "C0" defaults are the palette's first colour, written out; a title at
    the style's fixed height stays above the plotting area, clear of the data."""
    assert STYLE["lines.color"] == STYLE["patch.facecolor"] == PALETTE[0]
    fig, (ax, axr) = subplots(2, 1, sharex=True, figsize=(7.0, 5.6))
    ax.plot([0, 1e-3], [0, 200])
    ax.set_title("Third-body layer from HPT tests: a.txt\nmu_c1 = 0.1, mu_c2 = 0.2")
    axr.plot([0, 1e-3], [1, -1])
    from torlab.reports.plotting import finish

    finish(fig)
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    tb, ab = ax.title.get_window_extent(r), ax.get_window_extent(r)
    assert tb.y0 >= ab.y1
    assert tb.y1 <= fig.bbox.height


def test_joint_fit_title_fits_in_the_figure():
    """A layer fit of several HPT logs names its first and last file and their number, and
    the title stays within the figure (the full list ran off both sides)."""
    from torlab.fit.layer import fit_layer_hpt
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import reduce_hpt
    from torlab.reports.fit import fit_figure
    from torlab.reports.plotting import finish

    files = sorted((ROOT / "sample_data" / "hpt").glob("hpt_OFM1_4uL_25C*.txt"))
    assert len(files) >= 3
    res = fit_layer_hpt([reduce_hpt(*read_hpt(f)) for f in files], joint=True)
    fig = finish(fit_figure(res))
    head = fig.axes[0].get_title().split("\n")[0]
    assert files[0].name in head and f"({len(files)} files)" in head
    fig.canvas.draw()
    tb = fig.axes[0].title.get_window_extent(fig.canvas.get_renderer())
    assert 0 <= tb.x0 and tb.x1 <= fig.bbox.width
    # the legend: each file's points once, the model once (it listed "measured 0-3" and
    # "model 0-3", four lines of one model); the title in symbols
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert sum(lab.startswith("model") for lab in labels) == 1
    assert all(any(f.name in lab for lab in labels) for f in files)
    assert "μc1 = " in fig.axes[0].get_title() and "mu_c1" not in fig.axes[0].get_title()
    from figure_checks import figure_problems

    assert figure_problems(fig, file_names=tuple(f.name for f in files)) == []


def _pixels(png):
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))


def _matplotlib_png(fig):
    """The figure through matplotlib's own PNG writer (Pillow), as torlab wrote it before."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=STYLE["savefig.dpi"])
    return buf.getvalue()


def test_png_writer_round_trips_pixels_resolution_and_software():
    """:func:`png_bytes` writes what Pillow reads back pixel for pixel: RGB when every
    pixel is opaque, RGBA otherwise (both checked on odd sizes and a partly transparent
    image), with the resolution and the program."""
    from PIL import Image

    from torlab.reports.render import png_bytes

    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, size=(37, 53, 4), dtype=np.uint8)
    img[..., 3] = 255
    png = png_bytes(img, 150, "torlab test")
    im = Image.open(io.BytesIO(png))
    assert im.mode == "RGB" and im.size == (53, 37)
    assert im.info["Software"] == "torlab test"
    assert im.info["dpi"] == pytest.approx((150, 150), abs=0.02)
    np.testing.assert_array_equal(np.asarray(im), img[..., :3])
    img[5, 7, 3] = 10  # one pixel not opaque: the alpha channel is kept
    im = Image.open(io.BytesIO(png_bytes(img, 72)))
    assert im.mode == "RGBA" and "Software" not in im.info
    np.testing.assert_array_equal(np.asarray(im), img)
    big = np.full((3000, 700, 4), 255, np.uint8)  # several blocks of rows
    big[::7, ::3, :3] = rng.integers(0, 256, size=(429, 234, 3), dtype=np.uint8)
    np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(png_bytes(big, 150)))),
                                  big[..., :3])


def test_png_figure_has_the_pixels_of_matplotlibs_writer():
    """A figure written by torlab's PNG writer shows exactly the pixels matplotlib's own
    writer gives (a fit figure of the fixed layout, with an outside legend)."""
    from torlab.reports.plotting import finish, legend
    from torlab.reports.render import render

    x, y = _walk(3_000, seed=2)
    fig, (ax, axr) = subplots(2, 1, sharex=True, figsize=(7.0, 5.6), height_ratios=[3, 1])
    ax.plot(x, y, "o", ms=2, alpha=0.55, label="measured")
    ax.plot(x, y * 0.9, "-", label="model")
    axr.plot(x, y * 0.1, "o", ms=2)
    ax.set_ylabel("shear stress τ (MPa)")
    axr.set_xlabel("layer displacement u (µm)")
    ax.set_title("Third-body layer\nμc1 = 0.15")
    legend(ax)
    finish(fig)
    ours, theirs = render(fig, "png"), _matplotlib_png(fig)
    assert ours[:8] == b"\x89PNG\r\n\x1a\n" and ours != theirs
    np.testing.assert_array_equal(_pixels(ours), _pixels(theirs))


def test_facets_laid_out_once_show_what_matplotlibs_layout_shows():
    """A figure of facets (constrained layout) laid out once and kept
    (:func:`torlab.reports.render.fix_layout`) has the same pixels as matplotlib's save,
    which lays it out on each of its two drawings; the layout engine is gone after, and
    a second format needs no layout."""
    from torlab.reports.plotting import facet_legend, facets
    from torlab.reports.render import render_all

    def make():
        fig, axes = facets(5, ncols=2, strips=[0.8, 0, 0.8, 0.8, 0])
        for k, (ax, *strip) in enumerate(axes):
            x, y = _walk(200, seed=k)
            ax.plot(x, y, label=f"curve {k} with a long name")
            ax.set_xscale("log" if k % 2 else "linear")
            ax.set_ylabel("traction coefficient μ (–)")
            ax.set_title(f"panel {k}")
            facet_legend(ax)
            if strip and strip[0].get_visible():
                strip[0].plot(x, y * 0.01, "o", ms=2)
                strip[0].set_xlabel("creepage ξ (%)")
        fig.suptitle("Traction curves in facets")
        return fig

    theirs = _matplotlib_png(make())
    fig = make()
    out = render_all(fig, ["png", "svg"])
    assert fig.get_layout_engine() is None
    np.testing.assert_array_equal(_pixels(out["png"]), _pixels(theirs))
    assert b"<svg" in out["svg"][:400]
