"""Retention of an application: friction against axle passes, and a slip sweep as measured.

:func:`predict_retention` answers the railway's question -- for how many axle
passes (disc revolutions, or seconds at a speed) does an application keep the
coefficient in the 0.15-0.25 band? -- from

* the product's amount dependency (:class:`~torlab.model.amount.AmountLayer`,
  Paper C's HPT amount series),
* a removal law (:class:`~torlab.model.removal.RemovalLaw`, or the
  :class:`~torlab.fit.result.FitResult` of :func:`torlab.fit.removal.fit_removal`),
* a scene (the wheel-rail contact of Tab. 5.4, or a disc) at one creepage.

The removal ODE is solved by quadrature in the amount
(:func:`torlab.model.removal.passes_solution`), so a 10 000-pass prediction
costs a few dozen boundary-model evaluations, not one per pass.

:func:`simulate_sweep` simulates a traction curve recorded while the creepage
ramps over a given time and the product is removed meanwhile (thesis H4.1: the
positive traction trends of the literature are made by removal), beside the
steady curve at the applied amount, and classifies both trends with
:func:`torlab.model.prediction.classify_trend`.

Uncertainty (:func:`removal_draws`, :func:`propagate_draws`): parameter draws of
the removal law (normal in the fit's log parameters, with their correlations)
and of the layer (each tested amount's fit, interpolated like the estimate; the
coefficient of a drawn layer by linearisation of the boundary model at each
node), pushed through the same solution; the intervals are quantiles of the
draws.  The removal fit is conditional on the estimated layer, and the two are
drawn independently.

References
----------
.. [1] Kvarda, D., Skurka, S., Galas, R., Omasta, M., Shi, L.-B., Ding, H.-H., Wang, W.-J.,
   Krupka, I., Hartl, M. (2022). The effect of top of rail lubricant composition on
   adhesion and rheological behaviour. Engineering Science and Technology, an
   International Journal 35, 101100. https://doi.org/10.1016/j.jestch.2022.101100
.. [2] Kvarda, D., Galas, R., Omasta, M., Dzimko, M., Krupka, I., Hartl, M. (2022). Shear
   properties of top-of-rail products in numerical modelling. Proceedings of the
   Institution of Mechanical Engineers, Part F: Journal of Rail and Rapid Transit.
   https://doi.org/10.1177/09544097221138374
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.model.amount import MG_M2, areal_density
from torlab.model.removal import (
    Band,
    RemovalLaw,
    band_of,
    boundary_scene,
    energy_per_pass,
    mu_table,
    passes_solution,
)

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = [
    "BAND_PRESETS",
    "RetentionPrediction",
    "SweepPrediction",
    "predict_retention",
    "propagate_draws",
    "removal_draws",
    "retention_band",
    "retention_metrics",
    "simulate_sweep",
]

DEFAULT_BAND = (0.15, 0.25)

#: named coefficient bands: name -> (low, high, where the numbers come from).  The twin-disc
#: practice for rail friction materials (EN 15427-2-1, Annex H; CEN/TS 15427-2-2 for
#: top-of-rail materials) reports an effective friction level and a retentivity; the band
#: a product should hold depends on its class, and these values are the thesis's or a
#: convention, not numbers of those documents.
BAND_PRESETS: dict[str, tuple[float, float, str]] = {
    "thesis": (0.15, 0.25, "the thesis's optimal band for top-of-rail products (ch. 6): low "
                           "enough to cut wear and noise, high enough for traction and braking"),
    "intermediate": (0.20, 0.35, "a convention for drying top-of-rail friction modifiers, which "
                                 "are held at an intermediate friction above the thesis's band; "
                                 "the numbers are a common choice, not a standard's"),
}
#: the default retentivity: passes until mu leaves the band (rises above its upper bound)
RETENTIVITY_BAND = "band"


def retention_band(band: Any) -> tuple[tuple[float, float], str]:
    """A band from a preset name (:data:`BAND_PRESETS`), ``"LOW:HIGH"`` or ``(low, high)``:
    ``((low, high), what it is)``.

    Raises
    ------
    TorlabInputError
        An unknown name, not two increasing positive numbers.
    """
    from torlab._suggest import did_you_mean

    if isinstance(band, str) and ":" not in band:
        name = band.strip().lower()
        if name not in BAND_PRESETS:
            raise TorlabInputError(f"{band!r} is not a band preset ({', '.join(BAND_PRESETS)}) "
                                   f"nor LOW:HIGH{did_you_mean(name, list(BAND_PRESETS))}",
                                   key="band")
        lo, hi, why = BAND_PRESETS[name]
        return (lo, hi), f"{name}: {lo:g}-{hi:g} ({why})"
    if isinstance(band, str):
        parts = band.split(":")
        if len(parts) != 2:
            raise TorlabInputError(f"{band!r}: write LOW:HIGH, e.g. 0.15:0.25", key="band")
        try:
            band = (float(parts[0]), float(parts[1]))
        except ValueError:
            raise TorlabInputError(f"{band!r}: write LOW:HIGH, e.g. 0.15:0.25", key="band") from None
    lo, hi = (float(v) for v in band)
    if not (0 < lo < hi and math.isfinite(hi)):
        raise TorlabInputError(f"band must be two increasing positive coefficients, got "
                               f"{lo:g}:{hi:g}", key="band")
    return (lo, hi), f"{lo:g}-{hi:g} (given)"
#: probability over the parameter draws that a crossing (or its absence) needs to be stated;
#: below it the crossing's status is "undetermined" with the probability
CROSSING_PROBABILITY = 0.9


# ---------------------------------------------------------------------------------------------
# uncertainty: draws and their quantiles (the one place to swap for a shared module)
# ---------------------------------------------------------------------------------------------
def propagate_draws(samples: Any, *, confidence: float = 0.95, axis: int = -1
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Central ``confidence`` interval of sampled outputs: the two quantiles along ``axis``.

    Infinite samples (a crossing that never happens) count as larger than any
    finite one, so an upper bound may be ``inf``.
    """
    a = np.asarray(samples, dtype=float)
    q = 0.5 * (1.0 - confidence)
    lo = np.quantile(a, q, axis=axis, method="linear")
    hi = np.quantile(a, 1.0 - q, axis=axis, method="linear")
    return lo, hi


def removal_draws(removal: Any, n: int, rng: np.random.Generator, *, layer: Any = None,
                  node_draws: np.ndarray | None = None) -> dict[str, Any]:
    """Draws of a removal law's parameters.

    Parameters
    ----------
    removal
        A :class:`~torlab.model.removal.RemovalLaw` (no uncertainty: ``n``
        copies) or the :class:`~torlab.fit.result.FitResult` of
        :func:`torlab.fit.removal.fit_removal` (normal in its log parameters,
        ``meta["fit_space"]``).
    n
        Number of draws (0: the estimate only).
    layer, node_draws
        The layer the prediction draws (:meth:`~torlab.model.amount.AmountLayer.draw_nodes`).
        When it is the layer the removal was fitted with, each draw of the rates
        follows its layer draw through the fit's sensitivity to the layer
        (``theta = theta_hat + G (p_draw - p) + eps``, ``eps`` from the
        covariance without the layer part), so the two stay correlated as in the
        fit; otherwise the rates are drawn from their full covariance,
        independently of the layer.

    Returns
    -------
    dict
        ``order``, ``law`` (name), ``k``, ``spread`` and ``transfer`` (None when
        not fitted) as arrays of length ``max(n, 1)``; ``estimate`` the same
        for the estimate; ``correlated_with_layer``.
    """
    if isinstance(removal, RemovalLaw):
        est = {"k": removal.k, "spread": removal.spread, "transfer": None}
        rep = max(n, 1)
        return {"order": removal.order, "law": removal.name,
                "k": np.full(rep, removal.k), "spread": np.full(rep, removal.spread),
                "transfer": None, "estimate": est, "uncertain": False,
                "correlated_with_layer": False}
    meta = getattr(removal, "meta", None) or {}
    fs = meta.get("fit_space")
    if getattr(removal, "kind", "") != "removal" or not fs:
        raise TorlabInputError("removal must be a RemovalLaw or the result of "
                               "torlab.fit.removal.fit_removal")
    names = list(fs["names"])
    theta = np.asarray(fs["values"], dtype=float)
    cov = np.asarray(fs["covariance"], dtype=float)
    order = int(meta["order"])
    est_phys = {nm: math.exp(v) for nm, v in zip(names, theta, strict=True)}
    kname = f"k{order}"
    linked = False
    if n > 0:
        shift = np.zeros((n, theta.size))
        G = np.asarray(fs.get("layer_sensitivity", []), dtype=float)
        if layer is not None and node_draws is not None and G.size and \
                len(fs.get("layer_nodes_mg_m2", [])) == layer.nodes.size and np.allclose(
                    np.asarray(fs["layer_nodes_mg_m2"]) * MG_M2, layer.nodes, rtol=1e-9) and \
                G.shape == (theta.size, 4 * layer.nodes.size):
            allp = np.vstack([layer.dry_params, layer.params])
            dp = (node_draws - allp[None]).reshape(n, -1)
            shift = dp @ G.T
            cov = np.asarray(fs["covariance_without_layer"], dtype=float)
            linked = True
        w, v = np.linalg.eigh(0.5 * (cov + cov.T))
        L = v * np.sqrt(np.clip(w, 0.0, None))
        th = theta + shift + rng.standard_normal((n, theta.size)) @ L.T
    else:
        th = theta[None]
    phys = {nm: np.exp(th[:, i]) for i, nm in enumerate(names)}
    fixed = getattr(removal, "fixed", {}) or {}
    rep = th.shape[0]
    spread = phys.get("spread", np.full(rep, float(fixed.get("spread", 0.0))))
    transfer = phys.get("transfer")
    return {"order": order, "law": str(meta.get("law")), "k": phys[kname], "spread": spread,
            "transfer": transfer,
            "estimate": {"k": est_phys[kname],
                         "spread": est_phys.get("spread", float(fixed.get("spread", 0.0))),
                         "transfer": est_phys.get("transfer")},
            "uncertain": True, "correlated_with_layer": linked}


# ---------------------------------------------------------------------------------------------
# the retention prediction
# ---------------------------------------------------------------------------------------------
@dataclass
class RetentionPrediction:
    """Friction against passes after one application.

    Attributes
    ----------
    table
        DataFrame: ``passes``, ``amount_mg_m2``, ``mu``, ``mu_low95``,
        ``mu_high95`` (the retention table's contract columns), then ``energy_J_m2`` (dissipated per
        unit band area since the application) and ``time_s`` where a pass
        interval is known (a disc track at the scene's speed, or given).
    summary
        Key numbers for ``summary.json`` (crossings with intervals, law,
        amounts, what was modelled).
    modelled
        What the prediction modelled and what it left out.
    """

    table: Any
    summary: dict[str, Any]
    modelled: list[str]
    notes: list[str] = field(default_factory=list)


def _initial_amount(amount: Any, band: Band, *, band_length: float | None,
                    density: float | None, transfer: float) -> tuple[float, str]:
    """Areal density in the band [kg/m^2] of the applied amount, and how it was obtained."""
    from torlab.model.amount import parse_amount

    val, kind = amount if isinstance(amount, tuple) else parse_amount(amount)
    if kind == "mass_per_area":
        return areal_density((val, kind), transfer=transfer), "given per area"
    if band.area is not None:
        area, how = band.area, f"spread over the disc track (2 pi r x {band.width * 1e3:.3g} mm)"
    elif band_length is not None:
        from torlab.units import check_range

        if not (math.isfinite(band_length) and band_length > 0):
            raise TorlabInputError(f"band length must be positive, got {band_length}",
                                   key="band_length")
        check_range("band_length", band_length, where="band_length")
        area = band.width * band_length
        how = f"spread over {band_length:g} m of rail x {band.width * 1e3:.3g} mm band"
    else:
        raise TorlabInputError("an amount applied as a volume or mass on a rail needs the length "
                               "of rail it covers (band_length=), or give it per area (mg/m^2)",
                               key="amount")
    return areal_density((val, kind), area=area, density=density, transfer=transfer), how


def _applied(removal: Any, layer: Any, amount: Any, bnd: Any, n_draws: int, rng: Any, *,
             transfer: float | None, band_length: Any, density: Any, notes: list[str]
             ) -> tuple[Any, dict[str, Any], float, float, str]:
    """What one application puts into the band, and the parameter draws around it.

    The layer's node draws and the removal law's draws (:func:`removal_draws`); the
    transfer (given, else fitted, else the law's fixed one); the amount in the band
    (:func:`_initial_amount`, checked against the layer's tested range, a note in
    ``notes`` below it).

    Returns
    -------
    tuple
        ``(node draws or None, removal draws, transfer, areal density in the band
        [kg/m^2], how it was obtained)``.
    """
    node_draws = layer.draw_nodes(n_draws, rng) if n_draws > 0 else None
    rd = removal_draws(removal, n_draws, rng, layer=layer, node_draws=node_draws)
    est = rd["estimate"]
    tr = transfer if transfer is not None else (est["transfer"] if est["transfer"] is not None
                                                else _fixed_transfer(removal))
    m0, how = _initial_amount(amount, bnd, band_length=band_length, density=density, transfer=tr)
    layer.check(m0)
    notes += _below_tested(m0, layer)
    return node_draws, rd, tr, m0, how


def predict_retention(scene: Scene, layer: Any, removal: Any, amount: Any, *, creepage: float,  # noqa: C901 (each input form (file, fit, layer) and option checked where it is read)
                      track_radius: float | None = None, band_length: float | None = None,
                      density: float | None = None, transfer: float | None = None,
                      passes: Any = None, n_passes: float | None = None, points: int = 501,
                      band: tuple[float, float] = DEFAULT_BAND, confidence: float = 0.95,
                      n_draws: int = 200, seed: int = 0, per_interval: int = 6,
                      pass_interval: float | None = None, window: Any = None,
                      retentivity: Any = RETENTIVITY_BAND) -> RetentionPrediction:
    """Coefficient against passes after one application, with intervals (module docstring).

    Parameters
    ----------
    scene
        :class:`~torlab.scene.Scene`: contact, materials, speed (its ``boundary:``
        is replaced by the layer of the remaining amount; a ``lubricant:`` is
        not used).
    layer
        :class:`~torlab.model.amount.AmountLayer` of the product.
    removal
        :class:`~torlab.model.removal.RemovalLaw` or the removal fit's
        :class:`~torlab.fit.result.FitResult`.
    amount
        Applied amount: ``"4 uL"`` (with ``density``), ``"4 mg"`` or an areal
        density ``"30000 mg/m^2"``.
    creepage
        Creepage of the passes (fraction).
    track_radius
        Radius of a disc track [m]: a closed track, one pass per revolution;
        None for a rail (open track, one pass per axle).
    band_length
        Rail length [m] the applied volume or mass covers.
    density
        Product density [kg/m^3] for a volume.
    transfer
        Fraction of the applied product that reaches the band; default the
        removal fit's (fitted or fixed), else 1.
    passes, n_passes, points
        Passes to tabulate, or ``points`` passes from 0 to ``n_passes`` (default:
        until 1.2 x the passes to reach the dry anchor).
    band
        The coefficient band (default 0.15-0.25).
    confidence, n_draws, seed
        Interval level, parameter draws (0: no intervals), random seed.
    per_interval
        Friction-table nodes per interval between tested amounts.
    pass_interval
        Time between passes [s] on a rail, for a ``time_s`` column.
    window
        ``(first, last)`` passes of the effective friction level and the fraction of
        passes in the band (:func:`retention_metrics`); default the predicted range.
    retentivity
        ``"band"`` (default): passes until mu leaves the band; a fraction ``f``: passes
        until mu returns to ``f`` times the dry coefficient.

    Raises
    ------
    TorlabInputError
        Missing units, negative amount, an amount above the tested range, a
        volume without density, a rail amount without its length.
    """
    import pandas as pd

    from torlab.model.contact import build_contact

    if not (0 < band[0] < band[1]):
        raise TorlabInputError(f"band must be two increasing positive coefficients, got {band}",
                               key="band")
    if not (math.isfinite(creepage) and creepage != 0):
        raise TorlabInputError(f"creepage must be a non-zero number, got {creepage}",
                               key="creepage")
    rng = np.random.default_rng(seed)
    sc, left_out = boundary_scene(scene, layer.temperature_coefficients)
    notes: list[str] = []
    contact = build_contact(sc)
    bnd = band_of(contact, track_radius)
    F = float(contact.patch.F)
    c = F * abs(creepage) / bnd.width
    node_draws, rd, tr, m0, how = _applied(removal, layer, amount, bnd, n_draws, rng,
                                           transfer=transfer, band_length=band_length,
                                           density=density, notes=notes)
    est = rd["estimate"]
    m0_d = np.full(max(n_draws, 1), m0)
    if transfer is None and rd["transfer"] is not None:
        m0_d = m0 / tr * rd["transfer"]
        if layer.above == "error" and np.any(m0_d > layer.m_max):
            notes.append(f"{100 * np.mean(m0_d > layer.m_max):.0f} % of the transfer draws put "
                         "more product into the band than the largest tested amount; held at it")
            m0_d = np.minimum(m0_d, layer.m_max)
    table = mu_table(sc, layer, creepage, m_top=max(m0, float(np.max(m0_d))),
                     per_interval=per_interval, gradient=n_draws > 0, extra=[m0])
    curve = table.curve(0)
    central = passes_solution(curve, table.mu_dry[0], table.x[0], m0, rd["order"], est["k"],
                              est["spread"], c)
    nd = float(central.N_dry[0])
    if not math.isfinite(nd):
        notes.append("no removal (rate zero): the coefficient stays at its initial value")
    if passes is None:
        if n_passes is None:
            n_passes = 1000.0 if not math.isfinite(nd) else max(1.2 * nd, 10.0)
        passes = np.linspace(0.0, float(n_passes), int(points))
    Nq = np.asarray(passes, dtype=float)
    if Nq.ndim != 1 or Nq.size == 0 or not np.all(np.isfinite(Nq)) or np.any(Nq < 0):
        raise TorlabInputError("passes must be finite non-negative numbers", key="passes")
    m, mu, E = central.at(Nq)
    cols: dict[str, Any] = {"passes": Nq, "amount_mg_m2": m[:, 0] / MG_M2, "mu": mu[:, 0]}
    crossings: dict[str, Any] = {}
    levels = {"passes_to_enter_band": band[0], "passes_to_leave_band": band[1]}
    for key, lev in levels.items():
        Nc, mc = central.crossing(lev)
        crossings[key] = {"level": lev, "passes": _num(Nc[0]), "amount_mg_m2": _num(mc[0] / MG_M2),
                          "low95": None, "high95": None}
    if node_draws is not None:
        mu_nodes = table.draw_nodes(layer, node_draws)[:, 0, :]  # (n_x, D)
        dsol = passes_solution(table.curve(mu_nodes=mu_nodes), mu_nodes[0], table.x[0], m0_d,
                               rd["order"], rd["k"], rd["spread"], c)
        _, mud, _ = dsol.at(Nq)
        lo, hi = propagate_draws(mud, confidence=confidence, axis=1)
        cols["mu_low95"], cols["mu_high95"] = lo, hi
        for key, lev in levels.items():
            Nc, _ = dsol.crossing(lev)
            lo_c, hi_c = propagate_draws(Nc, confidence=confidence)
            crossings[key]["low95"], crossings[key]["high95"] = _num(lo_c), _num(hi_c)
            crossings[key]["never_fraction"] = float(np.mean(~np.isfinite(Nc)))
            crossings[key]["p_crosses"] = 1.0 - crossings[key]["never_fraction"]
    else:
        cols["mu_low95"] = cols["mu_high95"] = np.full(Nq.size, np.nan)
        notes.append("no parameter draws (n_draws=0): no intervals")
    metrics = retention_metrics(central, dsol if node_draws is not None else None,
                                table.mu_dry[0], mu_nodes[0] if node_draws is not None else None,
                                band, window=window if window is not None else
                                (0.0, float(Nq.max())), retentivity=retentivity,
                                confidence=confidence)
    cols["energy_J_m2"] = E[:, 0]
    dt = bnd.pass_interval(sc.kinematics.speed) if pass_interval is None else float(pass_interval)
    if dt is not None:
        cols["time_s"] = Nq * dt
    out = pd.DataFrame(cols)
    above_band = bool(mu[0, 0] > band[1])
    for key, cr in crossings.items():
        if key == "passes_to_enter_band" and cr["passes"] == 0.0:
            cr["above_band_at_application"] = above_band
        cr["status"] = _crossing_status(cr, layer, key)
    modelled = [f"Hertz contact ({contact.patch.method}), band width 2b = {bnd.width * 1e3:.4g} mm"
                f" ({bnd.kind}{'' if bnd.track_length is None else f', track {bnd.track_length * 1e3:.4g} mm'})",
                "boundary friction: FASTSIM with the layer of the remaining amount (HPT amount "
                "series, PCHIP in log amount)",
                f"removal: {rd['law']} in the frictional energy per unit band area "
                f"(e_pass = mu F |xi| / w = {c:.4g} mu J/m^2 per pass)",
                *left_out, *notes]
    if scene.thermal is None:
        modelled.append("contact temperature: not modelled (no thermal: section)")
    summary = {
        "scene": getattr(scene, "name", ""),
        "creepage": float(creepage),
        "band": list(band),
        "running_band": {"kind": bnd.kind, "width_m": bnd.width, "track_length_m": bnd.track_length},
        "applied": amount if isinstance(amount, str) else f"{amount[0]:g} ({amount[1]})",
        "transfer": tr,
        "initial_amount_mg_m2": m0 / MG_M2,
        "initial_amount_from": how,
        "tested_amounts_mg_m2": [float(v) / MG_M2 for v in layer.amounts],
        "dry_anchor_mg_m2": layer.dry_amount / MG_M2,
        "law": rd["law"],
        "law_parameters": {f"k{rd['order']}": est["k"], "spread": est["spread"]},
        "mu_initial": float(mu[0, 0]),
        "mu_dry": float(table.mu_dry[0]),
        "energy_per_pass_initial_J_m2": float(energy_per_pass(mu[0, 0], F, creepage, bnd.width)),
        "passes_to_dry_anchor": _num(central.N_dry[0]),
        **crossings,
        "retention_metrics": metrics,
        "confidence": confidence,
        "n_draws": int(n_draws),
        "uncertainty": ("parameter draws: layer (each tested amount's fit; boundary model "
                        "linearised at the nodes) and removal law (normal in its log parameters"
                        + (", following each layer draw through the fit's sensitivity to the "
                           "layer)" if rd["correlated_with_layer"] else ", independent of the "
                           "layer draws)"))
        if n_draws > 0 else "none",
        "modelled": modelled,
        "notes": list(notes),
        "layer_notes": list(layer.notes),
        "friction_evaluations": int(table.n_evaluations),
    }
    return RetentionPrediction(table=out, summary=summary, modelled=modelled, notes=notes)


def retention_metrics(central: Any, draws: Any, mu_dry: float, mu_dry_draws: Any,
                      band: tuple[float, float], *, window: tuple[float, float],
                      retentivity: Any = RETENTIVITY_BAND, confidence: float = 0.95,
                      n_grid: int = 2001) -> dict[str, Any]:
    """The retention figures labs report (EN 15427-2-1 Annex H; CEN/TS 15427-2-2), each with
    its interval from the parameter draws.

    * **effective friction level**: the mean coefficient over the window of passes
      (trapezoidal mean on ``n_grid`` passes);
    * **retentivity**: passes until the coefficient leaves the band (rises above its
      upper bound; ``retentivity="band"``), or until it returns to a fraction ``f`` of the
      dry coefficient (``retentivity=f``, each draw with its own dry coefficient); infinite
      where it never does within the model (no removal), reported as never;
    * **fraction of passes in the band** over the window.

    Parameters
    ----------
    central, draws
        :class:`~torlab.model.removal.PassesSolution` at the estimate and of the draws
        (None: no intervals).
    mu_dry, mu_dry_draws
        Dry coefficient at the estimate and per draw.
    band
        ``(low, high)``.
    window
        ``(first, last)`` passes.
    retentivity, confidence, n_grid
        As above; interval level; passes of the window's grid.

    Returns
    -------
    dict
        ``effective_friction``, ``retentivity``, ``fraction_in_band``: each ``value``,
        ``low95``, ``high95`` (None without draws or where infinite); the retentivity's
        ``definition``, ``level`` and ``p_reached`` (share of draws where it happens);
        ``window_passes``; ``holds``.

    Raises
    ------
    TorlabInputError
        A window that is not two increasing non-negative numbers, a fraction of dry
        outside (0, 1].
    """
    a, b = (float(v) for v in window)
    if not (0 <= a < b and math.isfinite(b)):
        raise TorlabInputError(f"window must be two increasing non-negative pass counts, got "
                               f"{a:g}:{b:g}", key="window")
    grid = np.linspace(a, b, int(n_grid))

    def stats(sol: Any) -> tuple[np.ndarray, np.ndarray]:
        _, mu, _ = sol.at(grid)                      # (n_grid, D)
        eff = np.trapezoid(mu, grid, axis=0) / (b - a)
        inside = ((mu >= band[0]) & (mu <= band[1])).astype(float)
        frac = np.trapezoid(inside, grid, axis=0) / (b - a)
        return eff, frac

    if retentivity == RETENTIVITY_BAND or retentivity is None:
        level, level_d = band[1], band[1]
        definition = f"passes until mu leaves the band (rises above {band[1]:g})"
    else:
        f = float(retentivity)
        if not (0 < f <= 1):
            raise TorlabInputError(f"retentivity: a fraction of the dry coefficient in (0, 1], "
                                   f"got {f:g}", key="retentivity")
        level = f * float(mu_dry)
        level_d = f * np.asarray(mu_dry_draws, dtype=float) if mu_dry_draws is not None \
            else level
        definition = f"passes until mu returns to {f:g} of dry ({level:.4g})"
    eff0, frac0 = stats(central)
    ret0 = float(central.crossing(level)[0][0])

    def entry(v: float, d: Any = None, log: bool = False) -> dict[str, Any]:
        e: dict[str, Any] = {"value": _num(v), "low95": None, "high95": None}
        if d is not None:
            lo, hi = propagate_draws(np.asarray(d, dtype=float), confidence=confidence)
            e["low95"], e["high95"] = _num(lo), _num(hi)
        return e

    out: dict[str, Any] = {
        "effective_friction": entry(float(eff0[0])),
        "retentivity": {**entry(ret0), "definition": definition, "level": float(level)},
        "fraction_in_band": entry(float(frac0[0])),
        "window_passes": [a, b], "band": list(band), "confidence": confidence,
        "holds": ("the parameter draws of the layer and the removal law (the fits' "
                  "uncertainty, the scatter between runs where a fit pooled repeats)")
        if draws is not None else "the estimate alone (no parameter draws)"}
    if draws is not None:
        eff, frac = stats(draws)
        Nc, _ = draws.crossing(level_d)
        out["effective_friction"] = entry(float(eff0[0]), eff)
        out["fraction_in_band"] = entry(float(frac0[0]), frac)
        out["retentivity"].update(entry(ret0, Nc))
        out["retentivity"]["p_reached"] = float(np.mean(np.isfinite(Nc)))
    if not math.isfinite(ret0):
        out["retentivity"]["note"] = "never within the model (no removal, or dry below the level)"
    return out


def _below_tested(m0: float, layer: Any) -> list[str]:
    """A note when the applied amount lies below the smallest tested amount, or above the
    largest where the layer holds its last fit (``above="hold"``)."""
    if m0 > layer.m_max * (1 + 1e-12):
        return [f"initial amount {m0 / MG_M2:.4g} mg/m^2 is above the largest tested amount "
                f"{layer.m_max / MG_M2:.4g} mg/m^2 of the HPT series: the layer of that amount is "
                "held above it (not known there; test a larger amount)"]
    if m0 >= layer.m_min:
        return []
    where = ("at or below the dry anchor: the dry coefficient from the first pass"
             if m0 <= layer.dry_amount else "between the dry anchor and the smallest tested "
             "amount, where the layer is the assumed interpolation to the dry fit")
    return [f"initial amount {m0 / MG_M2:.4g} mg/m^2 is below the smallest tested amount "
            f"{layer.m_min / MG_M2:.4g} mg/m^2 of the HPT series: {where} (apply more, or "
            "test smaller amounts)"]


def _fixed_transfer(removal: Any) -> float:
    fixed = getattr(removal, "fixed", None) or {}
    return float(fixed.get("transfer", 1.0))


def _num(v: Any) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def _crossing_status(cr: dict[str, Any], layer: Any, key: str) -> str:
    """What the crossing is and where the data stop supporting it.  With parameter draws a
    crossing (or "never") is stated only when the draws agree with probability
    :data:`CROSSING_PROBABILITY`; otherwise it is undetermined, with the probability."""
    p = cr.get("p_crosses")
    if p is not None and ((cr["passes"] is None and 1 - p < CROSSING_PROBABILITY)
                          or (cr["passes"] not in (None, 0.0) and p < CROSSING_PROBABILITY)):
        return (f"undetermined: the coefficient crosses this limit in {100 * p:.0f} % of the "
                f"parameter draws (a verdict needs {100 * CROSSING_PROBABILITY:.0f} %)")
    if cr["passes"] is None:
        return ("never: the coefficient stays below the band" if key == "passes_to_enter_band"
                else "never: the coefficient stays below the band's upper limit")
    if cr["passes"] == 0.0:
        if cr.get("above_band_at_application"):
            return ("never in the band: the coefficient at the application is already above "
                    "the band's upper limit")
        return ("in the band from the application on" if key == "passes_to_enter_band"
                else "above the band from the application on")
    s = "crosses"
    if cr["amount_mg_m2"] is not None and cr["amount_mg_m2"] * MG_M2 < layer.m_min:
        s += (" below the smallest tested amount: the passes depend on the assumed dry anchor "
              f"({layer.dry_amount / MG_M2:.4g} mg/m^2)")
    if cr.get("high95") is None and cr.get("low95") is not None:
        s += "; the upper bound is open (some draws never cross)"
    return s


# ---------------------------------------------------------------------------------------------
# a slip sweep as it is measured
# ---------------------------------------------------------------------------------------------
@dataclass
class SweepPrediction:
    """A traction curve recorded while the product is removed, beside the steady one.

    Attributes
    ----------
    table
        ``time_s``, ``creepage``, ``mu_sweep`` (the measured-looking curve),
        ``mu_steady`` (at the applied amount), ``amount_mg_m2``; with parameter
        draws also ``mu_sweep_low95``, ``mu_sweep_high95``, ``mu_steady_low95``,
        ``mu_steady_high95`` (quantiles of the draws).
    trend_sweep, trend_steady
        :func:`~torlab.model.prediction.classify_trend` of both curves.
    verdict
        One sentence: does removal turn a neutral steady curve positive?
    probability_positive
        Fraction of parameter draws whose sweep is classified positive (None
        without draws).
    summary
        Key numbers.
    """

    table: Any
    trend_sweep: dict[str, Any]
    trend_steady: dict[str, Any]
    verdict: str
    probability_positive: float | None
    summary: dict[str, Any]


def _interp_table(mu_tab: np.ndarray, x_nodes: np.ndarray, xi_nodes: np.ndarray, x: np.ndarray,
                  xi: float) -> np.ndarray:
    """Bilinear ``mu`` of each draw: table ``(n_x, n_xi, D)``, ``x`` (D,), one creepage."""
    j = int(np.clip(np.searchsorted(xi_nodes, xi) - 1, 0, xi_nodes.size - 2))
    f = (xi - xi_nodes[j]) / (xi_nodes[j + 1] - xi_nodes[j])
    f = min(max(f, 0.0), 1.0)
    col = mu_tab[:, j, :] * (1.0 - f) + mu_tab[:, j + 1, :] * f  # (n_x, D)
    xc = np.clip(x, x_nodes[0], x_nodes[-1])
    i = np.clip(np.searchsorted(x_nodes, xc) - 1, 0, x_nodes.size - 2)
    g = (xc - x_nodes[i]) / (x_nodes[i + 1] - x_nodes[i])
    d = np.arange(col.shape[1])
    return col[i, d] * (1.0 - g) + col[i + 1, d] * g


def simulate_sweep(scene: Scene, layer: Any, removal: Any, amount: Any, *,
                   creepage: tuple[float, float] = (0.0, 0.05), seconds: float,
                   track_radius: float | None = None, pass_interval: float | None = None,
                   band_length: float | None = None, density: float | None = None,
                   transfer: float | None = None, points: int = 101, n_draws: int = 100,
                   seed: int = 0, trend_tolerance: float = 0.01, per_interval: int = 6,
                   trend_probability: float | None = None) -> SweepPrediction:
    """A traction curve measured while the creepage ramps over ``seconds`` (thesis H4.1).

    The creepage rises linearly from ``creepage[0]`` to ``creepage[1]`` in
    ``seconds``; the product is removed meanwhile by the law, driven by the
    energy of each pass at the current creepage:
    ``dm/dt = -(g(m) e_pass(m, xi(t)) + s m) / T_pass`` with
    ``e_pass = mu(m, xi) F xi / w`` and ``T_pass`` the time between passes of
    a band point (a disc track's circumference over the speed, or
    ``pass_interval``).  Integrated with an adaptive Runge-Kutta method
    (``solve_ivp``, RK45, step control on all parameter draws at once) on a
    table of ``mu(m, xi)`` (bilinear in ``ln m`` and the creepage).  The steady
    curve is the coefficient at the applied amount.  Both trends are
    classified by :func:`torlab.model.prediction.classify_trend`.

    With parameter draws (``n_draws > 0``) each curve's class and the verdict
    are called only when their probability over the draws reaches
    ``trend_probability`` (:data:`~torlab.model.prediction.TREND_PROBABILITY`,
    0.9); otherwise they are ``undetermined`` and the probabilities are given.
    Without draws they are the classes of the curves at the estimate, and the
    verdict says so.

    Raises
    ------
    TorlabInputError
        No pass interval (neither a disc track nor ``pass_interval``), a
        non-positive duration, and the amount errors of :func:`predict_retention`.
    """
    import pandas as pd
    from scipy.integrate import solve_ivp

    from torlab.model.contact import build_contact
    from torlab.model.prediction import NOT_SATURATED, TREND_PROBABILITY, classify_trend

    thr = TREND_PROBABILITY if trend_probability is None else float(trend_probability)

    if not (math.isfinite(seconds) and seconds > 0):
        raise TorlabInputError(f"sweep duration must be positive, got {seconds}", key="seconds")
    xi0, xi1 = (float(v) for v in creepage)
    if not (0 <= xi0 < xi1):
        raise TorlabInputError(f"creepage range must rise from >= 0, got {creepage}",
                               key="creepage")
    rng = np.random.default_rng(seed)
    sc, left_out = boundary_scene(scene, layer.temperature_coefficients)
    notes: list[str] = []
    contact = build_contact(sc)
    bnd = band_of(contact, track_radius)
    T_pass = bnd.pass_interval(sc.kinematics.speed) if pass_interval is None else float(pass_interval)
    if T_pass is None or not (math.isfinite(T_pass) and T_pass > 0):
        raise TorlabInputError("a sweep needs the time between passes: a disc track "
                               "(track_radius=) at the scene's speed, or pass_interval=",
                               key="pass_interval")
    F = float(contact.patch.F)
    node_draws, rd, tr, m0, how = _applied(removal, layer, amount, bnd, n_draws, rng,
                                           transfer=transfer, band_length=band_length,
                                           density=density, notes=notes)
    est = rd["estimate"]
    xi_nodes = np.linspace(xi0, xi1, max(int(points), 3))
    table = mu_table(sc, layer, xi_nodes, m_top=m0, per_interval=per_interval,
                     gradient=n_draws > 0, extra=[m0])
    xn = table.x
    D = max(n_draws, 1) if n_draws > 0 else 0
    tabs = [table.mu[:, :, None]]
    ks, ss, m0s = [np.array([est["k"]])], [np.array([est["spread"]])], [np.array([m0])]
    if node_draws is not None:
        tabs.append(table.draw_nodes(layer, node_draws))
        ks.append(rd["k"])
        ss.append(rd["spread"])
        m0d = np.full(n_draws, m0) if transfer is not None or rd["transfer"] is None \
            else np.minimum(m0 / tr * rd["transfer"], table.m_max)
        m0s.append(m0d)
    tab = np.concatenate(tabs, axis=2)           # (n_x, n_xi, 1 + D)
    k = np.concatenate(ks)
    s = np.concatenate(ss)
    m_init = np.concatenate(m0s)
    order = rd["order"]
    w = bnd.width

    def xi_of(t: float) -> float:
        return xi0 + (xi1 - xi0) * min(max(t / seconds, 0.0), 1.0)

    def rhs(t: float, m: np.ndarray) -> np.ndarray:
        mm = np.maximum(m, 0.0)
        xi = xi_of(t)
        mu = _interp_table(tab, xn, xi_nodes, np.log(np.maximum(mm, 1e-300)), xi)
        e = mu * F * xi / w
        g = k * (mm if order == 1 else (mm > 0))
        return -(g * e + s * mm) / T_pass

    t_eval = np.linspace(0.0, seconds, xi_nodes.size)
    sol = solve_ivp(rhs, (0.0, seconds), m_init, method="RK45", t_eval=t_eval, rtol=1e-7,
                    atol=1e-9 * float(np.max(m_init)) + 1e-300)
    if not sol.success:
        from torlab.errors import ConvergenceError

        raise ConvergenceError(f"sweep integration failed: {sol.message}")
    mt = np.maximum(sol.y, 0.0)                   # (1 + D, n_t)
    xi_t = np.array([xi_of(t) for t in t_eval])
    mu_sweep = np.array([_interp_table(tab, xn, xi_nodes, np.log(np.maximum(mt[:, i], 1e-300)),
                                       xi_t[i]) for i in range(t_eval.size)])  # (n_t, 1 + D)
    steady = np.array([_interp_table(tab, xn, xi_nodes, np.log(m_init), xi_t[i])
                       for i in range(t_eval.size)])
    trend_sweep = classify_trend(xi_t, mu_sweep[:, 0], tolerance=trend_tolerance)
    trend_steady = classify_trend(xi_t, steady[:, 0], tolerance=trend_tolerance)
    p_pos = p_made = None
    p_steady = p_sweep = None
    joint: dict[str, float] = {}
    if D:
        sw = [classify_trend(xi_t, mu_sweep[:, 1 + d], tolerance=trend_tolerance)["trend"]
              for d in range(D)]
        st = [classify_trend(xi_t, steady[:, 1 + d], tolerance=trend_tolerance)["trend"]
              for d in range(D)]
        p_pos = float(np.mean([x == "positive" for x in sw]))
        # the H4.1 case in one draw: the recorded curve positive, the steady one not
        p_made = float(np.mean([a == "positive" and b in ("neutral", "negative")
                                for a, b in zip(sw, st, strict=True)]))
        p_steady = {c: float(np.mean([x == c for x in st])) for c in sorted(set(st))}
        p_sweep = {c: float(np.mean([x == c for x in sw])) for c in sorted(set(sw))}
        joint = {"made_by_removal": p_made,
                 "both_positive": float(np.mean([a == b == "positive" for a, b in
                                                 zip(sw, st, strict=True)])),
                 "never_levels_off": float(np.mean([a == NOT_SATURATED != b for a, b in
                                                    zip(sw, st, strict=True)])),
                 "not_positive": float(np.mean([a != "positive" for a in sw]))}
        for tr, pr in ((trend_sweep, p_sweep), (trend_steady, p_steady)):
            best = max(pr, key=pr.get)
            tr.update(probabilities=pr, probability_threshold=thr,
                      trend=best if pr[best] >= thr else "undetermined",
                      basis=f"the classes of {D} parameter draws")
    verdict = _sweep_verdict(trend_sweep["trend_point"], trend_steady["trend_point"], p_pos,
                             joint, thr)
    cols = {"time_s": t_eval, "creepage": xi_t, "mu_sweep": mu_sweep[:, 0],
            "mu_steady": steady[:, 0], "amount_mg_m2": mt[0] / MG_M2}
    if D:
        for name, arr in (("mu_sweep", mu_sweep), ("mu_steady", steady)):
            lo, hi = propagate_draws(arr[:, 1:], axis=1)
            cols[f"{name}_low95"], cols[f"{name}_high95"] = lo, hi
    out = pd.DataFrame(cols)
    summary = {
        "scene": getattr(scene, "name", ""), "seconds": float(seconds),
        "creepage_range": [xi0, xi1], "pass_interval_s": T_pass,
        "passes_during_sweep": float(seconds / T_pass),
        "initial_amount_mg_m2": m0 / MG_M2, "initial_amount_from": how,
        "final_amount_mg_m2": float(mt[0, -1] / MG_M2), "law": rd["law"],
        "trend_sweep": trend_sweep, "trend_steady": trend_steady,
        "probability_sweep_positive": p_pos,
        "probability_positive_by_removal": p_made,
        "sweep_trend_probabilities": p_sweep, "steady_trend_probabilities": p_steady,
        "verdict": verdict, "verdict_probabilities": joint or None,
        "probability_threshold": thr, "n_draws": int(n_draws), "notes": notes,
        "modelled": ["boundary friction: FASTSIM with the layer of the remaining amount",
                     f"removal: {rd['law']} in the frictional energy of each pass at the "
                     "current creepage", *left_out],
        "integrator": f"RK45 with step control, {sol.nfev} right-hand-side evaluations",
    }
    return SweepPrediction(table=out, trend_sweep=trend_sweep, trend_steady=trend_steady,
                           verdict=verdict, probability_positive=p_pos, summary=summary)


def _sweep_verdict(sweep: str, steady: str, p_pos: float | None,
                   joint: dict[str, float] | None = None, threshold: float = 0.9) -> str:
    """The sweep's verdict in one sentence.  With draws (``joint``: the probability of each
    outcome over them) an outcome is called only at ``threshold``; without, the classes of
    the curves at the estimate (``sweep``, ``steady``) are used and the sentence says so."""
    from torlab.model.prediction import NOT_SATURATED

    if joint:
        pm, pb, pn, pnp = (joint["made_by_removal"], joint["both_positive"],
                           joint["never_levels_off"], joint["not_positive"])
        if pm >= threshold:
            return (f"the measured-looking curve turns positive while the steady curve at the "
                    f"applied amount is neutral or negative in {100 * pm:.0f} % of the parameter "
                    "draws: the positive trend is made by the removal of product during the "
                    "sweep (thesis H4.1)")
        if pb >= threshold:
            return (f"both curves are positive in {100 * pb:.0f} % of the parameter draws: the "
                    "steady curve is positive without removal")
        if pn >= threshold:
            return (f"the measured-looking curve never levels off in {100 * pn:.0f} % of the "
                    "parameter draws: the removal during the sweep outpaces the saturation of "
                    "the traction")
        if pnp >= threshold:
            return (f"the measured-looking curve is not positive in {100 * pnp:.0f} % of the "
                    "parameter draws: removal during this sweep does not make a positive trend")
        return (f"undetermined: no outcome reaches probability {threshold:g} over the parameter "
                f"draws (positive by removal {pm:.2f}, recorded curve positive "
                f"{p_pos if p_pos is not None else float('nan'):.2f}, both positive {pb:.2f}, "
                f"never levels off {pn:.2f}); at the estimate the recorded curve is {sweep} and "
                f"the steady one {steady}")
    prob = "" if p_pos is None else f" (positive in {100 * p_pos:.0f} % of the parameter draws)"
    if p_pos is None:
        prob = " (the curves at the estimate, without parameter draws)"
    if sweep == "positive" and steady in ("neutral", "negative"):
        return (f"the measured-looking curve turns positive{prob} while the steady curve at the "
                f"applied amount is {steady}: the positive trend is made by the removal of product "
                "during the sweep (thesis H4.1)")
    if sweep == "positive" and steady == "positive":
        return f"both curves are positive{prob}: the steady curve is positive without removal"
    if sweep == NOT_SATURATED and steady != NOT_SATURATED:
        return (f"the measured-looking curve never levels off{prob}: the removal during the "
                f"sweep outpaces the saturation of the traction (the steady curve is {steady})")
    return (f"the measured-looking curve is {sweep}{prob} and the steady curve {steady}: removal "
            "during this sweep does not make a positive trend")
