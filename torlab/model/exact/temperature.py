"""Surface temperatures of both bodies on the exact solver's grid (Ertz and Knothe's model).

The frictional heat of a solved steady rolling contact (:func:`~torlab.model.exact.solver.solve`)
heats the surfaces of both bodies as they pass through the contact.  Each row of elements
(a strip ``y = const``) is a strip of the thesis's flash temperature (Eqs. 5.49-5.50;
``docs/model/thesis-reading.md``): at the high Péclet numbers of rolling contact a
surface particle conducts heat only into the depth, so its temperature rise at the
distance ``X`` from the leading edge is

    dT(X) = 1 / ((beta1 + beta2) sqrt(pi v)) * integral_0^X q(X') / sqrt(X - X') dX'

with ``q = |p| |s|`` the frictional heat flux [W/m^2] (the traction times the local slip
velocity, the deformation's share included), ``v`` the rolling speed [m/s] and
``beta = sqrt(lambda rho c)`` each body's thermal effusivity [W s^0.5/(m^2 K)].  The heat
splits between the bodies in the ratio of their effusivities, ``beta1 / (beta1 + beta2)``
into body 1, which keeps the two surfaces at one temperature in the contact (Ertz and
Knothe 2002, without their correction for the bodies' different speeds).

Two bulk temperatures ``T1``, ``T2`` [°C]: a surface entering the contact takes at once
the temperature of two half-spaces brought into perfect thermal contact,
``Tm = (beta1 T1 + beta2 T2) / (beta1 + beta2)``, and keeps it through the strip of length
``L``; behind it (the surface insulated again) each body relaxes back to its bulk,

    T_k(X) = T_k + (Tm - T_k) (2/pi) arcsin(sqrt(L / X)),   X > L,

the surface temperature of a half-space held at ``Tm`` for the time ``L/v`` (the flux
``beta (Tm - T_k) / sqrt(pi t)`` of that time, continued by the same kernel).  The
frictional heating adds to it in and behind the contact.

Discretisation: the flux is constant on each element (the solver's tractions and slips);
the temperature is taken at the element centres.  An element ``k`` elements upstream
contributes the exact integral over its length, ``2 (sqrt((k + 1/2) dx) - sqrt((k - 1/2)
dx))``; the element's own flux counts from its upstream edge to its centre,
``2 sqrt(dx/2)`` (``own_element="centre"``).  CONTACT counts the element's own flux with
twice that weight (``own_element="contact"``, for comparison with its printed results): its
temperatures exceed the converged ones by a share that falls as ``sqrt(dx/a)``, +9 % on
the 59 elements of the Ertz-Knothe example's strip (``docs/model/exact.md``).

References
----------
.. [1] Ertz, M., Knothe, K. (2002). A comparison of analytical and numerical methods for
   the calculation of temperatures in wheel/rail contact. Wear 253(3-4), 498-508.
   https://doi.org/10.1016/S0043-1648(02)00120-3
.. [2] Carslaw, H.S., Jaeger, J.C. (1959). Conduction of Heat in Solids, 2nd ed.,
   section 2.5 (flux into a half-space) and 10.7 (moving sources). Oxford.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from torlab.model.exact.solver import ADHESION, EXTERIOR, Solution

__all__ = ["SurfaceTemperature", "ThermalBody", "frictional_heat", "surface_temperature"]


@dataclass(frozen=True)
class ThermalBody:
    """One body's thermal properties and bulk temperature (Tab. 5.4's steel by default).

    Attributes
    ----------
    conductivity
        Heat conductivity ``lambda`` [W/(m K)].
    density
        ``rho`` [kg/m^3].
    heat_capacity
        ``c`` [J/(kg K)].
    bulk_temperature
        Temperature of the body away from the contact [°C].
    """

    conductivity: float = 50.0
    density: float = 7850.0
    heat_capacity: float = 450.0
    bulk_temperature: float = 20.0

    @property
    def effusivity(self) -> float:
        """``beta = sqrt(lambda rho c)`` [W s^0.5/(m^2 K)]."""
        return math.sqrt(self.conductivity * self.density * self.heat_capacity)

    def check(self) -> None:
        """Raise ``ValueError`` unless the properties are positive and finite."""
        for name in ("conductivity", "density", "heat_capacity"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if not math.isfinite(self.bulk_temperature):
            raise ValueError(f"bulk_temperature must be finite, got {self.bulk_temperature!r}")


@dataclass(frozen=True)
class SurfaceTemperature:
    """Surface temperatures of a solved contact (:func:`surface_temperature`).

    Attributes
    ----------
    body1, body2
        Surface temperature of each body at the element centres ``(mx, my)`` [°C]: bulk
        ahead of the contact, the contact temperature and its frictional rise in it, the
        relaxation behind it.
    contact
        The elements in contact ``(mx, my)``.
    heat_flux
        Frictional heat flux of the elements ``(mx, my)`` [W/m^2] (both bodies together).
    power
        Frictional power of the contact [W].
    entry_temperature
        ``Tm``, the temperature both surfaces take on entering the contact [°C].
    partition
        Share of the frictional heat that goes into body 1 [-].
    own_element
        How an element's own flux was counted (module docstring).
    """

    body1: np.ndarray
    body2: np.ndarray
    contact: np.ndarray
    heat_flux: np.ndarray
    power: float
    entry_temperature: float
    partition: float
    own_element: str

    @property
    def max_temperature(self) -> float:
        """The largest surface temperature of either body in the contact [°C]."""
        if not self.contact.any():
            return self.entry_temperature
        return float(max(self.body1[self.contact].max(), self.body2[self.contact].max()))


def frictional_heat(solution: Solution, speed: float, plastic_heat: float = 1.0) -> np.ndarray:
    """Frictional heat flux ``q = |p| |s|`` of each element ``(mx, my)`` [W/m^2].

    ``s`` is the element's slip velocity, its slip over the scheme's step of one element
    length times ``speed / dx`` (the deformation's share included); where a third-body
    layer flows plastically, the fraction ``plastic_heat`` of its plastic work is heat
    (CONTACT's ``BETAPL``; 1: the layer's shear is the sliding, all of it dissipated).

    Parameters
    ----------
    solution
        The solved steady rolling contact (CONTACT's signs).
    speed
        Rolling speed ``v`` [m/s].
    plastic_heat
        Fraction of the plastic work that becomes heat [-], in [0, 1].
    """
    if not 0.0 <= plastic_heat <= 1.0:
        raise ValueError(f"plastic_heat must lie in [0, 1], got {plastic_heat!r}")
    slip = np.linalg.norm(solution.sigma, axis=-1)
    if plastic_heat < 1.0:
        slip = np.maximum(slip - (1.0 - plastic_heat) * np.linalg.norm(solution.plastic, axis=-1),
                          0.0)
    q = np.linalg.norm(solution.p, axis=-1) * slip * (speed / solution.grid.dx)
    return np.where(solution.state == ADHESION, 0.0, q)


def _march_weights(mx: int, dx: float, own_element: str) -> np.ndarray:
    """Upper-triangular ``K`` [m^0.5]: ``(K @ q)_i`` is the integral of ``q(X') /
    sqrt(X_i - X')`` over the elements upstream of centre ``i`` and the element's own
    (material enters at the large index: the solver's contact rolls in ``+x``)."""
    k = np.arange(mx, dtype=float)
    w = 2.0 * (np.sqrt((k + 0.5) * dx) - np.sqrt(np.maximum(k - 0.5, 0.0) * dx))
    w[0] = (4.0 if own_element == "contact" else 2.0) * math.sqrt(dx / 2)
    idx = np.arange(mx)
    offset = idx[None, :] - idx[:, None]          # j - i: elements upstream of i
    return np.where(offset >= 0, w[np.clip(offset, 0, None)], 0.0)


def _conduction(contact: np.ndarray, dx: float, bulk: float, entry: float) -> np.ndarray:
    """The surface temperature of one body without frictional heat ``(mx, my)`` [°C]: bulk
    ahead of each strip, ``entry`` from its first to its last element in contact, the
    relaxation to bulk behind it."""
    T = np.full(contact.shape, bulk, dtype=float)
    for j in np.flatnonzero(contact.any(axis=0)):
        ix = np.flatnonzero(contact[:, j])
        lead, trail = ix.max(), ix.min()          # material enters at the large index
        T[trail: lead + 1, j] = entry
        L = (lead - trail + 1) * dx
        X = L + (trail - np.arange(trail) - 0.5) * dx   # distance from the leading edge
        T[:trail, j] = bulk + (entry - bulk) * (2 / math.pi) * np.arcsin(np.sqrt(L / X))
    return T


def surface_temperature(solution: Solution, speed: float, body1: ThermalBody | None = None,
                        body2: ThermalBody | None = None, *, plastic_heat: float = 1.0,
                        own_element: Literal["centre", "contact"] = "centre",
                        partition: float | None = None, heat_flux: np.ndarray | None = None
                        ) -> SurfaceTemperature:
    """Surface temperatures of both bodies of a solved steady rolling contact (module
    docstring; Ertz and Knothe 2002, Eqs. 5.49-5.50 of the thesis per strip).

    Parameters
    ----------
    solution
        The solved steady rolling contact (:func:`~torlab.model.exact.solver.solve`,
        rolling in ``+x``).
    speed
        Rolling speed ``v`` [m/s] (the particles' speed through the contact).
    body1, body2
        Each body's thermal properties and bulk temperature (default: Tab. 5.4's steel at
        20 °C; ``body2`` defaults to ``body1``).
    plastic_heat
        Fraction of a third-body layer's plastic work that becomes heat [-].
    own_element
        ``"centre"`` (default, converged): an element's own flux counts up to its
        centre; ``"contact"``: with CONTACT's weight, twice that, to compare with its
        printed temperatures.
    partition
        Share of the frictional heat that goes into body 1 [-], the rest into body 2
        (the thesis's Eq. 5.50 sends all of it into the body it describes: 1).  None
        (default): by the effusivities, ``beta1 / (beta1 + beta2)``, which keeps both
        surfaces at one temperature in the contact (Ertz and Knothe).
    heat_flux
        The heat flux ``(mx, my)`` [W/m^2] to use instead of the solution's
        :func:`frictional_heat` (e.g. the thesis's ``q = tau w`` with the rigid slip
        velocity ``w``, Eq. 5.49).

    Returns
    -------
    SurfaceTemperature
    """
    if own_element not in ("centre", "contact"):
        raise ValueError(f"own_element must be 'centre' or 'contact', got {own_element!r}")
    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"speed must be positive and finite, got {speed!r}")
    body1 = body1 or ThermalBody()
    body2 = body2 or body1
    body1.check()
    body2.check()
    b1, b2 = body1.effusivity, body2.effusivity
    grid = solution.grid
    if partition is not None and not 0.0 <= partition <= 1.0:
        raise ValueError(f"partition must lie in [0, 1], got {partition!r}")
    q = frictional_heat(solution, speed, plastic_heat) if heat_flux is None else heat_flux
    contact = solution.state != EXTERIOR
    K = _march_weights(grid.mx, grid.dx, own_element)
    if partition is None:  # by effusivity: both surfaces at one temperature
        rise1 = rise2 = (K @ q) / ((b1 + b2) * math.sqrt(math.pi * speed))
        share = b1 / (b1 + b2)
    else:
        integral = (K @ q) / math.sqrt(math.pi * speed)
        rise1 = partition * integral / b1
        rise2 = (1.0 - partition) * integral / b2
        share = float(partition)
    entry = (b1 * body1.bulk_temperature + b2 * body2.bulk_temperature) / (b1 + b2)
    T1 = _conduction(contact, grid.dx, body1.bulk_temperature, entry) + rise1
    T2 = _conduction(contact, grid.dx, body2.bulk_temperature, entry) + rise2
    return SurfaceTemperature(body1=T1, body2=T2, contact=contact, heat_flux=q,
                              power=float(q.sum() * grid.area), entry_temperature=entry,
                              partition=share, own_element=own_element)
