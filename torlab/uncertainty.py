"""Propagation of parameter uncertainty through a model: bands, derived quantities, verdicts.

A fit gives its parameters as an estimate with a covariance (and the residual
degrees of freedom of that covariance).  :func:`propagate` carries that
uncertainty through any model function of named parameters and returns, for
every output, the model at the estimate, a two-sided band (95 % by default),
the standard deviation, and how much each parameter contributes to the band.
:meth:`Propagation.derive` carries it on to a quantity computed from the
outputs (a trend, a crossing) without new model evaluations, and
:meth:`Propagation.class_probabilities` turns such a scalar into the
probability of each verdict class.

Parameter scale
---------------
Parameters listed in ``log_scale`` (positive quantities: friction limits,
lengths, viscosities) are propagated as ``theta = ln p`` with the covariance
``C_ij / (p_i p_j)`` (the same first-order information, expressed on the scale
on which their uncertainty is symmetric), so a sample or a step never makes
them negative.  The others (temperature coefficients, exponents) are
propagated as they are.

Methods
-------
``linear``
    The model's derivatives by forward differences, one step of one standard
    deviation along each parameter (``k + 1`` evaluations with the estimate
    itself); the output variance is ``G C G^T`` and the band
    ``f(theta0) +- t sd``.
``sampling``
    ``n_samples`` seeded draws of the parameters from the fit's distribution
    (multivariate normal, or Student t with the fit's degrees of freedom);
    the band is the sample's 2.5 % and 97.5 % quantiles around the model at
    the estimate.
``second-order``
    (chosen by the check below, never asked for) The model's curvature along the
    principal directions of the check: the model at ``+t`` along each (beside the
    probes at ``-t`` and the linear steps) gives a quadratic model, the gradient plus
    each direction's slope correction and curvature; it is checked at two points off
    the directions (between the first direction and the next one left out, at the
    band's edge distance) and kept when it misses the model there by at most
    ``nonlinearity_tol`` of the half-width.  The band is the 2.5-97.5 % range of
    :data:`N_SURROGATE` quasi-random draws (a seeded shift of the Halton sequence,
    through the inverse normal and chi-squared distributions: Owen, "Monte Carlo and
    quasi-Monte Carlo", 2013) of that quadratic, which costs no model evaluation: about
    ``k + 7`` evaluations in all instead of the sampling method's 400, and band edges
    closer to the exact ones than 400 random draws give (tests/test_uncertainty.py: a
    log-normal curve against its exact quantiles; tests/test_band_draws.py: a thermal
    traction curve against 3000 draws).  When the check fails the model is sampled.
``none``
    Every parameter variance is zero: the band is the curve itself.

Evaluations and cost
--------------------
The design points of the linear and second-order methods (steps, probes, check
points) go to the model in one call per stage: its ``evaluate_near`` where it has
one (a model that starts an iteration from its solution at the estimate, e.g.
:class:`torlab.model.bands.DryTractionModel`'s flash temperature), else its
``evaluate_many``; the sampling method's draws always go to ``evaluate_many`` (in
blocks, :func:`torlab.parallel.map_deferred`), so a sampled band does not depend on
where it is evaluated.  :func:`propagate` and :meth:`Propagation.derive` run with
one BLAS thread (:func:`torlab.threads.small_problem`): their matrices are small
(``k + 2m`` features by :data:`N_SURROGATE` draws), and on a busy machine a
multi-threaded BLAS made the same products tens of times slower
(docs/performance.md).

Nonlinearity check (``method="auto"``)
--------------------------------------
After the linear step the model is evaluated at the parameter sets that put
the band where it is widest: along the first (and, when it explains less than
90 %, the second) principal direction of the parameter space in the output
variance (each output point normalised by its own standard deviation), at
``-t`` standard deviations (the lower 95 % edge: ``t = 1.96``, or Student's
quantile for the smallest degrees of freedom of the fits).  The
nonlinearity is

``eta = max over outputs |f(probe) - linear prediction| / (t sd)``,

the error of the linear band edge relative to the band's half-width (the
standard deviation is floored at 1 % of its largest value along each output,
so points where the band vanishes, e.g. zero creepage, do not count).  When
``eta <= nonlinearity_tol`` (0.1 by default) the linear band is used, else the
second-order band when its own check passes, else the model is sampled.  ``k + 3`` evaluations for the linear band of a model with
``k`` parameters (``k + 2`` when one direction explains the variance).

Contributions
-------------
``contributions[output][name]`` is the parameter's share of the output's
variance: its Shapley effect (:func:`shapley_shares`) -- the variance it explains,
``var(E[y | theta_u + j]) - var(E[y | theta_u])``, averaged over the orders in which
the parameters are added -- for the output linearised in the parameters, ``y = g^T
theta``, with ``g`` the output's gradient (linear method) or the slopes of the
multiple linear regression of the output on the drawn parameters (sampling method).
The shares are never negative and add up to 1 in the linear method, to the part
of the variance that is linear in the parameters (``R^2 <= 1``) when sampled.
Strongly correlated parameters (a fit that determines a combination of them better
than each one) share the variance they explain together.

Degrees of freedom
------------------
A distribution may consist of independent blocks (one per fit), each with the
residual degrees of freedom of its covariance (``inf``: normal).  The linear
band uses Student's t with the Welch-Satterthwaite degrees of freedom of each
output's variance, ``nu = var^2 / sum_b (var_b^2 / nu_b)``; sampling draws each
block from a multivariate t with its own ``nu``.

Example
-------
>>> import numpy as np
>>> from torlab.uncertainty import ParameterDistribution, propagate
>>> x = np.linspace(0.0, 1.0, 5)
>>> dist = ParameterDistribution.from_covariance(("a", "b"), [1.0, 2.0],
...                                              [[0.01, 0.0], [0.0, 0.04]])
>>> band = propagate(lambda p: p["a"] + p["b"] * x, dist)
>>> band.method, round(float(band.high()[-1] - band.low()[-1]), 3)
('linear', 0.877)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.threads import small_problem

__all__ = [
    "CONFIDENCE",
    "NONLINEARITY_TOL",
    "N_SAMPLES",
    "ParameterDistribution",
    "PendingSampling",
    "Propagation",
    "propagate",
    "shapley_shares",
]

#: default two-sided confidence of a band
CONFIDENCE = 0.95
#: largest nonlinearity (error of the linear band edge / band half-width) for the linear method
NONLINEARITY_TOL = 0.1
#: parameter draws of the sampling method
N_SAMPLES = 400
#: draws of the second-order method's quadratic model (not of the model: cheap;
#: quasi-random, :func:`_lattice_draws`)
N_SURROGATE = 4096
#: principal directions probed by the nonlinearity check explain at least this share
_PROBE_SHARE = 0.9
#: a standard deviation below this fraction of its output's largest one is floored there
_SD_FLOOR = 0.01

Model = Callable[[dict[str, Any]], Any]


@dataclass(frozen=True)
class ParameterDistribution:
    """The uncertainty of named parameters: estimate, covariance, scale and degrees of freedom.

    Attributes
    ----------
    names
        Parameter names.
    values
        Estimates (the model's argument values), natural units.
    cov
        ``(k, k)`` covariance in natural units, symmetric positive semi-definite.
    log_scale
        Names propagated as ``ln p`` (positive parameters).
    blocks
        ``(indices, dof)`` of independent groups of parameters; ``dof`` is the
        residual degrees of freedom of that group's covariance (``inf``: normal).
        Default: one block with ``dof = inf``.
    """

    names: tuple[str, ...]
    values: np.ndarray
    cov: np.ndarray
    log_scale: frozenset[str] = frozenset()
    blocks: tuple[tuple[tuple[int, ...], float], ...] = ()

    @classmethod
    def from_covariance(cls, names: Sequence[str], values: Sequence[float], cov: Any, *,
                        log_scale: Sequence[str] = (), dof: float = math.inf
                        ) -> ParameterDistribution:
        """One block of parameters from a fit (see the class attributes).

        Raises
        ------
        ValueError
            Shapes that do not match, a non-finite or non-symmetric covariance, a
            negative variance, a log-scale parameter that is not positive.
        """
        names = tuple(str(n) for n in names)
        v = np.asarray(values, dtype=float).ravel()
        c = np.asarray(cov, dtype=float)
        k = len(names)
        if len(set(names)) != k:
            raise ValueError(f"parameter names repeat: {names}")
        if v.shape != (k,) or c.shape != (k, k):
            raise ValueError(f"{k} names but {v.size} values and a {c.shape} covariance")
        if not (np.all(np.isfinite(v)) and np.all(np.isfinite(c))):
            raise ValueError("values and covariance must be finite")
        scale = max(float(np.max(np.abs(np.diag(c)), initial=0.0)), 1e-300)
        if not np.allclose(c, c.T, rtol=1e-6, atol=1e-9 * scale):
            raise ValueError("the covariance is not symmetric")
        if np.any(np.diag(c) < 0):
            raise ValueError("a variance is negative")
        logs = frozenset(str(n) for n in log_scale)
        unknown = logs - set(names)
        if unknown:
            raise ValueError(f"log_scale names {sorted(unknown)} are not parameters")
        for i, n in enumerate(names):
            if n in logs and not v[i] > 0:
                raise ValueError(f"{n} = {v[i]:g} cannot be on a log scale (it must be > 0)")
        if not (dof > 0):
            raise ValueError("degrees of freedom must be > 0")
        return cls(names, v, 0.5 * (c + c.T), logs, ((tuple(range(k)), float(dof)),))

    @classmethod
    def combine(cls, parts: Sequence[ParameterDistribution]) -> ParameterDistribution:
        """Independent distributions side by side (block-diagonal covariance).

        Raises
        ------
        ValueError
            A parameter name in two parts.
        """
        names: list[str] = []
        blocks: list[tuple[tuple[int, ...], float]] = []
        for p in parts:
            off = len(names)
            names += list(p.names)
            blocks += [(tuple(off + i for i in idx), dof) for idx, dof in p.blocks_or_default]
        if len(set(names)) != len(names):
            raise ValueError(f"a parameter appears in two distributions: {names}")
        k = len(names)
        cov = np.zeros((k, k))
        off = 0
        for p in parts:
            m = len(p.names)
            cov[off:off + m, off:off + m] = p.cov
            off += m
        values = np.concatenate([p.values for p in parts]) if parts else np.zeros(0)
        logs = frozenset().union(*(p.log_scale for p in parts)) if parts else frozenset()
        return cls(tuple(names), values, cov, logs, tuple(blocks))

    @property
    def blocks_or_default(self) -> tuple[tuple[tuple[int, ...], float], ...]:
        """The blocks, or one normal block of every parameter."""
        return self.blocks or ((tuple(range(len(self.names))), math.inf),)

    @property
    def is_log(self) -> np.ndarray:
        """Boolean mask of the log-scale parameters."""
        return np.array([n in self.log_scale for n in self.names], dtype=bool)

    def transformed(self) -> tuple[np.ndarray, np.ndarray]:
        """``theta0`` and the covariance of ``theta`` (``ln p`` for the log-scale names)."""
        lg = self.is_log
        theta = np.where(lg, np.log(np.where(lg, self.values, 1.0)), self.values)
        d = np.where(lg, 1.0 / np.where(lg, self.values, 1.0), 1.0)
        return theta, self.cov * np.outer(d, d)

    def params(self, theta: np.ndarray) -> dict[str, Any]:
        """Model arguments from ``theta`` (``(k,)`` or ``(m, k)``: scalars or arrays)."""
        theta = np.asarray(theta, dtype=float)
        lg = self.is_log
        p = np.where(lg, np.exp(np.where(lg, theta, 0.0)), theta)
        if p.ndim == 1:
            return {n: float(v) for n, v in zip(self.names, p, strict=True)}
        return {n: p[:, i] for i, n in enumerate(self.names)}

    def subset(self, keep: Sequence[str]) -> ParameterDistribution:
        """The marginal distribution of ``keep`` (in the order of :attr:`names`)."""
        idx = [i for i, n in enumerate(self.names) if n in set(keep)]
        where = {old: new for new, old in enumerate(idx)}
        blocks = []
        for b, dof in self.blocks_or_default:
            nb = tuple(where[i] for i in b if i in where)
            if nb:
                blocks.append((nb, dof))
        return ParameterDistribution(tuple(self.names[i] for i in idx), self.values[idx],
                                     self.cov[np.ix_(idx, idx)],
                                     frozenset(n for n in self.log_scale if n in set(keep)),
                                     tuple(blocks))


@dataclass
class Propagation:
    """Outputs of a model under parameter uncertainty (see the module docstring).

    Attributes
    ----------
    method
        ``"linear"``, ``"sampling"`` or ``"none"`` (no parameter uncertainty).
    confidence
        Two-sided level of :meth:`low` / :meth:`high`.
    center
        Model at the estimate, per output.
    sd
        Standard deviation per output (linear: first order; sampling: of the sample).
    lower, upper
        Band edges per output.
    contributions
        ``{output: {parameter: share of the variance}}`` (arrays like the output; see
        the module docstring).
    nonlinearity
        The check's ``eta`` (NaN when not computed).
    n_evaluations
        Model evaluations spent (the estimate included when computed here).
    n_failed
        Samples whose model evaluation raised a numerical error (left out).
    names
        The parameters.
    notes
        What was done and why (for reports).
    """

    method: str
    confidence: float
    center: dict[str, np.ndarray]
    sd: dict[str, np.ndarray]
    lower: dict[str, np.ndarray]
    upper: dict[str, np.ndarray]
    contributions: dict[str, dict[str, np.ndarray]]
    nonlinearity: float
    n_evaluations: int
    names: tuple[str, ...]
    n_failed: int = 0
    notes: list[str] = field(default_factory=list)
    # the design, for derived quantities: outputs at the estimate, the steps and probes
    # (linear) or at the draws (sampling), with the parameter offsets in theta
    _design: dict[str, Any] = field(default_factory=dict, repr=False)

    def __getstate__(self) -> dict[str, Any]:
        """Picklable (the protocol cache): the model function is not kept, so a derived
        quantity of an unpickled propagation is linear (or uses its stored draws)."""
        state = dict(self.__dict__)
        state["_design"] = {k: v for k, v in self._design.items() if k != "model"}
        state.pop("_lattice", None)
        return state

    # -- access -----------------------------------------------------------------------------
    def _key(self, output: str | None) -> str:
        if output is None:
            if len(self.center) != 1:
                raise KeyError(f"name the output: {sorted(self.center)}")
            return next(iter(self.center))
        return output

    def low(self, output: str | None = None) -> np.ndarray:
        """Lower band edge of ``output`` (the only one when None)."""
        return self.lower[self._key(output)]

    def high(self, output: str | None = None) -> np.ndarray:
        """Upper band edge of ``output``."""
        return self.upper[self._key(output)]

    def dominant(self, output: str | None = None, *, min_share: float = 0.1) -> list[tuple[str, float]]:
        """Parameters that dominate the band of ``output``, largest first.

        The share of a parameter is its contribution (its Shapley effect,
        :func:`shapley_shares`) averaged over the output's points, weighted by their
        variance (so the widest part of the band counts most); parameters below
        ``min_share`` are left out.  The shares of all parameters add up to
        :meth:`explained` (at most 1).
        """
        key = self._key(output)
        var = np.nan_to_num(np.asarray(self.sd[key], dtype=float) ** 2)
        tot = float(np.sum(var))
        if tot <= 0:
            return []
        out = []
        for n, c in self.contributions[key].items():
            share = float(np.sum(np.nan_to_num(np.asarray(c, dtype=float)) * var) / tot)
            if share >= min_share:
                out.append((n, share))
        return sorted(out, key=lambda t: -t[1])

    def explained(self, output: str | None = None) -> float:
        """The part of the band's variance the parameters' shares cover, weighted over the
        output's points as :meth:`dominant` weights them: 1 in the linear method, the
        linear part ``R^2`` of a sampled output (the rest is the model's nonlinearity)."""
        key = self._key(output)
        var = np.nan_to_num(np.asarray(self.sd[key], dtype=float) ** 2)
        tot = float(np.sum(var))
        if tot <= 0:
            return 0.0
        return float(sum(np.sum(np.nan_to_num(np.asarray(c, dtype=float)) * var)
                         for c in self.contributions[key].values()) / tot)

    def summary(self, outputs: Sequence[str] | None = None) -> dict[str, Any]:
        """Method, check and dominant parameters per output, for ``summary.json``."""
        keys = list(outputs) if outputs is not None else list(self.center)
        return {
            "method": self.method,
            "confidence": self.confidence,
            "nonlinearity": None if not math.isfinite(self.nonlinearity) else self.nonlinearity,
            "nonlinearity_tolerance": self._design.get("tol"),
            "n_evaluations": int(self.n_evaluations),
            "n_samples": self._design.get("n_samples") if self.method == "sampling" else None,
            "quadratic_draws": self._design.get("n_surrogate")
            if self.method == "second-order" else None,
            "n_failed": int(self.n_failed),
            "parameters": list(self.names),
            "dominant": {k: [{"parameter": n, "share": round(s, 4)} for n, s in self.dominant(k)]
                         for k in keys if k in self.center},
            "explained": {k: round(self.explained(k), 4) for k in keys if k in self.center},
            "notes": list(self.notes),
        }

    # -- derived quantities -----------------------------------------------------------------
    @small_problem  # one BLAS thread: small matrices (torlab.threads)
    def derive(self, func: Callable[[dict[str, np.ndarray]], Any], *,
               nonlinearity_tol: float | None = None) -> Propagation:
        """Propagate ``func(outputs)`` (a function of the model's outputs) with the same design.

        No new model evaluations in the linear method: ``func`` is applied to
        the stored outputs at the estimate, the steps and the probes, and the
        derived quantity gets its own nonlinearity check; if it fails and the
        model is known, the model is sampled (``n_samples`` evaluations).  In
        the sampling method ``func`` is applied to every draw.
        """
        d = self._design
        tol = d.get("tol", NONLINEARITY_TOL) if nonlinearity_tol is None else nonlinearity_tol
        if self.method == "none":
            c = _as_outputs(func(d["f0"]))
            return _none_result(c, self.names, self.confidence, 0)
        if self.method == "linear":
            f0 = _as_outputs(func(d["f0"]))
            steps = [_as_outputs(func(f)) for f in d["steps"]]
            probes = [_as_outputs(func(f)) for f in d["probes"]]
            res = _linear_from_design(d["dist"], d["h"], f0, steps, d["dirs"], probes,
                                      self.confidence, tol, 0, self.names)
            if res.nonlinearity <= tol or d.get("model") is None:
                if res.nonlinearity > tol:
                    res.notes.append("the derived quantity is nonlinear in the parameters but "
                                     "no model was kept for sampling; linear result")
                return res
            model = d["model"]
            draws = _draws(d["dist"], d["n_samples"], d["seed"])
            samples, failed = _evaluate_many(model, d["dist"], draws, d["vectorized"])
            out = _sampling_from_draws(d["dist"], draws[~failed], samples, d["f0"],
                                       self.confidence, res.nonlinearity, self.names,
                                       int(failed.sum()), func=func, tol=tol)
            out.notes.insert(0, f"derived quantity nonlinear (eta = {res.nonlinearity:.3g} > "
                                f"{tol:g}): sampled the model")
            return out
        if self.method == "second-order":
            return self._derive_second_order(func, tol)
        samples = [_as_outputs(func(s)) for s in d["samples"]]
        f0 = _as_outputs(func(d["f0"]))
        stacked = {k: np.stack([s[k] for s in samples]) for k in f0}
        return _sampling_result(d["dist"], d["draws"], stacked, f0, self.confidence,
                                self.nonlinearity, self.names, self.n_failed, d)

    def _derive_second_order(self, func: Callable[[dict[str, np.ndarray]], Any],
                             tol: float) -> Propagation:
        """:meth:`derive` of a second-order propagation: ``func`` at the design's points
        gives the derived quantity's own quadratic model, checked as the outputs' was;
        failing that, the model is sampled (if kept) or the result is linear."""
        d = self._design
        design = {**d, "tol": tol}
        res = _second_order_from_design(design, self.confidence, self.nonlinearity,
                                        self.names, 0, func=func,
                                        draws=getattr(self, "_lattice", None))
        if isinstance(res, Propagation):
            return res
        model = d.get("model")
        lin = _linear_from_design(d["dist"], d["h"], _as_outputs(func(d["f0"])),
                                  [_as_outputs(func(o)) for o in d["steps"]], d["dirs"],
                                  [_as_outputs(func(o)) for o in d["probes"]],
                                  self.confidence, tol, 0, self.names)
        if model is None:
            lin.notes.append(f"the derived quantity's second-order check failed ({res}) and no "
                             "model was kept for sampling; linear result")
            return lin
        draws = _draws(d["dist"], d["n_samples"], d["seed"])
        samples, failed = _evaluate_many(model, d["dist"], draws, d["vectorized"])
        out = _sampling_from_draws(d["dist"], draws[~failed], samples, d["f0"],
                                   self.confidence, lin.nonlinearity, self.names,
                                   int(failed.sum()), func=func, tol=tol)
        out.notes.insert(0, f"derived quantity: {res}; sampled the model")
        return out

    def class_probabilities(self, edges: Sequence[float], output: str | None = None
                            ) -> np.ndarray:
        """Probabilities that a scalar output falls in each interval between ``edges``.

        ``edges = (a, b)`` gives ``P(x < a), P(a <= x <= b), P(x > b)``.  Linear
        method: Student-t (or normal) distribution of the output; sampling: the
        fraction of draws; ``none``: the class of the estimate with probability 1.
        """
        from torlab._stats import t_cdf  # scipy.stats.t.cdf, without its import

        key = self._key(output)
        e = np.asarray(edges, dtype=float)
        c = float(np.ravel(self.center[key])[0])
        if self.method == "none" or not float(np.ravel(self.sd[key])[0]) > 0:
            # the inner classes include their edges: [e0, e1], (e1, e2] ...
            idx = 0 if c < e[0] else max(1, int(np.sum(c > e)))
            p = np.zeros(e.size + 1)
            p[idx] = 1.0
            return p
        if self.method == "linear":
            nu = float(np.ravel(self._design.get("nu", {}).get(key, np.array([math.inf])))[0])
            s = float(np.ravel(self.sd[key])[0])
            cdf = t_cdf((e - c) / s, nu) if math.isfinite(nu) else _norm_cdf((e - c) / s)
        else:
            stacked = self._design.get("stacked", {})
            x = np.asarray(stacked[key] if key in stacked else _surrogate_samples(
                self._design, key, getattr(self, "_lattice", None)), dtype=float).reshape(-1)
            cdf = np.array([np.mean(x < v) if i == 0 else np.mean(x <= v)
                            for i, v in enumerate(e)])
        cdf = np.concatenate(([0.0], np.asarray(cdf, dtype=float), [1.0]))
        return np.clip(np.diff(cdf), 0.0, 1.0)


# ---------------------------------------------------------------------------------------------
# the propagation
# ---------------------------------------------------------------------------------------------
@small_problem  # one BLAS thread: small matrices (torlab.threads)
def propagate(model: Model, dist: ParameterDistribution, *, confidence: float = CONFIDENCE,
              method: str = "auto", n_samples: int = N_SAMPLES, seed: int = 0,
              nonlinearity_tol: float = NONLINEARITY_TOL, vectorized: bool = False,
              f0: Any = None, defer: bool = False) -> Propagation | PendingSampling:
    """Propagate a parameter distribution through ``model`` (see the module docstring).

    Parameters
    ----------
    model
        ``model(params) -> array`` or ``-> {name: array}``; ``params`` maps every
        name of ``dist`` to a float (or, ``vectorized=True``, to an ``(m,)``
        array, and the outputs get a leading axis of length ``m``).
    dist
        The parameters' distribution.
    confidence
        Two-sided level of the band.
    method
        ``"auto"`` (linear unless the nonlinearity check fails), ``"linear"``
        or ``"sampling"``.
    n_samples, seed
        Draws of the sampling method and the seed of their generator.
    nonlinearity_tol
        Largest ``eta`` for the linear method.
    vectorized
        Whether ``model`` takes arrays of parameter sets.
    f0
        The model at the estimate, if the caller has it (saves one evaluation).
    defer
        When the band is sampled (and ``model`` is not vectorised), return the
        :class:`PendingSampling` with the draws instead of evaluating them: the caller
        runs its blocks where it wants and calls its ``finish``.

    Returns
    -------
    Propagation or PendingSampling

    Raises
    ------
    ValueError
        Unknown method, confidence outside (0, 1).
    torlab.errors.NumericalError
        More than 5 % of the samples fail, or the model fails at the estimate or a step.
    """
    if method not in ("auto", "linear", "sampling"):
        raise ValueError(f"method must be auto, linear or sampling, not {method!r}")
    if not 0 < confidence < 1:
        raise ValueError("confidence must be between 0 and 1")
    n_eval = 0
    theta0, _ = dist.transformed()
    if f0 is None:
        f0 = _eval1(model, dist, theta0, vectorized)
        n_eval += 1
    f0 = _as_outputs(f0)
    design_base = {"dist": dist, "f0": f0, "tol": nonlinearity_tol, "model": model,
                   "n_samples": int(n_samples), "seed": int(seed), "vectorized": vectorized}
    _, cov_t = dist.transformed()
    sd_t = np.sqrt(np.clip(np.diag(cov_t), 0.0, None))
    if not np.any(sd_t > 0):
        res = _none_result(f0, dist.names, confidence, n_eval)
        res._design.update(design_base)
        return res
    if method == "sampling":
        return _sample(model, dist, f0, confidence, n_samples, seed, vectorized,
                       nonlinearity_tol, math.nan, design_base, n_eval, defer=defer)
    # --- linear: forward steps of one standard deviation ------------------------------------
    from torlab.errors import NumericalError

    k = len(dist.names)
    h = sd_t
    live = np.flatnonzero(h > 0)
    thetas = np.repeat(theta0[None, :], live.size, axis=0)
    thetas[np.arange(live.size), live] += h[live]
    try:
        step_out = _evaluate_rows(model, dist, thetas, vectorized)
        n_eval += live.size
        steps: list[dict[str, np.ndarray]] = []
        j = 0
        for i in range(k):
            if h[i] > 0:
                steps.append(step_out[j])
                j += 1
            else:
                steps.append(f0)
        tq_guess = _quantile(confidence, _min_dof(dist))
        dirs = _probe_directions(dist, h, f0, steps) if method == "auto" else []
        probes: list[dict[str, np.ndarray]] = []
        if dirs:
            pth = np.array([theta0 - tq_guess * dvec for dvec in dirs])
            probes = _evaluate_rows(model, dist, pth, vectorized)
            n_eval += len(dirs)
    except NumericalError as e:
        if method == "linear":
            raise
        # the model has no solution one step (or one band edge) away: not linear there
        return _sample(model, dist, f0, confidence, n_samples, seed, vectorized,
                       nonlinearity_tol, math.inf, design_base, n_eval,
                       f"sampled: the model failed at a linearisation point ({e})", defer)
    res = _linear_checked(dist, h, f0, steps, dirs, probes, confidence, nonlinearity_tol,
                          n_eval, method)
    res._design.update(design_base)
    if method == "linear" or res.nonlinearity <= nonlinearity_tol:
        if method == "auto":
            res.notes.insert(0, f"linearised: nonlinearity {res.nonlinearity:.3g} <= "
                                f"{nonlinearity_tol:g}")
        return res
    why = (f"nonlinearity {res.nonlinearity:.3g} > {nonlinearity_tol:g} (the linear band edge "
           "would be off by more than that share of the band's half-width)")
    try:
        second = _second_order(model, dist, res, vectorized, seed)
    except NumericalError as e:  # no solution at a point of the quadratic's design
        second = f"the model failed at a point of the second-order design ({e})"
    if isinstance(second, Propagation):
        second._design.update({k: v for k, v in design_base.items() if k != "n_samples"})
        second.notes.insert(0, f"second order: {why}; {second.notes.pop(0)}")
        return second
    # the evaluations of the second-order design are counted with the draws' (they were
    # spent; the band does not use them)
    n_eval = res.n_evaluations + (len(dirs) + 2 if "more evaluations" in second else 0)
    return _sample(model, dist, f0, confidence, n_samples, seed, vectorized, nonlinearity_tol,
                   res.nonlinearity, design_base, n_eval, f"sampled: {why}; {second}", defer)


def _sample(model: Model, dist: ParameterDistribution, f0: dict[str, np.ndarray],
            confidence: float, n_samples: int, seed: int, vectorized: bool, tol: float,
            eta: float, design_base: dict[str, Any], n_eval: int = 0, note: str = "",
            defer: bool = False) -> Propagation | PendingSampling:
    pending = PendingSampling(model, dist, _draws(dist, n_samples, seed), f0, confidence, tol,
                              eta, design_base, n_eval, note)
    return pending if defer and not vectorized else pending.run()


# ---------------------------------------------------------------------------------------------
# second order: the model's curvature along its principal directions
# ---------------------------------------------------------------------------------------------
def _second_order(model: Model, dist: ParameterDistribution, lin: Propagation, vectorized: bool,
                  seed: int) -> Propagation | str:
    """The band of a model that is not linear over it, from its curvature along the principal
    directions (see the module docstring): the :class:`Propagation`, or why not (a str).

    ``lin`` is the linear propagation (its design: the steps, the principal directions and
    the probes at ``-t`` along them).  The model is evaluated at ``+t`` along the same
    directions and at two check points off them; the quadratic model through these
    points must give the checks to ``tol`` of the band's half-width.  Raises
    :class:`~torlab.errors.NumericalError` if the model fails at one of the points.
    """
    d = lin._design
    dirs, tol = d["dirs"], d["tol"]
    theta0, _ = dist.transformed()
    t = _quantile(lin.confidence, _min_dof(dist))
    basis, _ = _principal_basis(dist, d["h"], d["f0"], d["steps"])
    checks = _check_points(dirs, basis[len(dirs)] if len(basis) > len(dirs) else None, t)
    rows = np.array([theta0 + t * dv for dv in dirs] + [theta0 + c for c in checks])
    out = _evaluate_rows(model, dist, rows, vectorized)
    n_eval = lin.n_evaluations + rows.shape[0]
    plus, at_checks = out[:len(dirs)], out[len(dirs):]
    design = {"dist": dist, "h": d["h"], "f0": d["f0"], "steps": d["steps"], "dirs": dirs,
              "probes": d["probes"], "plus": plus, "checks": checks, "at_checks": at_checks,
              "t": t, "tol": tol, "seed": int(seed), "n_surrogate": N_SURROGATE}
    res = _second_order_from_design(design, lin.confidence, lin.nonlinearity, lin.names, n_eval)
    return res if isinstance(res, Propagation) else f"{res} ({rows.shape[0]} more evaluations)"


def _check_points(dirs: list[np.ndarray], nxt: np.ndarray | None, t: float) -> list[np.ndarray]:
    """Offsets (theta) where the quadratic model is checked: between the first principal
    direction and the next one left out of the quadratic, on both sides of each (at the
    band's edge distance ``t``), or -- a single parameter -- half-way to the edges."""
    d1 = dirs[0]
    if nxt is None:
        return [-0.5 * t * d1, 0.5 * t * d1]
    r = math.sqrt(0.5)
    return [-t * r * (d1 + nxt), t * r * (d1 - nxt)]


def _quadratic(design: dict[str, Any], key: str, f0: np.ndarray, steps: list[np.ndarray],
               probes: list[np.ndarray], plus: list[np.ndarray]) -> dict[str, np.ndarray]:
    """The quadratic model of one output (flattened): ``f0``, the gradient ``G`` (k, n) from
    the forward steps, the directions' weights ``W`` (m, k: the coordinate along direction
    j of an offset is ``offset @ W[j]``), the slope corrections and curvatures (m, n) from
    the points at ``-t`` and ``+t`` along each direction."""
    dist, h, dirs, t = design["dist"], design["h"], design["dirs"], design["t"]
    _, cov = dist.transformed()
    f = np.asarray(f0, dtype=float).reshape(-1)
    G = np.stack([(np.asarray(steps[i], dtype=float).reshape(-1) - f) / h[i] if h[i] > 0
                  else np.zeros_like(f) for i in range(h.size)])
    P = np.linalg.pinv(cov)
    W = np.stack([P @ dv for dv in dirs])
    fm = np.stack([np.asarray(p, dtype=float).reshape(-1) for p in probes])
    fp = np.stack([np.asarray(p, dtype=float).reshape(-1) for p in plus])
    gd = np.stack([dv @ G for dv in dirs])
    slope = (fp - fm) / (2.0 * t) - gd
    curv = (fp + fm - 2.0 * f[None, :]) / t**2
    return {"f0": f, "G": G, "W": W, "slope": slope, "curv": curv,
            "shape": np.asarray(np.shape(f0), dtype=np.int64)}


def _quadratic_at(q: dict[str, np.ndarray], offsets: np.ndarray) -> np.ndarray:
    """The quadratic model at parameter offsets ``(N, k)`` (theta): ``(N, n)``."""
    return _quadratic_draws(q, offsets).T


def _quadratic_draws(q: dict[str, np.ndarray], offsets: np.ndarray) -> np.ndarray:
    """The quadratic model at parameter offsets ``(N, k)`` as ``(n, N)`` (each output point's
    draws contiguous): one product of the features ``[offsets, a, a^2 / 2]`` (``a`` the
    coordinates along the directions) with the stacked coefficients ``[G; slope; curv]``,
    so the only ``(n, N)`` array made is the result."""
    a = offsets @ q["W"].T
    z = np.concatenate([offsets, a, 0.5 * a * a], axis=1)  # (N, k + 2m)
    coef = np.concatenate([q["G"], q["slope"], q["curv"]], axis=0)  # (k + 2m, n)
    x = coef.T @ z.T
    x += q["f0"][:, None]
    return x


def _second_order_from_design(design: dict[str, Any], confidence: float, eta: float,
                              names: tuple[str, ...], n_eval: int,
                              func: Callable[[dict[str, np.ndarray]], Any] | None = None,
                              draws: np.ndarray | None = None) -> Propagation | str:
    """The second-order propagation of the model's outputs (or of ``func`` of them) from the
    design of :func:`_second_order`; a str saying why not when the checks fail."""
    dist, t, tol = design["dist"], design["t"], design["tol"]

    def apply(o: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return o if func is None else _as_outputs(func(o))

    f0 = apply(design["f0"])
    steps = [apply(o) for o in design["steps"]]
    probes = [apply(o) for o in design["probes"]]
    plus = [apply(o) for o in design["plus"]]
    at_checks = [apply(o) for o in design["at_checks"]]
    _, cov = dist.transformed()
    offsets = np.array(design["checks"])
    quads, worst = {}, 0.0
    for key, v0 in f0.items():
        q = _quadratic(design, key, v0, [o[key] for o in steps], [o[key] for o in probes],
                       [o[key] for o in plus])
        quads[key] = q
        sd = np.sqrt(np.clip(np.einsum("it,ij,jt->t", q["G"], cov, q["G"]), 0.0, None))
        if not np.all(np.isfinite(sd)) or float(np.max(sd, initial=0.0)) <= 0:
            continue
        floor = max(_SD_FLOOR * float(np.max(sd)), 1e-300)
        want = np.stack([np.asarray(o[key], dtype=float).reshape(-1) for o in at_checks])
        err = np.abs(want - _quadratic_at(q, offsets)) / (t * np.maximum(sd, floor))
        if not np.all(np.isfinite(err)):
            return "the model is not finite at a check point"
        worst = max(worst, float(np.max(err)))
    if worst > tol:
        return (f"the quadratic model along the principal direction(s) misses the model at "
                f"its check points by {worst:.3g} > {tol:g} of the half-width")
    if draws is None:
        draws = _lattice_draws(dist, int(design["n_surrogate"]), int(design["seed"]))
    theta0, _ = dist.transformed()
    lo_q, hi_q = 50.0 * (1 - confidence), 50.0 * (1 + confidence)
    center, sd, lower, upper, contrib, stacked = {}, {}, {}, {}, {}, {}
    # the draws' own covariance (a Student-t block's is wider than its scale matrix)
    dth = draws - theta0[None, :]
    cdd = dth.T @ dth / dth.shape[0]
    for key, q in quads.items():
        v0 = np.asarray(f0[key], dtype=float)
        x = _quadratic_draws(q, dth)  # (n, N)
        lo, hi = np.percentile(x, [lo_q, hi_q], axis=1)
        v = v0.reshape(-1)  # the band always contains the model at the estimate
        center[key] = v0
        vx = np.var(x, axis=1)
        sd[key] = np.sqrt(vx * (x.shape[1] / max(x.shape[1] - 1, 1))).reshape(v0.shape)
        lower[key] = np.minimum(lo, v).reshape(v0.shape)
        upper[key] = np.maximum(hi, v).reshape(v0.shape)
        # shares: the Shapley effects of the first-order part over the quadratic's whole
        # variance (adding up to its linear part, as a sampled band's)
        g = q["G"] + q["W"].T @ q["slope"]  # the quadratic's linear part (k, n)
        c = shapley_shares(g, cdd, np.maximum(vx, np.einsum("it,ij,jt->t", g, cdd, g)))
        contrib[key] = {n: c[i].reshape(v0.shape) for i, n in enumerate(names)}
        if func is not None:  # a derived quantity: its draws, for class_probabilities
            stacked[key] = x.T.reshape((x.shape[1], *v0.shape))
    res = Propagation(method="second-order", confidence=confidence, center=center, sd=sd,
                      lower=lower, upper=upper, contributions=contrib, nonlinearity=eta,
                      n_evaluations=n_eval, names=names)
    # the band's own draws are made again from the seed when they are needed (kept while
    # the object lives: not a field, so neither the cache nor a worker's pickle holds them)
    res._design = {**design, "quads": quads, "check_error": worst, "stacked": stacked}
    res._lattice = draws
    res.notes.append(f"the model's curvature along {len(design['dirs'])} principal "
                     f"direction(s) is taken into account (quadratic model through the "
                     f"points at -t and +t; at two check points it is off by {worst:.3g} "
                     f"<= {tol:g} of the half-width); the band is the 2.5-97.5 % range "
                     f"of {draws.shape[0]} draws of that model")
    return res


def _surrogate_samples(design: dict[str, Any], key: str, draws: np.ndarray | None = None
                       ) -> np.ndarray:
    """The draws of a second-order propagation's quadratic model of ``key`` (made again from
    its seed when not given: the same draws as the band's)."""
    dist = design["dist"]
    theta0, _ = dist.transformed()
    if draws is None:
        draws = _lattice_draws(dist, int(design["n_surrogate"]), int(design["seed"]))
    q = design["quads"][key]
    return _quadratic_at(q, draws - theta0[None, :]).reshape(
        (draws.shape[0], *tuple(int(x) for x in q["shape"])))


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------
def _norm_cdf(x: np.ndarray) -> np.ndarray:
    from scipy.special import ndtr

    return ndtr(x)


def _quantile(confidence: float, nu: Any) -> Any:
    """Two-sided quantile (Student t for finite ``nu``, normal for inf), elementwise."""
    from torlab._stats import norm_ppf, t_ppf  # scipy.stats's, without its import

    nu = np.asarray(nu, dtype=float)
    q = 0.5 + confidence / 2.0
    out = np.where(np.isfinite(nu), t_ppf(q, np.where(np.isfinite(nu), np.maximum(nu, 1.0),
                                                      1.0)), norm_ppf(q))
    return float(out) if out.ndim == 0 else out


def _min_dof(dist: ParameterDistribution) -> float:
    """The smallest degrees of freedom of the blocks (where the probes go: the widest quantile)."""
    return min(dof for _, dof in dist.blocks_or_default)


def _as_outputs(x: Any) -> dict[str, np.ndarray]:
    if isinstance(x, Mapping):
        return {str(k): np.asarray(v, dtype=float) for k, v in x.items()}
    return {"value": np.asarray(x, dtype=float)}


def _eval1(model: Model, dist: ParameterDistribution, theta: np.ndarray,
           vectorized: bool) -> dict[str, np.ndarray]:
    if vectorized:
        out = _as_outputs(model(dist.params(theta[None, :])))
        return {k: v[0] for k, v in out.items()}
    return _as_outputs(model(dist.params(theta)))


def _evaluate_rows(model: Model, dist: ParameterDistribution, thetas: np.ndarray,
                   vectorized: bool) -> list[dict[str, np.ndarray]]:
    """Model outputs at each row of ``thetas``, the design points of the linear and
    second-order methods (errors propagate: a model with ``evaluate_many`` raises the
    error of the first row that failed).  A model's ``evaluate_near`` (``evaluate_many``
    for parameter sets near the estimate, e.g. starting an iteration from the
    estimate's solution) is preferred to its ``evaluate_many``."""
    if thetas.shape[0] == 0:
        return []
    many = getattr(model, "evaluate_near", None) or getattr(model, "evaluate_many", None)
    if many is not None and not vectorized:
        outs, errors = many(dist.params(thetas))
        for e in errors:
            if e is not None:
                raise e
        outs = _as_outputs(outs)
        return [{k: v[i] for k, v in outs.items()} for i in range(thetas.shape[0])]
    if vectorized:
        out = _as_outputs(model(dist.params(thetas)))
        return [{k: v[i] for k, v in out.items()} for i in range(thetas.shape[0])]
    return [_as_outputs(model(dist.params(t))) for t in thetas]


#: parameter draws per task of the sampling method (:mod:`torlab.parallel`), and blocks per
#: round (after each round the evaluation stops if too many draws failed); both fixed, so
#: the split -- and the result -- never depends on how many workers evaluate the blocks
SAMPLE_BLOCK = 10
SAMPLE_ROUND = 4
#: draws per task for a model that evaluates many draws in one call (``evaluate_many``):
#: larger blocks share more of the work, smaller ones keep the arrays in cache
MANY_BLOCK = 20


@dataclass
class _Block:
    """Evaluate the model at a block of draws (a picklable executor task): row by row, or
    all in one call when the model has ``evaluate_many``.

    ``model.evaluate_many(params)`` takes ``{name: (m,) array}`` and returns
    ``(outputs, errors)``: ``{output: (m, ...) array}`` and, per draw, None or the
    error its evaluation alone would have raised.  It must give each draw the result
    ``model(params of that draw)`` gives, to round-off.
    """

    model: Any
    dist: ParameterDistribution

    def __call__(self, thetas: np.ndarray) -> list[tuple[dict[str, np.ndarray] | None, str]]:
        from torlab.errors import NumericalError, TorlabInputError

        out: list[tuple[dict[str, np.ndarray] | None, str]] = []
        many = getattr(self.model, "evaluate_many", None)
        if many is not None:
            outs, errors = many(self.dist.params(thetas))
            outs = _as_outputs(outs)
            for i, e in enumerate(errors):
                if e is None:
                    out.append(({k: v[i] for k, v in outs.items()}, ""))
                elif isinstance(e, (NumericalError, TorlabInputError, FloatingPointError,
                                    ValueError)):
                    out.append((None, str(e)))
                else:
                    raise e
            return out
        for t in thetas:
            try:
                out.append((_as_outputs(self.model(self.dist.params(t))), ""))
            except (NumericalError, TorlabInputError, FloatingPointError, ValueError) as e:
                out.append((None, str(e)))
        return out


def _block_executor(task: _Block) -> Any:
    """The executor in use for the draws; serial when local processes cannot take the model
    (a closure: standard pickling cannot send it) -- the same blocks, the same result."""
    from torlab.parallel import SerialExecutor, current

    ex = current()
    if ex.kind == "processes":
        import pickle

        try:
            pickle.dumps(task)
        except (pickle.PicklingError, TypeError, AttributeError):
            return SerialExecutor()
    return ex


def _draw_blocks(model: Model, thetas: np.ndarray) -> list[np.ndarray]:
    """The draws in the fixed blocks of their tasks (:data:`MANY_BLOCK` for a model with
    ``evaluate_many``, else :data:`SAMPLE_BLOCK`): the split depends on the draws only."""
    from torlab.parallel import chunks

    size = MANY_BLOCK if hasattr(model, "evaluate_many") else SAMPLE_BLOCK
    return [thetas[s] for s in chunks(thetas.shape[0], size)]


def _collect(results: Sequence[Any], m: int) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The outputs of the draws' blocks (``_Block`` results, in order), stacked, and the
    mask of the failed draws.

    The blocks are taken :data:`SAMPLE_ROUND` at a time; after a round in which more than
    5 % of all the draws have failed the rest are not looked at (they may not have been
    evaluated: :func:`_evaluate_many`) and the propagation fails.  So the same blocks
    give the same result and the same error however many of them were evaluated.
    """
    failed = np.zeros(m, dtype=bool)
    first = ""
    rows = []
    i = 0
    for r0 in range(0, len(results), SAMPLE_ROUND):
        for block in results[r0:r0 + SAMPLE_ROUND]:
            for res, err in block:
                if res is None:
                    failed[i] = True
                    first = first or err
                else:
                    rows.append(res)
                i += 1
        if failed.sum() > 0.05 * m:
            break
    _check_failed(failed, m, first)
    stacked = {k: np.stack([r[k] for r in rows]) for k in rows[0]} if rows else {}
    return stacked, failed


def _check_failed(failed: np.ndarray, m: int, first: str = "") -> None:
    if failed.sum() > 0.05 * m:
        from torlab.errors import NumericalError as NE

        raise NE(f"uncertainty propagation: the model failed for {int(failed.sum())} of {m} "
                 "parameter draws; the fit's uncertainty reaches parameters where the model "
                 "does not hold" + (f" (first: {first})" if first else ""))


def _evaluate_many(model: Model, dist: ParameterDistribution, thetas: np.ndarray,
                   vectorized: bool) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Outputs at the draws, stacked; draws whose evaluation fails numerically are left out.

    A vectorised model takes every draw in one call.  Otherwise the draws go in fixed
    blocks of :data:`SAMPLE_BLOCK` to the executor in use (:mod:`torlab.parallel`), each
    evaluated row by row -- or, for a model with ``evaluate_many`` (:class:`_Block`), in
    blocks of :data:`MANY_BLOCK` evaluated in one call each, with the failures still
    per draw -- :data:`SAMPLE_ROUND` blocks at a time; after a round in which
    more than 5 % of all the draws have failed, the rest are not evaluated (the model
    does not hold there, and the answer is already known: :func:`_collect`).  The rounds
    are the same whatever evaluates them, so the result and the failure count are the
    same serially, on processes and on a cluster.
    """
    m = thetas.shape[0]
    if vectorized:
        failed = np.zeros(m, dtype=bool)
        out = _as_outputs(model(dist.params(thetas)))
        for v in out.values():
            bad = ~np.all(np.isfinite(v.reshape(m, -1)) | np.isnan(v.reshape(m, -1)), axis=1)
            failed |= bad
        _check_failed(failed, m)
        return {k: v[~failed] for k, v in out.items()}, failed
    task = _Block(model, dist)
    ex = _block_executor(task)
    blocks = _draw_blocks(model, thetas)
    results: list[Any] = []
    for r0 in range(0, len(blocks), SAMPLE_ROUND):
        results += ex.map(task, blocks[r0:r0 + SAMPLE_ROUND], description="band: parameter draws")
        if sum(res is None for block in results for res, _ in block) > 0.05 * m:
            break
    return _collect(results, m)


@dataclass
class PendingSampling:
    """A sampled propagation whose draws are not evaluated yet (``propagate(..., defer=True)``).

    The draws are made from the seed here; :meth:`tasks` are their blocks (the same fixed
    blocks :func:`propagate` evaluates), independent of each other, for whoever runs
    them -- e.g. a protocol that evaluates the blocks of all its sampled bands together
    on every worker (:func:`torlab.parallel.map_deferred`) -- and :meth:`finish` turns
    their results into the :class:`Propagation` :func:`propagate` would have returned
    (the same arithmetic on the same blocks: the same result, bit for bit).
    """

    model: Any
    dist: ParameterDistribution
    draws: np.ndarray
    f0: dict[str, np.ndarray]
    confidence: float
    tol: float
    eta: float
    design_base: dict[str, Any]
    n_eval: int = 0
    note: str = ""

    def tasks(self) -> tuple[Callable[[np.ndarray], Any], list[np.ndarray]]:
        """The block task (a picklable callable) and the blocks of draws it takes."""
        return _Block(self.model, self.dist), _draw_blocks(self.model, self.draws)

    def finish(self, results: Sequence[Any]) -> Propagation:
        """The propagation from the blocks' results (in the order of :meth:`tasks`).

        Raises
        ------
        torlab.errors.NumericalError
            More than 5 % of the draws failed.
        """
        samples, failed = _collect(results, self.draws.shape[0])
        return self._result(samples, failed)

    def run(self) -> Propagation:
        """Evaluate the draws on the executor in use and finish (what :func:`propagate` does)."""
        samples, failed = _evaluate_many(self.model, self.dist, self.draws,
                                         self.design_base.get("vectorized", False))
        return self._result(samples, failed)

    def _result(self, samples: dict[str, np.ndarray], failed: np.ndarray) -> Propagation:
        out = _sampling_from_draws(self.dist, self.draws[~failed], samples, self.f0,
                                   self.confidence, self.eta, self.dist.names,
                                   int(failed.sum()), tol=self.tol)
        out._design.update({**self.design_base, **out._design})
        out.n_evaluations += self.n_eval
        if self.note:
            out.notes.insert(0, self.note)
        return out


def _draws(dist: ParameterDistribution, n: int, seed: int) -> np.ndarray:
    """``(n, k)`` draws of ``theta``: per block multivariate normal or Student t (seeded)."""
    rng = np.random.default_rng(seed)
    theta0, cov = dist.transformed()
    k = theta0.size
    out = np.repeat(theta0[None, :], n, axis=0)
    z = rng.standard_normal((n, k))
    for idx, dof in dist.blocks_or_default:
        ii = np.asarray(idx)
        c = cov[np.ix_(ii, ii)]
        w, v = np.linalg.eigh(c)
        root = v * np.sqrt(np.clip(w, 0.0, None))
        dz = z[:, ii] @ root.T
        if math.isfinite(dof):
            chi = rng.chisquare(dof, size=n)
            dz = dz * np.sqrt(dof / chi)[:, None]
        out[:, ii] += dz
    return out


#: bases of the Halton sequence's dimensions (:func:`_lattice_draws`)
_PRIMES = (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71)


def _halton(n: int, d: int, shift: np.ndarray) -> np.ndarray:
    """The first ``n`` points of the ``d``-dimensional Halton sequence (radical inverses in
    the first ``d`` primes), shifted by ``shift`` modulo 1 (Cranley-Patterson): uniform
    points in the unit cube that fill it far more evenly than random ones."""
    return (_halton_points(n, d) + shift[None, :]) % 1.0


@functools.lru_cache(maxsize=8)
def _halton_points(n: int, d: int) -> np.ndarray:
    """The unshifted points of :func:`_halton` (made once per size; read-only)."""
    out = np.empty((n, d))
    idx = np.arange(1, n + 1)
    for j in range(d):
        b, f = _PRIMES[j], 1.0
        r = np.zeros(n)
        i = idx.copy()
        while i.any():
            f /= b
            r += f * (i % b)
            i //= b
        out[:, j] = r
    out.flags.writeable = False
    return out


def _lattice_draws(dist: ParameterDistribution, n: int, seed: int) -> np.ndarray:
    """``(n, k)`` draws of ``theta`` as :func:`_draws` makes them (per block multivariate
    normal or Student t), from a randomly shifted Halton sequence instead of random
    numbers (quasi-Monte Carlo: the normal parts by the inverse normal distribution, each t
    block's chi-squared by its inverse; seeded shift).  Their quantiles of a smooth function
    are several times closer to the exact ones than those of as many random draws.  With
    more dimensions than :data:`_PRIMES` (where Halton points lose their evenness) the
    draws are random (:func:`_draws`)."""
    theta0, cov = dist.transformed()
    k = theta0.size
    blocks = dist.blocks_or_default
    d = k + sum(1 for _, dof in blocks if math.isfinite(dof))
    if d > len(_PRIMES):
        return _draws(dist, n, seed)
    z, scales = _standard_lattice(n, k, seed, tuple(float(dof) for _, dof in blocks))
    out = np.repeat(theta0[None, :], n, axis=0)
    for (idx, _), scale in zip(blocks, scales, strict=True):
        ii = np.asarray(idx)
        w, v = np.linalg.eigh(cov[np.ix_(ii, ii)])
        dz = z[:, ii] @ (v * np.sqrt(np.clip(w, 0.0, None))).T
        out[:, ii] += dz if scale is None else dz * scale[:, None]
    return out


@functools.lru_cache(maxsize=16)
def _standard_lattice(n: int, k: int, seed: int, dofs: tuple[float, ...]
                      ) -> tuple[np.ndarray, list[np.ndarray | None]]:
    """The standard normal points ``(n, k)`` of :func:`_lattice_draws` and each block's
    Student-t scale ``sqrt(dof / chi2)`` (None for a normal block), made once per size,
    seed and degrees of freedom (the inverse distributions are most of the cost)."""
    from scipy.special import chdtri, ndtri

    d = k + sum(1 for dof in dofs if math.isfinite(dof))
    u = _halton(n, d, np.random.default_rng(seed).random(d))
    u = np.clip(u, 1e-12, 1.0 - 1e-12)
    z = ndtri(u[:, :k])
    z.flags.writeable = False
    scales: list[np.ndarray | None] = []
    col = k
    for dof in dofs:
        if math.isfinite(dof):
            sc = np.sqrt(dof / chdtri(dof, u[:, col]))
            sc.flags.writeable = False
            scales.append(sc)
            col += 1
        else:
            scales.append(None)
    return z, scales


def _none_result(f0: dict[str, np.ndarray], names: tuple[str, ...], confidence: float,
                 n_eval: int) -> Propagation:
    zero = {k: np.zeros_like(v) for k, v in f0.items()}
    return Propagation(
        method="none", confidence=confidence, center=f0, sd=zero,
        lower={k: v.copy() for k, v in f0.items()}, upper={k: v.copy() for k, v in f0.items()},
        contributions={k: {n: np.zeros_like(v) for n in names} for k, v in f0.items()},
        nonlinearity=math.nan, n_evaluations=n_eval, names=names,
        notes=["no parameter uncertainty: the band is the curve"], _design={"f0": f0})


def _block_variances(dist: ParameterDistribution, G: dict[str, np.ndarray],
                     cov: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per output: total variance and Welch-Satterthwaite degrees of freedom."""
    out = {}
    for key, g in G.items():  # g: (k, *shape)
        gf = g.reshape(g.shape[0], -1)
        var = np.zeros(gf.shape[1])
        denom = np.zeros(gf.shape[1])
        for idx, dof in dist.blocks_or_default:
            ii = np.asarray(idx)
            gb = gf[ii]
            vb = np.einsum("it,ij,jt->t", gb, cov[np.ix_(ii, ii)], gb)
            var += vb
            if math.isfinite(dof):
                denom += vb**2 / dof
        with np.errstate(divide="ignore", invalid="ignore"):
            nu = np.where(denom > 0, var**2 / np.where(denom > 0, denom, 1.0), np.inf)
        shape = g.shape[1:]
        out[key] = (np.clip(var, 0.0, None).reshape(shape), nu.reshape(shape))
    return out


def _probe_directions(dist: ParameterDistribution, h: np.ndarray, f0: dict[str, np.ndarray],
                      steps: list[dict[str, np.ndarray]]) -> list[np.ndarray]:
    """Principal directions (in theta, scaled to one standard deviation) of the output
    variance: the first, and the second when the first explains less than
    :data:`_PROBE_SHARE`."""
    basis, share = _principal_basis(dist, h, f0, steps)
    if not basis:
        return []
    n_dirs = 1 if share[0] >= _PROBE_SHARE or len(basis) == 1 else 2
    return basis[:n_dirs]


def _principal_basis(dist: ParameterDistribution, h: np.ndarray, f0: dict[str, np.ndarray],
                     steps: list[dict[str, np.ndarray]]) -> tuple[list[np.ndarray], np.ndarray]:
    """Every principal direction of the output variance (in theta, one standard deviation
    long), largest first, and the share of the normalised variance each explains."""
    _, cov = dist.transformed()
    k = h.size
    rows = []
    for key, v0 in f0.items():
        g = np.stack([(steps[i][key] - v0) / h[i] if h[i] > 0 else np.zeros_like(v0)
                      for i in range(k)]).reshape(k, -1)
        g = np.where(np.isfinite(g), g, 0.0)
        var = np.einsum("it,ij,jt->t", g, cov, g)
        sd = np.sqrt(np.clip(var, 0.0, None))
        floor = _SD_FLOOR * float(np.max(sd, initial=0.0))
        if floor <= 0:
            continue
        rows.append((g / np.maximum(sd, floor)).T)  # (t, k)
    if not rows:
        return [], np.zeros(0)
    A = np.concatenate(rows)  # normalised sensitivities
    w, v = np.linalg.eigh(cov)
    root = v * np.sqrt(np.clip(w, 0.0, None))  # theta = theta0 + root z
    B = A @ root  # output per unit z
    _, s, vt = np.linalg.svd(B, full_matrices=False)
    if s.size == 0 or s[0] <= 0:
        return [], np.zeros(0)
    return [root @ vt[i] for i in range(s.size)], s**2 / np.sum(s**2)


#: parameters of one correlated group up to which Shapley shares are exact (2^k subsets);
#: a larger group is averaged over seeded random orders (:data:`_SHAPLEY_ORDERS`)
_SHAPLEY_EXACT = 10
_SHAPLEY_ORDERS = 512


def shapley_shares(g: np.ndarray, cov: np.ndarray, var: np.ndarray) -> np.ndarray:
    """Each parameter's share of an output's variance: the Shapley effects of a linear
    model with correlated, jointly normal parameters.

    For the output ``y = g^T theta`` (per output point; ``g`` the gradient, or the
    regression slopes of a sampled band) with ``cov(theta) = C``, the variance a set
    ``u`` of parameters explains is ``v(u) = var(E[y | theta_u]) = b_u^T C_uu^-1 b_u``
    with ``b = C g``; a parameter's Shapley effect is its marginal contribution
    ``v(u + j) - v(u)`` averaged over the orders in which the parameters are added
    (Owen and Prieur, "On Shapley value for measuring importance of dependent inputs",
    SIAM/ASA J. Uncertainty Quantification 5, 2017; Song, Nelson and Staum, SIAM/ASA
    JUQ 4, 2016).  The effects are never negative (``v`` grows with ``u``) and add up to
    ``v(all) = g^T C g``: divided by ``var`` the shares add up to 1 in the linear method
    and to the linear part ``R^2 <= 1`` of a sampled output's variance.  Correlated
    parameters share what they explain together (the even split of the covariance terms,
    ``g_j (C g)_j / var``, gave shares above 100 % and below 0 when two parameters were
    strongly correlated).  Uncorrelated groups are computed apart (a parameter's effect
    depends only on its own group); a group of more than :data:`_SHAPLEY_EXACT`
    parameters is averaged over :data:`_SHAPLEY_ORDERS` seeded random orders.

    Parameters
    ----------
    g
        ``(k, t)``: the output's sensitivity to each parameter at each of its points.
    cov
        ``(k, k)`` covariance of the parameters.
    var
        ``(t,)`` the variance to divide by (points where it is 0 get no shares).

    Returns
    -------
    numpy.ndarray
        ``(k, t)`` shares.
    """
    g = np.nan_to_num(np.asarray(g, dtype=float))
    cov = np.asarray(cov, dtype=float)
    k, t = g.shape
    effects = np.zeros((k, t))
    b = cov @ g
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    live = np.flatnonzero(sd > 0)
    for group in _groups(cov, live, sd):
        if len(group) == 1:
            j = group[0]
            effects[j] = g[j] ** 2 * cov[j, j]
        else:
            effects[group] = _group_effects(np.asarray(group), cov, b)
    var = np.asarray(var, dtype=float).reshape(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(var > 0, np.clip(effects, 0.0, None) / var, 0.0)
    return np.where(np.isfinite(out), out, 0.0)


def _groups(cov: np.ndarray, live: np.ndarray, sd: np.ndarray) -> list[list[int]]:
    """The groups of correlated parameters (connected through any correlation)."""
    rest = set(live.tolist())
    groups = []
    while rest:
        todo, grp = [min(rest)], []
        rest.discard(todo[0])
        while todo:
            i = todo.pop()
            grp.append(i)
            near = [j for j in rest if abs(cov[i, j]) > 1e-12 * sd[i] * sd[j]]
            for j in near:
                rest.discard(j)
            todo += near
        groups.append(sorted(grp))
    return groups


def _group_effects(group: np.ndarray, cov: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Shapley effects ``(m, t)`` of one correlated group (:func:`shapley_shares`)."""
    m = group.size
    if m <= _SHAPLEY_EXACT:
        # every subset's v at once (one batched solve per subset size), then each
        # parameter's weighted marginal contributions over the subsets without it
        V = _subset_values(group, cov, b)
        size = np.array([bin(u).count("1") for u in range(1 << m)])
        w = np.array([math.factorial(s) * math.factorial(m - s - 1) / math.factorial(m)
                      for s in range(m)])
        out = np.zeros((m, b.shape[1]))
        masks = np.arange(1 << m)
        for j in range(m):
            without = masks[(masks >> j & 1) == 0]
            out[j] = w[size[without]] @ (V[without | 1 << j] - V[without])
        return out
    cache: dict[int, np.ndarray] = {0: np.zeros(b.shape[1])}

    def v(mask: int) -> np.ndarray:
        got = cache.get(mask)
        if got is None:
            idx = group[[i for i in range(m) if mask >> i & 1]]
            got = cache[mask] = _explained(cov[np.ix_(idx, idx)], b[idx])
        return got

    out = np.zeros((m, b.shape[1]))
    rng = np.random.default_rng(20170101)
    for _ in range(_SHAPLEY_ORDERS):
        mask = 0
        for j in rng.permutation(m):
            nxt = mask | 1 << int(j)
            out[j] += v(nxt) - v(mask)
            mask = nxt
    return out / _SHAPLEY_ORDERS


def _explained(cu: np.ndarray, bu: np.ndarray) -> np.ndarray:
    """``v(u) = b_u^T C_uu^-1 b_u`` per output point (least squares where ``C_uu`` is
    singular)."""
    try:
        x = np.linalg.solve(cu, bu)
    except np.linalg.LinAlgError:
        x = np.linalg.lstsq(cu, bu, rcond=None)[0]
    return np.sum(bu * x, axis=0)


def _subset_values(group: np.ndarray, cov: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``v(u)`` ``(2^m, t)`` of every subset ``u`` of ``group`` (bit ``i`` of the row index:
    parameter ``group[i]`` in ``u``), the subsets of one size in one batched solve."""
    m = group.size
    V = np.zeros((1 << m, b.shape[1]))
    members = [[i for i in range(m) if u >> i & 1] for u in range(1 << m)]
    for s in range(1, m + 1):
        us = [u for u in range(1 << m) if len(members[u]) == s]
        idx = group[np.array([members[u] for u in us])]  # (n_s, s)
        cu = cov[idx[:, :, None], idx[:, None, :]]  # (n_s, s, s)
        bu = b[idx]  # (n_s, s, t)
        try:
            x = np.linalg.solve(cu, bu)
        except np.linalg.LinAlgError:  # a singular subset: each on its own
            V[us] = [_explained(c, bb) for c, bb in zip(cu, bu, strict=True)]
            continue
        V[us] = np.sum(bu * x, axis=1)
    return V


def _linear_checked(dist: ParameterDistribution, h: np.ndarray, f0: dict[str, np.ndarray],
                    steps: list[dict[str, np.ndarray]], dirs: list[np.ndarray],
                    probes: list[dict[str, np.ndarray]], confidence: float, tol: float,
                    n_eval: int, method: str) -> Propagation:
    """The linear propagation of :func:`propagate`, its parameters' shares computed only
    when it is the result (the linear method, or the check passed)."""
    res = _linear_from_design(dist, h, f0, steps, dirs, probes, confidence, tol, n_eval,
                              dist.names, shares=method == "linear")
    if method == "auto" and res.nonlinearity <= tol:
        res = _linear_from_design(dist, h, f0, steps, dirs, probes, confidence, tol, n_eval,
                                  dist.names)
    return res


def _linear_from_design(dist: ParameterDistribution, h: np.ndarray, f0: dict[str, np.ndarray],
                        steps: list[dict[str, np.ndarray]], dirs: list[np.ndarray],
                        probes: list[dict[str, np.ndarray]], confidence: float, tol: float,
                        n_eval: int, names: tuple[str, ...], shares: bool = True
                        ) -> Propagation:
    """The linear propagation from its design (``shares``: the parameters' Shapley shares
    too; without them -- all zero -- when only the nonlinearity is wanted)."""
    _, cov = dist.transformed()
    k = h.size
    G = {}
    for key, v0 in f0.items():
        G[key] = np.stack([(steps[i][key] - v0) / h[i] if h[i] > 0 else np.zeros_like(v0)
                           for i in range(k)])
    varnu = _block_variances(dist, G, cov)
    center, sd, lower, upper, contrib, nus = {}, {}, {}, {}, {}, {}
    eta = 0.0
    for key, v0 in f0.items():
        var, nu = varnu[key]
        s = np.sqrt(var)
        tq = _quantile(confidence, nu)
        center[key] = v0
        sd[key] = s
        lower[key] = v0 - tq * s
        upper[key] = v0 + tq * s
        nus[key] = nu
        g = G[key].reshape(k, -1)
        c = shapley_shares(g, cov, var.reshape(-1)) if shares else np.zeros_like(g)
        contrib[key] = {n: c[i].reshape(v0.shape) for i, n in enumerate(names)}
        flat_s = s.reshape(-1)
        floor = max(_SD_FLOOR * float(np.max(flat_s, initial=0.0)), 1e-300)
        tq0 = _quantile(confidence, _min_dof(dist))
        for dvec, pr in zip(dirs, probes, strict=True):
            lin = v0 - tq0 * np.tensordot(dvec, G[key], axes=(0, 0))
            err = np.abs(pr[key] - lin).reshape(-1)
            ok = np.isfinite(err) & np.isfinite(flat_s)
            if np.any(ok) and float(np.max(flat_s, initial=0.0)) > 0:
                eta = max(eta, float(np.max(err[ok] / (tq0 * np.maximum(flat_s[ok], floor)))))
    res = Propagation(method="linear", confidence=confidence, center=center, sd=sd, lower=lower,
                      upper=upper, contributions=contrib,
                      nonlinearity=eta if dirs else math.nan, n_evaluations=n_eval, names=names)
    res._design = {"dist": dist, "h": h, "f0": f0, "steps": steps, "dirs": dirs,
                   "probes": probes, "nu": nus, "tol": tol}
    return res


def _sampling_from_draws(dist: ParameterDistribution, draws: np.ndarray,
                         samples: dict[str, np.ndarray], f0: dict[str, np.ndarray],
                         confidence: float, eta: float, names: tuple[str, ...], n_failed: int,
                         func: Callable[[dict[str, np.ndarray]], Any] | None = None,
                         tol: float = NONLINEARITY_TOL) -> Propagation:
    m = draws.shape[0]
    per = [{k: v[i] for k, v in samples.items()} for i in range(m)]
    if func is not None:
        per = [_as_outputs(func(s)) for s in per]
        f0 = _as_outputs(func(f0))
    stacked = {k: np.stack([s[k] for s in per]) for k in f0}
    design = {"samples": per, "draws": draws, "tol": tol}
    return _sampling_result(dist, draws, stacked, f0, confidence, eta, names, n_failed, design)


def _sampling_result(dist: ParameterDistribution, draws: np.ndarray,
                     stacked: dict[str, np.ndarray], f0: dict[str, np.ndarray],
                     confidence: float, eta: float, names: tuple[str, ...], n_failed: int,
                     design: dict[str, Any]) -> Propagation:
    lo_q, hi_q = 50.0 * (1 - confidence), 50.0 * (1 + confidence)
    center, sd, lower, upper, contrib = {}, {}, {}, {}, {}
    m = draws.shape[0]
    theta0, _ = dist.transformed()
    dth = draws - theta0[None, :]
    dth = dth - dth.mean(axis=0)
    sth = np.sqrt(np.mean(dth**2, axis=0))
    for key, v0 in f0.items():
        x = stacked[key].reshape(m, -1)
        ok = np.all(np.isfinite(x), axis=0)
        lo = np.full(x.shape[1], np.nan)
        hi = np.full(x.shape[1], np.nan)
        s = np.full(x.shape[1], np.nan)
        if np.any(ok):
            lo[ok], hi[ok] = np.percentile(x[:, ok], [lo_q, hi_q], axis=0)
            s[ok] = np.std(x[:, ok], axis=0, ddof=1)
        # the band always contains the model at the estimate
        v = np.asarray(v0, dtype=float).reshape(-1)
        lo = np.where(np.isfinite(lo), np.minimum(lo, v), lo)
        hi = np.where(np.isfinite(hi), np.maximum(hi, v), hi)
        center[key] = v0
        sd[key] = s.reshape(v0.shape)
        lower[key] = lo.reshape(v0.shape)
        upper[key] = hi.reshape(v0.shape)
        # shares from the multiple regression of the output on the drawn parameters
        live = sth > 0
        shares = np.zeros((len(names), x.shape[1]))
        if np.any(live) and np.any(ok) and m > live.sum() + 1:
            xc = x[:, ok] - x[:, ok].mean(axis=0)
            d = dth[:, live]
            cdd = d.T @ d / m
            sxy = d.T @ xc / m  # (k_live, t)
            beta = np.linalg.lstsq(cdd, sxy, rcond=None)[0]
            vx = np.mean(xc**2, axis=0)
            sub = np.zeros((live.sum(), x.shape[1]))
            sub[:, ok] = shapley_shares(beta, cdd, vx)
            shares[live] = sub
        contrib[key] = {n: shares[i].reshape(v0.shape) for i, n in enumerate(names)}
    res = Propagation(method="sampling", confidence=confidence, center=center, sd=sd,
                      lower=lower, upper=upper, contributions=contrib, nonlinearity=eta,
                      n_evaluations=m + n_failed, names=names, n_failed=n_failed)
    res._design = {**design, "dist": dist, "f0": f0, "stacked": stacked, "n_samples": m + n_failed}
    if n_failed:
        res.notes.append(f"{n_failed} of {m + n_failed} parameter draws failed in the model and "
                         "were left out")
    return res
