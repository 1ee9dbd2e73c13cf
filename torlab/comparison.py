"""Is product A better than product B? Differences with their intervals and probabilities.

Two or more products, compositions or conditions are compared on each quantity they share
(the layer's ``mu_c1``, ``mu_c2`` -- every layer law's parameters -- temperature coefficients, a crossing amount, retention
figures, time-test levels, a film's speed exponent ...).  Every quantity of every item is
an :class:`Estimate`: a value with its standard error and degrees of freedom, and what its
interval holds (one record, or several runs pooled with their scatter).  Items that share a
label are repeats: they are pooled first with the random-effects model of
:mod:`torlab.random_effects` (REML between-run variance, Hartung-Knapp on ``runs - 1``
degrees of freedom), so the comparison sees the scatter between runs.

For each pair (every item against a reference, or all pairs):

* **difference** ``a - b`` (a ratio ``a / b`` for a positive quantity whose scatter is
  relative: the difference of the logarithms), with standard error
  ``sqrt(se_a^2 + se_b^2)`` (the items are measured independently) and Welch-Satterthwaite
  degrees of freedom ``(se_a^2 + se_b^2)^2 / (se_a^4/nu_a + se_b^4/nu_b)``; its 95 %
  interval is Student t on them (Welch 1947);
* **P(A higher)**: the probability that A's true value is the larger, ``T_nu(d / se)``:
  the posterior probability of a flat prior on the true difference (equal to one minus the
  one-sided p-value of the same t statistic).  With a stated direction (``better``: the
  higher or the lower value is better) it is **P(A better)**, and a verdict is called when
  it reaches ``probability`` (0.9) either way, else ``undetermined``;
* with more than two items, a **ranking** with probabilities: draws of every item's true
  value from its t distribution (seeded), the probability of each rank and of being the
  best, and the expected rank.

The virtual campaigns of ``tests/test_compare.py`` check the claims: the true differences
lie inside the 95 % intervals in at least 95 % of the seeds, and of the calls made at a
probability of 0.9 or more at least 90 % are right (``docs/uncertainty.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.codec import finite_tree

__all__ = ["COMPARE_PROBABILITY", "QUANTITIES", "CompareResult", "Comparison", "Estimate",
           "Item", "compare", "item_from_fit", "item_from_params", "items_from_path",
           "items_from_time_tests", "pool_items", "ranking"]

#: probability a comparison's verdict needs to be called
COMPARE_PROBABILITY = 0.9


@dataclass(frozen=True)
class QuantitySpec:
    """What a quantity is: its symbol and unit in tables and figures, its scale, and which
    direction is better (None: not stated unless the user says)."""

    label: str
    unit: str
    log: bool = False
    better: str | None = None
    factor: float = 1.0
    shown_unit: str = ""

    @property
    def display_unit(self) -> str:
        """Unit the tables and figures show (``shown_unit``, else the SI unit)."""
        return self.shown_unit or self.unit


def _layer_quantities() -> dict[str, QuantitySpec]:
    """The layer laws' parameters (:mod:`torlab.model.layers`): lengths shown in µm,
    temperature coefficients per 1000 K, positive ones compared as ratios; and the
    temperature fit's coefficients at the reference temperature."""
    from torlab.model.layers import all_params

    out: dict[str, QuantitySpec] = {}
    for n, p in all_params().items():
        if p.kind == "length":
            out[n] = QuantitySpec(p.symbol, p.unit, log=p.positive, factor=1e6, shown_unit="µm")
        elif p.temperature_of is not None:
            out[n] = QuantitySpec(p.symbol, p.unit, factor=1e3, shown_unit="1/(1000 K)")
        else:
            out[n] = QuantitySpec(p.symbol, p.unit, log=p.positive)
    for p in all_params().values():
        if p.temperature_of is not None:
            base = all_params()[p.temperature_of]
            out[f"{base.name}_Tref"] = QuantitySpec(f"{base.symbol}(Tref)", base.unit, log=True)
    return out


#: the quantities torlab compares, by name: symbol, SI unit, scale, default direction,
#: display factor and unit
QUANTITIES: dict[str, QuantitySpec] = {
    **_layer_quantities(),
    "speed_exponent": QuantitySpec("film speed exponent", "-"),
    "film_prefactor": QuantitySpec("film prefactor", "m", log=True, factor=1e9,
                                   shown_unit="nm"),
    "alpha": QuantitySpec("α", "1/Pa", log=True, factor=1e9, shown_unit="1/GPa"),
    "eta0": QuantitySpec("η0", "Pa*s", log=True, factor=1e3, shown_unit="mPa·s"),
    "Z": QuantitySpec("Z", "-"),
    "crossing_mass": QuantitySpec("applied mass where f crosses the threshold", "kg", log=True,
                                  factor=1e6, shown_unit="mg"),
    "f_window": QuantitySpec("HPT friction f", "-", log=True),
    "mean_after_recovery": QuantitySpec("mean μ after recovery", "-"),
    "minimum": QuantitySpec("minimum μ", "-"),
    "recovery_time_s": QuantitySpec("time to recover", "s"),
    "time_below_threshold_s": QuantitySpec("time below the threshold", "s", better="lower"),
    "passes_to_leave_band": QuantitySpec("passes until μ leaves the band", "-", log=True,
                                         better="higher"),
    "effective_friction": QuantitySpec("effective friction level", "-"),
    "retentivity": QuantitySpec("retentivity", "-", log=True, better="higher",
                                shown_unit="passes"),
    "fraction_in_band": QuantitySpec("fraction of passes in the band", "-", better="higher"),
}


def spec(name: str) -> QuantitySpec:
    """The :class:`QuantitySpec` of ``name`` (a plain linear one for unknown names)."""
    return QUANTITIES.get(name, QuantitySpec(name, ""))


@dataclass(frozen=True)
class Estimate:
    """One quantity of one item.

    Attributes
    ----------
    value
        The estimate (SI).
    se
        Its standard error on the comparison scale: of ``ln value`` when ``log``,
        else of ``value``.
    dof
        Degrees of freedom of its Student-t interval (``inf``: normal).
    log
        Compared as a ratio (a positive quantity with relative scatter).
    runs
        Runs it rests on (1: one record).
    holds
        What its interval holds, in words.
    """

    value: float
    se: float
    dof: float = math.inf
    log: bool = False
    runs: int = 1
    holds: str = ""

    @classmethod
    def from_interval(cls, value: float, low: float, high: float, dof: float = math.inf, *,
                      log: bool = False, runs: int = 1, holds: str = "") -> Estimate:
        """From a 95 % Student-t interval (on ``ln`` when ``log``, as torlab writes the
        intervals of positive parameters)."""
        tq = _tq(dof)
        if log and value > 0 and low > 0 and high > 0:
            se = (math.log(high) - math.log(low)) / (2 * tq)
        else:
            se = (high - low) / (2 * tq)
        return cls(float(value), float(se), float(dof), bool(log and value > 0), runs, holds)

    @property
    def z(self) -> float:
        """The value on the comparison scale."""
        return math.log(self.value) if self.log else self.value

    def interval(self, confidence: float = 0.95) -> tuple[float, float]:
        """Its interval on the natural scale."""
        tq = _tq(self.dof, confidence)
        if self.log:
            return self.value * math.exp(-tq * self.se), self.value * math.exp(tq * self.se)
        return self.value - tq * self.se, self.value + tq * self.se


def _tq(dof: float, confidence: float = 0.95) -> float:
    from torlab._stats import t_ppf

    return float(t_ppf(0.5 + confidence / 2, min(max(float(dof), 1.0), 1e6)))


def _nan_if_inf(x: float) -> float:
    """A table's degrees of freedom: an infinite one (a normal interval) as an empty cell."""
    return float(x) if math.isfinite(x) else math.nan


def _t_cdf(x: float, dof: float) -> float:
    from torlab._stats import t_cdf

    return float(t_cdf(x, min(max(float(dof), 1.0), 1e6)))


@dataclass
class Item:
    """A product, composition or condition: its estimates by quantity name."""

    label: str
    estimates: dict[str, Estimate] = field(default_factory=dict)
    sources: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def pool_items(items: list[Item]) -> list[Item]:
    """Items that share a label are repeats: each quantity pooled over them with random
    effects (:func:`torlab.random_effects.pool`, on ``ln`` for ratio quantities).  The
    order of first appearance is kept."""
    from torlab.random_effects import METHOD, pool

    groups: dict[str, list[Item]] = {}
    for it in items:
        groups.setdefault(it.label, []).append(it)
    out = []
    for label, its in groups.items():
        if len(its) == 1:
            out.append(its[0])
            continue
        names = list(dict.fromkeys(n for it in its for n in it.estimates))
        est: dict[str, Estimate] = {}
        notes = [n for it in its for n in it.notes]
        for n in names:
            es = [it.estimates[n] for it in its if n in it.estimates]
            if len(es) == 1:
                est[n] = es[0]
                continue
            log = all(e.log for e in es)
            z = [math.log(e.value) if log else e.value for e in es]
            pl = pool(z, [e.se ** 2 for e in es], dof_one=es[0].dof)
            val = math.exp(pl.estimate) if log else pl.estimate
            holds = (f"{pl.k} runs pooled ({METHOD}): scatter between runs "
                     f"{100 * pl.share_between:.0f} % of the variance")
            est[n] = Estimate(val, pl.se, pl.dof, log, sum(e.runs for e in es), holds)
        out.append(Item(label, est, [s for it in its for s in it.sources], notes))
    return out


@dataclass(frozen=True)
class Comparison:
    """One quantity of item ``a`` against item ``b`` (module docstring)."""

    quantity: str
    a: str
    b: str
    a_value: float
    b_value: float
    kind: str  # "difference" or "ratio"
    estimate: float
    low: float
    high: float
    se: float
    dof: float
    p_a_higher: float
    better: str | None
    p_better: float | None
    verdict: str
    holds: str

    def row(self) -> dict[str, Any]:
        """A table row (SI values; the display unit and factor in their columns)."""
        sp = spec(self.quantity)
        return {"quantity": self.quantity, "symbol": sp.label, "unit": sp.unit,
                "a": self.a, "b": self.b, "a_value": self.a_value, "b_value": self.b_value,
                "kind": self.kind, "estimate": self.estimate, "ci95_low": self.low,
                "ci95_high": self.high, "dof": _nan_if_inf(self.dof),
                "p_a_higher": self.p_a_higher,
                "better": self.better or "", "p_a_better": (math.nan if self.p_better is None
                                                            else self.p_better),
                "verdict": self.verdict, "holds": self.holds}


def _compare_pair(q: str, a: Item, b: Item, better: str | None, probability: float,
                  confidence: float) -> Comparison:
    ea, eb = a.estimates[q], b.estimates[q]
    log = ea.log and eb.log
    za = math.log(ea.value) if log else ea.value
    zb = math.log(eb.value) if log else eb.value
    # an estimate compared on the other scale: its standard error by the delta method
    sa = ea.se if ea.log == log else (ea.se / ea.value if log else ea.se * ea.value)
    sb = eb.se if eb.log == log else (eb.se / eb.value if log else eb.se * eb.value)
    d = za - zb
    var = sa * sa + sb * sb
    se = math.sqrt(var)
    den = (sa ** 4 / max(ea.dof, 1.0) if sa > 0 else 0.0) + \
        (sb ** 4 / max(eb.dof, 1.0) if sb > 0 else 0.0)
    dof = var * var / den if den > 0 else math.inf
    tq = _tq(dof, confidence)
    lo, hi = d - tq * se, d + tq * se
    if se > 0:
        p_hi = _t_cdf(d / se, dof)
    else:
        p_hi = 1.0 if d > 0 else 0.0 if d < 0 else 0.5
    if log:
        est, lo, hi, kind = math.exp(d), math.exp(lo), math.exp(hi), "ratio"
    else:
        est, kind = d, "difference"
    p_better = None if better is None else (p_hi if better == "higher" else 1.0 - p_hi)
    if p_better is not None:
        verdict = (f"{a.label} better" if p_better >= probability else
                   f"{b.label} better" if 1.0 - p_better >= probability else "undetermined")
    else:
        verdict = (f"{a.label} higher" if p_hi >= probability else
                   f"{a.label} lower" if 1.0 - p_hi >= probability else "undetermined")
    holds = "; ".join(dict.fromkeys(h for h in (ea.holds, eb.holds) if h))
    if verdict != "undetermined" and min(ea.runs, eb.runs) <= 1:
        # a call on one record: its noise only, not the scatter between repeated runs
        verdict += " (one run: record noise only)"
    return Comparison(q, a.label, b.label, ea.value, eb.value, kind, est, lo, hi, se, dof,
                      p_hi, better, p_better, verdict, holds)


def ranking(items: list[Item], quantity: str, better: str | None = None, *,
            draws: int = 20000, seed: int = 0) -> list[dict[str, Any]]:
    """The items ranked on ``quantity`` with probabilities (module docstring).

    Rank 1 is the best (with ``better``) or the highest value (without).  Returns one
    row per item: ``label``, ``value``, ``expected_rank``, ``p_best`` and ``p_rank_<r>``
    for every rank, in the order of the expected rank.
    """
    rng = np.random.default_rng(seed)
    its = [it for it in items if quantity in it.estimates]
    if not its:
        return []
    es = [it.estimates[quantity] for it in its]
    log = all(e.log for e in es)
    z = np.empty((draws, len(its)))
    for j, e in enumerate(es):
        se = e.se if e.log == log else (e.se / e.value if log else e.se * e.value)
        t = rng.standard_t(min(max(e.dof, 1.0), 1e6), size=draws)
        z[:, j] = (math.log(e.value) if log else e.value) + se * t
    sign = -1.0 if better == "lower" else 1.0
    order = np.argsort(-sign * z, axis=1)  # best first
    ranks = np.empty_like(order)
    rows = np.arange(draws)[:, None]
    ranks[rows, order] = np.arange(len(its))[None, :]
    out = []
    for j, (it, e) in enumerate(zip(its, es, strict=True)):
        r = ranks[:, j]
        row = {"label": it.label, "value": e.value, "expected_rank": float(np.mean(r) + 1),
               "p_best": float(np.mean(r == 0))}
        for k in range(len(its)):
            row[f"p_rank_{k + 1}"] = float(np.mean(r == k))
        out.append(row)
    out.sort(key=lambda x: x["expected_rank"])
    return out


@dataclass
class CompareResult:
    """What :func:`compare` finds: the comparisons, the rankings and what they rest on."""

    items: list[Item]
    comparisons: list[Comparison]
    rankings: dict[str, list[dict[str, Any]]]
    reference: str | None
    probability: float
    confidence: float
    better: dict[str, str]
    notes: list[str] = field(default_factory=list)

    def table(self) -> Any:
        """One row per comparison (:meth:`Comparison.row`)."""
        import pandas as pd

        cols = ["quantity", "symbol", "unit", "a", "b", "a_value", "b_value", "kind",
                "estimate", "ci95_low", "ci95_high", "dof", "p_a_higher", "better",
                "p_a_better", "verdict", "holds"]
        return pd.DataFrame([c.row() for c in self.comparisons], columns=cols)

    def values_table(self) -> Any:
        """One row per item and quantity: the value, its interval, runs, what it holds."""
        import pandas as pd

        rows = []
        for it in self.items:
            for q, e in it.estimates.items():
                lo, hi = e.interval(self.confidence)
                rows.append({"item": it.label, "quantity": q, "symbol": spec(q).label,
                             "unit": spec(q).unit, "value": e.value, "ci95_low": lo,
                             "ci95_high": hi, "dof": _nan_if_inf(e.dof), "runs": e.runs,
                             "holds": e.holds})
        return pd.DataFrame(rows, columns=["item", "quantity", "symbol", "unit", "value",
                                           "ci95_low", "ci95_high", "dof", "runs", "holds"])

    def ranking_table(self) -> Any:
        """One row per quantity and item of the rankings."""
        import pandas as pd

        rows = [{"quantity": q, **r} for q, rs in self.rankings.items() for r in rs]
        return pd.DataFrame(rows)

    def summary(self) -> dict[str, Any]:
        """For ``summary.json`` (finite numbers or None)."""
        return finite_tree({
            "reference": self.reference, "probability": self.probability,
            "confidence": self.confidence, "better": dict(self.better),
            "items": {it.label: {"sources": it.sources, "notes": it.notes,
                                 "quantities": sorted(it.estimates)} for it in self.items},
            "comparisons": [c.row() for c in self.comparisons],
            "rankings": self.rankings, "notes": list(self.notes),
            "method": ("difference (ratio for positive quantities with relative scatter) with "
                       "Welch-Satterthwaite Student-t interval; P(A higher) = T(d/se) (flat "
                       "prior on the true difference); repeats pooled by random effects; "
                       "rankings from seeded draws of each item's t distribution")})


def compare(items: list[Item], *, reference: str | None = None,
            quantities: list[str] | None = None, better: dict[str, str] | None = None,
            pairs: str = "reference", probability: float = COMPARE_PROBABILITY,
            confidence: float = 0.95, seed: int = 0) -> CompareResult:
    """Compare items on every quantity they share (module docstring).

    Parameters
    ----------
    items
        The items; those with one label are repeats, pooled first (:func:`pool_items`).
    reference
        The item the others are compared against (``pairs="reference"``); default the
        first.
    quantities
        Quantities to compare (default every quantity at least two items have).
    better
        ``{quantity: "higher" | "lower"}``: which direction is better (over the defaults
        of :data:`QUANTITIES`).
    pairs
        ``"reference"`` (every item against the reference) or ``"all"`` (every pair).
    probability
        Probability a verdict needs (:data:`COMPARE_PROBABILITY`).
    confidence
        Confidence of the intervals.
    seed
        Seed of the rankings' draws.

    Returns
    -------
    CompareResult

    Raises
    ------
    TorlabInputError
        Fewer than two items, an unknown reference or quantity, a direction other than
        higher/lower, no shared quantity.
    """
    from torlab._suggest import did_you_mean
    from torlab.errors import TorlabInputError

    its = pool_items(items)
    if len(its) < 2:
        raise TorlabInputError(f"compare needs two or more items; got {len(its)} "
                               f"({', '.join(it.label for it in its) or 'none'}): inputs of "
                               "one product are repeats of one item; label them to compare "
                               "them (LABEL=PATH)")
    labels = [it.label for it in its]
    if pairs not in ("reference", "all"):
        raise TorlabInputError(f"pairs must be 'reference' or 'all', not {pairs!r}", key="pairs")
    ref = reference if reference is not None else labels[0]
    if ref not in labels:
        raise TorlabInputError(f"reference {ref!r} is not among the items ({', '.join(labels)})"
                               f"{did_you_mean(ref, labels)}", key="reference")
    dirs = {q: s.better for q, s in QUANTITIES.items() if s.better}
    for q, d in (better or {}).items():
        if d not in ("higher", "lower"):
            raise TorlabInputError(f"better {q}={d!r}: say 'higher' or 'lower'", key="better")
        dirs[q] = d
    shared = [q for q in dict.fromkeys(n for it in its for n in it.estimates)
              if sum(q in it.estimates for it in its) >= 2]
    if quantities:
        unknown = [q for q in quantities if q not in shared]
        if unknown:
            raise TorlabInputError(
                f"{', '.join(unknown)}: not a quantity two items share (shared: "
                f"{', '.join(shared) or 'none'}){did_you_mean(unknown[0], shared)}",
                key="quantities")
        shared = list(quantities)
    if not shared:
        raise TorlabInputError("the items share no quantity to compare: "
                               + "; ".join(f"{it.label}: {', '.join(it.estimates) or 'none'}"
                                           for it in its))
    ref_item = its[labels.index(ref)]
    pl = [(a, ref_item) for a in its if a is not ref_item] if pairs == "reference" else \
        [(its[i], its[j]) for i in range(len(its)) for j in range(i + 1, len(its))]
    comps = [_compare_pair(q, a, b, dirs.get(q), probability, confidence)
             for q in shared for a, b in pl if q in a.estimates and q in b.estimates]
    ranks = {q: ranking(its, q, dirs.get(q), seed=seed) for q in shared
             if sum(q in it.estimates for it in its) > 2}
    notes = []
    single = sorted({it.label for it in its for q, e in it.estimates.items()
                     if q in shared and e.runs == 1})
    if single:
        notes.append(f"{', '.join(single)}: one run per quantity: its interval holds for that "
                     "record alone, not the scatter between repeated runs; a difference may be "
                     "that scatter (repeat the test to include it)")
    return CompareResult(its, comps, ranks, ref if pairs == "reference" else None,
                         probability, confidence, {q: d for q, d in dirs.items() if q in shared},
                         notes)


# ---------------------------------------------------------------------------------------------
# items from what a lab has: fit objects, parameter files, results folders, time tests
# ---------------------------------------------------------------------------------------------
#: parameters of a fit that are compared (the others, e.g. a logistic's shape, are not)
FIT_QUANTITIES = (*_layer_quantities(), "speed_exponent", "film_prefactor", "alpha", "eta0",
                  "Z")


def _runs(meta: dict[str, Any]) -> int:
    runs = meta.get("runs")
    return len(runs) if isinstance(runs, list) and runs else 1


def item_from_fit(fit: Any, label: str | None = None) -> Item:
    """An :class:`Item` of a :class:`~torlab.fit.result.FitResult`: its determined
    parameters (log-scale ones as ratios), each on its own interval's degrees of freedom."""
    from torlab.random_effects import ONE_RUN

    meta = fit.meta or {}
    lab = label or str(meta.get("product") or meta.get("source") or fit.kind)
    runs = _runs(meta)
    holds = (f"{runs} runs pooled: the scatter between runs and each run's own noise"
             if runs > 1 else ONE_RUN if meta.get("scatter") == ONE_RUN
             else str(meta.get("scatter") or ""))
    pdof = meta.get("interval_dof") if isinstance(meta.get("interval_dof"), dict) else {}
    est: dict[str, Estimate] = {}
    for n in fit.names:
        if n not in FIT_QUANTITIES or not fit.determined(n):
            continue
        v, se = float(fit.params[n]), float(fit.stderr[n])
        log = n in fit.log_scale and v > 0
        est[n] = Estimate(v, se / v if log else se, float(pdof.get(n, max(fit.dof, 1))), log,
                          runs, holds)
    return Item(lab, est, [str(meta.get("source", ""))])


def item_from_params(path: Any, label: str | None = None) -> Item:
    """An :class:`Item` of a parameter file (``torlab fit`` output ``params.yaml``): the
    ``fit:`` section's parameters with their standard errors and degrees of freedom.

    Raises
    ------
    TorlabInputError
        Not a parameter file with a ``fit:`` section of parameters.
    """
    from pathlib import Path

    from torlab.errors import TorlabInputError
    from torlab.yamlio import load_yaml

    doc = load_yaml(path)
    d = doc.data
    fit = d.get("fit") if isinstance(d, dict) else None
    pars = fit.get("parameters") if isinstance(fit, dict) else None
    if not isinstance(pars, dict) or not pars:
        raise TorlabInputError("not a parameter file of a torlab fit (a fit: section with "
                               "parameters:)", path=path)
    cov = fit.get("covariance") if isinstance(fit.get("covariance"), dict) else {}
    log_scale = set(cov.get("log_scale") or [])
    dof_all = cov.get("dof", fit.get("dof", math.inf))
    holds = str(fit.get("scatter") or "")
    runs = int(fit.get("runs_pooled") or 1)
    est: dict[str, Estimate] = {}
    for n, p in pars.items():
        if n not in FIT_QUANTITIES or not isinstance(p, dict):
            continue
        try:
            v = float(p["value"])
            se = float(p["stderr"]) if p.get("stderr") is not None else math.nan
            dof = float(p.get("dof", dof_all) if p.get("dof", dof_all) is not None else math.inf)
        except (KeyError, TypeError, ValueError):
            raise TorlabInputError(f"parameter {n}: value and stderr must be numbers",
                                   path=path, line=doc.lines.line(("fit", "parameters", n)),
                                   key=f"fit.parameters.{n}") from None
        if not (math.isfinite(v) and math.isfinite(se) and se >= 0):
            continue  # not determined (or fixed): not compared
        log = n in log_scale and v > 0
        est[n] = Estimate(v, se / v if log else se, dof, log, runs, holds)
    if not est:
        raise TorlabInputError("the parameter file has no determined parameter to compare",
                               path=path)
    prod = fit.get("product")
    if prod and fit.get("condition"):
        prod = f"{prod}-{fit['condition']}"
    lab = label or str(prod or Path(path).parent.name or Path(path).stem)
    return Item(lab, est, [str(path)])


#: what a single record's bootstrap interval holds, per figure (docs/uncertainty.md: the
#: coverage over simulated records)
_BOOTSTRAP_HOLDS = {
    "minimum": "the record's own noise (block bootstrap, corrected for the bias of a noisy "
               "record's minimum)",
    "recovery_time": "the record's own noise (block bootstrap); one record resolves a "
                     "crossing only roughly: such intervals held the true value in "
                     "77-97 % of simulated records",
    "time_below_threshold": "the record's own noise (block bootstrap); one record resolves a "
                            "crossing only roughly: such intervals held the true value in "
                            "77-97 % of simulated records",
}


def items_from_time_tests(evidence: dict[Any, dict[str, Any]], results: dict[Any, Any],
                          labels: dict[Any, str], compositions: dict[str, Any] | None = None,
                          repeat_dof: dict[str, float] | None = None) -> list[Item]:
    """Items of time tests: the mean after recovery (its record's or the repeats' interval),
    the minimum, the time to recover and the time below the threshold (block-bootstrap
    intervals; the minimum's value is the bias-corrected one, the centre of its interval),
    per test, labelled by ``labels[key]`` (its composition); a repeated
    composition's means over its repeats (``compositions``, from
    :func:`torlab.reduce.time_test_uncertainty.apply_repeats`) replace its tests."""
    figs = {"mean_after_recovery": "mean_after_recovery", "minimum": "minimum",
            "recovery_time_s": "recovery_time", "time_below_threshold_s": "time_below_threshold"}
    items: dict[str, Item] = {}
    comps = compositions or {}
    for key, ev in evidence.items():
        if key not in results or key not in labels:
            continue
        lab = labels[key]
        if lab in comps:
            continue
        res = results[key]
        est = {}
        for q, fig in figs.items():
            v = float(getattr(res, q, math.nan))
            lo, hi = float(ev.get(f"{fig}_low95", math.nan)), float(ev.get(f"{fig}_high95",
                                                                             math.nan))
            if not all(math.isfinite(x) for x in (v, lo, hi)):
                continue
            if fig == "mean_after_recovery":
                dof = float(ev.get("mean_after_recovery_dof", math.inf))
                holds = "the record's own noise (autocorrelated mean)"
            else:
                dof, holds = math.inf, _BOOTSTRAP_HOLDS[fig]
                if fig == "minimum" and math.isfinite(float(ev.get("minimum_bias", math.nan))):
                    v = 0.5 * (lo + hi)  # the bias-corrected minimum the interval is about
            est[q] = Estimate.from_interval(v, min(lo, v), max(hi, v), dof, holds=holds)
        items.setdefault(lab, Item(lab, {}, [], [])).estimates.update(est)
        items[lab].sources.append(f"{key[0]} step {key[1]}")
    for c, e in comps.items():
        est = {}
        for q, fig in figs.items():
            f = e.get(fig)
            if not isinstance(f, dict) or not all(
                    isinstance(f.get(k), (int, float)) and math.isfinite(f[k])
                    for k in ("mean", "low95", "high95")):
                continue
            est[q] = Estimate.from_interval(
                f["mean"], f["low95"], f["high95"], (repeat_dof or {}).get(fig, math.inf),
                runs=int(f.get("n", 1)), holds="the repeated tests' mean and the test-to-test "
                "scatter (one-way random effects)")
        items[c] = Item(c, est, [f"{int(e.get('n_tests', 0))} tests"])
    return list(items.values())


def items_from_path(path: Any, label: str | None = None) -> list[Item]:
    """The items a file or folder holds: a parameter file; a fit's results folder (its
    ``params.yaml``, or one per sub-folder); a protocol's results folder (its fitted sets
    in ``fits/*.yaml`` and its ``summary.json``'s time tests, crossings and retention).
    ``label`` names every item found (they are then repeats of one item).

    Raises
    ------
    TorlabInputError
        Nothing comparable found.
    """
    from pathlib import Path

    from torlab.errors import TorlabInputError

    p = Path(path)
    if p.is_file():
        if p.suffix.lower() in (".yaml", ".yml"):
            return [item_from_params(p, label)]
        if p.name == "summary.json":
            return _items_from_summary(p, label)
        raise TorlabInputError("compare reads parameter files (params.yaml), results folders "
                               "of torlab fit, predict retention and torlab run, or their "
                               "summary.json", path=p)
    if not p.is_dir():
        raise TorlabInputError("no such file or folder", path=p)
    if (p / "params.yaml").is_file():
        its = [item_from_params(p / "params.yaml", label)]
    else:
        subs = sorted(q for q in p.iterdir() if (q / "params.yaml").is_file())
        its = [item_from_params(q / "params.yaml", label) for q in subs]
    if (p / "summary.json").is_file() and not (p / "params.yaml").is_file():
        its += _items_from_summary(p / "summary.json", label)
    if not its:
        raise TorlabInputError("nothing to compare here: no params.yaml, no results of torlab "
                               "run or predict retention", path=p)
    return its


def _items_from_summary(path: Any, label: str | None) -> list[Item]:
    """Items of a results folder's ``summary.json``: a protocol run (its fitted sets in
    ``fits/``, time tests, crossings, retention) or a retention prediction."""
    import json
    from pathlib import Path

    from torlab.errors import TorlabInputError
    from torlab.files import open_regular

    p = Path(path)
    try:
        with open_regular(p) as fh:
            s = json.loads(fh.read(20_000_000))
    except (ValueError, UnicodeDecodeError) as e:
        raise TorlabInputError(f"not a readable summary.json ({e})", path=p) from None
    if not isinstance(s, dict):
        raise TorlabInputError("not a torlab summary.json", path=p)
    items: list[Item] = []
    if isinstance(s.get("retention_metrics"), dict):
        items.append(Item(label or p.parent.name, retention_estimates(s["retention_metrics"]),
                          [str(p)]))
    if isinstance(s.get("protocol"), dict):
        # the items of the run's comparisons (every estimate a section found), then the
        # fitted sets of products not among them
        cmp = ((s.get("reports") or {}).get("compare") or {})
        for it in cmp.get("items_estimates", []) if isinstance(cmp, dict) else []:
            items.append(_item_from_dict(it, label))
        have = {it.label for it in items}
        fits = p.parent / "fits"
        for f in sorted(fits.glob("*.yaml")) if fits.is_dir() else []:
            if label is None and _set_label(f.stem) in have:
                continue
            try:
                it = item_from_params(f, label)
            except TorlabInputError:
                continue
            if label is None:
                it.label = _set_label(f.stem)
            items.append(it)
    return _merge_labels(items)


def _set_label(stem: str) -> str:
    """``hpt_OFM1`` -> ``OFM1`` (the product of a fitted set's file); ``hpt-T_OFM1`` the same."""
    for pre in ("hpt-T_", "hpt_", "traction_", "lubricant_"):
        if stem.startswith(pre):
            return stem[len(pre):]
    return stem


def _merge_labels(items: list[Item]) -> list[Item]:
    """Items of one label from one source (a product's layer and temperature sets) merged."""
    out: dict[str, Item] = {}
    for it in items:
        if it.label in out and not (set(out[it.label].estimates) & set(it.estimates)):
            out[it.label].estimates.update(it.estimates)
            out[it.label].sources += it.sources
        elif it.label in out:
            out[f"{it.label} ({len(out)})"] = it
        else:
            out[it.label] = it
    return list(out.values())


def item_to_dict(it: Item) -> dict[str, Any]:
    """An item as data (a protocol's summary keeps its estimates for ``torlab compare``)."""
    return finite_tree({"label": it.label, "sources": it.sources, "estimates": {
        q: {"value": e.value, "se": e.se, "dof": e.dof, "log": e.log, "runs": e.runs,
            "holds": e.holds} for q, e in it.estimates.items()}})


def _item_from_dict(d: Any, label: str | None) -> Item:
    est = {}
    for q, e in (d.get("estimates") or {}).items() if isinstance(d, dict) else []:
        try:
            est[q] = Estimate(float(e["value"]), float(e["se"]),
                              math.inf if e.get("dof") is None else float(e["dof"]),
                              bool(e.get("log")), int(e.get("runs") or 1), str(e.get("holds", "")))
        except (KeyError, TypeError, ValueError):
            continue
    return Item(label or str(d.get("label", "?")), est, list(d.get("sources") or []))


def retention_estimates(m: dict[str, Any]) -> dict[str, Estimate]:
    """Estimates of a retention prediction's metrics (``summary.json`` ``retention_metrics``)."""
    est = {}
    for q in ("effective_friction", "retentivity", "fraction_in_band"):
        r = m.get(q)
        if not isinstance(r, dict):
            continue
        v, lo, hi = r.get("value"), r.get("low95"), r.get("high95")
        if all(isinstance(x, (int, float)) and math.isfinite(x) for x in (v, lo, hi)):
            est[q] = Estimate.from_interval(float(v), float(lo), float(hi),
                                            log=spec(q).log and min(v, lo) > 0,
                                            holds=str(m.get("holds", "")))
    return est
