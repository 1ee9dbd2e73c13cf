"""The layer-law interface (torlab.model.layers): the registry, the values, the scene's
``boundary:`` section, and each law's per-element plastic update against its own HPT curve.

The per-element update (:meth:`LayerLaw.return_map`) integrates a loading path step by
step (trial traction, radial return, the yield stress against the accumulated plastic
slip); the HPT curve (:meth:`LayerLaw.hpt_tau`) is the law's closed form at constant
normal stress.  One element of layer at constant pressure must follow the closed form:
an independent check of the yield stress and the update of every law.
"""

from __future__ import annotations

import dataclasses
import math
import pickle

import numpy as np
import pytest

from torlab.errors import TorlabInputError, ValidationErrors
from torlab.model.layers import DEFAULT_LAW, LAWS, LayerParams, all_params, get_law

#: one layer per law at 750 MPa (HPT-like): elastic length 10 um, limits of the order of 0.3
SIGMA = 750e6
CASES = {
    "voce": LayerParams(0.30, 0.45, 10e-6, 20e-6),
    "voce-softening": LayerParams(0.45, 0.30, 10e-6, 15e-6),
    "linear": LayerParams(law="linear", mu_c1=0.30, L_mue=10e-6, k_mu=5000.0),
    "linear-softening": LayerParams(law="linear", mu_c1=0.45, L_mue=10e-6, k_mu=-3000.0),
    "perfect": LayerParams(law="perfect", mu_c1=0.30, L_mue=10e-6),
}


def _element_path(lay: LayerParams, u: np.ndarray, sigma: float, k_extra: float = 0.0
                  ) -> np.ndarray:
    """Shear stress of one element of layer loaded along the displacements ``u`` [m]:
    trial ``tau + du / L``, then the law's radial return (``L = L_e + k_extra``)."""
    L = lay.L_mue / sigma + k_extra
    tau, kap = 0.0, 0.0
    out = []
    for du in np.diff(u, prepend=0.0):
        t, dk = lay.law.return_map(lay, sigma, np.array(tau + du / L), np.array(kap), 1.0 / L)
        tau, kap = float(t), kap + float(dk)
        out.append(tau)
    return np.array(out)


def test_the_registry_names_each_law_once_and_voce_is_the_default():
    assert DEFAULT_LAW == "voce" and get_law() is LAWS["voce"]
    for name, law in LAWS.items():
        assert law.name == name and get_law(name) is law
        assert len(set(law.names)) == len(law.names)
        # the elastic part and the onset are every law's
        assert {"mu_c1", "L_mue", "mu_c1_T"} <= set(law.names)
        for p in law.params:
            assert all_params()[p.name] is p or all_params()[p.name] == p
            assert p.unit and p.symbol and p.meaning
    with pytest.raises(KeyError, match="not a layer law"):
        get_law("hooke")


def test_layer_params_are_the_laws_frozen_dataclass():
    lay = LayerParams(0.30, 0.45, 10e-6, 20e-6)
    assert lay.law is get_law("voce") and isinstance(lay, LayerParams)
    assert lay.values == {"mu_c1": 0.30, "mu_c2": 0.45, "L_mue": 10e-6, "L_mup": 20e-6,
                          "mu_c1_T": 0.0, "mu_c2_T": 0.0}
    assert dataclasses.asdict(lay) == lay.values
    assert dataclasses.replace(lay, mu_c1=0.2) == lay.replace(mu_c1=0.2) != lay
    assert pickle.loads(pickle.dumps(lay)) == lay
    assert lay.get("k_mu", "none") == "none"
    with pytest.raises(TypeError, match="mu_c2"):
        LayerParams(0.30)
    with pytest.raises(TypeError, match="not a parameter"):
        lay.replace(k_mu=1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        lay.mu_c1 = 0.1  # type: ignore[misc]


def test_a_scene_boundary_builds_its_laws_values():
    from torlab.scene import Boundary, boundary_of, scene_from_dict

    base = {"contact": {"load": "20 kN", "a": "3.7 mm", "b": "3.3 mm"},
            "materials": {"E1": "210 GPa", "nu1": 0.28, "E2": "210 GPa", "nu2": 0.28}}
    sc = scene_from_dict({**base, "boundary": {"mu_c1": 0.3, "mu_c2": 0.45, "L_mue": 10e-6}})
    same = scene_from_dict({**base, "boundary": {"law": "voce", "mu_c1": 0.3, "mu_c2": 0.45,
                                                 "L_mue": 10e-6}})
    assert sc.boundary == same.boundary
    assert sc.boundary.layer == LayerParams(0.3, 0.45, 10e-6)
    # the default law is not written back: a Voce section dumps as it always has
    assert "law" not in sc.boundary.model_dump()
    assert boundary_of(sc.boundary.layer) == sc.boundary
    assert Boundary(mu_c1=0.3, mu_c2=0.45, L_mue=10e-6) == sc.boundary
    with pytest.raises(ValidationErrors, match=r"hooke'? is not"):
        scene_from_dict({**base, "boundary": {"law": "hooke", "mu_c1": 0.3}})
    with pytest.raises(ValidationErrors, match=r"boundary\.mu_c2: missing"):
        scene_from_dict({**base, "boundary": {"mu_c1": 0.3}})


@pytest.mark.parametrize("case", CASES)
def test_one_element_at_constant_pressure_follows_the_hpt_curve(case):
    """Radial return, step by step, against the law's closed-form HPT curve."""
    lay = CASES[case]
    u = np.linspace(0.0, 120e-6, 241)
    path = _element_path(lay, u, SIGMA)
    closed = lay.law.hpt_tau(u, SIGMA, lay)
    scale = float(np.max(np.abs(closed)))
    assert np.max(np.abs(path - closed)) < 1e-9 * scale


@pytest.mark.parametrize("case", CASES)
def test_unloading_is_elastic_and_reloading_yields_where_it_left(case):
    lay = CASES[case]
    law, L = lay.law, lay.L_mue / SIGMA
    up = np.linspace(0.0, 60e-6, 61)
    tau_top = _element_path(lay, up, SIGMA)[-1]
    kap = 60e-6 - tau_top * L  # the plastic slip at the top (u = tau L + kappa)
    # back by 1 um: elastic, the slope of the layer
    t, dk = law.return_map(lay, SIGMA, np.array(tau_top - 1e-6 / L), np.array(kap), 1.0 / L)
    assert float(dk) == 0.0 and float(t) == pytest.approx(tau_top - 1e-6 / L, rel=1e-12)
    # the yield stress of the hardened state is the stress at the top; below it, no yield
    tc = law.yield_stress(lay, SIGMA, kap)
    assert float(tc) == pytest.approx(tau_top, rel=1e-9)
    t, dk = law.return_map(lay, SIGMA, np.array(0.999 * tc), np.array(kap), 1.0 / L)
    assert float(dk) == 0.0


def test_return_map_keeps_the_direction_of_a_vector_trial():
    lay = CASES["voce"]
    law = lay.law
    L = lay.L_mue / SIGMA
    trial = np.array([[3e8, 4e8], [1e6, 0.0]])
    tau, dk = law.return_map(lay, SIGMA, trial, np.zeros(2), 1.0 / L)
    tc = law.yield_stress(lay, SIGMA, dk)
    assert np.linalg.norm(tau[0]) == pytest.approx(float(tc[0]), rel=1e-12)
    assert tau[0, 0] / tau[0, 1] == pytest.approx(0.75, rel=1e-12)
    assert dk[1] == 0.0 and np.array_equal(tau[1], trial[1])


def test_voce_refuses_a_plastic_branch_steeper_than_the_elastic_one():
    lay = LayerParams(0.1, 0.9, 100e-6, 1e-6)  # (mu_c2 - mu_c1) L_mue >> L_mup
    with pytest.raises(TorlabInputError, match="steeper than the elastic"):
        lay.law.yield_stress(lay, SIGMA, 1e-6)


# --- the laws in the solvers ------------------------------------------------------------------
#: the Tab. 5.4 wheel-rail contact (a = 3.7 mm, b = 3.3 mm, 0.78 GPa, steel)
A, B, P0 = 3.7e-3, 3.3e-3, 0.78e9
G_STEEL = 80e9
L1 = 8 * A / (3 * 4.2 * G_STEEL)


def _fastsim(lay: LayerParams, thermal: bool = False):
    from torlab.model.fastsim import FastsimProblem
    from torlab.model.flash import ThermalParams

    return FastsimProblem(a=A, b=B, p0=P0, L1=L1, layer=lay, speed=10.0,
                          thermal=ThermalParams() if thermal else None)


def _creep(lay: LayerParams):
    from torlab.model.creep import CreepProblem

    return CreepProblem(a=A, b=B, p0=P0, L1=L1, L2=8 * A / (3 * 3.7 * G_STEEL),
                        L3=math.pi * A * math.sqrt(A / B) / (4 * 1.6 * G_STEEL), layer=lay)


def test_perfect_plasticity_is_voce_with_equal_limits_and_linear_without_hardening():
    """Three ways to write one law: FASTSIM, the temperature loop and the creep forces with
    spin agree within the schemes' own quadrature error (1e-7 and 1e-6 of the force: the
    plastic panels differ, Voce's are graded with L_mup)."""
    from torlab.model.creep import creep_forces
    from torlab.model.fastsim import boundary_traction

    xi = np.array([1e-4, 1e-3, 3e-3, 1e-2, 0.1])
    same = [LayerParams(law="perfect", mu_c1=0.3, L_mue=10e-6, mu_c1_T=-1e-3),
            LayerParams(0.3, 0.3, 10e-6, 20e-6, -1e-3, -1e-3),
            LayerParams(law="linear", mu_c1=0.3, L_mue=10e-6, k_mu=0.0, mu_c1_T=-1e-3)]
    for thermal in (False, True):
        mus = [boundary_traction(_fastsim(lay, thermal), xi).mu for lay in same]
        # with temperature: within the loop's tolerance (0.1 K) times the coefficient (1e-3/K)
        np.testing.assert_allclose(mus[1], mus[0], rtol=1e-4 if thermal else 1e-7, atol=0)
        np.testing.assert_allclose(mus[2], mus[0], rtol=1e-12, atol=0)
    iso = [lay.replace(mu_c1_T=0.0) if lay.law.name != "voce" else
           lay.replace(mu_c1_T=0.0, mu_c2_T=0.0) for lay in same]
    f = [creep_forces(_creep(lay), [2e-3, 1e-3], [1e-3, 0.0], [0.0, 1.0]) for lay in iso]
    for other in f[1:]:
        for k in ("Fx", "Fy", "Mz"):
            np.testing.assert_allclose(getattr(other, k), getattr(f[0], k), rtol=1e-6,
                                       atol=1e-6 * np.max(np.abs(f[0].Fx)))


@pytest.mark.parametrize("case, creepages", [
    pytest.param("linear-softening", [0.1], marks=pytest.mark.slow),
    pytest.param("linear-strong", [1e-4, 3e-3, 1e-2, 0.1], marks=pytest.mark.slow),
    pytest.param("linear", [1e-4, 1e-3, 3e-3, 1e-2, 0.1], marks=pytest.mark.slow),
    pytest.param("linear-softening", [1e-4, 1e-3, 3e-3, 1e-2], marks=pytest.mark.slow),
    pytest.param("perfect", [1e-4, 1e-3, 1e-2, 0.1], marks=pytest.mark.slow),
])  # the reference integrates each creepage adaptively (one to several seconds each)
def test_fastsim_of_contacts_laws_against_the_grid_free_reference(case, creepages):
    """The default grid against the continuous strip solution (adaptive quadrature): within
    3e-5 of mu, the default scheme's accuracy for Voce (docs/model/boundary.md), also where
    softening takes the layer's strength to zero (a kink the panels put an edge on)."""
    from torlab.model.fastsim import boundary_traction
    from torlab.model.reference_solvers import boundary_traction_reference

    lay = CASES.get(case) or LayerParams(law="linear", mu_c1=0.45, L_mue=10e-6, k_mu=-5e4)
    prob = _fastsim(lay)
    mu = boundary_traction(prob, creepages).mu
    ref = [boundary_traction_reference(prob, x) for x in creepages]
    assert np.max(np.abs(mu - ref)) < 3e-5, (mu, ref)


def test_softening_to_zero_strength_converges_with_the_grid():
    """The kink where softening takes the strength to zero gets a panel edge: the default
    grid is within 3e-5 of a grid four times finer (the reference: the slow tests above)."""
    from torlab.model.fastsim import FastsimGrid, boundary_traction

    prob = _fastsim(LayerParams(law="linear", mu_c1=0.45, L_mue=10e-6, k_mu=-5e4))
    xi = np.array([3e-3, 1e-2, 0.1])
    fine = FastsimGrid(n=24, m=8, graded_panels=12, uniform_panels=12, clamp_panels=4)
    coarse = boundary_traction(prob, xi).mu
    np.testing.assert_allclose(coarse, boundary_traction(prob, xi, fine).mu, rtol=0, atol=3e-5)


def test_creep_forces_of_the_linear_law_without_spin_are_the_longitudinal_model():
    from torlab.model.creep import creep_forces
    from torlab.model.fastsim import boundary_traction

    for case in ("linear", "linear-softening", "perfect"):
        lay = CASES[case]
        xi = np.array([1e-3, 1e-2, 0.05])
        f = creep_forces(_creep(lay), xi, 0.0, 0.0)
        mu = boundary_traction(_fastsim(lay), xi).mu
        # the two schemes' panels differ: each within 2e-5 of mu of the continuous model
        np.testing.assert_allclose(f.Fx / _creep(lay).load, mu, rtol=0, atol=2e-5)


@pytest.mark.slow  # the reference: an ODE per strip with events, 2-6 s a point
@pytest.mark.parametrize("case, point", [
    ("linear", (2e-3, 1e-3, 0.0)), ("linear", (1e-3, 1e-3, 1.0)),
    ("linear", (0.02, 0.0, 2.0)), ("linear-softening", (2e-3, 0.0, 0.5)),
    ("linear-softening", (1e-3, 1e-3, 1.0)), ("perfect", (1e-3, 1e-3, 1.0))])
def test_creep_forces_of_contacts_laws_against_the_reference(case, point):
    """Lateral creepage and spin: the fast scheme against the grid-free reference, within
    3e-5 of N (Voce's accuracy on the same points: 2e-5).  The reference at rtol 1e-7
    differs from itself at 1e-8 by at most 2e-8 of N on these points (measured), 1500
    times below what is asserted."""
    from torlab.model.creep import creep_forces
    from torlab.model.reference_solvers import creep_forces_reference

    prob = _creep(CASES[case])
    x, e, f = point
    r = creep_forces(prob, [x], [e], [f])
    ref = creep_forces_reference(prob, x, e, f, rtol=1e-7)
    c = math.sqrt(A * B)
    got = np.array([r.Fx[0], r.Fy[0], r.Mz[0] / c]) / prob.load
    want = np.array([ref[0], ref[1], ref[2] / c]) / prob.load
    assert np.max(np.abs(got - want)) < 3e-5, (got, want)


def test_band_draws_of_a_linear_layer_are_the_row_by_row_results():
    from torlab.model.fastsim import boundary_traction, boundary_traction_draws

    prob = _fastsim(CASES["linear-softening"])
    k = np.array([-3000.0, -500.0, 0.0, 2000.0])
    m1 = np.array([0.45, 0.40, 0.35, 0.30])
    xi = np.array([1e-3, 1e-2, 0.1])
    d = boundary_traction_draws(prob, {"k_mu": k, "mu_c1": m1}, xi)
    for i in range(k.size):
        lay = prob.layer.replace(k_mu=k[i], mu_c1=m1[i])
        row = boundary_traction(dataclasses.replace(prob, layer=lay), xi).mu
        np.testing.assert_allclose(d.mu[i], row, rtol=1e-12, atol=1e-15)


# --- the HPT curve and CONTACT's parameters ----------------------------------------------------
def test_linear_hpt_curve_is_contacts_piecewise_linear_rheology():
    """At constant normal stress the linear law is the bilinear curve CONTACT uses for the
    Hou-Kalousek-Magel powders: slope G_el = sigma/L_mue to (u_c0, tau_c0), then k_u =
    sigma k_mu; CONTACT's input k_tau = G_el k_u/(G_el - k_u) is the slope against the plastic
    slip (its user guide's relation), which the per-element yield stress uses."""
    sigma = 900e6
    for u0, t0, u1, t1 in ((40e-6, 200e6, 540e-6, 400e6), (50e-6, 400e6, 550e-6, 300e6)):
        G_el, k_u = t0 / u0, (t1 - t0) / (u1 - u0)
        lay = LayerParams(law="linear", mu_c1=t0 / sigma, L_mue=sigma / G_el, k_mu=k_u / sigma)
        u = np.linspace(0.0, 600e-6, 601)
        want = np.where(u <= u0, G_el * u, t0 + k_u * (u - u0))
        np.testing.assert_allclose(lay.law.hpt_tau(u, sigma, lay), want, rtol=1e-12,
                                   atol=1e-6)
        k_tau = G_el * k_u / (G_el - k_u)
        kap = np.array([0.0, 1e-5, 2e-4])
        np.testing.assert_allclose(lay.law.yield_stress(lay, sigma, kap), t0 + k_tau * kap,
                                   rtol=1e-12)


# --- CONTACT's one-element example (examples/plastic_3bl) ---------------------------------------
def _contact_layer(layer: list[float], p: float) -> LayerParams:
    """torlab's law of CONTACT's ``GG3, LAYTHK, TAU_C0, K_TAU`` [N/mm^2, mm, N/mm^2, N/mm^3]
    at the pressure ``p`` [Pa]: ``mu_c1 = tau_c0/p``, ``L_mue = p h/G3`` and, from
    ``k_tau/p = k_mu/(1 - k_mu L_mue)``, ``k_mu``."""
    G3, h, tau0, k_tau = layer
    L_mue = p * (h * 1e-3) / (G3 * 1e6)
    if k_tau == 0:
        return LayerParams(law="perfect", mu_c1=tau0 * 1e6 / p, L_mue=L_mue)
    kp = k_tau * 1e9 / p  # N/mm^3 = 1e9 Pa/m
    return LayerParams(law="linear", mu_c1=tau0 * 1e6 / p, L_mue=L_mue,
                       k_mu=kp / (1.0 + kp * L_mue))


def test_contacts_one_element_example_by_the_layer_laws():
    """CONTACT's plastic_3bl: one element of 1 mm^2 under 900 N sheared step by step through
    the layer of the Hou-Kalousek-Magel powders (magnetite, clay with a reversal, sand
    softening, MoS2; 57 steps).  The element's own flexibility (the bodies') is CONTACT's
    case 1 (84.97 N at a shift of 0.001 mm, no layer); each step is the law's per-element
    update with torlab's parameters converted from CONTACT's.  Every force within the
    reference's printed precision (4 digits)."""
    from contact_bank import cases, totals

    ref = [t["FX"] for t in totals("examples/plastic_3bl.ref_out")]
    area, p = 1e-6, 900.0 / 1e-6
    L_bodies = 1e-6 / (ref[0] / area)  # case 1: a shift of 0.001 mm gives ref[0] N
    lay, tau, kap, got = None, 0.0, 0.0, []
    for c in cases("examples/plastic_3bl.inp"):
        if c.get("M", 4) == 0:
            lay = None
        if "layer" in c:
            lay = _contact_layer(c["layer"], p)
        if c["P"] == 2:
            tau, kap = 0.0, 0.0
        shift = -c["kin"][0] * 1e-3  # CONTACT's cksi [mm], its force opposes the shift
        if lay is None:
            tau += shift / L_bodies
        else:
            L = L_bodies + lay.L_mue / p
            t, dk = lay.law.return_map(lay, p, np.array(tau + shift / L), np.array(kap), 1 / L)
            tau, kap = float(t), kap + float(dk)
        got.append(tau * area)
    assert len(got) == len(ref) == 57
    np.testing.assert_allclose(got, ref, rtol=6e-4, atol=0.006)


def test_the_exact_solver_runs_a_layer_law_through_element_yield():
    """The exact solver (torlab.model.exact) with a layer law of this package
    (:class:`torlab.model.exact.scene.LawYield`: the pressure as the element parameter)
    gives what it gives
    with its own CONTACT law, on one element sheared through hardening, reversal and
    softening."""
    from torlab.model.exact.grid import Grid
    from torlab.model.exact.local import LinearYield
    from torlab.model.exact.scene import LawYield
    from torlab.model.exact.solver import Layer, solve

    g = Grid(-0.5, -0.5, 1.0, 1.0, 1, 1)
    pn = np.full((1, 1), 900.0)
    for layer in ([106.25, 0.020, 200.0, 435.0], [176.63, 0.020, 400.0, -195.0]):
        G3, h, tau0, k_tau = layer
        # the solver works in CONTACT's units (mm, N/mm^2): the law's values in mm too
        kp, L_mue = k_tau / 900.0, 900.0 * h / G3
        lay = LayerParams(law="linear", mu_c1=tau0 / 900.0, L_mue=L_mue,
                          k_mu=kp / (1.0 + kp * L_mue))
        theirs = Layer(h / G3, LinearYield(k_tau), tau0)
        ours = Layer(h / G3, LawYield(lay), 900.0)  # c1: the pressure [N/mm^2]
        out = []
        for law in (theirs, ours):
            p, kap, fx = np.zeros((1, 1, 2)), np.zeros((1, 1)), []
            for shift in (-0.04, -0.04, -0.05, 0.03, -0.06, -0.05):
                W = np.zeros((1, 1, 2))
                W[..., 0] = shift
                s = solve(g, 82000.0, 0.28, pn, 0.7, W, mode="shift", layer=law, p_prev=p,
                          kappa_prev=kap)
                p, kap = s.p, s.kappa
                fx.append(s.Fx)
            out.append(fx)
        np.testing.assert_allclose(out[1], out[0], rtol=1e-9)


# --- fitting the laws to HPT curves --------------------------------------------------------------
def _virtual_run(lay: LayerParams, seed: int):
    """A virtual HPT run of the layer (the sample-data generator's rig, noise and
    encoder), written, parsed and reduced with the true rig compliance."""
    import io

    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import RigCompliance, reduce_hpt
    from torlab.synth.hpt import HptRig, HptRunSpec, rig_compliance_u, simulate_hpt, write_hpt_log

    rig = HptRig()
    tg = np.linspace(0.0, 1e9, 2001)
    comp = RigCompliance(tg, rig_compliance_u(tg, rig), "true rig compliance")
    spec = HptRunSpec("virtual", "OFM1", 4, 25.0, lay, u_max=400e-6, seed=seed)
    df, meta = read_hpt(io.StringIO(write_hpt_log(spec, simulate_hpt(spec, rig), rig)),
                        name=f"seed{seed}")
    return reduce_hpt(df, meta, compliance=comp)


@pytest.mark.parametrize("truth", [
    LayerParams(law="linear", mu_c1=0.14, L_mue=8e-6, k_mu=300.0),
    LayerParams(law="linear", mu_c1=0.25, L_mue=8e-6, k_mu=-250.0),
    LayerParams(law="perfect", mu_c1=0.2, L_mue=6e-6)], ids=["hardening", "softening", "perfect"])
def test_hpt_fit_of_a_law_recovers_its_truth(truth):
    """A virtual run of the sample data's rig (force noise, the layer's slow strength
    fluctuation, encoder steps) with a layer of CONTACT's laws: the law's fit finds the truth
    within its 99 % intervals."""
    from torlab.fit.layer import fit_layer_hpt
    from torlab.fit.result import student_t

    res = fit_layer_hpt(_virtual_run(truth, 11), law=truth.law.name)
    assert res.meta["law"] == truth.law.name and res.names == truth.law.fit_names
    for n in res.names:
        t = student_t(res.meta["interval_dof"][n], 0.99)
        assert abs(res.params[n] - getattr(truth, n)) < t * res.stderr[n], (n, res.params[n])
    assert res.to_scene_dict()["boundary"]["law"] == truth.law.name


def test_law_selection_prefers_the_law_a_curve_was_made_with():
    """AICc (as fit removal): a Voce run (the sample data's OFM1 at 4 uL) chooses Voce, a
    hardening straight line chooses the linear law; the comparison is in the result."""
    from torlab.fit.layer import fit_layer_hpt

    lin = fit_layer_hpt(_virtual_run(LayerParams(law="linear", mu_c1=0.14, L_mue=8e-6,
                                                 k_mu=300.0), 12), law="auto")
    assert lin.meta["law"] == "linear"
    rows = {r["law"]: r for r in lin.meta["law_selection"]}
    assert set(rows) == set(LAWS) and rows["linear"]["delta_aicc"] == 0.0
    assert rows["perfect"]["delta_aicc"] > 10
    assert sum(r["weight"] for r in rows.values()) == pytest.approx(1.0)
    voce = fit_layer_hpt(_virtual_run(LayerParams(0.14, 0.22, 8e-6, 19e-6), 13),
                         law="voce,linear")
    assert voce.meta["law"] == "voce"
    assert [r["law"] for r in voce.meta["law_selection"]] == ["voce", "linear"]


def test_a_parameter_file_of_another_law_replaces_the_scenes_layer(tmp_path):
    """A scene merged with a parameter file that sets another law: the earlier files' keys
    the new law does not have are dropped, the shared ones kept unless the file sets them."""
    from torlab.scene import load_scene
    from torlab.yamlio import dump_yaml

    scene = tmp_path / "s.yaml"
    scene.write_text(dump_yaml({
        "contact": {"load": "20 kN", "a": "3.7 mm", "b": "3.3 mm"},
        "materials": {"E1": "210 GPa", "nu1": 0.28, "E2": "210 GPa", "nu2": 0.28},
        "thermal": {},
        "boundary": {"mu_c1": 0.3, "mu_c2": 0.45, "L_mue": "10 um", "L_mup": "20 um",
                     "mu_c1_T": "-1e-3 1/K", "mu_c2_T": "-2e-3 1/K"}}))
    params = tmp_path / "p.yaml"
    params.write_text(dump_yaml({"boundary": {"law": "linear", "mu_c1": 0.25,
                                              "L_mue": 8e-6, "k_mu": 400.0}}))
    sc = load_scene(scene, params)
    assert sc.boundary.layer == LayerParams(law="linear", mu_c1=0.25, L_mue=8e-6, k_mu=400.0,
                                            mu_c1_T=-1e-3)
    assert sc.boundary.model_dump()["law"] == "linear"


def test_every_law_and_parameter_is_documented():
    """docs/model/layers.md has a section for each law with a row for each of its keys, and
    the ranges a law declares for its own parameters (the page's "Plausible values")."""
    from conftest import ROOT

    doc = (ROOT / "docs" / "model" / "layers.md").read_text(encoding="utf-8")
    for name, law in LAWS.items():
        sec = doc.split(f"### `{name}`", 1)
        assert len(sec) == 2, f"no section for the {name} law"
        body = sec[1].split("\n### ", 1)[0]
        for p in law.params:
            assert f"`{p.name}`" in body, (name, p.name)
            if isinstance(p.range, dict):  # a quantity of the law's own
                plaus = doc.split("## Plausible values", 1)[1]
                assert f"| {p.range['what']} |" in plaus and f"`boundary.{p.name}`" in plaus


# --- the commands and the protocol ---------------------------------------------------------------
def test_fit_hpt_law_and_resolution_options_refuse_bad_values(cli, tmp_path):
    from conftest import ROOT

    log = ROOT / "sample_data" / "hpt" / "hpt_OFM1_4uL_25C.txt"
    r = cli("fit", "hpt", log, "-o", tmp_path / "a", "--law", "lineer")
    assert r.exit_code == 2 and "'lineer' is not a layer law" in r.output
    assert "did you mean 'linear'" in r.output and not (tmp_path / "a").exists()
    r = cli("fit", "hpt", log, "-o", tmp_path / "b", "--law", "auto", "--resolution", "-5 MPa")
    assert r.exit_code == 2 and "--resolution" in r.output
    # a resolution only the comparison of several laws uses: refused, not ignored
    r = cli("fit", "hpt", log, "-o", tmp_path / "c", "--law", "linear", "--resolution", "2 MPa")
    assert r.exit_code == 2 and "--resolution" in r.output and "linear law alone" in r.output
    assert "Traceback" not in r.output and not (tmp_path / "c").exists()


def test_fit_layer_hpt_refuses_a_resolution_with_one_law():
    from torlab.errors import TorlabInputError
    from torlab.fit.layer import fit_layer_hpt

    with pytest.raises(TorlabInputError, match="several layer laws"):
        fit_layer_hpt([], law="voce", resolution=1e6)


def test_a_protocol_fits_the_law_it_names(tmp_path):
    """``fits.hpt_layers.law``: the parameter set carries the law (its scene section and the
    fit's summary); an unknown law is a validation error naming the key."""
    import shutil

    from conftest import ROOT

    from torlab.errors import ValidationErrors
    from torlab.protocols.loader import load_protocol
    from torlab.protocols.runner import run_protocol

    for f in sorted((ROOT / "sample_data/hpt").glob("hpt_OFM1_4uL_25C*.txt")):
        shutil.copy(f, tmp_path / f.name)
    text = ("version: 1\nname: laws\ndata:\n  hpt:\n    files: [hpt_*.txt]\n"
            "fits:\n  hpt_layers:\n    amounts: [4 uL]\n    joint: true\n"
            "    temperature_coefficients: false\n    law: {law}\n"
            "reports:\n  amount: {{}}\n")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.format(law="hooke"))
    with pytest.raises(ValidationErrors, match=r"fits\.hpt_layers\.law"):
        load_protocol(bad)
    p = tmp_path / "p.yaml"
    p.write_text(text.format(law="linear"))
    run_protocol(p, tmp_path / "out")
    import json

    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    fit = s["fits"]["hpt:OFM1"]
    assert set(fit["params"]) == {"mu_c1", "L_mue", "k_mu"}
    from torlab.yamlio import load_yaml

    params = load_yaml(tmp_path / "out" / "fits" / "hpt_OFM1.yaml").data
    assert params["boundary"]["law"] == "linear"


@pytest.mark.parametrize("law", [n for n in LAWS if n != "voce"])
def test_predictions_of_a_scene_with_another_law(law):
    """A dry scene with another law: the traction curve (with the contact temperature), the
    creep forces with spin, and what they say they modelled."""
    from torlab.model.creep import predict_creep
    from torlab.model.predict import predict_traction
    from torlab.scene import boundary_of, scene_from_dict

    base = {"contact": {"load": "20 kN", "a": "3.7 mm", "b": "3.3 mm"},
            "materials": {"E1": "210 GPa", "nu1": 0.28, "E2": "210 GPa", "nu2": 0.28},
            "kinematics": {"speed": "10 m/s"}, "thermal": {}}
    lay = CASES[law].replace(mu_c1_T=-1e-3)
    sc = scene_from_dict({**base, "boundary": boundary_of(lay).model_dump()})
    assert sc.boundary.layer == lay
    t = predict_traction(sc, np.linspace(-0.05, 0.05, 11))
    assert np.all(np.isfinite(t.table["mu"])) and t.table["mu"].iloc[-1] > 0
    assert any(lay.law.short in m for m in t.modelled)
    assert t.summary["boundary"]["law"] == law
    c = predict_creep(sc.model_copy(update={"thermal": None}), [1e-3, 1e-2], lateral=1e-3,
                      spin=0.5)
    assert np.all(np.isfinite(c.table["mu"]))
    assert any(lay.law.limit_text in m for m in c.modelled)


def test_a_linear_layer_fitted_to_hpt_predicts_with_its_band(tmp_path):
    """fit hpt --law linear writes a parameter file with the law and its covariance;
    predict traction with it draws the band over the linear law's parameters."""
    from torlab.fit.layer import fit_layer_hpt
    from torlab.model.predict import predict_traction
    from torlab.scene import load_scene
    from torlab.yamlio import dump_yaml

    res = fit_layer_hpt(_virtual_run(LayerParams(law="linear", mu_c1=0.14, L_mue=8e-6,
                                                 k_mu=300.0), 14), law="linear")
    params = tmp_path / "params.yaml"
    res.to_params(params)
    scene = tmp_path / "scene.yaml"
    scene.write_text(dump_yaml({
        "contact": {"load": "20 kN", "a": "3.7 mm", "b": "3.3 mm"},
        "materials": {"E1": "210 GPa", "nu1": 0.28, "E2": "210 GPa", "nu2": 0.28},
        "boundary": {"mu_c1": 0.3, "mu_c2": 0.45, "L_mue": "10 um", "L_mup": "20 um"}}))
    sc = load_scene(scene, params)
    assert sc.boundary.law == "linear" and sc.boundary.k_mu == pytest.approx(res.params["k_mu"])
    t = predict_traction(sc, [0.002, 0.01, 0.03]).table
    assert np.all(t["mu_low95"] < t["mu"]) and np.all(t["mu"] < t["mu_high95"])
