"""CLI of the creep forces: predict traction --lateral/--spin, predict table, fit polach."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import error_lines

SCENE = Path(__file__).resolve().parents[1] / "protocols" / "scenes" / "wheel_rail_tab54.yaml"


def test_predict_traction_with_lateral_and_spin(cli, tmp_path):
    res = cli("predict", "traction", SCENE, "-o", tmp_path / "t", "--creepage", "0:0.01:6",
              "--lateral", "0.002", "--spin", "0.5 1/m")
    assert res.exit_code == 0, res.output
    df = pd.read_csv(tmp_path / "t" / "traction.csv")
    for col in ("creepage", "mu", "lateral", "spin_1_m", "Fx_N", "Fy_N", "Mz_Nm", "mu_x", "mu_y"):
        assert col in df.columns
    np.testing.assert_allclose(df.mu, df.mu_x)
    assert np.allclose(df.spin_1_m, 0.5) and np.all(df.Fy_N > 0)


def test_predict_table_writes_netcdf_and_csv(cli, tmp_path):
    pytest.importorskip("xarray")
    res = cli("predict", "table", SCENE, "-o", tmp_path / "tab", "--creepage", "-0.5:0.5:3",
              "--lateral", "0:0.5:2", "--spin", "-0.5:0.5:3", "--normalised")
    assert res.exit_code == 0, res.output
    df = pd.read_csv(tmp_path / "tab" / "creep_table.csv")
    assert len(df) == 3 * 2 * 3
    np.testing.assert_allclose(sorted(set(df.xi_norm.round(12))), [-0.5, 0.0, 0.5])
    assert (tmp_path / "tab" / "creep_table.nc").is_file()


@pytest.mark.parametrize("args, needle", [
    (("--creepage", "0.01"), "'creepage' has 1 point"),
    (("--spin", "2 1/m"), "'spin' has 1 point"),
    (("--spin", "1 m"), "spin"),
])
def test_predict_table_bad_axis_is_one_line_exit_2(cli, tmp_path, args, needle):
    res = cli("predict", "table", SCENE, "-o", tmp_path / "bad", "--lateral", "0:0.01:2", *args)
    assert res.exit_code == 2, res.output
    lines = error_lines(res)
    assert len(lines) == 1 and needle in lines[0], lines
    assert not (tmp_path / "bad").exists()


def test_fit_polach_writes_the_fit_and_its_error(cli, tmp_path):
    res = cli("fit", "polach", SCENE, "-o", tmp_path / "p", "--creepage", "0:0.03:13",
              "--speed", "10 m/s")
    assert res.exit_code == 0, res.output
    d = pd.read_csv(tmp_path / "p" / "fit_data.csv")
    assert {"mu_torlab", "mu_polach", "residual"} <= set(d.columns)
    tab = pd.read_csv(tmp_path / "p" / "fit_table.csv")
    assert list(tab.parameter) == ["mu0", "A", "B", "kA", "kS"]
    assert "largest difference" in res.output
