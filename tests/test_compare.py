"""Is A better than B: differences, probabilities, rankings, and their calibration.

References: Welch's t test (scipy.stats.ttest_ind_from_stats), closed-form rankings, and
seeded virtual campaigns whose true differences are known.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from torlab.comparison import Estimate, Item, compare, ranking
from torlab.errors import TorlabInputError


def test_difference_is_welch_and_the_probability_its_one_sided_p_value():
    from scipy.stats import ttest_ind_from_stats

    a = Item("A", {"q": Estimate(0.215, 0.004, 5)})
    b = Item("B", {"q": Estimate(0.203, 0.003, 9)})
    r = compare([a, b], reference="B")
    (c,) = r.comparisons
    assert c.kind == "difference" and c.estimate == pytest.approx(0.012)
    # Welch with standard errors: std = se sqrt(n), n = dof + 1
    t = ttest_ind_from_stats(0.215, 0.004 * math.sqrt(6), 6, 0.203, 0.003 * math.sqrt(10), 10,
                             equal_var=False)
    assert c.dof == pytest.approx((0.004 ** 2 + 0.003 ** 2) ** 2
                                  / (0.004 ** 4 / 5 + 0.003 ** 4 / 9))
    assert 1 - c.p_a_higher == pytest.approx(t.pvalue / 2, rel=1e-9)
    from scipy.stats import t as student

    half = student.ppf(0.975, c.dof) * 0.005
    assert (c.low, c.high) == pytest.approx((0.012 - half, 0.012 + half))
    assert c.verdict.startswith("A higher") and c.p_better is None


def test_ratio_of_positive_quantities_and_a_stated_direction():
    a = Item("A", {"mu_c2": Estimate(0.24, 0.02, 3, log=True, runs=4)})
    b = Item("B", {"mu_c2": Estimate(0.20, 0.02, 3, log=True, runs=4)})
    (c,) = compare([a, b], reference="B", better={"mu_c2": "lower"}).comparisons
    assert c.kind == "ratio" and c.estimate == pytest.approx(1.2)
    assert math.log(c.high) - math.log(1.2) == pytest.approx(math.log(1.2) - math.log(c.low))
    assert c.p_better == pytest.approx(1 - c.p_a_higher)
    assert c.verdict == "B better"  # A is higher, and lower is better


def test_one_run_calls_say_so_and_too_few_items_are_refused():
    a = Item("A", {"q": Estimate(1.0, 0.01)})
    b = Item("B", {"q": Estimate(1.1, 0.01)})
    r = compare([a, b])
    assert r.comparisons[0].verdict.endswith("(one run: record noise only)")
    assert any("record alone" in n for n in r.notes)
    with pytest.raises(TorlabInputError, match="two or more"):
        compare([a, Item("A", {"q": Estimate(1.0, 0.01)})])  # one label: repeats, one item
    with pytest.raises(TorlabInputError, match="share"):
        compare([a, Item("C", {"other": Estimate(1.0, 0.01)})])


def test_items_of_one_label_are_pooled_as_repeats():
    runs = [Item("A", {"q": Estimate(v, 0.001, 20)}) for v in (0.20, 0.21, 0.22)]
    r = compare([*runs, Item("B", {"q": Estimate(0.3, 0.001, 20)})])
    a = r.items[0].estimates["q"]
    assert a.runs == 3 and a.dof == 2 and a.value == pytest.approx(0.21)
    assert a.se == pytest.approx(0.01 / math.sqrt(3), rel=0.02)  # the runs' scatter


def test_ranking_probabilities():
    far = [Item(x, {"q": Estimate(v, 0.001, 50)}) for x, v in (("a", 1.0), ("b", 2.0),
                                                                 ("c", 3.0))]
    r = ranking(far, "q")
    assert [x["label"] for x in r] == ["c", "b", "a"] and r[0]["p_best"] == 1.0
    assert [x["label"] for x in ranking(far, "q", "lower")] == ["a", "b", "c"]
    tie = [Item(x, {"q": Estimate(1.0, 0.1, 1e6)}) for x in "ab"]
    assert ranking(tie, "q", draws=40000)[0]["p_best"] == pytest.approx(0.5, abs=0.01)


def test_compare_command_on_fit_folders(tmp_path, cli):
    """Two HPT fits of different products: one row per layer parameter, the files, the
    figure; the same product twice (unlabelled) is one item and refused."""
    from torlab.fit.result import FitResult

    names = ("mu_c1", "mu_c2", "L_mue", "L_mup")
    for prod, mu in (("P1", 0.20), ("P2", 0.24)):
        f = FitResult.from_covariance(
            "layer_hpt", names, np.array([0.6 * mu, mu, 8e-6, 19e-6]),
            np.diag([(0.01 * 0.6 * mu) ** 2, (0.01 * mu) ** 2, 1e-13, 1e-12]), dof=30,
            log_scale=names, residual_norm=1.0, n_points=400, warnings=[], data=None,
            meta={"product": prod})
        (tmp_path / prod).mkdir()
        f.to_params(tmp_path / prod / "params.yaml")
    r = cli("compare", tmp_path / "P1", tmp_path / "P2", "-o", tmp_path / "out",
            "--better", "mu_c2=higher")
    assert r.exit_code == 0, r.output
    out = tmp_path / "out"
    for n in ("compare.csv", "values.csv", "summary.json", "compare.png"):
        assert (out / n).is_file()
    s = json.loads((out / "summary.json").read_text())
    rows = {c["quantity"]: c for c in s["comparisons"]}
    assert set(rows) == set(names)
    assert rows["mu_c2"]["a"] == "P2" and rows["mu_c2"]["verdict"].startswith("P2 better")
    assert "P(P2 better" in r.output
    r = cli("compare", tmp_path / "P1", tmp_path / "P1", "-o", tmp_path / "o2")
    assert r.exit_code == 2 and "label them" in r.output
    r = cli("compare", f"A={tmp_path / 'P1'}", f"B={tmp_path / 'P1'}", "-o", tmp_path / "o3",
            "--better", "mu_c2=up")
    assert r.exit_code == 2 and "--better" in r.output


def test_compare_reads_time_tests_from_raw_exports_and_reduced_tables(tmp_path, cli):
    """MTM time tests compared directly: a PCS export and the *_timed.csv that 'torlab mtm
    reduce' writes of it give the same figures and intervals (one reading, through the
    registry); 'torlab compare' on two raw exports states the differences of the four
    figures, and the generating differences (sample_data/mtm/truth.yaml, the noise-free
    curves' figures) lie inside their intervals; a file that is no time test is refused."""
    import pandas as pd

    import torlab
    from tests.conftest import ROOT
    from torlab.yamlio import load_yaml

    mtm = ROOT / "sample_data" / "mtm"
    r = cli("mtm", "reduce", mtm / "mtm_base_5uL.txt", "-o", tmp_path / "red")
    assert r.exit_code == 0, r.output
    opts = {"replicates": 60, "duration": "20 min"}
    (raw,) = torlab.time_test_items(mtm / "mtm_base_5uL.txt", "base", **opts)
    (red,) = torlab.time_test_items(tmp_path / "red" / "mtm_base_5uL_timed.csv", "base", **opts)
    assert set(raw.estimates) == {"minimum", "recovery_time_s", "mean_after_recovery",
                                  "time_below_threshold_s"}
    for q, e in raw.estimates.items():
        assert (e.value, e.se) == (red.estimates[q].value, red.estimates[q].se), q
    r = cli("compare", f"base={mtm / 'mtm_base_5uL.txt'}",
            f"Al2O3={mtm / 'mtm_base-Al2O3_5uL.txt'}", "-o", tmp_path / "out",
            "--time-test", "replicates=60", "--time-test", "duration=20 min")
    assert r.exit_code == 0, r.output
    rows = pd.read_csv(tmp_path / "out" / "compare.csv").set_index("quantity")
    truth = {run["file"]: run["truth"] for run in load_yaml(mtm / "truth.yaml").data["runs"]}
    a, b = truth["mtm_base-Al2O3_5uL.txt"], truth["mtm_base_5uL.txt"]
    for q, key in (("minimum", "minimum"), ("recovery_time_s", "recovery_time_s"),
                   ("time_below_threshold_s", "time_below_threshold_s")):
        d = a[key] - b[key]
        assert rows.loc[q, "ci95_low"] <= d <= rows.loc[q, "ci95_high"], (q, d)
    r = cli("compare", f"x={mtm / 'mtm_base_5uL.txt'}", f"y={mtm / 'README.md'}", "-o",
            tmp_path / "o2")
    assert r.exit_code == 2 and "README.md" in r.output


def test_protocol_compare_section_needs_known_items(tmp_path):
    from torlab.protocols.schema import Reports

    rep = Reports.model_validate({"compare": {"items": ["a", "b"], "pairs": "all"}})
    assert len(rep.compare) == 1 and rep.compare[0].pairs == "all"
    with pytest.raises(Exception, match="pairs"):
        Reports.model_validate({"compare": [{"pairs": "some"}]})


def _campaign(seed: int, n_comp: int = 4, n_rep: int = 3):
    """Virtual time tests: composition i has a true mean after recovery mu_i (spread over
    0.15-0.19), each test is offset by a test-to-test scatter of 1-3 % of the level, each
    record has a 20 s fluctuation and white noise (read with the batch-means interval)."""
    from test_time_test_repeats import _record

    from torlab.reduce.time_test_uncertainty import hac_mean

    rng = np.random.default_rng(seed)
    mu = 0.15 + 0.04 * rng.uniform(size=n_comp)
    s = (0.01, 0.02, 0.03)[seed % 3]
    items = []
    for i in range(n_comp):
        for _ in range(n_rep):
            m, se, dof = hac_mean(_record(rng, mu[i] * (1 + s * rng.standard_normal())))
            items.append(Item(f"c{i}", {"mean_after_recovery": Estimate(m, se, dof)}))
    return items, mu


@pytest.mark.slow  # 300 virtual campaigns of 12 records each (about 10 s)
def test_compare_covers_true_differences_and_its_probabilities_are_calibrated():
    """Over 300 seeded campaigns of four compositions (three tests each, 1-3 % test-to-test
    scatter), every pair compared: the true difference lies inside the 95 % interval in at
    least 90 % of the comparisons, and of the calls made at P >= 0.9 at least 90 % are
    right (docs/uncertainty.md gives the measured table)."""
    hit = calls = right = 0
    n = 0
    bins = np.zeros((5, 2))
    edges = (0.5, 0.7, 0.9, 0.95, 0.99, 1.0001)
    for seed in range(300):
        items, mu = _campaign(seed)
        r = compare(items, pairs="all", better={"mean_after_recovery": "higher"})
        for c in r.comparisons:
            d = mu[int(c.a[1:])] - mu[int(c.b[1:])]
            n += 1
            hit += c.low <= d <= c.high
            p = max(c.p_better, 1 - c.p_better)
            ok = (c.p_better >= 0.5) == (d > 0)
            k = np.searchsorted(edges, p, side="right") - 1
            bins[k] += (1, ok)
            if p >= 0.9:
                calls += 1
                right += ok
    print("coverage", hit / n, "calls", calls, "right", right / calls,
          "by probability", [(edges[i], int(b[0]), round(b[1] / max(b[0], 1), 3))
                             for i, b in enumerate(bins)])
    assert n >= 1800 and hit / n >= 0.90
    assert calls >= 200 and right / calls >= 0.90
