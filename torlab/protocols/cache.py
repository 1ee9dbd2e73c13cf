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
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from torlab.codec import BadEntry, NotCacheable, decode_with_arrays, encode_with_arrays

__all__ = ["CACHE_DIR", "FORMAT", "FORMAT_VERSION", "INDEX", "Encoded", "Encoding", "EntryRef",
           "FigureStore", "Light", "ResultCache", "cache_key_file", "pack_light",
           "unpack_light"]

CACHE_DIR = ".cache"
FORMAT = "torlab-cache"
#: bump when the encoding changes; older entries are then recomputed
FORMAT_VERSION = 2
#: the version in a cached figure's HMAC line (``fig-<key>.png.mac``; the figure is the file)
FIGURE_FORMAT_VERSION = 1
SUFFIX = ".tlc"
#: entries larger than this are not read (a crafted folder must not exhaust memory)
MAX_ENTRY_BYTES = 512 << 20
#: the cache's index: every entry of the last run, its file's status and the light values
#: of some kinds (:func:`pack_light`); the input files' hashes (signed JSON:
#: ``torlab-cache-index 2 <hmac>``)
INDEX = "index.tlc"
INDEX_FORMAT = "torlab-cache-index"
INDEX_VERSION = 2
#: a light value in the index is refused if its JSON is longer than this [bytes]
LIGHT_MAX_BYTES = 1 << 24
#: entries of the index encoded, signed and written at a time (:meth:`ResultCache.write_index`)
INDEX_PIECE = 250
#: an input file changed less than this before it was hashed is hashed again next time [ns]
RACY_NS = 2_000_000_000
_O_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
T = TypeVar("T")


def _status(st: os.stat_result) -> list[int]:
    """What tells a file that was not written since from one that was: size,
    modification and change times [ns], inode (the change time cannot be set back)."""
    return [int(st.st_size), int(st.st_mtime_ns), int(st.st_ctime_ns), int(st.st_ino)]


def _valid_index(idx: Any) -> bool:
    """The index has the shape :meth:`ResultCache.write_index` writes (a light value is
    checked by the function that rebuilds it)."""
    from torlab import __version__

    if not isinstance(idx, dict) or not isinstance(idx.get("entries"), dict) \
            or not isinstance(idx.get("files"), dict) or idx.get("torlab") != __version__:
        return False
    for name, rec in idx["entries"].items():
        st = rec.get("st") if isinstance(rec, dict) else None
        if not (isinstance(name, str) and name.endswith(SUFFIX) and isinstance(st, list)
                and len(st) == 4 and all(type(x) is int for x in st)
                and isinstance(rec.get("kind"), str)
                and isinstance(rec.get("light", ""), str)):
            return False
    for path, rec in idx["files"].items():
        if not (isinstance(path, str) and isinstance(rec, list) and len(rec) == 6
                and all(type(x) is int for x in rec[:4]) and isinstance(rec[4], str)
                and type(rec[5]) is int):
            return False
    return True


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
        #: the index read at the start (entry name -> record), the names in the folder, the
        #: index this run writes (the entries it used), the input files' hashes
        self._index: dict[str, dict[str, Any]] = {}
        self._present: set[str] | None = None
        self._next: dict[str, dict[str, Any]] = {}
        self._hashes: dict[str, list[Any]] = {}
        self._hashes_next: dict[str, list[Any]] = {}
        #: the run that wrote the index (:meth:`up_to_date`), the run writing the next one
        self._run: Any = None
        self._run_next: dict[str, Any] | None = None

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

    @staticmethod
    def payload(name: str, kind: str, value: Any) -> bytes:
        """An entry without its header: the JSON tree (one line, padded to a multiple of 8
        bytes) and the arrays' bytes.  Needs no key, so a worker process can encode a
        value where it computed it (:func:`encoded`) and hand this process the bytes to
        sign (:meth:`store_payload`).  Raises :class:`~torlab.codec.NotCacheable`."""
        from torlab import __version__

        tree, chunks = encode_with_arrays(value)
        body = {"format": FORMAT, "version": FORMAT_VERSION, "torlab": __version__,
                "entry": name, "kind": kind, "value": tree}
        text = json.dumps(body, separators=(",", ":"), allow_nan=False).encode("utf-8")
        head_len = len(FORMAT) + len(str(FORMAT_VERSION)) + 64 + 3
        text += b" " * (-(head_len + len(text) + 1) % 8) + b"\n"
        return b"".join([text, *chunks])

    def dumps(self, name: str, kind: str, value: Any) -> bytes:
        """The bytes of an entry: a header line with the HMAC, the JSON tree (one line,
        padded to a multiple of 8 bytes), the arrays' bytes."""
        return self._signed(self.payload(name, kind, value))

    def _signed(self, payload: bytes) -> bytes:
        return f"{FORMAT} {FORMAT_VERSION} {self._mac(payload)}\n".encode("ascii") + payload

    def loads(self, name: str, kind: str, data: bytes | bytearray, copy: bool = False) -> Any:
        """The value of an entry; :class:`BadEntry` if it fails any check.  Its arrays are
        views of ``data`` (writable when ``data`` is a bytearray; bytes are copied once), or
        with ``copy`` arrays of their own (a caller that keeps part of the value)."""
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
        return decode_with_arrays(body.get("value"), view[end + 1:], copy)

    def _read(self, p: Path) -> bytearray | None:
        data, _ = self._read_stat(p)
        return data

    def _read_stat(self, p: Path) -> tuple[bytearray | None, os.stat_result | None]:
        """The bytes of a regular file (None if unreadable or too large) and its status as
        opened (``fstat``)."""
        from torlab.errors import TorlabInputError
        from torlab.files import open_regular

        try:
            with open_regular(p) as f:
                st = os.fstat(f.fileno())
                size = st.st_size
                if size > MAX_ENTRY_BYTES:
                    return None, None
                data = bytearray(size + 1)  # one more: a file that grew is seen whole
                n = f.readinto(data)
                if n > size:
                    rest = f.read(MAX_ENTRY_BYTES + 1 - n)
                    data = data[:n] + rest
                    if len(data) > MAX_ENTRY_BYTES:
                        return None, None
                    st = os.fstat(f.fileno())
                else:
                    del data[n:]
        except (TorlabInputError, OSError):
            return None, None
        return data, st

    # -- the index: which entries there are, each file's status, the small values ---------
    def _load_index(self) -> None:
        """Read the index once (or, without a valid one, scan the folder once).

        The index (:data:`INDEX`, an entry itself: signed, data only) lists every entry
        of the run that wrote it with its file's status (size, modification and change
        times, inode) and, for some kinds, a small value (:meth:`lookup_light`).  A name
        not in it is not looked for (no file is opened or stat'ed per entry).
        """
        if self._present is not None:
            return
        self._present = set()
        if self.folder is None:
            return
        t0 = time.perf_counter()
        try:
            idx = self._read_index()
            if _valid_index(idx):
                self._index = idx["entries"]
                self._hashes = idx["files"]
                self._run = idx.get("run")
                self._present = set(self._index)
                return
            with contextlib.suppress(OSError):  # no index: one scan of the folder
                with os.scandir(self.folder) as it:
                    self._present = {e.name for e in it if e.name.endswith(SUFFIX)
                                     and e.name != INDEX}
        finally:
            self.io_seconds += time.perf_counter() - t0

    def _read_index(self) -> Any:
        """The index's JSON (None: missing, unreadable or not authentic)."""
        assert self.folder is not None
        data = self._read(self.folder / INDEX)
        if data is None:
            return None
        nl = data.find(b"\n", 0, 200)
        head = bytes(data[:nl]).decode("ascii", "replace").split(" ") if nl > 0 else []
        if len(head) != 3 or head[0] != INDEX_FORMAT or head[1] != str(INDEX_VERSION) \
                or not hmac.compare_digest(head[2], self._mac(memoryview(data)[nl + 1:])):
            return None
        try:
            return json.loads(memoryview(data)[nl + 1:].tobytes())
        except (ValueError, RecursionError):
            return None

    def _unchanged(self, name: str) -> dict[str, Any] | None:
        """The index's record of ``name`` if its file is still the one the index describes
        (same size, times and inode: not written since), else None.

        The record leaves the index read at the start either way: one this run uses goes
        to the index it writes (where a second look finds it), one of a file written
        since (a results folder copied elsewhere has every file new) is let go with its
        light value (:func:`pack_light`), which at a 64x campaign is about 8 MB of text
        when kept to the end of the run (42 MB as JSON objects).
        """
        rec = self._index.pop(name, None) or self._next.get(name)  # asked for again
        if rec is None or self.folder is None:
            return None
        try:
            st = os.stat(self.folder / name, follow_symlinks=False)
        except OSError:
            return None
        return rec if _status(st) == rec.get("st") else None

    def lookup(self, kind: str, *, own_arrays: bool = False, **parts: Any) -> tuple[bool, Any]:
        """``(True, value)`` for a valid stored entry of ``(kind, parts)``, else ``(False, None)``.

        The value's arrays are views of the entry's bytes, or with ``own_arrays`` arrays of
        their own: a caller that keeps only part of the value (a fit without its data) then
        does not keep the whole entry in memory through one array.  The entry counts as
        used (kept by :meth:`prune`); a hit counts in :attr:`hits`.
        """
        if self.folder is None:
            return False, None
        t0 = time.perf_counter()
        try:
            return self._find(self._entry(kind, parts), kind, own_arrays)
        finally:
            self.io_seconds += time.perf_counter() - t0

    def _entry(self, kind: str, parts: dict[str, Any]) -> str:
        """The entry name of ``(kind, parts)``, counted as used; the index read (once)."""
        name = f"{self.key(kind, **parts)}{SUFFIX}"
        self.used.add(name)
        self._load_index()
        return name

    def _find(self, name: str, kind: str, own_arrays: bool = False) -> tuple[bool, Any]:
        """Entry ``name`` read, authenticated and decoded, if the folder holds it."""
        assert self._present is not None
        if name not in self._present:
            return False, None
        return self._load(name, kind, own_arrays)

    def _load(self, name: str, kind: str, own_arrays: bool = False) -> tuple[bool, Any]:
        """Read, authenticate and decode entry ``name`` (:meth:`lookup`)."""
        assert self.folder is not None
        self._index.pop(name, None)  # the earlier record: this read makes the next one
        p = self.folder / name
        data, st = self._read_stat(p)
        try:
            if data is None or st is None:
                raise BadEntry("unreadable")
            value = self.loads(name, kind, data, own_arrays)
        except BadEntry:
            self.rejected += 1
            with contextlib.suppress(OSError):
                p.unlink()
            return False, None
        self.hits += 1
        self._next[name] = {"kind": kind, "st": _status(st)}
        return True, value

    def lookup_light(self, kind: str, light: Light, **parts: Any) -> tuple[bool, Any]:
        """``(True, light.restore(light.light(value)))`` for a stored entry, else
        ``(False, None)``.

        ``light.light(value)`` is what the caller keeps of the value (a reduction's
        header and key figures without its data), as plain JSON; ``light.restore`` makes
        the caller's object of it again.  It is kept in the index, so a later run whose
        entry file is unchanged gets it without reading the entry at all; otherwise the
        entry is read, authenticated and decoded (:meth:`lookup`).
        """
        if self.folder is None:
            return False, None
        t0 = time.perf_counter()
        try:
            name = self._entry(kind, parts)
            rec = self._unchanged(name)
            if rec is not None and rec.get("kind") == kind and "light" in rec:
                # packed (pack_light); a LightOf where this run restored it before
                kept = rec["light"]
                try:
                    value = light.restore(kept() if isinstance(kept, LightOf)
                                          else unpack_light(kept))
                except (TypeError, ValueError, KeyError, AttributeError, RecursionError):
                    value = None
                if value is not None:
                    self.hits += 1
                    rec["light"] = LightOf(light.light, value)  # the JSON itself let go
                    self._next[name] = rec
                    return True, value
            hit, value = self._find(name, kind)  # the entry itself (its name known)
        finally:
            self.io_seconds += time.perf_counter() - t0
        if not hit:
            return False, None
        return True, self.keep_light(name, light, light.light(value))

    def keep_light(self, name: str, light: Light, small: Any) -> Any:
        """``light.restore(small)`` for the entry ``name`` written or found by this run;
        its index record keeps the restored value (:class:`LightOf`), not the JSON."""
        value = light.restore(small)
        rec = self._next.get(name)
        if rec is not None:
            rec["light"] = LightOf(light.light, value)
        return value

    def ref(self, kind: str, **parts: Any) -> EntryRef | None:
        """A reference to the stored entry of ``(kind, parts)`` that a worker process can
        read without the key (:meth:`EntryRef.value`: the file checked against the status
        this process wrote or authenticated it with); None when there is none."""
        name = f"{self.key(kind, **parts)}{SUFFIX}"
        rec = self._next.get(name)
        if self.folder is None or rec is None:
            return None
        return EntryRef(str(self.folder / name), name, kind, tuple(rec["st"]))

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
            self._next[name] = {"kind": kind, "st": self._write(name, blob)}
        finally:
            self.io_seconds += time.perf_counter() - t0

    def entry_name(self, kind: str, **parts: Any) -> str:
        """The file name of the entry of ``(kind, parts)``."""
        return f"{self.key(kind, **parts)}{SUFFIX}"

    def store_payload(self, name: str, kind: str, payload: bytes | None) -> None:
        """Sign and write an entry :meth:`payload` made elsewhere (a worker: :func:`encoded`);
        its light value for the index is :meth:`keep_light`'s.  A None payload (the value
        was not plain data) is not stored."""
        if self.folder is None:
            return
        t0 = time.perf_counter()
        try:
            if payload is None:
                self.not_cacheable.add(kind)
                self.used.discard(name)
                return
            self.used.add(name)
            self._next[name] = {"kind": kind, "st": self._write(name, self._signed(payload))}
        finally:
            self.io_seconds += time.perf_counter() - t0

    def _write(self, name: str, data: bytes | Iterator[bytes],
               head: Callable[[], bytes] | None = None) -> list[int]:
        """Write a new file ``name`` (never through an existing one) of ``data``, bytes or
        an iterator of pieces (a large index is never whole in memory); its status record.
        ``head()``: the first bytes, of a size known before (the index's signature),
        written at the start once the rest is."""
        from torlab.files import writing

        p = self.folder / name  # type: ignore[operator]
        target = self.register(f"{CACHE_DIR}/{name}") if self.register is not None else p
        with writing(target):
            target.parent.mkdir(parents=True, exist_ok=True)
            # a new file, never written through: the carried-over cache's files may be hard
            # links to the earlier results' (torlab.outputs.OutputDir keep=)
            with contextlib.suppress(FileNotFoundError):
                target.unlink()
            fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _O_NOFOLLOW, 0o666)
            with os.fdopen(fd, "wb") as f:
                size = 0 if head is None else f.write(head())  # its size; rewritten below
                for piece in [data] if isinstance(data, bytes) else data:
                    f.write(piece)
                if head is not None:
                    first = head()
                    if len(first) != size:
                        raise ValueError(f"{name}: a head of {len(first)} bytes, not {size}")
                    f.seek(0)
                    f.write(first)
                f.flush()
                return _status(os.fstat(f.fileno()))

    # -- input files: their hashes, kept across runs --------------------------------------
    def sha(self, path: str | os.PathLike[str]) -> str:
        """SHA-256 of an input file; reused from the index when the file's status (size,
        modification and change times, inode) is the one it had when it was hashed, and
        that change time lay at least :data:`RACY_NS` before the hashing (a file changed
        within the same clock tick as it was hashed is hashed again)."""
        from torlab.files import sha256_file, sha256_file_cached

        if self.folder is None:
            return sha256_file_cached(path)
        key = os.path.abspath(path)  # the protocol's paths are absolute already
        st = os.stat(key)
        now = _status(st)
        self._load_index()
        rec = self._hashes_next.get(key) or self._hashes.pop(key, None)  # read once
        if rec is not None and list(rec[:4]) == now and isinstance(rec[4], str) \
                and now[2] < rec[5] - RACY_NS:
            self._hashes_next[key] = rec
            return rec[4]
        t0 = time.perf_counter()
        at = time.time_ns()
        digest = sha256_file(key)
        self.io_seconds += time.perf_counter() - t0
        self._hashes_next[key] = [*now, digest, at]
        return digest

    # -- the whole run --------------------------------------------------------------------
    def record_run(self, key: str, dest: Any, info: dict[str, Any]) -> None:
        """Record in the next index the run that writes ``dest``: its key (what its results
        depend on) and the status of every file it wrote (:meth:`up_to_date`)."""
        from torlab.outputs import MANIFEST

        outputs = {}
        for name in dest.files:
            if name == MANIFEST or name.split("/", 1)[0] == CACHE_DIR:
                continue
            with contextlib.suppress(OSError):
                outputs[name] = _status(os.stat(dest.staging / name, follow_symlinks=False))
        self._run_next = {**info, "key": key, "outputs": outputs}

    def up_to_date(self, key: str, results: Path) -> dict[str, Any] | None:
        """The record of the run that wrote ``results`` (:meth:`record_run`) if it had the
        same key and every file it wrote is still the one it wrote (same size, times and
        inode: nothing edited, replaced or removed since); else None.  The record comes
        from the signed index, so a results folder from elsewhere never passes."""
        self._load_index()
        rec = self._run
        if not (isinstance(rec, dict) and rec.get("key") == key
                and isinstance(rec.get("outputs"), dict) and isinstance(rec.get("hits"), int)
                and isinstance(rec.get("figures"), int)
                and isinstance(rec.get("sections"), list)):
            return None
        for name, st in rec["outputs"].items():
            try:
                now = os.stat(results / name, follow_symlinks=False)
            except (OSError, TypeError, ValueError):
                return None
            if _status(now) != st:
                return None
        return rec

    def write_index(self) -> None:
        """Write the index of the entries this run used (:meth:`_load_index`): signed JSON."""
        if self.folder is None:
            return
        from torlab import __version__

        t0 = time.perf_counter()
        try:
            mac = hmac.new(self.secret, digestmod=hashlib.sha256)

            def signed(chunks: Iterator[str]) -> Iterator[bytes]:
                for c in chunks:
                    b = c.encode("utf-8")
                    mac.update(b)
                    yield b

            self.used.add(INDEX)
            self._write(INDEX, signed(self._index_text(__version__)), head=lambda: (
                f"{INDEX_FORMAT} {INDEX_VERSION} {mac.hexdigest()}\n".encode("ascii")))
        finally:
            self.io_seconds += time.perf_counter() - t0

    def _index_text(self, version: str) -> Iterator[str]:
        """The index's JSON, as ``json.dumps`` of ``{"torlab", "entries", "files", "run"}``
        would write it, in pieces of :data:`INDEX_PIECE` entries or input files' hash
        records: at a 64x campaign the index is 17 MB, which as one text and its bytes took
        35 MB more of the run's memory at its very end (pieces of 1000 entries: 6 MB); the
        hash records of a 128x campaign's 13 315 files are 2.5 MB of text.  A light value is
        written packed (:func:`pack_light`); an entry whose light value is not plain JSON
        is written without it."""
        dumps = json.JSONEncoder(separators=(",", ":")).encode

        def members(pairs: list[tuple[str, Any]], value: Callable[[Any], str]) -> Iterator[str]:
            """``"key":value`` members of a JSON object, :data:`INDEX_PIECE` at a time."""
            for i in range(0, len(pairs), INDEX_PIECE):
                yield "".join(f'{"," if j else ""}{dumps(k)}:{value(v)}'
                              for j, (k, v) in enumerate(pairs[i:i + INDEX_PIECE], start=i))

        def entry(rec: dict[str, Any]) -> str:
            kept = rec.get("light")
            if kept is None:
                return dumps(rec)
            try:
                packed = kept if isinstance(kept, str) else pack_light(kept)
            except (TypeError, ValueError):  # a light value that is not plain JSON
                return dumps({k: v for k, v in rec.items() if k != "light"})
            return dumps({**rec, "light": packed})

        yield f'{{"torlab":{dumps(version)},"entries":{{'
        yield from members([(n, r) for n, r in self._next.items() if n in self.used], entry)
        yield '},"files":{'
        yield from members(list(self._hashes_next.items()), dumps)
        yield f'}},"run":{dumps(self._run_next)}}}'

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
        """Write the index (:meth:`write_index`), then delete everything in the folder this
        run did not use (old entries, other files)."""
        if self.folder is None:
            return 0
        self.write_index()
        if not self.folder.is_dir():
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

    def has(self, key: str, fmt: str) -> bool:
        """Whether the store holds figure ``key`` in ``fmt`` (its file and its sidecar are
        there; neither is read nor checked here: :meth:`get` does that when the figure is
        taken, and gives None if the check fails)."""
        c = self.cache
        if c.folder is None:
            return False
        name = f"fig-{key}.{fmt}"
        return (c.folder / name).is_file() and (c.folder / f"{name}.mac").is_file()

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


@dataclass(frozen=True)
class EntryRef:
    """A stored entry as a worker process reads it (:meth:`ResultCache.ref`).

    The worker has no key: it trusts the file only if it is still the file the run
    wrote or authenticated (the same status: size, modification and change times,
    inode, checked on the opened file), and then decodes it (data only, as every entry).

    Attributes
    ----------
    path, name, kind
        The entry file, its name and kind.
    status
        Its file's status when the run wrote or authenticated it.
    """

    path: str
    name: str
    kind: str
    status: tuple[int, int, int, int]

    def value(self) -> Any:
        """The entry's value.

        Raises
        ------
        BadEntry
            The file is gone, changed since, or does not decode.
        """
        from torlab.errors import TorlabInputError
        from torlab.files import open_regular

        try:
            with open_regular(self.path) as f:
                if tuple(_status(os.fstat(f.fileno()))) != tuple(self.status):
                    raise BadEntry(f"{self.name} changed since it was stored")
                data = bytearray(f.read(MAX_ENTRY_BYTES + 1))
        except (OSError, TorlabInputError) as e:
            raise BadEntry(f"{self.name}: {e}") from None
        nl = data.find(b"\n", 0, 200)
        end = data.find(b"\n", nl + 1)
        if nl < 0 or end < 0:
            raise BadEntry(f"{self.name} is not an entry")
        view = memoryview(data)
        try:
            body = json.loads(view[nl + 1:end].tobytes())
        except (ValueError, RecursionError):
            raise BadEntry("payload is not JSON") from None
        if not isinstance(body, dict) or body.get("entry") != self.name \
                or body.get("kind") != self.kind:
            raise BadEntry("entry header does not match")
        return decode_with_arrays(body.get("value"), view[end + 1:])


@dataclass
class Encoded:
    """A task's result with its cache entry already encoded where it was computed
    (:func:`encoded`): ``value`` (or its light form), ``payload`` for
    :meth:`ResultCache.store_payload` (None: not plain data)."""

    value: Any
    payload: bytes | None
    light: bool = False  # ``value`` is the light form of the stored value
    #: the payloads of the further entries the task filled (:class:`Encoding`'s ``also``)
    also: tuple[bytes | None, ...] = ()


@dataclass(frozen=True)
class Light:
    """What a caller keeps of a kind of value (:meth:`ResultCache.lookup_light`):
    ``light(value)``, plain JSON (numbers, text, lists, mappings), and ``restore`` of that
    JSON, the caller's object (raising TypeError, ValueError or KeyError on JSON of
    another shape).  Both picklable (module-level functions).  The index keeps the restored
    value and remakes the JSON when it is written (:class:`LightOf`), so
    ``light(restore(j))`` must be ``j`` again."""

    light: Callable[[Any], Any]
    restore: Callable[[Any], Any]


class LightOf:
    """The light JSON of a kept value, made when the index is written
    (:meth:`ResultCache.write_index`): ``light(value)``, where ``value`` is what
    :meth:`Light.restore` made of that JSON, so the index holds the value the caller keeps
    anyway instead of a second copy of its JSON (the protocol run keeps an HPT log's light
    form packed: :class:`torlab.protocols.data.PackedReduction`).  ``light`` must give back
    the JSON that ``restore`` was given (tested for the HPT logs, the one instrument with a
    light form)."""

    __slots__ = ("light", "value")

    def __init__(self, light: Callable[[Any], Any], value: Any) -> None:
        self.light, self.value = light, value

    def __call__(self) -> Any:
        return self.light(self.value)


def pack_light(value: Any) -> str:
    """A light value as the index holds it: its JSON, compressed (zlib), in base64.

    A run that finds nothing changed but one file still reads the whole index; its light
    values as JSON objects took about 11 kB of Python objects per HPT log (a 64x
    campaign's 6656 logs: 72 MB) from the moment the index was read, where this text takes
    about 1.2 kB until the value is asked for (:func:`unpack_light`).

    Raises
    ------
    TypeError, ValueError
        ``value`` is not plain JSON.  A number that is not finite is written as Python's
        :mod:`json` writes and reads it (``NaN``, ``Infinity``), as the index always was.
    """
    import base64
    import zlib

    text = json.dumps(value, separators=(",", ":"), default=_light_json)
    return base64.b64encode(zlib.compress(text.encode("utf-8"), 6)).decode("ascii")


def unpack_light(text: str) -> Any:
    """The light value :func:`pack_light` made ``text`` of.

    Raises
    ------
    ValueError
        ``text`` is not base64 of zlib-compressed JSON, or that JSON is longer than
        :data:`LIGHT_MAX_BYTES` (it is not inflated further) or nested too deep.
    """
    import base64
    import binascii
    import zlib

    try:
        d = zlib.decompressobj()
        raw = d.decompress(base64.b64decode(text, validate=True), LIGHT_MAX_BYTES)
        if not d.eof or d.unconsumed_tail or d.unused_data:
            raise ValueError("a light value: truncated, trailing bytes or too long")
        return json.loads(raw)
    except (binascii.Error, zlib.error, RecursionError, UnicodeDecodeError) as e:
        raise ValueError(f"a light value: {e}") from None


def _light_json(o: Any) -> Any:
    """``json.dumps``' ``default``: a :class:`LightOf` as its JSON."""
    if isinstance(o, LightOf):
        return o()
    raise TypeError(f"not JSON: {type(o).__name__}")


@dataclass
class Encoding:
    """``fn`` as an executor task whose result comes back encoded for the cache
    (:class:`Encoded`), with its light JSON instead of the value when ``light`` is given
    (:class:`Light`): the worker encodes, this process only signs and writes (picklable)."""

    fn: Any
    light: Light | None = None

    def __call__(self, job: tuple[Any, ...]) -> Any:
        """``job``: ``(name, kind, arg)``, or ``(name, kind, arg, also)`` for a task that fills
        further entries, ``also`` their ``(name, kind)``: ``fn(arg)`` then returns one value
        per entry, the task's own first (all come back, each entry encoded)."""
        name, kind, arg, *rest = job
        also = rest[0] if rest else ()
        value = self.fn(arg)
        from torlab.parallel import Deferred

        if isinstance(value, Deferred):  # finished in the calling process, stored there
            return value
        values = value if also else (value,)
        payloads = [_payload(n, k, v) for (n, k), v in
                    zip(((name, kind), *also), values, strict=True)]
        if self.light is None:
            return Encoded(value, payloads[0], also=tuple(payloads[1:]))
        return Encoded(self.light.light(value), payloads[0], True, tuple(payloads[1:]))


def _payload(name: str, kind: str, value: Any) -> bytes | None:
    """:meth:`ResultCache.payload`, None for a value that is not plain data."""
    try:
        return ResultCache.payload(name, kind, value)
    except (NotCacheable, ValueError, TypeError):
        return None


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
