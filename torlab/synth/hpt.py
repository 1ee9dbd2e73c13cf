"""Synthetic HPT logs: a seeded virtual experiment with a known truth.

The sample data in ``sample_data/hpt/`` follow the design of Paper C (thesis
5.3.3): four products -- two oil-based TOR lubricants (OFM1, OFM2), a
water-based friction modifier tested wet and dry (WFM), a solid stick crushed
to powder (SFM) -- at several applied amounts, 750 MPa, 1 um/s, to 400 um; a
dry reference; and runs at raised temperature to 200 um.

Each run's layer follows a layer law of :mod:`torlab.model.layers` (the products of
the sample data: Voce's, :meth:`~torlab.model.layers.base.LayerLaw.hpt_tau`)
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
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from torlab.model.layers import LayerParams, get_law, hpt_tau
from torlab.reduce.hpt import annulus_area, effective_radius

__all__ = [
    "PAPER_B_PRODUCTS",
    "PAPER_C_RUNS",
    "PRODUCTS",
    "WET_RUNS",
    "HptNoise",
    "HptRig",
    "HptRunSpec",
    "ProductLaw",
    "paper_b_design",
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

    ``layer_law`` is the layer law of the runs (:mod:`torlab.model.layers`, default
    Voce).  With another law ``mu_c1`` follows the amount as above, ``L_mue`` and
    ``mu_c1_T`` as given, and the law's own parameters are ``layer_extra``
    (e.g. ``{"k_mu": 400.0}``), the same at every amount.
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
    layer_law: str = "voce"
    layer_extra: dict[str, float] = field(default_factory=dict)

    def mu_c2(self, mass_mg: float) -> float:
        """Saturated coefficient at an applied mass (mg)."""
        if mass_mg <= 0:
            return self.f_high
        return self.f_low + (self.f_high - self.f_low) / (1.0 + (mass_mg / self.m50_mg) ** self.k)

    def layer_values(self, mass_mg: float) -> dict[str, float]:
        """The layer law's fitted parameters at an applied mass (mg), without run-to-run
        scatter (the truth an amount series estimates)."""
        m2 = self.mu_c2(mass_mg)
        if get_law(self.layer_law) is get_law("voce"):
            return {"mu_c1": self.c1_ratio * m2, "mu_c2": m2, "L_mue": self.L_mue,
                    "L_mup": self.L_mup}
        return {"mu_c1": self.c1_ratio * m2, "L_mue": self.L_mue, **self.layer_extra}

    def temperature_values(self) -> dict[str, float]:
        """The layer law's temperature coefficients (1/K)."""
        law = get_law(self.layer_law)
        return {n: v for n, v in (("mu_c1_T", self.mu_c1_T), ("mu_c2_T", self.mu_c2_T))
                if n in law.temperature_names}

    def mass_mg(self, amount: float) -> float:
        """Applied mass (mg) of ``amount`` in :attr:`amount_unit`."""
        if self.amount_unit == "mg":
            return amount
        return amount * 1e-9 * (self.density_kg_m3 or 1000.0) * 1e6  # uL -> m^3 -> kg -> mg


#: the product laws of the virtual Paper C experiment (documented in docs/sample-data.md).
#: The temperature coefficients encode the thesis's finding (chapter 6, H4.1): the dry
#: contact's friction falls with temperature (-0.0025/-0.0035 1/K), the products suppress
#: that (a seventh of it or less, never an increase), so that every product's modelled
#: wheel-rail traction curve is neutral after saturation.
PRODUCTS: dict[str, ProductLaw] = {
    "OFM1": ProductLaw("OFM1", "oil-based TOR lubricant (ester, organic thickener, NLGI 0)", "uL",
                       930.0, 0.30, 0.06, 6.0, 2.5, 0.62, 8e-6, 18e-6, -0.0004, -0.0003),
    "OFM2": ProductLaw("OFM2", "oil-based TOR lubricant (ester, inorganic thickener, NLGI 00)", "uL",
                       950.0, 0.28, 0.05, 6.0, 2.0, 0.60, 10e-6, 22e-6, -0.0005, -0.0005),
    "WFM-dry": ProductLaw("WFM", "water-based friction modifier", "uL", 1100.0, 0.33, 0.05, 6.5,
                          2.5, 0.55, 7e-6, 25e-6, -0.0005, -0.0005, condition="dry"),
    "WFM-wet": ProductLaw("WFM", "water-based friction modifier", "uL", 1100.0, 0.30, 0.24, 8.0,
                          1.5, 0.58, 9e-6, 25e-6, -0.0005, -0.0005, condition="wet"),
    "SFM": ProductLaw("SFM", "solid stick friction modifier, crushed to ~50 um powder", "mg", None,
                      0.32, 0.06, 6.0, 3.0, 0.65, 6e-6, 30e-6, -0.0005, -0.0005),
    "dry": ProductLaw("dry", "no product (dry reference after run-in)", "", None, 0.50, 0.50, 1.0,
                      1.0, 0.62, 5e-6, 40e-6, -0.0025, -0.0035),
}

#: the HPT tests of Paper B (thesis 5.3.2): the custom TOR lubricant (ester oil with
#: bentonite thickener and Al2O3 friction-modifier particles) and the commercial TOR A, 8 uL,
#: to 0.1 mm.  The custom composition reaches the optimal band, the commercial one stays
#: low (chapter 6: "the commercial product causes a low coefficient of adhesion in the
#: boundary regime. This was not true for custom-made substances").
PAPER_B_PRODUCTS: dict[str, ProductLaw] = {
    "custom": ProductLaw("custom", "custom TOR lubricant (synthetic ester oil, bentonite "
                         "thickener, Al2O3 particles)", "uL", 950.0, 0.20, 0.20, 1.0, 1.0, 0.60,
                         8e-6, 15e-6, -0.0005, -0.0005),
    "TOR-A": ProductLaw("TOR-A", "commercial TOR lubricant A (biodegradable, hydrophobic)", "uL",
                        930.0, 0.10, 0.10, 1.0, 1.0, 0.60, 8e-6, 15e-6, -0.0005, -0.0005),
}


def _law(key: str) -> ProductLaw:
    """A product law of either campaign by its key."""
    return PRODUCTS[key] if key in PRODUCTS else PAPER_B_PRODUCTS[key]


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


#: runs per test temperature (degC) at the temperature amount in the Paper C design: up to
#: the flash temperatures the wheel-rail prediction of Tab. 5.4 reaches (about 190 degC at
#: 5 % creepage), so the exponential temperature law is not extrapolated far; more runs at
#: the ends of the range, where they determine a slope best, and some in between to show
#: the law is straight in ln mu
PAPER_C_RUNS: dict[float, int] = {25.0: 4, 65.0: 2, 105.0: 2, 145.0: 2, 185.0: 4}
#: the water-based FM tested wet cannot be heated beyond about 85 degC (its water boils)
WET_RUNS: dict[float, int] = {25.0: 4, 40.0: 2, 55.0: 2, 70.0: 2, 85.0: 4}


def paper_c_design(seed: int = 2022, amounts: Iterable[float] = (1, 2, 4, 8, 16),
                   runs: dict[float, int] | None = None, scatter: float = 0.03,
                   wet_runs: dict[float, int] | None = None,
                   temperature_amount: float = 4) -> list[HptRunSpec]:
    """The run list of the virtual Paper C campaign.

    Per product law, one run per amount at 25 degC to 400 um; at
    ``temperature_amount`` (4 uL or 4 mg) as many runs per temperature as
    ``runs`` says (:data:`PAPER_C_RUNS`; at 25 degC the amount series' run is
    the first), raised-temperature runs to 200 um; the dry reference likewise.
    The wet FM follows ``wet_runs`` (:data:`WET_RUNS`).  Repeats are named
    ``..._run2``, ``..._run3`` ...  Run-to-run scatter multiplies ``mu_c2`` (and
    ``mu_c1``) by ``1 + scatter * N(0, 1)``.

    With 14 runs over 25-185 degC a temperature coefficient has a standard
    error of about ``scatter / 240 K`` (0.00013 1/K at 3 %): enough to tell the
    products' coefficients (-0.0003 ... -0.0005 1/K) from 0 and from the dry
    contact's, and to call the wheel-rail trend after saturation (docs/sample-data.md).
    """
    runs = dict(PAPER_C_RUNS if runs is None else runs)
    wet_runs = dict(WET_RUNS if wet_runs is None else wet_runs)
    rng = np.random.default_rng(seed)
    specs: list[HptRunSpec] = []
    for key, law in PRODUCTS.items():
        amts: list[float | None] = [None] if key == "dry" else list(amounts)
        plan = wet_runs if law.condition == "wet" else runs
        temps = [25.0, *sorted(t for t in plan if t != 25.0)]
        for amt in amts:
            for T in temps:
                if T != 25.0 and amt not in (None, temperature_amount):
                    continue
                n = plan.get(T, 1) if amt in (None, temperature_amount) else 1
                for k in range(1, n + 1):
                    specs.append(_run_spec(law, key, amt, T, k, scatter, rng))
    return specs


def _run_spec(law: ProductLaw, key: str, amt: float | None, T: float, k: int, scatter: float,
              rng: np.random.Generator, u_max: float | None = None) -> HptRunSpec:
    """One run drawn around its product law (run ``k`` of a condition)."""
    mass = 0.0 if amt is None else law.mass_mg(amt)
    m2 = law.mu_c2(mass) * (1 + scatter * rng.standard_normal())
    m1 = law.c1_ratio * m2 * (1 + 0.5 * scatter * rng.standard_normal())
    layer_law = get_law(law.layer_law)
    if layer_law is get_law("voce"):
        p = LayerParams(mu_c1=round(m1, 5), mu_c2=round(m2, 5),
                        L_mue=law.L_mue * (1 + 0.1 * rng.standard_normal()),
                        L_mup=law.L_mup * (1 + 0.1 * rng.standard_normal()),
                        mu_c1_T=law.mu_c1_T, mu_c2_T=law.mu_c2_T)
        p = p.replace(L_mue=round(p.L_mue, 9), L_mup=round(p.L_mup, 9))
    else:
        p = LayerParams(law=layer_law, mu_c1=round(m1, 5),
                        L_mue=round(law.L_mue * (1 + 0.1 * rng.standard_normal()), 9),
                        mu_c1_T=law.mu_c1_T, **law.layer_extra)
    label = law.name + (f"-{law.condition}" if law.condition else "")
    amt_s = "" if amt is None else f"_{amt:g}{law.amount_unit}"
    name = f"hpt_{label}{amt_s}_{T:g}C" + (f"_run{k}" if k > 1 else "")
    return HptRunSpec(name=name, law=key, amount=amt, temperature_C=T, params=p,
                      u_max=u_max if u_max is not None else 400e-6 if T == 25.0 else 200e-6,
                      seed=int(rng.integers(0, 2**31 - 1)))


def paper_b_design(seed: int = 2023, amount: float = 8, repeats: int = 2,
                   scatter: float = 0.03) -> list[HptRunSpec]:
    """The HPT runs of the virtual Paper B campaign (thesis 5.3.2).

    The custom TOR lubricant and the commercial TOR A (:data:`PAPER_B_PRODUCTS`),
    ``amount`` uL each (8 uL "to ensure surface coverage"), 750 MPa, 1 um/s, to a
    maximum shear displacement of 0.1 mm, 25 degC, ``repeats`` runs each.
    """
    rng = np.random.default_rng(seed)
    return [_run_spec(law, key, amount, 25.0, k, scatter, rng, u_max=100e-6)
            for key, law in PAPER_B_PRODUCTS.items() for k in range(1, repeats + 1)]


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
    law = _law(spec.law)
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
                          rig: HptRig = HptRig(), noise: HptNoise = HptNoise(),
                          campaign: str = "paper_c") -> list[str]:
    """Write the virtual campaign into an :class:`~torlab.outputs.OutputDir`.

    ``campaign``: ``"paper_c"`` (:func:`paper_c_design`) or ``"paper_b"``
    (:func:`paper_b_design`), unless ``specs`` are given.  Returns the names of
    the log files.  ``truth.yaml`` holds every generating parameter;
    ``rig_compliance.csv`` the rig's compliance curve.
    """
    from torlab import __version__
    from torlab.yamlio import dump_yaml

    if campaign not in ("paper_c", "paper_b"):
        raise ValueError(f"unknown campaign {campaign!r} (paper_c, paper_b)")
    if specs is None:
        specs = paper_c_design(seed) if campaign == "paper_c" else paper_b_design(seed)
    names = []
    truth_runs = []
    for spec in specs:
        ch = simulate_hpt(spec, rig, noise)
        fname = f"{spec.name}.txt"
        out.write_text(fname, write_hpt_log(spec, ch, rig))
        names.append(fname)
        law = _law(spec.law)
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
            "boundary": ({} if spec.params.law is get_law() else
                         {"law": spec.params.law.name}) | {
                k: float(v) for k, v in spec.params.values.items()},
            "seed": spec.seed,
        })
    out.write_text("rig_compliance.csv", compliance_curve_text(rig, seed + 1))
    truth = {
        "description": f"SYNTHETIC HPT campaign following Paper {campaign[-1].upper()} (thesis "
                       f"{'5.3.3' if campaign == 'paper_c' else '5.3.2'}); generated by "
                       "'torlab synth hpt'. boundary: are the layer parameters each run was drawn "
                       "with (reference temperature 25 degC).",
        "torlab_version": __version__,
        "seed": seed,
        "campaign": campaign,
        "rig": asdict(rig),
        "noise": asdict(noise),
        "products": {k: asdict(v) for k, v in (PRODUCTS if campaign == "paper_c"
                                               else PAPER_B_PRODUCTS).items()},
        "runs": truth_runs,
    }
    out.write_text("truth.yaml", dump_yaml(truth))
    out.write_text("README.md", _README if campaign == "paper_c" else _README_B)
    return names


_README = """# Synthetic HPT sample data

**These files are synthetic.** They were generated by `torlab synth hpt` (a seeded
virtual experiment, see `torlab/synth/hpt.py` and `docs/sample-data.md`), not measured.

- `hpt_*.txt`: raw logs in the `torlab-hpt` format (`docs/formats/hpt.md`), following the
  Paper C design: OFM1, OFM2 (oil-based TOR lubricants), WFM (water-based FM, wet and dry),
  SFM (solid stick powder) at 1-16 uL (mg), 750 MPa, 1 um/s, to 400 um, 25 degC; at 4 uL
  (4 mg) four runs at 25 degC, two at each of 65, 105 and 145 degC and four at 185 degC to
  200 um (the wet FM at 40, 55, 70 and 85 degC); the dry reference likewise.
- `rig_compliance.csv`: the virtual rig's own displacement against shear stress.
- `truth.yaml`: every generating parameter (layer parameters per run, noise, rig).

Regenerate with `torlab synth hpt -o sample_data/hpt --seed 2022 --force`.
"""


_README_B = """# Synthetic HPT sample data of Paper B

**These files are synthetic.** They were generated by `torlab synth hpt --campaign paper_b`
(a seeded virtual experiment, see `torlab/synth/hpt.py` and `docs/sample-data.md`), not measured.

- `hpt_*.txt`: raw logs in the `torlab-hpt` format (`docs/formats/hpt.md`), following the
  Paper B design (thesis 5.3.2): the custom TOR lubricant (ester oil, bentonite, Al2O3) and
  the commercial TOR A, 8 uL each, 750 MPa, 1 um/s, to 0.1 mm, 25 degC, two runs each.
- `rig_compliance.csv`: the virtual rig's own displacement against shear stress.
- `truth.yaml`: every generating parameter (layer parameters per run, noise, rig).

Regenerate with `torlab synth hpt --campaign paper_b -o sample_data/hpt_paper_b --seed 2023 --force`.
"""
