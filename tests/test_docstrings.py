"""The docstrings of the physics, the fits and the public API: numpydoc, units in brackets,
the papers the models come from with their DOIs.

Read from the source (the module and function docstrings), so the check holds for code a
test run never executes.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re

import pytest
from conftest import ROOT

#: the units a docstring gives in brackets (``[m/s]``); written in parentheses after a
#: space (``speed (m/s)``) they are the old style this test keeps out
_UNITS = ("m", "mm", "um", "µm", "nm", "m/s", "mm/s", "Pa", "kPa", "MPa", "GPa", "Pa s",
          "Pa*s", "mPa s", "1/Pa", "1/GPa", "1/K", "K", "degC", "°C", "N", "kN", "s", "kg",
          "mg", "kg/m^3", "m^2", "m^2/J", "kg/J", "J", "W", "W/(m K)", "J/(kg K)", "m/Pa",
          "1/pass", "mg/m^2", "kg/m^2", "N m", "s/m")
_PAREN_UNIT = re.compile(r"(?<=\s)\((" + "|".join(re.escape(u) for u in
                                                  sorted(_UNITS, key=len, reverse=True)) + r")\)")

#: module -> the DOIs of the papers its model comes from (its ``References`` section)
PAPERS = {
    "torlab/model/fastsim.py": ["10.1080/00423118208968684", "10.1016/j.triboint.2021.106900",
                                "10.1016/S0043-1648(02)00120-3"],
    "torlab/model/strip.py": ["10.1080/00423118208968684"],
    "torlab/model/flash.py": ["10.1016/S0043-1648(02)00120-3"],
    "torlab/model/creep.py": ["10.1080/00423118208968684", "10.1007/978-94-015-7889-9"],
    "torlab/model/kalker.py": ["10.1007/978-94-015-7889-9"],
    "torlab/model/hertz.py": ["10.1515/crll.1882.92.156"],
    "torlab/model/ehl.py": ["10.1115/1.3453074"],
    "torlab/model/asperity.py": ["10.1098/rspa.1966.0242"],
    "torlab/model/loadshare.py": ["10.1243/PIME_PROC_1970_185_069_02"],
    "torlab/model/mixed.py": ["10.1016/j.triboint.2021.106900"],
    "torlab/model/polach.py": ["10.1016/j.wear.2004.03.046"],
    "torlab/model/viscosity.py": ["10.2475/ajs.s3-45.266.87"],
    "torlab/model/removal.py": ["10.1016/j.jestch.2022.101100"],
    "torlab/model/retention.py": ["10.1016/j.jestch.2022.101100"],
    "torlab/model/amount.py": ["10.1177/09544097221138374"],
    "torlab/model/exact/__init__.py": ["10.1007/978-94-015-7889-9"],
    "torlab/fit/layer.py": ["10.1177/09544097221138374"],
    "torlab/fit/traction.py": ["10.1016/j.triboint.2021.106900"],
    "torlab/fit/viscosity.py": ["10.2475/ajs.s3-45.266.87"],
    "torlab/fit/film.py": ["10.1115/1.3453074"],
    "torlab/fit/polach.py": ["10.1016/j.wear.2004.03.046"],
    "torlab/fit/removal.py": ["10.1016/j.jestch.2022.101100"],
    "torlab/fit/crossing.py": ["10.1177/09544097221138374"],
}


def _files() -> list:
    return sorted([*(ROOT / "torlab" / "model").rglob("*.py"),
                   *(ROOT / "torlab" / "fit").rglob("*.py"), ROOT / "torlab" / "api.py"])


def _docstrings(path) -> list[tuple[str, str]]:
    """``(where, docstring)`` of the module and of every function and class in it."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []
    for n in ast.walk(tree):
        if isinstance(n, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            doc = ast.get_docstring(n, clean=False)
            if doc:
                out.append((getattr(n, "name", "module"), doc))
    return out


def test_units_are_in_brackets():
    """``speed [m/s]``, not ``speed (m/s)``."""
    bad = []
    for p in _files():
        for where, doc in _docstrings(p):
            bad += [f"{p.relative_to(ROOT)}:{where}: ({m.group(1)})"
                    for m in _PAREN_UNIT.finditer(doc)]
    assert bad == []


def test_the_check_sees_a_unit_in_parentheses():
    assert _PAREN_UNIT.findall("Rolling speed (m/s), film (m) and G(s) of point(s)") == \
        ["m/s", "m"]


@pytest.mark.parametrize("module", sorted(PAPERS))
def test_models_cite_their_papers(module):
    """A model that comes from a paper says so in a numpydoc ``References`` section, with
    the DOI."""
    doc = ast.get_docstring(ast.parse((ROOT / module).read_text(encoding="utf-8"))) or ""
    assert "\nReferences\n----------\n" in doc
    refs = doc.split("\nReferences\n----------\n", 1)[1]
    for doi in PAPERS[module]:
        assert f"https://doi.org/{doi}" in refs.replace("\n   ", " ").replace(" ", ""), doi


def test_public_names_are_documented():
    """Every module of the physics and the fits, and every name in its ``__all__`` (and the
    public API's), has a docstring."""
    import torlab.fit
    import torlab.model

    names = ["torlab.api"]
    for pkg in (torlab.model, torlab.fit):
        names += [m.name for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + ".")]
    missing = []
    for name in names:
        mod = importlib.import_module(name)
        if not (mod.__doc__ or "").strip():
            missing.append(name)
        for n in getattr(mod, "__all__", []):
            obj = getattr(mod, n, None)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and not (obj.__doc__ or "").strip():
                missing.append(f"{name}.{n}")
    assert missing == []
