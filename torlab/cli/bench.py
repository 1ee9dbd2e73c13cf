"""``torlab bench``: speed against error of every numerical choice, measured on this machine."""

from typing import Annotated, Any

import typer

from torlab.cli._common import ForceOpt, OutOpt, QuietOpt, command_line, console, print_renderable


def register(root: typer.Typer) -> None:
    """Add the ``bench`` command to the root app."""
    root.command("bench")(bench_cmd)


def bench_cmd(
    out: OutOpt,
    quick: Annotated[bool, typer.Option("--quick", help="Reduced set (under a minute; what CI "
                                        "runs).")] = False,
    only: Annotated[list[str] | None, typer.Option(
        "--only", help="Run only this benchmark (repeat, or a comma list): hertz, fastsim, "
        "temperature, asperity, loadshare, optical, ... (the modules of torlab/bench/).")] = None,
    campaign: Annotated[int | None, typer.Option(
        "--campaign", metavar="N", help="Instead: how a protocol run grows with the campaign. "
        "Builds the 1x, 4x, 16x ... N x virtual Paper C campaigns (torlab synth hpt seeds "
        "1..N, paper_c's settings), runs each with torlab run cold, warm and with one log "
        "added, and writes the table (time, CPU, peak memory, report size, growth "
        "exponents, the peak memory's baseline and cost per log) to OUT/campaign.md "
        "and campaign.csv.", min=1)] = None,
    campaign_data: Annotated[str | None, typer.Option(
        "--campaign-data", metavar="DIR", help="With --campaign: build the campaigns in DIR "
        "and keep them (reused by the next run); default a temporary folder.")] = None,
    jobs: Annotated[int, typer.Option("--jobs", "-j", help="With --campaign: torlab run "
                                      "--jobs.", min=1)] = 2,
    fit_figures: Annotated[str | None, typer.Option(
        "--fit-figures", metavar="WHICH", help="With --campaign: torlab run --fit-figures "
        "(auto, all, warned, none).")] = None,
    force: ForceOpt = False,
    quiet: QuietOpt = False,
) -> None:
    """Measure time against error for each numerical choice against its reference.

    Runs every benchmark module of torlab.bench (or those named by --only),
    prints the tables, and writes OUT/bench.csv, OUT/bench.md (the table with
    the machine and the command) and OUT/plots/<component>.png (time against
    error, log-log, default marked). A benchmark that fails becomes a FAILED
    row; the others still run and the exit code is 1.
    """
    from rich.console import Console

    from torlab.bench.runner import run_benchmarks, select_components, write_bench_outputs
    from torlab.outputs import OutputDir
    from torlab.progress import Progress, enabled_for

    cmd = command_line()
    dest = OutputDir(out, force=force, command=cmd)  # refuses an occupied folder before the run
    if campaign is not None:
        _campaign(dest, out, campaign, campaign_data, jobs, quiet, fit_figures)
        return
    err = Console(stderr=True, highlight=False, soft_wrap=True)
    with Progress(enabled_for(quiet)) as prog, \
            prog.task("benchmark modules", len(select_components(only))) as advance:
        def say(m: str) -> None:
            with prog.pause():
                err.print(m)
            if not m.endswith("..."):
                advance()

        result = run_benchmarks(quick=quick, only=only, progress=say)
    try:
        written = write_bench_outputs(result, dest, cmd)
    except BaseException:
        dest.abort()
        raise
    dest.commit()
    _print_tables(result)
    console().print(f"wrote {', '.join(n for n in written if not n.startswith('plots/'))} and "
            f"{sum(n.startswith('plots/') for n in written)} plot(s) to {out} "
            f"({result.wall_time_s:.1f} s)")
    if result.failed:
        typer.echo(f"error: benchmark(s) failed: {', '.join(result.failed)} (the FAILED rows "
                   f"of {out}/bench.md say why)", err=True)
        raise typer.Exit(1)


def _campaign(dest: Any, out: Any, n: int, data: str | None, jobs: int, quiet: bool,
              fit_figures: str | None = None) -> None:
    """``torlab bench --campaign N``: the campaign table (:mod:`torlab.bench.campaign`)."""
    from rich.console import Console

    from torlab.bench.campaign import campaign_table, run_campaigns
    from torlab.bench.runner import machine_info

    err = Console(stderr=True, highlight=False, soft_wrap=True)
    machine = machine_info()
    extra = ("--fit-figures", fit_figures) if fit_figures is not None else ()
    try:
        if fit_figures is not None:
            from torlab.protocols.context import check_fit_figures

            check_fit_figures(fit_figures)
        rows = run_campaigns(n, jobs=jobs, data_dir=data, extra_args=extra,
                             progress=None if quiet else lambda m: err.print(m))
        table = campaign_table(rows)
        head = "\n".join(f"- {k}: {v}" for k, v in machine.items())
        dest.write_text("campaign.md", f"# torlab bench --campaign {n} --jobs {jobs}"
                        f"{''.join(' ' + a for a in extra)}\n\n{head}\n\n{table}")
        dest.write_csv("campaign.csv", {
            "size": [r.size for r in rows], "kind": [r.kind for r in rows],
            "wall_s": [r.wall_s for r in rows], "cpu_s": [r.cpu_s for r in rows],
            "peak_rss_MB": [r.peak_rss_mb for r in rows], "load": [r.load for r in rows],
            **{k: [r.counts.get(k, float("nan")) for r in rows]
               for k in ("logs", "sets", "curves", "figures", "report_html_mb", "output_files")},
            **{f"{k}_s": [r.timing.get(k, float("nan")) for r in rows]
               for k in ("compute", "figures", "io", "total")}},
            allow_missing=("compute_s", "figures_s", "io_s", "total_s"))
    except BaseException:
        dest.abort()
        raise
    dest.commit()
    console().print(table)
    console().print(f"wrote campaign.md, campaign.csv to {out}")


def _print_tables(result: Any) -> None:
    """One rich table per component: variant, default, time, error, time / default."""
    from rich.table import Table

    from torlab.bench.runner import display_rows

    shown = display_rows(result)
    comps: list[str] = []
    for r in result.rows:
        if r.component not in comps:
            comps.append(r.component)
    for comp in comps:
        idx = [i for i, r in enumerate(result.rows) if r.component == comp]
        refs = {result.rows[i].reference for i in idx}
        units = {result.rows[i].unit_of_work for i in idx}
        caption = []
        if len(units) == 1:
            caption.append(f"time per {units.pop()}")
        if len(refs) == 1 and next(iter(refs)):
            caption.append(f"error against {refs.pop()}")
        t = Table(title=comp, caption="; ".join(caption) or None, title_justify="left",
                  caption_justify="left")
        t.add_column("variant", overflow="fold")
        t.add_column("default", justify="center")
        t.add_column("time", justify="right")
        t.add_column("error", justify="right")
        t.add_column("time / default", justify="right")
        if len({result.rows[i].reference for i in idx}) > 1:
            t.add_column("reference", overflow="fold")
        for i in idx:
            r, d = result.rows[i], shown[i]
            style = "red" if r.extra.get("status") == "failed" else ("bold" if r.default else None)
            cells = [d["variant"], d["default"], d["time"], d["error"], d["time / default"]]
            if len(t.columns) == 6:
                cells.append(d["reference"])
            t.add_row(*cells, style=style)
        print_renderable(t)
