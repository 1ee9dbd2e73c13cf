"""Time tests after application (Paper B, thesis 5.3.2): a record ready for the removal fit.

A time test runs a ball-on-disc contact at constant load [N], rolling speed [m/s] and
slide-roll ratio [-] for minutes; a product is applied onto the disc track at the
application time [s], and the coefficient drops and recovers as the product is removed.
:func:`read_time_test` reads one from a PCS export (its timed step: load, speeds and
slide-roll ratio per sample, and where written the ``Applied amount`` with its unit and
the ``Disc track radius``) or from the ``*_timed.csv`` of ``torlab mtm reduce``;
:func:`time_test` builds one from arrays.  Either checks what the removal fit
(:func:`torlab.fit.removal.fit_removal`) relies on and finds the application (the
largest drop of the coefficient, :func:`torlab.reduce.mtm.time_test_metrics`) where it
is not given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.model.amount import parse_amount

__all__ = ["DEFAULT_MIN_DROP", "MIN_WINDOW", "TimeTest", "read_time_test", "read_timed_csv",
           "time_test"]


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


def _per_sample(v: Any, n: int, name: str, where: str) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise TorlabInputError(f"{name} must be one value or one per sample", path=where, key=name)
    if not np.all(np.isfinite(a)):
        raise TorlabInputError(f"{name} has non-finite values", path=where, key=name)
    return a


def _detect_application(t: np.ndarray, mu: np.ndarray, label: str, min_drop: float) -> float:
    from torlab.reduce.mtm import time_test_metrics

    r = time_test_metrics(t, mu, min_drop=min_drop, label=label)
    if r.application_source != "detected":
        raise TorlabInputError(
            f"no application marker: the coefficient never drops by {min_drop:g} or more, and no "
            "application time was given; a removal fit needs the moment the product was applied "
            "(--application-time '60 s'; application_time= in Python)", path=label)
    return float(r.application_time_s)


def time_test(t: Any, mu: Any, *, amount: Any, load: Any, speed: Any, creepage: Any,
              track_radius: float, application_time: float | None = None,
              density: float | None = None, label: str = "time test",
              min_drop: float = DEFAULT_MIN_DROP, lines: Any = None) -> TimeTest:
    """A :class:`TimeTest` from arrays (SI units; amount as a quantity with its unit).

    Samples whose load is zero or negative (an unloaded moment, or a broken load cell) have
    no coefficient: they are dropped, and a note says how many (with their ``lines`` in
    the file, where given).

    Raises
    ------
    TorlabInputError
        Too few samples, non-increasing time, an amount without unit or negative,
        no application marker (not given and no drop found), non-positive load in every
        sample, non-positive speed, slide-roll ratio or track radius.
    """
    t = np.asarray(t, dtype=float)
    mu = np.abs(np.asarray(mu, dtype=float))
    n_all = int(np.size(t))
    w = _per_sample(load, n_all, "load", label) if np.ndim(load) else None
    unloaded = np.zeros(n_all, dtype=bool) if w is None else ~(w > 0)
    if unloaded.all():
        raise TorlabInputError("load must be positive (it is zero or negative in every sample)",
                               path=label, key="load")
    ok = np.isfinite(t) & np.isfinite(mu) & ~unloaded
    n_bad = int(np.size(ok) - np.count_nonzero(ok | unloaded))
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
    if unloaded.any():
        where = ""
        if lines is not None:
            ln = np.asarray(lines)[unloaded]
            where = f" (lines {ln.min()}-{ln.max()})" if len(ln) > 1 else f" (line {ln[0]})"
        notes.append(f"{int(unloaded.sum())} samples with a load of zero or less{where} dropped: "
                     "a coefficient needs a load")
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
    path = Path(path)
    from torlab.files import open_regular

    with open_regular(path) as fh:  # a regular file only: no FIFO or device is waited on
        text_start = fh.read(200).decode("utf-8", "replace")
    if text_start.lstrip().lower().startswith(("mtm", "etm", "ehd")):
        t, mu, args, amount, amount_text, track_radius, label = _from_pcs(
            path, step, amount, track_radius)
    else:
        t, mu, args = _from_csv(path, step, amount, track_radius)
        amount_text, label = None, path.name
    notes = args.pop("notes", [])
    res = time_test(t, mu, amount=amount, application_time=application_time, density=density,
                    track_radius=float(track_radius), label=label, min_drop=min_drop, **args)
    if amount_text is not None:
        res.amount_text = amount_text
    res.notes += notes
    return res


def _from_pcs(path: Path, step: int | None, amount: Any, track_radius: float | None
              ) -> tuple[Any, Any, dict[str, Any], Any, str | None, Any, str]:
    """The timed step of a PCS export: time [s], coefficient, load [N], rolling speed [m/s]
    and slide-roll ratio per sample; the amount and track radius [m] from the step where
    not given; the label."""
    from torlab.parsers.pcs import read_pcs
    from torlab.reduce.mtm import mu_series

    amount_text: str | None = None
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
                                   "with its unit (--amount '5 uL'; amount='5 uL' in Python)",
                                   path=str(path), key="amount")
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
            raise TorlabInputError("no disc track radius in the file: give it (--track-radius "
                                   "'21 mm'; track_radius= in Python)", path=str(path),
                                   key="track_radius")
    notes = []
    if st is meta.unfinished_step:
        notes.append(f"the test stopped during step {st.number} (the export "
                     f"{'has no end line' if meta.completed_at is None else 'ends ' + repr(meta.end_text)}"
                     f"): fitted over the {np.nanmax(t):.0f} s recorded")
    args = dict(load=sub["ball_load_N"].ffill().bfill().to_numpy(dtype=float),
                lines=sub["line"].to_numpy(), notes=notes,
                speed=sub["rolling_speed_m_s"].ffill().bfill().to_numpy(dtype=float),
                creepage=sub["srr"].ffill().bfill().to_numpy(dtype=float))
    return t, mu, args, amount, amount_text, track_radius, f"{path.name} step {st.number}"


def read_timed_csv(path: str | Path, need: tuple[str, ...] = ()) -> Any:
    """The ``*_timed.csv`` of ``torlab mtm reduce``: its table, with ``step_time_s`` [s] and
    ``traction_coefficient`` [-] and the columns ``need`` (the one reader of that table: the
    removal fit's time tests, the comparisons' time tests).

    Raises
    ------
    TorlabInputError
        Not a readable CSV, or a column missing (named, with a hint where a column has no
        unit in its name).
    """
    import pandas as pd

    from torlab.files import open_regular

    try:
        with open_regular(path) as fh:  # a regular file only: no FIFO or device is waited on
            df = pd.read_csv(fh)
    except TorlabInputError:
        raise
    except Exception as e:  # pandas raises many classes for malformed CSV
        raise TorlabInputError(f"not a readable CSV ({type(e).__name__})", path=str(path)) \
            from None
    cols = ("step_time_s", "traction_coefficient", *need)
    miss = [c for c in cols if c not in df.columns]
    if miss:
        bare = [c for c in df.columns if c in ("time", "mu", "load", "speed", "t")]
        why = (f" (column(s) {', '.join(bare)} have no unit in their name)" if bare else "")
        raise TorlabInputError(f"missing column(s) {', '.join(miss)}{why}; expected the "
                               "*_timed.csv of 'torlab mtm reduce'", path=str(path))
    return df


def _from_csv(path: Path, step: int | None, amount: Any, track_radius: float | None
              ) -> tuple[Any, Any, dict[str, Any]]:
    """A ``*_timed.csv`` of ``torlab mtm reduce``: time [s], coefficient, load [N], rolling
    speed [m/s] and slide-roll ratio per sample (the amount and the track radius must be
    given)."""
    df = read_timed_csv(path, ("srr", "rolling_speed_m_s", "ball_load_N"))
    if step is not None and "step" in df:
        df = df[df["step"] == step]
    mu = df["traction_coefficient"].to_numpy(dtype=float)
    t = df["step_time_s"].to_numpy(dtype=float)
    args = {c: df[col].to_numpy(dtype=float) for c, col in
            (("load", "ball_load_N"), ("speed", "rolling_speed_m_s"), ("creepage", "srr"))}
    if amount is None:
        raise TorlabInputError("a time-test CSV carries no applied amount: give it with its "
                               "unit (--amount '5 uL'; amount='5 uL' in Python)",
                               path=str(path), key="amount")
    if track_radius is None:
        raise TorlabInputError("a time-test CSV carries no disc track radius: give it "
                               "(--track-radius '21 mm'; track_radius= in Python)",
                               path=str(path), key="track_radius")
    return t, mu, args
