"""The bad-input corpus (tests/fuzz_corpus.py) through the CLI: no traceback, no exit 1, no
hang, no raw warning -- every case either works or ends in one clear line.

Every test runs twice: on a fixed sample of the corpus (every tenth case, the first of
every reader, every special file and named case; the commands that draw figures asked for
their tables only, --no-plot) in the quick suite, and on the whole corpus, figures
included, in the slow step CI runs (``-m slow``).  The counts of the whole-corpus run are what
docs/reliability.md reports; set ``TORLAB_FUZZ_REPORT`` to a file name to have them
written as JSON.
"""

from __future__ import annotations

import collections
import json
import os

import pytest
from fuzz_corpus import build_corpus, run_corpus

BAD = ("traceback", "bug", "hang", "leaked_warning")


#: the named cases of test_issue_cases, always in the sample
NAMED = ("scene:wheel_rail_tab54.yaml:no_L_mue_L_mup", "protocol:small.yaml:as_written",
         "protocol:small.yaml:product_../../x", "protocol:small.yaml:scene_alias_bomb")
#: the quick suite's sample: every STRIDE-th case (and the special and named ones)
STRIDE = 10


@pytest.fixture(scope="module", params=["sample", pytest.param("whole", marks=pytest.mark.slow)])
def corpus(request, tmp_path_factory):
    """``(which, outcomes)``: the sample or the whole corpus through the CLI."""
    from typer.testing import CliRunner

    cases = build_corpus()
    if request.param == "sample":
        firsts = {c.reader: k for k, c in reversed(list(enumerate(cases)))}  # one per reader
        cases = [c for k, c in enumerate(cases)
                 if k % STRIDE == 0 or c.special or c.name in NAMED or firsts[c.reader] == k]
    return request.param, run_corpus(cases, tmp_path_factory.mktemp("corpus"), CliRunner(),
                                     plots=request.param == "whole")


@pytest.fixture
def outcomes(corpus):
    return corpus[1]


def test_corpus_has_no_traceback_exit_1_hang_or_raw_warning(corpus):
    which, outcomes = corpus
    counts = collections.Counter(o.kind for o in outcomes)
    by_reader = collections.defaultdict(collections.Counter)
    for o in outcomes:
        by_reader[o.case.reader][o.kind] += 1
    report = os.environ.get("TORLAB_FUZZ_REPORT")
    if report and which == "whole":
        with open(report, "w", encoding="utf-8") as f:
            json.dump({"cases": len(outcomes), "outcomes": dict(counts),
                       "by_reader": {k: dict(v) for k, v in by_reader.items()},
                       "hidden_library_warnings": sum(o.hidden_warnings for o in outcomes)},
                      f, indent=2)
    bad = [f"{o.kind}: {o.case.name}: {o.detail}" for o in outcomes if o.kind in BAD]
    assert not bad, "\n".join(bad[:20])
    scale = 1 if which == "whole" else STRIDE  # the sample is a tenth of the corpus
    assert len(outcomes) >= 300 // scale
    assert counts["ok"] > 50 // scale and counts["input_error"] > 200 // scale  # both kinds


def test_corpus_covers_every_reader_scene_and_protocol(outcomes):
    readers = {o.case.reader for o in outcomes}
    assert readers >= {"hpt", "hpt_map", "pcs", "ehd2", "optical", "visc", "scene",
                       "scene_stribeck", "protocol", "fit_hpt", "fit_removal",
                       "predict_retention"}
    specials = {o.case.mutation for o in outcomes if o.case.special}
    assert specials == {"fifo", "folder", "device", "missing", "symlink_device"}


@pytest.mark.parametrize("name, kind", [
    ("scene:wheel_rail_tab54.yaml:no_L_mue_L_mup", "ok"),
    ("protocol:small.yaml:as_written", "ok"),
    ("protocol:small.yaml:product_../../x", "ok"),
    ("protocol:small.yaml:scene_alias_bomb", "input_error"),
])
def test_issue_cases(outcomes, name, kind):
    (o,) = [o for o in outcomes if o.case.name == name]
    assert o.kind == kind, o.detail


def test_every_error_names_its_file(outcomes):
    """One line naming the input (or the option) that is wrong."""
    unnamed = [o for o in outcomes if o.kind == "input_error"
               and "input" not in o.detail and "rig2" not in o.detail
               and "/dev/zero" not in o.detail and "does-not-exist" not in o.detail
               and "scene.yaml" not in o.detail and "hpt_OFM1" not in o.detail]
    assert not unnamed, [o.detail for o in unnamed[:5]]
