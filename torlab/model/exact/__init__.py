"""Kalker's exact theory of steady rolling contact (CONTACT's discretisation), in torlab.

Modules: :mod:`.influence` (the half-space's influence coefficients and their FFT
products), :mod:`.grid` (the grid, Hertz's pressure), :mod:`.normal` (the
normal problem), :mod:`.local` (the friction and layer law of one element),
:mod:`.solver` (steady rolling and shifts on the grid), :mod:`.rolling` (creep
forces of a Hertzian contact with their discretisation error), :mod:`.temperature` (the
surface temperatures of both bodies from a solution's frictional heat), :mod:`.thermal`
(the contact temperature fed back into a third-body layer's limits).
``docs/model/exact.md`` explains the theory, the solver and its accuracy.

References
----------
.. [1] Kalker, J. J. (1990). Three-Dimensional Elastic Bodies in Rolling Contact. Solid
   Mechanics and its Applications 2, Kluwer, Dordrecht.
   https://doi.org/10.1007/978-94-015-7889-9
"""

from torlab.model.exact.local import LinearYield, VoceYield
from torlab.model.exact.rolling import (
                                        ExactContact,
                                        ExactGrid,
                                        ExactLayer,
                                        ExactResult,
                                        exact_creep_forces,
                                        normalised_creepages,
                                        solve_point,
)
from torlab.model.exact.temperature import SurfaceTemperature, ThermalBody, surface_temperature

__all__ = ["ExactContact", "ExactGrid", "ExactLayer", "ExactResult", "LinearYield",
           "SurfaceTemperature", "ThermalBody", "VoceYield", "exact_creep_forces",
           "normalised_creepages", "solve_point", "surface_temperature"]
