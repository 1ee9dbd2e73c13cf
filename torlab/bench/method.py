"""Benchmark of the boundary methods: theory error against Kalker's exact theory and cost.

The methods (:mod:`torlab.model.calibrated`): ``fastsim`` (the default: FASTSIM corrected
by the exact theory), ``fastsim-kalker`` (the thesis's FASTSIM) and ``exact`` (the exact
solver, :mod:`torlab.model.exact`).  Measured in one run:

* **theory error** over the cases of the FASTSIM-error table
  (:mod:`torlab.model.exact.fastsim_error`: pure creepage, spin, lateral creepage with spin,
  Kalker's linear-theory C33 and C32, full slip; Coulomb friction, ``nu = 0.28``): the
  largest relative error of each class -- pure creepage (target 1 %), Fx and Fy with spin
  (3 %), Mz (5 %) -- against the exact column (the exact solver on 40 x 40 elements, 24 x 24
  with ``--quick``) and Kalker's Table E.3 for the linear rows;
* **cost per curve**: a 101-point traction curve in longitudinal creepage on the Tab. 5.4
  wheel-rail scene with its layer (``boundary_traction``), and a 101-point curve in three
  creepages (``xi`` 1e-4..0.05, ``eta = 0.3 xi``, ``phi = 400 xi`` 1/m; ``creep_forces``),
  each method side by side in alternating rounds, as ratios to Kalker's FASTSIM (the target
  for the default: at most 2); and the exact solver's 101-point curve (25 and 15 elements)
  once, serially.

The machine is shared: the ratios, measured in one run, are the result; the times are
what they were.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace
from typing import Any

import numpy as np

from torlab.bench import BenchRow, median_time

__all__ = ["run"]

#: the target of each class (relative error)
TARGETS = {"pure creepage": 0.01, "Fx, Fy with spin": 0.03, "Mz": 0.05}


def _class(case: Any, q: str) -> str:
    if q in ("Mz", "C33", "C32"):
        return "Mz"
    return "pure creepage" if case.eta == 0 and case.phi == 0 else "Fx, Fy with spin"


def _theory_errors(quick: bool) -> dict[str, dict[str, Any]]:
    """Per method: the largest relative error per class and each row's error."""
    from torlab.model.calibration_build import method_values
    from torlab.model.exact.fastsim_error import CASES, exact_values
    from torlab.model.exact.rolling import ExactGrid

    grid = ExactGrid(n=24, coarse=16) if quick else None
    ref = {c.name: exact_values(c, grid) for c in CASES}
    out: dict[str, dict[str, Any]] = {}
    for method in ("fastsim", "fastsim-kalker"):
        worst: dict[str, float] = {}
        rows: dict[str, float] = {}
        for c in CASES:
            got = method_values(c, method)
            for q in c.quantities:
                v, _ = ref[c.name][q]
                e = got[q] / v - 1.0
                rows[f"{c.name} {q}"] = round(float(e), 4)
                k = _class(c, q)
                worst[k] = max(worst.get(k, 0.0), abs(float(e)))
        out[method] = {"worst": worst, "rows": rows}
    return out


def _curves() -> tuple[Any, Any, np.ndarray, tuple[np.ndarray, ...]]:
    from torlab.model.creep import creep_problem
    from torlab.model.prediction import fastsim_problem
    from torlab.scene import scene_from_dict

    scene = scene_from_dict({
        "contact": {"load": "20 kN", "a": "3.7 mm", "b": "3.3 mm"},
        "materials": {"E1": "210 GPa", "nu1": 0.28, "E2": "210 GPa", "nu2": 0.28},
        "kinematics": {"speed": "10 m/s"},
        "boundary": {"mu_c1": 0.30, "mu_c2": 0.45, "L_mue": "10 um", "L_mup": "20 um"}})
    xi = np.linspace(1e-4, 0.05, 101)
    return scene, fastsim_problem(scene), xi, (xi, 0.3 * xi, 400.0 * xi), creep_problem(scene)


def _alternating(fns: dict[str, Any], rounds: int) -> dict[str, float]:
    """Median time of each function over ``rounds`` rounds taken in turn (the machine's load
    changes alike for all)."""
    times: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(rounds):
        for k, f in fns.items():
            times[k].append(median_time(f, repeat=1, min_time=0.0))
    return {k: float(np.median(v)) for k, v in times.items()}


def run(quick: bool = False) -> list[BenchRow]:
    """Theory error and cost of the boundary methods (module docstring)."""
    from torlab.model.creep import creep_forces
    from torlab.model.fastsim import boundary_traction

    load = os.getloadavg()[0]
    errs = _theory_errors(quick)
    scene, fp, xi, cr3, cp = _curves()
    rounds = 3 if quick else 9
    long_t = _alternating({m: (lambda m=m: boundary_traction(
        replace(fp, calibrated=m == "fastsim"), xi)) for m in ("fastsim-kalker", "fastsim")},
        rounds)
    spin_t = _alternating({m: (lambda m=m: creep_forces(
        replace(cp, calibrated=m == "fastsim"), *cr3)) for m in ("fastsim-kalker", "fastsim")},
        max(rounds // 3, 2))
    ref = ("the exact theory (FASTSIM-error table of docs/model/exact.md; "
           + ("24 x 24 elements" if quick else "40 x 40 elements") + "; C33, C32: Kalker)")
    rows: list[BenchRow] = []
    for m in ("fastsim", "fastsim-kalker"):
        worst = errs[m]["worst"]
        rows.append(BenchRow(
            "boundary method: theory error and cost", m, long_t[m],
            float(max(worst.values())), ref, m == "fastsim",
            "101-point traction curve, longitudinal creepage, Tab. 5.4 scene with its layer",
            error_kind="relative, largest over the table",
            extra={"family": "method", "worst_by_class": {k: round(v, 4) for k, v in
                                                         worst.items()},
                   "targets": TARGETS, "rows": errs[m]["rows"],
                   "time_ratio_longitudinal_to_fastsim_kalker":
                       long_t[m] / long_t["fastsim-kalker"],
                   "time_three_creepages_s": spin_t[m],
                   "time_ratio_three_creepages_to_fastsim_kalker":
                       spin_t[m] / spin_t["fastsim-kalker"],
                   "loadavg_1min": load, "cpus": os.cpu_count()}))
    if not quick:
        from torlab.model.exact.rolling import ExactGrid
        from torlab.model.exact.scene import exact_contact

        ec = exact_contact(scene)
        from torlab.model.exact.rolling import exact_creep_forces

        t0 = time.perf_counter()
        r = exact_creep_forces(ec, xi, grid=ExactGrid(n=25))
        t_ex = time.perf_counter() - t0
        rows.append(BenchRow(
            "boundary method: theory error and cost", "exact", t_ex,
            float(np.max(r.Fx_error / np.maximum(np.abs(r.Fx), 1e-300))),
            "its own Richardson estimate (25 and 15 elements)", False,
            "101-point traction curve, longitudinal creepage, Tab. 5.4 scene with its layer",
            error_kind="relative discretisation error, largest over the curve",
            extra={"family": "method", "time_ratio_longitudinal_to_fastsim_kalker":
                   t_ex / long_t["fastsim-kalker"],
                   "time_ratio_longitudinal_to_fastsim": t_ex / long_t["fastsim"],
                   "loadavg_1min": load}))
    return rows
