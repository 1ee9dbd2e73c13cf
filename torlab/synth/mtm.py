"""Synthetic MTM time tests after application: PCS ``MTM311 Test Data File`` exports.

The design follows Paper B (thesis 5.3.2, Fig. 5.9): the MTM runs at 800 MPa
(about 18 N with the 19.05 mm ball), 2 % SRR and 1 m/s; a TOR lubricant
composition (Tab. 5.3: ester oil with bentonite, friction-modifier particles,
solid lubricants; commercial TOR A) is applied to the running contact and the
coefficient followed for 20 minutes.  Each virtual run has one ``BOD_TIMED``
step at 1 Hz: a dry stretch (``mu_dry``), the application at
``application_time_s``, a fast drop (time constant ``drop_tau_s``) to
``mu_min``, a dwell, an exponential recovery (``recovery_tau_s``) to
``mu_plateau`` -- or, for an over-application, no recovery at all:

    ``mu(t) = mu_min + (mu_plateau - mu_min) (1 - exp(-max(0, t - t_a - dwell) / tau_r))
    + (mu_dry - mu_min) exp(-(t - t_a) / tau_d)``  for ``t >= t_a``,

plus white noise, a slow Ornstein-Uhlenbeck fluctuation and the instrument's
4-decimal rounding.  The files reproduce the quirks of real exports (CRLF line
ends, ``°C`` in the column header, the duplicated ``Step Time`` and empty
header cells, rows with many empty fields, ``key<TAB>value`` and
``key = value unit`` metadata, dd/mm/yyyy dates).

``truth.yaml`` holds per file the generating parameters and the true figures
in the definitions of :mod:`torlab.reduce.mtm`, in closed form from the
noise-free curve: application time, minimum, 90 % recovery time
(``dwell + tau_r ln 10``), plateau and the time below 0.15.

The data are synthetic: realistic in form, not measurements.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from datetime import datetime, timedelta
from typing import Any

import numpy as np

__all__ = ["MtmTimeTest", "paper_b_time_tests", "simulate_time_test", "true_figures",
           "write_mtm_export", "write_mtm_sample_data"]


@dataclass(frozen=True)
class MtmTimeTest:
    """One virtual time test after application (see the module docstring)."""

    name: str
    composition: str
    amount_uL: float
    mu_dry: float
    mu_min: float
    mu_plateau: float
    dwell_s: float
    recovery_tau_s: float
    recovered: bool = True
    application_time_s: float = 60.0
    drop_tau_s: float = 2.0
    duration_s: float = 1260.0
    noise_sd: float = 0.003
    ou_sd: float = 0.004
    ou_tau_s: float = 20.0
    load_N: float = 18.0
    rolling_speed_m_s: float = 1.0
    srr: float = 0.02
    temperature_C: float = 30.0
    seed: int = 0


def paper_b_time_tests(seed: int = 2020) -> list[MtmTimeTest]:
    """Five virtual runs after Paper B: compositions of Tab. 5.3 and amounts.

    * base medium (ester oil + bentonite), 5 uL: drop to 0.03, recovery to 0.17;
    * base + Al2O3 friction-modifier particles, 5 uL: the same drop and recovery time, to a
      higher level, 0.22 (the hard particles set the friction, but cannot lift it out of the
      initial drop any sooner: thesis chapter 6, H2.2 falsified);
    * base + MoS2 solid lubricant, 5 uL: recovery to the base's level, 0.17 (no significant
      reduction of the effective coefficient: thesis chapter 6);
    * commercial TOR A, 5 uL: slower recovery to 0.19;
    * commercial TOR A, 20 uL (over-application): stays at about 0.03.
    """
    rng = np.random.default_rng(seed)
    s = [int(v) for v in rng.integers(0, 2**31 - 1, size=5)]
    return [
        MtmTimeTest("mtm_base_5uL", "ester oil + bentonite (base medium)", 5.0, 0.45, 0.030,
                    0.170, 60.0, 90.0, seed=s[0]),
        MtmTimeTest("mtm_base-Al2O3_5uL", "base medium + 10 um Al2O3 friction modifier", 5.0,
                    0.46, 0.031, 0.220, 60.0, 90.0, seed=s[1]),
        MtmTimeTest("mtm_base-MoS2_5uL", "base medium + MoS2 solid lubricant", 5.0, 0.44, 0.027,
                    0.170, 70.0, 100.0, seed=s[2]),
        MtmTimeTest("mtm_TOR-A_5uL", "commercial TOR A", 5.0, 0.45, 0.040, 0.190, 120.0, 150.0,
                    seed=s[3]),
        MtmTimeTest("mtm_TOR-A_20uL", "commercial TOR A (over-application)", 20.0, 0.45, 0.030,
                    0.030, 0.0, 1.0, recovered=False, seed=s[4]),
    ]


def mu_true(spec: MtmTimeTest, t: np.ndarray) -> np.ndarray:
    """Noise-free coefficient at step times ``t`` (s)."""
    t = np.asarray(t, dtype=float)
    ta = spec.application_time_s
    after = t >= ta
    x = np.maximum(0.0, t - ta - spec.dwell_s)
    rec = spec.mu_min + (spec.mu_plateau - spec.mu_min) * -np.expm1(-x / spec.recovery_tau_s)
    drop = (spec.mu_dry - spec.mu_min) * np.exp(-np.maximum(0.0, t - ta) / spec.drop_tau_s)
    return np.where(after, rec + drop, spec.mu_dry)


def true_figures(spec: MtmTimeTest, threshold: float = 0.15, fraction: float = 0.9) -> dict[str, Any]:
    """The true time-test figures in closed form (definitions of :mod:`torlab.reduce.mtm`).

    Recovery: ``dwell + tau_r ln(1/(1 - fraction))`` after the application (the
    drop term has decayed by then); time below ``threshold``: from the drop
    crossing (``tau_d ln((mu_dry - mu_min)/(threshold - mu_min))``) to the
    recovery crossing, or to the end when the plateau stays below.
    """
    ta = spec.application_time_s
    end = spec.duration_s - ta
    d = {
        "application_time_s": ta,
        "minimum": spec.mu_min,
        "plateau": spec.mu_plateau,
        "recovered": spec.recovered,
    }
    if spec.recovered:
        d["recovery_time_s"] = spec.dwell_s + spec.recovery_tau_s * math.log(1.0 / (1.0 - fraction))
    t_down = spec.drop_tau_s * math.log((spec.mu_dry - spec.mu_min) / (threshold - spec.mu_min))
    if spec.mu_plateau > threshold:
        t_up = spec.dwell_s - spec.recovery_tau_s * math.log(
            1 - (threshold - spec.mu_min) / (spec.mu_plateau - spec.mu_min))
        d["time_below_threshold_s"] = t_up - t_down
    else:
        d["time_below_threshold_s"] = end - t_down
    d["threshold"] = threshold
    return {k: (round(v, 6) if isinstance(v, float) else v) for k, v in d.items()}


def simulate_time_test(spec: MtmTimeTest) -> dict[str, np.ndarray]:
    """Channels of one run at 1 Hz: step time, coefficient, force, load, speeds, temperatures."""
    rng = np.random.default_rng(spec.seed)
    t = np.arange(1.0, spec.duration_s + 0.5)
    n = t.size
    mu = mu_true(spec, t)
    a = math.exp(-1.0 / spec.ou_tau_s)
    e = rng.standard_normal(n) * math.sqrt(1 - a * a)
    from scipy.signal import lfilter

    ou, _ = lfilter([1.0], [1.0, -a], e, zi=[a * rng.standard_normal()])
    # the fluctuation scales with the level (a lubricated contact is quieter)
    mu_obs = mu + spec.ou_sd * ou * np.sqrt(mu / 0.2) + spec.noise_sd * rng.standard_normal(n)
    load = spec.load_N * (1 + 0.001 * rng.standard_normal(n))
    force = mu_obs * load
    U = spec.rolling_speed_m_s * 1e3
    ball = U * (1 - spec.srr / 2) + 0.15 * rng.standard_normal(n)
    disc = U * (1 + spec.srr / 2) + 0.15 * rng.standard_normal(n)
    T = spec.temperature_C + 0.3 * (1 - np.exp(-t / 400.0)) + 0.05 * rng.standard_normal(n)
    wear = -60.0 + 5.0 * rng.standard_normal(n)
    return {"t": t, "mu": np.round(force / load, 4), "force": force, "load": load, "ball": ball,
            "disc": disc, "lube": T + 0.4, "pot": T, "wear": np.round(wear), "mu_true": mu}


_HEADER = ("Step Time (s)\tTraction Coeff (-)\t\t\t\t\t\t\tStep Time (s)\tPot RTD Temp (°C)\t"
           "Lube RTD Temp (°C)\tBall Load (N)\tPin Load (N)\tWear (um)\tECR (%)\t\tBall Speed 1\t"
           "Ball Speed 2\tBall Speed 3\tBall Speed 4\tDisc Speed 1\tDisc Speed 2\tDisc Speed 3\t"
           "Disc Speed 4\tDisc Frequency (Hz)\tRolling Speed (mm/s)\tSliding Speed (mm/s)\tSRR (%)\t"
           "\tTF1 (N)\tTF2 (N)\tTF3 (N)\tTF4 (N)\tTraction Force (N)\tTraction Coeff (-)\t"
           "Rolling Force (N)\tRolling Coeff (-)\tTraction Trace (-)")


def write_mtm_export(spec: MtmTimeTest, ch: dict[str, np.ndarray],
                     started: datetime = datetime(2019, 3, 14, 9, 30, 5)) -> str:
    """The PCS text export (CRLF line ends) of a simulated run."""
    step_start = started + timedelta(minutes=4, seconds=12)
    end = step_start + timedelta(seconds=spec.duration_s + 3)
    dur = int(spec.duration_s)

    def d(x: datetime) -> str:
        return x.strftime("%d/%m/%Y %H:%M:%S")

    head = [
        "MTM311 Test Data File",
        "Profile description:\tPaper B time test after application, 800 MPa, 2% SRR, 1 m/s",
        f"Lubricant name:\t{spec.composition}",
        "Lubricant properties file description:\t",
        f"Comments:\tSYNTHETIC (torlab synth mtm, seed {spec.seed}); {spec.amount_uL:g} uL applied "
        "to the running contact",
        "",
        "Number of steps in profile:\t1",
        "Number of steps completed:\t1",
        f"Test started at {d(started)}",
        "",
        f"Step 1 started at {d(step_start)}",
        f"Step type\tBOD_TIMED\tStep description\tTime test after application\tStep duration\t"
        f"{dur // 3600:02d}:{dur % 3600 // 60:02d}:{dur % 60:02d}",
        "Zero traction force (N)\t0.1382\t(measured at the start of this step)",
        "Disc track radius used for this step (mm)\t21.232",
        f"Applied amount = {spec.amount_uL:g} uL",
        f"Ball load = {spec.load_N:g} N",
        _HEADER,
    ]
    srr = (ch["disc"] - ch["ball"]) / (0.5 * (ch["disc"] + ch["ball"])) * 100
    cols = [ch["t"].astype(int).tolist(), ch["mu"].tolist(), ch["pot"].tolist(),
            ch["lube"].tolist(), ch["load"].tolist(), ch["wear"].astype(int).tolist(),
            ch["ball"].tolist(), ch["disc"].tolist(), (0.5 * (ch["ball"] + ch["disc"])).tolist(),
            (ch["disc"] - ch["ball"]).tolist(), srr.tolist(), ch["force"].tolist()]
    fmt = ("%d\t%.4f\t\t\t\t\t\t\t%d\t%.1f\t%.1f\t%.3f\t\t%d\t\t\t%.2f\t\t\t\t%.2f\t\t\t\t\t"
           "%.2f\t%.2f\t%.3f\t\t\t\t\t\t%.4f\t%.4f\t\t\t")
    rows = [fmt % (r[0], r[1], r[0], *r[2:], r[1]) for r in zip(*cols, strict=True)]
    tail = ["", f"All steps completed, test completed normally at {d(end)}"]
    return "\r\n".join(head + rows + tail) + "\r\n"


def write_mtm_sample_data(out: Any, seed: int = 2020) -> list[str]:
    """Write the virtual Paper B MTM time tests into an :class:`~torlab.outputs.OutputDir`.

    Returns the file names; ``truth.yaml`` holds every generating parameter and
    the true figures (:func:`true_figures`).
    """
    from torlab import __version__
    from torlab.yamlio import dump_yaml

    specs = paper_b_time_tests(seed)
    names, runs = [], []
    for k, spec in enumerate(specs):
        ch = simulate_time_test(spec)
        fname = f"{spec.name}.txt"
        out.write_bytes(fname, write_mtm_export(
            spec, ch, started=datetime(2019, 3, 14 + k, 9, 30, 5)).encode("utf-8"))
        names.append(fname)
        runs.append({"file": fname, "parameters": asdict(spec), "truth": true_figures(spec)})
    truth = {
        "description": "SYNTHETIC MTM time tests after application following Paper B (thesis "
                       "5.3.2, Fig. 5.9); generated by 'torlab synth mtm'. 'truth' holds the true "
                       "figures of the noise-free curve in the definitions of torlab.reduce.mtm "
                       "(recovery: 90 % of the way from the minimum to the plateau; low-adhesion "
                       "threshold 0.15); times in s of step time, recovery time from the "
                       "application.",
        "torlab_version": __version__,
        "seed": seed,
        "runs": runs,
    }
    out.write_text("truth.yaml", dump_yaml(truth))
    out.write_text("README.md", _README)
    return names


_README = """# Synthetic MTM sample data

**These files are synthetic.** They were generated by `torlab synth mtm` (a seeded virtual
experiment, see `torlab/synth/mtm.py` and `docs/sample-data.md`), not measured.

- `mtm_*.txt`: PCS Instruments `MTM311 Test Data File` exports (the real format, with its
  quirks: CRLF, `°C`, duplicated and empty header cells) of one `BOD_TIMED` step each: a time
  test after application after Paper B (800 MPa, 2 % SRR, 1 m/s, 1 Hz, 20 minutes after the
  application at about 60 s) for compositions of thesis Tab. 5.3 and two amounts of TOR A.
- `truth.yaml`: every generating parameter and the true figures (application time, minimum,
  recovery time, plateau, time below 0.15).

Reduce: `torlab mtm reduce sample_data/mtm/mtm_*.txt -o results/mtm`.

Regenerate with `torlab synth mtm -o sample_data/mtm --seed 2020 --force`.
"""
