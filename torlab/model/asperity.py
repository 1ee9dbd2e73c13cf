"""Asperity contact: Greenwood–Williamson pressure and the functions ``F_n``.

Thesis 5.2.4 (Eqs. 5.41–5.43) as ``docs/model/thesis-reading.md`` reads it.

* Roughness parameter ``K = psi * beta * gamma`` with ``psi`` the standard
  deviation of the asperity heights [m], ``beta`` the asperity tip *radius* [m]
  and ``gamma`` the asperity density [1/m^2].  Tab. 5.1 (Paper A):
  8.3 nm x 0.301 mm x 24 200 mm^-2 = 0.0605.
* Elastic (Greenwood–Williamson) asperity pressure, the dimensionally consistent
  form of Eq. 5.41::

      p_a = (4/3) K E* sqrt(psi/beta) F_3/2(h/psi)

  The thesis prints ``(4/3) (K/2) E* F_3/2 sqrt(psi/gamma)``.  ``sqrt(psi/gamma)``
  has the unit m^(3/2), so ``p_a`` would not be a pressure: ``beta`` is meant
  (Greenwood & Williamson: ``p = (4/3) gamma E* beta^(1/2) psi^(3/2) F_3/2``,
  which is the line above).  ``K/2`` equals ``K`` with the reduced modulus
  ``E' = 2 E*`` in place of ``E*`` (``(K/2) E' = K E*``): read with ``E*`` as
  printed it would halve the pressure.  No variant with the printed factors is
  offered, because the printed form is not a pressure.
* Plastic asperity pressure as the thesis gives it (Eq. 5.42)::

      p_a = (2/3) pi^2 H K^2 F_4(h/psi)

* ``F_n(t) = (1/sqrt(2 pi)) * integral_t^inf (s - t)^n exp(-s^2/2) ds`` (Eq. 5.43),
  the n-th moment of the part of a standard normal variable above ``t``.

Computing ``F_n``
-----------------
The thesis integrates Eq. 5.43 numerically (upper bound 30, 1000 steps);
:func:`F_n_thesis_quadrature` is that baseline.  The exact form is
``F_n(t) = Gamma(n+1)/sqrt(2 pi) exp(-t^2/4) D_-(n+1)(t)`` (parabolic cylinder
function).  ``scipy.special.pbdv`` evaluates it, but (scipy 1.17, measured
against mpmath) it loses accuracy for non-integer orders near |t| = 6 (relative
error up to 3e-9 at t = 6 for n = 3/2 and 3e-11 at t = -6), costs about 5 us per
point, and ``exp(-t^2/4) D`` overflows for t < -53.  torlab therefore uses

* :func:`F_n_exact` -- exact to rounding and used to build and test.  Measured
  against mpmath (40 digits) for n in {0, 0.3, 1.5, 2.5, 4, 7.25, 10, 20}: relative
  error <= 6e-14 for t in [-40, 12] and <= 7e-13 up to the underflow point, where
  ``ln F_n ~ -700`` and the rounding of the exponent alone costs ~700 eps:

  - t >= 2 + n/20: generalised Gauss–Laguerre quadrature (64 nodes, weight
    ``y^n e^-y``) of ``F_n(t) = phi(t) t^-(n+1) int_0^inf y^n e^-y e^(-y^2/(2t^2)) dy``,
    evaluated as ``ln F_n`` so that it underflows cleanly to 0;
  - -12 <= t < 2 + n/20: Gauss–Jacobi quadrature (weight ``x^n``, which carries the
    non-analytic factor exactly) of ``int_0^inf x^n exp(-(x+t)^2/2) dx`` plus
    Gauss–Legendre on the Gaussian bump when it is away from ``x = 0``;
  - t < -12: the moment series
    ``F_n(t) = |t|^n sum_j C(n, 2j) (2j-1)!! t^(-2j)``, whose truncation error
    is of order exp(-t^2/2) < 1e-31 there;
  - ``F_n`` is 0 where it is below the smallest float (t > ~38.6).

* :func:`F_n` -- the fast default.  For each order ``n`` it builds on first use
  (about 5 ms, cached) a piecewise Chebyshev interpolant of ``ln F_n(t)`` on
  t in [-12, t_0] (t_0 where ``F_n`` underflows, about 38.6) with pieces of width
  1/2 and degree 13, from :func:`F_n_exact`, and evaluates it with one index
  computation and a Horner loop over numpy arrays (a plain-Python path for
  scalars, which root finders use); below -12 it uses the moment series.
  Measured against mpmath: relative error <= 7e-14 on [-40, 12] and <= 7e-13
  up to the underflow point; ``torlab.bench.asperity`` reports ~50-80 ns per
  point on 1e4 points, over 1000x faster than the thesis quadrature (whose
  error is 4e-4 for n = 3/2 and 1e-8 for n = 4 on t in [-5, 10]).

``F_n`` is finite and non-negative for every finite ``t`` whose value fits in
a float (``F_n(t) ~ |t|^n`` for t -> -inf, so for ``n = 4`` that is
t > -1e77); beyond that :class:`FnOverflowError` is raised.  NaN propagates.

References
----------
.. [1] Greenwood, J. A., Williamson, J. B. P. (1966). Contact of nominally flat surfaces.
   Proceedings of the Royal Society A 295(1442), 300-319.
   https://doi.org/10.1098/rspa.1966.0242
.. [2] Greenwood, J. A., Tripp, J. H. (1970). The contact of two nominally flat rough
   surfaces. Proceedings of the Institution of Mechanical Engineers 185(1), 625-633.
   https://doi.org/10.1243/PIME_PROC_1970_185_069_02
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from torlab.errors import NumericalError, TorlabInputError

__all__ = [
    "AsperityModel",
    "F_n",
    "F_n_exact",
    "F_n_inverse",
    "F_n_pbdv",
    "F_n_thesis_quadrature",
    "FnOverflowError",
    "Roughness",
    "bracketed_root",
    "h_star",
    "p_a_elastic",
    "p_a_plastic",
    "roughness_K",
]

_LN_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
_SQRT_2PI = math.sqrt(2.0 * math.pi)
#: largest order supported (the Laguerre/Jacobi rules and the moment series are verified up to here)
N_MAX = 20.0
#: lower end of the interpolated range; the moment series is used below
_T_LOW = -12.0
#: Gauss rules
_N_GAUSS = 64
#: split point between the Jacobi/Legendre and the Laguerre rules
_T_LAGUERRE = 2.0
#: length of the Gaussian tail integrated with Legendre nodes (exp(-13^2/2) ~ 2e-37)
_TAIL = 13.0
#: ln of the smallest positive float64 (subnormal), ~ -744.4
_LN_TINY = math.log(5e-324)
_LN_MAX = math.log(np.finfo(float).max)
#: interpolant: piece width and polynomial degree
_PIECE = 0.5
_DEGREE = 13


class FnOverflowError(NumericalError):
    """``F_n(t)`` exceeds the largest float (t far below -1e30 for the orders used)."""


# ----------------------------------------------------------------------------------------
# exact evaluation
# ----------------------------------------------------------------------------------------

def _check_n(n: float) -> float:
    n = float(n)
    if not (0.0 <= n <= N_MAX):
        raise ValueError(f"F_n: order n must be in [0, {N_MAX:g}], got {n!r}")
    return n


@lru_cache(maxsize=64)
def _laguerre_rule(n: float) -> tuple[np.ndarray, np.ndarray]:
    from scipy.special import roots_genlaguerre

    y, w = roots_genlaguerre(_N_GAUSS, n)
    return y, w


@lru_cache(maxsize=64)
def _jacobi_rule(n: float) -> tuple[np.ndarray, np.ndarray]:
    from scipy.special import roots_jacobi

    u, w = roots_jacobi(_N_GAUSS, 0.0, n)  # weight (1+u)^n on [-1, 1]
    return u, w


@lru_cache(maxsize=1)
def _legendre_rule() -> tuple[np.ndarray, np.ndarray]:
    from scipy.special import roots_legendre

    return roots_legendre(_N_GAUSS)


@lru_cache(maxsize=64)
def _moment_coefficients(n: float, terms: int = 30) -> np.ndarray:
    """``C(n, 2j) (2j-1)!!`` for j = 0 .. terms-1 (the moments of the standard normal)."""
    from scipy.special import binom

    j = np.arange(terms)
    dfact = np.concatenate(([1.0], np.cumprod(np.arange(1, 2 * terms - 2, 2, dtype=float))))
    return binom(n, 2 * j) * dfact[:terms]


def _log_moment_series(n: float, t: np.ndarray) -> np.ndarray:
    """``ln F_n(t)`` for t <= -12 from the moment series (error ~ exp(-t^2/2))."""
    c = _moment_coefficients(n)
    x = 1.0 / (t * t)
    acc = np.full_like(t, c[-1])
    for ck in c[-2::-1]:
        acc = acc * x + ck
    return n * np.log(-t) + np.log(acc)


def _log_laguerre(n: float, t: np.ndarray) -> np.ndarray:
    """``ln F_n(t)`` for t >= 2: Gauss–Laguerre with weight ``y^n e^-y`` (x = y/t)."""
    y, w = _laguerre_rule(n)
    g = np.exp(-0.5 * (y[None, :] / t[:, None]) ** 2)
    return -_LN_SQRT_2PI - 0.5 * t * t - (n + 1.0) * np.log(t) + np.log(g @ w)


def _log_jacobi(n: float, t: np.ndarray) -> np.ndarray:
    """``ln F_n(t)`` for -12 <= t < 2: ``int_0^inf x^n exp(-(x+t)^2/2) dx / sqrt(2 pi)``."""
    u, wj = _jacobi_rule(n)
    z, wl = _legendre_rule()
    c = np.maximum(-t, 0.0)
    split = c >= 2.0
    # one Jacobi piece on [0, L] where the bump is near x = 0 (L = c + tail)
    L = np.where(split, c, c + _TAIL)[:, None]
    x = 0.5 * L * (1.0 + u[None, :])
    total = (0.5 * L[:, 0]) ** (n + 1.0) * (np.exp(-0.5 * (x + t[:, None]) ** 2) @ wj)
    # plus a Legendre piece on [c, c + tail] where the bump is away from the singular end
    if split.any():
        cs = c[split][:, None]
        xs = cs + 0.5 * _TAIL * (1.0 + z[None, :])
        total[split] += 0.5 * _TAIL * ((xs**n * np.exp(-0.5 * (xs - cs) ** 2)) @ wl)
    return np.log(total) - _LN_SQRT_2PI


def _log_F_exact(n: float, t: np.ndarray) -> np.ndarray:
    """``ln F_n(t)`` for finite t (1-D array) with ``t <= t_zero``; exact to rounding."""
    out = np.empty_like(t)
    lo = t < _T_LOW
    hi = t >= _T_LAGUERRE + 0.05 * n  # the Laguerre rule needs t >~ 2 + n/20 (measured)
    mid = ~(lo | hi)
    if lo.any():
        out[lo] = _log_moment_series(n, t[lo])
    if mid.any():
        out[mid] = _log_jacobi(n, t[mid])
    if hi.any():
        out[hi] = _log_laguerre(n, t[hi])
    return out


@lru_cache(maxsize=64)
def _t_zero(n: float) -> float:
    """Where ``F_n`` falls below the smallest float: above it ``F_n = 0``."""
    from scipy.optimize import brentq

    return float(brentq(lambda s: _log_laguerre(n, np.array([s]))[0] - _LN_TINY, 20.0, 60.0,
                        xtol=1e-12))


def _finish(n: float, t: np.ndarray, log_f: np.ndarray, where: np.ndarray,
            out: np.ndarray) -> None:
    """exp into ``out[where]`` with an overflow check."""
    if log_f.size and np.max(log_f) > _LN_MAX:
        bad = t[where][np.argmax(log_f)]
        raise FnOverflowError(f"F_{n:g}({bad:.6g}) exceeds the largest float64")
    out[where] = np.exp(log_f)


def _evaluate(n: float, t, log_inside) -> np.ndarray:
    """Common driver: NaN propagates, 0 above t_zero, moment series below -12."""
    t = np.asarray(t, dtype=float)
    flat = t.ravel()
    out = np.empty_like(flat)
    t0 = _t_zero(n)
    nan = np.isnan(flat)
    zero = flat >= t0
    low = flat < _T_LOW
    inside = ~(nan | zero | low)
    out[nan] = np.nan
    out[zero] = 0.0
    if low.any():
        _finish(n, flat, _log_moment_series(n, flat[low]), low, out)
    if inside.any():
        _finish(n, flat, log_inside(flat[inside]), inside, out)
    return out.reshape(t.shape)


def F_n_exact(n: float, t: np.ndarray | float) -> np.ndarray:
    """``F_n(t)`` (Eq. 5.43) exact to rounding; the reference for :func:`F_n`.

    Gauss–Laguerre (t >= 2), Gauss–Jacobi/Legendre (-12 <= t < 2) and the moment
    series (t < -12), see the module docstring.  About 1 us per point; use
    :func:`F_n` in computations.

    Parameters
    ----------
    n
        Order, 0 <= n <= 20 (3/2 elastic, 4 plastic).
    t
        Argument ``h/psi``, any shape.

    Returns
    -------
    numpy.ndarray
        ``F_n(t)``, same shape as ``t``; >= 0, 0 where it underflows.

    Raises
    ------
    FnOverflowError
        If ``F_n(t)`` exceeds the largest float64 (``t`` hugely negative).
    """
    n = _check_n(n)
    return _evaluate(n, t, lambda s: _log_F_exact(n, s))


def F_n_pbdv(n: float, t: np.ndarray | float) -> np.ndarray:
    """``F_n(t) = Gamma(n+1)/sqrt(2 pi) exp(-t^2/4) D_-(n+1)(t)`` with ``scipy.special.pbdv``.

    The textbook exact form, kept for the benchmark ("raw pbdv").  Valid for
    -53 < t < 38; inaccurate for non-integer ``n`` near |t| = 6 (see the module
    docstring).  Not used by torlab's computations.
    """
    from scipy.special import gamma, pbdv

    n = _check_n(n)
    t = np.asarray(t, dtype=float)
    d, _ = pbdv(-(n + 1.0), t)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        return gamma(n + 1.0) / _SQRT_2PI * np.exp(-0.25 * t * t) * d


def F_n_thesis_quadrature(n: float, t: np.ndarray | float, upper: float = 30.0,
                          steps: int = 1000) -> np.ndarray:
    """The thesis's numerical ``F_n`` (5.2.4): upper bound 30, 1000 steps.

    Trapezoidal rule on ``steps + 1`` equally spaced nodes from ``t`` to ``upper``
    of ``(s - t)^n exp(-s^2/2) / sqrt(2 pi)``; 0 for ``t >= upper``.  The baseline
    of the benchmark, vectorised over ``t`` (in blocks, to bound memory).
    """
    n = _check_n(n)
    t = np.asarray(t, dtype=float)
    flat = t.ravel()
    out = np.zeros_like(flat)
    k = np.linspace(0.0, 1.0, steps + 1)
    wts = np.full(steps + 1, 1.0)
    wts[0] = wts[-1] = 0.5
    block = max(1, 2_000_000 // (steps + 1))
    for i in range(0, flat.size, block):
        tb = flat[i:i + block]
        tb = np.where(tb < upper, tb, upper)
        step = (upper - tb) / steps
        x = step[:, None] * (k[None, :] * steps)  # s - t
        s = tb[:, None] + x
        vals = x**n * np.exp(-0.5 * s * s)
        out[i:i + block] = step * (vals @ wts) / _SQRT_2PI
    return out.reshape(t.shape)


# ----------------------------------------------------------------------------------------
# the fast default: piecewise Chebyshev interpolant of ln F_n
# ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Table:
    t_low: float
    t_zero: float
    inv_width: float
    pieces: int
    coefs: tuple[np.ndarray, ...]  # coefs[k][piece]: monomial coefficient of u^k
    rows: tuple[tuple[float, ...], ...]  # rows[piece]: the same, highest power first


@lru_cache(maxsize=64)
def _table(n: float) -> _Table:
    from numpy.polynomial import chebyshev as C

    t0 = _t_zero(n)
    pieces = math.ceil((t0 - _T_LOW) / _PIECE)
    nodes = np.cos(np.pi * (np.arange(_DEGREE + 1) + 0.5) / (_DEGREE + 1))  # Chebyshev points
    left = _T_LOW + _PIECE * np.arange(pieces)
    tt = left[:, None] + 0.5 * _PIECE * (nodes[None, :] + 1.0)
    vals = _log_F_exact(n, tt.ravel()).reshape(tt.shape)
    vander = C.chebvander(nodes, _DEGREE)
    cheb = np.linalg.solve(vander, vals.T)  # (degree+1, pieces)
    to_mono = np.zeros((_DEGREE + 1, _DEGREE + 1))  # column k: T_k in the monomial basis
    for k in range(_DEGREE + 1):
        col = C.cheb2poly(np.eye(_DEGREE + 1)[k])
        to_mono[: col.size, k] = col
    mono = to_mono @ cheb  # (degree+1, pieces)
    return _Table(_T_LOW, t0, 1.0 / _PIECE, pieces,
                  tuple(np.ascontiguousarray(mono[k]) for k in range(_DEGREE + 1)),
                  tuple(tuple(float(c) for c in mono[::-1, j]) for j in range(pieces)))


def _interp_scalar(tab: _Table, t: float) -> float:
    """Interpolated ``ln F_n`` at one t in [t_low, t_zero), plain Python."""
    x = (t - tab.t_low) * tab.inv_width
    i = min(int(x), tab.pieces - 1)
    u = 2.0 * (x - i) - 1.0
    acc = 0.0
    for c in tab.rows[i]:
        acc = acc * u + c
    return acc


def _log_F_interp(tab: _Table, t: np.ndarray) -> np.ndarray:
    """Interpolated ``ln F_n`` for t in [t_low, t_zero) (1-D)."""
    if t.size <= 4:  # numpy's per-call overhead dominates tiny arrays
        return np.array([_interp_scalar(tab, x) for x in t.tolist()])
    x = (t - tab.t_low) * tab.inv_width
    idx = x.astype(np.intp)
    np.minimum(idx, tab.pieces - 1, out=idx)
    u = 2.0 * (x - idx) - 1.0
    c = tab.coefs
    acc = c[-1][idx]
    for ck in c[-2::-1]:
        acc *= u
        acc += ck[idx]
    return acc


def _log_F_scalar(tab: _Table, n: float, t: float) -> float:
    """``ln F_n(t)`` for one finite ``t < t_zero`` in plain Python (root finders call this)."""
    if t < tab.t_low:
        return float(_log_moment_series(n, np.array([t]))[0])
    return _interp_scalar(tab, t)


def _log_F_fast(tab: _Table, n: float, t: np.ndarray | float) -> np.ndarray | float:
    """``ln F_n`` for finite ``t < t_zero`` (interpolant, moment series below t_low)."""
    if np.ndim(t) == 0 and not isinstance(t, np.ndarray):
        return _log_F_scalar(tab, n, float(t))
    t = np.asarray(t, dtype=float)
    flat = t.ravel()
    low = flat < tab.t_low
    if not low.any():
        return _log_F_interp(tab, flat).reshape(t.shape)
    out = np.empty_like(flat)
    out[low] = _log_moment_series(n, flat[low])
    out[~low] = _log_F_interp(tab, flat[~low])
    return out.reshape(t.shape)


def _F_scalar(tab: _Table, n: float, t: float) -> float:
    if t != t:
        return math.nan
    if t >= tab.t_zero:
        return 0.0
    lf = _log_F_scalar(tab, n, t)
    if lf > _LN_MAX:
        raise FnOverflowError(f"F_{n:g}({t:.6g}) exceeds the largest float64")
    return math.exp(lf)


def F_n(n: float, t: np.ndarray | float) -> np.ndarray:
    """``F_n(t)`` of Greenwood–Williamson (Eq. 5.43), fast and accurate; torlab's default.

    ``F_n(t) = (1/sqrt(2 pi)) int_t^inf (s - t)^n exp(-s^2/2) ds``, vectorised over
    ``t``.  A cached piecewise Chebyshev interpolant of ``ln F_n`` built from
    :func:`F_n_exact` (relative error <= 7e-14 for t <= 12, <= 7e-13 up to the
    underflow point; measured in ``torlab.bench.asperity`` and tested against
    mpmath), the moment series for t < -12 and exactly 0 above the underflow
    point (t ~ 38.6).

    Parameters
    ----------
    n
        Order, 0 <= n <= 20 (3/2: elastic, 4: plastic model).
    t
        Argument ``h/psi`` (any shape).

    Returns
    -------
    numpy.ndarray or float
        ``F_n(t)`` (>= 0, finite; NaN where ``t`` is NaN), shape of ``t``; a
        ``float`` for a scalar (non-array) ``t`` (a plain-Python path, ~20x
        cheaper per call, for root finders).

    Raises
    ------
    FnOverflowError
        If ``F_n(t)`` exceeds the largest float64 (``t`` hugely negative).
    """
    n = _check_n(n)
    tab = _table(n)
    if np.ndim(t) == 0 and not isinstance(t, np.ndarray):
        return _F_scalar(tab, n, float(t))
    t = np.asarray(t, dtype=float)
    flat = t.ravel()
    # fast path: everything inside the interpolated range (the common case)
    if flat.size and flat.min() >= tab.t_low and flat.max() < tab.t_zero:
        return np.exp(_log_F_interp(tab, flat)).reshape(t.shape)
    return _evaluate(n, t, lambda s: _log_F_interp(tab, s))


def bracketed_root(f, lo: np.ndarray, hi: np.ndarray, args: tuple = (), *,
                   xrtol: float = 4 * np.finfo(float).eps, xatol: float = 1e-300,
                   fatol: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Roots of the elementwise, monotone ``f(x, *args)`` in brackets ``[lo, hi]``.

    A shared helper of the model modules: ``scipy.optimize.brentq`` per element for
    up to 8 problems (its per-call cost is ~50x lower), otherwise the vectorised
    Chandrupatla method ``scipy.optimize.elementwise.find_root``.  Both stay in
    the bracket.  ``f`` must accept arrays and (brentq path) Python floats; ``args``
    are arrays shaped like ``lo``.

    Returns
    -------
    tuple
        ``(x, iterations, evaluations, converged)`` arrays shaped like ``lo``.
    """
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    args = tuple(np.broadcast_to(np.asarray(a, dtype=float), lo.shape) for a in args)
    if lo.size <= 8:
        from scipy.optimize import brentq

        x = np.empty(lo.shape)
        nit = np.zeros(lo.shape, dtype=int)
        nfev = np.zeros(lo.shape, dtype=int)
        ok = np.zeros(lo.shape, dtype=bool)
        for i in np.ndindex(lo.shape):
            a_i = tuple(float(a[i]) for a in args)

            def g(xx: float, a_i=a_i) -> float:
                return float(f(xx, *a_i))

            r, info = brentq(g, float(lo[i]), float(hi[i]), xtol=max(xatol, 1e-300),
                             rtol=max(xrtol, 4 * np.finfo(float).eps), full_output=True,
                             disp=False)
            x[i], nit[i], nfev[i], ok[i] = r, info.iterations, info.function_calls, info.converged
        return x, nit, nfev, ok
    from scipy.optimize.elementwise import find_root

    res = find_root(f, (lo, hi), args=args,
                    tolerances={"xrtol": xrtol, "xatol": xatol, "fatol": fatol})
    return res.x, np.asarray(res.nit), np.asarray(res.nfev), np.asarray(res.success)


def F_n_inverse(n: float, y: np.ndarray | float) -> np.ndarray:
    """The ``t`` with ``F_n(t) = y`` (``F_n`` is strictly decreasing for n > 0).

    Bracketed root of ``ln F_n(t) - ln y`` (:func:`bracketed_root`), vectorised
    over ``y``.

    Parameters
    ----------
    n
        Order, 0 <= n <= 20.
    y
        Target values, > 0 (and < 1 for ``n = 0``, since ``F_0 = Q < 1``).  Values
        below the smallest float ``F_n`` reaches return the underflow point.

    Returns
    -------
    numpy.ndarray
        ``t`` (shape of ``y``), accurate to a few ulp of ``ln F_n``.
    """
    n = _check_n(n)
    y = np.asarray(y, dtype=float)
    if not np.all(np.isfinite(y)) or np.any(y <= 0):
        raise ValueError("F_n_inverse: y must be finite and > 0")
    if n == 0 and np.any(y >= 1):
        raise ValueError("F_n_inverse: F_0 = Q(t) < 1, y must be < 1")
    tab = _table(n)
    ly = np.log(y)

    def log_f(s: np.ndarray) -> np.ndarray:
        return _log_F_fast(tab, n, s)

    # bracket: widen the lower end by doubling until ln F_n(lo) >= ln y (log space:
    # no overflow, F_n ~ |t|^n); the upper end is just below the underflow point
    lo = np.full(y.shape, -1.0)
    for _ in range(1100):
        need = log_f(lo) < ly
        if not need.any():
            break
        lo = np.where(need, 2.0 * lo, lo)
    hi = np.full(y.shape, tab.t_zero * (1.0 - 1e-12))
    under = ly <= log_f(hi)
    out = hi.copy()
    solve = ~under
    if solve.any():
        x, _, _, ok = bracketed_root(lambda s, ly_: log_f(s) - ly_, lo[solve], hi[solve],
                                     (ly[solve],), xatol=1e-15)
        if not np.all(ok):  # pragma: no cover - a valid bracket always converges
            raise NumericalError("F_n_inverse: the bracketed root did not converge")
        out[solve] = x
    return out


# ----------------------------------------------------------------------------------------
# Greenwood–Williamson pressure
# ----------------------------------------------------------------------------------------

def _positive(value: float, name: str, unit: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise TorlabInputError(f"must be a positive number ({unit}), got {value!r}", key=name)
    return v


def roughness_K(sigma: float, beta: float, gamma: float) -> float:
    """Roughness parameter ``K = psi beta gamma`` (thesis 5.2.4; docs/model/thesis-reading.md).

    Parameters
    ----------
    sigma
        Asperity height standard deviation ``psi`` [m].
    beta
        Asperity tip radius [m].
    gamma
        Asperity density [1/m^2].
    """
    return (_positive(sigma, "roughness.sigma", "m") * _positive(beta, "roughness.beta", "m")
            * _positive(gamma, "roughness.density", "1/m^2"))


def p_a_elastic(h: np.ndarray | float, sigma: float, beta: float, gamma: float,
                E_star: float) -> np.ndarray:
    """Elastic (Greenwood–Williamson) asperity pressure, consistent form of Eq. 5.41 [Pa].

    ``p_a = (4/3) K E* sqrt(psi/beta) F_3/2(h/psi)`` with ``K = psi beta gamma``
    (docs/model/thesis-reading.md; why not the printed ``K/2`` and ``sqrt(psi/gamma)``:
    module docstring).

    Parameters
    ----------
    h
        Separation of the mean planes [m], any shape; may be negative.
    sigma, beta, gamma
        ``psi`` [m], tip radius [m], density [1/m^2].
    E_star
        Contact modulus ``E*`` [Pa], ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2``.
    """
    return Roughness(sigma, beta, gamma, model="elastic").asperity_model(E_star=E_star).pressure(h)


def p_a_plastic(h: np.ndarray | float, sigma: float, beta: float, gamma: float,
                H: float) -> np.ndarray:
    """Plastic asperity pressure ``(2/3) pi^2 H K^2 F_4(h/psi)`` (Eq. 5.42), Pa.

    Parameters
    ----------
    h
        Separation of the mean planes [m], any shape.
    sigma, beta, gamma
        ``psi`` [m], tip radius [m], density [1/m^2].
    H
        Hardness [Pa], about 6 x the yield shear stress (Paper A: 6 GPa).
    """
    return Roughness(sigma, beta, gamma, model="plastic", hardness=H).asperity_model().pressure(h)


@dataclass(frozen=True)
class AsperityModel:
    """``p_a(h) = coefficient * F_n(h / sigma)``: the form both asperity models share.

    Built by :meth:`Roughness.asperity_model`.

    Attributes
    ----------
    n
        Order of ``F_n`` (3/2 elastic, 4 plastic).
    coefficient
        Pressure scale [Pa]: ``(4/3) K E* sqrt(psi/beta)`` or ``(2/3) pi^2 H K^2``.
    sigma
        ``psi`` [m].
    model
        ``"elastic"`` or ``"plastic"``.
    """

    n: float
    coefficient: float
    sigma: float
    model: str

    def pressure(self, h: np.ndarray | float) -> np.ndarray:
        """Mean asperity pressure ``p_a(h)`` [Pa], Eq. 5.41/5.42."""
        return self.coefficient * F_n(self.n, np.asarray(h, dtype=float) / self.sigma)

    def load(self, h: np.ndarray | float, a: float, b: float) -> np.ndarray:
        """Asperity load ``F_BL = p_a(h) pi a b`` (N; docs/model/thesis-reading.md)."""
        return self.pressure(h) * (math.pi * a * b)

    def h_star(self, F: float, a: float, b: float) -> float:
        """Separation at which the asperities carry the whole load: :func:`h_star`."""
        return h_star(F, a, b, self)


@dataclass(frozen=True)
class Roughness:
    """Surface roughness (the scene's ``roughness:`` section), SI units.

    Attributes
    ----------
    sigma
        Asperity height standard deviation ``psi`` [m], > 0.
    beta
        Asperity tip radius [m], > 0.
    density
        Asperity density ``gamma`` [1/m^2], > 0.
    model
        ``"elastic"`` (Eq. 5.41) or ``"plastic"`` (Eq. 5.42).
    hardness
        ``H`` [Pa], required for the plastic model.
    """

    sigma: float
    beta: float
    density: float
    model: str = "plastic"
    hardness: float | None = None

    def __post_init__(self) -> None:
        roughness_K(self.sigma, self.beta, self.density)  # validates the three
        if self.model not in ("elastic", "plastic"):
            raise TorlabInputError(f"unknown asperity model {self.model!r} (elastic | plastic)",
                                   key="roughness.model")
        if self.model == "plastic":
            if self.hardness is None:
                raise TorlabInputError("the plastic asperity model needs the hardness H",
                                       key="roughness.hardness")
            _positive(self.hardness, "roughness.hardness", "Pa")

    @property
    def K(self) -> float:
        """``K = psi beta gamma`` (-)."""
        return roughness_K(self.sigma, self.beta, self.density)

    def asperity_model(self, E_star: float | None = None) -> AsperityModel:
        """The pressure law ``p_a = c F_n(h/psi)`` for this roughness.

        Parameters
        ----------
        E_star
            Contact modulus [Pa], required by the elastic model.
        """
        if self.model == "elastic":
            if E_star is None:
                raise TorlabInputError("the elastic asperity model needs the contact modulus E*",
                                       key="materials")
            E = _positive(E_star, "materials.E_star", "Pa")
            c = 4.0 / 3.0 * self.K * E * math.sqrt(self.sigma / self.beta)
            return AsperityModel(1.5, c, float(self.sigma), "elastic")
        c = 2.0 / 3.0 * math.pi**2 * float(self.hardness) * self.K**2
        return AsperityModel(4.0, c, float(self.sigma), "plastic")


def h_star(F: float, a: float, b: float, model: AsperityModel) -> float:
    """Separation ``h*`` at which the asperities carry the whole load, ``F_BL(h*) = F``.

    ``p_a(h*) pi a b = F`` solved by a bracketed root on the monotone ``F_n``
    (:func:`F_n_inverse`).  May be negative (the asperities of a smooth or soft
    surface cannot carry the load before the mean planes cross).

    Parameters
    ----------
    F
        Normal load [N], > 0.
    a, b
        Contact semi-axes [m].
    model
        Asperity pressure law.

    Returns
    -------
    float
        ``h*`` [m].
    """
    F = _positive(F, "contact.load", "N")
    a = _positive(a, "contact.a", "m")
    b = _positive(b, "contact.b", "m")
    target = F / (math.pi * a * b * model.coefficient)
    return float(F_n_inverse(model.n, target)) * model.sigma
