"""Benchmark: what a figure costs, and what torlab's cheaper paths change in it.

Measured side by side in one run, CPU time (``time.process_time``, less disturbed by
other jobs on a shared machine than wall time), medians of interleaved rounds:

* **matplotlib's import** in a fresh Python process that has numpy and PIL loaded, as a
  ``torlab`` command does it (:data:`torlab.reports.plotting.LEAN_IMPORT`: no property
  tables in the artists' docstrings, no 3-D toolkit) against the full import.  Error:
  the number of pixels in which the same figure drawn after each import differs
  (0: identical).
* **Drawing one figure** to PNG (building it, the layout, Agg, PNG encoding), after a
  warm-up figure: the Tab. 5.4 traction curve with a 95 % band, and the HPT layer fit
  of four sample logs (821 points each, data and residual panels).
* **A long trace**: a 300 000-point random walk with spikes drawn as one line, whole
  and decimated to twice the plotting area's pixel columns
  (:func:`torlab.reports.plotting.decimate`, M4).  Error: the largest distance, in
  pixels, between the top (or bottom) dark pixel of the decimated line and that of the
  whole line in the same or a neighbouring pixel column (the criterion of
  ``tests/test_figure_cost.py``); 0 or 1 means the same line to the eye.

``quick=True`` runs fewer rounds and a 100 000-point trace.
"""

from __future__ import annotations

import io
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from torlab.bench import BenchRow

__all__ = ["run"]

ROOT = Path(__file__).resolve().parents[2]

_IMPORT = r"""
import sys, time
import numpy, PIL.Image
from torlab.reports import plotting
plotting.LEAN_IMPORT[0] = sys.argv[1] == "1"
t0 = time.process_time()
plotting._mpl()
from matplotlib.backends.backend_agg import FigureCanvasAgg
dt = time.process_time() - t0
from torlab.reports.render import render
fig, ax = plotting.subplots()
ax.plot([0, 1, 2], [0, 1, 0.5], label="a")
ax.set_xlabel("x (m)"); ax.set_ylabel("y (-)"); ax.set_title("t"); plotting.legend(ax)
plotting.finish(fig)
sys.stdout.buffer.write(f"{dt!r}\n".encode() + render(fig, "png"))
"""


def _import_rows(rounds: int) -> list[BenchRow]:
    from PIL import Image

    times: dict[str, list[float]] = {"1": [], "0": []}
    pngs: dict[str, bytes] = {}
    for _ in range(rounds):
        for lean in ("1", "0"):
            out = subprocess.run([sys.executable, "-c", _IMPORT, lean], capture_output=True,
                                 check=True, cwd=ROOT).stdout
            head, png = out.split(b"\n", 1)
            times[lean].append(float(head))
            pngs[lean] = png
    a, b = (np.asarray(Image.open(io.BytesIO(pngs[k])).convert("RGB")) for k in ("1", "0"))
    diff = int((a != b).any(axis=2).sum()) if a.shape == b.shape else -1
    lean, full = statistics.median(times["1"]), statistics.median(times["0"])
    unit = "import matplotlib.figure + Agg canvas in a fresh process (CPU time)"
    ref = "pixels differing from the same figure after the full import"
    return [BenchRow("matplotlib import", "lean (torlab commands)", lean, diff, ref, True, unit,
                     extra={"ratio_to_full": lean / full, "rounds": rounds}),
            BenchRow("matplotlib import", "full", full, 0.0, ref, False, unit,
                     extra={"rounds": rounds})]


def _cpu(fn: Any, rounds: int) -> float:
    fn()  # warm-up (fonts, caches)
    out = []
    for _ in range(rounds):
        t0 = time.process_time()
        fn()
        out.append(time.process_time() - t0)
    return statistics.median(out)


def _figure_rows(rounds: int) -> list[BenchRow]:
    from torlab.fit.layer import fit_layer_hpt
    from torlab.model.predict import predict_traction
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import reduce_hpt
    from torlab.reports.fit import result_figure
    from torlab.reports.predict import traction_figure
    from torlab.reports.render import Plot, plot
    from torlab.scene import load_scene

    sc = load_scene(ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml")
    t = predict_traction(sc, np.linspace(0.0, 0.05, 101)).table.copy()
    t["mu_low95"], t["mu_high95"] = 0.95 * t["mu"], 1.05 * t["mu"]
    logs = sorted((ROOT / "sample_data" / "hpt").glob("hpt_OFM1_4uL_25C*.txt"))
    fit = fit_layer_hpt([reduce_hpt(*read_hpt(f)) for f in logs], joint=True)
    cases: list[tuple[str, Plot]] = [
        ("traction curve, 101 points, band", plot(traction_figure, [("Tab. 5.4", t)],
                                                  boundary=sc.boundary, title="Tab. 5.4")),
        (f"HPT layer fit, {len(logs)} logs x {len(fit.data) // max(len(logs), 1)} points",
         plot(result_figure, fit)),
    ]
    rows = []
    for name, p in cases:
        def draw(p: Plot = p) -> None:
            from torlab.reports.render import draw_task

            draw_task((p, ("png",), None))

        rows.append(BenchRow("figure to PNG", name, _cpu(draw, rounds), None, "", True,
                             "build, lay out, draw and encode one figure (CPU time)",
                             extra={"rounds": rounds}))
    return rows


def _ink(png: bytes) -> tuple[np.ndarray, np.ndarray]:
    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png)).convert("L")).astype(int) < 150
    rows = np.arange(a.shape[0])[:, None]
    return np.where(a, rows, a.shape[0]).min(axis=0), np.where(a, rows, -1).max(axis=0)


def _extent_error(top: np.ndarray, bot: np.ndarray, top_ref: np.ndarray,
                  bot_ref: np.ndarray) -> float:
    def near(v: np.ndarray, f: Any) -> np.ndarray:
        p = np.pad(v, 1, mode="edge")
        return f(np.stack([p[:-2], p[1:-1], p[2:]]), axis=0)

    drawn = (bot >= 0) & (bot_ref >= 0)
    if not np.array_equal(bot >= 0, bot_ref >= 0):
        return float("inf")
    e = np.concatenate([np.maximum(near(top_ref, np.min) - top, 0)[drawn],
                        np.maximum(bot - near(bot_ref, np.max), 0)[drawn],
                        np.maximum(near(top, np.min) - top_ref, 0)[drawn],
                        np.maximum(bot_ref - near(bot, np.max), 0)[drawn]])
    return float(e.max()) if e.size else 0.0


def _trace_rows(n: int, rounds: int) -> list[BenchRow]:
    from torlab.reports.plotting import decimate, pixel_columns, subplots
    from torlab.reports.render import render

    rng = np.random.default_rng(7)
    x = np.linspace(0.0, 50.0, n)
    y = np.cumsum(rng.normal(size=n)) + 20 * np.sin(x / 3)
    y[rng.integers(0, n, 5)] += 150.0
    out: dict[bool, bytes] = {}
    kept: dict[bool, int] = {}

    def draw(thin: bool) -> None:
        fig, ax = subplots()
        ax.axis("off")
        xx, yy = decimate(x, y, pixel_columns(ax)) if thin else (x, y)
        ax.plot(xx, yy, lw=0.8, color="k")
        out[thin] = render(fig, "png")
        kept[thin] = int(xx.size)

    times: dict[bool, list[float]] = {True: [], False: []}
    draw(True)
    draw(False)
    for _ in range(rounds):
        for thin in (True, False):
            t0 = time.process_time()
            draw(thin)
            times[thin].append(time.process_time() - t0)
    ref = _ink(out[False])
    err = _extent_error(*_ink(out[True]), *ref)
    unit = f"draw a {n}-point line to PNG (CPU time)"
    what = "pixels by which the line's top/bottom per column departs from the whole line's"
    full = statistics.median(times[False])
    thin = statistics.median(times[True])
    return [BenchRow("long trace", "decimated (M4, 2x pixel columns)", thin, err, what, True,
                     unit, extra={"points_drawn": kept[True], "ratio_to_whole": thin / full,
                                  "rounds": rounds}),
            BenchRow("long trace", "whole line", full, 0.0, what, False, unit,
                     extra={"points_drawn": kept[False], "rounds": rounds})]


def run(quick: bool = False) -> list[BenchRow]:
    """Rows of the three measurements (module doc)."""
    rounds = 3 if quick else 7
    return (_import_rows(rounds) + _figure_rows(rounds)
            + _trace_rows(100_000 if quick else 300_000, rounds))


if __name__ == "__main__":  # pragma: no cover
    for row in run(quick="--quick" in sys.argv):
        print(f"{row.component:20s} {row.variant:40s} {row.time_s * 1e3:8.1f} ms", row.error,
              row.extra)
