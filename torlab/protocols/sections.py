"""The report stage of a protocol: one section per ``reports:`` entry.

Each function takes the run's :class:`~torlab.protocols.context.RunContext`
and returns a :class:`torlab.reports.html.Section` built by the report modules
(:mod:`torlab.reports.amount`, :mod:`~torlab.reports.timetest`,
:mod:`~torlab.reports.traction`, :mod:`~torlab.reports.stribeck`); model
curves come from :func:`torlab.model.predict.predict_traction` and
:func:`torlab.model.predict.predict_stribeck` through the run's cache.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.files import safe_name
from torlab.model.plausible import result_notes
from torlab.protocols.context import RunContext, drawn_fits, finite

__all__ = ["build_sections"]


def build_sections(ctx: RunContext, ready: Any = None) -> list[Any]:
    """Every report section the protocol asks for, then the fitted parameter sets.

    ``ready(section)`` is called as soon as each section is built (a protocol run starts
    drawing its figures then).  The fitted sets come last in the report but are built
    first when no other section adds to them (the film and retention sections do), so
    their figures can be drawn while the other sections compute.
    """
    r = ctx.p.reports
    builders = (("amount", amount), ("time_test", time_test), ("traction", traction),
                ("stribeck", stribeck), ("film", film), ("retention", retention),
                ("compare", compare))  # compare last: the others add its items
    wanted = [(key, fn) for key, fn in builders if getattr(r, key, None) not in (None, [])]
    ready = ready or (lambda section: None)
    fits = None
    if ctx.fit_rows and not any(key in ("film", "retention") for key, _ in wanted):
        fits = fits_section(ctx)
        ready(fits)
    out = []
    for _, fn in wanted:
        out.append(fn(ctx))
        ready(out[-1])
    if fits is None and ctx.fit_rows:
        fits = fits_section(ctx)
        ready(fits)
    return out + ([fits] if fits is not None else [])


def amount(ctx: RunContext) -> Any:
    """Friction against applied amount per product, with the threshold crossings (Paper C)."""
    from torlab.fit.crossing import amount_series
    from torlab.reports.amount import amount_section

    cfg = ctx.p.reports.amount
    # one log's detail restored at a time (PackedReduction)
    series = amount_series((r.detail for r in ctx.reductions.get("hpt", [])), ctx.p.products,
                           temperature=cfg.temperature,
                           temperature_tolerance=cfg.temperature_tolerance,
                           only=cfg.products or None)
    if cfg.products:
        have = set(series["product"]) if len(series) else set()
        missing = [p for p in cfg.products if p not in have
                   and not any(h.startswith(p + "-") for h in have)]
        if missing:
            raise TorlabInputError(f"no HPT run with an applied amount for "
                                   f"{', '.join(missing)}", key="reports.amount.products")
    fits = stats = None
    if series is not None and len(series):
        from torlab.codec import digest_value
        from torlab.fit.crossing import amount_statistics, fit_crossings

        opts = {"threshold": cfg.threshold, "band": tuple(cfg.band), "curve": cfg.curve,
                "confidence": cfg.confidence, "probability": cfg.probability}
        digest = digest_value(series)
        fits = ctx.cache.get_or_compute("amount_crossings",
                                        lambda: fit_crossings(series, **opts),
                                        series=digest, options=opts)
        # the report's own probabilities (Student t, chi-squared): cached too, so a re-run
        # that changed nothing does not load scipy.special for them
        stats = ctx.cache.get_or_compute(
            "amount_statistics", lambda: amount_statistics(
                series, fits, threshold=cfg.threshold, confidence=cfg.confidence,
                probability=cfg.probability), series=digest, options=opts)
    if fits:
        ctx.add_estimates(lambda: _crossing_items(series, fits, (stats or {}).get("scatter")))
    return amount_section(series, cfg, fits, stats)


def _crossing_items(series: Any, fits: list[Any], scatter: Any = None) -> list[Any]:
    """Each product's crossing as an applied mass (comparable across liquids and solids)."""
    import math

    from torlab.comparison import Estimate, Item
    from torlab.fit.crossing import mass_factor

    out = []
    for cf in fits:
        mf = mass_factor(series, cf.product) * 1e-6  # kg per unit of its amounts
        vals = (cf.crossing * mf, cf.crossing_low * mf, cf.crossing_high * mf)
        if not all(math.isfinite(v) and v > 0 for v in vals):
            continue
        holds = scatter["holds"] if scatter else (
            "the scatter of the runs about the products' logistic curves, pooled over the "
            "products")
        out.append(Item(cf.product, {"crossing_mass": Estimate.from_interval(
            *vals, max(int(cf.dof), 1), log=True, runs=int(cf.n_points), holds=holds)},
            [f"amount series of {cf.product}"]))
    return out


def _initial_drop(ctx: RunContext, idp: Any) -> dict[str, Any]:
    """The model's coefficient at each time test's creepage and speed (initial drop)."""
    ((_, sc, sd),) = ctx.scenes_for(idp.scene, idp.params)
    model: dict[str, Any] = {"mu": {}, "creepage": {}, "load_share": {}, "modelled": {},
                             "scene": sc.name or idp.scene[0].path, "params": list(idp.params)}
    jobs = []
    for label, red in ctx.labelled("mtm"):
        d, tts = red.detail.curves.get("timed"), red.detail.time_tests
        if d is None or not tts:
            continue
        after = d[(d["step"] == tts[0].step) & (d["step_time_s"] >= tts[0].application_time_s)]
        xi = idp.creepage
        if xi is None:
            if "srr" not in after or after["srr"].isna().all():
                raise TorlabInputError(f"{label}: the timed step logs no SRR; give "
                                       "reports.time_test.initial_drop.creepage",
                                       key="reports.time_test")
            xi = float(f"{np.median(np.abs(after['srr'].dropna())):.3g}")
        v = float(np.median(after["rolling_speed_m_s"].dropna())) \
            if "rolling_speed_m_s" in after and after["rolling_speed_m_s"].notna().any() \
            else sc.kinematics.speed
        sdv = dict(sd, kinematics={**sd.get("kinematics", {}), "speed": v})
        jobs.append((label, xi, (sdv, {"creepage": np.array([xi]),
                                       "cache_kind": "initial_drop_v3"})))
    preds = ctx.predict_many("traction", [j for _, _, j in jobs], "time tests: initial-drop model")
    for (label, xi, _), pred in zip(jobs, preds, strict=True):
        row = pred.table.iloc[0]
        model["mu"][label] = float(abs(row["mu"]))
        if "mu_low95" in pred.table:  # the band of the fitted layer's and viscosity law's uncertainty
            lo, hi = sorted((abs(float(row["mu_low95"])), abs(float(row["mu_high95"]))))
            model.setdefault("mu_low95", {})[label] = lo
            model.setdefault("mu_high95", {})[label] = hi
        model["load_share"][label] = float(row.get("load_share_asperity", 1.0))
        model["modelled"][label] = list(pred.modelled)
        model["creepage"][label] = xi
    return model


def time_test(ctx: RunContext) -> Any:
    """Time tests after application (Paper B), with the initial-drop model if asked."""
    from torlab.reports.timetest import time_test_section

    cfg = ctx.p.reports.time_test
    model = _initial_drop(ctx, cfg.initial_drop) if cfg.initial_drop is not None else None
    evidence = _time_test_evidence(ctx, cfg)
    repeats = _time_test_repeats(ctx, cfg, evidence) if evidence else None
    if evidence:
        ctx.add_estimates(lambda: _time_test_items(ctx, cfg, evidence, repeats))
    return time_test_section([(lab, r.detail) for lab, r in ctx.labelled("mtm")], cfg, model,
                             evidence, repeats)


def _time_test_items(ctx: RunContext, cfg: Any, evidence: dict[Any, Any],
                     repeats: dict[str, Any] | None) -> list[Any]:
    """The time tests as items for ``reports.compare``: a test by its file's label (with its
    step where a file holds several), a repeated composition by its name."""
    from torlab.comparison import items_from_time_tests

    results = {(lab, tt.step): tt for lab, red in ctx.labelled("mtm")
               for tt in red.detail.time_tests}
    steps: dict[str, int] = {}
    for lab, _ in evidence:
        steps[lab] = steps.get(lab, 0) + 1
    member = {lab: c for c, labs in cfg.repeats.items() for lab in labs}
    labels = {k: member.get(k[0]) or (k[0] if steps[k[0]] == 1 else f"{k[0]} step {k[1]}")
              for k in evidence}
    comps = (repeats or {}).get("compositions") or {}
    dof = {f: float(v.get("dof") or 0) or float("inf")
           for f, v in ((repeats or {}).get("figures") or {}).items()}
    return items_from_time_tests(evidence, results, labels, comps, dof)


def _time_test_repeats(ctx: RunContext, cfg: Any, evidence: dict[Any, Any]) -> dict[str, Any]:
    """The test-to-test scatter of ``reports.time_test.repeats`` applied to the evidence."""
    import copy

    from torlab.reduce.time_test_uncertainty import apply_repeats

    labels = [lab for lab, _ in ctx.labelled("mtm")]
    comp: dict[Any, str] = {}
    for name, members in cfg.repeats.items():
        for lab in members:
            if lab not in labels:
                raise TorlabInputError(f"repeats of {name!r}: no MTM file labelled {lab!r} "
                                       f"(labels: {', '.join(labels)})",
                                       key="reports.time_test.repeats")
            if any(c != name for (lb, _), c in comp.items() if lb == lab):
                raise TorlabInputError(f"{lab!r} is listed under two compositions",
                                       key="reports.time_test.repeats")
            for key in evidence:
                if key[0] == lab:
                    comp[key] = name
    for key in evidence:
        comp.setdefault(key, f"{key[0]} step {key[1]}")
    results = {(lab, tt.step): tt for lab, red in ctx.labelled("mtm")
               for tt in red.detail.time_tests}
    for key in list(evidence):
        evidence[key] = copy.deepcopy(evidence[key])
    out = apply_repeats(evidence, results, comp, band=tuple(cfg.band),
                        probability=cfg.probability)
    out["listed"] = {k: list(v) for k, v in cfg.repeats.items()}
    return out


def _time_test_evidence(ctx: RunContext, cfg: Any) -> dict[tuple[str, int], dict[str, Any]]:
    """``(label, step)`` -> intervals and verdict probabilities of its time-test figures."""
    from torlab.reduce.time_test_uncertainty import time_test_uncertainty

    opts = {k: v for k, v in ctx.p.data.mtm.time_test.options().items()
            if k != "application_time"}
    out = {}
    for label, red in ctx.prog.track(ctx.labelled("mtm"), "time tests: intervals"):
        d = red.detail.curves.get("timed")
        for tt in red.detail.time_tests:
            if d is None:
                continue
            sel = d["step"].to_numpy() == tt.step
            t = d.loc[sel, "step_time_s"].to_numpy(dtype=float)
            m = d.loc[sel, "traction_coefficient"].to_numpy(dtype=float)
            out[(label, tt.step)] = ctx.cache.get_or_compute(
                "time_test_evidence",
                lambda t=t, m=m, tt=tt: time_test_uncertainty(
                    t, m, tt, opts, band=tuple(cfg.band), replicates=cfg.replicates,
                    probability=cfg.probability),
                red=ctx.keys.get(id(red), red.source), step=tt.step, options=opts,
                band=list(cfg.band), replicates=cfg.replicates, probability=cfg.probability)
    return out


def _measured_curves(ctx: RunContext, ci: int, c: Any) -> list[Any]:
    """The measured traction curves of one ``reports.traction.curves`` entry."""
    import pandas as pd

    from torlab.model.prediction import classify_trend
    from torlab.reports.traction import TractionCurve

    cfg = ctx.p.reports.traction
    curves = ctx.reduction(c.measured.resolved).traction_curves()
    many = len(curves) > 1
    out = []
    for cv in curves:
        v = cv.speed_m_s
        at = f" @ {v:.3g} m/s" if v is not None and many else ""
        lab = c.measured.path.rsplit("/", 1)[-1] + at
        out.append(TractionCurve(
            label=f"measured {lab}" if c.scene else c.label + at, kind="measured",
            table=pd.DataFrame({"creepage": cv.x, "mu": cv.y} if cv.y_sd is None else
                               {"creepage": cv.x, "mu": cv.y, "mu_sd": cv.y_sd}),
            trend=classify_trend(cv.x, cv.y, tolerance=cfg.trend_tolerance,
                                 threshold=cfg.trend_probability, measured=True),
            source=str(c.measured.path), speed_m_s=v,
            group=f"{ci}:{v:.3g}" if v is not None and c.speeds == "measured" else f"{ci}:"))
    return out


def traction(ctx: RunContext) -> Any:
    """Predicted (and measured) traction curves with their trend after saturation (H4.1)."""
    from torlab.reports.traction import TractionCurve, traction_section

    cfg = ctx.p.reports.traction
    xi = np.asarray(cfg.creepage, dtype=float)
    curves: list[Any] = []
    measured: list[Any] = []
    jobs = []
    for ci, c in enumerate(cfg.curves):
        mine = _measured_curves(ctx, ci, c) if c.measured else []
        measured += mine
        if not c.scene:
            continue
        if c.speeds is None:
            speeds: list[float | None] = [None]
        elif c.speeds == "measured":
            speeds = [m.speed_m_s for m in mine if m.speed_m_s is not None] or [None]
        else:
            speeds = list(c.speeds)
        for setname, sc, sd in ctx.scenes_for(c.scene, c.params):
            jobs += [(ci, c, setname, sc, sd, v, len(speeds) > 1) for v in speeds]
    preds = ctx.predict_many("traction", [
        (sd if v is None else dict(sd, kinematics={**sd.get("kinematics", {}), "speed": v}),
         {"creepage": xi, "trend_tolerance": cfg.trend_tolerance,
          "trend_probability": cfg.trend_probability})
        for _, _, _, _, sd, v, _ in jobs], "traction: predicting curves")
    for (ci, c, setname, sc, _sd, v, many), pred in zip(jobs, preds, strict=True):
        speed = sc.kinematics.speed if v is None else v
        label = c.label.replace("{set}", setname) + (f" @ {speed:.3g} m/s" if many else "")
        ctx.notes += [f"traction {label}: {n}" for n in result_notes(pred.table)]
        ctx.notes += [f"traction {label}: {n}" for n in _extrapolation(
            ctx, pred.table, [p.replace("hpt:*", f"hpt:{setname}") for p in c.params])]
        one_set = len(set(ctx.param_sets)) <= 1 or "hpt:*" not in c.params
        curves.append(TractionCurve(
            label=label, kind="model", table=pred.table, trend=pred.trend,
            source=" + ".join([*(x.path for x in c.scene), *c.params]).replace(
                "hpt:*", f"hpt:{setname}"), speed_m_s=speed, modelled=pred.modelled,
            group=f"{ci}:{speed:.3g}" if c.speeds == "measured" else
            (f"{ci}:" if one_set else f"{ci}:{setname}"), band=pred.summary.get("band", {}),
            theory={"method": pred.summary.get("method"),
                    "theory_error": pred.summary.get("theory_error")},
            choices=ctx.selection_choices([p.replace("hpt:*", f"hpt:{setname}")
                                           for p in c.params])))
        if sc.boundary is not None:
            curves[-1].boundary = sc.boundary.model_dump()
    return traction_section(curves + measured, cfg)


def _extrapolation(ctx: RunContext, table: Any, sets: list[str]) -> list[str]:
    """A note when the contact is hotter than the runs its temperature coefficients rest on."""
    if "max_temperature_C" not in table:
        return []
    tmax = float(table["max_temperature_C"].max())
    out = []
    for name, res in ctx.fit_results:
        if res.kind != "temperature" or name.replace("hpt-T:", "hpt:", 1) not in sets:
            continue
        tested = max(res.meta.get("temperatures_C") or [float("inf")])
        if tmax > tested + 1.0:
            out.append(f"the contact reaches {tmax:.0f} °C, beyond the highest test temperature "
                       f"of {name} ({tested:.0f} °C): its exponential temperature law is "
                       "extrapolated there")
    return out


def _measured_stribeck(ctx: RunContext, path: Any) -> Any:
    import pandas as pd

    cv = ctx.reduction(path).stribeck_curve()
    d = {"rolling_speed_m_s": cv.x, "srr": cv.srr, "traction_coefficient": cv.y}
    if cv.y_sd is not None:
        d["traction_coefficient_sd"] = cv.y_sd
    return pd.DataFrame(d).reset_index(drop=True)


def stribeck(ctx: RunContext) -> Any:
    """Predicted Stribeck curves with the measured points."""
    from torlab.reports.stribeck import StribeckCurve, stribeck_section

    cfg = ctx.p.reports.stribeck
    v = np.asarray(cfg.speed, dtype=float)
    curves: list[Any] = []
    for c in ctx.prog.track(cfg.curves, "Stribeck: predicting curves"):
        meas = _measured_stribeck(ctx, c.measured.resolved) if c.measured else None
        xi = cfg.creepage
        if xi is None and meas is not None and meas["srr"].notna().any():
            xi = float(f"{np.median(np.abs(meas['srr'].dropna())):.3g}")  # the set SRR
        if xi is None and c.scene:
            raise TorlabInputError("give reports.stribeck.creepage (no measured file to take "
                                   "the SRR from)", key="reports.stribeck.creepage")
        if not c.scene:
            curves.append(StribeckCurve(label=c.label, creepage=xi, measured=meas,
                                        measured_label=c.measured.path.rsplit("/", 1)[-1],
                                        source=str(c.measured.path)))
            continue
        sets = ctx.scenes_for(c.scene, c.params)
        preds = ctx.predict_many("stribeck", [(sd, {"speed": v, "creepage": xi})
                                              for _, _, sd in sets])
        for (setname, _sc, _sd), pred in zip(sets, preds, strict=True):
            ctx.notes += [f"Stribeck {c.label.replace('{set}', setname)}: {n}"
                          for n in result_notes(pred.table)]
            curves.append(StribeckCurve(
                label=c.label.replace("{set}", setname), table=pred.table, creepage=xi,
                measured=meas, measured_label="" if c.measured is None else
                c.measured.path.rsplit("/", 1)[-1] + " (measured)",
                source=" + ".join([*(x.path for x in c.scene), *c.params]),
                modelled=pred.modelled, band=pred.summary.get("band", {}),
                transitions=pred.summary.get("transitions", {})))
    return stribeck_section(curves)


def film(ctx: RunContext) -> Any:
    """Measured film thickness against speed, the model's film and the fitted speed exponent."""
    import pandas as pd

    from torlab.fit.film import fit_film_thickness
    from torlab.reports.stribeck import film_section

    cfg = ctx.p.reports.film
    measured, models, fits = [], [], []
    for c in cfg.curves:
        d = None
        if c.measured is not None:
            try:
                cvs = ctx.reduction(c.measured.resolved).film_curves()
            except TorlabInputError:
                raise TorlabInputError("no film thickness measured", path=c.measured.resolved,
                                       key="reports.film") from None
            d = pd.DataFrame({"rolling_speed_m_s": np.concatenate([cv.x for cv in cvs]),
                              "film_thickness_m": np.concatenate([cv.y for cv in cvs])})
            if all(cv.y_sd is not None for cv in cvs):
                d["film_thickness_sd_m"] = np.concatenate([cv.y_sd for cv in cvs])
            d = d.sort_values("rolling_speed_m_s")
            measured.append((c.label, d))
        scs = ctx.scenes_for(c.scene, c.params) if c.scene else []
        lo, hi = (float(d["rolling_speed_m_s"].min()), float(d["rolling_speed_m_s"].max())) \
            if d is not None else (0.01, 3.0)
        preds = ctx.predict_many("stribeck", [
            (sd, {"speed": np.geomspace(lo, hi, 40), "creepage": 0.0, "cache_kind": "film_model"})
            for _, _, sd in scs])
        for (setname, _sc, _sd), pred in zip(scs, preds, strict=True):
            models.append((c.label.replace("{set}", setname), pred.table))
        if d is not None:
            v, h = d["rolling_speed_m_s"].to_numpy(), d["film_thickness_m"].to_numpy()
            fr = ctx.cache.get_or_compute(  # cached: a re-run then loads no optimiser for it
                "fit_film", lambda v=v, h=h, scs=scs: fit_film_thickness(
                    v, h, scene=scs[0][1] if scs else None, min_speed=cfg.min_speed or None),
                speed=v, film=h, scene=scs[0][2] if scs else None, min_speed=cfg.min_speed)
            fits.append((c.label, fr))
            ctx.fit_summary[f"film:{c.label}"] = finite({
                "kind": fr.kind, "params": dict(fr.params),
                "ci95": {k: list(v) for k, v in fr.ci95.items()}, "warnings": list(fr.warnings)})
    return film_section(measured, models, fits)


def _amount_series_fits(ctx: RunContext, cfg: Any) -> tuple[list[Any], Any, list[str]]:
    """One HPT layer fit per applied amount of ``cfg.product`` (repeats jointly) and the dry
    fit, at the report's temperature; each cached like the ``fits.hpt_layers`` fits."""
    from torlab.fit.layer import fit_layer_hpt

    groups: dict[Any, list[Any]] = {}
    for r in ctx.reductions.get("hpt", []):
        m = r.meta
        if m.temperature is not None and abs(m.temperature - cfg.temperature) > \
                cfg.temperature_tolerance:
            continue
        label = m.product + (f"-{m.condition}" if m.condition else "")
        if m.product == cfg.dry or label == cfg.dry:
            groups.setdefault(None, []).append(r)
        elif cfg.product in (m.product, label) and m.applied_amount is not None:
            groups.setdefault((m.applied_amount_kind, round(m.applied_amount, 15)), []).append(r)
    if None not in groups:
        raise TorlabInputError(f"no HPT run of the dry reference {cfg.dry!r} at "
                               f"{cfg.temperature:g} °C", key="reports.retention.dry")
    fits, labels = [], []
    for g in sorted((k for k in groups if k is not None), key=lambda k: k[1]):
        runs = groups[g]
        fits.append(ctx.cache.get_or_compute(
            "fit_hpt", lambda runs=runs: fit_layer_hpt([ctx.full(r).detail for r in runs]),
            runs=[ctx.keys[id(r)] for r in runs]))
        labels += [ctx.keys[id(r)] for r in runs]
    dry_runs = groups[None]
    dry = ctx.cache.get_or_compute(
        "fit_hpt", lambda: fit_layer_hpt([ctx.full(r).detail for r in dry_runs]),
        runs=[ctx.keys[id(r)] for r in dry_runs])
    return fits, dry, labels + [ctx.keys[id(r)] for r in dry_runs]


def retention(ctx: RunContext) -> Any:
    """Removal fit from the time tests and the HPT amount series, retention prediction and
    (optionally) a slip sweep on the prediction scene (docs/model/retention.md)."""
    from torlab.fit.removal import default_tribometer_scene, fit_removal
    from torlab.model.amount import AmountLayer
    from torlab.model.retention import predict_retention, simulate_sweep
    from torlab.reduce.time_test import read_time_test
    from torlab.reports.retention import retention_section
    from torlab.scene import scene_from_dict

    cfg = ctx.p.reports.retention
    fits, dry, run_keys = _amount_series_fits(ctx, cfg)
    prod = ctx.p.products.get(cfg.product)
    density = cfg.density or (prod.density if prod is not None else None)
    layer = AmountLayer.from_fits(fits, dry, density=density, dry_amount=cfg.dry_amount,
                                  repeatability=cfg.repeatability,
                                  temperature_tolerance=cfg.temperature_tolerance)
    layer_opts = [cfg.repeatability, cfg.dry_amount, cfg.temperature, density]
    dens = density or next((f.meta["product_density"] for f in fits
                            if isinstance(f.meta.get("product_density"), (int, float))), None)
    files = [p for e in cfg.time_tests for p in e.resolved] or ctx.lp.data_files("mtm")
    trib_dict = ctx.lp.scenes[tuple(x.resolved for x in cfg.tribometer)] if cfg.tribometer \
        else {}
    trib = scene_from_dict(trib_dict) if trib_dict else default_tribometer_scene()
    opts = {"laws": list(cfg.laws), "law": cfg.law, "transfer": cfg.transfer, "skip": cfg.skip}
    app = ctx.p.data.mtm.time_test.application_time
    fit = ctx.cache.get_or_compute(
        "fit_removal", lambda: fit_removal(
            [read_time_test(f, density=dens, application_time=app) for f in files], layer,
            trib, **opts),
        hpt=run_keys, tests=[ctx.sha(f) for f in files], scene=trib_dict, density=dens,
        application_time=app, layer_options=layer_opts, **opts)
    ctx.add_fit(f"removal:{cfg.product}", fit, {}, keep_set=False)
    pc = cfg.prediction
    ((_, sc, sd),) = ctx.scenes_for(pc.scene, [])
    kw = {"track_radius": pc.track_radius, "band_length": pc.band_length, "density": dens}
    key = {"fit": fit.meta["fit_space"], "hpt": run_keys, "layer_options": layer_opts,
           "scene": sd, **kw}
    pred = ctx.cache.get_or_compute("retention", lambda: predict_retention(
        sc, layer, fit, pc.amount, creepage=pc.creepage, band=tuple(pc.band),
        pass_interval=pc.pass_interval, n_passes=pc.passes, n_draws=pc.draws, seed=pc.seed,
        window=pc.window, retentivity=pc.retentivity,
        **kw), amount=pc.amount, spec=pc.model_dump(mode="json"), **key)
    from torlab.comparison import Item, retention_estimates

    ctx.add_estimates(lambda: [Item(cfg.product, retention_estimates(
        pred.summary["retention_metrics"]), [f"retention prediction of {cfg.product}"])])
    sweep = None
    if cfg.sweep is not None:
        sw = cfg.sweep
        xi = np.asarray(sw.creepage, dtype=float)
        sweep = ctx.cache.get_or_compute("retention_sweep", lambda: simulate_sweep(
            sc, layer, fit, sw.amount or pc.amount, creepage=(float(xi[0]), float(xi[-1])),
            points=xi.size, seconds=sw.seconds, pass_interval=sw.pass_interval or
            pc.pass_interval, n_draws=sw.draws,
            trend_tolerance=sw.trend_tolerance, trend_probability=sw.trend_probability,
            **kw), spec=sw.model_dump(mode="json"),
            amount=sw.amount or pc.amount, **key)
    return retention_section(cfg.product, fit, layer, pred, sweep, axis=cfg.axis)


def compare(ctx: RunContext) -> Any:
    """``reports.compare``: the run's items compared on the quantities they share."""
    from torlab._suggest import did_you_mean
    from torlab.comparison import compare as _compare
    from torlab.reports.compare import compare_section

    have = ctx.compare_items
    results = []
    for k, spec in enumerate(ctx.p.reports.compare):
        where = f"reports.compare[{k}]"
        labels = list(spec.items) or list(have)
        for lab in labels:
            if lab not in have:
                raise TorlabInputError(
                    f"no item {lab!r} in this run (items: {', '.join(have) or 'none'})"
                    f"{did_you_mean(lab, list(have))}", key=f"{where}.items")
        try:
            res = _compare([have[lab] for lab in labels], reference=spec.reference,
                           quantities=list(spec.quantities) or None, better=dict(spec.better),
                           pairs=spec.pairs, probability=spec.probability)
        except TorlabInputError as e:
            raise TorlabInputError(e.message, key=where) from None
        name = spec.name or (f"against {res.reference}" if res.reference else "every pair")
        results.append((name, res))
    return compare_section(results)


def _fit_figures_sentence(which: str, drawn: int, fitted: int, draw: bool = True) -> str:
    """The fits section's sentence on the data-against-model figures not drawn
    (``reports.fit_figures``; ``drawn`` of ``fitted`` sets have one; ``draw``: the run draws
    figures at all, else it says which sets would have one)."""
    from torlab.protocols.context import AUTO_ALL_SETS

    if which == "none":
        return ("No data-against-model figures are drawn (reports.fit_figures: none; 'all' "
                "draws one for every set).")
    why = ("reports.fit_figures: warned" if which == "warned" else
           f"reports.fit_figures: auto, above {AUTO_ALL_SETS} fitted sets")
    which_sets = ("those whose fit warned" if drawn else
                  "those whose fit warned, and none did")
    start = ("Data-against-model figures are drawn" if draw else
             "No figures are drawn in this run; with them, data-against-model figures would "
             "be drawn")
    return (f"{start} for {drawn} of the {fitted} fitted sets, {which_sets} ({why}; 'all' "
            "draws one for every set).")


def fits_section(ctx: RunContext) -> Any:
    """The fitted parameter sets: table, data-against-model figures, warnings."""
    import pandas as pd

    from torlab.reports.fit import result_figure
    from torlab.reports.html import Figure, Section, Table
    from torlab.reports.render import plot

    drawn = drawn_fits(ctx.fit_figures, ctx.fit_results)
    figs = [Figure(f"fit_{safe_name(name.replace(':', '_'))}", plot(result_figure,
                                                                     ctx.fit_arg(res)),
                   f"{name}: data against the fitted model, residuals")
            for name, res in drawn]
    warn = [f"{name}: {w}" for name, res in ctx.fit_results for w in res.warnings]
    show = {"set": ("set", ""), "parameter": ("parameter", ""), "value": ("value", ".5g"),
            "stderr": ("stderr", ".3g"), "95 % low": ("ci95_low", ".5g"),
            "95 % high": ("ci95_high", ".5g"), "unit": ("unit", ""), "status": ("status", ""),
            "between runs (% of variance)": ("between_runs_pct", ".0f")}
    sel = _selection_rows(ctx)
    paragraphs = [
        "Parameters identified from the protocol's data (torlab.fit): the HPT layers "
        "(thesis Eqs. 5.24-5.29) per product, temperature coefficients, layers from "
        "measured traction curves and viscosity laws; each set is also written as a "
        "scene parameter file in fits/ for 'torlab predict', with the covariance of its "
        "estimates (fit: covariance:), which the predictions above propagate into their bands.",
    ]
    paragraphs.append(
        "Repeated runs (the same product, amount and temperature) are fitted one by one and "
        "pooled with random effects (REML between-run variance, Hartung-Knapp interval on "
        "runs - 1 degrees of freedom): their intervals hold the scatter from run to run, "
        "and the table gives each parameter's share of its variance that is scatter between "
        "runs. A set from a single run has no such share: its interval holds for that record "
        "alone.")
    for name, res in ctx.fit_results:
        if res.meta.get("scatter"):
            paragraphs.append(f"{name}: {res.meta['scatter']}.")
    if len(drawn) < len(ctx.fit_results):
        paragraphs.append(_fit_figures_sentence(ctx.fit_figures, len(drawn),
                                                len(ctx.fit_results), ctx.draw))
    if sel:
        fixed = [r for r in sel if r["decision"].startswith("fixed")]
        kept = [r for r in sel if not r["decision"].startswith("fixed")]
        paragraphs.append(
            "Model selection (what the data do not resolve, and what was done): "
            f"{len(fixed)} parameter(s) fixed, {len(kept)} kept with their uncertainty "
            "(table 'model_selection'). A fixed value is exact in every prediction that uses "
            "the set; a kept one widens its band.")
        for r in sel:
            test = f" ({r['test']}, p = {r['p_value']:.2g})" if r["p_value"] == r["p_value"] else ""
            paragraphs.append(f"{r['set']}: {r['parameter']} {r['decision']}{test}.")
    tables = [Table("parameters", pd.DataFrame(ctx.fit_rows), "Fitted parameters", show,
                    allow_missing=("value", "stderr", "ci95_low", "ci95_high",
                                   "between_runs_pct"))]
    if sel:
        tables.append(Table(
            "model_selection", pd.DataFrame(sel), "Model selection per fit", {
                "set": ("set", ""), "parameter": ("parameter", ""), "decision": ("decision", ""),
                "test": ("test", ""), "p": ("p_value", ".3g"), "estimate": ("estimate", ".3g"),
                "95 % low (full model)": ("ci95_low_full", ".3g"),
                "95 % high (full model)": ("ci95_high_full", ".3g")},
            allow_missing=("test", "p_value", "estimate", "ci95_low_full", "ci95_high_full")))
    # its key numbers are summary.json's "fits", the run's fit summary, which the runner
    # writes (each entry JSON-safe as recorded): the same object, not a copy of every set's
    return Section(key="fits", title="Fitted parameter sets", paragraphs=paragraphs,
                   figures=figs, tables=tables, summary=ctx.fit_summary, notes=warn)


def _selection_rows(ctx: RunContext) -> list[dict[str, Any]]:
    """One row per model-selection choice of the run's fits (``meta["model_selection"]``)."""
    nan = float("nan")
    rows = []
    for name, res in ctx.fit_results:
        for par, ch in (res.meta.get("model_selection") or {}).items():
            if not isinstance(ch, dict):
                continue
            ci = ch.get("ci95_full_model") or ch.get("ci95") or [nan, nan]
            est = ch.get("estimate_1_per_K")
            rows.append({"set": name, "parameter": par, "decision": str(ch.get("decision", "")),
                         "test": str(ch.get("test", "")),
                         "p_value": nan if ch.get("p_value") is None else float(ch["p_value"]),
                         "estimate": nan if est is None else float(est),
                         "ci95_low_full": nan if ci[0] is None else float(ci[0]),
                         "ci95_high_full": nan if ci[1] is None else float(ci[1])})
    return rows
