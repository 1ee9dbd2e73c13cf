"""Benchmark: reducing a long optical tribometer log against a bare ``pandas.read_csv``.

The goal: reducing a 30-minute 1 kHz log (1.8 M rows) takes at most
1.5x a bare ``pandas.read_csv`` of the same file, with bounded memory.  This
benchmark writes such a log with the virtual rig (:mod:`torlab.synth.optical`;
Stribeck-like conditions of 8 s, film frames at 25 Hz) to a temporary folder
and measures, side by side on this machine,

* ``pandas.read_csv(path, comment="#")`` (type inference, every column);
* :func:`torlab.reduce.optical.reduce_optical_log` (field-count pass, chunked
  typed read, validation, windowed averages);

as medians of interleaved rounds (bare read, then reduction, in each round), in
wall time and in CPU time (``time.process_time``, less disturbed by other jobs
on a shared machine).  It reports both ratios and the peak Python heap (``tracemalloc``) of one run of each; the error of the
reduction is the largest deviation of its windowed coefficient from the
generating one.  ``quick=True`` uses a 2-minute log and fewer repeats.
"""

from __future__ import annotations

import statistics
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from torlab.bench import BenchRow

__all__ = ["run"]


def _log(path: Path, minutes: float) -> list[dict]:
    from torlab.synth.optical import OpticalCondition, OpticalTest, write_optical_log

    n = max(1, round(minutes * 60 / 8.0))
    speeds = np.geomspace(0.05, 2.0, n)
    conds = tuple(OpticalCondition(float(u), 0.05, 90.0, 8.0) for u in speeds)
    test = OpticalTest("bench", "stribeck", "rough", "water", conds)

    def mu(U: np.ndarray, s: np.ndarray) -> np.ndarray:
        return (0.02 + 0.1 / (1 + U / 0.2)) * np.tanh(s / 0.01)

    def h(U: np.ndarray) -> np.ndarray:
        return 100e-9 * U**0.67

    return write_optical_log(path, test, mu, h, seed=1)


def _peak(fn) -> float:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def run(quick: bool = False) -> list[BenchRow]:
    """Time a bare read against the full reduction of a synthetic 1 kHz log (see module docstring)."""
    import pandas as pd

    from torlab.reduce.optical import reduce_optical_log

    minutes = 2.0 if quick else 30.0
    repeat = 1 if quick else 5
    with tempfile.TemporaryDirectory(prefix="torlab-bench-optical-") as tmp:
        path = Path(tmp) / "log.csv"
        truth = _log(path, minutes)
        size_mb = path.stat().st_size / 1e6
        holder: dict = {}

        def bare() -> None:
            holder["df"] = pd.read_csv(path, comment="#")

        def reduce() -> None:
            holder["res"] = reduce_optical_log(path)

        # bare read and reduction interleaved, wall and CPU time of each round: a burst of
        # load from other jobs on the shared machine then hits both sides alike
        wall_bare, wall_red, cpu_bare, cpu_red = [], [], [], []
        rows = 0
        for _ in range(repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            bare()
            wall_bare.append(time.perf_counter() - t0)
            cpu_bare.append(time.process_time() - c0)
            rows = len(holder.pop("df"))
            t0, c0 = time.perf_counter(), time.process_time()
            reduce()
            wall_red.append(time.perf_counter() - t0)
            cpu_red.append(time.process_time() - c0)
        res = holder.pop("res")
        t_bare, t_red = statistics.median(wall_bare), statistics.median(wall_red)
        cpu_ratio = statistics.median(cpu_red) / statistics.median(cpu_bare)
        mem_bare = _peak(bare)
        holder.clear()
        mem_red = _peak(reduce)
        holder.clear()
    mu_true = np.array([r["traction_coefficient"] for r in truth])
    err = float(np.max(np.abs(res.points["traction_coefficient"].to_numpy() - mu_true)))
    unit = f"{minutes:g}-minute 1 kHz log ({rows} rows, {size_mb:.0f} MB)"
    ratio = t_red / t_bare
    return [
        BenchRow("optical log reduction", "pandas.read_csv (bare, baseline)", t_bare,
                 reference="", unit_of_work=unit,
                 extra={"peak_heap_MB": round(mem_bare / 1e6, 1), "ratio_to_bare": 1.0}),
        BenchRow("optical log reduction", "reduce_optical_log (chunked, 4 s windows)", t_red,
                 error=err, error_kind="absolute (coefficient)",
                 reference="generating coefficient at each set condition", default=True,
                 unit_of_work=unit,
                 extra={"peak_heap_MB": round(mem_red / 1e6, 1), "ratio_to_bare": round(ratio, 3),
                        "cpu_ratio_to_bare": round(cpu_ratio, 3), "target_ratio": 1.5,
                        "conditions": len(res.points)}),
    ]


if __name__ == "__main__":  # pragma: no cover
    for r in run(quick=False):
        print(r.to_dict())
