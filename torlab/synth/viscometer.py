"""Synthetic falling-body viscometer campaign: a seeded virtual experiment with a known truth.

The design follows Paper B (thesis 5.3.2): the base ester oil measured "at 50
MPa steps up to 300 MPa at ambient temperature 25 °C", plus a calibration run
on a reference liquid of known viscosity at atmospheric pressure.

The virtual viscometer (thesis 5.1.5) holds a steel sinker in a pressurised
cartridge.  For each fall the LVDT position follows the closed form of

    ``dx/dt = v (1 - exp(-t/tau_a)) (1 - exp(-(L - x)/delta))``,

an exponential approach to the terminal velocity ``v`` after the release
(``tau_a``) and a cushioned stop at the bottom of the travel ``L``
(``delta``); with ``s(t) = v (t - tau_a (1 - exp(-t/tau_a)))`` the solution is
``x = L - delta ln(1 + (exp(L/delta) - 1) exp(-s/delta))``.  The terminal
velocity is ``v = K (rho_body - rho_liquid(p)) / eta(p)`` with the true ``K``,
the Roelands law (Eq. 5.38) for ``eta(p)`` and the Dowson-Higginson density.
Between falls the sinker is returned to the top and rests; between pressure
steps the pressure ramps.  The instrument adds LVDT noise and quantisation,
pressure noise and drift, and temperature noise.  Every generating number goes
to ``truth.yaml``.

The data are synthetic: realistic in form, not measurements.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from torlab.model.viscosity import eta_roelands, roelands_alpha0
from torlab.reduce.viscometer import liquid_density

__all__ = ["ViscometerRig", "ViscometerRun", "paper_b_campaign", "simulate_viscometer",
           "write_viscometer_log", "write_viscometer_sample_data"]


@dataclass(frozen=True)
class ViscometerRig:
    """The virtual viscometer and its measurement chain."""

    K_m3_s2: float = 1.9e-8
    body_density_kg_m3: float = 7850.0
    travel_m: float = 8e-3
    release_tau_s: float = 0.3
    cushion_m: float = 0.25e-3
    sample_rate_hz: float = 10.0
    rest_s: float = 3.0
    return_s: float = 2.0
    ramp_s: float = 15.0
    lvdt_noise_m: float = 0.4e-6
    lvdt_quantum_m: float = 0.1e-6
    pressure_noise_Pa: float = 0.15e6
    pressure_drift_rel: float = 0.002
    temperature_noise_K: float = 0.03


@dataclass
class ViscometerRun:
    """One virtual log: a liquid at pressure steps, ``falls_per_step`` falls each."""

    name: str
    liquid: str
    rho0_kg_m3: float
    eta0_Pa_s: float
    Z: float
    pressures_Pa: tuple[float, ...]
    temperature_C: float = 25.0
    falls_per_step: int = 3
    density_model: str = "dowson-higginson"
    reference_viscosity_Pa_s: float | None = None
    seed: int = 0
    extra: dict[str, Any] = field(default_factory=dict)

    def eta(self, p: np.ndarray | float) -> np.ndarray:
        """True viscosity (Pa s) at ``p`` (Pa): Roelands law (Z = 0 gives a constant)."""
        return eta_roelands(p, self.eta0_Pa_s, self.Z)


def paper_b_campaign(seed: int = 2021) -> list[ViscometerRun]:
    """The virtual Paper B campaign: a reference-liquid calibration run and the ester oil.

    * ``visc_reference_25C``: a reference oil of 100 mPa*s (868 kg/m^3) at
      atmospheric pressure (0.1 MPa), 5 falls, no pressure dependence needed;
    * ``visc_ester_25C``: synthetic ester base oil, 960 kg/m^3, eta0 = 65 mPa*s,
      Roelands Z = 0.42 (alpha* about 14.9 1/GPa), at 0.1, 50, 100, ..., 300 MPa,
      3 falls per step, 25 °C.
    """
    rng = np.random.default_rng(seed)
    seeds = rng.integers(0, 2**31 - 1, size=2)
    ref = ViscometerRun("visc_reference_25C", "reference oil RO-100 (certified 100.0 mPa*s at "
                        "25 °C)", 868.0, 0.100, 0.0, (0.1e6,), falls_per_step=5,
                        density_model="constant", reference_viscosity_Pa_s=0.100,
                        seed=int(seeds[0]))
    ester = ViscometerRun("visc_ester_25C", "synthetic ester base oil", 960.0, 0.065, 0.42,
                          (0.1e6, *(k * 50e6 for k in range(1, 7))), seed=int(seeds[1]))
    return [ref, ester]


def _fall_x(tl: np.ndarray, v: float, rig: ViscometerRig) -> np.ndarray:
    s = v * (tl - rig.release_tau_s * -np.expm1(-tl / rig.release_tau_s))
    L, d = rig.travel_m, rig.cushion_m
    lnA = L / d + math.log(-math.expm1(-L / d))
    return L - d * np.logaddexp(0.0, lnA - s / d)


def simulate_viscometer(run: ViscometerRun, rig: ViscometerRig = ViscometerRig()
                        ) -> tuple[dict[str, np.ndarray], list[dict[str, Any]]]:
    """Simulate the channels of one log and the truth of each fall.

    Returns
    -------
    channels
        ``time_s``, ``position_m``, ``pressure_Pa``, ``temperature_C``.
    truth
        Per fall: ``pressure_Pa`` (set), ``viscosity_Pa_s``,
        ``liquid_density_kg_m3``, ``terminal_velocity_m_s``, ``t_release_s``.
    """
    rng = np.random.default_rng(run.seed)
    dt = 1.0 / rig.sample_rate_hz
    t_parts, x_parts, p_parts = [], [], []
    truth = []
    t0 = 0.0
    p_prev = run.pressures_Pa[0]

    def seg(n: int, x: np.ndarray | float, p: np.ndarray | float) -> None:
        nonlocal t0
        t = t0 + dt * np.arange(n)
        t_parts.append(t)
        x_parts.append(np.broadcast_to(np.asarray(x, dtype=float), (n,)).copy())
        p_parts.append(np.broadcast_to(np.asarray(p, dtype=float), (n,)).copy())
        t0 = t0 + dt * n

    for p_set in run.pressures_Pa:
        if p_set != p_prev:  # ramp with the sinker at the top
            n = round(rig.ramp_s / dt)
            seg(n, 0.0, p_prev + (p_set - p_prev) * np.linspace(0, 1, n))
        p_prev = p_set
        eta = float(run.eta(p_set))
        rho_l = float(liquid_density(run.rho0_kg_m3, p_set, run.density_model))
        v = rig.K_m3_s2 * (rig.body_density_kg_m3 - rho_l) / eta
        for _ in range(run.falls_per_step):
            seg(round(rig.rest_s / dt), 0.0, p_set)
            t_rel = t0
            # fall until the sinker is within a quarter cushion of the bottom, then rest there
            t_fall = (rig.travel_m + 3 * rig.cushion_m) / v + 3 * rig.release_tau_s
            n = math.ceil(t_fall / dt)
            tl = dt * np.arange(n)
            seg(n, _fall_x(tl, v, rig), p_set)
            seg(round(rig.rest_s / dt), float(_fall_x(np.array([t_fall]), v, rig)[0]), p_set)
            n = round(rig.return_s / dt)
            seg(n, np.linspace(rig.travel_m, 0.0, n), p_set)
            truth.append({"pressure_Pa": float(p_set), "viscosity_Pa_s": eta,
                          "liquid_density_kg_m3": rho_l, "terminal_velocity_m_s": v,
                          "t_release_s": round(t_rel, 6)})
    seg(round(rig.rest_s / dt), 0.0, p_prev)
    t = np.concatenate(t_parts)
    x = np.concatenate(x_parts)
    p = np.concatenate(p_parts)
    n = t.size
    x = x + rig.lvdt_noise_m * rng.standard_normal(n)
    x = np.round(x / rig.lvdt_quantum_m) * rig.lvdt_quantum_m
    drift = 1 + rig.pressure_drift_rel * np.sin(2 * np.pi * t / 240.0 + rng.uniform(0, 2 * np.pi))
    p = np.maximum(p * drift + rig.pressure_noise_Pa * rng.standard_normal(n), 0.0)
    T = run.temperature_C + rig.temperature_noise_K * rng.standard_normal(n)
    return {"time_s": t, "position_m": x, "pressure_Pa": p, "temperature_C": T}, truth


def write_viscometer_log(run: ViscometerRun, ch: dict[str, np.ndarray],
                         rig: ViscometerRig = ViscometerRig(), *, calibration: bool = False) -> str:
    """The ``torlab-visc`` text of a simulated run.

    ``calibration=True`` writes the true ``K`` in the header (otherwise the
    log is reduced with a reference-liquid log).
    """
    head = [
        "# torlab-visc 1",
        f"# liquid: {run.liquid}",
        f"# liquid_density: {run.rho0_kg_m3:g} kg/m^3",
        f"# density_model: {run.density_model}",
        "# body: steel sinker (virtual)",
        f"# body_density: {rig.body_density_kg_m3:g} kg/m^3",
    ]
    if run.reference_viscosity_Pa_s is not None:
        head.append(f"# reference_viscosity: {run.reference_viscosity_Pa_s * 1e3:g} mPa*s")
    if calibration:
        head.append(f"# calibration_constant: {rig.K_m3_s2:g} m^3/s^2")
    head += [
        f"# temperature: {run.temperature_C:g} degC",
        f"# fall_distance: {rig.travel_m * 1e3:g} mm",
        f"# run_id: {run.name}",
        "# operator: torlab synth",
        f"# notes: SYNTHETIC log (torlab synth visc, seed {run.seed})",
        "time [s],position [mm],pressure [MPa],temperature [degC]",
    ]
    cols = [np.round(ch["time_s"], 3).tolist(), (ch["position_m"] * 1e3).tolist(),
            (ch["pressure_Pa"] / 1e6).tolist(), ch["temperature_C"].tolist()]
    rows = ["%.2f,%.4f,%.2f,%.2f" % r for r in zip(*cols, strict=True)]  # noqa: UP031
    return "\n".join(head + rows) + "\n"


def write_viscometer_sample_data(out: Any, seed: int = 2021, rig: ViscometerRig = ViscometerRig()
                                 ) -> list[str]:
    """Write the virtual Paper B viscometer campaign into an :class:`~torlab.outputs.OutputDir`.

    Returns the log file names; ``truth.yaml`` holds every generating number
    (rig, K, laws, per-fall truth) and the Barus alpha a fit of the true
    viscosities would give.
    """
    from torlab import __version__
    from torlab.yamlio import dump_yaml

    runs = paper_b_campaign(seed)
    names = []
    truth_runs = []
    for run in runs:
        ch, falls = simulate_viscometer(run, rig)
        fname = f"{run.name}.txt"
        out.write_text(fname, write_viscometer_log(run, ch, rig))
        names.append(fname)
        d = asdict(run)
        d["pressures_Pa"] = [float(p) for p in run.pressures_Pa]
        if run.Z > 0:
            d["alpha_star_1_Pa"] = float(roelands_alpha0(run.eta0_Pa_s, run.Z))
        truth_runs.append({"file": fname, "run": d, "falls": falls})
    truth = {
        "description": "SYNTHETIC falling-body viscometer campaign following Paper B (thesis "
                       "5.3.2, 5.1.5); generated by 'torlab synth visc'. The sample logs carry no "
                       "calibration constant: reduce them with the reference-liquid log.",
        "torlab_version": __version__,
        "seed": seed,
        "rig": asdict(rig),
        "runs": truth_runs,
    }
    out.write_text("truth.yaml", dump_yaml(truth))
    out.write_text("README.md", _README)
    return names


_README = """# Synthetic falling-body viscometer sample data

**These files are synthetic.** They were generated by `torlab synth visc` (a seeded
virtual experiment, see `torlab/synth/viscometer.py` and `docs/sample-data.md`), not measured.

- `visc_reference_25C.txt`: calibration run on a reference oil of known viscosity
  (100 mPa*s, 868 kg/m^3) at atmospheric pressure, 5 falls.
- `visc_ester_25C.txt`: synthetic ester base oil at 0.1, 50, 100, ..., 300 MPa and 25 °C,
  3 falls per step (Paper B design), Roelands law eta0 = 65 mPa*s, Z = 0.42.
- `truth.yaml`: every generating number (rig, calibration constant, laws, every fall).

Reduce: `torlab visc reduce sample_data/visc/visc_ester_25C.txt --reference
sample_data/visc/visc_reference_25C.txt -o results/visc`.

Regenerate with `torlab synth visc -o sample_data/visc --seed 2021 --force`.
"""
