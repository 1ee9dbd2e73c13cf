"""Kalker's creepage coefficient C11 and the FASTSIM flexibility (thesis Eq. 5.17).

The table is Kalker's (1967 thesis; 1990 book Table E.3) as carried by the
open-source CONTACT program (routine ``linrol``); ``docs/model/kalker.md``
explains it.  Interpolation follows CONTACT so results compare with
it: linear in ``g`` between rows; in ``nu`` a quadratic through nu = 0, 0.25,
0.5 applied to ``1/C``.  Below ``g = 0.1`` (an extreme contact) the asymptotes
are used and :func:`C11` reports it: the table is never extrapolated.

With two different materials (steel ball on glass) Kalker's combined constants
are used (``docs/model/thesis-reading.md``): ``2/G = 1/G1 + 1/G2``,
``nu = (G/2) (nu1/G1 + nu2/G2)``, ``Gi = Ei / (2 (1 + nu_i))``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = ["C11", "L1", "ExtremeContactWarning", "combined_G_nu"]

_G = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0])
#: a <= b (g = a/b): C11 at nu = 0, 0.25, 0.5
_A_LE_B = np.array([
    [2.51, 3.31, 4.85], [2.59, 3.37, 4.81], [2.68, 3.44, 4.80], [2.78, 3.53, 4.82],
    [2.88, 3.62, 4.83], [2.98, 3.72, 4.91], [3.09, 3.81, 4.97], [3.19, 3.91, 5.05],
    [3.29, 4.01, 5.12], [3.40, 4.12, 5.20],
])
#: a > b (g = b/a)
_A_GT_B = np.array([
    [10.7, 11.7, 12.9], [6.96, 7.78, 8.82], [5.57, 6.34, 7.34], [4.84, 5.57, 6.57],
    [4.37, 5.10, 6.11], [4.06, 4.78, 5.80], [3.82, 4.54, 5.58], [3.65, 4.36, 5.42],
    [3.51, 4.22, 5.30], [3.40, 4.12, 5.20],
])


class ExtremeContactWarning(UserWarning):
    """The contact is more elongated than Kalker's table (g < 0.1): asymptotes used."""


def combined_G_nu(E1: float, nu1: float, E2: float, nu2: float) -> tuple[float, float]:
    """Kalker's combined shear modulus and Poisson ratio of two materials.

    ``2/G = 1/G1 + 1/G2``, ``nu = (G/2) (nu1/G1 + nu2/G2)``, ``Gi = Ei/(2(1+nu_i))``.
    """
    G1 = E1 / (2 * (1 + nu1))
    G2 = E2 / (2 * (1 + nu2))
    G = 2.0 / (1.0 / G1 + 1.0 / G2)
    nu = 0.5 * G * (nu1 / G1 + nu2 / G2)
    return G, nu


def _nu_interp(c0: float, c25: float, c50: float, nu: float) -> float:
    inv = (8 * (nu - 0.25) * (nu - 0.5) / c0 - 16 * nu * (nu - 0.5) / c25
           + 8 * nu * (nu - 0.25) / c50)
    return 1.0 / inv


def C11(a_over_b: float, nu: float, *, warn: bool = True) -> float:
    """Kalker's longitudinal creepage coefficient ``C11(a/b, nu)``.

    Parameters
    ----------
    a_over_b
        Semi-axis in the rolling direction over the lateral one.
    nu
        (Combined) Poisson ratio, 0 <= nu <= 0.5.
    warn
        Emit :class:`ExtremeContactWarning` below the table (g < 0.1).

    Returns
    -------
    float
        C11 (dimensionless).  Checks (``docs/model/kalker.md``): nu = 0.28 gives 3.7335
        (a/b = 0.5), 4.2262 (1), 5.2037 (2).
    """
    if not (a_over_b > 0 and math.isfinite(a_over_b)):
        raise ValueError(f"a/b must be positive and finite, got {a_over_b}")
    if not 0.0 <= nu <= 0.5:
        raise ValueError(f"Poisson ratio must be in [0, 0.5], got {nu}")
    if a_over_b <= 1.0:
        g, table = a_over_b, _A_LE_B
    else:
        g, table = 1.0 / a_over_b, _A_GT_B
    if g < 0.1:
        if warn:
            warnings.warn(f"contact ellipse a/b = {a_over_b:.4g} lies outside Kalker's table "
                          "(0.1 <= g <= 1): using the asymptotic C11", ExtremeContactWarning,
                          stacklevel=2)
        if a_over_b <= 1.0:
            return math.pi**2 / (4 * (1 - nu))
        lam = math.log(16 / g**2)
        return 2 * math.pi / ((lam - 2 * nu) * g) * (1 + (3 - math.log(4)) / (lam - 2 * nu))
    cols = [float(np.interp(g, _G, table[:, k])) for k in range(3)]
    return _nu_interp(*cols, nu)


def L1(a: float, C11_: float, G: float) -> float:
    """Kalker flexibility of the bodies ``L1 = 8a / (3 C11 G)`` (Eq. 5.17), m/Pa."""
    return 8.0 * a / (3.0 * C11_ * G)
