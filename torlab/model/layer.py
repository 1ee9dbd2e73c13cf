"""The third-body layer's constitutive law (thesis 5.2.2, Eqs. 5.26-5.29).

The interfacial layer is elastic until the shear stress reaches ``tau_c1`` and
then hardens (or softens, if ``tau_c2 < tau_c1``) towards ``tau_c2`` following
Voce's law.  With the pressure ``p`` and temperature ``T``:

* ``tau_c1 = mu_c1 * p * exp(mu_c1_T * (T - T_A))``            (Eq. 5.26)
* ``tau_c2 = mu_c2 * p * exp(mu_c2_T * (T - T_A))``            (Eq. 5.27)
* ``L_e = L_mue / p``  (elastic flexibility, m/Pa)              (Eq. 5.28)
* ``L_p = L_mup``      (plastic length scale, m)                (Eq. 5.29)
* plastic branch ``tau = tau_c1 + (tau_c2 - tau_c1) * (1 - exp(-(u - tau_c1*L)/L_p))``
  (Eq. 5.24 as ``docs/model/thesis-reading.md`` reads it).

At a constant normal stress ``sigma`` (the HPT test, docs/model/thesis-reading.md) the
law gives the shear stress against the layer displacement directly:
:func:`hpt_tau`.  The same four parameters drive FASTSIM in the rolling
contact (:mod:`torlab.model.fastsim`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["L_e", "LayerParams", "hpt_tau", "tau_c1", "tau_c2"]


@dataclass(frozen=True)
class LayerParams:
    """Third-body layer parameters (the scene's ``boundary:`` section), SI units.

    Attributes
    ----------
    mu_c1, mu_c2
        Limit coefficients of the elastic and the saturated (Voce) shear stress.
    L_mue
        Elastic parameter (m): ``L_e = L_mue / p``.
    L_mup
        Plastic (Voce) length (m).
    mu_c1_T, mu_c2_T
        Temperature coefficients (1/K) of the two limits.
    """

    mu_c1: float
    mu_c2: float
    L_mue: float = 0.0
    L_mup: float = 0.0
    mu_c1_T: float = 0.0
    mu_c2_T: float = 0.0


def tau_c1(mu_c1: float, p: np.ndarray | float, dT: np.ndarray | float = 0.0,
           mu_c1_T: float = 0.0) -> np.ndarray:
    """Elastic limit ``tau_c1 = mu_c1 p exp(mu_c1_T (T - T_A))`` (Eq. 5.26), Pa."""
    return mu_c1 * np.asarray(p) * np.exp(mu_c1_T * np.asarray(dT))


def tau_c2(mu_c2: float, p: np.ndarray | float, dT: np.ndarray | float = 0.0,
           mu_c2_T: float = 0.0) -> np.ndarray:
    """Voce saturation stress ``tau_c2 = mu_c2 p exp(mu_c2_T (T - T_A))`` (Eq. 5.27), Pa."""
    return mu_c2 * np.asarray(p) * np.exp(mu_c2_T * np.asarray(dT))


def L_e(L_mue: float, p: np.ndarray | float) -> np.ndarray:
    """Layer elastic flexibility ``L_e = L_mue / p`` (Eq. 5.28), m/Pa."""
    return L_mue / np.asarray(p, dtype=float)


def hpt_tau(u: np.ndarray, sigma: float, params: LayerParams, dT: float = 0.0) -> np.ndarray:
    """Shear stress of the layer against its displacement at constant normal stress.

    Elastic ``tau = u / L_e`` with ``L_e = L_mue / sigma`` up to ``tau_c1``
    (reached at ``u_y = tau_c1 L_e = mu_c1 L_mue``), then Voce towards ``tau_c2``
    (docs/model/thesis-reading.md; thesis Eqs. 5.24, 5.26-5.29).

    Parameters
    ----------
    u
        Layer displacement (m), >= 0; rig compliance not included.
    sigma
        Normal stress (Pa).
    params
        Layer parameters.
    dT
        Temperature above the reference ``T_A`` (K).

    Returns
    -------
    numpy.ndarray
        Shear stress (Pa), same shape as ``u``.
    """
    u = np.asarray(u, dtype=float)
    t1 = float(tau_c1(params.mu_c1, sigma, dT, params.mu_c1_T))
    t2 = float(tau_c2(params.mu_c2, sigma, dT, params.mu_c2_T))
    if params.L_mue <= 0:
        u_y = 0.0
        elastic = np.where(u > 0, t1, 0.0)
    else:
        le = params.L_mue / sigma
        u_y = t1 * le
        elastic = u / le
    up = np.maximum(u - u_y, 0.0)
    if params.L_mup <= 0:
        plastic = np.full_like(u, t2)
    else:
        plastic = t1 + (t2 - t1) * -np.expm1(-up / params.L_mup)
    return np.where(u <= u_y, elastic, plastic)
