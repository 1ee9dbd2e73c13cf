"""The friction law of one element: stick, slip on the Coulomb bound, or plastic flow in the layer.

Every solver of :mod:`torlab.model.exact` applies the same local law.  The slip
of an element over one step of the scheme, ``sigma`` (a displacement, m), and
its traction ``p`` [Pa] must satisfy (Kalker 1990, *Three-dimensional elastic
bodies in rolling contact*, section 5.2; CONTACT's interfacial layer after Hou,
Kalousek and Magel 1997):

* stick: ``sigma = 0`` and ``|p| <= b(0)``;
* slip or plastic flow: ``sigma = -lam e`` and ``p = b(lam) e`` with a unit vector
  ``e`` and ``lam >= 0``: the slip opposes the traction, the traction is on the bound.

The bound ``b(lam) = min(g, tau(kappa0 + lam))`` is the Coulomb bound
``g = mu p_n`` or the layer's yield stress ``tau`` after the element's accumulated
plastic deformation ``kappa0`` plus this step's ``lam`` (work hardening or
softening); ``lam`` counts as plastic deformation where ``tau < g`` and as slip
elsewhere.

The conditions are equivalent, for any ``r > 0``, to ``p = Pi(p - r sigma)`` with
the map ``Pi`` of :func:`project` (Alart and Curnier 1991): with
``z = p - r sigma``, an element sticks if ``|z| <= b(0)``; otherwise
``|z| = b(lam) + r lam`` fixes ``lam`` (a monotone scalar equation while
``b' > -r``: softening slower than the element's own stiffness) and
``Pi(z) = b(lam) z/|z|``.  The solvers' Newton iteration needs the derivative
``dPi = (b/|z|)(I - zz'/|z|^2) + b'/(b' + r) zz'/|z|^2`` on the slipping elements
and ``I`` on the sticking ones.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

__all__ = ["ADHESION", "EXTERIOR", "PLASTIC", "SLIP", "LinearYield", "Projection", "VoceYield",
           "YieldLaw", "project"]

EXTERIOR, ADHESION, SLIP, PLASTIC = 0, 1, 2, 3


class YieldLaw(Protocol):
    """The layer's yield stress against its accumulated plastic deformation."""

    def stress(self, kappa: np.ndarray, c1: np.ndarray, c2: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        """``(tau, dtau/dkappa)`` (Pa, Pa/m) at ``kappa`` [m] with the element parameters."""

    def reaching(self, tau: np.ndarray, c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
        """The plastic deformation at which the yield stress reaches ``tau`` (inf: never)."""

    def plastic_step(self, mag: np.ndarray, kappa0: np.ndarray, r: np.ndarray, c1: np.ndarray,
                     c2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Optional: the yielding element's step in one scalar solve.

        ``tau = tau_c(kappa0 + dk)`` with ``mag = tau + r dk`` (``mag`` the trial
        traction ``|z|`` above the yield stress, ``r`` the element's stiffness).
        Returns ``(tau, dk, dtau/dkappa)``.
        """


@dataclass(frozen=True)
class LinearYield:
    """CONTACT's law: ``tau = max(c1 + k_tau kappa, 0)`` (``c1 = tau_c0``), ``k_tau`` in Pa/m.

    ``k_tau > 0`` hardens, ``< 0`` softens, ``0`` is perfect plasticity.
    """

    k_tau: float = 0.0

    def stress(self, kappa, c1, c2):
        tau = c1 + self.k_tau * kappa
        pos = tau > 0
        return np.where(pos, tau, 0.0), np.where(pos, self.k_tau, 0.0)

    def plastic_step(self, mag, kappa0, r, c1, c2):
        k = self.k_tau
        dk = (mag - c1 - k * kappa0) / (r + k)
        tau = c1 + k * (kappa0 + dk)
        pos = tau > 0
        dk = np.where(pos, dk, mag / r)
        return np.where(pos, tau, 0.0), dk, np.where(pos, k, 0.0)

    def reaching(self, tau, c1, c2):
        if self.k_tau == 0:
            return np.full(np.shape(tau), np.inf)
        k = (tau - c1) / self.k_tau
        return np.where(k >= 0, k, np.inf)


@dataclass(frozen=True)
class VoceYield:
    """Voce's law (thesis Eq. 5.24): ``tau = c1 + (c2 - c1)(1 - exp(-kappa/L_p))``.

    ``c1 = tau_c1``, ``c2 = tau_c2`` per element; ``L_p`` [m] the Voce length
    (``0``: the saturation stress at once).
    """

    L_p: float

    def stress(self, kappa, c1, c2):
        if self.L_p <= 0:
            return np.where(kappa > 0, c2, c1) + 0.0 * kappa, np.zeros_like(kappa)
        ex = np.exp(-kappa / self.L_p)
        return c1 + (c2 - c1) * (1 - ex), (c2 - c1) * ex / self.L_p

    def reaching(self, tau, c1, c2):
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = (tau - c1) / (c2 - c1)
            k = -self.L_p * np.log1p(-frac)
        return np.where((frac >= 0) & (frac < 1) & np.isfinite(k), k, np.inf)


@dataclass
class Projection:
    """:func:`project`'s result for ``n`` elements.

    ``p`` the new tractions ``(n, 2)``; ``lam`` the slip over the step ``(n,)`` [m];
    ``state`` (:data:`ADHESION`, :data:`SLIP`, :data:`PLASTIC`); ``plastic_lam`` the
    part of ``lam`` that is plastic deformation; ``zhat``, ``fac``, ``radial`` the
    derivative's parts (``dPi = fac (I - zhat zhat') + radial zhat zhat'`` where
    slipping, ``I`` where sticking); ``slope`` the yield stress's slope ``dtau/dkappa``
    where the element flows plastically (0 elsewhere).
    """

    p: np.ndarray
    lam: np.ndarray
    state: np.ndarray
    plastic_lam: np.ndarray
    zhat: np.ndarray
    fac: np.ndarray
    radial: np.ndarray
    slope: np.ndarray | None = None

    def derivative(self, v: np.ndarray) -> np.ndarray:
        """``dPi v`` for ``v`` of shape ``(n, 2)``."""
        dot = (self.zhat * v).sum(axis=1)
        slip = self.state != ADHESION
        out = self.fac[:, None] * (v - self.zhat * dot[:, None]) + (
            self.radial * dot)[:, None] * self.zhat
        return np.where(slip[:, None], out, v)


def _bound(lam, g, law, kappa0, c1, c2):
    """``b(lam) = min(g, tau(kappa0 + lam))``, its derivative, and where it is plastic."""
    if law is None:
        return g, np.zeros_like(g), np.zeros(g.shape, bool)
    tau, dtau = law.stress(kappa0 + lam, c1, c2)
    plastic = tau < g
    return np.where(plastic, tau, g), np.where(plastic, dtau, 0.0), plastic


def project(z: np.ndarray, r: np.ndarray, g: np.ndarray, law: YieldLaw | None = None,
            kappa0: np.ndarray | None = None, c1: np.ndarray | None = None,
            c2: np.ndarray | None = None, iterations: int = 50) -> Projection:
    """The map ``Pi(z)`` of the local law (module docstring) for ``n`` elements.

    Parameters
    ----------
    z
        ``p - r sigma``, shape ``(n, 2)`` [Pa].
    r
        The positive scale ``(n,)`` (Pa/m).
    g
        Coulomb bound ``(n,)`` [Pa], ``inf`` where none.
    law, kappa0, c1, c2
        Layer yield law, accumulated plastic deformation before the step [m] and the
        law's element parameters ``(n,)``; ``law=None``: Coulomb friction only.
    """
    n = z.shape[0]
    zn = np.hypot(z[:, 0], z[:, 1])
    if kappa0 is None:
        kappa0 = np.zeros(n)
    b0, _, _ = _bound(np.zeros(n), g, law, kappa0, c1, c2)
    stick = zn <= b0
    zhat = z / np.where(zn > 0, zn, 1.0)[:, None]
    lam = np.zeros(n)
    b = np.where(stick, zn, b0)
    db = np.zeros(n)
    plastic = np.zeros(n, bool)
    slip = ~stick
    fast = (law is not None and hasattr(law, "plastic_step")
            and bool(np.all(np.isinf(g[slip]))))
    if slip.any():
        if law is None:
            lam = np.where(slip, (zn - b0) / r, 0.0)
        elif fast:
            i = np.nonzero(slip)[0]
            tau, dk, dt = law.plastic_step(zn[i], kappa0[i], r[i],
                                           None if c1 is None else c1[i],
                                           None if c2 is None else c2[i])
            lam[i] = dk
            b = b.copy()
            b[i] = tau
            db[i] = dt
            plastic = slip.copy()
        else:
            i = np.nonzero(slip)[0]
            zs, rs, gs, ks = zn[i], r[i], g[i], kappa0[i]
            a1 = None if c1 is None else c1[i]
            a2 = None if c2 is None else c2[i]
            lo = np.zeros(i.size)
            hi = zs / rs * (1 + 1e-12)           # b >= 0: |z| - r hi <= 0 <= b(hi)
            bb, dbb, _ = _bound(lo, gs, law, ks, a1, a2)
            lm = np.clip((zs - bb) / (rs + dbb), lo, hi)
            scale = zs / rs
            for _ in range(iterations):
                bb, dbb, _ = _bound(lm, gs, law, ks, a1, a2)
                f = bb + rs * lm - zs           # increasing in lam while b' > -r
                if np.abs(f).max() <= 1e-13 * np.max(zs):
                    break
                lo = np.where(f < 0, lm, lo)
                hi = np.where(f >= 0, lm, hi)
                den = rs + dbb
                new = lm - f / np.where(den > 0, den, 1.0)
                bad = (den <= 0) | (new <= lo) | (new >= hi)
                lm = np.where(bad, 0.5 * (lo + hi), new)
                if np.all(hi - lo <= 1e-15 * scale):
                    break
            lam[i] = lm
        if not fast:
            bb, dbb, pl = _bound(lam, g, law, kappa0, c1, c2)
            b = np.where(slip, bb, b)
            db = np.where(slip, dbb, 0.0)
            plastic = slip & pl
    p = np.where(stick[:, None], z, b[:, None] * zhat)
    fac = np.where(slip, b / np.where(zn > 0, zn, 1.0), 1.0)
    radial = np.where(slip, db / (db + r), 1.0)
    slope = np.where(plastic, db, 0.0)
    state = np.where(stick, ADHESION, np.where(plastic, PLASTIC, SLIP))
    plam = np.zeros(n)
    if fast:
        plam = np.where(slip, lam, 0.0)
    elif law is not None and slip.any():
        plam = _plastic_part(lam, plastic, g, law, kappa0, c1, c2)
    return Projection(p=p, lam=lam, state=state, plastic_lam=plam, zhat=zhat, fac=fac,
                      radial=radial, slope=slope)


def _plastic_part(lam, plastic, g, law, kappa0, c1, c2):
    """The plastic deformation in a step of slip ``lam``: all of it where the end state is
    plastic; where hardening lifted the yield stress to ``g`` during the step, the part
    until then; none where the element slid on ``g`` throughout.
    """
    tau0, _ = law.stress(kappa0, c1, c2)
    cross = (tau0 < g) & ~plastic & (lam > 0)
    part = np.where(plastic, lam, 0.0)
    if cross.any():
        reach = law.reaching(g, c1, c2) - kappa0
        part = np.where(cross, np.clip(reach, 0.0, lam), part)
    return part
