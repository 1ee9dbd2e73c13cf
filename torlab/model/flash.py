"""The flash temperature of a strip and its fixed point (thesis 5.2.5, Eqs. 5.49-5.50;
docs/model/thesis-reading.md): what FASTSIM (:mod:`torlab.model.fastsim`) and the creep
forces (:mod:`torlab.model.creep`) share.

The temperature rise of the surface along a strip of half-length ``a`` [m] under a
moving heat flux ``q = tau w`` [W/m^2] (``w`` [m/s] the rigid slip) is
``T(X) = T_A + (partition / sqrt(pi lambda rho c v)) integral_0^X q(X') / sqrt(X - X') dX'``
[°C], after Ertz and Knothe.  :func:`flash_temperature_matrix` integrates a
piecewise-linear ``q`` against that kernel exactly (product integration) on uniform
nodes in the strip's angle.  ``tau`` and ``T`` are coupled through the layer's limits
(their temperature coefficients [1/K]): :func:`converge_flash_temperature` finds the
fixed point ``dT = G(dT)`` with an adaptive under-relaxation per point until ``max |G(T)
- T|`` is below the tolerance [K], or raises :class:`~torlab.errors.ConvergenceError`
naming the point; :func:`converge_flash_temperature_groups` does the same for points
with a layer each (a band's draws), recording a failure per group.

References
----------
.. [1] Ertz, M., Knothe, K. (2002). A comparison of analytical and numerical methods for
   the calculation of temperatures in wheel/rail contact. Wear 253(3-4), 498-508.
   https://doi.org/10.1016/S0043-1648(02)00120-3
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import ConvergenceError

if TYPE_CHECKING:
    from torlab.model.layers import LayerParams

__all__ = ["ThermalParams", "converge_flash_temperature", "converge_flash_temperature_groups",
           "flash_temperature_matrix"]


@dataclass(frozen=True)
class ThermalParams:
    """Thermal properties for the flash temperature (the scene's ``thermal:``; Tab. 5.4
    defaults).

    Attributes
    ----------
    conductivity
        Heat conductivity ``lambda`` [W/(m K)].
    density
        ``rho`` [kg/m^3].
    heat_capacity
        ``c`` [J/(kg K)].
    partition
        Share of the frictional heat that goes into the body [-].
    slip_velocity
        ``"rigid"`` (the rigid slip ``w = xi v``) or ``"local"`` (zero in stick).
    tolerance
        The fixed point's tolerance on ``max |G(T) - T|`` [K].
    max_iterations
        Its iteration budget.
    """

    conductivity: float = 50.0
    density: float = 7850.0
    heat_capacity: float = 450.0
    partition: float = 1.0
    slip_velocity: str = "rigid"
    tolerance: float = 0.1
    max_iterations: int = 200


@cache
def flash_temperature_matrix(n_nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``theta_i`` (uniform on [0, pi]) and matrix ``K`` for a strip of half-length 1.

    For a piecewise-linear heat flux ``q`` on the nodes ``X_i = 1 - cos theta_i``,
    ``(K @ q)_i = integral_0^{X_i} q(X') / sqrt(X_i - X') dX'`` exactly.  For a
    strip of half-length ``a`` the integral scales with ``sqrt(a)``.
    """
    theta = np.linspace(0.0, math.pi, n_nodes)
    X = 1.0 - np.cos(theta)
    X[-1] = 2.0
    K = np.zeros((n_nodes, n_nodes))
    for i in range(1, n_nodes):
        Xc, Xn = X[:i], X[1 : i + 1]
        h = Xn - Xc
        sa = np.maximum(X[i] - Xn, 0.0)  # near end of each cell, in s = X_i - X'
        sb = X[i] - Xc
        r_a, r_b = np.sqrt(sa), np.sqrt(sb)
        i0 = 2.0 * (r_b - r_a)  # integral ds / sqrt(s)
        i1 = (2.0 / 3.0) * (sb * r_b - sa * r_a)  # integral s ds / sqrt(s)
        w_start = (i1 - sa * i0) / h  # weight of q at the cell's upstream node X_c
        w_end = (sb * i0 - i1) / h  # weight of q at the downstream node X_{c+1}
        np.add.at(K[i], np.arange(i), w_start)
        np.add.at(K[i], np.arange(1, i + 1), w_end)
    return theta, K


#: largest |mu_T dT| the iteration accepts: exp(30) = 1e13 changes of the limits mean
#: a thermal runaway, not a temperature
_MAX_EXPONENT = 30.0


def converge_flash_temperature(G: Any, dT: np.ndarray, its: np.ndarray, moving: np.ndarray,
                               th: ThermalParams, lay: LayerParams, where: Any, ambient: float
                               ) -> tuple[np.ndarray, np.ndarray, str, np.ndarray]:
    """The flash temperature's fixed point ``dT = G(dT)``, each point on its own.

    Shared by the longitudinal model (:mod:`torlab.model.fastsim`) and the creep forces
    (:mod:`torlab.model.creep`).  ``G(dT[rows], rows)`` is the temperature rise the
    points ``rows`` produce at the temperature ``dT`` (the first index of ``dT``
    numbers the points).  One pass suffices where the heating cannot change the
    limits (``|dT|`` times the largest temperature coefficient ``< 1e-6``); elsewhere each point iterates
    with its own adaptive under-relaxation (halved whenever its residual does not
    fall by 10 %) and leaves the active set once ``max |G(dT) - dT| < tolerance``.

    Returns
    -------
    tuple
        ``(dT, iterations per point, "single pass" or "iterated", Tmax per point)``.

    Raises
    ------
    ConvergenceError
        Thermal runaway (the limits would change by more than ``exp(30)``), or no
        convergence within ``th.max_iterations``; the message names the point
        (``where(i)``).
    """
    n = dT.shape[0]
    rows = np.flatnonzero(moving)
    new = np.zeros_like(dT)
    new[rows] = G(dT[rows], rows)
    peak = np.max(np.abs(new).reshape(n, -1), axis=1)
    sens = lay.law.temperature_sensitivity(lay)
    single = peak * sens < 1e-6  # heating too small to change the limits: one pass
    if sens == 0.0 or single.all():
        return new, its, "single pass", ambient + np.max(new.reshape(n, -1), axis=1)
    if np.max(peak) * sens > _MAX_EXPONENT:
        bad = int(np.argmax(peak))
        raise ConvergenceError(
            f"contact temperature runs away at {where(bad)}: the first pass already "
            f"heats by {peak[bad]:.3g} K, and the temperature coefficients "
            f"{lay.law.temperature_text(lay)} would change the limits "
            f"by a factor exp({_MAX_EXPONENT:g})", iterations=1)
    dT[single] = new[single]
    active = moving & ~single
    omega = np.ones(n)
    res_prev = np.full(n, np.inf)
    for k in range(1, th.max_iterations + 1):
        rows = _relaxed_step(G, new, dT, active, omega, res_prev, its, k, th.tolerance)
        if rows.size == 0:
            break
        runaway = ~np.isfinite(new[rows]) | (sens * np.abs(new[rows]) > _MAX_EXPONENT)
        if runaway.any():
            bad = int(rows[np.argmax(runaway.reshape(rows.size, -1).any(axis=1))])
            raise ConvergenceError(
                f"contact temperature diverged at {where(bad)} (thermal runaway: the "
                f"temperature coefficients {'/'.join(lay.law.temperature_names)} make frictional heating "
                f"self-amplifying)", iterations=k)
    else:
        rows = np.flatnonzero(active)
        res = np.max(np.abs(new[rows] - dT[rows]).reshape(rows.size, -1), axis=1)
        j = int(np.argmax(res))
        bad = int(rows[j])
        raise ConvergenceError(
            f"contact temperature did not converge at {where(bad)}: max |dT| = "
            f"{res[j]:.3g} K after {th.max_iterations} under-relaxed iterations (relaxation "
            f"{omega[bad]:.3g}); the temperature coefficients {lay.law.temperature_text(lay)} "
            "make the heating unstable at this slip",
            iterations=th.max_iterations, residual=float(res[j]))
    return dT, its, "iterated", ambient + np.max(dT.reshape(n, -1), axis=1)


def _relaxed_step(G: Any, new: np.ndarray, dT: np.ndarray, active: np.ndarray,
                  omega: np.ndarray, res_prev: np.ndarray, its: np.ndarray, k: int,
                  tol: float) -> np.ndarray:
    """Step ``k`` of the flash temperature's fixed-point iteration, in place.

    The active points whose residual ``max |G(dT) - dT|`` is below ``tol`` keep ``G(dT)``
    and leave the active set; the others move by their own under-relaxation factor
    (halved, down to 1/1024, whenever the residual did not fall by 10 %) and are
    evaluated again (``new``).  Returns the rows stepped (empty: every point converged).
    """
    rows = np.flatnonzero(active)
    if rows.size == 0:
        return rows
    # the arrays are large (points x strips x nodes): every point's rows as views where all
    # are active, each temporary once (fresh pages are what costs here)
    sel = _rows(rows, new.shape[0])
    diff = new[sel] - dT[sel]  # G(T) - T
    res = np.max(np.abs(diff).reshape(rows.size, -1), axis=1)
    done = res < tol
    if done.any():
        dT[rows[done]] = new[rows[done]]  # converged: keep G(T), leave the active set
        active[rows[done]] = False
        keep = ~done
        rows, res, diff = rows[keep], res[keep], diff[keep]
        if rows.size == 0:
            return rows
        sel = rows
    worse = res > 0.9 * res_prev[rows]
    omega[rows] = np.where(worse, np.maximum(omega[rows] * 0.5, 1.0 / 1024), omega[rows])
    res_prev[rows] = res
    diff *= omega[rows][:, None, None]
    if isinstance(sel, slice):
        dT += diff
    else:
        dT[sel] = dT[sel] + diff
    its[rows] = k + 1
    new[sel] = G(dT[sel], rows)
    return rows


def _rows(rows: np.ndarray, n: int) -> np.ndarray | slice:
    """``rows`` (sorted, distinct) as a slice when they are every row (a view, not a copy)."""
    return slice(None) if rows.size == n else rows


def converge_flash_temperature_groups(G: Any, new: np.ndarray, single: np.ndarray,
                                      peak: np.ndarray, sens: np.ndarray, its: np.ndarray,
                                      moving: np.ndarray, where: Any, th: ThermalParams,
                                      ambient: float, fail: Any, start: np.ndarray | None = None
                                      ) -> tuple[np.ndarray, np.ndarray, str, np.ndarray]:
    """:func:`converge_flash_temperature` with a layer per point (a band's draws): the same
    steps for each point, a failure recorded for its group instead of raised.

    ``new`` is the first pass ``G(start)`` (``G(0)`` without a start), ``single`` the points
    it settles, ``peak`` and ``sens`` each point's heating [K] and largest temperature
    coefficient [1/K]; ``fail(mask, why)`` records a failure of the points ``mask`` and
    returns every point that leaves with them (their whole group).  ``start`` (the shape of
    ``new``) is where the iteration starts (a nearby solution: the points then leave it
    after fewer steps, converged to the same tolerance); zero without one.
    """
    nx = new.shape[0]

    def drop(bad: np.ndarray, why: str) -> None:
        active[fail(bad, why)] = False

    dT = np.zeros_like(new) if start is None else np.array(start, dtype=float)
    dT[single] = new[single]
    active = moving & ~single
    runaway = active & (peak * sens > _MAX_EXPONENT)
    if runaway.any():
        drop(runaway, f"contact temperature runs away at {where(int(np.argmax(runaway)))}: the "
                      "first pass already changes the limits by more than a factor "
                      f"exp({_MAX_EXPONENT:g})")
    omega = np.ones(nx)
    res_prev = np.full(nx, np.inf)
    tol = th.tolerance
    for k in range(1, th.max_iterations + 1):
        rows = _relaxed_step(G, new, dT, active, omega, res_prev, its, k, tol)
        if rows.size == 0:
            break
        # not finite, or beyond the largest exponent (NaN fails the comparison)
        peak_k = np.max(np.abs(new[_rows(rows, nx)]).reshape(rows.size, -1), axis=1)
        bad = ~(sens[rows] * peak_k <= _MAX_EXPONENT)
        if bad.any():
            mask = np.zeros(nx, dtype=bool)
            mask[rows[bad]] = True
            drop(mask, f"contact temperature diverged at {where(int(rows[np.argmax(bad)]))} "
                       "(thermal runaway)")
    else:
        if active.any():
            drop(active.copy(), f"contact temperature did not converge at "
                                f"{where(int(np.argmax(active)))} after {th.max_iterations} "
                                "under-relaxed iterations")
    tmax = ambient + np.max(dT.reshape(nx, -1), axis=1)
    return dT, its, "iterated", tmax
