"""torlab's command-line interface: a thin typer layer over the library.

Every command lives in a submodule (``torlab.cli.hpt`` ...) that imports only
typer at import time; numerical and plotting libraries are imported inside the
command functions, so ``torlab --help`` starts fast.

Error policy (see :mod:`torlab.errors`): a user error prints one line
``error: <file>:<line>: <key>: <message>`` on stderr and exits with code 2; a
numerical failure exits with code 3; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Annotated, Any

import typer
from typer.core import TyperGroup

from torlab import __version__
from torlab.errors import TorlabError, ValidationErrors

__all__ = ["app", "main"]

_STATE: dict[str, Any] = {"debug": False, "argv": None}


def _err(line: str) -> None:
    typer.echo(f"error: {line}", err=True)


class _TorlabGroup(TyperGroup):
    """Root command: turns errors into one line and an exit code."""

    def main(self, args: Sequence[str] | None = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True,
             **extra: Any) -> Any:
        argv = list(sys.argv[1:] if args is None else args)
        debug = "--debug" in argv
        _STATE["debug"] = debug
        _STATE["argv"] = argv
        try:
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
    debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks for errors.")] = False,
) -> None:
    """torlab: HPT, MTM/ETM/EHD2, optical tribometer and viscometer data; the thesis's
    boundary + EHL friction model; fits; protocols and reports."""
    _STATE["debug"] = debug


#: command modules, each with ``register(app)``
_COMMAND_MODULES = ("reduce", "hpt", "synth", "predict", "fit", "run", "bench", "mtm", "optical",
                    "visc")


def _register() -> None:
    import importlib

    for name in _COMMAND_MODULES:
        importlib.import_module(f"torlab.cli.{name}").register(app)


_register()


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point (``torlab``)."""
    cmd = typer.main.get_command(app)
    return cmd.main(args=argv, prog_name="torlab", standalone_mode=True)
