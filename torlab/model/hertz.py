"""Normal contact: Hertz's elliptical contact (thesis 5.2.1, Eqs. 5.5-5.13).

Two solutions are offered:

* :func:`hertz_approximate`: the thesis's Hamrock-Brewe approximations
  ``k = 1.0339 (rx/ry)^0.636`` (Eq. 5.8), ``theta = 1.0003 + 0.5968 ry/rx``
  (Eq. 5.9), ``a = (3 k^2 theta F R / (pi E*))^(1/3)`` (Eq. 5.11),
  ``b = (3 theta F R / (pi k E*))^(1/3)`` (Eq. 5.12).  As docs/model/thesis-reading.md
  says, they hold for ``rx >= ry`` (then ``a >= b``); for ``rx < ry`` the roles
  are swapped rather than extrapolated.
* :func:`hertz_exact`: the exact solution with complete elliptic integrals
  (Johnson, *Contact Mechanics*, 1985, Eqs. 4.39-4.41): the eccentricity
  ``e^2 = 1 - (b/a)^2`` solves
  ``rx/ry = [(a/b)^2 E(e) - K(e)] / [K(e) - E(e)]`` (for rx >= ry) by a
  bracketed root, then ``a^3 = 3 F rx (K - E) / (pi E* e^2)``.

The pressure is ``p = 3F/(2 pi a b) sqrt(1 - (x/a)^2 - (y/b)^2)`` (Eq. 5.13),
``a`` in the rolling direction.

References
----------
.. [1] Hertz, H. (1882). Ueber die Berührung fester elastischer Körper. Journal für die
   reine und angewandte Mathematik 92, 156-171. https://doi.org/10.1515/crll.1882.92.156
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ContactPatch", "E_star", "hertz", "hertz_approximate", "hertz_exact", "patch_from_axes",
           "pressure"]


@dataclass(frozen=True)
class ContactPatch:
    """An elliptical Hertz contact.

    Attributes
    ----------
    a, b
        Semi-axes in the rolling (x) and lateral (y) direction [m].
    F
        Normal load [N].
    method
        ``approximate``, ``exact`` or ``given`` (semi-axes from the scene).
    """

    a: float
    b: float
    F: float
    method: str = "given"

    @property
    def p0(self) -> float:
        """Maximum Hertz pressure ``3F / (2 pi a b)`` [Pa], Eq. 5.13 at the centre."""
        return 3.0 * self.F / (2.0 * math.pi * self.a * self.b)

    @property
    def p_mean(self) -> float:
        """Mean pressure ``F / (pi a b)`` [Pa]."""
        return self.F / (math.pi * self.a * self.b)

    @property
    def area(self) -> float:
        """Contact area ``pi a b`` [m^2]."""
        return math.pi * self.a * self.b


def E_star(E1: float, nu1: float, E2: float, nu2: float) -> float:
    """Reduced modulus ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` (Eq. 5.10), Pa."""
    return 1.0 / ((1 - nu1 * nu1) / E1 + (1 - nu2 * nu2) / E2)


def pressure(x: np.ndarray, y: np.ndarray, patch: ContactPatch) -> np.ndarray:
    """Hertz pressure (Eq. 5.13), zero outside the ellipse [Pa]."""
    r2 = (np.asarray(x) / patch.a) ** 2 + (np.asarray(y) / patch.b) ** 2
    return patch.p0 * np.sqrt(np.maximum(1.0 - r2, 0.0))


def patch_from_axes(a: float, b: float, F: float) -> ContactPatch:
    """A patch with given semi-axes (Tab. 5.4 gives a = 3.7 mm, b = 3.3 mm)."""
    return ContactPatch(a=a, b=b, F=F, method="given")


def hertz_approximate(F: float, rx: float, ry: float, Es: float) -> ContactPatch:
    """Thesis approximation (Eqs. 5.7-5.12); see the module docstring."""
    R = 1.0 / (1.0 / rx + 1.0 / ry)
    swap = rx < ry
    big, small = (ry, rx) if swap else (rx, ry)
    k = 1.0339 * (big / small) ** 0.636
    theta = 1.0003 + 0.5968 * (small / big)
    long_ = (3 * k * k * theta * F * R / (math.pi * Es)) ** (1 / 3)
    short = (3 * theta * F * R / (math.pi * k * Es)) ** (1 / 3)
    a, b = (short, long_) if swap else (long_, short)
    return ContactPatch(a=a, b=b, F=F, method="approximate")


def _k_minus_e(m: float) -> float:
    """``K(m) - E(m)`` without cancellation for small ``m`` (parameter m = e^2)."""
    from scipy.special import ellipe, ellipk

    if m < 1e-3:
        # series: (pi/2) (m/2 + 3 m^2/16 + 15 m^3/128 + 175 m^4/2048)
        return 0.5 * math.pi * (m / 2 + 3 * m**2 / 16 + 15 * m**3 / 128 + 175 * m**4 / 2048)
    return float(ellipk(m) - ellipe(m))


def hertz_exact(F: float, rx: float, ry: float, Es: float) -> ContactPatch:
    """Exact Hertz contact with complete elliptic integrals (module docstring)."""
    from scipy.optimize import brentq
    from scipy.special import ellipe

    swap = rx < ry
    big, small = (ry, rx) if swap else (rx, ry)
    ratio = big / small  # >= 1: curvature ratio B/A of Johnson
    if ratio - 1.0 < 1e-12:
        m = 0.0
    else:
        def f(m: float) -> float:
            kme = _k_minus_e(m)
            e_ = float(ellipe(m))
            # (a/b)^2 E - K = E/(1-m) - K = (E - (1-m) K)/(1-m) ; K = E + kme, so
            # E - (1-m) K = m K - (K - E): no cancellation of E against K for small m
            num = (m * (e_ + kme) - kme) / (1 - m)
            return num / kme - ratio

        hi = 1.0 - 1e-15
        # relative stop only: m is as small as 1e-12 for nearly circular contacts
        m = brentq(f, 1e-12, hi, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200)
    if m == 0.0:
        long_ = (3 * F * big / (4 * Es)) ** (1 / 3)
        short = long_
    else:
        long_ = (3 * F * big * _k_minus_e(m) / (math.pi * Es * m)) ** (1 / 3)
        short = long_ * math.sqrt(1 - m)
    a, b = (short, long_) if swap else (long_, short)
    return ContactPatch(a=a, b=b, F=F, method="exact")


def hertz(F: float, rx: float, ry: float, Es: float, method: str = "approximate") -> ContactPatch:
    """Hertz contact by ``method`` (``approximate`` or ``exact``)."""
    if method == "approximate":
        return hertz_approximate(F, rx, ry, Es)
    if method == "exact":
        return hertz_exact(F, rx, ry, Es)
    raise ValueError(f"unknown Hertz method {method!r}")
