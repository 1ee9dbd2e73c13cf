"""PCS Instruments MTM / ETM / EHD2 text exports (registry entry ``pcs``).

Reads with :func:`torlab.parsers.pcs.read_pcs`, reduces with
:func:`torlab.reduce.mtm.reduce_pcs`: one table per step kind (traction,
Stribeck, timed, film, mapper, unknown kinds under their own name), the steps
table, and the time-test analysis after application where the file marks an
application or ``after_application`` asks for it.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from torlab.instruments.plugin import Command, Option
from torlab.instruments.reduction import Curve, Reduction

NAME = "pcs"
TITLE = "PCS Instruments MTM / ETM / EHD2"
FILES = "'Test Data File' text exports"
EXTENSIONS = (".txt",)
ALIASES: dict[str, dict[str, Any]] = {"mtm": {"family": "MTM"}, "etm": {"family": "ETM"},
                                      "ehd2": {"family": "EHD2"}, "ehd": {"family": "EHD2"}}
_FIRST = re.compile(r"^\s*((MTM|ETM|EHD)\w*\s+Test\s+Data\s+File|Step\s+1\b.*started\s+at)",
                    re.IGNORECASE)

OPTIONS: dict[str, Option] = {
    "family": Option("choice", None, "Read the files as MTM, ETM or EHD2 (default: detected "
                     "from the first line).", ("MTM", "ETM", "EHD2"), flag="--instrument",
                     key="instrument"),
    "after_application": Option("flag", None, "Analyse every timed step as a time test after "
                                "application (default: only steps whose description marks an "
                                "application).", key=None),
    "threshold": Option("number", 0.15, "Low-adhesion threshold of the time tests.",
                        check="coefficient", group="time_test"),
    "application_time": Option("time", None, "Application moment on the step-time axis (e.g. "
                               "'60 s'; implies the analysis after application); default: "
                               "detected as the largest drop.", check="nonneg",
                               group="time_test"),
    "recovery_fraction": Option("number", 0.9, "Recovered when the coefficient is this "
                                "fraction of the way back from the minimum to the plateau.",
                                check="fraction", group="time_test"),
    "recovery_level": Option("number", None, "Recovered when the coefficient reaches this "
                             "fixed value instead.", group="time_test"),
    "smooth": Option("time", 10.0, "Running-median window for the minimum and the crossings "
                     "('0 s': raw samples).", check="nonneg", unit="s", group="time_test"),
    "min_drop": Option("number", 0.05, "Smallest drop taken as the application when "
                       "detecting it.", check="nonneg", group="time_test"),
    "min_rise": Option("number", 0.03, "Smallest plateau - minimum taken as a recovery.",
                       check="nonneg", group="time_test"),
    "tail": Option("time", 120.0, "Window at the end over which the plateau is the median.",
                   check="positive", unit="s", group="time_test"),
    "duration": Option("time", None, "Evaluate up to this time after the application (Paper "
                       "B: '20 min'); default: to the end of the step.", check="positive",
                       group="time_test"),
}
#: options of the time-test analysis (passed to time_test_metrics)
_TIME_TEST = tuple(k for k, o in OPTIONS.items() if o.group == "time_test")

COMMAND = Command(
    "mtm", "PCS Instruments MTM/ETM (and EHD2) exports: every step kind (traction, Stribeck, "
    "timed, film, mapper ...); time tests after application (Paper B).",
    """Reduce PCS exports: every data step (traction, Stribeck, ball- or pin-on-disc timed,
    film, mapper, and unknown step types) as the coefficient against the x column of its own
    header (SRR, rolling speed, time), with every logged column; EHD2 film steps labelled by
    temperature; the time-test figures after application (thesis Fig. 5.9: application,
    minimum, time to recover, mean after recovery, time below the threshold) of timed steps
    that mark an application, or of all with --after-application.

    Writes per input '<name>_steps.csv', '<name>_<kind>.csv' and '<name>_<kind>.png' for each
    step kind present, '<name>_time_test.png', '<name>_metadata.json'; with ten traction steps
    or more '<name>_traction_map.csv' and the map and evolution figures
    ('<name>_traction_map.png', '<name>_traction_evolution.png'); 'summary.csv' (one row
    per data step) and 'time_tests.csv'.
    """,
    "PCS text exports (MTM311/ETM/EHD261 'Test Data File'); folders and patterns such as "
    "'exports/*.txt' are expanded.", argument="files", what="PCS export")


def detect(head: str) -> str:
    """``"first line '...'"`` for a PCS export (``MTM311 Test Data File``, ``Step 1 started at``)."""
    first = next((s.strip() for s in head.splitlines() if s.strip()), "")
    if _FIRST.match(first):
        return f"PCS export: first line {first[:40]!r}"
    return ""


def read(path: Path, family: str | None = None, **_: Any) -> tuple[Any, Any]:
    """:func:`torlab.parsers.pcs.read_pcs` (``family``: MTM, ETM or EHD2, default detected)."""
    from torlab.parsers.pcs import read_pcs

    return read_pcs(path, instrument=family)


def reduce(path: Path, **opts: Any) -> Reduction:
    """Read and reduce one export (:func:`torlab.reduce.mtm.reduce_pcs`)."""
    from torlab.reduce.mtm import reduce_pcs

    df, meta = read(path, opts.get("family"))
    tt = {k: opts[k] for k in _TIME_TEST if opts.get(k) is not None}
    red = reduce_pcs(df, meta, after_application=opts.get("after_application"), **tt)
    tables = {"steps": red.steps, **red.curves}
    if red.traction_map is not None:
        tables["traction_map"] = red.traction_map
    ids = {"step", "line", "n_rows", "first_line", "last_line"}
    optional = {k: tuple(c for c in v.columns if c not in ids) for k, v in tables.items()}
    key = {"pcs_instrument": meta.instrument, "instrument_model": meta.instrument_model,
           "steps": len(meta.steps), "data_steps": len(red.steps),
           "kinds": ", ".join(red.curves), "time_tests": len(red.time_tests),
           "coefficient_source": red.mu_source}
    return Reduction(NAME, str(path), tables, key, [*meta.warnings, *red.notes], meta, red,
                     optional, {"metadata.json": meta.to_dict()})


def figures(red: Reduction) -> dict[str, Any]:
    """One figure per step kind, and the time tests (declared, drawn later)."""
    from torlab.reports.mtm import curve_figure, time_test_figure
    from torlab.reports.render import plot

    d = red.detail
    figs = {kind: plot(curve_figure, d, kind) for kind in d.curves}
    if d.traction_map is not None:
        from torlab.reports.mtm import traction_evolution_figure, traction_map_figure

        figs["traction_map"] = plot(traction_map_figure, d)
        figs["traction_evolution"] = plot(traction_evolution_figure, d)
    if d.time_tests:
        figs["time_test"] = plot(time_test_figure, d, d.time_tests)
    return figs


def collect(reds: list[Reduction], options: dict[str, Any]) -> tuple[dict, dict, dict]:
    """``summary`` (every data step of every file) and ``time_tests`` tables."""
    import pandas as pd

    from torlab.reduce.mtm import TIME_TEST_OPTIONAL

    summary = pd.concat([r.detail.steps for r in reds], ignore_index=True)
    ids = {"step", "line", "n_rows", "first_line", "last_line"}
    tables = {"summary": summary}
    optional = {"summary": tuple(c for c in summary.columns if c not in ids)}
    tts = [dict(file=r.label, **t.summary()) for r in reds for t in r.detail.time_tests]
    if tts:
        tables["time_tests"] = pd.DataFrame(tts).drop(columns=["label"])
        optional["time_tests"] = TIME_TEST_OPTIONAL
    return tables, optional, {}


def display(reds: list[Reduction]) -> list[tuple[str, list[dict], dict]]:
    """Console tables: steps per kind and file; the time tests."""
    rows = []
    for r in reds:
        s = r.detail.steps
        for kind in dict.fromkeys(s["step_type"]):
            sub = s[s["step_type"] == kind]
            lo, hi = sub.get("traction_coefficient_min"), sub.get("traction_coefficient_max")
            rows.append({
                "file": r.label, "instrument": r.meta.instrument, "step type": kind,
                "steps": len(sub), "rows": int(sub["n_rows"].sum()),
                "load (N)": _mean(sub, "ball_load_N"), "lube T (°C)": _mean(sub, "lube_temperature_C"),
                "μ range": "" if lo is None or lo.isna().all() else f"{lo.min():.4f} … {hi.max():.4f}",
            })
    out = [("PCS reduction", rows, {"load (N)": ".1f", "lube T (°C)": ".1f"})]
    tts = [t for r in reds for t in r.detail.time_tests]
    if tts:
        below = f"time μ<{tts[0].threshold:g} (s)"
        shown = [{
            "file": t.label, "step": t.step,
            "application (s)": f"{t.application_time_s:.0f} ({t.application_source.split()[0]})",
            "minimum": t.minimum,
            "recovery (s)": f"{t.recovery_time_s:.0f}" if t.recovered else "not recovered",
            "mean after recovery": f"{t.mean_after_recovery:.4f}" if t.recovered else "",
            below: t.time_below_threshold_s, "plateau": t.plateau,
        } for t in tts]
        out.append(("Time tests after application (thesis Fig. 5.9)", shown,
                    {"minimum": ".4f", "plateau": ".4f", below: ".0f"}))
    return out


def _mean(df: Any, col: str) -> float:
    return float(df[col].mean()) if col in df else float("nan")


# ------------------------------------------------------------------ measured curves
def traction_curves(red: Reduction) -> list[Curve]:
    """One curve per traction step: |SRR| and |mu| (folded), with the step's mean speed
    (readings at a glitch of the speed control left out: :func:`torlab.reduce.mtm.speed_glitches`)."""
    import numpy as np

    d = red.detail.curves.get("traction")
    if d is None:
        return []
    if "speed_outlier" in d:
        d = d[~d["speed_outlier"]]
    out = []
    for st in dict.fromkeys(d["step"].tolist()):
        sub = d[d["step"] == st].sort_values("srr")
        v = float(sub["rolling_speed_m_s"].mean()) if "rolling_speed_m_s" in sub else None
        out.append(Curve(f"step {st}", np.abs(sub["srr"].to_numpy(dtype=float)),
                         np.abs(sub["traction_coefficient"].to_numpy(dtype=float)), speed_m_s=v,
                         temperature_C=_temp(sub)))
    return out


def stribeck_curves(red: Reduction) -> list[Curve]:
    """The Stribeck steps' points, sorted by rolling speed."""
    import numpy as np

    d = red.detail.curves.get("stribeck")
    if d is None:
        return []
    d = d.sort_values("rolling_speed_m_s")
    srr = d["srr"].to_numpy(dtype=float) if "srr" in d else np.full(len(d), np.nan)
    return [Curve("", d["rolling_speed_m_s"].to_numpy(dtype=float),
                  d["traction_coefficient"].to_numpy(dtype=float), srr=srr,
                  temperature_C=_temp(d))]


def film_curves(red: Reduction) -> list[Curve]:
    """One film-thickness curve per film step, labelled by its temperature (rows of a
    fringe-order misassignment left out: :func:`torlab.reduce.mtm.film_order_outliers`)."""
    d = red.detail.curves.get("film")
    if d is None or "film_thickness_m" not in d:
        return []
    out = []
    good = ~d["interference_order_outlier"] if "interference_order_outlier" in d else True
    for st in dict.fromkeys(d["step"].tolist()):
        sub = d[(d["step"] == st) & d["film_thickness_m"].notna() & good]
        if len(sub):
            out.append(Curve(str(sub["label"].iloc[0]), sub["rolling_speed_m_s"].to_numpy(dtype=float),
                             sub["film_thickness_m"].to_numpy(dtype=float),
                             temperature_C=_temp(sub)))
    return out


def _temp(d: Any) -> float | None:
    for c in ("lube_temperature_C", "pot_temperature_C", "temperature_C"):
        if c in d and d[c].notna().any():
            return float(d[c].mean())
    return None


# ------------------------------------------------------------------ protocol section data.mtm
def section_options(section: Any, ctx: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """The section's options; the time tests after application when the protocol reports
    them."""
    opts = {**section.options(),
            "after_application": True if ctx.p.reports.time_test is not None else None}
    return opts, opts


def write_section(dest: Any, labelled: list[tuple[str, Reduction]]) -> dict[str, Any]:
    """``data/mtm/<file>_<kind>.csv`` per step kind and ``data/mtm_steps.csv`` (labelled)."""
    import pandas as pd

    steps = []
    for label, red in labelled:
        steps.append(red.detail.steps.assign(label=label))
        for kind, cdf in red.detail.curves.items():
            dest.write_csv(f"data/mtm/{red.stem}_{kind}.csv", cdf,
                           allow_missing=red.optional.get(kind, ()))
    sdf = pd.concat(steps, ignore_index=True)
    dest.write_csv("data/mtm_steps.csv", sdf, allow_missing=tuple(
        c for c in sdf.columns if c not in ("step", "n_rows", "first_line", "last_line")))
    return {"files": len(labelled),
            "timed_steps": sum(len(r.detail.time_tests) for _, r in labelled)}
