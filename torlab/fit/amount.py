"""A product's amount dependency from its files: HPT logs or fitted parameter files -> layer.

Paper C measures the third-body layer on the HPT rig at several applied
amounts (thesis 5.3.3).  :func:`amount_layer` turns what a user has of such a
campaign into the :class:`~torlab.model.amount.AmountLayer` the retention
model needs:

* HPT curves (a raw log reduced by :func:`torlab.instruments.measured.layer_inputs`):
  each fitted alone (:func:`torlab.fit.layer.fit_layer_hpt`, Eqs. 5.24-5.29); the log
  header's ``applied_amount`` and ``product_density`` become the fit's provenance;
* parameter files of earlier HPT layer fits (``torlab fit hpt`` output,
  ``params.yaml``): the ``boundary:`` values with the standard errors of the
  ``fit:`` section (and its ``covariance:`` where written, else uncorrelated,
  said in the notes) -- the amount and density from the same provenance;
* :class:`~torlab.fit.result.FitResult` objects (a notebook).

The run without an applied amount (the dry reference, product ``dry``) is the
layer's ``m -> 0`` limit; every other run is one amount of one product.

References
----------
.. [1] Kvarda, D., Galas, R., Omasta, M., Dzimko, M., Krupka, I., Hartl, M. (2022). Shear
   properties of top-of-rail products in numerical modelling. Proceedings of the
   Institution of Mechanical Engineers, Part F: Journal of Rail and Rapid Transit.
   https://doi.org/10.1177/09544097221138374
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.model.amount import AmountLayer
from torlab.model.layers import get_law

__all__ = ["amount_layer", "layer_fit_from_params"]

YAML_SUFFIXES = (".yaml", ".yml")


def layer_fit_from_params(path: str | os.PathLike[str]) -> Any:
    """The HPT layer fit written to a parameter file (``torlab fit hpt`` -> ``params.yaml``).

    Returns
    -------
    FitResult
        ``kind="layer_hpt"``: the layer law's parameters (the file's ``boundary: law:``,
        default Voce), their covariance (the
        file's ``fit: covariance:`` block where present, else the standard
        errors uncorrelated) and the provenance (source, applied amount and
        unit, product density, temperature).

    Raises
    ------
    TorlabInputError
        Not a parameter file of an HPT layer fit, a parameter or standard error
        missing or not a number.
    """
    from torlab.fit.result import FitResult
    from torlab.yamlio import load_yaml

    doc = load_yaml(path)
    d = doc.data
    p = str(path)
    if not isinstance(d, dict) or not isinstance(d.get("fit"), dict) or \
            not isinstance(d.get("boundary"), dict):
        raise TorlabInputError("not a parameter file of an HPT layer fit (expected boundary: and "
                               "fit: from 'torlab fit hpt')", path=p)
    fit = d["fit"]
    if fit.get("kind") != "layer_hpt":
        raise TorlabInputError(f"a fit of kind {fit.get('kind')!r}, not an HPT layer fit "
                               "(layer_hpt)", path=p, line=doc.lines.line(("fit", "kind")),
                               key="fit.kind")
    b = d["boundary"]
    try:
        law = get_law(b.get("law"))
    except (KeyError, TypeError):
        raise TorlabInputError(f"{b.get('law')!r} is not a layer law", path=p,
                               line=doc.lines.line(("boundary", "law")),
                               key="boundary.law") from None
    names_l = law.fit_names
    pars = fit.get("parameters") if isinstance(fit.get("parameters"), dict) else {}
    vals, se = [], []
    for nm in names_l:
        try:
            v = float(b[nm])
            s = pars.get(nm, {}).get("stderr") if isinstance(pars.get(nm), dict) else None
            s = 0.0 if s is None else float(s)
        except KeyError:
            raise TorlabInputError(f"missing {nm}", path=p, line=doc.lines.line(("boundary",)),
                                   key=f"boundary.{nm}") from None
        except (TypeError, ValueError, AttributeError):
            raise TorlabInputError(f"{nm} and its stderr must be numbers", path=p,
                                   line=doc.lines.line(("boundary", nm)),
                                   key=f"boundary.{nm}") from None
        if not (math.isfinite(v) and math.isfinite(s) and s >= 0):
            raise TorlabInputError(f"{nm} must be finite with a non-negative stderr", path=p,
                                   line=doc.lines.line(("boundary", nm)), key=f"boundary.{nm}")
        vals.append(v)
        se.append(s)
    cov, note = _covariance(fit.get("covariance"), names_l, se)
    meta = {k: fit.get(k) for k in ("product", "condition", "applied_amount",
                                    "applied_amount_unit", "product_density", "temperature_C")}
    meta["source"] = str(fit.get("source") or Path(p).name)
    meta["parameter_file"] = Path(p).name
    if note:
        meta["notes"] = [f"{Path(p).name}: {note}"]
    if law is not get_law():
        meta["law"] = law.name
    dof = fit.get("dof", 50)
    return FitResult.from_covariance("layer_hpt", names_l, np.array(vals), cov,
                                     dof=int(dof) if isinstance(dof, int) else 50,
                                     residual_norm=float(fit.get("residual_rms") or 0.0),
                                     n_points=int(fit.get("n_points") or 0), warnings=[],
                                     data=None, meta=meta, residual_unit="Pa")


def _covariance(block: Any, names_l: Sequence[str], se: list[float]) -> tuple[Any, str]:
    """The covariance of a parameter file's layer fit: its ``fit: covariance:`` block where
    it is written (a well-formed one), else the standard errors uncorrelated, and the note
    that says so."""
    cov = np.diag(np.square(se))
    count = {2: "two", 3: "three", 4: "four"}.get(len(names_l), str(len(names_l)))
    note = f"correlations not in the file: the {count} parameters taken as uncorrelated"
    if isinstance(block, dict) and isinstance(block.get("names"), list):
        names = [str(n) for n in block["names"]]
        try:
            mat = np.asarray(block.get("matrix"), dtype=float)
        except (TypeError, ValueError):
            mat = np.zeros(0)
        if mat.shape == (len(names), len(names)) and np.all(np.isfinite(mat)):
            idx = [names.index(n) if n in names else -1 for n in names_l]
            for i, a in enumerate(idx):
                for j, c in enumerate(idx):
                    if a >= 0 and c >= 0:
                        cov[i, j] = mat[a, c]
            note = ""
    return cov, note


def _fit_of(item: Any) -> Any:
    """A layer FitResult of one input (parameter file, FitResult or HPT curve)."""
    from torlab.fit.result import FitResult

    if isinstance(item, FitResult):
        return item
    if isinstance(item, (str, os.PathLike)):
        return layer_fit_from_params(Path(item))
    from torlab.fit.layer import fit_layer_hpt

    return fit_layer_hpt([item])


def _has_amount(fit: Any) -> bool:
    return (fit.meta or {}).get("applied_amount") is not None


def amount_layer(inputs: Sequence[Any], *, density: float | None = None,
                 dry_amount: Any = None, repeatability: float = 0.0, above: str = "error",
                 temperature: float | None = None, temperature_tolerance: float = 5.0
                 ) -> tuple[AmountLayer, list[Any], Any, list[str]]:
    """The amount layer of one product from its HPT amount series and the dry run.

    Parameters
    ----------
    inputs
        HPT curves (:func:`torlab.instruments.measured.layer_inputs` makes them of raw
        logs), HPT layer parameter files (``params.yaml``) or FitResults: one per
        applied amount of one product, and one run without an applied amount (the dry
        reference).
    density
        Product density [kg/m^3] for amounts applied as volumes; default the
        runs' ``product_density``.
    dry_amount, repeatability, above
        As :meth:`~torlab.model.amount.AmountLayer.from_fits`.
    temperature, temperature_tolerance
        Use only runs at this temperature [degC]; default every run given (they
        must then be at one temperature).

    Returns
    -------
    (layer, amount fits, dry fit, notes)

    Raises
    ------
    TorlabInputError
        No dry run or several, fewer than two amounts, runs of different
        products, an amount without unit, a volume without density.
    """
    fits = [_fit_of(it) for it in inputs]
    notes = [n for f in fits for n in (f.meta or {}).get("notes", [])
             if isinstance(n, str)]
    if temperature is not None:
        keep = [f for f in fits if (f.meta or {}).get("temperature_C") is None
                or abs(float(f.meta["temperature_C"]) - temperature) <= temperature_tolerance]
        if len(keep) < len(fits):
            notes.append(f"{len(fits) - len(keep)} run(s) at other temperatures than "
                         f"{temperature:g} degC left out")
        fits = keep
    dry = [f for f in fits if not _has_amount(f)]
    series = [f for f in fits if _has_amount(f)]
    label = ", ".join(str((f.meta or {}).get("source", "?")) for f in dry)
    if not dry:
        raise TorlabInputError("the amount series has no dry run (an HPT run without an applied "
                               "amount): it is the layer's limit once the product is gone",
                               key="hpt")
    if len(dry) > 1:
        raise TorlabInputError(f"{len(dry)} runs without an applied amount ({label}): give one "
                               "dry reference", key="hpt")
    prods = sorted({str((f.meta or {}).get("product") or "") for f in series})
    if len(prods) > 1:
        raise TorlabInputError(f"the amount series mixes products ({', '.join(prods)}): give the "
                               "runs of one product", key="hpt")
    if density is None:
        dens = {float(f.meta["product_density"]) for f in series
                if isinstance((f.meta or {}).get("product_density"), (int, float))}
        if len(dens) > 1:
            raise TorlabInputError(f"the runs give different product densities "
                                   f"({', '.join(f'{v:g}' for v in sorted(dens))} kg/m^3): give "
                                   "the density", key="density")
        density = dens.pop() if dens else None
    layer = AmountLayer.from_fits(series, dry[0], density=density, dry_amount=dry_amount,
                                  above=above, repeatability=repeatability,
                                  temperature_tolerance=temperature_tolerance)
    layer.notes = notes + layer.notes
    return layer, series, dry[0], notes
