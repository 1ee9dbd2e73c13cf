"""Fit speed and accuracy (``torlab bench``): time per fit, error against the synthetic truth,
model evaluations.

Three fits: the HPT layer fit (one 820-point curve), the traction layer fit (a 40-point
FASTSIM curve) and the removal-rate fit of three time tests after application
(:func:`torlab.fit.removal.fit_removal`, first-order law, the synthetic tests of
:mod:`torlab.synth.retention`).  The removal fit is timed twice: with nothing kept from an
earlier fit (its friction tables and FASTSIM's yield tables built anew: the first fit of a
run) and with the tables of an earlier fit of the same layer kept (every later fit of that
product: a campaign's case); each row's time is the median over the fits, and the
ratio of the two is measured in the same run.
"""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time

import numpy as np

from torlab.bench import BenchRow
from torlab.model.layers import get_law

__all__ = ["run"]


NAMES = get_law("voce").fit_names  # the benchmark fits Voce's layer


def _fit_stats(fits, truth: dict[str, float]) -> dict[str, list[float]]:
    """Time, model evaluations, largest relative error and largest |z| of each fit.

    ``fits`` yields zero-argument callables, one fit each (timed one by one).
    """
    out: dict[str, list[float]] = {"time": [], "nfev": [], "err": [], "z": []}
    for fit in fits:
        t0 = time.perf_counter()
        res = fit()
        out["time"].append(time.perf_counter() - t0)
        out["nfev"].append(res.n_evaluations)
        out["err"].append(max(abs(res.params[k] / truth[k] - 1) for k in NAMES))
        out["z"].append(max(abs(res.params[k] - truth[k]) / res.stderr[k] for k in NAMES))
    return out


def _hpt_under_load(curves: list, quick: bool) -> list[BenchRow]:
    """The HPT fit with one BLAS thread (torlab's default, :mod:`torlab.threads`) and with
    OpenBLAS's own thread count, while another process keeps one core busy.

    The two run interleaved, fit by fit, in one run; the busy process is a Python spin
    loop started here and stopped at the end.  On one usable core the comparison is
    meaningless (no pool to fight over) and the rows say so.
    """
    import scipy.linalg  # noqa: F401  (both BLAS builds loaded before counting threads)
    from threadpoolctl import threadpool_info

    from torlab.fit.layer import fit_layer_hpt

    capped = fit_layer_hpt
    uncapped = fit_layer_hpt.__wrapped__
    blas = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    rounds = 2 if quick else 5
    times: dict[str, list[float]] = {"capped": [], "uncapped": []}
    params: dict[str, list] = {"capped": [], "uncapped": []}
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        time.sleep(0.2)  # let the spinner take its core
        for _ in range(rounds):
            for red in curves:
                for name, fit in (("uncapped", uncapped), ("capped", capped)):
                    t0 = time.perf_counter()
                    res = fit(red)
                    times[name].append(time.perf_counter() - t0)
                    params[name].append(np.array([res.params[k] for k in NAMES]))
    finally:
        busy.kill()
        busy.wait()
    t_cap = float(np.median(times["capped"]))
    t_unc = float(np.median(times["uncapped"]))
    diff = max(float(np.max(np.abs(a / b - 1))) for a, b in zip(params["capped"],
                                                                params["uncapped"], strict=True))
    note = "" if cores > 1 else "one usable core: nothing to fight over, ratio not meaningful"
    unit = "820-point HPT curve, another process spinning on one core"
    common = {"usable_cores": cores, "blas_pools_threads_default": ",".join(map(str, blas)),
              "fits_timed": len(times["capped"]), **({"note": note} if note else {})}
    return [
        BenchRow("layer fit from HPT under load", "one BLAS/OpenMP thread (torlab.threads)",
                 t_cap, diff, "the same fit without the thread cap (largest relative "
                 "parameter difference)", True, unit,
                 extra={**common, "time_p90_s": float(np.percentile(times["capped"], 90)),
                        "uncapped_over_capped": t_unc / t_cap}),
        BenchRow("layer fit from HPT under load", "OpenBLAS default threads (no cap, baseline)",
                 t_unc, None, "", False, unit,
                 extra={**common, "time_p90_s": float(np.percentile(times["uncapped"], 90))}),
    ]


def run(quick: bool = False) -> list[BenchRow]:
    """HPT layer fit (one 820-point curve) and FASTSIM traction fit (40-point curve).

    Error: the largest relative error of the four layer parameters against the
    generating truth (synthetic data with noise, so it is the fit's statistical
    error, not a numerical one); ``x_max_z`` is the largest |error| / stderr.
    """
    from torlab.fit.layer import fit_layer_hpt
    from torlab.fit.traction import fit_layer_traction, traction_model
    from torlab.model.layers import LayerParams
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import RigCompliance, reduce_hpt
    from torlab.scene import load_scene
    from torlab.synth.hpt import HptRig, HptRunSpec, rig_compliance_u, simulate_hpt, write_hpt_log

    rows: list[BenchRow] = []
    # --- HPT ---------------------------------------------------------------------------------
    rig = HptRig()
    tg = np.linspace(0, 1e9, 2001)
    comp = RigCompliance(tg, rig_compliance_u(tg, rig), "true")
    truth = {"mu_c1": 0.135, "mu_c2": 0.223, "L_mue": 8e-6, "L_mup": 19e-6}
    p = LayerParams(truth["mu_c1"], truth["mu_c2"], truth["L_mue"], truth["L_mup"])

    curves = []
    for seed in range(3 if quick else 10):
        spec = HptRunSpec("b", "OFM1", 4, 25.0, p, seed=seed)
        df, meta = read_hpt(io.StringIO(write_hpt_log(spec, simulate_hpt(spec, rig), rig)),
                            name="b")
        curves.append(reduce_hpt(df, meta, compliance=comp))

    st = _fit_stats((lambda red=red: fit_layer_hpt(red) for red in curves), truth)
    rows.append(BenchRow("layer fit from HPT", "least squares + white/AR(1) noise (Whittle)",
                         float(np.median(st["time"])), float(np.median(st["err"])),
                         "synthetic truth (torlab.synth.hpt)", True, "820-point HPT curve",
                         extra={"model_evaluations": float(np.median(st["nfev"])),
                                "max_z": float(np.max(st["z"]))}))
    rows += _hpt_under_load(curves[:4], quick)
    # --- traction ----------------------------------------------------------------------------
    from pathlib import Path

    scene_path = Path(__file__).resolve().parents[2] / "protocols" / "scenes" / \
        "optical_paper_a_rough.yaml"
    sc = load_scene(scene_path).model_copy(update={"lubricant": None, "roughness": None})
    tt = {"mu_c1": 0.16, "mu_c2": 0.26, "L_mue": 6e-6, "L_mup": 12e-6}
    xi = np.linspace(0.002, 0.08, 40)
    mu0 = traction_model(sc)(tt, xi)
    curves = [mu0 + 0.003 * np.random.default_rng(seed).standard_normal(xi.size)
              for seed in range(2 if quick else 8)]
    st = _fit_stats((lambda y=y: fit_layer_traction(sc, xi, y) for y in curves), tt)
    rows.append(BenchRow("layer fit from traction", "FASTSIM + trf least squares",
                         float(np.median(st["time"])), float(np.median(st["err"])),
                         "synthetic truth (model + 0.003 noise)", True, "40-point traction curve",
                         extra={"model_evaluations": float(np.median(st["nfev"])),
                                "time_max_s": float(np.max(st["time"])),
                                "max_z": float(np.max(st["z"]))}))
    rows += _removal_rows(quick)
    return rows


def _removal_rows(quick: bool) -> list[BenchRow]:
    """The removal fit of three synthetic time tests (1, 2, 4 uL), with nothing kept and
    with the friction tables of an earlier fit of the same layer kept (module docstring).

    Error: ``|k1 / k1_true - 1|`` (the fit's statistical error on noisy data);
    ``max_z``: the largest ``|k1 - k1_true| / stderr``; ``k1_change_with_kept_tables``: the
    largest relative difference of the rates fitted with kept tables from those fitted
    with tables built anew (kept tables are the same tables: 0).
    """
    import torlab.fit.removal as removal
    from torlab.model import fastsim
    from torlab.model.removal import RemovalLaw
    from torlab.synth.retention import mtm_scene, true_layer, virtual_time_tests

    law = RemovalLaw(1, 1.0e-6)
    layer, scene = true_layer(), mtm_scene()
    sets = [virtual_time_tests(law, s, layer) for s in range(2 if quick else 8)]

    def fresh() -> None:
        removal._TABLES.clear()
        fastsim._yield_table_of.cache_clear()

    out, rates = [], []
    for kept in (False, True):
        times, errs, zs, ks = [], [], [], []
        fresh()
        if kept:
            removal.fit_removal(sets[0], layer, scene)  # the tables of an earlier fit
        for tests in sets:
            if not kept:
                fresh()
            t0 = time.perf_counter()
            res = removal.fit_removal(tests, layer, scene)
            times.append(time.perf_counter() - t0)
            k, se = res.params["k1"], res.stderr["k1"]
            ks.append(k)
            errs.append(abs(k / law.k - 1.0))
            zs.append(abs(k - law.k) / se)
        out.append(BenchRow("removal fit", "three time tests, " + (
            "friction tables of an earlier fit of the layer kept" if kept
            else "nothing kept (tables built)"), float(np.median(times)),
            float(np.median(errs)), "synthetic truth (torlab.synth.retention)", not kept,
            "3 time tests of 1260 s",
            extra={"max_z": float(np.max(zs)), "fits": float(len(times))}))
        rates.append(np.array(ks))
    fresh()
    out[1].extra["k1_change_with_kept_tables"] = float(np.max(np.abs(rates[1] / rates[0] - 1.0)))
    out[0].extra["time_over_kept"] = out[0].time_s / out[1].time_s
    return out
