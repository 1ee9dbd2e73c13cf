"""torlab's command-line interface: a thin typer layer over the library.

Every command lives in a submodule (``torlab.cli.fit`` ...) that imports only
typer at import time; numerical and plotting libraries are imported inside the
command functions, so ``torlab --help`` starts fast.  The instruments' command groups
(``torlab hpt reduce`` ...) are made from the instrument registry
(:mod:`torlab.cli.instruments`).

Error policy (see :mod:`torlab.errors`): a user error prints one line
``error: <file>:<line>: <key>: <message>`` on stderr and exits with code 2; so
does an environment error (a folder that cannot be written, a full disk); a
numerical failure exits with code 3; exit code 1 means a bug in torlab.
``--debug`` (anywhere on the command line) shows the traceback instead.

Warnings: torlab's own (:class:`~torlab.errors.TorlabWarning`, and warnings
issued from torlab's code) print as one line ``warning: ...`` each, once.
Warnings of the numerical libraries (numpy's "invalid value encountered" and
the like) are not shown: a result they would spoil is refused by torlab's own
checks (no NaN reaches a result file); ``--debug`` shows them.
"""

import sys
import warnings
from collections.abc import Sequence
from typing import Annotated, Any

import typer
from typer.core import TyperGroup

from torlab import __version__
from torlab.errors import TorlabError, ValidationErrors

__all__ = ["app", "main", "run"]

_STATE: dict[str, Any] = {"debug": False, "argv": None, "warnings": [], "hidden_warnings": []}


def _err(line: str) -> None:
    typer.echo(f"error: {_one_line(line)}", err=True)


def _one_line(text: str) -> str:
    return " ".join(str(text).split("\n")).strip()


def _split_debug(argv: list[str]) -> tuple[list[str], bool]:
    """Remove ``--debug`` wherever it is (before a ``--`` end-of-options marker)."""
    end = argv.index("--") if "--" in argv else len(argv)
    head = [a for a in argv[:end] if a != "--debug"]
    return head + argv[end:], len(head) != end


def _show_warning(message: Any, category: type, filename: str, lineno: int, file: Any = None,
                  line: str | None = None) -> None:
    """Print torlab's warnings as one line each (once); keep library warnings for --debug."""
    import os

    from torlab.errors import TorlabWarning

    text = _one_line(str(message))
    pkg = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ours = issubclass(category, TorlabWarning) or (
        issubclass(category, UserWarning) and os.path.abspath(filename).startswith(pkg + os.sep))
    if ours:
        if text not in _STATE["warnings"]:
            _STATE["warnings"].append(text)
            typer.echo(f"warning: {text}", err=True)
        return
    _STATE["hidden_warnings"].append((category.__name__, text, filename, lineno))
    if _STATE["debug"]:
        typer.echo(warnings.formatwarning(message, category, filename, lineno, line).rstrip(),
                   err=True)


class _TorlabGroup(TyperGroup):
    """Root command: turns errors into one line and an exit code."""

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,  # noqa: C901 (the program's one entry: each exit path of a command is a branch)
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:
        argv = list(sys.argv[1:] if args is None else args)
        _STATE["argv"] = argv
        argv, debug = _split_debug(argv)
        _STATE.update(debug=debug, warnings=[], hidden_warnings=[])
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("always")
                warnings.showwarning = _show_warning
                rv = super().main(argv, prog_name or "torlab", complete_var,
                                  standalone_mode=False, **extra)
        except (typer.Exit, typer.Abort) as e:
            code = getattr(e, "exit_code", 1)
            if standalone_mode:
                sys.exit(code)
            return code
        except ValidationErrors as e:
            if debug:
                raise
            for line in e.lines():
                _err(line)
            return _exit(e.exit_code, standalone_mode)
        except TorlabError as e:
            if debug:
                raise
            _err(str(e))
            return _exit(e.exit_code, standalone_mode)
        except KeyboardInterrupt:
            _err("interrupted")
            return _exit(130, standalone_mode)
        except (OSError, MemoryError) as e:  # the environment: permissions, disk, memory
            if debug:
                raise
            if isinstance(e, MemoryError):
                _err("not enough memory for this input (MemoryError)")
            else:
                where = f"{e.filename}: " if getattr(e, "filename", None) else ""
                _err(f"{where}{e.strerror or e}")
            return _exit(2, standalone_mode)
        except Exception as e:
            if hasattr(e, "format_message") and hasattr(e, "exit_code"):  # click usage errors
                if debug:
                    raise
                if type(e).__name__ == "NoArgsIsHelpError":  # help was printed: not an error
                    return _exit(0, standalone_mode)
                ctx = getattr(e, "ctx", None)
                where = f" (see '{ctx.command_path} --help')" if ctx is not None else ""
                _err(f"{e.format_message()}{where}")
                return _exit(int(e.exit_code), standalone_mode)
            if debug:
                raise
            _err(f"internal error: {type(e).__name__}: {e} -- please report it; "
                 "rerun with --debug for the traceback")
            return _exit(1, standalone_mode)
        code = rv if isinstance(rv, int) else 0
        return _exit(code, standalone_mode)


def _exit(code: int, standalone: bool) -> int:
    if standalone:
        sys.exit(code)
    return code


app = typer.Typer(
    cls=_TorlabGroup,
    name="torlab",
    help="Top-of-rail tribology lab toolkit: raw instrument logs to friction, fitted model "
    "parameters, predicted traction/Stribeck curves and reports.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"torlab {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
    debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks for errors and the "
                                        "numerical libraries' warnings (accepted anywhere on "
                                        "the command line).")] = False,
) -> None:
    """torlab: HPT, MTM/ETM/EHD2, optical tribometer and viscometer data; the thesis's
    boundary + EHL friction model; fits; protocols and reports."""
    _STATE["debug"] = _STATE["debug"] or debug


#: command modules, each with ``register(app)``
_COMMAND_MODULES = ("reduce", "instruments", "synth", "predict", "fit", "run", "bench",
                    "compare")


def _register() -> None:
    import importlib

    for name in _COMMAND_MODULES:
        importlib.import_module(f"torlab.cli.{name}").register(app)


_register()


#: BLAS/OpenMP thread variables set to 1 for a command unless the user set them
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _one_blas_thread(argv: Sequence[str]) -> None:
    """Start numpy's and scipy's BLAS with one thread (before they are imported).

    torlab's linear algebra is small (:mod:`torlab.threads`: its fits already run with
    one thread) and its parallel work runs in processes (:mod:`torlab.parallel`);
    OpenBLAS creating its thread pool at import costs a command about 0.1 s of
    start-up on a 2-core machine.  A variable the user set is kept; ``torlab bench``
    keeps the libraries' defaults, because it measures them.

    pydantic (which typer loads for every command) is told not to look for plugins:
    torlab uses none, and the search reads every installed package's metadata
    (about 30 ms).  matplotlib, when a figure is drawn, skips its 3-D toolkit
    (:func:`torlab.reports.plotting._mpl`).
    """
    import os

    os.environ.setdefault("PYDANTIC_DISABLE_PLUGINS", "__all__")
    from torlab.reports.plotting import LEAN_IMPORT

    LEAN_IMPORT[0] = True
    if list(argv[:1]) == ["bench"] or "numpy" in sys.modules:
        return
    for v in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(v, "1")
    if all(os.environ[v] == "1" for v in BLAS_THREAD_VARIABLES):
        from torlab.threads import STARTED_SINGLE_THREADED

        STARTED_SINGLE_THREADED[0] = True


def main(argv: Sequence[str] | None = None) -> int:
    """Run one ``torlab`` command line (``argv``, default ``sys.argv[1:]``); raises
    ``SystemExit`` with its exit code, as a console program does.  From a notebook or a
    script: ``main(["predict", "traction", "scene.yaml", "-o", "out"])``."""
    import time

    _STATE["t_start"] = time.perf_counter()
    _one_blas_thread(list(sys.argv[1:] if argv is None else argv))
    cmd = typer.main.get_command(app)
    return cmd.main(args=argv, prog_name="torlab", standalone_mode=True)


def run() -> None:
    """The ``torlab`` program (and ``python -m torlab``): :func:`main`, then a quick exit.

    When a command returns, its results are written and committed, its worker
    processes and progress threads stopped and its messages printed.  What is left of
    a normal interpreter shutdown is freeing every object and module one by one: 0.1 s
    after ``predict traction``, 0.25 s after a warm protocol run (a fifth of it).  The
    program flushes its output and ends the process at once instead (``os._exit``)
    with the command's exit code.  An exception that escapes :func:`main` (a bug)
    takes the normal way out, with its traceback.
    """
    import os

    try:
        main()
        code: Any = 0
    except SystemExit as e:
        code = e.code
    if code is None:
        code = 0
    elif not isinstance(code, int):  # sys.exit("message"): printed, exit code 1
        print(code, file=sys.stderr)
        code = 1
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (`torlab ... | head`)
            pass
    os._exit(code)
