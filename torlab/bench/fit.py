"""Fit speed and accuracy (``torlab bench``): time per fit, error against the synthetic truth,
model evaluations (issue 6)."""

from __future__ import annotations

import io
import time

import numpy as np

from torlab.bench import BenchRow

__all__ = ["run"]


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def run(quick: bool = False) -> list[BenchRow]:
    """HPT layer fit (one 820-point curve) and FASTSIM traction fit (40-point curve).

    Error: the largest relative error of the four layer parameters against the
    generating truth (synthetic data with noise, so it is the fit's statistical
    error, not a numerical one); ``x_max_z`` is the largest |error| / stderr.
    """
    from torlab.fit.layer import fit_layer_hpt
    from torlab.fit.traction import fit_layer_traction, traction_model
    from torlab.model.layer import LayerParams
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import RigCompliance, reduce_hpt
    from torlab.scene import load_scene
    from torlab.synth.hpt import HptRig, HptRunSpec, rig_compliance_u, simulate_hpt, write_hpt_log

    rows: list[BenchRow] = []
    names = ("mu_c1", "mu_c2", "L_mue", "L_mup")
    # --- HPT ---------------------------------------------------------------------------------
    rig = HptRig()
    tg = np.linspace(0, 1e9, 2001)
    comp = RigCompliance(tg, rig_compliance_u(tg, rig), "true")
    truth = {"mu_c1": 0.135, "mu_c2": 0.223, "L_mue": 8e-6, "L_mup": 19e-6}
    p = LayerParams(truth["mu_c1"], truth["mu_c2"], truth["L_mue"], truth["L_mup"])
    times, errs, zs, nfev = [], [], [], []
    for seed in range(3 if quick else 10):
        spec = HptRunSpec("b", "OFM1", 4, 25.0, p, seed=seed)
        df, meta = read_hpt(io.StringIO(write_hpt_log(spec, simulate_hpt(spec, rig), rig)), name="b")
        red = reduce_hpt(df, meta, compliance=comp)
        res, t = _timed(lambda red=red: fit_layer_hpt(red))
        times.append(t)
        nfev.append(res.n_evaluations)
        errs.append(max(abs(res.params[k] / truth[k] - 1) for k in names))
        zs.append(max(abs(res.params[k] - truth[k]) / res.stderr[k] for k in names))
    rows.append(BenchRow("layer fit from HPT", "least squares + white/AR(1) noise (Whittle)",
                         float(np.median(times)), float(np.median(errs)),
                         "synthetic truth (torlab.synth.hpt)", True, "820-point HPT curve",
                         extra={"model_evaluations": float(np.median(nfev)),
                                "max_z": float(np.max(zs))}))
    # --- traction ----------------------------------------------------------------------------
    from pathlib import Path

    scene_path = Path(__file__).resolve().parents[2] / "protocols" / "scenes" / \
        "optical_paper_a_rough.yaml"
    sc = load_scene(scene_path).model_copy(update={"lubricant": None, "roughness": None})
    tt = {"mu_c1": 0.16, "mu_c2": 0.26, "L_mue": 6e-6, "L_mup": 12e-6}
    xi = np.linspace(0.002, 0.08, 40)
    mu0 = traction_model(sc)(tt, xi)
    times, errs, zs, nfev = [], [], [], []
    for seed in range(2 if quick else 8):
        y = mu0 + 0.003 * np.random.default_rng(seed).standard_normal(xi.size)
        res, t = _timed(lambda y=y: fit_layer_traction(sc, xi, y))
        times.append(t)
        nfev.append(res.n_evaluations)
        errs.append(max(abs(res.params[k] / tt[k] - 1) for k in names))
        zs.append(max(abs(res.params[k] - tt[k]) / res.stderr[k] for k in names))
    rows.append(BenchRow("layer fit from traction", "FASTSIM + trf least squares",
                         float(np.median(times)), float(np.median(errs)),
                         "synthetic truth (model + 0.003 noise)", True, "40-point traction curve",
                         extra={"model_evaluations": float(np.median(nfev)),
                                "time_max_s": float(np.max(times)), "max_z": float(np.max(zs))}))
    return rows
