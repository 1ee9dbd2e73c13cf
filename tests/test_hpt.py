"""HPT pipeline: format, reduction (thesis Eqs. 5.1-5.4), synthetic data, CLI."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest
from conftest import DATA, error_lines, sha

from torlab.errors import TorlabInputError
from torlab.parsers.hpt import read_hpt
from torlab.reduce.hpt import (
    RigCompliance,
    annulus_area,
    effective_radius,
    reduce_hpt,
    window_mean,
)

HAND = DATA / "hpt" / "hand.txt"


# --- geometry (thesis 5.1.3: annulus 6/12 mm, "contact area of 85 mm^2") -------------------
def test_annulus_area_and_effective_radius_exact():
    S = annulus_area(3e-3, 6e-3)
    re = effective_radius(3e-3, 6e-3)
    assert S * 1e6 == pytest.approx(84.823, abs=5e-4)  # 27 pi mm^2
    assert re * 1e3 == pytest.approx(4.6667, abs=5e-5)  # 14/3 mm
    # a thin ring's effective radius tends to its radius
    assert effective_radius(5e-3, 5.000001e-3) == pytest.approx(5e-3, rel=1e-6)


# --- hand-computed log ------------------------------------------------------------------------
def test_reduction_matches_hand_calculation():
    df, meta = read_hpt(HAND)
    res = reduce_hpt(df, meta)
    d = res.data
    # sigma = F / S: 63 617.2512 N / 84.8230016 mm^2 = 750 MPa; row 4 half the load
    assert d["normal_stress_Pa"].to_numpy() == pytest.approx([750e6, 750e6, 750e6, 375e6], rel=1e-8)
    # tau = arm force * 0.25 m / (r_e S) with r_e S = 126 pi mm^3 = 3.95840674e-7 m^3
    assert d["shear_stress_Pa"].to_numpy() == pytest.approx([0, 1.263135e8, 2.526269e8, 2.526269e8], rel=1e-6)
    assert d["friction"].to_numpy() == pytest.approx([0, 0.168418, 0.336836, 0.673672], rel=1e-5)
    # displacement from the motor (finer): 0.009 deg per row at r_e = 14/3 mm -> 0.733038 um
    assert res.displacement_source == "motor"
    assert d["displacement_m"].to_numpy() * 1e6 == pytest.approx([0, 0.733038, 1.466077, 2.199115], rel=1e-6)
    assert d["line"].tolist() == [12, 13, 14, 15]


def test_motor_versus_encoder_displacement():
    df, meta = read_hpt(HAND)
    enc = reduce_hpt(df, meta, source="encoder")
    # encoder: 0.01 deg per row -> 0.814487 um
    assert enc.displacement_source == "encoder"
    assert enc.data["displacement_m"].to_numpy()[-1] * 1e6 == pytest.approx(3 * 0.814487, rel=1e-6)
    only_encoder = df.drop(columns=["motor_angle_rad"])
    auto = reduce_hpt(only_encoder, meta)
    assert auto.displacement_source == "encoder"
    with pytest.raises(TorlabInputError, match="no motor angle"):
        reduce_hpt(only_encoder, meta, source="motor")


def test_window_mean_last_20um_before_maximum():
    u = np.r_[np.linspace(0, 100e-6, 101), np.linspace(99e-6, 90e-6, 10)]  # unloading after max
    y = np.r_[np.linspace(0, 100, 101), np.full(10, 1000.0)]
    m, s, n = window_mean(u, y, 20e-6)
    assert n == 21  # 80..100 um inclusive, samples after the maximum excluded
    assert m == pytest.approx(90.0)
    assert s == pytest.approx(np.std(np.arange(80, 101), ddof=1))
    m5, _, n5 = window_mean(u, y, 5e-6)
    assert (m5, n5) == (pytest.approx(97.5), 6)


def test_linear_compliance_is_subtracted():
    df, meta = read_hpt(HAND)
    c = 0.002e-6 / 1e6  # 0.002 um/MPa
    res = reduce_hpt(df, meta, compliance=RigCompliance.linear(c))
    d = res.data
    expected = d["displacement_raw_m"] - c * d["shear_stress_Pa"]
    assert d["displacement_m"].to_numpy() == pytest.approx(expected.to_numpy(), abs=1e-15)


def test_compliance_curve_file(tmp_path):
    p = tmp_path / "c.csv"
    p.write_text("# dry run\nshear_stress [MPa],displacement [um]\n0,0\n100,1.0\n200,1.5\n300,2.0\n")
    rc = RigCompliance.from_file(p)
    assert rc(np.array([50e6, 150e6, 250e6])) == pytest.approx([0.5e-6, 1.25e-6, 1.75e-6])
    # beyond the curve: extended with the slope of the upper fifth (0.005 um/MPa)
    assert rc(np.array([400e6]))[0] == pytest.approx(2.5e-6)
    assert rc.extrapolated


# --- synthetic data ----------------------------------------------------------------------------
def test_synth_then_reduce_recovers_generating_friction():
    from torlab.synth.hpt import HptNoise, HptRig, paper_c_design, simulate_hpt, write_hpt_log

    rig, noise = HptRig(), HptNoise()
    specs = paper_c_design(seed=11)
    picked = [s for s in specs if s.temperature_C == 25.0][::3]
    assert len(picked) >= 8
    for spec in picked:
        ch = simulate_hpt(spec, rig, noise)
        text = write_hpt_log(spec, ch, rig)
        df, meta = read_hpt(io.StringIO(text), name=spec.name)
        # the virtual rig's compliance is known exactly: subtract it as a curve
        tau = np.linspace(0, 500e6, 501)
        from torlab.synth.hpt import rig_compliance_u

        rc = RigCompliance(tau, rig_compliance_u(tau, rig), source="truth")
        res = reduce_hpt(df, meta, compliance=rc)
        f_true = ch["tau_true_Pa"][-1] / spec.sigma
        # noise of the window mean: white force noise averages out over n samples; the slow
        # Ornstein-Uhlenbeck strength fluctuation (correlation time tc) over a window of duration Tw
        # leaves a standard deviation of about rel * sqrt(2 tc / Tw)
        tw = res.window_m / spec.rate
        sd_ou = noise.strength_ou_rel * math.sqrt(min(1.0, 2 * noise.strength_ou_time_s / tw))
        sd_white = (noise.arm_force_rel + noise.arm_force_abs_N / 300) / math.sqrt(res.n_window)
        sd = f_true * math.hypot(sd_ou, sd_white) + noise.normal_force_drift_rel * f_true
        assert abs(res.f_window - f_true) < 4 * sd, spec.name
        # the elastic branch is recovered too: the layer displacement matches the truth
        assert np.max(np.abs(res.data["displacement_m"].to_numpy() - ch["u_layer_true_m"])) < 0.5e-6


def test_synth_is_seeded_and_deterministic():
    from torlab.synth.hpt import paper_c_design, simulate_hpt

    a = simulate_hpt(paper_c_design(seed=5)[0])
    b = simulate_hpt(paper_c_design(seed=5)[0])
    c = simulate_hpt(paper_c_design(seed=6)[0])
    assert np.array_equal(a["arm_force_N"], b["arm_force_N"])
    assert not np.array_equal(a["arm_force_N"], c["arm_force_N"])


# --- column map for another rig ----------------------------------------------------------------
def test_column_map_reads_other_rig_like_native(tmp_path):
    other = tmp_path / "rig2.csv"
    other.write_text(
        "Export of rig 2\n"
        "Zeit;Fn;M;phi_enc;motor_steps\n"
        "s;kN;Nm;deg;counts\n"
        "0,0;63,6172512;0;0,00;0\n"
        "1,0;63,6172512;50;0,01;20\n"
        "2,0;63,6172512;100;0,02;40\n"
        "3,0;31,8086256;100;0,03;60\n")
    mp = tmp_path / "rig2.yaml"
    mp.write_text(
        "delimiter: ';'\n"
        "decimal: ','\n"
        "header_line: 2\n"
        "skip_lines_after_header: 1\n"
        "columns:\n"
        "  time: {name: Zeit, unit: s}\n"
        "  normal_force: {name: Fn, unit: kN}\n"
        "  torque: {name: M, unit: N*m}\n"
        "  encoder_angle: {name: phi_enc, unit: deg}\n"
        "  motor_angle: {name: motor_steps, scale: 0.00045 deg}\n"
        "metadata:\n"
        "  r1: 3 mm\n"
        "  r2: 6 mm\n"
        "  product: other-rig\n")
    df2, meta2 = read_hpt(other, mp)
    res2 = reduce_hpt(df2, meta2)
    res1 = reduce_hpt(*read_hpt(HAND))
    for col in ("normal_stress_Pa", "shear_stress_Pa", "friction", "displacement_m"):
        assert res2.data[col].to_numpy() == pytest.approx(res1.data[col].to_numpy(), rel=1e-9, abs=1e-12)
    assert meta2.product == "other-rig"


def test_column_map_missing_column_names_the_map(tmp_path):
    other = tmp_path / "rig2.csv"
    other.write_text("t,F,M,a\n0,1,0,0\n1,1,1,1\n")
    mp = tmp_path / "m.yaml"
    mp.write_text("columns:\n  time: {name: t, unit: s}\n  normal_force: {name: Fz, unit: kN}\n"
                  "  torque: {name: M, unit: N*m}\n  encoder_angle: {name: a, unit: deg}\n"
                  "metadata: {r1: 3 mm, r2: 6 mm}\n")
    with pytest.raises(TorlabInputError, match="'Fz'"):
        read_hpt(other, mp)


# --- bad input: one line naming file and line, exit code 2 ------------------------------------
GOOD = HAND.read_text()
HEADER_END = GOOD.index("time [s]")


def _variant(kind: str) -> tuple[str, int | None, str]:
    """(file text, expected line, expected message fragment)."""
    head, table = GOOD[:HEADER_END], GOOD[HEADER_END:]
    rows = table.splitlines()
    if kind == "empty":
        return "", None, "empty"
    if kind == "truncated":
        return head + "\n".join(rows[:-1]) + "\n3,31.8086256,400\n", 15, "truncated"
    if kind == "missing_column":
        cut = "\n".join(",".join(r.split(",")[:2] + r.split(",")[3:]) for r in rows)
        return head + cut + "\n", 11, "missing column"
    if kind == "text_in_number":
        rows[2] = rows[2].replace("200", "2O0")
        return head + "\n".join(rows) + "\n", 13, "not a number"
    if kind == "zero_load":
        rows[3] = rows[3].replace("63.6172512", "0")
        return head + "\n".join(rows) + "\n", 14, "must be positive"
    if kind == "negative_load":
        rows[2] = rows[2].replace("63.6172512", "-5")
        return head + "\n".join(rows) + "\n", 13, "must be positive"
    if kind == "non_monotone_angle":
        rows[3] = rows[3].replace("0.01800", "0.00100")
        return head + "\n".join(rows) + "\n", 14, "backwards"
    if kind == "unknown_unit":
        rows[0] = rows[0].replace("arm_force [N]", "arm_force [newtonz]")
        return head + "\n".join(rows) + "\n", 11, "unknown unit"
    if kind == "wrong_unit":
        rows[0] = rows[0].replace("normal_force [kN]", "normal_force [mm]")
        return head + "\n".join(rows) + "\n", 11, "not a force"
    if kind == "wrong_delimiter":
        return head + "\n".join(r.replace(",", ";") for r in rows) + "\n", 11, "separated by ';'"
    if kind == "unknown_header_key":
        return head.replace("# operator", "# opertor").replace("# notes", "# colour: red\n# notes") + table, 10, "unknown header key"
    raise AssertionError(kind)


BAD_KINDS = ["empty", "truncated", "missing_column", "text_in_number", "zero_load", "negative_load",
             "non_monotone_angle", "unknown_unit", "wrong_unit", "wrong_delimiter", "unknown_header_key"]


@pytest.mark.parametrize("kind", BAD_KINDS)
def test_bad_input_library_error_names_file_and_line(kind, tmp_path):
    text, line, frag = _variant(kind)
    p = tmp_path / f"{kind}.txt"
    p.write_text(text)
    with pytest.raises(TorlabInputError) as ei:
        read_hpt(p)
    e = ei.value
    assert e.path == str(p)
    assert frag in str(e)
    if line is not None:
        assert e.line == line, str(e)


@pytest.mark.parametrize("kind", BAD_KINDS)
def test_bad_input_cli_one_line_exit_2(kind, tmp_path, cli):
    text, line, _frag = _variant(kind)
    p = tmp_path / f"{kind}.txt"
    p.write_text(text)
    before = sha(p)
    r = cli("hpt", "reduce", p, "-o", tmp_path / "out")
    assert r.exit_code == 2, r.output
    lines = error_lines(r)
    assert len(lines) == 1, lines
    assert lines[0].startswith("error: ")
    assert str(p) in lines[0]
    if line is not None:
        assert f"{p}:{line}" in lines[0]
    assert "Traceback" not in r.output
    assert not (tmp_path / "out").exists()
    assert sha(p) == before


# --- CLI end to end ----------------------------------------------------------------------------
def test_cli_reduce_writes_results_and_refuses_overwrite(tmp_path, cli):
    import pandas as pd

    from torlab.outputs import MANIFEST

    raw = tmp_path / "raw"
    raw.mkdir()
    r = cli("synth", "hpt", "-o", raw / "gen", "--seed", "3")
    assert r.exit_code == 0, r.output
    logs = sorted((raw / "gen").glob("hpt_OFM1_*_25C.txt"))
    hashes = {p: sha(p) for p in logs}
    out = tmp_path / "out"
    r = cli("hpt", "reduce", *logs, "-o", out, "--compliance", raw / "gen" / "rig_compliance.csv")
    assert r.exit_code == 0, r.output
    s = pd.read_csv(out / "summary.csv")
    assert len(s) == len(logs)
    assert set(s["displacement_source"]) == {"motor"}
    assert (out / "hpt.png").stat().st_size > 10_000
    for p in logs:
        red = pd.read_csv(out / f"{p.stem}_reduced.csv")
        assert {"shear_stress_Pa", "friction", "displacement_m", "normal_stress_Pa"} <= set(red.columns)
        assert np.isfinite(red.select_dtypes("number").to_numpy()).all()
    manifest = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    # the manifest records the command as invoked (not the test runner's own argv)
    assert manifest["command"].startswith("torlab hpt reduce ")
    assert manifest["command"].endswith(f"--compliance {raw / 'gen' / 'rig_compliance.csv'}")
    # raw files untouched
    assert all(sha(p) == h for p, h in hashes.items())
    # a second run refuses to overwrite ...
    r = cli("hpt", "reduce", *logs, "-o", out)
    assert r.exit_code == 2
    assert "--force" in error_lines(r)[0]
    # ... unless --force
    r = cli("hpt", "reduce", logs[0], "-o", out, "--force")
    assert r.exit_code == 0, r.output
    assert len(pd.read_csv(out / "summary.csv")) == 1
    assert not list(out.glob(f"{logs[1].stem}_reduced.csv"))  # old results replaced as a whole


def test_cli_refuses_output_folder_holding_inputs_or_foreign_files(tmp_path, cli):
    raw = tmp_path / "data"
    raw.mkdir()
    (raw / "hand.txt").write_text(GOOD)
    r = cli("hpt", "reduce", raw / "hand.txt", "-o", raw, "--force")
    assert r.exit_code == 2
    assert "contains the input" in error_lines(r)[0]
    other = tmp_path / "mine"
    other.mkdir()
    (other / "notes.txt").write_text("my notes")
    r = cli("hpt", "reduce", raw / "hand.txt", "-o", other, "--force")
    assert r.exit_code == 2
    assert "notes.txt" in error_lines(r)[0]
    assert (other / "notes.txt").read_text() == "my notes"


def test_cli_bad_options_one_line(tmp_path, cli):
    r = cli("hpt", "reduce", HAND, "-o", tmp_path / "o", "--window", "20 kg")
    assert r.exit_code == 2 and len(error_lines(r)) == 1 and "not a length" in r.output
    r = cli("hpt", "reduce", HAND, "-o", tmp_path / "o", "--source", "laser")
    assert r.exit_code == 2 and len(error_lines(r)) == 1
    r = cli("hpt", "reduce", tmp_path / "missing.txt", "-o", tmp_path / "o")
    assert r.exit_code == 2 and "not found" in error_lines(r)[0]
    r = cli("hpt", "reduce", HAND, "-o", tmp_path / "o", "--no-such-option")
    assert r.exit_code == 2 and len(error_lines(r)) == 1, r.output


def test_documented_example_parses():
    """The complete example in docs/formats/hpt.md is a valid log."""
    from conftest import ROOT

    doc = (ROOT / "docs" / "formats" / "hpt.md").read_text()
    block = doc.split("```text\n", 1)[1].split("```", 1)[0]
    df, meta = read_hpt(io.StringIO(block), name="hpt.md example")
    assert meta.product == "OFM1" and meta.applied_amount_unit == "uL"
    assert meta.applied_amount == pytest.approx(4e-9)
    assert meta.rig_compliance == pytest.approx(0.012e-12)
    assert meta.extra == {"x_batch": "2022-017"}
    res = reduce_hpt(df, meta)
    assert res.compliance.startswith("header")
    assert 0.2 < res.f_window < 0.3


def test_protocol_summary_table_in_blocks_is_the_table_of_all_rows(monkeypatch):
    """``data/hpt_summary.csv`` gathered a few runs at a time (blocks of 3 here) is the table
    made of all rows at once: the same columns in the same order (an optional figure missing
    in a whole block), the same types and the same CSV; the summary's f over the window of
    every run."""
    import types

    import pandas as pd

    import torlab.instruments.hpt as hpt

    rows = []
    for i in range(8):
        r = {"file": f"run{i}.txt", "product": "P", "f_window": 0.1 + i / 100, "n_points": 10 + i}
        if i in (4, 7):  # given in the second and the last block only
            r["applied_amount"] = float(i)
        if i != 5:
            r["ok"] = i % 2 == 0
        rows.append(r)
    labelled = [(r["file"], types.SimpleNamespace(key_numbers=r)) for r in rows]

    class Dest:
        def write_csv(self, name, df, **kw):
            self.name, self.df, self.kw = name, df, kw

    whole = pd.DataFrame([dict(r) for r in rows])
    monkeypatch.setattr(hpt, "SUMMARY_BLOCK", 3)
    dest = Dest()
    summary = hpt.write_section(dest, labelled)
    assert dest.name == "data/hpt_summary.csv"
    assert list(dest.df.columns) == list(whole.columns)
    assert list(dest.df.dtypes) == list(whole.dtypes)
    assert dest.df.to_csv(index=False) == whole.to_csv(index=False)
    assert summary == {"files": 8, "f_window": {r["file"]: r["f_window"] for r in rows}}
