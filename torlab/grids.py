"""Value lists and grids as users write them: ``start:stop:count`` or ``a, b, c``, with units."""

from __future__ import annotations

from typing import Any

from torlab.errors import TorlabInputError

__all__ = ["parse_values"]


def parse_values(spec: str, kind: str, option: str, quantity: str | None = None) -> Any:
    """Parse ``start:stop:num`` (inclusive, like ``numpy.linspace``) or a comma list.

    Plain numbers are SI; each value may carry its own unit
    (``"10 mm/s:2 m/s:50"``, ``"0.1 %,1 %"``).  ``kind`` is a
    :data:`torlab.units.KINDS` key; with ``quantity`` (a
    :data:`torlab.units.RANGES` key) every value is range-checked.

    Returns
    -------
    numpy.ndarray
        The values in SI units.
    """
    import numpy as np

    from torlab.units import to_si

    s = spec.strip()
    if not s:
        raise TorlabInputError("empty value list", key=option)
    if ":" in s and "," not in s:
        parts = s.split(":")
        if len(parts) != 3:
            raise TorlabInputError(f"{spec!r}: write start:stop:count, e.g. 0:0.05:101", key=option)
        start = to_si(parts[0], kind, where=option)
        stop = to_si(parts[1], kind, where=option)
        try:
            num = int(parts[2])
        except ValueError:
            raise TorlabInputError(f"{spec!r}: the count {parts[2]!r} is not an integer",
                                   key=option) from None
        if num < 1 or num > 100_000:
            raise TorlabInputError(f"{spec!r}: count must be between 1 and 100000", key=option)
        vals = [start, stop]
        out = np.linspace(start, stop, num)
    else:
        vals = [to_si(v, kind, where=option) for v in s.split(",") if v.strip()]
        if not vals:
            raise TorlabInputError(f"{spec!r}: no values", key=option)
        out = np.asarray(vals, dtype=float)
    if quantity is not None:
        from torlab.units import check_range

        for v in vals:
            check_range(quantity, v, where=option)
    return out
