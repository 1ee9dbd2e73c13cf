"""HPT layer fit: recovery of the synthetic truth, interval coverage, warnings, bad data."""

from __future__ import annotations

import io

import numpy as np
import pytest
from conftest import ROOT

from torlab.errors import FitError, TorlabInputError
from torlab.fit.layer import fit_layer_hpt, fit_layers_hpt, tau_of_raw_displacement
from torlab.fit.result import FitResult
from torlab.model.layers import LayerParams, hpt_tau
from torlab.parsers.hpt import read_hpt
from torlab.reduce.hpt import RigCompliance, reduce_hpt
from torlab.synth.hpt import HptRig, HptRunSpec, rig_compliance_u, simulate_hpt, write_hpt_log
from torlab.yamlio import load_yaml

HPT = ROOT / "sample_data" / "hpt"
NAMES = ("mu_c1", "mu_c2", "L_mue", "L_mup")
RIG = HptRig()
_TG = np.linspace(0.0, 1e9, 2001)
TRUE_COMPLIANCE = RigCompliance(_TG, rig_compliance_u(_TG, RIG), "true rig compliance")


def _run(params: LayerParams, seed: int, *, u_max: float = 400e-6, compliance=TRUE_COMPLIANCE,
         temperature_C: float = 25.0):
    """A virtual HPT run (the sample-data generator), written, parsed and reduced."""
    spec = HptRunSpec("virtual", "OFM1", 4, temperature_C, params, u_max=u_max, seed=seed)
    ch = simulate_hpt(spec, RIG)
    df, meta = read_hpt(io.StringIO(write_hpt_log(spec, ch, RIG)), name=f"seed{seed}")
    return reduce_hpt(df, meta, compliance=compliance)


def _truth(file: str) -> dict:
    runs = load_yaml(HPT / "truth.yaml").data["runs"]
    return next(r for r in runs if r["file"] == file)


def test_model_without_compliance_is_the_layer_law():
    """With no rig compliance the fit's model is torlab.model.layers.hpt_tau itself."""
    p = LayerParams(0.14, 0.22, 8e-6, 19e-6)
    u = np.linspace(0, 300e-6, 700)
    ref = hpt_tau(u, 750e6, p)
    got = tau_of_raw_displacement(u, 750e6, (0.14, 0.22, 8e-6, 19e-6))
    assert np.max(np.abs(got - ref)) < 1e-4 * (0.22 - 0.14) * 750e6


def test_the_fits_grids_are_numpys_to_the_bit():
    """The residuals' own grids (without numpy's generic set-up) are numpy.geomspace and
    numpy.linspace(0, stop) bit for bit, over ends from 1e-15 to 1e11 and any length."""
    from torlab.fit.layer import _geomspace, _linspace0

    rng = np.random.default_rng(3)
    for _ in range(3000):
        a = 10 ** rng.uniform(-15, 3)
        b = a * 10 ** rng.uniform(-6, 8)
        n = int(rng.integers(2, 500))
        assert np.array_equal(_geomspace(a, b, n), np.geomspace(a, b, n)), (a, b, n)
        assert np.array_equal(_linspace0(b, n), np.linspace(0.0, b, n)), (b, n)
        assert np.array_equal(_linspace0(-b, n), np.linspace(0.0, -b, n)), (-b, n)
    for a, b, n in ((1.0, 1.0, 5), (2.0, 3.0, 1), (1e-300, 1e300, 7)):
        assert np.array_equal(_geomspace(a, b, n), np.geomspace(a, b, n))
    for b, n in ((0.0, 5), (5e-324, 4), (1.0, 1), (1.0, 0)):
        assert np.array_equal(_linspace0(b, n), np.linspace(0.0, b, n))


@pytest.mark.skipif(not (HPT / "truth.yaml").exists(), reason="sample data absent")
@pytest.mark.parametrize("file", ["hpt_OFM1_4uL_25C.txt", "hpt_SFM_8mg_25C.txt",
                                  "hpt_OFM2_4uL_105C.txt"])
def test_sample_run_recovers_truth_within_intervals(file):
    """The shipped logs (rig compliance from the measured dry-run curve) give intervals
    that contain the generating parameters (at raised temperature: mu_ci exp(mu_ci_T dT))."""
    df, meta = read_hpt(HPT / file)
    res = fit_layer_hpt(reduce_hpt(df, meta, compliance=RigCompliance.from_file(
        HPT / "rig_compliance.csv")))
    t = _truth(file)
    b = dict(t["boundary"])
    dT = t["temperature_C"] - 25.0
    b["mu_c1"] *= np.exp(b["mu_c1_T"] * dT)
    b["mu_c2"] *= np.exp(b["mu_c2_T"] * dT)
    for n in NAMES:
        lo, hi = res.ci95[n]
        assert lo <= b[n] <= hi, (n, b[n], lo, hi)
        assert res.stderr[n] < 0.1 * abs(b[n])  # and the intervals are informative
    assert res.warnings == []
    assert set(res.to_scene_dict()["boundary"]) == set(NAMES)


@pytest.mark.slow
def test_interval_coverage_over_200_seeds():
    """95 % intervals cover the truth about 95 % of the time (binomial 3-sigma band 90-99.6 %
    for 200 seeds)."""
    p = LayerParams(0.135, 0.223, 8e-6, 19e-6)
    truth = {"mu_c1": 0.135, "mu_c2": 0.223, "L_mue": 8e-6, "L_mup": 19e-6}
    hits = np.zeros(4)
    n = 200
    for seed in range(n):
        res = fit_layer_hpt(_run(p, seed))
        hits += [res.ci95[k][0] <= truth[k] <= res.ci95[k][1] for k in NAMES]
    cover = hits / n
    assert np.all(cover >= 0.90), dict(zip(NAMES, cover, strict=True))
    assert np.all(cover <= 0.996), dict(zip(NAMES, cover, strict=True))


@pytest.mark.slow
def test_low_friction_layer_coverage_with_absolute_force_noise():
    """A low-friction layer: the arm transducer's absolute noise dominates the short elastic
    branch, so a purely relative noise model would make the L_mue interval too narrow."""
    vals = (0.05, 0.08, 12e-6, 10e-6)
    p = LayerParams(*vals)
    truth = dict(zip(NAMES, vals, strict=True))
    hits = np.zeros(4)
    n = 100
    for seed in range(1000, 1000 + n):
        res = fit_layer_hpt(_run(p, seed))
        hits += [res.ci95[k][0] <= truth[k] <= res.ci95[k][1] for k in NAMES]
    cover = hits / n
    assert np.all(cover >= 0.88), dict(zip(NAMES, cover, strict=True))  # binomial 3 sigma, 100


def test_whittle_noise_estimate_recovers_a_known_process():
    """White + AR(1) with known parameters: the Whittle estimates lie within 4 of their own
    asymptotic standard errors of the truth, and a white record gets a white model."""
    from torlab.fit._noise import NoiseModel, estimate_noise, parameter_dof

    rng = np.random.default_rng(5)
    n, vw, vc, rho = 20000, 2e-5, 6e-5, 0.95
    c = np.empty(n)
    c[0] = rng.standard_normal()
    e = rng.standard_normal(n) * np.sqrt(1 - rho**2)
    for i in range(1, n):
        c[i] = rho * c[i - 1] + e[i]
    scale = np.full(n, 3.0)
    r = scale * (np.sqrt(vw) * rng.standard_normal(n) + np.sqrt(vc) * c)
    nm = estimate_noise(r, scale)
    truth = np.array([np.log(vw), np.log(vc), np.log(rho / (1 - rho))])
    se = np.sqrt(np.diag(nm.theta_cov))
    assert np.all(np.abs(nm.theta - truth) < 4 * se), (nm.theta, truth, se)
    assert np.all(se < 0.1)  # and the record determines them
    white = estimate_noise(0.01 * rng.standard_normal(5000), np.ones(5000))
    assert white.correlated_var < 0.01 * white.white_var
    assert white.white_var + white.correlated_var == pytest.approx(1e-4, rel=0.05)
    assert white.effective_points(5000) > 4900
    # white noise: the variance of a mean has n - k degrees of freedom
    jac = np.ones((5000, 1))
    wm = NoiseModel(1e-4, 0.0, 0.0, kind="relative white", n_used=5000)
    assert parameter_dof(jac, [(slice(0, 5000), np.ones(5000), wm)])[0] == pytest.approx(
        4999, rel=1e-6)


def test_shared_parameters_fitted_to_every_point_hold_only_the_records_noise():
    """The fit of one parameter set to the OFM1 campaign's four 25 degC runs at once
    (``between="none"``) gives mu_c2 0.2348-0.2363, while the runs alone spread over
    0.223-0.245: the pooled fit's interval (tests/test_random_effects.py) holds that."""
    from torlab.instruments.measured import hpt_curves

    files = sorted(HPT.glob("hpt_OFM1_4uL_25C*.txt"))
    shared = fit_layer_hpt(hpt_curves(files, compliance=HPT / "rig_compliance.csv"),
                           between="none")
    lo, hi = shared.ci95["mu_c2"]
    assert hi - lo < 0.003
    assert "runs" not in shared.meta


def test_joint_fit_of_repeats():
    p = LayerParams(0.16, 0.30, 6e-6, 30e-6)
    runs = [_run(p, s) for s in (11, 12, 13)]
    joint = fit_layer_hpt(runs, joint=True)
    single = fit_layer_hpt(runs[0])
    truth = {"mu_c1": 0.16, "mu_c2": 0.30, "L_mue": 6e-6, "L_mup": 30e-6}
    # one joint fit is one draw: within 4 standard errors (the 95 % coverage itself is
    # tested over many seeds above)
    for k in NAMES:
        assert abs(joint.params[k] - truth[k]) < 4 * joint.stderr[k], k
    assert joint.stderr["mu_c2"] < single.stderr["mu_c2"]  # three curves determine it better
    assert joint.n_points > 2 * single.n_points
    per = fit_layers_hpt(runs)  # one fit per curve; fit_layer_hpt always returns one FitResult
    assert isinstance(per, list) and len(per) == 3
    assert all(isinstance(r, FitResult) for r in per)
    assert per[0].params == pytest.approx(single.params)


def test_repeats_are_their_own_fits_pooled_and_the_joint_fit_only_where_used():
    """With one law, repeats give the pooled fits of the curves alone (the same numbers as
    pooling the single fits); a non-default law is named; a curve that cannot be fitted
    alone falls back to the fit of all curves together (``between="none"``), with the
    warning that the scatter is not estimated."""
    from torlab.fit.repeats import pool_fits

    p = LayerParams(0.16, 0.30, 6e-6, 30e-6)
    runs = [_run(p, s) for s in (21, 22)]
    pooled = fit_layer_hpt(runs)
    alone = pool_fits([fit_layer_hpt(r) for r in runs])
    assert pooled.params == alone.params and pooled.stderr == alone.stderr
    assert "law" not in pooled.meta
    assert fit_layer_hpt(runs, law="linear").meta["law"] == "linear"
    q = LayerParams(0.5, 0.6, 40e-6, 19e-6)
    mixed = [_run(q, 23), _run(q, 24, u_max=12e-6)]  # the second never yields
    res = fit_layer_hpt(mixed)
    assert any(w.startswith("run-to-run scatter not estimated") for w in res.warnings)
    assert res.params == fit_layer_hpt(mixed, between="none").params


def test_a_series_reads_each_runs_estimates_as_the_whole_fit_gives_them():
    """run_estimates (what the temperature series reads of each run) is fit_layer_hpt's
    estimates, standard errors, covariance and keys bit for bit, for the default law and
    another one; lists and law choices are fit_layer_hpt itself."""
    from torlab.fit.layer import run_estimates

    r = _run(LayerParams(0.16, 0.30, 6e-6, 30e-6), 31, temperature_C=60.0)
    for law in (None, "linear"):
        full, light = fit_layer_hpt(r, law=law), run_estimates(r, law=law)
        assert light.params == full.params and light.stderr == full.stderr
        assert np.array_equal(light.covariance, full.covariance)
        for k in ("source", "product", "temperature_C", "law"):
            assert light.meta.get(k) == full.meta.get(k), k
        assert light.data is None and full.data is not None
    assert run_estimates([r], law="auto").meta["law_selection"]


def _same_estimates(a, b, keys=("source", "product", "temperature_C", "law")):
    assert a.params == b.params and a.stderr == b.stderr
    assert np.array_equal(a.covariance, b.covariance)
    for k in keys:
        assert a.meta.get(k) == b.meta.get(k), k


def test_a_layer_fit_hands_its_runs_to_the_series_unchanged():
    """fit_layer_hpt_runs: the layer fit_layer_hpt gives, and each run's own fit as
    run_estimates gives it, bit for bit (one run and three; the default law and another);
    so a temperature series made with those fits is the one made from the curves.  None
    where the layer is not made of the runs' own fits (a choice among laws)."""
    from torlab.fit.layer import fit_layer_hpt_runs, run_estimates
    from torlab.fit.temperature import fit_temperature_coefficients

    p = LayerParams(0.16, 0.30, 6e-6, 30e-6)
    at_t = [_run(p, 40 + i) for i in range(3)]
    others = [_run(p, 50 + i, temperature_C=t) for i, t in enumerate((65.0, 105.0, 145.0))]
    for law in (None, "linear"):
        for runs in (at_t[:1], at_t):
            layer, own = fit_layer_hpt_runs(runs, law=law)
            ref = fit_layer_hpt(runs, law=law)
            _same_estimates(layer, ref, ("source", "product", "temperature_C", "law",
                                         "scatter"))
            assert own is not None and len(own) == len(runs)
            for f, r in zip(own, runs, strict=True):
                _same_estimates(f, run_estimates(r, law=law))
                assert "scatter" not in f.meta  # the run's fit, not the pooled one
    temps = [298.15] * 3 + [338.15, 378.15, 418.15]
    _, own = fit_layer_hpt_runs(at_t)
    shared = fit_temperature_coefficients(own + others, temps)
    alone = fit_temperature_coefficients(at_t + others, temps)
    _same_estimates(shared, alone, ("law",))
    assert shared.meta.get("model_selection") == alone.meta.get("model_selection")
    assert fit_layer_hpt_runs(at_t, law="auto")[1] is None


def test_without_compliance_warns_that_L_mue_includes_the_rig():
    res = fit_layer_hpt(_run(LayerParams(0.135, 0.223, 8e-6, 19e-6), 3, compliance=None))
    assert any("rig's own compliance" in w for w in res.warnings)
    assert res.params["L_mue"] > 8e-6 * 1.5  # the rig's ~2.4 um at the elastic limit adds in


def test_L_mup_undetermined_when_the_curve_never_yields_to_a_new_level():
    """mu_c2 = mu_c1: after the elastic limit the stress stays flat, L_mup has no effect."""
    res = fit_layer_hpt(_run(LayerParams(0.2, 0.2, 8e-6, 19e-6), 5))
    assert any(w.startswith("L_mup not determined") for w in res.warnings), res.warnings
    assert res.ci95["mu_c2"][0] <= 0.2 <= res.ci95["mu_c2"][1]


def test_curve_stopped_before_saturation_warns():
    res = fit_layer_hpt(_run(LayerParams(0.135, 0.223, 8e-6, 19e-6), 6, u_max=12e-6))
    assert any("before it saturates" in w or w.startswith(("mu_c2 poorly", "L_mup poorly"))
               for w in res.warnings), res.warnings


def test_all_elastic_curve_is_refused():
    """A run stopped inside the elastic branch cannot give mu_c1, mu_c2, L_mup."""
    with pytest.raises(FitError, match="elastic branch"):
        fit_layer_hpt(_run(LayerParams(0.5, 0.6, 40e-6, 19e-6), 7, u_max=12e-6))


def test_bad_data_give_clear_messages():
    r = _run(LayerParams(0.135, 0.223, 8e-6, 19e-6), 8)
    few = r.data.iloc[:8]
    with pytest.raises(TorlabInputError, match="too few points"):
        fit_layer_hpt(few, sigma=750e6)
    const = r.data.copy()
    const["shear_stress_Pa"] = 1e8
    with pytest.raises(TorlabInputError, match="constant"):
        fit_layer_hpt(const)
    with pytest.raises(TorlabInputError, match="shear_stress_Pa"):
        fit_layer_hpt(r.data.drop(columns=["shear_stress_Pa"]))


def test_reduced_dataframe_recovers_the_compliance_the_reduction_subtracted():
    """A reduced CSV (no compliance object) gives the same fit as the HptResult."""
    r = _run(LayerParams(0.135, 0.223, 8e-6, 19e-6), 9)
    a = fit_layer_hpt(r)
    b = fit_layer_hpt(r.data)
    for k in NAMES:
        assert b.params[k] == pytest.approx(a.params[k], rel=2e-3)
