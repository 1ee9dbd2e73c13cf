"""PCS Instruments text exports: MTM, ETM and EHD2 (``Test Data File``).

The MTM (thesis 5.1.2), the ETM and the EHD2 optical film-thickness rig of PCS
Instruments write a tab-separated text export: a file header (profile, lubricant,
disc track radius, step counts, start date), then one block per *step* of the
test profile::

    MTM311 Test Data File
    Profile description:<TAB>New 3/4" ball on disc profile
    ...
    Test started at 19/08/2016 09:39:32

    Step 1 started at 19/08/2016 09:48:51
    Step type<TAB>BOD_TIMED<TAB>Step description<TAB>...<TAB>Step duration<TAB>02:46:40
    Zero traction force (N)<TAB>0.1467<TAB>(measured at the start of this step)
    Disc track radius used for this step (mm)<TAB>21.232
    Step Time (s)<TAB>Traction Coeff (-)<TAB><TAB>...<TAB>Ball Load (N)<TAB>...
    10<TAB>0.0955<TAB><TAB>...

    All steps completed, test completed normally at 19/08/2016 12:35:32

:func:`read_pcs` reads every step: its type (as written and normalised), its
description, start time, duration, metadata (``key = value unit``,
``key (unit)<TAB>value`` and ``key:<TAB>value`` lines, in SI where a unit is
given) and its data table.  Steps without a table (``FILM_ZERO``,
``ZERO_CHECK``, ``HEATING``, ``Mapper``, ``Suspend`` ...) are kept as metadata.

The data of all steps are returned as one *long* DataFrame with a ``step``
column (the step number as written), ``step_type`` (normalised: ``timed``,
``traction``, ``stribeck``, ``film`` ...), SI columns named after
:data:`PCS_COLUMNS`, and ``line`` (the file line of each row).

Quirks handled (all seen in real exports, see ``docs/formats/pcs.md``):

* CRLF or LF line ends, or both in one file; UTF-8 with or without BOM,
  Windows-1252; ``°C`` or ``degC`` (and UTF-8 ``°`` mis-decoded as ``Â°``);
* duplicated header cells: PCS writes the step's plot columns (x and up to seven
  y, often rounded) before the full data block, so ``Step Time (s)``,
  ``Rolling Speed (mm/s)``, ``Average Film (nm)`` ... appear twice.  The later
  (data-block) column is kept; the earlier one is dropped when it agrees with it
  to its printed precision, otherwise kept as ``<name>_col<k>`` with a warning;
* empty header cells: dropped when their column is empty, otherwise kept as
  ``unnamed_col<k>`` with a warning;
* rows with many empty fields (an empty field is "not logged", NaN);
* step types spelled per software generation (``BOD_TIMED``, ``BodTimed``,
  ``Traction``, ``FILM`` ...);
* dd/mm/yyyy dates, with or without seconds;
* speeds without a unit (``Ball Speed 1``): read as mm/s, which the files confirm
  (rolling speed = mean of ball and disc speed);
* the coefficient convention: in the ETM export ``Traction Coeff (-)`` is
  ``|Traction Force| / Ball Load`` while ``Traction Force (N)`` is signed.
  :func:`read_pcs` checks which convention a file uses
  (:attr:`PcsMetadata.coefficient_convention`) and adds
  ``traction_coefficient_signed`` (the coefficient with the sign of the traction
  force) next to ``traction_coefficient`` as written.

Every problem is one :class:`~torlab.errors.TorlabInputError` naming the file
and line: unknown first line (unless ``instrument=`` is given), a step without
its ``Step type`` line, a truncated row (wrong number of fields), text in a
number column, a non-finite number, a unit of the wrong kind or unknown, a
blank line between data rows, a bad date or duration.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, field
from datetime import datetime
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.parsers._text import (
    PathOrBuffer,
    read_text,
    refuse_below_absolute_zero,
    split_unit,
)

__all__ = [
    "INSTRUMENTS",
    "PCS_COLUMNS",
    "STEP_TYPES",
    "PcsMetadata",
    "PcsStep",
    "coefficient_column",
    "normalise_step_type",
    "read_ehd2",
    "read_etm",
    "read_mtm",
    "read_pcs",
    "step_geometry",
    "step_table",
]

#: instrument families torlab reads; aliases accepted by ``instrument=``
INSTRUMENTS = {"MTM": "MTM", "ETM": "ETM", "EHD2": "EHD2", "EHD": "EHD2"}

#: PCS column name (without unit, case-insensitive) -> (torlab column, kind, unit if none written)
PCS_COLUMNS: dict[str, tuple[str, str, str]] = {
    "step time": ("step_time_s", "time", "s"),
    "srr": ("srr", "dimensionless", "%"),
    "rolling speed": ("rolling_speed_m_s", "velocity", "mm/s"),
    "sliding speed": ("sliding_speed_m_s", "velocity", "mm/s"),
    "traction coeff": ("traction_coefficient", "dimensionless", "-"),
    "traction force": ("traction_force_N", "force", "N"),
    "traction force 1": ("traction_force_1_N", "force", "N"),
    "traction force 2": ("traction_force_2_N", "force", "N"),
    "tf1": ("traction_force_1_N", "force", "N"),
    "tf2": ("traction_force_2_N", "force", "N"),
    "tf3": ("traction_force_3_N", "force", "N"),
    "tf4": ("traction_force_4_N", "force", "N"),
    "ball load": ("ball_load_N", "force", "N"),
    "pin load": ("pin_load_N", "force", "N"),
    "lube temp": ("lube_temperature_C", "temperature", "degC"),
    "lube rtd temp": ("lube_temperature_C", "temperature", "degC"),
    "pot temp": ("pot_temperature_C", "temperature", "degC"),
    "pot rtd temp": ("pot_temperature_C", "temperature", "degC"),
    "wear": ("wear_m", "length", "um"),
    "ecr": ("ecr", "dimensionless", "%"),
    "ball speed 1": ("ball_speed_1_m_s", "velocity", "mm/s"),
    "ball speed 2": ("ball_speed_2_m_s", "velocity", "mm/s"),
    "ball speed 3": ("ball_speed_3_m_s", "velocity", "mm/s"),
    "ball speed 4": ("ball_speed_4_m_s", "velocity", "mm/s"),
    "disc speed 1": ("disc_speed_1_m_s", "velocity", "mm/s"),
    "disc speed 2": ("disc_speed_2_m_s", "velocity", "mm/s"),
    "disc speed 3": ("disc_speed_3_m_s", "velocity", "mm/s"),
    "disc speed 4": ("disc_speed_4_m_s", "velocity", "mm/s"),
    "disc frequency": ("disc_frequency_Hz", "frequency", "Hz"),
    "rolling force": ("rolling_force_N", "force", "N"),
    "rolling coeff": ("rolling_coefficient", "dimensionless", "-"),
    "traction trace": ("traction_trace", "dimensionless", "-"),
    "average film": ("film_thickness_m", "length", "nm"),
    "standard deviation": ("film_thickness_sd_m", "length", "nm"),
    "sd repeat number": ("sd_repeat_number", "dimensionless", "-"),
    "user repeat number": ("user_repeat_number", "dimensionless", "-"),
    "order": ("interference_order", "dimensionless", "-"),
    "lube ref index": ("lube_refractive_index", "dimensionless", "-"),
    "average wavelength": ("average_wavelength_m", "length", "nm"),
    "central film": ("central_film_thickness_m", "length", "nm"),
    "minimum film": ("minimum_film_thickness_m", "length", "nm"),
}

#: PCS columns holding text (kept as text where not empty)
TEXT_COLUMNS: dict[str, str] = {"image file name": "image_file_name"}

#: normalised step types: key = type letters upper-case, without a ``BOD`` prefix
STEP_TYPES: dict[str, str] = {
    "TIMED": "timed",
    "TRACTION": "traction",
    "STRIBECK": "stribeck",
    "FILM": "film",
    "FILMZERO": "film_zero",
    "SPACERZERO": "film_zero",
    "ZEROCHECK": "zero_check",
    "FILMZEROCHECK": "zero_check",
    "HEATING": "heating",
    "COOLING": "cooling",
    "MAPPER": "mapper",
    "MAP": "mapper",
    "SUSPEND": "suspend",
    "PAUSE": "suspend",
}

#: step types that carry a data table of measurements
DATA_STEP_TYPES = ("timed", "traction", "stribeck", "film")

#: step / header metadata keys with a known quantity kind (sanitised key -> (name, kind))
_KNOWN_META: dict[str, tuple[str, str]] = {
    "ball_load": ("ball_load_N", "force"),
    "camera_window_load": ("camera_window_load_N", "force"),
    "zero_traction_force": ("zero_traction_force_N", "force"),
    "disc_track_radius_used_for_this_step": ("disc_track_radius_m", "length"),
    "disc_track_radius": ("disc_track_radius_m", "length"),
    "peak_wavelength": ("peak_wavelength_m", "length"),
    "spacer_thickness": ("spacer_thickness_m", "length"),
    "film_thickness": ("film_thickness_m", "length"),
    "lubricant_refractive_index": ("lubricant_refractive_index", "dimensionless"),
    "trigger_position": ("trigger_position", "dimensionless"),
    "peak_order": ("peak_order", "dimensionless"),
    "rolling_speed": ("rolling_speed_m_s", "velocity"),
    "srr": ("srr", "dimensionless"),
}

#: the unit PCS means where a step line gives a number without one (its columns' units)
_META_UNIT = {"length": "mm", "velocity": "mm/s", "srr": "%"}

#: a Ball Load this far below zero (N) is not a load cell at rest but a broken value
LOAD_ZERO_NOISE_N = 0.5
#: the largest traction coefficient taken for a measurement (no contact's traction force is
#: ten times its load)
MAX_COEFFICIENT = 10.0


def _meta_range(name: str) -> str | None:
    """The :data:`torlab.units.RANGES` entry a header or step value is checked against."""
    if name.endswith("_load_N"):
        return "load"
    if name.endswith("_C"):
        return "temperature"
    if name == "disc_track_radius_m":
        return "track_radius"
    if name.endswith("_m_s") and "speed" in name and "sliding" not in name:
        return "speed"
    if name == "srr":
        return "creepage"
    if name.startswith("applied_amount"):
        return "amount_volume" if name.endswith("_m3") else \
            "amount_mass" if name.endswith("_kg") else None
    return None


def _checked(name: str, value: float, key: str, path: str, line: int) -> tuple[str, float]:
    """``(name, value)`` after the range check of its quantity (error or warning line); an
    applied amount of zero (the dry run) is not checked."""
    q = _meta_range(name)
    if q is not None and not (q.startswith("amount") and value == 0):
        from torlab.units import check_range

        check_range(q, value, where=key, path=path, line=line)
    return name, value

# metadata keys of the file header -> attribute of PcsMetadata
_HEADER_KEYS = {
    "profile description": "profile",
    "lubricant name": "lubricant",
    "lubricant properties file description": "lubricant_properties",
    "comments": "comments",
}

_SUFFIX = {"time": "_s", "length": "_m", "force": "_N", "velocity": "_m_s", "temperature": "_C",
           "pressure": "_Pa", "frequency": "_Hz", "torque": "_N_m", "viscosity": "_Pa_s",
           "density": "_kg_m3", "mass": "_kg", "volume": "_m3", "dimensionless": "", "angle": "_rad"}
_UNIT_KINDS = ("dimensionless", "time", "length", "velocity", "force", "temperature", "pressure",
               "frequency", "torque", "viscosity", "density", "mass", "volume")

_FIRST_LINE = re.compile(r"^\s*(?P<model>(?P<family>MTM|ETM|EHD)\w*)\s+Test\s+Data\s+File\b",
                         re.IGNORECASE)
_STEP = re.compile(r'^Step\s+(?P<n>\d+)(?:\s+"(?P<desc>[^"]*)")?\s+started\s+at\s+(?P<date>.*?)\s*$')
_AT_DATE = re.compile(r"^(?P<text>.*?)\s+at\s+(?P<date>\d{1,2}/\d{1,2}/\d{4}(?:\s+[\d:]+)?)\s*$")
_DATE = re.compile(r"^(\d{1,2})/(\d{1,2})/(\d{4})(?:\s+(\d{1,2}):(\d{2})(?::(\d{2}))?)?$")
_HMS = re.compile(r"^(\d+):(\d{1,2})(?::(\d{1,2}))?$")
_NUM = re.compile(r"^\s*(?P<num>[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)\s*(?P<unit>.*?)\s*$")
_HEATING = re.compile(r"Controlling temperature to\s*(?P<T>[+-]?\d+(?:\.\d*)?)\s*(?P<u>°C|degC|C|°F|K)"
                      r"(?:\s+using the\s+(?P<probe>\w+)\s+probe)?(?:\s+for\s+(?P<d>[\d:]+))?",
                      re.IGNORECASE)
_NUMERIC_START = re.compile(r"^\s*[+-]?(?:\d|\.\d)")


@dataclass
class PcsStep:
    """One step of a PCS test profile.

    Attributes
    ----------
    number
        Step number as written (``Step 3 started at ...``).
    type_raw, type
        Step type as written (``BOD_TIMED``, ``BodTimed``) and normalised
        (``timed``, ``traction``, ``stribeck``, ``film``, ``film_zero``,
        ``zero_check``, ``heating``, ``mapper``, ``suspend``, or ``other``).
    description
        The step description.
    started_at
        Start (from ``dd/mm/yyyy hh:mm[:ss]``); ``None`` if not given.
    duration_s
        ``Step duration`` (or a heating step's duration) in s, if given.
    metadata
        Step metadata: SI floats where the line gives a number (keys carry the
        unit, e.g. ``ball_load_N``, ``disc_track_radius_m``), text otherwise.
    metadata_raw
        The same lines as written: original key -> value text.
    n_rows
        Number of data rows.
    columns
        torlab columns with at least one value in this step.
    first_line, last_line
        File lines of the ``Step`` line and of the step's last non-blank line.
    header_line
        File line of the column header, ``None`` for steps without a table.
    plot_x, plot_y
        The step's plot columns as its own header names them: PCS writes the
        x column and the y columns of the step's plot first (``SRR (%)``,
        ``Traction Coeff (-)``) before the full data block; these are their
        torlab names (``srr``, ``traction_coefficient``).
    notes
        Free-text lines of the step.
    """

    number: int
    type_raw: str = ""
    type: str = "other"
    description: str = ""
    started_at: datetime | None = None
    duration_s: float | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    metadata_raw: dict[str, str] = field(default_factory=dict)
    n_rows: int = 0
    columns: list[str] = field(default_factory=list)
    first_line: int = 0
    last_line: int = 0
    header_line: int | None = None
    plot_x: str = ""
    plot_y: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def has_data(self) -> bool:
        """Whether the step has data rows."""
        return self.n_rows > 0

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (dates as ISO strings) for JSON/YAML."""
        d = asdict(self)
        d["started_at"] = None if self.started_at is None else self.started_at.isoformat()
        return d


@dataclass
class PcsMetadata:
    """File header and steps of a PCS export (SI units, temperatures in degC).

    Attributes
    ----------
    source
        File name (for messages).
    instrument
        ``"MTM"``, ``"ETM"`` or ``"EHD2"``; ``instrument_model`` as written
        (``"MTM311"``, ``"EHD261"``, ``""`` for headerless ETM files).
    detected_from
        ``"first line"`` or ``"override"``.
    profile, lubricant, lubricant_properties, comments
        File header text.
    disc_track_radius_m
        ``Disc track radius`` of the header (mm when no unit is written).
    steps_in_profile, steps_completed
        The header counts.
    started_at, completed_at
        ``Test started at`` and the end line's date.
    end_text
        The end line (``All steps completed, test completed normally``).
    completed_normally
        Whether the end line says so; ``None`` without an end line.
    header
        Every header line ``key -> value`` as written.
    steps
        :class:`PcsStep` objects in file order.
    columns
        torlab column -> PCS header cell it came from.
    coefficient_convention
        How ``Traction Coeff`` relates to ``Traction Force / Ball Load``:
        ``"magnitude"`` (|F|/W, the ETM export), ``"signed"`` (F/W),
        ``"consistent"`` (F/W, and no negative forces to tell the two apart),
        ``"inconsistent"``, or ``""`` when the file lacks the columns.
    warnings
        Everything read that a user should know (duplicates kept, unknown
        step types, empty data steps, ...).
    """

    source: str = ""
    instrument: str = ""
    instrument_model: str = ""
    detected_from: str = "first line"
    profile: str = ""
    lubricant: str = ""
    lubricant_properties: str = ""
    comments: str = ""
    disc_track_radius_m: float | None = None
    steps_in_profile: int | None = None
    steps_completed: int | None = None
    started_at: datetime | None = None
    completed_at: datetime | None = None
    end_text: str = ""
    completed_normally: bool | None = None
    header: dict[str, str] = field(default_factory=dict)
    steps: list[PcsStep] = field(default_factory=list)
    columns: dict[str, str] = field(default_factory=dict)
    coefficient_convention: str = ""
    warnings: list[str] = field(default_factory=list)

    def step(self, number: int) -> PcsStep:
        """The step with this number (the first, if numbers repeat)."""
        for s in self.steps:
            if s.number == number:
                return s
        raise TorlabInputError(f"no step {number} (steps: {_ranges([s.number for s in self.steps])})",
                               path=self.source)

    @property
    def unfinished_step(self) -> PcsStep | None:
        """The step the test stopped in when the export has no end line (a crash or a copy
        cut off) or its end line does not say it completed normally; None otherwise."""
        if not self.steps or self.completed_normally:
            return None
        return self.steps[-1]

    def data_steps(self, type: str | None = None) -> list[PcsStep]:
        """Steps with data rows, optionally of one normalised type."""
        return [s for s in self.steps if s.has_data and (type is None or s.type == type)]

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (dates as ISO strings) for JSON/YAML."""
        d = asdict(self)
        d["steps"] = [s.to_dict() for s in self.steps]
        for k in ("started_at", "completed_at"):
            v = getattr(self, k)
            d[k] = None if v is None else v.isoformat()
        return d


def normalise_step_type(raw: str) -> str:
    """Normalised step type of a PCS spelling (``BOD_TIMED``, ``BodTimed``, ``POD_TIMED`` -> ``timed``).

    Letters are upper-cased, everything else removed, and a leading ``BOD``
    (ball on disc) or ``POD`` (pin on disc) dropped; :data:`STEP_TYPES` maps
    the rest.  Unknown types give ``"other"``.
    """
    key = re.sub(r"[^A-Z]", "", raw.upper())
    if key.startswith(("BOD", "POD")) and len(key) > 3:
        key = key[3:]
    return STEP_TYPES.get(key, "other")


def step_geometry(raw: str) -> str:
    """Contact geometry a step type names: ``"ball on disc"`` (``BOD_...``), ``"pin on disc"``
    (``POD_...``), or ``""`` (not said)."""
    key = re.sub(r"[^A-Z]", "", raw.upper())
    return {"BOD": "ball on disc", "POD": "pin on disc"}.get(key[:3], "") if len(key) > 3 else ""


def _ranges(nums: list[int]) -> str:
    if not nums:
        return "none"
    return f"{min(nums)}-{max(nums)}" if len(nums) > 3 else ", ".join(map(str, nums))


def sanitise(name: str) -> str:
    s = re.sub(r"[^0-9a-zA-Z]+", "_", name.strip()).strip("_").lower()
    if not s:
        return "unnamed"
    return "c_" + s if s[0].isdigit() else s


def _fix_mojibake(s: str) -> str:
    return s.replace("Â°", "°").replace("\ufffd", "°") if ("Â" in s or "\ufffd" in s) else s


_UNIT_CACHE: dict[tuple[str, str], tuple[float, float] | None] = {}


def _unit_factor(unit: str, kind: str, *, where: str = "", path: Any = None,
                 line: int | None = None) -> tuple[float, float]:
    """:func:`torlab.units.parse_unit_factor`, cached (a PCS file repeats its units per step)."""
    from torlab.units import parse_unit_factor

    key = (unit, kind)
    hit = _UNIT_CACHE.get(key, False)
    if hit is False:
        try:
            hit = parse_unit_factor(unit, kind)
        except TorlabInputError:
            hit = None
        _UNIT_CACHE[key] = hit
    if hit is None:  # raise the located error
        return parse_unit_factor(unit, kind, where=where, path=path, line=line)
    return hit


def _parse_date(text: str, path: str, line: int) -> datetime:
    m = _DATE.match(text.strip())
    if not m:
        raise TorlabInputError(f"{text.strip()!r} is not a date (expected dd/mm/yyyy hh:mm[:ss])",
                               path=path, line=line)
    d, mo, y, hh, mm, ss = m.groups()
    try:
        return datetime(int(y), int(mo), int(d), int(hh or 0), int(mm or 0), int(ss or 0))
    except ValueError as e:
        raise TorlabInputError(f"{text.strip()!r} is not a valid date ({e})", path=path,
                               line=line) from None


def _parse_hms(text: str, path: str, line: int) -> float:
    m = _HMS.match(text.strip())
    if not m:
        raise TorlabInputError(f"{text.strip()!r} is not a duration (expected hh:mm:ss)", path=path,
                               line=line)
    h, mi, s = (int(g) if g else 0 for g in m.groups())
    if m.group(3) is None:  # hh:mm
        return float(h * 3600 + mi * 60)
    return float(h * 3600 + mi * 60 + s)


def _quantity(key: str, value: str, unit_hint: str, *, path: str, line: int) -> tuple[str, Any]:
    """(metadata key, value): a number with a unit becomes SI, text stays text."""
    base = sanitise(key)
    known = _KNOWN_META.get(base)
    m = _NUM.match(value)
    if not m:
        return base, value.strip()
    num = float(m.group("num"))
    if not math.isfinite(num):
        raise TorlabInputError(f"{m.group('num')!r} is not a finite number", path=path, line=line,
                               key=key.strip())
    unit = _fix_mojibake(m.group("unit") or unit_hint).strip()
    if known is not None:
        name, kind = known
        if not unit:
            # PCS writes lengths of the header in mm without a unit (Disc track radius: 36.273),
            # speeds in mm/s and the SRR in %, as in its columns
            unit = _META_UNIT.get(name, _META_UNIT.get(kind, ""))
        sc, off = _unit_factor(unit, kind, where=key.strip(), path=path, line=line) if unit \
            else (1.0, 0.0)
        return _checked(name, num * sc + off, key.strip(), path, line)
    if not unit:
        return base, num
    for kind in _UNIT_KINDS:
        try:
            sc, off = _unit_factor(unit, kind)
        except TorlabInputError:
            continue
        return _checked(base + _SUFFIX[kind], num * sc + off, key.strip(), path, line)
    return base, value.strip()  # a unit nobody knows: keep the text as written


# ------------------------------------------------------------------------------------------
@dataclass
class _Block:
    step: PcsStep
    header_cells: list[str] | None = None
    header_text: str = ""
    data: list[str] = field(default_factory=list)
    data_first_line: int = 0


def read_pcs(src: PathOrBuffer, *, instrument: str | None = None,
             name: str | None = None) -> tuple[Any, PcsMetadata]:
    """Read a PCS Instruments text export (MTM, ETM, EHD2).

    Parameters
    ----------
    src
        Path or text/bytes buffer.
    instrument
        ``"MTM"``, ``"ETM"`` or ``"EHD2"`` to read a file whose first line is
        not recognised (or to override the detection).  By default it is
        detected from the first line: ``MTM311 Test Data File`` -> MTM,
        ``EHD261 Test Data File`` -> EHD2, ``ETM... Test Data File`` or a file
        that starts directly with ``Step 1 started at`` -> ETM.
    name
        Display name for messages when ``src`` is a buffer.

    Returns
    -------
    df : pandas.DataFrame
        Long table of every data row: ``step``, ``step_type``, SI columns (see
        :data:`PCS_COLUMNS`; unknown PCS columns are kept with a sanitised
        name), ``traction_coefficient_signed`` where the file has traction
        force and coefficient, and ``line``.
    meta : PcsMetadata

    Raises
    ------
    TorlabInputError
        One problem, naming the file and line.
    """
    text, display = read_text(src, name=name)
    if not text.strip():
        raise TorlabInputError("file is empty", path=display)
    lines = text.split("\n")
    meta = PcsMetadata(source=display)
    if "\t" not in text:
        from torlab.parsers._text import detect_delimiter

        i = next((k for k, s in enumerate(lines) if detect_delimiter(s, [",", ";", "|"])), None)
        if i is not None:
            d = detect_delimiter(lines[i], [",", ";", "|"])
            raise TorlabInputError(f"no tab in the file: PCS exports are tab-separated, this one uses "
                                   f"{d!r}", path=display, line=i + 1)
    _detect(lines, meta, instrument, display)
    blocks = _split(lines, meta, display)
    df = _tables(blocks, meta, display)
    refuse_below_absolute_zero(df, display)
    _refuse_impossible(df, display)
    _coefficient_convention(df, meta)
    expected = meta.steps_completed
    if expected is not None and expected != len(meta.steps):
        meta.warnings.append(f"the header says {expected} steps completed, the file has "
                             f"{len(meta.steps)}")
    last = meta.unfinished_step
    if last is not None:
        how = ("has no end line ('All steps completed, test completed normally at ...')"
               if meta.completed_at is None else f"ends with {meta.end_text!r}")
        meta.warnings.append(f"the export {how}: the test stopped during step {last.number} "
                             f"(lines {last.first_line}-{last.last_line}), whose record is cut "
                             "short")
    nums = [s.number for s in meta.steps]
    if len(set(nums)) != len(nums):
        meta.warnings.append("step numbers repeat; use the 'line' column to tell the steps apart")
    return df, meta


def read_mtm(src: PathOrBuffer, **kw: Any) -> tuple[Any, PcsMetadata]:
    """:func:`read_pcs` of an MTM export (``instrument="MTM"``)."""
    return read_pcs(src, instrument="MTM", **kw)


def read_etm(src: PathOrBuffer, **kw: Any) -> tuple[Any, PcsMetadata]:
    """:func:`read_pcs` of an ETM export (``instrument="ETM"``)."""
    return read_pcs(src, instrument="ETM", **kw)


def read_ehd2(src: PathOrBuffer, **kw: Any) -> tuple[Any, PcsMetadata]:
    """:func:`read_pcs` of an EHD2 export (``instrument="EHD2"``)."""
    return read_pcs(src, instrument="EHD2", **kw)


def _detect(lines: list[str], meta: PcsMetadata, instrument: str | None, path: str) -> None:
    first_i = next(i for i, s in enumerate(lines) if s.strip())
    first = lines[first_i].strip()
    detected = ""
    m = _FIRST_LINE.match(first)
    if m:
        detected = {"MTM": "MTM", "ETM": "ETM", "EHD": "EHD2"}[m.group("family").upper()]
        meta.instrument_model = m.group("model")
    elif _STEP.match(first):
        detected = "ETM"
    if instrument is not None:
        key = str(instrument).strip().upper()
        if key not in INSTRUMENTS:
            raise TorlabInputError(f"unknown instrument {instrument!r} (choose MTM, ETM or EHD2)",
                                   key="instrument")
        meta.instrument = INSTRUMENTS[key]
        meta.detected_from = "override"
        if detected and detected != meta.instrument:
            meta.warnings.append(f"the first line says {detected}; read as {meta.instrument} as asked")
        return
    if not detected:
        shown = first if len(first) <= 60 else first[:57] + "..."
        raise TorlabInputError(
            f"not a PCS Instruments export: the first line is {shown!r}, expected "
            "'MTM311 Test Data File', 'EHD261 Test Data File' or 'Step 1 started at ...' (ETM); "
            "give the instrument (--instrument MTM|ETM|EHD2) to read it anyway",
            path=path, line=first_i + 1)
    meta.instrument = detected


def _split(lines: list[str], meta: PcsMetadata, path: str) -> list[_Block]:  # noqa: C901 (one pass over the export's sections: each section kind is a case)
    """Walk the lines: file header, then step blocks (metadata, table header, rows)."""
    n = len(lines)
    i = 0
    # ---- file header
    while i < n and not _STEP.match(lines[i].strip()):
        s = lines[i].strip()
        ln = i + 1
        if s and not _FIRST_LINE.match(s):
            _header_line(s, meta, path, ln)
        i += 1
    if i >= n:
        raise TorlabInputError("no steps: expected a line 'Step 1 started at dd/mm/yyyy hh:mm'",
                               path=path, line=n)
    blocks: list[_Block] = []
    while i < n:
        s = lines[i].strip()
        m = _STEP.match(s)
        if not m:  # only reached after a table ends: end line or stray text
            _second_run(s, meta, path, i + 1)
            i += 1
            continue
        if meta.completed_at is not None:
            _second_run(s, meta, path, i + 1, after_end=True)
        step = PcsStep(number=int(m.group("n")), first_line=i + 1, last_line=i + 1)
        if m.group("desc"):
            step.description = m.group("desc")
        step.started_at = _parse_date(m.group("date"), path, i + 1)
        blk = _Block(step)
        blocks.append(blk)
        meta.steps.append(step)
        i += 1
        # 'Step type' line
        while i < n and not lines[i].strip():
            i += 1
        if i >= n or not lines[i].strip().lower().startswith("step type"):
            raise TorlabInputError(f"step {step.number}: expected the 'Step type<TAB>...' line "
                                   "after the 'Step ... started at' line", path=path,
                                   line=i + 1 if i < n else step.first_line)
        _step_type_line(lines[i], step, meta, path, i + 1)
        step.last_line = i + 1
        i += 1
        # metadata lines, then maybe a table
        while i < n:
            raw = lines[i]
            s = raw.strip()
            ln = i + 1
            if not s:
                i += 1
                if blk.header_cells is not None:
                    break
                continue
            if _STEP.match(s):
                break
            _second_run(s, meta, path, ln)
            if blk.header_cells is not None:  # data rows
                blk.data.append(raw)
                step.last_line = ln
                i += 1
                continue
            cells = raw.split("\t")
            if (len([c for c in cells if c.strip()]) >= 4
                    and not _NUMERIC_START.match(cells[0]) and "=" not in s):
                blk.header_cells = cells
                blk.header_text = raw
                blk.data_first_line = ln + 1
                step.header_line = ln
                step.last_line = ln
                i += 1
                continue
            if _NUMERIC_START.match(s):
                raise TorlabInputError(f"step {step.number}: a data row without a column header "
                                       "line before it", path=path, line=ln)
            end = _AT_DATE.match(s)
            if end and not s.lower().startswith(("controlling", "step")) and "\t" not in raw:
                _end_line(end, meta, path, ln)
                i += 1
                continue
            _meta_line(raw, step, path, ln)
            step.last_line = ln
            i += 1
        # after a table: only the end line, free text or the next step may follow
        if blk.header_cells is not None:
            blank_at = i  # 1-based line of the blank line that ended the table is i
            while i < n and not _STEP.match(lines[i].strip()):
                s = lines[i].strip()
                _second_run(s, meta, path, i + 1)
                if s:
                    if _NUMERIC_START.match(s):
                        raise TorlabInputError(
                            f"blank line between data rows of step {step.number}", path=path,
                            line=blank_at)
                    end = _AT_DATE.match(s)
                    if end and "\t" not in lines[i]:
                        _end_line(end, meta, path, i + 1)
                    else:
                        _meta_line(lines[i], step, path, i + 1)
                        step.last_line = i + 1
                i += 1
    return blocks


def _second_run(s: str, meta: PcsMetadata, path: str, ln: int, *, after_end: bool = False
                ) -> None:
    """A line that starts another export (its first line, its 'Test started at', or a step
    after the end line) inside the steps: two runs in one file are refused, so that their
    steps are never reduced as one run."""
    if after_end or _FIRST_LINE.match(s) or s.lower().startswith("test started at"):
        what = "a step after the end line" if after_end else repr(s[:40])
        raise TorlabInputError(f"a second run starts here ({what}): this file holds two "
                               "exports one after the other; split it into one file per run",
                               path=path, line=ln)


def _header_line(s: str, meta: PcsMetadata, path: str, ln: int) -> None:
    low = s.lower()
    if low.startswith("test started at"):
        meta.started_at = _parse_date(s[len("test started at"):], path, ln)
        meta.header["Test started at"] = s[len("test started at"):].strip()
        return
    if "\t" in s or ":" in s:
        if ":" in s.split("\t", 1)[0]:
            key, value = s.split(":", 1)
        else:
            key, value = s.split("\t", 1)
        key = key.strip()
        value = value.strip().strip("\t").strip()
        meta.header[key] = value
        lk = re.sub(r"\s+", " ", key.lower())
        if lk in _HEADER_KEYS:
            setattr(meta, _HEADER_KEYS[lk], value)
        elif lk.startswith("disc track radius"):
            if value:
                _, unit = split_unit(key)
                _, v = _quantity("disc_track_radius", value, unit or "mm", path=path, line=ln)
                if not isinstance(v, float):
                    raise TorlabInputError(f"disc track radius {value!r} is not a number",
                                           path=path, line=ln)
                meta.disc_track_radius_m = v
        elif lk.startswith("number of steps"):
            if value:
                try:
                    count = int(value)
                except ValueError:
                    raise TorlabInputError(f"{key}: {value!r} is not a whole number", path=path,
                                           line=ln) from None
                if "completed" in lk:
                    meta.steps_completed = count
                else:
                    meta.steps_in_profile = count
        return
    meta.header[f"line {ln}"] = s


def _step_type_line(raw: str, step: PcsStep, meta: PcsMetadata, path: str, ln: int) -> None:
    cells = [c.strip() for c in raw.split("\t")]
    pairs: dict[str, str] = {}
    for k in range(0, len(cells) - 1, 2):
        if cells[k]:
            pairs[cells[k].lower()] = cells[k + 1]
    if len(cells) < 2 or not cells[1]:
        raise TorlabInputError(f"step {step.number}: the 'Step type' line names no type",
                               path=path, line=ln)
    step.type_raw = pairs.get("step type", cells[1])
    step.type = normalise_step_type(step.type_raw)
    if step.type == "other":
        meta.warnings.append(f"step {step.number}: unknown step type {step.type_raw!r}, kept as "
                             "'other'")
    if "step description" in pairs:
        step.description = pairs["step description"]
    if pairs.get("step duration"):
        step.duration_s = _parse_hms(pairs["step duration"], path, ln)


def _meta_line(raw: str, step: PcsStep, path: str, ln: int) -> None:
    s = raw.strip()
    if "=" in s and "\t" not in s:
        key, value = s.split("=", 1)
        k, v = _quantity(key, value, "", path=path, line=ln)
        step.metadata[k] = v
        step.metadata_raw[key.strip()] = value.strip()
        return
    if "\t" in s:
        cells = [c.strip() for c in s.split("\t")]
        key = cells[0].rstrip(":").strip()
        value = cells[1] if len(cells) > 1 else ""
        kname, unit = split_unit(key)
        k, v = _quantity(kname, value, unit, path=path, line=ln)
        step.metadata[k] = v
        step.metadata_raw[key] = "\t".join(cells[1:])
        return
    if ":" in s and not _HEATING.search(s):
        key, value = s.split(":", 1)
        k, v = _quantity(key, value, "", path=path, line=ln)
        step.metadata[k] = v
        step.metadata_raw[key.strip()] = value.strip()
        return
    step.notes.append(s)
    h = _HEATING.search(s)
    if h:
        unit = {"°c": "degC", "degc": "degC", "c": "degC", "°f": "degF", "k": "K"}[h.group("u").lower()]
        sc, off = _unit_factor(unit, "temperature", path=path, line=ln)
        step.metadata["target_temperature_C"] = _checked(
            "target_temperature_C", float(h.group("T")) * sc + off, "Controlling temperature",
            path, ln)[1]
        if h.group("probe"):
            step.metadata["control_probe"] = h.group("probe")
        if h.group("d"):
            d = _parse_hms(h.group("d"), path, ln)
            step.metadata["control_duration_s"] = d
            if step.duration_s is None:
                step.duration_s = d


def _end_line(m: re.Match[str], meta: PcsMetadata, path: str, ln: int) -> None:
    meta.end_text = m.group("text").strip().rstrip(",")
    meta.completed_at = _parse_date(m.group("date"), path, ln)
    meta.completed_normally = "completed normally" in meta.end_text.lower()


# ---------------------------------------------------------------------------------- tables
@dataclass
class _Col:
    index: int
    cell: str
    name: str  # torlab name ('' = empty header cell)
    kind: str = "dimensionless"
    scale: float = 1.0
    offset: float = 0.0
    text: bool = False
    order: int = 10_000


def _resolve_header(cells: list[str], path: str, line: int, meta: PcsMetadata) -> list[_Col]:
    order = {v[0]: k for k, v in enumerate(PCS_COLUMNS.values())}
    cols: list[_Col] = []
    for j, c in enumerate(cells):
        cell = _fix_mojibake(c.strip())
        if not cell:
            cols.append(_Col(j, "", ""))
            continue
        nm, unit = split_unit(cell)
        key = re.sub(r"\s+", " ", nm.strip().lower())
        if key in TEXT_COLUMNS:
            cols.append(_Col(j, cell, TEXT_COLUMNS[key], text=True, order=len(order)))
            continue
        if key in PCS_COLUMNS:
            tname, kind, default = PCS_COLUMNS[key]
            u = unit or default
            sc, off = _unit_factor(u, kind, where=f"column {cell!r}", path=path, line=line)
            cols.append(_Col(j, cell, tname, kind, sc, off, order=order[tname]))
            continue
        base = sanitise(nm)
        if not unit:
            cols.append(_Col(j, cell, base))
            continue
        for kind in _UNIT_KINDS:
            try:
                sc, off = _unit_factor(unit, kind)
            except TorlabInputError:
                continue
            cols.append(_Col(j, cell, base + _SUFFIX[kind], kind, sc, off))
            break
        else:
            meta.warnings.append(f"line {line}: column {cell!r} has a unit torlab does not know; "
                                 "kept as written")
            cols.append(_Col(j, cell, f"{base}_{sanitise(unit)}"))
    return cols


def _tables(blocks: list[_Block], meta: PcsMetadata, path: str) -> Any:
    import pandas as pd

    groups: dict[str, list[_Block]] = {}
    for b in blocks:
        if b.header_cells is None:
            continue
        b.step.n_rows = len(b.data)
        if not b.data:
            if b.step.type in DATA_STEP_TYPES:
                meta.warnings.append(f"step {b.step.number} ({b.step.type}) has a column header but "
                                     "no data rows")
            continue
        groups.setdefault(b.header_text, []).append(b)
    for b in blocks:
        if b.header_cells is None and b.step.type in DATA_STEP_TYPES:
            meta.warnings.append(f"step {b.step.number} ({b.step.type}) has no data table")
    frames = []
    for hblocks in groups.values():
        frames.append(_group_frame(hblocks, meta, path))
    if not frames:
        return pd.DataFrame({"step": pd.Series(dtype="int64"), "step_type": pd.Series(dtype="str"),
                             "line": pd.Series(dtype="int64")})
    df = pd.concat(frames, ignore_index=True, sort=False) if len(frames) > 1 else frames[0]
    if len(frames) > 1:
        df = df.sort_values("line", kind="stable", ignore_index=True)
    order = {v[0]: k for k, v in enumerate(PCS_COLUMNS.values())}
    value_cols = [c for c in df.columns if c not in ("step", "step_type", "line")]
    value_cols.sort(key=lambda c: (order.get(c, 10_000), c))
    df = df[["step", "step_type", *value_cols, "line"]]
    # per step: the columns with values (rows are in file order, steps contiguous)
    with_data = sorted((b for b in blocks if b.data), key=lambda b: b.data_first_line)
    if len(df) and with_data:
        nn = df[value_cols].notna().to_numpy().astype(np.int64)
        starts = np.searchsorted(df["line"].to_numpy(), [b.data_first_line for b in with_data])
        counts = np.add.reduceat(nn, starts, axis=0) if value_cols else None
        for k, b in enumerate(with_data):
            b.step.columns = [c for c, n in zip(value_cols, counts[k], strict=True) if n] \
                if counts is not None else []
    return df


def _decimals(values: list[str]) -> int:
    """Decimal places the values are printed to: digits after the point less the exponent
    (``1.23E-03`` has 5: a resolution of 1e-5)."""
    d = 0
    for v in values:
        m = _PRINTED.fullmatch(v.strip())
        if m:
            exp = int(m.group("exp") or 0)
            d = max(d, len(m.group("frac") or "") - exp)
    return d


_PRINTED = re.compile(r"[+-]?\d*(?:\.(?P<frac>\d*))?(?:[eE](?P<exp>[+-]?\d+))?")


def _group_frame(hblocks: list[_Block], meta: PcsMetadata, path: str) -> Any:  # noqa: C901 (each column group the PCS software writes is a case)
    """Parse the tables of all steps sharing one column header."""
    import pandas as pd

    first = hblocks[0]
    cells = first.header_cells or []
    ncol = len(cells)
    cols = _resolve_header(cells, path, first.step.header_line or 0, meta)
    plot = []  # the plot block: the header's cells up to the first empty one
    for c in cols:
        if not c.cell:
            break
        plot.append(c.name)
    for b in hblocks:
        b.step.plot_x, b.step.plot_y = (plot[0], plot[1:]) if plot else ("", [])
    num_idx = [c.index for c in cols if not c.text]
    text_idx = [c.index for c in cols if c.text]
    data: list[str] = []
    line_nos = []
    for b in hblocks:
        data.extend(b.data)
        line_nos.append(np.arange(b.data_first_line, b.data_first_line + len(b.data)))
    lines_arr = np.concatenate(line_nos)
    arr = _parse_rows(data, lines_arr, ncol, num_idx, cells, path, exact=bool(text_idx))
    values: dict[int, np.ndarray] = {j: arr[:, k] for k, j in enumerate(num_idx)}
    split_cache: list[list[str]] | None = None

    def column_text(j: int) -> list[str]:
        nonlocal split_cache
        if split_cache is None:
            split_cache = [ln.split("\t") for ln in data]
        return [f[j] for f in split_cache]

    # resolve names: empty cells, duplicates
    out: dict[str, np.ndarray] = {}
    out_cell: dict[str, str] = {}
    by_name: dict[str, list[_Col]] = {}
    for c in cols:
        if c.text:
            txt = [t.strip() for t in column_text(c.index)]
            if any(txt):
                out[c.name] = np.array(txt, dtype=object)
                out_cell[c.name] = c.cell
            continue
        v = values[c.index]
        if not c.name:
            if np.isfinite(v).any():
                nm = f"unnamed_col{c.index + 1}"
                meta.warnings.append(f"line {first.step.header_line}: column {c.index + 1} has no "
                                     f"header but holds values; kept as {nm!r}")
                out[nm] = v
                out_cell[nm] = ""
            continue
        by_name.setdefault(c.name, []).append(c)
    for nm, group in by_name.items():
        keep = group[-1]
        kv = values[keep.index] * keep.scale + keep.offset
        out[nm] = kv
        out_cell[nm] = keep.cell
        for c in group[:-1]:
            v = values[c.index] * c.scale + c.offset
            both = np.isfinite(v) & np.isfinite(kv)
            only_early = np.isfinite(v) & ~np.isfinite(kv)
            if not np.isfinite(v).any():
                continue
            if not np.isfinite(kv).any():
                out[nm] = v
                out_cell[nm] = c.cell
                kv = v
                continue
            diff = np.abs(v[both] - kv[both])
            agree = not only_early.any()
            if agree and not np.all(diff <= 1e-12 * np.abs(kv[both])):
                # compare to the printed precision of both columns (the plot block is rounded)
                d1 = _decimals(column_text(c.index))
                d2 = _decimals(column_text(keep.index))
                tol = (0.5 * 10.0 ** (-d1) * abs(c.scale) + 0.5 * 10.0 ** (-d2) * abs(keep.scale)) \
                    * (1 + 1e-9) + 1e-12 * np.abs(kv[both])
                agree = bool(np.all(diff <= tol))
            if not agree:
                alt = f"{nm}_col{c.index + 1}"
                meta.warnings.append(f"line {first.step.header_line}: column {c.cell!r} appears "
                                     f"twice with different values; the later is {nm!r}, the "
                                     f"earlier kept as {alt!r}")
                out[alt] = v
                out_cell[alt] = c.cell
    for nm, cell in out_cell.items():
        meta.columns.setdefault(nm, cell)
    n = len(data)
    frame: dict[str, Any] = {}
    step_no = np.concatenate([np.full(len(b.data), b.step.number, dtype=np.int64) for b in hblocks])
    step_type = np.concatenate([np.full(len(b.data), b.step.type, dtype=object) for b in hblocks])
    frame["step"] = step_no
    frame["step_type"] = step_type
    for nm, v in out.items():
        if v.dtype != object and not np.isfinite(v).any():
            continue  # a column never logged (Pin Load, TF3 ...)
        frame[nm] = v
    frame["line"] = lines_arr.astype(np.int64)
    assert all(len(v) == n for v in frame.values())
    return pd.DataFrame(frame)


def _parse_rows(data: list[str], line_nos: np.ndarray, ncol: int, use: list[int],
                cells: list[str], path: str, *, exact: bool = False) -> np.ndarray:
    """Float array (n_rows, len(use)); empty fields are NaN; errors name the line and column
    (:func:`torlab.parsers._table.parse_rows`: every row has the header's field count)."""
    from torlab.parsers._table import RowSpec, parse_rows

    spec = RowSpec([c.strip() or f"column {j + 1}" for j, c in enumerate(cells)], use, path,
                   delimiter="\t", allow_empty=[True] * len(use),
                   hint=" (PCS exports use '.')")
    return parse_rows(data, line_nos, spec)


# ---------------------------------------------------------------------- coefficient sign
def _coefficient_convention(df: Any, meta: PcsMetadata) -> None:
    need = ("traction_coefficient", "traction_force_N")
    if not all(c in df for c in need):
        return
    c = df["traction_coefficient"].to_numpy(dtype=float)
    f = df["traction_force_N"].to_numpy(dtype=float)
    signed = np.where(np.isfinite(f) & (f != 0), np.copysign(np.abs(c), f), c)
    df.insert(int(df.columns.get_loc("traction_coefficient")) + 1, "traction_coefficient_signed",
              signed)
    meta.columns["traction_coefficient_signed"] = "Traction Coeff with the sign of Traction Force"
    if "ball_load_N" not in df:
        meta.coefficient_convention = "undetermined"
        return
    w = df["ball_load_N"].to_numpy(dtype=float)
    ok = np.isfinite(c) & np.isfinite(f) & np.isfinite(w) & (w > 0)
    if not ok.any():
        meta.coefficient_convention = "undetermined"
        return
    r = f[ok] / w[ok]
    cc = c[ok]
    tol = np.maximum(6e-5, 3e-3 * np.abs(r))  # PCS prints 4 decimals
    as_signed = np.abs(cc - r) <= tol
    as_mag = np.abs(cc - np.abs(r)) <= tol
    neg = r < -tol
    if as_signed.all():
        meta.coefficient_convention = "signed" if neg.any() else "consistent"
    elif as_mag.all():
        meta.coefficient_convention = "magnitude"
        meta.warnings.append(
            f"'Traction Coeff' is |Traction Force| / Ball Load while 'Traction Force' is signed "
            f"({int(neg.sum())} rows with a negative force); traction_coefficient_signed carries "
            "the sign of the force")
    else:
        bad = int((~(as_signed | as_mag)).sum())
        meta.coefficient_convention = "inconsistent"
        meta.warnings.append(f"'Traction Coeff' differs from Traction Force / Ball Load in {bad} "
                             "rows (kept as written)")


def _refuse_impossible(df: Any, display: str) -> None:
    """Values no test produces are errors naming the line and column.

    A load column (``Ball Load``, ``Pin Load``) below ``-LOAD_ZERO_NOISE_N`` (a normal load
    cannot pull) or above the largest possible load (``torlab.units.RANGES["load"]``); a
    traction coefficient beyond :data:`MAX_COEFFICIENT` (no contact's traction is ten times
    its load: a broken column).  Readings around zero (an unloaded step) stay;
    :func:`torlab.reduce.mtm.mu_series` derives no coefficient from them and says so.
    """
    from torlab.units import RANGES

    high = RANGES["load"].high
    for c in ("ball_load_N", "pin_load_N"):
        if c not in df:
            continue
        w = df[c].to_numpy(dtype=float)
        bad = (w < -LOAD_ZERO_NOISE_N) | (w > high)  # NaN (an empty cell) compares False
        if bad.any():
            i = int(np.argmax(bad))
            line = int(df["line"].iloc[i]) if "line" in df else None
            why = f"a load cell at rest reads within {LOAD_ZERO_NOISE_N:g} N of zero" \
                if w[i] < 0 else f"the largest possible is {high:g} N"
            raise TorlabInputError(f"{w[i]:g} N is not possible for a normal load ({why}); check "
                                   "the value and the column's unit", path=display, line=line,
                                   key={"ball_load_N": "Ball Load", "pin_load_N": "Pin Load"}[c])
    for c in df.columns:
        limit = _largest(str(c), RANGES)
        if limit is None:
            continue
        top, what, unit, scale = limit
        v = df[c].to_numpy(dtype=float)
        bad = np.abs(v) > top  # NaN compares False
        if bad.any():
            i = int(np.argmax(bad))
            line = int(df["line"].iloc[i]) if "line" in df else None
            raise TorlabInputError(f"{v[i] / scale:g}{unit} is not possible for {what} (at most "
                                   f"{top / scale:g}{unit} in magnitude); check the value and "
                                   "the column's unit", path=display, line=line,
                                   key=f"column {_pcs_name(str(c))!r}")


def _pcs_name(col: str) -> str:
    """The PCS name of a torlab column, for messages (``lube_temperature_C`` -> ``Lube
    Temp``)."""
    base = re.sub(r"_col\d+$", "", col)
    for k, v in PCS_COLUMNS.items():
        if v[0] == base:
            return k.upper() if len(k) <= 3 else k.title()
    return col


def _largest(col: str, ranges: Any) -> tuple[float, str, str, float] | None:
    """``(largest magnitude in SI, what, unit shown, its scale)`` of a PCS column no test
    exceeds (``None``: not checked here)."""
    if col.startswith("traction_coefficient") or col.startswith("rolling_coefficient"):
        return MAX_COEFFICIENT, "a traction coefficient of any contact", "", 1.0
    if col.endswith("_m_s"):
        return ranges["speed"].high, "a speed", " m/s", 1.0
    if col == "srr":
        return ranges["creepage"].high, "a slide-roll ratio", " %", 0.01
    if col.endswith("force_N") or ("force_" in col and col.endswith("_N")):
        return ranges["load"].high, "a force", " N", 1.0
    return None


def coefficient_column(df: Any) -> tuple[str, str]:
    """The column holding the signed traction coefficient, and a description of its source.

    ``traction_coefficient_signed`` where the file has traction force and
    coefficient; else ``traction_coefficient``; else ``""`` (compute it from
    a traction force and the load).
    """
    if "traction_coefficient_signed" in df:
        return "traction_coefficient_signed", "PCS Traction Coeff with the sign of Traction Force"
    if "traction_coefficient" in df:
        return "traction_coefficient", "PCS Traction Coeff as written"
    return "", ""


def step_table(df: Any, meta: PcsMetadata, number: int) -> Any:
    """One step's rows, with only the columns that step logged.

    Raises
    ------
    TorlabInputError
        No such step, or the step has no data rows.
    """
    step = meta.step(number)
    sub = df[df["step"] == number]
    if sub.empty:
        raise TorlabInputError(f"step {number} ({step.type_raw}) has no data rows",
                               path=meta.source, line=step.first_line)
    keep = [c for c in sub.columns if c in ("step", "step_type", "line") or sub[c].notna().any()]
    return sub[keep].reset_index(drop=True)
