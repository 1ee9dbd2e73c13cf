"""MTM/ETM reductions: time tests after application (Paper B, Fig. 5.9), curves, CLI."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import DATA, ROOT, error_lines, real_pcs_file, sha

from torlab.errors import TorlabInputError
from torlab.parsers.pcs import read_pcs
from torlab.reduce.mtm import reduce_pcs, time_test_metrics

MTM = DATA / "pcs" / "mtm_quirks.txt"
ETM = DATA / "pcs" / "etm_quirks.txt"


def _hand_curve() -> tuple[np.ndarray, np.ndarray]:
    """0.4 until t = 19 s, 0.05 for t = 20..39 s, a ramp to 0.2 over t = 40..59 s, then 0.2."""
    t = np.arange(100.0)
    mu = np.full(100, 0.2)
    mu[:20] = 0.4
    mu[20:40] = 0.05
    mu[40:60] = 0.05 + 0.15 * (t[40:60] - 40) / 19
    return t, mu


def test_time_test_hand_calculation():
    t, mu = _hand_curve()
    r = time_test_metrics(t, mu, smooth=0, tail=30)
    # application: the last sample before the coefficient has fallen by a quarter of the drop
    assert r.application_source == "detected" and r.application_time_s == 19
    assert r.pre_application_mean == pytest.approx(0.4)
    assert (r.minimum, r.minimum_time_s) == (pytest.approx(0.05), 20)
    assert r.plateau == pytest.approx(0.2)
    # recovery level 0.05 + 0.9 (0.2 - 0.05) = 0.185: first reached at t = 58 (0.19211)
    assert r.recovery_level == pytest.approx(0.185)
    assert r.recovered and r.recovery_at_s == 58 and r.recovery_time_s == 58 - 19
    assert r.mean_after_recovery == pytest.approx((0.05 + 0.15 * 18 / 19 + 0.2 * 41) / 42)
    # below 0.15: t = 20..39 (20 s) and the ramp up to t = 52 (13 s)
    assert r.time_below_threshold_s == pytest.approx(33.0)
    assert r.mean_after_application == pytest.approx(np.mean(mu[19:]))
    assert r.evaluated_until_s == 99 and r.n == 81


def test_time_test_options():
    t, mu = _hand_curve()
    r = time_test_metrics(t, mu, smooth=0, tail=30, application_time=20.0)
    assert r.application_source == "given" and r.recovery_time_s == 38
    r = time_test_metrics(t, mu, smooth=0, tail=30, recovery_level=0.15)
    assert r.recovery_at_s == 53  # 0.05 + 0.15 * 13 / 19 = 0.1526
    r = time_test_metrics(t, mu, smooth=0, tail=10, duration=50)
    assert r.evaluated_until_s == 69
    r = time_test_metrics(t, mu, smooth=0, tail=30, threshold=0.1)
    assert r.time_below_threshold_s == pytest.approx(20.0 + 7.0)  # ramp < 0.1 up to t = 46
    # a one-sample spike makes the raw minimum; the 5 s running median removes it
    mu2 = mu.copy()
    mu2[70] = 0.0
    assert time_test_metrics(t, mu2, smooth=0, tail=20).minimum == 0.0
    assert time_test_metrics(t, mu2, smooth=5, tail=20).minimum == pytest.approx(0.05)
    with pytest.raises(TorlabInputError, match="outside the record"):
        time_test_metrics(t, mu, application_time=500)
    with pytest.raises(TorlabInputError, match="at least 5 samples"):
        time_test_metrics(t[:3], mu[:3])


def test_time_test_over_application_and_no_application():
    t = np.arange(600.0)
    mu = np.where(t < 60, 0.45, 0.03)
    r = time_test_metrics(t, mu, smooth=0)
    assert r.application_time_s == 59 and not r.recovered
    assert math.isnan(r.recovery_time_s) and math.isnan(r.mean_after_recovery)
    assert r.time_below_threshold_s == pytest.approx(540.0)
    flat = 0.1 + 0.002 * np.sin(t)
    r = time_test_metrics(t, flat)
    assert r.application_source.startswith("start") and r.application_time_s == 0
    assert any("no drop" in n for n in r.notes)


def test_time_test_noise_free_synthetic_matches_closed_form():
    """The reduction of the noise-free generating curve against the closed-form truth."""
    from torlab.synth.mtm import mu_true, paper_b_time_tests, true_figures

    for spec in paper_b_time_tests():
        t = np.arange(1.0, spec.duration_s + 0.5)
        r = time_test_metrics(t, mu_true(spec, t), smooth=0)
        tr = true_figures(spec)
        assert r.application_time_s == tr["application_time_s"]
        assert r.minimum == pytest.approx(tr["minimum"], abs=2e-4)
        assert r.recovered == tr["recovered"]
        if tr["recovered"]:
            # by the end the curve is within exp(-(1200 - dwell - 120 s)/tau_r) of its asymptote
            # (at most 1.1e-4 for TOR A): plateau and recovery level within that, the crossing
            # within one sample plus the shift of the level
            rest = (tr["plateau"] - tr["minimum"]) * math.exp(
                -(spec.duration_s - spec.application_time_s - spec.dwell_s - 120) / spec.recovery_tau_s)
            assert r.plateau == pytest.approx(tr["plateau"], abs=rest + 1e-6)
            assert r.recovery_time_s == pytest.approx(tr["recovery_time_s"], abs=1.5)
        # sampled every second: each crossing is within one sample
        assert r.time_below_threshold_s == pytest.approx(tr["time_below_threshold_s"], abs=2.0)


def test_sample_data_reduce_close_to_truth():
    """Committed sample_data/mtm (noisy) against its truth.yaml, within noise-based bounds."""
    from torlab.yamlio import load_yaml

    folder = ROOT / "sample_data" / "mtm"
    truth = load_yaml(folder / "truth.yaml").data
    assert len(truth["runs"]) == 5
    for run in truth["runs"]:
        p = run["parameters"]
        tr = run["truth"]
        df, meta = read_pcs(folder / run["file"])
        assert meta.instrument == "MTM" and len(meta.steps) == 1
        red = reduce_pcs(df, meta)
        r = red.time_tests[0]
        assert r.application_time_s == pytest.approx(tr["application_time_s"], abs=1.0)
        assert r.recovered == tr["recovered"], run["file"]
        # slow fluctuation sd at the plateau (the 10 s median does not average a 20 s process)
        sd = p["ou_sd"] * math.sqrt(max(tr["plateau"], 0.01) / 0.2) + p["noise_sd"] / 3
        assert r.plateau == pytest.approx(tr["plateau"], abs=4 * sd)
        assert r.minimum == pytest.approx(tr["minimum"], abs=5 * sd)
        if tr["recovered"]:
            slope = 0.1 * (tr["plateau"] - tr["minimum"]) / p["recovery_tau_s"]  # at 90 %
            assert r.recovery_time_s == pytest.approx(tr["recovery_time_s"], abs=4 * sd / slope)
            assert r.mean_after_recovery == pytest.approx(tr["plateau"], abs=4 * sd)


def test_reduce_pcs_curves_from_quirk_files():
    df, meta = read_pcs(MTM)
    red = reduce_pcs(df, meta)
    assert set(red.curves) == {"timed", "stribeck"}
    st = red.curves["stribeck"]
    assert st["rolling_speed_m_s"].tolist() == pytest.approx([1.99997, 1.00004, 0.49996, 0.20002,
                                                              0.09998])
    assert st["traction_coefficient"].tolist() == pytest.approx([0.02, 0.03, 0.05, 0.08, 0.11])
    assert st["srr"].tolist() == pytest.approx([0.05] * 5)
    assert list(red.steps["step"]) == [1, 3]
    assert red.steps["ball_load_N"].tolist() == pytest.approx([20.0, 20.0])
    df, meta = read_pcs(ETM)
    red = reduce_pcs(df, meta)
    tr = red.curves["traction"]
    assert len(tr) == 10
    # mu(SRR) uses the signed coefficient: negative at the negative SRR point
    neg = tr["srr"] < 0
    assert tr.loc[neg, "traction_coefficient"].tolist() == pytest.approx([-0.005, -0.005])
    assert tr.loc[~neg, "traction_coefficient"].min() > 0


@pytest.mark.realdata
def test_real_etm_traction_curves_odd_in_srr():
    df, meta = read_pcs(real_pcs_file("ETM_slim_mapper.txt"))
    red = reduce_pcs(df, meta)
    tr = red.curves["traction"]
    assert tr["step"].nunique() == 500
    hi = tr["srr"] > 0.1
    lo = tr["srr"] < -0.001
    assert (tr.loc[hi, "traction_coefficient"] > 0.03).mean() > 0.99  # a few real outliers
    # the 234 negative-SRR points (near SRR = 0, and a glitch at -27.8 % on line 7139) mostly
    # have negative signed coefficients (the force is signed; as written all are >= 0)
    assert lo.sum() == 234
    assert (tr.loc[lo, "traction_coefficient"] < 0).mean() > 0.9
    assert (df.loc[df["srr"] < -0.001, "traction_coefficient"] >= 0).all()


# --- CLI ------------------------------------------------------------------------------------------
def test_cli_mtm_reduce_writes_results_and_refuses_overwrite(tmp_path, cli):
    import pandas as pd

    raw = tmp_path / "raw"
    r = cli("synth", "mtm", "-o", raw, "--seed", "5")
    assert r.exit_code == 0, r.output
    files = sorted(raw.glob("mtm_*.txt"))
    assert len(files) == 5
    hashes = {p: sha(p) for p in files}
    out = tmp_path / "out"
    r = cli("mtm", "reduce", *files, MTM, "-o", out, "--duration", "20 min", "--no-plot")
    assert r.exit_code == 0, r.output
    # the synthetic files mark the application ("Time test after application"); the quirk
    # file's timed step does not, so it is a plain timed run unless asked for
    tt = pd.read_csv(out / "time_tests.csv")
    assert len(tt) == 5 and MTM.name not in set(tt["file"])
    assert "no application marked" in r.output
    r = cli("mtm", "reduce", *files, MTM, "-o", out, "--duration", "20 min", "--force",
            "--after-application")
    assert r.exit_code == 0, r.output
    tt = pd.read_csv(out / "time_tests.csv")
    assert len(tt) == 6 and tt["recovered"].sum() == 4
    assert (tt.loc[tt["file"] != MTM.name, "application_time_s"] == 60).all()
    assert np.isfinite(tt["minimum"]).all()
    s = pd.read_csv(out / "summary.csv")
    assert len(s) == 7 and set(s["step_type"]) == {"timed", "stribeck"}
    assert (out / "mtm_quirks_stribeck.png").stat().st_size > 10_000
    assert (out / f"{files[0].stem}_time_test.png").exists()
    assert (out / f"{files[0].stem}_metadata.json").exists()
    timed = pd.read_csv(out / f"{files[0].stem}_timed.csv")
    assert {"step", "traction_coefficient", "step_time_s", "ball_load_N", "line"} <= set(timed.columns)
    assert all(sha(p) == h for p, h in hashes.items())
    r = cli("mtm", "reduce", files[0], "-o", out)
    assert r.exit_code == 2 and "--force" in error_lines(r)[0]
    r = cli("mtm", "reduce", files[0], "-o", out, "--force", "--application-time", "60 s",
            "--no-plot")
    assert r.exit_code == 0, r.output
    assert pd.read_csv(out / "time_tests.csv")["application_source"].tolist() == ["given"]


def _bad_variant(kind: str) -> tuple[bytes, int | None, str]:
    lines = MTM.read_bytes().decode("utf-8-sig").split("\r\n")
    if kind == "empty":
        return b"", None, "empty"
    if kind == "truncated":
        lines[21] = lines[21][:12]
        return "\r\n".join(lines).encode(), 22, "truncated"
    if kind == "text_in_number":
        lines[18] = lines[18].replace("\t40.0\t", "\tforty\t", 1)
        return "\r\n".join(lines).encode(), 19, "not a number"
    if kind == "unknown_unit":
        lines[15] = lines[15].replace("Wear (um)", "Wear (uq)")
        return "\r\n".join(lines).encode(), 16, "unknown unit"
    if kind == "missing_column":  # no coefficient nor force: nothing to reduce
        for i in (15, 29):
            lines[i] = lines[i].replace("Traction Coeff (-)", "Coeff X (-)").replace(
                "Traction Force (N)", "Force X (N)")
        return "\r\n".join(lines).encode(), None, "no traction"
    if kind == "wrong_delimiter":
        return "\r\n".join(ln.replace("\t", ",") for ln in lines).encode(), 2, "tab-separated"
    if kind == "not_pcs":
        return b"time\tmu\n0\t0.1\n", 1, "not a PCS Instruments export"
    raise AssertionError(kind)


@pytest.mark.parametrize("kind", ["empty", "truncated", "text_in_number", "unknown_unit",
                                  "missing_column", "wrong_delimiter", "not_pcs"])
def test_cli_bad_input_one_line_exit_2(kind, tmp_path, cli):
    data, line, frag = _bad_variant(kind)
    p = tmp_path / f"{kind}.txt"
    p.write_bytes(data)
    before = sha(p)
    r = cli("mtm", "reduce", p, "-o", tmp_path / "out")
    assert r.exit_code == 2, r.output
    lines = error_lines(r)
    assert len(lines) == 1, lines
    assert lines[0].startswith("error: ") and str(p) in lines[0]
    if line is not None:
        assert f"{p}:{line}:" in lines[0], lines[0]
    assert frag in lines[0]
    assert "Traceback" not in r.output
    assert not (tmp_path / "out").exists()
    assert sha(p) == before


def test_cli_bad_options_one_line(tmp_path, cli):
    for args, frag in ((["--threshold", "-1"], "--threshold"), (["--instrument", "HFRR"], "--instrument"),
                       (["--smooth", "3 kg"], "not a time"), (["--recovery-fraction", "2"], "(0, 1]"),
                       (["--application-time", "5000 s"], "outside the record")):
        r = cli("mtm", "reduce", MTM, "-o", tmp_path / "o", *args)
        assert r.exit_code == 2, (args, r.output)
        assert len(error_lines(r)) == 1 and frag in error_lines(r)[0], r.output
