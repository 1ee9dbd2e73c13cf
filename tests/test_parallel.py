"""One executor for independent tasks: serial, local processes, a Dask cluster -- same results.

The three executors of :mod:`torlab.parallel` run the same work (a creep-force table in
chunks, the Monte-Carlo draws of a prediction band, a whole protocol: reductions, fits,
predictions, figures) and must give the same bytes.  The Dask part runs on a
``LocalCluster`` (two workers in this process); it is skipped where Dask's
``distributed`` package is not installed (``pip install 'torlab[dask]'``).
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from torlab.errors import TorlabInputError, TorlabWarning
from torlab.parallel import ProcessExecutor, SerialExecutor, current, get_executor, use

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"


# ------------------------------------------------------------------------------ tasks
def _square(x: int) -> int:
    return x * x


def _warn(x: int) -> int:
    warnings.warn(TorlabWarning(f"task {x} says so"), stacklevel=1)
    return x


def _fail(x: int) -> int:
    if x in (3, 5):
        raise TorlabInputError(f"bad {x}", key="k")
    return x


def _inner(x: int) -> str:
    return current().kind  # a task never starts tasks of its own: serial inside workers


@pytest.fixture(scope="module")
def dask_client():
    pytest.importorskip("distributed")
    from distributed import Client, LocalCluster

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Dask's own start-up chatter
        cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                               dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster)
    yield client
    client.close()
    cluster.close()


def _executors(dask_client=None):
    out = [SerialExecutor(), ProcessExecutor(2)]
    if dask_client is not None:
        from torlab.parallel import DaskExecutor

        out.append(DaskExecutor(dask_client))
    return out


@pytest.fixture(scope="module")
def executors(request):
    try:
        client = request.getfixturevalue("dask_client")
    except pytest.skip.Exception:
        client = None
    exs = _executors(client)
    yield exs
    for ex in exs:
        ex.close()


# ------------------------------------------------------------------------------ semantics
def test_map_keeps_order_reissues_warnings_and_raises_the_first_error(executors):
    for ex in executors:
        assert ex.map(_square, range(7)) == [x * x for x in range(7)], ex.kind
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            assert ex.map(_warn, [1, 2]) == [1, 2]
        got = sorted(str(x.message) for x in w if issubclass(x.category, TorlabWarning))
        assert got == ["task 1 says so", "task 2 says so"], ex.kind
        with pytest.raises(TorlabInputError, match="bad 3"):
            ex.map(_fail, range(7))
        assert set(ex.map(_inner, range(4))) == {"serial"}, ex.kind


def test_map_in_blocks_keeps_order_each_index_and_the_first_error(executors):
    """``chunksize`` sends short tasks in blocks (local workers and a Dask cluster alike):
    the same results in order, ``each`` told every task's own index, and the first error
    in task order raised as itself, not as the block's."""
    for ex in executors:
        seen = []

        def each(i, v, seen=seen):
            seen.append(i)
            return v + 1

        got = ex.map(_square, range(11), chunksize=4, each=each)
        assert got == [x * x + 1 for x in range(11)], ex.kind
        assert sorted(seen) == list(range(11)), ex.kind
        with pytest.raises(TorlabInputError, match="bad 3"):
            ex.map(_fail, range(11), chunksize=4)
        with pytest.raises(TorlabInputError, match="bad 3"):
            ex.map(_fail, range(11), chunksize=2)


class _Result:
    """A task's result whose life this process can watch (a weak reference)."""

    def __init__(self, i: int, early: bool) -> None:
        self.i, self.early = i, early


def _after_flag(job: tuple[str, int]) -> _Result:
    """Task ``i`` waits (at most 20 s) for the flag file ``i - 1`` the caller writes when
    it takes task ``i - 1``'s result: early only if results are taken as they arrive."""
    import time

    folder, i = job
    flag = Path(folder) / f"took-{i - 1}"
    end = time.monotonic() + 20
    while i > 0 and not flag.exists() and time.monotonic() < end:
        time.sleep(0.01)
    return _Result(i, i == 0 or flag.exists())


def test_local_map_takes_each_result_as_it_arrives_and_lets_it_go(tmp_path):
    """Local workers: ``each`` sees a block's results as soon as that block is done, not
    after the whole map (task ``i`` waits for ``each`` of task ``i - 1``), and the result
    it was given is no longer held once the next one arrives (a map's results are never
    all held at once)."""
    import weakref

    refs: list[weakref.ref] = []
    dead_before: list[bool] = []

    def each(i: int, v: _Result) -> bool:
        dead_before.append(all(r() is None for r in refs))
        refs.append(weakref.ref(v))
        (tmp_path / f"took-{i}").write_text("")
        return v.early

    with ProcessExecutor(2) as ex:
        got = ex.map(_after_flag, [(str(tmp_path), i) for i in range(5)], each=each)
    assert got == [True] * 5
    assert dead_before == [True] * 5


def test_background_results_taken_one_at_a_time(tmp_path, executors):
    """:meth:`Background.take` waits for that task only (the last one waits until the
    first is taken), gives each task's own result or error, and lets it go."""
    for ex in executors:
        if ex.kind == "serial":  # runs the tasks when asked: take is results' item
            assert ex.background(_square, range(3)).take(1) == 1
            continue
        if ex.kind == "processes":
            # (not on the test's Dask cluster: its workers are threads of this process,
            # which run one task at a time -- the later task could hold the turn)
            folder = tmp_path / ex.kind
            folder.mkdir()
            bg = ex.background(_after_flag, [(str(folder), i) for i in (0, 1)])
            first = bg.take(0)
            (folder / "took-0").write_text("")
            assert (first.i, bg.take(1).early) == (0, True), ex.kind
        else:
            bg = ex.background(_square, (0, 1))
            assert (bg.take(0), bg.take(1)) == (0, 1), ex.kind
        with pytest.raises(RuntimeError):
            bg.take(1)  # taken: not kept
        with pytest.raises(RuntimeError):
            bg.results()  # not after some were taken one by one
        bg = ex.background(_fail, range(5))
        assert bg.take(4) == 4, ex.kind
        with pytest.raises(TorlabInputError, match="bad 3"):
            bg.take(3)
        assert bg.take(2) == 2, ex.kind


#: the order the tasks of :func:`test_dask_background_batches_take_turns` started in (the
#: test's Dask workers are threads of this process)
_STARTED: list[tuple[str, int]] = []
_GO = threading.Event()


def _record(job: tuple[str, int]) -> tuple[str, int]:
    _STARTED.append(job)
    if job == ("A", 0):  # the first task holds its turn until the second batch is there
        _GO.wait(30)
    return job


def test_dask_background_batches_take_turns(dask_client):
    """A background batch started after another is not queued behind all of it: the
    ``i``-th task of every batch has the same priority, so a campaign-wide figure started
    after a section's 192 fit figures is drawn next, not last (where one worker drew it
    alone at the end of the run).  With one priority for all, B's first task started
    after A's last."""
    from torlab.parallel import DaskExecutor

    ex = DaskExecutor(dask_client)
    _STARTED.clear()
    _GO.clear()
    a = ex.background(_record, [("A", i) for i in range(12)])
    time.sleep(0.3)  # Dask orders work submitted within 0.1 s as one submission

    def known() -> int:  # tasks the scheduler holds (A's stay while their futures are held)
        return dask_client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))

    n0 = known()
    b = ex.background(_record, [("B", i) for i in range(3)])
    # A's first task is let go once the scheduler has B's tasks (submitting is
    # asynchronous: on a busy machine A's tasks ran on while B's were on their way)
    deadline = time.monotonic() + 10
    while known() < n0 + 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    _GO.set()
    assert a.results() == [("A", i) for i in range(12)]
    assert b.results() == [("B", i) for i in range(3)]
    # at most the tasks the scheduler had already given the two workers run before B's
    assert _STARTED.index(("B", 0)) < _STARTED.index(("A", 7)), _STARTED


def _read_relative(name: str) -> str:
    with open(name, encoding="utf-8") as f:
        return f.read()


def test_a_dask_task_runs_in_the_drivers_directory(tmp_path, monkeypatch):
    """A Dask worker started in another directory runs each task in the driver's working
    directory (passed with the task), so a relative path names the same file there; the
    worker's own directory is restored after the task, and a directory the worker does
    not have is left alone."""
    from torlab.parallel import _dask_run, _dask_run_block

    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "a.txt").write_text("here", encoding="utf-8")
    elsewhere = tmp_path / "worker"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    with pytest.raises(FileNotFoundError):
        _dask_run(_read_relative, "data/a.txt")
    assert _dask_run(_read_relative, "data/a.txt", cwd=str(tmp_path)) == ("here", [])
    assert _dask_run_block(_read_relative, ["data/a.txt"] * 2, str(tmp_path)) == \
        [("here", []), ("here", [])]
    assert Path.cwd() == elsewhere
    with pytest.raises(FileNotFoundError):
        _dask_run(_read_relative, "data/a.txt", cwd=str(tmp_path / "not-here"))
    assert Path.cwd() == elsewhere


def test_relative_paths_on_every_executor(tmp_path, monkeypatch, request):
    """Tasks of every executor read a file by a path relative to the run's directory."""
    (tmp_path / "a.txt").write_text("here", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    try:
        client = request.getfixturevalue("dask_client")
    except pytest.skip.Exception:
        client = None
    for ex in _executors(client):
        with ex:
            assert ex.map(_read_relative, ["a.txt", "a.txt"]) == ["here", "here"], ex.kind
            assert ex.map(_read_relative, ["a.txt"] * 3, chunksize=2) == ["here"] * 3, ex.kind


def _thread_name() -> str:
    import threading

    return threading.current_thread().name


def _same_here() -> str:
    return "torlab"


def test_background_on_every_executor_and_who_agrees(executors):
    """Background tasks give :meth:`map`'s results, in order, with the first error; a
    cluster agrees on what its workers compute as this process does, and not otherwise
    (here: the workers' thread names), which decides where figures are drawn."""
    for ex in executors:
        bg = ex.background(_square, range(6))
        assert bg.results() == [x * x for x in range(6)], ex.kind
        assert bg.take(2) == 4 and bg.results()[2] is None, ex.kind
        with pytest.raises(TorlabInputError, match="bad 3"):
            ex.background(_fail, range(5)).results()
        assert ex.agree(_same_here), ex.kind
    dask = [ex for ex in executors if ex.kind == "dask"]
    if dask:
        assert not dask[0].agree(_thread_name)


def test_get_executor_from_the_options():
    assert get_executor(1).kind == "serial"
    ex = get_executor(2)
    assert ex.kind == "processes" and ex.workers == 2
    assert current().kind == "serial"
    with use(ex):
        assert current() is ex
    assert current().kind == "serial"
    pytest.importorskip("distributed")
    from torlab.parallel import DaskExecutor

    with pytest.raises(TorlabInputError, match="--scheduler"):
        DaskExecutor("tcp://127.0.0.1:1", timeout="0.3s")  # nothing listens there


# ------------------------------------------------------------------------------ an early worker
_LOADED: list[int] = []


def _mark_loaded() -> None:
    _LOADED.append(os.getpid())


def _where(x: int) -> tuple[int, bool]:
    return os.getpid(), os.getpid() in _LOADED


def _unpicklable(x: int):
    return lambda: x


def test_warm_worker_loads_first_then_runs_tasks_like_the_other_executors():
    from torlab.parallel import WarmWorker

    ww = WarmWorker(["json", _mark_loaded, "no_such_module_here"])  # a failing need is left
    proc = ww._proc
    try:
        assert ww.map(_square, range(5)) == [x * x for x in range(5)]
        pid, loaded = ww.map(_where, [0])[0]
        assert pid == proc.pid != os.getpid() and loaded  # in the worker, after its needs
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            assert ww.map(_warn, [1, 2]) == [1, 2]
        assert sorted(str(x.message) for x in w if issubclass(x.category, TorlabWarning)) \
            == ["task 1 says so", "task 2 says so"]
        with pytest.raises(TorlabInputError, match="bad 3"):
            ww.map(_fail, range(7))
        assert ww.map(_inner, [0]) == ["serial"]
        with pytest.raises(RuntimeError, match="could not be returned"):
            ww.map(_unpicklable, [1])
        assert ww.map(_square, [3]) == [9]  # still serving after an error
    finally:
        ww.close()
    assert proc.exitcode == 0  # told to stop, and stopped


def test_warm_worker_that_is_gone_leaves_the_tasks_to_this_process():
    from torlab.parallel import WarmWorker

    ww = WarmWorker([])
    ww._proc.kill()
    ww._proc.join()
    assert ww.map(_where, [0]) == [(os.getpid(), False)]
    ww.close()


def _forever() -> None:
    import time

    time.sleep(600)


def test_warm_worker_never_used_is_not_waited_for():
    """A command that fails before its figure closes the worker while it is still loading:
    it is killed, not waited for."""
    import signal

    from torlab.parallel import WarmWorker

    ww = WarmWorker([_forever])
    proc = ww._proc
    ww.close()
    assert proc.exitcode == -signal.SIGKILL


def test_warm_worker_only_where_a_second_process_helps(monkeypatch):
    import torlab.parallel as par

    monkeypatch.setattr(par, "usable_cores", lambda: 2)
    monkeypatch.delenv("TORLAB_JOBS")
    assert par.warm_worker([], jobs=1) is None
    assert par.warm_worker([], scheduler="tcp://127.0.0.1:1") is None
    monkeypatch.setenv("TORLAB_JOBS", "1")
    assert par.warm_worker([]) is None
    ww = par.warm_worker([], jobs=2)
    assert isinstance(ww, par.WarmWorker)
    ww.close()
    monkeypatch.setattr(par, "usable_cores", lambda: 1)
    assert par.warm_worker([], jobs=4) is None


def test_predict_figure_drawn_by_the_early_worker_is_the_same(tmp_path, cli, monkeypatch):
    import torlab.parallel as par

    monkeypatch.setattr(par, "usable_cores", lambda: 2)
    used = []
    real = par.WarmWorker.map

    def spy(self, fn, items, **kw):
        used.append(fn.__name__)
        return real(self, fn, items, **kw)

    monkeypatch.setattr(par.WarmWorker, "map", spy)
    for jobs in ("2", "1"):
        r = cli("predict", "traction", SCENE, "-o", tmp_path / jobs, "--jobs", jobs,
                "--creepage", "0:0.05:21")
        assert r.exit_code == 0, r.output
    assert used == ["draw_task"]  # --jobs 2 only
    assert (tmp_path / "2" / "traction.png").read_bytes() == \
        (tmp_path / "1" / "traction.png").read_bytes()
    for jobs in ("2", "1"):
        r = cli("predict", "stribeck", ROOT / "protocols" / "scenes" / "optical_paper_a_rough.yaml",
                "-o", tmp_path / f"s{jobs}", "--jobs", jobs, "--speed", "0.01:2:8")
        assert r.exit_code == 0, r.output
    assert used == ["draw_task"] * 2
    assert (tmp_path / "s2" / "stribeck.png").read_bytes() == \
        (tmp_path / "s1" / "stribeck.png").read_bytes()
    # a bad scene with the worker started: one error line, nothing written, nothing drawn
    bad = tmp_path / "bad.yaml"
    bad.write_text(SCENE.read_text() + "\nno_such_key: 1\n")
    r = cli("predict", "traction", bad, "-o", tmp_path / "bad", "--jobs", "2")
    assert r.exit_code == 2 and "no_such_key" in r.output, r.output
    assert not (tmp_path / "bad").exists() and used == ["draw_task"] * 2


# ------------------------------------------------------------------------------ same bytes
def _same(a, b, what):
    assert type(a) is type(b), what
    if isinstance(a, dict):
        assert a.keys() == b.keys(), what
        for k in a:
            _same(a[k], b[k], f"{what}.{k}")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, what
        assert a.tobytes() == b.tobytes(), what  # bit for bit, NaN included
    else:
        assert a == b, what


def test_creep_table_chunks_bit_for_bit(executors):
    from torlab.model.creep import creep_problem
    from torlab.model.creep_table import creep_table
    from torlab.scene import load_scene

    prob = creep_problem(load_scene(SCENE))
    axes = (np.linspace(-0.004, 0.004, 5), np.linspace(-0.002, 0.002, 3), [-0.5, 0.0, 0.5])
    results = []
    for ex in executors:
        with use(ex):
            tab = creep_table(prob, *axes, chunk=4)  # 45 points, several chunks
        results.append({k: tab.dataset[k].values for k in tab.dataset.data_vars})
    for r in results[1:]:
        _same(results[0], r, "creep table")


def test_band_draws_bit_for_bit(executors):
    from torlab.model.bands import DryTractionModel
    from torlab.model.prediction import fastsim_grid, fastsim_problem
    from torlab.scene import load_scene
    from torlab.uncertainty import MANY_BLOCK, SAMPLE_ROUND, ParameterDistribution, propagate

    sc = load_scene(SCENE)
    xi = np.linspace(0.0, 0.02, 11)
    model = DryTractionModel(fastsim_problem(sc), fastsim_grid(sc), xi, ("mu",))
    dist = ParameterDistribution.from_covariance(
        ("mu_c1", "mu_c2", "L_mue"), [0.30, 0.45, 1e-5],
        [[4e-4, 1e-4, 0.0], [1e-4, 4e-4, 0.0], [0.0, 0.0, 4e-12]], log_scale=("L_mue",), dof=12)
    # the model evaluates a block of draws in one call: two rounds, the last block short
    n = (SAMPLE_ROUND + 2) * MANY_BLOCK + 7
    bands = []
    for ex in executors:
        with use(ex):
            b = propagate(model, dist, method="sampling", n_samples=n, seed=11)
        assert b.method == "sampling"
        bands.append({"low": b.low("mu"), "high": b.high("mu"), "center": b.center["mu"]})
    for b in bands[1:]:
        _same(bands[0], b, "band")
    assert np.all(bands[0]["low"] <= bands[0]["high"])


def _band_problem():
    from torlab.model.bands import DryTractionModel
    from torlab.model.prediction import fastsim_grid, fastsim_problem
    from torlab.scene import load_scene
    from torlab.uncertainty import ParameterDistribution

    sc = load_scene(SCENE)
    model = DryTractionModel(fastsim_problem(sc), fastsim_grid(sc), np.linspace(0.0, 0.02, 11),
                              ("mu", "max_temperature_C"))
    dist = ParameterDistribution.from_covariance(
        ("mu_c1", "mu_c2", "L_mue"), [0.30, 0.45, 1e-5],
        [[4e-4, 1e-4, 0.0], [1e-4, 4e-4, 0.0], [0.0, 0.0, 4e-12]], log_scale=("L_mue",), dof=12)
    return model, dist


def _deferred_band(n: int):
    """A task whose sampled band leaves its draws to the executor (n = 0: a plain result)."""
    from torlab.parallel import Deferred
    from torlab.uncertainty import propagate

    if n == 0:
        return "plain"
    model, dist = _band_problem()
    pending = propagate(model, dist, method="sampling", n_samples=n, seed=n, defer=True)
    fn, blocks = pending.tasks()
    return Deferred(fn, blocks, pending.finish)


def test_deferred_band_draws_bit_for_bit(executors):
    """Two sampled bands whose draw blocks run as top-level tasks (map_deferred), next to a
    task that defers nothing: on every executor the band propagate gives in one call."""
    from torlab.parallel import map_deferred
    from torlab.uncertainty import MANY_BLOCK, propagate

    sizes = [2 * MANY_BLOCK + 3, 0, MANY_BLOCK]
    model, dist = _band_problem()
    want = {n: propagate(model, dist, method="sampling", n_samples=n, seed=n)
            for n in sizes if n}
    for ex in executors:
        got = map_deferred(ex, _deferred_band, sizes)
        assert got[1] == "plain", ex.kind
        for n, b in zip(sizes, got, strict=True):
            if not n:
                continue
            assert b.method == "sampling" and b.n_evaluations == want[n].n_evaluations, ex.kind
            _same({"low": b.lower, "high": b.upper, "sd": b.sd, "c": b.contributions},
                  {"low": want[n].lower, "high": want[n].upper, "sd": want[n].sd,
                   "c": want[n].contributions}, f"{ex.kind} band of {n} draws")


class _Draw:
    """A draw's outputs (weakly referable: the test sees when it is let go)."""

    def __init__(self, x: int) -> None:
        self.x = x


def _draw(x: int) -> _Draw:
    return _Draw(x)


class _Whole:
    """A task's whole value: its draws, as a sampled band's propagation holds them."""

    def __init__(self, draws: list[_Draw]) -> None:
        self.draws = draws
        self.total = sum(d.x for d in draws)


def test_each_completed_value_is_finished_and_let_go_before_the_next_is_completed():
    """map_deferred's ``finished``: called here on each value completed here, once, as
    soon as its last subtask's result is in (before the next value's subtasks run, on
    one process); the map returns what it returns; by the time the next value is
    completed, the earlier one's whole form and its subtask results are gone (a
    protocol stores each sampled band and keeps only its summary: no two bands' draws
    at once).  A value deferred with no subtasks is completed too."""
    import gc
    import weakref

    from torlab.parallel import Deferred, map_deferred

    refs: list[weakref.ref] = []  # every completed value and its subtask results
    still: list[int] = []  # how many of them were alive as each value was completed
    events: list[str] = []

    def then(results: list[_Draw]) -> _Whole:
        gc.collect()
        still.append(sum(r() is not None for r in refs))
        events.append(f"then {len(results)}")
        w = _Whole(results)
        refs.extend([weakref.ref(w), *(weakref.ref(d) for d in results)])
        return w

    def draw(x: int) -> _Draw:
        events.append("draw")
        return _Draw(x)

    def task(n: int):
        return "plain" if n == 0 else Deferred(draw, list(range(max(n, 0))), then)

    calls = []

    def finished(i: int, v: _Whole) -> int:
        calls.append(i)
        return v.total

    got = map_deferred(SerialExecutor(), task, [3, 0, 4, -1, 2], finished=finished)
    assert got == [3, "plain", 6, 0, 1] and calls == [3, 0, 2, 4]
    assert events == ["then 0", *["draw"] * 3, "then 3", *["draw"] * 4, "then 4",
                      *["draw"] * 2, "then 2"]
    assert still == [0, 0, 0, 0] and len(refs) == 1 + (1 + 3) + (1 + 4) + (1 + 2)


def test_without_finished_the_completed_values_are_returned_whole():
    from torlab.parallel import Deferred, map_deferred

    got = map_deferred(SerialExecutor(),
                       lambda n: Deferred(_draw, list(range(n)), _Whole), [2, 3])
    assert [type(v) for v in got] == [_Whole, _Whole] and [v.total for v in got] == [1, 3]


@pytest.mark.slow
def test_protocol_prediction_with_a_sampled_band_bit_for_bit(executors):
    """The traction prediction of a protocol (its executor task, the band's model evaluations
    deferred to the executor) equals predict_traction in one call, on every executor (a
    nonlinear band: the second-order method's points, or 400 draws where it is sampled)."""
    import yaml

    from torlab.model.predict import predict_traction
    from torlab.parallel import map_deferred
    from torlab.protocols.context import _predict_task
    from torlab.scene import scene_from_dict

    scene = yaml.safe_load((ROOT / "tests" / "data" / "bands" / "wfm_wet_tab54.yaml").read_text())
    xi = np.linspace(0.0, 0.05, 51)
    want = predict_traction(scene_from_dict(scene), xi)
    assert want.band.method in ("second-order", "sampling")
    for ex in executors:
        got = map_deferred(ex, _predict_task, [("traction", scene, {"creepage": xi})])[0]
        assert got.band.method == want.band.method, ex.kind
        _same({k: got.table[k].to_numpy() for k in got.table},
              {k: want.table[k].to_numpy() for k in want.table}, ex.kind)
        assert got.trend == want.trend and "model" not in got.band._design, ex.kind


PROTOCOL = """\
version: 1
name: parallel
products:
  OFM1: {density: 930 kg/m^3}
data:
  hpt:
    files: [hpt_*.txt]
fits:
  hpt_layers:
    amounts: [4 uL]
    temperature: 25 degC
reports:
  amount: {curve: interpolation}
  traction:
    creepage: {from: 0, to: 0.03, points: 16}
    curves:
      - label: "{set}"
        scene: wheel_rail_tab54.yaml
        params: ["hpt:*"]
  figure_formats: [png, svg]
"""


def _files(folder: Path) -> dict[str, bytes]:
    out = {}
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder).as_posix()
        if p.is_file() and not rel.startswith(".cache") and rel != "torlab-manifest.json":
            out[rel] = p.read_bytes()
    return out


@pytest.mark.slow  # a whole protocol on every executor (the parts: above)
def test_protocol_run_bit_for_bit(tmp_path, executors):
    from torlab.protocols.runner import run_protocol

    for a in (1, 4, 16):
        f = ROOT / "sample_data" / "hpt" / f"hpt_OFM1_{a}uL_25C.txt"
        shutil.copy(f, tmp_path / f.name)
    shutil.copy(SCENE, tmp_path / SCENE.name)
    p = tmp_path / "parallel.yaml"
    p.write_text(PROTOCOL)
    runs = []
    for i, ex in enumerate(executors):
        res = run_protocol(p, tmp_path / f"out{i}", executor=ex, command="test")
        assert res.timing["figures_drawn"] == 4 and res.cache_misses > 4, ex.kind
        files = _files(tmp_path / f"out{i}")
        summary = json.loads(files.pop("summary.json"))
        summary.pop("run")  # timings
        runs.append((files, summary))
    names = sorted(runs[0][0])
    assert {"amount/amount_applied.png", "amount/amount_applied.svg", "traction/traction.png",
            "fits/hpt_OFM1.yaml", "traction/curves.csv"} <= set(names)
    for files, summary in runs[1:]:
        assert sorted(files) == names
        for n in names:
            assert files[n] == runs[0][0][n], n
        assert summary == runs[0][1]


# ------------------------------------------------------------------------------ CLI, processes
def _torlab(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:

    env = {k: v for k, v in os.environ.items() if k != "TORLAB_JOBS"}
    return subprocess.run([sys.executable, "-m", "torlab", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def _hpt_folder(tmp_path: Path, changes: dict[str, tuple[str, str]]) -> Path:
    d = tmp_path / "logs"
    d.mkdir()
    for f in sorted((ROOT / "sample_data" / "hpt").glob("hpt_OFM1_*uL_25C.txt")):
        text = f.read_text(encoding="utf-8")
        if f.name in changes:
            old, new = changes[f.name]
            assert old in text
            text = text.replace(old, new)
        (d / f.name).write_text(text, encoding="utf-8")
    return d


@pytest.mark.slow  # worker processes again; their warnings: below
def test_reduce_on_worker_processes_a_bad_file_among_many_is_one_error_line(tmp_path):
    """'torlab reduce --jobs 2' in a real process: the error raised in a worker reaches the
    console as one line naming the file and line, with the warning of another worker's file
    as one line too; exit 2, no traceback, no output folder."""
    d = _hpt_folder(tmp_path, {"hpt_OFM1_2uL_25C.txt": ("arm_length: 250 mm", "arm_length: 250"),
                               "hpt_OFM1_8uL_25C.txt": ("arm_length: 250 mm",
                                                        "arm_length: 2500 mm")})
    r = _torlab("reduce", d, "--jobs", "2", "--no-plot", "-o", tmp_path / "out", cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert "Traceback" not in r.stderr + r.stdout
    assert all(ln.startswith(("error: ", "warning: ")) for ln in lines), lines
    errors = [ln for ln in lines if ln.startswith("error: ")]
    assert len(errors) == 1 and "hpt_OFM1_2uL_25C.txt:9: arm_length: needs a unit" in errors[0]
    assert not (tmp_path / "out").exists()


def test_reduce_on_worker_processes_passes_warnings_as_lines(tmp_path):
    d = _hpt_folder(tmp_path, {"hpt_OFM1_8uL_25C.txt": ("arm_length: 250 mm",
                                                        "arm_length: 2500 mm")})
    r = _torlab("reduce", d, "--jobs", "2", "--no-plot", "-o", tmp_path / "out", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert all(ln.startswith("warning: ") for ln in lines), lines
    warn = [ln for ln in lines if "2500 mm is unusual for an HPT loading-arm length" in ln]
    assert len(warn) == 1 and "hpt_OFM1_8uL_25C.txt:9:" in warn[0], lines
    assert len(list((tmp_path / "out").glob("hpt_OFM1_*_reduced.csv"))) == 5


def _numpy_warning_task(x: int) -> float:
    return float(np.log(np.float64(x)))  # x = 0: numpy's "divide by zero" RuntimeWarning


def test_numpy_warning_in_a_worker_is_not_printed_raw(capsys):
    """A RuntimeWarning raised in a worker process is re-issued in the parent, where the CLI's
    handler hides it (counted for --debug), like one raised in the parent."""
    from torlab.cli import _STATE, _show_warning

    _STATE.update(debug=False, warnings=[], hidden_warnings=[])
    with ProcessExecutor(2) as ex, warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = _show_warning
        assert ex.map(_numpy_warning_task, [1, 0, 2])[1] == -np.inf
    err = capsys.readouterr().err
    assert err == "", err
    assert [h[0] for h in _STATE["hidden_warnings"]] == ["RuntimeWarning"]
