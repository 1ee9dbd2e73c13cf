"""torlab's default boundary method, FASTSIM corrected by Kalker's exact theory
(torlab.model.calibrated), against references it was not built from: the exact values of an
independent solver on CONTACT's discretisation (docs/model/exact.md), Kalker's linear-theory
coefficients (his Table E.3), full slip along the rigid slip (a quadrature of Hertz's
pressure), the exact solver itself on the FASTSIM-error table's cases, and fresh exact
solutions away from the tables' nodes (slow step).  The tables themselves are checked against
a fresh regeneration on a few rows."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from torlab.model.calibrated import DATA
from torlab.model.calibration_build import (
    fastsim_longitudinal,
    fastsim_spin,
    full_slip,
    method_values,
    twin,
)
from torlab.model.exact.fastsim_error import CASES, ErrorCase

CASE = {c.name: c for c in CASES}


# -------------------------------------------------------------------------------- references
#: the exact values of an independent solver on CONTACT's discretisation
#: (docs/model/exact.md): (case, quantity) -> value
INDEPENDENT = {("xi_small", "Fx"): 0.273, ("xi_large", "Fx"): 0.997,
               ("traction_curve_A2", "Fx"): 0.981, ("spin", "Fy"): 0.302,
               ("lateral_spin", "Fy"): 0.786, ("lateral_spin", "Mz"): -0.384}
#: the targets: pure creepage 1 %, forces with spin 3 %, the moment 5 %
TARGET = {"Fx": 0.01, "Fy": 0.03, "Mz": 0.05, "C33": 0.05, "C32": 0.05}


def _target(case: ErrorCase, q: str) -> float:
    pure = case.eta == 0 and case.phi == 0
    return TARGET["Fx"] if pure and q == "Fx" else TARGET[q] if q != "Fx" else 0.03


@pytest.mark.parametrize("key", sorted(INDEPENDENT))
def test_issue_table_against_the_independent_exact_values(key):
    """The default method within 1 % (pure creepage), 3 % (Fy with spin), 5 % (Mz) of the
    independent solver's values; plain FASTSIM misses the same targets."""
    name, q = key
    case = CASE[name]
    ref = INDEPENDENT[key]
    got = method_values(case, "fastsim")[q]
    # the quoted values have three digits: half a unit of the last one is their own error
    assert abs(got / ref - 1) <= _target(case, q) + 0.0005 / abs(ref)
    plain = method_values(case, "fastsim-kalker")[q]
    assert abs(plain / ref - 1) > _target(case, q)


@pytest.mark.slow  # the exact solver on 40 x 40 and 24 x 24 elements for twelve cases (~1 min)
def test_fastsim_error_table_rerun_against_the_exact_solver():
    """Every row of the FASTSIM-error table (docs/model/exact.md: pure creepage small and
    large, CONTACT's traction-curve example A2, pure spin, lateral creepage with and against
    spin, C33 and C32 at a/b 0.5/1/2, full slip with lateral creepage and spin) by the
    default method against torlab's exact solver: within 1 % in pure creepage, 3 % in Fx
    and Fy with spin, 5 % in Mz, C33 and C32 (plus the exact value's own discretisation
    error); plain FASTSIM misses at least one target in every class."""
    from torlab.model.exact.fastsim_error import exact_values

    missed = set()
    for case in CASES:
        ref = exact_values(case)
        got = method_values(case, "fastsim")
        plain = method_values(case, "fastsim-kalker")
        for q in case.quantities:
            v, e = ref[q]
            tol = _target(case, q)
            assert abs(got[q] - v) <= tol * abs(v) + abs(e), (case.name, q, got[q], v, e)
            if abs(plain[q] - v) > tol * abs(v) + abs(e):
                missed.add("pure" if case.eta == case.phi == 0 and q == "Fx" else q)
    assert {"pure", "Fy", "Mz", "C33", "C32"} <= missed


@pytest.mark.parametrize("name", ["C33_0.5", "C33_1", "C33_2"])
def test_linear_theory_spin_moment_is_kalkers(name):
    """C33 and C32 = C23 of Kalker's Table E.3 within 5 % (plain FASTSIM: 7-33 % off)."""
    from torlab.model.kalker import C23, C33

    case = CASE[name]
    got = method_values(case, "fastsim")
    assert got["C33"] == pytest.approx(C33(case.a_over_b, 0.28), rel=0.05)
    assert got["C32"] == pytest.approx(C23(case.a_over_b, 0.28), rel=0.05)


@pytest.mark.parametrize("a_over_b, v", [(1.0, (0.0, 6.0, 2.0)), (0.5, (0.0, 6.0, 2.0)),
                                         (2.0, (0.0, 6.0, -2.0)), (0.2, (0.3, 1.0, -0.5)),
                                         (5.0, (1.0, 0.0, 1.0))])
def test_full_slip_is_the_rigid_slip_direction(a_over_b, v):
    """At a creepage far beyond full slip (|v*| = 1e5, ten times the tables' FASTSIM stand-in
    for infinity) the default's traction is mu p against the rigid slip everywhere: its forces
    are the quadrature of Hertz's pressure along the rigid slip within 1 % of mu N (the spin
    share's interpolation between the table's directions leaves up to 0.4 %); plain FASTSIM's
    follow its three flexibilities (5-13 % off where there is spin and lateral creepage)."""
    from torlab.model.creep import CreepProblem, creep_forces
    from torlab.model.layers import LayerParams

    u = np.asarray(v, dtype=float)
    u = u / np.linalg.norm(u)
    ref = full_slip(a_over_b, u[None, :])[0]
    t = twin(a_over_b)
    muN, c = t["mu"] * t["load"], math.sqrt(t["a"] * t["b"])
    cr = [1e5 * u[i] / t["scale"][i] for i in range(3)]
    got = {}
    for cal in (True, False):
        prob = CreepProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], L2=t["L2"], L3=t["L3"],
                            layer=LayerParams(t["mu"], t["mu"], 0.0, 0.0), calibrated=cal)
        r = creep_forces(prob, *cr)
        got[cal] = np.array([float(r.Fx) / muN, float(r.Fy) / muN, float(r.Mz) / (muN * c)])
    np.testing.assert_allclose(got[True], ref, atol=0.01)
    if u[1] != 0 and u[2] != 0:
        assert np.max(np.abs(got[False] - ref)) > 0.05


def test_tables_fastsim_columns_are_this_fastsim():
    """The tables' FASTSIM columns are what FASTSIM computes now (a change of the scheme
    makes the correction stale: regenerate with --fastsim-only)."""
    long = pd.read_csv(DATA / "longitudinal.csv")
    rows = long[(long.a_over_b == 0.5) & (long.layer_ratio.isin([0.0, 0.3]))]
    for lam, g in rows.groupby("layer_ratio"):
        fs, _ = fastsim_longitudinal(0.5, lam, g.x.to_numpy())
        np.testing.assert_allclose(fs, g.fastsim_Fx, rtol=2e-6, atol=1e-9)
    spin = pd.read_csv(DATA / "spin.csv")
    g = spin[(spin.a_over_b == 2.0) & (spin.alpha_deg == 36.0) & np.isfinite(spin.rho)
             & (spin.rho > 0)]
    v = g[["xi_star", "eta_star", "phi_star"]].to_numpy()
    np.testing.assert_allclose(fastsim_spin(2.0, v), g[["fastsim_Fx", "fastsim_Fy",
                                                         "fastsim_Mz"]], rtol=2e-6, atol=2e-7)


def test_rebuilding_some_aspect_ratios_keeps_the_other_rows(tmp_path):
    """``--a-over-b`` replaces those aspect ratios' rows in the table at ``--out`` and keeps
    the others as they were (here FASTSIM's columns at a/b 2, which come out the same)."""
    import shutil

    from torlab.model.calibration_build import main

    shutil.copy(DATA / "longitudinal.csv", tmp_path / "longitudinal.csv")
    table = pd.read_csv(tmp_path / "longitudinal.csv")
    marked = table.copy()
    marked.loc[marked.a_over_b == 0.5, "fastsim_adhesion"] = -1.0  # not rebuilt: kept
    marked.loc[marked.a_over_b == 2.0, "fastsim_Fx"] = -1.0  # rebuilt
    marked.to_csv(tmp_path / "longitudinal.csv", index=False, float_format="%.7g")
    assert main(["--only", "longitudinal", "--fastsim-only", "--a-over-b", "2.0",
                 "--out", str(tmp_path)]) == 0
    out = pd.read_csv(tmp_path / "longitudinal.csv")
    assert out.shape == table.shape and list(out.columns) == list(table.columns)
    np.testing.assert_array_equal(out[["a_over_b", "layer_ratio", "x"]],
                                  table[["a_over_b", "layer_ratio", "x"]])
    np.testing.assert_allclose(out.fastsim_Fx, table.fastsim_Fx, rtol=2e-6, atol=1e-9)
    assert (out.fastsim_adhesion[out.a_over_b == 0.5] == -1.0).all()
    np.testing.assert_array_equal(out.exact_Fx, table.exact_Fx)


def test_full_slip_rows_are_the_quadrature():
    spin = pd.read_csv(DATA / "spin.csv")
    g = spin[(spin.a_over_b == 1.0) & np.isinf(spin.rho)].iloc[::5]
    v = g[["xi_star", "eta_star", "phi_star"]].to_numpy()
    np.testing.assert_allclose(full_slip(1.0, v), g[["exact_Fx", "exact_Fy", "exact_Mz"]],
                               atol=2e-6)


@pytest.mark.slow  # exact solutions on eight grids (about a minute)
def test_longitudinal_table_rows_against_a_fresh_regeneration():
    from torlab.model.calibration_build import GRIDS_LONGITUDINAL, exact_longitudinal

    long = pd.read_csv(DATA / "longitudinal.csv")
    for ab, lam, xs in ((1.0, 0.0, [0.1, 0.5]), (3.3, 0.5, [0.3])):
        g = long[(long.a_over_b == ab) & (long.layer_ratio == lam) & long.x.isin(xs)]
        ex, _ = exact_longitudinal(ab, lam, g.x.to_numpy(), GRIDS_LONGITUDINAL)
        np.testing.assert_allclose(ex, g.exact_Fx, rtol=1e-5)


def test_hardening_table_row_against_a_fresh_regeneration():
    """A row of hardening.csv recomputed by its builder (exact solver on three grids and
    FASTSIM): the shipped numbers are what the regenerating code path gives."""
    from torlab.model.calibration_build import hardening_rows

    hard = pd.read_csv(DATA / "hardening.csv")
    assert list(hard.columns) == ["a_over_b", "layer_ratio", "hardening", "voce_ratio",
                                  "L_mup_m", "x", "exact_Fx", "exact_Fx_error", "fastsim_Fx",
                                  "fastsim_adhesion", "exact_epp_Fx", "exact_epp_Fx_error",
                                  "fastsim_epp_Fx"]
    new = hardening_rows(a_over_b=(0.5,), layer_ratio=(0.3,), hardening=(1.25,), voce=(0.3,),
                         x=(0.4,))
    g = hard[(hard.a_over_b == 0.5) & (hard.layer_ratio == 0.3) & (hard.hardening == 1.25)
             & (hard.voce_ratio == 0.3) & (hard.x == 0.4)]
    assert len(g) == 1 and len(new) == 1
    for col in ("L_mup_m", "exact_Fx", "exact_Fx_error", "fastsim_Fx", "fastsim_adhesion",
                "exact_epp_Fx", "exact_epp_Fx_error", "fastsim_epp_Fx"):
        assert new[col].iloc[0] == pytest.approx(g[col].iloc[0], rel=1e-5, abs=1e-9), col


def test_hardening_builder_on_a_tiny_grid():
    """The builder's rows on a coarse grid (two grids of 10 and 14 elements): a row per node
    in the table's order, the layer's Voce length from its ratio, FASTSIM's column this
    FASTSIM's, the exact value near FASTSIM's (both the same layer, a few % apart) and, at
    mu_c2 = mu_c1, the elastic-perfectly plastic reference and the longitudinal table's
    contact."""
    from torlab.model.calibration_build import MU, hardening_rows, voce_layer
    from torlab.model.fastsim import FastsimProblem, boundary_traction

    xs = (0.3, 1.0)
    df = hardening_rows(a_over_b=(1.0,), layer_ratio=(0.3,), hardening=(1.0, 1.5),
                        voce=(0.5,), x=xs, grids=(10, 14))
    assert len(df) == 4 and list(df.hardening) == [1.0, 1.0, 1.5, 1.5]
    t = twin(1.0, 0.3)
    lay = voce_layer(t, MU, 1.5 * MU, 0.5)
    assert lay.L_mup == pytest.approx(0.5 * MU * (t["L1"] * t["p0"] + t["L_mue"]))
    xi = np.asarray(xs) * 1.3 / t["scale"][0]
    fs = boundary_traction(FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"],
                                          layer=lay), xi).mu / MU
    np.testing.assert_allclose(df.fastsim_Fx[2:], fs, rtol=1e-12)
    np.testing.assert_allclose(df.exact_Fx, df.fastsim_Fx, rtol=0.08)
    fs0, _ = fastsim_longitudinal(1.0, 0.3, np.asarray(xs))
    np.testing.assert_allclose(df.fastsim_Fx[:2], fs0, rtol=1e-6)
    np.testing.assert_allclose(df.fastsim_epp_Fx, np.tile(fs0, 2), rtol=1e-6)
    np.testing.assert_allclose(df.exact_Fx[:2], df.exact_epp_Fx[:2], rtol=1e-6)


def test_grid_interpolation_is_exact_for_multilinear_functions():
    """The tables' interpolation on uneven axes in five dimensions reproduces a function
    that is linear in each coordinate (two columns), clamps coordinates outside the axes
    to their ends, and gives the same values in blocks as point by point (more points
    than one block)."""
    from torlab.model.calibrated import _Grid

    rng = np.random.default_rng(3)
    axes = tuple(np.sort(rng.uniform(-2, 3, n)) for n in (4, 3, 5, 2, 6))
    a, b = rng.normal(size=5), rng.normal(size=5)

    def f(*x):  # linear in each coordinate, with products of several
        one = 1 + sum(ai * xi for ai, xi in zip(a, x, strict=True)) + x[0] * x[3]
        two = 2 - x[1] * x[2] * x[4] + sum(bi * xi for bi, xi in zip(b, x, strict=True))
        return np.stack([one, two], axis=-1)

    mesh = np.meshgrid(*axes, indexing="ij")
    grid = _Grid(axes, f(*mesh))
    n = _Grid.BLOCK + 37
    pts = [rng.uniform(ax[0], ax[-1], n) for ax in axes]
    np.testing.assert_allclose(grid(*pts), f(*pts), rtol=1e-12, atol=1e-12)
    out = [np.where(rng.random(n) < 0.5, ax[0] - 1.0, ax[-1] + 1.0) for ax in axes]
    ends = [np.where(o < ax[0], ax[0], ax[-1]) for o, ax in zip(out, axes, strict=True)]
    np.testing.assert_allclose(grid(*out), f(*ends), rtol=1e-12, atol=1e-12)
    one = np.array([grid(*(p[i] for p in pts)) for i in range(0, n, 97)])
    np.testing.assert_array_equal(one, grid(*pts)[::97])


def test_hardening_factor_at_the_nodes_and_without_hardening():
    """The factor Q is the table's exact ratio Voce/EPP over FASTSIM's at its nodes, exactly
    1 at mu_c2 = mu_c1 and at full slip."""
    from torlab.model.calibrated import hardening_factor

    hard = pd.read_csv(DATA / "hardening.csv").dropna()
    g = hard.iloc[::97]
    q, _ = hardening_factor(g.a_over_b, g.layer_ratio, g.hardening, g.voce_ratio, g.x)
    np.testing.assert_allclose(q, (g.exact_Fx / g.exact_epp_Fx) * (g.fastsim_epp_Fx
                                                                    / g.fastsim_Fx), rtol=1e-9)
    q1, e1 = hardening_factor(0.7, 0.4, 1.0, 0.5, np.array([0.1, 0.8, 3.0]))
    np.testing.assert_array_equal(q1, 1.0)
    np.testing.assert_array_equal(e1, 0.0)
    qi, _ = hardening_factor(0.7, 0.4, 1.4, 0.5, np.inf)
    assert qi == 1.0


@pytest.mark.parametrize("layer", [
    {"law": "voce", "mu_c1": 0.3, "mu_c2": 0.3, "L_mue": 2e-6, "L_mup": 5e-6},
    {"law": "voce", "mu_c1": 0.3, "mu_c2": 0.3, "L_mue": 0.0, "L_mup": 0.0},
    {"law": "perfect", "mu_c1": 0.3, "L_mue": 2e-6},
])
def test_coulomb_and_perfectly_plastic_layers_keep_the_longitudinal_ratio(layer):
    """A Coulomb contact and elastic-perfectly plastic layers get the longitudinal table's
    ratio and nothing else: the default is Kalker's FASTSIM times R, bit for bit, and its
    stated theory error has no hardening part (to rounding: the scheme multiplies in its
    own order)."""
    from torlab.model.calibrated import (
        INTERPOLATION_ERROR,
        layer_ratio,
        longitudinal_error,
        longitudinal_ratio,
        normalised_longitudinal,
    )
    from torlab.model.fastsim import FastsimProblem, boundary_traction
    from torlab.model.layers import LayerParams

    t = twin(0.8)
    law = layer.pop("law")
    lay = LayerParams(law=law, **layer)
    xi = np.linspace(-4e-3, 4e-3, 21)
    kw = {"a": t["a"], "b": t["b"], "p0": t["p0"], "L1": t["L1"], "layer": lay}
    plain = boundary_traction(FastsimProblem(**kw), xi).mu
    cal = FastsimProblem(**kw, calibrated=True)
    r = boundary_traction(cal, xi)
    lam = layer_ratio(t["L1"], t["p0"], lay.L_mue)
    x = normalised_longitudinal(t["a"], t["L1"], t["p0"], lay.mu_c1, xi) / (1 + lam)
    R, Rerr = longitudinal_ratio(0.8, np.broadcast_to(lam, x.shape), x)
    np.testing.assert_allclose(r.mu, plain * R, rtol=1e-15, atol=0)
    e = longitudinal_error(cal, xi, r.mu, calibrated=True, adhesion=r.adhesion_fraction)
    np.testing.assert_allclose(e, np.abs(r.mu) * np.sqrt((Rerr / R) ** 2
                                                          + INTERPOLATION_ERROR**2),
                               rtol=1e-12)


def test_band_draws_take_each_draws_hardening():
    """Layers per draw (a band's arrays) get each draw's own hardening factor: the same as
    each layer alone."""
    from torlab.model.calibrated import correct_longitudinal
    from torlab.model.fastsim import FastsimProblem
    from torlab.model.layers import LayerParams

    t = twin(1.2, 0.3)
    lays = [LayerParams(0.3, mu2, t["L_mue"], 4e-6) for mu2 in (0.2, 0.3, 0.4)]
    xi = np.array([2e-4, 8e-4, 2e-3])
    mu = np.array([0.1, 0.2, 0.25])
    one = [correct_longitudinal(FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"],
                                               layer=lay), xi, mu) for lay in lays]
    arr = LayerParams(**{n: np.array([getattr(lay, n) for lay in lays])[:, None]
                         for n in lays[0].law.names})
    prob = FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], layer=lays[0])
    both = correct_longitudinal(prob, xi[None, :], np.broadcast_to(mu, (3, 3)), layer=arr)
    np.testing.assert_allclose(both, np.array(one), rtol=1e-12)
    assert not np.allclose(one[0], one[2])


def test_hardening_correction_does_not_jump_as_lateral_creepage_or_spin_is_added():
    """The hardening table holds in pure longitudinal creepage; with lateral creepage or
    spin it is weighed on the longitudinal force by the longitudinal share of the
    normalised creepage, so the force of a hardening layer is continuous as a small lateral
    creepage or spin is added (it jumped by Q - 1 when the factor was dropped there)."""
    from torlab.model.calibrated import hardening_factor
    from torlab.model.creep import CreepProblem, creep_forces
    from torlab.model.layers import LayerParams

    t = twin(1.2, 0.3)
    onset = 0.3 * (t["L1"] * t["p0"] + t["L_mue"])
    lay = LayerParams(0.3, 0.4, t["L_mue"], 0.3 * onset)
    prob = CreepProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], L2=t["L2"], L3=t["L3"],
                        layer=lay, calibrated=True)
    xi = np.array([1.5e-3, 3e-3, 6e-3])
    lam = t["L_mue"] / (t["L1"] * t["p0"])
    Q = hardening_factor(t["a"] / t["b"], lam, 0.4 / 0.3, lay.L_mup / onset,
                         xi * t["scale"][0] / (1 + lam), error=False)[0]
    assert np.max(np.abs(Q - 1.0)) > 0.005  # the test point sees a real correction
    pure = creep_forces(prob, xi, 0.0, 0.0)
    for eta, phi in ((1e-9, 0.0), (0.0, 1e-7)):
        near = creep_forces(prob, xi, eta, phi)
        np.testing.assert_allclose(near.Fx, pure.Fx, rtol=1e-5)


# ---------------------------------------------------------- away from the nodes (slow step)
@pytest.mark.slow  # exact solutions on three grids
def test_spin_table_rows_against_a_fresh_regeneration():
    from torlab.model.calibration_build import exact_spin

    spin = pd.read_csv(DATA / "spin.csv")
    g = spin[(spin.a_over_b == 0.5) & (spin.alpha_deg == 36.0) & (spin.sigma == -0.35)
             & spin.rho.isin([0.3, 1.3])]
    ex, _ = exact_spin(0.5, g[["xi_star", "eta_star", "phi_star"]].to_numpy())
    np.testing.assert_allclose(ex, g[["exact_Fx", "exact_Fy", "exact_Mz"]], rtol=1e-5,
                               atol=1e-7)


@pytest.mark.slow  # fresh exact solutions, eight grids each
@pytest.mark.parametrize("a_over_b", [0.25, 0.6, 1.2, 2.5, 4.2])
def test_pure_creepage_within_one_percent_between_the_nodes(a_over_b):
    """Coulomb contacts at aspect ratios and creepages between the table's nodes: the
    default within 1 % of the exact theory extrapolated from eight grids (whose own 95 %
    error is added: it is the reference's, not the method's).  At a/b 4.2, between the
    nodes 3.3 and 5 and between the rows b/a 0.2 and 0.3 of Kalker's table, this holds
    because the default's FASTSIM interpolates Kalker's coefficients smoothly (linear in
    b/a, as Kalker's FASTSIM does, it was 1.8 % off: docs/model/boundary.md)."""
    from torlab.model.calibration_build import GRIDS_LONGITUDINAL, exact_longitudinal

    x = np.array([0.07, 0.25, 0.45, 0.65, 0.85])
    ex, err = exact_longitudinal(a_over_b, 0.0, x, GRIDS_LONGITUDINAL)
    t = twin(a_over_b)
    from torlab.model.fastsim import FastsimProblem, boundary_traction
    from torlab.model.layers import LayerParams

    prob = FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"],
                          layer=LayerParams(t["mu"], t["mu"], 0.0, 0.0), calibrated=True)
    got = boundary_traction(prob, x / t["scale"][0]).mu / t["mu"]
    assert np.all(np.abs(got / ex - 1) <= 0.01 + err / ex)


@pytest.mark.slow  # fresh exact solutions on three grids
@pytest.mark.parametrize("a_over_b", [0.25, 0.7, 1.6, 3.8])
def test_spin_within_targets_between_the_nodes(a_over_b):
    """Lateral creepage and spin at directions and aspect ratios between the spin table's
    nodes: Fx, Fy within 3 % and Mz within 5 % of the exact theory, relative to the larger
    of the value and a tenth of its full-slip scale (a force crossing zero has no relative
    error)."""
    from torlab.model.calibration_build import exact_spin

    v = np.array([[0.2, 0.25, 0.35], [0.0, 0.5, -0.4], [0.45, 0.1, -0.15], [0.0, 2.0, -0.7],
                  [0.15, 0.0, 0.9], [0.6, 0.6, 0.2]])
    ex, err = exact_spin(a_over_b, v)
    t = twin(a_over_b)
    from torlab.model.creep import CreepProblem, creep_forces
    from torlab.model.layers import LayerParams

    prob = CreepProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], L2=t["L2"], L3=t["L3"],
                        layer=LayerParams(t["mu"], t["mu"], 0.0, 0.0), calibrated=True)
    r = creep_forces(prob, *(v[:, i] / t["scale"][i] for i in range(3)))
    muN, c = t["mu"] * t["load"], math.sqrt(t["a"] * t["b"])
    got = np.stack([r.Fx / muN, r.Fy / muN, r.Mz / (muN * c)], -1)
    scale = np.maximum(np.abs(ex), 0.1)
    tol = np.array([0.03, 0.03, 0.05])
    assert np.all(np.abs(got - ex) <= tol * scale + err)


# ------------------------------------------------------------------- layers: the validation
def _validation_scene(s):
    """A validation scene's contact as the default method sees it (its flexibilities from
    Kalker's coefficients interpolated as the tables are) and its layer, as the exact values
    were computed for it (defined with CONTACT's linear interpolation of the coefficients)."""
    from torlab.model.calibration_build import _validation_layer

    built = twin(s.a_over_b, s.layer_ratio, mu=s.mu_c1, interpolation="linear")
    layer = _validation_layer(built, s.to_dict())
    assert layer.L_mue == pytest.approx(s.L_mue_m, rel=1e-5)
    assert layer.L_mup == pytest.approx(s.L_mup_m, rel=1e-5)
    return twin(s.a_over_b, s.layer_ratio, mu=s.mu_c1), layer


def test_theory_error_covers_the_layer_validation_set():
    """Voce layers (hardening and softening, a/b 0.25-4, lambda 0.02-3; a Latin hypercube,
    exact values shipped in validation.csv, which the hardening table was not built from):
    the default is within 1 % of the exact theory plus the reference's own error at every
    point; within 1.4 % everywhere (measured 1.39 %, at x = 0.08 where the reference's own
    error is 2.1 %), 1.0 % at the 95th percentile and from the knee on (x >= 0.25; before the
    hardening table 5.3 %, 3.4 % and 5.3 %).  The stated theory error covers at least 90 %
    of the points (it is meant as 95 %; measured: all 140).  Plain FASTSIM is off by up to
    8.5 %."""
    from torlab.model.calibrated import longitudinal_error
    from torlab.model.fastsim import FastsimProblem, boundary_traction

    df = pd.read_csv(DATA / "validation.csv").dropna()
    err, covered, plain, within, knee = [], [], [], [], []
    for _, g in df.groupby("scene"):
        s = g.iloc[0]
        t, layer = _validation_scene(s)
        prob = FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], layer=layer,
                              calibrated=True)
        r = boundary_traction(prob, g.creepage.to_numpy())
        e = longitudinal_error(prob, g.creepage.to_numpy(), r.mu, calibrated=True,
                               adhesion=r.adhesion_fraction)
        ex, ref = g.exact_mu.to_numpy(), g.exact_mu_error.to_numpy()
        err.append(np.abs(r.mu / ex - 1))
        covered.append(np.abs(r.mu - ex) <= e + ref)
        within.append(np.abs(r.mu - ex) <= 0.01 * ex + ref)
        knee.append(g.x.to_numpy() >= 0.25)
        plain.append(np.abs(g.fastsim_kalker_mu.to_numpy() / ex - 1))
    err, covered, plain, within, knee = (np.concatenate(v) for v in (err, covered, plain,
                                                                     within, knee))
    assert err.size >= 100
    assert within.all()
    assert err.max() < 0.015
    assert np.quantile(err, 0.95) < 0.011
    assert err[knee].max() < 0.011
    assert covered.mean() >= 0.9
    assert plain.max() > 0.07


def test_theory_error_covers_the_layer_validation_set_with_spin():
    """Voce layers with lateral creepage and spin (validation_spin.csv: eight of the layers
    above, seven creepage vectors each): the correction is carried over from the Coulomb
    contact, and its stated theory error (which counts the whole lateral/spin correction as
    possibly wrong) covers at least 90 % of each force and of the moment."""
    from torlab.model.calibrated import creep_error
    from torlab.model.creep import CreepProblem, creep_forces

    df = pd.read_csv(DATA / "validation_spin.csv").dropna()
    covered = []
    for _, g in df.groupby("scene"):
        s = g.iloc[0]
        t, layer = _validation_scene(s)
        prob = CreepProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], L2=t["L2"],
                            L3=t["L3"], layer=layer, calibrated=True)
        cr = [g.creepage.to_numpy(), g.lateral.to_numpy(), g.spin_1_m.to_numpy()]
        r = creep_forces(prob, *cr)
        e = np.stack(creep_error(prob, *cr, r.Fx, r.Fy, r.Mz, calibrated=True,
                                 adhesion=r.adhesion_fraction), -1)
        ex = g[["exact_Fx_N", "exact_Fy_N", "exact_Mz_Nm"]].to_numpy()
        er = g[["exact_Fx_error_N", "exact_Fy_error_N", "exact_Mz_error_Nm"]].to_numpy()
        covered.append(np.abs(np.stack([r.Fx, r.Fy, r.Mz], -1) - ex) <= e + er)
    covered = np.concatenate(covered)
    assert covered.shape[0] >= 50
    assert np.all(covered.mean(axis=0) >= 0.9)
