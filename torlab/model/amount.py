"""Amount of product as a model input: a third-body layer whose parameters depend on it.

Paper C measures the layer on the HPT rig at several applied amounts (thesis
5.3.3): one fit of the layer law's parameters (Voce: ``mu_c1, mu_c2, L_mue, L_mup``,
Eqs. 5.24, 5.26-5.29; the law is :attr:`AmountLayer.law`) per amount, plus a dry run.  :class:`AmountLayer` turns that series into a layer
``p(m)`` of the remaining *areal density* ``m`` of product (kg/m^2 inside,
mg/m^2 at the edges):

* the amount applied on the rig becomes an areal density over the rig's
  contact, ``m_i = mass_i / S`` with the annulus area ``S = pi (r2^2 - r1^2)``
  (Eq. 5.1's area; a volume is turned into a mass with the product density);
* each parameter is interpolated in ``x = ln m`` by a monotone piecewise cubic
  (Fritsch-Carlson / PCHIP, ``scipy.interpolate.PchipInterpolator``): where
  the fitted values rise or fall monotonically with the amount, so does the
  layer, and no overshoot appears between the amounts.  The coefficients
  (``mu_c1``, ``mu_c2`` ...) are interpolated as they are, the lengths (``L_mue``,
  ``L_mup``) in their logarithm (they stay positive);
* the dry fit is the limit ``m -> 0``.  On a log axis that limit sits at minus
  infinity, so the dry parameters are placed at an *anchor* ``m_dry`` below the
  smallest tested amount (default one decade below, ``dry_amount=``) and held
  below it.  Where the friction changes between the dry anchor and the
  smallest tested amount the data do not say; predictions report when they
  depend on this stretch;
* above the largest tested amount the layer is not known: asking for it is an
  error (``above="error"``, the default) or holds the last fit with a warning
  (``above="hold"``); it is never extrapolated silently.

Uncertainty is carried by parameter draws: each amount's fit gives a normal
distribution of its parameters (its estimate and covariance from the
standard errors and correlations of its :class:`~torlab.fit.result.FitResult`);
a draw takes one sample per amount (the fits are independent) and interpolates
it like the estimate (:meth:`AmountLayer.draw_params`).

Amounts at the edges (:func:`parse_amount`, :func:`areal_density`) are
quantities with a unit: a volume (``"4 uL"``, needs a density), a mass
(``"4 mg"``) or an areal density (``"200 mg/m^2"``).  A bare number is refused:
it could be any of the three.

References
----------
.. [1] Kvarda, D., Galas, R., Omasta, M., Dzimko, M., Krupka, I., Hartl, M. (2022). Shear
   properties of top-of-rail products in numerical modelling. Proceedings of the
   Institution of Mechanical Engineers, Part F: Journal of Rail and Rapid Transit.
   https://doi.org/10.1177/09544097221138374
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.model.layers import LayerLaw, LayerParams, get_law

__all__ = [
    "HPT_AREA",
    "LAYER_NAMES",
    "MG_M2",
    "AboveTestedError",
    "AmountLayer",
    "areal_density",
    "parse_amount",
]

#: kg/m^2 per mg/m^2
MG_M2 = 1e-6
#: the HPT annulus of thesis 5.1.3 (r1 = 3 mm, r2 = 6 mm): S = pi (r2^2 - r1^2), m^2
HPT_AREA = math.pi * (6e-3**2 - 3e-3**2)
#: the parameters of the default (Voce) law's amount series
LAYER_NAMES = get_law().fit_names
#: default anchor of the dry fit: this factor below the smallest tested amount
DRY_ANCHOR_FACTOR = 10.0

_KINDS = ("mass_per_area", "mass", "volume")
#: amount kind -> its entry of torlab.units.RANGES
_RANGE = {"mass_per_area": "amount_areal", "mass": "amount_mass", "volume": "amount_volume"}


def parse_amount(value: Any, *, where: str = "amount") -> tuple[float, str]:
    """An amount with its unit -> ``(SI value, kind)``.

    ``kind`` is ``"volume"`` [m^3], ``"mass"`` [kg] or ``"mass_per_area"``
    [kg/m^2].

    Raises
    ------
    TorlabInputError
        No unit (a bare number could be a volume, a mass or an areal density),
        an unknown unit or one of another kind, a negative or non-finite amount,
        an amount outside :data:`torlab.units.RANGES` (``amount_volume``,
        ``amount_mass``, ``amount_areal``; an unusual one warns).
    """
    from torlab.units import parse_unit_factor

    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise TorlabInputError(f"expected an amount such as '4 uL', '4 mg' or '200 mg/m^2', got "
                               f"{value!r}", key=where)
    text = str(value).strip()
    import re

    m = re.match(r"^\s*([+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?|[+-]?inf|nan)\s*(.*?)\s*$",
                 text, re.IGNORECASE)
    if not m:
        raise TorlabInputError(f"{text!r} is not an amount (write e.g. '4 uL', '4 mg' or "
                               "'200 mg/m^2')", key=where)
    num, unit = float(m.group(1)), m.group(2)
    if not unit:
        raise TorlabInputError(f"amount {text!r} has no unit: write '{text} uL', '{text} mg' or "
                               f"'{text} mg/m^2'", key=where)
    if not math.isfinite(num):
        raise TorlabInputError(f"amount {text!r} is not a finite number", key=where)
    if num < 0:
        raise TorlabInputError(f"amount {text!r} is negative", key=where)
    for kind in _KINDS:
        try:
            scale, _ = parse_unit_factor(unit, kind, where=where)
        except TorlabInputError:
            continue
        if num > 0:  # zero is the dry run; a positive amount must be a plausible one
            from torlab.units import check_range

            check_range(_RANGE[kind], num * scale, where=where)
        return num * scale, kind
    raise TorlabInputError(f"unit {unit!r} of amount {text!r} is not a volume (uL), a mass (mg) "
                           "or a mass per area (mg/m^2)", key=where)


def areal_density(amount: Any, *, area: float | None = None, density: float | None = None,
                  transfer: float = 1.0, where: str = "amount") -> float:
    """Areal density [kg/m^2] of an amount spread over ``area``.

    ``m = transfer * mass / area`` with ``mass = volume * density`` for a
    volume; an amount already given per area is multiplied by ``transfer``
    only.

    Parameters
    ----------
    amount
        A quantity string (``"4 uL"``, ``"4 mg"``, ``"200 mg/m^2"``) or a
        ``(value, kind)`` pair from :func:`parse_amount`.
    area
        Area the mass is spread over [m^2]: the running band of a disc
        (``2 pi r_track * width``), the rig's contact, a length of rail times
        the band width.
    density
        Product density [kg/m^3], for a volume.
    transfer
        Fraction of the applied product that reaches the band, in (0, 1].

    Raises
    ------
    TorlabInputError
        Units missing, negative amount, volume without density, mass without area.
    """
    if isinstance(amount, tuple):
        val, kind = float(amount[0]), str(amount[1])
        if not (math.isfinite(val) and val >= 0):
            raise TorlabInputError(f"amount must be a non-negative number, got {val:g}", key=where)
    else:
        val, kind = parse_amount(amount, where=where)
    if not (0 < transfer <= 1):
        raise TorlabInputError(f"transfer fraction must be in (0, 1], got {transfer:g}",
                               key="transfer")
    if kind == "mass_per_area":
        return transfer * val
    if kind == "volume":
        if density is None:
            raise TorlabInputError("a volume needs the product density to become a mass (give "
                                   "density, e.g. 930 kg/m^3)", key=where)
        if not (math.isfinite(density) and density > 0):
            raise TorlabInputError(f"density must be positive, got {density:g}", key="density")
        val = val * density
    if area is None or not (math.isfinite(area) and area > 0):
        raise TorlabInputError("a mass needs the area it is spread over (band or rig contact "
                               "area) to become an areal density", key=where)
    return transfer * val / area


def _law_of_fit(fit: Any) -> LayerLaw:
    """The layer law of a fit (its provenance's ``law``; default Voce)."""
    try:
        return get_law((getattr(fit, "meta", {}) or {}).get("law"))
    except KeyError as e:
        raise TorlabInputError(f"fit {_label(fit)}: {e.args[0]}") from None


def _fit_cov(fit: Any, law: LayerLaw | None = None) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Parameters and covariance of a layer FitResult; undetermined ones get variance 0."""
    notes: list[str] = []
    law = law or _law_of_fit(fit)
    names_l = law.fit_names
    k = len(names_l)
    names = list(getattr(fit, "names", ()))
    allv = {**getattr(fit, "fixed", {}), **getattr(fit, "params", {})}
    missing = [n for n in names_l if n not in allv]
    if missing:
        raise TorlabInputError(f"fit {_label(fit)} lacks the layer parameter(s) "
                               f"{', '.join(missing)} of the {law.name} law (give HPT layer fits "
                               "of one law: torlab.fit.layer)")
    p = np.array([float(allv[n]) for n in names_l])
    cov = np.zeros((k, k))
    se = np.array([float(fit.stderr.get(n, 0.0)) if n in names else 0.0 for n in names_l])
    bad = ~np.isfinite(se)
    if bad.any():
        notes.append(f"{_label(fit)}: {', '.join(n for n, b in zip(names_l, bad, strict=True) if b)}"
                     " not determined by its fit; carried without uncertainty")
        se = np.where(bad, 0.0, se)
    corr = np.eye(k)
    if names:
        idx = [names.index(n) if n in names else -1 for n in names_l]
        c = np.asarray(fit.correlation, dtype=float)
        for i, a in enumerate(idx):
            for j, b in enumerate(idx):
                if a >= 0 and b >= 0 and i != j and np.isfinite(c[a, b]):
                    corr[i, j] = c[a, b]
    cov = corr * np.outer(se, se)
    return p, cov, notes


def _label(fit: Any) -> str:
    meta = getattr(fit, "meta", {}) or {}
    return str(meta.get("source") or meta.get("product") or "layer fit")


def _fit_amount(fit: Any, *, area: float, density: float | None) -> float:
    """Areal density on the rig of a per-amount HPT fit (from its provenance)."""
    meta = getattr(fit, "meta", {}) or {}
    val, unit = meta.get("applied_amount"), meta.get("applied_amount_unit")
    if val is None:
        raise TorlabInputError(f"fit {_label(fit)} has no applied amount in its provenance; give "
                               "the amounts explicitly (amounts=...)")
    if not unit:
        raise TorlabInputError(f"fit {_label(fit)}: applied amount {val} has no unit; give the "
                               "amounts explicitly (amounts=...)")
    dens = density if density is not None else meta.get("product_density")
    return areal_density(f"{val} {unit}", area=area, density=dens, where=f"{_label(fit)} amount")


class AboveTestedError(TorlabInputError):
    """An amount above the largest tested amount of the HPT series, where the layer is not
    known.

    The message ends with how to go on: test a larger amount, or hold the last fit.  The
    way to hold it is ``hint``: ``above='hold'`` in Python (the default); a command says
    its own option instead (:meth:`with_hint`, ``--hold-above``).
    """

    def __init__(self, what: str, *, hint: str = "above='hold'", **where: Any) -> None:
        self.what, self.hint = what, hint
        super().__init__(f"{what} (test a larger amount, or hold the last fit with {hint})",
                         **where)

    def with_hint(self, hint: str, *, key: str | None = None,
                  prefix: str = "", suffix: str = "") -> AboveTestedError:
        """The same error with another way to hold the fit (a command-line option), key or
        context (``prefix``/``suffix`` around what is above the range)."""
        return AboveTestedError(f"{prefix}{self.what}{suffix}", hint=hint, path=self.path,
                                line=self.line, key=self.key if key is None else key)


@dataclass
class AmountLayer:
    """Layer parameters against the remaining areal density ``m`` (module docstring).

    Attributes
    ----------
    amounts
        Tested areal densities [kg/m^2], increasing, at least two.
    params
        ``(n, k)`` fitted parameters of :attr:`law` (its ``fit_names``; Voce: ``mu_c1,
        mu_c2, L_mue, L_mup``, SI) at :attr:`amounts`.
    covs
        ``(n, k, k)`` their covariances.
    dry_params, dry_cov
        The dry fit (the ``m -> 0`` limit) and its covariance.
    dry_amount
        Anchor of the dry fit [kg/m^2], below ``amounts[0]``.
    above
        ``"error"`` or ``"hold"`` above the largest tested amount.
    temperature_coefficients
        The law's temperature coefficients (Voce: ``(mu_c1_T, mu_c2_T)``, 1/K) given to
        every layer (the HPT amount series is at one temperature; default 0).
    sources
        Label of each amount's fit.
    notes
        What the construction assumed or dropped (undetermined parameters ...).
    law
        The layer law of every fit (:mod:`torlab.model.layers`; default Voce).
    """

    amounts: np.ndarray
    params: np.ndarray
    covs: np.ndarray
    dry_params: np.ndarray
    dry_cov: np.ndarray
    dry_amount: float
    above: str = "error"
    temperature_coefficients: tuple[float, ...] = (0.0, 0.0)
    sources: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    law: LayerLaw = field(default_factory=get_law)

    @property
    def names(self) -> tuple[str, ...]:
        """The interpolated parameters (the law's ``fit_names``), in column order."""
        return self.law.fit_names

    @property
    def _log(self) -> np.ndarray:
        """Which parameters are interpolated in their logarithm: the lengths."""
        return np.array([self.law.param(n).kind == "length" for n in self.names])

    @property
    def _positive(self) -> np.ndarray:
        return np.array([self.law.param(n).positive for n in self.names])

    def layer_of(self, p: Any) -> LayerParams:
        """The :class:`~torlab.model.layers.LayerParams` of one row of parameters."""
        return LayerParams(law=self.law, **{n: float(v) for n, v in zip(self.names, p,
                                                                         strict=True)},
                           **dict(zip(self.law.temperature_names,
                                      (float(v) for v in self.temperature_coefficients),
                                      strict=True)))

    def __post_init__(self) -> None:
        self.law = get_law(self.law)
        if len(self.temperature_coefficients) != len(self.law.temperature_names):
            raise TorlabInputError(f"the {self.law.name} layer law has "
                                   f"{len(self.law.temperature_names)} temperature coefficients "
                                   f"({', '.join(self.law.temperature_names)}), got "
                                   f"{len(self.temperature_coefficients)}")
        a = np.asarray(self.amounts, dtype=float)
        if a.ndim != 1 or a.size < 2:
            raise TorlabInputError(f"an amount series needs at least two different amounts, got "
                                   f"{a.size}: with one amount the dependency on the amount is "
                                   "not measured")
        if not np.all(np.isfinite(a)):
            raise TorlabInputError("amounts must be finite numbers")
        if np.any(a < 0):
            raise TorlabInputError(f"negative amount in the series ({np.min(a) / MG_M2:g} mg/m^2)")
        if np.any(a <= 0):
            raise TorlabInputError("an amount of zero is the dry fit: give it as dry=, not in the "
                                   "amount series")
        order = np.argsort(a)
        a = a[order]
        if np.any(np.diff(a) <= 0):
            dup = a[np.flatnonzero(np.diff(a) <= 0)[0]]
            raise TorlabInputError(f"two fits at the same amount ({dup / MG_M2:.6g} mg/m^2): fit "
                                   "repeats of one amount jointly (fit_layer_hpt(..., joint=True))")
        self.amounts = a
        self.params = np.asarray(self.params, dtype=float)[order]
        self.covs = np.asarray(self.covs, dtype=float)[order]
        if self.sources:
            self.sources = [self.sources[i] for i in order]
        self.dry_params = np.asarray(self.dry_params, dtype=float)
        self.dry_cov = np.asarray(self.dry_cov, dtype=float)
        if not (math.isfinite(self.dry_amount) and 0 < self.dry_amount < a[0]):
            raise TorlabInputError(f"the dry anchor ({self.dry_amount / MG_M2:g} mg/m^2) must lie "
                                   f"between 0 and the smallest tested amount "
                                   f"({a[0] / MG_M2:g} mg/m^2)", key="dry_amount")
        if self.above not in ("error", "hold"):
            raise TorlabInputError(f"above must be 'error' or 'hold', got {self.above!r}",
                                   key="above")
        allp = np.vstack([self.dry_params, self.params])
        log, pos = self._log, self._positive
        if not np.all(np.isfinite(allp)) or np.any(allp[:, log] <= 0) or \
                np.any(allp[:, pos & ~log] < 0):
            raise TorlabInputError("layer parameters must be finite, mu >= 0 and lengths > 0")
        self._nodes_x = np.log(np.r_[self.dry_amount, a])
        self._interp = self._make(allp)

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_fits(cls, fits: Sequence[Any], dry: Any, *, area: float = HPT_AREA,
                  density: float | None = None, amounts: Sequence[Any] | None = None,
                  dry_amount: Any = None, above: str = "error",
                  temperature_coefficients: tuple[float, ...] | None = None,
                  temperature_tolerance: float = 5.0, repeatability: float = 0.0
                  ) -> AmountLayer:
        """The layer of a product from its per-amount HPT fits and the dry fit.

        Parameters
        ----------
        fits
            :class:`~torlab.fit.result.FitResult` of ``fit_layer_hpt``, one per
            applied amount (repeats of an amount fitted jointly).
        dry
            The dry fit (no product), the ``m -> 0`` limit.
        area
            Rig contact area the applied amount is spread over [m^2]; default the
            HPT annulus of thesis 5.1.3 (84.8 mm^2).
        density
            Product density [kg/m^3] for amounts applied as volumes; default the
            ``product_density`` in a fit's provenance.
        amounts
            The amounts instead of the fits' provenance: quantity strings
            (``"4 uL"``, ``"3.7 mg"``, ``"44000 mg/m^2"``), one per fit.
        dry_amount
            Anchor of the dry fit (areal density, e.g. ``"1000 mg/m^2"``); default
            a tenth of the smallest tested amount.
        above
            ``"error"`` (default) or ``"hold"`` beyond the largest tested amount.
        temperature_coefficients
            The law's temperature coefficients for every layer (1/K; Voce:
            ``(mu_c1_T, mu_c2_T)``); default zero.
        temperature_tolerance
            Largest spread [K] of the fits' test temperatures.
        repeatability
            Relative run-to-run scatter of the layer parameters between repeated
            HPT runs (e.g. 0.03), added in quadrature to every fit's own standard
            errors.  A single run's fit errors do not contain it; give it where
            repeats have shown it (default 0: the fits' errors alone).

        Raises
        ------
        TorlabInputError
            Fewer than two amounts, a repeated or negative amount, a missing
            unit or density, fits at different temperatures, no dry fit.
        """
        fits = list(fits)
        if dry is None:
            raise TorlabInputError("give the dry HPT fit (dry=): it is the layer's limit when the "
                                   "product is gone")
        if len(fits) < 2:
            raise TorlabInputError(f"an amount series needs at least two different amounts, got "
                                   f"{len(fits)}: with one amount the dependency on the amount is "
                                   "not measured")
        if amounts is not None and len(amounts) != len(fits):
            raise TorlabInputError(f"{len(amounts)} amounts given for {len(fits)} fits",
                                   key="amounts")
        law = _law_of_fit(dry)
        other = sorted({_law_of_fit(f).name for f in fits} - {law.name})
        if other:
            raise TorlabInputError(f"the amount series mixes layer laws ({law.name} for the dry "
                                   f"fit, {', '.join(other)} for others): fit every amount with "
                                   "one law")
        ms, ps, cs, notes, src = [], [], [], [], []
        temps = []
        for i, f in enumerate(fits):
            if amounts is not None:
                ms.append(areal_density(amounts[i], area=area, density=density,
                                        where=f"amounts[{i}]"))
            else:
                ms.append(_fit_amount(f, area=area, density=density))
            p, c, nt = _fit_cov(f, law)
            ps.append(p)
            cs.append(c)
            notes += nt
            src.append(_label(f))
            t = (getattr(f, "meta", {}) or {}).get("temperature_C")
            if isinstance(t, (int, float)) and math.isfinite(t):
                temps.append(float(t))
        if temps and max(temps) - min(temps) > temperature_tolerance:
            raise TorlabInputError(f"the amount series mixes test temperatures "
                                   f"({min(temps):g}-{max(temps):g} degC): give the fits of one "
                                   "temperature")
        pd_, cd, nt = _fit_cov(dry, law)
        notes += nt
        if not (math.isfinite(repeatability) and repeatability >= 0):
            raise TorlabInputError(f"repeatability must be a non-negative fraction, got "
                                   f"{repeatability}", key="repeatability")
        if repeatability > 0:
            cs = [c + np.diag((repeatability * p) ** 2) for c, p in zip(cs, ps, strict=True)]
            cd = cd + np.diag((repeatability * pd_) ** 2)
            notes.append(f"run-to-run scatter {100 * repeatability:g} % added to every fit's "
                         "standard errors")
        m_arr = np.array(ms)
        if np.any(m_arr <= 0):
            raise TorlabInputError("an applied amount of zero is the dry fit: give it as dry=, not "
                                   "in the amount series")
        if dry_amount is None:
            anchor = float(np.min(m_arr)) / DRY_ANCHOR_FACTOR
            notes.append(f"dry fit anchored at {anchor / MG_M2:.4g} mg/m^2, a tenth of the smallest "
                         "tested amount (an assumption: the data do not show where the friction "
                         "returns to dry below the smallest amount)")
        else:
            anchor = areal_density(dry_amount, where="dry_amount")
        tc = (tuple(temperature_coefficients) if temperature_coefficients is not None
              else (0.0,) * len(law.temperature_names))
        return cls(amounts=m_arr, params=np.array(ps), covs=np.array(cs), dry_params=pd_,
                   dry_cov=cd, dry_amount=anchor, above=above,
                   temperature_coefficients=tc, sources=src, notes=notes, law=law)

    # -- interpolation ------------------------------------------------------------------------
    def _make(self, allp: np.ndarray) -> Any:
        """PCHIP in ln m of node values ``allp`` (..., n_nodes, k); lengths in their log."""
        from scipy.interpolate import PchipInterpolator

        log = self._log
        with np.errstate(divide="ignore", invalid="ignore"):
            y = np.where(log, np.log(np.maximum(allp, 1e-300)), allp)
        return PchipInterpolator(self._nodes_x, np.moveaxis(y, -2, 0), axis=0, extrapolate=False)

    @property
    def m_min(self) -> float:
        """Smallest tested amount [kg/m^2]."""
        return float(self.amounts[0])

    @property
    def m_max(self) -> float:
        """Largest tested amount [kg/m^2]."""
        return float(self.amounts[-1])

    @property
    def nodes(self) -> np.ndarray:
        """The interpolation nodes: dry anchor, then the tested amounts [kg/m^2]."""
        return np.exp(self._nodes_x)

    def check(self, m: Any, *, where: str = "amount") -> None:
        """Raise for negative amounts, and above the tested range when ``above='error'``."""
        m = np.asarray(m, dtype=float)
        if not np.all(np.isfinite(m)):
            raise TorlabInputError("amount must be finite", key=where)
        if np.any(m < 0):
            raise TorlabInputError(f"negative amount ({np.min(m) / MG_M2:g} mg/m^2)", key=where)
        if self.above == "error" and np.any(m > self.m_max * (1 + 1e-12)):
            raise AboveTestedError(
                f"amount {np.max(m) / MG_M2:.4g} mg/m^2 is above the largest tested amount "
                f"{self.m_max / MG_M2:.4g} mg/m^2 of the HPT series: the layer is not known there",
                key=where)

    def _eval(self, interp: Any, m: np.ndarray, dry: np.ndarray, top: np.ndarray) -> np.ndarray:
        m = np.asarray(m, dtype=float)
        x = np.log(np.clip(m, self.dry_amount, self.m_max))
        y = interp(x)  # (..m.shape, [draws,] k)
        y = np.where(self._log, np.exp(y), y)
        lo = (m <= self.dry_amount).reshape(m.shape + (1,) * (y.ndim - m.ndim))
        hi = (m >= self.m_max).reshape(lo.shape)
        return np.where(lo, dry, np.where(hi, top, y))

    def params_at(self, m: Any) -> np.ndarray:
        """The law's parameters (:attr:`names`, SI) at areal densities ``m`` -> shape
        ``m.shape + (k,)``."""
        self.check(m)
        return self._eval(self._interp, np.asarray(m, dtype=float), self.dry_params,
                          self.params[-1])

    def layer(self, m: float) -> LayerParams:
        """The :class:`~torlab.model.layers.LayerParams` at one areal density ``m`` [kg/m^2]."""
        return self.layer_of(self.params_at(float(m)))

    def draw_nodes(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``(n, n_nodes, k)`` draws of the node parameters (dry first), each node independent.

        Each fit's draw is normal with its estimate and covariance; draws of a
        limit or a length that fall to or below zero are reflected to a tiny
        positive value (a rare event with sensible fits).
        """
        allp = np.vstack([self.dry_params, self.params])
        covs = np.concatenate([self.dry_cov[None], self.covs])
        k = allp.shape[1]
        out = np.empty((n, allp.shape[0], k))
        for j in range(allp.shape[0]):
            c = covs[j]
            w, v = np.linalg.eigh(0.5 * (c + c.T))
            L = v * np.sqrt(np.clip(w, 0.0, None))
            out[:, j, :] = allp[j] + rng.standard_normal((n, k)) @ L.T
        floor = 1e-6 * np.abs(allp)[None]
        return np.where((out <= floor) & self._positive, np.maximum(floor, 1e-12), out)

    def draw_params(self, m: Any, node_draws: np.ndarray) -> np.ndarray:
        """Parameters at ``m`` of every draw of :meth:`draw_nodes` -> ``m.shape + (n, k)``."""
        self.check(m)
        interp = self._make(node_draws)  # y: (n_nodes, n, k)
        m = np.asarray(m, dtype=float)
        return self._eval(interp, m, node_draws[:, 0, :], node_draws[:, -1, :])

    def table(self) -> Any:
        """DataFrame of the nodes: ``amount_mg_m2``, the parameters and their standard errors."""
        import pandas as pd

        allp = np.vstack([self.dry_params, self.params])
        covs = np.concatenate([self.dry_cov[None], self.covs])
        rows = []
        for j, m in enumerate(self.nodes):
            r = {"node": "dry (anchor)" if j == 0 else "tested", "amount_mg_m2": m / MG_M2,
                 "source": "dry fit" if j == 0 else (self.sources[j - 1] if self.sources else "")}
            for i, nm in enumerate(self.names):
                r[nm] = allp[j, i]
                r[f"{nm}_se"] = math.sqrt(max(covs[j, i, i], 0.0))
            rows.append(r)
        return pd.DataFrame(rows)

    def to_dict(self) -> dict[str, Any]:
        """The layer as plain data (the ``layer:`` of a retention parameter file).

        Areal densities in mg/m^2, parameters in SI, each node's k x k
        covariance in the order of ``parameters`` (the law's; ``law:`` is written
        for a law other than the default); :meth:`from_dict` reads it back exactly
        (YAML keeps every float's digits).
        """
        allp = np.vstack([self.dry_params, self.params])
        covs = np.concatenate([self.dry_cov[None], self.covs])
        nodes = []
        for j, m in enumerate(np.r_[self.dry_amount, self.amounts]):
            nodes.append({"amount_mg_m2": float(m) / MG_M2,
                          "source": "dry fit" if j == 0 else (self.sources[j - 1]
                                                              if self.sources else ""),
                          **{nm: float(allp[j, i]) for i, nm in enumerate(self.names)},
                          "covariance": [[float(v) for v in row] for row in covs[j]]})
        law = {} if self.law is get_law() else {"law": self.law.name}
        return {**law, "parameters": list(self.names), "dry_anchor": "first node",
                "above": self.above,
                "temperature_coefficients": [float(v) for v in self.temperature_coefficients],
                "nodes": nodes, "notes": list(self.notes)}

    @classmethod
    def from_dict(cls, d: Any, *, path: Any = None, key: str = "layer") -> AmountLayer:
        """The layer of :meth:`to_dict` (read from a file: every value checked).

        Raises
        ------
        TorlabInputError
            A missing or malformed key, a node without its four parameters or a
            covariance that is not a finite symmetric 4 x 4 matrix, fewer than
            three nodes (the dry anchor and two tested amounts), too many nodes.
        """
        def bad(msg: str, k: str = "") -> TorlabInputError:
            return TorlabInputError(msg, path=path, key=f"{key}.{k}" if k else key)

        if not isinstance(d, dict) or not isinstance(d.get("nodes"), list):
            raise bad("expected a mapping with nodes: (the amount layer of 'torlab fit "
                      "removal')")
        try:
            law = get_law(d.get("law"))
        except (KeyError, TypeError):
            raise bad(f"{d.get('law')!r} is not a layer law", "law") from None
        names = law.fit_names
        k_ = len(names)
        nodes = d["nodes"]
        if not 3 <= len(nodes) <= 200:
            raise bad(f"needs the dry anchor and at least two tested amounts (3-200 nodes), got "
                      f"{len(nodes)}", "nodes")
        vals, covs, amts, src = [], [], [], []
        for j, n in enumerate(nodes):
            k = f"nodes[{j}]"
            if not isinstance(n, dict):
                raise bad("expected a mapping", k)
            try:
                amts.append(float(n["amount_mg_m2"]) * MG_M2)
                vals.append([float(n[nm]) for nm in names])
                c = np.asarray(n["covariance"], dtype=float)
            except KeyError as e:
                raise bad(f"missing {e.args[0]}", k) from None
            except (TypeError, ValueError):
                raise bad(f"amount_mg_m2, the {k_} parameters and covariance must be numbers",
                          k) from None
            if c.shape != (k_, k_) or not np.all(np.isfinite(c)) or not np.allclose(c, c.T) or \
                    np.any(np.diag(c) < 0):
                raise bad(f"covariance must be a finite symmetric {k_} x {k_} matrix with a "
                          "non-negative diagonal", f"{k}.covariance")
            covs.append(c)
            src.append(str(n.get("source", "")))
        nt = len(law.temperature_names)
        words = {1: "one number", 2: "two numbers"}.get(nt, f"{nt} numbers")
        tc = d.get("temperature_coefficients", [0.0] * nt)
        try:
            tcs = tuple(float(v) for v in tc)
        except (TypeError, ValueError):
            raise bad(f"expected {words}", "temperature_coefficients") from None
        if len(tcs) != nt or not all(math.isfinite(v) for v in tcs):
            raise bad(f"expected {words.replace('number', 'finite number')} (1/K)",
                      "temperature_coefficients")
        notes = d.get("notes", [])
        try:
            return cls(amounts=np.array(amts[1:]), params=np.array(vals[1:]),
                       covs=np.array(covs[1:]), dry_params=np.array(vals[0]), dry_cov=covs[0],
                       dry_amount=amts[0], above=str(d.get("above", "error")),
                       temperature_coefficients=tcs, sources=src[1:],
                       notes=[str(v) for v in notes] if isinstance(notes, list) else [], law=law)
        except TorlabInputError as e:
            raise bad(e.message, e.key or "") from None

    def summary(self) -> dict[str, Any]:
        """Key numbers for ``summary.json``."""
        return {"amounts_mg_m2": [float(v) / MG_M2 for v in self.amounts],
                "dry_anchor_mg_m2": self.dry_amount / MG_M2, "above": self.above,
                "interpolation": (f"PCHIP in ln m ({', '.join(n for n, g in zip(self.names, self._log, strict=True) if not g)} linear, "
                                  f"{', '.join(n for n, g in zip(self.names, self._log, strict=True) if g)} in log)"),
                "notes": list(self.notes)}
