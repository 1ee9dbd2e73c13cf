"""Surface temperatures on the exact solver's grid (torlab.model.exact.temperature).

References independent of the code: the strip solution's closed-form anchor (one strip of
half-length a under q = q0 sqrt(1 - (x/a)^2): peak 1.23462 q0 sqrt(a/v)/beta at 0.6522 a
behind the centre, 1.06385 at the trailing edge), recomputed here by adaptive quadrature
and by Jaeger's moving band source (the 2D conduction the strip kernel neglects); the
temperature of two half-spaces in perfect contact; the surface temperature after
separation by Duhamel's integral.  CONTACT's Ertz-Knothe example is in
tests/test_exact_bank.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from torlab.model.exact.grid import Grid, hertz_pressure
from torlab.model.exact.solver import ADHESION, EXTERIOR, SLIP, Solution
from torlab.model.exact.temperature import ThermalBody, frictional_heat, surface_temperature

PEAK, PEAK_AT, TRAILING = 1.23462, 0.6522, 1.06385   # the anchor (docs/model/thesis-reading.md)
STEEL = ThermalBody(bulk_temperature=0.0)


def _anchor(x: float) -> float:
    """(1/sqrt(pi)) integral_{-1}^{x} sqrt(1 - s^2)/sqrt(x - s) ds by adaptive quadrature."""
    from scipy.integrate import quad

    # sqrt(1 - s^2) / sqrt(x - s) = sqrt(1 - s) * (s + 1)^0.5 (x - s)^-0.5: the weight takes
    # both end points' powers, the rest is smooth
    val, _ = quad(lambda s: math.sqrt(1.0 - s), -1.0, x, weight="alg", wvar=(0.5, -0.5))
    return val / math.sqrt(math.pi)


def test_anchor_by_quadrature_and_jaeger():
    """The anchor's numbers by quadrature; at the Ertz-Knothe example's Péclet number
    (v a / 2 kappa = 6231) Jaeger's moving band source, which also conducts along the
    rolling direction, lies within 2e-4 of the strip kernel's value."""
    from scipy.integrate import quad
    from scipy.special import k0e

    assert _anchor(PEAK_AT) == pytest.approx(PEAK, rel=2e-5)
    assert _anchor(1.0) == pytest.approx(TRAILING, rel=2e-5)
    assert _anchor(PEAK_AT) > max(_anchor(PEAK_AT - 0.01), _anchor(PEAK_AT + 0.01))
    lam, rho, c, a, v = 50.0, 7850.0, 450.0, 5.88e-3, 30.0
    P = v * rho * c / (2 * lam)                        # v / (2 kappa) [1/m]

    def jaeger(x):
        """Carslaw and Jaeger 10.7: a line source Q' moving over a half-space,
        T = Q'/(pi lambda) exp(-P s) K0(P |s|), s the point's distance ahead of it."""
        # s = u^2 takes the logarithmic singularity of K0 at s = 0 away
        behind = quad(lambda u: 2 * u * math.sqrt(max(1 - ((x - u * u) / a) ** 2, 0.0))
                      * k0e(P * u * u), 0.0, math.sqrt(x + a), limit=200)[0]
        ahead = 0.0 if x >= a else quad(     # exp(-2 P s): nothing beyond s = 25/P
            lambda u: 2 * u * math.sqrt(1 - ((x + u * u) / a) ** 2) * math.exp(-2 * P * u * u)
            * k0e(P * u * u), 0.0, math.sqrt(min(a - x, 25 / P)), limit=200)[0]
        return (behind + ahead) / (math.pi * lam)

    scale = math.sqrt(a / v) / math.sqrt(lam * rho * c)
    assert jaeger(PEAK_AT * a) == pytest.approx(PEAK * scale, rel=2e-4)
    assert jaeger(a) == pytest.approx(TRAILING * scale, rel=5e-4)


def _sliding(n: int, a: float = 5e-3, b: float = 5e-3, mu: float = 0.3, w: float = 1.0,
             v: float = 30.0, load: float = 50e3, behind: int = 2) -> tuple[Solution, float]:
    """Full sliding at the slip speed ``w`` over Hertz's pressure, ``n`` elements along the
    strip y = 0 (three rows; ``behind`` more elements behind the trailing edge): no solver,
    the flux is mu p0 w sqrt(1 - (x/a)^2) on y = 0."""
    dx = 2 * a / n
    g = Grid(x0=-a - behind * dx, y0=-1.5 * dx, dx=dx, dy=dx, mx=n + 2 + behind, my=3)
    pn = hertz_pressure(g, a, b, load, "centre")
    state = np.where(pn > 0, SLIP, EXTERIOR)
    p = np.zeros((*pn.shape, 2))
    p[..., 0] = mu * pn
    sigma = np.zeros_like(p)
    sigma[..., 0] = np.where(pn > 0, -w * dx / v, 0.0)
    sol = Solution(grid=g, p=p, sigma=sigma, state=state, kappa=np.zeros(pn.shape),
                   plastic=np.zeros_like(p), newton=0, matvecs=0, residual=0.0)
    return sol, mu * 3 * load / (2 * math.pi * a * b) * w


@pytest.mark.parametrize("n", [59, 236])
def test_strip_converges_to_the_anchor(n):
    """The element scheme's peak on the centre strip against the anchor (half the heat into
    each of two equal bodies): within 0.1 % at 59 elements; CONTACT's weight of the own
    element lies above it by a share that falls as sqrt(dx): a discretisation error."""
    a, v = 5e-3, 30.0
    sol, q0 = _sliding(n, a=a, v=v)
    exact = 0.5 * PEAK * q0 * math.sqrt(a / v) / STEEL.effusivity
    centre = surface_temperature(sol, v, STEEL).max_temperature
    contact = surface_temperature(sol, v, STEEL, own_element="contact").max_temperature
    assert centre == pytest.approx(exact, rel=1e-3)
    excess = contact / exact - 1
    # the doubled own element adds q(x) 2 sqrt(dx/2) / sqrt(pi) (units of the anchor), q near
    # the peak 0.76 q0: 0.76 * 2 sqrt(1/n) / sqrt(pi) / 1.23462
    assert excess == pytest.approx(0.76 * 2 / math.sqrt(n) / math.sqrt(math.pi) / PEAK, rel=0.05)


def test_trailing_edge_and_power():
    """The centre strip's last element in contact against the anchor's trailing value (to
    the element's first-order offset), and the power: mu N w."""
    a, v, n = 5e-3, 30.0, 400
    sol, q0 = _sliding(n, a=a, v=v, behind=10)
    r = surface_temperature(sol, v, STEEL)
    row = r.body1[:, 1]
    last = int(np.flatnonzero(r.contact[:, 1]).min())
    assert row[last] == pytest.approx(0.5 * TRAILING * q0 * math.sqrt(a / v) / STEEL.effusivity,
                                      rel=0.01)
    assert np.all(np.diff(row[:last + 1]) > 0)        # cooling behind the contact
    x = sol.grid.x
    assert np.allclose(r.heat_flux[:, 1], q0 * np.sqrt(np.clip(1 - (x / a) ** 2, 0, None)),
                       rtol=1e-12, atol=0)                              # mu p w on y = 0
    assert r.power == pytest.approx(r.heat_flux.sum() * sol.grid.area, rel=1e-12)
    assert np.array_equal(frictional_heat(sol, v), r.heat_flux)


def test_two_bulk_temperatures_without_slip():
    """No slip: the surfaces take the contact temperature of two half-spaces in perfect
    contact, (b1 T1 + b2 T2)/(b1 + b2), and behind the contact relax as Duhamel's integral
    of the flux beta (Tm - T)/sqrt(pi t) that held them there (computed by quadrature)."""
    from scipy.integrate import quad

    sol, _ = _sliding(100, behind=20)
    sol.state[sol.state == SLIP] = ADHESION
    sol.sigma[:] = 0.0
    rail = ThermalBody(50.0, 7850.0, 450.0, 0.0)
    wheel = ThermalBody(25.0, 7000.0, 500.0, 150.0)
    r = surface_temperature(sol, 30.0, rail, wheel)
    b1, b2 = rail.effusivity, wheel.effusivity
    tm = (b1 * 0.0 + b2 * 150.0) / (b1 + b2)
    assert r.entry_temperature == pytest.approx(tm)
    assert r.max_temperature == pytest.approx(tm)
    assert np.allclose(r.body1[r.contact], tm) and np.allclose(r.body2[r.contact], tm)
    assert r.power == 0.0
    row = np.flatnonzero(r.contact[:, 1])
    L = row.size * sol.grid.dx
    for i in (row.min() - 1, row.min() - 3):            # behind the contact
        X = L + (row.min() - i - 0.5) * sol.grid.dx     # from the leading edge
        # t' in [0, L] the time in contact (in units of distance): flux 1/sqrt(pi t'),
        # temperature after it (1/sqrt(pi)) int flux / sqrt(X - t') dt'
        share = quad(lambda t, X=X: 1 / (math.pi * math.sqrt(X - t)), 0, L, weight="alg",
                     wvar=(-0.5, 0.0))[0]
        assert r.body1[i, 1] == pytest.approx(tm * share, rel=1e-6)
        assert r.body2[i, 1] == pytest.approx(150.0 + (tm - 150.0) * share, rel=1e-6)
    assert np.all(r.body1[: row.min() - 1, 1] < r.body1[row.min() - 1, 1])


def test_unequal_bodies_share_one_surface_temperature():
    """With frictional heat the bodies' surfaces stay equal in the contact (the heat splits by
    effusivity); swapping the bodies swaps the fields behind the contact."""
    sol, _ = _sliding(80)
    rail = ThermalBody(50.0, 7850.0, 450.0, 10.0)
    wheel = ThermalBody(20.0, 7000.0, 500.0, 60.0)
    r = surface_temperature(sol, 30.0, rail, wheel)
    assert np.allclose(r.body1[r.contact], r.body2[r.contact])
    assert r.partition == pytest.approx(rail.effusivity / (rail.effusivity + wheel.effusivity))
    s = surface_temperature(sol, 30.0, wheel, rail)
    assert np.allclose(s.body1, r.body2) and np.allclose(s.body2, r.body1)


def test_plastic_heat_and_bad_input():
    sol, _ = _sliding(40)
    sol.plastic[:] = sol.sigma                          # all of the slip is plastic flow
    full = frictional_heat(sol, 30.0)
    assert np.allclose(frictional_heat(sol, 30.0, plastic_heat=0.5), 0.5 * full)
    assert np.all(frictional_heat(sol, 30.0, plastic_heat=0.0) == 0.0)
    for bad in ({"own_element": "edge"}, {"plastic_heat": 1.5}):
        with pytest.raises(ValueError):
            surface_temperature(sol, 30.0, **bad)
    with pytest.raises(ValueError):
        surface_temperature(sol, 0.0)
    with pytest.raises(ValueError):
        surface_temperature(sol, 30.0, ThermalBody(conductivity=-1.0))
