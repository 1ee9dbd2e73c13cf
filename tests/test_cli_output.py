"""What the commands print and write around their numbers: console tables that keep their
cells whole when the output is not a terminal, and Excel sheets in the figures' units
(the retention commands' wording, hints and inputs are in tests/test_retention_cli.py).

References: the file names and hand conversions (2 % SRR is 0.02, 1e-4 m is 100 µm).
"""

from __future__ import annotations

import pandas as pd
import pytest

from tests.conftest import ROOT


# ------------------------------------------------------------------ console tables
def test_console_table_keeps_file_names_whole_when_piped(cli, tmp_path):
    """Not a terminal (CliRunner, like '| cat'): the table takes its natural width, so the
    file name is one cell on one line instead of 7-character pieces at 80 columns."""
    name = "hpt_OFM1_1uL_25C.txt"
    r = cli("hpt", "reduce", ROOT / "sample_data" / "hpt" / name, "-o", tmp_path / "out")
    assert r.exit_code == 0, r.output
    rows = [ln for ln in r.output.splitlines() if name in ln]
    assert len(rows) >= 1 and rows[0].startswith("│ ")  # the table row, the name unbroken
    assert "f (last 20 µm)" in r.output  # header cells are not folded either
    width = max(len(ln) for ln in r.output.splitlines() if ln.startswith(("┏", "│", "└")))
    assert width > 80


def test_console_table_fits_the_terminal_when_there_is_one(monkeypatch):
    """On a terminal rich fits the table to its width, as before."""
    import io

    from rich.console import Console
    from rich.table import Table

    import torlab.cli._common as common

    buf = io.StringIO()
    monkeypatch.setattr(common, "console", lambda: Console(
        file=buf, width=60, force_terminal=True, color_system=None))
    t = Table()
    for c in ("a" * 30, "b" * 30, "c" * 30):
        t.add_column(c, overflow="fold")
    t.add_row("x", "y", "z")
    common.print_renderable(t)
    assert max(len(ln) for ln in buf.getvalue().splitlines()) <= 60


# ------------------------------------------------------------------ Excel sheets
def test_xlsx_sheets_in_the_units_of_the_figures(tmp_path):
    from openpyxl import load_workbook

    from torlab.outputs import write_xlsx

    df = pd.DataFrame({"file": ["a.txt"], "srr": [0.02], "srr_max": [0.2],
                       "displacement_m": [1e-4], "shear_stress_Pa": [2.5e8],
                       "film_thickness_m": [3.2e-8], "rolling_speed_m_s": [0.025],
                       "alpha_1_Pa": [2e-8], "track_radius_m": [0.021],
                       "traction_coefficient": [0.05], "step_time_s": [6.0],
                       "residual_m": [2e-10]})
    write_xlsx(tmp_path / "t.xlsx", {"curves": df})
    ws = load_workbook(tmp_path / "t.xlsx")["curves"]
    got = {ws.cell(1, j).value: ws.cell(2, j).value for j in range(1, ws.max_column + 1)}
    assert got == {"file": "a.txt", "srr [%]": pytest.approx(2.0),
                   "srr_max [%]": pytest.approx(20.0), "displacement [µm]": pytest.approx(100.0),
                   "shear_stress [MPa]": pytest.approx(250.0),
                   "film_thickness [nm]": pytest.approx(32.0),
                   "rolling_speed [m/s]": pytest.approx(0.025),
                   "alpha [1/GPa]": pytest.approx(20.0), "track_radius [mm]": pytest.approx(21.0),
                   "traction_coefficient": pytest.approx(0.05), "step_time [s]": 6.0,
                   "residual [nm]": pytest.approx(0.2)}  # the film fits' residual_m
    assert list(df.columns)[1] == "srr" and df["srr"].iloc[0] == 0.02  # the table as it was


def test_reduce_xlsx_has_srr_in_per_cent_as_the_traction_figure(cli, tmp_path):
    """The sample MTM export's traction sheet: SRR in %, as the traction figure's axis."""
    from openpyxl import load_workbook

    src = next((ROOT / "sample_data" / "mtm").glob("*.txt"))
    out = tmp_path / "out"
    r = cli("reduce", src, "-o", out, "--xlsx")
    assert r.exit_code == 0, r.output
    wb = load_workbook(out / "tables.xlsx", read_only=True)
    csvs = {p.stem: pd.read_csv(p) for p in out.glob("*.csv")}
    checked = 0
    for name, df in csvs.items():
        if "srr" not in df or name[:31] not in wb.sheetnames:
            continue
        rows = list(wb[name[:31]].iter_rows(min_row=1, max_row=2, values_only=True))
        head = list(rows[0])
        assert "srr" not in head and "srr [%]" in head
        assert rows[1][head.index("srr [%]")] == pytest.approx(100 * df["srr"].iloc[0])
        checked += 1
    assert checked


# ------------------------------------------------------------------ EHD2 film steps' "μ"
def test_ehd2_rolling_force_ratio_is_noted_not_a_traction_coefficient(tmp_path):
    """The hand-made EHD2 export: four film rows at SRR 0.000 with Traction Force 1
    0.8000 N at 20.000 N.  The ratio 0.04 is the load cell's offset at pure rolling: the film
    table has no coefficient, the note gives the ratio; with sliding rows (SRR 10 %) the
    ratio stays a coefficient."""
    from torlab.parsers.pcs import read_pcs
    from torlab.reduce.mtm import reduce_pcs

    src = ROOT / "tests" / "data" / "pcs" / "ehd2_quirks.txt"
    red = reduce_pcs(*read_pcs(src))
    film = red.curves["film"]
    assert "traction_coefficient" not in film
    assert film["traction_force_1_N"].tolist() == [0.8] * 4
    (note,) = [n for n in red.notes if "Traction Force 1 / Ball Load" in n]
    assert "film step(s) 2: Traction Force 1 / Ball Load is 0.040-0.040 at pure rolling" in note
    assert "load cell's offset, not a traction coefficient" in note
    # the same rows sliding at 10 % SRR: a traction coefficient, no note
    raw = src.read_bytes().decode("cp1252")
    lines = raw.split("\r\n") if "\r\n" in raw else raw.split("\n")
    head = next(ln for ln in lines if ln.startswith("Rolling Speed")).split("\t")
    k = head.index("SRR (%)")
    out = []
    for ln in lines:
        f = ln.split("\t")
        if len(f) == len(head) and f[0][:1].isdigit():
            f[k] = "10.000"
        out.append("\t".join(f))
    sliding = tmp_path / "sliding.txt"
    sliding.write_bytes("\r\n".join(out).encode("cp1252"))
    red = reduce_pcs(*read_pcs(sliding))
    assert red.curves["film"]["traction_coefficient"].tolist() == pytest.approx([0.04] * 4)
    assert not [n for n in red.notes if "Traction Force 1 / Ball Load" in n]
