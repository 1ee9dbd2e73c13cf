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


def _cells(md: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", md, flags=re.S)


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
    for name in ("fit_hpt", "reduce_files", "predict_traction", "run_protocol"):
        assert f'id="{name}"' in page, name
