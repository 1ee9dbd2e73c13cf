"""Benchmark of the creep forces in xi, eta, phi: speed against error, and table time.

Scene: the wheel-rail contact of thesis Tab. 5.4 (a = 3.7 mm, b = 3.3 mm, F = 20 kN,
steel) with the example layer (mu_c1 0.30, mu_c2 0.45, L_mue 10 um, L_mup 20 um),
isothermal.  Measured side by side in one run:

* ``torlab`` -- :func:`torlab.model.creep.creep_forces` at several
  :class:`~torlab.model.creep.CreepGrid` s, the default marked; unit of work: one
  3-creepage point (xi, eta, phi all non-zero), as a vehicle-dynamics code calls it;
* ``baseline`` -- :func:`torlab.model.reference_solvers.naive_creep_forces`, the first-order
  FASTSIM with spin on a uniform ``m x m`` grid (Kalker's discrete scheme as CONTACT
  runs it, with the layer), vectorised over the rows;
* the longitudinal point of :func:`torlab.model.fastsim.boundary_traction` (the cost
  a 3-creepage point is compared with), and both on a 101-point curve (cost per point
  when vectorised); the ratios are medians over rounds in which the two are timed one
  after the other, so a change of the machine's load between them does not enter;
* the 21 x 21 x 11 table (Kalker-normalised axes -1..1 in xi*, eta* and phi*) through
  :func:`torlab.model.creep_table.creep_table`, serially and on a two-process pool.

Error of a variant: the largest of ``|F - F_ref|/(mu_c2 N)`` over the components Fx, Fy
and ``|Mz - Mz_ref|/(mu_c2 N c)`` (``c = sqrt(ab)``) and over the test set, against the
grid-free reference :func:`torlab.model.reference_solvers.creep_forces_reference` (ODE per strip
with events, adaptive quadrature across), evaluated once per run.  The default row's
``extra`` holds the per-component errors, the ratios the issue asks for and the
machine's load (the machines are shared: only ratios measured in one run mean much).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import replace
from functools import lru_cache
from typing import Any

import numpy as np

from torlab.bench import BenchRow, median_time
from torlab.model.creep import CreepGrid, CreepProblem, creep_forces, creep_problem
from torlab.model.reference_solvers import creep_forces_reference, naive_creep_forces

__all__ = ["TEST_SET", "paired_ratio", "run", "wheel_rail_problem"]

SCENE: dict[str, Any] = {
    "name": "wheel-rail Tab. 5.4 (isothermal)",
    "contact": {"load": "20 kN", "a": "3.7 mm", "b": "3.3 mm", "r1x": "350 mm"},
    "materials": {"E1": "210 GPa", "nu1": 0.28, "E2": "210 GPa", "nu2": 0.28},
    "kinematics": {"speed": "10 m/s", "ambient_temperature": "20 degC"},
    "boundary": {"mu_c1": 0.30, "mu_c2": 0.45, "L_mue": "10 um", "L_mup": "20 um"},
}
#: (xi, eta, phi 1/m): spin alone and with creepages, lateral, near and in saturation
TEST_SET: tuple[tuple[float, float, float], ...] = (
    (3e-3, 0.0, 1.0), (2e-3, 1e-3, 3.0), (0.0, 0.0, 5.0), (5e-4, 0.0, 2.0),
    (1e-3, 5e-4, -20.0), (0.02, -0.01, 10.0), (0.05, 0.0, 30.0), (3e-3, 1e-3, 0.0),
)
QUICK_SET = TEST_SET[:2]
POINT = (3e-3, 1e-3, 2.0)
DEFAULT = CreepGrid()


def wheel_rail_problem() -> CreepProblem:
    """The benchmark's :class:`CreepProblem`, built through the scene API."""
    from torlab.scene import scene_from_dict

    return creep_problem(scene_from_dict(SCENE))


@lru_cache(maxsize=64)
def _reference(prob: CreepProblem, case: tuple[float, float, float]) -> tuple[float, ...]:
    return creep_forces_reference(prob, *case, rtol=1e-8)


def paired_ratio(a: Callable[[], Any], b: Callable[[], Any], *, rounds: int = 9,
                 min_time: float = 0.05) -> tuple[float, float, float]:
    """``(median time of a, median time of b, median of the per-round ratios a/b)``.

    Each round times ``a`` and then ``b`` (each repeated to last ``min_time``), so both see
    the same load of the shared machine; the ratio is the median over the rounds.
    """
    import time

    def loops(fn: Callable[[], Any]) -> int:
        t0 = time.perf_counter()
        fn()
        return max(1, int(min_time / max(time.perf_counter() - t0, 1e-9)))

    na, nb = loops(a), loops(b)
    ta, tb = [], []
    for _ in range(rounds):
        for fn, n, out in ((a, na, ta), (b, nb, tb)):
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            out.append((time.perf_counter() - t0) / n)
    A, B = np.array(ta), np.array(tb)
    return float(np.median(A)), float(np.median(B)), float(np.median(A / B))


def _errors(prob: CreepProblem, cases: tuple, fn: Callable[[tuple], tuple]) -> np.ndarray:
    """Largest normalised error per component (Fx, Fy, Mz) over ``cases``."""
    scale = float(prob.layer.law.reference_mu(prob.layer)) * prob.load * np.array([1.0, 1.0, math.sqrt(prob.a * prob.b)])
    err = np.zeros(3)
    for c in cases:
        got = np.array(fn(c), dtype=float).ravel()
        err = np.maximum(err, np.abs(got - np.array(_reference(prob, c))) / scale)
    return err


def _table_axes(prob: CreepProblem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from torlab.model.creep_table import kalker_scales

    s = kalker_scales(prob)
    return (np.linspace(-1, 1, 21) / s["xi"], np.linspace(-1, 1, 21) / s["eta"],
            np.linspace(-1, 1, 11) / s["phi"])


def _table(prob: CreepProblem, workers: int) -> float:
    import time

    from torlab.model.creep_table import creep_table

    axes = _table_axes(prob)
    t0 = time.perf_counter()
    if workers <= 1:
        creep_table(prob, *axes)
    else:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers) as ex:
            creep_table(prob, *axes, map_fn=ex.map)
    return time.perf_counter() - t0


def run(quick: bool = False) -> list[BenchRow]:
    """Creep-force speed against error (see the module docstring).

    Parameters
    ----------
    quick
        Two reference cases, fewer grids, no table on the process pool.
    """
    from torlab.bench.fastsim import time_at_error
    from torlab.model.fastsim import FastsimProblem, boundary_traction

    prob = wheel_rail_problem()
    cases = QUICK_SET if quick else TEST_SET
    ref_name = (f"creep_forces_reference (grid-free: ODE per strip, adaptive quadrature) on "
                f"{len(cases)} cases")
    unit = "one 3-creepage point (xi, eta, phi) of the Tab. 5.4 scene"
    comp = "creep forces xi, eta, phi"
    reps = {"repeat": 3 if quick else 5, "min_time": 0.03 if quick else 0.1}

    def point(g: CreepGrid) -> Callable[[tuple], tuple]:
        def f(c):
            r = creep_forces(prob, *c, grid=g)
            return r.Fx, r.Fy, r.Mz
        return f

    grids = [DEFAULT, replace(DEFAULT, m=3), replace(DEFAULT, spin_panels=4),
             replace(DEFAULT, m=6), replace(DEFAULT, spin_panels=16, m=6, uniform_panels=32)]
    if quick:
        grids = grids[:2]
    rows = []
    for g in grids:
        e = _errors(prob, cases, point(g))
        t = median_time(lambda g=g: creep_forces(prob, *POINT, grid=g), **reps)
        rows.append(BenchRow(comp, f"torlab strips {g.spin_panels}x{g.spin_strips} m={g.m} "
                             f"panels 1+{g.graded_panels}+{g.uniform_panels}", t, float(e.max()),
                             ref_name, g == DEFAULT, unit, error_kind="of mu_c2 N",
                             extra={"family": "torlab", "error_Fx": e[0], "error_Fy": e[1],
                                    "error_Mz": e[2]}))
    base = []
    for m in ((20, 40, 80) if quick else (20, 40, 80, 160, 320)):
        def nv(c, m=m):
            return naive_creep_forces(prob, *c, mx=m, my=m)

        e = _errors(prob, cases, nv)
        t = median_time(lambda m=m: naive_creep_forces(prob, *POINT, mx=m, my=m),
                        repeat=3, min_time=0.0 if m >= 160 else reps["min_time"])
        base.append(BenchRow(comp, f"baseline first-order FASTSIM {m}x{m}", t, float(e.max()),
                             ref_name, False, unit, error_kind="of mu_c2 N",
                             extra={"family": "baseline", "error_Fx": e[0], "error_Fy": e[1],
                                    "error_Mz": e[2]}))
    d = rows[0]
    # the longitudinal point and the per-point cost of a 101-point curve, each timed in
    # rounds alternating with the 3-creepage one
    fp = FastsimProblem(a=prob.a, b=prob.b, p0=prob.p0, L1=prob.L1, layer=prob.layer)
    rounds = 5 if quick else 15
    t_3, t_lon, r_point = paired_ratio(lambda: creep_forces(prob, *POINT),
                                       lambda: boundary_traction(fp, POINT[0]), rounds=rounds)
    _, t_lon_creep, r_point_own = paired_ratio(lambda: creep_forces(prob, *POINT),
                                               lambda: creep_forces(prob, POINT[0]),
                                               rounds=rounds)
    xi = np.linspace(1e-4, 0.05, 101)
    t_curve_3, t_curve_lon, r_curve = paired_ratio(
        lambda: creep_forces(prob, xi, 0.3 * xi, 400.0 * xi), lambda: boundary_traction(fp, xi),
        rounds=rounds, min_time=0.2)
    rows.append(BenchRow("creep forces: longitudinal point", "torlab.model.fastsim "
                         "boundary_traction", t_lon, None, "", False,
                         "one longitudinal point", extra={"family": "longitudinal"}))
    rows.append(BenchRow("creep forces: 101-point curve", "torlab default, xi 1e-4..0.05, "
                         "eta = 0.3 xi, phi = 400 xi 1/m", t_curve_3, None, "", False,
                         "101-point curve", extra={"family": "curve"}))
    rows.append(BenchRow("creep forces: 101-point curve", "torlab.model.fastsim "
                         "boundary_traction, xi 1e-4..0.05", t_curve_lon, None, "", False,
                         "101-point curve", extra={"family": "curve"}))
    extra: dict[str, Any] = {
        "ratio_3creepage_point_to_longitudinal_point": r_point,
        "ratio_target": 3.0,
        "ratio_3creepage_point_to_longitudinal_point_of_creep": r_point_own,
        "time_3creepage_point_paired_s": t_3,
        "time_longitudinal_point_s": t_lon,
        "time_longitudinal_point_of_creep_s": t_lon_creep,
        "ratio_per_point_101_curve_3creepage_to_longitudinal": r_curve,
        "time_101_curve_longitudinal_s": t_curve_lon, "time_101_curve_3creepage_s": t_curve_3,
        "loadavg_1min": os.getloadavg()[0], "cpus": os.cpu_count(),
    }
    pts = [(r.error, r.time_s) for r in base if r.error]
    for target, key in ((1e-3, "at_0.1pct"), (d.error, "at_default_error")):
        tb, how = time_at_error(pts, target)
        extra[f"ratio_vs_baseline_{key}"] = tb / d.time_s if math.isfinite(tb) else None
        extra[f"ratio_vs_baseline_{key}_how"] = how
    # the table
    t_tab = _table(prob, 1)
    extra["table_21x21x11_serial_s"] = t_tab
    if not quick:
        extra["table_21x21x11_2_processes_s"] = _table(prob, 2)
    extra["table_target_s"] = 10.0
    rows.append(BenchRow("creep-force table", "21x21x11, serial", t_tab, None, "", False,
                         "21 x 21 x 11 table, Kalker-normalised axes -1..1",
                         extra={"family": "table"}))
    d.extra.update(extra)
    return rows + base
