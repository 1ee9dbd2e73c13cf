"""Synthetic MTM time tests after application with a stated removal law (truth stored).

A virtual time test (Paper B design, thesis 5.3.2: ball on disc, 18 N for
800 MPa, 1 m/s, 2 % SRR, product applied to the running contact) is simulated
from

* a *truth layer* ``p(m)`` (:class:`~torlab.model.amount.AmountLayer`, e.g. the
  layer of a product law of :mod:`torlab.synth.hpt` at the tested amounts,
  :func:`law_layer_fits`) -- the coefficient of the remaining amount is the
  boundary model (FASTSIM with the layer, :mod:`torlab.model.fastsim`) at the
  test's contact, evaluated directly at every step of the integration, no table;
* a :class:`~torlab.model.removal.RemovalLaw` in the frictional energy per unit
  band area (plus an optional per-pass spreading);
* the film phase right after the application: the coefficient starts at the
  film level ``mu_film`` and reaches the boundary level as the film thins,
  ``mu = mu_b(m) (1 - phi) + mu_film phi`` with ``phi = exp(-(t - t_a)/tau_film)``;
  the dissipated power is that of this coefficient, ``P = mu F |SRR| v``.

The amount obeys ``dm/dt = -(g(m) P / A_band + s m / T_rev)`` (``g = k0`` or
``k1 m``, ``A_band = 2 pi r_track 2b``, ``T_rev`` the disc revolution), integrated
in time by an adaptive Runge-Kutta method (``scipy.integrate.solve_ivp``,
DOP853, rtol 1e-9) -- independently of the closed forms and the quadrature the
fit and the prediction use.  The record gets white noise, a slow
Ornstein-Uhlenbeck fluctuation and the instrument's 4-decimal rounding, and is
written as a PCS ``MTM311 Test Data File`` by :func:`torlab.synth.mtm.write_mtm_export`.

:func:`write_retention_sample_data` writes a small campaign and ``truth.yaml``
with the law, its parameters, the truth layer's nodes and every test's
initial amount, band and energy at the end.  The data are synthetic.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from typing import Any

import numpy as np

from torlab.model.amount import HPT_AREA, MG_M2, AmountLayer
from torlab.model.layers import get_law
from torlab.model.removal import RemovalLaw

__all__ = [
    "RetentionTestSpec",
    "hpt_amount_series",
    "law_layer_fits",
    "mtm_scene",
    "paper_b_retention_design",
    "retention_time_test",
    "simulate_retention_test",
    "true_layer",
    "write_retention_sample_data",
]

#: the synthetic MTM export writes this disc track radius (m)
TRACK_RADIUS = 21.232e-3


@dataclass(frozen=True)
class RetentionTestSpec:
    """One virtual time test after application.

    ``amount_uL`` of a product of density ``density_kg_m3`` is applied at
    ``application_time_s``; ``transfer`` of it reaches the disc track.
    """

    name: str
    amount_uL: float
    density_kg_m3: float = 930.0
    transfer: float = 1.0
    load_N: float = 18.0
    speed_m_s: float = 1.0
    srr: float = 0.02
    duration_s: float = 1260.0
    application_time_s: float = 60.0
    mu_film: float = 0.03
    tau_film_s: float = 15.0
    noise_sd: float = 0.003
    ou_sd: float = 0.003
    ou_tau_s: float = 15.0
    temperature_C: float = 30.0
    seed: int = 0


def mtm_scene(load_N: float = 18.0, speed_m_s: float = 1.0) -> Any:
    """The MTM ball-on-disc contact of Paper B (19.05 mm steel ball on a flat steel disc).

    Its boundary method is Kalker's FASTSIM (``fastsim-kalker``), the thesis's model: the
    virtual experiments of ``sample_data/retention`` were made with it, and their truth
    is recovered with the model that made them.
    """
    from torlab.scene import scene_from_dict

    return scene_from_dict({
        "name": "MTM ball on disc (Paper B), boundary regime",
        "contact": {"load": load_N, "r1x": "9.525 mm", "r1y": "9.525 mm", "hertz": "exact"},
        "materials": {"E1": "210 GPa", "nu1": 0.3, "E2": "210 GPa", "nu2": 0.3},
        "kinematics": {"speed": speed_m_s, "ambient_temperature": "30 degC"},
        "boundary": {"mu_c1": 0.3, "mu_c2": 0.3},
        "grid": {"method": "fastsim-kalker"},
    })


def law_layer_fits(product: str = "OFM1", amounts: tuple[float, ...] = (1, 2, 4, 8, 16), *,
                   rel_se: float = 0.02) -> tuple[list[Any], Any]:
    """Per-amount layer "fits" of a product law of :mod:`torlab.synth.hpt`, and the dry one.

    The values are the law's (``mu_c2`` logistic in the applied mass, ``mu_c1 =
    c1_ratio mu_c2``, constant lengths) without run-to-run scatter; the
    standard errors are ``rel_se`` of each value (uncorrelated).  They stand
    for the HPT fits of the amount series when a test needs a known layer.
    """
    from torlab.fit.result import FitResult
    from torlab.model.layers import get_law
    from torlab.synth.hpt import PRODUCTS

    law = PRODUCTS[product]
    layer_law = get_law(law.layer_law)
    names = layer_law.fit_names

    def fr(p: list[float], amt: float | None) -> Any:
        p_arr = np.asarray(p, dtype=float)
        cov = np.diag((rel_se * p_arr) ** 2)
        meta = {"source": f"{law.name if amt is not None else 'dry'} "
                          f"{'' if amt is None else f'{amt:g} {law.amount_unit}'}".strip(),
                "product": law.name if amt is not None else "dry", "temperature_C": 25.0}
        if amt is not None:
            meta.update(applied_amount=float(amt), applied_amount_unit=law.amount_unit,
                        product_density=law.density_kg_m3)
        if layer_law is not get_law():
            meta["law"] = layer_law.name
        return FitResult.from_covariance("layer_hpt", names, p_arr, cov, dof=200,
                                         residual_norm=0.0, n_points=0, warnings=[], data=None,
                                         meta=meta, residual_unit="Pa")

    fits = []
    for a in amounts:
        v = law.layer_values(law.mass_mg(a))
        fits.append(fr([v[n] for n in names], a))
    d = PRODUCTS["dry"]
    v = d.layer_values(0.0)
    return fits, fr([v[n] for n in names], None)


def true_layer(product: str = "OFM1", amounts: tuple[float, ...] = (1, 2, 4, 8, 16), *,
               rel_se: float = 0.02, dry_amount: Any = None) -> AmountLayer:
    """:class:`AmountLayer` of :func:`law_layer_fits` on the HPT annulus (the truth layer)."""
    fits, dry = law_layer_fits(product, amounts, rel_se=rel_se)
    return AmountLayer.from_fits(fits, dry, area=HPT_AREA, dry_amount=dry_amount)


def paper_b_retention_design(seed: int = 2016) -> list[RetentionTestSpec]:
    """Two virtual time tests of one product: 1 uL and 2 uL on the running MTM (Paper B conditions)."""
    rng = np.random.default_rng(seed)
    s = [int(v) for v in rng.integers(0, 2**31 - 1, size=2)]
    return [RetentionTestSpec("mtm_retention_1uL", 1.0, seed=s[0]),
            RetentionTestSpec("mtm_retention_2uL", 2.0, seed=s[1])]


@lru_cache(maxsize=64)
def _noise_free(spec_key: tuple, layer_key: int, law: RemovalLaw) -> dict[str, np.ndarray]:
    return _integrate(RetentionTestSpec(*spec_key), layer_key, law)


_LAYERS: dict[int, AmountLayer] = {}


@lru_cache(maxsize=16)
def _fine_mu(layer_key: int, load_N: float, speed_m_s: float, srr: float) -> tuple[Any, float, float]:
    """``ln m -> mu_b`` on the MTM contact: a fine table of the boundary model.

    The boundary model is evaluated on 240 nodes uniform in ``ln m`` from the dry
    anchor to the largest tested amount and joined by a cubic spline
    (``scipy.interpolate.CubicSpline``): an interpolation error below 1e-5 in the
    coefficient (``tests/test_retention.py`` checks it against direct evaluations),
    independent of the 4-nodes-per-interval monotone table the fit and the
    prediction use.  Returns the spline, the dry coefficient and ``ln`` of the anchor.
    """
    from scipy.interpolate import CubicSpline

    from torlab.model.contact import build_contact
    from torlab.model.fastsim import boundary_traction
    from torlab.model.prediction import fastsim_grid, fastsim_problem

    layer = _LAYERS[layer_key]
    sc = mtm_scene(load_N, speed_m_s)
    prob = fastsim_problem(sc, build_contact(sc))
    grid = fastsim_grid(sc)
    x = np.linspace(math.log(layer.dry_amount), math.log(layer.m_max), 240)
    mu = np.array([abs(boundary_traction(replace(prob, layer=layer.layer(math.exp(v))),
                                         [srr], grid).mu[0]) for v in x])
    return CubicSpline(x, mu), float(mu[0]), float(x[0])


def _integrate(spec: RetentionTestSpec, layer_key: int, law: RemovalLaw
               ) -> dict[str, np.ndarray]:
    from scipy.integrate import solve_ivp

    from torlab.model.contact import build_contact

    layer = _LAYERS[layer_key]
    contact = build_contact(mtm_scene(spec.load_N, spec.speed_m_s))
    b = float(contact.patch.b)
    track = 2.0 * math.pi * TRACK_RADIUS
    area = track * 2.0 * b
    t_rev = track / spec.speed_m_s
    m0 = spec.transfer * spec.amount_uL * 1e-9 * spec.density_kg_m3 / area
    layer.check(m0)
    F, w = spec.load_N, spec.srr * spec.speed_m_s
    spline, mu_dry, x_dry = _fine_mu(layer_key, spec.load_N, spec.speed_m_s, spec.srr)
    x_top = math.log(layer.m_max)

    def mu_b(m: Any) -> Any:
        x = np.log(np.maximum(np.asarray(m, dtype=float), 1e-300))
        return np.where(x <= x_dry, mu_dry, spline(np.clip(x, x_dry, x_top)))

    ta = spec.application_time_s

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        m = max(float(y[0]), 0.0)
        f = math.exp(-(t - ta) / spec.tau_film_s)
        mu = float(mu_b(m)) * (1.0 - f) + spec.mu_film * f
        P = mu * F * w
        g = law.k * (m if law.order == 1 else (1.0 if m > 0 else 0.0))
        return np.array([-(g * P / area + law.spread * m / t_rev), P / area])

    t = np.arange(1.0, spec.duration_s + 0.5)
    after = t >= ta
    t_after = t[after]
    events = None
    if law.order == 0:
        def gone(t_: float, y: np.ndarray) -> float:
            return float(y[0])
        gone.terminal = True  # type: ignore[attr-defined]
        events = gone
    sol = solve_ivp(rhs, (ta, float(t[-1])), [m0, 0.0], method="DOP853", t_eval=t_after,
                    rtol=1e-10, atol=[1e-12 * m0, 1e-6], events=events)
    m = np.zeros(t_after.size)
    E = np.zeros(t_after.size)
    k = sol.t.size
    m[:k] = sol.y[0]
    E[:k] = sol.y[1]
    if k < t_after.size:  # zero order: the product is gone; dry friction from here on
        t0, E0 = float(sol.t_events[0][0]), float(sol.y_events[0][0][1])
        E[k:] = E0 + mu_dry * F * w * (t_after[k:] - t0) / area
    m = np.maximum(m, 0.0)
    f = np.exp(-(t_after - ta) / spec.tau_film_s)
    mu = np.full(t.size, mu_dry)
    mu[after] = mu_b(m) * (1.0 - f) + spec.mu_film * f
    mm = np.zeros(t.size)
    mm[after] = m
    EE = np.zeros(t.size)
    EE[after] = E
    return {"t": t, "mu_true": mu, "m_true": mm, "E_true": EE, "m0": np.array(m0),
            "area": np.array(area), "band_width": np.array(2.0 * b), "t_rev": np.array(t_rev)}


def simulate_retention_test(spec: RetentionTestSpec, layer: AmountLayer, law: RemovalLaw
                            ) -> dict[str, np.ndarray]:
    """Channels of one virtual time test (1 Hz): the noise-free truth and the noisy record.

    The noise-free curve depends only on the design, the layer and the law and is
    cached; the seed changes the noise.  Returns ``t``, ``mu`` (rounded to 4
    decimals), ``mu_true``, ``m_true`` (kg/m^2), ``E_true`` (J/m^2),
    ``force``, ``load``, ``ball``, ``disc`` (mm/s), ``lube``, ``pot``, ``wear``
    and the scalars ``m0``, ``area``, ``band_width``, ``t_rev``.
    """
    key = id(layer)
    _LAYERS[key] = layer
    base = _noise_free(astuple_spec(replace(spec, seed=0, noise_sd=0.0, ou_sd=0.0)), key, law)
    rng = np.random.default_rng(spec.seed)
    t = base["t"]
    n = t.size
    a = math.exp(-1.0 / spec.ou_tau_s)
    from scipy.signal import lfilter

    e = rng.standard_normal(n) * math.sqrt(1 - a * a)
    ou, _ = lfilter([1.0], [1.0, -a], e, zi=[a * rng.standard_normal()])
    mu_obs = base["mu_true"] + spec.ou_sd * ou + spec.noise_sd * rng.standard_normal(n)
    load = spec.load_N * (1 + 0.001 * rng.standard_normal(n))
    U = spec.speed_m_s * 1e3
    ball = U * (1 - spec.srr / 2) + 0.15 * rng.standard_normal(n)
    disc = U * (1 + spec.srr / 2) + 0.15 * rng.standard_normal(n)
    T = spec.temperature_C + 0.3 * (1 - np.exp(-t / 400.0)) + 0.05 * rng.standard_normal(n)
    wear = -60.0 + 5.0 * rng.standard_normal(n)
    return {**base, "mu": np.round(mu_obs, 4), "force": mu_obs * load, "load": load,
            "ball": ball, "disc": disc, "lube": T + 0.4, "pot": T, "wear": np.round(wear)}


def astuple_spec(spec: RetentionTestSpec) -> tuple:
    """The spec's fields as a hashable tuple (cache key)."""
    return tuple(asdict(spec).values())


def export_text(spec: RetentionTestSpec, ch: dict[str, np.ndarray], law: RemovalLaw,
                started: Any = None) -> str:
    """The PCS export of a simulated run (the writer of :mod:`torlab.synth.mtm`)."""
    from datetime import datetime

    from torlab.synth.mtm import MtmTimeTest, write_mtm_export

    mt = MtmTimeTest(spec.name, f"virtual product, removal law {law.name}", spec.amount_uL,
                     0.0, 0.0, 0.0, 0.0, 1.0, duration_s=spec.duration_s, seed=spec.seed,
                     load_N=spec.load_N, rolling_speed_m_s=spec.speed_m_s, srr=spec.srr,
                     temperature_C=spec.temperature_C, application_time_s=spec.application_time_s)
    text = write_mtm_export(mt, ch, started=started or datetime(2021, 5, 3, 9, 30, 5))
    p0 = _p0(spec.load_N)
    old = "Paper B time test after application, 800 MPa, 2% SRR, 1 m/s"
    new = (f"Time test after application, {p0 / 1e6:.0f} MPa, {100 * spec.srr:g}% SRR, "
           f"{spec.speed_m_s:g} m/s")
    return text.replace(old, new).replace("torlab synth mtm", "torlab.synth.retention")


def _p0(load_N: float) -> float:
    from torlab.model.contact import build_contact

    return float(build_contact(mtm_scene(load_N)).patch.p0)


def retention_time_test(spec: RetentionTestSpec, layer: AmountLayer, law: RemovalLaw, *,
                        via_file: bool = True) -> Any:
    """A simulated run as a :class:`~torlab.fit.removal.TimeTest` (application time as stated).

    ``via_file``: written as a PCS export and read back (the path a user's file
    takes: writer, parser, reader); otherwise built from the channels directly
    (the same numbers without the 4-decimal text of the other columns; fast).
    """
    from torlab.reduce.time_test import read_time_test, time_test

    ch = simulate_retention_test(spec, layer, law)
    if not via_file:
        roll = 0.5e-3 * (ch["ball"] + ch["disc"])
        srr = (ch["disc"] - ch["ball"]) / (0.5 * (ch["disc"] + ch["ball"]))
        return time_test(ch["t"], ch["mu"], amount=f"{spec.amount_uL:g} uL", load=ch["load"],
                         speed=roll, creepage=srr, track_radius=TRACK_RADIUS,
                         application_time=spec.application_time_s,
                         density=spec.density_kg_m3, label=spec.name)
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"{spec.name}.txt"
        p.write_bytes(export_text(spec, ch, law).encode("utf-8"))
        tt = read_time_test(p, application_time=spec.application_time_s,
                            density=spec.density_kg_m3)
    return tt


def virtual_time_tests(law: RemovalLaw, seed: int, layer: AmountLayer,
                       amounts: tuple[float, ...] = (1.0, 2.0, 4.0), **spec: Any) -> list[Any]:
    """Simulated time tests in memory (no file: :func:`retention_time_test` with
    ``via_file=False``), one per applied amount [uL], each with its own seed
    (``1000 seed + amount``) and the further :class:`RetentionTestSpec` fields ``spec``:
    the removal fit's synthetic data set (its tests and ``torlab bench``)."""
    return [retention_time_test(RetentionTestSpec(f"virtual_{a:g}uL", a, seed=1000 * seed + int(a),
                                                  **spec), layer, law, via_file=False)
            for a in amounts]


def hpt_amount_series(seed: int = 2016, product: str = "OFM1",
                      amounts: tuple[float, ...] = (1, 2, 4, 8, 16)) -> list[Any]:
    """The HPT runs of the truth layer: one per amount at 25 degC, and the dry run.

    Each run's layer is exactly the truth layer's node (:func:`law_layer_fits`:
    the product law without run-to-run scatter), so the layer a user fits from
    these logs estimates the layer the time tests were simulated with; the
    simulated rig adds its compliance and noise (:func:`torlab.synth.hpt.simulate_hpt`).
    """
    from torlab.model.layers import LayerParams
    from torlab.synth.hpt import PRODUCTS, HptRunSpec

    fits, dry = law_layer_fits(product, amounts)
    rng = np.random.default_rng([seed, 1])
    specs = []
    for law_key, amt, fit in [*((product, a, f) for a, f in zip(amounts, fits, strict=True)),
                              ("dry", None, dry)]:
        law = PRODUCTS[law_key]
        lp = LayerParams(law=law.layer_law, **fit.params, **law.temperature_values())
        name = f"hpt_{law.name}{'' if amt is None else f'_{amt:g}{law.amount_unit}'}_25C"
        specs.append(HptRunSpec(name=name, law=law_key, amount=amt, temperature_C=25.0,
                                params=lp, seed=int(rng.integers(0, 2**31 - 1))))
    return specs


def write_retention_sample_data(out: Any, seed: int = 2016, *,
                                law: RemovalLaw | None = None) -> list[str]:
    """Write the virtual retention campaign into an :class:`~torlab.outputs.OutputDir`.

    Two MTM time tests of OFM1 (1 and 2 uL) with a first-order removal law, and
    the product's HPT amount series (1-16 uL and a dry run, 25 degC, the truth
    layer's nodes; :func:`hpt_amount_series`) with the rig's compliance curve;
    ``truth.yaml`` holds the law, the truth layer's nodes, every test's design,
    initial amount, band and energy at the end, and every HPT run's layer.
    Returns the names of the data files (time tests, then HPT logs).
    """
    from torlab import __version__
    from torlab.synth.hpt import HptRig, compliance_curve_text, simulate_hpt, write_hpt_log
    from torlab.yamlio import dump_yaml

    law = law or RemovalLaw(1, 1.0e-6)
    layer = true_layer()
    names, runs = [], []
    for spec in paper_b_retention_design(seed):
        ch = simulate_retention_test(spec, layer, law)
        fname = f"{spec.name}.txt"
        out.write_bytes(fname, export_text(spec, ch, law).encode("utf-8"))
        names.append(fname)
        runs.append({"file": fname, "design": asdict(spec),
                     "initial_amount_mg_m2": float(ch["m0"]) / MG_M2,
                     "band_area_m2": float(ch["area"]), "band_width_m": float(ch["band_width"]),
                     "disc_revolution_s": float(ch["t_rev"]),
                     "energy_at_end_J_m2": float(ch["E_true"][-1]),
                     "amount_at_end_mg_m2": float(ch["m_true"][-1]) / MG_M2,
                     "mu_at_end": float(ch["mu_true"][-1])})
    hpt_runs = []
    for spec in hpt_amount_series(seed):
        fname = f"{spec.name}.txt"
        out.write_text(fname, write_hpt_log(spec, simulate_hpt(spec), HptRig(),
                                            notes="retention sample: the truth layer's node"))
        names.append(fname)
        hpt_runs.append({"file": fname, "applied_amount": spec.amount,
                         "boundary": ({} if spec.params.law is get_law() else
                                      {"law": spec.params.law.name})
                         | {k: float(v) for k, v in spec.params.values.items()},
                         "seed": spec.seed})
    out.write_text("rig_compliance.csv", compliance_curve_text(HptRig(), seed + 1))
    tab = layer.table()
    truth = {
        "description": "SYNTHETIC MTM time tests after application with a stated removal law "
                       "(torlab.synth.retention). The coefficient is the boundary model of the "
                       "MTM contact with the truth layer of the remaining amount; removal in the "
                       "frictional energy per unit band area (disc track 2 pi r x 2b).",
        "torlab_version": __version__,
        "seed": seed,
        "law": {"name": law.name, "order": law.order, law.k_name: law.k, "spread": law.spread,
                "units": {"k0": "kg/J", "k1": "m^2/J", "spread": "1/pass"}},
        "layer": {"product": "OFM1 (torlab.synth.hpt product law, no scatter)",
                  "area_m2": HPT_AREA,
                  "nodes": [{k: (float(v) if isinstance(v, (int, float, np.floating)) else str(v))
                             for k, v in row.items()} for row in tab.to_dict("records")]},
        "track_radius_m": TRACK_RADIUS,
        "runs": runs,
        "hpt_runs": hpt_runs,
    }
    out.write_text("truth.yaml", dump_yaml(truth))
    out.write_text("README.md", _README)
    return names


_README = """# Synthetic retention sample data

**These files are synthetic.** They were generated by `torlab.synth.retention` (a seeded
virtual experiment), not measured.

- `mtm_retention_*.txt`: PCS `MTM311 Test Data File` exports of time tests after application
  (18 N, 1 m/s, 2 % SRR, 1 Hz, 20 minutes after the application at 60 s) of 1 and 2 uL of a
  virtual product whose layer is the OFM1 law of the synthetic HPT campaign, removed by a
  first-order law in the frictional energy per unit band area.
- `hpt_OFM1_*uL_25C.txt`, `hpt_dry_25C.txt`: the product's HPT amount series (`torlab-hpt`
  logs, 750 MPa, 25 degC), each run's layer exactly the truth layer's node (no run-to-run
  scatter), with the virtual rig's compliance (`rig_compliance.csv`) and noise.
- `truth.yaml`: the law and its parameter, the truth layer's nodes, every test's design,
  initial amount in the band, band area, and the energy and amount at the end; every HPT
  run's layer.

Regenerate with `torlab synth retention -o sample_data/retention --seed 2016 --force`.
"""
