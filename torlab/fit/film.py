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
of freedom from the scatter about the fitted line.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
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
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ coef
    n = v.size
    dof = n - 2
    s2 = float(r @ r) / dof
    cov = s2 * np.linalg.inv(X.T @ X)
    lnC, nexp = float(coef[0]), float(coef[1])
    se_n, se_lnC = math.sqrt(cov[1, 1]), math.sqrt(cov[0, 0])
    tq = student_t(dof)
    names: list[str] = ["speed_exponent", "film_prefactor"]
    params = {"speed_exponent": nexp, "film_prefactor": math.exp(lnC)}
    stderr = {"speed_exponent": se_n, "film_prefactor": math.exp(lnC) * se_lnC}
    ci = {"speed_exponent": (nexp - tq * se_n, nexp + tq * se_n),
          "film_prefactor": (math.exp(lnC - tq * se_lnC), math.exp(lnC + tq * se_lnC))}
    k = 2
    corr = np.array([[1.0, cov[0, 1] / math.sqrt(cov[0, 0] * cov[1, 1])],
                     [cov[0, 1] / math.sqrt(cov[0, 0] * cov[1, 1]), 1.0]])
    corr = corr[::-1, ::-1]  # order: exponent, prefactor
    warnings: list[str] = []
    meta: dict[str, Any] = {"method": "least squares of ln h on ln v (Hamrock-Dowson form, Eq. 5.32)",
                            "min_speed_m_s": min_speed, "speed_range_m_s": [float(v.min()),
                                                                            float(v.max())]}
    if not (ci["speed_exponent"][0] <= HD_SPEED_EXPONENT <= ci["speed_exponent"][1]):
        warnings.append(f"speed exponent {nexp:.3f} differs from Hamrock-Dowson's 0.67 beyond its "
                        "95 % interval: the effective alpha then depends on the speed range")
    h_model = np.exp(X @ coef)
    data = pd.DataFrame({"speed_m_s": v, "film_thickness_measured_m": h,
                         "film_thickness_model_m": h_model, "residual_m": h - h_model,
                         "residual_ln": r})
    if scene is not None:
        a_val, a_se_ln, a_dof, d_ln = _effective_alpha(scene, v, h)
        names.append("alpha")
        tqa = student_t(a_dof)
        params["alpha"] = a_val
        stderr["alpha"] = a_val * a_se_ln
        ci["alpha"] = (a_val * math.exp(-tqa * a_se_ln), a_val * math.exp(tqa * a_se_ln))
        corr = np.pad(corr, ((0, 1), (0, 1)))
        corr[2, :2] = np.nan
        corr[:2, 2] = np.nan
        corr[2, 2] = 1.0
        data["film_thickness_hamrock_dowson_m"] = h * np.exp(-(d_ln - HD_G_EXPONENT
                                                               * math.log(a_val / _ALPHA_REF)))
        meta["lubricant_extra"] = {}
        meta["eta0_Pa_s"] = float(scene.lubricant.eta0)
        meta["alpha_note"] = ("effective alpha: the Hamrock-Dowson G that reproduces the measured "
                              "films with the scene's eta0 (at the test temperature)")
        k = 3
    res = FitResult(kind="film", names=tuple(names), params=params, stderr=stderr, ci95=ci,
                    correlation=corr[:k, :k], residual_norm=float(np.sqrt(np.mean((h - h_model) ** 2))),
                    n_points=int(n), warnings=warnings, data=data, meta=meta, residual_unit="m",
                    n_evaluations=1, dof=dof, x_column="speed_m_s",
                    y_column="film_thickness_measured_m")
    return res


_ALPHA_REF = 10e-9


def _effective_alpha(scene: Any, v: np.ndarray, h: np.ndarray) -> tuple[float, float, int, np.ndarray]:
    """``alpha`` (1/Pa), the standard error of ``ln alpha``, dof, and the log ratios."""
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
    mean = float(np.mean(d))
    sd = float(np.std(d, ddof=1))
    ln_alpha = math.log(_ALPHA_REF) + mean / HD_G_EXPONENT
    se_ln = sd / math.sqrt(n) / HD_G_EXPONENT
    return math.exp(ln_alpha), se_ln, n - 1, d
