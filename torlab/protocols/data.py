"""The reduce stage of a protocol: every ``data:`` section through the instrument registry.

Each section names an instrument of :data:`torlab.instruments.REGISTRY`
(``hpt`` -> ``hpt``, ``mtm`` -> ``pcs``, ``optical`` -> ``optical``, ``visc``
-> ``visc``); its files are reduced exactly as ``torlab <instrument> reduce``
reduces them, with the section's options, each result cached by the file's
SHA-256 and the options.  The reduced tables go to ``data/``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from torlab.protocols.context import RunContext

__all__ = ["SECTION_INSTRUMENT", "reduce_data", "section_options"]

#: data section -> registry instrument
SECTION_INSTRUMENT = {"hpt": "hpt", "mtm": "pcs", "optical": "optical", "visc": "visc"}


def section_options(ctx: RunContext, section: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """The reduction options of a data section, and their JSON-able cache key."""
    d = getattr(ctx.p.data, section)
    if section == "hpt":
        spec = d.compliance_spec
        comp: Any = None if spec is None else spec[1]
        key = None if spec is None else list(spec)
        if spec is not None and spec[0] == "file":
            from torlab.reduce.hpt import RigCompliance

            # named as written in the protocol (relative to its folder): the reduced tables
            # and the fits carry that name, not a path of this machine
            comp = RigCompliance.from_file(spec[1], name=d.compliance)
            key = ["file", ctx.sha(spec[1]), d.compliance]
        return ({"window": d.window, "source": d.source, "compliance": comp},
                {"window": d.window, "source": d.source, "compliance": key})
    if section == "mtm":
        opts = {"family": d.instrument, **d.time_test.options(),
                "after_application": True if ctx.p.reports.time_test is not None else None}
        return opts, opts
    if section == "optical":
        opts = {"window": d.window, "symmetry_tolerance": d.symmetry_tolerance,
                "symmetry_abs": d.symmetry_abs}
        return opts, opts
    refs = [p for e in d.reference for p in e.resolved]
    opts = {"calibration_constant": d.calibration_constant, "reference": refs or None,
            "tol": d.tol, "density_model": d.density_model, "law": ""}
    return opts, {**opts, "reference": [ctx.sha(p) for p in refs]}


def reduce_data(ctx: RunContext) -> None:
    """Reduce every data section's files (cached) and write ``data/``."""
    from torlab.instruments import get_instrument, prepare_options

    for section, name in SECTION_INSTRUMENT.items():
        if getattr(ctx.p.data, section) is None:
            continue
        inst = get_instrument(name)
        opts, key = section_options(ctx, section)
        prepared = prepare_options(inst, {k: v for k, v in opts.items() if v is not None})
        files = ctx.lp.data_files(section)
        parts = [{"sha": ctx.sha(f), "name": f.name, "options": key} for f in files]
        reds = ctx.cached_map(section, _reduce_task,
                              [(pt, (name, f, prepared, section)) for pt, f in
                               zip(parts, files, strict=True)], f"{section}: reducing files",
                              uses=(), short=True)  # no optimiser, no matplotlib: loaded meanwhile
        for red, pt in zip(reds, parts, strict=True):
            ctx.keys[id(red)] = ctx.cache.key(section, **pt)
        ctx.reductions[section] = reds
        _WRITERS[section](ctx, reds)


def _reduce_task(job: tuple[str, Path, dict[str, Any], str]) -> Any:
    """Reduce one data file with its section's prepared options (an executor task)."""
    from torlab.instruments import get_instrument

    name, f, prepared, section = job
    red = get_instrument(name).impl().reduce(f, **prepared)
    red.detected = f"protocol data.{section}"
    return red


def _write_hpt(ctx: RunContext, reds: list[Any]) -> None:
    import pandas as pd

    rows = [r.detail.summary() for r in reds]
    ctx.dest.write_csv("data/hpt_summary.csv", pd.DataFrame(rows),
                       allow_missing=("applied_amount", "temperature_C"))
    ctx.data_summary["hpt"] = {"files": len(rows),
                               "f_window": {r["file"]: r["f_window"] for r in rows}}


def _write_mtm(ctx: RunContext, reds: list[Any]) -> None:
    import pandas as pd

    steps = []
    for label, red in ctx.labelled("mtm"):
        steps.append(red.detail.steps.assign(label=label))
        for kind, cdf in red.detail.curves.items():
            ctx.dest.write_csv(f"data/mtm/{red.stem}_{kind}.csv", cdf,
                               allow_missing=red.optional.get(kind, ()))
    sdf = pd.concat(steps, ignore_index=True)
    ctx.dest.write_csv("data/mtm_steps.csv", sdf, allow_missing=tuple(
        c for c in sdf.columns if c not in ("step", "n_rows", "first_line", "last_line")))
    ctx.data_summary["mtm"] = {"files": len(reds),
                               "timed_steps": sum(len(r.detail.time_tests) for r in reds)}


def _write_optical(ctx: RunContext, reds: list[Any]) -> None:
    import pandas as pd

    from torlab.reduce.optical import SUMMARY_OPTIONAL

    rows = []
    for red in reds:
        ctx.dest.write_csv(f"data/optical/{red.stem}_points.csv", red.tables["points"],
                           allow_missing=red.optional["points"])
        rows.append(red.detail.summary())
    ctx.dest.write_csv("data/optical_summary.csv", pd.DataFrame(rows),
                       allow_missing=SUMMARY_OPTIONAL)
    ctx.data_summary["optical"] = {
        r["file"]: {"test": r["test"], "n_conditions": r["n_conditions"],
                    "symmetric": r["symmetric"]} for r in rows}


def _write_visc(ctx: RunContext, reds: list[Any]) -> None:
    for red in reds:
        ctx.dest.write_csv(f"data/visc/{red.stem}_steps.csv", red.tables["steps"])
    ctx.data_summary["visc"] = {
        r.label: {"calibration_constant_m3_s2": r.detail.calibration.K,
                  "n_falls": len(r.detail.falls)} for r in reds}


_WRITERS = {"hpt": _write_hpt, "mtm": _write_mtm, "optical": _write_optical, "visc": _write_visc}
