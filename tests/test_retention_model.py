"""Retention model: amount as an input, removal laws, the retention prediction, the slip sweep.

References independent of the code under test: hand calculations of areal densities, the
steady-rolling energy balance of a classic FASTSIM march written here, ODE integrations
(scipy's adaptive Runge-Kutta) of the removal laws against the closed forms and the
quadrature, the steady boundary prediction (torlab.model.predict) for the limits.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from torlab.errors import TorlabInputError
from torlab.fit.result import FitResult
from torlab.model.amount import HPT_AREA, MG_M2, AmountLayer, areal_density, parse_amount
from torlab.model.layers import LayerParams
from torlab.model.removal import (
    RemovalLaw,
    amount_from_energy,
    energy_per_pass,
    mu_table,
    passes_solution,
)
from torlab.model.retention import predict_retention, simulate_sweep
from torlab.synth.retention import law_layer_fits, true_layer
from torlab.units import to_si

NAMES = ("mu_c1", "mu_c2", "L_mue", "L_mup")


@pytest.fixture(scope="module")
def layer() -> AmountLayer:
    return true_layer()


@pytest.fixture(scope="module")
def rail():
    """Tab. 5.4 wheel-rail contact, isothermal (its layer is replaced by the amount's)."""
    from torlab.bench.fastsim import TAB54_SCENE
    from torlab.scene import scene_from_dict

    return scene_from_dict(TAB54_SCENE)


def _fit(p, amount=None, unit="uL", se=0.02, density=930.0):
    p = np.asarray(p, dtype=float)
    meta = {"source": f"{amount} {unit}"}
    if amount is not None:
        meta.update(applied_amount=amount, applied_amount_unit=unit, product_density=density)
    return FitResult.from_covariance("layer_hpt", NAMES, p, np.diag((se * p) ** 2), dof=100,
                                     residual_norm=0.0, n_points=0, warnings=[], data=None,
                                     meta=meta)


# --- amounts and units ------------------------------------------------------------------------
def test_mass_per_area_unit_and_amount_parsing():
    assert to_si("200 mg/m^2", "mass_per_area") == pytest.approx(2e-4)
    assert to_si("2 g/m**2", "mass_per_area") == pytest.approx(2e-3)
    assert parse_amount("4 uL") == (pytest.approx(4e-9), "volume")
    assert parse_amount("4 mg") == (pytest.approx(4e-6), "mass")
    assert parse_amount("30000 mg/m^2") == (pytest.approx(0.03), "mass_per_area")
    # the HPT annulus r1 = 3 mm, r2 = 6 mm: 84.82 mm^2
    assert HPT_AREA == pytest.approx(math.pi * 27e-6)
    # 4 uL of a 930 kg/m^3 product on the annulus: 3.72 mg / 84.82 mm^2 = 43 856 mg/m^2
    m = areal_density("4 uL", area=HPT_AREA, density=930.0)
    assert m / MG_M2 == pytest.approx(3.72 / 84.823e-6, rel=1e-4)
    assert areal_density("30000 mg/m^2", transfer=0.5) == pytest.approx(0.015)


@pytest.mark.parametrize("text, words", [
    ("5", "has no unit"), ("-5 uL", "negative"), ("5 N", "is not a volume"),
    ("five uL", "not an amount"),
])
def test_bad_amounts_one_clear_line(text, words):
    with pytest.raises(TorlabInputError) as e:
        parse_amount(text)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_volume_without_density_and_mass_without_area_are_user_errors():
    with pytest.raises(TorlabInputError, match="density"):
        areal_density("4 uL", area=1e-4)
    with pytest.raises(TorlabInputError, match="area"):
        areal_density("4 mg")


# --- the layer of the remaining amount --------------------------------------------------------
def test_amount_layer_interpolates_through_the_fits_and_holds_the_dry_limit(layer):
    tab = layer.table()
    for j, m in enumerate(layer.nodes):
        got = layer.params_at(m)
        assert got == pytest.approx(tab.loc[j, list(NAMES)].to_numpy(dtype=float), rel=1e-12)
    dry = layer.params_at(0.0)
    assert dry == pytest.approx(layer.dry_params)
    assert layer.params_at(0.3 * layer.dry_amount) == pytest.approx(layer.dry_params)
    # the default dry anchor: a tenth of the smallest tested amount, and it is said
    assert layer.dry_amount == pytest.approx(layer.m_min / 10)
    assert any("anchored" in n for n in layer.notes)
    # mu_c2 falls monotonically with the amount at the nodes, so does the interpolant
    m = np.geomspace(layer.dry_amount, layer.m_max, 2000)
    mu2 = layer.params_at(m)[:, 1]
    assert np.all(np.diff(mu2) <= 1e-15)
    # lengths constant over the tested amounts stay exactly constant (no overshoot)
    inside = m >= layer.m_min
    assert np.ptp(layer.params_at(m[inside])[:, 3]) < 1e-18


def test_amount_layer_bad_series_are_user_errors():
    fits, dry = law_layer_fits()
    with pytest.raises(TorlabInputError, match="at least two different amounts"):
        AmountLayer.from_fits(fits[:1], dry)
    with pytest.raises(TorlabInputError, match="same amount"):
        AmountLayer.from_fits([fits[0], fits[0]], dry)
    with pytest.raises(TorlabInputError, match="negative"):
        AmountLayer.from_fits(fits[:2], dry, amounts=["-1 uL", "2 uL"], density=930.0)
    with pytest.raises(TorlabInputError, match="no unit"):
        AmountLayer.from_fits(fits[:2], dry, amounts=["1", "2"])
    with pytest.raises(TorlabInputError, match="dry"):
        AmountLayer.from_fits(fits, None)
    nodens = [_fit([0.1, 0.2, 8e-6, 2e-5], 1, density=None),
              _fit([0.1, 0.2, 8e-6, 2e-5], 2, density=None)]
    for f in nodens:
        f.meta.pop("product_density")
    with pytest.raises(TorlabInputError, match="density"):
        AmountLayer.from_fits(nodens, dry)
    hot = law_layer_fits()[0]
    hot[1].meta["temperature_C"] = 80.0
    with pytest.raises(TorlabInputError, match="temperatures"):
        AmountLayer.from_fits(hot, dry)


def test_no_silent_extrapolation_above_the_tested_range():
    fits, dry = law_layer_fits()
    lay = AmountLayer.from_fits(fits, dry)
    with pytest.raises(TorlabInputError, match="above the largest tested amount"):
        lay.params_at(2 * lay.m_max)
    held = AmountLayer.from_fits(fits, dry, above="hold")
    assert held.params_at(2 * held.m_max) == pytest.approx(held.params[-1])


def test_layer_draws_carry_each_fits_covariance(layer):
    rng = np.random.default_rng(1)
    d = layer.draw_nodes(20000, rng)
    j = 3  # the third tested amount (node 0 is the dry anchor)
    sd = np.std(d[:, j, :], axis=0)
    se = np.sqrt(np.diag(layer.covs[j - 1]))
    assert sd == pytest.approx(se, rel=0.03)
    assert np.mean(d[:, j, :], axis=0) == pytest.approx(layer.params[j - 1], rel=1e-3)
    # the interpolation of the draws passes through the drawn values at the nodes
    at = layer.draw_params(layer.nodes[j], d[:50])
    assert at == pytest.approx(d[:50, j, :], rel=1e-12)


# --- energy ----------------------------------------------------------------------------------
def test_energy_per_pass_hand_calculation():
    """e_pass = mu F |xi| / w: 0.2 x 20 kN x 1 % over the 6.6 mm band of Tab. 5.4."""
    assert energy_per_pass(0.2, 20e3, -0.01, 6.6e-3) == pytest.approx(0.2 * 200 / 6.6e-3)
    assert energy_per_pass([0.1, 0.2], 18.0, 0.02, 2e-4) == pytest.approx([180.0, 360.0])


# --- removal laws: closed forms and quadrature against an ODE integrator ----------------------
def test_closed_forms_against_ode_integration():
    from scipy.integrate import solve_ivp

    t = np.linspace(0, 1000, 2001)
    P = 1e3 * (1 + 0.5 * np.sin(t / 90))  # a varying energy rate (J/m^2/s)
    E = np.concatenate([[0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
    N = t / 0.13
    m0 = 0.05
    for order, k, s in ((1, 2e-6, 0.0), (1, 1e-6, 2e-4), (0, 2e-8, 0.0), (0, 1e-8, 3e-4)):
        def rhs(tt, y, order=order, k=k, s=s):
            m = max(y[0], 0.0)
            g = k * (m if order else float(m > 0))
            return [-(g * np.interp(tt, t, P) + s * m / 0.13)]
        sol = solve_ivp(rhs, (0, 1000), [m0], t_eval=t, rtol=1e-10, atol=1e-14, max_step=1.0)
        got = amount_from_energy(m0, order, k, s, E, N)
        assert np.max(np.abs(got - np.maximum(sol.y[0], 0))) < 2e-5 * m0, (order, k, s)


def test_passes_quadrature_against_ode_integration(layer, rail):
    from scipy.integrate import solve_ivp

    tab = mu_table(rail, layer, 0.01)
    curve = tab.curve(0)
    c = 20e3 * 0.01 / 6.6e-3
    m0 = 120_000 * MG_M2

    def mu_of(m):
        return float(tab.mu_dry[0]) if m <= tab.m_dry else float(curve(math.log(m)))

    for order, k, s in ((1, 3e-7, 0.0), (1, 2e-7, 1e-3), (0, 1e-8, 0.0), (0, 5e-9, 5e-4)):
        sol = passes_solution(curve, tab.mu_dry[0], tab.x[0], m0, order, k, s, c)
        Nq = np.linspace(0, 4000, 81)
        m, _mu, E = sol.at(Nq)

        def rhs(n, y, order=order, k=k, s=s):
            mm = max(y[0], 0.0)
            e = c * mu_of(mm)
            return [-(k * (mm if order else float(mm > 0)) * e + s * mm), e]
        ref = solve_ivp(rhs, (0, 4000), [m0, 0.0], t_eval=Nq, rtol=1e-10, atol=[1e-14, 1e-6],
                        method="DOP853")
        assert np.max(np.abs(m[:, 0] - np.maximum(ref.y[0], 0))) < 1e-5 * m0, (order, s)
        assert np.max(np.abs(E[:, 0] / np.maximum(ref.y[1], 1e-9) - 1)[1:]) < 1e-4, (order, s)


# --- the limits --------------------------------------------------------------------------------
def _steady_mu(scene, lay: LayerParams, creepage: float) -> float:
    from torlab.model.predict import predict_traction
    from torlab.scene import Boundary

    b = Boundary(mu_c1=lay.mu_c1, mu_c2=lay.mu_c2, L_mue=lay.L_mue, L_mup=lay.L_mup)
    return float(predict_traction(scene.model_copy(update={"boundary": b}),
                                  [creepage]).table["mu"].iloc[0])


def test_zero_removal_keeps_the_steady_coefficient(layer, rail):
    m0 = 50_000 * MG_M2
    pr = predict_retention(rail, layer, RemovalLaw(1, 0.0), "50000 mg/m^2", creepage=0.01,
                           n_passes=5000, points=51, n_draws=0)
    ref = _steady_mu(rail, layer.layer(m0), 0.01)
    assert np.ptp(pr.table["mu"]) == 0.0
    assert pr.table["mu"].iloc[0] == pytest.approx(ref, abs=1e-10)  # m0 is a table node
    assert pr.table["amount_mg_m2"].to_numpy() == pytest.approx(50_000)
    assert pr.summary["passes_to_leave_band"]["passes"] is None  # never leaves: no removal
    assert any("no removal" in m for m in pr.modelled)


def test_very_fast_removal_gives_the_dry_prediction(layer, rail):
    pr = predict_retention(rail, layer, RemovalLaw(1, 1.0), "50000 mg/m^2", creepage=0.01,
                           passes=[0, 1, 2, 10, 100], n_draws=0)
    dry = _steady_mu(rail, LayerParams(*layer.dry_params), 0.01)
    assert pr.table["mu"].iloc[1:].to_numpy() == pytest.approx(dry, abs=1e-6)
    assert pr.summary["mu_dry"] == pytest.approx(dry, abs=1e-6)


def test_mu_against_passes_is_monotone_where_f_of_m_is(layer, rail):
    mus = np.array([_steady_mu(rail, layer.layer(m), 0.01)
                    for m in np.geomspace(layer.dry_amount, layer.m_max, 12)])
    assert np.all(np.diff(mus) < 0)  # f(m) falls with the amount for this product
    for law in (RemovalLaw(1, 2e-7), RemovalLaw(0, 5e-9), RemovalLaw(1, 1e-7, 1e-3)):
        pr = predict_retention(rail, layer, law, "150000 mg/m^2", creepage=0.01, points=400,
                               n_draws=0)
        assert np.all(np.diff(pr.table["mu"].to_numpy()) >= -1e-12), law
        assert np.all(np.diff(pr.table["amount_mg_m2"].to_numpy()) <= 1e-12), law


# --- the prediction: table, crossings, intervals, errors --------------------------------------
def test_retention_prediction_table_summary_and_intervals(layer, rail):
    pr = predict_retention(rail, layer, RemovalLaw(1, 2e-7), "100000 mg/m^2", creepage=0.01,
                           n_passes=3000, points=301, n_draws=200, seed=4)
    t = pr.table
    assert list(t.columns[:5]) == ["passes", "amount_mg_m2", "mu", "mu_low95", "mu_high95"]
    assert np.all(np.isfinite(t.to_numpy(dtype=float)))
    inside = (t["mu_low95"] <= t["mu"] + 1e-12) & (t["mu"] <= t["mu_high95"] + 1e-12)
    assert inside.mean() > 0.95
    assert (t["mu_high95"] - t["mu_low95"]).max() > 0
    s = pr.summary
    for key in ("passes_to_enter_band", "passes_to_leave_band"):
        cr = s[key]
        assert cr["low95"] <= cr["passes"] <= cr["high95"], cr
        # the crossing is where the table's coefficient passes the level
        j = int(np.searchsorted(t["passes"], cr["passes"]))
        assert t["mu"].iloc[j - 1] <= cr["level"] <= t["mu"].iloc[j]
    assert s["passes_to_enter_band"]["passes"] < s["passes_to_leave_band"]["passes"]
    assert s["initial_amount_mg_m2"] == pytest.approx(100_000)
    assert s["law"] == "first_order" and s["n_draws"] == 200
    assert "time_s" not in t  # a rail without a pass interval


def test_disc_scene_has_time_and_volume_amounts(layer):
    from torlab.synth.retention import TRACK_RADIUS, mtm_scene

    pr = predict_retention(mtm_scene(), layer, RemovalLaw(1, 1e-6), "2 uL", density=930.0,
                           creepage=0.02, track_radius=TRACK_RADIUS, n_passes=2000, points=21,
                           n_draws=0)
    assert pr.table["time_s"].iloc[-1] == pytest.approx(2000 * 2 * math.pi * TRACK_RADIUS / 1.0)
    assert pr.summary["running_band"]["kind"] == "disc"
    assert "disc track" in pr.summary["initial_amount_from"]


def test_prediction_input_errors(layer, rail):
    law = RemovalLaw(1, 1e-7)
    with pytest.raises(TorlabInputError, match="length of rail"):
        predict_retention(rail, layer, law, "4 uL", density=930.0, creepage=0.01)
    with pytest.raises(TorlabInputError, match="above the largest tested amount"):
        predict_retention(rail, layer, law, "900000 mg/m^2", creepage=0.01)
    with pytest.raises(TorlabInputError, match="no unit"):
        predict_retention(rail, layer, law, "4", creepage=0.01)
    with pytest.raises(TorlabInputError, match="negative"):
        predict_retention(rail, layer, law, "-4 mg/m^2", creepage=0.01)
    with pytest.raises(TorlabInputError, match="creepage"):
        predict_retention(rail, layer, law, "4000 mg/m^2", creepage=0.0)
    # on a rail the volume is spread over the length of rail it covers
    pr = predict_retention(rail, layer, law, "4 mL", density=930.0, band_length=100.0,
                           creepage=0.01, points=5, n_draws=0)
    assert pr.summary["initial_amount_mg_m2"] == pytest.approx(
        4e-6 * 930 / (100 * 6.6e-3) / MG_M2, rel=1e-3)


# --- the slip sweep ----------------------------------------------------------------------------
def _flat_layer() -> AmountLayer:
    """A product whose layer does not harden (mu_c1 = mu_c2): neutral steady traction."""
    fits = [_fit([v, v, 8e-6, 18e-6], a) for a, v in ((1, 0.30), (2, 0.24), (4, 0.15), (8, 0.09),
                                                        (16, 0.07))]
    return AmountLayer.from_fits(fits, _fit([0.45, 0.45, 5e-6, 40e-6]))


def test_sweep_without_removal_is_the_steady_curve(layer, rail):
    sw = simulate_sweep(rail, layer, RemovalLaw(1, 0.0), "60000 mg/m^2", creepage=(0, 0.03),
                        seconds=60, pass_interval=0.25, n_draws=0, points=61)
    assert np.max(np.abs(sw.table["mu_sweep"] - sw.table["mu_steady"])) < 1e-12
    assert sw.trend_sweep["trend"] == sw.trend_steady["trend"]
    # the steady curve is the boundary prediction at the applied amount
    ref = _steady_mu(rail, layer.layer(60_000 * MG_M2), 0.02)
    assert np.interp(0.02, sw.table["creepage"], sw.table["mu_steady"]) == pytest.approx(
        ref, abs=5e-4)


def test_sweep_removal_turns_a_neutral_curve_positive(rail):
    """Thesis H4.1 made quantitative: the steady curve of a non-hardening layer is neutral;
    removing product while the creepage ramps makes the recorded curve rise."""
    lay = _flat_layer()
    sw = simulate_sweep(rail, lay, RemovalLaw(1, 3e-8), "60000 mg/m^2", creepage=(0.0, 0.03),
                        seconds=60, pass_interval=0.2, n_draws=40, points=101)
    assert sw.trend_steady["trend"] == "neutral"
    assert sw.trend_sweep["trend"] == "positive"
    assert "H4.1" in sw.verdict
    assert sw.probability_positive is not None and sw.probability_positive > 0.8
    t = sw.table
    assert np.all(np.diff(t["amount_mg_m2"]) <= 0)
    assert t["mu_sweep"].iloc[-1] > t["mu_steady"].iloc[-1]
    # faster removal outpaces the saturation: the recorded curve never levels off
    fast = simulate_sweep(rail, lay, RemovalLaw(1, 3e-7), "60000 mg/m^2", creepage=(0.0, 0.03),
                          seconds=60, pass_interval=0.2, n_draws=0, points=101)
    assert fast.trend_sweep["trend"] == "not saturated in this range"
    assert "never levels off" in fast.verdict


def test_sweep_needs_a_pass_interval(layer, rail):
    with pytest.raises(TorlabInputError, match="time between passes"):
        simulate_sweep(rail, layer, RemovalLaw(1, 1e-7), "6000 mg/m^2", seconds=10)


# --- the synthetic generator --------------------------------------------------------------------
def test_generator_friction_table_matches_the_boundary_model(layer):
    """The generator's fine table (a cubic spline on 240 nodes) against direct evaluations."""
    from dataclasses import replace

    import torlab.synth.retention as R
    from torlab.model.contact import build_contact
    from torlab.model.fastsim import boundary_traction
    from torlab.model.prediction import fastsim_grid, fastsim_problem

    R._LAYERS[id(layer)] = layer
    spline, _mu_dry, _x_dry = R._fine_mu(id(layer), 18.0, 1.0, 0.02)
    sc = R.mtm_scene()
    prob = fastsim_problem(sc, build_contact(sc))
    for m in np.geomspace(layer.dry_amount * 1.01, layer.m_max * 0.99, 9):
        ref = abs(boundary_traction(replace(prob, layer=layer.layer(m)), [0.02],
                                    fastsim_grid(sc)).mu[0])
        assert float(spline(math.log(m))) == pytest.approx(ref, abs=1e-5)


def test_sample_campaign_writes_files_and_truth(tmp_path):
    from torlab.outputs import OutputDir
    from torlab.reduce.time_test import read_time_test
    from torlab.synth.retention import write_retention_sample_data
    from torlab.yamlio import load_yaml

    out = OutputDir(tmp_path / "ret")
    names = write_retention_sample_data(out)
    out.commit()
    truth = load_yaml(tmp_path / "ret" / "truth.yaml").data
    assert truth["law"]["name"] == "first_order" and truth["law"]["k1"] == 1e-6
    assert len(truth["runs"]) == 2 and len(truth["hpt_runs"]) == 6
    assert names == [r["file"] for r in truth["runs"]] + [r["file"] for r in truth["hpt_runs"]]
    assert (tmp_path / "ret" / "rig_compliance.csv").exists()
    # each HPT run carries exactly the truth layer's node at its amount (the dry run: the anchor)
    nodes = {n["amount_mg_m2"]: n for n in truth["layer"]["nodes"]}
    for r, node in zip(truth["hpt_runs"], sorted(nodes)[1:] + sorted(nodes)[:1], strict=True):
        for k in ("mu_c1", "mu_c2", "L_mue", "L_mup"):
            assert r["boundary"][k] == pytest.approx(nodes[node][k], rel=1e-12)
    tt = read_time_test(tmp_path / "ret" / names[0])
    assert tt.application_source == "detected"
    assert abs(tt.application_time - truth["runs"][0]["design"]["application_time_s"]) <= 2.0
    assert tt.amount_text.strip() == "1 uL"
    assert "SYNTHETIC" in (tmp_path / "ret" / "README.md").read_text().upper()


@pytest.mark.slow
def test_benchmark_rows_against_the_pass_by_pass_baseline():
    """The benchmark module (quick: 2 000 passes): the default row agrees with pass-by-pass
    FASTSIM and carries the time ratio measured in the same run (no time is asserted)."""
    from torlab.bench.retention import run
    from torlab.bench.runner import available_benchmarks

    assert "retention" in available_benchmarks()
    rows = run(quick=True)
    default = [r for r in rows if r.default]
    assert len(default) == 1
    d = default[0]
    assert d.error < 5e-4 and d.extra["crossing_error"] < 5e-3
    assert d.extra["baseline_time_over_default"] > 0
    assert "95 % intervals" in d.variant
    coarse = next(r for r in rows if r.variant.startswith("table 2/interval"))
    assert coarse.error > d.error  # fewer friction nodes, larger error


def test_sweep_verdict_is_called_only_at_the_threshold():
    """The outcome probabilities over the draws decide; below the threshold: undetermined,
    with the probabilities, whatever the curves at the estimate say."""
    from torlab.model.retention import _sweep_verdict

    j = {"made_by_removal": 0.75, "both_positive": 0.25, "never_levels_off": 0.0,
         "not_positive": 0.0}
    v = _sweep_verdict("positive", "neutral", 1.0, j, 0.9)
    assert v.startswith("undetermined") and "positive by removal 0.75" in v
    assert "H4.1" in _sweep_verdict("positive", "neutral", 1.0, j, 0.7)
    j2 = {"made_by_removal": 0.02, "both_positive": 0.0, "never_levels_off": 0.0,
          "not_positive": 0.98}
    assert "does not make a positive trend" in _sweep_verdict("positive", "neutral", 0.02, j2)
    # without draws: the classes at the estimate, said as such
    assert "without parameter draws" in _sweep_verdict("positive", "neutral", None)


def test_sweep_trend_classes_carry_their_probabilities(rail):
    lay = _flat_layer()
    sw = simulate_sweep(rail, lay, RemovalLaw(1, 3e-8), "60000 mg/m^2", creepage=(0.0, 0.03),
                        seconds=60, pass_interval=0.2, n_draws=40, points=101)
    p = sw.trend_sweep["probabilities"]
    assert sum(p.values()) == pytest.approx(1.0)
    assert sw.trend_sweep["trend"] == (max(p, key=p.get) if max(p.values()) >= 0.9
                                       else "undetermined")
    jp = sw.summary["verdict_probabilities"]
    assert jp["made_by_removal"] == pytest.approx(sw.summary["probability_positive_by_removal"])
    assert jp["made_by_removal"] >= 0.9 and "H4.1" in sw.verdict


def test_crossing_status_is_called_only_when_the_draws_agree():
    from torlab.model.retention import CROSSING_PROBABILITY, _crossing_status

    class Lay:
        m_min, dry_amount = 0.0, 1.0

    base = {"amount_mg_m2": 100.0, "low95": 10.0, "high95": None}
    assert _crossing_status({**base, "passes": 50.0, "p_crosses": 0.95}, Lay, "x") \
        .startswith("crosses")
    s = _crossing_status({**base, "passes": 50.0, "p_crosses": 0.6}, Lay, "x")
    assert s.startswith("undetermined") and "60 %" in s
    assert _crossing_status({**base, "passes": None, "p_crosses": 0.05}, Lay,
                            "passes_to_enter_band").startswith("never")
    assert _crossing_status({**base, "passes": None, "p_crosses": 0.3}, Lay,
                            "passes_to_enter_band").startswith("undetermined")
    assert CROSSING_PROBABILITY == 0.9
    # without draws: the central curve's status, as before
    assert _crossing_status({**base, "passes": 50.0}, Lay, "x").startswith("crosses")
