"""The one reduce loop behind ``torlab reduce`` and every ``torlab <instrument> reduce``:
the public API's :func:`torlab.api.reduce_to_folder`, its errors said with the command's
own option names, its tables printed."""

from pathlib import Path
from typing import Any

from torlab.cli._common import command_line, console, print_table
from torlab.errors import TorlabInputError

__all__ = ["reduce_command", "show_reductions"]


def _flag(key: str | None, flags: dict[str, str] | None) -> str | None:
    """The command-line spelling of an option error's key: the command's flag
    (``flags``), or ``--option <name>`` for ``torlab reduce`` (``flags`` None)."""
    if key is None or key.startswith("-"):
        return None
    if flags is None:
        return f"--option {key}"
    return None if "." in key else flags.get(key, "--" + key.replace("_", "-"))


def reduce_command(inputs: list[Path], out: Path, *, instrument: str | None, force: bool,
                   options: dict[str, Any], xlsx: bool = False, what: str = "input",
                   every_file: bool = False, flags: dict[str, str] | None = None,
                   formats: str | None = None, jobs: int | None = None,
                   scheduler: str | None = None, quiet: bool = False,
                   no_plot: bool = False) -> list[Any]:
    """Reduce the inputs through the public API, write and print the results.

    Option errors are reported with their command-line spelling: the command's flag
    (``flags``: option name -> ``--flag``), or ``--option window`` (``torlab reduce``).
    Files are reduced and figures drawn on the executor of ``--jobs``/``--scheduler``
    (:mod:`torlab.parallel`), with progress bars unless ``--quiet``; figures in
    ``--formats`` (none with ``--no-plot``).
    """
    from torlab.api import reduce_to_folder
    from torlab.cli._common import session

    with session(jobs, scheduler, quiet):
        try:
            res = reduce_to_folder(inputs, out, instrument, force=force, xlsx=xlsx,
                                   figures=not no_plot, formats=formats, every_file=every_file,
                                   what=what, command=command_line(), **options)
        except TorlabInputError as e:
            flag = _flag(e.key, flags)
            if flag is None or e.path is not None:
                raise
            raise TorlabInputError(e.message, key=flag) from None
    show_reductions(res)
    return res.reductions


def show_reductions(res: Any) -> None:
    """Print each instrument's tables, the detections, the notes and where the files went."""
    c = console()
    for title, rows, fmts in res.tables():
        if rows:
            print_table(rows, title=title, formats=fmts)
        else:
            c.print(title)
    reds = res.reductions
    for r in reds:
        if not r.detected.startswith("--as"):
            c.print(f"{r.label}: read as {r.instrument} ({r.detected})")
    for n in res.notes:
        c.print(f"[yellow]note[/yellow] {n}")
    for r in reds:
        for w in r.notes:
            c.print(f"[yellow]note[/yellow] {r.label}: {w}")
    c.print(f"wrote {len(res.written)} files ({len(reds)} input{'s' if len(reds) != 1 else ''}) "
            f"to {res.out}")
