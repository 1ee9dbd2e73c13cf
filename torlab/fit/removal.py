"""Removal law of a product from MTM time tests after application (Paper B) and its amount series.

The model
---------
A time test after application (thesis 5.3.2, Fig. 5.9) runs a ball-on-disc
contact at constant load, speed and slide-roll ratio; the product is applied
at ``t_a`` onto the disc track.  With the band of :mod:`torlab.model.removal`
(the disc track, ``2 pi r_track x 2b``):

* the energy dissipated per unit band area since the application is taken
  from the record itself, ``E(t) = integral_{t_a}^t |mu| F |SRR| v dt / A_band``
  (the measured coefficient, load, slide-roll ratio and rolling speed of every
  sample; trapezoidal), and the passes are ``N(t) = (t - t_a) v / L_track``;
* the remaining amount follows the law in closed form
  (:func:`torlab.model.removal.amount_from_energy`) from
  ``m0 = transfer x applied mass / A_band``;
* the modelled coefficient is the boundary model at the test's contact and
  slide-roll ratio with the layer of the remaining amount
  (:func:`torlab.model.removal.mu_table`, the product's HPT amount series).

Right after the application the contact runs on the film of the fresh product
(the initial drop, which the boundary model does not describe); the fit
therefore starts once the coefficient has recovered to the boundary level
(``skip="auto"``: twice the time at which the smoothed coefficient, after its
minimum, has come 90 % of the way back to the boundary coefficient at the
applied amount -- for an exponential recovery 1 % of the film's effect is left
then), or ``skip`` seconds after the application.  The energy dissipated
before that still counts.

The fit
-------
Log-parameters (``ln k``, and ``ln spread``, ``ln transfer`` where fitted) by
bounded least squares (``scipy.optimize.least_squares``, trust-region
reflective) from the best point of a grid, jointly over all time tests of the
product.  The residual noise of a time test is slow (the coefficient
fluctuates over tens of seconds): per test a white + AR(1) noise model is
estimated from the residuals (a moment fit of their autocovariance,
:func:`_ar1_noise`) and the covariance is the sandwich ``B J^T Sigma J B`` of
:mod:`torlab.fit._noise`; the intervals use Student's t on the effective
number of independent points.  The intervals of the rates are
``exp(ln k +- t se)`` (asymmetric in ``k``); the standard errors are the
delta-method ``k se(ln k)``.

The law is chosen per product by the small-sample Akaike criterion on the
effective number of independent points (``n_eff ln(RSS/n) + 2p +
2p(p+1)/(n_eff - p - 1)``, ``n_eff`` from the noise model of the best-fitting
law); ``meta["law_selection"]`` lists every candidate with its criterion,
difference to the best and Akaike weight.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import FitError, TorlabInputError
from torlab.fit.result import PARAM_UNITS, FitResult, student_t
from torlab.model.amount import MG_M2, AboveTestedError, areal_density, parse_amount
from torlab.model.removal import (
    LAW_UNITS,
    LAWS,
    amount_from_energy,
    band_of,
    mu_table,
    passes_solution,
)

__all__ = ["RemovalFit", "RetentionParams", "TimeTest", "check_options", "default_tribometer_scene",
           "fit_removal", "is_retention_file", "is_time_test_input", "load_retention",
           "read_time_test", "removal_figure", "retention_from_dict", "time_test"]

# the law parameters' units, registered where the fit results list units
for _k, _u in LAW_UNITS.items():
    PARAM_UNITS.setdefault(_k, _u)

#: fewest samples in a test's fit window
MIN_WINDOW = 20
#: smallest drop of the coefficient taken as the application (as torlab.reduce.mtm)
DEFAULT_MIN_DROP = 0.05


@dataclass
class TimeTest:
    """One time test after application, ready for the removal fit (SI units).

    Attributes
    ----------
    label
        Name for tables and figures (file and step).
    t
        Time (s), increasing.
    mu
        Coefficient magnitude.
    application_time
        Application moment on the ``t`` axis (s).
    application_source
        ``"given"`` or ``"detected"`` (largest drop of the coefficient).
    amount
        Applied amount ``(SI value, kind)`` (volume m^3, mass kg or kg/m^2).
    amount_text
        As written.
    load, speed, creepage
        Normal load (N), rolling speed (m/s) and |slide-roll ratio| per sample.
    track_radius
        Disc track radius (m).
    density
        Product density (kg/m^3), for a volume.
    """

    label: str
    t: np.ndarray
    mu: np.ndarray
    application_time: float
    application_source: str
    amount: tuple[float, str]
    amount_text: str
    load: np.ndarray
    speed: np.ndarray
    creepage: np.ndarray
    track_radius: float
    density: float | None = None
    notes: list[str] = field(default_factory=list)


def default_tribometer_scene(load: float = 18.0, speed: float = 1.0) -> Any:
    """The PCS MTM ball on disc: a 19.05 mm (3/4 in) steel ball on a flat steel disc.

    The tribometer scene of a removal fit when none is given (each time test's
    own load and speed replace these); its ``boundary:`` is a placeholder,
    replaced by the layer of the remaining amount.
    """
    from torlab.scene import scene_from_dict

    return scene_from_dict({
        "name": "PCS MTM ball on disc (19.05 mm steel ball, steel disc)",
        "contact": {"load": load, "r1x": "9.525 mm", "r1y": "9.525 mm", "hertz": "exact"},
        "materials": {"E1": "210 GPa", "nu1": 0.3, "E2": "210 GPa", "nu2": 0.3},
        "kinematics": {"speed": speed, "ambient_temperature": "30 degC"},
        "boundary": {"mu_c1": 0.3, "mu_c2": 0.3},
    })


def _per_sample(v: Any, n: int, name: str, where: str) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise TorlabInputError(f"{name} must be one value or one per sample", path=where, key=name)
    if not np.all(np.isfinite(a)):
        raise TorlabInputError(f"{name} has non-finite values", path=where, key=name)
    return a


def is_time_test_input(path: Path) -> bool:
    """A PCS export or a ``*_timed.csv`` (what a folder or pattern of time tests contributes)."""
    from torlab.instruments.measured import detected

    try:
        if detected(path) == "pcs":
            return True
    except TorlabInputError:
        return False
    from torlab.files import open_regular

    with open_regular(path) as fh:
        return b"step_time_s" in fh.read(2000).split(b"\n", 1)[0]


def _detect_application(t: np.ndarray, mu: np.ndarray, label: str, min_drop: float) -> float:
    from torlab.reduce.mtm import time_test_metrics

    r = time_test_metrics(t, mu, min_drop=min_drop, label=label)
    if r.application_source != "detected":
        raise TorlabInputError(
            f"no application marker: the coefficient never drops by {min_drop:g} or more, and no "
            "application time was given; a removal fit needs the moment the product was applied "
            "(application_time=)", path=label)
    return float(r.application_time_s)


def time_test(t: Any, mu: Any, *, amount: Any, load: Any, speed: Any, creepage: Any,
              track_radius: float, application_time: float | None = None,
              density: float | None = None, label: str = "time test",
              min_drop: float = DEFAULT_MIN_DROP) -> TimeTest:
    """A :class:`TimeTest` from arrays (SI units; amount as a quantity with its unit).

    Raises
    ------
    TorlabInputError
        Too few samples, non-increasing time, an amount without unit or negative,
        no application marker (not given and no drop found), non-positive load,
        speed, slide-roll ratio or track radius.
    """
    t = np.asarray(t, dtype=float)
    mu = np.abs(np.asarray(mu, dtype=float))
    ok = np.isfinite(t) & np.isfinite(mu)
    n_bad = int(np.size(ok) - np.count_nonzero(ok))
    t, mu = t[ok], mu[ok]
    if t.size < MIN_WINDOW + 5:
        raise TorlabInputError(f"a time test needs at least {MIN_WINDOW + 5} samples with a "
                               f"coefficient, got {t.size}", path=label)
    if np.any(np.diff(t) <= 0):
        raise TorlabInputError("time does not increase", path=label)
    if amount is None:
        raise TorlabInputError("no applied amount: give it with its unit (e.g. '5 uL')",
                               path=label, key="amount")
    amt = amount if isinstance(amount, tuple) else parse_amount(amount, where="amount")
    if isinstance(amount, tuple) and not (math.isfinite(amt[0]) and amt[0] >= 0):
        raise TorlabInputError(f"applied amount must be a non-negative number, got {amt[0]}",
                               path=label, key="amount")
    if amt[0] <= 0:
        raise TorlabInputError("applied amount is zero: nothing to remove", path=label,
                               key="amount")
    n = int(np.size(ok))
    load_a = _per_sample(load, n, "load", label)[ok]
    speed_a = _per_sample(speed, n, "speed", label)[ok]
    xi_a = np.abs(_per_sample(creepage, n, "creepage", label))[ok]
    for name, a in (("load", load_a), ("speed", speed_a), ("creepage", xi_a)):
        if np.median(a) <= 0:
            raise TorlabInputError(f"{name} must be positive", path=label, key=name)
    if not (math.isfinite(track_radius) and track_radius > 0):
        raise TorlabInputError(f"track radius must be positive, got {track_radius}", path=label,
                               key="track_radius")
    if application_time is None:
        t_app = _detect_application(t, mu, label, min_drop)
        src = "detected"
    else:
        t_app = float(application_time)
        src = "given"
        if not (t[0] <= t_app < t[-1]):
            raise TorlabInputError(f"application time {t_app:g} s is outside the record "
                                   f"({t[0]:g}-{t[-1]:g} s)", path=label, key="application_time")
    notes = [f"{n_bad} samples without a coefficient dropped"] if n_bad else []
    return TimeTest(label=label, t=t, mu=mu, application_time=t_app, application_source=src,
                    amount=amt, amount_text=amount if isinstance(amount, str) else
                    f"{amt[0]:g} ({amt[1]})", load=load_a, speed=speed_a, creepage=xi_a,
                    track_radius=float(track_radius), density=density, notes=notes)


def read_time_test(path: str | Path, *, step: int | None = None,
                   application_time: float | None = None, amount: Any = None,
                   density: float | None = None, track_radius: float | None = None,
                   min_drop: float = DEFAULT_MIN_DROP) -> TimeTest:
    """Read a time test: a PCS export (its timed step) or a ``*_timed.csv`` of ``torlab mtm reduce``.

    PCS files give the load, speeds and slide-roll ratio per sample, and where
    written the ``Applied amount`` (with its unit) and the ``Disc track radius``
    of the step; ``amount``/``track_radius`` override or supply them.  A
    ``*_timed.csv`` needs the columns ``step_time_s``, ``traction_coefficient``,
    ``srr``, ``rolling_speed_m_s``, ``ball_load_N`` and the amount and track
    radius as arguments.

    Raises
    ------
    TorlabInputError
        Unreadable file, several timed steps without ``step``, missing columns,
        an amount without unit, no track radius, no application marker.
    """
    import pandas as pd

    path = Path(path)
    label = path.name
    amount_text: str | None = None
    from torlab.files import open_regular

    with open_regular(path) as fh:  # a regular file only: no FIFO or device is waited on
        text_start = fh.read(200).decode("utf-8", "replace")
    if text_start.lstrip().lower().startswith(("mtm", "etm", "ehd")):
        from torlab.parsers.pcs import read_pcs
        from torlab.reduce.mtm import mu_series

        df, meta = read_pcs(path)
        timed = [s for s in meta.steps if s.type == "timed" and s.has_data]
        if not timed:
            raise TorlabInputError("no timed step (time test) with data", path=str(path))
        if step is None and len(timed) > 1:
            raise TorlabInputError(f"{len(timed)} timed steps ({', '.join(str(s.number) for s in timed)}): "
                                   "choose one with step=", path=str(path), key="step")
        st = timed[0] if step is None else meta.step(step)
        sel = (df["step"] == st.number).to_numpy()
        sub = df.loc[sel]
        mu, _src = mu_series(sub)
        if mu is None:
            raise TorlabInputError(f"step {st.number} has no traction coefficient", path=str(path))
        for c in ("step_time_s", "ball_load_N", "rolling_speed_m_s", "srr"):
            if c not in sub or not sub[c].notna().any():
                raise TorlabInputError(f"step {st.number} lacks the column {c} (load, rolling "
                                       "speed and SRR are needed for the dissipated energy)",
                                       path=str(path))
        t = sub["step_time_s"].to_numpy(dtype=float)
        if amount is None:
            raw = {k.lower(): v for k, v in st.metadata_raw.items()}
            txt = raw.get("applied amount")
            if txt is None:
                raise TorlabInputError(f"step {st.number} has no 'Applied amount': give the amount "
                                       "with its unit (amount='5 uL')", path=str(path),
                                       key="amount")
            try:
                amount = parse_amount(txt.replace("\t", " "), where="Applied amount")
            except TorlabInputError as e:
                lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
                ln = next((i + 1 for i in range(max(st.first_line - 1, 0), len(lines))
                           if lines[i].lower().lstrip().startswith("applied amount")),
                          st.first_line)
                raise TorlabInputError(e.message, path=str(path), line=ln,
                                       key="Applied amount") from None
            amount_text = txt.strip()
        if track_radius is None:
            track_radius = st.metadata.get("disc_track_radius_m", meta.disc_track_radius_m)
            if track_radius is None:
                raise TorlabInputError("no disc track radius in the file: give track_radius=",
                                       path=str(path), key="track_radius")
        args = dict(load=sub["ball_load_N"].ffill().bfill().to_numpy(dtype=float),
                    speed=sub["rolling_speed_m_s"].ffill().bfill().to_numpy(dtype=float),
                    creepage=sub["srr"].ffill().bfill().to_numpy(dtype=float))
        label = f"{path.name} step {st.number}"
    else:
        try:
            df = pd.read_csv(path)
        except Exception as e:  # pandas raises many classes for malformed CSV
            raise TorlabInputError(f"not a readable CSV ({type(e).__name__})", path=str(path)) \
                from None
        need = ("step_time_s", "traction_coefficient", "srr", "rolling_speed_m_s", "ball_load_N")
        miss = [c for c in need if c not in df.columns]
        if miss:
            bare = [c for c in df.columns if c in ("time", "mu", "load", "speed", "t")]
            why = (f" (column(s) {', '.join(bare)} have no unit in their name)" if bare else "")
            raise TorlabInputError(f"missing column(s) {', '.join(miss)}{why}; expected the "
                                   "*_timed.csv of 'torlab mtm reduce'", path=str(path))
        if step is not None and "step" in df:
            df = df[df["step"] == step]
        mu = df["traction_coefficient"].to_numpy(dtype=float)
        t = df["step_time_s"].to_numpy(dtype=float)
        args = {c: df[col].to_numpy(dtype=float) for c, col in
                (("load", "ball_load_N"), ("speed", "rolling_speed_m_s"), ("creepage", "srr"))}
        if amount is None:
            raise TorlabInputError("a time-test CSV carries no applied amount: give it with its "
                                   "unit (amount='5 uL')", path=str(path), key="amount")
        if track_radius is None:
            raise TorlabInputError("a time-test CSV carries no disc track radius: give "
                                   "track_radius=", path=str(path), key="track_radius")
    res = time_test(t, mu, amount=amount, application_time=application_time, density=density,
                    track_radius=float(track_radius), label=label, min_drop=min_drop, **args)
    if amount_text is not None:
        res.amount_text = amount_text
    return res


# ---------------------------------------------------------------------------------------------
# preparation of one test
# ---------------------------------------------------------------------------------------------
@dataclass
class _Prepared:
    test: TimeTest
    t_rel: np.ndarray         # time since application, from the application on
    mu: np.ndarray
    E: np.ndarray             # J/m^2 since application
    N: np.ndarray             # passes since application
    window: np.ndarray        # bool, samples in the fit
    m_applied: float          # kg/m^2 in the band with transfer 1
    transfer_max: float       # largest transfer the layer's tested range allows
    curve: Any                # ln m -> mu
    x_dry: float
    mu_dry: float
    m_max: float
    area: float
    creepage: float
    load: float
    speed: float
    skip: float
    i0: int                   # first sample of the fit window
    N_win: np.ndarray         # disc revolutions since the window start (from i0 on)
    c_rev: float              # energy per unit band area and revolution per unit mu (F xi / w)
    K_rel_var: float          # relative variance of the per-sample F xi v (condition noise)
    xg: np.ndarray            # fixed ln m grid from the dry anchor to the table top
    mug: np.ndarray           # the coefficient on it
    I0: dict[int, np.ndarray]  # per law order: integral of (m if order 0 else 1) / (c_rev mu) dx
    table: Any                # the friction table (with layer derivatives)
    notes: list[str]
    n_evaluations: int


_TABLES: dict[tuple, Any] = {}


def _table(sc: Any, layer: Any, creepage: float, top: float, per_interval: int) -> Any:
    """:func:`~torlab.model.removal.mu_table` with its layer derivatives, cached per layer,
    contact, creepage and range."""
    key = (id(layer), sc.model_dump_json(), creepage, float(f"{top:.6g}"), per_interval)
    hit = _TABLES.get(key)
    if hit is not None and hit[0] is layer:
        return hit[1]
    tab = mu_table(sc, layer, creepage, m_top=top, per_interval=per_interval, gradient=True)
    if len(_TABLES) >= 32:
        _TABLES.pop(next(iter(_TABLES)))
    _TABLES[key] = (layer, tab)
    return tab


def _test_scene(scene: Any, load: float, speed: float) -> Any:
    c = scene.contact.model_copy(update={"load": load})
    k = scene.kinematics.model_copy(update={"speed": speed})
    return scene.model_copy(update={"contact": c, "kinematics": k})


def _prepare(tt: TimeTest, scene: Any, layer: Any, *, skip: Any, duration: float | None,
             per_interval: int, max_transfer: float, fit_transfer: bool = False) -> _Prepared:
    from torlab.model.contact import build_contact
    from torlab.reduce.mtm import running_median

    after = tt.t >= tt.application_time
    t = tt.t[after] - tt.application_time
    mu = tt.mu[after]
    load, speed, xi = tt.load[after], tt.speed[after], tt.creepage[after]
    # the test's conditions: medians of the record; the friction table is built at them
    # rounded to 4 significant digits (one table serves repeated tests at the same conditions;
    # the coefficient changes by far less than the noise), the energy uses them as they are
    F, v, s = (float(np.median(a)) for a in (load, speed, xi))
    r4 = [float(f"{x:.4g}") for x in (F, v, s)]
    sc = _test_scene(scene, F, v)
    contact = build_contact(sc)
    band = band_of(contact, tt.track_radius)
    area = float(band.area)
    m_app = areal_density(tt.amount, area=area, density=tt.density, where=f"{tt.label} amount")
    tr_max = 1.0
    if not fit_transfer or layer.above == "hold" or m_app <= layer.m_max:
        top = m_app * max_transfer
        try:
            layer.check(top)
        except AboveTestedError as e:
            raise e.with_hint(e.hint, key="amount", prefix=f"{tt.label}: ",
                              suffix=" (the applied amount in the band)") from None
        except TorlabInputError as e:
            raise TorlabInputError(f"{tt.label}: {e.message} (the applied amount in the band)",
                                   key="amount") from None
    else:  # transfer fitted: it cannot bring more than the largest tested amount into the band
        top = layer.m_max
        tr_max = layer.m_max / m_app
    table = _table(_test_scene(scene, r4[0], r4[1]), layer, r4[2], top, per_interval)
    power = mu * load * xi * speed
    from scipy.integrate import cumulative_trapezoid

    E = cumulative_trapezoid(power, t, initial=0.0) / area
    N = cumulative_trapezoid(speed, t, initial=0.0) / band.track_length
    notes: list[str] = []
    curve = table.curve(0)
    if skip == "auto":
        dt = float(np.median(np.diff(t)))
        ms = running_median(mu, max(1, round(10.0 / dt)))
        k_min = int(np.argmin(ms[: max(3, len(ms) // 2)]))
        m_b0 = min(m_app * max_transfer, top)
        mu_b0 = float(table(m_b0)[()]) if m_b0 > table.m_dry else float(table.mu_dry[0])
        if float(ms[k_min]) >= mu_b0:
            skip_s = 0.0
            notes.append(f"{tt.label}: no initial drop below the boundary level "
                         f"({mu_b0:.3f}); fitted from the application on")
        else:
            level = float(ms[k_min]) + 0.9 * (mu_b0 - float(ms[k_min]))
            up = np.flatnonzero(ms[k_min:] >= level)
            t90 = float(t[k_min + int(up[0])]) if up.size else float(t[k_min])
            skip_s = 2.0 * t90
            notes.append(f"{tt.label}: fit starts {skip_s:.0f} s after the application: twice "
                         f"the time to recover 90 % of the way from the initial drop to the "
                         f"boundary level {mu_b0:.3f} (1 % of an exponential film effect left)")
    else:
        skip_s = float(skip)
        if not (math.isfinite(skip_s) and skip_s >= 0):
            raise TorlabInputError(f"skip must be a non-negative time (s) or 'auto', got {skip}",
                                   key="skip")
    win = t >= skip_s
    if duration is not None:
        win &= t <= duration
    if np.count_nonzero(win) < MIN_WINDOW:
        raise TorlabInputError(f"only {np.count_nonzero(win)} samples in the fit window "
                               f"({skip_s:g} s after the application to the end); need "
                               f"{MIN_WINDOW}", path=tt.label, key="skip")
    i0 = int(np.flatnonzero(win)[0])
    t_rev = band.track_length / v
    from torlab.model.removal import _cumulative_integral

    xg = np.linspace(float(table.x[0]), float(table.x[-1]), 2049)
    mug = np.asarray(curve(xg), dtype=float)
    mug[0] = float(table.mu_dry[0])
    c_rev = F * s / band.width
    I0 = {0: _cumulative_integral(np.exp(xg) / (c_rev * mug), float(xg[1] - xg[0])),
          1: _cumulative_integral(1.0 / (c_rev * mug), float(xg[1] - xg[0]))}
    return _Prepared(test=tt, t_rel=t, mu=mu, E=E, N=N, window=win, m_applied=m_app,
                     transfer_max=tr_max, i0=i0, N_win=(t[i0:] - t[i0]) / t_rev,
                     c_rev=c_rev, xg=xg, mug=mug, I0=I0, table=table,
                     K_rel_var=float(np.var(load * xi * speed) / np.mean(load * xi * speed) ** 2),
                     curve=curve, x_dry=float(table.x[0]), mu_dry=float(table.mu_dry[0]),
                     m_max=table.m_max, area=area, creepage=s, load=F, speed=v, skip=skip_s,
                     notes=notes, n_evaluations=table.n_evaluations)


# ---------------------------------------------------------------------------------------------
# the fit
# ---------------------------------------------------------------------------------------------
@dataclass
class _Spec:
    law: str
    order: int
    names: tuple[str, ...]    # physical names, e.g. ("k1", "spread", "transfer")
    spread: bool
    transfer_fit: bool


def check_options(laws: Sequence[str], law: str | None = None, transfer: Any = 1.0) -> list[str]:
    """The removal fit's option words, checked before any work: the candidate laws (returned,
    in order, without repeats) and the transfer (a fraction in (0, 1] or ``"fit"``).

    Raises
    ------
    TorlabInputError
        An unknown law (with the nearest known one), no law, or a bad transfer; keyed
        by its option (``laws``, ``law``, ``transfer``).
    """
    cands = list(dict.fromkeys([*laws, *([law] if law else [])]))
    if not cands:
        raise TorlabInputError("no candidate removal law", key="laws")
    for nm in cands:
        _spec(nm, False, "laws" if nm in laws else "law")
    if transfer != "fit":
        try:
            value = float(transfer)
        except (TypeError, ValueError):
            raise TorlabInputError(f"transfer must be a fraction or 'fit', got {transfer!r}",
                                   key="transfer") from None
        if not (0 < value <= 1):
            raise TorlabInputError(f"transfer must be in (0, 1], got {value:g}", key="transfer")
    return cands


def _spec(law: str, transfer_fit: bool, key: str = "laws") -> _Spec:
    if law not in LAWS:
        from torlab._suggest import did_you_mean

        raise TorlabInputError(f"unknown removal law {law!r}; use {', '.join(LAWS)}"
                               f"{did_you_mean(law, LAWS)}", key=key)
    order = 0 if law.startswith("zero") else 1
    spread = law.endswith("+spread")
    names = (f"k{order}",) + (("spread",) if spread else ()) + (("transfer",) if transfer_fit else ())
    return _Spec(law, order, names, spread, transfer_fit)


def _model(theta: np.ndarray, sp: _Spec, preps: list[_Prepared], transfer: float,
           energy: str = "model", nuisance: np.ndarray | None = None, fast: bool = False
           ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per test ``(m, mu, E)`` over the record from the application on.

    Before the fit window (the film phase) the amount follows the measured
    energy in closed form; from the window on either the model's own coupled
    energy (``energy="model"``: ``dm/dN = -(g(m) e_pass(m) + s m)`` solved by
    quadrature, :func:`~torlab.model.removal.passes_solution`) or the measured
    one (``"measured"``: closed form along the record).  ``nuisance`` (one row
    ``(eps, eta)`` per test) scales the measured energy before the window by
    ``1 + eps`` and the modelled energy rate by ``1 + eta`` (for the propagation
    of their measurement errors).  ``fast`` (the optimiser's path, laws without
    spreading): the coupled solution from precomputed integrals, scaled by the
    rate (the third element is then the measured energy, not the modelled one).
    """
    k = math.exp(theta[0])
    i = 1
    s = 0.0
    if sp.spread:
        s = math.exp(theta[i])
        i += 1
    tr = math.exp(theta[i]) if sp.transfer_fit else transfer
    out = []
    for j, p in enumerate(preps):
        m0 = p.m_applied * tr
        eps, eta = (0.0, 0.0) if nuisance is None else (float(nuisance[j, 0]),
                                                         float(nuisance[j, 1]))
        if energy == "measured":
            m = amount_from_energy(m0, sp.order, k, s, p.E, p.N)
            E = p.E
        elif fast and not sp.spread:
            i0 = p.i0
            E_pre = p.E[: i0 + 1] * (1.0 + eps)
            m_pre = amount_from_energy(m0, sp.order, k, 0.0, E_pre, p.N[: i0 + 1])
            m = np.concatenate([m_pre[:-1], _fast_window(p, sp.order, k, 1.0 + eta,
                                                         float(m_pre[-1]))])
            mu = np.interp(np.log(np.maximum(m, 1e-300)), p.xg, p.mug)
            out.append((m, mu, p.E))
            continue
        else:
            i0 = p.i0
            E_pre = p.E[: i0 + 1] * (1.0 + eps)
            m_pre = amount_from_energy(m0, sp.order, k, s, E_pre, p.N[: i0 + 1])
            sol = passes_solution(p.curve, p.mu_dry, p.x_dry, float(m_pre[-1]), sp.order, k, s,
                                  p.c_rev * (1.0 + eta), n_grid=513)
            mw, _, Ew = sol.at(p.N_win)
            m = np.concatenate([m_pre[:-1], mw[:, 0]])
            E = np.concatenate([E_pre[:-1], E_pre[-1] + Ew[:, 0]])
        x = np.log(np.clip(m, math.exp(p.x_dry), p.m_max))
        mu = np.where(m <= math.exp(p.x_dry), p.mu_dry, p.curve(x))
        out.append((m, mu, E))
    return out


def _with_mu_nodes(p: _Prepared, mu_nodes: np.ndarray) -> _Prepared:
    """A copy of a prepared test whose friction table has the node values ``mu_nodes``."""
    from dataclasses import replace as dc_replace

    from torlab.model.removal import _cumulative_integral

    curve = p.table.curve(mu_nodes=mu_nodes)
    mug = np.asarray(curve(p.xg), dtype=float)
    mug[0] = float(mu_nodes[0])
    h = float(p.xg[1] - p.xg[0])
    I0 = {0: _cumulative_integral(np.exp(p.xg) / (p.c_rev * mug), h),
          1: _cumulative_integral(1.0 / (p.c_rev * mug), h)}
    return dc_replace(p, curve=curve, mug=mug, I0=I0, mu_dry=float(mu_nodes[0]))


def _layer_sensitivity(theta: np.ndarray, J: np.ndarray, sp: _Spec, preps: list[_Prepared],
                       transfer: float, energy: str, layer: Any) -> tuple[np.ndarray, np.ndarray]:
    """``G = d theta / d p_nodes`` (n_theta x 4 n_nodes) and the layer's node covariance.

    Each node parameter of the layer (dry anchor and tested amounts) is
    perturbed in turn; the friction tables follow by their derivatives (the
    boundary model linearised at the table nodes, the perturbed parameters
    interpolated like the layer), and ``G = -B J^T J_L`` with ``J_L`` the
    residuals' response and ``B = (J^T J)^-1``.
    """
    from torlab.fit.result import _scaled_inverse

    allp = np.vstack([layer.dry_params, layer.params])
    covs = np.concatenate([layer.dry_cov[None], layer.covs])
    n_nodes = allp.shape[0]

    def resid(pp: list[_Prepared]) -> np.ndarray:
        mods = _model(theta, sp, pp, transfer, energy, fast=True)
        return np.concatenate([(mu_m - p.mu)[p.window] for p, (_, mu_m, _) in
                               zip(pp, mods, strict=True)])

    r0 = resid(preps)
    JL = np.zeros((r0.size, 4 * n_nodes))
    cols = []
    for j in range(n_nodes):
        for q in range(4):
            sd = math.sqrt(max(covs[j, q, q], 0.0))
            cols.append((j, q, sd))
    for c, (j, q, sd) in enumerate(cols):
        if sd <= 0:
            continue
        h = sd
        nodes = allp.copy()[None]
        nodes[0, j, q] += h
        pert = []
        for p in preps:
            tab = p.table
            dp = layer.draw_params(np.exp(tab.x), nodes)[:, 0, :] - tab.params
            mu_n = tab.mu[:, 0] + np.einsum("xp,xp->x", tab.grad[:, 0, :], dp)
            pert.append(_with_mu_nodes(p, mu_n))
        JL[:, c] = (resid(pert) - r0) / h
    B = _scaled_inverse(J.T @ J)
    G = -B @ J.T @ JL
    from scipy.linalg import block_diag

    return G, block_diag(*covs)


def _fast_window(p: _Prepared, order: int, k: float, scale: float, m_s: float) -> np.ndarray:
    """Amount over the fit window for a law without spreading (separable: ``N = I0 / k``).

    ``dm/dN = -k m^order c mu(m)``: the passes from ``m_s`` down to ``m`` are
    ``(I0(ln m_s) - I0(ln m)) / (k scale)`` with the precomputed ``I0``; below the
    dry anchor the friction is constant and the amount follows in closed form.
    """
    m_dry = math.exp(p.xg[0])
    N = p.N_win
    kk = k * scale
    I0 = p.I0[order]
    e_dry = p.c_rev * scale * p.mug[0]
    if m_s > m_dry and kk > 0:
        Is = float(np.interp(math.log(m_s), p.xg, I0))
        target = Is - N * kk
        m = np.exp(np.interp(target, I0, p.xg))
        N_dry = Is / kk
        m1 = m_dry
    else:
        m = np.full(N.size, m_s)
        N_dry = 0.0 if kk > 0 else math.inf
        m1 = m_s
    below = N > N_dry
    if below.any():
        dN = N[below] - N_dry
        if order == 1:
            m[below] = m1 * np.exp(-k * e_dry * dN)
        else:
            m[below] = np.maximum(m1 - k * e_dry * dN, 0.0)
    return m


def _start(sp: _Spec, preps: list[_Prepared], transfer: float, resid: Any) -> tuple[np.ndarray,
                                                                                   np.ndarray,
                                                                                   np.ndarray]:
    """Grid start and bounds of the log parameters."""
    E_end = max(float(np.max(p.E[p.window])) for p in preps)
    N_end = max(float(np.max(p.N[p.window])) for p in preps)
    tr_max = min(p.transfer_max for p in preps)
    m_ref = float(np.median([p.m_applied * (transfer if not sp.transfer_fit else 0.3 * tr_max)
                             for p in preps]))
    k_ref = (m_ref if sp.order == 0 else 1.0) / max(E_end, 1e-300)
    lk = math.log(k_ref)
    grids = [np.linspace(lk - 9.0, lk + 9.0, 19)]
    lo, hi = [lk - 25.0], [lk + 25.0]
    if sp.spread:
        ls = math.log(1.0 / max(N_end, 1.0))
        grids.append(np.linspace(ls - 9.0, ls + 3.0, 9))
        lo.append(ls - 25.0)
        hi.append(ls + 8.0)
    if sp.transfer_fit:
        grids.append(np.log(tr_max * np.array([0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.9])))
        lo.append(math.log(1e-4 * tr_max))
        hi.append(math.log(tr_max))
    mesh = np.stack(np.meshgrid(*grids, indexing="ij"), axis=-1).reshape(-1, len(grids))
    best, best_ss = mesh[0], math.inf
    for th in mesh:
        r = resid(th)
        ss = float(r @ r)
        if ss < best_ss:
            best, best_ss = th, ss
    return best, np.array(lo), np.array(hi)


def _ar1_noise(r: np.ndarray) -> Any:
    """White + AR(1) noise of a residual record by a moment fit of its autocovariance.

    ``gamma(0) = v_w + v_c``, ``gamma(k) = v_c rho^k`` (k >= 1): for each ``rho`` on
    a fine grid the amplitude ``v_c`` is the least-squares fit of the sample
    autocovariance at lags 1-30, and the best ``rho`` wins; ``v_w = gamma(0) - v_c``.
    The sample autocovariance of a record whose mean was removed is low by about
    the long-run variance over ``n``; that is added back (three passes).  A
    correlated part below 5 % of the variance (or ``rho < 0.05``) is dropped.
    Microseconds, where the Whittle estimate of :mod:`torlab.fit._noise` takes a
    noticeable fraction of a second (the coverage test runs it hundreds of times).

    ``n_used`` carries the estimate's own precision into the interval's degrees
    of freedom (``parameter_dof``: ``nu = n_used``): ``nu = 2 / var(ln LRV)``
    with ``var(ln LRV) ~ (5 (1 + rho)/(1 - rho) + 20) / n`` for the long-run
    variance ``LRV``, an empirical fit to the scatter of this estimator on
    simulated white + AR(1) records (correlation times 5-40 samples, 1150
    samples; the median estimate is within 5 % of the truth there).
    """
    from torlab.fit._noise import NoiseModel

    z = np.asarray(r, dtype=float) - float(np.mean(r))
    n = z.size
    K = int(min(30, max(n // 4, 1)))
    g_raw = np.array([float(z[: n - k] @ z[k:]) / n for k in range(K + 1)])
    if g_raw[0] <= 0:
        return NoiseModel(0.0, 0.0, 0.0, kind="none (exact fit)", n_used=n)
    lags = np.arange(1, K + 1)
    rhos = np.linspace(0.0, 0.998, 500)[1:]
    P = rhos[:, None] ** lags[None, :]
    PP = np.sum(P * P, axis=1)
    g = g_raw.copy()
    rho = v_c = 0.0
    for _ in range(3):
        vc = np.clip((P @ g[1:]) / PP, 0.0, g[0])
        sse = np.sum((g[None, 1:] - vc[:, None] * P) ** 2, axis=1)
        j = int(np.argmin(sse))
        rho, v_c = float(rhos[j]), float(vc[j])
        lrv = (g[0] - v_c) + v_c * (1.0 + rho) / (1.0 - rho)
        g = g_raw + lrv / n
    g0 = float(g[0])
    if v_c < 0.05 * g0 or rho < 0.05:
        return NoiseModel(g0, 0.0, 0.0, kind="white", n_used=n)
    nu = 2.0 * n / (5.0 * (1.0 + rho) / (1.0 - rho) + 20.0)
    return NoiseModel(g0 - v_c, v_c, rho, kind="white + AR(1) (moment fit)",
                      n_used=max(int(nu), 2))


def _fit_one(sp: _Spec, preps: list[_Prepared], transfer: float, energy: str) -> dict[str, Any]:
    from scipy.optimize import least_squares

    from torlab.fit._noise import effective_points, parameter_dof, sandwich_covariance

    def resid(theta: np.ndarray) -> np.ndarray:
        mods = _model(theta, sp, preps, transfer, energy, fast=True)
        return np.concatenate([(mu_m - p.mu)[p.window] for p, (_, mu_m, _) in
                               zip(preps, mods, strict=True)])

    x0, lo, hi = _start(sp, preps, transfer, resid)
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
    try:
        # Levenberg-Marquardt (MINPACK) from the grid's best point; the search bounds lie
        # far outside (+-25 in the log parameters) and are enforced afterwards
        sol = least_squares(resid, x0, method="lm", x_scale=1.0, diff_step=1e-7, xtol=1e-9,
                            ftol=1e-10, gtol=1e-10, max_nfev=500)
        if np.any(sol.x < lo) or np.any(sol.x > hi):
            sol = least_squares(resid, np.clip(sol.x, lo + 1e-9, hi - 1e-9), bounds=(lo, hi),
                                method="trf", x_scale=1.0, diff_step=1e-7, xtol=1e-9,
                                ftol=1e-10, gtol=1e-10, max_nfev=500)
    except (ValueError, np.linalg.LinAlgError) as e:
        raise FitError(f"removal fit ({sp.law}) failed: {e}") from None
    if sol.status <= 0:
        raise FitError(f"removal fit ({sp.law}) did not converge ({sol.message}, {sol.nfev} "
                       "evaluations)")
    r = sol.fun
    J = sol.jac
    blocks, off = [], 0
    for p in preps:
        nwin = int(np.count_nonzero(p.window))
        sl = slice(off, off + nwin)
        blocks.append((sl, np.ones(nwin), _ar1_noise(r[sl])))
        off += nwin
    at_bound = [sp.names[i] for i in range(len(sol.x))
                if sol.x[i] - lo[i] < 1e-6 or hi[i] - sol.x[i] < 1e-6]
    cov = sandwich_covariance(J, blocks)
    extra = np.zeros_like(cov)
    if energy == "model" and np.all(np.isfinite(cov)):
        extra = _nuisance_covariance(sol.x, J, sp, preps, transfer, blocks)
    return {"spec": sp, "theta": sol.x, "rss": float(r @ r), "n": int(r.size), "jac": J,
            "blocks": blocks, "neff": effective_points(blocks), "nfev": int(sol.nfev),
            "at_bound": at_bound, "resid": r, "cov": cov + extra, "cov_nuisance": extra,
            "pdof": parameter_dof(J, blocks)}


def _sum_variance(w: np.ndarray, nm: Any) -> float:
    """Variance of ``sum w_i eps_i`` for the white + AR(1) noise ``nm`` (absolute)."""
    var = nm.white_var * float(w @ w)
    if nm.correlated:
        from torlab._stats import ar1_recursion  # scipy.signal.lfilter, without its import

        fwd = ar1_recursion(w, nm.rho)
        bwd = ar1_recursion(w[::-1], nm.rho)[::-1]
        var += nm.correlated_var * float(w @ (fwd + bwd - w))
    return var


def _nuisance_covariance(theta: np.ndarray, J: np.ndarray, sp: _Spec, preps: list[_Prepared],
                         transfer: float, blocks: list[Any]) -> np.ndarray:
    """Parameter covariance from the measured quantities the model takes as given.

    Per test: the energy dissipated before the fit window (the integral of the
    *measured* coefficient over the film phase: its noise, with the block's
    white + AR(1) model, and the scatter of load x SRR x speed) and the energy
    rate in the window (the median of load x SRR x speed).  Linear propagation:
    ``d theta = -B J^T J_nu d nu``, ``B = (J^T J)^-1``.
    """
    T = len(preps)
    var_nu = np.zeros((T, 2))
    for j, (p, (_, _, nm)) in enumerate(zip(preps, blocks, strict=True)):
        i0 = p.i0
        if i0 > 0:
            tt = p.t_rel[: i0 + 1]
            w = np.zeros(i0 + 1)
            dt = np.diff(tt)
            w[:-1] += 0.5 * dt
            w[1:] += 0.5 * dt
            Ks = p.E[i0] / max(float(w @ p.mu[: i0 + 1]), 1e-300)  # mean F xi v / A
            var_E = Ks**2 * (_sum_variance(w, nm) + p.K_rel_var * float(
                (w * p.mu[: i0 + 1]) @ (w * p.mu[: i0 + 1])))
            var_nu[j, 0] = var_E / max(p.E[i0], 1e-300) ** 2
        var_nu[j, 1] = 0.5 * math.pi * p.K_rel_var / max(int(np.count_nonzero(p.window)), 1)
    if not np.any(var_nu > 0):
        return np.zeros((theta.size, theta.size))

    def resid(nu: np.ndarray) -> np.ndarray:
        mods = _model(theta, sp, preps, transfer, "model", nu.reshape(T, 2), fast=True)
        return np.concatenate([(mu_m - p.mu)[p.window] for p, (_, mu_m, _) in
                               zip(preps, mods, strict=True)])

    r0 = resid(np.zeros(2 * T))
    Jn = np.zeros((r0.size, 2 * T))
    for i in range(2 * T):
        if var_nu.ravel()[i] <= 0:
            continue
        h = 1e-4
        e = np.zeros(2 * T)
        e[i] = h
        Jn[:, i] = (resid(e) - r0) / h
    from torlab.fit.result import _scaled_inverse

    B = _scaled_inverse(J.T @ J)
    G = B @ J.T @ Jn
    out = G @ np.diag(var_nu.ravel()) @ G.T
    return 0.5 * (out + out.T)


def fit_removal(tests: TimeTest | Sequence[TimeTest], layer: Any, scene: Any, *,
                laws: Sequence[str] = ("zero_order", "first_order"), law: str | None = None,
                transfer: float | str = 1.0, skip: float | str = "auto",
                duration: float | None = None, per_interval: int = 6,
                energy: str = "model") -> FitResult:
    """Fit a removal law to time tests after application (module docstring).

    Parameters
    ----------
    tests
        :class:`TimeTest` (or a list: one product, fitted jointly).
    layer
        The product's :class:`~torlab.model.amount.AmountLayer` (HPT amount series).
    scene
        The tribometer's contact (:class:`~torlab.scene.Scene`: ball and disc radii
        and materials); each test's own load and speed replace the scene's.
    laws
        Candidate laws (:data:`torlab.model.removal.LAWS`); the criterion picks one.
    law
        Force this law (still reported against the other candidates).
    transfer
        Fraction of the applied product that reaches the band: a number (fixed,
        default 1) or ``"fit"``.
    skip
        Seconds after the application excluded from the fit (the film phase), or
        ``"auto"``.
    duration
        Fit up to this time after the application (s).
    per_interval
        Friction-table nodes per interval between tested amounts.
    energy
        Energy that drives the removal in the fit window: ``"model"`` (default,
        the modelled coefficient's, as in a prediction) or ``"measured"`` (the
        record's, taken as exact).

    Returns
    -------
    FitResult
        ``kind="removal"``: the chosen law's parameters (``k0`` kg/J or ``k1``
        m^2/J, ``spread`` 1/pass, ``transfer``), standard errors, 95 %
        intervals, correlations; ``meta`` holds ``law``, ``order``,
        ``law_selection``, ``fit_space`` (log parameters and covariance, for
        draws), the windows, the band and energy of each test; ``data`` the
        measured and modelled coefficient against the time since application.

    Raises
    ------
    TorlabInputError
        Bad options, an applied amount above the tested range, too short a window.
    FitError
        The optimiser fails.
    """
    import pandas as pd

    items = [tests] if isinstance(tests, TimeTest) else list(tests)
    if not items:
        raise TorlabInputError("no time test given")
    fit_tr = transfer == "fit"
    cands = check_options(laws, law, transfer)
    if not fit_tr:
        transfer = float(transfer)
    specs = [_spec(nm, fit_tr, "laws" if nm in laws else "law") for nm in cands]
    preps = [_prepare(tt, scene, layer, skip=skip, duration=duration, per_interval=per_interval,
                      max_transfer=1.0 if fit_tr else float(transfer), fit_transfer=fit_tr)
             for tt in items]
    if fit_tr and min(p.transfer_max for p in preps) < 1.0:
        tmax = min(p.transfer_max for p in preps)
        preps[0].notes.append(f"transfer searched up to {tmax:.3g}: more would put more product "
                              "into the band than the largest tested amount")
    if energy not in ("model", "measured"):
        raise TorlabInputError(f"energy must be 'model' or 'measured', got {energy!r}",
                               key="energy")
    fits = [_fit_one(sp, preps, 1.0 if fit_tr else float(transfer), energy) for sp in specs]
    # --- the information criterion -----------------------------------------------------------
    best_rss = min(fits, key=lambda f: f["rss"])
    neff = float(best_rss["neff"])
    n = best_rss["n"]
    rows = []
    for f in fits:
        p = len(f["spec"].names)
        corr = 2.0 * p * (p + 1) / max(neff - p - 1, 1.0)
        aicc = neff * math.log(max(f["rss"], 1e-300) / n) + 2 * p + corr
        rows.append({"law": f["spec"].law, "parameters": p, "rss": f["rss"], "aicc": aicc,
                     "at_bound": ", ".join(f["at_bound"])})
    a_min = min(r["aicc"] for r in rows)
    wsum = sum(math.exp(-0.5 * (r["aicc"] - a_min)) for r in rows)
    for r in rows:
        r["delta_aicc"] = r["aicc"] - a_min
        r["weight"] = math.exp(-0.5 * r["delta_aicc"]) / wsum
    chosen = law if law else min(rows, key=lambda r: r["aicc"])["law"]
    f = fits[cands.index(chosen)]
    sp = f["spec"]
    theta = f["theta"]
    G, cov_L = _layer_sensitivity(theta, f["jac"], sp, preps, 1.0 if fit_tr else float(transfer),
                                  energy, layer)
    cov_layer = G @ cov_L @ G.T
    cov_t = f["cov"] + cov_layer
    vals = np.exp(theta)
    D = np.diag(vals)
    cov = D @ cov_t @ D
    dof = max(math.floor(f["neff"]) - len(theta), 2)
    pdof = np.maximum(f["pdof"], 2.0)
    # --- data against model ------------------------------------------------------------------
    mods = _model(theta, sp, preps, 1.0 if fit_tr else float(transfer), energy)
    frames = []
    for p, (m, mu_m, E_m) in zip(preps, mods, strict=True):
        frames.append(pd.DataFrame({
            "test": p.test.label, "time_s": p.t_rel, "mu_measured": p.mu, "mu_model": mu_m,
            "residual": p.mu - mu_m, "amount_mg_m2": m / MG_M2, "energy_J_m2": E_m,
            "energy_measured_J_m2": p.E,
            "passes": p.N, "in_fit": p.window}))
    warnings: list[str] = []
    for nm in f["at_bound"]:
        warnings.append(f"{nm} not determined: at the bound of its search range (the data do not "
                        "resolve it)")
    notes = [nt for p in preps for nt in p.notes]
    meta: dict[str, Any] = {
        "law": sp.law, "order": sp.order,
        "method": "closed-form amount from the measured energy; trf least squares in log "
                  "parameters from a grid start; covariance from a white + AR(1) noise model per "
                  "test (Whittle), Satterthwaite degrees of freedom; law by AICc on effective "
                  "points",
        "criterion": "AICc on the effective number of independent points",
        "law_selection": rows,
        "fit_space": {"names": list(sp.names), "values": [float(v) for v in theta],
                      "covariance": [[float(v) for v in row] for row in cov_t],
                      "covariance_without_layer": [[float(v) for v in row] for row in f["cov"]],
                      "layer_sensitivity": [[float(v) for v in row] for row in G],
                      "layer_nodes_mg_m2": [float(v) / MG_M2 for v in layer.nodes]},
        "uncertainty_parts": {
            "quantity": "standard error of ln(parameter), per part",
            "data": [math.sqrt(max(v, 0.0)) for v in np.diag(f["cov"] - f["cov_nuisance"])],
            "measured_conditions": [math.sqrt(max(v, 0.0)) for v in np.diag(f["cov_nuisance"])],
            "layer": [math.sqrt(max(v, 0.0)) for v in np.diag(cov_layer)]},
        "interval_dof": {nm: round(float(d), 1) for nm, d in zip(sp.names, pdof, strict=True)},
        "effective_points": float(f["neff"]),
        "transfer": "fitted" if fit_tr else float(transfer),
        "energy": ("measured coefficient before the fit window, modelled one in it"
                   if energy == "model" else "measured coefficient throughout") +
                  ": E = integral |mu| F |SRR| v dt / (2 pi r_track 2b)",
        "tests": [{"label": p.test.label, "applied": p.test.amount_text,
                   "application_time_s": p.test.application_time,
                   "application_source": p.test.application_source,
                   "initial_amount_mg_m2": p.m_applied / MG_M2, "band_area_m2": p.area,
                   "load_N": p.load, "speed_m_s": p.speed, "creepage": p.creepage,
                   "fit_from_s": p.skip, "samples_in_fit": int(np.count_nonzero(p.window)),
                   "energy_at_end_J_m2": float(p.E[-1]), "passes_at_end": float(p.N[-1])}
                  for p in preps],
        "notes": notes,
        "source": ", ".join(p.test.label for p in preps),
    }
    fixed = {} if fit_tr else {"transfer": float(transfer)}
    if not sp.spread:
        fixed["spread"] = 0.0
    res = RemovalFit.from_covariance(
        "removal", sp.names, vals, cov, dof=dof, param_dof=pdof,
        residual_norm=float(np.sqrt(np.mean(f["resid"] ** 2))), n_points=int(f["n"]),
        warnings=warnings, data=pd.concat(frames, ignore_index=True), meta=meta,
        fixed=fixed, residual_unit="-",
        n_evaluations=int(f["nfev"] + sum(p.n_evaluations for p in preps)),
        x_column="time_s", y_column="mu_measured")
    se_t = np.sqrt(np.clip(np.diag(cov_t), 0.0, None))
    for i, nm in enumerate(sp.names):
        q = student_t(pdof[i])
        res.ci95[nm] = (float(math.exp(theta[i] - q * se_t[i])),
                        float(math.exp(theta[i] + q * se_t[i])))
        if nm == "transfer":
            tmax = min(p.transfer_max for p in preps)
            res.ci95[nm] = (res.ci95[nm][0], min(res.ci95[nm][1], tmax))
    dens = {float(p.test.density) for p in preps if p.test.density is not None}
    res.parameter_file = _parameter_section(res, layer, dens.pop() if len(dens) == 1 else None)
    return res


# ---------------------------------------------------------------------------------------------
# the result and its parameter file
# ---------------------------------------------------------------------------------------------
#: version of the ``retention:`` section of a parameter file
RETENTION_FORMAT = 1


@dataclass
class RemovalFit(FitResult):
    """The removal fit: a :class:`~torlab.fit.result.FitResult` (``kind="removal"``) that
    also carries what a prediction needs besides the law (:attr:`parameter_file`).

    Attributes
    ----------
    parameter_file
        The ``retention:`` section of ``params.yaml``: the law with its log-space
        covariance and sensitivity to the layer, the product's amount layer
        (:meth:`~torlab.model.amount.AmountLayer.to_dict`) and density.  Read
        back by :func:`load_retention`.
    """

    parameter_file: dict[str, Any] = field(default_factory=dict)

    def to_yaml_dict(self) -> dict[str, Any]:
        """``params.yaml``: the ``retention:`` section and the ``fit:`` provenance.

        A removal law has no scene keys (``boundary:``, ``lubricant:``): the
        file is read by ``torlab predict retention`` and ``predict traction
        --sweep``, not merged into a scene.
        """
        return {"retention": self.parameter_file, "fit": self.provenance()}

    def plot(self, *, title: str | None = None, model_curve: tuple[Any, Any] | None = None
             ) -> Any:
        """Measured against modelled coefficient and the remaining amount
        (:func:`torlab.reports.retention.removal_figure`)."""
        return removal_figure(self, title=title)


def _parameter_section(res: FitResult, layer: Any, density: float | None) -> dict[str, Any]:
    """The ``retention:`` section of a removal fit's parameter file."""
    allv = {**res.fixed, **res.params}
    return {
        "format": RETENTION_FORMAT,
        "law": res.meta["law"],
        "order": int(res.meta["order"]),
        "parameters": {k: float(v) for k, v in allv.items()},
        "units": {k: LAW_UNITS.get(k, "-") for k in allv},
        "fitted": list(res.names),
        "ci95": {k: [float(a), float(b)] for k, (a, b) in res.ci95.items()},
        "dof": int(res.dof),
        "interval_dof": dict(res.meta.get("interval_dof", {})),
        "density_kg_m3": density,
        "fit_space": res.meta["fit_space"],
        "layer": layer.to_dict(),
    }


@dataclass
class RetentionParams:
    """What ``torlab predict retention`` reads from a removal fit's parameter file.

    Attributes
    ----------
    layer
        The product's :class:`~torlab.model.amount.AmountLayer`.
    removal
        The law as a :class:`RemovalFit` (estimate, log-space covariance,
        sensitivity to the layer: :func:`torlab.model.retention.removal_draws`).
    density
        Product density (kg/m^3) of the time tests, or None.
    source
        The file.
    """

    layer: Any
    removal: Any
    density: float | None
    source: str


def _matrix(v: Any, shape: tuple[int, int], where: str, path: str) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.shape != shape or not np.all(np.isfinite(a)):
        raise TorlabInputError(f"expected a finite {shape[0]} x {shape[1]} matrix", path=path,
                               key=where)
    return a


def _log_values(v: Any, k: int, path: str) -> np.ndarray:
    """``fit_space.values``: the log parameters, finite except the rate's, which may be
    ``-.inf`` (a rate of zero: the product is not removed)."""
    try:
        a = np.asarray([v], dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.shape == (1, k) and a[0, 0] == -math.inf and np.all(np.isfinite(a[0, 1:])):
        return a[0]
    return _matrix([v], (1, k), "retention.fit_space.values", path)[0]


def retention_from_dict(d: Any, *, path: str = "", fit: Any = None) -> RetentionParams:
    """:class:`RetentionParams` from the ``retention:`` section (every value checked).

    Raises
    ------
    TorlabInputError
        Missing or malformed keys, an unknown law or format, matrices of the
        wrong shape or not finite, a layer of :meth:`AmountLayer.from_dict`'s
        errors.
    """
    from torlab.model.amount import AmountLayer

    def bad(msg: str, k: str = "") -> TorlabInputError:
        return TorlabInputError(msg, path=path or None, key=f"retention.{k}" if k else "retention")

    if not isinstance(d, dict):
        raise bad("expected the retention: section of 'torlab fit removal' output")
    if d.get("format") != RETENTION_FORMAT:
        raise bad(f"format {d.get('format')!r} is not the one this torlab reads "
                  f"({RETENTION_FORMAT})", "format")
    law = d.get("law")
    if law not in LAWS:
        raise bad(f"unknown removal law {law!r}; use one of {', '.join(LAWS)}", "law")
    order = 0 if str(law).startswith("zero") else 1
    fs = d.get("fit_space")
    if not isinstance(fs, dict) or not isinstance(fs.get("names"), list):
        raise bad("missing fit_space (names, values, covariance, layer_sensitivity)",
                  "fit_space")
    names = [str(n) for n in fs["names"]]
    k = len(names)
    if not 1 <= k <= 3 or names[0] != f"k{order}" or \
            any(n not in ("spread", "transfer") for n in names[1:]):
        raise bad(f"names {names} do not fit the law {law}", "fit_space.names")
    theta = _log_values(fs.get("values"), k, path)
    cov = _matrix(fs.get("covariance"), (k, k), "retention.fit_space.covariance", path)
    cov0 = _matrix(fs.get("covariance_without_layer", cov), (k, k),
                   "retention.fit_space.covariance_without_layer", path)
    for c, nm in ((cov, "covariance"), (cov0, "covariance_without_layer")):
        if not np.allclose(c, c.T, rtol=1e-6, atol=0.0) or np.any(np.diag(c) < 0):
            raise bad("must be symmetric with a non-negative diagonal", f"fit_space.{nm}")
        if theta[0] == -math.inf and np.any(c[0] != 0):
            raise bad(f"a removal rate of zero ({names[0]}: 0, ln = -.inf) is exact: its row "
                      "and column must be zero", f"fit_space.{nm}")
    layer = AmountLayer.from_dict(d.get("layer"), path=path or None, key="retention.layer")
    n_nodes = layer.nodes.size
    G = fs.get("layer_sensitivity", [])
    if G:
        g = _matrix(G, (k, 4 * n_nodes), "retention.fit_space.layer_sensitivity", path)
        if theta[0] == -math.inf and np.any(g[0] != 0):
            raise bad(f"a removal rate of zero ({names[0]}: 0) does not follow the layer: its "
                      "row must be zero", "fit_space.layer_sensitivity")
        _matrix([fs.get("layer_nodes_mg_m2")], (1, n_nodes),
                "retention.fit_space.layer_nodes_mg_m2", path)
    pars = d.get("parameters") if isinstance(d.get("parameters"), dict) else {}
    fixed = {}
    for nm in ("spread", "transfer"):
        if nm not in names and nm in pars:
            try:
                fixed[nm] = float(pars[nm])
            except (TypeError, ValueError):
                raise bad(f"{nm} must be a number", f"parameters.{nm}") from None
    if not (0 <= fixed.get("spread", 0.0) and 0 < fixed.get("transfer", 1.0) <= 1):
        raise bad("spread must be >= 0 and transfer in (0, 1]", "parameters")
    dens = d.get("density_kg_m3")
    if dens is not None and (isinstance(dens, bool) or not isinstance(dens, (int, float))
                             or not (math.isfinite(dens) and dens > 0)):
        raise bad("must be a positive number (kg/m^3) or null", "density_kg_m3")
    vals = np.exp(theta)
    _check_readable_copies(d, names, vals, bad)
    D = np.diag(vals)
    dof = d.get("dof", 10)
    res = RemovalFit.from_covariance(
        "removal", tuple(names), vals, D @ cov @ D,
        dof=int(dof) if isinstance(dof, int) and dof > 0 else 10, residual_norm=0.0,
        n_points=0, warnings=[], data=None, fixed=fixed, residual_unit="-",
        meta={"law": law, "order": order, "fit_space": fs, "source": Path(path).name if path
              else "retention parameters"}, parameter_file=d)
    ci = d.get("ci95") if isinstance(d.get("ci95"), dict) else {}
    for nm in names:
        iv = ci.get(nm)
        if isinstance(iv, list) and len(iv) == 2 and all(isinstance(x, (int, float))
                                                           for x in iv):
            res.ci95[nm] = (float(iv[0]), float(iv[1]))
    return RetentionParams(layer=layer, removal=res, density=None if dens is None else float(dens),
                           source=path)


def _check_readable_copies(d: dict, names: list[str], vals: np.ndarray,
                           bad: Callable[[str, str], TorlabInputError]) -> None:
    """The file's readable ``units``, ``parameters`` and ``ci95`` agree with ``fit_space``.

    The fit's numbers are read from ``fit_space`` (the log-parameters and their
    covariance); ``parameters``, ``units`` and ``ci95`` repeat them for people.  An edit
    to one of those copies would otherwise be ignored silently, so a copy that
    disagrees -- another unit, another value, an interval that leaves out the value --
    is an error naming the key.
    """
    units = d.get("units")
    if units is not None:
        if not isinstance(units, dict):
            raise bad("must be a map of parameter: unit", "units")
        for nm, u in units.items():
            want = LAW_UNITS.get(str(nm))
            if want is None:
                raise bad(f"unknown parameter {nm!r}; the laws have "
                          f"{', '.join(LAW_UNITS)}", f"units.{nm}")
            if str(u).replace(" ", "").replace("**", "^") != want:
                raise bad(f"{nm} is read in {want} (the unit 'torlab fit removal' writes), "
                          f"not {u!r}: refit instead of converting by hand", f"units.{nm}")
    pars = d.get("parameters")
    if pars is not None and not isinstance(pars, dict):
        raise bad("must be a map of parameter: value", "parameters")
    ci = d.get("ci95") if isinstance(d.get("ci95"), dict) else {}
    for nm, v in zip(names, vals, strict=True):
        if pars and nm in pars:
            p = pars[nm]
            if isinstance(p, bool) or not isinstance(p, (int, float)) or not math.isfinite(p):
                raise bad("must be a number", f"parameters.{nm}")
            if not math.isclose(p, v, rel_tol=1e-6):
                raise bad(f"{p:.6g} disagrees with fit_space.values ({v:.6g}), which the "
                          f"fit's numbers are read from: refit instead of editing",
                          f"parameters.{nm}")
        iv = ci.get(nm)
        if iv is not None and not (isinstance(iv, list) and len(iv) == 2
                                   and all(isinstance(x, (int, float))
                                           and not isinstance(x, bool) and math.isfinite(x)
                                           for x in iv)
                                   and iv[0] <= v * (1 + 1e-9) and v <= iv[1] * (1 + 1e-9)):
            raise bad(f"must be [low, high] around the value {v:.6g}", f"ci95.{nm}")


def is_retention_file(path: str | Path) -> bool:
    """Whether a YAML file is a removal fit's parameter file (a top-level ``retention:``)."""
    from torlab.yamlio import load_yaml

    d = load_yaml(path).data
    return isinstance(d, dict) and "retention" in d


def load_retention(path: str | Path) -> RetentionParams:
    """Read a removal fit's parameter file (``torlab fit removal`` -> ``params.yaml``).

    Raises
    ------
    TorlabInputError
        Not such a file, or a malformed ``retention:`` section (file and key named).
    """
    from torlab.yamlio import load_yaml

    doc = load_yaml(path)
    d = doc.data
    if not isinstance(d, dict) or "retention" not in d:
        raise TorlabInputError("not a removal parameter file (no retention: section; write one "
                               "with 'torlab fit removal')", path=str(path))
    try:
        return retention_from_dict(d["retention"], path=str(path))
    except TorlabInputError as e:
        if e.key and e.line is None:
            kp = tuple(int(x) if x.isdigit() else x for x in
                       e.key.replace("[", ".").replace("]", "").split("."))
            raise TorlabInputError(e.message, path=str(path), line=doc.lines.line(kp),
                                   key=e.key) from None
        raise


def removal_figure(result: FitResult, title: str | None = None) -> Any:
    """Measured against modelled coefficient after application (top), remaining amount
    (bottom): :func:`torlab.reports.retention.removal_figure`."""
    from torlab.reports.retention import removal_figure as _figure

    return _figure(result, title=title)
