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

Temperature scaling (:func:`fit_film_temperature`): from one such fit per
temperature, the film at a reference speed inside every curve's range,
``ln h(v_ref; T) = ln h(v_ref; T_ref) + b (T - T_ref)``, by weighted least squares
with each fit's own variance of ``ln h(v_ref)``.  In Hamrock-Dowson's formula the
film depends on the lubricant only through ``eta0^0.67 alpha^0.53`` (``U`` and
``G``); at one contact, load and speed ``b = 0.67 d ln eta0/dT + 0.53 d ln alpha/dT``
is what the data resolve, without the contact's geometry or materials, and without
the ambient viscosity.  The speed exponents of the temperatures are compared in the
same result: Welch's test of one common exponent for estimates whose variances are
themselves estimated (each from its fit's scatter, on its own degrees of freedom;
Welch 1951, Biometrika 38, 330), which a plain chi-squared with those variances taken
as known would reject too often.

Intervals are Student-t with ``n - 2`` (exponent) and ``n - 1`` (alpha) degrees
of freedom from the scatter about the fitted line; the prefactor and ``alpha``
are positive and get log-scale intervals.  A scatter proportional to ``h`` is
constant in ``ln h``; one of constant size (the interferometer's nanometres)
grows as ``1/h`` there and dominates the slow, thin films.  A variance function
estimated from the residuals (constant plus proportional, maximum likelihood)
weights the points when a likelihood-ratio test prefers it to constant
scatter in ``ln h`` (:func:`torlab.fit._noise.linear_least_squares`; one
degree of freedom less).

References
----------
.. [1] Hamrock, B. J., Dowson, D. (1977). Isothermal elastohydrodynamic lubrication of point
   contacts: Part III - Fully flooded results. Journal of Lubrication Technology 99(2),
   264-275. https://doi.org/10.1115/1.3453074
.. [2] Kvarda, D., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J., Krupka, I.,
   Hartl, M. (2021). Asperity-based model for prediction of traction in
   water-contaminated wheel-rail contact. Tribology International 157, 106900.
   https://doi.org/10.1016/j.triboint.2021.106900
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.fit._noise import linear_least_squares
from torlab.fit.result import FitResult, student_t
from torlab.threads import small_problem

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["HD_SPEED_EXPONENT", "fit_film_temperature", "fit_film_thickness"]

#: Hamrock-Dowson exponents of U and G (Eq. 5.32)
HD_SPEED_EXPONENT = 0.67
HD_G_EXPONENT = 0.53


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_film_thickness(speed_m_s: Any, h_m: Any, *, scene: Scene | None = None,
                       min_speed: float | None = None) -> FitResult:
    """Fit the film's speed exponent and (with a scene) the effective alpha.

    Parameters
    ----------
    speed_m_s, h_m
        Rolling (entrainment) speeds [m/s] and central film thicknesses [m].
    scene
        A :class:`~torlab.scene.Scene` with ``contact``, ``materials`` and
        ``lubricant.eta0`` (the viscosity at the test temperature) for the
        effective pressure-viscosity coefficient; None for the exponent only.
    min_speed
        Use only points at or above this speed [m/s].

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
    from torlab.random_effects import ONE_RUN

    res.meta.setdefault("scatter", ONE_RUN)  # one curve: its record's intervals
    return res


_ALPHA_REF = 10e-9


def _effective_alpha(scene: Scene, v: np.ndarray, h: np.ndarray, weights: np.ndarray | None = None
                     ) -> tuple[float, float, int, np.ndarray]:
    """``alpha`` [1/Pa], the standard error of ``ln alpha``, dof, and the log ratios.

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


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_film_temperature(fits: Any, temperatures_C: Any, *,
                         reference_speed: float | None = None) -> FitResult:
    """Temperature scaling of the film from one film fit per temperature.

    Parameters
    ----------
    fits
        :class:`FitResult` of :func:`fit_film_thickness`, one per temperature (at
        least two, at temperatures at least 2 K apart).
    temperatures_C
        Their temperatures [degC].
    reference_speed
        Speed [m/s] at which the films are compared; default the geometric centre of
        the speed range every fit covers.

    Returns
    -------
    FitResult
        ``kind="film_temperature"``: ``film_at_reference`` (m, the film at the
        reference speed and the lowest temperature) and
        ``film_temperature_coefficient`` (1/K, ``d ln h / dT`` at the reference
        speed; Hamrock-Dowson: ``0.67 d ln eta0/dT + 0.53 d ln alpha/dT``).  Intervals
        from the fits' own variances (normal quantiles), widened by the Birge
        ratio ``sqrt(chi2 / (k - 2))`` with Student-t on ``k - 2`` degrees of freedom
        when the films scatter more about the line than their variances say.
        ``meta["speed_exponents"]`` compares the exponents: their weighted mean,
        the chi-squared about it, Welch's F against one common exponent with its
        degrees of freedom and p-value, and Hamrock-Dowson's 0.67 against each
        interval.  ``meta["viscosity_ratio_if_alpha_constant"]``
        is ``eta0(T) / eta0(T_ref) = exp(b (T - T_ref) / 0.67)`` at each temperature,
        which holds only where alpha does not change with temperature.

    Raises
    ------
    TorlabInputError
        Fewer than two fits, temperatures closer than 2 K, no common speed range
        (give ``reference_speed``), a fit without a covariance.
    """
    import pandas as pd

    from torlab._stats import f_sf

    fits = list(fits)
    T = np.asarray(temperatures_C, dtype=float).ravel()
    if len(fits) < 2 or T.size != len(fits):
        raise TorlabInputError("temperature scaling: needs one film fit per temperature, at "
                               "least two")
    if not np.all(np.isfinite(T)) or np.min(np.diff(np.sort(T))) < 2.0:
        raise TorlabInputError("temperature scaling: the curves' temperatures must differ by "
                               f"at least 2 K (got {', '.join(f'{t:.1f}' for t in T)} degC)")
    lo = max(float(f.meta["speed_range_m_s"][0]) for f in fits)
    hi = min(float(f.meta["speed_range_m_s"][1]) for f in fits)
    if reference_speed is None:
        if not lo < hi:
            raise TorlabInputError("temperature scaling: the curves share no speed range; give "
                                   "the reference speed", key="reference_speed")
        v_ref = math.sqrt(lo * hi)
    else:
        v_ref = float(reference_speed)
        if not (math.isfinite(v_ref) and v_ref > 0):
            raise TorlabInputError(f"must be a positive speed, got {reference_speed!r}",
                                   key="reference_speed")
    x = math.log(v_ref)
    y, var, n_exp, n_se, n_ci, n_dof = [], [], [], [], [], []
    for f in fits:
        cov = np.asarray(f.covariance, dtype=float)
        C, n = f.params["film_prefactor"], f.params["speed_exponent"]
        # (exponent, C) -> (exponent, ln C): the prefactor's row and column over C
        J = np.diag([1.0, 1.0 / C])
        c2 = J @ cov[:2, :2] @ J
        g = np.array([x, 1.0])
        y.append(math.log(C) + n * x)
        var.append(float(g @ c2 @ g))
        n_exp.append(n)
        n_se.append(f.stderr["speed_exponent"])
        n_ci.append(f.ci95["speed_exponent"])
        n_dof.append(float(f.meta.get("interval_dof", {}).get("speed_exponent", f.dof)))
    y, var = np.array(y), np.array(var)
    if not np.all(np.isfinite(var) & (var > 0)):
        raise TorlabInputError("temperature scaling: every film fit needs a finite covariance")
    k = T.size
    T_ref = float(np.min(T))
    X = np.column_stack((np.ones(k), T - T_ref))
    W = 1.0 / var
    A = X.T @ (X * W[:, None])
    cov = np.linalg.inv(A)
    coef = cov @ (X.T @ (W * y))
    r = y - X @ coef
    chi2 = float(np.sum(W * r**2))
    birge = math.sqrt(chi2 / (k - 2)) if k > 2 else float("nan")
    scaled = k > 2 and birge > 1.0
    if scaled:
        cov = cov * birge**2
    dof = k - 2 if scaled else 10**6
    # exponents: one common exponent?  Welch's heteroscedastic test (the variances are
    # estimates on each fit's degrees of freedom)
    w = 1.0 / np.square(n_se)
    n_bar = float(np.sum(w * n_exp) / np.sum(w))
    chi2_n = float(np.sum(w * (np.asarray(n_exp) - n_bar) ** 2))
    lam = float(np.sum((1.0 - w / np.sum(w)) ** 2 / np.maximum(n_dof, 1.0)))
    f_welch = chi2_n / (k - 1) / (1.0 + 2.0 * (k - 2) / (k * k - 1) * lam)
    dof2 = (k * k - 1) / (3.0 * lam) if lam > 0 else float("inf")
    p_n = float(f_sf(f_welch, k - 1, min(dof2, 1e6)))
    h_ref = np.exp(y)
    h_mod = np.exp(X @ coef)
    data = pd.DataFrame({"temperature_C": T, "film_thickness_measured_m": h_ref,
                         "film_thickness_model_m": h_mod, "film_thickness_se_ln": np.sqrt(var),
                         "residual_m": h_ref - h_mod, "residual_ln": r,
                         "speed_exponent": n_exp, "speed_exponent_stderr": n_se})
    b = float(coef[1])
    names = ("film_at_reference", "film_temperature_coefficient")
    values = np.array([math.exp(coef[0]), b])
    jac = np.diag([values[0], 1.0])
    warnings = []
    if scaled:
        warnings.append(f"the films at {v_ref:.3g} m/s scatter {birge:.2g} times more about an "
                        "exponential in temperature than the fits' own errors: intervals widened "
                        f"by that factor, Student-t on {k - 2} degree(s) of freedom")
    if p_n < 0.05:
        warnings.append(f"the speed exponents differ between the temperatures (Welch's F "
                        f"{f_welch:.3g} on {k - 1} and {dof2:.3g} dof, p = {p_n:.2g}): the "
                        "film's temperature scaling depends on the reference speed")
    outside = [f"{t:.1f} degC" for t, ci in zip(T, n_ci, strict=True)
               if not (ci[0] <= HD_SPEED_EXPONENT <= ci[1])]
    meta = {
        "method": ("weighted least squares of ln h(v_ref) on T, weights the film fits' own "
                   "variances at v_ref" + (" (widened by the Birge ratio)" if scaled else "")),
        "reference_speed_m_s": v_ref, "reference_temperature_C": T_ref,
        "common_speed_range_m_s": [lo, hi] if lo < hi else None,
        "chi2": chi2, "birge_ratio": birge if k > 2 else None,
        "speed_exponents": {
            "values": [float(v) for v in n_exp], "stderr": [float(v) for v in n_se],
            "dof_each": n_dof, "weighted_mean": n_bar, "chi2_one_exponent": chi2_n,
            "welch_f": f_welch, "dof": [k - 1, dof2], "p_one_exponent": p_n,
            "hamrock_dowson": HD_SPEED_EXPONENT,
            "hamrock_dowson_outside_interval_at": outside},
        "viscosity_ratio_if_alpha_constant": {
            f"{t:.1f}": math.exp(b * (t - T_ref) / HD_SPEED_EXPONENT) for t in T},
        "resolvable": ("b = 0.67 d ln eta0/dT + 0.53 d ln alpha/dT (Hamrock-Dowson); eta0 and "
                       "alpha apart, and their values, need the lubricant's viscosity"),
    }
    return FitResult.from_covariance(
        "film_temperature", names, values, jac @ cov @ jac, dof=int(min(dof, 10**6)),
        param_dof=[dof, dof], log_scale=("film_at_reference",),
        residual_norm=float(np.sqrt(np.mean((h_ref - h_mod) ** 2))), n_points=int(k),
        warnings=warnings, data=data, meta=meta, residual_unit="m", n_evaluations=1,
        x_column="temperature_C", y_column="film_thickness_measured_m")

