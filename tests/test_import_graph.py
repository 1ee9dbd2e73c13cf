"""The package's import graph: no cycle, and the layers point one way.

The graph is read from the source (every ``import`` and ``from ... import`` of every
module, at module level and inside functions), so it holds for imports a test run
never executes.  :data:`LAYERS` declares the floors of the house (DEVELOPERS.md draws
them): a module imports modules of its own floor or of floors below, never above, and
no two modules import each other, through any chain, even inside functions.  The few
arrows that run back up on purpose are :data:`UPWARD`, each with the reason.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from conftest import ROOT

PKG = ROOT / "torlab"


def _modules() -> dict[str, Path]:
    mods = {}
    for p in PKG.rglob("*.py"):
        parts = list(p.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join(parts)] = p
    return mods


MODULES = _modules()


def _resolve(name: str) -> str | None:
    """The torlab module ``name`` refers to (a name inside a module: that module)."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _runtime_nodes(tree: ast.AST) -> list[ast.AST]:
    """Every node but those under ``if TYPE_CHECKING:`` (names for type hints only: no
    module is loaded for them)."""
    out: list[ast.AST] = []
    todo = [tree]
    while todo:
        n = todo.pop()
        out.append(n)
        for c in ast.iter_child_nodes(n):
            if isinstance(c, ast.If) and "TYPE_CHECKING" in ast.unparse(c.test):
                todo.extend(c.orelse)
                continue
            todo.append(c)
    return out


def _imports(module: str, top_level_only: bool) -> set[str]:
    path = MODULES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    nodes = [n for n in tree.body if not (isinstance(n, ast.If) and "TYPE_CHECKING" in
                                          ast.unparse(n.test))] \
        if top_level_only else _runtime_nodes(tree)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out: set[str] = set()
    for n in nodes:
        if isinstance(n, ast.Import):
            names = [a.name for a in n.names]
        elif isinstance(n, ast.ImportFrom):
            base = n.module or ""
            if n.level:
                up = package.split(".")[: len(package.split(".")) - (n.level - 1)]
                base = ".".join([*up, *([n.module] if n.module else [])])
            names = [f"{base}.{a.name}" for a in n.names] + [base]
        else:
            continue
        for nm in names:
            r = _resolve(nm)
            if r is not None and r != module and r.startswith("torlab"):
                out.add(r)
    return out


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


#: the floors, lowest first: a module belongs to the floor of the longest prefix that names it
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    # errors, the lazy package face (its public names load torlab.api through importlib on
    # first use, which is no import statement), the value codec, small helpers
    ("base", ("torlab", "torlab.errors", "torlab._stats", "torlab._suggest", "torlab.progress",
              "torlab.threads", "torlab.codec", "torlab._unit_table")),
    # the layer laws' registry: each law's parameters, units, ranges and stress formulas,
    # which the scene contract validates its boundary: section against and the comparisons
    # name their quantities by (numpy and the errors only)
    ("laws", ("torlab.model.layers",)),
    # units at the edges, safe files and result folders, the executor, YAML, uncertainty
    ("io", ("torlab.units", "torlab.files", "torlab.parallel", "torlab.grids", "torlab.yamlio",
            "torlab.outputs", "torlab.uncertainty", "torlab.random_effects",
            "torlab.comparison")),
    ("inputs", ("torlab.scene", "torlab.parsers")),        # the scene contract, raw files
    ("model", ("torlab.model",)),                          # the physics
    ("reduce", ("torlab.reduce",)),                        # raw channels -> quantities
    ("fit", ("torlab.fit",)),                              # quantities -> parameters
    ("reports", ("torlab.reports",)),                      # results -> figures, tables
    ("instruments", ("torlab.instruments",)),              # one plug-in per file format
    ("campaigns", ("torlab.synth", "torlab.protocols")),   # virtual experiments, protocols
    ("facade", ("torlab.api", "torlab.bench")),            # the public API, benchmarks
    ("cli", ("torlab.cli", "torlab.__main__")),            # commands over the API
]

#: arrows that run back up on purpose: (importer, imported) -> why
UPWARD: dict[tuple[str, str], str] = {
    ("torlab.fit.result", "torlab.reports.fit"):
        "FitResult.plot(): a result draws itself in a notebook (as lmfit's results do); the "
        "drawing is the report layer's, imported only when asked",
}


def _layer(module: str) -> int:
    best = (-1, -1)
    for i, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            # the package face "torlab" is itself only, not every module under it
            inside = module.startswith(p + ".") and p != "torlab"
            if (module == p or inside) and len(p) > best[1]:
                best = (i, len(p))
    assert best[0] >= 0, f"{module} is on no floor: add it to LAYERS"
    return best[0]


def test_the_graph_is_read():
    # the reader sees what is there: the CLI's root module imports its commands lazily,
    # the public API the library, the protocol runner its stages; a name imported for a
    # type hint only (under TYPE_CHECKING) is no import
    assert "torlab.model.fastsim" in _imports("torlab.model.creep", True)
    assert "torlab.instruments" in _imports("torlab.api", False)
    assert "torlab.scene" not in _imports("torlab.model.predict", False)
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycle_at_import_time():
    graph = {m: _imports(m, top_level_only=True) for m in MODULES}
    assert _cycles(graph) == []


def test_no_import_cycle_at_all():
    """Not even through imports inside functions: no two modules need each other."""
    graph = {m: _imports(m, top_level_only=False) for m in MODULES}
    assert _cycles(graph) == []


def _upward(graph: dict[str, set[str]]) -> list[str]:
    """The arrows of ``graph`` that run to a higher floor and are not in :data:`UPWARD`."""
    up = []
    for m in sorted(graph):
        for dep in sorted(graph[m]):
            if _layer(dep) > _layer(m) and (m, dep) not in UPWARD:
                up.append(f"{m} ({LAYERS[_layer(m)][0]}) -> {dep} ({LAYERS[_layer(dep)][0]})")
    return up


def test_every_module_is_on_a_floor_and_the_floors_point_down():
    assert _upward({m: _imports(m, top_level_only=False) for m in MODULES}) == []
    assert len(UPWARD) <= 2
    for (m, dep), why in UPWARD.items():  # each exception still exists and says why
        assert dep in _imports(m, top_level_only=False) and why


def test_the_floor_check_sees_an_upward_import():
    # a model module drawing a report, a parser reading through the registry: both found;
    # an import on the same floor or downward is not
    assert _upward({"torlab.model.fastsim": {"torlab.reports.render", "torlab.model.hertz"},
                    "torlab.parsers.pcs": {"torlab.instruments", "torlab.files"}}) == [
        "torlab.model.fastsim (model) -> torlab.reports.render (reports)",
        "torlab.parsers.pcs (inputs) -> torlab.instruments (instruments)"]
    assert _layer("torlab") < _layer("torlab.api")   # the package face is the ground floor
    assert _layer("torlab.cli.fit") == len(LAYERS) - 1
    with pytest.raises(AssertionError, match="on no floor"):  # a new module must be placed
        _layer("torlab.new_module")


def _room(module: str) -> str:
    """The room of a module: a top-level module, or the first-level package it is in."""
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 2 or (PKG / parts[-1]).is_dir() else module


def test_no_private_name_crosses_rooms():
    """What two rooms share is public in one of them: no module takes a ``_name`` from a
    module of another room (inside a room, a package's modules may share helpers)."""
    crossing = []
    for m, path in sorted(MODULES.items()):
        for n in _runtime_nodes(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(n, ast.ImportFrom) and n.module and not n.level
                    and n.module.startswith("torlab")):
                continue
            src = _resolve(n.module)
            for a in n.names:
                if a.name.startswith("_") and not a.name.startswith("__") and src and \
                        _room(src) != _room(m):
                    crossing.append(f"{m} <- {n.module}.{a.name}")
    assert crossing == []
    assert _room("torlab.model.exact.rolling") == _room("torlab.model.fastsim") != \
        _room("torlab.bench.exact")


def test_the_library_does_not_import_the_cli_or_the_facade():
    """Library modules import neither ``torlab.cli`` nor the public API module
    (``torlab.api`` sits on top of the library; the CLI on top of both)."""
    bad = []
    for m in MODULES:
        if m.startswith("torlab.cli") or m in ("torlab", "torlab.api", "torlab.__main__"):
            continue
        for dep in _imports(m, top_level_only=False):
            if dep.startswith("torlab.cli") or dep == "torlab.api":
                bad.append(f"{m} -> {dep}")
    assert bad == []


def test_the_cli_is_thin_and_the_runner_small():
    """Every function of torlab/cli/ fits on a screen (80 lines: a command parses its
    options and calls the library); the protocol runner sequences in 300 lines."""
    long = []
    for m, path in MODULES.items():
        if not m.startswith("torlab.cli"):
            continue
        for n in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and \
                    n.end_lineno - n.lineno + 1 > 80:
                long.append(f"{m}.{n.name}: {n.end_lineno - n.lineno + 1} lines")
    assert long == []
    runner = PKG / "protocols" / "runner.py"
    assert len(runner.read_text(encoding="utf-8").splitlines()) <= 300
