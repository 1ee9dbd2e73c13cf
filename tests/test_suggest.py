"""'Did you mean' for misspelt keys, options, instruments and columns."""

from __future__ import annotations

import pytest
from conftest import ROOT, error_lines


def test_scene_unknown_key_suggests_the_known_one(tmp_path, cli):
    p = tmp_path / "s.yaml"
    p.write_text("contact:\n  lod: 20 kN\n  r1x: 350 mm\n  r1y: inf\n  r2x: inf\n  r2y: 300 mm\n"
                 "materials: {E1: 210 GPa, nu1: 0.28, E2: 210 GPa, nu2: 0.28}\n"
                 "boundry: {mu_c1: 0.3}\n")
    r = cli("predict", "traction", p, "-o", tmp_path / "o")
    assert r.exit_code == 2
    lines = error_lines(r)
    assert any(f"{p}:2: contact.lod: unknown key (did you mean 'load'?)" in ln for ln in lines)
    assert any("boundry: unknown key (did you mean 'boundary'?)" in ln for ln in lines)


def test_protocol_unknown_key_suggests_the_known_one():
    from torlab.errors import ValidationErrors
    from torlab.protocols.loader import load_protocol_text

    text = (ROOT / "protocols" / "paper_b.yaml").read_text(encoding="utf-8")
    with pytest.raises(ValidationErrors) as ei:
        load_protocol_text(text.replace("threshold:", "treshold:", 1), base=ROOT / "protocols")
    assert any("treshold: unknown key (did you mean 'threshold'?)" in ln for ln in ei.value.lines())


def test_option_and_command_suggestions(cli):
    r = cli("hpt", "reduce", "x.txt", "-o", "o", "--windw", "3")
    assert r.exit_code == 2 and "--window" in error_lines(r)[0]
    r = cli("reduc")
    assert r.exit_code == 2 and "reduce" in error_lines(r)[0]


def test_unknown_log_column_suggests(tmp_path):
    from torlab.errors import TorlabInputError
    from torlab.parsers.viscometer import read_viscometer

    src = (ROOT / "sample_data" / "visc" / "visc_ester_25C.txt").read_text(encoding="utf-8")
    lines = src.split("\n")
    i = next(k for k, s in enumerate(lines) if s.strip() and not s.startswith("#"))
    lines[i] = lines[i].replace("pressure", "presure", 1)
    p = tmp_path / "v.txt"
    p.write_text("\n".join(lines), encoding="utf-8")
    with pytest.raises(TorlabInputError, match="did you mean 'pressure'"):
        read_viscometer(p)


def test_xlsx_without_openpyxl_says_how_to_install(monkeypatch, tmp_path):
    import builtins

    from torlab.errors import TorlabInputError
    from torlab.instruments.output import write_xlsx

    real = builtins.__import__

    def no_openpyxl(name, *a, **k):
        if name == "openpyxl":
            raise ImportError(name)
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_openpyxl)
    with pytest.raises(TorlabInputError, match=r"pip install 'torlab\[xlsx\]'"):
        write_xlsx(tmp_path / "t.xlsx", {})
