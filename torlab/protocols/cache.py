"""Re-run reuse: intermediate results cached in ``OUT/.cache/`` keyed by input hash + options.

A protocol run stores each expensive intermediate result (a reduced log, a fit,
a predicted curve) under a key made from the SHA-256 of its input files, the
options that produced it and the torlab version.  A re-run into the same output
folder (``--force``) carries the cache over (:class:`torlab.outputs.OutputDir`
``keep=``) and reuses every entry whose key still matches; entries a run did not
use are dropped, so the cache never grows beyond one run's results.

The entries are Python pickles written by torlab into the run's own output
folder; they are read back only from there (never from an input folder).
"""

from __future__ import annotations

import hashlib
import json
import pickle
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any, TypeVar

__all__ = ["CACHE_DIR", "ResultCache", "file_sha256"]

CACHE_DIR = ".cache"
T = TypeVar("T")


@cache
def _sha(path: str, mtime_ns: int, size: int) -> str:
    from torlab.outputs import sha256_file

    return sha256_file(path)


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file (memoised on path, modification time and size)."""
    st = Path(path).stat()
    return _sha(str(Path(path).resolve()), st.st_mtime_ns, st.st_size)


class ResultCache:
    """Pickled intermediate results in a folder (see the module docstring).

    Parameters
    ----------
    folder
        Where entries are read from and written to; ``None`` disables caching.
    register
        Called with the entry's relative name (``.cache/<key>.pkl``) when one is
        written, so the output folder lists it in its manifest.
    """

    def __init__(self, folder: Path | None, register: Callable[[str], Path] | None = None) -> None:
        self.folder = folder
        self.register = register
        self.hits = 0
        self.misses = 0
        self.used: set[str] = set()

    @staticmethod
    def key(kind: str, **parts: Any) -> str:
        """Key of an entry: ``kind``, the torlab version and ``parts`` (JSON, sorted)."""
        from torlab import __version__

        blob = json.dumps({"kind": kind, "torlab": __version__, **parts}, sort_keys=True,
                          default=_jsonable)
        return f"{kind}-{hashlib.sha256(blob.encode()).hexdigest()[:32]}"

    def get_or_compute(self, kind: str, compute: Callable[[], T], **parts: Any) -> T:
        """The cached value for ``(kind, parts)``, or ``compute()`` stored under it."""
        if self.folder is None:
            self.misses += 1
            return compute()
        k = self.key(kind, **parts)
        name = f"{k}.pkl"
        self.used.add(name)
        p = self.folder / name
        if p.is_file():
            try:
                with open(p, "rb") as f:
                    value = pickle.load(f)
                self.hits += 1
                if self.register is not None:
                    self.register(f"{CACHE_DIR}/{name}")
                return value
            except Exception:  # a damaged or incompatible entry is recomputed
                p.unlink(missing_ok=True)
        self.misses += 1
        value = compute()
        target = self.register(f"{CACHE_DIR}/{name}") if self.register is not None else p
        target.parent.mkdir(parents=True, exist_ok=True)
        with open(target, "wb") as f:
            pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
        return value

    def prune(self) -> int:
        """Delete entries this run did not use; returns how many."""
        if self.folder is None or not self.folder.is_dir():
            return 0
        n = 0
        for p in self.folder.glob("*.pkl"):
            if p.name not in self.used:
                p.unlink(missing_ok=True)
                n += 1
        return n


def _jsonable(o: Any) -> Any:
    import numpy as np

    if isinstance(o, Path):
        return str(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    return repr(o)
