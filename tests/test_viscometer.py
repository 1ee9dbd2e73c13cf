"""Falling-body viscometer: format, terminal velocity, NIST E3, Barus/Roelands fits, CLI."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from conftest import ROOT, error_lines, sha

from torlab.errors import TorlabInputError
from torlab.fit.result import FitResult
from torlab.fit.viscosity import fit_barus, fit_roelands
from torlab.parsers.viscometer import parse_calibration_constant, read_viscometer
from torlab.reduce.viscometer import (
    find_falls,
    liquid_density,
    reduce_viscometer,
    relative_viscosity,
    terminal_velocity,
)

DOC = (ROOT / "docs" / "formats" / "viscometer.md").read_text(encoding="utf-8")
EXAMPLE = DOC.split("```text\n# torlab-visc", 1)[1].split("```", 1)[0]
EXAMPLE = "# torlab-visc" + EXAMPLE
SAMPLE = ROOT / "sample_data" / "visc"


def test_nist_tn1900_example_e3_relative_falling_ball():
    # NIST Technical Note 1900 (2015), Example E3: 5.69 mPa s
    eta = relative_viscosity(4.63, 36.6, 61.0, 2217.0, 810.0, 1180.0)
    assert eta == pytest.approx(5.687, abs=5e-4)
    assert eta == pytest.approx(4.63 * 1037 * 61.0 / (1407 * 36.6), rel=1e-12)
    with pytest.raises(TorlabInputError):
        relative_viscosity(4.63, 36.6, 61.0, 800.0, 810.0, 1180.0)


def test_documented_example_by_hand():
    df, meta = read_viscometer(io.StringIO(EXAMPLE), name="viscometer.md example")
    assert meta.calibration_constant == pytest.approx(1.9e-8)
    assert (meta.liquid_density, meta.body_density) == (960.0, 7850.0)
    assert df["fall"].tolist().count(1) == 10 and df["line"].iloc[0] == 11
    res = reduce_viscometer(df, meta)
    assert len(res.falls) == 1
    f = res.falls.iloc[0]
    assert f["velocity_m_s"] == pytest.approx(0.002, rel=1e-9)
    # eta = 1.9e-8 x (7850 - 960) / 0.002 = 65.455 mPa s
    assert f["viscosity_Pa_s"] == pytest.approx(1.9e-8 * 6890 / 0.002, rel=1e-9)
    assert f["pressure_Pa"] == pytest.approx(0.1e6)
    assert f["first_line"] == 13


def test_calibration_constant_units():
    assert parse_calibration_constant("1.9e-8 m^3/s^2") == pytest.approx(1.9e-8)
    assert parse_calibration_constant("19 mm^3/s^2") == pytest.approx(1.9e-8)
    assert parse_calibration_constant(2e-8) == 2e-8
    with pytest.raises(TorlabInputError, match="not m\\^3/s\\^2"):
        parse_calibration_constant("1.9e-8 m/s")
    with pytest.raises(TorlabInputError, match="positive"):
        parse_calibration_constant("-1 m^3/s^2")


def test_dowson_higginson_density_by_hand():
    assert liquid_density(900.0, 1e9, "dowson-higginson") == pytest.approx(900 * (1 + 0.6 / 2.7))
    assert liquid_density(900.0, 0.0, "dowson-higginson") == pytest.approx(900.0)
    assert liquid_density(900.0, 3e8, "constant") == 900.0


def _fall_trace(v: float, tau: float, L: float, dt: float, noise: float = 0.0, seed: int = 0):
    """Release with exponential approach to v, then a uniform deceleration over the last 1 mm."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 2 * L / v + 5 * tau, dt)
    x = v * (t - tau * (1 - np.exp(-t / tau)))
    xs = L - 1e-3  # start of the deceleration: x = xs + v s - v s^2 / (2 T), T = 2 mm / v
    T = 2e-3 / v
    i = np.argmax(x >= xs)
    s = t[i:] - t[i]
    x[i:] = np.where(s < T, xs + v * s - v * s * s / (2 * T), xs + v * T / 2)
    return t, x + noise * rng.standard_normal(t.size)


def test_terminal_velocity_ignores_acceleration_and_deceleration():
    t, x = _fall_trace(v=1e-3, tau=0.5, L=8e-3, dt=0.05)
    v, _se, s0, s1 = terminal_velocity(t, x)
    # the steady part excludes the start (velocity < 98 % for t < 0.5 ln 50 = 1.96 s) and the
    # deceleration (from x = 7 mm on, the last 2 s of motion)
    assert v == pytest.approx(1e-3, rel=5e-4)
    assert t[s0] > 1.5 and t[s1 - 1] <= 7.5  # deceleration from x = 7 mm, at t = 7 s + tau
    # with 0.5 um LVDT noise: within a few standard errors
    tn, xn = _fall_trace(v=1e-3, tau=0.5, L=8e-3, dt=0.05, noise=0.5e-6, seed=3)
    vn, sen, _, _ = terminal_velocity(tn, xn)
    assert abs(vn - 1e-3) < 5 * sen + 2e-6
    with pytest.raises(TorlabInputError, match="does not move"):
        terminal_velocity(t, np.zeros_like(t))


def test_find_falls_in_a_trace_with_returns_and_rests():
    parts = []
    for v in (2e-3, 1e-3, 0.5e-3):
        parts += [np.zeros(30), _fall_trace(v, 0.3, 8e-3, 0.1)[1], np.full(30, 8e-3),
                  np.linspace(8e-3, 0, 20)]
    x = np.concatenate(parts) + 1e-7 * np.random.default_rng(1).standard_normal(
        sum(p.size for p in parts))
    t = 0.1 * np.arange(x.size)
    falls = find_falls(t, x)
    assert len(falls) == 3
    vs = [terminal_velocity(t[a:b], x[a:b])[0] for a, b in falls]
    assert vs == pytest.approx([2e-3, 1e-3, 0.5e-3], rel=2e-3)


# --- fits ------------------------------------------------------------------------------------------
def test_barus_fit_matches_scipy_linregress():
    from scipy import stats

    p = np.array([0.1, 50, 100, 150, 200, 250, 300]) * 1e6
    rng = np.random.default_rng(4)
    eta = 0.05 * np.exp(12e-9 * p) * np.exp(0.02 * rng.standard_normal(p.size))
    f = fit_barus(p, eta)
    ref = stats.linregress(p, np.log(eta))
    assert f.alpha == pytest.approx(ref.slope, rel=1e-10)
    assert math.log(f.eta0) == pytest.approx(ref.intercept, rel=1e-10)
    assert f.alpha_se == pytest.approx(ref.stderr, rel=1e-8)
    tq = 2.570581835636314  # Student t, 97.5 %, 5 degrees of freedom (tables)
    assert f.alpha_ci == pytest.approx((ref.slope - tq * ref.stderr, ref.slope + tq * ref.stderr),
                                       rel=1e-8)
    _lo, hi = f.eta0_ci
    assert math.log(hi) - math.log(f.eta0) == pytest.approx(tq * ref.intercept_stderr, rel=1e-8)
    assert f.dof == 5 and f.residuals == pytest.approx(np.log(eta) - (ref.intercept + ref.slope * p))
    assert not any("curved" in w for w in f.warnings)
    # exact Barus data: exact parameters
    g = fit_barus(p, 0.05 * np.exp(12e-9 * p))
    assert g.alpha == pytest.approx(12e-9, rel=1e-10) and g.eta0 == pytest.approx(0.05, rel=1e-10)


def _roelands_closed_form(p, eta0, Z):
    # Eq. 5.38 written out: eta = eta0 exp((ln eta0 + 9.67)((1 + 5.1e-9 p)^Z - 1))
    return eta0 * np.exp((np.log(eta0) + 9.67) * ((1 + 5.1e-9 * p) ** Z - 1))


def test_roelands_fit_recovers_exact_parameters():
    p = np.array([0.1, 50, 100, 150, 200, 250, 300]) * 1e6
    eta = _roelands_closed_form(p, 0.065, 0.42)
    f = fit_roelands(p, eta)  # eta0 from the atmospheric point
    assert f.eta0_source.startswith("measured at atmospheric")
    assert f.Z == pytest.approx(0.42, abs=2e-4)  # eta0 at 0.1 MPa differs from p = 0 slightly
    g = fit_roelands(p, eta, fit_eta0=True)
    assert g.Z == pytest.approx(0.42, rel=1e-7) and g.eta0 == pytest.approx(0.065, rel=1e-7)
    assert g.alpha == pytest.approx((math.log(0.065) + 9.67) * 5.1e-9 * 0.42, rel=1e-6)
    h = fit_roelands(p, eta, eta0=0.065)
    assert h.Z == pytest.approx(0.42, rel=1e-8) and h.eta0_source == "given"
    # Barus on Roelands data: ln eta is curved, and the fit says so
    b = fit_barus(p, eta)
    assert any("curved" in w for w in b.warnings)


def test_fit_warnings_and_too_few_points():
    p = np.array([0.1, 20, 40, 60, 80]) * 1e6
    eta = _roelands_closed_form(p, 0.065, 0.42) * np.exp(0.01 * np.array([1, -1, 1, -1, 1]))
    f = fit_roelands(p, eta)
    assert any("below 100 MPa" in w for w in f.warnings)
    with pytest.raises(TorlabInputError, match="at least 3 points"):
        fit_barus(p[:2], eta[:2])
    with pytest.raises(TorlabInputError, match="at least 3 points"):
        fit_roelands(p[1:3], eta[1:3])  # no atmospheric point: eta0 and Z fitted, 2 points
    with pytest.raises(TorlabInputError, match="one pressure"):
        fit_barus([1e6, 1e6, 1e6], [0.1, 0.1, 0.1])
    g = fit_roelands(p[1:], eta[1:])
    assert g.eta0_source == "fitted" and any("no point at atmospheric" in w for w in g.warnings)


def test_scene_dict_round_trips_through_units():
    from torlab.units import to_si

    p = np.array([0.1, 100, 200, 300]) * 1e6
    f = fit_roelands(p, _roelands_closed_form(p, 0.065, 0.42), fit_eta0=True)
    assert isinstance(f, FitResult) and f.kind == "viscosity"  # one result type for every fit
    d = f.to_scene_dict()["lubricant"]
    assert d["viscosity"] == "roelands" and set(d) == {"eta0", "viscosity", "alpha", "Z"}
    assert to_si(d["eta0"], "viscosity") == pytest.approx(0.065, rel=1e-5)
    assert to_si(d["alpha"], "inverse_pressure") == pytest.approx(f.alpha, rel=1e-5)
    assert d["Z"] == pytest.approx(0.42, rel=1e-5)
    b = fit_barus(p, 0.05 * np.exp(1.5e-8 * p)).to_scene_dict()
    assert b == {"lubricant": {"eta0": "50 mPa*s", "viscosity": "barus", "alpha": "15 1/GPa"}}


# --- the synthetic Paper B campaign against its truth --------------------------------------------
def test_sample_campaign_against_truth():
    from torlab.reduce.viscometer import calibrate
    from torlab.yamlio import load_yaml

    truth = load_yaml(SAMPLE / "truth.yaml").data
    K_true = truth["rig"]["K_m3_s2"]
    rdf, rmeta = read_viscometer(SAMPLE / "visc_reference_25C.txt")
    cal = calibrate(rdf, rmeta)
    assert cal.n_falls == 5 and cal.K == pytest.approx(K_true, rel=3e-3)
    df, meta = read_viscometer(SAMPLE / "visc_ester_25C.txt")
    assert meta.calibration_constant is None and meta.density_model == "dowson-higginson"
    res = reduce_viscometer(df, meta, calibration=cal)
    ester = next(r for r in truth["runs"] if r["file"] == "visc_ester_25C.txt")
    tv = np.array([f["viscosity_Pa_s"] for f in ester["falls"]])
    tp = np.array([f["pressure_Pa"] for f in ester["falls"]])
    assert len(res.falls) == len(tv) == 21 and len(res.steps) == 7
    assert res.falls["pressure_Pa"].to_numpy() == pytest.approx(tp, rel=0.005, abs=0.3e6)
    assert res.falls["viscosity_Pa_s"].to_numpy() == pytest.approx(tv, rel=5e-3)
    assert (res.falls["steady_fraction"] > 0.5).all()
    run = ester["run"]
    r = fit_roelands(res.falls["pressure_Pa"], res.falls["viscosity_Pa_s"], fit_eta0=True)
    assert r.Z == pytest.approx(run["Z"], abs=0.01)
    assert r.eta0 == pytest.approx(run["eta0_Pa_s"], rel=0.01)
    assert r.Z_ci[0] < run["Z"] + 0.01 and r.Z_ci[1] > run["Z"] - 0.01
    # Barus on these data: the secant slope of the true law over the same points
    b = fit_barus(res.falls["pressure_Pa"], res.falls["viscosity_Pa_s"])
    bt = fit_barus(tp, tv)
    assert b.alpha == pytest.approx(bt.alpha, rel=0.01)


# --- errors and CLI ---------------------------------------------------------------------------------
def _bad(kind: str) -> tuple[str, int | None, str]:
    lines = EXAMPLE.rstrip("\n").split("\n")
    assert lines[9].startswith("time [s]")

    def join(ls):
        return "\n".join(ls) + "\n"

    if kind == "empty":
        return "", None, "empty"
    if kind == "truncated":
        lines[-1] = lines[-1][:8]
        return join(lines), 23, "truncated"
    if kind == "text_in_number":
        lines[14] = lines[14].replace("1.8000", "1.8OOO")
        return join(lines), 15, "not a number"
    if kind == "unknown_unit":
        lines[9] = lines[9].replace("position [mm]", "position [mmm]")
        return join(lines), 10, "unknown unit"
    if kind == "missing_column":
        return join(lines[:9] + [",".join(r.split(",")[:2] + r.split(",")[3:]) for r in lines[9:]]), \
            10, "missing column 'pressure'"
    if kind == "wrong_delimiter":
        return join(lines[:9] + [r.replace(",", "\t") for r in lines[9:]]), 10, "separated by '\\t'"
    if kind == "missing_key":
        return join([ln for ln in lines if "body_density" not in ln]), None, "body_density"
    if kind == "negative_pressure":
        lines[12] = lines[12].replace(",0.10,", ",-0.10,")
        return join(lines), 13, "must not be negative"
    raise AssertionError(kind)


@pytest.mark.parametrize("kind", ["empty", "truncated", "text_in_number", "unknown_unit",
                                  "missing_column", "wrong_delimiter", "missing_key",
                                  "negative_pressure"])
def test_bad_input_cli_one_line_exit_2(kind, tmp_path, cli):
    text, line, frag = _bad(kind)
    p = tmp_path / f"{kind}.txt"
    p.write_text(text)
    before = sha(p)
    r = cli("visc", "reduce", p, "-o", tmp_path / "out")
    assert r.exit_code == 2, r.output
    lines = error_lines(r)
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(p) in lines[0], lines
    assert frag in lines[0], lines[0]
    if line is not None:
        assert f"{p}:{line}:" in lines[0], lines[0]
    assert not (tmp_path / "out").exists() and sha(p) == before


def test_cli_visc_reduce_end_to_end(tmp_path, cli):
    import pandas as pd

    from torlab.yamlio import load_yaml

    gen = tmp_path / "gen"
    r = cli("synth", "visc", "-o", gen, "--seed", "7")
    assert r.exit_code == 0, r.output
    sample, ref = gen / "visc_ester_25C.txt", gen / "visc_reference_25C.txt"
    out = tmp_path / "out"
    # without a calibration: one clear error
    r = cli("visc", "reduce", sample, "-o", out)
    assert r.exit_code == 2 and "no calibration constant" in error_lines(r)[0]
    r = cli("visc", "reduce", sample, "-o", out, "--reference", ref)
    assert r.exit_code == 0, r.output
    fit = pd.read_csv(out / "visc_ester_25C_fit.csv")
    assert fit["law"].tolist() == ["barus", "roelands"]
    assert fit.loc[1, "Z"] == pytest.approx(0.42, abs=0.01)
    falls = pd.read_csv(out / "visc_ester_25C_falls.csv")
    assert len(falls) == 21 and {"residual_ln_eta_barus", "residual_ln_eta_roelands"} <= set(falls)
    lub = load_yaml(out / "visc_ester_25C_lubricant_roelands.yaml").data["lubricant"]
    assert lub["viscosity"] == "roelands" and lub["eta0"].endswith("mPa*s")
    cal = pd.read_csv(out / "calibration.csv")
    assert cal["n_falls"].tolist() == [5]
    assert (out / "visc_ester_25C_fit.png").stat().st_size > 10_000
    r = cli("visc", "reduce", sample, "-o", out, "--reference", ref)
    assert r.exit_code == 2 and "--force" in error_lines(r)[0]
    # a given K; the reference log itself as a sample (one pressure: no fits, noted)
    r = cli("visc", "reduce", ref, "-o", out, "--force", "--calibration-constant", "1.9e-8 m^3/s^2",
            "--law", "barus")
    assert r.exit_code == 0, r.output
    s = pd.read_csv(out / "summary.csv")
    assert "no barus fit" in s["notes"].iloc[0]
    r = cli("visc", "reduce", ref, "-o", out, "--force", "--law", "wlf")
    assert r.exit_code == 2 and "--law" in error_lines(r)[0]


def test_committed_quirk_file_crlf_sign_fall_column_dowson_higginson():
    from conftest import DATA

    path = DATA / "visc" / "fall_column_crlf.txt"
    assert b"\r\n" in path.read_bytes()
    df, meta = read_viscometer(path)
    assert meta.position_sign == -1 and meta.calibration_constant == pytest.approx(1.9e-8)
    assert df["position_m"].max() == pytest.approx(7e-3)  # read negative, flipped
    res = reduce_viscometer(df, meta)
    f = res.falls.iloc[0]
    assert len(res.falls) == 1 and f["velocity_m_s"] == pytest.approx(2e-3, rel=1e-9)
    # Dowson-Higginson at 100 MPa: 960 (1 + 0.06 / 1.17) kg/m^3
    rho = 960 * (1 + 0.06 / 1.17)
    assert f["liquid_density_kg_m3"] == pytest.approx(rho, rel=1e-12)
    assert f["viscosity_Pa_s"] == pytest.approx(1.9e-8 * (7850 - rho) / 2e-3, rel=1e-9)
    assert "temperature_C" not in res.falls
