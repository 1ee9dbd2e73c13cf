"""High-pressure torsion (HPT) raw logs: the ``torlab-hpt`` text format.

The rig (thesis 5.1.3) presses a flat specimen against an annulus (r1 = 3 mm,
r2 = 6 mm) and turns the upper specimen through a loading arm driven by a screw
jack.  It logs the normal force, the force on the arm's transducer (torque =
force x arm length), the rotary encoder angle of the shaft, the worm-screw motor
position (finer, about 0.00045 deg of arm angle) and the heater temperature.

The format is documented with a complete example in ``docs/formats/hpt.md``::

    # torlab-hpt 1
    # product: OFM1
    # applied_amount: 4 uL
    # r1: 3 mm
    # r2: 6 mm
    # arm_length: 300 mm
    time [s],normal_force [kN],arm_force [N],encoder_angle [deg],motor_angle [deg]
    0.00,63.61,0.8,0.000,0.00000
    ...

Another rig's CSV is read through a *column map* (YAML, see the same document)
that names its columns, units, delimiter and the metadata it lacks, so no code
needs editing.

:func:`read_hpt` returns ``(DataFrame, HptMetadata)``.  The DataFrame has SI
columns ``time_s``, ``normal_force_N``, ``torque_N_m`` (from the arm force and
arm length when the log has ``arm_force``), ``encoder_angle_rad`` and/or
``motor_angle_rad``, and ``heater_temperature_C`` where logged; ``line`` holds
the file line of each row for messages.
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
    detect_delimiter,
    header_key,
    read_log_header,
    read_text,
    refuse_below_absolute_zero,
    split_unit,
)

__all__ = ["COLUMNS", "FORMAT_ID", "METADATA_KEYS", "HptMetadata", "read_hpt", "read_hpt_map"]

FORMAT_ID = "torlab-hpt"
FORMAT_VERSION = 1

#: canonical column -> (quantity kind, SI column name in the DataFrame)
COLUMNS: dict[str, tuple[str, str]] = {
    "time": ("time", "time_s"),
    "normal_force": ("force", "normal_force_N"),
    "arm_force": ("force", "arm_force_N"),
    "torque": ("torque", "torque_N_m"),
    "encoder_angle": ("angle", "encoder_angle_rad"),
    "motor_angle": ("angle", "motor_angle_rad"),
    "heater_temperature": ("temperature", "heater_temperature_C"),
}

#: header key -> quantity kind ("text" for free text, "amount" for a volume or a mass)
METADATA_KEYS: dict[str, str] = {
    "product": "text",
    "product_type": "text",
    "applied_amount": "amount",
    "product_density": "density",
    "temperature": "temperature",
    "r1": "length",
    "r2": "length",
    "arm_length": "length",
    "encoder_resolution": "angle",
    "motor_resolution": "angle",
    "normal_stress_set": "pressure",
    "displacement_rate_set": "velocity",
    "rig_compliance": "compliance",
    "specimen": "text",
    "condition": "text",
    "run_id": "text",
    "operator": "text",
    "date": "text",
    "notes": "text",
}

#: header key -> plausible-range quantity (torlab.units.RANGES); amounts by their kind
HEADER_RANGES: dict[str, str] = {
    "product_density": "density", "temperature": "temperature", "r1": "annulus_radius",
    "r2": "annulus_radius", "arm_length": "arm_length", "normal_stress_set": "stress",
    "displacement_rate_set": "displacement_rate", "rig_compliance": "rig_compliance",
    "volume": "amount_volume", "mass": "amount_mass",
}


@dataclass
class HptMetadata(LogMetadata):
    """Header of an HPT log, in SI units (temperatures in degC).

    Attributes
    ----------
    r1, r2
        Inner and outer radius of the annulus (m).
    arm_length
        Loading-arm length (m); None when the log has a torque column.
    applied_amount
        Applied product amount in SI (m^3 or kg) and ``applied_amount_unit``
        the unit it was written in (``"uL"``, ``"mg"``); ``applied_amount_kind``
        is ``"volume"`` or ``"mass"``.
    displacement_source
        Filled by the reduction: ``"motor"`` or ``"encoder"``.
    extra
        User keys starting with ``x_`` (kept as text).
    """

    product: str = ""
    product_type: str = ""
    applied_amount: float | None = None
    applied_amount_unit: str = ""
    applied_amount_kind: str = ""
    applied_amount_value: float | None = None
    product_density: float | None = None
    temperature: float | None = None
    r1: float | None = None
    r2: float | None = None
    arm_length: float | None = None
    encoder_resolution: float | None = None
    motor_resolution: float | None = None
    normal_stress_set: float | None = None
    displacement_rate_set: float | None = None
    rig_compliance: float | None = None
    specimen: str = ""
    condition: str = ""


    @property
    def label(self) -> str:
        """Short label for plots and tables: product, amount, temperature."""
        parts = [self.product or Path(self.source).stem]
        if self.condition:
            parts.append(self.condition)
        if self.applied_amount_value is not None:
            parts.append(f"{self.applied_amount_value:g} {self.applied_amount_unit}")
        if self.temperature is not None:
            parts.append(f"{self.temperature:g} °C")
        return " ".join(parts)


def _set_meta(meta: HptMetadata, key: str, value: str, *, path: str, line: int | None,
              source: str = "header") -> None:
    from torlab.units import NUMBER_PATTERN, check_range, parse_unit_factor, to_si

    key = key.strip()
    value = str(value).strip()
    kind = header_key(meta, key, value, METADATA_KEYS, path, line, source)
    if kind is None:
        return
    if kind == "text":
        setattr(meta, key, value)
        return
    if kind == "amount":
        m = NUMBER_PATTERN.match(value)
        unit = m.group("unit") if m else ""
        for amount_kind in ("volume", "mass"):
            try:
                si = to_si(value, amount_kind, where=key, path=path, line=line)
            except TorlabInputError:
                continue
            if not unit:
                raise TorlabInputError("applied_amount needs a unit (e.g. '4 uL' or '2 mg')",
                                       path=path, line=line, key=key)
            check_range(HEADER_RANGES[amount_kind], si, where=key, path=path, line=line)
            meta.applied_amount = si
            meta.applied_amount_kind = amount_kind
            meta.applied_amount_unit = unit
            meta.applied_amount_value = float(m.group("num"))
            return
        if unit:
            parse_unit_factor(unit, "volume", where=key, path=path, line=line)  # raises a clear error
        raise TorlabInputError(f"{value!r} is not an amount (write e.g. '4 uL' or '2 mg')",
                               path=path, line=line, key=key)
    m = NUMBER_PATTERN.match(value)
    if m and not m.group("unit") and kind not in ("dimensionless",):
        from torlab.units import example_quantity

        raise TorlabInputError(f"needs a unit (e.g. {example_quantity(kind)}); a plain number "
                               f"would be taken as SI ({value} {_si_unit(kind)})", path=path,
                               line=line, key=key)
    si = to_si(value, kind, where=key, path=path, line=line)
    if key in HEADER_RANGES:
        check_range(HEADER_RANGES[key], si, where=key, path=path, line=line)
    setattr(meta, key, si)


def _si_unit(kind: str) -> str:
    from torlab.units import KINDS

    return KINDS[kind][1]


def read_hpt_map(path: PathOrBuffer) -> dict[str, Any]:
    """Read and check a column-map YAML file for another rig's CSV.

    Keys: ``delimiter`` (default ``","``), ``decimal`` (``"."``),
    ``header_line`` (1-based line of the column names; default: the first line
    that is not a ``#`` comment), ``skip_lines_after_header`` (e.g. a units row),
    ``columns`` (canonical name -> ``{name, unit, scale}``) and ``metadata``
    (header keys the file lacks).  See ``docs/formats/hpt.md``.
    """
    from torlab.yamlio import load_yaml, load_yaml_text

    if isinstance(path, (str, Path)):
        doc = load_yaml(path)
    else:
        text, display = read_text(path)
        doc = load_yaml_text(text, display)
    d = doc.data
    if not isinstance(d, dict):
        raise doc.error((), "a column map must be a YAML mapping with a 'columns' section")
    allowed = {"delimiter", "decimal", "header_line", "skip_lines_after_header", "columns",
               "metadata", "description"}
    for k in d:
        if k not in allowed:
            raise doc.error((k,), f"unknown key (known: {', '.join(sorted(allowed))})")
    cols = d.get("columns")
    if not isinstance(cols, dict) or not cols:
        raise doc.error(("columns",), "needs a 'columns' mapping of torlab names to the rig's columns")
    out_cols: dict[str, dict[str, Any]] = {}
    for canon, spec in cols.items():
        if canon not in COLUMNS:
            raise doc.error(("columns", canon), f"unknown column (known: {', '.join(COLUMNS)})")
        if isinstance(spec, str):
            spec = {"name": spec}
        if not isinstance(spec, dict) or "name" not in spec:
            raise doc.error(("columns", canon), "write {name: <rig column>, unit: <unit>, scale: <optional>}")
        for k in spec:
            if k not in ("name", "unit", "scale"):
                raise doc.error(("columns", canon, k), "unknown key (known: name, unit, scale)")
        out_cols[canon] = {"name": str(spec["name"]), "unit": str(spec.get("unit", "")),
                           "scale": spec.get("scale"),
                           "line": doc.lines.line(("columns", canon))}
    meta = d.get("metadata") or {}
    if not isinstance(meta, dict):
        raise doc.error(("metadata",), "must be a mapping of header keys to values")
    delimiter, decimal, header_line, skip = _map_layout(doc, d)
    return {
        "path": doc.path or "<map>",
        "delimiter": delimiter,
        "decimal": decimal,
        "header_line": header_line,
        "skip": skip,
        "columns": out_cols,
        "metadata": {str(k): (str(v), doc.lines.line(("metadata", k))) for k, v in meta.items()},
    }


def _map_layout(doc: Any, d: dict[str, Any]) -> tuple[str, str, int | None, int]:
    """A column map's delimiter, decimal mark, header line and lines skipped, checked: an
    error naming the map's line for one that cannot be meant."""
    delimiter = d.get("delimiter", ",")
    if not isinstance(delimiter, str):
        raise doc.error(("delimiter",), "must be one character in quotes (e.g. ';' or '\\t')")
    delimiter = {"\\t": "\t", "tab": "\t"}.get(delimiter, delimiter)
    if len(delimiter) != 1 or delimiter in "0123456789.+-eE\"\r\n#":
        raise doc.error(("delimiter",), f"must be one character that cannot be part of a "
                        f"number (e.g. ';', ',' or '\\t'), got {delimiter!r}")
    decimal = d.get("decimal", ".")
    if decimal not in (".", ","):
        raise doc.error(("decimal",), f"must be '.' or ',', got {decimal!r}")
    if decimal == delimiter:
        raise doc.error(("decimal",), f"the decimal mark {decimal!r} cannot also be the "
                        "delimiter")
    header_line = d.get("header_line")
    if header_line is not None and (not isinstance(header_line, int)
                                    or isinstance(header_line, bool) or header_line < 1):
        raise doc.error(("header_line",), f"must be a whole number >= 1 (the line of the "
                        f"column names), got {header_line!r}")
    skip = d.get("skip_lines_after_header", 0)
    if skip is None:
        skip = 0
    if not isinstance(skip, int) or isinstance(skip, bool) or skip < 0:
        raise doc.error(("skip_lines_after_header",), f"must be a whole number >= 0 (lines "
                        f"between the column names and the first row), got {skip!r}")
    return delimiter, decimal, header_line, skip


def read_hpt(src: PathOrBuffer, mapping: PathOrBuffer | dict[str, Any] | None = None, *,
             name: str | None = None) -> tuple[Any, HptMetadata]:
    """Read an HPT raw log.

    Parameters
    ----------
    src
        Path or text/bytes buffer of a ``torlab-hpt`` log, or of another rig's
        CSV when ``mapping`` is given.
    mapping
        Column map (path to YAML, or the dict :func:`read_hpt_map` returns).
    name
        Display name for messages when ``src`` is a buffer.

    Returns
    -------
    df : pandas.DataFrame
        SI columns (see module docstring) and ``line`` (file line of each row).
    meta : HptMetadata
        Header values in SI units.

    Raises
    ------
    TorlabInputError
        One clear problem, naming the file and line: empty file, missing
        header key or column, unknown key or unit, wrong delimiter, truncated
        row, text in a number column, zero or negative load, angle or time
        going backwards.
    """
    try:
        return _read_hpt(src, mapping, name=name)
    except MemoryError:
        from torlab.parsers._table import memory_error

        raise memory_error(src, name) from None


def _read_hpt(src: PathOrBuffer, mapping: PathOrBuffer | dict[str, Any] | None, *,
              name: str | None) -> tuple[Any, HptMetadata]:
    from torlab.parsers._table import RowSpec, TextFile, read_columns

    if mapping is not None and not isinstance(mapping, dict):
        mapping = read_hpt_map(mapping)
    with TextFile(src, name=name) as tf:
        display = tf.display
        meta = HptMetadata(source=display)
        lines, header_idx, delimiter, decimal, skip, colspecs = _header(tf, mapping, meta)
        header_line_no = header_idx + 1
        header = lines[header_idx]
        fields = header.split(delimiter)
        if len(fields) == 1:
            other = detect_delimiter(header, [d for d in (",", "\t", ";", "|") if d != delimiter])
            if other is not None:
                raise TorlabInputError(
                    f"columns are separated by {other!r}, expected {delimiter!r}"
                    + (" (set 'delimiter' in the column map)" if mapping else
                       " (torlab-hpt logs are comma-separated; use --map for other layouts)"),
                    path=display, line=header_line_no)
        use_idx, si_names, scales, offsets = _resolve_columns(
            fields, colspecs, meta, display, header_line_no, mapping)
        first = header_line_no + 1 + skip  # file line of the first data row
        spec = RowSpec([f.strip() for f in fields], use_idx, display, delimiter=delimiter,
                       decimal=decimal, scales=scales, offsets=offsets,
                       units=[split_unit(fields[j])[1] for j in use_idx],
                       hint=" (declare decimal: ',' in a column map)" if mapping else
                       " (torlab-hpt logs use '.')")
        try:
            cols = read_columns(tf, first, spec)
        except TorlabInputError as e:
            if skip and e.message.startswith("no data rows"):
                raise TorlabInputError(f"no data rows after the column header and the {skip} "
                                       "lines skipped after it (skip_lines_after_header)",
                                       path=display, line=header_line_no) from None
            raise
    data = dict(zip(si_names, cols, strict=True))
    if "arm_force_N" in data:
        if meta.arm_length is None:
            raise TorlabInputError("the log has an arm_force column but no 'arm_length' header "
                                   "(torque = arm force x arm length)", path=display)
        arm = data.pop("arm_force_N")
        if "torque_N_m" not in data:
            arm *= meta.arm_length  # in place: a long log's column is not copied
            data["torque_N_m"] = arm
    n = len(cols[0])
    data["line"] = np.arange(first, first + n)
    import pandas as pd

    df = pd.DataFrame(data, copy=False)
    for req in ("r1", "r2"):
        if getattr(meta, req) is None:
            raise TorlabInputError(f"missing header key {req!r} (annulus radius, e.g. "
                                   f"'# {req}: {3 if req == 'r1' else 6} mm')", path=display)
    if not (0 <= meta.r1 < meta.r2):  # type: ignore[operator]
        raise TorlabInputError(f"annulus radii must satisfy 0 <= r1 < r2 (got r1 = "
                               f"{meta.r1 * 1e3:g} mm, r2 = {meta.r2 * 1e3:g} mm)", path=display,  # type: ignore[operator]
                               line=meta.lines.get("r2"))
    _check_rows(df, meta, display)
    refuse_below_absolute_zero(df, display)
    return df, meta


def _header(tf: Any, mapping: dict[str, Any] | None, meta: HptMetadata
            ) -> tuple[list[str], int, str, str, int, dict[str, Any] | None]:
    """The lines up to the column header, its index, the delimiter, decimal mark, lines
    skipped after it and the map's columns (None for a torlab-hpt log)."""
    display = tf.display
    if mapping is None:
        lines = tf.head(lambda ln, s: ln > 1 and bool(s.strip())
                        and not s.lstrip().startswith("#"))
    elif mapping["header_line"] is not None:
        lines = tf.head(lambda ln, s: ln >= mapping["header_line"])
    else:
        lines = tf.head(lambda ln, s: bool(s.strip()) and not s.lstrip().startswith("#"))
    if not any(s.strip() for s in lines):
        raise TorlabInputError("file is empty", path=display)
    if mapping is None:
        header_idx, delimiter, decimal, skip = _read_native_header(lines, meta, display)
        return lines, header_idx, delimiter, decimal, skip, None
    header_idx, delimiter, decimal, skip = _locate_mapped_header(lines, mapping, display)
    for k, (v, ln) in mapping["metadata"].items():
        _set_meta(meta, k, v, path=mapping["path"], line=ln, source="column-map metadata")
    return lines, header_idx, delimiter, decimal, skip, mapping["columns"]


def _read_native_header(lines: list[str], meta: HptMetadata, display: str) -> tuple[int, str, str, int]:
    meta.format_version, i = read_log_header(
        lines, FORMAT_ID, FORMAT_VERSION, display,
        lambda k, v, ln: _set_meta(meta, k, v, path=display, line=ln),
        hint=" (for another rig's CSV pass a column map with --map)")
    return i, ",", ".", 0


def _locate_mapped_header(lines: list[str], mapping: dict[str, Any], display: str) -> tuple[int, str, str, int]:
    hl = mapping["header_line"]
    if hl is not None:
        idx = int(hl) - 1
        if idx >= len(lines):
            raise TorlabInputError(f"header_line {hl} is beyond the end of the file "
                                   f"({len(lines)} lines)", path=display,
                                   key="header_line")
    else:
        idx = next((i for i, s in enumerate(lines) if s.strip() and not s.lstrip().startswith("#")), None)
        if idx is None:
            raise TorlabInputError("no column header line", path=display)
    return idx, mapping["delimiter"], mapping["decimal"], mapping["skip"]


def _resolve_columns(fields: list[str], colspecs: dict[str, Any] | None, meta: HptMetadata,  # noqa: C901 (each column of the rig's export and its unit is a case)
                     display: str, header_line_no: int, mapping: dict[str, Any] | None):
    from torlab.units import parse_unit_factor, to_si

    found: dict[str, tuple[int, str, float]] = {}  # canon -> (index, unit, scale)
    if colspecs is None:
        for j, f in enumerate(fields):
            nm, unit = split_unit(f)
            if nm in found:
                raise TorlabInputError(f"column {nm!r} appears twice", path=display, line=header_line_no)
            if nm not in COLUMNS:
                if nm.startswith("x_"):
                    continue
                raise TorlabInputError(f"unknown column {nm!r} (known: {', '.join(COLUMNS)}; "
                                       "prefix your own with x_)", path=display, line=header_line_no)
            if not unit:
                raise TorlabInputError(f"column {nm!r} has no unit; write '{nm} [unit]'",
                                       path=display, line=header_line_no)
            found[nm] = (j, unit, 1.0)
    else:
        stripped = [f.strip() for f in fields]
        for canon, spec in colspecs.items():
            nm = spec["name"]
            if nm not in stripped:
                raise TorlabInputError(f"column {nm!r} (mapped to {canon}) not found in the header; "
                                       f"the header has: {', '.join(stripped)}", path=display,
                                       line=header_line_no)
            j = stripped.index(nm)
            mloc = {"path": mapping["path"], "line": spec.get("line")}
            if spec.get("scale") is not None:
                # raw readings (e.g. counts) times a quantity per reading
                scale = to_si(spec["scale"], COLUMNS[canon][0], where=f"columns.{canon}.scale", **mloc)
                found[canon] = (j, "", scale)
            elif spec["unit"]:
                found[canon] = (j, spec["unit"], 1.0)
            else:
                raise TorlabInputError(f"the column map gives neither a unit nor a scale for {canon}",
                                       key=f"columns.{canon}", **mloc)
    for req in ("time", "normal_force"):
        if req not in found:
            raise TorlabInputError(f"missing column {req!r}", path=display, line=header_line_no)
    if "arm_force" not in found and "torque" not in found:
        raise TorlabInputError("missing column: need 'arm_force' (with the arm_length header) or 'torque'",
                               path=display, line=header_line_no)
    if "encoder_angle" not in found and "motor_angle" not in found:
        raise TorlabInputError("missing column: need 'motor_angle' and/or 'encoder_angle'",
                               path=display, line=header_line_no)
    use_idx, si_names, scales, offsets = [], [], [], []
    for canon, (j, unit, scale) in found.items():
        kind, si = COLUMNS[canon]
        if unit:
            if colspecs is None:
                uloc = {"path": display, "line": header_line_no}
            else:
                uloc = {"path": mapping["path"], "line": colspecs[canon].get("line")}
            sc, off = parse_unit_factor(unit, kind, where=f"column {canon!r}", **uloc)
        else:
            sc, off = scale, 0.0
        use_idx.append(j)
        si_names.append(si)
        scales.append(sc)
        offsets.append(off)
        meta.columns[si] = fields[j].strip()
    return use_idx, si_names, scales, offsets


def _first_bad(mask: np.ndarray, df: Any) -> int:
    return int(df["line"].to_numpy()[int(np.argmax(mask))])


def _check_rows(df: Any, meta: HptMetadata, display: str) -> None:
    fn = df["normal_force_N"].to_numpy()
    if (fn <= 0).any():
        bad = fn <= 0
        raise TorlabInputError(f"normal force must be positive, got {fn[np.argmax(bad)]:g} N",
                               path=display, line=_first_bad(bad, df), key="normal_force")
    t = df["time_s"].to_numpy()
    if len(t) > 1 and (np.diff(t) <= 0).any():
        bad = np.r_[False, np.diff(t) <= 0]
        raise TorlabInputError("time does not increase", path=display, line=_first_bad(bad, df),
                               key="time")
    for col, res in (("motor_angle_rad", meta.motor_resolution),
                     ("encoder_angle_rad", meta.encoder_resolution)):
        if col not in df:
            continue
        a = df[col].to_numpy()
        if len(a) < 2:
            continue
        # a quantised angle may jitter by one count; more than that is a real reversal
        tol = 1.0001 * res if res else 0.0
        d = np.diff(a)
        if (d < -tol).any():
            bad = np.r_[False, d < -tol]
            i = int(np.argmax(bad))
            raise TorlabInputError(
                f"angle goes backwards by {math.degrees(-d[i - 1]):.6g} deg (the reduction needs a "
                "monotone angle; split the log at reversals)", path=display,
                line=int(df['line'].to_numpy()[i]), key=col.removesuffix('_rad'))
