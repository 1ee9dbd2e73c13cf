"""Boundary model: Hertz, Kalker C11, FASTSIM with the layer, temperature.

References are independent of the code under test: Johnson's closed relations with
elliptic integrals computed here by quadrature, Kalker's table, Kalker's linear
theory, the closed form of continuous classic FASTSIM, full slip, the grid-free
reference (ODE + adaptive quadrature), the flash-temperature anchor of the notes.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from torlab.errors import ConvergenceError
from torlab.model.fastsim import FastsimGrid, FastsimProblem, boundary_traction
from torlab.model.flash import ThermalParams, flash_temperature_matrix
from torlab.model.hertz import E_star, hertz_approximate, hertz_exact
from torlab.model.kalker import C11, ExtremeContactWarning, combined_G_nu
from torlab.model.layers import LayerParams
from torlab.model.reference_solvers import boundary_traction_reference
from torlab.model.strip import e_strip

G_STEEL, NU = combined_G_nu(210e9, 0.28, 210e9, 0.28)


def problem(ab: float, layer: LayerParams, *, b: float = 3.3e-3, p0: float = 0.78e9,
            thermal: ThermalParams | None = None, speed: float = 10.0) -> FastsimProblem:
    a = ab * b
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtremeContactWarning)
        c11 = C11(a / b, NU)
    return FastsimProblem(a=a, b=b, p0=p0, L1=8 * a / (3 * c11 * G_STEEL), layer=layer,
                          speed=speed, thermal=thermal)


WR_LAYER = LayerParams(0.30, 0.45, 10e-6, 20e-6)


# ---------------------------------------------------------------------------------------
# Hertz
# ---------------------------------------------------------------------------------------
def _K_E(e2: float) -> tuple[float, float]:
    from scipy.integrate import quad

    K = quad(lambda t: 1 / math.sqrt(1 - e2 * math.sin(t) ** 2), 0, math.pi / 2, epsabs=0,
             epsrel=1e-13)[0]
    E = quad(lambda t: math.sqrt(1 - e2 * math.sin(t) ** 2), 0, math.pi / 2, epsabs=0,
             epsrel=1e-13)[0]
    return K, E


@pytest.mark.parametrize("rx, ry", [(0.35, 0.30), (0.05, 0.01), (0.01, 0.05), (0.46, 0.0127)])
def test_exact_hertz_satisfies_johnson_relations(rx, ry):
    """Johnson (1985) Eq. 4.39: the relative curvatures from p0, a, b and K(e), E(e)."""
    Es = E_star(210e9, 0.3, 210e9, 0.3)
    F = 1000.0
    p = hertz_exact(F, rx, ry, Es)
    big, small = max(p.a, p.b), min(p.a, p.b)
    e2 = 1 - (small / big) ** 2
    K, E = _K_E(e2)
    A = p.p0 / Es * small / (e2 * big**2) * (K - E)  # curvature along the long axis
    B = p.p0 / Es * small / (e2 * big**2) * ((big / small) ** 2 * E - K)
    r_long, r_short = (rx, ry) if p.a >= p.b else (ry, rx)
    assert A == pytest.approx(1 / (2 * r_long), rel=1e-9)
    assert B == pytest.approx(1 / (2 * r_short), rel=1e-9)
    assert p.p0 == pytest.approx(3 * F / (2 * math.pi * p.a * p.b))


def test_circular_hertz_closed_form():
    Es = E_star(210e9, 0.3, 82e9, 0.206)
    R = 12.7e-3
    p = hertz_exact(90.0, R, R, Es)  # ball on a flat: relative radii rx = ry = R
    a = (3 * 90.0 * R / (4 * Es)) ** (1 / 3)  # Johnson Eq. 4.22
    assert p.a == pytest.approx(a, rel=1e-12) and p.b == pytest.approx(a, rel=1e-12)


def test_approximate_hertz_close_to_exact_and_roles_swap():
    Es = E_star(210e9, 0.28, 210e9, 0.28)
    for rx, ry in [(0.35, 0.30), (0.5, 0.05), (0.05, 0.5)]:
        ap, ex = hertz_approximate(20e3, rx, ry, Es), hertz_exact(20e3, rx, ry, Es)
        assert ap.a == pytest.approx(ex.a, rel=0.05)
        assert ap.b == pytest.approx(ex.b, rel=0.05)
        assert (ap.a > ap.b) == (ex.a > ex.b) == (rx > ry)


# ---------------------------------------------------------------------------------------
# Kalker
# ---------------------------------------------------------------------------------------
def test_C11_published_checks_and_table_points():
    assert C11(0.5, 0.28) == pytest.approx(3.7335, abs=5e-5)
    assert C11(1.0, 0.28) == pytest.approx(4.2262, abs=5e-5)
    assert C11(2.0, 0.28) == pytest.approx(5.2037, abs=5e-5)
    # table nodes are reproduced exactly (a/b = 0.3 and b/a = 0.3, nu = 0.25)
    assert C11(0.3, 0.25) == pytest.approx(3.44, abs=1e-12)
    assert C11(1 / 0.3, 0.25) == pytest.approx(6.34, abs=1e-12)


@pytest.mark.parametrize("name", ["C11", "C22", "C23", "C33"])
def test_log_pchip_interpolation_is_scipys_pchip_of_log_c_over_log_g(name):
    """The smooth interpolation of Kalker's table is SciPy's monotone cubic (PCHIP) of
    ln C over ln g, column by column, then CONTACT's rule in nu; it passes through the
    table's rows, where it equals the linear interpolation."""
    from scipy.interpolate import PchipInterpolator

    from torlab.model import kalker

    nu = 0.28
    rows = np.round(np.arange(0.1, 1.0001, 0.1), 10)
    for half, abs_ in ((0, lambda g: g), (1, lambda g: 1 / g)):
        table = kalker._TABLES[name][half]
        fits = [PchipInterpolator(np.log(kalker._G), np.log(table[:, k])) for k in range(3)]
        for g in np.linspace(0.1, 1.0, 37):
            cols = [math.exp(float(f(math.log(g)))) for f in fits]
            ref = kalker._nu_interp(*cols, nu)
            got = kalker._coefficient(name, abs_(g), nu, False, "log-pchip")
            assert got == pytest.approx(ref, rel=1e-12)
        for g in rows:
            assert kalker._coefficient(name, abs_(g), nu, False, "log-pchip") == pytest.approx(
                kalker._coefficient(name, abs_(g), nu, False, "linear"), rel=1e-12)


def test_interpolation_argument_checked():
    with pytest.raises(ValueError, match="interpolation"):
        C11(2.0, 0.28, interpolation="cubic")
    # between the rows b/a = 0.2 and 0.3 the linear rule lies above the smooth one
    assert C11(4.2, 0.28) / C11(4.2, 0.28, interpolation="log-pchip") - 1 > 0.015


def test_C11_extreme_ellipse_warns_and_uses_asymptote():
    with pytest.warns(ExtremeContactWarning):
        c = C11(0.05, 0.3)
    assert c == pytest.approx(math.pi**2 / (4 * 0.7))


# ---------------------------------------------------------------------------------------
# FASTSIM against exact limits
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("ab", [0.2, 1.0, 5.0])
def test_kalker_linear_theory_slope(ab):
    """No layer, small creepage: Fx = G a b C11 xi (Kalker's linear theory) within 0.1 %."""
    prob = problem(ab, LayerParams(0.3, 0.3, 0.0, 0.0))
    xi = 1e-7
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExtremeContactWarning)
        c11 = C11(ab, NU)
    Fx = boundary_traction(prob, [xi]).mu[0] * prob.load
    assert Fx == pytest.approx(G_STEEL * prob.a * prob.b * c11 * xi, rel=1e-3)


def classic_fastsim(prob: FastsimProblem, xi: np.ndarray, mu: float) -> np.ndarray:
    """Continuous classic FASTSIM (Coulomb bound mu p, L = L1), longitudinal creepage.

    Every strip yields at the same angle, tan(kappa/2) = mu p0 L1 / (xi a); the strip
    integrals and the integral over y (of (1 - eta^2), = 4/3) are elementary.
    """
    kappa = 2 * np.arctan(mu * prob.p0 * prob.L1 / (np.abs(xi) * prob.a))
    el = np.abs(xi) * prob.a**2 * (1 - np.cos(kappa)) ** 2 / (2 * prob.L1)
    pl = mu * prob.p0 * prob.a * ((math.pi - kappa) / 2 + np.sin(2 * kappa) / 4)
    return np.sign(xi) * 2 / (math.pi * prob.a * prob.p0) * (el + pl)


@pytest.mark.parametrize("ab", [0.1, 0.5, 1.0, 2.0, 10.0])
def test_reduces_to_classic_fastsim(ab):
    """L_mue = 0 and mu_c1 = mu_c2: classic FASTSIM with the elliptic (Coulomb) bound."""
    prob = problem(ab, LayerParams(0.35, 0.35, 0.0, 5e-6))
    xi = np.array([-0.02, -1e-4, 1e-6, 1e-5, 1e-4, 1e-3, 3e-3, 0.01, 0.1, 1.0])
    mu = boundary_traction(prob, xi).mu
    np.testing.assert_allclose(mu, classic_fastsim(prob, xi, 0.35), rtol=1e-4)


def test_full_slip_tends_to_mu_c2():
    prob = problem(3.7 / 3.3, WR_LAYER)
    mu = boundary_traction(prob, [0.5, 1.0]).mu
    assert mu[1] == pytest.approx(0.45, rel=2e-3)
    assert mu[0] < mu[1] <= 0.45


def test_odd_in_creepage_and_zero_at_zero():
    prob = problem(1.2, WR_LAYER)
    xi = np.array([-0.03, -1e-3, -1e-5, 0.0, 1e-5, 1e-3, 0.03])
    mu = boundary_traction(prob, xi).mu
    assert mu[3] == 0.0
    np.testing.assert_array_equal(mu[:3], -mu[4:][::-1])
    assert np.all(np.diff(mu) > 0)


def test_a_kept_yield_table_gives_what_a_new_one_gives():
    """The yield tables are kept by the strips' r (the layer's elastic length and the
    contact): layers that differ in their limits only share one, and the traction is the
    same bits as with every table computed anew; another elastic length gets its own."""
    import torlab.model.fastsim as fs

    xi = np.geomspace(1e-4, 0.05, 12)
    layers = [WR_LAYER, LayerParams(0.25, 0.5, 10e-6, 20e-6), LayerParams(0.3, 0.45, 7e-6, 9e-6)]
    prob = problem(1.3, WR_LAYER)
    fs._yield_table_of.cache_clear()
    kept = [boundary_traction(dataclasses.replace(prob, layer=L), xi).mu for L in layers]
    info = fs._yield_table_of.cache_info()
    assert (info.misses, info.hits) == (2, 1)  # the first two share r; the third has its own
    new = []
    for L in layers:
        fs._yield_table_of.cache_clear()
        new.append(boundary_traction(dataclasses.replace(prob, layer=L), xi).mu)
    for a, b in zip(kept, new, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(kept[0], kept[1]) and not np.array_equal(kept[0], kept[2])
    assert not any(t.flags.writeable for t in fs._yield_table(np.array([0.7, 1.1])))


# the accuracy test set: a/b 0.2..5, creepage 1e-5..0.5, with and without the layer.
# The reference is slow (~1 s per point), so CI checks a spread-out sample of it;
# `torlab bench` runs the whole set.
REF_CASES = [
    (0.2, "layer", 1e-3), (0.2, "nolayer", 1e-5), (0.5, "soft", 0.01), (1.0, "layer", 1e-4),
    (1.0, "nolayer", 0.1), (2.0, "layer", 0.5), (2.0, "soft", 3e-3), (5.0, "layer", 0.01),
    (5.0, "nolayer", 1e-3),
]
LAYERS = {"layer": WR_LAYER, "nolayer": LayerParams(0.3, 0.45, 0.0, 20e-6),
          "soft": LayerParams(0.45, 0.3, 10e-6, 5e-6)}


@pytest.mark.parametrize("ab, layer, xi", REF_CASES)
def test_default_grid_against_grid_free_reference(ab, layer, xi):
    prob = problem(ab, LAYERS[layer])
    ref = boundary_traction_reference(prob, xi, rtol=1e-9)
    assert boundary_traction(prob, [xi]).mu[0] == pytest.approx(ref, rel=1e-3)


def test_e_strip_closed_form_against_mpmath():
    """e(theta; r) against 30-digit quadrature (mpmath, break points at the r scale)."""
    import mpmath as mp

    mp.mp.dps = 30
    for r in (0.0, 1e-4, 0.3, 0.49, 0.51, 3.0):
        for th in (1e-3, 0.2, 1.5, 3.0, math.pi):
            rr, tt = mp.mpf(r), mp.mpf(th)
            pts = sorted({mp.mpf(0), *(x for x in (rr, 10 * rr, tt - 10 * rr, tt - rr)
                                      if 0 < x < tt), tt})
            ref = mp.quad(lambda t, rr=rr: mp.sin(t) ** 2 / (mp.sin(t) + rr), pts)
            assert float(e_strip(th, r)) == pytest.approx(float(ref), rel=1e-12)


def _e_ref(th: float, r: float, a: float = 0.0) -> float:
    """``integral_a^th sin^2 t / (sin t + r) dt`` by 30-digit quadrature (mpmath), with
    break points at the r scale (its error is far below the 1e-13 the tests ask for)."""
    import mpmath as mp

    with mp.workdps(30):
        rr, ta, tt = mp.mpf(r), mp.mpf(a), mp.mpf(th)
        pts = sorted({ta, *(x for x in (ta + rr, ta + 10 * rr, tt - 10 * rr, tt - rr)
                            if ta < x < tt), tt})
        return float(mp.quad(lambda t: mp.sin(t) ** 2 / (mp.sin(t) + rr), pts))


#: the hard cases of e(theta; r)'s Gauss rule: r at and around 1/2 (nearest singularity),
#: around 1 (where it leaves the real axis), r >> 1, theta -> 0 and theta -> pi
_E_R = (1e-6, 0.1, 0.3, 0.4999999, 0.5, 0.5000001, 0.7, 0.9999999, 1.0, 1.0000001, 1.5, 7.7,
        100.0, 1e6)
_E_TH = (1e-6, 1e-3, 0.05, 0.3, 0.7, 1.3, 2.0, 2.9, math.pi - 1e-6, math.pi)


def _e_grid(rs, ths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r, th = (np.array(x, dtype=float).ravel() for x in np.meshgrid(rs, ths))
    return r, th, np.array([_e_ref(t, q) for t, q in zip(th, r, strict=True)])


def test_e_strip_gauss_nodes_against_mpmath():
    """e(theta; r) with the nodes the Bernstein ellipse asks for (6 to 24) against 30-digit
    quadrature over the hard cases, to 1e-13 relative; the worst case (r = 1/2, theta = pi)
    keeps all 24 nodes."""
    from torlab.model.strip import _gauss_nodes

    r, th, ref = _e_grid(_E_R, _E_TH)
    got = e_strip(th, r)
    rel = np.abs(got - ref) / np.abs(ref)
    assert np.max(rel) <= 1e-13, (r[np.argmax(rel)], th[np.argmax(rel)], np.max(rel))
    n = _gauss_nodes(np.array([math.pi, 0.3, 0.3]), np.array([0.5, 0.5, 100.0]))
    assert n[0] == 24 and 6 <= n[2] <= n[1] < 24


@pytest.mark.slow
def test_e_strip_gauss_nodes_against_mpmath_dense():
    """The same on a dense grid (25 r from 1 to 1e6, 21 around 1/2 to 3/2, 23 theta)."""
    rs = (*np.geomspace(1.0, 1e6, 25), *np.linspace(0.5, 1.5, 21), 1e-3, 0.2, 0.45)
    r, th, ref = _e_grid(rs, (*np.linspace(0.05, math.pi, 23), 1e-4, 0.01))
    rel = np.abs(e_strip(th, r) - ref) / np.abs(ref)
    assert np.max(rel) <= 1e-13, (r[np.argmax(rel)], th[np.argmax(rel)], np.max(rel))


@pytest.mark.parametrize("r", [0.27, 0.39, 0.5, 0.51, 0.99, 1.0, 1.01, 7.7, 1e3, 0.05, 1e-4])
def test_e_in_temperature_cell_against_mpmath(r):
    """e(theta; r) as the thermal yield-angle iteration takes it: the value at the start of
    its temperature cell (48 nodes) plus the piece up to theta, against 30-digit quadrature
    of the whole integral, to 1e-13 relative -- in the first and the last cell, and where
    r is too small for the piece's rule (``e_strip`` then)."""
    from torlab.model.strip import e_in_cell

    h = math.pi / 47
    t0 = np.array([0.0, 0.0, 3 * h, 20 * h, 46 * h, 46 * h])
    th = t0 + np.array([1e-7, 0.6, 0.3, 1.0, 0.5, 1.0]) * h
    th[-1] = math.pi
    e0 = np.array([_e_ref(a, r) if a > 0 else 0.0 for a in t0])
    got = e_in_cell(th, np.full(th.shape, r), t0, e0)
    ref = np.array([_e_ref(t, r) for t in th])
    np.testing.assert_allclose(got, ref, rtol=1e-13, atol=0)


@pytest.mark.parametrize("r", [0.0, 1e-6, 0.05, 0.4999999, 0.5, 1.0, 7.7, 1e6])
def test_e_on_uniform_nodes_against_mpmath(r):
    """e(theta; r) on the yield table's 256 uniform angles, summed cell by cell from the
    fourth angle (8 Gauss nodes per cell), against 30-digit quadrature to 1e-13 relative:
    the four angles at each end (e_strip's own rule), the first and last summed ones, and
    the middle, where 124 cells are summed; and the few-node case, which is e_strip's."""
    from torlab.model.strip import e_on_nodes

    n = 256
    j = np.array([1, 4, 5, 6, 50, 128, 200, 251, 252, 253, 255, 256])
    got = e_on_nodes(np.array(r), n)
    assert got.shape == (n,)
    ref = np.array([_e_ref(k * math.pi / n, r) for k in j])
    np.testing.assert_allclose(got[j - 1], ref, rtol=1e-13, atol=0)
    few = e_on_nodes(np.array([r, 2 * r]), 7)
    np.testing.assert_array_equal(few, e_strip(np.arange(1, 8) * math.pi / 7,
                                               np.array([r, 2 * r])[:, None]))


@pytest.mark.parametrize("grouped", [False, True])
def test_isothermal_yield_angles_solve_the_yield_condition(grouped):
    """The isothermal yield angles (a table cell, the secant start, e from the cell's start)
    solve ``e(theta; r) = c sin(theta)`` to round-off, with e by the whole rule
    (``e_strip``), for r below the cell rule's reach, at 1/2 and far above, and for roots in
    the first cell, the middle and the last cell; a layer per point (``groups``) gives the
    same angles."""
    import torlab.model.fastsim as fs

    r_s = np.array([1e-4, 0.02, 0.5, 0.9, 3.0, 50.0])
    theta = np.array([1e-3, 0.01, 0.4, 1.6, 2.9, math.pi - 1e-3, math.pi - 1e-6])
    # c from a chosen root: e(theta)/sin(theta) is increasing, so theta is the root
    c = e_strip(theta[:, None], r_s[None, :]) / np.sin(theta)[:, None]
    r = np.broadcast_to(r_s, c.shape)
    if grouped:
        gid = np.zeros(c.shape, dtype=int)
        th, _ = fs._yield_isothermal(c, r, groups=(gid, r_s[None, :]))
    else:
        th, _ = fs._yield_isothermal(c, r)
    np.testing.assert_allclose(th, np.broadcast_to(theta[:, None], c.shape), rtol=1e-11)
    resid = e_strip(th, r) - c * np.sin(th)
    assert np.all(np.abs(resid) <= 1e-13 * e_strip(th, r))


# ---------------------------------------------------------------------------------------
# hard cases
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("layer", [
    LayerParams(0.45, 0.30, 10e-6, 5e-6),      # softening: tau_c2 < tau_c1
    LayerParams(0.30, 0.45, 10e-6, 1e-15),     # L_mup -> 0
    LayerParams(0.30, 0.45, 10e-6, 0.0),       # L_mup = 0 (step to tau_c2)
    LayerParams(0.30, 0.45, 0.0, 20e-6),       # L_mue = 0
    LayerParams(0.0, 0.45, 10e-6, 20e-6),      # mu_c1 = 0: plastic from the leading edge
])
@pytest.mark.parametrize("ab", [0.1, 1.0, 10.0])
def test_hard_cases_finite_and_bounded(layer, ab):
    prob = problem(ab, layer)
    xi = np.array([-1.0, -0.01, 0.0, 1e-9, 1e-5, 1e-3, 0.05, 1.0])
    mu = boundary_traction(prob, xi).mu
    assert np.all(np.isfinite(mu))
    lim = max(layer.mu_c1, layer.mu_c2)
    assert np.all(np.abs(mu) <= lim * (1 + 1e-9))
    assert np.all(np.sign(mu) == np.sign(xi))


def test_vanishing_voce_length_tends_to_step():
    a = boundary_traction(problem(1.0, LayerParams(0.3, 0.45, 10e-6, 1e-12)), [1e-3]).mu[0]
    b = boundary_traction(problem(1.0, LayerParams(0.3, 0.45, 10e-6, 0.0)), [1e-3]).mu[0]
    assert a == pytest.approx(b, rel=1e-4)


def test_non_finite_creepage_is_refused():
    with pytest.raises(ValueError):
        boundary_traction(problem(1.0, WR_LAYER), [np.nan])


# ---------------------------------------------------------------------------------------
# temperature
# ---------------------------------------------------------------------------------------
def test_flash_temperature_converges_to_the_notes_anchor():
    """q = sqrt(1 - (x/a)^2) on a strip: peak 1.23462 at 0.6522 a behind the centre,
    1.06385 at the trailing edge (docs/model/thesis-reading.md; units q0 sqrt(a/v)/sqrt(lambda rho c),
    partition 1, formula T = (1/sqrt(pi lambda rho c v)) int q/sqrt(X - X') dX')."""
    theta, K = flash_temperature_matrix(2000)
    X = 1 - np.cos(theta)
    q = np.sqrt(np.clip(1 - (X - 1) ** 2, 0, None))
    T = K @ q / math.sqrt(math.pi)
    assert T[-1] == pytest.approx(1.06385, rel=1e-3)
    assert T.max() == pytest.approx(1.23462, rel=1e-3)
    assert X[np.argmax(T)] - 1 == pytest.approx(0.6522, abs=5e-3)


def test_temperature_lowers_traction_with_negative_coefficients():
    th = ThermalParams()
    iso = boundary_traction(problem(1.12, WR_LAYER, thermal=th), [0.002, 0.02])
    assert iso.temperature_loop == "single pass"
    assert np.all(iso.max_temperature_C > 20.0)
    hot_layer = LayerParams(0.30, 0.45, 10e-6, 20e-6, mu_c1_T=-1e-3, mu_c2_T=-1e-3)
    hot = boundary_traction(problem(1.12, hot_layer, thermal=th), [0.002, 0.02])
    assert hot.temperature_loop == "iterated"
    assert np.all(hot.mu < iso.mu)
    assert np.all(np.isfinite(hot.mu)) and np.all(hot.temperature_iterations >= 2)


def test_temperature_iteration_converged_to_its_fixed_point():
    """The returned state is a fixed point: a tighter tolerance changes mu by little."""
    lay = LayerParams(0.30, 0.45, 10e-6, 20e-6, mu_c1_T=-2e-3, mu_c2_T=-2e-3)
    loose = boundary_traction(problem(1.12, lay, thermal=ThermalParams(tolerance=0.1)), [0.02])
    tight = boundary_traction(problem(1.12, lay, thermal=ThermalParams(tolerance=1e-4,
                                                                        max_iterations=2000)),
                              [0.02])
    assert loose.mu[0] == pytest.approx(tight.mu[0], rel=1e-3)


def test_unstable_temperature_coefficient_converges_or_raises_named_error():
    lay = LayerParams(0.30, 0.45, 10e-6, 20e-6, mu_c1_T=0.02, mu_c2_T=0.02)  # self-amplifying
    prob = problem(1.12, lay, thermal=ThermalParams(max_iterations=50), speed=30.0)
    try:
        res = boundary_traction(prob, [0.01, 0.1])
    except ConvergenceError as e:
        assert "temperature" in str(e)
    else:
        assert np.all(np.isfinite(res.mu)) and np.all(np.isfinite(res.max_temperature_C))


def test_default_grid_matches_a_fine_grid_with_temperature():
    lay = LayerParams(0.30, 0.45, 10e-6, 20e-6, mu_c1_T=-1e-3, mu_c2_T=-5e-4)
    prob = problem(1.12, lay, thermal=ThermalParams(tolerance=1e-3))
    xi = [1e-3, 0.01, 0.05]
    coarse = boundary_traction(prob, xi).mu
    fine = boundary_traction(prob, xi, FastsimGrid(n=24, m=8, temperature_nodes=400)).mu
    np.testing.assert_allclose(coarse, fine, rtol=2e-3)
