"""The public API: lazy top level, unit strings, the notebook example, the API reference."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest
from conftest import ROOT

DOCS = ROOT / "docs"


def test_import_torlab_is_light_and_names_load_lazily():
    # a fresh interpreter: importing torlab (and building the CLI) imports no numerical library
    code = ("import sys, torlab, torlab.cli; "
            "print(sorted(m for m in ('numpy', 'pandas', 'scipy', 'matplotlib', 'pint') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    import torlab

    assert callable(torlab.reduce_file) and callable(torlab.fit_hpt)
    assert {"reduce_file", "fit_hpt", "predict_traction", "run_protocol"} <= set(dir(torlab))
    with pytest.raises(AttributeError):
        torlab.no_such_thing  # noqa: B018


def test_the_commands_annotations_are_evaluated_once_not_at_every_start():
    """typer builds every command from its function's annotations each time the program
    starts (and each time a test invokes it); annotations kept as strings are evaluated
    anew each time, more than half of that work (64 ms against 28 ms a start, measured on
    a slow host). Every command's annotations are objects, evaluated once when its module
    is imported."""
    import inspect

    from torlab.cli import app

    def callbacks(t):
        for c in t.registered_commands:
            yield c.callback
        for g in t.registered_groups:
            yield from callbacks(g.typer_instance)
        if t.registered_callback is not None:
            yield t.registered_callback.callback

    found = list(callbacks(app))
    assert len(found) > 20
    strings = {f"{f.__module__}.{f.__name__}": k for f in found
               for k, v in inspect.get_annotations(f).items() if isinstance(v, str)}
    assert not strings


def test_unit_strings_equal_si_numbers():
    import numpy as np

    import torlab

    f = ROOT / "sample_data" / "hpt" / "hpt_OFM1_4uL_25C.txt"
    a = torlab.reduce_file(f, window="20 um")
    b = torlab.reduce_file(f, window=20e-6)
    assert a.key_numbers["f_window"] == b.key_numbers["f_window"]
    c = torlab.reduce_file(f, window="0.04 mm")
    assert c.key_numbers["window_m"] == pytest.approx(40e-6)
    scene = ROOT / "protocols" / "scenes" / "wheel_rail_tab54.yaml"
    p1 = torlab.predict_traction(scene, "0:2 %:5")
    p2 = torlab.predict_traction(scene, np.linspace(0, 0.02, 5))
    assert p1.table["mu"].tolist() == pytest.approx(p2.table["mu"].tolist(), rel=1e-12)


def test_unknown_option_says_did_you_mean():
    import torlab
    from torlab.errors import TorlabInputError

    f = ROOT / "sample_data" / "hpt" / "hpt_OFM1_4uL_25C.txt"
    with pytest.raises(TorlabInputError, match=r"unknown option 'windw'.*did you mean 'window'"):
        torlab.reduce_file(f, windw="20 um")
    with pytest.raises(TorlabInputError, match="did you mean 'hpt'"):
        torlab.reduce_file(f, "hpx")


def test_a_fit_object_gives_the_band_its_params_file_gives(tmp_path):
    """``predict_*(..., params=fit)`` carries the fit's covariance exactly as the fit's
    params.yaml does: the same band, column for column, and the same band summary."""
    import numpy as np

    import torlab
    from torlab.fit.result import FitResult

    names = ("mu_c1", "mu_c2", "L_mue", "L_mup")
    sd = np.array([0.004, 0.005, 0.6e-6, 1.5e-6])
    corr = np.array([[1, 0.6, 0.2, 0], [0.6, 1, 0, 0.5], [0.2, 0, 1, 0.1], [0, 0.5, 0.1, 1]])
    fit = FitResult.from_covariance(  # what fit_hpt returns, without the curve's 2 s fit
        "layer_hpt", names, np.array([0.16, 0.26, 6e-6, 12e-6]), corr * np.outer(sd, sd),
        dof=30, log_scale=names, residual_norm=1e6, n_points=400, warnings=[], data=None,
        residual_unit="Pa")
    path = tmp_path / "params.yaml"
    fit.to_params(path)
    scene = ROOT / "protocols" / "scenes" / "optical_paper_a_dry.yaml"
    a = torlab.predict_traction(scene, "0:2 %:6", params=fit)
    b = torlab.predict_traction(scene, "0:2 %:6", params=path)
    assert "mu_low95" in a.table and a.summary["band"]["method"] != "not computed"
    for col in ("mu", "mu_low95", "mu_high95"):
        np.testing.assert_array_equal(a.table[col].to_numpy(), b.table[col].to_numpy())
    assert a.summary["band"] == b.summary["band"]
    assert a.trend == b.trend
    # the object and the file together: two independent blocks, as two files give
    two = torlab.load_scene(scene, path, path)
    c = torlab.predict_traction(scene, "0:2 %:6", params=[fit, path])
    assert len(two.fit.covariances) == len(torlab.api._scene(scene, [fit, path]).fit.covariances)
    assert c.summary["band"] == torlab.predict_traction(two, "0:2 %:6").summary["band"]


def _cells(md: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", md, flags=re.S)


@pytest.mark.slow  # every cell of the notebook, end to end
def test_notebook_example_runs(monkeypatch):
    """Every code cell of docs/notebook.md, in order, in one namespace (as a notebook would)."""
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(ROOT)
    cells = _cells((DOCS / "notebook.md").read_text(encoding="utf-8"))
    assert len(cells) >= 5
    ns: dict = {}
    for i, cell in enumerate(cells):
        try:
            exec(compile(cell, f"docs/notebook.md cell {i + 1}", "exec"), ns)
        except Exception as e:  # name the cell
            raise AssertionError(f"docs/notebook.md cell {i + 1} failed: {e!r}") from e
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.mark.slow
def test_api_reference_builds_without_warnings(tmp_path):
    pytest.importorskip("pdoc", reason="the docs extra (pdoc) is not installed: pip install "
                        "'torlab[docs]' to build the API reference")
    sys.path.insert(0, str(DOCS))
    try:
        import build_api
    finally:
        sys.path.remove(str(DOCS))
    problems = build_api.build(tmp_path)
    assert problems == []
    page = (tmp_path / "torlab" / "api.html").read_text(encoding="utf-8")
    for name in ("fit_hpt", "reduce_files", "predict_traction", "run_protocol", "predict_creep",
                 "creep_table", "fit_polach", "fit_removal", "predict_retention",
                 "predict_sweep"):
        assert f'id="{name}"' in page, name
    page = (tmp_path / "torlab" / "parallel.html").read_text(encoding="utf-8")
    for name in ("get_executor", "use", "SerialExecutor", "ProcessExecutor", "DaskExecutor"):
        assert f'id="{name}"' in page, name


TOY = '''
from pathlib import Path
from torlab.instruments import Option
from torlab.instruments.reduction import Reduction

NAME = "toy"
TITLE = "toy rig"
FILES = "toy logs"
EXTENSIONS = (".csv",)
OPTIONS = {"scale": Option("length", 1e-3, "A length.", check="positive")}


def detect(head):
    return "toy log" if head.startswith("# toy") else ""


def read(path, **_):
    import pandas as pd
    return pd.read_csv(path, comment="#"), {"source": str(path)}


def reduce(path, **opts):
    df, meta = read(path)
    df = df.assign(x_m=df["x"] * opts["scale"])
    return Reduction(NAME, str(path), {"scaled": df}, {"n": len(df)}, meta=meta)


def figures(red):
    return {}


def collect(reds, options):
    import pandas as pd
    return {"summary": pd.DataFrame([r.key_numbers for r in reds])}, {}, {}


def display(reds):
    return [("toy", [r.key_numbers for r in reds], {})]
'''


def test_a_new_instrument_is_one_module_and_one_registry_entry(tmp_path, monkeypatch, cli):
    """DEVELOPERS.md's claim: a module and a registry entry, and torlab reduce detects it."""
    import pandas as pd

    from torlab import instruments

    (tmp_path / "toy_instrument.py").write_text(TOY)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(instruments.REGISTRY, "toy", instruments.Instrument("toy_instrument"))
    f = tmp_path / "run1.csv"
    f.write_text("# toy log\nx\n1\n2\n")
    r = cli("reduce", f, "-O", "scale=2 mm", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    assert "run1.csv: read as toy (toy log)" in r.output
    out = pd.read_csv(tmp_path / "o" / "run1_scaled.csv")
    assert out["x_m"].tolist() == pytest.approx([0.002, 0.004])
    assert pd.read_csv(tmp_path / "o" / "summary.csv")["n"].tolist() == [2]
