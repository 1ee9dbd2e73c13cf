"""Shared pieces of the CLI: console, option types, value-list parsing, tables."""

from __future__ import annotations

import shlex
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import typer

from torlab.errors import TorlabInputError

__all__ = [
    "ForceOpt",
    "OutOpt",
    "command_line",
    "console",
    "parse_values",
    "print_table",
    "require_files",
]

OutOpt = Annotated[Path, typer.Option("-o", "--out", help="Output folder (created; must not "
                                      "hold earlier results unless --force).")]
ForceOpt = Annotated[bool, typer.Option("--force", help="Replace torlab's earlier results in "
                                        "the output folder.")]


def console() -> Any:
    """A rich console on stdout (imported lazily)."""
    from rich.console import Console

    return Console(highlight=False, soft_wrap=True)


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


def require_files(paths: Sequence[Path], what: str = "input") -> list[Path]:
    """Check that every path is an existing file; one clear error otherwise."""
    out = []
    for p in paths:
        if not p.exists():
            raise TorlabInputError(f"{what} file not found", path=p)
        if p.is_dir():
            raise TorlabInputError(f"is a folder; give the {what} file(s) in it", path=p)
        if not p.is_file():
            raise TorlabInputError(f"not a regular file (a device, FIFO or socket); give the "
                                   f"{what} file", path=p)
        out.append(p)
    if not out:
        raise TorlabInputError(f"no {what} files given")
    return out


def parse_values(spec: str, kind: str, option: str, quantity: str | None = None) -> Any:
    """Parse ``start:stop:num`` (inclusive, like ``numpy.linspace``) or a comma list.

    Plain numbers are SI; each value may carry its own unit
    (``"10 mm/s:2 m/s:50"``, ``"0.1 %,1 %"``).  ``kind`` is a
    :data:`torlab.units.KINDS` key; with ``quantity`` (a
    :data:`torlab.units.RANGES` key) every value is range-checked.

    Returns
    -------
    numpy.ndarray
        The values in SI units.
    """
    import numpy as np

    from torlab.units import to_si

    s = spec.strip()
    if not s:
        raise TorlabInputError("empty value list", key=option)
    if ":" in s and "," not in s:
        parts = s.split(":")
        if len(parts) != 3:
            raise TorlabInputError(f"{spec!r}: write start:stop:count, e.g. 0:0.05:101", key=option)
        start = to_si(parts[0], kind, where=option)
        stop = to_si(parts[1], kind, where=option)
        try:
            num = int(parts[2])
        except ValueError:
            raise TorlabInputError(f"{spec!r}: the count {parts[2]!r} is not an integer",
                                   key=option) from None
        if num < 1 or num > 100_000:
            raise TorlabInputError(f"{spec!r}: count must be between 1 and 100000", key=option)
        vals = [start, stop]
        out = np.linspace(start, stop, num)
    else:
        vals = [to_si(v, kind, where=option) for v in s.split(",") if v.strip()]
        if not vals:
            raise TorlabInputError(f"{spec!r}: no values", key=option)
        out = np.asarray(vals, dtype=float)
    if quantity is not None:
        from torlab.units import check_range

        for v in vals:
            check_range(quantity, v, where=option)
    return out


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
    console().print(t)
