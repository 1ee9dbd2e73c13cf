"""Errors torlab reports to its users.

Two families:

* :class:`TorlabInputError` and subclasses: something the *user* gave is wrong
  (a malformed file, an unknown key, a wrong unit, an output folder that would be
  overwritten).  The CLI prints exactly one line naming the file (and line or key)
  and exits with code 2, without a traceback.
* :class:`NumericalError` and subclasses: a numerical method did not reach its
  tolerance or would produce a non-finite number.  Numerics never fail silently:
  they converge or raise one of these.  The CLI prints one line and exits with
  code 3.

Both carry an optional location (``path``, ``line``, ``key``) that is rendered
as ``path:line: key: message``.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

__all__ = [
    "ConvergenceError",
    "FitError",
    "NumericalError",
    "OutputBusyError",
    "OutputExistsError",
    "OutputWriteError",
    "TorlabError",
    "TorlabInputError",
    "TorlabWarning",
    "ValidationErrors",
]


class TorlabError(Exception):
    """Base class of every error torlab raises on purpose.

    Parameters
    ----------
    message
        What is wrong, in the user's terms.
    path
        File the problem is in, if any.
    line
        1-based line number in ``path``, if known.
    key
        Key path (``contact.load``) or column name, if relevant.
    """

    exit_code = 2

    def __init__(
        self,
        message: str,
        *,
        path: str | os.PathLike[str] | None = None,
        line: int | None = None,
        key: str | None = None,
    ) -> None:
        self.message = message
        self.path = None if path is None else os.fspath(path)
        self.line = line
        self.key = key
        super().__init__(self.__str__())

    def location(self) -> str:
        """``path:line`` (or the part that is known), empty if none."""
        if self.path is None:
            return "" if self.line is None else f"line {self.line}"
        return self.path if self.line is None else f"{self.path}:{self.line}"

    def __str__(self) -> str:
        parts = [p for p in (self.location(), self.key) if p]
        parts.append(self.message)
        return ": ".join(parts)

    def with_path(self, path: str | os.PathLike[str]) -> TorlabError:
        """Return the same error with ``path`` filled in if it was missing."""
        if self.path is None:
            self.path = os.fspath(path)
            self.args = (self.__str__(),)
        return self


class TorlabInputError(TorlabError):
    """Bad user input: file, value, unit, key, option.  CLI exit code 2."""


class OutputExistsError(TorlabInputError):
    """An output folder already holds results and ``--force`` was not given."""


class OutputBusyError(TorlabInputError):
    """Another torlab process is writing to the same output folder (its lock is held)."""


class OutputWriteError(TorlabInputError):
    """The output folder cannot be written (read-only, no permission, disk full).

    An environment problem the user can act on, so it shares the exit code 2 of
    input errors.
    """


class ValidationErrors(TorlabInputError):
    """Several input problems found at once (scene and protocol validation).

    ``str()`` gives the first problem plus a count, so the CLI still prints one
    line per problem list header; :attr:`problems` holds every problem.
    """

    def __init__(self, problems: Sequence[TorlabInputError]) -> None:
        if not problems:
            raise ValueError("ValidationErrors needs at least one problem")
        self.problems = list(problems)
        first = self.problems[0]
        super().__init__(first.message, path=first.path, line=first.line, key=first.key)

    def __str__(self) -> str:
        first = str(self.problems[0]) if hasattr(self, "problems") else super().__str__()
        n = len(getattr(self, "problems", []))
        return first if n <= 1 else f"{first} (and {n - 1} more problem{'s' if n > 2 else ''})"

    def lines(self) -> list[str]:
        """Every problem, one per line."""
        return [str(p) for p in self.problems]


class NumericalError(TorlabError):
    """A numerical method failed to meet its tolerance.  CLI exit code 3."""

    exit_code = 3


class ConvergenceError(NumericalError):
    """An iteration did not converge within its budget.

    Attributes
    ----------
    iterations
        Iterations performed.
    residual
        Last residual (in the iteration's own units, stated in the message).
    """

    def __init__(
        self, message: str, *, iterations: int | None = None, residual: float | None = None, **kw
    ) -> None:
        self.iterations = iterations
        self.residual = residual
        super().__init__(message, **kw)


class FitError(NumericalError):
    """A parameter fit failed or the data cannot determine the parameters."""


class TorlabWarning(UserWarning):
    """A value torlab accepts but a user should look at (possible but unusual).

    Issued with :func:`warnings.warn`; the CLI prints each as one line
    ``warning: <file>:<line>: <key>: <message>``.  Carries the same location
    as :class:`TorlabError`.
    """

    def __init__(self, message: str, *, path: str | os.PathLike[str] | None = None,
                 line: int | None = None, key: str | None = None) -> None:
        self.message = message
        self.path = None if path is None else os.fspath(path)
        self.line = line
        self.key = key
        super().__init__(self.__str__())

    def __str__(self) -> str:
        loc = "" if self.path is None else (self.path if self.line is None
                                            else f"{self.path}:{self.line}")
        if not loc and self.line is not None:
            loc = f"line {self.line}"
        return ": ".join([p for p in (loc, self.key) if p] + [self.message])
