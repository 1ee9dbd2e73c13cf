"""BLAS/OpenMP threads for torlab's small problems (``threadpoolctl``).

torlab's linear algebra is small: Jacobians of a few hundred rows by a handful of
parameters, normal matrices of 4 x 4, L-BFGS-B on three parameters.  A
multi-threaded BLAS gains nothing on problems of that size, and on a busy
machine its threads wait for each other and for the cores: on the shared 2-core
machine of ``docs/performance.md``, with another process keeping one core busy,
the HPT layer fit took 4.6 times longer with OpenBLAS's default of one thread
per core than with one thread (``torlab bench --only fit`` measures the ratio in
one run).  The fits therefore run with one BLAS/OpenMP thread
(:func:`small_problem`); parallel work belongs to independent tasks, one
process each.

The limit holds for the duration of the call only: a notebook's own numpy work
keeps its thread pools.  The command line starts the BLAS libraries with one
thread in the first place (``OPENBLAS_NUM_THREADS=1`` before numpy loads, unless
the user set it; :func:`torlab.cli.main`); :func:`limit_threads` then has
nothing to do and does not load threadpoolctl and scipy's BLAS for it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

__all__ = ["SMALL_PROBLEM_THREADS", "limit_threads", "small_problem"]

#: BLAS/OpenMP threads a torlab fit uses.
SMALL_PROBLEM_THREADS = 1

F = TypeVar("F", bound=Callable[..., Any])

_CONTROLLER: list[Any] = []

#: set by the command line when the BLAS libraries were started with one thread
STARTED_SINGLE_THREADED = [False]


def _controller() -> Any:
    """One ``ThreadpoolController`` for the process, made once scipy's BLAS is loaded.

    numpy and scipy ship separate OpenBLAS builds, and a controller only knows the
    libraries loaded when it is made; scipy's is loaded with ``scipy.linalg``, which
    every fit needs anyway.
    """
    if not _CONTROLLER:
        import scipy.linalg  # noqa: F401  (loads scipy's BLAS before the controller looks)
        from threadpoolctl import ThreadpoolController

        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0]


@contextmanager
def limit_threads(n: int = SMALL_PROBLEM_THREADS) -> Iterator[None]:
    """Limit every BLAS and OpenMP pool of the process to ``n`` threads inside the block."""
    if STARTED_SINGLE_THREADED[0] and int(n) >= 1:
        yield
        return
    with _controller().limit(limits=int(n)):
        yield


def small_problem(func: F) -> F:
    """Decorator: run ``func`` with :data:`SMALL_PROBLEM_THREADS` BLAS/OpenMP threads.

    The undecorated function stays available as ``func.__wrapped__`` (the benchmark's
    baseline).
    """

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with limit_threads():
            return func(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
