"""Benchmark of the retention prediction: a 10 000-pass prediction against pass-by-pass FASTSIM.

Scene: the wheel-rail contact of thesis Tab. 5.4 (isothermal), creepage 1 %,
the OFM1 layer of the synthetic HPT campaign (:func:`torlab.synth.retention.true_layer`),
100 000 mg/m^2 applied, a first-order removal law with ``k1 = 1e-7 m^2/J``
(the band goes from the product's level through the 0.15-0.25 band to dry within
the 10 000 passes).

* ``pass-by-pass FASTSIM`` (the baseline): one boundary-model evaluation per
  pass with the layer of the amount at the pass, and the amount after the pass
  ``m exp(-k1 e_pass)`` (exact for a pass at constant friction).  10 000 passes
  (2 000 with ``quick``, with ``k1`` five times larger so that the same
  history fits in);
* ``torlab`` -- :func:`torlab.model.retention.predict_retention`: the friction
  table (``per_interval`` nodes between tested amounts) and the quadrature
  solution (``n_grid`` points), with and without the 95 % intervals
  (200 parameter draws, the default).

Error: ``max |mu - mu_baseline|`` over every 10th pass (absolute coefficient);
``x_crossing_error`` the largest relative error of the passes to enter and to
leave the 0.15-0.25 band.  The baseline's friction is constant during a pass and
the prediction's is continuous, so part of the difference is that modelling
choice (of the order of the removal per pass), not a numerical error.  The
default row's ``extra`` holds the ratio of the baseline's time to the default's,
both measured in this run.
"""

from __future__ import annotations

import math
import time

import numpy as np

from torlab.bench import BenchRow, median_time

__all__ = ["baseline_pass_by_pass", "run"]

AMOUNT = "100000 mg/m^2"
CREEPAGE = 0.01
K1 = 1e-7


def _scene():
    from torlab.bench.fastsim import TAB54_SCENE
    from torlab.scene import scene_from_dict

    return scene_from_dict(TAB54_SCENE)


def baseline_pass_by_pass(scene, layer, k1: float, m0: float, n_passes: int,
                          creepage: float = CREEPAGE) -> tuple[np.ndarray, np.ndarray]:
    """``(m, mu)`` at passes ``0 .. n_passes`` by one FASTSIM evaluation per pass."""
    from dataclasses import replace

    from torlab.model.contact import build_contact
    from torlab.model.fastsim import boundary_traction
    from torlab.model.prediction import fastsim_grid, fastsim_problem

    contact = build_contact(scene)
    prob = fastsim_problem(scene, contact)
    grid = fastsim_grid(scene)
    c = float(contact.patch.F) * abs(creepage) / (2.0 * float(contact.patch.b))
    m = np.empty(n_passes + 1)
    mu = np.empty(n_passes + 1)
    m[0] = m0
    for n in range(n_passes + 1):
        mu[n] = abs(float(boundary_traction(replace(prob, layer=layer.layer(m[n])), [creepage],
                                            grid).mu[0]))
        if n < n_passes:
            m[n + 1] = m[n] * math.exp(-k1 * c * mu[n])
    return m, mu


def run(quick: bool = False) -> list[BenchRow]:
    """Time and error of the retention prediction against pass-by-pass FASTSIM (module docstring)."""
    from torlab.model.amount import MG_M2
    from torlab.model.removal import RemovalLaw
    from torlab.model.retention import predict_retention
    from torlab.synth.retention import true_layer

    sc = _scene()
    layer = true_layer()
    n_passes = 2000 if quick else 10_000
    k1 = K1 * (5.0 if quick else 1.0)
    law = RemovalLaw(1, k1)
    m0 = 100_000 * MG_M2
    t0 = time.perf_counter()
    _m_b, mu_b = baseline_pass_by_pass(sc, layer, k1, m0, n_passes)
    t_base = time.perf_counter() - t0
    every = np.arange(0, n_passes + 1, 10)
    passes = np.arange(0, n_passes + 1, dtype=float)

    def crossing(mu: np.ndarray, level: float) -> float:
        j = int(np.argmax(mu >= level))
        if mu[j] < level:
            return math.inf
        if j == 0:
            return 0.0
        return (j - 1) + (level - mu[j - 1]) / (mu[j] - mu[j - 1])

    ref_cross = [crossing(mu_b, 0.15), crossing(mu_b, 0.25)]
    unit = f"{n_passes}-pass retention prediction"
    rows = [BenchRow("retention prediction", f"baseline: pass-by-pass FASTSIM ({n_passes} "
                     "evaluations)", t_base, 0.0, "itself", False, unit, error_kind="absolute mu",
                     extra={"fastsim_evaluations": n_passes + 1})]
    variants = [(6, 1025, 200, True), (2, 1025, 0, False), (4, 1025, 0, False),
                (6, 1025, 0, False), (12, 1025, 0, False), (6, 257, 0, False),
                (12, 4097, 0, False)]
    if quick:
        variants = variants[:4]
    from torlab.model.contact import build_contact
    from torlab.model.removal import mu_table, passes_solution

    contact = build_contact(sc)
    c = float(contact.patch.F) * CREEPAGE / (2.0 * float(contact.patch.b))
    t_default = None
    for per_interval, n_grid, n_draws, default in variants:
        if n_grid == 1025:
            def call(per_interval=per_interval, n_draws=n_draws):
                return predict_retention(sc, layer, law, AMOUNT, creepage=CREEPAGE,
                                         passes=passes, n_draws=n_draws,
                                         per_interval=per_interval)
            res = call()
            mu = res.table["mu"].to_numpy()
            cr = [res.summary["passes_to_enter_band"]["passes"],
                  res.summary["passes_to_leave_band"]["passes"]]
            n_ev = res.summary["friction_evaluations"]
        else:  # another quadrature grid: the table and the central solution, timed alone
            def call(per_interval=per_interval, n_grid=n_grid):
                tb = mu_table(sc, layer, CREEPAGE, per_interval=per_interval)
                return tb, passes_solution(tb.curve(0), tb.mu_dry[0], tb.x[0], m0, 1, k1, 0.0,
                                           c, n_grid=n_grid)
            tb, sol = call()
            mu = sol.at(passes)[1][:, 0]
            cr = [sol.crossing(0.15)[0][0], sol.crossing(0.25)[0][0]]
            n_ev = tb.n_evaluations
        err = float(np.max(np.abs(mu[every] - mu_b[every])))
        cerr = max(abs(a / b - 1.0) for a, b in zip(cr, ref_cross, strict=True))
        t = median_time(call, repeat=3, min_time=0.0)
        label = (f"table {per_interval}/interval, quadrature {n_grid} points, "
                 + (f"{n_draws} draws (95 % intervals)" if n_draws else "no intervals"))
        extra: dict[str, float] = {"crossing_error": cerr, "friction_evaluations": n_ev}
        if default:
            t_default = t
            extra["baseline_time_over_default"] = t_base / t
            extra["passes"] = n_passes
        rows.append(BenchRow("retention prediction", label, t, err,
                             "pass-by-pass FASTSIM baseline", default, unit,
                             error_kind="absolute mu", extra=extra))
    if t_default:
        for r in rows:
            r.extra.setdefault("time_over_default", r.time_s / t_default)
    return rows
