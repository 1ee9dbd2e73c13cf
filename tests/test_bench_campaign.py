"""``torlab bench --campaign``: the campaigns it builds, the growth fit and the table.

No test asserts a time; the runs themselves are measured by the benchmark.
"""

from __future__ import annotations

import math

import pytest

from torlab.bench import campaign as cb
from torlab.bench.campaign import (
    CampaignRun,
    campaign_sizes,
    campaign_table,
    growth,
    memory_line,
)


def test_campaign_sizes_are_powers_of_four_up_to_n():
    assert campaign_sizes(1) == [1]
    assert campaign_sizes(16) == [1, 4, 16]
    assert campaign_sizes(10) == [1, 4, 10]
    with pytest.raises(ValueError):
        campaign_sizes(0)


def _rows(a: float, b: float) -> list[CampaignRun]:
    return [CampaignRun(s, "cold", a * (104 * s) ** b, 2 * a * (104 * s) ** b, 100.0, 1.0,
                        {"logs": 104.0 * s, "sets": 12.0 * s, "curves": 6.0 * s,
                         "figures": 3.0 + 12 * s, "report_html_mb": 0.5, "output_files": 9.0},
                        {"figures": 0.1, "total": 1.0, "figures_cpu": 0.5})
            for s in (1, 4, 16)]


def test_growth_recovers_an_exact_power_law():
    a, b = growth(_rows(0.03, 1.25))
    assert b == pytest.approx(1.25, rel=1e-9)
    assert a == pytest.approx(0.03, rel=1e-9)
    assert math.isnan(growth(_rows(1.0, 1.0)[:1])[1])  # one size: no exponent


def _with_peaks(rows: list[CampaignRun], peaks: list[float]) -> list[CampaignRun]:
    import dataclasses

    return [dataclasses.replace(r, peak_rss_mb=p) for r, p in zip(rows, peaks, strict=True)]


def test_memory_line_recovers_a_baseline_and_a_cost_per_log():
    # 150 MB + 10 kB per log at 104, 416, 1664 logs (MiB and KiB, as ru_maxrss gives them):
    # exactly on the line
    rows = _with_peaks(_rows(1.0, 1.0), [150 + 10 / 1024 * n for n in (104, 416, 1664)])
    base, per_log, se = memory_line(rows)
    assert base == pytest.approx(150.0, rel=1e-12)
    assert per_log == pytest.approx(10.0, rel=1e-12)
    assert se == pytest.approx(0.0, abs=1e-9)
    # off the line by +1, -2, +1 MB: the slope's standard error by the textbook formula
    # s / sqrt(sum (x - mean x)^2), s^2 the residuals' sum of squares over n - 2 (in kB)
    x = [104.0, 416.0, 1664.0]
    y = [150 + 10 / 1024 * n + d for n, d in zip(x, (1.0, -2.0, 1.0), strict=True)]
    base, per_log, se = memory_line(_with_peaks(_rows(1.0, 1.0), y))
    mx, my = sum(x) / 3, sum(y) / 3
    sxx = sum((v - mx) ** 2 for v in x)
    b = sum((u - mx) * (v - my) for u, v in zip(x, y, strict=True)) / sxx
    a = my - b * mx
    s2 = sum((v - a - b * u) ** 2 for u, v in zip(x, y, strict=True)) / 1
    assert per_log == pytest.approx(1024 * b, rel=1e-10)
    assert base == pytest.approx(a, rel=1e-10)
    assert se == pytest.approx(1024 * math.sqrt(s2 / sxx), rel=1e-10)
    # two sizes: the line through both, no standard error; one size: nothing
    base, per_log, se = memory_line(rows[:2])
    assert per_log == pytest.approx(10.0, rel=1e-12) and math.isnan(se)
    assert all(math.isnan(v) for v in memory_line(rows[:1]))


def test_table_has_one_row_per_size_and_the_extrapolation():
    rows = _rows(0.03, 1.0)
    rows.append(CampaignRun(4, "warm", 0.5, 0.4, 120.0, 1.0, rows[1].counts, {}))
    text = campaign_table(rows)
    assert sum(line.startswith("| ") for line in text.splitlines()) == 4  # header, 3 sizes
    assert "| 4x | 416 / 48 / 24 / 51 |" in text
    assert "0.50 s (0.40 s)" in text
    # the figure stage's share of the wall time; the figures' CPU against the run's CPU
    # (4x: 2 * 0.03 * 416 = 24.96 s)
    assert "| 12.5 s (25.0 s) | 10% | 0.5 s, 2% |" in text
    # a = 0.03 s per log, exponent 1: 300 s at 10 000 logs
    assert "cold wall: grows as logs^1.00; at 10 000 logs about 300 s" in text
    # the peak memory (100 MB at every size): exponent 0, a line with no slope
    assert ("peak memory: grows as logs^0.00; as a line, 100 MB + 0.0 kB per log ± 0.0 kB "
            "(standard error over 3 sizes): at 10 000 logs about 100 MB, at 100 000 about "
            "100 MB (flat would be 0 kB per log)") in text


def test_built_campaign_is_a_valid_protocol_over_renamed_products(tmp_path, monkeypatch):
    import torlab.synth.hpt as synth
    from torlab.parsers.hpt import read_hpt
    from torlab.protocols.loader import load_protocol

    design = synth.paper_c_design
    monkeypatch.setattr(synth, "paper_c_design", lambda seed: design(seed)[:2])
    proto = cb.build_campaign(tmp_path / "c2", 2)
    lp = load_protocol(proto)
    files = lp.data_files("hpt")
    assert [f.name for f in files] == sorted(f.name for f in files)
    assert len(files) == 4 and {f.name[:7] for f in files} == {"hpt_s01", "hpt_s02"}
    _, meta = read_hpt(files[-1])
    assert meta.product.endswith("-s02") and meta.product in lp.protocol.products
    # built once: the marker makes a second call reuse the folder
    stamp = files[0].stat().st_mtime_ns
    assert cb.build_campaign(tmp_path / "c2", 2) == proto
    assert files[0].stat().st_mtime_ns == stamp


@pytest.mark.slow
def test_every_figure_of_a_two_seed_campaign_passes_the_figure_checks(tmp_path):
    """A campaign's figures differ from a sample protocol's in what only scale brings:
    products renamed per seed (longer file names in the fit figures' titles), products of
    other densities in one panel of the amount figures (masses close together on the
    log axis).  Every figure of a two-seed campaign passes :func:`figure_problems`; the
    checks found a fit title running off the figure and tick labels printed over each
    other here."""
    from figure_checks import figure_problems
    from figure_gallery import capture

    from torlab.protocols.runner import run_protocol

    proto = cb.build_campaign(tmp_path / "c2", 2)
    with capture() as seen:
        run_protocol(proto, tmp_path / "out", command="test")
    kinds = {p.name for _, p in seen}
    assert {"torlab.reports.fit:result_figure", "torlab.reports.amount:amount_figure",
            "torlab.reports.traction:traction_report_figure"} <= kinds
    bad = {}
    for name, p in seen:
        problems = figure_problems(p.draw())
        if problems:
            bad[name] = problems[:2]
    assert bad == {}


def test_campaign_bench_passes_fit_figures_to_its_runs(tmp_path, cli, monkeypatch):
    """``torlab bench --campaign N --fit-figures warned`` runs ``torlab run --fit-figures
    warned`` and says so in the table's heading; another value is refused before any run."""
    seen = []

    def fake(n, **kw):
        seen.append(kw.get("extra_args"))
        return _rows(0.03, 1.0)

    monkeypatch.setattr(cb, "run_campaigns", fake)
    r = cli("bench", "--campaign", "16", "--fit-figures", "warned", "-o", tmp_path / "b", "-q")
    assert r.exit_code == 0, r.output
    assert seen == [("--fit-figures", "warned")]
    assert (tmp_path / "b" / "campaign.md").read_text().startswith(
        "# torlab bench --campaign 16 --jobs 2 --fit-figures warned\n")
    r = cli("bench", "--campaign", "16", "--fit-figures", "few", "-o", tmp_path / "c", "-q")
    assert r.exit_code == 2 and "--fit-figures: 'few'" in r.output
    assert len(seen) == 1 and not (tmp_path / "c").exists()


def test_table_shows_the_run_with_one_log_added_and_its_memory_line():
    """The runs with one log added get their own column (wall, CPU, peak) and their own
    growth exponents and memory line: what a lab's rerun after a new log costs."""
    import dataclasses

    cold = _rows(0.03, 1.0)
    # one more log each; 120 MB + 20 kB per log (MiB and KiB)
    added = [dataclasses.replace(r, kind="added", wall_s=0.01 * (r.counts["logs"] + 1),
                                 cpu_s=0.02 * (r.counts["logs"] + 1),
                                 peak_rss_mb=120 + 20 / 1024 * (r.counts["logs"] + 1),
                                 counts=dict(r.counts, logs=r.counts["logs"] + 1))
             for r in cold]
    text = campaign_table(cold + added)
    assert sum(line.startswith("| ") for line in text.splitlines()) == 4  # header, 3 sizes
    # 4x: 417 logs: 4.17 s wall, 8.34 s CPU, 120 + 20 * 417 / 1024 = 128.1 MB
    assert "| 100 MB | 4.2 s (8.3 s), 128 MB |" in text
    assert "one log added, wall: grows as logs^1.00; at 10 000 logs about 100 s" in text
    assert ("peak memory, one log added: grows as logs^0.08; as a line, 120 MB + 20.0 kB "
            "per log ± 0.0 kB (standard error over 3 sizes): at 10 000 logs about 315 MB"
            ) in text
    assert "- peak memory: grows as logs^0.00; as a line, 100 MB + 0.0 kB per log" in text
    assert memory_line(cold + added, "added")[1] == pytest.approx(20.0, rel=1e-12)


def test_the_run_with_one_log_added_finds_it_and_leaves_the_campaign_as_built(
        tmp_path, monkeypatch):
    """The third run of a size sees one log more, a copy of the first, under
    :data:`ADDED_LOG`; the log is gone after it (a failed run too), and a leftover of a
    stopped benchmark is removed when the campaign is reused."""
    import torlab.synth.hpt as synth

    design = synth.paper_c_design
    monkeypatch.setattr(synth, "paper_c_design", lambda seed: design(seed)[:2])
    proto = cb.build_campaign(tmp_path / "c1", 1)
    data = proto.parent / "data"
    logs = sorted(p.name for p in data.glob("hpt_*.txt"))
    seen = []

    def fake_run(argv, cwd):
        seen.append(sorted(p.name for p in data.glob("hpt_*.txt")))
        if len(seen) == 3:
            assert (data / cb.ADDED_LOG).read_bytes() == (data / logs[0]).read_bytes()
        return 1.0, 1.0, 100.0

    monkeypatch.setattr(cb, "_run", fake_run)
    monkeypatch.setattr(cb, "_counts", lambda out: ({"logs": 2.0}, {}))
    rows = cb.run_campaigns(1, data_dir=tmp_path)
    assert [r.kind for r in rows] == ["cold", "warm", "added"]
    assert seen == [logs, logs, [*logs, cb.ADDED_LOG]]
    assert sorted(p.name for p in data.glob("hpt_*.txt")) == logs

    def failing(argv, cwd):
        raise RuntimeError("torlab run exited with 1")

    monkeypatch.setattr(cb, "_run", failing)
    with pytest.raises(RuntimeError):
        cb.run_campaigns(1, data_dir=tmp_path, warm_runs=0)
    (data / cb.ADDED_LOG).write_text("left by a stopped benchmark")
    cb.build_campaign(tmp_path / "c1", 1)
    assert sorted(p.name for p in data.glob("hpt_*.txt")) == logs
