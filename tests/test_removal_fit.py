"""Removal fit from MTM time tests after application: recovery, coverage, law choice, energy
transfer, inputs (files and bad input), the figure.

The virtual time tests come from torlab.synth.retention: the coefficient is the boundary model
of the remaining amount, the amount is integrated in time by an adaptive Runge-Kutta method
with the stated law (independently of the fit's closed forms and quadrature), and noise (white
+ a slow Ornstein-Uhlenbeck fluctuation) is added.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
import pytest

from torlab.errors import TorlabInputError
from torlab.fit.removal import fit_removal
from torlab.model.removal import RemovalLaw
from torlab.reduce.time_test import read_time_test, time_test
from torlab.reports.retention import removal_figure
from torlab.synth.retention import (
    TRACK_RADIUS,
    RetentionTestSpec,
    export_text,
    mtm_scene,
    retention_time_test,
    simulate_retention_test,
    true_layer,
    virtual_time_tests,
)

FIRST = RemovalLaw(1, 1.0e-6)
ZERO = RemovalLaw(0, 4.0e-8)
AMOUNTS = (2.0, 4.0)


@pytest.fixture(scope="module")
def layer():
    return true_layer()


@pytest.fixture(scope="module")
def scene():
    return mtm_scene()


def _tests(law, seed, layer, amounts=AMOUNTS, **kw):
    return virtual_time_tests(law, seed, layer, amounts, **kw)


def test_fit_recovers_the_law_and_reports_like_every_fit(layer, scene):
    res = fit_removal(_tests(FIRST, 7, layer), layer, scene)
    assert res.kind == "removal" and res.names == ("k1",)
    assert res.meta["law"] == "first_order" and res.meta["order"] == 1
    lo, hi = res.ci95["k1"]
    assert lo < FIRST.k < hi and lo < res.params["k1"] < hi
    assert res.stderr["k1"] < 0.1 * FIRST.k  # informative
    # asymmetric interval on the rate: exp(ln k +- t se)
    assert hi / res.params["k1"] == pytest.approx(res.params["k1"] / lo, rel=1e-9)
    sel = pd.DataFrame(res.meta["law_selection"])
    assert set(sel["law"]) == {"zero_order", "first_order"}
    assert sel["weight"].sum() == pytest.approx(1.0)
    assert sel.set_index("law").loc["first_order", "delta_aicc"] == 0.0
    assert res.fixed == {"transfer": 1.0, "spread": 0.0}
    tab = res.table()
    assert tab.set_index("parameter").loc["k1", "unit"] == "m^2/J"
    assert res.correlation.shape == (1, 1)
    d = res.data
    for col in ("test", "time_s", "mu_measured", "mu_model", "residual", "amount_mg_m2",
                "energy_J_m2", "passes", "in_fit"):
        assert col in d
    assert d.loc[d["in_fit"], "mu_model"].notna().all()
    # the energy bookkeeping by hand: mu F |SRR| v over the disc track 2 pi r x 2b
    t0 = res.meta["tests"][0]
    from torlab.model.contact import build_contact

    b = build_contact(mtm_scene(t0["load_N"], t0["speed_m_s"])).patch.b
    area = 2 * math.pi * TRACK_RADIUS * 2 * b
    assert t0["band_area_m2"] == pytest.approx(area, rel=1e-9)
    g = d[d["test"] == d["test"].iloc[0]]
    rate = np.diff(g["energy_measured_J_m2"]) / np.diff(g["time_s"])
    mu_mid = 0.5 * (g["mu_measured"].to_numpy()[1:] + g["mu_measured"].to_numpy()[:-1])
    hand = mu_mid * t0["load_N"] * t0["creepage"] * t0["speed_m_s"] / area
    assert np.median(rate / hand) == pytest.approx(1.0, abs=2e-3)
    assert set(res.summary()) >= {"params", "ci95", "stderr", "meta"}


def test_zero_order_law_is_chosen_for_zero_order_data(layer, scene):
    res = fit_removal(_tests(ZERO, 3, layer), layer, scene)
    assert res.meta["law"] == "zero_order" and res.names == ("k0",)
    lo, hi = res.ci95["k0"]
    assert lo < ZERO.k < hi
    assert res.table().set_index("parameter").loc["k0", "unit"] == "kg/J"


def test_tests_below_the_tested_range_share_one_friction_table(layer, scene):
    """The friction table of a test reaches the applied amount or the layer's largest tested
    amount, whichever is larger: tests of different amounts below that amount get the same
    table (built once), the same as the table over the tested range; one above it gets its
    own, which reaches its amount."""
    import torlab.fit.removal as fr
    from torlab.model.removal import mu_table

    fr._TABLES.clear()
    low, mid = fr._table(scene, layer, 0.02, 0.3 * layer.m_max, 6), \
        fr._table(scene, layer, 0.02, 0.7 * layer.m_max, 6)
    assert low is mid and len(fr._TABLES) == 1
    ref = mu_table(scene, layer, 0.02, per_interval=6, gradient=True)
    np.testing.assert_array_equal(low.x, ref.x)
    np.testing.assert_array_equal(low.mu, ref.mu)
    np.testing.assert_array_equal(low.grad, ref.grad)
    held = dataclasses.replace(layer, above="hold")
    inside, above = (fr._table(scene, held, 0.02, f * layer.m_max, 6) for f in (0.5, 1.5))
    assert above is not inside and above.m_max == pytest.approx(1.5 * layer.m_max)
    assert above.x[-1] == pytest.approx(math.log(1.5 * layer.m_max))
    np.testing.assert_array_equal(inside.mu, ref.mu)


@pytest.mark.slow
def test_coverage_and_law_choice_over_200_seeds(scene):
    """95 % intervals cover the true rate in >= 90 % of 200 virtual campaigns per law, and the
    criterion picks the true law in >= 90 % (a wrong pick counts as not covered).

    The layer is the generating one, given with negligible standard errors: this checks the
    intervals' data part (the record's noise and the measured conditions); the layer's part
    is checked by its linear response (next test)."""
    layer = true_layer(rel_se=1e-5)
    n = 200
    report = {}
    for law in (FIRST, ZERO):
        cover = pick = 0
        for seed in range(n):
            res = fit_removal(_tests(law, seed, layer), layer, scene)
            if res.meta["law"] == law.name:
                pick += 1
                lo, hi = res.ci95[law.k_name]
                cover += lo <= law.k <= hi
        report[law.name] = {"coverage": cover / n, "law_picked": pick / n}
    print(f"\nremoval fit over {n} seeds per law: {report}")
    for name, r in report.items():
        assert r["coverage"] >= 0.90, (name, report)
        assert r["coverage"] <= 0.995, (name, report)  # not vacuous either
        assert r["law_picked"] >= 0.90, (name, report)


def test_layer_uncertainty_enters_the_rate_through_its_linear_response(layer, scene):
    """The same data fitted with the nominal layer and with a layer one standard error off
    at one tested amount: the rate moves by what the fit's layer sensitivity G says (the
    linear response the layer's part of the interval is built from)."""
    from torlab.model.amount import AmountLayer

    j = 2  # the third tested amount (node j + 1; node 0 is the dry anchor)
    sd = np.sqrt(np.diag(layer.covs[j]))
    shifted = AmountLayer(layer.amounts, layer.params.copy(), layer.covs, layer.dry_params,
                          layer.dry_cov, layer.dry_amount)
    shifted.params[j, :2] += sd[:2]  # mu_c1 and mu_c2 one standard error higher
    shifted.__post_init__()
    data = _tests(FIRST, 2, layer, noise_sd=0.0, ou_sd=0.0)
    base = fit_removal(data, layer, scene, laws=("first_order",))
    moved = fit_removal(data, shifted, scene, laws=("first_order",))
    G = np.asarray(base.meta["fit_space"]["layer_sensitivity"])
    dp = np.zeros((layer.nodes.size, 4))
    dp[j + 1, :2] = sd[:2]
    predicted = float((G @ dp.ravel())[0])
    observed = math.log(moved.params["k1"] / base.params["k1"])
    assert abs(observed) > 1e-3  # a measurable shift
    assert observed == pytest.approx(predicted, rel=0.15)
    parts = base.meta["uncertainty_parts"]
    assert parts["layer"][0] > 0 and parts["data"][0] > 0
    total = math.log(base.ci95["k1"][1] / base.params["k1"])
    assert total > 1.9 * math.hypot(parts["layer"][0], parts["data"][0])


def test_a_layer_without_uncertainties_adds_nothing_to_the_interval(layer, scene):
    """Every node's covariance zero (a layer given as exact): no perturbed layer to
    follow, the layer's part of the interval is zero and the rest is what it is with
    the layer's uncertainties."""
    data = _tests(FIRST, 3, layer)
    exact = dataclasses.replace(layer, covs=np.zeros_like(layer.covs),
                                dry_cov=np.zeros_like(layer.dry_cov))
    res, ref = fit_removal(data, exact, scene), fit_removal(data, layer, scene)
    parts, ref_parts = res.meta["uncertainty_parts"], ref.meta["uncertainty_parts"]
    assert parts["layer"] == [0.0] and ref_parts["layer"][0] > 0
    assert parts["data"] == ref_parts["data"]
    lo, hi = res.ci95["k1"]
    assert lo < FIRST.k < hi and hi - lo < ref.ci95["k1"][1] - ref.ci95["k1"][0]


def test_energy_based_rate_transfers_between_loads_and_speeds(layer):
    """The same product tested at 18 N, 1 m/s, 2 % SRR and at 36 N, 2 m/s, 3 % SRR: the
    energy-based rates agree within their intervals, while the removal per second differs
    several-fold (a time-based law would not transfer)."""
    a = _tests(FIRST, 11, layer)
    b = _tests(FIRST, 12, layer, load_N=36.0, speed_m_s=2.0, srr=0.03, duration_s=460.0)
    ra = fit_removal(a, layer, mtm_scene(18.0, 1.0), laws=("first_order",))
    rb = fit_removal(b, layer, mtm_scene(36.0, 2.0), laws=("first_order",))
    ka, kb = ra.params["k1"], rb.params["k1"]
    for r in (ra, rb):
        assert r.ci95["k1"][0] < FIRST.k < r.ci95["k1"][1]
    assert abs(ka - kb) < 1.96 * math.hypot(ra.stderr["k1"], rb.stderr["k1"])
    assert ra.ci95["k1"][0] < kb < ra.ci95["k1"][1] or rb.ci95["k1"][0] < ka < rb.ci95["k1"][1]

    def per_second(r):
        t = r.meta["tests"][0]
        return r.params["k1"] * t["energy_at_end_J_m2"] / (t["passes_at_end"] * 2 * math.pi *
                                                           TRACK_RADIUS / t["speed_m_s"])
    assert per_second(rb) / per_second(ra) > 3.0


def test_transfer_fraction_can_be_fitted(layer, scene):
    tests = _tests(FIRST, 21, layer, transfer=0.5)
    res = fit_removal(tests, layer, scene, laws=("first_order",), transfer="fit")
    assert res.names == ("k1", "transfer")
    for name, truth in (("k1", FIRST.k), ("transfer", 0.5)):
        lo, hi = res.ci95[name]
        assert lo < truth < hi, (name, res.params, res.ci95)
    assert res.ci95["transfer"][1] <= 1.0
    assert np.isfinite(res.correlation).all()


def test_spreading_is_chosen_when_the_data_have_it(layer, scene):
    law = RemovalLaw(1, 6e-7, 1.5e-4)
    res = fit_removal(_tests(law, 5, layer), layer, scene,
                      laws=("first_order", "first_order+spread"))
    assert res.meta["law"] == "first_order+spread"
    for name, truth in (("k1", law.k), ("spread", law.spread)):
        lo, hi = res.ci95[name]
        assert lo < truth < hi, (name, res.params, res.ci95)
    # and not chosen where they do not
    res0 = fit_removal(_tests(FIRST, 5, layer), layer, scene,
                       laws=("first_order", "first_order+spread"))
    assert res0.meta["law"] == "first_order"


def test_fit_from_pcs_files_and_timed_csv_matches_the_arrays(layer, scene, tmp_path):
    from torlab.parsers.pcs import read_pcs
    from torlab.reduce.mtm import reduce_pcs

    spec = RetentionTestSpec("file_test", 2.0, seed=99)
    direct = retention_time_test(spec, layer, FIRST, via_file=False)
    p = tmp_path / "file_test.txt"
    p.write_bytes(export_text(spec, simulate_retention_test(spec, layer, FIRST), FIRST).encode())
    from_file = read_time_test(p, density=930.0)  # application detected, amount from the file
    assert from_file.application_source == "detected"
    assert abs(from_file.application_time - spec.application_time_s) <= 2.0
    assert from_file.track_radius == pytest.approx(TRACK_RADIUS)
    # torlab's own *_timed.csv (torlab mtm reduce) with the amount and track radius given
    df, meta = read_pcs(p)
    csv = tmp_path / "file_test_timed.csv"
    reduce_pcs(df, meta).curves["timed"].to_csv(csv, index=False)
    from_csv = read_time_test(csv, amount="2 uL", density=930.0, track_radius=TRACK_RADIUS,
                              application_time=spec.application_time_s)
    ks = [fit_removal(t, layer, scene, laws=("first_order",)).params["k1"]
          for t in (direct, from_file, from_csv)]
    assert ks[1] == pytest.approx(ks[0], rel=0.01) and ks[2] == pytest.approx(ks[0], rel=0.01)


def test_shipped_sample_time_tests_recover_their_truth(scene):
    """The files in sample_data/retention (written by the generator) against truth.yaml."""
    from conftest import ROOT

    from torlab.yamlio import load_yaml

    d = ROOT / "sample_data" / "retention"
    if not (d / "truth.yaml").exists():
        pytest.skip("sample data absent")
    truth = load_yaml(d / "truth.yaml").data
    lay = true_layer()
    tests = [read_time_test(d / r["file"], density=r["design"]["density_kg_m3"])
             for r in truth["runs"]]
    res = fit_removal(tests, lay, scene)
    assert res.meta["law"] == truth["law"]["name"]
    lo, hi = res.ci95["k1"]
    assert lo < truth["law"]["k1"] < hi
    for t, r in zip(res.meta["tests"], truth["runs"], strict=True):
        assert t["initial_amount_mg_m2"] == pytest.approx(r["initial_amount_mg_m2"], rel=2e-3)


# --- bad input -----------------------------------------------------------------------------------
def _one_line(e) -> str:
    s = str(e.value)
    assert "\n" not in s
    return s


def test_time_test_without_application_marker(layer):
    t = np.arange(1.0, 600.0)
    mu = 0.2 + 0.002 * np.random.default_rng(0).standard_normal(t.size)
    with pytest.raises(TorlabInputError) as e:
        time_test(t, mu, amount="2 uL", load=18.0, speed=1.0, creepage=0.02,
                  track_radius=0.02, label="flat.txt")
    s = _one_line(e)
    assert "no application marker" in s and "flat.txt" in s


@pytest.mark.parametrize("amount, words", [("2", "no unit"), ("-2 uL", "negative"),
                                           ("2 N", "not a volume"), (None, "no applied amount")])
def test_time_test_bad_amount(amount, words):
    t = np.arange(1.0, 200.0)
    mu = np.where(t < 50, 0.3, 0.1)
    with pytest.raises(TorlabInputError) as e:
        time_test(t, mu, amount=amount, load=18.0, speed=1.0, creepage=0.02,
                  track_radius=0.02, density=930.0)
    assert words in _one_line(e)


def test_pcs_amount_without_unit_names_file_and_line(layer, tmp_path):
    spec = RetentionTestSpec("nounit", 2.0, seed=1)
    text = export_text(spec, simulate_retention_test(spec, layer, FIRST), FIRST)
    p = tmp_path / "nounit.txt"
    p.write_bytes(text.replace("Applied amount = 2 uL", "Applied amount = 2").encode())
    with pytest.raises(TorlabInputError) as e:
        read_time_test(p, density=930.0)
    s = _one_line(e)
    line = 1 + text.split("\r\n").index("Applied amount = 2 uL")
    assert f"nounit.txt:{line}:" in s and "no unit" in s
    q = tmp_path / "noamount.txt"
    q.write_bytes(text.replace("Applied amount = 2 uL\r\n", "").encode())
    with pytest.raises(TorlabInputError, match="Applied amount"):
        read_time_test(q, density=930.0)


def test_csv_without_units_is_refused(tmp_path):
    p = tmp_path / "plain.csv"
    pd.DataFrame({"time": np.arange(100.0), "mu": np.full(100, 0.2)}).to_csv(p, index=False)
    with pytest.raises(TorlabInputError) as e:
        read_time_test(p, amount="2 uL", track_radius=0.02)
    s = _one_line(e)
    assert "no unit" in s and "plain.csv" in s


def test_bad_fit_options_and_ranges(layer, scene):
    tests = _tests(FIRST, 1, layer, amounts=(2.0,))
    with pytest.raises(TorlabInputError, match="transfer"):
        fit_removal(tests, layer, scene, transfer=1.5)
    with pytest.raises(TorlabInputError, match="unknown removal law"):
        fit_removal(tests, layer, scene, laws=("second_order",))
    with pytest.raises(TorlabInputError, match="samples in the fit window"):
        fit_removal(tests, layer, scene, skip=5000.0)
    big = _tests(FIRST, 1, layer, amounts=(2.0,))
    big[0].amount = (2e-8, "volume")  # 20 uL: more than the HPT series tested
    with pytest.raises(TorlabInputError, match="above the largest tested amount"):
        fit_removal(big, layer, scene)


# --- figure and prediction from the fit ----------------------------------------------------------
def test_figure_and_prediction_from_the_fit(layer, scene):
    from torlab.bench.fastsim import TAB54_SCENE
    from torlab.model.retention import predict_retention
    from torlab.scene import scene_from_dict

    res = fit_removal(_tests(FIRST, 8, layer), layer, scene)
    fig = removal_figure(res)
    ax, axm = fig.axes[:2]
    assert "(s)" in axm.get_xlabel() and "μ" in ax.get_ylabel()
    assert "mg/m²" in axm.get_ylabel()
    assert len(ax.lines) >= 2 * len(AMOUNTS)
    import matplotlib.pyplot as plt

    plt.close(fig)
    rail = scene_from_dict(TAB54_SCENE)
    pr = predict_retention(rail, layer, res, "100000 mg/m^2", creepage=0.01, points=101,
                           n_draws=100)
    pl = predict_retention(rail, layer, RemovalLaw(1, res.params["k1"]), "100000 mg/m^2",
                           creepage=0.01, points=101, n_draws=100)
    assert pr.table["mu"].to_numpy() == pytest.approx(pl.table["mu"].to_numpy(), abs=1e-12)
    wide = (pr.table["mu_high95"] - pr.table["mu_low95"]).max()
    narrow = (pl.table["mu_high95"] - pl.table["mu_low95"]).max()
    assert wide > narrow  # the rate's uncertainty adds to the layer's
