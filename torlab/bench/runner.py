"""Running the benchmarks and writing their results (``torlab bench``).

Every module ``torlab.bench.<name>`` that defines ``run(quick: bool = False) ->
list[BenchRow]`` is a benchmark (see :mod:`torlab.bench`).
:func:`run_benchmarks` discovers and runs them (a module that raises becomes
one ``failed`` row, the others still run); :func:`write_bench_outputs` writes

* ``bench.csv`` -- one row per measured variant (the :class:`BenchRow` fields,
  ``time_ratio_to_default`` and the module's extra figures as ``x_*`` columns);
* ``bench.md`` -- the machine, the command, a Markdown table and the extra
  figures per component;
* ``plots/<component>.png`` -- time against error per component, log-log,
  the default marked.

Example
-------
>>> from torlab.bench.runner import run_benchmarks, write_bench_outputs   # doctest: +SKIP
>>> from torlab.outputs import OutputDir
>>> res = run_benchmarks(quick=True, only=["hertz"])
>>> with OutputDir("bench-out") as out:
...     write_bench_outputs(res, out, command="notebook")
"""

from __future__ import annotations

import datetime as _dt
import importlib
import json
import math
import os
import platform
import re
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from torlab.bench import BenchRow
from torlab.errors import TorlabInputError

__all__ = [
    "BenchResult",
    "available_benchmarks",
    "bench_markdown",
    "bench_table",
    "display_rows",
    "machine_info",
    "run_benchmarks",
    "time_error_figure",
    "write_bench_outputs",
]

#: modules of torlab.bench that are not benchmarks
_NOT_BENCHMARKS = {"runner", "campaign"}  # campaign: torlab bench --campaign
#: the order benchmarks run and appear in (others follow alphabetically)
_ORDER = ("hertz", "fastsim", "temperature", "asperity", "loadshare", "scenes", "fit", "optical",
          "cli")


@dataclass
class BenchResult:
    """Rows of a benchmark run and how it went.

    Attributes
    ----------
    rows
        Every measured variant, in module order.
    modules
        ``(module, status, wall time s, rows, message)`` per benchmark module run;
        status ``ok``, ``failed`` or ``skipped`` (no ``run`` function).
    quick
        Whether the reduced set ran.
    machine
        :func:`machine_info` at the start of the run.
    wall_time_s
        Wall time of the whole run.
    """

    rows: list[BenchRow]
    modules: list[tuple[str, str, float, int, str]]
    quick: bool
    machine: dict[str, str] = field(default_factory=dict)
    wall_time_s: float = 0.0

    @property
    def failed(self) -> list[str]:
        """Names of the modules that raised."""
        return [m for m, status, *_ in self.modules if status == "failed"]


def available_benchmarks() -> list[str]:
    """Names of the modules in :mod:`torlab.bench` (candidates; ``run`` checked on import)."""
    import pkgutil

    import torlab.bench as pkg

    names = [m.name for m in pkgutil.iter_modules(pkg.__path__)
             if not m.name.startswith("_") and m.name not in _NOT_BENCHMARKS]
    rank = {n: i for i, n in enumerate(_ORDER)}
    return sorted(names, key=lambda n: (rank.get(n, len(rank)), n))


def machine_info() -> dict[str, str]:
    """CPU model, cores, memory, load, Python and library versions, date (strings)."""
    import numpy
    import pandas
    import scipy

    from torlab import __version__

    cpu = ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    cpu = cpu or platform.processor() or platform.machine() or "unknown"
    logical = os.cpu_count() or 0
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = logical
    mem = ""
    try:
        with open("/proc/meminfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    mem = f"{int(line.split()[1]) / 1024**2:.1f} GiB"
                    break
    except (OSError, ValueError, IndexError):
        pass
    try:
        load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
    except (AttributeError, OSError):
        load = "n/a"
    return {
        "cpu": cpu,
        "cores": f"{logical} logical, {usable} usable by this process",
        "memory": mem or "n/a",
        "load_average_1_5_15_min": load,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "pandas": pandas.__version__,
        "torlab": __version__,
        "date": _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S %Z"),
    }


def select_components(only: Sequence[str] | None) -> list[str]:
    names = available_benchmarks()
    if not only:
        return names
    wanted: list[str] = []
    for item in only:
        for name in (s.strip() for s in str(item).split(",")):
            if not name:
                continue
            if name not in names:
                raise TorlabInputError(f"no benchmark {name!r}; available: {', '.join(names)}",
                                       key="--only")
            if name not in wanted:
                wanted.append(name)
    if not wanted:
        raise TorlabInputError("no benchmark named", key="--only")
    return [n for n in names if n in wanted]


def run_benchmarks(quick: bool = False, only: Sequence[str] | None = None,
                   progress: Callable[[str], None] | None = None) -> BenchResult:
    """Run the benchmark modules and collect their rows.

    Parameters
    ----------
    quick
        Passed to every module's ``run`` (the reduced set CI runs).
    only
        Module names (``hertz``, ``fastsim`` ...; comma lists allowed); None: all.
    progress
        Called with a one-line message before and after each module.

    Returns
    -------
    BenchResult
        A module that raises gives one row with ``variant`` ``FAILED`` and the
        error in ``reference``; the other modules still run.

    Raises
    ------
    TorlabInputError
        An unknown name in ``only``.
    """
    names = select_components(only)
    say = progress or (lambda _m: None)
    machine = machine_info()
    rows: list[BenchRow] = []
    modules: list[tuple[str, str, float, int, str]] = []
    t_all = time.perf_counter()
    for name in names:
        say(f"running {name} ...")
        t0 = time.perf_counter()
        try:
            mod = importlib.import_module(f"torlab.bench.{name}")
            fn = getattr(mod, "run", None)
            if not callable(fn):
                modules.append((name, "skipped", 0.0, 0, "no run() function"))
                say(f"{name}: skipped (no run() function)")
                continue
            got = fn(quick=quick)
            if not isinstance(got, list) or not all(isinstance(r, BenchRow) for r in got):
                raise TypeError(f"run() returned {type(got).__name__}, not a list of BenchRow")
            for r in got:
                r.extra.setdefault("module", name)
            rows += got
            dt = time.perf_counter() - t0
            modules.append((name, "ok", dt, len(got), ""))
            say(f"{name}: {len(got)} rows in {dt:.1f} s")
        except KeyboardInterrupt:
            raise
        except BaseException as e:  # a failing benchmark must not stop the others
            dt = time.perf_counter() - t0
            msg = f"{type(e).__name__}: {e}".strip()
            where = traceback.extract_tb(e.__traceback__)
            if where:
                last = where[-1]
                msg += f" (at {os.path.basename(last.filename)}:{last.lineno})"
            rows.append(BenchRow(component=name, variant="FAILED", time_s=dt, error=None,
                                 reference=msg, unit_of_work="benchmark module run",
                                 extra={"module": name, "status": "failed"}))
            modules.append((name, "failed", dt, 0, msg))
            say(f"{name}: FAILED after {dt:.1f} s: {msg}")
    return BenchResult(rows=rows, modules=modules, quick=quick, machine=machine,
                       wall_time_s=time.perf_counter() - t_all)


# -------------------------------------------------------------------------------------------
# tables
# -------------------------------------------------------------------------------------------
def _default_times(rows: Sequence[BenchRow]) -> dict[str, float]:
    """Time of the single default row per component (components with 0 or >1 defaults omitted)."""
    by: dict[str, list[BenchRow]] = {}
    for r in rows:
        if r.default:
            by.setdefault(r.component, []).append(r)
    return {c: rs[0].time_s for c, rs in by.items() if len(rs) == 1 and rs[0].time_s > 0}


def _ratio(r: BenchRow, defaults: dict[str, float]) -> float | None:
    t = defaults.get(r.component)
    if t is None or r.extra.get("status") == "failed" or not math.isfinite(r.time_s):
        return None
    return r.time_s / t


def _cell(v: Any) -> Any:
    """A CSV-safe value: finite numbers, bools, strings; None for missing."""
    if v is None:
        return None
    if isinstance(v, bool):
        return v
    if isinstance(v, (int, float)):
        f = float(v)
        return v if math.isfinite(f) else str(f)
    if hasattr(v, "item") and callable(v.item):  # numpy scalar
        return _cell(v.item())
    if isinstance(v, (dict, list, tuple)):
        return json.dumps(v, default=str)
    return str(v)


def bench_table(result: BenchResult) -> Any:
    """The rows as a DataFrame (the columns of ``bench.csv``)."""
    import pandas as pd

    defaults = _default_times(result.rows)
    base_cols = ["module", "component", "variant", "default", "time_s", "error", "error_kind",
                 "reference", "unit_of_work", "time_ratio_to_default", "status"]
    recs = []
    extra_cols: list[str] = []
    for r in result.rows:
        rec = {
            "module": r.extra.get("module", ""), "component": r.component, "variant": r.variant,
            "default": bool(r.default), "time_s": _cell(r.time_s), "error": _cell(r.error),
            "error_kind": r.error_kind, "reference": r.reference, "unit_of_work": r.unit_of_work,
            "time_ratio_to_default": _cell(_ratio(r, defaults)),
            "status": r.extra.get("status", "ok"),
        }
        for k, v in r.extra.items():
            if k in ("module", "status"):
                continue
            col = f"x_{k}"
            if col not in extra_cols:
                extra_cols.append(col)
            rec[col] = _cell(v)
        recs.append(rec)
    return pd.DataFrame(recs, columns=base_cols + extra_cols)


def _fmt_time(t: Any) -> str:
    if not isinstance(t, (int, float)) or isinstance(t, bool) or not math.isfinite(t):
        return "" if t is None else str(t)
    if t >= 1:
        return f"{t:.3g} s"
    if t >= 1e-3:
        return f"{t * 1e3:.3g} ms"
    return f"{t * 1e6:.3g} µs"


def _fmt_num(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return str(v)
        if v == 0:
            return "0"
        return f"{v:.3g}"
    return str(v)


def _md(s: Any) -> str:
    return str(s).replace("|", "\\|").replace("\n", " ")


def display_rows(result: BenchResult) -> list[dict[str, str]]:
    defaults = _default_times(result.rows)
    out = []
    for r in result.rows:
        ratio = _ratio(r, defaults)
        out.append({
            "component": r.component,
            "variant": r.variant,
            "default": "★" if r.default else "",
            "time": _fmt_time(r.time_s),
            "error": _fmt_num(r.error) if r.error is not None else "",
            "reference": r.reference,
            "time / default": "" if ratio is None else f"{ratio:.3g}",
            "unit of work": r.unit_of_work,
        })
    return out


def bench_markdown(result: BenchResult, command: str) -> str:  # noqa: C901 (the report's sections in reading order, one branch each)
    """``bench.md``: machine, command, the table and each component's extra figures."""
    m = result.machine
    lines = [
        "# torlab bench" + (" (quick)" if result.quick else ""),
        "",
        f"- command: `{command}`",
        f"- date: {m.get('date', '')}",
        f"- CPU: {m.get('cpu', '')}; cores: {m.get('cores', '')}; memory: {m.get('memory', '')}",
        f"- load average at the start (1/5/15 min): {m.get('load_average_1_5_15_min', '')}",
        f"- Python {m.get('python', '')}, numpy {m.get('numpy', '')}, scipy {m.get('scipy', '')}, "
        f"pandas {m.get('pandas', '')}, torlab {m.get('torlab', '')}; {m.get('platform', '')}",
        f"- total wall time: {result.wall_time_s:.1f} s",
        "",
        "Times are medians of repeated runs of the unit of work on this (shared) machine; "
        "compare ratios measured in the same run rather than absolute times. "
        "★ marks torlab's default; *time / default* is relative to the default of the same "
        "component.",
        "",
        "## Modules",
        "",
        "| module | status | wall time | rows | note |",
        "|---|---|---|---|---|",
    ]
    for name, status, dt, n, msg in result.modules:
        lines.append(f"| {name} | {status} | {dt:.1f} s | {n} | {_md(msg)} |")
    lines += ["", "## Results", ""]
    disp = display_rows(result)
    cols = ["component", "variant", "default", "time", "error", "time / default", "unit of work",
            "reference"]
    lines.append("| " + " | ".join(cols) + " |")
    lines.append("|" + "---|" * len(cols))
    for d in disp:
        lines.append("| " + " | ".join(_md(d[c]) for c in cols) + " |")
    # extra figures per component
    comps: list[str] = []
    for r in result.rows:
        if r.component not in comps:
            comps.append(r.component)
    detail = []
    for c in comps:
        rs = [r for r in result.rows if r.component == c]
        count: dict[str, int] = {}
        for r in rs:
            for k in r.extra:
                if k not in ("module", "status"):
                    count[k] = count.get(k, 0) + 1
        if not count:
            continue
        detail += [f"### {c}", ""]
        # figures most variants have: a table; figures of one variant only: a list
        keys = [k for k, n in count.items() if n > 1 or len(rs) == 1]
        if keys:
            detail += ["| variant | " + " | ".join(_md(k) for k in keys) + " |",
                       "|---|" + "---|" * len(keys)]
            for r in rs:
                vals = [_md(_fmt_extra(k, r.extra.get(k))) for k in keys]
                detail.append(f"| {_md(r.variant)}{' ★' if r.default else ''} | "
                              + " | ".join(vals) + " |")
            detail.append("")
        for r in rs:
            own = [k for k in r.extra if count.get(k) == 1 and k not in keys]
            if own:
                detail.append(f"{_md(r.variant)}{' ★' if r.default else ''}:")
                detail.append("")
                detail += [f"- {k}: {_fmt_extra(k, r.extra[k])}" for k in own]
                detail.append("")
    if detail:
        lines += ["", "## Details per component", "", *detail]
    plots = [f"plots/{_slug(c)}.png" for c in comps if _plottable([r for r in result.rows
                                                                  if r.component == c])]
    if plots:
        lines += ["## Plots", "", "Time against error per component (log-log; ★ the default): "
                  + ", ".join(f"`{p}`" for p in plots), ""]
    return "\n".join(lines).rstrip() + "\n"


def _fmt_extra(key: str, v: Any) -> str:
    if isinstance(v, float) and key.endswith("_s") and math.isfinite(v):
        return _fmt_time(v)
    if isinstance(v, (dict, list, tuple)):
        return json.dumps(v, default=str)
    return _fmt_num(v)


def _slug(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", s).strip("_").lower() or "component"


# -------------------------------------------------------------------------------------------
# figures
# -------------------------------------------------------------------------------------------
def _plottable(rows: Sequence[BenchRow]) -> bool:
    return any(r.error is not None and math.isfinite(r.error) and r.time_s > 0
               and math.isfinite(r.time_s) for r in rows)


def time_error_figure(component: str, rows: Sequence[BenchRow]) -> Any:
    """Time against error of one component's variants (log-log), the default marked.

    Rows without an error are left out; an error of exactly 0 is drawn at the
    bottom of the axis with a downward triangle.  Variants are grouped by their
    ``extra["family"]`` where the module gives one; a line joins each group's
    speed/error front (the variants no faster variant beats in accuracy).
    """
    from torlab.reports.plotting import legend, subplots

    pts = [r for r in rows if r.error is not None and math.isfinite(r.error)
           and r.time_s > 0 and math.isfinite(r.time_s)]
    if not pts:
        raise ValueError(f"{component}: no variant with a time and an error to plot")
    pos = [r.error for r in pts if r.error > 0]
    floor = min(pos) / 10 if pos else 1e-16
    fig, ax = subplots()
    groups: dict[str, list[BenchRow]] = {}
    for r in pts:
        groups.setdefault(str(r.extra.get("family", "variants")), []).append(r)
    few = len(pts) <= 8  # few variants: each its own marker and legend entry
    marks = "osD^vp<>"
    for fam, rs in groups.items():
        rs = sorted(rs, key=lambda r: r.time_s)
        x = [r.error if r.error > 0 else floor for r in rs]
        y = [r.time_s for r in rs]
        line = ax.plot(x, y, "o", ms=4, label=None if few else fam)[0]
        if few:
            line.set_visible(False)
            for k, (xx, yy, r) in enumerate(zip(x, y, rs, strict=True)):
                name = r.variant[:48] + (f" (error 0, drawn at {floor:.0e})" if r.error == 0
                                         else "")
                ax.plot([xx], [yy], marks[k % len(marks)], ms=5, color=line.get_color(),
                        label=name if len(groups) == 1 else f"{fam}: {name}")
        # the family's speed/error front: each point faster than every more accurate one
        front, best = [], math.inf
        for xx, yy in zip(x, y, strict=True):
            if xx < best:
                front.append((xx, yy))
                best = xx
        if len(front) > 1:
            ax.plot(*zip(*front, strict=True), "-", lw=0.8, color=line.get_color())
        zero = [(xx, yy) for xx, yy, r in zip(x, y, rs, strict=True) if r.error == 0]
        if zero and not few:
            ax.plot(*zip(*zero, strict=True), "v", color=line.get_color(), ms=7)
    for r in pts:
        if r.default:
            e = r.error if r.error > 0 else floor
            ax.plot([e], [r.time_s], "*", ms=16, mfc="none", mec="k", mew=1.4, zorder=5,
                    label="default")
    ax.set_xscale("log")
    ax.set_yscale("log")
    import textwrap

    kind = pts[0].error_kind or "relative"
    refs = sorted({r.reference for r in pts})
    against = refs[0] if len(refs) == 1 else "each variant's reference (see bench.md)"
    ax.set_xlabel("\n".join(textwrap.wrap(f"error ε, {kind}, against {against} (–)", 100)),
                  fontsize=7)
    units = sorted({r.unit_of_work for r in pts})
    unit = units[0] if len(units) == 1 else "one unit of work (see bench.md)"
    ax.set_ylabel("\n".join(textwrap.wrap(f"time t per {unit} (s)", 60)), fontsize=7)
    ax.set_title(f"{component}: time against error", fontsize=10)
    if any(r.error == 0 for r in pts) and not few:
        ax.plot([], [], "v", color="0.4", label=f"error 0 (drawn at {floor:.0e})")
    legend(ax)
    return fig


def write_bench_outputs(result: BenchResult, out: Any, command: str) -> list[str]:
    """Write ``bench.csv``, ``bench.md`` and ``plots/*.png`` into an :class:`~torlab.outputs.OutputDir`.

    Returns
    -------
    list of str
        The names written (relative to the output folder).
    """
    table = bench_table(result)
    missing = (*(c for c in table.columns if c.startswith("x_")), "error", "time_ratio_to_default")
    names = ["bench.csv", "bench.md"]
    out.write_csv("bench.csv", table, allow_missing=missing)
    out.write_text("bench.md", bench_markdown(result, command))
    from torlab.reports.render import plot, write_figures

    comps: list[str] = []
    for r in result.rows:
        if r.component not in comps:
            comps.append(r.component)
    for c in comps:
        rs = [r for r in result.rows if r.component == c]
        if _plottable(rs):
            written, _ = write_figures(out, [(f"plots/{_slug(c)}", plot(time_error_figure, c,
                                                                         list(rs)))])
            names += written
    return names
