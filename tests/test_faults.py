"""Faults around ``torlab run``: kills at many points, concurrent runs, read-only and full disks.

Each test starts real ``torlab`` processes.  The invariant, whatever happens: the output
folder holds either the earlier results, byte for byte, or complete new ones (every file
its manifest lists, nothing else) -- never a mix, never neither once the next torlab
command has run -- and no staging folder is left behind after that command.  Where the
user can act (a busy, read-only or full place) the exit code is 2 with one line.
"""

from __future__ import annotations

import json
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

HPT = ROOT / "sample_data" / "hpt"
SCENE = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
SMALL = """\
version: 1
name: small
data:
  hpt:
    files: [hpt_*.txt]
fits:
  hpt_layers:
    amounts: [4 uL]
    temperature_coefficients: false
reports:
  amount:
    curve: interpolation
  traction:
    creepage: {from: 0, to: 0.05, points: 6}
    curves:
      - label: "{set}"
        scene: scene.yaml
        params: ["hpt:*"]
"""

#: seconds between start and kill -9: fixed seed, spread over a run (import, reduction,
#: fits, figures, commit); any point must satisfy the invariant
_RNG = random.Random(7)
KILL_AFTER = sorted(round(_RNG.uniform(0.3, 6.0), 2) for _ in range(4))


def _env(tmp: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("TORLAB_CONFIG_DIR", str(tmp / "config"))
    env["MPLCONFIGDIR"] = str(tmp / "mpl")
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    return env


def _torlab(tmp: Path, *args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "torlab", *map(str, args)], env=_env(tmp),
                          capture_output=True, text=True, timeout=300, **kw)


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    """A protocol with four HPT logs and a scene, run once; results in ``res/out``."""
    base = tmp_path_factory.mktemp("baseline")
    for f in sorted(HPT.glob("hpt_OFM1_*uL_25C.txt"))[:4]:
        shutil.copy(f, base / f.name)
    shutil.copy(SCENE, base / "scene.yaml")
    (base / "p.yaml").write_text(SMALL)
    (base / "res").mkdir()
    r = _torlab(base, "run", base / "p.yaml", "-o", base / "res" / "out")
    assert r.returncode == 0, r.stderr
    return base


@pytest.fixture
def project(baseline, tmp_path):
    """A copy of the baseline project (its earlier results included)."""
    p = tmp_path / "project"
    shutil.copytree(baseline, p, symlinks=True)
    return p


def _snapshot(out: Path) -> dict[str, bytes]:
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*"))
            if p.is_file()}


def _results(snap: dict[str, bytes]) -> dict[str, bytes]:
    """A snapshot without the protocol cache: the cache is moved into a run while it works
    (one rename) and moved back if it fails, so a failed run leaves the entries it added and
    a killed run leaves the earlier results without it (the next run rebuilds it); the
    results themselves are what must survive."""
    return {k: v for k, v in snap.items() if not k.startswith(".cache/")}


def _complete(out: Path) -> dict[str, bytes]:
    """The folder's files, after checking they are exactly what its manifest lists."""
    snap = _snapshot(out)
    man = json.loads(snap["torlab-manifest.json"])
    listed = set(man["files"])
    # the cache may be missing (see _results); every other listed file is there
    assert all((out / f).exists() for f in listed if f.split("/", 1)[0] != ".cache"), \
        "a listed file is missing"
    folders = {f for f in listed if (out / f).is_dir()}  # e.g. .cache
    for f in set(snap) - {"torlab-manifest.json"}:
        assert f in listed or f.split("/", 1)[0] in folders, f"{f} is not in the manifest"
    return snap


def _first_run(project: Path) -> dict[str, bytes]:
    """The earlier results of the project (complete)."""
    return _complete(project / "res" / "out")


def _same_results(a: dict[str, bytes], b: dict[str, bytes]) -> bool:
    """Two complete results of the same protocol (the data files are byte-identical)."""
    a, b = _results(a), _results(b)
    data = [k for k in a if k.endswith(".csv")]
    return set(a) == set(b) and all(a[k] == b[k] for k in data)


def _leftovers(project: Path) -> list[str]:
    return sorted(p.name for p in (project / "res").iterdir() if p.name != "out")


@pytest.mark.slow
@pytest.mark.parametrize("delay", KILL_AFTER)
def test_kill_at_any_time_leaves_old_or_new_results(project, delay):
    before = _first_run(project)
    out = project / "res" / "out"
    proc = subprocess.Popen([sys.executable, "-m", "torlab", "run", str(project / "p.yaml"),
                             "-o", str(out), "--force"], env=_env(project),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        proc.wait(timeout=delay)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    after = _complete(out)
    assert after == before or _same_results(after, before)
    r = _torlab(project, "run", project / "p.yaml", "-o", out, "--force")
    assert r.returncode == 0, r.stderr
    assert _same_results(_complete(out), before)
    assert _leftovers(project) == []


KILLER = """\
import os, signal, sys
import torlab.outputs as o
point = sys.argv[1]
real_replace, real_exchange = os.replace, o._exchange
def replace(a, b, **kw):
    if point in ("before-first-rename", "between-renames") and ".out.old-" in str(b):
        if point == "before-first-rename":
            os.kill(os.getpid(), signal.SIGKILL)
        real_replace(a, b, **kw)
        os.kill(os.getpid(), signal.SIGKILL)
    return real_replace(a, b, **kw)
def exchange(folder, a, b):
    if point == "after-exchange":
        real_exchange(folder, a, b) or sys.exit("no renameat2 here")
        os.kill(os.getpid(), signal.SIGKILL)
    return False  # two renames (the path for systems without an atomic exchange)
o.os.replace = replace
o._exchange = exchange
from torlab.cli import main
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.slow
@pytest.mark.parametrize("point", ["before-first-rename", "between-renames", "after-exchange"])
def test_kill_inside_the_commit_never_loses_both_versions(project, point):
    before = _first_run(project)
    out = project / "res" / "out"
    killer = project / "killer.py"
    killer.write_text(KILLER)
    r = subprocess.run([sys.executable, str(killer), point, "run", str(project / "p.yaml"),
                        "-o", str(out), "--force"], env=_env(project), capture_output=True,
                       text=True, timeout=300)
    if "no renameat2" in r.stderr:
        pytest.skip("no atomic exchange on this system")
    assert r.returncode == -signal.SIGKILL
    hidden = [p for p in (project / "res").iterdir() if p.name.startswith(".out.old-")]
    if point == "between-renames":
        assert not out.exists() and len(hidden) == 1  # the earlier results, complete, hidden
        assert _results(_snapshot(hidden[0])) == _results(before)
    else:
        assert _same_results(_complete(out), before)
    # the next command writing to out puts everything right before it looks at out
    r = _torlab(project, "run", project / "p.yaml", "-o", out)
    assert r.returncode == 2 and "already holds results" in r.stderr  # no --force: refused
    if point == "between-renames":
        assert _results(_snapshot(out)) == _results(before)
    assert _leftovers(project) == []
    assert _same_results(_complete(out), before)


@pytest.mark.slow  # three processes; the lock itself: tests/test_trust.py
def test_second_run_into_a_busy_folder_is_refused(project):
    before = _first_run(project)
    out = project / "res" / "out"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time\nfrom torlab.outputs import OutputDir\n"
         f"d = OutputDir({str(out)!r}, force=True)\nprint('locked', flush=True)\ntime.sleep(120)"],
        env=_env(project), stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        r = _torlab(project, "run", project / "p.yaml", "-o", out, "--force")
        assert r.returncode == 2
        assert r.stderr.strip() == (f"error: {out}: another torlab run (pid {holder.pid}) is "
                                    "writing to this output folder; wait for it to finish or "
                                    "choose another -o")
        assert _snapshot(out) == before
    finally:
        holder.kill()  # kill -9 frees the lock
        holder.wait()
    r = _torlab(project, "run", project / "p.yaml", "-o", out, "--force")
    assert r.returncode == 0, r.stderr
    assert _leftovers(project) == []


_HOLDER_WITH_WORKERS = """\
import time
from torlab.outputs import OutputDir
from torlab.parallel import ProcessExecutor, _noop
d = OutputDir({out!r}, force=True)
ex = ProcessExecutor(2)
assert ex.map(_noop, [1, 2, 3]) == [1, 2, 3]
print("workers", *[p.pid for p in ex._pool._processes.values()], flush=True)
time.sleep(120)
"""


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and fork: Linux")
def test_killed_run_with_worker_processes_leaves_the_folder_free(project):
    """kill -9 of a run whose process pool is busy: its forked workers neither hold the output
    folder's lock (they close their copy at fork) nor outlive the run (they die with their
    parent); the next run into the folder is not refused."""
    out = project / "res" / "out"
    lock = out.parent / f".{out.name}.lock"
    holder = subprocess.Popen([sys.executable, "-c", _HOLDER_WITH_WORKERS.format(out=str(out))],
                              env=_env(project), stdout=subprocess.PIPE, text=True)
    try:
        word, *pids = holder.stdout.readline().split()
        assert word == "workers" and len(pids) == 2
        for pid in pids:  # no worker has the lock file open
            fds = Path(f"/proc/{pid}/fd")
            assert all(os.path.realpath(fds / fd) != str(lock.resolve())
                       for fd in os.listdir(fds)), pid
    finally:
        holder.kill()
        holder.wait()
    deadline = 50
    while any(Path(f"/proc/{pid}").exists() and
              Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z" for pid in pids) \
            and deadline:
        subprocess.run(["sleep", "0.1"])
        deadline -= 1
    assert deadline, "the workers outlived their killed parent"
    r = _torlab(project, "run", project / "p.yaml", "-o", out, "--force")
    assert r.returncode == 0, r.stderr
    assert _leftovers(project) == []


@pytest.mark.slow
def test_two_runs_started_together(project):
    before = _first_run(project)
    out = project / "res" / "out"
    procs = [subprocess.Popen([sys.executable, "-m", "torlab", "run", str(project / "p.yaml"),
                               "-o", str(out), "--force"], env=_env(project),
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    codes = sorted(p.wait(timeout=300) for p in procs)
    errs = [p.stderr.read() for p in procs]
    assert codes in ([0, 0], [0, 2]), errs  # one after the other, or the second refused
    if codes == [0, 2]:
        assert any("another torlab run" in e for e in errs)
    assert _same_results(_complete(out), before)
    assert _leftovers(project) == []


def _read_only(project: Path) -> list[str] | None:
    """A command prefix that runs torlab with ``res`` read-only, or None if not possible here."""
    res = project / "res"
    if os.geteuid() != 0:
        res.chmod(0o555)
        return []
    if shutil.which("unshare") is None:
        return None
    probe = subprocess.run(["unshare", "-m", "true"], capture_output=True)
    if probe.returncode != 0:
        return None
    # root ignores permissions: a read-only bind mount in a private mount namespace
    return ["unshare", "-m", "sh", "-c",
            f"mount --bind {res} {res} && mount -o remount,bind,ro {res} && exec \"$@\"", "sh"]


@pytest.mark.slow  # real torlab processes; in one process: tests/test_trust.py
def test_read_only_output_place_is_exit_2_and_keeps_earlier_results(project):
    before = _first_run(project)
    out = project / "res" / "out"
    prefix = _read_only(project)
    if prefix is None:
        pytest.skip("cannot make a read-only place here")
    try:
        for target, force in ((out, ["--force"]), (project / "res" / "new", [])):
            r = subprocess.run([*prefix, sys.executable, "-m", "torlab", "run",
                                str(project / "p.yaml"), "-o", str(target), *force],
                               env=_env(project), capture_output=True, text=True, timeout=300)
            assert r.returncode == 2, r.stderr
            (line,) = r.stderr.strip().splitlines()
            assert line.startswith("error: ") and ("read-only" in line
                                                   or "permission denied" in line), line
    finally:
        (project / "res").chmod(0o755)
    assert _snapshot(out) == before
    assert _leftovers(project) == []


def _small_file_limit() -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes beyond the limit fail with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (30_000, 30_000))


@pytest.mark.slow  # a read-only place: above
def test_full_disk_is_exit_2_and_keeps_earlier_results(project):
    before = _first_run(project)
    out = project / "res" / "out"
    # results that differ from the earlier ones (a re-run whose results are byte-identical
    # keeps the earlier files and writes nothing large)
    (project / "p.yaml").write_text(SMALL.replace("points: 6", "points: 7"))
    r = subprocess.run([sys.executable, "-m", "torlab", "run", str(project / "p.yaml"), "-o",
                        str(out), "--force"], env=_env(project), capture_output=True, text=True,
                       timeout=300, preexec_fn=_small_file_limit)
    assert r.returncode == 2, r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert "cannot write the results: file too large" in line
    assert _results(_snapshot(out)) == _results(before)
    assert _leftovers(project) == []


@pytest.mark.slow  # more torlab processes
def test_staging_folders_without_a_pid_are_cleaned(project):
    """Staging folders named by mkdtemp alone (no pid) are removed too: they hold no results."""
    before = _first_run(project)
    out = project / "res" / "out"
    stale = project / "res" / ".out.staging-abc123"
    stale.mkdir()
    (stale / "half.csv").write_text("1,2\n")
    r = _torlab(project, "run", project / "p.yaml", "-o", out, "--force")
    assert r.returncode == 0, r.stderr
    assert _leftovers(project) == []
    assert _same_results(_complete(out), before)
