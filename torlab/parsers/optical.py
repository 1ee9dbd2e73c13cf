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
:func:`read_optical` concatenates them for small logs.  The rows are read by the
reader layer (:mod:`torlab.parsers._table`): every row's field count is checked
before the first chunk (a truncated row is an error, not a row of missing values),
line ends are the same for the header and the data.
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
from torlab.parsers._table import RowSpec, TextFile, iter_column_blocks
from torlab.parsers._text import (
    LogMetadata,
    PathOrBuffer,
    choice_value,
    header_key,
    parse_log_columns,
    read_log_header,
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
    blob: bytes | None  # the bytes of a buffer
    header_line: int  # 1-based line of the column header
    names: list[str]  # SI names of the used columns
    spec: RowSpec  # the data rows (torlab.parsers._table)

    def open(self) -> TextFile:
        """The log as a :class:`~torlab.parsers._table.TextFile`."""
        src: Any = self.path if self.path is not None else io.BytesIO(self.blob or b"")
        return TextFile(src, name=self.meta.source)


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


def open_optical(src: PathOrBuffer, *, name: str | None = None) -> OpticalSource:
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
    blob: bytes | None = None
    if isinstance(src, (str, os.PathLike)):
        path = os.fspath(src)
        tf = TextFile(path, name=name)
    else:
        raw = src.read()
        blob = raw.encode("utf-8", "surrogatepass") if isinstance(raw, str) else raw
        tf = TextFile(io.BytesIO(blob), name=name or getattr(src, "name", None))
    with tf:
        display = tf.display
        hlines = tf.head(lambda ln, s: ln > 1 and bool(s.strip())
                         and not s.lstrip().startswith("#"))
    if not any(s.strip() for s in hlines):
        raise TorlabInputError("file is empty", path=display)
    meta = OpticalMetadata(source=display)
    meta.format_version, hi = read_log_header(
        hlines, FORMAT_ID, FORMAT_VERSION, display,
        lambda k, v, ln: _set_meta(meta, k, v, display, ln),
        hint=" (PCS EHD2 exports are read too)")
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
    use, names, scales, offsets, empty, units = [], [], [], [], [], []
    for nm, (j, unit) in sorted(found.items(), key=lambda kv: kv[1][0]):
        kind, si, may_empty = COLUMNS[nm]
        sc, off = parse_unit_factor(unit, kind, where=f"column {nm!r}", path=display,
                                    line=header_line) if unit else (1.0, 0.0)
        use.append(j)
        names.append(si)
        scales.append(sc)
        offsets.append(off)
        empty.append(may_empty)
        units.append(unit)
        meta.columns[si] = cells[j].strip()
    spec = RowSpec([c.strip() for c in cells], use, display, allow_empty=empty, scales=scales,
                   offsets=offsets, units=units, hint=" (torlab-optical logs use '.')")
    return OpticalSource(meta=meta, path=path, blob=blob, header_line=header_line, names=names,
                         spec=spec)


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
    display = src.meta.source
    t_prev = -math.inf
    with src.open() as tf:
        for first, cols in iter_column_blocks(tf, src.header_line + 1, src.spec):
            n_block = len(cols[0])
            for s0 in range(0, n_block, chunksize):
                n = min(chunksize, n_block - s0)
                out = {nm: v[s0: s0 + n] for nm, v in zip(src.names, cols, strict=True)}
                first_row = first + s0
                for nm in src.names:
                    _validate_column(out[nm], nm, first_row, display)
                t = out["time_s"]
                if t[0] <= t_prev or (n > 1 and not (t[1:] > t[:-1]).all()):
                    d = np.diff(t, prepend=t_prev)
                    i = int(np.argmax(d <= 0))
                    raise TorlabInputError("time does not increase", path=display,
                                           line=first_row + i, key="time")
                t_prev = float(t[-1])
                out["line"] = np.arange(first_row, first_row + n)
                yield out


#: SI column -> (largest magnitude a test produces, what, unit shown, its scale): beyond it a
#: value is a broken cell or a wrong unit (the speed, load and temperature of
#: ``torlab.units.RANGES``; no interferometer measures a film of a millimetre)
_LARGEST: dict[str, tuple[float, str, str, float]] = {
    **dict.fromkeys(("ball_speed_m_s", "disc_speed_m_s", "ball_speed_set_m_s",
                     "disc_speed_set_m_s"), (1e3, "a speed", "m/s", 1.0)),
    **dict.fromkeys(("normal_load_N", "load_set_N", "friction_force_N"),
                    (1e8, "a force", "N", 1.0)),
    "temperature_C": (2000.0, "a temperature", "degC", 1.0),
    "film_thickness_m": (1e-3, "a film thickness", "nm", 1e-9),
}


def _validate_column(v: np.ndarray, name: str, first: int, display: str) -> None:
    """The per-column rules (finite values and empty cells: the reader layer)."""
    if name in _LARGEST:
        top, what, unit, scale = _LARGEST[name]
        big = np.abs(v) > top  # NaN (an empty cell) compares False
        if big.any():
            i = int(np.argmax(big))
            raise TorlabInputError(f"{v[i] / scale:g} {unit} is not possible for {what} (at most "
                                   f"{top / scale:g} {unit} in magnitude); check the value and "
                                   "the column's unit", path=display, line=first + i,
                                   key=name.removesuffix("_m_s").removesuffix("_N")
                                   .removesuffix("_C").removesuffix("_m"))
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
