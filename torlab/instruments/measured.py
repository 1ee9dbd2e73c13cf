"""Measured curves from any file a user hands a fit: an instrument file (through the
registry) or a CSV of reduced data (``torlab reduce`` output or a user's own table).

One detection (:func:`torlab.instruments.detect`) decides which: a file no
instrument recognises is read as a CSV with the columns the fit needs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, NamedTuple

from torlab.errors import TorlabInputError

__all__ = [
    "TimeTestRecord",
    "TractionData",
    "detected",
    "film_data",
    "hpt_curves",
    "is_hpt_input",
    "is_layer_input",
    "is_time_test_input",
    "layer_inputs",
    "loads",
    "numbers",
    "read_csv",
    "time_test_records",
    "traction_data",
    "viscosity_data",
]


def detected(path: Path) -> str:
    """The registry instrument of ``path`` ('' when no instrument format matches: a CSV)."""
    from torlab.instruments import detect

    try:
        return detect(path)[0].name
    except TorlabInputError as e:
        if "does not recognise" not in e.message:
            raise
        return ""


def read_csv(path: Path, need: tuple[tuple[str, ...], ...], what: str) -> tuple[Any, list[str]]:
    """A CSV of reduced data with one column of each group in ``need`` (first present wins)."""
    import pandas as pd

    from torlab.errors import TorlabInputError
    from torlab.files import open_regular

    try:
        with open_regular(path) as fh:  # a regular file only: no FIFO or device is waited on
            df = pd.read_csv(fh, comment="#")
    except (ValueError, pd.errors.ParserError, UnicodeDecodeError) as e:
        msg = " ".join(str(e).split())[:200]
        raise TorlabInputError(f"not a readable CSV of {what} ({msg})", path=path) from None
    cols = [next((c for c in group if c in df), "") for group in need]
    if not all(cols):
        raise TorlabInputError(f"not an instrument file torlab recognises, nor a CSV of {what} "
                               f"(columns {' and '.join(' or '.join(g) for g in need)})", path=path)
    return df, cols


def loads(load: Any) -> tuple[Any, dict[Path, Any]]:
    """A ``keep`` filter for :func:`torlab.instruments.expand_inputs` that keeps the files
    ``load`` reads without a :class:`TorlabInputError`, and the results it read.

    A folder or pattern given to a fit contributes the files the fit can use (a
    folder of ``torlab reduce`` output holds summaries and figures too); a file named
    on its own is always loaded, so its error is said.  Each file is read once:
    ``loaded.get(path)`` is its result when the filter read it.
    """
    loaded: dict[Path, Any] = {}

    def keep(path: Path) -> bool:
        try:
            loaded[path] = load(path)
        except TorlabInputError:
            return False
        return True

    return keep, loaded


def numbers(df: Any, col: str, path: Path, *, finite: bool = True) -> Any:
    """Column ``col`` as floats; a cell that is not a number (or, with ``finite``, NaN or
    inf) is an error naming the file, the column and the row of the table."""
    import numpy as np
    import pandas as pd

    raw = df[col]
    v = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float)
    text = raw.astype(str).str.strip().str.lower()
    bad = np.isnan(v) & ~text.isin(["nan", "", "none"]).to_numpy() & raw.notna().to_numpy()
    if finite:
        bad |= ~np.isfinite(v)
    if bad.any():
        i = int(np.argmax(bad))
        raise TorlabInputError(f"row {i + 1} of the table: {str(raw.iloc[i])[:40]!r} is not "
                               f"{'a finite number' if finite else 'a number'}", path=path,
                               key=col)
    return v


def viscosity_data(path: Path) -> tuple[Any, Any, Any]:
    """Pressure (Pa), viscosity (Pa s) and the logged temperatures (degC, the finite ones;
    None when not logged) of a reduced viscometer table ('torlab visc reduce'
    ``*_steps.csv`` or ``*_falls.csv``)."""
    import numpy as np

    df, (pc, ec) = read_csv(path, (("pressure_Pa",), ("viscosity_Pa_s",)),
                             "reduced viscometer data ('torlab visc reduce' output: pressure_Pa, "
                             "viscosity_Pa_s)")
    p, eta = numbers(df, pc, path), numbers(df, ec, path)
    T = None
    if "temperature_C" in df:
        t = numbers(df, "temperature_C", path, finite=False)
        t = t[np.isfinite(t)]
        if t.size:
            if (t < -273.15).any() or (t > 2000).any():
                from torlab.units import check_range

                for x in t:
                    check_range("temperature", float(x), path=path, where="temperature_C")
            T = t
    return p, eta, T


def is_hpt_input(path: Path) -> bool:
    """An HPT log or a reduced HPT CSV (what a folder given to 'fit hpt' contributes)."""
    if detected(path) == "hpt":
        return True
    with open(path, "rb") as f:
        return b"shear_stress_Pa" in f.read(2000).split(b"\n", 1)[0]


class TractionData(NamedTuple):
    """A measured traction test as the traction fit takes it: every point's creepage
    [-], coefficient [-] and rolling speed [m/s] (None where the source does not give
    it), and the test type (``dry_traction`` for a dry optical test, else '').

    The fields are typed ``object`` (arrays of floats in practice): a named tuple's
    annotations are resolved in the namespace of :mod:`collections`, where no typing name is
    defined."""

    creepage: object
    mu: object
    test: str
    speed: object


def traction_data(source: Any) -> TractionData:
    """The traction test of a file or reduction: its folded traction curves, every speed.

    The one place that turns what a user hands a traction fit into the fit's points
    (``torlab fit traction``, :func:`torlab.fit_traction`, protocols'
    ``fits.traction_layers``).

    Parameters
    ----------
    source
        An instrument file (reduced on the fly), a
        :class:`~torlab.instruments.reduction.Reduction`, or a CSV with creepage (or
        srr), mu (or traction_coefficient) and optionally speed_m_s (or
        rolling_speed_m_s).

    Returns
    -------
    TractionData
        The speed is one value per point [m/s], or None where the source does not
        give it (a CSV without a speed column, a curve without a rolling speed).
    """
    import numpy as np

    from torlab.instruments.reduction import Reduction

    if isinstance(source, Reduction):
        red = source
    elif detected(Path(source)):
        from torlab.instruments import reduce_file

        red = reduce_file(Path(source))
    else:
        path = Path(source)
        df, (xc, yc) = read_csv(path, (("creepage", "srr"), ("mu", "traction_coefficient")),
                                 "a traction curve")
        vc = next((c for c in ("speed_m_s", "rolling_speed_m_s") if c in df), None)
        return TractionData(numbers(df, xc, path), numbers(df, yc, path), "",
                            None if vc is None else numbers(df, vc, path))
    curves = red.traction_curves()
    v = None
    if curves and all(c.speed_m_s is not None for c in curves):
        v = np.concatenate([np.full(np.size(c.x), float(c.speed_m_s)) for c in curves])
    return TractionData(np.concatenate([np.asarray(c.x, dtype=float) for c in curves]),
                        np.concatenate([np.asarray(c.y, dtype=float) for c in curves]),
                        str(getattr(red.detail, "test", "") or ""), v)


def film_data(path: Path) -> list[tuple[str, Any, Any, float | None]]:
    """``(label, speed, film thickness, temperature or None)`` of every film curve: an
    instrument file (EHD2 film steps labelled by temperature, an optical log) or a CSV with
    speed_m_s (or rolling_speed_m_s) and film_thickness_m (and optionally temperature_C or
    lube_temperature_C, its mean the curve's temperature)."""
    if detected(path):
        from torlab.instruments import reduce_file

        curves = reduce_file(path).film_curves()
        return [(c.label if len(curves) > 1 else "", c.x, c.y, c.temperature_C) for c in curves]
    df, (vc, hc) = read_csv(path, (("speed_m_s", "rolling_speed_m_s"), ("film_thickness_m",)),
                             "film thickness")
    tc = next((c for c in ("temperature_C", "lube_temperature_C") if c in df), None)
    temp = None if tc is None else float(numbers(df, tc, path).mean())
    return [("", numbers(df, vc, path), numbers(df, hc, path), temp)]


def is_time_test_input(path: Path) -> bool:
    """A PCS export or a ``*_timed.csv`` (what a folder or pattern of time tests contributes
    to a removal fit, :func:`torlab.reduce.time_test.read_time_test`)."""
    try:
        if detected(path) == "pcs":
            return True
    except TorlabInputError:
        return False
    from torlab.files import open_regular

    with open_regular(path) as fh:
        return b"step_time_s" in fh.read(2000).split(b"\n", 1)[0]


class TimeTestRecord(NamedTuple):
    """One time test after application: its step, record (step time [s], coefficient [-])
    and figures (:class:`torlab.reduce.mtm.TimeTestResult`)."""

    step: int
    t: object
    mu: object
    result: object


def time_test_records(source: Any, **options: Any) -> list[TimeTestRecord]:
    """The time tests after application of a PCS export, its reduction, or the
    ``*_timed.csv`` of ``torlab mtm reduce``, each with the record its figures were read
    from.

    A PCS export is reduced by the registry (its timed steps marked as time tests after
    application; ``after_application=True`` takes every timed step); a ``*_timed.csv``
    (``step_time_s``, ``traction_coefficient``, optionally ``step``) is one time test per
    step.  ``options`` are the time-test options of ``torlab mtm reduce`` (``threshold``,
    ``smooth``, ``tail``, ``duration`` ...), in SI.

    Raises
    ------
    TorlabInputError
        A file that is neither, or that holds no time test.
    """
    from torlab.instruments.reduction import Reduction

    if isinstance(source, Reduction):
        red = source
    elif detected(Path(source)) == "pcs":
        from torlab.instruments import reduce_file

        red = reduce_file(Path(source), **options)
    else:
        return _timed_csv_records(Path(source), options)
    d = getattr(red.detail, "curves", {}).get("timed")
    out = []
    for tt in getattr(red.detail, "time_tests", []):
        if d is None:
            break
        sel = d["step"].to_numpy() == tt.step
        out.append(TimeTestRecord(int(tt.step),
                                  d.loc[sel, "step_time_s"].to_numpy(dtype=float),
                                  d.loc[sel, "traction_coefficient"].to_numpy(dtype=float), tt))
    if not out:
        raise TorlabInputError("no time test after application in this file (a timed step "
                               "marked 'time test after application'; after_application="
                               "True takes every timed step)", path=red.source)
    return out


def _timed_csv_records(path: Path, options: dict[str, Any]) -> list[TimeTestRecord]:
    """The time tests of a ``*_timed.csv``: one per step."""
    import numpy as np

    from torlab.reduce.mtm import time_test_metrics
    from torlab.reduce.time_test import read_timed_csv

    df = read_timed_csv(path)
    t = numbers(df, "step_time_s", path, finite=False)
    mu = numbers(df, "traction_coefficient", path, finite=False)
    steps = numbers(df, "step", path).astype(int) if "step" in df else np.ones(t.size, int)
    keep = {k: v for k, v in options.items() if k not in ("family", "after_application")}
    out = []
    for st in np.unique(steps):
        sel = steps == st
        try:
            res = time_test_metrics(t[sel], mu[sel], label=path.name, step=int(st), **keep)
        except TorlabInputError as e:
            if e.key is not None:
                raise
            raise TorlabInputError(f"step {int(st)}: {e.message}", path=path) from None
        out.append(TimeTestRecord(int(st), t[sel], mu[sel], res))
    return out


#: suffixes of parameter files (an HPT layer fit's ``params.yaml``)
YAML_SUFFIXES = (".yaml", ".yml")


def is_layer_input(path: Path) -> bool:
    """An HPT log or a parameter file (what a folder or pattern given as the amount series
    of a removal fit contributes)."""
    if path.suffix.lower() in YAML_SUFFIXES:
        return True
    try:
        return detected(path) == "hpt"
    except TorlabInputError:
        return False


def layer_inputs(items: Any, *, compliance: Any = None) -> list[Any]:
    """The inputs of :func:`torlab.fit.amount.amount_layer` from what a user gives: a raw
    HPT log (any file but a parameter file) becomes its curve, reduced through the registry
    as an HPT log with the rig ``compliance`` subtracted; parameter files (``params.yaml``
    of ``torlab fit hpt``), fit results and curves stay as they are."""
    import os

    out = []
    for it in items:
        if isinstance(it, (str, os.PathLike)) and Path(it).suffix.lower() not in YAML_SUFFIXES:
            from torlab.fit.layer import hpt_curve
            from torlab.instruments import reduce_file
            from torlab.reduce.hpt import RigCompliance

            comp = RigCompliance.from_spec(compliance)
            out.append(hpt_curve(reduce_file(Path(it), "hpt", compliance=comp).detail))
        else:
            out.append(it)
    return out


def hpt_curves(items: Any, *, compliance: Any = None, sigma: float | None = None,
               where: str = "compliance") -> list[Any]:
    """The curves of a layer fit from whatever holds them: the one place HPT fit inputs are
    prepared (``torlab fit hpt`` and ``temperature``, :func:`torlab.fit_hpt`,
    :func:`torlab.fit_temperature`, a protocol's ``fits.hpt_layers``).

    Parameters
    ----------
    items
        One or a list of: raw HPT logs (reduced here through the instrument registry,
        ``compliance`` subtracted), reduced CSVs (``torlab hpt reduce`` output:
        ``shear_stress_Pa``, ``displacement_raw_m`` ...), :class:`Reduction` objects of
        HPT logs, :class:`~torlab.reduce.hpt.HptResult`, reduced DataFrames or
        :class:`~torlab.fit.layer.HptCurve` (kept as they are).
    compliance
        Rig compliance (what :meth:`~torlab.reduce.hpt.RigCompliance.from_spec` takes):
        subtracted from a raw log by its reduction; used as the model's ``u_rig(tau)``
        of an already reduced curve.  Default: the one the reduction subtracted.
    sigma
        Normal stress [Pa]; default: each curve's mean.
    where
        The option name in messages (``"--compliance"``).

    Returns
    -------
    list of torlab.fit.layer.HptCurve
        In the order given (:func:`torlab.fit.layer.hpt_curve` of each).
    """
    import os

    from torlab.fit.layer import hpt_curve
    from torlab.instruments.reduction import Reduction
    from torlab.reduce.hpt import RigCompliance

    comp = RigCompliance.from_spec(compliance, where=where)
    out = []
    for it in items if isinstance(items, (list, tuple)) else [items]:
        if isinstance(it, (str, os.PathLike)):
            path = Path(it)
            if detected(path) == "hpt":
                from torlab.instruments import reduce_file

                # the reduction subtracted the compliance: the curve recovers it from its columns
                out.append(hpt_curve(reduce_file(path, "hpt", compliance=comp).detail,
                                     sigma=sigma))
                continue
            df, _ = read_csv(path, (("shear_stress_Pa",), ("displacement_raw_m",
                                                           "displacement_m")),
                             "a reduced HPT curve")
            out.append(hpt_curve(df, sigma=sigma, compliance=comp, name=path.name))
        else:
            out.append(hpt_curve(it.detail if isinstance(it, Reduction) else it, sigma=sigma,
                                 compliance=comp))
    return out
