"""torlab's default boundary method: FASTSIM corrected by Kalker's exact theory.

FASTSIM (:mod:`torlab.model.fastsim`, :mod:`torlab.model.creep`) solves Kalker's
*simplified* theory: every surface particle is a spring of its own.  Against the
*exact* half-space theory (:mod:`torlab.model.exact`) its forces are 2--6 % off in pure
creepage, up to 10 % with a third-body layer, and 10--40 % in the lateral force and the
spin moment with spin (``docs/model/exact.md``).  The method ``fastsim`` (the default)
keeps FASTSIM -- its layer, Voce limit, temperature and speed, with Kalker's coefficients
interpolated smoothly between the rows of his table (:data:`TABLE_INTERPOLATION`,
:mod:`torlab.model.kalker`) -- and corrects its forces by the exact theory's, read from two
tables the exact solver computed once (:mod:`torlab.model.calibration_build` regenerates
them):

* **Longitudinal creepage** (``longitudinal.csv``): the exact force over FASTSIM's on a
  contact with the layer's elastic compliance in series and a Coulomb bound, over the
  aspect ratio ``a/b``, the layer's compliance against the half-space's
  ``lambda = L_mue/(L1 p0)`` (thesis Eq. 5.28 against Eq. 5.17) and the creepage
  ``x = xi*/(1 + lambda)``, ``xi* = 4 a xi/(3 pi L1 mu p0)`` (Kalker's normalised
  creepage ``G a b C11 xi/(3 mu N)`` written with the flexibility).  A scene's FASTSIM
  traction is multiplied by the ratio ``R(a/b, lambda, x)`` at its own ``lambda`` and
  ``x`` with ``mu`` the layer's onset coefficient ``mu_c1``: where the stick zone ends.
  For a Coulomb contact and for an elastic-perfectly plastic layer this is the exact
  theory (to the table's accuracy).
* **A hardening or softening Voce layer** (``hardening.csv``): the factor
  ``Q = exact/(FASTSIM R)`` left on Voce layers, over ``a/b``, ``lambda``, the hardening
  ``mu_c2/mu_c1``, the Voce ratio ``L_mup/(mu_c1 (L1 p0 + L_mue))`` (the Voce length over
  the elastic displacement at the onset at the centre) and ``x``; the traction is
  ``mu R Q``.  ``Q = 1`` exactly at ``mu_c2 = mu_c1`` and for the other laws, so that a
  Coulomb contact and an elastic-perfectly plastic layer keep ``R`` alone.  Its measured
  error on an independent validation set is in ``docs/model/boundary.md``.
* **Lateral creepage and spin** (``spin.csv``): the exact forces and FASTSIM's on a
  Coulomb contact over ``a/b`` and the normalised creepage vector
  ``v* = (xi*, eta*, phi*)``: its length ``rho``, the direction ``alpha`` of its
  translational part and the spin's share ``sigma`` (:func:`spin_share`), up to full
  slip at ``rho = inf``, where the exact traction opposes the rigid slip.  A scene's
  forces get the longitudinal ratio on all three (at the vector's length) and the
  Coulomb contact's difference exact - FASTSIM ``D`` beyond its own longitudinal ratio,
  scaled to the scene's force level and by the half-space's share of the compliance
  ``w = 1/(1 + lambda)``::

      F = (R - w (R0 - 1)) F_fastsim + w (|F_fastsim| / |F_c|) mu N D   (:func:`correct_creep`)

  For a Coulomb contact this is the exact theory at every table node, including full
  slip in the rigid-slip direction; with a layer the correction fades as the layer's
  own (local, FASTSIM-like) compliance takes over.

Interpolation is multilinear on the tables' grids (``log a/b``; ``log lambda``, ``log``
of the Voce ratio and ``mu_c2/mu_c1`` for the hardening table; the compactified
creepage ``x/(1 + x)``, ``rho/(1 + rho)``, so that full slip is the grid's end), written
here with numpy rather than :mod:`scipy.interpolate`, whose import alone costs more
than a traction curve.  Outside ``0.2 <= a/b <= 5`` and ``lambda <= 5`` the table's edge
is used and the theory error says so.

The correction changes the forces, not the contact temperature: with ``thermal:`` the
flash temperature is FASTSIM's (its heat flux from FASTSIM's traction).

:func:`theory_error` states each method's error against the exact theory for a
prediction (the tables' own error, and where the correction is only carried over, the
error measured on the validation set of ``docs/model/boundary.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["DEFAULT_METHOD", "FAST_METHODS", "METHODS", "METHOD_TEXT", "TABLE_INTERPOLATION",
           "coefficient_interpolation", "correct_creep", "correct_longitudinal", "layer_ratio",
           "longitudinal_ratio", "method_note", "normalised_longitudinal", "spin_correction"]

#: the boundary methods: FASTSIM corrected by the exact theory (the default), Kalker's
#: FASTSIM as the thesis uses it, the exact solver, and the choice between them
METHODS = ("fastsim", "fastsim-kalker", "exact", "auto")
#: the methods FASTSIM computes (the others dispatch above it)
FAST_METHODS = ("fastsim", "fastsim-kalker")
DEFAULT_METHOD = "fastsim"
#: what each method is, for the output's ``modelled`` list
METHOD_TEXT = {
    "fastsim": "FASTSIM corrected by Kalker's exact theory (calibrated tables, "
               "torlab.model.calibrated)",
    "fastsim-kalker": "FASTSIM with Kalker's flexibilities (the thesis's model, Kalker's "
                      "simplified theory, not corrected)",
    "exact": "Kalker's exact theory (torlab.model.exact)",
}

#: how the default method's FASTSIM interpolates Kalker's coefficients between the rows of
#: his table (:mod:`torlab.model.kalker`): the monotone cubic of ``ln C`` over ``ln g``,
#: which follows the exact theory between the rows; its tables are built with it
TABLE_INTERPOLATION = "log-pchip"

DATA = Path(__file__).with_name("data")
_AB_RANGE = (0.2, 5.0)
_LAMBDA_MAX = 5.0


# --------------------------------------------------------------------------------------------
# multilinear interpolation on a rectangular grid (numpy; no scipy.interpolate import)
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Grid:
    """Values on the Cartesian product of increasing ``axes`` (each clamped at its ends)."""

    axes: tuple[np.ndarray, ...]
    values: np.ndarray  # shape (*len(axes), k)

    #: points interpolated at once (the corners' values of a block: 2^d x points x k)
    BLOCK = 2048

    def __call__(self, *coords: Any) -> np.ndarray:
        """Interpolate at points (coordinates broadcast); shape (..., k).

        Each point's value is the sum over the 2^d corners of its cell, taken in one
        gather from the flat values (the corners' offsets added to the cell's flat
        index), weighted by the product of the coordinates' fractions, multiplied in
        the axes' order and summed over the corners in order."""
        coords = np.broadcast_arrays(*(np.asarray(c, dtype=float) for c in coords))
        shape = coords[0].shape
        k = self.values.shape[-1]
        flat = self.values.reshape(-1, k)
        strides = np.cumprod([1, *(ax.size for ax in self.axes[:0:-1])])[::-1]
        n = coords[0].size
        base = np.zeros(n, dtype=np.intp)
        weights = np.ones((1, n))
        offsets = np.zeros(1, dtype=np.intp)
        for ax, c, stride in zip(self.axes, coords, strides, strict=True):
            c = np.minimum(np.maximum(c.ravel(), ax[0]), ax[-1])
            i = np.minimum(np.searchsorted(ax, c, side="right") - 1, ax.size - 2)
            f = (c - ax[i]) / (ax[i + 1] - ax[i])
            base += i * stride
            weights = np.concatenate([weights * (1.0 - f), weights * f])
            offsets = np.concatenate([offsets, offsets + stride])
        out = np.empty((n, k))
        for lo in range(0, n, self.BLOCK):
            sl = slice(lo, min(lo + self.BLOCK, n))
            corners = flat[base[None, sl] + offsets[:, None]]  # (2^d, points, k)
            out[sl] = np.sum(weights[:, sl, None] * corners, axis=0)
        return out.reshape(*shape, k)


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    """A numeric CSV with a header line: ``{column: values}``."""
    with open(path, encoding="utf-8") as f:
        names = f.readline().strip().split(",")
        data = np.loadtxt(f, delimiter=",", ndmin=2)
    return {n: data[:, i] for i, n in enumerate(names)}


def _compact(v: Any) -> np.ndarray:
    """``v/(1 + v)`` with ``inf -> 1``: the tables' creepage coordinate."""
    v = np.asarray(v, dtype=float)
    return np.where(np.isinf(v), 1.0, v / (1.0 + np.where(np.isinf(v), 0.0, v)))


@cache
def _longitudinal() -> tuple[_Grid, _Grid]:
    """The ratio exact/FASTSIM and its error on (log a/b, lambda, x/(1+x))."""
    t = _read_csv(DATA / "longitudinal.csv")
    ab = np.unique(t["a_over_b"])
    lam = np.unique(t["layer_ratio"])
    x = np.unique(t["x"])
    shape = (ab.size, lam.size, x.size)
    order = np.lexsort((t["x"], t["layer_ratio"], t["a_over_b"]))
    ex = t["exact_Fx"][order].reshape(shape)
    err = t["exact_Fx_error"][order].reshape(shape)
    fs = t["fastsim_Fx"][order].reshape(shape)
    ratio = ex / fs
    rerr = err / fs
    # no layer, vanishing creepage: both are Kalker's linear theory (FASTSIM's flexibility
    # is made for C11), so their ratio is 1 within the half unit of the third digit of
    # Kalker's table; the extrapolation's jitter there is larger
    first = np.flatnonzero(lam == 0.0)
    if first.size and x[0] <= 1e-3:
        ratio[:, first, 0] = 1.0
        rerr[:, first, 0] = 0.003
    # full slip (x -> inf): both are mu N
    ratio = np.concatenate([ratio, np.ones((*shape[:2], 1))], axis=2)
    rerr = np.concatenate([rerr, np.zeros((*shape[:2], 1))], axis=2)
    axes = (np.log(ab), lam, np.append(_compact(x), 1.0))
    return _Grid(axes, ratio[..., None]), _Grid(axes, rerr[..., None])


#: the spin table's node next to zero creepage: the linear theories' slopes rule below it
_RHO_LINEAR = 0.005


@cache
def _spin() -> tuple[_Grid, _Grid, _Grid]:
    """On (log a/b, rho/(1+rho), alpha, sigma): the Coulomb contact's exact forces minus
    FASTSIM's, FASTSIM's own (normalised, 3 components each) and the exact ones' errors.

    The rows ``rho = 0`` hold the two linear theories' slopes (Kalker's and FASTSIM's):
    between zero and the first node ``rho1`` the difference follows its linear-theory slope
    ``s`` and bends onto the node's value quadratically,
    ``D(rho) = s rho + (D(rho1) - s rho1)(rho/rho1)^2`` -- sampled at ``rho = 0.005`` -- so
    that Kalker's ``C33`` and ``C32`` hold as the creepages vanish.
    """
    t = _read_csv(DATA / "spin.csv")
    ab = np.unique(t["a_over_b"])
    rho = np.unique(t["rho"])  # 0 first, inf last
    al = np.unique(t["alpha_deg"])
    sg = np.unique(t["sigma"])
    shape = (ab.size, rho.size, al.size, sg.size)
    order = np.lexsort((t["sigma"], t["alpha_deg"], t["rho"], t["a_over_b"]))

    def block(prefix: str, suffix: str = "") -> np.ndarray:
        return np.stack([t[f"{prefix}{q}{suffix}"][order].reshape(shape)
                         for q in ("Fx", "Fy", "Mz")], axis=-1)

    ex, fs, err = block("exact_"), block("fastsim_"), block("exact_", "_error")
    slope_d, slope_f = ex[:, 0] - fs[:, 0], fs[:, 0]
    r1 = rho[1]
    q = (_RHO_LINEAR / r1) ** 2

    def near(v: np.ndarray, slope: np.ndarray) -> np.ndarray:
        return slope * _RHO_LINEAR + (v[:, 1] - slope * r1) * q

    diff = ex - fs
    diff = np.concatenate([np.zeros_like(diff[:, :1]), near(diff, slope_d)[:, None],
                           diff[:, 1:]], axis=1)
    fsv = np.concatenate([np.zeros_like(fs[:, :1]), near(fs, slope_f)[:, None], fs[:, 1:]],
                         axis=1)
    errv = np.concatenate([np.zeros_like(err[:, :1]), err[:, :1] * _RHO_LINEAR, err[:, 1:]],
                          axis=1)
    axes = (np.log(ab), np.concatenate([[0.0], _compact([_RHO_LINEAR]), _compact(rho[1:])]),
            al, sg)
    return _Grid(axes, diff), _Grid(axes, fsv), _Grid(axes, errv)


def pole_scale(a_over_b: float, ux: Any, uy: Any, c11: float, c22: float, c23: float) -> Any:
    """``phi*`` that puts the spin pole on the contact's edge, per unit translational
    normalised creepage in the direction ``(ux, uy)`` (module :func:`spin_share`)."""
    sa = math.sqrt(a_over_b)
    return c23 * np.hypot(np.asarray(uy) / (sa * c22), np.asarray(ux) * sa / c11)


def spin_share(a_over_b: float, v: np.ndarray, c11: float, c22: float, c23: float) -> np.ndarray:
    """``sigma = sign(phi) kappa/(1 + kappa)`` of normalised creepages ``v`` (..., 3), with
    ``xi* >= 0``, ``eta* >= 0``: ``kappa`` is the spin over the spin that puts the pole of
    the rigid slip ``(xi - phi y, eta + phi x)``, at ``(-eta/phi, xi/phi)``, on the contact's
    edge, ``kappa = |phi| / sqrt((eta/a)^2 + (xi/b)^2)``.  The pole is inside the contact for
    ``|sigma| > 0.5``; pure spin is ``+-1``, no spin ``0``.  In normalised creepages
    ``kappa = |phi*| / (C23 sqrt((eta* sqrt(b/a)/C22)^2 + (xi* sqrt(a/b)/C11)^2))``."""
    v = np.asarray(v, dtype=float)
    edge = np.hypot(v[..., 0], v[..., 1]) * 0.0 + pole_scale(a_over_b, v[..., 0], v[..., 1],
                                                             c11, c22, c23)
    ph = np.abs(v[..., 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(edge > 0, ph / (ph + edge), np.where(ph > 0, 1.0, 0.0))
    return np.sign(v[..., 2]) * share


# --------------------------------------------------------------------------------------------
# the correction
# --------------------------------------------------------------------------------------------
def layer_ratio(L1: float, p0: float, L_mue: Any) -> np.ndarray:
    """``lambda = L_mue/(L1 p0)``: the layer's compliance at the centre against the
    half-space's (thesis Eqs. 5.17, 5.28)."""
    return np.asarray(L_mue, dtype=float) / (L1 * p0)


def normalised_longitudinal(a: float, L1: float, p0: float, mu: Any, xi: Any) -> np.ndarray:
    """Kalker's normalised creepage ``xi* = G a b C11 xi/(3 mu N) = 4 a xi/(3 pi L1 mu p0)``
    (``inf`` where ``mu = 0``)."""
    mu = np.asarray(mu, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(mu > 0, 4.0 * a * np.abs(np.asarray(xi, dtype=float))
                        / (3.0 * math.pi * L1 * np.where(mu > 0, mu, 1.0) * p0), np.inf)


def longitudinal_ratio(a_over_b: Any, lam: Any, x: Any, *, error: bool = True
                       ) -> tuple[np.ndarray, np.ndarray | None]:
    """The ratio exact/FASTSIM of the longitudinal table and (with ``error``) the ratio's
    own error (from the exact values' discretisation error) at ``(a/b, lambda, x)``."""
    ratio, err = _longitudinal()
    la = np.log(np.maximum(np.asarray(a_over_b, dtype=float), 1e-9))
    cx = _compact(x)
    return ratio(la, lam, cx)[..., 0], (err(la, lam, cx)[..., 0] if error else None)


@cache
def _hardening_table() -> tuple[_Grid, _Grid]:
    """The hardening factor ``Q = exact/(FASTSIM R)`` of Voce layers and its error
    (relative: the difference of the Voce and the perfectly plastic layer's relative
    extrapolation errors, whose common part cancels in the ratio) on (log a/b, log lambda,
    mu_c2/mu_c1, log Voce ratio, x/(1+x)); ``Q = 1`` at ``mu_c2 = mu_c1`` (the
    longitudinal table's own layer) and at full slip (both are ``mu_c2 N``).  A node the
    exact solver did not converge on takes the next longer Voce length's value (or, failed
    at every length, 1 with the error measured for the onset's correction alone)."""
    t = _read_csv(DATA / "hardening.csv")
    axes_v = [np.unique(t[k]) for k in ("a_over_b", "layer_ratio", "hardening", "voce_ratio",
                                        "x")]
    shape = tuple(a.size for a in axes_v)
    order = np.lexsort(tuple(t[k] for k in ("x", "voce_ratio", "hardening", "layer_ratio",
                                            "a_over_b")))

    def col(name: str) -> np.ndarray:
        return t[name][order].reshape(shape)

    # exact/(FASTSIM R) with R = exact/FASTSIM of the elastic-perfectly plastic layer: the
    # ratio of the exact values on the same grids, whose discretisation errors cancel
    # largely, over FASTSIM's
    ex, exp_ = col("exact_Fx"), col("exact_epp_Fx")
    q = (ex / exp_) * (col("fastsim_epp_Fx") / col("fastsim_Fx"))
    qerr = np.abs(col("exact_Fx_error") / ex - col("exact_epp_Fx_error") / exp_)
    # a node the solver failed on: the next longer Voce length's value, its error the
    # whole factor's departure from 1
    for k in [*range(shape[3] - 2, -1, -1), shape[3] - 1]:
        bad = np.isnan(q[:, :, :, k])
        if bad.any() and shape[3] > 1:
            near = q[:, :, :, k + 1 if k + 1 < shape[3] else k - 1]
            q[:, :, :, k] = np.where(bad, near, q[:, :, :, k])
            qerr[:, :, :, k] = np.where(bad, np.abs(near - 1.0), qerr[:, :, :, k])
    # failed at every Voce length: the onset's correction alone, with the error measured
    # for it before this table (15 % per unit of |mu_c2 - mu_c1|/max(mu_c1, mu_c2))
    hv = axes_v[2]
    none = np.isnan(q)
    fallback = 0.15 * np.abs(hv - 1.0) / np.maximum(hv, 1.0)
    qerr = np.where(none, fallback[None, None, :, None, None], qerr)
    q = np.where(none, 1.0, q)
    at = int(np.searchsorted(hv, 1.0))
    q = np.insert(q, at, 1.0, axis=2)
    qerr = np.insert(qerr, at, 0.0, axis=2)
    q = np.concatenate([q, np.ones((*q.shape[:4], 1))], axis=4)
    qerr = np.concatenate([qerr, np.zeros((*qerr.shape[:4], 1))], axis=4)
    axes = (np.log(axes_v[0]), np.log(axes_v[1]), np.insert(hv, at, 1.0), np.log(axes_v[3]),
            np.append(_compact(axes_v[4]), 1.0))
    return _Grid(axes, q[..., None]), _Grid(axes, qerr[..., None])


def _hardening_of(prob: Any, layer: Any = None) -> tuple[np.ndarray, np.ndarray] | None:
    """``(mu_c2/mu_c1, Voce ratio)`` of a Voce layer that hardens or softens (arrays per
    draw with ``layer``); None for another law.  The Voce ratio is ``L_mup`` over the
    elastic displacement at the onset at the centre, ``mu_c1 (L1 p0 + L_mue)``."""
    lay = prob.layer if layer is None else layer
    if getattr(lay.law, "name", None) != "voce":
        return None
    mu1 = np.asarray(lay.mu_c1, dtype=float)
    pos = mu1 > 0
    safe = np.where(pos, mu1, 1.0)
    h = np.where(pos, np.asarray(lay.mu_c2, dtype=float) / safe, 1.0)
    onset = safe * (prob.L1 * prob.p0 + np.asarray(lay.L_mue, dtype=float))
    v = np.asarray(lay.L_mup, dtype=float) / onset
    return h, v


def hardening_factor(a_over_b: Any, lam: Any, h: Any, voce: Any, x: Any, *,
                     error: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """The hardening table's factor ``Q`` (exact over the longitudinal table's corrected
    FASTSIM of a Voce layer) and (with ``error``) its own relative error, at
    ``(a/b, lambda, mu_c2/mu_c1, Voce ratio, x)``; exactly 1 where ``mu_c2 = mu_c1``."""
    q, qe = _hardening_table()
    h = np.asarray(h, dtype=float)
    c = (np.log(np.maximum(np.asarray(a_over_b, dtype=float), 1e-9)),
         np.log(np.maximum(np.asarray(lam, dtype=float), 1e-9)), h,
         np.log(np.maximum(np.asarray(voce, dtype=float), 1e-12)), _compact(x))
    flat = h == 1.0
    out = np.where(flat, 1.0, q(*c)[..., 0])
    return out, (np.where(flat, 0.0, qe(*c)[..., 0]) if error else None)


def _layer_of(prob: Any, layer: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """``(lambda, mu_c1)`` of a problem's layer (or of ``layer``: arrays per draw)."""
    lay = prob.layer if layer is None else layer
    return (layer_ratio(prob.L1, prob.p0, lay.L_mue),
            np.asarray(lay.mu_c1, dtype=float))


def correct_longitudinal(prob: Any, xi: Any, mu: Any, layer: Any = None) -> np.ndarray:
    """FASTSIM's traction coefficient ``mu`` at creepages ``xi`` corrected by the exact
    theory (module docstring).

    Parameters
    ----------
    prob
        The :class:`~torlab.model.fastsim.FastsimProblem` (or creep problem) FASTSIM solved.
    xi
        Creepages (fractions), broadcast with ``mu``.
    mu
        FASTSIM's coefficients.
    layer
        Optionally a layer of arrays that broadcast with ``mu`` (one per draw of a band).

    Returns
    -------
    numpy.ndarray
        The corrected coefficients (the shape of ``mu``).
    """
    mu = np.asarray(mu, dtype=float)
    lam, mu1 = _layer_of(prob, layer)
    x = normalised_longitudinal(prob.a, prob.L1, prob.p0, mu1, xi) / (1.0 + lam)
    shape = np.broadcast(x, mu).shape
    R, _ = longitudinal_ratio(prob.a / prob.b, np.broadcast_to(lam, shape), x, error=False)
    hv = _hardening_of(prob, layer)
    if hv is not None:
        Q, _ = hardening_factor(prob.a / prob.b, lam, hv[0], hv[1], x, error=False)
        R = R * np.broadcast_to(Q, shape)
    return mu * R


def spin_correction(a_over_b: float, v: np.ndarray,
                    coefficients: tuple[float, float, float] | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Coulomb table at normalised creepages ``v`` (..., 3): exact minus FASTSIM,
    FASTSIM's own forces (normalised ``Fx, Fy`` by ``mu N``, ``Mz`` by ``mu N c``) and the
    exact values' errors, each (..., 3).  ``coefficients``: Kalker's ``C11, C22, C23`` of
    the contact (default: at ``a/b`` and ``nu = 0.28``, interpolated as the tables' own,
    :data:`TABLE_INTERPOLATION`).

    Uses the symmetries: ``xi* -> -xi*`` reverses ``Fx``; ``(eta*, phi*) -> -(eta*, phi*)``
    reverses ``Fy`` and ``Mz``.
    """
    diff, fs, err = _spin()
    v = np.asarray(v, dtype=float)
    sx = np.where(v[..., 0] < 0, -1.0, 1.0)
    sy = np.where(v[..., 1] < 0, -1.0, 1.0)
    xs, es, ps = np.abs(v[..., 0]), v[..., 1] * sy, v[..., 2] * sy
    rho = np.sqrt(xs * xs + es * es + ps * ps)
    alpha = np.degrees(np.arctan2(es, xs))
    if coefficients is None:
        from torlab.model.kalker import C11, C22, C23

        kw = {"warn": False, "interpolation": TABLE_INTERPOLATION}
        coefficients = (C11(a_over_b, 0.28, **kw), C22(a_over_b, 0.28, **kw),
                        C23(a_over_b, 0.28, **kw))
    sigma = spin_share(a_over_b, np.stack([xs, es, ps], axis=-1), *coefficients)
    la = np.log(max(a_over_b, 1e-9))
    c = (la, _compact(rho), alpha, sigma)
    d, f, e = diff(*c), fs(*c), err(*c)
    flip = np.stack([sx, sy, sy], axis=-1)
    return d * flip, f * flip, e


def correct_creep(prob: Any, xi: Any, eta: Any, phi: Any, Fx: Any, Fy: Any, Mz: Any, *,
                  hardening: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """FASTSIM's creep forces corrected by the exact theory (module docstring).

    ``F = (R - w (R0 - 1)) F_fs + w (|F_fs|/|F_c|) mu N D``: ``R`` the longitudinal
    ratio at the length of the normalised creepage vector (with the layer's ``lambda``,
    ``mu_c1``), ``R0`` the Coulomb contact's, ``D`` the Coulomb contact's difference exact
    - FASTSIM (normalised, the spin table), ``F_c`` its FASTSIM forces at the same
    normalised creepages (lengths of ``(Fx, Fy, Mz/c)``), ``w = 1/(1 + lambda)``.  For a
    Coulomb contact ``F = F_fs + mu N D``: the exact theory at the table's nodes, and
    between them FASTSIM plus the interpolated difference, which varies slowly where
    the forces themselves turn fast.

    Parameters
    ----------
    prob
        The :class:`~torlab.model.creep.CreepProblem` (with ``L2``, ``L3`` where
        ``eta``, ``phi`` are not zero).
    xi, eta, phi
        Creepages (fractions; spin in 1/m), broadcast.
    Fx, Fy, Mz
        FASTSIM's forces [N] and moment [N m].
    hardening
        Apply the hardening table's factor of a Voce layer (without it: the onset's
        ratio alone, which :func:`creep_error` compares with).

    Returns
    -------
    tuple
        The corrected ``(Fx, Fy, Mz)``.
    """
    xi, eta, phi, Fx, Fy, Mz = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                                     for v in (xi, eta, phi, Fx, Fy, Mz)))
    a, b = prob.a, prob.b
    lam, mu1 = _layer_of(prob)
    lam = float(lam)
    mu1 = float(mu1)
    if not mu1 > 0:  # no elastic range: the contact slides from the leading edge
        return Fx.copy(), Fy.copy(), Mz.copy()
    c = math.sqrt(a * b)
    L2 = prob.L2 if prob.L2 is not None else prob.L1
    L3 = prob.L3 if prob.L3 is not None else prob.L1
    muN = mu1 * prob.load
    # Kalker's normalisation written with the flexibilities (G C11 = 8a/(3 L1), ...)
    k = a * b / (3.0 * muN)
    v = np.stack([k * 8 * a / (3 * prob.L1) * xi, k * 8 * a / (3 * L2) * eta,
                  k * c * math.pi * a * math.sqrt(a / b) / (4 * L3) * phi], axis=-1)
    rho = np.linalg.norm(v, axis=-1)
    R, _ = longitudinal_ratio(a / b, lam, rho / (1.0 + lam), error=False)
    hv = _hardening_of(prob) if hardening else None
    if hv is not None:
        # the hardening table holds in pure longitudinal creepage (as boundary_traction's
        # correction); with lateral creepage or spin it is weighed on the longitudinal
        # force by the longitudinal share of the normalised creepage, (xi*/rho)^2, so that
        # the force does not jump as a small lateral creepage or spin is added
        Q = hardening_factor(a / b, lam, hv[0], hv[1], rho / (1.0 + lam), error=False)[0]
        with np.errstate(invalid="ignore", divide="ignore"):
            share = np.where(rho > 0, (v[..., 0] / np.where(rho > 0, rho, 1.0)) ** 2, 1.0)
        Rx = np.where((eta == 0) & (phi == 0), R * Q, R * (1.0 + share * (Q - 1.0)))
    else:
        Rx = R
    R0, _ = longitudinal_ratio(a / b, 0.0, rho, error=False)
    d, fsc, _ = spin_correction(a / b, v, _flex_coefficients(prob))
    # the scene's force level against the Coulomb contact's at the same normalised
    # creepages, as the length of (Fx, Fy, Mz/c): the components cross zero where lateral
    # creepage and spin oppose, the length does not
    scale = np.array([1.0, 1.0, 1.0 / c])
    Fn = np.stack([Fx, Fy, Mz], axis=-1) * scale
    level = np.linalg.norm(Fn, axis=-1)
    ref = np.linalg.norm(fsc, axis=-1) * muN
    w = 1.0 / (1.0 + lam)
    with np.errstate(invalid="ignore", divide="ignore"):
        gain = np.where(ref > 0, level / np.where(ref > 0, ref, 1.0), 1.0)
    # the longitudinal ratio's part of the Coulomb difference is taken off with the
    # scene's own FASTSIM forces (not the table's, which interpolate steep components)
    # the hardening factor on the longitudinal force only (Fy and Mz vanish with eta and
    # phi, so no force jumps as they are added; on them the validation set with spin
    # found the factor no help)
    base = np.stack([Rx, R, R], axis=-1) - (w * (R0 - 1.0))[..., None]
    out = base * Fn + (w * gain * muN)[..., None] * d
    out = out / scale
    return out[..., 0], out[..., 1], out[..., 2]


def _flex_coefficients(prob: Any) -> tuple[float, float, float]:
    """``C11, C22, C23`` up to a common factor, from the problem's flexibilities (only
    their ratios enter :func:`spin_share`)."""
    a, b = prob.a, prob.b
    L2 = prob.L2 if prob.L2 is not None else prob.L1
    L3 = prob.L3 if prob.L3 is not None else prob.L1
    return (8 * a / (3 * prob.L1), 8 * a / (3 * L2), math.pi * a * math.sqrt(a / b) / (4 * L3))


def coefficient_interpolation(method: str) -> str:
    """How a boundary method interpolates Kalker's coefficients between his table's rows
    (:mod:`torlab.model.kalker`): ``"linear"`` in ``g`` for Kalker's FASTSIM
    (``fastsim-kalker``, CONTACT's rule, as the thesis used it), :data:`TABLE_INTERPOLATION`
    for the others (the default's FASTSIM base, on which its tables were built; ``exact``
    and ``auto`` need the coefficients only for that base and for normalisation)."""
    return "linear" if method == "fastsim-kalker" else TABLE_INTERPOLATION


def method_note(method: str) -> str:
    """The ``modelled`` line of a method."""
    return f"boundary method: {method} -- {METHOD_TEXT[method]}"


# --------------------------------------------------------------------------------------------
# the theory error: each method's error against the exact theory, estimated
# --------------------------------------------------------------------------------------------
#: the longitudinal table's interpolation error (relative, 95 %): off-node exact solutions
#: against the corrected FASTSIM of Coulomb and elastic-layer contacts
#: (``tests/test_calibrated.py``, ``docs/model/boundary.md``)
INTERPOLATION_ERROR = 0.004
#: a hardening or softening Voce layer in pure longitudinal creepage, corrected by the
#: hardening table: the error left between its nodes, relative, per unit of
#: ``|mu_c2 - mu_c1| / max(mu_c1, mu_c2)``, where the contact slips (with the tables' own
#: errors it covers 95 % of the validation set's points, ``docs/model/boundary.md``)
HARDENING_ERROR = 0.04
#: ... and where the onset's correction is carried over (with lateral creepage or spin;
#: another law): the error measured for that at the knee of the curve, as above
CARRIED_HARDENING_ERROR = 0.15
#: the slip share (1 - adhesion fraction) from which the hardening error applies in full
HARDENING_ONSET = 0.2
#: the spin table's interpolation error (of mu N, or mu N c for the moment; 95 %)
SPIN_INTERPOLATION_ERROR = 0.01
#: lateral creepage and spin with a layer: the share of the Coulomb correction that may be
#: wrong (the correction is carried over, scaled by the half-space's compliance share; on
#: the validation set with spin it is off by as much as itself, docs/model/boundary.md)
LAYER_SPIN_ERROR = 1.0
#: outside the tables (a/b beyond 0.2-5, lambda beyond 5): the share of the correction
#: that may be wrong
OUTSIDE_ERROR = 0.5


def _hardening(lay: Any) -> np.ndarray:
    """``|mu_c2 - mu_c1| / max(mu_c1, mu_c2)`` of a Voce-like layer (0 without ``mu_c2``)."""
    mu1 = np.asarray(lay.mu_c1, dtype=float)
    mu2 = np.asarray(lay.get("mu_c2", lay.mu_c1), dtype=float)
    top = np.maximum(np.maximum(mu1, mu2), 1e-300)
    plastic_length = lay.get("L_mup", 1.0)
    return np.where(np.asarray(plastic_length) >= 0, np.abs(mu2 - mu1) / top, 0.0)


def _outside(a_over_b: float, lam: Any) -> np.ndarray:
    lo, hi = _AB_RANGE
    return (np.asarray(lam, dtype=float) > _LAMBDA_MAX) | (not lo <= a_over_b <= hi)


def _plastic_share(adhesion: Any) -> Any:
    """Where the hardening error applies: none in full adhesion, all from 20 % slip on
    (the validation set's errors below that are those of the tables)."""
    if adhesion is None:
        return 1.0
    return np.clip((1.0 - np.asarray(adhesion, dtype=float)) / HARDENING_ONSET, 0.0, 1.0)


def longitudinal_error(prob: Any, xi: Any, mu: Any, *, calibrated: bool,
                       adhesion: Any = None, carried: Any = False) -> np.ndarray:
    """The theory error (95 %, absolute in ``mu``) of a FASTSIM traction coefficient
    ``mu`` at creepages ``xi``: of the corrected one (``calibrated``, the ``fastsim``
    method) or of Kalker's FASTSIM (``fastsim-kalker``).

    * ``fastsim``: the table's own error (the exact values' extrapolation), its
      interpolation error (:data:`INTERPOLATION_ERROR`), for a hardening or softening
      Voce layer the hardening table's own error and its error between the nodes
      (:data:`HARDENING_ERROR`, where the contact slips: ``adhesion``, FASTSIM's
      adhesion fraction, below ``1 -`` :data:`HARDENING_ONSET`; everywhere without it;
      where ``carried``, the points with lateral creepage or spin, the onset's ratio
      alone and :data:`CARRIED_HARDENING_ERROR`, which also applies beyond the hardening
      table's ``mu_c2/mu_c1``, Voce ratio or ``lambda``, where its edge's factor is used,
      and where the flash temperature moves the layer's limits: the table is isothermal),
      and outside the tables half the correction (:data:`OUTSIDE_ERROR`), added in
      quadrature.
    * ``fastsim-kalker``: the correction it leaves out, ``|mu R - mu|``, with the
      corrected coefficient's own error in quadrature.
    """
    mu = np.asarray(mu, dtype=float)
    lay = prob.layer
    lam, mu1 = _layer_of(prob)
    x = normalised_longitudinal(prob.a, prob.L1, prob.p0, mu1, xi) / (1.0 + lam)
    R, Rerr = longitudinal_ratio(prob.a / prob.b, np.broadcast_to(lam, np.shape(x)), x)
    Qerr = 0.0
    carried = np.asarray(carried, dtype=bool)
    hv = _hardening_of(prob)
    if hv is not None:
        Q, Qerr = hardening_factor(prob.a / prob.b, lam, hv[0], hv[1], x)
        R = np.where(carried, R, R * Q)
        Qerr = np.where(carried, 0.0, Qerr)
        # beyond the hardening table's hardening, Voce ratio or lambda its edge's factor is
        # used: the error stated is that of carrying a correction over
        axes = _hardening_table()[0].axes
        h_ax, log_v = axes[2], axes[3]
        outside = ((hv[0] < h_ax[0]) | (hv[0] > h_ax[-1]) | (hv[1] < math.exp(log_v[0]))
                   | (hv[1] > math.exp(log_v[-1])) | (lam > math.exp(axes[1][-1])))
        carried = carried | outside
    else:
        carried = np.ones((), dtype=bool)
    R = np.broadcast_to(R, mu.shape)
    mu_cal = mu if calibrated else mu * R
    mu_plain = mu / R if calibrated else mu
    corr = np.abs(mu_cal - mu_plain)
    # the hardening table is isothermal: where the flash temperature moves the layer's
    # limits over the contact, its factor is applied and the error of carrying a
    # correction over is stated
    hot = getattr(prob, "thermal", None) is not None and any(
        np.any(np.asarray(getattr(lay, name, 0.0), dtype=float) != 0.0)
        for name in ("mu_c1_T", "mu_c2_T"))
    per_unit = np.where(carried | hot, CARRIED_HARDENING_ERROR, HARDENING_ERROR)
    rel = np.sqrt((Rerr / R) ** 2 + INTERPOLATION_ERROR**2 + Qerr**2
                  + (per_unit * _hardening(lay) * _plastic_share(adhesion)) ** 2)
    e_cal = np.sqrt((np.abs(mu_cal) * rel) ** 2
                    + (OUTSIDE_ERROR * corr * _outside(prob.a / prob.b, lam)) ** 2)
    return e_cal if calibrated else np.hypot(corr, e_cal)


def creep_error(prob: Any, xi: Any, eta: Any, phi: Any, Fx: Any, Fy: Any, Mz: Any, *,
                calibrated: bool, adhesion: Any = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The theory error (95 %; N, N, N m) of FASTSIM's creep forces (corrected with
    ``calibrated``, else Kalker's), as :func:`longitudinal_error` says, with the spin
    table's interpolation error (:data:`SPIN_INTERPOLATION_ERROR` of ``mu_c1 N``) and, with
    a layer, a share of the lateral and spin correction (:data:`LAYER_SPIN_ERROR`)."""
    xi, eta, phi, Fx, Fy, Mz = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                                     for v in (xi, eta, phi, Fx, Fy, Mz)))
    F = np.stack([Fx, Fy, Mz], axis=-1)
    if calibrated:
        # Kalker's FASTSIM is not at hand: the correction is that of the forces given
        # (to first order the same)
        cal = F
        back = np.stack(correct_creep(prob, xi, eta, phi, Fx, Fy, Mz), axis=-1)
        plain = F - (back - F)
    else:
        plain = F
        cal = np.stack(correct_creep(prob, xi, eta, phi, Fx, Fy, Mz), axis=-1)
    corr = np.abs(cal - plain)
    spin_part = (eta != 0) | (phi != 0)
    # with lateral creepage or spin the hardening table's factor is carried over (weighed
    # by the longitudinal share): the whole of what it changes is counted as possibly wrong
    hard = np.zeros_like(F)
    if _hardening_of(prob) is not None and np.any(spin_part):
        onset = np.stack(correct_creep(prob, xi, eta, phi, *np.moveaxis(plain, -1, 0),
                                       hardening=False), axis=-1)
        hard = np.abs(cal - onset) * spin_part[..., None]
    lam, mu1 = _layer_of(prob)
    c = math.sqrt(prob.a * prob.b)
    scale = float(mu1) * prob.load * np.array([1.0, 1.0, c])
    mag = np.hypot(cal[..., 0], cal[..., 1])[..., None] * np.array([1.0, 1.0, c])
    # the longitudinal part's relative error, on the force's magnitude
    e_long = longitudinal_error(prob, np.sqrt(xi**2 + eta**2), np.hypot(cal[..., 0], cal[..., 1]),
                                calibrated=True, adhesion=adhesion, carried=spin_part
                                ) / np.maximum(np.hypot(cal[..., 0], cal[..., 1]), 1e-300)
    e = np.sqrt((mag * e_long[..., None]) ** 2
                + (SPIN_INTERPOLATION_ERROR * scale * spin_part[..., None]) ** 2
                + (LAYER_SPIN_ERROR * corr * (float(lam) > 0) * spin_part[..., None]) ** 2
                + (OUTSIDE_ERROR * corr * _outside(prob.a / prob.b, lam)) ** 2
                + hard ** 2)
    if not calibrated:
        e = np.hypot(corr, e)
    return e[..., 0], e[..., 1], e[..., 2]
