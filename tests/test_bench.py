"""``torlab bench``: runner, outputs, CLI, and the pieces of the benchmarks that carry numbers.

No test asserts a time: speed is only measured, as ratios, by the benchmark itself.
"""

from __future__ import annotations

import itertools
import math
import sys
import types
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import error_lines

from torlab.bench import BenchRow
from torlab.bench.fastsim import naive_fastsim, scene_problem, time_at_error
from torlab.bench.hertz import hertz_reference
from torlab.bench.runner import (
    BenchResult,
    available_benchmarks,
    bench_markdown,
    run_benchmarks,
    time_error_figure,
    write_bench_outputs,
)
from torlab.errors import TorlabInputError
from torlab.model.kalker import C11, combined_G_nu
from torlab.outputs import OutputDir

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


# --- the CLI, end to end (what CI may call) ---------------------------------------------------
def test_cli_quick_only_hertz_writes_well_formed_outputs(cli, tmp_path):
    out = tmp_path / "bench"
    res = cli("bench", "--quick", "--only", "hertz", "-o", out)
    assert res.exit_code == 0, res.output
    assert "Hertz contact" in res.output
    for name in ("bench.csv", "bench.md", "plots/hertz_contact.png", "torlab-manifest.json"):
        assert (out / name).is_file(), name
    df = pd.read_csv(out / "bench.csv")
    for col in ("module", "component", "variant", "default", "time_s", "error", "reference",
                "unit_of_work", "time_ratio_to_default", "status"):
        assert col in df.columns
    assert set(df["module"]) == {"hertz"}
    assert (df["status"] == "ok").all()
    assert df["default"].sum() == 1
    assert np.isfinite(df["time_s"]).all() and (df["time_s"] > 0).all()
    assert np.isfinite(df["error"]).all()
    # the default is the reference of the ratio column
    assert df.loc[df["default"], "time_ratio_to_default"].iloc[0] == pytest.approx(1.0)
    # Hamrock-Brewe's approximation is a few per cent off at the circle (k = 1.0339 there, not
    # 1), while the exact solution agrees with the 30-digit one to round-off
    approx = df[df["variant"].str.startswith("approximate")].iloc[0]
    exact = df[df["variant"].str.startswith("exact")].iloc[0]
    assert 0.01 < approx["error"] < 0.05
    assert exact["error"] < 1e-12
    md = (out / "bench.md").read_text(encoding="utf-8")
    assert "- command: `torlab bench --quick --only hertz -o " in md
    assert "CPU:" in md and "numpy" in md and "Python" in md
    header = "| component | variant | default | time | error | time / default |"
    assert header in md
    table = [ln for ln in md.splitlines() if ln.startswith("| Hertz contact |")]
    assert len(table) == 2 and all(ln.count("|") == 9 for ln in table)
    assert (out / "plots" / "hertz_contact.png").read_bytes()[:8] == PNG_MAGIC


def test_cli_unknown_benchmark_is_one_line_exit_2(cli, tmp_path):
    res = cli("bench", "--quick", "--only", "nosuchthing", "-o", tmp_path / "b")
    assert res.exit_code == 2
    lines = error_lines(res)
    assert len(lines) == 1 and "--only" in lines[0] and "nosuchthing" in lines[0]
    assert "hertz" in lines[0]  # lists what is available
    assert not (tmp_path / "b").exists()


def test_cli_refuses_occupied_output_before_running(cli, tmp_path):
    out = tmp_path / "b"
    out.mkdir()
    (out / "mine.txt").write_text("user file")
    res = cli("bench", "--quick", "--only", "hertz", "-o", out)
    assert res.exit_code == 2
    assert (out / "mine.txt").read_text() == "user file"


# --- the runner ---------------------------------------------------------------------------------
def test_discovers_the_benchmark_modules():
    names = available_benchmarks()
    assert {"hertz", "fastsim", "temperature"} <= set(names)
    assert "runner" not in names
    assert names.index("hertz") < names.index("fastsim")


def test_failing_module_becomes_a_failed_row_and_others_still_run(monkeypatch, tmp_path):
    boom = types.ModuleType("torlab.bench.zz_boom")

    def run(quick: bool = False):
        raise RuntimeError("deliberate failure")

    boom.run = run
    ok = types.ModuleType("torlab.bench.zz_ok")
    ok.run = lambda quick=False: [BenchRow("ok component", "only", 1e-3, 0.5, "truth", True, "x")]
    monkeypatch.setitem(sys.modules, "torlab.bench.zz_boom", boom)
    monkeypatch.setitem(sys.modules, "torlab.bench.zz_ok", ok)
    monkeypatch.setattr("torlab.bench.runner.available_benchmarks", lambda: ["zz_boom", "zz_ok"])
    res = run_benchmarks(quick=True)
    assert res.failed == ["zz_boom"]
    assert [r.variant for r in res.rows] == ["FAILED", "only"]
    assert "RuntimeError: deliberate failure" in res.rows[0].reference
    with OutputDir(tmp_path / "o") as out:
        write_bench_outputs(res, out, "test")
    df = pd.read_csv(tmp_path / "o" / "bench.csv")
    assert df["status"].tolist() == ["failed", "ok"]
    assert "| zz_boom | failed |" in (tmp_path / "o" / "bench.md").read_text(encoding="utf-8")


def test_outputs_survive_awkward_extras(tmp_path):
    rows = [
        BenchRow("c", "a", 2e-3, 0.0, "ref", True, "u", extra={"speedup": math.inf, "d": {"k": 1},
                                                                "note": "x|y", "n": 3}),
        BenchRow("c", "b", 4e-3, None, "ref", False, "u", extra={"n": 5, "note": "p"}),
        BenchRow("c", "c", 8e-3, 1e-6, "ref", False, "u"),
    ]
    res = BenchResult(rows=rows, modules=[("m", "ok", 0.1, 3, "")], quick=True,
                      machine={"cpu": "test"})
    with OutputDir(tmp_path / "o") as out:
        names = write_bench_outputs(res, out, "cmd")
    assert "plots/c.png" in names
    df = pd.read_csv(tmp_path / "o" / "bench.csv")
    assert df["time_ratio_to_default"].tolist() == pytest.approx([1.0, 2.0, 4.0])
    assert math.isinf(df["x_speedup"].iloc[0])  # written as text, not refused
    assert math.isnan(df["error"].iloc[1])
    md = bench_markdown(res, "cmd")
    assert "x\\|y" in md  # a pipe cannot break the Markdown table
    assert "- speedup: inf" in md  # a figure only one variant has is listed under it


def test_figure_needs_a_measured_error():
    with pytest.raises(ValueError, match="no variant"):
        time_error_figure("c", [BenchRow("c", "a", 1e-3, None)])
    fig = time_error_figure("c", [BenchRow("c", "a", 1e-3, 0.0, default=True),
                                  BenchRow("c", "b", 2e-3, 1e-4)])
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert "error" in ax.get_xlabel() and ax.get_ylabel().startswith("time t") \
        and ax.get_ylabel().endswith("(s)")


def test_only_validation():
    with pytest.raises(TorlabInputError, match="available"):
        run_benchmarks(quick=True, only=["hertz,bogus"])


# --- equal-error interpolation ------------------------------------------------------------------
def test_time_at_error_on_a_first_order_family():
    # t = C / e exactly (a first-order method: halving the error doubles the work)
    pts = [(e, 1e-5 / e) for e in (1e-1, 1e-2, 1e-3, 1e-4)]
    t, how = time_at_error(pts, 3e-3)
    assert how == "interpolated" and t == pytest.approx(1e-5 / 3e-3, rel=1e-12)
    t, how = time_at_error(pts, 1e-5)
    assert how == "extrapolated" and t == pytest.approx(1.0, rel=1e-9)
    t, how = time_at_error(pts, 1e-6)  # more than a factor 10 beyond the data: no number
    assert how == "out of range" and math.isnan(t)
    t, how = time_at_error(pts, 0.5)
    assert how == "upper bound" and t == pytest.approx(1e-4)
    # a slower member that is no more accurate is off the front and ignored
    t, _ = time_at_error([*pts, (1e-2, 1.0)], 3e-3)
    assert t == pytest.approx(1e-5 / 3e-3, rel=1e-12)


# --- the baseline: the thesis's recurrence on a uniform grid -----------------------------------
def test_naive_baseline_converges_at_first_order_to_kalker_linear_theory():
    # classic FASTSIM (no layer), creepage far below sliding: Fx = G a b C11 xi exactly in
    # the continuous model (Kalker's linear theory, docs/model/kalker.md)
    p = scene_problem(layer=False)
    G, nu = combined_G_nu(210e9, 0.28, 210e9, 0.28)
    xi = 1e-6
    lin = G * p.a * p.b * C11(p.a / p.b, nu) * xi / p.load
    e100 = abs(naive_fastsim(p, xi, 100, 100)[0] / lin - 1)
    e200 = abs(naive_fastsim(p, xi, 200, 200)[0] / lin - 1)
    assert e200 < 0.006
    assert 1.7 < e100 / e200 < 2.3  # first order: doubling the grid halves the error


def test_naive_baseline_limits_and_symmetry():
    p = scene_problem(boundary={"L_mup": "0.01 um"})
    mu = naive_fastsim(p, [1.0, -1.0, 0.0], 100, 100)
    assert mu[0] == pytest.approx(0.45, rel=1e-9)  # full slip: mu_c2 everywhere
    assert mu[1] == -mu[0] and mu[2] == 0.0
    # one creepage at a time gives what the whole curve gives
    x = np.linspace(0, 0.05, 7)
    assert [naive_fastsim(p, v, 20, 30)[0] for v in x] == pytest.approx(
        naive_fastsim(p, x, 20, 30), rel=1e-14)


def test_naive_baseline_agrees_with_torlab_scheme_on_a_fine_grid():
    from torlab.model.fastsim import boundary_traction

    p = scene_problem()
    x = np.array([1e-3, 1e-2, 0.05])
    ref = boundary_traction(p, x).mu  # an independent implementation (closed forms, Gauss)
    assert naive_fastsim(p, x, 200, 400) == pytest.approx(ref, rel=5e-3)


# --- the Hertz reference ------------------------------------------------------------------------
def test_hertz_reference_circle_closed_form():
    # circular contact: a^3 = 3 F R' / (4 E*) with R' = rx = ry (Johnson Eq. 4.22)
    F, r, Es = 1e3, 0.01, 1.15e11
    a, b, p0 = hertz_reference(F, r, r, Es)
    a_ref = (3 * F * r / (4 * Es)) ** (1 / 3)
    assert a == pytest.approx(a_ref, rel=1e-14) and b == pytest.approx(a_ref, rel=1e-14)
    assert p0 == pytest.approx(3 * F / (2 * math.pi * a_ref**2), rel=1e-13)


def test_hertz_reference_swaps_axes():
    a1, b1, _ = hertz_reference(2e4, 0.35, 0.05, 1.15e11)
    a2, b2, _ = hertz_reference(2e4, 0.05, 0.35, 1.15e11)
    assert a1 > b1 and a1 == pytest.approx(b2, rel=1e-14) and b1 == pytest.approx(a2, rel=1e-14)


# --- the benchmark modules in their quick form ---------------------------------------------------
@pytest.mark.slow
def test_fastsim_quick_rows_and_ratios():
    from torlab.bench import fastsim

    rows = fastsim.run(quick=True)
    curve = [r for r in rows if r.component == "fastsim traction curve"]
    defaults = [r for r in curve if r.default]
    assert len(defaults) == 1
    d = defaults[0]
    assert d.extra["family"] == "torlab"
    families = {r.extra["family"] for r in curve}
    assert {"torlab", "baseline, square cells", "uniform midpoint-consistent"} <= families
    assert all(math.isfinite(r.time_s) and r.time_s > 0 for r in curve)
    assert all(r.error is not None and math.isfinite(r.error) for r in curve)
    for key in ("ratio_vs_square_baseline_at_0.1pct", "ratio_vs_tuned_baseline_at_0.1pct"):
        assert d.extra[key] > 0 and d.extra[key + "_how"] in ("interpolated", "extrapolated",
                                                              "upper bound")
    # the naive baseline converges: its square-cell errors fall as the grid grows
    sq = sorted((r for r in curve if r.extra["family"] == "baseline, square cells"),
                key=lambda r: r.extra["n"])
    assert all(a.error > b.error for a, b in itertools.pairwise(sq))


def test_temperature_quick_rows():
    from torlab.bench import temperature

    rows = {r.variant: r for r in temperature.run(quick=True)}
    default = [r for r in rows.values() if r.default]
    assert len(default) == 1 and default[0].extra["loop"] == "iterated"
    coarse = rows["temperature_nodes=24, tolerance 0.1 K"]
    fine = rows["temperature_nodes=96, tolerance 0.1 K"]
    assert fine.error < coarse.error  # the temperature grid converges towards the reference
    off = rows["temperature ignored (isothermal limits)"]
    # with mu_T = -0.002 1/K and a flash temperature of ~200 K the limits drop by tens of per cent
    assert off.error > 0.05 > 100 * default[0].error


def test_cli_benchmark_cases_are_runnable_and_their_library_calls_compile():
    """Every measured command's inputs exist, its library equivalent is valid Python, and
    the quick set is --help plus one prediction with and without its figure; the three
    protocols are timed cold and warm."""
    from torlab.bench import cli as bench_cli

    full = bench_cli.cases(quick=False)
    assert full[0].argv == ["--help"] and full[0].library is None
    for c in full:
        for a in c.argv:
            if a.endswith((".yaml", ".txt", ".csv")):
                assert Path(a).exists(), (c.name, a)
        if c.library is not None:
            compile(c.library, c.name, "exec")
    assert [c.name for c in bench_cli.cases(quick=True)] == [c.name for c in full[:3]]
    assert "--no-plot" in full[2].argv
    runs = [c for c in full if c.argv[0] == "run"]
    assert [c.name.split()[-1] for c in runs] == ["(cold)", "(warm)"] * 3
    assert all(c.warm == ("--force" in c.argv) for c in runs)


def test_cli_benchmark_library_call_does_the_commands_work(cli, tmp_path):
    """The library script of 'predict traction' writes the same table as the command."""
    from torlab.bench import cli as bench_cli

    case = bench_cli.cases(quick=True)[1]
    out = tmp_path / "cmd"
    res = cli(*[a.replace("{out}", str(out)) for a in case.argv])
    assert res.exit_code == 0, res.output
    lib = tmp_path / "lib"
    lib.mkdir()
    exec(compile(case.library, case.name, "exec"), {"OUT": str(lib)})
    a = pd.read_csv(out / "traction.csv")
    b = pd.read_csv(lib / "traction.csv")
    pd.testing.assert_frame_equal(a, b, check_exact=False, rtol=1e-8)  # OutputDir rounds


@pytest.mark.slow
def test_bands_quick_rows():
    """The band benchmark measures the plain curve, the default band and both methods in one
    run; the default is linearised for the HPT-fitted wheel-rail scene (k + 2 = 6 model
    evaluations: four steps and two probes), and its edges agree with the sampled reference
    within a half-width."""
    from torlab.bench import bands

    out = bands.run(quick=True)
    rows = {r.variant.split(" (")[0]: r for r in out
            if r.component not in ("band draws", "sampled band on 2 processes",
                                   "nonlinear traction band")}
    assert set(rows) == {"plain curve", "band, automatic choice", "band, linear",
                         "band, sampling"}
    # the sampled band on 2 processes as one task and as its blocks: the same band
    par = {r.variant: r for r in out if r.component == "sampled band on 2 processes"}
    assert set(par) == {"the band one task", "its blocks of draws as tasks"}
    assert par["its blocks of draws as tasks"].error == 0.0
    # the draws one by one and many per call: the same numbers (error 0 against one by one)
    draws = [r for r in out if r.component == "band draws"]
    assert {r.variant.split(" (")[0] for r in draws} == {"row by row", "many draws per call"}
    assert all(r.error == 0 for r in draws if r.variant.startswith("many"))
    d = rows["band, automatic choice"]
    assert d.default and "(linear)" in d.variant and d.extra["model_evaluations"] == 6
    assert 0 < d.error < 1.0
    # the nonlinear curve: the second-order band from a dozen evaluations, its edges near a
    # 600-draw band (whose own noise is about 0.1 half-widths; 3000 draws: test_band_draws)
    nl = {r.variant.split(" (")[0]: r for r in out if r.component == "nonlinear traction band"}
    assert set(nl) == {"plain curve", "band, automatic choice", "band, sampling"}
    a = nl["band, automatic choice"]
    assert "(second-order)" in a.variant and a.extra["model_evaluations"] <= 12
    assert 0 < a.error < 0.3


@pytest.mark.slow
def test_removal_fit_rows_fit_the_same_rates_with_kept_tables():
    """The removal-fit rows: three synthetic tests fitted with nothing kept and with an
    earlier fit's tables kept give the same rates (kept tables are the same tables), near
    the generating rate (the fit's statistical error), and the ratio of their times is
    measured in the same run (no time asserted)."""
    from torlab.bench.fit import _removal_rows

    built, kept = _removal_rows(quick=True)
    assert built.default and not kept.default
    assert "nothing kept" in built.variant and "kept" in kept.variant
    assert kept.extra["k1_change_with_kept_tables"] == 0.0
    assert built.error == kept.error and built.error < 0.1
    assert built.extra["max_z"] < 4.0 and built.extra["fits"] == 2.0
    assert built.extra["time_over_kept"] > 0
