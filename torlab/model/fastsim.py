"""FASTSIM with the third-body layer (thesis 5.2.2, Eqs. 5.14-5.30; docs/model/thesis-reading.md).

The model
---------
Pure longitudinal creepage ``xi`` on an elliptical Hertz contact (semi-axes
``a`` along the rolling direction, ``b`` across).  Each strip at lateral
position ``y`` has half-length ``a(y) = a sqrt(1 - (y/b)^2)``; a particle
enters at the leading edge with ``tau = u = 0`` and travels the distance ``X``
(0 at the leading edge, ``2 a(y)`` at the trailing edge).  Along the way

* the displacement grows as ``u = xi X``;
* while elastic, ``d tau = xi dX / L`` with ``L = L1 + L_mue / p``
  (Eqs. 5.17-5.18, 5.23, 5.28), i.e. ``tau = xi E(X)``,
  ``E(X) = integral_0^X dX'/L(X')``;
* once ``tau`` reaches ``tau_c1`` the state stays plastic with the Voce law
  ``tau = tau_c1 + (tau_c2 - tau_c1)(1 - exp(-max(u - tau_c1 L, 0) / L_mup))``
  (Eq. 5.24 as the notes read it; the ``max(., 0)`` keeps ``tau`` between the
  two limits where ``u`` has not yet caught up with ``tau_c1 L``, which happens
  when ``L`` grows towards the trailing edge);
* ``tau_c1``, ``tau_c2`` follow the pressure and the temperature (Eqs. 5.26-5.27).

``mu_BL = integral tau dA / integral p dA`` (Eq. 5.30) with the exact Hertz load.
Traction is odd in creepage: computed for ``|xi|``, sign restored.

Why not the thesis's grid (speed against error)
-----------------------------------------------
The thesis marches the recurrence (5.23) on a uniform grid of ``m`` points per
strip and ``n`` strips.  That converges at first order only (the yield point
falls inside a cell, the pressure's square-root edges are sampled badly):
halving the error doubles the grid.  torlab instead uses the structure of the
continuous strip solution:

* in the angle ``theta`` with ``X = a(y)(1 - cos theta)`` the pressure is
  ``p = P(y) sin theta`` and every integrand becomes smooth;
* the elastic stress is ``tau = xi (a(y)/L1) e(theta; r)`` with
  ``e(theta; r) = integral_0^theta sin^2 t / (sin t + r) dt`` and
  ``r = L_mue / (L1 P(y))``, which has a closed form (logarithmic for
  ``r < 1/2``; a Gauss-Legendre rule elsewhere, where the integrand is analytic
  well around the interval, with the nodes that distance asks for), and so has
  the elastic force
  ``integral_0^X_y tau dX = xi (a(y)^2/L1) [G(sin theta_y) - e(theta_y) cos theta_y]``
  with ``G(s) = s^2/2 - r s + r^2 ln(1 + s/r)``;
* the yield angle ``theta_y`` is the first root of ``xi E = tau_c1``, bracketed
  by a table (of the monotone ``e/sin theta``; with temperature, of the residual on
  the temperature nodes) and found to round-off by a safeguarded Newton iteration
  vectorised over all strips and creepages, which stops on a *relative* step
  (:func:`_bracketed_newton`);
* the plastic part is integrated by Gauss-Legendre panels that start at the
  yield point and at the end of the clamped zone (where ``u = tau_c1 L``, a
  closed form without temperature) and are graded geometrically with the
  Voce length ``L_mup / xi``, so the boundary layer of the exponential is
  resolved at any creepage;
* strips are Gauss-Legendre nodes in ``phi`` with ``y = b sin phi``, which
  removes the square-root behaviour at the lateral edges; the contact's
  symmetry halves the work.

The default grid (``n = 6`` strips, ``m = 4`` nodes per panel; 6 graded, 3
uniform and 1 clamp panel) is within 2.2e-5 (the target is 0.1 %) of the grid-free reference
(:func:`torlab.model.reference_solvers.boundary_traction_reference`,
adaptive quadrature of the continuous strip solution) over the accuracy test
set; ``torlab bench`` prints the speed-against-error table.

Temperature (thesis 5.2.5, docs/model/thesis-reading.md)
-------------------------------------------------
With a ``thermal:`` section, the flash temperature of each strip is
``T(X) = T_A + (partition / sqrt(pi lambda rho c v)) integral_0^X q(X') / sqrt(X - X') dX'``
with ``q = tau w`` (Eq. 5.49-5.50; ``w = xi v`` the rigid slip velocity).  It is
evaluated on a fixed grid per strip (uniform in ``theta``) by product
integration of a piecewise-linear ``q`` against the exact kernel (one matrix,
scaled by ``sqrt(a(y))``).  ``tau`` and ``T`` are coupled through ``tau_c1``,
``tau_c2``: the fixed-point iteration is under-relaxed adaptively per
creepage (the relaxation halves whenever the residual stops shrinking) until
``max |G(T) - T| < tolerance`` (0.1 K), or raises
:class:`~torlab.errors.ConvergenceError`.  When the temperature coefficients
are zero, or the first pass shows a heating that changes the limits by less
than 1e-6, no loop is run and the temperature is reported from one pass.
The points of a call (creepages; with ``speed=``, one speed per point, as in a
Stribeck curve) iterate together in one array, and each leaves the iteration
when it has converged: its result does not depend on the other points.

References
----------
.. [1] Kvarda, D. Experimental investigation and numerical modelling of top of rail
   products. PhD thesis, Brno University of Technology, Faculty of Mechanical
   Engineering (the model: section 5.2; no DOI).
.. [2] Kvarda, D., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J., Krupka, I.,
   Hartl, M. (2021). Asperity-based model for prediction of traction in
   water-contaminated wheel-rail contact. Tribology International 157, 106900.
   https://doi.org/10.1016/j.triboint.2021.106900
.. [3] Kalker, J. J. (1982). A fast algorithm for the simplified theory of rolling
   contact. Vehicle System Dynamics 11(1), 1-13. https://doi.org/10.1080/00423118208968684
.. [4] Ertz, M., Knothe, K. (2002). A comparison of analytical and numerical methods for
   the calculation of temperatures in wheel/rail contact. Wear 253(3-4), 498-508.
   https://doi.org/10.1016/S0043-1648(02)00120-3
"""

from __future__ import annotations

import copy
import functools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.errors import ConvergenceError
from torlab.model.flash import (
    ThermalParams,
    converge_flash_temperature,
    converge_flash_temperature_groups,
    flash_temperature_matrix,
)
from torlab.model.layers import LayerParams
from torlab.model.strip import (
    G_strip,
    e_in_cell,
    e_on_nodes,
    e_strip,
    gauss_legendre,
    interp_uniform,
    row_chunks,
    sin2_integral,
)

__all__ = [
    "BoundaryDraws",
    "BoundaryResult",
    "FastsimGrid",
    "FastsimProblem",
    "boundary_traction",
    "boundary_traction_draws",
]


# -------------------------------------------------------------------------------------------
# problem definition
# -------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FastsimGrid:
    """Resolution of the default scheme.

    Attributes
    ----------
    n
        Gauss nodes in ``phi`` over the half contact (strips).
    m
        Gauss nodes per panel along a strip.
    temperature_nodes
        Nodes per strip of the temperature grid.
    graded_panels, uniform_panels, clamp_panels
        Panels of the plastic zone: graded with the Voce length, then uniform
        in ``theta``; panels of the clamped zone.
    """

    n: int = 6
    m: int = 4
    temperature_nodes: int = 48
    graded_panels: int = 6
    uniform_panels: int = 3
    clamp_panels: int = 1


@dataclass(frozen=True)
class FastsimProblem:
    """Everything FASTSIM needs, in SI units.

    Attributes
    ----------
    a, b
        Semi-axes [m], ``a`` in the rolling direction.
    p0
        Maximum Hertz pressure [Pa].
    L1
        Kalker flexibility ``8a/(3 C11 G)`` [m/Pa], Eq. 5.17.
    layer
        Third-body layer parameters.
    speed
        Rolling speed v [m/s]; needed with ``thermal``.
    ambient_temperature
        ``T_A`` [degC].
    thermal
        Flash-temperature model, or None for no temperature.
    calibrated
        Correct the traction by Kalker's exact theory (:mod:`torlab.model.calibrated`,
        the ``fastsim`` boundary method, a scene's default); False: Kalker's FASTSIM
        as the thesis computes it (``fastsim-kalker``).
    """

    a: float
    b: float
    p0: float
    L1: float
    layer: LayerParams
    speed: float = 1.0
    ambient_temperature: float = 20.0
    thermal: ThermalParams | None = None
    calibrated: bool = False

    @property
    def load(self) -> float:
        """Normal load ``2 pi a b p0 / 3`` [N]."""
        return 2.0 * math.pi * self.a * self.b * self.p0 / 3.0


@dataclass
class BoundaryResult:
    """Boundary traction over a set of creepages.

    Attributes
    ----------
    creepage
        The creepages (fractions, signed) as given.
    mu
        Boundary traction coefficient ``mu_BL`` (signed, odd in creepage).
    adhesion_fraction
        Fraction of the load-weighted contact that is still elastic (stick).
    max_temperature_C
        Maximum flash temperature per creepage [degC], None without thermal.
    temperature_iterations
        Iterations of the tau-T loop per creepage (0: no loop).
    temperature_loop
        ``"off"`` (no thermal section), ``"single pass"`` (heating does not
        change the limits) or ``"iterated"``.
    yield_iterations
        Largest number of Newton iterations of a yield-angle solve (all strips
        and creepages at once; with temperature, the largest over the loop's
        passes): a few when the solve converges as it should.
    notes
        Remarks about the computation.
    temperature_rise
        The converged flash-temperature rise on the strips' temperature grid, (creepages,
        strips, temperature nodes) [K] (zero at zero creepage), None without thermal: where
        an evaluation at nearby parameters starts its iteration
        (:func:`boundary_traction_draws`' ``start``).
    """

    creepage: np.ndarray
    mu: np.ndarray
    adhesion_fraction: np.ndarray
    max_temperature_C: np.ndarray | None = None
    temperature_iterations: np.ndarray | None = None
    temperature_loop: str = "off"
    yield_iterations: int = 0
    notes: list[str] = field(default_factory=list)
    temperature_rise: np.ndarray | None = field(default=None, repr=False)


# -------------------------------------------------------------------------------------------
# the solver
# -------------------------------------------------------------------------------------------
def _strips(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``cos phi_j`` and integration weights of the strips (``y = b sin phi``, half contact)."""
    x, w = gauss_legendre(n)
    phi = 0.5 * math.pi * x
    return np.cos(phi), 0.5 * math.pi * w


def _expand(lay: LayerParams) -> LayerParams:
    """A layer of ``(nx, 1)`` arrays as ``(nx, 1, 1)`` (against ``(nx, ns, k)`` angles)."""
    return lay.map(lambda v: v[..., None])


def _group_e_nodes(r_group: np.ndarray, gid: np.ndarray, nT: int) -> np.ndarray:
    """``e(theta; r)`` on the temperature nodes per point (nx, ns, nT), computed once per
    group (``r_group`` (ng, ns), ``gid`` (nx,))."""
    ug, inv = np.unique(gid, return_inverse=True)
    e = e_strip(np.linspace(0.0, math.pi, nT)[None, None, :], r_group[ug][..., None])
    return e[inv.reshape(-1)]


class _Solver:
    """Vectorised evaluation for arrays of creepages (shape nx) and strips (shape ns).

    With ``groups`` (:func:`boundary_traction_draws`) the points carry their own layer:
    ``groups = (gid, layer)`` with ``gid`` (nx,) the group (parameter draw) of each point
    and ``layer`` a :class:`LayerParams` of ``(ng,)`` arrays.  Every layer quantity is then
    an array over the points (``(nx, 1)``), the yield-angle iteration stops per group, and
    a group whose iteration fails is recorded in ``stats["failed"]`` (its points carry on;
    their results are discarded) instead of raising.
    """

    def __init__(self, prob: FastsimProblem, grid: FastsimGrid, xi: np.ndarray,
                 stats: dict[str, Any] | None = None,
                 groups: tuple[np.ndarray, LayerParams] | None = None) -> None:
        self.prob = prob
        self.grid = grid
        self.xi = xi[:, None]  # (nx, 1)
        cphi, self.wy = _strips(grid.n)
        self.cphi = cphi[None, :]  # (1, ns)
        self.aj = prob.a * self.cphi  # strip half-lengths
        self.Pj = prob.p0 * self.cphi  # strip peak pressures
        self.groups = groups
        if groups is None:
            self.gid = None
            lay = prob.layer
            self.lay = lay
        else:
            self.gid, glay = groups
            # the layer of each point, (nx, 1)
            self.lay = glay.map(lambda v: np.asarray(v, dtype=float)[self.gid][:, None])
            lay = self.lay
            #: r of each group (ng, ns), for tables computed once per group
            self.r_group = np.asarray(glay.L_mue, dtype=float)[:, None] / (prob.L1 * self.Pj)
        self.r = lay.L_mue / (prob.L1 * self.Pj)  # (1, ns); (nx, ns) with groups
        # yield condition e(theta; r) = c sin(theta) * f1(T), c = mu_c1 L1 p0 / (xi a)
        self.c = lay.mu_c1 * prob.L1 * prob.p0 / (self.xi * prob.a)
        #: the length the plastic panels are graded with (:meth:`LayerLaw.grading_length`)
        self.Lp = lay.law.grading_length(lay)
        #: e(theta; r) on the temperature nodes (1, ns, nT), set by the temperature loop
        #: (with groups: (nx, ns, nT))
        self.e_nodes: np.ndarray | None = None
        #: largest iteration count of the yield-angle solves (shared with subsets)
        self.stats = stats if stats is not None else {"yield_iterations": 0}

    def subset(self, rows: np.ndarray | slice) -> _Solver:
        """The solver of the creepages ``xi[rows]`` (same strips, shared statistics).

        The per-point arrays are taken from this solver's (each element is computed
        elementwise from its own point, so these are the values a new solver would
        compute); a slice gives views.
        """
        sub = copy.copy(self)
        sub.xi = self.xi[rows]
        sub.c = self.c[rows]
        if self.groups is not None:
            sub.gid = self.gid[rows]
            sub.groups = (sub.gid, self.groups[1])
            sub.lay = self.lay.map(lambda v: v[rows])
            sub.r = self.r[rows]
            sub.Lp = sub.lay.law.grading_length(sub.lay)
            if self.e_nodes is not None:
                sub.e_nodes = self.e_nodes[rows]
        return sub

    def _fail(self, elements: np.ndarray, what: str) -> None:
        """Record the groups of the failed points (``elements``: a mask over the points)."""
        gids = np.unique(np.broadcast_to(self.gid.reshape((-1,) + (1,) * (elements.ndim - 1)),
                                         elements.shape)[elements])
        failed = self.stats["failed"]
        for g in gids:
            failed.setdefault(int(g), what)

    # -- yield angle ------------------------------------------------------------------------
    def yield_angle(self, dT_grid: np.ndarray | None) -> np.ndarray:
        """Yield angles ``theta_y`` (nx, ns): the first root of ``xi E = tau_c1`` per strip.

        ``dT_grid`` is the temperature rise on the uniform temperature nodes (None: the
        isothermal limits).  Both paths are a safeguarded Newton iteration from a
        bracketing table (:func:`_yield_isothermal`, :func:`_yield_thermal`).
        """
        lay = self.prob.layer
        shape = np.broadcast_shapes(self.c.shape, self.r.shape)
        if self.groups is not None:
            return self._yield_angle_groups(dT_grid, shape)
        if lay.mu_c1 == 0.0:
            return np.zeros(shape)
        c = np.broadcast_to(self.c, shape)
        r = np.broadcast_to(self.r, shape)
        if dT_grid is None or lay.mu_c1_T == 0.0:
            # tau_c1 does not depend on the temperature: the isothermal yield point
            th, its = _yield_isothermal(c, r)
        else:
            nT = dT_grid.shape[-1]
            e_nodes = self.e_nodes
            if e_nodes is None or e_nodes.shape[-1] != nT:
                e_nodes = e_strip(np.linspace(0.0, math.pi, nT)[None, None, :], self.r[..., None])
            th, its = _yield_thermal(c, r, e_nodes, dT_grid, lay.mu_c1_T)
        self.stats["yield_iterations"] = max(self.stats["yield_iterations"], its)
        return th

    def _yield_angle_groups(self, dT_grid: np.ndarray | None, shape: tuple[int, ...]
                            ) -> np.ndarray:
        """:meth:`yield_angle` with a layer per point: each point takes the path its own
        layer takes in :meth:`yield_angle` (no elastic limit, isothermal, thermal); the
        iteration stops per group, and a group that does not converge is recorded as
        failed (its angles are NaN)."""
        lay = self.lay
        th = np.zeros(shape)
        c = np.broadcast_to(self.c, shape)
        r = np.broadcast_to(self.r, shape)
        gid = np.broadcast_to(self.gid[:, None], shape)
        live = lay.mu_c1[:, 0] != 0.0
        hot = live & (lay.mu_c1_T[:, 0] != 0.0) if dT_grid is not None else np.zeros_like(live)
        its = 0
        for sel, thermal in ((live & ~hot, False), (hot, True)):
            rows = np.flatnonzero(sel)
            if rows.size == 0:
                continue
            if rows.size == shape[0]:
                rows = slice(None)  # every point: no copies
            if thermal:
                nT = dT_grid.shape[-1]
                e_nodes = self.e_nodes
                if e_nodes is None or e_nodes.shape[-1] != nT:
                    e_nodes = _group_e_nodes(self.r_group, self.gid, nT)
                t, it = _yield_thermal(c[rows], r[rows], e_nodes[rows], dT_grid[rows],
                                       lay.mu_c1_T[rows], groups=gid[rows])
                what = "FASTSIM yield angle with temperature"
            else:
                t, it = _yield_isothermal(c[rows], r[rows], groups=(gid[rows], self.r_group))
                what = "FASTSIM yield angle"
            bad = ~np.isfinite(t)
            if bad.any():
                self._fail(np.isin(np.arange(shape[0]),
                                   np.arange(shape[0])[rows][np.any(bad, axis=1)]),
                           f"{what}: the safeguarded Newton iteration did not converge in "
                           f"{_YIELD_MAX_ITER} steps")
            th[rows] = t
            its = max(its, it)
        self.stats["yield_iterations"] = max(self.stats["yield_iterations"], its)
        return th

    # -- stress at arbitrary angles ---------------------------------------------------------
    def tau(self, theta: np.ndarray, th_y: np.ndarray | None, dT: np.ndarray | float,
            e_theta: np.ndarray | None = None) -> np.ndarray:
        """Shear stress at angles ``theta`` (shape (nx, ns, k)).

        ``th_y`` are the yield angles (None: every node is plastic); ``e_theta``
        optionally gives ``e(theta; r)`` precomputed (fixed temperature grid).
        """
        prob = self.prob
        lay = self.prob.layer if self.groups is None else _expand(self.lay)
        aj = self.aj[..., None]
        Pj = self.Pj[..., None]
        xi = self.xi[..., None]
        p = Pj * np.sin(theta)
        X = aj * (1.0 - np.cos(theta))
        # the layer law's plastic branch at the slip xi X, with p L = L1 p + L_mue
        plastic = lay.law.strip_plastic(lay, p, xi * X, prob.L1 * p + lay.L_mue, dT,
                                        self.groups is not None)
        if th_y is None:
            return plastic
        if e_theta is None:
            e_theta = e_strip(theta, self.r[..., None])
        elastic = xi * (aj / prob.L1) * e_theta
        return np.where(theta < th_y[..., None], elastic, plastic)

    # -- force ------------------------------------------------------------------------------
    def force(self, th_y: np.ndarray, dT_grid: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Tangential force over the half contact [N] and the adhesion (elastic) load fraction."""
        prob, lay, g = self.prob, self.lay, self.grid
        aj, Pj, r = self.aj, self.Pj, self.r
        xi = self.xi
        # elastic part, closed form
        ey = e_strip(th_y, r)
        F_el = xi * (aj * aj / prob.L1) * (G_strip(np.sin(th_y), r) - ey * np.cos(th_y))
        # panels of the plastic zone
        A = xi * aj
        B = lay.mu_c1 * prob.L1 * Pj
        C = lay.mu_c1 * lay.L_mue
        R = np.hypot(A, B)
        phi0 = np.arctan2(B, A)
        q = np.clip((A - C) / R, -1.0, 1.0)
        th0 = np.where((A - C) / R < -1.0, math.pi, np.minimum(phi0 + np.arccos(q), math.pi))
        th_s = np.clip(np.maximum(th_y, th0), th_y, math.pi)
        if self.groups is not None:
            ell = np.where(self.Lp > 0, self.Lp, 0.0) / xi
        else:
            ell = (self.Lp / xi) if self.Lp > 0 else np.full_like(xi, 0.0)
        Xs = aj * (1.0 - np.cos(th_s))
        grades = np.r_[0.0, 0.25 * (2.0 ** np.arange(g.graded_panels) - 1.0) + 0.25][: g.graded_panels + 1]
        grades[0] = 0.0
        Xb = np.minimum(Xs[..., None] + ell[..., None] * grades, 2.0 * aj[..., None])
        thb = np.arccos(np.clip(1.0 - Xb / aj[..., None], -1.0, 1.0))
        th_end_graded = thb[..., -1]
        uni = th_end_graded[..., None] + (math.pi - th_end_graded[..., None]) * np.linspace(0, 1, g.uniform_panels + 1)
        cl = th_y[..., None] + (th_s - th_y)[..., None] * np.linspace(0, 1, g.clamp_panels + 1)
        edges = np.concatenate([cl, thb[..., 1:], uni[..., 1:]], axis=-1)  # (nx, ns, P+1)
        kinks = lay.law.strip_kinks(lay)
        if kinks:
            # where the law's plastic stress kinks (the slip d = c past the limit: same
            # closed form as the clamp's end), an edge more; the panels stay in order
            extra = []
            for c in kinks:
                qk = (A - C - c) / R
                th_k = np.where(qk < -1.0, math.pi, np.minimum(phi0 + np.arccos(
                    np.clip(qk, -1.0, 1.0)), math.pi))
                extra.append(np.where(np.isfinite(th_k), np.clip(th_k, th_s, math.pi), th_s))
            edges = np.sort(np.concatenate([edges, np.stack(extra, axis=-1)], axis=-1),
                            axis=-1)
        lo, hi = edges[..., :-1], edges[..., 1:]
        x, w = gauss_legendre(g.m)
        th = lo[..., None] + (hi - lo)[..., None] * x  # (nx, ns, P, m)
        wt = (hi - lo)[..., None] * w
        th = th.reshape(*th.shape[:2], -1)
        wt = wt.reshape(*wt.shape[:2], -1)
        dT = 0.0 if dT_grid is None else interp_uniform(th, dT_grid)
        tau = self.tau(th, None, dT)  # every node of these panels is plastic
        F_pl = aj * np.sum(wt * tau * np.sin(th), axis=-1)
        Ftot = 2.0 * prob.b * np.sum(self.wy * self.cphi * (F_el + F_pl), axis=-1)
        # load fraction still elastic: integral of p over [0, theta_y] per strip
        stick = 2.0 * prob.b * np.sum(self.wy * self.cphi * aj * Pj * sin2_integral(th_y), axis=-1)
        return Ftot, stick / prob.load


_YIELD_TABLE = 256
#: The yield-angle iteration stops once its Newton step is below this fraction of the angle.
#: Newton converges quadratically, so the error left after a step ``s`` is of order ``s^2``:
#: the angle is then exact to round-off.  (An absolute stop on the step never triggers
#: where round-off alone keeps the step at a few ulp of pi.)
_YIELD_RTOL = 1e-12
#: Iteration budget: plain bisection from a table cell needs about 45 steps.
_YIELD_MAX_ITER = 100


def _bracketed_newton(fdf: Any, lo: np.ndarray, hi: np.ndarray, th: np.ndarray,
                      what: str, groups: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Safeguarded Newton iteration for increasing functions, vectorised over elements.

    ``fdf(theta) -> (f, df)``; ``f < 0`` below the root, which lies in ``[lo, hi]``.  The
    bracket shrinks with the sign of ``f``; a step that leaves it (or is not finite)
    is replaced by bisection.  Stops when every element's step is at most
    ``_YIELD_RTOL`` times its angle.

    Returns
    -------
    tuple
        The roots and the number of iterations.

    Raises
    ------
    ConvergenceError
        Not converged within ``_YIELD_MAX_ITER`` iterations.

    With ``groups`` (an integer array like ``th``: the group of each element) every
    group stops on its own, when all its elements meet the stop, exactly as if it were
    iterated alone; ``fdf(theta, idx)`` then gets the flat indices ``idx`` of the
    elements still iterating, and a group that has not converged within
    ``_YIELD_MAX_ITER`` iterations gets NaN roots instead of an error.
    """
    if groups is not None:
        return _bracketed_newton_groups(fdf, lo, hi, th, groups)
    step = np.full(th.shape, np.inf)
    for it in range(1, _YIELD_MAX_ITER + 1):
        f, df = fdf(th)
        neg = f < 0
        lo = np.where(neg, th, lo)
        hi = np.where(neg, hi, th)
        with np.errstate(divide="ignore", invalid="ignore"):
            new = th - f / df
        bad = ~np.isfinite(new) | (new < lo) | (new > hi)
        new = np.where(bad, 0.5 * (lo + hi), new)
        step = np.abs(new - th)
        th = new
        if np.all(step <= _YIELD_RTOL * np.abs(th)):
            return th, it
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = step / np.abs(th)
    raise ConvergenceError(
        f"{what}: the safeguarded Newton iteration did not converge in {_YIELD_MAX_ITER} "
        f"steps (largest relative step {float(np.nanmax(rel)):.3g}); please report this scene",
        iterations=_YIELD_MAX_ITER, residual=float(np.nanmax(rel)))


def _bracketed_newton_groups(fdf: Any, lo: np.ndarray, hi: np.ndarray, th: np.ndarray,
                             groups: np.ndarray) -> tuple[np.ndarray, int]:
    """:func:`_bracketed_newton` with a stop per group (see there)."""
    shape = th.shape
    g = np.broadcast_to(groups, shape).ravel()
    ng = int(g.max()) + 1 if g.size else 0
    th = np.array(np.broadcast_to(th, shape), dtype=float).ravel()
    lo = np.array(np.broadcast_to(lo, shape), dtype=float).ravel()
    hi = np.array(np.broadcast_to(hi, shape), dtype=float).ravel()
    idx = np.arange(th.size)
    its = 0
    for it in range(1, _YIELD_MAX_ITER + 1):
        if idx.size == 0:
            break
        t = th[idx]
        f, df = fdf(t, idx)
        neg = f < 0
        lo_i = np.where(neg, t, lo[idx])
        hi_i = np.where(neg, hi[idx], t)
        with np.errstate(divide="ignore", invalid="ignore"):
            new = t - f / df
        bad = ~np.isfinite(new) | (new < lo_i) | (new > hi_i)
        new = np.where(bad, 0.5 * (lo_i + hi_i), new)
        step = np.abs(new - t)
        th[idx], lo[idx], hi[idx] = new, lo_i, hi_i
        going = np.zeros(ng, dtype=bool)
        going[g[idx][~(step <= _YIELD_RTOL * np.abs(new))]] = True
        its = it
        idx = idx[going[g[idx]]]
    th[idx] = np.nan  # not converged
    return th.reshape(shape), its


#: yield tables kept (:func:`_yield_table`): a fit's finite differences move one parameter
#: at a time, and only the layer's elastic length changes ``r``, so the latest few serve
#: most evaluations
_YIELD_TABLES_KEPT = 8


def _yield_table(r_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``ln e(theta; r) - ln sin(theta)`` (:func:`~torlab.model.strip.e_strip`) per strip on
    the ``_YIELD_TABLE`` uniform angles in (0, pi], ``inf`` at pi, and ``e(theta; r)``
    itself on the same angles; each of shape ``(ns, nt)``.

    It depends on the strips' ``r = L_mue / (L1 P(y))`` alone, so it is kept for the
    latest few ``r`` (:func:`_yield_table_of`): a fit's evaluations that change the limits
    but not the layer's elastic length find theirs, the same arrays as computed anew.
    Read-only.
    """
    return _yield_table_of(np.ascontiguousarray(r_s, dtype=float).tobytes())


@functools.lru_cache(maxsize=_YIELD_TABLES_KEPT)
def _yield_table_of(r_bytes: bytes) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_yield_table` of the strips' ``r`` given as its float64 bytes."""
    tables = _log_e_over_sin(np.frombuffer(r_bytes, dtype=float))
    for t in tables:
        t.flags.writeable = False
    return tables


def _log_e_over_sin(r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``ln e(theta; r) - ln sin(theta)`` on the ``_YIELD_TABLE`` uniform angles in (0, pi]
    for every ``r`` (:func:`~torlab.model.strip.e_on_nodes`), ``inf`` at pi, and
    ``e(theta; r)`` on those angles; each of shape ``r.shape + (nt,)``."""
    e = e_on_nodes(r, _YIELD_TABLE)
    table = np.log(e) - np.log(np.sin(np.arange(1, _YIELD_TABLE + 1) * (math.pi / _YIELD_TABLE)))
    table[..., -1] = np.inf  # sin(pi) = 0
    return table, e


def _table_start(pick: Any, k: np.ndarray, logc: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cell ``[lo, hi]`` of the yield tables that holds each root (``k``: the table
    nodes before it), ``e(lo; r)`` and a start: the secant of ``ln(e / sin) - ln c``
    through the cell's ends (the cell's middle where an end has no finite value: the
    first cell, starting at 0, and the last, ending at pi).  ``pick(i, j)``: each
    element's value at node ``j`` of table ``i`` of :func:`_log_e_over_sin`."""
    nt = _YIELD_TABLE
    h = math.pi / nt
    lo, hi = k * h, np.where(k >= nt - 1, math.pi, (k + 1) * h)
    j = np.maximum(k - 1, 0)
    e0 = np.where(k > 0, pick(1, j), 0.0)
    g0, g1 = pick(0, j) - logc, pick(0, np.minimum(k, nt - 1)) - logc  # g0 < 0 <= g1
    with np.errstate(divide="ignore", invalid="ignore"):
        start = lo + (hi - lo) * g0 / (g0 - g1)
    ok = (k > 0) & np.isfinite(start) & (start > lo) & (start < hi)
    return lo, hi, e0, np.where(ok, start, 0.5 * (lo + hi))


def _yield_isothermal(c: np.ndarray, r: np.ndarray,
                      groups: tuple[np.ndarray, np.ndarray] | None = None
                      ) -> tuple[np.ndarray, int]:
    """Yield angles solving ``e(theta; r) = c sin(theta)`` without temperature.

    ``e/sin`` is strictly increasing on (0, pi] (the elastic stress grows while the
    limit is concave up to the centre and falls after it), so a table of it per strip
    brackets the root within pi/256; a safeguarded Newton iteration
    (derivative ``sin^2/(sin + r) - c cos``; bisection whenever a step leaves the
    bracket, :func:`_bracketed_newton`), started from the secant of the table's
    ``ln(e/sin)`` through the cell's ends, then converges to round-off in a few steps.
    Inside the cell ``e`` is the table's value at the cell's start plus the integral
    over the rest (:func:`~torlab.model.strip.e_in_cell`: 8 Gauss nodes where the
    integrand's singularity is far enough, ``e_strip`` elsewhere).

    Returns
    -------
    tuple
        The angles (shape of ``c``) and the number of Newton iterations.

    With ``groups = (gid, r_group)`` (the group of each element and ``r`` per group and
    strip) each group has its own table and its own stop (:func:`_bracketed_newton`).
    """
    nt = _YIELD_TABLE
    logc = np.log(c)
    if groups is None:
        r_s = r[0] if r.ndim == 2 else r  # r is constant along the creepage axis
        table, e_tab = _yield_table(r_s)
        k = np.sum(table[None, :, :] < logc[..., None], axis=-1)  # table nodes before the root
        strip = np.arange(k.shape[-1])
        tabs = (table, e_tab)
        lo, hi, e0, th0 = _table_start(lambda i, j: tabs[i][strip, j], k, logc)

        def fdf(th: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            st, ct = np.sin(th), np.cos(th)
            return e_in_cell(th, r, lo, e0) - c * st, st * st / (st + r) - c * ct

        return _bracketed_newton(fdf, lo, hi, th0, "FASTSIM yield angle")
    gid, r_group = groups
    ug, inv = np.unique(gid[:, 0], return_inverse=True)  # a row's group (rows x strips)
    table, e_tab = _log_e_over_sin(r_group[ug])
    inv = inv.reshape(-1)
    k = np.empty(logc.shape, dtype=int)
    for sl in row_chunks(logc.shape[0], logc.shape[1] * nt):  # small temporaries
        k[sl] = np.sum(table[inv[sl]] < logc[sl, ..., None], axis=-1)
    strip = np.arange(k.shape[-1])
    tabs = (table, e_tab)
    lo, hi, e0, th0 = _table_start(lambda i, j: tabs[i][inv[:, None], strip, j], k, logc)
    cf, rf, lof, e0f = (np.ascontiguousarray(np.broadcast_to(x, lo.shape)).ravel()
                        for x in (c, r, lo, e0))

    def fdf_g(th: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cc, rr = cf[idx], rf[idx]
        st, ct = np.sin(th), np.cos(th)
        return e_in_cell(th, rr, lof[idx], e0f[idx]) - cc * st, st * st / (st + rr) - cc * ct

    return _bracketed_newton(fdf_g, lo, hi, th0, "FASTSIM yield angle", groups=groups[0])


def _yield_thermal(c: np.ndarray, r: np.ndarray, e_nodes: np.ndarray, dT: np.ndarray,
                   mu1T: Any, groups: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Yield angles solving ``e(theta; r) = c sin(theta) exp(mu_c1_T dT(theta))`` (Eq. 5.26).

    ``dT`` (nx, ns, nT) is the temperature rise on the uniform nodes, linear between
    them (as everywhere in the scheme).  The sign of the residual on the nodes brackets
    the *first* root (where the particle yields) in one cell; there ``dT`` is linear, the
    residual smooth, and a safeguarded Newton iteration (:func:`_bracketed_newton`,
    started from the secant through the cell ends) converges to round-off.

    Returns
    -------
    tuple
        The angles (nx, ns) and the number of Newton iterations.

    With ``groups`` (the group of each element), ``mu1T`` is an ``(nx, 1)`` array (one
    coefficient per point) and each group stops on its own (:func:`_bracketed_newton`).
    """
    nT = dT.shape[-1]
    if groups is not None:
        mu1T = np.asarray(mu1T, dtype=float)
        mu1T_nodes = mu1T[..., None]
    else:
        mu1T_nodes = mu1T
    h = math.pi / (nT - 1)
    nodes = np.linspace(0.0, math.pi, nT)
    sin_nodes = np.sin(nodes)

    def cells(c: np.ndarray, e_nodes: np.ndarray, m1: Any, dT: np.ndarray) -> tuple[np.ndarray, ...]:
        f_nodes = e_nodes - c[..., None] * sin_nodes * np.exp(m1 * dT)
        above = f_nodes[..., 1:] >= 0.0
        above[..., -1] = True  # f(pi) = e(pi) > 0: the particle has yielded by the trailing edge
        k = np.argmax(above, axis=-1)  # cell [theta_k, theta_k+1] holds the first root
        # the values at nodes k and k + 1 of each (point, strip): one flat index for all
        at = k + nT * np.arange(k.size).reshape(k.shape)
        dTf = np.ascontiguousarray(np.broadcast_to(dT, f_nodes.shape)).reshape(-1)
        ff = f_nodes.reshape(-1)
        d0 = dTf[at]
        slope = (dTf[at + 1] - d0) / h
        ef = np.ascontiguousarray(np.broadcast_to(e_nodes, f_nodes.shape)).reshape(-1)
        return k, d0, slope, ff[at], ff[at + 1], ef[at]

    if groups is None:
        k, d0, slope, f0, f1, e0 = cells(c, e_nodes, mu1T_nodes, dT)
    else:  # many points: in pieces that stay in cache
        k, d0, slope, f0, f1, e0 = (np.empty(c.shape, dtype=int), *(np.empty(c.shape)
                                                                     for _ in range(5)))
        for sl in row_chunks(c.shape[0], int(np.prod(dT.shape[1:]))):
            k[sl], d0[sl], slope[sl], f0[sl], f1[sl], e0[sl] = cells(c[sl], e_nodes[sl],
                                                                     mu1T_nodes[sl], dT[sl])
    lo = k * h
    hi = np.where(k + 1 == nT - 1, math.pi, (k + 1) * h)
    start = lo.copy()

    def fdf(th: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        st, ct = np.sin(th), np.cos(th)
        lim = c * np.exp(mu1T * (d0 + slope * (th - start)))
        e = e_in_cell(th, r, start, e0)
        return e - lim * st, st * st / (st + r) - lim * (ct + mu1T * slope * st)

    with np.errstate(divide="ignore", invalid="ignore"):
        th0 = lo - f0 * (hi - lo) / (f1 - f0)
    th0 = np.where(np.isfinite(th0) & (th0 > lo) & (th0 < hi), th0, 0.5 * (lo + hi))
    if groups is None:
        return _bracketed_newton(fdf, lo, hi, th0, "FASTSIM yield angle with temperature")
    flat = [np.ascontiguousarray(np.broadcast_to(x, lo.shape)).ravel()
            for x in (c, r, d0, slope, start, mu1T, e0)]

    def fdf_g(th: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cc, rr, dd, sl, st0, m1, ee = (x[idx] for x in flat)
        st, ct = np.sin(th), np.cos(th)
        lim = cc * np.exp(m1 * (dd + sl * (th - st0)))
        return (e_in_cell(th, rr, st0, ee) - lim * st,
                st * st / (st + rr) - lim * (ct + m1 * sl * st))

    return _bracketed_newton(fdf_g, lo, hi, th0, "FASTSIM yield angle with temperature",
                             groups=groups)


def _check_finite(name: str, arr: np.ndarray) -> None:
    if not np.all(np.isfinite(arr)):
        from torlab.errors import NumericalError

        raise NumericalError(f"FASTSIM produced a non-finite {name}; please report this scene")


def boundary_traction(prob: FastsimProblem, creepage: Any, grid: FastsimGrid | None = None,
                      *, speed: Any = None, extra_heat_flux: Any = None) -> BoundaryResult:
    """Boundary traction coefficient ``mu_BL(xi)`` (Eq. 5.30) with the third-body layer.

    Parameters
    ----------
    prob
        The contact and the layer (see :class:`FastsimProblem`).
    creepage
        Creepage(s) ``xi = w / v`` (fractions, any sign; Eq. 2.4 SRR as a fraction).
    grid
        Resolution (default :class:`FastsimGrid`).
    speed
        Rolling speed per creepage (m/s, >= 0), broadcast against ``creepage``;
        default ``prob.speed``.  Only the flash temperature depends on it, so a
        Stribeck curve with ``thermal:`` is one call with one point per speed.
    extra_heat_flux
        Optional callable ``(X_over_a, strip_cos_phi, creepage) -> (q_scale, q_add)``
        used by the mixed model to weight the boundary heat flux and add the
        film's (see :mod:`torlab.model.mixed`); ``None`` for a dry contact.  It is
        called once, with arrays that broadcast to (points, strips, temperature
        nodes): the points are every element of ``creepage`` (as ``|creepage|``,
        flattened, in order), so per-point data (speed, film, load share) can be
        indexed by the first axis.

    Returns
    -------
    BoundaryResult

    Raises
    ------
    ConvergenceError
        The contact-temperature iteration (or a yield-angle solve) did not converge.
    """
    grid = grid or FastsimGrid()
    xi_in = np.atleast_1d(np.asarray(creepage, dtype=float))
    if not np.all(np.isfinite(xi_in)):
        raise ValueError("creepage must be finite")
    v = np.broadcast_to(np.asarray(prob.speed if speed is None else speed, dtype=float),
                        xi_in.shape).ravel()
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ValueError("speed must be finite and >= 0")
    sign = np.sign(xi_in).ravel()  # points in order; the outputs take the input's shape
    mag = np.abs(xi_in).ravel()
    nz = mag > 0
    mu = np.zeros_like(mag)
    stick = np.ones_like(mag)
    tmax = None if prob.thermal is None else np.full(mag.shape, prob.ambient_temperature)
    iters = None if prob.thermal is None else np.zeros(mag.shape, dtype=int)
    loop = "off" if prob.thermal is None else "single pass"
    notes: list[str] = []
    stats = {"yield_iterations": 0}
    rise = None
    if prob.thermal is not None:
        rise = np.zeros((mag.size, grid.n, grid.temperature_nodes))
    if nz.any():
        xi = mag[nz]
        solver = _Solver(prob, grid, xi, stats)
        dT_grid = None
        if prob.thermal is not None:
            flux = _extra_flux(extra_heat_flux, grid, solver, mag, nz)
            dT_grid, it, loop, tm = _temperature(solver, prob, grid, xi, v[nz], flux)
            iters[nz] = it
            tmax[nz] = tm
            rise[nz] = dT_grid
            if loop == "single pass":
                lay = prob.layer
                dT_grid = None if not any(lay.law.temperature_coefficients(lay)) else dT_grid
        th_y = solver.yield_angle(dT_grid)
        F, st = solver.force(th_y, dT_grid)
        mu[nz] = F / prob.load
        stick[nz] = st
        if prob.calibrated:
            from torlab.model.calibrated import correct_longitudinal

            mu[nz] = correct_longitudinal(prob, xi, mu[nz])
    _check_finite("traction coefficient", mu)
    if tmax is not None:
        _check_finite("flash temperature", tmax)
    shape = xi_in.shape
    return BoundaryResult(creepage=xi_in, mu=(sign * mu).reshape(shape),
                          adhesion_fraction=stick.reshape(shape),
                          max_temperature_C=None if tmax is None else tmax.reshape(shape),
                          temperature_iterations=None if iters is None else iters.reshape(shape),
                          temperature_loop=loop, yield_iterations=stats["yield_iterations"],
                          notes=notes, temperature_rise=rise)


@dataclass
class BoundaryDraws:
    """Boundary traction of many layers (parameter draws) over the same creepages.

    Attributes
    ----------
    mu
        ``mu_BL`` (draws, creepages), signed; a failed draw's row is NaN.
    adhesion_fraction
        Elastic (stick) load fraction (draws, creepages).
    max_temperature_C
        Maximum flash temperature (draws, creepages), None without thermal.
    errors
        Per draw: ``""`` where it was computed, else why it failed (what
        :func:`boundary_traction` would have raised for that layer).
    """

    mu: np.ndarray
    adhesion_fraction: np.ndarray
    max_temperature_C: np.ndarray | None
    errors: list[str]


def boundary_traction_draws(prob: FastsimProblem, layers: Any, creepage: Any,
                            grid: FastsimGrid | None = None, *,
                            extra_heat_flux: Any = None, start: Any = None) -> BoundaryDraws:
    """:func:`boundary_traction` for many layers at once (the draws of a prediction band).

    Every (draw, creepage) pair is one point of a single vectorised evaluation, each
    with its own layer: the yield-angle iterations stop per draw, the
    contact-temperature iteration per point, so each draw goes through the same steps
    as :func:`boundary_traction` with its layer alone (the same result to round-off).
    A draw whose iteration fails is reported in ``errors`` and left out; the others
    are not affected.

    Parameters
    ----------
    prob
        The contact; its layer gives the parameters ``layers`` does not.
    layers
        ``{name: (m,) array}`` of the layer law's parameters (those of
        ``prob.layer.law``), one entry per draw.
    creepage
        Creepages (fractions, any sign), the same for every draw.
    grid
        Resolution (default :class:`FastsimGrid`).
    extra_heat_flux
        As in :func:`boundary_traction` (called once, for every point: draws x
        creepages, draw-major); the rolling speed is ``prob.speed``.
    start
        Where every draw's contact-temperature iteration starts: the flash-temperature
        rise (creepages, strips, temperature nodes) [K] of a nearby layer (the estimate's,
        :attr:`BoundaryResult.temperature_rise`); default zero.  Each point still
        iterates until its own residual is below the tolerance, so the result is the
        same fixed point to that tolerance, in fewer steps when the layers are close
        (a band's design points, :meth:`torlab.model.bands.DryTractionModel.evaluate_near`).

    Returns
    -------
    BoundaryDraws
    """
    grid = grid or FastsimGrid()
    xi_in = np.atleast_1d(np.asarray(creepage, dtype=float)).ravel()
    if not np.all(np.isfinite(xi_in)):
        raise ValueError("creepage must be finite")
    law = prob.layer.law
    unknown = set(layers) - set(law.names)
    if unknown:
        raise ValueError(f"not parameters of the {law.name} layer law: {sorted(unknown)}")
    vals = {f: np.asarray(layers.get(f, getattr(prob.layer, f)), dtype=float)
            for f in law.names}
    m = int(np.broadcast_shapes(*(v.shape for v in vals.values()), (1,))[0])
    glay = LayerParams(law=law, **{f: np.broadcast_to(vals[f], (m,)).astype(float)
                                   for f in law.names})
    n = xi_in.size
    sign = np.tile(np.sign(xi_in), m)
    mag = np.tile(np.abs(xi_in), m)  # draw-major points
    gid_all = np.repeat(np.arange(m), n)
    mu = np.zeros(m * n)
    stick = np.ones(m * n)
    tmax = None if prob.thermal is None else np.full(m * n, prob.ambient_temperature)
    stats: dict[str, Any] = {"yield_iterations": 0, "failed": {}}
    nz = mag > 0
    if nz.any():
        rows = np.flatnonzero(nz)
        solver = _Solver(prob, grid, mag[nz], stats, (gid_all[nz], glay))
        dT_grid = None
        if prob.thermal is not None:
            flux = _extra_flux(extra_heat_flux, grid, solver, mag, nz)
            v = np.full(rows.size, float(prob.speed))
            if not (math.isfinite(prob.speed) and prob.speed >= 0):
                raise ValueError("speed must be finite and >= 0")
            warm = None
            if start is not None:  # the same start for every draw, at each creepage
                warm = np.asarray(start, dtype=float)
                if warm.shape != (n, grid.n, grid.temperature_nodes):
                    raise ValueError(f"start has the shape {warm.shape}, not (creepages, "
                                     f"strips, nodes) = {(n, grid.n, grid.temperature_nodes)}")
                warm = np.tile(warm, (m, 1, 1))[nz]
            dT_grid, _, _, tm = _temperature(solver, prob, grid, mag[nz], v, flux, warm)
            tmax[nz] = tm
        if stats["failed"]:  # the failed draws' points take no further part
            keep = ~np.isin(gid_all[nz], np.fromiter(stats["failed"], dtype=int))
            solver = solver.subset(np.flatnonzero(keep))
            rows = rows[keep]
            dT_grid = None if dT_grid is None else dT_grid[keep]
        th_y = solver.yield_angle(dT_grid)
        F, st = np.empty(rows.size), np.empty(rows.size)
        per_row = grid.n * grid.m * (grid.graded_panels + grid.uniform_panels + grid.clamp_panels)
        for sl in row_chunks(rows.size, per_row):
            sub = solver.subset(sl)
            F[sl], st[sl] = sub.force(th_y[sl], None if dT_grid is None else dT_grid[sl])
        mu[rows] = F / prob.load
        stick[rows] = st
        if prob.calibrated:
            from torlab.model.calibrated import correct_longitudinal

            lay_rows = glay.map(lambda v: np.asarray(v)[gid_all[rows]])
            mu[rows] = correct_longitudinal(prob, mag[rows], mu[rows], layer=lay_rows)
    mu = (sign * mu).reshape(m, n)
    stick = stick.reshape(m, n)
    tmax = None if tmax is None else tmax.reshape(m, n)
    errors = []
    for g in range(m):
        why = stats["failed"].get(g, "")
        if not why and not np.all(np.isfinite(mu[g])):
            why = "FASTSIM produced a non-finite traction coefficient; please report this scene"
        if not why and tmax is not None and not np.all(np.isfinite(tmax[g])):
            why = "FASTSIM produced a non-finite flash temperature; please report this scene"
        errors.append(why)
    bad = np.array([bool(e) for e in errors], dtype=bool)
    mu[bad] = np.nan
    if tmax is not None:
        tmax[bad] = np.nan
    return BoundaryDraws(mu, stick, tmax, errors)


def _extra_flux(extra_heat_flux: Any, grid: FastsimGrid, solver: _Solver, mag: np.ndarray,
                nz: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``(scale, add)`` of the heat flux on the temperature grid of the points ``nz``
    (``extra_heat_flux`` of :func:`boundary_traction`), or None without one."""
    if extra_heat_flux is None:
        return None
    thetaT, _ = flash_temperature_matrix(grid.temperature_nodes)
    full = (mag.size, grid.n, thetaT.size)
    q_scale, q_add = extra_heat_flux((1.0 - np.cos(thetaT))[None, None, :],
                                     solver.cphi[..., None], mag[:, None, None])
    return (np.broadcast_to(np.asarray(q_scale, dtype=float), full)[nz],
            np.broadcast_to(np.asarray(q_add, dtype=float), full)[nz])


def _temperature(solver: _Solver, prob: FastsimProblem, grid: FastsimGrid, xi: np.ndarray,
                 speed: np.ndarray, flux: tuple[np.ndarray, np.ndarray] | None,
                 start: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, str, np.ndarray]:
    """Converge the flash temperature on the per-strip grid, every point at once.

    Each point (creepage ``xi[i]`` at speed ``speed[i]``) has its own under-relaxed
    fixed-point iteration (module docstring); the points are iterated together, in
    one array, and a point leaves the active set as soon as it has converged, so its
    result does not depend on the other points computed with it.

    With a layer per point (``solver.groups``, :func:`boundary_traction_draws`) the
    coefficients are the point's own, and a point that runs away or does not converge
    marks its group failed (``solver.stats["failed"]``) and leaves the iteration, with
    the other points of its group, instead of raising.

    With a layer per point, ``start`` (nx, ns, nT) [K] is where the iteration starts (a
    nearby solution, :func:`boundary_traction_draws`); zero without one.

    Returns
    -------
    tuple
        ``(dT grid (nx, ns, nT), iterations per point, mode, Tmax per point)``.
    """
    th = prob.thermal
    lay = prob.layer
    grouped = solver.groups is not None
    thetaT, K = flash_temperature_matrix(grid.temperature_nodes)
    KT = K.T
    nx, ns, nT = len(xi), grid.n, len(thetaT)
    moving = speed > 0
    coef = th.partition / np.sqrt(math.pi * th.conductivity * th.density * th.heat_capacity
                                  * np.maximum(speed, 1e-300))
    scale = coef[:, None, None] * np.sqrt(solver.aj)[..., None]  # (nx, ns, 1)
    w = (xi * speed)[:, None, None]  # rigid slip velocity
    if grouped:  # (nx, ns, nT), once per group
        solver.e_nodes = _group_e_nodes(solver.r_group, solver.gid, nT)
        # the yield angle takes the temperature only where mu_c1_T != 0 (yield_angle)
        coupled = True
    else:
        solver.e_nodes = e_strip(thetaT[None, None, :], solver.r[..., None])  # fixed: (1, ns, nT)
        coupled = any(lay.law.temperature_coefficients(lay))
    varying = np.ptp(speed) > 0 if nx else False

    def where(i: int) -> str:
        return f"creepage {xi[i]:.4g}" + (f" and speed {speed[i]:.4g} m/s" if varying else "")

    def G(dT: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Flash temperature rise of the points ``rows`` given their temperature ``dT``."""
        sub = solver if rows.size == nx else solver.subset(rows)
        th_y = sub.yield_angle(dT if coupled else None)
        if not grouped:
            return heat(sub, rows, th_y, dT)
        # many points: the (points, strips, nodes) arrays in pieces that stay in cache
        out = np.empty_like(dT)
        for sl in row_chunks(rows.size, ns * nT):
            out[sl] = heat(sub.subset(sl), rows[sl], th_y[sl], dT[sl])
        return out

    def heat(sub: _Solver, rows: np.ndarray, th_y: np.ndarray, dT: np.ndarray) -> np.ndarray:
        theta_nodes = thetaT[None, None, :]  # broadcast in tau: sin, cos once per node
        tau = sub.tau(theta_nodes, th_y, dT, sub.e_nodes)
        q = tau * w[rows]
        if th.slip_velocity == "local":
            q = np.where(theta_nodes < th_y[..., None], 0.0, q)
        if flux is not None:
            q = q * flux[0][rows] + flux[1][rows]
        return scale[rows] * (q @ KT)

    dT = np.zeros((nx, ns, nT))
    its = np.where(moving, 1, 0)
    if not moving.any():
        return dT, its, "single pass", np.full(nx, prob.ambient_temperature)
    if grouped:  # a layer per point: failures are recorded per group, not raised
        rows = np.flatnonzero(moving)
        if start is not None:  # a nearby solution (the first pass is G there)
            dT = np.where(moving[:, None, None], start, 0.0)
        new = np.zeros_like(dT)
        new[rows] = G(dT[rows], rows)
        peak = np.max(np.abs(new).reshape(nx, -1), axis=1)
        sens = solver.lay.law.temperature_sensitivity(solver.lay)[:, 0]
        single = peak * sens < 1e-6  # heating too small to change the limits: one pass

        def fail(bad: np.ndarray, why: str) -> np.ndarray:  # the points of the failed groups
            solver._fail(bad, why)
            return np.isin(solver.gid, np.fromiter(solver.stats["failed"], dtype=int))

        return converge_flash_temperature_groups(G, new, single, peak, sens, its, moving, where,
                                                 th, prob.ambient_temperature, fail, dT)
    return converge_flash_temperature(G, dT, its, moving, th, lay, where,
                                      prob.ambient_temperature)


