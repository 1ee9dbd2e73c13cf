"""Synthetic optical tribometer logs: a seeded virtual ball-on-disc rig at 1 kHz.

:func:`simulate_optical_log` is a *generic* simulator: given the set conditions
(rolling speed, SRR, load, duration) and callables for the true coefficient
``mu(U, SRR)`` and film thickness ``h(U)``, it produces the raw channels of the
optical tribometer of thesis 5.1.1:

* surface speeds of ball and disc that follow each set-point change with a
  first-order servo response (time constant ``speed_tau_s``), plus white noise
  (relative) and quantisation; ``u_ball = U (1 + SRR/2)``,
  ``u_disc = U (1 - SRR/2)`` so that ``SRR = (u_ball - u_disc) / U``;
* the normal load with noise and a slow sinusoidal drift of the lever;
* the friction force ``mu W`` where ``mu`` is the true coefficient at the
  *instantaneous* speeds, lagged by ``friction_tau_s`` (the run-in of each
  condition), plus white noise and quantisation;
* the film thickness at the camera's frame rate (empty cells between frames),
  with noise and quantisation.

:func:`write_optical_log` streams such a log to a ``torlab-optical`` file
condition by condition (so a 30-minute 1 kHz log never sits in memory) and
returns the per-condition truth.  :func:`paper_a_conditions` gives the test
sequence of thesis Tab. 5.2 (Paper A).

The data are synthetic: realistic in form, not measurements.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import IO, TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from torlab.scene import Scene

__all__ = [
    "PAPER_A_LAYER",
    "OpticalCondition",
    "OpticalRig",
    "OpticalTest",
    "demo_truth",
    "hertz_load",
    "model_truth",
    "paper_a_conditions",
    "simulate_optical_log",
    "write_optical_log",
]

MuFn = Callable[[np.ndarray, np.ndarray], np.ndarray]
HFn = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class OpticalCondition:
    """One set condition: rolling speed (m/s), SRR (fraction), load (N), duration (s)."""

    rolling_speed_m_s: float
    srr: float
    load_N: float
    duration_s: float = 8.0


@dataclass(frozen=True)
class OpticalTest:
    """A test of thesis Tab. 5.2: name, type, surface, lubricant and its conditions."""

    name: str
    test: str
    surface: str
    lubricant: str
    conditions: tuple[OpticalCondition, ...]
    window_s: float = 4.0


@dataclass(frozen=True)
class OpticalRig:
    """The virtual optical rig (thesis 5.1.1) and its measurement chain."""

    ball_radius_m: float = 12.7e-3
    sample_rate_hz: float = 1000.0
    film_rate_hz: float = 25.0
    speed_tau_s: float = 0.25
    friction_tau_s: float = 0.4
    speed_noise_rel: float = 0.002
    speed_quantum_m_s: float = 1e-4
    load_noise_rel: float = 0.004
    load_drift_rel: float = 0.005
    load_drift_period_s: float = 37.0
    load_quantum_N: float = 0.01
    force_noise_N: float = 0.02
    force_quantum_N: float = 0.001
    film_noise_m: float = 1.0e-9
    film_quantum_m: float = 0.1e-9


def hertz_load(p0: float, ball_radius: float, e1: float = 210e9, nu1: float = 0.3,
               e2: float = 82e9, nu2: float = 0.206) -> float:
    """Load (N) giving the maximum Hertzian pressure ``p0`` for a ball on a flat.

    ``p0 = (6 W E*^2 / (pi^3 R^2))^(1/3)`` with
    ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` (Johnson, Contact Mechanics, 4.2);
    defaults: bearing-steel ball on a BK7 glass disc.
    """
    e_star = 1.0 / ((1 - nu1 * nu1) / e1 + (1 - nu2 * nu2) / e2)
    return p0**3 * math.pi**3 * ball_radius**2 / (6.0 * e_star**2)


def paper_a_conditions(p0: float = 0.75e9, duration_s: float = 8.0) -> list[OpticalTest]:
    """The test sequence of thesis Tab. 5.2 (Paper A), 0.75 GPa, 4 s averaging windows.

    * dry traction, rough ball, 0.5 m/s, SRR -10 ... 10 % (15 conditions);
    * film thickness, smooth ball, 0.01 ... 2 m/s, SRR 0 (14 speeds);
    * Stribeck, smooth and rough, 0.1 ... 2 m/s log-spaced, SRR 5 % (12 speeds each);
    * traction, rough, at 0.25, 0.5, 1, 1.5 and 2 m/s, SRR -5 ... 5 % (11 each).

    Each condition lasts ``duration_s`` (8 s: the transient of the change, then
    the 4 s window with margin).  The load is the Hertz load of ``p0`` for the
    25.4 mm steel ball on the glass disc (:func:`hertz_load`, about 90 N).
    """
    W = round(hertz_load(p0, 12.7e-3), 1)
    water = "distilled water"

    def cond(u: float, s: float) -> OpticalCondition:
        return OpticalCondition(float(u), float(s), W, duration_s)

    srr_dry = [-10, -7.5, -5, -3, -2, -1, -0.5, 0, 0.5, 1, 2, 3, 5, 7.5, 10]
    film_u = [0.01, 0.02, 0.03, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0]
    strib_u = np.round(np.geomspace(0.1, 2.0, 12), 4)
    srr_tr = [-5, -3, -2, -1, -0.5, 0, 0.5, 1, 2, 3, 5]
    return [
        OpticalTest("dry_traction_rough", "dry_traction", "rough", "none",
                    tuple(cond(0.5, s / 100) for s in srr_dry)),
        OpticalTest("film_thickness_smooth", "film_thickness", "smooth", water,
                    tuple(cond(u, 0.0) for u in film_u)),
        OpticalTest("stribeck_smooth", "stribeck", "smooth", water,
                    tuple(cond(u, 0.05) for u in strib_u)),
        OpticalTest("stribeck_rough", "stribeck", "rough", water,
                    tuple(cond(u, 0.05) for u in strib_u)),
        OpticalTest("traction_rough", "traction", "rough", water,
                    tuple(cond(u, s / 100) for u in (0.25, 0.5, 1.0, 1.5, 2.0) for s in srr_tr)),
    ]


def demo_truth(test: OpticalTest) -> tuple[MuFn, HFn | None, str]:
    """An analytic stand-in truth for demo logs of a Tab. 5.2 test (not torlab's model).

    ``mu = mu_max(U) tanh(SRR / 0.01)`` with ``mu_max = 0.25`` for dry traction and
    ``mu_max = 0.02 + 0.08 / (1 + (U / 0.3 m/s)^1.5)`` lubricated (0.01 lower on a smooth
    ball); film thickness ``h = 40 nm (U / 1 m/s)^0.67`` (the speed exponent of
    Hamrock-Dowson) for lubricated tests, none for dry traction.

    Returns
    -------
    mu_fn, h_fn, description
    """
    if test.test == "dry_traction":
        def mu_dry(U: np.ndarray, s: np.ndarray) -> np.ndarray:
            return 0.25 * np.tanh(np.asarray(s) / 0.01) + 0.0 * np.asarray(U)

        return mu_dry, None, "mu = 0.25 tanh(SRR/0.01)"
    low = 0.01 if test.surface == "smooth" else 0.0

    def mu_wet(U: np.ndarray, s: np.ndarray) -> np.ndarray:
        U = np.asarray(U, dtype=float)
        return (0.02 - low + 0.08 / (1 + (np.abs(U) / 0.3) ** 1.5)) * np.tanh(np.asarray(s) / 0.01)

    def h(U: np.ndarray) -> np.ndarray:
        return 40e-9 * np.abs(np.asarray(U, dtype=float)) ** 0.67

    desc = (f"mu = ({0.02 - low:g} + 0.08/(1 + (U/0.3 m/s)^1.5)) tanh(SRR/0.01); "
            "h = 40 nm (U/1 m/s)^0.67")
    return mu_wet, h, desc


#: the third-body layer of the virtual Paper A campaign (steel ball on glass, dry): a low
#: saturated coefficient, as the thesis reports for the steel-glass pair (chapter 6), reached
#: at about 2 % creepage on the 0.24 mm contact (sub-micrometre layer lengths)
PAPER_A_LAYER = {"mu_c1": 0.20, "mu_c2": 0.26, "L_mue": 0.5e-6, "L_mup": 1.5e-6}


def model_truth(test: OpticalTest, scene: Scene, *, speeds: Any = None,
                creepages: Any = None) -> tuple[MuFn, HFn | None, str]:
    """The truth of a Tab. 5.2 test from torlab's own model on ``scene`` (Paper A sample data).

    The coefficient is the model's (:func:`torlab.model.mixed.stribeck_curve`
    for a lubricated scene: film, asperity load sharing and FASTSIM, Eq. 5.47;
    FASTSIM alone for a dry one), tabulated on a grid of rolling speed (log) and
    creepage and interpolated bilinearly (odd in creepage), so the rig's servo
    transitions see a smooth truth.  The film thickness is the model's central
    film (``film_thickness_m`` at zero creepage: Eq. 5.31 for the iso-viscous
    water with the asperities' share of the load), interpolated log-log.

    Parameters
    ----------
    test
        The test (its conditions set the grid's range).
    scene
        A validated :class:`~torlab.scene.Scene` (the contact of the test, with
        the truth layer and, for a lubricated test, the lubricant and roughness).
    speeds, creepages
        Grid nodes (default: 40 log-spaced speeds spanning the test's with 30 %
        margin, 121 creepages from 0 to 20 % beyond the largest |SRR|, half of
        them below 3 %; the set speeds and |SRR| of the conditions are nodes
        too, so the truth at a set condition is the model's exactly).

    Returns
    -------
    mu_fn, h_fn, description
    """
    from torlab.model.mixed import stribeck_curve
    from torlab.model.traction import traction_curve

    u = np.array([c.rolling_speed_m_s for c in test.conditions], dtype=float)
    smax = max(0.01, float(np.max(np.abs([c.srr for c in test.conditions]))))
    if creepages is None:
        knee = min(0.03, 0.5 * smax)
        xs = np.unique(np.round(np.concatenate((
            np.linspace(0.0, knee, 61), np.linspace(knee, 1.2 * smax, 61),
            np.abs([c.srr for c in test.conditions]))), 12))
    else:
        xs = np.asarray(creepages, float)
    if scene.lubricant is None:
        mu_s = np.abs(traction_curve(scene, xs).table["mu"].to_numpy(dtype=float))

        def mu_dry(U: np.ndarray, srr: np.ndarray) -> np.ndarray:
            srr = np.asarray(srr, dtype=float)
            return np.sign(srr) * np.interp(np.abs(srr), xs, mu_s) + 0.0 * np.asarray(U)

        return mu_dry, None, (f"torlab model on '{scene.name}': FASTSIM with the layer "
                              f"{_layer_text(scene)} (dry)")
    us = np.unique(np.concatenate((np.geomspace(0.7 * u.min(), 1.3 * u.max(), 40), u))) \
        if speeds is None else np.asarray(speeds, float)
    grid = np.empty((us.size, xs.size))
    for j, x in enumerate(xs):
        grid[:, j] = np.abs(stribeck_curve(scene, us, float(x))
                            .table["mu"].to_numpy(dtype=float))
    film = stribeck_curve(scene, us, 0.0).table["film_thickness_m"].to_numpy(float)
    lu, lh = np.log(us), np.log(np.maximum(film, 1e-15))

    def mu_wet(U: np.ndarray, srr: np.ndarray) -> np.ndarray:
        U = np.clip(np.abs(np.asarray(U, dtype=float)), us[0], us[-1])
        srr = np.asarray(srr, dtype=float)
        a = np.clip(np.abs(srr), xs[0], xs[-1])
        fu = np.interp(np.log(U), lu, np.arange(us.size))
        fx = np.interp(a, xs, np.arange(xs.size))
        i = np.clip(np.floor(fu).astype(int), 0, us.size - 2)
        k = np.clip(np.floor(fx).astype(int), 0, xs.size - 2)
        wu, wx = fu - i, fx - k
        v = ((1 - wu) * (1 - wx) * grid[i, k] + wu * (1 - wx) * grid[i + 1, k]
             + (1 - wu) * wx * grid[i, k + 1] + wu * wx * grid[i + 1, k + 1])
        return np.sign(srr) * v

    def h(U: np.ndarray) -> np.ndarray:
        U = np.abs(np.asarray(U, dtype=float))
        lv = np.log(np.maximum(U, 1e-9))
        # beyond the grid: the power law of its end intervals
        out = np.interp(lv, lu, lh)
        lo, hi = lv < lu[0], lv > lu[-1]
        out[lo] = lh[0] + (lv[lo] - lu[0]) * (lh[1] - lh[0]) / (lu[1] - lu[0])
        out[hi] = lh[-1] + (lv[hi] - lu[-1]) * (lh[-1] - lh[-2]) / (lu[-1] - lu[-2])
        return np.exp(out)

    return mu_wet, h, (f"torlab model on '{scene.name}': mixed lubrication (Eq. 5.47) with the "
                       f"layer {_layer_text(scene)}, {scene.roughness.model} asperities; film "
                       "from the model (Eq. 5.31)")


def _layer_text(scene: Scene) -> str:
    lay = scene.boundary.layer
    return ", ".join(f"{n} {v * 1e6:g} um" if lay.law.param(n).kind == "length" else f"{n} {v:g}"
                     for n, v in lay.values.items() if n in lay.law.fit_names)


def _quantise(x: np.ndarray, q: float) -> np.ndarray:
    """Round to multiples of ``q`` (and to its decimals, so the text is short)."""
    if q <= 0:
        return x
    digits = max(0, -math.floor(math.log10(q) + 1e-9)) + 1
    return np.round(np.round(x / q) * q, digits)


@dataclass
class _State:
    ub: float
    ud: float
    mu: float
    t: float = 0.0
    frame_next: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)


def _simulate_condition(c: OpticalCondition, k: int, st: _State, mu_fn: MuFn, h_fn: HFn | None,
                        rig: OpticalRig, rng: np.random.Generator) -> dict[str, np.ndarray]:
    dt = 1.0 / rig.sample_rate_hz
    n = round(c.duration_s * rig.sample_rate_hz)
    i0 = round(st.t * rig.sample_rate_hz)
    t = (i0 + np.arange(n)) * dt
    tl = t - t[0]
    ub_set = c.rolling_speed_m_s * (1 + c.srr / 2)
    ud_set = c.rolling_speed_m_s * (1 - c.srr / 2)
    e = np.exp(-tl / rig.speed_tau_s)
    ub = ub_set + (st.ub - ub_set) * e
    ud = ud_set + (st.ud - ud_set) * e
    U = 0.5 * (ub + ud)
    s = (ub - ud) / np.where(U != 0, U, 1.0)
    mu_inst = np.asarray(mu_fn(U, s), dtype=float)
    # first-order lag of the friction behind the kinematics (discrete, exact for a step input)
    a = math.exp(-dt / rig.friction_tau_s)
    from scipy.signal import lfilter

    mu, _ = lfilter([1 - a], [1, -a], mu_inst, zi=[a * st.mu])
    W_true = c.load_N * (1 + rig.load_drift_rel * np.sin(2 * np.pi * t / rig.load_drift_period_s))
    W = W_true * (1 + rig.load_noise_rel * rng.standard_normal(n))
    F = mu * W_true + rig.force_noise_N * rng.standard_normal(n)
    ubm = ub * (1 + rig.speed_noise_rel * rng.standard_normal(n))
    udm = ud * (1 + rig.speed_noise_rel * rng.standard_normal(n))
    out = {
        "time_s": np.round(t, 6),
        "condition": np.full(n, k, dtype=np.int64),
        "ball_speed_m_s": _quantise(ubm, rig.speed_quantum_m_s),
        "disc_speed_m_s": _quantise(udm, rig.speed_quantum_m_s),
        "normal_load_N": _quantise(W, rig.load_quantum_N),
        "friction_force_N": _quantise(F, rig.force_quantum_N),
        "mu_true": mu,
    }
    if h_fn is not None:
        h = np.full(n, np.nan)
        fdt = 1.0 / rig.film_rate_hz
        m = math.floor((t[-1] - st.frame_next) / fdt + 1e-9) + 1 if t[-1] >= st.frame_next \
            else 0
        ft = st.frame_next + fdt * np.arange(m)
        idx = np.unique(np.searchsorted(t, ft - 1e-9))
        idx = idx[idx < n]
        st.frame_next += fdt * m
        if idx.size:
            hv = np.asarray(h_fn(U[idx]), dtype=float)
            hv = hv + rig.film_noise_m * rng.standard_normal(idx.size)
            h[idx] = _quantise(np.maximum(hv, 0.0), rig.film_quantum_m)
        out["film_thickness_m"] = h
    st.ub, st.ud, st.mu = float(ub[-1]), float(ud[-1]), float(mu[-1])
    st.t = float(t[-1]) + dt
    return out


def simulate_optical_log(conditions: Sequence[OpticalCondition], mu_fn: MuFn, h_fn: HFn | None = None,
                         *, rig: OpticalRig = OpticalRig(), seed: int = 0,
                         start_speed_m_s: float | None = None) -> dict[str, np.ndarray]:
    """Simulate the raw channels of a log over ``conditions`` (see the module docstring).

    Parameters
    ----------
    conditions
        The set conditions, in order; numbered 1, 2, ... in the ``condition``
        channel.
    mu_fn
        True coefficient ``mu(U, SRR)`` (vectorised; signed, odd in SRR).
    h_fn
        True film thickness ``h(U)`` (m), or None for no film channel.
    rig
        The virtual rig.
    seed
        Random seed.
    start_speed_m_s
        Speed of both surfaces before the first condition (default: its
        rolling speed at zero SRR).

    Returns
    -------
    dict of numpy arrays
        ``time_s``, ``condition``, ``ball_speed_m_s``, ``disc_speed_m_s``,
        ``normal_load_N``, ``friction_force_N``, ``film_thickness_m`` (NaN
        between frames; only with ``h_fn``) and the noise-free ``mu_true``.
    """
    if not conditions:
        raise ValueError("no conditions")
    rng = np.random.default_rng(seed)
    u0 = conditions[0].rolling_speed_m_s if start_speed_m_s is None else start_speed_m_s
    mu0 = float(np.asarray(mu_fn(np.array([u0]), np.array([0.0])), dtype=float)[0])
    st = _State(u0, u0, mu0)
    parts = [_simulate_condition(c, k + 1, st, mu_fn, h_fn, rig, rng)
             for k, c in enumerate(conditions)]
    return {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}


_HEADER_COLS = ("time [s]", "condition", "ball_speed [m/s]", "disc_speed [m/s]", "normal_load [N]",
                "friction_force [N]")


def _format_block(ch: dict[str, np.ndarray], with_film: bool) -> str:
    """CSV rows of a block (values are already quantised; fixed decimals keep them exact)."""
    cols = [ch["time_s"].tolist(), ch["condition"].tolist(), ch["ball_speed_m_s"].tolist(),
            ch["disc_speed_m_s"].tolist(), ch["normal_load_N"].tolist(),
            ch["friction_force_N"].tolist()]
    fmt = "%.3f,%d,%.4f,%.4f,%.2f,%.3f"
    if with_film:
        h = ch["film_thickness_m"] * 1e9
        hs = [""] * h.size
        for i in np.nonzero(np.isfinite(h))[0].tolist():
            hs[i] = f"{h[i]:.1f}"
        cols.append(hs)
        fmt += ",%s"
    return "\n".join([fmt % r for r in zip(*cols, strict=True)]) + "\n"


def write_optical_log(dest: str | os.PathLike[str] | IO[str], test: OpticalTest, mu_fn: MuFn,
                      h_fn: HFn | None = None, *, rig: OpticalRig = OpticalRig(), seed: int = 0,
                      notes: str = "") -> list[dict[str, Any]]:
    """Write a ``torlab-optical`` log of ``test`` condition by condition; return the truth.

    Parameters
    ----------
    dest
        Path or text stream.
    test
        The test (conditions, surface, lubricant, type).
    mu_fn, h_fn, rig, seed
        As :func:`simulate_optical_log`.
    notes
        Added to the ``notes`` header.

    Returns
    -------
    list of dict
        Per condition: ``condition``, the set ``rolling_speed_m_s``, ``srr``,
        ``load_N``, ``duration_s``, the true ``traction_coefficient`` at the set
        point and ``film_thickness_m`` (when ``h_fn``).
    """
    close = False
    if isinstance(dest, (str, os.PathLike)):
        fh: IO[str] = open(dest, "w", encoding="utf-8", newline="\n")
        close = True
    else:
        fh = dest
    try:
        cols = list(_HEADER_COLS) + (["film_thickness [nm]"] if h_fn is not None else [])
        head = [
            f"# {'torlab-optical'} 1",
            "# rig: virtual optical ball-on-disc tribometer (torlab synth, after thesis 5.1.1)",
            f"# ball_radius: {rig.ball_radius_m * 1e3:g} mm",
            f"# sample_rate: {rig.sample_rate_hz:g} Hz",
            f"# test: {test.test}",
            f"# surface: {test.surface}",
            f"# lubricant: {test.lubricant}",
            f"# run_id: {test.name}",
            f"# notes: SYNTHETIC log (seed {seed}){'; ' + notes if notes else ''}",
        ]
        fh.write("\n".join(head) + "\n" + ",".join(cols) + "\n")
        rng = np.random.default_rng(seed)
        c0 = test.conditions[0]
        mu0 = float(np.asarray(mu_fn(np.array([c0.rolling_speed_m_s]), np.array([0.0])))[0])
        st = _State(c0.rolling_speed_m_s, c0.rolling_speed_m_s, mu0)
        truth = []
        for k, c in enumerate(test.conditions):
            ch = _simulate_condition(c, k + 1, st, mu_fn, h_fn, rig, rng)
            fh.write(_format_block(ch, h_fn is not None))
            row = {"condition": k + 1, **asdict(c),
                   "traction_coefficient": float(np.asarray(
                       mu_fn(np.array([c.rolling_speed_m_s]), np.array([c.srr])))[0])}
            if h_fn is not None:
                row["film_thickness_m"] = float(np.asarray(h_fn(np.array([c.rolling_speed_m_s])))[0])
            truth.append(row)
        return truth
    finally:
        if close:
            fh.close()
