"""Load sharing between film and asperities: balance, limits, Tab. 5.1 orderings, hard cases."""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest

from torlab.errors import NumericalError, TorlabInputError
from torlab.model.asperity import Roughness, p_a_elastic, p_a_plastic
from torlab.model.ehl import FilmThickness, Lubricant, hc_iso, hc_piezo, mu_ehl
from torlab.model.loadshare import (
    mixed,
    mixed_mu,
    mixed_tau,
    solve_load_sharing,
    solve_load_sharing_thesis,
)

# Paper A: 25.4 mm steel ball on glass, p0 = 0.75 GPa, water 1 mPa s, H = 6 GPa
E_GLASS = 75e9
R_A = 12.7e-3
P0_A = 0.75e9
A_A = math.pi * P0_A * R_A / (2 * E_GLASS)  # circular Hertz: a = pi p0 R / (2 E*)
F_A = 2 / 3 * math.pi * A_A**2 * P0_A
TAB51 = {"smooth": (8.3e-9, 0.301e-3, 24_200e6), "rough": (9.56e-9, 0.373e-3, 21_500e6)}
WATER = Lubricant(1e-3)
FILM_A = FilmThickness.from_contact(WATER, E_GLASS, R_A, A_A, A_A)


def _model(surface: str, model: str, E=E_GLASS):
    s, b, g = TAB51[surface]
    return Roughness(s, b, g, model=model, hardness=6e9).asperity_model(E)


SPEEDS = np.array([1e-4, 1e-3, 0.01, 0.1, 0.25, 0.5, 1.0, 1.5, 2.0, 5.0])


@pytest.mark.parametrize("surface,model", list(itertools.product(TAB51, ["elastic", "plastic"])))
def test_solution_balances_load_and_film(surface, model):
    asp = _model(surface, model)
    r = solve_load_sharing(SPEEDS, F_A, A_A, A_A, FILM_A, asp)
    assert np.all(r.regime == "mixed")
    # W_EHL + W_BL = W
    np.testing.assert_allclose(r.W_EHL + r.W_BL, r.W, rtol=1e-14)
    # the film carrying F_EHL is as thick as the separation (independent evaluation)
    np.testing.assert_allclose(hc_iso(SPEEDS, r.F_EHL, E_GLASS, R_A, 1e-3), r.h, rtol=1e-12)
    # the asperities carry F_BL at that separation (the public pressure functions)
    s, b, g = TAB51[surface]
    p = (p_a_elastic(r.h, s, b, g, E_GLASS) if model == "elastic"
         else p_a_plastic(r.h, s, b, g, 6e9))
    np.testing.assert_allclose(p * math.pi * A_A**2, r.F_BL, rtol=1e-12)
    assert np.all(r.residual < 1e-13)
    np.testing.assert_allclose(r.lam, r.h / s, rtol=1e-15)
    # the asperity share falls and the film grows with speed; mixed film >= full film
    assert np.all(np.diff(r.load_share_asperity) < 0)
    assert np.all(np.diff(r.h) > 0)
    assert np.all(r.h >= FILM_A.hc(SPEEDS, F_A))


def test_scalar_and_vector_paths_agree():
    asp = _model("rough", "plastic")
    vec = solve_load_sharing(SPEEDS, F_A, A_A, A_A, FILM_A, asp)  # vectorised root finder
    for i in (0, 4, 9):
        one = solve_load_sharing(float(SPEEDS[i]), F_A, A_A, A_A, FILM_A, asp)  # brentq
        assert isinstance(one.h, float) and isinstance(one.regime, str)
        assert one.h == pytest.approx(vec.h[i], rel=1e-12)
        assert one.load_share_asperity == pytest.approx(vec.load_share_asperity[i], rel=1e-12)
        assert one.iterations > 0 and one.evaluations > one.iterations


def test_speed_to_zero_all_load_on_asperities():
    # a rough surface whose asperities carry the load at positive separation (h* > 0)
    asp = Roughness(1e-6, 0.3e-3, 2.4e10, "plastic", hardness=6e9).asperity_model()
    r = solve_load_sharing(np.array([0.0, 1e-9, 1e-6, 1e-3]), F_A, A_A, A_A, FILM_A, asp)
    assert r.h_star > 0
    assert r.regime[0] == "boundary" and r.load_share_asperity[0] == 1.0
    assert r.h[0] == r.h_star and r.F_EHL[0] == 0.0 and r.film_thickness[0] == 0.0
    assert r.load_share_asperity[1] > 1 - 1e-9
    assert r.load_share_asperity[2] > 1 - 1e-3
    np.testing.assert_allclose(r.h[1:3], r.h_star, rtol=1e-3)
    # mu -> mu_boundary
    mu_bl = 0.3
    w = 0.05 * r.speed
    mu_e = np.where(r.film_thickness > 0, mu_ehl(w, np.where(r.film_thickness > 0,
                                                             r.film_thickness, 1.0),
                                                 P0_A, WATER), np.nan)
    mu = mixed(mu_e, mu_bl, r.W_EHL, r.W_BL, r.W)
    assert mu[0] == mu_bl
    assert mu[1] == pytest.approx(mu_bl, rel=1e-9)


def test_speed_to_zero_when_asperities_cannot_carry_the_load():
    # Tab. 5.1 at 0.75 GPa: h* < 0 for both models; a film formula only gives h > 0, so the
    # share tends to F_BL(h = 0)/F, with F_4(0) = 3/2: p_a(0) = pi^2 H K^2 (plastic)
    asp = _model("rough", "plastic")
    r = solve_load_sharing(np.array([0.0, 1e-12, 1e-9]), F_A, A_A, A_A, FILM_A, asp)
    assert r.h_star < 0
    K = 9.56e-9 * 0.373e-3 * 21_500e6
    limit = math.pi**2 * 6e9 * K**2 * math.pi * A_A**2 / F_A
    assert 0 < limit < 1
    assert r.load_share_asperity[1] == pytest.approx(limit, rel=1e-3)
    assert r.load_share_asperity[2] == pytest.approx(limit, rel=1e-2)
    assert r.load_share_asperity[0] == 1.0 and r.regime[0] == "boundary"  # no film at v = 0


def test_large_speed_full_film():
    asp = _model("rough", "plastic")
    r = solve_load_sharing(np.array([10.0, 100.0]), F_A, A_A, A_A, FILM_A, asp)
    assert r.load_share_asperity[0] < 1e-4
    assert r.regime[1] == "full_film" and r.load_share_asperity[1] == 0.0
    assert r.h[1] == pytest.approx(float(FILM_A.hc(100.0, F_A)), rel=1e-15)
    assert r.iterations[1] == 0
    mu_e = mu_ehl(0.05 * r.speed, r.film_thickness, P0_A, WATER)
    mu = mixed(mu_e, None if r.W_BL[1] == 0 and r.W_BL[0] == 0 else 0.3, r.W_EHL, r.W_BL, r.W)
    assert mu[1] == mu_e[1]
    assert mu[0] == pytest.approx(float(mu_e[0]), rel=1e-3, abs=1e-4 * 0.3)


@pytest.mark.parametrize("model", ["elastic", "plastic"])
def test_smoother_surface_lower_asperity_share(model):
    sm = solve_load_sharing(SPEEDS, F_A, A_A, A_A, FILM_A, _model("smooth", model))
    ro = solve_load_sharing(SPEEDS, F_A, A_A, A_A, FILM_A, _model("rough", model))
    assert np.all(sm.load_share_asperity < ro.load_share_asperity)


def test_elastic_carries_less_than_plastic_tab_5_1():
    """Paper A: "the lower load carried by asperity using the elastic deformation model".

    Holds for Tab. 5.1 at every speed, by a wide margin at low speed: at 1e-3 m/s the
    elastic share is about 2-3 %, the plastic one 40-70 %.
    """
    for surface in TAB51:
        el = solve_load_sharing(SPEEDS, F_A, A_A, A_A, FILM_A, _model(surface, "elastic"))
        pl = solve_load_sharing(SPEEDS, F_A, A_A, A_A, FILM_A, _model(surface, "plastic"))
        assert np.all(el.load_share_asperity < pl.load_share_asperity)
        assert el.load_share_asperity[1] < 0.05 < 0.3 < pl.load_share_asperity[1]


def test_smooth_surfaces():
    r = solve_load_sharing(SPEEDS, F_A, A_A, A_A, FILM_A, None)
    assert np.all(r.regime == "smooth")
    np.testing.assert_array_equal(r.h, FILM_A.hc(SPEEDS, F_A))
    assert np.all(r.load_share_asperity == 0) and np.all(np.isinf(r.lam))
    assert math.isnan(r.h_star) and r.model == "smooth"


def test_piezo_film_balance():
    # Paper B: MTM 19.05 mm ball on a flat disc, steel, 0.8 GPa, ester oil
    E = 117e9
    R = 19.05e-3 / 2
    a = math.pi * 0.8e9 * R / (2 * E)
    F = 2 / 3 * math.pi * a * a * 0.8e9
    lub = Lubricant(0.03, "barus", alpha=1.2e-8)
    film = FilmThickness.from_contact(lub, E, R, a, a)
    asp = Roughness(50e-9, 0.2e-3, 2e10, "elastic").asperity_model(E)
    v = np.array([0.01, 0.1, 1.0])
    r = solve_load_sharing(v, F, a, a, film, asp)
    ok = r.F_EHL > 0
    np.testing.assert_allclose(hc_piezo(v[ok], r.F_EHL[ok], E, R, 0.03, 1.2e-8, 1.0), r.h[ok],
                               rtol=1e-12)
    np.testing.assert_allclose(r.F_EHL + r.F_BL, F, rtol=1e-15)


def test_thesis_baseline():
    asp = _model("rough", "plastic")
    ref = solve_load_sharing(SPEEDS, F_A, A_A, A_A, FILM_A, asp)
    for i, v in enumerate(SPEEDS):
        t = solve_load_sharing_thesis(v, F_A, A_A, A_A, FILM_A, asp)
        assert t.converged and t.failure is None
        assert t.epsilon < 1e-3 and t.residual < 1e-3
        assert t.h == pytest.approx(ref.h[i], rel=1e-3)
    # v = 0: the scheme cannot start (h = hc = 0); recorded, not raised
    t = solve_load_sharing_thesis(0.0, F_A, A_A, A_A, FILM_A, asp)
    assert not t.converged and t.failure == "h<=0"


def test_mixed_helpers():
    # hand: W_EHL = 3, W_BL = 1: mu = (0.01*3 + 0.3*1)/4
    assert float(mixed(0.01, 0.3, 3.0, 1.0)) == pytest.approx((0.03 + 0.3) / 4, rel=1e-15)
    assert float(mixed_mu(0.01, 0.3, 3.0, 1.0, 4.0)) == pytest.approx(0.0825, rel=1e-15)
    tau_e = np.array([[1.0, 2.0], [3.0, 4.0]])
    tau_b = np.array([[10.0, 20.0], [30.0, 40.0]])
    np.testing.assert_allclose(mixed_tau(tau_e, tau_b, 0.5, 0.5), (tau_e + tau_b) / 2)
    # parts with zero weight are left out, even if not computed
    assert float(mixed(None, 0.3, 0.0, 2.0)) == 0.3
    assert float(mixed(np.nan, 0.3, 0.0, 2.0)) == 0.3
    assert float(mixed(0.02, np.nan, 1.0, 0.0)) == 0.02
    with pytest.raises(ValueError):
        mixed(None, 0.3, 1.0, 1.0)


def test_input_validation():
    asp = _model("rough", "plastic")
    with pytest.raises(TorlabInputError) as err:
        solve_load_sharing(-1.0, F_A, A_A, A_A, FILM_A, asp)
    assert err.value.key == "kinematics.speed"
    with pytest.raises(TorlabInputError) as err:
        solve_load_sharing(1.0, -5.0, A_A, A_A, FILM_A, asp)
    assert err.value.key == "contact.load"
    with pytest.raises(TorlabInputError):
        solve_load_sharing(1.0, 0.0, A_A, A_A, FILM_A, asp)
    with pytest.raises(TorlabInputError):
        solve_load_sharing(1.0, F_A, 0.0, A_A, FILM_A, asp)
    with pytest.raises(TorlabInputError):
        solve_load_sharing(np.array([1.0, np.nan]), F_A, A_A, A_A, FILM_A, asp)
    with pytest.raises(TorlabInputError) as err:
        Roughness(0.0, 0.373e-3, 21_500e6, "plastic", hardness=6e9)
    assert err.value.key == "roughness.sigma"


# ---------------------------------------------------------------------------- hard cases

HARD_SPEEDS = np.array([0.0, 1e-6, 1e-4, 1e-2, 0.1, 1.0, 10.0, 50.0, 100.0])
CREEPAGES = np.array([0.0, 1e-3, 0.05, 1.0])
LUBRICANTS = [("iso", {}), ("barus", {"alpha": 1e-8}), ("barus", {"alpha": 6e-8}),
              ("roelands", {"Z": 0.6}), ("roelands", {"Z": 1.2})]
SHEARS = [("newtonian", {}), ("limiting", {"gamma_L": 0.08}), ("eyring", {"tau0": 5e6})]


@pytest.mark.slow  # a sweep: 540 load-sharing problems at nine speeds, three shear laws
def test_hard_case_sweep():
    """Speed 0-100 m/s, sigma 1 nm-1 um, load 1 N-100 kN, eta0 1e-4-10 Pa s, every
    viscosity and shear law, steel-steel and steel-glass: finite results or a named
    NumericalError, and no warning of any kind."""
    R = 0.01
    n_ok = n_named = 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for E, F, eta0, (visc, vkw) in itertools.product(
                [117e9, 75e9], [1.0, 1e3, 1e5], [1e-4, 1e-2, 10.0], LUBRICANTS):
            a = (3 * F * R / (4 * E)) ** (1 / 3)  # circular Hertz contact
            p0 = 3 * F / (2 * math.pi * a * a)
            base = Lubricant(eta0, visc, **vkw)
            film = FilmThickness.from_contact(base, E, R, a, a)
            hs, ws = [], []
            for sigma, model in itertools.product([1e-9, 3e-8, 1e-6], ["elastic", "plastic"]):
                asp = Roughness(sigma, 0.3e-3, 2.4e10, model, hardness=6e9).asperity_model(E)
                r = solve_load_sharing(HARD_SPEEDS, F, a, a, film, asp)
                for arr in (r.h, r.lam, r.F_EHL, r.F_BL, r.W_EHL, r.W_BL, r.film_thickness):
                    assert np.all(np.isfinite(arr))
                assert np.all((r.load_share_asperity >= 0) & (r.load_share_asperity <= 1))
                np.testing.assert_allclose(r.W_EHL + r.W_BL, r.W, rtol=1e-13)
                assert np.all(r.residual < 1e-12)
                film_on = r.film_thickness > 0
                hs.append(r.film_thickness[film_on])
                ws.append(r.speed[film_on])
                # the mixed coefficient with a stand-in boundary value
                mu_e = np.where(film_on, 0.01, np.nan)
                assert np.all(np.isfinite(mixed(mu_e, 0.3, r.W_EHL, r.W_BL, r.W)))
            h = np.concatenate(hs)[:, None]
            w = np.concatenate(ws)[:, None] * CREEPAGES[None, :]
            for shear, skw in SHEARS:
                lub = Lubricant(eta0, visc, shear=shear, **vkw, **skw)
                try:
                    mu = mu_ehl(w, h, p0, lub)
                except NumericalError:
                    assert shear == "newtonian" and visc != "iso"
                    n_named += 1
                    continue
                assert np.all(np.isfinite(mu)) and np.all(mu >= 0)
                if shear == "limiting":
                    assert np.all(mu <= 0.08 * (1 + 1e-12))
                n_ok += 1
    assert n_ok > 0 and n_named > 0  # both outcomes occur in the sweep
