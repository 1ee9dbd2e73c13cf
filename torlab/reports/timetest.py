"""Time-test report (Paper B): the metrics table and the curves per composition.

Each timed MTM step is evaluated by :func:`torlab.reduce.mtm.time_test_metrics`
(thesis 5.3.2, Fig. 5.9: application moment, minimum, time to recover, mean
after recovery, time below the low-adhesion threshold).  The report puts every
composition's curve on one time axis (time since the application), marks the
optimal band and the threshold, and -- when the protocol asks for it -- the
modelled coefficient of the freshly lubricated contact at the test's SRR
(``initial_drop``: a scene with the fitted lubricant and layer,
:func:`torlab.model.predict.predict_traction`), next to the measured minimum.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from torlab.reports.html import Figure, Section, Table
from torlab.reports.plotting import subplots
from torlab.reports.render import plot

__all__ = ["time_test_section", "time_tests_figure"]

#: the intervals a time test's figure draws (:func:`torlab.reports.mtm.time_test_figure`)
_FIGURE_INTERVALS = ("minimum_low95", "minimum_high95", "recovery_time_low95",
                     "recovery_time_high95", "mean_after_recovery_low95",
                     "mean_after_recovery_high95")


def time_test_section(reductions: list[tuple[str, Any]], cfg: Any,
                      model: dict[str, Any] | None = None,
                      evidence: dict[tuple[str, int], dict[str, Any]] | None = None,
                      repeats: dict[str, Any] | None = None) -> Section:
    """The time-test report.

    Parameters
    ----------
    reductions
        ``(label, PcsReduction)`` per MTM file, with time tests computed.
    cfg
        The protocol's ``reports.time_test``.
    model
        Initial-drop model: ``{"mu": {label: mu}, "creepage": {label: xi},
        "scene": name, "params": [...]}`` or None.
    evidence
        ``(label, step)`` -> intervals and verdict probabilities of the figures
        (:func:`torlab.reduce.time_test_uncertainty.time_test_uncertainty`);
        the verdicts "recovered" and "in band" are then called only at the
        protocol's ``probability``.
    repeats
        The test-to-test scatter of repeated compositions
        (:func:`torlab.reduce.time_test_uncertainty.apply_repeats`, already applied to
        ``evidence``), or None.
    """
    import pandas as pd

    from torlab.errors import TorlabInputError
    from torlab.reports.mtm import time_test_figure

    rows = []
    figs: list[Figure] = []
    band = tuple(cfg.band)
    evidence = evidence or {}
    prob = getattr(cfg, "probability", 0.9)
    for label, red in reductions:
        for t in red.time_tests:
            ev = evidence.get((label, t.step), {})
            row = {"composition": label, "file": red.label, "step": t.step,
                   "application_time_s": t.application_time_s,
                   "application_source": t.application_source,
                   "pre_application_mean": t.pre_application_mean, "minimum": t.minimum,
                   "minimum_after_application_s": t.minimum_time_s - t.application_time_s,
                   "recovered": "yes" if t.recovered else "no",
                   "recovery_time_s": t.recovery_time_s,
                   "mean_after_recovery": t.mean_after_recovery,
                   "sd_after_recovery": t.sd_after_recovery, "plateau": t.plateau,
                   "time_below_threshold_s": t.time_below_threshold_s, "threshold": t.threshold,
                   "in_band": "" if not t.recovered else
                   ("yes" if band[0] <= t.mean_after_recovery <= band[1] else "no"),
                   "notes": "; ".join(t.notes)}
            for k in ("mean_after_recovery_se", "mean_after_recovery_low95",
                      "mean_after_recovery_high95", "p_in_band", "minimum_low95",
                      "minimum_high95", "recovery_time_low95", "recovery_time_high95",
                      "time_below_threshold_low95", "time_below_threshold_high95",
                      "p_recovered"):
                row[k] = ev.get(k, float("nan"))
            if ev:
                row["in_band_verdict"] = ev.get("in_band_verdict", "") if t.recovered else ""
                row["recovered_verdict"] = ev.get("recovered_verdict", "")
            if model is not None:
                row["model_initial_mu"] = model["mu"].get(label, float("nan"))
                row["model_initial_mu_low95"] = model.get("mu_low95", {}).get(label, float("nan"))
                row["model_initial_mu_high95"] = model.get("mu_high95", {}).get(label, float("nan"))
                row["model_creepage"] = model["creepage"].get(label, float("nan"))
            rows.append(row)
        if red.time_tests:
            marks = {t.step: {k: v for k, v in evidence.get((label, t.step), {}).items()
                              if k in _FIGURE_INTERVALS} for t in red.time_tests}
            figs.append(Figure(f"time_test_{_safe(label)}",
                               plot(time_test_figure, red, red.time_tests,
                                    marks if any(marks.values()) else None),
                               f"{label}: coefficient against step time with the time-test "
                               "figures marked (thesis Fig. 5.9)"
                               + (", with their 95 % intervals" if evidence else "")))
    if not rows:
        raise TorlabInputError("reports.time_test: no timed step with a traction coefficient in "
                               "the MTM files", key="reports.time_test")
    table = pd.DataFrame(rows)
    figs.insert(0, Figure("time_tests", plot(time_tests_figure, reductions, cfg, model),
                          "Coefficient against time since the application, every composition; "
                          "optimal band shaded, low-adhesion threshold dotted"
                          + ("; dashed: modelled coefficient of the lubricated contact "
                             "(initial drop)" if model else "")))
    show = {"composition": ("composition", ""), "application (s)": ("application_time_s", ".0f"),
            "minimum": ("minimum", ".4f"), "recovery (s)": ("recovery_time_s", ".0f"),
            "mean after recovery": ("mean_after_recovery", ".4f"),
            "sd": ("sd_after_recovery", ".4f"),
            f"time μ<{rows[0]['threshold']:g} (s)": ("time_below_threshold_s", ".0f"),
            "in band": ("in_band", "")}
    if evidence:
        show = {"composition": ("composition", ""),
                "application (s)": ("application_time_s", ".0f"),
                "minimum": ("minimum", ".4f"), "min 95 %": ("minimum_low95", ".4f"),
                "min 95 % high": ("minimum_high95", ".4f"),
                "recovery (s)": ("recovery_time_s", ".0f"),
                "rec. 95 % low": ("recovery_time_low95", ".0f"),
                "rec. 95 % high": ("recovery_time_high95", ".0f"),
                "P(recovered)": ("p_recovered", ".3f"),
                "mean after recovery": ("mean_after_recovery", ".4f"),
                "mean 95 % low": ("mean_after_recovery_low95", ".4f"),
                "mean 95 % high": ("mean_after_recovery_high95", ".4f"),
                f"time μ<{rows[0]['threshold']:g} (s)": ("time_below_threshold_s", ".0f"),
                "time 95 % low": ("time_below_threshold_low95", ".0f"),
                "time 95 % high": ("time_below_threshold_high95", ".0f"),
                "P(in band)": ("p_in_band", ".3f"), "in band": ("in_band_verdict", "")}
    if model is not None:
        show["model μ (initial drop)"] = ("model_initial_mu", ".4f")
    paragraphs = [
        "Time tests after application (thesis 5.3.2, Fig. 5.9): the application moment, the "
        "minimum of the running-median coefficient, the time to recover (90 % of the way from "
        "the minimum back to the plateau unless the protocol sets a level), the mean after "
        "recovery (the figure Paper B reports) and the time below the low-adhesion threshold.",
        f"Optimal band {band[0]:g}–{band[1]:g}.",
    ]
    if evidence:
        ev0 = next(iter(evidence.values()))
        paragraphs.append(
            "Evidence: every figure comes with a 95 % interval and every verdict with its "
            f"probability; a verdict is called at a probability of at least {prob:g}, else "
            "'undetermined'. The mean after recovery's interval is Student t on its "
            "autocorrelation-robust standard error (batch means); the other intervals and "
            f"P(recovered) come from a block bootstrap ({ev0.get('replicates', 0)} replicates) "
            "of the record's scatter about its running median. They hold "
            f"{ev0.get('basis', 'the record own noise')}: repeated tests measure that.")
        paragraphs.append(_repeats_sentence(repeats, band, prob))
        for r in rows:
            paragraphs.append(_evidence_sentence(r, band, prob))
    if model is not None:
        paragraphs.append(
            f"Initial drop: coefficient of the lubricated contact modelled on scene "
            f"'{model['scene']}' with {', '.join(model['params']) or 'its own parameters'} at "
            "each test's SRR (mixed lubrication, Eq. 5.47), to compare with the measured "
            "minimum.")
        paragraphs.extend(_initial_drop_comparison(rows, model))
    summary = {"band": list(band), "compositions": {}}
    for r in rows:
        k = r["composition"] if sum(x["composition"] == r["composition"] for x in rows) == 1 \
            else f"{r['composition']} step {r['step']}"
        summary["compositions"][k] = {
            c: (None if isinstance(r[c], float) and not math.isfinite(r[c]) else r[c])
            for c in ("application_time_s", "minimum", "recovered", "recovery_time_s",
                      "mean_after_recovery", "sd_after_recovery", "plateau",
                      "time_below_threshold_s", "in_band", "model_initial_mu",
                      "model_initial_mu_low95", "model_initial_mu_high95",
                      "mean_after_recovery_se", "mean_after_recovery_low95",
                      "mean_after_recovery_high95", "p_in_band", "in_band_verdict",
                      "minimum_low95", "minimum_high95", "recovery_time_low95",
                      "recovery_time_high95", "time_below_threshold_low95",
                      "time_below_threshold_high95", "p_recovered", "recovered_verdict")
            if c in r}
    if evidence:
        summary["probability"] = prob
        summary["test_to_test"] = _repeats_summary(repeats)
    optional = tuple(c for c in table.columns if c not in ("composition", "file", "step"))
    return Section(key="time_test", title="Time tests after application (Paper B)",
                   paragraphs=paragraphs, figures=figs,
                   tables=[Table("time_tests", table, "Time-test metrics per composition", show,
                                 allow_missing=optional)],
                   summary=summary)


def _repeats_summary(rep: dict[str, Any] | None) -> dict[str, Any]:
    if not rep or not rep.get("repeated"):
        return {"estimated": False, "why": "no composition was repeated"}

    def clean(x: Any) -> Any:
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        return None if isinstance(x, float) and not math.isfinite(x) else x

    return {"estimated": True, **clean({k: rep[k] for k in ("repeated", "figures",
                                                           "compositions")})}


def _repeats_sentence(rep: dict[str, Any] | None, band: tuple[float, float],
                      prob: float) -> str:
    """What the intervals hold: the record alone, or the record and the test-to-test scatter."""
    if not rep or not rep.get("repeated"):
        return ("No composition was repeated (reports.time_test.repeats lists none): every "
                "interval and verdict holds for its record only; the scatter from test to "
                "test (a new track, a new application) is not estimated and may be larger.")
    f = rep["figures"].get("mean_after_recovery", {})
    comps = ", ".join(f"{c} ({n} tests)" for c, n in rep["repeated"].items())
    out = (f"Repeated compositions: {comps}. The scatter of one test about its composition's "
           "mean, pooled over them (one-way random effects")
    if f and math.isfinite(f.get("sd_test", math.nan)):
        out += (f", {f['dof']} degrees of freedom): mean after recovery {f['sd_test']:.3g} "
                f"(the records' own standard error {f['sd_record']:.3g}, so test to test "
                f"{f['sd_between']:.3g})")
    else:
        out += ")"
    out += ("; it replaces the record's own uncertainty in every interval and verdict where it "
            "is larger (the same scatter assumed for every composition).")
    for c, e in rep.get("compositions", {}).items():
        m = e.get("mean_after_recovery")
        if m:
            v = m.get("in_band_verdict", "")
            out += (f" {c}: mean after recovery over {m['n']} tests {m['mean']:.4f} "
                    f"[{m['low95']:.4f}, {m['high95']:.4f}], "
                    + (f"{v} {band[0]:g}–{band[1]:g} (P = {m['p_in_band']:.2f})."
                       if v != "undetermined" else
                       f"in the band: undetermined (P = {m['p_in_band']:.2f} < {prob:g} "
                       "either way)."))
    return out


def _safe(s: str) -> str:
    """A figure-name part made from a label (:func:`torlab.files.plain_name`: at most 80
    characters; the protocol checks before the run that labels make different names)."""
    from torlab.files import plain_name

    return plain_name(s)


def _iv(r: dict[str, Any], key: str, fmt: str) -> str:
    lo, hi = r.get(f"{key}_low95", float("nan")), r.get(f"{key}_high95", float("nan"))
    if not (isinstance(lo, float) and math.isfinite(lo) and math.isfinite(hi)):
        return ""
    return f" [{lo:{fmt}}, {hi:{fmt}}]"


def _evidence_sentence(r: dict[str, Any], band: tuple[float, float], prob: float) -> str:
    """One composition's figures with their intervals and verdicts with probabilities."""
    out = [f"{r['composition']}: minimum {r['minimum']:.4f}{_iv(r, 'minimum', '.4f')}"]
    thr = r["threshold"]
    out.append(f"time below {thr:g} {r['time_below_threshold_s']:.0f} s"
               f"{_iv(r, 'time_below_threshold', '.0f')} s")
    p_rec = r.get("p_recovered", float("nan"))
    verdict = r.get("recovered_verdict", "")
    if math.isfinite(p_rec):
        out.append(f"{verdict or 'recovery'} (P(recovered) = {p_rec:.2f})")
    if r["recovered"] == "yes" and math.isfinite(r["recovery_time_s"]):
        out.append(f"time to recover {r['recovery_time_s']:.0f} s{_iv(r, 'recovery_time', '.0f')} s")
        p_in = r.get("p_in_band", float("nan"))
        mean = (f"mean after recovery {r['mean_after_recovery']:.4f}"
                f"{_iv(r, 'mean_after_recovery', '.4f')}")
        if math.isfinite(p_in):
            v = r.get("in_band_verdict", "")
            mean += (f", {v} {band[0]:g}–{band[1]:g} (P(in band) = {p_in:.2f})"
                     if v != "undetermined" else
                     f", in the band {band[0]:g}–{band[1]:g}: undetermined (P = {p_in:.2f} < "
                     f"{prob:g} either way)")
        out.append(mean)
    return "; ".join(out) + "."


def time_tests_figure(reductions: list[tuple[str, Any]], cfg: Any,
                      model: dict[str, Any] | None) -> Any:
    """Every composition's coefficient against time since its application, on one axis
    (:class:`~torlab.reports.render.Plot` function)."""
    from torlab.reports.plotting import PALETTE, axis_label, decimate, legend, pixel_columns

    fig, ax = subplots(figsize=(7.0, 4.6))
    band = cfg.band
    ax.axhspan(band[0], band[1], color="#d9ead3", alpha=0.6, lw=0,
               label=f"optimal band {band[0]:g}–{band[1]:g}")
    thr = None
    i = 0
    for label, red in reductions:
        if "timed" not in red.curves:
            continue
        d = red.curves["timed"]
        by_step = {t.step: t for t in red.time_tests}
        for st in dict.fromkeys(d["step"].tolist()):
            r = by_step.get(st)
            if r is None:
                continue
            sel = d["step"].to_numpy() == st
            t = d.loc[sel, "step_time_s"].to_numpy() - r.application_time_s
            color = PALETTE[i % len(PALETTE)]
            ax.plot(*decimate(t, d.loc[sel, "traction_coefficient"].to_numpy(),
                              pixel_columns(ax)), lw=0.8, color=color, label=label)
            ax.plot([r.minimum_time_s - r.application_time_s], [r.minimum], "o", color=color,
                    ms=4)
            if model is not None and math.isfinite(model["mu"].get(label, np.nan)):
                ax.axhline(model["mu"][label], color=color, ls="--", lw=0.9,
                           label="model: lubricated contact" if i == 0 else None)
            thr = r.threshold
            i += 1
    if thr is not None:
        ax.axhline(thr, color="k", ls=":", lw=0.8, label=f"threshold {thr:g}")
    ax.set_xlabel(axis_label("time since application", "t", "s"))
    ax.set_ylabel(axis_label("traction coefficient", "μ"))
    legend(ax)
    ax.set_title("Time tests after application (dots: minimum)")
    return fig


def _initial_drop_comparison(rows: list[dict[str, Any]], model: dict[str, Any]) -> list[str]:
    """What the initial-drop model included, and how far it is from the measured minima."""
    out = []
    # each test's speed is its own scene: list every distinct part once, in order
    parts = list(dict.fromkeys(
        m for per_test in model.get("modelled", {}).values() for m in per_test
        if m.split(":")[0] in ("EHL film", "boundary friction", "regimes")))
    if parts:
        out.append("Modelled: " + "; ".join(parts) + ".")
    ratios = [r["minimum"] / r["model_initial_mu"] for r in rows
              if math.isfinite(r.get("model_initial_mu", float("nan")))
              and r.get("model_initial_mu", 0) > 0 and math.isfinite(r["minimum"])]
    bands = [(r["model_initial_mu_low95"], r["model_initial_mu_high95"]) for r in rows
             if math.isfinite(r.get("model_initial_mu_low95", float("nan")))]
    if bands:
        out.append(f"The modelled coefficient's 95 % band from the fitted layer's and viscosity "
                   f"law's uncertainty: {min(b[0] for b in bands):.3g}–"
                   f"{max(b[1] for b in bands):.3g} over the tests.")
    if ratios:
        lo, hi = min(ratios), max(ratios)
        if lo > 2.0 or hi < 0.5:
            word = "below" if lo > 2.0 else "above"
            f_lo, f_hi = (lo, hi) if lo > 2.0 else (1 / hi, 1 / lo)
            span = f"{f_lo:.2g}" if abs(f_hi - f_lo) < 0.05 * f_lo else f"{f_lo:.2g}–{f_hi:.2g}"
            out.append(
                f"The modelled coefficient is {span} times {word} the measured minimum for "
                "every composition: with these inputs the model does not reproduce the depth "
                "of the drop (a full film whose traction follows a viscosity law fitted at "
                "viscometer pressures is the usual cause; see docs/reports.md, time test).")
        else:
            out.append(f"Measured minimum / modelled coefficient: {lo:.2g}–{hi:.2g}.")
    return out
