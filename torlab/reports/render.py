"""Figures as declared plots: drawn only when needed, cached by content, drawn in parallel.

A report or command does not draw its figures itself: it declares each as a
:class:`Plot` -- a module-level drawing function of :mod:`torlab.reports` and the
data it plots.  :func:`render_figures` then

1. keys every figure by the SHA-256 of what it shows (:func:`figure_key`: the
   drawing function, the source of its module and of the style module, the style
   version, the matplotlib and torlab versions, the file format and the plotted
   data itself, encoded by :mod:`torlab.codec`, as the protocol cache encodes results);
2. takes the figures whose key is in the cache (:class:`FigureStore`) as they are
   -- a re-run that changed nothing imports no matplotlib at all;
3. draws the others on the executor (:mod:`torlab.parallel`: one figure per task,
   every requested format from one drawing), and stores them.  A fit figure (one per
   fitted set) is drawn into a figure of the same layout that the same process drew
   before, where it kept one (:func:`draw_task`): the same pixels, about a quarter less
   CPU.

A protocol run starts each section's figures early (:class:`FiguresAhead`), on workers
that would otherwise wait; :func:`render_figures` takes those by what they show.

Formats: PNG by default, SVG and PDF on request (:data:`FORMATS`; ``--formats
png,svg`` on the commands, ``reports.figure_formats`` in a protocol).  SVG and
PDF are written reproducibly (fixed SVG ids, no PDF creation date), so a cached
figure is byte-identical to a fresh one.

A finished matplotlib figure (a :class:`matplotlib.figure.Figure` made by other
code) is accepted too; it is rendered here, not cached.
"""

from __future__ import annotations

import hashlib
import io
import json
import re
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

__all__ = ["DEFAULT_FORMATS", "FORMATS", "PNG_LEVEL", "Drawn", "FiguresAhead", "Plot",
           "RenderStats", "drawing_versions", "early_drawing", "figure_key", "fix_layout",
           "parse_formats", "plot", "plot_digest", "png_bytes", "prepare_drawing", "render",
           "render_all", "render_figures", "write_figures"]

#: file formats torlab writes figures in
FORMATS = ("png", "svg", "pdf")
#: what is written when nothing is asked for
DEFAULT_FORMATS = ("png",)


def parse_formats(value: str | Sequence[str] | None, *, key: str = "--formats") -> tuple[str, ...]:
    """``"png,svg"`` (or a list) -> ``("png", "svg")``; unknown formats are an input error."""
    if value is None:
        return DEFAULT_FORMATS
    parts = value.split(",") if isinstance(value, str) else list(value)
    out: list[str] = []
    for p in parts:
        f = str(p).strip().lower().lstrip(".")
        if not f:
            continue
        if f not in FORMATS:
            from torlab._suggest import did_you_mean
            from torlab.errors import TorlabInputError

            raise TorlabInputError(f"unknown figure format {p!r} (formats: "
                                   f"{', '.join(FORMATS)}){did_you_mean(f, FORMATS)}", key=key)
        if f not in out:
            out.append(f)
    if not out:
        from torlab.errors import TorlabInputError

        raise TorlabInputError(f"give at least one figure format ({', '.join(FORMATS)})", key=key)
    return tuple(out)


@dataclass(frozen=True)
class Plot:
    """A figure to draw: ``func(*args, **kwargs)`` returns a matplotlib figure.

    ``func`` must be a module-level function (figures are drawn in worker
    processes) and the arguments data (tables, arrays, numbers, text, torlab's
    result classes) so that the figure's key is a hash of what it shows.
    """

    func: Callable[..., Any]
    args: tuple = ()
    kwargs: dict[str, Any] = field(default_factory=dict)

    def draw(self) -> Any:
        """The matplotlib figure, laid out (:func:`torlab.reports.plotting.finish`)."""
        from torlab.reports.plotting import finish

        fig = self.func(*self.args, **self.kwargs)
        if not getattr(fig, "_torlab_finished", False):
            finish(fig)
        return fig

    @property
    def name(self) -> str:
        return f"{self.func.__module__}:{self.func.__qualname__}"


def plot(func: Callable[..., Any], *args: Any, **kwargs: Any) -> Plot:
    """Declare a figure (drawn later, if at all): ``plot(traction_figure, curves, title=...)``."""
    return Plot(func, args, kwargs)


# ------------------------------------------------------------------------------ keys
_VERSIONS: dict[str, str] = {}


def _versions() -> str:
    if not _VERSIONS:
        from importlib.metadata import PackageNotFoundError, version

        from torlab import __version__

        try:
            mpl = version("matplotlib")
        except PackageNotFoundError:  # pragma: no cover
            mpl = "?"
        _VERSIONS["v"] = f"torlab {__version__}, matplotlib {mpl}"
    return _VERSIONS["v"]


def drawing_versions() -> str:
    """What a figure's pixels depend on beside its data and torlab's source: the torlab,
    matplotlib and FreeType versions of the process that draws it (figures are drawn on a
    cluster's workers only where these are this process's, :meth:`Executor.agree
    <torlab.parallel.Executor.agree>`: a stored figure is keyed by this process's)."""
    from torlab.reports.plotting import _mpl

    _mpl()
    from matplotlib import ft2font

    return f"{_versions()}, FreeType {ft2font.__freetype_version__}"


def _source_hash(module: str) -> str:
    """SHA-256 of a module's source file (memoised on its modification time)."""
    from torlab.files import sha256_file_cached

    mod = sys.modules.get(module)
    f = getattr(mod, "__file__", None)
    try:
        return sha256_file_cached(f) if f else ""
    except OSError:
        return ""


def plot_digest(p: Plot) -> str | None:
    """The hash of what a figure shows, whatever its format (None if its data cannot be
    encoded): the drawing function, its module's and the style module's source, the
    style, the library versions and the plotted data."""
    from torlab.codec import NotCacheable, digest_value
    from torlab.reports.plotting import STYLE, STYLE_VERSION

    try:
        data = digest_value([list(p.args), p.kwargs])
    except (NotCacheable, ValueError, TypeError, RecursionError):
        return None
    blob = json.dumps({"func": p.name, "source": _source_hash(p.func.__module__),
                       "style_source": _source_hash("torlab.reports.plotting"),
                       "style": [STYLE_VERSION, repr(sorted(STYLE.items()))],
                       "versions": _versions(), "data": data},
                      sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


def figure_key(p: Plot, fmt: str, dpi: float | None = None, *,
               digest: str | None = None) -> str | None:
    """The content key of a figure in one format (None if its data cannot be encoded)."""
    d = digest if digest is not None else plot_digest(p)
    if d is None:
        return None
    return hashlib.sha256(f"{d} {fmt} {dpi}".encode()).hexdigest()[:40]


# ------------------------------------------------------------------------------ drawing
def render(fig: Any, fmt: str, dpi: float | None = None) -> bytes:
    """The bytes of a figure in ``fmt`` (reproducible in every format).

    PNG: matplotlib draws the canvas (its ``rgba`` output, the pixels its own PNG writer
    would get) and :func:`png_bytes` encodes them as they come.
    """
    from torlab.reports.plotting import STYLE

    dpi = dpi or STYLE["savefig.dpi"]
    if fmt == "png":
        sink = _PngSink(fig, dpi)
        with one_glyph_warning():
            fig.savefig(sink, format="rgba", dpi=dpi)
        return sink.value()
    buf = io.BytesIO()
    kw: dict[str, Any] = {}
    if fmt == "pdf":
        kw["metadata"] = {"CreationDate": None, "ModDate": None}
    elif fmt == "svg":
        kw["metadata"] = {"Date": None}
    with one_glyph_warning():
        fig.savefig(buf, format=fmt, dpi=dpi, **kw)
    return buf.getvalue()


#: zlib level of the PNG figures (:func:`png_bytes`; measured in docs/performance.md)
PNG_LEVEL = 3


def png_bytes(rgba: Any, dpi: float, software: str = "") -> bytes:
    """A PNG file of an image: 8-bit RGB (RGBA when any pixel is not opaque), every row
    unfiltered, zlib level :data:`PNG_LEVEL`, with its resolution (``pHYs``) and the
    program that drew it (``Software``).

    matplotlib's PNG writer (Pillow) chooses one of five row filters for every row by
    trying them all: for figures -- large flat areas, thin antialiased lines and text --
    that costs more than the compression and gives larger files than no filter
    (a fit figure: 17 ms and 87 kB against 10 ms and 70 kB).  The rows are compressed
    a block at a time, so no second copy of a large image is made.

    Parameters
    ----------
    rgba
        ``(height, width, 4)`` uint8 pixels, top row first.
    dpi
        Resolution [1/inch].
    software
        The ``Software`` text (none when empty).
    """
    import struct
    import zlib

    import numpy as np

    img = np.asarray(rgba, dtype=np.uint8)
    h, w, _ = img.shape
    c = 3 if int(img[..., 3].min(initial=255)) == 255 else 4
    co = zlib.compressobj(PNG_LEVEL)
    step = max(1, (1 << 20) // (w * c + 1))  # about a megabyte of rows at a time
    rows = np.zeros((min(step, h), 1 + w * c), np.uint8)  # filter byte 0: none
    idat = []
    for r0 in range(0, h, step):
        k = min(step, h - r0)
        px = rows[:k, 1:].reshape(k, w, c)
        for j in range(c):  # channel by channel: 3-4x faster than one strided copy
            px[..., j] = img[r0:r0 + k, :, j]
        idat.append(co.compress(rows[:k].data))
    idat.append(co.flush())

    def chunk(tag: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data)))

    ppm = int(dpi / 0.0254 + 0.5)  # pixels per metre, as Pillow writes it
    return b"".join([b"\x89PNG\r\n\x1a\n",
                     chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2 if c == 3 else 6,
                                                0, 0, 0)),
                     *([chunk(b"tEXt", b"Software\0" + software.encode("latin-1",
                                                                       "replace"))]
                       if software else []),
                     chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1)),
                     chunk(b"IDAT", b"".join(idat)), chunk(b"IEND", b"")])


class _PngSink(io.RawIOBase):
    """The file matplotlib writes a canvas's raw RGBA pixels to (``savefig(format="rgba")``):
    encoded to PNG (:func:`png_bytes`) as they arrive, at the size the canvas has while
    it is saved."""

    def __init__(self, fig: Any, dpi: float) -> None:
        super().__init__()
        self.fig, self.dpi = fig, dpi
        self.png: bytes | None = None
        self.parts: list[bytes] = []

    def writable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        import numpy as np

        w, h = self.fig.canvas.get_width_height(physical=True)
        n = memoryview(data).nbytes
        if self.png is None and not self.parts and n == w * h * 4:
            self.png = png_bytes(np.frombuffer(data, np.uint8).reshape(h, w, 4), self.dpi,
                                 _software())
        else:  # pieces (not what matplotlib does): gathered, encoded at the end
            self.parts.append(bytes(data))
            self.size = (w, h)
        return n

    def value(self) -> bytes:
        if self.png is None:
            import numpy as np

            w, h = self.size
            self.png = png_bytes(np.frombuffer(b"".join(self.parts), np.uint8)
                                 .reshape(h, w, 4), self.dpi, _software())
        return self.png


def _software() -> str:
    """The ``Software`` text of a PNG (matplotlib's own)."""
    import matplotlib

    return f"Matplotlib version{matplotlib.__version__}, https://matplotlib.org/"


_GLYPH_DEPTH = [0]


@contextmanager
def one_glyph_warning() -> Iterator[None]:
    """Inside: matplotlib's warnings about characters its font lacks are gathered into one
    warning (:func:`_glyph_warnings`); nested uses gather into the outermost."""
    if _GLYPH_DEPTH[0]:
        yield
        return
    _GLYPH_DEPTH[0] += 1
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield
    finally:
        _GLYPH_DEPTH[0] -= 1
    _glyph_warnings(caught)


_GLYPH = re.compile(r"Glyph (\d+) .*missing from font\(s\) (.+?)\.?$")


def _glyph_warnings(caught: Sequence[Any]) -> None:
    """matplotlib warns once per character its font cannot draw ("Glyph 28070 missing from
    font(s) DejaVu Sans"): these become one warning naming the characters; any other
    warning is passed on as it was."""
    missing: dict[str, None] = {}
    font = ""
    for w in caught:
        m = _GLYPH.match(str(w.message))
        if m:
            missing[chr(int(m.group(1)))] = None
            font = m.group(2)
            continue
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if missing:
        from torlab.errors import TorlabWarning

        chars = "".join(missing)
        warnings.warn(TorlabWarning(f"figures: {len(chars)} character(s) of the labels are not "
                                    f"in the font {font} and are drawn as boxes: {chars}"),
                      stacklevel=3)


def prepare_drawing() -> None:
    """Load what drawing a figure needs -- matplotlib with torlab's style, its Agg canvas,
    its fonts and the PNG writer -- by drawing a throwaway figure."""
    from torlab.reports.plotting import subplots

    fig, ax = subplots()
    ax.set_xlabel("x")
    fig.savefig(io.BytesIO(), format="png")


def _load_drawing() -> None:
    """The modules of :func:`prepare_drawing` without its throwaway figure (what an early
    worker loads: the figure it then draws loads the rest)."""
    import importlib

    from torlab.reports.plotting import _mpl

    _mpl()
    for m in ("matplotlib.backends.backend_agg", "matplotlib.font_manager", "PIL.PngImagePlugin"):
        importlib.import_module(m)


@contextmanager
def early_drawing(enabled: bool = True, jobs: int | None = None,
                  scheduler: str | None = None) -> Iterator[Any]:
    """A worker process that loads matplotlib now, while the command computes, and draws
    its figures at the end (:class:`torlab.parallel.WarmWorker`): pass what this yields
    as ``executor=`` to :func:`write_figures`.  Yields None when ``enabled`` is false or
    a second process would not help (``--jobs 1``, ``--scheduler``, one core): the
    figures are then drawn on the command's executor as usual.  The worker is stopped
    when the block ends, whatever happens in it."""
    from torlab.parallel import warm_worker

    worker = warm_worker([_load_drawing], jobs, scheduler) if enabled else None
    try:
        yield worker
    finally:
        if worker is not None:
            worker.close()


class Drawn(dict):  # type: ignore[type-arg]
    """A drawn figure's images by format (or, :func:`draw_to_files`, their files) and
    ``cpu_seconds``, the CPU time of drawing them (the drawing thread's, wherever it ran):
    a run adds them up (:attr:`RenderStats.cpu_seconds`), so the figures' share of the
    run's CPU is measured, not only the wall time left when the rest is done."""

    def __init__(self, items: Any = (), cpu_seconds: float = 0.0) -> None:
        super().__init__(items)
        self.cpu_seconds = cpu_seconds


def draw_task(task: tuple[Plot, tuple[str, ...], float | None]) -> Drawn:
    """Draw one figure and render it in each format (a task for the executor).

    A drawing function with a ``redraw`` attribute (:func:`torlab.reports.fit.result_figure`,
    drawn once per fitted set: 192 times in a campaign of 16 seeds) draws a PNG-only figure
    into a figure of the same layout it drew before in this process, where there is one
    (:func:`_figure`): the same pixels as a new figure, at less of matplotlib's work.
    """
    p, formats, dpi = task
    t0 = time.thread_time()
    with one_glyph_warning():
        fig, key = _figure(p, formats, dpi)
        kept = False
        try:
            out = render_all(fig, formats, dpi)
            if key is not None:  # kept only when rendered without an error
                _keep(key, fig)
                kept = True
            return Drawn(out, time.thread_time() - t0)
        finally:
            w, h = fig.get_size_inches() * (dpi or fig.dpi)
            if not kept:
                _close(fig)
            del fig
            if w * h > _LARGE_PIXELS:  # a campaign-wide figure: its memory given back
                import gc

                from torlab.parallel import trim_memory

                gc.collect()  # its artists refer to each other: freed by the collector only
                trim_memory()


#: figures kept for drawing again (:func:`_figure`): ``(function, resolution, layout) ->
#: (matplotlib settings, figure)``, the most recently used last
_KEPT: dict[tuple[str, float | None, Any], tuple[Any, Any]] = {}
#: the most figures kept in a process (the least recently used is dropped first): a
#: campaign's fit figures have two layouts (the HPT layer fits' and the temperature fits')
KEEP = 4


def _figure(p: Plot, formats: Sequence[str], dpi: float | None) -> tuple[Any, Any]:
    """The finished figure of ``p`` and the key under which to keep it (None: not kept).

    A plot whose function has a ``redraw`` attribute is drawn through it when only PNG is
    asked for (what torlab writes unless told otherwise; SVG and PDF files are always drawn
    from a new figure): ``redraw(take, *args, **kwargs) -> (figure, layout)``, where
    ``take(layout)`` hands over the figure of that layout kept from before (or None) and
    ``layout`` (hashable) says what must agree for a figure to be refilled (None: never
    kept).  A kept figure counts only at the same resolution and matplotlib settings
    (``rcParams``) it was drawn with, and is taken out while it is drawn (a failed drawing
    leaves none behind; a second thread draws its own).
    """
    redraw = getattr(p.func, "redraw", None)
    if redraw is None or tuple(formats) != ("png",):
        return p.draw(), None
    from torlab.reports.plotting import _mpl, finish

    rc = _mpl().rcParams.copy()  # (a copy that resolves no backend, imports no pyplot)

    def take(layout: Any) -> Any:
        kept = _KEPT.pop((p.name, dpi, layout), None)
        return kept[1] if kept is not None and kept[0] == rc else None

    fig, layout = redraw(take, *p.args, **p.kwargs)
    if not getattr(fig, "_torlab_finished", False):
        finish(fig)
    fig._torlab_rc = rc
    return fig, None if layout is None else (p.name, dpi, layout)


def _keep(key: Any, fig: Any) -> None:
    """Keep a rendered figure for :func:`_figure` (at most :data:`KEEP`), without the
    renderer it was saved with (its pixels, 4-5 MB for a fit figure; the next drawing makes
    its own): the canvas and every text (which remembers the renderer it was last drawn
    with) let go of it."""
    from matplotlib.text import Text

    canvas = fig.canvas
    canvas.__dict__.pop("renderer", None)
    canvas._lastKey = None
    for text in fig.findobj(Text):
        text._renderer = None
    _KEPT[key] = (fig.__dict__.pop("_torlab_rc"), fig)
    while len(_KEPT) > KEEP:
        _close(_KEPT.pop(next(iter(_KEPT)))[1])


#: a figure of more pixels than this gives its memory back when drawn (a campaign's
#: amount figure of 64 products, 2040 x 5266 pixels, left about 60 MB of freed but
#: resident memory in the worker that drew it, on top of which the next one was drawn).
#: A figure's artists refer to each other, so they are freed by the cyclic garbage
#: collector, not when the figure is let go: it runs first (a 16x campaign's traction
#: page left 32 MB resident after the trim without it, none with it)
_LARGE_PIXELS = 4e6


def render_all(fig: Any, formats: Sequence[str], dpi: float | None = None) -> dict[str, bytes]:
    """A figure in each format, laid out once (:func:`fix_layout`); the figure is spent
    (its layout no longer follows changes)."""
    fix_layout(fig, dpi)
    return {f: render(fig, f, dpi) for f in formats}


def fix_layout(fig: Any, dpi: float | None = None) -> None:
    """Lay out a figure with a layout engine (the constrained layout of
    :func:`torlab.reports.plotting.facets`) once, at the saving resolution, and keep it.

    ``savefig`` on such a figure draws it twice -- once without output, for the layout,
    then for real -- and the engine lays it out again on each draw, measuring every tick
    label, title and legend: four passes over the figure's text for one image, and more
    with every further format.  Here the engine runs once (it iterates to its own fixed
    point) and is then removed, so each format is one drawing with the same positions.
    Figures of the fixed layout (:func:`torlab.reports.plotting.subplots`) are left alone.
    """
    from torlab.reports.plotting import STYLE

    engine = fig.get_layout_engine()
    if engine is None:
        return
    fig.set_dpi(dpi or STYLE["savefig.dpi"])  # what savefig draws at (text snaps to pixels)
    engine.execute(fig)
    fig.set_layout_engine(None)


def _close(fig: Any) -> None:
    plt = sys.modules.get("matplotlib.pyplot")
    if plt is not None:  # a pyplot figure made by other code: release its manager
        plt.close(fig)


@dataclass
class RenderStats:
    """What :func:`render_figures` did: figures drawn and reused, seconds spent.

    ``ahead``: how many of the drawn figures were drawn in the background before
    (:class:`FiguresAhead`), while other work ran; ``seconds`` is the time spent in
    :func:`render_figures` itself; ``cpu_seconds`` the CPU time of drawing the figures
    drawn, wherever they were drawn (:class:`Drawn`).
    """

    drawn: int = 0
    reused: int = 0
    seconds: float = 0.0
    ahead: int = 0
    cpu_seconds: float = 0.0

    def add(self, other: RenderStats) -> None:
        self.drawn += other.drawn
        self.reused += other.reused
        self.seconds += other.seconds
        self.ahead += other.ahead
        self.cpu_seconds += other.cpu_seconds


def render_figures(items: Sequence[tuple[str, Any]], formats: Sequence[str] = DEFAULT_FORMATS, *,
                   store: Any = None, executor: Any = None, dpi: float | None = None,
                   description: str = "drawing figures", ahead: FiguresAhead | None = None,
                   each: Callable[[str, dict[str, bytes]], Any] | None = None
                   ) -> tuple[dict[str, Any], RenderStats]:
    """Every figure in every format: ``{name: {format: bytes}}`` and the statistics.

    Parameters
    ----------
    items
        ``(name, Plot or matplotlib figure)``.
    formats
        File formats (:data:`FORMATS`).
    store
        A :class:`FigureStore` (the protocol cache's): figures whose key it holds
        are reused, new ones stored.  None: everything is drawn.
    executor
        Where figures are drawn (:mod:`torlab.parallel`; default :func:`~torlab.parallel.current`).
    ahead
        Figures started earlier (:class:`FiguresAhead`, same formats and dpi): a figure
        that shows the same as one of them is taken from there.
    each
        ``each(name, images)`` is called as each figure is ready (stored, if there is a
        store), in any order, and its return value is kept instead of the images: a
        caller that writes the figures away holds only those still being written, not
        every figure of a large run at once.
    """
    from torlab.parallel import current

    t0 = time.perf_counter()
    stats = RenderStats()
    formats = tuple(formats)
    out: dict[str, Any] = {}
    todo: list[tuple[str, Plot, dict[str, str | None]]] = []

    def one(name: str, p: Any) -> None:
        """A figure from elsewhere drawn here, one drawn ahead, one the store holds; the
        others left to draw (``todo``)."""
        if not isinstance(p, Plot):  # a figure drawn by other code
            t0 = time.thread_time()
            try:
                from torlab.reports.plotting import finish

                if not getattr(p, "_torlab_finished", False) and hasattr(p, "_torlab_margins"):
                    finish(p)
                res = render_all(p, formats, dpi)
            finally:
                _close(p)
            stats.cpu_seconds += time.thread_time() - t0  # drawing it, not writing it
            out[name] = res if each is None else each(name, res)
            stats.drawn += 1
            return
        dg = (ahead.digest(p) if ahead is not None else plot_digest(p)) \
            if store is not None or ahead is not None else None
        keys = {f: figure_key(p, f, dpi, digest=dg) if dg is not None else None
                for f in formats}
        early = ahead.take(dg) if ahead is not None and dg is not None else None
        if early is not None:  # drawn in the background while the run computed
            out[name] = _new_figure(name, keys, early, store, each)
            stats.ahead += 1
            stats.drawn += 1
            stats.cpu_seconds += early.cpu_seconds
            return
        got = {f: store.get(keys[f], f) for f in formats if keys[f] is not None} \
            if store is not None else {}
        if len(got) == len(formats) and all(v is not None for v in got.values()):
            out[name] = got if each is None else each(name, got)  # type: ignore[arg-type]
            stats.reused += 1
            return
        todo.append((name, p, keys))

    from torlab.progress import current as progress

    # the figures drawn ahead are waited for one at a time, in order (each written away
    # by ``each`` before the next is taken)
    with progress().task(description if ahead is not None else "",
                         len(items) if ahead is not None else 0) as advance:
        for name, p in items:
            one(name, p)
            advance()
    if todo:
        ex = executor if executor is not None else current()
        if not ex.agree(drawing_versions):  # a cluster that would draw otherwise: here
            from torlab.parallel import SerialExecutor

            ex = SerialExecutor()

        def drawn(i: int, res: Drawn) -> None:
            stats.cpu_seconds += res.cpu_seconds
            out[todo[i][0]] = _new_figure(todo[i][0], todo[i][2], res, store, each)

        ex.map(draw_task, [(p, formats, dpi) for _, p, _ in todo], description=description,
               each=drawn)
        stats.drawn += len(todo)
    stats.seconds = time.perf_counter() - t0
    return {name: out[name] for name, _ in items if name in out}, stats


def draw_to_files(task: tuple[Plot, tuple[str, ...], float | None, str]) -> Drawn:
    """:func:`draw_task`, the images written to files in a folder (the last item) instead
    of returned: ``{format: file}``.  A figure drawn ahead on a local worker waits there,
    not in the memory of the process that will write it (:class:`FiguresAhead`)."""
    import os
    import tempfile

    *job, folder = task
    drawn = draw_task(tuple(job))  # type: ignore[arg-type]
    out = Drawn(cpu_seconds=drawn.cpu_seconds)
    for fmt, data in drawn.items():
        fd, path = tempfile.mkstemp(suffix=f".{fmt}", dir=folder)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        out[fmt] = path
    return out


def _read_drawn(files: dict[str, str], folder: str) -> Drawn:
    """The images :func:`draw_to_files` wrote (files of ``folder`` only), the files
    removed."""
    import os

    out = Drawn(cpu_seconds=getattr(files, "cpu_seconds", 0.0))
    for fmt, path in files.items():
        if os.path.dirname(os.path.abspath(path)) != os.path.abspath(folder):
            raise ValueError(f"a drawn figure outside its folder: {path}")
        with open(path, "rb") as f:
            out[fmt] = f.read()
        os.unlink(path)
    return out


def _new_figure(name: str, keys: dict[str, str | None], images: dict[str, bytes], store: Any,
                each: Callable[[str, dict[str, bytes]], Any] | None) -> Any:
    """A figure drawn (here or ahead): into the store, then to ``each``."""
    if store is not None:
        for f, k in keys.items():
            if k is not None:
                store.put(k, f, images[f])
    return images if each is None else each(name, images)


class FiguresAhead:
    """Figures drawn in the background (:meth:`torlab.parallel.Executor.background`) before
    they are written: a protocol run starts each report section's figures as soon as the
    section is built, and they are drawn whenever a worker would otherwise wait (between
    and at the ends of the later sections' computations).  :func:`render_figures` takes
    them by what they show (:func:`plot_digest`), so a figure is the same whether it was
    drawn ahead or not.

    Parameters
    ----------
    formats, dpi
        As for :func:`render_figures` (the same must be asked there).
    store
        A :class:`FigureStore`: figures it holds are not drawn ahead (they are reused, read
        from the store when they are written: a run that reuses most of its figures does
        not hold their images while it computes -- about 20 MB of PNG at a 64x campaign).
    executor
        Where they are drawn (default :func:`~torlab.parallel.current`); on a Dask
        cluster only if its workers draw as this process would (:func:`drawing_versions`),
        else nothing is drawn ahead (:func:`render_figures` draws them here).
    """

    def __init__(self, formats: Sequence[str] = DEFAULT_FORMATS, *, store: Any = None,
                 executor: Any = None, dpi: float | None = None) -> None:
        from torlab.parallel import current

        self.formats, self.dpi, self.store = tuple(formats), dpi, store
        self.executor = executor if executor is not None else current()
        # local workers write what they drew to files of a folder of this run's own (read
        # when the figure is taken): the figures drawn while the run computes are not all
        # held in this process (at a 64x campaign ~100 MB of PNG); a cluster's workers
        # may be on other machines: their images come back as bytes
        self._folder: str | None = None
        self._digests: dict[int, tuple[Any, str | None]] = {}
        # digest -> (batch, index, the folder its images are written to or None)
        self._started: dict[str, tuple[Any, int, str | None]] = {}
        self._stored: set[str] = set()  # the digests the store holds (not drawn ahead)
        self._batches: list[Any] = []

    def digest(self, p: Plot) -> str | None:
        """:func:`plot_digest`, computed once per plot."""
        got = self._digests.get(id(p))
        if got is None or got[0] is not p:
            got = (p, plot_digest(p))
            self._digests[id(p)] = got
        return got[1]

    def start(self, items: Sequence[tuple[str, Any]]) -> int:
        """Start drawing the :class:`Plot` items not in the store; returns how many."""
        if not self.executor.agree(drawing_versions):
            return 0
        todo: list[tuple[str, Plot]] = []
        for _, p in items:
            if not isinstance(p, Plot):
                continue
            dg = self.digest(p)
            if dg is None or dg in self._started or dg in self._stored \
                    or any(d == dg for d, _ in todo):
                continue
            if self.store is not None and all(
                    self.store.has(figure_key(p, f, self.dpi, digest=dg), f)
                    for f in self.formats):  # reused, not drawn (read when written)
                self._stored.add(dg)
                continue
            todo.append((dg, p))
        if not todo:
            return 0
        folder = self._spill_folder()
        jobs = [(p, self.formats, self.dpi) for _, p in todo]
        batch = self.executor.background(
            draw_task if folder is None else draw_to_files,
            jobs if folder is None else [(*j, folder) for j in jobs],
            description="drawing figures")
        self._batches.append(batch)
        for i, (dg, _) in enumerate(todo):
            self._started[dg] = (batch, i, folder)
        return len(todo)

    def _spill_folder(self) -> str | None:
        """The folder local workers write the figures they draw ahead to (made once), or
        None where the images come back as bytes (a cluster, serial work)."""
        if getattr(self.executor, "kind", "") != "processes":
            return None
        if self._folder is None:
            import shutil
            import tempfile
            import weakref

            self._folder = tempfile.mkdtemp(prefix="torlab-figures-")
            weakref.finalize(self, shutil.rmtree, self._folder, ignore_errors=True)
        return self._folder

    def take(self, digest: str) -> Drawn | None:
        """The figure with this digest in every format, if it was started (waits for it)."""
        got = self._started.get(digest)
        if got is None:
            return None
        batch, i, folder = got
        del self._started[digest]
        out = batch.take(i)  # not kept here: the caller writes it away
        return out if folder is None else _read_drawn(out, folder)

    def cancel(self) -> None:
        """Drop the figures not started yet (a run that failed)."""
        for b in self._batches:
            b.cancel()
        self.close()

    def close(self) -> None:
        """Remove the folder of the figures drawn ahead (those not taken with it)."""
        if self._folder is not None:
            import shutil

            shutil.rmtree(self._folder, ignore_errors=True)
            self._folder = None


def write_figures(dest: Any, items: Sequence[tuple[str, Any]],
                  formats: Sequence[str] = DEFAULT_FORMATS, *, store: Any = None,
                  executor: Any = None, dpi: float | None = None) -> tuple[list[str], RenderStats]:
    """Render figures and write ``<name>.<format>`` into an :class:`~torlab.outputs.OutputDir`
    (a file of the earlier results with the same bytes is kept, not rewritten).

    Returns the file names written and the :class:`RenderStats`.
    """
    def write(name: str, images: dict[str, bytes]) -> None:  # as each figure is ready
        for f in formats:  # an earlier result's file with the same bytes is kept as it is
            dest.write_bytes(f"{name}.{f}", images[f], keep_same=True)

    _, stats = render_figures(items, formats, store=store, executor=executor, dpi=dpi,
                              each=write)
    return [f"{name}.{f}" for name, _ in items for f in formats], stats
