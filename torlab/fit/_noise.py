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
correlation ``rho``; ``scale_t`` is the model's stress (relative noise).  Its
parameters come from the semivariogram ``g_k = mean((z_{t+k} - z_t)^2)/2 =
v_w + v_c (1 - rho^k)`` of the relative residuals ``z = r/scale`` on the
high-stress part of the record, which, unlike the autocovariance, is not biased
by the fitted level.  The parameter covariance of the least-squares estimate is
the sandwich ``B J^T Sigma J B`` with ``B = (J^T J)^-1`` and the effective
number of independent points ``n / (1 + 2 v_c/(v_w + v_c) rho/(1 - rho))``
gives the degrees of freedom of the Student-t interval.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from torlab.fit.result import _scaled_inverse

__all__ = ["NoiseModel", "estimate_noise", "sandwich_covariance"]

#: fewest points of the stationary part for a correlated-noise model
MIN_POINTS_CORRELATED = 40


@dataclass(frozen=True)
class NoiseModel:
    """Relative white + AR(1) residual noise (see module docstring)."""

    white_var: float
    correlated_var: float
    rho: float
    kind: str = "relative white + AR(1)"

    @property
    def relative_sd(self) -> float:
        """Total relative standard deviation of the residuals."""
        return math.sqrt(self.white_var + self.correlated_var)

    def effective_points(self, n: int) -> float:
        """Independent-equivalent number of points of a record of ``n``."""
        tot = self.white_var + self.correlated_var
        if tot <= 0 or self.rho <= 0:
            return float(n)
        infl = 1.0 + 2.0 * self.correlated_var / tot * self.rho / (1.0 - self.rho)
        return n / infl

    def as_dict(self) -> dict[str, float | str]:
        """For the provenance."""
        return {"noise_model": self.kind, "noise_white_relative_sd": math.sqrt(self.white_var),
                "noise_correlated_relative_sd": math.sqrt(self.correlated_var),
                "noise_lag1_correlation": self.rho}


def estimate_noise(residuals: np.ndarray, scale: np.ndarray, kmax: int = 60) -> NoiseModel:
    """Fit :class:`NoiseModel` to the residuals by their semivariogram.

    Parameters
    ----------
    residuals
        Residuals in record order.
    scale
        Positive scale of each residual (the model's stress).
    kmax
        Largest lag of the semivariogram (at most a quarter of the record): 60
        samples reach the plateau of a fluctuation correlated over ~20 samples (the
        HPT at 2 Hz, 10 s) yet stay few enough not to see the fitted trend.

    Notes
    -----
    With fewer than :data:`MIN_POINTS_CORRELATED` points at high stress the
    model is white noise with the relative variance of all residuals.
    """
    from scipy.optimize import least_squares

    r = np.asarray(residuals, dtype=float)
    s = np.asarray(scale, dtype=float)
    sel = s >= 0.5 * np.max(s)
    z = r[sel] / s[sel]
    n = z.size
    if n < MIN_POINTS_CORRELATED:
        zz = r / s
        return NoiseModel(float(np.mean(zz * zz)), 0.0, 0.0, kind="relative white")
    K = max(4, min(kmax, n // 4))
    k = np.arange(1, K + 1)
    g = np.array([np.mean((z[kk:] - z[:-kk]) ** 2) / 2.0 for kk in k])
    gm = float(np.mean(g))
    if gm <= 0:
        return NoiseModel(0.0, 0.0, 0.0, kind="none (exact fit)")

    def res(p: np.ndarray) -> np.ndarray:
        vw, vc, rho = p
        return (vw + vc * (1.0 - rho**k) - g) / gm

    x0 = np.array([0.5 * g[0], max(g[-1] - 0.5 * g[0], 1e-3 * gm), 0.9])
    sol = least_squares(res, x0, bounds=([0.0, 0.0, 0.0], [np.inf, np.inf, 0.9995]),
                        x_scale=np.array([gm, gm, 0.1]))
    vw, vc, rho = (float(v) for v in sol.x)
    if vc <= 1e-6 * (vw + vc) or rho <= 1e-3:
        return NoiseModel(float(np.mean(z * z)), 0.0, 0.0, kind="relative white")
    return NoiseModel(vw, vc, rho)


def sandwich_covariance(jac: np.ndarray, blocks: list[tuple[slice, np.ndarray, NoiseModel]]
                        ) -> np.ndarray:
    """``B J^T Sigma J B`` with ``Sigma`` block diagonal, one :class:`NoiseModel` per block.

    ``blocks`` lists ``(rows, scale, model)``; rows of different blocks (curves)
    are independent.
    """
    meat = np.zeros((jac.shape[1], jac.shape[1]))
    for rows, scale, nm in blocks:
        J = jac[rows]
        sj = J * scale[:, None]
        meat += nm.white_var * (sj.T @ sj)
        if nm.correlated_var > 0 and nm.rho > 0:
            # AR(1) covariance applied by a forward and a backward recursion (O(n k))
            from scipy.signal import lfilter

            a = sj
            fwd = lfilter([1.0], [1.0, -nm.rho], a, axis=0)
            bwd = lfilter([1.0], [1.0, -nm.rho], a[::-1], axis=0)[::-1]
            # sum_{s,t} rho^|s-t| a_s a_t^T = sum_t a_t (fwd_t + bwd_t - a_t)^T
            meat += nm.correlated_var * (a.T @ (fwd + bwd - a))
    bread = _scaled_inverse(jac.T @ jac)
    if not np.all(np.isfinite(bread)):
        return bread
    out = bread @ meat @ bread
    return 0.5 * (out + out.T)
