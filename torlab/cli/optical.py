"""``torlab optical``: optical ball-on-disc tribometer logs (and PCS EHD2 exports)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from torlab.cli._common import ForceOpt, OutOpt, command_line, console, print_table, require_files

app = typer.Typer(help="Optical ball-on-disc tribometer (thesis 5.1.1): windowed averages at "
                  "each set condition, traction / Stribeck / film-thickness tests (Tab. 5.2).",
                  no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``optical`` group to the root app."""
    root.add_typer(app, name="optical")


def _is_pcs(path: Path) -> bool:
    """Whether the file's first line is a PCS export's (``EHD261 Test Data File``, ``Step 1 ...``)."""
    import re

    with open(path, "rb") as f:
        head = f.read(300).decode("utf-8", errors="replace").lstrip("\ufeff").lstrip()
    first = head.split("\n", 1)[0].strip()
    return bool(re.match(r"^(\w+\s+Test\s+Data\s+File|Step\s+\d+\b.*started\s+at)", first))


@app.command("reduce")
def reduce_cmd(
    logs: Annotated[list[Path], typer.Argument(help="torlab-optical logs (docs/formats/optical.md) "
                                               "or PCS EHD2 exports.")],
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
) -> None:
    """Reduce optical tribometer logs: mean coefficient, speeds, load and film thickness over the
    last WINDOW of every set condition; rolling speed U = (u_ball + u_disc)/2 and
    SRR = (u_ball - u_disc)/U (thesis Eq. 2.4); the Tab. 5.2 test type; for traction tests the
    negative SRR folded onto positive with a symmetry check.

    Writes per input '<name>_points.csv' (one row per condition), '<name>_folded.csv' (traction
    tests) and '<name>.png'; 'summary.csv' with one row per input.
    """
    import pandas as pd

    from torlab.errors import TorlabInputError
    from torlab.outputs import OutputDir
    from torlab.reduce.optical import (
        FOLDED_OPTIONAL,
        POINT_OPTIONAL,
        SUMMARY_OPTIONAL,
        classify_test,
        fold_traction,
        reduce_ehd2,
        reduce_optical_log,
    )
    from torlab.reports.optical import optical_figure
    from torlab.units import to_si

    paths = require_files(logs, "optical log")
    w = to_si(window, "time", where="--window")
    if w <= 0:
        raise TorlabInputError("must be a positive time", key="--window")
    if test is not None:
        classify_test(None, given=test)  # validates the name
    if not (symmetry_tolerance >= 0 and symmetry_abs >= 0):
        raise TorlabInputError("symmetry tolerances must not be negative",
                               key="--symmetry-tolerance")
    dest = OutputDir(out, force=force, inputs=paths, command=command_line())
    results = []
    try:
        stems: set[str] = set()
        for f in paths:
            if _is_pcs(f):
                from torlab.parsers.pcs import read_pcs

                df, meta = read_pcs(f)
                res = reduce_ehd2(df, meta)
                if test is not None:
                    res.test, res.test_source = classify_test(res.points, given=test)
                if res.test in ("traction", "dry_traction") and "traction_coefficient" in res.points:
                    res.folded, res.symmetry = fold_traction(res.points, rel_tol=symmetry_tolerance,
                                                             abs_tol=symmetry_abs)
            else:
                res = reduce_optical_log(f, window=w, test=test, sym_rel=symmetry_tolerance,
                                         sym_abs=symmetry_abs)
            stem = f.stem
            while stem in stems:
                stem += "_"
            stems.add(stem)
            dest.write_csv(f"{stem}_points.csv", res.points, allow_missing=(*POINT_OPTIONAL, *(
                c for c in res.points.columns if c not in ("condition", "rolling_speed_m_s"))))
            if res.folded is not None:
                dest.write_csv(f"{stem}_folded.csv", res.folded, allow_missing=FOLDED_OPTIONAL)
            dest.save_figure(f"{stem}.png", optical_figure(res))
            results.append(res)
        summary = pd.DataFrame([r.summary() for r in results])
        dest.write_csv("summary.csv", summary, allow_missing=SUMMARY_OPTIONAL)
    except BaseException:
        dest.abort()
        raise
    dest.commit()
    shown = []
    for r in results:
        s = r.summary()
        shown.append({
            "file": s["file"], "test": s["test"] + (" (detected)" if s["test_source"] == "detected"
                                                   else ""),
            "conditions": s["n_conditions"],
            "U (m/s)": f"{s['rolling_speed_min_m_s']:.3g} … {s['rolling_speed_max_m_s']:.3g}",
            "SRR (%)": f"{s['srr_min'] * 100:.3g} … {s['srr_max'] * 100:.3g}",
            "μ": "" if s["traction_coefficient_min"] != s["traction_coefficient_min"] else
            f"{s['traction_coefficient_min']:.4f} … {s['traction_coefficient_max']:.4f}",
            "h (nm)": "" if s["film_thickness_min_m"] != s["film_thickness_min_m"] else
            f"{s['film_thickness_min_m'] * 1e9:.3g} … {s['film_thickness_max_m'] * 1e9:.3g}",
            "±SRR symmetric": s["symmetric"],
        })
    print_table(shown, title=f"Optical tribometer reduction ({w:g} s windows)")
    c = console()
    for r in results:
        for wn in r.warnings:
            c.print(f"[yellow]note[/yellow] {Path(r.source).name}: {wn}")
    c.print(f"wrote {len(results)} points CSV(s), figures and summary.csv to {out}")
