"""The remembering Agg canvas draws exactly what matplotlib's draws.

:mod:`torlab.reports.textcache` remembers text sizes, layouts and glyph bitmaps between
drawings.  The reference is matplotlib's own Agg canvas drawing the same figure: every
pixel must agree, for texts at random positions (fractions of a pixel), angles, sizes,
weights and alignments, with and without antialiasing, drawn several times over so that
the remembered glyphs are used.  Every figure kind torlab draws is compared the same way
in the slow suite (``tests/test_figure_kinds.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

import torlab.reports.textcache as tc


def _text_figure(canvas_cls, seed: int):
    from matplotlib.figure import Figure

    rng = np.random.default_rng(seed)
    fig = Figure(figsize=(4.3, 3.1), dpi=150)
    canvas_cls(fig)
    ax = fig.add_axes((0.13, 0.12, 0.8, 0.8))
    ax.plot(rng.random(20), rng.random(20))
    ax.set_xlabel("creepage ξ (%)")
    ax.set_ylabel("traction μ (–)")
    ax.set_title(f"seed {seed}: μc1 = {rng.random():.4f}\nsecond line ×10⁻⁴")
    words = ["0.1", "0.25", "μ", "ΔT (K)", "HPT", "fit ± 2σ", "−0.003", "Voce", "agg"]
    for _ in range(25):
        ax.text(rng.random(), rng.random(), str(rng.choice(words)),
                transform=ax.transAxes, fontsize=float(rng.choice([6, 7.5, 9, 11])),
                rotation=float(rng.choice([0, 0, 90, 30, rng.uniform(-180, 180)])),
                ha=str(rng.choice(["left", "center", "right"])),
                va=str(rng.choice(["baseline", "center", "top"])),
                weight=str(rng.choice(["normal", "bold"])),
                antialiased=bool(rng.random() < 0.8))
    ax.legend(["data"], loc="upper right")
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba()).copy()


@pytest.mark.skipif(not tc.available(), reason="this matplotlib lacks the Agg internals used")
def test_texts_are_the_same_pixels_as_matplotlibs():
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from torlab.reports.plotting import _mpl

    _mpl()
    tc.clear()
    for rep in range(2):  # the second round draws from remembered glyphs
        for seed in range(6):
            ours = _text_figure(tc.Canvas, seed)
            theirs = _text_figure(FigureCanvasAgg, seed)
            assert ours.shape == theirs.shape
            diff = int((ours != theirs).any(axis=-1).sum())
            assert diff == 0, f"round {rep}, seed {seed}: {diff} pixels differ"
    s = tc.stats()
    # the tables were used: most glyphs and sizes came from memory
    assert s["glyphs"]["hits"] > 2 * s["glyphs"]["misses"] > 0
    assert s["metrics"]["hits"] > 0 and s["layouts"]["hits"] > 0


def test_tables_are_bounded(monkeypatch):
    from torlab.reports._texttables import _store

    monkeypatch.setitem(tc.LIMITS, "glyphs", 10)
    table: dict = {}
    for i in range(35):
        _store(table, "glyphs", (i,), i)
        assert len(table) <= 10
    assert (34,) in table and (0,) not in table


def test_without_the_internals_the_canvas_is_matplotlibs(monkeypatch):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    monkeypatch.setattr(tc, "_CLASSES", [None])
    fig = Figure()
    assert type(tc.canvas(fig)) is FigureCanvasAgg
    assert not tc.available()


@pytest.mark.skipif(not tc.available(), reason="this matplotlib lacks the Agg internals used")
@pytest.mark.parametrize("first", [True, False])
def test_the_same_text_with_and_without_antialiasing(first):
    """The same glyphs at the same place, one drawing antialiased and one not: neither
    takes the other's bitmaps."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    def draw(canvas_cls, aa):
        fig = Figure(figsize=(2.0, 1.0), dpi=150)
        canvas_cls(fig)
        fig.text(0.1037, 0.4211, "μc2 0.2126", fontsize=9, antialiased=aa)
        fig.canvas.draw()
        return np.asarray(fig.canvas.buffer_rgba()).copy()

    tc.clear()
    for aa in (first, not first):
        assert np.array_equal(draw(tc.Canvas, aa), draw(FigureCanvasAgg, aa)), aa
