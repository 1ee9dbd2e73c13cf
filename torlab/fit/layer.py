"""Third-body layer parameters from HPT curves (Voce: ``mu_c1, mu_c2, L_mue, L_mup``).

The model is a layer law of :mod:`torlab.model.layers` at the run's normal stress
``sigma``: elastic ``tau = u sigma / L_mue`` up to ``tau_c1 = mu_c1 sigma``, then the
law's plastic branch -- by default Voce's, towards ``tau_c2 = mu_c2 sigma`` with the
length ``L_mup`` (thesis Eqs. 5.24, 5.26-5.29, as ``docs/model/thesis-reading.md``
reads them); ``law="linear"`` or ``"perfect"`` fit CONTACT's laws, and
``law="auto"`` fits every law and keeps the one with the smallest AICc
(:func:`fit_layer_hpt`).  The rig's own compliance ``u_rig(tau)`` is part of the
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
of one product are fitted jointly (``joint=True``): the law's parameters are
shared, each curve keeps its own normal stress and compliance.

References
----------
.. [1] Kvarda, D. Experimental investigation and numerical modelling of top of rail
   products. PhD thesis, Brno University of Technology, Faculty of Mechanical
   Engineering (the model: section 5.2; no DOI).
.. [2] Kvarda, D., Galas, R., Omasta, M., Dzimko, M., Krupka, I., Hartl, M. (2022). Shear
   properties of top-of-rail products in numerical modelling. Proceedings of the
   Institution of Mechanical Engineers, Part F: Journal of Rail and Rapid Transit.
   https://doi.org/10.1177/09544097221138374
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import FitError, TorlabInputError
from torlab.fit._noise import (
    NoiseModel,
    block_meats,
    effective_points,
    estimate_noise,
    parameter_dof,
    sandwich_covariance,
)
from torlab.fit.result import FitResult
from torlab.model.layers import LAWS, LayerLaw, LayerParams, get_law
from torlab.threads import small_problem

__all__ = ["AUTO", "LAYER_NAMES", "HptCurve", "fit_layer_hpt", "fit_layer_hpt_runs",
           "fit_layers_hpt", "hpt_curve",
           "law_choice", "run_estimates", "select_law", "tau_of_raw_displacement"]

#: the parameters of the default (Voce) law
LAYER_NAMES = get_law().fit_names


def _space(law: LayerLaw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The law's internal scaling and bounds (:class:`~torlab.model.layers.Param` ``scale``,
    ``fit``): mu as is, lengths in um."""
    ps = [law.param(n) for n in law.fit_names]
    return (np.array([p.scale for p in ps]), np.array([p.fit[0] for p in ps]),
            np.array([p.fit[1] for p in ps]))

#: fewest loading-branch points for a fit with uncertainties
MIN_POINTS = 12


@dataclass
class HptCurve:
    """One HPT loading curve ready for the fit (SI units).

    Attributes
    ----------
    u_raw
        Displacement from the angle [m], rig compliance included.
    tau
        Shear stress [Pa].
    sigma
        Normal stress [Pa], the mean over the loading branch unless given.
    compliance
        ``u_rig(tau)`` [m] or None.
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
                            n_elastic: int = 48, n_plastic: int = 320,
                            law: str | LayerLaw | None = None) -> np.ndarray:
    """Layer-law shear stress [Pa] at the *measured* displacement ``u_raw`` [m].

    ``x`` are the law's ``fit_names`` values in SI (Voce: ``mu_c1, mu_c2, L_mue,
    L_mup``).  The law (:meth:`~torlab.model.layers.base.LayerLaw.hpt_tau`; Voce:
    Eqs. 5.24, 5.26-5.29) is tabulated on the layer displacement -- uniform in
    ``tau`` on the elastic branch, geometric in ``u - u_y`` on the plastic one (graded
    with the law's own length, Voce's ``L_mup``) -- and ``u_raw = u_layer + u_rig(tau)``
    is inverted by monotone interpolation (piecewise-linear error below 1e-4 of
    ``tau_c2 - tau_c1``).
    """
    u_raw = np.asarray(u_raw, dtype=float)
    c0 = float(compliance(np.zeros(1))[0]) if compliance is not None else 0.0
    return _tau_raw(u_raw, float(np.max(u_raw)), sigma, x, compliance, c0, get_law(law),
                    n_elastic, n_plastic)


def _tau_raw(u_raw: np.ndarray, u_max: float, sigma: float, x: Sequence[float],
             compliance: Callable[[np.ndarray], np.ndarray] | None, c0: float, law: LayerLaw,
             n_elastic: int = 48, n_plastic: int = 320) -> np.ndarray:
    """:func:`tau_of_raw_displacement` with what a fit keeps per curve computed once:
    the largest displacement ``u_max`` [m] and the compliance at zero stress ``c0`` [m]
    (the fit's residuals call it some thirty times per curve)."""
    lay = LayerParams(law=law, **{n: float(v) for n, v in zip(law.fit_names, x, strict=True)})
    t1 = lay.mu_c1 * sigma
    le = lay.L_mue / sigma
    tau_el = _linspace0(t1, n_elastic)
    ul_el = tau_el * le
    uy = t1 * le
    span = max(u_max - uy, 0.0) * 1.05 + 1e-9
    lp = law.hpt_length(lay) or span
    s = _geomspace(min(1e-4 * lp, 0.5 * span), max(span, 2e-4 * lp), n_plastic)
    tau_pl = law.hpt_plastic(s, sigma, lay)
    ul = np.concatenate((ul_el, uy + s))
    tau = np.concatenate((tau_el, tau_pl))
    ur = ul + (np.asarray(compliance(tau), dtype=float) - c0
               if compliance is not None else 0.0)
    ur = np.maximum.accumulate(ur)
    out = np.interp(u_raw, ur, tau)
    neg = u_raw < 0
    if neg.any():
        slope = (tau[1] - tau[0]) / max(ur[1] - ur[0], 1e-30)
        out[neg] = u_raw[neg] * slope
    return out


_RAMPS: dict[int, np.ndarray] = {}


def _ramp(n: int) -> np.ndarray:
    """``0, 1, ..., n - 1`` as floats (read only; made once per length)."""
    r = _RAMPS.get(n)
    if r is None:
        r = np.arange(0, n, dtype=float)
        r.flags.writeable = False
        _RAMPS[n] = r
    return r


def _linspace0(stop: float, n: int) -> np.ndarray:
    """``numpy.linspace(0.0, stop, n)`` to the bit, without its generic set-up (the fit's
    residuals make two grids per evaluation)."""
    step = stop / (n - 1) if n > 1 else 0.0
    if n < 2 or step == 0 or not math.isfinite(step):
        return np.linspace(0.0, stop, n)
    y = _ramp(n) * step  # the same operations as numpy's: ramp * step + start, last = stop
    y += 0.0
    y[-1] = stop
    return y


def _geomspace(start: float, stop: float, n: int) -> np.ndarray:
    """``numpy.geomspace(start, stop, n)`` to the bit for positive finite ends, ``n >= 2``
    (numpy's steps: ``10 ** linspace(log10 start, log10 stop)`` with the ends set exactly),
    without its generic set-up: about 8 instead of 45 us."""
    if not (n >= 2 and start > 0 and stop > 0 and math.isfinite(start) and math.isfinite(stop)):
        return np.geomspace(start, stop, n)
    ls = np.log10(np.asarray(start, dtype=float))
    le = np.log10(np.asarray(stop, dtype=float))
    step = (le - ls) / (n - 1)
    if step == 0:
        return np.geomspace(start, stop, n)
    y = _ramp(n) * step
    y += ls
    y[-1] = le
    out = np.power(10.0, y)
    out[0] = start
    out[-1] = stop
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
def _initial_guess(c: HptCurve, law: LayerLaw) -> np.ndarray:
    """Data-driven start: initial slope -> L_mue, knee -> mu_c1; the law's own parameters
    from the curve after the knee (:meth:`~torlab.model.layers.base.LayerLaw.hpt_start`;
    Voce: the final stress -> mu_c2, the 63 % point -> L_mup)."""
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
    start = {"mu_c1": t1 / c.sigma, "L_mue": lme,
             **law.hpt_start(t1, t2, uy, ul, tau, c.sigma)}
    scale, lower, upper = _space(law)
    x = np.array([start[n] for n in law.fit_names]) / scale
    return np.clip(x, np.where(lower > 0, lower * 1.01, lower * 0.99),
                   np.where(upper > 0, upper * 0.99, upper * 1.01))


#: what ``law=`` takes besides a law's name: every law, the smallest AICc kept
AUTO = "auto"


def law_choice(law: Any, key: str = "law") -> list[LayerLaw]:
    """The laws a ``law=`` argument asks for: a name, ``"auto"`` (every law), or a list.

    ``key`` names the argument in the error (``"--law"`` on the command line).

    Raises
    ------
    TorlabInputError
        An unknown law (with a suggestion), or no law.
    """
    from torlab._suggest import did_you_mean

    if law is None:
        return [get_law()]
    names = ([x.strip() for x in law.split(",") if x.strip()] if isinstance(law, str)
             else [getattr(x, "name", x) for x in law])
    out: list[LayerLaw] = []
    for nm in names:
        if nm == AUTO:
            out.extend(LAWS.values())
            continue
        if nm not in LAWS:
            raise TorlabInputError(f"{nm!r} is not a layer law: use {', '.join(LAWS)} or "
                                   f"{AUTO}{did_you_mean(nm, [*LAWS, AUTO])}", key=key)
        out.append(LAWS[nm])
    out = list(dict.fromkeys(out))
    if not out:
        raise TorlabInputError("no layer law given", key=key)
    return out


def check_resolution(laws: Sequence[LayerLaw], resolution: float | None,
                     key: str = "resolution") -> None:
    """Refuse a stress ``resolution`` where only one law is fitted: it enters only the AICc
    comparison of several laws (:func:`select_law`), so with one law it would be ignored.

    Raises
    ------
    TorlabInputError
        ``resolution`` given with a single law.
    """
    if resolution is not None and len(laws) == 1:
        raise TorlabInputError(f"applies only when several layer laws are compared (law "
                               f"'auto' or a list), not with the {laws[0].name} law alone",
                               key=key)


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_layer_hpt(curves: Any, *, sigma: float | None = None, compliance: Any = None,
                  joint: bool = True, law: Any = None, between: str = "random",
                  resolution: float | None = None) -> FitResult:
    """Fit a layer law's parameters to HPT curves (Voce: ``mu_c1, mu_c2, L_mue, L_mup``,
    thesis Eqs. 5.24, 5.26-5.29).

    One curve gives its fit (its intervals hold for that record alone, and
    ``meta["scatter"]`` says so).  Several curves (repeats of one product and
    amount) give one parameter set: each curve is fitted alone and the runs are
    pooled with random effects (:func:`torlab.fit.repeats.pool_fits`: REML
    between-run variance, Hartung-Knapp intervals on ``runs - 1`` degrees of
    freedom), so the intervals hold the scatter from run to run.  One fit per
    curve is :func:`fit_layers_hpt`.

    Parameters
    ----------
    curves
        One or a list of :class:`~torlab.reduce.hpt.HptResult` (or DataFrames
        with the reduced columns ``shear_stress_Pa``, ``displacement_raw_m``,
        ``displacement_m``, ``normal_stress_Pa``).
    sigma
        Normal stress [Pa]; default: each curve's mean measured normal stress.
    compliance
        Rig compliance ``u_rig(tau)`` (a :class:`~torlab.reduce.hpt.RigCompliance`);
        default: the one the reduction subtracted, if any.
    joint
        Must be true (kept for callers that say so); one fit per curve is
        :func:`fit_layers_hpt`.
    law
        The layer law (:mod:`torlab.model.layers`): ``"voce"`` (default), ``"linear"``,
        ``"perfect"``, or ``"auto"`` (or a list of laws): each is fitted and the one
        with the smallest AICc is returned, the comparison in ``meta["law_selection"]``
        (:func:`select_law`); with repeats the law is chosen on all their points and
        each run fitted with it.
    between
        Several curves: ``"random"`` (default) pools the curves' own fits with the
        between-run variance; ``"none"`` fits the parameters to every point at
        once (the run-to-run scatter then only widens the residual noise model: the
        interval of the record, not of the product).  When a curve cannot be fitted
        alone (it never yields) the curves are fitted together and a warning says
        that the scatter is not estimated.  The fit of all curves together is made
        only where it is used (that case, ``"none"``, a choice among laws): whether it
        would converge does not decide a result made of the curves' own fits.
    resolution
        With several laws: the stress resolution of the data [Pa] (a digitised curve's
        reading, a logger's step); a law whose residuals are below it fits as well as the
        data can tell (its RSS is floored at ``n resolution^2`` in the AICc; where the best
        law's residuals are below it, they say nothing of the noise's correlation and the
        points count as independent readings with that error, ``n_eff = n``).  Default:
        round-off.

    Returns
    -------
    FitResult

    Raises
    ------
    TorlabInputError
        Bad or insufficient data (too few points, constant signal ...), an unknown law.
    FitError
        The optimiser does not converge, or the curve never leaves the elastic
        branch (the plastic parameters undetermined); with several laws, when
        every law fails.
    """
    if not joint:
        raise TypeError("fit_layer_hpt fits the curves together; use fit_layers_hpt for one fit "
                        "per curve")
    return _layer_fit(curves, sigma=sigma, compliance=compliance, law=law, between=between,
                      resolution=resolution)[0]


@small_problem  # one BLAS thread, as fit_layer_hpt
def fit_layer_hpt_runs(curves: Any, *, law: Any = None) -> tuple[FitResult, list[FitResult] | None]:
    """:func:`fit_layer_hpt` of ``curves`` and, where that result is made of the curves' own
    fits, those fits (else None).

    Each run's fit has the estimates, covariance and ``meta`` keys of :func:`run_estimates`
    of that curve bit for bit (it is the same fit, with its data table), so a temperature
    series that holds these runs takes them as they are
    (:func:`torlab.fit.temperature.fit_temperature_coefficients` accepts fits) instead of
    fitting them again.  None where the result is not made of them: a choice among laws
    (each run is fitted again with the chosen law), or a curve that cannot be fitted alone.
    """
    return _layer_fit(curves, law=law, keep_runs=True)


def _layer_fit(curves: Any, *, sigma: float | None = None, compliance: Any = None,
               law: Any = None, between: str = "random", resolution: float | None = None,
               keep_runs: bool = False) -> tuple[FitResult, list[FitResult] | None]:
    """:func:`fit_layer_hpt` and the curves' own fits it was made of (``keep_runs``)."""
    from torlab.fit.repeats import pool_fits

    if between not in ("random", "none"):
        raise TorlabInputError(f"between must be 'random' or 'none', not {between!r}",
                               key="between")
    laws = law_choice(law)
    check_resolution(laws, resolution)
    items = list(curves) if isinstance(curves, (list, tuple)) else [curves]
    if not items:
        raise TorlabInputError("no HPT curve given")
    cs = [hpt_curve(c, sigma=sigma, compliance=compliance) for c in items]
    # the fit of all curves together is made where it is used: to choose among several
    # laws, for between="none", and where a curve cannot be fitted alone (with one law and
    # repeats that each fit, the result is the pooled fits alone)
    together = select_law(cs, laws, resolution=resolution) if len(laws) > 1 else None
    chosen = LAWS.get(str(together.meta.get("law", "")), laws[0]) if together is not None \
        else laws[0]
    if len(cs) == 1 or between == "none":
        res = together if together is not None else _fit(cs, chosen)
        own = None
        if keep_runs and together is None and len(cs) == 1:
            own = [copy.copy(res)]  # the run's fit as run_estimates gives it: pooling marks res
            own[0].meta = dict(res.meta)
        return (pool_fits([res]) if len(cs) == 1 else res), own
    try:
        fits = [_fit([c], chosen) for c in cs]
    except FitError as e:
        if together is None:
            together = _fit(cs, chosen)
        together.warnings.append(
            f"run-to-run scatter not estimated: a curve cannot be fitted alone ({e}); the "
            "curves are fitted together, and the intervals hold the noise within the records "
            "only")
        return together, None
    res = pool_fits(fits)
    own = fits if keep_runs and together is None else None
    if together is None:
        if chosen is not get_law():  # as _fit writes it (the default law is not written)
            res.meta["law"] = chosen.name
        return res, own
    for k in ("law", "law_selection", "criterion"):
        if k in together.meta:
            res.meta[k] = together.meta[k]
    return res, own


def fit_layers_hpt(curves: Any, *, sigma: float | None = None, compliance: Any = None,
                   law: Any = None, resolution: float | None = None) -> list[FitResult]:
    """One :func:`fit_layer_hpt` per curve (e.g. one run per temperature), in order."""
    items = list(curves) if isinstance(curves, (list, tuple)) else [curves]
    if not items:
        raise TorlabInputError("no HPT curve given")
    return [fit_layer_hpt(c, sigma=sigma, compliance=compliance, law=law,
                          resolution=resolution) for c in items]


@small_problem  # one BLAS thread, as fit_layer_hpt
def run_estimates(curve: Any, *, law: Any = None) -> FitResult:
    """One run's layer estimates and their covariance, as a series of runs (the
    temperature coefficients, :func:`torlab.fit.temperature.fit_temperature_coefficients`)
    reads them: :func:`fit_layer_hpt` of the one curve, with the same estimates, standard
    errors, covariance and ``meta`` keys ``source``, ``product``, ``condition``,
    ``temperature_C`` (and ``law``) bit for bit, without what the series does not read
    (the data table, the per-parameter degrees of freedom, the warnings).  A list of
    curves (repeats at one temperature) or a choice among laws is :func:`fit_layer_hpt`
    itself.

    Raises
    ------
    TorlabInputError, FitError
        As :func:`fit_layer_hpt`.
    """
    laws = law_choice(law)
    if isinstance(curve, (list, tuple)) or len(laws) > 1:
        return fit_layer_hpt(curve, law=law)
    return _fit([hpt_curve(curve)], laws[0], light=True)


def select_law(cs: list[HptCurve], laws: Sequence[LayerLaw], *,
               resolution: float | None = None) -> FitResult:
    """Fit every law of ``laws`` to the curves and keep the one with the smallest AICc.

    As ``torlab fit removal`` chooses its removal law: ``AICc = n_eff ln(RSS/n) + 2k +
    2k(k+1)/(n_eff - k - 1)`` with ``RSS`` the residual sum of squares of each law's
    fit, ``k`` its number of parameters, ``n`` the points and ``n_eff`` the effective
    number of independent points of the best-fitting law's residuals (the HPT noise is
    correlated along the record, :mod:`torlab.fit._noise`); Akaike weights
    ``exp(-dAICc/2)`` normalised.  ``RSS`` is floored at ``n (resolution)^2`` (default
    ``resolution``: 1e-12 of the stress scale, round-off): residuals below the data's
    resolution are no evidence.  A law whose fit fails is listed with why and left out.
    The result is the chosen law's :class:`FitResult` with ``meta["law"]``,
    ``meta["law_selection"]`` (one row per law) and ``meta["criterion"]``.
    """
    fits: list[tuple[LayerLaw, FitResult | None, str]] = []
    for lw in laws:
        try:
            fits.append((lw, _fit(cs, lw), ""))
        except FitError as e:
            fits.append((lw, None, str(e)))
    ok = [(lw, r) for lw, r, _ in fits if r is not None]
    if not ok:
        raise FitError("no layer law fits these curves: " + "; ".join(
            f"{lw.name}: {why}" for lw, _, why in fits))
    rss = {lw.name: float(np.sum((r.data["residual_Pa"].to_numpy()) ** 2)) for lw, r in ok}
    best = min(ok, key=lambda t: rss[t[0].name])[1]
    n = int(best.n_points)
    neff = float(best.meta.get("effective_points", n))
    # residuals below the data's resolution (default round-off: a law that reproduces the
    # data exactly) are no evidence: RSS is floored at n resolution^2
    scale = max(float(np.max(np.abs(best.data["shear_stress_measured_Pa"]))), 1e-300)
    res_floor = 1e-12 * scale if resolution is None else float(resolution)
    floor = n * res_floor ** 2
    if min(rss.values()) <= floor:
        # the best law's residuals are below the resolution: they say nothing about the
        # noise's correlation; the resolution is the noise, point by point
        neff = float(n)
    rows: list[dict[str, Any]] = []
    for lw, r, why in fits:
        k = len(lw.fit_names)
        if r is None:
            rows.append({"law": lw.name, "parameters": k, "rss": None, "aicc": None,
                         "delta_aicc": None, "weight": 0.0, "note": why})
            continue
        corr = 2.0 * k * (k + 1) / max(neff - k - 1, 1.0)
        aicc = neff * math.log(max(rss[lw.name], floor) / n) + 2 * k + corr
        rows.append({"law": lw.name, "parameters": k, "rss": rss[lw.name], "aicc": aicc,
                     "note": "; ".join(r.warnings)})
    a_min = min(r["aicc"] for r in rows if r["aicc"] is not None)
    wsum = sum(math.exp(-0.5 * (r["aicc"] - a_min)) for r in rows if r["aicc"] is not None)
    for r in rows:
        if r["aicc"] is not None:
            r["delta_aicc"] = r["aicc"] - a_min
            r["weight"] = math.exp(-0.5 * r["delta_aicc"]) / wsum
    chosen = min((r for r in rows if r["aicc"] is not None), key=lambda r: r["aicc"])["law"]
    res = next(r for lw, r in ok if lw.name == chosen)
    res.meta["law"] = chosen
    res.meta["law_selection"] = rows
    res.meta["criterion"] = ("AICc on the effective number of independent points "
                             f"({neff:.1f} of {n}); RSS floored at "
                             + ("round-off" if resolution is None else
                                f"n ({res_floor / 1e6:.3g} MPa)^2, the data's resolution"))
    return res


def _fit(cs: list[HptCurve], law: LayerLaw | None = None, *, light: bool = False
         ) -> FitResult:
    """The least-squares fit of ``law`` to the curves ``cs`` together, with its covariance.

    ``light``: the estimates and their covariance only, as a series of runs reads them
    (:func:`run_estimates`): no data table, no per-parameter degrees of freedom (the
    intervals on the common ``dof``), no warnings.  The estimates and standard errors are
    those of the whole fit, bit for bit.
    """
    import pandas as pd
    from scipy.optimize import least_squares

    law = get_law(law)
    names = law.fit_names
    SCALE, LOWER, UPPER = _space(law)
    where = ", ".join(str(c.meta.get("source") or "curve") for c in cs)
    scale_tau = max(float(np.max(np.abs(c.tau))) for c in cs)

    # per curve, once: its displacements, their largest and the compliance at zero stress
    fixed = {id(c): (np.asarray(c.u_raw, dtype=float), float(np.max(c.u_raw)),
                     float(c.compliance(np.zeros(1))[0]) if c.compliance is not None else 0.0)
             for c in cs}

    def model(x: np.ndarray, c: HptCurve) -> np.ndarray:
        u, u_max, c0 = fixed[id(c)]
        return _tau_raw(u, u_max, c.sigma, x * SCALE, c.compliance, c0, law)

    def resid(x: np.ndarray) -> np.ndarray:
        return np.concatenate([(model(x, c) - c.tau) / scale_tau for c in cs])

    x0s = np.array([_initial_guess(c, law) for c in cs])
    pos = np.array([law.param(n).positive for n in names])
    # the geometric mean of the curves' starts (the arithmetic one for a signed parameter)
    x0 = np.where(pos, np.exp(np.mean(np.log(np.where(pos, x0s, 1.0)), axis=0)),
                  np.mean(x0s, axis=0))
    try:
        sol = least_squares(resid, x0, bounds=(LOWER, UPPER), x_scale="jac", method="trf",
                            xtol=1e-10, ftol=1e-10, max_nfev=400)
    except (ValueError, np.linalg.LinAlgError) as e:
        raise FitError(f"HPT layer fit failed for {where}: {e}") from None
    if sol.status <= 0:
        raise FitError(f"HPT layer fit did not converge for {where} ({sol.message}, "
                       f"{sol.nfev} evaluations)")
    x = sol.x
    p = x * SCALE
    pv = dict(zip(names, p, strict=True))
    # --- the data must leave the elastic branch -----------------------------------------
    n_plastic = 0
    for c in cs:
        t1 = pv["mu_c1"] * c.sigma
        u_yield = t1 * pv["L_mue"] / c.sigma + (float(c.compliance(np.array([t1]))[0] - c.compliance(
            np.zeros(1))[0]) if c.compliance is not None else 0.0)
        n_plastic += int(np.sum(c.u_raw > u_yield * (1 + 1e-9)))
    max_ratio = max(float(np.max(c.tau)) / c.sigma for c in cs)
    if n_plastic < 3 or pv["mu_c1"] >= max_ratio * 1.02:
        plastic = [n for n in names if n != "L_mue"]
        listed = ", ".join(plastic[:-1]) + f" and {plastic[-1]}" if len(plastic) > 1 \
            else plastic[0]
        verb = "are" if len(plastic) > 1 else "is"
        raise FitError(f"{where}: all points lie on the elastic branch (the curve never yields up to "
                       f"f = {max_ratio:.3g}), so {listed} {verb} not determined; run the "
                       "test to a larger displacement")
    # --- uncertainties ------------------------------------------------------------------
    J = sol.jac * scale_tau / SCALE[None, :]   # d tau / d p (SI) per row
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
        rows.append(r)
        if light:
            continue
        ul = c.u_raw - (c.compliance(c.tau) - c.compliance(np.zeros(1))[0]
                        if c.compliance is not None else 0.0)
        d = {"curve": i, "displacement_raw_m": c.u_raw, "displacement_m": ul,
             "shear_stress_measured_Pa": c.tau, "shear_stress_model_Pa": tau_m,
             "residual_Pa": r, "friction_measured": c.tau / c.sigma,
             "friction_model": tau_m / c.sigma}
        data_frames.append(pd.DataFrame(d))
    parts = block_meats(J, blocks)  # the noise's parts, shared by the two below
    cov = sandwich_covariance(J, blocks, parts)
    neff = effective_points(blocks)
    n = off
    k = len(names)
    dof = max(math.floor(neff) - k, 2)
    all_r = np.concatenate(rows)
    first = cs[0].meta
    if light:
        lmeta = {k2: first.get(k2) for k2 in ("product", "condition", "temperature_C")
                 if k2 in first}
        lmeta["source"] = where
        if law is not get_law():
            lmeta["law"] = law.name
        return FitResult.from_covariance(
            "layer_hpt", names, p, cov, dof=dof,
            log_scale=tuple(n_ for n_, ps in zip(names, pos, strict=True) if ps),
            residual_norm=float(np.sqrt(np.mean(all_r**2))), n_points=n, warnings=[],
            data=None, meta=lmeta, residual_unit="Pa", n_evaluations=int(sol.nfev))
    pdof = np.maximum(parameter_dof(J, blocks, parts), 2.0)
    meta: dict[str, Any] = {
        "method": "least squares (trf, bounds) on tau(u_raw), layer law + rig compliance; "
                  "covariance from a residual noise model (absolute floor + relative white + AR(1), "
                  "Whittle), Satterthwaite degrees of freedom per parameter",
        "curves": [str(c.meta.get("source", "")) for c in cs],
        "normal_stress_Pa": float(np.mean([c.sigma for c in cs])),
        "effective_points": float(neff),
        "interval_dof": {nm_: round(float(d), 1) for nm_, d in zip(names, pdof, strict=True)},
        **{k2: first.get(k2) for k2 in ("product", "condition", "applied_amount",
                                        "applied_amount_unit", "product_density",
                                        "temperature_C", "compliance")
           if k2 in first},
        "source": where,
    }
    if law is not get_law():
        meta["law"] = law.name  # the default law is not written (outputs as they always were)
    if len(cs) == 1:
        meta.update(noise_models[0].as_dict())
    result = FitResult.from_covariance(
        "layer_hpt", names, p, cov, dof=dof, param_dof=pdof,
        log_scale=tuple(n_ for n_, ps in zip(names, pos, strict=True) if ps),
        residual_norm=float(np.sqrt(np.mean(all_r**2))), n_points=n, warnings=[],
        data=pd.concat(data_frames, ignore_index=True), meta=meta, residual_unit="Pa",
        n_evaluations=int(sol.nfev), x_column="displacement_m",
        y_column="shear_stress_measured_Pa")
    result.warnings.extend(_layer_warnings(result, cs, law))
    return result


def _layer_warnings(res: FitResult, cs: list[HptCurve], law: LayerLaw | None = None) -> list[str]:
    """What the curve(s) do not determine."""
    law = get_law(law)
    p, se = res.params, res.stderr
    w, skip = law.fit_warnings(res, [float(np.max(c.u_raw)) for c in cs])
    for n in law.fit_names:
        if n in skip:
            continue
        if not res.determined(n):
            w.append(f"{n} not determined by these data")
        elif abs(p[n]) > 0 and se[n] > 0.5 * abs(p[n]):
            w.append(f"{n} poorly determined (standard error {se[n] / abs(p[n]):.0%})")
    if all(c.compliance is None for c in cs):
        w.append("L_mue includes the rig's own compliance: no compliance was given (measure it on "
                 "a dry run: torlab hpt reduce --compliance)")
    return w
