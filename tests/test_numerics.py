"""Stopping rules and vectorised loops of the boundary model.

* The yield-angle Newton iteration stops on a *relative* step and takes a few
  iterations (the count is exposed as ``BoundaryResult.yield_iterations``).
* The contact-temperature loop runs every point (creepage, speed) in one array with
  an active set: a point's result does not depend on the points computed with it,
  and a Stribeck curve with temperature is one FASTSIM call.
* Regression guard: numbers computed by the code *before* these changes (per-point
  temperature loop, ``scipy`` bracketed root for the yield angle with temperature,
  absolute stop on the isothermal Newton step).  They prove nothing about accuracy
  -- that is proven against the grid-free reference, Kalker's linear theory and full
  slip in ``test_boundary.py`` -- only that the rewrite did not move the results by
  more than 1e-9.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ROOT

from torlab.bench.fastsim import TEST_SET_A_OVER_B, scene_problem
from torlab.bench.scenes import full_mixed_scene
from torlab.bench.temperature import thermal_problem
from torlab.errors import ConvergenceError
from torlab.model import fastsim
from torlab.model.fastsim import boundary_traction
from torlab.model.hertz import hertz_exact
from torlab.model.strip import e_strip
from torlab.scene import load_scene, scene_from_dict

SOFTENING = {"mu_c1": 0.45, "mu_c2": 0.30}
CURVE = np.r_[np.linspace(0.0, 0.05, 101), 1e-5, 1e-4, 0.1, 0.5, 1.0]


# ---------------------------------------------------------------------------------------
# the yield-angle iteration: relative stop, few iterations
# ---------------------------------------------------------------------------------------
def test_relative_stop_ends_the_iteration_inside_round_off_noise():
    """A residual that carries noise of a few ulp of pi near its root (what round-off
    does to e(theta) - c sin(theta) near the trailing edge): Newton then keeps stepping
    by ~1e-15, above any absolute threshold of that size, and only a relative stop
    ends it.  The root must still be found to the noise level."""
    root = 3.0

    def fdf(th):
        bits = np.asarray(th, dtype=np.float64).view(np.int64)
        noise = 3e-15 * ((bits % 3) - 1.0)  # deterministic, ~7 ulp of 3.0
        return (th - root) + noise, np.ones_like(th)

    lo = np.full(4, 2.9)
    hi = np.full(4, math.pi)
    th, its = fastsim._bracketed_newton(fdf, lo, hi, np.array([2.95, 3.05, 3.1, 2.91]), "test")
    assert its <= 4
    assert np.all(np.abs(th - root) <= 1e-14)


def test_yield_newton_raises_a_named_error_when_out_of_budget(monkeypatch):
    monkeypatch.setattr(fastsim, "_YIELD_MAX_ITER", 1)
    with pytest.raises(ConvergenceError, match="yield angle"):
        boundary_traction(scene_problem(1.0, boundary=SOFTENING), [0.01])


@pytest.mark.parametrize("ab", TEST_SET_A_OVER_B)
def test_yield_iterations_stay_few_on_the_softening_scene(ab):
    """Softening layer (mu_c1 0.45 -> mu_c2 0.30) on the Tab. 5.4 contact, a 101-point
    curve plus extreme creepages: the Newton iteration converges in a handful of steps
    (measured 5-7; the absolute stop it replaces could run its 60-step budget)."""
    res = boundary_traction(scene_problem(ab, boundary=SOFTENING), CURVE)
    assert 1 <= res.yield_iterations <= 10


@pytest.mark.parametrize("layer, over", [(True, None), (False, None), (True, {"L_mue": 0.0})])
def test_yield_iterations_stay_few_on_the_other_test_set_layers(layer, over):
    for ab in TEST_SET_A_OVER_B:
        res = boundary_traction(scene_problem(ab, layer=layer, boundary=over), CURVE)
        assert 1 <= res.yield_iterations <= 12


def test_yield_iterations_with_temperature_stay_few():
    res = boundary_traction(thermal_problem(), np.linspace(0.0, 0.05, 21))
    assert res.temperature_loop == "iterated"
    assert 1 <= res.yield_iterations <= 10


# ---------------------------------------------------------------------------------------
# the temperature loop: per point, vectorised across points and speeds
# ---------------------------------------------------------------------------------------
def test_temperature_batch_equals_one_point_at_a_time():
    """Each point leaves the loop when it has converged: a curve computed in one call
    is the same as its points computed one by one (before, converged points kept
    iterating until the slowest had converged, which moved them within the 0.1 K
    tolerance)."""
    prob = thermal_problem()
    xi = np.linspace(0.0, 0.05, 11)
    batch = boundary_traction(prob, xi)
    for i, x in enumerate(xi):
        one = boundary_traction(prob, [x])
        assert batch.mu[i] == pytest.approx(one.mu[0], rel=1e-13, abs=1e-15)
        assert batch.max_temperature_C[i] == pytest.approx(one.max_temperature_C[0], rel=1e-13)
        assert batch.temperature_iterations[i] == one.temperature_iterations[0]
    assert len(set(batch.temperature_iterations[1:])) > 1  # the points need different counts


def _hot_mixed_scene():
    """The full mixed scene, hotter: lower conductivity, stronger temperature coefficients."""
    d = full_mixed_scene().model_dump(exclude_none=True)
    d["thermal"]["conductivity"] = 5.0
    d["boundary"].update(mu_c1_T=-3e-3, mu_c2_T=-3e-3)
    return scene_from_dict(d)


def test_stribeck_with_temperature_equals_one_fastsim_call_per_speed():
    """The vectorised Stribeck curve (one FASTSIM call, one point per speed) against the
    per-speed calls it replaces, on a scene where the speeds need 0-4 loop iterations
    (v = 0: boundary regime, no heating)."""
    from torlab.model.loadshare import solve_load_sharing
    from torlab.model.mixed import boundary_part, mixed_contact
    from torlab.model.predict import predict_stribeck

    sc = _hot_mixed_scene()
    v = np.r_[0.0, np.geomspace(0.01, 10.0, 12)]
    xi = 0.3
    table = predict_stribeck(sc, v, xi).table
    mc = mixed_contact(sc)
    p = mc.contact.patch
    ls = solve_load_sharing(v, p.F, p.a, p.b, mc.film, mc.asperity)
    counts = set()
    for i in range(v.size):
        one = boundary_part(mc, np.array([xi]), float(v[i]), float(ls.film_thickness[i]),
                        float(ls.load_share_asperity[i]))
        assert table["mu_boundary"][i] == pytest.approx(one.mu[0], rel=1e-13)
        assert table["max_temperature_C"][i] == pytest.approx(one.max_temperature_C[0], rel=1e-13)
        counts.add(int(one.temperature_iterations[0]))
    assert {0, 2, 3, 4} <= counts


def test_speed_per_point_is_validated():
    prob = thermal_problem()
    with pytest.raises(ValueError, match="speed"):
        boundary_traction(prob, [0.01, 0.02], speed=[1.0, -1.0])
    with pytest.raises(ValueError, match="speed"):
        boundary_traction(prob, [0.01], speed=[np.nan])


def test_speed_per_point_matches_the_problem_speed():
    import dataclasses

    prob = thermal_problem()
    xi = np.array([0.005, 0.02, 0.04])
    v = np.array([2.0, 10.0, 25.0])
    mixed = boundary_traction(prob, xi, speed=v)
    for i in range(xi.size):
        one = boundary_traction(dataclasses.replace(prob, speed=float(v[i])), [xi[i]])
        assert mixed.mu[i] == pytest.approx(one.mu[0], rel=1e-13)
        assert mixed.max_temperature_C[i] == pytest.approx(one.max_temperature_C[0], rel=1e-13)


# ---------------------------------------------------------------------------------------
# no layer flexibility with temperature (0/0 at the leading edge)
# ---------------------------------------------------------------------------------------
def test_e_strip_without_layer_is_one_minus_cos():
    """r = 0 (L_mue = 0): e(theta) = integral_0^theta sin t dt = 1 - cos(theta), also at
    theta = 0, where the quadrature branch used to divide 0 by 0."""
    th = np.array([0.0, 1e-9, 0.3, 1.0, 2.5, math.pi])
    np.testing.assert_allclose(e_strip(th, 0.0), 2.0 * np.sin(0.5 * th) ** 2, rtol=1e-13, atol=0)


def test_thermal_scene_without_layer_flexibility_has_a_finite_temperature():
    """The documented Tab. 5.4 scene with thermal: and no L_mue/L_mup: finite flash
    temperatures, the limit of a vanishing L_mue."""
    from torlab.model.predict import predict_traction

    base = load_scene(ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml").model_dump(exclude_none=True)
    base["boundary"].pop("L_mue")
    base["boundary"].pop("L_mup")
    xi = [0.001, 0.01, 0.05]
    t0 = predict_traction(scene_from_dict(base), xi).table
    base["boundary"]["L_mue"] = 1e-15
    t1 = predict_traction(scene_from_dict(base), xi).table
    T0 = t0["max_temperature_C"].to_numpy()
    assert np.all(np.isfinite(T0)) and np.all(T0 > 20.0)
    np.testing.assert_allclose(T0, t1["max_temperature_C"].to_numpy(), rtol=1e-9)
    np.testing.assert_allclose(t0["mu"], t1["mu"], rtol=1e-9)


# ---------------------------------------------------------------------------------------
# exact Hertz: nearly circular contacts
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("d", [1e-9, 1e-6, 2e-5, 1e-4, 1e-2])
def test_exact_hertz_nearly_circular_against_mpmath(d):
    """Curvature ratio 1 + d: the eccentricity m from 40-digit elliptic integrals
    (mpmath) solving (E/(1-m) - K)/(K - E) = 1 + d (Johnson Eq. 4.39).  Before the
    bracketed root stopped on a relative tolerance and the residual was written
    without cancelling E against K, m stuck at the bracket's lower end (1e-12) for
    d up to about 3e-5."""
    import mpmath as mp

    mp.mp.dps = 40
    D = mp.mpf(d)

    def g(m):
        K, E = mp.ellipk(m), mp.ellipe(m)
        return (E / (1 - m) - K) / (K - E) - (1 + D)

    m_ref = mp.findroot(g, 4 * D / 3)
    F, Es, r = 1000.0, 1e11, 0.01
    p = hertz_exact(F, r * (1 + d), r, Es)
    assert p.a / p.b == pytest.approx(float(1 / mp.sqrt(1 - m_ref)), rel=1e-13)
    a_ref = (3 * F * r * (1 + D) * (mp.ellipk(m_ref) - mp.ellipe(m_ref)) / (mp.pi * Es * m_ref)) ** (
        mp.mpf(1) / 3)
    assert p.a == pytest.approx(float(a_ref), rel=1e-12)


# ---------------------------------------------------------------------------------------
# regression guard (numbers from the code before this change; see the module docstring)
# ---------------------------------------------------------------------------------------
XI = [1e-5, 1e-4, 1e-3, 0.004, 0.01, 0.03, 0.1, 0.5]
ISOTHERMAL = {
    ("softening", 0.2): [0.0007478880865080575, 0.007478015505271195, 0.07391227624259296,
                         0.24785844669828233, 0.34820450990784657, 0.3351565362792278,
                         0.30771471538706935, 0.3007092878617818],
    ("softening", 1.0): [0.001213465883368494, 0.012131000292512495, 0.11766918994917169,
                         0.31482923478531877, 0.34475370412105516, 0.3145278812480566,
                         0.30250344648588673, 0.30021643124389785],
    ("softening", 5.0): [0.0024294492087822716, 0.024265196468622335, 0.21425954023449084,
                         0.34524374109268346, 0.32190802419480236, 0.30468646865813825,
                         0.3007492009157998, 0.3000642378153669],
    ("layer", 0.2): [0.0007478869939871327, 0.0074769226573068994, 0.07282267496300328,
                     0.219692554563354, 0.3216344656725978, 0.4044444933651229,
                     0.4410492847026404, 0.4491900543635415],
    ("layer", 2.0): [0.0015773415952788437, 0.015755365397800286, 0.1419881463374025,
                     0.3198887275040982, 0.4002063871322483, 0.43929106018403197,
                     0.4482869419808431, 0.4498534562020893],
    ("classic", 1.0): [0.0021164608074776626, 0.021121839150070126, 0.17760244523955956,
                       0.2906483121936479, 0.2992798415091867, 0.29997240109772066,
                       0.2999992536567423, 0.29999999640023023],
    ("L_mue = 0", 0.5): [0.0018697118510265216, 0.0186677759876165, 0.16346294458019597,
                         0.3178859859454018, 0.3783123924982058, 0.4285039721080949,
                         0.4461901119761419, 0.4496646089241396],
}
_LAYERS = {"softening": (True, SOFTENING), "layer": (True, None), "classic": (False, None),
           "L_mue = 0": (True, {"L_mue": 0.0})}


@pytest.mark.parametrize("key", list(ISOTHERMAL))
def test_regression_guard_isothermal(key):
    layer, over = _LAYERS[key[0]]
    mu = boundary_traction(scene_problem(key[1], layer=layer, boundary=over), XI).mu
    np.testing.assert_allclose(mu, ISOTHERMAL[key], rtol=0, atol=1e-9)


def test_regression_guard_temperature_loop():
    """Tab. 5.4 at 10 m/s with mu_c1_T = mu_c2_T = -0.002 1/K, computed in one call; the
    old numbers are one call per creepage (the old loop's batch results differed from
    those by up to 1.5e-6 in mu and 0.013 K, within its 0.1 K tolerance)."""
    res = boundary_traction(thermal_problem(), [0.0025, 0.01, 0.025, 0.05])
    np.testing.assert_allclose(res.mu, [0.2296230718879687, 0.3597803929784387,
                                        0.3671743457474055, 0.333891500736552],
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.max_temperature_C,
                               [29.336821133904415, 72.08076230930814, 144.96269455522122,
                                237.32072585121927], rtol=1e-9)


def test_regression_guard_full_mixed_scene():
    """Boundary + EHL + asperities + temperature: a Stribeck curve (old: one FASTSIM
    call per speed) and a traction curve."""
    from torlab.model.mixed import mixed_traction_curve
    from torlab.model.predict import predict_stribeck

    sc = full_mixed_scene()
    t = predict_stribeck(sc, np.geomspace(0.01, 2.0, 8), 0.05).table
    np.testing.assert_allclose(
        t["mu"], [0.13577465308470085, 0.12756249891601118, 0.11544050373371931,
                  0.0983889395944509, 0.0760176535528844, 0.04969689025142958,
                  0.024026944692836512, 0.006460727878052212], rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        t["max_temperature_C"], [22.761394041301145, 23.044353296381004, 23.379784453212018,
                                 23.716828940243463, 23.93656275938537, 23.848436922138724,
                                 23.30481529101513, 22.512097793957643], rtol=1e-9)
    mu = mixed_traction_curve(sc, [0.001, 0.005, 0.02, 0.05]).table["mu"]
    np.testing.assert_allclose(mu, [0.006381073716888548, 0.024615909009184977,
                                    0.039138438683792916, 0.04514403543225885],
                               rtol=0, atol=1e-9)


# ---------------------------------------------------------------------------------------
# BLAS/OpenMP threads of the fits
# ---------------------------------------------------------------------------------------
def test_fits_run_with_one_blas_thread_and_give_the_pools_back():
    import scipy.linalg  # noqa: F401  (both BLAS builds loaded)
    from threadpoolctl import threadpool_info

    from torlab.fit.film import fit_film_thickness
    from torlab.fit.layer import fit_layer_hpt
    from torlab.fit.temperature import fit_temperature_coefficients
    from torlab.fit.traction import fit_layer_traction
    from torlab.fit.viscosity import fit_barus, fit_roelands
    from torlab.threads import small_problem

    def pools():
        return {i["filepath"]: i["num_threads"] for i in threadpool_info()}

    @small_problem
    def probe():
        return pools()

    before = pools()
    inside = probe()
    assert inside and all(n == 1 for n in inside.values())
    assert pools() == before
    for fit in (fit_layer_hpt, fit_layer_traction, fit_film_thickness, fit_barus, fit_roelands,
                fit_temperature_coefficients):
        assert hasattr(fit, "__wrapped__"), fit.__name__  # decorated with small_problem
