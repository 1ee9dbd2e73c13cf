"""Benchmark of whole predictions: a traction and a Stribeck curve per example scene.

For every scene in ``protocols/scenes/`` (the wheel-rail contact of Tab. 5.4, the
MTM of Paper B, the optical tribometer of Paper A) and for a *full mixed scene*
(the Paper A rough ball with a flash temperature and temperature-dependent layer:
boundary + EHL + asperities + temperature, every part modelled):

* ``traction 101 points``: :func:`torlab.model.predict.predict_traction` on
  creepages 0 ... 0.05 (the targets: <= 20 ms for the boundary curve,
  <= 150 ms for the full mixed scene);
* ``stribeck 50 speeds``: :func:`torlab.model.predict.predict_stribeck` on
  0.01 ... 2 m/s at 5 % creepage (lubricated scenes);
* the load-sharing cost per point of the Stribeck curve (``extra``);
* the *softening scene* (the Tab. 5.4 contact with a softening layer, mu_c1 0.45 ->
  mu_c2 0.30, no temperature): the 101-point boundary curve (target <= 8 ms) with
  the yield-angle iteration count; for dry scenes ``extra`` also gives the time of
  FASTSIM alone (``boundary_traction``, without building the prediction's table);
* the full mixed scene's Stribeck curve with temperature computed the way it was
  before the tau-T loop was vectorised across speeds -- one FASTSIM call per speed
  -- next to the default (one call for all speeds), in the same run.

Error: the default grid against a fine grid (``n = 24, m = 8``, 400 temperature
nodes), the largest ``|mu - mu_fine| / max|mu_fine|`` over the curve.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from torlab.bench import BenchRow, median_time

__all__ = ["full_mixed_scene", "run", "softening_scene"]

SCENES = Path(__file__).resolve().parents[2] / "protocols" / "scenes"


def full_mixed_scene():
    """The Paper A rough-ball scene with ``thermal:`` and temperature coefficients."""
    from torlab.scene import load_scene, scene_from_dict

    base = load_scene(SCENES / "optical_paper_a_rough.yaml").model_dump(exclude_none=True)
    base.pop("fit", None)
    base["name"] = "full mixed (Paper A rough + temperature)"
    base["thermal"] = {"conductivity": 50.0, "density": 7850.0, "heat_capacity": 450.0}
    base["boundary"].update(mu_c1_T=-1e-3, mu_c2_T=-1e-3)
    return scene_from_dict(base)


def softening_scene():
    """The Tab. 5.4 contact with a softening layer (mu_c1 0.45 -> mu_c2 0.30), isothermal."""
    from torlab.bench.fastsim import TAB54_SCENE
    from torlab.scene import scene_from_dict

    d = {k: (dict(v) if isinstance(v, dict) else v) for k, v in TAB54_SCENE.items()}
    d["name"] = "softening (Tab. 5.4 contact, mu_c1 0.45 -> mu_c2 0.30)"
    d["boundary"].update(mu_c1=0.45, mu_c2=0.30)
    return scene_from_dict(d)


def _scenes(quick: bool):
    from torlab.scene import load_scene

    names = ["wheel_rail_tab54", "optical_paper_a_rough"] if quick else \
        ["wheel_rail_tab54", "mtm_paper_b", "optical_paper_a_rough", "optical_paper_a_smooth"]
    out = [(n, load_scene(SCENES / f"{n}.yaml")) for n in names if (SCENES / f"{n}.yaml").exists()]
    out.append(("softening layer, isothermal", softening_scene()))
    out.append(("full mixed + temperature", full_mixed_scene()))
    return out


def _fine(scene):
    from torlab.scene import scene_from_dict

    d = scene.model_dump(exclude_none=True)
    d["grid"] = {"n": 24, "m": 8, "temperature_nodes": 400}
    if "thermal" in d:
        d["thermal"]["tolerance"] = 1e-3
    return scene_from_dict(d)


def _stribeck_per_speed(scene, v: np.ndarray, default, t_default: float,
                        repeat: int) -> BenchRow:
    """Baseline: a Stribeck curve with temperature computed with one FASTSIM call (and
    tau-T loop) per speed, as before the loop was vectorised across speeds.

    The same work as :func:`~torlab.model.mixed.stribeck_curve` (contact, load
    sharing, film traction, boundary part) without building its table, so the ratio
    slightly favours the baseline.
    """
    from torlab.model.ehl import mu_ehl
    from torlab.model.loadshare import solve_load_sharing
    from torlab.model.mixed import SHARE_TOL, boundary_part, mixed_contact

    xi = 0.05

    def per_speed() -> np.ndarray:
        mc = mixed_contact(scene)
        p = mc.contact.patch
        ls = solve_load_sharing(v, p.F, p.a, p.b, mc.film, mc.asperity, share_tol=SHARE_TOL)
        share = np.asarray(ls.load_share_asperity, dtype=float)
        h = np.asarray(ls.film_thickness, dtype=float)
        film = np.asarray(ls.F_EHL) > 0
        mu_ehl(xi * v[film], h[film], p.p0, mc.lubricant)
        mu_b = np.full(v.shape, np.nan)
        for i in np.flatnonzero(share >= SHARE_TOL):
            mu_b[i] = boundary_part(mc, np.array([xi]), float(v[i]), float(h[i]),
                                float(share[i])).mu[0]
        return mu_b

    mu_b = per_speed()
    ref = default.table["mu_boundary"].to_numpy()
    diff = float(np.nanmax(np.abs(mu_b - ref)))
    t = median_time(per_speed, repeat=repeat)
    return BenchRow(
        component="scene Stribeck curve", variant="full mixed + temperature, one FASTSIM "
        "call per speed (baseline)", time_s=t, error=diff,
        reference="the default's mu_boundary (absolute difference)", default=False,
        unit_of_work="50-speed Stribeck curve 0.01..2 m/s at 5 %", error_kind="absolute",
        extra={"time_ratio_to_vectorised": t / t_default})


def run(quick: bool = False) -> list[BenchRow]:
    """Time and error of the example scenes' traction and Stribeck curves."""
    from torlab.model.predict import predict_stribeck, predict_traction

    rows: list[BenchRow] = []
    xi = np.linspace(0.0, 0.05, 101)
    v = np.geomspace(0.01, 2.0, 50)
    repeat = 3 if quick else 5
    for name, sc in _scenes(quick):
        fine = _fine(sc)
        pred = predict_traction(sc, xi)
        ref = predict_traction(fine, xi).table["mu"].to_numpy()
        err = float(np.max(np.abs(pred.table["mu"].to_numpy() - ref)) / np.max(np.abs(ref)))
        t = median_time(lambda sc=sc: predict_traction(sc, xi), repeat=repeat)
        extra = {"temperature_loop": next((m.split(": ", 1)[1].split(" (")[0]
                                           for m in pred.modelled
                                           if m.startswith("contact temperature")), "")}
        if sc.lubricant is None:
            from torlab.model.fastsim import boundary_traction
            from torlab.model.prediction import fastsim_grid, fastsim_problem

            prob, grid = fastsim_problem(sc), fastsim_grid(sc)
            bl = boundary_traction(prob, xi, grid)
            extra["yield_iterations"] = bl.yield_iterations
            extra["fastsim_only_time_s"] = median_time(
                lambda prob=prob, grid=grid: boundary_traction(prob, xi, grid), repeat=repeat)
        if name.startswith("softening"):
            extra["target_time_s"] = 8e-3
        rows.append(BenchRow(
            component="scene traction curve", variant=name, time_s=t, error=err,
            reference="same scene on a fine grid (n 24, m 8, 400 temperature nodes)",
            default=True, unit_of_work="101-point traction curve 0..0.05", extra=extra))
        if sc.lubricant is None:
            continue
        sp = predict_stribeck(sc, v, 0.05)
        ref = predict_stribeck(fine, v, 0.05).table["mu"].to_numpy()
        err = float(np.max(np.abs(sp.table["mu"].to_numpy() - ref)) / np.max(np.abs(ref)))
        t = median_time(lambda sc=sc: predict_stribeck(sc, v, 0.05), repeat=repeat)
        extra = {"load_sharing_evaluations_per_speed":
                 sp.summary["load_sharing_evaluations_per_speed"]}
        if sc.thermal is not None:
            extra["target_time_s"] = 0.15
        rows.append(BenchRow(
            component="scene Stribeck curve", variant=name, time_s=t, error=err,
            reference="same scene on a fine grid", default=True,
            unit_of_work="50-speed Stribeck curve 0.01..2 m/s at 5 %", extra=extra))
        if sc.thermal is not None:
            rows.append(_stribeck_per_speed(sc, v, sp, t, repeat))
    # load sharing alone, per point, for the full mixed scene's Stribeck curve
    from torlab.model.loadshare import solve_load_sharing
    from torlab.model.mixed import mixed_contact

    mc = mixed_contact(full_mixed_scene())
    p = mc.contact.patch
    t = median_time(lambda: solve_load_sharing(v, p.F, p.a, p.b, mc.film, mc.asperity),
                    repeat=repeat)
    rows.append(BenchRow(component="scene load sharing", variant="bracketed, 50 speeds",
                         time_s=t, default=True, unit_of_work="50 speeds",
                         extra={"time_per_point_s": t / v.size}))
    return rows
