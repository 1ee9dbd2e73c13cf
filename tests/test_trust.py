"""Trust under bad input: the cache, YAML limits, units and ranges, output safety, CLI policy.

Each test states the hazard it closes: a results folder that could run code or feed wrong
numbers, YAML that could hang or crash, temperatures read wrongly, values outside what is
possible, output folders lost or mixed, console output that is not one line.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, error_lines
from conftest import SMALL_PROTOCOL as SMALL
from hypothesis import given, settings
from hypothesis import strategies as st

from torlab.errors import (
    OutputBusyError,
    OutputExistsError,
    TorlabInputError,
    TorlabWarning,
)

SCENE = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
HPT = ROOT / "sample_data" / "hpt"


def _small_protocol(tmp_path: Path) -> Path:
    for f in sorted(HPT.glob("hpt_OFM1_*uL_25C.txt"))[:4]:
        shutil.copy(f, tmp_path / f.name)
    p = tmp_path / "small.yaml"
    p.write_text(SMALL)
    return p


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """The small protocol run once, under the session's cache key: ``(protocol, out, result)``.
    A test that changes the results works on its own copy (:func:`_copy_run`)."""
    from torlab.protocols.runner import run_protocol

    d = tmp_path_factory.mktemp("small")
    p = _small_protocol(d)
    return p, d / "out", run_protocol(p, d / "out")


def _copy_run(small_run, dest: Path):
    """``(protocol, out, result)`` with ``out`` a copy of the small run's results folder."""
    p, out, res = small_run
    shutil.copytree(out, dest)
    return p, dest, res


# ------------------------------------------------------------------------------ the cache
class _Boom:
    """Unpickling this writes a marker file: proof that code from the cache ran."""

    marker: Path

    def __reduce__(self):
        return (Path.write_text, (self.marker, "code from the cache ran"))


def _pickle_bomb(marker: Path) -> bytes:
    import pickle

    b = _Boom()
    b.marker = marker
    return pickle.dumps(b)


def test_crafted_cache_cannot_run_code_and_is_never_reused(tmp_path, small_run):
    """A results folder someone sends you with a crafted .cache: --force re-runs it safely."""
    from torlab.protocols.runner import run_protocol

    p, out, r1 = _copy_run(small_run, tmp_path / "out")
    cache = out / ".cache"
    entries = sorted(cache.glob("*-*.tlc"))  # the entries (not the index)
    assert entries and not list(cache.glob("*.pkl"))
    marker = tmp_path / "pwned"
    bomb = _pickle_bomb(marker)
    # the old pickle format under its old name, and a pickle under a current entry's name
    (cache / "hpt-0123456789abcdef0123456789abcdef.pkl").write_bytes(bomb)
    entries[0].write_bytes(bomb)
    man = json.loads((out / "torlab-manifest.json").read_text())
    man["files"].append(".cache/hpt-0123456789abcdef0123456789abcdef.pkl")
    (out / "torlab-manifest.json").write_text(json.dumps(man))
    r2 = run_protocol(p, out, force=True)
    assert not marker.exists()
    assert r2.summary["reports"] == r1.summary["reports"]
    assert r2.cache_misses == 1 and r2.cache_hits == len(entries) - 1
    assert not list((out / ".cache").glob("*.pkl"))  # dropped, never opened


def _entry_parts(blob: bytes) -> tuple[bytes, dict, bytes]:
    """A cache entry's HMAC line, JSON tree and array bytes (torlab.protocols.cache)."""
    head, tree, arrays = blob.split(b"\n", 2)
    return head, json.loads(tree), arrays


def _entry(head: bytes, body: dict, arrays: bytes) -> bytes:
    return head + b"\n" + json.dumps(body).encode() + b"\n" + arrays


def test_forged_cache_entry_is_recomputed_not_trusted(tmp_path, small_run):
    """An entry edited to carry other numbers fails its HMAC: the true value is recomputed."""
    from torlab.protocols.runner import run_protocol

    p, out, r1 = _copy_run(small_run, tmp_path / "out")
    f_true = r1.summary["data"]["hpt"]["f_window"]
    forged = list((out / ".cache").glob("hpt-*.tlc"))
    for e in forged:
        head, body, arrays = _entry_parts(e.read_bytes())
        body["value"]["fields"]["f_window"] = 0.999  # a friction value someone prefers
        e.write_bytes(_entry(head, body, arrays))
    assert forged
    r2 = run_protocol(p, out, force=True)
    assert r2.summary["data"]["hpt"]["f_window"] == f_true
    assert 0.999 not in f_true.values()
    assert r2.cache_misses == len(forged)


def test_entry_signed_with_another_key_is_rejected(tmp_path, monkeypatch):
    """Entries written by another user (another key) are recomputed."""
    from torlab.protocols.cache import ResultCache

    d = tmp_path / "c"
    monkeypatch.setenv("TORLAB_CONFIG_DIR", str(tmp_path / "alice"))
    a = ResultCache(d)
    assert a.get_or_compute("x", lambda: {"v": 1.0}, n=1) == {"v": 1.0}
    assert a.persistent_key and (tmp_path / "alice" / "cache-key").stat().st_mode & 0o077 == 0
    monkeypatch.setenv("TORLAB_CONFIG_DIR", str(tmp_path / "mallory"))
    m = ResultCache(d)
    assert m.get_or_compute("x", lambda: {"v": 2.0}, n=1) == {"v": 2.0}
    assert (m.hits, m.misses, m.rejected) == (0, 1, 1)
    monkeypatch.setenv("TORLAB_CONFIG_DIR", str(tmp_path / "alice"))
    a2 = ResultCache(d)
    assert a2.get_or_compute("x", lambda: {"v": 3.0}, n=1) == {"v": 3.0}  # mallory's entry
    assert a2.rejected == 1


def test_figures_of_a_results_folder_signed_elsewhere_are_drawn_again(tmp_path, monkeypatch,
                                                                       small_run):
    """A results folder someone sent you: its cached figures were replaced by other pictures
    whose sidecars carry a well-formed HMAC under the sender's key.  Your --force re-run
    draws every figure again and writes your own pictures; none of theirs is reused."""
    from torlab.protocols.cache import FigureStore, ResultCache
    from torlab.protocols.runner import run_protocol

    # the sender's results: the small run, made under the session's key (the sender's)
    p, out, _ = _copy_run(small_run, tmp_path / "sent")
    store = FigureStore(ResultCache(out / ".cache"))  # the sender's key
    figs = sorted((out / ".cache").glob("fig-*.png"))
    forged = figs[0].read_bytes()[::-1]  # another picture
    for fig in figs:
        fig.write_bytes(forged)
        mac = store._mac(fig.name, forged)
        head = fig.with_name(fig.name + ".mac").read_text().split()
        fig.with_name(fig.name + ".mac").write_text(f"{head[0]} {head[1]} {mac}\n")
    monkeypatch.setenv("TORLAB_CONFIG_DIR", str(tmp_path / "you"))
    mine = run_protocol(p, tmp_path / "mine")  # your own results, the reference pictures
    pngs = sorted(f.relative_to(tmp_path / "mine") for f in (tmp_path / "mine").rglob("*.png")
                  if ".cache" not in f.parts)
    assert pngs and mine.timing["figures_drawn"] == len(pngs)
    assert len(figs) == len(pngs)
    r = run_protocol(p, out, force=True)
    assert (r.timing["figures_drawn"], r.timing["figures_reused"]) == (len(pngs), 0)
    for rel in pngs:
        assert (out / rel).read_bytes() == (tmp_path / "mine" / rel).read_bytes(), rel
    assert forged not in [f.read_bytes() for f in (out / ".cache").glob("fig-*.png")]


@pytest.mark.parametrize("tname", ["builtins:eval", "os:system", "subprocess:Popen",
                                   "torlab.outputs:shutil", "torlab.protocols.cache:ResultCache",
                                   "pickle:loads", "torlab..x:Y"])
def test_cache_decodes_only_torlab_data_classes_even_with_a_valid_key(tmp_path, tname):
    """Data-only: an entry naming any other type is refused although its HMAC is right."""
    from torlab.codec import BadEntry
    from torlab.protocols.cache import ResultCache

    c = ResultCache(tmp_path)
    name = "k-1.tlc"
    blob = c.dumps(name, "k", {"a": 1})
    head, body, arrays = _entry_parts(blob)
    body["value"] = {"__t": "dc", "type": tname, "fields": {"args": ["echo hi"]}}
    payload = _entry(head, body, arrays).split(b"\n", 1)[1]
    forged = f"torlab-cache 2 {c._mac(payload)}\n".encode() + payload
    with pytest.raises(BadEntry, match=r"not allowed|no module|no class|not a result class"):
        c.loads(name, "k", forged)


def test_cache_round_trip_of_result_data():
    import pandas as pd

    from torlab.codec import decode_value, encode_value
    from torlab.reduce.viscometer import Calibration

    df = pd.DataFrame({"x_m": [1.0, np.nan, 3.0], "n": np.array([1, 2, 3], dtype=np.int64),
                       "ok": [True, False, True], "label": ["a", None, "c"]})
    df.attrs["unit"] = "m"
    v = {"table": df, "arr": np.arange(6.0).reshape(2, 3), "t": (1, "a", None),
         "cal": Calibration(1.9e-8, K_sd=1e-10, n_falls=3, source="ref"), "inf": math.inf,
         "path": Path("a/b"), np.float64(1.5): {2, 3}, "big": 10 ** 30}
    back = decode_value(json.loads(json.dumps(encode_value(v))))
    pd.testing.assert_frame_equal(back["table"], df)
    assert back["table"].attrs == {"unit": "m"}
    np.testing.assert_array_equal(back["arr"], v["arr"])
    assert back["t"] == (1, "a", None) and back["cal"] == v["cal"] and back["inf"] == math.inf
    assert back["path"] == Path("a/b") and back[1.5] == {2, 3} and back["big"] == 10 ** 30


_plain = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.tuples(inner, inner)
    | st.dictionaries(st.text(max_size=5) | st.integers(), inner, max_size=4),
    max_leaves=20)


@settings(max_examples=150, deadline=None)
@given(_plain)
def test_cache_round_trip_of_any_plain_value(v):
    from torlab.codec import decode_value, encode_value

    assert decode_value(json.loads(json.dumps(encode_value(v)))) == v


@settings(max_examples=150, deadline=None)
@given(st.binary(max_size=300))
def test_cache_loads_refuses_arbitrary_bytes_cleanly(tmp_path_factory, data):
    from torlab.codec import BadEntry
    from torlab.protocols.cache import ResultCache

    c = ResultCache(None)
    with pytest.raises(BadEntry):
        c.loads("k-1.tlc", "k", data)


def test_cache_skips_values_that_are_not_data(tmp_path):
    from torlab.protocols.cache import ResultCache

    c = ResultCache(tmp_path)
    assert c.get_or_compute("f", lambda: {"fn": len}, n=1)["fn"] is len
    assert c.not_cacheable == {"f"} and not list(tmp_path.iterdir())


def test_cache_copied_from_out_skips_links_and_devices(tmp_path):
    """--force copies OUT/.cache: a symlink to a secret or a device is not followed."""
    from torlab.outputs import OutputDir

    out = tmp_path / "out"
    with OutputDir(out) as d:
        d.write_text(".cache/a.tlc", "entry")
    secret = tmp_path / "secret.txt"
    secret.write_text("not yours")
    (out / ".cache" / "link.tlc").symlink_to(secret)
    (out / ".cache" / "zero.tlc").symlink_to("/dev/zero")
    man = json.loads((out / "torlab-manifest.json").read_text())  # the sender lists them
    man["files"] += [".cache/link.tlc", ".cache/zero.tlc"]
    (out / "torlab-manifest.json").write_text(json.dumps(man))
    d = OutputDir(out, force=True, keep=[".cache"])
    names = sorted(p.name for p in (d.staging / ".cache").iterdir())
    d.abort()
    assert names == ["a.tlc"]


# ------------------------------------------------------------------------------ YAML limits
BOMB = "a: &a [x,x,x,x,x,x,x,x,x]\n" + "".join(
    f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi", strict=True))


@pytest.mark.parametrize("text, fragment", [
    (BOMB, "aliases"),
    ("contact: &c\n  load: [*c]\n", "recursive"),
    ("a: " + "[" * 3000 + "]" * 3000 + "\n", "nested deeper"),
    ("a: " + "{b: " * 70 + "1" + "}" * 70 + "\n", "nested deeper"),
    ("n: " + "9" * 6000 + "\n", "not valid YAML"),
])
def test_yaml_limits(text, fragment):
    from torlab.yamlio import load_yaml_text

    with pytest.raises(TorlabInputError, match=fragment) as e:
        load_yaml_text(text, "s.yaml")
    assert e.value.path == "s.yaml"


def test_yaml_expansion_counted_once_per_node():
    """Shared aliases within the budget load (each anchored node is counted, not re-walked)."""
    from torlab.yamlio import load_yaml_text

    text = "m: &m {E1: 210 GPa, nu1: 0.3}\n" + "".join(f"s{i}: *m\n" for i in range(200))
    doc = load_yaml_text(text)
    assert doc.data["s199"] == {"E1": "210 GPa", "nu1": 0.3}
    merged = load_yaml_text("base: &b {x: 1, y: 2}\nnew:\n  <<: *b\n  y: 3\n").data
    assert merged["new"] == {"x": 1, "y": 3}


@pytest.mark.parametrize("which", ["scene", "parameter file", "protocol"])
def test_alias_bomb_is_one_line_exit_2_for_every_yaml_input(cli, tmp_path, which):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(BOMB)
    out = tmp_path / "o"
    args = {"scene": ["predict", "traction", bomb, "-o", out],
            "parameter file": ["predict", "traction", SCENE, bomb, "-o", out],
            "protocol": ["run", bomb, "-o", out]}[which]
    r = cli(*args)
    assert r.exit_code == 2, r.output
    (line,) = error_lines(r)
    assert line.startswith(f"error: {bomb}:") and "aliases" in line


def test_hpt_column_map_goes_through_the_limits(cli, tmp_path):
    csv = tmp_path / "rig.csv"
    csv.write_text("t,F\n0,1\n")
    mp = tmp_path / "map.yaml"
    mp.write_text(BOMB)
    r = cli("hpt", "reduce", csv, "--map", mp, "-o", tmp_path / "o")
    assert r.exit_code == 2 and "aliases" in error_lines(r)[0]


@pytest.mark.parametrize("special", ["fifo", "device", "big"])
def test_yaml_input_that_never_ends_is_refused(cli, tmp_path, special):
    p = tmp_path / "s.yaml"
    if special == "fifo":
        os.mkfifo(p)
    elif special == "device":
        p = Path("/dev/zero")
    else:
        p.write_bytes(b"# padding\n" * 500_000)
    r = cli("predict", "traction", p, "-o", tmp_path / "o")
    assert r.exit_code == 2
    assert ("not a regular file" in error_lines(r)[0]) or ("larger than" in error_lines(r)[0])


# ------------------------------------------------------------------------------ units
def test_temperature_differences_are_not_absolute_temperatures():
    from torlab.units import to_si

    for v in ("2 K", "2 degC", "2 delta_degC", "3.6 degF", "2"):
        assert to_si(v, "temperature_difference") == pytest.approx(2.0)
    assert to_si("300 K", "temperature") == pytest.approx(26.85)
    assert to_si("300 K", "temperature_difference") == pytest.approx(300.0)
    assert to_si("-40 degF", "temperature") == pytest.approx(-40.0)


def test_scene_and_protocol_tolerances_accept_kelvin(tmp_path):
    from torlab.protocols.schema import HptLayerFit
    from torlab.scene import load_scene

    p = tmp_path / "p.yaml"
    p.write_text("thermal:\n  tolerance: 0.1 K\nkinematics:\n  ambient_temperature: 300 K\n")
    sc = load_scene(SCENE, p)
    assert sc.thermal.tolerance == pytest.approx(0.1)
    assert sc.kinematics.ambient_temperature == pytest.approx(26.85)
    f = HptLayerFit.model_validate({"temperature_tolerance": "2 K", "amounts": ["4 uL"]})
    assert f.temperature_tolerance == pytest.approx(2.0)


@pytest.mark.parametrize("value, fragment", [
    ("20 C", "write degC"), ("-300 degC", "below absolute zero"), ("-5 K", "below absolute zero"),
    ("68 F", "write degF")])
def test_impossible_temperatures(value, fragment):
    from torlab.units import to_si

    with pytest.raises(TorlabInputError, match=fragment):
        to_si(value, "temperature", where="t")


def test_range_table_errors_outside_the_possible_and_warns_for_the_unusual():
    from torlab.units import RANGES, check_range

    for q, r in RANGES.items():
        assert r.low <= r.usual_low <= r.usual_high <= r.high, q
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            check_range(q, 0.5 * (r.usual_low + r.usual_high))  # usual: silent
        with pytest.raises(TorlabInputError, match="not possible"):
            check_range(q, r.high * 10 if r.high > 0 else 1.0)
    with pytest.warns(TorlabWarning, match=r"2500 mm is unusual for an HPT loading-arm length"):
        check_range("arm_length", 2.5, where="arm_length")


def test_documented_range_table_is_the_code_table():
    """docs/scenes.md lists every quantity of torlab.units.RANGES with its bounds."""
    from torlab.units import RANGES

    doc = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    table = doc.split("## Plausible values", 1)[1]
    for q in RANGES:
        assert f"| `{q}` |" in table, q


def _hpt_with(tmp_path: Path, old: str, new: str) -> Path:
    src = (HPT / "hpt_OFM1_4uL_25C.txt").read_text()
    assert old in src
    p = tmp_path / "h.txt"
    p.write_text(src.replace(old, new))
    return p


@pytest.mark.parametrize("old, new, line, fragment", [
    ("arm_length: 250 mm", "arm_length: 250", 9, "needs a unit"),
    ("arm_length: 250 mm", "arm_length: 0 mm", 9, "not possible"),
    ("arm_length: 250 mm", "arm_length: -250 mm", 9, "not possible"),
    ("applied_amount: 4 uL", "applied_amount: -4 uL", 4, "not possible"),
    ("temperature: 25 degC", "temperature: -300 degC", 6, "below absolute zero"),
    ("temperature: 25 degC", "temperature: 25 C", 6, "write degC"),
    ("r2: 6 mm", "r2: 1e300 m", 8, "not possible"),
])
def test_hpt_header_values_checked(cli, tmp_path, old, new, line, fragment):
    p = _hpt_with(tmp_path, old, new)
    r = cli("hpt", "reduce", p, "-o", tmp_path / "o")
    assert r.exit_code == 2
    (err,) = error_lines(r)
    assert err.startswith(f"error: {p}:{line}: ") and fragment in err


def test_unusual_header_value_is_one_warning_line(cli, tmp_path):
    p = _hpt_with(tmp_path, "arm_length: 250 mm", "arm_length: 2.5 m")
    r = cli("hpt", "reduce", p, "-o", tmp_path / "o")
    assert r.exit_code == 0
    warn = [ln for ln in error_lines(r) if ln.startswith("warning:")]
    assert warn == [f"warning: {p}:9: arm_length: 2500 mm is unusual for an HPT loading-arm "
                    "length (usually 10 mm to 2000 mm); check the number and its unit"]


@pytest.mark.parametrize("key, value, fragment", [
    ("r1x", "1e300 m", "not possible"), ("load", "1e12 N", "not possible"),
    ("speed", "5000 m/s", "not possible"), ("b", "1e-300 m", "not possible")])
def test_scene_values_outside_the_possible(cli, tmp_path, key, value, fragment):
    text = SCENE.read_text()
    lines = [ln for ln in text.splitlines() if ln.strip().startswith(f"{key}:")]
    s = tmp_path / "s.yaml"
    s.write_text(text.replace(lines[0].strip(), f"{key}: {value}", 1))
    r = cli("predict", "traction", s, "-o", tmp_path / "o")
    assert r.exit_code == 2
    assert f".{key}: " in error_lines(r)[0] and fragment in error_lines(r)[0]


# ------------------------------------------------------------------------------ outputs
def test_second_writer_is_refused_and_lock_released_after_commit(tmp_path, cli):
    from torlab.outputs import OutputDir

    out = tmp_path / "out"
    a = OutputDir(out)
    with pytest.raises(OutputBusyError, match=f"pid {os.getpid()}"):
        OutputDir(out)
    r = cli("predict", "traction", SCENE, "--creepage", "0:0.05:3", "-o", out)
    assert r.exit_code == 2 and "another torlab run" in error_lines(r)[0]
    a.write_text("x.txt", "1")
    a.commit()
    assert not (tmp_path / ".out.lock").exists()
    OutputDir(out, force=True).abort()  # free again


def test_leftovers_of_killed_runs_are_removed_and_hidden_results_restored(tmp_path):
    from torlab.outputs import OutputDir

    out = tmp_path / "out"
    with OutputDir(out) as d:
        d.write_text("a.txt", "earlier")
    # a commit killed between its two renames: OUT gone, the results in .out.old-*
    os.replace(out, tmp_path / ".out.old-99999999-1")
    (tmp_path / ".out.staging-99999999-abc").mkdir()
    (tmp_path / ".out.staging-99999999-abc" / "half.csv").write_text("x")
    (tmp_path / ".out.trash-1-2").mkdir()
    with pytest.warns(TorlabWarning, match="restored the earlier results"):
        d = OutputDir(out, force=True)
    assert (out / "a.txt").read_text() == "earlier"
    assert any("restored" in n for n in d.notes)
    d.abort()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.mark.parametrize("exchange", [True, False])
def test_commit_replaces_and_keeps_files_written_during_the_run(tmp_path, monkeypatch, exchange):
    from torlab import outputs
    from torlab.outputs import OutputDir

    if not exchange:
        monkeypatch.setattr(outputs, "_exchange", lambda folder, a, b: False)
    out = tmp_path / "out"
    with OutputDir(out) as d:
        d.write_text("data/a.csv", "old")
        d.write_text("report.md", "old")
    d = OutputDir(out, force=True)
    d.write_text("data/a.csv", "new")
    (out / "notes.txt").write_text("mine")          # the user writes into OUT meanwhile
    (out / "data" / "mine.csv").write_text("mine too")
    with pytest.warns(TorlabWarning, match="written into the output folder during the run"):
        d.commit()
    assert (out / "data" / "a.csv").read_text() == "new" and not (out / "report.md").exists()
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "data" / "mine.csv").read_text() == "mine too"
    assert len([n for n in d.notes if n.startswith("kept")]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    with pytest.raises(OutputExistsError, match=r"mine\.csv"):  # not ours: --force refuses now
        OutputDir(out, force=True)


def test_force_refuses_a_user_file_inside_a_result_subfolder(tmp_path):
    from torlab.outputs import OutputDir

    out = tmp_path / "out"
    with OutputDir(out) as d:
        d.write_text("data/a.csv", "x")
    (out / "data" / "my_notes.txt").write_text("mine")
    with pytest.raises(OutputExistsError, match=r"data/my_notes\.txt"):
        OutputDir(out, force=True)


@pytest.mark.parametrize("err, fragment", [(28, "no space left"), (30, "read-only"),
                                           (13, "permission denied")])
def test_write_failures_are_exit_2_and_leave_nothing(cli, tmp_path, monkeypatch, err, fragment):
    import pandas as pd

    from torlab import outputs

    def full(*a, **k):
        raise OSError(err, os.strerror(err))

    out = tmp_path / "out"
    # the table is written through pandas or, without it, as bytes: both fail
    monkeypatch.setattr(pd.DataFrame, "to_csv", full)
    monkeypatch.setattr(outputs, "_write_file", full)
    r = cli("predict", "traction", SCENE, "--creepage", "0:0.05:3", "-o", out)
    assert r.exit_code == 2
    (line,) = error_lines(r)
    assert line.startswith(f"error: {out}/traction.csv: cannot write the results: {fragment}")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_unwritable_place_is_exit_2(cli, tmp_path, monkeypatch):
    from torlab import outputs

    def denied(*a, **k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(outputs, "_private_dir", denied)
    r = cli("predict", "traction", SCENE, "--creepage", "0:0.05:3", "-o", tmp_path / "out")
    assert r.exit_code == 2 and "permission denied" in error_lines(r)[0]


def test_safe_name():
    from torlab.files import safe_name

    assert "/" not in safe_name("../../x") and not safe_name("../../x").startswith(".")
    assert safe_name("") == "_" and safe_name("OFM1-dry") == "OFM1-dry"


# ------------------------------------------------------------------------------ CLI policy
def test_debug_is_accepted_anywhere(cli, tmp_path):
    for k, args in enumerate((["--debug", "predict", "traction"],
                              ["predict", "--debug", "traction"], ["predict", "traction"])):
        r = cli(*args, SCENE, "--creepage", "0:0.05:3", "-o", tmp_path / str(k), "--debug",
                "--no-plot")
        assert r.exit_code == 0, r.output
    r = cli("predict", "traction", tmp_path / "missing.yaml", "-o", tmp_path / "x", "--debug")
    assert isinstance(r.exception, TorlabInputError)  # --debug: the exception, not one line


def test_numpy_warnings_never_reach_the_console(cli, tmp_path, monkeypatch):
    from torlab.cli import _STATE
    from torlab.model import predict

    real = predict.predict_traction

    def noisy(*a, **k):
        np.log(np.zeros(1))  # RuntimeWarning: divide by zero
        return real(*a, **k)

    monkeypatch.setattr(predict, "predict_traction", noisy)
    r = cli("predict", "traction", SCENE, "--creepage", "0:0.05:3", "-o", tmp_path / "a")
    assert r.exit_code == 0 and "RuntimeWarning" not in r.output + r.stderr
    assert [w[0] for w in _STATE["hidden_warnings"]] == ["RuntimeWarning"]
    r = cli("predict", "traction", SCENE, "--creepage", "0:0.05:3", "-o", tmp_path / "b", "--debug")
    assert "RuntimeWarning" in r.stderr


def test_environment_error_is_exit_2(cli, tmp_path, monkeypatch):
    from torlab import scene

    def boom(*a, **k):
        raise OSError(5, "Input/output error", "scene.yaml")

    monkeypatch.setattr(scene, "load_scene", boom)
    r = cli("predict", "traction", SCENE, "-o", tmp_path / "o")
    assert r.exit_code == 2 and error_lines(r) == ["error: scene.yaml: Input/output error"]


# ------------------------------------------------------------------------------ report.md
def test_markdown_report_escapes_html_from_log_headers():
    import pandas as pd

    from torlab.reports.html import Section, Table, render_markdown

    evil = "<img src=x onerror=alert(1)> [x](javascript:alert(1)) | `code`"
    s = Section(key="amount", title=f"Amount {evil}", paragraphs=[f"{evil}: f falls"],
                notes=[f"note {evil}\n# heading"],
                tables=[Table("t", pd.DataFrame({"product": [evil]}), f"cap {evil}")])
    md = render_markdown(f"T {evil}", [evil], [s], {"inputs": {evil: "abc"}})
    import re

    assert "<img" not in md and not re.search(r"(?<!\\)\]\(javascript", md)
    assert "\n# heading" not in md
    assert "&lt;img src=x onerror=alert(1)&gt;" in md
    lines = md.splitlines()
    for head in ("| product |", "| input file | SHA-256 |"):  # the | in values is escaped
        i = lines.index(head)
        cells = len(re.findall(r"(?<!\\)\|", head))
        assert len(re.findall(r"(?<!\\)\|", lines[i + 2])) == cells


# ------------------------------------------------------------------------------ the issue's wrong numbers
def test_e_strip_without_elastic_layer_is_the_closed_form():
    """L_mue = 0 (the scene default) gives r = 0: e = 1 - cos(theta), also at theta = 0."""
    from torlab.model.strip import e_strip

    th = np.array([0.0, 1e-12, 0.3, 1.0, np.pi / 2, np.pi])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        e = e_strip(th, np.zeros_like(th))
    np.testing.assert_allclose(e, 1.0 - np.cos(th), rtol=1e-12, atol=1e-15)


def test_documented_scene_without_layer_lengths_but_with_thermal(cli, tmp_path):
    s = tmp_path / "s.yaml"
    s.write_text("\n".join(ln for ln in SCENE.read_text().splitlines() if "L_mu" not in ln))
    r = cli("predict", "traction", s, "--creepage", "0:0.05:11", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    import pandas as pd

    t = pd.read_csv(tmp_path / "o" / "traction.csv")
    assert np.isfinite(t["max_temperature_C"]).all() and t["max_temperature_C"].iloc[0] == 20.0
    assert (t["mu"] <= 0.45 + 1e-12).all()  # never above mu_c2


def test_short_creepage_list_on_a_saturating_scene(cli, tmp_path):
    s = tmp_path / "s.yaml"  # without L_mue/L_mup: saturated at the first creepage
    s.write_text("\n".join(ln for ln in SCENE.read_text().splitlines() if "L_mu" not in ln))
    r = cli("predict", "traction", s, "--creepage", "0.01,0.02,0.05", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    assert "too few points" in r.output


def test_predictions_outside_the_model_say_so(cli, tmp_path):
    hot = tmp_path / "hot.yaml"
    hot.write_text(SCENE.read_text().replace("speed: 10 m/s", "speed: 140 m/s")
                   .replace("load: 20 kN", "load: 900 kN"))
    r = cli("predict", "traction", hot, "--creepage", "0:0.05:6", "-o", tmp_path / "h")
    assert r.exit_code == 0
    notes = json.loads((tmp_path / "h" / "summary.json").read_text())["notes"]
    assert any("contact temperature reaches" in n for n in notes) and "°C" in r.output
    r = cli("predict", "traction", SCENE, "--creepage", "0:0.05:6", "-o", tmp_path / "n")
    notes = json.loads((tmp_path / "n" / "summary.json").read_text())["notes"]
    assert not any("reaches" in n for n in notes)  # the documented scene: 20-200 degC


def _pcs_rows(text: str) -> tuple[list[str], int, list[str]]:
    lines = text.split("\n")
    h = next(i for i, ln in enumerate(lines) if ln.startswith("Step Time (s)"))
    return lines, h, lines[h].split("\t")


def test_blank_coefficient_cell_is_filled_from_its_own_row(tmp_path):
    from torlab.parsers.pcs import read_pcs
    from torlab.reduce.mtm import reduce_pcs

    text = (ROOT / "sample_data" / "mtm" / "mtm_TOR-A_5uL.txt").read_bytes().decode()
    text = text.replace("\r\n", "\n")
    lines, h, head = _pcs_rows(text)
    tc = [j for j, c in enumerate(head) if c.startswith("Traction Coeff")]
    tf, bl = head.index("Traction Force (N)"), head.index("Ball Load (N)")
    cells = lines[h + 5].split("\t")
    for j in tc:
        cells[j] = ""
    lines[h + 5] = "\t".join(cells)
    f = tmp_path / "blank.txt"
    f.write_text("\n".join(lines))
    red = reduce_pcs(*read_pcs(f))
    timed = red.curves["timed"]
    assert len(timed) == 1260  # no row lost, no row blanked
    row = timed.loc[timed["line"] == h + 6].iloc[0]
    assert row["traction_coefficient"] == pytest.approx(float(cells[tf]) / float(cells[bl]))
    others = timed.loc[timed["line"] != h + 6, "traction_coefficient"]
    assert others.notna().all()


def test_zero_ball_load_is_reported_or_refused(cli, tmp_path):
    text = (ROOT / "sample_data" / "mtm" / "mtm_TOR-A_5uL.txt").read_bytes().decode()
    lines, h, head = _pcs_rows(text.replace("\r\n", "\n"))
    tc = [j for j, c in enumerate(head) if c.startswith("Traction Coeff")]
    bl = head.index("Ball Load (N)")
    for blank_coeff in (False, True):
        out = list(lines)
        for i in range(h + 1, len(out)):
            cells = out[i].split("\t")
            if len(cells) == len(head):
                cells[bl] = "0"
                for j in tc if blank_coeff else ():
                    cells[j] = ""
                out[i] = "\t".join(cells)
        f = tmp_path / f"load0_{blank_coeff}.txt"
        f.write_text("\n".join(out))
        r = cli("mtm", "reduce", f, "-o", tmp_path / f"o{blank_coeff}")
        if blank_coeff:
            assert r.exit_code == 2
            assert "Ball Load" in error_lines(r)[0] and str(f) in error_lines(r)[0]
        else:
            assert r.exit_code == 0
            assert "Ball Load is zero or negative in 1260 of 1260 rows" in r.output


def test_viscometer_with_the_wrong_position_sign_warns(cli, tmp_path):
    src = (ROOT / "sample_data" / "visc" / "visc_ester_25C.txt").read_text().split("\n")
    src.insert(1, "# position_sign: -1")  # this LVDT already reads positive downward
    f = tmp_path / "v.txt"
    f.write_text("\n".join(src))
    ref = ROOT / "sample_data" / "visc" / "visc_reference_25C.txt"
    # the tables only (--no-plot): the warnings are the reduction's
    r = cli("visc", "reduce", f, "--reference", ref, "-o", tmp_path / "o", "--no-plot")
    assert r.exit_code == 0
    warn = [ln for ln in error_lines(r) if ln.startswith("warning:")]
    assert len(warn) == 1 and "position_sign is -1" in warn[0]
    r = cli("visc", "reduce", ROOT / "sample_data" / "visc" / "visc_ester_25C.txt",
            "--reference", ref, "-o", tmp_path / "ok", "--no-plot")
    assert r.exit_code == 0 and not [ln for ln in error_lines(r) if ln.startswith("warning:")]


def test_product_name_cannot_escape_the_output_folder(tmp_path):
    from torlab.protocols.runner import run_protocol

    (tmp_path / "w").mkdir()
    p = _small_protocol(tmp_path / "w")
    for f in (tmp_path / "w").glob("hpt_*.txt"):
        f.write_text(f.read_text().replace("# product: OFM1", "# product: ../../x <img src=x>"))
    p.write_text(p.read_text() + "fits:\n  hpt_layers:\n    amounts: [4 uL]\n"
                 "    temperature_coefficients: false\n")
    before = set(tmp_path.rglob("*"))
    run_protocol(p, tmp_path / "w" / "out")
    new = set(tmp_path.rglob("*")) - before
    assert all((tmp_path / "w" / "out") in q.parents or q == tmp_path / "w" / "out" for q in new)
    assert "<img" not in (tmp_path / "w" / "out" / "report.md").read_text()
