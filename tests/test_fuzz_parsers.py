"""Fuzz: mutated PCS, optical and viscometer files parse validly or fail with one clear error.

Mutations: truncation, byte flips, deleted tabs/commas, swapped units, NaN in a number field,
deleted line ranges (empty steps), duplicated and inserted lines.  Every outcome must be a
valid parse (finite values where the format requires them) or a
:class:`~torlab.errors.TorlabInputError` naming the file (and the line, unless the problem
concerns the whole file); anything else -- a traceback -- fails the test.
"""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from conftest import DATA, REAL_PCS, ROOT
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from torlab.errors import TorlabInputError

PCS_FILES = [DATA / "pcs" / n for n in ("mtm_quirks.txt", "etm_quirks.txt", "ehd2_quirks.txt")]


def _doc_example(name: str, marker: str) -> bytes:
    doc = (ROOT / "docs" / "formats" / name).read_text(encoding="utf-8")
    return (marker + doc.split("```text\n" + marker, 1)[1].split("```", 1)[0]).encode()


def _small_visc() -> bytes:
    """The head of the synthetic ester log: header and its first two falls."""
    lines = (ROOT / "sample_data" / "visc" / "visc_ester_25C.txt").read_bytes().split(b"\n")
    return b"\n".join(lines[:150]) + b"\n"


def _small_optical() -> bytes:
    from torlab.synth.optical import OpticalCondition, OpticalTest, write_optical_log

    conds = tuple(OpticalCondition(0.5, s, 90.0, 0.6) for s in (-0.02, 0.0, 0.02))
    buf = io.StringIO()
    write_optical_log(buf, OpticalTest("f", "traction", "rough", "water", conds),
                      lambda U, s: 0.05 * np.tanh(np.asarray(s) / 0.01),
                      lambda U: 30e-9 * np.asarray(U) ** 0.67, seed=1)
    return buf.getvalue().encode()


SOURCES: list[tuple[str, bytes]] = (
    [("pcs", p.read_bytes()) for p in PCS_FILES]
    + [("optical", _doc_example("optical.md", "# torlab-optical")), ("optical", _small_optical()),
       ("optical", (DATA / "optical" / "setpoints_torque_crlf.csv").read_bytes()),
       ("visc", _doc_example("viscometer.md", "# torlab-visc")), ("visc", _small_visc()),
       ("visc", (DATA / "visc" / "fall_column_crlf.txt").read_bytes())]
)

UNIT_SWAPS = [(b"(N)", b"(mm)"), (b"(mm/s)", b"(kg)"), (b"(%)", b"(Nx)"), (b"(nm)", b"(s)"),
              (b"(\xc2\xb0C)", b"(degF)"), (b"(degC)", b"(K)"), (b"[N]", b"[m]"),
              (b"[m/s]", b"[m/s^2]"), (b"[mm]", b"[bar]"), (b"[MPa]", b"[um]"),
              (b"[s]", b"[furlong]"), (b"kg/m^3", b"kg/m^2")]

#: whole-file problems that legitimately have no line number
WHOLE_FILE = ("file is empty", "missing header key", "no data rows", "no steps", "no fall",
              "no set condition", "no calibration constant", "binary file", "needs the",
              "the body must be denser", "the rows do not have")


def _mutate(data: bytes, draw) -> bytes:
    kind = draw(st.sampled_from(["truncate", "flip", "delete_sep", "swap_unit", "nan",
                                 "delete_lines", "duplicate_line", "insert_line", "several"]))
    if kind == "several":
        for _ in range(draw(st.integers(2, 4))):
            data = _mutate(data, draw)
        return data
    n = len(data)
    if n == 0:
        return data
    if kind == "truncate":
        return data[: draw(st.integers(0, n))]
    if kind == "flip":
        b = bytearray(data)
        for _ in range(draw(st.integers(1, 3))):
            i = draw(st.integers(0, n - 1))
            b[i] ^= draw(st.integers(1, 255))
        return bytes(b)
    if kind == "delete_sep":
        seps = [i for i, c in enumerate(data) if c in (9, 44)]  # tab, comma
        if not seps:
            return data
        i = seps[draw(st.integers(0, len(seps) - 1))]
        return data[:i] + data[i + 1:]
    if kind == "swap_unit":
        present = [s for s in UNIT_SWAPS if s[0] in data]
        if not present:
            return data
        old, new = present[draw(st.integers(0, len(present) - 1))]
        return data.replace(old, new, 1)
    lines = data.split(b"\n")
    k = draw(st.integers(0, len(lines) - 1))
    if kind == "nan":
        sep = b"\t" if b"\t" in lines[k] else b","
        fields = lines[k].split(sep)
        j = draw(st.integers(0, len(fields) - 1))
        fields[j] = draw(st.sampled_from([b"NaN", b"nan", b"inf", b"-", b""]))
        lines[k] = sep.join(fields)
    elif kind == "delete_lines":
        m = draw(st.integers(1, 40))
        del lines[k:k + m]
    elif kind == "duplicate_line":
        lines.insert(k, lines[k])
    else:
        lines.insert(k, draw(st.sampled_from([b"", b"garbage", b"Step 9 started at 01/01/2020 00:00",
                                              b"Step type\tTraction", b"#", b"1,2,3", b"\t\t\t"])))
    return b"\n".join(lines)


def _check_outcome(kind: str, data: bytes, name: str) -> None:
    try:
        _parse_and_reduce(kind, data, name)
    except TorlabInputError as e:
        assert e.path == name, f"error does not name the file: {e}"
        msg = str(e)
        assert "\n" not in msg, f"error is not one line: {msg!r}"
        assert e.line is not None or any(w in msg for w in WHOLE_FILE), \
            f"error names no line: {msg}"
        if e.line is not None:
            n_lines = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n").count(b"\n") + 1
            assert 1 <= e.line <= n_lines, msg


def _parse_and_reduce(kind: str, data: bytes, name: str) -> None:
    if kind == "pcs":
        from torlab.parsers.pcs import read_pcs
        from torlab.reduce.mtm import reduce_pcs

        df, meta = read_pcs(io.BytesIO(data), name=name)
        json.dumps(meta.to_dict(), allow_nan=False)  # what the CLI writes
        num = df.select_dtypes("number")
        assert not np.isinf(num.to_numpy(dtype=float)).any()
        assert df["line"].is_monotonic_increasing
        try:
            reduce_pcs(df, meta)
        except TorlabInputError as e:  # nothing to reduce: names the file
            assert e.path == name or e.key is not None
    elif kind == "optical":
        from torlab.parsers.optical import read_optical
        from torlab.reduce.optical import reduce_optical_log

        df, _ = read_optical(io.BytesIO(data), name=name)
        req = [c for c in df.columns if c not in ("film_thickness_m", "temperature_C")]
        assert np.isfinite(df[req].to_numpy(dtype=float)).all()
        reduce_optical_log(io.BytesIO(data), name=name, window=0.1)
    else:
        from torlab.parsers.viscometer import read_viscometer
        from torlab.reduce.viscometer import Calibration, reduce_viscometer

        df, meta = read_viscometer(io.BytesIO(data), name=name)
        assert np.isfinite(df.drop(columns=["line"]).to_numpy(dtype=float)).all()
        reduce_viscometer(df, meta, calibration=Calibration(1.9e-8))


def _committed(src, data):
    kind, raw = SOURCES[src]
    mutated = _mutate(raw, data.draw)
    _check_outcome(kind, mutated, f"fuzz-{kind}-{src}.txt")


REAL = ["demo_3.txt", "demo_5.txt", "ETM_slim_mapper.txt"]


def _real(which, data):
    path = REAL_PCS / REAL[which]
    if not path.exists():
        pytest.skip(f"real PCS data not available ({path})")
    raw = path.read_bytes()
    _check_outcome("pcs", _mutate(raw, data.draw), REAL[which])


def _fuzz(fn, examples: int, **strategies):
    return settings(max_examples=examples, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])(
        given(**strategies)(fn))


# each runs a few examples in the quick suite, and its full count in CI's slow step
_SRC = {"src": st.integers(0, len(SOURCES) - 1), "data": st.data()}
_WHICH = {"which": st.integers(0, 2), "data": st.data()}
test_mutated_committed_files = _fuzz(_committed, 50, **_SRC)
test_mutated_committed_files_all = pytest.mark.slow(_fuzz(_committed, 300, **_SRC))
test_mutated_real_pcs_files = pytest.mark.realdata(_fuzz(_real, 6, **_WHICH))
test_mutated_real_pcs_files_all = pytest.mark.realdata(pytest.mark.slow(_fuzz(_real, 40,
                                                                              **_WHICH)))


@pytest.mark.parametrize("i", range(len(SOURCES)))
def test_unmutated_sources_parse(i):
    kind, raw = SOURCES[i]
    _parse_and_reduce(kind, raw, f"src-{i}.txt")


@pytest.mark.parametrize(("reader", "sample"), [
    ("torlab.parsers.hpt:read_hpt", "hpt/hpt_OFM1_4uL_25C.txt"),
    ("torlab.parsers.viscometer:read_viscometer", "visc/visc_ester_25C.txt"),
    ("torlab.parsers.pcs:read_pcs", "mtm/mtm_TOR-A_20uL.txt"),
    ("torlab.parsers.optical:read_optical", "optical/dry_traction_rough.csv"),
])
def test_a_digit_of_another_script_is_an_error_naming_its_line(tmp_path, reader, sample):
    """Python's float() reads '\u0664' (Arabic-Indic four), pandas does not: the two parsers
    of a data row must agree, so the row is refused with its line and column (it once
    passed the exact scan after pandas had refused it: an internal error)."""
    import importlib
    import re

    mod, name = reader.split(":")
    read = getattr(importlib.import_module(mod), name)
    lines = (ROOT / "sample_data" / sample).read_text(encoding="utf-8").split("\n")
    k = next(k for k in range(int(0.7 * len(lines)), len(lines))
             if re.search("[0-9]", lines[k]) and not lines[k].startswith("#"))
    lines[k] = re.sub("[0-9]", "\u0664", lines[k], count=1)
    bad = tmp_path / (sample.split("/")[1])
    bad.write_text("\n".join(lines), encoding="utf-8")
    with pytest.raises(TorlabInputError, match="is not a number") as e:
        read(bad)
    assert e.value.line == k + 1 and e.value.path == str(bad)


def test_a_digit_of_another_script_is_one_error_line_from_the_command(cli, tmp_path):
    from conftest import error_lines

    lines = (ROOT / "sample_data" / "hpt" / "hpt_OFM1_4uL_25C.txt").read_text().split("\n")
    k = next(k for k in range(len(lines) // 2, len(lines)) if lines[k][:1].isdigit())
    lines[k] = "\u0664" + lines[k][1:]
    bad = tmp_path / "hpt_bad.txt"
    bad.write_text("\n".join(lines), encoding="utf-8")
    r = cli("hpt", "reduce", bad, "-o", tmp_path / "out")
    errs = error_lines(r)
    assert r.exit_code == 2 and len(errs) == 1 and "Traceback" not in r.output, r.output
    assert f"hpt_bad.txt:{k + 1}" in errs[0] and "is not a number" in errs[0], errs[0]
    assert not (tmp_path / "out").exists()
