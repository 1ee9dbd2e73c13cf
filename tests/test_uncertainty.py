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
    # shares: g (C g) / var, summing to 1
    s = r.contributions["value"]
    np.testing.assert_allclose(s["a"] + s["b"], 1.0, atol=1e-12)
    i = 4
    g = np.array([1.0, X[i]])
    np.testing.assert_allclose(s["b"][i], g[1] * (C @ g)[1] / sd[i] ** 2, rtol=1e-10)


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
    assert r.method == "sampling"
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
