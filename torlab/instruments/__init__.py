"""The instrument registry: every instrument torlab reads, one module each.

An instrument is one module of this package (what it declares:
:mod:`torlab.instruments.plugin`) and one line of :data:`INSTRUMENTS`.  From
those declarations come detection (:func:`detect`), folder expansion
(:func:`expand_inputs`), options with units and "did you mean"
(:func:`convert_options`), ``torlab reduce`` and the command group ``torlab
<instrument> reduce`` (:mod:`torlab.cli.instruments`), the protocol's ``data:``
sections (:mod:`torlab.protocols.schema`, :mod:`torlab.protocols.data`), and the
reduction loop they all share (:func:`reduce_file`, :func:`reduce_batch`).

The instrument modules declare; they import numerical libraries inside their
functions, so reading the registry (``torlab --help``) stays light.
"""

from __future__ import annotations

import glob
import importlib
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from torlab.errors import TorlabInputError
from torlab.instruments.plugin import HEAD_BYTES, Command, Option, read_head
from torlab.instruments.plugin import convert_options as _convert_options

__all__ = [
    "HEAD_BYTES",
    "INSTRUMENTS",
    "REGISTRY",
    "Command",
    "Instrument",
    "Option",
    "convert_options",
    "detect",
    "expand_inputs",
    "get_instrument",
    "read_file",
    "reduce_batch",
    "reduce_file",
    "reduce_files",
]

#: every instrument torlab reads, in detection order: a file is read by the first whose
#: ``detect`` accepts its first lines
INSTRUMENTS: tuple[str, ...] = (
    # formats with a first line of their own ('# torlab-hpt', 'MTM311 Test Data File' or
    # 'Step 1 started at', '# torlab-optical', '# torlab-visc'): no file is two of them, so
    # their order is the order of the commands, the protocol's data sections and the results
    "torlab.instruments.hpt",
    "torlab.instruments.pcs",
    "torlab.instruments.optical",  # also reads PCS EHD2 exports, but only with --as optical
    "torlab.instruments.visc",
    # recognised from its content (a 'Filename<TAB>' first line and a '[step]' line), a
    # weaker mark than a first line of its own: after those
    "torlab.instruments.trios",
)


@dataclass(frozen=True)
class Instrument:
    """A registry entry: the module that declares the instrument (imported once).

    Its declarations are read through the properties (``name``, ``title``, ``files``,
    ``aliases``, ``options``, ``extensions``, ``command``) and its functions through
    :meth:`impl`.
    """

    module: str

    def impl(self) -> ModuleType:
        """The instrument's module."""
        return importlib.import_module(self.module)

    @property
    def name(self) -> str:
        """Registry name (``--as``)."""
        return self.impl().NAME

    @property
    def title(self) -> str:
        """What the instrument is."""
        return self.impl().TITLE

    @property
    def files(self) -> str:
        """What files it reads."""
        return self.impl().FILES

    @property
    def aliases(self) -> dict[str, dict[str, Any]]:
        """Other names, each with the options it presets (``{"mtm": {"family": "MTM"}}``)."""
        return getattr(self.impl(), "ALIASES", {})

    @property
    def extensions(self) -> tuple[str, ...]:
        """File name endings a folder is searched for."""
        return tuple(self.impl().EXTENSIONS)

    @property
    def also_reads(self) -> tuple[str, ...]:
        """Other instruments whose files its reduction reads (optical: PCS EHD2 exports)."""
        return tuple(getattr(self.impl(), "ALSO_READS", ()))

    @property
    def options(self) -> dict[str, Option]:
        """The reduction's options."""
        return self.impl().OPTIONS

    @property
    def command(self) -> Command | None:
        """Its command group and protocol section (None: reached through ``torlab reduce``)."""
        return getattr(self.impl(), "COMMAND", None)


def _registry(modules: Iterable[str]) -> dict[str, Instrument]:
    out: dict[str, Instrument] = {}
    for m in modules:
        inst = Instrument(m)
        if inst.name in out:  # pragma: no cover - a declaration mistake
            raise ValueError(f"two instruments are named {inst.name!r}")
        out[inst.name] = inst
    return out


#: registry name -> entry, in detection order (:data:`INSTRUMENTS`)
REGISTRY: dict[str, Instrument] = _registry(INSTRUMENTS)


def data_suffixes() -> tuple[str, ...]:
    """File name endings a folder is searched for: every instrument's, once each."""
    return tuple(dict.fromkeys(e.lower() for i in REGISTRY.values() for e in i.extensions))


def by_command(name: str) -> Instrument:
    """The instrument whose command group / protocol section is ``name`` (``"mtm"``)."""
    for inst in REGISTRY.values():
        if inst.command is not None and inst.command.name == name:
            return inst
    raise KeyError(name)


def get_instrument(name: str) -> Instrument:
    """The registry entry of ``name`` or one of its aliases (case-insensitive)."""
    inst, _ = _lookup(name)
    return inst


def _lookup(name: str) -> tuple[Instrument, dict[str, Any]]:
    key = str(name).strip().lower()
    if key in REGISTRY:
        return REGISTRY[key], {}
    for inst in REGISTRY.values():
        if key in inst.aliases:
            return inst, dict(inst.aliases[key])
    from torlab._suggest import did_you_mean

    names = [*REGISTRY, *(a for i in REGISTRY.values() for a in i.aliases)]
    raise TorlabInputError(f"unknown instrument {name!r} (choose {', '.join(REGISTRY)})"
                           f"{did_you_mean(key, names)}", key="--as")


def detect(path: str | os.PathLike[str]) -> tuple[Instrument, str]:
    """Which instrument wrote ``path``, and why (from its first lines).

    Raises
    ------
    TorlabInputError
        No registered format recognises the file.
    """
    p = Path(path)
    if not p.exists():
        raise TorlabInputError("file not found", path=p)
    if p.is_dir():
        raise TorlabInputError("is a folder; give the files in it", path=p)
    head = read_head(p)
    for inst in REGISTRY.values():
        why = inst.impl().detect(head)
        if why:
            return inst, why
    first = next((s.strip() for s in head.splitlines() if s.strip()), "")
    shown = first if len(first) <= 60 else first[:57] + "..."
    raise TorlabInputError(f"torlab does not recognise this file (first line {shown!r}); "
                           f"give the instrument with --as ({', '.join(REGISTRY)})", path=p)


def convert_options(inst: Instrument | str, options: dict[str, Any]) -> dict[str, Any]:
    """Check option names and convert values (unit strings to SI) for ``inst``'s reduction
    (:func:`torlab.instruments.plugin.convert_options`).

    Options not given take their defaults.  Unknown names are errors with a
    "did you mean" suggestion.
    """
    inst = get_instrument(inst) if isinstance(inst, str) else inst
    return _convert_options(inst.options, options, inst.name)


def expand_inputs(items: Iterable[str | os.PathLike[str]], what: str = "input",
                  keep: Any = None) -> tuple[list[Path], list[str]]:
    """Files named by ``items``: files as they are, folders and glob patterns expanded.

    torlab expands folders and patterns itself, so ``torlab reduce data/*.txt``
    works where the shell does not expand them (Windows).  A folder gives its
    data files (``.txt``, ``.csv``, ``.tsv``, ``.dat``, ``.log``, not hidden,
    sorted); a pattern (``*``, ``?``, ``[...]``, ``**`` for sub-folders) its
    matches.  ``keep(path) -> bool`` filters the files a folder or pattern
    gives (e.g. "is detected as this instrument"); named files are always kept.

    Returns
    -------
    files, notes
        The files (each once, in order) and notes on what a folder or pattern
        left out.

    Raises
    ------
    TorlabInputError
        A name that is neither a file, a folder nor a pattern with matches, or
        no file at all.
    """
    out: list[Path] = []
    notes: list[str] = []
    for it in items:
        p = Path(it)
        if p.is_file():
            out.append(p)
            continue
        if p.is_dir():
            found = sorted(q for q in p.iterdir() if q.is_file() and not q.name.startswith(".")
                           and q.suffix.lower() in data_suffixes())
            src = f"folder {p}"
        elif any(ch in str(it) for ch in "*?["):
            found = sorted(Path(q) for q in glob.glob(str(it), recursive=True) if Path(q).is_file())
            if not found:
                raise TorlabInputError(f"no file matches the pattern {str(it)!r}", path=str(it))
            src = f"pattern {str(it)!r}"
        elif p.exists():
            raise TorlabInputError(f"not a regular file (a device, FIFO or socket); give the "
                                   f"{what} file", path=p)
        else:
            raise TorlabInputError(f"{what} file not found", path=p)
        chosen = [q for q in found if keep is None or keep(q)]
        left = [q.name for q in found if q not in chosen]
        if left:
            notes.append(f"{src}: left out {', '.join(left)} (not {what} files)")
        if not chosen:
            raise TorlabInputError(f"no {what} file in the {src}", path=p)
        out += chosen
    out = list(dict.fromkeys(out))
    if not out:
        raise TorlabInputError(f"no {what} files given")
    return out, notes


def is_instrument(name: str | None) -> Any:
    """A ``keep`` filter for :func:`expand_inputs`: files the instrument ``name`` reads
    (detected as it, or as one it also reads; any instrument when ``None``)."""
    def keep(p: Path) -> bool:
        try:
            found = detect(p)[0].name
        except TorlabInputError:
            return False
        return name is None or found == name or found in get_instrument(name).also_reads

    return keep


def read_file(path: str | os.PathLike[str], instrument: str | None = None, **options: Any
              ) -> tuple[Any, Any]:
    """Parse a file: ``(DataFrame, metadata)``, the instrument detected unless given."""
    inst, preset = _lookup(instrument) if instrument else (detect(path)[0], {})
    return inst.impl().read(Path(path), **{**preset, **options})


def reduce_file(path: str | os.PathLike[str], instrument: str | None = None, *,
                converted: bool = False, **options: Any) -> Any:
    """Reduce one file; the instrument is detected from its first lines unless given.

    Parameters
    ----------
    path
        The file.
    instrument
        Registry name or alias (``"pcs"``, ``"mtm"``, ``"hpt"`` ...).
    converted
        The options are already converted (:func:`convert_options`).
    **options
        The instrument's options (:data:`Option`; unit strings allowed).

    Returns
    -------
    Reduction
    """
    if instrument:
        inst, _preset = _lookup(instrument)
        how = f"--as {instrument}"
    else:
        inst, how = detect(path)
    if not converted:
        return reduce_batch([path], instrument, **options)[0][0]
    red = inst.impl().reduce(Path(path), **options)
    red.detected = how
    return red


def reduce_files(paths: Sequence[str | os.PathLike[str]], instrument: str | None = None,
                 **options: Any) -> list[Any]:
    """:func:`reduce_file` of every file, in order (see :func:`reduce_batch`)."""
    return reduce_batch(paths, instrument, **options)[0]


def reduce_batch(paths: Sequence[str | os.PathLike[str]], instrument: str | None = None,
                 **options: Any) -> tuple[list[Any], dict[str, dict[str, Any]]]:
    """Reduce every file, in order; also return each instrument's prepared options.

    Options are converted once per instrument, and what an instrument
    prepares once for a batch runs once (the viscometer's calibration from
    reference logs).  The files are reduced on the executor in use
    (:func:`torlab.parallel.current`: ``--jobs`` of the reduce commands).  Without ``instrument`` each file's instrument is
    detected and gets the options it knows; an option no detected instrument
    knows is an error.
    """
    order = [Path(p) for p in paths]
    how: dict[Path, tuple[Instrument, dict[str, Any], str]] = {}
    for p in order:
        if instrument:
            inst, preset = _lookup(instrument)
            how[p] = (inst, preset, f"--as {instrument}")
        else:
            inst, why = detect(p)
            how[p] = (inst, {}, why)
    used = {i.name: i for i, _, _ in how.values()}
    if not instrument and options:
        for k in options:
            if not any(k.replace("-", "_") in i.options for i in used.values()):
                convert_options(next(iter(used.values())), {k: options[k]})  # raises, with a hint
    prepared: dict[str, dict[str, Any]] = {}
    for name, inst in used.items():
        preset = next(pr for i, pr, _ in how.values() if i.name == name)
        mine = {k: v for k, v in options.items() if k.replace("-", "_") in inst.options}
        prepared[name] = prepare_options(inst, {**preset, **mine})
    from torlab.parallel import current

    jobs = [(how[p][0].name, p, prepared[how[p][0].name], how[p][2]) for p in order]
    reds = current().map(_reduce_one, jobs, description="reducing files")
    return reds, prepared


def _reduce_one(job: tuple[str, Path, dict[str, Any], str]) -> Any:
    """Reduce one file (a task of the executor in use, :mod:`torlab.parallel`)."""
    name, p, opts, why = job
    red = get_instrument(name).impl().reduce(p, **opts)
    red.detected = why
    return red


def prepare_options(inst: Instrument, options: dict[str, Any]) -> dict[str, Any]:
    """Converted options plus what the instrument computes once for a batch (``prepare``)."""
    opts = convert_options(inst, options)
    impl = inst.impl()
    return impl.prepare(opts) if hasattr(impl, "prepare") else opts
