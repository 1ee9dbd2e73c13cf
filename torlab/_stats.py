"""Student t, normal and F distribution functions, and the AR(1) recursion, without loading
``scipy.stats`` or ``scipy.signal``.

``scipy.stats`` and ``scipy.signal`` (which imports ``scipy.stats``) take 1-3 s to import
on a busy 2-core machine -- longer than a whole HPT fit -- although torlab needs only a
few of their functions.  These are the functions ``scipy.stats`` itself evaluates
(``t.ppf`` is ``scipy.special.stdtrit``, ``norm.cdf`` is ``ndtr`` ...), called directly,
for the arguments torlab passes (probabilities strictly between 0 and 1, degrees of
freedom > 0); and the first-order recursion ``scipy.signal.lfilter([1], [1, -rho], x)``
computes, as a loop over the rows of the small matrices of a fit's noise model.
``tests/test_stats.py`` compares every one with scipy's, bit for bit.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["ar1_recursion", "chi2_sf", "f_sf", "norm_cdf", "norm_ppf", "t_cdf", "t_ppf"]


def t_ppf(q: Any, df: Any) -> Any:
    """Student t quantile: ``scipy.stats.t.ppf(q, df)`` (``scipy.special.stdtrit``)."""
    from scipy.special import stdtrit

    return stdtrit(df, q)


def t_cdf(x: Any, df: Any) -> Any:
    """Student t distribution function: ``scipy.stats.t.cdf(x, df)`` (``stdtr``)."""
    from scipy.special import stdtr

    return stdtr(df, x)


def norm_ppf(q: Any) -> Any:
    """Standard normal quantile: ``scipy.stats.norm.ppf(q)`` (``ndtri``)."""
    from scipy.special import ndtri

    return ndtri(q)


def norm_cdf(x: Any) -> Any:
    """Standard normal distribution function: ``scipy.stats.norm.cdf(x)`` (``ndtr``)."""
    from scipy.special import ndtr

    return ndtr(x)


def f_sf(x: Any, dfn: Any, dfd: Any) -> Any:
    """Survival function of the F distribution: ``scipy.stats.f.sf(x, dfn, dfd)`` (``fdtrc``)."""
    from scipy.special import fdtrc

    return fdtrc(dfn, dfd, x)


def chi2_sf(x: Any, df: Any) -> Any:
    """Survival function of the chi-squared distribution: ``scipy.stats.chi2.sf(x, df)``
    (``chdtrc``)."""
    from scipy.special import chdtrc

    return chdtrc(df, x)


def ar1_recursion(x: Any, rho: float) -> np.ndarray:
    """``y[t] = x[t] + rho y[t-1]`` along the first axis (``y[0] = x[0]``).

    What ``scipy.signal.lfilter([1.0], [1.0, -rho], x, axis=0)`` computes (to round-off:
    1e-13 relative), as the forward substitution of the unit lower-bidiagonal system
    ``y[t] - rho y[t-1] = x[t]`` (LAPACK's banded solver, ``scipy.linalg.solve_banded``):
    compiled, about ten times faster than a loop over the rows, and without importing
    ``scipy.signal``.  torlab applies it to a fit's Jacobian (hundreds to a few thousand
    rows, a handful of columns).
    """
    from scipy.linalg import solve_banded

    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    if n == 0:
        return x.copy()
    ab = np.empty((2, n))
    ab[0] = 1.0
    ab[1] = -float(rho)
    return solve_banded((1, 0), ab, x, check_finite=False)
