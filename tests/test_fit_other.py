"""Film, temperature-coefficient and viscosity fits, and the torlab fit commands."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from conftest import REAL_PCS, ROOT

from torlab.errors import TorlabInputError
from torlab.fit.film import fit_film_thickness
from torlab.fit.layer import fit_layer_hpt
from torlab.fit.result import viscosity_result
from torlab.fit.temperature import fit_temperature_coefficients
from torlab.fit.viscosity import fit_viscosity
from torlab.model.contact import build_contact
from torlab.model.ehl import hc_piezo
from torlab.model.layers import LayerParams
from torlab.parsers.hpt import read_hpt
from torlab.reduce.hpt import RigCompliance, reduce_hpt
from torlab.scene import load_scene
from torlab.synth.hpt import HptRig, HptRunSpec, rig_compliance_u, simulate_hpt, write_hpt_log
from torlab.yamlio import load_yaml

HPT = ROOT / "sample_data" / "hpt"
MTM = ROOT / "protocols" / "scenes" / "mtm_paper_b.yaml"


# --- film ------------------------------------------------------------------------------------
@pytest.mark.skipif(not (REAL_PCS / "demo_3.txt").exists(), reason="real PCS files absent")
def test_real_ehd2_speed_exponents():
    """Issue 6: demo_3.txt gives log-log slopes near 0.64 (40 C) and 0.71 (100 C) above 50 mm/s."""
    from torlab.parsers.pcs import read_pcs
    from torlab.reduce.optical import reduce_ehd2

    df, meta = read_pcs(REAL_PCS / "demo_3.txt")
    pts = reduce_ehd2(df, meta).points
    got = {}
    for _, g in pts.groupby("step"):
        res = fit_film_thickness(g["rolling_speed_m_s"], g["film_thickness_m"], min_speed=0.05)
        got[round(float(g["lube_temperature_C"].mean()), -1)] = res.params["speed_exponent"]
    assert got[40.0] == pytest.approx(0.64, abs=0.01)
    assert got[100.0] == pytest.approx(0.71, abs=0.01)


def test_effective_alpha_recovered_from_hamrock_dowson_films():
    """Films generated with Hamrock-Dowson at alpha = 18 1/GPa, 3 % log-normal scatter."""
    sc = load_scene(MTM)
    c = build_contact(sc)
    v = np.geomspace(0.05, 2.0, 20)
    h = hc_piezo(v, sc.contact.load, c.E_star, c.rx, sc.lubricant.eta0, 18e-9, c.patch.b / c.patch.a)
    rng = np.random.default_rng(1)
    res = fit_film_thickness(v, h * np.exp(0.03 * rng.standard_normal(v.size)), scene=sc)
    lo, hi = res.ci95["alpha"]
    assert lo <= 18e-9 <= hi and hi - lo < 5e-9
    assert res.ci95["speed_exponent"][0] <= 0.67 <= res.ci95["speed_exponent"][1]
    assert res.to_scene_dict() == {"lubricant": {"alpha": res.params["alpha"]}}


def test_film_bad_data():
    with pytest.raises(TorlabInputError, match="too few"):
        fit_film_thickness([0.1, 0.2], [1e-8, 2e-8])
    with pytest.raises(TorlabInputError, match="constant"):
        fit_film_thickness([0.1, 0.2, 0.4], [1e-8, 1e-8, 1e-8])
    with pytest.raises(TorlabInputError, match="positive"):
        fit_film_thickness([0.1, 0.2, 0.4], [1e-8, 0.0, 2e-8])


# --- temperature -----------------------------------------------------------------------------
def _hpt_fit(params, T, seed):
    rig = HptRig()
    tg = np.linspace(0, 1e9, 2001)
    comp = RigCompliance(tg, rig_compliance_u(tg, rig), "true")
    spec = HptRunSpec("v", "dry", None, T, params, u_max=200e-6, seed=seed)
    df, meta = read_hpt(io.StringIO(write_hpt_log(spec, simulate_hpt(spec, rig), rig)), name="v")
    return fit_layer_hpt(reduce_hpt(df, meta, compliance=comp))


def test_temperature_coefficients_end_to_end():
    """HPT runs at 25-105 C with the dry reference's coefficients (-0.0025, -0.0035 1/K) and 3 %
    run-to-run scatter of the limits (the sample-data design): one draw with 3 residual degrees
    of freedom, so the truth is checked against the 99.9 % Student-t interval and the sign
    (95 % coverage: the next test)."""
    from torlab.fit.result import student_t

    rng = np.random.default_rng(5)
    fits = []
    for i, T in enumerate((25.0, 45.0, 65.0, 85.0, 105.0)):
        s = 1 + 0.03 * rng.standard_normal()
        p = LayerParams(0.31 * s, 0.50 * s, 5e-6, 40e-6, -0.0025, -0.0035)
        fits.append(_hpt_fit(p, T, 100 + i))
    res = fit_temperature_coefficients(fits)
    for k, v in (("mu_c1_T", -0.0025), ("mu_c2_T", -0.0035)):
        tq = student_t(res.dof, 0.999)
        assert abs(res.params[k] - v) < tq * res.stderr[k], (k, res.params[k], res.stderr[k])
        assert res.ci95[k][1] < 0  # the sign is determined
    assert set(res.to_scene_dict()["boundary"]) == {"mu_c1_T", "mu_c2_T"}


def test_temperature_interval_coverage():
    """ln mu(T) with 3 % scatter at 4 temperatures, 400 draws: coverage in 91-98.5 %."""
    from torlab.fit.result import FitResult

    T = np.array([25.0, 50.0, 80.0, 110.0])
    rng = np.random.default_rng(7)
    hits = 0
    n = 400
    for _ in range(n):
        mu = 0.2 * np.exp(-0.002 * (T - 25)) * np.exp(0.03 * rng.standard_normal(T.size))
        fits = [FitResult("layer_hpt", ("mu_c1", "mu_c2"), {"mu_c1": m, "mu_c2": m},
                          {}, {}, np.eye(2), 0.0, 1, [], None) for m in mu]
        res = fit_temperature_coefficients(fits, temperatures_K=T + 273.15, selection="none")
        hits += res.ci95["mu_c2_T"][0] <= -0.002 <= res.ci95["mu_c2_T"][1]
    assert 0.91 <= hits / n <= 0.985


def test_temperature_needs_three_temperatures():
    f = _hpt_fit(LayerParams(0.3, 0.5, 5e-6, 40e-6), 25.0, 1)
    with pytest.raises(TorlabInputError, match="three or more"):
        fit_temperature_coefficients([f, f], temperatures_K=[298.15, 323.15])


# --- viscosity -------------------------------------------------------------------------------
def test_viscosity_adapter_writes_lubricant_keys_and_warns_on_low_pressure():
    p = np.linspace(0.1e6, 80e6, 9)
    eta = 0.065 * np.exp(15e-9 * p) * np.exp(0.01 * np.random.default_rng(2).standard_normal(9))
    res = viscosity_result(fit_viscosity(p, eta, "roelands", fit_eta0=True))
    d = res.to_scene_dict()["lubricant"]
    assert d["viscosity"] == "roelands" and {"eta0", "Z", "alpha"} <= set(d)
    assert any("Z is poorly determined" in w for w in res.warnings)
    b = viscosity_result(fit_viscosity(p, eta, "barus"))
    assert b.ci95["alpha"][0] <= 15e-9 <= b.ci95["alpha"][1]


# --- CLI -------------------------------------------------------------------------------------
def test_cli_fit_hpt_then_predict(cli, tmp_path):
    out = tmp_path / "fit"
    r = cli("fit", "hpt", HPT / "hpt_OFM1_4uL_25C.txt", "--compliance", HPT / "rig_compliance.csv",
            "-o", out)
    assert r.exit_code == 0, r.output
    for f in ("params.yaml", "fit_table.csv", "correlation.csv", "fit_data.csv", "fit.png",
              "summary.json"):
        assert (out / f).exists(), f
    pr = cli("predict", "traction", ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml",
             out / "params.yaml", "--creepage", "0:0.02:5", "-o", tmp_path / "pred")
    assert pr.exit_code == 0, pr.output
    sc = load_scene(ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml", out / "params.yaml")
    import pandas as pd

    tab = pd.read_csv(out / "fit_table.csv").set_index("parameter")
    assert sc.boundary.mu_c2 == pytest.approx(tab.loc["mu_c2", "value"], rel=1e-9)


def test_cli_failed_fit_writes_nothing(cli, tmp_path):
    bad = tmp_path / "few.csv"
    bad.write_text("displacement_raw_m,displacement_m,shear_stress_Pa,normal_stress_Pa\n"
                   + "".join(f"{i * 1e-6},{i * 1e-6},{i * 1e7},7.5e8\n" for i in range(5)))
    r = cli("fit", "hpt", bad, "-o", tmp_path / "out")
    assert r.exit_code == 2
    assert "too few points" in r.output
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not (REAL_PCS / "demo_3.txt").exists(), reason="real PCS files absent")
def test_cli_fit_film_ehd2(cli, tmp_path):
    r = cli("fit", "film", REAL_PCS / "demo_3.txt", "--min-speed", "50 mm/s", "-o", tmp_path / "f")
    assert r.exit_code == 0, r.output
    # one fit per film step, named by the step's temperature (README: 40.2 °C and 100.7 °C),
    # and the temperature scaling of the two
    assert sorted(p.parent.name for p in (tmp_path / "f").glob("*/params.yaml")) == \
        ["100.7C", "40.2C", "temperature"]


OPT = ROOT / "sample_data" / "optical"
VISC = ROOT / "sample_data" / "visc"


@pytest.mark.slow  # fit traction then predict as commands: also tests/test_bands.py; the plateau: test_fit_traction.py
def test_cli_fit_traction_dry_feeds_predict(cli, tmp_path):
    # the dry optical log is generated from the model with a known layer (truth.yaml): the
    # fitted layer, fed to predict, must reproduce the true plateau and the slope near zero
    from torlab.model.traction import traction_curve

    scene = ROOT / "protocols" / "scenes" / "optical_paper_a_dry.yaml"
    layer = load_yaml(OPT / "truth.yaml").data["layer"]
    sc = load_scene(scene)
    true_mu = traction_curve(sc.model_copy(update={"boundary": sc.boundary.model_copy(
        update=layer)}), np.array([0.002, 0.1])).table["mu"].to_numpy()
    out = tmp_path / "fit"
    r = cli("fit", "traction", scene, OPT / "dry_traction_rough.csv", "-o", out)
    assert r.exit_code == 0, r.output
    for f in ("params.yaml", "fit_table.csv", "fit.png", "summary.json"):
        assert (out / f).exists(), f
    pr = cli("predict", "traction", scene, out / "params.yaml", "--creepage", "0.002,0.1",
             "-o", tmp_path / "pred")
    assert pr.exit_code == 0, pr.output
    import pandas as pd

    mu = pd.read_csv(tmp_path / "pred" / "traction.csv")["mu"].to_numpy()
    assert mu[1] == pytest.approx(true_mu[1], abs=0.003)
    assert mu[0] == pytest.approx(true_mu[0], abs=0.01)


def test_cli_fit_visc_from_reduced_output(cli, tmp_path):
    red = tmp_path / "red"
    r = cli("visc", "reduce", VISC / "visc_ester_25C.txt", "--reference",
            VISC / "visc_reference_25C.txt", "-o", red)
    assert r.exit_code == 0, r.output
    steps = next(red.glob("visc_ester_25C*_steps.csv"))
    out = tmp_path / "fit"
    r = cli("fit", "visc", steps, "--law", "roelands", "-o", out)
    assert r.exit_code == 0, r.output
    import pandas as pd

    tab = pd.read_csv(out / "fit_table.csv").set_index("parameter")
    lo, hi = tab.loc["Z", "ci95_low"], tab.loc["Z", "ci95_high"]
    assert lo <= 0.42 <= hi  # sample_data/visc/truth.yaml: Z = 0.42


def test_cli_fit_temperature_runs_and_reports_uncertainty(cli, tmp_path):
    logs = [HPT / f"hpt_OFM1_4uL_{t}C.txt" for t in (25, 65, 105)]
    out = tmp_path / "fit"
    r = cli("fit", "temperature", *logs, "--compliance", HPT / "rig_compliance.csv", "-o", out)
    assert r.exit_code == 0, r.output
    import pandas as pd

    tab = pd.read_csv(out / "fit_table.csv").set_index("parameter")
    assert {"mu_c1_T", "mu_c2_T"} <= set(tab.index)
    # truth (sample_data/hpt/truth.yaml, OFM1): mu_c1_T = -4e-4, mu_c2_T = -3e-4 1/K; three
    # temperatures with this run-to-run scatter cannot resolve them, and the fit must say so:
    # the likelihood-ratio test fixes them to 0 in params.yaml, the full model's interval
    # (which holds the truth) is in the summary, and the output names the decision
    import json

    sel = json.loads((out / "summary.json").read_text())["meta"]["model_selection"]
    for name, truth in (("mu_c1_T", -4e-4), ("mu_c2_T", -3e-4)):
        lo, hi = sel[name]["ci95_full_model"]
        assert lo <= truth <= hi
        assert lo < 0 < hi
        assert sel[name]["decision"] == "fixed to 0" and sel[name]["p_value"] >= 0.05
        assert tab.loc[name, "status"] == "fixed" and tab.loc[name, "value"] == 0.0
    assert "not resolved" in r.output and "fixed to 0" in r.output
    assert load_yaml(out / "params.yaml").data["boundary"] == {"mu_c1_T": 0.0, "mu_c2_T": 0.0}
    # --selection none keeps both with their whole uncertainty, in the covariance predictions use
    r = cli("fit", "temperature", *logs, "--compliance", HPT / "rig_compliance.csv",
            "--selection", "none", "-o", tmp_path / "none")
    assert r.exit_code == 0, r.output
    d = load_yaml(tmp_path / "none" / "params.yaml").data
    assert set(d["boundary"]) == {"mu_c1_T", "mu_c2_T"} and d["boundary"]["mu_c2_T"] != 0.0
    cov = d["fit"]["covariance"]
    assert {"mu_c1_T", "mu_c2_T"} <= set(cov["names"]) and d["fit"]["fixed"] == {}
    i = cov["names"].index("mu_c2_T")
    assert math.sqrt(cov["matrix"][i][i]) == pytest.approx(
        d["fit"]["parameters"]["mu_c2_T"]["stderr"], rel=1e-9)
    assert "kept, and its uncertainty is carried into predictions" in r.output
    r = cli("fit", "temperature", *logs, "--selection", "lr2", "-o", tmp_path / "bad")
    assert r.exit_code == 2 and "--selection" in r.output


@pytest.mark.slow  # 14 runs; the command: above
def test_cli_fit_temperature_resolves_with_the_campaign(cli, tmp_path):
    """The shipped Paper C design (14 runs at 25-185 degC) resolves OFM1's mu_c1_T (truth
    -4e-4 1/K, sample_data/hpt/truth.yaml): the test keeps it and its interval holds the truth."""
    logs = sorted(HPT.glob("hpt_OFM1_4uL_*C*.txt"))
    assert len(logs) == 14
    out = tmp_path / "fit"
    r = cli("fit", "temperature", *logs, "--compliance", HPT / "rig_compliance.csv", "-o", out)
    assert r.exit_code == 0, r.output
    import json

    sm = json.loads((out / "summary.json").read_text())
    sel = sm["meta"]["model_selection"]["mu_c1_T"]
    assert sel["decision"] == "kept" and sel["p_value"] < 0.05
    lo, hi = sm["ci95"]["mu_c1_T"]
    assert lo <= -4e-4 <= hi < 0
