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

Absolute temperatures and temperature *differences* are distinct kinds:
``"300 K"`` as a ``temperature`` is 26.85 degC, but as a
``temperature_difference`` (a tolerance, a range) it is 300 K = 300 degC of
difference; ``"2 K"``, ``"2 degC"`` and ``"2 delta_degC"`` are the same
difference.  A temperature below absolute zero is an error, and ``"20 C"`` (the
coulomb) gets the hint to write ``degC``.

:data:`RANGES` is torlab's table of plausible values per quantity (documented
in ``docs/scenes.md``); :func:`check_range` raises for a value outside what is
*possible* (a typing or unit error: a 1e300 m radius, a negative amount) and
issues a :class:`~torlab.errors.TorlabWarning` naming the value when it is
possible but *unusual* (a 250 m arm).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import cache
from typing import Any

from torlab.errors import TorlabInputError

__all__ = ["KINDS", "RANGES", "Range", "check_range", "format_quantity", "parse_unit_factor",
           "registry", "to_si"]

#: absolute zero in degrees Celsius
ABSOLUTE_ZERO_C = -273.15

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
    "temperature_difference": ("[temperature]", "K"),
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
    loc = {"path": path, "line": line, "key": where or None}
    if kind in ("temperature", "temperature_difference") and u in _NOT_TEMPERATURE:
        raise TorlabInputError(f"unit {unit!r} is the {_NOT_TEMPERATURE[u][0]}, not a temperature; "
                               f"write {_NOT_TEMPERATURE[u][1]}", **loc)
    try:
        if kind == "temperature_difference":
            if u in ("degC", "degF", "degR", "degRe", "celsius", "fahrenheit"):
                u = "delta_" + {"celsius": "degC", "fahrenheit": "degF"}.get(u, u)
            q = ureg.Quantity(1.0, u or "K")
            if q.dimensionality != ureg.get_dimensionality(dim):
                raise _WrongDim(q)
            return float(q.to("K").magnitude), 0.0
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


_NOT_TEMPERATURE = {"C": ("coulomb", "degC for degrees Celsius (e.g. '20 degC')"),
                    "F": ("farad", "degF for degrees Fahrenheit"),
                    "c": ("speed of light", "degC for degrees Celsius (e.g. '20 degC')")}


class _WrongDim(Exception):
    def __init__(self, q: Any) -> None:
        self.dim = str(q.dimensionality) or "dimensionless"
        super().__init__(self.dim)


def _example(kind: str) -> str:
    examples = {
        "length": "'0.373 mm'", "force": "'20 kN'", "pressure": "'750 MPa'",
        "viscosity": "'1 mPa*s'", "velocity": "'1 m/s'", "temperature": "'20 degC'",
        "temperature_difference": "'2 K'",
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
    si = x * scale + offset if math.isfinite(x) else x
    if kind == "temperature" and si < ABSOLUTE_ZERO_C - 1e-9:
        raise TorlabInputError(f"{value!r} is below absolute zero (-273.15 degC = 0 K)", **loc)
    return si


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


# ------------------------------------------------------------------------------------------
# plausible ranges
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Range:
    """What values of a quantity are possible and what is usual (SI units of ``kind``).

    Outside ``[low, high]`` a value is impossible or certainly a typing or unit
    error: :func:`check_range` raises.  Outside ``[usual_low, usual_high]`` it
    is possible but unusual: :func:`check_range` warns, naming the value.
    ``low_open`` excludes ``low`` itself (a load must be > 0).
    """

    kind: str
    low: float
    high: float
    usual_low: float
    usual_high: float
    what: str
    low_open: bool = True
    display: str = ""


#: quantity -> Range; the table in docs/scenes.md ("Plausible values") is this one
RANGES: dict[str, Range] = {
    "temperature": Range("temperature", ABSOLUTE_ZERO_C, 2000.0, -50.0, 300.0,
                         "an absolute temperature (ambient, test, heater)", low_open=False,
                         display="degC"),
    "temperature_difference": Range("temperature_difference", 0.0, 1000.0, 1e-4, 50.0,
                                    "a temperature difference (a tolerance)", display="K"),
    "load": Range("force", 1e-9, 1e8, 1e-3, 1e6, "a normal load", low_open=False, display="N"),
    "radius": Range("length", 1e-9, 1e6, 1e-4, 100.0,
                    "a radius of curvature (write inf for a flat direction)", low_open=False,
                    display="mm"),
    "semi_axis": Range("length", 1e-9, 1.0, 1e-6, 0.05, "a contact semi-axis", low_open=False,
                       display="mm"),
    "modulus": Range("pressure", 1e3, 1e13, 1e6, 1.2e12, "a Young's modulus", low_open=False,
                     display="GPa"),
    "speed": Range("velocity", 0.0, 1e3, 0.0, 150.0, "a rolling speed", low_open=False,
                   display="m/s"),
    "layer_length": Range("length", 0.0, 1.0, 0.0, 1e-3,
                          "a layer displacement (L_mue, L_mup)", low_open=False, display="um"),
    "viscosity": Range("viscosity", 1e-9, 1e12, 1e-5, 1e4, "a viscosity", low_open=False,
                       display="mPa*s"),
    "pressure_viscosity": Range("inverse_pressure", 0.0, 1e-6, 0.0, 1e-7,
                                "a pressure-viscosity coefficient", low_open=False,
                                display="1/GPa"),
    "stress": Range("pressure", 1.0, 1e11, 1e3, 2e10, "a stress or hardness", low_open=False,
                    display="MPa"),
    "roughness": Range("length", 1e-12, 1e-3, 1e-9, 5e-5, "an RMS roughness", low_open=False,
                       display="um"),
    "asperity_radius": Range("length", 1e-10, 0.01, 1e-8, 1e-3, "an asperity radius",
                             low_open=False, display="um"),
    "asperity_density": Range("areal_density", 1.0, 1e18, 1e6, 1e14,
                              "an asperity density", low_open=False, display="mm^-2"),
    "conductivity": Range("conductivity", 1e-4, 1e4, 0.01, 500.0, "a thermal conductivity",
                          low_open=False, display="W/(m*K)"),
    "density": Range("density", 1e-2, 3e4, 100.0, 22000.0, "a density", low_open=False,
                     display="kg/m^3"),
    "heat_capacity": Range("heat_capacity", 1.0, 1e5, 100.0, 5000.0, "a heat capacity",
                           low_open=False, display="J/(kg*K)"),
    "temperature_coefficient": Range("inverse_temperature", -1.0, 1.0, -0.05, 0.05,
                                     "a temperature coefficient", low_open=False,
                                     display="1/K"),
    "annulus_radius": Range("length", 0.0, 1.0, 5e-4, 0.05, "an HPT annulus radius",
                            low_open=False, display="mm"),
    "arm_length": Range("length", 1e-4, 10.0, 0.01, 2.0, "an HPT loading-arm length",
                        low_open=False, display="mm"),
    "amount_volume": Range("volume", 1e-15, 1e-3, 1e-11, 1e-6, "an applied volume",
                           low_open=False, display="uL"),
    "amount_mass": Range("mass", 1e-15, 1.0, 1e-8, 1e-3, "an applied mass", low_open=False,
                         display="mg"),
    "rig_compliance": Range("compliance", 0.0, 1e-9, 0.0, 1e-12, "a rig compliance",
                            low_open=False, display="um/MPa"),
    "displacement_rate": Range("velocity", 1e-15, 1.0, 1e-9, 1e-3, "a displacement rate",
                               low_open=False, display="um/s"),
    "creepage": Range("dimensionless", -2.0, 2.0, -0.5, 0.5,
                      "a creepage (SRR as a fraction; |SRR| <= 2 when both surfaces move "
                      "forward)", low_open=False),
    "displacement_window": Range("length", 0.0, 0.01, 1e-6, 1e-3,
                                 "an HPT averaging window (displacement)", display="um"),
    "ball_radius": Range("length", 1e-6, 1.0, 5e-4, 0.05, "a ball radius", low_open=False,
                         display="mm"),
}


def check_range(quantity: str, value: float, *, where: str = "", path: Any = None,
                line: int | None = None, allow_inf: bool = False) -> float:
    """Check ``value`` (SI) against :data:`RANGES` ``[quantity]``; return it unchanged.

    Raises
    ------
    TorlabInputError
        Outside the possible range (the message gives the range and the unit).

    Warns
    -----
    TorlabWarning
        Possible but outside the usual range; the message names the value.
    """
    import warnings

    from torlab.errors import TorlabWarning

    r = RANGES[quantity]
    loc = {"path": path, "line": line, "key": where or None}
    if allow_inf and math.isinf(value) and value > 0:
        return value
    shown = _show(value, r)
    below = value <= r.low if r.low_open else value < r.low
    if below or value > r.high or not math.isfinite(value):
        lo = "> " if r.low_open else ">= "
        raise TorlabInputError(
            f"{shown} is not possible for {r.what} (must be {lo}{_show(r.low, r)} and <= "
            f"{_show(r.high, r)}; check the number and its unit)", **loc)
    if not (r.usual_low <= value <= r.usual_high):
        warnings.warn(TorlabWarning(
            f"{shown} is unusual for {r.what} (usually {_show(r.usual_low, r)} to "
            f"{_show(r.usual_high, r)}); check the number and its unit", **loc), stacklevel=2)
    return value


def _show(value: float, r: Range) -> str:
    if r.kind in ("temperature", "temperature_difference"):  # degC and K are the SI units here
        return f"{value:.6g} {KINDS[r.kind][1]}"
    if not r.display or not math.isfinite(value) or value == 0:
        unit = r.display or KINDS[r.kind][1]
        return f"{value:.4g} {unit}".strip()
    try:
        return format_quantity(value, r.display)
    except Exception:  # a display unit pint cannot read: SI
        return f"{value:.4g} {KINDS[r.kind][1]}"
