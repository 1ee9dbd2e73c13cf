"""Shared test fixtures and helpers."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data"
REAL_PCS = ROOT.parent / "shared" / "real-data" / "pcs"


def pytest_configure(config):
    """Keep the cache's HMAC key (torlab.protocols.cache) out of the tester's home folder;
    commands run their tasks in their own process (pytest-xdist already uses every core;
    tests/test_parallel.py runs the executors themselves)."""
    import os
    import tempfile

    os.environ.setdefault("TORLAB_CONFIG_DIR", tempfile.mkdtemp(prefix="torlab-test-config-"))
    os.environ.setdefault("TORLAB_JOBS", "1")


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
def shipped_run(tmp_path_factory):
    """Run a shipped protocol (``protocols/<name>.yaml``) once per session: ``(out, RunResult)``.

    The protocol regression tests and the thesis validation table read the same runs.
    """
    from torlab.protocols.runner import run_protocol

    runs: dict[str, tuple[Path, object]] = {}

    def get(name: str):
        if name not in runs:
            out = tmp_path_factory.mktemp(name) / "out"
            runs[name] = (out, run_protocol(ROOT / "protocols" / f"{name}.yaml", out,
                                            command=f"test {name}"))
        return runs[name]

    return get
