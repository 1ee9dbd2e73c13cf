"""Creep forces of a Hertzian contact by Kalker's exact theory, with their discretisation error.

:func:`exact_creep_forces` solves steady rolling of two quasi-identical elastic
half-spaces on an elliptical Hertz contact (semi-axes ``a`` along the rolling
direction, ``b`` across, load ``N``) for longitudinal creepage ``xi``, lateral
creepage ``eta`` and spin ``phi`` together, with Coulomb friction and, optionally,
a third-body layer (its elastic flexibility and its plastic law).

Each point is solved on two grids (``n`` and ``coarse`` elements across each axis
of the ellipse, two more on every side): the answer is the fine grid's, and its
discretisation error is estimated from the difference of the two by Richardson's
rule for the scheme's first order (``h`` the element length)::

    err(F_n) = |F_n - F_coarse| * coarse / (n - coarse)

The normal pressure is the discrete half-space solution for the Hertz geometry
at the load (``normal="discrete"``, CONTACT's full solution), or Hertz's
elliptical pressure at the element centres (``normal="hertz"``).

Signs follow torlab: a force is positive along positive creepage (Kalker's and
CONTACT's forces on body 1 are these with the sign reversed); ``Mz`` is the
moment of the tractions about the contact centre, positive with positive spin.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from torlab.model.exact.grid import ellipse_grid, hertz_pressure
from torlab.model.exact.local import ADHESION, PLASTIC, YieldLaw
from torlab.model.exact.normal import hertz_curvatures, solve_normal
from torlab.model.exact.solver import Layer, Solution, rigid_slip, solve
from torlab.model.exact.thermal import ExactThermal, ThermalPoint, solve_thermal, thermal_note

__all__ = ["ExactContact", "ExactGrid", "ExactLayer", "ExactResult", "exact_creep_forces",
           "normalised_creepages", "solve_point"]


@dataclass(frozen=True)
class ExactLayer:
    """A third-body layer for the exact solver (SI units).

    Attributes
    ----------
    flexibility
        Elastic flexibility [m/Pa]: a constant ``h/G3`` (CONTACT), or ``None`` with
        ``flexibility_pressure``.
    flexibility_pressure
        ``L_mue`` [m]: the thesis's flexibility ``L_mue / p`` (Eq. 5.28), used when
        ``flexibility`` and ``flexibility_of`` are None.
    flexibility_of
        A function of the pressure [Pa] giving the flexibility [m/Pa], used when
        ``flexibility`` is None (a layer law's own).
    law
        The yield law (:class:`~torlab.model.exact.local.LinearYield`,
        :class:`~torlab.model.exact.local.VoceYield`, ...), or None: elastic layer.
    c1, c2
        The law's parameters as fixed stresses [Pa], or, with ``per_pressure``, as
        coefficients of the pressure (``tau_c1 = mu_c1 p``, ``tau_c2 = mu_c2 p``).
    per_pressure
        Whether ``c1, c2`` multiply the pressure.
    name
        What the output says was modelled.
    """

    flexibility: float | None = 0.0
    flexibility_pressure: float = 0.0
    flexibility_of: Callable[[np.ndarray], np.ndarray] | None = None
    law: YieldLaw | None = None
    c1: float | None = None
    c2: float | None = None
    per_pressure: bool = False
    name: str = "third-body layer"

    def on_grid(self, pn: np.ndarray) -> Layer:
        """The layer's arrays on a grid with the pressure ``pn`` [Pa]."""
        pos = pn > 0
        if self.flexibility is None and self.flexibility_of is not None:
            flex = np.where(pos, self.flexibility_of(np.where(pos, pn, 1.0)), 0.0)
        elif self.flexibility is None:
            flex = np.where(pos, self.flexibility_pressure / np.where(pos, pn, 1.0), 0.0)
        else:
            flex = np.full(pn.shape, float(self.flexibility))
        if self.law is None:
            return Layer(flexibility=flex)
        scale = pn if self.per_pressure else 1.0
        c1 = np.asarray(self.c1, float) * scale
        c2 = c1 if self.c2 is None else np.asarray(self.c2, float) * scale
        return Layer(flexibility=flex, law=self.law, c1=c1, c2=c2)


@dataclass(frozen=True)
class ExactContact:
    """An elliptical Hertz contact of two quasi-identical bodies (SI units).

    Attributes
    ----------
    a, b
        Semi-axes [m], ``a`` along the rolling direction.
    load
        Normal load ``N`` [N].
    G, nu
        Combined shear modulus [Pa] and Poisson ratio (Kalker's, for two materials).
    mu
        Coefficient of friction; ``inf``: no Coulomb bound (the layer's yield stress
        bounds the traction, or, without a layer law, no slip: the linear theory).
    layer
        Third-body layer, or None.
    thermal
        The contact temperature and its coupling to the layer's limits
        (:mod:`torlab.model.exact.thermal`), or None: isothermal.  With a non-zero
        ``sensitivity`` the layer's law must take the element's temperature rise as its
        parameter ``c2`` (``takes_temperature``, as
        :class:`~torlab.model.exact.scene.LawYield` does).
    """

    a: float
    b: float
    load: float
    G: float
    nu: float
    mu: float = math.inf
    layer: ExactLayer | None = None
    thermal: ExactThermal | None = None

    def at_speed(self, speed: float) -> ExactContact:
        """The contact rolling at ``speed`` [m/s] (only the contact temperature depends on
        it; the same contact without ``thermal``)."""
        if self.thermal is None:
            return self
        return replace(self, thermal=replace(self.thermal, speed=float(speed)))

    @property
    def coupled(self) -> bool:
        """Whether the contact temperature enters the layer's limits."""
        return (self.thermal is not None and self.thermal.sensitivity > 0
                and self.layer is not None and self.layer.law is not None)

    @property
    def p0(self) -> float:
        """Maximum Hertz pressure ``3N/(2 pi a b)`` [Pa]."""
        return 3 * self.load / (2 * math.pi * self.a * self.b)

    def check(self) -> None:
        """Raise ValueError on a contact the solver cannot take."""
        for name in ("a", "b", "load", "G"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive and finite, got {v}")
        if not 0.0 <= self.nu < 0.5:
            raise ValueError(f"Poisson ratio must be in [0, 0.5), got {self.nu}")
        if not self.mu > 0:
            raise ValueError(f"friction coefficient must be positive, got {self.mu}")
        if self.coupled and not getattr(self.layer.law, "takes_temperature", False):
            raise ValueError("a contact temperature coupled to the layer needs a yield law "
                             "that takes the element's temperature rise as c2 (LawYield)")


@dataclass(frozen=True)
class ExactGrid:
    """The two grids of :func:`exact_creep_forces`.

    Attributes
    ----------
    n
        Elements across each axis of the ellipse on the fine grid (the answer's).
    coarse
        Elements on the second grid (default ``round(0.6 n)``); 0: one grid, no error
        estimate.
    margin
        Elements added on every side.
    normal
        ``discrete`` (the half-space's discrete normal solution for the Hertz geometry)
        or ``hertz`` (Hertz's pressure at the element centres).
    tol
        Solver tolerance (:func:`torlab.model.exact.solver.solve`).
    """

    n: int = 25
    coarse: int | None = None
    margin: int = 2
    normal: str = "discrete"
    tol: float = 1e-6

    @property
    def n_coarse(self) -> int:
        return round(0.6 * self.n) if self.coarse is None else int(self.coarse)


@dataclass
class ExactResult:
    """Creep forces over a set of creepage triples (arrays of the broadcast input shape).

    Attributes
    ----------
    creepage, lateral, spin
        The creepages as given (fractions; spin in 1/m).
    Fx, Fy, Mz
        Forces [N] and spin moment [N m] on the fine grid, torlab's signs.
    Fx_error, Fy_error, Mz_error
        Their discretisation errors (Richardson from the two grids; NaN without a
        second grid).
    mu_x, mu_y
        ``Fx/N``, ``Fy/N``.
    adhesion_fraction, plastic_fraction
        Fractions of the contact's elements in adhesion and in plastic flow (fine grid).
    load
        Normal load [N].
    grid
        The grids used.
    notes
        What was modelled, for the output.
    solutions
        The fine-grid solutions (tractions, slip, element division), when kept.
    max_temperature_C
        The largest contact temperature of each point on the fine grid [°C] (None
        without ``thermal``; :mod:`torlab.model.exact.thermal`).
    temperature_iterations
        Solves of each point on the fine grid (1: one pass; None without ``thermal``).
    temperature_loop
        ``"off"`` (no ``thermal``), ``"single pass"`` (the heating cannot change the
        limits) or ``"iterated"`` (some point iterated the coupling).
    """

    creepage: np.ndarray
    lateral: np.ndarray
    spin: np.ndarray
    Fx: np.ndarray
    Fy: np.ndarray
    Mz: np.ndarray
    Fx_error: np.ndarray
    Fy_error: np.ndarray
    Mz_error: np.ndarray
    mu_x: np.ndarray
    mu_y: np.ndarray
    adhesion_fraction: np.ndarray
    plastic_fraction: np.ndarray
    load: float
    grid: ExactGrid
    notes: list[str] = field(default_factory=list)
    solutions: list[Solution] | None = None
    max_temperature_C: np.ndarray | None = None
    temperature_iterations: np.ndarray | None = None
    temperature_loop: str = "off"

    def table(self) -> Any:
        """Long DataFrame with units in the column names."""
        import pandas as pd

        cols = {"creepage": self.creepage, "lateral": self.lateral, "spin_1_m": self.spin,
                "Fx_N": self.Fx, "Fy_N": self.Fy, "Mz_Nm": self.Mz,
                "Fx_error_N": self.Fx_error, "Fy_error_N": self.Fy_error,
                "Mz_error_Nm": self.Mz_error, "mu_x": self.mu_x, "mu_y": self.mu_y,
                "adhesion_fraction": self.adhesion_fraction,
                "plastic_fraction": self.plastic_fraction}
        if self.max_temperature_C is not None:
            cols["max_temperature_C"] = self.max_temperature_C
        return pd.DataFrame({k: np.asarray(v).ravel() for k, v in cols.items()})


def normalised_creepages(contact: ExactContact, xi: Any = 0.0, eta: Any = 0.0, phi: Any = 0.0
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Kalker's normalised creepages ``(xi*, eta*, phi*)`` of a Coulomb contact.

    ``xi* = G a b C11 xi / (3 mu N)``, ``eta* = G a b C22 eta / (3 mu N)``,
    ``phi* = G (ab)^(3/2) C23 phi / (3 mu N)`` with Kalker's coefficients
    (:mod:`torlab.model.kalker`): the linear theory's force over ``mu N`` divided by 3,
    so that full slip sets in near ``xi* = 1`` (simplified theory: at ``xi* = 1``
    exactly for the parabolic bound).
    """
    from torlab.model.kalker import C11, C22, C23

    g = contact.a / contact.b
    s = contact.G * contact.a * contact.b / (3 * contact.mu * contact.load)
    c = math.sqrt(contact.a * contact.b)
    return (s * C11(g, contact.nu) * np.asarray(xi, float),
            s * C22(g, contact.nu) * np.asarray(eta, float),
            s * c * C23(g, contact.nu) * np.asarray(phi, float))


class RollingSetup:
    """The grid, pressure and layer of one grid size, built once for many creepages."""

    def __init__(self, contact: ExactContact, n: int, grid: ExactGrid) -> None:
        self.grid = ellipse_grid(contact.a, contact.b, n, n, grid.margin)
        g = self.grid
        if grid.normal == "discrete":
            A, B = hertz_curvatures(contact.a, contact.b, contact.load, contact.G, contact.nu)
            X, Y = g.centres()
            self.pn, _ = solve_normal(g, contact.G, contact.nu, A * X**2 + B * Y**2,
                                      contact.load)
        elif grid.normal == "hertz":
            self.pn = hertz_pressure(g, contact.a, contact.b, contact.load, "centre")
        else:
            raise ValueError(f"unknown normal pressure {grid.normal!r}")
        self.layer = None if contact.layer is None else contact.layer.on_grid(self.pn)
        self.contact = contact
        self.tol = grid.tol

    def solve(self, xi: float, eta: float, phi: float, p0: np.ndarray | None,
              dT: np.ndarray | None = None) -> Solution:
        """One point with the layer's limits at the temperature rise ``dT`` ``(mx, my)``
        [K] (None: at the ambient temperature), starting from the traction ``p0``."""
        c = self.contact
        g = self.grid
        # CONTACT's rolling convention: the force on body 1 opposes the creepage; its spin
        # term is taken at x + dx/6
        W = rigid_slip(g, xi, eta, phi, x_spin=g.dx / 6)
        layer = self.layer if dT is None else replace(self.layer, c2=dT)
        return solve(g, c.G, c.nu, self.pn, c.mu, W, layer=layer, p0=p0, tol=self.tol)

    def solve_thermal(self, xi: float, eta: float, phi: float, p0: np.ndarray | None,
                      dT0: np.ndarray | None = None) -> ThermalPoint:
        """One point with the contact temperature (:mod:`torlab.model.exact.thermal`),
        starting from the traction ``p0`` and the temperature rise ``dT0`` (None: the
        ambient temperature); with a ``thermal`` whose heating cannot enter the limits,
        one solve and its temperature."""
        g = self.grid
        where = (f"creepage {xi:.4g}" + (f", lateral {eta:.4g}" if eta else "")
                 + (f", spin {phi:.4g} 1/m" if phi else "")
                 + f" ({g.mx}x{g.my} elements)")
        th = self.contact.thermal
        if not self.contact.coupled:
            th = replace(th, sensitivity=0.0)
        W = rigid_slip(g, xi, eta, phi, x_spin=g.dx / 6)
        return solve_thermal(lambda dT, p: self.solve(xi, eta, phi, p, dT), th, W, where, p0,
                             dT0 if self.contact.coupled else None)


def solve_point(contact: ExactContact, xi: float, eta: float = 0.0, phi: float = 0.0,
                n: int = 25, grid: ExactGrid | None = None) -> Solution:
    """The solution on one grid of ``n`` elements (CONTACT's signs: forces on body 1)."""
    grid = grid or ExactGrid(n=n)
    contact.check()
    return RollingSetup(contact, n, grid).solve(xi, eta, phi, None)


def _solve_chunk(args: tuple) -> dict[str, np.ndarray]:
    """Solve consecutive points on both grids, each starting from the previous solution."""
    contact, grid, pts, keep = args
    setups = [RollingSetup(contact, grid.n, grid)]
    if grid.n_coarse > 0:
        setups.append(RollingSetup(contact, grid.n_coarse, grid))
    k = len(pts)
    out = {name: np.zeros((len(setups), k)) for name in ("Fx", "Fy", "Mz")}
    out["adh"] = np.zeros(k)
    out["pl"] = np.zeros(k)
    out["tmax"] = np.zeros(k)
    out["its"] = np.zeros(k, dtype=int)
    out["looped"] = np.zeros(k, dtype=bool)
    sols = []
    for j, st in enumerate(setups):
        prev = rise = None
        for i, (xi, eta, phi) in enumerate(pts):
            if contact.thermal is None:
                s = st.solve(xi, eta, phi, prev)
            else:  # from the previous point's tractions and temperature
                pt = st.solve_thermal(xi, eta, phi, prev, rise)
                s, rise = pt.solution, pt.rise
                if j == 0:
                    out["tmax"][i], out["its"][i] = pt.max_temperature, pt.iterations
                    out["looped"][i] = pt.loop == "iterated"
            prev = s.p
            out["Fx"][j, i], out["Fy"][j, i], out["Mz"][j, i] = -s.Fx, -s.Fy, -s.Mz
            if j == 0:
                inside = s.state > 0
                out["adh"][i] = float((s.state == ADHESION).sum()) / max(int(inside.sum()), 1)
                out["pl"][i] = float((s.state == PLASTIC).sum()) / max(int(inside.sum()), 1)
                if keep:
                    sols.append(s)
    out["solutions"] = sols
    return out


def exact_creep_forces(contact: ExactContact, creepage: Any, lateral: Any = 0.0,
                       spin: Any = 0.0, grid: ExactGrid | None = None, *, chunk: int = 8,
                       keep_solutions: bool = False) -> ExactResult:
    """Creep forces by Kalker's exact theory with their discretisation error (module docstring).

    Parameters
    ----------
    contact
        The contact (:class:`ExactContact`).
    creepage, lateral, spin
        Longitudinal and lateral creepage (fractions) and spin [1/m], broadcast.
    grid
        The grids (:class:`ExactGrid`).
    chunk
        Points solved one after the other (each from the previous solution) in one
        task; the tasks run on :func:`torlab.parallel.current`'s executor.  The split
        depends on the points only, so results do not depend on the number of workers.
    keep_solutions
        Keep the fine-grid solutions (tractions, slip, element division).

    Returns
    -------
    ExactResult

    Raises
    ------
    ValueError
        A contact the solver cannot take, or non-finite creepages.
    ConvergenceError
        The solver did not converge on a point.
    """
    from torlab import parallel

    grid = grid or ExactGrid()
    contact.check()
    if grid.n < 4 or (grid.n_coarse and not 2 <= grid.n_coarse < grid.n):
        raise ValueError(f"grid: need n >= 4 and 2 <= coarse < n, got n={grid.n}, "
                         f"coarse={grid.n_coarse}")
    xi_in, eta_in, phi_in = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                                  for v in (creepage, lateral, spin)))
    shape = xi_in.shape
    pts = np.stack([xi_in.ravel(), eta_in.ravel(), phi_in.ravel()], axis=1)
    if not np.all(np.isfinite(pts)):
        raise ValueError("creepages must be finite")
    tasks = [(contact, grid, pts[s], keep_solutions) for s in parallel.chunks(len(pts), chunk)]
    outs = parallel.current().map(_solve_chunk, tasks, description="exact creep forces")
    cat = {k: np.concatenate([o[k] for o in outs], axis=-1)
           for k in ("Fx", "Fy", "Mz", "adh", "pl", "tmax", "its", "looped")}
    nf, nc = grid.n, grid.n_coarse
    res = {}
    for k in ("Fx", "Fy", "Mz"):
        fine = cat[k][0]
        if nc:
            err = np.abs(fine - cat[k][1]) * nc / (nf - nc)
        else:
            err = np.full(fine.shape, np.nan)
        res[k] = fine.reshape(shape)
        res[k + "_error"] = err.reshape(shape)
    N = contact.load
    notes = [f"Kalker's exact theory (steady rolling, quasi-identical elastic half-spaces), "
             f"{nf}x{nf} elements on the ellipse, discretisation error from a second grid of "
             f"{nc}x{nc}" if nc else f"{nf}x{nf} elements, no discretisation error estimate",
             "normal pressure: " + ("discrete half-space solution for the Hertz geometry"
                                    if grid.normal == "discrete" else "Hertz at element centres"),
             f"friction: Coulomb, mu = {contact.mu:g}" if math.isfinite(contact.mu)
             else "friction: no Coulomb bound"]
    if contact.layer is not None:
        notes.append(f"{contact.layer.name} in series with the half-space")
    tmax = its = None
    loop = "off"
    if contact.thermal is not None:
        tmax, its = cat["tmax"].reshape(shape), cat["its"].reshape(shape)
        loop = "iterated" if np.any(cat["looped"]) else "single pass"
        notes.append(thermal_note(loop, contact.thermal, contact.coupled))
    sols = [s for o in outs for s in o["solutions"]] if keep_solutions else None
    return ExactResult(creepage=xi_in.copy(), lateral=eta_in.copy(), spin=phi_in.copy(),
                       Fx=res["Fx"], Fy=res["Fy"], Mz=res["Mz"], Fx_error=res["Fx_error"],
                       Fy_error=res["Fy_error"], Mz_error=res["Mz_error"],
                       mu_x=res["Fx"] / N, mu_y=res["Fy"] / N,
                       adhesion_fraction=cat["adh"].reshape(shape),
                       plastic_fraction=cat["pl"].reshape(shape), load=N, grid=grid,
                       notes=notes, solutions=sols, max_temperature_C=tmax,
                       temperature_iterations=its, temperature_loop=loop)
