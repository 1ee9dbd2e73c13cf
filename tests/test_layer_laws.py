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
    with pytest.raises(ValidationErrors, match="'hooke' is not"):
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
