"""YAML input with line numbers, for error messages that point at the line.

:func:`load_yaml` returns the data (plain dicts, lists and scalars, as
``yaml.safe_load`` gives them) and a :class:`LineMap` from key paths to 1-based
line numbers.  Duplicate keys, which PyYAML silently collapses, are errors.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError

__all__ = ["LineMap", "YamlDoc", "dump_yaml", "load_yaml", "load_yaml_text"]


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
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
        line = None if mark is None else mark.line + 1
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise TorlabInputError(f"not valid YAML: {problem}", path=spath, line=line) from None
    lines = LineMap()
    if node is not None:
        lines.lines[()] = node.start_mark.line + 1
        _walk(node, (), lines, spath)
    return YamlDoc(data=data, lines=lines, path=spath)


def load_yaml(path: str | os.PathLike[str]) -> YamlDoc:
    """Read a YAML file with line numbers.

    Raises
    ------
    TorlabInputError
        If the file cannot be read, is not valid YAML or repeats a key.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise TorlabInputError("file not found", path=p) from None
    except IsADirectoryError:
        raise TorlabInputError("is a folder, expected a YAML file", path=p) from None
    except UnicodeDecodeError as e:
        raise TorlabInputError(f"not UTF-8 text ({e.reason})", path=p) from None
    except OSError as e:
        raise TorlabInputError(f"cannot read ({e.strerror})", path=p) from None
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
    """YAML text for ``data`` with keys in insertion order."""
    import yaml

    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True, default_flow_style=False)
