"""Kalker's creepage coefficients C11, C22, C23 and the FASTSIM flexibilities (thesis Eq. 5.17).

The table is Kalker's (1967 thesis; 1990 book Table E.3) as carried by the
open-source CONTACT program (routine ``linrol``); ``docs/model/kalker.md``
explains it.  Interpolation follows CONTACT so results compare with it: linear
in ``g`` between rows; in ``nu`` a quadratic through nu = 0, 0.25, 0.5 applied to
``1/C``.  Below ``g = 0.1`` (an extreme contact) Kalker's asymptotes for a
slender ellipse are used and the functions report it: the table is never
extrapolated.

Flexibilities of Kalker's simplified theory with three flexibilities (Kalker
1982, Vehicle System Dynamics 11), chosen so that FASTSIM in full adhesion
reproduces the linear theory ``Fx = G a b C11 xi``, ``Fy = G a b (C22 eta +
sqrt(ab) C23 phi)``: ``L1 = 8a/(3 C11 G)``, ``L2 = 8a/(3 C22 G)``,
``L3 = pi a sqrt(a/b)/(4 C23 G)``.

With two different materials (steel ball on glass) Kalker's combined constants
are used (``docs/model/thesis-reading.md``): ``2/G = 1/G1 + 1/G2``,
``nu = (G/2) (nu1/G1 + nu2/G2)``, ``Gi = Ei / (2 (1 + nu_i))``.

References
----------
.. [1] Kalker, J. J. (1990). Three-Dimensional Elastic Bodies in Rolling Contact. Solid
   Mechanics and its Applications 2, Kluwer, Dordrecht.
   https://doi.org/10.1007/978-94-015-7889-9
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = ["C11", "C22", "C23", "C33", "L1", "L2", "L3", "ExtremeContactWarning", "combined_G_nu",
           "creepage_coefficients"]

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
#: C22 (lateral creepage) at nu = 0, 0.25, 0.5; a <= b, then a > b
_C22_A_LE_B = np.array([
    [2.51, 2.52, 2.53], [2.59, 2.63, 2.66], [2.68, 2.75, 2.81], [2.78, 2.88, 2.98],
    [2.88, 3.01, 3.14], [2.98, 3.14, 3.31], [3.09, 3.28, 3.48], [3.19, 3.41, 3.65],
    [3.29, 3.54, 3.82], [3.40, 3.67, 3.98],
])
_C22_A_GT_B = np.array([
    [10.7, 12.8, 16.0], [6.96, 8.14, 9.79], [5.57, 6.40, 7.51], [4.84, 5.48, 6.31],
    [4.37, 4.90, 5.56], [4.06, 4.50, 5.04], [3.82, 4.21, 4.67], [3.65, 3.99, 4.39],
    [3.51, 3.81, 4.16], [3.40, 3.67, 3.98],
])
#: C23 (spin into lateral force) at nu = 0, 0.25, 0.5; a <= b, then a > b
_C23_A_LE_B = np.array([
    [.334, .473, .731], [.483, .603, .809], [.607, .715, .889], [.720, .823, .977],
    [.827, .929, 1.07], [.930, 1.03, 1.18], [1.03, 1.14, 1.29], [1.13, 1.25, 1.40],
    [1.23, 1.36, 1.51], [1.33, 1.47, 1.63],
])
_C23_A_GT_B = np.array([
    [12.2, 14.6, 18.0], [5.72, 6.63, 7.89], [3.79, 4.32, 5.01], [2.88, 3.24, 3.70],
    [2.35, 2.62, 2.96], [2.01, 2.23, 2.50], [1.76, 1.95, 2.18], [1.58, 1.75, 1.94],
    [1.44, 1.59, 1.77], [1.33, 1.47, 1.63],
])
#: C33 (spin into the spin moment) at nu = 0, 0.25, 0.5; a <= b, then a > b (Kalker 1990,
#: Table E.3; torlab's exact solver reproduces the rows a/b = 0.5, 1, 2 within 0.5 %)
_C33_A_LE_B = np.array([
    [6.42, 8.28, 11.7], [3.46, 4.27, 5.66], [2.49, 2.96, 3.72], [2.02, 2.32, 2.77],
    [1.74, 1.93, 2.22], [1.56, 1.68, 1.86], [1.43, 1.50, 1.60], [1.34, 1.37, 1.42],
    [1.27, 1.27, 1.27], [1.21, 1.19, 1.16],
])
_C33_A_GT_B = np.array([
    [.796, .526, .228], [.826, .601, .341], [.868, .674, .446], [.912, .747, .549],
    [.958, .819, .650], [1.01, .892, .751], [1.05, .965, .852], [1.10, 1.04, .954],
    [1.16, 1.11, 1.06], [1.21, 1.19, 1.16],
])
_TABLES = {"C11": (_A_LE_B, _A_GT_B), "C22": (_C22_A_LE_B, _C22_A_GT_B),
           "C23": (_C23_A_LE_B, _C23_A_GT_B), "C33": (_C33_A_LE_B, _C33_A_GT_B)}


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


def _check(a_over_b: float, nu: float) -> None:
    if not (a_over_b > 0 and math.isfinite(a_over_b)):
        raise ValueError(f"a/b must be positive and finite, got {a_over_b}")
    if not 0.0 <= nu <= 0.5:
        raise ValueError(f"Poisson ratio must be in [0, 0.5], got {nu}")


def _asymptote(name: str, a_over_b: float, g: float, nu: float) -> float:
    """Kalker's asymptotes of a slender ellipse (g -> 0), as CONTACT's ``linrol`` uses them."""
    if a_over_b <= 1.0:  # a << b: a narrow ellipse across the rolling direction
        if name == "C11":
            return math.pi**2 / (4 * (1 - nu))
        if name == "C22":
            return math.pi**2 / 4
        return math.pi * math.sqrt(g) / (3 * (1 - nu)) * (1 + nu * (math.log(16 / g) - 5))
    lam = math.log(16 / g**2)  # a >> b: a long ellipse along the rolling direction
    if name == "C11":
        return 2 * math.pi / ((lam - 2 * nu) * g) * (1 + (3 - math.log(4)) / (lam - 2 * nu))
    if name == "C22":
        d = (1 - nu) * lam + 2 * nu
        return 2 * math.pi / g * (1 + (1 - nu) * (3 - math.log(4)) / d) / d
    return 2 * math.pi / (3 * g**1.5 * ((1 - nu) * lam - 2 + 4 * nu))


def _coefficient(name: str, a_over_b: float, nu: float, warn: bool) -> float:
    _check(a_over_b, nu)
    le, gt = _TABLES[name]
    if a_over_b <= 1.0:
        g, table = a_over_b, le
    else:
        g, table = 1.0 / a_over_b, gt
    if g < 0.1:
        if warn:
            warnings.warn(f"contact ellipse a/b = {a_over_b:.4g} lies outside Kalker's table "
                          f"(0.1 <= g <= 1): using the asymptotic {name}", ExtremeContactWarning,
                          stacklevel=3)
        return _asymptote(name, a_over_b, g, nu)
    cols = [float(np.interp(g, _G, table[:, k])) for k in range(3)]
    return _nu_interp(*cols, nu)


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
    return _coefficient("C11", a_over_b, nu, warn)


def C22(a_over_b: float, nu: float, *, warn: bool = True) -> float:
    """Kalker's lateral creepage coefficient ``C22(a/b, nu)`` (same table rules as :func:`C11`)."""
    return _coefficient("C22", a_over_b, nu, warn)


def C23(a_over_b: float, nu: float, *, warn: bool = True) -> float:
    """Kalker's spin coefficient ``C23(a/b, nu)``: ``Fy = G c^2 (C22 eta + c C23 phi)``, ``c = sqrt(ab)``."""
    return _coefficient("C23", a_over_b, nu, warn)


def C33(a_over_b: float, nu: float) -> float:
    """Kalker's spin-moment coefficient ``C33(a/b, nu)``: ``Mz = G c^4 (c C33 phi - C23 eta)``.

    Kalker's table (1990, Table E.3) with the rules of :func:`C11`, for
    ``0.1 <= g <= 1`` only: below, no asymptote is carried and ValueError is raised.
    ``C32``, the lateral creepage's moment, equals ``C23`` (reciprocity).
    """
    _check(a_over_b, nu)
    g = a_over_b if a_over_b <= 1.0 else 1.0 / a_over_b
    if g < 0.1:
        raise ValueError(f"a/b = {a_over_b:.4g} lies outside Kalker's table of C33 "
                         "(0.1 <= g <= 1)")
    return _coefficient("C33", a_over_b, nu, False)


def creepage_coefficients(a_over_b: float, nu: float, *, warn: bool = True
                          ) -> tuple[float, float, float]:
    """``(C11, C22, C23)`` at once; one :class:`ExtremeContactWarning` below the table."""
    with warnings.catch_warnings(record=True) as wl:
        warnings.simplefilter("always", ExtremeContactWarning)
        out = (C11(a_over_b, nu), C22(a_over_b, nu), C23(a_over_b, nu))
    if warn and wl:
        warnings.warn(f"contact ellipse a/b = {a_over_b:.4g} lies outside Kalker's table "
                      "(0.1 <= g <= 1): using the asymptotic C11, C22, C23",
                      ExtremeContactWarning, stacklevel=2)
    return out


def L1(a: float, C11_: float, G: float) -> float:
    """Kalker flexibility of the bodies ``L1 = 8a / (3 C11 G)`` (Eq. 5.17), m/Pa."""
    return 8.0 * a / (3.0 * C11_ * G)


def L2(a: float, C22_: float, G: float) -> float:
    """Kalker flexibility for lateral creepage ``L2 = 8a / (3 C22 G)``, m/Pa."""
    return 8.0 * a / (3.0 * C22_ * G)


def L3(a: float, b: float, C23_: float, G: float) -> float:
    """Kalker flexibility for spin ``L3 = pi a sqrt(a/b) / (4 C23 G)``, m/Pa.

    With it, FASTSIM in full adhesion gives the linear theory's spin force
    ``Fy = G (ab)^(3/2) C23 phi`` (the strip integral of ``phi (a(y)^2 - x^2)/(2 L3)``
    is ``pi a^3 b phi/(4 L3)``).
    """
    return math.pi * a * math.sqrt(a / b) / (4.0 * C23_ * G)
