"""Asperity contact: F_n against mpmath and closed forms, Greenwood–Williamson pressures."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from scipy.special import ndtr

from torlab.errors import NumericalError, TorlabInputError
from torlab.model.asperity import (
    F_n,
    F_n_exact,
    F_n_inverse,
    F_n_pbdv,
    F_n_thesis_quadrature,
    FnOverflowError,
    Roughness,
    h_star,
    p_a_elastic,
    p_a_plastic,
    roughness_K,
)

# Paper A, Tab. 5.1 (SI units)
SMOOTH = dict(sigma=8.3e-9, beta=0.301e-3, gamma=24_200e6)
ROUGH = dict(sigma=9.56e-9, beta=0.373e-3, gamma=21_500e6)


def _mp_quad(n: float, t: float) -> float:
    """Eq. 5.43 by mpmath.quad at 40 digits: int_0^inf x^n exp(-(x+t)^2/2) dx / sqrt(2 pi)."""
    with mpmath.workdps(40):
        n_, t_ = mpmath.mpf(n), mpmath.mpf(t)
        if t_ < 0:  # a Gaussian bump at x = -t
            pts = [0, -t_, -t_ + 2, -t_ + 8, mpmath.inf]
            val = mpmath.quad(lambda x: x**n_ * mpmath.exp(-(x + t_) ** 2 / 2), pts)
        else:  # e^(-t^2/2) int x^n e^(-t x - x^2/2) dx: the scale is 1/t near 0
            sc = 1 / (t_ + 1)
            pts = [0, sc, 4 * sc, 1, 4, mpmath.inf]
            val = mpmath.exp(-t_ * t_ / 2) * mpmath.quad(
                lambda x: x**n_ * mpmath.exp(-t_ * x - x * x / 2), pts)
        return float(val / mpmath.sqrt(2 * mpmath.pi))


def _mp_pcfd(n: float, t: float) -> float:
    """The parabolic-cylinder form Gamma(n+1)/sqrt(2 pi) e^(-t^2/4) D_-(n+1)(t), 40 digits."""
    with mpmath.workdps(40):
        n_, t_ = mpmath.mpf(n), mpmath.mpf(t)
        return float(mpmath.gamma(n_ + 1) / mpmath.sqrt(2 * mpmath.pi)
                     * mpmath.exp(-t_ * t_ / 4) * mpmath.pcfd(-(n_ + 1), t_))


T_REF = [-40.0, -10.0, -3.0, -0.5, 0.0, 0.7, 2.0, 5.0, 6.0, 8.5, 10.0, 15.0, 30.0]


@pytest.mark.parametrize("n", [1.5, 4.0])
def test_F_n_against_mpmath_quad(n):
    ref = np.array([_mp_quad(n, t) for t in T_REF])
    for f in (F_n, F_n_exact):
        got = f(n, np.array(T_REF))
        np.testing.assert_allclose(got, ref, rtol=1e-10, atol=0)


@pytest.mark.parametrize("n", [0.3, 2.5, 7.25])
def test_F_n_general_order_against_mpmath_pcfd(n):
    ts = [-25.0, -6.0, -1.0, 0.0, 1.0, 4.5, 6.0, 9.0, 20.0]
    ref = np.array([_mp_pcfd(n, t) for t in ts])
    np.testing.assert_allclose(F_n(n, np.array(ts)), ref, rtol=1e-10, atol=0)
    np.testing.assert_allclose(F_n_exact(n, np.array(ts)), ref, rtol=1e-10, atol=0)


def test_mpmath_references_agree():
    # the two independent references agree: guards the test's own reference
    for t in (-10.0, 0.0, 6.0, 15.0, 30.0):
        assert _mp_quad(1.5, t) == pytest.approx(_mp_pcfd(1.5, t), rel=1e-13)


def test_integer_orders_closed_forms():
    t = np.linspace(-3.0, 3.0, 61)
    Q = ndtr(-t)
    phi = np.exp(-0.5 * t * t) / math.sqrt(2 * math.pi)
    np.testing.assert_allclose(F_n(0, t), Q, rtol=1e-12)
    np.testing.assert_allclose(F_n(1, t), phi - t * Q, rtol=1e-12)
    np.testing.assert_allclose(F_n(4, t), (t**4 + 6 * t**2 + 3) * Q - (t**3 + 5 * t) * phi,
                               rtol=1e-11)
    # F_n(0) = 2^((n-1)/2) Gamma((n+1)/2) / sqrt(2 pi): F_4(0) = 3/2, F_3/2(0) = 0.4299...
    assert float(F_n(4, 0.0)) == pytest.approx(1.5, rel=1e-14)
    assert float(F_n(1.5, 0.0)) == pytest.approx(
        2**0.25 * math.gamma(1.25) / math.sqrt(2 * math.pi), rel=1e-13)


@pytest.mark.parametrize("n", [0.0, 1.5, 2.5, 4.0])
def test_F_n_finite_nonnegative_monotone_dense_grid(n):
    t = np.linspace(-60.0, 60.0, 24001)
    f = F_n(n, t)
    assert np.all(np.isfinite(f))
    assert np.all(f >= 0)
    assert np.all(np.diff(f) <= 1e-14 * f[1:])  # d F_n/dt = -n F_(n-1) <= 0, up to rounding
    assert np.all(f[t >= 39.0] == 0.0)  # underflows to 0, not NaN
    # F_n(t) ~ |t|^n for t -> -inf (moment series region)
    assert float(F_n(n, -60.0)) == pytest.approx(60.0**n * (1 + n * (n - 1) / 2 / 3600 + 0),
                                                 rel=1e-6)


def test_F_n_extreme_and_special_arguments():
    assert float(F_n(1.5, 1e300)) == 0.0
    assert float(F_n(4, np.inf)) == 0.0
    assert np.isnan(F_n(4, np.nan))
    assert float(F_n(1.5, -1e100)) == pytest.approx(1e150, rel=1e-12)
    with pytest.raises(FnOverflowError) as err:
        F_n(4, -1e100)
    assert isinstance(err.value, NumericalError)
    with pytest.raises(FnOverflowError):
        F_n_exact(4, -np.inf)
    with pytest.raises(ValueError):
        F_n(-0.5, 0.0)


def test_F_n_shapes():
    t = np.linspace(-5, 5, 12).reshape(3, 4)
    assert F_n(1.5, t).shape == (3, 4)
    assert np.ndim(F_n(1.5, 0.3)) == 0
    np.testing.assert_allclose(F_n(1.5, t), F_n_exact(1.5, t), rtol=1e-12)
    assert F_n(4, np.array([])).shape == (0,)


def test_pbdv_form_matches_where_pbdv_is_accurate():
    t = np.linspace(-5.0, 3.0, 33)
    np.testing.assert_allclose(F_n_pbdv(4.0, t), F_n_exact(4.0, t), rtol=1e-12)
    np.testing.assert_allclose(F_n_pbdv(1.5, t), F_n_exact(1.5, t), rtol=1e-12)


def test_thesis_quadrature_is_a_rough_approximation():
    # the baseline: 1000 trapezoidal steps up to 30 -- right to a few 1e-5, not to 1e-10
    t = np.array([-3.0, 0.0, 2.0])
    for n in (1.5, 4.0):
        ref = F_n_exact(n, t)
        err = np.abs(F_n_thesis_quadrature(n, t) / ref - 1)
        assert np.all(err < 1e-3)
    assert float(F_n_thesis_quadrature(4.0, 31.0)) == 0.0


@pytest.mark.parametrize("n", [1.5, 4.0])
def test_F_n_inverse(n):
    t = np.array([-30.0, -4.0, -0.3, 0.0, 1.0, 5.0, 20.0])
    y = F_n_exact(n, t)
    np.testing.assert_allclose(F_n_inverse(n, y), t, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(F_n_inverse(n, y[2:4]), t[2:4], atol=1e-12)  # vector path


def test_K_table_5_1():
    assert roughness_K(**SMOOTH) == pytest.approx(0.0605, abs=5e-5)
    assert roughness_K(**ROUGH) == pytest.approx(0.0767, abs=5e-5)
    assert Roughness(SMOOTH["sigma"], SMOOTH["beta"], SMOOTH["gamma"], "elastic").K == \
        pytest.approx(8.3e-9 * 0.301e-3 * 24_200e6)


def test_elastic_pressure_hand_value_and_dimensions():
    E = 100e9
    # at h = 0: p_a = 4/3 K E* sqrt(psi/beta) F_3/2(0), F_3/2(0) = 2^(1/4) Gamma(5/4)/sqrt(2 pi)
    K = 8.3e-9 * 0.301e-3 * 24_200e6
    F32_0 = 2**0.25 * math.gamma(1.25) / math.sqrt(2 * math.pi)
    hand = 4 / 3 * K * E * math.sqrt(8.3e-9 / 0.301e-3) * F32_0
    assert float(p_a_elastic(0.0, **SMOOTH, E_star=E)) == pytest.approx(hand, rel=1e-13)
    # dimensional consistency: scaling every length by 10 (gamma by 1/100) keeps p_a(h);
    # the printed thesis form (sqrt(psi/gamma)) would change by a factor 10^1.5
    h = np.array([-2e-8, 0.0, 1e-8])
    p1 = p_a_elastic(h, **SMOOTH, E_star=E)
    p10 = p_a_elastic(10 * h, SMOOTH["sigma"] * 10, SMOOTH["beta"] * 10, SMOOTH["gamma"] / 100,
                      E_star=E)
    np.testing.assert_allclose(p10, p1, rtol=1e-13)


def test_plastic_pressure_hand_value():
    H = 6e9
    K = 9.56e-9 * 0.373e-3 * 21_500e6
    # F_4(0) = 3/2  ->  p_a(0) = (2/3) pi^2 H K^2 (3/2) = pi^2 H K^2
    assert float(p_a_plastic(0.0, **ROUGH, H=H)) == pytest.approx(math.pi**2 * H * K**2,
                                                                 rel=1e-13)
    assert float(p_a_plastic(1e-6, **ROUGH, H=H)) == 0.0  # Lambda ~ 100: no contact


def test_h_star():
    rough = Roughness(ROUGH["sigma"], ROUGH["beta"], ROUGH["gamma"], "plastic", hardness=6e9)
    model = rough.asperity_model()
    F, a, b = 90.0, 2.4e-4, 2.0e-4
    hs = h_star(F, a, b, model)
    assert float(model.load(hs, a, b)) == pytest.approx(F, rel=1e-12)
    assert model.h_star(F, a, b) == hs


def test_roughness_validation():
    with pytest.raises(TorlabInputError) as err:
        Roughness(0.0, 1e-4, 1e10)
    assert err.value.key == "roughness.sigma"
    assert "\n" not in str(err.value)
    with pytest.raises(TorlabInputError):
        Roughness(-1e-9, 1e-4, 1e10, "elastic")
    with pytest.raises(TorlabInputError) as err:
        Roughness(1e-8, 1e-4, 1e10, "plastic")  # no hardness
    assert err.value.key == "roughness.hardness"
    with pytest.raises(TorlabInputError):
        Roughness(1e-8, 1e-4, 1e10, "plastic", hardness=-1.0)
    with pytest.raises(TorlabInputError):
        Roughness(1e-8, 1e-4, 1e10, "viscous")
    with pytest.raises(TorlabInputError):
        Roughness(1e-8, 1e-4, 1e10, "elastic").asperity_model()  # needs E*
    with pytest.raises(TorlabInputError):
        p_a_elastic(0.0, 1e-8, 1e-4, np.nan, E_star=1e11)
