"""``torlab reduce``: any instrument's files, the instrument detected from each file."""

from pathlib import Path
from typing import Annotated

import typer

from torlab.cli._common import (
    ForceOpt,
    FormatsOpt,
    JobsOpt,
    NoPlotOpt,
    OutOpt,
    QuietOpt,
    SchedulerOpt,
    XlsxOpt,
)


def _as_help() -> str:
    """``--as``: the registry's instruments and their other names."""
    from torlab.instruments import REGISTRY

    names = [i.name + (f" (or {', '.join(i.aliases)})" if i.aliases else "")
             for i in REGISTRY.values()]
    return (f"Read every file as this instrument: {', '.join(names)} (default: detected from "
            "each file's first lines).")


_AS_HELP = _as_help()


def register(root: typer.Typer) -> None:
    """Add the ``reduce`` command to the root app."""
    root.command("reduce")(reduce_cmd)


def reduce_cmd(
    inputs: Annotated[list[Path], typer.Argument(
        metavar="FILE_OR_FOLDER...", help="Instrument files, folders of them, or patterns such as "
        "'exports/*.txt' (expanded by torlab, also where the shell does not).")],
    out: OutOpt,
    as_: Annotated[str | None, typer.Option(
        "--as", help=_AS_HELP)] = None,
    option: Annotated[list[str] | None, typer.Option(
        "--option", "-O", help="An option of the instrument's reduction as NAME=VALUE, e.g. "
        "'window=20 um' (repeatable; 'torlab reduce --list' names them).")] = None,
    after_application: Annotated[bool, typer.Option(
        "--after-application", help="PCS: analyse every timed step as a time test after "
        "application (default: only steps that mark an application).")] = False,
    list_: Annotated[bool, typer.Option("--list", help="List the instruments, what they read and "
                                        "their options, and exit.", is_eager=True,
                                        callback=lambda v: _list() if v else None)] = False,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    no_plot: NoPlotOpt = False,
    formats: FormatsOpt = None,
    jobs: JobsOpt = None,
    scheduler: SchedulerOpt = None,
    quiet: QuietOpt = False,
) -> None:
    """Reduce files of any instrument; the instrument is detected from each file and said.

    Each file (folders and patterns expanded) is read as the instrument its first lines
    show (or --as), reduced as its own command would ('torlab hpt reduce', 'torlab mtm
    reduce' ...) and written to OUT: '<name>_<table>.csv', figures, and per instrument
    'summary.csv' (prefixed with the instrument when several are mixed); with --xlsx every
    table in 'tables.xlsx'.
    """
    from torlab.cli._reduce import reduce_command
    from torlab.errors import TorlabInputError

    opts: dict[str, object] = {}
    for it in option or []:
        if "=" not in it:
            raise TorlabInputError(f"{it!r}: write NAME=VALUE, e.g. 'window=20 um'", key="--option")
        k, v = (s.strip() for s in it.split("=", 1))
        opts[k.replace("-", "_")] = v
    if after_application:
        opts["after_application"] = True
    reduce_command(inputs, out, instrument=as_, force=force, xlsx=xlsx, options=opts,
                   what="instrument", formats=formats, jobs=jobs, scheduler=scheduler,
                   quiet=quiet, no_plot=no_plot)


def _list() -> None:
    from torlab.cli._common import console
    from torlab.instruments import REGISTRY

    c = console()
    for inst in REGISTRY.values():
        alias = f" (also: {', '.join(inst.aliases)})" if inst.aliases else ""
        c.print(f"[bold]{inst.name}[/bold]{alias}: {inst.title} — {inst.files}")
        for k, o in inst.options.items():
            d = "" if o.default is None else f" \\[default {o.shown_default()}]"
            c.print(f"    {k}: {o.help}{d}")
    raise typer.Exit(0)
