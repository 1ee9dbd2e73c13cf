"""Custom optical ball-on-disc tribometer logs: the ``torlab-optical`` CSV format.

The optical tribometer of thesis 5.1.1 drives a 25.4 mm steel ball and a glass
disc with separate servomotors, measures the normal load with a force
transducer, the friction with a torque transducer on the ball shaft at 1 kHz,
and the film thickness by colorimetric interferometry (at the camera's frame
rate).  ``torlab-optical`` is a self-describing CSV for such rigs, documented
with a complete example in ``docs/formats/optical.md``::

    # torlab-optical 1
    # ball_radius: 12.7 mm
    # surface: rough
    # lubricant: distilled water
    time [s],condition,ball_speed [m/s],disc_speed [m/s],normal_load [N],friction_force [N],film_thickness [nm]
    0.000,1,0.4750,0.5250,90.12,-3.412,
    ...

``condition`` numbers the set conditions (0 = between conditions); a log
without it must give set-point columns (``ball_speed_set``,
``disc_speed_set``, ``load_set``) whose changes mark the conditions.

Logs are long (30 minutes at 1 kHz = 1.8 M rows), so the reader works in
chunks: :func:`iter_optical_chunks` yields validated SI chunks with bounded
memory (the reduction in :mod:`torlab.reduce.optical` consumes them), and
:func:`read_optical` concatenates them for small logs.  A byte-level pass
first checks the field count of every row (a truncated row is an error, not a
row of missing values) and finds trailing blank or ``#`` lines.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.parsers._text import (
    _NUMBER_FIELD,
    LogMetadata,
    PathOrBuffer,
    choice_value,
    header_key,
    parse_log_columns,
    read_log_header,
    read_text,
    sign_value,
)

__all__ = [
    "COLUMNS",
    "FORMAT_ID",
    "METADATA_KEYS",
    "TEST_TYPES",
    "OpticalMetadata",
    "OpticalSource",
    "iter_optical_arrays",
    "iter_optical_chunks",
    "open_optical",
    "read_optical",
]

FORMAT_ID = "torlab-optical"
FORMAT_VERSION = 1

#: column -> (quantity kind, SI column name, may be empty)
COLUMNS: dict[str, tuple[str, str, bool]] = {
    "time": ("time", "time_s", False),
    "condition": ("dimensionless", "condition", False),
    "ball_speed": ("velocity", "ball_speed_m_s", False),
    "disc_speed": ("velocity", "disc_speed_m_s", False),
    "normal_load": ("force", "normal_load_N", False),
    "friction_force": ("force", "friction_force_N", False),
    "torque": ("torque", "torque_N_m", False),
    "film_thickness": ("length", "film_thickness_m", True),
    "temperature": ("temperature", "temperature_C", True),
    "ball_speed_set": ("velocity", "ball_speed_set_m_s", False),
    "disc_speed_set": ("velocity", "disc_speed_set_m_s", False),
    "load_set": ("force", "load_set_N", False),
}
SET_POINT_COLUMNS = ("ball_speed_set", "disc_speed_set", "load_set")

#: the test types of thesis Tab. 5.2
TEST_TYPES = ("dry_traction", "film_thickness", "stribeck", "traction")

#: header key -> kind ("text" for free text)
METADATA_KEYS: dict[str, str] = {
    "ball_radius": "length",
    "test": "text",
    "surface": "text",
    "lubricant": "text",
    "lubricant_viscosity": "viscosity",
    "friction_sign": "sign",
    "sample_rate": "frequency",
    "temperature": "temperature",
    "ball": "text",
    "disc": "text",
    "rig": "text",
    "run_id": "text",
    "operator": "text",
    "date": "text",
    "notes": "text",
}


@dataclass
class OpticalMetadata(LogMetadata):
    """Header of an optical tribometer log (SI, temperatures in degC)."""

    ball_radius: float | None = None
    test: str = ""
    surface: str = ""
    lubricant: str = ""
    lubricant_viscosity: float | None = None
    friction_sign: float = 1.0
    sample_rate: float | None = None
    temperature: float | None = None
    ball: str = ""
    disc: str = ""
    rig: str = ""


    @property
    def label(self) -> str:
        """Short label: run id or file name, surface, test."""
        parts = [self.run_id or Path(self.source).stem]
        if self.surface:
            parts.append(self.surface)
        return " ".join(parts)


@dataclass
class OpticalSource:
    """A log opened for chunked reading (see :func:`open_optical`)."""

    meta: OpticalMetadata
    path: str | None
    blob: bytes | None  # the text of a buffer, UTF-8 encoded
    header_line: int  # 1-based line of the column header
    ncol: int
    use: list[int]
    names: list[str]  # SI names of the used columns
    scales: list[float]
    offsets: list[float]
    may_be_empty: list[bool]
    cells: list[str]
    data_offset: int  # byte (path) or char (text) offset of the first data line
    data_end: int  # offset after the last data row (trailing blank and '#' lines excluded)


def _set_meta(meta: OpticalMetadata, key: str, value: str, path: str, line: int) -> None:
    from torlab.units import to_si

    key, value = key.strip(), value.strip()
    kind = header_key(meta, key, value, METADATA_KEYS, path, line)
    if kind is None:
        return
    if kind == "text":
        if key == "test":
            value = choice_value(value, TEST_TYPES, "test type", key, path, line)
        setattr(meta, key, value)
        return
    if kind == "sign":
        meta.friction_sign = sign_value(value, key, path, line)
        return
    v = to_si(value, kind, where=key, path=path, line=line)
    if key in _HEADER_RANGES:
        from torlab.units import check_range

        check_range(_HEADER_RANGES[key], v, where=key, path=path, line=line)
    setattr(meta, key, v)


#: header key -> plausible-range quantity (torlab.units.RANGES)
_HEADER_RANGES = {"ball_radius": "ball_radius", "temperature": "temperature",
                  "lubricant_viscosity": "viscosity"}


def open_optical(src: PathOrBuffer, *, name: str | None = None) -> OpticalSource:  # noqa: C901 (each way the rig writes its log is a case)
    """Read the header of a ``torlab-optical`` log and check its rows' field counts.

    Returns
    -------
    OpticalSource
        What :func:`iter_optical_chunks` needs.

    Raises
    ------
    TorlabInputError
        Empty file, bad first line, unknown header key or column, missing
        column, wrong delimiter, unknown unit, a row with the wrong number of
        fields, naming file and line.
    """
    from torlab.units import parse_unit_factor

    path: str | None = None
    text: str | None = None
    if isinstance(src, (str, os.PathLike)):
        path = os.fspath(src)
        display = name or path
        try:
            size = os.path.getsize(path)
        except FileNotFoundError:
            raise TorlabInputError("file not found", path=display) from None
        except OSError as e:
            raise TorlabInputError(f"cannot read ({e.strerror})", path=display) from None
        if os.path.isdir(path):
            raise TorlabInputError("is a folder, expected a file", path=display)
        from torlab.files import open_regular

        try:
            with open_regular(path) as f:
                head = f.read(min(size, 1 << 16))
        except TorlabInputError as e:
            raise TorlabInputError(e.message, path=display) from None
        if b"\x00" in head[:4096]:
            raise TorlabInputError("binary file, expected text", path=display)
        head_text, _ = read_text(io.BytesIO(head), name=display)
        if not head_text.strip():
            raise TorlabInputError("file is empty", path=display)
        hlines = head_text.split("\n")
    else:
        text, display = read_text(src, name=name)
        if not text.strip():
            raise TorlabInputError("file is empty", path=display)
        hlines = text.split("\n")
    meta = OpticalMetadata(source=display)
    meta.format_version, hi = read_log_header(
        hlines, FORMAT_ID, FORMAT_VERSION, display,
        lambda k, v, ln: _set_meta(meta, k, v, display, ln),
        hint=" (PCS EHD2 exports are read too)",
        stop=len(hlines) - (0 if text is not None else 1))
    header_line = hi + 1
    header = hlines[hi]
    cells = header.split(",")
    found = parse_log_columns(header, COLUMNS, display, header_line)
    for req in ("time", "ball_speed", "disc_speed", "normal_load"):
        if req not in found:
            raise TorlabInputError(f"missing column {req!r}", path=display, line=header_line)
    if "condition" not in found and not any(s in found for s in SET_POINT_COLUMNS):
        raise TorlabInputError("missing column 'condition' (or set-point columns ball_speed_set, "
                               "disc_speed_set, load_set) to tell the set conditions apart",
                               path=display, line=header_line)
    if not any(c in found for c in ("friction_force", "torque", "film_thickness")):
        raise TorlabInputError("missing column: need 'friction_force' or 'torque' (and/or "
                               "'film_thickness')", path=display, line=header_line)
    if "friction_force" in found and "torque" in found:
        raise TorlabInputError("give either 'friction_force' or 'torque', not both", path=display,
                               line=header_line)
    if "torque" in found and meta.ball_radius is None:
        raise TorlabInputError("a torque column needs the 'ball_radius' header (mu = torque / "
                               "(ball radius x load))", path=display, line=header_line)
    use, names, scales, offsets, empty = [], [], [], [], []
    for nm, (j, unit) in sorted(found.items(), key=lambda kv: kv[1][0]):
        kind, si, may_empty = COLUMNS[nm]
        sc, off = parse_unit_factor(unit, kind, where=f"column {nm!r}", path=display,
                                    line=header_line) if unit else (1.0, 0.0)
        use.append(j)
        names.append(si)
        scales.append(sc)
        offsets.append(off)
        empty.append(may_empty)
        meta.columns[si] = cells[j].strip()
    ncol = len(cells)
    blob = None if text is None else text.encode("utf-8")
    with _open_binary(path, blob) as f:
        offset, end = _data_range(f, header_line, display)
    if end <= offset:
        raise TorlabInputError("no data rows after the column header", path=display,
                               line=header_line)
    return OpticalSource(meta=meta, path=path, blob=blob, header_line=header_line, ncol=ncol,
                         use=use, names=names, scales=scales, offsets=offsets, may_be_empty=empty,
                         cells=[c.strip() for c in cells], data_offset=offset, data_end=end)


def _trailing(tail: bytes) -> int:
    """Bytes at the end of ``tail`` taken by trailing blank and '#' lines."""
    lines = tail.split(b"\n")
    n = len(tail)
    cut = n
    # the part after the last newline, then whole lines backwards
    for k in range(len(lines) - 1, -1, -1):
        ln = lines[k]
        s = ln.strip()
        if s == b"" or s.startswith(b"#"):
            cut -= len(ln) + (1 if k < len(lines) - 1 else 0)
            continue
        break
    return n - max(cut, 0)


def _open_binary(path: str | None, blob: bytes | None) -> Any:
    return open(path, "rb") if path is not None else io.BytesIO(blob or b"")


def _data_range(f: Any, header_line: int, display: str) -> tuple[int, int]:
    """Byte offsets of the first data row and of the end of the last one."""
    for _ in range(header_line):
        if not f.readline():
            raise TorlabInputError("no data rows after the column header", path=display,
                                   line=header_line)
    offset = f.tell()
    size = f.seek(0, os.SEEK_END)
    tail_len = min(size - offset, 1 << 16)
    f.seek(size - tail_len)
    tail = f.read(tail_len)
    return offset, size - _trailing(tail)


class _CountingReader(io.RawIOBase):
    """Reads ``[start, end)`` of a binary stream and counts the commas it hands out."""

    def __init__(self, f: Any, start: int, end: int) -> None:
        self.f = f
        self.f.seek(start)
        self.left = end - start
        self.commas = 0

    def readable(self) -> bool:
        return True

    def read(self, n: int = -1) -> bytes:
        if self.left <= 0:
            return b""
        n = self.left if n is None or n < 0 else min(n, self.left)
        data = self.f.read(n)
        self.left -= len(data)
        self.commas += data.count(b",")
        return data

    def readinto(self, b: Any) -> int:
        data = self.read(len(b))
        b[: len(data)] = data
        return len(data)


def _find_bad_field_count(f: Any, first_line: int, n_rows: int, ncol: int, display: str,
                          cells: list[str]) -> None:
    for i in range(n_rows):
        line = f.readline()
        if not line:
            break
        line = line.rstrip("\r\n")
        k = line.count(",") + 1
        if k != ncol:
            if not line.strip():
                raise TorlabInputError("blank line between data rows", path=display,
                                       line=first_line + i)
            hint = " (truncated row?)" if k < ncol else ""
            raise TorlabInputError(f"expected {ncol} fields separated by ',', found {k}{hint}",
                                   path=display, line=first_line + i)
    raise TorlabInputError("the rows do not have the header's number of fields", path=display)


def iter_optical_chunks(src: OpticalSource, chunksize: int = 250_000) -> Iterator[Any]:
    """Yield the data as validated pandas DataFrames of at most ``chunksize`` rows.

    Columns are the SI names of :data:`COLUMNS` present in the log plus
    ``line`` (file line of each row).  Required values must be finite;
    ``film_thickness`` and ``temperature`` may be empty (NaN); ``condition``
    must be a whole number >= 0; the load must be positive; time must increase.

    Raises
    ------
    TorlabInputError
        Naming the file, line and column of the first bad value.
    """
    import pandas as pd

    for cols in iter_optical_arrays(src, chunksize):
        yield pd.DataFrame(cols)


def iter_optical_arrays(src: OpticalSource, chunksize: int = 250_000) -> Iterator[dict[str, Any]]:
    """As :func:`iter_optical_chunks`, yielding dicts of numpy arrays (no DataFrame)."""
    import pandas as pd

    display = src.meta.source
    first_line = src.header_line + 1
    raw = _open_binary(src.path, src.blob)
    counter = _CountingReader(raw, src.data_offset, src.data_end)
    try:
        reader = pd.read_csv(
            io.BufferedReader(counter, buffer_size=1 << 20), sep=",", header=None,
            names=list(range(src.ncol)), usecols=src.use,
            dtype=dict.fromkeys(src.use, np.float64), engine="c", chunksize=chunksize,
            skip_blank_lines=False, keep_default_na=False, na_values=[""], quoting=3,
            encoding="utf-8", encoding_errors="replace")
        done = 0
        t_prev = -math.inf
        while True:
            try:
                chunk = next(reader)
            except StopIteration:
                break
            except Exception:  # text in a number column, too many fields: find the exact line
                _rescan(src, done, chunksize)
                raise TorlabInputError("unreadable rows", path=display,
                                       line=first_line + done) from None
            n = len(chunk)
            first = first_line + done
            out: dict[str, Any] = {}
            for k, j in enumerate(src.use):
                v = chunk[j].to_numpy(dtype=np.float64)
                _validate_column(v, k, src, first)
                if src.scales[k] != 1.0 or src.offsets[k] != 0.0:
                    v = v * src.scales[k] + src.offsets[k]
                out[src.names[k]] = v
            t = out["time_s"]
            if t[0] <= t_prev or (n > 1 and not (t[1:] > t[:-1]).all()):
                d = np.diff(t, prepend=t_prev)
                i = int(np.argmax(d <= 0))
                raise TorlabInputError("time does not increase", path=display, line=first + i,
                                       key="time")
            t_prev = float(t[-1])
            out["line"] = np.arange(first, first + n)
            done += n
            yield out
        if counter.commas != done * (src.ncol - 1):
            _field_count_error(src, done)
    finally:
        raw.close()


def _field_count_error(src: OpticalSource, n_rows: int) -> None:
    """A row has the wrong number of fields somewhere: name it (raises)."""
    f = io.TextIOWrapper(_open_binary(src.path, src.blob), encoding="utf-8", errors="replace",
                         newline=None)
    try:
        for _ in range(src.header_line):
            f.readline()
        _find_bad_field_count(f, src.header_line + 1, n_rows, src.ncol, src.meta.source,
                              src.cells)
    finally:
        f.close()


def _validate_column(v: np.ndarray, k: int, src: OpticalSource, first: int) -> None:
    """Finite values (NaN allowed where the column may be empty) and per-column rules."""
    display = src.meta.source
    cell = src.cells[src.use[k]]
    name = src.names[k]
    if not np.isfinite(v).all():
        bad = ~np.isfinite(v)
        if src.may_be_empty[k]:
            bad &= ~np.isnan(v)
        if bad.any():
            i = int(np.argmax(bad))
            msg = "empty value" if np.isnan(v[i]) else f"{v[i]:g} is not a finite number"
            raise TorlabInputError(msg, path=display, line=first + i, key=f"column {cell!r}")
    if name == "normal_load_N":
        if not (v > 0).all():
            i = int(np.argmax(~(v > 0)))
            raise TorlabInputError(f"normal load must be positive, got {v[i]:g}", path=display,
                                   line=first + i, key="normal_load")
    elif name == "load_set_N":
        if (v < 0).any():
            i = int(np.argmax(v < 0))
            raise TorlabInputError(f"a load set point cannot be negative, got {v[i]:g} N",
                                   path=display, line=first + i, key="load_set")
    elif name == "temperature_C":
        below = v < -273.15 - 1e-9  # NaN (an empty cell) compares False
        if below.any():
            i = int(np.argmax(below))
            raise TorlabInputError(f"{v[i]:g} degC is below absolute zero (-273.15 degC); "
                                   "check the value and the column's unit", path=display,
                                   line=first + i, key="temperature")
    elif name == "condition":
        badc = (v < 0) | (v != np.floor(v))
        if badc.any():
            i = int(np.argmax(badc))
            raise TorlabInputError(f"condition must be a whole number >= 0, got {v[i]:g}",
                                   path=display, line=first + i, key="condition")


def _rescan(src: OpticalSource, done: int, chunksize: int) -> None:
    """Find the first bad field among the rows of the failed chunk (raises)."""
    first = src.header_line + 1 + done
    f = io.TextIOWrapper(_open_binary(src.path, src.blob), encoding="utf-8", errors="replace",
                         newline=None)
    try:
        for _ in range(src.header_line + done):
            f.readline()
        for i in range(chunksize):
            row = f.readline()
            if not row:
                break
            fields = row.rstrip("\r\n").split(",")
            if len(fields) != src.ncol:
                raise TorlabInputError(f"expected {src.ncol} fields separated by ',', found "
                                       f"{len(fields)}", path=src.meta.source, line=first + i)
            for k, j in enumerate(src.use):
                s = fields[j].strip(" \t")
                if not s and src.may_be_empty[k]:
                    continue
                if not _NUMBER_FIELD.fullmatch(s):
                    raise TorlabInputError(f"{s!r} is not a number" if s else "empty value",
                                           path=src.meta.source, line=first + i,
                                           key=f"column {src.cells[j]!r}")
                v = float(s)
                if not math.isfinite(v):
                    raise TorlabInputError(f"{s!r} is not a finite number", path=src.meta.source,
                                           line=first + i, key=f"column {src.cells[j]!r}")
    finally:
        f.close()


def read_optical(src: PathOrBuffer, *, name: str | None = None) -> tuple[Any, OpticalMetadata]:
    """Read a whole ``torlab-optical`` log (for long logs use the chunked reduction).

    Returns
    -------
    df : pandas.DataFrame
        SI columns ``time_s``, ``condition`` (or set-point columns),
        ``ball_speed_m_s``, ``disc_speed_m_s``, ``normal_load_N``,
        ``friction_force_N`` or ``torque_N_m``, ``film_thickness_m`` (NaN where
        no frame), ``temperature_C``, and ``line``.
    meta : OpticalMetadata
    """
    import pandas as pd

    src_ = open_optical(src, name=name)
    chunks = list(iter_optical_chunks(src_))
    return pd.concat(chunks, ignore_index=True), src_.meta
