"""Running a protocol: raw logs -> reduced data -> fitted parameter sets -> reports.

:func:`run_protocol` is what ``torlab run PROTOCOL.yaml -o OUT`` calls.  In order:

1. load and validate the protocol (:func:`torlab.protocols.loader.load_protocol`),
   every problem listed before any work starts;
2. reduce the raw files of each instrument with the existing reductions
   (:mod:`torlab.reduce.hpt`, :mod:`~torlab.reduce.mtm`, :mod:`~torlab.reduce.optical`,
   :mod:`~torlab.reduce.viscometer`);
3. fit the parameter sets the protocol asks for (:mod:`torlab.fit`): HPT layers
   (``hpt:<product>``, with temperature coefficients), layers from measured
   traction curves (``traction:<name>``), viscosity laws (``lubricant:<name>``);
4. write the reports (:mod:`torlab.reports.amount`, ``timetest``, ``traction``,
   ``stribeck``) with figures, tables, ``report.html``, ``report.md`` and
   ``summary.json`` (key numbers, torlab version, SHA-256 of the protocol and of
   every input file).

Results go through :class:`torlab.outputs.OutputDir` (atomic, never over
earlier results without ``force``).  Intermediate results are cached in
``OUT/.cache`` keyed by input hashes and options (:mod:`torlab.protocols.cache`),
so a re-run with ``--force`` reuses what did not change.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import FitError, TorlabInputError

__all__ = ["RunResult", "run_protocol"]


@dataclass
class RunResult:
    """What a protocol run wrote and its key numbers."""

    out: Path
    summary: dict[str, Any]
    sections: list[str]
    cache_hits: int
    cache_misses: int
    notes: list[str] = field(default_factory=list)


class _Progress:
    """Rich progress bars for the long steps (no output when disabled)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self._p: Any = None

    def __enter__(self) -> _Progress:
        if self.enabled:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self._p = Progress(TextColumn("{task.description}"), BarColumn(),
                               MofNCompleteColumn(), TimeElapsedColumn(), transient=False)
            self._p.__enter__()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._p is not None:
            self._p.__exit__(*exc)

    def track(self, items: Iterable[Any], description: str) -> Iterator[Any]:
        items = list(items)
        if self._p is None:
            yield from items
            return
        task = self._p.add_task(description, total=len(items))
        for it in items:
            yield it
            self._p.advance(task)


# --------------------------------------------------------------------------- helpers
def _fit_module(name: str) -> Any:
    """``torlab.fit.<name>``, or a clear FitError when this torlab does not have it."""
    import importlib

    try:
        return importlib.import_module(f"torlab.fit.{name}")
    except ModuleNotFoundError as e:
        if e.name != f"torlab.fit.{name}":
            raise
        raise FitError(f"this torlab has no torlab.fit.{name} (parameter fits, issue 6), so the "
                       "protocol's fits: cannot run; remove them from the protocol or update "
                       "torlab") from None


def _is_optical_log(path: Path) -> bool:
    with open(path, "rb") as f:
        head = f.read(64).lstrip(b"\xef\xbb\xbf").lstrip()
    return head.startswith(b"# torlab-optical")


def _finite(v: Any) -> Any:
    """JSON-safe value: non-finite floats -> None, numpy scalars -> Python."""
    if isinstance(v, dict):
        return {str(k): _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_finite(x) for x in v]
    if isinstance(v, np.ndarray):
        return [_finite(x) for x in v.tolist()]
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, Path):
        return str(v)
    return v


class _Run:
    """State of one protocol run."""

    def __init__(self, lp: Any, dest: Any, cache: Any, prog: _Progress) -> None:
        self.lp = lp
        self.p = lp.protocol
        self.dest = dest
        self.cache = cache
        self.prog = prog
        self.notes: list[str] = []
        self.hpt: list[Any] = []
        self.hpt_keys: dict[int, str] = {}   # id(HptResult) -> cache key of its reduction
        self.mtm: list[tuple[str, Path, Any]] = []
        self.optical: dict[Path, Any] = {}
        self.visc: dict[Path, Any] = {}
        self.param_sets: dict[str, dict[str, Any]] = {}
        self.fit_rows: list[dict[str, Any]] = []
        self.fit_results: list[tuple[str, Any]] = []
        self.fit_summary: dict[str, Any] = {}
        self.data_summary: dict[str, Any] = {}

    def sha(self, p: Path) -> str:
        from torlab.protocols.cache import file_sha256

        return file_sha256(p)

    # ------------------------------------------------------------------ reduction
    def reduce_all(self) -> None:
        d = self.p.data
        if d.hpt is not None:
            self._reduce_hpt()
        if d.mtm is not None:
            self._reduce_mtm()
        if d.optical is not None:
            self._reduce_optical()
        if d.visc is not None:
            self._reduce_visc()

    def _reduce_hpt(self) -> None:
        import pandas as pd

        from torlab.parsers.hpt import read_hpt
        from torlab.reduce.hpt import RigCompliance, reduce_hpt

        d = self.p.data.hpt
        comp, comp_key = None, None
        spec = d.compliance_spec
        if spec is not None:
            if spec[0] == "file":
                comp = RigCompliance.from_file(spec[1])
                comp_key = ["file", self.sha(spec[1])]
            else:
                comp = RigCompliance.linear(spec[1])
                comp_key = ["value", spec[1]]
        for f in self.prog.track(self.lp.data_files("hpt"), "HPT: reducing logs"):
            def compute(f: Path = f) -> Any:
                df, meta = read_hpt(f)
                return reduce_hpt(df, meta, window=d.window, source=d.source, compliance=comp)

            parts = {"sha": self.sha(f), "name": f.name, "window": d.window,
                     "source": d.source, "compliance": comp_key}
            res = self.cache.get_or_compute("hpt", compute, **parts)
            self.hpt.append(res)
            self.hpt_keys[id(res)] = self.cache.key("hpt", **parts)
        rows = [r.summary() for r in self.hpt]
        df = pd.DataFrame(rows)
        self.dest.write_csv("data/hpt_summary.csv", df,
                            allow_missing=("applied_amount", "temperature_C"))
        self.data_summary["hpt"] = {"files": len(rows), "f_window": {
            r["file"]: r["f_window"] for r in rows}}

    def _reduce_mtm(self) -> None:
        import pandas as pd

        from torlab.parsers.pcs import read_pcs
        from torlab.reduce.mtm import reduce_pcs

        d = self.p.data.mtm
        opts = d.time_test.options()
        labels = self.lp.labels("mtm")
        steps = []
        for f in self.prog.track(self.lp.data_files("mtm"), "MTM: reducing exports"):
            def compute(f: Path = f) -> Any:
                df, meta = read_pcs(f, instrument=d.instrument)
                try:
                    return reduce_pcs(df, meta, **opts)
                except TorlabInputError as e:
                    raise e.with_path(f) from None

            red = self.cache.get_or_compute("mtm", compute, sha=self.sha(f), name=f.name,
                                            instrument=d.instrument, options=opts)
            label = labels.get(f) or f.stem
            self.mtm.append((label, f, red))
            steps.append(red.steps.assign(label=label))
            for kind, cdf in red.curves.items():
                self.dest.write_csv(f"data/mtm/{f.stem}_{kind}.csv", cdf,
                                    allow_missing=tuple(c for c in cdf.columns
                                                        if c not in ("step", "line")))
        sdf = pd.concat(steps, ignore_index=True)
        self.dest.write_csv("data/mtm_steps.csv", sdf, allow_missing=tuple(
            c for c in sdf.columns if c not in ("step", "n_rows", "first_line", "last_line")))
        self.data_summary["mtm"] = {"files": len(self.mtm),
                                    "timed_steps": sum(len(r.time_tests) for _, _, r in self.mtm)}

    def _reduce_optical(self) -> None:
        import pandas as pd

        from torlab.parsers.pcs import read_pcs
        from torlab.reduce.optical import (
            POINT_OPTIONAL,
            SUMMARY_OPTIONAL,
            reduce_ehd2,
            reduce_optical_log,
        )

        d = self.p.data.optical
        rows = []
        for f in self.prog.track(self.lp.data_files("optical"), "optical: reducing logs"):
            def compute(f: Path = f) -> Any:
                if _is_optical_log(f):
                    return reduce_optical_log(f, window=d.window, sym_rel=d.symmetry_tolerance,
                                              sym_abs=d.symmetry_abs)
                df, meta = read_pcs(f)
                return reduce_ehd2(df, meta)

            res = self.cache.get_or_compute(
                "optical", compute, sha=self.sha(f), name=f.name, window=d.window,
                sym=[d.symmetry_tolerance, d.symmetry_abs])
            self.optical[f] = res
            self.dest.write_csv(f"data/optical/{f.stem}_points.csv", res.points,
                                allow_missing=POINT_OPTIONAL)
            rows.append(res.summary())
        self.dest.write_csv("data/optical_summary.csv", pd.DataFrame(rows),
                            allow_missing=SUMMARY_OPTIONAL)
        self.data_summary["optical"] = {
            r["file"]: {"test": r["test"], "n_conditions": r["n_conditions"],
                        "symmetric": r["symmetric"]} for r in rows}

    def _reduce_visc(self) -> None:
        from torlab.parsers.viscometer import parse_calibration_constant, read_viscometer
        from torlab.reduce.viscometer import Calibration, calibrate, reduce_viscometer

        d = self.p.data.visc
        cal = None
        if d.calibration_constant is not None:
            cal = Calibration(parse_calibration_constant(d.calibration_constant),
                              source="protocol calibration_constant")
        elif d.reference:
            Ks, ns = [], []
            refs = [p for e in d.reference for p in e.resolved]
            for r in refs:
                rdf, rmeta = read_viscometer(r)
                c = calibrate(rdf, rmeta, tol=d.tol)
                Ks.append(c.K)
                ns.append(c.n_falls)
            w = np.asarray(ns, dtype=float)
            K = float(np.sum(w * np.asarray(Ks)) / w.sum())
            cal = Calibration(K, K_sd=float(np.std(Ks, ddof=1)) if len(Ks) > 1 else 0.0,
                              n_falls=int(w.sum()), source=", ".join(r.name for r in refs))
        for f in self.prog.track(self.lp.data_files("visc"), "viscometer: reducing logs"):
            def compute(f: Path = f) -> Any:
                df, meta = read_viscometer(f)
                return reduce_viscometer(df, meta, calibration=cal, tol=d.tol,
                                         density_model=d.density_model)

            res = self.cache.get_or_compute(
                "visc", compute, sha=self.sha(f), name=f.name, tol=d.tol,
                K=None if cal is None else cal.K, density_model=d.density_model)
            self.visc[f] = res
            self.dest.write_csv(f"data/visc/{f.stem}_steps.csv", res.steps)
        self.data_summary["visc"] = {
            f.name: {"calibration_constant_m3_s2": r.calibration.K, "n_falls": len(r.falls)}
            for f, r in self.visc.items()}

    # ------------------------------------------------------------------ fits
    def fit_all(self) -> None:
        f = self.p.fits
        if f.hpt_layers is not None:
            self._fit_hpt()
        for t in f.traction_layers:
            self._fit_traction(t)
        for lf in f.lubricants:
            self._fit_lubricant(lf)

    def _add_fit(self, name: str, res: Any, scene_dict: dict[str, Any]) -> None:
        self.param_sets[name] = scene_dict
        tab = res.table()
        for r in tab.to_dict("records"):
            self.fit_rows.append({"set": name, "kind": res.kind, **r})
        self.fit_results.append((name, res))
        self.fit_summary[name] = {"kind": res.kind, "params": dict(res.params),
                                  "ci95": {k: list(v) for k, v in res.ci95.items()},
                                  "residual_rms": res.residual_norm,
                                  "warnings": list(res.warnings)}
        from torlab.yamlio import dump_yaml

        if hasattr(res, "to_yaml_dict"):
            from torlab.outputs import safe_name

            self.dest.write_text(f"fits/{safe_name(name.replace(':', '_'))}.yaml",
                                 dump_yaml(_finite(res.to_yaml_dict())))

    def _fit_hpt(self) -> None:
        cfg = self.p.fits.hpt_layers
        layer = _fit_module("layer")
        groups: dict[str, list[Any]] = {}
        for r in self.hpt:
            m = r.meta
            label = m.product + (f"-{m.condition}" if m.condition else "")
            if cfg.products and label not in cfg.products and m.product not in cfg.products:
                continue
            groups.setdefault(label, []).append(r)
        if not groups:
            raise TorlabInputError("fits.hpt_layers: no HPT run of the listed products",
                                   key="fits.hpt_layers.products")

        def amount_ok(m: Any) -> bool:
            if m.applied_amount is None:
                return True
            return any(kind == m.applied_amount_kind and math.isclose(v, m.applied_amount,
                                                                      rel_tol=1e-6)
                       for kind, v in cfg.amounts)

        for label in self.prog.track(sorted(groups), "fits: HPT layers"):
            runs = [r for r in groups[label] if amount_ok(r.meta)]
            at_t = [r for r in runs if r.meta.temperature is None
                    or abs(r.meta.temperature - cfg.temperature) <= cfg.temperature_tolerance]
            if not at_t:
                self.notes.append(f"fits.hpt_layers: {label} has no run at the listed amounts "
                                  f"and {cfg.temperature:g} °C; no layer fitted")
                continue
            if len(at_t) > 1 and not cfg.joint:
                raise TorlabInputError(
                    f"{label}: {len(at_t)} runs match the amounts and temperature "
                    f"({', '.join(Path(r.meta.source).name for r in at_t)}); set joint: true to "
                    "fit them together, or list one amount", key="fits.hpt_layers.amounts")

            def compute(at_t: list[Any] = at_t) -> Any:
                res = layer.fit_layer_hpt(at_t, joint=True) if len(at_t) > 1 else \
                    layer.fit_layer_hpt(at_t[0])
                return res

            res = self.cache.get_or_compute("fit_hpt", compute,
                                            runs=[self.hpt_keys[id(r)] for r in at_t])
            scene_dict = res.to_scene_dict()
            others = [r for r in runs if all(r is not x for x in at_t) and r.meta.temperature is not None]
            if cfg.temperature_coefficients and others:
                tmod = _fit_module("temperature")
                curves = at_t[:1] + sorted(others, key=lambda r: r.meta.temperature)
                temps_K = [c.meta.temperature + 273.15 if c.meta.temperature is not None
                           else cfg.temperature + 273.15 for c in curves]

                def compute_t(curves: list[Any] = curves, temps_K: list[float] = temps_K,
                              tmod: Any = tmod) -> Any:
                    return tmod.fit_temperature_coefficients(curves, temps_K)

                tres = self.cache.get_or_compute(
                    "fit_temperature", compute_t, runs=[self.hpt_keys[id(c)] for c in curves],
                    temps=temps_K)
                tb = tres.to_scene_dict().get("boundary", {})
                scene_dict.setdefault("boundary", {}).update(
                    {k: v for k, v in tb.items() if k in ("mu_c1_T", "mu_c2_T")})
                self._add_fit(f"hpt-T:{label}", tres, tres.to_scene_dict())
                del self.param_sets[f"hpt-T:{label}"]
            self._add_fit(f"hpt:{label}", res, scene_dict)

    def _measured_traction(self, path: Path) -> list[tuple[float | None, np.ndarray, np.ndarray]]:
        """``(speed, creepage, mu)`` groups of a measured traction file (folded)."""
        if path in self.optical:
            res = self.optical[path]
            if res.folded is not None and len(res.folded):
                out = []
                fd = res.folded
                from torlab.reduce.optical import speed_groups

                g = speed_groups(fd["rolling_speed_m_s"].to_numpy())
                for k in np.unique(g):
                    sub = fd[g == k].sort_values("srr")
                    out.append((float(sub["rolling_speed_m_s"].mean()),
                                sub["srr"].to_numpy(dtype=float),
                                sub["traction_coefficient"].to_numpy(dtype=float)))
                return out
            raise TorlabInputError(f"{path.name} is a {res.test.replace('_', ' ')} test, not a "
                                   "traction test", path=path)
        for _, f, red in self.mtm:
            if f == path:
                if "traction" not in red.curves:
                    raise TorlabInputError("the file has no traction step", path=path)
                d = red.curves["traction"]
                out = []
                for st in dict.fromkeys(d["step"].tolist()):
                    sub = d[d["step"] == st].sort_values("srr")
                    v = float(sub["rolling_speed_m_s"].mean()) if "rolling_speed_m_s" in sub \
                        else None
                    out.append((v, np.abs(sub["srr"].to_numpy(dtype=float)),
                                np.abs(sub["traction_coefficient"].to_numpy(dtype=float))))
                return out
        raise TorlabInputError("not one of the protocol's optical or MTM files", path=path)

    def _measured_stribeck(self, path: Path) -> Any:
        import pandas as pd

        if path in self.optical:
            res = self.optical[path]
            p = res.points
            if "traction_coefficient" not in p or p["traction_coefficient"].isna().all():
                raise TorlabInputError("no traction coefficient measured", path=path)
            d = p[["rolling_speed_m_s", "srr", "traction_coefficient"]].dropna()
            return d.sort_values("rolling_speed_m_s").reset_index(drop=True)
        for _, f, red in self.mtm:
            if f == path:
                if "stribeck" not in red.curves:
                    raise TorlabInputError("the file has no Stribeck step", path=path)
                d = red.curves["stribeck"]
                return pd.DataFrame({"rolling_speed_m_s": d["rolling_speed_m_s"],
                                     "srr": d["srr"] if "srr" in d else np.nan,
                                     "traction_coefficient": d["traction_coefficient"]})
        raise TorlabInputError("not one of the protocol's optical or MTM files", path=path)

    def _fit_traction(self, t: Any) -> None:
        mod = _fit_module("traction")
        groups = self._measured_traction(t.measured.resolved)
        files = tuple(x.resolved for x in t.scene)
        xi = np.concatenate([g[1] for g in groups])
        mu = np.concatenate([g[2] for g in groups])
        speeds = [g[0] for g in groups if g[0] is not None]

        def compute() -> Any:
            from torlab.protocols.loader import deep_merge
            from torlab.scene import scene_from_dict

            sd = deep_merge({}, self.lp.scenes[files])
            if speeds:
                sd.setdefault("kinematics", {})["speed"] = float(np.median(speeds))
            return mod.fit_layer_traction(scene_from_dict(sd), xi, mu)

        res = self.cache.get_or_compute(
            "fit_traction", compute, measured=self.sha(t.measured.resolved),
            scene=self.lp.scenes[files], xi=xi, mu=mu)
        self._add_fit(f"traction:{t.name}", res, res.to_scene_dict())

    def _fit_lubricant(self, lf: Any) -> None:
        from torlab.fit.viscosity import fit_viscosity

        res = self.visc[lf.measured.resolved]
        p = res.falls["pressure_Pa"].to_numpy(dtype=float)
        eta = res.falls["viscosity_Pa_s"].to_numpy(dtype=float)
        T = float(res.falls["temperature_C"].mean()) if "temperature_C" in res.falls else None
        d = self.p.data.visc
        kw: dict[str, Any] = {"confidence": d.confidence, "temperature_C": T}
        if lf.law == "roelands":
            kw.update(eta0=d.eta0, fit_eta0=True if d.fit_eta0 else None)
        ft = fit_viscosity(p, eta, lf.law, **kw)
        name = f"lubricant:{lf.name}"
        self.param_sets[name] = {"lubricant": ft.to_scene_dict()}
        s = ft.summary()
        self.fit_summary[name] = {"kind": "viscosity", "law": lf.law,
                                  "params": {k: v for k, v in s.items()
                                             if isinstance(v, (int, float))},
                                  "warnings": list(ft.warnings)}
        from torlab.fit.result import viscosity_result

        cols = ("parameter", "value", "stderr", "ci95_low", "ci95_high", "unit", "status")
        for _, r in viscosity_result(ft).table().iterrows():
            row = {"set": name, "kind": "viscosity", **{c: r[c] for c in cols}}
            for c in ("stderr", "ci95_low", "ci95_high"):  # fixed eta0: no interval
                if not np.isfinite(row[c]):
                    row[c] = float("nan")
            self.fit_rows.append(row)
        from torlab.outputs import safe_name
        from torlab.yamlio import dump_yaml

        self.dest.write_text(f"fits/lubricant_{safe_name(lf.name)}.yaml",
                             dump_yaml({"lubricant": ft.to_scene_dict()}))

    # ------------------------------------------------------------------ scenes
    def scenes_for(self, refs: list[Any], params: list[str]) -> list[tuple[str, Any, dict]]:
        """``(set name, Scene, scene dict)`` for scene files with parameter sets applied.

        ``hpt:*`` gives one scene per fitted HPT product; other sets are applied in order.
        """
        from torlab.protocols.loader import deep_merge
        from torlab.scene import scene_from_dict

        files = tuple(x.resolved for x in refs)
        base = self.lp.scenes[files]
        star = [s[4:] for s in self.param_sets if s.startswith("hpt:")] \
            if "hpt:*" in params else [None]
        if "hpt:*" in params and not star:
            raise FitError("hpt:* names no fitted HPT layer (fits.hpt_layers fitted nothing)")
        out = []
        for prod in star:
            sd = deep_merge({}, base)
            for ps in params:
                name = f"hpt:{prod}" if ps == "hpt:*" else ps
                if name not in self.param_sets:
                    raise FitError(f"parameter set {name!r} was not fitted (see the fits: "
                                   "section and the notes above)")
                deep_merge(sd, self.param_sets[name])
            try:
                sc = scene_from_dict(sd, path=str(files[0]))
            except TorlabInputError as e:
                raise TorlabInputError(f"the scene with {', '.join(params)} applied is invalid: "
                                       f"{e}", path=files[0]) from None
            out.append((prod or "", sc, sd))
        return out

    # ------------------------------------------------------------------ reports
    def sections(self) -> list[Any]:
        r = self.p.reports
        out = []
        if r.amount is not None:
            out.append(self._amount())
        if r.time_test is not None:
            out.append(self._time_test())
        if r.traction is not None:
            out.append(self._traction())
        if r.stribeck is not None:
            out.append(self._stribeck())
        if r.film is not None:
            out.append(self._film())
        if self.fit_rows:
            out.append(self._fits_section())
        return out

    def _amount(self) -> Any:
        from torlab.reports.amount import amount_section, amount_series

        cfg = self.p.reports.amount
        series = amount_series(self.hpt, self.p.products, temperature=cfg.temperature,
                               temperature_tolerance=cfg.temperature_tolerance,
                               only=cfg.products or None)
        if cfg.products:
            have = set(series["product"]) if len(series) else set()
            missing = [p for p in cfg.products if p not in have
                       and not any(h.startswith(p + "-") for h in have)]
            if missing:
                raise TorlabInputError(f"no HPT run with an applied amount for "
                                       f"{', '.join(missing)}", key="reports.amount.products")
        return amount_section(series, cfg)

    def _time_test(self) -> Any:
        from torlab.model.predict import predict_traction
        from torlab.reports.timetest import time_test_section

        cfg = self.p.reports.time_test
        model = None
        if cfg.initial_drop is not None:
            idp = cfg.initial_drop
            ((_, sc, sd),) = self.scenes_for(idp.scene, idp.params)
            model = {"mu": {}, "creepage": {}, "load_share": {}, "modelled": {},
                     "scene": sc.name or idp.scene[0].path, "params": list(idp.params)}
            for label, _f, red in self.prog.track(self.mtm, "time tests: initial-drop model"):
                d = red.curves.get("timed")
                if d is None or not red.time_tests:
                    continue
                t0 = red.time_tests[0]
                after = d[(d["step"] == t0.step) & (d["step_time_s"] >= t0.application_time_s)]
                xi = idp.creepage
                if xi is None:
                    if "srr" not in after or after["srr"].isna().all():
                        raise TorlabInputError(
                            f"{label}: the timed step logs no SRR; give "
                            "reports.time_test.initial_drop.creepage", key="reports.time_test")
                    xi = float(f"{np.median(np.abs(after['srr'].dropna())):.3g}")
                v = float(np.median(after["rolling_speed_m_s"].dropna())) \
                    if "rolling_speed_m_s" in after and after["rolling_speed_m_s"].notna().any() \
                    else sc.kinematics.speed
                sdv = dict(sd, kinematics={**sd.get("kinematics", {}), "speed": v})

                def compute(sdv: dict = sdv, xi: float = xi) -> dict[str, Any]:
                    from torlab.scene import scene_from_dict

                    pred = predict_traction(scene_from_dict(sdv), np.array([xi]))
                    row = pred.table.iloc[0]
                    return {"mu": float(abs(row["mu"])),
                            "load_share": float(row.get("load_share_asperity", 1.0)),
                            "modelled": list(pred.modelled)}

                res = self.cache.get_or_compute("initial_drop_v2", compute, scene=sdv,
                                                creepage=xi)
                model["mu"][label] = res["mu"]
                model["load_share"][label] = res["load_share"]
                model["modelled"][label] = res["modelled"]
                model["creepage"][label] = xi
        return time_test_section([(lab, red) for lab, _f, red in self.mtm], cfg, model)

    def _traction(self) -> Any:
        import pandas as pd

        from torlab.model.plausible import result_notes
        from torlab.model.predict import classify_trend, predict_traction
        from torlab.reports.traction import TractionCurve, traction_section

        cfg = self.p.reports.traction
        xi = np.asarray(cfg.creepage, dtype=float)
        curves: list[TractionCurve] = []
        measured: list[TractionCurve] = []
        jobs = []
        for ci, c in enumerate(cfg.curves):
            groups = self._measured_traction(c.measured.resolved) if c.measured else []
            if c.measured is not None:
                for v, x, m in groups:
                    lab = c.measured.path.rsplit("/", 1)[-1]
                    lab = f"{lab} @ {v:.3g} m/s" if v is not None and len(groups) > 1 else lab
                    measured.append(TractionCurve(
                        label=f"measured {lab}" if c.scene else c.label + (
                            f" @ {v:.3g} m/s" if v is not None and len(groups) > 1 else ""),
                        kind="measured",
                        table=pd.DataFrame({"creepage": x, "mu": m}),
                        trend=classify_trend(x, m, tolerance=cfg.trend_tolerance),
                        source=str(c.measured.path), speed_m_s=v,
                        group=f"{ci}:{v:.3g}" if v is not None and c.speeds == "measured"
                        else f"{ci}:"))
            if not c.scene:
                continue
            if c.speeds is None:
                speeds: list[float | None] = [None]
            elif c.speeds == "measured":
                speeds = [g[0] for g in groups if g[0] is not None] or [None]
            else:
                speeds = list(c.speeds)
            for setname, sc, sd in self.scenes_for(c.scene, c.params):
                for v in speeds:
                    jobs.append((ci, c, setname, sc, sd, v, len(speeds) > 1))
        for ci, c, setname, sc, sd, v, many in self.prog.track(jobs, "traction: predicting curves"):
            sdv = sd if v is None else dict(sd, kinematics={**sd.get("kinematics", {}),
                                                            "speed": v})

            def compute(sdv: dict = sdv) -> Any:
                from torlab.scene import scene_from_dict

                return predict_traction(scene_from_dict(sdv), xi,
                                        trend_tolerance=cfg.trend_tolerance)

            pred = self.cache.get_or_compute("traction", compute, scene=sdv, creepage=xi,
                                             tol=cfg.trend_tolerance)
            label = c.label.replace("{set}", setname)
            speed = sc.kinematics.speed if v is None else v
            if many:
                label += f" @ {speed:.3g} m/s"
            self.notes += [f"traction {label}: {n}" for n in result_notes(pred.table)]
            curves.append(TractionCurve(
                label=label, kind="model", table=pred.table, trend=pred.trend,
                source=" + ".join([*(x.path for x in c.scene), *c.params]).replace(
                    "hpt:*", f"hpt:{setname}"), speed_m_s=speed,
                modelled=pred.modelled,
                group=f"{ci}:{speed:.3g}" if c.speeds == "measured" else
                (f"{ci}:" if len(set(self.param_sets)) <= 1 or "hpt:*" not in c.params
                 else f"{ci}:{setname}")))
            if sc.boundary is not None:
                curves[-1].boundary = sc.boundary.model_dump()
        return traction_section(curves + measured, cfg)

    def _stribeck(self) -> Any:
        from torlab.model.mixed import predict_stribeck
        from torlab.reports.stribeck import StribeckCurve, stribeck_section

        cfg = self.p.reports.stribeck
        v = np.asarray(cfg.speed, dtype=float)
        curves: list[StribeckCurve] = []
        for c in self.prog.track(cfg.curves, "Stribeck: predicting curves"):
            meas = self._measured_stribeck(c.measured.resolved) if c.measured else None
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
            for setname, _sc, sd in self.scenes_for(c.scene, c.params):
                def compute(sd: dict = sd, xi: float = xi) -> Any:
                    from torlab.scene import scene_from_dict

                    return predict_stribeck(scene_from_dict(sd), v, xi)

                pred = self.cache.get_or_compute("stribeck", compute, scene=sd, speed=v,
                                                 creepage=xi)
                from torlab.model.plausible import result_notes

                self.notes += [f"Stribeck {c.label.replace('{set}', setname)}: {n}"
                               for n in result_notes(pred.table)]
                curves.append(StribeckCurve(
                    label=c.label.replace("{set}", setname), table=pred.table, creepage=xi,
                    measured=meas, measured_label="" if c.measured is None else
                    c.measured.path.rsplit("/", 1)[-1] + " (measured)",
                    source=" + ".join([*(x.path for x in c.scene), *c.params]),
                    modelled=pred.modelled))
        return stribeck_section(curves)

    def _film(self) -> Any:
        from torlab.model.mixed import predict_stribeck
        from torlab.reports.stribeck import film_section

        cfg = self.p.reports.film
        measured, models, fits = [], [], []
        for c in cfg.curves:
            d = None
            if c.measured is not None:
                res = self.optical.get(c.measured.resolved)
                if res is None or "film_thickness_m" not in res.points or \
                        res.points["film_thickness_m"].isna().all():
                    raise TorlabInputError("no film thickness measured",
                                           path=c.measured.resolved, key="reports.film")
                d = res.points[["rolling_speed_m_s", "film_thickness_m"]].dropna()
                d = d[d["rolling_speed_m_s"] > 0].sort_values("rolling_speed_m_s")
                measured.append((c.label, d))
            scs = self.scenes_for(c.scene, c.params) if c.scene else []
            for setname, _sc, sd in scs:
                lo, hi = (float(d["rolling_speed_m_s"].min()), float(d["rolling_speed_m_s"].max())) \
                    if d is not None else (0.01, 3.0)
                grid = np.geomspace(lo, hi, 40)

                def compute(sd: dict = sd, grid: np.ndarray = grid) -> Any:
                    from torlab.scene import scene_from_dict

                    return predict_stribeck(scene_from_dict(sd), grid, 0.0)

                pred = self.cache.get_or_compute("film_model", compute, scene=sd, speed=grid)
                models.append((c.label.replace("{set}", setname), pred.table))
            if d is not None:
                film = _fit_module("film")
                sc0 = scs[0][1] if scs else None
                fr = film.fit_film_thickness(d["rolling_speed_m_s"].to_numpy(),
                                             d["film_thickness_m"].to_numpy(), scene=sc0,
                                             min_speed=cfg.min_speed or None)
                fits.append((c.label, fr))
                self.fit_summary[f"film:{c.label}"] = {"kind": fr.kind, "params": dict(fr.params),
                                                      "ci95": {k: list(v) for k, v in
                                                               fr.ci95.items()},
                                                      "warnings": list(fr.warnings)}
        return film_section(measured, models, fits)

    def _fits_section(self) -> Any:
        import pandas as pd

        from torlab.outputs import safe_name
        from torlab.reports.html import Figure, Section, Table

        df = pd.DataFrame(self.fit_rows)
        figs = []
        try:
            from torlab.reports.fit import fit_figure
        except ImportError:
            fit_figure = None
        if fit_figure is not None:
            for name, res in self.fit_results:
                figs.append(Figure(f"fit_{safe_name(name.replace(':', '_'))}", fit_figure(res),
                                   f"{name}: data against the fitted model, residuals"))
        warn = [f"{name}: {w}" for name, res in self.fit_results for w in res.warnings]
        show = {"set": ("set", ""), "parameter": ("parameter", ""), "value": ("value", ".5g"),
                "stderr": ("stderr", ".3g"), "95 % low": ("ci95_low", ".5g"),
                "95 % high": ("ci95_high", ".5g"), "unit": ("unit", ""),
                "status": ("status", "")}
        return Section(
            key="fits", title="Fitted parameter sets", paragraphs=[
                "Parameters identified from the protocol's data (torlab.fit): the HPT layers "
                "(thesis Eqs. 5.24-5.29) per product, temperature coefficients, layers from "
                "measured traction curves and viscosity laws; each set is also written as a "
                "scene parameter file in fits/ for 'torlab predict'."],
            figures=figs, tables=[Table("parameters", df, "Fitted parameters", show,
                                        allow_missing=("value", "stderr", "ci95_low",
                                                       "ci95_high"))],
            summary=_finite(self.fit_summary), notes=warn)


# --------------------------------------------------------------------------- entry point
def run_protocol(protocol: str | os.PathLike[str] | Any, out: str | os.PathLike[str], *,
                 force: bool = False, command: str = "", progress: bool = False,
                 cache: bool = True) -> RunResult:
    """Run a protocol from raw logs to reports (``torlab run``).

    Parameters
    ----------
    protocol
        Protocol file, or a :class:`~torlab.protocols.loader.LoadedProtocol`.
    out
        Output folder; refused if it holds earlier results unless ``force``.
    force
        Replace torlab's earlier results in ``out`` (its cache is reused).
    command
        Command line for the manifest and the report.
    progress
        Show rich progress bars.
    cache
        Reuse and store intermediate results in ``out/.cache``.

    Returns
    -------
    RunResult

    Raises
    ------
    ValidationErrors
        The protocol is invalid (every problem listed).
    TorlabInputError, FitError, NumericalError
        A data file, fit or prediction fails (nothing is written then).
    """
    from torlab import __version__
    from torlab.outputs import OutputDir
    from torlab.protocols.cache import CACHE_DIR, ResultCache, file_sha256
    from torlab.protocols.loader import LoadedProtocol, load_protocol
    from torlab.reports.html import render_html, render_markdown, write_sections
    from torlab.reports.plotting import pyplot

    t0 = time.perf_counter()
    lp = protocol if isinstance(protocol, LoadedProtocol) else load_protocol(protocol)
    inputs = lp.input_files()
    dest = OutputDir(out, force=force, inputs=inputs, command=command,
                     keep=[CACHE_DIR] if cache else [])
    pyplot()
    try:
        rc = ResultCache(dest.staging / CACHE_DIR if cache else None, register=dest.path)
        with _Progress(progress) as prog:
            run = _Run(lp, dest, rc, prog)
            run.reduce_all()
            run.fit_all()
            sections = run.sections()
        write_sections(dest, sections)
        base = lp.base
        prov = {
            "torlab_version": __version__,
            "protocol_file": lp.path.name if lp.path else "<text>",
            "protocol_sha256": file_sha256(lp.path) if lp.path else "",
            "command": command,
            "inputs": {_rel(p, base): file_sha256(p) for p in inputs if lp.path is None
                       or p != lp.path},
        }
        p = lp.protocol
        summary = {
            "torlab_version": __version__,
            "protocol": {"name": p.name, "title": p.title, "version": p.version,
                         "file": prov["protocol_file"], "sha256": prov["protocol_sha256"]},
            "inputs": prov["inputs"],
            "data": _finite(run.data_summary),
            "fits": _finite(run.fit_summary),
            "reports": {s.key: _finite(s.summary) for s in sections if s.key != "fits"},
            "notes": run.notes + [n for s in sections for n in s.notes],
        }
        title = p.title or p.name
        intro = [p.description] if p.description else []
        intro.append(f"Protocol {prov['protocol_file']} ({p.name}), torlab {__version__}.")
        if run.notes:
            intro += [f"Note: {n}" for n in run.notes]
        dest.write_text("report.html", render_html(title, intro, sections, prov))
        dest.write_text("report.md", render_markdown(title, intro, sections, prov))
        rc.prune()
        summary["run"] = {"seconds": round(time.perf_counter() - t0, 2), "cache_hits": rc.hits,
                          "cache_misses": rc.misses, "command": command}
        dest.write_json("summary.json", summary)
    except BaseException:
        dest.abort()
        raise
    dest.commit()
    return RunResult(out=Path(out), summary=summary, sections=[s.key for s in sections],
                     cache_hits=rc.hits, cache_misses=rc.misses, notes=summary["notes"])


def _rel(p: Path, base: Path) -> str:
    try:
        return os.path.relpath(p, base)
    except ValueError:  # another drive (Windows)
        return str(p)

