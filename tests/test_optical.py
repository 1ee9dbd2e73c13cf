"""Optical tribometer: torlab-optical format, windowed reduction (Paper A), Tab. 5.2, CLI."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from conftest import DATA, ROOT, error_lines, real_pcs_file, sha

from torlab.errors import TorlabInputError
from torlab.parsers.optical import read_optical
from torlab.reduce.optical import classify_test, fold_traction, reduce_ehd2, reduce_optical_log

DOC = (ROOT / "docs" / "formats" / "optical.md").read_text(encoding="utf-8")
EXAMPLE = DOC.split("```text\n", 1)[1].split("```", 1)[0]


def test_documented_example_reduces_by_hand():
    df, meta = read_optical(io.StringIO(EXAMPLE), name="optical.md example")
    assert meta.ball_radius == pytest.approx(12.7e-3) and meta.test == "traction"
    assert meta.extra == {"x_camera": "25 fps"}
    assert len(df) == 9 and df["line"].tolist() == list(range(12, 21))
    assert df["film_thickness_m"].notna().sum() == 2
    res = reduce_optical_log(io.StringIO(EXAMPLE), window=0.004, name="example")
    p = res.points
    assert p["condition"].tolist() == [1, 2]  # condition 0 is between conditions
    assert p["n_samples"].tolist() == [4, 4] and p["window_complete"].all()
    # condition 1: ball 0.4875, disc 0.5125 -> U = 0.5 m/s, SRR = -0.025 / 0.5 = -5 %
    ub = np.mean([0.4875, 0.4876, 0.4875, 0.4874])
    ud = np.mean([0.5125, 0.5124, 0.5125, 0.5126])
    assert p["rolling_speed_m_s"].iloc[0] == pytest.approx((ub + ud) / 2)
    assert p["srr"].iloc[0] == pytest.approx((ub - ud) / ((ub + ud) / 2))
    mu1 = np.mean([-4.504 / 90.10, -4.506 / 90.12, -4.503 / 90.08, -4.505 / 90.11])
    assert p["traction_coefficient"].iloc[0] == pytest.approx(mu1, rel=1e-12)
    assert p["film_thickness_m"].iloc[0] == pytest.approx(12.1e-9)
    assert p["n_film"].tolist() == [1, 1]
    mu2 = np.mean([4.504 / 90.09, 4.506 / 90.11, 4.505 / 90.10, 4.504 / 90.12])
    assert p["traction_coefficient"].iloc[1] == pytest.approx(mu2, rel=1e-12)
    assert (p["first_line"].tolist(), p["last_line"].tolist()) == ([12, 17], [15, 20])
    # the header says traction: the +-5 % pair is folded and symmetric
    assert res.test == "traction" and res.test_source == "given"
    assert res.symmetry["pairs"] == 1 and res.symmetry["symmetric"]
    assert res.symmetry["max_abs_diff"] == pytest.approx(abs(mu2 + mu1))


def test_window_is_the_end_of_each_condition():
    """Two conditions of 3 s at 100 Hz; a 1 s window averages exactly the last 100 samples."""
    t = np.arange(600) / 100.0
    cond = np.where(t < 3, 1, 2)
    # friction ramps during the first 2 s of each condition, then holds 3.0 / 6.0 N at 100 N
    tl = np.where(cond == 1, t, t - 3)
    f = np.where(cond == 1, 3.0, 6.0) * np.minimum(1.0, tl / 2.0)
    rows = "\n".join(f"{a:.2f},{c},0.98,1.02,100,{x:.6f}" for a, c, x in zip(t, cond, f, strict=True))
    log = ("# torlab-optical 1\ntime [s],condition,ball_speed [m/s],disc_speed [m/s],"
           "normal_load [N],friction_force [N]\n" + rows + "\n\n# end of run\n")
    res = reduce_optical_log(io.StringIO(log), window=1.0, name="w")
    p = res.points
    assert p["n_samples"].tolist() == [100, 100]
    assert p["traction_coefficient"].tolist() == pytest.approx([0.03, 0.06])
    assert p["srr"].tolist() == pytest.approx([-0.04, -0.04])
    assert p["rolling_speed_m_s"].tolist() == pytest.approx([1.0, 1.0])
    # a window longer than a condition averages it whole and says so
    res = reduce_optical_log(io.StringIO(log), window=5.0, name="w")
    assert not res.points["window_complete"].any() and "shorter than" in res.warnings[0]
    # set-point columns instead of a condition number give the same points
    log2 = ("# torlab-optical 1\ntime [s],load_set [N],ball_speed [m/s],disc_speed [m/s],"
            "normal_load [N],friction_force [N]\n" + "\n".join(
                f"{a:.2f},{50 * c},0.98,1.02,100,{x:.6f}" for a, c, x in zip(t, cond, f, strict=True)))
    p2 = reduce_optical_log(io.StringIO(log2), window=1.0, name="w2").points
    assert p2["traction_coefficient"].tolist() == pytest.approx([0.03, 0.06])
    assert p2["load_set_N"].tolist() == [50.0, 100.0]


def _mu(U, s):
    return (0.02 + 0.08 / (1 + (np.asarray(U) / 0.3) ** 1.5)) * np.tanh(np.asarray(s) / 0.01)


def _h(U):
    return 40e-9 * np.asarray(U) ** 0.67


def _synthetic(conds, seed=3):
    from torlab.synth.optical import OpticalTest, write_optical_log

    test = OpticalTest("t", "traction", "rough", "water", tuple(conds))
    buf = io.StringIO()
    truth = write_optical_log(buf, test, _mu, _h, seed=seed)
    return buf.getvalue(), truth


def test_synthetic_log_recovers_analytic_truth():
    from torlab.synth.optical import OpticalCondition, OpticalRig

    rig = OpticalRig()
    conds = [OpticalCondition(u, s, 90.0, 6.0) for u in (0.25, 1.0) for s in (-0.05, -0.01, 0.0,
                                                                             0.01, 0.05)]
    text, truth = _synthetic(conds)
    res = reduce_optical_log(io.StringIO(text), name="synth")
    p = res.points
    assert len(p) == 10 and p["window_complete"].all() and (p["n_samples"] == 4000).all()
    for row, tr in zip(p.itertuples(), truth, strict=True):
        # the speeds settle (servo time constant 0.25 s) long before the window: the rolling
        # speed and SRR are the set ones within the speed quantum / noise averaged over 4000 samples
        assert row.rolling_speed_m_s == pytest.approx(tr["rolling_speed_m_s"], rel=1e-3)
        assert row.srr == pytest.approx(tr["srr"], abs=2e-4)
        # mu: the truth at the measured point; force noise 0.02 N / 90 N / sqrt(4000)
        assert row.traction_coefficient == pytest.approx(float(_mu(row.rolling_speed_m_s, row.srr)),
                                                         abs=5e-4)
        assert row.traction_coefficient == pytest.approx(tr["traction_coefficient"], abs=0.01)
        # film: 100 frames in the window, 1 nm noise
        assert row.film_thickness_m == pytest.approx(tr["film_thickness_m"], abs=0.6e-9)
        assert row.n_film == 100
        assert row.normal_load_N == pytest.approx(90.0, rel=rig.load_drift_rel + 1e-3)
    assert res.test == "traction" and res.symmetry["symmetric"]
    assert res.symmetry["pairs"] == 4
    f = res.folded
    assert sorted(f["srr"].round(3).unique().tolist()) == [0.0, 0.01, 0.05]
    # chunking does not change the result
    p_small = reduce_optical_log(io.StringIO(text), name="synth", chunksize=7_000).points
    assert np.array_equal(p_small["traction_coefficient"].to_numpy(),
                          p["traction_coefficient"].to_numpy())
    assert np.array_equal(p_small["film_thickness_m"].to_numpy(), p["film_thickness_m"].to_numpy())


def test_torque_column_and_friction_sign():
    log = ("# torlab-optical 1\n# ball_radius: 12.5 mm\n# friction_sign: -1\n"
           "time [s],condition,ball_speed [m/s],disc_speed [m/s],normal_load [N],torque [N*mm]\n"
           "0,1,1.01,0.99,80,-50\n0.5,1,1.01,0.99,80,-50\n1.0,1,1.01,0.99,80,-50\n")
    p = reduce_optical_log(io.StringIO(log), window=1.0, name="tq").points
    # mu = -(-0.05 N m) / (0.0125 m x 80 N) = 0.05
    assert p["traction_coefficient"].iloc[0] == pytest.approx(0.05)
    assert p["srr"].iloc[0] == pytest.approx(0.02)


def test_fold_traction_symmetry_check_by_hand():
    import pandas as pd

    pts = pd.DataFrame({"rolling_speed_m_s": [1.0] * 5 + [2.0] * 2,
                        "srr": [-0.05, -0.01, 0.0, 0.0102, 0.05, -0.02, 0.02],
                        "traction_coefficient": [-0.060, -0.030, 0.001, 0.031, 0.058, -0.02, 0.04]})
    folded, sym = fold_traction(pts)
    assert sym["pairs"] == 3 and sym["unpaired"] == 0
    # pairs at 1 m/s: |0.058 - 0.060| and |0.031 - 0.030| within 10 %; at 2 m/s 0.04 vs 0.02 not
    assert sym["max_abs_diff"] == pytest.approx(0.02)
    assert not sym["symmetric"]
    ok = folded.dropna(subset=["difference"])
    assert ok["symmetric"].tolist() == ["yes", "yes", "no"]
    assert ok["traction_coefficient"].tolist() == pytest.approx([0.0305, 0.059, 0.03])
    folded, sym = fold_traction(pts.iloc[:5])
    assert sym["symmetric"] and sym["pairs"] == 2


def test_classify_test_types_of_tab_5_2():
    import pandas as pd

    film = pd.DataFrame({"srr": [0.0, 0.001], "rolling_speed_m_s": [0.1, 1.0],
                         "film_thickness_m": [10e-9, 50e-9], "traction_coefficient": [0.01, 0.01]})
    assert classify_test(film)[0] == "film_thickness"
    strib = pd.DataFrame({"srr": [0.05, 0.05, 0.0502], "rolling_speed_m_s": [0.1, 0.5, 2.0],
                          "traction_coefficient": [0.1, 0.05, 0.02]})
    assert classify_test(strib)[0] == "stribeck"
    trac = pd.DataFrame({"srr": [-0.05, 0.0, 0.05], "rolling_speed_m_s": [0.5] * 3,
                         "traction_coefficient": [-0.1, 0, 0.1]})
    assert classify_test(trac) == ("traction", "detected")
    assert classify_test(trac, lubricant="none")[0] == "dry_traction"
    assert classify_test(trac, given="Film thickness") == ("film_thickness", "given")
    with pytest.raises(TorlabInputError, match="unknown test type"):
        classify_test(trac, given="wear")


def test_paper_a_conditions_follow_tab_5_2():
    from torlab.synth.optical import hertz_load, paper_a_conditions

    tests = {t.name: t for t in paper_a_conditions()}
    W = tests["traction_rough"].conditions[0].load_N
    # invert the Hertz formula: p0 = (6 W E*^2 / (pi^3 R^2))^(1/3), steel on BK7 glass
    e_star = 1 / ((1 - 0.3**2) / 210e9 + (1 - 0.206**2) / 82e9)
    p0 = (6 * W * e_star**2 / (math.pi**3 * 0.0127**2)) ** (1 / 3)
    assert p0 == pytest.approx(0.75e9, rel=1e-3)
    assert hertz_load(0.75e9, 0.0127) == pytest.approx(W, abs=0.05)
    dry = tests["dry_traction_rough"]
    assert (dry.test, dry.surface, dry.lubricant) == ("dry_traction", "rough", "none")
    assert {c.rolling_speed_m_s for c in dry.conditions} == {0.5}
    assert min(c.srr for c in dry.conditions) == -0.10 and max(c.srr for c in dry.conditions) == 0.10
    film = tests["film_thickness_smooth"]
    assert {c.srr for c in film.conditions} == {0.0} and film.surface == "smooth"
    assert max(c.rolling_speed_m_s for c in film.conditions) == 2.0
    for name in ("stribeck_smooth", "stribeck_rough"):
        t = tests[name]
        assert {c.srr for c in t.conditions} == {0.05}
        assert min(c.rolling_speed_m_s for c in t.conditions) == pytest.approx(0.1)
        assert max(c.rolling_speed_m_s for c in t.conditions) == pytest.approx(2.0)
    tr = tests["traction_rough"]
    assert sorted({c.rolling_speed_m_s for c in tr.conditions}) == [0.25, 0.5, 1.0, 1.5, 2.0]
    assert min(c.srr for c in tr.conditions) == -0.05 and max(c.srr for c in tr.conditions) == 0.05
    assert all(t.window_s == 4.0 for t in tests.values())
    assert all(c.duration_s > 4.0 for t in tests.values() for c in t.conditions)


def test_simulator_is_seeded_and_has_transients():
    from torlab.synth.optical import OpticalCondition, simulate_optical_log

    conds = [OpticalCondition(0.5, 0.0, 90.0, 2.0), OpticalCondition(0.5, 0.05, 90.0, 2.0)]
    a = simulate_optical_log(conds, _mu, _h, seed=1)
    b = simulate_optical_log(conds, _mu, _h, seed=1)
    c = simulate_optical_log(conds, _mu, _h, seed=2)
    assert np.array_equal(a["friction_force_N"], b["friction_force_N"])
    assert not np.array_equal(a["friction_force_N"], c["friction_force_N"])
    assert len(a["time_s"]) == 4000 and a["condition"][0] == 1 and a["condition"][-1] == 2
    # right after the change to 5 % SRR the friction is still near zero (servo and friction lag)
    i = 2000
    assert abs(a["mu_true"][i + 5]) < 0.2 * abs(a["mu_true"][-1])
    # 2 s = 5 friction time constants (0.4 s) after the change, behind the 0.25 s servo: the
    # remaining lag is about exp(-5) (0.7 %) plus the servo's share
    assert a["mu_true"][-1] == pytest.approx(float(_mu(0.5, 0.05)), rel=0.01)
    assert a["mu_true"][-1] < float(_mu(0.5, 0.05))
    # film frames at 25 Hz: 100 in 4 s
    assert np.isfinite(a["film_thickness_m"]).sum() == 100


def test_ehd2_film_steps_through_the_optical_reduction():
    from torlab.parsers.pcs import read_pcs

    df, meta = read_pcs(DATA / "pcs" / "ehd2_quirks.txt")
    res = reduce_ehd2(df, meta)
    assert res.test == "film_thickness" and res.instrument == "EHD2"
    p = res.points
    assert p["film_thickness_m"].tolist() == pytest.approx([24.4e-9, 52.1e-9, 82.2e-9, 136.5e-9])
    # traction coefficient from Traction Force 1 / Ball Load = 0.8 / 20, and it says so
    assert p["traction_coefficient"].tolist() == pytest.approx([0.04] * 4)
    assert any("Traction Force 1" in w for w in res.warnings)


@pytest.mark.realdata
def test_real_ehd2_film_thickness_rises_with_speed():
    from torlab.parsers.pcs import read_pcs

    df, meta = read_pcs(real_pcs_file("demo_3.txt"))
    res = reduce_ehd2(df, meta)
    p = res.points
    assert len(p) == 42 and res.test == "film_thickness" and sorted(p["step"].unique()) == [2, 5]
    for _, g in p.groupby("step"):
        h = g.sort_values("rolling_speed_m_s")["film_thickness_m"].to_numpy()
        assert h[-1] > 10 * h[0]


# --- errors -----------------------------------------------------------------------------------------
GOOD = EXAMPLE


def _bad(kind: str) -> tuple[str, int | None, str]:
    """(text, line, message fragment); the example's header is line 11, rows lines 12-20."""
    lines = GOOD.rstrip("\n").split("\n")
    assert lines[10].startswith("time [s]")

    def join(ls: list[str]) -> str:
        return "\n".join(ls) + "\n"

    if kind == "empty":
        return "", None, "empty"
    if kind == "truncated_last_field":  # the film field (may be empty) is missing, not empty
        lines[13] = lines[13].rsplit(",", 1)[0]
        return join(lines), 14, "truncated"
    if kind == "truncated":
        lines[-1] = lines[-1][:10]
        return join(lines), 20, "truncated"
    if kind == "text_in_number":
        lines[14] = lines[14].replace("90.11", "9O.11")
        return join(lines), 15, "not a number"
    if kind == "unknown_unit":
        lines[10] = lines[10].replace("normal_load [N]", "normal_load [Nx]")
        return join(lines), 11, "unknown unit"
    if kind == "missing_column":
        cut = [",".join(r.split(",")[:4] + r.split(",")[5:]) for r in lines[10:]]
        return join(lines[:10] + cut), 11, "missing column 'normal_load'"
    if kind == "wrong_delimiter":
        return join(lines[:10] + [r.replace(",", ";") for r in lines[10:]]), 11, "separated by ';'"
    if kind == "nan":
        lines[13] = lines[13].replace("-4.503", "nan")
        return join(lines), 14, "not a finite number"
    if kind == "zero_load":
        lines[13] = lines[13].replace("90.08", "0")
        return join(lines), 14, "must be positive"
    if kind == "time_backwards":
        lines[15] = lines[15].replace("0.004,", "0.001,")
        return join(lines), 16, "does not increase"
    raise AssertionError(kind)


BAD = ["empty", "truncated_last_field", "truncated", "text_in_number", "unknown_unit",
       "missing_column", "wrong_delimiter", "nan", "zero_load", "time_backwards"]


@pytest.mark.parametrize("kind", BAD)
def test_bad_input_library(kind, tmp_path):
    text, line, frag = _bad(kind)
    p = tmp_path / f"{kind}.csv"
    p.write_text(text)
    with pytest.raises(TorlabInputError) as ei:
        reduce_optical_log(p, window=0.004)
    assert ei.value.path == str(p) and frag in str(ei.value), str(ei.value)
    if line is not None:
        assert ei.value.line == line, str(ei.value)


@pytest.mark.parametrize("kind", ["empty", "truncated", "text_in_number", "unknown_unit",
                                  "missing_column", "wrong_delimiter"])
def test_bad_input_cli_one_line_exit_2(kind, tmp_path, cli):
    text, line, frag = _bad(kind)
    p = tmp_path / f"{kind}.csv"
    p.write_text(text)
    before = sha(p)
    r = cli("optical", "reduce", p, "-o", tmp_path / "out", "--window", "4 ms")
    assert r.exit_code == 2, r.output
    lines = error_lines(r)
    assert len(lines) == 1 and lines[0].startswith("error: ") and frag in lines[0], lines
    if line is not None:
        assert f"{p}:{line}:" in lines[0]
    assert not (tmp_path / "out").exists() and sha(p) == before


def test_cli_optical_reduce_end_to_end(tmp_path, cli):
    import pandas as pd

    from torlab.synth.optical import OpticalCondition

    conds = [OpticalCondition(u, s, 90.0, 5.0) for u in (0.5, 1.0) for s in (-0.02, 0.0, 0.02)]
    text, _ = _synthetic(conds, seed=8)
    log = tmp_path / "trac.csv"
    log.write_text(text)
    ehd = DATA / "pcs" / "ehd2_quirks.txt"
    out = tmp_path / "out"
    r = cli("optical", "reduce", log, ehd, "-o", out)
    assert r.exit_code == 0, r.output
    s = pd.read_csv(out / "summary.csv")
    assert s["test"].tolist() == ["traction", "film_thickness"]
    assert s["symmetric"].tolist()[0] == "yes" and s["symmetry_pairs"].iloc[0] == 2
    pts = pd.read_csv(out / "trac_points.csv")
    assert len(pts) == 6 and np.isfinite(pts["traction_coefficient"]).all()
    assert (out / "trac_folded.csv").exists() and (out / "trac.png").stat().st_size > 10_000
    assert (out / "ehd2_quirks_points.csv").exists()
    r = cli("optical", "reduce", log, "-o", out)
    assert r.exit_code == 2 and "--force" in error_lines(r)[0]
    r = cli("optical", "reduce", log, "-o", out, "--force", "--test", "wear")
    assert r.exit_code == 2 and "not a known test" in error_lines(r)[0]
    r = cli("optical", "reduce", log, "-o", out, "--force", "--window", "-1 s")
    assert r.exit_code == 2 and len(error_lines(r)) == 1


def test_cli_synth_optical_writes_logs_with_truth(tmp_path, cli):
    from torlab.yamlio import load_yaml

    r = cli("synth", "optical", "-o", tmp_path / "g", "--tests", "dry_traction_rough")
    assert r.exit_code == 0, r.output
    truth = load_yaml(tmp_path / "g" / "truth.yaml").data
    assert truth["tests"][0]["file"] == "dry_traction_rough.csv"
    res = reduce_optical_log(tmp_path / "g" / "dry_traction_rough.csv")
    assert res.test == "dry_traction" and len(res.points) == 15
    mu_true = [c["traction_coefficient"] for c in truth["tests"][0]["conditions"]]
    assert np.max(np.abs(res.points["traction_coefficient"].to_numpy() - mu_true)) < 0.02
    r = cli("synth", "optical", "-o", tmp_path / "h", "--tests", "nope")
    assert r.exit_code == 2 and "unknown test" in error_lines(r)[0]


def test_bench_quick_returns_sane_rows():
    from torlab.bench.optical import run

    rows = run(quick=True)
    assert [r.variant.split(" ")[0] for r in rows] == ["pandas.read_csv", "reduce_optical_log"]
    assert all(r.time_s > 0 for r in rows)
    red = rows[1]
    assert red.default and red.extra["conditions"] == 15
    assert red.error is not None and red.error < 0.01
    assert red.extra["ratio_to_bare"] > 0 and red.extra["peak_heap_MB"] > 0


def test_committed_quirk_file_bom_crlf_setpoints_torque():
    path = DATA / "optical" / "setpoints_torque_crlf.csv"
    raw = path.read_bytes()
    assert raw.startswith(b"\xef\xbb\xbf") and b"\r\n" in raw
    df, meta = read_optical(path)
    assert meta.friction_sign == -1 and meta.ball_radius == pytest.approx(0.0125)
    assert "x_counter" not in df and "torque_N_m" in df and len(df) == 10
    assert df["line"].tolist() == list(range(8, 18))
    res = reduce_optical_log(path, window=0.5)
    p = res.points
    # set-point changes mark two conditions; mu = -T / (r W) = -(0.025 N m) / (0.0125 m x 50 N)
    assert p["traction_coefficient"].tolist() == pytest.approx([-0.04, 0.04])
    assert p["srr"].tolist() == pytest.approx([-0.02, 0.02])
    assert p["film_thickness_m"].tolist() == pytest.approx([20.5e-9, 20.7e-9])
    assert p["n_film"].tolist() == [3, 2] and p["temperature_C"].tolist() == pytest.approx([23.1, 23.2])
    assert res.test == "traction" and res.symmetry["symmetric"]


def _pairs(diffs, mu=0.05):
    """Folded points with the given +SRR minus folded -SRR differences, one pair per SRR."""
    import pandas as pd

    srr = [0.01 * (k + 1) for k in range(len(diffs))]
    return pd.DataFrame({"rolling_speed_m_s": [1.0] * (2 * len(diffs)),
                         "srr": [-s for s in srr] + srr,
                         "traction_coefficient": [-mu] * len(diffs) + [mu + d for d in diffs]})


def test_symmetry_offset_interval_is_the_paired_t_interval():
    from scipy import stats

    diffs = np.array([0.0012, -0.0008, 0.0004, 0.0010, -0.0003, 0.0006])
    _, sym = fold_traction(_pairs(diffs))
    lo, hi = stats.t.interval(0.95, len(diffs) - 1, loc=diffs.mean(), scale=stats.sem(diffs))
    assert sym["offset"] == pytest.approx(diffs.mean(), rel=1e-9)
    assert (sym["offset_low95"], sym["offset_high95"]) == pytest.approx((lo, hi), rel=1e-9)
    # tolerance max(10 % of ~0.05, 0.005) = 0.005: the offset is inside with P ~ 1
    assert sym["offset_tolerance"] == pytest.approx(0.005, rel=0.02)
    assert sym["symmetry_verdict"] == "symmetric" and sym["p_symmetric"] > 0.99


def test_symmetry_verdicts_asymmetric_and_undetermined():
    # every pair shifted by 0.02 (a misaligned force zero): outside the tolerance for sure
    _, sym = fold_traction(_pairs([0.020, 0.021, 0.019, 0.020]))
    assert sym["symmetry_verdict"] == "asymmetric" and sym["p_symmetric"] < 0.1
    # an offset at the tolerance with scatter: the data cannot tell
    _, sym = fold_traction(_pairs([0.001, 0.012, -0.002, 0.009]))
    assert sym["symmetry_verdict"] == "undetermined" and 0.1 < sym["p_symmetric"] < 0.9
    # two pairs: no interval, never called
    _, sym = fold_traction(_pairs([0.0, 0.0001]))
    assert sym["symmetry_verdict"] == "undetermined" and np.isnan(sym["offset_low95"])
