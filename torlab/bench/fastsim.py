"""Benchmark of the boundary model: FASTSIM with the third-body layer, speed against error.

Scene: the wheel-rail contact of thesis Tab. 5.4 (a = 3.7 mm, b = 3.3 mm,
F = 20 kN, steel E = 210 GPa, nu = 0.28) with a third-body layer
(mu_c1 = 0.30, mu_c2 = 0.45, L_mue = 10 um, L_mup = 20 um), no temperature.

Unit of work: a 101-point traction curve, creepage 0 ... 0.05.  Error of a
variant: ``max |mu - mu_ref| / max |mu_ref|`` over a handful of creepages
(8 from 1e-4 to 0.05; 4 with ``quick``) where the grid-free reference
:func:`torlab.model.reference_solvers.boundary_traction_reference` (adaptive quadrature
of the continuous strip solution) is evaluated once per run and cached.

Measured side by side in one run:

* ``torlab`` -- :func:`torlab.model.fastsim.boundary_traction` at several
  :class:`~torlab.model.fastsim.FastsimGrid` s (strips ``n``, Gauss nodes per
  panel ``m``, panel counts written ``graded+uniform+clamp``), the default
  marked;
* ``baseline`` -- :func:`naive_fastsim`, the thesis's own recurrence
  (Eqs. 5.22-5.25, docs/model/thesis-reading.md) marched on a uniform grid of ``n``
  strips and ``m`` points per strip, a plain numpy loop over the creepages, each
  vectorised over strips and points.  Two families: square cells ``n = m`` (what the thesis's
  grid suggests) and, conservatively, the grids on the baseline's own
  speed/error front found by a sweep of ``n`` and ``m`` for this scene (which
  profits from a cancellation of the strip and the along-strip errors that
  does not carry over to other scenes: see the ``test_set`` figures);
* ``uniform, midpoint-consistent`` -- the same uniform grid with the stress and
  the displacement taken at the cell midpoints (where the pressure is), a
  one-line improvement of the recurrence, for comparison.

The default row's ``extra`` holds the ratios that matter: a
family's time at equal error (its speed/error front interpolated on log-log
axes, :func:`time_at_error`) over the default's time, at 0.1 % (the accuracy
target, which the default beats by far) and at the default's own error where
that is within a factor 10 of the family's best measured error (otherwise
``out of range``: no honest number exists); and, for each of the target accuracies
1e-2, 1e-3 and 1e-6 (:data:`TARGETS`), the family's time at that error over the time of
torlab's fastest grid within it (``ratio_vs_<family>_at_1e-02`` ...).  Each ratio is given for the square-cell baseline, the tuned
baseline (by the error above and by the pointwise relative error
``max |mu/mu_ref - 1|``), the baseline on the accuracy test set (full run),
and the midpoint-consistent grid; ``..._fastest_torlab_grid`` divides by
torlab's fastest grid within 0.1 % instead of the default (front against
front).

The full run also evaluates the default grid (and every other grid) on the
accuracy test set: a/b in {0.2, 0.5, 1, 2, 5} (a b and the load fixed) x
{with the layer; without it (L_mue = 0, L_mup = 0, mu_c1 = mu_c2: classic
FASTSIM); L_mue = 0 with the Voce hardening kept; softening mu_c1 = 0.45 ->
mu_c2 = 0.30} x creepage {1e-5, 1e-4, 1e-3, 1e-2, 0.1, 0.5}; one row per
scene gives the default's largest relative error ``max |mu/mu_ref - 1|``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import Any

import numpy as np

from torlab.bench import BenchRow, median_time
from torlab.model.fastsim import FastsimGrid, FastsimProblem, boundary_traction

__all__ = [
    "TAB54_SCENE",
    "TEST_SET_A_OVER_B",
    "TEST_SET_CREEPAGES",
    "TEST_SET_LAYERS",
    "naive_fastsim",
    "reference_mu",
    "run",
    "scene_problem",
    "time_at_error",
]

#: the wheel-rail scene of thesis Tab. 5.4 with a third-body layer (no thermal: isothermal)
TAB54_SCENE: dict[str, Any] = {
    "name": "wheel-rail Tab. 5.4 (isothermal)",
    "contact": {"load": "20 kN", "a": "3.7 mm", "b": "3.3 mm", "r1x": "350 mm"},
    "materials": {"E1": "210 GPa", "nu1": 0.28, "E2": "210 GPa", "nu2": 0.28},
    "kinematics": {"speed": "10 m/s", "ambient_temperature": "20 degC"},
    "boundary": {"mu_c1": 0.30, "mu_c2": 0.45, "L_mue": "10 um", "L_mup": "20 um"},
}
NO_LAYER = {"mu_c1": 0.30, "mu_c2": 0.30, "L_mue": 0.0, "L_mup": 0.0}
TEST_SET_A_OVER_B = (0.2, 0.5, 1.0, 2.0, 5.0)
#: layer variants of the test set: (label, overrides of the boundary section)
TEST_SET_LAYERS: tuple[tuple[str, dict[str, Any] | None], ...] = (
    ("with layer", None),
    ("no layer (classic FASTSIM)", None),
    ("L_mue = 0, Voce kept", {"L_mue": 0.0}),
    ("softening mu_c1 0.45 -> mu_c2 0.30", {"mu_c1": 0.45, "mu_c2": 0.30}),
)
TEST_SET_CREEPAGES = (1e-5, 1e-4, 1e-3, 1e-2, 0.1, 0.5)
CURVE = np.linspace(0.0, 0.05, 101)
TARGET_ERROR = 1e-3
#: the accuracies at which the baseline is compared with torlab's fastest grid meeting each
TARGETS = (1e-2, 1e-3, 1e-6)

DEFAULT_GRID = FastsimGrid()


def scene_problem(a_over_b: float | None = None, layer: bool = True,
                  boundary: dict[str, Any] | None = None) -> FastsimProblem:
    """The :class:`FastsimProblem` of the Tab. 5.4 scene, built through the scene API.

    Parameters
    ----------
    a_over_b
        Semi-axis ratio; ``a b`` and the load stay those of Tab. 5.4 (so p0 does).
        None: Tab. 5.4's a = 3.7 mm, b = 3.3 mm.
    layer
        With the third-body layer, or classic FASTSIM (``L_mue = L_mup = 0``,
        ``mu_c1 = mu_c2 = 0.3``).
    boundary
        Overrides of the ``boundary:`` section.

    Returns
    -------
    FastsimProblem
        Kalker's FASTSIM (``grid: method: fastsim-kalker``: ``calibrated=False``, CONTACT's
        interpolation of Kalker's table): the scheme this benchmark measures
        against the simplified theory's grid-free reference (the default method's
        correction by the exact theory is a factor on its result, measured in
        :mod:`torlab.bench.method`).
    """

    from torlab.model.prediction import fastsim_problem
    from torlab.scene import scene_from_dict

    d = {k: (dict(v) if isinstance(v, dict) else v) for k, v in TAB54_SCENE.items()}
    if a_over_b is not None:
        ab = 3.7e-3 * 3.3e-3
        d["contact"]["a"] = math.sqrt(ab * a_over_b)
        d["contact"]["b"] = math.sqrt(ab / a_over_b)
    if not layer:
        d["boundary"] = dict(NO_LAYER)
    if boundary:
        d["boundary"].update(boundary)
    d["grid"] = {"method": "fastsim-kalker"}  # its flexibility too (docs/model/kalker.md)
    return fastsim_problem(scene_from_dict(d))


@lru_cache(maxsize=4096)
def reference_mu(prob: FastsimProblem, creepage: float) -> float:
    """Grid-free reference ``mu`` (cached for the run; ``boundary_traction_reference``)."""
    from torlab.model.reference_solvers import boundary_traction_reference

    return float(boundary_traction_reference(prob, creepage))


# -------------------------------------------------------------------------------------------
# the naive first-order baseline: the thesis's recurrence on a uniform grid
# -------------------------------------------------------------------------------------------
def naive_fastsim(prob: FastsimProblem, creepage: Any, n: int, m: int, *,
                  midpoint: bool = False) -> np.ndarray:
    """Boundary traction by the thesis's recurrence on a uniform grid (the benchmark's baseline).

    The contact is cut into ``n`` strips of equal width ``2b/n`` (strip centre
    ``y_j``, half-length ``a(y_j)``); each strip into ``m`` cells of length
    ``dx = 2a(y_j)/m``, the pressure (Eq. 5.13) and ``L = L1 + L_mue/p``
    (Eqs. 5.17, 5.18, 5.28) at the cell midpoints (never where ``p = 0``,
    docs/model/thesis-reading.md).  From the leading edge, per cell ``i``::

        u_i   = u_{i-1} + xi dx                              (Eq. 5.25)
        tau_i = tau_{i-1} + xi dx / L_i     while elastic     (Eqs. 5.22-5.23)
        tau_i = tau_c1 + (tau_c2 - tau_c1)(1 - exp(-max(u_i - tau_c1 L_i, 0)/L_mup))
                                             once tau has reached tau_c1 (Eq. 5.24;
                                             another layer law: its own branch)

    and ``mu = sum tau dA / sum p dA`` (Eq. 5.30) with the cell areas
    ``dx dy``.  Without temperature.  It converges at first order: the yield point
    falls inside a cell and ``tau_i`` (the stress at the end of cell ``i``) is paired
    with the midpoint pressure.

    Written as a plain numpy loop over the creepages, the scheme's own work and
    nothing else: the grid (pressure, ``L``, the elastic stress per unit creepage
    ``E_i = sum dx/L``, the slip per unit creepage) is made once; per creepage the
    elastic stress is ``xi E``, a cell has yielded once ``xi max_{j<=i}(E_j/tau_c1,j)
    >= 1`` (the running maximum, made once, is the march's "yielded since" flag for
    every creepage), the plastic branch is evaluated only for a creepage where some
    cell yields, and the sum over the cells is one dot product.  Arrays of one
    creepage (``n/2 x m``: the contact's symmetry in ``y`` halves the strips) stay
    in the processor's cache, which a batch over all creepages at once did not (2-3x
    slower at 80^2-320^2 cells, same numbers to round-off).

    Parameters
    ----------
    prob
        The contact and layer (``prob.thermal`` is ignored).
    creepage
        Creepages (any sign; the result is odd in creepage).
    n, m
        Strips and points per strip.
    midpoint
        Take ``tau`` and ``u`` at the cell midpoints instead (half a step of
        the recurrence earlier): the improved uniform grid, not the thesis's.

    Returns
    -------
    numpy.ndarray
        ``mu`` per creepage.
    """
    lay = prob.layer
    xi_in = np.atleast_1d(np.asarray(creepage, dtype=float))
    xi = np.abs(xi_in)
    dy = 2.0 * prob.b / n
    y = -prob.b + (np.arange(n) + 0.5) * dy
    yh = y[y >= -1e-12 * prob.b]  # the half y >= 0; the others are mirror images
    wy = np.where(np.abs(yh) <= 1e-12 * prob.b, 1.0, 2.0) * dy
    aj = prob.a * np.sqrt(1.0 - (yh / prob.b) ** 2)
    dx = 2.0 * aj / m
    X = (np.arange(m) + 0.5)[None, :] * dx[:, None]  # cell midpoints from the leading edge
    xloc = aj[:, None] - X
    p = prob.p0 * np.sqrt(np.maximum(1.0 - (xloc / prob.a) ** 2 - (yh[:, None] / prob.b) ** 2, 0.0))
    p = np.maximum(p, 1e-300)
    L = prob.L1 + lay.L_mue / p
    inc = dx[:, None] / L
    E = np.cumsum(inc, axis=1)
    U = (np.arange(m) + 1.0)[None, :] * dx[:, None]
    if midpoint:
        E = E - 0.5 * inc
        U = X
    t1 = lay.mu_c1 * p
    # a cell has yielded at creepage z once z E_j >= tau_c1,j at some j <= i
    reach = np.maximum.accumulate(E / t1, axis=1)
    pL = p * L
    dA = dx * wy  # per strip
    out = np.empty(xi.shape)
    for k, z in enumerate(xi):
        tau = z * E
        yielded = z * reach >= 1.0
        if yielded.any():
            tau = np.where(yielded, lay.law.strip_plastic(lay, p, z * U, pL, 0.0), tau)
        out[k] = tau.sum(axis=1) @ dA
    return np.sign(xi_in) * out / (p.sum(axis=1) @ dA)


# -------------------------------------------------------------------------------------------
# helpers
# -------------------------------------------------------------------------------------------
def _front(points: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """Speed/error front of ``(error, time)`` points: sorted by time, each more accurate."""
    out: list[tuple[float, float]] = []
    for e, t in sorted(points, key=lambda et: (et[1], et[0])):
        if e > 0 and (not out or e < out[-1][0]):
            out.append((e, t))
    return out


def time_at_error(points: Sequence[tuple[float, float]], target: float, *,
                  max_extrapolation: float = 10.0) -> tuple[float, str]:
    """Time a variant family needs for error ``target``: log-log interpolation on its front.

    Parameters
    ----------
    points
        ``(error, time)`` of the family's members.
    target
        Error wanted.
    max_extrapolation
        Extrapolate at most this factor below the family's best error.

    Returns
    -------
    (time, how)
        ``how`` is ``"interpolated"``, ``"extrapolated"`` (target below the
        family's best error: the last two front points' slope), ``"upper
        bound"`` (every member is already more accurate: the fastest member's
        time), or ``"out of range"`` (time NaN: the target is more than
        ``max_extrapolation`` below the best error).
    """
    fr = _front(points)
    if not fr:
        raise ValueError("no member with a positive error")
    if target >= fr[0][0]:
        return fr[0][1], "upper bound"
    for (e0, t0), (e1, t1) in itertools.pairwise(fr):
        if e1 <= target <= e0:
            s = (math.log(t1) - math.log(t0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + s * (math.log(target) - math.log(e0))), "interpolated"
    if len(fr) < 2 or target < fr[-1][0] / max_extrapolation:
        return math.nan, "out of range"
    (e0, t0), (e1, t1) = fr[-2], fr[-1]
    s = (math.log(t1) - math.log(t0)) / (math.log(e1) - math.log(e0))
    return math.exp(math.log(t1) + s * (math.log(target) - math.log(e1))), "extrapolated"


def _curve_error(mu: np.ndarray, ref: np.ndarray) -> float:
    return float(np.max(np.abs(mu - ref)) / np.max(np.abs(ref)))


def _time(fn: Callable[[], Any], quick: bool, heavy: bool = False) -> float:
    if heavy:
        return median_time(fn, repeat=3, min_time=0.0)
    return median_time(fn, repeat=3 if quick else 5, min_time=0.03 if quick else 0.1)


def _grid_label(g: FastsimGrid) -> str:
    return (f"torlab n={g.n} m={g.m} panels {g.graded_panels}+{g.uniform_panels}"
            f"+{g.clamp_panels}")


def _torlab_grids(quick: bool) -> list[FastsimGrid]:
    """The default grid first, then variations of one parameter at a time and a few others."""
    from dataclasses import replace

    d = DEFAULT_GRID
    if quick:
        cand = [d, replace(d, n=max(2, d.n // 2), m=max(2, d.m - 1)), replace(d, n=2 * d.n, m=d.m + 2)]
    else:
        cand = [d]
        cand += [replace(d, n=n) for n in (4, 6, 8, 12, 16, 24)]
        cand += [replace(d, m=m) for m in (3, 4, 6, 8)]
        cand += [replace(d, graded_panels=k) for k in (3, 4, 6, 8, 12)]
        cand += [replace(d, uniform_panels=k) for k in (2, 3, 4, 8)]
        cand += [replace(d, clamp_panels=k) for k in (1, 2)]
        cand += [replace(d, n=4, m=3), replace(d, n=6, m=3), replace(d, n=6, m=4)]
        cand += [FastsimGrid(n=12, m=6, graded_panels=8, uniform_panels=4, clamp_panels=2)]
    out: list[FastsimGrid] = []
    for g in cand:
        if g not in out:
            out.append(g)
    return out


# -------------------------------------------------------------------------------------------
# the benchmark
# -------------------------------------------------------------------------------------------
def _test_set(quick: bool) -> list[tuple[str, FastsimProblem, np.ndarray, np.ndarray, list[str]]]:
    """(label, problem, creepages, reference mu, reference failures) per test-set scene."""
    if quick:
        return []
    out = []
    for (kind, boundary), ab in itertools.product(TEST_SET_LAYERS, TEST_SET_A_OVER_B):
        prob = scene_problem(ab, kind != "no layer (classic FASTSIM)", boundary)
        xs, ref, failed = [], [], []
        for x in TEST_SET_CREEPAGES:
            try:
                ref.append(reference_mu(prob, x))
                xs.append(x)
            except Exception as e:  # a reference failure is reported, not hidden
                failed.append(f"{x:g}: {type(e).__name__}: {e}")
        label = f"a/b={ab:g}, {kind}"
        out.append((label, prob, np.array(xs), np.array(ref), failed))
    return out


def _test_set_error(tests: list, evaluate: Callable[[FastsimProblem, np.ndarray], np.ndarray]
                    ) -> float:
    """Largest pointwise relative error ``|mu/mu_ref - 1|`` over the whole test set."""
    worst = 0.0
    for _, prob, xs, ref, _ in tests:
        if len(xs):
            worst = max(worst, float(np.max(np.abs(evaluate(prob, xs) / ref - 1.0))))
    return worst


def run(quick: bool = False) -> list[BenchRow]:  # noqa: C901 (one benchmark run in reading order: rows, baselines, ratios)
    """FASTSIM speed against error (see the module docstring).

    Parameters
    ----------
    quick
        4 reference creepages, 3 torlab grids, smaller baseline grids, no test set.
    """
    prob = scene_problem()
    xs_all = np.geomspace(1e-4, 0.05, 4 if quick else 8)
    kept, ref_list, ref_failed = [], [], []
    for x in xs_all:
        try:
            ref_list.append(reference_mu(prob, float(x)))
            kept.append(float(x))
        except Exception as e:  # reported in the default row, never hidden
            ref_failed.append(f"{x:g}: {type(e).__name__}: {e}")
    if len(kept) < 2:
        raise RuntimeError("the grid-free reference failed at the benchmark's creepages: "
                           + "; ".join(ref_failed))
    xs, ref = np.array(kept), np.array(ref_list)
    ref_name = (f"boundary_traction_reference (grid-free, adaptive quadrature) at {len(xs)} "
                f"creepages 1e-4..0.05")
    unit = "101-point traction curve, creepage 0..0.05 (Tab. 5.4 scene)"
    tests = _test_set(quick)
    comp = "fastsim traction curve"

    def measure(name: str, family: str, curve: Callable[[FastsimProblem, np.ndarray], np.ndarray],
                params: dict[str, Any], heavy: bool = False, default: bool = False) -> BenchRow:
        t = _time(lambda: curve(prob, CURVE), quick, heavy)
        mu = curve(prob, xs)
        extra: dict[str, Any] = {"family": family, **params,
                                 "pointwise_rel_error": float(np.max(np.abs(mu / ref - 1.0)))}
        if tests:
            extra["test_set_max_rel_error"] = _test_set_error(tests, curve)
        return BenchRow(comp, name, t, _curve_error(mu, ref), ref_name, default, unit, extra=extra)

    # -- torlab's scheme ------------------------------------------------------------------
    torlab_rows = [
        measure(_grid_label(g), "torlab", lambda p, x, g=g: boundary_traction(p, x, g).mu,
                {"n": g.n, "m": g.m}, default=(g == DEFAULT_GRID))
        for g in _torlab_grids(quick)]
    d_row = torlab_rows[0]
    t_default, err_default = d_row.time_s, d_row.error

    # -- the naive baseline and the midpoint-consistent uniform grid ----------------------
    def naive(n: int, m: int, family: str, midpoint: bool = False) -> BenchRow:
        name = "uniform midpoint-consistent" if midpoint else "baseline Eq. 5.23 uniform"
        return measure(f"{name} n={n} m={m}", family,
                       lambda p, x: naive_fastsim(p, x, n, m, midpoint=midpoint),
                       {"n": n, "m": m}, heavy=n * m >= 160 * 320)

    square = (10, 20, 40, 80, 160) if quick else (10, 20, 40, 80, 160, 320, 640)
    base_rows = [naive(k, k, "baseline, square cells") for k in square]
    # the baseline's own fronts over n and m, by both error measures at the reference
    # creepages and the cost (cells of the half contact); only those grids are timed
    ns = (4, 8, 16, 32, 64) if quick else (4, 8, 16, 32, 64, 128, 256)
    ms = (40, 80, 160, 320, 640) if quick else (40, 80, 160, 320, 640, 1280, 2560)
    cand = []
    for n, m in itertools.product(ns, ms):
        mu = naive_fastsim(prob, xs, n, m)
        cand.append(((n + 1) // 2 * m, _curve_error(mu, ref), float(np.max(np.abs(mu / ref - 1))),
                     n, m))
    chosen: list[tuple[int, int]] = []
    for k in (1, 2):
        best = math.inf
        for c in sorted(cand, key=lambda c: (c[0], c[k])):
            if c[k] < best and c[k] >= 0.1 * TARGET_ERROR:
                best = c[k]
                if (c[3], c[4]) not in chosen and c[3] != c[4]:
                    chosen.append((c[3], c[4]))
    tuned_rows = [naive(n, m, "baseline, tuned n x m") for n, m in sorted(chosen)]
    mid_sizes = (10, 20, 40, 80) if quick else (10, 20, 40, 80, 160, 320)
    mid_rows = [naive(k, k, "uniform midpoint-consistent", midpoint=True) for k in mid_sizes]

    # -- ratios at equal error ------------------------------------------------------------
    baseline = base_rows + tuned_rows
    summary: dict[str, Any] = {
        "target_error": TARGET_ERROR,
        "default_meets_error_target": bool(err_default <= TARGET_ERROR),
        "target_time_s": 0.020, "default_meets_time_target": bool(t_default <= 0.020),
        "ratio_target": 50.0,
    }

    def ratio(key: str, rs: list[BenchRow], err_of: Callable[[BenchRow], float | None]) -> None:
        pts = [(e, r.time_s) for r in rs if (e := err_of(r)) is not None and e > 0]
        if not pts:
            return
        tb, how = time_at_error(pts, TARGET_ERROR)
        summary[f"ratio_vs_{key}_at_0.1pct"] = tb / t_default
        summary[f"ratio_vs_{key}_at_0.1pct_how"] = how
        # front against front: torlab's fastest grid within 0.1 % by the same measure
        ok = [r.time_s for r in torlab_rows if (e := err_of(r)) is not None and e <= TARGET_ERROR]
        if ok:
            summary[f"ratio_vs_{key}_at_0.1pct_fastest_torlab_grid"] = tb / min(ok)
        # the baseline against torlab's fastest grid at each target accuracy (a target
        # far below the baseline's best measured error: out of range, NaN)
        for target in TARGETS:
            tb, how = time_at_error(pts, target)
            ok = [r.time_s for r in torlab_rows
                  if (e := err_of(r)) is not None and e <= target]
            summary[f"ratio_vs_{key}_at_{target:.0e}"] = tb / min(ok) if ok else math.nan
            summary[f"ratio_vs_{key}_at_{target:.0e}_how"] = how
        e_def = err_of(d_row)
        if e_def is not None and e_def > 0:
            tb, how = time_at_error(pts, e_def)
            if math.isfinite(tb):
                summary[f"ratio_vs_{key}_at_default_error"] = tb / t_default
            else:
                how = (f"out of range: the default's error {e_def:.2g} is far below the "
                       f"family's best {min(e for e, _ in pts):.2g}")
            summary[f"ratio_vs_{key}_at_default_error_how"] = how

    ratio("square_baseline", base_rows, lambda r: r.error)
    # at the default's own error the square baseline is far out of measurable range; its
    # asymptotic law (error ~ n^-p, time ~ n^q, both fitted on its three finest grids)
    # gives the time it would need.  Reported with the measured p and q, never as measured.
    sq = sorted((r for r in base_rows if r.error), key=lambda r: r.extra["n"])[-3:]
    if len(sq) == 3 and err_default > 0:
        ln_n = np.log([r.extra["n"] for r in sq])
        p_ord = -np.polyfit(ln_n, np.log([r.error for r in sq]), 1)[0]
        q_exp = np.polyfit(ln_n, np.log([r.time_s for r in sq]), 1)[0]
        if p_ord > 0:
            t_eq = sq[-1].time_s * (sq[-1].error / err_default) ** (q_exp / p_ord)
            summary["ratio_vs_square_baseline_at_default_error_asymptotic"] = t_eq / t_default
            summary["square_baseline_order"] = float(p_ord)
            summary["square_baseline_time_exponent"] = float(q_exp)
    ratio("tuned_baseline", baseline, lambda r: r.error)
    ratio("tuned_baseline_pointwise", baseline, lambda r: r.extra["pointwise_rel_error"])
    if tests:
        ratio("baseline_on_test_set", baseline, lambda r: r.extra["test_set_max_rel_error"])
    ratio("uniform_midpoint", mid_rows, lambda r: r.error)
    if ref_failed:
        summary["reference_failures"] = "; ".join(ref_failed)
    d_row.extra.update(summary)
    for r in baseline + mid_rows:
        r.extra["time_ratio_to_default"] = r.time_s / t_default
    rows = torlab_rows + baseline + mid_rows

    # -- the default grid on the accuracy test set ---------------------------------------
    for label, p, x, r, failed in tests:
        extra: dict[str, Any] = {"a_over_b": p.a / p.b, "L_mue_m": p.layer.L_mue}
        err, t = None, 0.0
        if len(x):
            mu = boundary_traction(p, x).mu
            t = _time(lambda p=p, x=x: boundary_traction(p, x), quick)
            rel = np.abs(mu / r - 1.0)
            err = float(rel.max())
            extra["worst_creepage"] = float(x[int(np.argmax(rel))])
            extra["max_abs_error_over_max_mu"] = _curve_error(mu, r)
            extra["target_met"] = bool(err <= TARGET_ERROR)
        if failed:
            extra["reference_failures"] = "; ".join(failed)
        rows.append(BenchRow(
            "fastsim default grid: accuracy test set", label, t, err,
            "boundary_traction_reference at creepages " + ",".join(f"{v:g}" for v in x),
            True, f"{len(x)} creepages (1e-5..0.5) on this scene",
            error_kind="relative (pointwise max |mu/mu_ref - 1|)", extra=extra))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import time as _t

    t0 = _t.perf_counter()
    for row in run(quick=True):
        print(row.variant, f"{row.time_s * 1e3:.2f} ms", row.error)
    print(f"{_t.perf_counter() - t0:.1f} s")
