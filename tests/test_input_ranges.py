"""Plausible values beyond scenes and log headers: PCS step lines and load/temperature
columns, the creep-force options (--lateral, --spin, predict table axes, fit polach ranges)
and protocol creepage/speed/amount lists, each against the table of torlab.units.RANGES
(docs/scenes.md "Plausible values").

The references are physical limits independent of the code: a normal load cannot be
negative, nothing is colder than -273.15 degC, |SRR| <= 2 while both surfaces roll forward,
a 1e300 anything is a typing or unit error.  Each bad value must end in exactly one
``error:`` line naming the file and line (or the option) and exit code 2; an unusual but
possible value in one ``warning:`` line naming it, the command going on.
"""

from __future__ import annotations

import pytest

from tests.conftest import DATA, ROOT, error_lines

SAMPLE_MTM = ROOT / "sample_data" / "mtm" / "mtm_TOR-A_5uL.txt"
TAB54 = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
OPTICAL = DATA / "optical" / "setpoints_torque_crlf.csv"


def _one_error(r, *words: str) -> str:
    assert r.exit_code == 2, r.output
    lines = error_lines(r)
    errors = [ln for ln in lines if ln.startswith("error: ")]
    assert len(errors) == 1 and all(ln.startswith(("error: ", "warning: ")) for ln in lines), lines
    assert "Traceback" not in r.output
    for w in words:
        assert w in errors[0], (w, errors[0])
    return errors[0]


def _line_of(text: str, start: str) -> int:
    return next(i + 1 for i, ln in enumerate(text.split("\n")) if ln.startswith(start))


# ------------------------------------------------------------------ PCS step lines
@pytest.mark.parametrize("old, new, words", [
    ("Ball load = 18 N", "Ball load = 1e300 N", ("Ball load", "not possible for a normal load")),
    ("Ball load = 18 N", "Ball load = -18 N", ("Ball load", "not possible for a normal load")),
    ("Ball load = 18 N", "Ball load = 18 kN", ()),  # 18 kN on an MTM ball: possible (an ETM)
    ("Applied amount = 5 uL", "Applied amount = 1e9 uL", ("Applied amount",
                                                           "not possible for an applied volume")),
    ("Applied amount = 5 uL", "Applied amount = -5 uL", ("Applied amount", "not possible")),
    ("Disc track radius used for this step (mm)\t21.232",
     "Disc track radius used for this step (mm)\t0", ("Disc track radius", "not possible")),
    ("Ball load = 18 N", "Ball load = 18 N\nSRR = 500 %", ("SRR", "not possible for a creepage")),
    ("Ball load = 18 N", "Ball load = 18 N\nRolling speed = 5e6 mm/s",
     ("Rolling speed", "not possible for a rolling speed")),
    ("Ball load = 18 N", "Ball load = 18 N\nLube temperature = -300 degC",
     ("Lube temperature", "-300 degC is not possible for an absolute temperature")),
])
def test_pcs_step_lines_are_range_checked(cli, tmp_path, old, new, words):
    text = SAMPLE_MTM.read_text(encoding="utf-8")
    assert old in text
    bad = text.replace(old, new, 1)
    p = tmp_path / "mtm.txt"
    p.write_text(bad, encoding="utf-8")
    r = cli("mtm", "reduce", p, "-o", tmp_path / "out", "--no-plot")
    if not words:
        assert r.exit_code == 0, r.output
        return
    ln = _line_of(bad, new.split("\n")[-1])
    _one_error(r, f"mtm.txt:{ln}:", *words)
    assert not (tmp_path / "out").exists()


def test_pcs_step_line_without_unit_takes_the_export_units(tmp_path):
    """PCS writes speeds in mm/s and the SRR in %: a bare number is read in those."""
    from torlab.parsers.pcs import read_pcs

    text = SAMPLE_MTM.read_text(encoding="utf-8").replace(
        "Ball load = 18 N", "Ball load = 18 N\nSRR = 50\nRolling speed = 1000", 1)
    p = tmp_path / "mtm.txt"
    p.write_text(text, encoding="utf-8")
    _, meta = read_pcs(p)
    md = meta.steps[0].metadata
    assert md["srr"] == pytest.approx(0.5)
    assert md["rolling_speed_m_s"] == pytest.approx(1.0)


def test_pcs_unusual_step_load_is_a_warning_line(cli, tmp_path):
    text = SAMPLE_MTM.read_text(encoding="utf-8").replace("Ball load = 18 N",
                                                          "Ball load = 5e6 N", 1)
    p = tmp_path / "mtm.txt"
    p.write_text(text, encoding="utf-8")
    r = cli("mtm", "reduce", p, "-o", tmp_path / "out", "--no-plot")
    assert r.exit_code == 0, r.output
    ln = _line_of(text, "Ball load = 5e6 N")
    warn = [x for x in error_lines(r) if x.startswith("warning:")]
    assert any(f"mtm.txt:{ln}:" in w and "5e+06 N is unusual for a normal load" in w
               for w in warn), warn


def test_pcs_heating_target_below_absolute_zero(tmp_path):
    from torlab.errors import TorlabInputError
    from torlab.parsers.pcs import read_pcs

    text = (DATA / "pcs" / "ehd2_quirks.txt").read_bytes().replace(
        b"Controlling temperature to 100.0", b"Controlling temperature to -400.0")
    p = tmp_path / "ehd2.txt"
    p.write_bytes(text)
    with pytest.raises(TorlabInputError, match="below") as e:
        read_pcs(p)
    assert e.value.line == 29


# ------------------------------------------------------------------ data columns
def _mtm_row_replaced(tmp_path, col: int, value: str) -> tuple:
    """The sample MTM export with one cell of its 5th data row replaced."""
    lines = SAMPLE_MTM.read_text(encoding="utf-8").split("\n")
    hdr = next(i for i, ln in enumerate(lines) if ln.startswith("Step Time (s)"))
    i = hdr + 5
    cells = lines[i].split("\t")
    cells[col] = value
    lines[i] = "\t".join(cells)
    p = tmp_path / "mtm.txt"
    p.write_text("\n".join(lines), encoding="utf-8")
    return p, i + 1


def test_negative_ball_load_column_is_an_error_naming_the_line(cli, tmp_path):
    header = SAMPLE_MTM.read_text(encoding="utf-8").split("\n")
    cols = next(ln for ln in header if ln.startswith("Step Time (s)")).split("\t")
    p, ln = _mtm_row_replaced(tmp_path, cols.index("Ball Load (N)"), "-18.02")
    _one_error(cli("mtm", "reduce", p, "-o", tmp_path / "out", "--no-plot"),
               f"mtm.txt:{ln}:", "Ball Load", "-18.02 N is not possible for a normal load")
    # a load cell at rest around zero is not an error (the coefficient of that row is
    # taken from the coefficient column; the reduction says the load is zero there)
    p, _ = _mtm_row_replaced(tmp_path, cols.index("Ball Load (N)"), "-0.003")
    r = cli("mtm", "reduce", p, "-o", tmp_path / "out2", "--no-plot")
    assert r.exit_code == 0, r.output


def test_temperature_column_below_absolute_zero_names_the_line(cli, tmp_path):
    header = SAMPLE_MTM.read_text(encoding="utf-8").split("\n")
    cols = next(ln for ln in header if ln.startswith("Step Time (s)")).split("\t")
    p, ln = _mtm_row_replaced(tmp_path, cols.index("Lube RTD Temp (°C)"), "-300")
    _one_error(cli("mtm", "reduce", p, "-o", tmp_path / "out", "--no-plot"),
               f"mtm.txt:{ln}:", "below absolute zero")


@pytest.mark.parametrize("old, new, words", [
    ("20.5,23.1,2", "20.5,-300,2", ("temperature", "below absolute zero")),
    ("0.2,0.99,1.01,50,", "0.2,0.99,1.01,-50,", ("load_set", "cannot be negative")),
])
def test_optical_columns_that_cannot_be(cli, tmp_path, old, new, words):
    text = OPTICAL.read_bytes().decode("utf-8-sig")
    assert old in text
    bad = text.replace(old, new, 1)
    p = tmp_path / "opt.csv"
    p.write_text(bad, encoding="utf-8")
    ln = next(i + 1 for i, x in enumerate(bad.replace("\r\n", "\n").split("\n")) if new in x)
    _one_error(cli("optical", "reduce", p, "-o", tmp_path / "out", "--no-plot"),
               f"opt.csv:{ln}:", *words)


# ------------------------------------------------------------------ creep-force options
@pytest.mark.parametrize("args, words", [
    (("predict", "traction", TAB54, "--creepage", "0:0.01:3", "--lateral", "5", "--no-plot"),
     ("--lateral", "5 is not possible for a creepage")),
    (("predict", "traction", TAB54, "--creepage", "0:0.01:3", "--spin", "1e300", "--no-plot"),
     ("--spin", "1e+300 1/m is not possible for a spin")),
    (("predict", "traction", TAB54, "--creepage", "0:0.01:3", "--spin", "2 km", "--no-plot"),
     ("--spin",)),
    (("predict", "table", TAB54, "--creepage", "0:0.01:2", "--lateral", "0:3:2"),
     ("--lateral", "3 is not possible for a creepage")),
    (("predict", "table", TAB54, "--creepage", "0:0.01:2", "--spin", "0:1e9:2"),
     ("--spin", "not possible for a spin")),
    (("predict", "table", TAB54, "--creepage", "0:0.01:2", "--speed", "1e9:2e9:2"),
     ("--speed", "not possible for a rolling speed")),
    (("fit", "polach", TAB54, "--creepage", "0:5:5"), ("--creepage", "5 is not possible")),
    (("fit", "polach", TAB54, "--creepage", "0:0.05:5", "--speed", "1e9"),
     ("--speed", "not possible for a rolling speed")),
    (("fit", "polach", TAB54, "--creepage", "0:0.05:5", "--lateral", "-3"),
     ("--lateral", "not possible for a creepage")),
    (("fit", "polach", TAB54, "--creepage", "0:0.05:5", "--spin", "-1e7"),
     ("--spin", "not possible for a spin")),
])
def test_creep_force_options_outside_the_range_table(cli, tmp_path, args, words):
    _one_error(cli(*args, "-o", tmp_path / "out"), *words)
    assert not (tmp_path / "out").exists()


def test_unusual_spin_is_a_warning_line_and_the_prediction_goes_on(cli, tmp_path):
    r = cli("predict", "traction", TAB54, "--creepage", "0:0.01:3", "--spin", "2000",
            "--no-plot", "-o", tmp_path / "out")
    assert r.exit_code == 0, r.output
    warn = [x for x in error_lines(r) if x.startswith("warning:")]
    assert any("--spin: 2000 1/m is unusual for a spin" in w for w in warn), warn


def test_api_creep_options_are_range_checked():
    from torlab.api import predict_creep
    from torlab.errors import TorlabInputError

    with pytest.raises(TorlabInputError, match="lateral"):
        predict_creep(TAB54, "0:0.01:3", lateral=4.0)
    with pytest.raises(TorlabInputError, match="spin"):
        predict_creep(TAB54, "0:0.01:3", spin="1e300 1/m")


# ------------------------------------------------------------------ protocol lists
PROTOCOL = """\
version: 1
name: ranges
data:
  hpt:
    files: [hpt_*.txt]
fits:
  hpt_layers:
    amounts: [{amount}]
    temperature: 25 degC
reports:
  traction:
    creepage: {creepage}
    curves:
      - label: tab54
        scene: {scene}
        speeds: {speeds}
"""


@pytest.mark.parametrize("amount, creepage, speeds, words", [
    ("4 uL", "[0, 0.01, 3]", "[10 m/s]", ("creepage", "3 is not possible for a creepage")),
    ("4 uL", "{from: 0, to: 5, points: 3}", "[10 m/s]", ("creepage", "not possible")),
    ("4 uL", "0:0.05:3", "[1e9 m/s]", ("speeds", "not possible for a rolling speed")),
    ("1e9 uL", "0:0.05:3", "[10 m/s]", ("amounts", "not possible for an applied volume")),
    ("1e9 mg", "0:0.05:3", "[10 m/s]", ("amounts", "not possible for an applied mass")),
])
def test_protocol_lists_are_range_checked(cli, tmp_path, amount, creepage, speeds, words):
    import shutil

    for f in sorted((ROOT / "sample_data" / "hpt").glob("hpt_OFM1_*uL_25C.txt"))[:2]:
        shutil.copy(f, tmp_path / f.name)
    p = tmp_path / "p.yaml"
    p.write_text(PROTOCOL.format(amount=amount, creepage=creepage, speeds=speeds, scene=TAB54))
    _one_error(cli("run", p, "-o", tmp_path / "out"), "p.yaml:", *words)
    assert not (tmp_path / "out").exists()


def test_polach_fit_over_a_lateral_range_alone(cli, tmp_path):
    """A fit range without the pure longitudinal curve ('--lateral 0.005' only) starts from
    the curve nearest to it (it ended in an internal error).  The fit must reproduce
    torlab's own creep forces of that range (both components) to within 2 % of the
    saturated coefficient (mu_c2 = 0.45 of the scene)."""
    import pandas as pd
    import yaml

    out = tmp_path / "out"
    r = cli("fit", "polach", TAB54, "--creepage", "0:0.05:6", "--speed", "10 m/s",
            "--lateral", "0.005", "-o", out)
    assert r.exit_code == 0, r.output
    fit = yaml.safe_load((out / "params.yaml").read_text())["fit"]
    assert fit["residual_rms"] < 0.02 * 0.45
    data = pd.read_csv(out / "fit_data.csv")
    assert set(data["component"]) == {"x", "y"} and (data["lateral"] == 0.005).all()
    assert (data["residual"].abs() < 0.05 * 0.45).all()
