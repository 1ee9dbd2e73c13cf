"""A re-run that finds nothing changed (:func:`torlab.protocols.runner.run_protocol`).

A protocol run's results depend on torlab's, Python's and NumPy's versions, the protocol
file, every input file and the options that change a result (figure formats, figures drawn
or not, embedded or linked, which fitted sets get one and ``auto``'s threshold, the
cache).  :func:`run_key` hashes them; the run records the key and the status (size,
times, inode) of every file it wrote in its cache's signed index
(:meth:`~torlab.protocols.cache.ResultCache.record_run`).  A re-run with ``--force`` whose
key is the same and whose earlier files are all still the ones written
(:meth:`~torlab.protocols.cache.ResultCache.up_to_date`) keeps every result as it is --
nothing computed, drawn, unlinked or rewritten -- and :func:`unchanged_result` says so.
When something changed, the run is made again and each figure or report whose bytes did
not change is kept as the earlier file (``OutputDir.write_bytes(keep_same=True)``): one
rule, a result is never rewritten with the same bytes, at the two granularities.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

__all__ = ["run_key", "unchanged_result"]


def run_key(lp: Any, rc: Any, inputs: list[Path], options: dict[str, Any]) -> str:
    """What the results of a run depend on, hashed: torlab's, Python's and NumPy's versions,
    the protocol file and every input file (by their SHA-256: kept by the cache across runs,
    :meth:`~torlab.protocols.cache.ResultCache.sha`) and the options that change a result.
    Empty for a protocol given as text (never taken as unchanged)."""
    import hashlib
    import json
    import platform

    import numpy as np

    from torlab import __version__

    if lp.path is None or rc.folder is None:
        return ""
    blob = json.dumps({"torlab": __version__, "python": platform.python_version(),
                       "numpy": np.__version__, "protocol": rc.sha(lp.path),
                       "inputs": {str(p): rc.sha(p) for p in inputs}, "options": options},
                      sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def unchanged_result(out: Path, rec: dict[str, Any], t0: float, command: str,
                      executor: Any) -> dict[str, Any]:
    """The result of a re-run that found nothing changed, as the fields of a
    :class:`~torlab.protocols.runner.RunResult`: the earlier run's summary (its file is the
    one that run wrote: :meth:`~torlab.protocols.cache.ResultCache.up_to_date`), every
    result reused, no figure drawn, nothing written."""
    import json

    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    total = time.perf_counter() - t0
    summary["run"] = dict(summary.get("run", {}), command=command, cache_hits=rec["hits"],
                          cache_misses=0, figures_drawn=0, figures_reused=rec["figures"],
                          seconds=round(total, 2), unchanged=True)
    timing = {"compute": 0.0, "figures": 0.0, "io": 0.0, "other": total, "total": total,
              "figures_drawn": 0, "figures_reused": rec["figures"], "figures_ahead": 0,
              "figures_on": bool(rec.get("figures_on", True)),
              "files_kept": len(rec["outputs"]),
              "executor": executor.describe() if executor is not None else "none needed"}
    notes = list(summary.get("notes", []))
    return {"out": out, "summary": summary, "sections": list(rec["sections"]),
            "cache_hits": rec["hits"], "cache_misses": 0, "notes": notes, "timing": timing,
            "unchanged": True}
