"""TA Instruments TRIOS text exports: one module and one registry line.

References independent of the code: the hand-made export (tests/data/trios/hand.txt) is
written from closed forms (a Newtonian liquid of 0.05 Pa s; eta = 0.05 exp(-0.02 (T -
25 degC)) Pa s) in TRIOS's units (dyne/cm², Pa.s, °C; a step in Pa, mPa.s, min and K);
the real export's own columns check its unit conversion (its viscosity is the
instrument's stress / shear rate, so a wrong dyne/cm² factor shows as a factor of ten).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from conftest import DATA, ROOT

HAND = DATA / "trios" / "hand.txt"
REAL = ROOT.parent / "shared" / "real-data" / "rheometer" / "trios_demo.txt"
needs_real = pytest.mark.skipif(not REAL.is_file(), reason="the real TRIOS export is absent")


def _read(path):
    from torlab.instruments.trios import read

    return read(path)


def test_hand_made_export_read_in_si_units():
    df, meta = _read(HAND)
    assert [s.kind for s in meta.steps] == ["flow sweep", "temperature ramp", "peak hold"]
    s1 = df[df["step"] == 1]
    # 1 dyne/cm² = 0.1 Pa: the stress of 0.05 Pa s at 10 ... 200 1/s
    np.testing.assert_allclose(s1["shear_stress_Pa"], 0.05 * s1["shear_rate_1_s"], rtol=1e-12)
    np.testing.assert_allclose(s1["normal_stress_Pa"], [-10, -20, -30, -40, -50], rtol=1e-12)
    s3 = df[df["step"] == 3]  # Pa, mPa.s, min, K
    np.testing.assert_allclose(s3["viscosity_Pa_s"], 0.05, rtol=1e-12)
    np.testing.assert_allclose(s3["step_time_s"], [60, 120, 180, 240], rtol=1e-12)
    np.testing.assert_allclose(s3["temperature_C"], 25.0, atol=1e-9)
    assert s3["normal_stress_Pa"].isna().all()  # not exported in that step
    assert df["line"].tolist()[:2] == [10, 11] and df["line"].iloc[-1] == 33
    assert meta.header["Operator"] == "torlab tests"
    # the units row's extra trailing units (TRIOS writes them) are left out; an unknown
    # column is left out with a note
    assert meta.steps[0].columns["shear_stress_Pa"] == "dyne/cm²"
    assert meta.steps[1].left_out == ["Oscillation torque [µN.m]"]


def test_reduction_steps_and_viscosity_at_a_temperature():
    from torlab import reduce_file

    red = reduce_file(HAND, temperature="35 degC", temperature_band="10 K")
    st = red.tables["steps"]
    assert st["varies"].tolist() == ["shear rate", "temperature", "time"]
    assert st["viscosity_mean_Pa_s"].iloc[0] == pytest.approx(0.05, rel=1e-12)
    # the closed form at 35 degC: 0.05 exp(-0.2); the points are rounded to 6 digits
    at = red.tables["viscosity_at"].iloc[0]
    assert at["viscosity_Pa_s"] == pytest.approx(0.05 * math.exp(-0.2), rel=1e-5)
    assert at["viscosity_ci95_low_Pa_s"] <= 0.05 * math.exp(-0.2) <= at["viscosity_ci95_high_Pa_s"]
    assert at["dlnviscosity_dT_1_K"] == pytest.approx(-0.02, rel=1e-4)
    assert red.key_numbers["stress_rate_viscosity_rel_diff"] < 1e-5
    from torlab.yamlio import load_yaml_text

    lub = load_yaml_text(red.files["lubricant.yaml"]).data["lubricant"]
    assert lub["eta0"] == pytest.approx(at["viscosity_Pa_s"], rel=1e-12)


def test_viscosity_at_a_temperature_without_points_there_is_one_clear_error():
    from torlab import reduce_file
    from torlab.errors import TorlabInputError

    with pytest.raises(TorlabInputError, match=r"0 measured point\(s\) within 1 K of 80 degC "
                                              r"\(measured 25.0 to 45.0 degC\)") as e:
        reduce_file(HAND, temperature="80 degC")
    assert e.value.key == "temperature"


def test_units_that_disagree_with_the_numbers_are_said(tmp_path):
    """A stress column written in Pa where the instrument wrote dyne/cm²: the viscosity the
    file gives no longer equals stress / shear rate, and the reduction says so."""
    from torlab import reduce_file

    f = tmp_path / "pa.txt"
    f.write_bytes(HAND.read_bytes().replace("dyne/cm²\t1/s".encode(), b"Pa\t1/s", 1))
    red = reduce_file(f)
    assert red.key_numbers["stress_rate_viscosity_rel_diff"] == pytest.approx(9.0, rel=1e-9)
    assert any("check the units row" in n for n in red.notes)


def test_decimal_commas_read_as_the_same_numbers(tmp_path):
    text = HAND.read_text(encoding="utf-8")
    head, _, body = text.partition("[step]")
    f = tmp_path / "comma.txt"
    f.write_text(head + "[step]" + body.replace(".", ","), encoding="utf-8")
    # the units row keeps its points (Pa.s): TRIOS writes units in its own spelling
    f.write_text(f.read_text(encoding="utf-8").replace("Pa,s", "Pa.s"), encoding="utf-8")
    a, _ = _read(HAND)
    b, meta = _read(f)
    assert meta.decimal == ","
    pd.testing.assert_frame_equal(a, b)


def test_a_comma_file_whose_first_row_has_no_decimal_mark(tmp_path):
    """The decimal mark is read from every row of a step: a first row of whole numbers
    (298 K) does not make a decimal-comma export one read with points."""
    text = HAND.read_text(encoding="utf-8").replace("\r\n", "\n")
    head, _, body = text.partition("[step]")
    step3 = "[step]" + body.split("[step]")[2]
    f = tmp_path / "comma.txt"
    f.write_text(head + step3.replace("5\t100\t50\t1\t298.15", "5\t100\t50\t1\t298", 1)
                 .replace(".15", ",15").replace("mPa,s", "mPa.s"), encoding="utf-8")
    df, meta = _read(f)
    assert meta.decimal == ","
    np.testing.assert_allclose(df["temperature_C"], [24.85, 25.0, 25.0, 25.0], atol=1e-9)
    np.testing.assert_allclose(df["viscosity_Pa_s"], 0.05, rtol=1e-12)


@pytest.mark.parametrize("encode", [
    lambda t: t.encode("utf-16"),  # Excel's "Unicode text"
    lambda t: t.replace("\r\n", "\r").encode("utf-8"),
    lambda t: t.replace("\r\n", "\r\r\n").encode("utf-8"),
    lambda t: t.replace("Operator\t", "Comment\t" + "n" * 70_000 + "\r\nOperator\t")
    .encode("utf-8"),
], ids=["utf16_bom", "cr", "cr_cr_lf", "header_line_70kB"])
def test_encodings_line_ends_and_long_header_lines_read_the_same_points(tmp_path, encode):
    f = tmp_path / "x.txt"
    f.write_bytes(encode(HAND.read_bytes().decode("utf-8")))
    a, _ = _read(HAND)
    b, _ = _read(f)
    pd.testing.assert_frame_equal(a.drop(columns="line"), b.drop(columns="line"))


@pytest.mark.parametrize("change, line, message", [
    (("dyne/cm²\t1/s\tPa.s\ts\t°C\tdyne/cm²\ts\tµm", "dyne/cm²\t1/s\tPa.s"), 9,
     "the units row has 3 units for 6 columns"),
    (("dyne/cm²\t1/s\tPa.s\ts\t°C\tdyne/cm²\ts", "dyne/furlong\t1/s\tPa.s\ts\t°C\tdyne/cm²\ts"),
     9, "furlong"),
    (("Pa\t1/s\tmPa.s", "Pa\t1/s\tmm"), 29, "column 'Viscosity'"),
    (("25\t50\t0.05\t30", "25\t50\tabc\t30"), 12, "'abc' is not a number"),
    (("10\t20\t0.05\t20\t25.0\t-200", "10\t20\t0.05\t20\t25.0"), 11, "expected 6 fields"),
    (("5\t100\t50\t1\t298.15", "5\t100\t-50\t1\t298.15"), 30, "is not positive"),
    (("5\t100\t50\t2\t298.15", "5\t100\t50\t2\t-5"), 31, "below absolute zero"),
    (("dyne/cm²\t1/s\tPa.s\ts\t°C\tdyne/cm²\ts\tµm\n", ""), 9, "no units row"),
    (("[step]\nFlow sweep - 1\n", "[step]\n"), 6, "followed by the step's name"),
    (("25\t50\t0.05\t30\t25.0\t-300", "25\t50\t0,05\t30\t25.0\t-300"), 12,
     "column 'Viscosity': '0,05' has a decimal comma, but the file's decimal mark is '.'"),
    (("25\t50\t0.05\t30\t25.0\t-300", "25\t50\t   \t30\t25.0\t-300"), 12,
     "column 'Viscosity': a cell of spaces"),
    (("25\t50\t0.05\t30\t25.0\t-300", "1e308\t50\t0.05\t30\t25.0\t-300"), 12,
     "column 'Stress': 1e308 dyne/cm² is too large to be a measurement"),
    (("25\t50\t0.05\t30\t25.0\t-300", "25\t50\t0.05\t30\t25.0\t-300\t7"), 12,
     "expected 6 fields separated by tab"),
    (("Temperature ramp - 2\nStress\tShear rate\tViscosity",
      "Temperature ramp - 2\nStress\tShear rate\tThickness"), 18, "has no Viscosity column"),
])
def test_bad_exports_name_the_file_and_line(tmp_path, change, line, message):
    from torlab.errors import TorlabInputError

    text = HAND.read_text(encoding="utf-8").replace("\r\n", "\n")
    assert change[0] in text, change[0]
    f = tmp_path / "bad.txt"
    f.write_text(text.replace(change[0], change[1], 1), encoding="utf-8")
    with pytest.raises(TorlabInputError, match=message) as e:
        _read(f)
    assert e.value.path is not None and e.value.path.endswith("bad.txt")
    assert e.value.line == line


def test_not_a_trios_export_is_not_detected(tmp_path):
    from torlab.instruments import detect
    from torlab.instruments.trios import detect as trios_detect

    assert trios_detect(HAND.read_text(encoding="utf-8"))
    assert detect(HAND)[0].name == "trios"
    assert not trios_detect("Filename\tx\nOperator\ty\n")  # no step block
    assert not trios_detect("Name\tx\n[step]\n")  # another first line
    f = tmp_path / "header_only.txt"
    f.write_text("Filename\tx\nproceduresegments\t1\n")
    from torlab.errors import TorlabInputError

    with pytest.raises(TorlabInputError, match=r"no \[step\] block"):
        _read(f)


def test_torlab_reduce_detects_it_and_writes_its_tables(cli, tmp_path):
    r = cli("reduce", HAND, "-o", tmp_path / "o", "--no-plot")
    assert r.exit_code == 0, r.output
    assert "hand.txt: read as trios (TRIOS text export" in r.output
    pts = pd.read_csv(tmp_path / "o" / "hand_points.csv")
    assert pts.columns[0] == "step" and "shear_stress_Pa" in pts and "line" in pts
    assert pd.read_csv(tmp_path / "o" / "summary.csv")["n_points"].tolist() == [14]
    r = cli("trios", "reduce", HAND, "--temperature", "35 degC", "--temperature-band", "0 K",
            "-o", tmp_path / "p")
    assert r.exit_code == 2 and "--temperature-band: '0 K' must be positive" in r.output


def test_protocol_section_is_the_modules(tmp_path):
    """``data: trios:`` comes from the module's options: its keys, their checks, files."""
    from torlab.errors import ValidationErrors
    from torlab.protocols.loader import load_protocol_text

    (tmp_path / "hand.txt").write_bytes(HAND.read_bytes())
    (tmp_path / "scene.yaml").write_bytes((ROOT / "protocols" / "scenes" /
                                          "wheel_rail_tab54.yaml").read_bytes())
    text = ("version: 1\nname: t\ndata:\n  trios:\n    files: [hand.txt]\n"
            "    temperature: 35 degC\n    temperature_band: {band}\n"
            "reports:\n  traction:\n    creepage: {{from: 0, to: 0.05, points: 6}}\n"
            "    curves: [{{label: dry, scene: scene.yaml}}]\n")
    lp = load_protocol_text(text.format(band="10 K"), tmp_path)
    assert lp.data_files("trios") == [tmp_path / "hand.txt"]
    assert lp.protocol.data.trios.options() == {"temperature": 35.0,
                                                "temperature_band": pytest.approx(10.0)}
    with pytest.raises(ValidationErrors, match=r"data\.trios\.temperature_band"):
        load_protocol_text(text.format(band="-1 K"), tmp_path)


@pytest.mark.slow  # a protocol run (a traction report beside the data): ~3 s
def test_protocol_reduces_the_section_into_data(tmp_path):
    import json

    from torlab import run_protocol

    (tmp_path / "hand.txt").write_bytes(HAND.read_bytes())
    (tmp_path / "scene.yaml").write_bytes((ROOT / "protocols" / "scenes" /
                                          "wheel_rail_tab54.yaml").read_bytes())
    (tmp_path / "p.yaml").write_text(
        "version: 1\nname: t\ndata:\n  trios:\n    files: [hand.txt]\n"
        "    temperature: 35 degC\n    temperature_band: 10 K\n"
        "reports:\n  traction:\n    creepage: {from: 0, to: 0.05, points: 6}\n"
        "    curves: [{label: dry, scene: scene.yaml}]\n")
    run_protocol(tmp_path / "p.yaml", tmp_path / "out")
    data = tmp_path / "out" / "data"
    assert sorted(p.name for p in (data / "trios").iterdir()) == [
        "hand_points.csv", "hand_steps.csv", "hand_viscosity_at.csv"]
    at = pd.read_csv(data / "trios_viscosity_at.csv")
    assert at["viscosity_Pa_s"].iloc[0] == pytest.approx(0.05 * math.exp(-0.2), rel=1e-5)
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["data"]["trios"] == \
        {"files": 1}


# ------------------------------------------------------------------ the real export
@needs_real
def test_real_export_steps_units_and_its_own_consistency():
    from torlab import reduce_file

    red = reduce_file(REAL)
    df, st = red.tables["points"], red.tables["steps"]
    assert red.detected.startswith("TRIOS text export")
    assert st["name"].tolist() == ["Peak hold - 1", "Temperature ramp - 2",
                                   "Temperature ramp - 3", "Temperature ramp - 4"]
    assert st["varies"].tolist() == ["time", "temperature", "temperature", "temperature"]
    assert st["n_points"].tolist() == [300, 900, 1300, 399]
    # the first row as written: 42.6396 dyne/cm², 199.852 1/s, 0.0213356 Pa.s, -195.676 dyne/cm²
    first = df.iloc[0]
    assert first["shear_stress_Pa"] == pytest.approx(4.26396, rel=1e-12)
    assert first["normal_stress_Pa"] == pytest.approx(-19.5676, rel=1e-12)
    assert first["viscosity_Pa_s"] == pytest.approx(0.0213356, rel=1e-12)
    assert first["line"] == 10
    # the instrument's viscosity is its stress / shear rate: with dyne/cm² read as 0.1 Pa
    # the two agree to the 6 digits written (a wrong factor would be off by 10 or more)
    assert red.key_numbers["stress_rate_viscosity_rel_diff"] < 1e-4
    assert df["temperature_C"].min() == pytest.approx(5.008) and df["temperature_C"].max() == 70
    # the units row of the first and last steps holds two units more than columns
    assert red.meta.steps[0].columns["temperature_C"] == "°C"
    assert not red.notes


@needs_real
def test_real_export_viscosity_falls_with_temperature_and_the_interval_holds_it():
    """Between the ramps' points around 40 degC (thermal lag: the ramp up and down differ
    by a few per cent), the fitted value lies inside the measured spread."""
    from torlab import reduce_file

    red = reduce_file(REAL, temperature="40 degC")
    at = red.tables["viscosity_at"].iloc[0]
    pts = red.tables["points"]
    near = pts[(pts["temperature_C"] - 40).abs() <= 0.5]
    assert near["viscosity_Pa_s"].min() <= at["viscosity_Pa_s"] <= near["viscosity_Pa_s"].max()
    assert at["viscosity_ci95_low_Pa_s"] < at["viscosity_Pa_s"] < at["viscosity_ci95_high_Pa_s"]
    assert at["dlnviscosity_dT_1_K"] < 0  # thinner when hotter
    ramp = red.tables["steps"].set_index("step")
    # the cooling ramp 3 from 70 to 5 degC: viscosity rises about tenfold (0.0118 to 0.121)
    assert ramp.loc[3, "viscosity_max_Pa_s"] / ramp.loc[3, "viscosity_min_Pa_s"] > 9
