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
    from torlab.outputs import write_xlsx

    real = builtins.__import__

    def no_openpyxl(name, *a, **k):
        if name == "openpyxl":
            raise ImportError(name)
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_openpyxl)
    with pytest.raises(TorlabInputError, match=r"pip install 'torlab\[xlsx\]'"):
        write_xlsx(tmp_path / "t.xlsx", {})


# ------------------------------------------------------------------------------------------
# the commands and protocol sections added since: did you mean, and '20 C' -> write degC
# ------------------------------------------------------------------------------------------
RET = ROOT / "sample_data" / "retention"
HPT = ROOT / "sample_data" / "hpt"
DRY = ROOT / "protocols" / "scenes" / "optical_paper_a_dry.yaml"


def _one_line(r) -> str:
    lines = error_lines(r)
    assert r.exit_code == 2 and len(lines) == 1 and "Traceback" not in r.output, r.output
    return lines[0]


@pytest.mark.parametrize(("option", "value", "flag", "hint"), [
    ("--laws", "zero_ordr", "--laws", "did you mean 'zero_order'?"),
    ("--law", "first_ordr", "--law", "did you mean 'first_order'?"),
    ("--transfer", "fitt", "--transfer", "did you mean 'fit'?"),
    ("--skip", "autoo", "--skip", "did you mean 'auto'?"),
    ("--track-radius", "20 C", "--track-radius", "not a length"),
])
def test_fit_removal_answers_with_its_options(cli, tmp_path, option, value, flag, hint):
    r = cli("fit", "removal", RET / "mtm_retention_1uL.txt", "--hpt", RET, "--compliance",
            RET / "rig_compliance.csv", option, value, "-o", tmp_path / "o")
    line = _one_line(r)
    assert f"{flag}: " in line and hint in line, line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(("kw", "key"), [
    ({"laws": ["zero_ordr"]}, "laws"), ({"law": "first_ordr"}, "law"),
    ({"transfer": "fitt"}, "transfer"), ({"transfer": 1.5}, "transfer"),
    ({"skip": "autoo"}, "skip"), ({"track_radius": "20 C"}, "track_radius"),
    ({"duration": "5 kg"}, "duration"), ({"application_time": "x"}, "application_time"),
])
def test_fit_removal_names_a_bad_option_before_any_fit(monkeypatch, kw, key):
    """A misspelt option is named before the layer's HPT fits (or anything else) run."""
    import torlab.fit.amount as amount
    from torlab import api
    from torlab.errors import TorlabInputError

    def no_fit(*a, **k):
        raise AssertionError("the HPT fits ran before the options were checked")

    monkeypatch.setattr(amount, "amount_layer", no_fit)
    with pytest.raises(TorlabInputError) as e:
        api.fit_removal(RET / "mtm_retention_1uL.txt", [RET], **kw)
    assert e.value.key == key, e.value


@pytest.mark.parametrize(("args", "hint"), [
    (("fit", "temperature", HPT / "hpt_OFM1_4uL_25C.txt", "--selection", "tst"),
     "did you mean 'test'?"),
    (("fit", "visc", HPT / "hpt_OFM1_4uL_25C.txt", "--law", "barrus"), "did you mean 'barus'?"),
    (("fit", "traction", DRY, ROOT / "sample_data" / "optical" / "dry_traction_rough.csv",
      "--fix", "L_mupp=2 um"),
     "did you mean 'L_mup'?"),
    (("predict", "traction", DRY, "--formats", "pgn"), "did you mean 'png'?"),
    (("predict", "table", DRY, "--formats", "svg"), "No such option: --formats"),
    (("predict", "traction", DRY, "--scheduler", "tpc://host:8786"), "did you mean 'tcp'?"),
    (("predict", "traction", DRY, "--scheduler", "localhost:8786x"), "not a scheduler address"),
    (("predict", "traction", DRY, "--creepag", "0.1"), "--creepage"),
    (("predict", "retention", DRY, "--amount", "4 mg", "--passs", "3"), "--passes"),
    (("fit", "polach", DRY, "--sped", "5 m/s"), "--speed"),
    (("predict", "traction", DRY, "--swep", "60 s"), "--sweep"),
    (("hpt", "reduce", HPT / "hpt_OFM1_4uL_25C.txt", "--job", "2"), "--jobs"),
])
def test_newer_commands_suggest(cli, tmp_path, args, hint):
    line = _one_line(cli(*args, "-o", tmp_path / "o"))
    assert hint in line, line


def test_protocol_retention_section_suggests():
    from torlab.errors import ValidationErrors
    from torlab.protocols.loader import load_protocol_text

    text = (ROOT / "protocols" / "retention.yaml").read_text(encoding="utf-8")
    for old, new, hint in (
            ("    laws: [zero_order", "    laws: [zero_ordr", "did you mean 'zero_order'?"),
            ("    transfer: 1 ", "    transfer: fitt ", "did you mean 'fit'?"),
            ("    transfer: 1 ", "    transfr: 1 ", "did you mean 'transfer'?"),
            ("      pass_interval: 0.5 s", "      pass_intervall: 0.5 s",
             "did you mean 'pass_interval'?"),
            ("    temperature: 25 degC", "    temperature: 25 C", "write degC")):
        assert old in text
        with pytest.raises(ValidationErrors) as ei:
            load_protocol_text(text.replace(old, new, 1), base=ROOT / "protocols")
        assert any(hint in ln for ln in ei.value.lines()), (new, ei.value.lines())


def test_scene_choice_suggests(tmp_path, cli):
    p = tmp_path / "s.yaml"
    p.write_text(DRY.read_text(encoding="utf-8") + "thermal: {slip_velocity: locl}\n")
    r = cli("predict", "traction", p, "-o", tmp_path / "o")
    assert r.exit_code == 2
    assert any("'locl' is not allowed" in ln and "did you mean 'local'?" in ln
               for ln in error_lines(r))


def test_twenty_C_is_answered_with_degC_everywhere(cli, tmp_path):
    import torlab
    from torlab.errors import TorlabInputError

    r = cli("fit", "temperature", HPT / "hpt_OFM1_4uL_25C.txt", "--reference-temperature",
            "20 C", "-o", tmp_path / "o")
    assert "--reference-temperature" in _one_line(r) and "write degC" in _one_line(r)
    scene = tmp_path / "s.yaml"
    scene.write_text(DRY.read_text(encoding="utf-8").replace("ambient_temperature: 22 degC",
                                                             "ambient_temperature: 22 C"))
    r = cli("predict", "traction", scene, "-o", tmp_path / "p")
    assert r.exit_code == 2 and any("kinematics.ambient_temperature" in ln and "write degC" in ln
                                    for ln in error_lines(r))
    with pytest.raises(TorlabInputError, match="write degC"):
        torlab.fit_temperature([HPT / "hpt_OFM1_4uL_25C.txt"], reference_temperature="20 C")
    with pytest.raises(TorlabInputError, match="write degC"):
        torlab.fit_temperature([HPT / "hpt_OFM1_4uL_25C.txt"], ["20 C"])
    with pytest.raises(TorlabInputError, match="write degC"):
        torlab.fit_removal(RET / "mtm_retention_1uL.txt", [RET / "hpt_dry_25C.txt"],
                           temperature="25 C")
