"""Benchmark: the memory of reducing a long HPT log, against the size of the log.

The goal: ``torlab hpt reduce`` of a log needs at most 3x the log's size in memory beyond
what the command needs for a short log (the interpreter, numpy, pandas, matplotlib).  This
benchmark writes a ``torlab-hpt`` log of 6 million rows (about 220 MB; ``quick=True``:
600 000 rows, 22 MB) whose friction is known in closed form, and runs the command on it
and on the shipped short log, each in a fresh process that reports its own peak resident
memory (``ru_maxrss``): the ratio is (peak of the long log - peak of the short log) / size
of the long log.  Both with the figure (the default) and with ``--no-plot``.

The log: normal force 63.6 kN, arm force rising as ``A tanh(t / t0)`` to a plateau, arm
250 mm, annulus 3-6 mm, angles rising linearly.  Over the last 20 um before the maximum
displacement the arm force is its plateau to within 1e-9, so the friction there is
``f = A L / (r_e F)`` with ``r_e = 2 (r2^3 - r1^3) / (3 (r2^2 - r1^2))`` (thesis Eq. 5.3);
the error column is the reduction's ``f_window`` against it.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from torlab.bench import BenchRow

__all__ = ["run"]

_F_KN, _ARM_N, _L_M, _R1, _R2 = 63.6, 50.0, 0.25, 3e-3, 6e-3

_HEADER = """\
# torlab-hpt 1
# product: BENCH
# applied_amount: 4 uL
# temperature: 25 degC
# r1: 3 mm
# r2: 6 mm
# arm_length: 250 mm
# encoder_resolution: 0.005 deg
# motor_resolution: 0.00045 deg
# notes: SYNTHETIC long log (torlab bench hpt_memory)
time [s],normal_force [kN],arm_force [N],encoder_angle [deg],motor_angle [deg]
"""

_CHILD = """\
import json, resource, sys, time
from torlab.cli import main
t0 = time.perf_counter()
try:
    main(sys.argv[1:])
except SystemExit as e:
    code = e.code
else:
    code = 0
print(json.dumps({"code": code, "seconds": time.perf_counter() - t0,
                  "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}))
"""


def write_log(path: Path, rows: int) -> float:
    """Write the benchmark's log of ``rows`` rows; returns the friction it holds."""
    t = np.arange(rows) * 0.01
    with open(path, "w", encoding="utf-8") as f:
        f.write(_HEADER)
        for s in range(0, rows, 200_000):
            ts = t[s:s + 200_000]
            arm = _ARM_N * np.tanh(ts / (t[-1] / 10))
            enc = np.round(ts / t[-1] * 5, 3)
            mot = np.round(ts / t[-1] * 5, 5)
            np.savetxt(f, np.column_stack([ts, np.full(ts.size, _F_KN), arm, enc, mot]),
                       fmt=["%.2f", "%.4f", "%.6f", "%.3f", "%.5f"], delimiter=",")
    re = 2 * (_R2**3 - _R1**3) / (3 * (_R2**2 - _R1**2))
    return _ARM_N * _L_M / (re * _F_KN * 1e3)


def _peak(log: Path, out: Path, extra: list[str]) -> dict:
    r = subprocess.run([sys.executable, "-c", _CHILD, "hpt", "reduce", str(log), "-o", str(out),
                        *extra], capture_output=True, text=True, timeout=3600)
    res = json.loads(r.stdout.strip().splitlines()[-1])
    if res["code"] != 0:
        raise RuntimeError(f"torlab hpt reduce failed: {r.stderr.strip()[-300:]}")
    return res


def run(quick: bool = False) -> list[BenchRow]:
    """Peak memory of ``torlab hpt reduce`` on a long log (see the module docstring)."""
    import pandas as pd

    from torlab import __file__ as torlab_init

    short = Path(torlab_init).resolve().parents[1] / "sample_data" / "hpt" / \
        "hpt_OFM1_4uL_25C.txt"
    rows = 600_000 if quick else 6_000_000
    out: list[BenchRow] = []
    with tempfile.TemporaryDirectory(prefix="torlab-bench-hpt-") as tmp:
        log = Path(tmp) / "long.txt"
        f_true = write_log(log, rows)
        size = log.stat().st_size
        unit = f"torlab hpt reduce of a {rows}-row log ({size / 1e6:.0f} MB)"
        for extra, what in (([], "with its figure"), (["--no-plot"], "--no-plot")):
            base = _peak(short, Path(tmp) / f"s{len(extra)}", extra) if short.is_file() \
                else {"peak": 0}
            got = _peak(log, Path(tmp) / f"l{len(extra)}", extra)
            summary = pd.read_csv(Path(tmp) / f"l{len(extra)}" / "summary.csv")
            err = abs(float(summary["f_window"].iloc[0]) - f_true) / f_true
            ratio = (got["peak"] - base["peak"]) / size
            out.append(BenchRow(
                "HPT reduction memory", f"streamed read, shared columns ({what})",
                got["seconds"], error=err, reference="closed-form friction of the log",
                default=not extra, unit_of_work=unit,
                extra={"peak_MB": round(got["peak"] / 1e6, 1),
                       "short_log_peak_MB": round(base["peak"] / 1e6, 1),
                       "memory_ratio_to_file": round(ratio, 2), "target_ratio": 3.0}))
    return out


if __name__ == "__main__":  # pragma: no cover
    for r in run(quick="--quick" in sys.argv):
        print(r.to_dict())
