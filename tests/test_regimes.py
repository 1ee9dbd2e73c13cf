"""Regime transition speeds of the Stribeck curve and their 95 % intervals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.conftest import ROOT
from torlab.fit.film import fit_film_thickness
from torlab.model.mixed import stribeck_curve
from torlab.model.predict import predict_stribeck
from torlab.model.regimes import transition_evidence, transition_speeds
from torlab.reports.stribeck import StribeckCurve, stribeck_section
from torlab.scene import load_scene, scene_from_dict
from torlab.yamlio import dump_yaml

SCENES = ROOT / "protocols" / "scenes"


def _cov_scene(sc, names, values, matrix, **extra):
    d = sc.model_dump(exclude_none=True)
    d["fit"] = {"kind": "test", "covariance": {"names": list(names), "values": list(values),
                                               "matrix": matrix, **extra}}
    return scene_from_dict(d)


@pytest.mark.parametrize("name", ["optical_paper_a_rough", "optical_paper_a_smooth",
                                  "mtm_paper_b"])
def test_transition_is_where_the_load_sharing_solver_changes_its_label(name):
    """The closed-form crossing against the independent bracketed solve of the load sharing:
    just below it the solver says mixed, just above full film."""
    sc = load_scene(SCENES / f"{name}.yaml")
    v = transition_speeds(sc)["mixed_to_full_film"]
    t = stribeck_curve(sc, [v * (1 - 1e-5), v * (1 + 1e-5)], 0.02).table
    assert list(t["regime"]) == ["mixed", "full_film"]


def test_boundary_transition_on_a_contact_whose_asperities_can_carry_the_load():
    """A dense, soft asperity population: the film takes load only above a positive speed;
    the solver labels boundary below the crossing and mixed above it."""
    sc = load_scene(SCENES / "mtm_paper_b.yaml")
    d = sc.model_dump(exclude_none=True)
    d["roughness"]["density"] = d["roughness"]["density"] * 100
    sc = scene_from_dict(d)
    v = transition_speeds(sc)
    vb, vf = v["boundary_to_mixed"], v["mixed_to_full_film"]
    assert vb is not None and 0 < vb < vf
    t = stribeck_curve(sc, [vb * (1 - 1e-5), vb * (1 + 1e-5)], 0.02).table
    assert list(t["regime"]) == ["boundary", "mixed"]


def test_iso_viscous_transition_interval_is_the_closed_form_in_eta0():
    """Eq. 5.31 depends on the speed through U = eta0 v / (E' rx): the transition speed is
    exactly proportional to 1/eta0, so a log-normal eta0 with sd s in ln eta0 gives the 95 %
    interval v exp(-+1.96 s)."""
    sc = load_scene(SCENES / "optical_paper_a_rough.yaml")
    assert sc.lubricant.film == "iso"
    eta0, s = sc.lubricant.eta0, 0.1
    sc2 = _cov_scene(sc, ["eta0"], [eta0], [[(s * eta0) ** 2]])
    e = transition_evidence(sc2, (0.01, 100.0))["mixed_to_full_film"]
    v = e["speed_m_s"]
    assert e["method"] == "linear" and e["status"] == "resolved"
    assert e["low95_m_s"] == pytest.approx(v * math.exp(-1.959964 * s), rel=1e-4)
    assert e["high95_m_s"] == pytest.approx(v * math.exp(1.959964 * s), rel=1e-4)
    assert e["dominant"][0]["parameter"] == "eta0"
    # and the transition itself scales as 1/eta0
    sc3 = scene_from_dict({**sc.model_dump(exclude_none=True),
                           "lubricant": {**sc.lubricant.model_dump(exclude_none=True),
                                         "eta0": 2 * eta0}})
    assert transition_speeds(sc3)["mixed_to_full_film"] == pytest.approx(v / 2, rel=1e-8)


def test_zero_uncertainty_collapses_the_interval_and_boundary_parameters_do_not_count():
    sc = load_scene(SCENES / "mtm_paper_b.yaml")
    lub = sc.lubricant
    e = transition_evidence(_cov_scene(sc, ["eta0"], [lub.eta0], [[0.0]]),
                            (0.01, 3.0))["mixed_to_full_film"]
    assert e["status"] == "exact" and e["low95_m_s"] == e["high95_m_s"] == e["speed_m_s"]
    assert e["verdict"] == "within the modelled speeds"
    # a boundary-layer covariance does not move the load sharing: still exact
    b = sc.boundary
    e = transition_evidence(_cov_scene(sc, ["mu_c1"], [b.mu_c1], [[1e-4]]),
                            (0.01, 3.0))["mixed_to_full_film"]
    assert e["status"] == "exact"


def test_undetermined_viscosity_parameter_is_said_not_resolved():
    sc = load_scene(SCENES / "mtm_paper_b.yaml")
    lub = sc.lubricant
    e = transition_evidence(_cov_scene(sc, ["eta0"], [lub.eta0], [[(0.01 * lub.eta0) ** 2]],
                                       not_determined=["Z"]), (0.01, 3.0))["mixed_to_full_film"]
    assert e["status"] == "not resolved" and e["low95_m_s"] is None
    assert e["verdict"] == "undetermined" and "Z not determined" in e["notes"][0]
    # an interval over more than two decades of speed is not a resolved transition
    e = transition_evidence(_cov_scene(sc, ["eta0"], [lub.eta0], [[(2.0 * lub.eta0) ** 2]]),
                            (0.01, 3.0))["mixed_to_full_film"]
    assert e["status"] == "not resolved" and e["verdict"] == "undetermined"


@pytest.mark.slow  # a coverage sweep: 60 seeds
def test_transition_interval_from_a_film_fit_holds_the_true_transition(tmp_path):
    """Synthetic truth: films from Hamrock-Dowson at alpha = 18 1/GPa with 4 % scatter,
    fitted for alpha (torlab fit film), the fitted parameter file applied to the scene.
    The true transition (the scene at the true alpha) lies inside the 95 % interval in at
    least 90 % of 60 seeds."""
    from torlab.model.contact import build_contact
    from torlab.model.ehl import hc_piezo

    scene = SCENES / "mtm_paper_b.yaml"
    sc = load_scene(scene)
    c = build_contact(sc)
    v = np.geomspace(0.05, 2.0, 15)
    alpha = 18e-9
    h = hc_piezo(v, sc.contact.load, c.E_star, c.rx, sc.lubricant.eta0, alpha,
                 c.patch.b / c.patch.a)
    truth = transition_speeds(scene_from_dict({**sc.model_dump(exclude_none=True), "lubricant": {
        **sc.lubricant.model_dump(exclude_none=True), "alpha": alpha}}))["mixed_to_full_film"]
    inside, widths = [], []
    p = tmp_path / "params.yaml"
    for seed in range(60):
        res = fit_film_thickness(v, h * np.exp(0.04 * np.random.default_rng(seed)
                                               .standard_normal(v.size)), scene=sc)
        p.write_text(dump_yaml(res.to_yaml_dict()))
        e = transition_evidence(load_scene(scene, p), (0.01, 3.0))["mixed_to_full_film"]
        assert e["parameters"] == ["alpha"] and e["status"] == "resolved"
        inside.append(e["low95_m_s"] <= truth <= e["high95_m_s"])
        widths.append(e["high95_m_s"] / e["low95_m_s"])
    assert np.mean(inside) >= 0.9, np.mean(inside)
    assert np.median(widths) > 1.01  # a real interval, not a point


@pytest.mark.slow  # a 20-speed band; the report's text: below
def test_stribeck_report_prints_the_transition_with_its_interval():
    sc = load_scene(SCENES / "optical_paper_a_rough.yaml")
    lub = sc.lubricant
    sc2 = _cov_scene(sc, ["eta0"], [lub.eta0], [[(0.3 * lub.eta0) ** 2]])
    speeds = np.geomspace(0.5, 50.0, 20)
    pred = predict_stribeck(sc2, speeds, 0.02)
    tr = pred.summary["transitions"]["mixed_to_full_film"]
    sec = stribeck_section([StribeckCurve("rough", pred.table, 0.02, band=pred.summary["band"],
                                          transitions=pred.summary["transitions"])])
    text = " ".join(sec.paragraphs)
    assert f"{tr['low95_m_s']:.3g}–{tr['high95_m_s']:.3g} m/s" in text
    row = sec.tables[0].df.iloc[0]
    assert row["mixed_to_full_film_m_s"] == pytest.approx(tr["speed_m_s"])
    assert row["mixed_to_full_film_low95_m_s"] < row["mixed_to_full_film_m_s"]
    assert tr["verdict"] in ("within the modelled speeds", "undetermined")
    assert sec.summary["transitions"]["rough"]["mixed_to_full_film"]["status"] == "resolved"


def test_cli_predict_stribeck_prints_and_writes_the_transition(cli, tmp_path):
    """torlab fit film, then torlab predict stribeck: summary.json carries the transition
    with the interval from the fitted alpha, and the console prints it."""
    import json

    import pandas as pd

    from torlab.model.contact import build_contact
    from torlab.model.ehl import hc_piezo

    scene = SCENES / "mtm_paper_b.yaml"
    sc = load_scene(scene)
    c = build_contact(sc)
    v = np.geomspace(0.05, 2.0, 15)
    h = hc_piezo(v, sc.contact.load, c.E_star, c.rx, sc.lubricant.eta0, 18e-9,
                 c.patch.b / c.patch.a) * np.exp(0.03 * np.random.default_rng(2)
                                                 .standard_normal(15))
    pd.DataFrame({"speed_m_s": v, "film_thickness_m": h}).to_csv(tmp_path / "film.csv",
                                                                   index=False)
    assert cli("fit", "film", tmp_path / "film.csv", "--scene", scene, "-o",
               tmp_path / "fit").exit_code == 0
    r = cli("predict", "stribeck", scene, tmp_path / "fit" / "params.yaml", "--speed",
            "0.01:2:12", "-o", tmp_path / "pred")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "pred" / "summary.json").read_text())
    e = s["transitions"]["mixed_to_full_film"]
    assert e["status"] == "resolved" and e["parameters"] == ["alpha"]
    assert e["low95_m_s"] < e["speed_m_s"] < e["high95_m_s"]
    assert "regime transitions: " in r.output and "mixed → full film at" in r.output
