"""The renderer and canvas of :mod:`torlab.reports.textcache` (imported only where this
matplotlib has the Agg internals they use, :func:`torlab.reports.textcache.available`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.backends import backend_agg as agg

from torlab.reports._texttables import _GLYPHS, _LAYOUTS, _METRICS, _STATS, _store

RenderMode = agg.RenderMode
get_hinting_flag = agg.get_hinting_flag
fonts, get_font = agg._fontManager, agg.get_font  # the backend's own


class Renderer(agg.RendererAgg):
    """matplotlib's Agg renderer that remembers text sizes, layouts and glyphs."""

    def _font(self, prop: Any) -> Any:
        """The font of ``prop`` (as ``_prepare_font`` finds it), looked up once per
        font properties in this renderer's life (one drawing: the settings it is
        found by do not change)."""
        memo = self.__dict__.setdefault("_torlab_fonts", {})
        h = hash(prop)
        font = memo.get(h)
        if font is None:
            font = memo[h] = get_font(fonts._find_fonts_by_props(prop))
        return font

    def _get_font_height_metrics(self, prop: Any) -> tuple[float, float, float] | None:
        """A font's ascent, descent and line gap at its size (what ``Text._get_layout``
        reads from the font's tables when a renderer does not give them), remembered
        by font, size and resolution."""
        font = self._font(prop)
        size = prop.get_size_in_points()
        key = ("height", font, size, self.dpi)
        got = _METRICS.get(key)
        if got is not None:
            _STATS["metrics"][0] += 1
            return got
        _STATS["metrics"][1] += 1
        got = (None, None, None)
        for table_name, gap, ascent, descent in (
                ("OS/2", "sTypoLineGap", "sTypoAscender", "sTypoDescender"),
                ("hhea", "lineGap", "ascent", "descent")):
            table = font.get_sfnt_table(table_name)
            if table is None:
                continue
            scale = 1 / font.get_sfnt_table("head")["unitsPerEm"] * size * self.dpi / 72
            got = (table[ascent] * scale, -table[descent] * scale, table[gap] * scale)
            break
        _store(_METRICS, "metrics", key, got)
        return got

    def get_text_width_height_descent(self, s: str, prop: Any,
                                      ismath: Any) -> tuple[float, float, float]:
        if ismath:  # mathtext and TeX: matplotlib's own
            return super().get_text_width_height_descent(s, prop, ismath)
        flags = get_hinting_flag()
        key = (s, self._font(prop), prop.get_size_in_points(), self.dpi, flags)
        got = _METRICS.get(key)
        if got is not None:
            _STATS["metrics"][0] += 1
            return got
        _STATS["metrics"][1] += 1
        got = super().get_text_width_height_descent(s, prop, ismath)
        _store(_METRICS, "metrics", key, got)
        return got

    def draw_text(self, gc: Any, x: float, y: float, s: str, prop: Any, angle: float,
                  ismath: Any = False, mtext: Any = None) -> None:
        if ismath:
            return super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
        flags = get_hinting_flag()
        features = mtext.get_fontfeatures() if mtext is not None else None
        language = mtext.get_language() if mtext is not None else None
        size = prop.get_size_in_points()
        font = self._font(prop)
        fkey = tuple(features) if features is not None else None
        lkey = (s, font, size, self.dpi, flags, fkey,
                language if isinstance(language, (str, type(None))) else repr(language))
        items = _LAYOUTS.get(lkey)
        if items is None:
            _STATS["layouts"][1] += 1
            font = self._prepare_font(prop)
            items = tuple((it.ft_object, it.glyph_index, it.x, it.y)
                          for it in font._layout(s, flags=flags, features=features,
                                                 language=language))
            _store(_LAYOUTS, "layouts", lkey, items)
        else:
            _STATS["layouts"][0] += 1
        self._glyphs(gc, x, y, angle, size, items, flags)
        return None

    def _glyphs(self, gc: Any, x: float, y: float, angle: float, size: float,
                items: tuple, load_flags: Any) -> None:
        """matplotlib's ``_draw_text_glyphs_and_boxes`` for plain text (no slant or
        extension, no boxes), each glyph's bitmap taken from :data:`_GLYPHS` where it
        was rendered before at the same fraction of a pixel."""
        # the same arithmetic as matplotlib's, so the same 26.6 positions (its product
        # with the identity of no slant or extension leaves the matrix as it is)
        cos = math.cos(math.radians(angle))
        sin = math.sin(math.radians(angle))
        matrix = (0x10000 * np.array([[cos, -sin], [sin, cos]])).round().astype(int)
        mkey = tuple(matrix.ravel().tolist())
        aa = bool(gc.get_antialiased())
        height = self.height
        ih = int(height)
        dpi = self.dpi
        draw = self._renderer.draw_text_image
        for font, index, dx, dy in items:
            tx = round(0x40 * (x + dx * cos - dy * sin))
            ty = round(0x40 * (height - y + dx * sin + dy * cos))
            key = (font, size, dpi, index, mkey, tx & 63, ty & 63, load_flags, aa)
            got = _GLYPHS.get(key)
            if got is None:
                _STATS["glyphs"][1] += 1
                font.set_size(size, dpi)
                font._set_transform(matrix, [tx, ty])
                bitmap = font._render_glyph(index, load_flags,
                                            RenderMode.NORMAL if aa else RenderMode.MONO)
                buffer = bitmap.buffer
                if not aa:
                    buffer *= 0xff
                got = (buffer, bitmap.left - (tx >> 6), bitmap.top - (ty >> 6))
                _store(_GLYPHS, "glyphs", key, got)
            else:
                _STATS["glyphs"][0] += 1
            buffer, left, top = got
            # draw_text_image's y is downwards and the bitmap's bottom side
            draw(buffer, left + (tx >> 6), ih - (top + (ty >> 6)) + buffer.shape[0], 0, gc)


class Canvas(agg.FigureCanvasAgg):
    """matplotlib's Agg canvas drawing with :class:`Renderer`."""

    def get_renderer(self) -> Any:
        w, h = self.get_width_height(physical=True)
        key = w, h, self.figure.dpi
        if self._lastKey != key:
            self.renderer = Renderer(w, h, self.figure.dpi)
            self._lastKey = key
        return self.renderer
