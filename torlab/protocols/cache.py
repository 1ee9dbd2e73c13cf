"""Re-run reuse: intermediate results cached in ``OUT/.cache/`` keyed by input hash + options.

A protocol run stores each expensive intermediate result (a reduced log, a fit,
a predicted curve) under a key made from the SHA-256 of its input files, the
options that produced it and the torlab version.  A re-run into the same output
folder (``--force``) carries the cache over (:class:`torlab.outputs.OutputDir`
``keep=``) and reuses every entry whose key still matches; entries a run did not
use are dropped, so the cache never grows beyond one run's results.

**Nothing in a cache can run code, and nothing in it is trusted.**  A results
folder may come from someone else, so an entry is

* *data only*: a JSON tree with a schema (:data:`FORMAT`, :data:`FORMAT_VERSION`)
  followed by the raw bytes of its arrays: numbers, strings, lists, mappings,
  numpy arrays of plain numeric or text dtypes, pandas tables built from such
  columns, and torlab's own result dataclasses, rebuilt field by field after
  checking that the stored field names are exactly the class's (a changed class
  is a schema mismatch and the entry is recomputed).  No pickle, no ``eval``, no
  class named by the file outside ``torlab``.  The tree names each array's dtype
  (plain kinds only: no objects, no records), shape and offset in the binary
  part, which is bounds-checked before numpy views it (``np.frombuffer``: the
  bytes are read as numbers, never as objects); a table's columns of one dtype
  are stored as one 2-D block, and an object met twice in a value (the same
  table in a reduction's ``tables`` and its ``detail``) is stored once and
  decoded as one object again.
* *authenticated*: the first line carries an HMAC-SHA256 of the rest of the file
  (tree and arrays) under a key kept outside the results folder
  (:func:`cache_key_file`: the user's configuration folder, created with mode
  0600 on first use); nothing of an entry is parsed before its HMAC matches.  An
  entry written by another user or machine, or edited, fails the check and is
  recomputed -- so a crafted ``.cache`` can neither run code nor feed wrong
  numbers into a report.  Without a writable configuration folder the key lives
  only for one process (entries are then never reused across runs).

An entry is ``torlab-cache 2 <hmac>\n<JSON tree>\n<array bytes>`` (the JSON line is
padded with spaces so that the arrays start at a multiple of 8 bytes).  Version 1
entries (the arrays base64 in the JSON) are recomputed.  :func:`encode_value` and
:func:`decode_value` outside an entry give and take a JSON-only tree (arrays in
base64), which :func:`digest_value` hashes.

A value that cannot be written as data (e.g. one holding a function) is
simply not cached.
"""

from __future__ import annotations

import base64
import contextlib
import contextvars
import dataclasses
import hashlib
import hmac
import importlib
import json
import math
import os
import re
import secrets
import sys
import time
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any, TypeVar

__all__ = ["CACHE_DIR", "FORMAT", "FORMAT_VERSION", "FigureStore", "ResultCache", "cache_key_file",
           "decode_value", "digest_value", "encode_value", "file_sha256"]

CACHE_DIR = ".cache"
FORMAT = "torlab-cache"
#: bump when the encoding changes; older entries are then recomputed
FORMAT_VERSION = 2
#: the version in a cached figure's HMAC line (``fig-<key>.png.mac``; the figure is the file)
FIGURE_FORMAT_VERSION = 1
SUFFIX = ".tlc"
#: entries larger than this are not read (a crafted folder must not exhaust memory)
MAX_ENTRY_BYTES = 512 << 20
T = TypeVar("T")


@cache
def _sha(path: str, mtime_ns: int, size: int) -> str:
    from torlab.outputs import sha256_file

    return sha256_file(path)


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file (memoised on path, modification time and size)."""
    st = Path(path).stat()
    return _sha(str(Path(path).resolve()), st.st_mtime_ns, st.st_size)


# ------------------------------------------------------------------------------ the key
def cache_key_file() -> Path:
    """Where the cache's HMAC key is kept: ``$TORLAB_CONFIG_DIR``, else the user's
    configuration folder (``$XDG_CONFIG_HOME/torlab`` or ``~/.config/torlab``;
    ``%APPDATA%\\torlab`` on Windows), file ``cache-key``."""
    env = os.environ.get("TORLAB_CONFIG_DIR")
    if env:
        base = Path(env)
    elif sys.platform == "win32" and os.environ.get("APPDATA"):
        base = Path(os.environ["APPDATA"]) / "torlab"
    else:
        xdg = os.environ.get("XDG_CONFIG_HOME")
        base = (Path(xdg) if xdg else Path.home() / ".config") / "torlab"
    return base / "cache-key"


_PROCESS_KEY = secrets.token_bytes(32)


def _load_key() -> tuple[bytes, bool]:
    """``(key, persistent)``: the user's key (created on first use) or a per-process one."""
    p = cache_key_file()
    for _ in range(2):
        try:
            with open(p, "rb") as f:
                key = bytes.fromhex(f.read(200).decode("ascii").strip())
            if len(key) >= 16:
                return key, True
            return _PROCESS_KEY, False  # damaged: do not trust, do not overwrite silently
        except FileNotFoundError:
            pass
        except (OSError, ValueError, UnicodeDecodeError):
            return _PROCESS_KEY, False
        try:
            p.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(p, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except FileExistsError:
            continue  # another process created it just now: read theirs
        except OSError:
            return _PROCESS_KEY, False
        with os.fdopen(fd, "w", encoding="ascii") as f:
            f.write(secrets.token_hex(32) + "\n")
    return _PROCESS_KEY, False


# ------------------------------------------------------------------------------ encoding
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


_SINK: contextvars.ContextVar[_Sink | None] = contextvars.ContextVar("torlab_cache_sink",
                                                                    default=None)


def _shareable(v: Any) -> bool:
    """Objects stored once however often a value holds them (arrays, tables, result classes)."""
    mod = type(v).__module__
    return (mod.startswith("numpy") and type(v).__name__ == "ndarray") or (
        mod.startswith("pandas") and type(v).__name__ in ("DataFrame", "Series")) or (
        dataclasses.is_dataclass(v) and not isinstance(v, type))


def encode_value(v: Any) -> Any:
    """A JSON-ready tree for ``v`` (see the module docstring); raises :class:`NotCacheable`."""
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
                "v": [encode_value(x) for x in v]}
    if isinstance(v, dict):
        return {"__t": "dict", "v": [[encode_value(k), encode_value(x)] for k, x in v.items()]}
    if isinstance(v, Path):
        return {"__t": "path", "v": str(v)}
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


_DIGEST: contextvars.ContextVar[bool] = contextvars.ContextVar("torlab_cache_digest",
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

    def __init__(self, buf: Any) -> None:
        self.buf = buf
        self.objs: dict[int, Any] = {}


_READING: contextvars.ContextVar[_Reading | None] = contextvars.ContextVar(
    "torlab_cache_reading", default=None)


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


def _decode(t: Any, depth: int) -> Any:
    if depth > 200:
        raise BadEntry("nested too deeply")
    if t is None or isinstance(t, (bool, int, float, str)):
        return t
    d = depth + 1
    if isinstance(t, list):
        return [decode_value(x, depth=d) for x in t]
    if not isinstance(t, dict) or not isinstance(t.get("__t"), str):
        raise BadEntry("not an encoded value")
    tag = t["__t"]
    try:
        if tag == "ref":
            rd = _READING.get()
            k = t["i"]
            if rd is None or type(k) is not int or k not in rd.objs:
                raise BadEntry("reference to an object not decoded before")
            return rd.objs[k]
        if tag == "dict":
            return {_hashable(decode_value(k, depth=d)): decode_value(x, depth=d)
                    for k, x in t["v"]}
        if tag == "tuple":
            return tuple(decode_value(x, depth=d) for x in _list(t["v"]))
        if tag in ("set", "frozenset"):
            items = (_hashable(decode_value(x, depth=d)) for x in _list(t["v"]))
            return set(items) if tag == "set" else frozenset(items)
        if tag == "float":
            if t["v"] not in ("nan", "inf", "-inf"):
                raise BadEntry("bad float")
            return float(t["v"])
        if tag == "bigint":
            s = t["v"]
            if not isinstance(s, str) or len(s) > 400:
                raise BadEntry("bad integer")
            return int(s)
        if tag == "np":
            import numpy as np

            return np.asarray(decode_value(t["v"], depth=d), dtype=_dtype(t["dtype"]))[()]
        if tag in ("nd", "ndo"):
            return _dec_array(t, d)
        if tag == "path":
            return Path(_str(t["v"]))
        if tag in ("datetime", "date", "timestamp"):
            import datetime as dt

            if tag == "timestamp":
                import pandas as pd

                return pd.Timestamp(_str(t["v"]))
            cls = dt.datetime if tag == "datetime" else dt.date
            return cls.fromisoformat(_str(t["v"]))
        if tag in ("df", "series"):
            return _dec_pandas(t, d)
        if tag == "dc":
            return _dec_dataclass(t, d)
        if tag == "model":
            cls = _resolve_type(t["type"])
            if not hasattr(cls, "model_validate"):
                raise BadEntry(f"{t['type']} is not a model")
            return cls.model_validate(decode_value(t["v"], depth=d))
    except BadEntry:
        raise
    except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as e:
        raise BadEntry(f"{tag}: {type(e).__name__}: {e}") from None
    raise BadEntry(f"unknown tag {tag!r}")


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
    if "at" in t:  # in an entry's binary part: a view of the bytes read (no copy)
        rd = _READING.get()
        at = t["at"]
        if rd is None or type(at) is not int or not 0 <= at <= len(rd.buf) - n * dt.itemsize:
            raise BadEntry("array outside the entry's data")
        if n == 0 or dt.itemsize == 0:
            return np.empty(shape, dtype=dt)
        return np.frombuffer(rd.buf, dtype=dt, count=n, offset=at).reshape(shape)
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


# ------------------------------------------------------------------------------ the cache
class ResultCache:
    """Authenticated, data-only intermediate results in a folder (see the module docstring).

    Parameters
    ----------
    folder
        Where entries are read from and written to; ``None`` disables caching.
    register
        Called with the entry's relative name (``.cache/<key>.tlc``) when one is
        written or reused, so the output folder lists it in its manifest; returns
        the path to write to.

    Attributes
    ----------
    hits, misses
        Entries reused and computed.
    io_seconds, compute_seconds
        Time spent on reading and writing entries, and computing the missing ones
        (through :meth:`get_or_compute`).
    rejected
        Stored entries that failed the authentication or schema check (recomputed).
    not_cacheable
        Kinds whose values could not be stored as data.
    """

    def __init__(self, folder: Path | None, register: Callable[[str], Path] | None = None) -> None:
        self.folder = folder
        self.register = register
        self.hits = 0
        self.misses = 0
        self.rejected = 0
        self.not_cacheable: set[str] = set()
        self.used: set[str] = set()
        self._key: bytes | None = None
        self.persistent_key = False
        #: seconds spent reading, checking, encoding and writing entries; computing misses
        self.io_seconds = 0.0
        self.compute_seconds = 0.0
        self._figures: FigureStore | None = None

    @property
    def secret(self) -> bytes:
        if self._key is None:
            self._key, self.persistent_key = _load_key()
        return self._key

    @staticmethod
    def key(kind: str, **parts: Any) -> str:
        """Key of an entry: ``kind``, the torlab version and ``parts`` (JSON, sorted)."""
        from torlab import __version__

        blob = json.dumps({"kind": kind, "torlab": __version__, **parts}, sort_keys=True,
                          default=_jsonable)
        return f"{kind}-{hashlib.sha256(blob.encode()).hexdigest()[:32]}"

    def _mac(self, payload: bytes) -> str:
        return hmac.new(self.secret, payload, hashlib.sha256).hexdigest()

    def dumps(self, name: str, kind: str, value: Any) -> bytes:
        """The bytes of an entry: a header line with the HMAC, the JSON tree (one line,
        padded to a multiple of 8 bytes), the arrays' bytes."""
        from torlab import __version__

        sink = _Sink()
        token = _SINK.set(sink)
        try:
            tree = encode_value(value)
        finally:
            _SINK.reset(token)
        body = {"format": FORMAT, "version": FORMAT_VERSION, "torlab": __version__,
                "entry": name, "kind": kind, "value": tree}
        text = json.dumps(body, separators=(",", ":"), allow_nan=False).encode("utf-8")
        head_len = len(FORMAT) + len(str(FORMAT_VERSION)) + 64 + 3
        text += b" " * (-(head_len + len(text) + 1) % 8) + b"\n"
        payload = b"".join([text, *sink.chunks])
        return f"{FORMAT} {FORMAT_VERSION} {self._mac(payload)}\n".encode("ascii") + payload

    def loads(self, name: str, kind: str, data: bytes | bytearray) -> Any:
        """The value of an entry; :class:`BadEntry` if it fails any check.  Its arrays are
        views of ``data`` (writable when ``data`` is a bytearray; bytes are copied once)."""
        from torlab import __version__

        if not isinstance(data, bytearray):
            data = bytearray(data)
        nl = data.find(b"\n", 0, 200)
        parts = bytes(data[:nl]).decode("ascii", "replace").split(" ") if nl > 0 else []
        if len(parts) != 3 or parts[0] != FORMAT or parts[1] != str(FORMAT_VERSION):
            raise BadEntry("not a torlab cache entry of this version")
        view = memoryview(data)
        if not hmac.compare_digest(parts[2], self._mac(view[nl + 1:])):
            raise BadEntry("authentication failed (written elsewhere or changed)")
        end = data.find(b"\n", nl + 1)
        if end < 0:
            raise BadEntry("no end of the entry's tree")
        try:
            body = json.loads(view[nl + 1:end].tobytes())
        except (ValueError, RecursionError):
            raise BadEntry("payload is not JSON") from None
        if not isinstance(body, dict) or body.get("entry") != name or body.get("kind") != kind \
                or body.get("torlab") != __version__:
            raise BadEntry("entry header does not match")
        token = _READING.set(_Reading(view[end + 1:]))
        try:
            return decode_value(body.get("value"))
        except RecursionError:
            raise BadEntry("nested too deeply") from None
        finally:
            _READING.reset(token)

    def _read(self, p: Path) -> bytearray | None:
        from torlab.errors import TorlabInputError
        from torlab.outputs import open_regular

        try:
            with open_regular(p) as f:
                size = os.fstat(f.fileno()).st_size
                if size > MAX_ENTRY_BYTES:
                    return None
                data = bytearray(size + 1)  # one more: a file that grew is seen whole
                n = f.readinto(data)
                if n > size:
                    rest = f.read(MAX_ENTRY_BYTES + 1 - n)
                    data = data[:n] + rest
                    if len(data) > MAX_ENTRY_BYTES:
                        return None
                else:
                    del data[n:]
        except (TorlabInputError, OSError):
            return None
        return data

    def lookup(self, kind: str, **parts: Any) -> tuple[bool, Any]:
        """``(True, value)`` for a valid stored entry of ``(kind, parts)``, else ``(False, None)``.

        The entry counts as used (kept by :meth:`prune`); a hit counts in :attr:`hits`.
        """
        if self.folder is None:
            return False, None
        t0 = time.perf_counter()
        try:
            name = f"{self.key(kind, **parts)}{SUFFIX}"
            self.used.add(name)
            p = self.folder / name
            if not (p.exists() or p.is_symlink()):
                return False, None
            data = self._read(p)
            try:
                if data is None:
                    raise BadEntry("unreadable")
                value = self.loads(name, kind, data)
            except BadEntry:
                self.rejected += 1
                with contextlib.suppress(OSError):
                    p.unlink()
                return False, None
            self.hits += 1
            if self.register is not None:
                self.register(f"{CACHE_DIR}/{name}")
            return True, value
        finally:
            self.io_seconds += time.perf_counter() - t0

    def store(self, kind: str, value: Any, **parts: Any) -> None:
        """Store ``value`` under ``(kind, parts)`` (silently not, if it is not plain data)."""
        if self.folder is None:
            return
        t0 = time.perf_counter()
        try:
            name = f"{self.key(kind, **parts)}{SUFFIX}"
            try:
                blob = self.dumps(name, kind, value)
            except (NotCacheable, ValueError, TypeError):
                self.not_cacheable.add(kind)
                self.used.discard(name)
                return
            self.used.add(name)
            self._write(name, blob)
        finally:
            self.io_seconds += time.perf_counter() - t0

    def _write(self, name: str, blob: bytes) -> None:
        from torlab.outputs import _writing

        p = self.folder / name  # type: ignore[operator]
        target = self.register(f"{CACHE_DIR}/{name}") if self.register is not None else p
        with _writing(target):
            target.parent.mkdir(parents=True, exist_ok=True)
            # a new file, never written through: the carried-over cache's files may be hard
            # links to the earlier results' (torlab.outputs.OutputDir keep=)
            with contextlib.suppress(FileNotFoundError):
                target.unlink()
            target.write_bytes(blob)

    def get_or_compute(self, kind: str, compute: Callable[[], T], **parts: Any) -> T:
        """The cached value for ``(kind, parts)``, or ``compute()`` stored under it."""
        hit, value = self.lookup(kind, **parts)
        if hit:
            return value
        self.misses += 1
        t0 = time.perf_counter()
        value = compute()
        self.compute_seconds += time.perf_counter() - t0
        self.store(kind, value, **parts)
        return value

    @property
    def figures(self) -> FigureStore:
        """The cached figures of this cache (:class:`FigureStore`)."""
        if self._figures is None:
            self._figures = FigureStore(self)
        return self._figures

    def prune(self) -> int:
        """Delete everything in the folder this run did not use (old entries, other files)."""
        if self.folder is None or not self.folder.is_dir():
            return 0
        import shutil

        n = 0
        for p in self.folder.iterdir():
            if p.name in self.used:
                continue
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p, ignore_errors=True)
            else:
                with contextlib.suppress(OSError):
                    p.unlink()
            n += 1
        return n


class FigureStore:
    """Cached figures of a :class:`ResultCache`: ``fig-<key>.<format>`` files, authenticated.

    A cached figure is the PNG/SVG/PDF file itself, named by its content key
    (:func:`torlab.reports.render.figure_key`: the hash of the plotted data and
    style), next to a one-line sidecar ``fig-<key>.<format>.mac`` holding the
    HMAC-SHA256 of the file's bytes under the cache's key.  A figure whose
    sidecar is missing or does not match (written elsewhere, edited) is drawn
    again, so a crafted ``.cache`` cannot put a wrong picture into a report.

    Attributes
    ----------
    hits, misses
        Figures reused and not found.
    """

    def __init__(self, cache: ResultCache) -> None:
        self.cache = cache
        self.hits = 0
        self.misses = 0

    def _mac(self, name: str, data: bytes) -> str:
        return hmac.new(self.cache.secret, f"{FORMAT} figure {name}\n".encode() + data,
                        hashlib.sha256).hexdigest()

    def get(self, key: str, fmt: str) -> bytes | None:
        """The cached bytes of figure ``key`` in ``fmt``, or None."""
        c = self.cache
        if c.folder is None:
            return None
        t0 = time.perf_counter()
        try:
            name = f"fig-{key}.{fmt}"
            p = c.folder / name
            if not p.exists():
                self.misses += 1
                return None
            data, mac = c._read(p), c._read(p.with_name(name + ".mac"))
            head = bytes(mac or b"").decode("ascii", "replace").split()
            ok = data is not None and len(head) == 3 and head[0] == FORMAT \
                and head[1] == str(FIGURE_FORMAT_VERSION) and hmac.compare_digest(
                    head[2], self._mac(name, data))
            if not ok:
                c.rejected += 1
                for q in (p, p.with_name(name + ".mac")):
                    with contextlib.suppress(OSError):
                        q.unlink()
                self.misses += 1
                return None
            c.used.update((name, name + ".mac"))
            if c.register is not None:
                c.register(f"{CACHE_DIR}/{name}")
                c.register(f"{CACHE_DIR}/{name}.mac")
            self.hits += 1
            return bytes(data)  # type: ignore[arg-type]
        finally:
            c.io_seconds += time.perf_counter() - t0

    def put(self, key: str, fmt: str, data: bytes) -> None:
        """Store figure ``key`` in ``fmt``."""
        c = self.cache
        if c.folder is None:
            return
        t0 = time.perf_counter()
        try:
            name = f"fig-{key}.{fmt}"
            c.used.update((name, name + ".mac"))
            c._write(name, data)
            c._write(name + ".mac", f"{FORMAT} {FIGURE_FORMAT_VERSION} {self._mac(name, data)}\n"
                     .encode("ascii"))
        finally:
            c.io_seconds += time.perf_counter() - t0


def _jsonable(o: Any) -> Any:
    import numpy as np

    if isinstance(o, Path):
        return str(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    return repr(o)
