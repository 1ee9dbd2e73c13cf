"""``torlab <instrument> reduce``: one command group per instrument of the registry.

Each group is made from the instrument's declaration (:mod:`torlab.instruments.plugin`):
its ``COMMAND`` gives the group's name and help, the reduce command's help and its files
argument; its ``OPTIONS`` give the command's options, with their help, their flag and
their default in the unit users write (``--window`` ``[default: 20 um]``).  The command
calls the public API (:func:`torlab.api.reduce_to_folder`) through the reduce loop every
reduce command shares (:mod:`torlab.cli._reduce`).  Nothing here names an instrument: a
new one gets its command from its module.
"""

import inspect
from pathlib import Path
from typing import Annotated, Any

import typer

from torlab.cli._common import (
    ForceOpt,
    FormatsOpt,
    JobsOpt,
    NoPlotOpt,
    OutOpt,
    QuietOpt,
    SchedulerOpt,
    XlsxOpt,
)

__all__ = ["reduce_command_for", "register"]

#: the options every reduce command has: name, annotated type, default
_COMMON: tuple[tuple[str, Any, Any], ...] = (
    ("force", ForceOpt, False), ("xlsx", XlsxOpt, False), ("no_plot", NoPlotOpt, False),
    ("formats", FormatsOpt, None), ("jobs", JobsOpt, None), ("scheduler", SchedulerOpt, None),
    ("quiet", QuietOpt, False),
)
#: parameter names of the instrument's own options (apart from the common ones)
_PREFIX = "opt_"


def register(root: typer.Typer) -> None:
    """Add a ``torlab <name>`` group with its ``reduce`` command for every instrument of the
    registry that declares a command."""
    from torlab.instruments import REGISTRY

    for inst in REGISTRY.values():
        cmd = inst.command
        if cmd is None:
            continue
        app = typer.Typer(help=cmd.help, no_args_is_help=True)
        app.command("reduce")(reduce_command_for(inst))
        root.add_typer(app, name=cmd.name)


def _option_type(o: Any) -> tuple[Any, Any]:
    """The command-line type and default of an option: a quantity as text in its unit
    (``"20 um"``), a number as a float, a flag, paths; the rest as text."""
    if o.kind == "flag":
        return bool, False
    if o.kind == "number":
        t: Any = float
    elif o.kind == "path":
        t = Path
    elif o.kind == "paths":
        return list[Path] | None, None
    else:  # a quantity (unit string), choice, text, object
        t = str
    default = o.shown_default() if o.is_quantity else o.default
    return (t if default is not None else t | None), default


def reduce_command_for(inst: Any) -> Any:
    """The ``reduce`` command function of an instrument (a typer command: its signature and
    annotations are made from the declaration)."""
    cmd = inst.command
    flags = {k: f for k, o in inst.options.items() if (f := o.cli_flag(k)) is not None}
    params = [
        inspect.Parameter(cmd.argument, inspect.Parameter.KEYWORD_ONLY,
                          annotation=Annotated[list[Path], typer.Argument(help=cmd.inputs)]),
        inspect.Parameter("out", inspect.Parameter.KEYWORD_ONLY, annotation=OutOpt),
    ]
    for name, flag in flags.items():
        o = inst.options[name]
        t, default = _option_type(o)
        params.append(inspect.Parameter(_PREFIX + name, inspect.Parameter.KEYWORD_ONLY,
                                        annotation=Annotated[t, typer.Option(flag, help=o.help)],
                                        default=default))
    params += [inspect.Parameter(n, inspect.Parameter.KEYWORD_ONLY, annotation=a, default=d)
               for n, a, d in _COMMON]

    def reduce_cmd(**kw: Any) -> None:
        from torlab.cli._reduce import reduce_command

        opts = {}
        for name in flags:
            v = kw[_PREFIX + name]
            if v is not None and not (inst.options[name].kind == "flag" and not v):
                opts[name] = v
        every = any(o.reads_any and opts.get(k) is not None for k, o in inst.options.items())
        reduce_command(kw[cmd.argument], kw["out"], instrument=inst.name, force=kw["force"],
                       xlsx=kw["xlsx"], what=cmd.what, options=opts, every_file=every,
                       flags=flags, formats=kw["formats"], jobs=kw["jobs"],
                       scheduler=kw["scheduler"], quiet=kw["quiet"], no_plot=kw["no_plot"])

    reduce_cmd.__signature__ = inspect.Signature(params)  # type: ignore[attr-defined]
    reduce_cmd.__annotations__ = {p.name: p.annotation for p in params}
    reduce_cmd.__doc__ = cmd.reduce
    reduce_cmd.__name__ = reduce_cmd.__qualname__ = f"{cmd.name}_reduce"
    return reduce_cmd
