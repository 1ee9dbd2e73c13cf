"""The contact temperature fed back into the layer's limits on the exact solver's grid.

A third-body layer's limits follow the temperature of the contact (thesis Eqs.
5.26-5.27: ``tau_c1 = mu_c1 p exp(mu_c1_T (T - T_A))``, likewise ``tau_c2``), and the
temperature follows the frictional heat, which follows the traction.  FASTSIM's path
closes that loop strip by strip (:mod:`torlab.model.flash`); this module closes it on
the exact solver's elements:

1. solve the steady rolling contact with the limits at the temperature field ``dT``
   (each element's own temperature rise above the ambient ``T_A``, the layer law's
   ``dT``: :class:`~torlab.model.exact.scene.LawYield` takes it as the element
   parameter ``c2``), starting from the previous traction;
2. the heat flux of each element, the thesis's ``q = |tau| |w|`` with the rigid slip
   velocity ``w`` (Eq. 5.49, the scene's ``slip_velocity: rigid``, the default) or the
   solver's own local slip velocity, zero where an element sticks (``local``);
3. the contact temperature the layer sees: the surface temperature of the body the
   heat partition describes (:func:`~torlab.model.exact.temperature.surface_temperature`,
   Ertz and Knothe's strip solution along each row of elements, Eq. 5.50, with the
   scene's partition: 1 in the thesis, into the body it describes; FASTSIM's path uses
   the same formula, partition and flux on its strips);
4. fixed point on the field, ``dT = G(dT)``: Anderson's mixing of the last three steps
   (Walker and Ni 2011) while the largest residual falls by 10 % a step; where it does
   not, the history is dropped and the step under-relaxed, ``dT <- dT + omega (G(dT) -
   dT)``, ``omega`` halved each time (FASTSIM's rule); no step changes the limits by more
   than a factor e (``s max |step| <= 1``).  Until ``max |G(dT) - dT|`` over the contact
   is below the tolerance [K] (the scene's ``thermal: tolerance``, 0.1 K).  The answer is
   the solution at ``dT`` and the temperature it produces, ``G(dT)``.

No loop where one pass shows the heating cannot change the limits: with the largest
temperature coefficient ``s`` [1/K] and the first pass's largest rise ``dT1``,
``s dT1 < 1e-6`` (zero coefficients included) reports that pass (``"single pass"``),
as FASTSIM's path does.  A first pass with ``s dT1 > 30`` (the limits would change by
``exp(30)``), a non-finite temperature, or no convergence within the iteration budget
raise :class:`~torlab.errors.ConvergenceError` naming the point.

References
----------
.. [1] Ertz, M., Knothe, K. (2002). A comparison of analytical and numerical methods for
   the calculation of temperatures in wheel/rail contact. Wear 253(3-4), 498-508.
   https://doi.org/10.1016/S0043-1648(02)00120-3
.. [2] Walker, H.F., Ni, P. (2011). Anderson acceleration for fixed-point iterations. SIAM
   Journal on Numerical Analysis 49(4), 1715-1735. https://doi.org/10.1137/10078356X
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from torlab.errors import ConvergenceError
from torlab.model.exact.solver import EXTERIOR, Solution
from torlab.model.exact.temperature import ThermalBody, surface_temperature

__all__ = ["SINGLE_PASS", "ExactThermal", "ThermalPoint", "solve_thermal", "thermal_note"]

#: ``sensitivity * first pass's largest rise`` below which no loop is run (FASTSIM's rule)
SINGLE_PASS = 1e-6
#: largest ``|coefficient * dT|``: exp(30) = 1e13 changes of the limits are a runaway
_MAX_EXPONENT = 30.0


@dataclass(frozen=True)
class ExactThermal:
    """The contact temperature's model and its coupling to the layer's limits.

    Attributes
    ----------
    speed
        Rolling speed ``v`` [m/s] (> 0).
    body
        The bodies' thermal properties (both alike, the scene's ``thermal:``); its
        ``bulk_temperature`` is the ambient ``T_A`` [°C].
    partition
        Share of the frictional heat into the body whose temperature the layer sees
        [-] (Eq. 5.50: 1; 0.5 for equal bodies by Ertz and Knothe's split).
    slip_velocity
        ``"rigid"`` (Eq. 5.49: ``q = |tau| |w|``, ``w`` the rigid slip velocity) or
        ``"local"`` (the solver's slip velocity, zero in adhesion).
    sensitivity
        The layer's largest ``|temperature coefficient|`` [1/K]; 0: no coupling.
    growth
        The layer's largest positive temperature coefficient [1/K] (0: the limits only
        soften with heat, which limits the heating itself: no runaway).
    tolerance
        ``max |G(dT) - dT|`` at convergence [K].
    max_iterations
        Solves of one point before :class:`~torlab.errors.ConvergenceError`.
    """

    speed: float
    body: ThermalBody
    partition: float = 1.0
    slip_velocity: str = "rigid"
    sensitivity: float = 0.0
    growth: float = 0.0
    tolerance: float = 0.1
    max_iterations: int = 200

    @property
    def ambient(self) -> float:
        """``T_A`` [°C]."""
        return self.body.bulk_temperature


@dataclass
class ThermalPoint:
    """One point's coupled solution.

    Attributes
    ----------
    solution
        The solution with the limits at ``dT`` (the converged field).
    rise
        The temperature rise ``G(dT)`` this solution produces ``(mx, my)`` [K].
    max_temperature
        The largest contact temperature ``T_A + max G(dT)`` over the contact [°C].
    iterations
        Solves (1: one pass).
    loop
        ``"single pass"`` or ``"iterated"``.
    """

    solution: Solution
    rise: np.ndarray
    max_temperature: float
    iterations: int
    loop: str


def _rise(sol: Solution, th: ExactThermal, rigid_speed: np.ndarray | None) -> np.ndarray:
    """``G``: the contact temperature rise [K] of a solution (module docstring, 3.)."""
    q = None
    if th.slip_velocity == "rigid":
        q = np.linalg.norm(sol.p, axis=-1) * rigid_speed
        q = np.where(sol.state == EXTERIOR, 0.0, q)
    st = surface_temperature(sol, th.speed, th.body, th.body, partition=th.partition,
                             heat_flux=q)
    return np.where(st.contact, st.body1 - th.ambient, 0.0)


def solve_thermal(solve_at: Callable[[np.ndarray | None, np.ndarray | None], Solution],
                  th: ExactThermal, rigid_slip: np.ndarray, where: str,
                  p0: np.ndarray | None = None, dT0: np.ndarray | None = None
                  ) -> ThermalPoint:
    """Solve one point with the contact temperature in the layer's limits (module docstring).

    Parameters
    ----------
    solve_at
        ``solve_at(dT, p0)``: the solution with the limits at the rise ``dT`` ``(mx, my)``
        [K] (None: at the ambient temperature), starting from the traction ``p0``.
    th
        The thermal model.
    rigid_slip
        The rigid slip over one step ``(mx, my, 2)`` [m] (CONTACT's ``W``).
    where
        The point, for messages.
    p0
        Traction to start the first solve from.
    dT0
        Temperature rise ``(mx, my)`` [K] to start from (a neighbouring point's converged
        field); None: the ambient temperature, the first pass of the module docstring.

    Returns
    -------
    ThermalPoint

    Raises
    ------
    ConvergenceError
        Thermal runaway, a non-finite temperature, or no convergence within
        ``th.max_iterations`` solves.
    """
    sol = solve_at(dT0, p0)
    if not th.speed > 0:  # no rolling, no heat
        zero = np.zeros(sol.state.shape)
        return ThermalPoint(sol, zero, th.ambient, 1, "single pass")
    w = np.linalg.norm(rigid_slip, axis=-1) * (th.speed / sol.grid.dx)  # |w| [m/s]
    new = _rise(sol, th, w)
    sens = th.sensitivity
    peak = float(np.max(np.abs(new)))
    if not np.isfinite(peak):
        raise ConvergenceError(f"contact temperature is not finite at {where}", iterations=1)
    if sens * peak < SINGLE_PASS:
        return ThermalPoint(sol, new, th.ambient + float(np.max(new)), 1, "single pass")
    if th.growth * peak > _MAX_EXPONENT:
        raise ConvergenceError(
            f"contact temperature runs away at {where}: the first pass already heats by "
            f"{peak:.3g} K, and a temperature coefficient of {th.growth:.3g} 1/K would raise the "
            f"limits by a factor exp({_MAX_EXPONENT:g})", iterations=1)
    dT = np.zeros_like(new) if dT0 is None else dT0
    omega, res_prev = 1.0, np.inf
    hist: list[tuple[np.ndarray, np.ndarray]] = []   # (residual, G) of the last steps
    for k in range(1, th.max_iterations):
        diff = new - dT
        res = float(np.max(np.abs(diff)))
        if res < th.tolerance:
            return ThermalPoint(sol, new, th.ambient + float(np.max(new)), k, "iterated")
        if res > 0.9 * res_prev:
            omega = max(0.5 * omega, 1.0 / 1024)
            hist.clear()
        res_prev = res
        step = _anderson(hist, diff, new, dT) if omega == 1.0 else omega * diff
        # a step changes the limits by at most a factor e (strong coefficients)
        big = sens * float(np.max(np.abs(step)))
        dT = dT + (step if big <= 1.0 else step / big)
        sol = solve_at(dT, sol.p)
        new = _rise(sol, th, w)
        if not np.all(np.isfinite(new)) or th.growth * float(np.max(new)) > _MAX_EXPONENT:
            raise ConvergenceError(
                f"contact temperature diverged at {where} (thermal runaway: the temperature "
                f"coefficients make frictional heating self-amplifying)", iterations=k + 1)
    res = float(np.max(np.abs(new - dT)))
    if res < th.tolerance:
        return ThermalPoint(sol, new, th.ambient + float(np.max(new)), th.max_iterations,
                            "iterated")
    raise ConvergenceError(
        f"contact temperature did not converge at {where}: max |dT| = {res:.3g} K after "
        f"{th.max_iterations} solves (relaxation {omega:.3g}); the layer's temperature "
        "coefficients make the heating unstable at this slip",
        iterations=th.max_iterations, residual=res)


def _anderson(hist: list[tuple[np.ndarray, np.ndarray]], f: np.ndarray, g: np.ndarray,
              x: np.ndarray, depth: int = 3) -> np.ndarray:
    """The step of Anderson's mixing (Walker and Ni 2011) from ``x`` with the residual
    ``f = G(x) - x`` and ``g = G(x)``: ``G(x) - x - dG gamma`` with ``gamma`` the least-squares
    fit of ``f`` by the last ``depth`` differences of the residuals ``dF``; the plain step
    ``f`` while there is no history.  ``hist`` is updated in place."""
    hist.append((f.ravel().copy(), g.ravel().copy()))
    if len(hist) > depth + 1:
        del hist[0]
    if len(hist) < 2:
        return f
    F = np.stack([h[0] for h in hist], axis=1)
    G = np.stack([h[1] for h in hist], axis=1)
    dF, dG = np.diff(F, axis=1), np.diff(G, axis=1)
    gamma, *_ = np.linalg.lstsq(dF, f.ravel(), rcond=None)
    return (g.ravel() - dG @ gamma).reshape(x.shape) - x


def thermal_note(loop: str, th: ExactThermal, coupled: bool) -> str:
    """What the output says of the contact temperature (the FASTSIM path's words,
    :func:`torlab.model.prediction.temperature_note`, and the model's own)."""
    how = (f"Ertz-Knothe strip solution on the exact solver's grid, q = tau w with the "
           f"{'rigid' if th.slip_velocity == 'rigid' else 'local'} slip velocity, "
           f"heat partition {th.partition:g}")
    if loop == "single pass":
        why = ("the temperature coefficients are zero" if not coupled else
               f"the heating changes the limits by less than {SINGLE_PASS:g}")
        return f"contact temperature: computed once, no tau-T loop ({why}; {how})"
    return (f"contact temperature: coupled to the limits, iterated to convergence "
            f"(max |dT| < {th.tolerance:g} K; {how})")
