"""EHL film thickness and traction against hand values, quadrature and limits."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import dblquad

from torlab.errors import NumericalError, TorlabInputError
from torlab.model.ehl import (
    FilmThickness,
    Lubricant,
    NonPhysicalTractionError,
    ehl_groups,
    hc_iso,
    hc_piezo,
    mu_ehl,
    tau_ehl,
    tau_ehl_field,
)
from torlab.model.viscosity import roelands_alpha0


def test_hc_iso_hand_value():
    # E* = 100 GPa (E' = 2e11 Pa), rx = 10 mm, water eta0 = 1 mPa s, v = 0.1 m/s, F = 100 N
    # U = 1e-3 * 0.1 / (2e11 * 0.01) = 5e-14 ; W = 100 / (2e11 * 1e-4) = 5e-6
    # ln U = ln 5 - 14 ln 10 = -30.626753 ; 0.66 ln U = -20.213657 ; U^0.66 = 1.66464e-9
    # ln W = -12.206073 ; -0.21 ln W = 2.563275 ; W^-0.21 = 12.97825
    # hc = 5.08 * 1.66464e-9 * 12.97825 * 0.01 = 1.09749e-9 m
    U, _, W = ehl_groups(0.1, 100.0, 100e9, 0.01, 1e-3)
    assert float(U) == pytest.approx(5e-14, rel=1e-14)
    assert float(W) == pytest.approx(5e-6, rel=1e-14)
    hc = float(hc_iso(0.1, 100.0, 100e9, 0.01, 1e-3))
    assert hc == pytest.approx(5.08 * 1.66464e-9 * 12.97825 * 0.01, rel=1e-5)
    assert hc == pytest.approx(1.09749e-9, rel=1e-5)


def test_hc_piezo_hand_value():
    # Paper-B-like oil: E* = 100 GPa, rx = 10 mm, eta0 = 0.05 Pa s, alpha = 20 1/GPa, v = 1 m/s,
    # F = 20 N, circular (D = 1)
    # U = 0.05 / 2e9 = 2.5e-11 ; G = 2e-8 * 2e11 = 4000 ; W = 20 / 2e7 = 1e-6
    # U^0.67 = 7.88170e-8 ; G^0.53 = 81.1132 ; W^-0.067 = 2.52348 ; 1 - 0.61 e^-0.73 = 0.706036
    # hc = 2.69 * 7.88170e-8 * 81.1132 * 2.52348 * 0.706036 * 0.01 = 3.06401e-7 m
    hc = float(hc_piezo(1.0, 20.0, 100e9, 0.01, 0.05, 2e-8, D=1.0))
    assert hc == pytest.approx(2.69 * 7.88170e-8 * 81.1132 * 2.52348 * 0.706036 * 0.01, rel=2e-5)
    assert hc == pytest.approx(3.06401e-7, rel=1e-5)


def test_ellipticity_is_b_over_a():
    lub = Lubricant(0.05, "barus", alpha=2e-8)
    # a = 1 mm in the rolling direction, b = 2 mm transverse: D = b/a = 2
    wide = FilmThickness.from_contact(lub, 100e9, 0.01, a=1e-3, b=2e-3)
    narrow = FilmThickness.from_contact(lub, 100e9, 0.01, a=2e-3, b=1e-3)
    assert wide.D == 2.0 and narrow.D == 0.5
    ratio = float(wide.hc(1.0, 20.0) / narrow.hc(1.0, 20.0))
    assert ratio == pytest.approx((1 - 0.61 * math.exp(-0.73 * 2)) / (1 - 0.61 * math.exp(-0.73 * 0.5)),
                                  rel=1e-14)
    assert ratio > 1  # a contact wide across the rolling direction builds a thicker film
    # the iso-viscous formula has no ellipticity factor
    iso = Lubricant(1e-3)
    assert float(FilmThickness.from_contact(iso, 100e9, 0.01, 1e-3, 2e-3).hc(1.0, 20.0)) == \
        float(FilmThickness.from_contact(iso, 100e9, 0.01, 2e-3, 1e-3).hc(1.0, 20.0))


def test_film_defaults_and_roelands_alpha():
    assert Lubricant(1e-3).film_formula == "iso"
    assert Lubricant(0.05, "barus", alpha=2e-8).film_formula == "piezo"
    rl = Lubricant(0.05, "roelands", Z=0.6)
    assert rl.film_formula == "piezo"
    assert rl.film_alpha == pytest.approx(roelands_alpha0(0.05, 0.6))
    assert Lubricant(0.05, "barus", alpha=2e-8, film="iso").film_formula == "iso"
    # a piezo film for an iso-viscous liquid takes G from Z if no alpha is given
    assert Lubricant(0.05, film="piezo", Z=0.6).film_alpha == pytest.approx(
        roelands_alpha0(0.05, 0.6))
    # alpha = 0 is a valid (constant) Barus law with the iso film
    zero = Lubricant(0.05, "barus", alpha=0.0, film="iso", shear="limiting", gamma_L=0.1)
    assert float(mu_ehl(0.01, 1e-6, P0, zero)) == pytest.approx(
        float(mu_ehl(0.01, 1e-6, P0, Lubricant(0.05, shear="limiting", gamma_L=0.1))), rel=1e-12)


def test_hc_edges_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        film = FilmThickness("iso", 1e-3, 100e9, 0.01)
        v = np.array([0.0, 0.0, 1.0, 1.0])
        F = np.array([0.0, 10.0, 0.0, 10.0])
        hc = film.hc(v, F)
    assert hc[0] == 0.0 and hc[1] == 0.0
    assert hc[2] == np.inf
    assert 0 < hc[3] < np.inf
    # exact power laws
    assert float(film.hc(2.0, 10.0) / film.hc(1.0, 10.0)) == pytest.approx(2**0.66, rel=1e-14)
    assert float(film.hc(1.0, 20.0) / film.hc(1.0, 10.0)) == pytest.approx(2**-0.21, rel=1e-14)
    assert film.load_exponent == 0.21


# ---------------------------------------------------------------------------- traction

P0 = 1.0e9


def _mu_dblquad(lub: Lubricant, w: float, h: float, a: float, b: float, p0: float) -> float:
    """mu = int tau dA / int p dA over the ellipse, 2-D adaptive quadrature (scipy.dblquad).

    In elliptic polar coordinates x = a r cos(th), y = b r sin(th), dA = a b r dr dth,
    which keeps the integrand smooth up to the edge (r = 1).
    """

    def tau(r, th):
        p = p0 * math.sqrt(max(0.0, 1 - r * r))
        return float(tau_ehl(p, w, h, lub)) * a * b * r

    def press(r, th):
        return p0 * math.sqrt(max(0.0, 1 - r * r)) * a * b * r

    opts = dict(epsabs=0, epsrel=1e-9)
    T = dblquad(tau, 0, 2 * math.pi, 0, 1, **opts)[0]
    Fp = dblquad(press, 0, 2 * math.pi, 0, 1, **opts)[0]
    assert Fp == pytest.approx(2 / 3 * math.pi * a * b * p0, rel=1e-9)
    return T / Fp


def _mu_kinked_quad(lub: Lubricant, w: float, h: float, p0: float) -> float:
    """mu for the limiting law by 1-D adaptive quadrature (scipy.quad).

    Over the elliptic radius r = sin(th) (p = p0 cos th, smooth up to the edge):
    mu = int_0^(pi/2) tau(p0 cos th) 2 sin th cos th dth / (2 p0 / 3), split where
    eta(p) w/h = gamma_L p (kinks found by the test's own scan and brentq).
    """
    from scipy.integrate import quad
    from scipy.optimize import brentq

    def d(th):
        p = p0 * math.cos(th)
        return float(lub.log_eta(p)) + math.log(w / h) - math.log(lub.gamma_L * p)

    grid = np.linspace(0, math.pi / 2 - 1e-9, 4001)
    dv = np.array([d(x) for x in grid])
    kinks = [brentq(d, grid[i], grid[i + 1], xtol=1e-15)
             for i in np.flatnonzero(np.sign(dv[1:]) != np.sign(dv[:-1]))]
    edges = [0.0, *kinks, math.pi / 2]

    def f(th):
        return float(tau_ehl(p0 * math.cos(th), w, h, lub)) * 2 * math.sin(th) * math.cos(th)

    T = sum(quad(f, edges[i], edges[i + 1], epsabs=0, epsrel=1e-12, limit=200)[0]
            for i in range(len(edges) - 1))
    return T / (2 / 3 * p0)


def test_barus_newtonian_closed_form_against_2d_quadrature():
    lub = Lubricant(0.05, "barus", alpha=1e-8)  # c = alpha p0 = 10
    a, b = 3e-4, 1.5e-4
    ref = _mu_dblquad(lub, 0.01, 1e-6, a, b, P0)
    assert float(mu_ehl(0.01, 1e-6, P0, lub)) == pytest.approx(ref, rel=1e-7)
    # closed form by hand: mu = 3 eta0 w/(h p0) (e^c (c-1) + 1)/c^2
    c = 10.0
    hand = 3 * 0.05 * 0.01 / (1e-6 * P0) * (math.exp(c) * (c - 1) + 1) / c**2
    assert float(mu_ehl(0.01, 1e-6, P0, lub)) == pytest.approx(hand, rel=1e-13)


@pytest.mark.parametrize("c", [1e-9, 1e-3, 0.3, 0.5, 0.7, 40.0, 600.0])
def test_barus_closed_form_small_and_large_c(c):
    lub = Lubricant(0.05, "barus", alpha=c / P0)
    iso = float(mu_ehl(0.01, 1e-6, P0, Lubricant(0.05)))  # 3 eta0 w / (2 h p0)
    got = float(mu_ehl(0.01, 1e-6, P0, lub))
    # ratio to iso = 2 g(c), g(c) = (e^c (c - 1) + 1)/c^2, by mpmath-free reference:
    import mpmath

    with mpmath.workdps(50):
        cm = mpmath.mpf(c)
        g = (mpmath.exp(cm) * (cm - 1) + 1) / cm**2
    assert got / iso == pytest.approx(float(2 * g), rel=1e-13)


def test_roelands_newtonian_against_2d_quadrature():
    lub = Lubricant(0.05, "roelands", Z=0.6)
    a, b = 2e-4, 2e-4
    ref = _mu_dblquad(lub, 0.02, 5e-7, a, b, P0)
    assert float(mu_ehl(0.02, 5e-7, P0, lub)) == pytest.approx(ref, rel=1e-7)


def test_roelands_matches_barus_at_small_pressure():
    eta0, Z = 0.05, 0.6
    alpha_star = (math.log(eta0) + 9.67) * 5.1e-9 * Z  # initial slope, written out
    p0 = 1e5  # 0.1 MPa: alpha* p0 ~ 2e-3, the curvature of ln eta adds ~ (Z-1) b p0 / 2 of it
    r = float(mu_ehl(0.01, 1e-6, p0, Lubricant(eta0, "roelands", Z=Z)))
    bb = float(mu_ehl(0.01, 1e-6, p0, Lubricant(eta0, "barus", alpha=alpha_star)))
    assert r == pytest.approx(bb, rel=1e-6)
    assert r != bb
    # ... and not at 1 GPa
    r = float(mu_ehl(0.01, 1e-6, P0, Lubricant(eta0, "roelands", Z=Z)))
    bb = float(mu_ehl(0.01, 1e-6, P0, Lubricant(eta0, "barus", alpha=alpha_star)))
    assert abs(r / bb - 1) > 0.1


@pytest.mark.parametrize("visc,kw", [("iso", {}), ("barus", {"alpha": 2e-8}),
                                     ("roelands", {"Z": 0.6})])
def test_limiting_law(visc, kw):
    gL = 0.08
    lub = Lubricant(0.05, visc, shear="limiting", gamma_L=gL, **kw)
    newton = Lubricant(0.05, visc, **kw)
    w = np.geomspace(1e-9, 1e4, 60)
    mu = mu_ehl(w, 1e-7, P0, lub)
    assert np.all(mu <= gL * (1 + 1e-14))
    assert np.all(np.diff(mu) >= 0)
    assert float(mu[-1]) == pytest.approx(gL, rel=1e-3)
    assert float(mu[0]) == pytest.approx(float(mu_ehl(w[0], 1e-7, P0, newton)), rel=1e-9)
    # against adaptive quadrature split at the kinks, at kinked cases
    for ww, hh in ((0.01, 1e-7), (1.0, 1e-7), (0.02, 5e-8), (300.0, 1e-7)):
        ref = _mu_kinked_quad(lub, ww, hh, P0)
        assert float(mu_ehl(ww, hh, P0, lub)) == pytest.approx(ref, rel=1e-10)
    # no film: the limiting stress everywhere
    assert float(mu_ehl(1.0, 0.0, P0, lub)) == pytest.approx(gL, rel=1e-14)


@pytest.mark.parametrize("visc,kw", [("iso", {}), ("barus", {"alpha": 2e-8}),
                                     ("roelands", {"Z": 0.6})])
def test_eyring_tends_to_newtonian_at_small_stress(visc, kw):
    ey = Lubricant(0.05, visc, shear="eyring", tau0=1e15, **kw)
    nw = Lubricant(0.05, visc, **kw)
    assert float(mu_ehl(1e-4, 1e-6, P0, ey)) == pytest.approx(
        float(mu_ehl(1e-4, 1e-6, P0, nw)), rel=1e-9)
    # and is much lower at large stress
    ey = Lubricant(0.05, visc, shear="eyring", tau0=5e6, **kw)
    assert float(mu_ehl(1e3, 1e-7, P0, ey)) < 0.2 * float(mu_ehl(1e3, 1e-7, P0, nw))


def test_eyring_stress_hand_values():
    lub = Lubricant(0.05, "barus", alpha=2e-8, shear="eyring", tau0=5e6)
    p = np.array([0.0, 1e8, 5e8, 1e9, 2e9])
    w, h = 0.3, 1e-7
    eta = 0.05 * np.exp(2e-8 * p)
    hand = 5e6 * np.arcsinh(eta * w / (h * 5e6))
    hand[0] = 0.0  # no contact pressure: no stress
    np.testing.assert_allclose(tau_ehl(p, w, h, lub), hand, rtol=1e-13)
    # asinh x = ln(2x) + 1/(4x^2) - ...: the log form far out
    big = Lubricant(0.05, "barus", alpha=1e-7, shear="eyring", tau0=5e6)
    lx = math.log(0.05) + 1e-7 * 5e9 + math.log(w / h / 5e6)
    assert float(tau_ehl(5e9, w, h, big)) == pytest.approx(5e6 * (math.log(2) + lx), rel=1e-14)


@pytest.mark.parametrize("lub", [Lubricant(0.05, "barus", alpha=2e-8),
                                 Lubricant(0.05, "roelands", Z=0.6, shear="eyring", tau0=5e6),
                                 Lubricant(0.05, "barus", alpha=2e-8, shear="limiting",
                                           gamma_L=0.1)])
def test_mu_ehl_is_odd_in_w(lub):
    wp = np.linspace(0.0, 0.05, 51)[1:]
    w = np.concatenate([-wp[::-1], [0.0], wp])
    mu = mu_ehl(w, 1e-7, P0, lub)
    np.testing.assert_array_equal(mu, -mu[::-1])
    assert mu[50] == 0.0


def test_mu_ehl_broadcasts_w_and_h():
    lub = Lubricant(0.05, "barus", alpha=2e-8, shear="eyring", tau0=5e6)
    w = np.array([0.001, 0.01, 0.1])
    h = np.array([[1e-7], [2e-7]])
    mu = mu_ehl(w, h, P0, lub)
    assert mu.shape == (2, 3)
    assert mu[1, 2] == pytest.approx(float(mu_ehl(0.1, 2e-7, P0, lub)), rel=1e-14)


def test_newtonian_overflow_is_a_named_error():
    lub = Lubricant(10.0, "barus", alpha=1e-7)  # alpha p0 = 1000 at 10 GPa
    with pytest.raises(NonPhysicalTractionError) as err:
        mu_ehl(1.0, 1e-8, 1e10, lub)
    assert isinstance(err.value, NumericalError)
    assert err.value.exit_code == 3
    assert "limiting" in str(err.value) and "eyring" in str(err.value)
    assert "\n" not in str(err.value)
    with pytest.raises(NonPhysicalTractionError):
        tau_ehl_field(0.0, 0.0, 1.0, 1e-8, 1e-3, 1e-3, 1e10, lub)
    # the same contact with a limiting stress or Eyring is fine
    for shear, kw in (("limiting", {"gamma_L": 0.08}), ("eyring", {"tau0": 5e6})):
        ok = Lubricant(10.0, "barus", alpha=1e-7, shear=shear, **kw)
        assert np.isfinite(float(mu_ehl(1.0, 1e-8, 1e10, ok)))
    # a finite Newtonian value is returned even if large
    big = float(mu_ehl(1.0, 1e-8, 1e9, Lubricant(10.0, "barus", alpha=1e-7)))
    assert np.isfinite(big) and big > 1e10


def test_tau_field():
    lub = Lubricant(0.05, "barus", alpha=2e-8)
    a, b, w, h = 2e-4, 1e-4, 0.01, 1e-7
    # centre: eta(p0) w / h
    assert float(tau_ehl_field(0.0, 0.0, w, h, a, b, P0, lub)) == pytest.approx(
        0.05 * math.exp(2e-8 * P0) * w / h, rel=1e-13)
    # outside the ellipse and on its edge: no stress
    assert float(tau_ehl_field(a, 0.0, w, h, a, b, P0, lub)) == 0.0
    assert float(tau_ehl_field(0.0, 2 * b, w, h, a, b, P0, lub)) == 0.0
    # the field integrated on a fine midpoint grid gives mu_EHL * F
    n = 1200
    x = (np.arange(n) + 0.5) / n * 2 * a - a
    y = (np.arange(n) + 0.5) / n * 2 * b - b
    X, Y = np.meshgrid(x, y)
    dA = (2 * a / n) * (2 * b / n)
    T = tau_ehl_field(X, Y, w, h, a, b, P0, lub).sum() * dA
    F = 2 / 3 * math.pi * a * b * P0
    assert T / F == pytest.approx(float(mu_ehl(w, h, P0, lub)), rel=2e-3)
    # sign follows w
    assert float(tau_ehl_field(0.0, 0.0, -w, h, a, b, P0, lub)) < 0


@pytest.mark.parametrize("kwargs,key", [
    ({"eta0": -1e-3}, "lubricant.eta0"),
    ({"eta0": 0.0}, "lubricant.eta0"),
    ({"eta0": 0.05, "viscosity": "roelands", "Z": 0.0}, "lubricant.Z"),
    ({"eta0": 0.05, "viscosity": "roelands", "Z": -0.5}, "lubricant.Z"),
    ({"eta0": 0.05, "viscosity": "roelands"}, "lubricant.Z"),
    ({"eta0": 1e-5, "viscosity": "roelands", "Z": 0.6}, "lubricant.eta0"),
    ({"eta0": 0.05, "viscosity": "barus"}, "lubricant.alpha"),
    ({"eta0": 0.05, "viscosity": "barus", "alpha": -1e-8}, "lubricant.alpha"),
    ({"eta0": 0.05, "viscosity": "cross"}, "lubricant.viscosity"),
    ({"eta0": 0.05, "shear": "limiting"}, "lubricant.gamma_L"),
    ({"eta0": 0.05, "shear": "eyring", "tau0": 0.0}, "lubricant.tau0"),
    ({"eta0": 0.05, "film": "piezo"}, "lubricant.alpha"),
    ({"eta0": 0.05, "viscosity": "barus", "alpha": 0.0}, "lubricant.alpha"),  # piezo: G = 0
])
def test_lubricant_validation(kwargs, key):
    with pytest.raises(TorlabInputError) as err:
        Lubricant(**kwargs)
    assert err.value.key == key
    assert "\n" not in str(err.value)
    assert err.value.exit_code == 2


def test_traction_and_film_argument_validation():
    lub = Lubricant(1e-3)
    with pytest.raises(TorlabInputError):
        mu_ehl(0.1, -1e-9, P0, lub)
    with pytest.raises(TorlabInputError):
        mu_ehl(0.1, 1e-9, -P0, lub)
    with pytest.raises(TorlabInputError):
        hc_iso(-1.0, 10.0, 1e11, 0.01, 1e-3)
    with pytest.raises(TorlabInputError):
        hc_iso(1.0, -10.0, 1e11, 0.01, 1e-3)
    with pytest.raises(TorlabInputError):
        hc_iso(1.0, 10.0, 1e11, 0.01, -1e-3)
    with pytest.raises(TorlabInputError):
        FilmThickness("iso", 1e-3, 1e11, 0.0)
