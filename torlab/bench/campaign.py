"""How a protocol run grows with the campaign (``torlab bench --campaign N``).

A lab's protocol may hold a year of logs.  This benchmark builds virtual Paper C
campaigns of 1x, 4x, 16x ... the sample campaign (the seeds 1, 2, ... of ``torlab synth
hpt``, each seed's products named apart -- ``OFM1-s03`` -- so that every seed adds its own
fits, predicted curves and figures, as a year of new batches does) with paper_c's
settings (``protocols/paper_c.yaml``: its data options, fits and reports, without the
comparisons of its four products by name), and runs each
with ``torlab run`` as a user does:

* **cold**: into a fresh folder (everything reduced, fitted, predicted and drawn);
* **warm**: ``--force`` into the same folder, nothing changed (everything from the cache);
* **one log added**: ``--force`` into the same folder with one log more (a copy of the
  first log under another name, :data:`ADDED_LOG`, removed after the run): what a lab's
  protocol does when a new log comes.  Its reduction, its product's fits, curve and
  figures are made again, the rest comes from the cache -- after reading the whole
  cache index, so its peak memory grows with the campaign too.

For every run it records the wall time, the CPU time (user + system of the run and every
process it started: ``os.wait4``), the peak resident memory of the largest single process
(``ru_maxrss``: the parent, or a worker), the size of ``report.html``, the run's own split
(compute, figures, I/O: ``summary.json``'s ``run.timing``), the CPU time its figures took
to draw wherever they were drawn (``figures_cpu``, against the run's CPU: the figures'
share of the work, whatever overlapped) and the counts (logs, fitted parameter sets,
predicted curves, figures).  From the sizes it fits the growth exponent
``b`` of ``time = a * logs**b`` (least squares in log-log) and extrapolates to 10 000 logs.
The peak memory is also fitted as a line, ``base + per_log * logs`` (:func:`memory_line`,
for the cold runs and for the runs with one log added):
a process holds the libraries and the largest log's work whatever the campaign, plus what
it keeps of every log, so the line's slope is what "flat in campaign size" asks to be
zero, and the line, not the power law, is what extrapolates: a power law with a small
exponent bends the line down (peaks of 166, 182, 196 and 249 MB at 104 to 6656 logs give
logs^0.09, about 247 MB at 10 000 logs and 306 MB at 100 000, where the line, 172 MB + 12.0
kB per log, gives 289 MB and 1.3 GB).

The machine may be shared: the load average at the start of each run is recorded, and
the CPU time, the memory and the counts hardly depend on it (the wall time does).

The campaigns are built once into ``data_dir`` (kept and reused when given, e.g.
``--campaign-data``), the runs write into a temporary folder.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["CampaignRun", "build_campaign", "campaign_sizes", "campaign_table", "growth",
           "memory_line", "run_campaigns"]

REPO = Path(__file__).resolve().parents[2]
#: the marker of a built campaign (its size and the torlab version that built it)
MARKER = "campaign.json"
#: the log a run with one log added finds in the campaign's ``data/`` (matched by the
#: protocol's ``data/hpt_*.txt``, sorted last); removed after that run, and by
#: :func:`build_campaign` should a run have been stopped before
ADDED_LOG = "hpt_zz_added.txt"


@dataclass
class CampaignRun:
    """One protocol run of one campaign size.

    Attributes
    ----------
    size
        Seeds in the campaign (1x, 4x ...).
    kind
        ``"cold"``, ``"warm"`` or ``"added"`` (one log added; module docstring).
    wall_s, cpu_s
        Wall time; CPU time (user + system) of the run and every process it started.
    peak_rss_mb
        Largest resident memory of a single process of the run [MB] (``ru_maxrss``).
    load
        1-minute load average when the run started.
    counts
        ``logs``, ``sets`` (fitted parameter sets), ``curves`` (predicted curves),
        ``figures``, ``report_html_mb``, ``output_files``.
    timing
        The run's own split (``compute``, ``figures``, ``io``, ``other``: seconds of wall
        time) and ``figures_cpu`` (the CPU time of drawing its figures, in every process)
        from its ``summary.json``.
    """

    size: int
    kind: str
    wall_s: float
    cpu_s: float
    peak_rss_mb: float
    load: float
    counts: dict[str, float] = field(default_factory=dict)
    timing: dict[str, float] = field(default_factory=dict)


def campaign_sizes(n: int) -> list[int]:
    """1, 4, 16 ... up to ``n`` (and ``n`` itself when it is not a power of four)."""
    if n < 1:
        raise ValueError("a campaign has at least one seed")
    sizes = [1]
    while sizes[-1] * 4 <= n:
        sizes.append(sizes[-1] * 4)
    if sizes[-1] != n:
        sizes.append(n)
    return sizes


def _protocol(n: int) -> dict[str, Any]:
    """paper_c's protocol over the campaign's files and products."""
    from torlab.yamlio import load_yaml

    base = load_yaml(REPO / "protocols" / "paper_c.yaml").data
    doc = dict(base)
    doc["name"] = f"campaign_{n}x"
    doc["title"] = f"Paper C's protocol on a {n}x campaign (seeds 1-{n})"
    doc["description"] = ("Virtual Paper C campaign, torlab synth hpt seeds 1-"
                          f"{n}, products named by seed (torlab bench --campaign).")
    doc["products"] = {f"{k}-s{s:02d}": dict(v, label=f"{v['label']} (seed {s})")
                       for s in range(1, n + 1) for k, v in base["products"].items()}
    data = {**base["data"]["hpt"], "files": ["data/hpt_*.txt"],
            "compliance": "data/rig_compliance.csv"}
    doc["data"] = {"hpt": data}
    reports = json.loads(json.dumps(base["reports"]))
    # paper_c's comparisons name its four products; the campaign's are named by seed
    reports.pop("compare", None)
    for c in reports["traction"]["curves"]:
        c["scene"] = str(REPO / "protocols" / "scenes" / Path(c["scene"]).name)
    doc["reports"] = reports
    return doc


def build_campaign(folder: str | os.PathLike[str], n: int) -> Path:
    """The campaign of seeds 1..``n`` in ``folder`` (built unless it is there already).

    ``folder/protocol.yaml`` is paper_c's protocol over ``folder/data/``: the logs of
    ``torlab synth hpt --seed s`` for every seed, each seed's products renamed
    ``<product>-s<seed>`` (file names ``hpt_s<seed>_...``), and the rig compliance of
    seed 1.  Returns the protocol's path.
    """
    from torlab import __version__
    from torlab.outputs import OutputDir
    from torlab.synth.hpt import (
        HptRig,
        compliance_curve_text,
        paper_c_design,
        simulate_hpt,
        write_hpt_log,
    )
    from torlab.yamlio import dump_yaml

    folder = Path(folder)
    marker = folder / MARKER
    import hashlib

    proto = dump_yaml(_protocol(n))  # a changed protocol (paper_c's) builds it again
    want = {"seeds": n, "torlab": __version__,
            "protocol": hashlib.sha256(proto.encode()).hexdigest()}
    try:
        if json.loads(marker.read_text(encoding="utf-8")) == want:
            (folder / "data" / ADDED_LOG).unlink(missing_ok=True)  # a stopped run's
            return folder / "protocol.yaml"
    except (OSError, ValueError):
        pass
    rig = HptRig()
    with OutputDir(folder, force=True, command=f"torlab bench --campaign {n}") as out:
        for s in range(1, n + 1):
            tag = f"s{s:02d}"
            for spec in paper_c_design(s):
                text = write_hpt_log(spec, simulate_hpt(spec, rig), rig)
                text = re.sub(r"^# product: (\S+)", rf"# product: \1-{tag}", text, count=1,
                              flags=re.M)
                out.write_text(f"data/{spec.name.replace('hpt_', f'hpt_{tag}_', 1)}.txt", text)
        out.write_text("data/rig_compliance.csv", compliance_curve_text(rig, 2))
        out.write_text("protocol.yaml", proto)
        out.write_text(MARKER, json.dumps(want))
    return folder / "protocol.yaml"


def _run(argv: list[str], cwd: Path) -> tuple[float, float, float]:
    """Wall time, CPU time (the process and its children) and peak RSS [MB] of a command."""
    env = dict(os.environ)
    env.pop("TORLAB_DEBUG", None)
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env=env)
    err = proc.stderr.read() if proc.stderr is not None else b""
    _, status, ru = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        last = (err.decode("utf-8", "replace").strip().splitlines() or ["(no output)"])[-1]
        raise RuntimeError(f"torlab {' '.join(argv[3:])[:160]} exited with {proc.returncode}: "
                           f"{last}")
    rss = ru.ru_maxrss / (1024.0 if sys.platform != "darwin" else 1024.0**2)
    return wall, ru.ru_utime + ru.ru_stime, rss


def _counts(out: Path) -> tuple[dict[str, float], dict[str, float]]:
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    run = summary.get("run", {})
    curves = summary.get("reports", {}).get("traction", {}).get("curves", [])
    html = out / "report.html"
    counts = {
        "logs": float(summary.get("data", {}).get("hpt", {}).get("files", 0)),
        "sets": float(len(summary.get("fits", {}))),
        "curves": float(len(curves) if isinstance(curves, (list, dict)) else 0),
        "figures": float(run.get("figures_drawn", 0) + run.get("figures_reused", 0)),
        "report_html_mb": html.stat().st_size / 1e6 if html.exists() else math.nan,
        "output_files": float(sum(1 for _ in out.rglob("*") if _.is_file())),
    }
    return counts, {k: float(v) for k, v in run.get("timing", {}).items()
                    if isinstance(v, (int, float))}


def run_campaigns(n: int, *, jobs: int = 2, data_dir: str | os.PathLike[str] | None = None,
                  python: str | None = None, extra_args: tuple[str, ...] = (),
                  warm_runs: int = 1, added: bool = True,
                  progress: Any = None) -> list[CampaignRun]:
    """Cold, warm and one-log-added runs of the campaigns of :func:`campaign_sizes`
    (module docstring).

    Parameters
    ----------
    n
        The largest campaign (seeds).
    jobs
        ``torlab run --jobs``.
    data_dir
        Where the campaigns are built (and kept); default a temporary folder.
    python
        The interpreter whose torlab runs (default this one): compare two installs on
        the same campaigns, one after the other.
    extra_args
        More ``torlab run`` options (``--scheduler ADDRESS`` ...).
    warm_runs
        Warm runs per size (each is a row).
    added
        A run with one log added per size, after the warm runs.
    progress
        Called with a line before each step.
    """
    say = progress or (lambda _m: None)
    py = python or sys.executable
    rows: list[CampaignRun] = []
    with tempfile.TemporaryDirectory(prefix="torlab-campaign-") as tmp:
        root = Path(data_dir) if data_dir is not None else Path(tmp) / "data"
        for size in campaign_sizes(n):
            say(f"campaign {size}x: building ...")
            proto = build_campaign(root / f"c{size}", size)
            out = Path(tmp) / f"out{size}"
            kinds = ["cold"] + ["warm"] * warm_runs + (["added"] if added else [])
            for k, kind in enumerate(kinds):
                say(f"campaign {size}x: {kind if kind != 'added' else 'one log added'} "
                    "run ...")
                argv = [py, "-m", "torlab", "run", str(proto), "-o", str(out), "--jobs",
                        str(jobs), "--quiet", *extra_args, *(["--force"] if k else [])]
                load = os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan
                extra = _add_log(proto) if kind == "added" else None
                try:
                    wall, cpu, rss = _run(argv, proto.parent)
                finally:
                    if extra is not None:
                        extra.unlink(missing_ok=True)
                counts, timing = _counts(out)
                rows.append(CampaignRun(size, kind, wall, cpu, rss, load, counts, timing))
    return rows


def _add_log(proto: Path) -> Path:
    """A copy of the campaign's first log as :data:`ADDED_LOG` beside it (its path)."""
    import shutil

    data = proto.parent / "data"
    first = min(p for p in data.glob("hpt_*.txt") if p.name != ADDED_LOG)
    extra = data / ADDED_LOG
    shutil.copyfile(first, extra)
    return extra


def _points(rows: list[CampaignRun], kind: str, what: str) -> Any:
    """``(logs, what)`` of the runs of ``kind`` as two float arrays, the runs with a
    positive count and value only; None with fewer than two campaign sizes."""
    import numpy as np

    pts = [(r.counts.get("logs", 0.0), getattr(r, what)) for r in rows if r.kind == kind]
    pts = [(x, y) for x, y in pts if x > 0 and y > 0]
    if len({x for x, _ in pts}) < 2:
        return None
    return np.array(pts, dtype=float).T


def growth(rows: list[CampaignRun], kind: str = "cold", what: str = "wall_s"
           ) -> tuple[float, float]:
    """``(a, b)`` of ``what = a * logs**b`` over the runs of ``kind`` (least squares in
    log-log; NaN with fewer than two sizes)."""
    import numpy as np

    pts = _points(rows, kind, what)
    if pts is None:
        return math.nan, math.nan
    x, y = np.log(pts)
    b, lna = np.polyfit(x, y, 1)
    return float(math.exp(lna)), float(b)


def memory_line(rows: list[CampaignRun], kind: str = "cold") -> tuple[float, float, float]:
    """``(base [MB], per_log [kB], its standard error [kB])`` of the peak memory of the
    runs of ``kind`` as the line ``base + per_log * logs`` (ordinary least squares; the
    table's MB are ``ru_maxrss``'s MiB, so 1 MB = 1024 kB here).  The standard error needs
    three sizes or more (NaN with two); everything is NaN with fewer than two."""
    import numpy as np

    pts = _points(rows, kind, "peak_rss_mb")
    if pts is None:
        return math.nan, math.nan, math.nan
    x, y = pts
    slope, base = np.polyfit(x, y, 1)
    se = math.nan  # two points: the line through both
    if x.size > 2:  # (scipy's linregress gives NaN for a flat line: its r is 0/0 there)
        s2 = float(np.sum((y - base - slope * x) ** 2)) / (x.size - 2)
        se = math.sqrt(s2 / float(np.sum((x - x.mean()) ** 2)))
    return float(base), 1024 * float(slope), 1024 * se


def campaign_table(rows: list[CampaignRun]) -> str:
    """The Markdown table of the runs, the growth exponents, the peak memory's lines
    (:func:`memory_line`, cold and with one log added) and the extrapolations to 10 000
    logs."""
    first: dict[tuple[str, int], CampaignRun] = {}
    for r in rows:
        first.setdefault((r.kind, r.size), r)
    lines = ["| size | logs / sets / curves / figures | cold, wall (CPU) | figure stage, share "
             "of cold wall | figures' CPU, share of cold CPU | warm rerun, wall (CPU) | "
             "peak memory | one log added, wall (CPU), peak memory | report.html | load |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r.kind != "cold":
            continue
        w, a = first.get(("warm", r.size)), first.get(("added", r.size))
        c = r.counts
        fig = r.timing.get("figures", math.nan)
        share = fig / r.timing["total"] if r.timing.get("total") else math.nan
        cpu = r.timing.get("figures_cpu", math.nan)
        cpu_share = f"{cpu:.1f} s, {cpu / r.cpu_s:.0%}" if r.cpu_s > 0 and math.isfinite(cpu) \
            else "-"
        lines.append(
            f"| {r.size}x | {c['logs']:.0f} / {c['sets']:.0f} / {c['curves']:.0f} / "
            f"{c['figures']:.0f} | {r.wall_s:.1f} s ({r.cpu_s:.1f} s) | {share:.0%} | "
            f"{cpu_share} | "
            + (f"{w.wall_s:.2f} s ({w.cpu_s:.2f} s)" if w else "-")
            + f" | {max(r.peak_rss_mb, w.peak_rss_mb if w else 0):.0f} MB | "
            + (f"{a.wall_s:.1f} s ({a.cpu_s:.1f} s), {a.peak_rss_mb:.0f} MB" if a else "-")
            + f" | {c['report_html_mb']:.1f} MB | {r.load:.1f}"
            + "".join(f" / {x.load:.1f}" for x in (w, a) if x) + " |")
    out = ["\n".join(lines), ""]
    for kind, what, label in (("cold", "wall_s", "cold wall"), ("cold", "cpu_s", "cold CPU"),
                              ("warm", "wall_s", "warm wall"), ("warm", "cpu_s", "warm CPU"),
                              ("added", "wall_s", "one log added, wall"),
                              ("added", "cpu_s", "one log added, CPU")):
        a, b = growth(rows, kind, what)
        if math.isfinite(b):
            out.append(f"- {label}: grows as logs^{b:.2f}; at 10 000 logs about "
                       f"{a * 1e4**b:.3g} s")
    for kind, label in (("cold", "peak memory"), ("added", "peak memory, one log added")):
        b = growth(rows, kind, "peak_rss_mb")[1]
        if math.isfinite(b):
            out.append(_memory_text(rows, b, kind, label))
    return "\n".join(out) + "\n"


def _memory_text(rows: list[CampaignRun], b: float, kind: str = "cold",
                 label: str = "peak memory") -> str:
    """The peak memory's line of the table's list (the runs of ``kind``): its growth
    exponent and its line."""
    base, per_log, se = memory_line(rows, kind)  # (+ 0.0 below: no "-0.0" for a flat line)
    sizes = len({r.size for r in rows if r.kind == kind})
    err = (f" ± {se:.1f} kB (standard error over {sizes} sizes)" if math.isfinite(se)
           else " (two sizes: no standard error)")
    return (f"- {label}: grows as logs^{b:.2f}; as a line, {base:.0f} MB + "
            f"{round(per_log, 1) + 0.0:.1f} kB per log{err}: at 10 000 logs about "
            f"{base + per_log * 1e4 / 1024:.0f} MB, at 100 000 about "
            f"{base + per_log * 1e5 / 1024:.0f} MB (flat would be 0 kB per log)")
