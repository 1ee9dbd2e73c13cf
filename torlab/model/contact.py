"""From a scene to the numbers the physics needs: Hertz patch, moduli, Kalker flexibility.

:func:`build_contact` resolves a :class:`~torlab.scene.Scene` into a
:class:`ContactModel`: the Hertz contact (approximate or exact, thesis 5.2.1,
with the approximation's error against the exact solution reported),
``E*`` (Eq. 5.10), Kalker's combined ``G`` and ``nu``, ``C11`` and ``L1``
(Eq. 5.17), and the reduced radii.

References
----------
.. [1] Hertz, H. (1882). Ueber die Berührung fester elastischer Körper. Journal für die
   reine und angewandte Mathematik 92, 156-171. https://doi.org/10.1515/crll.1882.92.156
.. [2] Kalker, J. J. (1990). Three-Dimensional Elastic Bodies in Rolling Contact. Solid
   Mechanics and its Applications 2, Kluwer, Dordrecht.
   https://doi.org/10.1007/978-94-015-7889-9
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from torlab.model.calibrated import coefficient_interpolation
from torlab.model.hertz import ContactPatch, E_star, hertz_approximate, hertz_exact, patch_from_axes
from torlab.model.kalker import C11, L1, ExtremeContactWarning, combined_G_nu

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["ContactModel", "build_contact"]


@dataclass(frozen=True)
class ContactModel:
    """The resolved contact of a scene (SI units).

    Attributes
    ----------
    patch
        Semi-axes, load, p0.
    E_star, G, nu
        Reduced modulus (Eq. 5.10); Kalker's combined shear modulus and Poisson ratio.
    C11, L1
        Kalker's coefficient and flexibility ``8a/(3 C11 G)``; C11 interpolated between
        the rows of Kalker's table as the scene's boundary method does
        (:func:`torlab.model.calibrated.coefficient_interpolation`).
    rx, ry
        Reduced radii [m], ``inf`` if not given.
    hertz_check
        Relative differences of the approximate Hertz solution from the exact
        one (``a``, ``b``, ``p0``), when radii are given.
    notes
        Warnings for the user (e.g. an ellipse outside Kalker's table).
    """

    patch: ContactPatch
    E_star: float
    G: float
    nu: float
    C11: float
    L1: float
    rx: float
    ry: float
    hertz_check: dict[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def summary(self) -> dict[str, Any]:
        """Key numbers for reports (SI)."""
        p = self.patch
        return {
            "hertz": p.method,
            "a_m": p.a, "b_m": p.b, "p0_Pa": p.p0, "load_N": p.F,
            "E_star_Pa": self.E_star, "G_Pa": self.G, "nu": self.nu,
            "C11": self.C11, "L1_m_Pa": self.L1,
            "rx_m": self.rx if math.isfinite(self.rx) else None,
            "ry_m": self.ry if math.isfinite(self.ry) else None,
            "hertz_approximation_error": self.hertz_check or None,
        }


def build_contact(scene: Scene) -> ContactModel:
    """Resolve the contact of a :class:`~torlab.scene.Scene`."""
    c, m = scene.contact, scene.materials
    Es = E_star(m.E1, m.nu1, m.E2, m.nu2)
    G, nu = combined_G_nu(m.E1, m.nu1, m.E2, m.nu2)
    check: dict[str, float] = {}
    if c.a is not None:
        patch = patch_from_axes(c.a, c.b, c.load)
    else:
        approx = hertz_approximate(c.load, c.rx, c.ry, Es)
        exact = hertz_exact(c.load, c.rx, c.ry, Es)
        check = {"a": approx.a / exact.a - 1.0, "b": approx.b / exact.b - 1.0,
                 "p0": approx.p0 / exact.p0 - 1.0}
        patch = approx if c.hertz == "approximate" else exact
    notes = []
    with warnings.catch_warnings(record=True) as wlist:
        warnings.simplefilter("always", ExtremeContactWarning)
        c11 = C11(patch.a / patch.b, nu,
                  interpolation=coefficient_interpolation(scene.grid.method))
    notes += [str(w.message) for w in wlist]
    return ContactModel(patch=patch, E_star=Es, G=G, nu=nu, C11=c11, L1=L1(patch.a, c11, G),
                        rx=c.rx, ry=c.ry, hertz_check=check, notes=tuple(notes))
