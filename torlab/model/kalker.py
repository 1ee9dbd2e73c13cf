"""Kalker's creepage coefficients C11, C22, C23 and the FASTSIM flexibilities (thesis Eq. 5.17).

The table is Kalker's (1967 thesis; 1990 book Table E.3) as carried by the
open-source CONTACT program (routine ``linrol``); ``docs/model/kalker.md``
explains it.  In ``nu`` a quadratic through nu = 0, 0.25, 0.5 is applied to ``1/C``
(CONTACT's rule).  Between the rows ``g = 0.1, 0.2, ..., 1`` two interpolations
(argument ``interpolation``):

* ``"linear"`` (the default): linear in ``g``, as CONTACT does, so results compare
  with it; Kalker's FASTSIM (the method ``fastsim-kalker``) uses it.
* ``"log-pchip"``: a monotone piecewise-cubic Hermite interpolant (PCHIP, Fritsch and
  Carlson 1980, with the derivatives of Fritsch and Butland 1984 that
  ``scipy.interpolate.PchipInterpolator`` uses) of ``ln C`` over ``ln g``.  The
  coefficients of a slender ellipse grow like powers of ``1/g``, so linear
  interpolation in ``g`` bends at every row: between ``g = 0.2`` and ``0.3`` (a/b
  3.3--5) it puts C11 and C22 up to 1.6 % and C23 4.6 % above the exact theory, at
  a/b 7 6 % and 16 %.  Against torlab's exact solver's no-slip coefficients at ten
  aspect ratios between the rows (0.15--7), ``"log-pchip"`` stays within the
  solver-to-table differences at the neighbouring rows, to 0.2 %
  (``docs/model/kalker.md``).  The default boundary method
  (:mod:`torlab.model.calibrated`) uses it.

Below ``g = 0.1`` (an extreme contact) Kalker's asymptotes for a slender ellipse are
used and the functions report it: the table is never extrapolated.

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
.. [2] Fritsch, F. N., Carlson, R. E. (1980). Monotone piecewise cubic interpolation. SIAM
   Journal on Numerical Analysis 17(2), 238-246. https://doi.org/10.1137/0717021
.. [3] Fritsch, F. N., Butland, J. (1984). A method for constructing local monotone
   piecewise cubic interpolants. SIAM Journal on Scientific and Statistical Computing
   5(2), 300-304. https://doi.org/10.1137/0905021
"""

from __future__ import annotations

import math
import warnings
from functools import cache

import numpy as np

__all__ = ["C11", "C22", "C23", "C33", "INTERPOLATIONS", "L1", "L2", "L3", "ExtremeContactWarning",
           "combined_G_nu", "creepage_coefficients"]

#: how the table is interpolated between its rows (module docstring)
INTERPOLATIONS = ("linear", "log-pchip")

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


def _check(a_over_b: float, nu: float, interpolation: str = "linear") -> None:
    if not (a_over_b > 0 and math.isfinite(a_over_b)):
        raise ValueError(f"a/b must be positive and finite, got {a_over_b}")
    if not 0.0 <= nu <= 0.5:
        raise ValueError(f"Poisson ratio must be in [0, 0.5], got {nu}")
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"interpolation must be one of {', '.join(INTERPOLATIONS)}, "
                         f"got {interpolation!r}")


@cache
def _pchip_slopes(name: str, half: int) -> np.ndarray:
    """The PCHIP derivatives ``d ln C / d ln g`` at the rows of one half of a table
    (10, 3): Fritsch and Butland's weighted harmonic mean of the neighbouring secants
    inside (zero where they differ in sign), the shape-preserving three-point formula at
    the ends -- the derivatives of ``scipy.interpolate.PchipInterpolator``."""
    x = np.log(_G)
    y = np.log(_TABLES[name][half])
    h = np.diff(x)[:, None]
    m = np.diff(y, axis=0) / h
    d = np.zeros_like(y)
    w1 = 2 * h[1:] + h[:-1]
    w2 = h[1:] + 2 * h[:-1]
    same = (np.sign(m[1:]) == np.sign(m[:-1])) & (m[1:] != 0) & (m[:-1] != 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        inner = (w1 + w2) / (w1 / m[:-1] + w2 / m[1:])
    d[1:-1] = np.where(same, inner, 0.0)
    for end, (h0, h1, m0, m1) in ((0, (h[0], h[1], m[0], m[1])),
                                  (-1, (h[-1], h[-2], m[-1], m[-2]))):
        e = ((2 * h0 + h1) * m0 - h0 * m1) / (h0 + h1)
        e = np.where(np.sign(e) != np.sign(m0), 0.0, e)
        e = np.where((np.sign(m0) != np.sign(m1)) & (np.abs(e) > 3 * np.abs(m0)), 3 * m0, e)
        d[end] = e
    return d


def _rows(name: str, half: int, g: float, interpolation: str) -> list[float]:
    """The table's three ``nu`` columns at ``g`` (0.1 <= g <= 1)."""
    table = _TABLES[name][half]
    if interpolation == "linear":
        return [float(np.interp(g, _G, table[:, k])) for k in range(3)]
    x = np.log(_G)
    t = math.log(g)
    i = int(min(max(np.searchsorted(x, t, side="right") - 1, 0), x.size - 2))
    h = x[i + 1] - x[i]
    s = (t - x[i]) / h
    y = np.log(table)
    d = _pchip_slopes(name, half)
    # cubic Hermite basis on [x_i, x_i+1]
    h00, h10 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2
    h01, h11 = s * s * (3 - 2 * s), s * s * (s - 1)
    ln_c = h00 * y[i] + h10 * h * d[i] + h01 * y[i + 1] + h11 * h * d[i + 1]
    return [math.exp(v) for v in ln_c]


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


def _coefficient(name: str, a_over_b: float, nu: float, warn: bool,
                 interpolation: str = "linear") -> float:
    _check(a_over_b, nu, interpolation)
    if a_over_b <= 1.0:
        g, half = a_over_b, 0
    else:
        g, half = 1.0 / a_over_b, 1
    if g < 0.1:
        if warn:
            warnings.warn(f"contact ellipse a/b = {a_over_b:.4g} lies outside Kalker's table "
                          f"(0.1 <= g <= 1): using the asymptotic {name}", ExtremeContactWarning,
                          stacklevel=3)
        return _asymptote(name, a_over_b, g, nu)
    return _nu_interp(*_rows(name, half, g, interpolation), nu)


def C11(a_over_b: float, nu: float, *, warn: bool = True, interpolation: str = "linear"
        ) -> float:
    """Kalker's longitudinal creepage coefficient ``C11(a/b, nu)`` (Kalker 1990, Table E.3).

    Parameters
    ----------
    a_over_b
        Semi-axis in the rolling direction over the lateral one.
    nu
        (Combined) Poisson ratio, 0 <= nu <= 0.5.
    warn
        Emit :class:`ExtremeContactWarning` below the table (g < 0.1).
    interpolation
        Between the table's rows: ``"linear"`` in ``g`` (CONTACT's) or ``"log-pchip"``
        (a monotone cubic of ``ln C`` over ``ln g``; module docstring).

    Returns
    -------
    float
        C11 (dimensionless).  Checks (``docs/model/kalker.md``): nu = 0.28 gives 3.7335
        (a/b = 0.5), 4.2262 (1), 5.2037 (2), with either interpolation (table rows).
    """
    return _coefficient("C11", a_over_b, nu, warn, interpolation)


def C22(a_over_b: float, nu: float, *, warn: bool = True, interpolation: str = "linear"
        ) -> float:
    """Kalker's lateral creepage coefficient ``C22(a/b, nu)`` (same table rules as :func:`C11`)."""
    return _coefficient("C22", a_over_b, nu, warn, interpolation)


def C23(a_over_b: float, nu: float, *, warn: bool = True, interpolation: str = "linear"
        ) -> float:
    """Kalker's spin coefficient ``C23(a/b, nu)``: ``Fy = G c^2 (C22 eta + c C23 phi)``, ``c = sqrt(ab)``."""
    return _coefficient("C23", a_over_b, nu, warn, interpolation)


def C33(a_over_b: float, nu: float, *, interpolation: str = "linear") -> float:
    """Kalker's spin-moment coefficient ``C33(a/b, nu)``: ``Mz = G c^4 (c C33 phi - C23 eta)``.

    Kalker's table (1990, Table E.3) with the rules of :func:`C11`, for
    ``0.1 <= g <= 1`` only: below, no asymptote is carried and ValueError is raised.
    ``C32``, the lateral creepage's moment, equals ``C23`` (reciprocity).
    """
    _check(a_over_b, nu, interpolation)
    g = a_over_b if a_over_b <= 1.0 else 1.0 / a_over_b
    if g < 0.1:
        raise ValueError(f"a/b = {a_over_b:.4g} lies outside Kalker's table of C33 "
                         "(0.1 <= g <= 1)")
    return _coefficient("C33", a_over_b, nu, False, interpolation)


def creepage_coefficients(a_over_b: float, nu: float, *, warn: bool = True,
                          interpolation: str = "linear") -> tuple[float, float, float]:
    """``(C11, C22, C23)`` at once; one :class:`ExtremeContactWarning` below the table."""
    with warnings.catch_warnings(record=True) as wl:
        warnings.simplefilter("always", ExtremeContactWarning)
        out = (C11(a_over_b, nu, interpolation=interpolation),
               C22(a_over_b, nu, interpolation=interpolation),
               C23(a_over_b, nu, interpolation=interpolation))
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
