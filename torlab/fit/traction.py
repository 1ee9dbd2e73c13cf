"""Third-body layer parameters from a measured traction curve ``mu(creepage)``.

The model is the one ``torlab predict traction`` uses for the scene: Hertz +
FASTSIM with the third-body layer (thesis 5.2.2, Eqs. 5.14-5.30,
:mod:`torlab.model.fastsim`), or for a lubricated scene the mixed model of
:func:`torlab.model.predict.predict_traction`.  The parameters of the scene's layer
law (Voce: ``mu_c1, mu_c2, L_mue, L_mup``) are fitted by bounded least squares
(``scipy.optimize.least_squares``, trust-region reflective) from a
data-driven start:

* ``mu_c2`` from the plateau (median ``|mu|`` over the largest creepages);
* ``L_mue`` from the initial slope: one model evaluation with no layer
  flexibility gives Kalker's slope ``K0``; the layer adds ``L_mue / p`` to the
  flexibility ``L1``, so ``L_mue ~ (K0/K - 1) L1 p_mean``;
* ``mu_c1`` at 0.7 ``mu_c2`` (below the plateau when the curve rises to it; at
  the maximum when the curve overshoots and falls);
* ``L_mup`` equal to ``L_mue`` in metres (another law's own parameters:
  :meth:`~torlab.model.layers.base.LayerLaw.traction_start`).

The Jacobian is by forward differences (one model evaluation per parameter
per iteration; a 40-point dry curve costs about 5 ms per evaluation, so a
fit is a few tenths of a second).  Traction is odd in creepage: the sign of
each point is kept.  Standard errors are ``s^2 (J^T J)^-1`` with the residual
standard deviation ``s`` (independent points: each is a steady-state average).
Parameters may be held fixed (``fixed={"L_mup": 20e-6}``) when the curve does
not determine them.

A log recorded at several rolling speeds (an optical traction test at 0.25-2 m/s)
is fitted with each point at its own speed (``speed=``): in a lubricated contact
the film, and with it the asperities' share of the load, changes with the speed,
so one scene speed for every point would fit a different contact.

References
----------
.. [1] Kvarda, D., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J., Krupka, I.,
   Hartl, M. (2021). Asperity-based model for prediction of traction in
   water-contaminated wheel-rail contact. Tribology International 157, 106900.
   https://doi.org/10.1016/j.triboint.2021.106900
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import FitError, TorlabInputError
from torlab.fit._noise import estimate_variance_function
from torlab.fit.result import FitResult, _scaled_inverse, covariance_from_jacobian
from torlab.model.layers import LayerLaw, all_params, get_law
from torlab.threads import small_problem

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = ["fit_layer_traction", "fit_traction_test", "layer_values", "tested_contact",
           "traction_model"]

#: the parameters of the default (Voce) law; a scene with another law fits that law's
NAMES = get_law().fit_names
#: proportional share of the residual variance below which the noise counts as constant
PHI_NEGLIGIBLE = 0.05
#: weighted refits at most (feasible generalised least squares)
MAX_REWEIGHT = 3


#: quantity kind of each layer parameter (of every law)
LAYER_KINDS = {n: p.kind for n, p in all_params().items() if p.fit is not None}


def _bounds(law: LayerLaw, n: str) -> tuple[float, float]:
    """The traction fit's bounds of a parameter (units of its scale)."""
    p = law.param(n)
    return p.traction or p.fit


def layer_values(values: dict[str, Any], where: str = "fix") -> dict[str, float]:
    """Layer parameters given by a user (``{"L_mup": "20 um"}``) in SI; unknown names are
    errors with a suggestion."""
    from torlab._suggest import did_you_mean
    from torlab.units import to_si

    out = {}
    for k, v in values.items():
        if k not in LAYER_KINDS:
            raise TorlabInputError(f"{k!r} is not a layer parameter ({', '.join(LAYER_KINDS)})"
                                   f"{did_you_mean(k, LAYER_KINDS)}", key=where)
        out[k] = to_si(v, LAYER_KINDS[k], where=where)
    return out


def traction_model(scene: Scene) -> Any:
    """``f(params: dict, creepage) -> mu`` for the scene with the layer replaced by ``params``.

    A dry scene calls FASTSIM directly (no table, no summary; corrected by the exact
    theory unless the scene's method is ``fastsim-kalker``), or with method ``exact`` the
    exact solver; a lubricated one goes through
    :func:`~torlab.model.predict.predict_traction`.
    """
    from torlab.model.contact import build_contact
    from torlab.model.fastsim import boundary_traction
    from torlab.model.prediction import fastsim_grid, fastsim_problem
    from torlab.model.traction import traction_curve

    if scene.boundary is None:
        raise TorlabInputError("the scene needs a boundary: section (its values are the fit's "
                               "defaults for fixed parameters)", key="boundary")
    if scene.lubricant is None and scene.grid.method == "exact":
        from torlab.model.exact.rolling import ExactGrid
        from torlab.model.exact.scene import predict_exact

        def e(params: dict[str, float], xi: np.ndarray) -> np.ndarray:
            sc = with_params(scene, params)
            return predict_exact(sc, xi, grid=ExactGrid(n=scene.grid.exact_n)).table[
                "mu"].to_numpy()

        e.contact = build_contact(scene)  # type: ignore[attr-defined]
        return e
    if scene.lubricant is None:
        contact = build_contact(scene)
        prob = fastsim_problem(scene, contact)
        grid = fastsim_grid(scene)

        def f(params: dict[str, float], xi: np.ndarray) -> np.ndarray:
            layer = prob.layer.replace(**{k: float(v) for k, v in params.items()})
            return boundary_traction(replace(prob, layer=layer), xi, grid).mu

        f.contact = contact  # type: ignore[attr-defined]
        return f

    def g(params: dict[str, float], xi: np.ndarray) -> np.ndarray:
        b = scene.boundary.model_copy(update={k: float(v) for k, v in params.items()})
        return traction_curve(scene.model_copy(update={"boundary": b}), xi).table["mu"].to_numpy()

    g.contact = build_contact(scene)  # type: ignore[attr-defined]
    return g


def _check(creepage: Any, mu: Any) -> tuple[np.ndarray, np.ndarray]:
    xi = np.asarray(creepage, dtype=float).ravel()
    y = np.asarray(mu, dtype=float).ravel()
    if xi.shape != y.shape:
        raise TorlabInputError(f"traction fit: {xi.size} creepages but {y.size} coefficients")
    if not (np.all(np.isfinite(xi)) and np.all(np.isfinite(y))):
        raise TorlabInputError("traction fit: creepage and mu must be finite numbers")
    keep = xi != 0
    xi, y = xi[keep], y[keep]
    if xi.size < 6:
        raise TorlabInputError(f"traction fit: too few points at non-zero creepage ({xi.size}); the "
                               "four layer parameters with uncertainties need at least 6")
    if np.ptp(np.abs(xi)) <= 1e-6 * np.max(np.abs(xi)):
        raise TorlabInputError("traction fit: all points are at one creepage; the curve's shape "
                               "(slope, knee, plateau) needs a range")
    ya = np.abs(y)
    if np.max(ya) <= 0 or np.ptp(y * np.sign(xi)) <= 1e-6 * np.max(ya):
        raise TorlabInputError("traction fit: the traction coefficient is constant: no curve to fit")
    return xi, y


def _start(model: Any, scene: Scene, xi: np.ndarray, y: np.ndarray) -> dict[str, float]:
    """Data-driven initial guess (module docstring)."""
    a = np.abs(xi)
    ya = np.abs(y) * np.sign(y * xi)  # traction in the creepage's direction
    order = np.argsort(a)
    a, ya = a[order], ya[order]
    top = ya[a >= np.quantile(a, 0.8)]
    mu2 = float(np.clip(np.median(top), 0.01, 2.0))
    peak = float(np.max(ya))
    mu1 = peak if peak > 1.05 * mu2 else 0.7 * mu2
    # initial slope from the smallest creepages still below 40 % of the plateau
    low = ya < 0.4 * mu2
    if low.sum() >= 1:
        K = float(np.sum(ya[low] * a[low]) / np.sum(a[low] ** 2))
    else:
        K = float(ya[0] / a[0])
    contact = model.contact
    xi0 = np.array([1e-6])
    law = scene.boundary.layer.law
    K0 = float(model(law.elastic_probe(), xi0)[0] / 1e-6)
    p_mean = 2.0 / 3.0 * contact.patch.p0
    lme = max((K0 / max(K, 1e-9) - 1.0) * contact.L1 * p_mean, 0.05e-6)
    return law.traction_start(mu1, mu2, lme)


def speed_model(scene: Scene, speed: Any) -> tuple[Any, list[float], np.ndarray]:
    """The traction model of points at their own rolling speeds.

    Parameters
    ----------
    scene
        The test contact.
    speed
        Rolling speed of every point [m/s] (None: the scene's for all).

    Returns
    -------
    (model, speeds, group)
        ``model(params, xi)`` evaluates each point at its speed (``xi`` in the
        order of ``speed``); the distinct speeds [m/s] (within 5 % of a group's
        slowest, their mean) and each point's group index.  ``model.contact`` and
        ``model.first`` (the model at the slowest speed alone, for the start) as
        :func:`traction_model`.
    """
    if speed is None:
        m = traction_model(scene)
        m.first = m  # type: ignore[attr-defined]
        return m, [float(scene.kinematics.speed)], None  # type: ignore[return-value]
    from torlab.reduce.optical import speed_groups

    v = np.asarray(speed, dtype=float).ravel()
    if not (np.all(np.isfinite(v)) and np.all(v > 0)):
        raise TorlabInputError("traction fit: the rolling speeds must be positive numbers",
                               key="speed")
    g = speed_groups(v)
    speeds = [float(np.mean(v[g == k])) for k in range(int(g.max()) + 1)]
    models = [traction_model(scene.model_copy(update={"kinematics": scene.kinematics.model_copy(
        update={"speed": s})})) for s in speeds]

    def f(params: dict[str, float], xi: np.ndarray) -> np.ndarray:
        xi = np.asarray(xi, dtype=float)
        out = np.empty(xi.shape)
        for k, m in enumerate(models):
            sel = g == k
            out[sel] = m(params, xi[sel])
        return out

    f.contact = models[0].contact  # type: ignore[attr-defined]
    f.first = models[0]  # type: ignore[attr-defined]
    return f, speeds, g


@small_problem  # one BLAS thread: small matrices (torlab.threads)
def fit_layer_traction(scene: Scene, creepage: Any, mu: Any, *, fixed: dict[str, float] | None = None,
                       x0: dict[str, float] | None = None, max_nfev: int = 200,
                       speed: Any = None, method: str | None = None) -> FitResult:
    """Fit the layer parameters to a traction curve by the boundary method.

    ``fastsim`` (the scene's default: FASTSIM corrected by Kalker's exact theory) and
    ``fastsim-kalker`` (the thesis's FASTSIM) fit that model (:func:`fit_layer_fastsim`);
    ``exact`` fits Kalker's exact theory (:func:`fit_layer_exact`); ``auto`` fits the
    fast method and refits by the exact theory where the fitted curve's theory error
    exceeds its band's half-width (:func:`torlab.model.predict.choose_method`'s rule,
    the band from the fit's covariance).  The result's ``meta["boundary_method"]`` (also
    in ``params.yaml``'s ``fit:``) names the method and ``meta["theory_error"]`` its
    theory error along the data.
    """
    from torlab.model.predict import with_method

    scene = with_method(scene, method)
    asked = scene.grid.method
    if asked in ("exact", "auto") and scene.lubricant is not None:
        if asked == "exact":
            raise TorlabInputError("the exact solver models dry contacts: fit a lubricated "
                                   "scene with method fastsim", key="method")
    res = fit_layer_fastsim(scene, creepage, mu, fixed=fixed, x0=x0, max_nfev=max_nfev,
                            speed=speed)
    used, why = asked, ""
    if asked == "auto":
        used, why = _auto_fit(scene, res)
    elif asked == "exact":
        used = "exact"
    if used == "exact":
        res = fit_layer_exact(scene, creepage, mu, res, fixed=fixed, max_nfev=max_nfev)
    res.meta["boundary_method"] = used
    if asked == "auto":
        res.meta["boundary_method_auto"] = why
    _fit_theory_error(scene, res, used)
    return res


def _band_half_width(scene: Any, res: FitResult) -> np.ndarray | None:
    """The fitted curve's 95 % half-width at the data (linearised from the covariance)."""
    from torlab._stats import t_ppf

    names = list(res.names)
    cov = np.asarray(res.covariance, dtype=float)
    if not np.all(np.isfinite(cov)):
        return None
    xi = res.data["creepage"].to_numpy(dtype=float)
    model = traction_model(scene)
    base = dict(res.fixed) | dict(res.params)
    f0 = model(base, xi)
    J = np.empty((xi.size, len(names)))
    for j, n in enumerate(names):
        h = 1e-4 * max(abs(base[n]), 1e-12)
        J[:, j] = (model({**base, n: base[n] + h}, xi) - f0) / h
    var = np.einsum("ij,jk,ik->i", J, cov, J)
    t = float(t_ppf(0.975, res.dof)) if math.isfinite(res.dof) else 1.959963984540054
    return t * np.sqrt(np.clip(var, 0.0, None))


def _auto_fit(scene: Any, res: FitResult) -> tuple[str, str]:
    """``auto``: the fast method's fit stays where its theory error along the data is
    below the fitted curve's band half-width, else the exact theory's fit."""
    from torlab.model.calibrated import longitudinal_error
    from torlab.model.prediction import fastsim_problem

    if scene.lubricant is not None:
        return "fastsim", "the exact solver models dry contacts"
    xi = res.data["creepage"].to_numpy(dtype=float)
    mu = res.data["mu_model"].to_numpy(dtype=float)
    sc = with_params(scene, {**res.fixed, **res.params})
    err = longitudinal_error(fastsim_problem(sc), xi, mu, calibrated=True)
    hw = _band_half_width(sc, res)
    if hw is None:
        return "exact", "the fit's band is not determined: the exact theory"
    worst = int(np.argmax(err - hw))
    if err[worst] < hw[worst]:
        return "fastsim", (f"its theory error is below the fitted curve's band half-width at "
                           f"every point (largest {float(np.max(err)):.2g})")
    return "exact", (f"its theory error {float(err[worst]):.2g} exceeds the fitted curve's band "
                     f"half-width {float(hw[worst]):.2g} at creepage {float(xi[worst]):.4g}")


def _fit_theory_error(scene: Any, res: FitResult, method: str) -> None:
    """``meta["theory_error"]``: the fitted curve's theory error along the data."""
    from torlab.model.calibrated import longitudinal_error
    from torlab.model.prediction import fastsim_problem

    if scene.lubricant is not None:
        res.meta["theory_error"] = ("lubricated: the boundary part's theory error is in the "
                                    "predictions (predict traction)")
        return
    xi = res.data["creepage"].to_numpy(dtype=float)
    mu = res.data["mu_model"].to_numpy(dtype=float)
    if method == "exact":
        e = np.abs(res.data["mu_model_error"].to_numpy(dtype=float)) \
            if "mu_model_error" in res.data else np.full(xi.size, np.nan)
    else:
        sc = with_params(scene, {**res.fixed, **res.params})
        e = longitudinal_error(fastsim_problem(sc), xi, mu,
                               calibrated=method != "fastsim-kalker")
    res.data["mu_theory_error_95"] = e
    fin = np.isfinite(e)
    res.meta["theory_error_95"] = float(np.max(e[fin])) if fin.any() else None


def fit_layer_exact(scene: Scene, creepage: Any, mu: Any, start: FitResult, *,
                    fixed: dict[str, float] | None = None, max_nfev: int = 200,
                    iterations: int = 6) -> FitResult:
    """Fit the layer by Kalker's exact theory, from the fast method's fit ``start``.

    The exact theory is FASTSIM times the ratio exact/FASTSIM; the ratio depends little
    on the parameters, so it is computed once per round at the current estimate
    (:func:`torlab.model.exact.scene.predict_exact` on the data's creepages, the scene's
    ``grid: exact_n``) and held while FASTSIM with it is fitted; the rounds stop when no
    parameter moves by more than 1e-3 of its standard error.  At the end the model is
    the exact theory at the estimate (the residuals and ``mu_model`` are the exact
    theory's); the estimate solves the least-squares problem with the ratio's
    dependence on the parameters left out, which the last round's step bounds.
    """
    from torlab.model.exact.rolling import ExactGrid
    from torlab.model.exact.scene import predict_exact
    from torlab.model.predict import with_method

    xi, y = _check(creepage, mu)
    fast = with_method(scene, "fastsim")
    cur = start
    ratio = np.ones_like(xi)
    moved = math.inf
    for k in range(iterations):
        sc = with_params(scene, {**cur.fixed, **cur.params})
        ex = predict_exact(sc, xi, grid=ExactGrid(n=scene.grid.exact_n))
        fa = traction_model(fast)({**cur.fixed, **cur.params}, xi)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(np.abs(fa) > 0, ex.table["mu"].to_numpy() / fa, 1.0)
        new = fit_layer_fastsim(fast, xi, y, fixed=fixed, max_nfev=max_nfev,
                                x0={**cur.fixed, **cur.params}, ratio=ratio)
        se = {n: new.stderr[n] for n in new.names}
        moved = max((abs(new.params[n] - cur.params.get(n, new.params[n]))
                     / se[n] if se[n] and math.isfinite(se[n]) and se[n] > 0 else 0.0)
                    for n in new.names)
        cur = new
        if moved < 1e-3 and k > 0:
            break
    sc = with_params(scene, {**cur.fixed, **cur.params})
    ex = predict_exact(sc, xi, grid=ExactGrid(n=scene.grid.exact_n))
    m = ex.table["mu"].to_numpy()
    cur.data["mu_model"] = m
    cur.data["residual"] = y - m
    cur.data["mu_model_error"] = ex.table["mu_x_error"].to_numpy()
    cur.residual_norm = float(np.sqrt(np.mean((y - m) ** 2)))
    cur.meta["method"] = ("bounded least squares of Kalker's exact theory (FASTSIM times the "
                          "ratio exact/FASTSIM at the estimate, refreshed each round: "
                          f"{k + 1} rounds, last step {moved:.2g} standard errors)")
    cur.meta["model"] = "dry: Hertz + Kalker's exact theory with the layer in series"
    cur.meta["exact_grid"] = int(scene.grid.exact_n)
    return cur


def with_params(scene: Any, params: dict[str, float]) -> Any:
    """The scene with its layer's parameters replaced (SI values)."""
    b = scene.boundary.model_copy(update={k: float(v) for k, v in params.items()
                                          if k in scene.boundary.layer.law.names})
    return scene.model_copy(update={"boundary": b})


def fit_layer_fastsim(scene: Scene, creepage: Any, mu: Any, *, fixed: dict[str, float] | None = None,  # noqa: C901 (each input form, fixed parameter and fallback is a case, said in the result)
                      x0: dict[str, float] | None = None, max_nfev: int = 200,
                      speed: Any = None, ratio: Any = None) -> FitResult:
    """Fit the layer parameters to a traction curve with FASTSIM (thesis Eqs. 5.14-5.30),
    corrected by the exact theory or not as the scene's ``grid: method`` says
    (``ratio``: FASTSIM times these factors per point, :func:`fit_layer_exact`).

    Parameters
    ----------
    scene
        A :class:`~torlab.scene.Scene` describing the test contact (load,
        radii, materials, speed); its ``boundary:`` values are used for the
        fixed parameters and the temperature coefficients.
    creepage, mu
        The measured curve (creepage as a fraction, = SRR; any sign).
    fixed
        Parameters held at the given SI values instead of fitted.
    x0
        Starting values (SI) overriding the data-driven guess.
    max_nfev
        Model-evaluation budget of the optimiser.
    speed
        Rolling speed of every point [m/s] (a log at several speeds); default the
        scene's for all.

    Returns
    -------
    FitResult
        ``kind="layer_traction"``.

    Raises
    ------
    TorlabInputError
        Too few points, one creepage, constant signal, unknown fixed names.
    FitError
        The optimiser does not converge.
    """
    import pandas as pd
    from scipy.optimize import least_squares

    if speed is not None and scene.lubricant is None and scene.thermal is None:
        speed = None  # a dry isothermal contact does not depend on the speed
    if speed is not None:
        v_all = np.asarray(speed, dtype=float).ravel()
        if v_all.size != np.asarray(creepage).size:
            raise TorlabInputError(f"traction fit: {np.asarray(creepage).size} creepages but "
                                   f"{v_all.size} speeds", key="speed")
        speed = v_all[np.asarray(creepage, dtype=float).ravel() != 0]
    xi, y = _check(creepage, mu)
    fixed = dict(fixed or {})
    law = scene.boundary.layer.law if scene.boundary is not None else get_law()
    names = law.fit_names
    for k in fixed:
        if k not in names:
            raise TorlabInputError(f"cannot fix {k!r}: the traction fit's parameters are "
                                   f"{', '.join(names)}", key="fixed")
    free = [n for n in names if n not in fixed]
    if not free:
        raise TorlabInputError("every parameter is fixed: nothing to fit", key="fixed")
    if xi.size < len(free) + 2:
        raise TorlabInputError(f"traction fit: {xi.size} points for {len(free)} parameters; need "
                               f"at least {len(free) + 2}")
    model, speeds, group = speed_model(scene, speed)
    nfev = [0]
    factor = 1.0 if ratio is None else np.asarray(ratio, dtype=float)

    def evaluate(p: dict[str, float]) -> np.ndarray:
        nfev[0] += 1
        return model(p, xi) * factor

    first = slice(None) if group is None else group == 0
    start = _start(model.first, scene, xi[first], y[first])
    nfev[0] += 1
    start.update(x0 or {})
    sc = np.array([law.param(n).scale for n in free])
    lo = np.array([_bounds(law, n)[0] for n in free])
    hi = np.array([_bounds(law, n)[1] for n in free])
    xs = np.clip(np.array([start[n] for n in free]) / sc, np.where(lo > 0, lo * 1.001, lo * 0.999),
                 np.where(hi > 0, hi * 0.999, hi * 1.001))

    def params(x: np.ndarray) -> dict[str, float]:
        return {**fixed, **{n: float(v) * s for n, v, s in zip(free, x, sc, strict=True)}}

    def resid(x: np.ndarray) -> np.ndarray:
        return evaluate(params(x)) - y

    def solve(x_start: np.ndarray, w: np.ndarray | None, nfev_budget: int) -> Any:
        sw = None if w is None else 1.0 / np.sqrt(w)
        fun = resid if sw is None else (lambda x: resid(x) * sw)
        try:
            sol = least_squares(fun, x_start, bounds=(lo, hi), x_scale="jac", method="trf",
                                diff_step=1e-4, xtol=1e-6, ftol=1e-8, max_nfev=nfev_budget)
        except (ValueError, np.linalg.LinAlgError) as e:
            raise FitError(f"traction fit failed: {e}") from None
        if sol.status <= 0:
            raise FitError(f"traction fit did not converge within {max_nfev} evaluations "
                           f"({sol.message})")
        return sol

    sol = solve(xs, None, max_nfev)
    # --- noise that grows with the signal: variance function, then weighted least squares ---
    # (the residuals r are unweighted; sol.fun and sol.jac are of the weighted problem)
    r = sol.fun
    vf = estimate_variance_function(r, np.abs(y + r), _leverage(sol.jac))
    w = None
    for _ in range(MAX_REWEIGHT if vf.significant and vf.phi > PHI_NEGLIGIBLE else 0):
        w = vf.weights(np.abs(y + r))
        sol = solve(sol.x, w, max(max_nfev - nfev[0], 4 * len(free) + 8))
        r = sol.fun * np.sqrt(w)
        new = estimate_variance_function(r, np.abs(y + r), _leverage(sol.jac))
        done = abs(new.phi - vf.phi) < 0.05
        vf = new
        if done:
            break
    if w is not None and vf.phi <= PHI_NEGLIGIBLE:
        w = None  # the reweighting found the noise constant after all
        sol = solve(sol.x, None, max(max_nfev - nfev[0], 4 * len(free) + 8))
        r = sol.fun
    p = params(sol.x)
    # a parameter that ends on a bound of the search range: a length at its lower end (the
    # curve prefers no layer flexibility / an immediate hardening) is fixed there, the reduced
    # model; any other is not determined (the optimiser ran off along a direction the data
    # do not constrain)
    active = dict(zip(free, sol.active_mask, strict=True))
    at_zero = [n for n in free if law.param(n).kind == "length" and active[n] < 0]
    at_bound = [n for n in free if active[n] != 0 and n not in at_zero]
    keep = [i for i, n in enumerate(free) if n not in at_zero]
    names_fit = [free[i] for i in keep]
    if not names_fit:
        raise FitError("traction fit: every free parameter ended on a bound of its range")
    cov = _covariance(sol.jac[:, keep] / sc[None, keep], sol.fun, len(keep))
    for n in at_bound:
        i = names_fit.index(n)
        cov[i, :] = np.inf
        cov[:, i] = np.inf
    # one more degree of freedom spent on the variance function's shape
    dof = xi.size - len(keep) - (1 if w is not None else 0)
    y_model = y + r
    data = pd.DataFrame({"creepage": xi, "mu_measured": y, "mu_model": y_model, "residual": -r})
    if len(speeds) > 1:
        data.insert(0, "curve", [f"{speeds[k]:.3g} m/s" for k in group])
        data.insert(1, "speed_m_s", np.asarray(speed, dtype=float))
    if w is not None:
        data["residual_sd_relative"] = np.sqrt(w)
    meta = {"method": "bounded least squares (trf) of FASTSIM + layer (torlab predict's model)"
                      + ("" if w is None else "; weighted by a variance function estimated from "
                         "the residuals (noise growing with mu)"),
            "scene": getattr(scene, "name", ""),
            "model": "dry: Hertz + FASTSIM" if scene.lubricant is None else "mixed (predict_traction)",
            "creepage_range": [float(np.min(xi)), float(np.max(xi))],
            "speeds_m_s": speeds,
            "noise_model": vf.describe() if w is not None else
            "constant (the variance function's proportional share is negligible)",
            "noise_proportional_share": float(vf.phi)}
    from torlab.random_effects import ONE_RUN

    meta["scatter"] = ONE_RUN  # one curve; repeats are pooled by torlab.fit.repeats
    fixed = {**fixed, **{n: p[n] for n in at_zero}}
    res = FitResult.from_covariance(
        "layer_traction", tuple(names_fit), np.array([p[n] for n in names_fit]), cov, dof=dof,
        log_scale=tuple(n for n in names_fit if law.param(n).positive),
        residual_norm=float(np.sqrt(np.mean(r * r))), n_points=int(xi.size), warnings=[],
        data=data, meta=meta, fixed={k: float(v) for k, v in fixed.items()}, residual_unit="-",
        n_evaluations=int(nfev[0]), x_column="creepage", y_column="mu_measured")
    for n in at_zero:
        res.warnings.append(f"{n} at the lower end of its range ({p[n]:.3g} m): the curve is "
                            "consistent with 0, so it is fixed there (its one-sided uncertainty "
                            "is not carried into predictions)")
    for n in at_bound:
        res.warnings.append(f"{n} not determined: the fit ended on the bound of its search range "
                            f"({res.params[n]:.3g}); the curve does not constrain it (fix it with "
                            "a value from an HPT fit); predictions from this fit get no band "
                            "until it is fixed")
    if law is not get_law():
        res.meta["law"] = law.name
    res.warnings.extend(_warnings(res, xi, skip=set(at_bound)))
    if at_zero or at_bound:
        ms = res.meta.setdefault("model_selection", {})
        ms.update({n: {"decision": "fixed at the lower end of its range (the curve prefers 0)"}
                   for n in at_zero})
        ms.update({n: {"decision": "not determined (ended on a bound): no band until fixed"}
                   for n in at_bound})
    return res


def tested_contact(scene: Any, test: str = "", *, dry: bool = False) -> Any:
    """The contact a traction test was run in: ``scene`` itself, or, for a dry test
    (``dry``, or an optical log of test ``dry_traction``), the scene without its
    ``lubricant:`` and ``roughness:`` (Hertz + FASTSIM + layer)."""
    if (dry or test == "dry_traction") and (scene.lubricant is not None
                                            or scene.roughness is not None):
        return scene.model_copy(update={"lubricant": None, "roughness": None})
    return scene


def fit_traction_test(scene: Any, data: Any, *, dry: bool = False,
                      fixed: dict[str, float] | None = None,
                      method: str | None = None) -> FitResult:
    """The layer from one measured traction test, as every caller fits it.

    ``torlab fit traction``, :func:`torlab.fit_traction` and protocols'
    ``fits.traction_layers`` all come here: the test's contact
    (:func:`tested_contact`) and every point at its own rolling speed
    (:func:`fit_layer_traction` with ``speed=``; thesis Eqs. 5.14-5.30, the mixed
    model Eq. 5.47 for a lubricated contact).

    Parameters
    ----------
    scene
        The test contact (a validated :class:`~torlab.scene.Scene`).
    data
        ``(creepage, mu, test, speed)``
        (:class:`torlab.instruments.measured.TractionData`): creepage [-], coefficient
        [-], the test type ('' or ``dry_traction``) and each point's rolling speed
        [m/s] or None (the scene's speed for all).
    dry
        Ignore the scene's lubricant and roughness (a dry test).
    fixed
        Parameters held fixed [SI].
    method
        The boundary method (``fastsim``, ``exact``, ``auto``; None: the scene's
        ``grid: method``), :func:`fit_layer_traction`.

    Returns
    -------
    FitResult
    """
    xi, mu, test, speed = data
    return fit_layer_traction(tested_contact(scene, test, dry=dry), np.asarray(xi, dtype=float),
                              np.asarray(mu, dtype=float), fixed=fixed, speed=speed,
                              method=method)


def _covariance(J: np.ndarray, r: np.ndarray, k: int) -> np.ndarray:
    """Covariance of the (weighted) least-squares estimate: model-based, no narrower than HC3.

    ``s^2 (J^T J)^-1`` trusts the variance function (or the constant noise) it was
    weighted with; the HC3 sandwich ``B sum_i J_i J_i^T r_i^2/(1 - h_ii)^2 B``
    (MacKinnon & White 1985, J. Econometrics 29, 305) does not, but scatters more.
    Each parameter's variance is the larger of the two, the correlations are the
    model-based ones: over 200 seeds of constant and of proportional noise this
    took the coverage from 91-95 % to 94.5-97 % (docs/fit.md).
    """
    model, _s = covariance_from_jacobian(J, r, k)
    bread = _scaled_inverse(J.T @ J)
    if not np.all(np.isfinite(bread)):
        return model
    h = np.clip(_leverage(J), 0.0, 0.99)
    g = J * (np.asarray(r, dtype=float) / (1.0 - h))[:, None]
    hc3 = bread @ (g.T @ g) @ bread
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.sqrt(np.maximum(np.diag(hc3) / np.diag(model), 1.0))
    f = np.where(np.isfinite(f), f, 1.0)
    return model * np.outer(f, f)


def _leverage(jac: np.ndarray) -> np.ndarray:
    """Diagonal of the hat matrix ``J (J^T J)^-1 J^T`` (0 where singular)."""
    q, rr = np.linalg.qr(jac)
    ok = np.abs(np.diag(rr)) > 1e-12 * max(float(np.max(np.abs(np.diag(rr)), initial=0.0)), 1e-300)
    return np.sum(q[:, ok] ** 2, axis=1)


def _warnings(res: FitResult, xi: np.ndarray, skip: set[str] | None = None) -> list[str]:
    """What the curve does not determine, and what is done about it (``meta["model_selection"]``)."""
    w = []
    choice: dict[str, Any] = {}
    for n in res.names:
        if n in (skip or ()):
            continue
        v, se = res.params[n], res.stderr[n]
        if not math.isfinite(se):
            w.append(f"{n} not determined by this curve (fix it with a value from an HPT fit); "
                     "predictions from this fit get no band until it is fixed")
            choice[n] = {"decision": "not determined: no band until fixed"}
        elif v != 0 and se > 0.5 * abs(v):
            lo, hi = res.ci95[n]
            unit = "µm" if n.startswith("L_") else ""
            f = 1e6 if unit else 1.0
            w.append(f"{n} poorly determined (standard error {se / abs(v):.0%}, 95 % interval "
                     f"{lo * f:.3g}–{hi * f:.3g}{' ' + unit if unit else ''} on a log scale): kept, "
                     "and its uncertainty is carried into predictions; fix it (--fix) from an "
                     "HPT fit to narrow them")
            choice[n] = {"decision": "kept; its uncertainty is carried into predictions",
                         "relative_standard_error": se / abs(v), "ci95": [lo, hi]}
    if choice:
        res.meta.setdefault("model_selection", {}).update(choice)
    w.extend(get_law(res.meta.get("law")).traction_warnings(res))
    k = len(res.names)
    corr = res.correlation
    for i in range(k):
        for j in range(i + 1, k):
            c = corr[i, j]
            if np.isfinite(c) and abs(c) > 0.98:
                w.append(f"{res.names[i]} and {res.names[j]} are strongly correlated ({c:+.3f}): "
                         "the curve determines a combination of them")
    return w
