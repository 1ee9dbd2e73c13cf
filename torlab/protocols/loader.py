"""Loading a test protocol: YAML with line numbers, schema, cross-checks, every problem at once.

:func:`load_protocol` reads a protocol file (``docs/protocols.md``), validates
it against :mod:`torlab.protocols.schema` and checks what the schema alone
cannot (a report whose data section is missing, a parameter set no fit
produces, a measured file that is not one of the protocol's files, an invalid
scene).  It raises one :class:`~torlab.errors.ValidationErrors` listing every
problem, each with file, line and key path, before any work starts.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError, ValidationErrors

__all__ = ["REPORT_KEYS", "LoadedProtocol", "load_protocol", "load_protocol_text"]

#: the ``reports:`` sections, in report order
REPORT_KEYS = ("amount", "time_test", "traction", "stribeck", "film", "retention")


@dataclass
class LoadedProtocol:
    """A validated protocol and where it came from.

    Attributes
    ----------
    protocol
        The validated :class:`~torlab.protocols.schema.Protocol`.
    path
        The protocol file (None for text given directly).
    base
        Folder relative paths are resolved against (the protocol's folder).
    scenes
        Merged scene dictionaries keyed by the tuple of scene files (SI values),
        validated once here.
    """

    protocol: Any
    path: Path | None
    base: Path
    scenes: dict[tuple[Path, ...], dict[str, Any]] = field(default_factory=dict)
    #: data section -> file -> the name of its results where that is not the file's name
    #: without extension (:func:`_result_names`; ``names.get(f, f.stem)``)
    result_names: dict[str, dict[Path, str]] = field(default_factory=dict)

    def data_files(self, section: str) -> list[Path]:
        """Files of ``data.<section>`` (in protocol order, no duplicates)."""
        d = getattr(self.protocol.data, section)
        if d is None:
            return []
        out: dict[Path, None] = {}  # ordered, and a membership test of constant cost
        for entry in d.files:
            out.update(dict.fromkeys(entry.resolved))
        return list(out)

    def labels(self, section: str) -> dict[Path, str]:
        """Labels given to files of ``data.<section>`` (file -> label)."""
        d = getattr(self.protocol.data, section)
        if d is None:
            return {}
        return {e.resolved[0]: e.label for e in d.files if e.label}

    def input_files(self) -> list[Path]:
        """Every file the run reads (protocol, data, references, scenes), no duplicates."""
        files: dict[Path, None] = {} if self.path is None else {self.path: None}

        def add(p: Path | None) -> None:  # ordered, no duplicates, constant cost per file
            if p is not None:
                files.setdefault(p)

        from torlab.protocols.schema import DATA_SECTIONS

        for sec in DATA_SECTIONS:
            for p in self.data_files(sec):
                add(p)
        for sec in DATA_SECTIONS:  # reference logs, the rig compliance curve
            d = getattr(self.protocol.data, sec)
            for p in [] if d is None else d.input_files():
                add(p)
        for scene_files in self.scenes:
            for p in scene_files:
                add(p)
        for f in self.protocol.fits.lubricants:
            add(f.measured.resolved)
        return list(files)


def load_protocol(path: str | os.PathLike[str]) -> LoadedProtocol:
    """Read and validate a protocol file.

    Parameters
    ----------
    path
        The protocol YAML; relative paths in it are relative to its folder.

    Returns
    -------
    LoadedProtocol

    Raises
    ------
    TorlabInputError
        The file cannot be read or is not YAML.
    ValidationErrors
        Every schema and cross-check problem, each with file, line and key path.
    """
    from torlab.yamlio import load_yaml

    doc = load_yaml(path)
    return _validate(doc, Path(path))


def load_protocol_text(text: str, base: str | os.PathLike[str] = ".",
                       name: str = "<protocol>") -> LoadedProtocol:
    """Validate a protocol given as YAML text (paths relative to ``base``)."""
    from torlab.yamlio import load_yaml_text

    doc = load_yaml_text(text, name)
    lp = _validate(doc, None, base=Path(base))
    return lp


def _validate(doc: Any, path: Path | None, base: Path | None = None) -> LoadedProtocol:
    from pydantic import ValidationError

    from torlab.protocols.schema import PROTOCOL_VERSION, Protocol

    base = base if base is not None else (path.parent if path is not None else Path("."))
    data = doc.data
    if data is None:
        raise TorlabInputError("protocol file is empty", path=doc.path)
    if not isinstance(data, dict):
        raise TorlabInputError("a protocol must be a YAML mapping (version:, name:, data:, ...)",
                               path=doc.path, line=doc.lines.line(()))
    if "version" not in data:
        raise TorlabInputError(f"missing 'version: {PROTOCOL_VERSION}' (the protocol schema "
                               "version)", path=doc.path, line=1, key="version")
    if data["version"] != PROTOCOL_VERSION or isinstance(data["version"], bool):
        raise TorlabInputError(
            f"protocol version {data['version']!r} is not supported by this torlab (it reads "
            f"version {PROTOCOL_VERSION})", path=doc.path, line=doc.lines.line(("version",)),
            key="version")
    try:
        proto = Protocol.model_validate(data, context={"base": str(base)})
    except ValidationError as ve:
        problems = [_problem(doc, err, data) for err in ve.errors()]
        raise ValidationErrors(_sorted(problems)) from None
    lp = LoadedProtocol(protocol=proto, path=path, base=base)
    problems = _cross_check(lp, doc) + _result_names(lp, doc)
    if problems:
        raise ValidationErrors(_sorted(problems))
    return lp


def _sorted(problems: list[TorlabInputError]) -> list[TorlabInputError]:
    return sorted(problems, key=lambda e: (e.path or "", e.line or 0, e.key or ""))


_SKIP_LOC = ("float", "int", "str", "bool", "list", "tuple", "dict")


def _clean_loc(loc: tuple[Any, ...]) -> tuple[Any, ...]:
    out = []
    for x in loc:
        if isinstance(x, str) and (x.startswith(("function-", "literal[", "tuple[", "list["))
                                   or x in _SKIP_LOC or "[" in x):
            continue
        out.append(x)
    return tuple(out)


def _lookup(data: Any, loc: tuple[Any, ...]) -> Any:
    cur = data
    for k in loc:
        if isinstance(cur, dict) and k in cur:
            cur = cur[k]
        elif isinstance(cur, list) and isinstance(k, int) and 0 <= k < len(cur):
            cur = cur[k]
        else:
            return _MISSING
    return cur


_MISSING = object()


def _problem(doc: Any, err: dict[str, Any], data: Any) -> TorlabInputError:
    loc = _clean_loc(tuple(err["loc"]))
    t = err.get("type", "")
    msg = err.get("msg", "")
    raw = _lookup(data, loc)
    if t == "extra_forbidden":
        from torlab._suggest import key_suggestion
        from torlab.protocols.schema import Protocol

        hint = key_suggestion(Protocol, loc)
        text = f"unknown key{hint or ' (see docs/protocols.md for the keys of this section)'}"
    elif t == "missing":
        text = "missing (required)"
    elif t == "literal_error":
        from torlab._suggest import literal_suggestion

        text = (f"{raw!r} is not allowed: {msg.replace('Input should be ', 'use ')}"
                f"{literal_suggestion(err)}")
    elif t in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        text = f"{raw!r} is out of range: {msg.replace('Input should be ', 'must be ')}"
    elif t == "string_pattern_mismatch":
        text = f"{raw!r}: use letters, digits, '_', '.' and '-' only"
    elif t in ("too_short", "too_long"):
        text = msg.replace("List should have", "give").replace("Value should have", "give")
    elif msg.startswith("Value error, "):
        text = msg[len("Value error, "):]
    elif t.endswith("_type"):
        text = f"{raw!r}: {msg.replace('Input should be', 'expected')}" if raw is not _MISSING \
            else msg
    else:
        text = msg
    key = ".".join(str(x) for x in loc) or None
    return TorlabInputError(text, path=doc.path, line=doc.lines.line(loc), key=key)


def _cross_check(lp: LoadedProtocol, doc: Any) -> list[TorlabInputError]:
    """Problems the schema cannot see: dependencies between sections, scenes, names."""
    return _CrossCheck(lp, doc).run()


class _CrossCheck:
    """The checks of :func:`_cross_check`, one method per part of the protocol, run in the
    order their problems are reported."""

    def __init__(self, lp: LoadedProtocol, doc: Any) -> None:
        self.lp, self.doc = lp, doc
        self.p = lp.protocol
        self.problems: list[TorlabInputError] = []
        self.measured_files = set(lp.data_files("optical")) | set(lp.data_files("mtm"))
        self.names = [t.name for t in self.p.fits.traction_layers]
        self.lnames = [x.name for x in self.p.fits.lubricants]

    def run(self) -> list[TorlabInputError]:
        self._fits()
        self._reports()
        for i, t in enumerate(self.p.fits.traction_layers):
            self._scene(("fits", "traction_layers", i, "scene"), t.scene)
        for sec in ("traction", "stribeck", "film"):
            rep = getattr(self.p.reports, sec)
            for i, c in enumerate(rep.curves if rep is not None else []):
                self._curve(sec, i, c)
        self._stribeck_creepage()
        self._retention_scenes()
        self._initial_drop()
        return self.problems

    def err(self, keypath: tuple[Any, ...], message: str) -> None:
        self.problems.append(self.doc.error(keypath, message))

    def _fits(self) -> None:
        """Fits need their data sections and files; names are unique."""
        d, f, lp = self.p.data, self.p.fits, self.lp
        if f.hpt_layers is not None and d.hpt is None:
            self.err(("fits", "hpt_layers"), "fitting HPT layers needs data.hpt")
        if f.lubricants and d.visc is None:
            self.err(("fits", "lubricants"), "fitting lubricants needs data.visc (its calibration)")
        visc_files = set(lp.data_files("visc"))
        for i, lf in enumerate(f.lubricants):
            if lf.measured.resolved not in visc_files:
                self.err(("fits", "lubricants", i, "measured"),
                         f"{lf.measured.path} is not one of the files of data.visc")
        for i, t in enumerate(f.traction_layers):
            if t.measured.resolved not in self.measured_files:
                self.err(("fits", "traction_layers", i, "measured"),
                         f"{t.measured.path} is not one of the files of data.optical or data.mtm")
        for section, items, used in (("traction_layers", f.traction_layers, self.names),
                                     ("lubricants", f.lubricants, self.lnames)):
            for i, x in enumerate(items):
                if used.index(x.name) != i:
                    self.err(("fits", section, i, "name"), f"name {x.name!r} is used twice")

    def _reports(self) -> None:
        """Reports need their data sections; at least one report; the retention files."""
        d, r = self.p.data, self.p.reports
        if r.amount is not None and d.hpt is None:
            self.err(("reports", "amount"), "the amount-dependency report needs data.hpt")
        if r.time_test is not None and d.mtm is None:
            self.err(("reports", "time_test"), "the time-test report needs data.mtm")
        if all(getattr(r, k) is None for k in REPORT_KEYS):
            self.err(("reports",), "no report requested (amount, time_test, traction, stribeck, "
                     "film or retention)")
        if r.retention is None:
            return
        for sec in ("hpt", "mtm"):
            if getattr(d, sec) is None:
                self.err(("reports", "retention"), f"the retention report needs data.{sec} (the "
                         "HPT amount series and the MTM time tests)")
        mtm_files = set(self.lp.data_files("mtm"))
        for i, e in enumerate(r.retention.time_tests):
            if any(x not in mtm_files for x in e.resolved):
                self.err(("reports", "retention", "time_tests", i),
                         f"{e.path} is not one of the files of data.mtm")

    def _params(self, keypath: tuple[Any, ...], params: list[str]) -> None:
        """Parameter sets named by a curve exist among the fits."""
        for j, ps in enumerate(params):
            kind, _, name = ps.partition(":")
            if kind == "hpt" and self.p.fits.hpt_layers is None:
                self.err((*keypath, j), f"{ps!r} needs fits.hpt_layers")
            elif kind == "traction" and name not in self.names:
                self.err((*keypath, j), f"{ps!r}: no fits.traction_layers entry named {name!r}")
            elif kind == "lubricant" and name not in self.lnames:
                self.err((*keypath, j), f"{ps!r}: no fits.lubricants entry named {name!r}")

    def _scene(self, keypath: tuple[Any, ...], refs: list[Any], *,
               lubricated: bool = False) -> None:
        """A scene's files load (each once: their merged data kept in ``lp.scenes``)."""
        if not refs:
            return
        lp = self.lp
        key = tuple(x.resolved for x in refs)
        if key not in lp.scenes:
            try:
                lp.scenes[key] = _scene_dict(key)
            except ValidationErrors as e:
                self.problems.extend(e.problems)
                lp.scenes[key] = {}
                return
            except TorlabInputError as e:
                self.problems.append(e)
                lp.scenes[key] = {}
                return
        sd = lp.scenes[key]
        if lubricated and sd and "lubricant" not in sd:
            self.err(keypath, "a Stribeck or film curve needs a lubricated scene (lubricant: "
                     "section)")

    def _curve(self, sec: str, i: int, c: Any) -> None:
        """One curve of the traction, Stribeck or film report."""
        kp = ("reports", sec, "curves", i)
        self._params((*kp, "params"), c.params)
        self._scene((*kp, "scene"), c.scene, lubricated=sec != "traction")
        if c.params and not c.scene:
            self.err((*kp, "params"), "parameter sets are applied to a scene: give scene:")
        if c.measured is not None and c.measured.resolved not in self.measured_files:
            self.err((*kp, "measured"),
                     f"{c.measured.path} is not one of the files of data.optical or data.mtm")
        if c.speeds == "measured" and c.measured is None:
            self.err((*kp, "speeds"), "speeds: measured needs measured: (the file to take them "
                     "from)")
        if c.speeds is not None and sec != "traction":
            self.err((*kp, "speeds"), "speeds is a traction-report key (the Stribeck report's "
                     "speeds are reports.stribeck.speed)")
        if "{set}" in c.label and "hpt:*" not in c.params:
            self.err((*kp, "label"), "'{set}' in a label needs 'hpt:*' in params")

    def _stribeck_creepage(self) -> None:
        """A modelled Stribeck curve without a measured file needs the report's creepage."""
        st = self.p.reports.stribeck
        if st is None or st.creepage is not None:
            return
        for i, c in enumerate(st.curves):
            if c.scene and c.measured is None:
                self.err(("reports", "stribeck", "curves", i),
                         "give reports.stribeck.creepage (a modelled curve without a measured "
                         "file has no SRR to take)")

    def _retention_scenes(self) -> None:
        ret = self.p.reports.retention
        if ret is not None:
            kp = ("reports", "retention")
            self._scene((*kp, "prediction", "scene"), ret.prediction.scene)
            self._scene((*kp, "tribometer"), ret.tribometer)

    def _initial_drop(self) -> None:
        tt = self.p.reports.time_test
        if tt is None or tt.initial_drop is None:
            return
        idp = tt.initial_drop
        kp = ("reports", "time_test", "initial_drop")
        self._params((*kp, "params"), idp.params)
        self._scene((*kp, "scene"), idp.scene)
        if "hpt:*" in idp.params:
            self.err((*kp, "params"), "hpt:* makes one curve per product; name one product here")


def name_key(text: str, *, plain: bool = False) -> str:
    """The file name user text becomes (:func:`torlab.files.safe_name`; with ``plain``
    :func:`torlab.files.plain_name`, which labels of figures use), casefolded: two texts
    with one key would write one file (on a file system that ignores case too)."""
    from torlab.files import plain_name, safe_name

    return (plain_name(text) if plain else safe_name(text)).casefold()


def _result_names(lp: LoadedProtocol, doc: Any) -> list[TorlabInputError]:
    """Give every data file the name of its results, before any work; refuse two that
    would write one file.

    A file's results (``data/<section>/<name>_<table>.csv``, its entries of the summary)
    are named by its file name without extension; where files of a section share that
    name (``day1/export.txt``, ``day2/export.txt``), by their labels, which they then
    need.  The labels of a section (a file's label, else its name) name its rows and
    figures (``time_test_<label>.png``): no two may make one file name.  The names of the
    fitted parameter sets (``fits/traction_<name>.yaml``) and the Stribeck curves' labels
    likewise.
    """
    from torlab.protocols.schema import DATA_SECTIONS

    problems: list[TorlabInputError] = []
    p = lp.protocol
    for sec in DATA_SECTIONS:
        d = getattr(p.data, sec)
        if d is not None:
            lp.result_names[sec] = _data_names(lp, doc, sec, d, problems)
    f = p.fits
    for section, items in (("traction_layers", f.traction_layers), ("lubricants", f.lubricants)):
        _distinct(doc, [(("fits", section, i, "name"), x.name) for i, x in enumerate(items)],
                  "their fits would be written to one file", problems, twice=False)
    if p.reports.stribeck is not None:  # a label with {set} is one per product (see fits)
        _distinct(doc, [(("reports", "stribeck", "curves", i, "label"), c.label)
                        for i, c in enumerate(p.reports.stribeck.curves) if "{set}" not in c.label],
                  "their figures (stribeck_<label>) would be one", problems, plain=True)
    return problems


def _distinct(doc: Any, named: list[tuple[tuple[Any, ...], str]], what: str,
              problems: list[TorlabInputError], *, plain: bool = False,
              twice: bool = True) -> None:
    """Names (at their key paths) that make one file name: one problem for each later one
    (a name given twice too, unless ``twice`` is False: said elsewhere)."""
    from torlab.files import plain_name, safe_name

    seen: dict[str, str] = {}
    for keypath, text in named:
        k = name_key(text, plain=plain)
        if k in seen and (twice or seen[k] != text):
            made = plain_name(text) if plain else safe_name(text)
            problems.append(doc.error(keypath, f"{text!r} is used twice: {what}"
                                      if seen[k] == text else
                                      f"{text!r} makes the same file name ({made!r}) as "
                                      f"{seen[k]!r}: {what}; make them differ"))
        seen.setdefault(k, text)


def _data_names(lp: LoadedProtocol, doc: Any, sec: str, d: Any,
                problems: list[TorlabInputError]) -> dict[Path, str]:
    """The result names of ``data.<sec>``'s files that are not their stems (see
    :func:`_result_names`)."""
    from torlab.files import plain_name

    entry: dict[Path, int] = {}
    label: dict[Path, str] = {}
    for i, e in enumerate(d.files):
        for f in e.resolved:
            entry.setdefault(f, i)
            if e.label:
                label[f] = e.label
    by_stem: dict[str, list[Path]] = {}
    for f in entry:
        by_stem.setdefault(name_key(f.stem), []).append(f)
    names: dict[Path, str] = {}
    for f in entry:
        group = by_stem[name_key(f.stem)]
        if len(group) == 1:
            names[f] = f.stem
        elif f in label:
            names[f] = plain_name(label[f])
        elif f == [g for g in group if g not in label][-1]:  # said once, at the last
            other = next(g for g in group if g != f)
            problems.append(doc.error(
                ("data", sec, "files", entry[f]),
                f"{_shown(f, lp.base)} and {_shown(other, lp.base)} have one name ({f.stem!r}): "
                f"their results (data/{sec}/{f.stem}_*.csv) would overwrite each other; give "
                "each a label ({path: ..., label: ...})"))
    taken: dict[str, Path] = {}
    for f, n in names.items():
        k = n.casefold()
        if k in taken and not (f in label or taken[k] in label):  # labels: said below
            g = taken[k]
            problems.append(doc.error(
                ("data", sec, "files", entry[f]),
                f"{_shown(f, lp.base)} ({label.get(f, 'no label')!r}) and {_shown(g, lp.base)} "
                f"({label.get(g, 'no label')!r}) would write one result name ({n!r}) in "
                f"data/{sec}/; give labels that differ"))
        taken.setdefault(k, f)
    # labels name rows and figures; a file without one is named by its file name
    texts = [(f, label.get(f) or f.stem) for f in entry]
    seen: dict[str, tuple[Path, str]] = {}
    for f, text in texts:
        k = name_key(text, plain=True)
        if k in seen and (f in label or seen[k][0] in label):
            other = seen[k][1]
            problems.append(doc.error(
                ("data", sec, "files", entry[f]),
                f"label {_short(text)!r} is used twice" if text == other else
                f"label {_short(text)!r} makes the same file name "
                f"({_short(plain_name(text))!r}) as {_short(other)!r}: their figures and rows "
                "would be one; give labels that differ"))
        seen.setdefault(k, (f, text))
    # kept: the names that are not the file's stem (a campaign's thousands of files mostly
    # keep theirs)
    return {f: n for f, n in names.items() if n != f.stem}


def _short(text: str, n: int = 60) -> str:
    """User text for a message: its start and end where it is longer than ``n``."""
    return text if len(text) <= n else f"{text[: n // 2 - 2]} … {text[-(n // 2 - 2):]}"


def _shown(f: Path, base: Path) -> str:
    try:
        return f.relative_to(base).as_posix()
    except ValueError:
        return str(f)


def _scene_dict(files: tuple[Path, ...]) -> dict[str, Any]:
    """Merged scene dictionary of ``files`` (validated by :func:`torlab.scene.load_scene`)."""
    from torlab.scene import load_scene

    load_scene(*files)  # every problem with file, line and key
    return merged_scene_data(files)


def merged_scene_data(files: tuple[Path, ...] | list[Path]) -> dict[str, Any]:
    """The raw merged dictionary of scene files (later files override earlier keys)."""
    from torlab.yamlio import load_yaml

    merged: dict[str, Any] = {}
    for p in files:
        deep_merge(merged, load_yaml(p).data or {})
    return merged


def deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """Merge ``over`` into ``base`` key by key (nested mappings merged, copies taken)."""
    import copy

    for k, v in over.items():
        if isinstance(v, dict) and isinstance(base.get(k), dict):
            deep_merge(base[k], v)
        else:
            base[k] = copy.deepcopy(v)
    return base
