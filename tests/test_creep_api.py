"""The creep forces in the public API: torlab.predict_creep, creep_table, fit_polach.

They are thin layers over torlab.model.creep, creep_table and torlab.fit.polach (whose
physics the other creep tests check against Kalker, CONTACT and the grid-free
reference); here: unit strings equal SI numbers, the scene's grid reaches the scheme,
parameter files apply, and the names load lazily.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

SCENE = Path(__file__).resolve().parents[1] / "protocols" / "scenes" / "wheel_rail_tab54.yaml"


def test_top_level_names_load_lazily():
    import torlab

    for name in ("predict_creep", "creep_table", "fit_polach"):
        assert name in dir(torlab) and name in torlab.__all__
        assert callable(getattr(torlab, name))
    from torlab import api

    assert torlab.predict_creep is api.predict_creep


def test_predict_creep_unit_strings_equal_si_numbers():
    import torlab
    from torlab.model.creep import creep_forces, creep_problem, scene_grid

    a = torlab.predict_creep(SCENE, "0:1 %:5", lateral="0.1 %", spin="500 1/km")
    b = torlab.predict_creep(SCENE, np.linspace(0.0, 0.01, 5), lateral=1e-3, spin=0.5)
    for col in ("Fx_N", "Fy_N", "Mz_Nm", "mu_x", "mu_y"):
        np.testing.assert_array_equal(a.table[col], b.table[col])
    assert np.allclose(a.table["lateral"], 1e-3) and np.allclose(a.table["spin_1_m"], 0.5)
    # the same numbers as the model's creep_forces on the scene's problem and grid
    sc = torlab.load_scene(SCENE)
    r = creep_forces(creep_problem(sc), np.linspace(0.0, 0.01, 5), 1e-3, 0.5, scene_grid(sc))
    np.testing.assert_allclose(a.table["Fy_N"], r.Fy, rtol=1e-13)


def test_scene_grid_reaches_the_creep_scheme():
    """grid: n, m and temperature_nodes mean the same for both schemes and carry over."""
    import torlab
    from torlab.model.creep import CreepGrid, creep_forces, creep_problem, scene_grid
    from torlab.scene import scene_from_dict

    d = torlab.load_scene(SCENE).model_dump(exclude_none=True)
    d["grid"] = {"n": 8, "m": 6, "temperature_nodes": 32}
    fine = scene_from_dict(d)
    g = scene_grid(fine)
    assert (g.n, g.m, g.temperature_nodes) == (8, 6, 32)
    assert (g.spin_panels, g.uniform_panels) == (CreepGrid().spin_panels, CreepGrid().uniform_panels)
    assert scene_grid(torlab.load_scene(SCENE)).m == 4 == CreepGrid().m  # one default for both
    got = torlab.predict_creep(fine, [2e-3], lateral=1e-3, spin=1.0).table
    want = creep_forces(creep_problem(fine), 2e-3, 1e-3, 1.0, CreepGrid(n=8, m=6,
                                                                        temperature_nodes=32))
    assert got["Fx_N"][0] == pytest.approx(float(want.Fx), rel=1e-13)
    default = creep_forces(creep_problem(fine), 2e-3, 1e-3, 1.0)
    assert got["Fx_N"][0] != float(default.Fx)  # the grid changed the numbers


def test_parameter_files_apply_over_scene_objects(tmp_path):
    """A parameter file given with a Scene (not a path) is merged, as with a path."""
    import torlab

    p = tmp_path / "p.yaml"
    p.write_text("boundary:\n  mu_c2: 0.35\n", encoding="utf-8")
    sc = torlab.load_scene(SCENE)
    a = torlab.predict_creep(sc, [0.05], params=p).table
    b = torlab.predict_creep(SCENE, [0.05], params=p).table
    c = torlab.predict_creep(SCENE, [0.05]).table
    assert a["mu_x"][0] == pytest.approx(b["mu_x"][0], rel=1e-14)
    assert a["mu_x"][0] < c["mu_x"][0]


def test_creep_table_unit_strings_and_amounts(tmp_path):
    pytest.importorskip("xarray")
    import torlab

    lo, hi = tmp_path / "lo.yaml", tmp_path / "hi.yaml"
    lo.write_text("boundary:\n  mu_c2: 0.35\n", encoding="utf-8")
    hi.write_text("boundary:\n  mu_c2: 0.45\n", encoding="utf-8")
    t = torlab.creep_table(SCENE, "-0.5 %:0.5 %:3", "0 %, 0.2 %", "-1 1/m, 1 1/m",
                           amounts=[("2 uL", lo), ("4 uL", hi)])
    ds = t.dataset
    assert dict(ds.sizes) == {"creepage": 3, "lateral": 2, "spin": 2, "amount": 2}
    np.testing.assert_allclose(ds["creepage"], [-5e-3, 0.0, 5e-3])
    np.testing.assert_allclose(ds["amount"], [2.0, 4.0])
    assert ds["amount"].attrs["units"] == "uL"
    big = ds.isel(creepage=2, lateral=1, spin=1)
    assert float(big.Fx_N.isel(amount=0)) <= float(big.Fx_N.isel(amount=1))
    same = torlab.creep_table(SCENE, [-5e-3, 0.0, 5e-3], [0.0, 2e-3], [-1.0, 1.0],
                              params=hi).dataset
    np.testing.assert_allclose(ds.Fy_N.isel(amount=1), same.Fy_N, rtol=1e-13)
    from torlab.errors import TorlabInputError

    with pytest.raises(TorlabInputError, match="one unit"):
        torlab.creep_table(SCENE, "-1 %:1 %:3", "0:0.01:2", "-1:1:2",
                           amounts=[("2 uL", lo), ("4 mg", hi)])


def test_fit_polach_with_unit_strings():
    import torlab

    res = torlab.fit_polach(SCENE, "0:3 %:13", "10 m/s")
    assert set(res.params) >= {"mu0", "A", "B", "kA", "kS"}
    assert res.meta["max_abs_residual"] < 0.05
