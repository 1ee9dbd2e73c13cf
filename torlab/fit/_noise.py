"""Residual noise models for the fit uncertainties (shared by the layer fits).

A long record such as an HPT curve (800 points at 2 Hz) has residuals that are
neither independent nor of constant size: the layer's strength fluctuates
slowly (seconds) and in proportion to the stress.  ``s^2 (J^T J)^-1`` then
understates the uncertainty several times, and a kernel (Newey-West) estimate
cannot see a fluctuation that is longer than the few points of the elastic
branch.  We therefore estimate a small parametric noise model from the
residuals and propagate it exactly:

``r_t = scale_t (w_t + c_t)``, ``w`` white with variance ``v_w``, ``c`` a
stationary AR(1) (sampled Ornstein-Uhlenbeck) with variance ``v_c`` and lag-1
correlation ``rho``; ``scale_t`` is the model's stress (relative noise).  A
force transducer also has an absolute noise floor ``a`` that dominates at low
stress (the standstill before the motion, the elastic branch of a
low-friction layer): the white variance of row ``t`` is
``a^2 + max(v_w - a^2/S^2, 0) scale_t^2`` with ``S`` the median scale of the
high-stress part, so it is ``a^2`` at zero stress and ``v_w scale^2`` where
``v_w`` was measured; ``a^2`` is the mean square residual of the rows below
5 % of the largest stress.  The AR(1) parameters are
parameters are the Whittle maximum-likelihood estimate from the periodogram
``I_j`` of the relative residuals ``z = r/scale`` on the high-stress part of
the record: minimise ``sum_j ln f_j + I_j / f_j`` with the spectral density
``f(w) = v_w + v_c (1 - rho^2) / (1 - 2 rho cos w + rho^2)`` (Whittle 1953;
Brockwell & Davis, *Time Series: Theory and Methods*, 2nd ed., section 10.8).
Its asymptotic covariance is ``(sum_j g_j g_j^T)^-1`` with ``g_j`` the gradient
of ``ln f_j``, because ``I_j / f_j`` is nearly exponential with unit variance.

The parameter covariance of the least-squares estimate is the sandwich
``B J^T Sigma J B`` with ``B = (J^T J)^-1``, scaled by ``n_eff / (n_eff - k)``
for the ``k`` fitted parameters (the correlated analogue of dividing the
residual sum of squares by ``n - k``).  A short record determines its own
noise level only roughly (an HPT plateau spans some 20 correlation times), so
each parameter's Student-t interval gets its own Satterthwaite degrees of
freedom ``nu = 2 / var(ln sigma_j^2)``, with ``var(ln sigma_j^2)`` propagated
from the covariance of the noise-model estimate; ``nu`` never exceeds
``n_eff - k``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from torlab.fit.result import _scaled_inverse

__all__ = ["BlockMeat", "NoiseModel", "VarianceFunction", "block_meats", "effective_points",
           "estimate_noise", "estimate_variance_function", "parameter_dof",
           "sandwich_covariance"]

#: fewest points of the stationary part for a correlated-noise model
MIN_POINTS_CORRELATED = 40
#: fewest low-stress rows for an absolute noise floor
MIN_POINTS_FLOOR = 5
#: chi-square(2) 99 % quantile: the AR(1) part must beat white noise by this much
LR_CRITICAL = 9.21
#: largest lag-1 correlation of the AR(1) part
RHO_MAX = 0.9995


@dataclass(frozen=True)
class NoiseModel:
    """Relative white + AR(1) residual noise (see module docstring).

    ``theta_cov`` is the covariance of the estimate of
    ``(ln v_w, ln v_c, logit rho)`` (empty when the model is white noise; then
    ``n_used`` points determine ``v_w``).
    """

    white_var: float
    correlated_var: float
    rho: float
    kind: str = "relative white + AR(1)"
    n_used: int = 0
    floor_var: float = 0.0
    floor_ref: float = 1.0
    theta_cov: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False,
                                  compare=False)

    @property
    def relative_sd(self) -> float:
        """Total relative standard deviation of the residuals."""
        return math.sqrt(self.white_var + self.correlated_var)

    @property
    def correlated(self) -> bool:
        """Whether the model has an AR(1) part."""
        return self.correlated_var > 0 and self.rho > 0

    def effective_points(self, n: int) -> float:
        """Independent-equivalent number of points of a record of ``n``."""
        tot = self.white_var + self.correlated_var
        if tot <= 0 or self.rho <= 0:
            return float(n)
        infl = 1.0 + 2.0 * self.correlated_var / tot * self.rho / (1.0 - self.rho)
        return n / infl

    def with_theta(self, theta: np.ndarray) -> NoiseModel:
        """The model at ``(ln v_w, ln v_c, logit rho)`` (for derivatives)."""
        lvw, lvc, a = (float(v) for v in theta)
        return replace(self, white_var=math.exp(lvw), correlated_var=math.exp(lvc),
                       rho=1.0 / (1.0 + math.exp(-a)))

    def white_row_var(self, scale: np.ndarray) -> np.ndarray:
        """White variance of each row (absolute floor + relative part)."""
        rel = max(self.white_var - self.floor_var / self.floor_ref**2, 0.0)
        return self.floor_var + rel * np.asarray(scale, dtype=float) ** 2

    @property
    def theta(self) -> np.ndarray:
        """``(ln v_w, ln v_c, logit rho)`` of a correlated model."""
        return np.array([math.log(self.white_var), math.log(self.correlated_var),
                         math.log(self.rho / (1.0 - self.rho))])

    def as_dict(self) -> dict[str, float | str]:
        """For the provenance."""
        return {"noise_model": self.kind, "noise_white_relative_sd": math.sqrt(self.white_var),
                "noise_floor_sd": math.sqrt(self.floor_var),
                "noise_correlated_relative_sd": math.sqrt(self.correlated_var),
                "noise_lag1_correlation": self.rho}


def _log_spectrum(theta: np.ndarray, cosw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``ln f_j`` and its gradient (3, m) in ``(ln v_w, ln v_c, logit rho)``."""
    vw, vc = math.exp(theta[0]), math.exp(theta[1])
    rho = 1.0 / (1.0 + math.exp(-theta[2]))
    d = 1.0 - 2.0 * rho * cosw + rho * rho
    q = (1.0 - rho * rho) / d
    dq = (-2.0 * rho * d - (1.0 - rho * rho) * (2.0 * rho - 2.0 * cosw)) / (d * d)
    f = vw + vc * q
    grad = np.stack([np.full_like(f, vw), vc * q, vc * dq * rho * (1.0 - rho)]) / f
    return np.log(f), grad


def estimate_noise(residuals: np.ndarray, scale: np.ndarray) -> NoiseModel:
    """Whittle estimate of :class:`NoiseModel` from the residuals (module docstring).

    Parameters
    ----------
    residuals
        Residuals in record order.
    scale
        Positive scale of each residual (the model's stress).

    Notes
    -----
    With fewer than :data:`MIN_POINTS_CORRELATED` points at high stress, or
    when the AR(1) part is negligible, the model is white noise with the
    relative variance of the residuals.
    """
    from scipy.optimize import minimize

    r = np.asarray(residuals, dtype=float)
    s = np.asarray(scale, dtype=float)
    sel = s >= 0.5 * np.max(s)
    z = r[sel] / s[sel]
    n = z.size
    low = s <= 0.05 * np.max(s)
    floor = float(np.mean(r[low] ** 2)) if np.count_nonzero(low) >= MIN_POINTS_FLOOR else 0.0
    ref = float(np.median(s[sel]))
    if n < MIN_POINTS_CORRELATED:
        zz = r / s
        return NoiseModel(float(np.mean(zz * zz)), 0.0, 0.0, kind="relative white", n_used=r.size)
    tot = float(np.mean(z * z))
    if tot <= 0:
        return NoiseModel(0.0, 0.0, 0.0, kind="none (exact fit)", n_used=n)
    zc = z - z.mean()
    m = (n - 1) // 2  # Fourier frequencies strictly between 0 and pi
    per = (np.abs(np.fft.rfft(zc)[1:m + 1]) ** 2) / n
    cosw = np.cos(2.0 * np.pi * np.arange(1, m + 1) / n)

    def whittle(theta: np.ndarray) -> tuple[float, np.ndarray]:
        lf, g = _log_spectrum(theta, cosw)
        u = per * np.exp(-lf)
        return float(np.sum(lf + u)), g @ (1.0 - u)

    a_max = math.log(RHO_MAX / (1.0 - RHO_MAX))
    lo, hi = math.log(tot) - 30.0, math.log(tot) + 5.0
    bounds = [(lo, hi), (lo, hi), (-10.0, a_max)]
    best = None
    for rho0 in (0.5, 0.95):  # the likelihood can have a local minimum in rho
        x0 = np.array([math.log(0.3 * tot), math.log(0.7 * tot), math.log(rho0 / (1.0 - rho0))])
        sol = minimize(whittle, x0, jac=True, method="L-BFGS-B", bounds=bounds)
        if best is None or sol.fun < best.fun:
            best = sol
    theta = np.asarray(best.x, dtype=float)
    vw, vc = math.exp(theta[0]), math.exp(theta[1])
    rho = 1.0 / (1.0 + math.exp(-theta[2]))
    # keep the AR(1) part only where it explains the spectrum: likelihood-ratio test
    # against white noise (2 extra parameters, 1 % level; a tiny near-unit-root
    # component fitted to the periodogram's scatter would otherwise cut n_eff)
    white_nll = float(np.sum(np.log(tot) + per / tot))
    if 2.0 * (white_nll - float(best.fun)) < LR_CRITICAL or rho <= 1e-3:
        return NoiseModel(tot, 0.0, 0.0, kind="relative white", n_used=n, floor_var=floor,
                          floor_ref=ref)
    # Whittle information: sum_j grad(ln f_j) grad(ln f_j)^T
    grads = _log_spectrum(theta, cosw)[1]
    info = grads @ grads.T
    cov = np.linalg.pinv(info)
    return NoiseModel(vw, vc, rho, n_used=n, theta_cov=cov, floor_var=floor, floor_ref=ref)


class BlockMeat:
    """``J^T Sigma J`` of one block (rows ``J``, scales ``scale``) for any noise model of it.

    ``Sigma`` is a white part (:meth:`NoiseModel.white_row_var`) plus ``v_c`` times the
    AR(1) correlation at ``rho``; each part is kept by the values it depends on, so the
    noise models of :func:`parameter_dof`'s differences (which change one of ``v_w``,
    ``v_c``, ``rho`` at a time) reuse the others' parts: the same numbers, from the same
    operations, in half the AR(1) recursions.
    """

    def __init__(self, J: np.ndarray, scale: np.ndarray) -> None:
        self.J = J
        self.scale = np.asarray(scale, dtype=float)
        self.sj = J * self.scale[:, None]
        self._white: dict[tuple[float, float, float], np.ndarray] = {}
        self._ar: dict[float, np.ndarray] = {}

    def __call__(self, nm: NoiseModel) -> np.ndarray:
        key = (nm.white_var, nm.floor_var, nm.floor_ref)
        meat = self._white.get(key)
        if meat is None:
            meat = (self.J * nm.white_row_var(self.scale)[:, None]).T @ self.J
            self._white[key] = meat
        if not nm.correlated:
            return meat
        ar = self._ar.get(nm.rho)
        if ar is None:
            # AR(1) covariance applied by a forward and a backward recursion (O(n k))
            from torlab._stats import ar1_recursion  # scipy.signal.lfilter, without its import

            sj = self.sj
            fwd = ar1_recursion(sj, nm.rho)
            bwd = ar1_recursion(sj[::-1], nm.rho)[::-1]
            # sum_{s,t} rho^|s-t| a_s a_t^T = sum_t a_t (fwd_t + bwd_t - a_t)^T
            ar = sj.T @ (fwd + bwd - sj)
            self._ar[nm.rho] = ar
        return meat + nm.correlated_var * ar


def _meat(J: np.ndarray, scale: np.ndarray, nm: NoiseModel) -> np.ndarray:
    """``J^T Sigma J`` of one block."""
    return BlockMeat(J, scale)(nm)


def block_meats(jac: np.ndarray, blocks: list[tuple[slice, np.ndarray, NoiseModel]]
                ) -> list[BlockMeat]:
    """One :class:`BlockMeat` per block, for :func:`sandwich_covariance` and
    :func:`parameter_dof` of one fit to share."""
    return [BlockMeat(jac[rows], scale) for rows, scale, _ in blocks]


def effective_points(blocks: list[tuple[slice, np.ndarray, NoiseModel]]) -> float:
    """Independent-equivalent number of points of all blocks together."""
    return float(sum(nm.effective_points(rows.stop - rows.start) for rows, _, nm in blocks))


def sandwich_covariance(jac: np.ndarray, blocks: list[tuple[slice, np.ndarray, NoiseModel]],
                        parts: list[BlockMeat] | None = None) -> np.ndarray:
    """``n_eff/(n_eff - k) B J^T Sigma J B`` with ``Sigma`` block diagonal, one
    :class:`NoiseModel` per block.

    ``blocks`` lists ``(rows, scale, model)``; rows of different blocks (curves)
    are independent.  ``parts``: the blocks' :func:`block_meats` (made here if not given).
    """
    k = jac.shape[1]
    parts = block_meats(jac, blocks) if parts is None else parts
    meat = sum((part(nm) for part, (_, _, nm) in zip(parts, blocks, strict=True)),
               np.zeros((k, k)))
    bread = _scaled_inverse(jac.T @ jac)
    if not np.all(np.isfinite(bread)):
        return bread
    neff = effective_points(blocks)
    out = bread @ meat @ bread * (neff / max(neff - k, 1.0))
    return 0.5 * (out + out.T)


def parameter_dof(jac: np.ndarray, blocks: list[tuple[slice, np.ndarray, NoiseModel]],
                  parts: list[BlockMeat] | None = None) -> np.ndarray:
    """Satterthwaite degrees of freedom of each parameter's variance (module docstring).

    ``nu_j = 2 / var(ln sigma_j^2)``: for a white-noise block the variance of
    ``ln v_w`` is ``2/n``; for an AR(1) block the Whittle covariance of the
    noise parameters is propagated through ``ln sigma_j^2`` by central
    differences.  Capped at ``n_eff - k`` and floored at 1.  ``parts``: the blocks'
    :func:`block_meats` (made here if not given; shared with
    :func:`sandwich_covariance`).
    """
    k = jac.shape[1]
    neff = effective_points(blocks)
    cap = max(neff - k, 1.0)
    bread = _scaled_inverse(jac.T @ jac)
    if not np.all(np.isfinite(bread)):
        return np.full(k, cap)
    parts = block_meats(jac, blocks) if parts is None else parts
    meats = [part(nm) for part, (_, _, nm) in zip(parts, blocks, strict=True)]
    total = sum(meats, np.zeros((k, k)))
    var0 = np.diag(bread @ total @ bread)
    var_log = np.zeros(k)
    h = 1e-4
    for b, (rows, _, nm) in enumerate(blocks):
        if nm.correlated and nm.theta_cov.shape == (3, 3):
            grad = np.empty((3, k))
            for i in range(3):
                e = np.zeros(3)
                e[i] = h
                vp = np.diag(bread @ (total - meats[b] + parts[b](nm.with_theta(
                    nm.theta + e))) @ bread)
                vm = np.diag(bread @ (total - meats[b] + parts[b](nm.with_theta(
                    nm.theta - e))) @ bread)
                with np.errstate(divide="ignore", invalid="ignore"):
                    grad[i] = (np.log(vp) - np.log(vm)) / (2 * h)
            grad[~np.isfinite(grad)] = 0.0  # a parameter without variance: no dof information
            var_log += np.einsum("ik,ij,jk->k", grad, nm.theta_cov, grad)
        else:
            # white block: var(ln v_w) = 2/n, d ln var_j / d ln v_w = share of the block
            share = np.diag(bread @ meats[b] @ bread) / np.where(var0 > 0, var0, 1.0)
            var_log += share**2 * 2.0 / max(nm.n_used or (rows.stop - rows.start), 1)
    with np.errstate(divide="ignore"):
        nu = np.where(var_log > 0, 2.0 / var_log, cap)
    return np.clip(nu, 1.0, cap)


# ---------------------------------------------------------------------------------------------
# variance function of independent points (traction curves, film and temperature series)
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class VarianceFunction:
    """``Var(r_i) = s^2 ((1 - phi) + phi (scale_i / scale_ref)^2)``: constant plus proportional.

    ``phi = 0`` is noise of constant size, ``phi = 1`` noise proportional to
    the signal (``scale``, e.g. the model's ``|mu|``); ``scale_ref`` is the RMS
    of the scales, so ``s`` is the typical residual size either way.
    """

    phi: float
    scale_ref: float
    lr: float = 0.0

    @property
    def significant(self) -> bool:
        """Whether the proportional part beats constant noise (likelihood ratio, 1 %).

        ``phi = 0`` lies on the boundary, so the statistic is referred to the
        50:50 mixture of chi-square(0) and chi-square(1) (Self & Liang 1987,
        JASA 82, 605): critical value 5.41 at 1 %.
        """
        return self.lr >= LR_PHI_CRITICAL

    def weights(self, scale: np.ndarray) -> np.ndarray:
        """Relative variance ``w_i`` of each point (mean about 1)."""
        z = (np.asarray(scale, dtype=float) / self.scale_ref) ** 2
        return (1.0 - self.phi) + self.phi * z

    def describe(self) -> str:
        """For the fit's metadata."""
        return (f"variance = s^2 ({1 - self.phi:.3g} + {self.phi:.3g} (|signal| / "
                f"{self.scale_ref:.3g})^2), maximum likelihood from the residuals")


#: 1 % critical value of the boundary likelihood-ratio test phi = 0 (chi-bar-square: the
#: 98 % quantile of chi-square(1)); at 5 % a third of the false alarms on constant noise
#: reweighted a few small-signal points enough to cut the coverage of the others
LR_PHI_CRITICAL = 5.412
#: largest proportional share: a constant floor of 0.1 % of the mean variance always remains
PHI_MAX = 0.999


def estimate_variance_function(residuals: np.ndarray, scale: np.ndarray,
                               leverage: np.ndarray | None = None) -> VarianceFunction:
    """Maximum-likelihood ``phi`` of :class:`VarianceFunction` from independent residuals.

    ``s^2`` is profiled out: ``phi`` minimises
    ``sum_i ln w_i + n ln(sum_i r_i^2 / w_i)`` on ``[0, 1]`` (a bounded scalar
    search).  Residuals are divided by ``sqrt(1 - h_ii)`` with the leverages
    ``h`` when given (the fitted parameters pull each residual towards zero by
    that factor).  ``phi`` stays below :data:`PHI_MAX`, so a point with a
    near-zero signal never gets an unbounded weight.  With a scale that hardly varies (max/min < 1.05) the two
    components cannot be told apart and ``phi = 0``.
    """
    from scipy.optimize import minimize_scalar

    r = np.asarray(residuals, dtype=float)
    s = np.abs(np.asarray(scale, dtype=float))
    if leverage is not None:
        r = r / np.sqrt(np.clip(1.0 - np.asarray(leverage, dtype=float), 1e-3, None))
    ref = float(np.sqrt(np.mean(s * s))) or 1.0
    pos = s[s > 0]
    if r.size < 4 or pos.size < 2 or float(np.max(s)) < 1.05 * float(np.min(s)):
        return VarianceFunction(0.0, ref)
    z = (s / ref) ** 2
    r2 = r * r
    if not np.any(r2 > 0):
        return VarianceFunction(0.0, ref)
    n = r.size

    def nll(phi: float) -> float:
        w = np.maximum((1.0 - phi) + phi * z, 1e-12)
        return float(np.sum(np.log(w)) + n * math.log(max(float(np.sum(r2 / w)), 1e-300)))

    sol = minimize_scalar(nll, bounds=(0.0, PHI_MAX), method="bounded",
                          options={"xatol": 1e-4})
    phi = float(sol.x)
    # the ends of the interval are candidates too (the bounded search stays inside)
    for end in (0.0, PHI_MAX):
        if nll(end) <= nll(phi):
            phi = end
    return VarianceFunction(phi, ref, max(nll(0.0) - nll(phi), 0.0))


@dataclass(frozen=True)
class LinearFit:
    """Linear least squares with a covariance from an estimated variance function.

    Attributes
    ----------
    coef, cov
        Estimates and their covariance ``s^2 B X^T W X B``.
    residuals
        ``y - X coef`` (unweighted).
    weights
        Relative variance of each point (1 for constant noise).
    s2
        Residual variance of unit relative variance (``Var(r_i) = s2 weights_i``).
    dof
        Residual degrees of freedom (one fewer when the variance function was used).
    variance
        The :class:`VarianceFunction`, or None when the noise is taken as constant.
    A
        ``(X^T X)^-1 X^T``: ``coef = A y`` (for covariances with other estimates).
    """

    coef: np.ndarray
    cov: np.ndarray
    residuals: np.ndarray
    weights: np.ndarray
    s2: float
    dof: int
    variance: VarianceFunction | None
    A: np.ndarray


def linear_least_squares(X: np.ndarray, y: np.ndarray, scale: Any = None) -> LinearFit:
    """``y = X coef`` by ordinary least squares, with a covariance that holds when the
    noise grows with the signal.

    ``scale`` is the quantity the noise may grow with (see
    :class:`VarianceFunction`): a function of the fitted values
    (``scale(X coef)``) or an array.  The variance function is estimated from
    the residuals and, when the likelihood-ratio test prefers it to constant
    noise, enters the covariance: ``s^2 B X^T W X B`` with ``B = (X^T X)^-1``,
    ``W`` the relative variances and ``s^2 = sum r^2/w / (n - k - 1)``.  The
    estimates stay the ordinary ones (a weighted fit would move them where the
    line is only an approximation of the data, e.g. a film whose log-log slope
    drifts with speed).
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    n, k = X.shape
    q, rr = np.linalg.qr(X)
    rinv = np.linalg.inv(rr)
    A = rinv @ q.T  # coef = A y
    coef = A @ y
    bread = rinv @ rinv.T
    r = y - X @ coef
    w = np.ones(n)
    vf = None
    if scale is not None and n - k >= 3:
        sc = np.asarray(scale(X @ coef) if callable(scale) else scale, dtype=float)
        lev = np.sum((X @ bread) * X, axis=1)
        est = estimate_variance_function(r, sc, lev)
        if est.significant:
            vf = est
            w = est.weights(sc)
    dof = n - k - (1 if vf is not None else 0)
    # E[r_i^2] = s^2 (w_i (1 - 2 h_ii) + sum_j H_ij^2 w_j): divide by it, not by n - k
    H = X @ A
    expect = w * (1.0 - 2.0 * np.diag(H)) + (H * H) @ w
    s2 = float(np.sum(r * r)) / max(float(np.sum(expect)), 1e-300) if vf is not None else \
        float(r @ r) / max(n - k, 1)
    cov = s2 * (A * w[None, :]) @ A.T
    return LinearFit(coef, cov, r, w, s2, dof, vf, A)
