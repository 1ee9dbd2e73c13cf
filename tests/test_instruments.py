"""The instrument registry: every module declares what the commands and protocols are made
from, reading the registry loads no numerical library, and fits take their inputs from one
place whatever form they come in."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT

HPT = ROOT / "sample_data" / "hpt"


def _instruments():
    from torlab.instruments import REGISTRY

    return list(REGISTRY.values())


@pytest.mark.parametrize("inst", _instruments(), ids=lambda i: i.name)
def test_every_instrument_declares_itself(inst):
    from torlab.instruments.plugin import CHECKS
    from torlab.units import KINDS, RANGES

    m = inst.impl()
    assert m.NAME == inst.name and m.TITLE and m.FILES
    assert inst.extensions and all(e.startswith(".") for e in inst.extensions)
    for fn in ("detect", "read", "reduce", "figures", "collect", "display"):
        assert callable(getattr(m, fn)), fn
    for name, o in inst.options.items():
        assert o.kind in KINDS or o.kind in ("number", "text", "flag", "choice", "path",
                                             "paths", "object"), name
        assert not o.check or o.check in CHECKS, name
        assert not o.quantity or o.quantity in RANGES, name
        assert (o.kind == "choice") == bool(o.choices), name
        assert o.help.endswith((".", ")")), name
        if o.unit:  # the default shown in its unit converts back to the default
            from torlab.units import to_si

            assert to_si(o.shown_default(), o.kind) == pytest.approx(o.default), name
    for alias, preset in inst.aliases.items():
        assert alias not in [i.name for i in _instruments()]
        assert set(preset) <= set(inst.options)


def test_command_and_section_names_are_unique():
    names = [i.command.name for i in _instruments() if i.command is not None]
    assert len(names) == len(set(names))
    assert {"hpt", "mtm", "optical", "visc"} <= set(names)


def test_the_registry_loads_no_numerical_library():
    """``torlab --help`` reads every declaration: the modules import their libraries inside
    their functions."""
    code = ("import sys, torlab.instruments as i; [o.shown_default() for x in "
            "i.REGISTRY.values() for o in x.options.values()]; "
            "print(sorted(m for m in ('numpy', 'pandas', 'scipy', 'matplotlib', 'pint', "
            "'pydantic', 'torlab.units') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("unit, kind", [("um", "length"), ("mm", "length"), ("s", "time"),
                                        ("ms", "time"), ("K", "temperature_difference"),
                                        ("kPa", "pressure"), ("GPa", "pressure"), ("N", "force")])
def test_shown_defaults_scale_as_the_unit_table(unit, kind):
    from torlab.instruments.plugin import _prefix_scale
    from torlab.units import parse_unit_factor

    assert _prefix_scale(unit, kind) == pytest.approx(parse_unit_factor(unit, kind)[0],
                                                      rel=1e-15)


def test_folders_are_searched_for_every_instruments_endings():
    from torlab.instruments import data_suffixes

    assert set(data_suffixes()) >= {".txt", ".csv", ".tsv", ".dat", ".log"}


# ------------------------------------------------------------------ fit inputs, one place
def test_hpt_curves_are_the_same_from_a_log_its_reduction_and_its_csv(tmp_path):
    """A raw log, its Reduction, its HptResult and the reduced CSV written by 'torlab hpt
    reduce' give the same curve (the CSV at its 10 significant digits)."""
    from torlab import reduce_file
    from torlab.instruments.measured import hpt_curves

    log = HPT / "hpt_OFM1_4uL_25C.txt"
    red = reduce_file(log)
    red.tables["reduced"].to_csv(tmp_path / "r.csv", index=False, float_format="%.10g")
    from_log, from_red, from_res, from_csv = hpt_curves(
        [log, red, red.detail, tmp_path / "r.csv"])
    for c in (from_red, from_res):
        np.testing.assert_array_equal(c.tau, from_log.tau)
        np.testing.assert_array_equal(c.u_raw, from_log.u_raw)
        assert c.sigma == from_log.sigma
    np.testing.assert_allclose(from_csv.tau, from_log.tau, rtol=1e-9)
    np.testing.assert_allclose(from_csv.u_raw, from_log.u_raw, rtol=1e-9, atol=1e-15)
    assert from_csv.meta["source"] == "r.csv"


def test_hpt_curves_subtract_the_compliance_once(tmp_path):
    """A raw log is reduced with the compliance (the curve recovers it from the reduced
    columns); a reduced curve gets it as the model's rig term: both models see the same
    rig displacement."""
    from torlab import reduce_file
    from torlab.instruments.measured import hpt_curves

    log = HPT / "hpt_OFM1_4uL_25C.txt"
    comp = "0.012 um/MPa"
    raw, = hpt_curves(log, compliance=comp)
    plain = reduce_file(log, compliance=None).tables["reduced"]
    reduced, = hpt_curves(plain, compliance=comp)
    tau = np.linspace(0.0, 2e8, 5)
    np.testing.assert_allclose(raw.compliance(tau) - raw.compliance(np.zeros(1))[0],
                               0.012e-12 * tau, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(reduced.compliance(tau), 0.012e-12 * tau, rtol=1e-12)
    assert raw.meta["compliance"] == reduced.meta["compliance"] == "linear 0.012 um/MPa"


def test_hpt_curves_refuse_a_table_that_is_not_a_curve(tmp_path):
    from torlab.errors import TorlabInputError
    from torlab.instruments.measured import hpt_curves

    f = tmp_path / "other.csv"
    pd.DataFrame({"a": [1, 2], "b": [3, 4]}).to_csv(f, index=False)
    with pytest.raises(TorlabInputError, match="reduced HPT curve"):
        hpt_curves([f])


# ------------------------------------------------------------------ made from the declarations
@pytest.mark.parametrize("inst", [i for i in _instruments() if i.command is not None],
                         ids=lambda i: i.name)
def test_each_instrument_command_offers_its_options_once_declared(cli, inst):
    """``torlab <name> reduce --help`` shows every option the module declares for the command
    line, with the module's help and the default in its unit."""
    import re

    r = cli(inst.command.name, "reduce", "--help")
    assert r.exit_code == 0, r.output
    text = re.sub(r"[│\s]+", " ", r.output)
    for name, o in inst.options.items():
        flag = o.cli_flag(name)
        if flag is None:
            assert f"--{name.replace('_', '-')} " not in text
            continue
        assert f"{flag} " in text, flag
        assert " ".join(o.help.split()[:6]) in text, flag
        if o.unit:
            assert f"[default: {o.shown_default()}]" in text, flag


def test_the_reduce_commands_call_the_public_api_only():
    """The modules behind ``torlab reduce`` and the instruments' commands reach the library
    through :mod:`torlab.api` (and read the registry's declarations)."""
    import ast

    allowed = ("torlab.api", "torlab.cli", "torlab.errors", "torlab.instruments")
    for mod in ("reduce", "instruments", "_reduce"):
        tree = ast.parse((ROOT / "torlab" / "cli" / f"{mod}.py").read_text(encoding="utf-8"))
        used = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
        used |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
        mine = {u for u in used if u and u.startswith("torlab")}
        assert all(any(u == a or u.startswith(a + ".") for a in allowed) for u in mine), \
            (mod, mine)
        # of the registry, declarations only: no reduction or reader is called from here
        calls = {n.attr if isinstance(n, ast.Attribute) else getattr(n, "id", "")
                 for c in ast.walk(tree) if isinstance(c, ast.Call) for n in [c.func]}
        assert not calls & {"reduce_file", "reduce_batch", "reduce_files", "expand_inputs",
                            "write_reductions", "read_file"}, mod


TOY = '''
from pathlib import Path
from torlab.instruments.plugin import Command, Option
from torlab.instruments.reduction import Reduction

NAME = "toy"
TITLE = "toy rig"
FILES = "toy logs"
EXTENSIONS = (".csv",)
OPTIONS = {
    "scale": Option("length", 1e-3, "A length the x column is multiplied by.",
                    check="positive", unit="mm"),
    "label": Option("text", None, "A label of the run."),
}
COMMAND = Command("toy", "Toy rig.", "Reduce toy logs.", "Toy logs.", what="toy log")


def detect(head):
    return "toy log" if head.startswith("# toy") else ""


def read(path, **_):
    import pandas as pd
    return pd.read_csv(path, comment="#"), {"source": str(path)}


def reduce(path, **opts):
    df, meta = read(path)
    df = df.assign(x_m=df["x"] * opts["scale"])
    return Reduction(NAME, str(path), {"scaled": df}, {"n": len(df), "label": opts["label"]},
                     meta=meta)


def figures(red):
    return {}


def collect(reds, options):
    import pandas as pd
    return {"summary": pd.DataFrame([r.key_numbers for r in reds])}, {}, {}


def display(reds):
    return [("toy", [r.key_numbers for r in reds], {})]
'''


@pytest.fixture
def toy(tmp_path, monkeypatch):
    """A made-up instrument: one module and one registry entry."""
    from torlab import instruments

    (tmp_path / "toy_with_command.py").write_text(TOY)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "toy_with_command", raising=False)
    inst = instruments.Instrument("toy_with_command")
    monkeypatch.setitem(instruments.REGISTRY, "toy", inst)
    (tmp_path / "run1.csv").write_text("# toy log\nx\n1\n2\n")
    return inst


def test_a_new_instrument_gets_its_command(toy, tmp_path):
    import typer
    from typer.testing import CliRunner

    from torlab.cli.instruments import register

    app = typer.Typer()
    register(app)
    r = CliRunner().invoke(app, ["toy", "reduce", "--help"])
    assert r.exit_code == 0 and "A length the x column" in r.output and "1 mm" in r.output
    r = CliRunner().invoke(app, ["toy", "reduce", str(tmp_path / "run1.csv"), "--scale", "2 mm",
                                 "--label", "first", "-o", str(tmp_path / "o"), "--no-plot"])
    assert r.exit_code == 0, r.output
    out = pd.read_csv(tmp_path / "o" / "run1_scaled.csv")
    assert out["x_m"].tolist() == pytest.approx([0.002, 0.004])
    assert pd.read_csv(tmp_path / "o" / "summary.csv")["label"].tolist() == ["first"]
    r = CliRunner().invoke(app, ["toy", "reduce", str(tmp_path), "-o", str(tmp_path / "p")])
    assert r.exit_code == 0, r.output  # the folder gives the toy logs


def test_a_new_instrument_gets_its_protocol_section(toy, tmp_path):
    from pydantic import ValidationError

    from torlab.protocols.schema import section_model

    model = section_model(toy)
    sec = model.model_validate({"files": "run1.csv", "scale": "3 mm"},
                               context={"base": tmp_path})
    assert sec.options() == {"scale": pytest.approx(3e-3), "label": None}
    assert sec.input_files() == []
    with pytest.raises(ValidationError, match="scal"):
        model.model_validate({"files": "run1.csv", "scal": 1}, context={"base": tmp_path})
    with pytest.raises(ValidationError, match="greater than 0"):
        model.model_validate({"files": "run1.csv", "scale": "-1 mm"}, context={"base": tmp_path})
