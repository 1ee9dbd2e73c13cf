"""Measured curves from any file a user hands a fit: an instrument file (through the
registry) or a CSV of reduced data (``torlab reduce`` output or a user's own table).

One detection (:func:`torlab.instruments.detect`) decides which: a file no
instrument recognises is read as a CSV with the columns the fit needs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError

__all__ = [
    "detected",
    "film_data",
    "hpt_items",
    "is_hpt_input",
    "loads",
    "read_csv",
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

    try:
        df = pd.read_csv(path, comment="#")
    except (ValueError, pd.errors.ParserError) as e:
        msg = " ".join(str(e).split())
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


def is_hpt_input(path: Path) -> bool:
    """An HPT log or a reduced HPT CSV (what a folder given to 'fit hpt' contributes)."""
    if detected(path) == "hpt":
        return True
    with open(path, "rb") as f:
        return b"shear_stress_Pa" in f.read(2000).split(b"\n", 1)[0]


def hpt_items(files: list[Path], compliance: Any) -> list[Any]:
    """Raw HPT logs are reduced (instrument registry); reduced CSVs (``torlab hpt reduce``
    output) are read as they are."""
    from torlab.instruments import reduce_file

    out = []
    for f in files:
        if detected(f) == "hpt":
            out.append(reduce_file(f, "hpt", compliance=compliance).detail)
        else:
            df, _ = read_csv(f, (("shear_stress_Pa",), ("displacement_raw_m", "displacement_m")),
                              "a reduced HPT curve")
            out.append((f, df))
    return out


def traction_data(path: Path) -> tuple[Any, Any, str]:
    """Creepage and coefficient of a measured traction curve: an instrument file (its folded
    traction curves, every speed) or a CSV with creepage (or srr) and mu."""
    import numpy as np

    if detected(path):
        from torlab.instruments import reduce_file

        red = reduce_file(path)
        curves = red.traction_curves()
        test = getattr(red.detail, "test", "")
        return (np.concatenate([c.x for c in curves]), np.concatenate([c.y for c in curves]),
                test)
    df, (xc, yc) = read_csv(path, (("creepage", "srr"), ("mu", "traction_coefficient")),
                             "a traction curve")
    try:
        return df[xc].to_numpy(dtype=float), df[yc].to_numpy(dtype=float), ""
    except ValueError:
        raise TorlabInputError(f"columns {xc}, {yc} must be numbers", path=path) from None


def film_data(path: Path) -> list[tuple[str, Any, Any]]:
    """``(label, speed, film thickness)`` of every film curve: an instrument file (EHD2 film
    steps labelled by temperature, an optical log) or a CSV with speed_m_s (or
    rolling_speed_m_s) and film_thickness_m."""
    if detected(path):
        from torlab.instruments import reduce_file

        curves = reduce_file(path).film_curves()
        return [(c.label if len(curves) > 1 else "", c.x, c.y) for c in curves]
    df, (vc, hc) = read_csv(path, (("speed_m_s", "rolling_speed_m_s"), ("film_thickness_m",)),
                             "film thickness")
    return [("", df[vc].to_numpy(dtype=float), df[hc].to_numpy(dtype=float))]




def viscosity_data(path: Path) -> tuple[Any, Any, Any]:
    """Pressures, viscosities and (or ``None``) temperatures of reduced viscometer data: a
    CSV with pressure_Pa and viscosity_Pa_s ('torlab visc reduce' *_falls.csv or
    *_steps.csv)."""
    df, (pc, ec) = read_csv(path, (("pressure_Pa",), ("viscosity_Pa_s",)),
                             "reduced viscometer data ('torlab visc reduce' output)")
    try:
        T = df["temperature_C"].to_numpy(dtype=float) if "temperature_C" in df else None
        return df[pc].to_numpy(dtype=float), df[ec].to_numpy(dtype=float), T
    except ValueError:
        raise TorlabInputError(f"columns {pc}, {ec} must be numbers", path=path) from None
