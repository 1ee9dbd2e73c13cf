"""Pressure-viscosity laws (thesis Eqs. 5.38-5.39, docs/model/thesis-reading.md).

* Barus ``eta = eta0 exp(alpha p)``                                   (Eq. 5.39)
* Roelands ``eta = eta0 exp[(ln eta0 + 9.67) ((1 + 5.1e-9 p)^Z - 1)]``   (Eq. 5.38)
  with ``eta0`` in Pa s and ``p`` in Pa (the constants 9.67 and 5.1e-9 1/Pa
  belong to these units).
* constant (iso-viscous) ``eta = eta0``.

The ``log_*`` functions return ``ln eta`` so that callers can work in log space
where ``eta`` itself would overflow (a Newtonian film at several GPa).

The Roelands pressure-viscosity coefficient ``alpha* = (ln eta0 + 9.67) * 5.1e-9 * Z``
is the initial slope of ``ln eta`` against ``p`` (:func:`roelands_alpha0`).

References
----------
.. [1] Roelands, C. J. A. (1966). Correlational aspects of the
   viscosity-temperature-pressure relationship of lubricating oils. PhD thesis, Delft
   University of Technology (no DOI).
.. [2] Barus, C. (1893). Isothermals, isopiestics and isometrics relative to viscosity.
   American Journal of Science s3-45(266), 87-96.
   https://doi.org/10.2475/ajs.s3-45.266.87
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ROELANDS_C",
    "ROELANDS_P0_INV",
    "eta",
    "eta_barus",
    "eta_roelands",
    "log_eta",
    "log_eta_barus",
    "log_eta_roelands",
    "roelands_alpha0",
]

#: Roelands constants for SI units: ln(eta_inf / 1 Pa s) = -9.67, 1/p_r = 5.1e-9 1/Pa
ROELANDS_C = 9.67
ROELANDS_P0_INV = 5.1e-9


def log_eta_barus(p: np.ndarray | float, eta0: float, alpha: float) -> np.ndarray:
    """``ln eta`` of the Barus law (Eq. 5.39): ``ln eta0 + alpha p``."""
    return np.log(eta0) + alpha * np.asarray(p, dtype=float)


def log_eta_roelands(p: np.ndarray | float, eta0: float, Z: float) -> np.ndarray:
    """``ln eta`` of the Roelands law (Eq. 5.38), ``eta0`` in Pa s, ``p`` in Pa (>= 0)."""
    p = np.maximum(np.asarray(p, dtype=float), 0.0)
    return np.log(eta0) + (np.log(eta0) + ROELANDS_C) * np.expm1(Z * np.log1p(ROELANDS_P0_INV * p))


def eta_barus(p: np.ndarray | float, eta0: float, alpha: float) -> np.ndarray:
    """Barus viscosity ``eta0 exp(alpha p)`` (Eq. 5.39), Pa s."""
    return np.exp(log_eta_barus(p, eta0, alpha))


def eta_roelands(p: np.ndarray | float, eta0: float, Z: float) -> np.ndarray:
    """Roelands viscosity (Eq. 5.38), Pa s."""
    return np.exp(log_eta_roelands(p, eta0, Z))


def log_eta(p: np.ndarray | float, law: str, eta0: float, alpha: float = 0.0, Z: float = 0.0) -> np.ndarray:
    """``ln eta`` for ``law`` in ``{"iso", "barus", "roelands"}``."""
    if law == "iso":
        return np.full(np.shape(p), np.log(eta0))
    if law == "barus":
        return log_eta_barus(p, eta0, alpha)
    if law == "roelands":
        return log_eta_roelands(p, eta0, Z)
    raise ValueError(f"unknown viscosity law {law!r}")


def eta(p: np.ndarray | float, law: str, eta0: float, alpha: float = 0.0, Z: float = 0.0) -> np.ndarray:
    """Viscosity [Pa s] for ``law`` in ``{"iso", "barus", "roelands"}``."""
    return np.exp(log_eta(p, law, eta0, alpha, Z))


def roelands_alpha0(eta0: float, Z: float) -> float:
    """Initial pressure-viscosity coefficient of the Roelands law, ``d ln eta / dp`` at p = 0 [1/Pa]."""
    return (np.log(eta0) + ROELANDS_C) * ROELANDS_P0_INV * Z
