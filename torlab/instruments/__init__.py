"""The instrument registry: one entry per instrument / file format.

Every instrument torlab reads is one module of this package and one entry of
:data:`REGISTRY`.  A module provides

* ``detect(head) -> str``: why the first lines of a file are this format
  (``""`` when they are not);
* ``read(path, **options) -> (DataFrame, metadata)``: the parser;
* ``reduce(path, **options) -> Reduction``: the reduction
  (:class:`~torlab.instruments.reduction.Reduction`: tables, key numbers, notes);
* ``OPTIONS``: the reduction's options (:class:`Option`: unit kind, default,
  help), so options given as unit strings (``window="20 um"``) are converted
  and misspelt names get a suggestion;
* ``figures(red)``, ``collect(reds, options)`` (the tables and figures over all
  files: ``summary.csv`` ...), ``display(reds)`` (console rows), and the
  measured curves it holds (``traction_curves``, ``stribeck_curves``,
  ``film_curves``).

``torlab reduce``, the instrument commands (``torlab hpt reduce`` ...) and the
protocol runner are loops over this registry (:func:`reduce_file`,
:func:`reduce_files`); detection exists once (:func:`detect`).  Modules are
imported when first used, so ``import torlab`` stays light.
"""

from __future__ import annotations

import glob
import importlib
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError

__all__ = [
    "REGISTRY",
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

#: bytes read from the start of a file to detect its format
HEAD_BYTES = 4096
#: file name endings a folder is searched for
DATA_SUFFIXES = (".txt", ".csv", ".tsv", ".dat", ".log")


@dataclass(frozen=True)
class Option:
    """One option of a reduction.

    ``kind`` is a :data:`torlab.units.KINDS` quantity kind (values may be
    unit strings such as ``"20 um"``; plain numbers are SI), or ``"number"``,
    ``"text"``, ``"flag"``, ``"choice"``, ``"path"``, ``"paths"``, ``"object"``
    (a library object passed as it is).  ``check`` is ``"positive"``,
    ``"nonneg"``, ``"fraction"`` (0 < v <= 1) or ``"open_fraction"`` (0 < v < 1).
    """

    kind: str
    default: Any = None
    help: str = ""
    choices: tuple[str, ...] = ()
    check: str = ""


@dataclass(frozen=True)
class Instrument:
    """A registry entry: name, what it reads, the module that does it.

    ``aliases`` maps other names (``mtm``, ``ehd2``) to preset options
    (``{"family": "MTM"}``).
    """

    name: str
    title: str
    module: str
    files: str
    aliases: dict[str, dict[str, Any]] = field(default_factory=dict)

    def impl(self) -> Any:
        """The instrument's module (imported on first use)."""
        return importlib.import_module(self.module)

    @property
    def options(self) -> dict[str, Option]:
        """The reduction's options."""
        return self.impl().OPTIONS


def _entry(name: str, title: str, files: str, aliases: dict[str, dict[str, Any]] | None = None
           ) -> Instrument:
    return Instrument(name, title, f"torlab.instruments.{name}", files, aliases or {})


#: every instrument torlab reads, in detection order
REGISTRY: dict[str, Instrument] = {
    "pcs": _entry("pcs", "PCS Instruments MTM / ETM / EHD2", "'Test Data File' text exports",
                  {"mtm": {"family": "MTM"}, "etm": {"family": "ETM"},
                   "ehd2": {"family": "EHD2"}, "ehd": {"family": "EHD2"}}),
    "hpt": _entry("hpt", "high-pressure torsion rig", "torlab-hpt logs (other CSVs with --map)",
                  {"torsion": {}}),
    "optical": _entry("optical", "optical ball-on-disc tribometer",
                      "torlab-optical logs; PCS EHD2 exports with --as optical",
                      {"tribometer": {}}),
    "visc": _entry("visc", "falling-body viscometer", "torlab-visc logs", {"viscometer": {}}),
}


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


def _head(path: Path) -> str:
    with open(path, "rb") as f:
        raw = f.read(HEAD_BYTES)
    for enc in ("utf-8-sig", "cp1252"):
        try:
            return raw.decode(enc)
        except UnicodeDecodeError:
            continue
    return raw.decode("utf-8", errors="replace")


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
    head = _head(p)
    for inst in REGISTRY.values():
        why = inst.impl().detect(head)
        if why:
            return inst, why
    first = next((s.strip() for s in head.splitlines() if s.strip()), "")
    shown = first if len(first) <= 60 else first[:57] + "..."
    raise TorlabInputError(f"torlab does not recognise this file (first line {shown!r}); "
                           f"give the instrument with --as ({', '.join(REGISTRY)})", path=p)


def convert_options(inst: Instrument | str, options: dict[str, Any]) -> dict[str, Any]:
    """Check option names and convert values (unit strings to SI) for ``inst``'s reduction.

    Options not given take their defaults.  Unknown names are errors with a
    "did you mean" suggestion.
    """
    from torlab._suggest import did_you_mean

    inst = get_instrument(inst) if isinstance(inst, str) else inst
    spec: dict[str, Option] = inst.options
    out = {k: o.default for k, o in spec.items()}
    for k, v in options.items():
        name = k.replace("-", "_")
        if name not in spec:
            raise TorlabInputError(f"unknown option {k!r} for {inst.name} (options: "
                                   f"{', '.join(spec)}){did_you_mean(name, spec)}", key=k)
        out[name] = None if v is None else _convert(spec[name], v, name)
    return out


def _convert(o: Option, v: Any, name: str) -> Any:
    from torlab.units import KINDS, to_si

    if o.kind == "object":
        return v
    if o.kind == "flag":
        return bool(v)
    if o.kind == "text":
        return str(v)
    if o.kind == "path":
        return Path(v)
    if o.kind == "paths":
        return [Path(x) for x in ([v] if isinstance(v, (str, os.PathLike)) else v)]
    if o.kind == "choice":
        s = str(v).strip().lower()
        low = {c.lower(): c for c in o.choices}
        if s not in low:
            from torlab._suggest import did_you_mean

            raise TorlabInputError(f"{v!r} is not a known {name.replace('_', ' ')} (choose "
                                   f"{', '.join(o.choices)}){did_you_mean(s, o.choices)}",
                                   key=name)
        return low[s]
    if o.kind == "number":
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise TorlabInputError(f"{v!r} is not a number", key=name) from None
    elif o.kind in KINDS:
        x = to_si(v, o.kind, where=name)
    else:  # pragma: no cover - a registry mistake
        raise ValueError(f"option {name}: unknown kind {o.kind!r}")
    _check(o.check, x, name, v)
    return x


def _check(check: str, x: float, name: str, given: Any) -> None:
    import math

    bad = {
        "positive": (lambda v: v > 0, "must be positive"),
        "nonneg": (lambda v: v >= 0, "must not be negative"),
        "fraction": (lambda v: 0 < v <= 1, "must be in (0, 1]"),
        "open_fraction": (lambda v: 0 < v < 1, "must be in (0, 1)"),
    }.get(check)
    if not math.isfinite(x):
        raise TorlabInputError(f"{given!r} is not a finite number", key=name)
    if bad is not None and not bad[0](x):
        raise TorlabInputError(f"{given!r} {bad[1]}", key=name)


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
                           and q.suffix.lower() in DATA_SUFFIXES)
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


#: instruments whose reduction also reads another's files (the optical reduction reads EHD2)
ALSO_READS = {"optical": ("pcs",)}


def is_instrument(name: str | None) -> Any:
    """A ``keep`` filter for :func:`expand_inputs`: files the instrument ``name`` reads
    (detected as it, or as one it also reads; any instrument when ``None``)."""
    def keep(p: Path) -> bool:
        try:
            found = detect(p)[0].name
        except TorlabInputError:
            return False
        return name is None or found == name or found in ALSO_READS.get(name, ())

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
