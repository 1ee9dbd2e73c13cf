"""Benchmark of the executor (``torlab bench --only parallel``): one parameter study serially,
on local processes and on a Dask cluster -- its scaling, and that the results are the same.

The study is what a user maps over many independent conditions: the creep-force table of
the thesis's Tab. 5.4 wheel-rail contact with its flash temperature and example layer
over longitudinal creepage x lateral creepage x spin x rolling speed, in torlab's fixed
chunks (:func:`torlab.model.creep_table.creep_table`).  Measured side by side in one run,
rounds interleaved:

* ``serial`` (``--jobs 1``, the reference of the speed-up);
* ``processes`` with 1 and 2 workers (``--jobs N``);
* ``dask`` -- a Dask ``LocalCluster`` of 1 and 2 worker processes, one thread each, the
  client in this process (what ``--scheduler`` connects to; needs ``distributed``, else
  the rows are left out).

Each row's ``extra`` holds the speed-up over serial, the number of tasks, and whether the
table is identical to the serial one byte for byte (``identical``).  On a shared 2-core
machine the speed-up of 2 workers is bounded by what the other jobs leave free
(``load_average`` at the start is recorded): read it with that in mind.
"""

from __future__ import annotations

import logging
import os
import time
from typing import Any

import numpy as np

from torlab.bench import BenchRow

__all__ = ["run"]


def _study(quick: bool) -> tuple[Any, tuple, dict[str, Any]]:
    from pathlib import Path

    from torlab.model.creep import creep_problem
    from torlab.scene import load_scene

    scene = Path(__file__).resolve().parents[2] / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
    prob = creep_problem(load_scene(scene))
    if quick:
        axes = (np.linspace(-0.01, 0.01, 7), np.linspace(-0.005, 0.005, 3), [0.0, 1.0])
        return prob, axes, {"speed": [5.0, 20.0], "chunk": 8}
    axes = (np.linspace(-0.01, 0.01, 21), np.linspace(-0.01, 0.01, 11), np.linspace(-2, 2, 5))
    return prob, axes, {"speed": [5.0, 10.0, 20.0, 40.0], "chunk": 256}


def _table(prob: Any, axes: tuple, opts: dict[str, Any]) -> dict[str, np.ndarray]:
    from torlab.model.creep_table import creep_table

    tab = creep_table(prob, *axes, speed=opts["speed"], chunk=opts["chunk"])
    return {k: tab.dataset[k].values for k in tab.dataset.data_vars}


def _same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    return a.keys() == b.keys() and all(a[k].tobytes() == b[k].tobytes() for k in a)


def run(quick: bool = False) -> list[BenchRow]:
    """Time of the study on each executor, its speed-up over serial (module docstring)."""
    from torlab.parallel import DaskExecutor, ProcessExecutor, SerialExecutor, activate

    prob, axes, opts = _study(quick)
    n_points = int(np.prod([len(a) for a in axes])) * len(opts["speed"])
    rounds = 1 if quick else 2
    makers: list[tuple[str, Any]] = [
        ("serial (--jobs 1)", SerialExecutor),
        ("1 local process (--jobs 1 as a pool)", lambda: ProcessExecutor(1)),
        ("2 local processes (--jobs 2)", lambda: ProcessExecutor(2)),
    ]
    clusters: list[Any] = []
    try:
        import warnings

        from distributed import Client, LocalCluster

        for n in (1, 2):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                lc = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                  dashboard_address=None,
                                  silence_logs=logging.ERROR)
                cl = Client(lc, set_as_default=False)
            clusters.append((lc, cl))
            makers.append((f"Dask LocalCluster, {n} worker{'s' * (n > 1)} (--scheduler)",
                           lambda cl=cl: DaskExecutor(cl)))
    except ImportError:
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    times: dict[str, list[float]] = {name: [] for name, _ in makers}
    results: dict[str, dict[str, np.ndarray]] = {}
    execs = {name: make() for name, make in makers}
    try:
        for name, ex in execs.items():  # warm-up: worker start, imports (not timed)
            with activate(ex):
                results[name] = _table(prob, axes, opts)
        for _ in range(rounds):
            for name, ex in execs.items():
                with activate(ex):
                    t0 = time.perf_counter()
                    results[name] = _table(prob, axes, opts)
                    times[name].append(time.perf_counter() - t0)
    finally:
        for ex in execs.values():
            ex.close()
        quiet = logging.getLogger("distributed")  # the cluster's shutdown chatter
        level = quiet.level
        quiet.setLevel(logging.ERROR)
        try:
            for lc, cl in clusters:
                cl.close()
                lc.close()
        finally:
            quiet.setLevel(level)
    t_serial = float(np.median(times["serial (--jobs 1)"]))
    ref = results["serial (--jobs 1)"]
    n_tasks = len(opts["speed"]) * -(-int(np.prod([len(a) for a in axes])) // opts["chunk"])
    rows = []
    for name, _ in makers:
        t = float(np.median(times[name]))
        rows.append(BenchRow(
            component="executor scaling", variant=name, time_s=t, error=None,
            reference="the serial table, byte for byte", default=name.startswith("serial"),
            unit_of_work=f"creep-force table, {n_points} points in at most {n_tasks} tasks",
            extra={"speedup_vs_serial": t_serial / t, "identical": _same(ref, results[name]),
                   "tasks": n_tasks, "points": n_points, "rounds": rounds,
                   "load_average": load, "usable_cores": _cores()}))
    return rows


def _cores() -> int:
    from torlab.parallel import usable_cores

    return usable_cores()
