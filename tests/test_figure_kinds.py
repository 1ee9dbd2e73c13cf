"""Every figure kind torlab draws is drawn and passes the figure checks.

The kinds are read from torlab's source (``tests/figure_gallery.py``: every ``plot(func,
...)`` declaration names a drawing function), so a new kind is found as soon as it is
declared; the gallery makes each from the sample data as the commands and protocols do,
and ``tests/figure_checks.py`` checks every one: text inside the canvas and clear of the
other text and the data, legends without repeats, one unit per axis, symbols in titles,
visible error bars and bands.  The quick suite checks a sample of the kinds
(``tests/test_figures.py``); here, every figure of every sample protocol and command,
each also drawn on matplotlib's own canvas to the same pixels (``tests/test_textcache.py``).
"""

from __future__ import annotations

import importlib

import pytest
from figure_gallery import (
    REAL_PCS,
    data_file_names,
    declared_kinds,
    draw_checked,
    gallery,
    kind_name,
)

#: kinds drawn only from a long series of traction sweeps, which only the real ETM export has
REAL_ONLY = {"torlab.reports.mtm:traction_map_figure",
             "torlab.reports.mtm:traction_evolution_figure"}


def test_declared_kinds_are_module_functions():
    """Every declared figure names a module-level function that exists (figures are drawn
    in worker processes, by name)."""
    kinds = declared_kinds()
    assert len(kinds) >= 20
    for kind in kinds:
        module, name = kind.split(":")
        func = getattr(importlib.import_module(module), name)
        assert kind_name(func) == kind


@pytest.mark.slow  # the four sample protocols (warm re-runs of their session runs), every
# instrument's reduction and the figure-drawing commands: about 70 figures drawn
def test_every_figure_kind_is_drawn_and_publishable(tmp_path, shipped_run, monkeypatch):
    earlier = {name: shipped_run(name)[0] for name in ("paper_a", "paper_b", "paper_c",
                                                        "retention")}
    plots = gallery(tmp_path, earlier=earlier)
    drawn = {kind_name(p.func) for p in plots.values()}
    missing = set(declared_kinds()) - drawn
    if not (REAL_PCS / "ETM_slim_mapper.txt").is_file():
        missing -= REAL_ONLY
    assert not missing, f"declared but not in tests/figure_gallery.py: {sorted(missing)}"
    names = data_file_names()
    problems = []
    for name, p in plots.items():
        _, found = draw_checked(p, names)
        problems += [f"{name}: {x}" for x in found]
    assert not problems, "\n".join(problems)
    # the same pixels with torlab's remembering canvas (torlab.reports.textcache; its
    # tables filled by the figures drawn above) as with matplotlib's own Agg canvas
    import torlab.reports.textcache as tc
    from torlab.reports.render import render_all

    assert tc.available()
    ours = {name: render_all(p.draw(), ("png",))["png"] for name, p in plots.items()}
    monkeypatch.setattr(tc, "_CLASSES", [None])
    differ = [name for name, p in plots.items()
              if render_all(p.draw(), ("png",))["png"] != ours[name]]
    assert not differ, f"pixels differ from matplotlib's canvas: {differ}"
