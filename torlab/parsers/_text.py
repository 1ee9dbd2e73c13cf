"""Shared helpers of the instrument parsers, over the reader layer
:mod:`torlab.parsers._table` (encodings, line ends, size bound, rows and cells).

* :func:`read_text` reads a path or buffer as text (UTF-8 with or without BOM,
  falling back to Windows-1252, which PCS software sometimes writes; UTF-16 with its
  BOM), with every line end normalised, and returns a display name for messages.
* The ``torlab-*`` log header: :func:`read_log_header`, :func:`parse_log_columns`,
  :func:`header_key` and the value helpers.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import IO, Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.parsers._table import (  # the one reader layer; number_field re-exported
    MAX_TEXT_BYTES,
    TextFile,
    number_field,
)

__all__ = ["MAX_TEXT_BYTES", "LogMetadata", "PathOrBuffer", "detect_delimiter", "header_key",
           "number_field", "parse_log_columns", "read_log_header",
           "read_text", "refuse_below_absolute_zero", "sign_value", "split_unit"]

PathOrBuffer = str | os.PathLike[str] | IO[str] | IO[bytes]


def read_text(src: PathOrBuffer, *, name: str | None = None) -> tuple[str, str]:
    """Read ``src`` (path, text buffer or bytes buffer) as text
    (:class:`torlab.parsers._table.TextFile`: encodings, line ends, size bound).

    Returns
    -------
    text, display_name
        ``text`` has ``\\n`` line ends and no BOM; ``display_name`` is the path
        or ``name`` or ``"<buffer>"`` for messages.

    Raises
    ------
    TorlabInputError
        File missing, a folder, not a regular file (a FIFO or ``/dev/zero``
        would block or never end), larger than :data:`MAX_TEXT_BYTES` (said
        before reading it), binary, or unreadable.
    """
    with TextFile(src, name=name) as tf:
        return tf.read_text(), tf.display


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


def as_path_str(p: Any) -> str:
    """``str`` of a path-like, for messages."""
    return os.fspath(p) if isinstance(p, (str, os.PathLike)) else str(p)


# ------------------------------------------------------------------ the torlab-* log formats
@dataclass
class LogMetadata:
    """What every ``torlab-*`` log header has (the instrument's metadata adds its keys).

    Attributes
    ----------
    source
        File name (for messages).
    format_version
        The version on the first line.
    run_id, operator, date, notes
        Free text of the header.
    columns
        torlab column -> the header cell it came from.
    extra
        User keys starting with ``x_`` (kept as text).
    lines
        Header key -> the file line it is on (for messages).
    """

    source: str = ""
    format_version: int = 1
    run_id: str = ""
    operator: str = ""
    date: str = ""
    notes: str = ""
    columns: dict[str, str] = field(default_factory=dict)
    extra: dict[str, str] = field(default_factory=dict)
    lines: dict[str, int] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (for JSON/YAML)."""
        return asdict(self)


def header_key(meta: LogMetadata, key: str, value: str, keys: dict[str, str], path: str,
               line: int | None, source: str = "header") -> str | None:
    """The kind of a header key (``keys[key]``), its line recorded; ``None`` for the user's
    own ``x_`` keys (kept in ``meta.extra``).

    Raises
    ------
    TorlabInputError
        An unknown key, with a suggestion.
    """
    from torlab._suggest import did_you_mean

    if key.startswith(("x_", "x-")):
        meta.extra[key] = value
        return None
    kind = keys.get(key)
    if kind is None:
        raise TorlabInputError(f"unknown {source} key {key!r}{did_you_mean(key, keys)} (known: "
                               f"{', '.join(keys)}; prefix your own keys with x_)", path=path,
                               line=line)
    meta.lines[key] = line or 0
    return kind


def sign_value(value: str, key: str, path: str, line: int | None) -> float:
    """A header sign: ``1``, ``+1`` or ``-1``."""
    if value not in ("1", "+1", "-1"):
        raise TorlabInputError(f"{key} must be 1 or -1, got {value!r}", path=path, line=line,
                               key=key)
    return float(value)


def choice_value(value: str, choices: Sequence[str], what: str, key: str, path: str,
                 line: int | None, *, sep: str = "_") -> str:
    """A header value that names one of ``choices`` (case, spaces and ``-``/``_`` free:
    ``Dry Traction`` is ``dry_traction``); an unknown one is refused with the known ones and
    "did you mean"."""
    from torlab._suggest import did_you_mean

    v = re.sub(r"[\s_-]+", sep, value.strip().lower())
    if v not in choices:
        raise TorlabInputError(f"unknown {what} {value!r} (known: {', '.join(choices)})"
                               f"{did_you_mean(v, choices)}", path=path, line=line, key=key)
    return v


def read_log_header(lines: list[str], fmt_id: str, fmt_version: int, display: str,
                    set_meta: Callable[[str, str, int], None], *, hint: str = "",
                    stop: int | None = None) -> tuple[int, int]:
    """Check a ``torlab-*`` log's first line and read its ``# key: value`` header.

    ``set_meta(key, value, line)`` takes each header line.  Returns the format
    version and the index of the column-header line.

    Raises
    ------
    TorlabInputError
        Another first line (``hint`` is added to the message), a newer
        version, a header line without ``key: value``, no column header.
    """
    first = lines[0].strip()
    if not first.startswith("#") or fmt_id not in first:
        raise TorlabInputError(f"not a {fmt_id} log: the first line must be '# {fmt_id} "
                               f"{fmt_version}'{hint}", path=display, line=1)
    try:
        version = int(first.split(fmt_id, 1)[1].strip() or fmt_version)
    except ValueError:
        raise TorlabInputError(f"bad format version in {first!r}", path=display, line=1) from None
    if version > fmt_version:
        raise TorlabInputError(f"{fmt_id} version {version} is newer than this torlab reads "
                               f"({fmt_version}); update torlab", path=display, line=1)
    for i in range(1, len(lines) if stop is None else stop):
        s = lines[i].strip()
        if not s:
            continue
        if not s.startswith("#"):
            return version, i
        body = s[1:].strip()
        if not body:
            continue
        if ":" not in body:
            raise TorlabInputError(f"header line must be '# key: value', got {s!r}",
                                   path=display, line=i + 1)
        k, v = body.split(":", 1)
        set_meta(k, v, i + 1)
    raise TorlabInputError("no column header line after the '#' header", path=display,
                           line=len(lines))


def parse_log_columns(header: str, columns: dict[str, tuple[Any, ...]], display: str,
                      line: int) -> dict[str, tuple[int, str]]:
    """Name -> (index, unit) of a ``torlab-*`` log's comma-separated column header.

    ``columns`` maps the known names to a tuple whose first item is the
    quantity kind (``"dimensionless"`` needs no unit); ``x_`` columns are the
    user's own and skipped.

    Raises
    ------
    TorlabInputError
        Another delimiter, an unnamed, unknown (with a suggestion) or repeated
        column, a missing unit.
    """
    from torlab._suggest import did_you_mean

    cells = header.split(",")
    if len(cells) == 1:
        other = detect_delimiter(header, ["\t", ";", "|"])
        if other is not None:
            raise TorlabInputError(f"columns are separated by {other!r}, expected ','",
                                   path=display, line=line)
    found: dict[str, tuple[int, str]] = {}
    for j, c in enumerate(cells):
        nm, unit = split_unit(c)
        if not nm:
            raise TorlabInputError(f"column {j + 1} has no name", path=display, line=line)
        if nm.startswith("x_"):
            continue
        if nm not in columns:
            raise TorlabInputError(f"unknown column {nm!r}{did_you_mean(nm, columns)} (known: "
                                   f"{', '.join(columns)}; prefix your own with x_)",
                                   path=display, line=line)
        if nm in found:
            raise TorlabInputError(f"column {nm!r} appears twice", path=display, line=line)
        if columns[nm][0] != "dimensionless" and not unit:
            raise TorlabInputError(f"column {nm!r} has no unit; write '{nm} [unit]'", path=display,
                                   line=line)
        found[nm] = (j, unit)
    return found


def refuse_below_absolute_zero(df: Any, display: str) -> None:
    """A temperature column (``*_C``) below -273.15 degC, or above the hottest temperature
    torlab takes for a measurement (``torlab.units.RANGES["temperature"]``, 2000 degC), is
    an error naming the line.

    Temperature columns are converted to degC from any unit (K, degF); a value
    below absolute zero or above that is a wrong unit or a broken cell, never a
    measurement.
    """
    from torlab.units import RANGES

    top = RANGES["temperature"].high
    for c in df.columns:
        if not str(c).endswith("_C"):
            continue
        v = df[c].to_numpy(dtype=float)
        bad = (v < -273.15 - 1e-9) | (v > top)
        if bad.any():
            i = int(np.argmax(bad))
            line = int(df["line"].iloc[i]) if "line" in df else None
            what = "is below absolute zero (-273.15 degC)" if v[i] < 0 else \
                f"is above {top:g} degC, which no test reaches"
            raise TorlabInputError(f"{v[i]:g} degC {what}; check the value and the column's "
                                   "unit", path=display, line=line, key=str(c))
