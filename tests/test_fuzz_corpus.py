"""The bad-input corpus (tests/fuzz_corpus.py) through the CLI: no traceback, no exit 1, no
hang, no raw warning -- every case either works or ends in one clear line.

Every test runs twice: on a fixed sample of the corpus (every twentieth case -- every
sixtieth of the commands added later, mostly fits --, the first of every reader, every
special file and named case; the commands that draw figures asked for their tables only,
--no-plot; without the cases that are whole runs of valid input, which the quick suite's
tests of those commands run) in the quick suite, and on the whole corpus, figures
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

BAD = ("traceback", "bug", "hang", "leaked_warning", "wrote_outside")


#: the named cases of test_issue_cases; in the sample too, but for the two whole protocol
#: runs (1.5 s each), which the quick suite runs as tests/test_trust.py's small protocol and
#: test_product_name_cannot_escape_the_output_folder
NAMED = ("scene:wheel_rail_tab54.yaml:no_L_mue_L_mup", "protocol:small.yaml:as_written",
         "protocol:small.yaml:product_../../x", "protocol:small.yaml:scene_alias_bomb")
NAMED_WHOLE_ONLY = ("protocol:small.yaml:as_written", "protocol:small.yaml:product_../../x")
#: the quick suite's sample: every STRIDE-th case (and the special and named ones); of the
#: commands added later (mostly fits, slower per case) every NEW_STRIDE-th
STRIDE = 20
NEW_STRIDE = 60

#: the commands added to the corpus with the creep-force and retention work; each has its
#: valid input as its first case and fuzzed option values
NEW_COMMANDS = ("fit_traction", "fit_film", "fit_visc", "fit_temperature", "fit_polach",
                "predict_table", "predict_creep", "predict_sweep", "reduce_as")
#: of these, the commands whose valid input is a whole fit or table (up to a second each): it
#: runs in the whole corpus; in the quick suite the command's own CLI tests run it (and the
#: sample holds its mutations)
VALID_WHOLE_ONLY = ("fit_traction", "fit_film", "fit_temperature", "fit_polach",
                    "predict_table", "predict_sweep")


@pytest.fixture(scope="module", params=["sample", pytest.param("whole", marks=pytest.mark.slow)])
def corpus(request, tmp_path_factory):
    """``(which, outcomes)``: the sample or the whole corpus through the CLI."""
    from typer.testing import CliRunner

    cases = build_corpus()
    if request.param == "sample":
        cases = [c for c in cases if c.name not in NAMED_WHOLE_ONLY
                 and not (c.reader in VALID_WHOLE_ONLY and c.mutation == "as_written")]
        firsts = {c.reader: k for k, c in reversed(list(enumerate(cases)))}  # one per reader
        cases = [c for k, c in enumerate(cases)
                 if k % (STRIDE if c.reader not in NEW_COMMANDS else NEW_STRIDE) == 0
                 or c.special or c.name in NAMED or (c.expect and not c.slow)
                 or firsts[c.reader] == k]
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
    scale = 1 if which == "whole" else STRIDE  # the sample: a twentieth and the firsts
    assert len(outcomes) >= 300 // scale
    assert counts["ok"] > 50 // scale and counts["input_error"] > 200 // scale  # both kinds


def test_corpus_covers_every_reader_scene_and_protocol(outcomes):
    readers = {o.case.reader for o in outcomes}
    assert readers >= {"hpt", "hpt_map", "pcs", "ehd2", "optical", "visc", "trios", "scene",
                       "scene_stribeck", "protocol", "fit_hpt", "fit_removal",
                       "predict_retention", *NEW_COMMANDS}
    specials = {o.case.mutation for o in outcomes if o.case.special}
    assert specials == {"fifo", "folder", "device", "missing", "symlink_device"}


def test_every_command_accepts_its_valid_input(corpus):
    """The as-written input of each command works: the errors of its mutations are about
    the mutation, not a command that always fails."""
    which, outcomes = corpus
    valid = {o.case.reader: o for o in outcomes if o.case.mutation == "as_written"
             and o.case.reader in NEW_COMMANDS}
    assert set(valid) == set(NEW_COMMANDS) - (set() if which == "whole" else
                                              set(VALID_WHOLE_ONLY))
    bad = {r: o.detail for r, o in valid.items() if o.kind != "ok"}
    assert not bad, bad


def test_option_values_are_fuzzed_on_every_range_checked_option(corpus):
    from fuzz_corpus import OPTIONS

    which, outcomes = corpus
    if which != "whole":
        pytest.skip("the whole corpus only (the sample holds a few of the option cases)")
    seen = {(o.case.reader, o.case.args[0]) for o in outcomes if o.case.source == "option"}
    assert seen == {(c, opt) for c, opts in OPTIONS.items() for opt in opts}


@pytest.mark.parametrize("name, kind", [
    ("scene:wheel_rail_tab54.yaml:no_L_mue_L_mup", "ok"),
    ("protocol:small.yaml:as_written", "ok"),
    ("protocol:small.yaml:product_../../x", "ok"),
    ("protocol:small.yaml:scene_alias_bomb", "input_error"),
])
def test_issue_cases(corpus, name, kind):
    which, outcomes = corpus
    if which == "sample" and name in NAMED_WHOLE_ONLY:
        pytest.skip("a whole protocol run: the whole corpus only (the slow step)")
    (o,) = [o for o in outcomes if o.case.name == name]
    assert o.kind == kind, o.detail


def test_reported_cases_have_their_expected_outcome(outcomes):
    """Each reported problem (``fuzz_corpus.reported_cases``) ends as it must: the right
    numbers (exit 0) or the error line that names it."""
    cases = [o for o in outcomes if o.case.expect]
    assert cases
    wrong = [f"{o.case.name}: {o.kind} {o.detail!r}" for o in cases
             if o.kind != o.case.expect or o.case.expect_in not in o.detail
             or (o.case.expect_not_in and o.case.expect_not_in in o.detail)]
    assert not wrong, "\n".join(wrong)


def test_every_error_names_its_file(outcomes):
    """One line naming the input (or the option) that is wrong."""
    def names(o) -> bool:
        if o.case.args:  # a fuzzed option: its name, as the CLI or the library spells it
            opt = o.case.args[0]
            if opt in o.detail or f"{opt.lstrip('-').replace('-', '_')}:" in o.detail \
                    or (opt == "--sweep" and "sweep:" in o.detail):
                return True
        return any(w in o.detail for w in ("input", "rig2", "/dev/zero", "does-not-exist",
                                           "scene.yaml", "hpt_OFM1", "removal.yaml",
                                           "comp.csv", "/out: "))  # the output folder

    unnamed = [o for o in outcomes if o.kind == "input_error" and not names(o)]
    assert not unnamed, [f"{o.case.name}: {o.detail}" for o in unnamed[:8]]
