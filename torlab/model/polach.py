"""Polach's creep-force model (Polach 1999, 2005), the law vehicle-dynamics codes accept.

Polach, O. (1999) "A fast wheel-rail forces calculation computer code", Vehicle System
Dynamics 33 (suppl.), 728-739; Polach, O. (2005) "Creep forces in simulations of traction
vehicles running on adhesion limit", Wear 258, 992-1000.  Written here in torlab's sign
convention (forces along positive creepage; Polach writes them against it).

Tangential force (2005, with the reduction factors ``kA`` in the adhesion area and ``kS``
in the slip area, ``kS <= kA <= 1``; ``kA = kS = 1`` is the 1999 law)::

    F = (2 Q mu / pi) [ kA eps/(1 + (kA eps)^2) + arctan(kS eps) ]
    eps = (pi G a b c_jj / (4 Q mu)) s_C
    c_jj = sqrt((C11 s_x/s)^2 + (C22 s_y/s)^2),   s = sqrt(s_x^2 + s_y^2)

and the friction coefficient falling with the slip velocity ``w = s_C V``::

    mu = mu0 [(1 - A) exp(-B w) + A]          (A = mu_inf/mu0, B in s/m)

Spin (1999): the lateral creepage is increased by the spin where that increases it,
``s_yC = s_y + phi a`` if ``|s_y + phi a| > |s_y|`` else ``s_y``;
``s_C = sqrt(s_x^2 + s_yC^2)``; ``Fx = F s_x/s_C``, ``Fy = F s_y/s_C + F_yS`` with::

    F_yS = -(9/16) a Q mu K_M [1 + 6.3 (1 - exp(-a/b))] phi / s_C
    K_M = |eps_M| (d^3/3 - d^2/2 + 1/6) - (1/3) sqrt((1 - d^2)^3),
    d = (eps_M^2 - 1)/(eps_M^2 + 1),
    eps_M = (8/3) (G b sqrt(ab)/(Q mu)) C23 s_yC / (1 + 6.3 (1 - exp(-a/b)))

For small creepages this is Kalker's linear theory: ``Fx = G a b C11 s_x``,
``Fy = G a b (C22 s_y + sqrt(ab) C23 phi)`` (with ``kA = kS = 1``; the initial slope is
``(kA + kS)/2`` of it otherwise).  ``G C11``, ``G C22``, ``G C23`` come from Kalker's
flexibilities of the contact (:mod:`torlab.model.kalker`), so the law and torlab's
creep-force model share the contact.

Polach's papers do not say which slip velocity enters ``mu`` with spin; torlab uses the
total creepage ``s_C`` (with the spin increment), which is ``s`` without spin.

References
----------
.. [1] Polach, O. (2005). Creep forces in simulations of traction vehicles running on
   adhesion limit. Wear 258(7-8), 992-1000. https://doi.org/10.1016/j.wear.2004.03.046
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["PolachContact", "PolachParams", "polach_contact", "polach_forces"]


@dataclass(frozen=True)
class PolachParams:
    """Polach's five parameters (2005).

    Attributes
    ----------
    mu0
        Maximum friction coefficient (at zero slip velocity).
    A
        ``mu_inf / mu0``: friction at infinite slip velocity over ``mu0``.
    B
        Exponential decrease of friction with the slip velocity [s/m].
    kA, kS
        Reduction of the initial slope in the adhesion and the slip area.
    """

    mu0: float
    A: float = 1.0
    B: float = 0.0
    kA: float = 1.0
    kS: float = 1.0


@dataclass(frozen=True)
class PolachContact:
    """The contact Polach's law needs: semi-axes [m], load Q [N], ``G Cij`` [Pa]."""

    a: float
    b: float
    Q: float
    G_C11: float
    G_C22: float
    G_C23: float


def polach_contact(problem: Any) -> PolachContact:
    """Polach's contact from a :class:`~torlab.model.creep.CreepProblem` (same ``G Cij``).

    ``G C11 = 8a/(3 L1)``, ``G C22 = 8a/(3 L2)``, ``G C23 = pi a sqrt(a/b)/(4 L3)``
    (Kalker's flexibilities inverted); ``nan`` where a flexibility is unknown.
    """
    a, b = problem.a, problem.b
    gc22 = 8 * a / (3 * problem.L2) if problem.L2 is not None else math.nan
    gc23 = math.pi * a * math.sqrt(a / b) / (4 * problem.L3) if problem.L3 is not None else math.nan
    return PolachContact(a=a, b=b, Q=problem.load, G_C11=8 * a / (3 * problem.L1),
                         G_C22=gc22, G_C23=gc23)


def polach_forces(params: PolachParams, contact: PolachContact, creepage: Any, lateral: Any = 0.0,
                  spin: Any = 0.0, speed: Any = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """``(Fx, Fy)`` of Polach's law [N], torlab's sign; arrays broadcast together.

    Parameters
    ----------
    params
        ``mu0, A, B, kA, kS``.
    contact
        Semi-axes, load and ``G Cij`` (:func:`polach_contact`).
    creepage, lateral, spin
        Longitudinal, lateral creepage (fractions), spin [1/m].
    speed
        Rolling (vehicle) speed V [m/s] for the slip velocity ``w = s_C V``.
    """
    sx, sy, phi, V = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                           for v in (creepage, lateral, spin, speed)))
    a, b, Q = contact.a, contact.b, contact.Q
    syc = np.where(np.abs(sy + phi * a) > np.abs(sy), sy + phi * a, sy)
    sc = np.sqrt(sx * sx + syc * syc)
    s = np.sqrt(sx * sx + sy * sy)
    p = params
    mu = p.mu0 * ((1.0 - p.A) * np.exp(-p.B * sc * V) + p.A)
    with np.errstate(invalid="ignore", divide="ignore"):
        cx = np.where(s > 0, sx / np.where(s > 0, s, 1.0), 1.0)
        cy = np.where(s > 0, sy / np.where(s > 0, s, 1.0), 0.0)
        Gcjj = np.sqrt((contact.G_C11 * cx) ** 2 + (np.nan_to_num(contact.G_C22) * cy) ** 2)
        eps = math.pi * a * b * Gcjj * sc / (4.0 * Q * mu)
        F = 2.0 * Q * mu / math.pi * (p.kA * eps / (1.0 + (p.kA * eps) ** 2)
                                      + np.arctan(p.kS * eps))
        inv = np.where(sc > 0, 1.0 / np.where(sc > 0, sc, 1.0), 0.0)
        Fx = F * sx * inv
        Fy = F * sy * inv
        if np.any(phi != 0):
            ks = 1.0 + 6.3 * (1.0 - math.exp(-a / b))
            eM = 8.0 / 3.0 * b * math.sqrt(a * b) * contact.G_C23 * syc / (Q * mu * ks)
            d = (eM * eM - 1.0) / (eM * eM + 1.0)
            KM = np.abs(eM) * (d**3 / 3 - d**2 / 2 + 1.0 / 6.0) \
                - np.sqrt(np.clip(1.0 - d * d, 0.0, None) ** 3) / 3.0
            FyS = -9.0 / 16.0 * a * Q * mu * KM * ks * phi * inv
            Fy = Fy + np.where(phi != 0, FyS, 0.0)
    return Fx, Fy
