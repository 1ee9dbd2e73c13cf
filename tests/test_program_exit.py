"""The ``torlab`` program ends with ``os._exit`` after its command (``torlab.cli.run``): the
exit code, every printed line and every written file must survive that."""

from __future__ import annotations

import json
import subprocess
import sys

from conftest import ROOT

SCENE = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"


def _torlab(*args, **kw):
    return subprocess.run([sys.executable, "-m", "torlab", *map(str, args)], capture_output=True,
                          text=True, timeout=120, **kw)


def test_exit_codes_output_and_files_survive_the_quick_exit(tmp_path):
    out = tmp_path / "o"
    r = _torlab("predict", "traction", SCENE, "-o", out, "--creepage", "0:0.05:11", "--no-plot")
    assert r.returncode == 0, r.stderr
    # the last line printed, and complete files
    assert r.stdout.rstrip().splitlines()[-1].startswith("wrote traction.csv, summary.json")
    assert len((out / "traction.csv").read_text().splitlines()) == 12
    assert json.loads((out / "summary.json").read_text())["n_points"] == 11
    # an input error: its exit code and its one line on stderr
    r = _torlab("predict", "traction", tmp_path / "missing.yaml", "-o", tmp_path / "p")
    assert r.returncode == 2 and r.stderr.startswith("error: ") and "missing.yaml" in r.stderr
    # a usage error (click's own exit code)
    r = _torlab("predict", "traction", "--no-such-option")
    assert r.returncode == 2 and "No such option" in r.stderr

