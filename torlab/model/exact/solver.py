"""The tangential problem on the grid: steady rolling and shifts, solved by semi-smooth Newton.

Discretisation (Kalker 1990, chapter 5; CONTACT's user guide, "Discretisation
of the problem")
-----------------------------------------------------------------------------
Tractions are constant on each element; the displacement difference at the
element centres is ``u = A p`` (:mod:`torlab.model.exact.influence`), plus the
layer's own ``L p`` where there is a third-body layer.  The slip of an element
over one step of the scheme (a displacement) is

* steady rolling (the contact rolls in ``+x``, material enters at the leading
  edge, large ``x``; the step is the element length ``dx``, so that a particle at
  element ``I`` was at the element ``I+1`` ahead one step earlier)::

      sigma_I = W_I + v_I - v_{I+1},   v = A p + L p,   W_I = dx (xi - phi y_I, eta + phi x_I)

  The half-space part is ``A q`` with ``q_I = p_I - p_{I+1}`` (the displacement one
  element ahead of the leading edge, traction-free but displaced, is included);
* a shift from a previous state ``p'`` (Cattaneo's problem, the one-element
  layer tests): ``sigma = W + (A + L)(p - p')``, ``W`` the rigid shift;
* a step of transient rolling over one element length from a previous state:
  ``sigma_I = W_I + v_I - v'_{I+1}``, the previous displacement taken where the
  particle was (the state of the element ahead, ``kappa`` too).

Plastic deformation of the layer does not enter ``sigma`` (it takes the place of
slip, :mod:`torlab.model.exact.local`); it raises or lowers the yield stress
through the accumulated plastic deformation ``kappa``, which in steady rolling
is carried with the material: ``kappa_I`` before the step is the sum of the
plastic increments of the elements ahead of ``I`` in its row.

Solver
------
The conditions of every element, ``p = Pi(p - r sigma(p))`` with the local law's
map ``Pi`` and ``r = 1/d`` (``d`` the element's own flexibility in the scheme),
are solved by a semi-smooth Newton iteration (the generalised Jacobian
``J v = v - dPi (v - r B v)``, ``B`` the linear part of ``sigma``) whose linear
systems GMRES solves with products ``B v`` by FFT.  Each step is damped by
backtracking on the residual's norm.  The iteration stops when no element's
``p - Pi(...)`` exceeds ``tol`` times the largest traction bound, or raises
:class:`~torlab.errors.ConvergenceError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from torlab.errors import ConvergenceError
from torlab.model.exact.grid import Grid
from torlab.model.exact.influence import Influence, coefficients
from torlab.model.exact.local import ADHESION, EXTERIOR, PLASTIC, SLIP, YieldLaw, project

__all__ = ["ADHESION", "EXTERIOR", "PLASTIC", "SLIP", "Layer", "Solution", "rigid_slip", "solve"]


@dataclass(frozen=True)
class Layer:
    """The third-body layer on the grid.

    Attributes
    ----------
    flexibility
        Elastic flexibility of the layer, ``(mx, my)`` or a scalar [m/Pa]: ``h/G3`` in
        CONTACT, ``L_mue/p`` in the thesis (Eq. 5.28).
    law
        Yield law, or None for an elastic layer.
    c1, c2
        The law's element parameters ``(mx, my)`` or scalars [Pa].
    """

    flexibility: Any = 0.0
    law: YieldLaw | None = None
    c1: Any = None
    c2: Any = None


@dataclass
class Solution:
    """The solved tangential problem on the grid, in CONTACT's sign convention.

    Attributes
    ----------
    p
        Traction on body 1 ``(mx, my, 2)`` [Pa].
    sigma
        Slip over the step ``(mx, my, 2)`` (m; zero where sticking).
    state
        Element division ``(mx, my)``: 0 exterior, 1 adhesion, 2 slip, 3 plastic.
    kappa
        Accumulated plastic deformation after the step ``(mx, my)`` [m].
    plastic
        Plastic displacement increment of the step ``(mx, my, 2)`` [m].
    newton, matvecs
        Newton steps and products with the influence matrix.
    residual
        Final residual (fraction of the largest bound).
    Fx, Fy, Mz
        Totals of ``p`` (N, N, N m) about the origin.
    """

    grid: Grid
    p: np.ndarray
    sigma: np.ndarray
    state: np.ndarray
    kappa: np.ndarray
    plastic: np.ndarray
    newton: int
    matvecs: int
    residual: float
    Fx: float = 0.0
    Fy: float = 0.0
    Mz: float = 0.0
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        X, Y = self.grid.centres()
        A = self.grid.area
        self.Fx = float(self.p[..., 0].sum() * A)
        self.Fy = float(self.p[..., 1].sum() * A)
        self.Mz = float((X * self.p[..., 1] - Y * self.p[..., 0]).sum() * A)

    def counts(self) -> dict[str, int]:
        """Elements in adhesion, slip and plastic flow."""
        return {"adhesion": int((self.state == ADHESION).sum()),
                "slip": int((self.state == SLIP).sum()),
                "plastic": int((self.state == PLASTIC).sum())}


@lru_cache(maxsize=16)
def influence(mx: int, my: int, dx: float, dy: float, G: float, nu: float, extra: int
              ) -> Influence:
    """The :class:`Influence` of a grid, built once (the solves of a curve share it)."""
    return Influence(mx, my, dx, dy, G, nu, extra=extra)


def gmres(matvec, b: np.ndarray, precond, rtol: float, maxiter: int) -> np.ndarray:
    """Right-preconditioned GMRES without restarts (modified Gram-Schmidt, Givens rotations).

    Solves ``A x = b`` to ``|b - A x| <= rtol |b|`` or ``maxiter`` iterations; returns the
    best ``x`` reached.  (scipy's implementation costs more per iteration than the FFT
    product at these sizes.)
    """
    beta = float(np.linalg.norm(b))
    n = b.size
    if beta == 0.0:
        return np.zeros(n)
    V = np.empty((maxiter + 1, n))
    Z = np.empty((maxiter, n))
    H = np.zeros((maxiter + 1, maxiter))
    cs = np.zeros(maxiter)
    sn = np.zeros(maxiter)
    g = np.zeros(maxiter + 1)
    g[0] = beta
    V[0] = b / beta
    k = 0
    for k in range(maxiter):
        Z[k] = precond(V[k])
        w = matvec(Z[k])
        h = V[: k + 1] @ w
        w = w - h @ V[: k + 1]
        h2 = V[: k + 1] @ w               # one re-orthogonalisation
        w = w - h2 @ V[: k + 1]
        h = h + h2
        hn = float(np.linalg.norm(w))
        for i in range(k):                 # apply the earlier rotations
            t = cs[i] * h[i] + sn[i] * h[i + 1]
            h[i + 1] = -sn[i] * h[i] + cs[i] * h[i + 1]
            h[i] = t
        r = math.hypot(h[k], hn)
        cs[k], sn[k] = (h[k] / r, hn / r) if r > 0 else (1.0, 0.0)
        h[k] = r
        g[k + 1] = -sn[k] * g[k]
        g[k] = cs[k] * g[k]
        H[: k + 1, k] = h[: k + 1]
        if hn > 0:
            V[k + 1] = w / hn
        if abs(g[k + 1]) <= rtol * beta or hn == 0:
            break
    m = k + 1
    y = np.linalg.solve(np.triu(H[:m, :m]), g[:m]) if m else np.zeros(0)
    return y @ Z[:m]


class _Problem:
    """The discrete problem restricted to the contact's elements (vectors ``(n, 2)``)."""

    def __init__(self, grid: Grid, G: float, nu: float, pn: np.ndarray, g: np.ndarray,
                 flex: np.ndarray, layer: Layer, mode: str, W: np.ndarray,
                 p_prev: np.ndarray | None, kappa_prev: np.ndarray | None) -> None:
        self.grid = grid
        self.mode = mode
        contact = pn > 0
        self.contact = contact
        self.idx = np.nonzero(contact.ravel())[0]
        self.n = self.idx.size
        mx, my = grid.mx, grid.my
        self.inf = influence(mx, my, grid.dx, grid.dy, G, nu, 0)
        self.flex = flex
        self.g = g.ravel()[self.idx]
        self.L = flex.ravel()[self.idx]
        self.has_flex = bool(np.any(flex != 0))
        # a constant flexibility inside the contact acts on q like on p (L q = L p - L p ahead)
        self.flex_const = False
        self.law = layer.law
        shape = pn.shape

        def grid_arr(v):
            return None if v is None else np.broadcast_to(np.asarray(v, float), shape).ravel()[self.idx]

        self.c1 = grid_arr(layer.c1)
        self.c2 = grid_arr(layer.c2 if layer.c2 is not None else layer.c1)
        c0 = coefficients(0, 0, grid.dx, grid.dy, G, nu)
        if mode == "steady":
            c1 = coefficients(1, 0, grid.dx, grid.dy, G, nu)
            d = 0.5 * (c0["xx"] - c1["xx"] + c0["yy"] - c1["yy"])
        else:
            d = 0.5 * (c0["xx"] + c0["yy"])
        self.a00 = np.array([float(c0["xx"]), float(c0["yy"])])
        self.r = 1.0 / (float(d) + self.L)
        self.W = W.reshape(-1, 2)[self.idx]
        self.p_prev = None if p_prev is None else p_prev.reshape(-1, 2)[self.idx]
        kp = np.zeros(shape) if kappa_prev is None else np.asarray(kappa_prev, float)
        if mode == "transient":
            # the previous displacement and plastic state where each particle was: one
            # element ahead (traction-free, unyielded material beyond the grid)
            inf1 = influence(mx, my, grid.dx, grid.dy, G, nu, 1)
            ux, uy = inf1.tangential(p_prev[..., 0], p_prev[..., 1])
            v = np.stack([ux, uy], axis=-1)
            v[:mx] += flex[..., None] * p_prev
            self.W = self.W - v[1:].reshape(-1, 2)[self.idx]
            ahead = np.zeros(shape)
            ahead[:-1] = kp[1:]
            kp = ahead
        self.kappa_prev = kp.ravel()[self.idx]
        if mode == "steady" and self.law is not None:
            # the elements of each row, from the leading edge: kappa is carried along them
            ix, iy = np.unravel_index(self.idx, shape)
            self.col = ix
            self.row = iy
            self._kappa_guess = np.zeros(self.n)
        self.matvecs = 0

    def to_grid(self, v: np.ndarray) -> np.ndarray:
        full = np.zeros((self.grid.mx * self.grid.my, 2))
        full[self.idx] = v
        return full.reshape(self.grid.mx, self.grid.my, 2)

    def B(self, v: np.ndarray) -> np.ndarray:
        """The linear part of ``sigma``: ``(mx, my)``-convolution by FFT."""
        self.matvecs += 1
        full = np.zeros((2, self.grid.mx * self.grid.my))
        full[:, self.idx] = v.T
        full = full.reshape(2, self.grid.mx, self.grid.my)
        if self.mode == "steady":
            q = full.copy()
            q[:, :-1] -= full[:, 1:]
        else:
            q = full
        out = self.inf.tangential_stacked(q)
        if self.has_flex:
            out = out + self.flex * q if self.flex_const else out + self._lq(full)
        return out.reshape(2, -1)[:, self.idx].T

    def precondition(self, v: np.ndarray, stick: np.ndarray) -> np.ndarray:
        """An approximate inverse of the Jacobian: on sticking elements (where it is
        ``r B = r A (I - S)``) the traction increments ``q = v/(r a00)`` with the own
        coefficient ``a00`` of ``A``, summed from the leading edge (the inverse of
        ``I - S``); the identity on sliding elements."""
        if self.mode != "steady" or not stick.any():
            return v
        w = np.where(stick[:, None], v, 0.0) / (self.r[:, None] * (self.a00 + self.L[:, None]))
        full = self.to_grid(w)
        p = np.cumsum(full[::-1], axis=0)[::-1].reshape(-1, 2)[self.idx]
        return np.where(stick[:, None], p, v)

    def scale(self, pr: Any, bounded: bool) -> float:
        """The traction the stopping test is relative to: the largest bound (the Coulomb
        bound, the layer's yield stress of fresh material) or traction."""
        if bounded:
            s = float(np.max(np.where(np.isfinite(self.g), self.g, 0.0)))
            if self.law is not None:
                tau0, _ = self.law.stress(np.zeros(self.n), self.c1, self.c2)
                s = max(s, float(np.abs(pr.p).max()), float(np.max(tau0)))
        else:
            s = float(np.abs(pr.p).max())
        return s if s > 0 else 1.0

    def carried_derivative(self, pr: Any, dz: np.ndarray) -> np.ndarray:
        """The tractions' change through the plastic deformation carried from ahead.

        A flowing element's traction ``tau(kappa + lam) zhat`` changes with ``kappa`` by
        ``tau' r/(tau' + r)`` and its plastic increment with its own ``|z|`` by
        ``1/(tau' + r)``; summed along the rows from the leading edge (to first order:
        the change of ``lam`` through ``kappa`` itself is left out).
        """
        slope = pr.slope
        flow = pr.state == PLASTIC
        if slope is None or not flow.any():
            return np.zeros_like(dz)
        dl = np.where(flow, (pr.zhat * dz).sum(axis=1) / (slope + self.r), 0.0)
        inc = np.zeros((self.grid.mx + 1, self.grid.my))
        inc[self.col, self.row] = dl
        ahead = np.cumsum(inc[::-1], axis=0)[::-1][self.col + 1, self.row]
        gain = np.where(flow, slope * self.r / (slope + self.r), 0.0)
        return (gain * ahead)[:, None] * pr.zhat

    def _lq(self, full: np.ndarray) -> np.ndarray:
        Lv = self.flex * full
        if self.mode == "steady":
            Lq = Lv.copy()
            Lq[:, :-1] -= Lv[:, 1:]
            return Lq
        return Lv

    def sigma(self, p: np.ndarray) -> np.ndarray:
        if self.mode == "steady":
            return self.W + self.B(p)
        if self.mode == "transient":
            return self.W + self.B(p)
        return self.W + self.B(p - self.p_prev)

    def project(self, z: np.ndarray):
        if self.mode == "steady" and self.law is not None:
            return self._project_march(z)
        return project(z, self.r, self.g, self.law, self.kappa_prev, self.c1, self.c2)

    def _project_march(self, z: np.ndarray):
        """Project with ``kappa`` carried along the rows from the leading edge.

        ``kappa`` before an element is the sum of the plastic increments ahead of it in its
        row, which depend on their own ``kappa``: a triangular system, solved by projecting
        all elements at once with the last ``kappa`` and summing again until nothing
        changes (after ``k`` passes the first ``k`` columns are exact, so this ends in at
        most as many passes as columns; usually in a few).  The last evaluation's
        ``kappa`` is the start.
        """
        kb = self._kappa_guess
        scale = 0.0
        for _ in range(self.grid.mx + 1):
            pr = project(z, self.r, self.g, self.law, kb, self.c1, self.c2)
            inc = np.zeros((self.grid.mx + 1, self.grid.my))
            inc[self.col, self.row] = pr.plastic_lam
            ahead = np.cumsum(inc[::-1], axis=0)[::-1]        # sum over this and ahead
            new = ahead[self.col + 1, self.row]               # strictly ahead
            scale = max(scale, float(np.abs(new).max()), 1e-300)
            done = float(np.abs(new - kb).max()) <= 1e-12 * scale
            kb = new
            if done:
                break
        else:  # pragma: no cover - bounded by the number of columns
            raise ConvergenceError("exact contact solver: the plastic deformation carried "
                                   "along the rows did not settle")
        if not done:
            pr = project(z, self.r, self.g, self.law, kb, self.c1, self.c2)
        self._kappa_guess = kb
        pr.kappa_before = kb  # type: ignore[attr-defined]
        return pr


def solve(grid: Grid, G: float, nu: float, pn: np.ndarray, mu: float | np.ndarray,
          W: np.ndarray, *, mode: str = "steady", layer: Layer | None = None,
          p_prev: np.ndarray | None = None, kappa_prev: np.ndarray | None = None,
          p0: np.ndarray | None = None, tol: float = 1e-7, max_newton: int = 80) -> Solution:
    """Solve the tangential problem on a grid (module docstring).

    Parameters
    ----------
    grid
        The discretisation; in steady rolling the contact rolls in ``+x``.
    G, nu
        Combined shear modulus [Pa] and Poisson ratio.
    pn
        Normal pressure ``(mx, my)`` [Pa]; the contact is where ``pn > 0``.
    mu
        Coefficient of friction (scalar or per element); ``inf``: no Coulomb bound
        (with no layer law: no slip, the linear theory).
    W
        Rigid slip over the step ``(mx, my, 2)`` [m]: in steady rolling
        ``dx (xi - phi y, eta + phi x)``; in a shift, the rigid shift.
    mode
        ``steady``, ``shift`` or ``transient`` (one step of rolling over ``dx``).
    layer
        Third-body layer (flexibility and yield law), or None.
    p_prev, kappa_prev
        In a shift or a transient step: the tractions and the accumulated plastic
        deformation before it (on the grid).
    p0
        Tractions to start from (a neighbouring solution), else zero.
    tol
        Stopping tolerance, a fraction of the largest traction bound (module docstring).
    max_newton
        Newton steps before :class:`~torlab.errors.ConvergenceError`.

    Returns
    -------
    Solution
    """
    if mode not in ("steady", "shift", "transient"):
        raise ValueError(f"unknown mode {mode!r}")
    pn = np.asarray(pn, dtype=float)
    contact = pn > 0
    layer = layer or Layer()
    mu_arr = np.broadcast_to(np.asarray(mu, dtype=float), pn.shape)
    g = np.where(contact, mu_arr * np.where(contact, pn, 1.0), 0.0)
    flex = np.broadcast_to(np.asarray(layer.flexibility, dtype=float), pn.shape).copy()
    flex[~contact] = 0.0
    if mode in ("shift", "transient") and p_prev is None:
        p_prev = np.zeros((*pn.shape, 2))
    prob = _Problem(grid, G, nu, pn, g, flex, layer, mode, np.asarray(W, float), p_prev,
                    kappa_prev)
    n = prob.n
    if n == 0:
        raise ValueError("no element of the grid is in contact")
    p = np.zeros((n, 2)) if p0 is None else np.asarray(p0, float).reshape(-1, 2)[prob.idx].copy()
    gfin = prob.g[np.isfinite(prob.g)]
    bounded = prob.law is not None or gfin.size == n

    def evaluate(p):
        z = p - prob.r[:, None] * prob.sigma(p)
        pr = prob.project(z)
        return p - pr.p, pr

    F, pr = evaluate(p)
    carried = mode == "steady" and prob.law is not None
    hist = []
    steps = 0
    while True:
        res = float(np.abs(F).max()) / prob.scale(pr, bounded)
        hist.append(res)
        if res <= tol:
            break
        if steps >= max_newton:
            raise ConvergenceError(
                f"exact contact solver: residual {res:.1e} above {tol:.0e} after {steps} Newton "
                f"steps ({n} elements in contact)")
        steps += 1
        r = prob.r

        def J(vflat, pr=pr, r=r):
            v = vflat.reshape(n, 2)
            dz = v - r[:, None] * prob.B(v)
            out = v - pr.derivative(dz)
            if carried:
                out = out - prob.carried_derivative(pr, dz)
            return out.ravel()

        stick = pr.state == ADHESION

        def M(vflat, stick=stick):
            return prob.precondition(vflat.reshape(n, 2), stick).ravel()

        fnorm = float(np.linalg.norm(F))
        forcing = min(0.1, fnorm / max(float(np.linalg.norm(pr.p)), 1e-300))
        dx = gmres(J, -F.ravel(), M, rtol=max(forcing, 1e-12), maxiter=min(2 * n, 300))
        dx = dx.reshape(n, 2)
        t = 1.0
        for _ in range(30):
            pt = p + t * dx
            Ft, prt = evaluate(pt)
            if np.linalg.norm(Ft) <= (1 - 1e-4 * t) * fnorm:
                break
            t *= 0.5
        else:
            # no decrease along the Newton direction: take a damped fixed-point step instead
            pt = p - 0.5 * F
            Ft, prt = evaluate(pt)
        p, F, pr = pt, Ft, prt
    # the converged state
    p = pr.p
    sigma = np.where((pr.state != ADHESION)[:, None], -pr.lam[:, None] * pr.zhat, 0.0)
    state = np.full(grid.mx * grid.my, EXTERIOR)
    state[prob.idx] = pr.state
    plastic = pr.plastic_lam[:, None] * pr.zhat
    kap = np.zeros(grid.mx * grid.my)
    if mode == "steady" and prob.law is not None:
        kap[prob.idx] = pr.kappa_before + pr.plastic_lam
    else:
        kap[prob.idx] = prob.kappa_prev + pr.plastic_lam
    shape = (grid.mx, grid.my)
    return Solution(grid=grid, p=prob.to_grid(p), sigma=prob.to_grid(sigma),
                    state=state.reshape(shape), kappa=kap.reshape(shape),
                    plastic=prob.to_grid(plastic), newton=steps, matvecs=prob.matvecs,
                    residual=hist[-1], info={"residuals": hist})


def rigid_slip(grid: Grid, xi: float, eta: float, phi: float, x_spin: float = 0.0) -> np.ndarray:
    """Steady rolling's rigid slip over one step ``dx (xi - phi y, eta + phi (x + x_spin))`` [m]."""
    X, Y = grid.centres()
    return grid.dx * np.stack([xi - phi * Y, eta + phi * (X + x_spin)], axis=-1)

