"""``torlab synth``: seeded virtual experiments (sample data with a known truth)."""

from __future__ import annotations

from typing import Annotated

import typer

from torlab.cli._common import ForceOpt, OutOpt, command_line, console

app = typer.Typer(help="Generate synthetic raw logs from stated model parameters (seeded, "
                  "with the generating parameters written next to them).", no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``synth`` group to the root app."""
    root.add_typer(app, name="synth")


@app.command("hpt")
def synth_hpt(
    out: OutOpt,
    seed: Annotated[int, typer.Option(help="Random seed (the same seed gives the same files).")] = 2022,
    force: ForceOpt = False,
) -> None:
    """Virtual Paper C campaign: HPT logs of OFM1, OFM2, WFM (wet/dry), SFM at 1-16 uL (mg),
    raised-temperature runs, a dry reference, the rig compliance curve and truth.yaml."""
    from torlab.outputs import OutputDir
    from torlab.synth.hpt import write_hpt_sample_data

    with OutputDir(out, force=force, command=command_line()) as dest:
        names = write_hpt_sample_data(dest, seed=seed)
    console().print(f"wrote {len(names)} synthetic HPT logs, rig_compliance.csv and truth.yaml to {out}")
