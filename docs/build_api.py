"""Build torlab's API reference (HTML, from the docstrings) with one command.

    python docs/build_api.py [OUTPUT_FOLDER]     # default: docs/_build/api

It uses pdoc (``pip install 'torlab[docs]'``; the test extra includes it) with
numpydoc docstrings, and fails (exit 1) on any warning: the test suite builds
it the same way (``tests/test_api.py``).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

#: the modules of the reference: the public API first, then what it returns and reads
MODULES = [
    "torlab",
    "torlab.api",
    "torlab.instruments",
    "torlab.instruments.plugin",
    "torlab.instruments.reduction",
    "torlab.instruments.output",
    "torlab.instruments.measured",
    "torlab.fit.result",
    "torlab.fit.viscosity",
    "torlab.parallel",
    "torlab.scene",
    "torlab.errors",
]


def build(out: str | Path) -> list[str]:
    """Write the reference into ``out``; returns the warnings raised while building."""
    import pdoc
    import pdoc.render

    pdoc.render.configure(docformat="numpy", show_source=False,
                          footer_text="torlab API reference")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pdoc.pdoc(*MODULES, output_directory=Path(out))
    return [f"{w.category.__name__}: {w.message}" for w in caught]


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path(__file__).resolve().parent / "_build" / "api"
    problems = build(out)
    for p in problems:
        print(p, file=sys.stderr)
    print(f"API reference: {out / 'index.html'} ({len(problems)} warnings)")
    return 1 if problems else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
