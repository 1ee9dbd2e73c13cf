"""Writing results safely: atomic, never over earlier results, never over inputs.

:class:`OutputDir` is how every torlab command writes.  Files go to a hidden
staging folder next to the target; :meth:`OutputDir.commit` swaps it into place
in one rename, so a crash or an error leaves either the earlier results or the
new ones, never a mix.  A target that already holds files is refused unless
``force=True``, and even then only if every file in it was written by torlab
(listed in its ``torlab-manifest.json``): ``--force`` never deletes a user's
own files.  A target that contains one of the command's *input* files is always
refused.

Example
-------
>>> with OutputDir("out", force=False, inputs=["run1.txt"]) as out:   # doctest: +SKIP
...     out.write_csv("reduced.csv", df)
...     out.save_figure("curve.png", fig)
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from torlab import __version__
from torlab.errors import OutputExistsError, TorlabInputError

__all__ = ["MANIFEST", "OutputDir", "atomic_write_bytes", "atomic_write_text", "sha256_file"]

MANIFEST = "torlab-manifest.json"


def sha256_file(path: str | os.PathLike[str], chunk: int = 1 << 20) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while b := f.read(chunk):
            h.update(b)
    return h.hexdigest()


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file and ``os.replace``."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write UTF-8 ``text`` atomically (see :func:`atomic_write_bytes`)."""
    atomic_write_bytes(path, text.encode("utf-8"))


class OutputDir:
    """A results folder written atomically; see the module docstring.

    Parameters
    ----------
    target
        Folder the results end up in.
    force
        Replace earlier torlab results in ``target``.
    inputs
        The command's input files; ``target`` may not contain any of them.
    command
        Command line recorded in the manifest.
    keep
        Names (relative paths) of files or folders in an existing ``target``
        to carry over into the new results (e.g. a cache), if present.
    """

    def __init__(
        self,
        target: str | os.PathLike[str],
        *,
        force: bool = False,
        inputs: Iterable[str | os.PathLike[str]] = (),
        command: str = "",
        keep: Iterable[str] = (),
    ) -> None:
        self.target = Path(target)
        self.force = force
        self.command = command
        self.inputs = [Path(p) for p in inputs]
        self.keep = list(keep)
        self.files: list[str] = []
        self._staging: Path | None = None
        self._check_target()

    # -- checks -------------------------------------------------------------
    def _check_target(self) -> None:
        t = self.target
        if t.exists() and not t.is_dir():
            raise TorlabInputError("output path exists and is not a folder", path=t)
        tres = t.resolve()
        for inp in self.inputs:
            try:
                inp.resolve().relative_to(tres)
            except ValueError:
                continue
            raise TorlabInputError(
                f"output folder contains the input file {inp}; choose another -o so raw data "
                "are never touched", path=t)
        if not t.exists():
            return
        entries = [e.name for e in t.iterdir()]
        if not entries:
            return
        if not self.force:
            raise OutputExistsError(
                "output folder already holds results; use --force to replace them or choose "
                "another -o", path=t)
        owned = self._owned(t)
        foreign = sorted(set(entries) - owned - {MANIFEST})
        if foreign:
            more = "" if len(foreign) <= 3 else f" and {len(foreign) - 3} more"
            raise OutputExistsError(
                "--force only replaces torlab's own results, but the folder also holds "
                f"{', '.join(foreign[:3])}{more}; move them or choose another -o", path=t)

    @staticmethod
    def _owned(t: Path) -> set[str]:
        man = t / MANIFEST
        if not man.exists():
            return set()
        try:
            files = json.loads(man.read_text(encoding="utf-8")).get("files", [])
        except (OSError, ValueError):
            return set()
        return {str(f).split("/", 1)[0] for f in files}

    # -- staging ------------------------------------------------------------
    @property
    def staging(self) -> Path:
        """Folder files are written to before :meth:`commit`."""
        if self._staging is None:
            parent = self.target.resolve().parent
            parent.mkdir(parents=True, exist_ok=True)
            self._staging = Path(tempfile.mkdtemp(prefix=f".{self.target.name}.staging-", dir=parent))
            if self.target.exists():
                for name in self.keep:
                    src = self.target / name
                    if src.is_dir():
                        shutil.copytree(src, self._staging / name)
                    elif src.exists():
                        shutil.copy2(src, self._staging / name)
        return self._staging

    def path(self, name: str) -> Path:
        """Staging path for ``name`` (a relative path), recorded in the manifest."""
        rel = Path(name)
        if rel.is_absolute() or ".." in rel.parts:
            raise ValueError(f"output names must be relative paths inside the folder: {name!r}")
        p = self.staging / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        if rel.as_posix() not in self.files:
            self.files.append(rel.as_posix())
        return p

    def final_path(self, name: str) -> Path:
        """Where ``name`` will be after :meth:`commit`."""
        return self.target / name

    def write_text(self, name: str, text: str) -> Path:
        """Write a UTF-8 text file."""
        p = self.path(name)
        p.write_text(text, encoding="utf-8")
        return self.final_path(name)

    def write_bytes(self, name: str, data: bytes) -> Path:
        """Write a binary file."""
        p = self.path(name)
        p.write_bytes(data)
        return self.final_path(name)

    def write_json(self, name: str, obj: Any) -> Path:
        """Write ``obj`` as indented JSON (NaN/inf are refused)."""
        return self.write_text(name, json.dumps(obj, indent=2, allow_nan=False, default=_json_default) + "\n")

    def write_csv(self, name: str, df: Any, *, float_format: str = "%.10g",
                  allow_missing: tuple[str, ...] = ()) -> Path:
        """Write a pandas DataFrame as CSV (no index).

        Numbers must be finite: a NaN or inf is refused (a numerical bug must not
        reach a result file), except NaN in the ``allow_missing`` columns, which
        is written as an empty cell meaning "not given" (e.g. no applied amount).
        """
        import numpy as np

        num = df.select_dtypes(include="number")
        bad = []
        for c in num.columns:
            v = num[c].to_numpy(dtype=float)
            ok = np.isfinite(v) | (np.isnan(v) if c in allow_missing else False)
            if not ok.all():
                bad.append(c)
        if bad:
            raise ValueError(f"refusing to write non-finite values to {name}: columns {bad}")
        p = self.path(name)
        df.to_csv(p, index=False, float_format=float_format, lineterminator="\n")
        return self.final_path(name)

    def save_figure(self, name: str, fig: Any, **kw: Any) -> Path:
        """Save a matplotlib figure (format from the suffix) and close it."""
        import matplotlib.pyplot as plt

        p = self.path(name)
        kw.setdefault("dpi", 150)
        kw.setdefault("bbox_inches", "tight")
        fig.savefig(p, **kw)
        plt.close(fig)
        return self.final_path(name)

    # -- commit -------------------------------------------------------------
    def commit(self) -> Path:
        """Write the manifest and move the results into place atomically."""
        st = self.staging
        for name in self.keep:
            if (st / name).exists() and name not in self.files:
                self.files.append(name)
        manifest = {
            "torlab_version": __version__,
            "command": self.command,
            "written": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "inputs": {str(p): sha256_file(p) for p in self.inputs if p.is_file()},
            "files": sorted(self.files),
        }
        (st / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
        t = self.target
        old = None
        if t.exists():
            old = t.with_name(f".{t.name}.old-{os.getpid()}-{time.monotonic_ns()}")
            os.replace(t, old)
        try:
            os.replace(st, t)
        except BaseException:
            if old is not None:
                os.replace(old, t)
            raise
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        self._staging = None
        return t

    def abort(self) -> None:
        """Discard the staged files; the target is left as it was."""
        if self._staging is not None:
            shutil.rmtree(self._staging, ignore_errors=True)
            self._staging = None

    def __enter__(self) -> OutputDir:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.abort()


def _json_default(o: Any) -> Any:
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
