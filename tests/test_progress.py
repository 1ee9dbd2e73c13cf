"""Progress bars: shown on a terminal, silent with --quiet or when piped; the executor's
tasks advance them; the final line of a protocol run splits its time honestly."""

from __future__ import annotations

import io
import re

import pytest

from torlab.progress import Progress, current, enabled_for


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_enabled_only_on_a_terminal_and_not_quiet():
    assert enabled_for(stream=_Tty()) is True
    assert enabled_for(quiet=True, stream=_Tty()) is False
    assert enabled_for(stream=io.StringIO()) is False

    class Closed:
        def isatty(self):
            raise ValueError("I/O operation on closed file")

    assert enabled_for(stream=Closed()) is False


def test_bars_advance_through_the_executor_and_go_when_done(monkeypatch):
    from rich.console import Console

    from torlab.parallel import SerialExecutor

    shown = Console(file=_Tty(), force_terminal=True, width=100)
    monkeypatch.setattr("rich.progress.get_console", lambda: shown, raising=False)
    with Progress(enabled=True) as p:
        assert current() is p
        out = SerialExecutor().map(abs, [-1, -2, -3], description="three tasks")
        seen = [t.description for t in p._p.tasks]
        assert list(p.track(range(4), "four items")) == [0, 1, 2, 3]
        with p.task("a bar", 5) as advance:
            advance(5)
            (task,) = [t for t in p._p.tasks if t.description == "a bar"]
            assert task.completed == 5 and task.total == 5
        assert p._p.tasks == []  # transient: every bar removed when its work ended
    assert out == [1, 2, 3]
    assert seen == []  # the map's bar was removed once the map returned
    assert current() is not p  # outside the block: the silent one again


def test_disabled_progress_yields_everything_and_draws_nothing(capsys):
    with Progress(enabled=False) as p:
        assert list(p.track("abc", "letters")) == ["a", "b", "c"]
        with p.task("x", 3) as advance:
            advance()
        with p.pause():
            pass
    assert capsys.readouterr().out == ""


@pytest.mark.parametrize("quiet", [False, True])
def test_protocol_run_output_has_no_bar_when_piped_and_splits_its_time(cli, tmp_path, quiet):
    import shutil

    from tests.conftest import ROOT
    from tests.test_protocols import SMALL  # the amount section of five sample HPT logs

    for f in sorted((ROOT / "sample_data/hpt").glob("hpt_OFM1_*uL_25C.txt")):
        shutil.copy(f, tmp_path / f.name)
    proto = tmp_path / "small.yaml"
    proto.write_text(SMALL)
    r = cli("run", proto, "-o", tmp_path / "out", *(["--quiet"] if quiet else []))
    assert r.exit_code == 0, r.output
    # piped: no bar redrawn in place (carriage returns, cursor controls), no "3/5 0:00:01"
    assert "\r" not in r.output and "\x1b[" not in r.output
    assert not re.search(r"\d+/\d+ +\d:\d\d:\d\d", r.output)
    line = next(ln for ln in r.output.splitlines() if "compute" in ln)
    parts = {k: float(v) for k, v in re.findall(r"(compute|figures|I/O) ([0-9.]+) s", line)}
    total = float(re.search(r"; ([0-9.]+) s =", line).group(1))
    assert set(parts) == {"compute", "figures", "I/O"}
    assert sum(parts.values()) <= total + 0.15  # the parts never add up to more than the whole
