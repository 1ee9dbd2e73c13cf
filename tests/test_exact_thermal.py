"""The contact temperature coupled to the layer's limits on the exact solver's grid
(torlab.model.exact.thermal).

References independent of the coupling:

* zero temperature coefficients: the isothermal solve, bit for bit, whether the loop is
  skipped or forced to run;
* full slip (every element flowing at the layer's limit): the force is the integral of
  the limit ``tau_c(p, T) = mu_c1 p exp(mu_c1_T dT)`` over the Hertz ellipse -- by a
  quadrature of Hertz's pressure with the solver's temperature field
  (``surface_temperature``), and by an independent strip march of the same model
  (Hertz's pressure, Eq. 5.50's kernel, the limit at the local temperature on 400 cells
  per strip) that knows nothing of the exact solver;
* FASTSIM's path with the flash temperature on the same scene: within the default
  method's stated theory error plus the exact solver's discretisation error;
* hard cases: converged and finite, or ConvergenceError, never NaN.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from torlab.errors import ConvergenceError
from torlab.model.exact import ExactGrid, exact_creep_forces
from torlab.model.exact.scene import exact_contact, predict_exact
from torlab.model.exact.temperature import surface_temperature
from torlab.scene import scene_from_dict

GRID = ExactGrid(n=12, coarse=7)   # small grids: the quick suite's
VOCE = {"mu_c1": 0.3, "mu_c2": 0.45, "L_mue": "10 um", "L_mup": "20 um",
        "mu_c1_T": -2e-3, "mu_c2_T": -3e-3}
BETA = math.sqrt(50.0 * 7850.0 * 450.0)   # Tab. 5.4 steel's effusivity


def _scene(boundary: dict, speed: float = 10.0, thermal: dict | None = None, method: str = "fastsim"):
    """Tab. 5.4's wheel-rail contact with the given layer (and thermal section)."""
    d = {"name": "thermal", "contact": {"load": "20 kN", "a": "3.7 mm", "b": "3.3 mm"},
         "materials": {"E1": "210 GPa", "nu1": 0.28, "E2": "210 GPa", "nu2": 0.28},
         "kinematics": {"speed": f"{speed} m/s", "ambient_temperature": "20 degC"},
         "boundary": boundary, "grid": {"method": method}}
    if thermal is not None:
        d["thermal"] = {"conductivity": 50, "density": 7850, "heat_capacity": 450, **thermal}
    return scene_from_dict(d)


# ---------------------------------------------------------------- (a) zero coefficients
def test_zero_coefficients_equal_the_isothermal_solver_bit_for_bit():
    """With zero temperature coefficients the thermal path runs no loop and returns the
    isothermal forces exactly, with the temperature reported from the one pass."""
    xi = [1e-3, 4e-3, 2e-2]
    cold = {**VOCE, "mu_c1_T": 0.0, "mu_c2_T": 0.0}
    hot = predict_exact(_scene(cold, thermal={}), xi, grid=GRID)
    iso = predict_exact(_scene(cold), xi, grid=GRID)
    for col in ("mu", "Fx_N", "Fx_error_N", "adhesion_fraction", "plastic_fraction"):
        assert np.array_equal(hot.table[col].to_numpy(), iso.table[col].to_numpy()), col
    assert "max_temperature_C" not in iso.table
    t = hot.table["max_temperature_C"].to_numpy()
    assert np.all(np.diff(t) > 0) and t[0] > 20.0          # heats with the slip
    assert any("computed once, no tau-T loop (the temperature coefficients are zero" in m
               for m in hot.modelled)
    assert any(m == "contact temperature: not modelled (no thermal: section)"
               for m in iso.modelled)
    assert hot.summary["temperature_iterations_max"] == 1


def test_forced_loop_with_zero_coefficients_changes_nothing():
    """The loop itself, forced to run on a layer whose limits do not depend on the
    temperature (a non-zero sensitivity claimed), solves again at the first pass's
    temperature field, from the first pass's traction, and returns the isothermal forces
    to the solver's tolerance (1e-8 of the load: the re-solve starts elsewhere, so not
    bit for bit) after two solves; a temperature field handed to the yield law (c2) with
    zero coefficients leaves the solution unchanged bit for bit."""
    cold = {**VOCE, "mu_c1_T": 0.0, "mu_c2_T": 0.0}
    ec = exact_contact(_scene(cold, thermal={}))
    forced = replace(ec, thermal=replace(ec.thermal, sensitivity=1e-3))
    xi = [2e-3, 1e-2]
    a = exact_creep_forces(forced, xi, 0.0, 0.0, GRID)
    b = exact_creep_forces(replace(ec, thermal=None), xi, 0.0, 0.0, GRID)
    assert a.temperature_loop == "iterated" and np.all(a.temperature_iterations == 2)
    assert np.allclose(a.Fx, b.Fx, rtol=0.0, atol=1e-8 * ec.load)
    assert np.allclose(a.Fx_error, b.Fx_error, rtol=0.0, atol=1e-8 * ec.load)
    from torlab.model.exact.rolling import RollingSetup

    st = RollingSetup(ec, 10, GRID)
    field = np.linspace(0.0, 300.0, st.pn.size).reshape(st.pn.shape)
    s0, s1 = st.solve(5e-3, 1e-3, 0.5, None), st.solve(5e-3, 1e-3, 0.5, None, field)
    assert np.array_equal(s0.p, s1.p) and np.array_equal(s0.state, s1.state)


# ------------------------------------------------------------------- (b) full slip
def _strip_reference(a, b, N, mu, muT, xi, v, *, M=400, S=48):
    """Full slip of a perfectly plastic layer by an independent march: per strip (Gauss
    nodes in ``y = b sin(phi)``) ``M`` cells of Hertz's pressure; the rise at each cell
    centre is Eq. 5.50's kernel over the cells upstream plus the cell's own heat up to
    its centre, ``q = mu p exp(muT dT) xi v``, solved cell by cell (partition 1).
    Returns ``(F / N, largest rise [K])``."""
    p0 = 3 * N / (2 * math.pi * a * b)
    phi, wphi = np.polynomial.legendre.leggauss(S)
    phi, wphi = 0.5 * math.pi * phi, 0.5 * math.pi * wphi
    y, ay = b * np.sin(phi), a * np.cos(phi)
    dx = 2 * ay / M
    x = ay[:, None] - (np.arange(M) + 0.5)[None, :] * dx[:, None]   # from the leading edge
    p = p0 * np.sqrt(np.clip(1 - (x / a) ** 2 - (y[:, None] / b) ** 2, 0.0, None))
    k = np.arange(M)
    w = 2 * (np.sqrt(k + 0.5) - np.sqrt(np.maximum(k - 0.5, 0.0)))
    w[0] = 2 * math.sqrt(0.5)
    w = w[None, :] * np.sqrt(dx)[:, None]
    c = 1.0 / (BETA * math.sqrt(math.pi * v))
    q = np.zeros((S, M))
    rise = np.zeros((S, M))
    for i in range(M):
        up = np.sum(q[:, :i] * w[:, i:0:-1], axis=1) if i else 0.0
        d = np.zeros(S)
        for _ in range(60):    # a contraction: c w0 mu p |muT| xi v << 1
            d = c * (up + mu * p[:, i] * np.exp(muT * d) * xi * v * w[:, 0])
        rise[:, i] = d
        q[:, i] = mu * p[:, i] * np.exp(muT * d) * xi * v
    F = np.sum(np.sum(q / (xi * v) * dx[:, None], axis=1) * b * np.cos(phi) * wphi)
    return F / N, float(rise.max())


def test_full_slip_force_is_the_integral_of_the_limit_at_the_temperature():
    """Large creepage, a perfectly plastic layer softening with temperature: every element
    flows at tau_c(p, T); the force equals the limit's integral over the Hertz ellipse at
    the computed temperature field (quadrature, 2e-3), and an independent strip march of
    the same model gives the force (2e-3) and the peak temperature (2 %); the isothermal
    limit mu_c1 N lies 13 % away."""
    mu, muT, xi, v = 0.3, -2e-3, 0.1, 1.0
    sc = _scene({"law": "perfect", "mu_c1": mu, "L_mue": "10 um", "mu_c1_T": muT}, speed=v,
                thermal={})
    ec = exact_contact(sc)
    r = exact_creep_forces(ec, [xi], 0.0, 0.0, ExactGrid(n=16, coarse=10), keep_solutions=True)
    s = r.solutions[0]
    inside = s.state > 0
    assert r.temperature_loop == "iterated" and np.all(s.state[inside] == 3)  # all flowing
    # the temperature field the solver converged to, from surface_temperature
    q = np.where(inside, np.linalg.norm(s.p, axis=-1) * xi * v, 0.0)
    T = surface_temperature(s, v, ec.thermal.body, ec.thermal.body, partition=1.0,
                            heat_flux=q).body1
    g, a, b, N = s.grid, ec.a, ec.b, ec.load
    u, wu = np.polynomial.legendre.leggauss(200)
    R, TH = np.meshgrid(0.5 * (u + 1), math.pi * (u + 1), indexing="ij")
    X, Y = a * R * np.cos(TH), b * R * np.sin(TH)
    P = 3 * N / (2 * math.pi * a * b) * np.sqrt(1 - R**2)
    ix = np.clip(((X - g.x0) / g.dx).astype(int), 0, g.mx - 1)
    iy = np.clip(((Y - g.y0) / g.dy).astype(int), 0, g.my - 1)
    tau = mu * P * np.exp(muT * (T[ix, iy] - 20.0))
    quad = float(np.sum(tau * a * b * R * (0.5 * wu)[:, None] * (math.pi * wu)[None, :])) / N
    got = float(r.mu_x[0])
    assert got == pytest.approx(quad, rel=2e-3)
    ref, peak = _strip_reference(a, b, N, mu, muT, xi, v)
    assert got == pytest.approx(ref, rel=2e-3)
    assert float(r.max_temperature_C[0]) - 20.0 == pytest.approx(peak, rel=0.02)
    assert abs(got / mu - 1) > 0.1                        # the temperature matters here


# ------------------------------------------------------------------- (c) FASTSIM's path
@pytest.mark.slow  # the default exact grid (25 and 15 elements) along a curve, 1-2 s; the
# temperatures' agreement stays quick (the next test)
def test_exact_thermal_curve_lies_within_the_default_methods_theory_error():
    """The same hot scene by the default method (FASTSIM corrected, flash temperature on
    its strips) and by the exact solver with the coupled temperature: the curves differ by
    less than the default method's stated theory error plus the exact solver's
    discretisation error, and the contact temperatures' rises agree within 5 % (both Eq.
    5.50 with q = tau w; they differ by the traction each theory distributes)."""
    from torlab.model.predict import predict_traction

    sc = _scene(VOCE, thermal={})
    xi = np.array([1e-3, 3e-3, 1e-2, 4e-2])
    ex = predict_exact(sc, xi, grid=ExactGrid(n=sc.grid.exact_n)).table
    fast = predict_traction(sc, xi, method="fastsim").table
    d = np.abs(ex["mu"].to_numpy() - fast["mu"].to_numpy())
    allowed = fast["mu_theory_error_95"].to_numpy() + ex["mu_x_error"].to_numpy()
    assert np.all(d <= allowed), (d, allowed)
    rise_e = ex["max_temperature_C"].to_numpy() - 20.0
    rise_f = fast["max_temperature_C"].to_numpy() - 20.0
    assert np.allclose(rise_e, rise_f, rtol=0.05)
    # the heating matters: the curve falls after its peak, unlike the isothermal one
    assert ex["mu"].iloc[-1] < ex["mu"].iloc[-2]


def test_contact_temperatures_of_both_paths_agree():
    """On small grids the exact path's contact temperature rise agrees with FASTSIM's flash
    temperature within 5 % (both Eq. 5.50 with q = tau w and partition 1)."""
    from torlab.model.traction import traction_curve

    sc = _scene(VOCE, thermal={})
    xi = np.array([3e-3, 1e-2, 4e-2])
    ex = predict_exact(sc, xi, grid=GRID).table["max_temperature_C"].to_numpy() - 20.0
    fast = traction_curve(sc, xi).table["max_temperature_C"].to_numpy() - 20.0
    assert np.allclose(ex, fast, rtol=0.05)


def test_auto_uses_the_exact_solver_for_a_hot_scene_by_the_theory_error_rule():
    """choose_method no longer keeps a scene whose limits follow the temperature on
    FASTSIM: without a band (nothing says the theory error is negligible) auto takes the
    exact solver, whose output reports the contact temperature and the loop."""
    from torlab.model.predict import choose_method, predict_traction

    sc = _scene(VOCE, thermal={})
    fast = predict_traction(sc, [1e-3, 1e-2], method="fastsim")
    used, why = choose_method(sc, fast)
    assert used == "exact" and "no band" in why


# ------------------------------------------------------------------- (d) hard cases
def test_hard_cases_converge_or_raise_never_nan():
    """Strong softening with temperature at high speed (the first pass heats by 1500 K,
    at which the limits would fall by exp(-45)) converges: softening limits its own heat,
    and each step may change the limits by a factor e at most; the forces and
    temperatures are finite and the heating is far below the first pass's.  A positive
    coefficient that runs away and an iteration budget too small raise ConvergenceError
    naming the point."""
    xi = [2e-3, 2e-2, 0.1]
    strong = {**VOCE, "mu_c1_T": -0.02, "mu_c2_T": -0.03}
    r = predict_exact(_scene(strong, speed=60.0, thermal={}), xi, grid=GRID)
    tab = r.table[["mu", "Fx_error_N", "max_temperature_C"]].to_numpy()
    assert np.all(np.isfinite(tab)) and np.all(r.table["mu"] > 0)
    t = r.table["max_temperature_C"].to_numpy()
    assert np.all(t > 20.0) and t[-1] < 20.0 + 0.2 * 1500  # heating limited by softening
    mu = r.table["mu"].to_numpy()
    assert mu[-1] < 0.2 * 0.45 and mu[-1] < mu[1]        # the limits fell with the heat
    runaway = {**VOCE, "mu_c1_T": 0.05, "mu_c2_T": 0.05}
    with pytest.raises(ConvergenceError, match=r"runs away|diverged"):
        predict_exact(_scene(runaway, speed=60.0, thermal={}), [0.1], grid=GRID)
    with pytest.raises(ConvergenceError, match=r"did not converge at creepage 0\.02"):
        predict_exact(_scene(VOCE, speed=30.0, thermal={"max_iterations": 2}), [2e-2],
                      grid=GRID)


def test_a_scene_at_rest_and_a_weak_heating_take_one_pass():
    """No rolling (speed 0) heats nothing; a tiny coefficient whose heating changes the
    limits by less than 1e-6 runs no loop, and the output says why."""
    r = predict_exact(_scene(VOCE, speed=0.0, thermal={}), [1e-2], grid=GRID)
    assert r.table["max_temperature_C"].iloc[0] == 20.0
    weak = {**VOCE, "mu_c1_T": 1e-12, "mu_c2_T": 0.0}
    r = predict_exact(_scene(weak, thermal={}), [1e-2], grid=GRID)
    assert any("less than 1e-06" in m for m in r.modelled)
    assert r.summary["temperature_iterations_max"] == 1


def _small_exact(scene):
    return scene.model_copy(update={"grid": scene.grid.model_copy(
        update={"method": "exact", "exact_n": 8})})


def test_polach_data_by_the_exact_theory_follow_the_speed_of_a_hot_scene():
    """Polach's data by the exact theory solve each speed with its own heating: the hot
    layer loses traction with speed."""
    from torlab.fit.polach import polach_data
    from torlab.model.creep import creep_problem

    hot = _small_exact(_scene(VOCE, thermal={}))
    df = polach_data(creep_problem(hot), [2e-3, 1e-2, 3e-2], [1.0, 20.0],
                     exact=(exact_contact(hot), ExactGrid(n=8)))
    slow, fast = (df[df["speed_m_s"] == v]["mu_x"].to_numpy() for v in (1.0, 20.0))
    assert np.all(fast < slow)


@pytest.mark.slow  # two exact tables over 16 cells each (3-6 s); the per-speed contact is
# quick in the Polach test above
def test_exact_creep_table_follows_the_speed_of_a_hot_scene():
    """A speed axis of the exact solver's table solves each speed with its own heating: the
    hot layer loses traction with speed, a cold one does not (its values repeat along the
    axis, and the table says so)."""
    pytest.importorskip("xarray")
    from torlab.model.creep_table import scene_creep_table

    axes = ([2e-3, 1e-2], [0.0, 1e-3], [0.0, 1.0])
    hot = _small_exact(_scene(VOCE, thermal={}))
    t = scene_creep_table(hot, *axes, speed=[1.0, 20.0])
    fx = t.dataset["Fx_N"].sel(creepage=1e-2, lateral=0.0, spin=0.0)
    assert float(fx.sel(speed=20.0)) < 0.97 * float(fx.sel(speed=1.0))
    temp = t.dataset["max_temperature_C"].sel(creepage=1e-2, lateral=0.0, spin=0.0)
    assert float(temp.sel(speed=20.0)) > float(temp.sel(speed=1.0)) > 20.0
    cold = hot.model_copy(update={"boundary": hot.boundary.model_copy(
        update={"mu_c1_T": 0.0, "mu_c2_T": 0.0})})
    t = scene_creep_table(cold, *axes, speed=[1.0, 20.0])
    fx = t.dataset["Fx_N"].sel(creepage=1e-2, lateral=0.0, spin=0.0)
    assert float(fx.sel(speed=20.0)) == float(fx.sel(speed=1.0))
    assert any("do not depend on speed" in n for n in t.notes)


def test_a_scenes_exact_contact_goes_to_worker_processes():
    """A scene's exact contact (its layer law, flexibility and thermal model) pickles, as
    the chunks of a curve on worker processes need (--jobs), and solves alike after."""
    import pickle

    ec = exact_contact(_scene(VOCE, thermal={}))
    back = pickle.loads(pickle.dumps(ec))
    a = exact_creep_forces(ec, [5e-3], 0.0, 0.0, GRID)
    b = exact_creep_forces(back, [5e-3], 0.0, 0.0, GRID)
    assert np.array_equal(a.Fx, b.Fx) and np.array_equal(a.max_temperature_C, b.max_temperature_C)


def _with_band(scene, rel: float):
    """The scene with a fit covariance of ``rel`` relative standard deviation on each of
    the layer's four parameters (the temperature coefficients fixed)."""
    b = scene.boundary
    names = ["mu_c1", "mu_c2", "L_mue", "L_mup"]
    vals = [getattr(b, n) for n in names]
    d = scene.model_dump(exclude_none=True)
    d["fit"] = {"kind": "test", "covariance": {"names": names, "values": vals,
                                               "matrix": np.diag((rel * np.array(vals)) ** 2)
                                               .tolist()}}
    return scene_from_dict(d)


def test_auto_weighs_a_hot_scenes_theory_error_against_its_band():
    """A hot scene follows the same rule as any other: a narrow band (1 %) is narrower than
    the default method's theory error, so auto takes the exact solver with its coupled
    temperature, and the fast band of mu and of the contact temperature is moved onto the
    exact curve (a wide band keeps the fast method by the same rule: tests/test_method.py)."""
    from torlab.model.predict import predict_traction

    sc = _scene(VOCE, thermal={}, method="auto")
    sc = sc.model_copy(update={"grid": sc.grid.model_copy(update={"exact_n": 10})})
    xi = np.array([2e-3, 1e-2, 3e-2])
    pred = predict_traction(_with_band(sc, 0.01), xi)
    assert pred.summary["method"]["method"] == "exact", pred.summary["method"]["why"]
    t = pred.table
    assert any("coupled to the limits" in m for m in pred.modelled)
    for c, lo, hi in (("mu", "mu_low95", "mu_high95"),
                      ("max_temperature_C", "max_temperature_low95_C", "max_temperature_high95_C")):
        assert np.all(t[lo] <= t[c]) and np.all(t[c] <= t[hi]), c
