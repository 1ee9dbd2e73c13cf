"""High-pressure torsion logs (registry entry ``hpt``).

Reads ``torlab-hpt`` logs (or another rig's CSV with a column map) with
:func:`torlab.parsers.hpt.read_hpt` and reduces them with
:func:`torlab.reduce.hpt.reduce_hpt`: sigma, tau and f against displacement,
f over the window before the maximum (thesis Eqs. 5.1-5.4).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from torlab.instruments.plugin import Command, Option
from torlab.instruments.reduction import Reduction

NAME = "hpt"
TITLE = "high-pressure torsion rig"
FILES = "torlab-hpt logs (other CSVs with --map)"
EXTENSIONS = (".txt", ".csv", ".tsv", ".dat", ".log")  # another rig's table, with a column map
ALIASES: dict[str, dict[str, Any]] = {"torsion": {}}

OPTIONS: dict[str, Option] = {
    "window": Option("length", 20e-6, "Displacement window before the maximum over which f is "
                     "averaged.", check="positive", unit="um", quantity="displacement_window"),
    "source": Option("choice", "auto", "Displacement from the 'motor' angle, the 'encoder' "
                     "angle, or 'auto' (motor where logged).", ("auto", "motor", "encoder")),
    "compliance": Option("object", None, "Rig compliance to subtract: a curve file (torlab-hpt "
                         "log of a dry run, or CSV with shear_stress and displacement columns) "
                         "or a constant such as '0.012 um/MPa'."),
    "map": Option("path", None, "Column map (YAML) for another rig's CSV layout; see "
                  "docs/formats/hpt.md.", key=None, reads_any=True),
}

COMMAND = Command(
    "hpt", "High-pressure torsion (HPT) rig: reduce raw logs to shear stress and friction "
    "against displacement.",
    """Reduce HPT logs: S, r_e, sigma = F/S, tau = M/(r_e S), f = tau/sigma against
    displacement (thesis Eqs. 5.1-5.4), and f over the last 20 um before the maximum.

    Writes per input '<name>_reduced.csv' (SI units in the column names), 'summary.csv',
    and 'hpt.png' with every run on one figure.
    """,
    "Raw HPT logs (torlab-hpt format, or another rig's CSV with --map); folders and patterns "
    "such as 'logs/*.txt' are expanded.", argument="raw", what="HPT log")


def detect(head: str) -> str:
    """``"torlab-hpt log"`` for a file starting with ``# torlab-hpt``."""
    return "torlab-hpt log" if head.lstrip().startswith("# torlab-hpt") else ""


def read(path: Path, map: Any = None, **_: Any) -> tuple[Any, Any]:
    """:func:`torlab.parsers.hpt.read_hpt` (with the column map, if any)."""
    from torlab.parsers.hpt import read_hpt

    return read_hpt(path, map)


def prepare(opts: dict[str, Any]) -> dict[str, Any]:
    """Read the compliance curve and the column map once for all files."""
    from torlab.parsers.hpt import read_hpt_map
    from torlab.reduce.hpt import RigCompliance

    out = dict(opts)
    out["compliance"] = RigCompliance.from_spec(opts.get("compliance"), where="--compliance")
    if opts.get("map") is not None and not isinstance(opts["map"], dict):
        out["map"] = read_hpt_map(opts["map"])
    return out


def reduce(path: Path, **opts: Any) -> Reduction:
    """Read and reduce one log."""
    from torlab.reduce.hpt import reduce_hpt

    if "compliance" in opts and opts["compliance"] is not None \
            and not callable(opts["compliance"]):
        opts = prepare(opts)
    df, meta = read(path, opts.get("map"))
    res = reduce_hpt(df, meta, window=opts.get("window", 20e-6), source=opts.get("source", "auto"),
                     compliance=opts.get("compliance"))
    notes = [f"rig compliance subtracted: {res.compliance}"] if res.compliance else []
    return Reduction(NAME, str(path), {"reduced": res.data}, res.summary(), notes, meta, res)


def figures(red: Reduction) -> dict[str, Any]:
    """No per-file figure: every run is drawn on one figure (:func:`collect`)."""
    return {}


def collect(reds: list[Reduction], options: dict[str, Any]) -> tuple[dict, dict, dict]:
    """``summary`` (one row per run) and ``hpt`` (every run on one figure)."""
    import pandas as pd

    from torlab.reports.hpt import hpt_figure

    rows = pd.DataFrame([r.detail.summary() for r in reds])
    from torlab.reports.render import plot

    fig = plot(hpt_figure, [r.detail for r in reds], title="HPT: shear stress and friction")
    return ({"summary": rows}, {"summary": ("applied_amount", "temperature_C")}, {"hpt": fig})


def display(reds: list[Reduction]) -> list[tuple[str, list[dict], dict]]:
    """Console table: product, amount, temperature, sigma, f over the window."""
    rows = []
    w = reds[0].detail.window_m if reds else 20e-6
    fcol = f"f (last {w * 1e6:g} µm)"
    for red in reds:
        r = red.detail.summary()
        rows.append({
            "file": r["file"], "product": r["product"] + (f" {r['condition']}" if r["condition"]
                                                          else ""),
            "amount": "" if r["applied_amount_unit"] == "" else
            f"{r['applied_amount']:g} {r['applied_amount_unit']}",
            "T (°C)": "" if r["temperature_C"] != r["temperature_C"] else f"{r['temperature_C']:.0f}",
            "σ (MPa)": r["normal_stress_Pa"] / 1e6, fcol: r["f_window"], "± sd": r["f_window_std"],
            "u max (µm)": r["displacement_max_m"] * 1e6, "u from": r["displacement_source"],
        })
    return [("HPT reduction", rows, {"σ (MPa)": ".1f", "u max (µm)": ".1f", "± sd": ".4f",
                                     fcol: ".4f"})]


# ------------------------------------------------------------------ protocol section data.hpt
def check_section(values: dict[str, Any], resolve: Any) -> dict[str, Any]:
    """``compliance``: a constant (``"0.012 um/MPa"``) or a curve file (relative to the
    protocol) -> ``{"compliance": ("value", m/Pa) or ("file", path), "inputs": [file]}``."""
    from torlab.errors import TorlabInputError
    from torlab.units import to_si

    c = values.get("compliance")
    if c is None:
        return {}
    try:
        v = to_si(c, "compliance")
    except TorlabInputError:
        pass
    else:
        if v < 0:
            raise ValueError("the rig compliance must not be negative")
        return {"compliance": ("value", v)}
    try:
        path = resolve(c)[0]
    except ValueError as e:
        raise ValueError(f"compliance: neither a compliance like '0.012 um/MPa' nor a "
                         f"file ({e})") from None
    return {"compliance": ("file", path), "inputs": [path]}


def section_options(section: Any, ctx: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """The options and cache key; a compliance curve named as written in the protocol."""
    spec = section.derived.get("compliance")
    comp: Any = None if spec is None else spec[1]
    key = None if spec is None else list(spec)
    if spec is not None and spec[0] == "file":
        from torlab.reduce.hpt import RigCompliance

        # named as written in the protocol (relative to its folder): the reduced tables
        # and the fits carry that name, not a path of this machine
        comp = RigCompliance.from_file(spec[1], name=section.compliance)
        key = ["file", ctx.sha(spec[1]), section.compliance]
    return ({"window": section.window, "source": section.source, "compliance": comp},
            {"window": section.window, "source": section.source, "compliance": key})


def light(red: Reduction) -> dict[str, Any]:
    """What a protocol run keeps of a reduced run (:mod:`torlab.protocols.data`), as plain
    JSON: the header, the summary figures and notes, without the reduced curve (the fits
    read it from the run's cache where they run)."""
    from dataclasses import asdict, fields

    def plain(v: Any) -> Any:
        return v.item() if hasattr(v, "item") and not isinstance(v, (str, bytes)) else v

    d = red.detail
    return {"source": red.source, "detected": red.detected, "notes": list(red.notes),
            "key_numbers": {k: plain(v) for k, v in red.key_numbers.items()},
            "meta": asdict(red.meta),
            "detail": {f.name: plain(getattr(d, f.name)) for f in fields(d)
                       if f.name not in ("data", "meta")}}


def from_light(d: dict[str, Any]) -> Reduction:
    """The Reduction of :func:`light`'s JSON: header and key figures, no tables, and a
    detail without its curve (``data`` None).  TypeError or KeyError for other JSON."""
    from torlab.parsers.hpt import HptMetadata
    from torlab.reduce.hpt import HptResult

    meta = HptMetadata(**d["meta"])
    detail = HptResult(data=None, meta=meta, **d["detail"])
    if not isinstance(d["key_numbers"], dict) or not isinstance(d["notes"], list):
        raise TypeError("not the light form of an HPT reduction")
    return Reduction(NAME, str(d["source"]), {}, d["key_numbers"], [str(n) for n in d["notes"]],
                     meta, detail, detected=str(d["detected"]))


#: runs whose key figures are gathered at a time (:func:`write_section`)
SUMMARY_BLOCK = 256


def write_section(dest: Any, labelled: list[tuple[str, Reduction]]) -> dict[str, Any]:
    """``data/hpt_summary.csv`` (one row per run); the summary's f over the window.

    The rows are gathered :data:`SUMMARY_BLOCK` runs at a time, each block a table of its
    own, joined once (the same table as of all rows at once): a protocol run keeps each
    log packed (:class:`torlab.protocols.data.PackedReduction`), and the key figures of
    every log unpacked at once, beside the objects the run keeps (each run's name and f),
    spread Python's heap over memory it does not give back: at 13 312 logs this table
    grew the process by 38 MB, in blocks of 128 to 512 runs by 17 to 19 MB (measured)."""
    import pandas as pd

    parts, f_window = [], {}
    for i in range(0, len(labelled), SUMMARY_BLOCK):
        rows = [dict(r.key_numbers) for _, r in labelled[i:i + SUMMARY_BLOCK]]
        parts.append(pd.DataFrame(rows))
        f_window.update((r["file"], r["f_window"]) for r in rows)
    table = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
    dest.write_csv("data/hpt_summary.csv", table,
                   allow_missing=("applied_amount", "temperature_C"))
    return {"files": len(labelled), "f_window": f_window}
