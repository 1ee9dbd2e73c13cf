"""``torlab compare``: is product A better than product B? Differences with their evidence."""

from pathlib import Path
from typing import Annotated, Any

import typer

from torlab.cli._common import (
    ForceOpt,
    FormatsOpt,
    OutOpt,
    XlsxOpt,
    command_line,
    console,
    print_table,
)


def register(root: typer.Typer) -> None:
    """Add the ``compare`` command to the root app."""
    root.command("compare")(compare_cmd)


def _items(args: list[str]) -> tuple[dict[str, list[Path]], list[Path], list[Path]]:
    """``[LABEL=]PATH`` arguments: labelled paths (a label given twice: repeats), unlabelled
    paths, and every input path (to keep the output apart from them)."""
    from torlab.errors import TorlabInputError

    labelled: dict[str, list[Path]] = {}
    plain: list[Path] = []
    for a in args:
        lab, sep, rest = a.partition("=")
        if sep and lab.strip() and not Path(a).exists():
            p = Path(rest.strip())
            if not p.exists():
                raise TorlabInputError("no such file or folder", path=p)
            labelled.setdefault(lab.strip(), []).append(p)
        else:
            p = Path(a)
            if not p.exists():
                raise TorlabInputError("no such file or folder", path=p)
            plain.append(p)
    inputs = [p for ps in labelled.values() for p in ps] + plain
    return labelled, plain, inputs


def _better(items: list[str]) -> dict[str, str]:
    from torlab.errors import TorlabInputError

    out = {}
    for it in items:
        q, sep, d = it.partition("=")
        if not sep or d.strip() not in ("higher", "lower"):
            raise TorlabInputError(f"{it!r}: write QUANTITY=higher or QUANTITY=lower, e.g. "
                                   "'mu_c2=higher'", key="--better")
        out[q.strip()] = d.strip()
    return out


def _time_test_options(items: list[str]) -> dict[str, Any]:
    """``--time-test KEY=VALUE`` options: the time-test options of 'torlab mtm reduce'
    (units allowed), ``replicates`` (a whole number) and ``band`` (``LOW:HIGH``)."""
    from torlab.errors import TorlabInputError

    out: dict[str, Any] = {}
    for it in items:
        k, sep, v = (x.strip() for x in it.partition("="))
        if not sep or not k or not v:
            raise TorlabInputError(f"{it!r}: write KEY=VALUE, e.g. 'duration=20 min'",
                                   key="--time-test")
        try:
            if k == "replicates":
                out[k] = int(v)
            elif k == "band":
                lo, hi = (float(x) for x in v.split(":"))
                out[k] = (lo, hi)
            else:
                out[k] = v
        except ValueError:
            raise TorlabInputError(f"{it!r}: replicates is a whole number, band LOW:HIGH "
                                   "(e.g. 0.15:0.25)", key="--time-test") from None
    return out


def compare_cmd(
    items: Annotated[list[str], typer.Argument(
        help="What to compare, each [LABEL=]PATH: a parameter file (params.yaml), a results "
        "folder of 'torlab fit', 'torlab predict retention' or 'torlab run', or an MTM time "
        "test (a PCS export or the *_timed.csv of 'torlab mtm reduce'). A label given to "
        "several paths makes them repeats of one item (pooled with their scatter); without "
        "a label an item is named by its product, folder or file.")],
    out: OutOpt,
    reference: Annotated[str | None, typer.Option(help="The item the others are compared "
                                                  "against (default the first).")] = None,
    all_pairs: Annotated[bool, typer.Option("--all-pairs", help="Compare every pair instead "
                                            "of every item against the reference.")] = False,
    quantity: Annotated[list[str] | None, typer.Option(
        "--quantity", help="Compare only this quantity (repeatable; default every shared "
        "one): mu_c1, mu_c2, L_mue, L_mup, mu_c1_T, mu_c2_T, crossing_amount, "
        "mean_after_recovery, effective_friction, retentivity ...")] = None,
    better: Annotated[list[str] | None, typer.Option(
        "--better", help="Which direction is better: 'mu_c2=higher' (repeatable); P(A "
        "better) and the verdict are then stated for it.")] = None,
    probability: Annotated[float, typer.Option(min=0.5, max=0.999, help="Probability a "
                                               "verdict needs.")] = 0.9,
    time_test: Annotated[list[str] | None, typer.Option(
        "--time-test", help="An option of the time tests read here, KEY=VALUE (repeatable): "
        "those of 'torlab mtm reduce' ('duration=20 min', 'threshold=0.15', 'tail=120 s' "
        "...), 'replicates=200' (block bootstrap) and 'band=0.15:0.25'.")] = None,
    force: ForceOpt = False,
    xlsx: XlsxOpt = False,
    formats: FormatsOpt = None,
) -> None:
    """Compare two or more products, compositions or conditions on every quantity they
    share: the difference (the ratio for positive quantities) with its 95 % interval, the
    probability that A is higher (and, for a stated direction, better), a verdict at
    --probability, and with more than two items a ranking with probabilities.

    Writes compare.csv (one row per comparison), values.csv (each item's values and
    intervals, what they hold), ranking.csv (more than two items), compare.png (the
    differences with their intervals and the line of no difference) and summary.json.

    An MTM time test is read through the instrument registry (a PCS export's time tests
    after application, or a *_timed.csv): its minimum, time to recover, mean after
    recovery and time below the threshold, each with the interval of its record
    (docs/uncertainty.md says what one record resolves); tests under one label are
    repeats, pooled with the scatter between them.
    """
    from torlab.api import compare
    from torlab.outputs import OutputDir
    from torlab.reports.compare import verdict_text, write_compare

    labelled, plain, inputs = _items(items)
    things: list[Any] = [(lab, p) for lab, ps in labelled.items() for p in ps] + plain
    res = compare(things, reference=reference, quantities=quantity or None,
                  better=_better(better or []), pairs="all" if all_pairs else "reference",
                  probability=probability, time_tests=_time_test_options(time_test or []))
    dest = OutputDir(out, force=force, inputs=inputs, command=command_line())
    with dest:
        names = write_compare(dest, res, title="", formats=formats, xlsx=xlsx)
    rows = [{"item": it.label, "runs": max((e.runs for e in it.estimates.values()), default=1),
             "quantities": ", ".join(it.estimates)} for it in res.items]
    print_table(rows, title="Items")
    c = console()
    for r in res.table().to_dict("records"):
        c.print(verdict_text(r))
    for q, rk in res.rankings.items():
        c.print(f"ranking on {q}: " + "; ".join(
            f"{r['label']} P(rank 1) {r['p_best']:.2f}" for r in rk))
    for n in res.notes:
        c.print(f"[yellow]note:[/yellow] {n}")
    c.print(f"wrote {', '.join(names)} to {out}")
