"""Scene-level predictions (issues 3 and 4): `torlab predict traction|stribeck`, the
mixed model's limits, what is modelled, bad scenes, and a hard-case sweep."""

from __future__ import annotations

import itertools
import json
import warnings

import numpy as np
import pandas as pd
import pytest

from tests.conftest import ROOT, error_lines, sha
from torlab.errors import NumericalError, TorlabError
from torlab.model.mixed import mixed_traction_curve
from torlab.model.predict import predict_stribeck, predict_traction
from torlab.model.prediction import classify_trend
from torlab.scene import load_scene, scene_from_dict

SCENES = ROOT / "protocols" / "scenes"


def lubricated(**over) -> dict:
    """Paper A-like rough ball on glass with water; sections overridden by ``over``."""
    d = {
        "name": "test",
        "contact": {"load": "90 N", "r1x": "12.7 mm", "r1y": "12.7 mm", "hertz": "exact"},
        "materials": {"E1": "210 GPa", "nu1": 0.3, "E2": "82 GPa", "nu2": 0.206},
        "kinematics": {"speed": "0.5 m/s"},
        "boundary": {"mu_c1": 0.18, "mu_c2": 0.25, "L_mue": "5 um", "L_mup": "10 um"},
        "lubricant": {"eta0": "1 mPa*s"},
        "roughness": {"sigma": "9.56 nm", "beta": "0.373 mm", "density": "21500 mm^-2",
                      "hardness": "6 GPa"},
    }
    for k, v in over.items():
        if v is None:
            d.pop(k, None)
        elif isinstance(v, dict) and isinstance(d.get(k), dict):
            d[k] = {**d[k], **v}
        else:
            d[k] = v
    return d


# ---------------------------------------------------------------------------------------
# example scenes and the CLI
# ---------------------------------------------------------------------------------------
def test_example_scenes_load_and_match_the_thesis():
    wr = load_scene(SCENES / "wheel_rail_tab54.yaml")
    from torlab.model.contact import build_contact

    c = build_contact(wr)
    assert c.patch.p0 == pytest.approx(790e6, rel=0.015)  # Tab. 5.4: 790 MPa
    for name, p0 in [("mtm_paper_b", 800e6), ("optical_paper_a_rough", 750e6),
                     ("optical_paper_a_smooth", 750e6)]:
        c = build_contact(load_scene(SCENES / f"{name}.yaml"))
        assert c.patch.p0 == pytest.approx(p0, rel=2e-3), name


def test_predict_traction_cli_dry(cli, tmp_path):
    scene = SCENES / "wheel_rail_tab54.yaml"
    before = sha(scene)
    r = cli("predict", "traction", scene, "--creepage", "0:0.05:101", "-o", tmp_path / "out")
    assert r.exit_code == 0, r.output
    out = tmp_path / "out"
    t = pd.read_csv(out / "traction.csv")
    assert list(t.columns[:2]) == ["creepage", "mu"]
    assert {"mu_boundary", "max_temperature_C"} <= set(t.columns)
    assert len(t) == 101 and t["mu"].iloc[0] == 0.0
    assert np.all(np.diff(t["mu"]) > 0) and t["mu"].max() < 0.45
    s = json.loads((out / "summary.json").read_text())
    # the scene has no temperature coefficients: an isothermal layer, which only rises to mu_c2
    assert s["trend_after_saturation"]["trend"] in ("negative", "neutral",
                                                  "not saturated in this range")
    assert any("EHL film: not modelled" in m for m in s["modelled"])
    assert (out / "traction.png").stat().st_size > 10_000
    assert not (out / "traction.svg").exists()  # PNG by default; SVG/PDF on request
    assert "trend after saturation" in r.output
    assert sha(scene) == before
    # never silently over earlier results
    r2 = cli("predict", "traction", scene, "-o", out)
    assert r2.exit_code == 2 and "--force" in r2.output


def test_predict_traction_formats_and_no_plot(cli, tmp_path):
    scene = SCENES / "wheel_rail_tab54.yaml"
    r = cli("predict", "traction", scene, "-o", tmp_path / "all", "--formats", "png,svg,pdf")
    assert r.exit_code == 0, r.output
    out = tmp_path / "all"
    assert (out / "traction.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert b"<svg" in (out / "traction.svg").read_bytes()[:400]
    assert (out / "traction.pdf").read_bytes()[:5] == b"%PDF-"
    # --no-plot: the same table and summary, no figure
    r = cli("predict", "traction", scene, "-o", tmp_path / "np", "--no-plot")
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "np").iterdir()) == [
        "summary.json", "torlab-manifest.json", "traction.csv"]
    assert (tmp_path / "np" / "traction.csv").read_bytes() == (out / "traction.csv").read_bytes()
    # an unknown format is a one-line user error, nothing written
    r = cli("predict", "traction", scene, "-o", tmp_path / "bad", "--formats", "png,jpeg")
    assert r.exit_code == 2 and "jpeg" in r.output and "--formats" in r.output
    assert not (tmp_path / "bad").exists()


def test_predict_traction_params_file_overrides_scene(cli, tmp_path):
    params = tmp_path / "params.yaml"
    params.write_text("boundary:\n  mu_c1: 0.1\n  mu_c2: 0.12\n  L_mue: 5 um\n  L_mup: 10 um\n")
    r = cli("predict", "traction", SCENES / "wheel_rail_tab54.yaml", params,
            "--creepage", "0.001,0.01,0.1", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "o" / "traction.csv")
    assert t["creepage"].tolist() == [0.001, 0.01, 0.1]
    assert t["mu"].max() <= 0.12 + 1e-9


def test_predict_stribeck_cli(cli, tmp_path):
    r = cli("predict", "stribeck", SCENES / "optical_paper_a_smooth.yaml", "--speed", "0.01:2:20",
            "--creepage", "5 %", "-o", tmp_path / "s")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "s" / "stribeck.csv")
    for col in ("speed_m_s", "mu", "film_thickness_m", "lambda", "load_share_asperity"):
        assert col in t.columns
    assert t["speed_m_s"].iloc[0] == pytest.approx(0.01) and t["speed_m_s"].iloc[-1] == 2
    assert np.all(np.diff(t["film_thickness_m"]) > 0)
    assert np.all(np.diff(t["load_share_asperity"]) < 0)
    assert (tmp_path / "s" / "stribeck.png").exists()


def test_stribeck_of_a_dry_scene_is_a_user_error(cli, tmp_path):
    r = cli("predict", "stribeck", SCENES / "wheel_rail_tab54.yaml", "-o", tmp_path / "x")
    assert r.exit_code == 2
    assert len(error_lines(r)) == 1 and "lubricant" in error_lines(r)[0]


@pytest.mark.parametrize("edit, key", [
    (("  mu_c2: 0.45", "  mu_c2: 0.45\n  mu_c3: 0.5"), "boundary.mu_c3"),
    (("  load: 20 kN\n", ""), "contact.load"),
    (("load: 20 kN", "load: 20 km"), "contact.load"),
    (("load: 20 kN", "load: -20 kN"), "contact.load"),
    (("E1: 210 GPa", "E1: -210 GPa"), "materials.E1"),
    (("speed: 10 m/s", "speed: fast"), "kinematics.speed"),
])
def test_bad_scene_one_line_naming_file_and_key(cli, tmp_path, edit, key):
    text = (SCENES / "wheel_rail_tab54.yaml").read_text()
    assert edit[0] in text
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace(edit[0], edit[1]))
    r = cli("predict", "traction", bad, "-o", tmp_path / "o")
    assert r.exit_code == 2
    lines = error_lines(r)
    assert len(lines) == 1, lines
    assert "bad.yaml" in lines[0] and key in lines[0] and "Traceback" not in r.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("section, value, key", [
    ("lubricant", {"eta0": "-1 mPa*s"}, "lubricant.eta0"),
    ("lubricant", {"viscosity": "roelands", "Z": 0}, "lubricant.Z"),
    ("lubricant", {"viscosity": "roelands", "Z": -0.5}, "lubricant.Z"),
    ("roughness", {"sigma": "0 nm"}, "roughness.sigma"),
    ("roughness", {"hardness": "6 GPa/s"}, "roughness.hardness"),
    ("lubricant", {"shear": "limiting"}, "lubricant"),
])
def test_bad_lubricant_and_roughness_inputs(cli, tmp_path, section, value, key):
    import yaml

    f = tmp_path / "s.yaml"
    f.write_text(yaml.safe_dump(lubricated(**{section: value})))
    r = cli("predict", "stribeck", f, "-o", tmp_path / "o")
    assert r.exit_code == 2, r.output
    lines = error_lines(r)
    assert len(lines) == 1 and "s.yaml" in lines[0] and key in lines[0], lines


def test_bad_creepage_option(cli, tmp_path):
    r = cli("predict", "traction", SCENES / "wheel_rail_tab54.yaml", "--creepage", "0:0.05",
            "-o", tmp_path / "o")
    assert r.exit_code == 2 and "--creepage" in error_lines(r)[0]


# ---------------------------------------------------------------------------------------
# model only what the scene needs
# ---------------------------------------------------------------------------------------
def test_full_film_skips_fastsim_and_says_so():
    sc = scene_from_dict(lubricated(kinematics={"speed": "5 m/s"},
                                    lubricant={"eta0": "0.5 Pa*s"}))
    p = mixed_traction_curve(sc, [0.001, 0.01])
    assert "mu_boundary" not in p.table and (p.table["load_share_asperity"] == 0).all()
    assert any("boundary friction: not modelled" in m for m in p.modelled)
    np.testing.assert_allclose(p.table["mu"], p.table["mu_ehl"])


def test_smooth_scene_needs_no_boundary_section():
    sc = scene_from_dict(lubricated(roughness=None, boundary=None))
    p = predict_stribeck(sc, [0.1, 1.0], 0.02)
    assert (p.table["load_share_asperity"] == 0).all() and p.table["lambda"].isna().all()
    assert any("no roughness" in m for m in p.modelled)


def test_asperity_load_without_boundary_section_is_a_user_error():
    with pytest.raises(TorlabError, match="boundary"):
        predict_traction(scene_from_dict(lubricated(boundary=None)), [0.01])


def test_dry_scene_without_boundary_is_a_user_error():
    d = lubricated(lubricant=None, roughness=None, boundary=None)
    with pytest.raises(TorlabError, match="boundary"):
        predict_traction(scene_from_dict(d), [0.01])


# ---------------------------------------------------------------------------------------
# limits of the mixed model
# ---------------------------------------------------------------------------------------
def test_speed_zero_all_load_on_asperities_mu_equals_boundary():
    sc = scene_from_dict(lubricated())
    p = predict_stribeck(sc, [0.0], 0.02)
    row = p.table.iloc[0]
    assert row["load_share_asperity"] == 1.0 and row["regime"] == "boundary"
    assert row["mu"] == pytest.approx(row["mu_boundary"], rel=1e-12)


def test_speed_to_zero_mu_tends_to_boundary_when_asperities_can_carry_the_load():
    # a rough surface whose asperities alone carry the load above the mean plane (h* > 0)
    sc = scene_from_dict(lubricated(roughness={"sigma": "0.1 um", "beta": "100 um",
                                               "density": "20000 mm^-2", "hardness": "6 GPa"},
                                    lubricant={"eta0": "0.1 Pa*s"}))
    p = predict_stribeck(sc, [1e-6, 1e-3, 1e-2, 0.1, 1.0], 0.02)
    assert p.summary["h_star_m"] > 0
    share = p.table["load_share_asperity"].to_numpy()
    assert share[0] > 0.9999 and share[-1] < 0.5 and np.all(np.diff(share) <= 0)
    mu_b = p.table["mu_boundary"].iloc[0]
    assert p.table["mu"].iloc[0] == pytest.approx(mu_b, rel=2e-3)


def test_large_speed_mu_tends_to_film():
    sc = scene_from_dict(lubricated())
    p = predict_stribeck(sc, [1.0, 50.0, 100.0], 0.02)
    assert p.table["load_share_asperity"].iloc[-1] == 0.0
    assert p.table["regime"].iloc[-1] == "full_film"
    assert p.table["mu"].iloc[-1] == pytest.approx(p.table["mu_ehl"].iloc[-1], rel=1e-12)


def test_smoother_surface_lowers_the_asperity_share():
    rough = predict_stribeck(load_scene(SCENES / "optical_paper_a_rough.yaml"), [0.1, 0.5], 0.05)
    smooth = predict_stribeck(load_scene(SCENES / "optical_paper_a_smooth.yaml"), [0.1, 0.5], 0.05)
    assert np.all(smooth.table["load_share_asperity"] < rough.table["load_share_asperity"])


def test_mixed_is_the_load_weighted_mean():
    sc = scene_from_dict(lubricated())
    p = mixed_traction_curve(sc, [-0.01, 0.0, 0.004, 0.03])
    t = p.table
    s = t["load_share_asperity"]
    np.testing.assert_allclose(t["mu"], s * t["mu_boundary"] + (1 - s) * t["mu_ehl"], rtol=1e-12)
    assert t["mu"].iloc[1] == 0.0 and t["mu"].iloc[0] < 0


def test_thermal_mixed_scene_reports_temperature():
    sc = scene_from_dict(lubricated(thermal={"conductivity": 50},
                                    boundary={"mu_c1_T": -1e-3, "mu_c2_T": -1e-3}))
    p = mixed_traction_curve(sc, [0.001, 0.02])
    assert "max_temperature_C" in p.table and (p.table["max_temperature_C"] > 20).all()
    cold = mixed_traction_curve(scene_from_dict(lubricated()), [0.001, 0.02])
    assert np.all(p.table["mu"] <= cold.table["mu"] + 1e-12)


def test_newtonian_film_with_barus_gets_a_plausibility_note():
    sc = scene_from_dict(lubricated(lubricant={"eta0": "0.1 Pa*s", "viscosity": "barus",
                                               "alpha": "25 1/GPa"},
                                    contact={"load": "200 N"}, kinematics={"speed": "2 m/s"}))
    try:
        p = mixed_traction_curve(sc, [0.0, 0.05])
    except NumericalError as e:  # overflow is a named error
        assert "limiting" in str(e)
    else:
        assert any("not physical" in n for n in p.summary["notes"])


# ---------------------------------------------------------------------------------------
# hard-case sweep
# ---------------------------------------------------------------------------------------
SPEEDS = [0.0, 1e-4, 0.01, 1.0, 10.0, 100.0]
LAWS = [
    ({"viscosity": "iso"}, {"shear": "newtonian"}),
    ({"viscosity": "barus", "alpha": "20 1/GPa"}, {"shear": "limiting", "gamma_L": 0.07}),
    ({"viscosity": "roelands", "Z": 0.6, "alpha": "15 1/GPa"}, {"shear": "eyring",
                                                                "tau0": "5 MPa"}),
    ({"viscosity": "barus", "alpha": "20 1/GPa"}, {"shear": "newtonian"}),
    ({"viscosity": "roelands", "Z": 0.6}, {"shear": "limiting", "gamma_L": 0.07}),
    ({"viscosity": "iso"}, {"shear": "eyring", "tau0": "5 MPa"}),
]


@pytest.mark.parametrize("visc, shear", LAWS)
def test_hard_case_sweep(visc, shear):
    """Speed 0-100 m/s, sigma 1 nm-1 um, load 1 N-100 kN, eta0 1e-4-10 Pa s: finite
    results everywhere, no warnings, or a named torlab error."""
    outcomes = {"ok": 0, "named error": 0}
    for sigma, load, eta0 in itertools.product(["1 nm", "30 nm", "1 um"], ["1 N", "1 kN", "100 kN"],
                                               [1e-4, 0.01, 10.0]):
        d = lubricated(lubricant={"eta0": eta0, **visc, **shear},
                       roughness={"sigma": sigma}, contact={"load": load})
        sc = scene_from_dict(d)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                p = predict_stribeck(sc, SPEEDS, 0.05)
                t = mixed_traction_curve(sc, [-0.05, 0.0, 1e-4, 0.05])
            except TorlabError:
                outcomes["named error"] += 1
                continue
        num = p.table.drop(columns=["regime", "lambda", "mu_ehl", "mu_boundary"])
        assert np.isfinite(num.to_numpy(dtype=float)).all(), (sigma, load, eta0)
        assert np.isfinite(t.table.to_numpy(dtype=float)).all()
        assert ((p.table["load_share_asperity"] >= 0) & (p.table["load_share_asperity"] <= 1)).all()
        outcomes["ok"] += 1
    assert outcomes["ok"] >= 9  # most of the grid is physical for every law


# ---------------------------------------------------------------------------------------
# trend after saturation (thesis H4.1)
# ---------------------------------------------------------------------------------------
def test_classify_trend_on_analytic_curves():
    x = np.linspace(0, 0.05, 101)
    base = np.tanh(x / 0.004)
    assert classify_trend(x, 0.3 * base * (1 - 2 * x))["trend"] == "negative"
    assert classify_trend(x, 0.3 * base)["trend"] == "neutral"
    assert classify_trend(x, 0.3 * base * (1 + 2 * x))["trend"] == "positive"
    assert classify_trend(x, 2 * x)["trend"] == "not saturated in this range"
    assert classify_trend(-x, -0.3 * base * (1 - 2 * x))["trend"] == "negative"



def test_an_isothermal_layer_still_rising_is_not_saturated_not_positive():
    """Without a temperature effect the layer's curve only rises towards mu_c2 (Eqs. 5.26-5.29
    with mu_ci_T unused): a 30 um Voce length on the Tab. 5.4 contact still rises by several
    per cent after 2.5 % creepage.  The band makes that rise near certain; it is the curve
    not having saturated in this range, not a positive characteristic (H4.1).  One creepage
    has too few points for any trend."""
    import torlab
    from torlab.fit.result import FitResult

    names = ("mu_c1", "mu_c2", "L_mue", "L_mup")
    v = np.array([0.14, 0.23, 8e-6, 30e-6])
    fit = FitResult.from_covariance("layer_hpt", names, v, np.diag((0.05 * v) ** 2), dof=30,
                                    log_scale=names, residual_norm=1.0, n_points=100,
                                    warnings=[], data=None)
    scene = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
    p = torlab.predict_traction(scene, "0:5 %:51", params=fit)
    t = p.trend
    assert t["probabilities"]["positive"] > 0.9  # the rise itself is near certain
    assert t["trend"] == t["trend_point"] == "not saturated in this range"
    assert t["rises_only"] and "isothermal" in t["note"]
    raw = classify_trend(p.table["creepage"].to_numpy(), p.table["mu"].to_numpy(),
                         uncertainty=p.band)
    assert raw["trend"] == "positive"  # what the curve alone would be called
    # the report says so, with the probabilities, and does not call it positive
    from types import SimpleNamespace

    from torlab.reports.traction import TractionCurve, traction_section

    sec = traction_section([TractionCurve("OFM1", "model", p.table, t, "scene",
                                          band=p.summary["band"])],
                           SimpleNamespace(trend_tolerance=0.01))
    words = " ".join(sec.paragraphs)
    assert "OFM1 (model)" in words and "not saturated in this range (still rising: " \
        "negative 0.00" in words and "trend after saturation positive" not in words
    assert torlab.predict_traction(scene, [0.01]).trend["trend"] == "too few points"
    assert classify_trend(np.array([0.0, 0.01]), np.array([0.0, 0.2]))["trend"] == \
        "too few points"


def _rising_tab54(**update):
    """The Tab. 5.4 contact, isothermal, with a 30 um Voce length: still rising after 2.5 %."""
    scene = load_scene(ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml")
    b = scene.boundary.model_copy(update={"mu_c1": 0.14, "mu_c2": 0.23, "L_mue": 8e-6,
                                          "L_mup": 30e-6, **update})
    return scene, scene.model_copy(update={"boundary": b, "thermal": None})


def test_every_models_curve_classifies_its_trend_with_the_same_rule():
    """The dry traction curve and the creep forces (FASTSIM in three creepages) call one
    classification (torlab.model.prediction.scene_trend): the Tab. 5.4 contact with a 30 um
    Voce length still rises after saturation in both, and both say 'not saturated in this
    range' (an isothermal hardening layer), not 'positive'.  With a softening layer
    (mu_c1 > mu_c2) or a temperature effect the rule does not apply; a lubricated scene's
    film can make the curve rise."""
    from torlab.model.creep import predict_creep
    from torlab.model.prediction import rises_only
    from torlab.model.traction import traction_curve

    scene, sc = _rising_tab54()
    xi = np.linspace(0.0, 0.05, 11)
    for how, pred in (("dry", traction_curve(sc, xi)), ("creep", predict_creep(sc, xi))):
        t = pred.trend
        raw = classify_trend(pred.table["creepage"].to_numpy(), pred.table["mu"].to_numpy())
        assert raw["trend"] == "positive", how  # the curve alone rises
        assert t["trend"] == "not saturated in this range" and t["rises_only"], how
    b = sc.boundary
    assert rises_only(sc)
    assert not rises_only(_rising_tab54(mu_c1=0.25)[1])  # softening: a peak, then a fall
    hot = scene.model_copy(update={"boundary": b.model_copy(update={"mu_c2_T": -1e-3})})
    assert not rises_only(hot)  # thermal: the heating can make it rise or fall
    assert rises_only(hot, temperature=False)  # a model without the temperature
    assert not rises_only(load_scene(ROOT / "protocols" / "scenes" /
                                     "optical_paper_a_rough.yaml"))


@pytest.mark.slow  # the exact solver along a curve (3 s); the same rule, quick: the test above
def test_the_exact_solvers_curve_classifies_its_trend_with_the_same_rule():
    """predict_exact on a layer without temperature coefficients (its thermal: section
    computes the temperature but cannot change the limits) applies the isothermal rule; a
    softening layer does not."""
    from torlab.model.exact.scene import ExactGrid, predict_exact

    xi = np.linspace(0.0, 0.05, 11)
    scene, _ = _rising_tab54()
    t = predict_exact(scene, xi, grid=ExactGrid(n=8)).trend  # with its thermal: section
    assert t["rises_only"] and "isothermal" in t["note"] and t["trend"] != "positive"
    t = predict_exact(_rising_tab54(mu_c1=0.25)[1], xi, grid=ExactGrid(n=8)).trend
    assert not t.get("rises_only")


def test_classify_trend_sparse_and_folded_curves():
    # measured SRR steps of an optical traction test: flat tanh plateau, one point in the tail
    srr = np.array([0.005, 0.01, 0.02, 0.03, 0.05, 0.1])
    flat = 0.25 * np.tanh(srr / 0.01)
    assert classify_trend(srr, flat)["trend"] == "too few points"
    # +/- SRR of the same flat curve fold onto one point each: neutral, not tilted by the knee
    x = np.linspace(0.001, 0.1, 40)
    both = np.r_[-x, x]
    t = classify_trend(both, 0.25 * np.tanh(both / 0.01))
    assert t["trend"] == "neutral"
    assert abs(t["relative_change"]) < 0.01
    falling = np.r_[-x, x], 0.25 * np.tanh(np.r_[-x, x] / 0.01) * (1 - 2 * np.abs(np.r_[-x, x]))
    assert classify_trend(*falling)["trend"] == "negative"


def test_several_parameter_files_give_one_labelled_curve_each(cli, tmp_path):
    """Two layer fits (the same scene keys) are alternatives: one curve each, with its band,
    in one long CSV and one figure; a temperature fit beside them applies to both; a label
    given as LABEL=FILE names its curve."""
    from torlab.fit.result import FitResult

    names = ("mu_c1", "mu_c2", "L_mue", "L_mup")
    for tag, mu in (("a", 0.20), ("b", 0.26)):
        v = np.array([0.6 * mu, mu, 6e-6, 12e-6])
        FitResult.from_covariance("layer_hpt", names, v, np.diag((0.03 * v) ** 2), dof=20,
                                  log_scale=names, residual_norm=1.0, n_points=100,
                                  warnings=[], data=None, meta={"product": f"P{tag}"}
                                  ).to_params(tmp_path / f"{tag}.yaml")
    (tmp_path / "t.yaml").write_text("boundary:\n  mu_c1_T: -0.0005\n  mu_c2_T: -0.0005\n")
    scene = SCENES / "optical_paper_a_dry.yaml"
    r = cli("predict", "traction", scene, tmp_path / "a.yaml", f"second={tmp_path / 'b.yaml'}",
            tmp_path / "t.yaml", "--creepage", "0:4 %:9", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "o" / "traction.csv")
    assert list(t.columns[:3]) == ["curve", "creepage", "mu"]
    assert set(t["curve"]) == {"Pa", "second"} and "mu_low95" in t
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert set(s["curves"]) == {"Pa", "second"}
    for c in s["curves"].values():  # the temperature file applies to both
        assert c["boundary"]["mu_c2_T"] == -0.0005 and c["band"]["method"] != "not computed"
    hi = t[t["curve"] == "second"]["mu"].max()
    assert hi > t[t["curve"] == "Pa"]["mu"].max()
    assert (tmp_path / "o" / "traction.png").is_file() and "(2 curves)" in r.output
    # one file after the scene: one curve, as before (no curve column)
    r = cli("predict", "traction", scene, tmp_path / "a.yaml", "--creepage", "0:4 %:9",
            "-o", tmp_path / "one", "--no-plot")
    assert r.exit_code == 0 and "curve" not in pd.read_csv(tmp_path / "one" / "traction.csv")


@pytest.mark.slow  # two lubricated curves with bands (several s); the overlay: the traction test
def test_stribeck_curves_of_two_parameter_sets(cli, tmp_path):
    from torlab.fit.result import FitResult

    names = ("mu_c1", "mu_c2", "L_mue", "L_mup")
    for tag, mu in (("a", 0.20), ("b", 0.26)):
        v = np.array([0.6 * mu, mu, 6e-6, 12e-6])
        FitResult.from_covariance("layer_hpt", names, v, np.diag((0.03 * v) ** 2), dof=20,
                                  log_scale=names, residual_norm=1.0, n_points=100,
                                  warnings=[], data=None).to_params(tmp_path / f"{tag}.yaml")
    r = cli("predict", "stribeck", SCENES / "optical_paper_a_rough.yaml",
            f"A={tmp_path / 'a.yaml'}", f"B={tmp_path / 'b.yaml'}", "--speed", "0.05:1:4", "-o",
            tmp_path / "o", "--no-plot")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "o" / "stribeck.csv")
    assert list(t.columns[:2]) == ["curve", "speed_m_s"] and set(t["curve"]) == {"A", "B"}
    assert "mu_low95" in t and len(t) == 8
    a, b = (t[t["curve"] == k]["mu"].to_numpy() for k in "AB")
    assert np.all(b >= a)  # the stronger layer carries more where the asperities touch


def test_lubricated_thermal_scene_without_temperature_coefficients():
    # a rough lubricated scene with thermal: but temperature coefficients of zero: the
    # heating cannot change the layer's limits, so the contact temperature is computed once
    # and the traction is the one of the same scene without thermal:
    sc = load_scene(SCENES / "optical_paper_a_rough.yaml")
    d = sc.model_dump(exclude_none=True)
    cold = mixed_traction_curve(scene_from_dict(d), [0.001, 0.01, 0.03])
    hot = mixed_traction_curve(scene_from_dict({**d, "thermal": {}}), [0.001, 0.01, 0.03])
    assert "contact temperature: computed once, no tau-T loop (the temperature coefficients " \
        "are zero)" in hot.modelled
    assert np.array_equal(hot.table["mu"].to_numpy(), cold.table["mu"].to_numpy())
    assert np.all(hot.table["max_temperature_C"] > sc.kinematics.ambient_temperature)


def test_the_long_table_holds_every_curves_points_under_its_label():
    """``curves.csv``: ``curve`` and ``kind`` first, then every column of the curves' tables
    in the order they first appear; a column a curve lacks is empty there, one empty in
    every curve is left out, and each curve's points are its table's, in order."""
    from types import SimpleNamespace

    import pandas as pd

    from torlab.reports.traction import TractionCurve, traction_section

    xi = np.linspace(0.001, 0.03, 12)
    mu = 0.3 * np.tanh(80 * xi)
    model = pd.DataFrame({"creepage": xi, "mu": mu, "mu_low95": 0.97 * mu,
                          "mu_high95": 1.03 * mu, "unused": np.nan})
    measured = pd.DataFrame({"creepage": xi[::2], "mu": 0.9 * mu[::2], "speed_m_s": 0.5,
                             "unused": np.nan})
    trend = {"trend": "neutral", "trend_from_creepage": None}
    curves = [TractionCurve("A", "model", model, trend, "s"),
              TractionCurve("B", "measured", measured, trend, "m"),
              TractionCurve("C", "model", model.iloc[:5], trend, "s")]
    sec = traction_section(curves, SimpleNamespace(trend_tolerance=0.01))
    long = next(t for t in sec.tables if t.name == "curves").df
    assert list(long.columns) == ["curve", "kind", "creepage", "mu", "mu_low95", "mu_high95",
                                  "speed_m_s"]
    assert long["curve"].tolist() == ["A"] * 12 + ["B"] * 6 + ["C"] * 5
    assert long["kind"].tolist() == ["model"] * 12 + ["measured"] * 6 + ["model"] * 5
    for label, t in (("A", model), ("B", measured), ("C", model.iloc[:5])):
        part = long[long["curve"] == label].reset_index(drop=True)
        for col in long.columns[2:]:
            want = t[col].to_numpy(dtype=float) if col in t else np.full(len(t), np.nan)
            assert np.array_equal(part[col].to_numpy(dtype=float), want, equal_nan=True), col
    assert str(long["curve"].dtype) == str(pd.Series(["A"]).dtype)  # text, as a label column
