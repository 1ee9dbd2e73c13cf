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
  followed by the raw bytes of its arrays, as :func:`torlab.codec.encode_with_arrays`
  writes them (numbers, text, arrays, tables and torlab's own result classes; no
  pickle, no ``eval``, no class named by the file outside ``torlab``; a changed
  result class is a schema mismatch and the entry is recomputed);
* *authenticated*: the first line carries an HMAC-SHA256 of the rest of the file
  (tree and arrays) under a key kept outside the results folder
  (:func:`cache_key_file`: the user's configuration folder, created with mode
  0600 on first use); nothing of an entry is parsed before its HMAC matches.  An
  entry written by another user or machine, or edited, fails the check and is
  recomputed -- so a crafted ``.cache`` can neither run code nor feed wrong
  numbers into a report.  Without a writable configuration folder the key lives
  only for one process (entries are then never reused across runs); so it does, with
  one warning, when the key file cannot be trusted (:func:`_load_key`: a link, another
  user's or a world-readable file, a FIFO, a damaged or constant key).

An entry is ``torlab-cache 2 <hmac>\n<JSON tree>\n<array bytes>`` (the JSON line is
padded with spaces so that the arrays start at a multiple of 8 bytes).  Version 1
entries (the arrays base64 in the JSON) are recomputed.

A value that cannot be written as data (e.g. one holding a function) is
simply not cached.
"""

from __future__ import annotations

import contextlib
import hashlib
import hmac
import json
import os
import secrets
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from torlab.codec import BadEntry, NotCacheable, decode_with_arrays, encode_with_arrays

__all__ = ["CACHE_DIR", "FORMAT", "FORMAT_VERSION", "FigureStore", "ResultCache",
           "cache_key_file"]

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


# ------------------------------------------------------------------------------ the key
def cache_key_file() -> Path:
    """Where the cache's HMAC key is kept: ``$TORLAB_CONFIG_DIR``, else the user's
    configuration folder (``$XDG_CONFIG_HOME/torlab`` or ``~/.config/torlab``;
    ``%APPDATA%\\torlab`` on Windows), file ``cache-key``.  A relative
    ``$TORLAB_CONFIG_DIR`` or ``$XDG_CONFIG_HOME`` is ignored (the XDG rule: a relative
    path would put the key under whatever folder torlab runs in)."""
    env = os.environ.get("TORLAB_CONFIG_DIR")
    if env and os.path.isabs(env):
        base = Path(env)
    elif sys.platform == "win32" and os.environ.get("APPDATA"):
        base = Path(os.environ["APPDATA"]) / "torlab"
    else:
        xdg = os.environ.get("XDG_CONFIG_HOME")
        base = (Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".config") / "torlab"
    return base / "cache-key"


_PROCESS_KEY = secrets.token_bytes(32)
#: the key's length (bytes); torlab writes it as 64 hexadecimal digits and a newline
KEY_BYTES = 32


class _Untrusted(Exception):
    """The key file exists but may not be used (the reason is the message)."""


def _load_key() -> tuple[bytes, bool]:
    """``(key, persistent)``: the user's key (created on first use) or a per-process one.

    A key file is used only when it can be trusted: a regular file (not a link, FIFO or
    folder), the user's own, readable and writable by the user alone (mode 0600), in a
    folder no one else may write to, holding :data:`KEY_BYTES` random bytes as
    hexadecimal digits (not a constant such as all zeros).  Otherwise the run uses a key
    of its own (nothing is reused across runs, the documented fallback) and says why in
    one warning; a file that is there is never overwritten.
    """
    import warnings

    from torlab.errors import TorlabWarning

    for env in ("TORLAB_CONFIG_DIR", "XDG_CONFIG_HOME"):
        v = os.environ.get(env)
        if v and not os.path.isabs(v):
            warnings.warn(TorlabWarning(f"{env}={v!r} is a relative path and is ignored (the "
                                        "cache key would depend on the folder torlab runs in)"),
                          stacklevel=3)
    p = cache_key_file()
    for _ in range(2):
        try:
            return _read_key(p), True
        except FileNotFoundError:
            pass
        except _Untrusted as e:
            warnings.warn(TorlabWarning(f"{e}; this run uses a key of its own, so nothing in "
                                        "OUT/.cache is reused (remove the file: torlab makes a "
                                        "new one)", path=p), stacklevel=3)
            return _PROCESS_KEY, False
        try:
            p.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
            fd = os.open(p, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0),
                         0o600)
        except FileExistsError:
            continue  # another process created it just now (or a link is there): read it
        except OSError:
            return _PROCESS_KEY, False  # no configuration folder: the key lasts this run
        with os.fdopen(fd, "w", encoding="ascii") as f:
            f.write(secrets.token_hex(KEY_BYTES) + "\n")
    return _PROCESS_KEY, False


def _read_key(p: Path) -> bytes:
    """The key in ``p`` if it can be trusted (see :func:`_load_key`); raises
    FileNotFoundError or :class:`_Untrusted`."""
    import stat

    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(p, flags)  # a FIFO opens at once (and is refused below): no hang
    except FileNotFoundError:
        raise
    except OSError as e:
        import errno

        if e.errno == errno.ELOOP:
            raise _Untrusted("the cache key is a symbolic link (it could be anyone's file)") \
                from None
        raise _Untrusted(f"the cache key cannot be read ({e.strerror})") from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise _Untrusted("the cache key is a folder, not a file")
        if not stat.S_ISREG(st.st_mode):
            raise _Untrusted("the cache key is not a regular file (a FIFO, device or socket)")
        if hasattr(os, "geteuid") and st.st_uid != os.geteuid():
            raise _Untrusted(f"the cache key belongs to another user (uid {st.st_uid})")
        if os.name == "posix" and st.st_mode & 0o077:
            raise _Untrusted(f"the cache key can be read or written by others (mode "
                             f"{stat.S_IMODE(st.st_mode):04o}, must be 0600): anyone who read "
                             "it can sign cache entries")
        if os.name == "posix":
            dst = os.stat(p.parent)
            if dst.st_mode & 0o022 or (hasattr(os, "geteuid") and dst.st_uid != os.geteuid()):
                raise _Untrusted(f"the cache key's folder can be written by others (mode "
                                 f"{stat.S_IMODE(dst.st_mode):04o}, owner uid {dst.st_uid}): "
                                 "anyone could put a key of their own there")
        raw = os.read(fd, 4 * KEY_BYTES + 8)
    finally:
        os.close(fd)
    text = raw.decode("ascii", "replace").strip()
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) != KEY_BYTES:
        what = "empty" if not text else f"not {2 * KEY_BYTES} hexadecimal digits"
        raise _Untrusted(f"the cache key is damaged ({what})")
    if len(set(key)) < 8:
        raise _Untrusted(f"the cache key is not random ({len(set(key))} distinct byte values "
                         f"in {KEY_BYTES}, e.g. all zeros)")
    return key


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

        tree, chunks = encode_with_arrays(value)
        body = {"format": FORMAT, "version": FORMAT_VERSION, "torlab": __version__,
                "entry": name, "kind": kind, "value": tree}
        text = json.dumps(body, separators=(",", ":"), allow_nan=False).encode("utf-8")
        head_len = len(FORMAT) + len(str(FORMAT_VERSION)) + 64 + 3
        text += b" " * (-(head_len + len(text) + 1) % 8) + b"\n"
        payload = b"".join([text, *chunks])
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
        return decode_with_arrays(body.get("value"), view[end + 1:])

    def _read(self, p: Path) -> bytearray | None:
        from torlab.errors import TorlabInputError
        from torlab.files import open_regular

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
        from torlab.files import writing

        p = self.folder / name  # type: ignore[operator]
        target = self.register(f"{CACHE_DIR}/{name}") if self.register is not None else p
        with writing(target):
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
