"""Between-run scatter: the REML variance, the pooled interval, repeated fits pooled.

References: the REML score equation of a random-effects meta-analysis (Viechtbauer 2005),
the homoscedastic closed form ``RSS / (n - p)``, Hartung-Knapp's variance by hand, and the
coverage of seeded virtual HPT campaigns whose run-to-run scatter is known.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ROOT

from torlab.random_effects import ONE_RUN, one_way, pool, pool_vectors, reml_between


def _score(y, v, tau2):
    """The REML estimating equation of one common mean: zero at an interior maximum."""
    w = 1.0 / (v + tau2)
    mu = np.sum(w * y) / np.sum(w)
    return float(np.sum(w * w * (y - mu) ** 2) - np.sum(w) + np.sum(w * w) / np.sum(w))


def test_reml_solves_its_score_equation_and_has_the_homoscedastic_closed_form():
    y = np.array([0.231, 0.244, 0.223, 0.239, 0.236])
    v = np.array([0.002, 0.004, 0.001, 0.003, 0.002]) ** 2
    t2 = reml_between(y, v)
    assert t2 > 0 and abs(_score(y, v, t2)) < 1e-6 * np.sum(1 / (v + t2))
    # equal own variances: the homoscedastic model's REML variance RSS/(n-1) less v
    ve = np.full(5, 0.002 ** 2)
    assert reml_between(y, ve) == pytest.approx(np.var(y, ddof=1) - 0.002 ** 2, rel=1e-12)
    # runs that agree better than their own errors: no between-run variance
    assert reml_between([0.2, 0.2001, 0.1999], np.full(3, 0.01 ** 2)) == 0.0
    # a line through the runs (a temperature series): RSS / (n - 2)
    x = np.arange(6.0)
    yl = 0.3 - 0.01 * x + np.array([0.01, -0.02, 0.015, 0.0, -0.01, 0.005])
    X = np.column_stack([np.ones(6), x])
    rss = np.sum((yl - X @ np.linalg.lstsq(X, yl, rcond=None)[0]) ** 2)
    assert reml_between(yl, np.zeros(6), X) == pytest.approx(rss / 4, rel=1e-12)


def test_pooled_estimate_is_hartung_knapp_by_hand():
    y = np.array([0.231, 0.244, 0.223, 0.239])
    v = np.array([0.002, 0.004, 0.001, 0.003]) ** 2
    p = pool(y, v)
    t2 = reml_between(y, v)
    w = 1 / (v + t2)
    mu = np.sum(w * y) / np.sum(w)
    q = np.sum(w * (y - mu) ** 2) / 3
    assert p.estimate == pytest.approx(mu) and p.dof == 3 and p.k == 4
    assert p.se == pytest.approx(math.sqrt(max(q, 1.0) / np.sum(w)))
    assert p.var_within + p.var_between == pytest.approx(p.se ** 2)
    assert p.var_within == pytest.approx(np.sum((w / np.sum(w)) ** 2 * v))
    assert 0.9 < p.share_between <= 1.0  # runs 0.002 apart scatter 0.009: between dominates
    from scipy.stats import t

    _, hi = p.interval()
    assert hi - mu == pytest.approx(t.ppf(0.975, 3) * p.se)
    one = pool([0.2], [0.001 ** 2], dof_one=12)
    assert one.k == 1 and one.dof == 12 and math.isnan(one.tau) and one.se == 0.001


def test_pooled_vectors_keep_each_variance_and_a_valid_covariance():
    rng = np.random.default_rng(4)
    k, p = 4, 3
    vals = np.exp(np.log([0.14, 0.23, 8e-6]) + 0.03 * rng.standard_normal((k, p)))
    covs = np.array([np.diag((0.005 * vals[i]) ** 2) for i in range(k)])
    est, cov, pooled = pool_vectors(vals, covs, [True, True, True])
    for j in range(p):
        # log scale: the natural variance is (value * se_ln)^2
        assert cov[j, j] == pytest.approx((est[j] * pooled[j].se) ** 2, rel=1e-9)
        assert est[j] == pytest.approx(math.exp(pooled[j].estimate))
    assert np.all(np.linalg.eigvalsh(cov) > -1e-18)
    np.testing.assert_allclose(cov, cov.T)


def test_one_way_is_the_anova_within_mean_square():
    x = [0.20, 0.22, 0.21, 0.18, 0.17, 0.25]
    g = ["a", "a", "a", "b", "b", "c"]
    r = one_way(x, g, [0.004] * 6)
    assert r["dof"] == 3 and r["sd_test"] == pytest.approx(math.sqrt(2.5e-4 / 3))


def test_repeated_hpt_runs_are_pooled_with_their_scatter():
    """The sample OFM1 campaign's four 25 degC runs: their fits spread over 0.223-0.245, so
    the pooled interval holds that scatter (the fit of shared parameters to every point
    gave 0.2348-0.2363: tests/test_fit_layer.py)."""
    from torlab.fit.layer import fit_layer_hpt
    from torlab.instruments.measured import hpt_curves

    hpt = ROOT / "sample_data" / "hpt"
    files = sorted(hpt.glob("hpt_OFM1_4uL_25C*.txt"))
    assert len(files) == 4
    pooled = fit_layer_hpt(hpt_curves(files, compliance=hpt / "rig_compliance.csv"))
    lo, hi = pooled.ci95["mu_c2"]
    each = [r["mu_c2"] for r in pooled.meta["runs"]]
    assert max(each) - min(each) > 0.015  # the runs scatter by several per cent
    assert lo < min(each) and hi > max(each)
    assert pooled.meta["interval_dof"]["mu_c2"] == 3
    re = pooled.meta["random_effects"]["mu_c2"]
    assert re["runs"] == 4 and re["share_between"] > 0.9
    assert "4 runs pooled" in pooled.meta["scatter"]
    assert pooled.covariance_section()["dof"] == 3
    assert pooled.provenance()["runs_pooled"] == 4


def test_one_run_says_its_interval_holds_for_that_record_alone():
    from torlab.fit.repeats import pool_fits
    from torlab.fit.result import FitResult

    f = FitResult.from_covariance("layer_hpt", ("mu_c2",), np.array([0.2]),
                                  np.array([[1e-6]]), dof=20, log_scale=("mu_c2",),
                                  residual_norm=1.0, n_points=100, warnings=[], data=None)
    assert pool_fits([f]).meta["scatter"] == ONE_RUN
    g = FitResult.from_covariance("film", ("mu_c2",), np.array([0.2]), np.array([[1e-6]]),
                                  dof=20, residual_norm=1.0, n_points=100, warnings=[],
                                  data=None)
    with pytest.raises(Exception, match="one kind"):
        pool_fits([f, g])


@pytest.mark.slow  # 200 virtual campaigns of three HPT runs each (600 fits, 2-3 min)
def test_pooled_intervals_cover_the_product_over_200_campaigns():
    """Virtual campaigns: a product's layer, three runs each drawn with 1, 2 or 3 % scatter
    of every parameter (log-normal), simulated by torlab.synth's HPT rig and fitted; the
    pooled 95 % interval holds the product's value in >= 90 % of 200 campaigns for every
    parameter (docs/fit.md gives the measured table)."""
    from test_fit_layer import NAMES, _run

    from torlab.fit.layer import fit_layer_hpt
    from torlab.model.layers import LayerParams

    truth = {"mu_c1": 0.135, "mu_c2": 0.223, "L_mue": 8e-6, "L_mup": 19e-6}
    hits = np.zeros(4)
    n = 200
    for c in range(n):
        rng = np.random.default_rng(10_000 + c)
        s = (0.01, 0.02, 0.03)[c % 3]
        runs = []
        for _ in range(3):
            p = {k: v * math.exp(s * rng.standard_normal()) for k, v in truth.items()}
            runs.append(_run(LayerParams(**p), int(rng.integers(2**31 - 1)), u_max=200e-6))
        res = fit_layer_hpt(runs)
        hits += [res.ci95[k][0] <= truth[k] <= res.ci95[k][1] for k in NAMES]
    cover = hits / n
    print("pooled coverage", dict(zip(NAMES, cover, strict=True)))
    assert np.all(cover >= 0.90), dict(zip(NAMES, cover, strict=True))
