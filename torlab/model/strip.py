"""Closed forms along a strip of an elliptical contact: the integrals FASTSIM and the creep
solver share (thesis 5.2.2, Eqs. 5.16-5.30; docs/model/thesis-reading.md).

A strip at lateral position ``y`` of a Hertz contact has half-length
``a(y) = a sqrt(1 - (y/b)^2)``; in the angle ``theta`` with ``X = a(y)(1 - cos theta)``
the pressure is ``p = P(y) sin theta``, and the elastic stress of the third-body layer is
``tau = xi (a(y)/L1) e(theta; r)`` with ``r = L_mue / (L1 P(y))`` [-]:

* :func:`e_strip`: ``e(theta; r) = integral_0^theta sin^2 t / (sin t + r) dt`` (closed form
  for ``r < 1/2``, a Gauss-Legendre rule with as many nodes as the integrand's nearest
  singularity asks for elsewhere); :func:`e_in_cell` the same from a value at the start of
  a temperature cell;
* :func:`G_strip`: ``G(s) = integral_0^s x^2/(x + r) dx``, the elastic force of a strip
  ``xi (a(y)^2/L1) [G(sin theta_y) - e(theta_y) cos theta_y]``; :func:`sin2_integral`;
* :func:`gauss_legendre` nodes and weights on [0, 1], :func:`row_chunks` (work in pieces
  whose temporaries stay in cache), :func:`interp_uniform` (a quantity on the uniform
  temperature nodes at any angle).

References
----------
.. [1] Kalker, J. J. (1982). A fast algorithm for the simplified theory of rolling
   contact. Vehicle System Dynamics 11(1), 1-13. https://doi.org/10.1080/00423118208968684
.. [2] Kvarda, D., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J., Krupka, I.,
   Hartl, M. (2021). Asperity-based model for prediction of traction in water-contaminated
   wheel-rail contact. Tribology International 157, 106900.
   https://doi.org/10.1016/j.triboint.2021.106900
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

__all__ = ["CHUNK_ELEMENTS", "G_strip", "e_in_cell", "e_on_nodes", "e_strip", "gauss_legendre",
           "interp_uniform", "row_chunks", "sin2_integral"]


@cache
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


#: elements of the (points, strips, nodes) arrays computed at once with a layer per point,
#: and of e_strip's quadrature: temporaries below ~128 kB come from the allocator's free
#: lists and stay in cache; larger ones are fresh pages each time (several times slower)
CHUNK_ELEMENTS = 12288


def row_chunks(n_rows: int, per_row: int) -> list[slice]:
    """Slices of ``n_rows`` rows with about :data:`CHUNK_ELEMENTS` elements each."""
    step = max(1, CHUNK_ELEMENTS // max(per_row, 1))
    return [slice(i, min(i + step, n_rows)) for i in range(0, n_rows, step)]


def e_strip(theta: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``e(theta; r) = integral_0^theta sin^2 t / (sin t + r) dt`` (elastic stress shape).

    ``tau_el = xi (a(y)/L1) e(theta; r)`` with ``r = L_mue/(L1 P(y))``.  Closed form
    ``(1 - cos theta) - r theta + r^2 J`` with ``J = integral dt/(sin t + r)``
    (tangent half-angle substitution) where ``r < 1/2`` and ``theta > r``; a
    Gauss-Legendre rule elsewhere (the integrand's nearest singularity is then far
    from the interval), with as many nodes as that distance needs for round-off
    accuracy (:func:`_gauss_nodes`: 6 to 24).
    """
    theta, r = np.broadcast_arrays(np.asarray(theta, dtype=float), np.asarray(r, dtype=float))
    out = np.empty(theta.shape)
    # r = 0 (no elastic layer, L_mue = 0): e = 1 - cos(theta), also at theta = 0 where the
    # quadrature's integrand would be 0/0
    closed = (r < 0.5) & ((theta > r) | (r <= 0))
    if closed.any():
        th, rr = theta[closed], r[closed]
        res = 2.0 * np.sin(0.5 * th) ** 2  # 1 - cos(theta) without cancellation
        pos = rr > 0
        if pos.any():
            t, q = th[pos], rr[pos]
            s = np.sqrt(1.0 - q * q)
            v = np.cos(0.5 * t) / np.sin(0.5 * t)  # cot(theta/2), 0 at theta = pi
            J = (np.log1p(q * v / (1.0 + s)) - np.log1p((1.0 + s) * v / q)
                 + 2.0 * np.log((1.0 + s) / q)) / s
            res[pos] = res[pos] - q * t + q * q * J
        out[closed] = res
    other = ~closed
    if other.any():
        th, rr = theta[other], r[other]
        out[other] = _gauss_piece(None, th, rr, _gauss_nodes(th, rr))
    return out


@cache
def _gauss_rules() -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on [0, 1] of every even Gauss-Legendre rule from 6 to 24 points,
    one row per rule (row ``k``: the ``2k``-point rule), padded with zero weights to 24
    columns."""
    x = np.zeros((13, 24))
    w = np.zeros((13, 24))
    for n in range(_GAUSS_MIN, 25, 2):
        x[n // 2, :n], w[n // 2, :n] = gauss_legendre(n)
    return x, w


#: Gauss-Legendre nodes of e_strip's rule: ``n >= _GAUSS_A / ln(rho)``, even, from
#: ``_GAUSS_MIN`` to 24 (see :func:`_gauss_nodes`)
_GAUSS_A = 13.0


_GAUSS_MIN = 6


def _gauss_nodes(theta: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Nodes of the Gauss-Legendre rule for ``e(theta; r)`` (:func:`e_strip`), per element.

    The integrand ``sin^2 t / (sin t + r)`` is analytic except where ``sin t = -r``:
    at ``t = -asin r`` for ``r <= 1``, at ``t = -pi/2 +- i acosh r`` for ``r > 1``
    (the points after ``theta <= pi`` are farther).  The ``n``-point rule on
    ``[0, theta]`` then errs by ``O(M rho^(-2n))`` with ``rho`` the Bernstein ellipse
    through that point (foci at 0 and ``theta``: ``rho = A + sqrt(A^2 - 1)`` with ``2 A
    theta`` the sum of the point's distances to the foci) and ``M`` the integrand's
    largest value on it (Trefethen, *Approximation Theory and Approximation Practice*,
    Thm. 19.3).  ``sin^2 t`` grows like ``exp(2 |Im t|)``, so ``rho`` is capped where
    the ellipse's half-width reaches 1 (``(theta/4)(rho - 1/rho) = 1``; the case of a
    large ``r``, whose singularity is far).  ``n = 2 ceil(13 / ln rho)``
    (``rho^(-2n) <= e^-52``), from 6 to 24: round-off accuracy with a margin over
    the worst case, ``r = 1/2`` at ``theta = pi``, which needs the 24 nodes
    (``tests/test_boundary.py`` checks it against 30-digit quadrature).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        near = r <= 1.0
        c = np.arccosh(np.where(near, 1.0, r))
        half = 0.5 * math.pi
        A = np.where(near, 1.0 + 2.0 * np.arcsin(np.minimum(r, 1.0)) / theta,
                     (np.hypot(half, c) + np.hypot(theta + half, c)) / theta)
        # the ellipse also stays within |Im t| <= 1, where sin^2 t grows by at most cosh(1)^2
        cap = 4.0 / theta + np.sqrt(16.0 / (theta * theta) + 1.0)
        rho = np.minimum(A + np.sqrt(A * A - 1.0), cap)
        n = 2.0 * np.ceil(_GAUSS_A / np.log(rho))
    return np.where(np.isfinite(n) & (n < 24), np.maximum(n, _GAUSS_MIN), 24).astype(int)


#: Gauss-Legendre nodes of e(theta; r) over a part of a temperature cell (:func:`e_in_cell`)
_CELL_NODES = 8


def _gauss_piece(a: np.ndarray | None, d: np.ndarray, r: np.ndarray,
                 nodes: np.ndarray | int = _CELL_NODES) -> np.ndarray:
    """``integral_a^(a+d) sin^2 t / (sin t + r) dt`` (``a`` None: from 0) by the
    Gauss-Legendre rule of ``nodes`` points (even, 6 to 24; one count for all or one per
    element), every element in one pass: each row takes its rule's nodes and weights,
    padded with zero weights to the largest rule in use, which add nothing (a row's sum
    differs from its rule's alone only in the order of the additions)."""
    xs, ws = _gauss_rules()
    k_all = np.broadcast_to(np.asarray(nodes) // 2, d.shape)
    m = 2 * int(k_all.max()) if d.size else 0
    out = np.empty(d.shape)
    # in pieces of CHUNK_ELEMENTS nodes: temporaries that stay small are much faster
    for sl in row_chunks(d.size, m):
        k = k_all[sl]
        x, w = xs[k, :m], ws[k, :m]
        t = d[sl, None] * x if a is None else a[sl, None] + d[sl, None] * x
        st = np.sin(t)
        den = st + r[sl, None]
        # the integrand tends to 0 with sin t where r = 0 (no layer): no 0/0 at sin t = 0
        f = np.divide(st * st, den, out=np.zeros_like(den), where=den > 0)
        out[sl] = d[sl] * np.sum(w * f, axis=1)
    return out


def e_in_cell(theta: np.ndarray, r: np.ndarray, t0: np.ndarray, e0: np.ndarray) -> np.ndarray:
    """``e(theta; r)`` (:func:`e_strip`) from its value ``e0`` at ``t0 <= theta``, the start
    of the temperature cell that holds ``theta``: ``e0`` plus the integral over the short
    piece ``[t0, theta]`` by an :data:`_CELL_NODES`-point Gauss-Legendre rule.

    The integrand's singularities (``sin t = -r``) lie at least ``delta = r + min(t0,
    pi - theta)`` from the piece for ``r <= 1`` (``asin r >= r``) and at least ``pi/2``
    for ``r > 1``.  Where ``delta >= 4 d`` (``d = theta - t0``; every ``r >= 0.27`` with
    the default 48 temperature nodes) the Bernstein ellipse of the piece has ``rho >=
    9 + sqrt(80) > 17`` and 8 nodes err by ``rho^-16 < 1e-19`` relative to the piece;
    :func:`e_strip` elsewhere.  ``tests/test_boundary.py`` checks both against 30-digit
    quadrature.
    """
    shape = theta.shape
    theta, r, t0, e0 = (np.ravel(x) for x in np.broadcast_arrays(theta, r, t0, e0))
    d = theta - t0
    inc = r + np.minimum(t0, math.pi - theta) >= 4.0 * d
    if inc.all():
        return (e0 + _gauss_piece(t0, d, r)).reshape(shape)
    out = np.empty(theta.shape)
    rest = ~inc
    out[rest] = e_strip(theta[rest], r[rest])
    if inc.any():
        out[inc] = e0[inc] + _gauss_piece(t0[inc], d[inc], r[inc])
    return out.reshape(shape)


def e_on_nodes(r: np.ndarray, n: int) -> np.ndarray:
    """``e(theta_j; r)`` (:func:`e_strip`) on the ``n`` uniform angles ``theta_j = j pi/n``,
    ``j = 1 .. n``, for every ``r``; shape ``r.shape + (n,)``.

    Cell by cell: the first four and the last four angles by :func:`e_strip`, the ones
    between as the value at the fourth plus the integrals over the cells before them,
    each by :data:`_CELL_NODES` Gauss-Legendre nodes (:func:`e_in_cell`'s rule: there the
    integrand's singularities lie at least four cell widths from the cell, whatever
    ``r >= 0``, so each cell's rule is exact to round-off), summed in order.  The
    integrand is positive, so the sum's relative round-off stays below about ``n`` units
    in the last place; ``tests/test_boundary.py`` checks the values against 30-digit
    quadrature.  About half the time of :func:`e_strip` on the same angles, whose rule
    integrates each from 0 with up to 24 nodes (measured for 8 and 32 strips).
    """
    r = np.asarray(r, dtype=float)
    h = math.pi / n
    theta = np.arange(1, n + 1) * h
    if n < 10:  # no cell four widths from both ends
        return e_strip(theta, r[..., None])
    ends = np.r_[theta[:4], theta[-4:]]
    out = np.empty((*r.shape, n))
    e_ends = e_strip(ends, r[..., None])
    out[..., :4], out[..., -4:] = e_ends[..., :4], e_ends[..., 4:]
    # cells [i h, (i + 1) h] for i = 4 .. n - 5: delta = r + min(i h, pi - (i + 1) h) >= 4 h
    t0 = np.arange(4, n - 4) * h
    rr, tt = np.broadcast_arrays(r[..., None], t0)
    piece = _gauss_piece(tt.ravel(), np.full(tt.size, h), rr.ravel(), _CELL_NODES)
    out[..., 4:n - 4] = out[..., 3:4] + np.cumsum(piece.reshape(tt.shape), axis=-1)
    return out


def G_strip(s: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``G(s) = integral_0^s x^2/(x + r) dx = s^2/2 - r s + r^2 ln(1 + s/r)``."""
    s, r = np.broadcast_arrays(np.asarray(s, dtype=float), np.asarray(r, dtype=float))
    out = 0.5 * s * s
    pos = r > 0
    if pos.any():
        ss, rr = s[pos], r[pos]
        z = ss / rr
        series = z < 0.1
        val = np.empty(ss.shape)
        if series.any():
            zz, r2 = z[series], rr[series] ** 2
            acc = np.zeros(zz.shape)
            for k in range(3, 20):
                acc += (-1) ** (k + 1) * zz**k / k
            val[series] = r2 * acc
        ns = ~series
        if ns.any():
            val[ns] = 0.5 * ss[ns] ** 2 - rr[ns] * ss[ns] + rr[ns] ** 2 * np.log1p(z[ns])
        out[pos] = val
    return out


def sin2_integral(theta: np.ndarray) -> np.ndarray:
    """``integral_0^theta sin^2 t dt``."""
    return 0.5 * theta - 0.25 * np.sin(2.0 * theta)


def interp_uniform(theta: np.ndarray, grid_T: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``grid_T[..., i]`` given on uniform theta nodes on [0, pi].

    ``theta`` has shape ``(..., k)`` with the leading axes of ``grid_T``.
    """
    nT = grid_T.shape[-1]
    pos = np.clip(theta / math.pi * (nT - 1), 0.0, nT - 1 - 1e-12)
    i0 = pos.astype(int)
    f = pos - i0
    lo = np.take_along_axis(grid_T, i0, axis=-1)
    hi = np.take_along_axis(grid_T, i0 + 1, axis=-1)
    return lo + f * (hi - lo)
