"""Traction-curve fit of the layer with FASTSIM."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from torlab.errors import TorlabInputError
from torlab.fit.traction import fit_layer_traction, traction_model
from torlab.model.predict import predict_traction
from torlab.scene import load_scene, scene_from_dict

SCENE = ROOT / "protocols" / "scenes" / "optical_paper_a_rough.yaml"
TRUTH = {"mu_c1": 0.16, "mu_c2": 0.26, "L_mue": 6e-6, "L_mup": 12e-6}


def _dry_scene():
    sc = load_scene(SCENE)
    return sc.model_copy(update={"lubricant": None, "roughness": None})


def _curve(seed: int, n: int = 40, noise: float = 0.003):
    sc = _dry_scene()
    xi = np.linspace(0.002, 0.08, n)
    mu = traction_model(sc)(TRUTH, xi)
    return sc, xi, mu + noise * np.random.default_rng(seed).standard_normal(n)


def test_model_is_predicts_model():
    """The fit's model is exactly what torlab predict traction computes for the scene."""
    sc, xi, _ = _curve(0)
    b = sc.boundary.model_copy(update=TRUTH)
    ref = predict_traction(sc.model_copy(update={"boundary": b}), xi).table["mu"].to_numpy()
    np.testing.assert_allclose(traction_model(sc)(TRUTH, xi), ref, rtol=0, atol=1e-14)


@pytest.mark.slow
def test_recovery_and_coverage_over_seeds():
    """Synthetic curves (model at known parameters + white noise): the 95 % intervals cover
    the truth in at least 25 of 30 seeds for each parameter (binomial: 28.5 expected)."""
    hits = np.zeros(4)
    nfev = []
    n = 30
    for seed in range(n):
        sc, xi, mu = _curve(seed)
        res = fit_layer_traction(sc, xi, mu)
        hits += [res.ci95[k][0] <= TRUTH[k] <= res.ci95[k][1] for k in TRUTH]
        nfev.append(res.n_evaluations)
    assert np.all(hits >= 25), hits
    assert np.median(nfev) < 150  # a handful of Jacobians, not a brute-force search


def test_odd_in_creepage_and_sign_kept():
    sc, xi, mu = _curve(1)
    a = fit_layer_traction(sc, xi, mu)
    b = fit_layer_traction(sc, -xi, -mu)
    for k in TRUTH:
        assert b.params[k] == pytest.approx(a.params[k], rel=1e-3)


def test_fixed_parameter_is_reported_and_written():
    sc, xi, mu = _curve(2)
    res = fit_layer_traction(sc, xi, mu, fixed={"L_mup": 12e-6})
    assert "L_mup" not in res.names
    assert res.to_scene_dict()["boundary"]["L_mup"] == 12e-6
    assert res.ci95["mu_c2"][0] <= TRUTH["mu_c2"] <= res.ci95["mu_c2"][1]


def test_params_file_feeds_predict_unchanged(tmp_path):
    """The written parameter file merged onto the scene reproduces the fitted model curve."""
    from torlab.yamlio import dump_yaml

    sc, xi, mu = _curve(3)
    res = fit_layer_traction(sc, xi, mu)
    p = tmp_path / "params.yaml"
    p.write_text(dump_yaml(res.to_yaml_dict()))
    dry = tmp_path / "dry.yaml"
    raw = load_scene(SCENE).model_dump(exclude_none=True)
    raw.pop("lubricant"), raw.pop("roughness"), raw.pop("fit", None)
    dry.write_text(dump_yaml(raw))
    merged = load_scene(dry, p)
    pred = predict_traction(merged, xi).table["mu"].to_numpy()
    np.testing.assert_allclose(pred, res.data["mu_model"].to_numpy(), atol=1e-12)
    assert merged.fit["kind"] == "layer_traction"
    scene_from_dict(merged.model_dump())  # still a valid scene


def test_sample_dry_traction_plateau():
    """sample_data/optical/dry_traction_rough.csv is generated from the model with a known
    layer (its truth.yaml): the fitted saturated coefficient is the generating mu_c2."""
    from torlab.reduce.optical import reduce_optical_log
    from torlab.yamlio import load_yaml

    opt = ROOT / "sample_data" / "optical"
    mu_c2 = load_yaml(opt / "truth.yaml").data["layer"]["mu_c2"]
    pts = reduce_optical_log(opt / "dry_traction_rough.csv").points
    res = fit_layer_traction(_dry_scene(), pts["srr"], pts["traction_coefficient"])
    assert res.ci95["mu_c2"][0] <= mu_c2 <= res.ci95["mu_c2"][1]
    assert res.params["mu_c2"] == pytest.approx(mu_c2, abs=0.003)


def test_bad_traction_data():
    sc, xi, mu = _curve(4)
    with pytest.raises(TorlabInputError, match="too few"):
        fit_layer_traction(sc, xi[:4], mu[:4])
    with pytest.raises(TorlabInputError, match="constant"):
        fit_layer_traction(sc, xi, np.full_like(xi, 0.2))
    with pytest.raises(TorlabInputError, match="one creepage"):
        fit_layer_traction(sc, np.full(10, 0.01), np.linspace(0.1, 0.2, 10))
    with pytest.raises(TorlabInputError, match="fix"):
        fit_layer_traction(sc, xi, mu, fixed={"nope": 1.0})


def test_lubricated_scene_fits_the_boundary_layer_through_the_mixed_model():
    """Rough ball in water at 0.05 m/s: about half of the load is on asperities, so the measured
    plateau is about half of mu_c2. The fit goes through the mixed model and recovers the
    layer's own parameters (one draw: each within 4 standard errors of the truth)."""
    sc = load_scene(SCENE)
    sc = sc.model_copy(update={"kinematics": sc.kinematics.model_copy(update={"speed": 0.05})})
    xi = np.linspace(0.002, 0.08, 30)
    share = predict_traction(sc, xi).table["load_share_asperity"].to_numpy()
    assert np.all((share > 0.3) & (share < 0.8))  # a genuinely mixed contact
    f = traction_model(sc)
    mu = f(TRUTH, xi) + 0.0015 * np.random.default_rng(21).standard_normal(xi.size)
    assert np.max(mu) < 0.7 * TRUTH["mu_c2"]  # the plateau is not mu_c2
    res = fit_layer_traction(sc, xi, mu)
    for k, v in TRUTH.items():
        assert abs(res.params[k] - v) < 4 * res.stderr[k], (k, res.params[k], v, res.stderr[k])
    assert res.params["mu_c2"] == pytest.approx(TRUTH["mu_c2"], rel=0.05)
    assert res.n_evaluations < 150


def test_softening_fit_is_flagged_and_a_hardening_one_is_not():
    """A curve from a softening layer (mu_c1 > mu_c2) gets the softening warning; the
    hardening truth of the other tests does not."""
    soft = {"mu_c1": 0.30, "mu_c2": 0.22, "L_mue": 6e-6, "L_mup": 8e-6}
    sc = _dry_scene()
    xi = np.linspace(0.002, 0.08, 40)
    mu = traction_model(sc)(soft, xi) + 0.002 * np.random.default_rng(8).standard_normal(40)
    res = fit_layer_traction(sc, xi, mu)
    assert any(w.startswith("softening layer fitted") for w in res.warnings), res.warnings
    sc, xi, mu = _curve(5)
    res = fit_layer_traction(sc, xi, mu)
    assert not any(w.startswith("softening") for w in res.warnings), res.warnings


def test_noisy_sparse_curve_never_gives_a_negative_bound_and_states_each_choice():
    """20 points with 0.01 noise (4 % of the plateau): the knee is poorly resolved.  Every
    interval stays positive (log scale); a poorly determined parameter is kept and said to be
    carried into predictions; one that runs onto the upper bound of its range is not
    determined (left out of the covariance, so a prediction gets no band); a length that runs
    to 0 is fixed there.  Seeds 0-3 show all three."""
    sc = _dry_scene()
    xi = np.linspace(0.002, 0.08, 20)
    mu0 = traction_model(sc)(TRUTH, xi)
    seen = set()
    for seed in range(4):
        res = fit_layer_traction(sc, xi, mu0 + 0.01 * np.random.default_rng(seed).standard_normal(20))
        for n in res.names:
            assert res.ci95[n][0] >= 0, (n, res.ci95[n])
        sel = res.meta.get("model_selection", {})
        cov = res.covariance_section()
        assert set(cov["names"]) | set(cov["not_determined"]) == set(res.names)
        for n, d in sel.items():
            seen.add(d["decision"].split(";")[0].split(" (")[0])
            if d["decision"].startswith("kept"):
                assert any(w.startswith(f"{n} poorly determined") and "carried into predictions"
                           in w for w in res.warnings)
                assert n in cov["names"]
            elif d["decision"].startswith("not determined"):
                assert n in cov["not_determined"] and not res.determined(n)
            else:
                assert n in res.fixed and n not in res.names
    assert seen == {"kept", "not determined", "fixed at the lower end of its range"}, seen


def _two_speeds():
    sc = load_scene(SCENE)
    xi1 = np.linspace(0.004, 0.05, 8)
    return sc, np.concatenate([xi1, xi1]), np.repeat([0.1, 0.5], xi1.size)


SPEED_TRUTH = {"mu_c1": 0.2, "mu_c2": 0.26, "L_mue": 2e-6, "L_mup": 4e-6}


def test_a_log_at_several_speeds_is_modelled_at_each_points_speed():
    """A lubricated traction test recorded at two rolling speeds: the film (and with it the
    asperities' share) differs between them, so one scene speed cannot model both curves.
    The fit's model evaluates each point at its own speed."""
    from torlab.fit.traction import speed_model

    sc, xi, v = _two_speeds()
    f, speeds, group = speed_model(sc, v)
    assert speeds == pytest.approx([0.1, 0.5]) and list(group) == [0] * 8 + [1] * 8
    mu = f(SPEED_TRUTH, xi)
    slow = sc.model_copy(update={"kinematics": sc.kinematics.model_copy(update={"speed": 0.1})})
    np.testing.assert_allclose(mu[:8], traction_model(slow)(SPEED_TRUTH, xi[:8]), atol=1e-14)
    np.testing.assert_allclose(mu[8:], traction_model(sc)(SPEED_TRUTH, xi[8:]), atol=1e-14)
    assert abs(traction_model(sc)(SPEED_TRUTH, xi[:8]) - mu[:8]).max() > 0.02
    with pytest.raises(TorlabInputError, match="speeds"):
        fit_layer_traction(sc, xi, mu, speed=v[:3])


@pytest.mark.slow  # two mixed-model curves fitted (3 s); the model at each speed: the test above
def test_a_log_at_several_speeds_is_fitted_at_each_points_speed():
    """The fit of the two-speed curve recovers the layer (mu_c2 in its interval)."""
    from torlab.fit.traction import speed_model

    sc, xi, v = _two_speeds()
    mu = speed_model(sc, v)[0](SPEED_TRUTH, xi)
    mu = mu * (1 + 0.005 * np.random.default_rng(3).standard_normal(xi.size))
    res = fit_layer_traction(sc, xi, mu, speed=v)
    assert res.meta["speeds_m_s"] == pytest.approx([0.1, 0.5])
    assert set(res.data["curve"]) == {"0.1 m/s", "0.5 m/s"}
    lo, hi = res.ci95["mu_c2"]
    assert lo <= SPEED_TRUTH["mu_c2"] <= hi and hi - lo < 0.05


@pytest.mark.slow  # the sample log's five speeds through the mixed model (10 s); parts above
def test_paper_a_lubricated_traction_log_fits_from_the_command_line(tmp_path, cli):
    """``torlab fit traction`` on Paper A's lubricated traction log (five speeds, truth in
    sample_data/optical/truth.yaml: mu_c2 0.26): no internal error, a valid summary.json,
    the generating mu_c2 within its interval, the speeds stated."""
    import json

    from torlab.yamlio import load_yaml

    opt = ROOT / "sample_data" / "optical"
    r = cli("fit", "traction", SCENE, opt / "traction_rough.csv", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert len(s["meta"]["speeds_m_s"]) == 5
    truth = load_yaml(opt / "truth.yaml").data["layer"]["mu_c2"]
    lo, hi = s["ci95"]["mu_c2"]
    assert lo <= truth <= hi


def test_an_unbounded_interval_reaches_the_summary_as_null():
    """A parameter whose interval has no upper end (a length at the foot of its range) is
    written as null in summary.json and params.yaml, never as an infinity."""
    import json

    from torlab.fit.result import FitResult

    res = FitResult.from_covariance("layer_traction", ("mu_c2", "L_mue"),
                                    np.array([0.26, 1e-10]), np.diag([1e-8, 1e-13]), dof=20,
                                    log_scale=("mu_c2", "L_mue"), residual_norm=0.001,
                                    n_points=25, warnings=[], data=None)
    assert res.ci95["L_mue"][1] == np.inf
    res.meta["model_selection"] = {"L_mue": {"ci95": list(res.ci95["L_mue"])}}
    s = json.dumps(res.summary(), allow_nan=False)
    assert json.loads(s)["meta"]["model_selection"]["L_mue"]["ci95"] == [0.0, None]
    assert res.provenance()["model_selection"]["L_mue"]["ci95"][1] is None
    assert "unbounded" in res.report()


# ------------------------------------------------- one fit for the CLI, the API, protocols
@pytest.fixture(scope="module")
def two_speed_log(tmp_path_factory):
    """A virtual optical traction log at 0.1 and 0.5 m/s (8 SRRs each) on the lubricated
    Paper A contact, generated from the mixed model with SPEED_TRUTH at each set speed."""
    from torlab.synth.optical import OpticalCondition, OpticalRig, OpticalTest, write_optical_log

    sc, xi, v = _two_speeds()
    from torlab.fit.traction import speed_model

    grid = np.linspace(0.0, 0.06, 31)
    tab = {s: speed_model(sc, np.full(grid.size, s))[0](SPEED_TRUTH, grid) for s in (0.1, 0.5)}

    def mu_fn(U, srr):
        U, srr = np.asarray(U, dtype=float), np.asarray(srr, dtype=float)
        near = np.where(np.abs(U - 0.1) < np.abs(U - 0.5), 0.1, 0.5)
        a = np.abs(srr)
        return np.sign(srr) * np.where(near == 0.1, np.interp(a, grid, tab[0.1]),
                                       np.interp(a, grid, tab[0.5]))

    conds = tuple(OpticalCondition(float(u), float(s), 90.1, 6.0) for u, s in zip(v, xi, strict=True))
    test = OpticalTest("two speeds", "traction", "rough", "water", conds)
    path = tmp_path_factory.mktemp("two_speeds") / "two.csv"
    write_optical_log(path, test, mu_fn, rig=OpticalRig(sample_rate_hz=50.0), seed=5)
    return path


def _protocol(tmp_path, log):
    p = tmp_path / "two_speeds.yaml"
    p.write_text(f"""\
version: 1
name: two_speeds
data:
  optical:
    files: [{log.as_posix()}]
fits:
  traction_layers:
    - name: wet
      measured: {log.as_posix()}
      scene: {SCENE.as_posix()}
reports:
  traction:
    creepage: {{from: 0, to: 0.05, points: 6}}
    curves:
      - label: water, fitted layer
        scene: {SCENE.as_posix()}
        params: ["traction:wet"]
        speeds: measured
        measured: {log.as_posix()}
""")
    return p


def test_traction_data_gives_every_point_its_speed(two_speed_log):
    """A log at two rolling speeds: traction_data (the one reader of a traction test for
    the CLI, the API and protocols) gives each point the speed it was measured at, from the
    file and from its reduction alike."""
    from torlab.instruments import reduce_file
    from torlab.instruments.measured import traction_data

    log = two_speed_log
    d = traction_data(log)
    assert d.test == "traction" and d.creepage.size == d.speed.size == 16
    np.testing.assert_allclose(np.sort(np.unique(np.round(d.speed, 3))), [0.1, 0.5])
    # each point's speed is its condition's: the slow curve's points at 0.1 m/s
    _, xi, v = _two_speeds()
    for s in (0.1, 0.5):
        np.testing.assert_allclose(np.sort(d.creepage[np.isclose(d.speed, s, rtol=0.05)]),
                                   xi[v == s], atol=1.5e-3)
    r = traction_data(reduce_file(log))
    for a, b in zip((*d[:2], d.speed), (*r[:2], r.speed), strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_protocol_hands_the_fit_every_points_speed(tmp_path, monkeypatch, two_speed_log):
    """fits.traction_layers fits a multi-speed log as ``torlab fit traction`` does: the
    lubricated scene, each point at its own speed (not the median speed for all). The fit
    itself is stopped once called (its result on this log: the slow test below)."""
    import torlab.fit.traction as ft
    from torlab.protocols.runner import run_protocol

    class Called(Exception):
        pass

    seen = {}

    def spy(scene, creepage, mu, *, fixed=None, speed=None, **_):
        seen.update(scene=scene, creepage=creepage, speed=speed)
        raise Called

    monkeypatch.setattr(ft, "fit_layer_traction", spy)
    with pytest.raises(Called):
        run_protocol(_protocol(tmp_path, two_speed_log), tmp_path / "out", cache=False)
    assert seen["scene"].lubricant is not None
    assert seen["speed"] is not None and seen["speed"].size == seen["creepage"].size == 16
    np.testing.assert_allclose(np.sort(np.unique(np.round(seen["speed"], 3))), [0.1, 0.5])


@pytest.mark.slow  # two mixed-model fits of a two-speed log (about 5 s); the hand-over: above
def test_a_protocol_fits_a_multi_speed_log_as_the_api_does(tmp_path, two_speed_log):
    """The protocol's traction:wet set is the API's fit of the same file, number for
    number, and holds the generating mu_c2 in its interval."""
    import torlab
    from torlab.protocols.runner import run_protocol

    log = two_speed_log
    run = run_protocol(_protocol(tmp_path, log), tmp_path / "out", cache=False)
    api = torlab.fit_traction(SCENE, log)
    assert api.meta["speeds_m_s"] == pytest.approx([0.1, 0.5], rel=0.02)
    lo, hi = api.ci95["mu_c2"]
    assert lo <= SPEED_TRUTH["mu_c2"] <= hi
    got = run.summary["fits"]["traction:wet"]
    for n in SPEED_TRUTH:
        assert got["params"][n] == pytest.approx(api.params[n], rel=1e-12), n
