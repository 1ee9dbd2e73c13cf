"""HPT reduction: raw log -> normal stress, shear stress, friction against displacement.

Thesis Eqs. 5.1-5.4 with the annulus r1 < r2:

* contact area ``S = pi (r2^2 - r1^2)``
* effective radius ``r_e = 2 (r2^3 - r1^3) / (3 (r2^2 - r1^2))``      (Eq. 5.3)
* normal stress ``sigma = F / S``                                     (Eq. 5.1)
* shear stress ``tau = M_k / (r_e S)``                                (Eq. 5.2)
* friction ``f = tau / sigma``                                        (Eq. 5.4)
* displacement at the effective radius ``u = r_e * (theta - theta_0)``
  from the worm-screw motor angle where logged (finer), the shaft encoder
  otherwise; :attr:`HptResult.displacement_source` says which.

Optionally the rig's own compliance, measured on a dry run, is subtracted:
``u_layer = u - u_rig(tau)`` (:class:`RigCompliance`).

The figure Paper C reports (thesis Fig. 5.10) is ``f`` averaged over the last
20 um of displacement before the maximum displacement (:func:`window_mean`,
the window is configurable).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from torlab.errors import TorlabInputError
from torlab.parsers.hpt import HptMetadata

__all__ = [
    "HptResult",
    "RigCompliance",
    "annulus_area",
    "effective_radius",
    "reduce_hpt",
    "window_mean",
]

DEFAULT_WINDOW = 20e-6
#: the largest friction coefficient over the window taken for a measurement: no contact's
#: shear stress is ten times its normal stress (a torque or arm force in the wrong unit,
#: or a broken column, is)
MAX_FRICTION = 10.0


def annulus_area(r1: float, r2: float) -> float:
    """Contact area of the annulus ``S = pi (r2^2 - r1^2)`` (m^2), used in Eqs. 5.1-5.2."""
    return math.pi * (r2 * r2 - r1 * r1)


def effective_radius(r1: float, r2: float) -> float:
    """Effective radius ``r_e = 2 (r2^3 - r1^3) / (3 (r2^2 - r1^2))`` (Eq. 5.3), m.

    For a uniform shear stress on the annulus the torque is ``M = tau r_e S``.
    """
    return 2.0 * (r2**3 - r1**3) / (3.0 * (r2 * r2 - r1 * r1))


@dataclass
class RigCompliance:
    """The rig's own displacement against shear stress, ``u_rig(tau)``.

    Build it from a constant (:meth:`linear`, m/Pa) or from a curve measured on a
    dry run (:meth:`from_file`: a ``torlab-hpt`` log of the dry run, whose
    loading branch is used, or a CSV with ``shear_stress [unit]`` and
    ``displacement [unit]`` columns).  Beyond the measured range the curve is
    extended with the slope of its upper fifth; :attr:`extrapolated` records
    whether that happened.
    """

    tau: np.ndarray
    u: np.ndarray
    source: str = ""
    extrapolated: bool = field(default=False, compare=False)
    #: the curve file it was read from (None for a constant)
    path: Path | None = field(default=None, compare=False)

    @classmethod
    def linear(cls, compliance: float, source: str = "") -> RigCompliance:
        """``u_rig = compliance * tau`` (compliance in m/Pa)."""
        if not math.isfinite(compliance) or compliance < 0:
            raise TorlabInputError(f"rig compliance must be a non-negative number, got {compliance}")
        return cls(np.array([0.0, 1e9]), np.array([0.0, compliance * 1e9]),
                   source or f"linear {compliance * 1e12:.4g} um/MPa")

    @classmethod
    def from_file(cls, path: str | Path, *, name: str | None = None) -> RigCompliance:
        """Read a compliance curve (see class docstring).

        ``name`` is the file's name in :attr:`source` (the reduced tables'
        ``compliance`` column; default: ``path`` as given; messages always give
        ``path``).  A protocol names it as written in the protocol, so that its
        results carry no path of the machine they were computed on.
        """
        from torlab.parsers._table import RowSpec, TextFile, read_columns
        from torlab.parsers._text import split_unit
        from torlab.units import parse_unit_factor

        with TextFile(path) as tf:
            display = tf.display
            head = tf.head(lambda ln, s: bool(s.strip()) and not s.lstrip().startswith("#"))
            if next((s for s in head if s.strip()), "").lstrip().startswith("# torlab-hpt"):
                tf.close()
                from torlab.parsers.hpt import read_hpt

                df, meta = read_hpt(path)
                res = reduce_hpt(df, meta)
                tau = res.data["shear_stress_Pa"].to_numpy()
                u = res.data["displacement_m"].to_numpy()
            else:
                if not head or not head[-1].strip() or head[-1].lstrip().startswith("#"):
                    raise TorlabInputError("a compliance curve needs a header and at least two "
                                           "rows", path=display)
                hl = len(head)
                header = [split_unit(h) for h in head[-1].split(",")]
                names = [h[0] for h in header]
                if "shear_stress" not in names or "displacement" not in names:
                    raise TorlabInputError("compliance CSV needs columns 'shear_stress [unit]' "
                                           "and 'displacement [unit]'", path=display, line=hl)
                it, iu = names.index("shear_stress"), names.index("displacement")
                st, _ = parse_unit_factor(header[it][1] or "Pa", "pressure",
                                          where="shear_stress", path=display, line=hl)
                su, _ = parse_unit_factor(header[iu][1] or "m", "length", where="displacement",
                                          path=display, line=hl)
                spec = RowSpec(names, [it, iu], display, scales=[st, su],
                               units=[header[it][1] or "Pa", header[iu][1] or "m"])
                tau, u = read_columns(tf, hl + 1, spec)
                if len(tau) < 2:
                    raise TorlabInputError("a compliance curve needs a header and at least two "
                                           "rows", path=display)
        # loading branch: up to the maximum shear stress, with tau strictly increasing
        k = int(np.argmax(tau))
        tau, u = tau[: k + 1], u[: k + 1]
        keep = np.r_[True, tau[1:] > np.maximum.accumulate(tau)[:-1]]
        tau, u = tau[keep], u[keep]
        if len(tau) < 2:
            raise TorlabInputError("compliance curve has fewer than two points of increasing shear "
                                   "stress", path=display)
        if tau[0] > 0:
            tau, u = np.r_[0.0, tau], np.r_[u[0] - tau[0] * (u[1] - u[0]) / (tau[1] - tau[0]), u]
        return cls(tau, u - u[0], source=name or str(display), path=Path(path))

    @classmethod
    def from_spec(cls, spec: Any, where: str = "compliance") -> RigCompliance | None:
        """A compliance from what a user gives: None, a :class:`RigCompliance`, a number
        (m/Pa), a curve file, or a constant with a unit (``"0.012 um/MPa"``)."""
        if spec is None or isinstance(spec, RigCompliance):
            return spec
        if isinstance(spec, (int, float)):
            return cls.linear(float(spec))
        p = Path(str(spec))
        if p.exists():
            return cls.from_file(p)
        from torlab.units import to_si

        return cls.linear(to_si(str(spec), "compliance", where=where))

    def __call__(self, tau: np.ndarray) -> np.ndarray:
        """Rig displacement at shear stress ``tau`` (Pa) -> m."""
        tau = np.asarray(tau, dtype=float)
        t, u = self.tau, self.u
        out = np.interp(tau, t, u)
        hi = tau > t[-1]
        if hi.any():
            j = max(0, int(0.8 * (len(t) - 1)))
            slope = (u[-1] - u[j]) / (t[-1] - t[j]) if t[-1] > t[j] else 0.0
            out = np.where(hi, u[-1] + slope * (tau - t[-1]), out)
            self.extrapolated = True
        lo = tau < t[0]
        if lo.any():
            slope = (u[1] - u[0]) / (t[1] - t[0])
            out = np.where(lo, u[0] + slope * (tau - t[0]), out)
        return out


@dataclass
class HptResult:
    """A reduced HPT run.

    Attributes
    ----------
    data
        DataFrame with ``time_s``, ``normal_force_N``, ``torque_N_m``,
        ``normal_stress_Pa``, ``shear_stress_Pa``, ``friction`` (f, -),
        ``displacement_raw_m`` (from the angle), ``displacement_m`` (after the
        compliance correction, equal to raw without one), ``heater_temperature_C``
        where logged, and ``line`` (raw-file line of each row).
    meta
        The log's header.
    area_m2, effective_radius_m
        S and r_e of the annulus.
    displacement_source
        ``"motor"`` or ``"encoder"``.
    compliance
        Description of the subtracted rig compliance, ``""`` if none.
    window_m
        Window of the reported friction (m of displacement).
    f_window, f_window_std, tau_window_Pa, sigma_mean_Pa, u_max_m, n_window
        The summary figures (see :func:`window_mean`).
    """

    data: Any
    meta: HptMetadata
    area_m2: float
    effective_radius_m: float
    displacement_source: str
    compliance: str
    window_m: float
    f_window: float
    f_window_std: float
    tau_window_Pa: float
    sigma_mean_Pa: float
    u_max_m: float
    n_window: int

    def summary(self) -> dict[str, Any]:
        """One summary row (SI values, unit-carrying keys)."""
        m = self.meta
        return {
            "file": Path(m.source).name,
            "product": m.product,
            "condition": m.condition,
            "applied_amount": m.applied_amount_value if m.applied_amount_value is not None else float("nan"),
            "applied_amount_unit": m.applied_amount_unit,
            "temperature_C": m.temperature if m.temperature is not None else float("nan"),
            "normal_stress_Pa": self.sigma_mean_Pa,
            "f_window": self.f_window,
            "f_window_std": self.f_window_std,
            "shear_stress_window_Pa": self.tau_window_Pa,
            "window_m": self.window_m,
            "n_window": self.n_window,
            "displacement_max_m": self.u_max_m,
            "displacement_source": self.displacement_source,
            "compliance": self.compliance or "none",
            "n_points": len(self.data),
        }


def window_mean(u: np.ndarray, y: np.ndarray, window: float = DEFAULT_WINDOW) -> tuple[float, float, int]:
    """Mean and standard deviation of ``y`` over the last ``window`` of ``u`` before its maximum.

    Samples with index up to ``argmax(u)`` and ``u >= max(u) - window`` are used
    (thesis Fig. 5.10: the last 20 um before the maximum displacement).

    Returns
    -------
    mean, std, n
        ``std`` is the sample standard deviation (0 for one sample).
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    k = int(np.argmax(u))
    umax = u[k]
    sel = np.zeros(len(u), dtype=bool)
    sel[: k + 1] = u[: k + 1] >= umax - window * (1 + 1e-9)  # the boundary sample counts
    vals = y[sel]
    n = int(vals.size)
    std = float(np.std(vals, ddof=1)) if n > 1 else 0.0
    return float(np.mean(vals)), std, n


def reduce_hpt(
    df: Any,
    meta: HptMetadata,
    *,
    window: float = DEFAULT_WINDOW,
    source: str = "auto",
    compliance: RigCompliance | None = None,
) -> HptResult:
    """Reduce a parsed HPT log (thesis Eqs. 5.1-5.4).

    Parameters
    ----------
    df, meta
        From :func:`torlab.parsers.hpt.read_hpt`.
    window
        Displacement window (m) of the reported friction; default 20 um.
    source
        ``"auto"`` (motor angle where logged, encoder otherwise), ``"motor"``
        or ``"encoder"``.
    compliance
        Rig compliance to subtract; default: the header's ``rig_compliance``
        when given, none otherwise.

    Returns
    -------
    HptResult

    Raises
    ------
    TorlabInputError
        The requested angle column is missing, the window is not positive, or
        the run has no displacement.
    """
    try:
        return _reduce_hpt(df, meta, window=window, source=source, compliance=compliance)
    except MemoryError:
        from torlab.parsers._table import memory_error

        raise memory_error(meta.source, what="reduce") from None


def _reduce_hpt(df: Any, meta: HptMetadata, *, window: float, source: str,
                compliance: RigCompliance | None) -> HptResult:
    import pandas as pd

    path = meta.source
    if not (window > 0 and math.isfinite(window)):
        raise TorlabInputError(f"the friction window must be a positive length, got {window} m",
                               key="window")
    r1, r2 = meta.r1, meta.r2
    S = annulus_area(r1, r2)
    re = effective_radius(r1, r2)
    if source == "auto":
        source = "motor" if "motor_angle_rad" in df else "encoder"
    col = {"motor": "motor_angle_rad", "encoder": "encoder_angle_rad"}.get(source)
    if col is None:
        raise TorlabInputError(f"displacement source must be auto, motor or encoder, not {source!r}",
                               key="source")
    if col not in df:
        raise TorlabInputError(f"the log has no {source} angle column", path=path)
    theta = df[col].to_numpy(dtype=float)
    u_raw = theta - theta[0]
    u_raw *= re
    F = df["normal_force_N"].to_numpy(dtype=float)
    M = df["torque_N_m"].to_numpy(dtype=float)
    sigma = F / S
    tau = M / (re * S)
    f = tau / sigma
    if compliance is None and meta.rig_compliance is not None:
        compliance = RigCompliance.linear(meta.rig_compliance, source="header rig_compliance")
    u = u_raw - compliance(tau) if compliance is not None else u_raw
    if not np.any(u_raw > 0):
        raise TorlabInputError("the angle never increases: no displacement to reduce", path=path)
    cols = {
        "time_s": df["time_s"].to_numpy(),
        "normal_force_N": F,
        "torque_N_m": M,
        "normal_stress_Pa": sigma,
        "shear_stress_Pa": tau,
        "friction": f,
        "displacement_raw_m": u_raw,
        "displacement_m": u,
    }
    if "heater_temperature_C" in df:
        cols["heater_temperature_C"] = df["heater_temperature_C"].to_numpy()
    cols["line"] = df["line"].to_numpy()
    # the log's columns are shared, not copied: a long log's reduction needs only the
    # memory of the new columns
    out = pd.DataFrame(cols, copy=False)
    fm, fs, n = window_mean(u, f, window)
    if not abs(fm) <= MAX_FRICTION:
        what = "torque (or arm_force and arm_length)"
        # the location: the log's first reading beyond the bound (the line of the error)
        beyond = np.flatnonzero(~(np.abs(f) <= MAX_FRICTION))
        first = int(cols["line"][beyond[0]]) if beyond.size else None
        raise TorlabInputError(f"the friction coefficient over the window is {fm:.3g}, which no "
                               f"contact has (|f| <= {MAX_FRICTION:g}; the first reading beyond "
                               f"it is on this line): check the {what} and the normal_force "
                               "columns and their units", path=path, line=first)
    tm, _, _ = window_mean(u, tau, window)
    desc = ""
    if compliance is not None:
        desc = compliance.source + (" (extrapolated beyond the measured range)" if compliance.extrapolated else "")
    return HptResult(
        data=out, meta=meta, area_m2=S, effective_radius_m=re, displacement_source=source,
        compliance=desc, window_m=window, f_window=fm, f_window_std=fs, tau_window_Pa=tm,
        sigma_mean_Pa=float(np.mean(sigma)), u_max_m=float(np.max(u)), n_window=n,
    )
