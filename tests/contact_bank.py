"""CONTACT's example inputs and reference outputs (Apache-2.0), read where they are present.

The folder ``../shared/datasets/contact`` beside the repository holds CONTACT's own
test bank (E.A.H. Vollebregt's program for Kalker's exact theory); it is never copied
into the repository, and the tests that read it skip where it is absent.  These
helpers read the few things the tests need: the totals and element counts of the
reference outputs, and the sequences of cases of the longer inputs.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT

BANK = ROOT.parent / "shared" / "datasets" / "contact"


def bank_file(rel: str) -> Path:
    """A file of the bank, or skip the test."""
    path = BANK / rel
    if not path.is_file():
        pytest.skip(f"CONTACT's test bank is not here ({rel})")
    return path


def totals(rel: str) -> list[dict[str, float]]:
    """Per case: ``FN, FX, FY, MZ`` (CONTACT's units, its signs) of a ``.ref_out``."""
    lines = bank_file(rel).read_text(encoding="utf-8").splitlines()
    out = []
    for i, line in enumerate(lines):
        if line.split()[:4] == ["FN", "FX", "FY", "MZ"]:
            v = lines[i + 1].split()
            out.append({"FN": float(v[0]), "FX": float(v[1]), "FY": float(v[2]),
                        "MZ": float(v[3])})
    return out


def second_row(rel: str, first: str) -> list[list[str]]:
    """Per case: the line after a header line starting with ``first`` (split)."""
    lines = bank_file(rel).read_text(encoding="utf-8").splitlines()
    return [lines[i + 1].split() for i, line in enumerate(lines)
            if line.split()[:1] == [first]]


def counts(rel: str) -> list[dict[str, int]]:
    """Per case: the element counts ``NCON, NADH, NSLIP`` (and ``NPLAST``)."""
    lines = bank_file(rel).read_text(encoding="utf-8").splitlines()
    out = []
    for i, line in enumerate(lines):
        head = line.split()
        if head[:2] == ["NPOT", "NCON"]:
            v = [int(x) for x in lines[i + 1].split()]
            d = dict(zip(head, v, strict=False))
            out.append(d)
    return out


def cases(rel: str) -> list[dict]:
    """The cases of an input: control digits ``P, T, F``, the kinematic line and the layer.

    Only what the tests use: the first digits of the ``P-B-T-N-F-S`` line, the ``M``
    digit, the ``FN, CKSI/FX, CETA, CPHI`` line and the ``GG3, LAYTHK, TAU_C0, K_TAU`` line.
    """
    out: list[dict] = []
    cur: dict | None = None
    for line in bank_file(rel).read_text(encoding="utf-8").splitlines():
        parts = line.split()
        if "P-B-T-N-F-S" in line:
            d = parts[0].rjust(6, "0")
            cur = {"P": int(d[0]), "T": int(d[2]), "F": int(d[4])}
            out.append(cur)
        elif cur is None:
            continue
        elif "L-D-C-M-Z-E" in line:
            cur["M"] = int(parts[0].rjust(6, "0")[3])
        elif "FN," in line and len(parts) >= 4:
            cur["FN"], cur["kin"] = float(parts[0]), [float(v) for v in parts[1:4]]
        elif "GG3, LAYTHK" in line:
            cur["layer"] = [float(v) for v in parts[:4]]
    return out
