"""What an instrument module declares, and the conversion of its options.

An instrument is one module (``torlab/instruments/<name>.py``) listed once in
:data:`torlab.instruments.INSTRUMENTS`.  The module declares, at its top level:

========================  =====================================================================
``NAME``                  registry name (``--as``, :attr:`Reduction.instrument`)
``TITLE``, ``FILES``      what the instrument is and what files it writes (``torlab reduce --list``)
``EXTENSIONS``            file name endings a folder is searched for (``(".txt",)``)
``ALIASES``               optional: other names and the options they preset (``{"mtm": {...}}``)
``OPTIONS``               the reduction's options (:class:`Option`: kind, unit, default, help)
``COMMAND``               optional: the command group ``torlab <name> reduce`` and the
                          protocol's ``data: <name>:`` section (:class:`Command`)
``detect(head)``          why the first lines of a file are this format (``""`` when not)
``read(path, **opts)``    the parser: ``(DataFrame in SI units, metadata)``
``reduce(path, **opts)``  the reduction: a :class:`~torlab.instruments.reduction.Reduction`
``figures``, ``collect``, ``display``: its figures, tables over all files, console tables
========================  =====================================================================

and optionally ``prepare(options)`` (once per batch), the measured curves it holds
(``traction_curves``, ``stribeck_curves``, ``film_curves``) and the protocol hooks
``check_section``, ``section_options``, ``write_section`` and ``light`` (:mod:`torlab.protocols.data`
documents their defaults; ``light(reduction)`` is what a protocol run keeps in memory of a
reduction whose bulk its fits read from the run's cache).  Everything else (the commands, their option help, the
protocol section's schema, detection, folders, ``--xlsx``) is generated from these.

This module is the vocabulary of those declarations: it imports nothing of
torlab but the errors (and :mod:`torlab.units` when a value is converted), so
the registry and the command line can read every declaration without loading
a numerical library.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from torlab.errors import TorlabInputError

__all__ = ["CHECKS", "HEAD_BYTES", "Command", "Option", "convert_options", "read_head"]

#: bytes read from the start of a file to detect its format
HEAD_BYTES = 4096

#: option checks: name -> (test of the SI value, message after the value as given)
CHECKS: dict[str, tuple[Any, str]] = {
    "positive": (lambda v: v > 0, " must be positive"),
    "nonneg": (lambda v: v >= 0, " must not be negative"),
    "fraction": (lambda v: 0 < v <= 1, " must be in (0, 1]"),
    "open_fraction": (lambda v: 0 < v < 1, " must be in (0, 1)"),
    "coefficient": (lambda v: 0 <= v < 10, ": give a coefficient such as 0.15"),
}


#: option kinds that are not quantities
_NOT_QUANTITIES = frozenset({"number", "text", "flag", "choice", "path", "paths", "object"})


@dataclass(frozen=True)
class Option:
    """One option of a reduction, declared once for the library, the commands and protocols.

    Attributes
    ----------
    kind
        A :data:`torlab.units.KINDS` quantity kind (values may be unit strings such as
        ``"20 um"``; plain numbers are SI), or ``"number"``, ``"text"``, ``"flag"``,
        ``"choice"``, ``"path"``, ``"paths"`` or ``"object"`` (a library object passed
        as it is; text on the command line and in a protocol).
    default
        Default value, SI for a quantity (None: not set).
    help
        One sentence or two: what it does (the command's ``--help``, ``torlab reduce
        --list`` and the protocol reference show this text).
    choices
        The values of a ``"choice"``.
    check
        A :data:`CHECKS` name: ``"positive"``, ``"nonneg"``, ``"fraction"``
        (0 < v <= 1), ``"open_fraction"`` (0 < v < 1), ``"coefficient"`` (0 <= v < 10).
    unit
        The unit a quantity's default is shown in (``"um"``: ``[default: 20 um]``).
    flag
        Its command-line flag when not ``--<name with dashes>`` (the PCS ``family`` is
        ``--instrument``); None: not on the command line.
    key
        Its key in the protocol's ``data:`` section when not the name; None: not in a
        protocol.
    group
        Protocol: the mapping of the section that holds it (``time_test``).
    quantity
        Protocol: the :data:`torlab.units.RANGES` entry its value is checked against.
    reads_any
        Given, a folder contributes every data file, not only the ones detected as this
        instrument (a column map makes another rig's CSV readable).
    """

    kind: str
    default: Any = None
    help: str = ""
    choices: tuple[str, ...] = ()
    check: str = ""
    unit: str = ""
    flag: str | None = ""
    key: str | None = ""
    group: str = ""
    quantity: str = ""
    reads_any: bool = False

    def cli_flag(self, name: str) -> str | None:
        """The command-line flag of option ``name`` (None: not on the command line)."""
        if self.flag is None:
            return None
        return self.flag or "--" + name.replace("_", "-")

    def protocol_key(self, name: str) -> str | None:
        """The key of option ``name`` in a protocol section (None: not in a protocol)."""
        if self.key is None:
            return None
        return self.key or name

    @property
    def is_quantity(self) -> bool:
        """A :data:`torlab.units.KINDS` quantity (a value may carry a unit)."""
        return self.kind not in _NOT_QUANTITIES

    def shown_default(self) -> Any:
        """The default as a user writes it: a quantity in its :attr:`unit` (``"20 um"``)."""
        if self.default is None or not self.unit:
            return self.default
        scale = _prefix_scale(self.unit, self.kind)
        offset = 0.0
        if scale is None:  # not an SI unit with a prefix: the unit table (or pint)
            from torlab.units import parse_unit_factor

            scale, offset = parse_unit_factor(self.unit, self.kind)
        return f"{(self.default - offset) / scale:.6g} {self.unit}"


@dataclass(frozen=True)
class Command:
    """How an instrument meets its users: the command group ``torlab <name>`` with its
    ``reduce`` command, and the protocol's ``data: <name>:`` section.

    Attributes
    ----------
    name
        The command group and the protocol section (``"mtm"`` for the PCS exports).
    help
        The group's help (one sentence).
    reduce
        The ``reduce`` command's help: what it computes, then (after a blank line) what
        it writes.
    inputs
        Help of the files argument.
    argument
        The files argument's name (shown as ``FILES...`` in the usage line).
    what
        One input file in messages (``"HPT log"``: "no HPT log file in the folder ...").
    """

    name: str
    help: str
    reduce: str
    inputs: str
    argument: str = "files"
    what: str = "input"


#: SI units of the quantity kinds options use, and the prefixes a shown default may carry:
#: ``torlab --help`` shows ``[default: 20 um]`` without loading the unit table
_SI_UNITS = {"length": "m", "time": "s", "temperature_difference": "K", "pressure": "Pa",
             "force": "N", "mass": "kg", "frequency": "Hz"}
_PREFIXES = {"": 1.0, "n": 1e-9, "u": 1e-6, "µ": 1e-6, "m": 1e-3, "k": 1e3, "M": 1e6,
             "G": 1e9}


def _prefix_scale(unit: str, kind: str) -> float | None:
    """The factor of ``unit`` to SI when it is the kind's SI unit with a prefix (``um``),
    else None (tests/test_instruments.py checks it against :func:`torlab.units.to_si`)."""
    si = _SI_UNITS.get(kind)
    if si is None or not unit.endswith(si) or kind == "mass":
        return None
    return _PREFIXES.get(unit[: -len(si)])


def read_head(path: str | os.PathLike[str]) -> str:
    """The first :data:`HEAD_BYTES` of a file as text, for ``detect``: as the parsers read
    it (:func:`torlab.parsers._table.head_text`: UTF-8, else Windows-1252; UTF-16 by its
    byte-order mark; every line end one ``\\n``)."""
    from torlab.parsers._table import head_text

    return head_text(path, HEAD_BYTES)


def convert_options(spec: Mapping[str, Option], options: Mapping[str, Any], owner: str
                    ) -> dict[str, Any]:
    """Check option names and convert values (unit strings to SI) against ``spec``.

    Options not given take their defaults.  Unknown names are errors with a
    "did you mean" suggestion; ``owner`` names the instrument in that message.
    """
    from torlab._suggest import did_you_mean

    out = {k: o.default for k, o in spec.items()}
    for k, v in options.items():
        name = k.replace("-", "_")
        if name not in spec:
            raise TorlabInputError(f"unknown option {k!r} for {owner} (options: "
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
    if o.kind == "path":  # a library caller may give the object a path names (a column map)
        return Path(v) if isinstance(v, (str, os.PathLike)) else v
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
    else:  # pragma: no cover - a declaration mistake (tests/test_instruments.py checks them)
        raise ValueError(f"option {name}: unknown kind {o.kind!r}")
    _check(o.check, x, name, v)
    return x


def _check(check: str, x: float, name: str, given: Any) -> None:
    if not math.isfinite(x):
        raise TorlabInputError(f"{given!r} is not a finite number", key=name)
    test = CHECKS.get(check)
    if test is not None and not test[0](x):
        raise TorlabInputError(f"{given!r}{test[1]}", key=name)
