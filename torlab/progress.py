"""Progress bars for work that takes more than a moment (rich), silent when asked or piped.

One :class:`Progress` is active at a time (:func:`current`); the CLI opens it
around a command (``--quiet`` or a standard output that is not a terminal keep
it silent), and whatever runs inside -- reductions over many files, fits,
figures, the executor's tasks (:mod:`torlab.parallel`), benchmark modules --
adds its bars to it with :meth:`Progress.track` or :meth:`Progress.task`.
Library calls outside such a block show nothing.

Bars are *transient*: a bar disappears when its work is done, so work that
takes a fraction of a second flickers at most once and leaves the terminal as
it was; what remains on screen is the command's own summary.  The bars are
refreshed when they advance and by rich's refresh thread, which is started
only after the executor's worker processes exist (see
:class:`torlab.parallel.ProcessExecutor`), so no worker is forked while that
thread holds a lock.
"""

from __future__ import annotations

import contextvars
import sys
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["Progress", "current", "enabled_for"]

_CURRENT: contextvars.ContextVar[Progress | None] = contextvars.ContextVar(
    "torlab_progress", default=None)


def enabled_for(quiet: bool = False, stream: Any = None) -> bool:
    """Whether bars should show: not ``quiet`` and the stream (stdout) is a terminal."""
    if quiet:
        return False
    s = sys.stdout if stream is None else stream
    try:
        return bool(s.isatty())
    except (AttributeError, ValueError):
        return False


class Progress:
    """Rich progress bars, or nothing when disabled.

    Use as a context manager; inside it :func:`current` returns this object.

    Parameters
    ----------
    enabled
        Show bars; ``None``: when standard output is a terminal.
    """

    def __init__(self, enabled: bool | None = None) -> None:
        self.enabled = enabled_for() if enabled is None else bool(enabled)
        self._p: Any = None
        self._token: Any = None

    def __enter__(self) -> Progress:
        if self.enabled:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                TextColumn,
                TimeElapsedColumn,
            )
            from rich.progress import Progress as RichProgress

            self._p = RichProgress(TextColumn("{task.description}"), BarColumn(),
                                   MofNCompleteColumn(), TimeElapsedColumn(), transient=True)
            self._p.__enter__()
        self._token = _CURRENT.set(self)
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._token is not None:
            _CURRENT.reset(self._token)
            self._token = None
        if self._p is not None:
            p, self._p = self._p, None
            p.__exit__(*exc)

    @contextmanager
    def task(self, description: str, total: int) -> Iterator[Any]:
        """A bar of ``total`` steps; yields ``advance(n=1)``. The bar goes when the block ends."""
        if self._p is None or total <= 0:
            yield lambda n=1: None
            return
        tid = self._p.add_task(description, total=total)

        def advance(n: int = 1) -> None:
            self._p.advance(tid, n)

        try:
            yield advance
        finally:
            if self._p is not None:
                self._p.remove_task(tid)

    def track(self, items: Iterable[Any], description: str) -> Iterator[Any]:
        """Yield ``items`` while advancing a bar."""
        items = list(items)
        with self.task(description, len(items)) as advance:
            for it in items:
                yield it
                advance()

    def pause(self) -> Any:
        """A context in which the bars are hidden (for printing while they run)."""
        if self._p is None:
            from contextlib import nullcontext

            return nullcontext()
        return _Paused(self._p)


class _Paused:
    def __init__(self, p: Any) -> None:
        self.p = p

    def __enter__(self) -> None:
        self.p.stop()

    def __exit__(self, *exc: Any) -> None:
        self.p.start()


_SILENT = Progress(enabled=False)


def current() -> Progress:
    """The active :class:`Progress` (a silent one outside any)."""
    return _CURRENT.get() or _SILENT
