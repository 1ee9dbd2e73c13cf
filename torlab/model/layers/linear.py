"""Linear hardening or softening: CONTACT's interfacial-layer law.

After the elastic limit ``tau_c1 = mu_c1 p f1(T)`` the layer's strength changes
linearly with the slip past the limit::

    tau = p max(mu_c1 f1 + k_mu s, 0),    s = max(u - tau_c1 L, 0)

with ``k_mu`` [1/m] the rate at which the friction coefficient of the layer grows
(``k_mu > 0``: work hardening) or falls (``k_mu < 0``: softening, down to zero
strength) per metre of slip.  At the constant normal stress of an HPT test this is
a straight line of slope ``sigma k_mu`` after the knee: the piecewise-linear
rheology CONTACT uses for the Hou-Kalousek-Magel powders.

In CONTACT's terms (``docs/model/layers.md``): the yield limit grows with the
accumulated plastic slip ``u*_pl`` of the layer, ``tau_c = tau_c0 + k_tau u*_pl``,
with ``tau_c0 = mu_c1 p``, the layer's flexibility ``h/G = L_mue / p`` and
``k_tau = p k_mu / (1 - k_mu L_mue)`` (the slope against the layer's plastic slip
alone; the slope ``sigma k_mu`` includes the layer's elastic part).

References
----------
Vollebregt, E.A.H., CONTACT user guide, section "Interfacial layer of contaminants"
(the ``M = 4`` material: ``GG3``, ``LAYTHK``, ``TAU_C0``, ``K_TAU``).
Hou, K., Kalousek, J., Magel, E. (1997). Rheological model of solid layer in rolling
contact. Wear 211, 134-140. doi:10.1016/S0043-1648(97)00098-X
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.model.layers.base import L_MUE, MU_C1, MU_C1_T, LayerLaw, Param

if TYPE_CHECKING:
    from torlab.model.layers import LayerParams

__all__ = ["LINEAR", "Linear"]

K_MU = Param("k_mu", "inverse_length", "1/m", "kμ",
             "hardening rate: the layer's friction coefficient grows by k_mu per metre of slip "
             "past the elastic limit (negative: softening)",
             range={"kind": "inverse_length", "low": -1e9, "high": 1e9, "usual_low": -1e5,
                    "usual_high": 1e5, "what": "a layer hardening rate (k_mu)",
                    "low_open": False, "display": "1/mm"},
             fit=(-1e3, 1e3), scale=1e3, column="_per_m")


class Linear(LayerLaw):
    """Linear work hardening/softening (module docstring)."""

    name = "linear"
    title = "linear hardening/softening (CONTACT)"
    reference = "CONTACT user guide, interfacial layer (TAU_C0, K_TAU); Hou et al. (1997)"
    params = (MU_C1, L_MUE, K_MU, MU_C1_T)
    limit_text = "linearly hardening limit"
    short = "linear hardening"

    # -- HPT ----------------------------------------------------------------------------------
    def hpt_plastic(self, s: np.ndarray, sigma: float, lay: LayerParams) -> np.ndarray:
        return sigma * np.maximum(lay.mu_c1 + lay.k_mu * np.asarray(s, dtype=float), 0.0)

    def hpt_start(self, t1: float, t2: float, uy: float, ul: np.ndarray, tau: np.ndarray,
                  sigma: float) -> dict[str, float]:
        """``k_mu`` from the chord between the elastic limit and the last point."""
        after = ul > uy
        span = float(ul[after][-1] - uy) if after.any() else 0.0
        return {"k_mu": (t2 - t1) / sigma / span if span > 0 else 0.0}

    def traction_start(self, mu1: float, mu2: float, lme: float) -> dict[str, float]:
        return {"mu_c1": mu1, "L_mue": lme, "k_mu": 0.0}

    def elastic_probe(self) -> dict[str, float]:
        return {"mu_c1": 10.0, "L_mue": 0.0, "k_mu": 0.0}

    # -- FASTSIM strips -----------------------------------------------------------------------
    def strip_plastic(self, lay: LayerParams, p: Any, u: Any, pL: Any, dT: Any,
                      grouped: bool = False) -> Any:
        c1 = lay.mu_c1_T
        f1 = np.exp(c1 * dT) if (np.any(c1) if grouped else c1) else 1.0
        d = u - lay.mu_c1 * f1 * pL
        return p * np.maximum(lay.mu_c1 * f1 + lay.k_mu * np.maximum(d, 0.0), 0.0)

    def strip_partials(self, lay: LayerParams, p: float, u: float, pL: float
                       ) -> tuple[float, float, float]:
        d = max(u - lay.mu_c1 * pL, 0.0)
        c = lay.mu_c1 + lay.k_mu * d
        if c <= 0:
            return 0.0, 0.0, 0.0
        if d <= 0:
            return c, 0.0, 0.0
        return c, p * lay.k_mu, -p * lay.k_mu * lay.mu_c1

    def strip_kinks(self, lay: LayerParams) -> list[Any]:
        """Softening: the strength reaches zero at the slip ``mu_c1 / |k_mu|``."""
        k = np.asarray(lay.k_mu, dtype=float)
        if not np.any(k < 0):
            return []
        with np.errstate(divide="ignore", invalid="ignore"):
            return [np.where(k < 0, lay.mu_c1 / np.where(k < 0, -k, 1.0), np.nan)]

    def grading_length(self, lay: LayerParams) -> Any:
        """Softening: the slip ``mu_c1 / |k_mu|`` to zero strength (a kink there)."""
        k = np.asarray(lay.k_mu, dtype=float)
        with np.errstate(divide="ignore"):
            out = np.where(k < 0, lay.mu_c1 / np.where(k < 0, -k, 1.0), 0.0)
        return out if out.ndim else float(out)

    def hardens(self, lay: LayerParams) -> bool:
        return bool(np.any(lay.k_mu != 0))

    def softens(self, lay: LayerParams) -> bool:
        return bool(np.any(lay.k_mu < 0))

    # -- elements -----------------------------------------------------------------------------
    def _k_plastic(self, lay: LayerParams) -> float:
        """``k_tau / p = k_mu / (1 - k_mu L_mue)`` [1/m]: the rate against the plastic slip."""
        from torlab.errors import TorlabInputError

        den = 1.0 - lay.k_mu * lay.L_mue
        if np.any(den <= 0):
            raise TorlabInputError("linear layer: the plastic branch is steeper than the elastic "
                                   "one (k_mu L_mue >= 1), so the stress cannot be split into "
                                   "an elastic and a plastic slip")
        return lay.k_mu / den

    def yield_stress(self, lay: LayerParams, p: Any, kappa: Any, dT: Any = 0.0) -> np.ndarray:
        """``tau_c = p max(mu_c1 f1 + k_mu kappa / (1 - k_mu L_mue), 0)`` (CONTACT's
        ``tau_c0 + k_tau u*_pl``)."""
        p = np.asarray(p, dtype=float)
        f1 = np.exp(lay.mu_c1_T * np.asarray(dT))
        kp = self._k_plastic(lay)
        return p * np.maximum(lay.mu_c1 * f1 + kp * np.maximum(np.asarray(kappa, float), 0.0),
                              0.0)

    def hardening_modulus(self, lay: LayerParams, p: Any, kappa: Any, dT: Any = 0.0
                          ) -> np.ndarray:
        tc = self.yield_stress(lay, p, kappa, dT)
        return np.where(tc > 0, np.asarray(p, dtype=float) * self._k_plastic(lay), 0.0)

    def plastic_reach(self, lay: LayerParams, p: Any, tau: Any, dT: Any = 0.0) -> np.ndarray:
        """Closed form: ``kappa = (tau/p - mu_c1 f1) / (k_tau/p)``."""
        p = np.asarray(p, dtype=float)
        kp = self._k_plastic(lay)
        if kp == 0:
            return np.full(np.broadcast_shapes(np.shape(p), np.shape(tau)), np.inf)
        f1 = np.exp(lay.mu_c1_T * np.asarray(dT))
        with np.errstate(divide="ignore", invalid="ignore"):
            k = (np.asarray(tau, dtype=float) / p - lay.mu_c1 * f1) / kp
        return np.where(np.isfinite(k) & (k >= 0), k, np.inf)

    def _plastic_slip(self, lay: LayerParams, p: Any, mag: np.ndarray, kappa: np.ndarray,
                      k: np.ndarray, dT: Any) -> np.ndarray:
        """Closed form: ``dk = (|tau_trial| - tau_c) / (k + p k_tau/p)``; where softening
        reaches zero strength (or outruns the element's stiffness) the traction drops to
        zero, ``dk = |tau_trial| / k``."""
        tc = self.yield_stress(lay, p, kappa, dT)
        H = self.hardening_modulus(lay, p, kappa, dT)
        over = np.maximum(mag - tc, 0.0)
        den = k + H
        with np.errstate(divide="ignore", invalid="ignore"):
            dk = np.where(den > 0, over / np.where(den > 0, den, 1.0), np.inf)
            to_zero = mag / np.where(k > 0, k, np.inf)
        # strength left after the step; none: the traction is gone
        gone = (tc + H * dk <= 0) | ~np.isfinite(dk)
        return np.where(over > 0, np.where(gone, to_zero, dk), 0.0)


LINEAR = Linear()
