"""Optical tribometer reduction: windowed averages at set conditions, Tab. 5.2 test types.

For each set condition of a log (thesis 5.1.1, Paper A 5.3.1) the mean over the
last ``window`` seconds of the condition (4 s in Paper A: "each measurement point
of the coefficient of adhesion is an average from a 4 second long interval at
set measurement conditions") of

* the surface speeds ``u_ball``, ``u_disc`` -> rolling (entrainment) speed
  ``U = (u_ball + u_disc) / 2`` and slide-to-roll ratio
  ``SRR = (u_ball - u_disc) / U`` as a fraction (thesis Eq. 2.4, model notes
  section 2: SRR equals the creepage);
* the coefficient ``mu = F / W`` per sample (friction force over normal load),
  or ``mu = T / (r_ball W)`` from the ball-shaft torque, then its mean and
  standard deviation over the window;
* the normal load, temperature and film thickness (mean of the camera frames in
  the window).

The window ends at the end of the condition, after the transient of the change.
A condition shorter than the window is averaged whole and flagged
(``window_complete = False``).

Test types of thesis Tab. 5.2 (given in the log's ``test`` header or detected):

* ``film_thickness``: SRR about 0 (|SRR| < 0.5 %), film thickness logged ->
  h against rolling speed;
* ``stribeck``: constant SRR, rolling speed varying -> mu against rolling speed;
* ``traction`` / ``dry_traction`` (lubricant ``none``/``dry``): SRR varying, at
  one or several rolling speeds -> mu against SRR per speed.  Negative SRR is
  folded onto positive (``|SRR|``, ``-mu``) and the symmetry checked: every
  pair of points at ``-s`` and ``+s`` (same speed, ``|s|`` within 5 % or 0.1 %
  SRR) must agree within ``max(rel_tol |mu|, abs_tol)``, defaults 10 % and
  0.005.

:func:`reduce_optical_log` streams a log in chunks: memory stays bounded by a
chunk plus the trailing window of the current condition, whatever the length
of the log (a 30-minute 1 kHz log has 1.8 M rows).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.parsers._text import PathOrBuffer

__all__ = [
    "DEFAULT_WINDOW_S",
    "OpticalResult",
    "classify_test",
    "fold_traction",
    "reduce_ehd2",
    "reduce_optical_log",
    "speed_groups",
]

DEFAULT_WINDOW_S = 4.0
SRR_ZERO = 0.005
#: |SRR| at or below which a traction point counts as SRR = 0 when folding (0.1 %)
SRR_ZERO_FOLD = 0.001
DEFAULT_SYM_REL = 0.10
DEFAULT_SYM_ABS = 0.005

#: columns of the points table that may be empty (no film frames, no temperature ...)
POINT_OPTIONAL = ("film_thickness_m", "film_thickness_sd_m", "temperature_C",
                  "traction_coefficient", "traction_coefficient_sd", "ball_speed_set_m_s",
                  "disc_speed_set_m_s", "load_set_N", "lube_temperature_C", "pot_temperature_C")


@dataclass
class OpticalResult:
    """A reduced optical (or EHD2) log.

    Attributes
    ----------
    source, label
        File name and a label for tables.
    test
        Test type (:data:`torlab.parsers.optical.TEST_TYPES`) and
        ``test_source`` ``"header"`` or ``"detected"``.
    points
        One row per set condition: ``condition``, ``rolling_speed_m_s``,
        ``srr``, ``traction_coefficient`` and ``_sd``, ``normal_load_N``,
        ``film_thickness_m`` (and ``_sd``, ``n_film``), ``temperature_C``,
        ``ball_speed_m_s``, ``disc_speed_m_s``, ``window_s``,
        ``window_complete``, ``n_samples``, ``t_start_s``, ``t_end_s``,
        ``first_line``, ``last_line``.
    folded
        Traction tests: the folded curve (see :func:`fold_traction`); else None.
    symmetry
        Traction tests: the symmetry check; else {}.
    window_s
        Averaging window.
    rows
        Rows read.
    warnings
        Short conditions, conditions without friction, ...
    """

    source: str
    label: str
    test: str
    test_source: str
    points: Any
    folded: Any = None
    symmetry: dict[str, Any] = field(default_factory=dict)
    window_s: float = DEFAULT_WINDOW_S
    rows: int = 0
    instrument: str = "optical"
    surface: str = ""
    warnings: list[str] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        """One row for ``summary.csv``."""
        p = self.points
        mu = p["traction_coefficient"].to_numpy(dtype=float) if "traction_coefficient" in p \
            else np.array([])
        h = p["film_thickness_m"].to_numpy(dtype=float) if "film_thickness_m" in p else np.array([])
        sym = self.symmetry
        return {
            "file": Path(self.source).name,
            "instrument": self.instrument,
            "surface": self.surface,
            "test": self.test,
            "test_source": self.test_source,
            "n_conditions": len(p),
            "n_rows": self.rows,
            "window_s": self.window_s,
            "rolling_speed_min_m_s": float(p["rolling_speed_m_s"].min()),
            "rolling_speed_max_m_s": float(p["rolling_speed_m_s"].max()),
            "srr_min": float(p["srr"].min()),
            "srr_max": float(p["srr"].max()),
            "traction_coefficient_min": _nan(np.min, mu),
            "traction_coefficient_max": _nan(np.max, mu),
            "film_thickness_min_m": _nan(np.min, h),
            "film_thickness_max_m": _nan(np.max, h),
            "symmetry_pairs": int(sym.get("pairs", 0)),
            "symmetry_max_abs_diff": float(sym.get("max_abs_diff", float("nan"))),
            "symmetric": "" if not sym else ("yes" if sym.get("symmetric") else "no"),
            "symmetry_offset": float(sym.get("offset", float("nan"))),
            "symmetry_offset_low95": float(sym.get("offset_low95", float("nan"))),
            "symmetry_offset_high95": float(sym.get("offset_high95", float("nan"))),
            "symmetry_verdict": sym.get("symmetry_verdict", ""),
            "p_symmetric": float(sym.get("p_symmetric", float("nan"))),
            "warnings": "; ".join(self.warnings),
        }


SUMMARY_OPTIONAL = ("traction_coefficient_min", "traction_coefficient_max", "film_thickness_min_m",
                    "film_thickness_max_m", "symmetry_max_abs_diff", "symmetry_offset",
                    "symmetry_offset_low95", "symmetry_offset_high95", "p_symmetric")


def _nan(fn: Any, v: np.ndarray) -> float:
    v = v[np.isfinite(v)]
    return float(fn(v)) if v.size else float("nan")


#: largest |traction coefficient| accepted from a log; beyond it a load or force cell is wrong
MU_MAX = 10.0


# ---------------------------------------------------------------------- the streaming reducer
class _Accumulator:
    """Keeps the trailing window of the current condition; finalises each condition."""

    def __init__(self, window: float, names: list[str], mu_mode: str, ball_radius: float | None,
                 sign: float, source: str = "") -> None:
        self.source = source
        self.window = window
        self.names = names
        self.mu_mode = mu_mode
        self.r = ball_radius
        self.sign = sign
        self.points: list[dict[str, Any]] = []
        self.key: float | None = None
        self.buf: dict[str, np.ndarray] = {}
        self.start_t = 0.0
        self.start_line = 0
        self.n = 0
        self.run = 0
        self.dt = math.nan

    def feed(self, cols: dict[str, np.ndarray], keys: np.ndarray) -> None:
        t = cols["time_s"]
        if math.isnan(self.dt) and t.size > 1:
            self.dt = float(np.median(np.diff(t[: min(t.size, 10_000)])))
        cut = np.nonzero(keys[1:] != keys[:-1])[0] + 1
        bounds = np.concatenate(([0], cut, [t.size]))
        for a, b in itertools.pairwise(bounds):
            k = float(keys[a])
            part = {c: v[a:b] for c, v in cols.items()}
            if self.key is not None and k == self.key:
                self.n += b - a
                self.buf = {c: np.concatenate((self.buf[c], part[c])) for c in self.buf}
            else:
                self.finish()
                self.key, self.buf = k, part
                self.start_t = float(part["time_s"][0])
                self.start_line = int(part["line"][0])
                self.n = b - a
                self.run += 1
            tb = self.buf["time_s"]
            keep = tb > tb[-1] - self.window * (1 + 1e-9)
            if not keep[0]:
                i0 = int(np.argmax(keep))
                self.buf = {c: v[i0:] for c, v in self.buf.items()}

    def finish(self) -> None:
        if self.key is None or not self.buf:
            return
        key, buf = self.key, self.buf
        self.key, self.buf = None, {}
        if key <= 0 and "condition" in buf:  # condition 0: between set conditions
            return
        t = buf["time_s"]
        t_end = float(t[-1])
        sel = t > t_end - self.window + 0.5 * (self.dt if math.isfinite(self.dt) else 0.0)
        dt = self.dt if math.isfinite(self.dt) else 0.0
        duration = t_end - self.start_t + dt
        complete = duration >= self.window * (1 - 1e-6)
        if not complete:
            sel = np.ones_like(t, dtype=bool)
        ub = buf["ball_speed_m_s"][sel]
        ud = buf["disc_speed_m_s"][sel]
        w = buf["normal_load_N"][sel]
        row: dict[str, Any] = {
            "condition": int(key) if "condition" in buf else self.run,
            "segment": self.run,
        }
        mb, md = float(np.mean(ub)), float(np.mean(ud))
        U = 0.5 * (mb + md)
        row["rolling_speed_m_s"] = U
        row["srr"] = (mb - md) / U if U != 0 else float("nan")
        row["sliding_speed_m_s"] = mb - md
        row["ball_speed_m_s"] = mb
        row["disc_speed_m_s"] = md
        row["normal_load_N"] = float(np.mean(w))
        if self.mu_mode == "force":
            mu = self.sign * buf["friction_force_N"][sel] / w
        elif self.mu_mode == "torque":
            mu = self.sign * buf["torque_N_m"][sel] / (self.r * w)
        else:
            mu = None
        if mu is not None:
            bad = ~(np.abs(mu) <= MU_MAX)
            if bad.any():
                i = int(np.argmax(bad))
                raise TorlabInputError(
                    f"traction coefficient {mu[i]:.4g} (from a normal load of {w[i]:.4g} N) is not a "
                    f"friction coefficient (|mu| <= {MU_MAX:g}); check the load and force columns",
                    path=self.source or None, line=int(buf["line"][sel][i]))
            row["traction_coefficient"] = float(np.mean(mu))
            row["traction_coefficient_sd"] = float(np.std(mu, ddof=1)) if mu.size > 1 else 0.0
        if "film_thickness_m" in buf:
            h = buf["film_thickness_m"][sel]
            h = h[np.isfinite(h)]
            row["film_thickness_m"] = float(np.mean(h)) if h.size else float("nan")
            row["film_thickness_sd_m"] = float(np.std(h, ddof=1)) if h.size > 1 else float("nan")
            row["n_film"] = int(h.size)
        if "temperature_C" in buf:
            row["temperature_C"] = _nan(np.mean, buf["temperature_C"][sel])
        for c in ("ball_speed_set_m_s", "disc_speed_set_m_s", "load_set_N"):
            if c in buf:
                row[c] = float(np.mean(buf[c][sel]))
        row["window_s"] = min(self.window, duration)
        row["window_complete"] = bool(complete)
        row["n_samples"] = int(sel.sum())
        row["t_start_s"] = self.start_t
        row["t_end_s"] = t_end
        row["first_line"] = self.start_line
        row["last_line"] = int(buf["line"][-1])
        self.points.append(row)


def _keys(chunk: dict[str, np.ndarray], state: dict[str, Any]) -> np.ndarray:
    """Per-row condition key: the condition column, or a run counter of set-point changes."""
    if "condition" in chunk:
        return chunk["condition"]
    sp = [c for c in ("ball_speed_set_m_s", "disc_speed_set_m_s", "load_set_N") if c in chunk]
    arr = np.column_stack([chunk[c] for c in sp])
    prev = state.get("prev")
    first_change = prev is None or bool(np.any(arr[0] != prev))
    change = np.r_[first_change, np.any(arr[1:] != arr[:-1], axis=1)]
    run0 = state.get("run", 0)
    runs = run0 + np.cumsum(change)
    state["run"] = int(runs[-1])
    state["prev"] = arr[-1].copy()
    return runs.astype(float)


def reduce_optical_log(src: PathOrBuffer, *, window: float = DEFAULT_WINDOW_S,
                       test: str | None = None, chunksize: int = 250_000,
                       sym_rel: float = DEFAULT_SYM_REL, sym_abs: float = DEFAULT_SYM_ABS,
                       name: str | None = None) -> OpticalResult:
    """Reduce a ``torlab-optical`` log to one point per set condition (thesis 5.1.1, Paper A).

    Parameters
    ----------
    src
        Path or buffer of the log.
    window
        Averaging window (s) at the end of each condition; Paper A: 4 s.
    test
        Test type to use instead of the header's or the detected one.
    chunksize
        Rows per chunk (memory bound).
    sym_rel, sym_abs
        Symmetry tolerances of the traction fold.
    name
        Display name for a buffer.

    Returns
    -------
    OpticalResult

    Raises
    ------
    TorlabInputError
        Bad log (see :func:`torlab.parsers.optical.open_optical` and
        :func:`~torlab.parsers.optical.iter_optical_chunks`), a non-positive
        window, or no set condition in the log.
    """
    import pandas as pd

    from torlab.parsers.optical import iter_optical_arrays, open_optical

    if not (window > 0 and math.isfinite(window)):
        raise TorlabInputError(f"the averaging window must be a positive time, got {window} s",
                               key="window")
    osrc = open_optical(src, name=name)
    meta = osrc.meta
    mode = "force" if "friction_force_N" in osrc.names else \
        "torque" if "torque_N_m" in osrc.names else "none"
    acc = _Accumulator(window, osrc.names, mode, meta.ball_radius, meta.friction_sign,
                       source=meta.source)
    state: dict[str, Any] = {}
    rows = 0
    for chunk in iter_optical_arrays(osrc, chunksize=chunksize):
        acc.feed(chunk, _keys(chunk, state))
        rows += len(chunk["line"])
    acc.finish()
    if not acc.points:
        raise TorlabInputError("no set condition in the log (every row has condition 0)",
                               path=meta.source)
    points = pd.DataFrame(acc.points)
    warnings = []
    short = points.loc[~points["window_complete"], "condition"].tolist()
    if short:
        warnings.append(f"{len(short)} condition(s) shorter than the {window:g} s window, averaged "
                        f"whole: {', '.join(map(str, short[:5]))}{' ...' if len(short) > 5 else ''}")
    if "film_thickness_m" in points:
        nofilm = int((points["n_film"] == 0).sum())
        if nofilm and nofilm < len(points):
            warnings.append(f"{nofilm} condition(s) without a film-thickness frame in the window")
    if (points["rolling_speed_m_s"] <= 0).any():
        bad = points.loc[points["rolling_speed_m_s"] <= 0].iloc[0]
        raise TorlabInputError(f"rolling speed {bad['rolling_speed_m_s']:g} m/s at condition "
                               f"{bad['condition']}: SRR needs a positive rolling speed",
                               path=meta.source, line=int(bad["first_line"]))
    kind, how = classify_test(points, meta.lubricant, given=test or meta.test or None)
    res = OpticalResult(source=meta.source, label=meta.label, test=kind, test_source=how,
                        points=points, window_s=window, rows=rows, surface=meta.surface,
                        warnings=warnings)
    if kind in ("traction", "dry_traction") and "traction_coefficient" in points:
        res.folded, res.symmetry = fold_traction(points, rel_tol=sym_rel, abs_tol=sym_abs)
    return res


def classify_test(points: Any, lubricant: str = "", given: str | None = None) -> tuple[str, str]:
    """Test type of thesis Tab. 5.2 from the set conditions (see the module docstring).

    Returns
    -------
    test, source
        ``source`` is ``"given"`` or ``"detected"``.
    """
    from torlab.parsers.optical import TEST_TYPES

    if given:
        g = given.lower().replace(" ", "_").replace("-", "_")
        if g not in TEST_TYPES:
            raise TorlabInputError(f"unknown test type {given!r} (known: {', '.join(TEST_TYPES)})",
                                   key="test")
        return g, "given"
    srr = points["srr"].to_numpy(dtype=float)
    U = points["rolling_speed_m_s"].to_numpy(dtype=float)
    has_film = "film_thickness_m" in points and points["film_thickness_m"].notna().any()
    has_mu = "traction_coefficient" in points
    dry = lubricant.strip().lower() in ("none", "dry", "no lubricant", "dry contact")
    if np.all(np.abs(srr) < SRR_ZERO) and (has_film or not has_mu):
        return "film_thickness", "detected"
    if np.ptp(srr) < SRR_ZERO and (len(U) < 2 or U.max() > 1.5 * U.min()):
        return "stribeck", "detected"
    return ("dry_traction" if dry else "traction"), "detected"


def speed_groups(U: np.ndarray, rel: float = 0.05) -> np.ndarray:
    """Group labels (0, 1, ...) of rolling speeds within ``rel`` of the group's slowest speed."""
    U = np.asarray(U, dtype=float)
    order = np.argsort(U, kind="stable")
    labels = np.empty(U.size, dtype=int)
    g, base = -1, -math.inf
    for i in order:
        if U[i] > base * (1 + rel) + 1e-6:
            g += 1
            base = U[i]
        labels[i] = g
    return labels


def fold_traction(points: Any, *, rel_tol: float = DEFAULT_SYM_REL, abs_tol: float = DEFAULT_SYM_ABS
                  ) -> tuple[Any, dict[str, Any]]:
    """Fold negative SRR onto positive and check the symmetry (Paper A, thesis 5.3.1).

    Traction is odd in SRR, ``mu(-s) = -mu(s)`` (model notes section 2), so a
    point at ``-s`` is plotted at ``|s|`` with ``-mu``.  Points are paired per
    rolling-speed group (:func:`speed_groups`) when ``|s|`` agrees within 5 %
    (or 0.001); points with ``|s| <= 0.001`` count as SRR = 0.  A pair is symmetric when
    ``|mu(+s) - (-mu(-s))| <= max(rel_tol * mean |mu|, abs_tol)``.

    Returns
    -------
    folded : pandas.DataFrame
        Per speed group and |SRR|: ``rolling_speed_m_s``, ``srr`` (>= 0),
        ``traction_coefficient`` (mean of the available sides),
        ``traction_coefficient_sd`` (the spread of the coefficient in the averaging
        window; for a pair, of both windows' samples together:
        ``sqrt((sd+^2 + sd-^2)/2 + (difference/2)^2)``), ``traction_coefficient_pos``, ``traction_coefficient_neg_folded`` (NaN
        where a side is missing), ``difference`` (pos - folded neg),
        ``symmetric``, ``n_points``.
    symmetry : dict
        ``pairs``, ``max_abs_diff``, ``rms_diff``, ``max_rel_diff``,
        ``symmetric`` (every pair within tolerance), ``unpaired`` (count),
        ``rel_tol``, ``abs_tol``; and the systematic offset with its evidence
        (:func:`_offset_evidence`): ``offset``, ``offset_low95``, ``offset_high95``,
        ``offset_tolerance``, ``p_symmetric``, ``symmetry_verdict``.
    """
    import pandas as pd

    U = points["rolling_speed_m_s"].to_numpy(dtype=float)
    s = points["srr"].to_numpy(dtype=float)
    mu = points["traction_coefficient"].to_numpy(dtype=float)
    sd = points["traction_coefficient_sd"].to_numpy(dtype=float) \
        if "traction_coefficient_sd" in points else np.full(mu.shape, np.nan)
    groups = speed_groups(U)
    rows = []
    diffs, rels, oks, scales = [], [], [], []
    unpaired = 0
    for g in np.unique(groups):
        idx = np.nonzero(groups == g)[0]
        Ug = float(np.mean(U[idx]))
        neg = [i for i in idx if s[i] < -SRR_ZERO_FOLD]
        pos = [i for i in idx if s[i] > SRR_ZERO_FOLD]
        zero = [i for i in idx if abs(s[i]) <= SRR_ZERO_FOLD]
        used: set[int] = set()
        for i in zero:
            rows.append({"rolling_speed_m_s": Ug, "srr": 0.0, "traction_coefficient": mu[i],
                         "traction_coefficient_sd": sd[i], "traction_coefficient_pos": mu[i],
                         "traction_coefficient_neg_folded": float("nan"),
                         "difference": float("nan"), "symmetric": "", "n_points": 1})
        for i in neg:
            a = -s[i]
            cand = [j for j in pos if j not in used and abs(s[j] - a) <= max(0.001, 0.05 * a)]
            if not cand:
                unpaired += 1
                rows.append({"rolling_speed_m_s": Ug, "srr": a, "traction_coefficient": -mu[i],
                             "traction_coefficient_sd": sd[i],
                             "traction_coefficient_pos": float("nan"),
                             "traction_coefficient_neg_folded": -mu[i], "difference": float("nan"),
                             "symmetric": "", "n_points": 1})
                continue
            j = min(cand, key=lambda j: abs(s[j] - a))
            used.add(j)
            p, q = mu[j], -mu[i]
            d = p - q
            scale = 0.5 * (abs(p) + abs(q))
            ok = abs(d) <= max(rel_tol * scale, abs_tol)
            diffs.append(d)
            scales.append(scale)
            rels.append(abs(d) / scale if scale > 0 else 0.0)
            oks.append(ok)
            rows.append({"rolling_speed_m_s": Ug, "srr": 0.5 * (s[j] + a),
                         "traction_coefficient": 0.5 * (p + q),
                         # spread of both windows' samples together (equal counts)
                         "traction_coefficient_sd": float(np.sqrt(0.5 * (sd[i] ** 2 + sd[j] ** 2)
                                                                  + 0.25 * d * d)),
                         "traction_coefficient_pos": p,
                         "traction_coefficient_neg_folded": q, "difference": d,
                         "symmetric": "yes" if ok else "no", "n_points": 2})
        for j in pos:
            if j in used:
                continue
            if neg:
                unpaired += 1
            rows.append({"rolling_speed_m_s": Ug, "srr": s[j], "traction_coefficient": mu[j],
                         "traction_coefficient_sd": sd[j], "traction_coefficient_pos": mu[j],
                         "traction_coefficient_neg_folded": float("nan"),
                         "difference": float("nan"), "symmetric": "", "n_points": 1})
    folded = pd.DataFrame(rows).sort_values(["rolling_speed_m_s", "srr"], ignore_index=True)
    d = np.asarray(diffs)
    sym = {
        "pairs": len(diffs),
        "max_abs_diff": float(np.max(np.abs(d))) if d.size else float("nan"),
        "rms_diff": float(np.sqrt(np.mean(d * d))) if d.size else float("nan"),
        "max_rel_diff": float(np.max(rels)) if rels else float("nan"),
        "symmetric": bool(all(oks)) if oks else False,
        "unpaired": unpaired,
        "rel_tol": rel_tol,
        "abs_tol": abs_tol,
    }
    sym.update(_offset_evidence(d, np.asarray(scales), rel_tol, abs_tol))
    return folded, sym


#: probability a symmetry verdict needs (else "undetermined"), as the reports' verdicts
SYMMETRY_PROBABILITY = 0.9


def _offset_evidence(d: np.ndarray, scale: np.ndarray, rel_tol: float,
                     abs_tol: float) -> dict[str, Any]:
    """The systematic offset between the +SRR and the folded -SRR sides, with its evidence.

    The pairs' differences ``d`` (pos - folded neg) estimate one offset (a misaligned zero
    of the force or of the SRR shifts every pair the same way); its 95 % interval is the
    paired Student t interval over the pairs, which holds the run-to-run scatter of the
    points as the data show it.  The verdict is an equivalence test against the
    tolerance ``t = max(rel_tol * mean |mu|, abs_tol)``: ``symmetric`` when the offset is
    within ``[-t, t]`` with probability >= :data:`SYMMETRY_PROBABILITY` (one-sided t tests
    on both edges), ``asymmetric`` when it is outside with that probability, else
    ``undetermined`` (always, with fewer than three pairs).
    """
    from torlab._stats import t_cdf, t_ppf  # scipy.stats.t, without its import

    nan = float("nan")
    out: dict[str, Any] = {"offset": nan, "offset_low95": nan, "offset_high95": nan,
                           "offset_tolerance": nan, "p_symmetric": nan,
                           "symmetry_verdict": "undetermined"}
    n = int(d.size)
    if n == 0:
        out["symmetry_verdict"] = ""
        return out
    tol = max(rel_tol * float(np.mean(scale)) if scale.size else 0.0, abs_tol)
    m = float(np.mean(d))
    out.update(offset=m, offset_tolerance=tol)
    if n < 3:
        return out
    se = float(np.std(d, ddof=1)) / math.sqrt(n)
    dof = n - 1
    if se > 0:
        q = float(t_ppf(0.975, dof))
        out.update(offset_low95=m - q * se, offset_high95=m + q * se)
        p_in = float(t_cdf((tol - m) / se, dof) - t_cdf((-tol - m) / se, dof))
    else:
        out.update(offset_low95=m, offset_high95=m)
        p_in = 1.0 if abs(m) <= tol else 0.0
    out["p_symmetric"] = p_in
    out["symmetry_verdict"] = ("symmetric" if p_in >= SYMMETRY_PROBABILITY else
                               "asymmetric" if 1.0 - p_in >= SYMMETRY_PROBABILITY
                               else "undetermined")
    return out


#: columns of the folded table that may be empty
FOLDED_OPTIONAL = ("traction_coefficient_sd", "traction_coefficient_pos",
                   "traction_coefficient_neg_folded", "difference")


def reduce_ehd2(df: Any, meta: Any, *, test: str | None = None, sym_rel: float = DEFAULT_SYM_REL,
                sym_abs: float = DEFAULT_SYM_ABS) -> OpticalResult:
    """Film steps of a PCS EHD2 export as an optical result (film thickness and traction).

    Each EHD2 film-step row is already one condition (the instrument averages
    at each rolling speed), so the rows are the points: ``rolling_speed_m_s``,
    ``srr``, ``film_thickness_m``, ``traction_coefficient`` (see
    :func:`torlab.reduce.mtm.mu_series` for its source), ``ball_load_N`` as
    ``normal_load_N``, temperatures, ``step``, ``line``.  A traction test
    (given as ``test`` or detected) is folded onto positive SRR with the
    symmetry check, as for an optical log (:func:`fold_traction`).

    Raises
    ------
    TorlabInputError
        The file has no film step with data.
    """
    import pandas as pd

    from torlab.reduce.mtm import mu_series

    sel = (df["step_type"] == "film").to_numpy()
    if not sel.any():
        raise TorlabInputError("no FILM step with data rows in this PCS file (the optical "
                               "reduction reads EHD2 film steps)", path=meta.source)
    sub = df.loc[sel]
    mu, src = mu_series(sub, meta)
    out: dict[str, Any] = {"condition": np.arange(1, int(sel.sum()) + 1),
                           "step": sub["step"].to_numpy()}
    for c, nm in (("rolling_speed_m_s", "rolling_speed_m_s"), ("srr", "srr"),
                  ("film_thickness_m", "film_thickness_m"),
                  ("film_thickness_sd_m", "film_thickness_sd_m"),
                  ("ball_load_N", "normal_load_N"), ("lube_temperature_C", "lube_temperature_C"),
                  ("pot_temperature_C", "pot_temperature_C"), ("step_time_s", "step_time_s")):
        if c in sub:
            out[nm] = sub[c].to_numpy(dtype=float)
    if "rolling_speed_m_s" not in out:
        raise TorlabInputError("the film steps have no rolling speed column", path=meta.source)
    if mu is not None:
        out["traction_coefficient"] = mu
    out["first_line"] = sub["line"].to_numpy()
    out["last_line"] = sub["line"].to_numpy()
    points = pd.DataFrame(out)
    if "srr" not in points:
        points["srr"] = 0.0
    points = points.loc[points["rolling_speed_m_s"].notna()].reset_index(drop=True)
    warnings = list(meta.warnings)  # the export's own (zero loads, a test that stopped ...)
    if src:
        warnings.append(f"traction coefficient from {src}")
    kind, how = classify_test(points, meta.lubricant, given=test)
    res = OpticalResult(source=meta.source, label=Path(meta.source).name, test=kind,
                        test_source=how, points=points, window_s=0.0, rows=int(sel.sum()),
                        instrument="EHD2", warnings=warnings)
    if kind in ("traction", "dry_traction") and "traction_coefficient" in points:
        res.folded, res.symmetry = fold_traction(points, rel_tol=sym_rel, abs_tol=sym_abs)
    return res
