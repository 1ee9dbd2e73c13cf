"""The tables of :mod:`torlab.reports.textcache` (no matplotlib here: the renderer in
:mod:`torlab.reports._textagg` fills them, :func:`~torlab.reports.textcache.stats` reads
them)."""

from __future__ import annotations

from typing import Any

#: most entries of each table (metrics, layouts, glyph bitmaps) in one process: a glyph
#: takes about 0.7 kB with its key, so at most about 11 MB; the 195 figures of a campaign
#: of 16 seeds, drawn in one process, leave 9 800 glyphs (6.8 MB), 1 400 sizes, 1 000 layouts
LIMITS = {"metrics": 8192, "layouts": 8192, "glyphs": 16384}

_METRICS: dict[tuple, tuple[float, float, float]] = {}
_LAYOUTS: dict[tuple, tuple[tuple[Any, int, float, float], ...]] = {}
_GLYPHS: dict[tuple, tuple[Any, int, int]] = {}
_STATS = {"metrics": [0, 0], "layouts": [0, 0], "glyphs": [0, 0]}  # [hits, misses]


def _store(table: dict, name: str, key: tuple, value: Any) -> None:
    if len(table) >= LIMITS[name]:  # drop the oldest half (dicts keep insertion order)
        for k in list(table)[: len(table) // 2 + 1]:
            del table[k]
    table[key] = value
