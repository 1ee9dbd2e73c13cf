"""Shared pieces of the CLI: console, option types, value-list parsing, tables."""

import shlex
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer

from torlab.grids import parse_values

__all__ = [
    "ForceOpt",
    "FormatsOpt",
    "HoldAboveOpt",
    "JobsOpt",
    "OutOpt",
    "QuietOpt",
    "SchedulerOpt",
    "XlsxOpt",
    "command_line",
    "console",
    "hold_above_hint",
    "option_keys",
    "parse_values",
    "print_renderable",
    "print_table",
    "print_theory_error",
    "require_files",
    "session",
]

OutOpt = Annotated[Path, typer.Option("-o", "--out", help="Output folder (created; must not "
                                      "hold earlier results unless --force).")]
ForceOpt = Annotated[bool, typer.Option("--force", help="Replace torlab's earlier results in "
                                        "the output folder.")]
XlsxOpt = Annotated[bool, typer.Option("--xlsx", help="Also write tables.xlsx: every table as a "
                                       "sheet of one Excel workbook (needs openpyxl: pip install "
                                       "'torlab\\[xlsx]').")]  # \\[: rich would read [xlsx] as markup
FormatsOpt = Annotated[str | None, typer.Option(
    "--formats", metavar="FORMATS", help="Figure formats, comma-separated: png (default), svg, "
    "pdf; e.g. 'png,svg'.")]
JobsOpt = Annotated[int | None, typer.Option(
    "--jobs", "-j", metavar="N", help="Worker processes for independent tasks (default: "
    "$TORLAB_JOBS, else every usable core; 1: serial, in this process).")]
SchedulerOpt = Annotated[str | None, typer.Option(
    "--scheduler", metavar="ADDRESS", help="Run the tasks on a Dask cluster instead "
    "(tcp://host:8786; needs pip install 'torlab[dask]'; see docs/performance.md).")]
NoPlotOpt = Annotated[bool, typer.Option("--no-plot", help="Write the tables only (no figure: "
                                         "no plotting library is loaded).")]
QuietOpt = Annotated[bool, typer.Option(
    "--quiet", "-q", help="No progress bars (they are never shown when the output is not a "
    "terminal).")]


MethodOpt = Annotated[str | None, typer.Option(
    "--method", metavar="METHOD", help="Boundary method: fastsim (FASTSIM corrected by "
    "Kalker's exact theory), fastsim-kalker (Kalker's FASTSIM, the thesis's model), exact "
    "(Kalker's exact theory: slow), auto (fastsim where its theory error is below the band's "
    "half-width, else exact); default the scene's grid: method (fastsim).")]


HoldAboveOpt = Annotated[bool, typer.Option(
    "--hold-above", help="Above the largest amount the HPT series tested, hold the layer of "
    "that amount (said in the notes) instead of refusing: the layer is not known there.")]


@contextmanager
def hold_above_hint() -> Iterator[None]:
    """Say how to hold the layer above the tested amounts with the command's option
    (``--hold-above``), not with the library's keyword (``above='hold'``)."""
    from torlab.model.amount import AboveTestedError

    try:
        yield
    except AboveTestedError as e:
        key = "--" + e.key.replace("_", "-") if e.key and not e.key.startswith("-") else e.key
        raise e.with_hint("--hold-above", key=key) from None


def print_theory_error(summary: dict) -> None:
    """The boundary method and its theory error (beside the band, never in it)."""
    m = summary.get("method")
    te = summary.get("theory_error")
    if not m:
        return
    c = console()
    how = f" (auto: {m['why']})" if m.get("asked") == "auto" else ""
    c.print(f"boundary method: [bold]{m['method']}[/bold]{how}")
    if te and te.get("theory_error_95") is not None:
        band = ""
        if te.get("band_half_width_min") is not None:
            band = f"; the band's half-width is {te['band_half_width_min']:.2g} or more"
        c.print(f"theory error (95 %, against Kalker's exact theory, not in the band): "
                f"{te['theory_error_95']:.2g} in mu at most ({100 * te['relative_95']:.2g} % "
                f"of mu){band}")


def console() -> Any:
    """A rich console on stdout (imported lazily)."""
    from rich.console import Console

    return Console(highlight=False, soft_wrap=True)


def print_renderable(renderable: Any) -> None:
    """Print a rich table (or other renderable) on stdout, never wrapped to fit a width
    the output does not have.

    On a terminal the table fits the terminal, as rich draws it.  When the output is
    not a terminal (a pipe, a log, CI) there is no width to fit: rich would assume 80
    columns and fold long cells (file names) into pieces, so the console is widened
    to the table's natural width and every cell stays on one line.
    """
    from rich.measure import Measurement

    c = console()
    if not c.is_terminal:
        natural = Measurement.get(c, c.options.update_width(1 << 16), renderable).maximum
        c.width = max(c.width, natural)
    c.print(renderable)


def command_line() -> str:
    """The command line as typed (for manifests and reports).

    Uses the arguments the root command was invoked with (set by
    ``torlab.cli``), so it is right under ``CliRunner`` or from a notebook,
    not only from a shell; falls back to ``sys.argv``.
    """
    from torlab.cli import _STATE

    argv = _STATE.get("argv")
    if argv is None:
        argv = sys.argv[1:]
    return " ".join(shlex.quote(str(a)) for a in ["torlab", *argv])


def require_files(paths: Sequence[Path], what: str = "input", keep: Any = None) -> list[Path]:
    """The files named: files as they are, folders and patterns (``logs/*.txt``) expanded
    by torlab (:func:`torlab.instruments.expand_inputs`, ``keep`` filtering what a folder
    or pattern gives); one clear error for a missing file or no file at all."""
    from torlab.instruments import expand_inputs

    files, notes = expand_inputs(paths, what, keep)
    if notes:
        c = console()
        for n in notes:
            c.print(f"[yellow]note[/yellow] {n}")
    return files


def print_table(rows: Sequence[dict[str, Any]], title: str = "", formats: dict[str, str] | None = None) -> None:
    """Print dict rows as a rich table (columns from the first row)."""
    from rich.table import Table

    if not rows:
        return
    formats = formats or {}
    t = Table(title=title or None, show_lines=False)
    cols = list(rows[0].keys())
    for c in cols:
        t.add_column(c, overflow="fold")
    for r in rows:
        cells = []
        for c in cols:
            v = r.get(c, "")
            f = formats.get(c)
            if f and isinstance(v, (int, float)):
                cells.append(format(v, f))
            elif isinstance(v, float):
                cells.append(f"{v:.4g}")
            else:
                cells.append(str(v))
        t.add_row(*cells)
    print_renderable(t)


@contextmanager
def session(jobs: int | None = None, scheduler: str | None = None, quiet: bool = False,
            parallel: bool = True) -> Iterator[Any]:
    """A command's executor (``--jobs``, ``--scheduler``; :mod:`torlab.parallel`) and its
    progress bars (``--quiet``; :mod:`torlab.progress`), in that order: worker processes
    are started before any progress-bar thread.  Yields the executor."""
    from torlab.parallel import SerialExecutor, get_executor
    from torlab.progress import Progress, enabled_for

    ex = get_executor(jobs, scheduler) if parallel else SerialExecutor()
    with ex, Progress(enabled_for(quiet)):
        yield ex


@contextmanager
def option_keys(command: Any) -> Iterator[None]:
    """Say a library error keyed by a keyword argument the command passes on (``skip``,
    ``track_radius``) with the command's own option (``--skip``, ``--track-radius``).

    ``command`` is the typer command function; its parameters and their option
    names (``typer.Option("--as")``, else typer's ``--name-with-dashes``) give the
    flags.  Errors keyed otherwise, or naming a file, pass unchanged."""
    from torlab.errors import TorlabInputError

    try:
        yield
    except TorlabInputError as e:
        if e.path is not None or not e.key or type(e) is not TorlabInputError:
            raise
        flag = _option_flags(command).get(e.key)
        if flag is None:
            raise
        raise TorlabInputError(e.message, key=flag) from None


def _option_flags(command: Any) -> dict[str, str]:
    """Parameter name -> its long option of a typer command function (arguments left out)."""
    import typing

    flags = {}
    for name, hint in typing.get_type_hints(command, include_extras=True).items():
        info = next((m for m in getattr(hint, "__metadata__", ()) if hasattr(m, "param_decls")),
                    None)
        if info is None or type(info).__name__ != "OptionInfo":
            continue
        decls = [d for d in (info.param_decls or ()) if d.startswith("--")]
        flags[name] = decls[0].split("/")[0] if decls else "--" + name.replace("_", "-")
    return flags
