"""Fit commands on several files, folders and patterns; --xlsx on the fit commands.

References: the sample data's known truth (sample_data/*/truth.yaml), and an exact
property of least squares: a curve fitted jointly with an identical copy of itself has
the same minimum, and its standard errors shrink by sqrt((n - p)/(2n - p)).
"""

from __future__ import annotations

import json
import shutil

import pandas as pd
import pytest
from conftest import ROOT, error_lines

OPT = ROOT / "sample_data" / "optical"
VISC = ROOT / "sample_data" / "visc"
HPT = ROOT / "sample_data" / "hpt"
DRY_SCENE = ROOT / "protocols" / "scenes" / "optical_paper_a_dry.yaml"


def _table(folder):
    return pd.read_csv(folder / "fit_table.csv").set_index("parameter")


@pytest.fixture(scope="module")
def traction_runs(tmp_path_factory):
    """One traction file fitted alone, as two copies (one fit each), and jointly."""
    from typer.testing import CliRunner

    from torlab.cli import app

    run = CliRunner()
    tmp = tmp_path_factory.mktemp("traction")
    data = tmp / "data"
    data.mkdir()
    for name in ("a.csv", "b.csv"):
        shutil.copy(OPT / "dry_traction_rough.csv", data / name)
    shutil.copy(OPT / "film_thickness_smooth.csv", data / "film.csv")  # no traction curve
    (data / "notes.txt").write_text("bench notes, not data\n")
    out = {}
    for key, args in (("single", [data / "a.csv"]), ("folder", [data]),
                      ("joint", [str(data / "[ab].csv"), "--joint"])):
        out[key] = tmp / key
        r = run.invoke(app, ["fit", "traction", str(DRY_SCENE), *map(str, args), "-o",
                             str(out[key]), "--xlsx"])
        assert r.exit_code == 0, r.output
        out[key + "_output"] = r.output
    return out


@pytest.mark.slow  # four traction fits with --xlsx; folders, patterns and joint fits: the hpt and film tests below
def test_traction_folder_gives_one_fit_per_curve(traction_runs):
    folder = traction_runs["folder"]
    # the film log and the notes are left out (said), the two curves fitted one by one
    assert "left out film.csv, notes.txt" in " ".join(traction_runs["folder_output"].split())
    assert sorted(p.parent.name for p in folder.glob("*/params.yaml")) == ["a", "b"]
    summary = pd.read_csv(folder / "fit_summary.csv").set_index("curve")
    assert list(summary.index) == ["a", "b"]
    single = _table(traction_runs["single"])
    for name in ("a", "b"):
        t = _table(folder / name)
        assert t["value"].to_numpy() == pytest.approx(single["value"].to_numpy(), rel=1e-9)
        assert summary.loc[name, "mu_c2"] == pytest.approx(single.loc["mu_c2", "value"],
                                                           rel=1e-9)
    # the true plateau of the synthetic log (sample_data/optical/truth.yaml: mu_c2 = 0.26)
    lo, hi = single.loc["mu_c2", ["ci95_low", "ci95_high"]]
    assert abs(single.loc["mu_c2", "value"] - 0.26) < 0.01 or lo <= 0.26 <= hi


@pytest.mark.slow  # four traction fits with --xlsx; folders, patterns and joint fits: the hpt and film tests below
def test_traction_joint_fit_of_a_repeat(traction_runs):
    """A curve and its exact copy: the same least-squares minimum, standard errors smaller
    by sqrt((n - p)/(2n - p)) (the residual variance over twice the points)."""
    single, joint = _table(traction_runs["single"]), _table(traction_runs["joint"])
    free = single["status"] == "free"
    assert joint["value"].to_numpy() == pytest.approx(single["value"].to_numpy(), rel=2e-4)
    n = json.loads((traction_runs["single"] / "summary.json").read_text())["n_points"]
    p = int(free.sum())
    ratio = (joint.loc[free, "stderr"] / single.loc[free, "stderr"]).to_numpy()
    assert ratio == pytest.approx(((n - p) / (2 * n - p)) ** 0.5, rel=2e-3)
    assert not (traction_runs["joint"] / "fit_summary.csv").exists()


@pytest.mark.slow  # four traction fits with --xlsx; folders, patterns and joint fits: the hpt and film tests below
def test_fit_xlsx_holds_the_tables(traction_runs):
    from openpyxl import load_workbook

    wb = load_workbook(traction_runs["folder"] / "tables.xlsx", read_only=True)
    assert {"a_fit_table", "b_fit_table", "a_fit_data", "fit_summary"} <= set(wb.sheetnames)
    rows = list(wb["a_fit_table"].values)
    csv = pd.read_csv(traction_runs["folder"] / "a" / "fit_table.csv")
    assert list(rows[0]) == list(csv.columns)
    got = {r[0]: r[1] for r in rows[1:]}
    assert got["mu_c2"] == pytest.approx(csv.set_index("parameter").loc["mu_c2", "value"],
                                         rel=1e-9)  # the CSV: 10 digits


def test_empty_pattern_and_folder_are_one_line(cli, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.txt").write_text("nothing to fit\n")
    cases = [
        (("fit", "traction", DRY_SCENE, str(tmp_path / "*.csv")), "no file matches the pattern"),
        (("fit", "traction", DRY_SCENE, empty), "no traction-curve file in the folder"),
        (("fit", "film", empty), "no film-thickness file in the folder"),
        (("fit", "hpt", str(empty / "*.txt")), "no HPT file in the pattern"),
        (("fit", "visc", empty), "no reduced viscometer file in the folder"),
        (("fit", "temperature", empty), "no HPT file in the folder"),
    ]
    for args, msg in cases:
        r = cli(*args, "-o", tmp_path / "out")
        assert r.exit_code == 2, (args, r.output)
        lines = error_lines(r)
        assert len(lines) == 1 and msg in lines[0], (args, lines)
        assert "Traceback" not in r.output
    assert not (tmp_path / "out").exists()


def test_film_several_files_and_joint(cli, tmp_path):
    data = tmp_path / "film"
    data.mkdir()
    for name in ("run1.csv", "run2.csv"):
        shutil.copy(OPT / "film_thickness_smooth.csv", data / name)
    r = cli("fit", "film", str(data / "run*.csv"), "-o", tmp_path / "each")
    assert r.exit_code == 0, r.output
    assert sorted(p.parent.name for p in (tmp_path / "each").glob("*/params.yaml")) == \
        ["run1", "run2"]
    one = _table(tmp_path / "each" / "run1")
    r = cli("fit", "film", data, "--joint", "-o", tmp_path / "joint", "--xlsx")
    assert r.exit_code == 0, r.output
    joint = _table(tmp_path / "joint")
    assert joint["value"].to_numpy() == pytest.approx(one["value"].to_numpy(), rel=1e-6)
    assert (tmp_path / "joint" / "tables.xlsx").exists()
    # the smooth film log is made with Hamrock-Dowson's speed exponent (0.67, Eq. 5.32)
    assert one.iloc[0]["ci95_low"] - 0.05 <= 0.67 <= one.iloc[0]["ci95_high"] + 0.05


def test_visc_folder_takes_the_falls(cli, tmp_path):
    red = tmp_path / "red"
    r = cli("visc", "reduce", VISC / "visc_ester_25C.txt", "--reference",
            VISC / "visc_reference_25C.txt", "-o", red, "--xlsx", "--no-plot")
    assert r.exit_code == 0, r.output
    assert (red / "tables.xlsx").exists()
    r = cli("fit", "visc", red, "-o", tmp_path / "fit", "--xlsx")
    assert r.exit_code == 0, r.output
    out = " ".join(r.output.split())
    assert "visc_ester_25C_steps.csv" in out and "left out" in out
    tab = _table(tmp_path / "fit")
    lo, hi = tab.loc["Z", "ci95_low"], tab.loc["Z", "ci95_high"]
    assert lo <= 0.42 <= hi  # sample_data/visc/truth.yaml: Z = 0.42
    n = json.loads((tmp_path / "fit" / "summary.json").read_text())["n_points"]
    assert n == len(pd.read_csv(red / "visc_ester_25C_falls.csv"))


def test_visc_refuses_two_temperatures(cli, tmp_path):
    red = tmp_path / "red"
    r = cli("visc", "reduce", VISC / "visc_ester_25C.txt", "--reference",
            VISC / "visc_reference_25C.txt", "-o", red, "--no-plot")
    assert r.exit_code == 0, r.output
    falls = pd.read_csv(red / "visc_ester_25C_falls.csv")
    hot = falls.assign(temperature_C=falls["temperature_C"] + 15.0)
    hot.to_csv(tmp_path / "hot_falls.csv", index=False)
    r = cli("fit", "visc", red / "visc_ester_25C_falls.csv", tmp_path / "hot_falls.csv",
            "-o", tmp_path / "fit")
    assert r.exit_code == 2
    assert "a viscosity law holds at one temperature" in error_lines(r)[0]


@pytest.mark.parametrize("cmd", ["hpt", "temperature", "film", "visc", "traction", "polach",
                                 "removal"])
def test_every_fit_command_has_xlsx(cli, cmd):
    r = cli("fit", cmd, "--help")
    assert r.exit_code == 0 and "--xlsx" in r.output


@pytest.mark.parametrize("cmd", ["hpt", "mtm", "optical", "visc"])
def test_every_reduce_command_has_xlsx(cli, cmd):
    r = cli(cmd, "reduce", "--help")
    assert r.exit_code == 0 and "--xlsx" in r.output


def test_hpt_folder_one_fit_per_log_and_xlsx(cli, tmp_path):
    logs = tmp_path / "logs"
    logs.mkdir()
    for t in ("25C", "25C_run2"):
        shutil.copy(HPT / f"hpt_OFM1_4uL_{t}.txt", logs)
    r = cli("fit", "hpt", logs, "--compliance", HPT / "rig_compliance.csv", "-o",
            tmp_path / "fit", "--xlsx")
    assert r.exit_code == 0, r.output
    summary = pd.read_csv(tmp_path / "fit" / "fit_summary.csv")
    assert list(summary["curve"]) == ["hpt_OFM1_4uL_25C", "hpt_OFM1_4uL_25C_run2"]
    assert "residual_rms_Pa" in summary
    from openpyxl import load_workbook

    names = load_workbook(tmp_path / "fit" / "tables.xlsx", read_only=True).sheetnames
    assert "fit_summary" in names and "hpt_OFM1_4uL_25C_fit_table" in names
