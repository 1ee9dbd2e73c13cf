"""Writing results safely: atomic, locked, never over earlier results, never over inputs.

:class:`OutputDir` is how every torlab command writes.  Its guarantees:

* **One writer.**  A lock file next to the target (``.OUT.lock``, an OS file
  lock released when the process ends, even by ``kill -9``) is taken when the
  :class:`OutputDir` is created; a second run into the same folder is refused
  (:class:`~torlab.errors.OutputBusyError`, exit code 2).
* **Atomic.**  Files go to a hidden staging folder next to the target
  (``.OUT.staging-<pid>-...``); :meth:`OutputDir.commit` swaps it into place.
  On Linux the swap is one ``renameat2(RENAME_EXCHANGE)`` system call; elsewhere
  it is two renames (target -> ``.OUT.old-...``, staging -> target), and a
  process killed between them leaves the earlier results complete in
  ``.OUT.old-...``, which the next torlab command writing to ``OUT`` puts back.
  A crash or an error therefore leaves either the earlier results or the new
  ones, never a mix and never neither.
* **Leftovers are cleaned.**  Staging folders of killed runs are removed by the
  next run into the same folder (under the lock, so none of them is in use).
* **Never over other files.**  A target that already holds files is refused
  unless ``force=True``, and even then only if every file in it was written by
  torlab (listed in its ``torlab-manifest.json``): ``--force`` never deletes a
  user's own files.  A file a user puts into the folder *while* the run works
  is moved into the new results at the commit.  A target that contains one of
  the command's *input* files is always refused.
* **Never through a link.**  The lock file, the staging folder, every file and
  sub-folder written and the swap are opened or renamed relative to a descriptor of
  their folder without following a symbolic link (``openat`` with ``O_NOFOLLOW``): a
  link planted as ``.OUT.lock``, an OUT that is a link, or a staging folder replaced by a
  link during the run is an :class:`~torlab.errors.OutputWriteError` (exit code 2), and
  nothing is written where it points.
* **Clear errors.**  A folder that cannot be written (read-only, no permission,
  disk full) is a :class:`~torlab.errors.OutputWriteError` naming the path
  (exit code 2), and nothing is left behind.

Single files (reading a regular file, hashing, an atomic write, a safe name) are
:mod:`torlab.files`, which this module builds on.

Example
-------
>>> with OutputDir("out", force=False, inputs=["run1.txt"]) as out:   # doctest: +SKIP
...     out.write_csv("reduced.csv", df)
...     write_figures(out, [("curve", fig)])   # torlab.reports.render
"""

from __future__ import annotations

import contextlib
import errno
import itertools
import json
import os
import re
import shutil
import stat
import sys
import time
import weakref
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from torlab import __version__
from torlab.errors import OutputBusyError, OutputExistsError, OutputWriteError, TorlabInputError
from torlab.files import sha256_file, writing

__all__ = ["MANIFEST", "OutputDir", "columns_csv", "sheet_units", "write_xlsx"]

MANIFEST = "torlab-manifest.json"


def columns_csv(cols: Mapping[str, Any], float_format: str = "%.10g") -> str:
    """CSV text of named 1-D columns, as ``pandas.DataFrame.to_csv(index=False,
    float_format=...)`` writes it: floats with ``float_format`` (NaN as an empty cell),
    integers and booleans as Python prints them, text quoted where it must be."""
    import csv
    import io

    import numpy as np

    names = list(cols)
    n = len(next(iter(cols.values()))) if cols else 0
    cells = []
    for k in names:
        v = np.asarray(cols[k])
        if v.shape != (n,):
            raise ValueError(f"column {k!r} has {v.size} values, expected {n}")
        if v.dtype.kind == "f":
            cells.append(["" if x != x else float_format % x for x in v.tolist()])
        elif v.dtype.kind in "biu":
            cells.append([str(x) for x in v.tolist()])
        else:
            cells.append(["" if x is None or (isinstance(x, float) and x != x) else str(x)
                          for x in v.tolist()])
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    w.writerows(zip(*cells, strict=True))
    return buf.getvalue()

#: column-name suffix -> (unit shown, factor from SI); the longest suffix that matches wins
_SUFFIX_UNITS = {
    "_Pa_s": ("Pa·s", 1.0), "_1_Pa": ("1/GPa", 1e9), "_m_Pa": ("m/Pa", 1.0),
    "_Pa": ("MPa", 1e-6), "_m_s": ("m/s", 1.0), "_mg_m2": ("mg/m²", 1.0), "_m2": ("mm²", 1e6),
    "_1_m": ("1/m", 1.0), "_1_per_K": ("1/K", 1.0), "_mg": ("mg", 1.0), "_uL": ("µL", 1.0),
    "_N": ("N", 1.0), "_C": ("°C", 1.0), "_K": ("K", 1.0), "_Hz": ("Hz", 1.0), "_s": ("s", 1.0),
    "_m": ("m", 1.0),
}
#: lengths: the unit the figures use for them, by a word of the column name (else mm)
_LENGTH_UNITS = ((("film", "thickness", "wavelength", "separation", "h_star", "sigma",
                   "residual"),  # residual_m: the film fits' (HPT residuals are in Pa)
                  ("nm", 1e9)),
                 (("displacement", "u_layer", "wear", "l_mu", "window", "band_width"),
                  ("µm", 1e6)))
#: fractions the figures show in per cent (SRR, creepage, electrical contact resistance)
_PERCENT = ("srr", "creepage", "ecr")


def sheet_units(df: Any) -> Any:
    """A table in the units of torlab's figures, each header naming its unit in brackets.

    The CSVs keep SI (``srr`` a fraction, ``displacement_m``, ``shear_stress_Pa``); the
    figures show per cent, µm, MPa and nm.  An Excel sheet is read next to the figures,
    so ``--xlsx`` converts: SRR and creepage (and columns named ``srr_…``,
    ``creepage_…``) and ECR to per cent, stresses and pressures to MPa, pressure-viscosity
    coefficients to 1/GPa, film thicknesses and wavelengths to nm, displacements and
    wear to µm, other lengths to mm, areas to mm²; speeds stay in m/s as the figures show
    them.  ``displacement_m`` becomes ``displacement [µm]``, ``srr`` ``srr [%]``; columns
    without a unit suffix (coefficients, text) are left as they are.
    """
    import pandas as pd

    out = {}
    for col in df.columns:
        name, values = str(col), df[col]
        numeric = pd.api.types.is_numeric_dtype(values) and not pd.api.types.is_bool_dtype(values)
        low = name.lower()
        if numeric and (low in _PERCENT or low.startswith(tuple(f"{w}_" for w in _PERCENT))) \
                and not any(low.endswith(sfx) for sfx in _SUFFIX_UNITS):
            out[f"{name} [%]"] = values * 100.0
            continue
        sfx = next((k for k in sorted(_SUFFIX_UNITS, key=len, reverse=True)
                    if name.endswith(k) and len(name) > len(k)), None)
        if not numeric or sfx is None:
            out[name] = values
            continue
        unit, factor = _SUFFIX_UNITS[sfx]
        if sfx == "_m":
            unit, factor = next((u for words, u in _LENGTH_UNITS
                                 if any(w in low for w in words)), ("mm", 1e3))
        out[f"{name[:-len(sfx)]} [{unit}]"] = values * factor if factor != 1.0 else values
    return pd.DataFrame(out, index=df.index)


def write_xlsx(path: str | os.PathLike[str] | Any, tables: Mapping[str, Any]) -> Any:
    """Write tables as the sheets of one Excel workbook (openpyxl).

    Sheet names are cut to Excel's 31 characters (made unique); every sheet is in
    the units of the figures, with the unit of each column in its header
    (:func:`sheet_units`: ``srr [%]``, ``displacement [µm]``), where the CSVs keep SI.

    Parameters
    ----------
    path
        A file name or a binary buffer.
    tables
        Sheet name -> pandas DataFrame.

    Returns
    -------
    The path (a :class:`~pathlib.Path`) or the buffer written to.

    Raises
    ------
    TorlabInputError
        openpyxl is not installed (the message says how to install it).
    """
    try:
        import openpyxl  # noqa: F401
    except ImportError:
        raise TorlabInputError("--xlsx needs openpyxl: pip install 'torlab[xlsx]' (or pip "
                               "install openpyxl)", key="--xlsx") from None
    import pandas as pd

    path = Path(path) if isinstance(path, (str, os.PathLike)) else path
    used: set[str] = set()
    with pd.ExcelWriter(path, engine="openpyxl") as xw:
        for name, df in tables.items():
            sheet = name[:31]
            k = 1
            while sheet in used:
                tail = f"~{k}"
                sheet = name[:31 - len(tail)] + tail
                k += 1
            used.add(sheet)
            sheet_units(df).to_excel(xw, sheet_name=sheet, index=False)
    return path


# ---------------------------------------------------------------------------- no links
# Every name torlab writes next to or inside the output folder is opened relative to a
# descriptor of its folder (``openat``) and without following a symbolic link, so a link
# planted in OUT's parent (``.OUT.lock -> victim``) can never redirect a write.
_O_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_O_DIRECTORY = getattr(os, "O_DIRECTORY", 0)
_O_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_O_NONBLOCK = getattr(os, "O_NONBLOCK", 0)
_O_DIRREF = getattr(os, "O_PATH", os.O_RDONLY)  # a folder held only to name things in it
#: the ``*at`` system calls (Linux, macOS, BSD); elsewhere paths checked with ``lstat``
_AT = all(f in os.supports_dir_fd for f in (os.open, os.mkdir, os.stat, os.unlink, os.rename))


class _Dir:
    """A folder held open: names in it are resolved against the folder itself, not a path
    that someone could swap for a link between a check and a use."""

    def __init__(self, path: Path, *, nofollow: bool = False) -> None:
        self.path = path
        self.fd: int | None = None
        if _AT:
            flags = (os.O_RDONLY if nofollow else _O_DIRREF) | _O_DIRECTORY | _O_CLOEXEC
            self.fd = os.open(path, flags | (_O_NOFOLLOW if nofollow else 0))

    def sub(self, name: str) -> _Dir:
        """The sub-folder ``name`` (never through a link)."""
        d = _Dir.__new__(_Dir)
        d.path = self.path / name
        d.fd = None
        if self.fd is not None:
            d.fd = os.open(name, os.O_RDONLY | _O_DIRECTORY | _O_NOFOLLOW | _O_CLOEXEC,
                           dir_fd=self.fd)
        elif self.lstat(name) is not None and stat.S_ISLNK(self.lstat(name).st_mode):
            raise OSError(errno.ELOOP, os.strerror(errno.ELOOP), str(d.path))
        return d

    def _at(self, name: str) -> tuple[Any, dict[str, Any]]:
        return (name, {"dir_fd": self.fd}) if self.fd is not None else (self.path / name, {})

    def open(self, name: str, flags: int, mode: int = 0o666) -> int:
        """``open(name)`` without following a link (``ELOOP`` for a link)."""
        p, kw = self._at(name)
        if self.fd is None:
            st = self.lstat(name)
            if st is not None and stat.S_ISLNK(st.st_mode):
                raise OSError(errno.ELOOP, os.strerror(errno.ELOOP), str(p))
        return os.open(p, flags | _O_NOFOLLOW | _O_CLOEXEC, mode, **kw)

    def lstat(self, name: str) -> os.stat_result | None:
        p, kw = self._at(name)
        try:
            return os.stat(p, follow_symlinks=False, **kw)
        except FileNotFoundError:
            return None

    def mkdir(self, name: str, mode: int = 0o777) -> None:
        p, kw = self._at(name)
        os.mkdir(p, mode, **kw)

    def unlink(self, name: str) -> None:
        p, kw = self._at(name)
        os.unlink(p, **kw)

    def rename(self, src: str, dst: str) -> None:
        """Rename ``src`` to ``dst`` in this folder (replacing ``dst``; a link is renamed
        or replaced itself, never followed)."""
        if self.fd is not None:
            os.replace(src, dst, src_dir_fd=self.fd, dst_dir_fd=self.fd)
        else:
            os.replace(self.path / src, self.path / dst)

    def close(self) -> None:
        fd, self.fd = self.fd, None
        if fd is not None:
            with contextlib.suppress(OSError):
                os.close(fd)


def _link_error(what: str, where: Path | None, target: Path) -> OutputWriteError:
    """``what`` (``where``; None: the output folder itself) is a symbolic link."""
    if where is None:
        return OutputWriteError(f"{what} is a symbolic link; torlab never writes through a "
                                "link (give the folder it points to, or another -o)", path=target)
    return OutputWriteError(f"{what} {where} is a symbolic link; torlab never writes through "
                            "a link (remove it, or choose another -o)", path=target)


# ---------------------------------------------------------------------------- lock
class _Lock:
    """An exclusive, non-blocking OS lock on a lock file (released when the process dies).

    The lock file is opened in its folder without following a link and must be a regular
    file with no other hard link: a link planted as ``.OUT.lock`` is refused, and nothing
    is written to it.

    A process forked while the lock is held (a worker of
    :class:`torlab.parallel.ProcessExecutor`) closes its copy of the descriptor at once
    (:func:`_forget_locks_in_child`): the lock belongs to the run, and a worker outliving a
    killed run must not keep its output folder locked.
    """

    def __init__(self, folder: _Dir, name: str, target: Path) -> None:
        self.folder = folder
        self.name = name
        self.path = folder.path / name
        self.target = target
        self.fd: int | None = None
        _LOCKS.add(self)

    def acquire(self) -> None:
        for _ in range(20):
            with writing(self.target):
                try:
                    fd = self.folder.open(self.name, os.O_RDWR | os.O_CREAT | _O_NONBLOCK, 0o644)
                except OSError as e:
                    if e.errno == errno.ELOOP:
                        raise _link_error("the lock file", self.path, self.target) from None
                    raise
            try:
                st = os.fstat(fd)
                if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
                    raise OutputWriteError(
                        f"the lock file {self.path} is not a plain file torlab made (a "
                        f"{'file with other hard links' if stat.S_ISREG(st.st_mode) else 'FIFO, device or socket'}); "
                        "remove it, or choose another -o", path=self.target)
                if not _try_lock(fd):
                    holder = _read_pid(fd)
                    who = f" (pid {holder})" if holder else ""
                    raise OutputBusyError(
                        f"another torlab run{who} is writing to this output folder; wait for it "
                        "to finish or choose another -o", path=self.target)
            except BaseException:
                os.close(fd)
                raise
            # the holder we waited for may have removed the file: lock the current one
            now = self.folder.lstat(self.name)
            if now is None or not os.path.samestat(st, now):
                os.close(fd)
                continue
            with writing(self.target):
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode())
            self.fd = fd
            return
        raise OutputBusyError("could not lock the output folder (its lock file keeps "
                              "changing)", path=self.target)

    def release(self) -> None:
        if self.fd is None:
            self.folder.close()
            return
        fd, self.fd = self.fd, None
        with contextlib.suppress(OSError):  # only our own lock file, never one put in its place
            now = self.folder.lstat(self.name)
            if now is not None and os.path.samestat(os.fstat(fd), now):
                self.folder.unlink(self.name)
        with contextlib.suppress(OSError):
            os.close(fd)  # closing releases the lock
        self.folder.close()

    def __del__(self) -> None:
        self.release()


_LOCKS: weakref.WeakSet[_Lock] = weakref.WeakSet()


def _forget_locks_in_child() -> None:
    """After ``fork``: close the child's copies of held lock descriptors (without unlinking)."""
    for lk in list(_LOCKS):
        fd, lk.fd = lk.fd, None
        if fd is not None:
            with contextlib.suppress(OSError):
                os.close(fd)
            lk.folder.close()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_locks_in_child)


def _try_lock(fd: int) -> bool:
    try:
        import fcntl
    except ImportError:  # Windows
        import msvcrt

        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            return False
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as e:
        if e.errno in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
            return False
        raise
    return True


def _read_pid(fd: int) -> int | None:
    try:
        return int(os.pread(fd, 32, 0).split()[0])
    except (OSError, ValueError, IndexError, AttributeError):
        return None


# ---------------------------------------------------------------------------- atomic swap
def _exchange(folder: _Dir, a: str, b: str) -> bool:
    """Atomically swap two names of ``folder`` (Linux ``renameat2(RENAME_EXCHANGE)``);
    False if unsupported."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    at_fdcwd, rename_exchange = -100, 2
    if folder.fd is None:
        dfd, a_, b_ = at_fdcwd, os.fsencode(folder.path / a), os.fsencode(folder.path / b)
    else:
        dfd, a_, b_ = folder.fd, os.fsencode(a), os.fsencode(b)
    rc = fn(dfd, a_, dfd, b_, rename_exchange)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False  # file system or kernel without the flag: two renames instead
    raise OSError(err, os.strerror(err), os.fspath(folder.path / a))


def _remove_tree(p: Path) -> None:
    """Delete a folder of ours: renamed to a ``trash`` name first, so that a half-deleted
    folder can never be mistaken for complete results.  A link is removed, never followed
    (``shutil.rmtree`` walks by descriptors on Linux; a read-only folder inside is made
    writable only when it is a folder, not a link)."""
    try:
        if stat.S_ISLNK(os.lstat(p).st_mode):
            os.unlink(p)
            return
    except OSError:
        return
    trash = p.with_name(re.sub(r"\.(old|staging)-", ".trash-", p.name, count=1))
    if trash != p:
        try:
            os.replace(p, trash)
            p = trash
        except OSError:
            pass

    def writable(fn: Any, path: str, exc: Any) -> None:  # a read-only folder of ours
        with contextlib.suppress(OSError):
            for d in (os.path.dirname(path), path):
                if stat.S_ISDIR(os.lstat(d).st_mode):
                    os.chmod(d, 0o700)
            fn(path)

    if sys.version_info >= (3, 12):
        shutil.rmtree(p, onexc=writable)
    else:
        shutil.rmtree(p, onerror=writable)


def _mine(st: os.stat_result) -> bool:
    """Whether a file or folder belongs to this process's user (always, without owners)."""
    return not hasattr(os, "geteuid") or st.st_uid == os.geteuid()


def _private_dir(folder: _Dir, prefix: str) -> str:
    """Make a new folder ``prefix<random>`` (mode 0700) in ``folder``; its name."""
    import secrets

    for _ in range(100):
        name = f"{prefix}{secrets.token_hex(5)}"
        try:
            folder.mkdir(name, 0o700)
        except FileExistsError:
            continue
        return name
    raise FileExistsError(errno.EEXIST, "no free name for a staging folder", str(folder.path))


# ---------------------------------------------------------------------------- the folder
class OutputDir:
    """A results folder written atomically; see the module docstring.

    Parameters
    ----------
    target
        Folder the results end up in.  Its last part may not be a symbolic link (the
        folders above it may: they are the user's own path).
    force
        Replace earlier torlab results in ``target``.
    inputs
        The command's input files; ``target`` may not contain any of them.
    command
        Command line recorded in the manifest.
    keep
        Names (relative paths) of folders or files in an existing ``target`` to
        carry over into the new results (e.g. a cache).  Only regular files are
        carried over (no symbolic links, devices or FIFOs), as hard links where the
        file system allows (the ``write_*`` methods replace such a link by a new
        file, so the earlier results are never written through; a caller writing
        to :meth:`path` itself must do the same); what they contain is for their
        reader to check -- the folder may come from someone else.
    carry
        Names of folders (one name each, no ``/``) in an existing ``target`` to *move*
        into the new results when the staging folder is made (one rename, however many
        files they hold: a protocol's cache), and back if the run fails.  Only a real
        folder of this user is moved (not a link); its files are left as they are, so
        what they contain is for their reader to check.  A run killed while it holds
        one leaves the earlier results without it.

    Raises
    ------
    OutputBusyError
        Another process is writing to ``target``.
    OutputExistsError
        ``target`` holds results (without ``force``) or files torlab did not write.
    OutputWriteError
        The place cannot be written, or a name torlab writes (the folder, its lock file)
        is a symbolic link.
    """

    def __init__(
        self,
        target: str | os.PathLike[str],
        *,
        force: bool = False,
        inputs: Iterable[str | os.PathLike[str]] = (),
        command: str = "",
        keep: Iterable[str] = (),
        carry: Iterable[str] = (),
    ) -> None:
        self.target = Path(target)
        t = self.target
        # the user's path to the folder is resolved; its last part is never followed
        if t.name in ("", ".", ".."):
            self._real = t.resolve()
        else:
            self._real = t.parent.resolve() / t.name
        self.force = force
        self.command = command
        # the caller's paths themselves (a campaign's are thousands: no copy of each)
        self.inputs = [p if isinstance(p, Path) else Path(p) for p in inputs]
        self.keep = list(keep)
        self.carry = list(carry)
        if any("/" in c or c in ("", ".", "..") for c in self.carry):
            raise ValueError(f"carry takes folder names, not paths: {self.carry}")
        self._carried: list[str] = []
        #: the inputs' SHA-256 for the manifest (a caller that hashed them already may
        #: give its own function)
        self.hasher: Any = sha256_file
        self.files: list[str] = []  # in the order written; _listed: the same names, a set
        self._listed: set[str] = set()
        self._written: dict[str, str] = {}  # names written by the write_* methods (casefolded)
        self.notes: list[str] = []
        #: files of the earlier results kept as they were (same bytes; :meth:`write_bytes`)
        self.kept: list[str] = []
        #: seconds spent writing files (for a command's honest time split)
        self.io_seconds = 0.0
        self._staging: Path | None = None
        self._stage: _Dir | None = None
        self._check_kind(t)
        self._check_inputs()
        parent = self._real.parent
        with writing(parent):
            parent.mkdir(parents=True, exist_ok=True)
            self._parent = _Dir(parent)
        self._lock = _Lock(self._parent, f".{self._real.name}.lock", t)
        try:
            self._lock.acquire()
            self._recover()
            self._check_target()
        except BaseException:
            self._lock.release()
            raise

    # -- checks -------------------------------------------------------------
    def _check_kind(self, t: Path) -> None:
        try:
            st = os.lstat(self._real)
        except FileNotFoundError:
            return
        except OSError as e:
            raise OutputWriteError(f"cannot read the output folder ({e.strerror})",
                                   path=t) from None
        if stat.S_ISLNK(st.st_mode):
            raise _link_error("the output folder", None, t)
        if not stat.S_ISDIR(st.st_mode):
            raise TorlabInputError("output path exists and is not a folder", path=t)

    def _check_inputs(self) -> None:
        tres = self._real
        for inp in self.inputs:
            try:
                inp.resolve().relative_to(tres)
            except ValueError:
                continue
            raise TorlabInputError(
                f"output folder contains the input file {inp}; choose another -o so raw data "
                "are never touched", path=self.target)

    def _check_target(self) -> None:
        t = self.target
        self._check_kind(t)
        if not os.path.lexists(self._real):
            return
        mode = stat.S_IMODE(os.lstat(self._real).st_mode)
        if os.name == "posix" and not mode & stat.S_IWUSR:  # also when root could write it
            raise OutputWriteError(f"the output folder is read-only (mode {mode:04o}); make it "
                                   "writable (chmod u+w) or choose another -o", path=t)
        try:
            empty = next(self._real.iterdir(), None) is None
        except OSError as e:
            raise OutputWriteError(f"cannot read the output folder ({e.strerror})",
                                   path=t) from None
        if empty:
            return
        if not self.force:
            raise OutputExistsError(
                "output folder already holds results; use --force to replace them or choose "
                "another -o", path=t)
        foreign = _foreign_files(self._real)
        if foreign:
            more = "" if len(foreign) <= 3 else f" and {len(foreign) - 3} more"
            raise OutputExistsError(
                "--force only replaces torlab's own results, but the folder also holds "
                f"{', '.join(foreign[:3])}{more}; move them or choose another -o", path=t)

    def _recover(self) -> None:
        """Put back results hidden by an interrupted commit; delete killed runs' leftovers.

        Runs under the lock, so no other process is using any of these folders.  Only
        folders of this user are touched (a folder someone else put there is not ours to
        restore or delete), never a link.
        """
        t = self._real
        pre = f".{t.name}."
        try:
            entries = []
            for e in os.scandir(t.parent):
                if not e.name.startswith(pre):
                    continue
                st = e.stat(follow_symlinks=False)
                if stat.S_ISDIR(st.st_mode) and _mine(st):
                    entries.append((Path(e.path), st.st_mtime_ns))
        except OSError:
            return
        olds = [p for p, _ in sorted(entries, key=lambda x: x[1])
                if p.name.startswith(pre + "old-")]
        if olds and not os.path.lexists(t):
            newest = olds.pop()
            with writing(self.target):
                self._parent.rename(newest.name, t.name)
            self._note(f"restored the earlier results of {self.target} from an interrupted "
                       "run")
        for p, _ in entries:
            if p.name.startswith((pre + "staging-", pre + "trash-")) or p in olds:
                self._retire(p)

    def _note(self, text: str) -> None:
        """Record ``text`` in :attr:`notes` and issue it as a TorlabWarning (one CLI line)."""
        import warnings

        from torlab.errors import TorlabWarning

        self.notes.append(text)
        warnings.warn(TorlabWarning(text), stacklevel=3)

    # -- staging ------------------------------------------------------------
    @property
    def staging(self) -> Path:
        """Folder files are written to before :meth:`commit` (mode 0700 until then)."""
        if self._staging is None:
            t = self._real
            with writing(t.parent):
                name = _private_dir(self._parent, f".{t.name}.staging-{os.getpid()}-")
                self._stage = self._parent.sub(name)
                self._staging = t.parent / name
                if os.path.isdir(t) and not os.path.islink(t):
                    for k in self.keep:  # linked where possible: kept files are only
                        # ever replaced (unlinked, written anew), never changed in place
                        _copy_regular(t / k, self._staging / k, link=True)
                    self._move_carried(into_staging=True)
        return self._staging

    def _move_carried(self, *, into_staging: bool) -> None:
        """Move the :attr:`carry` folders from the earlier results into staging, or back."""
        if not self.carry or self._stage is None:
            return
        try:
            out = self._parent.sub(self._real.name)
        except OSError:
            return
        try:
            src, dst = (out, self._stage) if into_staging else (self._stage, out)
            for k in (self.carry if into_staging else list(self._carried)):
                st = src.lstat(k)
                if st is None or not stat.S_ISDIR(st.st_mode) or not _mine(st) \
                        or dst.lstat(k) is not None:
                    continue
                try:
                    if src.fd is not None and dst.fd is not None:
                        os.rename(k, k, src_dir_fd=src.fd, dst_dir_fd=dst.fd)
                    else:
                        os.rename(src.path / k, dst.path / k)
                except OSError:
                    continue
                if into_staging:
                    self._carried.append(k)
                else:
                    self._carried.remove(k)
        finally:
            out.close()

    def _check_staging(self) -> None:
        """The staging folder's name still names the folder this run made."""
        assert self._stage is not None and self._staging is not None
        if self._stage.fd is None:
            return
        now = self._parent.lstat(self._staging.name)
        if now is None or not os.path.samestat(now, os.fstat(self._stage.fd)):
            raise OutputWriteError(f"the staging folder {self._staging} was moved or replaced "
                                   "during the run; nothing was written", path=self.target)

    def _rel(self, name: str) -> Path:
        rel = Path(name)
        if rel.is_absolute() or ".." in rel.parts or not rel.parts:
            raise ValueError(f"output names must be relative paths inside the folder: {name!r}")
        return rel

    def _folder_of(self, rel: Path) -> _Dir:
        """The staging sub-folder holding ``rel`` (made if missing; never through a link).
        The caller closes it."""
        _ = self.staging  # made on first use
        assert self._stage is not None
        d = self._stage
        opened: list[_Dir] = []
        try:
            for part in rel.parts[:-1]:
                with contextlib.suppress(FileExistsError):
                    d.mkdir(part)
                d = d.sub(part)
                opened.append(d)
        except BaseException:
            for o in opened:
                o.close()
            raise
        for o in opened[:-1]:
            o.close()
        if not opened:  # the caller's own handle on the staging folder
            d = _Dir.__new__(_Dir)
            d.path = self._stage.path
            d.fd = os.dup(self._stage.fd) if self._stage.fd is not None else None
        return d

    def _open_new(self, name: str) -> int:
        """A new file ``name`` in staging, open for writing: any file of that name (a hard
        link to a carried-over file) is unlinked first; never opened through a link."""
        rel = self._rel(name)
        key = rel.as_posix().casefold()  # one name on a file system that ignores case too
        if rel.as_posix() != MANIFEST:
            if key in self._written:
                raise OutputExistsError(
                    f"two results of this run would be written to one file, "
                    f"{self._written[key]}{'' if self._written[key] == rel.as_posix() else ' / ' + rel.as_posix()}"
                    " (two inputs, labels or products that make the same file name); nothing "
                    "was written", path=self.target)
            self._written[key] = rel.as_posix()
        d = self._folder_of(rel)
        try:
            with contextlib.suppress(FileNotFoundError):
                d.unlink(rel.name)
            fd = d.open(rel.name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        finally:
            d.close()
        if rel.as_posix() != MANIFEST:
            self._list(rel.as_posix())
        return fd

    def _list(self, name: str) -> None:
        """Record ``name`` for the manifest (once)."""
        if name not in self._listed:
            self._listed.add(name)
            self.files.append(name)

    def path(self, name: str) -> Path:
        """Staging path for ``name`` (a relative path), recorded in the manifest.

        Its folders are made (never through a link); the caller writes the file itself
        and must not write through an existing file of that name (unlink it first).
        """
        rel = self._rel(name)
        with writing(self.target / rel):
            self._folder_of(rel).close()
            self._check_staging()
        self._list(rel.as_posix())
        return self.staging / rel

    def final_path(self, name: str) -> Path:
        """Where ``name`` will be after :meth:`commit`."""
        return self.target / name

    def write_text(self, name: str, text: str, *, keep_same: bool = False) -> Path:
        """Write a UTF-8 text file (``keep_same``: as for :meth:`write_bytes`)."""
        return self.write_bytes(name, text.encode("utf-8"), keep_same=keep_same)

    def write_lines(self, name: str, lines: Callable[[], Iterable[str]], *,
                    keep_same: bool = False) -> Path:
        """Write a UTF-8 text file of the pieces ``lines()`` gives, encoded and written about
        64 kB at a time: neither the text nor its bytes are ever whole in memory (a 64x
        campaign's ``report.html`` is 2.6 MB, and was about 10 MB more of the run's memory
        as a list of lines, their text and its bytes).  A piece that fails mid-way leaves no
        file of that name.

        ``keep_same``: as for :meth:`write_bytes`; the earlier file is compared with the
        pieces of a first ``lines()``, and ``lines()`` is called again to write a file that
        differs (so it must give the same pieces each time).
        """
        t0 = time.perf_counter()
        with writing(self.final_path(name)):
            if not (keep_same and self._keep_earlier(name, _chunks(lines()))):
                fd = self._open_new(name)
                try:
                    with os.fdopen(fd, "wb") as f:
                        for b in _chunks(lines()):
                            f.write(b)
                except BaseException:
                    self._forget(name)
                    raise
        self.io_seconds += time.perf_counter() - t0
        return self.final_path(name)

    def write_bytes(self, name: str, data: bytes, *, keep_same: bool = False) -> Path:
        """Write a binary file.

        ``keep_same``: where the earlier results (replaced with ``force``) hold a file of
        this name with exactly these bytes, that file is kept as it is -- hard-linked into
        the new results, its time and inode unchanged -- instead of written anew (a
        re-run's figures and reports that did not change are not rewritten).
        """
        t0 = time.perf_counter()
        with writing(self.final_path(name)):
            if not (keep_same and self._keep_earlier(name, data)):
                _write_file(self._open_new(name), data)
        self.io_seconds += time.perf_counter() - t0
        return self.final_path(name)

    def _keep_earlier(self, name: str, data: bytes | Iterator[bytes]) -> bool:
        """Link the earlier results' ``name`` into staging if it holds exactly ``data`` (its
        bytes, or the pieces of them in order).

        Only a regular file of this user, inside the earlier results (no link on the way),
        and only where the file system links; anything else: False (written anew)."""
        if not self.force:
            return False
        rel = self._rel(name)
        src = self._real / rel
        whole = isinstance(data, bytes)
        try:
            st = os.lstat(src)
            if not (stat.S_ISREG(st.st_mode) and (not whole or st.st_size == len(data))
                    and _mine(st)):
                return False
            if Path(os.path.realpath(src)) != Path(os.path.realpath(self._real)) / rel:
                return False  # a folder on the way is a link
            fd = os.open(src, os.O_RDONLY | _O_NOFOLLOW | _O_CLOEXEC)
            with os.fdopen(fd, "rb") as f:
                if not os.path.samestat(os.fstat(f.fileno()), st):
                    return False
                if whole:
                    if f.read(len(data) + 1) != data:
                        return False
                elif any(f.read(len(b)) != b for b in data) or f.read(1):
                    return False
        except OSError:
            return False
        self._remove(rel)
        if not _hard_link(src, self.staging / rel, st):
            return False
        self._list(rel.as_posix())
        self.kept.append(rel.as_posix())
        return True

    def write_json(self, name: str, obj: Any) -> Path:
        """Write ``obj`` as indented JSON (NaN/inf are refused), in pieces as it is encoded.

        The bytes are those of ``json.dumps(obj, indent=2)`` and a newline, but the text is
        never whole in memory (with its bytes beside it: about three times a file's size;
        a 64x campaign's ``summary.json`` is 5 MB).  A value that is not JSON (NaN,
        infinity, an object): ValueError or TypeError, and no file of that name.
        """
        enc = json.JSONEncoder(indent=2, allow_nan=False, default=_json_default)
        return self.write_lines(name, lambda: itertools.chain(enc.iterencode(obj), ["\n"]))

    def _remove(self, rel: Path) -> None:
        """Unlink ``rel`` in staging if it is there (never through a link on the way)."""
        d = self._folder_of(rel)
        try:
            with contextlib.suppress(FileNotFoundError):
                d.unlink(rel.name)
        finally:
            d.close()

    def _forget(self, name: str) -> None:
        """Remove a file this run began to write and could not finish, and its records."""
        rel = self._rel(name)
        self._remove(rel)
        self._written.pop(rel.as_posix().casefold(), None)
        if rel.as_posix() in self._listed:
            self._listed.discard(rel.as_posix())
            self.files.remove(rel.as_posix())

    def write_csv(self, name: str, df: Any, *, float_format: str = "%.10g",
                  allow_missing: tuple[str, ...] = ()) -> Path:
        """Write a table as CSV (no index): a pandas DataFrame, or a mapping of column name
        to a 1-D array (written without importing pandas, byte for byte as pandas would).

        Numbers must be finite: a NaN or inf is refused (a numerical bug must not
        reach a result file), except NaN in the ``allow_missing`` columns, which
        is written as an empty cell meaning "not given" (e.g. no applied amount).
        """
        import numpy as np

        t0 = time.perf_counter()
        if isinstance(df, Mapping):
            cols = {str(k): np.asarray(v) for k, v in df.items()}
            num = {k: v for k, v in cols.items() if v.dtype.kind in "biuf"}
        else:
            cols = None
            num = {c: df[c] for c in df.select_dtypes(include="number").columns}
        bad = []
        for c, col in num.items():
            v = np.asarray(col, dtype=float)
            ok = np.isfinite(v) | (np.isnan(v) if c in allow_missing else False)
            if not ok.all():
                bad.append(c)
        if bad:
            raise ValueError(f"refusing to write non-finite values to {name}: columns {bad}")
        with writing(self.final_path(name)):
            fd = self._open_new(name)
            if cols is None:
                with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
                    df.to_csv(f, index=False, float_format=float_format, lineterminator="\n")
            else:
                _write_file(fd, columns_csv(cols, float_format).encode("utf-8"))
        self.io_seconds += time.perf_counter() - t0
        return self.final_path(name)

    def write_xlsx(self, name: str, tables: Mapping[str, Any]) -> Path:
        """Write tables as the sheets of one Excel workbook (``--xlsx`` of every command
        that writes tables; :func:`write_xlsx`: sheet names cut to Excel's 31 characters,
        the figures' units, each named in its column's header)."""
        import io

        buf = io.BytesIO()
        write_xlsx(buf, tables)
        return self.write_bytes(name, buf.getvalue())

    # -- commit -------------------------------------------------------------
    def commit(self) -> Path:
        """Write the manifest and move the results into place atomically; release the lock."""
        try:
            with writing(self.target):
                return self._commit()
        except BaseException:
            self.abort()
            raise
        finally:
            self._lock.release()

    def _commit(self) -> Path:
        st = self.staging
        for name in [*self.keep, *self.carry]:
            if (st / name).exists():
                self._list(name)
        manifest = {
            "torlab_version": __version__,
            "command": self.command,
            "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "inputs": {str(p): self.hasher(p) for p in self.inputs if p.is_file()},
            "files": sorted(self.files),
        }
        _write_file(self._open_new(MANIFEST), (json.dumps(manifest, indent=2) + "\n").encode())
        self._check_staging()
        t = self._real
        now = self._parent.lstat(t.name)
        if now is not None and stat.S_ISLNK(now.st_mode):
            raise _link_error("the output folder", None, self.target)
        # private (0700) while it was written; the results get the mode of the folder they
        # replace (one the user made), or a new folder's mode under the umask
        mode = stat.S_IMODE(now.st_mode) if now is not None else 0o777 & ~_umask()
        assert self._stage is not None
        if self._stage.fd is not None:
            os.fchmod(self._stage.fd, mode)
        else:
            os.chmod(st, mode)
        if now is None:
            self._parent.rename(st.name, t.name)
            self._close_stage()
            return self.target
        if _exchange(self._parent, st.name, t.name):
            old = st  # the staging path now holds the earlier results
        else:
            old = t.with_name(f".{t.name}.old-{os.getpid()}-{time.monotonic_ns()}")
            self._parent.rename(t.name, old.name)
            try:
                self._parent.rename(st.name, t.name)
            except BaseException:
                self._parent.rename(old.name, t.name)
                raise
        self._close_stage()
        self._retire(old)
        return self.target

    def _close_stage(self) -> None:
        self._staging = None
        if self._stage is not None:
            self._stage.close()
            self._stage = None

    def _retire(self, old: Path) -> None:
        """Delete a replaced or left-over folder, first moving any user file in it into the results.

        A folder with a manifest is a complete earlier result (or a finished
        staging folder): files in it that its manifest does not list were put
        there by someone else (e.g. during the run) and move into the target.
        A folder without a manifest is a killed run's partial staging.  If a
        file cannot be moved, the folder is kept, renamed so that it is visible.
        """
        t = self._real
        if old.is_symlink():  # a link put in its place: drop it, never touch what it points to
            with contextlib.suppress(OSError):
                old.unlink()
            return
        if (old / MANIFEST).is_file() and t.is_dir() and not t.is_symlink():
            try:
                for rel in _foreign_files(old):
                    dst = t / rel
                    k = 1
                    while dst.exists() or dst.is_symlink():
                        dst = (t / rel).with_name(f"{Path(rel).name}.kept-{k}")
                        k += 1
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(old / rel, dst)
                    self._note(f"kept {dst.relative_to(t).as_posix()} in {self.target}: it was "
                               "written into the output folder during the run")
            except OSError:
                keep = t.with_name(f"{t.name}.earlier-{time.strftime('%Y%m%d-%H%M%S')}")
                with contextlib.suppress(OSError):
                    os.replace(old, keep)
                    self._note(f"could not move files written during the run into "
                               f"{self.target}; the earlier folder is kept as {keep}")
                    return
        _remove_tree(old)

    def abort(self) -> None:
        """Discard the staged files; the target is left as it was (with the :attr:`carry`
        folders moved back); release the lock."""
        if self._staging is not None:
            with contextlib.suppress(OSError, OutputWriteError):
                self._check_staging()  # a folder put in its place is not ours to delete
                self._move_carried(into_staging=False)
                _remove_tree(self._staging)
            self._close_stage()
        self._lock.release()

    def close(self) -> None:
        """Give up without writing (same as :meth:`abort`)."""
        self.abort()

    def __enter__(self) -> OutputDir:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.abort()


def _umask() -> int:
    """The process's umask (from ``/proc`` where there is one: setting it to read it back
    would change it for a moment for every thread)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    m = os.umask(0o022)
    os.umask(m)
    return m


def _chunks(pieces: Iterable[str], size: int = 1 << 16) -> Iterator[bytes]:
    """The UTF-8 bytes of ``pieces`` in blocks of about ``size`` characters."""
    buf: list[str] = []
    n = 0
    for p in pieces:
        buf.append(p)
        n += len(p)
        if n >= size:
            yield "".join(buf).encode("utf-8")
            buf.clear()
            n = 0
    if buf:
        yield "".join(buf).encode("utf-8")


def _write_file(fd: int, data: bytes) -> None:
    """Write all of ``data`` to the open file ``fd`` and close it."""
    with os.fdopen(fd, "wb") as f:
        f.write(data)

# ---------------------------------------------------------------------------- helpers
def _manifest_files(t: Path) -> set[str]:
    man = t / MANIFEST
    if not man.is_file() or man.is_symlink():
        return set()
    try:
        if man.stat().st_size > 64 << 20:
            return set()
        files = json.loads(man.read_text(encoding="utf-8")).get("files", [])
    except (OSError, ValueError, AttributeError):
        return set()
    if not isinstance(files, list):
        return set()
    return {str(f).strip("/") for f in files if isinstance(f, str)}


def _foreign_files(t: Path) -> list[str]:
    """Relative paths under ``t`` not written by torlab (not in its manifest), sorted.

    A listed folder (e.g. ``.cache``) covers everything in it; a file in a
    listed file's folder that is not itself listed is foreign.
    """
    owned = _manifest_files(t)
    out: list[str] = []

    def walk(d: Path, rel: str) -> None:
        try:
            entries = sorted(os.scandir(d), key=lambda e: e.name)
        except OSError:
            return
        for e in entries:
            r = f"{rel}{e.name}"
            if r == MANIFEST or r in owned:
                continue
            if e.is_dir(follow_symlinks=False) and any(o.startswith(r + "/") for o in owned):
                walk(Path(e.path), r + "/")
            else:
                out.append(r)

    walk(t, "")
    return out


def _copy_regular(src: Path, dst: Path, *, max_bytes: int = 1 << 30, depth: int = 8,
                  link: bool = False) -> None:
    """Copy regular files (a file, or a folder's tree) from ``src``; links and devices skipped.

    With ``link``, a file is hard-linked where the file system allows it (same device,
    the user's own file) and copied otherwise: for files that are only ever replaced,
    never written in place (the cache's entries), a link is a copy without the copying.
    """
    if depth < 0:
        return
    try:
        st = src.lstat()
    except OSError:
        return
    if stat.S_ISREG(st.st_mode):
        if st.st_size <= max_bytes:
            dst.parent.mkdir(parents=True, exist_ok=True)
            if link and _hard_link(src, dst, st):
                return
            shutil.copyfile(src, dst, follow_symlinks=False)
        return
    if stat.S_ISDIR(st.st_mode):
        for e in os.scandir(src):
            _copy_regular(Path(e.path), dst / e.name, max_bytes=max_bytes, depth=depth - 1,
                          link=link)


def _hard_link(src: Path, dst: Path, st: os.stat_result) -> bool:
    """Hard-link ``src`` (checked to be the regular file ``st``) as ``dst``; False if not."""
    try:
        os.link(src, dst, follow_symlinks=False)
    except (OSError, NotImplementedError):
        return False
    try:  # still the file that was checked (not swapped for a link or a device meanwhile)
        got = dst.lstat()
        if stat.S_ISREG(got.st_mode) and (got.st_ino, got.st_dev) == (st.st_ino, st.st_dev):
            return True
    except OSError:
        pass
    with contextlib.suppress(OSError):
        dst.unlink()
    return False


def _json_default(o: Any) -> Any:
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
