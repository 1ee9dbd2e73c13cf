"""The binary cache entry (torlab.protocols.cache, format 2) and the cache's carry-over.

An entry is ``torlab-cache 2 <hmac>`` / a JSON tree / the raw bytes of its arrays.  These
tests build entries, check that every value comes back equal (tables with their dtypes,
shared objects as one object), and that an entry signed with the right key but with a
broken tree (an array outside the data, a table whose blocks miss a column, a reference
to nothing) is refused, never read out of bounds.  The carry-over of ``OUT/.cache`` as
hard links must never write through to the earlier results.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest


def _cache(tmp_path):
    from torlab.protocols.cache import ResultCache

    return ResultCache(tmp_path / "c")


def _split(blob: bytes) -> tuple[bytes, dict, bytes]:
    head, tree, arrays = blob.split(b"\n", 2)
    return head, json.loads(tree), arrays


def _signed(c, body: dict, arrays: bytes) -> bytes:
    """An entry with a correct HMAC under ``c``'s key (as if torlab itself had written it)."""
    payload = json.dumps(body).encode() + b"\n" + arrays
    return f"torlab-cache 2 {c._mac(payload)}\n".encode() + payload


def _mixed_table() -> pd.DataFrame:
    df = pd.DataFrame({
        "x_m": [1.0, np.nan, 3.0, 4.5],
        "n": np.array([1, 2, 3, 4], dtype=np.int64),
        "ok": [True, False, True, True],
        "label": ["a", None, "c", "d"],
        "y_m": [0.5, 0.25, 0.125, 1e-300],
        "k": np.array([7, 8, 9, 10], dtype=np.int32),
        "obj": np.array([1, "x", None, 2.5], dtype=object),
        "when": pd.to_datetime(["2024-01-01", "2024-01-02", "2024-01-03", "2024-01-04"]),
        "frac": pd.array([0.5, None, 1.5, 2.0], dtype="Float64"),
    }, index=pd.Index([10, 20, 30, 40], name="row"))
    df.attrs["unit"] = "m"
    return df


def test_entry_round_trip_keeps_tables_arrays_and_shared_objects(tmp_path):
    from torlab.reduce.viscometer import Calibration

    c = _cache(tmp_path)
    df = _mixed_table()
    a = np.arange(12.0).reshape(3, 4)
    v = {"table": df, "again": df, "arr": a, "same": a, "col": df["x_m"],
         "empty": pd.DataFrame(index=pd.RangeIndex(3)), "none": np.zeros((0, 5)),
         "text": np.array(["ab", "c"]), "cal": Calibration(1.9e-8, K_sd=1e-10, n_falls=3),
         "t": (1, "a", None, math.inf), "big": 10 ** 30, np.float64(1.5): {2, 3},
         "path": Path("a/b")}
    back = c.loads("k-1.tlc", "k", c.dumps("k-1.tlc", "k", v))
    pd.testing.assert_frame_equal(back["table"], df)
    assert list(back["table"].dtypes) == list(df.dtypes)
    assert back["table"].attrs == {"unit": "m"}
    assert back["again"] is back["table"]  # one object stored once, one object decoded
    assert back["arr"] is back["same"]
    np.testing.assert_array_equal(back["arr"], a)
    pd.testing.assert_series_equal(back["col"], df["x_m"])
    pd.testing.assert_frame_equal(back["empty"], v["empty"])
    assert back["none"].shape == (0, 5) and back["text"].tolist() == ["ab", "c"]
    assert back["cal"] == v["cal"] and back["t"] == v["t"] and back["big"] == 10 ** 30
    assert back[1.5] == {2, 3} and back["path"] == Path("a/b")
    # decoded arrays are writable numbers of their own (a view of the entry's bytes)
    back["arr"][0, 0] = -1.0
    assert a[0, 0] == 0.0 and back["table"]["x_m"].iloc[0] == 1.0


def _base(a: np.ndarray) -> Any:
    """The object at the end of an array's chain of bases (itself when it owns its data)."""
    while isinstance(a, np.ndarray) and a.base is not None:
        a = a.base
    return a


def test_an_entry_decoded_with_arrays_of_their_own_shares_no_bytes(tmp_path):
    """``loads(copy=True)`` (a caller that keeps only part of a value): the same value,
    but every array, a table's columns included, with memory of its own -- a kept part
    no longer keeps the whole entry's bytes; without it the arrays are views of them."""
    c = _cache(tmp_path)
    df = _mixed_table()
    v = {"table": df, "big": np.arange(50_000.0), "small": np.arange(3.0)}
    data = bytearray(c.dumps("k-1.tlc", "k", v))
    viewed = c.loads("k-1.tlc", "k", data)
    own = c.loads("k-1.tlc", "k", data, copy=True)
    pd.testing.assert_frame_equal(own["table"], df)
    assert list(own["table"].dtypes) == list(df.dtypes)
    np.testing.assert_array_equal(own["big"], v["big"])
    assert np.shares_memory(viewed["small"], np.frombuffer(data, dtype=np.uint8))
    for a in (own["big"], own["small"], own["table"]["x_m"].to_numpy()):
        assert not np.shares_memory(a, np.frombuffer(data, dtype=np.uint8))
        assert not isinstance(_base(a), (bytearray, bytes, memoryview))


def test_a_cached_value_kept_in_part_does_not_keep_its_entry(tmp_path):
    """RunContext.cached_map with ``keep`` on a value found in the cache (a warm run: a
    fit kept without its data, a prediction without its band): the kept part's arrays
    are its own, not views of the entry -- 384 fits of a 64x campaign's warm run held
    every entry whole (110 MB) through a few small arrays each."""
    from torlab.parallel import SerialExecutor
    from torlab.progress import Progress
    from torlab.protocols.cache import ResultCache
    from torlab.protocols.context import RunContext

    tasks = [({"n": 4}, 4)]
    got = []
    for _ in range(2):  # computed, then from the cache
        c = ResultCache(tmp_path / "c")
        ctx = RunContext(lp=None, dest=None, cache=c, prog=Progress(),
                         executor=SerialExecutor())
        got.append(ctx.cached_map("parts", _big_and_small, tasks, keep=_small_only)[0])
        c.write_index()
    assert c.hits == 1
    np.testing.assert_array_equal(got[1], np.arange(4.0))
    assert not isinstance(_base(got[1]), (bytearray, bytes, memoryview))
    # the whole value, looked up as such: views of the entry's bytes (no copy)
    hit, whole = ResultCache(tmp_path / "c").lookup("parts", n=4)
    assert hit and isinstance(_base(whole["small"]), (bytearray, bytes, memoryview))


def _big_and_small(n: int) -> dict:  # module level: a task
    return {"big": np.zeros(100_000), "small": np.arange(float(n))}


def _small_only(_i: int, v: dict) -> np.ndarray:
    return v["small"]


def test_entry_stores_a_table_once_per_dtype_and_its_bytes_raw(tmp_path):
    """The arrays are raw bytes after the tree (no base64), 8-byte aligned; a table's float
    columns are one block."""
    c = _cache(tmp_path)
    df = pd.DataFrame({f"c{i}": np.linspace(0, 1, 1000) + i for i in range(6)})
    blob = c.dumps("k-1.tlc", "k", {"t": df, "same": df})
    _head, body, arrays = _split(blob)
    assert len(arrays) == 6 * 1000 * 8
    assert (len(blob) - len(arrays)) % 8 == 0  # the arrays start 8-byte aligned
    np.testing.assert_array_equal(np.frombuffer(arrays, "<f8")[:1000], df["c0"].to_numpy())
    tree = body["value"]["v"][0][1]
    assert tree["__t"] == "df" and len(tree["blocks"]) == 1 and tree["blocks"][0][0] == list(
        range(6))
    assert body["value"]["v"][1][1] == {"__t": "ref", "i": tree["def"]}


def test_json_tree_outside_an_entry_is_unchanged():
    """Outside an entry encode_value gives the JSON-only tree (base64 arrays) that
    digest_value hashes: its text fast paths give what the generic conversion gives."""
    from torlab.codec import _enc_column, _enc_index, encode_value

    s = pd.Series(["a", None, "c"], dtype="str")
    generic = s.astype(object).where(s.notna(), None).tolist()
    assert _enc_column(s) == {"ext": "str", "v": generic}
    ix = pd.Index(["p", "q"], dtype="str", name="cols")
    assert _enc_index(ix)["col"] == _enc_column(pd.Series(ix))
    tree = encode_value({"a": np.arange(3.0), "b": np.arange(3.0)})
    assert "b64" in tree["v"][0][1] and "ref" not in json.dumps(tree)


def test_a_list_of_plain_values_decodes_as_it_is_and_any_other_list_item_by_item():
    """A list whose items are all plain JSON values (a column of text) is taken as it is,
    as a list of its own; a list holding an encoded value anywhere decodes that value (a
    tuple, an array), and an unknown tag in it is refused as before."""
    from torlab.codec import BadEntry, decode_value

    tree = ["a", None, 1, 2.5, True, "é"]
    got = decode_value(tree)
    assert got == tree and got is not tree
    mixed = ["a", 1, {"__t": "tuple", "v": [1, ["x", 2]]}, [3, {"__t": "tuple", "v": []}]]
    assert decode_value(mixed) == ["a", 1, (1, ["x", 2]), [3, ()]]
    with pytest.raises(BadEntry, match="unknown tag"):
        decode_value(["a", "b", {"__t": "no-such-tag"}])
    with pytest.raises(BadEntry, match="not an encoded value"):
        decode_value(["a", {"x": 1}])


def test_plain_leaves_encode_as_the_generic_path_does(tmp_path, monkeypatch):
    """Plain leaves (None, bool, int, float, str) skip the search for shared objects; the
    entry is byte for byte the one the generic path writes, subclasses (numpy scalars, an
    IntEnum) included, and non-finite and big numbers keep their nodes."""
    import enum

    from torlab import codec

    class Level(enum.IntEnum):
        LOW = 1

    c = _cache(tmp_path)
    v = {"x": [None, True, False, 0, -7, 2 ** 60, 1.5, -0.0, math.nan, math.inf, "s", ""],
         "np": (np.float64(2.5), np.int64(3), np.bool_(True)), "table": _mixed_table(),
         "again": [1.0, 1.0], "lvl": 7}
    fast = c.dumps("k-1.tlc", "k", v)
    monkeypatch.setattr(codec, "_PLAIN", frozenset())
    assert c.dumps("k-1.tlc", "k", v) == fast
    assert codec.encode_value(Level.LOW) == 1  # an int subclass: the generic path
    monkeypatch.undo()
    assert codec.encode_value([2 ** 60, math.nan]) == [{"__t": "bigint", "v": str(2 ** 60)},
                                                       {"__t": "float", "v": "nan"}]


@pytest.mark.parametrize("breakage", ["offset past the end", "negative offset", "shape too big",
                                      "offset not a number", "no binary part",
                                      "block misses a column", "column twice",
                                      "block of the wrong height", "reference to nothing",
                                      "reference before its object", "object numbered twice"])
def test_signed_entry_with_a_broken_tree_is_refused(tmp_path, breakage):
    """Even with the right key (torlab's own entry, damaged), a tree pointing outside its
    data or at nothing is a BadEntry (recomputed), never an out-of-bounds read."""
    from torlab.codec import BadEntry

    c = _cache(tmp_path)
    df = pd.DataFrame({"a": [1.0, 2.0], "b": [3.0, 4.0], "n": np.array([1, 2])})
    arr = np.arange(4.0)
    _head, body, arrays = _split(c.dumps("k-1.tlc", "k", {"arr": arr, "df": df, "again": arr}))
    items = body["value"]["v"]
    nd, table, ref = items[0][1], items[1][1], items[2][1]
    if breakage == "offset past the end":
        nd["at"] = len(arrays) - 8
    elif breakage == "negative offset":
        nd["at"] = -8
    elif breakage == "shape too big":
        nd["shape"] = [10 ** 6]
    elif breakage == "offset not a number":
        nd["at"] = "0"
    elif breakage == "no binary part":
        arrays = b""
    elif breakage == "block misses a column":
        table["blocks"][0][0] = [0]
        table["blocks"][0][1]["shape"] = [1, 2]
    elif breakage == "column twice":
        table["blocks"][1][0] = [0]
    elif breakage == "block of the wrong height":
        table["blocks"][0][1]["shape"] = [2, 1]
    elif breakage == "reference to nothing":
        ref["i"] = 99
    elif breakage == "reference before its object":
        items[0], items[2] = items[2], items[0]
    elif breakage == "object numbered twice":
        table["def"] = nd["def"]
    with pytest.raises(BadEntry):
        c.loads("k-1.tlc", "k", _signed(c, body, arrays))


def test_version_1_entry_is_recomputed(tmp_path):
    """An entry of the earlier format (arrays base64 in the JSON) is not read: recomputed."""
    from torlab.codec import BadEntry, encode_value

    c = _cache(tmp_path)
    payload = json.dumps({"format": "torlab-cache", "version": 1, "entry": "k-1.tlc",
                          "kind": "k", "value": encode_value([1.0])}).encode()
    with pytest.raises(BadEntry, match="version"):
        c.loads("k-1.tlc", "k", f"torlab-cache 1 {c._mac(payload)}\n".encode() + payload)


def test_carried_over_cache_is_linked_but_never_written_through(tmp_path):
    """--force carries OUT/.cache over as hard links where it can: writing an entry anew
    (through the cache or the output folder) leaves the earlier results' file as it was,
    whether the run is aborted or committed."""
    from torlab.outputs import OutputDir
    from torlab.protocols.cache import ResultCache

    out = tmp_path / "out"
    with OutputDir(out) as d:
        d.write_bytes(".cache/a.tlc", b"earlier a")
        d.write_bytes(".cache/b.tlc", b"earlier b")
    a_old, b_old = out / ".cache" / "a.tlc", out / ".cache" / "b.tlc"
    d = OutputDir(out, force=True, keep=[".cache"])
    staged = d.staging / ".cache"
    linked = os.stat(staged / "a.tlc").st_ino == os.stat(a_old).st_ino
    rc = ResultCache(staged, register=d.path)
    rc._write("a.tlc", b"new a")  # an entry written again
    d.write_bytes(".cache/b.tlc", b"new b")
    assert (staged / "a.tlc").read_bytes() == b"new a"
    assert a_old.read_bytes() == b"earlier a" and b_old.read_bytes() == b"earlier b"
    d.abort()
    assert a_old.read_bytes() == b"earlier a" and b_old.read_bytes() == b"earlier b"
    d = OutputDir(out, force=True, keep=[".cache"])
    d.write_bytes(".cache/b.tlc", b"new b")
    d.commit()
    assert (out / ".cache" / "b.tlc").read_bytes() == b"new b"
    assert (out / ".cache" / "a.tlc").read_bytes() == b"earlier a"
    if hasattr(os, "link"):
        assert linked  # the same file system: linked, not copied


def test_warm_rerun_reads_the_binary_entries_it_wrote(tmp_path):
    """A re-run reuses every entry of the first run and gives the same report numbers."""
    import shutil

    from torlab.protocols.runner import run_protocol

    root = Path(__file__).resolve().parents[1]
    for f in sorted((root / "sample_data/hpt").glob("hpt_OFM1_*uL_25C.txt")):
        shutil.copy(f, tmp_path / f.name)
    (tmp_path / "p.yaml").write_text(
        "version: 1\nname: small\ndata:\n  hpt:\n    files: [hpt_*.txt]\n"
        "reports:\n  amount:\n    curve: interpolation\n")
    r1 = run_protocol(tmp_path / "p.yaml", tmp_path / "out")
    entries = sorted((tmp_path / "out" / ".cache").glob("*-*.tlc"))
    assert entries and all(e.read_bytes().startswith(b"torlab-cache 2 ") for e in entries)
    # the index of the entries, read once by the next run: a format of its own
    index = tmp_path / "out" / ".cache" / "index.tlc"
    assert index.read_bytes().startswith(b"torlab-cache-index ")
    r2 = run_protocol(tmp_path / "p.yaml", tmp_path / "out", force=True)
    assert (r2.cache_hits, r2.cache_misses) == (r1.cache_misses, 0)
    assert r2.summary["reports"] == r1.summary["reports"]
    assert r2.summary["data"] == r1.summary["data"]


def test_amount_probability_of_the_protocol_calls_the_crossing_verdicts(tmp_path):
    """``reports.amount.probability`` is the level of every verdict of the amount report,
    the crossings' too (they are cached with it in their key): a crossing whose probability
    of lying within the tested amounts is below it is "undetermined", one above it called."""
    import shutil

    from torlab.protocols.runner import run_protocol

    root = Path(__file__).resolve().parents[1]
    for f in sorted((root / "sample_data/hpt").glob("hpt_*_25C*.txt")):
        shutil.copy(f, tmp_path / f.name)
    prob = 0.99999999  # between the sample products' probabilities (all near 1)
    (tmp_path / "p.yaml").write_text(
        "version: 1\nname: small\ndata:\n  hpt:\n    files: [hpt_*.txt]\n"
        f"reports:\n  amount:\n    probability: {prob}\n")
    r = run_protocol(tmp_path / "p.yaml", tmp_path / "out")
    called = {}
    for name, row in r.summary["reports"]["amount"]["products"].items():
        p = row["p_crossing_in_range"]
        if p is None:
            continue
        assert (row["crossing_verdict"] == "undetermined") == (p < prob), name
        called[name] = p >= prob
    assert True in called.values() and False in called.values(), called


def _pair_task(x: int) -> tuple[dict, list]:  # module level: a task for the executor
    _pair_task.calls += 1
    return {"square": x * x}, [x, -x]


_pair_task.calls = 0


def _square(x: int) -> int:  # module level: a task for the executor
    return x * x


@dataclass
class _Draws:
    """Finish a deferred sum of squares: the whole value, its draws included."""

    n: int

    def __call__(self, results: list[int]) -> dict:
        return {"n": self.n, "sum": sum(results), "draws": list(results)}


def _deferred_sum(n: int) -> Any:
    """A task that leaves its squares to the executor (as a sampled band leaves its draws)."""
    from torlab.parallel import Deferred

    return Deferred(_square, list(range(n)), _Draws(n))


def _without_draws(_i: int, v: dict) -> dict:
    return {k: x for k, x in v.items() if k != "draws"}


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_result_finished_here_is_kept_as_a_stored_one(tmp_path, jobs):
    """RunContext.cached_map with ``keep``: a task whose work was deferred to the executor is
    finished in this process and stored there and then, whole (not held until the next
    map: the whole value, its draws, is not kept beyond the map); what the map returns for
    it is what ``keep`` makes of it, as for a result stored by its worker and one found in
    the cache."""
    from torlab.parallel import ProcessExecutor, SerialExecutor
    from torlab.progress import Progress
    from torlab.protocols.cache import ResultCache
    from torlab.protocols.context import RunContext

    ex = ProcessExecutor(jobs) if jobs > 1 else SerialExecutor()
    tasks = [({"n": 3}, 3), ({"n": 5}, 5)]
    try:
        got = []
        for _ in range(2):  # computed, then from the cache
            c = ResultCache(tmp_path / "c")
            ctx = RunContext(lp=None, dest=None, cache=c, prog=Progress(), executor=ex)
            got.append(ctx.cached_map("sums", _deferred_sum, tasks, keep=_without_draws))
            assert c._next.keys() >= {c.entry_name("sums", n=3), c.entry_name("sums", n=5)}
            c.write_index()
        assert got[0] == got[1] == [{"n": 3, "sum": 5}, {"n": 5, "sum": 30}]
        assert c.hits == 2
        assert ResultCache(tmp_path / "c").lookup("sums", n=5) == (
            True, {"n": 5, "sum": 30, "draws": [0, 1, 4, 9, 16]})  # the entry: whole
    finally:
        ex.close()


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_task_that_fills_two_entries(tmp_path, jobs):
    """RunContext.cached_map with ``also``: one computation stored as two entries, each
    found by a later run under its own kind and key (as another section looks for it); a
    later map takes the pair from the cache only when both are there."""
    from torlab.parallel import ProcessExecutor
    from torlab.progress import Progress
    from torlab.protocols.cache import ResultCache
    from torlab.protocols.context import RunContext

    ex = ProcessExecutor(jobs) if jobs > 1 else None
    tasks = [({"x": 3}, 3), ({"x": 4}, 4)]
    also = [("second", {"y": 3}), None]

    def run():  # one run: its own cache object over the folder, the index written at the end
        c = ResultCache(tmp_path / "c")
        ctx = RunContext(lp=None, dest=None, cache=c, prog=Progress(), executor=ex)
        got = ctx.cached_map("first", _pair_task, tasks, also=also)
        c.write_index()
        return got

    try:
        got = run()
        assert got[0] == ({"square": 9}, [3, -3]) and got[1] == ({"square": 16}, [4, -4])
        c = ResultCache(tmp_path / "c")
        assert c.lookup("first", x=3) == (True, {"square": 9})
        assert c.lookup("second", y=3) == (True, [3, -3])
        _pair_task.calls = 0
        assert run() == got
        assert _pair_task.calls == 0  # both from the cache
        (tmp_path / "c" / c.entry_name("second", y=3)).unlink()
        assert run() == got  # the first task computed again, both its entries stored
        assert (tmp_path / "c" / c.entry_name("second", y=3)).is_file()
        assert ResultCache(tmp_path / "c").lookup("second", y=3) == (True, [3, -3])
    finally:
        if ex is not None:
            ex.close()


def test_a_set_encodes_alike_in_every_process():
    """A set of text iterates in an order that changes from process to process (salted
    string hashes); its encoding, and so an entry's bytes and a content key, does not:
    two interpreters with different hash seeds give the same tree, and it reads back as
    the same set."""
    import subprocess
    import sys

    from torlab.codec import decode_value, encode_value

    code = ("import json; from torlab.codec import encode_value, digest_value; "
            "v = {'log_scale': frozenset({'mu_c1', 'mu_c2', 'L_mue', 'L_mup', 'a', 'b', 'c'}), "
            "'tags': {3, 1, 2, ('x', 1.5)}}; "
            "print(json.dumps(encode_value(v)), digest_value(v))")
    seen = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           check=True, env={**os.environ, "PYTHONHASHSEED": seed}).stdout
            for seed in ("1", "2", "3", "4")}
    assert len(seen) == 1
    tree = json.loads(seen.pop().rsplit(" ", 1)[0])
    assert decode_value(tree) == {"log_scale": frozenset({"mu_c1", "mu_c2", "L_mue", "L_mup",
                                                          "a", "b", "c"}),
                                  "tags": {3, 1, 2, ("x", 1.5)}}
    assert encode_value({"a", "b"}) == {"__t": "set", "v": ["a", "b"]}
