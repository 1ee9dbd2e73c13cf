"""Protocol results never overwrite each other: names are settled before any work.

Two data files of one name in different folders, two labels that make one file name
(``run 1`` and ``run/1``), two products that do (``OFM 1`` and ``OFM_1``), a label too long
for a file name: each either gets results of its own or is refused, before anything is
computed, with one error naming the protocol line (or the log); and whatever slips
through is refused by the output folder itself, which never writes one name twice in a
run.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from conftest import ROOT, error_lines

from torlab.errors import OutputExistsError, ValidationErrors

MTM = ROOT / "sample_data" / "mtm"
HPT = ROOT / "sample_data" / "hpt"


def _mtm_protocol(tmp_path: Path, files: str) -> Path:
    for d, src in (("day1", "mtm_base_5uL.txt"), ("day2", "mtm_TOR-A_5uL.txt")):
        (tmp_path / d).mkdir(exist_ok=True)
        shutil.copy(MTM / src, tmp_path / d / "export.txt")
    p = tmp_path / "p.yaml"
    p.write_text(f"version: 1\nname: days\ndata:\n  mtm:\n    files:\n{files}"
                 "    time_test: {threshold: 0.15, duration: 20 min}\n"
                 "reports:\n  time_test:\n    band: [0.15, 0.25]\n")
    return p


def test_two_files_of_one_name_without_labels_are_refused_before_any_work(cli, tmp_path):
    p = _mtm_protocol(tmp_path, "      - day1/export.txt\n      - day2/export.txt\n")
    r = cli("run", p, "-o", tmp_path / "out")
    assert r.exit_code == 2
    (line,) = error_lines(r)
    assert line.startswith(f"error: {p}:7: data.mtm.files.1: day2/export.txt and "
                           "day1/export.txt have one name ('export')") and "give each a label" \
        in line
    assert not (tmp_path / "out").exists()


def test_two_files_of_one_name_are_named_by_their_labels(cli, tmp_path):
    p = _mtm_protocol(tmp_path, "      - {path: day1/export.txt, label: day 1}\n"
                                "      - {path: day2/export.txt, label: day 2}\n")
    r = cli("run", p, "-o", tmp_path / "out")
    assert r.exit_code == 0, r.output
    data = sorted(f.name for f in (tmp_path / "out" / "data" / "mtm").iterdir())
    assert data == ["day_1_timed.csv", "day_2_timed.csv"]
    import pandas as pd

    a = pd.read_csv(tmp_path / "out" / "data" / "mtm" / "day_1_timed.csv")
    b = pd.read_csv(tmp_path / "out" / "data" / "mtm" / "day_2_timed.csv")
    assert not a["traction_coefficient"].equals(b["traction_coefficient"])  # two files' data
    figs = sorted(f.name for f in (tmp_path / "out" / "time_test").iterdir()
                  if f.name.startswith("time_test_"))
    assert figs == ["time_test_day_1.png", "time_test_day_2.png"]


@pytest.mark.parametrize("a, b, fragment", [
    ("run 1", "run/1", "makes the same file name ('run_1') as 'run 1'"),
    ("same", "same", "label 'same' is used twice"),
    ("Run", "run", "makes the same file name ('run') as 'Run'"),
])
def test_labels_that_make_one_file_name_are_refused(tmp_path, a, b, fragment):
    from torlab.protocols.loader import load_protocol

    shutil.copy(MTM / "mtm_base_5uL.txt", tmp_path / "a.txt")
    shutil.copy(MTM / "mtm_TOR-A_5uL.txt", tmp_path / "b.txt")
    p = tmp_path / "p.yaml"
    p.write_text("version: 1\nname: labels\ndata:\n  mtm:\n    files:\n"
                 f"      - {{path: a.txt, label: '{a}'}}\n      - {{path: b.txt, label: '{b}'}}\n"
                 "reports:\n  time_test: {band: [0.15, 0.25]}\n")
    with pytest.raises(ValidationErrors) as e:
        load_protocol(p)
    (prob,) = e.value.problems
    assert prob.line == 7 and fragment in prob.message


def test_a_label_too_long_for_a_file_name_is_cut_to_a_name_that_fits(cli, tmp_path):
    long = "a very long label " * 20  # 360 characters
    p = _mtm_protocol(tmp_path, f"      - {{path: day1/export.txt, label: '{long}'}}\n")
    r = cli("run", p, "-o", tmp_path / "out")
    assert r.exit_code == 0, r.output
    names = [f.name for f in (tmp_path / "out" / "time_test").iterdir()]
    assert max(len(n) for n in names) < 100


def test_products_whose_parameter_files_would_be_one_are_refused(cli, tmp_path):
    for prod, src in (("OFM 1", "hpt_OFM1_4uL_25C.txt"), ("OFM_1", "hpt_OFM2_4uL_25C.txt")):
        text = (HPT / src).read_text().replace("# product: OFM1", f"# product: {prod}") \
            .replace("# product: OFM2", f"# product: {prod}")
        (tmp_path / src).write_text(text)
    p = tmp_path / "p.yaml"
    p.write_text("version: 1\nname: products\ndata:\n  hpt:\n    files: [hpt_*.txt]\n"
                 "fits:\n  hpt_layers: {amounts: [4 uL], temperature_coefficients: false}\n"
                 "reports:\n  amount: {curve: interpolation}\n")
    r = cli("run", p, "-o", tmp_path / "out")
    assert r.exit_code == 2
    (line,) = error_lines(r)
    assert "products 'OFM 1' and 'OFM_1' would write one parameter file (fits/hpt_OFM_1.yaml)" \
        in line and "hpt_OFM2_4uL_25C.txt:2: product:" in line
    assert not (tmp_path / "out").exists()


def test_the_output_folder_never_writes_one_name_twice(tmp_path):
    from torlab.outputs import OutputDir

    d = OutputDir(tmp_path / "out")
    d.write_text("data/a.csv", "1")
    for again in ("data/a.csv", "data/A.csv"):
        with pytest.raises(OutputExistsError, match="two results of this run would be written"):
            d.write_text(again, "2")
    d.commit()
    assert (tmp_path / "out" / "data" / "a.csv").read_text() == "1"
    assert json.loads((tmp_path / "out" / "torlab-manifest.json").read_text())["files"] == \
        ["data/a.csv"]
