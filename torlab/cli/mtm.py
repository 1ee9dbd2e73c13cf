"""``torlab mtm``: PCS Instruments MTM/ETM/EHD2 exports."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from torlab.cli._common import (
    ForceOpt,
    FormatsOpt,
    JobsOpt,
    NoPlotOpt,
    OutOpt,
    QuietOpt,
    SchedulerOpt,
    XlsxOpt,
)

app = typer.Typer(help="PCS Instruments MTM/ETM (and EHD2) exports: every step kind (traction, "
                  "Stribeck, timed, film, mapper ...); time tests after application (Paper B).",
                  no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``mtm`` group to the root app."""
    root.add_typer(app, name="mtm")


@app.command("reduce")
def reduce_cmd(
    files: Annotated[list[Path], typer.Argument(help="PCS text exports (MTM311/ETM/EHD261 "
                                                "'Test Data File'); folders and patterns such "
                                                "as 'exports/*.txt' are expanded.")],
    out: OutOpt,
    instrument: Annotated[str | None, typer.Option(
        help="Read the files as MTM, ETM or EHD2 (default: detected from the first line).")] = None,
    after_application: Annotated[bool, typer.Option(
        "--after-application", help="Analyse every timed step as a time test after application "
        "(default: only steps whose description marks an application).")] = False,
    threshold: Annotated[float, typer.Option(help="Low-adhesion threshold of the time tests.")] = 0.15,
    application_time: Annotated[str | None, typer.Option(
        "--application-time", help="Application moment on the step-time axis (e.g. '60 s'; "
        "implies --after-application); default: detected as the largest drop.")] = None,
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
    xlsx: XlsxOpt = False,
    no_plot: NoPlotOpt = False,
    formats: FormatsOpt = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Reduce PCS exports: every data step (traction, Stribeck, ball- or pin-on-disc timed,
    film, mapper, and unknown step types) as the coefficient against the x column of its own
    header (SRR, rolling speed, time), with every logged column; EHD2 film steps labelled by
    temperature; the time-test figures after application (thesis Fig. 5.9: application,
    minimum, time to recover, mean after recovery, time below the threshold) of timed steps
    that mark an application, or of all with --after-application.

    Writes per input '<name>_steps.csv', '<name>_<kind>.csv' and '<name>_<kind>.png' for each
    step kind present, '<name>_time_test.png', '<name>_metadata.json'; 'summary.csv' (one row
    per data step) and 'time_tests.csv'.
    """
    from torlab.cli._reduce import reduce_command

    opts = {"family": instrument, "threshold": threshold, "application_time": application_time,
            "recovery_fraction": recovery_fraction, "recovery_level": recovery_level,
            "smooth": smooth, "min_drop": min_drop, "duration": duration,
            "after_application": True if after_application else None}
    if not (0 <= threshold < 10):
        from torlab.errors import TorlabInputError

        raise TorlabInputError(f"{threshold}: give a coefficient such as 0.15", key="--threshold")
    reduce_command(files, out, instrument="pcs", force=force, xlsx=xlsx, what="PCS export",
                   options={k: v for k, v in opts.items() if v is not None},
                   formats=formats, jobs=jobs, scheduler=scheduler, quiet=quiet,
                   no_plot=no_plot)
