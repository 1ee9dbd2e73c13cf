"""The one reduce loop behind ``torlab reduce`` and every ``torlab <instrument> reduce``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from torlab.cli._common import command_line, console, print_table
from torlab.errors import TorlabInputError

__all__ = ["reduce_command"]


#: option names whose command-line flag is spelt differently
_FLAGS = {"family": "--instrument"}


def _flag(key: str | None) -> str | None:
    if key is None or key.startswith("-") or "." in key:
        return None
    return _FLAGS.get(key, "--" + key.replace("_", "-"))


def _extra_inputs(opts: dict[str, Any]) -> list[Path]:
    """Files the options read (compliance curve, column map, reference logs)."""
    out: list[Path] = []
    for v in opts.values():
        if isinstance(v, Path) and v.is_file():
            out.append(v)
        elif isinstance(v, list) and all(isinstance(x, Path) for x in v):
            out += [x for x in v if x.is_file()]
        elif getattr(v, "path", None) is not None and isinstance(v.path, Path):
            out.append(v.path)
    return out


def reduce_command(inputs: list[Path], out: Path, *, instrument: str | None, force: bool,
                   options: dict[str, Any], xlsx: bool = False, what: str = "input",
                   filter_folders: bool = True, flags: bool = True, formats: str | None = None,
                   jobs: int | None = None, scheduler: str | None = None,
                   quiet: bool = False, no_plot: bool = False) -> list[Any]:
    """Expand the inputs, reduce them through the registry, write and print the results.

    Option errors are reported with their command-line spelling: ``--window``
    (``flags``), or ``--option window`` (``torlab reduce``).  Files are reduced and
    figures drawn on the executor of ``--jobs``/``--scheduler`` (:mod:`torlab.parallel`),
    with progress bars unless ``--quiet``; figures in ``--formats`` (none with ``--no-plot``).
    """
    from torlab.cli._common import session
    from torlab.instruments import (
        expand_inputs,
        get_instrument,
        is_instrument,
        reduce_batch,
    )
    from torlab.instruments.output import write_reductions
    from torlab.outputs import OutputDir
    from torlab.reports.render import parse_formats

    fmts = parse_formats(formats)
    with session(jobs, scheduler, quiet):
        try:
            keep = None if not filter_folders else \
                is_instrument(get_instrument(instrument).name if instrument else None)
            files, notes = expand_inputs(inputs, what, keep)
            reds, prepared = reduce_batch(files, instrument, **options)
        except TorlabInputError as e:
            flag = _flag(e.key) if flags else (None if e.key is None or e.key.startswith("-")
                                               else f"--option {e.key}")
            if flag is None or e.path is not None:
                raise
            raise TorlabInputError(e.message, key=flag) from None
        extra = [p for o in prepared.values() for p in _extra_inputs(o)]
        dest = OutputDir(out, force=force, inputs=[*files, *extra], command=command_line())
        with dest:
            written = write_reductions(dest, reds, prepared, xlsx=xlsx, formats=fmts,
                                       figures=not no_plot)
    show_reductions(reds, notes, out, len(written))
    return reds


def show_reductions(reds: list[Any], notes: list[str], out: Path, n_files: int) -> None:
    """Print each instrument's tables, the detections, the notes and where the files went."""
    from torlab.instruments import get_instrument

    c = console()
    for kind in dict.fromkeys(r.instrument for r in reds):
        mine = [r for r in reds if r.instrument == kind]
        for title, rows, fmts in get_instrument(kind).impl().display(mine):
            if rows:
                print_table(rows, title=title, formats=fmts)
            else:
                c.print(title)
    for r in reds:
        if not r.detected.startswith("--as"):
            c.print(f"{r.label}: read as {r.instrument} ({r.detected})")
    for n in notes:
        c.print(f"[yellow]note[/yellow] {n}")
    for r in reds:
        for w in r.notes:
            c.print(f"[yellow]note[/yellow] {r.label}: {w}")
    c.print(f"wrote {n_files} files ({len(reds)} input{'s' if len(reds) != 1 else ''}) to {out}")
