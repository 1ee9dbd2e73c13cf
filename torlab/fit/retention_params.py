"""The result of a removal fit and its parameter file (the ``retention:`` section).

:class:`RemovalFit` is the :class:`~torlab.fit.result.FitResult` of
:func:`torlab.fit.removal.fit_removal` (``kind="removal"``) with what a retention
prediction needs besides the law: :func:`parameter_section` writes it as the
``retention:`` section of ``params.yaml`` (the law with its log-space covariance and
sensitivity to the layer, the product's amount layer, its density [kg/m^3]);
:func:`load_retention` reads such a file back as :class:`RetentionParams` (every value
checked, the file and key named in an error), which ``torlab predict retention`` and
``predict traction --sweep`` take.  The law's parameters and units are those of
:data:`torlab.model.removal.LAW_UNITS` (``k0`` [kg/J], ``k1`` [m^2/J], ``spread``
[1/pass], ``transfer`` [-]).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.fit.result import FitResult
from torlab.model.removal import LAW_UNITS, LAWS

__all__ = ["RETENTION_FORMAT", "RemovalFit", "RetentionParams", "is_retention_file",
           "load_retention", "parameter_section", "retention_from_dict"]

#: version of the ``retention:`` section of a parameter file
RETENTION_FORMAT = 1


@dataclass
class RemovalFit(FitResult):
    """The removal fit: a :class:`~torlab.fit.result.FitResult` (``kind="removal"``) that
    also carries what a prediction needs besides the law (:attr:`parameter_file`).

    Attributes
    ----------
    parameter_file
        The ``retention:`` section of ``params.yaml``: the law with its log-space
        covariance and sensitivity to the layer, the product's amount layer
        (:meth:`~torlab.model.amount.AmountLayer.to_dict`) and density.  Read
        back by :func:`load_retention`.
    """

    parameter_file: dict[str, Any] = field(default_factory=dict)

    def to_yaml_dict(self) -> dict[str, Any]:
        """``params.yaml``: the ``retention:`` section and the ``fit:`` provenance.

        A removal law has no scene keys (``boundary:``, ``lubricant:``): the
        file is read by ``torlab predict retention`` and ``predict traction
        --sweep``, not merged into a scene.
        """
        return {"retention": self.parameter_file, "fit": self.provenance()}


def parameter_section(res: FitResult, layer: Any, density: float | None) -> dict[str, Any]:
    """The ``retention:`` section of a removal fit's parameter file."""
    allv = {**res.fixed, **res.params}
    return {
        "format": RETENTION_FORMAT,
        "law": res.meta["law"],
        "order": int(res.meta["order"]),
        "parameters": {k: float(v) for k, v in allv.items()},
        "units": {k: LAW_UNITS.get(k, "-") for k in allv},
        "fitted": list(res.names),
        "ci95": {k: [float(a), float(b)] for k, (a, b) in res.ci95.items()},
        "dof": int(res.dof),
        "interval_dof": dict(res.meta.get("interval_dof", {})),
        "density_kg_m3": density,
        "fit_space": res.meta["fit_space"],
        "layer": layer.to_dict(),
    }


@dataclass
class RetentionParams:
    """What ``torlab predict retention`` reads from a removal fit's parameter file.

    Attributes
    ----------
    layer
        The product's :class:`~torlab.model.amount.AmountLayer`.
    removal
        The law as a :class:`RemovalFit` (estimate, log-space covariance,
        sensitivity to the layer: :func:`torlab.model.retention.removal_draws`).
    density
        Product density [kg/m^3] of the time tests, or None.
    source
        The file.
    """

    layer: Any
    removal: Any
    density: float | None
    source: str


def _matrix(v: Any, shape: tuple[int, int], where: str, path: str) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise TorlabInputError(f"expected a finite {shape[0]} x {shape[1]} matrix", path=path,
                               key=where)
    return a


def _log_values(v: Any, k: int, path: str) -> np.ndarray:
    """``fit_space.values``: the log parameters, finite except the rate's, which may be
    ``-.inf`` (a rate of zero: the product is not removed)."""
    try:
        a = np.asarray([v], dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.shape == (1, k) and a[0, 0] == -math.inf and np.all(np.isfinite(a[0, 1:])):
        return a[0]
    return _matrix([v], (1, k), "retention.fit_space.values", path)[0]


def _fit_space(fs: dict, law: str, order: int, path: str,
               bad: Callable[[str, str], TorlabInputError]) -> tuple[list[str], Any, Any]:
    """The names, log values and covariance of ``fit_space`` (with its covariance without
    the layer), checked: the names fit the law, the matrices are square, symmetric, with a
    non-negative diagonal, and exact (zero) where the rate is zero."""
    names = [str(n) for n in fs["names"]]
    k = len(names)
    if not 1 <= k <= 3 or names[0] != f"k{order}" or \
            any(n not in ("spread", "transfer") for n in names[1:]):
        raise bad(f"names {names} do not fit the law {law}", "fit_space.names")
    theta = _log_values(fs.get("values"), k, path)
    cov = _matrix(fs.get("covariance"), (k, k), "retention.fit_space.covariance", path)
    cov0 = _matrix(fs.get("covariance_without_layer", cov), (k, k),
                   "retention.fit_space.covariance_without_layer", path)
    for c, nm in ((cov, "covariance"), (cov0, "covariance_without_layer")):
        if not np.allclose(c, c.T, rtol=1e-6, atol=0.0) or np.any(np.diag(c) < 0):
            raise bad("must be symmetric with a non-negative diagonal", f"fit_space.{nm}")
        if theta[0] == -math.inf and np.any(c[0] != 0):
            raise bad(f"a removal rate of zero ({names[0]}: 0, ln = -.inf) is exact: its row "
                      "and column must be zero", f"fit_space.{nm}")
    return names, theta, cov


def retention_from_dict(d: Any, *, path: str = "", fit: Any = None) -> RetentionParams:
    """:class:`RetentionParams` from the ``retention:`` section (every value checked).

    Raises
    ------
    TorlabInputError
        Missing or malformed keys, an unknown law or format, matrices of the
        wrong shape or not finite, a layer of :meth:`AmountLayer.from_dict`'s
        errors.
    """
    from torlab.model.amount import AmountLayer

    def bad(msg: str, k: str = "") -> TorlabInputError:
        return TorlabInputError(msg, path=path or None, key=f"retention.{k}" if k else "retention")

    if not isinstance(d, dict):
        raise bad("expected the retention: section of 'torlab fit removal' output")
    if d.get("format") != RETENTION_FORMAT:
        raise bad(f"format {d.get('format')!r} is not the one this torlab reads "
                  f"({RETENTION_FORMAT})", "format")
    law = d.get("law")
    if law not in LAWS:
        raise bad(f"unknown removal law {law!r}; use one of {', '.join(LAWS)}", "law")
    order = 0 if str(law).startswith("zero") else 1
    fs = d.get("fit_space")
    if not isinstance(fs, dict) or not isinstance(fs.get("names"), list):
        raise bad("missing fit_space (names, values, covariance, layer_sensitivity)",
                  "fit_space")
    names, theta, cov = _fit_space(fs, law, order, path, bad)
    k = len(names)
    layer = AmountLayer.from_dict(d.get("layer"), path=path or None, key="retention.layer")
    n_nodes = layer.nodes.size
    G = fs.get("layer_sensitivity", [])
    if G:
        g = _matrix(G, (k, 4 * n_nodes), "retention.fit_space.layer_sensitivity", path)
        if theta[0] == -math.inf and np.any(g[0] != 0):
            raise bad(f"a removal rate of zero ({names[0]}: 0) does not follow the layer: its "
                      "row must be zero", "fit_space.layer_sensitivity")
        _matrix([fs.get("layer_nodes_mg_m2")], (1, n_nodes),
                "retention.fit_space.layer_nodes_mg_m2", path)
    pars = d.get("parameters") if isinstance(d.get("parameters"), dict) else {}
    fixed = {}
    for nm in ("spread", "transfer"):
        if nm not in names and nm in pars:
            try:
                fixed[nm] = float(pars[nm])
            except (TypeError, ValueError):
                raise bad(f"{nm} must be a number", f"parameters.{nm}") from None
    if not (0 <= fixed.get("spread", 0.0) and 0 < fixed.get("transfer", 1.0) <= 1):
        raise bad("spread must be >= 0 and transfer in (0, 1]", "parameters")
    dens = d.get("density_kg_m3")
    if dens is not None and (isinstance(dens, bool) or not isinstance(dens, (int, float))
                             or not (math.isfinite(dens) and dens > 0)):
        raise bad("must be a positive number (kg/m^3) or null", "density_kg_m3")
    vals = np.exp(theta)
    _check_readable_copies(d, names, vals, bad)
    D = np.diag(vals)
    dof = d.get("dof", 10)
    res = RemovalFit.from_covariance(
        "removal", tuple(names), vals, D @ cov @ D,
        dof=int(dof) if isinstance(dof, int) and dof > 0 else 10, residual_norm=0.0,
        n_points=0, warnings=[], data=None, fixed=fixed, residual_unit="-",
        meta={"law": law, "order": order, "fit_space": fs, "source": Path(path).name if path
              else "retention parameters"}, parameter_file=d)
    ci = d.get("ci95") if isinstance(d.get("ci95"), dict) else {}
    for nm in names:
        iv = ci.get(nm)
        if isinstance(iv, list) and len(iv) == 2 and all(isinstance(x, (int, float))
                                                           for x in iv):
            res.ci95[nm] = (float(iv[0]), float(iv[1]))
    return RetentionParams(layer=layer, removal=res, density=None if dens is None else float(dens),
                           source=path)


def _check_readable_copies(d: dict, names: list[str], vals: np.ndarray,
                           bad: Callable[[str, str], TorlabInputError]) -> None:
    """The file's readable ``units``, ``parameters`` and ``ci95`` agree with ``fit_space``.

    The fit's numbers are read from ``fit_space`` (the log-parameters and their
    covariance); ``parameters``, ``units`` and ``ci95`` repeat them for people.  An edit
    to one of those copies would otherwise be ignored silently, so a copy that
    disagrees -- another unit, another value, an interval that leaves out the value --
    is an error naming the key.
    """
    units = d.get("units")
    if units is not None:
        if not isinstance(units, dict):
            raise bad("must be a map of parameter: unit", "units")
        for nm, u in units.items():
            want = LAW_UNITS.get(str(nm))
            if want is None:
                raise bad(f"unknown parameter {nm!r}; the laws have "
                          f"{', '.join(LAW_UNITS)}", f"units.{nm}")
            if str(u).replace(" ", "").replace("**", "^") != want:
                raise bad(f"{nm} is read in {want} (the unit 'torlab fit removal' writes), "
                          f"not {u!r}: refit instead of converting by hand", f"units.{nm}")
    pars = d.get("parameters")
    if pars is not None and not isinstance(pars, dict):
        raise bad("must be a map of parameter: value", "parameters")
    ci = d.get("ci95") if isinstance(d.get("ci95"), dict) else {}
    for nm, v in zip(names, vals, strict=True):
        if pars and nm in pars:
            p = pars[nm]
            if isinstance(p, bool) or not isinstance(p, (int, float)) or not math.isfinite(p):
                raise bad("must be a number", f"parameters.{nm}")
            if not math.isclose(p, v, rel_tol=1e-6):
                raise bad(f"{p:.6g} disagrees with fit_space.values ({v:.6g}), which the "
                          f"fit's numbers are read from: refit instead of editing",
                          f"parameters.{nm}")
        iv = ci.get(nm)
        if iv is not None and not (isinstance(iv, list) and len(iv) == 2
                                   and all(isinstance(x, (int, float))
                                           and not isinstance(x, bool) and math.isfinite(x)
                                           for x in iv)
                                   and iv[0] <= v * (1 + 1e-9) and v <= iv[1] * (1 + 1e-9)):
            raise bad(f"must be [low, high] around the value {v:.6g}", f"ci95.{nm}")


def is_retention_file(path: str | Path) -> bool:
    """Whether a YAML file is a removal fit's parameter file (a top-level ``retention:``)."""
    from torlab.yamlio import load_yaml

    d = load_yaml(path).data
    return isinstance(d, dict) and "retention" in d


def load_retention(path: str | Path) -> RetentionParams:
    """Read a removal fit's parameter file (``torlab fit removal`` -> ``params.yaml``).

    Raises
    ------
    TorlabInputError
        Not such a file, or a malformed ``retention:`` section (file and key named).
    """
    from torlab.yamlio import load_yaml

    doc = load_yaml(path)
    d = doc.data
    if not isinstance(d, dict) or "retention" not in d:
        raise TorlabInputError("not a removal parameter file (no retention: section; write one "
                               "with 'torlab fit removal')", path=str(path))
    try:
        return retention_from_dict(d["retention"], path=str(path))
    except TorlabInputError as e:
        if e.key and e.line is None:
            kp = tuple(int(x) if x.isdigit() else x for x in
                       e.key.replace("[", ".").replace("]", "").split("."))
            raise TorlabInputError(e.message, path=str(path), line=doc.lines.line(kp),
                                   key=e.key) from None
        raise
