"""Writing reductions: per-file tables, figures and files; the tables over all files; Excel.

:func:`write_reductions` is what ``torlab reduce`` and every ``torlab <instrument>
reduce`` command write: for each reduced file ``<stem>_<table>.csv``,
``<stem>_<figure>.png`` and its further files (``<stem>_metadata.json`` ...);
then each instrument's tables over all its files (``summary.csv``,
``time_tests.csv`` ...; prefixed with the instrument's name when one run
reduces files of several instruments) and figures; with ``xlsx=True`` one
Excel workbook of every table (``tables.xlsx``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["ReducedFolder", "reduce_to_folder", "write_reductions"]


@dataclass
class ReducedFolder:
    """What :func:`reduce_to_folder` reduced and wrote.

    Attributes
    ----------
    out
        The output folder.
    reductions
        One :class:`~torlab.instruments.reduction.Reduction` per file, in order.
    notes
        What a folder or pattern left out.
    written
        The names of the files written.
    """

    out: Path
    reductions: list[Any]
    notes: list[str] = field(default_factory=list)
    written: list[str] = field(default_factory=list)

    def tables(self) -> list[tuple[str, list[dict[str, Any]], dict[str, str]]]:
        """Each instrument's console tables ``(title, rows, number formats)`` (a title with
        no rows is a line of its own)."""
        from torlab.instruments import get_instrument

        out = []
        for kind in dict.fromkeys(r.instrument for r in self.reductions):
            mine = [r for r in self.reductions if r.instrument == kind]
            out += get_instrument(kind).impl().display(mine)
        return out


def reduce_to_folder(inputs: Sequence[str | os.PathLike[str]], out: str | os.PathLike[str],
                     instrument: str | None = None, *, force: bool = False, xlsx: bool = False,
                     figures: bool = True, formats: Any = None, every_file: bool = False,
                     what: str = "input", command: str | None = None,
                     **options: Any) -> ReducedFolder:
    """Reduce files, folders and patterns and write every result into ``out``.

    Folders and patterns give the files detected as ``instrument`` (any instrument when
    None; every data file with ``every_file``); options are converted and prepared once
    (:func:`~torlab.instruments.reduce_batch`); files are reduced on the executor in use.
    Written through an :class:`~torlab.outputs.OutputDir` (atomic; earlier results only
    replaced with ``force``) with the files the options read among its inputs.
    """
    from torlab.instruments import expand_inputs, get_instrument, is_instrument, reduce_batch
    from torlab.outputs import OutputDir
    from torlab.reports.render import parse_formats

    fmts = parse_formats(formats)
    keep = None if every_file else \
        is_instrument(get_instrument(instrument).name if instrument else None)
    files, notes = expand_inputs(list(inputs), what, keep)
    reds, prepared = reduce_batch(files, instrument, **options)
    extra = [p for o in prepared.values() for p in _option_files(o)]
    dest = OutputDir(out, force=force, inputs=[*files, *extra], command=command)
    with dest:
        written = write_reductions(dest, reds, prepared, xlsx=xlsx, formats=fmts,
                                   figures=figures)
    return ReducedFolder(Path(out), reds, notes, written)


def _option_files(opts: dict[str, Any]) -> list[Path]:
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


def _unique_stems(reds: list[Any]) -> list[str]:
    stems: list[str] = []
    for r in reds:
        s = r.stem
        while s in stems:
            s += "_"
        stems.append(s)
    return stems


def write_reductions(dest: Any, reds: list[Any], options: dict[str, dict[str, Any]] | None = None,
                     *, figures: bool = True, xlsx: bool = False,
                     formats: Any = None) -> list[str]:
    """Write reductions into an :class:`~torlab.outputs.OutputDir` (staged; the caller commits).

    Parameters
    ----------
    dest
        The output folder.
    reds
        :class:`~torlab.instruments.reduction.Reduction` objects.
    options
        Instrument name -> the (prepared) options of its reductions, for the
        tables over all files (the viscometer's calibration rows).
    figures
        Write figures.
    formats
        Their file formats (default PNG; :data:`torlab.reports.render.FORMATS`).
    xlsx
        Also write ``tables.xlsx``: one sheet per table (needs openpyxl).

    Returns
    -------
    list of str
        The names of the files written.
    """
    from torlab.instruments import get_instrument

    options = options or {}
    written: list[str] = []
    sheets: dict[str, Any] = {}
    figs: list[tuple[str, Any]] = []
    for red, stem in zip(reds, _unique_stems(reds), strict=True):
        for name, df in red.tables.items():
            fn = f"{stem}_{name}.csv"
            dest.write_csv(fn, df, allow_missing=red.optional.get(name, ()))
            written.append(fn)
            sheets[f"{stem}_{name}"] = df
        for name, content in red.files.items():
            fn = f"{stem}_{name}"
            if isinstance(content, (dict, list)):
                dest.write_json(fn, content)
            else:
                dest.write_text(fn, str(content))
            written.append(fn)
        if figures:
            for name, fig in red.plots().items():
                figs.append((f"{stem}_{name}" if name else stem, fig))
    kinds = list(dict.fromkeys(r.instrument for r in reds))
    for kind in kinds:
        mine = [r for r in reds if r.instrument == kind]
        impl = get_instrument(kind).impl()
        tables, optional, figs_all = impl.collect(mine, options.get(kind, {}))
        pre = "" if len(kinds) == 1 else f"{kind}_"
        for name, df in tables.items():
            dest.write_csv(f"{pre}{name}.csv", df, allow_missing=optional.get(name, ()))
            written.append(f"{pre}{name}.csv")
            sheets[f"{pre}{name}"] = df
        if figures:
            figs += [(f"{pre}{name}", fig) for name, fig in figs_all.items()]
    if figs:
        from torlab.reports.render import parse_formats, write_figures

        names, _ = write_figures(dest, figs, parse_formats(formats))
        written += names
    if xlsx:
        dest.write_xlsx("tables.xlsx", sheets)
        written.append("tables.xlsx")
    return written

