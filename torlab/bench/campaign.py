"""A large HPT campaign built from the Paper C sample campaign, for measuring protocol runs.

:func:`build_campaign` writes ``copies`` virtual Paper C campaigns (``torlab synth hpt``
with the seeds 1 .. ``copies``), each product renamed per seed (``OFM1-s03``), and a
protocol with Paper C's settings over all of them: at 16 copies, 1664 logs, 96 traction
curves and about 200 figures.  ``python -m torlab.bench.campaign OUT --copies 16`` builds
it and runs it cold (with and without figures) and warm, one after the other, and prints
each run's time split and the size of ``report.html`` (docs/performance.md).
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

__all__ = ["build_campaign", "run_once"]

_PROTOCOL = """\
version: 1
name: campaign_{copies}x
title: "{copies} copies of the Paper C campaign (seeds 1-{copies})"
data:
  hpt:
    files:
{files}
    compliance: s01/rig_compliance.csv
    window: 20 um
fits:
  hpt_layers:
    amounts: [4 uL, 4 mg]
    temperature: 25 degC
    joint: true
    temperature_coefficients: true
    selection: none
reports:
  amount:
    temperature: 25 degC
    band: [0.15, 0.25]
    threshold: 0.15
    basis: mass
    curve: logistic
    confidence: 0.95
  traction:
    creepage: {{from: 0, to: 0.05, points: 51}}
    trend_tolerance: 0.01
    trend_probability: 0.9
    band: [0.15, 0.25]
    curves:
      - label: "{{set}} (Tab. 5.4)"
        scene: {scene}
        params: ["hpt:*"]
"""


def build_campaign(dest: str | Path, copies: int) -> Path:
    """Write ``copies`` renamed Paper C campaigns into ``dest`` and the protocol over them
    (``dest/campaign.yaml``, returned)."""
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    for k in range(1, copies + 1):
        d = dest / f"s{k:02d}"
        if not (d / "truth.yaml").is_file():
            subprocess.run([sys.executable, "-m", "torlab", "synth", "hpt", "--seed", str(k),
                            "-o", str(d)], check=True, capture_output=True)
            for f in d.glob("hpt_*.txt"):  # each seed's products under names of their own
                text = f.read_text(encoding="utf-8")
                f.write_text(re.sub(r"^# product: (\S+)", rf"# product: \1-s{k:02d}", text,
                                    count=1, flags=re.M), encoding="utf-8")
    scene = Path(__file__).resolve().parents[2] / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
    files = "\n".join(f"      - s{k:02d}/hpt_*.txt" for k in range(1, copies + 1))
    p = dest / "campaign.yaml"
    p.write_text(_PROTOCOL.format(copies=copies, files=files, scene=scene), encoding="utf-8")
    return p


def run_once(protocol: Path, out: Path, *args: str, python: str = sys.executable,
             env: dict[str, str] | None = None) -> dict[str, float]:
    """Run ``torlab run`` in a new process: wall time, the time split it prints, the size
    of ``report.html`` and of the folder's figures."""
    t0 = time.perf_counter()
    r = subprocess.run([python, "-m", "torlab", "run", str(protocol), "-o", str(out), "-q",
                        *args], check=True, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    line = next(x for x in r.stdout.splitlines() if x.startswith("cache:"))
    got = {"wall": wall}
    for key in ("compute", "figures", "I/O"):
        m = re.search(rf"{re.escape(key)} ([0-9.]+) s", line)
        got[key.lower().replace("/", "")] = float(m.group(1)) if m else float("nan")
    html = out / "report.html"
    got["report_html_MB"] = html.stat().st_size / 1e6 if html.is_file() else float("nan")
    got["figures_MB"] = sum(f.stat().st_size for f in out.rglob("*.png")
                            if ".cache" not in f.parts) / 1e6
    return got


def main(argv: list[str] | None = None) -> int:  # pragma: no cover - a measuring tool
    import argparse
    import shutil

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("out", type=Path)
    ap.add_argument("--copies", type=int, default=16)
    ap.add_argument("--jobs", default="2")
    a = ap.parse_args(argv)
    proto = build_campaign(a.out / "campaign", a.copies)
    for name, extra in (("cold", ()), ("cold, --no-figures", ("--no-figures",))):
        out = a.out / f"run-{len(extra)}"
        shutil.rmtree(out, ignore_errors=True)
        print(name, run_once(proto, out, "-j", a.jobs, *extra))
    print("warm", run_once(proto, a.out / "run-0", "-j", a.jobs, "--force"))
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
