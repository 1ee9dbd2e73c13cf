"""PCS Instruments exports (MTM, ETM, EHD2): hand-made quirk files and the real exports."""

from __future__ import annotations

import io
from datetime import datetime

import numpy as np
import pytest
from conftest import DATA, ROOT, real_pcs_file

from torlab.errors import TorlabInputError
from torlab.parsers.pcs import normalise_step_type, read_etm, read_mtm, read_pcs, step_table

MTM = DATA / "pcs" / "mtm_quirks.txt"
ETM = DATA / "pcs" / "etm_quirks.txt"
EHD = DATA / "pcs" / "ehd2_quirks.txt"


# --- step types as each software generation spells them ----------------------------------------
@pytest.mark.parametrize("raw, norm", [
    ("BOD_TIMED", "timed"), ("BodTimed", "timed"), ("Timed", "timed"), ("Traction", "traction"),
    ("TRACTION", "traction"), ("BOD_STRIBECK", "stribeck"), ("Stribeck", "stribeck"),
    ("FILM", "film"), ("FILM_ZERO", "film_zero"), ("ZERO_CHECK", "zero_check"),
    ("HEATING", "heating"), ("Mapper", "mapper"), ("Suspend", "suspend"), ("Wobble", "other"),
])
def test_step_type_spellings(raw, norm):
    assert normalise_step_type(raw) == norm


# --- hand-made MTM file: BOM, CRLF, °C in UTF-8, duplicated and empty cells ----------------------
def test_mtm_quirk_file_header_and_steps():
    assert MTM.read_bytes()[:3] == b"\xef\xbb\xbf" and b"\r\n" in MTM.read_bytes()
    _df, meta = read_pcs(MTM)
    assert meta.instrument == "MTM" and meta.instrument_model == "MTM311"
    assert meta.detected_from == "first line"
    assert meta.lubricant == "test oil"
    assert meta.started_at == datetime(2021, 3, 5, 14, 7)
    assert meta.completed_at == datetime(2021, 3, 5, 14, 12)
    assert meta.completed_normally is True
    assert meta.steps_in_profile == 3 and meta.steps_completed == 3
    assert [(s.number, s.type_raw, s.type) for s in meta.steps] == [
        (1, "BOD_TIMED", "timed"), (2, "Suspend", "suspend"), (3, "BOD_STRIBECK", "stribeck")]
    s1, s2, s3 = meta.steps
    assert s1.started_at == datetime(2021, 3, 5, 14, 8, 30)
    assert s1.duration_s == 60.0
    assert s1.description == "Timed 1 min"
    # key<TAB>value with the unit in the key, and key = value unit, both in SI
    assert s1.metadata["zero_traction_force_N"] == pytest.approx(0.12)
    assert s1.metadata["disc_track_radius_m"] == pytest.approx(0.021232)
    assert s1.metadata["ball_load_N"] == pytest.approx(20.0)
    assert (s1.n_rows, s2.n_rows, s3.n_rows) == (6, 0, 5)
    assert not s2.has_data and s2.description == "Wait for operator"
    assert (s1.first_line, s1.header_line, s1.last_line) == (11, 16, 22)
    assert meta.warnings == []


def test_mtm_quirk_file_columns_units_and_duplicates():
    df, meta = read_pcs(MTM)
    # the duplicated 'Step Time (s)' and the empty cells leave one column each
    assert list(df.columns).count("step_time_s") == 1
    assert not any(c.startswith("unnamed") for c in df.columns)
    t1 = step_table(df, meta, 1)
    assert t1["step_time_s"].tolist() == [10, 20, 30, 40, 50, 60]
    assert t1["line"].tolist() == list(range(17, 23))
    # units: % -> fraction, mm/s -> m/s, um -> m, °C as written
    assert t1["srr"].tolist() == pytest.approx([0.02] * 6)
    assert t1["rolling_speed_m_s"].tolist() == pytest.approx([1.0] * 6)
    assert t1["ball_speed_1_m_s"].tolist() == pytest.approx([0.99] * 6)
    assert t1["wear_m"].tolist() == pytest.approx([-12e-6] * 6)
    assert t1["lube_temperature_C"].tolist() == pytest.approx([41.0] * 6)
    assert t1["traction_coefficient"].tolist() == pytest.approx([0.1, 0.09, 0.08, 0.085, 0.095, 0.1])
    # coefficient = force / load (20 N): the file's convention is consistent
    assert (t1["traction_force_N"] / t1["ball_load_N"]).tolist() == pytest.approx(
        t1["traction_coefficient"].tolist())
    assert meta.coefficient_convention == "consistent"
    # Stribeck step: the rounded plot column (1999.97 written as 2000.0) agrees with the data
    # block to its precision and is dropped; the precise value is kept
    t3 = step_table(df, meta, 3)
    assert t3["rolling_speed_m_s"].tolist() == pytest.approx([1.99997, 1.00004, 0.49996, 0.20002,
                                                              0.09998])
    assert t3["step_type"].unique().tolist() == ["stribeck"]
    assert "pin_load_N" not in df  # never logged


def test_etm_quirk_file_no_header_lf_degc_and_coefficient_magnitude():
    text = ETM.read_bytes()
    assert b"\r" not in text and text.startswith(b"Step 1 started at")
    df, meta = read_pcs(ETM)
    assert meta.instrument == "ETM" and meta.instrument_model == ""
    assert [s.type for s in meta.steps] == ["mapper", "traction", "traction", "timed"]
    assert meta.steps[0].metadata["camera_window_load_N"] == pytest.approx(198.652)
    assert meta.steps[3].duration_s == 3.0
    tr = df[df["step_type"] == "traction"]
    assert len(tr) == 10 and sorted(tr["step"].unique()) == [2, 3]
    # Traction Coeff is |F|/W in this export while the force is signed
    assert meta.coefficient_convention == "magnitude"
    assert (df["traction_coefficient"] >= 0).all()
    row = tr[tr["traction_force_N"] < 0].iloc[0]
    assert row["traction_coefficient"] == pytest.approx(0.005)
    assert row["traction_coefficient_signed"] == pytest.approx(-0.005)
    assert row["srr"] == pytest.approx(-0.0004)
    assert any("|Traction Force|" in w for w in meta.warnings)
    # degC read like °C
    assert tr["lube_temperature_C"].tolist() == pytest.approx([39.5] * 10)
    assert tr["ball_load_N"].tolist() == pytest.approx([1600.0] * 10)


def test_ehd2_quirk_file_cp1252_text_column_and_non_data_steps():
    raw = EHD.read_bytes()
    assert b"\xb0C" in raw and b"\r\n" in raw  # Windows-1252 degree sign, CRLF
    df, meta = read_pcs(EHD)
    assert meta.instrument == "EHD2"
    assert meta.disc_track_radius_m == pytest.approx(0.036273)  # header value in mm, no unit
    assert [s.type for s in meta.steps] == ["film_zero", "film", "heating", "zero_check"]
    assert [s.description for s in meta.steps] == ["Spacer zero", "Film 40", "Heat", "Check"]
    fz = meta.steps[0].metadata
    assert fz["ball_load_N"] == pytest.approx(19.9)
    assert fz["trigger_position"] == 233
    assert fz["peak_wavelength_m"] == pytest.approx(506.7e-9)
    assert fz["spacer_thickness_m"] == pytest.approx(519.7e-9)
    heat = meta.steps[2]
    assert heat.metadata["target_temperature_C"] == 100.0
    assert heat.metadata["control_probe"] == "pot"
    assert heat.duration_s == 600.0
    assert meta.steps[3].metadata["film_thickness_m"] == pytest.approx(2.3e-9)
    assert meta.steps[3].metadata["lubricant_refractive_index"] == pytest.approx(1.4)
    film = step_table(df, meta, 2)
    assert film["film_thickness_m"].tolist() == pytest.approx([24.4e-9, 52.1e-9, 82.2e-9, 136.5e-9])
    assert film["rolling_speed_m_s"].tolist() == pytest.approx([0.02021, 0.05025, 0.10033, 0.19977])
    assert film["lube_temperature_C"].tolist() == pytest.approx([40.4] * 4)
    assert film["image_file_name"].tolist() == ["img001.bmp", "img002.bmp", "img003.bmp", "img004.bmp"]
    assert "traction_coefficient" not in df  # the EHD2 logs only Traction Force 1 here


def test_detection_override_and_unknown_first_line():
    text = MTM.read_text(encoding="utf-8-sig").replace("MTM311 Test Data File", "Export v2", 1)
    with pytest.raises(TorlabInputError) as ei:
        read_pcs(io.StringIO(text), name="odd.txt")
    assert ei.value.line == 1 and "not a PCS Instruments export" in str(ei.value)
    df, meta = read_pcs(io.StringIO(text), name="odd.txt", instrument="MTM")
    assert meta.instrument == "MTM" and meta.detected_from == "override" and len(df) == 11
    # per-instrument names; an override that contradicts the first line is noted
    _, m2 = read_etm(MTM)
    assert m2.instrument == "ETM" and any("first line says MTM" in w for w in m2.warnings)
    assert read_mtm(MTM)[1].instrument == "MTM"
    with pytest.raises(TorlabInputError, match="unknown instrument"):
        read_pcs(MTM, instrument="HFRR")


def test_documented_example_parses():
    doc = (ROOT / "docs" / "formats" / "pcs.md").read_text(encoding="utf-8")
    block = doc.split("```text\n", 1)[1].split("```", 1)[0].replace("<TAB>", "\t")
    df, meta = read_pcs(io.StringIO(block), name="pcs.md example")
    assert meta.instrument == "MTM" and [s.type for s in meta.steps] == ["timed", "suspend"]
    assert df["traction_coefficient"].tolist() == pytest.approx([0.1, 0.09, 0.08])
    assert df["traction_force_N"].tolist() == pytest.approx([2.0, 1.8, 1.6])
    assert meta.steps[0].metadata["ball_load_N"] == 20.0


# --- errors: one line naming file and line ------------------------------------------------------
def _mtm_lines() -> list[str]:
    return MTM.read_bytes().decode("utf-8-sig").split("\r\n")


@pytest.mark.parametrize("mutate, line, fragment", [
    (lambda L: L.__setitem__(18, L[18].rsplit("\t", 20)[0]), 19, "truncated row"),
    (lambda L: L.__setitem__(19, L[19].replace("\t20.000\t", "\t2O.000\t", 1)), 20, "not a number"),
    (lambda L: L.__setitem__(19, L[19].replace("\t20.000\t", "\tnan\t", 1)), 20, "not a finite number"),
    (lambda L: L.__setitem__(15, L[15].replace("Ball Load (N)", "Ball Load (Nx)")), 16, "unknown unit"),
    (lambda L: L.__setitem__(15, L[15].replace("Ball Load (N)", "Ball Load (mm)")), 16, "not a force"),
    (lambda L: L.__setitem__(19, ""), 20, "blank line between data rows"),
    (lambda L: L.__setitem__(11, "Step tipe\tBOD_TIMED"), 12, "Step type"),
    (lambda L: L.__setitem__(10, "Step 1 started at 31/02/2021 14:08:30"), 11, "not a valid date"),
    (lambda L: L.__setitem__(11, L[11].replace("00:01:00", "1 minute")), 12, "not a duration"),
])
def test_bad_input_names_file_and_line(mutate, line, fragment, tmp_path):
    lines = _mtm_lines()
    mutate(lines)
    p = tmp_path / "bad.txt"
    p.write_bytes("\r\n".join(lines).encode("utf-8"))
    with pytest.raises(TorlabInputError) as ei:
        read_pcs(p)
    assert ei.value.path == str(p)
    assert ei.value.line == line, str(ei.value)
    assert fragment in str(ei.value)


def test_empty_and_missing_files(tmp_path):
    p = tmp_path / "empty.txt"
    p.write_text("")
    with pytest.raises(TorlabInputError, match="empty"):
        read_pcs(p)
    with pytest.raises(TorlabInputError, match="not found"):
        read_pcs(tmp_path / "nope.txt")


# --- real exports (skipped where the real files are absent) -------------------------------------------
@pytest.mark.realdata
def test_real_mtm_demo5():
    df, meta = read_pcs(real_pcs_file("demo_5.txt"))
    assert meta.instrument == "MTM" and meta.instrument_model == "MTM311"
    assert len(meta.steps) == 1 and meta.steps[0].type_raw == "BOD_TIMED"
    st = meta.steps[0]
    assert st.type == "timed" and st.n_rows == 1000 and len(df) == 1000
    assert st.started_at == datetime(2016, 8, 19, 9, 48, 51)
    assert st.duration_s == 2 * 3600 + 46 * 60 + 40  # "Step duration 02:46:40"
    assert st.metadata["disc_track_radius_m"] == pytest.approx(0.021232)
    assert st.metadata["zero_traction_force_N"] == pytest.approx(0.1467)
    assert meta.started_at == datetime(2016, 8, 19, 9, 39, 32)
    assert meta.completed_normally
    # facts read off the file with awk: step time 10 ... 10000 s every 10 s; load 19.857-20.240 N;
    # lube temperature 97.7-102.0 °C; first and last coefficient 0.0955 and 0.1241
    t = df["step_time_s"].to_numpy()
    assert t[0] == 10 and t[-1] == 10000 and np.all(np.diff(t) == 10)
    assert df["ball_load_N"].min() == pytest.approx(19.857)
    assert df["ball_load_N"].max() == pytest.approx(20.240)
    assert df["lube_temperature_C"].min() == pytest.approx(97.7)
    assert df["lube_temperature_C"].max() == pytest.approx(102.0)
    assert df["traction_coefficient"].iloc[[0, -1]].tolist() == [0.0955, 0.1241]
    assert df["line"].iloc[0] == 15
    # the coefficient is the force over the load, to its printed 4 decimals
    assert np.max(np.abs(df["traction_force_N"] / df["ball_load_N"] - df["traction_coefficient"])) < 6e-5
    assert meta.coefficient_convention == "consistent"
    # the speeds without a unit are mm/s: rolling speed = mean of ball and disc speed
    mean = 0.5 * (df["ball_speed_1_m_s"] + df["disc_speed_1_m_s"])
    assert np.max(np.abs(mean - df["rolling_speed_m_s"])) < 1e-4


@pytest.mark.realdata
def test_real_ehd2_demo3():
    df, meta = read_pcs(real_pcs_file("demo_3.txt"))
    assert meta.instrument == "EHD2"
    assert [s.type_raw for s in meta.steps] == ["FILM_ZERO", "FILM", "ZERO_CHECK", "HEATING", "FILM",
                                                "ZERO_CHECK", "ZERO_CHECK"]
    assert meta.disc_track_radius_m == pytest.approx(0.036273)
    assert meta.steps[0].metadata["spacer_thickness_m"] == pytest.approx(519.7e-9)
    assert meta.steps[3].metadata["target_temperature_C"] == 100.0
    films = meta.data_steps("film")
    assert [s.number for s in films] == [2, 5] and [s.n_rows for s in films] == [21, 21]
    f40, f100 = (step_table(df, meta, n) for n in (2, 5))
    # README: film steps at about 40 and 100 °C
    assert f40["lube_temperature_C"].mean() == pytest.approx(40.2, abs=0.3)
    assert f100["lube_temperature_C"].mean() == pytest.approx(100.7, abs=0.3)
    for f in (f40, f100):
        u = f["rolling_speed_m_s"].to_numpy()
        h = f["film_thickness_m"].to_numpy()
        assert np.all(np.diff(u) > 0)
        assert 0.019 < u[0] < 0.021 and 1.99 < u[-1] < 2.01
        assert h[-1] > 10 * h[0]  # film rises with speed: 24.4 -> 540.2 nm, 4.8 -> 123.6 nm
        assert np.corrcoef(np.log(u), np.log(h))[0, 1] > 0.98
    # thinner at 100 °C than at 40 °C at every speed
    assert np.all(f100["film_thickness_m"].to_numpy() < f40["film_thickness_m"].to_numpy())
    assert f40["film_thickness_m"].iloc[0] == pytest.approx(24.4e-9)
    assert f100["film_thickness_m"].iloc[-1] == pytest.approx(123.6e-9)


@pytest.mark.realdata
def test_real_etm_traction_steps():
    df, meta = read_pcs(real_pcs_file("ETM_slim_mapper.txt"))
    assert meta.instrument == "ETM" and meta.detected_from == "first line"
    types = [s.type for s in meta.steps]
    assert types.count("traction") == 500 and types.count("mapper") == 17
    assert types.count("timed") == 1 and len(types) == 518
    assert {s.type_raw for s in meta.steps} == {"Traction", "Mapper", "BodTimed"}
    tr = df[df["step_type"] == "traction"]
    assert len(tr) == 20500  # 41 rows per traction step, counted with awk
    assert {s.n_rows for s in meta.data_steps("traction")} == {41}
    # about 1647 N and 25 mm/s (README); load range 1643.642-1651.563 N from awk
    assert tr["ball_load_N"].min() == pytest.approx(1643.642)
    assert tr["ball_load_N"].max() == pytest.approx(1651.563)
    assert 0.0245 < tr["rolling_speed_m_s"].median() < 0.0255
    assert tr["srr"].max() > 0.19 and tr["srr"].min() < 0.01  # SRR 0-20 %
    assert meta.coefficient_convention == "magnitude"
    assert (tr["traction_coefficient"] >= 0).all()
    neg = tr["traction_force_N"] < 0
    assert neg.any() and (tr.loc[neg, "traction_coefficient_signed"] <= 0).all()
    assert meta.steps[1].metadata["zero_traction_force_N"] == pytest.approx(0.6225)
    assert meta.completed_at == datetime(2019, 5, 10, 0, 0, 2)
