"""Prediction bands (``torlab bench``): a traction curve with its 95 % band against the plain
curve, and the band's accuracy against a many-draw reference.

The scene is the thesis's wheel-rail contact (Tab. 5.4, with its flash temperature) with the
layer of an HPT fit: a synthetic HPT run of the sample generator (seed 0) fitted by
``fit_layer_hpt``, whose covariance the prediction propagates (:mod:`torlab.model.bands`).
The unit of work is ``predict_traction`` on 101 creepages 0-5 %.  The error of a band is the
largest difference of its edges from the reference band, in units of the reference
half-width at that creepage (over ``mu`` and the temperature): 0.1 means an edge is off by a
twentieth of the band's width.  The reference is the mean of two independent sampled bands
(``n`` seeded draws each); half their difference is the reference's own noise
(``x_reference_noise``), the floor below which no error can be resolved.

The second group times the sampled band's draws themselves, row by row (each draw a whole
model evaluation, as every band was computed before) against many draws in one vectorised
call (``evaluate_many``, :mod:`torlab.model.bands`), side by side in one run, on a 41-point
mixed curve (the Paper A rough ball in water: film, asperity load sharing, FASTSIM) and a
51-point Tab. 5.4 curve with its flash temperature and temperature coefficients; the error
is the largest relative difference of the two bands' edges (round-off: the draws are the
same computation).

The nonlinear group is the curve of paper_c's campaign whose band is not linear over it
(the WFM-wet layer on Tab. 5.4 with its flash temperature, ``tests/data/bands``): the plain
curve, ``predict_traction`` with the automatic choice (the second-order band) and 400 draws,
against a band of 3000 draws (600 with ``quick``).

The third group runs the thermal curve's sampled band on 2 local processes, as a protocol
did before (the whole band one task: its draws one after the other in one worker) and as it
does now (the band's 20 blocks of draws as tasks of their own,
:func:`torlab.parallel.map_deferred`), alternating, side by side; the two bands must be
equal bit for bit.
"""

from __future__ import annotations

import io

import numpy as np

from torlab.bench import BenchRow, median_time, median_time_and_value
from torlab.model.layers import get_law

__all__ = ["run"]


def _scene_with_fit() -> object:
    from pathlib import Path

    from torlab.fit.layer import fit_layer_hpt
    from torlab.model.layers import LayerParams
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import RigCompliance, reduce_hpt
    from torlab.scene import load_scene, scene_from_dict
    from torlab.synth.hpt import HptRig, HptRunSpec, rig_compliance_u, simulate_hpt, write_hpt_log

    rig = HptRig()
    tg = np.linspace(0, 1e9, 2001)
    comp = RigCompliance(tg, rig_compliance_u(tg, rig), "true")
    spec = HptRunSpec("b", "OFM1", 4, 25.0, LayerParams(0.135, 0.223, 8e-6, 19e-6), seed=0)
    df, meta = read_hpt(io.StringIO(write_hpt_log(spec, simulate_hpt(spec, rig), rig)), name="b")
    res = fit_layer_hpt(reduce_hpt(df, meta, compliance=comp))
    base = load_scene(Path(__file__).resolve().parents[2] / "protocols" / "scenes" /
                      "wheel_rail_tab54.yaml").model_dump(exclude_none=True)
    base.pop("fit", None)
    d = res.to_yaml_dict()
    base["boundary"] = {**base["boundary"], **d["boundary"]}
    base["fit"] = d["fit"]
    return scene_from_dict(base)


def _edge_error(band, ref: dict[str, tuple[np.ndarray, np.ndarray]]) -> float:
    """Largest edge difference over the reference half-width (every output)."""
    worst = 0.0
    for k, (lo, hi) in ref.items():
        half = 0.5 * (hi - lo)
        ok = half > 1e-6 * np.max(np.abs(half))
        d = np.maximum(np.abs(band.low(k) - lo), np.abs(band.high(k) - hi))
        worst = max(worst, float(np.max(d[ok] / half[ok])))
    return worst


class _RowByRow:
    """A band model without ``evaluate_many``: its draws are evaluated one by one."""

    def __init__(self, model: object) -> None:
        self.model = model

    def __call__(self, p: dict) -> dict:
        return self.model(p)


def _draw_cases() -> list[tuple[str, object, object, dict, str]]:
    """(name, band model, distribution, outputs at the estimate, unit of work)."""
    from pathlib import Path

    from torlab.model.bands import DryTractionModel, MixedTractionModel, scene_uncertainty
    from torlab.model.mixed import mixed_traction_curve
    from torlab.model.prediction import fastsim_grid, fastsim_problem
    from torlab.model.traction import traction_curve
    from torlab.scene import load_scene, scene_from_dict

    scenes = Path(__file__).resolve().parents[2] / "protocols" / "scenes"
    cases = []
    # the Paper A rough ball in water with a dry-fit-like layer covariance
    d = load_scene(scenes / "optical_paper_a_rough.yaml").model_dump(exclude_none=True)
    names = list(get_law("voce").fit_names)
    vals = [d["boundary"][k] for k in names]
    sd = np.array([0.1, 0.05, 0.3, 0.3]) * np.array(vals)
    corr = np.array([[1, 0.5, 0.9, 0.8], [0.5, 1, 0.4, 0.6], [0.9, 0.4, 1, 0.7],
                     [0.8, 0.6, 0.7, 1]])
    d["fit"] = {"kind": "bench", "covariance": {"names": names, "values": vals,
                                                "matrix": (corr * np.outer(sd, sd)).tolist()}}
    sc = scene_from_dict(d)
    xi = np.linspace(0.0, 0.1, 41)
    t = traction_curve(sc, xi).table
    outs = ("mu", "film_thickness_m")
    cases.append(("mixed", MixedTractionModel(mixed_traction_curve, sc, xi, (), outs),
                  scene_uncertainty(sc).dist, {k: t[k].to_numpy() for k in outs},
                  "400 draws of a 41-point mixed traction curve (Paper A rough ball, water)"))
    # Tab. 5.4 with the flash temperature and temperature coefficients
    d = load_scene(scenes / "wheel_rail_tab54.yaml").model_dump(exclude_none=True)
    d["boundary"].update(mu_c1_T=-8e-4, mu_c2_T=-4e-4)
    names = list(get_law("voce").names)
    vals = [d["boundary"][k] for k in names]
    cov = np.diag((np.array([0.05, 0.05, 0.3, 0.3, 0.5, 0.7]) * np.abs(vals)) ** 2)
    d["fit"] = {"kind": "bench", "covariance": {"names": names, "values": vals,
                                                "matrix": cov.tolist()}}
    sc = scene_from_dict(d)
    xi = np.linspace(0.0, 0.05, 51)
    t = traction_curve(sc, xi).table
    outs = ("mu", "max_temperature_C")
    cases.append(("thermal", DryTractionModel(fastsim_problem(sc), fastsim_grid(sc), xi, outs),
                  scene_uncertainty(sc).dist, {k: t[k].to_numpy() for k in outs},
                  "400 draws of a 51-point Tab. 5.4 curve with flash temperature"))
    return cases


def _draw_rows(quick: bool) -> list[BenchRow]:
    """The sampled band's draws, row by row against many at a time (same run)."""
    import time

    from torlab.uncertainty import propagate

    n = 100 if quick else 400
    rows = []
    for _, model, dist, f0, unit in _draw_cases():
        unit = unit.replace("400", str(n))
        times: dict[str, list[float]] = {"rows": [], "many": []}
        bands = {}
        for _ in range(1 if quick else 3):  # alternating, best of each
            for kind, m in (("rows", _RowByRow(model)), ("many", model)):
                t0 = time.perf_counter()
                bands[kind] = propagate(m, dist, method="sampling", n_samples=n, seed=1, f0=f0)
                times[kind].append(time.perf_counter() - t0)
        err = 0.0
        for k in f0:
            for edge in ("low", "high"):
                a, b = getattr(bands["many"], edge)(k), getattr(bands["rows"], edge)(k)
                err = max(err, float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300))))
        t_rows, t_many = min(times["rows"]), min(times["many"])
        ref = "the same draws evaluated row by row"
        rows.append(BenchRow("band draws", "row by row", t_rows, None, "", False, unit,
                             extra={"ratio_to_row_by_row": 1.0}))
        rows.append(BenchRow("band draws", "many draws per call (evaluate_many)", t_many, err,
                             ref, True, unit, error_kind="relative difference of band edges",
                             extra={"ratio_to_row_by_row": t_many / t_rows,
                                    "speedup": t_rows / t_many}))
    return rows


def _whole_band(case: tuple) -> object:
    """The sampled band in this task, its draws one block after the other (a task's executor
    is serial inside a worker)."""
    from torlab.uncertainty import propagate

    if case is None:  # the empty task beside it (a map of one task would run in the caller)
        return None
    model, dist, f0, n = case
    return propagate(model, dist, method="sampling", n_samples=n, seed=1, f0=f0)


def _deferred_band(case: tuple) -> object:
    """The sampled band with its draws left to the executor (:class:`torlab.parallel.Deferred`)."""
    from torlab.parallel import Deferred
    from torlab.uncertainty import propagate

    model, dist, f0, n = case
    pending = propagate(model, dist, method="sampling", n_samples=n, seed=1, f0=f0, defer=True)
    fn, blocks = pending.tasks()
    return Deferred(fn, blocks, pending.finish)


def _process_rows(quick: bool) -> list[BenchRow]:
    """The thermal curve's sampled band on 2 processes: one task, or its blocks as tasks."""
    import time

    from torlab.parallel import ProcessExecutor, map_deferred

    n = 100 if quick else 400
    _, model, dist, f0, unit = _draw_cases()[-1]
    unit = unit.replace("400", str(n)) + ", 2 local processes"
    case = (model, dist, f0, n)
    times: dict[str, list[float]] = {"one": [], "blocks": []}
    bands = {}
    ex = ProcessExecutor(2)  # not the current executor: a task's band stays in its worker
    try:
        ex.map(_square, [1, 2])  # workers started before the clock
        for _ in range(1 if quick else 3):  # alternating, best of each
            for kind in ("one", "blocks"):
                t0 = time.perf_counter()
                if kind == "one":
                    bands[kind] = ex.map(_whole_band, [case, None])[0]
                else:
                    bands[kind] = map_deferred(ex, _deferred_band, [case])[0]
                times[kind].append(time.perf_counter() - t0)
    finally:
        ex.close()
    same = all(np.array_equal(getattr(bands["one"], e)[k], getattr(bands["blocks"], e)[k])
               for k in f0 for e in ("lower", "upper"))
    t_one, t_blocks = min(times["one"]), min(times["blocks"])
    return [BenchRow("sampled band on 2 processes", "the band one task", t_one, None, "", False,
                     unit, extra={"ratio_to_one_task": 1.0}),
            BenchRow("sampled band on 2 processes", "its blocks of draws as tasks", t_blocks,
                     0.0 if same else 1.0, "the band as one task", True, unit,
                     error_kind="0: equal bit for bit, 1: not",
                     extra={"ratio_to_one_task": t_blocks / t_one, "speedup": t_one / t_blocks})]


def _square(x: int) -> int:
    return x * x


#: the nonlinear band of paper_c's campaign (the WFM-wet layer on Tab. 5.4 with its flash
#: temperature and temperature coefficients, as the protocol fits it from the sample data)
NONLINEAR_SCENE = ("tests", "data", "bands", "wfm_wet_tab54.yaml")


def _nonlinear_rows(quick: bool) -> list[BenchRow]:
    """The curve whose band the nonlinearity check refuses to linearise: plain, the
    automatic choice (second order) and 400 draws, against a band of 3000 draws."""
    from pathlib import Path

    import yaml

    from torlab.model.bands import scene_uncertainty, traction_band
    from torlab.model.predict import predict_traction
    from torlab.model.traction import traction_curve
    from torlab.scene import scene_from_dict

    path = Path(__file__).resolve().parents[2].joinpath(*NONLINEAR_SCENE)
    if not path.is_file():  # an installed torlab without its tests
        return []
    sc = scene_from_dict(yaml.safe_load(path.read_text(encoding="utf-8")))
    xi = np.linspace(0.0, 0.05, 51)
    su = scene_uncertainty(sc)
    table = traction_curve(sc, xi).table
    n_ref = 600 if quick else 3000
    ref_band = traction_band(sc, xi, table, su, method="sampling", n_samples=n_ref, seed=12345)
    ref = {k: (ref_band.low(k), ref_band.high(k)) for k in ref_band.center}
    repeat = 3 if quick else 7
    t_plain = median_time(lambda: traction_curve(sc, xi), repeat=repeat)
    t_auto = median_time(lambda: predict_traction(sc, xi), repeat=repeat)
    auto = predict_traction(sc, xi).band
    # the timed band itself (its draws are seeded: the same band)
    t_samp, samp = median_time_and_value(lambda: traction_band(
        sc, xi, table, su, method="sampling", n_samples=400, seed=3), repeat=1)
    t_samp += t_plain
    comp = "nonlinear traction band"
    unit = "51-point Tab. 5.4 curve, WFM-wet layer, flash temperature"
    refname = f"sampled band of {n_ref} draws (seed 12345)"
    kind = "band edge / reference half-width"
    return [
        BenchRow(comp, "plain curve (no band)", t_plain, None, "", False, unit,
                 extra={"ratio_to_plain": 1.0}),
        BenchRow(comp, f"band, automatic choice ({auto.method})", t_auto,
                 _edge_error(auto, ref), refname, True, unit, error_kind=kind,
                 extra={"ratio_to_plain": t_auto / t_plain, "model_evaluations":
                        auto.n_evaluations, "nonlinearity": auto.nonlinearity}),
        BenchRow(comp, "band, sampling (400 draws)", t_samp, _edge_error(samp, ref), refname,
                 False, unit, error_kind=kind,
                 extra={"ratio_to_plain": t_samp / t_plain, "model_evaluations":
                        samp.n_evaluations})]


def run(quick: bool = False) -> list[BenchRow]:
    """Plain curve, its band by the default choice, forced linearisation and forced sampling;
    the sampled band's draws row by row and many at a time."""
    from torlab.model.bands import scene_uncertainty, traction_band
    from torlab.model.predict import predict_traction
    from torlab.model.traction import traction_curve

    sc = _scene_with_fit()
    xi = np.linspace(0.0, 0.05, 101)
    su = scene_uncertainty(sc)
    plain_table = traction_curve(sc, xi).table
    n_ref = 150 if quick else 1500
    ra, rb = (traction_band(sc, xi, plain_table, su, method="sampling", n_samples=n_ref, seed=s)
              for s in (12345, 54321))
    ref = {k: (0.5 * (ra.low(k) + rb.low(k)), 0.5 * (ra.high(k) + rb.high(k))) for k in ra.center}
    noise = 0.5 * _edge_error(ra, {k: (rb.low(k), rb.high(k)) for k in rb.center})
    repeat = 3 if quick else 7
    t_plain = median_time(lambda: traction_curve(sc, xi), repeat=repeat)
    t_band = median_time(lambda: predict_traction(sc, xi), repeat=repeat)
    pred = predict_traction(sc, xi)
    unit = "101-point traction curve (wheel-rail Tab. 5.4, HPT-fitted layer)"
    refname = f"mean of two sampled bands, {n_ref} draws each"
    rows = [BenchRow("traction curve with 95 % band", "plain curve (no band)", t_plain, None,
                     "", False, unit, extra={"ratio_to_plain": 1.0})]
    rows.append(BenchRow(
        "traction curve with 95 % band", f"band, automatic choice ({pred.band.method})", t_band,
        _edge_error(pred.band, ref), refname, True, unit,
        error_kind="band edge / reference half-width",
        extra={"ratio_to_plain": t_band / t_plain, "model_evaluations": pred.band.n_evaluations,
               "nonlinearity": pred.band.nonlinearity, "reference_noise": noise}))
    for method, n in (("linear", None), ("sampling", 150 if quick else 400)):
        opts = {"method": method} | ({"n_samples": n} if n else {})
        # the last band timed: the same band (seeded draws)
        t, b = median_time_and_value(lambda o=opts: traction_band(sc, xi, plain_table, su, **o),
                                     repeat=repeat)
        t += t_plain
        rows.append(BenchRow("traction curve with 95 % band",
                             f"band, {method}" + (f" ({n} draws)" if n else ""), t,
                             _edge_error(b, ref), refname, False, unit,
                             error_kind="band edge / reference half-width",
                             extra={"ratio_to_plain": t / t_plain,
                                    "model_evaluations": b.n_evaluations,
                                    "reference_noise": noise}))
    return rows + _nonlinear_rows(quick) + _draw_rows(quick) + _process_rows(quick)
