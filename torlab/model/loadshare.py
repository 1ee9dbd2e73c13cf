"""Load sharing between the EHL film and the asperities (thesis Eqs. 5.44–5.48; notes section 7).

With the separation ``h`` of the mean planes,

* asperity load ``F_BL(h) = p_a(h) pi a b`` (Eq. 5.41/5.42; the thesis writes
  ``pi a^2`` for its circular contacts),
* film load ``F_EHL = F - F_BL(h)``,
* and the film must be as thick as the separation: ``hc(F_EHL) = h``
  (Eq. 5.31/5.32 with ``W_EHL = F_EHL/(E' rx^2)``).

Non-dimensional loads (Eqs. 5.44–5.46): ``W = F/(E' rx^2)``,
``W_BL = F_BL/(E' rx^2)``, ``W_EHL = F_EHL/(E' rx^2)``.

The algorithm (default): :func:`solve_load_sharing`
---------------------------------------------------
``hc(F_EHL) = hc(F) (F/F_EHL)^e`` (``e`` = 0.21 iso, 0.067 piezo), so the film load
that gives a film of thickness ``h`` is ``F (hc(F)/h)^(1/e)``.  In ``t = h/psi``
the load balance is::

    phi(t) = (t_c/t)^(1/e) + A F_n(t) - 1 = 0,     t_c = hc(F)/psi,  A = c pi a b / F

(``p_a = c F_n(h/psi)``).  Both terms decrease strictly with ``t``, so ``phi``
has exactly one root; it is the root of the notes' ``g(h) = h - hc(F - F_BL(h))``
(monotone increasing on ``(h*, inf)``).  The bracket is known in closed form:

* ``L = max(t_c, t*)`` with ``A F_n(t*) = 1`` (``h*``: the asperities alone carry
  ``F``): ``phi(L) >= 0``;
* ``U = max(2^e t_c, t_1/2)`` with ``A F_n(t_1/2) = 1/2``: each term <= 1/2, so
  ``phi(U) <= 0``;

and a bracketed root finder (``scipy.optimize.brentq`` for up to 8 speeds,
Chandrupatla's ``scipy.optimize.elementwise.find_root`` vectorised over the
speeds of a longer Stribeck curve; :func:`torlab.model.asperity.bracketed_root`)
converges to rounding without ever leaving ``[L, U]``.  The ends:

* ``v = 0``: no film (``hc = 0``, also if ``hc`` underflows), all load on the
  asperities, ``h = h*`` (regime ``"boundary"``);
* ``A F_n(t_c) < share_tol``: the asperity load at the full-film thickness is
  negligible, so ``h = hc(F)``, ``F_BL = 0`` (regime ``"full_film"``; the lead
  skips FASTSIM); likewise a film share below ``share_tol`` after the solve is
  reported as ``"boundary"`` with ``F_EHL = 0``;
* no roughness: ``h = hc(F)``, no asperity load (regime ``"smooth"``,
  ``lam = inf``).

Limit v -> 0 when ``h* < 0``
----------------------------
A film formula only gives ``h > 0``.  If the asperity law cannot carry the
whole load at ``h = 0`` (``h* < 0``: Tab. 5.1 for both models at 0.75 GPa, the
elastic one far from it), the root tends to ``h -> 0+`` as ``v -> 0`` and the
asperity share to ``F_BL(0)/F < 1`` (``F_4(0) = 3/2``, ``F_3/2(0) = 0.4299``), not
to 1.  Paper A reports exactly this ("the prediction using elastic asperity
deformation heavily underestimates the coefficient of adhesion at low speed").
At ``v = 0`` itself there is no film and ``h = h*``; the share jumps to 1 there.

The thesis's scheme, kept as a baseline: :func:`solve_load_sharing_thesis`
-------------------------------------------------------------------------
Start at ``h = hc(F)`` (all load on the film), error
``eps = |(W^2 - (W_EHL + W_BL)^2)/W^2|`` (Eq. 5.45) with tolerance 0.1 %, second
point ``h - hc/1000``, then secant steps on ``eps``.  It can leave the physical
range (``h <= 0``), stall or fail to converge; failures are recorded, not
raised.  Used only in ``torlab.bench.loadshare``.

The mixed coefficient (Eqs. 5.47–5.48): :func:`mixed`
``mu = (mu_EHL W_EHL + mu_BL W_BL)/W``, ``tau`` likewise.

References
----------
.. [1] Greenwood, J. A., Tripp, J. H. (1970). The contact of two nominally flat rough
   surfaces. Proceedings of the Institution of Mechanical Engineers 185(1), 625-633.
   https://doi.org/10.1243/PIME_PROC_1970_185_069_02
.. [2] Kvarda, D., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J., Krupka, I.,
   Hartl, M. (2021). Asperity-based model for prediction of traction in
   water-contaminated wheel-rail contact. Tribology International 157, 106900.
   https://doi.org/10.1016/j.triboint.2021.106900
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from torlab.errors import ConvergenceError, TorlabInputError
from torlab.model.asperity import F_n, F_n_inverse, bracketed_root

__all__ = [
    "LoadShare",
    "ThesisLoadShare",
    "mixed",
    "mixed_mu",
    "mixed_tau",
    "solve_load_sharing",
    "solve_load_sharing_thesis",
]

#: regimes reported by :func:`solve_load_sharing`
REGIMES = ("smooth", "full_film", "mixed", "boundary")


def _positive(value: float, key: str, unit: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise TorlabInputError(f"must be a positive number ({unit}), got {value!r}", key=key)
    return v


@dataclass(frozen=True)
class LoadShare:
    """Result of :func:`solve_load_sharing` (arrays shaped like ``speed``, or scalars).

    Attributes
    ----------
    speed
        Rolling speed ``v`` [m/s].
    h
        Separation of the mean planes [m]; ``h*`` (possibly < 0) in the
        ``"boundary"`` regime at ``v = 0``.
    film_thickness
        Film thickness [m]: ``h`` where the film carries load, else 0.
    lam
        ``Lambda = h/psi``; ``inf`` for smooth surfaces (write no lambda column then).
    F, F_EHL, F_BL
        Total, film and asperity load [N]; ``F_EHL + F_BL = F`` exactly.
    load_share_asperity
        ``F_BL/F``.
    W, W_EHL, W_BL
        Non-dimensional loads ``F/(E' rx^2)`` (Eqs. 5.44–5.46, with ``pi a b``).
    residual
        Relative load balance at ``h``: ``|F_film(h) + F_BL(h) - F|/F`` with
        ``F_film(h)`` the film load for which ``hc = h`` (0 where no solve was
        needed: ``v = 0``, smooth, full film at ``hc(F)``).
    iterations, evaluations
        Root-finder iterations and evaluations of the balance (0 where no solve).
    regime
        ``"smooth"``, ``"full_film"``, ``"mixed"`` or ``"boundary"`` (module docstring).
    h_star
        Separation at which the asperities carry all the load [m]; ``nan`` if smooth.
    model
        ``"smooth"``, ``"elastic"`` or ``"plastic"``.
    """

    speed: Any
    h: Any
    film_thickness: Any
    lam: Any
    F: float
    F_EHL: Any
    F_BL: Any
    load_share_asperity: Any
    W: float
    W_EHL: Any
    W_BL: Any
    residual: Any
    iterations: Any
    evaluations: Any
    regime: Any
    h_star: float
    model: str
    extra: dict[str, Any] = field(default_factory=dict)

    def mix(self, ehl: Any, bl: Any) -> Any:
        """``(ehl W_EHL + bl W_BL)/W`` (Eqs. 5.47–5.48) with this solution's weights."""
        return mixed(ehl, bl, self.W_EHL, self.W_BL, self.W)


def _outputs(scalar: bool, **arrays: Any) -> dict[str, Any]:
    if not scalar:
        return arrays
    out = {}
    for k, v in arrays.items():
        x = np.asarray(v).reshape(-1)[0]
        out[k] = x.item() if isinstance(x, np.generic) else x
    return out


def solve_load_sharing(speed: np.ndarray | float, F: float, a: float, b: float, film,
                       asperity=None, *, share_tol: float = 1e-9) -> LoadShare:
    """Separation and load sharing between film and asperities (notes section 7).

    Bracketed, monotone solve of ``hc(F - F_BL(h)) = h`` (module docstring),
    vectorised over ``speed``.

    Parameters
    ----------
    speed
        Rolling (entrainment) speed(s) ``v`` [m/s], >= 0; scalar or array.
    F
        Normal load [N], > 0.
    a, b
        Hertz semi-axes [m], ``a`` in the rolling direction.
    film
        :class:`torlab.model.ehl.FilmThickness` of the contact.
    asperity
        :class:`torlab.model.asperity.AsperityModel` (``Roughness.asperity_model(E*)``),
        or ``None`` for smooth surfaces.
    share_tol
        Film or asperity share below which that part is dropped (end regimes).

    Returns
    -------
    LoadShare
        Fields shaped like ``speed`` (Python scalars for a scalar ``speed``).

    Raises
    ------
    ConvergenceError
        If the bracketed root does not converge (not observed: the bracket is
        guaranteed and both root finders converge on any valid bracket).
    """
    F = _positive(F, "contact.load", "N")
    a = _positive(a, "contact.a", "m")
    b = _positive(b, "contact.b", "m")
    if not (0.0 < share_tol < 0.5):
        raise ValueError("share_tol must be in (0, 0.5)")
    scalar = np.ndim(speed) == 0
    v = np.atleast_1d(np.asarray(speed, dtype=float))
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise TorlabInputError("rolling speed must be finite and >= 0 (m/s)",
                               key="kinematics.speed")
    hc_full = film.hc(v, F)
    W = float(film.W(F))
    zeros = np.zeros_like(v)
    if asperity is None:
        res = _outputs(scalar, speed=v, h=hc_full, film_thickness=hc_full,
                       lam=np.full_like(v, np.inf), F_EHL=np.full_like(v, F), F_BL=zeros,
                       load_share_asperity=zeros, W_EHL=np.full_like(v, W), W_BL=zeros,
                       residual=zeros, iterations=zeros.astype(int),
                       evaluations=zeros.astype(int),
                       regime=np.full(v.shape, "smooth", dtype=object))
        return LoadShare(F=F, W=W, h_star=math.nan, model="smooth", **res)

    n, psi = asperity.n, asperity.sigma
    A = asperity.coefficient * math.pi * a * b / F
    e = film.load_exponent
    t_c = hc_full / psi

    t = np.empty_like(v)
    share = np.empty_like(v)
    resid = np.zeros_like(v)
    its = np.zeros(v.shape, dtype=int)
    nfev = np.zeros(v.shape, dtype=int)
    regime = np.full(v.shape, "mixed", dtype=object)

    no_film = hc_full == 0  # v = 0 (or a film below the smallest float)
    share_at_full = np.where(no_film, 1.0, A * F_n(n, np.where(no_film, 0.0, t_c)))
    full = ~no_film & (share_at_full < share_tol)
    t[full] = t_c[full]
    share[full] = 0.0
    regime[full] = "full_film"
    todo = np.flatnonzero(~(no_film | full))

    # h* (asperities carry F) and t_1/2 (they carry F/2): the bracket ends (notes section 7)
    t_star, t_half = (float(x) for x in F_n_inverse(n, np.array([1.0, 0.5]) / A))
    t[no_film] = t_star
    share[no_film] = 1.0
    regime[no_film] = "boundary"
    if todo.size:
        tc = t_c[todo]

        def phi(x: np.ndarray, tc_: np.ndarray) -> np.ndarray:
            return (tc_ / x) ** (1.0 / e) + A * F_n(n, x) - 1.0

        lo = np.maximum(tc, t_star)
        hi = np.maximum(tc * 2.0**e, t_half)
        f_lo = phi(lo, tc)
        f_hi = phi(hi, tc)
        root = np.where(f_lo <= 0.0, lo, hi)  # exact zeros at the ends (rare)
        inner = (f_lo > 0.0) & (f_hi < 0.0)
        if inner.any():
            x, nit, nf, ok = bracketed_root(phi, lo[inner], hi[inner], (tc[inner],),
                                            fatol=1e-15)
            if not np.all(ok):
                bad = int(np.flatnonzero(~ok)[0])
                raise ConvergenceError(
                    f"load sharing did not converge at v = {v[todo][inner][bad]:g} m/s",
                    iterations=int(nit[bad]))
            root[inner] = x
            its[todo[inner]] = nit
            nfev[todo[inner]] = nf + 2
        t[todo] = root
        sh = np.minimum(A * F_n(n, root), 1.0)
        resid[todo] = np.abs(phi(root, tc))
        share[todo] = sh
        # end regimes reached by the solve itself
        lo_share = sh < share_tol
        hi_share = (1.0 - sh) < share_tol
        regime[todo[lo_share]] = "full_film"
        regime[todo[hi_share]] = "boundary"
        share[todo[lo_share]] = 0.0
        share[todo[hi_share]] = 1.0

    h = t * psi
    F_BL = share * F
    F_EHL = F - F_BL
    film_h = np.where(F_EHL > 0, h, 0.0)
    res = _outputs(scalar, speed=v, h=h, film_thickness=film_h, lam=t, F_EHL=F_EHL, F_BL=F_BL,
                   load_share_asperity=share, W_EHL=film.W(F_EHL), W_BL=film.W(F_BL),
                   residual=resid, iterations=its, evaluations=nfev, regime=regime)
    return LoadShare(F=F, W=W, h_star=t_star * psi, model=asperity.model,
                     extra={"t_half": t_half, "A": A}, **res)


# ----------------------------------------------------------------------------------------
# the thesis's scheme (baseline)
# ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ThesisLoadShare:
    """Result of :func:`solve_load_sharing_thesis`: never raises, records the failure.

    Attributes
    ----------
    h
        Last separation [m] (``nan`` if the scheme could not start).
    converged
        Whether ``eps < tol`` was reached.
    failure
        ``None``, ``"h<=0"`` (left the physical range), ``"nan"``, ``"stalled"``
        (zero secant denominator) or ``"max_iter"``.
    iterations
        Secant steps taken.
    evaluations
        Evaluations of ``eps``.
    epsilon
        Last ``eps`` (Eq. 5.45).
    residual
        ``|W_EHL + W_BL - W|/W`` at ``h`` (``nan`` if undefined).
    share
        ``W_BL/W`` at ``h``.
    """

    h: float
    converged: bool
    failure: str | None
    iterations: int
    evaluations: int
    epsilon: float
    residual: float
    share: float


def solve_load_sharing_thesis(speed: float, F: float, a: float, b: float, film, asperity, *,
                              tol: float = 1e-3, max_iter: int = 100) -> ThesisLoadShare:
    """The thesis's load-sharing iteration (5.2.4), a benchmark baseline only.

    ``h0 = hc(F)`` (all load on the film); ``eps(h) = |(W^2 - (W_EHL + W_BL)^2)/W^2|``
    (Eq. 5.45) with ``W_EHL(h)`` the film load for which ``hc = h`` and
    ``W_BL(h) = p_a(h) pi a b/(E' rx^2)`` (Eq. 5.44, ``pi a b``); stop at
    ``eps < tol`` (0.1 %); else ``h1 = h0 - hc/1000`` and secant
    ("Newton–Raphson" from two points) steps on ``eps``.

    Returns
    -------
    ThesisLoadShare
        Outcome, including failures (never raises for numerical trouble).
    """
    v = float(speed)
    W = float(film.W(F))
    hc0 = float(film.hc(v, F))
    e = film.load_exponent
    n_eval = 0

    def eps_of(h: float) -> tuple[float, float, float]:
        nonlocal n_eval
        n_eval += 1
        with np.errstate(all="ignore"):
            w_ehl = W * (hc0 / h) ** (1.0 / e)
            w_bl = float(film.W(asperity.load(h, a, b)))
            s = w_ehl + w_bl
            return abs((W * W - s * s) / (W * W)), abs(s - W) / W, w_bl / W

    def out(h, conv, fail, it, eps, resid, share) -> ThesisLoadShare:
        return ThesisLoadShare(h, conv, fail, it, n_eval, eps, resid, share)

    if not (math.isfinite(hc0) and hc0 > 0):
        return out(math.nan, False, "h<=0", 0, math.nan, math.nan, math.nan)
    h0 = hc0
    e0, r0, s0 = eps_of(h0)
    if e0 < tol:
        return out(h0, True, None, 0, e0, r0, s0)
    h1 = h0 - hc0 / 1000.0
    e1, r1, s1 = eps_of(h1)
    for it in range(1, max_iter + 1):
        if e1 < tol:
            return out(h1, True, None, it - 1, e1, r1, s1)
        if e1 == e0:
            return out(h1, False, "stalled", it - 1, e1, r1, s1)
        h2 = h1 - e1 * (h1 - h0) / (e1 - e0)
        if not math.isfinite(h2):
            return out(h1, False, "nan", it, e1, r1, s1)
        if h2 <= 0:
            return out(h2, False, "h<=0", it, e1, r1, s1)
        h0, e0 = h1, e1
        h1 = h2
        e1, r1, s1 = eps_of(h1)
        if not math.isfinite(e1):
            return out(h1, False, "nan", it, e1, r1, s1)
    if e1 < tol:
        return out(h1, True, None, max_iter, e1, r1, s1)
    return out(h1, False, "max_iter", max_iter, e1, r1, s1)


# ----------------------------------------------------------------------------------------
# the mixed coefficient
# ----------------------------------------------------------------------------------------

def mixed(ehl: Any, bl: Any, W_EHL: Any, W_BL: Any, W: Any = None) -> np.ndarray:
    """Load-weighted combination ``(ehl W_EHL + bl W_BL)/W`` (Eqs. 5.47–5.48).

    For ``mu`` (Eq. 5.47) and for the shear stress field ``tau`` (Eq. 5.48).  A
    part whose weight is 0 is left out, so ``ehl`` (or ``bl``) may be ``None`` or
    contain NaN where it was not modelled (``"boundary"`` / ``"full_film"``).

    Parameters
    ----------
    ehl, bl
        EHL and boundary values (broadcastable with the weights).
    W_EHL, W_BL
        Film and asperity loads (any consistent unit: N or non-dimensional).
    W
        Total load; default ``W_EHL + W_BL`` (the thesis's denominator; equal at
        the solution).
    """
    W_EHL = np.asarray(W_EHL, dtype=float)
    W_BL = np.asarray(W_BL, dtype=float)
    Wt = W_EHL + W_BL if W is None else np.asarray(W, dtype=float)

    def part(x: Any, w: np.ndarray) -> np.ndarray:
        if x is None:
            if np.any(w != 0):
                raise ValueError("a part with non-zero load share has no value")
            return np.zeros_like(w)
        x = np.asarray(x, dtype=float)
        return np.where(w != 0, x, 0.0) * w

    return (part(ehl, W_EHL) + part(bl, W_BL)) / Wt


#: Eq. 5.47
mixed_mu = mixed
#: Eq. 5.48
mixed_tau = mixed
