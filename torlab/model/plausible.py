"""Notes on predicted values that are computable but outside what the model describes.

A scene can be valid, every input within :data:`torlab.units.RANGES`, and still
ask for a contact the model was not built for: a fast, heavily loaded, highly
creeping contact heats by thousands of degrees in the flash-temperature model
(thesis Eqs. 5.49-5.50, constant material properties), and the EHL film
formulas (Eqs. 5.31-5.32, for films much thinner than the contact) extrapolate
to millimetres at extreme speeds and viscosities.  Such numbers are not errors
of the numerics, so they are kept, but every prediction that contains one
carries a note naming the value (:func:`result_notes`), written to the
summary, the report and the console.

Limits
------
``max_temperature_C`` above :data:`HOT_C` (1000 degC): steel changes phase near
727 degC and melts near 1450 degC; the model's constant conductivity, density,
heat capacity and friction limits do not hold there.

``film_thickness_m`` above :data:`THICK_FILM_M` (100 um): EHL films in
Hertzian contacts are nanometres to a few micrometres; the central-film
formulas are regressions over that range.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["HOT_C", "THICK_FILM_M", "result_notes"]

#: contact temperature above which the flash-temperature model's assumptions fail (degC)
HOT_C = 1000.0
#: film thickness above which the EHL formulas are far outside their range (m)
THICK_FILM_M = 1e-4


def result_notes(table: Any) -> list[str]:
    """Notes for the columns of a prediction ``table`` that leave the model's range."""
    notes = []
    if "max_temperature_C" in table:
        t = np.asarray(table["max_temperature_C"], dtype=float)
        t = t[np.isfinite(t)]
        if t.size and t.max() > HOT_C:
            notes.append(f"the contact temperature reaches {t.max():.4g} °C: above about "
                         f"{HOT_C:g} °C the flash-temperature model (constant material "
                         "properties, no phase change or melting) does not describe the "
                         "contact; the friction there is not a prediction (check the speed, "
                         "load, creepage and thermal: data)")
    if "film_thickness_m" in table:
        h = np.asarray(table["film_thickness_m"], dtype=float)
        h = h[np.isfinite(h)]
        if h.size and h.max() > THICK_FILM_M:
            notes.append(f"the film thickness reaches {h.max():.3g} m: far above the "
                         "nanometre-to-micrometre films the EHL formulas (Eqs. 5.31-5.32) are "
                         "fitted to; check eta0, alpha, the speed and the radii")
    return notes
