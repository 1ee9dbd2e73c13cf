"""Creep-force tables: axes, Kalker's normalisation, files, bad axes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from torlab.errors import TorlabInputError
from torlab.model.creep import CreepProblem, creep_forces
from torlab.model.flash import ThermalParams
from torlab.model.kalker import L1, L2, L3, combined_G_nu, creepage_coefficients
from torlab.model.layers import LayerParams

xr = pytest.importorskip("xarray")

from torlab.model.creep_table import creep_table, kalker_scales  # noqa: E402

G, NU = combined_G_nu(210e9, 0.28, 210e9, 0.28)


def problem(layer: LayerParams, *, a: float = 3.7e-3, b: float = 3.3e-3, N: float = 20e3,
            thermal: ThermalParams | None = None) -> CreepProblem:
    c11, c22, c23 = creepage_coefficients(a / b, NU)
    return CreepProblem(a=a, b=b, p0=3 * N / (2 * math.pi * a * b), L1=L1(a, c11, G),
                        L2=L2(a, c22, G), L3=L3(a, b, c23, G), layer=layer, thermal=thermal)


WR = LayerParams(0.30, 0.45, 10e-6, 20e-6)


def test_normalisation_is_kalkers_linear_theory():
    """In Kalker's units linear theory has slope 3 in xi* and eta* and 1 in phi*
    (G c^2 C11 xi = 3 mu N xi*, ...): computed here from the C's, not the table's scales."""
    prob = problem(LayerParams(0.3, 0.3, 0.0, 0.0))
    c11, c22, c23 = creepage_coefficients(prob.a / prob.b, NU)
    c = math.sqrt(prob.a * prob.b)
    muN = 0.3 * prob.load
    s = kalker_scales(prob)
    assert s["xi"] == pytest.approx(G * c * c * c11 / (3 * muN), rel=1e-12)
    assert s["eta"] == pytest.approx(G * c * c * c22 / (3 * muN), rel=1e-12)
    assert s["phi"] == pytest.approx(G * c**3 * c23 / muN, rel=1e-12)
    e = 1e-6
    t = creep_table(prob, [-e / s["xi"], e / s["xi"]], [-e / s["eta"], e / s["eta"]],
                    [-e / s["phi"], e / s["phi"]]).dataset
    one = t.isel(creepage=1, lateral=1, spin=1)
    assert float(one.xi_norm) == pytest.approx(e)
    sel = t.isel(creepage=1, lateral=0, spin=0)
    # Fx*/xi* = 3, Fy* = 3 eta* + phi* at these tiny creepages
    assert float(sel.Fx_norm) == pytest.approx(3 * e, rel=1e-4)
    assert float(sel.Fy_norm) == pytest.approx(-3 * e - e, rel=1e-4)


def test_table_matches_direct_evaluation_and_symmetry_mapping():
    prob = problem(WR)
    xi = np.array([-4e-3, -1e-3, 0.0, 2e-3])
    eta = np.array([-3e-3, 0.0, 1e-3])
    phi = np.array([-2.0, 0.0, 1.0, 4.0])
    t = creep_table(prob, xi, eta, phi, chunk=7).dataset
    X, E, P = np.meshgrid(xi, eta, phi, indexing="ij")
    r = creep_forces(prob, X, E, P, symmetry=False)
    scale = 0.45 * prob.load
    np.testing.assert_allclose(t.Fx_N.values, r.Fx, atol=1e-10 * scale)
    np.testing.assert_allclose(t.Fy_N.values, r.Fy, atol=1e-10 * scale)
    np.testing.assert_allclose(t.Mz_Nm.values, r.Mz, atol=1e-10 * scale * prob.a)
    assert t.Fx_N.dims == ("creepage", "lateral", "spin")
    assert t.spin.attrs["units"] == "1/m"
    assert t.attrs["mu_normalisation"] == 0.45


def test_netcdf_and_long_csv(tmp_path):
    from torlab.outputs import OutputDir

    prob = problem(WR)
    tab = creep_table(prob, [0.0, 1e-3, 3e-3], [0.0, 2e-3], [-1.0, 1.0],
                      provenance={"scene": "wheel-rail", "files": ["a.yaml"]})
    with OutputDir(tmp_path / "out") as out:
        names = tab.write(out)
    assert names == ["creep_table.nc", "creep_table.csv"]
    back = xr.open_dataset(tmp_path / "out" / "creep_table.nc", engine="scipy")
    np.testing.assert_allclose(back.Fx_N.values, tab.dataset.Fx_N.values)
    assert back.attrs["scene"] == "wheel-rail"
    assert "normalisation" in back.attrs
    back.close()
    import pandas as pd

    df = pd.read_csv(tmp_path / "out" / "creep_table.csv")
    assert len(df) == 3 * 2 * 2
    for col in ("creepage", "lateral", "spin_1_m", "Fx_N", "Fy_N", "Mz_Nm", "mu_x", "mu_y",
                "Fx_norm", "xi_norm", "phi_norm"):
        assert col in df.columns


def test_speed_and_amount_axes():
    cold = problem(WR)
    hot = problem(LayerParams(0.3, 0.45, 10e-6, 20e-6, -0.002, -0.003), thermal=ThermalParams())
    t = creep_table([(2.0, cold), (4.0, hot)], [1e-3, 5e-3], [0.0, 1e-3], [0.0, 2.0],
                    speed=[1.0, 10.0], amount_unit="uL").dataset
    assert t.Fx_N.dims == ("creepage", "lateral", "spin", "speed", "amount")
    # the cold product does not depend on speed, the hot one loses traction with speed
    np.testing.assert_allclose(t.Fx_N.sel(amount=2.0, speed=1.0), t.Fx_N.sel(amount=2.0, speed=10.0))
    hot_v = t.Fx_N.sel(amount=4.0, creepage=5e-3, lateral=0.0, spin=0.0)
    assert float(hot_v.sel(speed=10.0)) < float(hot_v.sel(speed=1.0))
    assert t.amount.attrs["units"] == "uL"
    notes = creep_table(cold, [1e-3, 2e-3], [0.0, 1e-3], [0.0, 1.0], speed=[1.0, 2.0]).notes
    assert any("no thermal" in n for n in notes)


def test_chunks_go_through_map_fn():
    calls = []

    def counting_map(fn, items):
        items = list(items)
        calls.append(len(items))
        return map(fn, items)

    creep_table(problem(WR), [0.0, 1e-3, 2e-3], [0.0, 1e-3], [0.0, 1.0, 2.0], chunk=4,
                map_fn=counting_map)
    assert calls and calls[0] >= 2


@pytest.mark.parametrize("axes, match", [
    (([1e-3], [0.0, 1e-3], [0.0, 1.0]), "'creepage' has 1 point"),
    (([0.0, 1e-3], [0.0, 1e-3], [2.0]), "'spin' has 1 point"),
    (([1e-3, 0.0], [0.0, 1e-3], [0.0, 1.0]), "increase strictly"),
    (([0.0, np.inf], [0.0, 1e-3], [0.0, 1.0]), "non-finite"),
])
def test_bad_axes_are_one_clear_error(axes, match):
    with pytest.raises(TorlabInputError, match=match):
        creep_table(problem(WR), *axes)


def test_spin_axis_without_contact_shape():
    p = problem(WR)
    bare = CreepProblem(a=p.a, b=p.b, p0=p.p0, L1=p.L1, layer=p.layer)
    with pytest.raises(TorlabInputError, match="spin needs the contact shape"):
        creep_table(bare, [0.0, 1e-3], [0.0, 0.0 + 1e-12], [0.0, 1.0])
