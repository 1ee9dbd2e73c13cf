"""Polach's creep-force law and its fit to torlab's creep forces."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from torlab.errors import TorlabInputError
from torlab.fit.polach import fit_polach, fit_polach_data, polach_data
from torlab.model.creep import CreepProblem, creep_forces
from torlab.model.flash import ThermalParams
from torlab.model.kalker import L1, L2, L3, combined_G_nu, creepage_coefficients
from torlab.model.layers import LayerParams
from torlab.model.polach import PolachParams, polach_contact, polach_forces

G, NU = combined_G_nu(210e9, 0.28, 210e9, 0.28)


def problem(layer: LayerParams, thermal: ThermalParams | None = None) -> CreepProblem:
    a, b, N = 3.7e-3, 3.3e-3, 20e3
    c11, c22, c23 = creepage_coefficients(a / b, NU)
    return CreepProblem(a=a, b=b, p0=3 * N / (2 * math.pi * a * b), L1=L1(a, c11, G),
                        L2=L2(a, c22, G), L3=L3(a, b, c23, G), layer=layer, thermal=thermal)


WR = LayerParams(0.30, 0.45, 10e-6, 20e-6)
HOT = LayerParams(0.30, 0.45, 10e-6, 20e-6, -0.002, -0.003)


def test_linear_limit_is_kalkers_theory():
    """kA = kS = 1 and small creepage: Fx = G a b C11 sx, Fy = G a b (C22 sy + sqrt(ab) C23 phi)."""
    prob = problem(WR)
    c = polach_contact(prob)
    c11, c22, c23 = creepage_coefficients(prob.a / prob.b, NU)
    e = 1e-9
    fx, fy = polach_forces(PolachParams(0.3), c, [e, 0, 0, e], [0, e, 0, 0], [0, 0, e, 0])
    lin = G * prob.a * prob.b
    assert fx[0] == pytest.approx(lin * c11 * e, rel=1e-9)
    assert fy[1] == pytest.approx(lin * c22 * e, rel=1e-9)
    assert fy[2] == pytest.approx(lin * math.sqrt(prob.a * prob.b) * c23 * e, rel=1e-9)
    # reduction factors: initial slope (kA + kS)/2 of Kalker's
    fr, _ = polach_forces(PolachParams(0.3, kA=0.6, kS=0.2), c, e)
    assert fr == pytest.approx(0.4 * fx[3], rel=1e-9)


def test_full_slip_and_falling_friction():
    """Large creepage: F -> mu(w) Q with mu = mu0 ((1 - A) exp(-B w) + A), w = s V."""
    c = polach_contact(problem(WR))
    p = PolachParams(0.4, A=0.5, B=0.6)
    s, V = 2.0, 10.0
    fx, fy = polach_forces(p, c, s * 0.6, s * 0.8, 0.0, V)
    mu = 0.4 * ((1 - 0.5) * math.exp(-0.6 * s * V) + 0.5)
    assert math.hypot(fx, fy) == pytest.approx(mu * c.Q, rel=1e-4)
    assert math.atan2(fy, fx) == pytest.approx(math.atan2(0.8, 0.6), abs=1e-12)
    fx_neg, _ = polach_forces(p, c, -s * 0.6, s * 0.8, 0.0, V)
    assert fx_neg == pytest.approx(-fx)


def test_fit_recovers_the_parameters_of_polachs_own_curves():
    """Data made with Polach's law: the fit returns its parameters (an independent check
    of the fitting, without torlab's model)."""
    c = polach_contact(problem(WR))
    true = PolachParams(0.42, A=0.35, B=0.45, kA=0.7, kS=0.25)
    xi = np.linspace(0.0, 0.08, 33)
    rows = []
    import pandas as pd

    for V in (5.0, 15.0, 30.0):
        fx, _ = polach_forces(true, c, xi, 0.0, 0.0, V)
        rows.append(pd.DataFrame({"creepage": xi, "lateral": 0.0, "spin_1_m": 0.0,
                                  "speed_m_s": V, "mu_x": fx / c.Q, "mu_y": 0.0}))
    res = fit_polach_data(pd.concat(rows, ignore_index=True), c)
    for name in ("mu0", "A", "B", "kA", "kS"):
        assert res.params[name] == pytest.approx(getattr(true, name), rel=1e-5)
    assert res.residual_norm < 1e-9
    assert not res.warnings


def test_fit_to_torlab_reports_the_error_curve_and_number():
    prob = problem(HOT, ThermalParams())
    xi = np.linspace(0.0, 0.04, 21)
    res = fit_polach(prob, xi, [5.0, 20.0], source="wheel-rail")
    assert res.kind == "polach" and res.names == ("mu0", "A", "B", "kA", "kS")
    d = res.data
    assert len(d) == 2 * xi.size
    # the curve: torlab's values are torlab's, Polach's are the law at the fitted parameters
    r = creep_forces(dataclasses.replace(prob, speed=20.0), xi)
    np.testing.assert_allclose(d[d.speed_m_s == 20.0].mu_torlab, r.mu_x, rtol=1e-12)
    fx, _ = polach_forces(PolachParams(*(res.params[n] for n in res.names)), polach_contact(prob),
                          d.creepage, 0.0, 0.0, d.speed_m_s)
    np.testing.assert_allclose(d.mu_polach, fx / prob.load, rtol=1e-12)
    np.testing.assert_allclose(d.residual, d.mu_polach - d.mu_torlab, atol=1e-15)
    # the number: RMS and the largest residual, small against mu (a few per cent of 0.45)
    assert res.meta["max_abs_residual"] == pytest.approx(np.max(np.abs(d.residual)))
    assert res.residual_norm < 0.02 and res.meta["max_abs_residual"] < 0.04
    assert res.params["kS"] <= res.params["kA"] <= 1.0
    assert 0 < res.params["A"] < 1 and res.params["B"] > 0  # heating lowers friction with speed
    assert res.to_scene_dict() == {}  # Polach's parameters are not scene keys


def test_fit_flags_what_the_range_cannot_determine():
    """Creepages far below saturation show only the initial slope: the friction levels
    and their fall are not determined, and the fit says so."""
    res = fit_polach(problem(WR), np.linspace(0, 2e-4, 11), [10.0])
    flagged = [n for n in res.names if res.table().set_index("parameter").status[n] != "fitted"]
    assert {"A", "B"} <= set(flagged)
    assert res.meta["max_abs_residual"] < 1e-3  # the slope itself is reproduced


def test_fit_with_lateral_creepage_and_spin_fits_both_components():
    prob = problem(HOT, ThermalParams())
    res = fit_polach(prob, np.linspace(0.0, 0.02, 9), [10.0], lateral=[0.0, 2e-3],
                     spin=[0.0, 1.0])
    assert set(res.data.component) == {"x", "y"}
    assert res.meta["max_abs_residual"] < 0.06


def test_bad_input():
    prob = problem(WR)
    with pytest.raises(TorlabInputError, match="three creepages"):
        polach_data(prob, [0.0, 0.01], [10.0])
    with pytest.raises(TorlabInputError, match="speeds"):
        polach_data(prob, [0.0, 0.01, 0.02], [0.0])
