"""Benchmark of the film/asperity load sharing (thesis 5.2.4; notes section 7) and EHL traction.

Load sharing on a hard-case set -- speeds 0 ... 100 m/s, sigma 1 nm ... 1 um,
loads 1 N ... 100 kN, eta0 1e-4 ... 10 Pa s, every viscosity law, elastic and
plastic asperities, steel-steel (E* = 117 GPa) and steel-glass (75 GPa) circular
contacts of a 10 mm radius ball:

* ``bracketed, vectorised over speeds`` (default) -- :func:`solve_load_sharing`
  with all speeds of a case in one call (a Stribeck curve);
* ``bracketed, one speed per call`` -- the same, called per speed (a traction
  curve needs one solve);
* ``thesis secant on eps`` -- :func:`solve_load_sharing_thesis`, the thesis's
  scheme (tolerance 0.1 % on Eq. 5.45).

Error: the largest ``|W_EHL(h) + W_BL(h) - W|/W`` over the points a variant
solved, with ``W_EHL(h)`` the film load for which ``hc = h``.  ``extra``: time
per point, mean/max iterations, failures (by reason), largest relative
difference of ``h`` to the default.

EHL traction: ``mu_EHL`` for a 101-point traction curve for each shear law
(Barus oil at 1 GPa), against adaptive quadrature.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter

import numpy as np

from torlab.bench import BenchRow, median_time
from torlab.model.asperity import Roughness
from torlab.model.ehl import FilmThickness, Lubricant, mu_ehl, tau_ehl
from torlab.model.loadshare import solve_load_sharing, solve_load_sharing_thesis

__all__ = ["hard_cases", "run"]

R_BALL = 0.01


def hard_cases(quick: bool = False) -> tuple[np.ndarray, list[dict]]:
    """The hard-case set: ``(speeds, cases)``; each case holds F, a, film, asperity."""
    speeds = (np.array([0.0, 1e-4, 0.01, 1.0, 100.0]) if quick
              else np.array([0.0, 1e-6, 1e-4, 1e-3, 0.01, 0.1, 0.5, 1.0, 2.0, 10.0, 50.0, 100.0]))
    sigmas = [1e-9, 1e-6] if quick else [1e-9, 3e-8, 1e-6]
    loads = [1.0, 1e5] if quick else [1.0, 1e3, 1e5]
    etas = [1e-4, 10.0] if quick else [1e-4, 1e-2, 10.0]
    laws = [("iso", {}), ("barus", {"alpha": 2e-8}), ("roelands", {"Z": 0.6})]
    cases = []
    for E, F, eta0, (visc, kw), sigma, model in itertools.product(
            [117e9, 75e9], loads, etas, laws, sigmas, ["elastic", "plastic"]):
        a = (3 * F * R_BALL / (4 * E)) ** (1 / 3)
        lub = Lubricant(eta0, visc, **kw)
        cases.append({
            "F": F, "a": a, "film": FilmThickness.from_contact(lub, E, R_BALL, a, a),
            "asperity": Roughness(sigma, 0.3e-3, 2.4e10, model,
                                  hardness=6e9).asperity_model(E),
        })
    return speeds, cases


def _load_error(case: dict, v: float, h: float) -> float:
    """``|W_EHL(h) + W_BL(h) - W|/W`` with the film load for which ``hc = h``."""
    film, F = case["film"], case["F"]
    hc = float(film.hc(v, F))
    f_film = F * (hc / h) ** (1.0 / film.load_exponent) if h > 0 else (0.0 if hc == 0 else math.inf)
    f_bl = float(case["asperity"].load(h, case["a"], case["a"]))
    return abs(f_film + f_bl - F) / F


def _load_sharing_rows(quick: bool) -> list[BenchRow]:
    speeds, cases = hard_cases(quick)
    n_pts = speeds.size * len(cases)
    unit = f"one point of the hard-case set ({n_pts} points)"

    def vectorised():
        return [solve_load_sharing(speeds, c["F"], c["a"], c["a"], c["film"], c["asperity"])
                for c in cases]

    def per_speed():
        return [solve_load_sharing(float(v), c["F"], c["a"], c["a"], c["film"], c["asperity"])
                for c in cases for v in speeds]

    def thesis():
        return [solve_load_sharing_thesis(float(v), c["F"], c["a"], c["a"], c["film"],
                                          c["asperity"]) for c in cases for v in speeds]

    opts = {"repeat": 1 if quick else 3, "min_time": 0.0}
    t_vec = median_time(vectorised, **opts) / n_pts
    t_one = median_time(per_speed, **opts) / n_pts
    t_th = median_time(thesis, **opts) / n_pts
    res = vectorised()
    ones = per_speed()
    th = thesis()

    h_ref = np.concatenate([r.h for r in res])
    regimes = Counter(np.concatenate([r.regime for r in res]).tolist())
    err_vec = max(float(np.max(r.residual)) for r in res)
    its = np.concatenate([r.iterations for r in res])
    nfev = np.concatenate([r.evaluations for r in res])
    solved = its > 0
    rows = [BenchRow(
        component="load sharing", variant="bracketed, vectorised over speeds", time_s=t_vec,
        error=err_vec, reference="load balance |W_EHL + W_BL - W|/W", default=True,
        unit_of_work=unit,
        extra={"mean_iterations": float(its[solved].mean()), "max_iterations": int(its.max()),
               "mean_evaluations": float(nfev[solved].mean()), "failures": 0,
               "regimes": dict(regimes), "speedup_vs_thesis": t_th / t_vec})]

    h_one = np.array([r.h for r in ones])
    its1 = np.array([r.iterations for r in ones])
    rows.append(BenchRow(
        component="load sharing", variant="bracketed, one speed per call", time_s=t_one,
        error=max(r.residual for r in ones), reference="load balance |W_EHL + W_BL - W|/W",
        unit_of_work=unit,
        extra={"mean_iterations": float(its1[its1 > 0].mean()), "max_iterations": int(its1.max()),
               "failures": 0,
               "max_rel_h_difference": float(np.max(np.abs(h_one - h_ref)
                                                    / np.maximum(np.abs(h_ref), 1e-300))),
               "speedup_vs_thesis": t_th / t_one}))

    conv = np.array([r.converged for r in th])
    fails = Counter(r.failure for r in th if r.failure is not None)
    it_th = np.array([r.iterations for r in th])
    err_th = [_load_error(cases[i // speeds.size], float(speeds[i % speeds.size]), r.h)
              for i, r in enumerate(th) if r.converged]
    h_th = np.array([r.h for r in th])
    dh = np.abs(h_th[conv] - h_ref[conv]) / np.abs(h_ref[conv])
    rows.append(BenchRow(
        component="load sharing", variant="thesis secant on eps (baseline)", time_s=t_th,
        error=max(err_th) if err_th else None,
        reference="load balance |W_EHL + W_BL - W|/W (converged points)", unit_of_work=unit,
        extra={"mean_iterations": float(it_th[conv].mean()) if conv.any() else None,
               "max_iterations": int(it_th.max()),
               "failures": int((~conv).sum()), "failures_by_reason": dict(fails),
               "max_rel_h_difference": float(dh.max()) if dh.size else None}))
    return rows


def _traction_rows(quick: bool) -> list[BenchRow]:
    from scipy.integrate import quad

    p0, h = 1.0e9, 5e-8
    w = np.linspace(0.0, 0.05, 101)  # 101 creepages at 1 m/s
    rows = []
    laws = [("newtonian", {}), ("limiting", {"gamma_L": 0.08}), ("eyring", {"tau0": 5e6})]
    for shear, kw in laws:
        lub = Lubricant(0.05, "barus", alpha=2e-8, shear=shear, **kw)
        tm = median_time(lambda lub=lub: mu_ehl(w, h, p0, lub), repeat=3 if quick else 5,
                         min_time=0.02 if quick else 0.1)
        mu = mu_ehl(w, h, p0, lub)
        errs = []
        for i in (10, 50, 100):
            # reference: quad over theta, r = sin(theta) (p = p0 cos(theta)), many subintervals
            def f(th, wi=w[i], lub=lub):
                return float(tau_ehl(p0 * math.cos(th), wi, h, lub)) * math.sin(2 * th)
            edges = np.linspace(0.0, math.pi / 2, 65)
            ref = sum(quad(f, edges[k], edges[k + 1], epsabs=0, epsrel=1e-12, limit=200)[0]
                      for k in range(64)) / (2 / 3 * p0)
            errs.append(abs(mu[i] / ref - 1))
        rows.append(BenchRow(
            component="EHL traction", variant=f"{shear} (Barus 20/GPa, 1 GPa)", time_s=tm,
            error=max(errs), reference="scipy.quad over the contact radius, 64 panels",
            default=shear == "newtonian", unit_of_work="mu_EHL at 101 creepages",
            extra={"time_per_point_s": tm / w.size}))
    return rows


def run(quick: bool = False) -> list[BenchRow]:
    """Load sharing and EHL traction: time and error of each variant (module docstring).

    Parameters
    ----------
    quick
        A smaller hard-case set and fewer repeats.
    """
    return _load_sharing_rows(quick) + _traction_rows(quick)
