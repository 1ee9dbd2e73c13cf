"""'Did you mean ...?' for unknown names (options, keys, instruments)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

__all__ = ["did_you_mean", "key_suggestion", "literal_suggestion", "word_or"]


def did_you_mean(word: str, choices: Iterable[str], *, n: int = 1) -> str:
    """``" (did you mean 'x'?)"`` for the closest of ``choices``, or ``""`` when none is close.

    Uses :func:`difflib.get_close_matches` (ratio >= 0.6), case-insensitive.
    """
    import difflib

    choices = [str(c) for c in choices]
    lower = {c.lower(): c for c in choices}
    hits = difflib.get_close_matches(str(word).lower(), list(lower), n=n, cutoff=0.6)
    if not hits:
        return ""
    return " (did you mean " + " or ".join(repr(lower[h]) for h in hits) + "?)"


def literal_suggestion(err: dict[str, Any]) -> str:
    """``did_you_mean`` for a value outside a pydantic ``Literal`` (a ``literal_error``):
    the allowed values are the quoted ones of the error's ``expected``."""
    import re

    expected = str((err.get("ctx") or {}).get("expected", ""))
    value = err.get("input")
    if not isinstance(value, str):
        return ""
    return did_you_mean(value, re.findall(r"'([^']*)'", expected))


def word_or(value: Any, word: str, convert: Any, error: Any = ValueError) -> Any:
    """``word`` itself (``'fit'``, ``'auto'``), or ``convert(value)`` (a quantity).

    A value ``convert`` refuses that is a misspelling of ``word`` is answered with
    ``error(message)`` saying so ("did you mean 'auto'?"); other refusals pass unchanged.
    """
    if value == word:
        return word
    try:
        return convert(value)
    except Exception:
        hint = did_you_mean(value, [word]) if isinstance(value, str) else ""
        if not hint:
            raise
        raise error(f"{value!r} is neither {word!r} nor a quantity{hint}") from None


def key_suggestion(model: Any, loc: tuple[Any, ...]) -> str:
    """``did_you_mean`` for an unknown key at ``loc`` of a pydantic model (a scene, a protocol).

    The known keys are the fields (and aliases) of the model the key's parent
    location resolves to; ``""`` when that cannot be told.
    """
    if not loc:
        return ""
    parent = _model_at(model, loc[:-1])
    if parent is None:
        return ""
    names = set()
    for name, f in parent.model_fields.items():
        names.add(f.alias or name)
    return did_you_mean(str(loc[-1]), sorted(names))


def _model_at(model: Any, loc: tuple[Any, ...]) -> Any:
    """The pydantic model class at a location (list indices and dict keys skipped)."""
    import typing

    cur = model
    for part in loc:
        if isinstance(part, int):
            continue
        fields = getattr(cur, "model_fields", None)
        if fields is None:
            return None
        f = fields.get(part) or next((v for v in fields.values() if v.alias == part), None)
        if f is None:
            return None
        cur = _inner_model(f.annotation, typing)
        if cur is None:
            return None
    return cur if hasattr(cur, "model_fields") else None


def _inner_model(tp: Any, typing: Any) -> Any:
    """The first pydantic model inside an annotation (Optional, list, Annotated, unions)."""
    if hasattr(tp, "model_fields"):
        return tp
    for arg in typing.get_args(tp):
        m = _inner_model(arg, typing)
        if m is not None:
            return m
    return None
