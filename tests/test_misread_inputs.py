"""Lab files that used to be read wrongly without a word, through the commands.

Each case changes a shipped file in one way a lab file goes wrong (a decimal comma in one
cell, a header written with other line ends, a run cut off or two runs in one file, a
column of huge numbers ...) and checks the command against what the change means: the
numbers of the unchanged file (the same data written another way must give them), or
one ``error:`` line naming the file and line (and column), exit code 2.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT, error_lines

SAMPLE = ROOT / "sample_data"
HPT_LOG = SAMPLE / "hpt" / "hpt_OFM1_4uL_25C.txt"
VISC = SAMPLE / "visc" / "visc_ester_25C.txt"
VISC_REF = SAMPLE / "visc" / "visc_reference_25C.txt"
TT = SAMPLE / "retention" / "mtm_retention_1uL.txt"
EHD2 = ROOT / "tests" / "data" / "pcs" / "ehd2_quirks.txt"
MTM_QUIRKS = ROOT / "tests" / "data" / "pcs" / "mtm_quirks.txt"


def _lines(path: Path) -> list[str]:
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:  # a PCS export in Windows-1252
        text = raw.decode("cp1252")
    return text.replace("\r\n", "\n").split("\n")


def _one_error(r, path: Path, line: int | None = None) -> str:
    assert r.exit_code == 2, r.output
    (ln,) = error_lines(r)
    assert ln.startswith(f"error: {path}" + (f":{line}:" if line is not None else ""))
    return ln


# ------------------------------------------------------------------ one field more or less
def test_a_decimal_comma_in_a_viscometer_row_is_an_error_naming_the_line(cli, tmp_path):
    lines = _lines(VISC)
    assert lines[62] == "5.00,3.4196,0.07,25.04"
    lines[62] = "5.00,3,4196,0.07,25.04"  # read as 3 mm, 4196 MPa, 0.07 degC before
    f = tmp_path / "visc.txt"
    f.write_text("\n".join(lines))
    r = cli("visc", "reduce", f, "--reference", VISC_REF, "-o", tmp_path / "o", "--no-plot")
    ln = _one_error(r, f, 63)
    assert "expected 4 fields" in ln and "found 5" in ln and "decimal comma" in ln


def test_a_decimal_comma_in_a_compliance_curve_is_an_error_naming_the_line(cli, tmp_path):
    comp = SAMPLE / "hpt_paper_b" / "rig_compliance.csv"
    lines = _lines(comp)
    i = next(k for k, s in enumerate(lines) if s.startswith("170.0,"))
    lines[i] = lines[i].replace("170.0,2.", "170.0,2,")  # changed f_window before
    f = tmp_path / "comp.csv"
    f.write_text("\n".join(lines))
    r = cli("hpt", "reduce", SAMPLE / "hpt_paper_b" / "hpt_TOR-A_8uL_25C.txt",
            "--compliance", f, "-o", tmp_path / "o", "--no-plot")
    assert "expected 2 fields" in _one_error(r, f, i + 1)


@pytest.mark.parametrize("change, fragment", [
    (lambda s: s + ",5", "found 6"), (lambda s: s.rsplit(",", 1)[0], "a truncated row"),
])
def test_an_hpt_row_with_one_field_more_or_less(cli, tmp_path, change, fragment):
    lines = _lines(HPT_LOG)
    lines[29] = change(lines[29])
    f = tmp_path / "h.txt"
    f.write_text("\n".join(lines))
    r = cli("hpt", "reduce", f, "-o", tmp_path / "o", "--no-plot")
    assert fragment in _one_error(r, f, 30)


def _rig2(tmp_path: Path, csv_change=None, map_change=None) -> tuple[Path, Path]:
    from fuzz_corpus import HPT_MAP, HPT_MAP_CSV

    m = tmp_path / "rig2.yaml"
    m.write_text(map_change(HPT_MAP) if map_change else HPT_MAP)
    c = tmp_path / "rig2.csv"
    text = HPT_MAP_CSV.decode()
    c.write_text(csv_change(text) if csv_change else text)
    return m, c


def test_a_column_map_file_read_right_with_its_decimal_comma(cli, tmp_path):
    """The rig-2 file (semicolons, decimal commas, counts scaled by the map) against the
    values it was written from."""
    from torlab.parsers.hpt import read_hpt

    m, c = _rig2(tmp_path)
    df, _ = read_hpt(c, m)
    k = np.arange(12)
    assert np.allclose(df["time_s"], k)
    assert np.allclose(df["normal_force_N"], 63617.2512)
    assert np.allclose(df["torque_N_m"], np.minimum(50 * k, 100))
    assert np.allclose(np.degrees(df["motor_angle_rad"]), 20 * k * 0.00045)


@pytest.mark.parametrize("edit, line, fragment", [
    (lambda t: t.replace("2,0;63", "2,0;63;7", 1).replace("3,0;", "3,0;", 1), 6, "found 6"),
    (lambda t: t.replace("4,0;", "409.00;", 1), 8,
     "column 'Zeit': '409.00' has a decimal point, but the file's decimal mark is ','"),
])
def test_a_column_map_file_with_a_bad_row(cli, tmp_path, edit, line, fragment):
    m, c = _rig2(tmp_path, csv_change=edit)
    r = cli("hpt", "reduce", c, "--map", m, "-o", tmp_path / "o", "--no-plot")
    assert fragment in _one_error(r, c, line)


@pytest.mark.parametrize("key, value, named, fragment", [
    ("delimiter", '""', "delimiter", "must be one character"),
    ("delimiter", "';;'", "delimiter", "must be one character"),
    ("delimiter", "','", "decimal", "cannot also be the delimiter"),
    ("decimal", "';'", "decimal", "must be '.' or ','"),
    ("header_line", "x", "header_line", "must be a whole number >= 1"),
    ("skip_lines_after_header", "x", "skip_lines_after_header", "must be a whole number >= 0"),
    ("skip_lines_after_header", "1e9", "skip_lines_after_header", "must be a whole number"),
    ("skip_lines_after_header", "-300", "skip_lines_after_header", "must be a whole number"),
])
def test_column_map_values_that_cannot_be_meant(cli, tmp_path, key, value, named, fragment):
    m, c = _rig2(tmp_path, map_change=lambda t: re.sub(rf"(?m)^{key}:.*$", f"{key}: {value}",
                                                       t))
    r = cli("hpt", "reduce", c, "--map", m, "-o", tmp_path / "o", "--no-plot")
    ln = _one_error(r, m)
    assert re.match(rf"error: {re.escape(str(m))}:\d+: {named}: ", ln) and fragment in ln


def test_skipping_past_the_end_of_a_column_map_file(cli, tmp_path):
    m, c = _rig2(tmp_path, map_change=lambda t: t.replace("skip_lines_after_header: 1",
                                                          "skip_lines_after_header: 1000000000"))
    r = cli("hpt", "reduce", c, "--map", m, "-o", tmp_path / "o", "--no-plot")
    assert "skip_lines_after_header" in _one_error(r, c, 2)


# ------------------------------------------------------------------ line ends, encodings
@pytest.mark.parametrize("end", [b"\r\r\n", b"\r"])
def test_optical_header_line_ends_never_drop_rows(tmp_path, end):
    from torlab.parsers.optical import read_optical

    src = SAMPLE / "optical" / "film_thickness_smooth.csv"
    raw = src.read_bytes()
    head, _, body = raw.partition(b"\ntime")
    f = tmp_path / "log.csv"
    f.write_bytes(head.replace(b"\n", end) + end + b"time" + body)
    rows = sum(1 for s in body.split(b"\n")[1:] if s.strip() and not s.startswith(b"#"))
    df, _ = read_optical(f)
    ref, _ = read_optical(src)
    assert len(df) == rows == len(ref)
    assert df.drop(columns="line").equals(ref.drop(columns="line"))


def test_utf16_files_read_like_their_utf8_originals(cli, tmp_path):
    """Excel's "Unicode text" is UTF-16 with a byte-order mark."""
    from torlab.parsers.hpt import read_hpt
    from torlab.parsers.pcs import read_pcs

    h = tmp_path / "h16.txt"
    h.write_text(HPT_LOG.read_text(encoding="utf-8").replace("\n", "\r\n"), encoding="utf-16")
    assert read_hpt(h)[0].drop(columns="line").equals(read_hpt(HPT_LOG)[0].drop(columns="line"))
    m = tmp_path / "m16.txt"
    m.write_text((SAMPLE / "mtm" / "mtm_TOR-A_5uL.txt").read_text(encoding="utf-8"),
                 encoding="utf-16")
    a, b = read_pcs(m)[0], read_pcs(SAMPLE / "mtm" / "mtm_TOR-A_5uL.txt")[0]
    assert a.equals(b)
    r = cli("reduce", h, m, "-o", tmp_path / "o", "--no-plot")  # detected as well
    assert r.exit_code == 0, r.output


def test_an_optical_header_line_over_64_kib(tmp_path):
    from torlab.parsers.optical import read_optical

    src = SAMPLE / "optical" / "stribeck_smooth.csv"
    lines = _lines(src)
    lines.insert(2, "# x_long: " + "n" * 70_000)
    f = tmp_path / "log.csv"
    f.write_text("\n".join(lines))
    df, meta = read_optical(f)
    assert len(meta.extra["x_long"]) == 70_000 and len(df) == len(read_optical(src)[0])


def test_a_cell_of_spaces_is_empty_where_allowed_and_named_elsewhere(cli, tmp_path):
    from torlab.parsers.optical import read_optical

    src = SAMPLE / "optical" / "stribeck_smooth.csv"
    lines = _lines(src)
    h = next(k for k, s in enumerate(lines) if s.startswith("time"))
    c = lines[h + 5].split(",")
    film = list(lines)
    film[h + 5] = ",".join([*c[:-1], "   "])
    f = tmp_path / "film.csv"
    f.write_text("\n".join(film))
    df, _ = read_optical(f)
    assert np.isnan(df["film_thickness_m"].iloc[4])
    load = list(lines)
    load[h + 5] = ",".join([*c[:4], "   ", *c[5:]])
    g = tmp_path / "load.csv"
    g.write_text("\n".join(load))
    r = cli("optical", "reduce", g, "-o", tmp_path / "o", "--no-plot")
    assert "column 'normal_load [N]': a cell of spaces" in _one_error(r, g, h + 6)


# ------------------------------------------------------------------ runs cut off or merged
def _crashed(tmp_path: Path) -> Path:
    lines = _lines(TT)
    end = next(k for k, s in enumerate(lines) if "completed normally" in s)
    f = tmp_path / "crashed.txt"
    f.write_text("\n".join(lines[: end - 300]), encoding="utf-8")
    return f


def test_a_time_test_cut_off_before_its_end_is_not_taken_for_a_finished_one(cli, tmp_path):
    f = _crashed(tmp_path)
    r = cli("mtm", "reduce", f, "--after-application", "-o", tmp_path / "o", "--no-plot")
    ln = _one_error(r, f)
    assert "the test stopped during this time test" in ln and "--duration" in ln
    # the part recorded, asked for: analysed, and the output says the test stopped
    r = cli("mtm", "reduce", f, "--after-application", "--duration", "10 min",
            "-o", tmp_path / "o2", "--no-plot")
    assert r.exit_code == 0, r.output
    assert "the test stopped during step 1" in r.output


def test_a_finished_export_says_nothing_of_the_kind(cli, tmp_path):
    r = cli("mtm", "reduce", TT, "--after-application", "-o", tmp_path / "o", "--no-plot")
    assert r.exit_code == 0 and "stopped" not in r.output


@pytest.mark.parametrize("src, command", [(EHD2, "optical"), (EHD2, "mtm"),
                                          (ROOT / "tests" / "data" / "pcs" / "etm_quirks.txt",
                                           "mtm")])
def test_two_runs_in_one_export_are_refused(cli, tmp_path, src, command):
    f = tmp_path / "two.txt"
    text = "\n".join(_lines(src))
    f.write_text(text + text, encoding="utf-8")
    r = cli(command, "reduce", f, "-o", tmp_path / "o", "--no-plot")
    n = len(text.split("\n"))
    assert "a second run starts here" in _one_error(r, f, n)


def test_zero_ball_load_in_some_rows_of_an_ehd2_export_is_said(cli, tmp_path):
    lines = _lines(EHD2)
    h = next(k for k, s in enumerate(lines) if "\t" in s and "Ball Load" in s)
    j = next(k for k, c in enumerate(lines[h].split("\t")) if c.startswith("Ball Load"))
    k = h + 1
    while lines[k].strip():
        c = lines[k].split("\t")
        c[j] = "0"
        lines[k] = "\t".join(c)
        k += 1
    f = tmp_path / "load0.txt"
    f.write_text("\n".join(lines), encoding="utf-8")
    r = cli("optical", "reduce", f, "-o", tmp_path / "o", "--no-plot")
    assert r.exit_code == 0
    assert f"Ball Load is zero or negative in 4 of 4 rows (lines {h + 2}-{k})" in r.output


# ------------------------------------------------------------------ numbers out of reach
@pytest.mark.parametrize("col", [0, 1, 2, 3, 4])
def test_an_hpt_column_near_the_largest_float(cli, tmp_path, col):
    lines = _lines(HPT_LOG)
    h = next(k for k, s in enumerate(lines) if s.startswith("time"))
    for k in range(h + 1, len(lines)):
        if lines[k]:
            c = lines[k].split(",")
            c[col] = f"{1e308 * (1 - k * 1e-6):.6e}"
            lines[k] = ",".join(c)
    f = tmp_path / "h.txt"
    f.write_text("\n".join(lines))
    r = cli("hpt", "reduce", f, "-o", tmp_path / "o", "--no-plot")
    name = lines[h].split(",")[col]
    assert f"column '{name}': " in _one_error(r, f, h + 2)
    assert "too large to be a measurement" in error_lines(r)[0]


@pytest.mark.parametrize("column", ["Ball Load (N)", "Traction Force (N)"])
def test_a_pcs_column_near_the_largest_float(cli, tmp_path, column):
    lines = _lines(SAMPLE / "mtm" / "mtm_TOR-A_5uL.txt")
    h = next(k for k, s in enumerate(lines) if s.startswith("Step Time"))
    head = lines[h].split("\t")
    j = head.index(column)
    for k in range(h + 1, len(lines)):
        c = lines[k].split("\t")
        if len(c) == len(head):
            c[j] = "1.0e308"
            lines[k] = "\t".join(c)
    f = tmp_path / "m.txt"
    f.write_text("\n".join(lines), encoding="utf-8")
    r = cli("mtm", "reduce", f, "-o", tmp_path / "o", "--no-plot")
    assert f"column '{column}': 1.0e308 is too large" in _one_error(r, f, h + 2)


@pytest.mark.parametrize("column, value, fragment", [
    ("Traction Coeff (-)", "9e99", "column 'Traction Coeff': 9e+99 is not possible for a "
     "traction coefficient"),
    ("Traction Coeff (-)", "10.5", "column 'Traction Coeff': 10.5 is not possible"),
    ("Ball Load (N)", "2e8", "Ball Load: 2e+08 N is not possible for a normal load (the "
     "largest possible is 1e+08 N)"),
    ("Rolling Speed (mm/s)", "2e6", "column 'Rolling Speed': 2000 m/s is not possible for a "
     "speed (at most 1000 m/s"),
    ("SRR (%)", "250", "column 'SRR': 250 % is not possible for a slide-roll ratio (at most "
     "200 %"),
    ("Traction Force (N)", "9e99", "column 'Traction Force': 9e+99 N is not possible for a "
     "force"),
    ("Lube RTD Temp (°C)", "2500", "lube_temperature_C: 2500 degC is above 2000 degC"),
])
def test_pcs_values_no_test_produces_are_named(cli, tmp_path, column, value, fragment):
    """Values inside the reader's bound (1e100 in SI units) that no test produces: a
    traction coefficient above 10, a load above 1e8 N, a speed above 1000 m/s, a
    slide-roll ratio beyond 200 %, a temperature above 2000 degC (was: exit 0 with a
    coefficient of 9e99 in the summary)."""
    lines = _lines(SAMPLE / "mtm" / "mtm_TOR-A_5uL.txt")
    h = next(k for k, s in enumerate(lines) if s.startswith("Step Time"))
    head = lines[h].split("\t")
    j = len(head) - 1 - head[::-1].index(column)  # the used column (the last of the name)
    c = lines[h + 3].split("\t")
    c[j] = value
    lines[h + 3] = "\t".join(c)
    f = tmp_path / "m.txt"
    f.write_text("\n".join(lines), encoding="utf-8")
    r = cli("mtm", "reduce", f, "-o", tmp_path / "o", "--no-plot")
    assert fragment in _one_error(r, f, h + 4)


@pytest.mark.parametrize("column, value, fragment", [
    ("ball_speed [m/s]", "2000", "ball_speed: 2000 m/s is not possible for a speed"),
    ("normal_load [N]", "2e8", "normal_load: 2e+08 N is not possible for a force"),
    ("friction_force [N]", "9e99", "friction_force: 9e+99 N is not possible for a force"),
    ("film_thickness [nm]", "2e6", "film_thickness: 2e+06 nm is not possible for a film "
     "thickness (at most 1e+06 nm"),
])
def test_optical_values_no_test_produces_are_named(cli, tmp_path, column, value, fragment):
    lines = _lines(SAMPLE / "optical" / "stribeck_smooth.csv")
    h = next(k for k, s in enumerate(lines) if s.startswith("time"))
    j = lines[h].split(",").index(column)
    c = lines[h + 3].split(",")
    c[j] = value
    lines[h + 3] = ",".join(c)
    f = tmp_path / "o.csv"
    f.write_text("\n".join(lines))
    r = cli("optical", "reduce", f, "-o", tmp_path / "o", "--no-plot")
    assert fragment in _one_error(r, f, h + 4)


def test_an_hpt_friction_coefficient_no_contact_has_is_an_error(cli, tmp_path):
    """An arm force of 9e99 N in the second half of the rows (inside the reader's bound):
    the friction coefficient over the window would be 7.6e96.  The error names the first
    line beyond the bound."""
    lines = _lines(HPT_LOG)
    h = next(k for k, s in enumerate(lines) if s.startswith("time"))
    j = lines[h].split(",").index("arm_force [N]")
    start = (h + 1 + len(lines)) // 2
    for k in range(start, len(lines)):
        if lines[k]:
            c = lines[k].split(",")
            c[j] = "9e99"
            lines[k] = ",".join(c)
    f = tmp_path / "h.txt"
    f.write_text("\n".join(lines))
    r = cli("hpt", "reduce", f, "-o", tmp_path / "o", "--no-plot")
    assert "the friction coefficient over the window is 7.58e+96, which no contact has" in \
        _one_error(r, f, start + 1)


def test_memory_running_out_while_reducing_names_the_log(monkeypatch):
    from torlab.errors import TorlabInputError
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce import hpt as rh

    df, meta = read_hpt(HPT_LOG)

    def no_memory(*a, **k):
        raise MemoryError

    monkeypatch.setattr(rh, "window_mean", no_memory)
    with pytest.raises(TorlabInputError, match="not enough memory to reduce this file") as e:
        rh.reduce_hpt(df, meta)
    assert e.value.path == str(HPT_LOG)


def test_pcs_numbers_in_exponent_notation_are_compared_at_their_precision(tmp_path):
    """A column written twice, once as 9.5E-02 (two figures) and once as 0.09538: the
    same values at the printed precision, so one column and no note."""
    from torlab.parsers.pcs import read_pcs

    out = []
    for s in _lines(MTM_QUIRKS):
        c = s.split("\t")
        if len(c) > 30 and c[0][:1].isdigit():
            v = float(c[1]) * 1.004
            c[1], c[34] = f"{v:.1E}", f"{v:.5f}"
            s = "\t".join(c)
        out.append(s)
    f = tmp_path / "exp.txt"
    f.write_text("\n".join(out), encoding="utf-8")
    df, meta = read_pcs(f)
    assert not [w for w in meta.warnings if "appears twice" in w]
    assert "traction_coefficient_col2" not in df
    assert np.allclose(df["traction_coefficient"].dropna(), np.round(
        df["traction_coefficient"].dropna(), 5))


# ------------------------------------------------------------------ scenes
def test_a_very_soft_roughness_is_full_film_at_every_speed(cli, tmp_path):
    """hardness 1e-6 MPa (inside the documented range): the asperities carry next to
    nothing, so no speed separates mixed from full film (was: math domain error)."""
    scene = tmp_path / "soft.yaml"
    scene.write_text((ROOT / "protocols" / "scenes" / "optical_paper_a_rough.yaml").read_text()
                     .replace("hardness: 6 GPa", "hardness: 1e-6 MPa"))
    r = cli("predict", "stribeck", scene, "--speed", "0.01:2:6", "--creepage", "0.02",
            "-o", tmp_path / "o", "--no-plot")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    tr = s["transitions"]["mixed_to_full_film"]
    assert tr["speed_m_s"] is None and "full film at every positive speed" in tr["notes"][0]
    assert set(pd.read_csv(tmp_path / "o" / "stribeck.csv")["regime"]) == {"full_film"}


def test_roelands_eta0_below_eta_inf_names_the_scene_line(cli, tmp_path):
    from torlab import scene
    from torlab.model import viscosity

    assert scene.ROELANDS_C == viscosity.ROELANDS_C
    scene = tmp_path / "roe.yaml"
    text = (ROOT / "protocols" / "scenes" / "mtm_paper_b.yaml").read_text()
    scene.write_text(text.replace("eta0: 65 mPa*s", "eta0: 0.01 mPa*s"))
    r = cli("predict", "stribeck", scene, "--speed", "0.01:2:6", "--creepage", "0.02",
            "-o", tmp_path / "o", "--no-plot")
    line = next(k for k, s in enumerate(text.split("\n"), 1) if s.startswith("lubricant:"))
    assert "eta0: the Roelands law (Z) needs eta0 above" in _one_error(r, scene, line)


def test_a_long_yaml_list_is_not_blamed_on_aliases(tmp_path):
    from torlab.errors import TorlabInputError
    from torlab.yamlio import load_yaml_text

    with pytest.raises(TorlabInputError, match="more than 100000 values in one YAML file"):
        load_yaml_text("x: [" + "1, " * 100_001 + "1]\n", "a.yaml")


# ------------------------------------------------------------------ figures
def test_characters_the_font_lacks_are_one_warning(tmp_path):
    from torlab.errors import TorlabWarning
    from torlab.reports.plotting import subplots
    from torlab.reports.render import render

    fig, ax = subplots()
    ax.set_title("润滑油 OFM1")
    with pytest.warns(TorlabWarning) as got:
        render(fig, "png")
    msgs = [str(w.message) for w in got]
    assert len(msgs) == 1 and "drawn as boxes: 润滑油" in msgs[0]


def test_an_unwritable_home_prints_nothing_from_matplotlib(tmp_path):
    env = {"HOME": "/proc/no-such-home", "PATH": "/usr/bin:/bin",
           "TMPDIR": str(tmp_path)}
    r = subprocess.run([sys.executable, "-c", "import torlab.reports, os\n"
                        "from torlab.reports.plotting import subplots\nsubplots()\n"
                        "print(os.environ['MPLCONFIGDIR'])"],
                       env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stderr == ""
    d = Path(r.stdout.strip())
    assert d.parent == tmp_path and (d.stat().st_mode & 0o777) == 0o700
    shutil.rmtree(d, ignore_errors=True)


@pytest.mark.parametrize("env", ["XDG_CONFIG_HOME", "XDG_CACHE_HOME"])
def test_a_relative_xdg_folder_makes_nothing_in_the_working_folder(tmp_path, env):
    """A relative XDG_CONFIG_HOME would have matplotlib make relcfg/matplotlib wherever
    torlab runs; torlab gives it its private folder instead."""
    work = tmp_path / "work"
    work.mkdir()
    e = {"HOME": str(tmp_path / "home"), "PATH": "/usr/bin:/bin", "TMPDIR": str(tmp_path),
         env: "relcfg"}
    r = subprocess.run([sys.executable, "-c", "import torlab.reports, os\n"
                        "from torlab.reports.plotting import subplots\nsubplots()\n"
                        "print(os.environ['MPLCONFIGDIR'])"],
                       env=e, cwd=work, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stderr == ""
    assert list(work.iterdir()) == []
    assert Path(r.stdout.strip()).parent == tmp_path
    shutil.rmtree(r.stdout.strip(), ignore_errors=True)


# ------------------------------------------------------------------ time tests for the fit
def test_time_test_rows_without_load_are_dropped_and_said(tmp_path):
    from torlab.errors import TorlabInputError
    from torlab.reduce.time_test import read_time_test

    lines = _lines(TT)
    h = next(k for k, s in enumerate(lines) if s.startswith("Step Time"))
    j = lines[h].split("\t").index("Ball Load (N)")

    def zero(rows: range) -> Path:
        out = list(lines)
        for k in rows:
            c = out[k].split("\t")
            c[j] = "0"
            out[k] = "\t".join(c)
        f = tmp_path / f"load0_{len(rows)}.txt"
        f.write_text("\n".join(out), encoding="utf-8")
        return f

    whole = read_time_test(TT, density=930.0)
    some = read_time_test(zero(range(h + 1, h + 40)), density=930.0)
    assert some.t.size == whole.t.size - 39 and (some.load > 0).all()
    assert f"39 samples with a load of zero or less (lines {h + 2}-{h + 40}) dropped" in \
        " ".join(some.notes)
    n_rows = next(k for k in range(h + 1, len(lines)) if not lines[k].strip())
    with pytest.raises(TorlabInputError, match="zero or negative in every sample"):
        read_time_test(zero(range(h + 1, n_rows)), density=930.0)


def test_a_time_test_cut_off_is_fitted_as_recorded_and_says_so(tmp_path):
    from torlab.reduce.time_test import read_time_test

    tt = read_time_test(_crashed(tmp_path), density=930.0)
    whole = read_time_test(TT, density=930.0)
    assert tt.t[-1] < whole.t[-1] and np.array_equal(tt.t, whole.t[: tt.t.size])
    assert any("the test stopped during step 1" in n for n in tt.notes)
