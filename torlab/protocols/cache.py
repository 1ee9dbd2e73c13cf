"""Re-run reuse: intermediate results cached in ``OUT/.cache/`` keyed by input hash + options.

A protocol run stores each expensive intermediate result (a reduced log, a fit,
a predicted curve) under a key made from the SHA-256 of its input files, the
options that produced it and the torlab version.  A re-run into the same output
folder (``--force``) carries the cache over (:class:`torlab.outputs.OutputDir`
``keep=``) and reuses every entry whose key still matches; entries a run did not
use are dropped, so the cache never grows beyond one run's results.

**Nothing in a cache can run code, and nothing in it is trusted.**  A results
folder may come from someone else, so an entry is

* *data only*: JSON with a schema (:data:`FORMAT`, :data:`FORMAT_VERSION`):
  numbers, strings, lists, mappings, numpy arrays of plain numeric or text
  dtypes (raw bytes, base64), pandas tables built from such columns, and
  torlab's own result dataclasses, rebuilt field by field after checking that
  the stored field names are exactly the class's (a changed class is a schema
  mismatch and the entry is recomputed).  No pickle, no ``eval``, no class
  named by the file outside ``torlab``.
* *authenticated*: the first line carries an HMAC-SHA256 of the payload under a
  key kept outside the results folder (:func:`cache_key_file`: the user's
  configuration folder, created with mode 0600 on first use).  An entry written
  by another user or machine, or edited, fails the check and is recomputed --
  so a crafted ``.cache`` can neither run code nor feed wrong numbers into a
  report.  Without a writable configuration folder the key lives only for one
  process (entries are then never reused across runs).

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
FORMAT_VERSION = 1
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


def encode_value(v: Any) -> Any:
    """A JSON-ready tree for ``v`` (see the module docstring); raises :class:`NotCacheable`."""
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
    return {"col": _enc_column(pd.Series(ix)), "name": encode_value(ix.name)}


def _enc_pandas(v: Any) -> Any:
    import pandas as pd

    if isinstance(v, pd.DataFrame):
        if isinstance(v.columns, pd.MultiIndex):
            raise NotCacheable("MultiIndex columns")
        return {"__t": "df", "columns": _enc_index(v.columns),
                "data": [_enc_column(v.iloc[:, j]) for j in range(v.shape[1])],
                "index": _enc_index(v.index), "attrs": encode_value(dict(v.attrs))}
    if isinstance(v, pd.Series):
        return {"__t": "series", "name": encode_value(v.name), "data": _enc_column(v),
                "index": _enc_index(v.index)}
    if isinstance(v, pd.Timestamp):
        return {"__t": "timestamp", "v": v.isoformat()}
    raise NotCacheable(type(v).__qualname__)


def decode_value(t: Any, *, depth: int = 0) -> Any:
    """Rebuild a value from :func:`encode_value`'s tree; raises :class:`BadEntry`."""
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
        return pd.Series(decode_value(c["v"], depth=d), dtype=object).astype(c["ext"])
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
    return pd.Index(_dec_column(ix["col"], d), name=name)


def _dec_pandas(t: dict, d: int) -> Any:
    import pandas as pd

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
    attrs = decode_value(t.get("attrs", {"__t": "dict", "v": []}), depth=d)
    if not isinstance(attrs, dict):
        raise BadEntry("bad table attributes")
    df.attrs.update(attrs)
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
        """The bytes of an entry (header line with the HMAC, then the JSON payload)."""
        from torlab import __version__

        body = {"format": FORMAT, "version": FORMAT_VERSION, "torlab": __version__,
                "entry": name, "kind": kind, "value": encode_value(value)}
        payload = json.dumps(body, separators=(",", ":"), allow_nan=False).encode("utf-8")
        return f"{FORMAT} {FORMAT_VERSION} {self._mac(payload)}\n".encode("ascii") + payload

    def loads(self, name: str, kind: str, data: bytes) -> Any:
        """The value of an entry; :class:`BadEntry` if it fails any check."""
        from torlab import __version__

        head, sep, payload = data.partition(b"\n")
        parts = head.decode("ascii", "replace").split(" ")
        if not sep or len(parts) != 3 or parts[0] != FORMAT or parts[1] != str(FORMAT_VERSION):
            raise BadEntry("not a torlab cache entry of this version")
        if not hmac.compare_digest(parts[2], self._mac(payload)):
            raise BadEntry("authentication failed (written elsewhere or changed)")
        try:
            body = json.loads(payload)
        except (ValueError, RecursionError):
            raise BadEntry("payload is not JSON") from None
        if not isinstance(body, dict) or body.get("entry") != name or body.get("kind") != kind \
                or body.get("torlab") != __version__:
            raise BadEntry("entry header does not match")
        try:
            return decode_value(body.get("value"))
        except RecursionError:
            raise BadEntry("nested too deeply") from None

    def _read(self, p: Path) -> bytes | None:
        from torlab.errors import TorlabInputError
        from torlab.outputs import open_regular

        try:
            with open_regular(p) as f:
                data = f.read(MAX_ENTRY_BYTES + 1)
        except (TorlabInputError, OSError):
            return None
        return None if len(data) > MAX_ENTRY_BYTES else data

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
            head = (mac or b"").decode("ascii", "replace").split()
            ok = data is not None and len(head) == 3 and head[0] == FORMAT \
                and head[1] == str(FORMAT_VERSION) and hmac.compare_digest(
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
            return data
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
            c._write(name + ".mac", f"{FORMAT} {FORMAT_VERSION} {self._mac(name, data)}\n"
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
