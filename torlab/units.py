"""Quantities with units at torlab's edges.

Anything a user writes as a quantity (scene files, protocols, log headers, CLI
options) is either a plain number, taken to be in SI units, or a string with a
unit: ``"20 kN"``, ``"0.373 mm"``, ``"1 mPa*s"``, ``"21500 mm^-2"``,
``"15 1/GPa"``, ``"20 degC"``.  :func:`to_si` turns it into a float in the SI
unit of the expected *kind* and raises :class:`~torlab.errors.TorlabInputError`
naming the key when the unit is unknown or of the wrong dimension.

Parsing uses pint (loaded on first use, with its definition cache, so that
importing torlab stays fast).  Temperatures are returned in degrees Celsius, the
SI derived unit torlab uses for absolute temperatures; temperature *coefficients*
(``1/K``) and differences are the same in K and degC.
"""

from __future__ import annotations

import math
import re
from functools import cache
from typing import Any

from torlab.errors import TorlabInputError

__all__ = ["KINDS", "format_quantity", "parse_unit_factor", "registry", "to_si"]

#: kind -> (pint dimensionality string, SI unit shown to users)
KINDS: dict[str, tuple[str, str]] = {
    "dimensionless": ("", ""),
    "length": ("[length]", "m"),
    "area": ("[length]**2", "m^2"),
    "volume": ("[length]**3", "m^3"),
    "mass": ("[mass]", "kg"),
    "time": ("[time]", "s"),
    "force": ("[force]", "N"),
    "torque": ("[force]*[length]", "N*m"),
    "pressure": ("[pressure]", "Pa"),
    "inverse_pressure": ("1/[pressure]", "1/Pa"),
    "velocity": ("[length]/[time]", "m/s"),
    "angle": ("", "rad"),
    "viscosity": ("[pressure]*[time]", "Pa*s"),
    "density": ("[mass]/[length]**3", "kg/m^3"),
    "areal_density": ("1/[length]**2", "1/m^2"),
    "mass_per_area": ("[mass]/[length]**2", "kg/m^2"),
    "compliance": ("[length]/[pressure]", "m/Pa"),
    "temperature": ("[temperature]", "degC"),
    "inverse_temperature": ("1/[temperature]", "1/K"),
    "conductivity": ("[power]/[length]/[temperature]", "W/(m*K)"),
    "heat_capacity": ("[energy]/[mass]/[temperature]", "J/(kg*K)"),
    "frequency": ("1/[time]", "Hz"),
    "inverse_length": ("1/[length]", "1/m"),
}

_NUMBER = re.compile(
    r"^\s*(?P<num>[+-]?(?:inf(?:inity)?|nan|(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?))\s*(?P<unit>.*?)\s*$",
    re.IGNORECASE,
)

# spellings users type that pint does not read as meant
_WHOLE = {"": "", "-": "", "%": "percent", "°": "deg", "deg C": "degC"}
_PARTS = (("µ", "u"), ("μ", "u"), ("°C", "degC"), ("℃", "degC"), ("^", "**"))


@cache
def registry() -> Any:
    """The shared pint UnitRegistry (created on first use, cached on disk if possible)."""
    import pint

    try:
        ureg = pint.UnitRegistry(cache_folder=":auto:", autoconvert_offset_to_baseunit=True)
    except Exception:  # a read-only home folder must not break unit parsing
        ureg = pint.UnitRegistry(autoconvert_offset_to_baseunit=True)
    ureg.define("count = [] = counts = cnt")
    return ureg


def _normalise_unit(unit: str) -> str:
    u = unit.strip()
    if u in _WHOLE:
        return _WHOLE[u]
    for old, new in _PARTS:
        u = u.replace(old, new)
    return u


def parse_unit_factor(unit: str, kind: str, *, where: str = "", path: Any = None,
                      line: int | None = None) -> tuple[float, float]:
    """Return ``(scale, offset)`` converting values in ``unit`` to the SI unit of ``kind``.

    ``si = value * scale + offset``; the offset is non-zero only for
    temperatures given in kelvin or Fahrenheit (torlab keeps degrees Celsius).

    Raises
    ------
    TorlabInputError
        If the unit is unknown or has the wrong dimension.
    """
    if kind not in KINDS:
        raise ValueError(f"unknown quantity kind {kind!r}")
    dim, si = KINDS[kind]
    ureg = registry()
    u = _normalise_unit(unit)
    try:
        if kind == "temperature":
            q0 = ureg.Quantity(0.0, u or "degC").to("degC").magnitude
            q1 = ureg.Quantity(1.0, u or "degC").to("degC").magnitude
            return q1 - q0, q0
        q = ureg.Quantity(1.0, u) if u else ureg.Quantity(1.0)
        if kind in ("dimensionless", "angle"):
            target = "rad" if kind == "angle" else ""
            if not q.dimensionless:
                raise _WrongDim(q)
            return float(q.to(target).magnitude) if target else float(q.to("").magnitude), 0.0
        if q.dimensionality != ureg.get_dimensionality(dim):
            raise _WrongDim(q)
        return float(q.to(si.replace("^", "**")).magnitude), 0.0
    except _WrongDim as e:
        raise TorlabInputError(
            f"unit {unit!r} is not {_article(kind)} {kind.replace('_', ' ')} (expected something like "
            f"{_example(kind)}; got {e.dim})", path=path, line=line, key=where or None) from None
    except Exception as e:  # pint raises several unrelated classes for unknown units
        raise TorlabInputError(f"unknown unit {unit!r} ({type(e).__name__})", path=path, line=line,
                               key=where or None) from None


class _WrongDim(Exception):
    def __init__(self, q: Any) -> None:
        self.dim = str(q.dimensionality) or "dimensionless"
        super().__init__(self.dim)


def _example(kind: str) -> str:
    examples = {
        "length": "'0.373 mm'", "force": "'20 kN'", "pressure": "'750 MPa'",
        "viscosity": "'1 mPa*s'", "velocity": "'1 m/s'", "temperature": "'20 degC'",
        "inverse_pressure": "'15 1/GPa'", "areal_density": "'21500 mm^-2'",
        "inverse_temperature": "'-0.002 1/K'", "density": "'7850 kg/m^3'",
        "conductivity": "'50 W/(m*K)'", "heat_capacity": "'450 J/(kg*K)'",
        "torque": "'10 N*m'", "angle": "'0.5 deg'", "time": "'4 s'", "volume": "'8 uL'",
        "mass": "'2 mg'", "mass_per_area": "'200 mg/m^2'", "compliance": "'0.02 um/MPa'", "dimensionless": "a plain number",
    }
    return examples.get(kind, f"a value in {KINDS[kind][1]}")


def to_si(value: Any, kind: str, *, where: str = "", path: Any = None, line: int | None = None,
          allow_inf: bool = False) -> float:
    """Convert a user quantity to a float in the SI unit of ``kind``.

    Parameters
    ----------
    value
        A number (taken as SI), or a string ``"<number> <unit>"``; ``"inf"``
        where ``allow_inf``.
    kind
        One of :data:`KINDS`.
    where
        Key or option name used in error messages.
    path, line
        File and line the value came from, for error messages.
    allow_inf
        Accept ``inf`` (a flat surface's radius).

    Returns
    -------
    float
        The value in SI units (degC for temperatures).

    Raises
    ------
    TorlabInputError
        Not a number, unknown unit, wrong dimension, NaN, or inf where not allowed.
    """
    loc = {"path": path, "line": line, "key": where or None}
    if isinstance(value, bool):
        raise TorlabInputError(f"expected a {kind.replace('_', ' ')}, got {value!r}", **loc)
    if isinstance(value, (int, float)):
        x = float(value)
        scale, offset = 1.0, 0.0
    elif isinstance(value, str):
        m = _NUMBER.match(value)
        if not m:
            raise TorlabInputError(
                f"{value!r} is not a quantity (write a number, optionally with a unit, e.g. "
                f"{_example(kind)})", **loc)
        x = float(m.group("num"))
        unit = m.group("unit")
        scale, offset = parse_unit_factor(unit, kind, where=where, path=path, line=line) \
            if unit else (1.0, 0.0)
    else:
        raise TorlabInputError(
            f"expected a {kind.replace('_', ' ')} such as {_example(kind)}, got {type(value).__name__}",
            **loc)
    if math.isnan(x):
        raise TorlabInputError("value is NaN", **loc)
    if math.isinf(x) and not allow_inf:
        raise TorlabInputError("value is infinite", **loc)
    return x * scale + offset if math.isfinite(x) else x


def format_quantity(value: float, unit: str, digits: int = 4) -> str:
    """Format an SI value for display, e.g. ``format_quantity(2e-5, 'um')`` -> ``'20 um'``."""
    if unit in ("", "-"):
        return f"{value:.{digits}g}"
    scale, offset = parse_unit_factor(unit, _kind_of(unit))
    return f"{(value - offset) / scale:.{digits}g} {unit}"


def _kind_of(unit: str) -> str:
    ureg = registry()
    u = _normalise_unit(unit)
    if u in ("degC", "K", "degF"):
        return "temperature"
    q = ureg.Quantity(1.0, u)
    for kind, (dim, _) in KINDS.items():
        if kind in ("temperature", "angle"):
            continue
        if (dim == "" and q.dimensionless) or (dim and q.dimensionality == ureg.get_dimensionality(dim)):
            return kind
    raise ValueError(f"no kind for unit {unit!r}")


def _article(kind: str) -> str:
    """``a`` or ``an`` before a kind's name (all kinds are plain English words)."""
    return "an" if kind[:1] in "aeiou" else "a"
