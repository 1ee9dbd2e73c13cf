"""How a local pool spends its cores: blocks of short tasks, workers forked before the
modules they do not use are loaded, and background tasks that only take idle workers.

These change where time goes, never a result: every test here checks results, order,
warnings and errors (the first in task order), and the ordering rules themselves --
which process has which module, which task started before which -- not durations.
"""

from __future__ import annotations

import sys
import time
import types
import warnings

import pytest

from tests.test_parallel import _fail, _square, _warn
from tests.test_prepare import small_fit_protocol
from torlab.errors import TorlabInputError, TorlabWarning
from torlab.parallel import ProcessExecutor, SerialExecutor

LINUX = sys.platform.startswith("linux")


def _stamp(job: tuple[str, float]) -> tuple[str, float]:
    """Sleep, then say which task this was and when it started."""
    name, sleep = job
    t = time.time()
    time.sleep(sleep)
    return name, t


def _loaded(name: str) -> bool:
    return name in sys.modules


def _slow_loaded(name: str) -> bool:
    time.sleep(0.5)  # long enough for the parent to load the module meanwhile
    return name in sys.modules


# ------------------------------------------------------------------------------ blocks
def test_blocks_of_tasks_keep_order_warnings_and_the_first_error():
    with ProcessExecutor(2) as ex:
        for size in (1, 2, 3, 4, 7, 50):
            assert ex.map(_square, range(23), chunksize=size) == [x * x for x in range(23)]
            with warnings.catch_warnings(record=True) as w:
                warnings.simplefilter("always")
                assert ex.map(_warn, [1, 2, 3], chunksize=size) == [1, 2, 3]
            said = [str(x.message) for x in w if issubclass(x.category, TorlabWarning)]
            assert sorted(said) == ["task 1 says so", "task 2 says so", "task 3 says so"]
            # 3 and 5 fail: in one block or in two, 3 is raised, as itself
            with pytest.raises(TorlabInputError, match="bad 3"):
                ex.map(_fail, range(9), chunksize=size)


def test_serial_map_takes_and_ignores_the_block_size():
    assert SerialExecutor().map(_square, range(5), chunksize=3) == [0, 1, 4, 9, 16]


# ------------------------------------------------------------------------------ uses
@pytest.fixture
def fresh_module(tmp_path, monkeypatch):
    """The name of a module no test has loaded (written for this test, on ``sys.path``;
    forked workers inherit the path)."""
    name = f"torlab_probe_{tmp_path.name.replace('-', '_')}"
    (tmp_path / f"{name}.py").write_text("VALUE = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield name
    sys.modules.pop(name, None)


@pytest.mark.skipif(not LINUX, reason="workers are forked on Linux")
def test_workers_start_before_what_their_tasks_do_not_use_and_get_it_at_the_next_map(
        fresh_module):
    """A map with ``uses=()`` forks its workers without the prepared module and loads it in
    this process while they work; the next map that uses it forks the workers again,
    with it."""
    name = fresh_module
    assert name not in sys.modules
    ex = ProcessExecutor(2)
    ex.prepare(name)
    with ex:
        first = ex.map(_slow_loaded, [name] * 2, uses=())
        assert first == [False, False]      # forked before it was loaded
        assert name in sys.modules          # loaded here while they worked
        pool = ex._pool
        assert ex.map(_loaded, [name] * 4) == [True] * 4   # forked again, with it
        assert ex._pool is not pool
        pool = ex._pool
        assert ex.map(_loaded, [name] * 4, uses=()) == [True] * 4
        assert ex._pool is pool             # nothing new to inherit: the same workers


# ------------------------------------------------------------------------------ background
def test_background_results_in_order_with_warnings_and_the_first_error():
    for ex in (SerialExecutor(), ProcessExecutor(2)):
        with ex:
            bg = ex.background(_square, range(9))
            assert ex.map(_square, range(4)) == [0, 1, 4, 9]  # a map meanwhile
            assert bg.results() == [x * x for x in range(9)], ex.kind
            assert bg.results() == [x * x for x in range(9)]  # asked again: the same
            bg = ex.background(_warn, [1, 2])
            with warnings.catch_warnings(record=True) as w:
                warnings.simplefilter("always")
                assert bg.results() == [1, 2]
            said = sorted(str(x.message) for x in w if issubclass(x.category, TorlabWarning))
            assert said == ["task 1 says so", "task 2 says so"], ex.kind
            with pytest.raises(TorlabInputError, match="bad 3"):
                ex.background(_fail, range(7)).results()


_CALLS: list[int] = []


def _count(x: int) -> int:
    _CALLS.append(x)
    return x


def test_serial_background_runs_when_its_results_are_asked_for():
    _CALLS.clear()
    bg = SerialExecutor().background(_count, [1, 2, 3])
    assert _CALLS == []
    assert bg.results() == [1, 2, 3] and _CALLS == [1, 2, 3]


@pytest.mark.skipif(not LINUX, reason="the background feed is for forked workers")
def test_background_tasks_never_queue_ahead_of_a_map():
    """Background tasks take only idle workers: of six, two start at once on the idle pool;
    a map's tasks submitted next start before any other background task."""
    with ProcessExecutor(2) as ex:
        ex.map(_square, range(2))  # workers up
        bg = ex.background(_stamp, [(f"bg{i}", 0.3) for i in range(6)])
        time.sleep(0.1)  # the feed has given the idle workers their first two
        fg = ex.map(_stamp, [("fg0", 0.05), ("fg1", 0.05)])
        got = bg.results()
    assert [n for n, _ in got] == [f"bg{i}" for i in range(6)]
    starts = sorted(got + fg, key=lambda r: r[1])
    order = [n for n, _ in starts]
    assert set(order[:2]) == {"bg0", "bg1"}, order
    assert set(order[2:4]) == {"fg0", "fg1"}, order


@pytest.mark.skipif(not LINUX, reason="workers are forked on Linux")
def test_no_new_workers_while_background_tasks_run():
    """A need prepared while background tasks run does not fork the pool again under them
    (the tasks would be lost): the map runs on the same workers, which import it
    themselves; once the background is done, the next map forks again."""
    with ProcessExecutor(2) as ex:
        ex.map(_square, range(2))
        pool = ex._pool
        bg = ex.background(_stamp, [(f"bg{i}", 0.2) for i in range(4)])
        ex.prepare("xml.dom.minidom")
        assert ex.map(_square, range(4)) == [0, 1, 4, 9]
        assert ex._pool is pool
        assert [n for n, _ in bg.results()] == ["bg0", "bg1", "bg2", "bg3"]
        assert ex.map(_loaded, ["xml.dom.minidom"] * 2) == [True, True]
        assert ex._pool is not pool


@pytest.mark.skipif(not LINUX, reason="the background feed is for forked workers")
def test_cancelled_background_says_so():
    with ProcessExecutor(2) as ex:
        bg = ex.background(_stamp, [(f"bg{i}", 0.2) for i in range(8)])
        bg.cancel()
        with pytest.raises(RuntimeError, match="cancelled"):
            bg.results()
        assert ex.map(_square, range(3)) == [0, 1, 4]  # the pool is still fine


# ------------------------------------------------------------------------------ figures ahead
def _plots():
    import numpy as np
    import pandas as pd

    from torlab.reports.predict import traction_figure
    from torlab.reports.render import plot

    xi = np.linspace(0, 0.01, 21)
    out = []
    for k in (1.0, 2.0):
        t = pd.DataFrame({"creepage": xi, "mu": 0.3 * np.tanh(k * 200 * xi)})
        out.append((f"f{k:g}", plot(traction_figure, [("a", t)], title=f"k = {k:g}")))
    return out


def test_figures_drawn_ahead_are_the_figures_drawn_at_the_end(tmp_path):
    from torlab.protocols.cache import FigureStore, ResultCache
    from torlab.reports.render import FiguresAhead, render_figures

    items = _plots()
    plain, st0 = render_figures(items, ("png",))
    assert (st0.drawn, st0.ahead) == (2, 0)
    for ex in (SerialExecutor(), ProcessExecutor(2)):
        with ex:
            store = FigureStore(ResultCache(tmp_path / f"cache-{ex.kind}"))
            ahead = FiguresAhead(("png",), store=store, executor=ex)
            assert ahead.start(items[:1]) == 1
            assert ahead.start(items[:1]) == 0  # started already
            got, st = render_figures(items, ("png",), store=store, executor=ex, ahead=ahead)
            assert (st.drawn, st.ahead, st.reused) == (2, 1, 0), ex.kind
            assert got == plain, ex.kind
            # both are in the store now: none is drawn ahead again, both are reused,
            # each read from the store once
            hits = store.hits
            again = FiguresAhead(("png",), store=store, executor=ex)
            assert again.start(items) == 0
            got, st = render_figures(items, ("png",), store=store, executor=ex, ahead=again)
            assert (st.drawn, st.reused) == (0, 2) and got == plain
            assert store.hits - hits == 2


def test_figures_cpu_time_counted_wherever_they_are_drawn(tmp_path, monkeypatch):
    """Each drawn figure carries the CPU time of its drawing (its thread's), through a
    worker's pipe and a file drawn ahead; a run adds up those of the figures it drew,
    none for the figures the store gave back, and reports it (``figures_cpu``)."""
    import pickle
    import time

    from torlab.protocols.cache import FigureStore, ResultCache
    from torlab.reports import render as render_mod
    from torlab.reports.render import Drawn, FiguresAhead, draw_task, render_figures

    items = _plots()
    t0 = time.thread_time()
    one = draw_task((items[0][1], ("png",), None))
    spent = time.thread_time() - t0
    assert isinstance(one, Drawn) and 0 < one.cpu_seconds <= spent
    back = pickle.loads(pickle.dumps(one))
    assert back == one and back.cpu_seconds == one.cpu_seconds
    _, st = render_figures(items, ("png",))
    assert st.drawn == 2 and st.cpu_seconds > 0
    with ProcessExecutor(2) as ex:
        store = FigureStore(ResultCache(tmp_path / "cache"))
        ahead = FiguresAhead(("png",), store=store, executor=ex)
        ahead.start(items[:1])
        worker_cpu = []
        real = render_mod._new_figure

        def spy(name, keys, images, store, each):
            worker_cpu.append(images.cpu_seconds)
            return real(name, keys, images, store, each)

        monkeypatch.setattr(render_mod, "_new_figure", spy)
        _, st = render_figures(items, ("png",), store=store, executor=ex, ahead=ahead)
        monkeypatch.undo()
        assert (st.drawn, st.ahead) == (2, 1)
        assert len(worker_cpu) == 2 and all(c > 0 for c in worker_cpu)
        assert st.cpu_seconds == pytest.approx(sum(worker_cpu))
        _, st = render_figures(items, ("png",), store=store, executor=ex)
        assert (st.reused, st.cpu_seconds) == (2, 0.0)


def test_figures_handed_on_as_they_are_ready_and_not_held(tmp_path):
    """With ``each``, every figure -- drawn ahead, drawn at the end or reused from the
    store -- goes to it once, with the bytes of a plain drawing, and what it returns is
    kept instead; a figure drawn ahead is no longer held by the background work once
    taken."""
    from torlab.protocols.cache import FigureStore, ResultCache
    from torlab.reports.render import FiguresAhead, render_figures

    items = _plots()
    plain, _ = render_figures(items, ("png",))
    with ProcessExecutor(2) as ex:
        store = FigureStore(ResultCache(tmp_path / "cache"))
        ahead = FiguresAhead(("png",), store=store, executor=ex)
        ahead.start(items[:1])
        batch = ahead._batches[0]
        seen: dict[str, bytes] = {}

        def each(name, images):
            assert name not in seen
            seen[name] = images["png"]
            return len(images["png"])

        got, st = render_figures(items, ("png",), store=store, executor=ex, ahead=ahead,
                                 each=each)
        assert (st.drawn, st.ahead) == (2, 1)
        assert list(got) == [n for n, _ in items]  # in the items' order
        assert seen == {n: v["png"] for n, v in plain.items()}
        assert got == {n: len(v["png"]) for n, v in plain.items()}
        with pytest.raises(RuntimeError, match="taken"):
            batch.take(0)  # taken: not kept by the background work
        seen.clear()
        got, st = render_figures(items, ("png",), store=store, executor=ex, each=each)
        assert (st.drawn, st.reused) == (0, 2) and seen == {n: v["png"] for n, v in plain.items()}


@pytest.mark.skipif(not LINUX, reason="glibc's malloc_trim")
def test_freed_memory_is_given_back_to_the_system():
    """Memory freed among objects that stay (the heap's free pages) is resident until
    :func:`torlab.parallel.trim_memory` gives it back."""
    from torlab.parallel import trim_memory

    def anon_mb():
        with open("/proc/self/status") as f:
            return next(int(x.split()[1]) for x in f if x.startswith("RssAnon")) / 1024

    blocks = [bytearray(b"x" * 60_000) for _ in range(1500)]  # 90 MB from the heap
    keep = [bytearray(64) for _ in range(1500)]  # small objects between them stay
    before = anon_mb()
    del blocks
    freed = anon_mb()
    trim_memory()
    after = anon_mb()
    assert before - after > 50, (before, freed, after)
    assert keep


#: weak references to the figures :func:`_figure_of` made
_MADE: list = []


def _figure_of(side_in: float):
    """A square figure of ``side_in`` inches, a weak reference to it kept in :data:`_MADE`."""
    import weakref

    from matplotlib.figure import Figure

    fig = Figure(figsize=(side_in, side_in))
    fig.add_subplot().plot([0.0, 1.0], [0.0, 1.0])
    fig._torlab_finished = True  # (torlab's margins are for its own figures)
    _MADE.append(weakref.ref(fig))
    return fig


def test_a_campaign_wide_figure_is_freed_as_soon_as_it_is_drawn():
    """A figure's artists refer to each other, so only the cyclic collector frees them; a
    figure of more than ``_LARGE_PIXELS`` is collected (and its memory trimmed) when drawn,
    not whenever the collector next runs -- a worker's next figure is drawn on the memory
    given back.  A small one is left to the collector (the check can see a live figure)."""
    import gc

    from torlab.reports.render import _LARGE_PIXELS, Plot, draw_task

    large = (2 * _LARGE_PIXELS) ** 0.5 / 100  # inches at 100 dpi
    gc.collect()
    gc.disable()
    try:
        draw_task((Plot(_figure_of, (1.0,)), ("png",), 100.0))
        small_alive = _MADE[-1]() is not None
        draw_task((Plot(_figure_of, (large,)), ("png",), 100.0))
        assert _MADE[-1]() is None
    finally:
        gc.enable()
    assert small_alive


def test_sections_built_in_report_order_with_the_fits_first_when_nothing_adds_to_them(
        monkeypatch):
    """The fitted sets are built (and their figures started) first unless the film or the
    retention section adds to them; the report's order is the same either way."""
    import torlab.protocols.sections as S

    built: list[str] = []
    for key in ("amount", "time_test", "traction", "stribeck", "film", "retention"):
        monkeypatch.setattr(S, key, lambda ctx, key=key: (built.append(key),
                                                           types.SimpleNamespace(key=key))[1])
    monkeypatch.setattr(S, "fits_section", lambda ctx: (built.append("fits"),
                                                        types.SimpleNamespace(key="fits"))[1])

    def ctx(**reports):
        keys = ("amount", "time_test", "traction", "stribeck", "film", "retention")
        r = types.SimpleNamespace(**{k: reports.get(k) for k in keys})
        return types.SimpleNamespace(p=types.SimpleNamespace(reports=r), fit_rows=[{}])

    for reports, first in (({"amount": 1, "traction": 1}, "fits"),
                           ({"amount": 1, "film": 1}, "amount"),
                           ({"traction": 1, "retention": 1}, "traction")):
        built.clear()
        ready: list[str] = []
        out = S.build_sections(ctx(**reports), ready=lambda s, ready=ready: ready.append(s.key))
        assert [s.key for s in out] == [*reports, "fits"]  # (given in the report's order)
        assert built[0] == first and ready == built, (reports, built)


# ------------------------------------------------------------------------- stored results
@pytest.mark.slow  # two protocol runs
def test_a_run_on_worker_processes_stores_every_result_it_computed(tmp_path):
    """Every result is stored in the cache as it arrives or is finished here (the workers
    are forked again between the reductions and the fits): a re-run computes nothing."""
    from torlab.protocols.runner import run_protocol

    p = small_fit_protocol(tmp_path)
    with ProcessExecutor(2) as ex:
        cold = run_protocol(p, tmp_path / "out", executor=ex)
        warm = run_protocol(p, tmp_path / "out", force=True, executor=ex)
    assert cold.cache_misses > 3 and cold.cache_hits == 0
    assert (warm.cache_misses, warm.cache_hits) == (0, cold.cache_misses)
    assert warm.timing["figures_drawn"] == 0


def test_figures_drawn_ahead_wait_in_files_not_in_memory(tmp_path):
    """On local workers a figure drawn ahead is written to a file of the run's own folder
    and read when taken (the same bytes as a plain drawing); each file goes when its
    figure is taken, the folder when the figures are done; a file named outside the
    folder is refused."""
    import os

    from torlab.reports.render import FiguresAhead, _read_drawn, render_figures

    items = _plots()
    plain, _ = render_figures(items, ("png",))
    with ProcessExecutor(2) as ex:
        ahead = FiguresAhead(("png",), executor=ex)
        assert ahead.start(items) == len(items)
        folder = ahead._folder
        assert folder is not None and os.path.isdir(folder)
        got, st = render_figures(items, ("png",), executor=ex, ahead=ahead)
        assert st.ahead == len(items)
        assert got == plain
        assert os.listdir(folder) == []
        ahead.close()
        assert not os.path.exists(folder)
    outside = tmp_path / "x.png"
    outside.write_bytes(b"png")
    with pytest.raises(ValueError, match="outside"):
        _read_drawn({"png": str(outside)}, str(tmp_path / "folder"))
    assert outside.exists()


def test_figures_the_store_holds_are_not_read_until_they_are_written(tmp_path, monkeypatch):
    """A run that reuses its figures does not hold their images while it computes: starting
    the figures reads none of those the store holds, each is read once when written; one
    whose sidecar no longer matches is not drawn ahead and is drawn when written, with the
    bytes of a plain drawing."""
    from torlab.protocols.cache import FigureStore, ResultCache
    from torlab.reports.render import FiguresAhead, figure_key, plot_digest, render_figures

    items = _plots()
    plain, _ = render_figures(items, ("png",))
    store = FigureStore(ResultCache(tmp_path / "cache"))
    render_figures(items, ("png",), store=store)  # both stored
    reads: list[str] = []
    real = FigureStore.get
    monkeypatch.setattr(FigureStore, "get", lambda self, k, f: reads.append(k) or real(self, k, f))
    with ProcessExecutor(2) as ex:
        ahead = FiguresAhead(("png",), store=store, executor=ex)
        assert ahead.start(items) == 0 and reads == []  # found, not read
        got, st = render_figures(items, ("png",), store=store, executor=ex, ahead=ahead)
        assert (st.drawn, st.reused) == (0, 2) and got == plain and len(reads) == 2
        key = figure_key(items[1][1], "png", None, digest=plot_digest(items[1][1]))
        mac = tmp_path / "cache" / f"fig-{key}.png.mac"
        mac.write_text(mac.read_text().replace("a", "b").replace("0", "1"))
        ahead = FiguresAhead(("png",), store=store, executor=ex)
        assert ahead.start(items) == 0  # both files there: not drawn ahead
        got, st = render_figures(items, ("png",), store=store, executor=ex, ahead=ahead)
        assert (st.drawn, st.reused, st.ahead) == (1, 1, 0) and got == plain
