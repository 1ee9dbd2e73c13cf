"""What a protocol run carries from stage to stage (:class:`RunContext`).

The runner (:mod:`torlab.protocols.runner`) only sequences; the stages
(:mod:`~torlab.protocols.data` reduces, :mod:`~torlab.protocols.fits` fits,
:mod:`~torlab.protocols.sections` builds the report sections) read and fill a
:class:`RunContext`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any, get_args

import numpy as np

from torlab.errors import FitError, TorlabInputError
from torlab.files import safe_name
from torlab.progress import Progress
from torlab.protocols.schema import FitFigures

__all__ = ["SHORT_BLOCK", "Progress", "RunContext", "add_covariance", "finite"]

#: the most tasks of one block of short tasks (:meth:`RunContext.cached_map`): a block of a
#: reduce stage is 64 reductions' cache entries (about 3 MB for HPT logs) in transit
SHORT_BLOCK = 64


def finite(v: Any) -> Any:
    """JSON-safe value: non-finite floats -> None, numpy scalars -> Python, paths -> str."""
    if isinstance(v, dict):
        return {str(k): finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [finite(x) for x in v]
    if isinstance(v, np.ndarray):
        return [finite(x) for x in v.tolist()]
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, Path):
        return str(v)
    return v


@dataclass
class RunContext:
    """State of one protocol run.

    Attributes
    ----------
    lp
        The loaded protocol (:class:`~torlab.protocols.loader.LoadedProtocol`).
    dest, cache, prog
        Output folder, result cache, progress bars (:class:`torlab.progress.Progress`).
    executor
        Where independent tasks run (:mod:`torlab.parallel`; serial by default).
    reductions
        Data section (``hpt``, ``mtm``, ``optical``, ``visc``) -> the
        :class:`~torlab.instruments.reduction.Reduction` of each file, in order.
    keys
        ``id(reduction)`` -> cache key of its reduction (fits key on it).
    param_sets
        Parameter set name (``hpt:OFM1``, ``lubricant:ester`` ...) -> scene dict.
    fit_rows, fit_results, fit_summary
        Parameter table rows, ``(name, fit result)`` (each kept as a
        :class:`~torlab.fit.result.PackedFit`) and the summary of every fit (JSON-safe
        when recorded, :func:`finite`: ``summary.json`` writes it as it is).
    data_summary, notes
        Key numbers of the reduced data; notes for the report.
    fit_figures
        Which fitted sets get a figure: ``auto`` (every set up to :data:`AUTO_ALL_SETS`
        fitted sets, above that those whose fit warned), ``all``, ``warned`` (those whose
        fit warned), ``none`` (the protocol's ``reports.fit_figures``, or ``torlab run
        --fit-figures``; :func:`drawn_fits`).
    draw
        Whether the run draws figures at all (``torlab run --no-figures``: no); the
        sections declare theirs either way, and the reports name those not drawn.
    """

    lp: Any
    dest: Any
    cache: Any
    prog: Progress
    executor: Any = None
    reductions: dict[str, list[Any]] = field(default_factory=dict)
    keys: dict[int, str] = field(default_factory=dict)
    param_sets: dict[str, dict[str, Any]] = field(default_factory=dict)
    fit_rows: list[dict[str, Any]] = field(default_factory=list)
    fit_results: list[tuple[str, Any]] = field(default_factory=list)
    fit_summary: dict[str, Any] = field(default_factory=dict)
    data_summary: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    fit_figures: str = "auto"
    draw: bool = True
    #: what the sections found of each item (product, composition) for ``reports.compare``:
    #: label -> :class:`torlab.comparison.Item`
    compare_items: dict[str, Any] = field(default_factory=dict)
    #: ``id(reduction)`` -> where the whole reduction is, for a reduction kept light
    #: (:func:`torlab.protocols.data.reduce_data`): an object with ``reduction()`` (the
    #: whole one, read here) and ``arg()`` (what a task takes instead: read there)
    stored: dict[int, Any] = field(default_factory=dict)
    #: ``id(fit result)`` -> its :class:`~torlab.fit.result.StoredFit`, for a fit kept
    #: without its data (:meth:`keep_fit`), until the fit is recorded (:meth:`add_fit`: its
    #: :class:`~torlab.fit.result.PackedFit` then carries the reference, and
    #: :meth:`fit_arg` makes what its figure is given)
    stored_fits: dict[int, Any] = field(default_factory=dict)
    _by_source: dict[Path, Any] | None = field(default=None, repr=False)

    @property
    def p(self) -> Any:
        """The protocol."""
        return self.lp.protocol

    def sha(self, path: Path) -> str:
        """SHA-256 of a file (kept by the result cache across runs:
        :meth:`torlab.protocols.cache.ResultCache.sha`)."""
        return self.cache.sha(path)

    def reduction(self, path: Path) -> Any:
        """The (whole) reduction of one of the protocol's data files."""
        if self._by_source is None or len(self._by_source) != sum(map(len, self.reductions.values())):
            self._by_source = {}
            for reds in self.reductions.values():
                for r in reds:
                    self._by_source.setdefault(Path(r.source), r)
        r = self._by_source.get(Path(path))
        if r is None:
            raise TorlabInputError("not one of the protocol's data files", path=path)
        return self.full(r)

    def full(self, red: Any) -> Any:
        """The whole reduction of ``red`` (read from the cache when only its summary is
        kept here: :attr:`stored`)."""
        s = self.stored.get(id(red))
        return red if s is None else s.reduction()

    def task_arg(self, red: Any) -> Any:
        """What a task takes for the reduction ``red``: the reduction's ``detail``, or a
        reference a worker reads it through (:attr:`stored`; ``torlab.protocols.data.detail``
        turns either into the detail)."""
        s = self.stored.get(id(red))
        return red.detail if s is None else s.arg()

    def keep_fit(self, res: Any, kind: str, parts: dict[str, Any]) -> Any:
        """What this process keeps of a fit result stored in the cache as ``(kind,
        parts)``: the result without its data table (:class:`~torlab.fit.result.StoredFit`;
        a large fit's data stay in the cache, read where its figure is drawn), or the
        result itself where it has no data or no entry."""
        from torlab.fit.result import FitResult, StoredFit

        if not isinstance(res, FitResult) or res.data is None:
            return res
        ref = self.cache.ref(kind, **parts)
        if ref is None:
            return res
        stored = StoredFit.of(res, ref)
        self.stored_fits[id(stored.light)] = stored
        return stored.light

    def fit_arg(self, res: Any) -> Any:
        """What a figure of the fit result ``res`` takes: its
        :class:`~torlab.fit.result.StoredFit` if it is kept without its data, else the
        result (restored from its :class:`~torlab.fit.result.PackedFit`)."""
        from torlab.fit.result import PackedFit

        if isinstance(res, PackedFit):
            return res.arg()
        return self.stored_fits.get(id(res), res)

    def labelled(self, section: str) -> list[tuple[str, Any]]:
        """``(label, reduction)`` of a data section (the protocol's labels, else file stems)."""
        labels = self.lp.labels(section)
        return [(labels.get(Path(r.source)) or r.stem, r) for r in self.reductions.get(section, [])]

    def add_fit(self, name: str, res: Any, scene_dict: dict[str, Any], *,
                keep_set: bool = True) -> None:
        """Record a fitted parameter set: table rows, summary, ``fits/<name>.yaml``.

        The kept set carries the fit's covariance (``fit: covariance:``, first,
        before any block already in ``scene_dict`` such as the temperature
        fit's), so the predictions that use it draw bands (:mod:`torlab.model.bands`).
        """
        from torlab.yamlio import dump_yaml

        if keep_set:
            add_covariance(scene_dict, res, first=True)
            self.param_sets[name] = scene_dict
        re = res.meta.get("random_effects") or {}
        for r in res.table().to_dict("records"):
            sh = (re.get(r["parameter"]) or {}).get("share_between")
            self.fit_rows.append({"set": name, "kind": res.kind, **r,
                                  "between_runs_pct": float("nan") if sh is None
                                  else 100.0 * float(sh)})
        self.fit_results.append((name, _packed(res, self.stored_fits.pop(id(res), None))))
        said = {"kind": res.kind, "params": dict(res.params),
                "ci95": {k: list(v) for k, v in res.ci95.items()},
                "residual_rms": res.residual_norm, "warnings": list(res.warnings)}
        if res.meta.get("scatter"):
            said["scatter"] = str(res.meta["scatter"])
        if re:
            said["random_effects"] = re
        if res.meta.get("model_selection"):
            said["model_selection"] = res.meta["model_selection"]
        self.fit_summary[name] = finite(said)  # as summary.json writes it (no copy there)
        from torlab.comparison import item_from_fit

        # (made only when the protocol compares anything: a campaign's fits are many)
        self.add_estimates(lambda: [it for it in [item_from_fit(res, name.split(":", 1)[-1])]
                                    if it.estimates])
        self.dest.write_text(f"fits/{safe_name(name.replace(':', '_'))}.yaml",
                             dump_yaml(finite(res.to_yaml_dict())))

    def add_estimates(self, items: list[Any] | Callable[[], list[Any]]) -> None:
        """Add items' estimates (:class:`torlab.comparison.Item`) for ``reports.compare``;
        an item's quantities from several sections (a product's layer and its crossing)
        join under its label.  ``items`` may be a callable that builds them: it is called
        only when the protocol compares anything (a re-run without ``reports.compare`` then
        loads no statistics module for estimates it never uses)."""
        from torlab.comparison import Item

        if callable(items):
            if not self.p.reports.compare:
                return
            items = items()
        for it in items:
            have = self.compare_items.setdefault(it.label, Item(it.label))
            have.estimates.update(it.estimates)
            have.sources += [s for s in it.sources if s not in have.sources]

    def selection_choices(self, sets: list[str]) -> list[str]:
        """The model-selection choices of the fits behind parameter sets, one line each.

        ``hpt:<product>`` includes its temperature fit (``hpt-T:<product>``):
        a coefficient fixed to 0 there is exact in every prediction that uses
        the set, which the report must say next to the prediction's verdict.
        """
        names = [n for s in sets for n in (s, s.replace("hpt:", "hpt-T:", 1))]
        out = []
        for name, res in self.fit_results:
            if name not in names:
                continue
            for par, ch in (res.meta.get("model_selection") or {}).items():
                if not isinstance(ch, dict):
                    continue
                p = ch.get("p_value")
                test = f" ({ch.get('test', 'test')}: p = {p:.2g})" if p is not None else ""
                out.append(f"{name}: {par} {ch.get('decision', '')}{test}")
        return out

    def scenes_for(self, refs: list[Any], params: list[str]) -> list[tuple[str, Any, dict]]:
        """``(set name, Scene, scene dict)`` for scene files with parameter sets applied.

        ``hpt:*`` gives one scene per fitted HPT product; other sets are applied in order.
        """
        from torlab.protocols.loader import deep_merge
        from torlab.scene import scene_from_dict

        files = tuple(x.resolved for x in refs)
        base = self.lp.scenes[files]
        star = [s[4:] for s in self.param_sets if s.startswith("hpt:")] \
            if "hpt:*" in params else [None]
        if "hpt:*" in params and not star:
            raise FitError("hpt:* names no fitted HPT layer (fits.hpt_layers fitted nothing)")
        out = []
        for prod in star:
            sd = deep_merge({}, base)
            blocks = _covariances(sd)
            for ps in params:
                name = f"hpt:{prod}" if ps == "hpt:*" else ps
                if name not in self.param_sets:
                    raise FitError(f"parameter set {name!r} was not fitted (see the fits: "
                                   "section and the notes above)")
                blocks += _covariances(self.param_sets[name])
                deep_merge(sd, self.param_sets[name])
            if blocks:  # every set's blocks are kept (independent fits), as load_scene does
                sd["fit"]["covariance"] = blocks
            try:
                sc = scene_from_dict(sd, path=str(files[0]))
            except TorlabInputError as e:
                raise TorlabInputError(f"the scene with {', '.join(params)} applied is invalid: "
                                       f"{e}", path=files[0]) from None
            out.append((prod or "", sc, sd))
        return out

    def predict(self, kind: str, scene: dict[str, Any], **kw: Any) -> Any:
        """A cached prediction: ``kind`` ``traction`` or ``stribeck`` of a scene dict.

        A scene with fit covariances gets its 95 % band and, for traction, the
        trend with class probabilities (``trend_tolerance``, ``trend_probability``).
        """
        return self.predict_many(kind, [(scene, kw)])[0]

    def predict_many(self, kind: str, jobs: list[tuple[dict[str, Any], dict[str, Any]]],
                     description: str = "") -> list[Any]:
        """Cached predictions ``(scene dict, options)`` of one ``kind``, the missing ones
        computed on the run's executor (in order).

        Each is kept here without its band's propagation (:func:`_kept_prediction`): the
        sections read the band from the prediction's ``summary`` and its table's columns;
        the cache entry keeps the whole prediction."""
        tasks = []
        for scene, kw in jobs:
            kw = dict(kw)
            ck = kw.pop("cache_kind", kind)
            tasks.append((ck, {"scene": scene, **kw}, (kind, scene, kw)))
        out: list[Any] = [None] * len(tasks)
        by_kind: dict[str, list[int]] = {}
        for i, t in enumerate(tasks):
            by_kind.setdefault(t[0], []).append(i)
        for ck, idx in by_kind.items():
            vals = self.cached_map(ck, _predict_task, [(tasks[i][1], tasks[i][2]) for i in idx],
                                   description, keep=_kept_prediction)
            for i, v in zip(idx, vals, strict=True):
                out[i] = v
        return out

    def _found(self, kind: str, parts: dict[str, Any], light: Any,
               also: tuple[str, dict[str, Any]] | None, part: bool = False) -> tuple[bool, Any]:
        """``(hit, value)`` of one task of :meth:`cached_map` in the cache; ``part``: only
        part of the value is kept (its arrays then its own, not views of the entry)."""
        hit, v = (self.cache.lookup(kind, own_arrays=part, **parts) if light is None else
                  self.cache.lookup_light(kind, light, **parts))
        if hit and also is not None:
            hit, v2 = self.cache.lookup(also[0], own_arrays=part, **also[1])
            v = (v, v2)
        return hit, v

    def _store_encoded(self, name: str, kind: str, v: Any, more: tuple, light: Any,
                       keep: Callable[[Any], Any] | None) -> Any:
        """Write a task's encoded result (:class:`torlab.protocols.cache.Encoded`) and the
        further entries it filled; what :meth:`cached_map` keeps of it."""
        self.cache.store_payload(name, kind, v.payload)
        for (other, k), payload in zip(more, v.also, strict=True):
            self.cache.store_payload(other, k, payload)
        if v.light:  # the index keeps the restored value, remaking its JSON when written
            return self.cache.keep_light(name, light, v.value)
        return v.value if keep is None else keep(v.value)

    def cached_map(self, kind: str | list[str], fn: Any, tasks: list[tuple[dict[str, Any], Any]],
                   description: str = "", uses: Any = None, short: bool = False,
                   light: Any = None,
                   also: list[tuple[str, dict[str, Any]] | None] | None = None,
                   keep: Callable[[int, Any], Any] | None = None) -> list[Any]:
        """``fn(arg)`` for ``(cache parts, arg)`` tasks: entries in the cache are reused, the
        others computed on the run's executor (:mod:`torlab.parallel`) and stored.

        ``kind``: the cache kind of every task, or one per task (tasks of several kinds in
        one map, so that no worker waits between them).  ``uses``: which of the
        executor's prepared modules the tasks use (:meth:`torlab.parallel.Executor.map`;
        None: all).  ``short``: the tasks take milliseconds each, so they go to the
        workers in blocks (four per worker, at most :data:`SHORT_BLOCK` tasks each).
        ``light``: what this process keeps of a value
        (:class:`torlab.protocols.cache.Light`: a reduction's header and key figures): the
        values themselves stay in the cache (:meth:`full`, :meth:`task_arg`), and a later
        run takes the light values from the cache's index without reading the entries.

        ``also``: for each task None or the ``(kind, parts)`` of a second entry it fills
        (two results of one computation, each stored where later runs and other sections
        look for it): ``fn(arg)`` returns the pair, and the task's result is the pair; it is
        taken from the cache only when both entries are there (not with ``light``).

        ``keep``: ``keep(i, value)`` is what this process keeps of task ``i``'s value,
        called as soon as the value is found in or written to the cache (a large fit kept
        without its data: :meth:`keep_fit`), so that the whole values are never all held.

        A computed value is encoded for the cache where it was computed (a worker,
        :class:`torlab.protocols.cache.Encoding`); this process signs and writes it as it
        arrives, so a long map's results are never all held here at once.  A value
        completed here (a sampled band, its draws run as tasks of their own:
        :func:`torlab.parallel.map_deferred`) is stored, whole, as soon as it is completed
        and only ``keep``'s form of it kept, so that no two such values (every draw's
        outputs) are held here at once.
        """
        import time

        from torlab.parallel import current

        kinds = [kind] * len(tasks) if isinstance(kind, str) else list(kind)
        also = list(also) if also is not None else [None] * len(tasks)
        if light is not None and any(also):
            raise ValueError("cached_map: a task with a second entry keeps its whole values")
        out: list[Any] = [None] * len(tasks)
        todo = []
        for i, (parts, _) in enumerate(tasks):
            hit, v = self._found(kinds[i], parts, light, also[i], keep is not None)
            if hit:
                out[i] = v if keep is None else keep(i, v)
            else:
                todo.append(i)
        if todo:
            from torlab.parallel import map_deferred
            from torlab.protocols.cache import Encoded, Encoding

            ex = self.executor if self.executor is not None else current()
            t0 = time.perf_counter()
            cache = self.cache.folder is not None
            names = [self.cache.entry_name(kinds[i], **tasks[i][0]) for i in todo]
            more = [() if also[i] is None else
                    ((self.cache.entry_name(also[i][0], **also[i][1]), also[i][0]),)
                    for i in todo]

            written: set[int] = set()  # stored (and kept) as they came: not again

            def stored(j: int, v: Any) -> Any:  # as each result arrives
                if not isinstance(v, Encoded):
                    return v
                written.add(j)
                return self._store_encoded(names[j], kinds[todo[j]], v, more[j], light,
                                           None if keep is None else partial(keep, todo[j]))

            def finished(j: int, v: Any) -> Any:  # completed here (its work was deferred)
                i = todo[j]
                if cache:  # stored now, whole (its draws); kept as a stored one is
                    if also[i] is None:
                        self.cache.store(kinds[i], v, **tasks[i][0])
                    else:
                        self.cache.store(kinds[i], v[0], **tasks[i][0])
                        self.cache.store(also[i][0], v[1], **also[i][1])
                written.add(j)
                return v if keep is None else keep(i, v)

            # a task may defer part of its work (a sampled band's draws): those parts run
            # as tasks of their own, on every worker (torlab.parallel.Deferred)
            # short tasks go in blocks of at most SHORT_BLOCK tasks: a block's results are
            # held here from its arrival until each is stored, so the memory of a map does
            # not grow with its number of tasks
            size = min(-(-len(todo) // (4 * max(1, ex.workers))), SHORT_BLOCK) if short else 1
            task = Encoding(fn, light) if cache else fn
            args = [(names[j], kinds[i], tasks[i][1], *((more[j],) if more[j] else ()))
                    for j, i in enumerate(todo)] if cache else [tasks[i][1] for i in todo]
            vals = map_deferred(ex, task, args, description=description,
                                subtasks="band: parameter draws", uses=uses, chunksize=size,
                                each=stored, finished=finished)
            self.cache.compute_seconds += time.perf_counter() - t0
            self.cache.misses += len(todo)
            for j, (i, v) in enumerate(zip(todo, vals, strict=True)):
                # what neither ``stored`` nor ``finished`` took (no cache): kept as a
                # stored one is (``keep``)
                out[i] = v if keep is None or j in written else keep(i, v)
        return out


#: ``reports.fit_figures: auto`` draws a figure of every fitted set up to this many sets,
#: and above it only of the sets whose fit warned: a report of a few products shows every
#: fit; a campaign's shows the fits to look at (its parameter table holds every set)
AUTO_ALL_SETS = 24
FIT_FIGURES: tuple[str, ...] = get_args(FitFigures)


def figure_choices(reports: Any, figures: bool | None = None, fit_figures: str | None = None
                   ) -> tuple[bool, bool, str]:
    """``(draw, embed, fit_figures)`` of a run: the figures at all, embedded in report.html,
    and which fitted sets get one -- the options given (``torlab run --no-figures``,
    ``--fit-figures``), else the protocol's ``reports`` keys.

    Raises
    ------
    TorlabInputError
        ``fit_figures`` is not one of :data:`FIT_FIGURES`.
    """
    draw = figures if figures is not None else bool(getattr(reports, "figures", True))
    embed = getattr(reports, "html_figures", "link") == "embed"
    which = fit_figures if fit_figures is not None else getattr(reports, "fit_figures", "auto")
    return draw, embed, check_fit_figures(which)


def check_fit_figures(value: str) -> str:
    """``value`` if it names which fitted sets get a figure (one of :data:`FIT_FIGURES`:
    ``reports.fit_figures``, ``--fit-figures``); else TorlabInputError."""
    if value not in FIT_FIGURES:
        raise TorlabInputError(f"{value!r}: expected {', '.join(FIT_FIGURES[:-1])} or "
                               f"{FIT_FIGURES[-1]}", key="--fit-figures")
    return value


def drawn_fits(which: str, results: list[tuple[str, Any]]) -> list[tuple[str, Any]]:
    """The ``(name, fit result)`` of ``results`` that get a data-against-model figure under
    ``reports.fit_figures: which`` (``auto``: all of them when there are at most
    :data:`AUTO_ALL_SETS`, else as ``warned``), in their order."""
    if which == "auto":
        which = "all" if len(results) <= AUTO_ALL_SETS else "warned"
    return [(name, res) for name, res in results
            if which == "all" or (which == "warned" and res.warnings)]


def _packed(res: Any, stored: Any) -> Any:
    """What the run keeps of a fit result to its end: a
    :class:`~torlab.fit.result.PackedFit` (with the reference of its
    :class:`~torlab.fit.result.StoredFit` ``stored``, if any), or the result itself if it is
    not a :class:`~torlab.fit.result.FitResult`."""
    from torlab.fit.result import FitResult, PackedFit

    if not isinstance(res, FitResult):
        return res
    return PackedFit(res, None if stored is None else stored.ref)


def add_covariance(scene_dict: dict[str, Any], res: Any, *, first: bool = False) -> None:
    """Put a fit's ``fit: covariance:`` block into a parameter-set dict (a list of blocks)."""
    cs = res.covariance_section() if hasattr(res, "covariance_section") else None
    if cs is None:
        return
    blocks = scene_dict.setdefault("fit", {}).setdefault("covariance", [])
    if first:
        blocks.insert(0, cs)
    else:
        blocks.append(cs)


def _covariances(d: dict[str, Any]) -> list[Any]:
    """The covariance blocks of a scene or parameter-set dict (a copy, as a list)."""
    import copy

    fit = d.get("fit")
    c = fit.get("covariance") if isinstance(fit, dict) else None
    if c is None:
        return []
    return copy.deepcopy(c if isinstance(c, list) else [c])


def _predict_task(job: tuple[str, dict[str, Any], dict[str, Any]]) -> Any:
    """One prediction of a scene dict (an executor task).

    A scene with fit covariances gets its 95 % band and, for traction, the trend with
    class probabilities.
    """
    from torlab.scene import scene_from_dict

    kind, scene, kw = job
    sc = scene_from_dict(scene)
    if kind == "traction":
        from torlab.model.predict import predict_traction_deferred
        from torlab.parallel import Deferred

        # a sampled band's draws are left to the executor (torlab.parallel.map_deferred)
        pred = predict_traction_deferred(sc, kw["creepage"],
                                         trend_tolerance=kw.get("trend_tolerance", 0.01),
                                         trend_threshold=kw.get("trend_probability", 0.9))
        if isinstance(pred, Deferred):
            pred.then = _CacheReady(pred.then)
            return pred
    else:
        from torlab.model.predict import predict_stribeck

        pred = predict_stribeck(sc, kw["speed"], kw["creepage"])
    return _cache_ready(pred)


def _kept_prediction(_i: int, pred: Any) -> Any:
    """What a protocol run keeps of a prediction (:meth:`RunContext.predict_many`): all but
    its band's :class:`~torlab.uncertainty.Propagation` (the design, the contributions and
    the band's arrays: about 30 kB of a traction curve's 55 kB), whose numbers the
    prediction's ``summary`` and table hold.  The 384 curves of a 64x campaign would hold
    about 12 MB of them in this process until their report is built."""
    import dataclasses

    if dataclasses.is_dataclass(pred) and getattr(pred, "band", None) is not None:
        return dataclasses.replace(pred, band=None)
    return pred


def _cache_ready(pred: Any) -> Any:
    """The prediction without its band's model function (not data: the cache keeps the
    design)."""
    band = getattr(pred, "band", None)
    if band is not None:
        band._design.pop("model", None)
    return pred


@dataclass
class _CacheReady:
    """Finish a deferred prediction, then :func:`_cache_ready` (picklable)."""

    then: Any

    def __call__(self, results: list[Any]) -> Any:
        return _cache_ready(self.then(results))
