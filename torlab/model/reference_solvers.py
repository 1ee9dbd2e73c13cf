"""Reference and baseline solvers of the boundary traction and the creep forces: slow,
grid-free or first-order, written for clarity over speed, against which the tests and
``torlab bench`` measure the fast solvers' error.

* :func:`boundary_traction_reference`: ``mu_BL`` [-] of FASTSIM with the third-body layer
  (:mod:`torlab.model.fastsim`) without a grid and without temperature, by an ODE per
  strip (``solve_ivp``) and adaptive quadrature across the strips; independent of the
  fast scheme's closed forms (:mod:`torlab.model.strip`);
* :func:`creep_forces_reference`: the creep forces ``(Fx, Fy, Mz)`` [N, N, N m] of
  :mod:`torlab.model.creep` the same way (an ODE per strip with event location,
  adaptive quadrature across);
* :func:`naive_creep_forces`: Kalker's first-order discrete FASTSIM on a uniform grid, as
  CONTACT runs it (the benchmark's baseline).

References
----------
.. [1] Kalker, J. J. (1982). A fast algorithm for the simplified theory of rolling
   contact. Vehicle System Dynamics 11(1), 1-13. https://doi.org/10.1080/00423118208968684
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from torlab.errors import ConvergenceError
from torlab.model.creep import CreepProblem, kalker_weighted_flexibility
from torlab.model.fastsim import FastsimProblem

__all__ = ["boundary_traction_reference", "creep_forces_reference", "naive_creep_forces"]


# -------------------------------------------------------------------------------------------
# grid-free reference (adaptive quadrature of the continuous strip solution)
# -------------------------------------------------------------------------------------------
def _crossings(fun: Any, grid: np.ndarray, vals: np.ndarray, level: float) -> list[float]:
    """The roots of ``fun = level`` (``brentq``) in the grid cells where ``vals`` (``fun`` on
    ``grid``) crosses it."""
    from scipy.optimize import brentq

    return [brentq(lambda t: fun(t) - level, grid[i], grid[i + 1], xtol=1e-16, rtol=1e-15)
            for i in np.flatnonzero((vals[:-1] < level) != (vals[1:] < level))]


def boundary_traction_reference(prob: FastsimProblem, creepage: float, *, rtol: float = 1e-10) -> float:  # noqa: C901 (a reference solver spelled out case by case, for clarity over speed)
    """Grid-free reference ``mu_BL`` without temperature, by adaptive quadrature.

    Independent of the fast scheme's closed forms: per strip, ``E(X)`` and the
    elastic force come from an ODE integration in ``X`` (``solve_ivp``, DOP853,
    ``rtol`` 1e-12), the yield point from ``brentq`` on its dense output, the
    plastic force from ``quad`` with the clamp and the law's grading length
    (Voce: ``L_mup``) as break points, and the strips from ``quad`` over ``y``.  Slow (seconds); for tests
    and the benchmark.
    """
    from scipy.integrate import quad, solve_ivp
    from scipy.optimize import brentq

    if prob.thermal is not None and any(prob.layer.law.temperature_coefficients(prob.layer)):
        raise ValueError("the reference covers the isothermal model only")
    xi = abs(float(creepage))
    if xi == 0:
        return 0.0
    lay = prob.layer
    L1 = prob.L1

    def strip_force(eta: float) -> float:
        s = math.sqrt(max(1.0 - eta * eta, 0.0))
        ay, Py = prob.a * s, prob.p0 * s
        if ay <= 0:
            return 0.0

        # the ODE in theta for the dimensionless e = E L1/ay and m = M L1/ay^2, with
        # X = ay (1 - cos theta), p = Py sin theta: de/dtheta = sin^2/(sin + r),
        # dm/dtheta = (1 - cos theta) de/dtheta, r = L_mue/(L1 Py); integrated numerically
        r = lay.L_mue / (L1 * Py)

        def rhs(th, y):
            st = math.sin(th)
            de = st * st / (st + r) if st + r > 0 else 0.0
            return [de, (1.0 - math.cos(th)) * de]

        sol = solve_ivp(rhs, (0.0, math.pi), [0.0, 0.0], method="DOP853", rtol=1e-12,
                        atol=1e-15, dense_output=True)
        kE = ay / L1

        if lay.mu_c1 == 0:
            thy = 0.0
        else:
            # first sign change of xi E - tau_c1 on a fine scan, then brentq
            def g(th):
                return xi * kE * float(sol.sol(th)[0]) - lay.mu_c1 * Py * math.sin(th)

            ths = np.linspace(0, math.pi, 4001)[1:]
            gv = xi * kE * sol.sol(ths)[0] - lay.mu_c1 * Py * np.sin(ths)
            k = int(np.argmax(gv >= 0))
            lo = ths[k - 1] if k > 0 else 1e-300
            thy = brentq(g, lo, ths[k], xtol=1e-16, rtol=1e-15, maxiter=500)
        ey, my = (float(v) for v in sol.sol(thy))
        # elastic force: integral_0^Xy xi E dX = xi (Xy E(Xy) - integral_0^Xy X/L dX)
        F_el = xi * ay * kE * ((1.0 - math.cos(thy)) * ey - my)

        def tau_pl_theta(th):
            pp = Py * math.sin(th)
            X = ay * (1.0 - math.cos(th))
            tau = float(lay.law.strip_plastic(lay, pp, xi * X, L1 * pp + lay.L_mue, 0.0))
            return tau * ay * math.sin(th)

        def dfun(th):
            return xi * ay * (1.0 - math.cos(th)) - lay.mu_c1 * (L1 * Py * math.sin(th) + lay.L_mue)

        tg = np.linspace(thy, math.pi, 2001)
        dv = xi * ay * (1.0 - np.cos(tg)) - lay.mu_c1 * (L1 * Py * np.sin(tg) + lay.L_mue)
        pts = [thy, *_crossings(dfun, tg, dv, 0.0)]  # and the clamp's end
        grading = float(lay.law.grading_length(lay))
        if grading > 0:
            Xb = ay * (1.0 - math.cos(pts[-1]))
            ell = grading / xi
            for k in (0.25, 0.5, 1, 2, 4, 8, 16, 32, 64):
                if Xb + ell * k < 2 * ay:
                    pts.append(math.acos(1.0 - (Xb + ell * k) / ay))
        for c in lay.law.strip_kinks(lay):  # the law's own kinks, at d = c
            pts += _crossings(dfun, tg, dv, float(c))
        pts = [*sorted(set(min(max(t, thy), math.pi) for t in pts)), math.pi]
        F_pl = 0.0
        for lo_, hi_ in itertools.pairwise(pts):
            if hi_ > lo_:
                val, err, *_ = quad(tau_pl_theta, lo_, hi_, epsabs=0, epsrel=rtol, limit=200,
                                    full_output=1)
                # quadpack's round-off flag at the clamp kink is harmless; a real loss is not
                if err > 1e3 * rtol * abs(val) + 1e-300:
                    raise ConvergenceError(f"reference quadrature error {err:.3g} on a strip")
                F_pl += val
        return F_el + F_pl

    def integrand(phi: float) -> float:
        return strip_force(math.sin(phi)) * math.cos(phi)

    Fx = 2.0 * prob.b * quad(integrand, 0.0, 0.5 * math.pi, epsabs=0, epsrel=rtol, limit=200)[0]
    return Fx / prob.load


# -------------------------------------------------------------------------------------------
# grid-free reference (ODE per strip with events, adaptive quadrature across)
# -------------------------------------------------------------------------------------------
def _reference_strip(prob: CreepProblem, xi: float, eta: float, phi: float, yb: float,  # noqa: C901 (a reference solver spelled out case by case, for clarity over speed)
                     rtol: float) -> np.ndarray:
    """``(Fx, Fy, Mz)`` per unit width of the strip at ``y = b yb`` (the reference's ODE)."""
    from scipy.integrate import solve_ivp

    lay = prob.layer
    L1 = prob.L1
    L2 = prob.L2 if prob.L2 is not None else L1
    L3 = prob.L3 if prob.L3 is not None else L1
    LK = float(kalker_weighted_flexibility(prob, xi, eta, phi))
    kalker = prob.restick == "kalker"
    parab = prob.traction_bound == "parabolic"
    p0 = (4.0 / 3.0) * prob.p0 if parab else prob.p0
    c2 = 1.0 - yb * yb
    if c2 <= 0:
        return np.zeros(3)
    ay = prob.a * math.sqrt(c2)
    y = prob.b * yb
    pc = p0 * (c2 if parab else math.sqrt(c2))  # peak pressure of the strip
    wx = xi - phi * y

    # integrated in the angle t with X = ay (1 - cos t), x = ay cos t, p = pc sin t
    # (sin^2 t for the parabolic bound): every integrand is smooth in t
    def p_of(t):
        st = math.sin(t)
        return pc * (st * st if parab else st)

    def dp_of(t):  # dp/dt
        return pc * (2 * math.sin(t) * math.cos(t) if parab else math.cos(t))

    def Tel(t):  # d tau_el / dt
        p = p_of(t)
        if lay.L_mue > 0:
            if p <= 0:
                return 0.0, 0.0
            le = lay.L_mue / p
        else:
            le = 0.0
        x = ay * math.cos(t)
        j = ay * math.sin(t)
        return (j * (xi / (L1 + le) - phi * y / (L3 + le)),
                j * (eta / (L2 + le) + phi * x / (L3 + le)))

    def absw(t):  # |w| dX/dt
        return math.hypot(wx, eta + phi * ay * math.cos(t)) * ay * math.sin(t)

    def kap(t, S):  # Voce slip before the clamp max(., 0); S rides along as a state
        return S - lay.mu_c1 * (LK * p_of(t) + lay.L_mue)

    law = lay.law

    def glim(t, S):
        p = p_of(t)
        return float(law.strip_plastic(lay, p, S, LK * p + lay.L_mue, 0.0))

    def dglim(t, S):  # dg/dt = g_p dp/dt + g_u dS/dt + g_pL LK dp/dt
        p, dp = p_of(t), dp_of(t)
        g_p, g_u, g_pL = law.strip_partials(lay, p, S, LK * p + lay.L_mue)
        return g_p * dp + g_u * absw(t) + g_pL * LK * dp

    end = math.pi
    X0 = 0.0
    # stick: [tau_x, tau_y, S, Fx, Fy, Mz]; slip: [psi, 0, S, Fx, Fy, Mz]
    state = np.zeros(6)
    mode = "stick"
    first = [True]
    rt = dict(method="DOP853", rtol=rtol,
              atol=1e-14 * max(1.0, float(law.reference_mu(lay)) * prob.p0 * ay))

    def rhs_stick(t, s):
        Tx, Ty = Tel(t)
        x = ay * math.cos(t)
        j = ay * math.sin(t)
        return [Tx, Ty, absw(t), j * s[0], j * s[1], j * (x * s[1] - y * s[0])]

    def rhs_slip(t, s):
        Tx, Ty = Tel(t)
        g = glim(t, s[2])
        c, sn = math.cos(s[0]), math.sin(s[0])
        x = ay * math.cos(t)
        j = ay * math.sin(t)
        dpsi = (-sn * Tx + c * Ty) / g if g > 0 else 0.0
        return [dpsi, 0.0, absw(t), j * g * c, j * g * sn, j * g * (x * sn - y * c)]

    def ev_yield(t, s):
        # a particle that unloaded sits at the limit: a relative margin of 1e-9 keeps
        # the event from firing again at the point where it stuck
        lim = lay.mu_c1 * p_of(t) if first[0] else glim(t, s[2]) * (1 + 1e-9)
        return math.hypot(s[0], s[1]) - lim if t > 1e-12 else -1.0

    ev_yield.terminal = True
    ev_yield.direction = 1

    def ev_unload(t, s):
        Tx, Ty = Tel(t)
        lam = math.cos(s[0]) * Tx + math.sin(s[0]) * Ty
        gd = dglim(t, s[2])
        return lam - (gd if kalker else min(gd, 0.0))

    ev_unload.terminal = True
    ev_unload.direction = -1

    def ev_clamp(t, s):  # the Voce limit's kink: restart the integrator there
        return kap(t, s[2])

    ev_clamp.terminal = True
    ev_clamp.direction = 1
    guard = 0
    skip_clamp = False
    while X0 < end - 1e-12 and guard < 400:
        guard += 1
        if mode == "stick":
            sol = solve_ivp(rhs_stick, (X0, end), state, events=ev_yield, **rt)
        else:
            evs = [ev_unload] if skip_clamp else [ev_unload, ev_clamp]
            sol = solve_ivp(rhs_slip, (X0, end), state, events=evs, **rt)
        skip_clamp = mode == "slip" and sol.status == 1 and not sol.t_events[0].size
        if sol.status == -1:
            raise ConvergenceError(f"reference ODE failed on a strip: {sol.message}")
        state = sol.y[:, -1].copy()
        Xn = sol.t[-1]
        if sol.status == 1:
            if mode == "stick":
                mag = math.hypot(state[0], state[1])
                if mag > 0:
                    psi = math.atan2(state[1], state[0])
                else:
                    Tx, Ty = Tel(Xn + 1e-9)
                    psi = math.atan2(Ty, Tx)
                state[0], state[1] = psi, 0.0
                mode = "slip"
                first[0] = False
            elif sol.t_events[0].size:  # unloading: stick again
                g = glim(Xn, state[2])
                state[0], state[1] = g * math.cos(state[0]), g * math.sin(state[0])
                mode = "stick"
            # the clamp event only restarts the slip integration
            if Xn <= X0:  # an event at the start point: step past it
                Xn = X0 + 1e-12
        X0 = Xn
    if guard >= 400:
        raise ConvergenceError("reference: more than 400 stick/slip switches on one strip")
    return state[3:]


def creep_forces_reference(problem: CreepProblem, creepage: float, lateral: float = 0.0,
                           spin: float = 0.0, *, rtol: float = 1e-9) -> tuple[float, float, float]:
    """Grid-free ``(Fx, Fy, Mz)`` of the isothermal model, for tests and the benchmark.

    Independent of the fast scheme's closed forms, tables and march: per strip,
    ``solve_ivp`` (DOP853) integrates the stick traction ``d tau/dX`` from the
    rigid slip and the flexibilities, or in slip the direction
    ``d psi/dX = (n . d tau_el/dX)/g`` with the magnitude ``g`` from the layer law,
    switching at located events (yield, unloading, re-yield) and at the clamp end;
    the forces ride along as integrals; ``quad_vec`` integrates across the strips.
    Slow (seconds to a minute).
    """
    from scipy.integrate import quad_vec

    prob = problem
    if prob.thermal is not None and any(prob.layer.law.temperature_coefficients(prob.layer)):
        raise ValueError("the reference covers the isothermal model only")
    xi, eta, phi = float(creepage), float(lateral), float(spin)

    scale = np.array([1.0, 1.0, 1.0 / prob.a])  # Mz/a: comparable sizes for quad_vec's norm

    def integrand(ph: float) -> np.ndarray:
        return _reference_strip(prob, xi, eta, phi, math.sin(ph), rtol) * math.cos(ph) * scale

    pts = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 9)
    total = np.zeros(3)
    for lo, hi in itertools.pairwise(pts):
        val, _err = quad_vec(integrand, lo, hi, epsabs=0.0, epsrel=1e2 * rtol, limit=400)
        total += val
    return tuple(float(v) for v in prob.b * total / scale)


# -------------------------------------------------------------------------------------------
# naive first-order FASTSIM (uniform grid), the benchmark's baseline
# -------------------------------------------------------------------------------------------
def naive_creep_forces(problem: CreepProblem, creepage: Any, lateral: Any = 0.0, spin: Any = 0.0,
                       *, mx: int = 50, my: int = 50, scale: float = 1.0
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """FASTSIM with the layer on a uniform ``mx x my`` grid (first order), isothermal.

    Kalker's discrete scheme as CONTACT runs it (element centres, implicit Euler
    from the leading edge: ``tau_i = tau_(i-1) + Delta tau_el``, clipped to the
    limit), with the layer's flexibility and the Voce limit of this module at the
    element centres.  Vectorised over rows and creepages, marched along ``x``.
    ``scale`` enlarges the grid's box beyond the ellipse as CONTACT's potential contact
    does (elements count where their centre is inside the ellipse).
    Returns ``(Fx, Fy, Mz)`` in the broadcast shape of the creepages.
    """
    prob = problem
    lay = prob.layer
    xi_in, eta_in, phi_in = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                                  for v in (creepage, lateral, spin)))
    shape = xi_in.shape
    xi, eta, phi = (v.ravel()[:, None] for v in (xi_in, eta_in, phi_in))
    L1 = prob.L1
    L2 = prob.L2 if prob.L2 is not None else L1
    L3 = prob.L3 if prob.L3 is not None else L1
    LK = kalker_weighted_flexibility(prob, xi, eta, phi)
    a, b = prob.a, prob.b
    dx, dy = 2 * scale * a / mx, 2 * scale * b / my
    yc = -scale * b + dy * (np.arange(my) + 0.5)
    xc = scale * a - dx * (np.arange(mx) + 0.5)  # leading edge first
    parab = prob.traction_bound == "parabolic"
    pk = (4.0 / 3.0) * prob.p0 if parab else prob.p0
    y = yc[None, :]
    nc = xi.shape[0]
    tau = np.zeros((nc, my), dtype=complex)
    S = np.zeros((nc, my))
    plastic = np.zeros((nc, my), dtype=bool)
    yielded = np.zeros((nc, my), dtype=bool)
    Fx = np.zeros(nc)
    Fy = np.zeros(nc)
    Mz = np.zeros(nc)
    kalker = prob.restick == "kalker"
    wx = xi - phi * y
    for x in xc:
        u = 1.0 - (x / a) ** 2 - (y / b) ** 2
        inside = np.broadcast_to(u > 0, (nc, my))
        p = pk * (np.maximum(u, 0.0) if parab else np.sqrt(np.maximum(u, 0.0)))
        with np.errstate(divide="ignore"):
            le = np.where(u > 0, lay.L_mue / np.where(u > 0, p, 1.0), 0.0)
        wy = eta + phi * x
        S = np.where(inside, S + np.hypot(wx, wy) * dx, 0.0)
        d_el = ((xi / (L1 + le) - phi * y / (L3 + le))
                + 1j * (eta / (L2 + le) + phi * x / (L3 + le))) * dx
        t1 = lay.mu_c1 * p
        g = lay.law.strip_plastic(lay, p, S, LK * p + lay.L_mue, 0.0)
        cur = np.abs(tau)
        trial = np.where(inside, tau + d_el, 0.0)
        at = np.abs(trial)
        lim_stick = g if kalker else np.minimum(cur, g)
        stay = plastic & ~(at < lim_stick)
        yield_now = ~plastic & (at >= np.where(yielded, g, t1))
        newp = (stay | yield_now) & inside
        with np.errstate(invalid="ignore", divide="ignore"):
            dirn = np.where(at > 0, trial / np.where(at > 0, at, 1.0), 0.0)
        tau = np.where(newp, g * dirn, trial)
        plastic = newp
        yielded = (yielded | newp) & inside
        Fx += np.sum(tau.real, axis=1) * dx * dy
        Fy += np.sum(tau.imag, axis=1) * dx * dy
        Mz += np.sum(x * tau.imag - y * tau.real, axis=1) * dx * dy
    return Fx.reshape(shape), Fy.reshape(shape), Mz.reshape(shape)
