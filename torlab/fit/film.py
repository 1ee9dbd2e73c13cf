"""Film thickness against rolling speed: speed exponent and effective pressure-viscosity coefficient.

* Speed exponent: ordinary least squares of ``ln h = ln C + n ln v`` over the
  points at or above ``min_speed`` (below it the film is a few nm and the
  spacer layer / roughness dominate; Hamrock-Dowson predicts ``n = 0.67``,
  Eq. 5.32).  ``C`` is the film at 1 m/s.
* Effective ``alpha``: with a scene (contact, materials, ``lubricant.eta0`` at the
  test temperature), the Hamrock-Dowson formula (Eq. 5.32, :func:`torlab.model.ehl.hc_piezo`)
  ``hc = 2.69 U^0.67 G^0.53 W^-0.067 (1 - 0.61 e^(-0.73 D)) rx`` with
  ``G = alpha E'`` is solved for the ``alpha`` that fits the measured films on
  average: ``ln h_i - ln hc(v_i; alpha_1) = 0.53 ln(alpha / alpha_1)`` for any
  reference ``alpha_1``, so ``ln alpha`` is a mean with a Student-t interval.

Intervals are Student-t with ``n - 2`` (exponent) and ``n - 1`` (alpha) degrees
of freedom from the scatter about the fitted line; the prefactor and ``alpha``
are positive and get log-scale intervals.  A scatter proportional to ``h`` is
constant in ``ln h``; one of constant size (the interferometer's nanometres)
grows as ``1/h`` there and dominates the slow, thin films.  A variance function
estimated from the residuals (constant plus proportional, maximum likelihood)
weights the points when a likelihood-ratio test prefers it to constant
scatter in ``ln h`` (:func:`torlab.fit._noise.linear_least_squares`; one
degree of freedom less).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.fit._noise import linear_least_squares
from torlab.fit.result import FitResult, student_t
from torlab.threads import small_problem

__all__ = ["HD_SPEED_EXPONENT", "fit_film_thickness"]

#: Hamrock-Dowson exponents of U and G (Eq. 5.32)
HD_SPEED_EXPONENT = 0.67
HD_G_EXPONENT = 0.53


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_film_thickness(speed_m_s: Any, h_m: Any, *, scene: Any = None,
                       min_speed: float | None = None) -> FitResult:
    """Fit the film's speed exponent and (with a scene) the effective alpha.

    Parameters
    ----------
    speed_m_s, h_m
        Rolling (entrainment) speeds (m/s) and central film thicknesses (m).
    scene
        A :class:`~torlab.scene.Scene` with ``contact``, ``materials`` and
        ``lubricant.eta0`` (the viscosity at the test temperature) for the
        effective pressure-viscosity coefficient; None for the exponent only.
    min_speed
        Use only points at or above this speed (m/s).

    Returns
    -------
    FitResult
        ``kind="film"``; parameters ``speed_exponent``, ``film_prefactor``
        (m, film at 1 m/s) and with a scene ``alpha`` (1/Pa, written as the
        ``lubricant: alpha`` key).

    Raises
    ------
    TorlabInputError
        Too few points, non-positive or non-finite values, one speed, constant film.
    """
    import pandas as pd

    v = np.asarray(speed_m_s, dtype=float).ravel()
    h = np.asarray(h_m, dtype=float).ravel()
    if v.shape != h.shape:
        raise TorlabInputError(f"film fit: {v.size} speeds but {h.size} film thicknesses")
    ok = np.isfinite(v) & np.isfinite(h)
    if not ok.all():
        raise TorlabInputError("film fit: speeds and film thicknesses must be finite numbers")
    sel = np.ones(v.size, dtype=bool) if min_speed is None else v >= min_speed
    v, h = v[sel], h[sel]
    if np.any(v <= 0) or np.any(h <= 0):
        raise TorlabInputError("film fit: speeds and film thicknesses must be positive for a "
                               "log-log fit (use --min-speed to drop the slow points)")
    if v.size < 3:
        raise TorlabInputError(f"film fit: too few points ({v.size}"
                               f"{'' if min_speed is None else f' at or above {min_speed:g} m/s'}); "
                               "the exponent with an uncertainty needs at least 3")
    x, y = np.log(v), np.log(h)
    if np.ptp(x) < 1e-6:
        raise TorlabInputError("film fit: all points are at one speed")
    if np.ptp(y) < 1e-9:
        raise TorlabInputError("film fit: the film thickness is constant: no speed dependence to fit")
    X = np.column_stack((np.ones_like(x), x))
    # noise of constant size in h (nm of the interferometer) is 1/h in ln h
    lf = linear_least_squares(X, y, lambda lnh: np.exp(-lnh))
    coef, cov, r = lf.coef, lf.cov, lf.residuals
    n = v.size
    dof = lf.dof
    lnC, nexp = float(coef[0]), float(coef[1])
    se_n = math.sqrt(cov[1, 1])
    tq = student_t(dof)
    names: list[str] = ["speed_exponent", "film_prefactor"]
    params = {"speed_exponent": nexp, "film_prefactor": math.exp(lnC)}
    # covariance in the order (exponent, ln C), then natural units for the prefactor
    cov_t = cov[::-1, ::-1]
    warnings: list[str] = []
    meta: dict[str, Any] = {"method": "least squares of ln h on ln v (Hamrock-Dowson form, Eq. 5.32)"
                            + ("" if lf.variance is None else
                               "; weighted by a variance function estimated from the residuals"),
                            "min_speed_m_s": min_speed, "speed_range_m_s": [float(v.min()),
                                                                            float(v.max())],
                            "noise_model": ("constant in ln h (film scatter proportional to h)"
                                            if lf.variance is None else
                                            lf.variance.describe() + " (signal: 1/h)")}
    ci_n = (nexp - tq * se_n, nexp + tq * se_n)
    if not (ci_n[0] <= HD_SPEED_EXPONENT <= ci_n[1]):
        warnings.append(f"speed exponent {nexp:.3f} differs from Hamrock-Dowson's 0.67 beyond its "
                        "95 % interval: the effective alpha then depends on the speed range")
    h_model = np.exp(X @ coef)
    data = pd.DataFrame({"speed_m_s": v, "film_thickness_measured_m": h,
                         "film_thickness_model_m": h_model, "residual_m": h - h_model,
                         "residual_ln": r})
    values_t = [nexp, lnC]
    if scene is not None:
        a_val, a_se_ln, a_dof, d_ln = _effective_alpha(scene, v, h, lf.weights)
        names.append("alpha")
        params["alpha"] = a_val
        # ln alpha = const + mean(d)/0.53 and (n, ln C) are all linear in ln h: under the
        # line's noise model (Var ln h_i = s^2 w_i) cov(coef, mean d) = s^2 A W 1 / n; the
        # correlations of that representation scale alpha's own variance
        wv = lf.weights
        cross = lf.s2 * (lf.A @ wv)[::-1] / n  # (exponent, ln C)
        var_mean = lf.s2 * float(np.sum(wv)) / n**2
        c3 = np.zeros((3, 3))
        c3[:2, :2] = cov_t
        c3[2, 2] = a_se_ln**2
        for i in range(2):
            den = math.sqrt(cov_t[i, i] * var_mean)
            corr = float(np.clip(cross[i] / den, -1.0, 1.0)) if den > 0 else 0.0
            c3[i, 2] = c3[2, i] = corr * math.sqrt(cov_t[i, i]) * a_se_ln
        cov_t = c3
        values_t.append(math.log(a_val))
        data["film_thickness_hamrock_dowson_m"] = h * np.exp(-(d_ln - HD_G_EXPONENT
                                                               * math.log(a_val / _ALPHA_REF)))
        meta["lubricant_extra"] = {}
        meta["eta0_Pa_s"] = float(scene.lubricant.eta0)
        meta["alpha_note"] = ("effective alpha: the Hamrock-Dowson G that reproduces the measured "
                              "films with the scene's eta0 (at the test temperature)")
        meta["interval_dof"] = {"speed_exponent": dof, "film_prefactor": dof, "alpha": a_dof}
    jac = np.exp(values_t)
    jac[0] = 1.0  # the exponent is on its own scale
    cov_nat = cov_t * np.outer(jac, jac)
    pdof = [dof, dof] + ([a_dof] if scene is not None else [])
    res = FitResult.from_covariance(
        "film", tuple(names), np.array([params[k] for k in names]), cov_nat, dof=dof,
        param_dof=pdof, log_scale=("film_prefactor", "alpha"),
        residual_norm=float(np.sqrt(np.mean((h - h_model) ** 2))), n_points=int(n),
        warnings=warnings, data=data, meta=meta, residual_unit="m", n_evaluations=1,
        x_column="speed_m_s", y_column="film_thickness_measured_m")
    return res


_ALPHA_REF = 10e-9


def _effective_alpha(scene: Any, v: np.ndarray, h: np.ndarray, weights: np.ndarray | None = None
                     ) -> tuple[float, float, int, np.ndarray]:
    """``alpha`` (1/Pa), the standard error of ``ln alpha``, dof, and the log ratios.

    ``weights`` are the relative variances of ``ln h`` (the film line's variance
    function): the variance of the mean log ratio is ``s^2 sum(w) / n^2`` with
    ``s^2`` estimated from the scatter about the mean with those weights.
    """
    from torlab.model.contact import build_contact
    from torlab.model.ehl import hc_piezo

    if scene.lubricant is None:
        raise TorlabInputError("the effective alpha needs the scene's lubricant: eta0 (the "
                               "viscosity at the test temperature)", key="lubricant")
    c = build_contact(scene)
    if not math.isfinite(c.rx):
        raise TorlabInputError("the effective alpha needs the radius in the rolling direction "
                               "(r1x / r2x)", key="contact")
    D = c.patch.b / c.patch.a
    h1 = hc_piezo(v, scene.contact.load, c.E_star, c.rx, scene.lubricant.eta0, _ALPHA_REF, D)
    d = np.log(h) - np.log(h1)
    n = d.size
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    mean = float(np.mean(d))
    # E[(d_i - mean)^2] = s^2 (w_i (1 - 2/n) + sum(w)/n^2)
    expect = float(np.sum(w * (1.0 - 2.0 / n) + np.sum(w) / n**2))
    s2 = float(np.sum((d - mean) ** 2)) / max(expect, 1e-300)
    ln_alpha = math.log(_ALPHA_REF) + mean / HD_G_EXPONENT
    se_ln = math.sqrt(s2 * float(np.sum(w))) / n / HD_G_EXPONENT
    return math.exp(ln_alpha), se_ln, n - 1, d
