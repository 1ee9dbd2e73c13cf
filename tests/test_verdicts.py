"""Evidence behind the reports' verdicts: viscosity covariance, time-test intervals, the amount
report's status evidence and same-mass test, the film ratio, measured trends.

References: ordinary least squares in closed form (numpy's solve of the normal equations),
the delta method checked by Monte Carlo, the long-run variance of an AR(1) process, hand
computations of chi-square and geometric means.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT

from torlab.fit.viscosity import fit_viscosity
from torlab.model.viscosity import log_eta_roelands


def _visc_data(seed: int = 1, sd: float = 0.01):
    rng = np.random.default_rng(seed)
    p = np.repeat(np.arange(0, 301, 50) * 1e6 + 1e5, 3)
    eta = np.exp(log_eta_roelands(p, 0.065, 0.42) + sd * rng.standard_normal(p.size))
    return p, eta


def test_barus_covariance_is_the_least_squares_one():
    """(ln eta0, alpha) of a Barus fit: s^2 (X^T X)^-1, in natural units for eta0."""
    p, eta = _visc_data()
    f = fit_viscosity(p, eta, "barus")
    X = np.column_stack((np.ones_like(p), p))
    y = np.log(eta)
    coef = np.linalg.solve(X.T @ X, X.T @ y)
    r = y - X @ coef
    cov = r @ r / (p.size - 2) * np.linalg.inv(X.T @ X)
    e0 = math.exp(coef[0])
    want = cov * np.outer([e0, 1.0], [e0, 1.0])
    assert f.names == ("eta0", "alpha")
    assert np.allclose(f.covariance, want, rtol=1e-8)
    assert f.correlation[0, 1] == pytest.approx(want[0, 1] / math.sqrt(want[0, 0] * want[1, 1]))
    assert f.correlation[0, 1] < -0.5  # the intercept is an extrapolation to p = 0
    cs = f.covariance_section()
    assert cs["names"] == ["eta0", "alpha"] and cs["log_scale"] == ["eta0"]


def test_roelands_alpha_star_covariance_by_monte_carlo():
    """The derived alpha* = (ln eta0 + 9.67) 5.1e-9 Z: its variance and covariances in the
    written block against draws of (Z, ln eta0) from the fit's covariance."""
    p, eta = _visc_data(2, sd=0.03)
    f = fit_viscosity(p, eta, "roelands", fit_eta0=True)
    cs = f.covariance_section()
    assert cs["names"] == ["eta0", "Z", "alpha"]
    C = np.asarray(cs["matrix"])
    assert cs["values"][2] == pytest.approx(f.alpha)
    # draws of (ln eta0, Z) with the fit's covariance
    c_nat = np.asarray(f.covariance)
    jac = np.diag([1 / f.eta0, 1.0])
    c_log = jac @ c_nat @ jac
    rng = np.random.default_rng(0)
    d = rng.multivariate_normal([math.log(f.eta0), f.Z], c_log, size=200_000)
    a = (d[:, 0] + 9.67) * 5.1e-9 * d[:, 1]
    assert C[2, 2] == pytest.approx(np.var(a), rel=0.02)
    assert C[1, 2] == pytest.approx(np.cov(d[:, 1], a)[0, 1], rel=0.03)
    assert np.linalg.eigvalsh(C / np.sqrt(np.outer(np.diag(C), np.diag(C)))).min() > -1e-9


def test_viscosity_parameter_file_gives_a_band(tmp_path):
    """A lubricant from the viscosity fit carries its uncertainty into a lubricated prediction."""
    from torlab.model.predict import predict_traction
    from torlab.scene import load_scene
    from torlab.yamlio import dump_yaml

    p, eta = _visc_data()
    f = fit_viscosity(p, eta, "barus")
    params = tmp_path / "lub.yaml"
    params.write_text(dump_yaml(f.to_yaml_dict()))
    sc = load_scene(ROOT / "protocols/scenes/mtm_paper_b.yaml", params)
    assert sc.lubricant.eta0 == pytest.approx(f.eta0, rel=1e-11)
    pr = predict_traction(sc, np.linspace(0, 0.05, 6))
    band = pr.summary["band"]
    assert band["method"] in ("linear", "sampling")
    assert set(band["parameters"]) == {"eta0", "alpha"}
    t = pr.table
    assert np.all(t["film_thickness_low95_m"] <= t["film_thickness_m"])
    assert np.all(t["film_thickness_m"] <= t["film_thickness_high95_m"])
    assert (t["film_thickness_high95_m"] - t["film_thickness_low95_m"]).max() > 0


# ------------------------------------------------------------------ time tests
@pytest.mark.parametrize("white", [0.0, 0.003])
def test_batch_mean_interval_covers_the_mean_of_a_wandering_series(white):
    """The mean of a slowly wandering series (AR(1), rho 0.95: a 20 s fluctuation at 1 Hz, as
    the MTM sample data; with and without white noise on top): the 95 % interval holds the
    true mean in about 95 % of 300 series (binomial 3-sigma floor 0.88), where the naive
    sd/sqrt(n) interval holds it far less often."""
    from scipy.signal import lfilter
    from scipy.stats import t as student

    from torlab.reduce.time_test_uncertainty import hac_mean

    rng = np.random.default_rng(3)
    rho, n = 0.95, 900
    hits = naive = 0
    for _ in range(300):
        e = rng.standard_normal(n) * math.sqrt(1 - rho * rho)
        x, _ = lfilter([1.0], [1.0, -rho], e, zi=[rho * rng.standard_normal()])
        y = 0.17 + 0.004 * x + white * rng.standard_normal(n)
        m, se, dof = hac_mean(y)
        hits += abs(m - 0.17) <= student.ppf(0.975, dof) * se
        naive += abs(m - 0.17) <= 1.96 * y.std(ddof=1) / math.sqrt(n)
    assert hits / 300 >= 0.88
    assert naive / 300 < 0.7


def _timed(label: str):
    from torlab.synth.mtm import paper_b_time_tests, simulate_time_test

    spec = next(s for s in paper_b_time_tests(2020) if s.name == label)
    ch = simulate_time_test(spec)
    return spec, {"step_time_s": ch["t"], "traction_coefficient": ch["mu"]}


def test_time_test_intervals_and_verdicts():
    """A recovering and an over-lubricated test: the minimum read from the noisy record lies
    below the true one (torlab.synth.mtm.true_figures: the noise-free curve's, in closed
    form), and its interval, corrected for that bias, is centred above the record's figure
    (a record that stays low gets no minimum interval, and a note why);
    the crossings' intervals hold the true figures; the verdicts are called at the
    probability, and the mean's interval holds the true plateau. (Coverage over seeds:
    tests/test_time_test_repeats.py, slow.)"""
    from torlab.reduce.mtm import time_test_metrics
    from torlab.reduce.time_test_uncertainty import time_test_uncertainty
    from torlab.synth.mtm import true_figures

    for label, recovers in (("mtm_base_5uL", True), ("mtm_TOR-A_20uL", False)):
        spec, ch = _timed(label)
        t, mu = ch["step_time_s"], ch["traction_coefficient"]
        opts = {"threshold": 0.15, "smooth": 10.0, "duration": 1200.0}
        res = time_test_metrics(t, mu, **opts)
        ev = time_test_uncertainty(t, mu, res, opts, replicates=60, seed=1)
        assert ev["replicates"] == 60
        truth = true_figures(spec)
        assert res.minimum < truth["minimum"]
        if recovers:
            assert ev["minimum_bias"] < 0
            assert 0.5 * (ev["minimum_low95"] + ev["minimum_high95"]) > res.minimum
        else:  # a level with a fluctuation: its deepest point is not resolved, and says so
            assert math.isnan(ev["minimum_low95"]) and "not recovered" in ev["minimum_note"]
        lo, hi = ev["time_below_threshold_low95"], ev["time_below_threshold_high95"]
        assert lo <= truth["time_below_threshold_s"] <= hi
        if recovers:
            lo, hi = ev["recovery_time_low95"], ev["recovery_time_high95"]
            assert lo <= truth["recovery_time_s"] <= hi
        if recovers:
            assert ev["recovered_verdict"] == "recovered" and ev["p_recovered"] >= 0.9
            lo, hi = ev["mean_after_recovery_low95"], ev["mean_after_recovery_high95"]
            assert lo < res.mean_after_recovery < hi
            assert ev["in_band_verdict"] == "in band"
            # the mean after recovery estimates the plateau (the recovery's tail is < 0.002)
            assert lo - 0.002 <= spec.mu_plateau <= hi + 0.002
        else:
            assert ev["recovered_verdict"] == "not recovered" and ev["p_recovered"] <= 0.1
            assert ev["in_band_verdict"] == ""
    # deterministic for a seed
    spec, ch = _timed("mtm_base_5uL")
    res = time_test_metrics(ch["step_time_s"], ch["traction_coefficient"], smooth=10.0)
    a = time_test_uncertainty(ch["step_time_s"], ch["traction_coefficient"], res,
                              {"smooth": 10.0}, replicates=20, seed=5)
    b = time_test_uncertainty(ch["step_time_s"], ch["traction_coefficient"], res,
                              {"smooth": 10.0}, replicates=20, seed=5)
    assert a == b


# ------------------------------------------------------------------ amount report evidence
def test_mass_homogeneity_by_hand():
    from scipy.stats import chi2, t

    from torlab.fit.crossing import mass_homogeneity

    tq = float(t.ppf(0.975, 8))
    rows = []
    masses, ses = [6.0, 7.0, 9.0], [0.05, 0.08, 0.1]
    for i, (m, se) in enumerate(zip(masses, ses, strict=True)):
        rows.append({"product": f"P{i}", "crossing_mass_mg": m,
                     "crossing_mass_low_mg": m * math.exp(-tq * se),
                     "crossing_mass_high_mg": m * math.exp(tq * se)})
    rows.append({"product": "none", "crossing_mass_mg": float("nan"),
                 "crossing_mass_low_mg": float("nan"), "crossing_mass_high_mg": float("nan")})
    h = mass_homogeneity(rows, tq)
    w = 1 / np.array(ses) ** 2
    lm = np.log(masses)
    mbar = float(np.sum(w * lm) / np.sum(w))
    c2 = float(np.sum(w * (lm - mbar) ** 2))
    assert h["products"] == ["P0", "P1", "P2"] and h["dof"] == 2
    assert h["chi2"] == pytest.approx(c2, rel=1e-9)
    assert h["p_value"] == pytest.approx(chi2.sf(c2, 2), rel=1e-9)
    assert h["mass_mg"] == pytest.approx(math.exp(mbar), rel=1e-9)
    assert mass_homogeneity(rows[:1], tq) is None


def test_film_ratio_by_hand():
    from torlab.reports.stribeck import film_ratio

    v = np.array([0.01, 0.1, 0.3, 1.0, 2.0])
    h_model = 8e-9 * v**0.66
    model = pd.DataFrame({"speed_m_s": np.geomspace(0.005, 3, 60),
                          "film_thickness_m": 8e-9 * np.geomspace(0.005, 3, 60) ** 0.66})
    factors = np.array([1.0, 1.1, 0.95, 1.05, 1.0])
    meas = pd.DataFrame({"rolling_speed_m_s": v, "film_thickness_m": h_model * factors})
    r = film_ratio(meas, model)
    keep = h_model * factors > 2e-9  # films thinner than 2 nm (0.01, 0.1 m/s) are left out
    g = np.exp(np.mean(np.log(factors[keep])))
    assert r["n_points"] == int(keep.sum()) == 3
    assert r["ratio"] == pytest.approx(g, rel=2e-3)  # log-log interpolation of the model
    assert r["ratio_low95"] < r["ratio"] < r["ratio_high95"]


# ------------------------------------------------------------------ trends of measured curves
def test_measured_trend_without_scatter_is_not_called():
    from torlab.model.prediction import classify_trend

    x = np.array([0.0, 0.005, 0.01, 0.02, 0.05, 0.075, 0.1])
    y = np.array([0.0, 0.2, 0.25, 0.26, 0.26, 0.262, 0.261])
    t = classify_trend(x, y, measured=True)
    assert t["trend"] == "undetermined" and t["trend_point"] == "neutral"
    assert t["probabilities"] is None and "no scatter" in t["basis"]


def test_cli_synth_hpt_paper_b(cli, tmp_path):
    r = cli("synth", "hpt", "--campaign", "paper_b", "-o", tmp_path / "b")
    assert r.exit_code == 0, r.output
    logs = sorted(p.name for p in (tmp_path / "b").glob("hpt_*.txt"))
    assert logs == ["hpt_TOR-A_8uL_25C.txt", "hpt_TOR-A_8uL_25C_run2.txt",
                    "hpt_custom_8uL_25C.txt", "hpt_custom_8uL_25C_run2.txt"]
    # the same seed gives the shipped files
    shipped = ROOT / "sample_data" / "hpt_paper_b"
    for name in logs:
        assert (tmp_path / "b" / name).read_bytes() == (shipped / name).read_bytes()
    r = cli("synth", "hpt", "--campaign", "paper_x", "-o", tmp_path / "x")
    assert r.exit_code == 2 and "--campaign" in r.output


def _amount_series(repeats: int, run_sd: float, seed: int = 0):
    """Two products, five amounts, ``repeats`` runs each: logistic f in ln amount with a
    run-to-run scatter ``run_sd``."""
    import pandas as pd

    from torlab.fit.crossing import logistic

    rng = np.random.default_rng(seed)
    rows = []
    for prod, c in (("A", math.log(4.0)), ("B", math.log(8.0))):
        for a in (1.0, 2.0, 4.0, 8.0, 16.0, 32.0):
            for _ in range(repeats):
                f = float(logistic(np.log(a), 0.08, 0.30, 2.0, c)) + run_sd * rng.standard_normal()
                rows.append({"product": prod, "file": f"{prod}_{a}.txt", "applied_amount": a,
                             "applied_amount_unit": "uL", "amount_kind": "volume",
                             "density_kg_m3": 900.0, "mass_mg": a * 0.9, "f": f,
                             "f_sd": 0.01, "temperature_C": 25.0, "product_type": "liquid",
                             "product_label": prod})
    return pd.DataFrame(rows)


def test_amount_intervals_say_what_one_run_per_amount_cannot_resolve():
    """One run per amount: the crossing intervals rest on the scatter about the logistic
    curves, and the result says that it holds the run-to-run scatter and each run's noise
    together, which one run per amount cannot tell apart."""
    from torlab.fit.crossing import amount_statistics, fit_crossings

    series = _amount_series(1, 0.005)
    fits = fit_crossings(series, threshold=0.15, band=(0.15, 0.25))
    sc = fits[0].meta["scatter"]
    assert sc["basis"] == "residuals" and sc["dof_repeats"] == 0
    r = np.concatenate([cf.data["residual"].to_numpy() for cf in fits])
    assert sc["sd"] == pytest.approx(math.sqrt(r @ r / (r.size - 8)), rel=1e-12)
    assert "one run per amount" in sc["holds"] and "cannot tell" in sc["holds"]
    st = amount_statistics(series, fits, threshold=0.15, confidence=0.95)
    assert st["scatter"]["holds"] == sc["holds"]


def test_amount_repeats_are_pooled_with_random_effects():
    """Two runs at every amount: the repeats' one-way REML scatter is the pooled
    within-amount variance (by hand), and the crossing intervals and the status evidence use
    the larger of it and the scatter about the logistic curves, on its degrees of
    freedom."""
    from torlab.fit.crossing import fit_crossings

    series = _amount_series(2, 0.01, seed=3)
    g = series.groupby(["product", "applied_amount"])["f"]
    ss = float(((series["f"] - g.transform("mean")) ** 2).sum())
    dof = int((g.count() - 1).sum())
    fits = fit_crossings(series, threshold=0.15, band=(0.15, 0.25))
    sc = fits[0].meta["scatter"]
    assert sc["repeated_amounts"] == 12 and sc["dof_repeats"] == dof == 12
    assert sc["sd_repeats"] == pytest.approx(math.sqrt(ss / dof), rel=1e-9)
    assert "runs repeat 12 amounts" in sc["holds"]
    assert sc["sd"] == max(sc["sd_repeats"], sc["sd_residual"])
    assert sc["basis"] == ("repeats" if sc["sd_repeats"] > sc["sd_residual"] else "residuals")
    for cf in fits:  # the intervals rest on that scatter and its degrees of freedom
        if cf.cov is not None:
            assert cf.dof == sc["dof"]
    # the evidence of "above/below at every amount" uses the same scatter
    from torlab.fit.crossing import amount_statistics

    st = amount_statistics(series, fits, threshold=0.15, confidence=0.95)
    assert st["pooled"] == [sc["sd"], sc["dof"]]
