"""Benchmark of whole commands (``torlab bench``): what a user waits for.

Each main command runs as a subprocess, exactly as a user types it, on the
repository's example scenes and sample data, and is timed from start to exit.
In the same run, interleaved round by round, are timed

* ``torlab --help`` -- the floor every command pays (interpreter start, the
  CLI's imports); it is the component's default, so *time / default* is each
  command's wall time in units of ``--help``;
* the *equivalent library call* as a subprocess (``python -c`` with the
  library functions the command uses, writing the same tables with pandas, no
  figures, no console output): what the same work costs from a script;
* the library call *in this process*, warm (imports done): the computation and
  the writing alone.

Times are medians over the rounds: wall time, and the CPU time (user + system) of
the command and every process it started, which a busy machine inflates much less
than the wall time.  The ratios (command over ``--help``, command over the library
script, in-process share of the command's wall time) are what to read: the machine
is shared and noisy.  The commands write into fresh folders of a temporary
directory; the sample data are only read.

The three shipped protocols are timed *cold* (a fresh output folder: everything
reduced, fitted, predicted and drawn) and *warm* (``--force`` into a folder of an
earlier run, nothing changed: every result and figure comes from its cache).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from torlab.bench import BenchRow

__all__ = ["Case", "cases", "run"]

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "protocols" / "scenes"
SAMPLES = REPO / "sample_data"


@dataclass
class Case:
    """One command and its library equivalent.

    Attributes
    ----------
    name
        Short label (the row's variant).
    argv
        Arguments after ``torlab``; ``{out}`` is replaced by a fresh output folder.
    library
        Python source doing the command's work with the library (``OUT`` is the
        output folder, a string); None for ``--help``.
    rounds
        Rounds for this case (None: the run's default).
    in_process
        Also time the library call in this process (not for whole protocols, whose
        library call is the command's work by definition).
    warm
        ``{out}`` is one folder, filled by an untimed first run of the command without
        ``--force`` before the rounds (a re-run that finds everything in its cache).
    """

    name: str
    argv: list[str]
    library: str | None = None
    rounds: int | None = None
    in_process: bool = True
    warm: bool = False


def _files(folder: Path, pattern: str, n: int | None = None) -> list[str]:
    found = sorted(str(p) for p in folder.glob(pattern))
    return found[:n] if n else found


def cases(quick: bool = False) -> list[Case]:
    """The commands measured: all, or with ``quick`` ``--help`` and ``predict traction`` with
    and without its figure."""
    wr = str(SCENES / "wheel_rail_tab54.yaml")
    rough = str(SCENES / "optical_paper_a_rough.yaml")
    hpt = _files(SAMPLES / "hpt", "hpt_OFM1_*uL_25C.txt", 4)
    mtm = _files(SAMPLES / "mtm", "mtm_*.txt")
    optical = _files(SAMPLES / "optical", "*.csv")
    visc = str(SAMPLES / "visc" / "visc_ester_25C.txt")
    visc_ref = str(SAMPLES / "visc" / "visc_reference_25C.txt")
    fit_log = str(SAMPLES / "hpt" / "hpt_OFM1_4uL_25C.txt")
    traction_lib = f"""
import json, numpy as np
from torlab.scene import load_scene
from torlab.model.predict import predict_traction
p = predict_traction(load_scene({wr!r}), np.linspace(0.0, 0.05, 101))
p.table.to_csv(OUT + '/traction.csv', index=False)
json.dump(p.summary, open(OUT + '/summary.json', 'w'), default=str)
"""
    out: list[Case] = [
        Case("torlab --help", ["--help"]),
        Case("predict traction (Tab. 5.4, 101 creepages)",
             ["predict", "traction", wr, "-o", "{out}"], traction_lib),
        Case("predict traction --no-plot", ["predict", "traction", wr, "-o", "{out}",
                                            "--no-plot"], traction_lib),
    ]
    if quick:
        return out
    out.append(Case(f"hpt reduce ({len(hpt)} logs)", ["hpt", "reduce", *hpt, "-o", "{out}"], f"""
import pandas as pd
from pathlib import Path
from torlab.parsers.hpt import read_hpt
from torlab.reduce.hpt import reduce_hpt
rows = []
for f in {hpt!r}:
    df, meta = read_hpt(f)
    r = reduce_hpt(df, meta)
    r.data.to_csv(OUT + '/' + Path(f).stem + '_reduced.csv', index=False)
    rows.append(r.summary())
pd.DataFrame(rows).to_csv(OUT + '/summary.csv', index=False)
"""))
    out += [
        Case("predict stribeck (Paper A rough, 50 speeds)",
             ["predict", "stribeck", rough, "-o", "{out}"], f"""
import json, numpy as np
from torlab.scene import load_scene
from torlab.model.predict import predict_stribeck
p = predict_stribeck(load_scene({rough!r}), np.geomspace(0.01, 2.0, 50), 0.05)
p.table.to_csv(OUT + '/stribeck.csv', index=False)
json.dump(p.summary, open(OUT + '/summary.json', 'w'), default=str)
"""),
        Case(f"mtm reduce ({len(mtm)} exports)", ["mtm", "reduce", *mtm, "-o", "{out}"], f"""
import pandas as pd
from pathlib import Path
from torlab.parsers.pcs import read_pcs
from torlab.reduce.mtm import reduce_pcs
steps = []
for f in {mtm!r}:
    df, meta = read_pcs(f)
    red = reduce_pcs(df, meta)
    for kind, cdf in red.curves.items():
        cdf.to_csv(OUT + '/' + Path(f).stem + '_' + kind + '.csv', index=False)
    steps.append(red.steps)
pd.concat(steps, ignore_index=True).to_csv(OUT + '/summary.csv', index=False)
"""),
        Case(f"optical reduce ({len(optical)} logs)", ["optical", "reduce", *optical, "-o",
                                                      "{out}"], f"""
from pathlib import Path
from torlab.reduce.optical import reduce_optical_log
for f in {optical!r}:
    res = reduce_optical_log(f, window=4.0)
    res.points.to_csv(OUT + '/' + Path(f).stem + '_points.csv', index=False)
"""),
        Case("visc reduce (ester + reference log)",
             ["visc", "reduce", visc, "--reference", visc_ref, "-o", "{out}"], f"""
from torlab.fit.viscosity import fit_barus, fit_roelands
from torlab.parsers.viscometer import read_viscometer
from torlab.reduce.viscometer import calibrate, reduce_viscometer
cal = calibrate(*read_viscometer({visc_ref!r}))
df, meta = read_viscometer({visc!r})
res = reduce_viscometer(df, meta, calibration=cal)
res.steps.to_csv(OUT + '/steps.csv', index=False)
p, eta = res.falls['pressure_Pa'].to_numpy(), res.falls['viscosity_Pa_s'].to_numpy()
fit_barus(p, eta)
fit_roelands(p, eta)
"""),
        Case("fit hpt (one raw log)", ["fit", "hpt", fit_log, "-o", "{out}"], f"""
from torlab.yamlio import dump_yaml
from torlab.fit.layer import fit_layer_hpt
from torlab.parsers.hpt import read_hpt
from torlab.reduce.hpt import reduce_hpt
res = fit_layer_hpt([reduce_hpt(*read_hpt({fit_log!r}))], joint=True)
open(OUT + '/params.yaml', 'w').write(dump_yaml({{k: float(v) for k, v in res.params.items()}}))
"""),
    ]
    for name in ("paper_a", "paper_b", "paper_c"):
        proto = str(REPO / "protocols" / f"{name}.yaml")
        out += [Case(f"run protocols/{name}.yaml (cold)", ["run", proto, "-o", "{out}"], f"""
from torlab.protocols.runner import run_protocol
run_protocol({proto!r}, OUT + '/run')
""", rounds=2, in_process=False),
                Case(f"run protocols/{name}.yaml (warm)", ["run", proto, "-o", "{out}", "--force"],
                     rounds=3, in_process=False, warm=True)]
    return out


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("TORLAB_DEBUG", None)
    env["PYTHONIOENCODING"] = "utf-8"
    return env


def _timed(argv: list[str], cwd: Path) -> tuple[float, float]:
    """Wall and CPU time (user + system, the process and what it started) of one
    subprocess (s); raises with its last error line if it fails."""
    import resource

    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         text=True, check=False, env=_env())
    dt = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        last = (res.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise RuntimeError(f"{' '.join(argv[2:])[:120]} exited with {res.returncode}: {last}")
    return dt, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def _in_process(code: str, out: Path, rounds: int) -> float:
    """Median time of the library code run in this process (after one warm-up run)."""
    times = []
    for i in range(rounds + 1):
        d = out / f"inproc{i}"
        d.mkdir()
        t0 = time.perf_counter()
        exec(compile(code, "<library call>", "exec"), {"OUT": str(d)})
        if i:
            times.append(time.perf_counter() - t0)
    return float(np.median(times))


def run(quick: bool = False) -> list[BenchRow]:
    """Wall time of each command against ``torlab --help`` and the library call (module doc)."""
    from torlab.progress import current as progress

    todo = cases(quick)
    default_rounds = 2 if quick else 3
    cmd_t: dict[str, list[float]] = {c.name: [] for c in todo}
    cmd_cpu: dict[str, list[float]] = {c.name: [] for c in todo}
    lib_t: dict[str, list[float]] = {c.name: [] for c in todo}
    py = sys.executable
    n_runs = sum((c.rounds or default_rounds) * (2 if c.library else 1) + c.warm for c in todo)
    with tempfile.TemporaryDirectory(prefix="torlab-bench-cli-") as tmp, \
            progress().task("cli: commands", n_runs) as advance:
        root = Path(tmp)
        warm_dirs: dict[str, Path] = {}
        for k, c in enumerate(todo):
            if c.warm:  # the folder a warm run finds: filled by one untimed cold run
                warm_dirs[c.name] = root / f"warm{k}"
                argv = [a.replace("{out}", str(warm_dirs[c.name])) for a in c.argv
                        if a != "--force"]
                _timed([py, "-m", "torlab", *argv], root)
                advance()
        n = 0
        for rnd in range(max(c.rounds or default_rounds for c in todo)):
            for c in todo:
                if rnd >= (c.rounds or default_rounds):
                    continue
                n += 1
                out = warm_dirs.get(c.name, root / f"cmd{n}")
                argv = [a.replace("{out}", str(out)) for a in c.argv]
                wall, cpu = _timed([py, "-m", "torlab", *argv], root)
                cmd_t[c.name].append(wall)
                cmd_cpu[c.name].append(cpu)
                advance()
                if c.library is not None:
                    out = root / f"lib{n}"
                    out.mkdir()
                    code = f"OUT = {str(out)!r}\n{c.library}"
                    lib_t[c.name].append(_timed([py, "-c", code], root)[0])
                    advance()
        inproc = {}
        for c in todo:
            if c.library is not None and c.in_process:
                d = root / f"inproc_{len(inproc)}"
                d.mkdir()
                inproc[c.name] = _in_process(c.library, d, 2)
    t_help = float(np.median(cmd_t["torlab --help"]))
    c_help = float(np.median(cmd_cpu["torlab --help"]))
    rows = []
    for c in todo:
        t = float(np.median(cmd_t[c.name]))
        cpu = float(np.median(cmd_cpu[c.name]))
        extra: dict[str, Any] = {"ratio_to_help": t / t_help, "cpu_s": cpu,
                                 "cpu_ratio_to_help": cpu / c_help,
                                 "rounds": len(cmd_t[c.name]),
                                 "command": "torlab " + " ".join(
                                     Path(a).name if os.sep in a else a.replace("{out}", "OUT")
                                     for a in c.argv)}
        if c.library is not None and lib_t[c.name]:
            t_lib = float(np.median(lib_t[c.name]))
            extra.update(library_script_s=t_lib, ratio_to_library_script=t / t_lib)
        if c.name in inproc:
            extra.update(library_in_process_s=inproc[c.name],
                         in_process_share_of_command=inproc[c.name] / t)
        rows.append(BenchRow(
            component="command wall time", variant=c.name, time_s=t, error=None,
            reference="", default=c.library is None and not c.warm,
            unit_of_work="one command, start to exit (subprocess)", extra=extra))
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in run(quick="--quick" in sys.argv):
        print(f"{row.variant:45s} {row.time_s:7.2f} s", {k: (round(v, 3) if isinstance(v, float)
                                                            else v) for k, v in row.extra.items()})
