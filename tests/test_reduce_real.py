"""``torlab reduce`` on every real PCS export, with detection, against numbers read off the files.

The files are the MIT-licensed PCS exports beside the repository
(found by ``conftest.real_pcs_file``; skipped where absent).  Every expected number
below was read from the files by hand (awk over the columns named), not
produced by torlab.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from conftest import DATA, REAL_PCS, error_lines, real_pcs_file, sha


@pytest.fixture(scope="module")
def reduced(tmp_path_factory):
    """``torlab reduce FOLDER`` of the real files (the folder as given, no --as)."""
    from typer.testing import CliRunner

    from torlab.cli import app

    for name in ("demo_3.txt", "demo_5.txt", "demo_12.txt", "ETM_slim_mapper.txt"):
        real_pcs_file(name)
    out = tmp_path_factory.mktemp("real") / "out"
    before = {p: sha(p) for p in REAL_PCS.iterdir()}
    r = CliRunner().invoke(app, ["reduce", str(REAL_PCS), "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert {p: sha(p) for p in REAL_PCS.iterdir()} == before  # inputs untouched
    return out, r.output


@pytest.mark.realdata
@pytest.mark.slow  # openpyxl writes the 3 MB mapper's tables in about 20 s
def test_folder_with_xlsx_writes_every_table_as_a_sheet(tmp_path):
    from typer.testing import CliRunner

    from torlab.cli import app

    for name in ("demo_3.txt", "demo_5.txt", "ETM_slim_mapper.txt"):
        real_pcs_file(name)
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["reduce", str(REAL_PCS), "-o", str(out), "--xlsx"])
    assert r.exit_code == 0, r.output
    assert (out / "tables.xlsx").stat().st_size > 10_000


@pytest.mark.realdata
def test_folder_detects_each_file_and_leaves_out_the_licence(reduced):
    out, text = reduced
    for name, first in (("demo_3.txt", "EHD261 Test Data File"),
                        ("demo_5.txt", "MTM311 Test Data File"),
                        ("demo_12.txt", "EHD261 Test Data File"),
                        ("ETM_slim_mapper.txt", "Step 1 started at 10/05/2019")):
        assert f"{name}: read as pcs" in text and first in text, name
    assert "left out LICENSE.txt" in " ".join(text.split())
    s = pd.read_csv(out / "summary.csv")
    assert s.groupby("file")["step"].count().to_dict() == {
        "ETM_slim_mapper.txt": 501, "demo_3.txt": 2, "demo_5.txt": 1,
        "demo_12.txt": 3}  # its three FILM steps (40, 60, 80 degC)


@pytest.mark.realdata
def test_mtm_demo5_plain_timed_run(reduced):
    out, text = reduced
    st = pd.read_csv(out / "demo_5_steps.csv").iloc[0]
    # 'Step type BOD_TIMED', 'Step duration 02:46:40': 1000 rows at 10 s
    assert (st["step_type"], st["step_type_raw"], st["geometry"]) == \
        ("timed", "BOD_TIMED", "ball on disc")
    assert st["n_rows"] == 1000 and st["duration_s"] == 10000.0
    assert st["x_column"] == "step_time_s"  # the header's first cell, 'Step Time (s)'
    # awk over 'Traction Coeff (-)' (column 2, lines 15-1014) and 'Ball Load (N)' (column 12)
    assert st["traction_coefficient_mean"] == pytest.approx(0.113105, abs=1e-6)
    assert st["traction_coefficient_min"] == 0.0758 and st["traction_coefficient_max"] == 0.1319
    assert st["ball_load_N"] == pytest.approx(20.0002, abs=1e-4)
    timed = pd.read_csv(out / "demo_5_timed.csv")
    assert len(timed) == 1000
    assert timed[["step_time_s", "traction_coefficient"]].iloc[0].tolist() == [10, 0.0955]
    assert timed[["step_time_s", "traction_coefficient"]].iloc[-1].tolist() == [10000, 0.1241]
    # a plain 3-hour run: no application is marked, so no after-application analysis
    assert not (out / "time_tests.csv").exists()
    assert "no application marked" in text


@pytest.mark.realdata
def test_ehd2_demo3_film_steps_labelled_by_temperature(reduced):
    out, output = reduced
    st = pd.read_csv(out / "demo_3_steps.csv")
    # mean of 'Lube Temp' (column 10) over lines 23-43 and 61-81: 40.1762 and 100.7238 °C
    assert st["label"].tolist() == ["40.2 °C", "100.7 °C"]
    assert st["lube_temperature_C"].tolist() == pytest.approx([40.1762, 100.7238], abs=1e-4)
    assert st["step_type"].tolist() == ["film", "film"] and st["n_rows"].tolist() == [21, 21]
    film = pd.read_csv(out / "demo_3_film.csv")
    h = {lab: g["film_thickness_m"].to_numpy() for lab, g in film.groupby("label", sort=False)}
    assert h["40.2 °C"][[0, -1]] == pytest.approx([24.4e-9, 540.2e-9])
    assert h["100.7 °C"][[0, -1]] == pytest.approx([4.8e-9, 123.6e-9])
    # the film steps log only 'Traction Force 1 (N)' (column 22): 0.7975 N at 20.025 N and
    # SRR 0.000 in every row: the ratio is the load cell's offset, kept as the two columns,
    # not as a traction coefficient (none in the table, a note says why)
    assert film[["traction_force_1_N", "ball_load_N"]].iloc[0].tolist() == pytest.approx(
        [0.7975, 20.025])
    assert "traction_coefficient" not in film
    assert "traction_coefficient_mean" not in st
    text = " ".join(output.split())
    assert ("film step(s) 2, 5: Traction Force 1 / Ball Load is 0.036-0.044 at pure rolling"
            in text and "load cell's offset, not a traction coefficient" in text)
    assert (out / "demo_3_film.png").stat().st_size > 10_000


@pytest.mark.realdata
def test_etm_traction_steps_from_their_own_header(reduced):
    out, _ = reduced
    st = pd.read_csv(out / "ETM_slim_mapper_steps.csv")
    assert st["step_type"].value_counts().to_dict() == {"traction": 500, "timed": 1}
    assert set(st.loc[st["step_type"] == "traction", "x_column"]) == {"srr"}  # 'SRR (%)' first
    assert set(st.loc[st["step_type"] == "traction", "n_rows"]) == {41}
    tr = pd.read_csv(out / "ETM_slim_mapper_traction.csv")
    assert len(tr) == 20500 and tr["step"].nunique() == 500
    # step 3's first row: SRR 18.554 %, Traction Coeff 0.0596, Ball Load 1647.866 N, force +98.2
    first = tr.iloc[0]
    assert (first["step"], first["srr"], first["traction_coefficient"], first["ball_load_N"]) == \
        pytest.approx((3, 0.18554, 0.0596, 1647.866))
    # the 17 Mapper steps have no data rows: nothing to reduce, no table
    assert not (out / "ETM_slim_mapper_mapper.csv").exists()


@pytest.mark.realdata
def test_after_application_when_asked(tmp_path, cli):
    f = real_pcs_file("demo_5.txt")
    r = cli("reduce", f, "-o", tmp_path / "o", "--after-application")
    assert r.exit_code == 0, r.output
    tt = pd.read_csv(tmp_path / "o" / "time_tests.csv")
    assert len(tt) == 1 and tt["step"].iloc[0] == 1
    assert np.isfinite(tt["minimum"].iloc[0])


@pytest.mark.realdata
def test_as_overrides_detection_and_bad_instrument_is_one_line(tmp_path, cli):
    f = real_pcs_file("demo_3.txt")
    r = cli("reduce", f, "--as", "optical", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    pts = pd.read_csv(tmp_path / "o" / "demo_3_points.csv")
    assert len(pts) == 42  # the optical reduction: each EHD2 film row is a condition
    r = cli("reduce", f, "--as", "mtn", "-o", tmp_path / "p")
    assert r.exit_code == 2 and len(error_lines(r)) == 1
    assert "did you mean 'mtm'" in error_lines(r)[0]


@pytest.mark.realdata
def test_glob_pattern_expanded_by_torlab(tmp_path, cli):
    for name in ("demo_3.txt", "demo_5.txt", "demo_12.txt"):
        real_pcs_file(name)
    r = cli("reduce", str(REAL_PCS / "demo_*.txt"), "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    assert set(pd.read_csv(tmp_path / "o" / "summary.csv")["file"]) == {"demo_3.txt", "demo_5.txt",
                                                                       "demo_12.txt"}


# --- step kinds the real files lack, on the hand-made quirk file -------------------------------
@pytest.mark.parametrize("raw, kind, geometry", [("POD_TIMED", "timed", "pin on disc"),
                                                  ("WOBBLE_SWEEP", "wobble_sweep", "")])
def test_pin_on_disc_and_unknown_step_kinds_reduced(raw, kind, geometry, tmp_path, cli):
    text = (DATA / "pcs" / "mtm_quirks.txt").read_bytes().decode("utf-8-sig")
    p = tmp_path / "variant.txt"
    p.write_text(text.replace("Step type\tBOD_STRIBECK", f"Step type\t{raw}"), encoding="utf-8")
    r = cli("reduce", p, "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    st = pd.read_csv(tmp_path / "o" / "variant_steps.csv")
    row = st[st["step"] == 3].iloc[0]
    assert (row["step_type"], row["step_type_raw"]) == (kind, raw)
    assert (row["geometry"] if isinstance(row["geometry"], str) else "") == geometry
    # the step's own header starts with 'Rolling Speed (mm/s)': its curve's x column
    assert row["x_column"] == "rolling_speed_m_s"
    curve = pd.read_csv(tmp_path / "o" / f"variant_{kind}.csv")
    assert (curve["step"] == 3).sum() == 5
    if kind != "timed":
        assert "not one torlab knows" in " ".join(r.output.split())


# --- an EHD2 traction file through the protocol path (it used to be refused there) -------------
def _ehd2_traction(path):
    """A hand-made EHD2 export: one FILM step at 100 mm/s with SRR -5 ... +5 %, and
    mu = 0.05 tanh(SRR / 2 %) in 'Traction Force 1' at 20 N."""
    import math

    lines = (DATA / "pcs" / "ehd2_quirks.txt").read_bytes().decode("cp1252").split("\r\n")
    i = next(k for k, s in enumerate(lines) if s.startswith("20.2\t24.4"))
    tmpl = lines[i].split("\t")
    rows = []
    for k, srr in enumerate((-5.0, -2.0, -1.0, 1.0, 2.0, 5.0)):
        f = list(tmpl)
        ub, ud = 100.0 * (1 + srr / 200), 100.0 * (1 - srr / 200)
        f[0], f[8], f[13], f[15], f[17] = "100.0", str(10 + 8 * k), f"{ub:.2f}", f"{ud:.2f}", \
            "100.00"
        f[18], f[19] = f"{ub - ud:.2f}", f"{srr:.3f}"
        f[21] = f"{20.0 * 0.05 * math.tanh(srr / 2.0):.4f}"
        rows.append("\t".join(f))
    j = i
    while lines[j].strip():
        j += 1
    lines[i:j] = rows
    path.write_bytes("\r\n".join(lines).encode("cp1252"))
    return path


def test_protocol_takes_an_ehd2_traction_file_folded(tmp_path):
    from torlab.protocols.runner import run_protocol

    f = _ehd2_traction(tmp_path / "ehd2_traction.txt")
    p = tmp_path / "p.yaml"
    p.write_text(f"""\
version: 1
name: ehd2_traction
data:
  optical:
    files: [{f}]
reports:
  traction:
    curves:
      - label: EHD2 traction
        measured: {f}
""")
    res = run_protocol(p, tmp_path / "out")
    assert res.summary["data"]["optical"]["ehd2_traction.txt"]["test"] == "traction"
    assert res.summary["data"]["optical"]["ehd2_traction.txt"]["symmetric"] == "yes"
    curve = next(iter(res.summary["reports"]["traction"]["curves"].values()))
    # folded: |SRR| 1, 2, 5 % with mu = 0.05 tanh(SRR / 2 %) (the file's own numbers)
    assert curve["mu_max"] == pytest.approx(0.05 * np.tanh(2.5), abs=1e-4)
