"""Every figure kind torlab draws, made from the sample data as torlab's commands make them.

* :func:`declared_kinds` reads torlab's source for the figures it declares: every call
  ``plot(func, ...)`` of :mod:`torlab.reports.render` names a drawing function -- a figure
  kind.  A new kind is found here as soon as it is declared.
* :func:`capture` records the figures a command or protocol run declares (the
  :class:`~torlab.reports.render.Plot` objects handed to
  :func:`~torlab.reports.render.render_figures`) without drawing them.
* :func:`gallery` runs the sample protocols, the reductions of every instrument's sample
  files and the fit and predict commands that draw figures of their own, and returns
  every figure they declared, by name.

``python tests/figure_gallery.py OUT`` draws them all into ``OUT`` (one PNG each) and
prints what :func:`figure_checks.figure_problems` finds in each.
"""

from __future__ import annotations

import ast
import contextlib
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_data"
DATA = Path(__file__).resolve().parent / "data"
REAL_PCS = ROOT.parent / "shared" / "real-data" / "pcs"
SCENES = ROOT / "protocols" / "scenes"


def kind_name(func: Any) -> str:
    """``module:function`` of a drawing function."""
    return f"{func.__module__}:{func.__qualname__}"


def declared_kinds() -> dict[str, list[str]]:
    """Every drawing function torlab declares a figure with: ``{"module:function": [where,
    ...]}``, from the calls ``plot(func, ...)`` in torlab's source (``func`` resolved through
    the module's imports)."""
    out: dict[str, list[str]] = {}
    for path in sorted((ROOT / "torlab").rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        module = ".".join(rel.parts).removesuffix(".__init__")
        tree = ast.parse(path.read_text(encoding="utf-8"))
        defined = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("plot", "Plot") and node.args):
                continue
            if module == "torlab.reports.render":
                continue  # the declaration itself
            name = node.args[0]
            if not isinstance(name, ast.Name):
                raise AssertionError(f"{rel}:{node.lineno}: plot() of {ast.unparse(name)}; "
                                     "declare a figure with a module-level function's name")
            target = _resolve(tree, name.id, module, defined)
            out.setdefault(target, []).append(f"{rel}:{node.lineno}")
    return out


def _resolve(tree: ast.Module, name: str, module: str, defined: set[str]) -> str:
    """The ``module:function`` a name in ``module`` stands for (its own function, or an
    import anywhere in the module, inside functions too)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            for a in node.names:
                if (a.asname or a.name) == name:
                    return f"{node.module}:{a.name}"
    if name in defined:
        return f"{module}:{name}"
    raise AssertionError(f"{module}: cannot tell which function {name!r} is")


@contextlib.contextmanager
def capture() -> Iterator[list[tuple[str, Any]]]:
    """Record every declared figure ``(name, Plot)`` handed to ``render_figures`` inside the
    block; nothing is drawn (the files written are empty)."""
    from torlab.reports import render

    seen: list[tuple[str, Any]] = []
    orig, orig_start = render.render_figures, render.FiguresAhead.start

    def spy(items: Any, formats: Any = render.DEFAULT_FORMATS, **_: Any) -> Any:
        got = {}
        for name, p in items:
            if isinstance(p, render.Plot):
                # a fit kept in the run's cache (StoredFit) read now: the cache is moved
                # into the output folder when the run ends, and these plots outlive it
                seen.append((name, render.Plot(p.func, tuple(
                    a.whole() if hasattr(a, "whole") else a for a in p.args), p.kwargs)))
            got[name] = {f: b"" for f in formats}
        return got, render.RenderStats()

    render.render_figures = spy
    render.FiguresAhead.start = lambda self, items: 0
    try:
        yield seen
    finally:
        render.render_figures = orig
        render.FiguresAhead.start = orig_start


def _cli(*args: Any) -> None:
    from typer.testing import CliRunner

    from torlab.cli import app

    r = CliRunner().invoke(app, [str(a) for a in args])
    if r.exit_code != 0:
        raise AssertionError(f"torlab {' '.join(map(str, args))}: {r.output}\n{r.exception!r}")


def protocol_plots(name: str, out: Path, earlier: Path | None = None) -> list[tuple[str, Any]]:
    """The figures of a sample protocol's run into ``out`` (a warm re-run of a copy of
    ``earlier``, an earlier run's folder, when given)."""
    from torlab.protocols.runner import run_protocol

    force = False
    if earlier is not None and (earlier / "summary.json").is_file():
        shutil.copytree(earlier, out)
        force = True
    with capture() as seen:
        run_protocol(ROOT / "protocols" / f"{name}.yaml", out, force=force, command="gallery")
    return [(f"{name}/{n}", p) for n, p in seen]


def command_plots(tmp: Path, runs: dict[str, Path] | None = None) -> list[tuple[str, Any]]:
    """The figures of the reductions of every instrument's sample files and of the fit and
    predict commands that draw their own (the overlays of several parameter sets from the
    protocol runs' parameter files, ``runs``: protocol name -> its results folder)."""
    out: list[tuple[str, Any]] = []
    groups = {
        "hpt": sorted(SAMPLE.glob("hpt_paper_b/hpt_*.txt")),
        "mtm": [SAMPLE / "mtm" / "mtm_TOR-A_5uL.txt"],
        "pcs": sorted((DATA / "pcs").glob("*.txt")),
        "optical": sorted((SAMPLE / "optical").glob("*.csv")),
        "visc": [SAMPLE / "visc" / "visc_ester_25C.txt"],
        "trios": [DATA / "trios" / "hand.txt"],
        "etm": [REAL_PCS / "ETM_slim_mapper.txt"],
    }
    opts = {"visc": ("--reference", SAMPLE / "visc" / "visc_reference_25C.txt")}
    for key, files in groups.items():
        files = [f for f in files if f.is_file()]
        if not files:
            continue
        cmd = ("visc", "reduce") if key == "visc" else ("reduce",)
        with capture() as seen:
            _cli(*cmd, *files, *opts.get(key, ()), "-o", tmp / f"reduce_{key}")
        out += [(f"reduce {key}/{n}", p) for n, p in seen]
    tab54 = SCENES / "wheel_rail_tab54.yaml"
    rough = SCENES / "optical_paper_a_rough.yaml"
    ehd2 = DATA / "pcs" / "ehd2_quirks.txt"
    commands: dict[str, tuple[Any, ...]] = {
        "predict traction": ("predict", "traction", tab54, "--creepage", "0:0.05:21"),
        "predict stribeck": ("predict", "stribeck", rough, "--speed", "0.01:2:12",
                             "--creepage", "5 %"),
        "fit film": ("fit", "film", ehd2),
        "fit polach": ("fit", "polach", tab54, "--creepage", "0:0.05:6", "--speed",
                       "5 m/s,20 m/s"),
    }
    runs = runs or {}
    if "paper_c" in runs:
        fits = runs["paper_c"] / "fits"
        commands["predict traction overlay"] = (
            "predict", "traction", tab54, f"OFM1={fits / 'hpt_OFM1.yaml'}",
            f"OFM2={fits / 'hpt_OFM2.yaml'}", "--creepage", "0:0.05:11")
    if "paper_a" in runs:
        dry = runs["paper_a"] / "fits" / "traction_dry.yaml"
        alt = tmp / "softer_layer.yaml"
        alt.parent.mkdir(parents=True, exist_ok=True)
        alt.write_text("boundary:\n  mu_c1: 0.15\n  mu_c2: 0.2\n", encoding="utf-8")
        commands["predict stribeck overlay"] = (
            "predict", "stribeck", rough, f"fitted={dry}", f"softer={alt}", "--speed",
            "0.01:2:8", "--creepage", "5 %")
    if "retention" in runs:
        rem = runs["retention"] / "fits" / "removal_OFM1.yaml"
        faster = tmp / "faster_removal.yaml"
        faster.parent.mkdir(parents=True, exist_ok=True)
        text = rem.read_text(encoding="utf-8")
        faster.write_text(text, encoding="utf-8")
        commands["predict retention overlay"] = (
            "predict", "retention", tab54, f"fitted={rem}", f"copy={faster}", "--amount",
            "100000 mg/m^2")
    for key, args in commands.items():
        with capture() as seen:
            _cli(*args, "-o", tmp / key.replace(" ", "_"))
        out += [(f"{key}/{n}", p) for n, p in seen]
    return out


def measured_stribeck_plots(tmp: Path) -> list[tuple[str, Any]]:
    """A Stribeck report of measured points only (no scene)."""
    f = SAMPLE / "optical" / "stribeck_smooth.csv"
    proto = tmp / "stribeck_measured.yaml"
    tmp.mkdir(parents=True, exist_ok=True)
    proto.write_text(f"""version: 1
name: stribeck_measured
data:
  optical:
    files: [{f}]
reports:
  stribeck:
    speed: {{from: 0.01 m/s, to: 3 m/s, points: 10, spacing: log}}
    curves:
      - label: smooth ball
        measured: {f}
""", encoding="utf-8")
    from torlab.protocols.runner import run_protocol

    with capture() as seen:
        run_protocol(proto, tmp / "out", command="gallery")
    return [(f"stribeck measured/{n}", p) for n, p in seen]


def bench_plots() -> list[tuple[str, Any]]:
    """``torlab bench``'s time-against-error figure of a component with a few variants."""
    from torlab.bench import BenchRow
    from torlab.bench.runner import time_error_figure
    from torlab.reports.render import plot

    rows = [BenchRow("fastsim", f"grid {n}x{n}", 1e-4 * n * n / 100, 0.4 / n,
                     reference="the 640x640 grid", default=n == 40, unit_of_work="curve")
            for n in (10, 20, 40, 80)]
    rows.append(BenchRow("fastsim", "exact", 3e-2, 0.0, reference="the 640x640 grid",
                         unit_of_work="curve"))
    return [("bench/fastsim", plot(time_error_figure, "fastsim", rows))]


def crowded(plots: dict[str, Any], copies: int = 16) -> list[tuple[str, Any]]:
    """A large campaign's figures made from the sample's: Paper C's traction curves and
    amount series, each product copied ``copies`` times under its own name (the 16×
    campaign of docs/performance.md has 96 traction curves)."""
    import dataclasses

    from torlab.reports.render import plot

    out = []
    trac = plots.get("paper_c/traction/traction")
    if trac is not None:
        curves, cfg = trac.args
        def scaled(t: Any, f: float) -> Any:
            cols = [c for c in ("mu", "mu_low95", "mu_high95") if c in t]
            return t.assign(**{c: t[c] * f for c in cols})

        many = [dataclasses.replace(c, label=f"{c.label}, copy {k + 1}",
                                    group=f"{c.group or c.label}, copy {k + 1}",
                                    table=scaled(c.table, 1 + 0.01 * k))
                for k in range(copies) for c in curves]
        out.append((f"crowded/traction_{len(many)}", plot(trac.func, many, cfg)))
    amount = plots.get("paper_c/amount/amount_applied")
    if amount is not None:
        import pandas as pd

        series, fits, cfg = amount.args
        k_series, k_fits = [], []
        for k in range(4):
            k_series.append(series.assign(product=series["product"] + f"-{k + 1}"))
            k_fits += [dataclasses.replace(cf, product=f"{cf.product}-{k + 1}") for cf in fits]
        out.append(("crowded/amount_20", plot(amount.func, pd.concat(k_series, ignore_index=True),
                                              k_fits, cfg, **amount.kwargs)))
    return out


def gallery(tmp: Path, *, earlier: dict[str, Path] | None = None,
            protocols: tuple[str, ...] = ("paper_a", "paper_b", "paper_c", "retention")
            ) -> dict[str, Any]:
    """Every figure the sample protocols and commands declare, and the crowded figures of a
    large campaign: ``{name: Plot}``."""
    earlier = earlier or {}
    plots: list[tuple[str, Any]] = []
    for name in protocols:
        plots += protocol_plots(name, tmp / name, earlier.get(name))
    plots += command_plots(tmp / "commands", {n: tmp / n for n in protocols})
    plots += measured_stribeck_plots(tmp / "stribeck_measured")
    plots += bench_plots()
    got = dict(plots)
    got.update(crowded(got))
    return got


def draw_checked(p: Any, file_names: tuple[str, ...] = ()) -> tuple[Any, list[str]]:
    """Draw a declared figure as torlab does (laid out) and check it."""
    from figure_checks import figure_problems

    fig = p.draw()
    return fig, figure_problems(fig, file_names=file_names)


def data_file_names() -> tuple[str, ...]:
    """The sample files' names (text from the data, which the title checks leave alone)."""
    names = [p.name for d in (SAMPLE, DATA) for p in d.rglob("*") if p.is_file()]
    if REAL_PCS.is_dir():
        names += [p.name for p in REAL_PCS.iterdir()]
    return tuple(sorted(set(names), key=len, reverse=True))


def main(out: str) -> int:  # pragma: no cover - a developer's tool
    import os
    import tempfile

    from torlab.reports.render import render

    os.environ.setdefault("TORLAB_JOBS", "1")
    dest = Path(out)
    dest.mkdir(parents=True, exist_ok=True)
    names = data_file_names()
    import pickle

    cached = dest / "plots.pickle"
    if cached.is_file():
        plots = pickle.loads(cached.read_bytes())
    else:
        with tempfile.TemporaryDirectory() as tmp:
            plots = gallery(Path(tmp))
        cached.write_bytes(pickle.dumps(plots))
    declared = declared_kinds()
    drawn = {kind_name(p.func) for p in plots.values()}
    for k in sorted(set(declared) - drawn):
        print(f"NOT DRAWN: {k} (declared at {', '.join(declared[k])})")
    bad = 0
    for name, p in plots.items():
        fig, problems = draw_checked(p, names)
        fn = dest / (name.replace("/", "__").replace(" ", "_") + ".png")
        fn.write_bytes(render(fig, "png"))
        for x in problems:
            print(f"{name}: {x}")
        bad += bool(problems)
    print(f"{len(plots)} figures, {len(drawn)} kinds, {bad} with problems")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    raise SystemExit(main(sys.argv[1]))
