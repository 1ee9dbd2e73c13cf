"""Prediction bands from a fit's covariance (torlab predict), trend and crossing evidence."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import brentq
from scipy.stats import norm

from tests.conftest import ROOT, error_lines
from torlab.fit.film import fit_film_thickness
from torlab.fit.traction import fit_layer_traction, traction_model
from torlab.model.mixed import stribeck_curve
from torlab.model.predict import predict_stribeck, predict_traction
from torlab.model.prediction import classify_trend
from torlab.scene import load_scene, scene_from_dict
from torlab.uncertainty import ParameterDistribution, propagate
from torlab.yamlio import dump_yaml

SCENES = ROOT / "protocols" / "scenes"
TRUTH = {"mu_c1": 0.16, "mu_c2": 0.26, "L_mue": 6e-6, "L_mup": 12e-6}
XI_FIT = np.geomspace(0.0005, 0.08, 40)


def _dry_scene_file(tmp_path, grid=None):
    raw = load_scene(SCENES / "optical_paper_a_rough.yaml").model_dump(exclude_none=True)
    for k in ("lubricant", "roughness", "fit"):
        raw.pop(k, None)
    if grid is not None:
        raw["grid"] = grid
    p = tmp_path / "dry.yaml"
    p.write_text(dump_yaml(raw))
    return p


def _params_file(tmp_path, result, name="params.yaml"):
    p = tmp_path / name
    p.write_text(dump_yaml(result.to_yaml_dict()))
    return p


def _with_covariance(base: dict, names, values, matrix, **extra) -> dict:
    return {**base, "fit": {"kind": "test", "covariance": {
        "names": list(names), "values": list(values), "matrix": matrix, **extra}}}


# ---------------------------------------------------------------------------------------
# bands
# ---------------------------------------------------------------------------------------
def test_zero_parameter_uncertainty_collapses_the_band_onto_the_curve(tmp_path):
    sc = load_scene(SCENES / "wheel_rail_tab54.yaml")
    b = sc.boundary
    names = ["mu_c1", "mu_c2", "L_mue", "L_mup"]
    d = _with_covariance(sc.model_dump(exclude_none=True), names,
                         [getattr(b, n) for n in names], np.zeros((4, 4)).tolist())
    pred = predict_traction(scene_from_dict(d), np.linspace(0, 0.02, 21))
    t = pred.table
    np.testing.assert_array_equal(t["mu_low95"], t["mu"])
    np.testing.assert_array_equal(t["mu_high95"], t["mu"])
    assert pred.summary["band"]["method"] == "none"


def test_band_without_covariance_is_not_computed_and_says_why():
    pred = predict_traction(load_scene(SCENES / "wheel_rail_tab54.yaml"), [0.001, 0.01])
    assert "mu_low95" not in pred.table
    assert pred.summary["band"]["method"] == "not computed"
    assert "no fit covariance" in pred.summary["band"]["notes"][0]
    assert pred.trend["probabilities"] is None


@pytest.mark.slow
def test_true_curve_inside_the_band_on_synthetic_truth(tmp_path):
    """Synthetic dry traction curves (model at known parameters, 2 % noise proportional to mu,
    40 log-spaced creepages), fitted; the fit's params.yaml drives the prediction.  Over 40
    seeds the true curve lies inside the 95 % band at >= 90 % of the creepages on average (the
    band is pointwise, so one seed whose estimates are off misses a whole stretch: the mean
    over seeds is what 95 % promises).  The coarse FASTSIM grid (n = 4, m = 3) keeps the
    sweep short; data and predictions use the same model, so the grid's own error (2e-4)
    does not enter."""
    dry = _dry_scene_file(tmp_path, grid={"n": 4, "m": 3})
    sc = load_scene(dry)
    model = traction_model(sc)
    mu_fit = model(TRUTH, XI_FIT)
    xi = np.linspace(0.001, 0.06, 25)
    truth = model(TRUTH, xi)
    inside, methods = [], []
    for seed in range(40):
        e = np.random.default_rng(seed).standard_normal(XI_FIT.size)
        res = fit_layer_traction(sc, XI_FIT, mu_fit * (1 + 0.02 * e))
        pred = predict_traction(load_scene(dry, _params_file(tmp_path, res)), xi)
        t = pred.table
        inside.append(np.mean((truth >= t["mu_low95"]) & (truth <= t["mu_high95"])))
        methods.append(pred.band.method)
    assert np.mean(inside) >= 0.9, (inside, methods)


def test_stribeck_film_band_from_a_film_fit_holds_the_true_film(tmp_path):
    """Films from Hamrock-Dowson at alpha = 18 1/GPa with 4 % scatter, fitted for the effective
    alpha; the fitted parameter file gives the Stribeck curve a film-thickness band that holds
    the film of the true alpha (several seeds; the model at the truth is the reference)."""
    from torlab.model.contact import build_contact
    from torlab.model.ehl import hc_piezo

    scene = SCENES / "mtm_paper_b.yaml"
    sc = load_scene(scene)
    c = build_contact(sc)
    v = np.geomspace(0.05, 2.0, 15)
    h = hc_piezo(v, sc.contact.load, c.E_star, c.rx, sc.lubricant.eta0, 18e-9,
                 c.patch.b / c.patch.a)
    speeds = np.geomspace(0.01, 3.0, 25)
    true = stribeck_curve(sc.model_copy(update={"lubricant": sc.lubricant.model_copy(
        update={"alpha": 18e-9})}), speeds, 0.05).table
    inside = []
    for seed in range(6):
        res = fit_film_thickness(v, h * np.exp(0.04 * np.random.default_rng(seed).standard_normal(
            v.size)), scene=sc)
        pred = predict_stribeck(load_scene(scene, _params_file(tmp_path, res)), speeds, 0.05)
        t = pred.table
        assert pred.band.names == ("alpha",)
        inside.append(np.mean((true["film_thickness_m"] >= t["film_thickness_low95_m"])
                              & (true["film_thickness_m"] <= t["film_thickness_high95_m"])))
        assert np.all(t["film_thickness_low95_m"] < t["film_thickness_m"])
        assert np.all(t["mu_low95"] <= t["mu"]) and np.all(t["mu"] <= t["mu_high95"])
    assert np.mean(inside) >= 0.8, inside  # 6 draws of one parameter: 0.95 expected


def test_overridden_and_undetermined_parameters(tmp_path):
    sc = load_scene(SCENES / "wheel_rail_tab54.yaml")
    base = sc.model_dump(exclude_none=True)
    names = ["mu_c1", "mu_c2", "L_mue", "L_mup"]
    vals = [getattr(sc.boundary, n) for n in names]
    cov = np.diag([0.01 * v for v in vals]) ** 2
    # a value changed after the fit is taken as exact
    d = _with_covariance(base, names, [vals[0], vals[1] * 1.1, *vals[2:]], cov.tolist())
    pred = predict_traction(scene_from_dict(d), [0.002, 0.01, 0.03])
    assert "mu_c2" not in pred.band.names and len(pred.band.names) == 3
    assert any("mu_c2" in n and "exact" in n for n in pred.summary["band"]["notes"])
    # a parameter the fit did not determine: no band, and the reason
    d = _with_covariance(base, names[:3], vals[:3], cov[:3, :3].tolist(),
                         not_determined=["L_mup"])
    pred = predict_traction(scene_from_dict(d), [0.002, 0.01, 0.03])
    assert pred.band is None and "mu_low95" not in pred.table
    assert "L_mup not determined" in pred.summary["band"]["notes"][0]


def test_two_parameter_files_give_independent_blocks(tmp_path):
    """An HPT layer fit and a temperature fit (kept coefficients) on a thermal scene: the band
    carries both covariances, each with its own degrees of freedom."""
    from torlab.fit.result import FitResult

    base = load_scene(SCENES / "wheel_rail_tab54.yaml")
    names = ("mu_c1", "mu_c2", "L_mue", "L_mup")
    vals = np.array([0.3, 0.45, 10e-6, 20e-6])
    layer = FitResult.from_covariance("layer_hpt", names, vals, np.diag((0.02 * vals) ** 2),
                                      dof=20, log_scale=names, residual_norm=0.0, n_points=30,
                                      warnings=[], data=None)
    tnames = ("mu_c1_T", "mu_c2_T")
    temp = FitResult.from_covariance("temperature", tnames, np.array([-1e-3, -2e-3]),
                                     np.diag([3e-4, 3e-4]) ** 2, dof=3, residual_norm=0.0,
                                     n_points=5, warnings=[], data=None)
    sc = load_scene(SCENES / "wheel_rail_tab54.yaml", _params_file(tmp_path, layer, "l.yaml"),
                    _params_file(tmp_path, temp, "t.yaml"))
    assert base.thermal is not None and len(sc.fit.covariances) == 2
    pred = predict_traction(sc, [0.002, 0.01, 0.05])
    assert set(pred.band.names) == set(names) | set(tnames)
    blocks = pred.band._design["dist"].blocks
    assert sorted(dof for _, dof in blocks) == [3.0, 20.0]


def test_bad_covariance_in_a_parameter_file_is_one_line_naming_the_key(cli, tmp_path):
    sc = load_scene(SCENES / "wheel_rail_tab54.yaml")
    bad = tmp_path / "bad.yaml"
    for matrix, why in (([[1e-4, 1e-5], [0.0, 1e-4]], "not symmetric"),
                        ([[1e-4, 2e-4], [2e-4, 1e-4]], "positive semi-definite"),
                        ([[1e-4]], "2 x 2")):
        bad.write_text(dump_yaml({"boundary": {"mu_c1": sc.boundary.mu_c1,
                                               "mu_c2": sc.boundary.mu_c2},
                                  "fit": {"covariance": {"names": ["mu_c1", "mu_c2"],
                                                         "values": [sc.boundary.mu_c1,
                                                                    sc.boundary.mu_c2],
                                                         "matrix": matrix}}}))
        r = cli("predict", "traction", SCENES / "wheel_rail_tab54.yaml", bad, "-o",
                tmp_path / "o")
        assert r.exit_code == 2, r.output
        lines = error_lines(r)
        assert len(lines) == 1 and "bad.yaml" in lines[0] and "fit.covariance" in lines[0], lines
        assert why in lines[0]
        assert not (tmp_path / "o").exists()


def test_cli_fit_traction_then_predict_with_band(cli, tmp_path):
    dry = _dry_scene_file(tmp_path)
    sc = load_scene(dry)
    mu = traction_model(sc)(TRUTH, XI_FIT) * (1 + 0.01 * np.random.default_rng(5).standard_normal(
        XI_FIT.size))
    pd.DataFrame({"creepage": XI_FIT, "mu": mu}).to_csv(tmp_path / "curve.csv", index=False)
    r = cli("fit", "traction", dry, tmp_path / "curve.csv", "-o", tmp_path / "fit")
    assert r.exit_code == 0, r.output
    prm = load_scene(dry, tmp_path / "fit" / "params.yaml")
    (cov,) = prm.fit.covariances
    assert cov.names == ["mu_c1", "mu_c2", "L_mue", "L_mup"]
    assert set(cov.log_scale) == set(cov.names)
    r = cli("predict", "traction", dry, tmp_path / "fit" / "params.yaml", "--creepage",
            "0:0.05:51", "-o", tmp_path / "pred")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "pred" / "traction.csv")
    assert {"mu_low95", "mu_high95"} <= set(t.columns)
    assert np.all(t["mu_low95"] <= t["mu"]) and np.all(t["mu"] <= t["mu_high95"])
    assert np.all(t["mu_high95"].iloc[1:] > t["mu_low95"].iloc[1:])
    s = json.loads((tmp_path / "pred" / "summary.json").read_text())
    assert s["band"]["method"] in ("linear", "sampling")
    assert s["band"]["dominant"]["mu"], s["band"]
    assert "95 % band from the fit's covariance" in r.output and "shares of its variance" in r.output
    tr = s["trend_after_saturation"]
    assert set(tr) >= {"trend", "saturation_creepage", "trend_from_creepage", "probabilities"}
    assert (tmp_path / "pred" / "traction.png").exists()


# ---------------------------------------------------------------------------------------
# verdicts with their evidence
# ---------------------------------------------------------------------------------------
XT = np.linspace(0.0005, 0.1, 80)


def _tilted(A, b):
    return A * np.tanh(XT / 0.004) * (1 + b * XT)


def _change_reference(b):
    """The H4.1 statistic computed independently: line through |mu| over the second half of
    the post-saturation range, its change relative to the first point of that half."""
    y = np.abs(_tilted(0.3, b))
    k = int(np.argmax(y >= 0.95 * y.max()))
    tail = XT >= 0.5 * (XT[k] + XT[-1])
    slope = np.polyfit(XT[tail], y[tail], 1)[0]
    return slope * (XT[tail][-1] - XT[tail][0]) / y[tail][0]


@pytest.mark.parametrize("b0, sd", [(0.05, 0.05), (0.3, 0.05), (-0.4, 0.05), (0.2, 0.2)])
def test_trend_probabilities_against_a_closed_form(b0, sd):
    """mu = 0.3 tanh(x/0.004)(1 + b x), b ~ N(b0, sd^2): the statistic is monotone in b, so
    P(positive) = P(b > b*) with change(b*) = +1 %, P(negative) = P(b < b_) with
    change(b_) = -1 %: normal probabilities the propagation must reproduce."""
    d = ParameterDistribution.from_covariance(("b",), [b0], [[sd**2]])
    prop = propagate(lambda p: {"mu": _tilted(0.3, p["b"])}, d)
    t = classify_trend(XT, _tilted(0.3, b0), uncertainty=prop)
    b_hi = brentq(lambda b: _change_reference(b) - 0.01, -2, 2)
    b_lo = brentq(lambda b: _change_reference(b) + 0.01, -2, 2)
    p_pos, p_neg = norm.sf((b_hi - b0) / sd), norm.cdf((b_lo - b0) / sd)
    p = t["probabilities"]
    assert p["positive"] == pytest.approx(p_pos, abs=0.01)
    assert p["negative"] == pytest.approx(p_neg, abs=0.01)
    assert sum(p.values()) == pytest.approx(1.0, abs=1e-9)
    best = max(p, key=p.get)
    assert t["trend"] == (best if p[best] >= 0.9 else "undetermined")
    assert t["trend_point"] in ("negative", "neutral", "positive")
    assert t["relative_change"] == pytest.approx(_change_reference(b0), rel=1e-9)


def test_undetermined_trend_reports_its_probabilities_and_the_threshold_is_configurable():
    d = ParameterDistribution.from_covariance(("b",), [0.1], [[0.1**2]])
    prop = propagate(lambda p: {"mu": _tilted(0.3, p["b"])}, d)
    t = classify_trend(XT, _tilted(0.3, 0.1), uncertainty=prop)
    # change = 0.1 x 0.05 / (1 + ...) ~ +0.5 %: neutral at the estimate, but not likely enough
    assert t["trend"] == "undetermined" and t["trend_point"] == "neutral"
    assert max(t["probabilities"].values()) < 0.9
    lax = classify_trend(XT, _tilted(0.3, 0.1), uncertainty=prop, threshold=0.5)
    assert lax["trend"] == max(lax["probabilities"], key=lax["probabilities"].get)
    wide = classify_trend(XT, _tilted(0.3, 0.1), uncertainty=prop, tolerance=0.5)
    assert wide["trend"] == "neutral" and wide["probabilities"]["neutral"] > 0.99


def test_measured_trend_from_the_scatter_about_the_line():
    rng = np.random.default_rng(4)
    flat = _tilted(0.3, 0.0) + 0.003 * rng.standard_normal(XT.size)
    falling = _tilted(0.3, -1.0) + 0.001 * rng.standard_normal(XT.size)
    t = classify_trend(XT, falling, measured=True)
    assert t["trend"] == "negative" and t["probabilities"]["negative"] > 0.999
    t = classify_trend(XT, flat, measured=True)
    assert t["trend"] in ("neutral", "undetermined")
    assert "scatter" in t["basis"] and t["relative_change_low95"] < t["relative_change"]
    # without evidence the old keys and the point class stay as they were
    t = classify_trend(XT, flat)
    assert t["probabilities"] is None and t["trend"] == t["trend_point"]


def test_trend_keys_always_present():
    for x, y in ((XT, 2 * XT), ([0.01, 0.02], [0.1, 0.2]), (XT, _tilted(0.3, 0.0))):
        t = classify_trend(np.asarray(x), np.asarray(y))
        assert {"trend", "saturation_creepage", "trend_from_creepage", "probabilities",
                "trend_point"} <= set(t)


def test_crossing_probabilities_against_monte_carlo():
    """Logistic f(x) = 0.05 + 0.25 expit(-3 (x - ln 8)) with a small parameter covariance: the
    probability that the 0.15 crossing lies within 2-20 amounts, by the delta method, matches
    a Monte Carlo over the parameters with the crossing solved for each draw."""
    from scipy.special import expit

    from torlab.fit.crossing import crossing_probabilities

    p = {"f_low": 0.05, "f_high": 0.30, "k": 3.0, "c": float(np.log(8.0))}
    C = np.diag([0.005, 0.005, 0.3, 0.1]) ** 2
    a = np.array([2.0, 4.0, 8.0, 16.0, 20.0])
    ev = crossing_probabilities(p, C, a, 0.15, dof=1e6)
    rng = np.random.default_rng(0)
    draws = rng.multivariate_normal([0.05, 0.30, 3.0, np.log(8.0)], C, 20000)
    fl, fh, k, c = draws.T
    lnx = c + np.log((fh - fl) / (0.15 - fl) - 1) / k
    mc = np.mean((lnx >= np.log(2.0)) & (lnx <= np.log(20.0)))
    assert ev["p_inside"] == pytest.approx(mc, abs=0.01)
    f_max = fl + (fh - fl) * expit(-k * (np.log(20.0) - c))
    assert ev["p_below_at_largest"] == pytest.approx(np.mean(f_max < 0.15), abs=0.01)
    assert ev["verdict"] == ("crosses within the tested amounts" if ev["p_inside"] >= 0.9
                             else "undetermined")


def test_prediction_with_band_pickles_for_the_protocol_cache(tmp_path):
    import pickle

    dry = _dry_scene_file(tmp_path)
    sc = load_scene(dry)
    mu = traction_model(sc)(TRUTH, XI_FIT) * (1 + 0.01 * np.random.default_rng(1).standard_normal(
        XI_FIT.size))
    res = fit_layer_traction(sc, XI_FIT, mu)
    pred = predict_traction(load_scene(dry, _params_file(tmp_path, res)), [0.002, 0.01, 0.04])
    back = pickle.loads(pickle.dumps(pred))
    np.testing.assert_array_equal(back.table["mu_high95"], pred.table["mu_high95"])
    assert back.band.method == pred.band.method


def test_cli_fit_film_then_predict_stribeck_with_bands(cli, tmp_path):
    from torlab.model.contact import build_contact
    from torlab.model.ehl import hc_piezo

    scene = SCENES / "mtm_paper_b.yaml"
    sc = load_scene(scene)
    c = build_contact(sc)
    v = np.geomspace(0.05, 2.0, 15)
    h = hc_piezo(v, sc.contact.load, c.E_star, c.rx, sc.lubricant.eta0, 18e-9,
                 c.patch.b / c.patch.a) * np.exp(0.03 * np.random.default_rng(2).standard_normal(15))
    pd.DataFrame({"speed_m_s": v, "film_thickness_m": h}).to_csv(tmp_path / "film.csv",
                                                                   index=False)
    r = cli("fit", "film", tmp_path / "film.csv", "--scene", scene, "-o", tmp_path / "fit")
    assert r.exit_code == 0, r.output
    r = cli("predict", "stribeck", scene, tmp_path / "fit" / "params.yaml", "--speed",
            "0.01:2:12", "-o", tmp_path / "pred")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "pred" / "stribeck.csv")
    for col in ("mu_low95", "mu_high95", "film_thickness_low95_m", "film_thickness_high95_m"):
        assert col in t and t[col].notna().all(), col
    assert np.all(t["film_thickness_low95_m"] < t["film_thickness_m"])
    assert np.all(t["film_thickness_m"] < t["film_thickness_high95_m"])
    s = json.loads((tmp_path / "pred" / "summary.json").read_text())
    assert s["band"]["parameters"] == ["alpha"]
    assert s["band"]["dominant"]["film_thickness_m"][0]["parameter"] == "alpha"


def test_uncertainty_reaching_a_model_failure_gives_no_band_and_the_reason():
    """Temperature coefficients known only to +-0.01 1/K with one degree of freedom (three
    temperatures): their 95 % range includes self-amplifying heating in the Tab. 5.4 thermal
    scene, where the tau-T loop has no steady state.  No band is drawn; the summary says why."""
    sc = load_scene(SCENES / "wheel_rail_tab54.yaml")
    d = sc.model_dump(exclude_none=True)
    d["boundary"].update(mu_c1_T=5e-4, mu_c2_T=5e-4)
    d = _with_covariance(d, ["mu_c1_T", "mu_c2_T"], [5e-4, 5e-4], [[1e-4, 0.0], [0.0, 1e-4]],
                         dof=1.0)
    pred = predict_traction(scene_from_dict(d), np.linspace(0.002, 0.05, 8))
    assert pred.band is None and "mu_low95" not in pred.table
    note = pred.summary["band"]["notes"][0]
    assert note.startswith("no band:") and "failed for" in note and "runaway" in note, note
    assert pred.trend["probabilities"] is None
