"""Propagation of parameter uncertainty (torlab.uncertainty) against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm
from scipy.stats import t as student

from torlab.errors import NumericalError
from torlab.uncertainty import ParameterDistribution, propagate

X = np.linspace(0.0, 2.0, 9)
Z95 = norm.ppf(0.975)


def _line(p):
    return p["a"] + p["b"] * X


def test_linear_model_band_is_the_closed_form():
    """y = a + b x with a known covariance: var y = Caa + 2 x Cab + x^2 Cbb exactly."""
    C = np.array([[0.04, -0.01], [-0.01, 0.09]])
    d = ParameterDistribution.from_covariance(("a", "b"), [1.0, 0.5], C)
    r = propagate(_line, d)
    assert r.method == "linear"
    sd = np.sqrt(C[0, 0] + 2 * X * C[0, 1] + X**2 * C[1, 1])
    np.testing.assert_allclose(r.sd["value"], sd, rtol=1e-10)
    np.testing.assert_allclose(r.low(), 1.0 + 0.5 * X - Z95 * sd, rtol=1e-10)
    np.testing.assert_allclose(r.high(), 1.0 + 0.5 * X + Z95 * sd, rtol=1e-10)
    assert r.nonlinearity < 1e-9
    assert r.n_evaluations == 1 + 2 + 2  # estimate, one step per parameter, two probes
    # shares: the Shapley effects of two correlated normal parameters, summing to 1.  With
    # one parameter known, E[y | a] is linear in a (normal regression), so the variance a
    # explains alone is cov(y, a)^2 / var(a); a's effect is the mean of what it adds first
    # and what it adds second: (v(a) + var - v(b)) / 2
    s = r.contributions["value"]
    np.testing.assert_allclose(s["a"] + s["b"], 1.0, atol=1e-12)
    i = 4
    g = np.array([1.0, X[i]])
    cov_ya, cov_yb = C[0] @ g, C[1] @ g
    va, vb, var = cov_ya**2 / C[0, 0], cov_yb**2 / C[1, 1], sd[i] ** 2
    np.testing.assert_allclose(s["a"][i], (va + var - vb) / 2 / var, rtol=1e-10)
    np.testing.assert_allclose(s["b"][i], (vb + var - va) / 2 / var, rtol=1e-10)


def test_shares_of_correlated_parameters_are_shapley_effects():
    """Three correlated parameters: the shares are the Shapley effects, computed here from a
    sample by brute force (the variance each set of parameters explains is the R^2 of the
    least-squares regression of y on that set, averaged over all 6 orders), never negative,
    and summing to 1 -- where the even split of the covariance gave a share of 135 % and
    one below 0 (a layer fit's mu_c1 and L_mue correlated at 0.995)."""
    import itertools

    from torlab.uncertainty import shapley_shares

    sdv = np.array([0.01, 0.02, 0.005])
    R = np.array([[1.0, 0.995, -0.3], [0.995, 1.0, -0.25], [-0.3, -0.25, 1.0]])
    C = R * np.outer(sdv, sdv)
    g = np.array([[3.0], [-1.0], [2.0]])
    var = float(g[:, 0] @ C @ g[:, 0])
    got = shapley_shares(g, C, np.array([var]))[:, 0]
    even = g[:, 0] * (C @ g[:, 0]) / var
    assert even.max() > 1.0 and even.min() < 0.0  # what the even split reported
    assert np.all(got >= 0) and got.sum() == pytest.approx(1.0, abs=1e-12)
    rng = np.random.default_rng(3)
    theta = rng.multivariate_normal(np.zeros(3), C, size=400_000)
    y = theta @ g[:, 0]

    def explained(u):
        if not u:
            return 0.0
        coef, *_ = np.linalg.lstsq(theta[:, list(u)], y, rcond=None)
        return float(np.var(theta[:, list(u)] @ coef))

    ref = np.zeros(3)
    orders = list(itertools.permutations(range(3)))
    for order in orders:
        for k, j in enumerate(order):
            ref[j] += explained(order[:k + 1]) - explained(order[:k])
    ref /= len(orders) * np.var(y)
    np.testing.assert_allclose(got, ref, atol=0.01)
    # uncorrelated parameters: each its own g_j^2 C_jj / var
    Cd = np.diag(sdv**2)
    vd = float(g[:, 0] @ Cd @ g[:, 0])
    np.testing.assert_allclose(shapley_shares(g, Cd, np.array([vd]))[:, 0],
                               g[:, 0] ** 2 * sdv**2 / vd, rtol=1e-12)


def test_zero_uncertainty_collapses_the_band_onto_the_curve():
    d = ParameterDistribution.from_covariance(("a", "b"), [1.0, 0.5], np.zeros((2, 2)))
    r = propagate(_line, d)
    assert r.method == "none"
    np.testing.assert_array_equal(r.low(), 1.0 + 0.5 * X)
    np.testing.assert_array_equal(r.high(), 1.0 + 0.5 * X)
    assert r.dominant() == []


def test_student_t_and_welch_satterthwaite_degrees_of_freedom():
    """Two independent fits (dof 4 and 30): the band uses t with
    nu = var^2 / (var_a^2/4 + var_b^2/30) at each point."""
    da = ParameterDistribution.from_covariance(("a",), [1.0], [[0.04]], dof=4)
    db = ParameterDistribution.from_covariance(("b",), [0.5], [[0.09]], dof=30)
    r = propagate(_line, ParameterDistribution.combine([da, db]))
    va, vb = 0.04 * np.ones_like(X), 0.09 * X**2
    nu = (va + vb) ** 2 / (va**2 / 4 + vb**2 / 30)
    half = student.ppf(0.975, nu) * np.sqrt(va + vb)
    np.testing.assert_allclose(r.high() - (1.0 + 0.5 * X), half, rtol=1e-9)
    # at x = 0 only the dof-4 block counts
    assert r.high()[0] - 1.0 == pytest.approx(student.ppf(0.975, 4) * 0.2, rel=1e-9)


def test_nonlinear_model_is_sampled_and_matches_exact_quantiles():
    """y = exp(a x), a ~ N(0.3, 0.5^2): far from linear over the band; the check must say so,
    and the sampled band must match the exact quantiles exp(x (0.3 +- 1.96 0.5))."""
    d = ParameterDistribution.from_covariance(("a",), [0.3], [[0.25]])
    r = propagate(lambda p: np.exp(p["a"] * X), d, n_samples=4000, seed=3)
    assert r.method == "sampling" and r.nonlinearity > 0.1
    exact_lo, exact_hi = np.exp(X * (0.3 - Z95 * 0.5)), np.exp(X * (0.3 + Z95 * 0.5))
    np.testing.assert_allclose(r.low()[1:], exact_lo[1:], rtol=0.04)
    np.testing.assert_allclose(r.high()[1:], exact_hi[1:], rtol=0.04)
    # reproducible with its seed
    r2 = propagate(lambda p: np.exp(p["a"] * X), d, n_samples=4000, seed=3)
    np.testing.assert_array_equal(r.high(), r2.high())


def test_log_scale_parameter_never_goes_negative_and_gives_lognormal_quantiles():
    """b = 2 with a 60 % standard error on a log scale: draws are log-normal, so the band of
    y = b is 2 exp(+-1.96 0.6) (a symmetric one would go to -0.35)."""
    d = ParameterDistribution.from_covariance(("b",), [2.0], [[(0.6 * 2.0) ** 2]],
                                              log_scale=["b"])
    r = propagate(lambda p: np.array([p["b"]]), d, n_samples=4000, seed=1)
    # monotone in one parameter: the quadratic through -t and +t holds the band's edges
    assert r.method == "second-order" and r.n_evaluations <= 8
    assert r.low()[0] > 0
    assert r.low()[0] == pytest.approx(2.0 * math.exp(-Z95 * 0.6), rel=0.05)
    assert r.high()[0] == pytest.approx(2.0 * math.exp(Z95 * 0.6), rel=0.05)


def test_vectorised_model_gives_the_same_band():
    C = np.array([[0.04, 0.0], [0.0, 0.09]])
    d = ParameterDistribution.from_covariance(("a", "b"), [1.0, 0.5], C)

    def vec(p):
        return np.asarray(p["a"])[:, None] + np.asarray(p["b"])[:, None] * X[None, :]

    a = propagate(_line, d)
    b = propagate(vec, d, vectorized=True)
    np.testing.assert_allclose(a.high(), b.high(), rtol=1e-12)


def test_derived_quantity_and_class_probabilities():
    """The slope of y = a + b x, derived from the outputs, is b: P(b < 0.3), P(0.3..0.7),
    P(b > 0.7) for b ~ N(0.5, 0.3^2) are the normal probabilities."""
    d = ParameterDistribution.from_covariance(("a", "b"), [1.0, 0.5], np.diag([0.04, 0.09]))
    r = propagate(_line, d)
    slope = r.derive(lambda o: (o["value"][-1] - o["value"][0]) / (X[-1] - X[0]))
    assert slope.method == "linear"
    assert float(slope.sd["value"]) == pytest.approx(0.3, rel=1e-9)
    p = slope.class_probabilities((0.3, 0.7))
    exact = [norm.cdf(-0.2 / 0.3), norm.cdf(0.2 / 0.3) - norm.cdf(-0.2 / 0.3), norm.sf(0.2 / 0.3)]
    np.testing.assert_allclose(p, exact, atol=1e-9)
    # the sampled version agrees within its sampling error
    s = propagate(_line, d, method="sampling", n_samples=4000, seed=2)
    ps = s.derive(lambda o: (o["value"][-1] - o["value"][0]) / (X[-1] - X[0])
                  ).class_probabilities((0.3, 0.7))
    np.testing.assert_allclose(ps, exact, atol=0.03)


def test_dominant_parameter_is_the_one_with_the_large_effect():
    d = ParameterDistribution.from_covariance(("a", "b"), [1.0, 0.5], np.diag([1e-6, 0.09]))
    r = propagate(_line, d)
    dom = r.dominant()
    assert dom[0][0] == "b" and dom[0][1] > 0.99 and len(dom) == 1


def test_bad_distributions_are_refused():
    with pytest.raises(ValueError, match="symmetric"):
        ParameterDistribution.from_covariance(("a", "b"), [1, 2], [[1, 0.5], [0, 1]])
    with pytest.raises(ValueError, match="log scale"):
        ParameterDistribution.from_covariance(("a",), [-1.0], [[1.0]], log_scale=["a"])
    with pytest.raises(ValueError, match="2 names"):
        ParameterDistribution.from_covariance(("a", "b"), [1.0], [[1.0]])
    with pytest.raises(ValueError, match="finite"):
        ParameterDistribution.from_covariance(("a",), [1.0], [[math.inf]])


def test_a_model_that_fails_for_many_draws_is_a_numerical_error():
    d = ParameterDistribution.from_covariance(("a",), [0.0], [[1.0]])

    def fragile(p):
        if p["a"] > 0.5:
            raise NumericalError("out of range")
        return np.array([p["a"] ** 3])

    with pytest.raises(NumericalError, match="failed for"):
        propagate(fragile, d, method="sampling", n_samples=200)


def test_fit_result_distribution_round_trip_matches_the_ols_closed_form():
    """A film fit's covariance (written in SI with the prefactor on a log scale) read back as a
    distribution gives, for ln h = ln C + n ln v, exactly the ordinary least-squares band
    s^2 [1, x] (X^T X)^-1 [1, x]^T computed here with numpy."""
    from torlab.fit.film import fit_film_thickness

    v = np.geomspace(0.05, 2.0, 12)
    lnh = np.log(40e-9) + 0.67 * np.log(v) + 0.03 * np.random.default_rng(3).standard_normal(12)
    res = fit_film_thickness(v, np.exp(lnh))
    assert res.meta["noise_model"].startswith("constant")
    dist = res.distribution()
    assert set(dist.log_scale) == {"film_prefactor"}
    x = np.log(np.array([0.02, 0.3, 5.0]))
    band = propagate(lambda p: np.log(p["film_prefactor"]) + p["speed_exponent"] * x, dist)
    X = np.column_stack((np.ones(v.size), np.log(v)))
    _, rss, *_ = np.linalg.lstsq(X, lnh, rcond=None)
    C = rss[0] / (v.size - 2) * np.linalg.inv(X.T @ X)
    A = np.column_stack((np.ones(x.size), x))
    np.testing.assert_allclose(band.sd["value"], np.sqrt(np.einsum("ij,jk,ik->i", A, C, A)),
                               rtol=1e-6)
    half = student.ppf(0.975, v.size - 2) * band.sd["value"]
    np.testing.assert_allclose(band.high() - band.center["value"], half, rtol=1e-9)


def test_shares_of_a_large_correlated_group_average_random_orders(monkeypatch):
    """A group beyond the exact enumeration is averaged over random orders: each order's
    contributions add up to the group's variance, so the shares still sum to 1, and they
    agree with the exact enumeration of the same group."""
    import torlab.uncertainty as u

    rng = np.random.default_rng(5)
    k = 11
    A = rng.normal(size=(k, k))
    C = A @ A.T / k + 0.1 * np.eye(k)
    g = rng.normal(size=(k, 3))
    var = np.einsum("it,ij,jt->t", g, C, g)
    sampled = u.shapley_shares(g, C, var)
    assert np.all(sampled >= 0)
    np.testing.assert_allclose(sampled.sum(axis=0), 1.0, atol=1e-10)
    monkeypatch.setattr(u, "_SHAPLEY_EXACT", k)
    exact = u.shapley_shares(g, C, var)
    np.testing.assert_allclose(exact.sum(axis=0), 1.0, atol=1e-10)
    np.testing.assert_allclose(sampled, exact, atol=0.02)


def test_second_order_band_of_a_lognormal_curve_matches_its_exact_quantiles():
    """y(x) = exp(a + b x) with (a, b) correlated normal: y(x) is log-normal, its 95 % band
    exactly exp(m(x) +- 1.96 s(x)) with s^2 = var(a + b x).  Far from linear over the band
    (eta > 0.1), so the automatic choice takes the model's curvature: its band edges within
    0.15 half-widths of the exact ones, from at most 12 model evaluations (400 random
    draws give about 0.18 here)."""
    x = np.linspace(0.0, 1.0, 21)
    C = np.array([[0.09, -0.03], [-0.03, 0.16]])
    d = ParameterDistribution.from_covariance(("a", "b"), [0.2, 0.5], C)
    r = propagate(lambda p: np.exp(p["a"] + p["b"] * x), d, seed=1)
    assert r.method == "second-order" and r.nonlinearity > 0.1 and r.n_evaluations <= 12
    s = np.sqrt(C[0, 0] + 2 * C[0, 1] * x + C[1, 1] * x**2)
    lo, hi = np.exp(0.2 + 0.5 * x - Z95 * s), np.exp(0.2 + 0.5 * x + Z95 * s)
    err = np.maximum(np.abs(r.low() - lo), np.abs(r.high() - hi)) / (0.5 * (hi - lo))
    assert float(np.max(err)) <= 0.15
    assert r.summary()["quadratic_draws"] > 0
    # the parameters' shares add up to the part of the variance linear in them: for a
    # log-normal y = exp(L), corr(y, L)^2 = s^2 / (exp(s^2) - 1)
    total = sum(r.contributions["value"].values())
    np.testing.assert_allclose(total, s**2 / np.expm1(s**2), atol=0.05)


def test_lattice_draws_have_the_distributions_moments():
    """The quasi-random draws of the second-order method: mean and covariance of the
    distribution (normal block) to well within a random sample's scatter."""
    from torlab.uncertainty import _lattice_draws

    C = np.array([[4.0, 1.2], [1.2, 1.0]])
    d = ParameterDistribution.from_covariance(("a", "b"), [1.0, -2.0], C)
    z = _lattice_draws(d, 4096, 3)
    np.testing.assert_allclose(z.mean(axis=0), [1.0, -2.0], atol=0.01)
    np.testing.assert_allclose(np.cov(z.T), C, rtol=0.02, atol=0.02)
