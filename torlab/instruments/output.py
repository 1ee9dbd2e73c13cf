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

from typing import Any

__all__ = ["write_reductions"]


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

