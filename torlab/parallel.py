"""One executor for torlab's independent tasks: in this process, on local processes, or on a
Dask cluster -- with the same results, bit for bit, in all three.

What goes through it: the reductions of a protocol's files, its fits, its predicted
curves and its figures (:mod:`torlab.protocols`), the Monte-Carlo draws of a
prediction band (:mod:`torlab.uncertainty`), the chunks of a creep-force table
(:mod:`torlab.model.creep_table`).  Each of these is a list of tasks that do not
depend on each other; :meth:`Executor.map` runs a picklable function over them and
returns the results *in order*.

* :class:`SerialExecutor` -- one after the other in this process (``--jobs 1``);
* :class:`ProcessExecutor` -- a pool of local worker processes (``--jobs N``; the
  commands' default is every core this process may use);
* :class:`DaskExecutor` -- the workers of a Dask distributed cluster
  (``--scheduler tcp://host:8786``; needs ``pip install 'torlab[dask]'``).

**Same results.**  A task's result depends only on its arguments: the split of
the work into tasks is fixed by the work itself (a creep table's chunk size, a
band's block of draws), never by the number of workers; random draws are made
from their seed before the work is split; every task runs with one BLAS/OpenMP
thread (:func:`torlab.threads.limit_threads`) wherever it runs, so a sum inside
a matrix product is never split differently.  ``tests/test_parallel.py``
compares the three executors' results byte for byte.

**Warnings and errors.**  A task's warnings are recorded where it runs and
issued again, with their original file and line, in the calling process, so
the command line shows them as it would for serial work.  An error in a task
stops the map and is raised in the caller (the first in task order).

**Choosing.**  :func:`get_executor` makes one from the command line's options;
:func:`current` is the one in use (serial unless a block ``with
use(executor):`` says otherwise), so library code deep inside a computation
(a band's draws) finds it without a parameter.  Inside a worker, :func:`current`
is serial: tasks never start tasks of their own.

**Spending the cores** (:class:`ProcessExecutor`; none of it changes a result).
``map(..., uses=...)`` forks the workers before the prepared modules their tasks do not
use, which this process loads while they work; ``map(..., chunksize=n)`` sends many
short tasks in blocks; :meth:`Executor.background` starts tasks that only take idle
workers (a protocol's figures while its later sections compute).

**Work a task finds.**  A task that discovers independent work of its own (a
protocol's prediction whose band turns out sampled: 20 blocks of draws) returns
it as a :class:`Deferred` instead of doing it alone in its worker;
:func:`map_deferred` runs the deferred work of all the tasks of a map as
top-level tasks, on every worker, and completes each task in the caller as its
work comes back.
"""

from __future__ import annotations

import contextvars
import itertools
import os
import sys
import threading
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

__all__ = ["Background", "DaskExecutor", "Deferred", "Executor", "ProcessExecutor",
           "SerialExecutor", "WarmWorker", "activate", "chunks", "current", "get_executor",
           "map_deferred", "map_tasks", "usable_cores", "use", "warm_worker"]

_CURRENT: contextvars.ContextVar[Executor | None] = contextvars.ContextVar(
    "torlab_executor", default=None)


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the system has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # macOS, Windows
        return max(1, os.cpu_count() or 1)


# ------------------------------------------------------------------------------ the task
def _run(fn: Callable[[Any], Any], item: Any) -> tuple[Any, list[tuple[Any, ...]]]:
    """Run one task with one BLAS thread; return its result and the warnings it issued."""
    from torlab.threads import limit_threads

    with warnings.catch_warnings(record=True) as caught, limit_threads(1):
        out = fn(item)
    return out, [(w.message, w.category, w.filename, w.lineno) for w in caught]


class _BlockError(Exception):
    """The error of one task of a block (:func:`_run_block`), raised as itself in the caller."""

    def __init__(self, error: BaseException) -> None:
        super().__init__(error)
        self.error = error


def _run_block(fn: Callable[[Any], Any], items: Sequence[Any]) -> list[tuple[Any, list]]:
    """:func:`_run` on each of a block of items, in order; the first error stops the block."""
    out = []
    for it in items:
        try:
            out.append(_run(fn, it))
        except Exception as e:
            raise _BlockError(e) from None
    return out


def _cancel(futures: Sequence[Any]) -> None:
    """Cancel the futures not yet let go (None: taken)."""
    for f in futures:
        if f is not None:
            f.cancel()


def _unwrap(e: BaseException) -> BaseException:
    return e.error if isinstance(e, _BlockError) else e


class Background:
    """Tasks started by :meth:`Executor.background`; :meth:`results` waits for them all,
    :meth:`take` for one."""

    def __init__(self, get: Callable[[], list[Any]],
                 cancel: Callable[[], None] | None = None,
                 one: Callable[[int], Any] | None = None) -> None:
        self._get, self._cancel, self._one, self._out = get, cancel, one, None
        self._took = False

    def results(self) -> list[Any]:
        """The tasks' results in order (their warnings issued here); the first error in
        task order is raised."""
        if self._out is None:
            if self._took:
                raise RuntimeError("background results asked for after some were taken")
            self._out = self._get()
        return self._out

    def take(self, i: int) -> Any:
        """The ``i``-th task's result (its warnings issued here, its error raised), no
        longer kept here: a large result is held only by whoever took it.  Where the
        executor can (a local pool, a Dask cluster), only that task is waited for, so
        the results taken one by one are never all held at once."""
        if self._one is not None and self._out is None:
            self._took = True
            return self._one(i)
        out = self.results()
        res, out[i] = out[i], None
        return res

    def cancel(self) -> None:
        """Drop the tasks not started (a run that failed)."""
        if self._cancel is not None:
            self._cancel()


class _Feed:
    """Background tasks on a :class:`ProcessExecutor`'s pool: a thread submits them one at a
    time whenever fewer tasks than workers are busy, so they never queue ahead of a
    :meth:`~Executor.map`'s tasks (except those already running)."""

    def __init__(self, ex: ProcessExecutor, pool: Any, fn: Callable[[Any], Any],
                 items: list[Any]) -> None:
        self.ex, self.pool, self.fn, self.items = ex, pool, fn, items
        self.futs: list[Any] = []
        self.stopped = False
        self._submitted = threading.Condition()
        self.thread = threading.Thread(target=self._feed, name="torlab-background",
                                       daemon=True)
        self.thread.start()

    def _feed(self) -> None:
        for it in self.items:
            with self.ex._idle:
                while not self.stopped and self.ex._busy >= self.ex.workers:
                    self.ex._idle.wait()
                if self.stopped:
                    return
            try:
                fut = self.ex._submit(self.pool, _run, self.fn, it)
            except RuntimeError:  # the pool was shut down (a run that failed)
                with self._submitted:
                    self._submitted.notify_all()
                return
            with self._submitted:
                self.futs.append(fut)
                self._submitted.notify_all()

    def active(self) -> bool:
        return self.thread.is_alive() or not all(f is None or f.done() for f in self.futs)

    def take(self, i: int) -> Any:
        """The ``i``-th task's result once it is done (submitted first, if need be); its
        future is let go."""
        with self._submitted:
            while len(self.futs) <= i and not self.stopped and self.thread.is_alive():
                self._submitted.wait(0.5)
            if len(self.futs) <= i or self.futs[i] is None:
                raise RuntimeError("background task cancelled or already taken")
            f, self.futs[i] = self.futs[i], None
        return _results([f.result()])[0]

    def cancel(self) -> None:
        with self.ex._idle:
            self.stopped = True
            self.ex._idle.notify_all()
        self.thread.join()
        _cancel(self.futs)

    def results(self, description: str) -> list[Any]:
        from torlab.progress import current as progress

        with progress().task(description, len(self.items) if description else 0) as advance:
            self.thread.join()  # every task submitted (the workers are free by now)
            if self.stopped:
                raise RuntimeError("background tasks were cancelled")
            out = []
            try:
                for f in self.futs:  # in order: the first error in task order is raised
                    out.append(f.result())
                    advance()
            except BaseException:
                _cancel(self.futs)
                raise
        self.futs = []  # every task is done: the results are held by the caller only
        return _results(out)


def _reissue(records: Sequence[tuple[Any, ...]]) -> None:
    for message, category, filename, lineno in records:
        warnings.warn_explicit(message, category, filename, lineno)


def _results(out: Sequence[tuple[Any, Sequence[tuple[Any, ...]]]]) -> list[Any]:
    """The tasks' results, in order, each task's warnings reissued here (as a serial run would)."""
    results = []
    for res, ws in out:
        _reissue(ws)
        results.append(res)
    return results


def _worker_init(parent: int | None = None) -> None:
    """A worker runs its tasks serially and leaves Ctrl-C to the parent; on Linux it dies
    with its parent (``PR_SET_PDEATHSIG``), so a ``kill -9`` of a run leaves no orphaned
    workers behind (the output folder's lock is not inherited either: see
    :class:`torlab.outputs.OutputDir`)."""
    import signal

    _CURRENT.set(None)
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except (ValueError, OSError):  # not the main thread (a threaded Dask worker)
        pass
    if parent is not None and sys.platform.startswith("linux"):
        try:
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
        if os.getppid() != parent:  # the parent died before the line above
            os._exit(0)


# ------------------------------------------------------------------------------ executors
class Executor:
    """Runs independent tasks; use :meth:`map`.  Base class: serial.

    Attributes
    ----------
    kind
        ``serial``, ``processes`` or ``dask``.
    workers
        How many tasks run at a time.
    """

    kind = "serial"
    workers = 1

    def describe(self) -> str:
        """One line for reports and logs."""
        return "serial (this process)"

    def map(self, fn: Callable[[Any], Any], items: Iterable[Any], *,
            description: str = "", uses: Sequence[str | Callable[[], Any]] | None = None,
            chunksize: int = 1, each: Callable[[int, Any], Any] | None = None) -> list[Any]:
        """``[fn(item) for item in items]``, in order (``fn`` picklable for other executors).

        ``description`` labels the progress bar (:mod:`torlab.progress`) shown while the
        tasks run; nothing is shown for a single task.  ``uses`` says which of the
        :meth:`prepare` needs the tasks use (None: all of them); local workers may then
        start without the others, which this process loads while the tasks run
        (:class:`ProcessExecutor`).  It only changes where time is spent: a task that uses
        a module its worker lacks imports it itself.  ``chunksize``: items sent to a
        local worker together, for many short tasks (a protocol's reductions: 3 ms
        each), whose one-by-one round trips would cost more than the tasks.  ``each(i,
        result)`` is called in this process as each task's result arrives (in any order)
        and its return value is kept instead: work on the results that should not wait
        for the whole map, such as writing a large result away and keeping a summary of it
        (so that the results of a long map are never all held at once).
        """
        from torlab.progress import current as progress

        items = list(items)
        out = []
        with progress().task(description, len(items) if description and len(items) > 1
                             else 0) as advance:
            for i, it in enumerate(items):
                res, ws = self._run_one(fn, it)
                _reissue(ws)
                out.append(res if each is None else each(i, res))
                advance()
        return out

    def _run_one(self, fn: Callable[[Any], Any], item: Any) -> tuple[Any, list[tuple[Any, ...]]]:
        """One task of :meth:`map`: its result and its warnings (here: in this process)."""
        return _run(fn, item)

    def prepare(self, *needs: str | Callable[[], Any]) -> None:
        """Modules (names) or set-up functions the coming tasks will need: loaded in this
        process before workers are forked, so that they load once, not once per worker
        (only :class:`ProcessExecutor` with ``fork`` uses them; nothing is loaded if no
        worker is ever started; see ``uses`` of :meth:`map`)."""

    def background(self, fn: Callable[[Any], Any], items: Iterable[Any], *,
                   description: str = "") -> Background:
        """``fn`` over ``items`` with spare capacity: the tasks run when no other task
        wants the workers (between and at the ends of :meth:`map` calls, while this
        process works alone), and :meth:`Background.results` gives their results, in
        order, as :meth:`map` would (waiting for those not done).

        A protocol run draws the figures of its first report sections this way while
        the later sections compute.  Here (serial, and the executors without a pool of
        their own) the tasks run when their results are asked for.
        """
        return Background(lambda: self.map(fn, items, description=description))

    def agree(self, fn: Callable[[], Any]) -> bool:
        """Whether ``fn()`` gives on every worker what it gives in this process (a figure
        is drawn on the workers only where they draw as this process would).  Here, and on
        local workers (forks or spawns of this install): yes."""
        return True

    def close(self) -> None:
        """Release workers (nothing for the serial executor)."""

    def __enter__(self) -> Executor:
        self._token = _CURRENT.set(self)
        return self

    def __exit__(self, *exc: Any) -> None:
        _CURRENT.reset(self._token)
        self.close()


class SerialExecutor(Executor):
    """Every task in this process, one after the other."""


class ProcessExecutor(Executor):
    """A pool of local worker processes.

    Workers are started on the first :meth:`map` of more than one task (a command
    that never has parallel work never starts them), by ``fork`` on Linux -- they
    inherit the modules already imported, so a worker starts in milliseconds --
    and by ``spawn`` elsewhere.  Every worker is forked at once, with the
    progress bars' refresh thread stopped meanwhile, so no lock is copied into a
    worker while another thread holds it.

    What :meth:`prepare` lists is loaded in this process before the workers are
    forked.  A map whose tasks use only part of it (``uses``: none for a
    protocol's reductions, the optimiser for its fits) forks the workers with that
    part and loads the rest here, one need at a time, while they work; the next map
    that uses more forks the workers again, from this process with it loaded (the
    idle workers are closed first: about 20 ms).  On two cores that takes most of
    the loading (SciPy's optimiser and matplotlib: 0.7 s) off the wall time.

    Parameters
    ----------
    jobs
        Worker processes (default: :func:`usable_cores`).
    """

    kind = "processes"

    def __init__(self, jobs: int | None = None) -> None:
        self.workers = max(1, int(jobs or usable_cores()))
        self._pool: Any = None
        self._needs: list[str | Callable[[], Any]] = []
        self._loaded: list[str | Callable[[], Any]] = []  # loaded here, in order
        self._inherited: list[str | Callable[[], Any]] = []  # loaded when the pool forked
        self._busy = 0  # tasks (or blocks) submitted to the pool and not done
        self._idle = threading.Condition()
        self._feeds: list[_Feed] = []  # background work

    def prepare(self, *needs: str | Callable[[], Any]) -> None:
        self._needs += [n for n in needs if n not in self._needs]

    def _load_needs(self, needs: Sequence[str | Callable[[], Any]] | None = None) -> None:
        """Import what :meth:`prepare` listed (``needs``: only those), once."""
        todo = [n for n in (self._needs if needs is None else needs) if n not in self._loaded]
        _load(todo)
        self._loaded += todo

    def describe(self) -> str:
        return f"{self.workers} local processes"

    def _start(self, uses: Sequence[str | Callable[[], Any]] | None = None) -> Any:
        """The pool, forked (again if need be) so that its workers have ``uses``."""
        import multiprocessing as mp

        method = "fork" if sys.platform.startswith("linux") else "spawn"
        uses = self._needs if uses is None else list(uses)
        if self._pool is not None and method == "fork" \
                and any(n not in self._inherited for n in uses) \
                and not any(f.active() for f in self._feeds):  # never under background work
            self._shutdown()  # idle workers; the new ones are forked below, with ``uses``
        if self._pool is None:
            from concurrent.futures import ProcessPoolExecutor

            from torlab.progress import current as progress

            ctx = mp.get_context(method)
            if method == "fork":
                self._load_needs(uses)
                trim_memory()  # what this process freed is not copied into the workers
            import gc

            with progress().pause():
                self._pool = ProcessPoolExecutor(self.workers, mp_context=ctx,
                                                 initializer=_worker_init,
                                                 initargs=(os.getpid(),))
                if method == "fork":  # fork every worker now, while no other thread runs
                    gc.freeze()
                    try:
                        for f in [self._pool.submit(_noop, i) for i in range(self.workers)]:
                            f.result()
                    finally:
                        gc.unfreeze()
            self._inherited = list(self._loaded)
        return self._pool

    def map(self, fn: Callable[[Any], Any], items: Iterable[Any], *,
            description: str = "", uses: Sequence[str | Callable[[], Any]] | None = None,
            chunksize: int = 1, each: Callable[[int, Any], Any] | None = None) -> list[Any]:
        items = list(items)
        if len(items) <= 1:  # one task: no round trip through a worker
            return super().map(fn, items, description=description, each=each)
        from concurrent.futures import FIRST_COMPLETED, wait

        from torlab.progress import current as progress

        pool = self._start(uses)
        blocks = chunks(len(items), chunksize)
        futs = [self._submit(pool, _run_block, fn, items[b]) for b in blocks]
        index = {f: i for i, f in enumerate(futs)}
        out: list[Any] = [None] * len(blocks)
        try:
            with progress().task(description, len(items) if description else 0) as advance:
                if sys.platform.startswith("linux"):
                    # what the tasks do not use: loaded here while they run, one need at
                    # a time, until they are done (the rest while later tasks run)
                    for need in [n for n in self._needs if n not in self._loaded]:
                        if all(f.done() for f in futs):
                            break
                        self._load_needs([need])
                pending = set(futs)
                while pending:
                    # each block's results taken as it finishes (FIRST_EXCEPTION would
                    # wait for every block when none fails), and its future let go: a
                    # map's results (a reduction's cache entry each) are never all held
                    done, pending = wait(pending, return_when=FIRST_COMPLETED)
                    failed = []
                    for f in done:
                        i = index.pop(f)
                        futs[i] = None
                        b = blocks[i]
                        if f.exception() is None:
                            res = f.result()
                            if each is not None:
                                res = [(each(b.start + j, r), ws) for j, (r, ws) in enumerate(res)]
                            out[i] = res
                        else:
                            failed.append((i, f.exception()))
                        advance(b.stop - b.start)
                    del done
                    if failed:
                        # the first error in task order: later blocks are cancelled, earlier
                        # ones finish (one of them may fail first in order)
                        first, error = min(failed, key=lambda x: x[0])
                        _cancel(futs[first + 1:])
                        earlier = [f for f in futs[:first] if f is not None]
                        wait(earlier)
                        for f in earlier:
                            if f.exception() is not None:
                                raise _unwrap(f.exception())
                        raise _unwrap(error)
        except BaseException:
            _cancel(futs)
            raise
        trim_memory()  # the results' transfers (pickles, cache entries written) are freed
        return _results([r for block in out for r in block])

    def _submit(self, pool: Any, *args: Any) -> Any:
        """Submit one task, counted as busy until it is done (:meth:`background`)."""
        with self._idle:
            self._busy += 1
        try:
            fut = pool.submit(*args)
        except BaseException:
            self._task_done(None)
            raise
        fut.add_done_callback(self._task_done)
        return fut

    def _task_done(self, _: Any) -> None:
        with self._idle:
            self._busy -= 1
            self._idle.notify_all()

    def background(self, fn: Callable[[Any], Any], items: Iterable[Any], *,
                   description: str = "") -> Background:
        items = list(items)
        if not items or not sys.platform.startswith("linux"):
            return super().background(fn, items, description=description)
        pool = self._start(None)  # every prepared need, before the feeding thread starts
        feed = _Feed(self, pool, fn, items)
        self._feeds = [f for f in self._feeds if f.active()] + [feed]
        return Background(lambda: feed.results(description), feed.cancel, feed.take)

    def close(self) -> None:
        for feed in self._feeds:
            feed.cancel()
        self._feeds = []
        self._shutdown()

    def _shutdown(self) -> None:
        """Close the workers (idle: a new :meth:`map` forks others)."""
        if self._pool is not None:
            pool, self._pool = self._pool, None
            pool.shutdown(wait=True, cancel_futures=True)
            self._inherited = []


def _noop(i: int) -> int:
    return i


def trim_memory() -> None:
    """Give the memory this process has freed back to the system (glibc's
    ``malloc_trim``; nothing elsewhere).

    Python's small objects and numpy's small arrays come from the C heap, which keeps
    the pages of freed objects for reuse: after a protocol's reduce stage (thousands of
    reductions arriving in blocks and written to the cache) about 100 MB of a 16x
    campaign's parent were free but resident.  A worker forked then maps the parent's
    resident pages too, so each worker's resident size started from it.  Trimming takes
    milliseconds (8 ms for 100 MB here).
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        trim = getattr(ctypes.CDLL(None), "malloc_trim", None)
    except (OSError, AttributeError):  # pragma: no cover (another C library)
        return
    if trim is not None:
        trim(0)


def _load(needs: Sequence[str | Callable[[], Any]]) -> None:
    """Import modules (names) and call set-up functions; a failure is left to the task that
    needs them, where it happens."""
    import importlib

    for need in needs:
        try:
            need() if callable(need) else importlib.import_module(need)
        except Exception:
            pass


class WarmWorker(Executor):
    """One worker process, forked at once, that loads what its tasks will need while this
    process goes on with other work; the tasks of a later :meth:`map` run there.

    A command that ends by drawing its figure (``torlab predict traction``) starts one
    as it begins: the worker imports matplotlib with its Agg canvas, fonts and PNG writer
    (about a third of the command's time) while the command itself loads the scene and
    computes the curve; then it draws the figure.  On two cores that takes the import
    off the command's wall time.  Make one with :func:`warm_worker`, which
    gives None where it would not help (one usable core, no ``fork``).

    The tasks of a map run one after another in the worker, with their results,
    warnings and first error returned as :class:`ProcessExecutor` returns them.  If
    the worker is gone (killed, or it could not start), they run in this process.  A
    worker that was never sent a task is killed when it is closed: a command that stops
    at an input error does not wait for the worker's imports.
    """

    kind = "processes"
    workers = 1

    def __init__(self, needs: Sequence[str | Callable[[], Any]]) -> None:
        import multiprocessing as mp

        ctx = mp.get_context("fork")
        self._conn, child = ctx.Pipe()
        self._proc: Any = ctx.Process(target=_warm_main, args=(child, os.getpid(), list(needs)),
                                      daemon=True)
        self._proc.start()
        child.close()
        self._sent = False

    def describe(self) -> str:
        return "a worker process started early"

    def _run_one(self, fn: Callable[[Any], Any], item: Any) -> tuple[Any, list[tuple[Any, ...]]]:
        if self._proc is not None:
            try:
                self._sent = True
                self._conn.send((fn, item))
                ok, payload = self._conn.recv()
            except (EOFError, OSError, BrokenPipeError):  # the worker is gone
                self._stop()
            else:
                if not ok:
                    raise payload
                return payload
        return _run(fn, item)

    def _stop(self) -> None:
        proc, self._proc = self._proc, None
        if proc is None:
            return
        if not self._sent:  # never used (the command failed first): no need to wait for it
            proc.kill()
        else:
            try:
                self._conn.send(None)
            except (OSError, BrokenPipeError):
                pass
        self._conn.close()
        proc.join(timeout=5)
        if proc.is_alive():  # pragma: no cover - a worker stuck in a task
            proc.kill()
            proc.join()

    def close(self) -> None:
        self._stop()


def _warm_main(conn: Any, parent: int, needs: list[str | Callable[[], Any]]) -> None:
    """A :class:`WarmWorker`'s process: load, then run tasks until told to stop."""
    _worker_init(parent)
    _load(needs)
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            break
        if msg is None:
            break
        fn, item = msg
        try:
            reply: tuple[bool, Any] = (True, _run(fn, item))
        except Exception as e:  # returned to the caller, raised there
            reply = (False, e)
        try:
            conn.send(reply)
        except Exception as e:  # an unpicklable result or error: say what it was
            conn.send((False, RuntimeError(f"a task's {'result' if reply[0] else 'error'} "
                                           f"could not be returned: {e}")))
    conn.close()


def warm_worker(needs: Sequence[str | Callable[[], Any]], jobs: int | None = None,
                scheduler: str | None = None) -> WarmWorker | None:
    """A :class:`WarmWorker` loading ``needs``, or None where it would not help: ``--jobs 1``,
    a Dask ``--scheduler``, one usable core, or no ``fork`` (macOS, Windows)."""
    if scheduler or not sys.platform.startswith("linux") or usable_cores() < 2 \
            or _job_count(jobs) < 2:
        return None
    return WarmWorker(needs)


class DaskExecutor(Executor):
    """The workers of a Dask distributed cluster.

    Parameters
    ----------
    scheduler
        The scheduler's address (``tcp://host:8786``), or a
        ``distributed.Client`` / ``LocalCluster`` to use as it is.
    timeout
        How long to try to reach a scheduler given by address.

    Notes
    -----
    Tasks and their results travel between this process and the workers as
    pickles (that is how Dask works): connect only to a cluster you control.
    The workers read input files by the paths this process gives them, so they
    must see the same file system (a cluster on this machine, or a shared disk);
    each task runs in this process's working directory where the worker has it, so
    relative paths name the same files.  Short tasks (``map(..., chunksize=n)``) go
    in blocks, as to local workers.
    """

    kind = "dask"

    def __init__(self, scheduler: Any, timeout: str = "20s") -> None:
        try:
            from distributed import Client
        except ImportError:
            from torlab.errors import TorlabInputError

            raise TorlabInputError("--scheduler needs Dask's distributed package: pip install "
                                   "'torlab[dask]'", key="--scheduler") from None
        self._own = False
        if isinstance(scheduler, Client):
            self.client = scheduler
        elif isinstance(scheduler, str):
            check_address(scheduler)
            try:
                self.client = Client(scheduler, timeout=timeout, set_as_default=False)
            except (OSError, ValueError) as e:
                from torlab.errors import TorlabInputError

                raise TorlabInputError(f"cannot reach the Dask scheduler at {scheduler}: {e}",
                                       key="--scheduler") from None
            self._own = True
        else:  # a cluster object
            self.client = Client(scheduler, set_as_default=False)
            self._own = True
        info = self.client.scheduler_info()
        self.workers = max(1, sum(int(w.get("nthreads", 1)) for w in info["workers"].values()))
        self._agree: dict[Any, bool] = {}
        self.address = getattr(self.client.scheduler, "address", str(scheduler))

    def describe(self) -> str:
        return f"Dask cluster {self.address} ({self.workers} worker threads)"

    def map(self, fn: Callable[[Any], Any], items: Iterable[Any], *,
            description: str = "", uses: Sequence[str | Callable[[], Any]] | None = None,
            chunksize: int = 1, each: Callable[[int, Any], Any] | None = None) -> list[Any]:
        items = list(items)
        if not items:
            return []
        from torlab.progress import current as progress

        # short tasks go in blocks, as to local workers: the scheduler's and the
        # workers' cost per task (a few ms of Dask's bookkeeping and transfers) would
        # otherwise be larger than the task
        blocks = chunks(len(items), chunksize)
        cwd = os.getcwd()
        if len(blocks) == len(items):
            futs = self.client.map(_dask_run, [fn] * len(items), items, pure=False, cwd=cwd)
        else:
            futs = self.client.map(_dask_run_block, [fn] * len(blocks),
                                   [items[b] for b in blocks], pure=False, cwd=cwd)
        out = []
        try:
            with progress().task(description, len(items) if description else 0) as advance:
                for f, b in zip(futs, blocks, strict=True):  # in order: the first error first
                    try:
                        got = f.result()
                    except _BlockError as e:
                        raise e.error from None
                    for j, (res, ws) in enumerate(got if len(blocks) < len(items)
                                                  else [got]):
                        out.append((res if each is None else each(b.start + j, res), ws))
                    advance(b.stop - b.start)
        except BaseException:
            self.client.cancel(futs)
            raise
        return _results(out)

    def background(self, fn: Callable[[Any], Any], items: Iterable[Any], *,
                   description: str = "") -> Background:
        """The tasks submitted now at a lower priority than every :meth:`map`'s, so the
        scheduler gives a worker a background task only when no other task waits.

        The ``i``-th task of every batch has the priority ``-10 - i``: the batches
        started at different times take turns, as the local pool's do (:class:`_Feed`),
        instead of each waiting for all earlier ones (Dask's order among equal
        priorities).  A protocol run starts a section of 192 fit figures and then the
        campaign-wide figures (about 2 s each): in turn, these are drawn while the fit
        figures remain to fill the end; in order, they came last, one worker drawing
        alone for their last 2 s.
        """
        items = list(items)
        if not items:
            return Background(lambda: [])
        cwd = os.getcwd()
        futs = [self.client.submit(_dask_run, fn, it, pure=False, priority=-10 - i, cwd=cwd)
                for i, it in enumerate(items)]

        def results() -> list[Any]:
            from torlab.progress import current as progress

            out = []
            try:
                with progress().task(description, len(items) if description else 0) as adv:
                    for f in futs:  # in order: the first error in task order
                        out.append(f.result())
                        adv()
            except BaseException:
                self.client.cancel(futs)
                raise
            futs.clear()  # the results are the caller's now
            return _results(out)

        def one(i: int) -> Any:
            f, futs[i] = futs[i], None
            if f is None:
                raise RuntimeError("background task already taken")
            return _results([f.result()])[0]

        return Background(results, lambda: self.client.cancel([f for f in futs if f is not None]),
                          one)

    def agree(self, fn: Callable[[], Any]) -> bool:
        """Whether ``fn()`` gives the same on every worker of the cluster as here (asked
        once per function and cluster; no: when a worker cannot be asked)."""
        known = self._agree.get(fn)
        if known is None:
            try:
                got, here = self.client.run(fn), fn()
                known = bool(got) and all(v == here for v in got.values())
            except Exception:  # a worker that cannot answer does not agree
                known = False
            self._agree[fn] = known
        return known

    def close(self) -> None:
        if self._own:
            self.client.close()
            self._own = False


#: one task at a time per process on a Dask worker: Python's warning capture
#: (``warnings.catch_warnings``) is process-wide, so two tasks on threads of one
#: process would record (or lose) each other's warnings
_DASK_TASK_LOCK = threading.Lock()


def _dask_run(fn: Callable[[Any], Any], item: Any, cwd: str | None = None
              ) -> tuple[Any, list[tuple[Any, ...]]]:
    """A task on a Dask worker (:func:`_run`), one at a time in its process, in the
    driver's working directory ``cwd`` where the worker has it (so that the relative
    paths the driver was given name the same files).

    Run workers as processes with one thread each (``dask worker --nthreads 1``,
    ``LocalCluster(processes=True, threads_per_worker=1)``) to use every core:
    threads of one process take torlab's tasks in turn.
    """
    return _dask_run_block(fn, [item], cwd, block=False)


def _dask_run_block(fn: Callable[[Any], Any], items: Sequence[Any], cwd: str | None = None,
                    *, block: bool = True) -> Any:
    """A block of tasks on a Dask worker (:func:`_run_block`; ``block=False``: one task,
    :func:`_run`), in the driver's working directory (:func:`_dask_run`)."""
    _CURRENT.set(None)  # a task on a threaded worker starts no tasks of its own
    with _DASK_TASK_LOCK:
        here = os.getcwd()
        move = cwd is not None and cwd != here and os.path.isdir(cwd)
        if move:
            os.chdir(cwd)  # process-wide: one task at a time in this process (the lock)
        try:
            return _run_block(fn, items) if block else _run(fn, items[0])
        finally:
            if move:
                os.chdir(here)


# ------------------------------------------------------------------------------ choosing
_SERIAL = SerialExecutor()


def current() -> Executor:
    """The executor in use (serial outside any ``with use(...)`` block and inside workers)."""
    return _CURRENT.get() or _SERIAL


@contextmanager
def use(executor: Executor) -> Iterator[Executor]:
    """Make ``executor`` the :func:`current` one inside the block (and close it after)."""
    with executor:
        yield executor


@contextmanager
def activate(executor: Executor) -> Iterator[Executor]:
    """Make ``executor`` the :func:`current` one inside the block, leaving it open (for an
    executor used by several blocks)."""
    token = _CURRENT.set(executor)
    try:
        yield executor
    finally:
        _CURRENT.reset(token)


#: the protocols of a Dask scheduler address torlab passes on (``tcp://host:8786``)
ADDRESS_PROTOCOLS = ("tcp", "tls", "ucx", "ws", "wss", "inproc")


def check_address(address: str) -> None:
    """Refuse a scheduler address Dask could only fail on late: an unknown protocol (with a
    "did you mean"), or a port that is not a number from 1 to 65535 (``tcp://host:8786``).

    Raises
    ------
    TorlabInputError
        Keyed ``--scheduler``.
    """
    from torlab._suggest import did_you_mean
    from torlab.errors import TorlabInputError

    proto, sep, rest = address.strip().partition("://")
    if not sep:
        proto, rest = "tcp", address.strip()
    if proto not in ADDRESS_PROTOCOLS:
        raise TorlabInputError(f"{address!r}: unknown protocol {proto!r} (write tcp://host:8786)"
                               f"{did_you_mean(proto, ADDRESS_PROTOCOLS)}", key="--scheduler")
    if proto == "inproc":
        return
    host, colon, port = rest.rpartition(":") if not rest.endswith("]") else (rest, "", "")
    if not rest or (colon and (not host or not port.isdigit() or not 1 <= int(port) <= 65535)):
        raise TorlabInputError(f"{address!r} is not a scheduler address: write host:port, e.g. "
                               "tcp://192.168.1.10:8786", key="--scheduler")


def get_executor(jobs: int | None = None, scheduler: str | None = None) -> Executor:
    """The executor for the command-line options ``--jobs`` and ``--scheduler``.

    ``scheduler`` wins; else ``jobs`` 1 is serial and anything else (default: the
    environment variable ``TORLAB_JOBS``, else every usable core) a
    :class:`ProcessExecutor` -- serial too where only one core is usable.
    """
    if scheduler:
        return DaskExecutor(scheduler)
    n = _job_count(jobs)
    if n <= 1:
        return SerialExecutor()
    return ProcessExecutor(n)


def _job_count(jobs: int | None) -> int:
    """Worker processes for ``--jobs`` (None: ``TORLAB_JOBS``, else every usable core)."""
    if jobs is None and os.environ.get("TORLAB_JOBS", "").strip():
        try:
            jobs = int(os.environ["TORLAB_JOBS"])
        except ValueError:
            from torlab.errors import TorlabInputError

            raise TorlabInputError(f"TORLAB_JOBS={os.environ['TORLAB_JOBS']!r} is not a whole "
                                   "number of worker processes", key="TORLAB_JOBS") from None
    return usable_cores() if jobs is None or jobs <= 0 else int(jobs)


def map_tasks(fn: Callable[[Any], Any], items: Iterable[Any], *, description: str = "",
              uses: Sequence[str | Callable[[], Any]] | None = None, chunksize: int = 1,
              each: Callable[[int, Any], Any] | None = None) -> list:
    """:meth:`Executor.map` on the :func:`current` executor."""
    return current().map(fn, items, description=description, uses=uses, chunksize=chunksize,
                         each=each)


def chunks(n: int, size: int) -> list[slice]:
    """``n`` items in fixed blocks of ``size`` (the split never depends on the workers)."""
    size = max(1, int(size))
    return [slice(i, min(i + size, n)) for i in range(0, n, size)]


# ------------------------------------------------------------------------------ tasks in two stages
class Deferred:
    """What a task returns when its result needs more independent work first.

    ``fn`` (picklable) is to be run on each of ``items``, anywhere, and
    ``then(results)`` -- called in the process that mapped the task, with the
    results in the order of ``items`` -- gives the task's result (or another
    :class:`Deferred`).  :func:`map_deferred` runs the items of every deferred
    task of a map as top-level tasks of one executor: a task never starts tasks
    of its own inside a worker (no nested pools, no idle workers while one
    task works through its part alone).  A sampled prediction band is the case
    in point (:class:`torlab.uncertainty.PendingSampling`).
    """

    def __init__(self, fn: Callable[[Any], Any], items: Sequence[Any],
                 then: Callable[[list[Any]], Any]) -> None:
        self.fn, self.items, self.then = fn, list(items), then


def _call(job: tuple[Callable[[Any], Any], Any]) -> Any:
    fn, item = job
    return fn(item)


class _Completion:
    """The ``each`` of :func:`map_deferred`'s map of subtasks: collects each deferred
    result's subtask results as they arrive (``j``: the subtask's place in the map) and
    completes the result in ``out`` at its last one (``then``, then ``finished``)."""

    def __init__(self, out: list[Any], pending: list[int],
                 finished: Callable[[int, Any], Any] | None) -> None:
        self.out, self.pending, self.finished = out, pending, finished
        sizes = [len(out[i].items) for i in pending]
        self.owner = [k for k, n in enumerate(sizes) for _ in range(n)]
        self.start = list(itertools.accumulate(sizes, initial=0))[:-1]
        self.left = sizes
        self.parts: dict[int, list[Any]] = {}  # pending result -> its subtask results so far

    def __call__(self, j: int, r: Any) -> None:
        k = self.owner[j]
        i = self.pending[k]
        self.parts.setdefault(k, [None] * len(self.out[i].items))[j - self.start[k]] = r
        self.left[k] -= 1
        if not self.left[k]:  # its last subtask
            self._complete(k)

    def without_subtasks(self) -> None:
        """Complete the deferred results that have no subtasks."""
        for k, n in enumerate(self.left):
            if n == 0:
                self._complete(k)

    def _complete(self, k: int) -> None:
        from torlab.threads import limit_threads

        i = self.pending[k]
        d, part = self.out[i], self.parts.pop(k, [])
        with warnings.catch_warnings(record=True) as caught, limit_threads(1):
            v = d.then(part)
        del d, part
        _reissue([(w.message, w.category, w.filename, w.lineno) for w in caught])
        done = self.finished
        self.out[i] = v if done is None or isinstance(v, Deferred) else done(i, v)


def map_deferred(executor: Executor, fn: Callable[[Any], Any], items: Iterable[Any], *,
                 description: str = "", subtasks: str = "",
                 uses: Sequence[str | Callable[[], Any]] | None = None,
                 chunksize: int = 1, each: Callable[[int, Any], Any] | None = None,
                 finished: Callable[[int, Any], Any] | None = None) -> list[Any]:
    """:meth:`Executor.map`, with the :class:`Deferred` results completed.

    The items of all the deferred results go to ``executor`` in one map
    (labelled ``subtasks``), in order; each ``then`` runs here -- as a task would,
    with one BLAS thread -- as the last of its items' results arrives, until no result
    is deferred.  ``uses`` and
    ``chunksize``: as for :meth:`Executor.map`, for the first map; ``each``: for the
    first map's results that are not deferred.  ``finished(i, value)``: called here on
    each result as soon as it is completed here, and what is kept of it (its whole form
    -- a sampled band's every draw -- stored and let go before the next one is
    completed).  A deferred result is completed as soon as its last subtask's result
    arrives (while the others' subtasks run), and its subtask results are let go then:
    the subtask results held here are those of the results still being completed, not
    those of the whole map.  The split into tasks is the tasks' own, so the results do
    not depend on the executor.
    """

    def first(i: int, v: Any) -> Any:
        return v if each is None or isinstance(v, Deferred) else each(i, v)

    out = executor.map(fn, items, description=description, uses=uses, chunksize=chunksize,
                       each=first)
    while True:
        pending = [i for i, v in enumerate(out) if isinstance(v, Deferred)]
        if not pending:
            return out
        jobs = [(out[i].fn, it) for i in pending for it in out[i].items]
        completion = _Completion(out, pending, finished)
        completion.without_subtasks()
        executor.map(_call, jobs, description=subtasks or description, each=completion)
