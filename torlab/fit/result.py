"""The result of every ``torlab fit``: parameters, uncertainties, warnings, data vs model.

Every fit in torlab returns a :class:`FitResult` (one type for every fit:
parameters, standard errors, 95 % intervals, covariance-based correlations,
warnings, the data against the model; :meth:`FitResult.report`,
:meth:`FitResult.plot`, :meth:`FitResult.to_params`).  Parameters are in SI units; ``names`` are the scene contract's keys
where one exists (the layer laws' parameters of :mod:`torlab.model.layers`, ``eta0``,
``alpha``, ``Z``), so :meth:`FitResult.to_scene_dict`
is a valid parameter file for ``torlab predict`` (the scene keys of ``docs/scenes.md``).

Uncertainties come from the linearised least-squares covariance
``C = s^2 (J^T J)^-1`` (or a heteroscedasticity-and-autocorrelation-consistent
sandwich where the residuals are correlated, see :func:`hac_covariance`), the
95 % intervals from Student's t with the residual degrees of freedom.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.codec import finite_tree
from torlab.model.layers import DEFAULT_LAW, all_params
from torlab.model.parameters import BOUNDARY_KEYS, LUBRICANT_KEYS
from torlab.model.removal import LAW_UNITS

__all__ = [
    "PARAM_UNITS",
    "FitResult",
    "PackedFit",
    "StoredFit",
    "covariance_from_jacobian",
    "finite_tree",
    "hac_covariance",
    "log_interval",
    "student_t",
    "viscosity_result",
]

#: unit of each parameter name (SI) for tables and the scene file
PARAM_UNITS: dict[str, str] = {
    **{n: p.unit for n, p in all_params().items()},  # the layer laws' (torlab.model.layers)
    "eta0": "Pa*s",
    "alpha": "1/Pa",
    "Z": "-",
    "speed_exponent": "-",
    "film_prefactor": "m",
    "film_at_reference": "m",
    "film_temperature_coefficient": "1/K",
    "rig_compliance": "m/Pa",
    "mu_c1_Tref": "-",
    "mu_c2_Tref": "-",
    # Polach's creep-force law (torlab.model.polach)
    "mu0": "-",
    "A": "-",
    "B": "s/m",
    "kA": "-",
    "kS": "-",
    # the removal laws (torlab.model.removal): k0, k1, spread, transfer
    **LAW_UNITS,
}



def student_t(dof: float, confidence: float = 0.95) -> float:
    """Two-sided Student-t quantile for ``confidence`` with ``dof`` degrees of freedom.

    ``dof`` may be fractional (Satterthwaite degrees of freedom); below 1 it is 1.
    """
    from torlab._stats import t_ppf  # scipy.stats.t.ppf, without its import

    return float(t_ppf(0.5 + confidence / 2.0, max(float(dof), 1.0)))


def covariance_from_jacobian(jac: np.ndarray, residuals: np.ndarray, n_params: int
                             ) -> tuple[np.ndarray, float]:
    """Least-squares covariance ``s^2 (J^T J)^+`` and the residual standard deviation ``s``.

    A (numerically) singular ``J^T J`` gives infinite variances for the
    directions it cannot resolve (pseudo-inverse with an infinite fill), so an
    undetermined parameter shows up as such rather than as a small error.
    """
    r = np.asarray(residuals, dtype=float)
    dof = max(r.size - n_params, 1)
    s2 = float(r @ r) / dof
    return _scaled_inverse(jac.T @ jac) * s2, math.sqrt(s2)


def _scaled_inverse(a: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric positive semi-definite matrix, ``inf`` on its null space."""
    d = np.sqrt(np.clip(np.diag(a), 0.0, None))
    k = a.shape[0]
    bad = d <= 0
    d[bad] = 1.0
    an = a / np.outer(d, d)
    w, v = np.linalg.eigh(an)
    tol = max(w.max(initial=0.0), 1.0) * 1e-12
    ok = w > tol
    inv = (v[:, ok] / w[ok]) @ v[:, ok].T
    out = inv / np.outer(d, d)
    if not ok.all() or bad.any():
        # the directions of the null space carry unbounded variance
        null = v[:, ~ok]
        weight = np.sum(null**2, axis=1) > 1e-6
        for i in range(k):
            if weight[i] or bad[i]:
                out[i, :] = np.inf
                out[:, i] = np.inf
    return out


def hac_covariance(jac: np.ndarray, residuals: np.ndarray, lags: int) -> np.ndarray:
    """Newey-West (Bartlett kernel) sandwich covariance of least-squares parameters.

    ``C = (J^T J)^-1 J^T Omega J (J^T J)^-1`` with
    ``J^T Omega J = sum_l w_l sum_t (g_t g_{t-l}^T + g_{t-l} g_t^T)``, ``g_t = J_t r_t``,
    ``w_l = 1 - l / (lags + 1)`` (Newey & West 1987, Econometrica 55, 703).
    It stays consistent when the residuals are correlated along the record (the
    HPT strength fluctuation) and when their variance changes (relative noise),
    where ``s^2 (J^T J)^-1`` would be far too optimistic.
    """
    g = jac * np.asarray(residuals, dtype=float)[:, None]
    meat = g.T @ g
    for lag in range(1, int(lags) + 1):
        w = 1.0 - lag / (lags + 1.0)
        gamma = g[lag:].T @ g[:-lag]
        meat += w * (gamma + gamma.T)
    bread = _scaled_inverse(jac.T @ jac)
    if not np.all(np.isfinite(bread)):
        return bread
    n, k = jac.shape
    return bread @ meat @ bread * (n / max(n - k, 1))


@dataclass
class FitResult:
    """A fitted parameter set: what every fit in torlab returns.

    Attributes
    ----------
    kind
        ``"layer_hpt"``, ``"layer_traction"``, ``"temperature"``, ``"film"`` or
        ``"viscosity"``.
    names
        Parameter names, scene-contract keys where one exists.
    params, stderr
        Values and standard errors, SI units.
    ci95
        95 % confidence intervals ``(low, high)``.
    correlation
        ``(k, k)`` correlation matrix of the estimates (NaN where undetermined).
    residual_norm
        RMS of the residuals, in the data's unit (:attr:`residual_unit`).
    n_points
        Points used in the fit.
    warnings
        What the data do not determine (``"L_mup not determined: ..."``).
    data
        DataFrame with the abscissa, ``*_measured``, ``*_model`` and
        ``residual_*`` columns (units in the names).
    meta
        Provenance: product, amount, temperature, source files, method ...
    fixed
        Parameters held fixed in the fit (value, SI), reported and written but
        without uncertainty.
    residual_unit
        Unit of :attr:`residual_norm` (``"Pa"``, ``"-"``, ``"m"`` ...).
    n_evaluations
        Model evaluations the optimiser used (benchmark figure).
    dof
        Residual degrees of freedom (of the intervals, unless a fit gives each
        parameter its own: the HPT layer fit lists them in
        ``meta["interval_dof"]``).
    x_column, y_column
        Names of the abscissa and the measured column of :attr:`data` (figure).
    covariance
        ``(k, k)`` covariance of the estimates in SI units (order of :attr:`names`;
        ``inf`` rows for undetermined parameters), or None where the fit does not
        give one.  Written to ``params.yaml`` (``fit: covariance:``) so that
        predictions carry the fit's uncertainty (:mod:`torlab.uncertainty`).
    log_scale
        Parameters whose uncertainty is symmetric in ``ln p`` (positive
        parameters): their intervals are ``p exp(+-t se/p)`` (never negative)
        and predictions propagate them on that scale.
    """

    kind: str
    names: tuple[str, ...]
    params: dict[str, float]
    stderr: dict[str, float]
    ci95: dict[str, tuple[float, float]]
    correlation: np.ndarray
    residual_norm: float
    n_points: int
    warnings: list[str]
    data: Any
    meta: dict[str, Any] = field(default_factory=dict)
    fixed: dict[str, float] = field(default_factory=dict)
    residual_unit: str = "-"
    n_evaluations: int = 0
    dof: int = 0
    x_column: str = ""
    y_column: str = ""
    covariance: Any = None
    log_scale: tuple[str, ...] = ()

    # -- construction ---------------------------------------------------------------------
    @classmethod
    def from_covariance(cls, kind: str, names: tuple[str, ...], values: np.ndarray,
                        cov: np.ndarray, *, dof: int, param_dof: Any = None,
                        log_scale: tuple[str, ...] = (), **kw: Any) -> FitResult:
        """Build a result from estimates and their covariance (Student-t intervals).

        ``param_dof`` (one value per parameter, optional) gives each interval
        its own degrees of freedom (Satterthwaite); ``dof`` otherwise.
        Parameters in ``log_scale`` (positive) get the transformed interval
        ``p exp(+-t se/p)`` (the delta method on ``ln p``), which is never negative.
        """
        values = np.asarray(values, dtype=float)
        cov = np.asarray(cov, dtype=float)
        var = np.diag(cov)
        se = np.where(np.isfinite(var) & (var >= 0), np.sqrt(np.abs(var)), np.inf)
        if param_dof is None:
            tq = np.full(values.size, student_t(dof))
        else:
            tq = np.array([student_t(d) for d in np.asarray(param_dof, dtype=float)])
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(se, se)
        corr[~np.isfinite(corr)] = np.nan
        np.fill_diagonal(corr, 1.0)
        params = {n: float(v) for n, v in zip(names, values, strict=True)}
        stderr = {n: float(s) for n, s in zip(names, se, strict=True)}
        ci = {n: log_interval(v, s, q) if n in log_scale else (float(v - q * s), float(v + q * s))
              for n, v, s, q in zip(names, values, se, tq, strict=True)}
        return cls(kind=kind, names=tuple(names), params=params, stderr=stderr, ci95=ci,
                   correlation=corr, dof=int(dof), covariance=cov.copy(),
                   log_scale=tuple(n for n in names if n in log_scale), **kw)

    # -- outputs ----------------------------------------------------------------------------
    def determined(self, name: str) -> bool:
        """Whether ``name`` has a finite standard error."""
        return math.isfinite(self.stderr.get(name, math.inf))

    def distribution(self, names: Any = None) -> Any:
        """The estimates' :class:`~torlab.uncertainty.ParameterDistribution` (determined ones).

        ``names`` restricts it (default: every determined parameter).  None
        when the fit gives no covariance.  The degrees of freedom are the
        smallest of the parameters' (``meta["interval_dof"]``) or :attr:`dof`.
        """
        from torlab.uncertainty import ParameterDistribution

        if self.covariance is None:
            return None
        keep = [i for i, n in enumerate(self.names) if self.determined(n)
                and (names is None or n in names)]
        if not keep:
            return None
        sel = [self.names[i] for i in keep]
        cov = np.asarray(self.covariance, dtype=float)[np.ix_(keep, keep)]
        return ParameterDistribution.from_covariance(
            sel, [self.params[n] for n in sel], cov,
            log_scale=[n for n in sel if n in self.log_scale], dof=self._block_dof(sel))

    def _param_dof(self, name: str) -> float:
        """Degrees of freedom of one parameter's interval."""
        pd = self.meta.get("interval_dof")
        if isinstance(pd, dict) and name in pd:
            return float(pd[name])
        return float(max(self.dof, 1))

    def _block_dof(self, names: Any) -> float:
        pd = self.meta.get("interval_dof")
        if isinstance(pd, dict) and pd:
            return float(min(float(pd.get(n, self.dof)) for n in names))
        return float(max(self.dof, 1))

    def covariance_section(self) -> dict[str, Any] | None:
        """The ``fit: covariance:`` block of ``params.yaml`` (validated by :mod:`torlab.scene`).

        ``names``, ``values`` (the estimates it belongs to), ``matrix`` (SI),
        ``log_scale``, ``dof`` and ``not_determined`` (parameters left out:
        no finite variance).  None without a covariance.
        """
        if self.covariance is None:
            return None
        det = [n for n in self.names if self.determined(n)]
        idx = [self.names.index(n) for n in det]
        cov = np.asarray(self.covariance, dtype=float)[np.ix_(idx, idx)]
        if not np.all(np.isfinite(cov)):
            return None
        return {"names": det, "values": [float(self.params[n]) for n in det],
                "matrix": [[float(x) for x in row] for row in cov],
                "log_scale": [n for n in det if n in self.log_scale],
                "dof": self._block_dof(det) if det else float(self.dof),
                "not_determined": [n for n in self.names if n not in det]}

    def to_scene_dict(self) -> dict[str, Any]:
        """The scene contract's ``boundary:`` / ``lubricant:`` keys of the fitted values.

        Plain SI numbers (the scene reader accepts them); only parameters with a
        scene key are written, fixed ones included.  Other fitted numbers (speed
        exponent ...) are in :meth:`table` and the provenance, not here.
        """
        allv = {**self.fixed, **self.params}
        out: dict[str, Any] = {}
        b = {k: float(allv[k]) for k in BOUNDARY_KEYS if k in allv}
        law = self.meta.get("law")
        if b and isinstance(law, str) and law != DEFAULT_LAW and self.kind.startswith("layer"):
            b = {"law": law, **b}  # the default law is not written (a scene's default)
        if b:
            out["boundary"] = b
        lub = {k: float(allv[k]) for k in LUBRICANT_KEYS if k in allv}
        lub.update(self.meta.get("lubricant_extra", {}))
        if lub:
            out["lubricant"] = lub
        return out

    def provenance(self) -> dict[str, Any]:
        """The ``fit:`` section of a parameter file (the scene reader keeps it as provenance)."""
        from torlab import __version__

        prov: dict[str, Any] = {
            "kind": self.kind,
            "torlab_version": __version__,
            "n_points": int(self.n_points),
            "residual_rms": float(self.residual_norm),
            "residual_unit": self.residual_unit,
            "parameters": {
                n: {"value": self.params[n], "stderr": _finite_or_none(self.stderr[n]),
                    "ci95": [_finite_or_none(self.ci95[n][0]), _finite_or_none(self.ci95[n][1])],
                    "unit": PARAM_UNITS.get(n, ""), "dof": self._param_dof(n)}
                for n in self.names
            },
            "fixed": dict(self.fixed),
            "warnings": list(self.warnings),
        }
        cs = self.covariance_section()
        if cs is not None:
            prov["covariance"] = cs
        if isinstance(self.meta.get("runs"), list) and self.meta["runs"]:
            prov["runs_pooled"] = len(self.meta["runs"])
        if isinstance(self.meta.get("model_selection"), dict):
            prov["model_selection"] = finite_tree(self.meta["model_selection"])
        for k, v in self.meta.items():
            if k != "lubricant_extra" and (v is None or isinstance(v, (str, int, float, bool, list))):
                prov.setdefault(k, v)
        return prov

    def to_yaml_dict(self) -> dict[str, Any]:
        """``params.yaml``: the scene keys plus the ``fit:`` provenance."""
        return {**self.to_scene_dict(), "fit": self.provenance()}

    def to_params(self, path: str | Any | None = None) -> dict[str, Any]:
        """The parameter file ``torlab predict`` reads: the scene keys of the fitted values
        (``boundary:``, ``lubricant:``) and the ``fit:`` provenance.

        With ``path`` it is also written there as YAML (refused if the file
        exists: results are never overwritten silently).
        """
        d = self.to_yaml_dict()
        if path is not None:
            from pathlib import Path

            from torlab.errors import TorlabInputError
            from torlab.files import atomic_write_text
            from torlab.yamlio import dump_yaml

            p = Path(path)
            if p.exists():
                raise TorlabInputError("exists; choose a new file for the parameters", path=p)
            atomic_write_text(p, dump_yaml(d))
        return d

    def report(self) -> str:
        """The fit as Markdown: parameters with standard errors, 95 % intervals and status,
        fixed values, points, residual RMS, and the warnings."""
        lines = [f"**{self.kind} fit** ({self.meta.get('source', '') or 'data'}): "
                 f"{self.n_points} points, residual RMS {self.residual_norm:.4g} "
                 f"{self.residual_unit}", "",
                 "| parameter | value | std. error | 95 % interval | unit | status |",
                 "|---|---|---|---|---|---|"]
        for r in self.table().itertuples():
            se = "—" if r.stderr != r.stderr else f"{r.stderr:.3g}"
            hi = "unbounded" if r.ci95_high != r.ci95_high else f"{r.ci95_high:.5g}"
            ci = "—" if r.ci95_low != r.ci95_low else f"[{r.ci95_low:.5g}, {hi}]"
            lines.append(f"| {r.parameter} | {r.value:.5g} | {se} | {ci} | {r.unit} | "
                         f"{r.status} |")
        if self.meta.get("scatter"):
            lines += ["", str(self.meta["scatter"])]
        lines += [""] + [f"- warning: {w}" for w in self.warnings]
        return "\n".join(lines).rstrip() + "\n"

    def _repr_markdown_(self) -> str:
        return self.report()

    def plot(self, *, title: str | None = None, model_curve: tuple[Any, Any] | None = None) -> Any:
        """The result's figure (a matplotlib figure): data against the fitted model and the
        residuals, or what its kind draws (:func:`torlab.reports.fit.result_figure`)."""
        # upward on purpose: a result draws itself in a notebook (``fit.plot()``, as lmfit's
        # results do); what it draws is the report layer's, imported only when asked
        from torlab.reports.fit import result_figure

        return result_figure(self, title=title, model_curve=model_curve)

    def table(self) -> Any:
        """DataFrame ``parameter, value, stderr, ci95_low, ci95_high, unit`` (+ fixed rows).

        Undetermined standard errors and intervals are empty cells (NaN).
        """
        import pandas as pd

        rows = []
        for n in self.names:
            se = self.stderr[n]
            lo, hi = self.ci95[n]
            rows.append({"parameter": n, "value": self.params[n],
                         "stderr": se if math.isfinite(se) else float("nan"),
                         "ci95_low": lo if math.isfinite(lo) else float("nan"),
                         "ci95_high": hi if math.isfinite(hi) else float("nan"),
                         "unit": PARAM_UNITS.get(n, ""), "status": self._status(n)})
        for n, v in self.fixed.items():
            rows.append({"parameter": n, "value": v, "stderr": float("nan"),
                         "ci95_low": float("nan"), "ci95_high": float("nan"),
                         "unit": PARAM_UNITS.get(n, ""), "status": "fixed"})
        return pd.DataFrame(rows, columns=["parameter", "value", "stderr", "ci95_low",
                                           "ci95_high", "unit", "status"])

    def _status(self, name: str) -> str:
        if not self.determined(name):
            return "not determined"
        if any(w.startswith((f"{name} poorly", f"{name} not")) for w in self.warnings):
            return "poorly determined"
        return "fitted"

    def correlation_table(self) -> Any:
        """Correlation matrix as a labelled DataFrame."""
        import pandas as pd

        return pd.DataFrame(self.correlation, index=list(self.names), columns=list(self.names))

    def summary(self) -> dict[str, Any]:
        """Key numbers for ``summary.json`` (finite numbers or None)."""
        return {
            "kind": self.kind,
            "n_points": int(self.n_points),
            "dof": int(self.dof),
            "residual_rms": float(self.residual_norm),
            "residual_unit": self.residual_unit,
            "n_evaluations": int(self.n_evaluations),
            "params": dict(self.params),
            "stderr": {k: _finite_or_none(v) for k, v in self.stderr.items()},
            "ci95": {k: [_finite_or_none(a), _finite_or_none(b)] for k, (a, b) in self.ci95.items()},
            "correlation": [[_finite_or_none(float(x)) for x in row] for row in self.correlation],
            "fixed": dict(self.fixed),
            "log_scale": list(self.log_scale),
            "warnings": list(self.warnings),
            "meta": finite_tree({k: v for k, v in self.meta.items() if k != "lubricant_extra"}),
        }


@dataclass(frozen=True)
class StoredFit:
    """A fit result whose data table stays in a store (a protocol run's result cache):
    what a figure of it is given instead of the whole result, read where it is drawn.

    A protocol run keeps of each large fit (an HPT layer pooled over many runs: its
    :attr:`FitResult.data` is a few hundred kB) only :attr:`light` (the result without its
    data); the figure task reads the whole result through the reference (:meth:`whole`).
    What the figure shows is named by the two fields (a figure's content key,
    :func:`torlab.reports.render.plot_digest`): the stored entry's name (a content key of
    the fit's inputs) and the light result (every estimate); the reference (the entry
    file's place and status, which differ from run to run) is not a field.  It reads
    back while the entry stays where it was written: a protocol run's cache is in the
    run's staging folder until the run ends and is then moved into the output folder, so a
    plot kept past the run reads its fit first (:meth:`whole`).

    Attributes
    ----------
    entry
        The stored entry's name.
    light
        The result without its data (``data`` None).
    """

    entry: str
    light: FitResult

    @classmethod
    def of(cls, result: FitResult, ref: Any) -> StoredFit:
        """The stored form of ``result``, read back through ``ref`` (an object with
        ``name`` and ``value()``: :class:`torlab.protocols.cache.EntryRef`)."""
        import dataclasses

        out = cls(ref.name, dataclasses.replace(result, data=None))
        object.__setattr__(out, "ref", ref)  # not a field: not part of the content key
        return out

    def whole(self) -> FitResult:
        """The whole result, read from the store.

        Raises
        ------
        TorlabInputError
            The entry is gone or changed since it was stored (the run's cache folder was
            changed while it ran), or holds another result.
        """
        from torlab.codec import BadEntry
        from torlab.errors import TorlabInputError

        ref = getattr(self, "ref", None)
        try:
            if ref is None:
                raise BadEntry("no reference to it")
            value = ref.value()
        except BadEntry as e:
            raise TorlabInputError(f"the stored fit {self.entry} cannot be read back ({e}); "
                                   "was the run's cache folder changed while it ran?") from None
        names = list(self.light.params)
        if not isinstance(value, FitResult) or value.kind != self.light.kind \
                or list(value.params) != names or not np.array_equal(
                    [value.params[n] for n in names], [self.light.params[n] for n in names],
                    equal_nan=True):
            raise TorlabInputError(f"the stored fit {self.entry} holds another result; was the "
                                   "run's cache folder changed while it ran?")
        return value


class PackedFit:
    """A fit result a protocol run keeps to its end but reads little: compressed, about 2
    kB where the result (without its data) holds 12-17 kB of Python objects.

    A campaign fits one set per few logs, and the run keeps every result for its report
    (the fits section's notes, the model-selection table, the figures of the sets that get
    one); kept as they came, the results of a 128x campaign's 1536 sets were about 20 MB
    of the run's memory.  :attr:`kind` and :attr:`warnings` (read of every set) are kept as
    they are, and the data table, if the result has one, as it is (a table is compact
    already); any other attribute is read from the result restored from the bytes (about
    50 us), which :meth:`restored` gives whole.  The bytes are :mod:`pickle`'s, made in
    this process from a result it computed or read and checked, and read back only here:
    they are never written to a file or taken from one.

    Attributes
    ----------
    kind, warnings
        Those of the result.
    ref
        Where the whole result is stored, for a result kept without its data
        (:class:`StoredFit`), else None.
    """

    __slots__ = ("_blob", "_data", "kind", "ref", "warnings")

    def __init__(self, result: FitResult, ref: Any = None) -> None:
        import dataclasses
        import pickle
        import zlib

        self._data = result.data  # the table apart, as it is
        light = result if result.data is None else dataclasses.replace(result, data=None)
        # level 1: as small as level 6 for a result without its table, and quicker
        self._blob = zlib.compress(pickle.dumps(light, protocol=5), 1)
        self.kind, self.warnings, self.ref = result.kind, list(result.warnings), ref

    def restored(self) -> FitResult:
        """The result (a new object at every call; its data table the one kept)."""
        import pickle
        import zlib

        res = pickle.loads(zlib.decompress(self._blob))  # bytes made in this process
        res.data = self._data
        return res

    def arg(self) -> Any:
        """What a figure of the result is given: its :class:`StoredFit` if it is kept
        without its data, else the result."""
        res = self.restored()
        return res if self.ref is None else StoredFit.of(res, self.ref)

    def __getattr__(self, attr: str) -> Any:
        if attr.startswith("__"):  # copy, pickle: not looked up in the restored one
            raise AttributeError(attr)
        return getattr(self.restored(), attr)

    def __repr__(self) -> str:
        return f"PackedFit({self.kind!r}, {len(self._blob)} bytes)"


def log_interval(value: float, se: float, tq: float) -> tuple[float, float]:
    """``value exp(+-tq se/value)``: the interval of a positive parameter on the log scale.

    The delta method on ``ln p`` (standard error ``se/p``); it keeps the
    interval positive and gives the asymmetry of a poorly determined positive
    parameter.  ``(0, inf)`` when ``se`` is infinite.
    """
    if not (value > 0):
        return (float(value - tq * se), float(value + tq * se))
    r = tq * se / value
    if not math.isfinite(r):
        return (0.0, math.inf)
    if r > 700.0:  # beyond exp's range: no upper bound
        return (float(value * math.exp(-r)), math.inf)
    return (float(value * math.exp(-r)), float(value * math.exp(r)))


def _finite_or_none(x: float) -> float | None:
    return float(x) if x is not None and math.isfinite(x) else None


def viscosity_result(vf: Any) -> FitResult:
    """The viscosity fit itself: :class:`~torlab.fit.viscosity.ViscosityFit` is a
    :class:`FitResult` (kept for callers of the earlier converter)."""
    return vf
