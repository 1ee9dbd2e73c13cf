"""Falling-body high-pressure viscometer logs: the ``torlab-visc`` format.

The viscometer of thesis 5.1.5 lets a body (sinker or ball) fall through the
liquid in a pressurised cartridge (up to 0.3 GPa) and records its position with
an LVDT.  ``torlab-visc`` is a self-describing CSV for such logs, documented with
a complete example in ``docs/formats/viscometer.md``::

    # torlab-visc 1
    # liquid: synthetic ester base oil
    # liquid_density: 960 kg/m^3
    # body_density: 7850 kg/m^3
    # calibration_constant: 1.9e-8 m^3/s^2
    time [s],position [mm],pressure [MPa],temperature [degC]
    0.0,0.0003,0.10,25.01
    ...

The position increases as the body falls (``position_sign: -1`` flips an LVDT
that reads the other way).  Falls are found automatically (see
:mod:`torlab.reduce.viscometer`), or numbered in an optional ``fall`` column
(0 = not a fall).  A log of a *reference liquid* gives its known viscosity in
``reference_viscosity``; it calibrates ``calibration_constant`` for the sample
logs.

:func:`read_viscometer` returns ``(DataFrame, ViscometerMetadata)`` with SI
columns ``time_s``, ``position_m``, ``pressure_Pa``, ``temperature_C`` (where
logged), ``fall`` (where logged) and ``line``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.parsers._text import (
    LogMetadata,
    PathOrBuffer,
    choice_value,
    header_key,
    parse_log_columns,
    read_log_header,
    refuse_below_absolute_zero,
    sign_value,
)

__all__ = ["COLUMNS", "DENSITY_MODELS", "FORMAT_ID", "METADATA_KEYS", "ViscometerMetadata",
           "parse_calibration_constant", "read_viscometer"]

FORMAT_ID = "torlab-visc"
FORMAT_VERSION = 1

#: column -> (kind, SI name, required)
COLUMNS: dict[str, tuple[str, str, bool]] = {
    "time": ("time", "time_s", True),
    "position": ("length", "position_m", True),
    "pressure": ("pressure", "pressure_Pa", True),
    "temperature": ("temperature", "temperature_C", False),
    "fall": ("dimensionless", "fall", False),
}

#: liquid density against pressure
DENSITY_MODELS = ("constant", "dowson-higginson")

#: header key -> kind ("text" free text; "calibration" m^3/s^2)
METADATA_KEYS: dict[str, str] = {
    "liquid": "text",
    "liquid_density": "density",
    "density_model": "text",
    "body": "text",
    "body_density": "density",
    "calibration_constant": "calibration",
    "reference_viscosity": "viscosity",
    "temperature": "temperature",
    "position_sign": "sign",
    "fall_distance": "length",
    "run_id": "text",
    "operator": "text",
    "date": "text",
    "notes": "text",
}


@dataclass
class ViscometerMetadata(LogMetadata):
    """Header of a viscometer log (SI units, temperatures in degC).

    Attributes
    ----------
    liquid_density
        Density of the liquid at atmospheric pressure (kg/m^3).
    density_model
        ``"constant"`` or ``"dowson-higginson"`` (see
        :func:`torlab.reduce.viscometer.liquid_density`).
    body_density
        Density of the falling body (kg/m^3).
    calibration_constant
        ``K`` of ``eta = K (rho_body - rho_liquid) / v`` (m^3/s^2), if known.
    reference_viscosity
        Known viscosity of a reference liquid (Pa s): the log calibrates ``K``.
    position_sign
        +1 when the position increases as the body falls, -1 otherwise.
    """

    liquid: str = ""
    liquid_density: float | None = None
    density_model: str = "constant"
    body: str = ""
    body_density: float | None = None
    calibration_constant: float | None = None
    reference_viscosity: float | None = None
    temperature: float | None = None
    position_sign: float = 1.0
    fall_distance: float | None = None


    @property
    def label(self) -> str:
        """Liquid (or file name) and temperature."""
        parts = [self.liquid or Path(self.source).stem]
        if self.temperature is not None:
            parts.append(f"{self.temperature:g} °C")
        return " ".join(parts)


def parse_calibration_constant(value: Any, *, where: str = "calibration_constant", path: Any = None,
                               line: int | None = None) -> float:
    """A calibration constant ``K`` in m^3/s^2 (a number, or ``"1.9e-8 m^3/s^2"``).

    ``K`` has the unit of ``eta v / delta rho``: Pa s x m/s / (kg/m^3) = m^3/s^2.
    """
    from torlab.units import NUMBER_PATTERN, registry

    loc = {"path": path, "line": line, "key": where}
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        x = float(value)
    else:
        m = NUMBER_PATTERN.match(str(value))
        if not m:
            raise TorlabInputError(f"{value!r} is not a quantity (e.g. '1.9e-8 m^3/s^2')", **loc)
        x = float(m.group("num"))
        unit = m.group("unit").strip()
        if unit:
            ureg = registry()
            try:
                q = ureg.Quantity(1.0, unit.replace("^", "**"))
                scale = float(q.to("m**3/s**2").magnitude)
            except Exception as e:  # pint: unknown unit or wrong dimension
                raise TorlabInputError(f"unit {unit!r} is not m^3/s^2 (the unit of eta v / "
                                       f"delta rho; {type(e).__name__})", **loc) from None
            x *= scale
    if not (math.isfinite(x) and x > 0):
        raise TorlabInputError(f"must be a positive number, got {value!r}", **loc)
    return x


def _set_meta(meta: ViscometerMetadata, key: str, value: str, path: str, line: int) -> None:
    from torlab.units import to_si

    key, value = key.strip(), value.strip()
    kind = header_key(meta, key, value, METADATA_KEYS, path, line)
    if kind is None:
        return
    if kind == "text":
        if key == "density_model":
            value = choice_value(value, DENSITY_MODELS, "density model", key, path, line,
                                 sep="-")
        setattr(meta, key, value)
        return
    if kind == "sign":
        meta.position_sign = sign_value(value, key, path, line)
        return
    if kind == "calibration":
        meta.calibration_constant = parse_calibration_constant(value, path=path, line=line)
        return
    v = to_si(value, kind, where=key, path=path, line=line)
    if kind in ("density", "viscosity", "length") and v <= 0:
        raise TorlabInputError(f"must be positive, got {value!r}", path=path, line=line, key=key)
    if key in _HEADER_RANGES:
        from torlab.units import check_range

        check_range(_HEADER_RANGES[key], v, where=key, path=path, line=line)
    setattr(meta, key, v)


#: header key -> plausible-range quantity (torlab.units.RANGES)
_HEADER_RANGES = {"liquid_density": "density", "body_density": "density",
                  "reference_viscosity": "viscosity", "temperature": "temperature"}


def read_viscometer(src: PathOrBuffer, *, name: str | None = None) -> tuple[Any, ViscometerMetadata]:
    """Read a ``torlab-visc`` log.

    Returns
    -------
    df : pandas.DataFrame
        ``time_s``, ``position_m`` (increasing as the body falls, after
        ``position_sign``), ``pressure_Pa``, ``temperature_C`` and ``fall``
        where logged, and ``line``.
    meta : ViscometerMetadata

    Raises
    ------
    TorlabInputError
        One problem naming the file and line: empty file, bad first line,
        unknown or missing header key, unknown or missing column, wrong
        delimiter, unknown unit, truncated row, text in a number column,
        time not increasing, a negative pressure, a fall number that is not a
        whole number >= 0, a body not denser than the liquid.
    """
    import pandas as pd

    from torlab.parsers._table import RowSpec, TextFile, read_columns
    from torlab.units import parse_unit_factor

    with TextFile(src, name=name) as tf:
        display = tf.display
        lines = tf.head(lambda ln, s: ln > 1 and bool(s.strip())
                        and not s.lstrip().startswith("#"))
        if not any(s.strip() for s in lines):
            raise TorlabInputError("file is empty", path=display)
        meta = ViscometerMetadata(source=display)
        meta.format_version, hi = read_log_header(
            lines, FORMAT_ID, FORMAT_VERSION, display,
            lambda k, v, ln: _set_meta(meta, k, v, display, ln))
        for req in ("liquid_density", "body_density"):
            if getattr(meta, req) is None:
                raise TorlabInputError(f"missing header key {req!r} (e.g. '# {req}: "
                                       f"{'960' if req == 'liquid_density' else '7850'} kg/m^3')",
                                       path=display)
        if meta.body_density <= meta.liquid_density:  # type: ignore[operator]
            raise TorlabInputError("the body must be denser than the liquid (body_density > "
                                   "liquid_density)", path=display,
                                   line=meta.lines.get("body_density"))
        header_line = hi + 1
        header = lines[hi]
        cells = header.split(",")
        found = parse_log_columns(header, COLUMNS, display, header_line)
        for nm, (_, _, req) in COLUMNS.items():
            if req and nm not in found:
                raise TorlabInputError(f"missing column {nm!r}", path=display, line=header_line)
        use, scales, offsets, units = [], [], [], []
        for nm, (j, unit) in found.items():
            kind = COLUMNS[nm][0]
            sc, off = parse_unit_factor(unit, kind, where=f"column {nm!r}", path=display,
                                        line=header_line) if unit else (1.0, 0.0)
            use.append(j)
            scales.append(sc)
            offsets.append(off)
            units.append(unit)
        spec = RowSpec([c.strip() for c in cells], use, display, scales=scales,
                       offsets=offsets, units=units, hint=" (torlab-visc logs use '.')")
        arrs = read_columns(tf, header_line + 1, spec)
    data: dict[str, np.ndarray] = {}
    for k, (nm, (j, _)) in enumerate(found.items()):
        si = COLUMNS[nm][1]
        data[si] = arrs[k]
        meta.columns[si] = cells[j].strip()
    df = pd.DataFrame(data, copy=False)
    line_no = np.arange(header_line + 1, header_line + 1 + len(df))
    df["line"] = line_no
    if meta.position_sign != 1.0:
        df["position_m"] = df["position_m"] * meta.position_sign
    t = df["time_s"].to_numpy()
    if len(t) > 1 and (np.diff(t) <= 0).any():
        i = int(np.argmax(np.diff(t) <= 0)) + 1
        raise TorlabInputError("time does not increase", path=display, line=int(line_no[i]),
                               key="time")
    p = df["pressure_Pa"].to_numpy()
    if (p < 0).any():
        i = int(np.argmax(p < 0))
        raise TorlabInputError(f"pressure must not be negative, got {p[i] / 1e6:g} MPa (give the "
                               "absolute pressure)", path=display, line=int(line_no[i]),
                               key="pressure")
    if "fall" in df:
        f = df["fall"].to_numpy()
        bad = (f < 0) | (f != np.round(f))
        if bad.any():
            i = int(np.argmax(bad))
            raise TorlabInputError(f"fall must be a whole number >= 0, got {f[i]:g}", path=display,
                                   line=int(line_no[i]), key="fall")
        df["fall"] = df["fall"].astype(np.int64)
    refuse_below_absolute_zero(df, display)
    return df, meta
