"""torlab: top-of-rail tribology lab toolkit.

Raw instrument logs in (HPT, PCS MTM/ETM/EHD2, optical tribometer, falling-body
viscometer), friction, fitted third-body and EHL parameters, predicted traction
and Stribeck curves and reports out.  Every quantity inside torlab is in SI
units (temperatures in degrees Celsius); conversion happens at the edges, and
every public function accepts unit strings (``window="20 um"``).

The public API (:mod:`torlab.api`) is available at the top level::

    import torlab
    red = torlab.reduce_file("demo_5.txt")            # instrument detected
    fit = torlab.fit_hpt("hpt_OFM1_4uL_25C.txt")
    curve = torlab.predict_traction("scene.yaml", "0:5 %:51", params=fit)
    forces = torlab.predict_creep("wheel_rail.yaml", "0:2 %:41", lateral="0.1 %",
                                  spin="0.5 1/m")            # Fx, Fy, Mz

``import torlab`` itself imports nothing heavy: each name is loaded on first
use (PEP 562), so ``torlab --help`` starts fast.
"""

from __future__ import annotations

from typing import Any

__version__ = "0.1.0"

#: public name -> module that defines it (imported on first use)
_LAZY = {
    "read": "torlab.api",
    "reduce_file": "torlab.api",
    "reduce_files": "torlab.api",
    "reduce_to_folder": "torlab.api",
    "fit_hpt": "torlab.api",
    "fit_traction": "torlab.api",
    "fit_temperature": "torlab.api",
    "fit_viscosity": "torlab.api",
    "fit_film": "torlab.api",
    "fit_removal": "torlab.api",
    "load_scene": "torlab.api",
    "predict_traction": "torlab.api",
    "predict_stribeck": "torlab.api",
    "predict_creep": "torlab.api",
    "creep_table": "torlab.api",
    "fit_polach": "torlab.api",
    "predict_retention": "torlab.api",
    "predict_sweep": "torlab.api",
    "run_protocol": "torlab.api",
    "compare": "torlab.api",
    "time_test_items": "torlab.api",
    "FitResult": "torlab.fit.result",
    "Reduction": "torlab.instruments.reduction",
    "REGISTRY": "torlab.instruments",
    "TorlabInputError": "torlab.errors",
}

__all__ = ["__version__", *_LAZY]


def __getattr__(name: str) -> Any:
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'torlab' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(mod), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
