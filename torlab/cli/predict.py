"""``torlab predict``: traction and Stribeck curves of a scene."""

from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import typer

from torlab.cli._common import (
    ForceOpt,
    FormatsOpt,
    HoldAboveOpt,
    JobsOpt,
    MethodOpt,
    NoPlotOpt,
    OutOpt,
    QuietOpt,
    SchedulerOpt,
    command_line,
    console,
    hold_above_hint,
    option_keys,
    print_theory_error,
    require_files,
)

app = typer.Typer(help="Predict traction and Stribeck curves of a scene (Hertz + FASTSIM with "
                  "the third-body layer, contact temperature, EHL film, asperity load sharing).",
                  no_args_is_help=True)

ScenesArg = Annotated[list[Path], typer.Argument(
    help="Scene YAML, then optional parameter files (e.g. 'torlab fit' output) that override "
    "its keys, in order.")]


def _written(names: list[str]) -> str:
    return ", ".join(names)


def _param_keys(path: Path) -> set[tuple[str, str]]:
    """The scene keys a parameter file sets (``(section, key)``; its ``fit:`` provenance
    aside)."""
    from torlab.yamlio import load_yaml

    d = load_yaml(path).data
    out: set[tuple[str, str]] = set()
    for sec, v in (d.items() if isinstance(d, dict) else []):
        if sec == "fit":
            continue
        if isinstance(v, dict):
            out |= {(str(sec), str(k)) for k in v}
        else:
            out.add((str(sec), ""))
    return out


def _curve_label(path: Path, taken: list[str]) -> str:
    """A curve's label: the product of the fit behind its file, else its folder or stem."""
    from torlab.yamlio import load_yaml

    d = load_yaml(path).data
    fit = d.get("fit") if isinstance(d, dict) else None
    lab = ""
    if isinstance(fit, dict) and fit.get("product"):
        lab = str(fit["product"]) + (f"-{fit['condition']}" if fit.get("condition") else "")
    if not lab or lab in taken:
        lab = path.parent.name if path.stem == "params" and path.parent.name else path.stem
    while lab in taken:
        lab += "'"
    taken.append(lab)
    return lab


def split_curves(args: list[Path]) -> tuple[list[Path], list[tuple[str, list[Path]]]]:
    """The scene and parameter files of a prediction, and its curves.

    ``LABEL=FILE`` arguments are curves (files under one label together make one curve);
    unlabelled parameter files that set the same scene keys as another file (two layers,
    two removal laws) are alternatives, one curve each; the others (a temperature fit
    beside a layer) apply to every curve.  Returns every file (scene first, for the checks)
    and the curves ``(label, files)``: empty when there is one curve (the files merged in
    order, as before).
    """
    from torlab.errors import TorlabInputError

    scene: list[Path] = []
    labelled: dict[str, list[Path]] = {}
    plain: list[Path] = []
    for k, a in enumerate(args):
        s = str(a)
        lab, sep, rest = s.partition("=")
        if k and sep and lab.strip() and not Path(s).exists():
            labelled.setdefault(lab.strip(), []).append(Path(rest.strip()))
        elif k == 0:
            scene.append(Path(s))
        else:
            plain.append(Path(s))
    every = [*scene, *plain, *(f for fs in labelled.values() for f in fs)]
    files = require_files(every, "scene")
    if not labelled and len(plain) < 2:
        return files, []
    keys = {f: _param_keys(f) for f in [*plain, *(g for fs in labelled.values() for g in fs)]}
    alt = [f for f in plain if any(keys[f] & keys[g] for g in keys if g != f)]
    common = [f for f in plain if f not in alt]
    taken = list(labelled)
    curves = [(lab, [*common, *fs]) for lab, fs in labelled.items()]
    curves += [(_curve_label(f, taken), [*common, f]) for f in alt]
    if len(curves) == 1 and not labelled:
        return files, []
    if not curves:
        return files, []
    if len(curves) > 12:
        raise TorlabInputError(f"{len(curves)} curves: compare at most 12 in one figure",
                               key="PARAMS")
    return files, [(lab, [scene[0], *fs]) for lab, fs in curves]


def register(root: typer.Typer) -> None:
    """Add the ``predict`` group to the root app."""
    root.add_typer(app, name="predict")


def _print_modelled(modelled: list[str], notes: list[str]) -> None:
    c = console()
    c.print("[bold]modelled:[/bold]")
    for m in modelled:
        c.print(f"  - {m}")
    for n in notes:
        c.print(f"[yellow]note:[/yellow] {n}")


def _print_band(summary: dict) -> None:
    """The band's method and the parameters that dominate it (or why there is none)."""
    b = summary.get("band")
    if not b:
        return
    c = console()
    if b["method"] == "not computed":
        for n in b["notes"]:
            c.print(f"[yellow]band:[/yellow] {n}")
        return
    nl = b.get("nonlinearity")
    how = {"linear": "linearised", "sampling": f"sampled ({b.get('n_samples')} draws)",
           "none": "no parameter uncertainty: the band is the curve"}.get(b["method"], b["method"])
    c.print(f"95 % band from the fit's covariance: {how}"
            + (f", nonlinearity {nl:.2g} (limit {b['nonlinearity_tolerance']:g})"
               if nl is not None else "") + f", {b['n_evaluations']} model evaluations")
    from torlab.reports.traction import shares_text

    for out, dom in b.get("dominant", {}).items():
        if dom:
            c.print(f"  {out}: shares of its variance: "
                    + shares_text(dom, (b.get("explained") or {}).get(out)))
    for n in b["notes"]:
        if not n.startswith(("linearised", "sampled")):
            c.print(f"[yellow]band:[/yellow] {n}")


_SWEEP_HELP = ("Simulate the curve as recorded during a slip sweep of this duration ('60 s') "
               "while product is removed; needs a 'torlab fit removal' params.yaml among the "
               "files and --amount ('4 uL', '4 mg', '100000 mg/m^2'); the running band as in "
               "'predict retention'.")


@app.command("traction")
def traction_cmd(
    scene: ScenesArg,
    out: OutOpt,
    creepage: Annotated[str, typer.Option(help="Creepages (= SRR as a fraction): start:stop:count "
                                          "or a comma list; units allowed ('0 %:5 %:101').")]
    = "0:0.05:101",
    lateral: Annotated[str, typer.Option(help="Lateral creepage (fraction) of every point; "
                                         "non-zero: creep forces in three creepages.")] = "0",
    spin: Annotated[str, typer.Option(help="Spin (1/m, units allowed: '0.5 1/m') of every "
                                      "point; non-zero: creep forces in three creepages.")] = "0",
    sweep: Annotated[str | None, typer.Option(help=_SWEEP_HELP)] = None,
    amount: Annotated[str | None, typer.Option(help="With --sweep: the applied amount.")] = None,
    band_length: Annotated[str | None, typer.Option(help="With --sweep: rail length.")] = None,
    track_radius: Annotated[str | None, typer.Option(help="With --sweep: disc track.")] = None,
    pass_interval: Annotated[str | None, typer.Option(help="With --sweep: time between "
                                                      "passes on a rail.")] = None,
    hold_above: HoldAboveOpt = False,
    method: MethodOpt = None,
    force: ForceOpt = False,
    no_plot: NoPlotOpt = False,
    formats: FormatsOpt = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Traction curve mu(creepage) at the scene's speed.

    Writes traction.csv (creepage, mu, and where modelled mu_boundary, mu_ehl,
    load_share_asperity, film_thickness_m, max_temperature_C), traction.png (--formats:
    also .svg/.pdf; --no-plot: none) (mu against creepage with the layer's limits mu_c1,
    mu_c2 and the 95 % band) and summary.json
    (what was modelled, the trend after saturation, thesis H4.1).  With --lateral or
    --spin (dry scenes): lateral, spin_1_m, Fx_N, Fy_N, Mz_Nm, mu_x, mu_y too (mu = mu_x).
    --sweep: the curve recorded while product is removed, beside the steady one (H4.1).
    When a parameter file from 'torlab fit' carries its covariance, the fit's uncertainty
    is propagated: mu_low95/mu_high95 (and the film thickness and temperature bands) in
    the CSV, the band in the figure, the method and the dominant parameters in
    summary.json, and the trend with the probability of each class.  Every prediction
    names its boundary method (--method) and states its theory error against Kalker's
    exact theory apart from the band: mu_theory_error_95 in the CSV (Fx/Fy/Mz too with
    --lateral/--spin), method and theory_error in summary.json.
    """
    from torlab.reports.render import early_drawing, parse_formats

    files, curves = split_curves(scene)
    fmts = parse_formats(formats)
    if sweep is not None or amount is not None:
        return _sweep(files, out, force, fmts, creepage=creepage, seconds=sweep, amount=amount,
                      band_length=band_length, track_radius=track_radius,
                      pass_interval=pass_interval, above="hold" if hold_above else None)
    if curves:
        return _traction_overlay(files, curves, out, creepage, lateral, spin, force=force,
                                 formats=None if no_plot else fmts, jobs=jobs,
                                 scheduler=scheduler, quiet=quiet)
    # the figure's worker loads matplotlib while this process loads the scene and computes
    with early_drawing(not no_plot, jobs, scheduler) as drawer:
        pred, names = _traction(files, out, creepage, lateral, spin, force=force,
                                formats=None if no_plot else fmts, drawer=drawer, jobs=jobs,
                                scheduler=scheduler, quiet=quiet, method=method)
    _print_modelled(pred.modelled, pred.summary.get("notes", []))
    _print_band(pred.summary)
    print_theory_error(pred.summary)
    _print_trend(pred)
    console().print(f"wrote {_written(names)} to {out}")


def _traction(files: list[Path], out: Path, creepage: str, lateral: str, spin: str, *,
              force: bool, formats: Sequence[str] | None, drawer: Any, jobs: int | None,
              scheduler: str | None, quiet: bool, method: str | None = None
              ) -> tuple[Any, list[str]]:
    """``predict traction``'s work: the prediction, and the names of the files written
    (``formats`` None: no figure; ``drawer``: where the figure is drawn)."""
    from torlab.cli._common import parse_values, session
    from torlab.model.predict import predict_creep, predict_traction, with_method
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene

    _no_retention_file(files)
    with option_keys(traction_cmd):
        sc = with_method(load_scene(*files), method)
    xi = parse_values(creepage, "dimensionless", "--creepage", "creepage")
    eta = float(parse_values(lateral, "dimensionless", "--lateral", "creepage")[0])
    phi = float(parse_values(spin, "inverse_length", "--spin", "spin")[0])
    dest = OutputDir(out, force=force, inputs=files, command=command_line())
    names = ["traction.csv", "summary.json"]
    with dest, session(jobs, scheduler, quiet):
        if eta or phi:
            pred = predict_creep(sc, xi, eta, phi)
        else:
            pred = predict_traction(sc, xi, as_frame=False)
        dest.write_csv("traction.csv", pred.table,
                       allow_missing=("max_temperature_low95_C", "max_temperature_high95_C",
                                      "mu_theory_error_95", "Fx_theory_error_95_N",
                                      "Fy_theory_error_95_N", "Mz_theory_error_95_Nm"))
        summary = dict(pred.summary, creepage_range=[float(xi.min()), float(xi.max())],
                       n_points=int(xi.size))
        dest.write_json("summary.json", summary)
        if formats is not None:
            from torlab.reports.predict import traction_figure
            from torlab.reports.render import plot, write_figures

            fig = plot(traction_figure, [(sc.name or files[0].stem, pred.table)],
                       boundary=sc.boundary, title=f"Traction: {sc.name or files[0].stem}")
            names += write_figures(dest, [("traction", fig)], formats, executor=drawer)[0]
    return pred, names


def _traction_overlay(files: list[Path], curves: list[tuple[str, list[Path]]], out: Path,
                      creepage: str, lateral: str, spin: str, *, force: bool,
                      formats: Sequence[str] | None, jobs: int | None, scheduler: str | None,
                      quiet: bool) -> None:
    """Several parameter sets: one labelled curve each, with its band, in one long CSV
    (``curve`` first), one figure and one summary (``curves``)."""
    import pandas as pd

    from torlab.cli._common import parse_values, session
    from torlab.model.predict import predict_traction
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene

    _no_retention_file(files)
    xi = parse_values(creepage, "dimensionless", "--creepage", "creepage")
    eta = float(parse_values(lateral, "dimensionless", "--lateral", "creepage")[0])
    phi = float(parse_values(spin, "inverse_length", "--spin", "spin")[0])
    scenes = [(lab, load_scene(*fs), fs) for lab, fs in curves]
    dest = OutputDir(out, force=force, inputs=files, command=command_line())
    names = ["traction.csv", "summary.json"]
    preds = []
    with dest, session(jobs, scheduler, quiet):
        for lab, sc, _ in scenes:
            if eta or phi:
                from torlab.model.creep import predict_creep

                preds.append((lab, predict_creep(sc, xi, eta, phi)))
            else:
                preds.append((lab, predict_traction(sc, xi)))
        long = pd.concat([pd.DataFrame(p.table).assign(curve=lab) for lab, p in preds],
                         ignore_index=True)
        long = long[["curve", *[c for c in long.columns if c != "curve"]]]
        dest.write_csv("traction.csv", long, allow_missing=tuple(
            c for c in long.columns if c not in ("curve", "creepage", "mu")))
        dest.write_json("summary.json", {
            "curves": {lab: dict(p.summary, parameter_files=[str(f) for f in fs[1:]])
                       for (lab, p), (_, _, fs) in zip(preds, scenes, strict=True)},
            "creepage_range": [float(xi.min()), float(xi.max())], "n_points": int(xi.size)})
        if formats is not None:
            from torlab.reports.predict import traction_figure
            from torlab.reports.render import plot, write_figures

            fig = plot(traction_figure, [(lab, p.table) for lab, p in preds],
                       title=f"Traction: {scenes[0][1].name or files[0].stem}, "
                             f"{len(preds)} parameter sets")
            names += write_figures(dest, [("traction", fig)], formats)[0]
    for lab, p in preds:
        console().print(f"[bold]{lab}[/bold] ({', '.join(f.name for f in dict(curves)[lab][1:])})")
        _print_band(p.summary)
        _print_trend(p)
    console().print(f"wrote {_written(names)} ({len(preds)} curves) to {out}")


def _print_trend(pred: Any) -> None:
    """The largest coefficient (with its band) and the trend after saturation (H4.1)."""
    import numpy as np

    t = pred.trend
    c = console()
    tab = pred.table
    mu = np.abs(np.asarray(tab["mu"], dtype=float))
    i = int(np.argmax(mu))
    band = ""
    if "mu_low95" in tab:
        band = (f" (95 % band {abs(float(np.asarray(tab['mu_low95'])[i])):.4f}–"
                f"{abs(float(np.asarray(tab['mu_high95'])[i])):.4f})")
    c.print(f"max |mu| = {mu[i]:.4f}{band} at creepage "
            f"{float(np.asarray(tab['creepage'])[i]):.4g}")
    if t.get("saturation_creepage") is None:
        c.print(f"trend after saturation: {t['trend']}" + (
            " (give three or more creepages)" if t["trend"] == "too few points" else ""))
    elif t["trend"] == "not saturated in this range" and t.get("relative_change") is None:
        c.print("trend after saturation: not saturated in this range (the curve does not level "
                "off in this range)")
    elif t.get("trend_from_creepage") is None:  # e.g. 'too few points' after saturation
        c.print(f"trend after saturation (H4.1): {t['trend']} (saturated at creepage "
                f"{t['saturation_creepage']:.4g}; give more creepages beyond it to read a trend)")
    else:
        probs = t.get("probabilities")
        ev = ""
        if probs:
            ev = ("; probabilities " + ", ".join(f"{k} {v:.2f}" for k, v in probs.items())
                  + f" (a class is called at >= {t['probability_threshold']:g})")
        c.print(f"trend after saturation (H4.1): [bold]{t['trend']}[/bold] (saturated at "
                f"creepage {t['saturation_creepage']:.4g}; from {t['trend_from_creepage']:.4g} "
                f"to the end mu changes {100 * t['relative_change']:+.2f} %, neutral within "
                f"±{100 * t['tolerance']:g} %{ev})")
        if t.get("note") and t["trend"] == "not saturated in this range":
            c.print(f"  {t['note']}")


def _no_retention_file(files: Sequence[Path]) -> None:
    """A removal parameter file among a plain prediction's files: say what it is for."""
    params = [f for f in files[1:] if f.suffix.lower() in (".yaml", ".yml")]
    if not params:  # a scene alone: nothing to check, nothing to import
        return
    from torlab.errors import TorlabInputError
    from torlab.fit.retention_params import is_retention_file

    for f in params:
        if is_retention_file(f):
            raise TorlabInputError("a removal parameter file ('torlab fit removal' output): use "
                                   "it with --sweep and --amount, or with 'torlab predict "
                                   "retention'", path=f)


def _sweep(files: list[Path], out: Path, force: bool, formats: Sequence[str],
           **kw: str | None) -> None:
    """``predict traction --sweep``: the recorded-looking curve beside the steady one."""
    from torlab.api import predict_sweep
    from torlab.errors import TorlabInputError
    from torlab.outputs import OutputDir
    from torlab.reports.retention import write_sweep

    if kw["seconds"] is None or kw["amount"] is None:
        raise TorlabInputError("a slip sweep needs both --sweep (its duration) and --amount",
                               key="--sweep" if kw["seconds"] is None else "--amount")
    with hold_above_hint(), option_keys(traction_cmd):
        sw = predict_sweep(files[0], files[1:], kw.pop("amount"), **kw)
    with OutputDir(out, force=force, inputs=files, command=command_line()) as dest:
        names = write_sweep(dest, sw, title="", formats=formats)
    s = sw.summary
    c = console()
    _print_modelled(s["modelled"], s["notes"])
    c.print(f"sweep over {s['seconds']:g} s: {s['passes_during_sweep']:.4g} passes, amount "
            f"{s['initial_amount_mg_m2']:.4g} -> {s['final_amount_mg_m2']:.4g} mg/m^2")
    c.print(f"trend after saturation: recorded curve [bold]{s['trend_sweep']['trend']}[/bold], "
            f"steady curve [bold]{s['trend_steady']['trend']}[/bold]")
    c.print(f"verdict: {s['verdict']}")
    c.print(f"wrote {', '.join(names)} to {out}")


@app.command("retention")
def retention_cmd(
    scene: ScenesArg,
    out: OutOpt,
    amount: Annotated[str, typer.Option(help="Applied amount: '4 uL' (with the product "
                                        "density), '4 mg', or per area '100000 mg/m^2'.")],
    creepage: Annotated[str, typer.Option(help="Creepage of every pass ('1 %' or a "
                                          "fraction).")] = "1 %",
    passes: Annotated[str | None, typer.Option(help="Predict this many axle passes (default: "
                                               "until 1.2 x the passes to dry).")] = None,
    cycles: Annotated[str | None, typer.Option(help="Predict this many disc revolutions "
                                               "(needs --track-radius).")] = None,
    time: Annotated[str | None, typer.Option(help="Predict this long ('2 h') at --speed (a disc, "
                                             "or a rail with --pass-interval).")] = None,
    speed: Annotated[str | None, typer.Option(help="Rolling speed (default the scene's).")]
    = None,
    band: Annotated[str, typer.Option(help="The coefficient band: a preset (thesis: 0.15-0.25, "
                                      "intermediate: 0.20-0.35; docs/model/retention.md) or "
                                      "LOW:HIGH.")] = "thesis",
    window: Annotated[str | None, typer.Option(help="FIRST:LAST passes of the effective "
                                               "friction level (default: all).")] = None,
    retentivity: Annotated[str, typer.Option(help="'band' (until mu leaves it) or a fraction "
                                             "of dry (0.9).")] = "band",
    band_length: Annotated[str | None, typer.Option(help="Rail length a volume or mass "
                                                    "covers ('20 mm').")] = None,
    track_radius: Annotated[str | None, typer.Option(help="Disc track radius: a closed track, "
                                                     "one pass per revolution.")] = None,
    pass_interval: Annotated[str | None, typer.Option(help="Time between axle passes on a "
                                                      "rail ('2 s'), for a time axis.")] = None,
    density: Annotated[str | None, typer.Option(help="Product density ('930 kg/m^3'); default "
                                                "the removal fit's.")] = None,
    draws: Annotated[int, typer.Option(help="Parameter draws for the 95 % intervals (0: "
                                       "none).")] = 200,
    seed: Annotated[int, typer.Option(help="Seed of the draws.")] = 0,
    hold_above: HoldAboveOpt = False,
    force: ForceOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Coefficient against axle passes (disc revolutions, or time) after one application,
    with 95 % intervals, and the passes until it enters and leaves the band.

    SCENE, then the removal params.yaml of 'torlab fit removal' (and optional scene
    parameter files). Writes retention.csv (passes, amount_mg_m2, mu, mu_low95, mu_high95,
    energy_J_m2[, time_s]), summary.json (crossings with 95 % intervals, law, what was
    modelled), retention.png (--formats: also .svg/.pdf).
    """
    from torlab.errors import TorlabInputError
    from torlab.outputs import OutputDir
    from torlab.reports.retention import write_retention
    from torlab.units import to_si

    files, curves = split_curves(scene)  # several removal files: one curve each
    given = [k for k, v in (("--passes", passes), ("--cycles", cycles), ("--time", time)) if v]
    if len(given) > 1:
        raise TorlabInputError(f"give one of {', '.join(given)}", key=given[1])
    if cycles is not None and track_radius is None:
        raise TorlabInputError("cycles are revolutions of a disc track: give --track-radius",
                               key="--cycles")
    n = passes or cycles
    with hold_above_hint(), option_keys(retention_cmd):
        preds = _retention_predictions(
            curves or [("", files)], None if n is None else to_si(
                n, "dimensionless", where=given[0]), amount=amount, creepage=creepage,
            time=time, speed=speed, band=band, band_length=band_length,
            track_radius=track_radius, pass_interval=pass_interval, density=density,
            n_draws=draws, seed=seed, above="hold" if hold_above else None, window=window,
            retentivity=retentivity)
    axis = "time" if time else "cycles" if track_radius else "passes"
    with OutputDir(out, force=force, inputs=files, command=command_line()) as dest:
        from torlab.reports.retention import write_retention_overlay

        names = write_retention_overlay(dest, preds, axis=axis, formats=formats, title=(
            f"Retention of {len(preds)} products")) if curves else write_retention(
            dest, preds[0][1], axis=axis, formats=formats)
    for lab, pred in preds:
        if lab:
            console().print(f"[bold]{lab}[/bold]")
        _print_modelled(pred.modelled, [])
        _print_crossings(pred.summary)
    console().print(f"wrote {', '.join(names)} to {out}")


def _retention_predictions(runs: list[tuple[str, list[Path]]], n_passes: Any, **kw: Any
                           ) -> list[tuple[str, Any]]:
    """One retention prediction per curve (scene first in its files); several on one passes
    axis (the longest of their default ranges)."""
    from torlab.api import predict_retention

    def predict(fs: list[Path], n: Any) -> Any:
        return predict_retention(fs[0], fs[1:], passes=n, **kw)

    preds = [(lab, predict(fs, n_passes)) for lab, fs in runs]
    if len(preds) > 1 and n_passes is None and kw.get("time") is None:
        end = max(float(p.table["passes"].iloc[-1]) for _, p in preds)
        preds = [(lab, p if float(p.table["passes"].iloc[-1]) == end else predict(fs, end))
                 for (lab, p), (_, fs) in zip(preds, runs, strict=True)]
    return preds


def _print_crossings(s: dict) -> None:
    from torlab.reports.retention import crossing_text

    c = console()
    c.print(f"applied {s['applied']}: {s['initial_amount_mg_m2']:.4g} mg/m^2 in the band; mu "
            f"{s['mu_initial']:.4f} at the application, dry {s['mu_dry']:.4f}")
    for key, word in (("passes_to_enter_band", "enters"), ("passes_to_leave_band", "leaves")):
        cr = s[key]
        c.print(f"mu {word} the band (crosses {cr['level']:g}): "
                f"[bold]{crossing_text(cr)}[/bold] -- {cr['status']}")
    if s.get("retention_metrics"):
        from torlab.reports.retention import metrics_text

        c.print(metrics_text(s["retention_metrics"]))


@app.command("stribeck")
def stribeck_cmd(
    scene: ScenesArg,
    out: OutOpt,
    speed: Annotated[str, typer.Option(help="Rolling speeds: start:stop:count (log-spaced when "
                                       "--log) or a comma list; units allowed.")]
    = "0.01:2:50",
    creepage: Annotated[str, typer.Option(help="Creepage (SRR as a fraction, or '5 %').")]
    = "0.05",
    log: Annotated[bool, typer.Option("--log/--linear", help="Space start:stop:count "
                                      "speeds geometrically (default) or linearly.")] = True,
    force: ForceOpt = False,
    no_plot: NoPlotOpt = False,
    formats: FormatsOpt = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Stribeck curve mu(speed) at one creepage for a lubricated scene.

    Writes stribeck.csv (speed_m_s, mu, film_thickness_m, lambda, load_share_asperity,
    mu_ehl, mu_boundary, separation_m, regime), stribeck.png (--formats: also .svg/.pdf;
    --no-plot: none) (mu, Lambda and the asperity load share against speed, regimes
    shaded) and summary.json.  With a
    parameter file that carries its fit covariance: the 95 % bands of mu and the film
    thickness (mu_low95, mu_high95, film_thickness_low95_m ...) in the CSV and figure.
    """
    from torlab.reports.render import early_drawing, parse_formats

    files, curves = split_curves(scene)
    fmts = parse_formats(formats)
    # the figure's worker loads matplotlib while this process loads the scene and computes
    with early_drawing(not no_plot, jobs, scheduler) as drawer:
        from torlab.cli._common import session
        from torlab.errors import TorlabInputError
        from torlab.model.predict import predict_stribeck
        from torlab.outputs import OutputDir
        from torlab.scene import load_scene

        sc = load_scene(*(curves[0][1] if curves else files))
        if sc.lubricant is None:
            raise TorlabInputError("a Stribeck curve needs a lubricated scene (lubricant: section)",
                                   path=files[0], key="lubricant")
        v, xi = _stribeck_axes(speed, creepage, log)
        if curves:
            return _stribeck_overlay(files, curves, out, v, float(xi[0]), force=force,
                                     formats=None if no_plot else fmts, jobs=jobs,
                                     scheduler=scheduler, quiet=quiet)
        dest = OutputDir(out, force=force, inputs=files, command=command_line())
        names = ["stribeck.csv", "summary.json"]
        with dest, session(jobs, scheduler, quiet):
            pred = predict_stribeck(sc, v, float(xi[0]))
            dest.write_csv("stribeck.csv", pred.table,
                           allow_missing=("lambda", "mu_ehl", "mu_boundary", "max_temperature_C",
                                          "max_temperature_low95_C", "max_temperature_high95_C"))
            dest.write_json("summary.json", pred.summary)
            if not no_plot:
                from torlab.reports.predict import stribeck_figure
                from torlab.reports.render import plot, write_figures

                fig = plot(stribeck_figure, pred.table,
                           title=f"Stribeck curve: {sc.name or files[0].stem}",
                           creepage=pred.creepage)
                names += write_figures(dest, [("stribeck", fig)], fmts, executor=drawer)[0]
    _print_modelled(pred.modelled, pred.summary.get("notes", []))
    _print_band(pred.summary)
    s = pred.summary
    console().print(f"mu from {s['mu_min']:.4g} to {s['mu_max']:.4g}; regimes: "
                    + ", ".join(f"{k} ({n} speeds)" for k, n in s["regimes"].items()))
    if s.get("transitions"):
        from torlab.reports.stribeck import transition_words

        console().print(f"regime transitions: {transition_words(s['transitions'])}")
    console().print(f"wrote {_written(names)} to {out}")


def _stribeck_axes(speed: str, creepage: str, log: bool) -> tuple[Any, Any]:
    """``--speed`` (log-spaced for start:stop:count with ``--log``) and the one ``--creepage``."""
    import numpy as np

    from torlab.cli._common import parse_values
    from torlab.errors import TorlabInputError

    v = parse_values(speed, "velocity", "--speed", "speed")
    if log and ":" in speed and "," not in speed:
        if v[0] <= 0:
            raise TorlabInputError("log-spaced speeds must start above 0 (or use --linear)",
                                   key="--speed")
        v = np.geomspace(v[0], v[-1], v.size)
    xi = parse_values(creepage, "dimensionless", "--creepage", "creepage")
    if xi.size != 1:
        raise TorlabInputError("give one creepage", key="--creepage")
    return v, xi


def _stribeck_overlay(files: list[Path], curves: list[tuple[str, list[Path]]], out: Path,
                      v: Any, xi: float, *, force: bool, formats: Sequence[str] | None,
                      jobs: int | None, scheduler: str | None, quiet: bool) -> None:
    """Several parameter sets: one labelled Stribeck curve each, with its bands, in one long
    CSV (``curve`` first), one figure and one summary (``curves``)."""
    import pandas as pd

    from torlab.cli._common import session
    from torlab.model.predict import predict_stribeck
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene

    scenes = [(lab, load_scene(*fs), fs) for lab, fs in curves]
    dest = OutputDir(out, force=force, inputs=files, command=command_line())
    names = ["stribeck.csv", "summary.json"]
    with dest, session(jobs, scheduler, quiet):
        preds = [(lab, predict_stribeck(sc, v, xi)) for lab, sc, _ in scenes]
        long = pd.concat([pd.DataFrame(p.table).assign(curve=lab) for lab, p in preds],
                         ignore_index=True)
        long = long[["curve", *[c for c in long.columns if c != "curve"]]]
        dest.write_csv("stribeck.csv", long, allow_missing=tuple(
            c for c in long.columns if c not in ("curve", "speed_m_s", "mu")))
        dest.write_json("summary.json", {"curves": {
            lab: dict(p.summary, parameter_files=[str(f) for f in fs[1:]])
            for (lab, p), (_, _, fs) in zip(preds, scenes, strict=True)}})
        if formats is not None:
            from torlab.reports.predict import stribeck_overlay_figure
            from torlab.reports.render import plot, write_figures

            fig = plot(stribeck_overlay_figure, [(lab, p.table) for lab, p in preds],
                       title=f"Stribeck curves: {scenes[0][1].name or files[0].stem}",
                       creepage=xi)
            names += write_figures(dest, [("stribeck", fig)], formats)[0]
    for lab, p in preds:
        s = p.summary
        console().print(f"[bold]{lab}[/bold]: mu from {s['mu_min']:.4g} to {s['mu_max']:.4g}")
        _print_band(s)
    console().print(f"wrote {_written(names)} ({len(preds)} curves) to {out}")


@app.command("table")
def table_cmd(
    scene: ScenesArg,
    out: OutOpt,
    creepage: Annotated[str, typer.Option(help="Longitudinal-creepage axis (start:stop:count or "
                                          "a list; >= 2 points).")] = "-0.01:0.01:21",
    lateral: Annotated[str, typer.Option(help="Lateral-creepage axis.")] = "-0.01:0.01:21",
    spin: Annotated[str, typer.Option(help="Spin axis (1/m; units allowed).")] = "-2:2:11",
    speed: Annotated[str | None, typer.Option(help="Optional speed axis (m/s; units allowed): "
                                              "changes the contact temperature.")] = None,
    amount: Annotated[list[str] | None, typer.Option(
        help="Amount axis: 'AMOUNT=PARAMS.yaml' per applied amount, e.g. '4 uL=p4.yaml' "
        "(repeatable; the parameter file overrides the scene).")] = None,
    normalised: Annotated[bool, typer.Option(help="Axes in Kalker's normalised creepages "
                                             "xi*, eta*, phi* instead of fractions and 1/m.")]
    = False,
    load: Annotated[str | None, typer.Option(help="Optional normal-load axis ('10 kN, 20 kN, "
                                             "80 kN'): one contact per load (Hertz); with a "
                                             "layer the normalised forces depend on it.")]
    = None,
    method: MethodOpt = None,
    force: ForceOpt = False,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Creep-force table over creepage x lateral x spin (x speed x amount x load) for a dry
    scene.

    Writes creep_table.nc (netCDF3, CF conventions: axes, units, Kalker's normalisation,
    the contact it holds for, the boundary method, the scene's provenance), creep_table.csv
    (one row per point) and summary.json.  Every force comes with its theory error
    against Kalker's exact theory (Fx_theory_error_95_N ...).  With a layer Kalker's
    normalised forces hold for the table's contact only (its load_N and a_over_b
    coordinates; --load adds a load axis).
    """
    from torlab.cli._common import parse_values, session
    from torlab.model.creep_table import scene_creep_table
    from torlab.outputs import OutputDir
    from torlab.scene import load_scene

    files = require_files(scene, "scene")
    kinds = ("dimensionless", "dimensionless", "inverse_length") if not normalised else \
        ("dimensionless",) * 3
    ranges = ("creepage", "creepage", "spin") if not normalised else (None,) * 3
    axes = [parse_values(v, k, f"--{n}", q) for v, k, n, q in
            zip((creepage, lateral, spin), kinds, ("creepage", "lateral", "spin"), ranges,
                strict=True)]
    v = parse_values(speed, "velocity", "--speed", "speed") if speed is not None else None
    loads = parse_values(load, "force", "--load", "load") if load is not None else None
    pairs, unit, extra = _parse_amounts(amount or [])
    amounts = [(a, load_scene(*files, p)) for a, p in pairs] if pairs else None
    sc = load_scene(*files)
    with session(jobs, scheduler, quiet), option_keys(table_cmd):
        tab = scene_creep_table(sc, *axes, speed=v, amounts=amounts, amount_unit=unit,
                                normalised=normalised, loads=loads, method=method,
                                provenance={
                                    "scene_files": [str(f) for f in [*files, *extra]],
                                    "command": command_line()})
    dest = OutputDir(out, force=force, inputs=[*files, *extra], command=command_line())
    with dest:
        names = tab.write(dest)
        dims = dict(tab.dataset.sizes)
        dest.write_json("summary.json", {"dims": dims, "notes": tab.notes,
                                         "attributes": {k: v for k, v in tab.dataset.attrs.items()
                                                        if isinstance(v, (str, int, float))}})
    for n in tab.notes:
        console().print(f"[yellow]note:[/yellow] {n}")
    at = tab.dataset.attrs
    console().print(f"boundary method: [bold]{at['boundary_method']}[/bold]; theory error "
                    f"(95 %, against Kalker's exact theory): up to "
                    f"{at['theory_error_95_max_mu']:.2g} in mu (Fx_theory_error_95_N ...)")
    console().print(f"normalised forces hold for {at['normalisation_valid_for']}")
    console().print(f"table {' x '.join(f'{k} {v}' for k, v in dims.items())}; wrote "
                    f"{', '.join(names)}, summary.json to {out}")


def _parse_amounts(items: Sequence[str]) -> tuple[list[tuple[float, Path]], str, list[Path]]:
    """``'4 uL=params.yaml'`` items: ``([(4.0, Path)], 'uL', [Path])`` (one unit for all)."""
    import re

    from torlab.errors import TorlabInputError

    pairs: list[tuple[float, Path]] = []
    units = set()
    for it in items:
        m = re.fullmatch(r"\s*([+-]?\d+(?:\.\d*)?(?:[eE][+-]?\d+)?)\s*([^=]*?)\s*=\s*(.+)", it)
        if not m:
            raise TorlabInputError(f"{it!r}: write AMOUNT=PARAMS.yaml, e.g. '4 uL=p4.yaml'",
                                   key="--amount")
        units.add(m.group(2))
        pairs.append((float(m.group(1)), Path(m.group(3).strip())))
    if len(units) > 1:
        raise TorlabInputError(f"amounts in different units {sorted(units)}: use one unit",
                               key="--amount")
    files = require_files([p for _, p in pairs], "parameter") if pairs else []
    return [(a, f) for (a, _), f in zip(pairs, files, strict=True)], (units.pop() if units else ""), files
