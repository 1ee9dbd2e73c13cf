"""The reduce stage of a protocol: every ``data:`` section through the instrument registry.

Each section is an instrument's (its :class:`~torlab.instruments.plugin.Command` name:
``mtm`` is the PCS exports); its files are reduced exactly as ``torlab <section>
reduce`` reduces them, with the section's options, each result cached by the file's
SHA-256 and the options.  The reduced tables go to ``data/``.

An instrument module may shape its section with two hooks (beside ``check_section``,
which the schema calls):

* ``section_options(section, ctx) -> (options, cache_key)``: the reduction's options and
  their JSON-able cache key.  Default (:func:`default_options`): the section's options,
  a path list as the files' SHA-256 in the key.
* ``write_section(dest, labelled) -> summary``: write ``data/`` from the ``(label,
  Reduction)`` pairs, return the section's entry of the run summary.  Default
  (:func:`default_write`): every table of every file under ``data/<section>/`` and the
  tables over all files (the instrument's ``collect``) as ``data/<section>_<table>.csv``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from torlab.protocols.context import RunContext

__all__ = ["default_options", "default_write", "reduce_data", "section_options"]


def default_options(section: Any, ctx: RunContext) -> tuple[dict[str, Any], dict[str, Any]]:
    """The section's options, and their cache key (files by their SHA-256)."""
    opts = section.options()
    key = {k: [ctx.sha(p) for p in v] if isinstance(v, list) and v and isinstance(v[0], Path)
           else v for k, v in opts.items()}
    return opts, key


def section_options(ctx: RunContext, section: str) -> tuple[dict[str, Any], dict[str, Any]]:
    """The reduction options of a data section, and their JSON-able cache key."""
    from torlab.instruments import by_command

    impl = by_command(section).impl()
    hook = getattr(impl, "section_options", default_options)
    return hook(getattr(ctx.p.data, section), ctx)


def reduce_data(ctx: RunContext) -> None:
    """Reduce every data section's files (cached) and write ``data/``."""
    from torlab.instruments import by_command, prepare_options
    from torlab.protocols.schema import DATA_SECTIONS

    for section in DATA_SECTIONS:
        if getattr(ctx.p.data, section) is None:
            continue
        inst = by_command(section)
        opts, key = section_options(ctx, section)
        prepared = prepare_options(inst, {k: v for k, v in opts.items() if v is not None})
        files = ctx.lp.data_files(section)
        parts = [{"sha": ctx.sha(f), "name": f.name, "options": key} for f in files]
        reds = ctx.cached_map(section, _reduce_task,
                              [(pt, (inst.name, f, prepared, section)) for pt, f in
                               zip(parts, files, strict=True)], f"{section}: reducing files",
                              uses=(), short=True)  # no optimiser, no matplotlib: loaded meanwhile
        names = ctx.lp.result_names.get(section, {})
        for red, pt, f in zip(reds, parts, files, strict=True):
            ctx.keys[id(red)] = ctx.cache.key(section, **pt)
            if names.get(f, f.stem) != f.stem:  # two files of one name: named by labels
                red.name = names[f]
        ctx.reductions[section] = reds
        write = getattr(inst.impl(), "write_section", None)
        labelled = ctx.labelled(section)
        ctx.data_summary[section] = write(ctx.dest, labelled) if write is not None else \
            default_write(ctx.dest, labelled, section, prepared)


def _reduce_task(job: tuple[str, Path, dict[str, Any], str]) -> Any:
    """Reduce one data file with its section's prepared options (an executor task)."""
    from torlab.instruments import get_instrument

    name, f, prepared, section = job
    red = get_instrument(name).impl().reduce(f, **prepared)
    red.detected = f"protocol data.{section}"
    return red


def default_write(dest: Any, labelled: list[tuple[str, Any]], section: str,
                  options: dict[str, Any]) -> dict[str, Any]:
    """``data/<section>/<file>_<table>.csv`` for every table of every file, and the tables
    over all files as ``data/<section>_<table>.csv``; the summary counts the files."""
    reds = [r for _, r in labelled]
    for red in reds:
        for name, df in red.tables.items():
            dest.write_csv(f"data/{section}/{red.stem}_{name}.csv", df,
                           allow_missing=red.optional.get(name, ()))
    if reds:
        from torlab.instruments import get_instrument

        tables, optional, _ = get_instrument(reds[0].instrument).impl().collect(reds, options)
        for name, df in tables.items():
            dest.write_csv(f"data/{section}_{name}.csv", df,
                           allow_missing=optional.get(name, ()))
    return {"files": len(reds)}
