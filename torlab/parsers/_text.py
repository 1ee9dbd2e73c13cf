"""Shared low-level helpers of the instrument parsers.

* :func:`read_text` reads a path or buffer as text (UTF-8 with or without BOM,
  falling back to Windows-1252, which PCS software sometimes writes), with
  CRLF/LF line ends normalised, and returns a display name for messages.
* :func:`parse_numeric_rows` turns delimited text rows into a float array,
  fast (pandas' C parser) when the rows are clean and, when they are not,
  re-scans them to report the first bad line exactly (truncated row, text in a
  number column, wrong field count, NaN).
"""

from __future__ import annotations

import io
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any

import numpy as np

from torlab.errors import TorlabInputError

_NUMBER_FIELD = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan)",
                           re.IGNORECASE)

__all__ = ["PathOrBuffer", "detect_delimiter", "parse_numeric_rows", "read_text",
           "refuse_below_absolute_zero", "split_unit"]

PathOrBuffer = str | os.PathLike[str] | IO[str] | IO[bytes]

#: largest text input read (bytes); a path must be a regular file (no FIFO or device)
MAX_TEXT_BYTES = 1 << 30


def read_text(src: PathOrBuffer, *, name: str | None = None) -> tuple[str, str]:
    """Read ``src`` (path, text buffer or bytes buffer) as text.

    Returns
    -------
    text, display_name
        ``text`` has ``\\n`` line ends and no BOM; ``display_name`` is the path
        or ``name`` or ``"<buffer>"`` for messages.

    Raises
    ------
    TorlabInputError
        File missing, a folder, not a regular file (a FIFO or ``/dev/zero``
        would block or never end), larger than :data:`MAX_TEXT_BYTES`, or
        unreadable.
    """
    if isinstance(src, (str, os.PathLike)):
        from torlab.outputs import open_regular

        p = Path(src)
        display = name or str(p)
        try:
            with open_regular(p) as f:
                raw = f.read(MAX_TEXT_BYTES + 1)
        except TorlabInputError as e:
            raise TorlabInputError(e.message, path=display) from None
        except OSError as e:
            raise TorlabInputError(f"cannot read ({e.strerror})", path=display) from None
        if len(raw) > MAX_TEXT_BYTES:
            raise TorlabInputError(f"larger than {MAX_TEXT_BYTES >> 20} MiB; torlab reads "
                                   "instrument logs up to that size", path=display)
    else:
        display = name or getattr(src, "name", None) or "<buffer>"
        raw = src.read()
    if isinstance(raw, bytes):
        if b"\x00" in raw[:4096]:
            raise TorlabInputError("binary file, expected text", path=display)
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError:
            text = raw.decode("cp1252", errors="replace")
    else:
        text = raw.removeprefix("\ufeff")
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text, str(display)


def split_unit(header: str) -> tuple[str, str]:
    """Split ``"name [unit]"`` or ``"name (unit)"`` into ``(name, unit)``."""
    h = header.strip()
    for open_, close in (("[", "]"), ("(", ")")):
        if h.endswith(close) and open_ in h:
            i = h.rindex(open_)
            return h[:i].strip(), h[i + 1 : -1].strip()
    return h, ""


def detect_delimiter(line: str, candidates: Sequence[str] = (",", "\t", ";", "|")) -> str | None:
    """The candidate delimiter occurring most often in ``line`` (None if none)."""
    best, count = None, 0
    for d in candidates:
        c = line.count(d)
        if c > count:
            best, count = d, c
    return best


def parse_numeric_rows(
    lines: Sequence[str],
    first_line_no: int,
    columns: Sequence[str],
    *,
    path: str,
    delimiter: str = ",",
    decimal: str = ".",
    use: Sequence[int] | None = None,
    allow_empty: Sequence[bool] | None = None,
) -> np.ndarray:
    """Parse delimited numeric rows into an ``(n_rows, n_used)`` float array.

    Parameters
    ----------
    lines
        The data lines (no header), without line ends.  Blank lines at the end
        are ignored; a blank line in the middle is an error.
    first_line_no
        1-based file line number of ``lines[0]`` (for messages).
    columns
        Names of all fields in a row (for messages and the field count).
    path
        File name for messages.
    delimiter, decimal
        Field separator and decimal mark.
    use
        Indices of the fields to return (default: all).
    allow_empty
        Per returned column, whether an empty field is allowed (read as NaN).

    Raises
    ------
    TorlabInputError
        Naming the file, the 1-based line and the column, for the first bad
        field: wrong number of fields (a truncated row), text in a number
        column, NaN or infinity, a blank line between rows.
    """
    ncol = len(columns)
    use = list(range(ncol)) if use is None else list(use)
    allow_empty = [False] * len(use) if allow_empty is None else list(allow_empty)
    n = len(lines)
    while n and not lines[n - 1].strip():
        n -= 1
    lines = lines[:n]
    if n == 0:
        return np.empty((0, len(use)))
    body = "\n".join(lines)
    arr = None
    try:
        import pandas as pd

        df = pd.read_csv(io.StringIO(body), sep=delimiter, decimal=decimal, header=None,
                         names=list(range(ncol)), usecols=use, dtype=float, engine="c",
                         skip_blank_lines=False, na_filter=True, keep_default_na=False,
                         na_values=[""])
        arr = df[use].to_numpy(dtype=float)
        if arr.shape[0] != n:
            arr = None
    except Exception:  # any parser complaint: the exact scan below names the line
        arr = None
    if arr is not None:
        bad_nan = ~np.isfinite(arr)
        if allow_empty and any(allow_empty):
            bad_nan &= ~(np.isnan(arr) & np.asarray(allow_empty)[None, :])
        # pandas pads a short (truncated) row with NaN: with no empty field allowed the
        # NaN check catches it, otherwise count the fields
        if not bad_nan.any() and (not any(allow_empty) or _field_counts_ok(lines, delimiter, ncol)):
            return arr
    _scan_for_error(lines, first_line_no, columns, path=path, delimiter=delimiter,
                    decimal=decimal, use=use, allow_empty=allow_empty)
    raise AssertionError("unreachable: scan found no error")  # pragma: no cover


def _field_counts_ok(lines: Sequence[str], delimiter: str, ncol: int) -> bool:
    return all(line.count(delimiter) == ncol - 1 for line in lines)


def _scan_for_error(lines: Sequence[str], first_line_no: int, columns: Sequence[str], *,
                    path: str, delimiter: str, decimal: str, use: Sequence[int],
                    allow_empty: Sequence[bool]) -> None:
    ncol = len(columns)
    for i, line in enumerate(lines):
        ln = first_line_no + i
        if not line.strip():
            raise TorlabInputError("blank line between data rows", path=path, line=ln)
        fields = line.split(delimiter)
        if len(fields) != ncol:
            hint = " (truncated row?)" if len(fields) < ncol else ""
            raise TorlabInputError(f"expected {ncol} fields separated by {delimiter!r}, found "
                                   f"{len(fields)}{hint}", path=path, line=ln)
        for j, ae in zip(use, allow_empty, strict=True):
            f = fields[j].strip(" \t")
            if not f:
                if ae:
                    continue
                raise TorlabInputError("empty value", path=path, line=ln, key=f"column {columns[j]!r}")
            g = f.replace(decimal, ".") if decimal != "." else f
            if not _NUMBER_FIELD.fullmatch(g):  # float() would accept '1_0' or control characters
                raise TorlabInputError(f"{f!r} is not a number", path=path, line=ln,
                                       key=f"column {columns[j]!r}")
            v = float(g)
            if not np.isfinite(v):
                raise TorlabInputError(f"{f!r} is not a finite number", path=path, line=ln,
                                       key=f"column {columns[j]!r}")


def as_path_str(p: Any) -> str:
    """``str`` of a path-like, for messages."""
    return os.fspath(p) if isinstance(p, (str, os.PathLike)) else str(p)


def refuse_below_absolute_zero(df: Any, display: str) -> None:
    """A temperature column (``*_C``) below -273.15 degC is an error naming the line.

    Temperature columns are converted to degC from any unit (K, degF); a value
    below absolute zero is a wrong unit or a broken cell, never a measurement.
    """
    for c in df.columns:
        if not str(c).endswith("_C"):
            continue
        v = df[c].to_numpy(dtype=float)
        bad = v < -273.15 - 1e-9
        if bad.any():
            i = int(np.argmax(bad))
            line = int(df["line"].iloc[i]) if "line" in df else None
            raise TorlabInputError(f"{v[i]:g} degC is below absolute zero (-273.15 degC); "
                                   "check the value and the column's unit", path=display,
                                   line=line, key=str(c))
