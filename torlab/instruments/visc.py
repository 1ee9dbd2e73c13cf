"""Falling-body viscometer logs (registry entry ``visc``).

Reduces ``torlab-visc`` logs with :func:`torlab.reduce.viscometer.reduce_viscometer`
(falls in the LVDT trace, terminal velocities, viscosity per fall and pressure
step) and fits the pressure-viscosity laws (Barus alpha, Roelands Z; thesis
Eqs. 5.38-5.39) with :mod:`torlab.fit.viscosity`.  The calibration constant
comes from the log's header, a given constant, or reference-liquid logs
(:func:`torlab.reduce.viscometer.calibrate_from_references`), computed once
for all files.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError
from torlab.instruments.plugin import Command, Option, convert_options
from torlab.instruments.reduction import Reduction

NAME = "visc"
TITLE = "falling-body viscometer"
FILES = "torlab-visc logs"
EXTENSIONS = (".txt", ".log")
ALIASES: dict[str, dict[str, Any]] = {"viscometer": {}}

OPTIONS: dict[str, Option] = {
    "reference": Option("paths", None, "Reference-liquid log(s) with a 'reference_viscosity' "
                        "header: calibrate K from them (repeat for several)."),
    "calibration_constant": Option("text", None, "K of eta = K (rho_body - rho_liquid) / v, e.g. "
                                   "'1.9e-8 m^3/s^2' (instead of the header or a reference "
                                   "log)."),
    "calibration": Option("object", None, "A Calibration (instead of the above).", flag=None,
                          key=None),
    "tol": Option("number", 0.02, "Steady part: local slope within this fraction of the "
                  "terminal velocity.", check="open_fraction"),
    "density_model": Option("choice", None, "Liquid density against pressure: constant or "
                            "dowson-higginson (default: the log's header).",
                            ("constant", "dowson-higginson")),
    "law": Option("text", "barus,roelands", "Fits: barus, roelands or both (comma list).",
                  key=None),
    "fit_eta0": Option("flag", False, "Fit eta0 with Roelands Z (default: eta0 from the "
                       "atmospheric points)."),
    "eta0": Option("viscosity", None, "Fix the Roelands eta0 (e.g. '65 mPa*s').",
                   check="positive", quantity="viscosity"),
    "confidence": Option("number", 0.95, "Level of the confidence intervals.",
                         check="open_fraction"),
}

COMMAND = Command(
    "visc", "Falling-body high-pressure viscometer (thesis 5.1.5): terminal velocities, "
    "viscosity per pressure step, Barus and Roelands fits.",
    """Reduce viscometer logs: falls found in the LVDT trace, terminal velocity from each fall's
    steady part, eta = K (rho_body - rho_liquid) / v per fall and per pressure step; then the
    Barus alpha (ln eta against p) and Roelands Z fits with confidence intervals and residuals.

    Writes per input '<name>_falls.csv', '<name>_steps.csv', '<name>_fit.csv',
    '<name>_lubricant_<law>.yaml' (the scene's lubricant: block), '<name>_falls.png',
    '<name>_fit.png'; 'summary.csv' and, with --reference, 'calibration.csv'.
    """,
    "torlab-visc logs of the sample liquid (docs/formats/viscometer.md).", argument="logs",
    what="viscometer log")


def detect(head: str) -> str:
    """``"torlab-visc log"`` for a file starting with ``# torlab-visc``."""
    return "torlab-visc log" if head.lstrip().startswith("# torlab-visc") else ""


def read(path: Path, **_: Any) -> tuple[Any, Any]:
    """:func:`torlab.parsers.viscometer.read_viscometer`."""
    from torlab.parsers.viscometer import read_viscometer

    return read_viscometer(path)


def laws(spec: str) -> list[str]:
    """The laws of a comma list (``"barus,roelands"``; ``""`` or ``"none"``: no fit)."""
    if str(spec).strip().lower() in ("", "none"):
        return []
    out = [x.strip().lower() for x in str(spec).split(",") if x.strip()]
    if not out or any(x not in ("barus", "roelands") for x in out):
        raise TorlabInputError(f"{spec!r}: choose barus, roelands or both", key="--law")
    return out


def prepare(opts: dict[str, Any]) -> dict[str, Any]:
    """The calibration, once for all files (reference logs averaged)."""
    from torlab.parsers.viscometer import parse_calibration_constant
    from torlab.reduce.viscometer import Calibration, calibrate_from_references

    out = dict(opts)
    laws(out["law"])
    refs, const = out.get("reference") or [], out.get("calibration_constant")
    if refs and const is not None:
        raise TorlabInputError("give either --reference or --calibration-constant",
                               key="--calibration-constant")
    out["calibration_rows"] = []
    if out.get("calibration") is None and const is not None:
        out["calibration"] = Calibration(parse_calibration_constant(
            const, where="--calibration-constant"), source="--calibration-constant")
    elif out.get("calibration") is None and refs:
        out["calibration"], out["calibration_rows"] = calibrate_from_references(refs,
                                                                                tol=out["tol"])
    out["prepared"] = True
    return out


def reduce(path: Path, **opts: Any) -> Reduction:
    """Reduce one log and fit the laws asked for."""
    import pandas as pd

    from torlab.fit.viscosity import fit_optional
    from torlab.reduce.viscometer import reduce_viscometer
    from torlab.yamlio import dump_yaml

    if not opts.get("prepared"):
        opts = prepare(convert_options(OPTIONS, {k: v for k, v in opts.items() if k in OPTIONS},
                                       NAME))
    df, meta = read(path)
    res = reduce_viscometer(df, meta, calibration=opts.get("calibration"), tol=opts["tol"],
                            density_model=opts.get("density_model"))
    T = float(res.falls["temperature_C"].mean()) if "temperature_C" in res.falls else \
        meta.temperature
    fits, notes = _fits(res, opts, T)
    falls = res.falls.copy()
    for ft in fits:
        falls[f"residual_ln_eta_{ft.law}"] = ft.residuals
    tables = {"steps": res.steps, "falls": falls}
    optional: dict[str, tuple[str, ...]] = {}
    files = {}
    if fits:
        fdf = pd.DataFrame([ft.row() for ft in fits])
        tables["fit"], optional["fit"] = fdf, fit_optional(fdf.columns)
        files = {f"lubricant_{ft.law}.yaml": dump_yaml(ft.to_scene_dict()) for ft in fits}
    res.fits = fits  # the figures and the summary row use them
    key = _summary_row(path, meta, res, fits, T, opts)
    return Reduction(NAME, str(path), tables, key, notes + [
        f"{ft.law}: {w}" for ft in fits for w in ft.warnings], meta, res, optional, files)


def _fits(res: Any, opts: dict[str, Any], T: float | None) -> tuple[list[Any], list[str]]:
    from torlab.fit.viscosity import fit_barus, fit_roelands

    p = res.falls["pressure_Pa"].to_numpy()
    eta = res.falls["viscosity_Pa_s"].to_numpy()
    fits, notes = [], list(res.warnings)
    for lw in laws(opts["law"]):
        try:
            if lw == "barus":
                fits.append(fit_barus(p, eta, confidence=opts["confidence"], temperature_C=T))
            else:
                fits.append(fit_roelands(p, eta, eta0=opts.get("eta0"),
                                         fit_eta0=True if opts.get("fit_eta0") else None,
                                         confidence=opts["confidence"], temperature_C=T))
        except TorlabInputError as e:
            if e.key is not None:
                raise
            notes.append(f"no {lw} fit: {e.message}")
    return fits, notes


def _summary_row(path: Path, meta: Any, res: Any, fits: list[Any], T: float | None,
                 opts: dict[str, Any]) -> dict[str, Any]:
    p = res.falls["pressure_Pa"].to_numpy()
    bar = next((ft for ft in fits if ft.law == "barus"), None)
    roe = next((ft for ft in fits if ft.law == "roelands"), None)
    nan = float("nan")
    return {
        "file": path.name, "liquid": meta.liquid, "temperature_C": T if T is not None else nan,
        "n_falls": len(res.falls), "n_steps": len(res.steps),
        "pressure_min_Pa": float(p.min()), "pressure_max_Pa": float(p.max()),
        "calibration_constant_m3_s2": res.calibration.K,
        "calibration_source": res.calibration.source,
        "density_model": opts.get("density_model") or meta.density_model,
        "barus_eta0_Pa_s": bar.eta0 if bar else nan,
        "barus_alpha_1_Pa": bar.alpha if bar else nan,
        "barus_alpha_se_1_Pa": bar.alpha_se if bar else nan,
        "roelands_eta0_Pa_s": roe.eta0 if roe else nan,
        "roelands_Z": roe.Z if roe else nan, "roelands_Z_se": roe.Z_se if roe else nan,
        "roelands_alpha_star_1_Pa": roe.alpha if roe else nan,
        "notes": "; ".join(res.warnings),
    }


def figures(red: Reduction) -> dict[str, Any]:
    """The falls (``falls``) and, with fits, the data against the laws (``fit``)."""
    from torlab.reports.render import plot
    from torlab.reports.viscometer import falls_figure, fit_figure

    res = red.detail
    figs = {"falls": plot(falls_figure, res)}
    if res.fits:
        figs["fit"] = plot(fit_figure, res, res.fits)
    return figs


def collect(reds: list[Reduction], options: dict[str, Any]) -> tuple[dict, dict, dict]:
    """``summary`` (one row per log) and, with reference logs, ``calibration``."""
    import pandas as pd

    rows = []
    for r in reds:
        row = dict(r.key_numbers)
        row["notes"] = "; ".join(r.notes)
        rows.append(row)
    sdf = pd.DataFrame(rows)
    tables = {"summary": sdf}
    optional = {"summary": tuple(c for c in sdf.columns
                                 if c.startswith(("barus_", "roelands_", "temperature")))}
    if options.get("calibration_rows"):
        tables = {"calibration": pd.DataFrame(options["calibration_rows"]), **tables}
    return tables, optional, {}


def display(reds: list[Reduction]) -> list[tuple[str, list[dict], dict]]:
    """Console tables: viscosity per pressure step; the fits."""
    rows, frows = [], []
    for r in reds:
        for st in r.detail.steps.itertuples():
            rows.append({"file": r.label, "p (MPa)": st.pressure_Pa / 1e6,
                         "η (mPa·s)": st.viscosity_Pa_s * 1e3, "falls": st.n_falls,
                         "sd (%)": st.viscosity_rel_sd * 100})
        for ft in r.detail.fits:
            if ft.law == "barus":
                par = (f"α = {ft.alpha * 1e9:.4g} 1/GPa [{ft.alpha_ci[0] * 1e9:.4g}, "
                       f"{ft.alpha_ci[1] * 1e9:.4g}]")
            else:
                par = (f"Z = {ft.Z:.4g} [{ft.Z_ci[0]:.4g}, {ft.Z_ci[1]:.4g}], "
                       f"α* = {ft.alpha * 1e9:.4g} 1/GPa")
            frows.append({"file": r.label, "law": ft.law, "η0 (mPa·s)": ft.eta0 * 1e3,
                          f"parameter [{100 * ft.confidence:g} % CI]": par,
                          "residual sd (ln η)": ft.s, "n": ft.n})
    out = [("Viscosity per pressure step", rows,
            {"p (MPa)": ".1f", "η (mPa·s)": ".4g", "sd (%)": ".2f"})]
    if frows:
        out.append(("Pressure-viscosity fits (Eqs. 5.38-5.39)", frows,
                    {"η0 (mPa·s)": ".4g", "residual sd (ln η)": ".3g"}))
    if reds:
        cal = reds[0].detail.calibration
        out.append((f"calibration constant K = {cal.K:.6g} m^3/s^2 ({cal.source})", [], {}))
    return out


# ------------------------------------------------------------------ protocol section data.visc
def check_section(values: dict[str, Any], resolve: Any) -> dict[str, Any]:
    """Reference logs or a calibration constant, not both; the constant is readable."""
    if values.get("reference") and values.get("calibration_constant") is not None:
        raise ValueError("give either reference or calibration_constant, not both")
    if values.get("calibration_constant") is not None:
        from torlab.parsers.viscometer import parse_calibration_constant

        try:
            parse_calibration_constant(values["calibration_constant"])
        except TorlabInputError as e:
            raise ValueError(f"calibration_constant: {e.message}") from None
    return {}


def section_options(section: Any, ctx: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """The calibration and the steady-part options; no fit here (``fits.lubricants`` fits
    with the section's ``eta0``, ``fit_eta0`` and ``confidence``)."""
    refs = [p for e in section.reference for p in e.resolved]
    opts = {"calibration_constant": section.calibration_constant, "reference": refs or None,
            "tol": section.tol, "density_model": section.density_model, "law": ""}
    return opts, {**opts, "reference": [ctx.sha(p) for p in refs]}


def write_section(dest: Any, labelled: list[tuple[str, Reduction]]) -> dict[str, Any]:
    """``data/visc/<file>_steps.csv``; the summary's calibration constant and falls."""
    for _, red in labelled:
        dest.write_csv(f"data/visc/{red.stem}_steps.csv", red.tables["steps"])
    return {r.label: {"calibration_constant_m3_s2": r.detail.calibration.K,
                      "n_falls": len(r.detail.falls)} for _, r in labelled}
