"""A scene's creep forces by Kalker's exact theory: the entry the rest of torlab calls.

:func:`exact_contact` resolves a dry scene (``boundary:``, no ``lubricant:``) into the
exact solver's :class:`~torlab.model.exact.rolling.ExactContact`: the Hertz patch and
Kalker's combined ``G`` and ``nu`` of :func:`torlab.model.contact.build_contact`, and the
third-body layer of the ``boundary:`` section in series with the half-space, read
through the one interface of the layer laws (:mod:`torlab.model.layers`, whichever law
the scene names):

* its elastic flexibility ``L_e = L_mue / p`` (thesis Eq. 5.28,
  :meth:`~torlab.model.layers.LayerLaw.elastic_flexibility`), element by element;
* its yield stress against the accumulated plastic deformation ``kappa``
  (:meth:`~torlab.model.layers.LayerLaw.yield_stress`: for Voce's law, the stress of one
  element loaded at a constant pressure along the law's HPT curve) and the plastic step
  of a yielding element (:meth:`~torlab.model.layers.LayerLaw.return_map` with the
  element's own stiffness in the scheme), at each element's temperature: with a
  ``thermal:`` section the contact temperature (Ertz and Knothe's strip solution on the
  solver's grid, the scene's partition and slip velocity, thesis Eqs. 5.49-5.50) enters
  the limits through their temperature coefficients (Eqs. 5.26-5.27) and the coupling
  is iterated to the scene's tolerance (:mod:`torlab.model.exact.thermal`); without one,
  or with zero coefficients, the limits are the ambient temperature's, and the output
  says which.

The layer's yield stress is the friction: there is no separate Coulomb coefficient
(``mu = inf``).  :func:`predict_exact` returns the same
:class:`~torlab.model.prediction.TractionPrediction` as the FASTSIM path
(:func:`torlab.model.creep.predict_creep`), with the forces' discretisation errors in
the table.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.model.exact.rolling import ExactContact, ExactGrid, ExactLayer, exact_creep_forces
from torlab.model.exact.temperature import ThermalBody
from torlab.model.exact.thermal import ExactThermal

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["LawYield", "exact_contact", "predict_exact", "scene_layer", "scene_thermal"]


class LawYield:
    """A layer law of :mod:`torlab.model.layers` as the exact solver's yield law
    (:class:`~torlab.model.exact.local.YieldLaw`): the element parameter ``c1`` is the
    pressure [Pa], ``c2`` the element's temperature rise above the ambient [K] (the
    limits' ``exp(mu_T dT)`` of thesis Eqs. 5.26-5.27; 0 without a contact temperature);
    ``lay`` the law's values (:class:`~torlab.model.layers.LayerParams`)."""

    #: ``c2`` is the element's temperature rise (:mod:`torlab.model.exact.thermal`)
    takes_temperature = True

    def __init__(self, lay: Any) -> None:
        self.lay = lay
        self.law = lay.law

    @property
    def sensitivity(self) -> float:
        """The largest ``|temperature coefficient|`` [1/K]."""
        return float(self.law.temperature_sensitivity(self.lay))

    @property
    def growth(self) -> float:
        """The largest positive temperature coefficient [1/K] (0 where none is)."""
        return float(max([0.0, *(float(np.max(c)) for c in
                                  self.law.temperature_coefficients(self.lay))]))

    def stress(self, kappa, c1, c2):
        dT = 0.0 if c2 is None else c2
        return (self.law.yield_stress(self.lay, c1, kappa, dT),
                self.law.hardening_modulus(self.lay, c1, kappa, dT))

    def plastic_step(self, mag, kappa0, r, c1, c2):
        """The law's return map with the element's stiffness ``r`` [Pa/m]."""
        dT = 0.0 if c2 is None else c2
        tau, dk = self.law.return_map(self.lay, c1, mag, kappa0, r, dT)
        return np.abs(tau), dk, self.law.hardening_modulus(self.lay, c1, kappa0 + dk, dT)

    def reaching(self, tau, c1, c2):
        """The plastic deformation at which the yield stress reaches ``tau`` (bisection up to
        1 m, inf where it never does)."""
        tau = np.asarray(tau, dtype=float)
        lo, hi = np.zeros(tau.shape), np.full(tau.shape, 1.0)
        ok = (self.stress(hi, c1, c2)[0] >= tau) & (self.stress(lo, c1, c2)[0] < tau)
        if not ok.any():
            return np.full(tau.shape, np.inf)
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            below = self.stress(mid, c1, c2)[0] < tau
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return np.where(ok, 0.5 * (lo + hi), np.inf)


class LawFlexibility:
    """The layer law's elastic flexibility [m/Pa] against the pressure [Pa] (thesis Eq.
    5.28), a picklable callable: a curve's chunks go to worker processes."""

    def __init__(self, lay: Any) -> None:
        self.lay = lay

    def __call__(self, p: Any) -> Any:
        return self.lay.law.elastic_flexibility(self.lay, p)


def scene_layer(boundary: Any) -> ExactLayer:
    """The exact solver's layer of a scene's ``boundary:`` section (module docstring)."""
    lay = boundary.layer
    law = lay.law
    return ExactLayer(flexibility=None, flexibility_of=LawFlexibility(lay),
                      law=LawYield(lay), c1=1.0, c2=0.0, per_pressure=True,
                      name=f"third-body layer ({law.name} law: "
                           f"{', '.join(law.names)})")


def exact_contact(scene: Scene, contact: Any = None) -> ExactContact:
    """The :class:`ExactContact` of a dry scene (module docstring).

    Raises
    ------
    TorlabInputError
        The scene has no ``boundary:`` section or is lubricated.
    """
    from torlab.model.contact import build_contact

    if scene.boundary is None:
        raise TorlabInputError("the exact solver needs a boundary: section (mu_c1, mu_c2, "
                               "L_mue, L_mup)", key="boundary")
    if scene.lubricant is not None:
        raise TorlabInputError("the exact solver models dry (third-body layer) scenes only: "
                               "remove the lubricant: section", key="lubricant")
    contact = contact or build_contact(scene)
    p = contact.patch
    layer = scene_layer(scene.boundary)
    return ExactContact(a=p.a, b=p.b, load=p.F, G=contact.G, nu=contact.nu, mu=math.inf,
                        layer=layer, thermal=scene_thermal(scene, layer))


def scene_thermal(scene: Scene, layer: ExactLayer) -> ExactThermal | None:
    """The contact temperature of a scene's ``thermal:`` section on the exact solver's
    grid (:class:`~torlab.model.exact.thermal.ExactThermal`; None without one): the
    bodies' thermal data, the rolling speed, the ambient temperature, the heat partition,
    the slip velocity, the tolerance and the iteration budget as FASTSIM's path takes
    them, and the layer's largest temperature coefficient."""
    th = scene.thermal
    if th is None:
        return None
    body = ThermalBody(conductivity=th.conductivity, density=th.density,
                       heat_capacity=th.heat_capacity,
                       bulk_temperature=scene.kinematics.ambient_temperature)
    return ExactThermal(speed=scene.kinematics.speed, body=body, partition=th.partition,
                        slip_velocity=th.slip_velocity, sensitivity=layer.law.sensitivity,
                        growth=layer.law.growth,
                        tolerance=th.tolerance, max_iterations=th.max_iterations)


def predict_exact(scene: Scene, creepage: Any, lateral: float = 0.0, spin: float = 0.0,
                  grid: ExactGrid | None = None) -> Any:
    """Creep forces of a dry scene by Kalker's exact theory along a creepage curve.

    Parameters
    ----------
    scene
        A validated dry :class:`~torlab.scene.Scene`.
    creepage
        Longitudinal creepages (fractions).
    lateral, spin
        Lateral creepage (fraction) and spin [1/m], the same for every point.
    grid
        The two grids (:class:`~torlab.model.exact.rolling.ExactGrid`).

    Returns
    -------
    torlab.model.prediction.TractionPrediction
        ``table`` with ``creepage``, ``mu`` (= ``mu_x``), ``lateral``, ``spin_1_m``,
        ``mu_x``, ``mu_y``, ``Fx_N``, ``Fy_N``, ``Mz_Nm``, their errors ``Fx_error_N``,
        ``Fy_error_N``, ``Mz_error_Nm`` and ``mu_x_error``, ``adhesion_fraction``,
        ``plastic_fraction`` and, with ``thermal:``, ``max_temperature_C`` (the largest
        contact temperature the layer sees [°C]).

    Raises
    ------
    ConvergenceError
        The solver, or the contact temperature's coupling to the limits, did not
        converge on a point.
    """
    from torlab import __version__
    from torlab.model.contact import build_contact
    from torlab.model.prediction import TractionPrediction, scene_trend

    xi = np.atleast_1d(np.asarray(creepage, dtype=float))
    contact = build_contact(scene)
    ec = exact_contact(scene, contact)
    grid = grid or ExactGrid()
    r = exact_creep_forces(ec, xi, lateral, spin, grid)
    table = r.table()
    table.insert(1, "mu", r.mu_x)
    table.insert(table.columns.get_loc("mu_y") + 1, "mu_x_error", r.Fx_error / r.load)
    notes = [n for n in r.notes if not n.startswith("contact temperature")]
    thermal = ([n for n in r.notes if n.startswith("contact temperature")]
               or ["contact temperature: not modelled (no thermal: section)"])
    modelled = [f"Hertz contact ({contact.patch.method})", *notes,
                "EHL film: not modelled (dry scene, no lubricant:)", *thermal]
    trend = scene_trend(scene, xi, r.mu_x)
    summary = {"torlab_version": __version__, "scene": scene.name, "method": "exact",
               "contact": contact.summary(), "modelled": modelled, "notes": list(contact.notes),
               "lateral": float(lateral), "spin_1_m": float(spin),
               "grid": {"n": grid.n, "coarse": grid.n_coarse, "normal": grid.normal},
               "mu_max": float(np.max(np.hypot(r.mu_x, r.mu_y))),
               "discretisation_error_mu_max": float(np.max(r.Fx_error / r.load)),
               "trend_after_saturation": trend, "boundary": scene.boundary.model_dump()}
    if r.temperature_iterations is not None:
        summary["temperature_iterations_max"] = int(np.max(r.temperature_iterations))
    return TractionPrediction(table=table, contact=contact, modelled=modelled, trend=trend,
                              summary=summary)
