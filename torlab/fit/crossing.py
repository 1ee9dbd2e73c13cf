"""Threshold crossings of an amount series (Paper C): where a product's friction falls below
the low-friction threshold, with an interval and the evidence for the verdict.

For every product the HPT runs at one temperature form a series of the friction ``f``
[-] (mean over the window before the maximum displacement, thesis Fig. 5.10) against the
applied amount (:func:`amount_series`; µL for liquids, mg for solids, and the applied mass
[mg] where the product's density [kg/m^3] is known).

Crossing estimate (``curve: logistic``, the default): per product a four-parameter
logistic in log amount, ``f(x) = f_low + (f_high - f_low) / (1 + exp(k (x - c)))``,
``x = ln amount``, fitted by least squares (``scipy.optimize.least_squares``,
:func:`fit_crossings`).  Its crossing is ``ln A* = c + ln((f_high - f_low)/(thr - f_low) -
1) / k``.  The residual variance is pooled over the products (the run-to-run scatter of
the test method; a five-amount series alone leaves one degree of freedom), and the
interval is the delta method on ``ln A*`` with Student's t on the pooled degrees of
freedom, so it is asymmetric in ``A*``.  A crossing is reported only where the measured
series brackets the threshold (no extrapolation).  ``curve: interpolation`` interpolates
``f`` linearly in ``ln amount`` between the two runs bracketing the threshold (no
interval).

The evidence (:func:`crossing_probabilities`): the probability that the crossing lies
inside the tested amounts, that the friction at the largest amount is below the
threshold and at the smallest above it; the verdict "crosses within the tested amounts"
is called only when that probability reaches :data:`CROSSING_PROBABILITY` (0.9).
:func:`amount_statistics` adds the pooled scatter, the evidence of "above (below) the
threshold at every amount" and whether the products cross at one applied mass
(:func:`mass_homogeneity`, thesis H3.2).  The report that draws all this is
:mod:`torlab.reports.amount`.

References
----------
.. [1] Kvarda, D., Galas, R., Omasta, M., Dzimko, M., Krupka, I., Hartl, M. (2022). Shear
   properties of top-of-rail products in numerical modelling. Proceedings of the
   Institution of Mechanical Engineers, Part F: Journal of Rail and Rapid Transit.
   https://doi.org/10.1177/09544097221138374
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.fit.result import FitResult

__all__ = [
    "CROSSING_PROBABILITY",
    "CrossingFit",
    "amount_series",
    "amount_statistics",
    "crossing_probabilities",
    "crossing_row",
    "fit_crossings",
    "logistic",
    "logistic_band",
    "mass_factor",
    "mass_homogeneity",
    "run_scatter",
]

MG = 1e-6  # kg per mg
#: probability the crossing must have of lying within the tested amounts to be called
CROSSING_PROBABILITY = 0.9


def logistic(x: np.ndarray, f_low: float, f_high: float, k: float, c: float) -> np.ndarray:
    """Four-parameter logistic in ``x = ln amount`` (decreasing for ``k > 0``)."""
    from scipy.special import expit

    return f_low + (f_high - f_low) * expit(-k * (np.asarray(x, dtype=float) - c))


def amount_series(results: Iterable[Any], products: dict[str, Any], *, temperature: float,
                  temperature_tolerance: float, only: list[str] | None = None) -> Any:
    """The amount series: one row per HPT run with an applied amount at ``temperature``.

    Parameters
    ----------
    results
        :class:`torlab.reduce.hpt.HptResult` of every run (read once, in order).
    products
        The protocol's ``products:`` (name -> :class:`~torlab.protocols.schema.Product`);
        a ``product-condition`` key wins over the plain product name.
    temperature, temperature_tolerance
        Runs within ``temperature ± tolerance`` [degC] are used; runs without a
        logged temperature are used too.
    only
        Products (labels) to keep; default all.

    Returns
    -------
    pandas.DataFrame
        ``product`` (with condition), ``file``, ``applied_amount`` (in its unit),
        ``applied_amount_unit``, ``amount_kind`` (volume/mass), ``density_kg_m3``,
        ``mass_mg``, ``f``, ``f_sd``, ``temperature_C``, ``product_type``,
        ``product_label`` (``products.<name>.label``, else the product).
    """
    import pandas as pd

    rows = []
    for r in results:
        m = r.meta
        if m.applied_amount is None:
            continue
        T = m.temperature
        if T is not None and abs(T - temperature) > temperature_tolerance:
            continue
        label = m.product + (f"-{m.condition}" if m.condition else "")
        if only and label not in only and m.product not in only:
            continue
        cfg = products.get(label) or products.get(m.product)
        dens = cfg.density if cfg is not None and cfg.density is not None else m.product_density
        if m.applied_amount_kind == "mass":
            mass_mg = m.applied_amount / MG
        elif dens is not None:
            mass_mg = m.applied_amount * dens / MG
        else:
            mass_mg = float("nan")
        rows.append({
            "product": label, "file": r.meta.source.rsplit("/", 1)[-1],
            "applied_amount": float(m.applied_amount_value),
            "applied_amount_unit": m.applied_amount_unit, "amount_kind": m.applied_amount_kind,
            "density_kg_m3": float(dens) if dens is not None else float("nan"),
            "mass_mg": float(mass_mg), "f": float(r.f_window), "f_sd": float(r.f_window_std),
            "temperature_C": float(T) if T is not None else float("nan"),
            "product_type": (cfg.type if cfg is not None and cfg.type else m.product_type) or "",
            "product_label": (cfg.label if cfg is not None and cfg.label else label),
        })
    df = pd.DataFrame(rows)
    if len(df):
        df = df.sort_values(["product", "applied_amount"], kind="stable").reset_index(drop=True)
    return df


@dataclass
class _Crossing:
    """One product's amount-dependency fit while it is being computed."""

    product: str
    unit: str
    n: int
    method: str
    params: dict[str, float] = field(default_factory=dict)
    cov: Any = None
    dof: int = 0
    crossing: float = float("nan")
    crossing_low: float = float("nan")
    crossing_high: float = float("nan")
    status: str = ""
    band_low_amount: float = float("nan")
    band_high_amount: float = float("nan")
    notes: list[str] = field(default_factory=list)
    data: Any = None
    p_inside: float = float("nan")
    p_below_at_largest: float = float("nan")
    p_above_at_smallest: float = float("nan")
    verdict: str = ""


_NAN = float("nan")


@dataclass
class CrossingFit(FitResult):
    """One product's amount-dependency fit and threshold crossing: a
    :class:`~torlab.fit.result.FitResult` (``kind="amount_crossing"``; parameters
    ``f_low``, ``f_high``, ``k``, ``c`` of the logistic when it was fitted, none for
    an interpolation) with the crossing amount and its interval.

    Attributes
    ----------
    product, unit
        Product (with condition) and the unit of its amounts (µL, mg).
    method
        ``"logistic"``, ``"interpolation"`` or ``"none"`` (no crossing).
    status
        ``"crosses"``, ``"below threshold at every amount"`` or ``"above ..."``.
    crossing, crossing_low, crossing_high
        Amount where f falls below the threshold and its interval (NaN where
        not reported).
    band_low_amount, band_high_amount
        Amounts where f enters and leaves the optimal band.
    cov
        Covariance of the logistic parameters (pooled residual variance).
    notes
        What the fit decided (fallbacks to interpolation ...).
    p_inside, p_below_at_largest, p_above_at_smallest, verdict
        The evidence of :func:`crossing_probabilities` (NaN / "" without a
        logistic fit with an interval).
    """

    product: str = ""
    unit: str = ""
    method: str = ""
    status: str = ""
    crossing: float = _NAN
    crossing_low: float = _NAN
    crossing_high: float = _NAN
    band_low_amount: float = _NAN
    band_high_amount: float = _NAN
    cov: Any = None
    notes: list[str] = field(default_factory=list)
    p_inside: float = _NAN
    p_below_at_largest: float = _NAN
    p_above_at_smallest: float = _NAN
    verdict: str = ""

    @property
    def n(self) -> int:
        """Number of amounts of the series."""
        return self.n_points

    @classmethod
    def of(cls, c: _Crossing) -> CrossingFit:
        """The result of a finished :class:`_Crossing`."""
        extra = {k: getattr(c, k) for k in ("product", "unit", "method", "status", "crossing",
                                            "crossing_low", "crossing_high", "band_low_amount",
                                            "band_high_amount", "notes", "p_inside",
                                            "p_below_at_largest", "p_above_at_smallest",
                                            "verdict")}
        meta = {"product": c.product, "method": c.method, "status": c.status,
                "source": c.product}
        common = {"residual_unit": "-", "x_column": "applied_amount", "y_column": "f_measured",
                  "meta": meta, "n_points": c.n, "data": c.data, "warnings": list(c.notes)}
        if c.method == "logistic" and c.cov is not None:
            names = ("f_low", "f_high", "k", "c")
            r = c.data["residual"].to_numpy()
            res = cls.from_covariance("amount_crossing", names, [c.params[n] for n in names],
                                      c.cov, dof=max(c.dof, 1), residual_norm=float(
                                          np.sqrt(np.mean(r * r))), **common, **extra)
            res.cov = c.cov
            return res
        params = dict(c.params)
        names = tuple(params)
        inf = {n: math.inf for n in names}
        return cls(kind="amount_crossing", names=names, params=params, stderr=inf,
                   ci95={n: (_NAN, _NAN) for n in names},
                   correlation=np.full((len(names), len(names)), np.nan),
                   residual_norm=_NAN, cov=c.cov, **common, **extra)


def _ln_crossing(p: dict[str, float], level: float) -> float:
    fl, fh, k, c = p["f_low"], p["f_high"], p["k"], p["c"]
    q = (fh - fl) / (level - fl) - 1.0
    return c + math.log(q) / k


def _ln_crossing_grad(p: dict[str, float], level: float) -> np.ndarray:
    fl, fh, k = p["f_low"], p["f_high"], p["k"]
    q = (fh - fl) / (level - fl) - 1.0
    d_fh = 1.0 / (k * q * (level - fl))
    d_fl = (fh - level) / (k * q * (level - fl) ** 2)
    d_k = -math.log(q) / k**2
    return np.array([d_fl, d_fh, d_k, 1.0])


def crossing_probabilities(params: dict[str, float], cov: Any, amounts: Any, threshold: float,
                           dof: float, *, probability: float = CROSSING_PROBABILITY
                           ) -> dict[str, Any]:
    """Evidence for a threshold crossing under the logistic fit's uncertainty.

    The log crossing amount is ``ln A* ~ ln A*_hat + se T_dof`` (delta method,
    Student t with the pooled degrees of freedom, as the interval), the fitted
    friction at an amount ``f(x) ~ f_hat(x) + se_f(x) T_dof``.

    Parameters
    ----------
    params, cov
        Logistic parameters ``f_low, f_high, k, c`` and their covariance.
    amounts
        The tested amounts (any unit, > 0).
    threshold
        The low-friction threshold.
    dof
        Degrees of freedom of the covariance.
    probability
        Probability needed to call the verdict.

    Returns
    -------
    dict
        ``p_inside`` (the crossing lies between the smallest and the largest
        amount), ``p_below_at_largest``, ``p_above_at_smallest`` and
        ``verdict``: ``"crosses within the tested amounts"`` when
        ``p_inside >= probability``, else ``"undetermined"``.
    """
    from scipy.special import expit

    from torlab._stats import t_cdf  # scipy.stats.t.cdf, without its import

    a = np.asarray(amounts, dtype=float)
    x_lo, x_hi = math.log(float(a.min())), math.log(float(a.max()))
    C = np.asarray(cov, dtype=float)
    fl, fh, k, c = params["f_low"], params["f_high"], params["k"], params["c"]

    def f_and_grad(x: float) -> tuple[float, np.ndarray]:
        e = float(expit(-k * (x - c)))
        d = e * (1.0 - e)
        return fl + (fh - fl) * e, np.array([1.0 - e, e, -(fh - fl) * d * (x - c),
                                             (fh - fl) * d * k])

    out: dict[str, Any] = {"p_inside": float("nan")}
    for x, key, below in ((x_hi, "p_below_at_largest", True), (x_lo, "p_above_at_smallest", False)):
        f, g = f_and_grad(x)
        se = math.sqrt(max(float(g @ C @ g), 0.0))
        cdf = float(t_cdf((threshold - f) / se, dof)) if se > 0 else float(f < threshold)
        out[key] = cdf if below else 1.0 - cdf
    if fl < threshold < fh:
        lc = _ln_crossing(params, threshold)
        gr = _ln_crossing_grad(params, threshold)
        se = math.sqrt(max(float(gr @ C @ gr), 0.0))
        if se > 0:
            out["p_inside"] = float(t_cdf((x_hi - lc) / se, dof)
                                    - t_cdf((x_lo - lc) / se, dof))
        else:
            out["p_inside"] = float(x_lo <= lc <= x_hi)
    else:
        out["p_inside"] = 0.0
    out["verdict"] = ("crosses within the tested amounts" if out["p_inside"] >= probability
                      else "undetermined")
    return out


def _interp_crossing(x: np.ndarray, f: np.ndarray, level: float) -> float:
    """ln amount where ``f`` first falls below ``level`` (linear in ln amount), NaN if never."""
    for i in range(len(x) - 1):
        if f[i] >= level > f[i + 1]:
            return float(x[i] + (level - f[i]) * (x[i + 1] - x[i]) / (f[i + 1] - f[i]))
    return float("nan")


def fit_crossings(series: Any, *, threshold: float, band: tuple[float, float],
                  curve: str = "logistic", confidence: float = 0.95,
                  probability: float = CROSSING_PROBABILITY) -> list[CrossingFit]:
    """Threshold crossing per product (see the module docstring).

    A product whose series does not cross the threshold gets no logistic fit
    (``method = "none"``); a logistic fit that does not converge or ends at a
    bound of ``k`` or ``c`` falls back to interpolation, and says so in its notes.
    Each logistic crossing with an interval gets its evidence
    (:func:`crossing_probabilities`, the verdict called at ``probability``).
    """
    from scipy.optimize import least_squares

    fits: list[_Crossing] = []
    jacs: dict[str, Any] = {}
    ss, dof = 0.0, 0
    for prod, g in series.groupby("product", sort=False):
        g = g.sort_values("applied_amount")
        a = g["applied_amount"].to_numpy(dtype=float)
        f = g["f"].to_numpy(dtype=float)
        x = np.log(a)
        unit = str(g["applied_amount_unit"].iloc[0])
        cf = _Crossing(product=str(prod), unit=unit, n=len(a), method=curve)
        if f.max() < threshold:
            cf.status = "below threshold at every amount"
        elif f[-1] >= threshold and f.min() >= threshold:
            cf.status = "above threshold at every amount"
        else:
            cf.status = "crosses"
        lin = _interp_crossing(x, f, threshold)
        if curve == "logistic" and cf.status != "crosses":
            cf.method = "none"
        elif curve == "logistic" and len(a) >= 5 and np.ptp(x) > 0:
            x0 = [float(f.min()), float(f.max()), 2.0, float(np.mean(x))]
            lo = [0.0, 0.0, 0.05, float(x.min()) - 3.0]
            hi = [2.0, 2.0, 30.0, float(x.max()) + 3.0]
            x0 = np.clip(x0, np.array(lo) + 1e-9, np.array(hi) - 1e-9)
            sol = least_squares(lambda p, x=x, f=f: logistic(x, *p) - f, x0, bounds=(lo, hi),
                                x_scale=[0.1, 0.1, 1.0, 1.0], xtol=1e-12, ftol=1e-12,
                                gtol=1e-12, max_nfev=5000)
            if not sol.success:
                cf.notes.append(f"{prod}: the logistic fit did not converge ({sol.message}); "
                                "crossing by interpolation")
                cf.method = "interpolation"
                fits.append(_finish(cf, x, f, a, lin, threshold, band))
                continue
            cf.params = dict(zip(("f_low", "f_high", "k", "c"), map(float, sol.x), strict=True))
            at_bound = [n for n, v, lb, ub in zip(cf.params, sol.x, lo, hi, strict=True)
                        if n != "f_low" and n != "f_high" and (abs(v - lb) < 1e-6 or abs(v - ub) < 1e-6)]
            if at_bound:
                cf.notes.append(f"{prod}: logistic parameter(s) {', '.join(at_bound)} at their "
                                "bound: the series does not determine the curve; crossing by "
                                "interpolation")
                cf.method = "interpolation"
            else:
                jacs[cf.product] = sol.jac
                ss += float(sol.fun @ sol.fun)
                dof += len(a) - 4
        elif curve == "logistic":
            cf.notes.append(f"{prod}: fewer than 5 amounts, crossing by interpolation")
            cf.method = "interpolation"
        fits.append(_finish(cf, x, f, a, lin, threshold, band))
    sc = run_scatter(series, ss, dof, [cf.product for cf in fits if cf.product in jacs])
    _intervals(fits, jacs, sc["sd"] ** 2 * sc["dof"] if sc["dof"] else ss, sc["dof"] or dof,
               threshold, confidence, series, probability)
    out = [CrossingFit.of(cf) for cf in fits]
    for r in out:
        r.meta["scatter"] = sc
    return out


def run_scatter(series: Any, ss: float, dof: int, products: list[str]) -> dict[str, Any]:
    """What the crossing intervals hold: the scatter of one run's f about its product's
    curve, from the residuals about the logistic curves or, where runs repeat an amount,
    from the repeats (one-way random effects, :func:`torlab.random_effects.one_way`).

    Each amount of a Paper C series is one HPT run, and a run's f differs from the
    product's curve by the run-to-run scatter (a new sample, a new application) and by the
    run's own noise over its window.  With one run per amount the residuals about the
    fitted curves hold both together (and any misfit of the logistic shape), and nothing
    in the data separates them.  Runs that repeat an amount measure the scatter of one
    run about its amount's mean without the curve (REML, the pooled within-amount
    variance on ``sum (n - 1)`` degrees of freedom); the intervals then use the larger of
    the two variances (never below what the repeats show), with its degrees of freedom.

    Parameters
    ----------
    series
        The amount series (:func:`amount_series`).
    ss, dof
        Residual sum of squares and degrees of freedom of the logistic fits, pooled.
    products
        The products with a logistic fit (whose residuals ``ss`` holds).

    Returns
    -------
    dict
        ``sd``, ``dof`` (the scatter the intervals use; NaN / 0 without either),
        ``basis`` (``residuals`` or ``repeats``), ``sd_residual``, ``dof_residual``,
        ``sd_repeats``, ``dof_repeats``, ``repeated_amounts`` (amounts with two or more
        runs, over the products) and ``holds`` (the sentence the reports print).
    """
    from torlab.random_effects import one_way

    sd_res = math.sqrt(ss / dof) if dof > 0 else _NAN
    sel = series["product"].isin(products) if len(series) else series.index == -1
    sub = series[sel]
    rep = one_way(sub["f"].to_numpy(dtype=float),
                  [f"{p}|{a!r}" for p, a in zip(sub["product"], sub["applied_amount"],
                                                strict=True)]) if len(sub) else {"dof": 0}
    sd_rep, dof_rep = float(rep.get("sd_test", _NAN)), int(rep.get("dof", 0))
    out = {"sd_residual": sd_res, "dof_residual": int(dof), "sd_repeats": sd_rep,
           "dof_repeats": dof_rep, "repeated_amounts": int(rep.get("n_compositions", 0))}
    if dof_rep > 0 and (not math.isfinite(sd_res) or sd_rep > sd_res):
        out.update(sd=sd_rep, dof=dof_rep, basis="repeats")
    else:
        out.update(sd=sd_res, dof=int(dof) if math.isfinite(sd_res) else 0, basis="residuals")
    if dof_rep > 0:
        out["holds"] = (
            f"runs repeat {out['repeated_amounts']} amounts: the scatter of one run about its "
            f"amount's mean is {sd_rep:.3g} ({dof_rep} degrees of freedom, one-way random "
            f"effects), the scatter about the logistic curves {sd_res:.3g} ({dof} degrees of "
            f"freedom); the intervals use the larger ({out['basis']}). Either holds the "
            "run-to-run scatter and each run's own noise together: a run's own noise over its "
            "window is not separated from it")
    else:
        out["holds"] = (
            "one run per amount: the intervals hold the scatter of the runs about the "
            f"products' logistic curves ({sd_res:.3g}, pooled over the products, {dof} "
            "degrees of freedom), which is the run-to-run scatter and each run's own noise "
            "together, plus any misfit of the logistic shape; with one run per amount the data "
            "cannot tell these apart (repeated runs at an amount would measure the run-to-run "
            "scatter)")
    return out


def _finish(cf: _Crossing, x: np.ndarray, f: np.ndarray, a: np.ndarray, lin: float,
            threshold: float, band: tuple[float, float]) -> _Crossing:
    """Crossing and band amounts of one product from its fit (or interpolation)."""
    import pandas as pd

    p = cf.params
    model = logistic(x, **p) if cf.method == "logistic" and p else np.interp(x, x, f)
    cf.data = pd.DataFrame({"applied_amount": a, "ln_amount": x, "f_measured": f,
                            "f_model": model, "residual": f - model})
    if cf.status == "crosses" and cf.method == "logistic":
        if p["f_low"] < threshold < p["f_high"]:
            cf.crossing = math.exp(_ln_crossing(p, threshold))
        if not (a.min() <= cf.crossing <= a.max()):
            cf.notes.append(f"{cf.product}: the logistic crossing lies outside the tested "
                            "amounts; crossing by interpolation")
            cf.method = "interpolation"
    if cf.status == "crosses" and cf.method == "interpolation":
        cf.crossing = math.exp(lin) if math.isfinite(lin) else float("nan")
    for level, attr in ((band[1], "band_low_amount"), (band[0], "band_high_amount")):
        if cf.method == "logistic":
            if p["f_low"] < level < p["f_high"]:
                v = math.exp(_ln_crossing(p, level))
                if a.min() <= v <= a.max():
                    setattr(cf, attr, v)
        else:
            v = _interp_crossing(x, f, level)
            if math.isfinite(v):
                setattr(cf, attr, math.exp(v))
    return cf


def _intervals(fits: list[_Crossing], jacs: dict[str, Any], ss: float, dof: int,
               threshold: float, confidence: float, series: Any = None,
               probability: float = CROSSING_PROBABILITY) -> None:
    """Pooled residual variance -> delta-method intervals on ln A*."""
    from torlab._stats import t_ppf  # scipy.stats.t.ppf, without its import

    if dof >= 1:
        s2 = ss / dof
        tq = float(t_ppf(0.5 + confidence / 2, dof))
        for cf in fits:
            if cf.product not in jacs:
                continue
            J = jacs[cf.product]
            try:
                cov = np.linalg.inv(J.T @ J) * s2
            except np.linalg.LinAlgError:
                cf.notes.append(f"{cf.product}: singular fit, no interval")
                continue
            cf.cov, cf.dof = cov, dof
            if cf.status == "crosses" and cf.method == "logistic" and math.isfinite(cf.crossing):
                gr = _ln_crossing_grad(cf.params, threshold)
                se = math.sqrt(max(float(gr @ cov @ gr), 0.0))
                lc = math.log(cf.crossing)
                cf.crossing_low, cf.crossing_high = math.exp(lc - tq * se), math.exp(lc + tq * se)
                if series is not None:
                    amounts = series.loc[series["product"] == cf.product, "applied_amount"]
                    ev = crossing_probabilities(cf.params, cov, amounts, threshold, dof,
                                                probability=probability)
                    cf.p_inside = ev["p_inside"]
                    cf.p_below_at_largest = ev["p_below_at_largest"]
                    cf.p_above_at_smallest = ev["p_above_at_smallest"]
                    cf.verdict = ev["verdict"]
    elif any(cf.method == "logistic" for cf in fits):
        for cf in fits:
            cf.notes.append(f"{cf.product}: no residual degrees of freedom, no interval")


def _pooled_scatter(fits: list[CrossingFit]) -> tuple[float, int]:
    """Run-to-run scatter of f pooled over the products' logistic fits: (sd, dof) of
    :func:`run_scatter` (the repeats' where they show more)."""
    sc = next((cf.meta.get("scatter") for cf in fits if cf.meta.get("scatter")), None)
    if sc is not None:
        return (sc["sd"], sc["dof"]) if sc["dof"] > 0 else (_NAN, 0)
    ss, dof = 0.0, 0
    for cf in fits:
        if cf.method == "logistic" and cf.data is not None and cf.cov is not None:
            r = cf.data["residual"].to_numpy(dtype=float)
            ss += float(r @ r)
            dof += r.size - 4
    return (math.sqrt(ss / dof), dof) if dof > 0 else (_NAN, 0)


def _status_evidence(series: Any, cf: CrossingFit, thr: float, pooled: tuple[float, int],
                     prob: float) -> dict[str, Any]:
    """The probability behind "above (below) the threshold at every amount".

    At the amount where the series comes closest to the threshold (the mean of
    its repeats), the probability that the true f is on the reported side,
    from the pooled run-to-run scatter (Student t).  NaN without a pooled scatter
    or for a crossing product.
    """
    from torlab._stats import t_cdf  # scipy.stats.t.cdf, without its import

    out: dict[str, Any] = {"p_status": _NAN, "status_verdict": ""}
    s, dof = pooled
    if cf.status == "crosses" or not (math.isfinite(s) and s > 0 and dof > 0):
        return out
    g = series[series["product"] == cf.product].groupby("applied_amount")["f"]
    mean, n = g.mean(), g.count()
    above = cf.status.startswith("above")
    i = mean.idxmin() if above else mean.idxmax()
    z = (float(mean[i]) - thr) / (s / math.sqrt(float(n[i])))
    p = float(t_cdf(z if above else -z, dof))
    out["p_status"] = p
    out["status_verdict"] = cf.status if p >= prob else "undetermined"
    return out


def mass_homogeneity(rows: list[dict[str, Any]], tq: float) -> dict[str, Any] | None:
    """Do the products cross the threshold at one applied mass? (thesis H3.2)

    The log crossing masses with their delta-method standard errors (the
    intervals' half-widths in ``ln A*`` over their quantile ``tq``) against their
    weighted mean: ``chi2 = sum((m_i - m)^2 / se_i^2)`` on ``k - 1`` degrees of
    freedom.  None with fewer than two products with a crossing interval.
    """
    from torlab._stats import chi2_sf, norm_ppf  # scipy.stats's, without its import

    z = float(norm_ppf(0.975))
    ms, ses, names = [], [], []
    for r in rows:
        lo, hi, m = r.get("crossing_mass_low_mg"), r.get("crossing_mass_high_mg"), \
            r.get("crossing_mass_mg")
        if not all(isinstance(v, float) and math.isfinite(v) and v > 0 for v in (lo, hi, m)):
            continue
        ms.append(math.log(m))
        ses.append((math.log(hi) - math.log(lo)) / (2 * tq))
        names.append(r["product"])
    if len(ms) < 2:
        return None
    m, se = np.array(ms), np.array(ses)
    w = 1 / se**2
    mbar = float(np.sum(w * m) / np.sum(w))
    sebar = float(1 / math.sqrt(np.sum(w)))
    c2 = float(np.sum(w * (m - mbar) ** 2))
    k = len(ms)
    return {"products": names, "chi2": c2, "dof": k - 1, "p_value": float(chi2_sf(c2, k - 1)),
            "mass_mg": math.exp(mbar), "mass_low_mg": math.exp(mbar - z * sebar),
            "mass_high_mg": math.exp(mbar + z * sebar),
            "ratio_largest_to_smallest": math.exp(float(m.max() - m.min()))}


def mass_factor(series: Any, product: str) -> float:
    """mg per unit of the product's applied amount (NaN without a density)."""
    g = series[series["product"] == product]
    r = g.iloc[0]
    if r["amount_kind"] == "mass":
        return 1.0 if r["applied_amount_unit"] == "mg" else float(g["mass_mg"].iloc[0] /
                                                                  g["applied_amount"].iloc[0])
    return float(r["mass_mg"] / r["applied_amount"]) if math.isfinite(r["mass_mg"]) else float("nan")


def crossing_row(series: Any, cf: CrossingFit) -> dict[str, Any]:
    """A product's row of the crossings table (without the status evidence)."""
    mf = mass_factor(series, cf.product)
    ptype = str(series.loc[series["product"] == cf.product, "product_type"].iloc[0])
    return {
        "product": cf.product, "product_type": ptype, "n_amounts": cf.n,
        "amount_unit": cf.unit, "status": cf.status, "method": cf.method,
        "crossing_amount": cf.crossing, "crossing_amount_low": cf.crossing_low,
        "crossing_amount_high": cf.crossing_high,
        "crossing_mass_mg": cf.crossing * mf, "crossing_mass_low_mg": cf.crossing_low * mf,
        "crossing_mass_high_mg": cf.crossing_high * mf,
        "band_amount_from": cf.band_low_amount, "band_amount_to": cf.band_high_amount,
        "mg_per_unit": mf,
        "p_crossing_in_range": cf.p_inside, "p_below_at_largest": cf.p_below_at_largest,
        "p_above_at_smallest": cf.p_above_at_smallest, "crossing_verdict": cf.verdict,
    }


def amount_statistics(series: Any, fits: list[CrossingFit], *, threshold: float,
                      confidence: float, probability: float = CROSSING_PROBABILITY
                      ) -> dict[str, Any]:
    """The report's probabilities beyond the crossing fits (plain numbers, cacheable).

    Returns
    -------
    dict
        ``pooled``: ``[sd, dof]`` of the run-to-run scatter pooled over the logistic fits;
        ``status``: product -> ``{p_status, status_verdict}`` (:func:`_status_evidence`);
        ``t_quantile``: Student t quantile of ``confidence`` on the pooled degrees of
        freedom (NaN without them); ``mass_homogeneity``: :func:`mass_homogeneity` of the
        crossing masses (None with fewer than two); ``scatter``: what the intervals hold
        (:func:`run_scatter`; None without a logistic fit).
    """
    from torlab._stats import t_ppf  # scipy.stats.t.ppf, without its import

    pooled = _pooled_scatter(fits)
    status = {cf.product: _status_evidence(series, cf, threshold, pooled, probability)
              for cf in fits}
    tq = float(t_ppf(0.5 + confidence / 2, pooled[1])) if pooled[1] > 0 else _NAN
    rows = [crossing_row(series, cf) for cf in fits]
    same = mass_homogeneity(rows, tq) if math.isfinite(tq) else None
    sc = next((cf.meta.get("scatter") for cf in fits if cf.meta.get("scatter")), None)
    return {"pooled": [pooled[0], pooled[1]], "status": status, "t_quantile": tq,
            "mass_homogeneity": same, "scatter": sc}


def logistic_band(x: np.ndarray, cf: CrossingFit) -> tuple[np.ndarray, np.ndarray] | None:
    """95 % band of the fitted logistic mean curve at ``x = ln amount`` (delta method on the
    parameters' covariance, Student t on the pooled degrees of freedom), None without one."""
    if cf.cov is None or cf.method != "logistic":
        return None
    from scipy.special import expit, stdtrit

    C = np.asarray(cf.cov, dtype=float)
    if C.shape != (4, 4) or not np.all(np.isfinite(C)):
        return None
    p = cf.params
    s = expit(-p["k"] * (x - p["c"]))
    d = p["f_high"] - p["f_low"]
    ds = s * (1.0 - s)
    J = np.stack([1.0 - s, s, -d * ds * (x - p["c"]), d * ds * p["k"]], axis=1)
    se = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", J, C, J), 0.0))
    q = float(stdtrit(max(cf.dof, 1), 0.975))
    y = logistic(x, **p)
    return y - q * se, y + q * se
