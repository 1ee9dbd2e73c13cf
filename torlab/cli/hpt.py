"""``torlab hpt``: high-pressure torsion logs."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from torlab.cli._common import ForceOpt, OutOpt, command_line, console, print_table, require_files

app = typer.Typer(help="High-pressure torsion (HPT) rig: reduce raw logs to shear stress and "
                  "friction against displacement.", no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``hpt`` group to the root app."""
    root.add_typer(app, name="hpt")


@app.command("reduce")
def reduce_cmd(
    raw: Annotated[list[Path], typer.Argument(help="Raw HPT logs (torlab-hpt format, or another "
                                              "rig's CSV with --map).")],
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
) -> None:
    """Reduce HPT logs: S, r_e, sigma = F/S, tau = M/(r_e S), f = tau/sigma against
    displacement (thesis Eqs. 5.1-5.4), and f over the last 20 um before the maximum.

    Writes per input '<name>_reduced.csv' (SI units in the column names), 'summary.csv',
    and 'hpt.png' with every run on one figure.
    """
    from torlab.errors import TorlabInputError
    from torlab.outputs import OutputDir
    from torlab.parsers.hpt import read_hpt, read_hpt_map
    from torlab.reduce.hpt import RigCompliance, reduce_hpt
    from torlab.reports.hpt import hpt_figure
    from torlab.units import to_si

    files = require_files(raw, "HPT log")
    w = to_si(window, "length", where="--window")
    if w <= 0:
        raise TorlabInputError("must be a positive length", key="--window")
    if source not in ("auto", "motor", "encoder"):
        raise TorlabInputError(f"{source!r}: choose auto, motor or encoder", key="--source")
    comp = None
    inputs = list(files)
    if compliance is not None:
        cp = Path(compliance)
        if cp.exists():
            comp = RigCompliance.from_file(cp)
            inputs.append(cp)
        else:
            comp = RigCompliance.linear(to_si(compliance, "compliance", where="--compliance"))
    mapping = None
    if map_ is not None:
        mapping = read_hpt_map(map_)
        inputs.append(map_)
    dest = OutputDir(out, force=force, inputs=inputs, command=command_line())
    results = []
    try:
        names = set()
        for f in files:
            df, meta = read_hpt(f, mapping)
            res = reduce_hpt(df, meta, window=w, source=source, compliance=comp)
            stem = f.stem
            while stem in names:
                stem += "_"
            names.add(stem)
            dest.write_csv(f"{stem}_reduced.csv", res.data)
            results.append(res)
        import pandas as pd

        rows = [r.summary() for r in results]
        dest.write_csv("summary.csv", pd.DataFrame(rows),
                       allow_missing=("applied_amount", "temperature_C"))
        dest.save_figure("hpt.png", hpt_figure(results, title="HPT: shear stress and friction"))
    except BaseException:
        dest.abort()
        raise
    dest.commit()
    shown = [{
        "file": r["file"], "product": (r["product"] + (f" {r['condition']}" if r["condition"] else "")),
        "amount": "" if r["applied_amount_unit"] == "" else f"{r['applied_amount']:g} {r['applied_amount_unit']}",
        "T (°C)": "" if r["temperature_C"] != r["temperature_C"] else f"{r['temperature_C']:.0f}", "σ (MPa)": r["normal_stress_Pa"] / 1e6,
        f"f (last {w * 1e6:g} µm)": r["f_window"], "± sd": r["f_window_std"],
        "u max (µm)": r["displacement_max_m"] * 1e6, "u from": r["displacement_source"],
    } for r in rows]
    print_table(shown, title="HPT reduction", formats={"σ (MPa)": ".1f", "u max (µm)": ".1f",
                                                       "± sd": ".4f", f"f (last {w * 1e6:g} µm)": ".4f"})
    c = console()
    if comp is not None:
        c.print(f"rig compliance subtracted: {results[0].compliance}")
    c.print(f"wrote {len(results)} reduced CSV(s), summary.csv and hpt.png to {out}")
