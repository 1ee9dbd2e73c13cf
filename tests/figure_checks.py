"""What a figure must be to go into a paper as it is, checked on the figure itself.

:func:`figure_problems` lays a finished figure out with its own renderer (matplotlib's
Agg canvas: the text extents a saved PNG has) and lists what is wrong with it:

* **canvas**: every text (titles, axis and tick labels, legends, annotations, colour-bar
  labels) lies inside the figure;
* **overlap**: no two texts overlap (a title and a legend, a tick label and an axis
  label, two annotations); no annotation or legend inside the plotting area lies on a
  drawn line or marker;
* **legends**: no label twice;
* **axes**: every axis that shows data is labelled, with exactly one unit in parentheses
  at the end (no "mg or µL"); a dimensionless quantity says ``(–)``;
* **titles**: symbols, not parameter names (``μc1``, never ``mu_c1``); a temperature
  coefficient's value carries its unit (1/K);
* **error bars**: the caps are wider than the marker they belong to, so a spread smaller
  than the marker still shows;
* **bands**: a shaded band differs from the white background by at least
  :data:`MIN_CONTRAST` in luminance (the 95 % bands of several products were drawn at
  12 % opacity, which a pale colour makes nearly white).

The checks read the figure, not the code that drew it: a new figure kind is checked by
drawing it (``tests/test_figure_kinds.py`` enumerates the kinds torlab declares).
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

#: the smallest luminance difference of a shaded band from the white background
MIN_CONTRAST = 0.08
#: overlaps smaller than this (pixels at the figure's dpi) are anti-aliasing, not overlap
_TOL = 1.0

_UNIT = re.compile(r"\(((?:[^()]|\([^()]*\))+)\)$")


def _names() -> set[str]:
    """Parameter names a figure must not show in place of symbols (the fits' parameter
    names that are not words or symbols: ``mu_c1``, ``L_mue``, ``eta0``)."""
    from torlab.fit.result import PARAM_UNITS

    return {n for n in PARAM_UNITS if "_" in n} | {"eta0"}


def _layer_params() -> list[Any]:
    from torlab.model.layers import all_params

    return list(all_params().values())


def _texts(fig: Any, r: Any) -> list[tuple[str, Any, Any]]:
    """(what, text, window extent) of every visible, non-empty text of the figure."""
    out: list[tuple[str, Any, Any]] = []

    def add(what: str, t: Any) -> None:
        if t is None or not t.get_visible() or not t.get_text().strip():
            return
        out.append((what, t, t.get_window_extent(r)))

    if getattr(fig, "_suptitle", None) is not None:
        add("suptitle", fig._suptitle)
    for t in fig.texts:
        if t is not getattr(fig, "_suptitle", None):
            add("figure text", t)
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        for t in (ax.title, ax._left_title, ax._right_title):
            add("title", t)
        add("x label", ax.xaxis.label)
        add("y label", ax.yaxis.label)
        for axis, name in ((ax.xaxis, "x tick"), (ax.yaxis, "y tick")):
            if not axis.get_visible():
                continue
            for tick in axis._update_ticks():  # the ticks that are drawn
                if tick.get_visible():
                    add(name, tick.label1)
                    if tick.label2.get_visible():
                        add(name, tick.label2)
            add(f"{name} offset", axis.offsetText)
        for t in ax.texts:
            add("annotation", t)
    return out


def _legend_boxes(fig: Any, r: Any) -> list[tuple[Any, Any, Any]]:
    """(axes or None, legend, window extent) of every legend."""
    out = []
    for ax in fig.axes:
        lg = ax.get_legend()
        if lg is not None and lg.get_visible():
            out.append((ax, lg, lg.get_window_extent(r)))
    for lg in fig.legends:
        out.append((None, lg, lg.get_window_extent(r)))
    return out


def _overlap(a: Any, b: Any) -> bool:
    return (min(a.x1, b.x1) - max(a.x0, b.x0) > _TOL) and (min(a.y1, b.y1) - max(a.y0, b.y0) > _TOL)


def _inside(b: Any, canvas: Any) -> bool:
    return (b.x0 >= canvas.x0 - _TOL and b.y0 >= canvas.y0 - _TOL and b.x1 <= canvas.x1 + _TOL
            and b.y1 <= canvas.y1 + _TOL)


def _line_hits(line: Any, box: Any) -> bool:
    """Whether a drawn line or its markers lie in ``box`` (display coordinates)."""
    if not line.get_visible() or line.get_alpha() == 0:
        return False
    path = line.get_transform().transform_path(line.get_path())
    if line.get_linestyle() not in ("None", "none", "", " "):
        if path.intersects_bbox(box, filled=False):
            return True
    marker = line.get_marker()
    if marker not in (None, "None", "none", "", " ") and len(path.vertices):
        rad = line.get_markersize() / 72.0 * line.figure.dpi / 2.0
        v = path.vertices
        v = v[np.all(np.isfinite(v), axis=1)]
        inside = ((v[:, 0] + rad > box.x0) & (v[:, 0] - rad < box.x1)
                  & (v[:, 1] + rad > box.y0) & (v[:, 1] - rad < box.y1))
        return bool(inside.any())
    return False


def _luminance(rgb: Any) -> float:
    r, g, b = rgb[:3]
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def _axis_problems(ax: Any, where: str) -> list[str]:
    out = []
    if not ax.has_data() or not ax.get_visible():
        return out
    shared = [a for a in ax.get_shared_x_axes().get_siblings(ax) if a.get_visible()]
    labels = {"y": ax.get_ylabel(),
              "x": ax.get_xlabel() or next((a.get_xlabel() for a in shared if a.get_xlabel()), "")}
    shared_y = [a for a in ax.get_shared_y_axes().get_siblings(ax) if a.get_visible()]
    if not labels["y"]:
        labels["y"] = next((a.get_ylabel() for a in shared_y if a.get_ylabel()), "")
    is_colorbar = hasattr(ax, "_colorbar")
    for k, lab in labels.items():
        if (is_colorbar and not lab) or _categorical(ax.xaxis if k == "x" else ax.yaxis):
            continue
        text = lab.strip()
        m = _UNIT.search(text)
        if m is None:
            out.append(f"{where}: {k} axis {text!r} has no unit in parentheses at the end")
            continue
        unit = m.group(1)
        if re.search(r"\b(or|and)\b|,", unit):
            out.append(f"{where}: {k} axis {text!r} gives more than one unit ({unit})")
    return out


def _categorical(axis: Any) -> bool:
    """An axis whose tick labels are names (products, comparisons), not numbers: its
    labels say what it shows, and it has no unit."""
    labels = [t.get_text() for t in axis.get_ticklabels() if t.get_text().strip()]
    if not labels:
        return False
    for t in labels:
        try:
            float(t.replace("−", "-").replace("%", ""))
        except ValueError:
            continue
        return False
    return True


def _title_problems(texts: list[str], file_names: tuple[str, ...]) -> list[str]:
    out = []
    names = _names()
    for t in texts:
        clean = t
        for f in file_names:
            clean = clean.replace(f, "")
        words = set(re.findall(r"[A-Za-z][A-Za-z0-9_]*", clean))
        bad = sorted(words & names)
        if bad:
            out.append(f"title {t!r} shows parameter names {bad}, not symbols")
        for sym in (p.symbol for p in _layer_params() if p.temperature_of):
            # the value runs to the next "<symbol> =", a semicolon or the line's end
            for m in re.finditer(re.escape(sym) + r"\s*=\s*(.*?)(?=,\s*\S+\s*=|;|\n|$)",
                                 clean):
                if "1/K" not in m.group(1):
                    out.append(f"title {t!r}: the temperature coefficient {sym} has no unit")
    return out


def figure_problems(fig: Any, *, file_names: tuple[str, ...] = ()) -> list[str]:
    """What keeps ``fig`` (finished: :func:`torlab.reports.plotting.finish`) from a paper;
    empty when nothing does.  ``file_names``: text from the data (file names) that the
    title checks leave alone."""
    fig.draw_without_rendering()  # lays out what a draw lays out (axis label positions)
    r = fig.canvas.get_renderer()
    texts = _texts(fig, r)
    legends = _legend_boxes(fig, r)
    problems = _layout_problems(fig, r, texts, legends)
    for _, lg, _b in legends:
        labels = [x.get_text() for x in lg.get_texts()]
        seen = {x for x in labels if labels.count(x) > 1}
        if seen:
            problems.append(f"legend repeats {sorted(seen)}")
    for k, ax in enumerate(fig.axes):
        problems += _axis_problems(ax, f"axes {k}")
    titles = [t.get_text() for w, t, _ in texts if w in ("title", "suptitle", "figure text")]
    problems += _title_problems(titles, file_names)
    for ax in fig.axes:
        problems += _mark_problems(ax)
    return problems


def _layout_problems(fig: Any, r: Any, texts: list[tuple[str, Any, Any]],
                     legends: list[tuple[Any, Any, Any]]) -> list[str]:
    """Texts and legends inside the canvas, clear of each other and of the data."""
    canvas = fig.bbox
    problems = []
    for what, t, b in texts:
        if not _inside(b, canvas):
            problems.append(f"{what} {t.get_text()!r} runs off the figure ({_box(b)} in "
                            f"{_box(canvas)})")
    for _, lg, b in legends:
        if not _inside(b, canvas):
            problems.append(f"legend of {len(lg.get_texts())} entries runs off the figure "
                            f"({_box(b)} in {_box(canvas)})")
    boxes = [(f"{w} {t.get_text()!r}", b) for w, t, b in texts]
    boxes += [(f"legend ({len(lg.get_texts())} entries)", b) for _, lg, b in legends]
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            (na, a), (nb, b) = boxes[i], boxes[j]
            if _overlap(a, b):
                problems.append(f"{na} overlaps {nb}")
    areas = [(k, ax.bbox) for k, ax in enumerate(fig.axes) if ax.get_visible()]
    titles = [(w, t, b) for w, t, b in texts if w in ("title", "suptitle", "figure text")]
    problems += [f"{w} {t.get_text()!r} lies on the plotting area of axes {k}"
                 for w, t, b in titles for k, a in areas if _overlap(a, b)]
    for ax in fig.axes:  # annotations and legends inside the plotting area against the data
        inner = [(f"annotation {t.get_text()!r}", t.get_window_extent(r)) for t in ax.texts
                 if t.get_visible() and t.get_text().strip()]
        lg = ax.get_legend()
        if lg is not None and not getattr(lg, "_torlab_outside", False):
            inner.append(("legend inside the axes", lg.get_window_extent(r)))
        for name, b in inner:
            hit = next((ln for ln in ax.lines if _line_hits(ln, b)), None)
            if hit is not None:
                problems.append(f"{name} lies on the line {hit.get_label()!r}")
    return problems


def _mark_problems(ax: Any) -> list[str]:
    """Error bars whose caps a marker hides; bands too pale to see."""
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import to_rgba
    from matplotlib.container import ErrorbarContainer

    problems = []
    for c in ax.containers:
        if not isinstance(c, ErrorbarContainer):
            continue
        data_line, caps, bars = c.lines
        if data_line is None or data_line.get_marker() in (None, "None", "none", "", " ") \
                or not len(data_line.get_xdata()):
            continue
        if not any(len(b.get_segments()) for b in bars):  # no spread given
            continue
        ms = data_line.get_markersize()
        if not caps:
            problems.append(f"error bars of {c.get_label()!r} have no caps: a spread smaller "
                            "than the marker is hidden")
        elif caps[0].get_markersize() < ms + 1.5:
            problems.append(f"error bar caps of {c.get_label()!r} ({caps[0].get_markersize()} "
                            f"pt) are not wider than the marker ({ms} pt)")
    for coll in ax.collections:
        if not isinstance(coll, PolyCollection) or not coll.get_visible():
            continue
        fc = coll.get_facecolor()
        if not len(fc):
            continue
        rgba = to_rgba(fc[0])  # the face colour holds the collection's alpha
        blended = [1.0 - rgba[3] * (1.0 - ch) for ch in rgba[:3]]
        if 1.0 - _luminance(blended) < MIN_CONTRAST:
            problems.append(f"the band {coll.get_label()!r} is nearly invisible (luminance "
                            f"{_luminance(blended):.3f} on white)")
    return problems


def _box(b: Any) -> str:
    return f"[{b.x0:.0f}, {b.y0:.0f}, {b.x1:.0f}, {b.y1:.0f}]"
