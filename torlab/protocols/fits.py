"""The fit stage of a protocol: the ``fits:`` section's parameter sets.

* ``fits.hpt_layers``: per product (and condition) the third-body layer from
  its HPT runs at the amounts and temperature asked for
  (:func:`torlab.fit.layer.fit_layer_hpt`, several runs fitted jointly), and
  the temperature coefficients from its runs at other temperatures
  (:func:`torlab.fit.temperature.fit_temperature_coefficients`) -> ``hpt:<product>``;
* ``fits.traction_layers``: the layer from a measured traction test, fitted as
  ``torlab fit traction`` fits it (:func:`torlab.fit.traction.fit_traction_test`)
  -> ``traction:<name>``;
* ``fits.lubricants``: a viscosity law from viscometer falls
  (:func:`torlab.fit.viscosity.fit_viscosity`) -> ``lubricant:<name>``.

Every fit is cached on the cache keys of the reductions it uses.
"""

from __future__ import annotations

import math
from typing import Any

from torlab.errors import TorlabInputError
from torlab.protocols.context import RunContext, add_covariance, finite

__all__ = ["fit_all"]

#: what the fit tasks use of the run's prepared modules (:meth:`torlab.parallel.Executor.map`):
#: the optimiser and the fits' own modules, not matplotlib (loaded meanwhile, for the figures)
_FITS_USE = ("scipy.optimize", "torlab.fit.layer", "torlab.fit.temperature")


def fit_all(ctx: RunContext) -> None:
    """Fit every parameter set the protocol asks for, in order."""
    f = ctx.p.fits
    if f.hpt_layers is not None:
        fit_hpt_layers(ctx)
    for t in f.traction_layers:
        fit_traction_layer(ctx, t)
    for lf in f.lubricants:
        fit_lubricant(ctx, lf)


def _hpt_groups(ctx: RunContext, cfg: Any) -> tuple[dict[str, list[Any]],
                                                    dict[int, float | None], set[int]]:
    """Product label -> its HPT runs (reductions), restricted to ``cfg.products``; and, by
    ``id`` of the run, its temperature [°C] and whether its applied amount is one of
    ``cfg``'s.  Each run's header is read once (a campaign's runs are kept packed,
    restored when read: :class:`torlab.protocols.data.PackedReduction`)."""
    groups: dict[str, list[Any]] = {}
    temp_of: dict[int, float | None] = {}
    amount_ok: set[int] = set()
    for r in ctx.reductions.get("hpt", []):
        m = r.meta
        label = m.product + (f"-{m.condition}" if m.condition else "")
        if cfg.products and label not in cfg.products and m.product not in cfg.products:
            continue
        groups.setdefault(label, []).append(r)
        temp_of[id(r)] = m.temperature
        if _amount_ok(cfg, m):
            amount_ok.add(id(r))
    if not groups:
        raise TorlabInputError("fits.hpt_layers: no HPT run of the listed products",
                               key="fits.hpt_layers.products")
    _distinct_file_names(groups)
    return groups, temp_of, amount_ok


def _distinct_file_names(groups: dict[str, list[Any]]) -> None:
    """Refuse, before any fit, two products whose parameter files would be one
    (``OFM 1`` and ``OFM_1`` both make ``fits/hpt_OFM_1.yaml``): one product's file would
    silently carry the other's layer."""
    from torlab.files import safe_name
    from torlab.protocols.loader import name_key

    seen: dict[str, str] = {}
    for label in sorted(groups):
        k = name_key(f"hpt_{label}")
        if k in seen:
            r = groups[label][0]
            raise TorlabInputError(
                f"products {seen[k]!r} and {label!r} would write one parameter file "
                f"(fits/{safe_name(f'hpt_{label}')}.yaml) and one figure: name them so that "
                "they differ in letters or digits", path=r.meta.source,
                line=r.meta.lines.get("product") or None, key="product")
        seen[k] = label


def _amount_ok(cfg: Any, m: Any) -> bool:
    if m.applied_amount is None:
        return True
    return any(kind == m.applied_amount_kind and math.isclose(v, m.applied_amount, rel_tol=1e-6)
               for kind, v in cfg.amounts)


def fit_hpt_layers(ctx: RunContext) -> None:
    """``hpt:<product>`` parameter sets (layer and temperature coefficients).

    The products' layer fits, then their temperature fits, run on the run's executor.
    """
    cfg = ctx.p.fits.hpt_layers
    groups, temp_of, amount_ok = _hpt_groups(ctx, cfg)
    plan = []  # (label, runs at the temperature, runs at other temperatures)
    for label in sorted(groups):
        runs = [r for r in groups[label] if id(r) in amount_ok]
        at_t = [r for r in runs if temp_of[id(r)] is None
                or abs(temp_of[id(r)] - cfg.temperature) <= cfg.temperature_tolerance]
        if not at_t:
            ctx.notes.append(f"fits.hpt_layers: {label} has no run at the listed amounts "
                             f"and {cfg.temperature:g} °C; no layer fitted")
            continue
        if len(at_t) > 1 and not cfg.joint:
            raise TorlabInputError(
                f"{label}: {len(at_t)} runs match the amounts and temperature "
                f"({', '.join(r.label for r in at_t)}); set joint: true to "
                "fit them together, or list one amount", key="fits.hpt_layers.amounts")
        chosen = {id(r) for r in at_t}
        others = [r for r in runs if id(r) not in chosen and temp_of[id(r)] is not None]
        plan.append((label, at_t, others))
    temp_jobs = []
    for label, at_t, others in plan:
        if cfg.temperature_coefficients and others:
            # every run of the layer's amounts: those at the fit temperature (all of them
            # when fitted jointly: repeats) and those at the other temperatures
            curves = at_t + sorted(others, key=lambda r: temp_of[id(r)])
            temps_K = [t + 273.15 if (t := temp_of[id(c)]) is not None
                       else cfg.temperature + 273.15 for c in curves]
            temp_jobs.append((label, ({"runs": [ctx.keys[id(c)] for c in curves],
                                       "temps": temps_K, "selection": cfg.selection},
                                      ("temperature", ([ctx.task_arg(c) for c in curves],
                                                       temps_K, cfg.selection)))))
        elif cfg.temperature_coefficients and any("thermal" in sd for sd in ctx.lp.scenes.values()):
            ctx.notes.append(f"fits.hpt_layers: {label} has no run at another temperature: its "
                             "temperature coefficients are not measured (the scene's values "
                             "are used as exact)")
    # the law is part of a job's key only where it is not the default (the keys of the
    # default law's fits are as they always were)
    law = {} if cfg.law == "voce" else {"law": cfg.law}
    layer_jobs = [({"runs": [ctx.keys[id(r)] for r in at_t], **law},
                   ("layer", ([ctx.task_arg(r) for r in at_t], cfg.law) if law else
                    [ctx.task_arg(r) for r in at_t]))
                  for _, at_t, _ in plan]
    if cfg.law == "auto" and temp_jobs:
        # every law is fitted and one chosen per product: its temperature runs are fitted
        # with the chosen law, after the layer fits
        layers = ctx.cached_map(["fit_hpt"] * len(layer_jobs), _fit_task, layer_jobs,
                                "fits: HPT layers", uses=_FITS_USE,
                                keep=lambda i, v: ctx.keep_fit(v, "fit_hpt", layer_jobs[i][0]))
        chosen = {lab: r.meta.get("law", "voce") for (lab, _, _), r in
                  zip(plan, layers, strict=True)}
        temp_jobs = [(lab, ({**key, "law": chosen[lab]}, ("temperature", (*arg[:3],
                                                                          chosen[lab]))))
                     for lab, (key, (_, arg)) in temp_jobs]
        res = ctx.cached_map(["fit_temperature"] * len(temp_jobs), _fit_task,
                             [j for _, j in temp_jobs], "fits: temperature coefficients",
                             uses=_FITS_USE)
        temps = dict(zip([lab for lab, _ in temp_jobs], res, strict=True))
    else:
        # a product with a temperature series: one task fits its layer and its series, the
        # runs at the fit temperature once for both (fit_layer_hpt_runs), and fills both
        # cache entries (the layer's is also the one the retention section looks for); the
        # longer tasks first, so that no worker waits at the end
        if law:
            temp_jobs = [(lab, ({**key, **law}, ("temperature", (*arg, cfg.law))))
                         for lab, (key, (_, arg)) in temp_jobs]
        index = {lab: n for n, (lab, _, _) in enumerate(plan)}
        both = [(tkey, ("both", (len(plan[index[lab]][1]), *targ)))
                for lab, (tkey, (_, targ)) in temp_jobs]
        alone = sorted(set(range(len(plan))) - {index[lab] for lab, _ in temp_jobs})
        parts = [layer_jobs[index[lab]][0] for lab, _ in temp_jobs] + \
            [layer_jobs[n][0] for n in alone]

        def keep(i: int, v: Any) -> Any:  # a layer kept without its data (in the cache)
            if i < len(both):
                return v[0], ctx.keep_fit(v[1], "fit_hpt", parts[i])
            return ctx.keep_fit(v, "fit_hpt", parts[i])

        res = ctx.cached_map(["fit_temperature"] * len(both) + ["fit_hpt"] * len(alone),
                             _fit_task, both + [layer_jobs[n] for n in alone],
                             "fits: HPT layers and temperature coefficients", uses=_FITS_USE,
                             also=[("fit_hpt", p) for p in parts[:len(both)]]
                             + [None] * len(alone), keep=keep)
        temps, layers = {}, [None] * len(plan)
        for (lab, _), (series, layer) in zip(temp_jobs, res[:len(both)], strict=True):
            temps[lab], layers[index[lab]] = series, layer
        for n, layer in zip(alone, res[len(both):], strict=True):
            layers[n] = layer
    for (label, _, _), res in zip(plan, layers, strict=True):
        scene_dict = res.to_scene_dict()
        if label in temps:
            _temperature(ctx, label, temps[label], scene_dict)
        ctx.add_fit(f"hpt:{label}", res, scene_dict)


def _fit_task(job: tuple[str, Any]) -> Any:
    """One product's HPT layer fit (``("layer", details)`` or ``("layer", (details,
    law))``), temperature coefficients (``("temperature", (details, temperatures_K,
    selection[, law]))``), or both (``("both", (k, details, ...))``: the layer of the first
    ``k`` runs and the series of all, returned as ``(series, layer)``): an executor task."""
    from torlab.fit.layer import fit_layer_hpt
    from torlab.instruments.measured import hpt_curves
    from torlab.protocols.data import detail

    what, arg = job
    if what == "both":  # (runs at the fit temperature, details, temperatures_K, selection[, law])
        from torlab.fit.layer import fit_layer_hpt_runs
        from torlab.fit.temperature import fit_temperature_coefficients

        k, details, temps_K, selection, *law = arg
        curves = hpt_curves([detail(x) for x in details])
        lw = law[0] if law else None
        layer, runs = fit_layer_hpt_runs(curves[:k], law=lw)
        series = fit_temperature_coefficients((runs if runs is not None else curves[:k])
                                              + curves[k:], temps_K, selection=selection,
                                              law=lw)
        return series, layer
    if what == "layer":
        if isinstance(arg, tuple):
            return fit_layer_hpt(hpt_curves([detail(x) for x in arg[0]]), law=arg[1])
        return fit_layer_hpt(hpt_curves([detail(x) for x in arg]))
    from torlab.fit.temperature import fit_temperature_coefficients

    details, temps_K, selection, *law = arg
    return fit_temperature_coefficients(hpt_curves([detail(x) for x in details]), temps_K,
                                        selection=selection, law=law[0] if law else None)


def _temperature(ctx: RunContext, label: str, tres: Any, scene_dict: dict[str, Any]) -> None:
    """Temperature coefficients of a product's layer, merged into its scene dict."""
    from torlab.model.layers import get_law

    tb = tres.to_scene_dict().get("boundary", {})
    scene_dict.setdefault("boundary", {}).update(
        {k: v for k, v in tb.items() if k in get_law(tres.meta.get("law")).temperature_names})
    # the coefficients' covariance (with the intercepts') travels with the layer's set
    add_covariance(scene_dict, tres)
    ctx.add_fit(f"hpt-T:{label}", tres, tres.to_scene_dict(), keep_set=False)


def fit_traction_layer(ctx: RunContext, t: Any) -> None:
    """``traction:<name>``: the layer from a measured traction test, fitted as ``torlab fit
    traction`` fits it (:func:`torlab.fit.traction.fit_traction_test`: every point at its
    own rolling speed, a dry test without the scene's lubricant)."""
    from torlab.fit.traction import fit_traction_test
    from torlab.instruments.measured import traction_data
    from torlab.scene import scene_from_dict

    data = traction_data(ctx.reduction(t.measured.resolved))
    files = tuple(x.resolved for x in t.scene)

    def compute() -> Any:
        return fit_traction_test(scene_from_dict(ctx.lp.scenes[files]), data)

    res = ctx.cache.get_or_compute("fit_traction", compute,
                                   measured=ctx.sha(t.measured.resolved),
                                   scene=ctx.lp.scenes[files], xi=data.creepage, mu=data.mu,
                                   test=data.test,
                                   speed=data.speed)
    ctx.add_fit(f"traction:{t.name}", res, res.to_scene_dict())


def fit_lubricant(ctx: RunContext, lf: Any) -> None:
    """``lubricant:<name>``: a viscosity law from a viscometer file's falls."""
    from torlab.fit.viscosity import fit_viscosity

    red = ctx.reduction(lf.measured.resolved)
    res = red.detail
    p = res.falls["pressure_Pa"].to_numpy(dtype=float)
    eta = res.falls["viscosity_Pa_s"].to_numpy(dtype=float)
    T = float(res.falls["temperature_C"].mean()) if "temperature_C" in res.falls else None
    d = ctx.p.data.visc
    kw: dict[str, Any] = {"confidence": d.confidence, "temperature_C": T}
    if lf.law == "roelands":
        kw.update(eta0=d.eta0, fit_eta0=True if d.fit_eta0 else None)
    # cached like the other fits: a re-run that changed nothing loads no optimiser for it
    ft = ctx.cache.get_or_compute("fit_viscosity", lambda: fit_viscosity(p, eta, lf.law, **kw),
                                  reduction=ctx.keys.get(id(red)), pressure=p, viscosity=eta,
                                  law=lf.law, options=kw)
    name = f"lubricant:{lf.name}"
    ctx.add_fit(name, ft, ft.to_scene_dict())
    row = ft.row()
    ctx.fit_summary[name] = finite({"kind": "viscosity", "law": lf.law,
                                    "params": {k: v for k, v in row.items()
                                               if isinstance(v, (int, float))},
                                    "correlation": ft.correlation.tolist(),
                                    "warnings": list(ft.warnings)})
