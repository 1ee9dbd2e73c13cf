"""Falling-body viscometer reduction: falls, terminal velocities, viscosity per pressure step.

Thesis 5.1.5 and model notes section 8: a body falls through the pressurised
liquid; its terminal velocity ``v`` gives the viscosity

    ``eta = K (rho_body - rho_liquid) / v``

with a calibration constant ``K`` (m^3/s^2) obtained on a reference liquid of
known viscosity, ``K = eta_ref v_ref / (rho_body - rho_ref)`` (for a ball in
Stokes flow ``K = 2 r^2 g / 9`` times a wall correction; measuring ``K``
includes the geometry and the wall effect at once).

For a fixed fall distance the velocities are inversely proportional to the
fall times, which gives the *relative* falling-ball method
(:func:`relative_viscosity`), e.g. NIST Technical Note 1900, Example E3:

    ``eta_s = eta_ref (rho_b - rho_s) t_s / ((rho_b - rho_ref) t_ref)``.

Falls are found in the LVDT trace automatically (:func:`find_falls`) unless
the log numbers them; the terminal velocity of each fall comes from its steady
part (:func:`terminal_velocity`): the longest stretch over which the local
slope stays within ``tol`` (2 %) of the fall's typical slope, which leaves out
the acceleration after the release and the deceleration at the bottom (the band
is then narrowed to a quarter or half of ``tol`` around the run's median slope
while the run keeps at least half its length); ``v`` is the least-squares slope
of position against time over that stretch, with its standard error.

The liquid density may follow the Dowson-Higginson relation
``rho(p) = rho0 (1 + 0.6e-9 p / (1 + 1.7e-9 p))`` (p in Pa; Dowson & Higginson,
Elasto-hydrodynamic Lubrication, 1966) or stay constant (the default).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.parsers.viscometer import ViscometerMetadata

__all__ = [
    "DEFAULT_TOL",
    "Calibration",
    "Fall",
    "ViscometerResult",
    "calibrate",
    "calibrate_from_references",
    "find_falls",
    "liquid_density",
    "reduce_viscometer",
    "relative_viscosity",
    "terminal_velocity",
]

DEFAULT_TOL = 0.02
#: a fall must travel this fraction of the trace's position range
MIN_TRAVEL_FRACTION = 0.3


def liquid_density(rho0: float, p: np.ndarray | float, model: str = "constant") -> np.ndarray:
    """Liquid density at pressure ``p`` (Pa): constant, or Dowson-Higginson.

    ``rho = rho0 (1 + 0.6e-9 p / (1 + 1.7e-9 p))`` for ``"dowson-higginson"``.
    """
    p = np.asarray(p, dtype=float)
    if model == "constant":
        return np.full(p.shape, float(rho0)) if p.shape else np.asarray(float(rho0))
    if model == "dowson-higginson":
        return rho0 * (1.0 + 0.6e-9 * p / (1.0 + 1.7e-9 * p))
    raise TorlabInputError(f"unknown density model {model!r} (constant, dowson-higginson)",
                           key="density_model")


def relative_viscosity(eta_ref: float, t_ref: float, t_sample: float, rho_body: float,
                       rho_ref: float, rho_sample: float) -> float:
    """Viscosity by the relative falling-ball method (NIST TN 1900, Example E3).

    ``eta_s = eta_ref (rho_b - rho_s) t_s / ((rho_b - rho_ref) t_ref)``: the
    same ball falls the same distance in a reference liquid (viscosity
    ``eta_ref``, density ``rho_ref``, fall time ``t_ref``) and in the sample
    (``rho_sample``, ``t_sample``).  Any consistent units; the result has the
    unit of ``eta_ref``.

    Raises
    ------
    TorlabInputError
        Non-positive times or viscosity, or a ball not denser than a liquid.
    """
    for nm, v in (("eta_ref", eta_ref), ("t_ref", t_ref), ("t_sample", t_sample)):
        if not (math.isfinite(v) and v > 0):
            raise TorlabInputError(f"must be a positive number, got {v}", key=nm)
    if not (rho_body > rho_ref and rho_body > rho_sample):
        raise TorlabInputError("the ball must be denser than both liquids", key="rho_body")
    return eta_ref * (rho_body - rho_sample) * t_sample / ((rho_body - rho_ref) * t_ref)


@dataclass
class Fall:
    """One fall and its terminal velocity.

    Attributes
    ----------
    index
        1-based number of the fall in the log.
    i0, i1
        Row range of the fall in the log (``i1`` exclusive).
    s0, s1
        Row range of the steady part used for the velocity.
    velocity_m_s, velocity_se_m_s
        Least-squares slope over the steady part and its standard error.
    steady_fraction
        Duration of the steady part / duration of the motion (5 % to 95 % of
        the fall's travel).
    pressure_Pa, temperature_C
        Means over the steady part (temperature NaN if not logged).
    first_line, last_line
        File lines of the fall.
    """

    index: int
    i0: int
    i1: int
    s0: int
    s1: int
    velocity_m_s: float
    velocity_se_m_s: float
    steady_fraction: float
    t_start_s: float
    t_end_s: float
    steady_start_s: float
    steady_end_s: float
    pressure_Pa: float
    temperature_C: float
    first_line: int
    last_line: int


def _local_slopes(t: np.ndarray, x: np.ndarray, w: int) -> np.ndarray:
    """Least-squares slopes over every window of ``w`` consecutive samples (vectorised)."""
    n = t.size
    t0 = t - t[0]
    c1 = np.concatenate(([0.0], np.cumsum(t0)))
    c2 = np.concatenate(([0.0], np.cumsum(t0 * t0)))
    cx = np.concatenate(([0.0], np.cumsum(x)))
    ctx = np.concatenate(([0.0], np.cumsum(t0 * x)))
    i = np.arange(n - w + 1)
    st = c1[i + w] - c1[i]
    stt = c2[i + w] - c2[i]
    sx = cx[i + w] - cx[i]
    stx = ctx[i + w] - ctx[i]
    den = w * stt - st * st
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, (w * stx - st * sx) / den, 0.0)


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """Start and end (exclusive) of the longest run of True (0, 0 if none)."""
    if not mask.any():
        return 0, 0
    m = np.concatenate(([False], mask, [False])).astype(np.int8)
    d = np.diff(m)
    starts = np.nonzero(d == 1)[0]
    ends = np.nonzero(d == -1)[0]
    k = int(np.argmax(ends - starts))
    return int(starts[k]), int(ends[k])


def terminal_velocity(t: np.ndarray, x: np.ndarray, *, tol: float = DEFAULT_TOL,
                      window: int | None = None, min_fraction: float = 0.2
                      ) -> tuple[float, float, int, int]:
    """Terminal velocity from the steady part of one fall.

    Parameters
    ----------
    t, x
        Time (s) and position (m, increasing as the body falls) of one fall.
    tol
        Relative tolerance of the local slope around the terminal velocity.
    window
        Samples per local slope (default ``max(5, n // 20)``).
    min_fraction
        The steady part must cover at least this fraction of the moving samples.

    Returns
    -------
    v, se, s0, s1
        Slope (m/s), its standard error, and the sample range ``[s0, s1)`` of
        the steady part.

    Raises
    ------
    TorlabInputError
        Too few samples, no downward motion, or no steady part.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    n = t.size
    if n < 8:
        raise TorlabInputError(f"a fall needs at least 8 samples, got {n}")
    w = window or max(5, n // 20)
    w = min(w, max(3, n // 3))
    s = _local_slopes(t, x, w)
    hi = float(np.percentile(s, 95))
    if not hi > 0:
        raise TorlabInputError("the body does not move down in this fall")
    moving = s > 0.5 * hi
    v_ref = float(np.median(s[moving]))
    a, b = _longest_run(np.abs(s - v_ref) <= tol * abs(v_ref))
    need = max(2, min_fraction * moving.sum() - w)
    if b - a < need:
        raise TorlabInputError(f"no steady part: the slope stays within {tol:.0%} of "
                               f"{v_ref * 1e3:.4g} mm/s over only {b - a} windows")
    # centre the band on the typical slope of the steady run, and narrow it while the run stays
    # at least half as long: the edges of a wide band still hold some acceleration/deceleration
    v_ref = float(np.median(s[a:b]))
    for frac in (0.25, 0.5, 1.0):
        a2, b2 = _longest_run(np.abs(s - v_ref) <= frac * tol * abs(v_ref))
        if b2 - a2 >= max(need, 0.5 * (b - a)):
            a, b = a2, b2
            break
    # samples at the centres of the steady windows (the edge windows reach beyond them)
    h = (w - 1) // 2
    s0, s1 = a + h, b + h
    if s1 - s0 < 3:
        s0, s1 = a, b - 1 + w
    tt, xx = t[s0:s1], x[s0:s1]
    tm = tt.mean()
    sxx = float(np.sum((tt - tm) ** 2))
    v = float(np.sum((tt - tm) * (xx - xx.mean())) / sxx)
    resid = xx - (xx.mean() + v * (tt - tm))
    dof = max(1, tt.size - 2)
    se = float(math.sqrt(np.sum(resid * resid) / dof / sxx))
    return v, se, s0, s1


def find_falls(t: np.ndarray, x: np.ndarray, *, min_travel: float = MIN_TRAVEL_FRACTION  # noqa: C901 (the fall detection's guards, each a named bad-input case)
               ) -> list[tuple[int, int]]:
    """Row ranges ``[i0, i1)`` of the falls in an LVDT trace (position increasing downward).

    A zig-zag over the trace with a reversal threshold of ``min_travel`` times
    the position range splits it into rising and falling legs; every rising leg
    (from a lowest to the next highest position) that travels at least that far
    is a fall.  Rests at the top and the bottom may be part of the leg: the
    steady-part detection leaves them out.
    """
    x = np.asarray(x, dtype=float)
    n = x.size
    if n < 8:
        return []
    rng = float(np.max(x) - np.min(x))
    if rng <= 0:
        return []
    h = min_travel * rng
    # zig-zag: alternating extremes, each at least h from the previous one (one pass)
    ext_i: list[int] = []
    direction = 0  # +1 rising (tracking a maximum), -1 falling (tracking a minimum)
    lo = hi = cand = 0
    for i in range(1, n):
        xi = x[i]
        if direction == 0:
            if xi > x[hi]:
                hi = i
            if xi < x[lo]:
                lo = i
            if x[hi] - x[lo] >= h:
                if lo < hi:
                    ext_i, direction, cand = [lo], 1, hi
                else:
                    ext_i, direction, cand = [hi], -1, lo
            continue
        if direction == 1:
            if xi > x[cand]:
                cand = i
            elif x[cand] - xi >= h:
                ext_i.append(cand)
                direction, cand = -1, i
        else:
            if xi < x[cand]:
                cand = i
            elif xi - x[cand] >= h:
                ext_i.append(cand)
                direction, cand = 1, i
    if direction != 0:
        ext_i.append(cand)
    falls = []
    for a, b in itertools.pairwise(ext_i):
        if x[b] - x[a] >= h:
            falls.append((a, b + 1))
    return falls


@dataclass
class Calibration:
    """Calibration constant ``K`` (m^3/s^2) and where it came from."""

    K: float
    K_sd: float = 0.0
    n_falls: int = 0
    source: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain dict."""
        return {"calibration_constant_m3_s2": self.K, "calibration_constant_sd_m3_s2": self.K_sd,
                "n_falls": self.n_falls, "source": self.source}


@dataclass
class ViscometerResult:
    """A reduced viscometer log.

    Attributes
    ----------
    meta
        The log's header.
    falls
        DataFrame, one row per fall: ``fall``, ``step``, ``pressure_Pa``,
        ``temperature_C``, ``velocity_m_s`` and ``_se``, ``liquid_density_kg_m3``,
        ``viscosity_Pa_s`` and ``_se``, the fall and steady time ranges,
        ``steady_fraction``, ``first_line``, ``last_line``.
    steps
        DataFrame, one row per pressure step: mean pressure, temperature,
        viscosity (geometric mean of the falls), its relative standard
        deviation, number of falls.
    calibration
        The ``K`` used.
    fits
        Pressure-viscosity fits of the falls, where asked for
        (:mod:`torlab.fit.viscosity`).
    fall_list
        :class:`Fall` objects (for figures).
    """

    meta: ViscometerMetadata
    falls: Any
    steps: Any
    calibration: Calibration
    fall_list: list[Fall] = field(default_factory=list)
    trace: Any = None
    warnings: list[str] = field(default_factory=list)
    fits: list[Any] = field(default_factory=list)

    @property
    def label(self) -> str:
        """File name."""
        return Path(self.meta.source).name


def _falls_of(df: Any, meta: ViscometerMetadata, tol: float) -> list[Fall]:
    t = df["time_s"].to_numpy(dtype=float)
    x = df["position_m"].to_numpy(dtype=float)
    p = df["pressure_Pa"].to_numpy(dtype=float)
    temp = df["temperature_C"].to_numpy(dtype=float) if "temperature_C" in df else None
    line = df["line"].to_numpy()
    if "fall" in df:
        f = df["fall"].to_numpy()
        cut = np.nonzero(np.diff(f) != 0)[0] + 1
        bounds = np.concatenate(([0], cut, [f.size]))
        ranges = [(int(a), int(b)) for a, b in itertools.pairwise(bounds)
                  if f[a] > 0]
    else:
        ranges = find_falls(t, x)
        _check_direction(t, x, ranges, meta)
    if not ranges:
        raise TorlabInputError("no fall found in the position trace (a fall must travel at least "
                               f"{MIN_TRAVEL_FRACTION:.0%} of the position range; or number the "
                               "falls in a 'fall' column)", path=meta.source)
    out = []
    for k, (a, b) in enumerate(ranges, start=1):
        try:
            v, se, s0, s1 = terminal_velocity(t[a:b], x[a:b], tol=tol)
        except TorlabInputError as e:
            raise TorlabInputError(f"fall {k}: {e.message}", path=meta.source,
                                   line=int(line[a])) from None
        s0 += a
        s1 += a
        # the moving part: from 5 % to 95 % of the fall's travel
        xs = x[a:b]
        lo, hi = xs.min(), xs.max()
        mv = np.nonzero((xs > lo + 0.05 * (hi - lo)) & (xs < lo + 0.95 * (hi - lo)))[0]
        moving = float(t[a + mv[-1]] - t[a + mv[0]]) if mv.size > 1 else float(t[b - 1] - t[a])
        out.append(Fall(
            index=k, i0=a, i1=b, s0=s0, s1=s1, velocity_m_s=v, velocity_se_m_s=se,
            steady_fraction=min(1.0, float(t[s1 - 1] - t[s0]) / moving) if moving > 0 else 0.0, t_start_s=float(t[a]), t_end_s=float(t[b - 1]),
            steady_start_s=float(t[s0]), steady_end_s=float(t[s1 - 1]),
            pressure_Pa=float(np.mean(p[s0:s1])),
            temperature_C=float(np.mean(temp[s0:s1])) if temp is not None else float("nan"),
            first_line=int(line[a]), last_line=int(line[b - 1])))
    return out


def _moving_time(t: np.ndarray, x: np.ndarray, a: int, b: int) -> float:
    """Time a leg ``[a, b)`` takes between 10 % and 90 % of its travel (rests excluded)."""
    xs = x[a:b]
    lo, hi = xs.min(), xs.max()
    mv = np.nonzero((xs > lo + 0.1 * (hi - lo)) & (xs < lo + 0.9 * (hi - lo)))[0]
    return float(t[a + mv[-1]] - t[a + mv[0]]) if mv.size > 1 else 0.0


#: falls that take less than this fraction of the opposite legs' time suggest a flipped sign
RETURN_RATIO = 0.5


def _check_direction(t: np.ndarray, x: np.ndarray, ranges: list[tuple[int, int]],
                     meta: ViscometerMetadata) -> None:
    """Warn when the legs taken as falls are much quicker than the legs the other way.

    A body sinking under gravity through a viscous liquid is slower than the
    mechanical return to the top; when the detected falls take less than
    :data:`RETURN_RATIO` of the opposite legs' time (10-90 % of the travel,
    medians), the position probably reads the other way: the "falls" are the
    returns and every viscosity would be wrong (``position_sign``).
    """
    import warnings

    from torlab.errors import TorlabWarning

    back = find_falls(t, -x)
    if len(ranges) < 2 or len(back) < 2:
        return
    d_fall = float(np.median([_moving_time(t, x, a, b) for a, b in ranges]))
    d_back = float(np.median([_moving_time(t, -x, a, b) for a, b in back]))
    if d_back > 0 and d_fall < RETURN_RATIO * d_back:
        warnings.warn(TorlabWarning(
            f"the legs taken as falls move for {d_fall:.3g} s (median), the legs the other way "
            f"for {d_back:.3g} s: a body sinking through the liquid is normally slower than its "
            f"return, so the position may read the other way (position_sign is "
            f"{meta.position_sign:+g} in this log; the viscosities assume the falls are right)",
            path=meta.source), stacklevel=3)


def _steps(pressures: np.ndarray, rel: float = 0.02, abs_pa: float = 1e6) -> np.ndarray:
    """Step labels: falls whose pressures are within max(2 %, 1 MPa) of the step's first."""
    order = np.argsort(pressures, kind="stable")
    lab = np.empty(pressures.size, dtype=int)
    g, base = 0, None
    for i in order:
        if base is None or pressures[i] > base + max(abs_pa, rel * abs(base)):
            g += 1
            base = pressures[i]
        lab[i] = g
    return lab


def calibrate(df: Any, meta: ViscometerMetadata, *, tol: float = DEFAULT_TOL,
              reference_viscosity: float | None = None) -> Calibration:
    """Calibration constant from a reference-liquid log: ``K = eta_ref v / (rho_b - rho_ref)``.

    ``eta_ref`` is the log's ``reference_viscosity`` header (or the argument);
    ``K`` is the mean over the falls (``K_sd`` their standard deviation).

    Raises
    ------
    TorlabInputError
        No reference viscosity, or no fall.
    """
    eta = reference_viscosity if reference_viscosity is not None else meta.reference_viscosity
    if eta is None:
        raise TorlabInputError("a reference-liquid log needs the 'reference_viscosity' header "
                               "(e.g. '# reference_viscosity: 100 mPa*s')", path=meta.source)
    falls = _falls_of(df, meta, tol)
    Ks = []
    for f in falls:
        rho_l = float(liquid_density(meta.liquid_density, f.pressure_Pa, meta.density_model))
        Ks.append(eta * f.velocity_m_s / (meta.body_density - rho_l))
    K = np.asarray(Ks)
    return Calibration(K=float(K.mean()), K_sd=float(K.std(ddof=1)) if K.size > 1 else 0.0,
                       n_falls=int(K.size),
                       source=f"reference liquid {meta.liquid or ''} in {Path(meta.source).name} "
                              f"({eta * 1e3:g} mPa*s)".replace("  ", " "))


def calibrate_from_references(paths: list[Any], *, tol: float = DEFAULT_TOL
                              ) -> tuple[Calibration, list[dict[str, Any]]]:
    """One calibration constant from reference-liquid logs, and one row per log.

    ``K`` is the mean of the logs' constants weighted by their number of
    falls; its spread ``K_sd`` is the standard deviation between the logs when
    there are several, else the one log's standard deviation over its falls
    (:func:`calibrate`).

    Raises
    ------
    TorlabInputError
        No reference log, or one without a reference viscosity or falls.
    """
    from torlab.parsers.viscometer import read_viscometer

    if not paths:
        raise TorlabInputError("no reference log given")
    cals, rows = [], []
    for r in paths:
        rdf, rmeta = read_viscometer(r)
        c = calibrate(rdf, rmeta, tol=tol)
        cals.append(c)
        rows.append({"file": Path(r).name, **c.to_dict()})
    Ks = np.array([c.K for c in cals])
    w = np.array([c.n_falls for c in cals], dtype=float)
    K = float(np.sum(w * Ks) / w.sum())
    sd = float(np.std(Ks, ddof=1)) if len(Ks) > 1 else cals[0].K_sd
    return Calibration(K, K_sd=sd, n_falls=int(w.sum()),
                       source=", ".join(Path(r).name for r in paths)), rows


def reduce_viscometer(df: Any, meta: ViscometerMetadata, *, calibration: Calibration | None = None,
                      tol: float = DEFAULT_TOL, density_model: str | None = None
                      ) -> ViscometerResult:
    """Viscosity of every fall and every pressure step of a log (thesis 5.1.5).

    Parameters
    ----------
    df, meta
        From :func:`torlab.parsers.viscometer.read_viscometer`.
    calibration
        ``K``; default: the log's ``calibration_constant`` header.
    tol
        Steady-part tolerance of :func:`terminal_velocity`.
    density_model
        Override the header's density model.

    Returns
    -------
    ViscometerResult

    Raises
    ------
    TorlabInputError
        No calibration constant, no falls, a fall without a steady part.
    """
    import pandas as pd

    if not (0 < tol < 1):
        raise TorlabInputError(f"the steady-part tolerance must be in (0, 1), got {tol}", key="tol")
    if calibration is None:
        if meta.calibration_constant is None:
            raise TorlabInputError("no calibration constant: give 'calibration_constant' in the "
                                   "header or a reference-liquid log (--reference)",
                                   path=meta.source)
        calibration = Calibration(meta.calibration_constant, source="header calibration_constant")
    model = density_model or meta.density_model
    falls = _falls_of(df, meta, tol)
    p = np.array([f.pressure_Pa for f in falls])
    rho_l = liquid_density(meta.liquid_density, p, model)
    v = np.array([f.velocity_m_s for f in falls])
    vse = np.array([f.velocity_se_m_s for f in falls])
    eta = calibration.K * (meta.body_density - rho_l) / v
    step = _steps(p)
    fdf = pd.DataFrame({
        "fall": [f.index for f in falls],
        "step": step,
        "pressure_Pa": p,
        "temperature_C": [f.temperature_C for f in falls],
        "velocity_m_s": v,
        "velocity_se_m_s": vse,
        "liquid_density_kg_m3": rho_l,
        "viscosity_Pa_s": eta,
        "viscosity_se_Pa_s": eta * vse / v,
        "t_start_s": [f.t_start_s for f in falls],
        "t_end_s": [f.t_end_s for f in falls],
        "steady_start_s": [f.steady_start_s for f in falls],
        "steady_end_s": [f.steady_end_s for f in falls],
        "steady_fraction": [f.steady_fraction for f in falls],
        "first_line": [f.first_line for f in falls],
        "last_line": [f.last_line for f in falls],
    })
    if fdf["temperature_C"].isna().all():
        fdf = fdf.drop(columns="temperature_C")
    rows = []
    for g in np.unique(step):
        sel = step == g
        le = np.log(eta[sel])
        rows.append({
            "step": int(g),
            "pressure_Pa": float(np.mean(p[sel])),
            **({"temperature_C": float(fdf.loc[sel, "temperature_C"].mean())}
               if "temperature_C" in fdf else {}),
            "viscosity_Pa_s": float(np.exp(le.mean())),
            "viscosity_rel_sd": float(np.std(le, ddof=1)) if sel.sum() > 1 else 0.0,
            "n_falls": int(sel.sum()),
        })
    warnings = []
    low = fdf.loc[fdf["steady_fraction"] < 0.3, "fall"].tolist()
    if low:
        warnings.append(f"fall(s) {', '.join(map(str, low))}: steady part under 30 % of the fall")
    return ViscometerResult(meta=meta, falls=fdf, steps=pd.DataFrame(rows),
                            calibration=calibration, fall_list=falls, trace=df, warnings=warnings)
