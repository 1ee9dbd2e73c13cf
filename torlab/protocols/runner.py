"""Running a protocol: raw logs -> reduced data -> fitted parameter sets -> reports.

:func:`run_protocol` is what ``torlab run PROTOCOL.yaml -o OUT`` calls.  It
only sequences the stages, each a library module working on one
:class:`~torlab.protocols.context.RunContext`:

1. load and validate the protocol (:func:`torlab.protocols.loader.load_protocol`),
   every problem listed before any work starts;
2. reduce the files of each ``data:`` section through the instrument registry,
   exactly as ``torlab <instrument> reduce`` does (:mod:`torlab.protocols.data`);
3. fit the parameter sets of ``fits:`` (:mod:`torlab.protocols.fits`): HPT
   layers (``hpt:<product>``, with temperature coefficients), layers from
   measured traction curves (``traction:<name>``), viscosity laws
   (``lubricant:<name>``);
4. build the report sections (:mod:`torlab.protocols.sections`: amount, time
   test, traction, Stribeck, film, fitted sets) and write ``report.html``,
   ``report.md`` and ``summary.json`` (key numbers, torlab version, SHA-256 of
   the protocol and of every input file).

Results go through :class:`torlab.outputs.OutputDir` (atomic, never over
earlier results without ``force``).  Intermediate results are cached in
``OUT/.cache`` keyed by input hashes and options (:mod:`torlab.protocols.cache`),
and so are the figures, keyed by what they show (:mod:`torlab.reports.render`), so
a re-run with ``--force`` reuses what did not change -- and, when nothing changed,
neither computes nor draws anything.

Independent tasks -- the files of a data section, the products' fits, the
predicted curves of a report, the figures -- run on one executor
(:mod:`torlab.parallel`: serial, local processes, or a Dask cluster), with the
same results in all three.  The run's time is split honestly
(:attr:`RunResult.timing`): computing (reductions, fits, predictions, the
reports' own numbers), drawing figures, reading and writing (cache entries,
tables, figures, the reports), and the rest (loading the protocol, imports).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["RunResult", "run_protocol"]


@dataclass
class RunResult:
    """What a protocol run wrote and its key numbers."""

    out: Path
    summary: dict[str, Any]
    sections: list[str]
    cache_hits: int
    cache_misses: int
    notes: list[str] = field(default_factory=list)
    #: seconds: ``compute``, ``figures``, ``io``, ``other``, ``total`` (wall time of each
    #: stage); figures ``figures_drawn``, ``figures_reused``, and ``figures_ahead``: drawn
    #: while the sections computed (their drawing is inside ``compute``'s wall time);
    #: ``figures_cpu``: the CPU time of drawing the figures drawn, in whichever process
    #: (the figures' share of the run's CPU, whatever overlapped)
    timing: dict[str, Any] = field(default_factory=dict)
    #: nothing changed since the run that wrote ``out`` (the protocol, its inputs, torlab
    #: and the options): the results were left as they were, nothing was rewritten
    unchanged: bool = False


# --------------------------------------------------------------------------- entry point
def run_protocol(protocol: str | os.PathLike[str] | Any, out: str | os.PathLike[str], *,
                 force: bool = False, command: str = "", progress: bool = False,
                 cache: bool = True, formats: Any = None, executor: Any = None,
                 figures: bool | None = None, fit_figures: str | None = None) -> RunResult:
    """Run a protocol from raw logs to reports (``torlab run``).

    Parameters
    ----------
    protocol
        Protocol file, or a :class:`~torlab.protocols.loader.LoadedProtocol`.
    out
        Output folder; refused if it holds earlier results unless ``force``.
    force
        Replace torlab's earlier results in ``out`` (its cache is reused).
    command
        Command line for the manifest and the report.
    progress
        Show rich progress bars.
    cache
        Reuse and store intermediate results and figures in ``out/.cache``.
    formats
        Figure formats (``["png", "svg"]``; default the protocol's
        ``reports.figure_formats``, else PNG).
    executor
        Where independent tasks run (:mod:`torlab.parallel`); default
        :func:`torlab.parallel.current` (serial unless the caller set one).
    figures
        Draw the figures (default the protocol's ``reports.figures``, else yes); without
        them every number and table is written, and the reports name the figures not
        drawn.
    fit_figures
        Which fitted sets get a figure (default the protocol's; ``context.drawn_fits``).

    Returns
    -------
    RunResult

    Raises
    ------
    ValidationErrors
        The protocol is invalid (every problem listed).
    TorlabInputError, FitError, NumericalError
        A data file, fit or prediction fails (nothing is written then).
    """
    from torlab.outputs import OutputDir
    from torlab.protocols.cache import CACHE_DIR, ResultCache
    from torlab.protocols.context import AUTO_ALL_SETS, figure_choices
    from torlab.protocols.loader import LoadedProtocol, load_protocol
    from torlab.protocols.rerun import run_key, unchanged_result
    from torlab.reports.render import parse_formats

    t0 = time.perf_counter()
    lp = protocol if isinstance(protocol, LoadedProtocol) else load_protocol(protocol)
    p = lp.protocol
    formats = parse_formats(formats if formats is not None
                            else getattr(p.reports, "figure_formats", None) or None)
    draw, embed, which = figure_choices(p.reports, figures, fit_figures)
    inputs = lp.input_files()
    t1 = time.perf_counter()
    dest = OutputDir(out, force=force, inputs=inputs, command=command,
                     carry=[CACHE_DIR] if cache else [])
    try:
        # the earlier results' cache (moved into the new results below, if they are made)
        rc = ResultCache(dest.final_path(CACHE_DIR) if cache else None)
        key = run_key(lp, rc, inputs, {"formats": list(formats), "cache": cache, "figures": draw,
                                       "embed": embed, "fit_figures": [which, AUTO_ALL_SETS]})
        same = rc.up_to_date(key, dest.final_path("")) if force and key else None
        if same is not None:  # nothing changed: the results are there, nothing is rewritten
            dest.close()
            return RunResult(**unchanged_result(Path(out), same, t0, command, executor))
        rc.folder = dest.staging / CACHE_DIR if cache else None
        rc.register = dest.path
        dest.hasher = rc.sha  # the manifest's input hashes: each file hashed once
        t_io = time.perf_counter() - t1  # the output folder and its carried-over cache
        return _run(lp, dest, rc, formats, key, executor, progress, cache, command, t0,
                    t_io, inputs, draw, embed, which)
    except BaseException:
        dest.abort()
        raise


def _run(lp: Any, dest: Any, rc: Any, formats: Any, run_key: str, executor: Any,
         progress: bool, cache: bool, command: str, t0: float, t_io: float,
         inputs: list[Path], draw: bool, embed: bool, fit_figures: str = "auto") -> RunResult:
    """The stages of :func:`run_protocol` into ``dest`` (which the caller aborts on an
    error), and the commit."""
    from torlab import __version__
    from torlab.files import sha256_file_cached
    from torlab.parallel import current
    from torlab.progress import Progress
    from torlab.protocols.context import RunContext, finite
    from torlab.protocols.data import reduce_data
    from torlab.protocols.fits import fit_all
    from torlab.protocols.sections import build_sections
    from torlab.reports.html import html_lines, markdown_lines, write_figures, write_tables
    from torlab.reports.render import FiguresAhead, RenderStats

    p = lp.protocol
    ex = executor if executor is not None else current()
    ex.prepare(*_needs(p, draw))
    with Progress(progress) as prog:
        run = RunContext(lp, dest, rc, prog, executor=ex, fit_figures=fit_figures, draw=draw)
        t1 = time.perf_counter()
        io0 = rc.io_seconds + dest.io_seconds
        reduce_data(run)
        fit_all(run)
        # each section's figures start as soon as it is built, drawn whenever a
        # worker would otherwise wait while the later sections compute
        ahead = FiguresAhead(formats, store=rc.figures if cache else None, executor=ex) \
            if draw else None
        try:
            sections = build_sections(run, ready=None if ahead is None else (
                lambda s: ahead.start([(f"{s.key}/{f.name}", f.fig) for f in s.figures])))
            t_stages = time.perf_counter() - t1
            io_stages = rc.io_seconds + dest.io_seconds - io0
            t1 = time.perf_counter()
            io0 = rc.io_seconds + dest.io_seconds
            fig = write_figures(dest, sections, formats,
                                store=rc.figures if cache else None, executor=ex,
                                ahead=ahead, images=embed) if draw else RenderStats()
        except BaseException:
            if ahead is not None:
                ahead.cancel()
            raise
        finally:
            if ahead is not None:
                ahead.close()
        t_figures = time.perf_counter() - t1
        io_figures = rc.io_seconds + dest.io_seconds - io0
    t2 = time.perf_counter()
    write_tables(dest, sections)
    base = lp.base
    prov = {
        "torlab_version": __version__,
        "protocol_file": lp.path.name if lp.path else "<text>",
        "protocol_sha256": sha256_file_cached(lp.path) if lp.path else "",
        "command": command,
        "inputs": {_rel(p, base): rc.sha(p) for p in inputs if lp.path is None
                   or p != lp.path},
    }
    summary = {
        "torlab_version": __version__,
        "protocol": {"name": p.name, "title": p.title, "version": p.version,
                     "file": prov["protocol_file"], "sha256": prov["protocol_sha256"]},
        "inputs": prov["inputs"],
        "data": finite(run.data_summary),
        "fits": run.fit_summary,  # JSON-safe as recorded (RunContext.add_fit)
        "reports": {s.key: finite(s.summary) for s in sections if s.key != "fits"},
        "notes": run.notes + [n for s in sections for n in s.notes],
    }
    title = p.title or p.name
    intro = [p.description] if p.description else []
    intro.append(f"Protocol {prov['protocol_file']} ({p.name}), torlab {__version__}.")
    if run.notes:
        intro += [f"Note: {n}" for n in run.notes]
    shown = ("embed" if embed else "link") if draw else None
    # a page that did not change is kept as it was (not rewritten)
    dest.write_lines("report.html", lambda: html_lines(title, intro, sections, prov,
                                                       figures=shown), keep_same=True)
    dest.write_lines("report.md", lambda: markdown_lines(title, intro, sections, prov,
                                                         figures=shown is not None),
                     keep_same=True)
    # honest split: reading and writing (cache entries, cached figures, result files)
    # is I/O wherever it happened; what remains of each stage is its own work
    timing = {"compute": max(t_stages - io_stages, 0.0),
              "figures": max(t_figures - io_figures, 0.0),
              "io": t_io + io_stages + io_figures + time.perf_counter() - t2,
              "figures_cpu": fig.cpu_seconds,
              "figures_drawn": fig.drawn, "figures_reused": fig.reused,
              "figures_ahead": fig.ahead, "figures_on": draw,
              "files_kept": len(dest.kept), "executor": ex.describe()}
    summary["run"] = {"seconds": round(time.perf_counter() - t0, 2), "cache_hits": rc.hits,
                      "cache_misses": rc.misses, "command": command,
                      "figures_drawn": fig.drawn, "figures_reused": fig.reused,
                      "timing": {k: round(timing[k], 3)
                                 for k in ("compute", "figures", "io", "figures_cpu")}
                      | {"total": round(time.perf_counter() - t0, 3)}}
    dest.write_json("summary.json", summary)
    sections_run = [s.key for s in sections]
    if run_key:  # what a re-run with nothing changed finds (torlab.protocols.rerun)
        rc.record_run(run_key, dest, {"sections": sections_run, "hits": rc.hits + rc.misses,
                                      "figures": fig.drawn + fig.reused, "figures_on": draw})
    rc.prune()  # the index, then what this run did not use
    t3 = time.perf_counter()
    dest.commit()
    timing["io"] += time.perf_counter() - t3
    timing["total"] = time.perf_counter() - t0
    timing["other"] = max(timing["total"] - timing["compute"] - timing["figures"]
                          - timing["io"], 0.0)
    return RunResult(out=dest.target, summary=summary, sections=sections_run,
                     cache_hits=rc.hits, cache_misses=rc.misses, notes=summary["notes"],
                     timing=timing)


def _needs(p: Any, draw: bool = True) -> list[Any]:
    """What the protocol's tasks will import, loaded once in this process and inherited by
    the local workers (:meth:`torlab.parallel.Executor.prepare`) instead of once in every
    worker: the fits' optimiser (which the amount report's crossings need here too), the
    figures' matplotlib (when ``draw``), and torlab's own modules of the fits, predictions and figures.
    In the order the stages need them: the executor loads them one at a time while
    earlier tasks run.  Nothing is loaded when no worker starts (a re-run from the cache).
    """
    from torlab.reports.render import prepare_drawing

    r = p.reports
    fits = any(getattr(p.fits, k, None) for k in ("hpt_layers", "traction_layers", "lubricants"))
    needs: list[Any] = []
    if fits or getattr(r, "amount", None) is not None:
        needs.append("scipy.optimize")
    if getattr(p.fits, "hpt_layers", None):
        needs += ["torlab.fit.layer", "torlab.fit.temperature"]
    if draw:
        needs.append(prepare_drawing)
    if getattr(r, "traction", None) is not None or getattr(r, "stribeck", None) is not None:
        needs += ["torlab.model.predict", "torlab.model.bands", "torlab.uncertainty",
                  "torlab._stats"]
    if fits:
        needs.append("torlab.reports.fit")
    report_modules = {"amount": "amount", "time_test": "timetest", "traction": "traction",
                      "stribeck": "stribeck"}
    needs += [f"torlab.reports.{m}" for key, m in report_modules.items()
              if getattr(r, key, None) is not None]
    return needs


def _rel(p: Path, base: Path) -> str:
    try:
        return os.path.relpath(p, base)
    except ValueError:  # another drive (Windows)
        return str(p)

