"""``torlab synth``: seeded virtual experiments (sample data with a known truth)."""

from typing import Annotated

import typer

from torlab.cli._common import ForceOpt, OutOpt, command_line, console

app = typer.Typer(help="Generate synthetic raw logs from stated model parameters (seeded, "
                  "with the generating parameters written next to them).", no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``synth`` group to the root app."""
    root.add_typer(app, name="synth")


def _write(out: object, force: bool, seed: int, writer: object, what: str) -> None:
    """Run a ``write_*_sample_data(dest, seed=)`` into a new output folder and say so."""
    from torlab.outputs import OutputDir

    with OutputDir(out, force=force, command=command_line()) as dest:
        names = writer(dest, seed=seed)  # type: ignore[operator]
    console().print(f"wrote {len(names)} {what} to {out}")


@app.command("hpt")
def synth_hpt(
    out: OutOpt,
    seed: Annotated[int | None, typer.Option(
        help="Random seed (the same seed gives the same files); default 2022 (Paper C), "
             "2023 (Paper B).")] = None,
    campaign: Annotated[str, typer.Option(
        help="paper_c: OFM1, OFM2, WFM (wet/dry), SFM at 1-16 uL (mg) and at 25-185 degC, dry "
             "reference; paper_b: the custom TOR lubricant and TOR A at 8 uL to 0.1 mm.",
        case_sensitive=False)] = "paper_c",
    force: ForceOpt = False,
) -> None:
    """Virtual HPT campaign of Paper C (default) or Paper B: raw logs, the rig compliance
    curve and truth.yaml."""
    from functools import partial

    from torlab.errors import TorlabInputError
    from torlab.synth.hpt import write_hpt_sample_data

    camp = campaign.strip().lower()
    if camp not in ("paper_c", "paper_b"):
        raise TorlabInputError(f"--campaign must be paper_c or paper_b, not {campaign!r}",
                               key="--campaign")
    _write(out, force, seed if seed is not None else 2022 if camp == "paper_c" else 2023,
           partial(write_hpt_sample_data, campaign=camp),
           "synthetic HPT logs, rig_compliance.csv and truth.yaml")


@app.command("mtm")
def synth_mtm(
    out: OutOpt,
    seed: Annotated[int, typer.Option(help="Random seed (the same seed gives the same files).")] = 2020,
    force: ForceOpt = False,
) -> None:
    """Virtual Paper B MTM time tests after application: PCS 'MTM311 Test Data File' exports
    (BOD_TIMED, 1 Hz, 20 min after the application) of compositions of thesis Tab. 5.3 and two
    amounts of TOR A, with truth.yaml (application time, minimum, recovery time, plateau)."""
    from torlab.synth.mtm import write_mtm_sample_data

    _write(out, force, seed, write_mtm_sample_data, "synthetic MTM exports and truth.yaml")


@app.command("retention")
def synth_retention(
    out: OutOpt,
    seed: Annotated[int, typer.Option(help="Random seed (the same seed gives the same files).")] = 2016,
    force: ForceOpt = False,
) -> None:
    """Virtual retention campaign with a stated removal law: two MTM time tests after
    application (PCS exports, 1 and 2 uL, first order k1 = 1e-6 m^2/J in the frictional
    energy), the product's HPT amount series (1-16 uL and dry, the truth layer), the rig
    compliance and truth.yaml (law, layer nodes, initial amounts, energy at the end)."""
    from torlab.synth.retention import write_retention_sample_data

    _write(out, force, seed, write_retention_sample_data,
           "synthetic time tests and HPT logs, rig_compliance.csv and truth.yaml")


@app.command("visc")
def synth_visc(
    out: OutOpt,
    seed: Annotated[int, typer.Option(help="Random seed (the same seed gives the same files).")] = 2021,
    force: ForceOpt = False,
) -> None:
    """Virtual Paper B viscometer campaign: a reference-liquid calibration log and the ester oil
    at 0.1-300 MPa in 50 MPa steps at 25 °C (Roelands law), with truth.yaml."""
    from torlab.synth.viscometer import write_viscometer_sample_data

    _write(out, force, seed, write_viscometer_sample_data,
           "synthetic viscometer logs and truth.yaml")


@app.command("optical")
def synth_optical(
    out: OutOpt,
    seed: Annotated[int, typer.Option(help="Random seed (the same seed gives the same files).")] = 2019,
    tests: Annotated[str, typer.Option(help="Comma list of the Tab. 5.2 tests to write (names as "
                                       "in paper_a_conditions(), or 'all').")] = "all",
    force: ForceOpt = False,
) -> None:
    """Demo optical tribometer logs of the Paper A test sequence (thesis Tab. 5.2) at 1 kHz.

    The truth is a simple *analytic stand-in* (documented in docs/sample-data.md), not torlab's
    friction model: mu = mu_max(U) tanh(SRR / 1 %) with mu_max falling with speed (0.25 dry),
    h = 40 nm (U / 1 m/s)^0.67.  truth.yaml lists it per condition."""
    from torlab.errors import TorlabInputError
    from torlab.outputs import OutputDir
    from torlab.synth.optical import demo_truth, paper_a_conditions, write_optical_log
    from torlab.yamlio import dump_yaml

    all_tests = paper_a_conditions()
    names = [t.name for t in all_tests]
    pick = names if tests.strip() == "all" else [s.strip() for s in tests.split(",") if s.strip()]
    bad = [p for p in pick if p not in names]
    if bad or not pick:
        raise TorlabInputError(f"unknown test {', '.join(bad) or tests!r} (known: {', '.join(names)})",
                               key="--tests")
    with OutputDir(out, force=force, command=command_line()) as dest:
        truth = {"description": "SYNTHETIC optical tribometer logs (torlab synth optical): Paper A "
                                "test sequence of thesis Tab. 5.2 with an analytic stand-in truth "
                                "(not the torlab model)", "seed": seed, "tests": []}
        for k, t in enumerate(all_tests):
            if t.name not in pick:
                continue
            mu_fn, h_fn, desc = demo_truth(t)
            rows = write_optical_log(dest.path(f"{t.name}.csv"), t, mu_fn, h_fn, seed=seed + k,
                                     notes=f"demo truth: {desc}")
            truth["tests"].append({"file": f"{t.name}.csv", "test": t.test, "surface": t.surface,
                                   "truth": desc, "conditions": rows})
        dest.write_text("truth.yaml", dump_yaml(truth))
    console().print(f"wrote {len(pick)} synthetic optical logs and truth.yaml to {out}")
