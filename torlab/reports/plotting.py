"""Matplotlib set-up shared by every torlab figure (lazy import, Agg backend)."""

from __future__ import annotations

from typing import Any

__all__ = ["pyplot", "subplots"]

_STYLE = {
    "figure.figsize": (7.0, 4.5),
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "legend.frameon": False,
    "legend.fontsize": 8,
    "savefig.dpi": 150,
    "svg.hashsalt": "torlab",  # reproducible SVG ids
    "svg.fonttype": "none",
}


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend with torlab's style."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    plt.rcParams.update(_STYLE)
    plt.rcParams["path.simplify"] = True
    return plt


def subplots(*args: Any, **kw: Any) -> tuple[Any, Any]:
    """``plt.subplots`` with torlab's style and constrained layout."""
    plt = pyplot()
    kw.setdefault("layout", "constrained")
    return plt.subplots(*args, **kw)
