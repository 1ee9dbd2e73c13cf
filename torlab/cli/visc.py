"""``torlab visc``: falling-body high-pressure viscometer logs."""

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

app = typer.Typer(help="Falling-body high-pressure viscometer (thesis 5.1.5): terminal velocities, "
                  "viscosity per pressure step, Barus and Roelands fits.", no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``visc`` group to the root app."""
    root.add_typer(app, name="visc")


@app.command("reduce")
def reduce_cmd(
    logs: Annotated[list[Path], typer.Argument(help="torlab-visc logs of the sample liquid "
                                               "(docs/formats/viscometer.md).")],
    out: OutOpt,
    reference: Annotated[list[Path] | None, typer.Option(
        help="Reference-liquid log(s) with a 'reference_viscosity' header: calibrate K from them "
        "(repeat for several).")] = None,
    calibration_constant: Annotated[str | None, typer.Option(
        "--calibration-constant", help="K of eta = K (rho_body - rho_liquid) / v, e.g. "
        "'1.9e-8 m^3/s^2' (instead of the header or a reference log).")] = None,
    tol: Annotated[float, typer.Option(help="Steady part: local slope within this fraction of the "
                                       "terminal velocity.")] = 0.02,
    density_model: Annotated[str | None, typer.Option(
        help="Liquid density against pressure: constant or dowson-higginson (default: the "
        "log's header).")] = None,
    law: Annotated[str, typer.Option(help="Fits: barus, roelands or both (comma list).")] = "barus,roelands",
    fit_eta0: Annotated[bool, typer.Option("--fit-eta0", help="Fit eta0 with Roelands Z (default: "
                                           "eta0 from the atmospheric points).")] = False,
    eta0: Annotated[str | None, typer.Option(help="Fix the Roelands eta0 (e.g. '65 mPa*s').")] = None,
    confidence: Annotated[float, typer.Option(help="Level of the confidence intervals.")] = 0.95,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    no_plot: NoPlotOpt = False,
    formats: FormatsOpt = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Reduce viscometer logs: falls found in the LVDT trace, terminal velocity from each fall's
    steady part, eta = K (rho_body - rho_liquid) / v per fall and per pressure step; then the
    Barus alpha (ln eta against p) and Roelands Z fits with confidence intervals and residuals.

    Writes per input '<name>_falls.csv', '<name>_steps.csv', '<name>_fit.csv',
    '<name>_lubricant_<law>.yaml' (the scene's lubricant: block), '<name>_falls.png',
    '<name>_fit.png'; 'summary.csv' and, with --reference, 'calibration.csv'.
    """
    from torlab.cli._reduce import reduce_command

    opts = {"reference": reference or None, "calibration_constant": calibration_constant,
            "tol": tol, "density_model": density_model, "law": law, "fit_eta0": fit_eta0,
            "eta0": eta0, "confidence": confidence}
    reduce_command(logs, out, instrument="visc", force=force, xlsx=xlsx, what="viscometer log",
                   options={k: v for k, v in opts.items() if v is not None},
                   formats=formats, jobs=jobs, scheduler=scheduler, quiet=quiet,
                   no_plot=no_plot)
