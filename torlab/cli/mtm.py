"""``torlab mtm``: PCS Instruments MTM/ETM/EHD2 exports."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from torlab.cli._common import ForceOpt, OutOpt, command_line, console, print_table, require_files

app = typer.Typer(help="PCS Instruments MTM/ETM (and EHD2) exports: traction, Stribeck and timed "
                  "steps; time tests after application (Paper B).", no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``mtm`` group to the root app."""
    root.add_typer(app, name="mtm")


@app.command("reduce")
def reduce_cmd(
    files: Annotated[list[Path], typer.Argument(help="PCS text exports (MTM311/ETM/EHD261 "
                                                "'Test Data File').")],
    out: OutOpt,
    instrument: Annotated[str | None, typer.Option(
        help="Read the files as MTM, ETM or EHD2 (default: detected from the first line).")] = None,
    threshold: Annotated[float, typer.Option(help="Low-adhesion threshold of the time tests.")] = 0.15,
    application_time: Annotated[str | None, typer.Option(
        "--application-time", help="Application moment on the step-time axis (e.g. '60 s'); "
        "default: detected as the largest drop of the coefficient.")] = None,
    recovery_fraction: Annotated[float, typer.Option(
        help="Recovered when the coefficient is this fraction of the way back from the minimum "
        "to the plateau.")] = 0.9,
    recovery_level: Annotated[float | None, typer.Option(
        help="Recovered when the coefficient reaches this fixed value instead.")] = None,
    smooth: Annotated[str, typer.Option(help="Running-median window for the minimum and the "
                                        "crossings ('0 s': raw samples).")] = "10 s",
    min_drop: Annotated[float, typer.Option(help="Smallest drop taken as the application when "
                                            "detecting it.")] = 0.05,
    duration: Annotated[str | None, typer.Option(
        help="Evaluate up to this time after the application (Paper B: '20 min'); default: to "
        "the end of the step.")] = None,
    force: ForceOpt = False,
) -> None:
    """Reduce PCS exports: per step, traction coefficient against SRR (traction steps), rolling
    speed (Stribeck) or time (timed), with load and temperatures; time-test figures of every
    timed step (thesis Fig. 5.9: application, minimum, time to recover, mean after recovery,
    time below the threshold).

    Writes per input '<name>_steps.csv', '<name>_<type>.csv' and '<name>_<type>.png' for each
    step type present, '<name>_time_test.png', '<name>_metadata.json'; 'summary.csv' (one row
    per data step) and 'time_tests.csv'.
    """
    import pandas as pd

    from torlab.errors import TorlabInputError
    from torlab.outputs import OutputDir
    from torlab.parsers.pcs import read_pcs
    from torlab.reduce.mtm import TIME_TEST_OPTIONAL, reduce_pcs
    from torlab.reports.mtm import curve_figure, time_test_figure
    from torlab.units import to_si

    paths = require_files(files, "PCS export")
    if instrument is not None and instrument.strip().upper() not in ("MTM", "ETM", "EHD2", "EHD"):
        raise TorlabInputError(f"{instrument!r}: choose MTM, ETM or EHD2", key="--instrument")
    opts = {
        "threshold": threshold,
        "recovery_fraction": recovery_fraction,
        "recovery_level": recovery_level,
        "smooth": to_si(smooth, "time", where="--smooth"),
        "min_drop": min_drop,
    }
    if not (0 <= threshold < 10):
        raise TorlabInputError(f"{threshold}: give a coefficient such as 0.15", key="--threshold")
    if not (0 < recovery_fraction <= 1):
        raise TorlabInputError(f"{recovery_fraction}: must be in (0, 1]", key="--recovery-fraction")
    if opts["smooth"] < 0:
        raise TorlabInputError("must not be negative", key="--smooth")
    if application_time is not None:
        opts["application_time"] = to_si(application_time, "time", where="--application-time")
    if duration is not None:
        opts["duration"] = to_si(duration, "time", where="--duration")
        if opts["duration"] <= 0:
            raise TorlabInputError("must be a positive time", key="--duration")
    dest = OutputDir(out, force=force, inputs=paths, command=command_line())
    reds = []
    try:
        stems: set[str] = set()
        all_steps, all_tt = [], []
        for f in paths:
            df, meta = read_pcs(f, instrument=instrument)
            try:
                red = reduce_pcs(df, meta, **opts)
            except TorlabInputError as e:
                raise e.with_path(f) from None
            stem = f.stem
            while stem in stems:
                stem += "_"
            stems.add(stem)
            dest.write_json(f"{stem}_metadata.json", meta.to_dict())
            steps = red.steps
            dest.write_csv(f"{stem}_steps.csv", steps, allow_missing=_numeric_optional(steps))
            for kind, cdf in red.curves.items():
                dest.write_csv(f"{stem}_{kind}.csv", cdf, allow_missing=_numeric_optional(cdf))
                dest.save_figure(f"{stem}_{kind}.png", curve_figure(red, kind))
            if red.time_tests:
                dest.save_figure(f"{stem}_time_test.png", time_test_figure(red, red.time_tests))
            all_steps.append(steps)
            all_tt += [dict(file=f.name, **t.summary()) for t in red.time_tests]
            reds.append(red)
        summary = pd.concat(all_steps, ignore_index=True)
        dest.write_csv("summary.csv", summary, allow_missing=_numeric_optional(summary))
        if all_tt:
            tt = pd.DataFrame(all_tt).drop(columns=["label"])
            dest.write_csv("time_tests.csv", tt, allow_missing=TIME_TEST_OPTIONAL)
    except BaseException:
        dest.abort()
        raise
    dest.commit()
    _print(reds, out)


def _numeric_optional(df: object) -> tuple[str, ...]:
    """Columns that may hold 'not logged' cells (everything but the identifiers)."""
    keep = {"step", "line", "n_rows", "first_line", "last_line"}
    return tuple(c for c in df.columns if c not in keep)  # type: ignore[attr-defined]


def _print(reds: list, out: Path) -> None:
    import math

    rows = []
    for r in reds:
        s = r.steps
        for kind in ("timed", "traction", "stribeck", "film"):
            sub = s[s["step_type"] == kind]
            if sub.empty:
                continue
            lo = sub.get("traction_coefficient_min")
            hi = sub.get("traction_coefficient_max")
            rows.append({
                "file": r.label, "instrument": r.meta.instrument, "step type": kind,
                "steps": len(sub), "rows": int(sub["n_rows"].sum()),
                "load (N)": float(sub["ball_load_N"].mean()) if "ball_load_N" in sub else math.nan,
                "lube T (°C)": float(sub["lube_temperature_C"].mean())
                if "lube_temperature_C" in sub else math.nan,
                "μ range": "" if lo is None or lo.isna().all() else
                f"{lo.min():.4f} … {hi.max():.4f}",
            })
    print_table(rows, title="PCS reduction", formats={"load (N)": ".1f", "lube T (°C)": ".1f"})
    tts = [t for r in reds for t in r.time_tests]
    if tts:
        shown = [{
            "file": t.label, "step": t.step,
            "application (s)": f"{t.application_time_s:.0f} ({t.application_source.split()[0]})",
            "minimum": t.minimum, "recovery (s)": "not recovered" if not t.recovered else
            f"{t.recovery_time_s:.0f}",
            "mean after recovery": "" if not t.recovered else f"{t.mean_after_recovery:.4f}",
            f"time μ<{t.threshold:g} (s)": t.time_below_threshold_s,
            "plateau": t.plateau,
        } for t in tts]
        print_table(shown, title="Time tests after application (thesis Fig. 5.9)",
                    formats={"minimum": ".4f", "plateau": ".4f",
                             f"time μ<{tts[0].threshold:g} (s)": ".0f"})
    c = console()
    for r in reds:
        for w in r.meta.warnings:
            c.print(f"[yellow]note[/yellow] {r.label}: {w}")
    c.print(f"wrote reduced CSVs, figures, summary.csv{' and time_tests.csv' if tts else ''} to "
            f"{out}")
