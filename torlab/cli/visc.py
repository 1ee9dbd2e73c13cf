"""``torlab visc``: falling-body high-pressure viscometer logs."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from torlab.cli._common import ForceOpt, OutOpt, command_line, console, print_table, require_files

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
) -> None:
    """Reduce viscometer logs: falls found in the LVDT trace, terminal velocity from each fall's
    steady part, eta = K (rho_body - rho_liquid) / v per fall and per pressure step; then the
    Barus alpha (ln eta against p) and Roelands Z fits with confidence intervals and residuals.

    Writes per input '<name>_falls.csv', '<name>_steps.csv', '<name>_fit.csv',
    '<name>_lubricant_<law>.yaml' (the scene's lubricant: block), '<name>_falls.png',
    '<name>_fit.png'; 'summary.csv' and, with --reference, 'calibration.csv'.
    """
    import pandas as pd

    from torlab.errors import TorlabInputError
    from torlab.fit.viscosity import fit_barus, fit_optional, fit_roelands
    from torlab.outputs import OutputDir
    from torlab.parsers.viscometer import (
        DENSITY_MODELS,
        parse_calibration_constant,
        read_viscometer,
    )
    from torlab.reduce.viscometer import Calibration, calibrate, reduce_viscometer
    from torlab.reports.viscometer import falls_figure, fit_figure
    from torlab.units import to_si
    from torlab.yamlio import dump_yaml

    paths = require_files(logs, "viscometer log")
    refs = require_files(reference, "reference log") if reference else []
    laws = [x.strip().lower() for x in law.split(",") if x.strip()]
    if not laws or any(x not in ("barus", "roelands") for x in laws):
        raise TorlabInputError(f"{law!r}: choose barus, roelands or both", key="--law")
    if not (0 < tol < 1):
        raise TorlabInputError(f"{tol}: must be in (0, 1)", key="--tol")
    if not (0 < confidence < 1):
        raise TorlabInputError(f"{confidence}: must be in (0, 1)", key="--confidence")
    if density_model is not None and density_model not in DENSITY_MODELS:
        raise TorlabInputError(f"{density_model!r}: choose {' or '.join(DENSITY_MODELS)}",
                               key="--density-model")
    if refs and calibration_constant is not None:
        raise TorlabInputError("give either --reference or --calibration-constant",
                               key="--calibration-constant")
    eta0_v = to_si(eta0, "viscosity", where="--eta0") if eta0 is not None else None
    cal = None
    cal_rows = []
    if calibration_constant is not None:
        cal = Calibration(parse_calibration_constant(calibration_constant,
                                                     where="--calibration-constant"),
                          source="--calibration-constant")
    elif refs:
        Ks, ns = [], []
        for r in refs:
            rdf, rmeta = read_viscometer(r)
            c = calibrate(rdf, rmeta, tol=tol)
            cal_rows.append({"file": r.name, **c.to_dict()})
            Ks.append(c.K)
            ns.append(c.n_falls)
        import numpy as np

        w = np.asarray(ns, dtype=float)
        K = float(np.sum(w * np.asarray(Ks)) / w.sum())
        cal = Calibration(K, K_sd=float(np.std(Ks, ddof=1)) if len(Ks) > 1 else
                          cal_rows[0]["calibration_constant_sd_m3_s2"], n_falls=int(w.sum()),
                          source=", ".join(r.name for r in refs))
    dest = OutputDir(out, force=force, inputs=[*paths, *refs], command=command_line())
    results = []
    try:
        if cal_rows:
            dest.write_csv("calibration.csv", pd.DataFrame(cal_rows))
        stems: set[str] = set()
        summary = []
        for f in paths:
            df, meta = read_viscometer(f)
            res = reduce_viscometer(df, meta, calibration=cal, tol=tol,
                                    density_model=density_model)
            stem = f.stem
            while stem in stems:
                stem += "_"
            stems.add(stem)
            dest.write_csv(f"{stem}_steps.csv", res.steps)
            dest.save_figure(f"{stem}_falls.png", falls_figure(res))
            p = res.falls["pressure_Pa"].to_numpy()
            eta = res.falls["viscosity_Pa_s"].to_numpy()
            T = float(res.falls["temperature_C"].mean()) if "temperature_C" in res.falls else \
                meta.temperature
            fits, notes = [], list(res.warnings)
            for lw in laws:
                try:
                    if lw == "barus":
                        fits.append(fit_barus(p, eta, confidence=confidence, temperature_C=T))
                    else:
                        fits.append(fit_roelands(p, eta, eta0=eta0_v,
                                                 fit_eta0=True if fit_eta0 else None,
                                                 confidence=confidence, temperature_C=T))
                except TorlabInputError as e:
                    if e.key is not None:
                        raise
                    notes.append(f"no {lw} fit: {e.message}")
            falls_res = res.falls.copy()
            for ft in fits:
                falls_res[f"residual_ln_eta_{ft.law}"] = ft.residuals
            dest.write_csv(f"{stem}_falls.csv", falls_res)
            if fits:
                fdf = pd.DataFrame([ft.summary() for ft in fits])
                dest.write_csv(f"{stem}_fit.csv", fdf, allow_missing=fit_optional(fdf.columns))
                for ft in fits:
                    dest.write_text(f"{stem}_lubricant_{ft.law}.yaml", dump_yaml(
                        {"lubricant": ft.to_scene_dict()}))
                dest.save_figure(f"{stem}_fit.png", fit_figure(res, fits))
            for ft in fits:
                notes += [f"{ft.law}: {w}" for w in ft.warnings]
            bar = next((ft for ft in fits if ft.law == "barus"), None)
            roe = next((ft for ft in fits if ft.law == "roelands"), None)
            nan = float("nan")
            summary.append({
                "file": f.name, "liquid": meta.liquid, "temperature_C": T if T is not None else nan,
                "n_falls": len(res.falls), "n_steps": len(res.steps),
                "pressure_min_Pa": float(p.min()), "pressure_max_Pa": float(p.max()),
                "calibration_constant_m3_s2": res.calibration.K,
                "calibration_source": res.calibration.source,
                "density_model": density_model or meta.density_model,
                "barus_eta0_Pa_s": bar.eta0 if bar else nan,
                "barus_alpha_1_Pa": bar.alpha if bar else nan,
                "barus_alpha_se_1_Pa": bar.alpha_se if bar else nan,
                "roelands_eta0_Pa_s": roe.eta0 if roe else nan,
                "roelands_Z": roe.Z if roe else nan, "roelands_Z_se": roe.Z_se if roe else nan,
                "roelands_alpha_star_1_Pa": roe.alpha if roe else nan,
                "notes": "; ".join(notes),
            })
            results.append((res, fits, notes))
        sdf = pd.DataFrame(summary)
        dest.write_csv("summary.csv", sdf, allow_missing=tuple(
            c for c in sdf.columns if c.startswith(("barus_", "roelands_", "temperature"))))
    except BaseException:
        dest.abort()
        raise
    dest.commit()
    rows = []
    for res, _fits, _ in results:
        for st in res.steps.itertuples():
            rows.append({"file": res.label, "p (MPa)": st.pressure_Pa / 1e6,
                         "η (mPa·s)": st.viscosity_Pa_s * 1e3, "falls": st.n_falls,
                         "sd (%)": st.viscosity_rel_sd * 100})
    print_table(rows, title="Viscosity per pressure step", formats={
        "p (MPa)": ".1f", "η (mPa·s)": ".4g", "sd (%)": ".2f"})
    frows = []
    for res, fits, _ in results:
        for ft in fits:
            if ft.law == "barus":
                par = (f"α = {ft.alpha * 1e9:.4g} 1/GPa [{ft.alpha_ci[0] * 1e9:.4g}, "
                       f"{ft.alpha_ci[1] * 1e9:.4g}]")
            else:
                par = (f"Z = {ft.Z:.4g} [{ft.Z_ci[0]:.4g}, {ft.Z_ci[1]:.4g}], "
                       f"α* = {ft.alpha * 1e9:.4g} 1/GPa")
            frows.append({"file": res.label, "law": ft.law, "η0 (mPa·s)": ft.eta0 * 1e3,
                          f"parameter [{100 * ft.confidence:g} % CI]": par,
                          "residual sd (ln η)": ft.s, "n": ft.n})
    print_table(frows, title="Pressure-viscosity fits (Eqs. 5.38-5.39)",
                formats={"η0 (mPa·s)": ".4g", "residual sd (ln η)": ".3g"})
    c = console()
    if cal is not None:
        c.print(f"calibration constant K = {cal.K:.6g} m^3/s^2 ({cal.source})")
    for res, _, notes in results:
        for n in notes:
            c.print(f"[yellow]note[/yellow] {res.label}: {n}")
    c.print(f"wrote falls, steps, fits, lubricant YAML, figures and summary.csv to {out}")
