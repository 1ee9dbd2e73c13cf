"""Between-run scatter: random-effects estimates of a quantity measured in repeated runs.

A product's layer, a traction curve, a film or a time test measured twice does not give
the same number twice: a new sample, a new track, a new application scatter from run to
run by a few per cent, which is often far more than one run's own fitting or record
noise.  An interval that holds only a run's own noise then makes every difference look
significant.  Every place in torlab where repeats exist pools them with one model:

``y_i = x_i' beta + b_i + e_i``

with ``y_i`` run ``i``'s estimate, ``e_i`` its own error of known variance ``v_i`` (the
run's fit or record gives it), ``b_i`` the run-to-run offset with variance ``tau^2``
(unknown) and ``x_i' beta`` the fixed part: one common mean (repeats of one product),
a mean per group (several compositions sharing one scatter) or a line (a temperature
series).

* ``tau^2`` is the restricted maximum-likelihood (REML) estimate (Patterson & Thompson
  1971; for meta-analysis Viechtbauer 2005, J. Educ. Behav. Stat. 30, 261): it maximises
  ``-1/2 [sum ln(v_i + tau^2) + ln det(X'WX) + r'Wr]``, ``W = diag(1/(v_i + tau^2))``,
  over ``tau^2 >= 0`` (:func:`reml_between`).  With equal ``v_i`` and one mean per
  group it is the pooled within-group variance less ``v`` (the one-way analysis of
  variance of the MTM time tests, :func:`one_way`).
* The pooled estimate is the weighted mean ``sum w_i y_i / sum w_i``, ``w_i = 1/(v_i +
  tau^2)``; its variance ``1/sum w_i`` splits into the part of the runs' own noise and
  the part of the scatter between runs (:class:`Pooled`).
* The interval is Hartung & Knapp's (2001, Stat. Med. 20, 3875; Sidik & Jonkman 2002):
  the variance is scaled by ``q = sum w_i (y_i - mu)^2 / (k - 1)`` where the runs scatter
  more than the model says (``q`` is floored at 1, the modification of Knapp & Hartung
  2003 that never makes the interval narrower than the model's), with Student t on
  ``k - 1`` degrees of freedom.  With few runs ``tau^2`` itself is uncertain, and a normal
  interval on the REML variance would cover far less than 95 %; t on ``k - 1`` holds it
  (the coverage tables in ``docs/fit.md``).

One run cannot show its scatter: its interval holds for that record alone, and the
results say so (:data:`ONE_RUN`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["ONE_RUN", "Pooled", "one_way", "pool", "pool_vectors", "reml_between"]

#: what an interval from a single run holds
ONE_RUN = ("one run: the interval holds for this record alone; the scatter between runs is "
           "not estimated (repeat the test to include it)")
#: the method, in words, for results
METHOD = ("random effects: REML between-run variance, Hartung-Knapp interval (Student t on "
          "runs - 1 degrees of freedom)")


def _reml_nll(tau2: float, y: np.ndarray, v: np.ndarray, X: np.ndarray) -> float:
    """Minus twice the restricted log-likelihood (constants dropped)."""
    w = 1.0 / (v + tau2)
    xtwx = X.T @ (X * w[:, None])
    sign, logdet = np.linalg.slogdet(xtwx)
    if sign <= 0:
        return math.inf
    beta = np.linalg.solve(xtwx, X.T @ (w * y))
    r = y - X @ beta
    return float(np.sum(np.log(v + tau2)) + logdet + np.sum(w * r * r))


def reml_between(y: Any, v: Any, X: Any = None) -> float:
    """REML estimate of the between-run variance ``tau^2`` (module docstring).

    Parameters
    ----------
    y
        Each run's estimate.
    v
        Each run's own variance (its squared standard error; 0 where unknown).
    X
        Design of the fixed part (runs x columns); default one common mean.

    Returns
    -------
    float
        ``tau^2 >= 0`` (0 when the runs scatter no more than their own variances say,
        or when there are no more runs than fixed parameters).

    Raises
    ------
    ConvergenceError
        The bounded search did not converge.
    """
    from scipy.optimize import minimize_scalar

    from torlab.errors import ConvergenceError

    y = np.asarray(y, dtype=float).ravel()
    v = np.asarray(v, dtype=float).ravel()
    X = np.ones((y.size, 1)) if X is None else np.asarray(X, dtype=float).reshape(y.size, -1)
    if y.size <= X.shape[1]:
        return 0.0
    beta = np.linalg.lstsq(X, y, rcond=None)[0]
    s2 = float(np.sum((y - X @ beta) ** 2)) / (y.size - X.shape[1])
    if s2 <= 0:
        return 0.0
    if np.ptp(v) <= 1e-12 * max(float(np.max(v)), s2):
        # equal own variances: the homoscedastic linear model, whose REML variance is
        # RSS / (n - p) exactly
        return max(s2 - float(np.mean(v)), 0.0)
    # a tiny floor keeps W finite for runs whose own variance is 0 (unknown or exact)
    vv = np.maximum(v, 1e-12 * s2)
    # search sqrt(tau^2) on [0, 10 s]: the likelihood falls off beyond the raw scatter
    hi = 10.0 * math.sqrt(s2)
    sol = minimize_scalar(lambda t: _reml_nll(t * t, y, vv, X), bounds=(0.0, hi),
                          method="bounded", options={"xatol": 1e-6 * hi, "maxiter": 500})
    if not sol.success:
        raise ConvergenceError(f"REML between-run variance did not converge ({sol.message})")
    t = float(sol.x)
    if _reml_nll(0.0, y, vv, X) <= _reml_nll(t * t, y, vv, X):  # the boundary is a candidate
        t = 0.0
    return t * t


@dataclass(frozen=True)
class Pooled:
    """A quantity pooled over repeated runs (module docstring).

    Attributes
    ----------
    estimate
        The pooled estimate (random-effects weighted mean).
    se
        Its standard error (Hartung-Knapp: the model's, scaled up where the runs
        scatter more than it says).
    dof
        Degrees of freedom of its Student-t interval (``k - 1``; the run's own with
        one run).
    k
        Runs pooled.
    tau
        Between-run standard deviation (REML; NaN with one run).
    var_within, var_between
        The parts of ``se**2`` from the runs' own noise and from the scatter between
        runs (they add up to ``se**2``; the Hartung-Knapp excess is scatter the
        runs' own noise does not explain, counted as between-run).
    q
        Hartung-Knapp's ratio of the observed to the modelled scatter.
    runs
        The runs' estimates and their own standard errors.
    """

    estimate: float
    se: float
    dof: float
    k: int
    tau: float
    var_within: float
    var_between: float
    q: float
    runs: tuple[tuple[float, float], ...] = field(default=(), repr=False)

    @property
    def share_between(self) -> float:
        """Fraction of the estimate's variance that is scatter between runs."""
        tot = self.var_within + self.var_between
        return min(max(self.var_between / tot, 0.0), 1.0) if tot > 0 else 0.0

    def interval(self, confidence: float = 0.95) -> tuple[float, float]:
        """Student-t interval of the pooled estimate."""
        from torlab._stats import t_ppf

        tq = float(t_ppf(0.5 + confidence / 2, max(self.dof, 1.0)))
        return self.estimate - tq * self.se, self.estimate + tq * self.se

    def as_dict(self) -> dict[str, Any]:
        """For summaries (finite numbers or None)."""
        def fin(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {"runs": self.k, "estimate": fin(self.estimate), "se": fin(self.se),
                "dof": fin(self.dof), "between_run_sd": fin(self.tau),
                "share_within": fin(1.0 - self.share_between) if self.k > 1 else 1.0,
                "share_between": fin(self.share_between) if self.k > 1 else None,
                "hartung_knapp_q": fin(self.q)}


def pool(y: Any, v: Any, *, dof_one: float = math.inf) -> Pooled:
    """Pool one quantity over repeated runs (module docstring).

    Parameters
    ----------
    y
        Each run's estimate.
    v
        Each run's own variance (squared standard error; ``inf`` where the run does
        not determine it: left out).
    dof_one
        Degrees of freedom of a single run's own interval (used when one run is left).

    Returns
    -------
    Pooled
        With one run: that run, ``tau`` NaN, every variance within.

    Raises
    ------
    ValueError
        No run with a finite variance.
    """
    y = np.asarray(y, dtype=float).ravel()
    v = np.asarray(v, dtype=float).ravel()
    ok = np.isfinite(y) & np.isfinite(v) & (v >= 0)
    y, v = y[ok], v[ok]
    runs = tuple((float(a), float(math.sqrt(b))) for a, b in zip(y, v, strict=True))
    if y.size == 0:
        raise ValueError("no run with a finite estimate and variance")
    if y.size == 1:
        return Pooled(float(y[0]), float(math.sqrt(v[0])), float(dof_one), 1, math.nan,
                      float(v[0]), 0.0, math.nan, runs)
    k = y.size
    tau2 = reml_between(y, v)
    vv = np.maximum(v, 1e-300)
    w = 1.0 / (vv + tau2)
    W = float(np.sum(w))
    mu = float(np.sum(w * y) / W)
    var_model = 1.0 / W
    a = w / W
    var_w = float(np.sum(a * a * v))
    q = float(np.sum(w * (y - mu) ** 2) / (k - 1))
    scale = max(q, 1.0)
    var = var_model * scale
    return Pooled(mu, math.sqrt(var), float(k - 1), k, math.sqrt(tau2), var_w,
                  var - var_w, q, runs)


def pool_vectors(values: Any, covs: Any, log_scale: Any = (), *,
                 dof_one: Any = None) -> tuple[np.ndarray, np.ndarray, list[Pooled]]:
    """Pool parameter vectors of repeated runs, with their joint covariance.

    Each parameter is pooled by :func:`pool` (positive ones listed in ``log_scale``
    on ``ln p``: a scatter of a few per cent is relative).  The covariance of the
    pooled vector adds to the runs' own covariances (weighted as the estimates are)
    the between-run covariance ``Psi = D_tau R D_tau``, whose correlations ``R`` are
    those of the runs' scatter beyond their own noise (the sample covariance of the
    estimates less their mean own covariance, projected onto the positive
    semi-definite matrices); each parameter's variance is then scaled to its
    Hartung-Knapp variance, so the diagonal is exactly :func:`pool`'s.

    Parameters
    ----------
    values
        ``(k, p)`` estimates of ``k`` runs.
    covs
        ``(k, p, p)`` their own covariances (``inf`` rows: not determined in that run).
    log_scale
        Boolean mask (or indices) of the parameters pooled on the log scale.
    dof_one
        Per-parameter degrees of freedom of a single run (with ``k = 1``).

    Returns
    -------
    (estimate, covariance, pooled)
        The pooled vector and its covariance (natural scale), and the per-parameter
        :class:`Pooled` (on the scale pooled: ``ln p`` for log-scale parameters).
    """
    Y = np.atleast_2d(np.asarray(values, dtype=float))
    C = np.asarray(covs, dtype=float).reshape(Y.shape[0], Y.shape[1], Y.shape[1])
    k, p = Y.shape
    logm = np.zeros(p, dtype=bool)
    ls = np.asarray(log_scale)
    if ls.dtype == bool and ls.size == p:
        logm = ls.copy()
    elif ls.size:
        logm[ls.astype(int)] = True
    logm &= np.all(Y > 0, axis=0)
    # to the pooling scale: ln p for the log-scale parameters
    Z = np.where(logm[None, :], np.log(np.where(Y > 0, Y, 1.0)), Y)
    J = np.where(logm[None, :], 1.0 / np.where(Y > 0, Y, 1.0), 1.0)  # dz/dy per run
    V = C * J[:, :, None] * J[:, None, :]
    dof1 = np.full(p, math.inf) if dof_one is None else np.asarray(dof_one, dtype=float)
    pooled = []
    for j in range(p):
        vj = V[:, j, j]
        pooled.append(pool(Z[:, j], np.where(np.isfinite(vj), vj, np.inf), dof_one=dof1[j]))
    z = np.array([pl.estimate for pl in pooled])
    finite = np.isfinite(V).all(axis=(1, 2))
    if k == 1 or finite.sum() < 2:
        cov_z = V[int(np.argmax(finite))] if finite.any() else V[0]
    else:
        Zf, Vf = Z[finite], V[finite]
        tau = np.array([pl.tau if math.isfinite(pl.tau) else 0.0 for pl in pooled])
        # the between-run correlations: sample covariance less the mean own covariance
        S = np.cov(Zf, rowvar=False, ddof=1).reshape(p, p)
        B = S - Vf.mean(axis=0)
        d = np.sqrt(np.clip(np.diag(B), 0.0, None))
        with np.errstate(divide="ignore", invalid="ignore"):
            R = np.where(np.outer(d, d) > 0, B / np.outer(d, d), 0.0)
        R = np.clip(R, -1.0, 1.0)
        np.fill_diagonal(R, 1.0)
        ev, U = np.linalg.eigh(R)
        R = (U * np.clip(ev, 0.0, None)) @ U.T
        dr = np.sqrt(np.clip(np.diag(R), 1e-300, None))
        R = R / np.outer(dr, dr)
        Psi = R * np.outer(tau, tau)
        w = 1.0 / (np.stack([np.diag(x) for x in Vf]) + tau[None, :] ** 2)  # (k, p)
        a = w / w.sum(axis=0, keepdims=True)
        cov_z = np.einsum("ij,il,ijl->jl", a, a, Vf + Psi[None, :, :])
        # each variance to its Hartung-Knapp variance (the correlations kept)
        target = np.array([pl.se ** 2 for pl in pooled])
        f = np.sqrt(target / np.clip(np.diag(cov_z), 1e-300, None))
        cov_z = cov_z * np.outer(f, f)
    est = np.where(logm, np.exp(z), z)
    jac = np.where(logm, est, 1.0)
    cov = cov_z * np.outer(jac, jac)
    return est, 0.5 * (cov + cov.T), pooled


def one_way(values: Any, groups: Any, record_sd: Any = None) -> dict[str, Any]:
    """Scatter of one test's figure about its group's mean: REML with a mean per group.

    The model of the module docstring with one fixed mean per group (composition)
    and one variance shared by every group.  A test's record noise is part of what
    scatters from test to test, so the REML variance of one test's figure is taken
    with it (:func:`reml_between` with no own variance): the pooled within-group
    variance ``s^2 = sum_i sum_j (x_ij - xbar_i)^2 / sum_i (n_i - 1)`` on
    ``sum (n_i - 1)`` degrees of freedom, exactly (Searle, Casella & McCulloch 1992,
    Variance Components, ch. 3).  The records' own standard errors then split it: the
    between-test part is ``sqrt(max(0, s^2 - mean record variance))``.

    Parameters
    ----------
    values
        The figure of every test.
    groups
        The group of every test (tests of one group are repeats).
    record_sd
        Each test's standard error from its own record (NaN where unknown).

    Returns
    -------
    dict
        ``sd_test`` (``s``: scatter of one test about its group's mean, record noise
        included; NaN without a repeat), ``dof`` (``sum (n_i - 1)``), ``sd_record``
        (root mean square of the repeated tests' own standard errors), ``sd_between``
        (the part the records do not explain), ``n_tests``, ``n_compositions`` (groups
        with at least two finite values), ``means`` (``{group: (mean, n)}``).
    """
    x = np.asarray(values, dtype=float)
    g = np.asarray([str(v) for v in groups], dtype=object)
    sd = np.full(x.shape, np.nan) if record_sd is None else np.asarray(record_sd, dtype=float)
    ok = np.isfinite(x)
    means: dict[str, tuple[float, int]] = {}
    rep_groups = []
    for key in dict.fromkeys(g[ok]):
        sel = ok & (g == key)
        means[str(key)] = (float(x[sel].mean()), int(sel.sum()))
        if sel.sum() >= 2:
            rep_groups.append(key)
    sel = ok & np.isin(g, rep_groups)
    n_t = int(sel.sum())
    dof = n_t - len(rep_groups)
    if dof <= 0:
        return {"sd_test": math.nan, "dof": 0, "sd_record": math.nan, "sd_between": math.nan,
                "n_tests": 0, "n_compositions": 0, "means": means}
    xs, gs = x[sel], g[sel]
    X = (gs[:, None] == np.array(rep_groups, dtype=object)[None, :]).astype(float)
    s = math.sqrt(reml_between(xs, np.zeros(xs.size), X))
    rec = [v for v in sd[sel] if math.isfinite(v)]
    sr = math.sqrt(float(np.mean(np.square(rec)))) if rec else math.nan
    between = math.sqrt(max(0.0, s * s - sr * sr)) if math.isfinite(sr) else math.nan
    return {"sd_test": s, "dof": dof, "sd_record": sr, "sd_between": between,
            "n_tests": n_t, "n_compositions": len(rep_groups), "means": means}
