"""Pressure-viscosity fits: Barus alpha and Roelands Z (thesis Eqs. 5.38-5.39, Paper B).

Paper B measured the base ester oil "at 50 MPa steps up to 300 MPa at ambient
temperature 25 °C" and used the Barus (Eq. 5.39) and Roelands (Eq. 5.38)
equations "to estimate the pressure-viscosity coefficients".

* :func:`fit_barus`: ordinary least squares of ``ln eta = ln eta0 + alpha p``;
  standard errors from the residual variance ``s^2 = RSS/(n - 2)``
  (``se(alpha) = s / sqrt(Sxx)``, ``se(ln eta0) = s sqrt(1/n + pbar^2/Sxx)``)
  and two-sided Student-t intervals with ``n - 2`` degrees of freedom.
* :func:`fit_roelands`: nonlinear least squares (``scipy.optimize.least_squares``)
  of ``ln eta`` against :func:`torlab.model.viscosity.log_eta_roelands` for ``Z``
  (and ``ln eta0`` when asked or when no atmospheric point fixes it); covariance
  ``s^2 (J^T J)^-1`` at the solution, t-intervals with ``n - k`` degrees of freedom.

Residuals are in ``ln eta`` (relative errors, the natural scale of a viscosity
spanning decades).  The joint covariance of the fitted parameters is kept (the
Barus ``ln eta0``-``alpha`` estimates are strongly correlated: the intercept is
an extrapolation to p = 0) and written to ``params.yaml`` (``fit: covariance:``)
so predictions carry it (:mod:`torlab.model.bands`); for Roelands it also holds
the derived ``alpha*`` the Hamrock-Dowson film law uses, with its covariances
by the delta method.  The results carry ``warnings`` when the data cannot
determine a parameter well (Z from pressures all below 100 MPa, where Roelands
and Barus hardly differ; a relative standard error above 50 %); fewer points
than parameters + 1 is an error (no residual degree of freedom for an
uncertainty).

References
----------
.. [1] Roelands, C. J. A. (1966). Correlational aspects of the
   viscosity-temperature-pressure relationship of lubricating oils. PhD thesis, Delft
   University of Technology (no DOI).
.. [2] Barus, C. (1893). Isothermals, isopiestics and isometrics relative to viscosity.
   American Journal of Science s3-45(266), 87-96.
   https://doi.org/10.2475/ajs.s3-45.266.87
.. [3] Kvarda, D., Skurka, S., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J.,
   Krupka, I., Hartl, M. (2022). The effect of top of rail lubricant composition on
   adhesion and rheological behaviour. Engineering Science and Technology, an
   International Journal 35, 101100. https://doi.org/10.1016/j.jestch.2022.101100
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.errors import FitError, TorlabInputError
from torlab.fit.result import FitResult, student_t
from torlab.model.viscosity import (
    ROELANDS_C,
    ROELANDS_P0_INV,
    log_eta_barus,
    log_eta_roelands,
    roelands_alpha0,
)
from torlab.threads import small_problem

__all__ = ["ViscosityFit", "fit_barus", "fit_optional", "fit_roelands", "fit_viscosity"]

#: below this maximum pressure Z is poorly determined
Z_MIN_PRESSURE = 100e6
ATMOSPHERIC_MAX = 1e6
#: pressures within this range count as one pressure
ONE_PRESSURE = 1e6


_NAN = float("nan")


@dataclass
class ViscosityFit(FitResult):
    """A fitted pressure-viscosity law: a :class:`~torlab.fit.result.FitResult` with the
    law's own figures.

    The :class:`FitResult` side has ``kind="viscosity"``, parameters ``eta0``
    and ``alpha`` (Barus) or ``eta0`` and ``Z`` (Roelands; the equivalent
    ``alpha*`` as a fixed, derived value), 95 % intervals, the data against the
    law and the residuals in ``ln eta``; ``eta0`` given or taken from the
    atmospheric points is fixed (no interval).  The attributes below keep the
    fit's own view at its ``confidence`` level.

    Attributes
    ----------
    law
        ``"barus"`` or ``"roelands"``.
    eta0, eta0_ci
        Viscosity at p = 0 [Pa s] and its confidence interval.
    eta0_source
        ``"fitted"``, ``"given"`` or ``"measured at atmospheric pressure"``.
    alpha, alpha_se, alpha_ci
        Barus coefficient [1/Pa]; for Roelands the equivalent initial slope
        ``alpha* = (ln eta0 + 9.67) 5.1e-9 Z`` (:func:`roelands_alpha0`), no se.
    Z, Z_se, Z_ci
        Roelands pressure-viscosity index (Roelands only).
    confidence
        Level of these intervals (default 0.95).
    n, dof
        Points and residual degrees of freedom.
    rss, s
        Residual sum of squares and residual standard deviation (in ln eta).
    pressures_Pa, viscosity_Pa_s, residuals
        The data and the residuals ``ln eta - ln eta_fit``.
    temperature_C
        Mean temperature of the data, if known.
    """

    law: str = "barus"
    eta0: float = _NAN
    eta0_ci: tuple[float, float] = (_NAN, _NAN)
    eta0_source: str = ""
    alpha: float = _NAN
    alpha_se: float = _NAN
    alpha_ci: tuple[float, float] = (_NAN, _NAN)
    Z: float = _NAN
    Z_se: float = _NAN
    Z_ci: tuple[float, float] = (_NAN, _NAN)
    confidence: float = 0.95
    n: int = 0
    rss: float = 0.0
    s: float = 0.0
    pressures_Pa: np.ndarray = field(default_factory=lambda: np.empty(0))
    viscosity_Pa_s: np.ndarray = field(default_factory=lambda: np.empty(0))
    residuals: np.ndarray = field(default_factory=lambda: np.empty(0))
    temperature_C: float | None = None

    @classmethod
    def build(cls, *, law: str, eta0: float, eta0_se_log: float, eta0_source: str, alpha: float,
              alpha_se: float, confidence: float, dof: int, p: np.ndarray, eta: np.ndarray,
              residuals: np.ndarray, temperature_C: float | None, warnings: list[str],
              Z: float = _NAN, Z_se: float = _NAN, cov_log: Any = None) -> ViscosityFit:
        """The result from the estimates and their standard errors (intervals from Student t).

        ``cov_log`` is the covariance of the free parameters on the fit's own
        scale (``ln eta0`` for the viscosity, ``alpha`` or ``Z`` as they are),
        in the order ``eta0, alpha, Z`` of those that are free; it becomes
        :attr:`covariance` in natural units (``var eta0 = eta0^2 var ln eta0``).
        """
        import pandas as pd

        res = np.asarray(residuals, dtype=float)
        n = int(p.size)
        rss = float(res @ res)
        t_c, t95 = _t(confidence, dof), student_t(dof)

        def ci(v: float, se: float, t: float) -> tuple[float, float]:
            return (v - t * se, v + t * se) if math.isfinite(se) else (_NAN, _NAN)

        le = math.log(eta0)
        se0 = eta0_se_log if math.isfinite(eta0_se_log) else 0.0
        eta0_ci = (math.exp(le - t_c * se0), math.exp(le + t_c * se0))
        free = {"eta0": eta0_source == "fitted", "alpha": law == "barus", "Z": law == "roelands"}
        vals = {"eta0": eta0, "alpha": alpha, "Z": Z}
        ses = {"eta0": eta0 * eta0_se_log, "alpha": alpha_se, "Z": Z_se}
        names = tuple(k for k in ("eta0", "alpha", "Z") if free[k])
        ci95 = {k: ci(vals[k], ses[k], t95) for k in names}
        if "eta0" in ci95:
            ci95["eta0"] = (math.exp(le - t95 * eta0_se_log), math.exp(le + t95 * eta0_se_log))
        fixed = {k: vals[k] for k in ("eta0", "alpha") if not free[k]}
        corr = np.full((len(names), len(names)), np.nan)
        np.fill_diagonal(corr, 1.0)
        cov = None
        if cov_log is not None:
            c = np.asarray(cov_log, dtype=float).reshape(len(names), len(names))
            if np.all(np.isfinite(c)):
                scale = np.array([eta0 if k == "eta0" else 1.0 for k in names])
                cov = c * np.outer(scale, scale)
                sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
                with np.errstate(invalid="ignore", divide="ignore"):
                    corr = cov / np.outer(sd, sd)
                corr[~np.isfinite(corr)] = np.nan
                np.fill_diagonal(corr, 1.0)
        model = eta * np.exp(-res)
        data = pd.DataFrame({"pressure_Pa": p, "viscosity_measured_Pa_s": eta,
                             "viscosity_model_Pa_s": model, "residual_ln_eta": res})
        return cls(
            kind="viscosity", names=names, params={k: float(vals[k]) for k in names},
            stderr={k: float(ses[k]) if math.isfinite(ses[k]) else math.inf for k in names},
            ci95=ci95, correlation=corr, residual_norm=math.sqrt(rss / dof), n_points=n,
            warnings=warnings, data=data,
            meta={"law": law, "eta0_source": eta0_source, "temperature_C": temperature_C,
                  "lubricant_extra": {"viscosity": law},
                  "scatter": "one sample: the interval holds for these falls alone; the "
                             "scatter between samples is not estimated"},
            fixed=fixed, residual_unit="ln(Pa*s)", dof=int(dof), x_column="pressure_Pa",
            covariance=cov, log_scale=("eta0",) if "eta0" in names and cov is not None else (),
            y_column="viscosity_measured_Pa_s", law=law, eta0=eta0, eta0_ci=eta0_ci,
            eta0_source=eta0_source, alpha=alpha, alpha_se=alpha_se,
            alpha_ci=ci(alpha, alpha_se, t_c) if law == "barus" else (alpha, alpha), Z=Z,
            Z_se=Z_se, Z_ci=ci(Z, Z_se, t_c), confidence=confidence, n=n, rss=rss,
            s=math.sqrt(rss / dof), pressures_Pa=p, viscosity_Pa_s=eta, residuals=res,
            temperature_C=temperature_C)

    def predict(self, p: np.ndarray | float) -> np.ndarray:
        """Viscosity [Pa s] of the fitted law at ``p`` [Pa]."""
        if self.law == "barus":
            return np.exp(log_eta_barus(p, self.eta0, self.alpha))
        return np.exp(log_eta_roelands(p, self.eta0, self.Z))

    def to_scene_dict(self) -> dict[str, Any]:
        """The scene contract's ``lubricant:`` keys (``eta0``, ``viscosity``, ``alpha``, ``Z``).

        Quantities are strings with units (``"65.1234567 mPa*s"``, ``"14.9 1/GPa"``),
        written with 12 significant digits so that the scene's values are the
        estimates the covariance belongs to (a band needs them equal to 1e-9);
        for Roelands ``alpha`` is the equivalent initial coefficient ``alpha*``
        (the Hamrock-Dowson G needs one).
        """
        d: dict[str, Any] = {
            "eta0": f"{self.eta0 * 1e3:.12g} mPa*s",
            "viscosity": self.law,
            "alpha": f"{self.alpha * 1e9:.12g} 1/GPa",
        }
        if self.law == "roelands":
            d["Z"] = float(f"{self.Z:.12g}")
        return {"lubricant": d}

    def covariance_section(self) -> dict[str, Any] | None:
        """The ``fit: covariance:`` block; for Roelands with the derived ``alpha*``.

        ``alpha* = (ln eta0 + 9.67) 5.1e-9 Z`` (:func:`roelands_alpha0`) is what
        the scene's piezo-viscous film law uses; its variance and covariances
        with ``eta0`` and ``Z`` follow by the delta method, so the block is
        singular (rank of the free parameters) but positive semi-definite.
        """
        cs = super().covariance_section()
        if cs is None or self.law != "roelands" or "alpha" in cs["names"]:
            return cs
        names = list(cs["names"])
        c = np.asarray(cs["matrix"], dtype=float)
        g = np.array([ROELANDS_P0_INV * self.Z / self.eta0 if n == "eta0" else
                      (math.log(self.eta0) + ROELANDS_C) * ROELANDS_P0_INV if n == "Z" else 0.0
                      for n in names])
        cg = c @ g
        full = np.zeros((len(names) + 1, len(names) + 1))
        full[:-1, :-1] = c
        full[:-1, -1] = full[-1, :-1] = cg
        full[-1, -1] = float(g @ cg)
        cs["names"] = [*names, "alpha"]
        cs["values"] = [*cs["values"], float(self.alpha)]
        cs["matrix"] = [[float(x) for x in row] for row in full]
        return cs

    def row(self) -> dict[str, Any]:
        """One flat row (SI units) for ``fit.csv``."""
        lo, hi = self.confidence_label()
        return {
            "law": self.law,
            "eta0_Pa_s": self.eta0,
            f"eta0_{lo}_Pa_s": self.eta0_ci[0],
            f"eta0_{hi}_Pa_s": self.eta0_ci[1],
            "eta0_source": self.eta0_source,
            "alpha_1_Pa": self.alpha,
            "alpha_se_1_Pa": self.alpha_se,
            f"alpha_{lo}_1_Pa": self.alpha_ci[0],
            f"alpha_{hi}_1_Pa": self.alpha_ci[1],
            "Z": self.Z,
            "Z_se": self.Z_se,
            f"Z_{lo}": self.Z_ci[0],
            f"Z_{hi}": self.Z_ci[1],
            "confidence": self.confidence,
            "n": self.n,
            "dof": self.dof,
            "residual_sd_ln_eta": self.s,
            "pressure_min_Pa": float(np.min(self.pressures_Pa)),
            "pressure_max_Pa": float(np.max(self.pressures_Pa)),
            "temperature_C": float("nan") if self.temperature_C is None else self.temperature_C,
            "warnings": "; ".join(self.warnings),
        }

    def confidence_label(self) -> tuple[str, str]:
        """Column tags of the interval ends, e.g. ``("ci95_low", "ci95_high")``."""
        c = f"{100 * self.confidence:g}".replace(".", "_")
        return f"ci{c}_low", f"ci{c}_high"


#: fit.csv columns that may be empty (Z of a Barus fit, alpha se of a Roelands fit ...)
FIT_OPTIONAL = ("alpha_se_1_Pa", "Z", "Z_se", "Z_ci95_low", "Z_ci95_high", "temperature_C")


def fit_optional(columns: Any) -> tuple[str, ...]:
    """The columns of a ``fit.csv`` table that may be empty."""
    return tuple(c for c in columns if c.startswith(("Z", "alpha_se", "temperature")))


def _check(p: Any, eta: Any, k: int, law: str) -> tuple[np.ndarray, np.ndarray]:
    p = np.asarray(p, dtype=float).ravel()
    eta = np.asarray(eta, dtype=float).ravel()
    if p.shape != eta.shape:
        raise TorlabInputError(f"{law} fit: {p.size} pressures but {eta.size} viscosities")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(eta))):
        raise TorlabInputError(f"{law} fit: pressures and viscosities must be finite numbers")
    if np.any(eta <= 0):
        raise TorlabInputError(f"{law} fit: viscosities must be positive")
    if np.any(p < 0):
        raise TorlabInputError(f"{law} fit: pressures must not be negative")
    if p.size < k + 1:
        raise TorlabInputError(f"{law} fit needs at least {k + 1} points for {k} parameter"
                               f"{'s' if k > 1 else ''} with an uncertainty, got {p.size}")
    return p, eta


def _t(confidence: float, dof: int) -> float:
    from torlab._stats import t_ppf  # scipy.stats.t.ppf, without its import

    if not (0 < confidence < 1):
        raise TorlabInputError(f"confidence must be in (0, 1), got {confidence}", key="confidence")
    return float(t_ppf(0.5 + confidence / 2, dof))


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_barus(p: Any, eta: Any, *, confidence: float = 0.95,
              temperature_C: float | None = None) -> ViscosityFit:
    """Barus fit ``ln eta = ln eta0 + alpha p`` (Eq. 5.39) by ordinary least squares.

    Parameters
    ----------
    p, eta
        Pressures [Pa] and viscosities [Pa s], one per measurement.
    confidence
        Level of the Student-t intervals.
    temperature_C
        Recorded in the result.

    Raises
    ------
    TorlabInputError
        Fewer than 3 points, all at one pressure, or bad values.
    """
    p, eta = _check(p, eta, 2, "Barus")
    y = np.log(eta)
    n = p.size
    pm = p.mean()
    sxx = float(np.sum((p - pm) ** 2))
    if sxx <= 0 or np.ptp(p) < ONE_PRESSURE:
        raise TorlabInputError("Barus fit: all points are at one pressure (within 1 MPa); alpha "
                               "needs several")
    alpha = float(np.sum((p - pm) * (y - y.mean())) / sxx)
    a = float(y.mean() - alpha * pm)
    res = y - (a + alpha * p)
    dof = n - 2
    s = math.sqrt(float(np.sum(res * res)) / dof)
    se_alpha = s / math.sqrt(sxx)
    se_a = s * math.sqrt(1.0 / n + pm * pm / sxx)
    _t(confidence, dof)  # checks the level
    warnings = []
    if np.ptp(p) < 50e6:
        warnings.append(f"alpha from a narrow pressure range ({np.ptp(p) / 1e6:.3g} MPa)")
    if alpha != 0 and se_alpha > 0.5 * abs(alpha):
        warnings.append(f"alpha is poorly determined (standard error {se_alpha / abs(alpha):.0%})")
    if n >= 4 and np.unique(p).size >= 3:
        # curvature of ln eta against p: the quadratic term's t statistic
        z = (p - pm) / math.sqrt(sxx / n)
        X = np.column_stack((np.ones(n), z, z * z))
        coef, rss2, *_ = np.linalg.lstsq(X, y, rcond=None)
        if rss2.size and n > 3:
            s2 = float(rss2[0]) / (n - 3)
            cov = s2 * np.linalg.inv(X.T @ X)
            tstat = coef[2] / math.sqrt(cov[2, 2]) if cov[2, 2] > 0 else math.inf
            if abs(tstat) > 3:
                warnings.append(f"ln eta is curved against p (quadratic term t = {tstat:.3g}): "
                                "the Barus law does not describe these data over the whole range; "
                                "alpha is a secant (compare the Roelands fit)")
    # ln eta0 (the intercept) and alpha: cov = s^2 (X^T X)^-1, off-diagonal -s^2 pbar / Sxx
    cov_log = np.array([[se_a * se_a, -s * s * pm / sxx], [-s * s * pm / sxx, se_alpha * se_alpha]])
    return ViscosityFit.build(
        law="barus", eta0=math.exp(a), eta0_se_log=se_a, eta0_source="fitted", alpha=alpha,
        alpha_se=se_alpha, confidence=confidence, dof=dof, p=p, eta=eta, residuals=res,
        temperature_C=temperature_C, warnings=warnings, cov_log=cov_log)


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_roelands(p: Any, eta: Any, *, eta0: float | None = None, fit_eta0: bool | None = None,  # noqa: C901 (the fit's checks and fallbacks, each said in its result)
                 confidence: float = 0.95, temperature_C: float | None = None) -> ViscosityFit:
    """Roelands fit (Eq. 5.38) of ``Z`` (and ``eta0``) by nonlinear least squares in ``ln eta``.

    Parameters
    ----------
    p, eta
        Pressures [Pa] and viscosities [Pa s].
    eta0
        Fix ``eta0`` [Pa s] and fit ``Z`` only.
    fit_eta0
        Fit ``eta0`` together with ``Z``.  Default (``None``): fix ``eta0`` at
        the points at atmospheric pressure (p <= 1 MPa) if there are any (their
        geometric mean, brought to p = 0 with the fitted law), otherwise fit it
        (with a warning).
    confidence
        Level of the Student-t intervals.
    temperature_C
        Recorded in the result.

    Raises
    ------
    TorlabInputError
        Too few points for the parameters, bad values.
    FitError
        The optimiser fails.
    """
    from scipy.optimize import least_squares

    p0 = np.asarray(p, dtype=float).ravel()
    warnings: list[str] = []
    if eta0 is not None:
        if not (math.isfinite(eta0) and eta0 > 0):
            raise TorlabInputError(f"eta0 must be a positive viscosity, got {eta0}", key="eta0")
        source, free_eta0 = "given", False
    elif fit_eta0:
        source, free_eta0 = "fitted", True
    else:
        atm = p0 <= ATMOSPHERIC_MAX if p0.size else np.zeros(0, bool)
        e = np.asarray(eta, dtype=float).ravel()
        if fit_eta0 is None and atm.any() and atm.size == e.size and np.all(e[atm] > 0):
            eta0 = float(np.exp(np.mean(np.log(e[atm]))))
            source, free_eta0 = f"measured at atmospheric pressure ({int(atm.sum())} points)", False
        else:
            source, free_eta0 = "fitted", True
            if fit_eta0 is None:
                warnings.append("no point at atmospheric pressure: eta0 fitted together with Z")
    k = 2 if free_eta0 else 1
    p, e = _check(p, eta, k, "Roelands")
    if np.ptp(p) < ONE_PRESSURE:
        raise TorlabInputError("Roelands fit: all points are at one pressure (within 1 MPa); Z "
                               "needs several")
    y = np.log(e)
    atm_sel = (p <= ATMOSPHERIC_MAX) if source.startswith("measured") else None
    if not free_eta0 and eta0 is not None and math.log(eta0) + 9.67 <= 0:
        raise TorlabInputError(f"eta0 = {eta0:g} Pa s is below the Roelands limit 6.3e-5 Pa s")
    # start: Z from the Barus slope of the data (alpha* = (ln eta0 + 9.67) 5.1e-9 Z)
    le0 = math.log(eta0) if eta0 is not None else float(y[np.argmin(p)])
    slope = np.polyfit(p, y, 1)[0] if np.ptp(p) > 0 else 0.0
    z0 = float(np.clip(slope / ((le0 + 9.67) * 5.1e-9), 0.05, 3.0)) if le0 > -9.67 else 0.5

    def resid(x: np.ndarray) -> np.ndarray:
        le = x[1] if free_eta0 else math.log(eta0)  # type: ignore[arg-type]
        return y - log_eta_roelands(p, math.exp(le), x[0])

    x0 = np.array([z0, le0]) if free_eta0 else np.array([z0])
    for _ in range(4 if atm_sel is not None else 1):
        try:
            sol = least_squares(resid, x0, method="trf", x_scale="jac", xtol=1e-14, ftol=1e-14,
                                gtol=1e-14, max_nfev=2000)
        except Exception as ex:  # scipy raises several classes for degenerate data
            raise FitError(f"Roelands fit failed ({type(ex).__name__}: {ex})") from None
        if not sol.success:
            raise FitError(f"Roelands fit did not converge ({sol.message})")
        if atm_sel is None:
            break
        # eta0 from the atmospheric points, brought from their pressure to p = 0 with the
        # current Z (a 0.1 MPa point is about 0.15 % above eta0 for an ester)
        le_new = float(np.mean(y[atm_sel] - (log_eta_roelands(p[atm_sel], eta0, sol.x[0])
                                             - math.log(eta0))))
        if abs(le_new - math.log(eta0)) < 1e-12:
            break
        eta0 = math.exp(le_new)
        x0 = sol.x
    Z = float(sol.x[0])
    le = float(sol.x[1]) if free_eta0 else math.log(eta0)  # type: ignore[arg-type]
    res = sol.fun
    dof = p.size - k
    s = math.sqrt(float(np.sum(res * res)) / dof)
    jtj = sol.jac.T @ sol.jac
    _t(confidence, dof)  # checks the level
    cond = np.linalg.cond(jtj)
    if not np.isfinite(cond) or cond > 1e14:
        cov = np.full((k, k), np.nan)
        warnings.append("the data do not determine the parameters (singular Jacobian)")
    else:
        cov = s * s * np.linalg.inv(jtj)
    z_se = float(math.sqrt(cov[0, 0])) if np.isfinite(cov[0, 0]) and cov[0, 0] >= 0 else float("nan")
    le_se = math.sqrt(cov[1, 1]) if free_eta0 and np.isfinite(cov[1, 1]) else \
        (float("nan") if free_eta0 else 0.0)
    if float(np.max(p)) < Z_MIN_PRESSURE:
        warnings.append(f"Z is poorly determined: all pressures are below "
                        f"{Z_MIN_PRESSURE / 1e6:g} MPa, where the Roelands and Barus laws hardly "
                        "differ")
    if np.isfinite(z_se) and Z != 0 and z_se > 0.5 * abs(Z):
        warnings.append(f"Z is poorly determined (standard error {z_se / abs(Z):.0%})")
    a0 = float(roelands_alpha0(math.exp(le), Z))
    # free parameters in the result's order (eta0, Z): x = (Z, ln eta0) reordered
    cov_log = cov[::-1, ::-1] if free_eta0 else cov
    return ViscosityFit.build(
        law="roelands", eta0=math.exp(le), eta0_se_log=le_se, eta0_source=source, alpha=a0,
        alpha_se=float("nan"), Z=Z, Z_se=z_se, confidence=confidence, dof=dof, p=p, eta=e,
        residuals=np.asarray(res, dtype=float), temperature_C=temperature_C, warnings=warnings,
        cov_log=cov_log)


def fit_viscosity(p: Any, eta: Any, law: str = "barus", **kw: Any) -> ViscosityFit:
    """:func:`fit_barus` or :func:`fit_roelands` by name."""
    if law == "barus":
        return fit_barus(p, eta, **kw)
    if law == "roelands":
        return fit_roelands(p, eta, **kw)
    raise TorlabInputError(f"unknown viscosity law {law!r} (barus, roelands)", key="law")
