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
* ``light(reduction) -> JSON`` and ``from_light(JSON) -> Reduction``: what the run keeps
  in memory of each file (its header and key figures, say) as plain JSON and the
  Reduction rebuilt from it (without its data), the whole reduction staying in the run's
  cache: the fits read it there, in the worker that fits (:class:`ReductionArg`), and a
  later run takes the light forms from the cache's index without reading the entries.
  Then ``write_section`` receives the light forms.  Default: none (the whole reductions
  are kept; so they are when the run has no cache).  The run keeps each light form packed
  (:class:`PackedReduction`: its JSON compressed, restored when read): a campaign of
  thousands of HPT logs (the ``hpt`` section's) keeps about 0.3 kB per log instead of its
  curve.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from torlab.instruments.reduction import Reduction
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
        jobs = [(inst.name, f, prepared, section) for f in files]
        # an instrument with a light form keeps only that here (its data stay in the cache)
        light = None
        if ctx.cache.folder is not None and hasattr(inst.impl(), "light"):
            from torlab.protocols.cache import Light

            light = Light(_light, _Restore(inst.name))
        reds = ctx.cached_map(section, _reduce_task, list(zip(parts, jobs, strict=True)),
                              f"{section}: reducing files", uses=(), short=True,
                              light=light)  # no optimiser, no matplotlib: loaded meanwhile
        names = ctx.lp.result_names.get(section, {})
        shared = _Section(ctx.cache, section, key, inst.name, prepared)
        for red, pt, f in zip(reds, parts, files, strict=True):
            ctx.keys[id(red)] = ctx.cache.key(section, **pt)
            if names.get(f, f.stem) != f.stem:  # two files of one name: named by labels
                red.name = names[f]
            if light is not None:
                ctx.stored[id(red)] = StoredReduction(shared, pt["sha"], f)
        ctx.reductions[section] = reds
        write = getattr(inst.impl(), "write_section", None)
        labelled = ctx.labelled(section)
        ctx.data_summary[section] = write(ctx.dest, labelled) if write is not None else \
            default_write(ctx.dest, labelled, section, prepared)


def _light(red: Any) -> Any:
    """The light form of a reduction (its instrument's ``light``: plain JSON): what a
    protocol run keeps in memory of it (:class:`PackedReduction`)."""
    if isinstance(red, PackedReduction):
        return red.light_json()
    from torlab.instruments import get_instrument

    return get_instrument(red.instrument).impl().light(red)


@dataclass(frozen=True)
class _Restore:
    """What the run keeps of a light form: its :class:`PackedReduction`, once the
    instrument's ``from_light`` has taken the JSON (TypeError, ValueError, KeyError for
    JSON of another shape)."""

    instrument: str

    def __call__(self, d: Any) -> Any:
        return PackedReduction(_packer(self.instrument), d)


class _Packer:
    """Packs one instrument's light forms and restores them: the JSON value in
    :mod:`marshal`'s format (read back in 10 µs, where ``json`` takes 24 µs; the bytes are
    made in this process from JSON already checked and never leave it), compressed with the
    first form packed as zlib's preset dictionary (most of a log's light form -- its keys,
    units, header lines, settings -- is every log's)."""

    __slots__ = ("_lock", "instrument", "last", "restore", "zdict")

    def __init__(self, instrument: str) -> None:
        import threading

        from torlab.instruments import get_instrument

        self.instrument, self._lock = instrument, threading.Lock()
        self.restore = get_instrument(instrument).impl().from_light
        self.zdict: bytes | None = None
        #: ``(packed, restored)``: the last one restored (read several times in a row)
        self.last: tuple[Any, Any] = (None, None)

    def pack(self, d: Any) -> bytes:
        import marshal
        import zlib

        _plain(d, self.instrument)  # marshal would take a NumPy number as its bytes
        text = marshal.dumps(d)  # plain JSON values; made and read in this process only
        if self.zdict is None:
            with self._lock:  # one dictionary for all (a form packed is unpacked with it)
                if self.zdict is None:
                    self.zdict = text[-32768:]  # zlib's window
        c = zlib.compressobj(6, zdict=self.zdict)
        return c.compress(text) + c.flush()

    def unpack(self, blob: bytes) -> Any:
        import marshal
        import zlib

        assert self.zdict is not None  # set by the first pack
        return marshal.loads(zlib.decompressobj(zdict=self.zdict).decompress(blob))


_LEAVES = (str, int, float, bool, type(None))


def _plain(v: Any, instrument: str, at: str = "") -> None:
    """TypeError unless ``v`` is plain JSON: mappings with text keys, lists, and text,
    numbers (Python's own, not NumPy's), booleans, None."""
    if isinstance(v, dict):
        for k, x in v.items():
            if type(k) is not str:
                raise TypeError(f"{instrument}: light form key {at}{k!r} is not text")
            _plain(x, instrument, f"{at}{k}.")
    elif isinstance(v, list):
        for x in v:
            _plain(x, instrument, at)
    elif type(v) not in _LEAVES:
        raise TypeError(f"{instrument}: light form value {at.rstrip('.') or '(top)'} is a "
                        f"{type(v).__module__}.{type(v).__name__}, not plain JSON")


_PACKERS: dict[str, _Packer] = {}


def _packer(instrument: str) -> _Packer:
    """The packer of an instrument's light forms (one per process)."""
    p = _PACKERS.get(instrument)
    if p is None:
        p = _PACKERS.setdefault(instrument, _Packer(instrument))
    return p


class PackedReduction:
    """A reduction a protocol run keeps as its instrument's light form (header and key
    figures, no tables), compressed: about 0.3 kB per HPT log, where the Reduction
    restored from it holds about 3 kB of Python objects (a 64x campaign's 6656 logs: 2
    MB instead of 20 MB, the C heap's fragmentation by them not counted).

    ``source``, ``instrument``, ``name``, ``stem`` and ``label`` are kept as they are; any
    other attribute (``meta``, ``detail``, ``key_numbers``, ``notes`` ...) is read from the
    Reduction restored from the light form (about 20 µs for an HPT log; the last one
    restored is kept, for reads in a row).  The whole reduction is in the
    run's cache (:class:`StoredReduction`).
    """

    __slots__ = ("_blob", "_packer", "instrument", "name", "source")

    def __init__(self, packer: _Packer, d: Any) -> None:
        red = packer.restore(d)  # refuses JSON of another shape, here
        self._packer = packer
        self._blob = packer.pack(d)
        self.source, self.instrument, self.name = red.source, red.instrument, red.name
        packer.last = (self, red)

    label = Reduction.label
    stem = Reduction.stem

    def light_json(self) -> Any:
        """The light form (JSON), as the instrument's ``light`` made it."""
        return self._packer.unpack(self._blob)

    def restored(self) -> Reduction:
        """The light Reduction (no tables; its detail without the curve)."""
        packed, red = self._packer.last
        if packed is not self:
            red = self._packer.restore(self.light_json())
            self._packer.last = (self, red)
        red.name = self.name
        return red

    def __getattr__(self, attr: str) -> Any:
        if attr.startswith("__"):  # copy, pickle: not looked up in the restored one
            raise AttributeError(attr)
        return getattr(self.restored(), attr)

    def __repr__(self) -> str:
        return f"PackedReduction({self.instrument!r}, {self.source!r})"


class _Section:
    """What the stored reductions of one data section share: the cache, the section, its
    options' key and the instrument with its prepared options (one object, not one copy
    per log)."""

    __slots__ = ("cache", "instrument", "options", "prepared", "section")

    def __init__(self, cache: Any, section: str, options: str, instrument: str,
                 prepared: dict[str, Any]) -> None:
        self.cache, self.section, self.options = cache, section, options
        self.instrument, self.prepared = instrument, prepared


class StoredReduction:
    """A reduction kept in the run's cache, of which the run holds only the light form.

    :meth:`reduction` reads it here (or reduces the file again, should the entry be gone);
    :meth:`arg` is what a task takes instead (:class:`ReductionArg`), read in its worker.
    Of each log it holds the file's path and SHA-256; its cache key's parts and its
    reduce task are made from them when asked (a campaign holds one per log).
    """

    __slots__ = ("path", "sha", "shared")

    def __init__(self, shared: _Section, sha: str, path: Path) -> None:
        self.shared, self.sha, self.path = shared, sha, path

    @property
    def parts(self) -> dict[str, Any]:
        """The cache key's parts (as :func:`reduce_data` stored the reduction)."""
        return {"sha": self.sha, "name": self.path.name, "options": self.shared.options}

    @property
    def job(self) -> tuple[str, Path, dict[str, Any], str]:
        """The reduce task (:func:`_reduce_task`)."""
        s = self.shared
        return (s.instrument, self.path, s.prepared, s.section)

    def reduction(self) -> Any:
        """The whole reduction."""
        s = self.shared
        hit, red = s.cache.lookup(s.section, **self.parts)
        return red if hit else _reduce_task(self.job)

    def arg(self) -> ReductionArg:
        """The reduction as a task's argument (:func:`detail`)."""
        s = self.shared
        return ReductionArg(s.cache.ref(s.section, **self.parts), self.job)


@dataclass(frozen=True)
class ReductionArg:
    """A reduction a task reads where it runs: the cache entry (checked against the status
    it was stored with, :class:`torlab.protocols.cache.EntryRef`), or -- the entry gone or
    changed -- the file reduced again."""

    ref: Any
    job: tuple

    def reduction(self) -> Any:
        from torlab.codec import BadEntry

        if self.ref is not None:
            try:
                return self.ref.value()
            except BadEntry:
                pass
        return _reduce_task(self.job)


def detail(x: Any) -> Any:
    """The reduction detail a task was given: as it is, or read through a
    :class:`ReductionArg`."""
    return x.reduction().detail if isinstance(x, ReductionArg) else x


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
