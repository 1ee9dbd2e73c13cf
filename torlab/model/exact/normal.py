"""The normal contact problem on the grid: Hertz's geometry, the half-space's discrete solution.

For quasi-identical bodies the normal problem does not depend on the tangential
one (Kalker 1990, section 1.5): it is solved first and gives the traction bound.

The discrete problem (CONTACT's "full solution" of the normal problem): find the
element pressures ``p >= 0`` and the approach ``delta`` such that the deformed
distance ``e = h + A_n p - delta`` is zero where ``p > 0`` and positive elsewhere,
with the total ``sum p dA`` equal to the load.  It is a convex quadratic
programme; :func:`solve_normal` uses the conjugate-gradient method of Polonsky
and Keer (1999, *Wear* 231) with products ``A_n p`` by FFT.

:func:`hertz_curvatures` gives the undeformed distance ``h = A x^2 + B y^2`` of the
Hertz contact with semi-axes ``a, b`` at a load (Johnson, *Contact Mechanics*,
1985, Eqs. 4.39-4.41, solved for the curvatures).
"""

from __future__ import annotations

import math

import numpy as np

from torlab.errors import ConvergenceError
from torlab.model.exact.grid import Grid
from torlab.model.exact.influence import Influence

__all__ = ["hertz_curvatures", "solve_normal"]


def hertz_curvatures(a: float, b: float, load: float, G: float, nu: float) -> tuple[float, float]:
    """Curvatures ``(A, B)`` [1/m] with ``h = A x^2 + B y^2`` that give the semi-axes ``a, b``.

    Quasi-identical bodies: ``E* = G/(1 - nu)`` (the combined modulus of
    ``p = E*/pi`` times the integral of ``u_n``).  With the longer semi-axis ``l``, the
    shorter ``s``, ``e^2 = 1 - s^2/l^2`` and the complete elliptic integrals
    ``K(e), E(e)``: ``A_l = (p0 s/(E* l^2)) (K - E)/e^2`` along the longer axis and
    ``A_s = (p0 s/(E* l^2)) (E/(1 - e^2) - K)/e^2`` along the shorter one,
    ``p0 = 3 N/(2 pi a b)``.
    """
    from scipy.special import ellipe, ellipk

    Es = G / (1 - nu)
    p0 = 3 * load / (2 * math.pi * a * b)
    lng, sht = max(a, b), min(a, b)
    m = 1 - (sht / lng) ** 2
    c = p0 * sht / (Es * lng**2)
    if m < 1e-8:
        along_long = along_short = c * math.pi / 4
    else:
        K, E = float(ellipk(m)), float(ellipe(m))
        along_long = c * (K - E) / m
        along_short = c * (E / (1 - m) - K) / m
    return (along_long, along_short) if a >= b else (along_short, along_long)


def solve_normal(grid: Grid, G: float, nu: float, h: np.ndarray, load: float, *,
                 tol: float = 1e-10, max_iter: int = 2000) -> tuple[np.ndarray, float]:
    """Pressures ``(mx, my)`` [Pa] and approach [m] of the discrete normal problem.

    Parameters
    ----------
    grid
        The grid.
    G, nu
        Combined elastic constants.
    h
        Undeformed distance at the element centres ``(mx, my)`` [m].
    load
        Total normal force [N].
    tol
        Stop when the relative change of the pressures in a step is below ``tol``.

    Raises
    ------
    ConvergenceError
        No convergence in ``max_iter`` steps.
    """
    inf = Influence(grid.mx, grid.my, grid.dx, grid.dy, G, nu, extra=0)
    dA = grid.area
    p = np.full(h.shape, load / (h.size * dA))
    t = np.zeros(h.shape)
    G_old = 1.0
    delta = 0.0
    for _ in range(max_iter):
        gap = inf.normal(p) + h
        Ic = p > 0
        gbar = gap[Ic].mean()
        gap -= gbar
        Gk = float((gap[Ic] ** 2).sum())
        t = np.where(Ic, gap + delta * (Gk / G_old) * t, 0.0)
        G_old = Gk
        r = inf.normal(t)
        r -= r[Ic].mean()
        rt = float((r[Ic] * t[Ic]).sum())
        tau = float((gap[Ic] * t[Ic]).sum()) / rt if rt != 0 else 0.0
        p_old = p
        p = np.where(Ic, p - tau * t, 0.0)
        p = np.maximum(p, 0.0)
        overlap = (p == 0) & (gap < 0)
        if overlap.any():
            delta = 0.0
            p = np.where(overlap, p - tau * gap, p)
        else:
            delta = 1.0
        p *= load / (p.sum() * dA)
        err = float(np.abs(p - p_old).sum() * dA) / load
        if err < tol:
            break
    else:
        raise ConvergenceError(f"exact normal problem: no convergence in {max_iter} steps")
    approach = float((inf.normal(p) + h)[p > 0].mean())
    return p, approach
