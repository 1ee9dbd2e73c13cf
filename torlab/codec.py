"""The value codec: torlab's results as data only (a JSON tree and raw array bytes).

:func:`encode_value` turns a value into a JSON-ready tree, :func:`decode_value` rebuilds
it, and :func:`digest_value` hashes it (a content key: the protocol cache's entries and
the figures' keys, :mod:`torlab.reports.render`).  What can be encoded:

numbers, strings, lists, tuples, sets (their elements in one order, whatever the
process: the same value, the same bytes and key), mappings, paths, dates, numpy scalars
and arrays of plain numeric or text dtypes, pandas tables and series built from such columns,
torlab's own result dataclasses (rebuilt field by field after checking that the stored
field names are exactly the class's: a changed class is a :class:`BadEntry`) and
torlab's pydantic models (the scenes).  No pickle, no ``eval``, no class named by the
data outside ``torlab``.  The tree names each array's dtype (plain kinds only: no
objects, no records) and shape.  A value that cannot be written as data (one holding a
function, say) raises :class:`NotCacheable`.

Two layouts of the arrays:

* :func:`encode_value` alone: the arrays' bytes in base64 inside the tree (JSON only);
  :func:`digest_value` hashes each array's bytes where that layout would carry them.
* :func:`encode_with_arrays`: the bytes apart, in a list of chunks, each array at a
  multiple of 8 bytes from the start of the binary part, which
  :func:`decode_with_arrays` bounds-checks before numpy views it (``np.frombuffer``:
  the bytes are read as numbers, never as objects).  A table's columns of one dtype
  are one 2-D block there, and an object met twice in a value (the same table in a
  reduction's ``tables`` and its ``detail``) is stored once and decoded as one object
  again.  The signed store of :mod:`torlab.protocols.cache` writes entries this way.

Nothing here reads or writes files.
"""

from __future__ import annotations

import base64
import contextvars
import dataclasses
import hashlib
import importlib
import json
import math
import re
from pathlib import Path
from typing import Any

__all__ = ["BadEntry", "NotCacheable", "decode_value", "decode_with_arrays", "digest_value",
           "encode_value", "encode_with_arrays", "finite_tree"]


class NotCacheable(Exception):
    """The value holds something that is not plain data (it is then not cached)."""


class BadEntry(Exception):
    """A stored entry does not match the schema (it is then recomputed)."""


_DTYPE_KINDS = set("biufcUMm")  # bool, int, uint, float, complex, text, datetime, timedelta
_TYPE_NAME = re.compile(r"^torlab(?:\.[a-z_][a-z0-9_]*)+:[A-Za-z_][A-Za-z0-9_]*$")
_PD_EXT_DTYPES = {"str", "string", "boolean", "Int64", "Int32", "Float64", "category"}


class _Sink:
    """Where :func:`encode_value` puts the arrays' bytes while an entry is written (its
    binary part), and the objects it has met (an object met again is a reference)."""

    def __init__(self) -> None:
        self.chunks: list[Any] = []
        self.size = 0
        #: id -> (the object, kept alive so that its id is not reused; its number or None
        #: while it is being encoded)
        self.seen: dict[int, tuple[Any, int | None]] = {}
        self.n = 0

    def add(self, a: Any) -> int:
        """Append a contiguous array's bytes (at a multiple of 8); its offset."""
        pad = -self.size % 8
        if pad:
            self.chunks.append(b"\0" * pad)
            self.size += pad
        at = self.size
        if a.nbytes:
            self.chunks.append(memoryview(a.reshape(-1).view("u1")))
            self.size += a.nbytes
        return at


_SINK: contextvars.ContextVar[_Sink | None] = contextvars.ContextVar("torlab_codec_sink",
                                                                    default=None)


#: the exact types :func:`_encode` writes as themselves or as one small node (never shared)
_PLAIN = frozenset({type(None), bool, int, float, str})


def _shareable(v: Any) -> bool:
    """Objects stored once however often a value holds them (arrays, tables, result classes)."""
    mod = type(v).__module__
    return (mod.startswith("numpy") and type(v).__name__ == "ndarray") or (
        mod.startswith("pandas") and type(v).__name__ in ("DataFrame", "Series")) or (
        dataclasses.is_dataclass(v) and not isinstance(v, type))


def encode_value(v: Any) -> Any:
    """A JSON-ready tree for ``v`` (see the module docstring); raises :class:`NotCacheable`."""
    if type(v) in _PLAIN:  # most of a value's leaves: no sharing to look for
        return _encode(v)
    sink = _SINK.get()
    if sink is not None and _shareable(v):
        seen = sink.seen.get(id(v))
        if seen is not None:
            if seen[1] is None:
                raise NotCacheable("a value that contains itself")
            return {"__t": "ref", "i": seen[1]}
        sink.seen[id(v)] = (v, None)
        tree = _encode(v)
        sink.seen[id(v)] = (v, sink.n)
        tree["def"] = sink.n
        sink.n += 1
        return tree
    return _encode(v)


def _encode(v: Any) -> Any:
    import numpy as np

    if v is None or isinstance(v, (bool, str)):
        return v
    if isinstance(v, int) and not isinstance(v, bool):
        return v if abs(v) < 2 ** 53 else {"__t": "bigint", "v": str(v)}
    if isinstance(v, float):
        return v if math.isfinite(v) else {"__t": "float", "v": repr(v)}
    if isinstance(v, np.generic):
        return {"__t": "np", "dtype": _dtype_str(np.asarray(v).dtype), "v": encode_value(v.item())}
    if isinstance(v, np.ndarray):
        return _enc_array(v)
    if isinstance(v, list):
        return [encode_value(x) for x in v]
    if isinstance(v, tuple):
        return {"__t": "tuple", "v": [encode_value(x) for x in v]}
    if isinstance(v, (set, frozenset)):
        return {"__t": "frozenset" if isinstance(v, frozenset) else "set",
                "v": _in_order([encode_value(x) for x in v])}
    if isinstance(v, dict):
        return {"__t": "dict", "v": [[encode_value(k), encode_value(x)] for k, x in v.items()]}
    if isinstance(v, Path):
        return {"__t": "path", "v": str(v)}
    return _enc_object(v)


def _in_order(trees: list[Any]) -> list[Any]:
    """A set's elements in one order whatever the process: a set of text iterates in an
    order that changes from process to process (Python salts the hashes of text), which
    would give one value different entry bytes and content keys from run to run.  Sorted
    by their JSON; left as they are where an element holds a shared object (its
    definition must come before references to it)."""
    keys = [json.dumps(t, sort_keys=True, separators=(",", ":")) for t in trees]
    if any('"def":' in k or '"__t":"ref"' in k for k in keys):
        return trees
    return [t for _, t in sorted(zip(keys, trees, strict=True), key=lambda kt: kt[0])]


def _enc_object(v: Any) -> Any:
    """Dates, pandas objects, torlab's result dataclasses and pydantic models."""
    import datetime as dt

    if isinstance(v, dt.datetime):
        return {"__t": "datetime", "v": v.isoformat()}
    if isinstance(v, dt.date):
        return {"__t": "date", "v": v.isoformat()}
    mod = type(v).__module__
    if mod.startswith("pandas"):
        return _enc_pandas(v)
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        name = _type_name(type(v))
        return {"__t": "dc", "type": name,
                "fields": {f.name: encode_value(getattr(v, f.name)) for f in dataclasses.fields(v)}}
    if hasattr(v, "model_dump") and hasattr(type(v), "model_validate"):  # pydantic (scenes)
        return {"__t": "model", "type": _type_name(type(v)),
                "v": encode_value(v.model_dump(mode="python"))}
    raise NotCacheable(type(v).__qualname__)


def _type_name(cls: type) -> str:
    name = f"{cls.__module__}:{cls.__qualname__}"
    if not _TYPE_NAME.match(name):
        raise NotCacheable(name)
    return name


def _dtype_str(dt: Any) -> str:
    if dt.kind not in _DTYPE_KINDS:
        raise NotCacheable(f"dtype {dt}")
    return dt.str


def _enc_array(a: Any) -> Any:
    import numpy as np

    if a.dtype.kind == "O":
        return {"__t": "ndo", "shape": list(a.shape), "v": [encode_value(x) for x in a.ravel()]}
    a = np.ascontiguousarray(a)
    if _DIGEST.get():  # digest_value: the bytes' hash stands for them
        return {"__t": "nd", "dtype": _dtype_str(a.dtype), "shape": list(a.shape),
                "sha256": hashlib.sha256(a.reshape(-1).view(np.uint8)).hexdigest()}
    sink = _SINK.get()
    if sink is not None:  # an entry: the bytes go to its binary part
        return {"__t": "nd", "dtype": _dtype_str(a.dtype), "shape": list(a.shape),
                "at": sink.add(a)}
    return {"__t": "nd", "dtype": _dtype_str(a.dtype), "shape": list(a.shape),
            "b64": base64.b64encode(a.tobytes()).decode("ascii")}


_DIGEST: contextvars.ContextVar[bool] = contextvars.ContextVar("torlab_codec_digest",
                                                               default=False)


def digest_value(v: Any) -> str:
    """SHA-256 (hex) of a value as :func:`encode_value` encodes it, each array's bytes hashed
    where the encoding would carry them as base64 (a content key without the cost of
    writing the data out); raises :class:`NotCacheable` like :func:`encode_value`."""
    token = _DIGEST.set(True)
    try:
        tree = encode_value(v)
    finally:
        _DIGEST.reset(token)
    blob = json.dumps(tree, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


def _enc_column(s: Any) -> Any:
    import numpy as np

    dt = s.dtype
    name = str(dt)
    if name in _PD_EXT_DTYPES:
        if name in ("str", "string"):  # the same list, without a where() pass
            vals = s.to_numpy(dtype=object, na_value=None).tolist()
        else:
            vals = s.astype(object).where(s.notna(), None).tolist()
        return {"ext": name, "v": encode_value(vals)}
    if isinstance(dt, np.dtype):
        return {"v": _enc_array(s.to_numpy())}
    if name.startswith("datetime64[") and "," in name:  # tz-aware
        raise NotCacheable(name)
    raise NotCacheable(f"pandas dtype {name}")


def _enc_index(ix: Any) -> Any:
    import pandas as pd

    if isinstance(ix, pd.RangeIndex):
        return {"range": [int(ix.start), int(ix.stop), int(ix.step)], "name": encode_value(ix.name)}
    if isinstance(ix, pd.MultiIndex):
        raise NotCacheable("MultiIndex")
    if str(ix.dtype) in ("str", "string"):  # column names: what _enc_column gives, directly
        vals = ix.to_numpy(dtype=object, na_value=None).tolist()
        return {"col": {"ext": str(ix.dtype), "v": encode_value(vals)},
                "name": encode_value(ix.name)}
    return {"col": _enc_column(pd.Series(ix)), "name": encode_value(ix.name)}


def _enc_pandas(v: Any) -> Any:
    import pandas as pd

    if isinstance(v, pd.DataFrame):
        if isinstance(v.columns, pd.MultiIndex):
            raise NotCacheable("MultiIndex columns")
        if _SINK.get() is not None:
            return _enc_frame_blocks(v)
        return {"__t": "df", "columns": _enc_index(v.columns),
                "data": [_enc_column(col) for _, col in v.items()],
                "index": _enc_index(v.index), "attrs": encode_value(dict(v.attrs))}
    if isinstance(v, pd.Series):
        return {"__t": "series", "name": encode_value(v.name), "data": _enc_column(v),
                "index": _enc_index(v.index)}
    if isinstance(v, pd.Timestamp):
        return {"__t": "timestamp", "v": v.isoformat()}
    raise NotCacheable(type(v).__qualname__)


def _enc_frame_blocks(v: Any) -> Any:
    """A table in an entry: its columns of each plain numpy dtype as one 2-D array
    ``(columns, rows)`` with their positions, the others (text, objects) one by one.
    The same order as :func:`_dec_pandas` reads them (columns, blocks, index, attrs)."""
    import numpy as np

    groups: dict[str, list[int]] = {}
    other: list[int] = []
    for j, dt in enumerate(v.dtypes):
        if isinstance(dt, np.dtype) and dt.kind in _DTYPE_KINDS:
            groups.setdefault(dt.str, []).append(j)
        else:
            other.append(j)
    columns = _enc_index(v.columns)
    blocks = [[js, _enc_array(np.ascontiguousarray(v.iloc[:, js].to_numpy().T))]
              for js in groups.values()]
    cols = [[j, _enc_column(v.iloc[:, j])] for j in other]
    return {"__t": "df", "columns": columns, "blocks": blocks, "cols": cols,
            "index": _enc_index(v.index), "attrs": encode_value(dict(v.attrs))}


class _Reading:
    """What :func:`decode_value` needs inside an entry: its binary part, the objects
    decoded so far by number (for references)."""

    def __init__(self, buf: Any, copy: bool = False) -> None:
        self.buf, self.copy = buf, copy
        self.objs: dict[int, Any] = {}


_READING: contextvars.ContextVar[_Reading | None] = contextvars.ContextVar(
    "torlab_codec_reading", default=None)


def decode_value(t: Any, *, depth: int = 0) -> Any:
    """Rebuild a value from :func:`encode_value`'s tree; raises :class:`BadEntry`."""
    v = _decode(t, depth)
    if type(t) is dict and "def" in t:  # an object later parts of the value refer to
        rd = _READING.get()
        k = t["def"]
        if rd is None or type(k) is not int or k in rd.objs:
            raise BadEntry("bad object number")
        rd.objs[k] = v
    return v


#: the JSON values that decode to themselves (a list of only these is taken as it is)
_PLAIN = frozenset({type(None), bool, int, float, str})


def _decode(t: Any, depth: int) -> Any:
    if depth > 200:
        raise BadEntry("nested too deeply")
    if t is None or isinstance(t, (bool, int, float, str)):
        return t
    d = depth + 1
    if isinstance(t, list):
        if all(type(x) in _PLAIN for x in t):  # a column of text: its values as they are
            return list(t)
        return [decode_value(x, depth=d) for x in t]
    if not isinstance(t, dict) or not isinstance(t.get("__t"), str):
        raise BadEntry("not an encoded value")
    tag = t["__t"]
    dec = _DECODERS.get(tag)
    if dec is None:
        raise BadEntry(f"unknown tag {tag!r}")
    try:
        return dec(t, d)
    except BadEntry:
        raise
    except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as e:
        raise BadEntry(f"{tag}: {type(e).__name__}: {e}") from None


def _dec_ref(t: dict, d: int) -> Any:
    rd = _READING.get()
    k = t["i"]
    if rd is None or type(k) is not int or k not in rd.objs:
        raise BadEntry("reference to an object not decoded before")
    return rd.objs[k]


def _dec_set(t: dict, d: int) -> Any:
    items = (_hashable(decode_value(x, depth=d)) for x in _list(t["v"]))
    return set(items) if t["__t"] == "set" else frozenset(items)


def _dec_float(t: dict, d: int) -> float:
    if t["v"] not in ("nan", "inf", "-inf"):
        raise BadEntry("bad float")
    return float(t["v"])


def _dec_bigint(t: dict, d: int) -> int:
    s = t["v"]
    if not isinstance(s, str) or len(s) > 400:
        raise BadEntry("bad integer")
    return int(s)


def _dec_np(t: dict, d: int) -> Any:
    import numpy as np

    return np.asarray(decode_value(t["v"], depth=d), dtype=_dtype(t["dtype"]))[()]


def _dec_time(t: dict, d: int) -> Any:
    if t["__t"] == "timestamp":
        import pandas as pd

        return pd.Timestamp(_str(t["v"]))
    import datetime as dt

    cls = dt.datetime if t["__t"] == "datetime" else dt.date
    return cls.fromisoformat(_str(t["v"]))


def _dec_model(t: dict, d: int) -> Any:
    cls = _resolve_type(t["type"])
    if not hasattr(cls, "model_validate"):
        raise BadEntry(f"{t['type']} is not a model")
    return cls.model_validate(decode_value(t["v"], depth=d))


def _list(v: Any) -> list:
    if not isinstance(v, list):
        raise BadEntry("expected a list")
    return v


def _str(v: Any) -> str:
    if not isinstance(v, str):
        raise BadEntry("expected a string")
    return v


def _hashable(v: Any) -> Any:
    if isinstance(v, list):
        raise BadEntry("a list cannot be a key")
    return v


def _dtype(s: Any) -> Any:
    import numpy as np

    if not isinstance(s, str) or len(s) > 32:
        raise BadEntry("bad dtype")
    dt = np.dtype(s)
    if dt.kind not in _DTYPE_KINDS or dt.fields is not None or dt.subdtype is not None:
        raise BadEntry(f"dtype {s!r} not allowed")
    return dt


def _shape(s: Any) -> tuple[int, ...]:
    if not isinstance(s, list) or len(s) > 32 or not all(
            isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in s):
        raise BadEntry("bad shape")
    return tuple(s)


def _dec_array(t: dict, d: int) -> Any:
    import numpy as np

    shape = _shape(t["shape"])
    n = math.prod(shape)
    if t["__t"] == "ndo":
        items = _list(t["v"])
        if len(items) != n:
            raise BadEntry("array size does not match its shape")
        out = np.empty(n, dtype=object)
        for i, x in enumerate(items):
            out[i] = decode_value(x, depth=d)
        return out.reshape(shape)
    dt = _dtype(t["dtype"])
    if "at" in t:  # in an entry's binary part: a view of the bytes read (or a copy)
        rd = _READING.get()
        at = t["at"]
        if rd is None or type(at) is not int or not 0 <= at <= len(rd.buf) - n * dt.itemsize:
            raise BadEntry("array outside the entry's data")
        if n == 0 or dt.itemsize == 0:
            return np.empty(shape, dtype=dt)
        a = np.frombuffer(rd.buf, dtype=dt, count=n, offset=at).reshape(shape)
        return a.copy() if rd.copy else a
    raw = base64.b64decode(_str(t["b64"]), validate=True)
    if len(raw) != n * dt.itemsize:
        raise BadEntry("array size does not match its shape")
    return np.frombuffer(raw, dtype=dt).reshape(shape).copy()


def _dec_column(c: Any, d: int) -> Any:
    import pandas as pd

    if not isinstance(c, dict):
        raise BadEntry("bad column")
    if "ext" in c:
        if c["ext"] not in _PD_EXT_DTYPES:
            raise BadEntry(f"pandas dtype {c['ext']!r} not allowed")
        vals = decode_value(c["v"], depth=d)
        if c["ext"] in ("str", "string") and type(vals) is list and all(
                type(x) is str for x in vals):  # text without gaps: the direct constructor
            return pd.Series(pd.array(vals, dtype=c["ext"]))
        return pd.Series(vals, dtype=object).astype(c["ext"])
    arr = _dec_array(c["v"], d)
    if arr.ndim != 1:
        raise BadEntry("a column must be one-dimensional")
    return pd.Series(arr)


def _dec_index(ix: Any, d: int) -> Any:
    import pandas as pd

    if not isinstance(ix, dict):
        raise BadEntry("bad index")
    name = decode_value(ix.get("name"), depth=d)
    if "range" in ix:
        a, b, s = (int(x) for x in _list(ix["range"]))
        return pd.RangeIndex(a, b, s, name=name)
    c = ix["col"]
    if isinstance(c, dict) and c.get("ext") in ("str", "string") and type(c.get("v")) is list \
            and all(type(x) is str for x in c["v"]):  # column names: the direct constructor
        return pd.Index(c["v"], dtype=c["ext"], name=name)
    return pd.Index(_dec_column(c, d), name=name)


def _dec_pandas(t: dict, d: int) -> Any:
    import pandas as pd

    if "blocks" in t:
        return _dec_frame_blocks(t, d)
    index = _dec_index(t["index"], d)
    if t["__t"] == "series":
        s = _dec_column(t["data"], d)
        if len(s) != len(index):
            raise BadEntry("series length does not match its index")
        s.index = index
        s.name = decode_value(t["name"], depth=d)
        return s
    cols = _dec_index(t["columns"], d)
    data = [_dec_column_values(c, d) for c in _list(t["data"])]
    if len(cols) != len(data) or any(len(v) != len(index) for v in data):
        raise BadEntry("table columns do not match")
    # one constructor call from the columns' values (numpy arrays or Series of an extension
    # dtype): much faster than joining one Series per column
    df = pd.DataFrame(dict(enumerate(data)), index=index, copy=False) if data \
        else pd.DataFrame(index=index)
    df.columns = cols
    return _with_attrs(df, t, d)


def _with_attrs(df: Any, t: dict, d: int) -> Any:
    """``df`` with the table attributes stored in ``t`` (a table's ``attrs``)."""
    attrs = decode_value(t.get("attrs", {"__t": "dict", "v": []}), depth=d)
    if not isinstance(attrs, dict):
        raise BadEntry("bad table attributes")
    df.attrs.update(attrs)
    return df


def _dec_frame_blocks(t: dict, d: int) -> Any:
    """A table stored by :func:`_enc_frame_blocks` (each dtype's columns one 2-D block)."""
    import numpy as np

    if t["__t"] != "df":
        raise BadEntry("blocks outside a table")
    cols = _dec_index(t["columns"], d)
    n_cols = len(cols)
    parts = []  # (values: 2-D (columns, rows) array or 1-D column, positions)
    for item in _list(t["blocks"]):
        js, node = _list(item)
        arr = _dec_array(node, d)
        parts.append((arr, _positions(js, n_cols)))
    for item in _list(t["cols"]):
        j, node = _list(item)
        parts.append((_dec_column_values(node, d), _positions([j], n_cols)))
    index = _dec_index(t["index"], d)
    n = len(index)
    for arr, pos in parts:
        want = (pos.size, n) if arr.ndim == 2 else (n,) if pos.size == 1 else None
        if arr.shape != want:
            raise BadEntry("table block does not match its columns and index")
    covered = np.sort(np.concatenate([pos for _, pos in parts])) if parts else np.zeros(0)
    if not np.array_equal(covered, np.arange(n_cols)):
        raise BadEntry("table blocks do not cover its columns once each")
    df = _frame_from_blocks(parts, index, cols)
    return _with_attrs(df, t, d)


def _positions(js: Any, n_cols: int) -> Any:
    import numpy as np

    if not isinstance(js, list) or not js or not all(
            type(j) is int and 0 <= j < n_cols for j in js):
        raise BadEntry("bad column positions")
    return np.asarray(js, dtype=np.intp)


def _frame_from_blocks(parts: list[tuple[Any, Any]], index: Any, cols: Any) -> Any:
    """A DataFrame from checked ``(block, positions)`` parts: with pandas' block constructor
    where it has one (pandas >= 3: no copy, no consolidation), else column by column."""
    import numpy as np
    import pandas as pd

    try:
        from pandas.api.internals import create_dataframe_from_blocks
    except ImportError:  # older pandas: the public constructor
        create_dataframe_from_blocks = None
    if create_dataframe_from_blocks is not None:
        blocks = [(a if a.ndim == 2 or not isinstance(a, np.ndarray) else a.reshape(1, -1), pos)
                  for a, pos in parts]
        return create_dataframe_from_blocks(blocks, index=index, columns=cols)
    data: dict[int, Any] = {}
    for a, pos in parts:
        if a.ndim == 2:
            data.update(zip(pos.tolist(), a, strict=True))
        else:
            data[int(pos[0])] = a
    if not data:
        df = pd.DataFrame(index=index)
    else:
        df = pd.DataFrame({j: data[j] for j in range(len(cols))}, index=index, copy=False)
    df.columns = cols
    return df


def _dec_column_values(c: Any, d: int) -> Any:
    """A column's values: a numpy array, or a Series for an extension dtype (no index)."""
    if isinstance(c, dict) and "ext" not in c and "v" in c:
        arr = _dec_array(c["v"], d)
        if arr.ndim != 1:
            raise BadEntry("a column must be one-dimensional")
        return arr
    return _dec_column(c, d).array


def _resolve_type(name: Any) -> type:
    """A class of torlab's own named ``module:Class`` (nothing outside ``torlab``)."""
    if not isinstance(name, str) or not _TYPE_NAME.match(name):
        raise BadEntry(f"type {name!r} not allowed")
    modname, qual = name.split(":")
    try:
        mod = importlib.import_module(modname)
    except ImportError:
        raise BadEntry(f"no module {modname}") from None
    cls = getattr(mod, qual, None)
    if not isinstance(cls, type) or cls.__module__ != modname:
        raise BadEntry(f"no class {name}")
    return cls


def _dec_dataclass(t: dict, d: int) -> Any:
    cls = _resolve_type(t["type"])
    if not dataclasses.is_dataclass(cls):
        raise BadEntry(f"{t['type']} is not a result class")
    stored = t["fields"]
    if not isinstance(stored, dict):
        raise BadEntry("bad fields")
    fields = dataclasses.fields(cls)
    if set(stored) != {f.name for f in fields}:  # the class changed: schema mismatch
        raise BadEntry(f"{t['type']}: fields differ from this torlab's")
    vals = {f.name: decode_value(stored[f.name], depth=d) for f in fields}
    obj = cls(**{f.name: vals[f.name] for f in fields if f.init})
    for f in fields:
        if not f.init:
            object.__setattr__(obj, f.name, vals[f.name])
    return obj


#: tag of an encoded value -> its decoder ``(tree, depth) -> value``
_DECODERS: dict[str, Any] = {
    "ref": _dec_ref,
    "dict": lambda t, d: {_hashable(decode_value(k, depth=d)): decode_value(x, depth=d)
                          for k, x in t["v"]},
    "tuple": lambda t, d: tuple(decode_value(x, depth=d) for x in _list(t["v"])),
    "set": _dec_set,
    "frozenset": _dec_set,
    "float": _dec_float,
    "bigint": _dec_bigint,
    "np": _dec_np,
    "nd": _dec_array,
    "ndo": _dec_array,
    "path": lambda t, d: Path(_str(t["v"])),
    "datetime": _dec_time,
    "date": _dec_time,
    "timestamp": _dec_time,
    "df": _dec_pandas,
    "series": _dec_pandas,
    "dc": _dec_dataclass,
    "model": _dec_model,
}


# ------------------------------------------------------------------------------ arrays apart
def encode_with_arrays(value: Any) -> tuple[Any, list[Any]]:
    """The tree of ``value`` with its arrays' bytes apart: ``(tree, chunks)``.

    ``b"".join(chunks)`` is the binary part: each array starts at a multiple of 8 bytes
    from its start (its offset is in the tree), shared objects are stored once.  Raises
    :class:`NotCacheable` like :func:`encode_value`.
    """
    sink = _Sink()
    token = _SINK.set(sink)
    try:
        tree = encode_value(value)
    finally:
        _SINK.reset(token)
    return tree, sink.chunks


def decode_with_arrays(tree: Any, binary: Any, copy: bool = False) -> Any:
    """Rebuild a value from :func:`encode_with_arrays`'s tree and binary part (a
    ``memoryview`` or buffer; its arrays are views of it, or with ``copy`` arrays of their
    own, so that a part of the value kept does not keep the whole buffer).  Raises
    :class:`BadEntry`."""
    token = _READING.set(_Reading(binary, copy))
    try:
        return decode_value(tree)
    except RecursionError:
        raise BadEntry("nested too deeply") from None
    finally:
        _READING.reset(token)


def finite_tree(obj: Any) -> Any:
    """``obj`` with every non-finite number (an unbounded interval's end, an undetermined
    estimate) replaced by None, in nested dicts, lists and tuples: what a result file
    may hold (JSON has no infinity; a report says "unbounded" where it finds None)."""
    import numpy as np

    def walk(o: Any) -> Any:
        if isinstance(o, dict):
            return {k: walk(v) for k, v in o.items()}
        if isinstance(o, (list, tuple)):
            return [walk(v) for v in o]
        if isinstance(o, (float, np.floating)):
            return float(o) if math.isfinite(o) else None
        return o

    return walk(obj)
