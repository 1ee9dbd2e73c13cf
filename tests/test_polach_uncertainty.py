"""The layer's uncertainty carried into Polach's parameters (``torlab fit polach``).

References independent of the refits: a zero covariance (the interval is the estimate);
Polach's mu0 in full slip, which is the layer's mu_c2 (so a covariance on mu_c2 alone
gives mu0 the relative interval of mu_c2, known in closed form); the same draws on a
serial and a process executor; and a product fitted from a sample HPT log.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

import torlab
from torlab.fit.polach import N_DRAWS, NAMES, NOT_CARRIED
from torlab.parallel import ProcessExecutor, SerialExecutor, use

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
HPT = ROOT / "sample_data" / "hpt"
# a layer that saturates soon after yield (L_mup 1 um): over creepages to 20 % the curve
# is mostly full slip at mu_c2, and Polach's mu0 follows it (mu0 / mu_c2 = 1.007, the
# same to 0.1 % for mu_c2 changed by +-15 %)
LAYER = {"mu_c1": 0.30, "mu_c2": 0.45, "L_mue": 10e-6, "L_mup": 1e-6}
FULL_SLIP = {"creepage": "0:0.2:21", "speed": "10 m/s"}


def params_file(path: Path, names: list[str], cov: list[list[float]]) -> Path:
    """A parameter file with the layer and a fit covariance of ``names``."""
    doc = {"boundary": dict(LAYER),
           "fit": {"kind": "layer_hpt",
                   "covariance": {"names": names, "values": [LAYER[n] for n in names],
                                  "matrix": cov, "log_scale": names}}}
    path.write_text(yaml.safe_dump(doc))
    return path


def test_zero_covariance_collapses_to_the_estimate(tmp_path):
    p = params_file(tmp_path / "p.yaml", ["mu_c2", "L_mup"], [[0.0, 0.0], [0.0, 0.0]])
    res = torlab.fit_polach(SCENE, params=[p], draws=50, **FULL_SLIP)
    lu = res.meta["layer_uncertainty"]
    assert lu["carried"] and lu["method"] == "none" and lu["n_failed"] == 0
    for n in NAMES:
        assert lu["interval"][n] == [res.params[n], res.params[n]]
        assert lu["sd"][n] == 0.0


@pytest.mark.slow  # 200 draws, each a Polach refit: a Monte-Carlo check, in the slow step
def test_mu0_carries_the_relative_interval_of_mu_c2(tmp_path):
    """Full slip: mu0 = 1.007 mu_c2 in every draw, so ln mu0 has mu_c2's normal
    distribution (sd s): its 95 % interval is mu0 exp(-+1.96 s).  Tolerance: three
    Monte-Carlo standard errors of a 2.5 % quantile of n draws, 2.67 s / sqrt(n)."""
    s = 0.05
    n = 200
    p = params_file(tmp_path / "p.yaml", ["mu_c2"], [[(s * LAYER["mu_c2"]) ** 2]])
    res = torlab.fit_polach(SCENE, params=[p], draws=n, seed=3, **FULL_SLIP)
    lu = res.meta["layer_uncertainty"]
    assert lu["carried"] and lu["method"] == "sampling"
    assert lu["n_draws"] == n and lu["n_failed"] == 0 and lu["layer_parameters"] == ["mu_c2"]
    mu0 = res.params["mu0"]
    assert mu0 / LAYER["mu_c2"] == pytest.approx(1.007, abs=0.003)
    lo, hi = lu["interval"]["mu0"]
    tol = 3 * 2.67 * s / math.sqrt(n)
    assert math.log(lo / mu0) == pytest.approx(-1.96 * s, abs=tol)
    assert math.log(hi / mu0) == pytest.approx(1.96 * s, abs=tol)
    # the standard deviation: relative Monte-Carlo error 1/sqrt(2n) = 5 %
    assert lu["sd"]["mu0"] / mu0 == pytest.approx(s, rel=0.15)
    # mu_c2 alone explains mu0
    assert lu["correlation"]["mu0"]["mu_c2"] > 0.99
    assert lu["dominant"]["mu0"][0]["parameter"] == "mu_c2"
    assert lu["dominant"]["mu0"][0]["share"] > 0.95
    # the approximation's interval is reported apart (much narrower here)
    a_lo, a_hi = res.ci95["mu0"]
    assert a_hi - a_lo < 0.1 * (hi - lo)


@pytest.mark.slow  # a process pool; executors bit for bit: tests/test_parallel.py
def test_serial_and_processes_give_the_same_numbers(tmp_path):
    names = ["mu_c1", "mu_c2", "L_mue", "L_mup"]
    sd = np.array([0.01, 0.01, 1e-6, 0.2e-6])
    corr = np.array([[1, 0.3, 0, 0], [0.3, 1, 0, 0.2], [0, 0, 1, 0], [0, 0.2, 0, 1.0]])
    p = params_file(tmp_path / "p.yaml", names, (corr * np.outer(sd, sd)).tolist())
    out = []
    for ex in (SerialExecutor(), ProcessExecutor(2)):
        with use(ex):
            out.append(torlab.fit_polach(SCENE, params=[p], draws=24, seed=7, **FULL_SLIP))
    a, b = (r.meta["layer_uncertainty"] for r in out)
    assert a["method"] == "sampling" and a["n_draws"] == 24
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
    # the seed matters
    other = torlab.fit_polach(SCENE, params=[p], draws=24, seed=8, **FULL_SLIP)
    assert other.meta["layer_uncertainty"]["interval"] != a["interval"]


def test_without_covariance_it_is_said(tmp_path):
    res = torlab.fit_polach(SCENE, draws=10, **FULL_SLIP)
    lu = res.meta["layer_uncertainty"]
    assert not lu["carried"] and lu["interval"] is None
    assert lu["reason"].startswith(f"{NOT_CARRIED}: no covariance")
    assert any(w.startswith(f"{NOT_CARRIED}: no covariance") for w in res.warnings)
    p = params_file(tmp_path / "p.yaml", ["mu_c2"], [[1e-4]])
    off = torlab.fit_polach(SCENE, params=[p], draws=0, **FULL_SLIP)
    assert off.meta["layer_uncertainty"]["reason"] == f"{NOT_CARRIED}: no draws asked for " \
                                                      "(draws = 0)"
    # the approximation at the estimate is the same with or without the layer's draws
    on = torlab.fit_polach(SCENE, params=[p], draws=4, **FULL_SLIP)
    assert on.meta["layer_uncertainty"]["carried"]
    assert on.params == off.params and on.ci95 == off.ci95


@pytest.mark.slow  # an HPT fit, then 12 Polach refits (the library's draws: quick tests above)
def test_cli_with_a_layer_fitted_from_an_hpt_log(cli, tmp_path):
    r = cli("fit", "hpt", HPT / "hpt_OFM1_4uL_25C.txt", "--compliance",
            HPT / "rig_compliance.csv", "-o", tmp_path / "layer")
    assert r.exit_code == 0, r.output
    args = ("fit", "polach", SCENE, tmp_path / "layer" / "params.yaml", "--speed", "10 m/s",
            "--creepage", "0:0.05:21", "--draws", "12", "-j", "1", "-q")
    res = cli(*args, "-o", tmp_path / "p")
    assert res.exit_code == 0, res.output
    assert "95 % interval from the layer" in res.output and "12 draws" in res.output
    assert "only 12 draws" in " ".join(res.output.split())  # few draws: said
    summ = json.loads((tmp_path / "p" / "summary.json").read_text())
    lu = summ["meta"]["layer_uncertainty"]
    assert lu["carried"] and lu["n_draws"] == 12
    assert lu["layer_parameters"] == ["mu_c1", "mu_c2", "L_mue", "L_mup"]
    tab = pd.read_csv(tmp_path / "p" / "layer_intervals.csv")
    assert list(tab.parameter) == list(NAMES)
    assert {"layer_low95", "layer_high95", "approx_ci95_low", "approx_ci95_high",
            "corr_mu_c2", "dominant"} <= set(tab.columns)
    assert np.all(tab.layer_low95 <= tab.value) and np.all(tab.value <= tab.layer_high95)
    mu0 = tab.set_index("parameter").loc["mu0"]
    assert mu0.layer_high95 > mu0.layer_low95
    # the fit error is reported as before
    assert "largest difference" in res.output
    assert {"mu_torlab", "mu_polach", "residual"} <= set(
        pd.read_csv(tmp_path / "p" / "fit_data.csv").columns)
    # without the product's covariance the report says so
    res = cli("fit", "polach", SCENE, "--speed", "10 m/s", "--creepage", "0:0.05:21",
              "-q", "-o", tmp_path / "q")
    assert res.exit_code == 0, res.output
    assert f"{NOT_CARRIED}: no covariance" in " ".join(res.output.split())
    summ = json.loads((tmp_path / "q" / "summary.json").read_text())
    assert summ["meta"]["layer_uncertainty"]["carried"] is False


def test_cli_default_draws_is_the_library_default():
    import inspect

    from torlab.cli.fit import polach_cmd

    assert inspect.signature(polach_cmd).parameters["draws"].default == N_DRAWS
