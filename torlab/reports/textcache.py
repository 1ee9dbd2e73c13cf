"""An Agg canvas that remembers the text it has drawn: the same pixels, less work.

matplotlib's Agg renderer lays out and rasterises every text from its font outlines on
every drawing, and measures it again for every new renderer (each saved image gets
one).  A campaign draws hundreds of figures of the same few labels, tick numbers and
legend entries, so most of that work repeats.  :class:`Canvas` (the canvas of torlab's
figures, :func:`torlab.reports.plotting.subplots` and ``facets``) keeps, per process:

* the size of a text (width, height, descent) by text, font, size, resolution and
  hinting -- what matplotlib caches only per renderer;
* the layout of a text (its glyphs and their positions) by the same, plus the font
  features and language;
* the bitmap of a glyph by font, size, resolution, rotation, hinting, antialiasing and
  the fraction of a pixel (1/64) at which it is placed: FreeType's bitmap of a glyph
  moved by whole pixels is the same bitmap, moved.

Each table is bounded (:data:`LIMITS`; the oldest half is dropped when one is full).
A font's ascent, descent and line gap at a size (which ``Text`` reads from the font's
tables for every text it lays out) are kept with the sizes.  Mathematical text and TeX
take matplotlib's own path.  Nothing here changes a pixel: ``tests/test_textcache.py``
draws texts at random positions, angles, sizes and weights with this canvas and with
matplotlib's and compares every pixel; ``tests/test_figure_kinds.py`` does the same for
every figure kind torlab draws.

The renderer leans on private parts of matplotlib's Agg backend (``_prepare_font``,
``FT2Font._layout``, ``_set_transform`` and ``_render_glyph``, and the hook
``_get_font_height_metrics`` that ``Text`` asks a renderer for, as in matplotlib 3.11);
where one is missing the canvas is matplotlib's own (:func:`available`).  Fonts are
matplotlib's per thread (``get_font``), and so are the tables' entries that hold them.
"""

from __future__ import annotations

from typing import Any

from torlab.reports._texttables import _GLYPHS, _LAYOUTS, _METRICS, _STATS, LIMITS

__all__ = ["LIMITS", "available", "canvas", "clear", "stats"]


def clear() -> None:
    """Forget every remembered text and glyph (and the hit counts)."""
    for t in (_METRICS, _LAYOUTS, _GLYPHS):
        t.clear()
    for v in _STATS.values():
        v[:] = [0, 0]


def stats() -> dict[str, dict[str, int]]:
    """Hits, misses and entries of each table in this process."""
    sizes = {"metrics": len(_METRICS), "layouts": len(_LAYOUTS), "glyphs": len(_GLYPHS)}
    return {k: {"hits": v[0], "misses": v[1], "entries": sizes[k]} for k, v in _STATS.items()}


_CLASSES: list[Any] = []


def available() -> bool:
    """Whether this matplotlib has the Agg internals the remembering renderer uses."""
    return _classes() is not None


def canvas(fig: Any) -> Any:
    """Give ``fig`` the remembering canvas (matplotlib's Agg canvas where it cannot be
    used); returns the canvas."""
    return _canvas_class()(fig)


def __getattr__(name: str) -> Any:  # Canvas is made on first use (matplotlib is heavy)
    if name == "Canvas":
        return _canvas_class()
    raise AttributeError(name)


def _canvas_class() -> Any:
    """The remembering canvas class, or matplotlib's Agg canvas where it cannot be used."""
    classes = _classes()
    if classes is None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        return FigureCanvasAgg
    return classes[1]


def _classes() -> tuple[Any, Any] | None:
    if _CLASSES:
        return _CLASSES[0]
    _CLASSES.append(_make_classes())
    return _CLASSES[0]


def _make_classes() -> tuple[Any, Any] | None:
    from matplotlib.backends import backend_agg as agg
    from matplotlib.ft2font import FT2Font
    from matplotlib.text import Text

    need = (all(hasattr(agg, a) for a in ("_fontManager", "get_font", "get_hinting_flag",
                                          "RenderMode"))
            and hasattr(agg.RendererAgg, "_prepare_font")
            and all(hasattr(FT2Font, a) for a in ("_layout", "_set_transform", "_render_glyph"))
            and all(hasattr(Text, a) for a in ("get_fontfeatures", "get_language")))
    if not need:
        return None
    from torlab.reports._textagg import Canvas, Renderer

    return Renderer, Canvas
