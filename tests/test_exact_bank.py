"""Kalker's exact theory (torlab.model.exact) against CONTACT's own test bank.

CONTACT (E.A.H. Vollebregt, Apache-2.0) is the reference implementation of Kalker's
exact theory.  Its example inputs and reference outputs lie in
``../shared/datasets/contact`` (never in the repository); each test states the case's
inputs, reads CONTACT's printed results and skips where the folder is absent.  CONTACT's
units are mm, N and N/mm^2; the forces are those on body 1 (torlab's solver core
uses the same convention).  The printed results have four significant digits, so a
difference of 0.05 % is within their rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from contact_bank import bank_file, cases, counts, second_row, totals

from torlab.model.exact.grid import Grid
from torlab.model.exact.local import LinearYield
from torlab.model.exact.normal import hertz_curvatures, solve_normal
from torlab.model.exact.solver import SLIP, Layer, rigid_slip, solve

ROUNDING = 6e-4  # four printed digits


def _carter_grid(mx: int, xc1: float, dx: float) -> Grid:
    """CONTACT's 2D grids: one row of elements 200 mm wide, centre of the first at xc1."""
    return Grid(x0=xc1 - dx / 2, y0=-100.0, dx=dx, dy=200.0, mx=mx, my=1)


def _normal(g: Grid, G: float, nu: float, b1: float, b3: float, load: float) -> np.ndarray:
    X, Y = g.centres()
    return solve_normal(g, G, nu, b1 * X**2 + b3 * Y**2, load)[0]


def _shift(w: float, g: Grid) -> np.ndarray:
    W = np.zeros((g.mx, g.my, 2))
    W[..., 0] = w
    return W


def test_carter2d():
    """Carter/Fromm 2D rolling (55 x 1 elements, R = 500 mm, xi = -0.024 %, mu = 0.3)."""
    ref = totals("examples/carter2d.ref_out")[0]
    cnt = counts("examples/carter2d.ref_out")[0]
    g = _carter_grid(55, -1.05, 0.04)
    pn = _normal(g, 82000.0, 0.28, 0.001, 0.0, 35780.0)
    s = solve(g, 82000.0, 0.28, pn, 0.3, rigid_slip(g, -0.00024, 0, 0))
    assert s.Fx == pytest.approx(ref["FX"], rel=ROUNDING)
    assert s.counts()["adhesion"] == cnt["NADH"] and s.counts()["slip"] == cnt["NSLIP"]
    assert int((pn > 0).sum()) == cnt["NCON"]


def test_cattaneo():
    """Cattaneo's shift of a polyethylene ball (19 x 19 elements) to Fx = -7/8 mu N."""
    from scipy.optimize import brentq

    ref = second_row("examples/cattaneo.ref_out", "FN/G")[1]  # FN/G, SHIFT X, ...
    cnt = counts("examples/cattaneo.ref_out")[1]
    G, nu, mu, load = 200.0, 0.42, 0.4, 9.1954
    g = Grid(x0=-1.26667, y0=-1.26667, dx=0.13333, dy=0.13333, mx=19, my=19)
    pn = _normal(g, G, nu, 0.01, 0.01, load)
    w = brentq(lambda w: solve(g, G, nu, pn, mu, _shift(w, g), mode="shift").Fx
               + 0.875 * mu * load, 0.0, 0.02, xtol=1e-12)
    s = solve(g, G, nu, pn, mu, _shift(w, g), mode="shift")
    assert w == pytest.approx(float(ref[1]), rel=ROUNDING)
    assert int((pn > 0).sum()) == cnt["NCON"]
    assert (s.counts()["adhesion"], s.counts()["slip"]) == (cnt["NADH"], cnt["NSLIP"])


def test_fastsim_example_exact_case():
    """The fastsim example's first case: CONTACT's half-space solution (44 x 44 elements,
    a = 8, b = 4 mm, eta = -6.25e-4, phi = 6.25e-4 1/mm); the spin's rigid slip is taken
    at x + dx/6 as CONTACT does."""
    ref = totals("examples/fastsim.ref_out")[0]
    cnt = counts("examples/fastsim.ref_out")[0]
    G, nu = 82000.0, 0.28
    A, B = hertz_curvatures(8.0, 4.0, 82000.0, G, nu)
    g = Grid(x0=-8.8, y0=-4.4, dx=0.4, dy=0.2, mx=44, my=44)
    pn = _normal(g, G, nu, A, B, 82000.0)
    s = solve(g, G, nu, pn, 0.3, rigid_slip(g, 0.0, -6.25e-4, 6.25e-4, x_spin=g.dx / 6))
    assert s.Fy == pytest.approx(ref["FY"], rel=ROUNDING)
    assert s.Mz == pytest.approx(ref["MZ"], rel=ROUNDING)
    assert (s.counts()["adhesion"], s.counts()["slip"]) == (cnt["NADH"], cnt["NSLIP"])
    assert int((pn > 0).sum()) == cnt["NCON"]


@pytest.mark.parametrize("case,bound", [(4, "parabolic"), (5, "elliptic")])
def test_fastsim_example_fastsim_cases(case, bound):
    """CONTACT's FASTSIM on 44 x 44 and 220 x 220 elements, extrapolated to the grid-free
    limit at first order, against torlab's (grid-free) FASTSIM with CONTACT's three
    flexibilities (printed in the output) and FASTSIM's re-stick rule."""
    from torlab.model.creep import CreepProblem, creep_forces
    from torlab.model.layers import LayerParams

    tot = totals("examples/fastsim.ref_out")
    flx = second_row("examples/fastsim.ref_out", "FLX1")[0]
    coarse = tot[case - 3]                       # the same bound on 44 x 44
    fine = tot[case]
    ext = {k: fine[k] + (fine[k] - coarse[k]) * 44 / (220 - 44) for k in ("FY", "MZ")}
    a, b, load = 8e-3, 4e-3, 82000.0
    L = [float(v) * 1e-9 for v in flx]            # mm^3/N -> m/Pa
    prob = CreepProblem(a=a, b=b, p0=3 * load / (2 * math.pi * a * b), L1=L[0], L2=L[1],
                        L3=L[2], layer=LayerParams(mu_c1=0.3, mu_c2=0.3),
                        traction_bound=bound, restick="kalker")
    r = creep_forces(prob, 0.0, -6.25e-4, 0.625)
    # torlab's force opposes CONTACT's force on body 1
    assert -float(r.Fy) == pytest.approx(ext["FY"], rel=0.002)
    assert -float(r.Mz) * 1e3 == pytest.approx(ext["MZ"], rel=0.002)


def _carter_plast(series: int, k_tau: float) -> tuple[float, dict]:
    grids = {0: (30, -1.16, 0.08), 1: (55, -1.08, 0.04), 2: (105, -1.04, 0.02)}
    g = _carter_grid(*grids[series])
    pn = _normal(g, 82000.0, 0.28, 0.001, 0.0, 35780.0)
    s = solve(g, 82000.0, 0.28, pn, 0.5, rigid_slip(g, -0.0004, 0, 0),
              layer=Layer(0.0, LinearYield(k_tau), 35.0))
    return s.Fx, s.counts()


K_TAUS = (4018000.0, 123000.0, 0.0, -20500.0)


@pytest.mark.parametrize("k", range(4))
def test_carter_plast_coarse(k):
    """Carter with the surface's plasticity (no layer thickness): hardening, perfectly plastic
    and softening (k_tau in N/mm^3), 30 elements.  Softening differs by up to 0.2 % (one
    element's division); the finer grids agree closer (the slow test)."""
    ref = totals("testbank-plast/carter_plast.ref_out")[k]
    cnt = counts("testbank-plast/carter_plast.ref_out")[k]
    fx, c = _carter_plast(0, K_TAUS[k])
    if K_TAUS[k] >= 0:
        assert fx == pytest.approx(ref["FX"], rel=ROUNDING)
        assert (c["adhesion"], c["slip"], c["plastic"]) == (cnt["NADH"], cnt["NSLIP"],
                                                             cnt["NPLAST"])
    else:
        assert fx == pytest.approx(ref["FX"], rel=0.0025)


@pytest.mark.slow  # the 55- and 105-element series (about 8 s); the 30-element series is quick
@pytest.mark.parametrize("series", [1, 2])
def test_carter_plast_fine(series):
    tot = totals("testbank-plast/carter_plast.ref_out")
    for k, kt in enumerate(K_TAUS):
        fx, _ = _carter_plast(series, kt)
        tol = ROUNDING if kt >= 0 else (8e-4 if series == 1 else ROUNDING)
        assert fx == pytest.approx(tot[4 * series + k]["FX"], rel=tol)


def test_plastic_3bl_one_element_series():
    """One element of 1 mm^2 sheared through an interfacial layer step by step (Hou, Kalousek,
    Magel's magnetite, clay with a reversal, sand softening, MoS2): 57 steps."""
    ref = [t["FX"] for t in totals("examples/plastic_3bl.ref_out")]
    g = Grid(-0.5, -0.5, 1.0, 1.0, 1, 1)
    p, kap, layer = np.zeros((1, 1, 2)), np.zeros((1, 1)), None
    got = []
    for c in cases("examples/plastic_3bl.inp"):
        if c.get("M", 4) == 0:
            layer = None
        if "layer" in c:
            G3, h, tau0, k_tau = c["layer"]
            layer = Layer(h / G3, LinearYield(k_tau), tau0)
        if c["P"] == 2:
            p, kap = np.zeros((1, 1, 2)), np.zeros((1, 1))
        s = solve(g, 82000.0, 0.28, np.full((1, 1), c["FN"]), 0.7, _shift(c["kin"][0], g),
                  mode="shift", layer=layer, p_prev=p, kappa_prev=kap)
        p, kap = s.p, s.kappa
        got.append(s.Fx)
    assert len(got) == len(ref) == 57
    assert np.allclose(got, ref, rtol=ROUNDING, atol=0.006)


def _sequence(rel: str, g: Grid, G: float, nu: float, mu: float, pn: np.ndarray,
              layer: Layer, steps: int | None = None) -> list[float]:
    """Run a bank input's cases: steady (T=3), shift (T=1) and transient (T=2) steps,
    creepage or force prescribed, from zero (P=2) or the previous state."""
    from scipy.optimize import brentq

    load = float(pn.sum() * g.area)
    p, kap = np.zeros((g.mx, g.my, 2)), np.zeros((g.mx, g.my))
    out = []
    for c in cases(rel)[:steps]:
        if "layer" in c:
            G3, h, tau0, k_tau = c["layer"]
            layer = Layer(h / G3, LinearYield(k_tau), tau0)
        if c["P"] == 2:
            p, kap = np.zeros_like(p), np.zeros_like(kap)
        v, eta, phi = c["kin"]
        mode = {1: "shift", 2: "transient", 3: "steady"}[c["T"]]

        def run(x, mode=mode, eta=eta, phi=phi, p=p, kap=kap, layer=layer):
            W = _shift(x, g) if mode == "shift" else rigid_slip(g, x, eta, phi, g.dx / 6)
            return solve(g, G, nu, pn, mu, W, mode=mode, layer=layer, p_prev=p,
                         kappa_prev=kap, p0=p if mode == "transient" else None)

        if c["F"] == 1:   # the force prescribed: find the shift or creepage
            target = v * mu * load
            x = brentq(lambda x, t=target: run(x).Fx - t, -0.1, 0.0, xtol=1e-14)
            s = run(x)
        else:
            s = run(v)
        p, kap = s.p, s.kappa
        out.append(s.Fx)
    return out


@pytest.mark.parametrize("steps", [
    5, pytest.param(None, marks=pytest.mark.slow)])  # all 50 cases: about 3 s
def test_catt2d_plast_cattaneo_to_carter(steps):
    """2D Cattaneo shift with plasticity, then 49 steps of transient rolling towards Carter."""
    ref = [t["FX"] for t in totals("testbank-plast/catt2d_plast.ref_out")][:steps]
    g = _carter_grid(30, -1.16, 0.08)
    pn = _normal(g, 82000.0, 0.28, 0.001, 0.0, 35780.0)
    got = _sequence("testbank-plast/catt2d_plast.inp", g, 82000.0, 0.28, 0.5, pn,
                    Layer(0.0, LinearYield(123000.0), 35.0), steps)
    assert len(got) == len(ref)
    assert np.allclose(got, ref, rtol=ROUNDING)


@pytest.mark.slow  # 34 x 33 elements with plasticity (about 2 s); Carter's plasticity is quick
def test_catt3d_plast_steady():
    """3D steady rolling with plasticity (34 x 33 elements): force and element division."""
    ref = totals("testbank-plast/catt3d_plast.ref_out")[0]
    cnt = counts("testbank-plast/catt3d_plast.ref_out")[0]
    g = Grid(x0=-4.125, y0=-4.125, dx=0.25, dy=0.25, mx=34, my=33)
    pn = _normal(g, 1.0, 0.28, 0.002963, 0.002963, 0.4705)
    s = solve(g, 1.0, 0.28, pn, 0.4013, rigid_slip(g, -0.0034, 0, 0),
              layer=Layer(0.0, LinearYield(0.42857), 0.005))
    assert s.Fx == pytest.approx(ref["FX"], rel=ROUNDING)
    assert (s.counts()["adhesion"], s.counts()["slip"], s.counts()["plastic"]) == (
        cnt["NADH"], cnt["NSLIP"], cnt["NPLAST"])


@pytest.mark.slow  # 63 cases on 34 x 33 elements (about 10 s); the steady case is quick
def test_catt3d_plast_sequence():
    """3D: steady rolling, a transient step from rest to the same force, 56 transient steps
    (Cattaneo to Carter), then a perfectly plastic layer with spin."""
    ref = [t["FX"] for t in totals("testbank-plast/catt3d_plast.ref_out")]
    g = Grid(x0=-4.125, y0=-4.125, dx=0.25, dy=0.25, mx=34, my=33)
    pn = _normal(g, 1.0, 0.28, 0.002963, 0.002963, 0.4705)
    got = _sequence("testbank-plast/catt3d_plast.inp", g, 1.0, 0.28, 0.4013, pn,
                    Layer(0.0, LinearYield(0.42857), 0.005))
    assert len(got) == len(ref)
    assert np.allclose(got, ref, rtol=1e-3)


# Ertz and Knothe's temperature example: CONTACT rolls it to -x (chi = 180 deg, material
# enters at small x), torlab's solver to +x: the grid, x, the x-components and the spin are
# mirrored (CONTACT's spin term at x - dx/6 becomes torlab's at x' + dx/6).
ERTZ_SPEED, ERTZ_MU = 30.0, 0.3


@pytest.fixture(scope="module")
def ertz():
    """The example's grid (216 x 45 elements of 0.2 x 0.5 mm, CONTACT's corner at x = -7.90
    mm, mirrored) and its discrete normal problem (B1 = 0.001015, B3 = 0.0004215 1/mm,
    100 kN, G = 82 GPa, nu = 0.28), SI units."""
    bank_file("examples/ertz_temperature.ref_out")
    g = Grid(x0=-35.30e-3, y0=-11.25e-3, dx=0.2e-3, dy=0.5e-3, mx=216, my=45)
    X, Y = g.centres()
    pn = solve_normal(g, 82e9, 0.28, 1.015 * X**2 + 0.4215 * Y**2, 100e3)[0]
    return g, pn


def _ertz_solve(ertz, xi: float, eta: float = 0.0, phi_per_mm: float = 0.0):
    g, pn = ertz
    return solve(g, 82e9, 0.28, pn, ERTZ_MU,
                 rigid_slip(g, -xi, eta, -phi_per_mm * 1e3, x_spin=g.dx / 6))


def _bodies(t1: float, t2: float):
    from torlab.model.exact.temperature import ThermalBody

    return ThermalBody(50.0, 7850.0, 450.0, t1), ThermalBody(50.0, 7850.0, 450.0, t2)


def test_ertz_temperature_cases_1_to_3(ertz):
    """Full sliding at 1 m/s with equal bulk temperatures (case 1), no sliding with the wheel
    at 150 degC (case 2), both (case 3): CONTACT's printed largest surface temperature with
    its weight of an element's own heat; the converged temperature (the own element's heat
    up to its centre) and the thesis's strip solution against the closed-form anchor."""
    from torlab.model.exact.temperature import surface_temperature
    from torlab.model.fastsim import FastsimProblem, boundary_traction
    from torlab.model.flash import ThermalParams
    from torlab.model.kalker import C11, L1
    from torlab.model.layers import LayerParams

    rows = second_row("examples/ertz_temperature.ref_out", "FN/G")   # ..., PMAX, MAX(T1,T2)
    power = [float(r.split()[5]) for r in _lines_after("examples/ertz_temperature.ref_out",
                                                          "FN")]
    pn = ertz[1]
    assert int((pn > 0).sum()) == counts("examples/ertz_temperature.ref_out")[0]["NCON"]
    assert pn.max() / 1e6 == pytest.approx(float(rows[0][4]), rel=ROUNDING)
    slide, rest = _ertz_solve(ertz, -0.03333), _ertz_solve(ertz, 0.0)
    assert slide.counts()["slip"] == int((pn > 0).sum()) and rest.counts()["slip"] == 0
    cold, hot = _bodies(0.0, 0.0), _bodies(0.0, 150.0)
    for sol, bodies, ref, pw in ((slide, cold, rows[0], power[0]), (rest, hot, rows[1], power[1]),
                                 (slide, hot, rows[2], power[2])):
        t = surface_temperature(sol, ERTZ_SPEED, *bodies, own_element="contact")
        assert t.max_temperature == pytest.approx(float(ref[-1]), rel=ROUNDING)
        assert t.power == pytest.approx(-pw, rel=ROUNDING, abs=1e-9)
    # converged: the own element's heat up to its centre (152.3 degC, the local slip's)
    centre = surface_temperature(slide, ERTZ_SPEED, *cold).max_temperature
    assert centre == pytest.approx(152.3, abs=0.05)
    # the rigid slip (mu p times 1 m/s) in place of the solver's: the anchor's value
    a, b = 5.88e-3, 10.54e-3
    p0 = 3 * 100e3 / (2 * math.pi * a * b)
    anchor = 0.5 * 1.23462 * ERTZ_MU * p0 * 1.0 * math.sqrt(a / ERTZ_SPEED) / math.sqrt(
        50.0 * 7850.0 * 450.0)                                       # 150.30 degC
    rigid = _rigid(slide, 1.0, ERTZ_SPEED)
    assert surface_temperature(rigid, ERTZ_SPEED, *cold).max_temperature == pytest.approx(
        anchor, rel=1e-3)
    # the thesis's strip solution (FASTSIM's strips, half the heat into each body)
    prob = FastsimProblem(a=a, b=b, p0=p0, L1=L1(a, C11(a / b, 0.28), 82e9),
                          layer=LayerParams(mu_c1=0.3, mu_c2=0.3), speed=ERTZ_SPEED,
                          ambient_temperature=0.0,
                          thermal=ThermalParams(50.0, 7850.0, 450.0, 0.5, "rigid"))
    strip = float(boundary_traction(prob, 1 / 30).max_temperature_C[0])   # 149.9 degC
    assert strip == pytest.approx(anchor, rel=5e-3)


def _rigid(sol, w: float, v: float):
    """``sol`` with every sliding element's slip replaced by the rigid slip ``w`` [m/s]."""
    import dataclasses

    sigma = np.zeros_like(sol.sigma)
    sigma[..., 0] = np.where(sol.state == SLIP, w * sol.grid.dx / v, 0.0)
    return dataclasses.replace(sol, sigma=sigma)


def _lines_after(rel: str, first: str) -> list[str]:
    lines = bank_file(rel).read_text(encoding="utf-8").splitlines()
    return [lines[i + 1] for i, line in enumerate(lines) if line.split()[:1] == [first]
            and "FRIC.POWER" in line]


@pytest.mark.slow  # one more tangential solve with partial sliding (about 1 s); cases 1-3 quick
def test_ertz_temperature_case_4(ertz):
    """Partial sliding (xi = -0.2 %, eta = 0.1 %, phi = 2e-4 1/mm) with the wheel at 150 degC:
    CONTACT's forces, element division, frictional power and largest surface temperature."""
    from torlab.model.exact.temperature import surface_temperature

    ref, cnt = totals("examples/ertz_temperature.ref_out")[3], counts(
        "examples/ertz_temperature.ref_out")[3]
    row = second_row("examples/ertz_temperature.ref_out", "FN/G")[3]
    power = float(_lines_after("examples/ertz_temperature.ref_out", "FN")[3].split()[5])
    s = _ertz_solve(ertz, -0.002, 0.001, 0.0002)
    assert -s.Fx == pytest.approx(ref["FX"], rel=ROUNDING)             # mirrored x
    assert s.Fy == pytest.approx(ref["FY"], rel=ROUNDING)
    assert -s.Mz * 1e3 == pytest.approx(ref["MZ"], rel=ROUNDING)       # N mm
    assert (s.counts()["adhesion"], s.counts()["slip"]) == (cnt["NADH"], cnt["NSLIP"])
    t = surface_temperature(s, ERTZ_SPEED, *_bodies(0.0, 150.0), own_element="contact")
    assert t.power == pytest.approx(-power, rel=ROUNDING)
    assert t.max_temperature == pytest.approx(float(row[-1]), rel=ROUNDING)


def test_hou_curves_do_not_separate_the_laws():
    """The Hou-Kalousek-Magel curves of CONTACT's bank (doc/plot_hou.m) are its bilinear
    idealisations: two points per material (the onset and one point of the plastic
    branch).  CONTACT's linear law reproduces them by construction; Voce's law reaches a
    straight branch only in its limit (a Voce length far beyond the tested slip, the
    saturation stress far outside the measured range), where it fits them as well: the
    curves cannot tell the laws apart."""
    import re

    from scipy.optimize import least_squares

    text = bank_file("doc/plot_hou.m").read_text(encoding="utf-8")
    pts = {}
    for key in ("utot_c0", "tau_c0", "utot_c1", "tau_c1"):
        pts[key] = [float(v) for v in re.findall(rf"{key}\(\d\)\s*=\s*([-\d.]+);", text)]
    assert all(len(v) == 4 for v in pts.values())
    for u0, t0, u1, t1 in zip(*pts.values(), strict=True):
        k = (t1 - t0) / (u1 - u0)                       # MPa/um
        u = np.linspace(u0, 600.0, 200)
        lin = t0 + k * (u - u0)
        if k == 0:                                      # magnetite: perfectly plastic
            continue
        fit = least_squares(lambda x, u=u, lin=lin, t0=t0, u0=u0:
                            t0 + (x[0] - t0) * -np.expm1(-(u - u0) / x[1]) - lin,
                            [t0 + 500 * k, 1000.0], bounds=([-1e5, 1.0], [1e5, 1e8]))
        rms = math.sqrt(np.mean(fit.fun**2))
        assert rms < 1e-3 * abs(t1 - t0)
        assert fit.x[1] > 10 * (600.0 - u0)             # Voce length >> the tested slip

