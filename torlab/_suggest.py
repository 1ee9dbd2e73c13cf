"""'Did you mean ...?' for unknown names (options, keys, instruments)."""

from __future__ import annotations

from collections.abc import Iterable

__all__ = ["did_you_mean"]


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
