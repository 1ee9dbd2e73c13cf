"""Benchmark of ``F_n`` (Greenwood–Williamson, Eq. 5.43): time and error of each evaluator.

Variants, each timed on the same array of arguments spanning t = -5 ... 10 and
compared with an mpmath reference (parabolic cylinder form at 30 digits,
computed once per process and cached):

* ``interpolated ln F_n`` -- :func:`torlab.model.asperity.F_n`, torlab's default;
* ``exact (Gauss quadratures + moment series)`` -- :func:`~torlab.model.asperity.F_n_exact`;
* ``raw pbdv`` -- the textbook exact form with ``scipy.special.pbdv``;
* ``thesis quadrature 1000 steps`` -- the thesis's trapezoidal rule up to 30.

``extra`` carries the time per point, the speed ratio to the thesis quadrature
and, for the default, the error over the whole range t = -40 ... 38.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from torlab.bench import BenchRow, median_time
from torlab.model.asperity import F_n, F_n_exact, F_n_pbdv, F_n_thesis_quadrature

__all__ = ["run"]

ORDERS = (1.5, 4.0)


@lru_cache(maxsize=16)
def _reference(n: float, lo: float, hi: float, m: int) -> tuple[np.ndarray, np.ndarray, str]:
    """(t, F_n(t), description) on ``m`` points; mpmath if installed, else F_n_exact."""
    t = np.linspace(lo, hi, m)
    try:
        import mpmath
    except ImportError:  # pragma: no cover - mpmath comes with the test extra
        return t, F_n_exact(n, t), "F_n_exact (mpmath not installed)"
    with mpmath.workdps(30):
        nn = mpmath.mpf(n)
        pref = mpmath.gamma(nn + 1) / mpmath.sqrt(2 * mpmath.pi)
        vals = [float(pref * mpmath.exp(-mpmath.mpf(x) ** 2 / 4) * mpmath.pcfd(-(nn + 1), x))
                for x in t.tolist()]
    return t, np.array(vals), "mpmath pcfd, 30 digits"


def _max_rel(got: np.ndarray, ref: np.ndarray) -> float:
    ok = ref > 0
    return float(np.max(np.abs(got[ok] / ref[ok] - 1.0)))


def run(quick: bool = False) -> list[BenchRow]:
    """Time and error of the ``F_n`` evaluators (see the module docstring).

    Parameters
    ----------
    quick
        Fewer points (2000 timed, 60 reference) for a smoke run.
    """
    n_time = 2_000 if quick else 10_000
    n_ref = 60 if quick else 400
    t = np.linspace(-5.0, 10.0, n_time)
    variants = [
        ("interpolated ln F_n (piecewise Chebyshev)", F_n, True),
        ("exact (Gauss quadratures + moment series)", F_n_exact, False),
        ("raw pbdv", F_n_pbdv, False),
        ("thesis quadrature 1000 steps", F_n_thesis_quadrature, False),
    ]
    rows: list[BenchRow] = []
    for n in ORDERS:
        t_ref, f_ref, ref_name = _reference(n, -5.0, 10.0, n_ref)
        F_n(n, 0.0)  # build the interpolant outside the timing
        times = {}
        measured = []
        for name, fn, default in variants:
            tm = median_time(lambda fn=fn, n=n: fn(n, t), repeat=3 if quick else 5,
                             min_time=0.02 if quick else 0.1)
            times[name] = tm
            measured.append((name, fn, default, tm, _max_rel(fn(n, t_ref), f_ref)))
        base = times["thesis quadrature 1000 steps"]
        for name, fn, default, tm, err in measured:
            extra = {"n": n, "time_per_point_s": tm / n_time,
                     "speedup_vs_thesis": base / tm}
            if default:
                tw, fw, _ = _reference(n, -40.0, 38.0, 40 if quick else 120)
                extra["max_rel_error_t_-40_38"] = _max_rel(fn(n, tw), fw)
            rows.append(BenchRow(
                component=f"F_{n:g}", variant=name, time_s=tm, error=err,
                reference=f"{ref_name}, {n_ref} points in [-5, 10]", default=default,
                unit_of_work=f"F_n at {n_time} points in [-5, 10]", extra=extra))
    return rows
