"""A protocol run keeps a large fit without its data: the data stay in the result cache.

An HPT layer pooled over many runs carries a data table of a few hundred kB; a campaign
of thousands of logs would hold every one of them until the figures are drawn.  The run
keeps the result without its data (:meth:`RunContext.keep_fit`), and the fit's figure
reads the whole result where it is drawn (:class:`torlab.fit.result.StoredFit`).
"""

from __future__ import annotations

import os

import pytest
from conftest import ROOT

from torlab.errors import TorlabInputError
from torlab.fit.result import FitResult, StoredFit

FILES = sorted((ROOT / "sample_data" / "hpt").glob("hpt_OFM1_4uL_25C*.txt"))


def _layer_fit(paths: list[str]) -> FitResult:  # module level: a task for the executor
    from torlab.fit.layer import fit_layer_hpt
    from torlab.parsers.hpt import read_hpt
    from torlab.reduce.hpt import reduce_hpt

    return fit_layer_hpt([reduce_hpt(*read_hpt(f)) for f in paths], joint=True)


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    """A layer fit computed through ``cached_map`` with ``keep=keep_fit`` (two local
    workers), the run's context, and the fit computed here."""
    from torlab.parallel import ProcessExecutor
    from torlab.progress import Progress
    from torlab.protocols.cache import ResultCache
    from torlab.protocols.context import RunContext

    assert len(FILES) >= 3
    folder = tmp_path_factory.mktemp("cache")
    tasks = [({"runs": [f.name for f in FILES[:k]]}, [str(f) for f in FILES[:k]])
             for k in (2, 3)]
    with ProcessExecutor(2) as ex:
        ctx = RunContext(lp=None, dest=None, cache=ResultCache(folder), prog=Progress(),
                         executor=ex)
        kept = ctx.cached_map("fit_hpt", _layer_fit, tasks,
                              keep=lambda i, v: ctx.keep_fit(v, "fit_hpt", tasks[i][0]))
    return ctx, kept, _layer_fit(tasks[1][1]), folder


def test_kept_without_data_and_read_back_whole(stored):
    """What the run keeps has every estimate and no data; the figure's argument reads the
    whole result back, equal to the fit computed here."""
    ctx, kept, here, _ = stored
    for res in kept:
        assert isinstance(res, FitResult) and res.data is None
        arg = ctx.fit_arg(res)
        assert isinstance(arg, StoredFit) and arg.light is res
    whole = ctx.fit_arg(kept[1]).whole()
    assert whole.params == here.params and whole.stderr == here.stderr
    assert whole.data.equals(here.data)
    assert kept[1].params == here.params and kept[1].meta == here.meta


def test_the_figure_of_a_stored_fit_is_the_figure_of_the_fit(stored):
    """Same PNG bytes from the stored fit (read where it is drawn) as from the whole
    result; the figure's content key names the entry and the estimates, not the entry
    file's place (another copy of the cache gives the same key), and differs between
    two fits."""
    from torlab.reports.fit import result_figure
    from torlab.reports.render import draw_task, plot, plot_digest

    ctx, kept, here, _ = stored
    arg = ctx.fit_arg(kept[1])
    assert draw_task((plot(result_figure, arg), ("png",), None)) == \
        draw_task((plot(result_figure, here), ("png",), None))
    moved = StoredFit.of(here, type(arg.ref)("/elsewhere/" + arg.entry, arg.entry, "fit_hpt",
                                             (0, 0, 0, 0)))
    assert plot_digest(plot(result_figure, moved)) == plot_digest(plot(result_figure, arg))
    other = plot_digest(plot(result_figure, ctx.fit_arg(kept[0])))
    assert other is not None and other != plot_digest(plot(result_figure, arg))


def test_a_stored_fit_changed_or_gone_is_a_clear_error(stored, tmp_path):
    """An entry changed since it was stored, gone, or holding another fit: one error that
    names it, not a figure of other data."""
    import shutil

    ctx, kept, _, folder = stored
    arg = ctx.fit_arg(kept[1])
    copy = tmp_path / "c"
    shutil.copytree(folder, copy)
    ref = type(arg.ref)(str(copy / arg.entry), arg.entry, "fit_hpt", arg.ref.status)
    with pytest.raises(TorlabInputError, match="cannot be read back"):
        StoredFit.of(kept[1], ref).whole()  # another file's status
    os.unlink(copy / arg.entry)
    with pytest.raises(TorlabInputError, match="cannot be read back"):
        StoredFit.of(kept[1], ref).whole()
    swapped = StoredFit.of(kept[1], ctx.fit_arg(kept[0]).ref)
    with pytest.raises(TorlabInputError, match="another result"):
        swapped.whole()
    with pytest.raises(TorlabInputError, match="cannot be read back"):
        StoredFit(arg.entry, arg.light).whole()  # made without a reference


def test_a_stored_fit_with_an_undetermined_estimate_reads_back(tmp_path):
    """An estimate that is NaN (undetermined) is the same estimate when read back."""
    import dataclasses

    from torlab.protocols.cache import ResultCache

    res = _layer_fit([str(f) for f in FILES[:2]])
    name = next(iter(res.params))
    res = dataclasses.replace(res, params={**res.params, name: float("nan")})
    c = ResultCache(tmp_path / "c")
    c.store("fit_hpt", res, runs=["x"])
    back = StoredFit.of(res, c.ref("fit_hpt", runs=["x"])).whole()
    assert back.params.keys() == res.params.keys() and back.data.equals(res.data)


def test_kept_from_the_cache_too_and_whole_without_one(stored, tmp_path):
    """A later run finds the fit in the cache and keeps it without its data as well; with
    no cache folder the whole result is kept."""
    from torlab.progress import Progress
    from torlab.protocols.cache import ResultCache
    from torlab.protocols.context import RunContext

    ctx, _, here, folder = stored
    ctx.cache.write_index()
    later = RunContext(lp=None, dest=None, cache=ResultCache(folder), prog=Progress())
    parts = {"runs": [f.name for f in FILES[:3]]}
    again = later.cached_map("fit_hpt", _layer_fit, [(parts, None)],
                             keep=lambda i, v: later.keep_fit(v, "fit_hpt", parts))
    assert again[0].data is None and later.fit_arg(again[0]).whole().params == here.params
    none = RunContext(lp=None, dest=None, cache=ResultCache(None), prog=Progress())
    assert none.keep_fit(here, "fit_hpt", parts) is here and none.fit_arg(here) is here


def test_a_recorded_fit_is_kept_packed_and_its_figure_is_the_same(stored, tmp_path):
    """Once recorded (``RunContext.add_fit``), a fit is kept as a PackedFit: its kind and
    warnings as they are, every other attribute the result's; its figure's argument has
    the content key and draws the bytes of the argument before packing; a fit without a
    stored entry gives the result itself; and what is kept takes under a third of the
    memory of the result it packs."""
    import gc
    import tracemalloc
    from types import SimpleNamespace

    from torlab.codec import digest_value
    from torlab.fit.result import PackedFit
    from torlab.progress import Progress
    from torlab.protocols.context import RunContext
    from torlab.reports.fit import result_figure
    from torlab.reports.render import draw_task, plot, plot_digest

    ctx, kept, here, _ = stored

    class Dest:  # add_fit writes fits/<name>.yaml
        def write_text(self, name: str, text: str) -> None:
            (tmp_path / name.replace("/", "_")).write_text(text)

    lp = SimpleNamespace(protocol=SimpleNamespace(reports=SimpleNamespace(compare=None)))
    run = RunContext(lp=lp, dest=Dest(), cache=ctx.cache, prog=Progress())
    light = kept[1]
    run.stored_fits[id(light)] = ctx.stored_fits[id(light)]
    before = ctx.fit_arg(light)
    run.add_fit("hpt:OFM1", light, light.to_scene_dict())
    run.add_fit("hpt:here", here, here.to_scene_dict())
    (_, packed), (_, whole) = run.fit_results
    assert isinstance(packed, PackedFit) and isinstance(whole, PackedFit)
    assert not run.stored_fits  # the reference travels with the packed fit
    assert packed.kind == light.kind and packed.warnings == light.warnings
    assert packed.params == light.params and packed.meta == light.meta
    assert digest_value(packed.restored()) == digest_value(light)
    arg = run.fit_arg(packed)
    assert arg.entry == before.entry
    assert plot_digest(plot(result_figure, arg)) == plot_digest(plot(result_figure, before))
    assert draw_task((plot(result_figure, arg), ("png",), None)) == \
        draw_task((plot(result_figure, before), ("png",), None))
    mine = run.fit_arg(whole)  # no entry: the result itself, with its data (kept as it is)
    assert not isinstance(mine, PackedFit) and mine.data is here.data
    assert digest_value(mine) == digest_value(here)

    def traced(make):
        gc.collect()
        tracemalloc.start()
        try:
            made = [make() for _ in range(20)]
            return tracemalloc.get_traced_memory()[0] / len(made)
        finally:
            tracemalloc.stop()

    assert traced(lambda: PackedFit(light)) < traced(packed.restored) / 3
