"""``torlab fit``: identify the model's parameters from reduced measurements.

Each command writes ``params.yaml`` (the scene contract's ``boundary:`` /
``lubricant:`` keys plus a ``fit:`` provenance section, so
``torlab predict traction SCENE params.yaml`` reads it unchanged),
``fit_table.csv`` (value, standard error, 95 % interval per parameter),
``correlation.csv``, ``fit_data.csv`` (data, model, residuals), ``fit.png``
(data against model and residuals) and ``summary.json``; with ``--xlsx`` every
table in ``tables.xlsx`` too.  Data arguments take files, folders and patterns
(``'runs/*.csv'``, expanded by torlab: a folder contributes the files the fit can
read); several curves give one fit each, in a sub-folder per curve with
``fit_summary.csv`` over them, or with ``--joint`` one parameter set: their fits pooled
with random effects (:mod:`torlab.fit.repeats`).  A fit
that fails writes nothing.
"""

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from torlab.cli._common import (
    ForceOpt,
    FormatsOpt,
    HoldAboveOpt,
    JobsOpt,
    MethodOpt,
    OutOpt,
    QuietOpt,
    SchedulerOpt,
    XlsxOpt,
    command_line,
    console,
    hold_above_hint,
    option_keys,
    print_table,
    require_files,
)
from torlab.instruments.measured import (
    film_data,
    is_hpt_input,
    loads,
    traction_data,
    viscosity_data,
)

if TYPE_CHECKING:
    from torlab.scene import Scene

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
              model_curve: tuple[Any, Any] | None = None, formats: Any = None
              ) -> dict[str, Any]:
    """Write one :class:`~torlab.fit.result.FitResult` into an OutputDir (under ``prefix``);
    its figure (the result's own :meth:`plot`) in ``formats`` (``--formats``; PNG by
    default).  Returns its tables by sheet name (for ``--xlsx``)."""
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
    if result.kind == "layer_hpt" and result.meta.get("law_selection"):
        sel = law_selection_table(result)
        dest.write_csv(f"{pre}law_selection.csv", sel,
                       allow_missing=("rss_Pa2", "aicc", "delta_aicc", "note"))
    write_figures(dest, [(f"{pre}fit", plot(result_figure, result, title=title,
                                            model_curve=model_curve))], parse_formats(formats))
    sheet = f"{prefix.replace('/', '_')}_" if prefix else ""
    return {f"{sheet}fit_table": tab, f"{sheet}correlation": corr,
            f"{sheet}fit_data": result.data}


def write_fits(dest: Any, fits: list[tuple[str, Any]], title: str, *, xlsx: bool = False,
               formats: Any = None, curves: dict[str, Any] | None = None,
               sheets: dict[str, Any] | None = None) -> str:
    """Write one fit into the folder, or several (``(name, result)``) each into a sub-folder
    ``<name>/`` with ``fit_summary.csv`` (one row per fit: parameters, standard errors,
    residual RMS, warnings); with ``xlsx`` every table (and ``sheets``, a command's own
    tables) in ``tables.xlsx``.  ``title`` is the figures' title before the source;
    ``curves`` the dense model curve by name.  Returns what was written, in words."""
    import pandas as pd

    curves = curves or {}
    sheets = dict(sheets or {})
    several = len(fits) > 1
    for name, r in fits:
        src = r.meta.get("source", "")
        sheets.update(write_fit(dest, r, name if several else "",
                                title=f"{title}: {src}" if src else title,
                                model_curve=curves.get(name), formats=formats))
    what = "params.yaml, fit_table.csv, fit.png ..."
    if several:
        unit = fits[0][1].residual_unit
        rms = "residual_rms" + (f"_{unit}" if unit not in ("-", "") else "")
        tab = pd.DataFrame([{"curve": n, **{k: r.params[k] for k in r.names},
                             **{f"{k}_stderr": r.stderr[k] for k in r.names},
                             rms: r.residual_norm, "warnings": "; ".join(r.warnings)}
                            for n, r in fits])
        dest.write_csv("fit_summary.csv", tab, allow_missing=tuple(
            c for c in tab.columns if c != "curve"))
        sheets["fit_summary"] = tab
        what = f"one folder per curve ({len(fits)}) and fit_summary.csv"
    if xlsx:
        dest.write_xlsx("tables.xlsx", sheets)
        what += ", tables.xlsx"
    return what


def law_selection_table(result: Any) -> Any:
    """The layer laws a fit compared (``meta["law_selection"]``): one row per law."""
    import pandas as pd

    return pd.DataFrame([{"law": r["law"], "parameters": r["parameters"], "rss_Pa2": r["rss"],
                          "aicc": r["aicc"], "delta_aicc": r["delta_aicc"],
                          "weight": r["weight"], "chosen": r["law"] == result.meta["law"],
                          "note": r.get("note") or None}
                         for r in result.meta["law_selection"]])


def print_fit(result: Any, title: str) -> None:
    """Rich summary: parameters, intervals, residual norm and warnings."""
    from torlab.fit.result import PARAM_UNITS

    rows = []
    for _, r in result.table().iterrows():
        unit = PARAM_UNITS.get(r["parameter"], "")
        f = 1e6 if unit == "m" and abs(r["value"]) < 1e-2 else 1e9 if unit == "1/Pa" else 1.0
        u = {1e6: "µm", 1e9: "1/GPa"}.get(f, unit)
        hi = "unbounded" if r["ci95_high"] != r["ci95_high"] else f"{r['ci95_high'] * f:.5g}"
        rows.append({"parameter": r["parameter"], "value": f"{r['value'] * f:.5g}",
                     "± se": "—" if r["stderr"] != r["stderr"] else f"{r['stderr'] * f:.2g}",
                     "95 % interval": "—" if r["ci95_low"] != r["ci95_low"] else
                     f"[{r['ci95_low'] * f:.5g}, {hi}]",
                     "unit": u, "status": r["status"]})
    print_table(rows, title=title)
    c = console()
    c.print(f"{result.n_points} points, residual RMS {result.residual_norm:.4g} "
            f"{result.residual_unit}, {result.n_evaluations} model evaluations")
    if result.meta.get("scatter"):
        c.print(str(result.meta["scatter"]))
    for w in result.warnings:
        c.print(f"[yellow]warning:[/yellow] {w}")


#: the largest spread of the files' mean temperatures 'fit visc' pools into one law (K)
VISC_TEMPERATURE_SPREAD_K = 2.0

_FILES = ["params.yaml", "fit_table.csv", "correlation.csv", "fit_data.csv", "fit.png",
          "summary.json"]


def _compliance(value: str | None, inputs: list[Path]) -> Any:
    from torlab.reduce.hpt import RigCompliance

    comp = RigCompliance.from_spec(value, where="--compliance")
    if comp is not None and comp.path is not None:
        inputs.append(comp.path)
    return comp


# ------------------------------------------------------------------------------------------
# commands
# ------------------------------------------------------------------------------------------
@app.command("hpt")
def hpt_cmd(
    inputs: Annotated[list[Path], typer.Argument(help="Raw HPT logs (torlab-hpt) or reduced CSVs "
                                                 "('torlab hpt reduce' output); folders and "
                                                 "patterns such as 'logs/*.txt' expanded.")],
    out: OutOpt,
    joint: Annotated[bool, typer.Option("--joint", help="One parameter set for all curves "
                                        "(repeats of one product and amount): each fitted, "
                                        "pooled with the scatter between runs.")] = False,
    compliance: Annotated[str | None, typer.Option(
        help="Rig compliance (curve file or constant such as '0.012 um/MPa'); default: the one "
        "the reduction subtracted.")] = None,
    law: Annotated[str, typer.Option(
        "--law", help="Layer law: voce (the thesis's, default), linear (CONTACT's linear "
        "hardening/softening), perfect (elastic-perfectly plastic), or auto: each fitted and "
        "the smallest AICc kept (law_selection.csv); a comma-separated list compares those "
        "(docs/model/layers.md).")] = "voce",
    resolution: Annotated[str | None, typer.Option(
        "--resolution", help="With several laws: the shear stress resolution of the data "
        "(e.g. '2.9 MPa' for a digitised curve); residuals below it count as none in the "
        "AICc. Default: round-off.")] = None,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Layer parameters from HPT curves: Voce's mu_c1, mu_c2, L_mue, L_mup (thesis
    Eqs. 5.24-5.29) or another layer law's (--law).

    One fit per curve (a sub-folder per curve and fit_summary.csv when there are several)
    or, with --joint, one parameter set: the curves' fits pooled with random effects (REML
    between-run variance, Hartung-Knapp intervals on runs - 1 degrees of freedom), whose
    intervals hold the scatter from run to run; summary.json's random_effects gives each
    parameter's share of its variance within and between runs.
    With --law auto (or a list) every law is fitted and the one with the smallest AICc
    kept; the console and law_selection.csv give the comparison.
    """
    from torlab.fit.layer import check_resolution, fit_layer_hpt, fit_layers_hpt, law_choice
    from torlab.instruments.measured import hpt_curves
    from torlab.outputs import OutputDir
    from torlab.units import check_range, to_si

    files = require_files(inputs, "HPT", keep=is_hpt_input)
    extra: list[Path] = []
    comp = _compliance(compliance, extra)
    # an unknown law, or a resolution no law comparison uses: one error line before anything
    # is read
    laws = law_choice(law, key="--law")
    res_pa = None if resolution is None else check_range(
        "stress", to_si(resolution, "pressure", where="--resolution"), where="--resolution")
    check_resolution(laws, res_pa, key="--resolution")
    curves = hpt_curves(files, compliance=comp)
    results = [fit_layer_hpt(curves, law=law, resolution=res_pa)] if joint or len(curves) == 1 \
        else fit_layers_hpt(curves, law=law, resolution=res_pa)
    names: list[str] = []
    fits = [(_stem(f, names), r) for f, r in zip(files, results, strict=False)]
    dest = OutputDir(out, force=force, inputs=[*files, *extra], command=command_line())
    with dest:
        what = write_fits(dest, fits, "HPT layer fit", xlsx=xlsx, formats=formats)
    for r in results:
        chosen = f" ({r.meta['law']} law)" if r.meta.get("law") else ""
        print_fit(r, f"HPT layer fit{chosen}: {r.meta.get('source', '')}")
        if r.meta.get("law_selection"):
            print_table(law_selection_table(r).drop(columns=["note"]).to_dict("records"),
                        title=f"Law choice (AICc; {r.meta.get('criterion', '')})",
                        formats={"rss_Pa2": ".4g", "aicc": ".1f", "delta_aicc": ".1f",
                                 "weight": ".3f"})
    console().print(f"wrote {what} to {out}")


def _stem(f: Path | str, names: list[str]) -> str:
    """A sub-folder name for ``f`` (its stem, or a label) not yet in ``names``."""
    s = Path(f).stem if isinstance(f, Path) else f
    while s in names:
        s += "_"
    names.append(s)
    return s


@app.command("traction")
def traction_cmd(
    scene: Annotated[Path, typer.Argument(help="Scene YAML of the test contact (load, radii, "
                                          "materials, speed); its boundary: values are the "
                                          "defaults of fixed parameters.")],
    data: Annotated[list[Path], typer.Argument(
        help="Traction curves: CSVs with creepage (or srr) and mu (or traction_coefficient), "
        "PCS exports or torlab-optical logs; folders and patterns such as 'runs/*.csv' "
        "expanded.")],
    out: OutOpt,
    joint: Annotated[bool, typer.Option("--joint", help="One parameter set for all curves "
                                        "(repeats of one test in this scene): each fitted, "
                                        "pooled with the scatter between them.")] = False,
    fix: Annotated[list[str] | None, typer.Option(
        "--fix", help="Hold a parameter fixed: 'L_mup=20 um' (repeatable).")] = None,
    dry: Annotated[bool, typer.Option("--dry", help="Dry test: ignore the scene's lubricant: and "
                                      "roughness: (automatic for a dry_traction optical log).")]
    = False,
    method: MethodOpt = None,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Layer parameters from measured traction curves mu(SRR), fitted with the model of
    'torlab predict traction' (thesis Eqs. 5.14-5.30) by the boundary method (--method):
    FASTSIM corrected by Kalker's exact theory (default), the thesis's FASTSIM, the exact
    theory, or auto (the exact theory where the fast one's theory error exceeds the fitted
    curve's band); params.yaml's fit: section names it (boundary_method) and the fit's
    theory error (theory_error_95; fit_data.csv's mu_theory_error_95).

    A lubricated scene is fitted with the mixed model (film + asperities + layer); a dry
    test (--dry, or a torlab-optical log of test dry_traction) with the dry model.  Every
    curve is one test in the scene: several files give one fit each (a sub-folder per file
    and fit_summary.csv), or with --joint one parameter set: the curves' fits pooled with
    random effects (the intervals hold the scatter between the repeats).
    """
    from torlab.model.predict import with_method
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene

    (scene,) = require_files([scene], "scene")
    with option_keys(traction_cmd):
        sc = with_method(load_scene(scene), method)
    keep, loaded = loads(traction_data)
    files = require_files(data, "traction-curve", keep=keep)
    curves = [(f, *(loaded[f] if f in loaded else traction_data(f))) for f in files]
    fits, model_curves = _traction_fits(sc, curves, joint=joint, dry=dry,
                                        fixed=_parse_fixed(fix or []))
    dest = OutputDir(out, force=force, inputs=[scene, *files], command=command_line())
    with dest:
        what = write_fits(dest, fits, "Traction fit", xlsx=xlsx, formats=formats,
                          curves=model_curves)
    for _, r in fits:
        print_fit(r, f"Traction fit: {r.meta['source']}")
    console().print(f"wrote {what} to {out}")


def _traction_fits(sc: "Scene", curves: list[tuple[Path, Any, Any, str, Any]], *, joint: bool,
                   dry: bool, fixed: dict[str, float]
                   ) -> tuple[list[tuple[str, Any]], dict[str, Any]]:
    """One traction fit per curve ``(file, creepage, mu, test, speed)``
    (:func:`torlab.fit.traction.fit_traction_test`: a dry test in the scene without its
    lubricant and roughness, the points of a log at several speeds each at its own
    speed), pooled with their scatter (``joint``); each with its dense model curve (one
    speed)."""
    import numpy as np

    from torlab.errors import TorlabInputError
    from torlab.fit.traction import fit_traction_test, tested_contact, traction_model

    is_dry = [dry or c[3] == "dry_traction" for c in curves]
    if joint and len(set(is_dry)) > 1:
        wet = [c[0].name for c, d in zip(curves, is_dry, strict=True) if not d]
        raise TorlabInputError(f"--joint pools repeats of one test, but {', '.join(wet)} "
                               "is lubricated and the others dry traction tests: fit them "
                               "apart (or give --dry)", key="--joint")
    lubricated = sc.lubricant is not None or sc.roughness is not None
    if lubricated and any(is_dry):
        console().print("dry traction test: the scene's lubricant: and roughness: are ignored "
                        "(Hertz + FASTSIM + layer)")
    names: list[str] = []
    fits, model_curves = [], {}
    for f, *data in curves:
        res = fit_traction_test(sc, data, dry=dry, fixed=fixed)
        res.meta["source"] = f.name
        name = _stem(f, names)
        if len(res.meta.get("speeds_m_s", [])) <= 1:  # one speed: the model as a dense curve
            xi = np.asarray(data[0], dtype=float)
            exact = res.meta.get("boundary_method") == "exact"
            dense = np.linspace(float(np.min(xi)), float(np.max(xi)), 41 if exact else 201)
            scm = tested_contact(sc, data[2], dry=dry)
            if exact:
                scm = scm.model_copy(update={"grid": scm.grid.model_copy(
                    update={"method": "exact"})})
            model_curves[name] = (dense, traction_model(scm)(res.params, dense))
        fits.append((name, res))
    if joint and len(fits) > 1:  # repeats: each curve's fit, pooled with their scatter
        return _pooled(fits), {}
    return fits, model_curves


def _pooled(fits: list[tuple[str, Any]]) -> list[tuple[str, Any]]:
    """Repeated curves' fits as one: pooled with random effects (torlab.fit.repeats)."""
    from torlab.fit.repeats import pool_fits

    return [(fits[0][0], pool_fits([r for _, r in fits]))]


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
                                                 "at three or more temperatures; folders and "
                                                 "patterns expanded.")],
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
    xlsx: XlsxOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Temperature coefficients mu_c1_T, mu_c2_T (thesis Eqs. 5.26-5.27) from one layer fit
    per run: ln mu_ci against T; each coefficient kept or fixed to 0 (--selection).  The
    runs together give one fit; each run's layer fit is in runs/<name>/."""
    from torlab.fit.layer import fit_layers_hpt
    from torlab.fit.temperature import fit_temperature_coefficients
    from torlab.instruments.measured import hpt_curves
    from torlab.outputs import OutputDir
    from torlab.units import check_range, to_si

    sel = _choice(selection, ("test", "none"), "--selection")
    files = require_files(inputs, "HPT", keep=is_hpt_input)
    extra: list[Path] = []
    comp = _compliance(compliance, extra)
    Tref = check_range("temperature", to_si(reference_temperature, "temperature",
                                            where="--reference-temperature"),
                       where="--reference-temperature")
    curves = hpt_curves(files, compliance=comp)
    fits = fit_layers_hpt(curves)
    res = fit_temperature_coefficients(fits, reference_temperature_C=Tref, selection=sel)
    dest = OutputDir(out, force=force, inputs=[*files, *extra], command=command_line())
    with dest:
        sheets: dict[str, Any] = {}
        names: list[str] = []
        for f, r in zip(files, fits, strict=True):
            sheets.update(write_fit(dest, r, f"runs/{_stem(f, names)}", formats=formats))
        write_fits(dest, [("", res)], "Temperature coefficients of the layer", xlsx=xlsx,
                   formats=formats, sheets=sheets)
    print_fit(res, "Temperature coefficients")
    console().print(f"wrote {', '.join(_FILES)} and runs/ (one layer fit per run) to {out}")


def _choice(value: str, choices: tuple[str, ...], key: str) -> str:
    """``value`` (case-insensitive) if it is one of ``choices``; else one line naming them
    (with "did you mean")."""
    from torlab._suggest import did_you_mean
    from torlab.errors import TorlabInputError

    v = value.strip().lower()
    if v not in choices:
        raise TorlabInputError(f"{value!r} is not one of {', '.join(choices)}"
                               f"{did_you_mean(v, choices)}", key=key)
    return v


@app.command("film")
def film_cmd(
    data: Annotated[list[Path], typer.Argument(
        help="Film-thickness data: PCS EHD2 exports, torlab-optical logs, or CSVs with "
        "speed_m_s (or rolling_speed_m_s) and film_thickness_m; folders and patterns such as "
        "'ehd2/*.txt' expanded.")],
    out: OutOpt,
    scene: Annotated[Path | None, typer.Option(help="Scene (contact, materials, lubricant eta0 at "
                                               "the test temperature) for the effective "
                                               "alpha.")] = None,
    min_speed: Annotated[str | None, typer.Option(help="Fit only speeds at or above this, e.g. "
                                                  "'50 mm/s'.")] = None,
    joint: Annotated[bool, typer.Option("--joint", help="One parameter set for all curves "
                                        "(repeats at one temperature): each fitted, pooled "
                                        "with the scatter between them.")] = False,
    reference_speed: Annotated[str | None, typer.Option(
        help="Speed at which curves at different temperatures are compared (default: the "
        "geometric centre of the speed range they share), e.g. '300 mm/s'.")] = None,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Speed exponent of the film (Hamrock-Dowson predicts 0.67, Eq. 5.32) and, with a scene,
    the effective pressure-viscosity coefficient alpha.  Every film curve gets its own fit
    (a sub-folder each, named by file and, for EHD2 film steps, by temperature, and
    fit_summary.csv); --joint pools the curves' fits with random effects (the intervals hold
    the scatter between them).  Curves at two or more temperatures also give the film's
    temperature scaling at one speed (temperature/: d ln h/dT, the speed exponents
    compared)."""
    from torlab.fit.film import fit_film_thickness
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene
    from torlab.units import check_range, to_si

    keep, loaded = loads(film_data)
    files = require_files(data, "film-thickness", keep=keep)
    scenes = require_files([scene], "scene") if scene else []
    vmin = None if min_speed is None else check_range(
        "speed", to_si(min_speed, "velocity", where="--min-speed"), where="--min-speed")
    sc = load_scene(scenes[0]) if scenes else None
    vref = None if reference_speed is None else check_range(
        "speed", to_si(reference_speed, "velocity", where="--reference-speed"),
        where="--reference-speed")
    groups = [(f, label, v, h, temp) for f in files
              for label, v, h, temp in (loaded[f] if f in loaded else film_data(f))]
    names: list[str] = []
    fits = []
    temps = []
    for f, label, v, h, temp in groups:
        r = fit_film_thickness(v, h, scene=sc, min_speed=vmin)
        r.meta["source"] = f"{f.name}{'' if not label else f' {label}'}"
        if temp is not None:
            r.meta["temperature_C"] = float(temp)
        tag = label.replace(" °C", "C").replace(" ", "_")
        fits.append((_stem(tag if len(files) == 1 and tag else
                           f"{f.stem}_{tag}" if tag else f.stem, names), r))
        temps.append(temp)
    if joint:  # repeats: each curve's fit, pooled with the scatter between them
        fits, temps = _pooled(fits), [None]
    scaling, why_not = _film_scaling(fits, temps, vref)
    dest = OutputDir(out, force=force, inputs=[*files, *scenes], command=command_line())
    with dest:
        sheets = {}
        if scaling is not None:
            sheets = write_fit(dest, scaling, "temperature", formats=formats,
                               title="Film thickness at one rolling speed against temperature: "
                                     f"{files[0].name if len(files) == 1 else f'{len(files)} files'}")
        what = write_fits(dest, fits, "Film thickness", xlsx=xlsx, formats=formats,
                          sheets=sheets)
        if scaling is not None:
            what = what.replace(", tables.xlsx", "") + ", temperature/ (the temperature " \
                "scaling)" + (", tables.xlsx" if xlsx else "")
    for _, r in fits:
        print_fit(r, f"Film fit: {r.meta['source']}")
    if scaling is not None:
        _print_film_scaling(scaling)
    elif why_not:
        console().print(f"[yellow]note:[/yellow] {why_not}")
    console().print(f"wrote {what} to {out}")


def _film_scaling(fits: list[tuple[str, Any]], temps: list[float | None],
                  vref: float | None) -> tuple[Any, str]:
    """The temperature scaling of film curves at two or more temperatures (None and why
    not otherwise: one curve, a curve without a temperature, temperatures within 2 K)."""
    from torlab.fit.film import fit_film_temperature

    if len(fits) < 2:
        return None, ""
    if any(t is None for t in temps):
        return None, "no temperature scaling: not every film curve states its temperature"
    if min(abs(a - b) for i, a in enumerate(temps) for b in temps[i + 1:]) < 2.0:
        return None, ("no temperature scaling: two curves are within 2 K of each other "
                      "(repeats at one temperature: fit them with --joint)")
    r = fit_film_temperature([f for _, f in fits], temps, reference_speed=vref)
    r.meta["source"] = ", ".join(f.meta.get("source", n) for n, f in fits)
    return r, ""


def _print_film_scaling(r: Any) -> None:
    """The temperature scaling's parameters and the speed exponents compared."""
    m = r.meta
    print_fit(r, f"Film temperature scaling at {m['reference_speed_m_s']:.3g} m/s")
    e = m["speed_exponents"]
    c = console()
    c.print(f"speed exponents {', '.join(f'{v:.3f}' for v in e['values'])}: one common "
            f"exponent {'rejected' if e['p_one_exponent'] < 0.05 else 'not rejected'} "
            f"(Welch's F {e['welch_f']:.3g} on {e['dof'][0]} and {e['dof'][1]:.3g} dof, p = "
            f"{e['p_one_exponent']:.2g}); Hamrock-Dowson's 0.67 outside the 95 % interval at "
            f"{', '.join(e['hamrock_dowson_outside_interval_at']) or 'no temperature'}")
    ratio = ", ".join(f"{t} degC {v:.3g}" for t, v in m["viscosity_ratio_if_alpha_constant"]
                      .items())
    c.print(f"resolvable: {m['resolvable']}; eta0(T)/eta0(T_ref) if alpha is constant: {ratio}")


@app.command("visc")
def visc_cmd(
    data: Annotated[list[Path], typer.Argument(help="'torlab visc reduce' output CSVs "
                                               "(*_steps.csv or *_falls.csv: pressure_Pa, "
                                               "viscosity_Pa_s); folders and patterns "
                                               "expanded.")],
    out: OutOpt,
    law: Annotated[str, typer.Option(help="barus or roelands.")] = "roelands",
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Viscosity law (eta0, alpha or Z; thesis Eqs. 5.38-5.39) from reduced viscometer data,
    written as the scene's lubricant: keys.  Every file's points together give one fit (the
    law of one lubricant at one temperature: files more than 2 K apart are refused).  A
    folder contributes its *_falls.csv (a log's *_steps.csv are the same falls averaged per
    pressure step, taken only where the falls are not there)."""
    import numpy as np

    from torlab.fit.result import viscosity_result
    from torlab.fit.viscosity import fit_viscosity
    from torlab.outputs import OutputDir

    law = _choice(law, ("barus", "roelands"), "--law")
    reads, loaded = loads(viscosity_data)
    files = require_files(data, "reduced viscometer", keep=lambda f: reads(f) and not (
        f.name.endswith("_steps.csv") and f.with_name(f.name[:-10] + "_falls.csv").is_file()))
    p, eta, T = zip(*(loaded[f] if f in loaded else viscosity_data(f) for f in files),
                    strict=True)
    Ts = [t for t in T if t is not None]
    Tm = float(np.mean(np.concatenate(Ts))) if Ts else None
    means = [float(np.mean(t)) for t in Ts]
    if means and max(means) - min(means) > VISC_TEMPERATURE_SPREAD_K:
        from torlab.errors import TorlabInputError

        raise TorlabInputError(
            f"the files are at {', '.join(f'{t:.1f}' for t in means)} degC: a viscosity law "
            "holds at one temperature; fit each temperature apart")
    vf = fit_viscosity(np.concatenate(p), np.concatenate(eta), law, temperature_C=Tm)
    res = viscosity_result(vf)
    res.meta["source"] = ", ".join(f.name for f in files)
    dest = OutputDir(out, force=force, inputs=files, command=command_line())
    with dest:
        write_fits(dest, [("", res)], f"Viscosity fit ({law})", xlsx=xlsx, formats=formats)
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
    draws: Annotated[int, typer.Option(min=0, help="Draws of the layer from its fit's "
                                       "covariance, Polach refitted to each (0: off).")] = 200,
    method: MethodOpt = None,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    formats: FormatsOpt = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Polach's creep-force parameters mu0, A, B, kA, kS (Polach 2005; spin of 1999) fitted
    to torlab's predicted creep forces of a dry scene over a creepage and speed range.

    Writes params.yaml (the parameters in the fit: section), fit_table.csv, correlation.csv,
    fit_data.csv (torlab, Polach and their difference per point: the fit error as a curve),
    fit.png and summary.json (RMS and largest error: the numbers).  When the product's
    parameter file carries its fit's covariance, the layer is drawn from it (--draws) and
    Polach refitted per draw: layer_intervals.csv and summary.json's layer_uncertainty give
    each parameter's 95 % interval from the layer, the dominant layer parameters and the
    correlations (fit_table.csv's intervals are the approximation's).  torlab's forces
    come from the boundary method (--method; exact: Kalker's exact theory, isothermal);
    summary.json names it (boundary_method) and their theory error (theory_error_95;
    fit_data.csv's mu_theory_error_95).
    """
    from torlab.cli._common import session
    from torlab.fit.polach import fit_polach_scene, layer_interval_table
    from torlab.grids import parse_values
    from torlab.model.predict import with_method
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene

    files = require_files(scene, "scene")
    with option_keys(polach_cmd):
        sc = with_method(load_scene(*files), method)
    xi = parse_values(creepage, "dimensionless", "--creepage", "creepage")
    v = parse_values(speed, "velocity", "--speed", "speed")
    eta = None if lateral is None else parse_values(lateral, "dimensionless", "--lateral",
                                                    "creepage")
    phi = None if spin is None else parse_values(spin, "inverse_length", "--spin", "spin")
    dest = OutputDir(out, force=force, inputs=files, command=command_line())
    with dest, session(jobs, scheduler, quiet):  # the folder is checked before the draws
        res = fit_polach_scene(sc, xi, v, lateral=eta, spin=phi, draws=draws,
                               source=sc.name or files[0].stem)
        lay = layer_interval_table(res)
        write_fits(dest, [("", res)], "Polach fit", xlsx=xlsx, formats=formats,
                   sheets={"layer_intervals": lay})
        dest.write_csv("layer_intervals.csv", lay, allow_missing=tuple(
            c for c in lay.columns if c not in ("parameter", "value")))
    print_fit(res, f"Polach fit: {res.meta['source']}")
    lu = res.meta["layer_uncertainty"]
    if lu["carried"]:
        print_table([{"parameter": r.parameter, "value": f"{r.value:.5g}",
                      "95 % interval from the layer": f"[{r.layer_low95:.5g}, "
                                                      f"{r.layer_high95:.5g}]",
                      "dominant": r.dominant or "—"} for r in lay.itertuples()],
                    title=f"Layer uncertainty ({lu['method']}, {lu['n_draws']} draws, "
                          f"{lu['n_failed']} failed)")
    te = res.meta.get("theory_error_95")
    console().print(f"torlab's forces by [bold]{res.meta.get('boundary_method')}[/bold]"
                    + (f" (auto: {res.meta['boundary_method_auto']})"
                       if res.meta.get("boundary_method_auto") else "")
                    + (f"; their theory error (95 %, against Kalker's exact theory): up to "
                       f"{te:.2g} in mu" if te is not None else ""))
    console().print(f"largest difference Polach - torlab: {res.meta['max_abs_residual']:.3g} "
                    f"(F/N); wrote {', '.join(_FILES)}, layer_intervals.csv to {out}")


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
    hold_above: HoldAboveOpt = False,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
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
    from torlab.instruments.measured import is_layer_input, is_time_test_input
    from torlab.outputs import OutputDir

    files = require_files(tests, "time-test", keep=is_time_test_input)
    _no_hpt_logs_among_time_tests(files, hpt)
    layer_files = require_files([Path(h) for h in hpt], "HPT", keep=is_layer_input)
    extra = [scene] if scene else []
    comp = _compliance(compliance, extra)
    with hold_above_hint(), option_keys(removal_cmd):
        res = fit_removal(files, layer_files, scene=scene, density=density, amount=amount,
                          track_radius=track_radius, application_time=application_time,
                          compliance=comp, repeatability=repeatability,
                          laws=[x.strip() for x in laws.split(",") if x.strip()], law=law,
                          transfer=transfer.strip(), skip=skip.strip(),
                          above="hold" if hold_above else "error")
    dest = OutputDir(out, force=force, inputs=[*files, *layer_files, *extra],
                     command=command_line())
    with dest:
        _write_removal(dest, res, xlsx=xlsx, formats=formats)
    _print_removal(res)
    console().print(f"wrote {', '.join(_FILES)}, law_selection.csv, amount_layer.csv/.png"
                    f"{', tables.xlsx' if xlsx else ''} to {out}")


def _print_removal(res: Any) -> None:
    """The removal fit, its law choice, each test's measured retention figures, the notes."""
    from torlab.reports.retention import metrics_text

    print_fit(res, f"Removal fit ({res.meta['law']}): {res.meta['source']}")
    print_table([{k: r[k] for k in ("law", "parameters", "aicc", "delta_aicc", "weight")}
                 for r in res.meta["law_selection"]], title="Law choice (AICc)",
                formats={"aicc": ".1f", "delta_aicc": ".1f", "weight": ".3f"})
    for t in res.meta.get("tests", []):
        if t.get("retention_metrics"):
            console().print(f"{t['label']} (measured): {metrics_text(t['retention_metrics'])}")
    for n in res.meta.get("notes", []):
        console().print(f"[yellow]note:[/yellow] {n}")


def _no_hpt_logs_among_time_tests(files: list[Path], hpt: list[str]) -> None:
    """Refuse HPT logs among the time tests: the shell expands an unquoted ``--hpt
    hpt/*.txt`` into ``--hpt hpt/a.txt hpt/b.txt ...``, which gives ``--hpt`` only the first
    file and the time tests the others."""
    from torlab.errors import TorlabInputError
    from torlab.instruments.measured import detected

    logs = []
    for f in files:
        try:
            if detected(f) == "hpt":
                logs.append(f)
        except TorlabInputError:
            continue
    if logs:
        more = f" and {len(logs) - 1} more" if len(logs) > 1 else ""
        first = f" after --hpt {hpt[0]}" if len(hpt) == 1 else ""
        raise TorlabInputError(
            f"{logs[0]}{more}: an HPT log among the time tests; an unquoted pattern{first} gives "
            "--hpt only its first file and the time tests the others: quote the pattern "
            "(--hpt 'hpt/*.txt') or repeat --hpt before each file", key="--hpt")


def _write_removal(dest: Any, res: Any, *, xlsx: bool, formats: Any) -> None:
    """The removal fit's files, its law selection and its amount layer (table, figure)."""
    import pandas as pd

    from torlab.fit.retention_params import retention_from_dict
    from torlab.reports.render import parse_formats, plot, write_figures
    from torlab.reports.retention import layer_figure

    layer = retention_from_dict(res.parameter_file).layer
    own = {"law_selection": pd.DataFrame(res.meta["law_selection"]),
           "amount_layer": layer.table()}
    for name, tab in own.items():
        dest.write_csv(f"{name}.csv", tab)
    write_fits(dest, [("", res)], "Removal fit", xlsx=xlsx, formats=formats, sheets=own)
    write_figures(dest, [("amount_layer", plot(layer_figure, layer))], parse_formats(formats))
