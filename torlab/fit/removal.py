"""Removal law of a product from MTM time tests after application (Paper B) and its amount series.

The model
---------
A time test after application (thesis 5.3.2, Fig. 5.9) runs a ball-on-disc
contact at constant load, speed and slide-roll ratio; the product is applied
at ``t_a`` onto the disc track.  With the band of :mod:`torlab.model.removal`
(the disc track, ``2 pi r_track x 2b``):

* the energy dissipated per unit band area since the application is taken
  from the record itself, ``E(t) = integral_{t_a}^t |mu| F |SRR| v dt / A_band``
  (the measured coefficient, load, slide-roll ratio and rolling speed of every
  sample; trapezoidal), and the passes are ``N(t) = (t - t_a) v / L_track``;
* the remaining amount follows the law in closed form
  (:func:`torlab.model.removal.amount_from_energy`) from
  ``m0 = transfer x applied mass / A_band``;
* the modelled coefficient is the boundary model at the test's contact and
  slide-roll ratio with the layer of the remaining amount
  (:func:`torlab.model.removal.mu_table`, the product's HPT amount series).

Right after the application the contact runs on the film of the fresh product
(the initial drop, which the boundary model does not describe); the fit
therefore starts once the coefficient has recovered to the boundary level
(``skip="auto"``: twice the time at which the smoothed coefficient, after its
minimum, has come 90 % of the way back to the boundary coefficient at the
applied amount -- for an exponential recovery 1 % of the film's effect is left
then), or ``skip`` seconds after the application.  The energy dissipated
before that still counts.

The fit
-------
Log-parameters (``ln k``, and ``ln spread``, ``ln transfer`` where fitted) by
bounded least squares (``scipy.optimize.least_squares``, trust-region
reflective) from the best point of a grid, jointly over all time tests of the
product.  The residual noise of a time test is slow (the coefficient
fluctuates over tens of seconds): per test a white + AR(1) noise model is
estimated from the residuals (a moment fit of their autocovariance,
:func:`_ar1_noise`) and the covariance is the sandwich ``B J^T Sigma J B`` of
:mod:`torlab.fit._noise`; the intervals use Student's t on the effective
number of independent points.  The intervals of the rates are
``exp(ln k +- t se)`` (asymmetric in ``k``); the standard errors are the
delta-method ``k se(ln k)``.

The law is chosen per product by the small-sample Akaike criterion on the
effective number of independent points (``n_eff ln(RSS/n) + 2p +
2p(p+1)/(n_eff - p - 1)``, ``n_eff`` from the noise model of the best-fitting
law); ``meta["law_selection"]`` lists every candidate with its criterion,
difference to the best and Akaike weight.

References
----------
.. [1] Kvarda, D., Skurka, S., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J.,
   Krupka, I., Hartl, M. (2022). The effect of top of rail lubricant composition on
   adhesion and rheological behaviour. Engineering Science and Technology, an
   International Journal 35, 101100. https://doi.org/10.1016/j.jestch.2022.101100
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import FitError, TorlabInputError
from torlab.fit.result import FitResult, student_t
from torlab.fit.retention_params import RemovalFit, parameter_section
from torlab.model.amount import MG_M2, AboveTestedError, areal_density
from torlab.model.removal import (
    LAWS,
    amount_from_energy,
    band_of,
    mu_table,
    passes_solution,
)
from torlab.reduce.time_test import MIN_WINDOW, TimeTest

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["check_options", "default_tribometer_scene", "fit_removal"]


def default_tribometer_scene(load: float = 18.0, speed: float = 1.0) -> Any:
    """The PCS MTM ball on disc: a 19.05 mm (3/4 in) steel ball on a flat steel disc.

    The tribometer scene of a removal fit when none is given (each time test's
    own load and speed replace these); its ``boundary:`` is a placeholder,
    replaced by the layer of the remaining amount.
    """
    from torlab.scene import scene_from_dict

    return scene_from_dict({
        "name": "PCS MTM ball on disc (19.05 mm steel ball, steel disc)",
        "contact": {"load": load, "r1x": "9.525 mm", "r1y": "9.525 mm", "hertz": "exact"},
        "materials": {"E1": "210 GPa", "nu1": 0.3, "E2": "210 GPa", "nu2": 0.3},
        "kinematics": {"speed": speed, "ambient_temperature": "30 degC"},
        "boundary": {"mu_c1": 0.3, "mu_c2": 0.3},
    })


# ---------------------------------------------------------------------------------------------
# preparation of one test
# ---------------------------------------------------------------------------------------------
def _measured_retention(p: Any) -> dict[str, Any]:
    """A time test's retention figures as labs report them, from its record after the
    application (:func:`torlab.reduce.time_test_uncertainty.measured_retention`, the
    thesis's band 0.15-0.25); finite numbers or None."""
    from torlab.fit.result import finite_tree
    from torlab.model.retention import DEFAULT_BAND
    from torlab.reduce.time_test_uncertainty import measured_retention

    return finite_tree(measured_retention(p.N, p.mu, band=DEFAULT_BAND, mu_dry=p.mu_dry,
                                          replicates=100))


@dataclass
class _Prepared:
    test: TimeTest
    t_rel: np.ndarray         # time since application, from the application on
    mu: np.ndarray
    E: np.ndarray             # J/m^2 since application
    N: np.ndarray             # passes since application
    window: np.ndarray        # bool, samples in the fit
    m_applied: float          # kg/m^2 in the band with transfer 1
    transfer_max: float       # largest transfer the layer's tested range allows
    curve: Any                # ln m -> mu
    x_dry: float
    mu_dry: float
    m_max: float
    area: float
    creepage: float
    load: float
    speed: float
    skip: float
    i0: int                   # first sample of the fit window
    N_win: np.ndarray         # disc revolutions since the window start (from i0 on)
    c_rev: float              # energy per unit band area and revolution per unit mu (F xi / w)
    K_rel_var: float          # relative variance of the per-sample F xi v (condition noise)
    xg: np.ndarray            # fixed ln m grid from the dry anchor to the table top
    mug: np.ndarray           # the coefficient on it
    I0: dict[int, np.ndarray]  # per law order: integral of (m if order 0 else 1) / (c_rev mu) dx
    table: Any                # the friction table (with layer derivatives)
    notes: list[str]
    n_evaluations: int


_TABLES: dict[tuple, Any] = {}


def _table(sc: Scene, layer: Any, creepage: float, top: float, per_interval: int) -> Any:
    """:func:`~torlab.model.removal.mu_table` with its layer derivatives, cached per layer,
    contact, creepage and range.

    The range is the table's own: every ``top`` up to the layer's largest tested amount
    gives the same table (:func:`~torlab.model.removal.mu_table` extends it above that
    amount only), so tests of different amounts below it share one."""
    top = max(float(top), float(layer.m_max))
    key = (id(layer), sc.model_dump_json(), creepage, float(f"{top:.6g}"), per_interval)
    hit = _TABLES.get(key)
    if hit is not None and hit[0] is layer:
        return hit[1]
    tab = mu_table(sc, layer, creepage, m_top=top, per_interval=per_interval, gradient=True)
    if len(_TABLES) >= 32:
        _TABLES.pop(next(iter(_TABLES)))
    _TABLES[key] = (layer, tab)
    return tab


def _test_scene(scene: Scene, load: float, speed: float) -> Any:
    c = scene.contact.model_copy(update={"load": load})
    k = scene.kinematics.model_copy(update={"speed": speed})
    return scene.model_copy(update={"contact": c, "kinematics": k})


def _prepare(tt: TimeTest, scene: Scene, layer: Any, *, skip: Any, duration: float | None,
             per_interval: int, max_transfer: float, fit_transfer: bool = False) -> _Prepared:
    from torlab.model.contact import build_contact
    from torlab.reduce.mtm import running_median

    after = tt.t >= tt.application_time
    t = tt.t[after] - tt.application_time
    mu = tt.mu[after]
    load, speed, xi = tt.load[after], tt.speed[after], tt.creepage[after]
    # the test's conditions: medians of the record; the friction table is built at them
    # rounded to 4 significant digits (one table serves repeated tests at the same conditions;
    # the coefficient changes by far less than the noise), the energy uses them as they are
    F, v, s = (float(np.median(a)) for a in (load, speed, xi))
    r4 = [float(f"{x:.4g}") for x in (F, v, s)]
    sc = _test_scene(scene, F, v)
    contact = build_contact(sc)
    band = band_of(contact, tt.track_radius)
    area = float(band.area)
    m_app = areal_density(tt.amount, area=area, density=tt.density, where=f"{tt.label} amount")
    tr_max = 1.0
    if not fit_transfer or layer.above == "hold" or m_app <= layer.m_max:
        top = m_app * max_transfer
        try:
            layer.check(top)
        except AboveTestedError as e:
            raise e.with_hint(e.hint, key="amount", prefix=f"{tt.label}: ",
                              suffix=" (the applied amount in the band)") from None
        except TorlabInputError as e:
            raise TorlabInputError(f"{tt.label}: {e.message} (the applied amount in the band)",
                                   key="amount") from None
    else:  # transfer fitted: it cannot bring more than the largest tested amount into the band
        top = layer.m_max
        tr_max = layer.m_max / m_app
    table = _table(_test_scene(scene, r4[0], r4[1]), layer, r4[2], top, per_interval)
    power = mu * load * xi * speed
    from scipy.integrate import cumulative_trapezoid

    E = cumulative_trapezoid(power, t, initial=0.0) / area
    N = cumulative_trapezoid(speed, t, initial=0.0) / band.track_length
    notes: list[str] = [f"{tt.label}: {nt}" for nt in tt.notes]
    curve = table.curve(0)
    if skip == "auto":
        dt = float(np.median(np.diff(t)))
        ms = running_median(mu, max(1, round(10.0 / dt)))
        k_min = int(np.argmin(ms[: max(3, len(ms) // 2)]))
        m_b0 = min(m_app * max_transfer, top)
        mu_b0 = float(table(m_b0)[()]) if m_b0 > table.m_dry else float(table.mu_dry[0])
        if float(ms[k_min]) >= mu_b0:
            skip_s = 0.0
            notes.append(f"{tt.label}: no initial drop below the boundary level "
                         f"({mu_b0:.3f}); fitted from the application on")
        else:
            level = float(ms[k_min]) + 0.9 * (mu_b0 - float(ms[k_min]))
            up = np.flatnonzero(ms[k_min:] >= level)
            t90 = float(t[k_min + int(up[0])]) if up.size else float(t[k_min])
            skip_s = 2.0 * t90
            notes.append(f"{tt.label}: fit starts {skip_s:.0f} s after the application: twice "
                         f"the time to recover 90 % of the way from the initial drop to the "
                         f"boundary level {mu_b0:.3f} (1 % of an exponential film effect left)")
    else:
        skip_s = float(skip)
        if not (math.isfinite(skip_s) and skip_s >= 0):
            raise TorlabInputError(f"skip must be a non-negative time (s) or 'auto', got {skip}",
                                   key="skip")
    win = t >= skip_s
    if duration is not None:
        win &= t <= duration
    if np.count_nonzero(win) < MIN_WINDOW:
        raise TorlabInputError(f"only {np.count_nonzero(win)} samples in the fit window "
                               f"({skip_s:g} s after the application to the end); need "
                               f"{MIN_WINDOW}", path=tt.label, key="skip")
    i0 = int(np.flatnonzero(win)[0])
    t_rev = band.track_length / v
    from torlab.model.removal import cumulative_integral

    xg = np.linspace(float(table.x[0]), float(table.x[-1]), 2049)
    mug = np.asarray(curve(xg), dtype=float)
    mug[0] = float(table.mu_dry[0])
    c_rev = F * s / band.width
    I0 = {0: cumulative_integral(np.exp(xg) / (c_rev * mug), float(xg[1] - xg[0])),
          1: cumulative_integral(1.0 / (c_rev * mug), float(xg[1] - xg[0]))}
    return _Prepared(test=tt, t_rel=t, mu=mu, E=E, N=N, window=win, m_applied=m_app,
                     transfer_max=tr_max, i0=i0, N_win=(t[i0:] - t[i0]) / t_rev,
                     c_rev=c_rev, xg=xg, mug=mug, I0=I0, table=table,
                     K_rel_var=float(np.var(load * xi * speed) / np.mean(load * xi * speed) ** 2),
                     curve=curve, x_dry=float(table.x[0]), mu_dry=float(table.mu_dry[0]),
                     m_max=table.m_max, area=area, creepage=s, load=F, speed=v, skip=skip_s,
                     notes=notes, n_evaluations=table.n_evaluations)


# ---------------------------------------------------------------------------------------------
# the fit
# ---------------------------------------------------------------------------------------------
@dataclass
class _Spec:
    law: str
    order: int
    names: tuple[str, ...]    # physical names, e.g. ("k1", "spread", "transfer")
    spread: bool
    transfer_fit: bool


def check_options(laws: Sequence[str], law: str | None = None, transfer: Any = 1.0) -> list[str]:
    """The removal fit's option words, checked before any work: the candidate laws (returned,
    in order, without repeats) and the transfer (a fraction in (0, 1] or ``"fit"``).

    Raises
    ------
    TorlabInputError
        An unknown law (with the nearest known one), no law, or a bad transfer; keyed
        by its option (``laws``, ``law``, ``transfer``).
    """
    cands = list(dict.fromkeys([*laws, *([law] if law else [])]))
    if not cands:
        raise TorlabInputError("no candidate removal law", key="laws")
    for nm in cands:
        _spec(nm, False, "laws" if nm in laws else "law")
    if transfer != "fit":
        try:
            value = float(transfer)
        except (TypeError, ValueError):
            raise TorlabInputError(f"transfer must be a fraction or 'fit', got {transfer!r}",
                                   key="transfer") from None
        if not (0 < value <= 1):
            raise TorlabInputError(f"transfer must be in (0, 1], got {value:g}", key="transfer")
    return cands


def _spec(law: str, transfer_fit: bool, key: str = "laws") -> _Spec:
    if law not in LAWS:
        from torlab._suggest import did_you_mean

        raise TorlabInputError(f"unknown removal law {law!r}; use {', '.join(LAWS)}"
                               f"{did_you_mean(law, LAWS)}", key=key)
    order = 0 if law.startswith("zero") else 1
    spread = law.endswith("+spread")
    names = (f"k{order}",) + (("spread",) if spread else ()) + (("transfer",) if transfer_fit else ())
    return _Spec(law, order, names, spread, transfer_fit)


def _model(theta: np.ndarray, sp: _Spec, preps: list[_Prepared], transfer: float,
           energy: str = "model", nuisance: np.ndarray | None = None, fast: bool = False
           ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per test ``(m, mu, E)`` over the record from the application on.

    Before the fit window (the film phase) the amount follows the measured
    energy in closed form; from the window on either the model's own coupled
    energy (``energy="model"``: ``dm/dN = -(g(m) e_pass(m) + s m)`` solved by
    quadrature, :func:`~torlab.model.removal.passes_solution`) or the measured
    one (``"measured"``: closed form along the record).  ``nuisance`` (one row
    ``(eps, eta)`` per test) scales the measured energy before the window by
    ``1 + eps`` and the modelled energy rate by ``1 + eta`` (for the propagation
    of their measurement errors).  ``fast`` (the optimiser's path, laws without
    spreading): the coupled solution from precomputed integrals, scaled by the
    rate (the third element is then the measured energy, not the modelled one).
    """
    k = math.exp(theta[0])
    i = 1
    s = 0.0
    if sp.spread:
        s = math.exp(theta[i])
        i += 1
    tr = math.exp(theta[i]) if sp.transfer_fit else transfer
    out = []
    for j, p in enumerate(preps):
        m0 = p.m_applied * tr
        eps, eta = (0.0, 0.0) if nuisance is None else (float(nuisance[j, 0]),
                                                         float(nuisance[j, 1]))
        if energy == "measured":
            m = amount_from_energy(m0, sp.order, k, s, p.E, p.N)
            E = p.E
        elif fast and not sp.spread:
            i0 = p.i0
            E_pre = p.E[: i0 + 1] * (1.0 + eps)
            m_pre = amount_from_energy(m0, sp.order, k, 0.0, E_pre, p.N[: i0 + 1])
            m = np.concatenate([m_pre[:-1], _fast_window(p, sp.order, k, 1.0 + eta,
                                                         float(m_pre[-1]))])
            mu = np.interp(np.log(np.maximum(m, 1e-300)), p.xg, p.mug)
            out.append((m, mu, p.E))
            continue
        else:
            i0 = p.i0
            E_pre = p.E[: i0 + 1] * (1.0 + eps)
            m_pre = amount_from_energy(m0, sp.order, k, s, E_pre, p.N[: i0 + 1])
            sol = passes_solution(p.curve, p.mu_dry, p.x_dry, float(m_pre[-1]), sp.order, k, s,
                                  p.c_rev * (1.0 + eta), n_grid=513)
            mw, _, Ew = sol.at(p.N_win)
            m = np.concatenate([m_pre[:-1], mw[:, 0]])
            E = np.concatenate([E_pre[:-1], E_pre[-1] + Ew[:, 0]])
        x = np.log(np.clip(m, math.exp(p.x_dry), p.m_max))
        mu = np.where(m <= math.exp(p.x_dry), p.mu_dry, p.curve(x))
        out.append((m, mu, E))
    return out


def _with_mu_nodes(p: _Prepared, mu_nodes: np.ndarray) -> list[_Prepared]:
    """Copies of a prepared test whose friction table has the node values ``mu_nodes``
    ``(n_x, n)``, one per column: interpolated and integrated for every column at once
    (each column's numbers are those of the column alone)."""
    from dataclasses import replace as dc_replace

    from scipy.interpolate import PPoly

    from torlab.model.removal import cumulative_integral

    curves = p.table.curve(mu_nodes=mu_nodes)
    mug = np.asarray(curves(p.xg), dtype=float)  # (n_xg, n)
    mug[0] = mu_nodes[0]
    h = float(p.xg[1] - p.xg[0])
    I0 = {0: cumulative_integral(np.exp(p.xg)[:, None] / (p.c_rev * mug), h),
          1: cumulative_integral(1.0 / (p.c_rev * mug), h)}
    return [dc_replace(p, curve=PPoly.construct_fast(curves.c[..., i], curves.x,
                                                     extrapolate=False),
                       mug=mug[:, i], I0={o: v[:, i] for o, v in I0.items()},
                       mu_dry=float(mu_nodes[0, i]))
            for i in range(mu_nodes.shape[1])]


def _layer_sensitivity(theta: np.ndarray, J: np.ndarray, sp: _Spec, preps: list[_Prepared],
                       transfer: float, energy: str, layer: Any) -> tuple[np.ndarray, np.ndarray]:
    """``G = d theta / d p_nodes`` (n_theta x 4 n_nodes) and the layer's node covariance.

    Each node parameter of the layer (dry anchor and tested amounts) is
    perturbed in turn; the friction tables follow by their derivatives (the
    boundary model linearised at the table nodes, the perturbed parameters
    interpolated like the layer), and ``G = -B J^T J_L`` with ``J_L`` the
    residuals' response and ``B = (J^T J)^-1``.
    """
    from torlab.fit.result import _scaled_inverse

    allp = np.vstack([layer.dry_params, layer.params])
    covs = np.concatenate([layer.dry_cov[None], layer.covs])
    n_nodes = allp.shape[0]

    def resid(pp: list[_Prepared]) -> np.ndarray:
        mods = _model(theta, sp, pp, transfer, energy, fast=True)
        return np.concatenate([(mu_m - p.mu)[p.window] for p, (_, mu_m, _) in
                               zip(pp, mods, strict=True)])

    r0 = resid(preps)
    JL = np.zeros((r0.size, 4 * n_nodes))
    cols = []
    for j in range(n_nodes):
        for q in range(4):
            sd = math.sqrt(max(covs[j, q, q], 0.0))
            cols.append((j, q, sd))
    live = [(c, j, q, sd) for c, (j, q, sd) in enumerate(cols) if sd > 0]
    # every perturbed layer at once: the layer's interpolation of each is independent of the
    # others (one draw each, the same numbers as one by one)
    nodes = np.repeat(allp[None], len(live), axis=0)
    for i, (_, j, q, sd) in enumerate(live):
        nodes[i, j, q] += sd
    per_test = []  # per test, its copy for every perturbed layer
    for p in preps if live else []:
        tab = p.table
        dp = layer.draw_params(np.exp(tab.x), nodes) - tab.params[:, None, :]  # (n_x, n_live, k)
        per_test.append(_with_mu_nodes(p, tab.mu[:, :1] + np.einsum("xp,xcp->xc",
                                                                     tab.grad[:, 0, :], dp)))
    for i, (c, _, _, h) in enumerate(live):
        JL[:, c] = (resid([copies[i] for copies in per_test]) - r0) / h
    B = _scaled_inverse(J.T @ J)
    G = -B @ J.T @ JL
    from scipy.linalg import block_diag

    return G, block_diag(*covs)


def _fast_window(p: _Prepared, order: int, k: float, scale: float, m_s: float) -> np.ndarray:
    """Amount over the fit window for a law without spreading (separable: ``N = I0 / k``).

    ``dm/dN = -k m^order c mu(m)``: the passes from ``m_s`` down to ``m`` are
    ``(I0(ln m_s) - I0(ln m)) / (k scale)`` with the precomputed ``I0``; below the
    dry anchor the friction is constant and the amount follows in closed form.
    """
    m_dry = math.exp(p.xg[0])
    N = p.N_win
    kk = k * scale
    I0 = p.I0[order]
    e_dry = p.c_rev * scale * p.mug[0]
    if m_s > m_dry and kk > 0:
        Is = float(np.interp(math.log(m_s), p.xg, I0))
        target = Is - N * kk
        m = np.exp(np.interp(target, I0, p.xg))
        N_dry = Is / kk
        m1 = m_dry
    else:
        m = np.full(N.size, m_s)
        N_dry = 0.0 if kk > 0 else math.inf
        m1 = m_s
    below = N > N_dry
    if below.any():
        dN = N[below] - N_dry
        if order == 1:
            m[below] = m1 * np.exp(-k * e_dry * dN)
        else:
            m[below] = np.maximum(m1 - k * e_dry * dN, 0.0)
    return m


def _start(sp: _Spec, preps: list[_Prepared], transfer: float, resid: Any) -> tuple[np.ndarray,
                                                                                   np.ndarray,
                                                                                   np.ndarray]:
    """Grid start and bounds of the log parameters."""
    E_end = max(float(np.max(p.E[p.window])) for p in preps)
    N_end = max(float(np.max(p.N[p.window])) for p in preps)
    tr_max = min(p.transfer_max for p in preps)
    m_ref = float(np.median([p.m_applied * (transfer if not sp.transfer_fit else 0.3 * tr_max)
                             for p in preps]))
    k_ref = (m_ref if sp.order == 0 else 1.0) / max(E_end, 1e-300)
    lk = math.log(k_ref)
    grids = [np.linspace(lk - 9.0, lk + 9.0, 19)]
    lo, hi = [lk - 25.0], [lk + 25.0]
    if sp.spread:
        ls = math.log(1.0 / max(N_end, 1.0))
        grids.append(np.linspace(ls - 9.0, ls + 3.0, 9))
        lo.append(ls - 25.0)
        hi.append(ls + 8.0)
    if sp.transfer_fit:
        grids.append(np.log(tr_max * np.array([0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.9])))
        lo.append(math.log(1e-4 * tr_max))
        hi.append(math.log(tr_max))
    mesh = np.stack(np.meshgrid(*grids, indexing="ij"), axis=-1).reshape(-1, len(grids))
    best, best_ss = mesh[0], math.inf
    for th in mesh:
        r = resid(th)
        ss = float(r @ r)
        if ss < best_ss:
            best, best_ss = th, ss
    return best, np.array(lo), np.array(hi)


def _ar1_noise(r: np.ndarray) -> Any:
    """White + AR(1) noise of a residual record by a moment fit of its autocovariance.

    ``gamma(0) = v_w + v_c``, ``gamma(k) = v_c rho^k`` (k >= 1): for each ``rho`` on
    a fine grid the amplitude ``v_c`` is the least-squares fit of the sample
    autocovariance at lags 1-30, and the best ``rho`` wins; ``v_w = gamma(0) - v_c``.
    The sample autocovariance of a record whose mean was removed is low by about
    the long-run variance over ``n``; that is added back (three passes).  A
    correlated part below 5 % of the variance (or ``rho < 0.05``) is dropped.
    Microseconds, where the Whittle estimate of :mod:`torlab.fit._noise` takes a
    noticeable fraction of a second (the coverage test runs it hundreds of times).

    ``n_used`` carries the estimate's own precision into the interval's degrees
    of freedom (``parameter_dof``: ``nu = n_used``): ``nu = 2 / var(ln LRV)``
    with ``var(ln LRV) ~ (5 (1 + rho)/(1 - rho) + 20) / n`` for the long-run
    variance ``LRV``, an empirical fit to the scatter of this estimator on
    simulated white + AR(1) records (correlation times 5-40 samples, 1150
    samples; the median estimate is within 5 % of the truth there).
    """
    from torlab.fit._noise import NoiseModel

    z = np.asarray(r, dtype=float) - float(np.mean(r))
    n = z.size
    K = int(min(30, max(n // 4, 1)))
    g_raw = np.array([float(z[: n - k] @ z[k:]) / n for k in range(K + 1)])
    if g_raw[0] <= 0:
        return NoiseModel(0.0, 0.0, 0.0, kind="none (exact fit)", n_used=n)
    lags = np.arange(1, K + 1)
    rhos = np.linspace(0.0, 0.998, 500)[1:]
    P = rhos[:, None] ** lags[None, :]
    PP = np.sum(P * P, axis=1)
    g = g_raw.copy()
    rho = v_c = 0.0
    for _ in range(3):
        vc = np.clip((P @ g[1:]) / PP, 0.0, g[0])
        sse = np.sum((g[None, 1:] - vc[:, None] * P) ** 2, axis=1)
        j = int(np.argmin(sse))
        rho, v_c = float(rhos[j]), float(vc[j])
        lrv = (g[0] - v_c) + v_c * (1.0 + rho) / (1.0 - rho)
        g = g_raw + lrv / n
    g0 = float(g[0])
    if v_c < 0.05 * g0 or rho < 0.05:
        return NoiseModel(g0, 0.0, 0.0, kind="white", n_used=n)
    nu = 2.0 * n / (5.0 * (1.0 + rho) / (1.0 - rho) + 20.0)
    return NoiseModel(g0 - v_c, v_c, rho, kind="white + AR(1) (moment fit)",
                      n_used=max(int(nu), 2))


def _fit_one(sp: _Spec, preps: list[_Prepared], transfer: float, energy: str) -> dict[str, Any]:
    from scipy.optimize import least_squares

    from torlab.fit._noise import effective_points, parameter_dof, sandwich_covariance

    def resid(theta: np.ndarray) -> np.ndarray:
        mods = _model(theta, sp, preps, transfer, energy, fast=True)
        return np.concatenate([(mu_m - p.mu)[p.window] for p, (_, mu_m, _) in
                               zip(preps, mods, strict=True)])

    x0, lo, hi = _start(sp, preps, transfer, resid)
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
    try:
        # Levenberg-Marquardt (MINPACK) from the grid's best point; the search bounds lie
        # far outside (+-25 in the log parameters) and are enforced afterwards
        sol = least_squares(resid, x0, method="lm", x_scale=1.0, diff_step=1e-7, xtol=1e-9,
                            ftol=1e-10, gtol=1e-10, max_nfev=500)
        if np.any(sol.x < lo) or np.any(sol.x > hi):
            sol = least_squares(resid, np.clip(sol.x, lo + 1e-9, hi - 1e-9), bounds=(lo, hi),
                                method="trf", x_scale=1.0, diff_step=1e-7, xtol=1e-9,
                                ftol=1e-10, gtol=1e-10, max_nfev=500)
    except (ValueError, np.linalg.LinAlgError) as e:
        raise FitError(f"removal fit ({sp.law}) failed: {e}") from None
    if sol.status <= 0:
        raise FitError(f"removal fit ({sp.law}) did not converge ({sol.message}, {sol.nfev} "
                       "evaluations)")
    r = sol.fun
    J = sol.jac
    blocks, off = [], 0
    for p in preps:
        nwin = int(np.count_nonzero(p.window))
        sl = slice(off, off + nwin)
        blocks.append((sl, np.ones(nwin), _ar1_noise(r[sl])))
        off += nwin
    at_bound = [sp.names[i] for i in range(len(sol.x))
                if sol.x[i] - lo[i] < 1e-6 or hi[i] - sol.x[i] < 1e-6]
    cov = sandwich_covariance(J, blocks)
    extra = np.zeros_like(cov)
    if energy == "model" and np.all(np.isfinite(cov)):
        extra = _nuisance_covariance(sol.x, J, sp, preps, transfer, blocks)
    return {"spec": sp, "theta": sol.x, "rss": float(r @ r), "n": int(r.size), "jac": J,
            "blocks": blocks, "neff": effective_points(blocks), "nfev": int(sol.nfev),
            "at_bound": at_bound, "resid": r, "cov": cov + extra, "cov_nuisance": extra,
            "pdof": parameter_dof(J, blocks)}


def _sum_variance(w: np.ndarray, nm: Any) -> float:
    """Variance of ``sum w_i eps_i`` for the white + AR(1) noise ``nm`` (absolute)."""
    var = nm.white_var * float(w @ w)
    if nm.correlated:
        from torlab._stats import ar1_recursion  # scipy.signal.lfilter, without its import

        fwd = ar1_recursion(w, nm.rho)
        bwd = ar1_recursion(w[::-1], nm.rho)[::-1]
        var += nm.correlated_var * float(w @ (fwd + bwd - w))
    return var


def _nuisance_covariance(theta: np.ndarray, J: np.ndarray, sp: _Spec, preps: list[_Prepared],
                         transfer: float, blocks: list[Any]) -> np.ndarray:
    """Parameter covariance from the measured quantities the model takes as given.

    Per test: the energy dissipated before the fit window (the integral of the
    *measured* coefficient over the film phase: its noise, with the block's
    white + AR(1) model, and the scatter of load x SRR x speed) and the energy
    rate in the window (the median of load x SRR x speed).  Linear propagation:
    ``d theta = -B J^T J_nu d nu``, ``B = (J^T J)^-1``.
    """
    T = len(preps)
    var_nu = np.zeros((T, 2))
    for j, (p, (_, _, nm)) in enumerate(zip(preps, blocks, strict=True)):
        i0 = p.i0
        if i0 > 0:
            tt = p.t_rel[: i0 + 1]
            w = np.zeros(i0 + 1)
            dt = np.diff(tt)
            w[:-1] += 0.5 * dt
            w[1:] += 0.5 * dt
            Ks = p.E[i0] / max(float(w @ p.mu[: i0 + 1]), 1e-300)  # mean F xi v / A
            var_E = Ks**2 * (_sum_variance(w, nm) + p.K_rel_var * float(
                (w * p.mu[: i0 + 1]) @ (w * p.mu[: i0 + 1])))
            var_nu[j, 0] = var_E / max(p.E[i0], 1e-300) ** 2
        var_nu[j, 1] = 0.5 * math.pi * p.K_rel_var / max(int(np.count_nonzero(p.window)), 1)
    if not np.any(var_nu > 0):
        return np.zeros((theta.size, theta.size))

    def resid(nu: np.ndarray) -> np.ndarray:
        mods = _model(theta, sp, preps, transfer, "model", nu.reshape(T, 2), fast=True)
        return np.concatenate([(mu_m - p.mu)[p.window] for p, (_, mu_m, _) in
                               zip(preps, mods, strict=True)])

    r0 = resid(np.zeros(2 * T))
    Jn = np.zeros((r0.size, 2 * T))
    for i in range(2 * T):
        if var_nu.ravel()[i] <= 0:
            continue
        h = 1e-4
        e = np.zeros(2 * T)
        e[i] = h
        Jn[:, i] = (resid(e) - r0) / h
    from torlab.fit.result import _scaled_inverse

    B = _scaled_inverse(J.T @ J)
    G = B @ J.T @ Jn
    out = G @ np.diag(var_nu.ravel()) @ G.T
    return 0.5 * (out + out.T)


def fit_removal(tests: TimeTest | Sequence[TimeTest], layer: Any, scene: Scene, *,
                laws: Sequence[str] = ("zero_order", "first_order"), law: str | None = None,
                transfer: float | str = 1.0, skip: float | str = "auto",
                duration: float | None = None, per_interval: int = 6,
                energy: str = "model") -> FitResult:
    """Fit a removal law to time tests after application (module docstring).

    Parameters
    ----------
    tests
        :class:`TimeTest` (or a list: one product, fitted jointly).
    layer
        The product's :class:`~torlab.model.amount.AmountLayer` (HPT amount series).
    scene
        The tribometer's contact (:class:`~torlab.scene.Scene`: ball and disc radii
        and materials); each test's own load and speed replace the scene's.
    laws
        Candidate laws (:data:`torlab.model.removal.LAWS`); the criterion picks one.
    law
        Force this law (still reported against the other candidates).
    transfer
        Fraction of the applied product that reaches the band: a number (fixed,
        default 1) or ``"fit"``.
    skip
        Seconds after the application excluded from the fit (the film phase), or
        ``"auto"``.
    duration
        Fit up to this time after the application [s].
    per_interval
        Friction-table nodes per interval between tested amounts.
    energy
        Energy that drives the removal in the fit window: ``"model"`` (default,
        the modelled coefficient's, as in a prediction) or ``"measured"`` (the
        record's, taken as exact).

    Returns
    -------
    FitResult
        ``kind="removal"``: the chosen law's parameters (``k0`` kg/J or ``k1``
        m^2/J, ``spread`` 1/pass, ``transfer``), standard errors, 95 %
        intervals, correlations; ``meta`` holds ``law``, ``order``,
        ``law_selection``, ``fit_space`` (log parameters and covariance, for
        draws), the windows, the band and energy of each test; ``data`` the
        measured and modelled coefficient against the time since application.

    Raises
    ------
    TorlabInputError
        Bad options, an applied amount above the tested range, too short a window.
    FitError
        The optimiser fails.
    """
    import pandas as pd

    items = [tests] if isinstance(tests, TimeTest) else list(tests)
    if not items:
        raise TorlabInputError("no time test given")
    fit_tr = transfer == "fit"
    cands = check_options(laws, law, transfer)
    if not fit_tr:
        transfer = float(transfer)
    specs = [_spec(nm, fit_tr, "laws" if nm in laws else "law") for nm in cands]
    preps = [_prepare(tt, scene, layer, skip=skip, duration=duration, per_interval=per_interval,
                      max_transfer=1.0 if fit_tr else float(transfer), fit_transfer=fit_tr)
             for tt in items]
    if fit_tr and min(p.transfer_max for p in preps) < 1.0:
        tmax = min(p.transfer_max for p in preps)
        preps[0].notes.append(f"transfer searched up to {tmax:.3g}: more would put more product "
                              "into the band than the largest tested amount")
    if energy not in ("model", "measured"):
        raise TorlabInputError(f"energy must be 'model' or 'measured', got {energy!r}",
                               key="energy")
    fits = [_fit_one(sp, preps, 1.0 if fit_tr else float(transfer), energy) for sp in specs]
    # --- the information criterion -----------------------------------------------------------
    best_rss = min(fits, key=lambda f: f["rss"])
    neff = float(best_rss["neff"])
    n = best_rss["n"]
    rows = []
    for f in fits:
        p = len(f["spec"].names)
        corr = 2.0 * p * (p + 1) / max(neff - p - 1, 1.0)
        aicc = neff * math.log(max(f["rss"], 1e-300) / n) + 2 * p + corr
        rows.append({"law": f["spec"].law, "parameters": p, "rss": f["rss"], "aicc": aicc,
                     "at_bound": ", ".join(f["at_bound"])})
    a_min = min(r["aicc"] for r in rows)
    wsum = sum(math.exp(-0.5 * (r["aicc"] - a_min)) for r in rows)
    for r in rows:
        r["delta_aicc"] = r["aicc"] - a_min
        r["weight"] = math.exp(-0.5 * r["delta_aicc"]) / wsum
    chosen = law if law else min(rows, key=lambda r: r["aicc"])["law"]
    f = fits[cands.index(chosen)]
    sp = f["spec"]
    theta = f["theta"]
    G, cov_L = _layer_sensitivity(theta, f["jac"], sp, preps, 1.0 if fit_tr else float(transfer),
                                  energy, layer)
    with np.errstate(all="ignore"):
        cov_layer = G @ cov_L @ G.T
        cov_t = f["cov"] + cov_layer
    if not np.all(np.isfinite(cov_t)):
        names = ", ".join(p.test.label for p in preps)
        raise TorlabInputError(
            f"the time test(s) {names} do not determine the {chosen} removal law: its "
            "uncertainty is not finite (a record that ends before the friction shows the "
            "removal, or a fit window of too few samples?)", key="tests")
    vals = np.exp(theta)
    D = np.diag(vals)
    cov = D @ cov_t @ D
    dof = max(math.floor(f["neff"]) - len(theta), 2)
    pdof = np.maximum(f["pdof"], 2.0)
    # --- data against model ------------------------------------------------------------------
    mods = _model(theta, sp, preps, 1.0 if fit_tr else float(transfer), energy)
    frames = []
    for p, (m, mu_m, E_m) in zip(preps, mods, strict=True):
        frames.append(pd.DataFrame({
            "test": p.test.label, "time_s": p.t_rel, "mu_measured": p.mu, "mu_model": mu_m,
            "residual": p.mu - mu_m, "amount_mg_m2": m / MG_M2, "energy_J_m2": E_m,
            "energy_measured_J_m2": p.E,
            "passes": p.N, "in_fit": p.window}))
    warnings: list[str] = []
    for nm in f["at_bound"]:
        warnings.append(f"{nm} not determined: at the bound of its search range (the data do not "
                        "resolve it)")
    notes = [nt for p in preps for nt in p.notes]
    meta: dict[str, Any] = {
        "law": sp.law, "order": sp.order,
        "method": "closed-form amount from the measured energy; trf least squares in log "
                  "parameters from a grid start; covariance from a white + AR(1) noise model per "
                  "test (Whittle), Satterthwaite degrees of freedom; law by AICc on effective "
                  "points",
        "criterion": "AICc on the effective number of independent points",
        "law_selection": rows,
        "fit_space": {"names": list(sp.names), "values": [float(v) for v in theta],
                      "covariance": [[float(v) for v in row] for row in cov_t],
                      "covariance_without_layer": [[float(v) for v in row] for row in f["cov"]],
                      "layer_sensitivity": [[float(v) for v in row] for row in G],
                      "layer_nodes_mg_m2": [float(v) / MG_M2 for v in layer.nodes]},
        "uncertainty_parts": {
            "quantity": "standard error of ln(parameter), per part",
            "data": [math.sqrt(max(v, 0.0)) for v in np.diag(f["cov"] - f["cov_nuisance"])],
            "measured_conditions": [math.sqrt(max(v, 0.0)) for v in np.diag(f["cov_nuisance"])],
            "layer": [math.sqrt(max(v, 0.0)) for v in np.diag(cov_layer)]},
        "interval_dof": {nm: round(float(d), 1) for nm, d in zip(sp.names, pdof, strict=True)},
        "effective_points": float(f["neff"]),
        "transfer": "fitted" if fit_tr else float(transfer),
        "energy": ("measured coefficient before the fit window, modelled one in it"
                   if energy == "model" else "measured coefficient throughout") +
                  ": E = integral |mu| F |SRR| v dt / (2 pi r_track 2b)",
        "tests": [{"label": p.test.label, "applied": p.test.amount_text,
                   "application_time_s": p.test.application_time,
                   "application_source": p.test.application_source,
                   "initial_amount_mg_m2": p.m_applied / MG_M2, "band_area_m2": p.area,
                   "load_N": p.load, "speed_m_s": p.speed, "creepage": p.creepage,
                   "fit_from_s": p.skip, "samples_in_fit": int(np.count_nonzero(p.window)),
                   "energy_at_end_J_m2": float(p.E[-1]), "passes_at_end": float(p.N[-1]),
                   "retention_metrics": _measured_retention(p)}
                  for p in preps],
        "notes": notes,
        "source": ", ".join(p.test.label for p in preps),
    }
    fixed = {} if fit_tr else {"transfer": float(transfer)}
    if not sp.spread:
        fixed["spread"] = 0.0
    res = RemovalFit.from_covariance(
        "removal", sp.names, vals, cov, dof=dof, param_dof=pdof,
        residual_norm=float(np.sqrt(np.mean(f["resid"] ** 2))), n_points=int(f["n"]),
        warnings=warnings, data=pd.concat(frames, ignore_index=True), meta=meta,
        fixed=fixed, residual_unit="-",
        n_evaluations=int(f["nfev"] + sum(p.n_evaluations for p in preps)),
        x_column="time_s", y_column="mu_measured")
    se_t = np.sqrt(np.clip(np.diag(cov_t), 0.0, None))
    for i, nm in enumerate(sp.names):
        q = student_t(pdof[i])
        res.ci95[nm] = (float(math.exp(theta[i] - q * se_t[i])),
                        float(math.exp(theta[i] + q * se_t[i])))
        if nm == "transfer":
            tmax = min(p.transfer_max for p in preps)
            res.ci95[nm] = (res.ci95[nm][0], min(res.ci95[nm][1], tmax))
    dens = {float(p.test.density) for p in preps if p.test.density is not None}
    res.parameter_file = parameter_section(res, layer, dens.pop() if len(dens) == 1 else None)
    return res


