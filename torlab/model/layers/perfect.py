"""Perfect plasticity: elastic up to the limit, then flow at constant strength.

After the elastic limit the layer flows at ``tau = tau_c1 = mu_c1 p f1(T)``: no
hardening, no softening (CONTACT's interfacial layer with ``K_TAU = 0``; Voce's law
with ``mu_c2 = mu_c1``).  In FASTSIM it is Kalker's simplified theory with the
traction bound ``mu_c1 p`` and the layer's flexibility in series.

References
----------
Vollebregt, E.A.H., CONTACT user guide, section "Interfacial layer of contaminants"
(``K_TAU = 0``: elastic-perfectly plastic).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.model.layers.base import L_MUE, MU_C1, MU_C1_T, LayerLaw

if TYPE_CHECKING:
    from torlab.model.layers import LayerParams

__all__ = ["PERFECT", "Perfect"]


class Perfect(LayerLaw):
    """Elastic-perfectly plastic (module docstring)."""

    name = "perfect"
    title = "elastic-perfectly plastic (CONTACT, k_tau = 0)"
    reference = "CONTACT user guide, interfacial layer with K_TAU = 0"
    params = (MU_C1, L_MUE, MU_C1_T)
    limit_text = "perfectly plastic limit"
    short = "perfectly plastic"

    def hpt_plastic(self, s: np.ndarray, sigma: float, lay: LayerParams) -> np.ndarray:
        return np.full(np.shape(s), lay.mu_c1 * sigma)

    def traction_start(self, mu1: float, mu2: float, lme: float) -> dict[str, float]:
        return {"mu_c1": mu2, "L_mue": lme}

    def strip_plastic(self, lay: LayerParams, p: Any, u: Any, pL: Any, dT: Any,
                      grouped: bool = False) -> Any:
        c1 = lay.mu_c1_T
        f1 = np.exp(c1 * dT) if (np.any(c1) if grouped else c1) else 1.0
        return lay.mu_c1 * p * f1 + 0.0 * u

    def strip_partials(self, lay: LayerParams, p: float, u: float, pL: float
                       ) -> tuple[float, float, float]:
        return lay.mu_c1, 0.0, 0.0

    def hardens(self, lay: LayerParams) -> bool:
        return False

    def yield_stress(self, lay: LayerParams, p: Any, kappa: Any, dT: Any = 0.0) -> np.ndarray:
        return (lay.mu_c1 * np.asarray(p, dtype=float) * np.exp(lay.mu_c1_T * np.asarray(dT))
                + 0.0 * np.asarray(kappa, dtype=float))

    def hardening_modulus(self, lay: LayerParams, p: Any, kappa: Any, dT: Any = 0.0
                          ) -> np.ndarray:
        return np.zeros(np.broadcast_shapes(np.shape(p), np.shape(kappa)))

    def plastic_reach(self, lay: LayerParams, p: Any, tau: Any, dT: Any = 0.0) -> np.ndarray:
        """The yield stress never moves: ``inf``."""
        return np.full(np.broadcast_shapes(np.shape(p), np.shape(tau)), np.inf)

    def _plastic_slip(self, lay: LayerParams, p: Any, mag: np.ndarray, kappa: np.ndarray,
                      k: np.ndarray, dT: Any) -> np.ndarray:
        """Closed form: ``dk = (|tau_trial| - tau_c1) / k`` where positive."""
        tc = self.yield_stress(lay, p, kappa, dT)
        return np.maximum(mag - tc, 0.0) / k


PERFECT = Perfect()
