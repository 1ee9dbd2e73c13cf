"""Test protocols: validation, the shipped protocols, reports, provenance, re-runs.

Each shipped protocol runs once per session (module-scoped fixtures).  The tests of the
Paper A and Paper C runs (about ten seconds each) are in CI's slow step (``-m slow``); the
quick suite runs Paper B's, from raw logs to reports.  Each run's
``summary.json`` is compared with ``tests/expected/<name>.json`` within the
tolerances below; a changed number fails with a readable diff.  Set
``TORLAB_UPDATE_EXPECTED=1`` to rewrite the expected files after an intended
change (and review the diff before committing).

Accuracy is checked against references the code does not produce: the
generating truth of the synthetic sample data (``sample_data/*/truth.yaml`` and
the product laws of :mod:`torlab.synth.hpt`), SHA-256 computed here with
hashlib, and the model truth of the optical logs (sample_data/optical/truth.yaml).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from conftest import SMALL_PROTOCOL as SMALL

from tests.conftest import REAL_PCS, ROOT, error_lines, sha

PROTOCOLS = ROOT / "protocols"
EXPECTED = Path(__file__).resolve().parent / "expected"

#: relative and absolute tolerance of the summary comparison, per top-level section
TOLERANCES = {"data": (1e-6, 1e-12), "reports": (1e-4, 1e-9), "fits": (1e-3, 1e-9)}
#: sections of summary.json compared with the expected file
COMPARED = ("protocol", "data", "fits", "reports")


# --------------------------------------------------------------------------- helpers
def _diff(expected: Any, got: Any, path: str, rtol: float, atol: float, out: list[str]) -> None:
    if isinstance(expected, dict) and isinstance(got, dict):
        for k in expected:
            if k not in got:
                out.append(f"{path}.{k}: missing (expected {expected[k]!r})")
            else:
                _diff(expected[k], got[k], f"{path}.{k}", rtol, atol, out)
        for k in got:
            if k not in expected:
                out.append(f"{path}.{k}: new key (value {got[k]!r})")
    elif isinstance(expected, list) and isinstance(got, list):
        if len(expected) != len(got):
            out.append(f"{path}: {len(expected)} items expected, got {len(got)}")
        for i, (e, g) in enumerate(zip(expected, got, strict=False)):
            _diff(e, g, f"{path}[{i}]", rtol, atol, out)
    elif isinstance(expected, (int, float)) and isinstance(got, (int, float)) \
            and not isinstance(expected, bool) and not isinstance(got, bool):
        if not math.isclose(float(expected), float(got), rel_tol=rtol, abs_tol=atol):
            rel = abs(got - expected) / max(abs(expected), 1e-300)
            out.append(f"{path}: expected {expected!r}, got {got!r} (relative change {rel:.2e}, "
                       f"tolerance {rtol:g})")
    elif expected != got:
        out.append(f"{path}: expected {expected!r}, got {got!r}")


def compare_summary(name: str, summary: dict[str, Any]) -> list[str]:
    """Differences between ``summary`` and ``tests/expected/<name>.json`` (empty: equal)."""
    current = {k: summary[k] for k in COMPARED}
    current["protocol"] = {k: v for k, v in current["protocol"].items() if k != "sha256"}
    path = EXPECTED / f"{name}.json"
    if os.environ.get("TORLAB_UPDATE_EXPECTED"):
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps(current, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    expected = json.loads(path.read_text(encoding="utf-8"))
    diffs: list[str] = []
    for sec in COMPARED:
        rtol, atol = TOLERANCES.get(sec, (0.0, 0.0))
        _diff(expected.get(sec), current.get(sec), sec, rtol, atol, diffs)
    return diffs


@pytest.fixture(scope="module")
def paper_a(shipped_run):
    return shipped_run("paper_a")


@pytest.fixture(scope="module")
def paper_b(shipped_run):
    return shipped_run("paper_b")


@pytest.fixture(scope="module")
def paper_c(shipped_run):
    return shipped_run("paper_c")


# --------------------------------------------------------------------------- validation
BAD = """\
version: 1
name: bad protocol
data:
  hpt:
    files: [missing_*.txt]
    window: 3 s
    colour: blue
fits:
  hpt_layers:
    amounts: [4 kg/m^3]
reports:
  amount:
    band: [0.3, 0.2]
  traction:
    curves:
      - label: x
        scene: nowhere.yaml
        params: ["traction:nope"]
"""


def _line_of(text: str, needle: str) -> int:
    for i, ln in enumerate(text.splitlines(), 1):
        if needle in ln:
            return i
    raise AssertionError(needle)


def test_every_problem_listed_with_line_and_key(tmp_path):
    from torlab.errors import ValidationErrors
    from torlab.protocols.loader import load_protocol

    p = tmp_path / "bad.yaml"
    p.write_text(BAD)
    with pytest.raises(ValidationErrors) as ei:
        load_protocol(p)
    probs = {e.key: e for e in ei.value.problems}
    expect = {
        "name": "name: bad protocol",           # spaces are not allowed in names
        "data.hpt.files.0": "files: [missing",  # no file matches
        "data.hpt.window": "window: 3 s",       # a time, not a length
        "data.hpt.colour": "colour: blue",      # unknown key
        "fits.hpt_layers.amounts.0": "amounts:",
        "reports.amount": "amount:",            # band upside down
        "reports.traction.curves.0.scene.0": "scene: nowhere.yaml",
    }
    for key, needle in expect.items():
        assert key in probs, f"no problem reported for {key}: {sorted(probs)}"
        assert probs[key].line == _line_of(BAD, needle), key
        assert probs[key].path == str(p)
    assert "unknown key" in probs["data.hpt.colour"].message
    assert "not a length" in probs["data.hpt.window"].message
    assert "neither a volume" in probs["fits.hpt_layers.amounts.0"].message


def test_cross_checks_after_schema(tmp_path):
    """References between sections: a report without its data, a set no fit produces."""
    from torlab.errors import ValidationErrors
    from torlab.protocols.loader import load_protocol

    text = f"""\
version: 1
name: cross
data:
  optical:
    files: [{ROOT}/sample_data/optical/stribeck_rough.csv]
reports:
  amount: {{}}
  stribeck:
    curves:
      - label: a
        scene: {PROTOCOLS}/scenes/wheel_rail_tab54.yaml
        params: ["hpt:*", "lubricant:oil"]
        measured: {ROOT}/sample_data/optical/stribeck_smooth.csv
"""
    p = tmp_path / "cross.yaml"
    p.write_text(text)
    with pytest.raises(ValidationErrors) as ei:
        load_protocol(p)
    msgs = {(e.key, e.line): e.message for e in ei.value.problems}
    keys = {k for k, _ in msgs}
    assert "reports.amount" in keys                       # needs data.hpt
    assert "reports.stribeck.curves.0.params.0" in keys   # hpt:* without fits.hpt_layers
    assert "reports.stribeck.curves.0.params.1" in keys   # no lubricant fit named oil
    assert "reports.stribeck.curves.0.measured" in keys   # not one of data.optical
    assert "reports.stribeck.curves.0.scene" in keys      # dry scene in a Stribeck report
    assert ("reports.stribeck.curves.0.params.1", _line_of(text, "params:")) in msgs


def test_fit_names_used_twice(tmp_path, cli):
    """Two fits of one kind under one name: each repeat is listed (key, line), exit 2."""
    text = f"""\
version: 1
name: dup
data:
  optical:
    files: [{ROOT}/sample_data/optical/dry_traction_rough.csv,
            {ROOT}/sample_data/optical/film_thickness_smooth.csv]
  visc:
    files: [{ROOT}/sample_data/visc/visc_ester_25C.txt]
    reference: [{ROOT}/sample_data/visc/visc_reference_25C.txt]
fits:
  traction_layers:
    - {{name: dry, measured: {ROOT}/sample_data/optical/dry_traction_rough.csv,
       scene: {PROTOCOLS}/scenes/optical_paper_a_dry.yaml}}
    - {{name: dry, measured: {ROOT}/sample_data/optical/dry_traction_rough.csv,
       scene: {PROTOCOLS}/scenes/optical_paper_a_dry.yaml}}
  lubricants:
    - {{name: ester, measured: {ROOT}/sample_data/visc/visc_ester_25C.txt, law: roelands}}
    - {{name: ester, measured: {ROOT}/sample_data/visc/visc_ester_25C.txt, law: barus}}
reports:
  film:
    curves:
      - {{label: smooth, scene: {PROTOCOLS}/scenes/optical_paper_a_smooth.yaml,
         measured: {ROOT}/sample_data/optical/film_thickness_smooth.csv}}
"""
    p = tmp_path / "dup.yaml"
    p.write_text(text)
    r = cli("run", p, "-o", tmp_path / "out")
    assert r.exit_code == 2, r.output
    lines = error_lines(r)
    twice = [ln for ln in lines if "is used twice" in ln]
    assert len(twice) == 2, lines
    assert any("fits.traction_layers.1.name" in ln for ln in twice)
    assert any("fits.lubricants.1.name" in ln for ln in twice)
    assert not (tmp_path / "out").exists()


def test_version_and_duplicates(tmp_path):
    from torlab.errors import TorlabInputError, ValidationErrors
    from torlab.protocols.loader import load_protocol

    p = tmp_path / "v2.yaml"
    p.write_text("version: 2\nname: x\ndata: {}\n")
    with pytest.raises(TorlabInputError) as ei:
        load_protocol(p)
    assert not isinstance(ei.value, ValidationErrors)
    assert ei.value.key == "version" and ei.value.line == 1 and "not supported" in ei.value.message
    p.write_text("version: 1\nname: x\nname: y\n")
    with pytest.raises(TorlabInputError) as ei:
        load_protocol(p)
    assert ei.value.line == 3 and "twice" in ei.value.message


def test_cli_lists_every_problem_exit_2(tmp_path, cli):
    p = tmp_path / "bad.yaml"
    p.write_text(BAD)
    r = cli("run", p, "-o", tmp_path / "out")
    assert r.exit_code == 2
    lines = error_lines(r)
    assert len(lines) >= 7
    assert all(ln.startswith(f"error: {p}:") for ln in lines)
    assert "Traceback" not in r.output
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", ["paper_a", "paper_b", "paper_c", "retention"])
def test_shipped_protocols_validate(cli, name):
    r = cli("run", PROTOCOLS / f"{name}.yaml", "--validate-only")
    assert r.exit_code == 0, r.output
    assert "valid protocol" in r.output


def test_docs_examples_validate():
    """Every complete example in docs/protocols.md is a valid protocol."""
    from torlab.protocols.loader import load_protocol_text

    text = (ROOT / "docs/protocols.md").read_text()
    blocks = [b for b in re.findall(r"```yaml\n(.*?)```", text, re.S) if b.startswith("version:")]
    assert len(blocks) >= 4
    names = {load_protocol_text(b, base=PROTOCOLS).protocol.name for b in blocks}
    assert len(names) == len(blocks)


# --------------------------------------------------------------------------- Paper C
def _truth_crossing(product: str, threshold: float = 0.15) -> float | None:
    """Amount (in the product's unit) where the generating law crosses ``threshold``."""
    from torlab.synth.hpt import PRODUCTS

    law = PRODUCTS[product]
    if not law.f_low < threshold < law.f_high:
        return None
    m = law.m50_mg * ((law.f_high - law.f_low) / (threshold - law.f_low) - 1) ** (1 / law.k)
    return m if law.amount_unit == "mg" else m / (law.density_kg_m3 * 1e-3)


@pytest.mark.slow
def test_paper_c_amount_against_truth(paper_c):
    _out, res = paper_c
    amt = res.summary["reports"]["amount"]
    truth = yaml.safe_load((ROOT / "sample_data/hpt/truth.yaml").read_text())
    # every 25 degC run's f (window before the maximum) against the generating value; repeats
    # of one amount are told apart by their file
    runs = [r for r in truth["runs"] if r["applied_amount_unit"] and r["temperature_C"] == 25.0]
    keys = [f"{r['product'] + ('-' + r['condition'] if r['condition'] else '')} "
            f"{r['applied_amount']:g} {r['applied_amount_unit']}" for r in runs]
    f_true = {k if keys.count(k) == 1 else f"{k} ({r['file']})": r["friction_at_max_displacement"]
              for k, r in zip(keys, runs, strict=True)}
    assert len(f_true) == len(runs) > 25
    assert set(amt["f_by_run"]) == set(f_true)
    for k, f in amt["f_by_run"].items():
        assert abs(f - f_true[k]) < 0.01, k
    for prod, v in amt["products"].items():
        t = _truth_crossing(prod)
        if t is None:   # WFM wet never falls below 0.15 (f_low 0.24)
            assert v["status"] == "above threshold at every amount"
            assert v["crossing_amount"] is None
            continue
        assert v["status"] == "crosses"
        assert v["crossing_amount_low"] < t < v["crossing_amount_high"], (prod, t, v)
        assert abs(v["crossing_amount"] / t - 1) < 0.1, (prod, t, v["crossing_amount"])
        # mass basis: volume x density of the protocol's products: section
        dens = {"OFM1": 930, "OFM2": 950, "WFM-dry": 1100, "SFM": None}[prod]
        mf = 1.0 if dens is None else dens * 1e-3
        assert v["crossing_mass_mg"] == pytest.approx(v["crossing_amount"] * mf, rel=1e-12)


@pytest.mark.slow
def test_paper_c_layers_and_traction(paper_c):
    out, res = paper_c
    s = res.summary
    truth = yaml.safe_load((ROOT / "sample_data/hpt/truth.yaml").read_text())
    # the layer is fitted to the product's 25 degC runs at 4 uL (mg) jointly: the mean of theirs
    gen: dict[str, list[float]] = {}
    for r in truth["runs"]:
        if r["temperature_C"] == 25.0 and r["applied_amount"] in (4, None):
            prod = r["product"] + ("-" + r["condition"] if r["condition"] else "")
            gen.setdefault(prod, []).append(r["boundary"]["mu_c2"])
    assert min(len(v) for v in gen.values()) == 4
    for prod, m2 in gen.items():
        fit = s["fits"][f"hpt:{prod}"]["params"]
        assert abs(fit["mu_c2"] - sum(m2) / len(m2)) < 0.01, prod
    curves = s["reports"]["traction"]["curves"]
    assert {c.split(" (")[0] for c in curves} == set(gen)
    for v in curves.values():
        assert v["trend"] in ("negative", "neutral", "positive", "not saturated in this range",
                              "undetermined")
        assert 0 < v["mu_max"] < 1
    # every fitted layer is written as a parameter file torlab predict reads
    from torlab.scene import load_scene

    sc = load_scene(PROTOCOLS / "scenes/wheel_rail_tab54.yaml", out / "fits/hpt_OFM1.yaml")
    assert sc.boundary.mu_c2 == pytest.approx(s["fits"]["hpt:OFM1"]["params"]["mu_c2"])


def test_fit_figures_for_the_warned_sets_or_none(paper_c, tmp_path, cli, monkeypatch):
    """``reports.fit_figures`` / ``--fit-figures``: a figure for every fitted set, for those
    whose fit warned, for none, or (auto) by the number of sets; the parameter table and the
    other figures the same."""
    from torlab.protocols.runner import run_protocol

    out0, res0 = paper_c
    fits = res0.summary["fits"]
    warned = {n for n, f in fits.items() if f["warnings"]}
    assert warned and len(warned) < len(fits)  # the case is not trivial either way

    def pngs(d: Path) -> set[str]:
        return {p.name for p in (d / "fits").glob("*.png")}

    assert pngs(out0) == {f"fit_{n.replace(':', '_')}.png" for n in fits}
    out = tmp_path / "out"
    shutil.copytree(out0, out)  # its cache: a warm re-run
    r = run_protocol(PROTOCOLS / "paper_c.yaml", out, force=True, fit_figures="warned")
    assert not r.unchanged  # another option: not the earlier results
    assert pngs(out) == {f"fit_{n.replace(':', '_')}.png" for n in warned}
    md = (out / "report.md").read_text(encoding="utf-8")
    assert (f"drawn for {len(warned)} of the {len(fits)} fitted sets, those whose fit "
            "warned") in md
    for same in ("fits/parameters.csv", "amount/amount_applied.png", "traction/traction.png"):
        assert (out / same).read_bytes() == (out0 / same).read_bytes(), same
    assert r.summary["fits"] == res0.summary["fits"]
    # without figures the report says which sets would have one
    r = run_protocol(PROTOCOLS / "paper_c.yaml", out, force=True, fit_figures="warned",
                     figures=False)
    assert (f"No figures are drawn in this run; with them, data-against-model figures would "
            f"be drawn for {len(warned)} of the {len(fits)} fitted sets, those whose fit warned"
            ) in (out / "report.md").read_text(encoding="utf-8")
    # auto (the default): every set up to AUTO_ALL_SETS fitted sets (paper_c's 12 are
    # fewer: every set, as the first run drew), as warned beyond them
    import torlab.protocols.context as context

    assert len(fits) <= context.AUTO_ALL_SETS
    monkeypatch.setattr(context, "AUTO_ALL_SETS", len(fits) - 1)
    r = run_protocol(PROTOCOLS / "paper_c.yaml", out, force=True)
    assert pngs(out) == {f"fit_{n.replace(':', '_')}.png" for n in warned}
    assert (f"drawn for {len(warned)} of the {len(fits)} fitted sets, those whose fit warned "
            f"(reports.fit_figures: auto, above {len(fits) - 1} fitted sets; 'all' draws one "
            "for every set)") in (out / "report.md").read_text(encoding="utf-8")
    monkeypatch.setattr(context, "AUTO_ALL_SETS", len(fits))
    r = run_protocol(PROTOCOLS / "paper_c.yaml", out, force=True)
    assert pngs(out) == {f"fit_{n.replace(':', '_')}.png" for n in fits}
    assert "Data-against-model figures are drawn for" not in (out / "report.md").read_text()
    # the protocol's key, and none
    text = (PROTOCOLS / "paper_c.yaml").read_text().replace(
        "../sample_data/", (ROOT / "sample_data").as_posix() + "/").replace(
        "scenes/", (PROTOCOLS / "scenes").as_posix() + "/")
    assert "\nreports:\n" in text
    p = tmp_path / "paper_c.yaml"
    p.write_text(text.replace("\nreports:\n", "\nreports:\n  fit_figures: none\n", 1))
    r = cli("run", p, "-o", out, "--force", "-q")
    assert r.exit_code == 0, r.output
    assert pngs(out) == set() and (out / "amount" / "amount_applied.png").is_file()
    assert "No data-against-model figures are drawn" in (out / "report.md").read_text()
    r = cli("run", p, "-o", out, "--force", "-q", "--fit-figures", "some")
    assert r.exit_code == 2
    assert error_lines(r) == ["error: --fit-figures: 'some': expected auto, all, warned or "
                              "none"]
    p.write_text(text.replace("\nreports:\n", "\nreports:\n  fit_figures: few\n", 1))
    r = cli("run", p, "-o", tmp_path / "other", "-q")
    assert r.exit_code == 2
    line = text.split("\nreports:\n")[0].count("\n") + 3  # the key's line in the file
    assert error_lines(r) == [f"error: {p}:{line}: reports.fit_figures: 'few' is not "
                              "allowed: use 'auto', 'all', 'warned' or 'none'"]


def test_auto_fit_figures_every_set_of_a_few_the_warned_ones_of_many(monkeypatch):
    """``auto``: every set up to AUTO_ALL_SETS fitted sets, above that the warned ones (none
    when no fit warned, said so); ``all``/``warned``/``none`` whatever the count."""
    from types import SimpleNamespace

    import torlab.protocols.context as context
    from torlab.protocols.sections import _fit_figures_sentence

    monkeypatch.setattr(context, "AUTO_ALL_SETS", 3)
    fits = [(f"s{i}", SimpleNamespace(warnings=["w"] if i in (1, 4) else [])) for i in range(5)]
    names = lambda which, rs: [n for n, _ in context.drawn_fits(which, rs)]  # noqa: E731
    assert names("auto", fits[:3]) == ["s0", "s1", "s2"]
    assert names("auto", fits) == ["s1", "s4"] == names("warned", fits)
    assert names("all", fits) == [n for n, _ in fits] and names("none", fits) == []
    quiet = [(n, SimpleNamespace(warnings=[])) for n, _ in fits]
    assert names("auto", quiet) == []
    assert _fit_figures_sentence("auto", 0, 5) == (
        "Data-against-model figures are drawn for 0 of the 5 fitted sets, those whose fit "
        "warned, and none did (reports.fit_figures: auto, above 3 fitted sets; 'all' draws "
        "one for every set).")
    assert _fit_figures_sentence("warned", 2, 5).endswith(
        "those whose fit warned (reports.fit_figures: warned; 'all' draws one for every set).")
    assert _fit_figures_sentence("auto", 2, 5, draw=False) == (
        "No figures are drawn in this run; with them, data-against-model figures would be "
        "drawn for 2 of the 5 fitted sets, those whose fit warned (reports.fit_figures: auto, "
        "above 3 fitted sets; 'all' draws one for every set).")
    # the threshold the docs give is the code's
    monkeypatch.undo()
    n = context.AUTO_ALL_SETS
    for doc in ("protocols.md", "cli.md"):
        text = " ".join((ROOT / "docs" / doc).read_text(encoding="utf-8").split())
        assert f"up to {n} fitted sets" in text or f"at most {n} sets" in text, doc
    import typing

    from torlab.cli.run import run_cmd

    option = typing.get_type_hints(run_cmd, include_extras=True)["fit_figures"].__metadata__[0]
    assert f"up to {n} fitted sets" in option.help


@pytest.mark.slow
def test_paper_c_expected_summary(paper_c):
    diffs = compare_summary("paper_c", paper_c[1].summary)
    assert not diffs, "summary.json changed:\n  " + "\n  ".join(diffs)


# --------------------------------------------------------------------------- Paper B
def test_paper_b_time_tests_against_truth(paper_b):
    _out, res = paper_b
    truth = yaml.safe_load((ROOT / "sample_data/mtm/truth.yaml").read_text())
    by_file = {r["file"]: r["truth"] for r in truth["runs"]}
    label_file = {"base medium 5 uL": "mtm_base_5uL.txt", "base + Al2O3 5 uL":
                  "mtm_base-Al2O3_5uL.txt", "base + MoS2 5 uL": "mtm_base-MoS2_5uL.txt",
                  "TOR A 5 uL": "mtm_TOR-A_5uL.txt", "TOR A 20 uL": "mtm_TOR-A_20uL.txt"}
    comps = res.summary["reports"]["time_test"]["compositions"]
    assert set(comps) == set(label_file)
    for label, v in comps.items():
        t = by_file[label_file[label]]
        assert abs(v["application_time_s"] - t["application_time_s"]) <= 5
        assert abs(v["minimum"] - t["minimum"]) < 0.01
        assert (v["recovered"] == "yes") == t["recovered"]
        if t["recovered"]:
            assert abs(v["recovery_time_s"] - t["recovery_time_s"]) < 0.15 * t["recovery_time_s"]
            assert abs(v["plateau"] - t["plateau"]) < 0.01
        assert abs(v["time_below_threshold_s"] - t["time_below_threshold_s"]) < \
            0.1 * t["time_below_threshold_s"] + 10
        assert v["model_initial_mu"] is not None and 0 <= v["model_initial_mu"] < 1


def test_paper_b_report_says_what_the_initial_drop_model_included(paper_b):
    """The full-film model is far below every measured minimum: the report says so, with
    the factor computed from the summary's own numbers."""
    out, res = paper_b
    comps = res.summary["reports"]["time_test"]["compositions"].values()
    ratios = [v["minimum"] / v["model_initial_mu"] for v in comps]
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "Modelled: EHL film:" in md and "regimes: full_film" in md
    assert f"is {min(ratios):.2g}–{max(ratios):.2g} times below the measured minimum" in md


def test_paper_b_inputs_fitted(paper_b):
    out, res = paper_b
    s = res.summary
    vt = yaml.safe_load((ROOT / "sample_data/visc/truth.yaml").read_text())
    z = next(r["run"]["Z"] for r in vt["runs"] if r["file"] == "visc_ester_25C.txt")
    assert s["fits"]["lubricant:ester"]["params"]["Z"] == pytest.approx(z, abs=0.02)
    # the HPT layers of Paper B: the custom lubricant and TOR A at 8 uL to 0.1 mm, two runs each
    ht = yaml.safe_load((ROOT / "sample_data/hpt_paper_b/truth.yaml").read_text())
    for prod in ("custom", "TOR-A"):
        runs = [r for r in ht["runs"] if r["product"] == prod]
        assert len(runs) == 2 and all(r["displacement_max_m"] == pytest.approx(1e-4) and
                                      r["applied_amount"] == 8 for r in runs)
        m2 = sum(r["boundary"]["mu_c2"] for r in runs) / 2
        assert s["fits"][f"hpt:{prod}"]["params"]["mu_c2"] == pytest.approx(m2, abs=0.01)
    # the initial-drop model uses the custom lubricant's layer
    assert s["reports"]["time_test"]["compositions"]["base medium 5 uL"]["model_initial_mu"] > 0
    lub = yaml.safe_load((out / "fits/lubricant_ester.yaml").read_text())["lubricant"]
    assert lub["viscosity"] == "roelands"


def test_paper_b_expected_summary(paper_b):
    diffs = compare_summary("paper_b", paper_b[1].summary)
    assert not diffs, "summary.json changed:\n  " + "\n  ".join(diffs)


def test_paper_b_compares_the_compositions_and_torlab_compare_reads_the_run(paper_b, cli,
                                                                            tmp_path):
    """The report's comparisons: every composition against the base medium on the time-test
    figures (one test each: the record's noise only, and the report says so), the custom
    lubricant's layer against TOR A's (two runs each, pooled); torlab compare reads the
    same estimates back from the results folder."""
    out, res = paper_b
    cmp = res.summary["reports"]["compare"]["comparisons"]
    base = cmp["compositions against the base medium"]
    assert base["reference"] == "base medium 5 uL"
    rows = [r for r in base["comparisons"] if r["quantity"] == "mean_after_recovery"]
    assert {r["a"] for r in rows} == {"base + Al2O3 5 uL", "base + MoS2 5 uL"}
    al = next(r for r in rows if r["a"] == "base + Al2O3 5 uL")
    # the sample campaign's truth: plateaus 0.22 and 0.17 (sample_data/mtm/truth.yaml)
    assert al["ci95_low"] <= 0.05 <= al["ci95_high"]
    assert al["verdict"].endswith("(one run: record noise only)")
    hpt = cmp["the custom TOR lubricant against TOR A (HPT layer)"]["comparisons"]
    mu2 = next(r for r in hpt if r["quantity"] == "mu_c2")
    assert mu2["kind"] == "ratio" and mu2["ci95_high"] < 1 and mu2["verdict"] == "TOR-A lower"
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "## Comparisons" in md and (out / "compare").is_dir()
    r = cli("compare", out, "--reference", "base medium 5 uL", "--quantity",
            "mean_after_recovery", "-o", tmp_path / "c")
    assert r.exit_code == 0, r.output
    again = json.loads((tmp_path / "c" / "summary.json").read_text())["comparisons"]
    got = next(c for c in again if c["a"] == "base + Al2O3 5 uL")
    assert got["estimate"] == pytest.approx(al["estimate"], rel=1e-12)
    assert (got["ci95_low"], got["ci95_high"]) == pytest.approx((al["ci95_low"],
                                                                 al["ci95_high"]), rel=1e-9)


# --------------------------------------------------------------------------- Paper A
@pytest.mark.slow
def test_paper_a_against_model_truth(paper_a):
    """The optical logs are generated from torlab's model (sample_data/optical/truth.yaml):
    the film, the fitted dry layer and the measured Stribeck points against that truth."""
    out, res = paper_a
    s = res.summary
    truth = yaml.safe_load((ROOT / "sample_data/optical/truth.yaml").read_text())
    tests = {t["test"] + ":" + t["surface"]: t for t in truth["tests"]}
    # measured film against the model's film at the same speeds: the ratio is 1 within noise
    ratio = s["reports"]["film"]["measured_to_model"]["smooth ball"]
    assert ratio["ratio_low95"] < 1.0 < ratio["ratio_high95"]
    assert abs(ratio["ratio"] - 1) < 0.05
    # the dry layer's saturated coefficient is the generating one
    layer = truth["layer"]
    assert s["fits"]["traction:dry"]["params"]["mu_c2"] == pytest.approx(layer["mu_c2"], abs=0.005)
    tr = s["reports"]["traction"]["curves"]
    dry_true = max(abs(c["traction_coefficient"]) for c in tests["dry_traction:rough"]["conditions"])
    assert tr["measured dry_traction_rough.csv"]["mu_max"] == pytest.approx(dry_true, abs=0.005)
    # lubricated traction falls with rolling speed, measured and modelled (Stribeck, Paper A)
    meas = [v["mu_max"] for k, v in tr.items() if k.startswith("measured traction_rough")]
    assert meas == sorted(meas, reverse=True) and len(meas) == 5
    st = s["reports"]["stribeck"]["curves"]
    for lab in ("smooth ball", "rough ball"):
        assert st[lab]["n_measured"] == 12
        assert st[lab]["creepage"] == pytest.approx(0.05, abs=0.002)
    # measured Stribeck points against the generating truth at the set conditions
    import pandas as pd

    d = pd.read_csv(out / "stribeck/curves.csv")
    for lab, key in (("rough ball", "stribeck:rough"), ("smooth ball", "stribeck:smooth")):
        m = d[(d["curve"] == lab) & (d["kind"] == "measured")].sort_values("speed_m_s")
        cond = sorted(tests[key]["conditions"], key=lambda c: c["rolling_speed_m_s"])
        want = np.abs([c["traction_coefficient"] for c in cond])
        # force noise 0.02 N on 90 N averaged over the 4 s window, speeds within 0.2 %
        assert np.max(np.abs(m["mu"].to_numpy() - want)) < 0.002, lab


@pytest.mark.slow
def test_paper_a_expected_summary(paper_a):
    diffs = compare_summary("paper_a", paper_a[1].summary)
    assert not diffs, "summary.json changed:\n  " + "\n  ".join(diffs)


# --------------------------------------------------------------------------- reports, provenance
@pytest.mark.parametrize("fixture", [pytest.param("paper_a", marks=pytest.mark.slow), "paper_b",
                                     pytest.param("paper_c", marks=pytest.mark.slow)])
def test_report_files_and_provenance(request, fixture):
    out, res = request.getfixturevalue(fixture)
    s = json.loads((out / "summary.json").read_text())
    from torlab import __version__

    assert s["torlab_version"] == __version__
    proto = PROTOCOLS / f"{fixture}.yaml"
    assert s["protocol"]["sha256"] == sha(proto)
    assert s["inputs"], "no input hashes"
    for rel, h in s["inputs"].items():
        assert h == sha(PROTOCOLS / rel), rel
    html = (out / "report.html").read_text()
    assert html.startswith("<!DOCTYPE html>")
    assert "data:image" not in html  # the figures linked, from inside the folder
    assert not re.search(r"""(src|href)=['"](https?:|/|\.\./)""", html)
    for src in re.findall(r"""<img [^>]*src=['"]([^'"]+)['"]""", html):
        assert (out / src).is_file(), src
    md = (out / "report.md").read_text()
    for sec in res.sections:
        folder = out / sec
        pngs = sorted(folder.glob("*.png"))
        assert pngs, sec
        for p in pngs:
            assert not p.with_suffix(".svg").exists()  # PNG only unless asked
            assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
            assert f"{sec}/{p.name}" in md
        for c in folder.glob("*.csv"):
            assert "nan" not in c.read_text().lower().replace("non", ""), c
    manifest = json.loads((out / "torlab-manifest.json").read_text())
    assert "summary.json" in manifest["files"]


def test_summary_diff_is_readable():
    diffs: list[str] = []
    _diff({"a": {"x": 1.0, "s": "neutral"}}, {"a": {"x": 1.5, "s": "positive", "n": 2}}, "r",
          1e-4, 0.0, diffs)
    assert "r.a.x: expected 1.0, got 1.5 (relative change 5.00e-01, tolerance 0.0001)" in diffs
    assert "r.a.s: expected 'neutral', got 'positive'" in diffs
    assert "r.a.n: new key (value 2)" in diffs


# --------------------------------------------------------------------------- re-runs


def test_rerun_reuses_cache_and_refuses_overwrite(tmp_path):
    from torlab.errors import OutputExistsError
    from torlab.protocols.runner import run_protocol

    for f in sorted((ROOT / "sample_data/hpt").glob("hpt_OFM1_*uL_25C.txt")):
        shutil.copy(f, tmp_path / f.name)
    p = tmp_path / "small.yaml"
    p.write_text(SMALL)
    out = tmp_path / "out"
    r1 = run_protocol(p, out)
    # five reductions, the amount section's crossings and its statistics; two figures
    # (amount, mass) drawn
    assert r1.cache_hits == 0 and r1.cache_misses == 7
    assert (r1.timing["figures_drawn"], r1.timing["figures_reused"]) == (2, 0)
    png = (out / "amount" / "amount_applied.png").read_bytes()
    with pytest.raises(OutputExistsError):
        run_protocol(p, out)
    kept = ("amount/amount_applied.png", "amount/amount_mass.png", "report.html", "report.md")
    before = {n: (out / n).stat() for n in kept}
    r2 = run_protocol(p, out, force=True)
    assert (r2.cache_hits, r2.cache_misses) == (7, 0)
    assert (r2.timing["figures_drawn"], r2.timing["figures_reused"]) == (0, 2)
    assert (out / "amount" / "amount_applied.png").read_bytes() == png
    assert r2.summary["reports"] == r1.summary["reports"]
    # nothing changed: nothing drawn, nothing rewritten, every result the same file (inode
    # and time) as the first run's
    assert r2.unchanged
    manifest = json.loads((out / "torlab-manifest.json").read_text())
    for n, st in before.items():
        now = (out / n).stat()
        assert (now.st_ino, now.st_mtime_ns) == (st.st_ino, st.st_mtime_ns), n
    assert r2.timing["files_kept"] == len([n for n in manifest["files"]
                                           if not n.startswith(".cache")])
    # a changed input file is recomputed, the others are reused; so are the crossings and
    # the figures, whose data did not change (only a comment of the log did): the figure
    # files are kept as they were (same inode and time), the reports (which name the
    # inputs' SHA-256) are written anew
    f = tmp_path / "hpt_OFM1_8uL_25C.txt"
    f.write_text(f.read_text().replace("# operator: torlab synth", "# operator: someone else"))
    r3 = run_protocol(p, out, force=True)
    assert not r3.unchanged
    assert (r3.cache_hits, r3.cache_misses) == (6, 1)
    assert r3.timing["figures_reused"] == 2
    for n in kept[:2]:
        now, st = (out / n).stat(), before[n]
        assert (now.st_ino, now.st_mtime_ns) == (st.st_ino, st.st_mtime_ns), n
    assert (out / "report.html").stat().st_ino != before["report.html"].st_ino
    report3 = (out / "report.html").stat()
    assert r3.timing["files_kept"] >= 2
    assert r3.summary["inputs"]["hpt_OFM1_8uL_25C.txt"] == sha(f)
    assert len(list((out / ".cache").glob("*-*.tlc"))) == 7   # the stale entry was dropped
    # a changed number is a changed figure: drawn again, the old one dropped
    p.write_text(SMALL.replace("curve: interpolation", "curve: interpolation\n    threshold: 0.2"))
    r4 = run_protocol(p, out, force=True)
    assert (r4.timing["figures_drawn"], r4.timing["figures_reused"]) == (2, 0)
    assert (out / "amount" / "amount_applied.png").read_bytes() != png
    # changed: a new file (the previous run's, alive until replaced, is the only inode it
    # cannot have; the first run's may have been recycled by the file system)
    assert (out / "report.html").stat().st_ino != report3.st_ino
    assert len(list((out / ".cache").glob("fig-*.png"))) == 2
    assert len(list((out / ".cache").glob("fig-*.png.mac"))) == 2


def test_no_figures_and_the_linked_report(tmp_path, cli):
    """``--no-figures`` (or ``reports.figures: false``) writes every number and table and
    names the figures not drawn; report.html shows the figures from their files (its size
    does not grow with them), or embeds them with ``reports.html_figures: embed``."""
    import json
    import re

    for f in sorted((ROOT / "sample_data/hpt").glob("hpt_OFM1_*uL_25C.txt")):
        shutil.copy(f, tmp_path / f.name)
    p = tmp_path / "small.yaml"
    p.write_text(SMALL)
    r = cli("run", p, "-o", tmp_path / "plain", "-q")
    assert r.exit_code == 0, r.output
    page = (tmp_path / "plain" / "report.html").read_text(encoding="utf-8")
    assert "data:image" not in page and len(page) < 20_000
    srcs = re.findall(r"<img [^>]*src='([^']+)'", page)
    assert sorted(srcs) == ["amount/amount_applied.png", "amount/amount_mass.png"]
    assert all((tmp_path / "plain" / s).is_file() for s in srcs)
    r = cli("run", p, "-o", tmp_path / "bare", "-q", "--no-figures")
    assert r.exit_code == 0, r.output
    assert "figures: not drawn (--no-figures)" in r.output
    assert not list((tmp_path / "bare").rglob("*.png"))
    bare = tmp_path / "bare"
    assert (bare / "report.html").read_text(encoding="utf-8").count("figure not drawn") == 2
    assert "figure not drawn" in (bare / "report.md").read_text(encoding="utf-8")
    for t in ("amount/crossings.csv", "amount/series.csv"):
        assert (bare / t).read_bytes() == (tmp_path / "plain" / t).read_bytes()
    a, b = (json.loads((d / "summary.json").read_text()) for d in (tmp_path / "plain", bare))
    assert a["reports"] == b["reports"] and a["fits"] == b["fits"]
    # the protocol's keys
    p.write_text(SMALL + "  figures: false\n")
    r = cli("run", p, "-o", tmp_path / "key", "-q")
    assert r.exit_code == 0 and not list((tmp_path / "key").rglob("*.png"))
    p.write_text(SMALL + "  html_figures: embed\n")
    r = cli("run", p, "-o", tmp_path / "embed", "-q")
    assert r.exit_code == 0
    assert (tmp_path / "embed" / "report.html").read_text().count("data:image/png;base64,") == 2


def test_cached_figure_that_was_changed_is_drawn_again(tmp_path):
    """A cached figure is authenticated like every cache entry: an edited one is redrawn."""
    from torlab.protocols.runner import run_protocol

    for f in sorted((ROOT / "sample_data/hpt").glob("hpt_OFM1_*uL_25C.txt")):
        shutil.copy(f, tmp_path / f.name)
    p = tmp_path / "small.yaml"
    p.write_text(SMALL + "  figure_formats: png, svg\n")
    out = tmp_path / "out"
    run_protocol(p, out)
    assert (out / "amount" / "amount_applied.svg").is_file()
    figs = sorted((out / ".cache").glob("fig-*.png"))
    assert len(figs) == 2
    good = (out / "amount" / "amount_applied.png").read_bytes()
    for fig in figs:  # a picture changed in the cache (its authentication left as it was)
        fig.write_bytes(fig.read_bytes() + b"tampered")
    # a log's comment changed: the run is made again, the figures' data are the same
    f = tmp_path / "hpt_OFM1_8uL_25C.txt"
    f.write_text(f.read_text().replace("# operator: torlab synth", "# operator: someone else"))
    r = run_protocol(p, out, force=True)
    assert (r.timing["figures_drawn"], r.timing["figures_reused"]) == (2, 0)
    assert (out / "amount" / "amount_applied.png").read_bytes() == good


def test_missing_output_option(tmp_path, cli):
    r = cli("run", PROTOCOLS / "paper_b.yaml")
    assert r.exit_code == 2
    assert "-o OUT" in error_lines(r)[0]


# --------------------------------------------------------------------------- real files
@pytest.mark.slow  # a whole protocol on real exports
def test_real_pcs_files_in_a_protocol(tmp_path):
    """The PCS parsers inside a protocol, on real MTM/ETM/EHD2 exports (skipped without them)."""
    if not REAL_PCS.is_dir():
        pytest.skip(f"real PCS data not available ({REAL_PCS})")
    from torlab.protocols.runner import run_protocol

    mtm = [REAL_PCS / "demo_5.txt", REAL_PCS / "ETM_slim_mapper.txt"]
    ehd = REAL_PCS / "demo_3.txt"
    for f in (*mtm, ehd):
        if not f.exists():
            pytest.skip(f"{f} not available")
    p = tmp_path / "real.yaml"
    p.write_text(f"""\
version: 1
name: real_pcs
data:
  mtm:
    files:
      - {{path: {mtm[0]}, label: MTM demo}}
      - {{path: {mtm[1]}, label: ETM mapper}}
  optical:
    files: [{ehd}]
reports:
  time_test: {{}}
  film:
    curves:
      - label: EHD2 demo
        measured: {ehd}
""")
    res = run_protocol(p, tmp_path / "out")
    comps = res.summary["reports"]["time_test"]["compositions"]
    assert set(comps) == {"MTM demo", "ETM mapper"}
    for v in comps.values():
        assert 0 <= v["minimum"] < 1
    assert sha(ehd) in res.summary["inputs"].values()
    film = res.summary["fits"]["film:EHD2 demo"]["params"]
    assert 0.3 < film["speed_exponent"] < 1.0   # EHL films grow with speed, roughly U^0.67


def test_paper_b_says_the_intervals_hold_for_the_record_only(paper_b):
    """The sample campaign repeats no composition: the report says what its intervals hold."""
    out, res = paper_b
    tt = res.summary["reports"]["time_test"]["test_to_test"]
    assert tt == {"estimated": False, "why": "no composition was repeated"}
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "holds for its record only" in md and "is not estimated" in md


def test_time_test_repeats_widen_the_intervals(tmp_path, cli):
    """Two MTM records listed as repeats of one composition: their scatter is estimated and
    used where larger than the record's own; an unknown label is a one-line error."""
    mtm = ROOT / "sample_data" / "mtm"
    text = f"""version: 1
name: repeats
data:
  mtm:
    files:
      - {{path: {mtm / 'mtm_base_5uL.txt'}, label: base run 1}}
      - {{path: {mtm / 'mtm_base-MoS2_5uL.txt'}, label: base run 2}}
      - {{path: {mtm / 'mtm_TOR-A_5uL.txt'}, label: TOR A}}
    time_test: {{threshold: 0.15, smooth: 10 s, duration: 20 min}}
reports:
  time_test:
    replicates: 20
    repeats:
      base: [base run 1, base run 2]
"""
    p = tmp_path / "rep.yaml"
    p.write_text(text)
    r = cli("run", p, "-o", tmp_path / "out")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "out" / "summary.json").read_text())["reports"]["time_test"]
    tt = s["test_to_test"]
    assert tt["estimated"] and tt["repeated"] == {"base": 2}
    f = tt["figures"]["mean_after_recovery"]
    m1 = s["compositions"]["base run 1"]["mean_after_recovery"]
    m2 = s["compositions"]["base run 2"]["mean_after_recovery"]
    assert f["dof"] == 1 and f["sd_test"] == pytest.approx(abs(m1 - m2) / math.sqrt(2))
    c = tt["compositions"]["base"]["mean_after_recovery"]
    assert c["mean"] == pytest.approx((m1 + m2) / 2)
    md = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert "Repeated compositions: base (2 tests)" in md
    bad = p.read_text().replace("[base run 1, base run 2]", "[base run 1, base run 3]")
    p.write_text(bad)
    r = cli("run", p, "-o", tmp_path / "out2")
    assert r.exit_code == 2 and "base run 3" in r.output and "Traceback" not in r.output


def test_results_carry_no_path_of_this_machine(tmp_path):
    """A results folder is sent to others: its tables, fits and reports do not name the
    folders the data and the rig compliance were read from on this machine (they are named
    as written in the protocol).  The provenance records keep what the user typed: the
    command line, and the input manifest with each input's path and SHA-256."""
    from torlab.protocols.runner import run_protocol

    (tmp_path / "data").mkdir()
    (tmp_path / "proto").mkdir()
    for f in sorted((ROOT / "sample_data/hpt").glob("hpt_OFM1_*uL_25C.txt")):
        shutil.copy(f, tmp_path / "data" / f.name)
    shutil.copy(ROOT / "sample_data/hpt/rig_compliance.csv", tmp_path / "data")
    p = tmp_path / "proto" / "small.yaml"
    p.write_text(SMALL.replace("[hpt_*.txt]", "[../data/hpt_*.txt]\n"
                               "    compliance: ../data/rig_compliance.csv"))
    out = tmp_path / "out"
    run_protocol(p.resolve(), out)
    texts = {f: "\n".join(ln for ln in f.read_text().splitlines() if "torlab run " not in ln)
             for f in out.rglob("*") if f.is_file() and f.name != "torlab-manifest.json"
             and f.suffix in (".csv", ".yaml", ".json", ".md", ".html", ".txt")}
    assert len(texts) > 5
    assert any("../data/rig_compliance.csv" in t for t in texts.values())
    leaks = [f.name for f, t in texts.items() if str(tmp_path) in t]
    assert leaks == []
