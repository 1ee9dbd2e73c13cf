"""``torlab hpt``: high-pressure torsion logs."""

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

app = typer.Typer(help="High-pressure torsion (HPT) rig: reduce raw logs to shear stress and "
                  "friction against displacement.", no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``hpt`` group to the root app."""
    root.add_typer(app, name="hpt")


@app.command("reduce")
def reduce_cmd(
    raw: Annotated[list[Path], typer.Argument(help="Raw HPT logs (torlab-hpt format, or another "
                                              "rig's CSV with --map); folders and patterns "
                                              "such as 'logs/*.txt' are expanded.")],
    out: OutOpt,
    map_: Annotated[Path | None, typer.Option("--map", help="Column map (YAML) for another rig's "
                                              "CSV layout; see docs/formats/hpt.md.")] = None,
    window: Annotated[str, typer.Option(help="Displacement window before the maximum over which "
                                        "f is averaged.")] = "20 um",
    source: Annotated[str, typer.Option(help="Displacement from the 'motor' angle, the 'encoder' "
                                        "angle, or 'auto' (motor where logged).")] = "auto",
    compliance: Annotated[str | None, typer.Option(
        help="Rig compliance to subtract: a curve file (torlab-hpt log of a dry run, or CSV with "
        "shear_stress and displacement columns) or a constant such as '0.012 um/MPa'.")] = None,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    no_plot: NoPlotOpt = False,
    formats: FormatsOpt = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Reduce HPT logs: S, r_e, sigma = F/S, tau = M/(r_e S), f = tau/sigma against
    displacement (thesis Eqs. 5.1-5.4), and f over the last 20 um before the maximum.

    Writes per input '<name>_reduced.csv' (SI units in the column names), 'summary.csv',
    and 'hpt.png' with every run on one figure.
    """
    from torlab.cli._reduce import reduce_command

    opts = {"window": window, "source": source, "compliance": compliance, "map": map_}
    reduce_command(raw, out, instrument="hpt", force=force, xlsx=xlsx, what="HPT log",
                   options={k: v for k, v in opts.items() if v is not None},
                   filter_folders=map_ is None,
                   formats=formats, jobs=jobs, scheduler=scheduler, quiet=quiet,
                   no_plot=no_plot)
