"""Regenerate the calibration tables of torlab's default boundary method.

The default boundary method (:mod:`torlab.model.calibrated`) is FASTSIM corrected by
Kalker's exact theory.  The correction is read from three tables, which this module
computes with the exact solver (:mod:`torlab.model.exact`) and FASTSIM
(:mod:`torlab.model.fastsim`, :mod:`torlab.model.creep`) on the same contacts::

    python -m torlab.model.calibration_build            # every table (hours of CPU)
    python -m torlab.model.calibration_build --only longitudinal --jobs 2
    python -m torlab.model.calibration_build --only hardening   # Voce layers (25 min)
    python -m torlab.model.calibration_build --fastsim-only   # FASTSIM columns only
    python -m torlab.model.calibration_build --only spin --a-over-b 2.6 4.1   # these rows

* ``longitudinal.csv``: pure longitudinal creepage on a contact with an elastic layer in
  series (flexibility ``L_mue/p``, thesis Eq. 5.28) and a Coulomb bound ``mu p``, over
  the aspect ratio ``a/b``, the layer's compliance against the half-space's,
  ``lambda = L_mue/(L1 p0)``, and the creepage
  ``x = xi*/(1 + lambda)``, ``xi* = G a b C11 xi/(3 mu N)`` (Kalker's normalisation;
  dividing by ``1 + lambda`` puts the onset of full slip near the same ``x`` whatever
  the layer).  Columns: the exact force ``Fx/(mu N)`` with its discretisation error,
  FASTSIM's, and FASTSIM's adhesion fraction.
* ``hardening.csv``: Voce layers that harden or soften (no Coulomb bound) in pure
  longitudinal creepage, over ``a/b``, ``lambda``, the hardening ``mu_c2/mu_c1`` and the
  Voce ratio ``L_mup/(mu_c1 (L1 p0 + L_mue))`` (:func:`voce_layer`), at the creepages
  ``x`` (``xi*`` at ``mu_c1``).  Columns: the exact ``Fx/(mu_c1 N)`` with its error (three
  grids), FASTSIM's and its adhesion fraction, and the same three of the elastic-perfectly
  plastic layer at the onset on the same contact (``epp``): the default method's factor
  is the exact ratio Voce/EPP over FASTSIM's, whose discretisation errors largely
  cancel.  ``a/b`` and ``lambda`` are coarse (three and five nodes): the factor left
  after the longitudinal table's ratio varies slowly in them.
* ``spin.csv``: a Coulomb contact (no layer) in longitudinal creepage, lateral creepage
  and spin, over ``a/b`` and the normalised creepage vector
  ``v* = (xi*, eta*, phi*)`` (``phi* = G (ab)^(3/2) C23 phi/(3 mu N)``): its length
  ``rho``, the direction ``alpha`` of its translational part in the ``xi*``--``eta*``
  plane, and the spin's share ``sigma`` (:func:`torlab.model.calibrated.spin_share`: the
  spin pole enters the contact at ``|sigma| = 0.5``, where the forces turn fastest, and
  the nodes crowd there).  Columns: the exact
  ``Fx/(mu N)``, ``Fy/(mu N)``, ``Mz/(mu N c)`` with their errors and FASTSIM's.  The
  rows ``rho = inf`` are full slip: the traction ``mu p`` opposes the rigid slip
  (exactly, from a quadrature of Hertz's pressure), and FASTSIM's at ``rho = 1e4``.

The exact values are extrapolated to a vanishing element size from several grids
(``n`` elements across each axis of the ellipse: 20 to 48 in steps of 4 for the
longitudinal table, whose target is 1 %; 24, 32, 40 for the spin table and the
validation sets): the scheme is first order, and a straight line in ``1/n`` through the
values leaves residuals of a few 1e-4 of ``mu N`` (the staircase's jitter,
``docs/model/exact.md``).  The error column (:func:`_extrapolate`) is twice the
intercept's standard error with eight grids, the largest difference from the pairs'
extrapolations with three.  Kalker's coefficients (the flexibilities and the
normalisation) are interpolated between the rows of his table as the default method's
FASTSIM does (:data:`torlab.model.calibrated.TABLE_INTERPOLATION`; at an aspect ratio
between the rows a change of it changes both columns: regenerate that aspect ratio's
rows, ``--a-over-b``).  ``nu`` is 0.28 (steel); ``docs/model/boundary.md`` states
the error for other values.  Near ``x = 0`` of a contact without a layer the exact and
FASTSIM's forces are both Kalker's linear theory (``C11``, which FASTSIM's flexibility
reproduces exactly and the exact solver within its 0.5 %): the table's first node
``x = 0.001`` takes their ratio as 1 there rather than the extrapolation's jitter.

``tests/test_calibrated.py`` recomputes a few rows of each table (exact and FASTSIM)
and checks the shipped numbers against them.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

__all__ = ["ALPHA_DEG", "A_OVER_B", "A_OVER_B_SPIN", "GRIDS", "GRIDS_LONGITUDINAL",
           "HARD_A_OVER_B", "HARD_LAMBDA", "HARD_RATIO", "HARD_VOCE", "HARD_X", "LAMBDA", "NU",
           "RHO", "SIGMA", "X_NODES",
           "epp_reference", "exact_layer_mu", "exact_longitudinal", "exact_spin", "fastsim_longitudinal",
           "fastsim_spin", "full_slip", "hardening_rows", "longitudinal_rows", "main",
           "spin_rows", "twin", "voce_layer"]

#: Poisson's ratio of the tables
NU = 0.28
#: Coulomb coefficient of the tables' contacts (the normalised results do not depend on it)
MU = 0.3
#: aspect ratios a/b
A_OVER_B = (0.2, 0.3, 0.5, 0.7, 1.0, 1.4, 2.0, 3.3, 5.0)
#: the spin table's aspect ratios (denser towards 5, where the forces with spin change most
#: between the nodes)
A_OVER_B_SPIN = (0.2, 0.3, 0.5, 0.7, 1.0, 1.4, 2.0, 2.6, 3.3, 4.1, 5.0)
#: the layer's compliance against the half-space's, L_mue/(L1 p0)
LAMBDA = (0.0, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.8, 1.2, 2.0, 3.2, 5.0)
#: the longitudinal table's creepages x = xi*/(1 + lambda)
X_NODES = (0.001, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.2,
           1.5, 2.0, 3.0)
#: the spin table's lengths |v*| of the normalised creepage vector: beyond the onset of
#: full slip the difference exact - FASTSIM approaches its full-slip value slowly (FASTSIM's
#: spin-pole region shrinks as 1/|v*|), so the nodes continue to 100
RHO = (0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0, 1.3, 1.8, 2.6, 4.0, 6.0, 9.0, 14.0, 25.0,
       50.0, 100.0)
#: directions: the angle of the translational creepage in the xi*-eta* plane (degrees) ...
ALPHA_DEG = (0.0, 18.0, 36.0, 54.0, 72.0, 90.0)
#: ... and the spin's share ``sigma = sign(phi) kappa/(1 + kappa)``, ``kappa`` the spin pole's
#: distance from the centre over the contact's edge in its direction, inverted
#: (:func:`spin_share`): the pole enters the contact at ``|sigma| = 0.5``, where the forces
#: change fastest, so the nodes crowd there
SIGMA = (-1.0, -0.8, -0.75, -0.7, -0.65, -0.6, -0.55, -0.5, -0.45, -0.35, -0.2, 0.0, 0.2, 0.35,
         0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 1.0)
#: the grids the exact values are extrapolated from: eight for the longitudinal table (its
#: target is 1 %, and three grids leave the extrapolation 0.3-0.5 % uncertain), three for
#: the spin table (3 and 5 %) and the validation set
GRIDS = (24, 32, 40)
GRIDS_LONGITUDINAL = (20, 24, 28, 32, 36, 40, 44, 48)
#: FASTSIM's stand-in for infinite creepage in the full-slip rows
RHO_FULL_SLIP = 1e4


def twin(a_over_b: float, layer_ratio: float = 0.0, mu: float = MU,
         interpolation: str | None = None) -> dict[str, Any]:
    """The tables' contact at an aspect ratio: ``sqrt(ab)`` = 6 mm, 100 kN, ``G`` = 82 GPa.

    Returns ``a, b, load, G, nu, p0, L1, L2, L3, L_mue`` (the layer's elastic length for
    ``lambda = layer_ratio``) and the scales ``s`` turning ``xi, eta, phi`` into Kalker's
    normalised creepages (module docstring).  Kalker's coefficients are interpolated
    between his table's rows by ``interpolation`` (:mod:`torlab.model.kalker`; default the
    default method's, :data:`torlab.model.calibrated.TABLE_INTERPOLATION`, on which the
    tables are built; the validation sets' layers were defined with ``"linear"``).
    """
    from torlab.model.calibrated import TABLE_INTERPOLATION
    from torlab.model.kalker import C11, C22, C23, L1, L2, L3

    how = interpolation or TABLE_INTERPOLATION
    c = 6e-3
    g = float(a_over_b)
    a, b = c * math.sqrt(g), c / math.sqrt(g)
    load, G = 100e3, 82e9
    p0 = 3 * load / (2 * math.pi * a * b)
    c11, c22, c23 = (C(g, NU, interpolation=how) for C in (C11, C22, C23))
    l1 = L1(a, c11, G)
    s = G * a * b / (3 * mu * load)
    return {"a": a, "b": b, "load": load, "G": G, "nu": NU, "p0": p0, "mu": mu, "L1": l1,
            "L2": L2(a, c22, G), "L3": L3(a, b, c23, G), "L_mue": layer_ratio * l1 * p0,
            "scale": (s * c11, s * c22, s * math.sqrt(a * b) * c23)}


def _extrapolate(values: np.ndarray, grids: tuple[int, ...] = GRIDS
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares line in ``h = 1/n`` through the grids' values: its value at ``h = 0``
    and that value's error.

    With four grids or more the error is twice the intercept's standard error, the
    scatter about the line (the staircase's jitter) estimated from the residuals; with
    three, the largest difference from the extrapolations of each pair of grids (one
    residual degree of freedom says little about the scatter).
    """
    h = 1.0 / np.asarray(grids, dtype=float)
    A = np.vstack([np.ones_like(h), h]).T
    flat = values.reshape(len(grids), -1)
    coef = np.linalg.lstsq(A, flat, rcond=None)[0]
    f0 = coef[0]
    if len(grids) >= 4:
        resid = flat - A @ coef
        s2 = np.sum(resid * resid, axis=0) / (len(grids) - 2)
        var0 = s2 * np.linalg.inv(A.T @ A)[0, 0]
        err = 2.0 * np.sqrt(var0)
    else:
        err = np.zeros_like(f0)
        for i, j in itertools.combinations(range(len(grids)), 2):
            pair = flat[j] + (flat[j] - flat[i]) * h[j] / (h[i] - h[j])
            err = np.maximum(err, np.abs(pair - f0))
    return f0.reshape(values.shape[1:]), err.reshape(values.shape[1:])


def _exact_contact(t: dict[str, Any]) -> Any:
    from torlab.model.exact import ExactContact, ExactLayer

    layer = None
    if t["L_mue"] > 0:
        layer = ExactLayer(flexibility=None, flexibility_pressure=t["L_mue"],
                           name="elastic layer in series (L_mue/p)")
    return ExactContact(a=t["a"], b=t["b"], load=t["load"], G=t["G"], nu=t["nu"], mu=t["mu"],
                        layer=layer)


def exact_longitudinal(a_over_b: float, layer_ratio: float, x: Any,
                       grids: tuple[int, ...] = GRIDS) -> tuple[np.ndarray, np.ndarray]:
    """Exact ``Fx/(mu N)`` and its error at the longitudinal table's creepages ``x``."""
    from torlab.model.exact import ExactGrid, exact_creep_forces

    t = twin(a_over_b, layer_ratio)
    con = _exact_contact(t)
    xi = np.asarray(x, dtype=float) * (1.0 + layer_ratio) / t["scale"][0]
    vals = np.array([exact_creep_forces(con, xi, 0.0, 0.0, ExactGrid(n=n, coarse=0)).Fx
                     for n in grids]) / (t["mu"] * t["load"])
    return _extrapolate(vals, grids)


def fastsim_longitudinal(a_over_b: float, layer_ratio: float, x: Any
                         ) -> tuple[np.ndarray, np.ndarray]:
    """FASTSIM's ``Fx/(mu N)`` and adhesion fraction on the same contact (default grid)."""
    from torlab.model.fastsim import FastsimProblem, boundary_traction
    from torlab.model.layers import LayerParams

    t = twin(a_over_b, layer_ratio)
    prob = FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"],
                          layer=LayerParams(t["mu"], t["mu"], t["L_mue"], 0.0))
    xi = np.asarray(x, dtype=float) * (1.0 + layer_ratio) / t["scale"][0]
    r = boundary_traction(prob, xi)
    return r.mu / t["mu"], r.adhesion_fraction


def direction(rho: Any, alpha_deg: Any, sigma: Any, a_over_b: float) -> np.ndarray:
    """Normalised creepages ``(xi*, eta*, phi*)`` (..., 3) of the spin table's coordinates:
    the length ``rho``, the translational direction ``alpha`` and the spin share ``sigma``
    (:func:`torlab.model.calibrated.spin_share` inverted)."""
    from torlab.model.calibrated import pole_scale

    al = np.radians(alpha_deg)
    sg = np.asarray(sigma, dtype=float)
    ux, uy = np.cos(al), np.sin(al)
    k = np.abs(sg) / np.maximum(1.0 - np.abs(sg), 1e-300)  # kappa
    ph = np.sign(sg) * k * pole_scale(a_over_b, ux, uy, *_coefficients(a_over_b))
    pure = np.abs(sg) >= 1.0
    t = np.where(pure, 0.0, 1.0)
    ph = np.where(pure, np.sign(sg), ph)
    v = np.stack(np.broadcast_arrays(t * ux, t * uy, ph), -1)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return np.asarray(rho, dtype=float)[..., None] * v


def _coefficients(a_over_b: float) -> tuple[float, float, float]:
    from torlab.model.calibrated import TABLE_INTERPOLATION
    from torlab.model.kalker import creepage_coefficients

    return creepage_coefficients(a_over_b, NU, interpolation=TABLE_INTERPOLATION)


def exact_spin(a_over_b: float, v: np.ndarray, grids: tuple[int, ...] = GRIDS
               ) -> tuple[np.ndarray, np.ndarray]:
    """Exact ``(Fx/(mu N), Fy/(mu N), Mz/(mu N c))`` (k, 3) and their errors at the
    normalised creepages ``v`` (k, 3) of a Coulomb contact."""
    from torlab.model.exact import ExactGrid, exact_creep_forces

    t = twin(a_over_b)
    con = _exact_contact(t)
    cr = [v[:, i] / t["scale"][i] for i in range(3)]
    muN, c = t["mu"] * t["load"], math.sqrt(t["a"] * t["b"])
    out = []
    for n in grids:
        r = exact_creep_forces(con, *cr, ExactGrid(n=n, coarse=0))
        out.append(np.stack([r.Fx / muN, r.Fy / muN, r.Mz / (muN * c)], -1))
    return _extrapolate(np.array(out), grids)


def fastsim_spin(a_over_b: float, v: np.ndarray) -> np.ndarray:
    """FASTSIM's normalised ``(Fx, Fy, Mz)`` (k, 3) on the same Coulomb contact."""
    from torlab.model.creep import CreepProblem, creep_forces
    from torlab.model.layers import LayerParams

    t = twin(a_over_b)
    prob = CreepProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], L2=t["L2"], L3=t["L3"],
                        layer=LayerParams(t["mu"], t["mu"], 0.0, 0.0))
    cr = [v[:, i] / t["scale"][i] for i in range(3)]
    r = creep_forces(prob, *cr)
    muN, c = t["mu"] * t["load"], math.sqrt(t["a"] * t["b"])
    return np.stack([r.Fx / muN, r.Fy / muN, r.Mz / (muN * c)], -1)


def linear_slopes(a_over_b: float, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kalker's linear theory and FASTSIM's along unit directions ``u`` (k, 3): the
    normalised forces per unit length of ``v*`` as it vanishes.  Kalker's:
    ``Fx = 3 xi*``, ``Fy = 3 (eta* + phi*)``, ``Mz = 3 (C33/C23) phi* - 3 (C32/C22) eta*``
    with ``C32 = C23`` (his Table E.3, :func:`torlab.model.kalker.C33`); FASTSIM's from its
    forces at ``|v*| = 1e-6`` (its ``C33`` and ``C32`` are not Kalker's)."""
    from torlab.model.calibrated import TABLE_INTERPOLATION
    from torlab.model.kalker import C33

    _, c22, c23 = _coefficients(a_over_b)
    c33 = C33(a_over_b, NU, interpolation=TABLE_INTERPOLATION)
    u = np.asarray(u, dtype=float)
    ex = np.stack([3 * u[:, 0], 3 * (u[:, 1] + u[:, 2]),
                   3 * (c33 / c23) * u[:, 2] - 3 * (c23 / c22) * u[:, 1]], -1)
    small = 1e-6
    return ex, fastsim_spin(a_over_b, u * small) / small


def full_slip(a_over_b: float, u: np.ndarray, nodes: int = 160) -> np.ndarray:
    """Full slip at infinite creepage along the unit directions ``u`` (k, 3): the traction
    ``mu p`` opposes the rigid slip ``(xi - phi y, eta + phi x)`` everywhere; normalised
    ``(Fx, Fy, Mz)`` (k, 3) by Gauss quadrature of Hertz's pressure.

    The direction field turns by pi across the point where the rigid slip vanishes (spin);
    the quadrature splits the ellipse into ``nodes`` rings and angles, accurate to about
    1e-4 there and to round-off elsewhere.
    """
    t = twin(a_over_b)
    a, b = t["a"], t["b"]
    r, wr = np.polynomial.legendre.leggauss(nodes)
    r, wr = 0.5 * (r + 1.0), 0.5 * wr
    ang = (np.arange(2 * nodes) + 0.5) * math.pi / nodes
    R, T = np.meshgrid(r, ang, indexing="ij")
    x, y = a * R * np.cos(T), b * R * np.sin(T)
    # p dA = p0 sqrt(1 - r^2) a b r dr dt; mu N = mu 2 pi a b p0 / 3
    w = (wr[:, None] * np.sqrt(1.0 - R * R) * R * (math.pi / nodes)) * 3.0 / (2.0 * math.pi)
    c = math.sqrt(a * b)
    out = np.empty((len(u), 3))
    for k, (ux, uy, uz) in enumerate(np.asarray(u, dtype=float)):
        xi, eta, phi = ux / t["scale"][0], uy / t["scale"][1], uz / t["scale"][2]
        wx, wy = xi - phi * y, eta + phi * x
        m = np.hypot(wx, wy)
        m = np.where(m > 0, m, np.inf)
        tx, ty = wx / m, wy / m
        out[k] = [np.sum(w * tx), np.sum(w * ty), np.sum(w * (x * ty - y * tx)) / c]
    return out


def longitudinal_rows(a_over_b: Any = A_OVER_B, layer_ratio: Any = LAMBDA, x: Any = X_NODES,
                      exact: bool = True, grids: tuple[int, ...] = GRIDS_LONGITUDINAL,
                      progress: Any = None) -> Any:
    """The longitudinal table (module docstring) as a DataFrame."""
    import pandas as pd

    rows = []
    for g, lam in itertools.product(a_over_b, layer_ratio):
        xs = np.asarray(x, dtype=float)
        fs, adh = fastsim_longitudinal(g, lam, xs)
        ex, err = exact_longitudinal(g, lam, xs, grids) if exact else (np.nan * xs, np.nan * xs)
        for i in range(xs.size):
            rows.append({"a_over_b": g, "layer_ratio": lam, "x": xs[i], "exact_Fx": ex[i],
                         "exact_Fx_error": err[i], "fastsim_Fx": fs[i],
                         "fastsim_adhesion": adh[i]})
        if progress:
            progress(f"longitudinal a/b {g:g}, lambda {lam:g}")
    return pd.DataFrame(rows)


def spin_rows(a_over_b: Any = A_OVER_B_SPIN, rho: Any = RHO, alpha_deg: Any = ALPHA_DEG,
              sigma: Any = SIGMA, exact: bool = True, grids: tuple[int, ...] = GRIDS,
              progress: Any = None) -> Any:
    """The spin table (module docstring) as a DataFrame (pure-spin directions, ``sigma =
    +-1``, are solved once and repeated for every ``alpha``)."""
    import pandas as pd

    rows = []
    rho = np.asarray(rho, dtype=float)
    for g in a_over_b:
        done: dict[float, tuple[np.ndarray, ...]] = {}
        for al, sg in itertools.product(alpha_deg, sigma):
            if abs(sg) == 1.0 and sg in done:
                ex, err, fs, fsl, fsf = done[sg]
            else:
                v = direction(rho, al, sg, g)
                fs = fastsim_spin(g, v)
                if exact:
                    ex, err = exact_spin(g, v, grids)
                else:
                    ex, err = np.full(v.shape, np.nan), np.full(v.shape, np.nan)
                u = direction(1.0, al, sg, g)[None, :]
                fsl = full_slip(g, u)[0]
                fsf = fastsim_spin(g, u * RHO_FULL_SLIP)[0]
                done[sg] = (ex, err, fs, fsl, fsf)
            v = direction(rho, al, sg, g)
            u = direction(1.0, al, sg, g)
            lin_ex, lin_fs = linear_slopes(g, u[None, :])
            rows.append({"a_over_b": g, "rho": 0.0, "alpha_deg": al, "sigma": sg,
                         "xi_star": u[0], "eta_star": u[1], "phi_star": u[2],
                         "exact_Fx": lin_ex[0, 0], "exact_Fy": lin_ex[0, 1],
                         "exact_Mz": lin_ex[0, 2], "exact_Fx_error": 0.0,
                         "exact_Fy_error": 0.0, "exact_Mz_error": 0.005 * abs(lin_ex[0, 2]),
                         "fastsim_Fx": lin_fs[0, 0], "fastsim_Fy": lin_fs[0, 1],
                         "fastsim_Mz": lin_fs[0, 2]})
            for i in range(rho.size + 1):
                last = i == rho.size
                r = math.inf if last else rho[i]
                e = fsl if last else ex[i]
                de = np.zeros(3) if last else err[i]
                f = fsf if last else fs[i]
                vi = direction(1.0, al, sg, g) if last else v[i]
                rows.append({"a_over_b": g, "rho": r, "alpha_deg": al, "sigma": sg,
                             "xi_star": vi[0], "eta_star": vi[1], "phi_star": vi[2],
                             "exact_Fx": e[0], "exact_Fy": e[1], "exact_Mz": e[2],
                             "exact_Fx_error": de[0], "exact_Fy_error": de[1],
                             "exact_Mz_error": de[2], "fastsim_Fx": f[0], "fastsim_Fy": f[1],
                             "fastsim_Mz": f[2]})
            if progress:
                progress(f"spin a/b {g:g}, alpha {al:g}, sigma {sg:g}")
    return pd.DataFrame(rows)


#: the hardening table's nodes (``hardening.csv``): aspect ratios, the layer's compliance
#: ratio ``lambda``, the hardening ``mu_c2/mu_c1`` (1 is the longitudinal table's own
#: elastic-perfectly plastic layer, not computed), the Voce length over the elastic
#: displacement at the onset (:func:`voce_ratio`) and the creepages ``x``; coarse in
#: ``a/b`` and ``lambda``, where the ratio to the longitudinal table's correction varies
#: slowly (``docs/model/boundary.md``)
HARD_A_OVER_B = (0.2, 0.5, 1.4)
HARD_LAMBDA = (0.02, 0.1, 0.3, 1.0, 3.0)
HARD_RATIO = (0.6, 0.8, 1.25, 1.7)
HARD_VOCE = (0.1, 0.3, 1.0, 3.0)
HARD_X = (0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.75, 0.9, 1.1, 1.4, 2.0, 3.0)
#: the smallest Voce length the exact solver splits the layer's slip with, in units of
#: ``|mu_c2 - mu_c1| L_mue`` (its plastic branch must be less steep than the elastic one)
VOCE_FLOOR = 1.5


def voce_layer(t: dict[str, Any], mu_c1: float, mu_c2: float, voce: float) -> Any:
    """A Voce layer on the contact ``t`` (:func:`twin`): its elastic length ``t["L_mue"]``,
    and ``L_mup = voce mu_c1 (L1 p0 + L_mue)`` (the elastic displacement at the onset at the
    centre), at least :data:`VOCE_FLOOR` ``|mu_c2 - mu_c1| L_mue``."""
    from torlab.model.layers import LayerParams

    onset = mu_c1 * (t["L1"] * t["p0"] + t["L_mue"])
    lp = max(voce * onset, VOCE_FLOOR * abs(mu_c2 - mu_c1) * t["L_mue"])
    return LayerParams(mu_c1, mu_c2, t["L_mue"], lp)


def exact_layer_mu(t: dict[str, Any], lay: Any, xi: Any, grids: tuple[int, ...] = GRIDS
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The exact solver's traction coefficient ``Fx/N`` of the contact ``t`` with the layer
    ``lay`` (no Coulomb bound) at creepages ``xi``, extrapolated from ``grids``, and its
    error; NaN where the solver does not converge (the caller says so)."""
    from torlab.errors import ConvergenceError
    from torlab.model.exact import ExactContact, ExactGrid, exact_creep_forces
    from torlab.model.exact.scene import scene_layer

    con = ExactContact(a=t["a"], b=t["b"], load=t["load"], G=t["G"], nu=t["nu"],
                       mu=math.inf, layer=scene_layer(SimpleNamespace(layer=lay)))
    xi = np.asarray(xi, dtype=float)
    try:
        vals = np.array([exact_creep_forces(con, xi, 0.0, 0.0, ExactGrid(n=n, coarse=0)).mu_x
                         for n in grids])
    except ConvergenceError:
        vals = np.full((len(grids), xi.size), np.nan)
    return _extrapolate(vals, grids)


def epp_reference(t: dict[str, Any], xi: Any, exact: bool = True,
                  grids: tuple[int, ...] = GRIDS) -> tuple[np.ndarray, ...]:
    """The hardening table's reference on the contact ``t``: the elastic-perfectly plastic
    layer at the onset (a Voce layer with ``mu_c2 = mu_c1``), exact ``Fx/(mu N)`` and its
    error on the same ``grids`` as the Voce layers (their discretisation errors largely
    cancel in the ratio), and FASTSIM's."""
    from torlab.model.fastsim import FastsimProblem, boundary_traction

    lay = voce_layer(t, MU, MU, 1.0)
    prob = FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], layer=lay)
    fs = boundary_traction(prob, xi).mu / MU
    xi = np.asarray(xi, dtype=float)
    ex, err = exact_layer_mu(t, lay, xi, grids) if exact else (np.nan * xi, np.nan * xi)
    return ex / MU, err / MU, fs


def hardening_rows(a_over_b: Any = HARD_A_OVER_B, layer_ratio: Any = HARD_LAMBDA,
                   hardening: Any = HARD_RATIO, voce: Any = HARD_VOCE, x: Any = HARD_X,
                   exact: bool = True, grids: tuple[int, ...] = GRIDS,
                   progress: Any = None) -> Any:
    """The hardening table: Voce layers in pure longitudinal creepage, exact and FASTSIM's
    ``Fx/(mu_c1 N)`` over ``a/b``, ``lambda``, ``mu_c2/mu_c1``, the Voce ratio and
    ``x = xi*/(1 + lambda)`` (``xi*`` at ``mu_c1``), with the elastic-perfectly plastic
    layer's (:func:`epp_reference`), as a DataFrame.  The column
    ``voce_ratio`` is the node; ``L_mup_m`` the layer's length (above the node's where the
    exact solver needs it, :func:`voce_layer`)."""
    import pandas as pd

    from torlab.model.fastsim import FastsimProblem, boundary_traction

    rows = []
    xs = np.asarray(x, dtype=float)
    for g, lam in itertools.product(a_over_b, layer_ratio):
        t = twin(g, lam)
        xi = xs * (1.0 + lam) / t["scale"][0]
        ex_p, err_p, fs_p = epp_reference(t, xi, exact, grids)
        for h, v in itertools.product(hardening, voce):
            lay = voce_layer(t, MU, MU * h, v)
            prob = FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], layer=lay)
            r = boundary_traction(prob, xi)
            ex, err = (exact_layer_mu(t, lay, xi, grids) if exact
                       else (np.nan * xs, np.nan * xs))
            if exact and progress and np.isnan(ex).any():
                progress(f"hardening a/b {g:g}, lambda {lam:g}, mu_c2/mu_c1 {h:g}, "
                         f"Voce {v:g}: exact solver failed")
            for i in range(xs.size):
                rows.append({"a_over_b": g, "layer_ratio": lam, "hardening": h,
                             "voce_ratio": v, "L_mup_m": lay.L_mup, "x": xs[i],
                             "exact_Fx": ex[i] / MU, "exact_Fx_error": err[i] / MU,
                             "fastsim_Fx": r.mu[i] / MU,
                             "fastsim_adhesion": r.adhesion_fraction[i],
                             "exact_epp_Fx": ex_p[i], "exact_epp_Fx_error": err_p[i],
                             "fastsim_epp_Fx": fs_p[i]})
        if progress:
            progress(f"hardening a/b {g:g}, lambda {lam:g}")
    return pd.DataFrame(rows)


#: the validation set's scenes: (a/b, lambda, mu_c1, mu_c2, L_mup/(L1 p0 mu_c1)) drawn by a
#: seeded Latin hypercube (:func:`validation_scenes`)
VALIDATION_SEED = 28
VALIDATION_SCENES = 16
#: the validation creepages, as x = xi*/(1 + lambda) with xi* at mu_c1
VALIDATION_X = (0.03, 0.08, 0.15, 0.25, 0.4, 0.55, 0.7, 0.9, 1.3, 2.5)


def validation_scenes(n: int = VALIDATION_SCENES, seed: int = VALIDATION_SEED) -> list[dict]:
    """Layers with a Voce law for the validation of the correction (not used by it):
    ``a/b`` log-uniform in [0.25, 4], ``lambda`` log-uniform in [0.02, 3], ``mu_c1`` in
    [0.2, 0.45], ``mu_c2/mu_c1`` log-uniform in [0.6, 1.7] and the Voce length
    ``L_mup`` log-uniform in [0.1, 3] times the elastic displacement at the onset
    ``tau_c1 (L1 + L_mue/p0)`` at the centre; a Latin hypercube, so every range is
    covered evenly."""
    rng = np.random.default_rng(seed)
    u = (np.argsort(rng.random((5, n)), axis=1) + rng.random((5, n))) / n
    ab = np.exp(np.log(0.25) + u[0] * np.log(16.0))
    lam = np.exp(np.log(0.02) + u[1] * np.log(150.0))
    mu1 = 0.2 + 0.25 * u[2]
    mu2 = mu1 * np.exp(np.log(0.6) + u[3] * np.log(1.7 / 0.6))
    lp = np.exp(np.log(0.1) + u[4] * np.log(30.0))
    return [{"a_over_b": float(ab[i]), "layer_ratio": float(lam[i]), "mu_c1": float(mu1[i]),
             "mu_c2": float(mu2[i]), "voce_ratio": float(lp[i])} for i in range(n)]


def _validation_layer(t: dict[str, Any], s: dict[str, float]) -> Any:
    from torlab.model.layers import LayerParams

    onset = s["mu_c1"] * (t["L1"] * t["p0"] + t["L_mue"])
    # the exact solver splits the layer's slip into elastic and plastic parts only where
    # the plastic branch is less steep than the elastic one: |mu_c2 - mu_c1| L_mue < L_mup
    lp = max(s["voce_ratio"] * onset, 1.5 * abs(s["mu_c2"] - s["mu_c1"]) * t["L_mue"])
    return LayerParams(s["mu_c1"], s["mu_c2"], t["L_mue"], lp)


def validation_rows(scenes: list[dict] | None = None, x: Any = VALIDATION_X,
                    grids: tuple[int, ...] = GRIDS, progress: Any = None) -> Any:
    """Exact and FASTSIM traction of the validation scenes (Voce layers; pure creepage)."""
    import pandas as pd

    from torlab.errors import ConvergenceError
    from torlab.model.exact import ExactGrid, exact_creep_forces
    from torlab.model.exact.scene import scene_layer
    from torlab.model.fastsim import FastsimProblem, boundary_traction

    rows = []
    for k, s in enumerate(scenes or validation_scenes()):
        # the layers defined, and Kalker's FASTSIM computed, with CONTACT's coefficients
        t = twin(s["a_over_b"], s["layer_ratio"], mu=s["mu_c1"], interpolation="linear")
        lay = _validation_layer(t, s)
        xs = np.asarray(x, dtype=float)
        xi = xs * (1.0 + s["layer_ratio"]) / t["scale"][0]
        from torlab.model.exact import ExactContact

        con = ExactContact(a=t["a"], b=t["b"], load=t["load"], G=t["G"], nu=t["nu"],
                           mu=math.inf, layer=scene_layer(SimpleNamespace(layer=lay)))
        try:
            vals = np.array([exact_creep_forces(con, xi, 0.0, 0.0,
                                                ExactGrid(n=n, coarse=0)).mu_x
                             for n in grids])
        except ConvergenceError as e:  # recorded: the exact solver's own limits
            if progress:
                progress(f"validation scene {k}: exact solver failed ({e})")
            vals = np.full((len(grids), xs.size), np.nan)
        ex, err = _extrapolate(vals, grids)
        prob = FastsimProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], layer=lay)
        fs = boundary_traction(prob, xi).mu
        for i in range(xs.size):
            rows.append({"scene": k, **s, "L_mue_m": lay.L_mue, "L_mup_m": lay.L_mup,
                         "x": xs[i], "creepage": xi[i], "exact_mu": ex[i],
                         "exact_mu_error": err[i], "fastsim_kalker_mu": fs[i]})
        if progress:
            progress(f"validation scene {k}")
    return pd.DataFrame(rows)


#: the validation points with lateral creepage and spin: normalised (xi*, eta*, phi*) at the
#: layer's onset coefficient, divided by 1 + lambda as the longitudinal table's x
VALIDATION_SPIN_V = ((0.1, 0.1, 0.1), (0.3, 0.0, 0.3), (0.0, 0.4, -0.3), (0.2, 0.3, 0.4),
                     (0.6, 0.2, -0.2), (0.0, 0.0, 0.6), (0.1, 1.2, 0.5))
VALIDATION_SPIN_SCENES = 8


def validation_spin_rows(scenes: list[dict] | None = None, v: Any = VALIDATION_SPIN_V,
                         grids: tuple[int, ...] = GRIDS, progress: Any = None) -> Any:
    """Exact and FASTSIM creep forces of the first validation scenes (Voce layers) with
    lateral creepage and spin (the correction's transfer to a layer is checked on them)."""
    import pandas as pd

    from torlab.errors import ConvergenceError
    from torlab.model.creep import CreepProblem, creep_forces
    from torlab.model.exact import ExactContact, ExactGrid, exact_creep_forces
    from torlab.model.exact.scene import scene_layer

    rows = []
    vs = np.asarray(v, dtype=float)
    for k, s in enumerate((scenes or validation_scenes())[:VALIDATION_SPIN_SCENES]):
        # the layers defined, and Kalker's FASTSIM computed, with CONTACT's coefficients
        t = twin(s["a_over_b"], s["layer_ratio"], mu=s["mu_c1"], interpolation="linear")
        lay = _validation_layer(t, s)
        cr = [vs[:, i] * (1.0 + s["layer_ratio"]) / t["scale"][i] for i in range(3)]
        con = ExactContact(a=t["a"], b=t["b"], load=t["load"], G=t["G"], nu=t["nu"],
                           mu=math.inf, layer=scene_layer(SimpleNamespace(layer=lay)))
        try:
            vals = np.array([np.stack([r.Fx, r.Fy, r.Mz], -1) for r in
                             (exact_creep_forces(con, *cr, ExactGrid(n=n, coarse=0))
                              for n in grids)])
        except ConvergenceError as e:
            if progress:
                progress(f"validation scene {k} with spin: exact solver failed ({e})")
            vals = np.full((len(grids), len(vs), 3), np.nan)
        ex, err = _extrapolate(vals, grids)
        prob = CreepProblem(a=t["a"], b=t["b"], p0=t["p0"], L1=t["L1"], L2=t["L2"],
                            L3=t["L3"], layer=lay)
        fs = creep_forces(prob, *cr)
        for i in range(len(vs)):
            rows.append({"scene": k, **s, "L_mue_m": lay.L_mue, "L_mup_m": lay.L_mup,
                         "xi_star": vs[i, 0], "eta_star": vs[i, 1], "phi_star": vs[i, 2],
                         "creepage": cr[0][i], "lateral": cr[1][i], "spin_1_m": cr[2][i],
                         "exact_Fx_N": ex[i, 0], "exact_Fy_N": ex[i, 1], "exact_Mz_Nm": ex[i, 2],
                         "exact_Fx_error_N": err[i, 0], "exact_Fy_error_N": err[i, 1],
                         "exact_Mz_error_Nm": err[i, 2], "fastsim_kalker_Fx_N": fs.Fx[i],
                         "fastsim_kalker_Fy_N": fs.Fy[i], "fastsim_kalker_Mz_Nm": fs.Mz[i]})
        if progress:
            progress(f"validation scene {k} with spin")
    return pd.DataFrame(rows)


def method_values(case: Any, method: str = "fastsim") -> dict[str, float]:
    """A case of the FASTSIM-error table (:mod:`torlab.model.exact.fastsim_error`) by a fast
    boundary method: ``{quantity: value}``, normalised as the table's (``fastsim``: the
    default, FASTSIM corrected by the exact theory; ``fastsim-kalker``: Kalker's FASTSIM,
    the table's own FASTSIM column)."""
    from dataclasses import replace

    from torlab.model.creep import creep_forces
    from torlab.model.exact.fastsim_error import (
        MU,
        case_contact,
        case_creepages,
        case_scales,
        fastsim_values,
    )

    if method == "fastsim-kalker":
        return fastsim_values(case)
    t = twin(case.a_over_b)
    contact = case_contact(case)
    from torlab.model.creep import CreepProblem
    from torlab.model.layers import LayerParams

    linear = case.quantities[0] in ("C33", "C32")
    mu = 1e6 if linear else MU
    prob = CreepProblem(a=contact.a, b=contact.b, p0=contact.p0, L1=t["L1"], L2=t["L2"],
                        L3=t["L3"], layer=LayerParams(mu_c1=mu, mu_c2=mu), calibrated=True)
    c = math.sqrt(contact.a * contact.b)
    G = contact.G
    if linear:
        small = 1e-6
        rs = creep_forces(prob, 0.0, 0.0, small / c)
        rl = creep_forces(prob, 0.0, small, 0.0)
        return {"C33": float(rs.Mz) / (G * c**3 * small),
                "C32": -float(rl.Mz) / (G * c**3 * small)}
    r = creep_forces(replace(prob), *case_creepages(case, contact))
    sc = case_scales(contact)
    return {q: float(getattr(r, q)) / sc[q] for q in case.quantities}


#: where the tables live
DATA = Path(__file__).with_name("data")


def main(argv: list[str] | None = None) -> int:
    """Command line (module docstring)."""
    ap = argparse.ArgumentParser(prog="python -m torlab.model.calibration_build",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", choices=("longitudinal", "spin", "hardening", "validation",
                                       "validation_spin"))
    ap.add_argument("--fastsim-only", action="store_true",
                    help="recompute FASTSIM's columns, keep the exact ones")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, default=DATA)
    ap.add_argument("--a-over-b", type=float, nargs="*", default=None,
                    help="only these aspect ratios: their rows replace (or join) those of "
                         "the table in --out, the others are kept")
    args = ap.parse_args(argv)
    import pandas as pd

    from torlab import parallel

    t0 = time.time()

    def progress(msg: str) -> None:
        print(f"{time.time() - t0:8.0f} s  {msg}", flush=True)

    given = tuple(args.a_over_b) if args.a_over_b else None
    args.out.mkdir(parents=True, exist_ok=True)
    default_ab = {"longitudinal": A_OVER_B, "spin": A_OVER_B_SPIN,
                  "hardening": HARD_A_OVER_B}
    with parallel.use(parallel.get_executor(args.jobs)):
        for name, build in (("longitudinal", longitudinal_rows), ("spin", spin_rows),
                            ("hardening", hardening_rows), ("validation", validation_rows),
                            ("validation_spin", validation_spin_rows)):
            if args.only and args.only != name:
                continue
            if name.startswith("validation") and (args.fastsim_only or args.a_over_b):
                continue
            path = args.out / f"{name}.csv"
            old = pd.read_csv(path) if path.exists() else None
            mine = (np.zeros(0, bool) if old is None else
                    np.isclose(old["a_over_b"].to_numpy()[:, None], given).any(axis=1)
                    if given else np.ones(len(old), bool))
            if args.fastsim_only:
                if old is None:
                    raise SystemExit(f"{path}: no table to take the exact columns from")
                new = build(a_over_b=given or default_ab[name], exact=False,
                            progress=progress)
                keep = [c for c in old.columns if c.startswith("exact")]
                if len(new) != int(mine.sum()):
                    raise SystemExit(f"{path}: the table's rows are not this build's grid")
                new[keep] = old.loc[mine, keep].to_numpy()
                df = new
            elif name.startswith("validation"):
                df = build(progress=progress)
            else:
                df = build(a_over_b=given or default_ab[name], progress=progress)
            if given and old is not None:  # the other aspect ratios' rows are kept
                df = pd.concat([old[~mine], df], ignore_index=True)
                df = df.sort_values("a_over_b", kind="stable", ignore_index=True)
            tmp = path.with_suffix(".csv.tmp")
            df.to_csv(tmp, index=False, float_format="%.7g", na_rep="nan")
            tmp.replace(path)
            progress(f"wrote {path}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
