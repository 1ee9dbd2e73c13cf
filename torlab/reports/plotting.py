"""torlab's figure style, in one place: the look, the layout and the pieces every plot shares.

Every torlab figure is a :class:`matplotlib.figure.Figure` on the Agg canvas, made
by :func:`subplots` -- never through ``matplotlib.pyplot``, whose import and
figure manager a command that writes a PNG does not need.  matplotlib itself is
imported on the first figure only.

* **Look** (:data:`STYLE`): sans-serif 9 pt, light grid, no top/right spines,
  150 dpi.  :data:`STYLE_VERSION` is part of every cached figure's key
  (:mod:`torlab.reports.render`): bump it when the look changes.
* **Layout**: fixed margins in inches (no layout engine, no ``bbox_inches="tight"``
  second pass); a legend outside the axes (:func:`legend`) widens the figure by
  the legend's measured width, so the plotting area keeps its size and nothing
  overlaps the data.
* **Long traces**: :func:`decimate` keeps, of a line with more points than the
  plotting area has pixel columns (:func:`pixel_columns`), the ones a pixel column
  can show (first, last, lowest, highest per bin).
* **Pieces**: :func:`colours` (distinct, stable colours per product or curve),
  :func:`band` (a 95 % prediction band), :func:`points` (measured points with
  error bars from the per-point spread), :func:`unit` ("µL", "µm" ...) and
  :func:`axis_label` (quantity, symbol and unit).
"""

from __future__ import annotations

import functools
import math
import re
import sys
from collections.abc import Callable, Iterable, Sequence
from typing import Any

__all__ = ["BAND_CONTRAST", "DIMENSIONLESS", "PALETTE", "STYLE", "STYLE_VERSION", "axis_label",
           "band", "band_style", "cap", "colours", "decimate", "facet_legend", "facets",
           "figure_legend", "finish", "fit_units", "legend", "number", "param_label", "param_symbol", "param_text",
           "param_unit", "pixel_columns", "plain_log_ticks", "points", "pretty", "pyplot",
           "subplots", "unit"]

#: bump when the look of the figures changes (invalidates cached figures)
STYLE_VERSION = 3

STYLE: dict[str, Any] = {
    "figure.figsize": (7.0, 4.5),
    "figure.dpi": 100,
    "font.size": 9,
    "axes.titlesize": 10,
    # the title at a fixed height above the axes (matplotlib's automatic placement
    # measures every tick label of the axes once more on each draw to see whether
    # the title must move up; torlab's axes have no ticks or labels on top)
    "axes.titley": 1.0,
    "axes.labelsize": 9,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "lines.linewidth": 1.5,
    # matplotlib's defaults here are "C0", the first colour of the property cycle,
    # looked up in the cycle again for every patch, spine and line made
    "lines.color": "#0072B2",
    "patch.facecolor": "#0072B2",
    "lines.markersize": 4,
    "errorbar.capsize": 3,
    "legend.frameon": False,
    "legend.fontsize": 8,
    "legend.handlelength": 1.8,
    "savefig.dpi": 150,
    "savefig.facecolor": "white",
    "path.simplify": True,
    "agg.path.chunksize": 10000,
    "svg.hashsalt": "torlab",  # reproducible SVG ids
    "svg.fonttype": "none",
    "pdf.fonttype": 42,
}

#: distinct colours (Okabe-Ito, readable by colour-blind readers), then tab10's
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000",
           "#F0E442", "#8c564b", "#7f7f7f", "#bcbd22", "#17becf", "#9467bd", "#d62728")

#: the unit written for a dimensionless quantity
DIMENSIONLESS = "–"

# margins of the fixed layout (inches)
_LEFT, _RIGHT, _BOTTOM, _TOP, _HSPACE, _WSPACE = 0.78, 0.22, 0.52, 0.38, 0.22, 0.62
_LINE = 0.17  # one extra line of 9-pt text
#: the most legend entries in one column (an outside legend as tall as a 4.5-inch figure)
_LEGEND_ROWS = 20

_READY: list[Any] = []
#: set by the command line: matplotlib's projections may skip its 3-D toolkit (see :func:`_mpl`)
LEAN_IMPORT = [False]


def _mpl() -> Any:
    """matplotlib, imported once, with torlab's style as the default rc parameters.

    In a ``torlab`` command (:data:`LEAN_IMPORT`) two parts of matplotlib's import that
    only serve interactive use are skipped:

    * the registration of the 3-D projection (``mpl_toolkits.mplot3d``, about 80 ms of
      a figure's 0.5 s of imports): no torlab figure is 3-D.  The toolkit stays
      importable afterwards;
    * the property tables matplotlib writes into the docstrings of every artist class's
      ``set()`` as the class is defined (:func:`_lean_artist_docs`; about a third of
      the import's CPU time).  A command never shows a docstring; the methods
      themselves are unchanged.
    """
    if not _READY:
        import warnings

        block = LEAN_IMPORT[0] and "mpl_toolkits.mplot3d" not in sys.modules
        if block:
            sys.modules["mpl_toolkits.mplot3d"] = None  # type: ignore[assignment]
        try:
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", message="Unable to import Axes3D")
                import matplotlib

                if LEAN_IMPORT[0]:
                    _lean_artist_docs()
                import matplotlib.figure
        finally:
            if block and sys.modules.get("mpl_toolkits.mplot3d", 0) is None:
                del sys.modules["mpl_toolkits.mplot3d"]
        from cycler import cycler

        style = dict(STYLE, **{"axes.prop_cycle": cycler(color=PALETTE)})
        matplotlib.rcParams.update(style)
        _READY.append(matplotlib)
    return _READY[0]


def _lean_artist_docs() -> None:
    """Let the artist classes matplotlib defines from now on skip their docstring tables.

    matplotlib builds, for each :class:`~matplotlib.artist.Artist` subclass, a ``set()``
    method whose docstring lists every property with its accepted values (parsed from
    the setters' docstrings, ``matplotlib.artist.kwdoc``), and interpolates the same
    tables into other docstrings.  Here the tables are empty and ``set()`` keeps the
    inherited signature; ``set()`` itself, and every setter, work as before.
    """
    import matplotlib.artist as martist

    if getattr(martist, "_torlab_lean", False) or sys.flags.optimize >= 2:
        return

    def kwdoc(artist: Any) -> str:
        return ""

    def update_set(cls: Any) -> None:
        cls.set._autogenerated_signature = True

    martist.kwdoc = kwdoc
    martist.Artist._update_set_signature_and_docstring = classmethod(update_set)
    martist._torlab_lean = True


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend with torlab's style (for notebooks;
    torlab's own figures do not use it)."""
    mpl = _mpl()
    mpl.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _lines(text: str | None) -> int:
    return 0 if not text else text.count("\n") + 1


def subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float] | None = None,
             sharex: bool = False, sharey: bool = False,
             height_ratios: Sequence[float] | None = None,
             gridspec_kw: dict[str, Any] | None = None, left: float | None = None,
             top: float | None = None, **_: Any) -> tuple[Any, Any]:
    """A figure and its axes (like ``pyplot.subplots``) on the Agg canvas, fixed layout.

    Parameters
    ----------
    nrows, ncols, sharex, sharey, height_ratios, gridspec_kw
        As for :meth:`matplotlib.figure.Figure.subplots`.
    figsize
        Width and height in inches of the plotting region plus margins (a legend
        outside the axes widens it, :func:`legend`).
    left, top
        Margins in inches (default 0.78 and 0.38); :func:`finish` adds room for
        multi-line titles and axis labels.

    Other keywords (``layout=`` of older callers) are ignored: the layout is fixed.
    """
    _mpl()
    from matplotlib.figure import Figure

    from torlab.reports.textcache import canvas

    w, h = figsize or STYLE["figure.figsize"]
    fig = Figure(figsize=(w, h))
    canvas(fig)
    gs = dict(gridspec_kw or {})
    if height_ratios is not None:
        gs["height_ratios"] = list(height_ratios)
    axes = fig.subplots(nrows, ncols, sharex=sharex, sharey=sharey, squeeze=True,
                        gridspec_kw=gs or None)
    fig._torlab_margins = {"left": _LEFT if left is None else left,  # type: ignore[attr-defined]
                           "top": _TOP if top is None else top}
    _place(fig)
    return fig, axes


def _place(fig: Any, extra_right: float = 0.0) -> None:
    """Set the fixed margins (inches -> fractions of the current figure size)."""
    w, h = fig.get_size_inches()
    m = getattr(fig, "_torlab_margins", {"left": _LEFT, "top": _TOP})
    axes = fig.axes
    top = m["top"] + _LINE * max([_lines(ax.get_title()) - 1 for ax in axes] + [0])
    sup = getattr(fig, "_suptitle", None)
    if sup is not None:  # at a fixed height below the top edge, above any axes title
        sup.set_y(1.0 - 0.06 / h)
        sup.set_verticalalignment("top")
        need = 0.06 + 0.2 * _lines(sup.get_text()) + 0.1
        if any(ax.get_title() for ax in axes):
            top += need
        else:
            top = max(top, need)
    left = m["left"] + _LINE * max([_lines(ax.get_ylabel()) - 1 for ax in axes] + [0])
    bottom = _BOTTOM + _LINE * max([_lines(ax.get_xlabel()) - 1 for ax in axes] + [0])
    gs = axes[0].get_gridspec() if axes and axes[0].get_subplotspec() is not None else None
    nrows, ncols = gs.get_geometry() if gs is not None else (1, 1)
    inner_h = max(h - top - bottom, 0.5)
    inner_w = max(w - left - _RIGHT - extra_right, 0.5)
    ax_h = inner_h / max(nrows, 1)
    ax_w = inner_w / max(ncols, 1)
    titles = any(_lines(ax.get_title()) for ax in axes[ncols:]) if nrows > 1 else False
    # x labels of panels above others (stacked panels that do not share x): their tick
    # labels and label need the room between the panels
    inner = max([_lines(ax.get_xlabel()) for ax in axes[:-ncols]] + [0]) if nrows > 1 else 0
    hspace = (_HSPACE + (0.3 if titles else 0.0) + (0.2 + _LINE * inner if inner else 0.0)) \
        / max(ax_h, 0.1)
    wspace = _WSPACE / max(ax_w, 0.1)
    fig.subplots_adjust(left=left / w, right=1 - (_RIGHT + extra_right) / w, bottom=bottom / h,
                        top=1 - top / h, hspace=hspace, wspace=wspace)


def legend(ax: Any, *, outside: bool = True, loc: str = "upper right", ncol: int = 1,
           title: str | None = None, **kw: Any) -> Any:
    """A legend: outside the axes on the right (default; the figure grows to fit it) or
    inside at a fixed corner (``outside=False``, ``loc``). Never ``loc="best"``, whose
    search over every data point costs more than the rest of the figure.

    Returns the legend (None when nothing is labelled).
    """
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    labels = [pretty(x) for x in labels]
    # a legend no taller than the plotting area: more columns rather than entries cut off
    ncol = max(ncol, math.ceil(len(labels) / _LEGEND_ROWS))
    if outside:
        lg = ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                       borderaxespad=0.0, ncol=ncol, title=title, **kw)
        lg._torlab_outside = True
    else:
        lg = ax.legend(handles, labels, loc=loc, ncol=ncol, title=title, **kw)
    return lg


def finish(fig: Any) -> Any:
    """Final layout: margins for multi-line labels and titles, room for outside legends.

    An outside legend's width is measured with the Agg renderer's font metrics
    (no drawing) and the figure is widened by it.  A figure finished again (its texts
    changed: :func:`torlab.reports.fit.redraw_result_figure`) is laid out anew from the
    size it had when it was first finished.  Returns ``fig``.
    """
    for ax in fig.axes:
        if ax.get_title():
            ax.set_title(pretty(ax.get_title()))
    if getattr(fig, "_suptitle", None) is not None:
        fig._suptitle.set_text(pretty(fig._suptitle.get_text()))
    if fig.get_layout_engine() is not None:  # a grid of facets (:func:`facets`) lays itself out
        fig._torlab_finished = True  # type: ignore[attr-defined]
        return fig
    base = getattr(fig, "_torlab_size", None)
    if base is None:
        fig._torlab_size = tuple(fig.get_size_inches())  # type: ignore[attr-defined]
    else:  # finished again (a kept figure refilled): laid out from the size it was made with
        fig.set_size_inches(*base)
    need = 0.0
    outside = [ax.get_legend() for ax in fig.axes
                if ax.get_legend() is not None and getattr(ax.get_legend(), "_torlab_outside",
                                                           False)]
    if outside:
        r = fig.canvas.get_renderer()
        dpi = fig.dpi
        need = max(lg.get_window_extent(r).width / dpi for lg in outside) + 0.12
        w, h = fig.get_size_inches()
        fig.set_size_inches(w + need, h)
    _place(fig, extra_right=need)
    if _wrap_titles(fig):  # more lines: more room at the top
        _place(fig, extra_right=need)
    fig._torlab_finished = True  # type: ignore[attr-defined]
    return fig


def _wrap_titles(fig: Any) -> bool:
    """Break an axes title wider than the figure allows at spaces, into as few lines as
    fit, as even in length as they go (measured with the Agg renderer's font metrics).  A
    title is centred over its axes, so it has twice the distance from the axes' centre to
    the nearer edge of the figure, less a tenth of an inch on each side: a fit over four
    runs whose files have long names ("Third-body layer from HPT tests:
    hpt_s01_WFM-dry_4uL_25C.txt … (4 files)") ran off the left edge.  True if a title
    was broken."""
    changed = False
    r = None
    width_px = fig.bbox.width
    for ax in fig.axes:
        t = ax.title
        text = t.get_text()
        if not text or "$" in text or not t.get_visible():
            continue
        if r is None:
            r = fig.canvas.get_renderer()
        pos = ax.get_position()
        centre = 0.5 * (pos.x0 + pos.x1) * width_px
        room = 2.0 * (min(centre, width_px - centre) - 0.1 * fig.dpi)
        if t.get_window_extent(r).width <= room:
            continue
        width = functools.partial(_text_width, r, t.get_fontproperties())
        lines = []
        for line in text.split("\n"):
            got = _wrap_line(line, room, width)
            lo, hi = room / len(got), room  # the same lines, as even as they go
            for _ in range(8 if len(got) > 1 else 0):
                mid = 0.5 * (lo + hi)
                if len(_wrap_line(line, mid, width)) == len(got):
                    hi = mid
                else:
                    lo = mid
            lines += _wrap_line(line, hi, width)
        wrapped = "\n".join(lines)
        if wrapped != text:
            t.set_text(wrapped)
            changed = True
    return changed


def _text_width(r: Any, prop: Any, text: str) -> float:
    """The width of one line of ``text`` in pixels (the renderer's font metrics)."""
    return r.get_text_width_height_descent(text, prop, ismath=False)[0]


def _wrap_line(line: str, room: float, width: Callable[[str], float]) -> list[str]:
    """``line`` broken at spaces into lines each as long as ``width`` allows within
    ``room`` (a word wider than that alone on its line)."""
    words = line.split(" ")
    out, cur = [], words[0]
    for w in words[1:]:
        if width(f"{cur} {w}") <= room:
            cur = f"{cur} {w}"
        else:
            out.append(cur)
            cur = w
    return [*out, cur]


def facets(n: int, *, ncols: int = 2, panel: tuple[float, float] = (3.4, 2.5),
           strips: Sequence[float] | None = None, legend_width: float = 2.3,
           shared_legend: bool = False) -> tuple[Any, list[list[Any]]]:
    """A figure of ``n`` panels (facets) in ``ncols`` columns, for what one panel cannot show
    readably (many curves: a few per facet, each facet with its own legend; or quantities in
    different units side by side).

    Laid out by matplotlib's constrained layout (the fixed margins of :func:`subplots` do
    not know the facets' legends): every label, tick label and legend is kept inside the
    figure and clear of the others.

    Parameters
    ----------
    n
        Number of facets.
    ncols
        Columns of facets (fewer when ``n`` is smaller).
    panel
        Width and height (inches) of one facet's plotting area.
    strips
        Per facet, the height (inches) of a strip below its panel that shares its x axis
        (0: none); None: no strips.
    legend_width
        Room (inches) for a facet's legend to the right of its panel (``shared_legend``:
        for one legend of the whole figure, at its right).

    Returns
    -------
    (figure, axes)
        ``axes[i]`` is ``[panel]`` or ``[panel, strip]`` of facet ``i``.
    """
    _mpl()
    from matplotlib.figure import Figure

    from torlab.reports.textcache import canvas

    ncols = max(1, min(ncols, n))
    nrows = math.ceil(n / ncols)
    strip_h = [float(x) for x in (strips or [0.0] * n)] + [0.0] * n
    row_strip = [max(strip_h[r * ncols:(r + 1) * ncols] or [0.0]) for r in range(nrows)]
    pw, ph = panel
    width = ncols * (pw + 0.9 + (0.0 if shared_legend else legend_width)) + \
        (legend_width if shared_legend else 0.0)
    height = 0.5 + sum(ph + 0.75 + (sh + 0.1 if sh else 0.0) for sh in row_strip)
    fig = Figure(figsize=(width, height), layout="constrained")
    canvas(fig)
    fig.get_layout_engine().set(h_pad=0.04, w_pad=0.06, hspace=0.02, wspace=0.04)
    ratios: list[float] = []
    for sh in row_strip:
        ratios += [ph, sh] if sh else [ph]
    gs = fig.add_gridspec(len(ratios), ncols, height_ratios=ratios)
    out: list[list[Any]] = []
    row = 0
    for r in range(nrows):
        for c in range(ncols):
            i = r * ncols + c
            if i >= n:
                break
            ax = fig.add_subplot(gs[row, c])
            axes = [ax]
            if row_strip[r]:
                st = fig.add_subplot(gs[row + 1, c], sharex=ax)
                if strip_h[i] <= 0:
                    st.set_visible(False)
                axes.append(st)
            out.append(axes)
        row += 2 if row_strip[r] else 1
    fig._torlab_facets = True  # type: ignore[attr-defined]
    return fig, out


def figure_legend(fig: Any, axes: Sequence[Any], **kw: Any) -> Any:
    """One legend for every facet of a :func:`facets` figure, at its right: each label once,
    in the order the facets show them."""
    handles: dict[str, Any] = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(pretty(lab), h)
    if not handles:
        return None
    ncol = max(1, math.ceil(len(handles) / _LEGEND_ROWS))
    lg = fig.legend(list(handles.values()), list(handles), loc="outside right upper",
                    ncol=ncol, **kw)
    lg._torlab_outside = True
    return lg


def facet_legend(ax: Any, **kw: Any) -> Any:
    """The legend of a facet (:func:`facets`), outside its panel on the right (the
    constrained layout makes room for it)."""
    return legend(ax, **kw)


def colours(keys: Iterable[Any]) -> dict[Any, str]:
    """A distinct colour per key, in the order given (stable: the same keys in the same
    order get the same colours in every figure of a report)."""
    out: dict[Any, str] = {}
    for k in keys:
        if k not in out:
            out[k] = PALETTE[len(out) % len(PALETTE)]
    return out


#: the smallest luminance step of a shaded 95 % band from the white background
BAND_CONTRAST = 0.12


def _luminance(rgb: Sequence[float]) -> float:
    """Relative luminance (Rec. 709 weights) of an RGB colour in 0..1."""
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]


def band_style(color: Any, alpha: float = 0.22) -> tuple[tuple[float, float, float], float]:
    """The colour and opacity of a band in ``color`` that stands out from white by at least
    :data:`BAND_CONTRAST` in luminance: the opacity is raised for a pale colour (up to
    0.45), and a colour too pale even then (yellow) is darkened."""
    from matplotlib.colors import to_rgb

    rgb = to_rgb(color)
    lum = _luminance(rgb)
    need = BAND_CONTRAST / max(1.0 - lum, 1e-9)
    if need <= max(alpha, 0.45):
        return rgb, max(alpha, need)
    k = (1.0 - BAND_CONTRAST / 0.45) / max(lum, 1e-9)  # scale so that 1 - lum = contrast/0.45
    return tuple(min(max(c * k, 0.0), 1.0) for c in rgb), 0.45  # type: ignore[return-value]


def band(ax: Any, x: Any, low: Any, high: Any, *, color: Any, label: str | None = None,
         alpha: float = 0.22) -> Any:
    """A shaded 95 % band between ``low`` and ``high`` (no edge line), at least
    :data:`BAND_CONTRAST` darker than the background (:func:`band_style`)."""
    rgb, a = band_style(color, alpha)
    return ax.fill_between(x, low, high, color=rgb, alpha=a, lw=0, label=label)


def points(ax: Any, x: Any, y: Any, yerr: Any = None, *, color: str, label: str | None = None,
           marker: str = "o", ms: float = 4.0, filled: bool = False, xerr: Any = None) -> Any:
    """Measured points, with error bars where a spread is given (NaN: no bar).

    The bars' caps are 2 pt wider than the marker, so a spread smaller than the marker
    still shows as the caps' ends beside it.
    """
    import numpy as np

    mfc = color if filled else "white"
    if yerr is None and xerr is None:
        return ax.plot(x, y, marker, ms=ms, color=color, mfc=mfc, mew=1.0, ls="none",
                       label=label)
    ye = None if yerr is None else np.where(np.isfinite(np.asarray(yerr, float)),
                                            np.asarray(yerr, float), 0.0)
    return ax.errorbar(x, y, yerr=ye, xerr=xerr, fmt=marker, ms=ms, color=color, mfc=mfc,
                       mew=1.0, elinewidth=0.8, capsize=cap(ms), label=label)


def cap(ms: float) -> float:
    """The cap size (half its width, points) of error bars on markers of size ``ms``: the
    caps are 2 pt wider than the marker."""
    return ms / 2.0 + 1.0


_UNITS = {"ul": "µL", "uL": "µL", "µl": "µL", "μl": "µL", "μL": "µL", "ml": "mL",
          "nl": "nL", "um": "µm", "μm": "µm", "ug": "µg", "μg": "µg", "us": "µs"}


def unit(u: str) -> str:
    """A unit as printed on a figure: ``uL``/``ul`` -> ``µL``, ``um`` -> ``µm`` ..."""
    u = str(u).strip()
    return _UNITS.get(u, re.sub(r"\bu(?=[LlmgsN]\b)", "µ", u).replace("µl", "µL"))


_AMOUNT = re.compile(r"(\d)(\s*)(?:[uμµ]L|[uμµ]l)\b")


def pretty(text: str) -> str:
    """Text as shown on a figure: an amount in microlitres written ``µL`` (``5 uL``, ``5 ul``,
    ``5µl`` -> ``5 µL``, ``5µL``); a file name (``hpt_4uL_25C.txt``) is left as it is."""
    return _AMOUNT.sub(r"\1\2µL", str(text))


def axis_label(quantity: str, symbol: str = "", unit_: str = DIMENSIONLESS) -> str:
    """``"traction coefficient μ (–)"``: words, the symbol, the unit in parentheses."""
    sym = f" {symbol}" if symbol else ""
    return f"{quantity}{sym} ({unit(unit_) if unit_ else DIMENSIONLESS})"


#: symbols of the fitted parameters that are not a layer law's (a layer law's symbols come
#: from its registry, :mod:`torlab.model.layers`; every unit from the fit's own table,
#: :data:`torlab.fit.result.PARAM_UNITS`)
_SYMBOLS = {"eta0": "η0", "alpha": "α", "Z": "Z", "speed_exponent": "n",
            "film_prefactor": "C", "film_at_reference": "h(v_ref)",
            "film_temperature_coefficient": "b", "rig_compliance": "c_rig", "mu0": "μ0",
            "A": "A", "B": "B", "kA": "kA", "kS": "kS", "k0": "k0", "k1": "k1",
            "spread": "s", "transfer": "f_tr"}
#: SI unit -> the unit shown on a figure and the factor to it (one per kind of parameter)
_SHOWN = {"m": ("µm", 1e6), "1/Pa": ("1/GPa", 1e9), "Pa*s": ("mPa·s", 1e3),
          "m/Pa": ("µm/GPa", 1e15), "m^2/J": ("m²/J", 1.0), "-": ("", 1.0)}
#: parameters in metres shown in nm (film thicknesses), not µm (layer lengths)
_NANO = ("film_prefactor", "film_at_reference")


def param_symbol(name: str) -> str:
    """The symbol of a fitted parameter for figures: a layer law's from its registry
    (``mu_c1`` -> ``μc1``, ``mu_c1_T`` -> ``μc1,T``), a limit at the reference temperature
    ``μc1(T_ref)``, the others' from a short table; an unknown name as it is."""
    from torlab.model.layers import all_params

    layer = all_params()
    if name in layer:
        return layer[name].symbol
    if name.endswith("_Tref") and name[:-5] in layer:
        return f"{layer[name[:-5]].symbol}(T_ref)"
    return _SYMBOLS.get(name, name)


def param_unit(name: str, si: str | None = None) -> tuple[str, float]:
    """The unit a parameter is shown in on a figure and the factor from its SI value
    (``L_mue``: µm, 1e6; ``mu_c1_T``: 1/K; a dimensionless one: ``""``).

    ``si``: the parameter's SI unit as its fit states it (:meth:`FitResult.table`'s
    ``unit``, from :data:`torlab.fit.result.PARAM_UNITS`); None: a layer law's from its
    registry, else dimensionless.
    """
    from torlab.model.layers import all_params

    if si is None:
        layer = all_params()
        base = name[:-5] if name.endswith("_Tref") and name[:-5] in layer else name
        si = layer[base].unit if base in layer and base == name else "-"
    if si == "m" and name in _NANO:
        return "nm", 1e9
    return _SHOWN.get(si, (si, 1.0))


def number(v: float, digits: int = 4) -> str:
    """A number for a figure: ``digits`` significant digits, a true minus sign, powers of
    ten written ``×10⁻⁴`` below 1e-3 and from 1e5 on."""
    if not math.isfinite(v):
        return str(v)
    if v != 0 and not 1e-3 <= abs(v) < 1e5:
        m, e = f"{v:.{max(digits - 1, 0)}e}".split("e")
        sup = str(int(e)).translate(str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹"))
        return f"{m}×10{sup}".replace("-", "−")
    return f"{v:.{digits}g}".replace("-", "−")


def param_text(name: str, value: float, digits: int = 4, si: str | None = None) -> str:
    """``"μc1 = 0.1462"``, ``"Lμe = 8.31 µm"``, ``"μc1,T = −5.296×10⁻⁴ 1/K"``: a fitted
    parameter's symbol, value and unit, for a figure's title (``si``: its SI unit,
    :func:`param_unit`)."""
    u, f = param_unit(name, si)
    return f"{param_symbol(name)} = {number(value * f, digits)}" + (f" {u}" if u else "")


def param_label(name: str, si: str | None = None) -> str:
    """An axis label for a parameter: ``"μc1 (–)"``, ``"Lμe (µm)"``."""
    u, _ = param_unit(name, si)
    return f"{param_symbol(name)} ({u or DIMENSIONLESS})"


def fit_units(result: Any) -> dict[str, str]:
    """The SI unit of each parameter of a :class:`~torlab.fit.result.FitResult`, as its
    table states them."""
    t = result.table()
    return {str(n): str(u) for n, u in zip(t["parameter"], t["unit"], strict=True)}


#: the least distance between neighbouring ticks of :func:`plain_log_ticks`, as a part of
#: the span of the values on the log axis (twelve ticks, the most it sets, evenly apart)
LOG_TICK_SPACING = 1 / 12


def plain_log_ticks(axis: Any, values: Any) -> None:
    """Ticks of a logarithmic axis at ``values`` written as plain numbers (1, 2, 4, 8, 16
    rather than 10^0, 10^1), when there are few of them, and no minor ticks (the log
    scale's unlabelled marks at 3, 5, 6, 7, 9, 20, ... mean nothing between ticks at the
    values; drawing them was a sixth of a campaign's amount figure).

    A value closer to the last tick kept than :data:`LOG_TICK_SPACING` of the values'
    span gets none: a panel of products of other densities (applied masses 0.93, 0.95,
    1.86, 1.90 ... 15.2 mg) has its ticks at the first product's values, not two labels
    printed over each other.
    """
    import numpy as np
    from matplotlib.ticker import FixedLocator, NullLocator, ScalarFormatter

    v = np.unique(np.asarray(values, dtype=float))
    v = v[np.isfinite(v) & (v > 0)]
    if v.size > 1:
        step = (v[-1] / v[0]) ** LOG_TICK_SPACING
        kept = [v[0]]
        for x in v[1:]:
            if x >= kept[-1] * step * (1 - 1e-9):  # evenly spaced values all kept
                kept.append(x)
        v = np.asarray(kept)
    if not 1 < v.size <= 12:
        return
    axis.set_major_locator(FixedLocator(v))
    f = ScalarFormatter()
    f.set_scientific(False)
    axis.set_major_formatter(f)
    axis.set_minor_locator(NullLocator())


def pixel_columns(ax: Any, oversample: float = 2.0) -> int:
    """Bins for :func:`decimate` on ``ax``: ``oversample`` times the pixel columns of the
    axes' plotting area in a saved figure (``savefig.dpi``)."""
    fig = ax.get_figure()
    width_in = ax.get_position().width * fig.get_figwidth()
    return max(math.ceil(oversample * width_in * STYLE["savefig.dpi"]), 1)


def decimate(x: Any, y: Any, columns: int, *, log_x: bool = False) -> tuple[Any, Any]:
    """The points of a line that a figure ``columns`` pixels wide can show (M4).

    The x range is cut into ``columns`` equal bins (in log x for ``log_x``), and of the
    points in each bin only the first, the last, the lowest and the highest are kept,
    in their original order (the M4 aggregation of Jugel et al., "M4: a
    visualization-oriented time series data aggregation", Proc. VLDB Endow. 7 (10),
    2014).  A line drawn through them covers, in every bin, the same vertical extent
    as the full line and joins the neighbouring bins at the same points; with bins
    at least as fine as the pixel columns (:func:`pixel_columns` uses twice as
    many) the drawn line reaches the same top and bottom pixel in every column, to
    within the one pixel over which antialiasing spreads a single-sample spike.

    Every extreme (in each bin and so overall) and both endpoints are kept.
    Non-finite points (gaps in a line) are kept where they are and a gap ends a bin's
    run, so the line breaks where it did.  A line of at most ``4 * columns`` points,
    or whose finite x is not monotonic (a loop, which bins of x cannot thin), is
    returned unchanged.

    Parameters
    ----------
    x, y
        The line's coordinates (same length).
    columns
        Number of x bins (at least the pixel columns of the axes).
    log_x
        Bins equal in ``log10(x)`` (a logarithmic x axis); points with ``x <= 0`` are
        kept as they are (matplotlib does not draw them there).

    Returns
    -------
    tuple of numpy.ndarray
        The kept ``x`` and ``y`` (float arrays).
    """
    import numpy as np

    xa = np.asarray(x, dtype=float).ravel()
    ya = np.asarray(y, dtype=float).ravel()
    if xa.shape != ya.shape:
        raise ValueError(f"decimate: x and y differ in length ({xa.size} and {ya.size})")
    n = xa.size
    columns = int(columns)
    if columns < 1 or n <= 4 * columns:
        return xa, ya
    # a long line is read in slices (a few MB of temporaries, not a dozen copies of it)
    inc = dec = True
    prev = lo = hi = math.nan
    nfin = 0
    for s in range(0, n, _SLICE):
        xs, ok = _finite_x(xa[s:s + _SLICE], ya[s:s + _SLICE], log_x)
        xf = xs[ok]
        if not xf.size:
            continue
        step = np.diff(xf, prepend=prev if prev == prev else xf[0])
        inc = inc and bool(np.all(step >= 0))
        dec = dec and bool(np.all(step <= 0))
        prev = float(xf[-1])
        lo, hi = float(np.fmin(lo, xf.min())), float(np.fmax(hi, xf.max()))
        nfin += xf.size
    if nfin < 2 or not (inc or dec) or not hi > lo:
        return xa, ya
    keep: list[Any] = []
    s, run0 = 0, 0
    while s < n:
        e, w = min(s + _SLICE, n), _SLICE // 8
        while True:  # end the slice where a segment starts, so none is cut in two
            stop = min(e + w, n)
            key, ok, runs = _keys(xa[s:stop], ya[s:stop], log_x, lo, hi, columns, run0, s)
            if e >= n:
                cut = n - s
                break
            change = np.flatnonzero(key[e - s:] != key[e - s - 1:-1])
            if change.size:
                cut = e - s + int(change[0])
                break
            if stop >= n:
                cut = n - s
                break
            w *= 2
        key, ok = key[:cut], ok[:cut]
        starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
        ends = np.r_[starts[1:], cut] - 1
        seg = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, cut]))
        yv = np.where(ok, ya[s:s + cut], np.nan)
        idx = np.arange(cut)
        keep += [starts + s, ends + s]
        for reduce in (np.fmin, np.fmax):
            ext = reduce.reduceat(yv, starts)
            hit = ok & (yv == ext[seg])
            first = np.minimum.reduceat(np.where(hit, idx, cut), starts)
            keep.append(first[first < cut] + s)
        run0 = int(runs[cut - 1])
        s += cut
    sel = np.unique(np.concatenate(keep))
    return xa[sel], ya[sel]


#: points of a long line handled at a time by :func:`decimate`
_SLICE = 1 << 18


def _finite_x(x: Any, y: Any, log_x: bool) -> tuple[Any, Any]:
    """The binned x (log10 for ``log_x``) and which points are finite."""
    import numpy as np

    with np.errstate(divide="ignore", invalid="ignore"):
        xs = np.log10(np.where(x > 0, x, np.nan)) if log_x else x
    return xs, np.isfinite(xs) & np.isfinite(y)


def _keys(x: Any, y: Any, log_x: bool, lo: float, hi: float, columns: int, run0: int,
          offset: int) -> tuple[Any, Any, Any]:
    """Segment keys of a slice of a line starting at point ``offset``: consecutive finite
    points in one bin share a key, every non-finite point has its own; ``run0`` counts the
    non-finite points before the slice.  Returns the keys, the finite mask and the running
    count of non-finite points."""
    import numpy as np

    xs, ok = _finite_x(x, y, log_x)
    b = np.zeros(x.size, dtype=np.int64)
    b[ok] = np.minimum(((xs[ok] - lo) / (hi - lo) * columns).astype(np.int64), columns - 1)
    runs = run0 + np.cumsum(~ok)
    key = np.where(ok, runs * (columns + 1) + b, -1 - offset - np.arange(x.size))
    return key, ok, runs


def finite(values: Any) -> bool:
    """Whether any value is finite (something to draw)."""
    try:
        return any(math.isfinite(float(v)) for v in values)
    except TypeError:
        return False
