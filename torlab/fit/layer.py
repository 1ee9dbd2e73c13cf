"""Third-body layer parameters from HPT curves: ``mu_c1, mu_c2, L_mue, L_mup``.

The model is the layer law of :mod:`torlab.model.layer` at the run's normal
stress ``sigma`` (thesis Eqs. 5.24, 5.26-5.29, as
``docs/model/thesis-reading.md`` reads them): elastic ``tau = u sigma / L_mue`` up to
``tau_c1 = mu_c1 sigma``, then Voce towards ``tau_c2 = mu_c2 sigma`` with the
length ``L_mup``.  The rig's own compliance ``u_rig(tau)`` is part of the
model, as in the measurement: the angle measures
``u_raw = u_layer + u_rig(tau)``, so the model is evaluated on a fine grid of
the layer displacement, mapped to ``u_raw`` and interpolated at the measured
``displacement_raw_m`` (the shear stress is the quantity with the noise; the
displacement from the motor angle is exact to 0.04 um).  Subtracting the
compliance from ``u`` with the *measured* stress instead would move the noise
of ``tau`` into ``u``, amplified by the steep elastic slope.

The compliance is the one the reduction subtracted (``torlab hpt reduce
--compliance``; recovered exactly from the ``displacement_raw_m`` and
``displacement_m`` columns) or the ``compliance`` argument.  Without any, the
fitted ``L_mue`` includes the rig and the result says so.

Uncertainties: least squares gives the estimate; the covariance propagates a
noise model estimated from the residuals (relative white + AR(1), see
:mod:`torlab.fit._noise`), because an HPT record's residuals are strongly
correlated (the layer's strength fluctuates over seconds).

Fitted on the loading branch (up to the maximum displacement).  Several curves
of one product are fitted jointly (``joint=True``): the four parameters are
shared, each curve keeps its own normal stress and compliance.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import FitError, TorlabInputError
from torlab.fit._noise import (
    NoiseModel,
    effective_points,
    estimate_noise,
    parameter_dof,
    sandwich_covariance,
)
from torlab.fit.result import FitResult
from torlab.threads import small_problem

__all__ = ["LAYER_NAMES", "HptCurve", "fit_layer_hpt", "fit_layers_hpt", "hpt_curve",
           "tau_of_raw_displacement"]

LAYER_NAMES = ("mu_c1", "mu_c2", "L_mue", "L_mup")
#: internal parameter scaling: mu as is, lengths in um
_SCALE = np.array([1.0, 1.0, 1e-6, 1e-6])
_LOWER = np.array([1e-4, 1e-4, 1e-3, 1e-3])  # mu, mu, um, um
_UPPER = np.array([5.0, 5.0, 1e3, 1e4])
#: fewest loading-branch points for a fit with uncertainties
MIN_POINTS = 12


@dataclass
class HptCurve:
    """One HPT loading curve ready for the fit (SI units).

    Attributes
    ----------
    u_raw
        Displacement from the angle (m), rig compliance included.
    tau
        Shear stress (Pa).
    sigma
        Normal stress (Pa), the mean over the loading branch unless given.
    compliance
        ``u_rig(tau)`` (m) or None.
    meta
        Product, amount, temperature, source ...
    """

    u_raw: np.ndarray
    tau: np.ndarray
    sigma: float
    compliance: Callable[[np.ndarray], np.ndarray] | None = None
    meta: dict[str, Any] = field(default_factory=dict)


def tau_of_raw_displacement(u_raw: np.ndarray, sigma: float, x: Sequence[float],
                            compliance: Callable[[np.ndarray], np.ndarray] | None = None, *,
                            n_elastic: int = 48, n_plastic: int = 320) -> np.ndarray:
    """Layer-law shear stress (Pa) at the *measured* displacement ``u_raw`` (m).

    ``x = (mu_c1, mu_c2, L_mue, L_mup)`` in SI.  The law (:func:`torlab.model.layer.hpt_tau`,
    Eqs. 5.24, 5.26-5.29) is tabulated on the layer displacement -- uniform in
    ``tau`` on the elastic branch, geometric in ``u - u_y`` with the Voce length
    on the plastic one -- and ``u_raw = u_layer + u_rig(tau)`` is inverted by
    monotone interpolation (piecewise-linear error below 1e-4 of ``tau_c2 - tau_c1``).
    """
    mu1, mu2, lme, lmp = (float(v) for v in x)
    u_raw = np.asarray(u_raw, dtype=float)
    t1, t2 = mu1 * sigma, mu2 * sigma
    le = lme / sigma
    tau_el = np.linspace(0.0, t1, n_elastic)
    ul_el = tau_el * le
    uy = t1 * le
    span = max(float(np.max(u_raw)) - uy, 0.0) * 1.05 + 1e-9
    lp = max(lmp, 1e-12)
    s = np.geomspace(min(1e-4 * lp, 0.5 * span), max(span, 2e-4 * lp), n_plastic)
    tau_pl = t1 + (t2 - t1) * -np.expm1(-s / lp)
    ul = np.concatenate((ul_el, uy + s))
    tau = np.concatenate((tau_el, tau_pl))
    ur = ul + (np.asarray(compliance(tau), dtype=float) - float(compliance(np.zeros(1))[0])
               if compliance is not None else 0.0)
    ur = np.maximum.accumulate(ur)
    out = np.interp(u_raw, ur, tau)
    neg = u_raw < 0
    if neg.any():
        slope = (tau[1] - tau[0]) / max(ur[1] - ur[0], 1e-30)
        out[neg] = u_raw[neg] * slope
    return out


# ---------------------------------------------------------------------------------------------
# input preparation
# ---------------------------------------------------------------------------------------------
def _compliance_from_columns(tau: np.ndarray, du: np.ndarray) -> Callable[[np.ndarray], np.ndarray] | None:
    """The compliance the reduction subtracted, from ``u_raw - u`` against ``tau``."""
    if not np.any(np.abs(du) > 1e-12):
        return None
    order = np.argsort(tau, kind="stable")
    t, d = tau[order], du[order]
    t, idx = np.unique(t, return_index=True)
    d = d[idx]
    if t.size < 2:
        return None

    def comp(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        out = np.interp(x, t, d)
        hi = x > t[-1]
        if hi.any():
            j = max(0, int(0.8 * (t.size - 1)))
            sl = (d[-1] - d[j]) / (t[-1] - t[j]) if t[-1] > t[j] else 0.0
            out = np.where(hi, d[-1] + sl * (x - t[-1]), out)
        lo = x < t[0]
        if lo.any():
            sl = (d[1] - d[0]) / (t[1] - t[0])
            out = np.where(lo, d[0] + sl * (x - t[0]), out)
        return out

    return comp


def hpt_curve(curve: Any, *, sigma: float | None = None, compliance: Any = None,
              name: str | None = None) -> HptCurve:
    """Turn an :class:`~torlab.reduce.hpt.HptResult` or a reduced DataFrame into an :class:`HptCurve`.

    The loading branch is kept: every sample up to the last one at the
    maximum displacement.

    Raises
    ------
    TorlabInputError
        Missing columns, non-finite values, too few points, constant signal.
    """
    from torlab.reduce.hpt import HptResult

    meta: dict[str, Any] = {}
    if isinstance(curve, HptCurve):
        return curve
    if isinstance(curve, HptResult):
        df = curve.data
        m = curve.meta
        meta = {"source": Path(m.source).name if m.source else "", "product": m.product,
                "condition": m.condition, "applied_amount": m.applied_amount_value,
                "applied_amount_unit": m.applied_amount_unit, "temperature_C": m.temperature,
                "product_density": m.product_density, "compliance": curve.compliance or "none"}
    else:
        df = curve
        meta = {"source": name or ""}
    where = meta.get("source") or name or "HPT curve"
    cols = set(getattr(df, "columns", []))
    if "shear_stress_Pa" not in cols or not ({"displacement_raw_m", "displacement_m"} & cols):
        raise TorlabInputError("an HPT curve needs the reduced columns shear_stress_Pa and "
                               "displacement_raw_m (or displacement_m); reduce the raw log with "
                               "'torlab hpt reduce' first", path=where)
    tau = df["shear_stress_Pa"].to_numpy(dtype=float)
    u_raw = df["displacement_raw_m" if "displacement_raw_m" in cols else "displacement_m"
               ].to_numpy(dtype=float)
    comp = None
    if compliance is not None:
        comp = compliance
        meta["compliance"] = getattr(compliance, "source", "") or "given"
    elif "displacement_raw_m" in cols and "displacement_m" in cols:
        comp = _compliance_from_columns(tau, u_raw - df["displacement_m"].to_numpy(dtype=float))
        if comp is not None and meta.get("compliance", "none") == "none":
            meta["compliance"] = "as subtracted by the reduction"
    if comp is None:
        meta["compliance"] = "none"
    if not (np.all(np.isfinite(tau)) and np.all(np.isfinite(u_raw))):
        raise TorlabInputError("shear stress and displacement must be finite numbers", path=where)
    k_end = int(np.flatnonzero(u_raw >= np.max(u_raw))[-1]) if u_raw.size else 0
    tau, u_raw = tau[: k_end + 1], u_raw[: k_end + 1]
    if sigma is None:
        if "normal_stress_Pa" not in cols:
            raise TorlabInputError("no normal_stress_Pa column: give the normal stress (sigma)",
                                   path=where, key="sigma")
        sig_all = df["normal_stress_Pa"].to_numpy(dtype=float)
        sigma = float(np.mean(sig_all[np.isfinite(sig_all)]))
    if not (math.isfinite(sigma) and sigma > 0):
        raise TorlabInputError(f"normal stress must be positive, got {sigma:g} Pa", path=where,
                               key="sigma")
    if tau.size < MIN_POINTS:
        raise TorlabInputError(f"too few points on the loading branch ({tau.size}) to fit the four "
                               f"layer parameters with uncertainties; need at least {MIN_POINTS}",
                               path=where)
    tmax = float(np.max(np.abs(tau)))
    if tmax <= 0 or np.ptp(tau) <= 1e-6 * tmax or np.ptp(u_raw) <= 0:
        raise TorlabInputError("the shear stress (or the displacement) is constant: no curve to fit",
                               path=where)
    meta["normal_stress_Pa"] = sigma
    return HptCurve(u_raw=u_raw, tau=tau, sigma=sigma, compliance=comp, meta=meta)


# ---------------------------------------------------------------------------------------------
# the fit
# ---------------------------------------------------------------------------------------------
def _initial_guess(c: HptCurve) -> np.ndarray:
    """Data-driven start: plateau -> mu_c2, initial slope -> L_mue, knee -> mu_c1, L_mup."""
    u = c.u_raw
    tau = c.tau
    ul = u - (c.compliance(tau) - c.compliance(np.zeros(1))[0] if c.compliance is not None else 0.0)
    n = tau.size
    tail = tau[int(0.9 * n):]
    t2 = float(np.median(tail)) if tail.size else float(tau[-1])
    tmax = float(np.max(tau))
    # elastic slope from the points below 30 % of the maximum stress (above noise)
    low = (tau > 0.02 * tmax) & (tau < 0.3 * tmax) & (ul > 0)
    if low.sum() >= 2:
        slope = float(np.sum(tau[low] * ul[low]) / np.sum(ul[low] ** 2))
    else:
        k = int(np.argmax(tau > 0.5 * tmax))
        slope = float(tau[k] / max(ul[k], 1e-9))
    slope = max(slope, 1e3)
    lme = c.sigma / slope
    # knee: first point more than 15 % below the elastic line
    dev = tau < 0.85 * slope * np.maximum(ul, 0)
    k1 = int(np.argmax(dev & (tau > 0.1 * tmax))) if np.any(dev & (tau > 0.1 * tmax)) else n - 1
    t1 = float(tau[max(k1 - 1, 0)])
    t1 = max(t1, 0.2 * t2)
    uy = t1 / slope
    target = t1 + 0.63 * (t2 - t1)
    after = np.flatnonzero((ul > uy) & ((tau - target) * np.sign(t2 - t1) >= 0))
    lmp = float(ul[after[0]] - uy) if after.size and abs(t2 - t1) > 0.02 * t2 else 10e-6
    x = np.array([t1 / c.sigma, t2 / c.sigma, lme, max(lmp, 0.2e-6)]) / _SCALE
    return np.clip(x, _LOWER * 1.01, _UPPER * 0.99)


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_layer_hpt(curves: Any, *, sigma: float | None = None, compliance: Any = None,
                  joint: bool = True) -> FitResult:
    """Fit ``mu_c1, mu_c2, L_mue, L_mup`` to HPT curves (thesis Eqs. 5.24, 5.26-5.29).

    One curve gives its fit; several curves (repeats of one product and
    amount) are fitted jointly: the four parameters shared, each curve with
    its own normal stress and compliance.  One fit per curve is
    :func:`fit_layers_hpt`.

    Parameters
    ----------
    curves
        One or a list of :class:`~torlab.reduce.hpt.HptResult` (or DataFrames
        with the reduced columns ``shear_stress_Pa``, ``displacement_raw_m``,
        ``displacement_m``, ``normal_stress_Pa``).
    sigma
        Normal stress (Pa); default: each curve's mean measured normal stress.
    compliance
        Rig compliance ``u_rig(tau)`` (a :class:`~torlab.reduce.hpt.RigCompliance`);
        default: the one the reduction subtracted, if any.
    joint
        Must be true (kept for callers that say so); one fit per curve is
        :func:`fit_layers_hpt`.

    Returns
    -------
    FitResult

    Raises
    ------
    TorlabInputError
        Bad or insufficient data (too few points, constant signal ...).
    FitError
        The optimiser does not converge, or the curve never leaves the elastic
        branch (``mu_c1``, ``mu_c2``, ``L_mup`` undetermined).
    """
    if not joint:
        raise TypeError("fit_layer_hpt fits the curves together; use fit_layers_hpt for one fit "
                        "per curve")
    items = list(curves) if isinstance(curves, (list, tuple)) else [curves]
    if not items:
        raise TorlabInputError("no HPT curve given")
    return _fit([hpt_curve(c, sigma=sigma, compliance=compliance) for c in items])


def fit_layers_hpt(curves: Any, *, sigma: float | None = None, compliance: Any = None
                   ) -> list[FitResult]:
    """One :func:`fit_layer_hpt` per curve (e.g. one run per temperature), in order."""
    items = list(curves) if isinstance(curves, (list, tuple)) else [curves]
    if not items:
        raise TorlabInputError("no HPT curve given")
    return [fit_layer_hpt(c, sigma=sigma, compliance=compliance) for c in items]


def _fit(cs: list[HptCurve]) -> FitResult:
    import pandas as pd
    from scipy.optimize import least_squares

    where = ", ".join(str(c.meta.get("source") or "curve") for c in cs)
    scale_tau = max(float(np.max(np.abs(c.tau))) for c in cs)

    def model(x: np.ndarray, c: HptCurve) -> np.ndarray:
        return tau_of_raw_displacement(c.u_raw, c.sigma, x * _SCALE, c.compliance)

    def resid(x: np.ndarray) -> np.ndarray:
        return np.concatenate([(model(x, c) - c.tau) / scale_tau for c in cs])

    x0s = [_initial_guess(c) for c in cs]
    x0 = np.exp(np.mean(np.log(np.array(x0s)), axis=0))
    try:
        sol = least_squares(resid, x0, bounds=(_LOWER, _UPPER), x_scale="jac", method="trf",
                            xtol=1e-10, ftol=1e-10, max_nfev=400)
    except (ValueError, np.linalg.LinAlgError) as e:
        raise FitError(f"HPT layer fit failed for {where}: {e}") from None
    if sol.status <= 0:
        raise FitError(f"HPT layer fit did not converge for {where} ({sol.message}, "
                       f"{sol.nfev} evaluations)")
    x = sol.x
    p = x * _SCALE
    # --- the data must leave the elastic branch -----------------------------------------
    n_plastic = 0
    for c in cs:
        t1 = p[0] * c.sigma
        u_yield = t1 * p[2] / c.sigma + (float(c.compliance(np.array([t1]))[0] - c.compliance(
            np.zeros(1))[0]) if c.compliance is not None else 0.0)
        n_plastic += int(np.sum(c.u_raw > u_yield * (1 + 1e-9)))
    max_ratio = max(float(np.max(c.tau)) / c.sigma for c in cs)
    if n_plastic < 3 or p[0] >= max_ratio * 1.02:
        raise FitError(f"{where}: all points lie on the elastic branch (the curve never yields up to "
                       f"f = {max_ratio:.3g}), so mu_c1, mu_c2 and L_mup are not determined; run the "
                       "test to a larger displacement")
    # --- uncertainties ------------------------------------------------------------------
    J = sol.jac * scale_tau / _SCALE[None, :]   # d tau / d p (SI) per row
    rows, blocks, off = [], [], 0
    data_frames = []
    noise_models: list[NoiseModel] = []
    for i, c in enumerate(cs):
        tau_m = model(x, c)
        r = c.tau - tau_m
        sc = np.maximum(np.abs(tau_m), 0.02 * max(float(np.max(np.abs(tau_m))), 1.0))
        nm = estimate_noise(r, sc)
        noise_models.append(nm)
        sl = slice(off, off + r.size)
        blocks.append((sl, sc, nm))
        off += r.size
        ul = c.u_raw - (c.compliance(c.tau) - c.compliance(np.zeros(1))[0]
                        if c.compliance is not None else 0.0)
        d = {"curve": i, "displacement_raw_m": c.u_raw, "displacement_m": ul,
             "shear_stress_measured_Pa": c.tau, "shear_stress_model_Pa": tau_m,
             "residual_Pa": r, "friction_measured": c.tau / c.sigma,
             "friction_model": tau_m / c.sigma}
        data_frames.append(pd.DataFrame(d))
        rows.append(r)
    cov = sandwich_covariance(J, blocks)
    neff = effective_points(blocks)
    n = off
    k = len(LAYER_NAMES)
    dof = max(math.floor(neff) - k, 2)
    pdof = np.maximum(parameter_dof(J, blocks), 2.0)
    all_r = np.concatenate(rows)
    first = cs[0].meta
    meta: dict[str, Any] = {
        "method": "least squares (trf, bounds) on tau(u_raw), layer law + rig compliance; "
                  "covariance from a residual noise model (absolute floor + relative white + AR(1), "
                  "Whittle), Satterthwaite degrees of freedom per parameter",
        "curves": [str(c.meta.get("source", "")) for c in cs],
        "normal_stress_Pa": float(np.mean([c.sigma for c in cs])),
        "effective_points": float(neff),
        "interval_dof": {nm_: round(float(d), 1) for nm_, d in zip(LAYER_NAMES, pdof, strict=True)},
        **{k2: first.get(k2) for k2 in ("product", "condition", "applied_amount",
                                        "applied_amount_unit", "product_density",
                                        "temperature_C", "compliance")
           if k2 in first},
        "source": where,
    }
    if len(cs) == 1:
        meta.update(noise_models[0].as_dict())
    result = FitResult.from_covariance(
        "layer_hpt", LAYER_NAMES, p, cov, dof=dof, param_dof=pdof, log_scale=LAYER_NAMES,
        residual_norm=float(np.sqrt(np.mean(all_r**2))), n_points=n, warnings=[],
        data=pd.concat(data_frames, ignore_index=True), meta=meta, residual_unit="Pa",
        n_evaluations=int(sol.nfev), x_column="displacement_m",
        y_column="shear_stress_measured_Pa")
    result.warnings.extend(_layer_warnings(result, cs))
    return result


def _layer_warnings(res: FitResult, cs: list[HptCurve]) -> list[str]:
    """What the curve(s) do not determine."""
    w: list[str] = []
    p, se = res.params, res.stderr
    cov12 = res.correlation[0, 1] * se["mu_c1"] * se["mu_c2"] if res.determined("mu_c1") and \
        res.determined("mu_c2") else math.inf
    d = p["mu_c2"] - p["mu_c1"]
    var_d = se["mu_c1"] ** 2 + se["mu_c2"] ** 2 - 2 * cov12 if math.isfinite(cov12) else math.inf
    sd_d = math.sqrt(max(var_d, 0.0))
    step_resolved = abs(d) > 3.0 * sd_d and abs(d) > 0.02 * max(p["mu_c1"], p["mu_c2"])
    if not step_resolved:
        w.append(f"L_mup not determined: the curve never yields to a new level after the elastic "
                 f"limit (mu_c2 - mu_c1 = {d:.3g} +- {sd_d:.2g}), so the Voce length has no effect")
    else:
        u_after = min(float(np.max(c.u_raw)) - p["mu_c1"] * p["L_mue"] for c in cs)
        if u_after < 3.0 * p["L_mup"]:
            w.append(f"mu_c2 poorly determined: the curve ends {u_after / max(p['L_mup'], 1e-12):.2g} "
                     "L_mup after the elastic limit, before it saturates; run to a larger "
                     "displacement")
    for n in LAYER_NAMES:
        if n == "L_mup" and not step_resolved:
            continue
        if not res.determined(n):
            w.append(f"{n} not determined by these data")
        elif abs(p[n]) > 0 and se[n] > 0.5 * abs(p[n]):
            w.append(f"{n} poorly determined (standard error {se[n] / abs(p[n]):.0%})")
    if all(c.compliance is None for c in cs):
        w.append("L_mue includes the rig's own compliance: no compliance was given (measure it on "
                 "a dry run: torlab hpt reduce --compliance)")
    return w
