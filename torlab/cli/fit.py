"""``torlab fit``: identify the model's parameters from reduced measurements.

Each command writes ``params.yaml`` (the scene contract's ``boundary:`` /
``lubricant:`` keys plus a ``fit:`` provenance section, so
``torlab predict traction SCENE params.yaml`` reads it unchanged),
``fit_table.csv`` (value, standard error, 95 % interval per parameter),
``correlation.csv``, ``fit_data.csv`` (data, model, residuals), ``fit.png``
(data against model and residuals) and ``summary.json``.  A fit that fails
writes nothing.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from torlab.cli._common import (
    ForceOpt,
    FormatsOpt,
    OutOpt,
    command_line,
    console,
    print_table,
    require_files,
)
from torlab.instruments.measured import film_data, hpt_items, is_hpt_input, traction_data

app = typer.Typer(help="Fit the model's parameters (third-body layer, temperature coefficients, "
                  "viscosity, film) to reduced measurements, with uncertainties.",
                  no_args_is_help=True)


def register(root: typer.Typer) -> None:
    """Add the ``fit`` group to the root app."""
    root.add_typer(app, name="fit")


# ------------------------------------------------------------------------------------------
# shared output
# ------------------------------------------------------------------------------------------
def write_fit(dest: Any, result: Any, prefix: str = "", title: str | None = None,
              model_curve: tuple[Any, Any] | None = None, formats: Any = None) -> None:
    """Write one :class:`~torlab.fit.result.FitResult` into an OutputDir (under ``prefix``);
    its figure (the result's own :meth:`plot`) in ``formats`` (``--formats``; PNG by
    default)."""
    from torlab.reports.fit import result_figure
    from torlab.reports.render import parse_formats, plot, write_figures
    from torlab.yamlio import dump_yaml

    pre = f"{prefix}/" if prefix else ""
    use = ("torlab predict retention SCENE params.yaml" if result.kind == "removal" else
           "torlab predict (name it after the scene)")
    dest.write_text(f"{pre}params.yaml", f"# torlab fit output: a parameter file for {use}\n"
                    + dump_yaml(result.to_yaml_dict()))
    tab = result.table()
    dest.write_csv(f"{pre}fit_table.csv", tab, allow_missing=("stderr", "ci95_low", "ci95_high"))
    corr = result.correlation_table().reset_index(names="parameter")
    dest.write_csv(f"{pre}correlation.csv", corr, allow_missing=tuple(result.names))
    dest.write_csv(f"{pre}fit_data.csv", result.data)
    dest.write_json(f"{pre}summary.json", result.summary())
    write_figures(dest, [(f"{pre}fit", plot(result_figure, result, title=title,
                                            model_curve=model_curve))], parse_formats(formats))


def print_fit(result: Any, title: str) -> None:
    """Rich summary: parameters, intervals, residual norm and warnings."""
    from torlab.fit.result import PARAM_UNITS

    rows = []
    for _, r in result.table().iterrows():
        unit = PARAM_UNITS.get(r["parameter"], "")
        f = 1e6 if unit == "m" and abs(r["value"]) < 1e-2 else 1e9 if unit == "1/Pa" else 1.0
        u = {1e6: "µm", 1e9: "1/GPa"}.get(f, unit)
        rows.append({"parameter": r["parameter"], "value": f"{r['value'] * f:.5g}",
                     "± se": "—" if r["stderr"] != r["stderr"] else f"{r['stderr'] * f:.2g}",
                     "95 % interval": "—" if r["ci95_low"] != r["ci95_low"] else
                     f"[{r['ci95_low'] * f:.5g}, {r['ci95_high'] * f:.5g}]",
                     "unit": u, "status": r["status"]})
    print_table(rows, title=title)
    c = console()
    c.print(f"{result.n_points} points, residual RMS {result.residual_norm:.4g} "
            f"{result.residual_unit}, {result.n_evaluations} model evaluations")
    for w in result.warnings:
        c.print(f"[yellow]warning:[/yellow] {w}")


_FILES = ["params.yaml", "fit_table.csv", "correlation.csv", "fit_data.csv", "fit.png",
          "summary.json"]


def _compliance(value: str | None, inputs: list[Path]) -> Any:
    from torlab.reduce.hpt import RigCompliance

    comp = RigCompliance.from_spec(value, where="--compliance")
    if comp is not None and comp.path is not None:
        inputs.append(comp.path)
    return comp


def _prepare_hpt(items: list[Any], compliance: Any) -> list[Any]:
    from torlab.fit.layer import hpt_curve

    res = []
    for it in items:
        if isinstance(it, tuple):
            res.append(hpt_curve(it[1], name=it[0].name, compliance=compliance))
        else:
            res.append(hpt_curve(it, compliance=compliance if not it.compliance else None))
    return res


# ------------------------------------------------------------------------------------------
# commands
# ------------------------------------------------------------------------------------------
@app.command("hpt")
def hpt_cmd(
    inputs: Annotated[list[Path], typer.Argument(help="Raw HPT logs (torlab-hpt) or reduced CSVs "
                                                 "('torlab hpt reduce' output).")],
    out: OutOpt,
    joint: Annotated[bool, typer.Option("--joint", help="One fit of shared parameters to all "
                                        "curves (repeats of one product and amount).")] = False,
    compliance: Annotated[str | None, typer.Option(
        help="Rig compliance (curve file or constant such as '0.012 um/MPa'); default: the one "
        "the reduction subtracted.")] = None,
    force: ForceOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Layer parameters mu_c1, mu_c2, L_mue, L_mup from HPT curves (thesis Eqs. 5.24-5.29).

    One fit per curve (a sub-folder per curve when there are several) or, with
    --joint, one fit to all curves.
    """
    from torlab.fit.layer import fit_layer_hpt, fit_layers_hpt
    from torlab.outputs import OutputDir

    files = require_files(inputs, "HPT", keep=is_hpt_input)
    extra: list[Path] = []
    comp = _compliance(compliance, extra)
    curves = _prepare_hpt(hpt_items(files, comp), comp)
    results = [fit_layer_hpt(curves)] if joint or len(curves) == 1 else fit_layers_hpt(curves)
    dest = OutputDir(out, force=force, inputs=[*files, *extra], command=command_line())
    with dest:
        names = []
        for i, r in enumerate(results):
            pre = "" if len(results) == 1 else _stem(files[i], names)
            write_fit(dest, r, pre, title=f"HPT layer fit: {r.meta.get('source', '')}",
                      formats=formats)
        if len(results) > 1:
            import pandas as pd

            rows = [{"curve": n, **{k: r.params[k] for k in r.names},
                     **{f"{k}_stderr": r.stderr[k] for k in r.names},
                     "residual_rms_Pa": r.residual_norm, "warnings": "; ".join(r.warnings)}
                    for n, r in zip(names, results, strict=True)]
            dest.write_csv("fit_summary.csv", pd.DataFrame(rows),
                           allow_missing=tuple(f"{k}_stderr" for k in results[0].names))
    for r in results:
        print_fit(r, f"HPT layer fit: {r.meta.get('source', '')}")
    console().print(f"wrote {'params.yaml, fit_table.csv, fit.png ...' if len(results) == 1 else 'one folder per curve and fit_summary.csv'} to {out}")


def _stem(f: Path, names: list[str]) -> str:
    s = f.stem
    while s in names:
        s += "_"
    names.append(s)
    return s


@app.command("traction")
def traction_cmd(
    scene: Annotated[Path, typer.Argument(help="Scene YAML of the test contact (load, radii, "
                                          "materials, speed); its boundary: values are the "
                                          "defaults of fixed parameters.")],
    data: Annotated[Path, typer.Argument(help="Traction curve: CSV with creepage (or srr) and mu "
                                         "(or traction_coefficient), or a torlab-optical log.")],
    out: OutOpt,
    fix: Annotated[list[str] | None, typer.Option(
        "--fix", help="Hold a parameter fixed: 'L_mup=20 um' (repeatable).")] = None,
    dry: Annotated[bool, typer.Option("--dry", help="Dry test: ignore the scene's lubricant: and "
                                      "roughness: (automatic for a dry_traction optical log).")]
    = False,
    force: ForceOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Layer parameters from a measured traction curve mu(SRR), fitted with FASTSIM
    (the model of 'torlab predict traction', thesis Eqs. 5.14-5.30).

    A lubricated scene is fitted with the mixed model (film + asperities + layer); a dry
    test (--dry, or a torlab-optical log of test dry_traction) with the dry model.
    """
    from torlab.fit.traction import fit_layer_traction
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene

    files = require_files([scene, data], "input")
    sc = load_scene(scene)
    xi, mu, test = traction_data(data)
    if (dry or test == "dry_traction") and (sc.lubricant is not None or sc.roughness is not None):
        sc = sc.model_copy(update={"lubricant": None, "roughness": None})
        console().print("dry traction test: the scene's lubricant: and roughness: are ignored "
                        "(Hertz + FASTSIM + layer)")
    fixed = _parse_fixed(fix or [])
    res = fit_layer_traction(sc, xi, mu, fixed=fixed)
    res.meta["source"] = data.name
    import numpy as np

    from torlab.fit.traction import traction_model

    dense = np.linspace(float(np.min(xi)), float(np.max(xi)), 201)
    curve = (dense, traction_model(sc)(res.params, dense))
    dest = OutputDir(out, force=force, inputs=files, command=command_line())
    with dest:
        write_fit(dest, res, title=f"Traction fit: {data.name}", model_curve=curve,
                  formats=formats)
    print_fit(res, f"Traction fit: {data.name}")
    console().print(f"wrote {', '.join(_FILES)} to {out}")


def _parse_fixed(items: list[str]) -> dict[str, float]:
    from torlab.errors import TorlabInputError
    from torlab.fit.traction import layer_values

    pairs = {}
    for it in items:
        if "=" not in it:
            raise TorlabInputError(f"{it!r}: use NAME=VALUE, e.g. 'L_mup=20 um'", key="--fix")
        k, v = (s.strip() for s in it.split("=", 1))
        pairs[k] = v
    return layer_values(pairs, where="--fix")


@app.command("temperature")
def temperature_cmd(
    inputs: Annotated[list[Path], typer.Argument(help="HPT logs (or reduced CSVs) of one product "
                                                 "at three or more temperatures.")],
    out: OutOpt,
    compliance: Annotated[str | None, typer.Option(help="Rig compliance (curve file or "
                                                   "constant).")] = None,
    reference_temperature: Annotated[str, typer.Option(help="Reference temperature of the "
                                                       "intercepts.")] = "25 degC",
    selection: Annotated[str, typer.Option(
        help="'test': a coefficient the likelihood-ratio test against 0 does not resolve (5 %) "
             "is fixed to 0; 'none': every coefficient is kept and its uncertainty carried "
             "into predictions.", case_sensitive=False)] = "test",
    force: ForceOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Temperature coefficients mu_c1_T, mu_c2_T (thesis Eqs. 5.26-5.27) from one layer fit
    per run: ln mu_ci against T; each coefficient kept or fixed to 0 (--selection)."""
    from torlab.errors import TorlabInputError
    from torlab.fit.layer import fit_layers_hpt
    from torlab.fit.temperature import fit_temperature_coefficients
    from torlab.outputs import OutputDir
    from torlab.units import check_range, to_si

    sel = selection.strip().lower()
    if sel not in ("test", "none"):
        raise TorlabInputError(f"--selection must be 'test' or 'none', not {selection!r}",
                               key="--selection")
    files = require_files(inputs, "HPT", keep=is_hpt_input)
    extra: list[Path] = []
    comp = _compliance(compliance, extra)
    Tref = check_range("temperature", to_si(reference_temperature, "temperature",
                                            where="--reference-temperature"),
                       where="--reference-temperature")
    curves = _prepare_hpt(hpt_items(files, comp), comp)
    fits = fit_layers_hpt(curves)
    res = fit_temperature_coefficients(fits, reference_temperature_C=Tref, selection=sel)
    dest = OutputDir(out, force=force, inputs=[*files, *extra], command=command_line())
    with dest:
        write_fit(dest, res, title="Temperature coefficients of the layer", formats=formats)
        names: list[str] = []
        for f, r in zip(files, fits, strict=True):
            write_fit(dest, r, f"runs/{_stem(f, names)}", formats=formats)
    print_fit(res, "Temperature coefficients")
    console().print(f"wrote {', '.join(_FILES)} and runs/ (one layer fit per run) to {out}")


@app.command("film")
def film_cmd(
    data: Annotated[Path, typer.Argument(help="Film-thickness data: PCS EHD2 export, "
                                         "torlab-optical log, or CSV with speed_m_s (or "
                                         "rolling_speed_m_s) and film_thickness_m.")],
    out: OutOpt,
    scene: Annotated[Path | None, typer.Option(help="Scene (contact, materials, lubricant eta0 at "
                                               "the test temperature) for the effective "
                                               "alpha.")] = None,
    min_speed: Annotated[str | None, typer.Option(help="Fit only speeds at or above this, e.g. "
                                                  "'50 mm/s'.")] = None,
    force: ForceOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Speed exponent of the film (Hamrock-Dowson predicts 0.67, Eq. 5.32) and, with a scene,
    the effective pressure-viscosity coefficient alpha. An EHD2 file with several film
    steps gives one fit per step (a sub-folder each)."""
    from torlab.fit.film import fit_film_thickness
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene
    from torlab.units import check_range, to_si

    files = require_files([data] + ([scene] if scene else []), "input")
    vmin = None if min_speed is None else check_range(
        "speed", to_si(min_speed, "velocity", where="--min-speed"), where="--min-speed")
    sc = load_scene(scene) if scene else None
    groups = film_data(data)
    results = []
    for label, v, h in groups:
        r = fit_film_thickness(v, h, scene=sc, min_speed=vmin)
        r.meta["source"] = f"{data.name}{'' if not label else f' {label}'}"
        results.append((label, r))
    dest = OutputDir(out, force=force, inputs=files, command=command_line())
    with dest:
        for label, r in results:
            write_fit(dest, r, label.replace(" °C", "C").replace(" ", "_")
                      if len(results) > 1 else "",
                      title=f"Film thickness: {r.meta['source']}", formats=formats)
    for _label, r in results:
        print_fit(r, f"Film fit: {r.meta['source']}")
    console().print(f"wrote the film fit{'s' if len(results) > 1 else ''} to {out}")


@app.command("visc")
def visc_cmd(
    data: Annotated[list[Path], typer.Argument(help="'torlab visc reduce' output CSVs "
                                               "(*_steps.csv or *_falls.csv: pressure_Pa, "
                                               "viscosity_Pa_s).")],
    out: OutOpt,
    law: Annotated[str, typer.Option(help="barus or roelands.")] = "roelands",
    force: ForceOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Viscosity law (eta0, alpha or Z; thesis Eqs. 5.38-5.39) from reduced viscometer data,
    written as the scene's lubricant: keys."""
    import numpy as np

    from torlab.fit.result import viscosity_result
    from torlab.fit.viscosity import fit_viscosity
    from torlab.instruments.measured import viscosity_data
    from torlab.outputs import OutputDir

    files = require_files(data, "viscosity")
    p, eta, T = [], [], []
    for f in files:
        pf, ef, tf = viscosity_data(f)
        p.append(pf)
        eta.append(ef)
        if tf is not None:
            T.append(tf)
    Tm = float(np.mean(T)) if T else None
    vf = fit_viscosity(np.concatenate(p), np.concatenate(eta), law, temperature_C=Tm)
    res = viscosity_result(vf)
    res.meta["source"] = ", ".join(f.name for f in files)
    dest = OutputDir(out, force=force, inputs=files, command=command_line())
    with dest:
        write_fit(dest, res, title=f"Viscosity fit ({law})", formats=formats)
    print_fit(res, f"Viscosity fit ({law})")
    console().print(f"wrote {', '.join(_FILES)} to {out}")


@app.command("polach")
def polach_cmd(
    scene: Annotated[list[Path], typer.Argument(help="Scene YAML, then parameter files of the "
                                                "product (e.g. 'torlab fit' output), in order.")],
    out: OutOpt,
    creepage: Annotated[str, typer.Option(help="Longitudinal creepages of the fit range "
                                          "(start:stop:count or a list).")] = "0:0.05:41",
    speed: Annotated[str, typer.Option(help="Rolling speeds of the fit range (units allowed).")]
    = "5 m/s,20 m/s",
    lateral: Annotated[str | None, typer.Option(help="Optional lateral creepages added at each "
                                                "creepage and speed.")] = None,
    spin: Annotated[str | None, typer.Option(help="Optional spins (1/m) added likewise.")] = None,
    force: ForceOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Polach's creep-force parameters mu0, A, B, kA, kS (Polach 2005; spin of 1999) fitted
    to torlab's predicted creep forces of a dry scene over a creepage and speed range.

    Writes params.yaml (the parameters in the fit: section), fit_table.csv, correlation.csv,
    fit_data.csv (torlab, Polach and their difference per point: the fit error as a curve),
    fit.png and summary.json (RMS and largest error: the numbers).
    """
    from torlab.fit.polach import fit_polach
    from torlab.grids import parse_values
    from torlab.model.creep import creep_problem
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene

    files = require_files(scene, "scene")
    sc = load_scene(*files)
    res = fit_polach(creep_problem(sc), parse_values(creepage, "dimensionless", "--creepage",
                                                     "creepage"),
                     parse_values(speed, "velocity", "--speed", "speed"),
                     lateral=None if lateral is None else parse_values(lateral, "dimensionless",
                                                                       "--lateral", "creepage"),
                     spin=None if spin is None else parse_values(spin, "inverse_length", "--spin",
                                                                 "spin"),
                     source=sc.name or files[0].stem)
    with OutputDir(out, force=force, inputs=files, command=command_line()) as dest:
        write_fit(dest, res, title=f"Polach fit: {res.meta['source']}", formats=formats)
    print_fit(res, f"Polach fit: {res.meta['source']}")
    console().print(f"largest difference Polach - torlab: {res.meta['max_abs_residual']:.3g} "
                    f"(F/N); wrote {', '.join(_FILES)} to {out}")


@app.command("removal")
def removal_cmd(
    tests: Annotated[list[Path], typer.Argument(help="Time tests after application: PCS exports "
                                                "(their timed step) or *_timed.csv of 'torlab "
                                                "mtm reduce'; folders and patterns expanded.")],
    out: OutOpt,
    hpt: Annotated[list[str], typer.Option(
        "--hpt", help="The product's amount series: HPT logs or 'torlab fit hpt' params.yaml, one "
        "per applied amount, and the dry run (repeatable; folders and patterns expanded).")],
    scene: Annotated[Path | None, typer.Option(help="Scene of the tribometer contact (radii, "
                                               "materials); default the PCS MTM ball on "
                                               "disc.")] = None,
    density: Annotated[str | None, typer.Option(help="Product density for amounts in uL "
                                                "('930 kg/m^3'); default the HPT logs'.")] = None,
    amount: Annotated[str | None, typer.Option(help="Applied amount of every time test ('2 uL') "
                                               "where the files do not state it.")] = None,
    track_radius: Annotated[str | None, typer.Option(help="Disc track radius ('21 mm') where the "
                                                     "files do not state it.")] = None,
    application_time: Annotated[str | None, typer.Option(
        help="Application moment in the step ('60 s'); default: the largest drop.")] = None,
    compliance: Annotated[str | None, typer.Option(help="Rig compliance of the HPT logs (curve "
                                                   "file or '0.012 um/MPa').")] = None,
    repeatability: Annotated[float, typer.Option(help="Relative run-to-run scatter of the HPT "
                                                 "layer parameters (e.g. 0.03).")] = 0.0,
    laws: Annotated[str, typer.Option(help="Candidate laws (comma list of zero_order, "
                                      "first_order, zero_order+spread, first_order+spread).")]
    = "zero_order,first_order",
    law: Annotated[str | None, typer.Option(help="Force this law (still compared).")] = None,
    transfer: Annotated[str, typer.Option(help="Fraction of the applied product reaching the "
                                          "track, or 'fit'.")] = "1",
    skip: Annotated[str, typer.Option(help="Time after the application left out of the fit "
                                      "(the film phase), or 'auto'.")] = "auto",
    force: ForceOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Removal law of a product (k0 or k1, spread, transfer) from MTM time tests after
    application and its HPT amount series; the law chosen by AICc (docs/model/retention.md).

    Writes params.yaml (the retention: section 'torlab predict retention' reads: law,
    covariance, the amount layer), fit_table.csv, correlation.csv, fit_data.csv (measured and
    modelled mu(t), amount, energy), fit.png (measured against modelled mu(t)),
    law_selection.csv, amount_layer.csv/.png and summary.json.
    """
    from torlab.api import fit_removal
    from torlab.fit.amount import is_layer_input
    from torlab.fit.removal import is_time_test_input, retention_from_dict
    from torlab.outputs import OutputDir
    from torlab.reports.retention import layer_figure

    files = require_files(tests, "time-test", keep=is_time_test_input)
    layer_files = require_files([Path(h) for h in hpt], "HPT", keep=is_layer_input)
    extra = [scene] if scene else []
    comp = _compliance(compliance, extra)
    res = fit_removal(files, layer_files, scene=scene, density=density, amount=amount,
                      track_radius=track_radius, application_time=application_time,
                      compliance=comp, repeatability=repeatability,
                      laws=[x.strip() for x in laws.split(",") if x.strip()], law=law,
                      transfer="fit" if transfer.strip() == "fit" else transfer, skip=skip)
    import pandas as pd

    layer = retention_from_dict(res.parameter_file).layer
    dest = OutputDir(out, force=force, inputs=[*files, *layer_files, *extra],
                     command=command_line())
    with dest:
        write_fit(dest, res, title=f"Removal fit: {res.meta['source']}", formats=formats)
        dest.write_csv("law_selection.csv", pd.DataFrame(res.meta["law_selection"]))
        dest.write_csv("amount_layer.csv", layer.table())
        from torlab.reports.render import parse_formats, plot, write_figures

        write_figures(dest, [("amount_layer", plot(layer_figure, layer))],
                      parse_formats(formats))
    print_fit(res, f"Removal fit ({res.meta['law']}): {res.meta['source']}")
    print_table([{k: r[k] for k in ("law", "parameters", "aicc", "delta_aicc", "weight")}
                 for r in res.meta["law_selection"]], title="Law choice (AICc)",
                formats={"aicc": ".1f", "delta_aicc": ".1f", "weight": ".3f"})
    for n in res.meta.get("notes", []):
        console().print(f"[yellow]note:[/yellow] {n}")
    console().print(f"wrote {', '.join(_FILES)}, law_selection.csv, amount_layer.csv/.png to "
                    f"{out}")
