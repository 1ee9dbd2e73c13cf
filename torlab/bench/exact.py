"""Benchmark of Kalker's exact theory (``torlab.model.exact``): time against grid and error.

Cases: three rows of the FASTSIM-error table (:mod:`torlab.model.exact.fastsim_error`):
pure longitudinal creepage at ``xi* = 0.1`` on a circle, pure spin and lateral creepage
against spin on ``a/b = 0.5`` (Coulomb friction, ``nu = 0.28``).  Measured in one run:

* ``one grid``: one solve (from rest) on ``n x n`` elements over the ellipse (two more on
  every side), for ``n`` from 10 to 50; unit of work: one case, the median over the cases;
* ``two grids``: a point of :func:`~torlab.model.exact.rolling.exact_creep_forces`
  (``n`` and ``0.6 n``, the answer with its Richardson error), for ``n`` = 15, 25, 40;
* the 101-point curve (``xi*`` 0.005..1.5) on 25 and 15 elements, each point starting from
  its predecessor, serially and on two worker processes (``torlab.parallel``);
* torlab's default boundary method (FASTSIM) on the same cases: its time and its theory
  error against the exact theory over the whole FASTSIM-error table.

Error of a grid: the largest ``|F - F_ref|/(mu N)`` (``Mz`` over ``mu N c``) over the cases
and components against the exact theory on 80 x 80 elements extrapolated with 48 x 48
(Richardson at first order), evaluated once per run.  The rows' ``extra`` hold the
estimated errors (Richardson from the two grids), CONTACT's published single-thread times
(a 2016 machine: 1.6 ms on 11 x 11, 28 ms on 25 x 25, 133 ms on 35 x 35) and the
machine's load: the machines are shared, only ratios measured in one run mean much.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from torlab.bench import BenchRow, median_time

__all__ = ["run"]

CASE_NAMES = ("xi_small", "spin", "lateral_spin")
CONTACT_PUBLISHED = {"11x11_s": 1.6e-3, "25x25_s": 28e-3, "35x35_s": 133e-3}
DEFAULT_N = 25


def _cases() -> list[Any]:
    from torlab.model.exact.fastsim_error import CASES

    return [c for c in CASES if c.name in CASE_NAMES]


def _values(case: Any, n: int, coarse: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Normalised ``(Fx, Fy, Mz)`` and their Richardson errors on one (or two) grids."""
    from torlab.model.exact.fastsim_error import case_contact, case_creepages, case_scales
    from torlab.model.exact.rolling import ExactGrid, exact_creep_forces

    c = case_contact(case)
    r = exact_creep_forces(c, *case_creepages(case, c), grid=ExactGrid(n=n, coarse=coarse))
    sc = case_scales(c)
    v = np.array([float(r.Fx[()]) / sc["Fx"], float(r.Fy[()]) / sc["Fy"],
                  float(r.Mz[()]) / sc["Mz"]])
    e = np.array([float(r.Fx_error[()]) / sc["Fx"], float(r.Fy_error[()]) / sc["Fy"],
                  float(r.Mz_error[()]) / sc["Mz"]])
    return v, e


def _solver(case: Any, n: int):
    """A function solving the case from rest on one ``n x n`` grid (set up once)."""
    from torlab.model.exact.fastsim_error import case_contact, case_creepages
    from torlab.model.exact.rolling import ExactGrid, RollingSetup

    c = case_contact(case)
    setup = RollingSetup(c, n, ExactGrid(n=n))
    cr = case_creepages(case, c)
    return lambda: setup.solve(*cr, None)


def _cpu_time(fn, repeat: int = 3) -> float:
    """Median CPU time of this process for one call (s): on a shared machine the wall time
    also holds the waits for the cores, the CPU time does not."""
    out = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        out.append(time.process_time() - t0)
    return float(np.median(out))


def _curve_time(jobs: int) -> tuple[float, float]:
    from torlab import parallel
    from torlab.model.exact.fastsim_error import CASES, case_contact
    from torlab.model.exact.rolling import ExactGrid, exact_creep_forces, normalised_creepages

    c = case_contact(CASES[0])
    xs = normalised_creepages(c, 1.0)[0]
    xi = np.linspace(0.005, 1.5, 101) / float(xs)
    grid = ExactGrid(n=DEFAULT_N)
    ex = parallel.get_executor(jobs)
    try:
        with parallel.use(ex):
            exact_creep_forces(c, xi[:2], grid=grid)          # start the workers
            t0, c0 = time.perf_counter(), time.process_time()
            exact_creep_forces(c, xi, grid=grid)
            return time.perf_counter() - t0, time.process_time() - c0
    finally:
        ex.close()


def run(quick: bool = False) -> list[BenchRow]:
    """Exact-solver speed against error (see the module docstring).

    Parameters
    ----------
    quick
        Fewer grids, a coarser reference, no process pool.
    """
    from torlab.model.exact.fastsim_error import error_table
    from torlab.model.exact.fastsim_error import fastsim_values as fs_values

    cases = _cases()
    ref_n, ref_c = (48, 32) if quick else (80, 48)
    ref = {c.name: _values(c, ref_n, ref_c)[0] for c in cases}
    ref_name = (f"exact theory on {ref_n} x {ref_n} elements extrapolated with {ref_c} x "
                f"{ref_c} (Richardson) on {len(cases)} cases")
    load = os.getloadavg()[0]
    rows: list[BenchRow] = []
    grids = (10, 15, 25) if quick else (10, 15, 20, 25, 32, 40, 50)
    reps = {"repeat": 3, "min_time": 0.05 if quick else 0.2}
    for n in grids:
        times, cpus, errs, steps = [], [], [], []
        for c in cases:
            f = _solver(c, n)
            times.append(median_time(f, **reps))
            cpus.append(_cpu_time(f))
            sol = f()
            steps.append(sol.newton)
            v, _ = _values(c, n)
            errs.append(np.abs(v - ref[c.name]).max())
        rows.append(BenchRow(
            "exact solver, one grid", f"{n}x{n} elements on the ellipse (+2 on every side)",
            float(np.median(times)), float(max(errs)), ref_name, n == DEFAULT_N,
            "one case solved from rest (median over the cases)", error_kind="of mu N",
            extra={"family": "one grid", "newton_steps_max": max(steps),
                   "cpu_per_case_s": float(np.median(cpus)),
                   "times_per_case_s": [round(t, 5) for t in times],
                   "contact_published_single_thread": CONTACT_PUBLISHED,
                   "loadavg_1min": load, "cpus": os.cpu_count()}))
    for n in ((15, 25) if quick else (15, 25, 40)):
        times, errs, est = [], [], []
        for c in cases:
            times.append(median_time(lambda c=c, n=n: _values(c, n, round(0.6 * n)),
                                     repeat=3, min_time=0.0))
            v, e = _values(c, n, round(0.6 * n))
            errs.append(np.abs(v - ref[c.name]).max())
            est.append(e.max())
        rows.append(BenchRow(
            "exact creep forces, two grids", f"{n} and {round(0.6 * n)} elements "
            "(Richardson error)", float(np.median(times)), float(max(errs)), ref_name,
            n == DEFAULT_N, "one point with its discretisation error (setup included)",
            error_kind="of mu N",
            extra={"family": "two grids", "estimated_error_max": float(max(est)),
                   "estimated_errors": [float(x) for x in est],
                   "actual_errors": [float(x) for x in errs]}))
    t_serial, cpu_serial = _curve_time(1)
    curve_extra: dict[str, Any] = {"family": "curve", "target_2_jobs_s": 5.0,
                                   "cpu_serial_s": cpu_serial, "loadavg_1min": load}
    rows.append(BenchRow("exact creep forces: 101-point curve", "25 and 15 elements, serial",
                         t_serial, None, "", False, "101-point curve, xi* 0.005..1.5",
                         extra=curve_extra))
    if not quick:
        t2, _ = _curve_time(2)
        rows.append(BenchRow("exact creep forces: 101-point curve",
                             "25 and 15 elements, --jobs 2", t2, None, "", False,
                             "101-point curve, xi* 0.005..1.5",
                             extra={**curve_extra, "ratio_serial_to_2_jobs": t_serial / t2}))
    # the default method's theory error against the exact theory, and its time
    from torlab.model.exact.fastsim_error import CASES

    table = error_table(cases=CASES[:3] if quick else CASES)
    worst = table.loc[table.error.abs().idxmax()]
    t_fs = float(np.median([median_time(lambda c=c: fs_values(c), **reps) for c in cases]))
    rows.append(BenchRow(
        "default method's theory error", "FASTSIM (three flexibilities, elliptical bound)",
        t_fs, float(table.error.abs().max()), "the exact theory, FASTSIM-error table "
        f"({len(table)} rows)", False, "one case", error_kind="relative, largest over the table",
        extra={"family": "theory error", "worst_case": f"{worst.case} {worst.quantity}",
               "errors": {f"{r.case} {r.quantity}": round(float(r.error), 4)
                          for r in table.itertuples()}}))
    return rows
