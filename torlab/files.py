"""Safe file access, the lowest layer of torlab's input and output.

Every reader of a user's file and every writer of a result goes through these few
functions, which import nothing of torlab but its errors:

* :func:`open_regular` opens a file for reading and refuses what is not a regular file
  (a FIFO would block, ``/dev/zero`` never ends);
* :func:`sha256_file` hashes one (:func:`sha256_file_cached` memoised on its path,
  modification time and size, for the content keys of the protocol cache and figures);
* :func:`atomic_write_bytes` and :func:`atomic_write_text` replace one file atomically
  (a temporary file and ``os.replace``);
* :func:`safe_name` makes a file-name part from user text;
* :func:`writing` turns an operating-system write failure into an
  :class:`~torlab.errors.OutputWriteError` naming the place (exit code 2).

Whole results folders (locked, staged, swapped into place) are
:class:`torlab.outputs.OutputDir`, built on these.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import stat
import tempfile
from collections.abc import Iterator
from functools import cache
from pathlib import Path
from typing import BinaryIO

from torlab.errors import OutputWriteError, TorlabInputError

__all__ = [
    "atomic_write_bytes",
    "atomic_write_text",
    "open_regular",
    "plain_name",
    "safe_name",
    "sha256_file",
    "sha256_file_cached",
    "writing",
]


def sha256_file(path: str | os.PathLike[str], chunk: int = 1 << 20) -> str:
    """Hex SHA-256 of a regular file's bytes.

    Raises
    ------
    TorlabInputError
        ``path`` is not a regular file (a FIFO or a device such as ``/dev/zero``
        would block or never end).
    """
    h = hashlib.sha256()
    with open_regular(path) as f:
        while b := f.read(chunk):
            h.update(b)
    return h.hexdigest()


@cache
def _sha(path: str, mtime_ns: int, size: int) -> str:
    return sha256_file(path)


def sha256_file_cached(path: str | os.PathLike[str]) -> str:
    """:func:`sha256_file`, memoised on the path, modification time and size (a file
    hashed again in one process, such as a figure module's source, is read once)."""
    st = Path(path).stat()
    return _sha(str(Path(path).resolve()), st.st_mtime_ns, st.st_size)


def open_regular(path: str | os.PathLike[str]) -> BinaryIO:
    """Open ``path`` for binary reading, refusing anything that is not a regular file.

    The file is opened without blocking (a FIFO with no writer would otherwise
    hang the open) and checked with ``fstat`` on the open descriptor, so a path
    swapped between a check and the open cannot slip through.

    Raises
    ------
    TorlabInputError
        Missing, a folder, a device, FIFO or socket, or unreadable.
    """
    p = os.fspath(path)
    nonblock = getattr(os, "O_NONBLOCK", 0)
    flags = os.O_RDONLY | nonblock | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(p, flags)
    except FileNotFoundError:
        raise TorlabInputError("file not found", path=p) from None
    except IsADirectoryError:
        raise TorlabInputError("is a folder, expected a file", path=p) from None
    except OSError as e:
        raise TorlabInputError(f"cannot read ({e.strerror})", path=p) from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise TorlabInputError("is a folder, expected a file", path=p)
        if not stat.S_ISREG(st.st_mode):
            raise TorlabInputError("not a regular file (a device, FIFO or socket); give a file",
                                   path=p)
        if nonblock:
            os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file and ``os.replace``."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write UTF-8 ``text`` atomically (see :func:`atomic_write_bytes`)."""
    atomic_write_bytes(path, text.encode("utf-8"))


_UNSAFE = re.compile(r"[^A-Za-z0-9._+=@,-]+")


def safe_name(text: str, *, max_len: int = 80) -> str:
    """A file-name part made from user text (a product name, a label).

    Path separators, ``..``, leading dots, spaces and control characters become
    ``_``, so a product called ``../../x`` cannot name a file outside the output
    folder; an empty result becomes ``_``.
    """
    s = _UNSAFE.sub("_", str(text)).strip("._") or "_"
    return s[:max_len]


_PLAIN = re.compile(r"[^A-Za-z0-9._-]+")


def plain_name(text: str, *, max_len: int = 80) -> str:
    """A file-name part made from a label that a report links to as it is: letters,
    digits, ``.``, ``_`` and ``-`` only (nothing Markdown or HTML would escape), other
    runs of characters ``_``, at most ``max_len`` characters (a label of any length makes
    a name a file system takes)."""
    s = _PLAIN.sub("_", str(text)).strip("._") or "_"
    return s[:max_len]


_ENV_ERRNOS = {errno.ENOSPC: "no space left on the device",
               errno.EDQUOT: "disk quota exceeded",
               errno.EROFS: "read-only file system",
               errno.EACCES: "permission denied",
               errno.EPERM: "operation not permitted",
               errno.EFBIG: "file too large for this file system or limit"}


@contextlib.contextmanager
def writing(where: str | os.PathLike[str]) -> Iterator[None]:
    """Turn an operating-system write failure into an :class:`OutputWriteError`."""
    try:
        yield
    except OSError as e:
        if isinstance(e, (FileNotFoundError, IsADirectoryError, NotADirectoryError)) and \
                e.errno not in _ENV_ERRNOS:
            raise OutputWriteError(f"cannot write the results ({e.strerror}); was the output "
                                   "folder moved or changed during the run?", path=where) from None
        reason = _ENV_ERRNOS.get(e.errno or 0, e.strerror or type(e).__name__)
        raise OutputWriteError(f"cannot write the results: {reason}", path=where) from None
