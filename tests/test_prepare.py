"""``Executor.prepare``: modules the tasks need, loaded once before local workers fork."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest


def _loaded(name: str) -> bool:
    return name in sys.modules


def small_fit_protocol(folder: Path) -> Path:
    """``folder/p.yaml``: the OFM1 logs at 25 °C, one joint layer fit, the amount report
    (a protocol with reductions, fits and figures, small enough for a quick test)."""
    root = Path(__file__).resolve().parents[1]
    for f in sorted((root / "sample_data/hpt").glob("hpt_OFM1_*uL_25C*.txt")):
        shutil.copy(f, folder / f.name)
    p = folder / "p.yaml"
    p.write_text("version: 1\nname: small\ndata:\n  hpt:\n    files: [hpt_*.txt]\n"
                 "fits:\n  hpt_layers:\n    amounts: [4 uL]\n    joint: true\n"
                 "    temperature_coefficients: false\n"
                 "reports:\n  amount: {}\n")
    return p


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="workers are forked on Linux")
def test_prepared_modules_are_loaded_before_the_fork_and_only_then():
    """Run in a fresh interpreter: a prepared module is not loaded while no worker starts,
    and is in every worker (inherited) once a map of several tasks forks them."""
    code = """
import sys
from torlab.parallel import ProcessExecutor, SerialExecutor
import tests.test_prepare as t
name = "xml.dom.minidom"  # a module nothing in torlab loads
assert name not in sys.modules
SerialExecutor().prepare(name)
ex = ProcessExecutor(2)
ex.prepare(name)
assert ex.map(t._loaded, [name]) == [False]      # one task: in this process, no fork
assert name not in sys.modules
with ex:
    got = ex.map(t._loaded, [name] * 4)
assert name in sys.modules and got == [True] * 4, got
print("ok")
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr


@pytest.mark.slow  # two protocol runs in new interpreters; prepare itself: above
def test_warm_protocol_run_loads_no_optimiser_and_no_matplotlib(tmp_path):
    """A re-run that finds everything in its cache starts no worker, so the modules the
    runner prepares for them (scipy.optimize, matplotlib) are never loaded."""
    root = Path(__file__).resolve().parents[1]
    small_fit_protocol(tmp_path)
    code = f"""
import sys
from torlab.parallel import ProcessExecutor
from torlab.protocols.runner import run_protocol
with ProcessExecutor(2) as ex:
    r = run_protocol({str(tmp_path / "p.yaml")!r}, {str(tmp_path / "out")!r}, force=True,
                     executor=ex)
print(r.cache_misses, "scipy.optimize" in sys.modules, "matplotlib" in sys.modules,
      "scipy.special" in sys.modules)
"""
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           timeout=300, cwd=root) for _ in range(2)]
    for r in runs:
        assert r.returncode == 0, r.stderr
    cold, warm = (r.stdout.split() for r in runs)
    assert cold[0] != "0" and cold[1] == "True"   # the fits ran: the optimiser was loaded
    assert warm == ["0", "False", "False", "False"], warm
