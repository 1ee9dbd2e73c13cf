"""Shared test fixtures and helpers."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data"
REAL_PCS = ROOT.parent / "shared" / "real-data" / "pcs"

#: the smallest protocol: the sample HPT logs and the amount report (tests of runs, re-runs
#: and trust)
SMALL_PROTOCOL = """\
version: 1
name: small
data:
  hpt:
    files: [hpt_*.txt]
reports:
  amount:
    curve: interpolation
"""


def pytest_configure(config):
    """Keep the cache's HMAC key (torlab.protocols.cache) out of the tester's home folder;
    commands run their tasks in their own process (pytest-xdist already uses every core;
    tests/test_parallel.py runs the executors themselves)."""
    import os
    import tempfile

    os.environ.setdefault("TORLAB_CONFIG_DIR", tempfile.mkdtemp(prefix="torlab-test-config-"))
    os.environ.setdefault("TORLAB_JOBS", "1")
    _build_each_cli_once()


def _build_each_cli_once() -> None:
    """typer's ``CliRunner.invoke`` builds the click command tree from the typer app on every
    call: for torlab's ~50 commands that is about 40 ms of reading type hints, which the
    suite's ~500 invocations would pay again and again.  A ``torlab`` process builds it
    once; so does the suite (the tree holds no state between invocations)."""
    import typer.testing

    build = typer.testing._get_command  # fails loudly if typer renames it
    built: dict[object, object] = {}  # typer app -> its click command

    def get_command(app):
        if app not in built:
            built[app] = build(app)
        return built[app]

    typer.testing._get_command = get_command


#: pytest-xdist (``--dist loadscope``) sends a test module's tests to one worker; these modules
#: go with another one, because they read its session fixture (``shipped_run``'s Paper B run:
#: one worker makes it instead of the other waiting for its lock)
SCOPE_WITH = {"tests/test_validation.py": "tests/test_protocols.py"}
#: the modules whose tests take longest together, in the quick suite (module fixtures: the fuzz
#: sample, protocol runs, fits) or in the slow step (the whole fuzz corpus, coverage sweeps,
#: every figure kind drawn: 71 s in one test):
#: they start first, so that neither worker is left with one of them at the end while the
#: other is idle; the others follow in their usual order
LONG_FIRST = ("tests/test_fuzz_corpus.py", "tests/test_fit_coverage.py",
              "tests/test_figure_kinds.py", "tests/test_removal_fit.py",
              "tests/test_retention_cli.py", "tests/test_trust.py", "tests/test_protocols.py", "tests/test_validation.py", "tests/test_bands.py",
              "tests/test_polach_uncertainty.py", "tests/test_faults.py", "tests/test_parallel.py",
              "tests/test_fit_batch.py", "tests/test_fit_other.py", "tests/test_scheduling.py")


def pytest_collection_modifyitems(config, items):
    """The long modules first (:data:`LONG_FIRST`); the order within a module is kept."""
    rank = {m: k for k, m in enumerate(LONG_FIRST)}
    items.sort(key=lambda it: rank.get(it.nodeid.split("::", 1)[0], len(rank)))


def pytest_xdist_make_scheduler(config, log):
    """``--dist loadscope`` with the modules of :data:`SCOPE_WITH` joined to theirs."""
    if config.getvalue("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class JoinedScopes(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            scope = super()._split_scope(nodeid)
            return SCOPE_WITH.get(scope.split("::", 1)[0], scope)

    return JoinedScopes(config, log)


@pytest.fixture
def runner():
    from typer.testing import CliRunner

    return CliRunner()


@pytest.fixture
def cli(runner):
    """Invoke the torlab CLI; returns the click Result."""
    from torlab.cli import app

    def invoke(*args: str):
        return runner.invoke(app, [str(a) for a in args])

    return invoke


def sha(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def error_lines(result) -> list[str]:
    """Non-empty stderr lines of a CLI result."""
    err = getattr(result, "stderr", None)
    if err is None:
        err = result.output
    return [ln for ln in err.splitlines() if ln.strip()]


def real_pcs_file(name: str) -> Path:
    p = REAL_PCS / name
    if not p.exists():
        pytest.skip(f"real PCS data not available ({p})")
    return p


@pytest.fixture(scope="session")
def shipped_run(tmp_path_factory, request):
    """Run a shipped protocol (``protocols/<name>.yaml``) once per session: ``(out, RunResult)``.

    The protocol regression tests and the thesis validation table read the same runs.  Under
    pytest-xdist the test modules sit on different workers: the first worker to ask runs the
    protocol (under a file lock) and leaves a copy of its results folder; another worker
    copies that folder and reruns the protocol into it with ``force`` -- torlab's own cache
    (authenticated by the session's key) makes that rerun warm, and its result is the same.
    """
    import shutil

    from torlab.protocols.runner import run_protocol

    try:
        import fcntl
    except ImportError:  # no POSIX locks: every worker runs its own
        fcntl = None
    worker = getattr(request.config, "workerinput", None)
    shared = (tmp_path_factory.getbasetemp().parent / "shipped-runs"
              if worker is not None and fcntl is not None else None)
    runs: dict[str, tuple[Path, object]] = {}

    def run(name: str, out: Path, force: bool = False):
        return run_protocol(ROOT / "protocols" / f"{name}.yaml", out, force=force,
                            command=f"test {name}")

    def get(name: str):
        if name in runs:
            return runs[name]
        out = tmp_path_factory.mktemp(name) / "out"
        if shared is None:
            runs[name] = (out, run(name, out))
            return runs[name]
        shared.mkdir(exist_ok=True)
        done = shared / name
        with open(shared / f"{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if (done / "summary.json").is_file():
                shutil.copytree(done, out)
                runs[name] = (out, run(name, out, force=True))
            else:
                runs[name] = (out, run(name, out))
                shutil.copytree(out, shared / f".{name}.partial")
                (shared / f".{name}.partial").rename(done)
        return runs[name]

    return get
