"""``torlab run``: a test protocol from raw logs to reports."""

from pathlib import Path
from typing import Annotated, Any

import typer

from torlab.cli._common import (
    ForceOpt,
    FormatsOpt,
    JobsOpt,
    QuietOpt,
    SchedulerOpt,
    command_line,
    console,
)


def register(root: typer.Typer) -> None:
    """Add the ``run`` command to the root app."""
    root.command("run")(run_cmd)


def run_cmd(
    protocol: Annotated[Path, typer.Argument(help="Protocol YAML (docs/protocols.md).")],
    out: Annotated[Path | None, typer.Option(
        "-o", "--out", help="Output folder (created; must not hold earlier results unless "
        "--force).")] = None,
    force: ForceOpt = False,
    validate_only: Annotated[bool, typer.Option(
        "--validate-only", help="Only check the protocol (every problem listed) and exit.")]
    = False,
    no_cache: Annotated[bool, typer.Option(
        "--no-cache", help="Recompute everything (do not reuse OUT/.cache).")] = False,
    formats: FormatsOpt = None,
    no_figures: Annotated[bool, typer.Option(
        "--no-figures", help="Draw no figures (the reports keep every number and table; "
        "the protocol's reports.figures: false does the same).")] = False,
    fit_figures: Annotated[str | None, typer.Option(
        "--fit-figures", help="Which fitted sets get a data-against-model figure: auto (all "
        "up to 24 fitted sets, above that those whose fit warned), all, warned or none; the "
        "parameter table holds every set (default the protocol's reports.fit_figures, else "
        "auto).")] = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Run a test protocol: reduce its raw logs, fit its parameter sets and write its reports.

    Writes to OUT: report.html (figures linked), report.md, summary.json (key numbers,
    torlab version, SHA-256 of the protocol and every input), one folder per report with
    figures (PNG; --formats or the protocol's reports.figure_formats for SVG/PDF) and CSV
    tables, data/ (reduced logs), fits/ (parameter files for 'torlab predict').  A re-run
    with --force reuses the unchanged intermediate results and figures cached in
    OUT/.cache.  Independent tasks (files, fits, curves, figures) run on every core
    (--jobs) or a Dask cluster (--scheduler), with the same results.
    """
    from torlab.errors import TorlabInputError
    from torlab.protocols.loader import REPORT_KEYS, load_protocol

    lp = load_protocol(protocol)
    c = console()
    p = lp.protocol
    if validate_only:
        n = len(lp.input_files())
        reports = [k for k in REPORT_KEYS if getattr(p.reports, k) is not None]
        c.print(f"{protocol}: valid protocol '{p.name}' (version {p.version}): {n} input "
                f"files, reports: {', '.join(reports)}")
        return
    if out is None:
        raise TorlabInputError("give the output folder with -o OUT (or --validate-only)",
                               key="--out")
    from torlab.cli._common import session
    from torlab.progress import enabled_for
    from torlab.protocols.runner import run_protocol
    from torlab.reports.render import parse_formats

    fmts = parse_formats(formats) if formats is not None else None
    with session(jobs, scheduler, quiet) as ex:
        res = run_protocol(lp, out, force=force, command=command_line(),
                           progress=enabled_for(quiet), cache=not no_cache, formats=fmts,
                           executor=ex, figures=False if no_figures else None,
                           fit_figures=fit_figures)
    for n in res.notes:
        c.print(f"[yellow]note[/yellow] {n}")
    _print_key_numbers(res.summary)
    c.print(_timing_line(res))
    if res.unchanged:
        c.print(f"nothing changed since the run that wrote {out} (protocol, input files, "
                "options, torlab): its results are current; nothing was rewritten")
        return
    c.print(f"wrote {', '.join(res.sections)} report(s): {out}/report.html, report.md, "
            "summary.json")


def _timing_line(res: Any) -> str:
    """The final line: what was reused, and the command's time split honestly.

    compute: reductions, fits, predictions and the reports' numbers; figures: drawing;
    I/O: reading and writing cache entries, figures and results; the rest: starting
    Python, imports, loading and checking the protocol (from the command's start).  These
    are wall times of the stages: figures drawn on idle workers while the sections were
    computed (said as "n started while computing") are inside compute's time.
    """
    import time

    from torlab.cli import _STATE

    t = dict(res.timing)
    if "t_start" in _STATE:
        t["total"] = time.perf_counter() - _STATE["t_start"]
        t["other"] = max(t["total"] - t["compute"] - t["figures"] - t["io"], 0.0)
    figs = ("figures: not drawn (--no-figures)" if not t.get("figures_on", True) else
            f"figures: {t['figures_reused']} reused, {t['figures_drawn']} drawn"
            f"{_alongside(t.get('figures_ahead', 0))}"
            + (f", {t['files_kept']} unchanged files kept" if t.get("files_kept") else ""))
    return (f"cache: {res.cache_hits} results reused, {res.cache_misses} computed; {figs}; "
            f"{t['total']:.1f} s = "
            f"compute {t['compute']:.1f} s + figures {t['figures']:.1f} s + I/O {t['io']:.1f} s "
            f"+ start-up, imports and checks {t['other']:.1f} s ({t['executor']})")


def _alongside(n: int) -> str:
    return f" ({n} started while computing)" if n else ""


def _print_key_numbers(summary: dict) -> None:
    from torlab.cli._common import print_table

    rep = summary.get("reports", {})
    if "amount" in rep:
        a = rep["amount"]
        rows = [{"product": k, "status": v["status"],
                 "crossing": "" if v.get("crossing_amount") is None else
                 f"{v['crossing_amount']:.3g} {v['amount_unit']}",
                 "interval": "" if v.get("crossing_amount_low") is None else
                 f"[{v['crossing_amount_low']:.3g}, {v['crossing_amount_high']:.3g}]",
                 "mass (mg)": "" if v.get("crossing_mass_mg") is None else
                 f"{v['crossing_mass_mg']:.3g}"} for k, v in a["products"].items()]
        print_table(rows, title=f"Amount where f falls below {a['threshold']:g}")
    if "time_test" in rep:
        rows = [{"composition": k, "minimum": v["minimum"],
                 "recovery (s)": v["recovery_time_s"] if v["recovery_time_s"] is not None else "",
                 "mean after recovery": v["mean_after_recovery"]
                 if v["mean_after_recovery"] is not None else "",
                 "in band": v["in_band"]} for k, v in rep["time_test"]["compositions"].items()]
        print_table(rows, title="Time tests", formats={"minimum": ".4f",
                                                       "mean after recovery": ".4f",
                                                       "recovery (s)": ".0f"})
    if "traction" in rep:
        rows = [{"curve": k, "kind": v["kind"], "μ max": v["mu_max"], "trend": v["trend"]}
                for k, v in rep["traction"]["curves"].items()]
        print_table(rows, title="Traction: trend after saturation (H4.1)",
                    formats={"μ max": ".4f"})
    if "retention" in rep:
        from torlab.reports.retention import crossing_text

        r = rep["retention"]
        pr = r["prediction"]
        rows = [{"band limit": f"{pr[k]['level']:g}", "passes (95 %)": crossing_text(pr[k]),
                 "status": pr[k]["status"]}
                for k in ("passes_to_enter_band", "passes_to_leave_band")]
        law = ", ".join(f"{k} {v['value']:.3g} [{v['low95']:.3g}, {v['high95']:.3g}] {v['unit']}"
                        for k, v in r["parameters"].items())
        print_table(rows, title=f"Retention of {r['product']}: {r['law']} ({law}), "
                    f"{pr['applied']} on {pr['scene']}")
        if "sweep" in r:
            console().print(f"slip sweep: {r['sweep']['verdict']}")
