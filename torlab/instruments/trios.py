"""TA Instruments TRIOS rheometer text exports (registry entry ``trios``).

A TRIOS "export to text" file is tab-separated: a header of ``key<TAB>value`` lines
(``Filename``, ``Instrument name``, ``rundate`` ...), then one block per procedure
step::

    [step]
    Temperature ramp - 2
    Stress<TAB>Shear rate<TAB>Viscosity<TAB>Step time<TAB>Temperature<TAB>Normal stress
    dyne/cm²<TAB>1/s<TAB>Pa.s<TAB>s<TAB>°C<TAB>dyne/cm²
    72.7304<TAB>200.000<TAB>0.0363652<TAB>10.0400<TAB>25.004<TAB>-825.549
    ...

The units row under the column names gives each column's unit, in TRIOS's spelling
(``dyne/cm²``, ``Pa.s``, ``°C``, ``µN.m``); every value is converted to SI here, at the
edge, with :func:`torlab.units.parse_unit_factor` (pint for the units torlab's table does
not hold).  TRIOS writes the units of columns it did not export after the last one (a
units row longer than the column names): those are left out.  Columns torlab does not
know (oscillation quantities ...) are left out with a note.  The file is read through
torlab's reader layer (:mod:`torlab.parsers._table`: size bound, UTF-8, Windows-1252 or
UTF-16 with its BOM, every line end alike) and each step's rows with its rules: a row with
another number of fields than the column names, a cell that is not a finite number (text,
NaN, an empty cell or a cell of spaces, a decimal comma in a step written with points), a
value beyond 1e100 once in SI units, a viscosity that is not positive or a temperature
below absolute zero is an error naming the line and column.  A step whose rows hold
commas and no point is read with decimal commas.

The reduction gives viscosity against shear rate, time and temperature: every point
(``points``: SI units, the step and the file line of each), one row per step
(``steps``: what the step varies, its ranges, the mean viscosity and its spread) and,
with ``temperature``, the viscosity at that temperature from the points around it
(``viscosity_at``: ln eta against T fitted by least squares, with its 95 % interval) and
the scene's ``lubricant: eta0`` as ``<name>_lubricant.yaml``.  Where the stress, the
shear rate and the viscosity are all exported, their agreement (``eta = tau / rate``) is
checked: a units row that does not match the numbers shows there.

The export format is described in ``docs/formats/trios.md``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError
from torlab.instruments.plugin import Command, Option
from torlab.instruments.reduction import Reduction

NAME = "trios"
TITLE = "TA Instruments rotational rheometer (TRIOS)"
FILES = "TRIOS text exports (tab-separated, [step] blocks, a units row)"
EXTENSIONS = (".txt",)
ALIASES: dict[str, dict[str, Any]] = {"rheometer": {}, "tainstruments": {}}

OPTIONS: dict[str, Option] = {
    "temperature": Option("temperature", None, "Also give the viscosity at this temperature "
                          "(e.g. '40 degC'): ln eta against T fitted to the points within the "
                          "temperature band around it, written as the scene's lubricant eta0."),
    "temperature_band": Option("temperature_difference", 1.0, "Half-width of the band of "
                               "measured temperatures used for the viscosity at --temperature.",
                               check="positive", unit="K"),
}

COMMAND = Command(
    "trios", "TA Instruments TRIOS rheometer exports: viscosity against shear rate, time and "
    "temperature, units converted to SI.",
    """Reduce TRIOS text exports: every step's points in SI units (stress from dyne/cm² to
    Pa ...), what each step varies (shear rate, temperature or time), its ranges and mean
    viscosity with its spread; the viscosity from the stress and the shear rate checked
    against the exported viscosity; with --temperature the viscosity at that temperature
    with its 95 % interval.

    Writes per input '<name>_points.csv', '<name>_steps.csv' and '<name>.png' (viscosity
    against time, temperature and shear rate); with --temperature '<name>_viscosity_at.csv'
    and '<name>_lubricant.yaml'; 'summary.csv' with one row per input.
    """,
    "TRIOS text exports (docs/formats/trios.md); folders and patterns are expanded.",
    argument="exports", what="TRIOS export")

#: TRIOS column name (lower case) -> (torlab column, quantity kind)
COLUMNS: dict[str, tuple[str, str]] = {
    "stress": ("shear_stress_Pa", "pressure"),
    "shear stress": ("shear_stress_Pa", "pressure"),
    "shear rate": ("shear_rate_1_s", "frequency"),
    "viscosity": ("viscosity_Pa_s", "viscosity"),
    "step time": ("step_time_s", "time"),
    "time": ("time_s", "time"),
    "total time": ("time_s", "time"),
    "temperature": ("temperature_C", "temperature"),
    "normal stress": ("normal_stress_Pa", "pressure"),
    "normal force": ("normal_force_N", "force"),
    "torque": ("torque_N_m", "torque"),
    "gap": ("gap_m", "length"),
}
#: the column every step needs
REQUIRED = "viscosity_Pa_s"
#: header lines before the first [step] (a longer header is not a TRIOS export)
MAX_HEADER_LINES = 500
#: a shear rate varies within a step when its largest is this factor above its smallest
RATE_VARIES = 1.5
#: a temperature varies within a step when it spans more than this (K)
TEMPERATURE_VARIES = 2.0
#: relative difference of eta and tau / rate above which the units are said to disagree
CONSISTENCY = 0.01

_STEP_NAME = re.compile(r"^(?P<kind>.*?)\s*-\s*(?P<n>\d+)\s*$")
_NUMBER = re.compile(r"[+-]?(\d+[.,]?\d*|[.,]\d+)([eE][+-]?\d+)?")


def detect(head: str) -> str:
    """``"TRIOS text export ..."`` for a file whose first line is ``Filename<TAB>...`` and
    that holds a ``[step]`` line (or the ``proceduresegments`` header key)."""
    lines = [s.strip("\r") for s in head.splitlines()]
    first = next((s for s in lines if s.strip()), "")
    if not first.startswith("Filename\t"):
        return ""
    if any(s.strip() == "[step]" or s.startswith("proceduresegments\t") for s in lines):
        return "TRIOS text export: a 'Filename' header and step blocks"
    return ""


@dataclass
class TriosStep:
    """One ``[step]`` block: its name as written, its number and kind, where it is."""

    number: int
    name: str
    kind: str
    header_line: int
    first_line: int = 0
    last_line: int = 0
    columns: dict[str, str] = field(default_factory=dict)  # torlab column -> unit as written
    left_out: list[str] = field(default_factory=list)  # columns not read, "name [unit]"


@dataclass
class TriosMetadata:
    """The export's header (``key -> value`` as written) and its steps."""

    source: str
    header: dict[str, str] = field(default_factory=dict)
    steps: list[TriosStep] = field(default_factory=list)
    decimal: str = "."
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: header, steps (number, name, kind, lines, units), notes."""
        return {"source": self.source, "header": dict(self.header), "decimal": self.decimal,
                "steps": [{"number": s.number, "name": s.name, "kind": s.kind,
                           "first_line": s.first_line, "last_line": s.last_line,
                           "units": dict(s.columns), "left_out": list(s.left_out)}
                          for s in self.steps], "notes": list(self.notes)}


def read(path: Path, **_: Any) -> tuple[Any, TriosMetadata]:
    """Parse a TRIOS text export: ``(points, metadata)``.

    Returns
    -------
    (pandas.DataFrame, TriosMetadata)
        One row per point of every step: ``step``, the known columns in SI units
        (``shear_stress_Pa``, ``shear_rate_1_s``, ``viscosity_Pa_s``, ``step_time_s``,
        ``temperature_C`` [degC], ``normal_stress_Pa`` ...) and ``line`` (1-based).

    Raises
    ------
    TorlabInputError
        Naming the file and line: no ``[step]`` block, a step without its column names
        or units row, an unknown or wrong unit, a bad field count or number, no
        viscosity column, no data row, a non-positive viscosity.
    """
    import pandas as pd

    from torlab.parsers._table import TextFile

    with TextFile(path) as tf:  # size bound, encodings, every line end alike
        display = tf.display
        lines = [s for _, s in tf.iter_lines()]
    meta = TriosMetadata(source=display)
    k = _read_header(lines, meta, display)
    frames = []
    while k < len(lines):
        step, df, k = _read_step(lines, k, meta, display)
        if step is None:
            continue
        meta.steps.append(step)
        if df is not None:
            frames.append(df)
    if not meta.steps:
        raise TorlabInputError("no [step] block: not a TRIOS text export", path=display)
    if not frames:
        raise TorlabInputError("no data rows in any step", path=display)
    df = pd.concat(frames, ignore_index=True)
    order = ["step", *dict.fromkeys(c for c, _ in COLUMNS.values() if c in df), "line"]
    return df[order], meta


def _read_header(lines: list[str], meta: TriosMetadata, display: str) -> int:
    """The ``key<TAB>value`` lines before the first ``[step]``; returns that line's index."""
    for i, raw in enumerate(lines):
        if raw.strip() == "[step]":
            return i
        if i >= MAX_HEADER_LINES:
            break
        if raw.strip():
            key, _, value = raw.partition("\t")
            meta.header[key.strip()] = value.strip()
    raise TorlabInputError("no [step] block: not a TRIOS text export", path=display)


def _step_columns(cols: list[str], units: list[str], step: TriosStep, display: str, k: int
                  ) -> tuple[list[int], list[str], list[tuple[float, float]]]:
    """The columns of a step torlab reads: their positions, torlab names and SI factors
    (``(scale, offset)`` of each unit); the others are listed in ``step.left_out``."""
    from torlab.units import parse_unit_factor

    use: list[int] = []
    names: list[str] = []
    scales: list[tuple[float, float]] = []
    for j, c in enumerate(cols):
        known = COLUMNS.get(c.lower())
        if known is None:
            step.left_out.append(f"{c} [{units[j]}]" if units[j] else c)
            continue
        col, kind_ = known
        if col in names:
            raise TorlabInputError(f"two columns of {col}", path=display, line=k + 3,
                                   key=f"column {c!r}")
        if not units[j]:
            raise TorlabInputError(f"no unit for column {c!r}", path=display, line=k + 4)
        scales.append(parse_unit_factor(units[j], kind_, where=f"column {c!r}", path=display,
                                        line=k + 4))
        use.append(j)
        names.append(col)
        step.columns[col] = units[j]
    return use, names, scales


def _read_step(lines: list[str], k: int, meta: TriosMetadata, display: str
               ) -> tuple[TriosStep | None, Any, int]:
    """The block starting at ``lines[k]`` (``[step]``, or blank lines between blocks):
    ``(step, its points or None, index after it)``."""
    import numpy as np

    from torlab.parsers._table import RowSpec, parse_rows

    if not lines[k].strip():
        return None, None, k + 1
    if lines[k].strip() != "[step]":
        raise TorlabInputError(f"expected '[step]' or a blank line between steps, found "
                               f"{lines[k][:40]!r}", path=display, line=k + 1)
    if k + 3 >= len(lines) or not lines[k + 1].strip() or lines[k + 1].strip() == "[step]" \
            or "\t" in lines[k + 1].strip():
        raise TorlabInputError("a [step] line must be followed by the step's name, its column "
                               "names and its units row", path=display, line=k + 1)
    name = lines[k + 1].strip()
    m = _STEP_NAME.match(name)
    number = int(m.group("n")) if m else len(meta.steps) + 1
    kind = (m.group("kind") if m else name).strip().lower()
    step = TriosStep(number, name, kind, header_line=k + 3)
    cols = [c.strip() for c in lines[k + 2].split("\t")]
    units = [u.strip() for u in lines[k + 3].split("\t")]
    if all(_NUMBER.fullmatch(u) for u in units if u) and any(units):
        raise TorlabInputError("no units row under the column names (this line holds numbers)",
                               path=display, line=k + 4)
    if len(units) < len(cols):
        raise TorlabInputError(f"the units row has {len(units)} units for {len(cols)} columns",
                               path=display, line=k + 4)
    use, names, scales = _step_columns(cols, units, step, display, k)
    if REQUIRED not in names:
        raise TorlabInputError(f"step {name!r} has no Viscosity column", path=display,
                               line=k + 3)
    end = k + 4
    while end < len(lines) and lines[end].strip() and lines[end].strip() != "[step]":
        end += 1
    rows = lines[k + 4:end]
    if not rows:
        meta.notes.append(f"step {number} ({name}) has no data rows")
        return step, None, end
    if meta.decimal == "." and _decimal_comma(rows):
        meta.decimal = ","
    # every row's field count, every cell a finite number with the file's decimal mark,
    # converted to SI in the layer (so a value beyond its bound is judged in SI units)
    spec = RowSpec(cols, use, display, delimiter="\t", decimal=meta.decimal,
                   scales=[a for a, _ in scales], offsets=[b for _, b in scales],
                   units=[units[j] for j in use])
    arr = parse_rows(rows, k + 5, spec)
    step.first_line, step.last_line = k + 5, end
    import pandas as pd

    data = {"step": np.full(len(rows), number)}
    for i, col in enumerate(names):
        data[col] = arr[:, i]
    data["line"] = np.arange(k + 5, end + 1)
    df = pd.DataFrame(data)
    _check_values(df, display)
    if step.left_out:
        meta.notes.append(f"step {number}: columns not read: {', '.join(step.left_out)}")
    return step, df, end


def _decimal_comma(rows: list[str]) -> bool:
    """A step written with decimal commas (``0,0213``; tab-separated): a comma in its rows
    and no point (a row with the other mark is then an error naming its line)."""
    return any("," in r for r in rows) and not any("." in r for r in rows)


def _check_values(df: Any, display: str) -> None:
    """Viscosity positive (the reduction takes its logarithm); temperatures above absolute
    zero (a wrong units row shows here)."""
    import numpy as np

    from torlab.parsers._text import refuse_below_absolute_zero

    eta = df[REQUIRED].to_numpy()
    bad = ~(eta > 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise TorlabInputError(f"viscosity {eta[i]:g} Pa s is not positive", path=display,
                               line=int(df["line"].iloc[i]), key="column 'Viscosity'")
    refuse_below_absolute_zero(df, display)


# ------------------------------------------------------------------ the reduction
def reduce(path: Path, **opts: Any) -> Reduction:
    """Read and reduce one export (options converted to SI: ``temperature`` in degC,
    ``temperature_band`` in K)."""
    df, meta = read(path)
    steps = step_table(df, meta)
    notes = list(meta.notes)
    check = consistency(df)
    if check is not None and check > CONSISTENCY:
        notes.append(f"the exported viscosity differs from shear stress / shear rate by up to "
                     f"{100 * check:.3g} %: check the units row")
    tables: dict[str, Any] = {"points": df, "steps": steps}
    optional = {"points": tuple(c for c in df.columns if c not in ("step", "line")),
                "steps": tuple(c for c in steps.columns if c not in
                               ("step", "name", "kind", "varies", "n_points", "first_line",
                                "last_line"))}
    files: dict[str, Any] = {"metadata.json": meta.to_dict()}
    key = _key_numbers(Path(path), df, steps, check)
    T = opts.get("temperature")
    if T is not None:
        at = viscosity_at(df, T, opts.get("temperature_band") or 1.0, where=str(path))
        tables["viscosity_at"] = at
        row = at.iloc[0]
        key.update(viscosity_at_C=T, viscosity_at_Pa_s=float(row["viscosity_Pa_s"]),
                   viscosity_at_ci95_low_Pa_s=float(row["viscosity_ci95_low_Pa_s"]),
                   viscosity_at_ci95_high_Pa_s=float(row["viscosity_ci95_high_Pa_s"]))
        files["lubricant.yaml"] = _lubricant_yaml(Path(path).name, row)
    return Reduction(NAME, str(path), tables, key, notes, meta, None, optional, files)


def step_table(df: Any, meta: TriosMetadata) -> Any:
    """One row per step with points: name, kind, what it varies, ranges, mean viscosity
    and its standard deviation, file lines."""
    import numpy as np
    import pandas as pd

    rows = []
    for st in meta.steps:
        d = df[df["step"] == st.number]
        if not len(d):
            continue
        eta = d["viscosity_Pa_s"].to_numpy()
        r = {"step": st.number, "name": st.name, "kind": st.kind, "varies": varies(d),
             "n_points": len(d)}
        for col, short in (("step_time_s", "step_time"), ("temperature_C", "temperature"),
                           ("shear_rate_1_s", "shear_rate")):
            unit = col.removeprefix(short).lstrip("_")
            v = d[col].to_numpy() if col in d else np.array([np.nan])
            r[f"{short}_min_{unit}"] = float(np.min(v))
            r[f"{short}_max_{unit}"] = float(np.max(v))
        r.update(viscosity_mean_Pa_s=float(np.mean(eta)),
                 viscosity_sd_Pa_s=float(np.std(eta, ddof=1)) if len(eta) > 1 else np.nan,
                 viscosity_min_Pa_s=float(np.min(eta)), viscosity_max_Pa_s=float(np.max(eta)),
                 first_line=st.first_line, last_line=st.last_line)
        rows.append(r)
    return pd.DataFrame(rows)


def varies(d: Any) -> str:
    """What a step varies: ``"shear rate"`` (largest over smallest above
    :data:`RATE_VARIES`), else ``"temperature"`` (a span above :data:`TEMPERATURE_VARIES`
    K), else ``"time"`` (a peak hold: constant conditions)."""
    if "shear_rate_1_s" in d:
        g = d["shear_rate_1_s"].abs()
        if (g.min() > 0 and g.max() / g.min() > RATE_VARIES) or g.min() <= 0 < g.max():
            return "shear rate"
    if "temperature_C" in d and d["temperature_C"].max() - d["temperature_C"].min() \
            > TEMPERATURE_VARIES:
        return "temperature"
    return "time"


def consistency(df: Any) -> float | None:
    """The largest relative difference of the exported viscosity and shear stress / shear
    rate (None when one of the three is not exported or no rate is above zero)."""
    import numpy as np

    if not {"shear_stress_Pa", "shear_rate_1_s", "viscosity_Pa_s"} <= set(df.columns):
        return None
    rate = df["shear_rate_1_s"].to_numpy()
    ok = np.abs(rate) > 0
    if not ok.any():
        return None
    eta = df["viscosity_Pa_s"].to_numpy()[ok]
    return float(np.max(np.abs(df["shear_stress_Pa"].to_numpy()[ok] / rate[ok] - eta) / eta))


def viscosity_at(df: Any, T: float, band: float, where: str = "") -> Any:
    """The viscosity at temperature ``T`` [degC] from the points within ``band`` [K].

    ``ln eta = a + b (T_i - T)`` fitted by least squares to those points (``a`` alone
    when they span less than 0.1 K), so ``eta(T) = exp(a)``; the 95 % interval is
    ``exp(a -+ t s_a)`` with the Student t of ``n - p`` degrees of freedom and the
    standard error ``s_a`` of ``a`` from the residuals.  The points may be at different
    shear rates: their range is reported, and a shear-thinning liquid's spread widens the
    interval.

    Raises
    ------
    TorlabInputError
        No temperature column, or fewer than three points within the band.
    """
    import numpy as np
    import pandas as pd

    from torlab._stats import t_ppf

    if "temperature_C" not in df:
        raise TorlabInputError("no Temperature column: the viscosity at a temperature needs "
                               "one", path=where, key="temperature")
    t = df["temperature_C"].to_numpy()
    sel = np.abs(t - T) <= band
    n = int(sel.sum())
    if n < 3:
        raise TorlabInputError(f"{n} measured point(s) within {band:g} K of {T:g} degC "
                               f"(measured {t.min():.1f} to {t.max():.1f} degC); need 3",
                               path=where, key="temperature")
    x = t[sel] - T
    y = np.log(df["viscosity_Pa_s"].to_numpy()[sel])
    X = np.column_stack([np.ones(n), x]) if np.ptp(x) >= 0.1 and n > 3 else np.ones((n, 1))
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    resid = y - X @ coef
    dof = n - X.shape[1]
    s2 = float(resid @ resid) / dof
    se = float(np.sqrt(s2 * np.linalg.inv(X.T @ X)[0, 0]))
    q = float(t_ppf(0.975, dof))
    rate = df["shear_rate_1_s"].to_numpy()[sel] if "shear_rate_1_s" in df else \
        np.array([np.nan])
    return pd.DataFrame([{
        "temperature_C": T, "viscosity_Pa_s": float(np.exp(coef[0])),
        "viscosity_ci95_low_Pa_s": float(np.exp(coef[0] - q * se)),
        "viscosity_ci95_high_Pa_s": float(np.exp(coef[0] + q * se)),
        "ln_viscosity_se": se, "residual_sd_ln": float(np.sqrt(s2)),
        "dlnviscosity_dT_1_K": float(coef[1]) if len(coef) > 1 else np.nan,
        "n_points": n, "band_K": band, "temperature_min_C": float(t[sel].min()),
        "temperature_max_C": float(t[sel].max()), "shear_rate_min_1_s": float(np.min(rate)),
        "shear_rate_max_1_s": float(np.max(rate)),
    }])


def _lubricant_yaml(source: str, row: Any) -> str:
    from torlab.yamlio import dump_yaml

    return (f"# eta0 at {row['temperature_C']:g} degC from {source} (TRIOS export, "
            f"{int(row['n_points'])} points within {row['band_K']:g} K), 95 % interval "
            f"[{row['viscosity_ci95_low_Pa_s']:.4g}, {row['viscosity_ci95_high_Pa_s']:.4g}] "
            "Pa s\n" + dump_yaml({"lubricant": {"eta0": float(row["viscosity_Pa_s"])}}))


def _key_numbers(path: Path, df: Any, steps: Any, check: float | None) -> dict[str, Any]:
    nan = float("nan")

    def rng(col: str) -> tuple[float, float]:
        return (float(df[col].min()), float(df[col].max())) if col in df else (nan, nan)

    (t0, t1), (g0, g1), (e0, e1) = (rng("temperature_C"), rng("shear_rate_1_s"),
                                    rng("viscosity_Pa_s"))
    return {"file": path.name, "n_steps": len(steps), "n_points": len(df),
            "temperature_min_C": t0, "temperature_max_C": t1, "shear_rate_min_1_s": g0,
            "shear_rate_max_1_s": g1, "viscosity_min_Pa_s": e0, "viscosity_max_Pa_s": e1,
            "stress_rate_viscosity_rel_diff": nan if check is None else check}


# ------------------------------------------------------------------ tables, figures, console
def figures(red: Reduction) -> dict[str, Any]:
    """Viscosity against time, temperature and shear rate, written as ``<name>.png``."""
    from torlab.reports.render import plot

    return {"": plot(trios_figure, red.tables["points"], red.tables["steps"],
                     title=f"TRIOS: {red.label}")}


def trios_figure(points: Any, steps: Any, title: str = "") -> Any:
    """Viscosity (log scale) against time (the steps one after another), temperature and
    shear rate, a colour per step; a temperature panel when the temperature is exported, a
    shear-rate panel when a step varies it.

    Parameters
    ----------
    points, steps
        The reduction's ``points`` and ``steps`` tables.
    title
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import numpy as np

    from torlab.reports.plotting import PALETTE, decimate, finish, legend, pixel_columns, subplots

    panels = [("time", "time t, steps one after the other (s)")]
    if "temperature_C" in points:
        panels.append(("temperature_C", "temperature T (°C)"))
    if "shear_rate_1_s" in points and (steps["varies"] == "shear rate").any():
        panels.append(("shear_rate_1_s", "shear rate γ̇ (1/s)"))
    fig, axes = subplots(1, len(panels), figsize=(3.2 * len(panels) + 1.0, 3.8))
    axes = np.atleast_1d(axes)
    offset = 0.0
    for i, st in enumerate(steps.itertuples()):
        d = points[points["step"] == st.step]
        eta = d["viscosity_Pa_s"].to_numpy()
        color = PALETTE[i % len(PALETTE)]
        for ax, (col, _) in zip(axes, panels, strict=True):
            if col == "time":
                ts = d["step_time_s"].to_numpy() if "step_time_s" in d else \
                    np.arange(len(d), dtype=float)
                x = offset + ts
            else:
                x = d[col].to_numpy()
            label = f"{st.step}: {st.name}" if ax is axes[-1] else None
            if col == "time":
                ax.plot(*decimate(x, eta, pixel_columns(ax)), color=color, lw=1.0, label=label)
            else:
                ax.plot(x, eta, ".", ms=2, color=color, label=label)
        if "step_time_s" in d:
            offset += float(d["step_time_s"].max())
        else:
            offset += len(d)
    for ax, (col, label) in zip(axes, panels, strict=True):
        ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel("viscosity η (Pa·s)")
        if col == "shear_rate_1_s" and (points[col] > 0).all() and \
                points[col].max() / points[col].min() > 10:
            ax.set_xscale("log")
    legend(axes[-1])
    if title:
        fig.suptitle(title)
    return finish(fig)


def collect(reds: list[Reduction], options: dict[str, Any]) -> tuple[dict, dict, dict]:
    """``summary``: one row per export; with ``temperature``, ``viscosity_at`` (one row per
    export)."""
    import pandas as pd

    sdf = pd.DataFrame([r.key_numbers for r in reds])
    tables = {"summary": sdf}
    optional = {"summary": tuple(c for c in sdf.columns if c not in ("file", "n_steps",
                                                                     "n_points"))}
    at = [r.tables["viscosity_at"].assign(file=r.label) for r in reds
          if "viscosity_at" in r.tables]
    if at:
        tables["viscosity_at"] = pd.concat(at, ignore_index=True)
        optional["viscosity_at"] = ("dlnviscosity_dT_1_K", "shear_rate_min_1_s",
                                    "shear_rate_max_1_s")
    return tables, optional, {}


def display(reds: list[Reduction]) -> list[tuple[str, list[dict], dict]]:
    """Console tables: the steps of every export; the viscosity at the temperature asked."""
    def rng(lo: float, hi: float, f: str) -> str:
        return "" if lo != lo else f"{lo:{f}}" if f"{lo:{f}}" == f"{hi:{f}}" else \
            f"{lo:{f}} … {hi:{f}}"

    rows, at = [], []
    for r in reds:
        for st in r.tables["steps"].itertuples():
            rows.append({"file": r.label, "step": f"{st.step}: {st.name}", "varies": st.varies,
                         "points": st.n_points,
                         "T (°C)": rng(st.temperature_min_C, st.temperature_max_C, ".1f"),
                         "γ̇ (1/s)": rng(st.shear_rate_min_1_s, st.shear_rate_max_1_s, ".4g"),
                         "η mean (mPa·s)": st.viscosity_mean_Pa_s * 1e3,
                         "± sd": st.viscosity_sd_Pa_s * 1e3})
        if "viscosity_at" in r.tables:
            a = r.tables["viscosity_at"].iloc[0]
            at.append({"file": r.label, "T (°C)": a["temperature_C"],
                       "η (mPa·s)": a["viscosity_Pa_s"] * 1e3,
                       "95 % interval (mPa·s)": f"[{a['viscosity_ci95_low_Pa_s'] * 1e3:.4g}, "
                                                f"{a['viscosity_ci95_high_Pa_s'] * 1e3:.4g}]",
                       "points": int(a["n_points"])})
    out = [("TRIOS rheometer reduction", rows, {"η mean (mPa·s)": ".4g", "± sd": ".2g"})]
    if at:
        out.append(("Viscosity at the temperature asked (ln η against T)", at,
                    {"T (°C)": ".1f", "η (mPa·s)": ".4g"}))
    return out
