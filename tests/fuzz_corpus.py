"""A seeded corpus of bad inputs for every reader, scene and protocol, run through the CLI.

:func:`build_corpus` derives the cases at test time from the sample data, the files in
``tests/data`` and, where present, the real PCS exports (never copied into the repository):
truncation, byte flips, changed delimiters, BOM / CRLF / CR / Latin-1, NaN / inf / empty
cells, huge and negative values, time going backwards, duplicated header lines, unit
swaps, binary files, FIFOs, folders, devices; for YAML (scenes, protocols, column maps):
changed values and units, deleted and duplicated lines, alias bombs, recursive aliases,
deep nesting.  :func:`run_case` runs one case in-process through typer's ``CliRunner``
with a per-case time limit and classifies the outcome; ``tests/test_fuzz_corpus.py``
asserts that no case ends in a traceback, exit code 1, a hang or a raw warning.
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import re
import signal
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
SAMPLE = ROOT / "sample_data"
REAL_PCS = ROOT.parent / "shared" / "real-data" / "pcs"
REAL_TRIOS = ROOT.parent / "shared" / "real-data" / "rheometer" / "trios_demo.txt"
SCENES = ROOT / "protocols" / "scenes"

#: per-case time limit (s): a case running longer is a hang
TIME_LIMIT = 60


@dataclass
class Case:
    """One corpus case: a reader, a mutation, and the file content (or a special path)."""

    reader: str
    source: str
    mutation: str
    data: bytes | None = None
    special: str | None = None  # fifo, folder, device, missing, symlink-device
    extra: dict[str, bytes] = field(default_factory=dict)  # companion files by name
    args: tuple[str, ...] = ()  # options replacing (or added to) the command's defaults
    #: for a case of a reported problem: the outcome it must have (ok, input_error) and a
    #: text its error line (or, when ok, its console output or warnings) must hold
    expect: str | None = None
    expect_in: str = ""
    expect_not_in: str = ""  # a text its output must not hold (a false note)
    slow: bool = False  # a whole fit or run: in the whole corpus only, not the quick sample

    @property
    def name(self) -> str:
        return f"{self.reader}:{self.source}:{self.mutation}"


@dataclass
class Outcome:
    """What a case did."""

    case: Case
    exit_code: int | None
    kind: str  # ok, input_error, numerical_error, bug, traceback, hang, leaked_warning
    detail: str = ""
    hidden_warnings: int = 0


# ----------------------------------------------------------------------------- sources
def _small_optical() -> bytes:
    import numpy as np

    from torlab.synth.optical import OpticalCondition, OpticalTest, write_optical_log

    conds = tuple(OpticalCondition(0.5, s, 90.0, 0.6) for s in (-0.02, 0.0, 0.02))
    buf = io.StringIO()
    write_optical_log(buf, OpticalTest("f", "traction", "rough", "water", conds),
                      lambda U, s: 0.05 * np.tanh(np.asarray(s) / 0.01),
                      lambda U: 30e-9 * np.asarray(U) ** 0.67, seed=1)
    return buf.getvalue().encode()


def _head(path: Path, n: int) -> bytes:
    lines = path.read_bytes().split(b"\n")
    return b"\n".join(lines[:n]) + b"\n"


def sources() -> dict[str, list[tuple[str, bytes]]]:
    """Reader -> [(source name, bytes)] of valid inputs to mutate."""
    hpt = [("hand.txt", (DATA / "hpt" / "hand.txt").read_bytes()),
           ("hpt_OFM1_4uL_25C", (SAMPLE / "hpt" / "hpt_OFM1_4uL_25C.txt").read_bytes())]
    pcs = [(p.name, p.read_bytes()) for p in sorted((DATA / "pcs").glob("*_quirks.txt"))
           if not p.name.startswith("ehd2")]
    pcs.append(("mtm_TOR-A_5uL", (SAMPLE / "mtm" / "mtm_TOR-A_5uL.txt").read_bytes()))
    ehd2 = [("ehd2_quirks.txt", (DATA / "pcs" / "ehd2_quirks.txt").read_bytes())]
    if REAL_PCS.is_dir():
        for name, n in (("demo_5.txt", None), ("ETM_slim_mapper.txt", 3000)):
            p = REAL_PCS / name
            if p.is_file():
                pcs.append((f"real:{name}", p.read_bytes() if n is None else _head(p, n)))
        if (REAL_PCS / "demo_3.txt").is_file():
            ehd2.append(("real:demo_3.txt", (REAL_PCS / "demo_3.txt").read_bytes()))
    optical = [("small_traction", _small_optical()),
               ("setpoints_torque_crlf", (DATA / "optical" / "setpoints_torque_crlf.csv")
                .read_bytes()),
               ("film_thickness_smooth", _head(SAMPLE / "optical" / "film_thickness_smooth.csv",
                                               700))]
    visc = [("fall_column_crlf", (DATA / "visc" / "fall_column_crlf.txt").read_bytes()),
            ("visc_ester_head", _head(SAMPLE / "visc" / "visc_ester_25C.txt", 1500))]
    scene = [(p.name, p.read_bytes()) for p in sorted(SCENES.glob("*.yaml"))]
    trios = [("hand.txt", (DATA / "trios" / "hand.txt").read_bytes())]
    if REAL_TRIOS.is_file():  # the first step and the start of the second
        trios.append(("real:trios_demo.txt", _head(REAL_TRIOS, 330)))
    return {"hpt": hpt, "pcs": pcs, "ehd2": ehd2, "optical": optical, "visc": visc,
            "trios": trios, "scene": scene, "protocol": [("small.yaml", PROTOCOL.encode())],
            "hpt_map": [("rig2.yaml", HPT_MAP.encode())]}


PROTOCOL = """\
version: 1
name: fuzz
title: "fuzz protocol"
products:
  OFM1: {label: "oil-based FM 1", density: 930 kg/m^3}
data:
  hpt:
    files: [hpt_*.txt]
    window: 20 um
fits:
  hpt_layers:
    amounts: [4 uL]
    temperature: 25 degC
    temperature_tolerance: 2 K
    temperature_coefficients: false
reports:
  amount:
    temperature: 25 degC
    band: [0.15, 0.25]
    threshold: 0.15
    curve: interpolation
  traction:
    creepage: {from: 0, to: 0.05, points: 6}
    curves:
      - label: "{set}"
        scene: scene.yaml
        params: ["hpt:*"]
"""

HPT_MAP = """\
delimiter: ';'
decimal: ','
header_line: 2
skip_lines_after_header: 1
columns:
  time: {name: Zeit, unit: s}
  normal_force: {name: Fn, unit: kN}
  torque: {name: M, unit: N*m}
  encoder_angle: {name: phi_enc, unit: deg}
  motor_angle: {name: motor_steps, scale: 0.00045 deg}
metadata:
  r1: 3 mm
  r2: 6 mm
  product: other-rig
"""

HPT_MAP_CSV = (b"Export of rig 2\nZeit;Fn;M;phi_enc;motor_steps\ns;kN;Nm;deg;counts\n"
               + b"".join(f"{k},0;63,6172512;{min(50 * k, 100)};{k / 100:.2f};{20 * k}\n"
                          .replace(".", ",").encode() for k in range(12)))


def retention_sources() -> tuple[dict[str, bytes], bytes]:
    """The retention commands' inputs: the HPT layer parameter files of a product's amount
    series (``torlab fit hpt`` output of the synthetic truth layer, name -> YAML) and a
    removal parameter file fitted to the shipped time tests with that layer."""
    from torlab.fit.removal import fit_removal
    from torlab.model.amount import AmountLayer
    from torlab.reduce.time_test import read_time_test
    from torlab.synth.retention import law_layer_fits, mtm_scene
    from torlab.yamlio import dump_yaml

    fits, dry = law_layer_fits()
    layer_files = {f"layer_{i}.yaml": dump_yaml(f.to_yaml_dict()).encode()
                   for i, f in enumerate([*fits, dry])}
    layer = AmountLayer.from_fits(fits, dry)
    tests = [read_time_test(p, density=930.0)
             for p in sorted((SAMPLE / "retention").glob("mtm_retention_*.txt"))]
    res = fit_removal(tests, layer, mtm_scene(), laws=("first_order",))
    return layer_files, dump_yaml(res.to_yaml_dict()).encode()


# ----------------------------------------------------------------------------- mutations
_NUM = re.compile(rb"(?<![\w.])[+-]?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?(?![\w.])")
UNIT_SWAPS = [(b"[N]", b"[m]"), (b"[kN]", b"[kg]"), (b"[mm]", b"[bar]"), (b"[s]", b"[furlong]"),
              (b"[deg]", b"[N]"), (b"(N)", b"(mm)"), (b"(mm/s)", b"(kg)"), (b"(%)", b"(Nx)"),
              (b"[degC]", b"[C]"), (b"degC", b"K"), (b"[MPa]", b"[um]"), (b"mm", b"km"),
              (b" uL", b" kg"), (b" mm", b""), (b"kN", b"N")]
HUGE = [b"1e300", b"-1e300", b"1e-300", b"-5", b"0", b"NaN", b"inf", b"-inf", b"", b"1e30"]


def _lines(b: bytes) -> list[bytes]:
    return b.split(b"\n")


def _data_lines(ls: list[bytes]) -> list[int]:
    """Indices of lines that look like data rows (mostly numbers and separators)."""
    out = []
    for i, ln in enumerate(ls):
        s = ln.strip()
        if s and not s.startswith(b"#") and re.fullmatch(rb"[0-9eE.+\-,;\t ]+", s) \
                and len(_NUM.findall(s)) >= 2:
            out.append(i)
    return out


def mutate_text(data: bytes, rng: random.Random) -> list[tuple[str, bytes]]:
    """Every text mutation of ``data`` once (random positions from ``rng``)."""
    out: list[tuple[str, bytes]] = []
    n = len(data)
    ls = _lines(data)
    dl = _data_lines(ls)
    out.append(("truncate", data[: rng.randrange(max(1, n))]))
    b = bytearray(data)
    for _ in range(rng.randint(1, 6)):
        b[rng.randrange(n)] = rng.randrange(256)
    out.append(("byte_flip", bytes(b)))
    for a, c in ((b",", b";"), (b"\t", b","), (b",", b"\t")):
        if a in data:
            out.append((f"delim_{a!r}->{c!r}", data.replace(a, c)))
            break
    out.append(("bom_crlf", b"\xef\xbb\xbf" + data.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n")))
    out.append(("cr_only", data.replace(b"\r\n", b"\n").replace(b"\n", b"\r")))
    try:
        out.append(("latin1", data.decode("utf-8").encode("latin-1", errors="replace")
                    .replace(b"deg", b"\xb0")))
    except UnicodeDecodeError:
        pass
    if dl:
        for tag in ("nan_cell", "huge_cell"):
            i = rng.choice(dl)
            nums = list(_NUM.finditer(ls[i]))
            m = rng.choice(nums)
            v = rng.choice(HUGE[5:9]) if tag == "nan_cell" else rng.choice([*HUGE[:5], b"1e30"])
            l2 = list(ls)
            l2[i] = ls[i][: m.start()] + v + ls[i][m.end():]
            out.append((f"{tag}={v.decode() or 'empty'}", b"\n".join(l2)))
        if len(dl) > 3:
            i, j = rng.sample(dl[1:], 2)
            l2 = list(ls)
            l2[i], l2[j] = l2[j], l2[i]
            out.append(("time_backwards", b"\n".join(l2)))
        l2 = list(ls)
        i = rng.choice(dl)
        l2[i] = b",".join([b"1e300"] * 8)
        out.append(("row_of_huge", b"\n".join(l2)))
        hdr = dl[0] - 1
        if hdr >= 0:
            l2 = list(ls)
            l2.insert(hdr + 1, ls[hdr])
            out.append(("duplicated_header", b"\n".join(l2)))
        data_rows = set(dl)
        l2 = [ln for k, ln in enumerate(ls) if k not in data_rows]
        out.append(("no_data_rows", b"\n".join(l2)))
        k0 = rng.choice(dl)
        out.append(("deleted_block", b"\n".join(ls[:k0] + ls[k0 + rng.randint(1, 30):])))
    heads = [i for i, ln in enumerate(ls) if ln.startswith(b"#") and b":" in ln]
    if heads:
        i = rng.choice(heads)
        l2 = list(ls)
        l2.insert(i + 1, ls[i])
        out.append(("duplicated_key", b"\n".join(l2)))
        numeric = [i for i in heads if _NUM.search(ls[i].split(b":", 1)[1])]
        for v in (b"0", b"-3", b"1e300", b"250", b"20 C", b"-300 degC", b"nan"):
            if numeric:
                i = rng.choice(numeric)
                key = ls[i].split(b":", 1)[0]
                l2 = list(ls)
                l2[i] = key + b": " + v
                out.append((f"header_value={v.decode()}", b"\n".join(l2)))
    swaps = [(a, c) for a, c in UNIT_SWAPS if a in data]
    if swaps:
        a, c = rng.choice(swaps)
        out.append((f"unit_swap_{a.decode()}->{c.decode() or 'none'}", data.replace(a, c, 1)))
    out.append(("binary", bytes(rng.randrange(256) for _ in range(2048))))
    out.append(("nul_inside", data[: n // 2] + b"\x00" + data[n // 2:]))
    out.append(("empty", b""))
    out.append(("whitespace", b"  \n\n\t\n"))
    out.append(("long_line", data[: n // 3] + b"9" * 200_000 + b"\n" + data[n // 3:]))
    return out


YAML_VALUES = ["0", "-1", "1e300", "1e300 m", ".nan", ".inf", "x", "300 K", "20 C", "-300 degC",
               "[1, 2]", "{a: 1}", "true", '""', "~", "1e-300", "2 K"]


def mutate_yaml(data: bytes, rng: random.Random, *, values: int = 8) -> list[tuple[str, bytes]]:
    """YAML mutations of ``data``: values, units, lines, aliases, nesting, size."""
    out: list[tuple[str, bytes]] = []
    ls = _lines(data)
    kv = [i for i, ln in enumerate(ls) if re.match(rb"^\s*[A-Za-z_][\w]*:\s*\S", ln)
          and not ln.lstrip().startswith(b"#")]
    for v in rng.sample(YAML_VALUES, min(values, len(YAML_VALUES))):
        i = rng.choice(kv)
        key = ls[i].split(b":", 1)[0]
        l2 = list(ls)
        l2[i] = key + b": " + v.encode()
        out.append((f"value[{key.strip().decode()}]={v}", b"\n".join(l2)))
    units = [(b" kN", b" km"), (b" mm", b" kg"), (b" GPa", b" s"), (b" degC", b" C"),
             (b" m/s", b" m/s^2"), (b" mPa*s", b" Pa"), (b" um", b""), (b" uL", b" N")]
    for a, c in units:
        if a in data:
            out.append((f"unit{a.decode()}->{c.decode() or 'none'}", data.replace(a, c, 1)))
    i = rng.choice(kv)
    out.append(("deleted_line", b"\n".join(ls[:i] + ls[i + 1:])))
    out.append(("duplicated_line", b"\n".join([*ls[:i + 1], ls[i], *ls[i + 1:]])))
    out.append(("unknown_key", data + b"\nsurprise: 1\n"))
    out.append(("tab_indent", data.replace(b"\n  ", b"\n\t", 1)))
    out.append(("truncate", data[: rng.randrange(max(1, len(data)))]))
    b = bytearray(data)
    for _ in range(3):
        b[rng.randrange(len(b))] = rng.randrange(256)
    out.append(("byte_flip", bytes(b)))
    bomb = b"a: &a [x,x,x,x,x,x,x,x,x]\n" + b"".join(
        f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]\n".encode()
        for p, c in zip("abcdefgh", "bcdefghi", strict=True))
    out.append(("alias_bomb", bomb))
    out.append(("alias_bomb_appended", data + b"\n" + bomb.replace(b"a:", b"zz_a:", 1)))
    out.append(("recursive_alias", b"contact: &c\n  load: [*c]\n" + data))
    out.append(("deep_nesting", b"a: " + b"[" * 5000 + b"]" * 5000 + b"\n"))
    out.append(("huge_document", b"x: [" + b"1, " * 1_500_000 + b"1]\n"))
    out.append(("long_integer", data + b"\nzz: " + b"9" * 6000 + b"\n"))
    out.append(("not_a_mapping", b"- 1\n- 2\n"))
    out.append(("two_documents", data + b"\n---\n" + data))
    return out


# ----------------------------------------------------------------------------- the corpus
def build_corpus(seed: int = 20240613) -> list[Case]:
    """The fixed-seed corpus (same cases on every run)."""
    rng = random.Random(seed)
    cases: list[Case] = []
    src = sources()
    for reader in ("hpt", "pcs", "ehd2", "optical", "visc"):
        for name, data in src[reader]:
            for mut, b in mutate_text(data, rng):
                cases.append(Case(reader, name, mut, b))
    for name, data in src["hpt"][1:2]:  # a sample log: long enough to fit
        for mut, b in mutate_text(data, rng)[::3]:
            cases.append(Case("fit_hpt", name, mut, b))
    for name, data in src["scene"]:
        for mut, b in mutate_yaml(data, rng):
            cases.append(Case("scene", name, mut, b))
        if b"lubricant:" in data:
            for mut, b in mutate_yaml(data, rng, values=4)[:5]:
                cases.append(Case("scene_stribeck", name, mut, b))
    scene = (SCENES / "wheel_rail_tab54.yaml").read_bytes()
    # the documented scene without L_mue/L_mup (their defaults) and with thermal:
    nolayer = b"\n".join(ln for ln in scene.split(b"\n") if b"L_mu" not in ln)
    cases.append(Case("scene", "wheel_rail_tab54.yaml", "no_L_mue_L_mup", nolayer))
    for name, data in src["protocol"]:
        for mut, b in mutate_yaml(data, rng, values=6):
            cases.append(Case("protocol", name, mut, b, extra={"scene.yaml": scene}))
        cases.append(Case("protocol", name, "as_written", data, extra={"scene.yaml": scene}))
        cases.append(Case("protocol", name, "product_../../x", data,
                          extra={"scene.yaml": scene, "__product__": b"../../x <img src=x>"}))
        bomb = dict(mutate_yaml(scene, random.Random(1)))["alias_bomb_appended"]
        cases.append(Case("protocol", name, "scene_alias_bomb", data, extra={"scene.yaml": bomb}))
    for name, data in src["hpt_map"]:
        for mut, b in mutate_yaml(data, rng, values=5):
            cases.append(Case("hpt_map", name, mut, b))
    for reader in ("hpt", "pcs", "optical", "visc", "scene", "protocol"):
        for special in ("fifo", "folder", "device", "missing", "symlink_device"):
            cases.append(Case(reader, "-", special, special=special))
    # the retention commands (their own generator: the cases above stay as they were)
    rng2 = random.Random(seed + 16)
    layer_files, removal = retention_sources()
    tt = (SAMPLE / "retention" / "mtm_retention_1uL.txt").read_bytes()
    for mut, b in mutate_text(tt, rng2)[::2]:
        cases.append(Case("fit_removal", "mtm_retention_1uL", mut, b, extra=layer_files))
    for mut, b in mutate_yaml(removal, rng2, values=6)[::2]:
        cases.append(Case("predict_retention", "removal.yaml", mut, b))
    for special in ("fifo", "device", "missing"):
        cases.append(Case("fit_removal", "-", special, special=special, extra=layer_files))
    cases += _more_commands(seed, src, removal)
    cases += _trios_cases(seed, src)
    cases += reported_cases(layer_files)
    return cases


#: what a planted file in the work folder must still hold after a case (a write outside OUT)
VICTIM = b"precious\n"


def reported_cases(layer_files: dict[str, bytes] | None = None) -> list[Case]:
    """The reported problems, each with the outcome it must have (``Case.expect``).

    Environment cases plant files next to OUT before the command runs (``extra`` key
    ``__plant__``); every case's run checks that ``victim.txt`` in the work folder, when
    there is one, still holds :data:`VICTIM` (:func:`run_case`).  Their exact numbers are
    tested in ``tests/test_misread_inputs.py``, ``tests/test_reader_layer.py`` and
    ``tests/test_output_links.py``.
    """
    hpt_raw = (SAMPLE / "hpt" / "hpt_OFM1_4uL_25C.txt").read_bytes()
    out: list[Case] = []

    def case(reader: str, source: str, mutation: str, data: bytes, expect: str, text: str = "",
             **kw: Any) -> None:
        out.append(Case(reader, source, mutation, data, expect=expect, expect_in=text, **kw))

    # no write outside OUT, through any link planted next to it
    for plant, text in (("lock_symlink", "lock file"), ("lock_dangling", "lock file"),
                        ("lock_hardlink", "lock file"), ("lock_fifo", "lock file"),
                        ("out_symlink", "symbolic link"), ("out_read_only", "is read-only")):
        case("hpt", "hpt_OFM1_4uL_25C", f"planted_{plant}", hpt_raw, "input_error", text,
             extra={"__plant__": plant.encode()})
    # one field more or fewer, a decimal comma, a decimal point where a comma is declared
    hpt, visc = _text_lines(hpt_raw), _text_lines((SAMPLE / "visc" / "visc_ester_25C.txt")
                                                  .read_bytes())
    visc[62] = "5.00,3,4196,0.07,25.04"
    case("visc", "visc_ester_25C", "decimal_comma_line_63", _join(visc), "input_error",
         ":63: expected 4 fields separated by ',' like the column header, found 5")
    for mut, row in (("extra_field", hpt[29] + ",5"), ("missing_field", hpt[29].rsplit(",", 1)[0])):
        h2 = list(hpt)
        h2[29] = row
        case("hpt", "hpt_OFM1_4uL_25C", mut, _join(h2), "input_error", ":30: expected 5 fields")
    comp = _text_lines((SAMPLE / "hpt_paper_b" / "rig_compliance.csv").read_bytes())
    i = next(k for k, t in enumerate(comp) if t.startswith("170.0,"))
    comp[i] = comp[i].replace("170.0,2.", "170.0,2,")
    case("hpt_compliance", "rig_compliance.csv", "decimal_comma", hpt_raw, "input_error",
         f"comp.csv:{i + 1}: expected 2 fields", extra={"comp.csv": _join(comp)})
    rig = HPT_MAP_CSV.decode()
    case("hpt_map", "rig2.yaml", "csv_extra_field", HPT_MAP.encode(), "input_error",
         "rig2.csv:6: expected 5 fields",
         extra={"__csv__": rig.replace("2,0;63", "2,0;63;7", 1).encode()})
    case("hpt_map", "rig2.yaml", "csv_point_in_decimal_comma_file", HPT_MAP.encode(),
         "input_error", "'409.00' has a decimal point",
         extra={"__csv__": rig.replace("4,0;", "409.00;", 1).encode()})
    case("hpt_map", "rig2.yaml", "as_written_decimal_comma", HPT_MAP.encode(), "ok")
    for key, value, text in (("delimiter", '""', "delimiter: must be one character"),
                             ("header_line", "x", "header_line: must be a whole number"),
                             ("skip_lines_after_header", "x", "skip_lines_after_header: must"),
                             ("skip_lines_after_header", "1e9", "skip_lines_after_header: must"),
                             ("skip_lines_after_header", "-300", "skip_lines_after_header: must"),
                             ("skip_lines_after_header", "1000000000", "skipped after it")):
        m = re.sub(rf"(?m)^{key}:.*$", f"{key}: {value}", HPT_MAP)
        case("hpt_map", "rig2.yaml", f"{key}={value}", m.encode(), "input_error", text)
    # line ends and encodings
    opt = (SAMPLE / "optical" / "film_thickness_smooth.csv").read_bytes()
    head, _, body = opt.partition(b"\ntime")
    for name, end in (("header_cr_cr_lf", b"\r\r\n"), ("header_lone_cr", b"\r")):
        case("optical", "film_thickness_smooth", name,
             head.replace(b"\n", end) + end + b"time" + body, "ok")
    text = hpt_raw.decode("utf-8")
    case("hpt", "hpt_OFM1_4uL_25C", "utf16_bom", text.replace("\n", "\r\n").encode("utf-16"),
         "ok")
    mtm = (SAMPLE / "mtm" / "mtm_TOR-A_5uL.txt").read_bytes()
    case("pcs", "mtm_TOR-A_5uL", "utf16_bom", mtm.decode("utf-8").encode("utf-16"), "ok")
    strib = _text_lines((SAMPLE / "optical" / "stribeck_smooth.csv").read_bytes())
    case("optical", "stribeck_smooth", "header_line_70kB",
         _join([*strib[:2], "# x_long: " + "n" * 70_000, *strib[2:]]), "ok")
    h = next(k for k, t in enumerate(strib) if t.startswith("time"))
    cells = strib[h + 5].split(",")
    film, load = list(strib), list(strib)
    film[h + 5] = ",".join([*cells[:-1], "   "])
    load[h + 5] = ",".join([*cells[:4], "   ", *cells[5:]])
    case("optical", "stribeck_smooth", "spaces_in_film_cell", _join(film), "ok")
    case("optical", "stribeck_smooth", "spaces_in_load_cell", _join(load), "input_error",
         f":{h + 6}: column 'normal_load [N]': a cell of spaces")
    # runs cut off, two runs in one file
    tt = (SAMPLE / "retention" / "mtm_retention_1uL.txt").read_bytes()
    tl = _text_lines(tt)
    end = next(k for k, t in enumerate(tl) if "completed normally" in t)
    crashed = _join(tl[: end - 300])
    case("pcs", "mtm_retention_1uL", "cut_off_time_test", crashed, "input_error",
         "the test stopped during this time test", args=("--after-application",))
    case("pcs", "mtm_retention_1uL", "cut_off_time_test_duration", crashed, "ok",
         "the test stopped during step 1", args=("--after-application", "--duration", "10 min"))
    ehd2 = _text_lines((DATA / "pcs" / "ehd2_quirks.txt").read_bytes())
    two = _join(ehd2 + ehd2)
    for reader in ("ehd2", "pcs"):
        case(reader, "ehd2_quirks.txt", "two_runs", two, "input_error",
             f":{len(ehd2) + 1}: a second run starts here")
    # numbers out of reach, loads of zero
    hh = next(k for k, t in enumerate(hpt) if t.startswith("time"))
    big = [",".join([f"{1e308:.6e}", *t.split(",")[1:]]) if k > hh and t else t
           for k, t in enumerate(hpt)]
    case("hpt", "hpt_OFM1_4uL_25C", "time_column_1e308", _join(big), "input_error",
         "too large to be a measurement")
    ml = _text_lines(mtm)
    mh = next(k for k, t in enumerate(ml) if t.startswith("Step Time"))
    j = ml[mh].split("\t").index("Ball Load (N)")
    m308, m0 = list(ml), list(tl)
    for k in range(mh + 1, len(ml)):
        c = ml[k].split("\t")
        if len(c) > j:
            c[j] = "1.0e308"
            m308[k] = "\t".join(c)
    case("pcs", "mtm_TOR-A_5uL", "ball_load_1e308", _join(m308), "input_error",
         "column 'Ball Load (N)': 1.0e308 is too large")
    th = next(k for k, t in enumerate(tl) if t.startswith("Step Time"))
    tj = tl[th].split("\t").index("Ball Load (N)")
    for k in range(th + 1, th + 40):
        c = tl[k].split("\t")
        c[tj] = "0"
        m0[k] = "\t".join(c)
    case("fit_removal", "mtm_retention_1uL", "ball_load_0_in_39_rows", _join(m0), "ok",
         "39 samples with a load of zero or less", slow=True,
         extra=dict(layer_files if layer_files is not None else retention_sources()[0]))
    # PCS numbers in exponent notation: no false "appears twice"
    q = []
    for t in _text_lines((DATA / "pcs" / "mtm_quirks.txt").read_bytes()):
        c = t.split("\t")
        if len(c) > 30 and c[0][:1].isdigit():
            v = float(c[1]) * 1.004
            c[1], c[34] = f"{v:.1E}", f"{v:.5f}"
            t = "\t".join(c)
        q.append(t)
    case("pcs", "mtm_quirks.txt", "exponent_notation", _join(q), "ok",
         expect_not_in="appears twice")
    # scenes and YAML
    rough = (SCENES / "optical_paper_a_rough.yaml").read_bytes()
    case("scene_stribeck", "optical_paper_a_rough.yaml", "hardness_1e-6_MPa",
         rough.replace(b"hardness: 6 GPa", b"hardness: 1e-6 MPa"), "ok")
    pb = (SCENES / "mtm_paper_b.yaml").read_bytes()
    case("scene_stribeck", "mtm_paper_b.yaml", "roelands_eta0_below_eta_inf",
         pb.replace(b"eta0: 65 mPa*s", b"eta0: 0.01 mPa*s"), "input_error",
         "lubricant: eta0: the Roelands law (Z) needs eta0 above")
    case("scene", "wheel_rail_tab54.yaml", "list_of_100001_values",
         (SCENES / "wheel_rail_tab54.yaml").read_bytes() + b"\nx_list: [" + b"1, " * 100_001
         + b"1]\n", "input_error", "more than 100000 values in one YAML file")
    # protocol results that would overwrite each other: refused before any work
    two = ("version: 1\nname: days\ndata:\n  hpt:\n    files:\n{files}reports:\n"
           "  amount: {{curve: interpolation}}\n")
    case("protocol_files", "two_days.yaml", "one_file_name_in_two_folders",
         two.format(files="      - day1/hpt.txt\n      - day2/hpt.txt\n").encode(),
         "input_error", "have one name ('hpt')")
    case("protocol_files", "two_days.yaml", "labels_run_1_and_run/1",
         two.format(files="      - {path: day1/hpt.txt, label: run 1}\n"
                          "      - {path: day2/hpt.txt, label: run/1}\n").encode(),
         "input_error", "('run_1')")
    scene = (SCENES / "wheel_rail_tab54.yaml").read_bytes()
    case("protocol", "small.yaml", "products_OFM 1_and_OFM_1", PROTOCOL.encode(), "input_error",
         "would write one parameter file (fits/hpt_OFM_1.yaml)", slow=True,
         extra={"scene.yaml": scene, "__products__": b"OFM 1|OFM_1"})
    # cache keys that cannot be trusted: not used, said, nothing reused; a FIFO never hangs
    for kind, text in (("readable", "can be read or written by others"),
                       ("zeros", "is not random"), ("fifo", "not a regular file")):
        case("protocol", "small.yaml", f"cache_key_{kind}", PROTOCOL.encode(), "ok",
             text, slow=True, extra={"scene.yaml": scene, "__key__": kind.encode()})
    # a log over the size bound: refused before it is read
    case("hpt", "-", "over_1_GiB_sparse", b"", "input_error", "larger than 1024 MiB",
         extra={"__sparse__": b"1"})
    # a Ball Load of zero in every row, or in some, of an MTM step: said with the lines
    ml0 = _text_lines(mtm)
    n_rows = next(k for k in range(mh + 1, len(ml0)) if not ml0[k][:1].isdigit())
    for which, rows in (("all", range(mh + 1, n_rows)), ("some", range(mh + 1, mh + 4))):
        m = list(ml0)
        for k in rows:
            c = m[k].split("\t")
            c[j] = "0"
            m[k] = "\t".join(c)
        case("pcs", "mtm_TOR-A_5uL", f"ball_load_0_in_{which}_rows", _join(m), "ok",
             f"Ball Load is zero or negative in {len(rows)} of {n_rows - mh - 1} rows "
             f"(lines {mh + 2}-{rows[-1] + 1})")
    # values inside the reader's bound that no test produces
    hj = hpt[hh].split(",").index("arm_force [N]")
    arm = [",".join(c if i != hj else "9e99" for i, c in enumerate(t.split(",")))
           if k > hh and t else t for k, t in enumerate(hpt)]
    case("hpt", "hpt_OFM1_4uL_25C", "arm_force_9e99", _join(arm), "input_error",
         "the friction coefficient over the window is 7.58e+96, which no contact has")
    mc = list(ml0)
    c = mc[mh + 3].split("\t")
    c[len(c) - 1 - ml0[mh].split("\t")[::-1].index("Traction Coeff (-)")] = "9e99"
    mc[mh + 3] = "\t".join(c)
    case("pcs", "mtm_TOR-A_5uL", "traction_coeff_9e99", _join(mc), "input_error",
         f":{mh + 4}: column 'Traction Coeff': 9e+99 is not possible")
    sf = list(strib)
    c = sf[h + 5].split(",")
    c[-1] = "9e99"
    sf[h + 5] = ",".join(c)
    case("optical", "stribeck_smooth", "film_thickness_9e99", _join(sf), "input_error",
         f":{h + 6}: film_thickness: 9e+99 nm is not possible for a film thickness")
    out += _trios_reader_cases() + _law_cases(hpt_raw)
    return out


def _trios_reader_cases() -> list[Case]:
    """The TRIOS export through the reader layer: each row rule with its outcome."""
    hand = (DATA / "trios" / "hand.txt").read_bytes()
    row = b"25\t50\t0.05\t30\t25.0\t-300"
    out = []
    for mut, new, expect, text in (
            ("extra_field", row + b"\t7", "input_error", ":12: expected 6 fields separated by tab"),
            ("missing_field", row.rsplit(b"\t", 1)[0], "input_error", "(a truncated row?)"),
            ("decimal_comma_cell", row.replace(b"0.05", b"0,05"), "input_error",
             ":12: column 'Viscosity': '0,05' has a decimal comma"),
            ("cell_of_spaces", row.replace(b"0.05", b"   "), "input_error",
             ":12: column 'Viscosity': a cell of spaces"),
            ("empty_cell", row.replace(b"0.05", b""), "input_error",
             ":12: column 'Viscosity': empty value"),
            ("nan_cell", row.replace(b"0.05", b"nan"), "input_error",
             "'nan' is not a finite number"),
            ("stress_1e308", b"1e308" + row[2:], "input_error",
             ":12: column 'Stress': 1e308 dyne/cm² is too large to be a measurement")):
        out.append(Case("trios", "hand.txt", mut, hand.replace(row, new, 1), expect=expect,
                        expect_in=text))
    text = hand.decode("utf-8")
    for mut, b in (("utf16_bom", text.encode("utf-16")),
                   ("cr_only", hand.replace(b"\r\n", b"\r")),
                   ("cr_cr_lf", hand.replace(b"\r\n", b"\r\r\n")),
                   ("header_line_70kB", hand.replace(b"Operator\t", b"Comment\t" + b"n" * 70_000
                                                     + b"\r\nOperator\t"))):
        out.append(Case("trios", "hand.txt", mut, b, expect="ok"))
    return out


#: a layer parameter file as 'torlab fit hpt --law linear' writes it (its boundary section)
LINEAR_PARAMS = "boundary:\n  law: linear\n  mu_c1: 0.21\n  L_mue: 31 um\n  k_mu: 50 1/m\n"


def _law_cases(hpt_raw: bytes) -> list[Case]:
    """``fit hpt --law`` and ``--resolution``; parameter files whose law and parameters do
    not go together (``predict traction SCENE PARAMS``)."""
    out = []
    for law, text in (("nosuch", "--law: 'nosuch' is not a layer law"),
                      ("voce,nosuch", "--law: 'nosuch' is not a layer law"),
                      ("", "--law: no layer law given")):
        out.append(Case("fit_hpt", "hpt_OFM1_4uL_25C", f"law={law}", hpt_raw,
                        args=("--law", law), expect="input_error", expect_in=text))
    for value, text in (("x", "'x' is not a quantity"), ("0", "0 MPa is not possible"),
                        ("-1 MPa", "-1 MPa is not possible"), ("nan", "value is NaN"),
                        ("1e300 MPa", "1e+300 MPa is not possible"),
                        ("2.9 K", "unit 'K' is not a pressure")):
        out.append(Case("fit_hpt", "hpt_OFM1_4uL_25C", f"resolution={value}", hpt_raw,
                        args=("--resolution", value, "--law", "auto"), expect="input_error",
                        expect_in=f"--resolution: {text}"))
    out.append(Case("fit_hpt", "hpt_OFM1_4uL_25C", "resolution=2.9 MPa", hpt_raw,
                    args=("--law", "auto", "--resolution", "2.9 MPa"), expect="ok", slow=True))
    lin = LINEAR_PARAMS
    for mut, text, expect, want in (
            ("as_written", lin, "ok", ""),
            ("law_without_its_parameter", lin.replace("  k_mu: 50 1/m\n", ""), "input_error",
             "input.yaml:1: boundary.k_mu: missing (required)"),
            ("parameter_of_another_law", lin.replace("law: linear", "law: voce"),
             "input_error", "boundary.k_mu: not a parameter of the voce layer law"),
            ("unknown_law", lin.replace("law: linear", "law: nosuch"), "input_error",
             "boundary: nosuch is not a layer law")):
        out.append(Case("predict_params", "linear_params.yaml", mut, text.encode(),
                        expect=expect, expect_in=want))
    return out


def _text_lines(raw: bytes) -> list[str]:
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("cp1252")
    return text.replace("\r\n", "\n").split("\n")


def _join(lines: list[str]) -> bytes:
    return "\n".join(lines).encode("utf-8")


def _plant_key(kind: str, work: Path) -> Path:
    """A configuration folder whose cache key cannot be trusted (``kind``)."""
    d = work / "config"
    d.mkdir(mode=0o700)
    key = d / "cache-key"
    if kind == "readable":
        key.write_text("ab" * 8 + "".join(f"{i:02x}" for i in range(24)) + "\n")
        key.chmod(0o644)
    elif kind == "zeros":
        key.write_text("00" * 32 + "\n")
        key.chmod(0o600)
    elif kind == "fifo":
        os.mkfifo(key)
    else:
        raise ValueError(kind)
    return d


def _plant(what: str, work: Path) -> None:
    """Files someone else put next to OUT (``work/out``) before the run."""
    victim = work / "victim.txt"
    victim.write_bytes(VICTIM)
    lock = work / ".out.lock"
    if what == "lock_symlink":
        lock.symlink_to("victim.txt")
    elif what == "lock_dangling":
        lock.symlink_to(work / "created-through-link.txt")
    elif what == "lock_hardlink":
        os.link(victim, lock)
    elif what == "lock_fifo":
        os.mkfifo(lock)
    elif what == "out_read_only":  # replaced even with --force once
        (work / "out").mkdir()
        (work / "out").chmod(0o555)
    elif what == "out_symlink":
        (work / "elsewhere").mkdir()
        (work / "out").symlink_to(work / "elsewhere", target_is_directory=True)
    else:
        raise ValueError(what)


#: option values tried on every option of the commands below (a few per option, seeded)
OPTION_VALUES = ["1e300", "-1e300", "nan", "inf", "", "x", "0", "-5", "1 kg", "1e-300",
                 "0:1e9:3", "0:1:0", "1,,2", "5:", "3", "-0.5", "2000 1/m", "1e5 mg/m^2",
                 "10 s", "-1 h", "0.002", "5 %", "0.5 1/m", "2 mm/s", "4 uL", "300 K"]

#: command -> its options whose values are fuzzed
OPTIONS = {
    "predict_creep": ("--lateral", "--spin", "--creepage"),
    "predict_sweep": ("--sweep", "--amount", "--pass-interval", "--track-radius", "--creepage"),
    "predict_table": ("--creepage", "--lateral", "--spin", "--speed", "--amount"),
    "fit_polach": ("--creepage", "--speed", "--lateral", "--spin"),
    "predict_retention": ("--amount", "--time", "--passes", "--creepage", "--band",
                          "--track-radius", "--speed"),
    "fit_film": ("--min-speed",),
    "fit_temperature": ("--reference-temperature",),
}


def visc_table() -> bytes:
    """A reduced viscometer table (``torlab visc reduce`` ``*_steps.csv`` columns): Barus'
    law, eta0 60 mPa s, alpha 15 1/GPa, 25 degC, 1 % scatter (seeded)."""
    import numpy as np

    rng = np.random.default_rng(3)
    p = np.linspace(0.0, 400e6, 12)
    eta = 0.06 * np.exp(15e-9 * p) * (1 + 0.01 * rng.standard_normal(p.size))
    rows = "".join(f"{a:.6g},{b:.6g},25.0\n" for a, b in zip(p, eta, strict=True))
    return ("pressure_Pa,viscosity_Pa_s,temperature_C\n" + rows).encode()


def _more_commands(seed: int, src: dict, removal: bytes) -> list[Case]:
    """The fits, the creep-force and retention options and ``reduce --as`` (their own
    generator, so the cases above stay as they were)."""
    rng = random.Random(seed + 32)
    out: list[Case] = []
    tab54 = (SCENES / "wheel_rail_tab54.yaml").read_bytes()
    hpt = SAMPLE / "hpt"
    temps = {f"hpt_OFM1_4uL_{t}C.txt": (hpt / f"hpt_OFM1_4uL_{t}C.txt").read_bytes()
             for t in (65, 105)}
    small = dict(src["optical"])["small_traction"]
    dry = (SAMPLE / "optical" / "dry_traction_rough.csv").read_bytes()
    ehd2 = (DATA / "pcs" / "ehd2_quirks.txt").read_bytes()
    # each command's valid input first (the quick sample runs the first case of a reader)
    for reader, source, data, extra in (
            ("fit_traction", "dry_traction_rough", dry, {}),
            ("fit_film", "ehd2_quirks.txt", ehd2, {}),
            ("fit_visc", "steps.csv", visc_table(), {}),
            ("fit_temperature", "hpt_OFM1_4uL_25C", (hpt / "hpt_OFM1_4uL_25C.txt").read_bytes(),
             temps),
            ("fit_polach", "wheel_rail_tab54.yaml", tab54, {}),
            ("predict_table", "wheel_rail_tab54.yaml", tab54, {}),
            ("predict_creep", "wheel_rail_tab54.yaml", tab54, {}),
            ("predict_sweep", "wheel_rail_tab54.yaml", tab54, {"removal.yaml": removal}),
            ("reduce_as", "pcs", (DATA / "pcs" / "mtm_quirks.txt").read_bytes(), {})):
        out.append(Case(reader, source, "as_written", data, extra=extra,
                        args=("--as", "pcs") if reader == "reduce_as" else ()))
    for mut, b in mutate_text(dry, rng)[::3]:
        out.append(Case("fit_traction", "dry_traction_rough", mut, b))
    for mut, b in mutate_text(ehd2, rng)[::3]:
        out.append(Case("fit_film", "ehd2_quirks.txt", mut, b))
    for mut, b in mutate_text(visc_table(), rng)[::2]:
        out.append(Case("fit_visc", "steps.csv", mut, b))
    for mut, b in mutate_text((hpt / "hpt_OFM1_4uL_25C.txt").read_bytes(), rng)[::4]:
        out.append(Case("fit_temperature", "hpt_OFM1_4uL_25C", mut, b, extra=temps))
    for mut, b in mutate_yaml(tab54, rng, values=4)[::3]:
        out.append(Case("fit_polach", "wheel_rail_tab54.yaml", mut, b))
    for mut, b in mutate_yaml(tab54, rng, values=4)[::4]:
        out.append(Case("predict_table", "wheel_rail_tab54.yaml", mut, b))
    for cmd, opts in OPTIONS.items():
        data = removal if cmd == "predict_retention" else \
            (DATA / "pcs" / "ehd2_quirks.txt").read_bytes() if cmd == "fit_film" else \
            (hpt / "hpt_OFM1_4uL_25C.txt").read_bytes() if cmd == "fit_temperature" else tab54
        extra = {"removal.yaml": removal} if cmd == "predict_sweep" else \
            temps if cmd == "fit_temperature" else {}
        for opt in opts:
            for v in rng.sample(OPTION_VALUES, 4):
                out.append(Case(cmd, "option", f"{opt}={v}", data, extra=extra, args=(opt, v)))
    # reduce --as: every instrument name on each kind of file, and mutated files read as one
    files = {"hpt": (hpt / "hpt_OFM1_4uL_25C.txt").read_bytes(),
             "pcs": (DATA / "pcs" / "mtm_quirks.txt").read_bytes(),
             "optical": small, "visc": dict(src["visc"])["fall_column_crlf"]}
    for kind, data in files.items():
        for as_ in ("pcs", "ehd2", "hpt", "optical", "visc", "tribo"):
            out.append(Case("reduce_as", kind, f"--as={as_}", data, args=("--as", as_)))
        for mut, b in mutate_text(data, rng)[::6]:
            out.append(Case("reduce_as", kind, mut, b, args=("--as", kind)))
    for reader in ("fit_traction", "fit_film", "fit_visc", "reduce_as"):
        for special in ("fifo", "folder", "missing"):
            out.append(Case(reader, "-", special, special=special,
                            args=("--as", "pcs") if reader == "reduce_as" else ()))
    return out


def _trios_cases(seed: int, src: dict) -> list[Case]:
    """TA Instruments TRIOS exports (their own generator, so the cases above stay as they
    were): every text mutation, a units row short of a unit, a unit of another kind, an
    unknown unit, a step without its units row or its viscosity, the special files."""
    rng = random.Random(seed + 48)
    out: list[Case] = []
    for name, data in src["trios"]:
        for mut, b in mutate_text(data, rng):
            out.append(Case("trios", name, mut, b))
    hand = dict(src["trios"])["hand.txt"]
    units = "dyne/cm²\t1/s\tPa.s\ts\t°C\tdyne/cm²".encode()
    for mut, new in (("units_row_short", "dyne/cm²\t1/s".encode()),
                     ("unit_of_another_kind", units.replace(b"Pa.s", b"mm")),
                     ("unknown_unit", units.replace("dyne/cm²".encode(), b"dyne/furlong", 1)),
                     ("empty_unit", units.replace(b"1/s", b"")),
                     ("no_units_row", b"")):
        out.append(Case("trios", "hand.txt", mut, hand.replace(units + b"\ts\t\xc2\xb5m\r\n",
                                                              new + b"\r\n" if new else b"",
                                                              1)))
    out.append(Case("trios", "hand.txt", "no_viscosity_column",
                    hand.replace(b"\tViscosity\t", b"\tThickness\t")))
    out.append(Case("trios", "hand.txt", "step_without_name",
                    hand.replace(b"[step]\r\nFlow sweep - 1\r\n", b"[step]\r\n", 1)))
    out.append(Case("trios", "hand.txt", "temperature_option", hand,
                    args=("--temperature", "80 degC")))
    for special in ("fifo", "folder", "device", "missing", "symlink_device"):
        out.append(Case("trios", "-", special, special=special))
    return out


# ----------------------------------------------------------------------------- running
class _Hang(BaseException):
    """Raised by the alarm when a case exceeds :data:`TIME_LIMIT`."""


def _alarm(signum: int, frame: object) -> None:
    raise _Hang()


def _place(case: Case, work: Path) -> Path:
    """Write the case's input into ``work`` and return its path."""
    suffix = {"scene": ".yaml", "scene_stribeck": ".yaml", "protocol": ".yaml", "hpt_map": ".yaml",
              "protocol_files": ".yaml",
              "predict_retention": ".yaml", "optical": ".csv", "fit_visc": ".csv",
              "fit_polach": ".yaml", "predict_table": ".yaml", "predict_creep": ".yaml",
              "predict_sweep": ".yaml", "fit_traction": ".csv",
              "predict_params": ".yaml"}.get(case.reader, ".txt")
    p = work / f"input{suffix}"
    if case.special == "fifo":
        os.mkfifo(p)
    elif case.special == "folder":
        p.mkdir()
        (p / "inside.txt").write_text("x")
    elif case.special == "device":
        p = Path("/dev/zero")
    elif case.special == "missing":
        p = work / "does-not-exist.txt"
    elif case.special == "symlink_device":
        p.symlink_to("/dev/zero")
    else:
        p.write_bytes(case.data or b"")
    return p


def command(case: Case, work: Path) -> list[str]:
    """The CLI arguments of a case (its input placed in ``work``), with ``case.args``
    replacing the value of an option the command already gives (or added)."""
    args = _command(case, work)
    rest = list(case.args)
    while rest:  # options with a value ("--x", "1"), or flags (starting "--", no value)
        opt = rest.pop(0)
        if not rest or rest[0].startswith("--"):
            if opt not in args:
                args.append(opt)
            continue
        value = rest.pop(0)
        if opt in args:
            i = args.index(opt)
            args[i + 1] = value
        else:
            args += [opt, value]
    return args


def _companions(case: Case, work: Path) -> list[Path]:
    paths = []
    for k, v in case.extra.items():
        if not k.startswith("__"):
            (work / k).write_bytes(v)
            paths.append(work / k)
    return paths


def _command(case: Case, work: Path) -> list[str]:
    p = _place(case, work)
    if "__plant__" in case.extra:
        _plant(case.extra["__plant__"].decode(), work)
    if "__sparse__" in case.extra:
        from torlab.parsers._table import MAX_TEXT_BYTES

        with open(p, "wb") as f:  # no disk used
            f.truncate(MAX_TEXT_BYTES + 1)
    out = str(work / "out")
    r = case.reader
    if r == "hpt":
        return ["hpt", "reduce", str(p), "-o", out]
    if r == "pcs":
        return ["mtm", "reduce", str(p), "-o", out]
    if r in ("ehd2", "optical"):
        return ["optical", "reduce", str(p), "-o", out]
    if r == "visc":
        ref = SAMPLE / "visc" / "visc_reference_25C.txt"
        return ["visc", "reduce", str(p), "--reference", str(ref), "-o", out]
    if r == "trios":
        return ["trios", "reduce", str(p), "-o", out]
    if r == "scene":
        return ["predict", "traction", str(p), "--creepage", "0:0.05:6", "-o", out]
    if r == "scene_stribeck":
        return ["predict", "stribeck", str(p), "--speed", "0.01:2:6", "--creepage", "0.02",
                "-o", out]
    if r == "fit_hpt":
        return ["fit", "hpt", str(p), "-o", out]
    if r == "fit_removal":
        hpt = []
        for k, v in case.extra.items():
            (work / k).write_bytes(v)
            hpt += ["--hpt", str(work / k)]
        return ["fit", "removal", str(p), *hpt, "--density", "930 kg/m^3", "-o", out]
    if r == "predict_retention":
        return ["predict", "retention", str(SCENES / "wheel_rail_tab54.yaml"), str(p),
                "--amount", "50000 mg/m^2", "--draws", "20", "-o", out]
    if r == "fit_traction":
        return ["fit", "traction", str(SCENES / "optical_paper_a_dry.yaml"), str(p), "--dry",
                "-o", out]
    if r == "fit_film":
        return ["fit", "film", str(p), "-o", out]
    if r == "fit_visc":
        return ["fit", "visc", str(p), "--law", "barus", "-o", out]
    if r == "fit_temperature":
        return ["fit", "temperature", str(p), *map(str, _companions(case, work)),
                "--reference-temperature", "25 degC", "-o", out]
    if r == "fit_polach":
        return ["fit", "polach", str(p), "--creepage", "0:0.05:6", "--speed", "5 m/s,20 m/s",
                "-o", out]
    if r == "predict_table":
        return ["predict", "table", str(p), "--creepage", "0:0.01:3", "--lateral", "0:0.01:3",
                "--spin", "0:1:2", "-o", out]
    if r == "predict_params":
        return ["predict", "traction", str(SCENES / "wheel_rail_tab54.yaml"), str(p),
                "--creepage", "0:0.05:6", "-o", out]
    if r == "predict_creep":
        return ["predict", "traction", str(p), "--creepage", "0:0.02:5", "--lateral", "0.001",
                "--spin", "0.1", "-o", out]
    if r == "predict_sweep":
        (rem,) = _companions(case, work)
        return ["predict", "traction", str(p), str(rem), "--sweep", "60 s", "--amount",
                "50000 mg/m^2", "--pass-interval", "2 s", "--creepage", "0:0.05:6", "-o", out]
    if r == "reduce_as":
        return ["reduce", str(p), "-o", out]
    if r == "hpt_compliance":
        (comp,) = _companions(case, work)
        return ["hpt", "reduce", str(p), "--compliance", str(comp), "-o", out]
    if r == "hpt_map":
        csv = work / "rig2.csv"
        csv.write_bytes(case.extra.get("__csv__", HPT_MAP_CSV))
        return ["hpt", "reduce", str(csv), "--map", str(p), "-o", out]
    if r == "protocol_files":  # the same HPT log as day1/hpt.txt and day2/hpt.txt
        for d in ("day1", "day2"):
            (work / d).mkdir()
            (work / d / "hpt.txt").write_bytes((SAMPLE / "hpt" / "hpt_OFM1_4uL_25C.txt")
                                               .read_bytes())
        return ["run", str(p), "-o", out]
    if r == "protocol":
        product = case.extra.get("__product__")
        products = case.extra.get("__products__", b"").split(b"|") if \
            "__products__" in case.extra else []
        for k, f in enumerate(sorted((SAMPLE / "hpt").glob("hpt_OFM1_*uL_25C.txt"))[:4]):
            b = f.read_bytes()
            if product is not None:
                b = b.replace(b"# product: OFM1", b"# product: " + product)
            if products:  # one product per file, in turn
                b = b.replace(b"# product: OFM1", b"# product: " + products[k % len(products)])
            (work / f.name).write_bytes(b)
        for k, v in case.extra.items():
            if not k.startswith("__"):
                (work / k).write_bytes(v)
        return ["run", str(p), "-o", out]
    raise ValueError(r)


_STDERR_OK = ("error: ", "warning: ")


#: the commands that take --no-plot (tables only)
_PLOTTING = {("hpt", "reduce"), ("mtm", "reduce"), ("optical", "reduce"), ("visc", "reduce"),
             ("trios", "reduce"),
             ("predict", "traction"), ("predict", "stribeck")}


def run_case(case: Case, work: Path, runner: object, plots: bool = True) -> Outcome:
    """Run one case through the CLI in-process and classify what happened."""
    from torlab.cli import _STATE, app

    work.mkdir(parents=True, exist_ok=True)
    args = command(case, work)
    if not plots and (tuple(args[:2]) in _PLOTTING or args[0] == "reduce"):
        args.append("--no-plot")
    env_before = os.environ.get("TORLAB_CONFIG_DIR")
    if "__key__" in case.extra:  # a cache key someone else can use, in a folder of its own
        os.environ["TORLAB_CONFIG_DIR"] = str(_plant_key(case.extra["__key__"].decode(), work))
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(TIME_LIMIT)
    try:
        res = runner.invoke(app, args)
    except _Hang:
        return Outcome(case, None, "hang", f"over {TIME_LIMIT} s")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
        if "__key__" in case.extra:
            if env_before is None:
                os.environ.pop("TORLAB_CONFIG_DIR", None)
            else:
                os.environ["TORLAB_CONFIG_DIR"] = env_before
    hidden = len(_STATE.get("hidden_warnings", []))
    out = res.output or ""
    err = getattr(res, "stderr", "") or ""
    code = res.exit_code
    victim = work / "victim.txt"
    if (victim.is_file() and victim.read_bytes() != VICTIM) or \
            (work / "created-through-link.txt").exists() or \
            ((work / "elsewhere").is_dir() and any((work / "elsewhere").iterdir())):
        return Outcome(case, code, "wrote_outside", "a file outside OUT was written", hidden)
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        import traceback

        tb = "".join(traceback.format_exception(res.exception)).splitlines()[-3:]
        return Outcome(case, code, "traceback", " | ".join(tb), hidden)
    if "Traceback (most recent call last)" in out + err:
        return Outcome(case, code, "traceback", err[-300:], hidden)
    bad = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith(_STDERR_OK)]
    if bad:
        return Outcome(case, code, "leaked_warning", bad[0][:200], hidden)
    if code == 1:
        return Outcome(case, code, "bug", err.strip()[-300:], hidden)
    if code in (2, 3):
        first = [ln for ln in err.splitlines() if ln.startswith("error: ")]
        if not first:
            return Outcome(case, code, "bug", "exit code without an error line", hidden)
        return Outcome(case, code, "input_error" if code == 2 else "numerical_error",
                       first[0][:200], hidden)
    if code == 0:
        said = [ln for ln in (err + "\n" + out).splitlines()
                if ln.startswith(("warning: ", "note"))]
        return Outcome(case, code, "ok", " | ".join(said)[:2000], hidden)
    return Outcome(case, code, "bug", f"exit code {code}", hidden)


def run_corpus(cases: list[Case], base: Path, runner: object, plots: bool = True,
               progress: Callable[[int, Outcome], None] | None = None) -> list[Outcome]:
    """Run every case in its own folder under ``base``."""
    outs = []
    for k, c in enumerate(cases):
        o = run_case(c, base / f"c{k:04d}", runner, plots)
        outs.append(o)
        if progress is not None:
            progress(k, o)
    return outs


if __name__ == "__main__":  # python tests/fuzz_corpus.py [filter]: run and print the outcomes
    import collections
    import tempfile

    from typer.testing import CliRunner

    sys.path.insert(0, str(ROOT / "tests"))
    flt = sys.argv[1] if len(sys.argv) > 1 else ""
    cases = [c for c in build_corpus() if flt in c.name]
    with tempfile.TemporaryDirectory() as d, contextlib.redirect_stderr(sys.stderr):
        def show(k: int, o: Outcome) -> None:
            if o.kind not in ("ok", "input_error", "numerical_error"):
                print(f"{k:4d} {o.kind:15s} {o.case.name}: {o.detail}", flush=True)
        outs = run_corpus(cases, Path(d), CliRunner(), progress=show)
    print(len(outs), collections.Counter(o.kind for o in outs))
