"""Creep-force tables for vehicle-dynamics codes (xarray Dataset, netCDF, long CSV).

:func:`creep_table` evaluates the creep-force model of :mod:`torlab.model.creep`
on the Cartesian product of a longitudinal-creepage axis, a lateral-creepage axis
and a spin axis [1/m], optionally times a speed axis (the contact temperature
depends on it) and an amount axis (one scene or parameter set per applied product
amount).  The result is an :class:`xarray.Dataset` with the forces in SI units
and in the normalised form of Kalker's book of tables (Kalker 1996, "Book of tables
for the Hertzian creep-force law"; CONTACT's ``usetab`` tables use it):

* creepages scaled by the linear theory and the friction force,
  ``xi* = G c^2 C11 xi/(3 mu N)``, ``eta* = G c^2 C22 eta/(3 mu N)``,
  ``phi* = G c^3 C23 phi/(mu N)``, ``c = sqrt(ab)``;
* forces ``Fx/(mu N)``, ``Fy/(mu N)``, moment ``Mz/(mu N c)``.

In these units linear theory has slope 3 in ``xi*`` and ``eta*`` and 1 in ``phi*``,
and full slip is 1.  ``G C11`` etc. are taken from the flexibilities
(``G C11 = 8a/(3 L1)``, ``G C22 = 8a/(3 L2)``, ``G C23 = pi a sqrt(a/b)/(4 L3)``),
which is Kalker's scaling wherever the flexibilities are his.  ``mu`` is the layer law's
reference coefficient (:meth:`~torlab.model.layers.base.LayerLaw.reference_mu`: Voce's
saturation coefficient ``mu_c2``, full slip of the isothermal model being ``mu_c2 N``;
``mu_c1`` for the other laws); it is stored as ``mu_normalisation``.  Signs are torlab's (force along the creepage):
Kalker's and CONTACT's tables carry the opposite sign.

Each axis needs at least two points (a table is interpolated) and must increase
strictly.  The evaluation is vectorised; the points are cut into chunks of
``chunk`` creepage triples that are independent of each other, and ``map_fn``
(``map`` by default; e.g. an executor's ``map``) evaluates them, so a process
pool or a cluster can take the work.

xarray is an optional dependency (``pip install 'torlab[tables]'``); netCDF is
written as netCDF3 through scipy (``engine="scipy"``), so no compiled netCDF
library is needed.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.model.creep import CreepGrid, CreepProblem, canonical_creepages, creep_forces
from torlab.model.layers import get_law

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = [
    "CreepTable",
    "TableAxis",
    "creep_table",
    "kalker_scales",
    "require_xarray",
    "scene_creep_table",
]

#: the CSV/netCDF variables with their units and meaning
VARIABLES: dict[str, tuple[str, str]] = {
    "Fx_N": ("N", "longitudinal creep force (positive along positive creepage)"),
    "Fy_N": ("N", "lateral creep force"),
    "Mz_Nm": ("N m", "spin moment about the contact centre"),
    "mu_x": ("1", "Fx / N"),
    "mu_y": ("1", "Fy / N"),
    "Fx_norm": ("1", "Fx / (mu N), Kalker's normalisation"),
    "Fy_norm": ("1", "Fy / (mu N)"),
    "Mz_norm": ("1", "Mz / (mu N c), c = sqrt(a b)"),
    "adhesion_fraction": ("1", "fraction of the load carried in stick"),
    "max_temperature_C": ("degC", "maximum flash temperature"),
    "Fx_theory_error_95_N": ("N", "theory error of Fx (95 %) against Kalker's exact theory: "
                             "the boundary method's own error, apart from any fit's"),
    "Fy_theory_error_95_N": ("N", "theory error of Fy (95 %) against Kalker's exact theory"),
    "Mz_theory_error_95_Nm": ("N m", "theory error of Mz (95 %) against Kalker's exact theory"),
}
#: the CF conventions the netCDF file follows (units, long_name; coordinates without
#: _FillValue)
CONVENTIONS = "CF-1.8"


def require_xarray() -> Any:
    """Import xarray or raise a one-line :class:`TorlabInputError` saying how to get it."""
    try:
        import xarray
    except ImportError:  # pragma: no cover - depends on the environment
        raise TorlabInputError("creep-force tables need xarray: pip install 'torlab[tables]' "
                               "(or pip install xarray)") from None
    return xarray


@dataclass(frozen=True)
class TableAxis:
    """One axis of a table: name, values (SI), unit and description."""

    name: str
    values: np.ndarray
    unit: str
    description: str

    @classmethod
    def make(cls, name: str, values: Any, unit: str, description: str) -> TableAxis:
        """Validate: finite, at least two points, strictly increasing."""
        v = np.atleast_1d(np.asarray(values, dtype=float)).ravel()
        if v.size < 2:
            raise TorlabInputError(f"table axis {name!r} has {v.size} point(s): a table axis "
                                   "needs at least two (give start:stop:count or a list)",
                                   key=name)
        if not np.all(np.isfinite(v)):
            raise TorlabInputError(f"table axis {name!r} has a non-finite value", key=name)
        if np.any(np.diff(v) <= 0):
            raise TorlabInputError(f"table axis {name!r} must increase strictly (a table is "
                                   "interpolated along it)", key=name)
        return cls(name, v, unit, description)


def kalker_scales(prob: CreepProblem) -> dict[str, float]:
    """Scales of Kalker's normalisation for a problem (see the module docstring).

    Returns ``mu`` (the layer law's reference coefficient: Voce's ``mu_c2``), ``N``, ``c``, and the factors turning ``xi``, ``eta``,
    ``phi`` into ``xi*``, ``eta*``, ``phi*`` (``nan`` for a creepage whose flexibility
    is unknown).
    """
    a, b = prob.a, prob.b
    c = math.sqrt(a * b)
    mu = float(prob.layer.law.reference_mu(prob.layer))
    N = prob.load
    GC11 = 8 * a / (3 * prob.L1)
    GC22 = 8 * a / (3 * prob.L2) if prob.L2 is not None else math.nan
    GC23 = math.pi * a * math.sqrt(a / b) / (4 * prob.L3) if prob.L3 is not None else math.nan
    muN = mu * N if mu > 0 else math.nan
    return {"mu": mu, "N": N, "c": c, "xi": GC11 * c * c / (3 * muN),
            "eta": GC22 * c * c / (3 * muN), "phi": GC23 * c**3 / muN,
            "G_C11": GC11, "G_C22": GC22, "G_C23": GC23}


def _chunk(prob: CreepProblem, grid: CreepGrid | None, xi: np.ndarray, eta: np.ndarray,
           phi: np.ndarray, exact: Any = None) -> dict[str, np.ndarray]:
    """Evaluate one chunk of creepage triples (a picklable unit of work for ``map_fn``):
    FASTSIM (corrected by the exact theory where ``prob.calibrated``), or with ``exact``
    -- ``(ExactContact, ExactGrid)`` -- Kalker's exact theory; with each force's theory
    error."""
    if exact is not None:
        from torlab.model.exact.rolling import exact_creep_forces

        r = exact_creep_forces(exact[0], xi, eta, phi, exact[1])
        out = {"Fx_N": r.Fx, "Fy_N": r.Fy, "Mz_Nm": r.Mz, "mu_x": r.mu_x, "mu_y": r.mu_y,
               "adhesion_fraction": r.adhesion_fraction, "Fx_theory_error_95_N": r.Fx_error,
               "Fy_theory_error_95_N": r.Fy_error, "Mz_theory_error_95_Nm": r.Mz_error}
        if r.max_temperature_C is not None:
            out["max_temperature_C"] = r.max_temperature_C
        return out
    from torlab.model.calibrated import creep_error

    r = creep_forces(prob, xi, eta, phi, grid)
    ex, ey, ez = creep_error(prob, xi, eta, phi, r.Fx, r.Fy, r.Mz, calibrated=prob.calibrated,
                             adhesion=r.adhesion_fraction)
    out = {"Fx_N": r.Fx, "Fy_N": r.Fy, "Mz_Nm": r.Mz, "mu_x": r.mu_x, "mu_y": r.mu_y,
           "adhesion_fraction": r.adhesion_fraction, "Fx_theory_error_95_N": ex,
           "Fy_theory_error_95_N": ey, "Mz_theory_error_95_Nm": ez}
    if r.max_temperature_C is not None:
        out["max_temperature_C"] = r.max_temperature_C
    return out


def _executor_map(fn: Callable[[Any], Any], items: Iterable[Any]) -> list[Any]:
    from torlab.parallel import current

    return current().map(fn, items, description="creep-force table")


def _chunk_star(args: tuple) -> dict[str, np.ndarray]:
    return _chunk(*args)


@dataclass
class CreepTable:
    """A computed table: the :class:`xarray.Dataset` and what went into it."""

    dataset: Any
    axes: list[TableAxis]
    notes: list[str] = field(default_factory=list)

    def to_long(self) -> Any:
        """Long DataFrame, one row per point: axes (with units), normalised creepages, forces."""
        ds = self.dataset
        df = ds.to_dataframe().reset_index()
        ren = {ax.name: _column(ax) for ax in self.axes}
        return df.rename(columns=ren)

    def write(self, out: Any, stem: str = "creep_table") -> list[str]:
        """Write ``<stem>.nc`` (netCDF3 via scipy) and ``<stem>.csv`` through an
        :class:`~torlab.outputs.OutputDir`; returns the file names."""
        nc = f"{stem}.nc"
        path = out.path(nc)
        ds = self.dataset
        # CF: coordinates carry no _FillValue (xarray would add NaN to float coordinates)
        encoding = {name: {"_FillValue": None} for name in ds.coords}
        ds.to_netcdf(path, engine="scipy", format="NETCDF3_64BIT", encoding=encoding)
        out.write_csv(f"{stem}.csv", self.to_long(), float_format="%.9g")
        return [nc, f"{stem}.csv"]


def _column(ax: TableAxis) -> str:
    unit = {"1": "", "1/m": "_1_m", "m/s": "_m_s"}.get(ax.unit, "_" + ax.unit.replace("/", "_"))
    return ax.name if unit and ax.name.endswith(unit) else f"{ax.name}{unit}"


def creep_table(problem: CreepProblem | Sequence[tuple[float, CreepProblem]], creepage: Any,  # noqa: C901 (each axis of the table and its checks is a case)
                lateral: Any, spin: Any, *, speed: Any = None, amount_unit: str = "",
                grid: CreepGrid | None = None, chunk: int = 256,
                map_fn: Callable[[Callable[[Any], Any], Iterable[Any]], Iterable[Any]] | None = None,
                provenance: dict[str, Any] | None = None, exact: Any = None) -> CreepTable:
    """N-dimensional creep-force table over creepage x lateral x spin (x speed x amount).

    Parameters
    ----------
    problem
        The contact and layer (:func:`torlab.model.creep.creep_problem`), or for an
        amount axis a sequence of ``(amount, problem)`` pairs (amounts increasing).
    creepage, lateral, spin
        Axis values: longitudinal and lateral creepage (fractions), spin [1/m].
    speed
        Optional rolling-speed axis [m/s]; it changes only the contact temperature
        (a scene without ``thermal:`` gets a note that the forces do not depend on it).
    amount_unit
        Unit of the amount axis, for the metadata (``"uL"``, ``"mg/m"``...).
    grid
        Resolution of the creep-force scheme.
    chunk
        Creepage triples per unit of work.
    map_fn
        ``map``-like callable evaluating the chunks (default: the executor in use,
        :func:`torlab.parallel.current` -- serial unless a command's ``--jobs`` or
        ``--scheduler`` set one; the chunks are the same whatever evaluates them).
    provenance
        Extra attributes (scene name and files, command line ...), stored as JSON text.
    exact
        Solve by Kalker's exact theory: ``(contacts, grid)``, one
        :class:`~torlab.model.exact.rolling.ExactContact` per problem (the problems still
        give the normalisation) and the :class:`~torlab.model.exact.rolling.ExactGrid`.
        None: FASTSIM, corrected by the exact theory where the problems are
        ``calibrated`` (the ``fastsim`` method).

    Returns
    -------
    CreepTable
        With each force's theory error (``Fx_theory_error_95_N`` ...), the method, and
        as coordinates the contact (``load_N``, ``a_over_b``) the normalised variables
        hold for.

    Raises
    ------
    TorlabInputError
        An axis with fewer than two points, unsorted or non-finite values; spin or
        lateral creepage without the flexibilities they need; xarray missing.
    """
    xr = require_xarray()
    axes = [TableAxis.make("creepage", creepage, "1", "longitudinal creepage xi"),
            TableAxis.make("lateral", lateral, "1", "lateral creepage eta"),
            TableAxis.make("spin", spin, "1/m", "spin phi")]
    problems: list[tuple[float | None, CreepProblem]]
    if isinstance(problem, CreepProblem):
        problems = [(None, problem)]
    else:
        pairs = list(problem)
        amounts = TableAxis.make("amount", [p[0] for p in pairs], amount_unit or "1",
                                 f"applied product amount ({amount_unit or 'as given'})")
        problems = [(float(v), p) for v, (_, p) in zip(amounts.values, pairs, strict=True)]
        axes.append(amounts)
    speeds = None
    notes: list[str] = []
    if speed is not None:
        sp = TableAxis.make("speed", speed, "m/s", "rolling speed v")
        if np.any(sp.values <= 0):
            raise TorlabInputError("table axis 'speed' must be positive", key="speed")
        speeds = sp.values
        axes.insert(3, sp)
        if all(p.thermal is None for _, p in problems):
            notes.append("speed axis: the scene has no thermal: section, so the forces do not "
                         "depend on speed (the values repeat along it)")
    xi_ax, eta_ax, phi_ax = (ax.values for ax in axes[:3])
    XI, ETA, PHI = (v.ravel() for v in np.meshgrid(xi_ax, eta_ax, phi_ax, indexing="ij"))
    base_shape = (xi_ax.size, eta_ax.size, phi_ax.size)
    for _, p in problems:
        if p.L3 is None and np.any(PHI != 0):
            raise TorlabInputError("spin needs the contact shape (L3 from C23): build the "
                                   "problem from a scene", key="spin")
        if p.L2 is None and np.any(ETA != 0):
            raise TorlabInputError("lateral creepage needs L2 (from C22)", key="lateral")
    # the model's symmetries: each distinct triple up to sign flips is solved once
    # (a table symmetric about zero costs a quarter); then units of work:
    # (problem at a speed) x chunk of distinct triples
    uniq, inv, sx, sy = canonical_creepages(XI, ETA, PHI)
    UX, UE, UP = (uniq[:, k].copy() for k in range(3))
    work = []
    variants = []
    if exact is not None:
        if len(exact[0]) != len(problems):
            raise ValueError("exact: one contact per problem")
        if speeds is not None and not any(c.coupled for c in exact[0]):
            notes.append("speed axis: the contact temperature does not enter the layer's "
                         "limits, so the exact solver's forces do not depend on speed (the "
                         "values repeat along it)")
    for ip, (amount, p) in enumerate(problems):
        ex = None if exact is None else (exact[0][ip], exact[1])
        for v in (speeds if speeds is not None else [None]):
            pv = p if v is None else _with_speed(p, float(v))
            variants.append((amount, v, pv))
            exv = ex if ex is None or v is None else (ex[0].at_speed(float(v)), ex[1])
            for s in range(0, UX.size, chunk):
                work.append((pv, grid, UX[s:s + chunk], UE[s:s + chunk], UP[s:s + chunk], exv))
    results = list((map_fn or _executor_map)(_chunk_star, work))
    per_variant = math.ceil(UX.size / chunk)
    sign = {"Fx_N": sx, "mu_x": sx, "Fy_N": sy, "mu_y": sy, "Mz_Nm": sy}
    method = ("exact" if exact is not None else
              "fastsim" if problems[0][1].calibrated else "fastsim-kalker")
    names = list(results[0])
    shape_extra = ([speeds.size] if speeds is not None else []) + \
        ([len(problems)] if problems[0][0] is not None else [])
    full_shape = base_shape + tuple(shape_extra)
    data = {k: np.empty(full_shape) for k in names}
    for iv, (amount, v, _pv) in enumerate(variants):
        parts = results[iv * per_variant:(iv + 1) * per_variant]
        idx: tuple = ()
        if speeds is not None:
            idx += (int(np.flatnonzero(speeds == v)[0]),)
        if amount is not None:
            idx += (next(i for i, (a_, _) in enumerate(problems) if a_ == amount),)
        for k in names:
            vals = np.concatenate([r[k] for r in parts])[inv] * sign.get(k, 1.0)
            data[k][(..., *idx)] = vals.reshape(base_shape)
    dims = [ax.name for ax in axes]
    # normalised creepages and forces, per problem (mu and the scales may change with amount)
    scales = [kalker_scales(p) for _, p in problems]
    sc = {k: np.array([s[k] for s in scales]) for k in ("mu", "N", "c", "xi", "eta", "phi")}
    amount_dim = problems[0][0] is not None

    def per_amount(v: np.ndarray) -> Any:
        return xr.DataArray(v, dims=["amount"]) if amount_dim else float(v[0])

    coords: dict[str, Any] = {ax.name: (ax.name, ax.values, {"units": ax.unit,
                                                               "long_name": ax.description})
                              for ax in axes}
    ds = xr.Dataset({k: (dims, data[k], {"units": VARIABLES[k][0], "long_name": VARIABLES[k][1]})
                     for k in names}, coords=coords)
    muN = per_amount(sc["mu"] * sc["N"])
    ds["Fx_norm"] = ds["Fx_N"] / muN
    ds["Fy_norm"] = ds["Fy_N"] / muN
    ds["Mz_norm"] = ds["Mz_Nm"] / (muN * per_amount(sc["c"]))
    for k in ("Fx_norm", "Fy_norm", "Mz_norm"):
        ds[k].attrs = {"units": VARIABLES[k][0], "long_name": VARIABLES[k][1]}
    for name, key, desc in (("xi_norm", "xi", "G c^2 C11 xi / (3 mu N)"),
                            ("eta_norm", "eta", "G c^2 C22 eta / (3 mu N)"),
                            ("phi_norm", "phi", "G c^3 C23 phi / (mu N)")):
        axis = {"xi": "creepage", "eta": "lateral", "phi": "spin"}[key]
        val = ds[axis] * per_amount(sc[key])
        ds = ds.assign_coords({name: val})
        ds[name].attrs = {"units": "1", "long_name": f"Kalker-normalised {axis}: {desc}"}
    ds = ds.transpose(*dims)
    p0 = problems[0][1]
    law = p0.layer.law
    # the contact the normalised variables hold for (scalar coordinates)
    ds = ds.assign_coords(load_N=p0.load, a_over_b=p0.a / p0.b)
    ds["load_N"].attrs = {"units": "N", "long_name": "normal load of the contact"}
    ds["a_over_b"].attrs = {"units": "1", "long_name": "aspect ratio a/b of the contact "
                                                        "(a along the rolling direction)"}
    fastsim = ("FASTSIM with the third-body layer in longitudinal creepage, lateral creepage "
               f"and spin (Kalker's three flexibilities, {law.limit_text}; torlab.model.creep)")
    model = {"fastsim-kalker": fastsim,
             "fastsim": fastsim + ", corrected by Kalker's exact theory (torlab.model.calibrated)",
             "exact": ("Kalker's exact theory (torlab.model.exact): quasi-identical elastic "
                       "half-spaces, the layer in series, isothermal")}[method]
    err = np.hypot(data["Fx_theory_error_95_N"], data["Fy_theory_error_95_N"])
    attrs: dict[str, Any] = {
        "Conventions": CONVENTIONS,
        "title": "creep-force table (torlab)",
        "model": model,
        "boundary_method": method,
        "theory_error": ("each force's theory error (95 %) against Kalker's exact theory is "
                         "the variable <force>_theory_error_95_<unit>, apart from any fit's "
                         "uncertainty"),
        "theory_error_95_max_mu": float(np.nanmax(err) / p0.load),
        "normalisation_valid_for": _validity(p0),
        "sign_convention": ("forces along positive creepage are positive; Kalker's and "
                            "CONTACT's forces have the opposite sign"),
        "normalisation": ("Kalker's book of tables: xi* = G c^2 C11 xi/(3 mu N), "
                          "eta* = G c^2 C22 eta/(3 mu N), phi* = G c^3 C23 phi/(mu N), "
                          f"F/(mu N), Mz/(mu N c), c = sqrt(a b), mu = {law.reference_name}"),
        "mu_normalisation": float(sc["mu"][0]) if not amount_dim else json.dumps(
            [float(v) for v in sc["mu"]]),
        "a_m": p0.a, "b_m": p0.b, "load_N": p0.load, "p0_Pa": p0.p0,
        "L1_m_Pa": p0.L1, "L2_m_Pa": p0.L2 if p0.L2 is not None else math.nan,
        "L3_m_Pa": p0.L3 if p0.L3 is not None else math.nan,
        "restick": p0.restick, "traction_bound": p0.traction_bound,
        "grid": json.dumps(asdict(grid or CreepGrid())),
        "layer": json.dumps(({} if p0.layer.law is get_law() else {"law": p0.layer.law.name})
                            | {k: float(v) for k, v in p0.layer.values.items()}),
        "thermal": json.dumps(asdict(p0.thermal)) if p0.thermal is not None else "none",
        "speed_m_s": p0.speed, "ambient_temperature_C": p0.ambient_temperature,
        "notes": json.dumps(notes),
    }
    from torlab import __version__

    attrs["torlab_version"] = __version__
    for k, v in (provenance or {}).items():
        attrs[k] = v if isinstance(v, (str, int, float)) else json.dumps(v, default=str)
    ds.attrs.update(attrs)
    for k in names:
        if not np.all(np.isfinite(data[k])):
            from torlab.errors import NumericalError

            raise NumericalError(f"creep table: non-finite values in {k}; please report this scene")
    return CreepTable(dataset=ds, axes=axes, notes=notes)


def _layered(layer: Any) -> bool:
    """Whether a layer makes Kalker's normalised forces depend on the contact: an elastic
    length, or a limit other than one Coulomb coefficient."""
    if float(layer.L_mue) > 0:
        return True
    mu1 = float(layer.mu_c1)
    return float(layer.get("mu_c2", mu1)) != mu1


def _validity(p: CreepProblem) -> str:
    """For which contacts the normalised variables hold (the attribute's text)."""
    if _layered(p.layer):
        return (f"this contact only: a = {p.a:.6g} m, b = {p.b:.6g} m, N = {p.load:.6g} N "
                "(coordinates a_over_b, load_N) with this layer. The layer's compliance "
                "L_mue/p and its limits make the normalised forces depend on the load and "
                "the contact: for another contact use the dimensional variables of a table "
                "made for it, or a table over --load")
    return ("any contact of this aspect ratio and Poisson ratio: without an elastic layer "
            "and with one friction coefficient the normalised forces are Kalker's, the same "
            "for every load")


def _with_speed(p: CreepProblem, v: float) -> CreepProblem:
    from dataclasses import replace

    return replace(p, speed=v)


def scene_creep_table(scene: Scene, creepage: Any, lateral: Any, spin: Any, *, speed: Any = None,
                      amounts: Sequence[tuple[float, Any]] | None = None, amount_unit: str = "",
                      normalised: bool = False, map_fn: Any = None,
                      provenance: dict[str, Any] | None = None, loads: Any = None,
                      method: str | None = None) -> CreepTable:
    """:func:`creep_table` of a scene (or, with ``amounts``, of one scene per amount; with
    ``loads``, of one contact per load).

    Parameters
    ----------
    scene
        A validated dry :class:`~torlab.scene.Scene`; ignored when ``amounts`` is given.
    creepage, lateral, spin
        Axis values: fractions and 1/m, or with ``normalised`` Kalker's ``xi*``, ``eta*``,
        ``phi*`` (converted with the scene's contact and the layer's reference coefficient,
        Voce's ``mu_c2``; with an amount axis, with the first amount's; with a load axis,
        with each load's, so that the normalised axes are the same at every load).
    speed
        Optional speed axis [m/s].
    amounts
        ``(amount, scene)`` pairs for an amount axis (one parameter set per amount).
    amount_unit
        Unit text of the amounts.
    normalised
        Axes given in Kalker's normalised creepages.
    map_fn
        ``map``-like callable for the chunks (e.g. an executor's ``map``).
    provenance
        Attributes to store (scene files, command).
    loads
        Optional normal-load axis (N, increasing, two at least): the contact of each load
        by Hertz from the scene's radii, or, where the scene gives the semi-axes, with
        ``a`` and ``b`` scaled as ``load^(1/3)`` (Hertz's law); the dimension ``load_N``.
        With a layer the normalised forces depend on the load: this is the table that
        carries it.
    method
        The boundary method (``fastsim``, ``fastsim-kalker``, ``exact``, ``auto``); None:
        the scene's ``grid: method``.  ``auto`` has no band to weigh a table's theory
        error against and so uses the exact solver (with the contact temperature coupled
        to the layer's limits where the scene has them).
    """
    from torlab.model.predict import with_method

    first = amounts[0][1] if amounts else scene
    method = method or first.grid.method
    if loads is not None:
        ax = TableAxis.make("load_N", loads, "N", "normal load")
        if np.any(ax.values <= 0):
            raise TorlabInputError("table axis 'load' must be positive", key="load")
        xr = require_xarray()
        parts = [scene_creep_table(_at_load(scene, v), creepage, lateral, spin, speed=speed,
                                   amounts=None if not amounts else
                                   [(a, _at_load(sc, v)) for a, sc in amounts],
                                   amount_unit=amount_unit, normalised=normalised,
                                   map_fn=map_fn, provenance=provenance, method=method)
                 for v in ax.values]
        sets = [p.dataset for p in parts]
        if normalised:  # the normalised axes are the same at every load, the creepages not
            norm = {"creepage": "xi_norm", "lateral": "eta_norm", "spin": "phi_norm"}
            sets = [d.swap_dims(norm) for d in sets]
            sets = [d.assign_coords({k: sets[0][k].values for k in norm.values()})
                    for d in sets]
        ds = xr.concat(sets, dim="load_N", coords="different", compat="equals",
                       combine_attrs="override", join="exact")
        ds = ds.transpose(..., "load_N")
        ds["load_N"].attrs = {"units": "N", "long_name": "normal load of the contact"}
        for k in ("a_m", "b_m", "p0_Pa", "L1_m_Pa", "L2_m_Pa", "L3_m_Pa", "load_N"):
            ds.attrs.pop(k, None)
        ds.attrs["contacts"] = json.dumps([{k: p.dataset.attrs.get(k) for k in
                                            ("a_m", "b_m", "p0_Pa", "L1_m_Pa", "L2_m_Pa",
                                             "L3_m_Pa", "load_N")} for p in parts])
        valid = parts[0].dataset.attrs["normalisation_valid_for"]
        ds.attrs["normalisation_valid_for"] = (
            "each load's contact (dimension load_N; its a, b, p0 in the attribute contacts; "
            "the same aspect ratio at every load)" + (
                ": " + valid.split("with this layer. ", 1)[1] if "with this layer. " in valid
                else ": " + valid))
        ds.attrs["theory_error_95_max_mu"] = max(p.dataset.attrs["theory_error_95_max_mu"]
                                                 for p in parts)
        if any(sc.contact.a is not None for sc in [scene, *(s for _, s in amounts or [])]):
            parts[0].notes.append("load axis: the scene gives the semi-axes, scaled with "
                                  "load^(1/3) as Hertz's solution scales them")
        axes = [*parts[0].axes, ax]
        return CreepTable(dataset=ds, axes=axes, notes=parts[0].notes)
    first = with_method(first, method)
    if amounts:
        amounts = [(a, with_method(sc, method)) for a, sc in amounts]
    from torlab.model.creep import creep_problem, scene_grid

    prob0 = creep_problem(first)
    xi, eta, phi = (np.atleast_1d(np.asarray(v, dtype=float)) for v in (creepage, lateral, spin))
    if normalised:
        s = kalker_scales(prob0)
        xi, eta, phi = xi / s["xi"], eta / s["eta"], phi / s["phi"]
    prov = {"scene": getattr(first, "name", ""), "axes_given_normalised": int(normalised),
            **(provenance or {})}
    scenes = [first] if not amounts else [sc for _, sc in amounts]
    target: Any = prob0 if not amounts else [(float(a), creep_problem(sc)) for a, sc in amounts]
    exact = None
    used = method
    if method == "auto":
        used = "exact"
        prov["method_auto"] = "exact: a table has no band to weigh the theory error against"
    if used == "exact":
        from torlab.model.exact.rolling import ExactGrid
        from torlab.model.exact.scene import exact_contact

        exact = ([exact_contact(sc) for sc in scenes], ExactGrid(n=first.grid.exact_n))
    prov["method_asked"] = method
    # the exact solver's points are a thousand times dearer: smaller units of work spread
    # them over the workers (each point of a unit starts from its predecessor's tractions)
    return creep_table(target, xi, eta, phi, speed=speed, amount_unit=amount_unit,
                       grid=scene_grid(first), map_fn=map_fn, provenance=prov, exact=exact,
                       chunk=16 if exact is not None else 256)


def _at_load(scene: Any, load: float) -> Any:
    """The scene at another normal load: Hertz from its radii, or its semi-axes scaled by
    ``(load/load0)^(1/3)``."""
    c = scene.contact
    upd: dict[str, Any] = {"load": float(load)}
    if c.a is not None:
        k = (float(load) / c.load) ** (1.0 / 3.0)
        upd.update(a=c.a * k, b=c.b * k)
    return scene.model_copy(update={"contact": c.model_copy(update=upd)})
