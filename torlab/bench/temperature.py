"""Benchmark of the contact-temperature iteration (thesis 5.2.5, Eqs. 5.49-5.50; docs/model/thesis-reading.md).

Scene: the wheel-rail contact of Tab. 5.4 (:data:`torlab.bench.fastsim.TAB54_SCENE`,
10 m/s) with the Tab. 5.4 thermal data (lambda = 50 W/(m K), rho = 7850 kg/m^3,
c = 450 J/(kg K)) and temperature-dependent limits ``mu_c1_T = mu_c2_T =
-0.002 1/K`` (Eqs. 5.26-5.27), so the tau-T loop has to iterate.

Unit of work: a traction curve of 21 creepages 0 ... 0.05 (11 with
``quick``) with the temperature coupled.  Variants: the number of
temperature nodes per strip (``FastsimGrid.temperature_nodes``; default 48)
at the default tolerance (0.1 K), and the tolerance at the default nodes;
plus ``temperature ignored`` (the isothermal model) to show what the loop
buys.  Error: ``max |mu - mu_ref| / max |mu_ref|`` against a run with
400 nodes and a 1e-4 K tolerance (the same strips and panels); ``extra``:
the error of the maximum temperature (K), iterations (max, mean), and the
time relative to the default.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from torlab.bench import BenchRow, median_time_and_value
from torlab.model.fastsim import BoundaryResult, FastsimGrid, FastsimProblem, boundary_traction

__all__ = ["REFERENCE_NODES", "REFERENCE_TOLERANCE_K", "run", "thermal_problem"]

REFERENCE_NODES = 400
REFERENCE_TOLERANCE_K = 1e-4
MU_T = -0.002


def thermal_problem(mu_T: float = MU_T) -> FastsimProblem:
    """The Tab. 5.4 scene with ``thermal:`` and ``mu_c1_T = mu_c2_T = mu_T`` (1/K), by
    Kalker's FASTSIM (the scheme the benchmark measures, as
    :func:`torlab.bench.fastsim.scene_problem`)."""
    from torlab.bench.fastsim import TAB54_SCENE
    from torlab.model.prediction import fastsim_problem
    from torlab.scene import scene_from_dict

    d = {k: (dict(v) if isinstance(v, dict) else v) for k, v in TAB54_SCENE.items()}
    d["name"] = "wheel-rail Tab. 5.4 with flash temperature"
    d["thermal"] = {"conductivity": "50 W/(m*K)", "density": "7850 kg/m^3",
                    "heat_capacity": "450 J/(kg*K)"}
    d["boundary"].update(mu_c1_T=mu_T, mu_c2_T=mu_T)
    d["grid"] = {"method": "fastsim-kalker"}
    return fastsim_problem(scene_from_dict(d))


def _with_tolerance(prob: FastsimProblem, tol: float, max_iterations: int | None = None) -> FastsimProblem:
    th = dataclasses.replace(prob.thermal, tolerance=tol,
                             max_iterations=max_iterations or prob.thermal.max_iterations)
    return dataclasses.replace(prob, thermal=th)


def run(quick: bool = False) -> list[BenchRow]:
    """Time, iterations and error of the temperature iteration (see the module docstring).

    Parameters
    ----------
    quick
        11 creepages, three node counts, fewer repeats.
    """
    prob = thermal_problem()
    default = FastsimGrid()
    tol0 = prob.thermal.tolerance
    xi = np.linspace(0.0, 0.05, 11 if quick else 21)
    ref_prob = _with_tolerance(prob, REFERENCE_TOLERANCE_K, max_iterations=5000)
    ref = boundary_traction(ref_prob, xi, dataclasses.replace(default, temperature_nodes=REFERENCE_NODES))
    ref_name = (f"temperature_nodes={REFERENCE_NODES}, tolerance {REFERENCE_TOLERANCE_K:g} K "
                f"(same strips and panels)")
    unit = f"{len(xi)}-point traction curve 0..0.05 with the tau-T loop (Tab. 5.4, 10 m/s)"
    nodes = (24, 48, 96) if quick else (16, 24, 32, 48, 64, 96, 128, 200)
    tols = () if quick else (1.0, 0.01)
    variants: list[tuple[str, FastsimProblem, FastsimGrid, bool]] = []
    for k in sorted(set(nodes) | {default.temperature_nodes}):
        g = dataclasses.replace(default, temperature_nodes=k)
        variants.append((f"temperature_nodes={k}, tolerance {tol0:g} K", prob, g,
                         g == default))
    for tol in tols:
        variants.append((f"temperature_nodes={default.temperature_nodes}, tolerance {tol:g} K",
                         _with_tolerance(prob, tol), default, False))
    variants.append(("temperature ignored (isothermal limits)",
                     dataclasses.replace(prob, thermal=None), default, False))

    mu_scale = float(np.max(np.abs(ref.mu)))
    tmax_ref = ref.max_temperature_C
    measured: list[tuple[str, bool, float, BoundaryResult]] = []
    for name, p, g, is_def in variants:
        t, r = median_time_and_value(lambda p=p, g=g: boundary_traction(p, xi, g),
                                     repeat=3 if quick else 5, min_time=0.0 if quick else 0.2)
        measured.append((name, is_def, t, r))
    t_def = next(t for _, d, t, _ in measured if d)
    rows = []
    for name, is_def, t, r in measured:
        extra: dict[str, Any] = {"time_ratio_to_default": t / t_def}
        if r.max_temperature_C is not None:
            extra["max_temperature_error_K"] = float(np.max(np.abs(r.max_temperature_C - tmax_ref)))
            extra["iterations_max"] = int(np.max(r.temperature_iterations))
            extra["iterations_mean"] = float(np.mean(r.temperature_iterations[xi > 0]))
            extra["loop"] = r.temperature_loop
        else:
            extra["max_temperature_error_K"] = float(np.max(tmax_ref - prob.ambient_temperature))
            extra["loop"] = "off"
        if is_def:
            extra["reference_max_temperature_C"] = float(np.max(tmax_ref))
            extra["reference_iterations_max"] = int(np.max(ref.temperature_iterations))
        rows.append(BenchRow(
            "contact temperature", name, t, float(np.max(np.abs(r.mu - ref.mu))) / mu_scale,
            ref_name, is_def, unit, error_kind="relative (max |mu - mu_ref| / max |mu_ref|)",
            extra=extra))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run(quick=False):
        print(row.variant, f"{row.time_s * 1e3:.1f} ms", f"{row.error:.3g}", row.extra)
