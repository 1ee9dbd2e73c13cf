"""The thesis's statements and numbers against torlab (docs/validation.md, one test per row).

Every row of the table in ``docs/validation.md`` has a test here that computes torlab's
value -- from the model alone (``model`` rows: the thesis's own numbers, such as Tab. 5.4's
p0 from Hertz) or from a shipped protocol run on the synthetic sample data (``campaign``
rows: does the campaign reproduce the statement it stands for?) -- asserts the agreement the
row states, and checks that the table shows the value it computed (so the document cannot
drift from the code).  The references are the thesis's numbers and statements, not torlab's
output; a row that torlab reproduces only in part asserts what holds and the table says what
does not, and why.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

DOC = ROOT / "docs" / "validation.md"
SCENES = ROOT / "protocols" / "scenes"
#: the rows read from the Paper A and Paper C protocol runs (about ten seconds each, from raw
#: logs to reports) run in CI's slow step with the regression tests of those runs
#: (tests/test_protocols.py); the Paper B rows, from the quicker run, stay in the quick suite
SHIPPED_A_C = pytest.mark.slow


def _rows() -> dict[str, list[str]]:
    """``id -> cells`` of the validation table."""
    out = {}
    for line in DOC.read_text(encoding="utf-8").splitlines():
        m = re.match(r"^\|\s*([A-Z]\d+)\s*\|", line)
        if m:  # cells split at unescaped pipes (a "\\|" is text)
            cells = re.split(r"(?<!\\)\|", line.strip()[1:-1])
            out[m.group(1)] = [c.strip() for c in cells]
    return out


def _shows(row: str, *values: str, column: int = 5) -> None:
    """The table's torlab cell (or ``column``) of ``row`` shows every one of ``values``."""
    rows = _rows()
    assert row in rows, f"docs/validation.md has no row {row}"
    cell = rows[row][column]
    for v in values:
        assert v in cell, f"{row}: the table shows {cell!r}, torlab computes {v}"


def _sum(shipped_run, name: str) -> dict:
    return shipped_run(name)[1].summary


def test_every_row_has_a_test():
    ids = set(_rows())
    here = Path(__file__).read_text(encoding="utf-8")
    tested = set(re.findall(r"def test_([a-z]\d+)_", here))
    assert {i.lower() for i in ids} == tested, "rows and tests differ"
    for cells in _rows().values():
        assert cells[3] in ("model", "scene", "campaign"), cells
        assert cells[8] in ("reproduced", "partly", "not reproduced"), cells


# ------------------------------------------------------------------ model: the thesis's numbers
def test_m1_tab54_p0_from_hertz():
    """Tab. 5.4: a = 3.7 mm, b = 3.3 mm, F = 20 kN give p0 = 790 MPa (3F / 2 pi a b)."""
    from torlab.model.contact import build_contact
    from torlab.scene import load_scene

    p0 = build_contact(load_scene(SCENES / "wheel_rail_tab54.yaml")).patch.p0 / 1e6
    # a and b are printed to 0.05 mm: p0 is known to (0.05/3.7 + 0.05/3.3) = 2.9 %
    assert abs(p0 / 790 - 1) < 0.05 / 3.7 + 0.05 / 3.3
    _shows("M1", f"{p0:.0f} MPa")
    _shows("M1", f"{100 * (p0 / 790 - 1):+.1f} %".replace("+", ""), column=6)


def test_m2_tab51_k_smooth():
    from torlab.model.asperity import roughness_K

    k = roughness_K(8.3e-9, 0.301e-3, 24200e6)
    assert abs(k - 0.0605) <= 0.00005 + 1e-12  # printed to three digits
    _shows("M2", f"{k:.5f}")


def test_m3_tab51_k_rough():
    from torlab.model.asperity import roughness_K

    k = roughness_K(9.56e-9, 0.373e-3, 21500e6)
    assert abs(k - 0.0767) <= 0.00005 + 1e-12
    _shows("M3", f"{k:.5f}")


def test_m4_hpt_annulus_area():
    """5.1.3: annulus of 12 mm outer and 6 mm inner diameter: 85 mm²."""
    from torlab.reduce.hpt import annulus_area

    s = annulus_area(3e-3, 6e-3) * 1e6
    assert abs(s - 85) <= 0.5
    _shows("M4", f"{s:.1f} mm²")


def test_m5_mtm_70n_pressure():
    """5.1.2: the MTM's 70 N give 1.25 GPa (19.05 mm steel ball on a steel disc)."""
    from torlab.model.hertz import E_star, hertz

    def p0(E: float) -> float:
        return hertz(70.0, 9.525e-3, 9.525e-3, E_star(E, 0.3, E, 0.3), method="exact").p0 / 1e9

    lo, hi = p0(200e9), p0(210e9)   # AISI 52100: E 200-210 GPa (not stated in the thesis)
    assert lo <= 1.25 <= hi
    _shows("M5", f"{hi:.3f} GPa", f"{lo:.3f}")


def test_m6_paper_a_scene_pressure():
    from torlab.model.contact import build_contact
    from torlab.scene import load_scene

    p0 = build_contact(load_scene(SCENES / "optical_paper_a_dry.yaml")).patch.p0 / 1e9
    assert abs(p0 - 0.75) < 0.005
    _shows("M6", f"{p0:.3f} GPa")


def test_m7_paper_b_scene_pressure():
    from torlab.model.contact import build_contact
    from torlab.scene import load_scene

    p0 = build_contact(load_scene(SCENES / "mtm_paper_b.yaml")).patch.p0 / 1e6
    assert abs(p0 - 800) < 10
    _shows("M7", f"{p0:.0f} MPa")


@SHIPPED_A_C
def test_m8_elastic_asperities_underestimate_at_low_speed(shipped_run):
    """Chapter 6 (Paper A): the elastic asperity model heavily underestimates the coefficient at
    low speed and gets more accurate at higher speed (against the plastic one, which the
    synthetic Stribeck points follow)."""
    from torlab.model.mixed import stribeck_curve
    from torlab.scene import load_scene

    out, _ = shipped_run("paper_a")
    sc = load_scene(SCENES / "optical_paper_a_smooth.yaml", out / "fits" / "traction_dry.yaml")
    el = sc.model_copy(update={"roughness": sc.roughness.model_copy(update={"model": "elastic"})})
    v = np.array([0.1, 0.3, 1.0, 2.0])
    ratio = (stribeck_curve(el, v, 0.05).table["mu"].to_numpy()
             / stribeck_curve(sc, v, 0.05).table["mu"].to_numpy())
    assert ratio[0] < 0.5                      # heavily underestimates at low speed
    assert np.all(np.diff(ratio) > 0)          # and less so as the speed rises
    assert ratio[-1] < 0.5                     # but not accurate at 2 m/s: the part not reproduced
    _shows("M8", f"{ratio[0]:.3f}", f"{ratio[-1]:.3f}")


# ------------------------------------------------------------------ Paper A campaign
@SHIPPED_A_C
def test_a1_film_near_eq531(shipped_run):
    r = _sum(shipped_run, "paper_a")["reports"]["film"]["measured_to_model"]["smooth ball"]
    assert r["ratio_low95"] <= 1.0 <= r["ratio_high95"]
    _shows("A1", f"{r['ratio']:.3f}", f"[{r['ratio_low95']:.3f}, {r['ratio_high95']:.3f}]")


@SHIPPED_A_C
def test_a2_smooth_stribeck_very_low(shipped_run):
    out, _res = shipped_run("paper_a")
    import pandas as pd

    d = pd.read_csv(out / "stribeck" / "curves.csv")
    m = {c: d[(d["curve"] == c) & (d["kind"] == "measured")].sort_values("speed_m_s")
         for c in ("smooth ball", "rough ball")}
    smooth, rough = m["smooth ball"]["mu"].to_numpy(), m["rough ball"]["mu"].to_numpy()
    assert smooth.max() < 0.1 and np.all(smooth < rough)
    _shows("A2", f"{smooth.min():.4f}–{smooth.max():.3f}")


@SHIPPED_A_C
def test_a3_model_represents_the_data(shipped_run):
    st = _sum(shipped_run, "paper_a")["reports"]["stribeck"]["curves"]
    for lab in ("smooth ball", "rough ball"):
        assert st[lab]["rms_measured_minus_model"] < 0.05 * st[lab]["measured_mu_max"]
    _shows("A3", f"{st['smooth ball']['rms_measured_minus_model']:.1e}",
           f"{st['rough ball']['rms_measured_minus_model']:.1e}")


@SHIPPED_A_C
def test_a4_dry_saturation_low(shipped_run):
    mu = _sum(shipped_run, "paper_a")["reports"]["traction"]["curves"][
        "measured dry_traction_rough.csv"]["mu_max"]
    assert mu < 0.3
    _shows("A4", f"{mu:.3f}")


# ------------------------------------------------------------------ Paper B campaign
def _tt(shipped_run) -> dict:
    return _sum(shipped_run, "paper_b")["reports"]["time_test"]["compositions"]


def test_b1_custom_compositions_in_band(shipped_run):
    tt = _tt(shipped_run)
    vals = []
    for lab in ("base medium 5 uL", "base + Al2O3 5 uL", "base + MoS2 5 uL"):
        v = tt[lab]
        assert v["in_band_verdict"] == "in band" and v["p_in_band"] >= 0.9, lab
        vals.append(f"{v['mean_after_recovery']:.4f}")
    _shows("B1", *vals)


def test_b2_mos2_no_significant_reduction(shipped_run):
    tt = _tt(shipped_run)
    base, mos2 = tt["base medium 5 uL"], tt["base + MoS2 5 uL"]
    rel = mos2["mean_after_recovery"] / base["mean_after_recovery"] - 1
    assert abs(rel) < 0.05
    se = math.hypot(base["mean_after_recovery_se"], mos2["mean_after_recovery_se"])
    z = (mos2["mean_after_recovery"] - base["mean_after_recovery"]) / se
    _shows("B2", f"{100 * rel:+.1f} %", f"z = {z:.1f}")


def test_b3_particles_do_not_suppress_the_drop(shipped_run):
    tt = _tt(shipped_run)
    base, al = tt["base medium 5 uL"], tt["base + Al2O3 5 uL"]
    assert abs(al["minimum"] - base["minimum"]) < 0.01
    assert al["minimum_high95"] < 0.15 and base["minimum_high95"] < 0.15
    _shows("B3", f"{al['minimum']:.4f}", f"{base['minimum']:.4f}")


def test_b4_tor_a_over_lubricates_at_the_higher_amount(shipped_run):
    tt = _tt(shipped_run)
    assert tt["TOR A 20 uL"]["recovered_verdict"] == "not recovered"
    assert tt["TOR A 5 uL"]["recovered_verdict"] == "recovered"
    _shows("B4", f"{tt['TOR A 20 uL']['p_recovered']:.2f}", f"{tt['TOR A 5 uL']['p_recovered']:.2f}")


def test_b5_hpt_commercial_low_custom_in_band(shipped_run):
    f = _sum(shipped_run, "paper_b")["fits"]
    lo_c, hi_c = f["hpt:custom"]["ci95"]["mu_c2"]
    _lo_a, hi_a = f["hpt:TOR-A"]["ci95"]["mu_c2"]
    assert 0.15 <= lo_c and hi_c <= 0.25
    assert hi_a < 0.15
    _shows("B5", f"{f['hpt:custom']['params']['mu_c2']:.3f}",
           f"{f['hpt:TOR-A']['params']['mu_c2']:.3f}")


def test_b6_initial_drop_is_a_lubrication_regime_effect(shipped_run):
    """The model puts the freshly lubricated contact in the full-film regime, far below 0.15
    (reproduced); its level is 9-20 times below the measured minima (not reproduced)."""
    out, res = shipped_run("paper_b")
    tt = res.summary["reports"]["time_test"]["compositions"]
    mus = [v["model_initial_mu"] for v in tt.values()]
    assert max(mus) < 0.15
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "regimes: full_film" in md
    ratios = [v["minimum"] / v["model_initial_mu"] for v in tt.values()]
    assert min(ratios) > 2           # the part not reproduced, as the table says
    _shows("B6", f"{mus[0]:.4f}", f"{min(ratios):.2g}–{max(ratios):.2g}")


# ------------------------------------------------------------------ Paper C campaign
def _c(shipped_run) -> dict:
    return _sum(shipped_run, "paper_c")


@SHIPPED_A_C
def test_c1_dry_friction_about_half(shipped_run):
    fw = _c(shipped_run)["data"]["hpt"]["f_window"]
    f = [v for k, v in fw.items() if k.startswith("hpt_dry_25C")]
    m = sum(f) / len(f)
    assert len(f) == 4 and abs(m - 0.5) < 0.05
    _shows("C1", f"{m:.3f}")


@SHIPPED_A_C
def test_c2_temperature_lowers_dry_friction(shipped_run):
    s = _c(shipped_run)
    _lo, hi = s["fits"]["hpt-T:dry"]["ci95"]["mu_c2_T"]
    assert hi < 0
    fw = s["data"]["hpt"]["f_window"]
    hot = np.mean([v for k, v in fw.items() if k.startswith("hpt_dry_185C")])
    _shows("C2", f"{s['fits']['hpt-T:dry']['params']['mu_c2_T']:.5f}", f"{hot:.3f}")


PRODUCTS = ("OFM1", "OFM2", "SFM", "WFM-dry", "WFM-wet")


@SHIPPED_A_C
def test_c3_products_suppress_the_temperature_effect(shipped_run):
    f = _c(shipped_run)["fits"]
    _dry_lo, dry_hi = f["hpt-T:dry"]["ci95"]["mu_c2_T"]
    dry = f["hpt-T:dry"]["params"]["mu_c2_T"]
    worst = 0.0
    for p in PRODUCTS:
        lo, _hi = f[f"hpt-T:{p}"]["ci95"]["mu_c2_T"]
        assert lo > dry_hi, p
        worst = max(worst, abs(f[f"hpt-T:{p}"]["params"]["mu_c2_T"] / dry))
    assert worst < 0.2
    _shows("C3", f"{worst:.2f}")


@SHIPPED_A_C
def test_c4_no_product_rises_with_temperature(shipped_run):
    f = _c(shipped_run)["fits"]
    highest = max(f[f"hpt-T:{p}"]["ci95"]["mu_c2_T"][0] for p in PRODUCTS)
    assert highest < 0  # no lower bound above 0: no product's friction rises significantly
    _shows("C4", f"{highest:.5f}")


@SHIPPED_A_C
def test_c5_products_neutral_traction_trend(shipped_run):
    tr = _c(shipped_run)["reports"]["traction"]["curves"]
    shown = []
    for p in ("OFM1", "OFM2", "SFM", "WFM-dry"):
        v = tr[f"{p} (Tab. 5.4)"]
        assert v["trend"] == "neutral" and v["probabilities"]["neutral"] >= 0.9, p
        shown.append(f"{v['probabilities']['neutral']:.2f}")
    wet = tr["WFM-wet (Tab. 5.4)"]
    assert wet["trend"] == "undetermined"    # the part not reproduced (table: why)
    _shows("C5", *shown, f"{wet['probabilities']['neutral']:.2f}")


@SHIPPED_A_C
def test_c6_dry_trend_negative(shipped_run):
    v = _c(shipped_run)["reports"]["traction"]["curves"]["dry (Tab. 5.4)"]
    assert v["trend"] == "negative" and v["probabilities"]["negative"] >= 0.9
    _shows("C6", f"{100 * v['relative_change']:+.1f} %")


@SHIPPED_A_C
def test_c7_wet_fm_never_low(shipped_run):
    v = _c(shipped_run)["reports"]["amount"]["products"]["WFM-wet"]
    assert v["status"] == "above threshold at every amount"
    assert v["status_verdict"] == v["status"] and v["p_status"] >= 0.9
    _shows("C7", f"{v['p_status']:.3f}")


@SHIPPED_A_C
def test_c8_same_mass_for_every_product(shipped_run):
    h = _c(shipped_run)["reports"]["amount"]["mass_homogeneity"]
    assert set(h["products"]) == {"OFM1", "OFM2", "SFM", "WFM-dry"}
    assert h["p_value"] >= 0.05
    _shows("C8", f"p = {h['p_value']:.2f}", f"{h['mass_mg']:.2f} mg")


@SHIPPED_A_C
def test_c9_one_microlitre_about_one_milligram(shipped_run):
    prods = _c(shipped_run)["reports"]["amount"]["products"]
    f = [v["mg_per_unit"] for p, v in prods.items() if v["amount_unit"] == "uL"]
    assert min(f) >= 0.9 - 1e-9 and max(f) <= 1.1 + 1e-9
    _shows("C9", f"{min(f):.2f}–{max(f):.2f}")


# ------------------------------------------------------------------ the Paper C report's calls
@SHIPPED_A_C
def test_paper_c_calls_no_trend_below_the_threshold(shipped_run):
    """Every trend the Paper C report calls has at least the protocol's probability; the
    others are 'undetermined' with their probabilities (issue: verdicts with evidence)."""
    out, res = shipped_run("paper_c")
    tr = res.summary["reports"]["traction"]
    thr = tr["trend_probability"]
    assert thr == 0.9
    called = 0
    for name, v in tr["curves"].items():
        probs = v["probabilities"]
        assert probs is not None, f"{name}: a modelled curve without probabilities"
        assert sum(probs.values()) == pytest.approx(1.0, abs=1e-9)
        if v["trend"] in ("negative", "neutral", "positive"):
            assert probs[v["trend"]] >= thr, name
            called += 1
        else:
            assert v["trend"] == "undetermined" and max(probs.values()) < thr, name
    assert called >= 5
    # the report's text says the same, curve by curve
    md = (out / "report.md").read_text(encoding="utf-8")
    for name, v in tr["curves"].items():
        if v["trend"] == "undetermined":
            assert f"{name} (model): " in md and "undetermined: no class reaches probability" in md
        else:
            p = v["probabilities"][v["trend"]]
            assert f"trend after saturation {v['trend']} with probability {p:.2f}" in md
