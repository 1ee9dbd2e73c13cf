"""Synthetic HPT logs: a seeded virtual experiment with a known truth.

The sample data in ``sample_data/hpt/`` follow the design of Paper C (thesis
5.3.3): four products -- two oil-based TOR lubricants (OFM1, OFM2), a
water-based friction modifier tested wet and dry (WFM), a solid stick crushed
to powder (SFM) -- at several applied amounts, 750 MPa, 1 um/s, to 400 um; a
dry reference; and runs at raised temperature to 200 um.

Each run's layer follows the Voce law of :func:`torlab.model.layer.hpt_tau`
with parameters drawn around a product law (:data:`PRODUCTS`): the saturated
coefficient ``mu_c2`` falls with the applied *mass* along a logistic curve, the
same for every product type except the wet FM (thesis H3.1/H3.2 findings), and
the limits depend on temperature through ``mu_c1_T``, ``mu_c2_T``.  The
simulated instrument adds the rig's compliance, force noise (white plus a slow
Ornstein-Uhlenbeck fluctuation of the layer's strength), load noise and drift,
angle quantisation of the encoder and the motor, and standstill at the start
and end.  Every generating number is written to ``truth.yaml`` beside the logs,
so fits can be checked against a known truth.

The data are synthetic.  They are realistic in form, not measurements.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from torlab.model.layer import LayerParams, hpt_tau
from torlab.reduce.hpt import annulus_area, effective_radius

__all__ = [
    "PRODUCTS",
    "HptNoise",
    "HptRig",
    "HptRunSpec",
    "ProductLaw",
    "paper_c_design",
    "rig_compliance_u",
    "simulate_hpt",
    "write_hpt_log",
    "write_hpt_sample_data",
]


@dataclass(frozen=True)
class HptRig:
    """The virtual rig (thesis 5.1.3)."""

    r1: float = 3e-3
    r2: float = 6e-3
    arm_length: float = 0.25
    encoder_resolution_deg: float = 0.005
    motor_resolution_deg: float = 0.00045
    #: rig compliance u_rig(tau) = c1 tau + c0 (1 - exp(-tau / tau_s))  (seating + linear)
    compliance_c1: float = 0.012e-6 / 1e6  # m/Pa (0.012 um/MPa)
    compliance_c0: float = 0.4e-6  # m
    compliance_tau_s: float = 30e6  # Pa


@dataclass(frozen=True)
class HptNoise:
    """Measurement noise of the virtual rig (all relative values are fractions)."""

    arm_force_abs_N: float = 0.4
    arm_force_rel: float = 0.003
    strength_ou_rel: float = 0.008
    strength_ou_time_s: float = 10.0
    normal_force_rel: float = 0.0015
    normal_force_drift_rel: float = 0.002
    heater_temperature_K: float = 0.3


def rig_compliance_u(tau: np.ndarray, rig: HptRig) -> np.ndarray:
    """The virtual rig's own displacement at shear stress ``tau`` (m)."""
    tau = np.asarray(tau, dtype=float)
    return rig.compliance_c1 * tau + rig.compliance_c0 * -np.expm1(-np.maximum(tau, 0) / rig.compliance_tau_s)


@dataclass(frozen=True)
class ProductLaw:
    """How a product's layer depends on the applied amount and temperature.

    ``mu_c2(m) = f_low + (f_high - f_low) / (1 + (m / m50)^k)`` with the mass
    ``m`` in mg (volume x density for liquids); ``mu_c1 = c1_ratio * mu_c2``.
    """

    name: str
    product_type: str
    amount_unit: str  # "uL" or "mg"
    density_kg_m3: float | None  # for uL -> mg
    f_high: float
    f_low: float
    m50_mg: float
    k: float
    c1_ratio: float
    L_mue: float
    L_mup: float
    mu_c1_T: float
    mu_c2_T: float
    condition: str = ""

    def mu_c2(self, mass_mg: float) -> float:
        """Saturated coefficient at an applied mass (mg)."""
        if mass_mg <= 0:
            return self.f_high
        return self.f_low + (self.f_high - self.f_low) / (1.0 + (mass_mg / self.m50_mg) ** self.k)

    def mass_mg(self, amount: float) -> float:
        """Applied mass (mg) of ``amount`` in :attr:`amount_unit`."""
        if self.amount_unit == "mg":
            return amount
        return amount * 1e-9 * (self.density_kg_m3 or 1000.0) * 1e6  # uL -> m^3 -> kg -> mg


#: the product laws of the virtual experiment (documented in docs/sample-data.md)
PRODUCTS: dict[str, ProductLaw] = {
    "OFM1": ProductLaw("OFM1", "oil-based TOR lubricant (ester, organic thickener, NLGI 0)", "uL",
                       930.0, 0.30, 0.06, 6.0, 2.5, 0.62, 8e-6, 18e-6, -0.0004, -0.0003),
    "OFM2": ProductLaw("OFM2", "oil-based TOR lubricant (ester, inorganic thickener, NLGI 00)", "uL",
                       950.0, 0.28, 0.05, 6.0, 2.0, 0.60, 10e-6, 22e-6, -0.0004, -0.0002),
    "WFM-dry": ProductLaw("WFM", "water-based friction modifier", "uL", 1100.0, 0.33, 0.05, 6.5,
                          2.5, 0.55, 7e-6, 25e-6, -0.0003, -0.0002, condition="dry"),
    "WFM-wet": ProductLaw("WFM", "water-based friction modifier", "uL", 1100.0, 0.30, 0.24, 8.0,
                          1.5, 0.58, 9e-6, 25e-6, -0.0003, -0.0002, condition="wet"),
    "SFM": ProductLaw("SFM", "solid stick friction modifier, crushed to ~50 um powder", "mg", None,
                      0.32, 0.06, 6.0, 3.0, 0.65, 6e-6, 30e-6, -0.0002, 0.0001),
    "dry": ProductLaw("dry", "no product (dry reference after run-in)", "", None, 0.50, 0.50, 1.0,
                      1.0, 0.62, 5e-6, 40e-6, -0.0025, -0.0035),
}


@dataclass
class HptRunSpec:
    """One virtual HPT run."""

    name: str
    law: str
    amount: float | None
    temperature_C: float
    params: LayerParams
    sigma: float = 750e6
    rate: float = 1e-6
    u_max: float = 400e-6
    sample_rate_hz: float = 2.0
    standstill_s: float = 5.0
    seed: int = 0
    reference_temperature_C: float = 25.0
    extra: dict[str, Any] = field(default_factory=dict)


def paper_c_design(seed: int = 2022, amounts: Iterable[float] = (1, 2, 4, 8, 16),
                   temperatures: Iterable[float] = (50.0, 80.0), scatter: float = 0.03) -> list[HptRunSpec]:
    """The run list of the virtual Paper C campaign.

    Per product law, one run per amount at 25 degC to 400 um; at 4 uL (4 mg)
    one run per raised temperature to 200 um; a dry reference at each
    temperature.  Run-to-run scatter multiplies ``mu_c2`` (and ``mu_c1``) by
    ``1 + scatter * N(0, 1)``.
    """
    rng = np.random.default_rng(seed)
    specs: list[HptRunSpec] = []
    for key, law in PRODUCTS.items():
        amts: list[float | None] = [None] if key == "dry" else list(amounts)
        for amt in amts:
            for T in (25.0, *temperatures):
                if T != 25.0 and amt not in (None, 4):
                    continue
                mass = 0.0 if amt is None else law.mass_mg(amt)
                m2 = law.mu_c2(mass) * (1 + scatter * rng.standard_normal())
                m1 = law.c1_ratio * m2 * (1 + 0.5 * scatter * rng.standard_normal())
                p = LayerParams(mu_c1=round(m1, 5), mu_c2=round(m2, 5),
                                L_mue=law.L_mue * (1 + 0.1 * rng.standard_normal()),
                                L_mup=law.L_mup * (1 + 0.1 * rng.standard_normal()),
                                mu_c1_T=law.mu_c1_T, mu_c2_T=law.mu_c2_T)
                p = replace(p, L_mue=round(p.L_mue, 9), L_mup=round(p.L_mup, 9))
                label = law.name + (f"-{law.condition}" if law.condition else "")
                amt_s = "" if amt is None else f"_{amt:g}{law.amount_unit}"
                name = f"hpt_{label}{amt_s}_{T:g}C"
                specs.append(HptRunSpec(
                    name=name, law=key, amount=amt, temperature_C=T, params=p,
                    u_max=400e-6 if T == 25.0 else 200e-6,
                    seed=int(rng.integers(0, 2**31 - 1))))
    return specs


def simulate_hpt(spec: HptRunSpec, rig: HptRig = HptRig(), noise: HptNoise = HptNoise()) -> dict[str, np.ndarray]:
    """Simulate the raw channels of one run.

    Returns a dict of arrays: ``time_s``, ``normal_force_kN``, ``arm_force_N``,
    ``encoder_angle_deg``, ``motor_angle_deg``, ``heater_temperature_C`` and
    the noise-free ``tau_true_Pa``, ``u_layer_true_m`` for checks.
    """
    rng = np.random.default_rng(spec.seed)
    S = annulus_area(rig.r1, rig.r2)
    re = effective_radius(rig.r1, rig.r2)
    dT = spec.temperature_C - spec.reference_temperature_C

    # measured displacement advances at the set rate; solve u_layer + u_rig(tau(u_layer)) = u_meas
    u_layer = np.linspace(0.0, spec.u_max * 1.05, 20001)
    tau_l = hpt_tau(u_layer, spec.sigma, spec.params, dT)
    u_meas_of_layer = u_layer + rig_compliance_u(tau_l, rig)
    u_meas_of_layer = np.maximum.accumulate(u_meas_of_layer)  # guard against snap-back

    dt = 1.0 / spec.sample_rate_hz
    t_move = spec.u_max / spec.rate
    t = np.arange(0.0, spec.standstill_s * 2 + t_move + 0.5 * dt, dt)
    u_meas = np.clip((t - spec.standstill_s) * spec.rate, 0.0, spec.u_max)
    ul = np.interp(u_meas, u_meas_of_layer, u_layer)
    tau = hpt_tau(ul, spec.sigma, spec.params, dT)

    # slow fluctuation of the layer's strength (Ornstein-Uhlenbeck, unit variance)
    a = math.exp(-dt / noise.strength_ou_time_s)
    ou = np.empty(len(t))
    ou[0] = rng.standard_normal()
    e = rng.standard_normal(len(t)) * math.sqrt(1 - a * a)
    for i in range(1, len(t)):
        ou[i] = a * ou[i - 1] + e[i]
    tau_obs = tau * (1 + noise.strength_ou_rel * ou)
    torque = tau_obs * re * S
    arm = torque / rig.arm_length
    arm = arm + rng.standard_normal(len(t)) * (noise.arm_force_abs_N + noise.arm_force_rel * np.abs(arm))

    fn_set = spec.sigma * S
    drift = noise.normal_force_drift_rel * np.sin(2 * np.pi * t / (t[-1] + dt) + rng.uniform(0, 2 * np.pi))
    fn = fn_set * (1 + drift + noise.normal_force_rel * rng.standard_normal(len(t)))

    theta = (u_meas + 0.0) / re  # rad; the angle sensors see the measured (layer + rig) rotation
    deg = np.degrees(theta)
    enc = np.floor(deg / rig.encoder_resolution_deg + 1e-9) * rig.encoder_resolution_deg
    mot = np.round(deg / rig.motor_resolution_deg) * rig.motor_resolution_deg
    out = {
        "time_s": t,
        "normal_force_kN": fn / 1e3,
        "arm_force_N": arm,
        "encoder_angle_deg": enc,
        "motor_angle_deg": mot,
        "tau_true_Pa": tau,
        "u_layer_true_m": ul,
    }
    if abs(dT) > 1.0:
        out["heater_temperature_C"] = spec.temperature_C + noise.heater_temperature_K * rng.standard_normal(len(t))
    return out


def write_hpt_log(spec: HptRunSpec, channels: dict[str, np.ndarray], rig: HptRig = HptRig(),
                  notes: str = "") -> str:
    """The ``torlab-hpt`` text of a simulated run."""
    law = PRODUCTS[spec.law]
    head = [
        "# torlab-hpt 1",
        f"# product: {law.name}",
        f"# product_type: {law.product_type}",
    ]
    if law.condition:
        head.append(f"# condition: {law.condition}")
    if spec.amount is not None:
        head.append(f"# applied_amount: {spec.amount:g} {law.amount_unit}")
        if law.density_kg_m3:
            head.append(f"# product_density: {law.density_kg_m3:g} kg/m^3")
    head += [
        f"# temperature: {spec.temperature_C:g} degC",
        f"# r1: {rig.r1 * 1e3:g} mm",
        f"# r2: {rig.r2 * 1e3:g} mm",
        f"# arm_length: {rig.arm_length * 1e3:g} mm",
        f"# encoder_resolution: {rig.encoder_resolution_deg:g} deg",
        f"# motor_resolution: {rig.motor_resolution_deg:g} deg",
        f"# normal_stress_set: {spec.sigma / 1e6:g} MPa",
        f"# displacement_rate_set: {spec.rate * 1e6:g} um/s",
        "# specimen: 100CrMn6 60 HRC, polished, run-in to Ra ~0.3 um",
        f"# run_id: {spec.name}",
        "# operator: torlab synth",
        f"# notes: SYNTHETIC log (torlab synth hpt, seed {spec.seed}); {notes}".rstrip("; "),
    ]
    cols = ["time [s]", "normal_force [kN]", "arm_force [N]", "encoder_angle [deg]", "motor_angle [deg]"]
    data = [channels["time_s"], channels["normal_force_kN"], channels["arm_force_N"],
            channels["encoder_angle_deg"], channels["motor_angle_deg"]]
    fmts = ["%.2f", "%.4f", "%.2f", "%.3f", "%.5f"]
    if "heater_temperature_C" in channels:
        cols.append("heater_temperature [degC]")
        data.append(channels["heater_temperature_C"])
        fmts.append("%.1f")
    lines = [*head, ",".join(cols)]
    arr = np.column_stack(data)
    fmt = ",".join(fmts)
    lines += [fmt % tuple(row) for row in arr]
    return "\n".join(lines) + "\n"


def compliance_curve_text(rig: HptRig = HptRig(), seed: int = 7) -> str:
    """CSV of the rig compliance 'measured on a dry run' (with measurement noise)."""
    rng = np.random.default_rng(seed)
    tau = np.linspace(0.0, 420e6, 43)
    u = rig_compliance_u(tau, rig) + 0.01e-6 * rng.standard_normal(tau.size) * (tau > 0)
    lines = ["# torlab rig compliance curve: displacement of the rig itself against shear stress",
             "# SYNTHETIC (torlab synth hpt): dry run with bonded specimens, loading branch",
             "shear_stress [MPa],displacement [um]"]
    lines += [f"{t / 1e6:.1f},{x * 1e6:.4f}" for t, x in zip(tau, u, strict=True)]
    return "\n".join(lines) + "\n"


def write_hpt_sample_data(out: Any, seed: int = 2022, specs: list[HptRunSpec] | None = None,
                          rig: HptRig = HptRig(), noise: HptNoise = HptNoise()) -> list[str]:
    """Write the virtual campaign into an :class:`~torlab.outputs.OutputDir`.

    Returns the names of the log files.  ``truth.yaml`` holds every
    generating parameter; ``rig_compliance.csv`` the rig's compliance curve.
    """
    from torlab import __version__
    from torlab.yamlio import dump_yaml

    specs = paper_c_design(seed) if specs is None else specs
    names = []
    truth_runs = []
    for spec in specs:
        ch = simulate_hpt(spec, rig, noise)
        fname = f"{spec.name}.txt"
        out.write_text(fname, write_hpt_log(spec, ch, rig))
        names.append(fname)
        law = PRODUCTS[spec.law]
        tau_end = float(ch["tau_true_Pa"][np.argmax(ch["u_layer_true_m"])])
        truth_runs.append({
            "file": fname,
            "product": law.name,
            "condition": law.condition,
            "applied_amount": spec.amount,
            "applied_amount_unit": law.amount_unit,
            "applied_mass_mg": 0.0 if spec.amount is None else round(law.mass_mg(spec.amount), 6),
            "temperature_C": spec.temperature_C,
            "normal_stress_Pa": spec.sigma,
            "displacement_max_m": spec.u_max,
            "friction_at_max_displacement": tau_end / spec.sigma,
            "boundary": {k: float(v) for k, v in asdict(spec.params).items()},
            "seed": spec.seed,
        })
    out.write_text("rig_compliance.csv", compliance_curve_text(rig, seed + 1))
    truth = {
        "description": "SYNTHETIC HPT campaign following Paper C (thesis 5.3.3); generated by "
                       "'torlab synth hpt'. boundary: are the layer parameters each run was drawn "
                       "with (reference temperature 25 degC).",
        "torlab_version": __version__,
        "seed": seed,
        "rig": asdict(rig),
        "noise": asdict(noise),
        "products": {k: asdict(v) for k, v in PRODUCTS.items()},
        "runs": truth_runs,
    }
    out.write_text("truth.yaml", dump_yaml(truth))
    out.write_text("README.md", _README)
    return names


_README = """# Synthetic HPT sample data

**These files are synthetic.** They were generated by `torlab synth hpt` (a seeded
virtual experiment, see `torlab/synth/hpt.py` and `docs/sample-data.md`), not measured.

- `hpt_*.txt`: raw logs in the `torlab-hpt` format (`docs/formats/hpt.md`), following the
  Paper C design: OFM1, OFM2 (oil-based TOR lubricants), WFM (water-based FM, wet and dry),
  SFM (solid stick powder) at 1-16 uL (mg), 750 MPa, 1 um/s, to 400 um; runs at 50 and
  80 degC to 200 um; a dry reference.
- `rig_compliance.csv`: the virtual rig's own displacement against shear stress.
- `truth.yaml`: every generating parameter (layer parameters per run, noise, rig).

Regenerate with `torlab synth hpt -o sample_data/hpt --seed 2022 --force`.
"""
