"""``torlab optical``: optical ball-on-disc tribometer logs (and PCS EHD2 exports)."""

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

app = typer.Typer(help="Optical ball-on-disc tribometer (thesis 5.1.1): windowed averages at "
                  "each set condition, traction / Stribeck / film-thickness tests (Tab. 5.2).",
                  no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``optical`` group to the root app."""
    root.add_typer(app, name="optical")


@app.command("reduce")
def reduce_cmd(
    logs: Annotated[list[Path], typer.Argument(help="torlab-optical logs (docs/formats/optical.md) "
                                               "or PCS EHD2 exports; folders and patterns are "
                                               "expanded.")],
    out: OutOpt,
    window: Annotated[str, typer.Option(help="Averaging window at the end of each set condition "
                                        "(Paper A: 4 s).")] = "4 s",
    test: Annotated[str | None, typer.Option(
        help="Test type: dry_traction, film_thickness, stribeck or traction (default: the log's "
        "'test' header, else detected).")] = None,
    symmetry_tolerance: Annotated[float, typer.Option(
        help="Relative tolerance of the ±SRR symmetry check.")] = 0.10,
    symmetry_abs: Annotated[float, typer.Option(
        help="Absolute tolerance (coefficient) of the ±SRR symmetry check.")] = 0.005,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    no_plot: NoPlotOpt = False,
    formats: FormatsOpt = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Reduce optical tribometer logs: mean coefficient, speeds, load and film thickness over the
    last WINDOW of every set condition; rolling speed U = (u_ball + u_disc)/2 and
    SRR = (u_ball - u_disc)/U (thesis Eq. 2.4); the Tab. 5.2 test type; for traction tests the
    negative SRR folded onto positive with a symmetry check (EHD2 exports too).

    Writes per input '<name>_points.csv' (one row per condition), '<name>_folded.csv' (traction
    tests) and '<name>.png'; 'summary.csv' with one row per input.
    """
    from torlab.cli._reduce import reduce_command

    opts = {"window": window, "test": test, "symmetry_tolerance": symmetry_tolerance,
            "symmetry_abs": symmetry_abs}
    reduce_command(logs, out, instrument="optical", force=force, xlsx=xlsx, what="optical log",
                   options={k: v for k, v in opts.items() if v is not None},
                   formats=formats, jobs=jobs, scheduler=scheduler, quiet=quiet,
                   no_plot=no_plot)
