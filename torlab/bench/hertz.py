"""Benchmark of the normal contact: the thesis's approximate Hertz against the exact solution.

Variants, each timed per call and compared, for a/b from 0.1 to 10, with an
independent high-precision solution (mpmath at 30 digits: the eccentricity
from ``mpmath.findroot`` on Johnson's Eq. 4.39 with ``mpmath.ellipk/ellipe``,
then Eqs. 4.40-4.41):

* ``approximate (Hamrock-Brewe, Eqs. 5.8-5.12)`` --
  :func:`torlab.model.hertz.hertz_approximate`, the scene default
  (``contact.hertz: approximate``);
* ``exact (elliptic integrals)`` -- :func:`torlab.model.hertz.hertz_exact`.

The error of a variant is the largest relative error of ``a``, ``b`` and
``p0`` over the ratios; ``extra`` gives each quantity's error separately, the
error over the near-circular range 0.5 <= a/b <= 2, and the speed ratio of the
exact solution to the approximation.

The ratios are set through the radii: a steel wheel-rail pair (E = 210 GPa,
nu = 0.28, F = 20 kN) with ``rx = 350 mm`` and ``ry = rx / c``; ``c`` is chosen
from a geometric range of curvature ratios wide enough that the exact a/b spans
0.1 ... 10.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from torlab.bench import BenchRow, median_time
from torlab.model.hertz import E_star, hertz_approximate, hertz_exact

__all__ = ["hertz_reference", "run"]

F_N = 20e3
RX = 0.35
ES = E_star(210e9, 0.28, 210e9, 0.28)
#: curvature ratios rx/ry; (rx/ry)^0.636 * 1.0339 ~ a/b, so 1/40 ... 40 covers a/b 0.1 ... 10
_RATIO_SPAN = 40.0


@lru_cache(maxsize=64)
def hertz_reference(F: float, rx: float, ry: float, Es: float) -> tuple[float, float, float]:
    """``(a, b, p0)`` of the exact Hertz contact at 30 digits (mpmath), independent of torlab.

    Johnson (*Contact Mechanics*, 1985) Eqs. 4.39-4.41 with ``e^2 = 1 - (b/a)^2``
    for ``rx >= ry``: ``rx/ry = [E(e)/(1-e^2) - K(e)] / [K(e) - E(e)]``,
    ``a^3 = 3 F rx (K - E) / (pi E* e^2)``; the axes swap for ``rx < ry``.
    """
    import mpmath

    with mpmath.workdps(30):
        big, small = (mpmath.mpf(ry), mpmath.mpf(rx)) if rx < ry else (mpmath.mpf(rx), mpmath.mpf(ry))
        F_, Es_ = mpmath.mpf(F), mpmath.mpf(Es)
        ratio = big / small
        if ratio == 1:
            long_ = (3 * F_ * big / (4 * Es_)) ** (mpmath.mpf(1) / 3)
            short = long_
        else:
            def f(m):
                K, E = mpmath.ellipk(m), mpmath.ellipe(m)
                return (E / (1 - m) - K) / (K - E) - ratio

            # bracket in m = e^2 by bisection on a log scale of 1 - m, then refine
            lo, hi = mpmath.mpf("1e-20"), 1 - mpmath.mpf("1e-25")
            m = mpmath.findroot(f, (lo, hi), solver="anderson", tol=mpmath.mpf(10) ** -28,
                                maxsteps=500)
            K, E = mpmath.ellipk(m), mpmath.ellipe(m)
            long_ = (3 * F_ * big * (K - E) / (mpmath.pi * Es_ * m)) ** (mpmath.mpf(1) / 3)
            short = long_ * mpmath.sqrt(1 - m)
        a, b = (short, long_) if rx < ry else (long_, short)
        p0 = 3 * F_ / (2 * mpmath.pi * a * b)
        return float(a), float(b), float(p0)


def _ry_values(quick: bool) -> np.ndarray:
    n = 9 if quick else 41
    return RX / np.geomspace(1.0 / _RATIO_SPAN, _RATIO_SPAN, n)


def _errors(fn, rys: np.ndarray) -> dict[str, np.ndarray]:
    """Relative errors of a, b, p0 and the reference a/b, one entry per ry."""
    ea, eb, ep, ab = [], [], [], []
    for ry in rys:
        ref = hertz_reference(F_N, RX, float(ry), ES)
        got = fn(F_N, RX, float(ry), ES)
        ea.append(got.a / ref[0] - 1.0)
        eb.append(got.b / ref[1] - 1.0)
        ep.append(got.p0 / ref[2] - 1.0)
        ab.append(ref[0] / ref[1])
    return {"a": np.abs(ea), "b": np.abs(eb), "p0": np.abs(ep), "a_over_b": np.array(ab)}


def run(quick: bool = False) -> list[BenchRow]:
    """Time and error of the approximate and exact Hertz solutions (see the module docstring).

    Parameters
    ----------
    quick
        9 ratios instead of 41 and fewer repeats.
    """
    rys = _ry_values(quick)
    variants = [
        ("approximate (Hamrock-Brewe, Eqs. 5.8-5.12)", hertz_approximate, True),
        ("exact (elliptic integrals, bracketed root)", hertz_exact, False),
    ]
    repeat = 3 if quick else 7
    measured = []
    for name, fn, default in variants:
        def one(fn=fn) -> None:
            for ry in rys:
                fn(F_N, RX, float(ry), ES)

        t = median_time(one, repeat=repeat, min_time=0.02 if quick else 0.1) / len(rys)
        errs = _errors(fn, rys)
        measured.append((name, default, t, errs))
    t_approx = measured[0][2]
    rows = []
    for name, default, t, errs in measured:
        ab = errs["a_over_b"]
        worst = np.maximum(np.maximum(errs["a"], errs["b"]), errs["p0"])
        near = (ab >= 0.5 - 1e-9) & (ab <= 2.0 + 1e-9)
        k = int(np.argmax(worst))
        rows.append(BenchRow(
            component="Hertz contact", variant=name, time_s=t, error=float(worst.max()),
            reference="mpmath 30-digit elliptic-integral solution (Johnson Eqs. 4.39-4.41)",
            default=default,
            unit_of_work="one contact (F, rx, ry, E*) -> a, b, p0",
            extra={
                "a_over_b_range": f"{ab.min():.3g}-{ab.max():.3g} ({len(ab)} ratios)",
                "max_rel_error_a": float(errs["a"].max()),
                "max_rel_error_b": float(errs["b"].max()),
                "max_rel_error_p0": float(errs["p0"].max()),
                "max_rel_error_a_over_b_0.5_2": float(worst[near].max()),
                "worst_a_over_b": float(ab[k]),
                "time_ratio_to_approximate": t / t_approx,
            }))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for r in run(quick=False):
        print(r.to_dict())
