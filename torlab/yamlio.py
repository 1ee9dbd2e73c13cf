"""YAML input with line numbers, for error messages that point at the line.

:func:`load_yaml` returns the data (plain dicts, lists and scalars, as
``yaml.safe_load`` gives them) and a :class:`LineMap` from key paths to 1-based
line numbers.  Duplicate keys, which PyYAML silently collapses, are errors.

Every YAML input torlab reads (scenes, parameter files, protocols, column maps)
comes through here, with limits, because a YAML file is user input and YAML
aliases can make a small file very expensive ("billion laughs"):

* at most :data:`MAX_BYTES` of text (scenes and protocols are a few kB), read
  from a regular file only (a FIFO or ``/dev/zero`` is refused, not waited on);
* nesting at most :data:`MAX_DEPTH` levels, counted with aliases expanded;
* at most :data:`MAX_NODES` values with every alias expanded, computed once per
  node (so the check itself costs no more than the file's size);
* an alias that refers to the collection it is inside (a recursive structure)
  is an error.

Each limit is an error naming the file and line, not a hang or a crash.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError

__all__ = ["MAX_BYTES", "MAX_DEPTH", "MAX_NODES", "LineMap", "YamlDoc", "dump_yaml", "load_yaml",
           "load_yaml_text"]

#: largest YAML input read (bytes)
MAX_BYTES = 4 << 20
#: deepest nesting of collections, aliases expanded
MAX_DEPTH = 64
#: most values (mapping keys and values, sequence items, scalars), aliases expanded
MAX_NODES = 100_000


@dataclass
class LineMap:
    """Line numbers of the keys and items of a YAML document."""

    lines: dict[tuple[Any, ...], int] = field(default_factory=dict)

    def line(self, keypath: Sequence[Any]) -> int | None:
        """Line of ``keypath``, or of its closest existing parent."""
        kp = tuple(keypath)
        while kp:
            if kp in self.lines:
                return self.lines[kp]
            kp = kp[:-1]
        return self.lines.get((), None)


@dataclass
class YamlDoc:
    """A parsed YAML file: ``data``, ``lines`` and the ``path`` it came from."""

    data: Any
    lines: LineMap
    path: str | None

    def error(self, keypath: Sequence[Any], message: str) -> TorlabInputError:
        """A :class:`TorlabInputError` located at ``keypath`` in this file."""
        key = ".".join(str(k) for k in keypath) or None
        return TorlabInputError(message, path=self.path, line=self.lines.line(keypath), key=key)


def load_yaml_text(text: str, path: str | os.PathLike[str] | None = None) -> YamlDoc:
    """Parse YAML ``text``; see :func:`load_yaml`."""
    import yaml

    spath = None if path is None else os.fspath(path)
    if len(text) > MAX_BYTES:
        raise TorlabInputError(f"YAML text larger than {MAX_BYTES >> 20} MiB (scenes and "
                               "protocols are a few kB)", path=spath)
    # libyaml's parser where PyYAML has it (its wheels do): the same events, nodes and
    # marks as the pure-Python one, about ten times faster
    safe = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    try:
        aliases = _check_nesting(yaml.parse(text, Loader=safe), spath)
        loader = safe(text)
        try:
            node = loader.get_single_node()
            if node is not None:
                _check_expansion(node, spath, aliases)
                lines = LineMap()
                lines.lines[()] = node.start_mark.line + 1
                _walk(node, (), lines, spath)
                data = loader.construct_document(node)
            else:
                lines, data = LineMap(), None
        finally:
            loader.dispose()
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
        line = None if mark is None else mark.line + 1
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        if "nesting depth" in problem:  # libyaml (>= 0.2.6) scans ahead and has its own limit
            raise TorlabInputError(f"YAML nested deeper than {MAX_DEPTH} levels", path=spath,
                                   line=line) from None
        raise TorlabInputError(f"not valid YAML: {problem}", path=spath, line=line) from None
    except (ValueError, OverflowError) as e:  # e.g. an integer with too many digits, 2021-13-45
        raise TorlabInputError(f"not valid YAML: {str(e).splitlines()[0]}", path=spath) from None
    return YamlDoc(data=data, lines=lines, path=spath)


def _check_nesting(events: Any, spath: str | None) -> bool:
    """Refuse text nested deeper than :data:`MAX_DEPTH` before it is composed (recursively).
    Returns whether the text has an alias."""
    import yaml

    depth = 0
    aliases = False
    for ev in events:
        if isinstance(ev, yaml.AliasEvent):
            aliases = True
        if isinstance(ev, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_DEPTH:
                raise TorlabInputError(f"YAML nested deeper than {MAX_DEPTH} levels", path=spath,
                                       line=ev.start_mark.line + 1)
        elif isinstance(ev, yaml.CollectionEndEvent):
            depth -= 1
    return aliases


def _check_expansion(root: Any, spath: str | None, aliases: bool = True) -> None:
    """Size and depth of the document with every alias expanded, each node visited once.

    Iterative post-order over the node graph (aliases share nodes); a node met
    again while it is being visited is an alias to its own ancestor.
    """
    import yaml

    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    active: set[int] = set()
    stack: list[tuple[Any, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        k = id(node)
        if done:
            kids = _children(node)
            size[k] = 1 + sum(size[id(c)] for c in kids)
            depth[k] = 1 + max((depth[id(c)] for c in kids), default=0)
            active.discard(k)
            if size[k] > MAX_NODES:
                if not aliases:
                    raise TorlabInputError(
                        f"more than {MAX_NODES} values in one YAML file; torlab reads scenes, "
                        "protocols and parameter files up to that many (put long data in a "
                        "data file)", path=spath, line=node.start_mark.line + 1)
                raise TorlabInputError(
                    f"YAML expands to more than {MAX_NODES} values through its aliases "
                    "(&anchor/*alias); write the values out or use fewer aliases", path=spath,
                    line=node.start_mark.line + 1)
            if depth[k] > MAX_DEPTH:
                raise TorlabInputError(f"YAML nested deeper than {MAX_DEPTH} levels once its "
                                       "aliases are expanded", path=spath,
                                       line=node.start_mark.line + 1)
            continue
        if k in size:
            continue
        if k in active:
            raise TorlabInputError("an alias refers to the collection it is in (a recursive "
                                   "structure)", path=spath, line=node.start_mark.line + 1)
        if not isinstance(node, yaml.CollectionNode):
            size[k], depth[k] = 1, 0
            continue
        active.add(k)
        stack.append((node, True))
        for c in _children(node):
            if id(c) in active:
                raise TorlabInputError("an alias refers to the collection it is in (a "
                                       "recursive structure)", path=spath,
                                       line=c.start_mark.line + 1)
            if id(c) not in size:
                stack.append((c, False))


def _children(node: Any) -> list[Any]:
    import yaml

    if isinstance(node, yaml.MappingNode):
        return [x for kv in node.value for x in kv]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def load_yaml(path: str | os.PathLike[str]) -> YamlDoc:
    """Read a YAML file with line numbers (within the limits of the module docstring).

    Raises
    ------
    TorlabInputError
        If the file cannot be read, is not a regular file, is too large, is not
        valid YAML, repeats a key or exceeds a limit.
    """
    from torlab.files import open_regular

    p = Path(path)
    with open_regular(p) as f:
        try:
            raw = f.read(MAX_BYTES + 1)
        except OSError as e:
            raise TorlabInputError(f"cannot read ({e.strerror})", path=p) from None
    if len(raw) > MAX_BYTES:
        raise TorlabInputError(f"larger than {MAX_BYTES >> 20} MiB; expected a YAML file of a "
                               "few kB", path=p)
    if b"\x00" in raw:
        raise TorlabInputError("binary file, expected YAML text", path=p)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise TorlabInputError(f"not UTF-8 text ({e.reason})", path=p) from None
    return load_yaml_text(text, p)


def _walk(node: Any, path: tuple[Any, ...], lines: LineMap, spath: str | None) -> None:
    import yaml

    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, int] = {}
        for knode, vnode in node.value:
            key = knode.value
            line = knode.start_mark.line + 1
            if key in seen:
                raise TorlabInputError(
                    f"key {key!r} appears twice (first on line {seen[key]})",
                    path=spath, line=line, key=".".join(str(k) for k in (*path, key)))
            seen[key] = line
            lines.lines[(*path, key)] = line
            _walk(vnode, (*path, key), lines, spath)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            lines.lines[(*path, i)] = item.start_mark.line + 1
            _walk(item, (*path, i), lines, spath)


def dump_yaml(data: Any) -> str:
    """YAML text for ``data`` with keys in insertion order (libyaml's emitter where PyYAML has
    it: the same text as the pure-Python one, three times faster)."""
    import yaml

    return yaml.dump(data, Dumper=getattr(yaml, "CSafeDumper", yaml.SafeDumper), sort_keys=False,
                     allow_unicode=True, default_flow_style=False)
