"""Voce's law: the thesis's layer (Eqs. 5.24, 5.26-5.29), torlab's default.

After the elastic limit ``tau_c1 = mu_c1 p f1(T)`` the stress moves exponentially
towards the saturation ``tau_c2 = mu_c2 p f2(T)`` (hardening if ``mu_c2 > mu_c1``,
softening if below) over the length ``L_mup`` of slip past the limit::

    tau = tau_c1 + (tau_c2 - tau_c1) (1 - exp(-s / L_mup)),    s = max(u - tau_c1 L, 0)

(Eq. 5.24 as ``docs/model/thesis-reading.md`` reads it; ``f_i = exp(mu_ci_T (T - T_A))``,
Eqs. 5.26-5.27).  ``L_mup = 0`` is a step to ``tau_c2``.

References
----------
Voce, E. (1948). The relationship between stress and strain for homogeneous deformation.
J. Inst. Metals 74, 537-562.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.model.layers.base import L_MUE, MU_C1, MU_C1_T, LayerLaw, Param

if TYPE_CHECKING:
    from torlab.model.layers import LayerParams

__all__ = ["VOCE", "Voce"]

MU_C2 = Param("mu_c2", "dimensionless", "-", "μc2",
              "saturation coefficient: the plastic branch tends to tau_c2 = mu_c2 p (Eq. 5.27; "
              "below mu_c1: softening)", ge=0.0, le=5.0, fit=(1e-4, 5.0), traction=(1e-4, 3.0),
              positive=True)
L_MUP = Param("L_mup", "length", "m", "Lμp",
              "Voce length: slip past the elastic limit over which the stress moves 63 % of "
              "the way to tau_c2 (Eq. 5.29; 0: a step)", default=0.0, ge=0.0,
              range="layer_length", fit=(1e-3, 1e4), scale=1e-6, positive=True, column="_m")
MU_C2_T = Param("mu_c2_T", "inverse_temperature", "1/K", "μc2,T",
                "temperature coefficient of mu_c2 (Eq. 5.27)", default=0.0,
                range="temperature_coefficient", temperature_of="mu_c2", column="_per_K")


class Voce(LayerLaw):
    """Voce hardening/softening (module docstring)."""

    name = "voce"
    title = "Voce hardening/softening (thesis Eq. 5.24)"
    reference = "thesis Eqs. 5.24, 5.26-5.29; Voce (1948)"
    params = (MU_C1, MU_C2, L_MUE, L_MUP, MU_C1_T, MU_C2_T)
    limit_text = "Voce limit"
    short = "Voce"
    reference_name = "mu_c2"

    # -- HPT ----------------------------------------------------------------------------------
    def hpt_tau(self, u: np.ndarray, sigma: float, lay: LayerParams, dT: float = 0.0
                ) -> np.ndarray:
        """Shear stress [Pa] against the layer displacement ``u`` [m] at constant normal
        stress ``sigma`` [Pa]: elastic ``tau = u / L_e``, ``L_e = L_mue / sigma``, up to
        ``tau_c1`` (reached at ``u_y = mu_c1 L_mue``), then Voce towards ``tau_c2``
        (thesis Eqs. 5.24, 5.26-5.29)."""
        u = np.asarray(u, dtype=float)
        t1 = float(lay.mu_c1 * np.asarray(sigma) * np.exp(lay.mu_c1_T * np.asarray(dT)))
        t2 = float(lay.mu_c2 * np.asarray(sigma) * np.exp(lay.mu_c2_T * np.asarray(dT)))
        if lay.L_mue <= 0:
            u_y = 0.0
            elastic = np.where(u > 0, t1, 0.0)
        else:
            le = lay.L_mue / sigma
            u_y = t1 * le
            elastic = u / le
        up = np.maximum(u - u_y, 0.0)
        if lay.L_mup <= 0:
            plastic = np.full_like(u, t2)
        else:
            plastic = t1 + (t2 - t1) * -np.expm1(-up / lay.L_mup)
        return np.where(u <= u_y, elastic, plastic)

    def hpt_plastic(self, s: np.ndarray, sigma: float, lay: LayerParams) -> np.ndarray:
        t1, t2 = lay.mu_c1 * sigma, lay.mu_c2 * sigma
        lp = max(lay.L_mup, 1e-12)
        return t1 + (t2 - t1) * -np.expm1(-s / lp)

    def hpt_length(self, lay: LayerParams) -> float | None:
        return max(lay.L_mup, 1e-12)

    def hpt_start(self, t1: float, t2: float, uy: float, ul: np.ndarray, tau: np.ndarray,
                  sigma: float) -> dict[str, float]:
        """``mu_c2`` from the final stress, ``L_mup`` from where the curve has gone 63 % of
        the way from the limit to it."""
        target = t1 + 0.63 * (t2 - t1)
        after = np.flatnonzero((ul > uy) & ((tau - target) * np.sign(t2 - t1) >= 0))
        lmp = float(ul[after[0]] - uy) if after.size and abs(t2 - t1) > 0.02 * t2 else 10e-6
        return {"mu_c2": t2 / sigma, "L_mup": max(lmp, 0.2e-6)}

    def fit_warnings(self, res: Any, ends: list[float]) -> tuple[list[str], set[str]]:
        """``L_mup`` means nothing when the curve shows no step from ``mu_c1`` to ``mu_c2``;
        ``mu_c2`` is poorly known when the curve ends before it saturates."""
        w: list[str] = []
        p, se = res.params, res.stderr
        cov12 = res.correlation[0, 1] * se["mu_c1"] * se["mu_c2"] if res.determined("mu_c1") \
            and res.determined("mu_c2") else math.inf
        d = p["mu_c2"] - p["mu_c1"]
        var_d = se["mu_c1"] ** 2 + se["mu_c2"] ** 2 - 2 * cov12 if math.isfinite(cov12) \
            else math.inf
        sd_d = math.sqrt(max(var_d, 0.0))
        step_resolved = abs(d) > 3.0 * sd_d and abs(d) > 0.02 * max(p["mu_c1"], p["mu_c2"])
        if not step_resolved:
            w.append(f"L_mup not determined: the curve never yields to a new level after the "
                     f"elastic limit (mu_c2 - mu_c1 = {d:.3g} +- {sd_d:.2g}), so the Voce length "
                     "has no effect")
            return w, {"L_mup"}
        u_after = min(u_end - p["mu_c1"] * p["L_mue"] for u_end in ends)
        if u_after < 3.0 * p["L_mup"]:
            w.append(f"mu_c2 poorly determined: the curve ends "
                     f"{u_after / max(p['L_mup'], 1e-12):.2g} L_mup after the elastic limit, "
                     "before it saturates; run to a larger displacement")
        return w, set()

    def traction_start(self, mu1: float, mu2: float, lme: float) -> dict[str, float]:
        """Start of a traction fit: the plateau gives ``mu_c2``, ``L_mup = L_mue``."""
        return {"mu_c1": mu1, "mu_c2": mu2, "L_mue": lme, "L_mup": max(lme, 1e-6)}

    def elastic_probe(self) -> dict[str, float]:
        return {"mu_c1": 10.0, "mu_c2": 10.0, "L_mue": 0.0, "L_mup": 1e-6}

    def traction_warnings(self, res: Any) -> list[str]:
        """A fitted softening (``mu_c1`` above ``mu_c2`` by more than two standard errors)
        often means the model's transition is sharper than the data's."""
        if not ("mu_c1" in res.names and "mu_c2" in res.names):
            return []
        d = res.params["mu_c1"] - res.params["mu_c2"]
        i, j = res.names.index("mu_c1"), res.names.index("mu_c2")
        c = res.correlation[i, j] if np.isfinite(res.correlation[i, j]) else 0.0
        s1, s2 = res.stderr["mu_c1"], res.stderr["mu_c2"]
        sd = math.sqrt(max(s1 * s1 + s2 * s2 - 2 * c * s1 * s2, 0.0))
        if math.isfinite(sd) and d > 2 * sd:
            return [f"softening layer fitted: mu_c1 = {res.params['mu_c1']:.3g} > mu_c2 = "
                    f"{res.params['mu_c2']:.3g} (the layer's strength falls after its elastic "
                    "limit). If the measured curve has no peak above its plateau, the model's "
                    "transition is sharper than the data's: fix mu_c1 or L_mup from an HPT fit"]
        return []

    # -- FASTSIM strips -----------------------------------------------------------------------
    def strip_plastic(self, lay: LayerParams, p: Any, u: Any, pL: Any, dT: Any,
                      grouped: bool = False) -> Any:
        if not grouped:
            f1 = np.exp(lay.mu_c1_T * dT) if lay.mu_c1_T else 1.0
            f2 = np.exp(lay.mu_c2_T * dT) if lay.mu_c2_T else 1.0
        else:  # exp(0 dT) = 1 exactly where a coefficient is zero: the same as above
            f1 = np.exp(lay.mu_c1_T * dT) if np.any(lay.mu_c1_T) else 1.0
            f2 = np.exp(lay.mu_c2_T * dT) if np.any(lay.mu_c2_T) else 1.0
        t1 = lay.mu_c1 * p * f1
        t2 = lay.mu_c2 * p * f2
        d = u - lay.mu_c1 * f1 * pL
        Lp = lay.L_mup
        if grouped and np.all(Lp > 0):
            decay = np.exp(-np.maximum(d, 0.0) / Lp)
        elif grouped:
            with np.errstate(divide="ignore", invalid="ignore"):
                decay = np.where(Lp > 0, np.exp(-np.maximum(d, 0.0) / np.where(Lp > 0, Lp, 1.0)),
                                 np.where(d > 0, 0.0, 1.0))
        elif Lp > 0:
            decay = np.exp(-np.maximum(d, 0.0) / Lp)
        else:
            decay = np.where(d > 0, 0.0, 1.0)
        return t2 - (t2 - t1) * decay

    def strip_partials(self, lay: LayerParams, p: float, u: float, pL: float
                       ) -> tuple[float, float, float]:
        d = u - lay.mu_c1 * pL
        if lay.L_mup > 0:
            e = math.exp(-max(d, 0.0) / lay.L_mup)
            D = lay.mu_c2 - lay.mu_c1
            g_p = lay.mu_c1 + D * (1.0 - e)
            if d <= 0:
                return g_p, 0.0, 0.0
            g_u = D * p * e / lay.L_mup
            return g_p, g_u, -g_u * lay.mu_c1
        return (lay.mu_c2 if d > 0 else lay.mu_c1), 0.0, 0.0

    def grading_length(self, lay: LayerParams) -> Any:
        return lay.L_mup

    def hardens(self, lay: LayerParams) -> bool:
        return not (lay.mu_c2 == lay.mu_c1 and lay.mu_c1_T == lay.mu_c2_T)

    def softens(self, lay: LayerParams) -> bool:
        return bool(np.any(lay.mu_c2 < lay.mu_c1))

    def reference_mu(self, lay: LayerParams) -> Any:
        return lay.mu_c2

    def limits(self) -> list[tuple[str, str]]:
        return [("mu_c1", "μ_c1 (elastic limit)"), ("mu_c2", "μ_c2 (plastic limit)")]

    # -- elements -----------------------------------------------------------------------------
    def yield_stress(self, lay: LayerParams, p: Any, kappa: Any, dT: Any = 0.0) -> np.ndarray:
        """``tau_c(kappa)`` such that one element loaded at constant pressure follows the
        HPT curve: ``tau = t1 + (t2 - t1)(1 - exp(-s / L_mup))`` with the slip past the
        limit ``s = (tau - t1) L_e + kappa`` (the layer's elastic part beyond the limit
        plus its plastic slip).  Solved per element by safeguarded Newton; needs the
        plastic branch to be less steep than the elastic one (``|t2 - t1| L_e < L_mup``
        where hardening), else :class:`~torlab.errors.TorlabInputError`."""
        from torlab.errors import ConvergenceError, TorlabInputError

        p = np.asarray(p, dtype=float)
        kap = np.maximum(np.asarray(kappa, dtype=float), 0.0)
        t1 = lay.mu_c1 * p * np.exp(lay.mu_c1_T * np.asarray(dT))
        t2 = lay.mu_c2 * p * np.exp(lay.mu_c2_T * np.asarray(dT))
        D = t2 - t1
        if lay.L_mup <= 0:
            return np.where(kap > 0, t2, t1) + 0.0 * kap
        Le = lay.L_mue / np.where(p > 0, p, np.inf)
        a = D * Le / lay.L_mup  # slope ratio: plastic over elastic at the limit
        if np.any(a >= 1.0):
            raise TorlabInputError("Voce layer: the plastic branch is steeper than the elastic "
                                   "one ((mu_c2 - mu_c1) L_mue >= L_mup), so the stress "
                                   "cannot be split into an elastic and a plastic slip")
        # z = tau - t1 solves z = D (1 - exp(-(z Le + kappa)/L_mup)); z lies between 0 and D
        z = D * -np.expm1(-kap / lay.L_mup)
        for _ in range(60):
            e = np.exp(-(z * Le + kap) / lay.L_mup)
            f = z - D * (1.0 - e)
            df = 1.0 - a * e
            new = z - f / df
            new = np.where(D >= 0, np.clip(new, 0.0, D), np.clip(new, D, 0.0))
            step = np.abs(new - z)
            z = new
            if np.all(step <= 1e-15 * np.maximum(np.abs(D), 1e-300)):
                return t1 + z
        raise ConvergenceError("Voce layer: the yield stress of an element did not converge")

    def _plastic_slip(self, lay: LayerParams, p: Any, mag: np.ndarray, kappa: np.ndarray,
                      k: np.ndarray, dT: Any) -> np.ndarray:
        """One scalar equation per element in the traction after the step,
        ``F(tau) = tau - t1 - D (1 - exp(-((tau - t1) L_e + kappa + (|tau_trial| - tau)/k)
        / L_mup)) = 0``, bracketed between the yield stress before the step and the
        trial (hardening) or the saturation (softening) and solved by safeguarded Newton."""
        from torlab.errors import ConvergenceError

        p = np.asarray(p, dtype=float)
        tc = self.yield_stress(lay, p, kappa, dT)
        act = mag > tc
        shape = np.broadcast_shapes(np.shape(mag), np.shape(kappa), np.shape(tc), np.shape(k))
        if not np.any(act) or lay.L_mup <= 0:
            if lay.L_mup <= 0:  # a step to tau_c2: flow at tau_c2 once yielded
                t2 = lay.mu_c2 * p * np.exp(lay.mu_c2_T * np.asarray(dT))
                return np.where(act & (mag > t2), (mag - t2) / k, 0.0) + np.zeros(shape)
            return np.zeros(shape)
        t1 = lay.mu_c1 * p * np.exp(lay.mu_c1_T * np.asarray(dT))
        t2 = lay.mu_c2 * p * np.exp(lay.mu_c2_T * np.asarray(dT))
        D = t2 - t1
        Le = lay.L_mue / np.where(p > 0, p, np.inf)
        kap = np.broadcast_to(np.maximum(np.asarray(kappa, dtype=float), 0.0), shape)
        mag_b, k_b = np.broadcast_to(mag, shape), np.broadcast_to(k, shape)

        def F(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            e = np.exp(-((t - t1) * Le + kap + (mag_b - t) / k_b) / lay.L_mup)
            return t - t1 - D * (1.0 - e), 1.0 - D * e * (Le - 1.0 / k_b) / lay.L_mup

        hard = np.broadcast_to(D >= 0, shape)
        lo = np.where(hard, tc, np.minimum(t2, mag_b))
        hi = np.where(hard, mag_b, tc)
        t = np.where(act, 0.5 * (lo + hi), mag_b)
        for _ in range(100):
            f, df = F(t)
            lo = np.where(f < 0, t, lo)
            hi = np.where(f < 0, hi, t)
            new = t - f / np.where(df != 0, df, np.nan)
            bad = ~np.isfinite(new) | (new < lo) | (new > hi)
            new = np.where(act, np.where(bad, 0.5 * (lo + hi), new), mag_b)
            step = np.abs(new - t)
            t = new
            if np.all(step <= 1e-14 * np.maximum(np.abs(t), 1e-300)):
                return np.where(act, (mag_b - t) / k_b, 0.0)
        raise ConvergenceError("Voce layer: the plastic slip of a contact element did not "
                               "converge in 100 steps")

    def plastic_reach(self, lay: LayerParams, p: Any, tau: Any, dT: Any = 0.0) -> np.ndarray:
        """Closed form: the Voce curve reaches ``tau`` at the slip past the limit
        ``s = -L_mup ln(1 - (tau - t1)/(t2 - t1))``, of which ``(tau - t1) L_e`` is elastic."""
        p = np.asarray(p, dtype=float)
        tau = np.asarray(tau, dtype=float)
        t1 = lay.mu_c1 * p * np.exp(lay.mu_c1_T * np.asarray(dT))
        t2 = lay.mu_c2 * p * np.exp(lay.mu_c2_T * np.asarray(dT))
        Le = lay.L_mue / np.where(p > 0, p, np.inf)
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = (tau - t1) / (t2 - t1)
            if lay.L_mup > 0:
                k = -lay.L_mup * np.log1p(-frac) - (tau - t1) * Le
            else:
                k = np.where(frac == 1.0, 0.0, np.inf)
        return np.where((frac >= 0) & (frac < 1) & np.isfinite(k) & (k >= 0), k, np.inf)

    def hardening_modulus(self, lay: LayerParams, p: Any, kappa: Any, dT: Any = 0.0
                          ) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        tc = self.yield_stress(lay, p, kappa, dT)
        if lay.L_mup <= 0:
            return np.zeros_like(tc)
        t2 = lay.mu_c2 * p * np.exp(lay.mu_c2_T * np.asarray(dT))
        Le = lay.L_mue / np.where(p > 0, p, np.inf)
        # tau = t2 - (t2 - t1) e with e = exp(-s/L_mup): d tau = (t2 - tau)(Le d tau + dk)/L_mup
        g = (t2 - tc) / lay.L_mup
        return g / (1.0 - g * Le)


VOCE = Voce()
