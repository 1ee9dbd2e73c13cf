"""torlab: top-of-rail tribology lab toolkit.

Raw instrument logs in (HPT, PCS MTM/ETM/EHD2, optical tribometer, falling-body
viscometer), friction, fitted third-body and EHL parameters, predicted traction
and Stribeck curves and reports out.  Every quantity inside torlab is in SI
units (temperatures in degrees Celsius, the SI derived unit); conversion
happens at the edges (parsers, scene files, CLI, reports).

The package is importable without side effects and imports heavy libraries
(scipy.optimize, matplotlib, pint) lazily, so ``torlab --help`` starts fast.
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
