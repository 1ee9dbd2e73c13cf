"""Protocol runs that stay cheap as the campaign grows: the cache's index, light reductions
in the parent process, a re-run with nothing changed, one scan per folder, results stored
as they arrive.

Each test checks a result or a count of work (entries read, files rewritten, hashes
computed), never a duration; ``torlab bench --campaign`` measures the speed.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import pytest
from conftest import SMALL_PROTOCOL as AMOUNT

ROOT = Path(__file__).resolve().parents[1]
HPT = ROOT / "sample_data" / "hpt"


FITS = """\
version: 1
name: fits
products:
  OFM1: {label: "oil-based FM 1", density: 930 kg/m^3}
data:
  hpt:
    files: [hpt_*.txt]
fits:
  hpt_layers:
    amounts: [4 uL]
    temperature: 25 degC
    joint: true
    temperature_coefficients: false
reports:
  amount:
    curve: interpolation
"""


def _protocol(tmp_path: Path, text: str, pattern: str, n: int = 4) -> Path:
    for f in sorted(HPT.glob(pattern))[:n]:
        shutil.copy(f, tmp_path / f.name)
    p = tmp_path / "p.yaml"
    p.write_text(text)
    return p


def _light(rec: dict[str, Any]) -> Any:
    """An index record's light value, read as the index's format describes it (base64 of
    zlib-compressed JSON), independently of the cache's own reader."""
    import base64
    import zlib

    return json.loads(zlib.decompress(base64.b64decode(rec["light"], validate=True)))


def _files(out: Path) -> dict[str, tuple[int, int, bytes]]:
    return {str(f.relative_to(out)): (f.stat().st_ino, f.stat().st_mtime_ns, f.read_bytes())
            for f in sorted(out.rglob("*")) if f.is_file()}


# ------------------------------------------------------------------ nothing changed
def test_rerun_with_nothing_changed_rewrites_nothing(tmp_path):
    """A --force re-run that finds the protocol, its files, torlab and the options as they
    were leaves every file of the results (and of its cache) as it is; an edited result or
    a changed input makes it a run again, which restores what was edited."""
    from torlab.protocols.runner import run_protocol

    p = _protocol(tmp_path, AMOUNT, "hpt_OFM1_*uL_25C.txt")
    out = tmp_path / "out"
    r1 = run_protocol(p, out)
    before = _files(out)
    r2 = run_protocol(p, out, force=True)
    assert r2.unchanged and not r1.unchanged
    assert _files(out) == before  # same inodes, times and bytes: nothing rewritten
    assert (r2.cache_hits, r2.cache_misses) == (r1.cache_misses, 0)
    assert r2.summary["reports"] == r1.summary["reports"] and r2.sections == r1.sections
    assert (r2.timing["figures_drawn"], r2.timing["figures_reused"]) == (0, 2)
    # an edited result: a run (from the cache), which writes the result again
    md = out / "report.md"
    text = md.read_text()
    md.write_text(text + "\nmy own line\n")
    r3 = run_protocol(p, out, force=True)
    assert not r3.unchanged and (r3.cache_hits, r3.cache_misses) == (r1.cache_misses, 0)
    assert md.read_text() == text
    # other options: a run
    r4 = run_protocol(p, out, force=True, formats=["png", "svg"])
    assert not r4.unchanged and list(out.rglob("*.svg"))
    # a changed input: a run that recomputes that file only
    f = sorted(tmp_path.glob("hpt_*.txt"))[-1]
    f.write_text(f.read_text().replace("# operator: torlab synth", "# operator: someone"))
    r5 = run_protocol(p, out, force=True, formats=["png", "svg"])
    assert not r5.unchanged and r5.cache_misses == 1


def test_unchanged_results_copied_elsewhere_are_run_again(tmp_path):
    """The record of the run is signed and names the files by their status: a copy of the
    results (new files) or a folder from elsewhere is never taken as current."""
    from torlab.protocols.runner import run_protocol

    p = _protocol(tmp_path, AMOUNT, "hpt_OFM1_*uL_25C.txt")
    run_protocol(p, tmp_path / "out")
    shutil.copytree(tmp_path / "out", tmp_path / "copy")
    r = run_protocol(p, tmp_path / "copy", force=True)
    assert not r.unchanged


# ------------------------------------------------------------------ light reductions
@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """The small fit protocol run once: ``(protocol, out, result)``."""
    from torlab.protocols.runner import run_protocol

    d = tmp_path_factory.mktemp("fits")
    p = _protocol(d, FITS, "hpt_OFM1_*uL_25C.txt")
    return p, d / "out", run_protocol(p, d / "out")


def test_parent_keeps_light_reductions_and_fits_read_the_whole_ones(tmp_path, monkeypatch,
                                                                    fitted):
    """The run keeps each HPT log's header and key figures only; the fit, which reads the
    curves from the cache in its task, equals the fit of a run without a cache (which
    keeps the whole reductions)."""
    from torlab.protocols import fits as fits_mod
    from torlab.protocols.runner import run_protocol

    p, _, r1 = fitted
    # the fit figures were drawn: their CPU time is the run's figures' (summary.json)
    assert r1.summary["run"]["timing"]["figures_cpu"] == round(r1.timing["figures_cpu"], 3) > 0
    seen = {}
    real = fits_mod.fit_all

    def spy(ctx):
        seen["reds"] = list(ctx.reductions["hpt"])
        seen["full"] = [ctx.full(r) for r in seen["reds"]]
        return real(ctx)

    monkeypatch.setattr(fits_mod, "fit_all", spy)
    monkeypatch.setattr("torlab.protocols.runner.fit_all", spy, raising=False)
    out = tmp_path / "again"
    r2 = run_protocol(p, out)
    reds, full = seen["reds"], seen["full"]
    assert reds and all(r.tables == {} and r.detail.data is None for r in reds)
    assert all(len(f.detail.data) == f.key_numbers["n_points"] > 100 for f in full)
    assert [r.key_numbers for r in reds] == [f.key_numbers for f in full]
    assert [r.meta for r in reds] == [f.meta for f in full]
    # each kept packed: its light form compressed, read back as the instrument made it
    from torlab.instruments import get_instrument
    from torlab.protocols.data import PackedReduction

    impl = get_instrument("hpt").impl()
    assert all(isinstance(r, PackedReduction) for r in reds)
    assert [r.light_json() for r in reds] == [impl.light(f) for f in full]
    text = [len(json.dumps(r.light_json(), separators=(",", ":"))) for r in reds]
    assert max(len(r._blob) for r in reds) < 0.3 * min(text)
    assert [r.stem for r in reds] == [f.stem for f in full]
    r0 = run_protocol(p, tmp_path / "nocache", cache=False)
    assert r2.summary["fits"] == r0.summary["fits"] == r1.summary["fits"]
    assert r2.summary["data"] == r0.summary["data"]
    assert (out / "data" / "hpt_summary.csv").read_bytes() == \
        (tmp_path / "nocache" / "data" / "hpt_summary.csv").read_bytes()


def test_index_remakes_each_light_form_from_the_kept_reduction(tmp_path, monkeypatch,
                                                                fitted):
    """The run's index holds no second copy of a light form (its record keeps the restored
    reduction and remakes the JSON when the index is written); what it writes is the light
    form of the whole reduction in the entry, and a later run that takes the light forms
    from that index writes them again unchanged."""
    from torlab.instruments import get_instrument
    from torlab.protocols.cache import CACHE_DIR, LightOf, ResultCache
    from torlab.protocols.runner import run_protocol

    p, _, _ = fitted
    out = tmp_path / "out"
    held: list[Any] = []
    real = ResultCache.write_index

    def spy(self):
        held.extend(r["light"] for r in self._next.values() if "light" in r)
        return real(self)

    monkeypatch.setattr(ResultCache, "write_index", spy)
    run_protocol(p, out)
    assert held and all(isinstance(x, LightOf) for x in held)
    impl = get_instrument("hpt").impl()
    rc = ResultCache(out / CACHE_DIR)
    entries = rc._read_index()["entries"]
    lights = {n: _light(r) for n, r in entries.items() if "light" in r}
    assert len(lights) == len(held)
    rc._load_index()
    for name, j in lights.items():
        hit, whole = rc._load(name, "hpt")
        assert hit and whole.detail.data is not None
        assert json.dumps(impl.light(whole)) == json.dumps(j)
        assert json.dumps(impl.light(impl.from_light(j))) == json.dumps(j)
    held.clear()
    r = run_protocol(p, out, force=True, figures=False)  # another key: lights from the index
    assert held and all(isinstance(x, LightOf) for x in held)
    assert r.timing["figures_cpu"] == r.summary["run"]["timing"]["figures_cpu"] == 0
    again = ResultCache(out / CACHE_DIR)._read_index()["entries"]
    assert {n: _light(r) for n, r in again.items() if "light" in r} == lights


def test_the_index_read_at_the_start_keeps_no_record_the_run_consulted(tmp_path, monkeypatch,
                                                                         fitted):
    """Each record of the earlier index (an entry's status and light form, an input file's
    hash) is read once: the run moves what it uses into the index it writes and lets go of
    what no longer describes its file.  A copy of the results (every file new: no record
    matches) is re-run, so each log's light form is read from its entry; the records of
    the copied index, with their light JSON, are not kept to the run's end."""
    from torlab.protocols.cache import CACHE_DIR, ResultCache
    from torlab.protocols.runner import run_protocol

    p, out, _ = fitted
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)  # new files: new inodes and change times
    n_logs = len(list(p.parent.glob("hpt_*.txt")))
    seen: dict[str, Any] = {}
    real = ResultCache.write_index

    def spy(self):
        seen.update(left=dict(self._index), hashes=dict(self._hashes),
                    used=set(self._next), hashed=set(self._hashes_next))
        return real(self)

    monkeypatch.setattr(ResultCache, "write_index", spy)
    earlier = ResultCache(copy / CACHE_DIR)._read_index()
    r = run_protocol(p, copy, force=True, figures=False)
    hpt = [n for n, rec in earlier["entries"].items() if rec["kind"] == "hpt"]
    assert len(hpt) == n_logs and set(hpt) <= seen["used"]
    assert r.cache_hits >= n_logs  # the light forms came from the copied entries
    assert not set(seen["left"]) & seen["used"]  # nothing used is kept twice
    assert not [n for n, rec in seen["left"].items() if "light" in rec]
    assert set(earlier["files"]) <= seen["hashed"] and not seen["hashes"]
    assert r.summary["fits"] == fitted[2].summary["fits"]


def test_packed_reduction_reads_back_what_it_was_given(fitted):
    """A light form kept packed gives back the JSON it was given (non-finite numbers and
    non-ASCII text too) and the Reduction restored from it, whichever of several is read in
    turn; its name (set by the run) carries into the restored one; JSON of another shape
    is refused when packed; it is a fraction of the JSON's size."""
    import numpy as np

    from torlab.instruments import get_instrument, prepare_options
    from torlab.protocols.data import PackedReduction, _light, _Restore
    from torlab.protocols.loader import load_protocol

    p, _, _ = fitted
    lp = load_protocol(p)
    inst = get_instrument("hpt")
    opts = {k: v for k, v in lp.protocol.data.hpt.options().items() if v is not None}
    prepared = prepare_options(inst, opts)
    whole = [inst.impl().reduce(f, **prepared) for f in lp.data_files("hpt")[:3]]
    forms = [inst.impl().light(r) for r in whole]
    forms[1]["key_numbers"]["f_window"] = float("nan")
    forms[2]["meta"]["operator"] = "Jürgen Müller"
    packed = [_Restore("hpt")(json.loads(json.dumps(j))) for j in forms]
    assert all(isinstance(x, PackedReduction) for x in packed)
    for _ in range(2):  # each read after another one: restored again, not the last one's
        for x, j, w in zip(packed, forms, whole, strict=True):
            got = x.light_json()
            assert json.dumps(got) == json.dumps(j) and json.dumps(_light(x)) == json.dumps(j)
            assert x.meta == w.meta if j is not forms[2] else x.meta.operator == "Jürgen Müller"
            assert x.detail.data is None and x.tables == {}
            assert (x.source, x.stem, x.label) == (w.source, w.stem, w.label)
    assert packed[1].key_numbers["f_window"] != packed[1].key_numbers["f_window"]  # NaN
    packed[0].name = "run-a"
    assert packed[0].stem == packed[0].label == "run-a" == packed[0].restored().stem
    with pytest.raises(AttributeError):
        _ = packed[0].no_such_attribute
    bad = json.loads(json.dumps(forms[0]))
    del bad["meta"]
    with pytest.raises(KeyError):
        _Restore("hpt")(bad)
    numpy_number = json.loads(json.dumps(forms[0]))  # marshal would keep its bytes
    numpy_number["key_numbers"]["f_window"] = np.float64(0.1)
    with pytest.raises(TypeError, match=r"key_numbers\.f_window is a numpy\.float64"):
        _Restore("hpt")(numpy_number)
    assert all(len(x._blob) < 0.3 * len(json.dumps(j)) for x, j in zip(packed, forms,
                                                                      strict=True))


def test_rerun_reads_no_reduction_of_an_unchanged_file(tmp_path, monkeypatch, fitted):
    """With one input changed, the other files' reductions come from the cache's index (no
    entry file read); the fit of the changed runs is computed again."""
    from torlab.protocols.cache import ResultCache
    from torlab.protocols.runner import run_protocol

    p0, _, r1 = fitted
    shutil.copytree(p0.parent, tmp_path / "w", ignore=shutil.ignore_patterns("out"))
    p = tmp_path / "w" / p0.name
    out = tmp_path / "w" / "out"
    run_protocol(p, out)
    f = sorted(p.parent.glob("hpt_*.txt"))[-1]
    f.write_text(f.read_text().replace("# operator: torlab synth", "# operator: someone"))
    loaded: list[str] = []
    real = ResultCache._load

    def count(self, name, kind, *rest):
        loaded.append(kind)
        return real(self, name, kind, *rest)

    monkeypatch.setattr(ResultCache, "_load", count)
    r = run_protocol(p, out, force=True)
    assert "hpt" not in loaded  # the unchanged file's reduction: from the index
    assert r.cache_misses == 2  # the changed file's reduction and the fit that uses it
    assert r.summary["fits"] == r1.summary["fits"]  # a comment changed, not the data


def test_task_reduces_again_when_its_entry_changed(tmp_path, fitted):
    """A fit task reads a reduction through a reference checked against the status the run
    stored it with; a changed entry file is not read, the log is reduced again."""
    from torlab.codec import BadEntry
    from torlab.instruments import get_instrument, prepare_options
    from torlab.protocols.cache import ResultCache
    from torlab.protocols.data import StoredReduction, _Section, detail
    from torlab.protocols.loader import load_protocol

    p, _, _ = fitted
    lp = load_protocol(p)
    f = lp.data_files("hpt")[0]
    inst = get_instrument("hpt")
    opts = {k: v for k, v in lp.protocol.data.hpt.options().items() if v is not None}
    prepared = prepare_options(inst, opts)
    whole = inst.impl().reduce(f, **prepared)
    rc = ResultCache(tmp_path / "c")
    stored = StoredReduction(_Section(rc, "hpt", "opts", "hpt", prepared), rc.sha(f), f)
    assert stored.parts == {"sha": rc.sha(f), "name": f.name, "options": "opts"}
    assert stored.job == ("hpt", f, prepared, "hpt")
    rc.store("hpt", whole, **stored.parts)
    arg = stored.arg()
    assert arg.ref is not None
    assert detail(arg).data.equals(whole.detail.data)
    entry = Path(arg.ref.path)
    entry.write_bytes(entry.read_bytes())  # the same bytes, written again: not the same file
    with pytest.raises(BadEntry, match="changed since"):
        arg.ref.value()
    assert detail(arg).data.equals(whole.detail.data)  # reduced again


# ------------------------------------------------------------------ the pieces
def test_output_folder_carries_its_cache_by_moving_it(tmp_path):
    """``carry``: the folder is moved into the new results (the same files, not copies),
    and back when the run fails."""
    from torlab.outputs import OutputDir

    out = tmp_path / "out"
    with OutputDir(out) as d:
        d.write_text(".cache/a.tlc", "entry")
        d.write_text("r.txt", "result")
    ino = (out / ".cache" / "a.tlc").stat().st_ino
    d = OutputDir(out, force=True, carry=[".cache"])
    assert (d.staging / ".cache" / "a.tlc").stat().st_ino == ino
    assert not (out / ".cache").exists()
    d.abort()
    assert (out / ".cache" / "a.tlc").stat().st_ino == ino
    d = OutputDir(out, force=True, carry=[".cache"])
    d.write_text("r.txt", "new")
    d.commit()
    assert (out / ".cache" / "a.tlc").stat().st_ino == ino
    assert ".cache" in json.loads((out / "torlab-manifest.json").read_text())["files"]
    with pytest.raises(ValueError):
        OutputDir(tmp_path / "x", carry=["a/b"])


@pytest.mark.parametrize("jobs", [1, 2])
def test_each_result_is_handled_once_as_it_arrives(jobs):
    from torlab.parallel import ProcessExecutor, SerialExecutor

    seen = []

    def each(i, v):
        seen.append((i, v))
        return -v

    ex = SerialExecutor() if jobs == 1 else ProcessExecutor(jobs)
    try:
        out = ex.map(abs, [-3, 1, -4, 1, -5], each=each, chunksize=2)
    finally:
        ex.close()
    assert out == [-3, -1, -4, -1, -5]
    assert sorted(seen) == [(0, 3), (1, 1), (2, 4), (3, 1), (4, 5)]


def test_one_scan_of_a_folder_matches_glob(tmp_path):
    import glob

    from torlab.protocols.schema import resolve_paths

    for n in ("b.txt", "a.txt", ".hidden.txt", "c.csv", "B.txt"):
        (tmp_path / n).write_text("x")
    (tmp_path / "d.txt").mkdir()
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "e.txt").write_text("x")
    (tmp_path / "link.txt").symlink_to(tmp_path / "a.txt")
    (tmp_path / "dlink.txt").symlink_to(tmp_path / "sub")
    for pat in ("*.txt", ".*.txt", "[ab].txt", "?.txt", "*", "sub/*.txt", "*/e.txt"):
        want = sorted(Path(h) for h in glob.glob(str(tmp_path / pat)) if Path(h).is_file())
        assert resolve_paths(pat, tmp_path) == want, pat
    with pytest.raises(ValueError, match="no file matches"):
        resolve_paths("*.xlsx", tmp_path)


def _small(v):
    return {"n": v["n"]}


def _restored(j):
    return {"n": j["n"], "restored": True}


def test_light_value_taken_twice_from_the_index(tmp_path, monkeypatch):
    """An entry's light value asked for twice in one run (a file listed twice) comes from
    the index both times, as two values of their own, and is written again."""
    from torlab.protocols.cache import Light, ResultCache

    light = Light(_small, _restored)
    c = ResultCache(tmp_path / "c")
    c.store("k", {"n": 7, "data": list(range(100))}, x=1)
    assert c.lookup_light("k", light, x=1) == (True, {"n": 7, "restored": True})
    c.write_index()
    c = ResultCache(tmp_path / "c")
    loads = []
    real = ResultCache._load
    monkeypatch.setattr(ResultCache, "_load",
                        lambda self, n, k, *rest: loads.append(n) or real(self, n, k, *rest))
    (h1, a), (h2, b) = c.lookup_light("k", light, x=1), c.lookup_light("k", light, x=1)
    assert h1 and h2 and a == b == {"n": 7, "restored": True} and a is not b
    assert loads == []  # from the index, not the entry
    c.write_index()
    assert [_light(r) for r in ResultCache(tmp_path / "c")._read_index()["entries"].values()
            ] == [{"n": 7}]


def test_index_written_in_pieces_is_json_of_the_whole_and_signed(tmp_path):
    """The index is written in pieces (never whole in memory): JSON of the whole index
    (the pieces joined where they should be), its signature over it (a later run reads it),
    a light value remade from what the run keeps and packed (base64 of compressed JSON:
    a run holds the index it read as this text until it asks for the value), and an entry
    whose light value is not plain JSON written without it (the others keep theirs)."""
    from torlab.protocols.cache import INDEX, INDEX_PIECE, LightOf, ResultCache

    c = ResultCache(tmp_path / "c")
    c._load_index()
    want, lights = {}, {}
    for i in range(2 * INDEX_PIECE + 345):  # three pieces, the last one part-filled
        name = f"k-{i:04d}.tlc"
        rec = {"kind": "hpt", "st": [i, 2 * i, 3 * i, 4 * i]}
        c._next[name] = dict(rec, light=LightOf(lambda v: {"n": v, "t": "é"}, i))
        want[name], lights[name] = rec, {"n": i, "t": "é"}
        c.used.add(name)
    c._next["odd.tlc"] = {"kind": "x", "st": [1, 2, 3, 4], "light": LightOf(set, ())}
    c.used.add("odd.tlc")
    want["odd.tlc"] = {"kind": "x", "st": [1, 2, 3, 4]}
    c._next["unused.tlc"] = {"kind": "x", "st": [1, 2, 3, 4]}  # not used: not written
    files = {f"/data/é/log {i}.txt": [i, 5, 6, 7, f"{i:064x}", 8] for i in range(INDEX_PIECE + 3)}
    c._hashes_next.update(files)  # two pieces of input files' hash records
    c.write_index()
    data = (tmp_path / "c" / INDEX).read_bytes()
    text = data[data.index(b"\n") + 1:]
    whole = json.loads(text)
    from torlab import __version__

    assert text == json.dumps(whole, separators=(",", ":")).encode()
    assert whole["torlab"] == __version__ and whole["files"] == files and whole["run"] is None
    got = whole["entries"]
    assert {n: _light(r) for n, r in got.items() if "light" in r} == lights
    assert list(got) == list(want)  # in the order the run used them
    assert {n: {k: v for k, v in r.items() if k != "light"} for n, r in got.items()} == want
    again = ResultCache(tmp_path / "c")._read_index()
    assert again == whole  # signed: read back
    (tmp_path / "c" / INDEX).write_bytes(data.replace(b'"st":[7,14,21,28]', b'"st":[7,14,21,29]'))
    assert ResultCache(tmp_path / "c")._read_index() is None  # and checked


def test_input_hashes_are_reused_only_for_files_not_changed_since(tmp_path, monkeypatch):
    from torlab import files
    from torlab.protocols import cache as cm

    f = tmp_path / "in.txt"
    f.write_text("abc")
    calls = []
    real = files.sha256_file
    monkeypatch.setattr(files, "sha256_file", lambda p: calls.append(p) or real(p))

    def fresh():
        c = cm.ResultCache(tmp_path / "c")
        return c, c.sha(f)

    c, h = fresh()
    c.write_index()
    assert h == real(f) and len(calls) == 1
    _, h2 = fresh()  # hashed right after it was written: within the racy margin, again
    assert h2 == h and len(calls) == 2
    monkeypatch.setattr(cm, "RACY_NS", 0)
    c, _ = fresh()
    c.write_index()
    n = len(calls)
    _, h3 = fresh()
    assert h3 == h and len(calls) == n  # unchanged: reused
    f.write_text("abd")  # same size, new content
    c, h4 = fresh()
    assert h4 == real(f) != h and len(calls) == n + 1
    os.utime(f, ns=(0, 0))
    _, h5 = fresh()
    assert h5 == h4 and len(calls) == n + 2  # another status: hashed again


TRACTION = FITS + """\
  traction:
    creepage: {from: 0, to: 0.04, points: 9}
    curves:
      - label: "{set}"
        scene: scene.yaml
        params: ["hpt:*"]
"""


@pytest.mark.slow
def test_predictions_kept_without_their_band_propagation(tmp_path, monkeypatch):
    """The run keeps each predicted curve without its band's propagation (its numbers are in
    the prediction's summary and table), cold and warm; the cache entry keeps it whole, and
    the report is the same as from the whole predictions."""
    import dataclasses

    from torlab.protocols import context
    from torlab.protocols.cache import ResultCache
    from torlab.protocols.runner import run_protocol

    p = _protocol(tmp_path, TRACTION, "hpt_OFM1_4uL_25C*.txt")
    shutil.copy(ROOT / "protocols/scenes/wheel_rail_tab54.yaml", tmp_path / "scene.yaml")
    kept: list[Any] = []
    orig = context.RunContext.predict_many

    def spy(self, *a, **kw):
        out = orig(self, *a, **kw)
        kept.extend(out)
        return out

    monkeypatch.setattr(context.RunContext, "predict_many", spy)
    out = tmp_path / "out"
    r1 = run_protocol(p, out)
    r2 = run_protocol(p, tmp_path / "again")  # another folder: computed again
    assert r1.cache_misses and len(kept) == 2
    stored = [ResultCache(out / ".cache").loads(f.name, "traction", f.read_bytes())
              for f in (out / ".cache").glob("traction-*.tlc")]
    assert len(stored) == 1 and stored[0].band is not None  # the entry: whole
    assert all(k.band is None for k in kept)  # this process: without it
    assert kept[0].summary["band"]["method"] and "mu_low95" in kept[0].table
    # a warm run takes the curve from the cache: kept without the band too
    r3 = run_protocol(p, out, force=True, fit_figures="none")
    assert r3.cache_hits and len(kept) == 3 and kept[2].band is None
    # the report is the one the whole prediction gives
    monkeypatch.setattr(context, "_kept_prediction", lambda _i, v: v)
    r4 = run_protocol(p, tmp_path / "whole")
    assert kept[3].band is not None
    for r in (r2, r3):
        assert r.summary["reports"]["traction"] == r1.summary["reports"]["traction"]
    assert r4.summary["reports"]["traction"] == r1.summary["reports"]["traction"]
    assert kept[3].summary == kept[0].summary
    assert dataclasses.replace(kept[3], band=None).trend == kept[0].trend


def test_json_written_in_pieces_is_the_whole_dump(tmp_path):
    """``OutputDir.write_json`` writes the bytes of ``json.dumps(obj, indent=2)`` and a
    newline while it encodes (a large summary is never whole in memory); a value that is not
    JSON leaves no file and no entry in the manifest, and the name can be written again."""
    import numpy as np

    from torlab.outputs import OutputDir

    obj = {"curves": {f"c{i}": {"mu": np.linspace(0, 0.3, 60) + i, "n": np.int64(i),
                                "name": f"µ {i}", "path": tmp_path / f"f{i}"}
                      for i in range(400)}, "notes": ["ä", None, True, 1.5e-300]}
    dest = OutputDir(tmp_path / "out")
    dest.write_json("summary.json", obj)
    bad = {"a": list(range(40_000)), "b": float("nan")}  # fails after the first pieces
    with pytest.raises(ValueError):
        dest.write_json("sub/bad.json", bad)
    with pytest.raises(TypeError):
        dest.write_json("sub/bad.json", {"x": list(range(40_000)), "y": object()})
    assert not (dest.staging / "sub" / "bad.json").exists()
    dest.write_json("sub/bad.json", {"fixed": 1})  # the name is free again
    dest.commit()
    from torlab.outputs import _json_default

    text = (tmp_path / "out" / "summary.json").read_text(encoding="utf-8")
    assert len(text) > 1 << 17  # more than one piece
    assert text == json.dumps(obj, indent=2, allow_nan=False, default=_json_default) + "\n"
    manifest = json.loads((tmp_path / "out" / "torlab-manifest.json").read_text())
    assert manifest["files"] == ["sub/bad.json", "summary.json"]
    assert json.loads((tmp_path / "out" / "sub" / "bad.json").read_text()) == {"fixed": 1}


def test_text_written_in_lines_keeps_an_unchanged_earlier_file(tmp_path):
    """``OutputDir.write_lines`` writes the UTF-8 bytes of its pieces (over several 64 kB
    blocks); with ``keep_same`` an earlier file of exactly those bytes is kept (the same
    inode, the pieces made once), one that differs only in its last byte or is one byte
    longer is written anew; a piece that fails leaves no file."""
    from torlab.outputs import OutputDir

    lines = [f"<tr><td>µ {i}</td><td>{i * 0.1:.3f}</td></tr>\n" for i in range(8000)]
    text = "".join(lines)
    assert len(text) > 3 << 16
    made = []

    def pieces(last: str = "") -> Any:
        made.append(1)
        return iter([*lines, last])

    out = tmp_path / "out"
    with OutputDir(out) as d:
        d.write_lines("report.html", pieces)
        d.write_lines("same.html", pieces)
        d.write_lines("longer.html", pieces)
        d.write_lines("last.html", lambda: iter([*lines[:-1], lines[-1][:-1] + "x"]))
    assert (out / "report.html").read_bytes() == text.encode("utf-8")
    inode = {n: (out / n).stat().st_ino for n in ("report.html", "same.html", "longer.html",
                                                  "last.html")}
    made.clear()
    d = OutputDir(out, force=True)
    d.write_lines("report.html", pieces, keep_same=True)
    assert made == [1] and d.kept == ["report.html"]
    d.write_lines("same.html", pieces, keep_same=False)  # not asked: written anew
    d.write_lines("longer.html", lambda: pieces("!"), keep_same=True)
    d.write_lines("last.html", pieces, keep_same=True)
    assert d.kept == ["report.html"] and len(made) == 1 + 1 + 2 + 2

    def failing() -> Any:
        yield from lines
        raise RuntimeError("a table could not be rendered")

    with pytest.raises(RuntimeError):
        d.write_lines("bad.html", failing)
    assert not (d.staging / "bad.html").exists()
    d.commit()
    assert not (out / "bad.html").exists()
    assert (out / "report.html").stat().st_ino == inode["report.html"]
    for n in ("same.html", "longer.html", "last.html"):
        assert (out / n).stat().st_ino != inode[n]
        assert (out / n).read_bytes() == (text + ("!" if n == "longer.html" else "")).encode()


def test_a_fit_gives_its_estimates_only_to_a_protocol_that_compares(tmp_path, monkeypatch):
    """The estimates of a fitted set (``torlab.comparison.item_from_fit``) are made only when
    the protocol has ``reports.compare``: a campaign's hundreds of fits keep none otherwise."""
    import torlab.comparison as cmp
    from tests.test_prepare import small_fit_protocol
    from torlab.protocols.runner import run_protocol

    made: list[str] = []
    orig = cmp.item_from_fit
    monkeypatch.setattr(cmp, "item_from_fit", lambda res, label, *a, **k: (
        made.append(label), orig(res, label, *a, **k))[1])
    p = small_fit_protocol(tmp_path)
    for f in ROOT.glob("sample_data/hpt/hpt_OFM2_4uL_25C*.txt"):  # a second product
        shutil.copy(f, tmp_path / f.name)
    run_protocol(p, tmp_path / "plain", figures=False, cache=False)
    assert made == []
    p.write_text(p.read_text() + "  compare:\n  - quantities: [L_mue]\n")
    r = run_protocol(p, tmp_path / "compared", figures=False, cache=False)
    assert sorted(made) == ["OFM1", "OFM2"] and "compare" in r.sections


def test_the_index_read_at_the_start_holds_each_light_value_as_packed_text(tmp_path):
    """A run reads the whole index even when one file changed; each light value stays the
    compact text the index holds (not a tree of Python objects) until the run asks for it,
    and reads back as the value that was written."""
    from torlab.protocols.cache import Light, ResultCache

    light = Light(_small, _restored)
    c = ResultCache(tmp_path / "c")
    for n in range(3):
        c.store("k", {"n": n, "data": list(range(100))}, x=n)
    for n in range(3):
        c.lookup_light("k", light, x=n)
    c.write_index()
    c = ResultCache(tmp_path / "c")
    c._load_index()
    assert len(c._index) == 3 and all(type(r["light"]) is str for r in c._index.values())
    assert [c.lookup_light("k", light, x=n) for n in range(3)] == [
        (True, {"n": n, "restored": True}) for n in range(3)]


@pytest.mark.parametrize("damage", ["not base64 !", "bm90IHpsaWI=", "truncated", "trailing",
                                    "too long", "not json"])
def test_a_packed_light_value_that_is_not_one_is_refused(monkeypatch, damage):
    """What :func:`unpack_light` is given is checked: base64, a whole zlib stream with
    nothing after it, inflated no further than the limit, JSON -- else ValueError (an index
    record whose light value is refused is read from its entry instead)."""
    import base64
    import zlib

    import torlab.protocols.cache as cache

    def b64(raw: bytes) -> str:
        return base64.b64encode(raw).decode()

    good = zlib.compress(b'{"n":1}')
    assert cache.unpack_light(b64(good)) == {"n": 1} == cache.unpack_light(cache.pack_light(
        {"n": 1}))
    monkeypatch.setattr(cache, "LIGHT_MAX_BYTES", 1000)
    text = {"not base64 !": "not base64 !", "bm90IHpsaWI=": "bm90IHpsaWI=",
            "truncated": b64(good[:-3]), "trailing": b64(good + b"x"),
            "too long": b64(zlib.compress(b'"' + b"a" * 5000 + b'"')),
            "not json": b64(zlib.compress(b"{n: 1}"))}[damage]
    with pytest.raises(ValueError):
        cache.unpack_light(text)


def test_an_index_light_value_refused_is_read_from_its_entry(tmp_path, monkeypatch):
    """A signed index whose light value does not unpack costs a read of the entry, not a
    wrong value or an error."""
    from torlab.protocols.cache import Light, ResultCache

    light = Light(_small, _restored)
    c = ResultCache(tmp_path / "c")
    c.store("k", {"n": 7, "data": list(range(100))}, x=1)
    c.lookup_light("k", light, x=1)
    (rec,) = c._next.values()
    rec["light"] = "bm90IHpsaWI="  # base64, not of a zlib stream: written as it is
    c.write_index()
    c = ResultCache(tmp_path / "c")
    c._load_index()
    assert [r["light"] for r in c._index.values()] == ["bm90IHpsaWI="]
    loads = []
    real_load = ResultCache._load
    monkeypatch.setattr(ResultCache, "_load",
                        lambda self, n, k, *rest: loads.append(n) or real_load(self, n, k, *rest))
    assert c.lookup_light("k", light, x=1) == (True, {"n": 7, "restored": True})
    assert len(loads) == 1
