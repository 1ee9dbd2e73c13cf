"""Retention through the CLI: synth retention, fit removal, predict retention, predict traction
--sweep; the shipped retention protocol; bad input (one line, exit 2, nothing written).

References independent of the code under test: the generating truth of the synthetic campaign
(``sample_data/retention/truth.yaml``: the law's k1, the truth layer), hand calculations of
areal densities and pass intervals, and torlab's ordinary traction prediction
(``predict_traction``, FASTSIM with the layer) for the steady curve of a sweep.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from tests.conftest import ROOT, error_lines

SAMPLE = ROOT / "sample_data" / "retention"
TAB54 = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
HPT = [str(p) for p in sorted(SAMPLE.glob("hpt_*.txt"))]
COMPLIANCE = str(SAMPLE / "rig_compliance.csv")
TESTS = [str(SAMPLE / "mtm_retention_1uL.txt"), str(SAMPLE / "mtm_retention_2uL.txt")]


def _truth() -> dict:
    return yaml.safe_load((SAMPLE / "truth.yaml").read_text())


def _hpt_args(files=HPT) -> list[str]:
    out = []
    for f in files:
        out += ["--hpt", f]
    return [*out, "--compliance", COMPLIANCE]


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """``torlab fit removal`` on the shipped sample campaign (once per module), on the
    tribometer scene the campaign was made with (Kalker's FASTSIM, the thesis's boundary
    method: protocols/scenes/mtm_retention.yaml)."""
    from typer.testing import CliRunner

    from torlab.cli import app

    out = tmp_path_factory.mktemp("fit") / "fit"
    r = CliRunner().invoke(app, ["fit", "removal", *TESTS, *_hpt_args(), "--scene",
                                 str(ROOT / "protocols" / "scenes" / "mtm_retention.yaml"),
                                 "-o", str(out)])
    assert r.exit_code == 0, r.output
    return out, r.output


# --------------------------------------------------------------------------- synth
def test_synth_retention_reproduces_the_shipped_campaign(cli, tmp_path):
    out = tmp_path / "ret"
    r = cli("synth", "retention", "-o", out)
    assert r.exit_code == 0, r.output
    truth = yaml.safe_load((out / "truth.yaml").read_text())
    files = [x["file"] for x in truth["runs"]] + [x["file"] for x in truth["hpt_runs"]]
    assert len(files) == 8 and (out / "rig_compliance.csv").exists()
    for f in files:  # the shipped sample data are this command's output (same seed)
        assert (out / f).read_bytes() == (SAMPLE / f).read_bytes(), f
    assert truth["law"] == _truth()["law"]
    # the HPT logs state the amounts and the density the layer converts with
    head = (out / "hpt_OFM1_4uL_25C.txt").read_text().splitlines()[:8]
    assert "# applied_amount: 4 uL" in head and "# product_density: 930 kg/m^3" in head


# --------------------------------------------------------------------------- fit removal
def test_fit_removal_recovers_the_stated_law(fitted):
    out, console = fitted
    truth = _truth()
    summ = json.loads((out / "summary.json").read_text())
    assert summ["kind"] == "removal" and summ["meta"]["law"] == truth["law"]["name"]
    lo, hi = summ["ci95"]["k1"]
    assert lo < truth["law"]["k1"] < hi
    assert hi / lo < 1.6  # informative: the two tests pin the rate
    tab = pd.read_csv(out / "fit_table.csv")
    assert list(tab["parameter"]) == ["k1", "transfer", "spread"]
    sel = pd.read_csv(out / "law_selection.csv")
    assert set(sel["law"]) == {"zero_order", "first_order"}
    assert sel.loc[sel["law"] == "first_order", "weight"].iloc[0] > 0.99
    data = pd.read_csv(out / "fit_data.csv")
    assert {"time_s", "mu_measured", "mu_model", "amount_mg_m2", "in_fit"} <= set(data.columns)
    for name in ("params.yaml", "fit.png", "amount_layer.csv", "amount_layer.png",
                 "correlation.csv"):
        assert (out / name).exists(), name
    assert "first_order" in console and "Law choice" in console


def test_fit_removal_params_carry_the_layer_and_the_law(fitted):
    from torlab.fit.retention_params import load_retention
    from torlab.model.amount import HPT_AREA, MG_M2

    out, _ = fitted
    text = (out / "params.yaml").read_text()
    assert text.startswith("# torlab fit output: a parameter file for torlab predict retention")
    rp = load_retention(out / "params.yaml")
    truth = _truth()
    # areal densities of the HPT series by hand: 1-16 uL x 930 kg/m^3 over pi (6^2 - 3^2) mm^2
    area = math.pi * (6e-3**2 - 3e-3**2)
    assert area == pytest.approx(HPT_AREA)
    want = [a * 1e-9 * 930.0 / area / MG_M2 for a in (1, 2, 4, 8, 16)]
    assert rp.layer.amounts / MG_M2 == pytest.approx(want, rel=1e-12)
    assert rp.layer.dry_amount / MG_M2 == pytest.approx(want[0] / 10, rel=1e-12)
    # the fitted layer at every tested amount: the truth nodes within 5 % (HPT fit precision)
    nodes = {round(n["amount_mg_m2"]): n for n in truth["layer"]["nodes"]}
    for m, p in zip(rp.layer.amounts, rp.layer.params, strict=True):
        node = nodes[round(m / MG_M2)]
        assert p[1] == pytest.approx(node["mu_c2"], rel=0.05)
    assert rp.density == 930.0
    assert rp.removal.params["k1"] == pytest.approx(
        json.loads((out / "summary.json").read_text())["params"]["k1"], rel=1e-12)


@pytest.mark.slow  # eight HPT fits first
def test_fit_removal_from_hpt_parameter_files_equals_from_logs(fitted, cli, tmp_path):
    """The amount series as 'torlab fit hpt' parameter files gives the same law as the logs."""
    out, _ = fitted
    pfiles = []
    for f in HPT:
        d = tmp_path / Path(f).stem
        r = cli("fit", "hpt", f, "--compliance", COMPLIANCE, "-o", d)
        assert r.exit_code == 0, r.output
        pfiles.append(str(d / "params.yaml"))
    r = cli("fit", "removal", *TESTS, *[a for p in pfiles for a in ("--hpt", p)],
            "--scene", ROOT / "protocols" / "scenes" / "mtm_retention.yaml",
            "-o", tmp_path / "from_params")
    assert r.exit_code == 0, r.output
    a = json.loads((out / "summary.json").read_text())
    b = json.loads((tmp_path / "from_params" / "summary.json").read_text())
    assert b["params"]["k1"] == pytest.approx(a["params"]["k1"], rel=1e-6)


def test_python_api_matches_the_commands(fitted, tmp_path):
    """torlab.fit_removal with the layer as an object, and predict_retention from the result in
    memory or from its parameter file, give the command's numbers."""
    import torlab
    from torlab.fit.retention_params import load_retention

    out, _ = fitted
    rp = load_retention(out / "params.yaml")
    res = torlab.fit_removal(TESTS, rp.layer, density="930 kg/m^3",
                             scene=ROOT / "protocols" / "scenes" / "mtm_retention.yaml")
    cli_k1 = json.loads((out / "summary.json").read_text())["params"]["k1"]
    assert res.params["k1"] == pytest.approx(cli_k1, rel=1e-9)
    res.to_params(tmp_path / "removal.yaml")
    kw = {"creepage": "1 %", "n_draws": 50, "passes": 400}
    a = torlab.predict_retention(TAB54, res, "100000 mg/m^2", **kw)
    b = torlab.predict_retention(TAB54, tmp_path / "removal.yaml", "100000 mg/m^2", **kw)
    assert a.table["mu"].to_numpy() == pytest.approx(b.table["mu"].to_numpy(), rel=1e-12)
    assert a.table["mu_high95"].to_numpy() == pytest.approx(b.table["mu_high95"].to_numpy(),
                                                            rel=1e-12)
    assert a.table["passes"].iloc[-1] == 400.0


# --------------------------------------------------------------------------- predict retention
def test_predict_retention_outputs_and_crossings(fitted, cli, tmp_path):
    out, _ = fitted
    r = cli("predict", "retention", TAB54, out / "params.yaml", "--amount", "100000 mg/m^2",
            "--creepage", "1 %", "--draws", "100", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "p" / "retention.csv")
    assert list(t.columns[:5]) == ["passes", "amount_mg_m2", "mu", "mu_low95", "mu_high95"]
    assert np.all(t["mu_low95"] <= t["mu"] + 1e-12) and np.all(t["mu"] <= t["mu_high95"] + 1e-12)
    assert np.all(np.diff(t["amount_mg_m2"]) <= 0) and t["amount_mg_m2"].iloc[0] == 1e5
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    for key, level in (("passes_to_enter_band", 0.15), ("passes_to_leave_band", 0.25)):
        cr = s[key]
        assert cr["level"] == level and cr["low95"] < cr["passes"] < cr["high95"]
        # the table's coefficient passes the level at the reported pass
        assert np.interp(cr["passes"], t["passes"], t["mu"]) == pytest.approx(level, abs=2e-3)
    assert s["passes_to_enter_band"]["passes"] < s["passes_to_leave_band"]["passes"]
    assert s["law"] == "first_order" and s["modelled"] and "notes" in s
    assert (tmp_path / "p" / "retention.png").stat().st_size > 1000
    assert not (tmp_path / "p" / "retention.svg").exists()  # PNG unless --formats says more
    assert "enters the band" in r.output and "leaves the band" in r.output


def test_retention_figures_labs_report_follow_from_the_curve(fitted, cli, tmp_path):
    """The effective friction level is the mean of the table's coefficient over the window,
    the fraction in the band follows from the crossings (the coefficient only rises after
    the application), the retentivity is the passes to leave the band; each with its
    interval.  A named band preset and a fraction of dry work too."""
    out, _ = fitted
    r = cli("predict", "retention", TAB54, out / "params.yaml", "--amount", "100000 mg/m^2",
            "--draws", "60", "--passes", "400", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "p" / "retention.csv")
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    m = s["retention_metrics"]
    assert m["window_passes"] == [0, 400] and m["band"] == [0.15, 0.25]
    assert t["passes"].iloc[-1] == 400  # the window is the predicted range
    mean = np.trapezoid(t["mu"], t["passes"]) / 400
    assert m["effective_friction"]["value"] == pytest.approx(mean, rel=2e-3)
    a, b = s["passes_to_enter_band"]["passes"], s["passes_to_leave_band"]["passes"]
    assert m["fraction_in_band"]["value"] == pytest.approx((min(b, 400) - min(a, 400)) / 400,
                                                           abs=2e-3)
    assert m["retentivity"]["value"] == pytest.approx(b, rel=1e-9)
    for k in ("effective_friction", "retentivity", "fraction_in_band"):
        e = m[k]
        assert e["low95"] <= e["value"] <= e["high95"], k
    assert "effective friction level over passes 0–400" in r.output
    r = cli("predict", "retention", TAB54, out / "params.yaml", "--amount", "100000 mg/m^2",
            "--draws", "0", "--band", "intermediate", "--retentivity", "0.9", "--window",
            "100:300", "-o", tmp_path / "q")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "q" / "summary.json").read_text())
    m = s["retention_metrics"]
    assert s["band"] == [0.2, 0.35] and m["retentivity"]["level"] == pytest.approx(
        0.9 * s["mu_dry"])
    assert m["window_passes"] == [100, 300] and m["effective_friction"]["low95"] is None
    r = cli("predict", "retention", TAB54, out / "params.yaml", "--amount", "100000 mg/m^2",
            "--band", "thesiss", "-o", tmp_path / "r")
    assert r.exit_code == 2 and "did you mean 'thesis'" in r.output


def test_fit_removal_reports_each_tests_retention_figures(fitted):
    out, output = fitted
    s = json.loads((out / "summary.json").read_text())
    for t in s["meta"]["tests"]:
        m = t["retention_metrics"]
        e = m["effective_friction"]
        assert e["low95"] <= e["value"] <= e["high95"]
        assert 0 <= m["fraction_in_band"]["value"] <= 1
        assert "record's own noise" in m["holds"]
    assert "(measured): effective friction level" in output


def test_predict_retention_of_two_products_in_one_figure(fitted, cli, tmp_path):
    """Two removal files: one labelled curve each, on one passes axis, in one long CSV."""
    out, _ = fitted
    r = cli("predict", "retention", TAB54, f"A={out / 'params.yaml'}",
            f"B={out / 'params.yaml'}", "--amount", "100000 mg/m^2", "--draws", "0",
            "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "p" / "retention.csv")
    assert list(t.columns[:2]) == ["curve", "passes"] and set(t["curve"]) == {"A", "B"}
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert set(s["curves"]) == {"A", "B"}
    assert (tmp_path / "p" / "retention.png").is_file()


def test_predict_retention_volume_on_a_rail_and_time_axis(fitted, cli, tmp_path):
    out, _ = fitted
    r = cli("predict", "retention", TAB54, out / "params.yaml", "--amount", "4 uL",
            "--band-length", "20 mm", "--time", "1 h", "--pass-interval", "10 s",
            "--draws", "0", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    # 4 uL of a 930 kg/m^3 product over 20 mm of a 2b = 6.6 mm band (Tab. 5.4: b = 3.3 mm)
    assert s["initial_amount_mg_m2"] == pytest.approx(4e-9 * 930.0 / (6.6e-3 * 0.02) * 1e6,
                                                      rel=1e-9)
    t = pd.read_csv(tmp_path / "p" / "retention.csv")
    assert t["time_s"].to_numpy() == pytest.approx(10.0 * t["passes"].to_numpy())
    assert t["time_s"].iloc[-1] == pytest.approx(3600.0)
    assert t["mu_low95"].isna().all()  # no draws: no interval, said in the notes
    assert any("no parameter draws" in n for n in s["notes"])


def test_predict_retention_cycles_on_a_disc(fitted, cli, tmp_path):
    out, _ = fitted
    r = cli("predict", "retention", TAB54, out / "params.yaml", "--amount", "100000 mg/m^2",
            "--track-radius", "0.5 m", "--cycles", "500", "--draws", "0", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "p" / "retention.csv")
    assert t["passes"].iloc[-1] == pytest.approx(500.0)
    # one revolution of a 0.5 m track at the scene's 10 m/s
    assert t["time_s"].to_numpy() == pytest.approx(t["passes"].to_numpy() * 2 * math.pi * 0.5
                                                   / 10.0)


def test_predict_retention_on_the_mtm_disc_matches_the_generator(fitted, cli, tmp_path):
    """1 uL on the MTM disc track: the initial amount and the revolution time of the virtual
    time test (truth.yaml, written by the generator's own integration)."""
    out, _ = fitted
    run = _truth()["runs"][0]
    r = cli("predict", "retention", ROOT / "protocols" / "scenes" / "mtm_paper_b.yaml",
            out / "params.yaml", "--amount", "1 uL", "--creepage", "2 %", "--track-radius",
            f"{_truth()['track_radius_m']!r} m", "--draws", "0", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert s["initial_amount_mg_m2"] == pytest.approx(run["initial_amount_mg_m2"], rel=1e-6)
    assert s["running_band"]["width_m"] == pytest.approx(run["band_width_m"], rel=1e-9)
    t = pd.read_csv(tmp_path / "p" / "retention.csv")
    assert t["time_s"].to_numpy() == pytest.approx(t["passes"].to_numpy()
                                                   * run["disc_revolution_s"], rel=1e-9)
    assert any("lubricant film: not modelled" in m for m in s["modelled"])


# --------------------------------------------------------------------------- sweep
def test_sweep_steady_curve_is_the_traction_model_at_the_applied_amount(fitted, cli, tmp_path):
    """The steady column is torlab's ordinary traction prediction with the layer of the applied
    amount (here a tested amount, 4 uL on the HPT annulus), and no removal leaves it unchanged."""
    from torlab.fit.retention_params import load_retention
    from torlab.model.predict import predict_traction
    from torlab.scene import load_scene

    out, _ = fitted
    m0 = 4e-9 * 930.0 / (math.pi * (6e-3**2 - 3e-3**2))  # kg/m^2
    r = cli("predict", "traction", TAB54, out / "params.yaml", "--sweep", "2 s", "--amount",
            f"{m0 * 1e6!r} mg/m^2", "--pass-interval", "0.5 s", "--creepage", "0:0.05:26",
            "-o", tmp_path / "s")
    assert r.exit_code == 0, r.output
    tr = pd.read_csv(tmp_path / "s" / "traction.csv")
    assert list(tr.columns[:3]) == ["creepage", "mu", "mu_sweep"]
    rp = load_retention(out / "params.yaml")
    lay = rp.layer.layer(m0)
    sc = load_scene(TAB54)
    sc = sc.model_copy(update={"boundary": sc.boundary.model_copy(update={
        "mu_c1": lay.mu_c1, "mu_c2": lay.mu_c2, "L_mue": lay.L_mue, "L_mup": lay.L_mup}),
        "thermal": None})
    ref = predict_traction(sc, tr["creepage"].to_numpy()).table["mu"].abs().to_numpy()
    assert tr["mu"].to_numpy() == pytest.approx(ref, abs=1e-9)
    assert np.all(tr["mu_sweep"] >= tr["mu"] - 1e-9)  # removal only raises mu (f(m) falls)
    s = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert s["passes_during_sweep"] == pytest.approx(4.0)
    assert 0.0 <= s["probability_sweep_positive"] <= 1.0
    st = s["trend_steady"]
    assert st["trend_point"] in ("neutral", "positive", "negative")
    best = max(st["probabilities"], key=st["probabilities"].get)
    assert st["trend"] == (best if st["probabilities"][best] >= 0.9 else "undetermined")
    assert "verdict:" in r.output and s["verdict"] in r.output
    assert (tmp_path / "s" / "sweep.csv").exists() and (tmp_path / "s" / "traction.png").exists()


# --------------------------------------------------------------------------- bad input
def _bad(r, *words: str) -> str:
    assert r.exit_code == 2, r.output
    lines = error_lines(r)
    assert len(lines) == 1 and lines[0].startswith("error: "), lines
    assert "Traceback" not in r.output
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def test_time_test_without_application_marker(cli, tmp_path):
    from torlab.model.removal import RemovalLaw
    from torlab.synth.retention import (
        RetentionTestSpec,
        export_text,
        simulate_retention_test,
        true_layer,
    )

    law = RemovalLaw(1, 1e-6)
    spec = RetentionTestSpec("flat", 1.0, application_time_s=0.0, mu_film=0.13, seed=3)
    p = tmp_path / "flat.txt"
    p.write_bytes(export_text(spec, simulate_retention_test(spec, true_layer(), law), law)
                  .encode())
    r = cli("fit", "removal", p, *_hpt_args(), "-o", tmp_path / "out")
    _bad(r, "flat.txt", "no application marker")
    assert not (tmp_path / "out").exists()


def test_timed_csv_without_marker_and_without_units(cli, tmp_path):
    t = np.arange(1.0, 300.0)
    df = pd.DataFrame({"step_time_s": t, "traction_coefficient": 0.2 + 0 * t, "srr": 0.02,
                       "rolling_speed_m_s": 1.0, "ball_load_N": 18.0})
    p = tmp_path / "flat_timed.csv"
    df.to_csv(p, index=False)
    base = ["fit", "removal", p, *_hpt_args()]
    _bad(cli(*base, "--amount", "2 uL", "--track-radius", "21 mm", "-o", tmp_path / "o"),
         "no application marker")
    # the hints name the command's options (and the keywords for Python)
    for args, words in ((["--track-radius", "21 mm"], "--amount '5 uL'"),
                        (["--amount", "2 uL"], "--track-radius '21 mm'"),
                        (["--amount", "2 uL", "--track-radius", "21 mm"], "--application-time")):
        r = cli(*base, *args, "-o", tmp_path / "o")
        assert r.exit_code == 2 and words in error_lines(r)[-1], r.output
    _bad(cli(*base, "--amount", "2", "--track-radius", "21 mm", "-o", tmp_path / "o"),
         "no unit")
    _bad(cli(*base, "--amount", "-2 uL", "--track-radius", "21 mm", "-o", tmp_path / "o"),
         "negative")
    assert not (tmp_path / "o").exists()


def test_amount_series_with_one_amount(cli, tmp_path):
    one = [str(SAMPLE / "hpt_OFM1_4uL_25C.txt"), str(SAMPLE / "hpt_dry_25C.txt")]
    _bad(cli("fit", "removal", *TESTS, *_hpt_args(one), "-o", tmp_path / "o"),
         "at least two different amounts")
    nodry = [str(SAMPLE / "hpt_OFM1_4uL_25C.txt"), str(SAMPLE / "hpt_OFM1_8uL_25C.txt")]
    _bad(cli("fit", "removal", *TESTS, *_hpt_args(nodry), "-o", tmp_path / "o"), "no dry run")
    assert not (tmp_path / "o").exists()


def test_hpt_amount_without_unit_names_file_and_line(cli, tmp_path):
    files = []
    for f in HPT:
        q = tmp_path / Path(f).name
        shutil.copy(f, q)
        files.append(str(q))
    q = tmp_path / "hpt_OFM1_2uL_25C.txt"
    lines = q.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("# applied_amount"))
    lines[k] = "# applied_amount: 2"
    q.write_text("\n".join(lines) + "\n")
    _bad(cli("fit", "removal", *TESTS, *_hpt_args(files), "-o", tmp_path / "o"),
         "hpt_OFM1_2uL_25C.txt", "unit")


@pytest.mark.parametrize("amount, words", [("-4 uL", ("negative",)), ("4", ("no unit",)),
                                           ("4 N", ("not a volume",)),
                                           ("4 uL", ("band_length",))])
def test_predict_retention_bad_amounts(fitted, cli, tmp_path, amount, words):
    out, _ = fitted
    _bad(cli("predict", "retention", TAB54, out / "params.yaml", "--amount", amount,
             "-o", tmp_path / "p"), *words)
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize("args, words", [
    (("--amount", "1e12 mg/m^2"), ("amount: 1e+12 mg/m^2 is not possible for an applied amount per area",)),
    (("--amount", "1e9 uL", "--band-length", "20 mm"), ("not possible for an applied volume",)),
    (("--amount", "1e5 mg/m^2", "--time", "1e300 s", "--pass-interval", "2 s"),
     ("time: 1e+300 s is not possible for a duration",)),
    (("--amount", "1e5 mg/m^2", "--time", "1 h", "--pass-interval", "-2 s"),
     ("--pass-interval: -2 s is not possible",)),
    (("--amount", "1e5 mg/m^2", "--track-radius", "1e300 m"), ("--track-radius: 1e+303 mm is not possible for a track radius",)),
    (("--amount", "2 uL", "--band-length", "1e300 m"),
     ("band", "1e+300 m is not possible for a length of rail")),
])
def test_predict_retention_options_outside_the_range_table(fitted, cli, tmp_path, args, words):
    """Amounts, durations and radii of the retention commands against torlab.units.RANGES."""
    out, _ = fitted
    _bad(cli("predict", "retention", TAB54, out / "params.yaml", *args, "-o", tmp_path / "p"),
         *words)
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize("seconds, amount, words", [
    ("1e300 s", "1e5 mg/m^2", ("sweep: 1e+300 s is not possible for a duration",)),
    ("0 s", "1e5 mg/m^2", ("sweep: 0 s is not possible",)),
    ("60 s", "1e12 mg/m^2", ("amount: 1e+12 mg/m^2 is not possible",)),
])
def test_sweep_options_outside_the_range_table(fitted, cli, tmp_path, seconds, amount, words):
    out, _ = fitted
    _bad(cli("predict", "traction", TAB54, out / "params.yaml", "--sweep", seconds, "--amount",
             amount, "--track-radius", "0.5 m", "-o", tmp_path / "p"), *words)
    assert not (tmp_path / "p").exists()


def test_unusual_amount_is_a_warning_line_naming_it(fitted, cli, tmp_path):
    out, _ = fitted
    r = cli("predict", "retention", TAB54, out / "params.yaml", "--amount", "0.5 mg/m^2",
            "--draws", "0", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    warn = [ln for ln in error_lines(r) if ln.startswith("warning:")]
    assert any("0.5 mg/m^2 is unusual for an applied amount per area" in w for w in warn), warn


def test_predict_retention_other_bad_input(fitted, cli, tmp_path):
    out, _ = fitted
    p = out / "params.yaml"
    base = ("predict", "retention", TAB54)
    _bad(cli(*base, "--amount", "1e5 mg/m^2", "-o", tmp_path / "p"), "removal parameter file")
    _bad(cli(*base, p, "--amount", "1e7 mg/m^2", "-o", tmp_path / "p"),
         "above the largest tested amount")
    _bad(cli(*base, p, "--amount", "1e5 mg/m^2", "--passes", "10", "--time", "1 h",
             "-o", tmp_path / "p"), "--time")
    _bad(cli(*base, p, "--amount", "1e5 mg/m^2", "--cycles", "10", "-o", tmp_path / "p"),
         "--track-radius")
    _bad(cli(*base, p, "--amount", "1e5 mg/m^2", "--creepage", "3", "-o", tmp_path / "p"),
         "creepage")
    bad = tmp_path / "bad.yaml"
    d = yaml.safe_load(p.read_text())
    d["retention"]["fit_space"]["covariance"] = [[1.0, 2.0]]
    bad.write_text(yaml.safe_dump(d))
    _bad(cli(*base, bad, "--amount", "1e5 mg/m^2", "-o", tmp_path / "p"), "bad.yaml",
         "retention.fit_space.covariance")
    # a removal file given to a plain traction prediction says what it is for
    _bad(cli("predict", "traction", TAB54, p, "-o", tmp_path / "p"), "--sweep")
    _bad(cli("predict", "traction", TAB54, p, "--sweep", "2 s", "-o", tmp_path / "p"),
         "--amount")
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize("edit, key", [
    (("units", "k1", "x"), "retention.units.k1"),
    (("units", "k1", "mm^2/J"), "retention.units.k1"),
    (("units", "k9", "m^2/J"), "retention.units.k9"),
    (("parameters", "k1", 2.0e-6), "retention.parameters.k1"),
    (("parameters", "k1", "fast"), "retention.parameters.k1"),
    (("ci95", "k1", [1.0, 2.0]), "retention.ci95.k1"),
])
def test_removal_file_readable_copies_must_agree_with_the_fit(fitted, tmp_path, edit, key):
    """The numbers are read from fit_space; a units, parameters or ci95 entry edited by hand
    (which would otherwise be ignored) is an error naming its key."""
    from torlab.errors import TorlabInputError
    from torlab.fit.retention_params import load_retention

    out, _ = fitted
    d = yaml.safe_load((out / "params.yaml").read_text())
    load_retention(out / "params.yaml")  # the file as written loads
    section, name, value = edit
    d["retention"][section][name] = value
    bad = tmp_path / "edited.yaml"
    bad.write_text(yaml.safe_dump(d))
    with pytest.raises(TorlabInputError) as e:
        load_retention(bad)
    assert key in str(e.value) and "edited.yaml" in str(e.value)


# --------------------------------------------------------------------------- the protocol
@pytest.fixture(scope="module")
def protocol_run(tmp_path_factory):
    from torlab.protocols.runner import run_protocol

    out = tmp_path_factory.mktemp("rp") / "out"
    return out, run_protocol(ROOT / "protocols" / "retention.yaml", out, command="test retention")


def test_retention_protocol_against_truth(protocol_run):
    out, res = protocol_run
    truth = _truth()
    rep = res.summary["reports"]["retention"]
    assert rep["product"] == "OFM1" and rep["law"] == truth["law"]["name"]
    k1 = rep["parameters"]["k1"]
    assert k1["low95"] < truth["law"]["k1"] < k1["high95"]
    pr = rep["prediction"]
    assert pr["initial_amount_mg_m2"] == 1e5 and pr["scene"] == "wheel-rail Tab. 5.4"
    enter, leave = pr["passes_to_enter_band"], pr["passes_to_leave_band"]
    assert enter["low95"] < enter["passes"] < enter["high95"] < leave["low95"]
    assert leave["low95"] < leave["passes"] < leave["high95"]
    sw = rep["sweep"]
    assert sw["passes_during_sweep"] == pytest.approx(4.0)
    # the steady curve's class over the draws; called only at probability 0.9
    assert sw["trend_steady"] in ("neutral", "positive", "negative", "undetermined")
    jp = sw["verdict_probabilities"]
    assert ("H4.1" in sw["verdict"]) == (jp["made_by_removal"] >= 0.9)
    assert sw["verdict"].startswith("undetermined") == (max(jp.values()) < 0.9)
    assert 0.0 <= sw["probability_positive_by_removal"] <= sw["probability_sweep_positive"] <= 1
    assert "removal:OFM1" in res.summary["fits"]
    for f in ("retention/retention.png", "retention/removal_fit.png",
              "retention/amount_layer.png", "retention/sweep.png", "retention/retention.csv",
              "retention/crossings.csv", "fits/removal_OFM1.yaml"):
        assert (out / f).exists(), f
    html = (out / "report.html").read_text()
    assert "Product retention (OFM1)" in html and "H4.1" in html
    assert "retention/retention.csv" in (out / "report.md").read_text()


def test_protocol_removal_file_reproduces_the_report_prediction(protocol_run, cli, tmp_path):
    out, res = protocol_run
    pr = res.summary["reports"]["retention"]["prediction"]
    r = cli("predict", "retention", TAB54, out / "fits" / "removal_OFM1.yaml", "--amount",
            "100000 mg/m^2", "--creepage", "1 %", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    for key in ("passes_to_enter_band", "passes_to_leave_band"):
        for k in ("passes", "low95", "high95"):
            assert s[key][k] == pytest.approx(pr[key][k], rel=1e-9)


def test_retention_protocol_expected_summary(protocol_run):
    from tests.test_protocols import compare_summary

    diffs = compare_summary("retention", protocol_run[1].summary)
    assert not diffs, "summary.json changed:\n  " + "\n  ".join(diffs)


RET_PROTOCOL = """\
version: 1
name: ret
data:
  hpt:
    files: [{hpt}]
  mtm:
    files: [{mtm}]
reports:
  retention:
    product: OFM1
    time_tests: [{other}]
    laws: [second_order]
    prediction:
      scene: {scene}
      amount: -4 uL
"""


def test_retention_protocol_problems_listed_with_line_and_key(cli, tmp_path):
    p = tmp_path / "ret.yaml"
    text = RET_PROTOCOL.format(hpt=HPT[0], mtm=TESTS[0], other=TESTS[1], scene=TAB54)
    p.write_text(text)
    r = cli("run", p, "-o", tmp_path / "out")
    assert r.exit_code == 2
    lines = error_lines(r)
    assert any("reports.retention.laws.0" in ln and "second_order" in ln for ln in lines)
    assert any("reports.retention.prediction.amount" in ln and "negative" in ln
               and f"ret.yaml:{text.splitlines().index('      amount: -4 uL') + 1}:" in ln
               for ln in lines)
    p.write_text(text.replace("[second_order]", "[first_order]").replace("-4 uL", "4 uL"))
    lines = error_lines(cli("run", p, "-o", tmp_path / "out"))
    assert any("reports.retention.time_tests.0" in ln and "not one of the files of data.mtm"
               in ln for ln in lines)
    p.write_text(text.replace("[second_order]", "[first_order]").replace("-4 uL", "4 uL")
                 .replace(f"  mtm:\n    files: [{TESTS[0]}]\n", ""))
    lines = error_lines(cli("run", p, "-o", tmp_path / "out"))
    assert any("needs data.mtm" in ln for ln in lines)
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------- wording, hints, inputs
def test_unquoted_hpt_pattern_is_an_error_not_extra_time_tests(cli, tmp_path):
    """``--hpt hpt_*.txt`` unquoted: the shell gives --hpt the first log and the time tests
    the others; torlab names them instead of fitting them as time tests."""
    r = cli("fit", "removal", *TESTS, "--hpt", HPT[0], *HPT[1:], "-o", tmp_path / "o")
    assert r.exit_code == 2
    (line,) = error_lines(r)
    assert f"{HPT[1]} and {len(HPT) - 2} more: an HPT log among the time tests" in line
    assert "quote the pattern" in line and "--hpt" in line and "dry run" not in line
    assert not (tmp_path / "o").exists()


def test_amount_above_the_tested_range_names_the_option(fitted, cli, tmp_path):
    r = cli("predict", "retention", TAB54, fitted[0] / "params.yaml", "--amount", "5e6 mg/m^2",
            "--draws", "0", "-o", tmp_path / "p")
    assert r.exit_code == 2
    (line,) = [ln for ln in error_lines(r) if ln.startswith("error")]
    assert "above the largest tested amount" in line and "--hold-above" in line
    assert "above='hold'" not in line and line.startswith("error: --amount:")
    r = cli("predict", "retention", TAB54, fitted[0] / "params.yaml", "--amount", "5e6 mg/m^2",
            "--draws", "0", "--hold-above", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert any("is held above it" in n for n in s["notes"])


def test_amount_above_the_tested_range_in_python_names_the_keyword(fitted):
    import torlab
    from torlab.model.amount import AboveTestedError

    with pytest.raises(AboveTestedError, match=r"above='hold'"):
        torlab.predict_retention(TAB54, fitted[0] / "params.yaml", "5e6 mg/m^2", n_draws=0)
    p = torlab.predict_retention(TAB54, fitted[0] / "params.yaml", "5e6 mg/m^2", n_draws=0, above="hold")
    assert p.summary["initial_amount_mg_m2"] == pytest.approx(5e6)


def test_mu_above_the_band_at_the_application_is_never_in_it(fitted, cli, tmp_path):
    """A band below the initial coefficient: mu never enters it (it is above it from the
    start) -- not "enters the band from the application on"."""
    r = cli("predict", "retention", TAB54, fitted[0] / "params.yaml", "--amount", "100000 mg/m^2",
            "--draws", "0", "--band", "0.05:0.1", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert s["mu_initial"] > 0.1  # the premise: above the band at the application
    enter = s["passes_to_enter_band"]
    assert enter["status"].startswith("never in the band") and enter["above_band_at_application"]
    assert s["passes_to_leave_band"]["status"] == "above the band from the application on"
    text = " ".join(r.output.split())
    assert "enters the band (crosses 0.05): never (above the band" in text
    assert "enters the band (crosses 0.05): from the application on" not in text
    # mu inside the band at the application: in it from the application on
    r = cli("predict", "retention", TAB54, fitted[0] / "params.yaml", "--amount", "100000 mg/m^2",
            "--draws", "0", "--band", f"0.05:{s['mu_initial'] + 0.05:.3f}", "-o", tmp_path / "q")
    s = json.loads((tmp_path / "q" / "summary.json").read_text())
    assert s["passes_to_enter_band"]["status"] == "in the band from the application on"


def _zero_rate(params, tmp_path, variance=0.0):
    d = yaml.safe_load(params.read_text())
    r = d["retention"]
    r["parameters"]["k1"] = 0.0
    r["ci95"]["k1"] = [0.0, 0.0]
    fs = r["fit_space"]
    fs["values"] = [float("-inf")]
    fs["covariance"] = [[variance]]
    fs["covariance_without_layer"] = [[0.0]]
    fs["layer_sensitivity"] = [[0.0] * len(fs["layer_sensitivity"][0])]
    out = tmp_path / "zero.yaml"
    out.write_text(yaml.safe_dump(d, sort_keys=False))
    assert "-.inf" in out.read_text()
    return out


def test_a_zero_removal_rate_can_be_written(fitted, cli, tmp_path):
    """k1 = 0 (ln = -inf): no removal, the coefficient stays at its initial value."""
    zero = _zero_rate(fitted[0] / "params.yaml", tmp_path)
    r = cli("predict", "retention", TAB54, zero, "--amount", "100000 mg/m^2", "--passes",
            "500", "--draws", "20", "-o", tmp_path / "p")
    assert r.exit_code == 0, r.output
    t = pd.read_csv(tmp_path / "p" / "retention.csv")
    assert np.ptp(t["mu"]) == 0.0 and np.ptp(t["amount_mg_m2"]) == 0.0
    assert t["amount_mg_m2"].iloc[-1] == pytest.approx(1e5)
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert s["passes_to_enter_band"]["passes"] is None
    assert any("no removal (rate zero)" in n for n in s["notes"])
    bad = _zero_rate(fitted[0] / "params.yaml", tmp_path / "..", variance=0.1)
    r = cli("predict", "retention", TAB54, bad, "--amount", "100000 mg/m^2", "-o",
            tmp_path / "q")
    assert r.exit_code == 2
    assert "retention.fit_space.covariance: a removal rate of zero" in error_lines(r)[-1]
