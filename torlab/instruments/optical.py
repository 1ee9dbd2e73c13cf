"""Optical ball-on-disc tribometer logs (registry entry ``optical``).

``torlab-optical`` logs are reduced with
:func:`torlab.reduce.optical.reduce_optical_log` (mean over the last window of
every set condition, thesis Tab. 5.2 test types, +-SRR fold); PCS EHD2 exports
read as optical results with :func:`torlab.reduce.optical.reduce_ehd2` (each
film-step row is a condition), folded the same way when they are traction tests.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from torlab.instruments.plugin import Command, Option, read_head
from torlab.instruments.reduction import Curve, Reduction

NAME = "optical"
TITLE = "optical ball-on-disc tribometer"
FILES = "torlab-optical logs; PCS EHD2 exports with --as optical"
EXTENSIONS = (".txt", ".csv")
ALIASES: dict[str, dict[str, Any]] = {"tribometer": {}}
#: other instruments whose files this reduction reads: PCS EHD2 exports
ALSO_READS = ("pcs",)

OPTIONS: dict[str, Option] = {
    "window": Option("time", 4.0, "Averaging window at the end of each set condition (Paper A: "
                     "4 s).", check="positive", unit="s"),
    "test": Option("choice", None, "Test type: dry_traction, film_thickness, stribeck or "
                   "traction (default: the log's 'test' header, else detected).",
                   ("dry_traction", "film_thickness", "stribeck", "traction"), key=None),
    "symmetry_tolerance": Option("number", 0.10, "Relative tolerance of the ±SRR symmetry check.",
                                 check="nonneg"),
    "symmetry_abs": Option("number", 0.005, "Absolute tolerance (coefficient) of the ±SRR "
                           "symmetry check.", check="nonneg"),
}

COMMAND = Command(
    "optical", "Optical ball-on-disc tribometer (thesis 5.1.1): windowed averages at each set "
    "condition, traction / Stribeck / film-thickness tests (Tab. 5.2).",
    """Reduce optical tribometer logs: mean coefficient, speeds, load and film thickness over the
    last WINDOW of every set condition; rolling speed U = (u_ball + u_disc)/2 and
    SRR = (u_ball - u_disc)/U (thesis Eq. 2.4); the Tab. 5.2 test type; for traction tests the
    negative SRR folded onto positive with a symmetry check (EHD2 exports too).

    Writes per input '<name>_points.csv' (one row per condition), '<name>_folded.csv' (traction
    tests) and '<name>.png'; 'summary.csv' with one row per input.
    """,
    "torlab-optical logs (docs/formats/optical.md) or PCS EHD2 exports; folders and patterns "
    "are expanded.", argument="logs", what="optical log")


def detect(head: str) -> str:
    """``"torlab-optical log"`` for a file starting with ``# torlab-optical``."""
    return "torlab-optical log" if head.lstrip().startswith("# torlab-optical") else ""


def _is_pcs(path: Path) -> bool:
    from torlab.instruments.pcs import detect as pcs_detect

    return bool(pcs_detect(read_head(path)))


def read(path: Path, **_: Any) -> tuple[Any, Any]:
    """The rows and header of a log (or of a PCS EHD2 export)."""
    if _is_pcs(path):
        from torlab.parsers.pcs import read_pcs

        return read_pcs(path)
    from torlab.parsers.optical import read_optical

    return read_optical(path)


def reduce(path: Path, **opts: Any) -> Reduction:
    """Reduce one log or EHD2 export to one point per condition (and the folded curve)."""
    from torlab.reduce.optical import (
        FOLDED_OPTIONAL,
        POINT_OPTIONAL,
        reduce_ehd2,
        reduce_optical_log,
    )

    sym = {"sym_rel": opts.get("symmetry_tolerance", 0.10),
           "sym_abs": opts.get("symmetry_abs", 0.005)}
    if _is_pcs(path):
        from torlab.parsers.pcs import read_pcs

        df, meta = read_pcs(path)
        res = reduce_ehd2(df, meta, test=opts.get("test"), **sym)
    else:
        res = reduce_optical_log(path, window=opts.get("window", 4.0), test=opts.get("test"),
                                 **sym)
        meta = None
    tables = {"points": res.points}
    optional = {"points": (*POINT_OPTIONAL, *(c for c in res.points.columns
                                             if c not in ("condition", "rolling_speed_m_s")))}
    if res.folded is not None:
        tables["folded"] = res.folded
        optional["folded"] = FOLDED_OPTIONAL
    return Reduction(NAME, str(path), tables, res.summary(), list(res.warnings), meta, res,
                     optional)


def figures(red: Reduction) -> dict[str, Any]:
    """The log's figure (by test type), written as ``<name>.png`` (declared, drawn later)."""
    from torlab.reports.optical import optical_figure
    from torlab.reports.render import plot

    return {"": plot(optical_figure, red.detail)}


def collect(reds: list[Reduction], options: dict[str, Any]) -> tuple[dict, dict, dict]:
    """``summary``: one row per log."""
    import pandas as pd

    from torlab.reduce.optical import SUMMARY_OPTIONAL

    return ({"summary": pd.DataFrame([r.detail.summary() for r in reds])},
            {"summary": SUMMARY_OPTIONAL}, {})


def display(reds: list[Reduction]) -> list[tuple[str, list[dict], dict]]:
    """Console table: test type, conditions, speed/SRR/mu/h ranges, symmetry."""
    def rng(lo: float, hi: float, scale: float = 1.0, f: str = ".3g") -> str:
        return "" if lo != lo else f"{lo * scale:{f}} … {hi * scale:{f}}"

    rows = []
    for r in reds:
        s = r.detail.summary()
        rows.append({
            "file": s["file"],
            "test": s["test"] + (" (detected)" if s["test_source"] == "detected" else ""),
            "conditions": s["n_conditions"],
            "U (m/s)": rng(s["rolling_speed_min_m_s"], s["rolling_speed_max_m_s"]),
            "SRR (%)": rng(s["srr_min"], s["srr_max"], 100),
            "μ": rng(s["traction_coefficient_min"], s["traction_coefficient_max"], f=".4f"),
            "h (nm)": rng(s["film_thickness_min_m"], s["film_thickness_max_m"], 1e9),
            "±SRR symmetric": s["symmetric"],
        })
    w = reds[0].detail.window_s if reds else 4.0
    return [(f"Optical tribometer reduction ({w:g} s windows)", rows, {})]


# ------------------------------------------------------------------ measured curves
def traction_curves(red: Reduction) -> list[Curve]:
    """The folded traction curve, one per rolling speed (|SRR|, mu)."""
    import numpy as np

    from torlab.reduce.optical import speed_groups

    res = red.detail
    fd = res.folded
    if fd is None or not len(fd):
        return []
    g = speed_groups(fd["rolling_speed_m_s"].to_numpy())
    out = []
    for k in np.unique(g):
        sub = fd[g == k].sort_values("srr")
        v = float(sub["rolling_speed_m_s"].mean())
        out.append(Curve(f"{v:.3g} m/s", sub["srr"].to_numpy(dtype=float),
                         sub["traction_coefficient"].to_numpy(dtype=float), speed_m_s=v,
                         y_sd=_sd(sub, "traction_coefficient_sd")))
    return out


def stribeck_curves(red: Reduction) -> list[Curve]:
    """The points with a coefficient, sorted by rolling speed."""
    p = red.detail.points
    if "traction_coefficient" not in p or p["traction_coefficient"].isna().all():
        return []
    d = p.dropna(subset=["rolling_speed_m_s", "srr", "traction_coefficient"])
    d = d.sort_values("rolling_speed_m_s")
    return [Curve("", d["rolling_speed_m_s"].to_numpy(dtype=float),
                  d["traction_coefficient"].to_numpy(dtype=float),
                  srr=d["srr"].to_numpy(dtype=float), y_sd=_sd(d, "traction_coefficient_sd"))]


def _sd(d: Any, col: str) -> Any:
    """The spread column ``col`` as an array (None when the table has none)."""
    return d[col].to_numpy(dtype=float) if col in d and d[col].notna().any() else None


def film_curves(red: Reduction) -> list[Curve]:
    """Film thickness against rolling speed: one curve per EHD2 film step (labelled by its
    temperature), one for an optical log."""
    from torlab.reduce.mtm import step_label

    p = red.detail.points
    if "film_thickness_m" not in p or p["film_thickness_m"].isna().all():
        return []
    d = p.dropna(subset=["film_thickness_m"])
    d = d[d["rolling_speed_m_s"] > 0]
    groups = d.groupby("step", sort=False) if "step" in d else [(None, d)]
    out = []
    for st, g in groups:
        g = g.sort_values("rolling_speed_m_s")
        T = _temp(g)
        label = "" if st is None else step_label(_FilmStep(int(st)), g)
        out.append(Curve(label, g["rolling_speed_m_s"].to_numpy(dtype=float),
                         g["film_thickness_m"].to_numpy(dtype=float), temperature_C=T,
                         y_sd=_sd(g, "film_thickness_sd_m")))
    return out


class _FilmStep:
    type = "film"

    def __init__(self, number: int) -> None:
        self.number = number


def _temp(d: Any) -> float | None:
    for c in ("lube_temperature_C", "temperature_C", "pot_temperature_C"):
        if c in d and d[c].notna().any():
            return float(d[c].mean())
    return None


# ------------------------------------------------------------------ protocol section data.optical
def write_section(dest: Any, labelled: list[tuple[str, Reduction]]) -> dict[str, Any]:
    """``data/optical/<file>_points.csv`` and ``data/optical_summary.csv``."""
    import pandas as pd

    from torlab.reduce.optical import SUMMARY_OPTIONAL

    rows = []
    for _, red in labelled:
        dest.write_csv(f"data/optical/{red.stem}_points.csv", red.tables["points"],
                       allow_missing=red.optional["points"])
        rows.append(red.detail.summary())
    dest.write_csv("data/optical_summary.csv", pd.DataFrame(rows),
                   allow_missing=SUMMARY_OPTIONAL)
    return {r["file"]: {"test": r["test"], "n_conditions": r["n_conditions"],
                        "symmetric": r["symmetric"]} for r in rows}
