"""The boundary method of a prediction, a table and a fit (--method fastsim|fastsim-kalker|
exact|auto) and its theory error, stated apart from the band."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.conftest import ROOT
from torlab.errors import TorlabInputError
from torlab.model.predict import predict_creep, predict_traction, with_method
from torlab.scene import load_scene, scene_from_dict
from torlab.yamlio import dump_yaml

SCENES = ROOT / "protocols" / "scenes"
XI = np.array([0.0005, 0.002, 0.006, 0.02])


def wheel_rail(**grid) -> object:
    """The Tab. 5.4 wheel-rail scene without its thermal section, by the default method
    (the protocol's scene file asks for the thesis's FASTSIM)."""
    d = load_scene(SCENES / "wheel_rail_tab54.yaml").model_dump(exclude_none=True)
    d.pop("thermal", None)
    d["grid"] = {"exact_n": 10, **grid}
    return scene_from_dict(d)


def test_default_method_is_fastsim_corrected_and_says_so():
    sc = wheel_rail()
    assert sc.grid.method == "fastsim"
    pred = predict_traction(sc, XI)
    s = pred.summary
    assert s["method"]["method"] == "fastsim"
    assert any("corrected by Kalker's exact theory" in m for m in pred.modelled)
    te = s["theory_error"]
    assert te["method"] == "fastsim" and 0 < te["theory_error_95"] < 0.05
    assert "mu_theory_error_95" in pred.table
    # the band is a separate figure: no covariance here, so no band, and the theory
    # error is not in it
    assert s["band"]["method"] == "not computed"


def test_methods_interpolate_kalkers_table_their_own_way():
    """Kalker's FASTSIM keeps CONTACT's linear interpolation of Kalker's table (the thesis's
    model); the default's FASTSIM base, on which its tables are built, the monotone cubic of
    ln C over ln g, in L1 and in the creep problem's L2, L3 (docs/model/kalker.md)."""
    from torlab.model.contact import build_contact
    from torlab.model.creep import creep_problem
    from torlab.model.kalker import L1, L2, L3, creepage_coefficients

    d = wheel_rail().model_dump(exclude_none=True)
    d["contact"] = {**d["contact"], "a": 8.4e-3, "b": 2e-3}  # a/b 4.2: b/a between rows
    for method, how in (("fastsim", "log-pchip"), ("fastsim-kalker", "linear")):
        sc = scene_from_dict({**d, "grid": {**d["grid"], "method": method}})
        con = build_contact(sc)
        c11, c22, c23 = creepage_coefficients(4.2, con.nu, interpolation=how)
        prob = creep_problem(sc, con)
        assert con.C11 == pytest.approx(c11, rel=1e-12)
        assert prob.L1 == pytest.approx(L1(8.4e-3, c11, con.G), rel=1e-12)
        assert prob.L2 == pytest.approx(L2(8.4e-3, c22, con.G), rel=1e-12)
        assert prob.L3 == pytest.approx(L3(8.4e-3, 2e-3, c23, con.G), rel=1e-12)
        assert prob.calibrated == (method == "fastsim")


def test_thesis_fastsim_differs_and_its_theory_error_is_the_correction():
    sc = wheel_rail()
    cal = predict_traction(sc, XI)
    plain = predict_traction(sc, XI, method="fastsim-kalker")
    mu_c, mu_p = cal.table["mu"].to_numpy(), plain.table["mu"].to_numpy()
    diff = np.abs(mu_c - mu_p)
    assert diff.max() > 0.003  # the layer's linear regime alone: several per cent
    e = plain.table["mu_theory_error_95"].to_numpy()
    assert np.all(e >= diff * 0.999)
    assert plain.summary["method"]["method"] == "fastsim-kalker"
    assert plain.summary["theory_error"]["theory_error_95"] > cal.summary["theory_error"][
        "theory_error_95"]


def test_exact_method_is_the_exact_solver_with_its_discretisation_error():
    sc = wheel_rail()
    pred = predict_traction(sc, XI[:3], method="exact")
    assert pred.summary["method"]["method"] == "exact"
    assert any("exact theory" in m for m in pred.modelled)
    e = pred.table["mu_theory_error_95"].to_numpy()
    np.testing.assert_allclose(e, pred.table["mu_x_error"].to_numpy())
    # the exact theory and the corrected FASTSIM agree within their stated errors
    fast = predict_traction(sc, XI[:3])
    assert np.all(np.abs(pred.table["mu"].to_numpy() - fast.table["mu"].to_numpy())
                  <= e + fast.table["mu_theory_error_95"].to_numpy())


def test_auto_without_a_band_uses_the_exact_solver_and_says_why():
    pred = predict_traction(wheel_rail(method="auto"), XI[:3])
    m = pred.summary["method"]
    assert m["asked"] == "auto" and m["method"] == "exact"
    assert "no band" in m["why"]


def test_auto_keeps_fastsim_where_the_band_is_wider_than_its_theory_error():
    sc = wheel_rail(method="auto")
    b = sc.boundary
    names = ["mu_c1", "mu_c2", "L_mue", "L_mup"]
    vals = [getattr(b, n) for n in names]
    cov = np.diag((0.3 * np.array(vals)) ** 2)   # a wide band: 30 % on each parameter
    d = sc.model_dump(exclude_none=True)
    d["fit"] = {"kind": "test", "covariance": {"names": names, "values": vals,
                                               "matrix": cov.tolist()}}
    pred = predict_traction(scene_from_dict(d), XI)
    m = pred.summary["method"]
    assert m["method"] == "fastsim", m["why"]
    hw = 0.5 * (pred.table["mu_high95"] - pred.table["mu_low95"]).to_numpy()
    assert np.all(pred.table["mu_theory_error_95"].to_numpy() < hw)


def test_exact_method_of_a_lubricated_scene_is_a_user_error_and_auto_stays_fast():
    sc = load_scene(SCENES / "mtm_paper_b.yaml")
    with pytest.raises(TorlabInputError, match="dry contacts"):
        predict_traction(with_method(sc, "exact"), [0.01, 0.02])
    pred = predict_traction(with_method(sc, "auto"), [0.005, 0.01, 0.02])
    assert pred.summary["method"]["method"] == "fastsim"
    te = pred.summary["theory_error"]
    assert any("load share" in n or "carry no load" in n for n in te["notes"])


def test_unknown_method_is_one_clear_error():
    with pytest.raises(TorlabInputError, match="unknown boundary method 'fastsimm'"):
        with_method(wheel_rail(), "fastsimm")
    with pytest.raises(Exception, match="method"):
        scene_from_dict({**wheel_rail().model_dump(exclude_none=True),
                         "grid": {"method": "kalker"}})


def test_creep_forces_name_the_method_and_each_force_error():
    sc = wheel_rail()
    pred = predict_creep(sc, XI, 0.001, 2.0)
    for col in ("Fx_theory_error_95_N", "Fy_theory_error_95_N", "Mz_theory_error_95_Nm"):
        assert col in pred.table and np.all(np.asarray(pred.table[col]) > 0)
    assert pred.summary["method"]["method"] == "fastsim"
    plain = predict_creep(sc, XI, 0.001, 2.0, method="fastsim-kalker")
    assert not np.allclose(plain.table["Mz_Nm"], pred.table["Mz_Nm"])


def test_cli_predict_traction_method_in_console_csv_and_summary(cli, tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text(dump_yaml(wheel_rail().model_dump(exclude_none=True)))
    r = cli("predict", "traction", p, "--creepage", "0:0.01:6", "--method",
            "fastsim-kalker", "--no-plot", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    assert "boundary method: fastsim-kalker" in r.output
    assert "theory error (95 %" in r.output and "not in the band" in r.output
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["method"]["method"] == "fastsim-kalker"
    assert s["theory_error"]["theory_error_95"] > 0
    head = (tmp_path / "o" / "traction.csv").read_text().splitlines()[0]
    assert "mu_theory_error_95" in head.split(",")
    bad = cli("predict", "traction", p, "--method", "exactly", "-o", tmp_path / "o2")
    assert bad.exit_code == 2 and "--method" in bad.output


def test_fit_records_its_method_and_theory_error():
    """Data made by the thesis's FASTSIM: its fit recovers the truth; the default method's fit
    does not (its model differs by the correction), and params.yaml names the method."""
    from torlab.fit.traction import fit_layer_traction, traction_model

    sc = wheel_rail(method="fastsim-kalker")
    truth = {k: getattr(sc.boundary, k) for k in ("mu_c1", "mu_c2", "L_mue", "L_mup")}
    xi = np.geomspace(2e-4, 0.03, 30)
    mu = traction_model(sc)(truth, xi)
    plain = fit_layer_traction(sc, xi, mu, fixed={"L_mup": truth["L_mup"]})
    assert plain.params["mu_c1"] == pytest.approx(truth["mu_c1"], rel=1e-3)
    assert plain.meta["boundary_method"] == "fastsim-kalker"
    assert plain.to_params()["fit"]["boundary_method"] == "fastsim-kalker"
    cal = fit_layer_traction(sc, xi, mu, fixed={"L_mup": truth["L_mup"]}, method="fastsim")
    assert cal.meta["boundary_method"] == "fastsim"
    assert cal.params["L_mue"] != pytest.approx(plain.params["L_mue"], rel=1e-2)
    assert "mu_theory_error_95" in cal.data and cal.meta["theory_error_95"] > 0


def test_fit_polach_names_its_method_and_theory_error():
    """torlab.fit_polach by Kalker's FASTSIM and by the default method: each names its
    method and states the theory error of torlab's forces; the default's is smaller (the
    correction is what Kalker's FASTSIM leaves out), and Polach's initial slope follows the
    forces it was fitted to."""
    import torlab

    scene = SCENES / "wheel_rail_tab54.yaml"
    kw = {"creepage": "0:0.02:7", "speed": "10 m/s", "draws": 0}
    plain = torlab.fit_polach(scene, method="fastsim-kalker", **kw)
    cal = torlab.fit_polach(scene, method="fastsim", **kw)
    assert plain.meta["boundary_method"] == "fastsim-kalker"
    assert cal.meta["boundary_method"] == "fastsim"
    assert 0 < cal.meta["theory_error_95"] < plain.meta["theory_error_95"]
    assert "mu_theory_error_95" in cal.data
    assert cal.params["kA"] != pytest.approx(plain.params["kA"], rel=1e-3)


@pytest.mark.slow  # rounds of the exact solver (~6 s); the exact prediction and the fast fits are quick tests
def test_fit_by_the_exact_theory_recovers_a_curve_of_the_exact_theory():
    """A curve made by the exact solver (a coarse grid: the fit uses the same one, so the
    model is the data's): the exact fit recovers the layer; Kalker's FASTSIM fits another
    one; params.yaml names the method and mu_model_error the exact solver's own error."""
    from torlab.fit.traction import fit_layer_traction
    from torlab.model.exact.rolling import ExactGrid
    from torlab.model.exact.scene import predict_exact

    sc = wheel_rail(exact_n=10)
    truth = {k: getattr(sc.boundary, k) for k in ("mu_c1", "mu_c2", "L_mue", "L_mup")}
    xi = np.geomspace(3e-4, 0.02, 9)
    mu = predict_exact(sc, xi, grid=ExactGrid(n=10)).table["mu"].to_numpy()
    fixed = {"L_mup": truth["L_mup"]}
    ex = fit_layer_traction(sc, xi, mu, fixed=fixed, method="exact")
    assert ex.meta["boundary_method"] == "exact"
    assert ex.to_params()["fit"]["boundary_method"] == "exact"
    for k in ("mu_c1", "mu_c2", "L_mue"):
        assert ex.params[k] == pytest.approx(truth[k], rel=0.02), k
    assert np.all(np.isfinite(ex.data["mu_model_error"]))
    plain = fit_layer_traction(sc, xi, mu, fixed=fixed, method="fastsim-kalker")
    assert plain.params["L_mue"] != pytest.approx(truth["L_mue"], rel=0.05)
