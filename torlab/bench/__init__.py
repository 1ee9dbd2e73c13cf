"""Speed-against-error benchmarks (``torlab bench``).

Each benchmark module (``torlab.bench.<component>``) provides

    def run(quick: bool = False) -> list[BenchRow]

measuring, *in one run on the current machine*, the time and the error of each
numerical choice of its component against a reference, and marking the default.
Times are medians of repeats (:func:`median_time`); ratios between variants
measured side by side are what the benchmark reports, because the machines
are shared and noisy.  No unit test asserts a time.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

__all__ = ["BenchRow", "median_time", "median_time_and_value"]


@dataclass
class BenchRow:
    """One measured variant.

    Attributes
    ----------
    component
        What is measured (``"F_n"``, ``"fastsim traction curve"``, ...).
    variant
        Scheme/grid/method (``"exact (pbdv)"``, ``"thesis quadrature 1000 steps"``).
    time_s
        Median wall time of one evaluation of the benchmark's unit of work.
    error
        Error against ``reference`` (relative unless ``error_kind`` says otherwise);
        ``None`` where not applicable.
    reference
        What the error is measured against.
    default
        Whether this variant is torlab's default.
    unit_of_work
        What one timed evaluation does (``"101-point traction curve"``).
    extra
        Other figures (iterations, failures, ratio to a baseline ...).
    """

    component: str
    variant: str
    time_s: float
    error: float | None = None
    reference: str = ""
    default: bool = False
    unit_of_work: str = ""
    error_kind: str = "relative"
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Flat dict for tables."""
        d = asdict(self)
        extra = d.pop("extra")
        d.update({f"x_{k}": v for k, v in extra.items()})
        return d


def median_time(fn: Callable[[], Any], *, repeat: int = 5, min_time: float = 0.05,
                max_loops: int = 10_000) -> float:
    """Median over ``repeat`` rounds of the mean time of one call of ``fn`` (s).

    Each round calls ``fn`` enough times to last at least ``min_time``.
    """
    t0 = time.perf_counter()
    fn()
    one = time.perf_counter() - t0
    loops = max(1, min(max_loops, int(min_time / max(one, 1e-9))))
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(loops):
            fn()
        samples.append((time.perf_counter() - t0) / loops)
    samples.sort()
    return samples[len(samples) // 2]


def median_time_and_value(fn: Callable[[], Any], **options: Any) -> tuple[float, Any]:
    """:func:`median_time` of ``fn`` and the value of its last call: for work whose result
    the benchmark reports too (not computed once more; ``fn`` must be deterministic)."""
    last: list[Any] = []

    def call() -> Any:
        last[:] = [fn()]
        return last[0]

    return median_time(call, **options), last[0]
