"""Real-export quirks on hand-made files (no real data needed): a long series of traction
sweeps (the traction map, its figures, a speed-control glitch), an EHD2 fringe-order
misassignment, and the film's temperature scaling on films of a known law.

References: the numbers written into the files (each bin's readings, the glitch's line),
and films generated from ``h = C(T) v^n`` with ``C(T) = C0 exp(b (T - T0))`` in closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.conftest import DATA

HEAD = ("SRR (%)\tTraction Coeff (-)\t\t\t\t\t\t\tStep Time (s)\tPot RTD Temp (degC)\t"
        "Lube RTD Temp (degC)\tBall Load (N)\tWear (um)\t\tBall Speed 1\tBall Speed 2\t"
        "Ball Speed 3\tBall Speed 4\tDisc Speed 1\tDisc Speed 2\tDisc Speed 3\tDisc Speed 4\t"
        "Rolling Speed (mm/s)\tSliding Speed (mm/s)\tSRR (%)\t\tTF1 (N)\tTF2 (N)\tTF3 (N)\t"
        "TF4 (N)\tTraction Force (N)\tTraction Coeff (-)\tRolling Force (N)\tRolling Coeff (-)\t"
        "Traction Trace (-)")
SWEEP = (8.0, 6.0, 4.0, 2.0, 0.0, 2.0, 4.0, 6.0, 8.0)  # SRR (%), down and up
N_STEPS = 12


def _mu(step: int, srr: float) -> float:
    """The coefficient written for a step and SRR: a knee at 2 %, a plateau rising by 0.001
    per step."""
    return 0.0 if srr == 0 else 0.025 if srr == 2 else 0.050 + 0.001 * step


def _row(t: int, srr: float, mu: float, v: float = 25.0) -> str:
    ball, disc = v * (1 - srr / 200), v * (1 + srr / 200)
    f = mu * 1600.0
    cells = [f"{srr:.3f}", f"{mu:.4f}", "", "", "", "", "", "", str(t), "40.0", "39.5",
             "1600.000", "360", "", f"{ball:.2f}", "", "", "", f"{disc:.2f}", "", "", "",
             f"{v:.2f}", f"{disc - ball:.2f}", f"{srr:.3f}", "", f"{f:.4f}", f"{-f:.4f}", "",
             "", f"{f:.4f}", f"{mu:.4f}", "", "", ""]
    return "\t".join(cells)


def _series(path, glitch_step: int = 5):
    """An ETM-style export: ``N_STEPS`` traction sweeps 8 -> 0 -> 8 % SRR at 25 mm/s, ten
    minutes apart, a mapper step after the sixth; one reading of ``glitch_step`` at 29.5
    mm/s and SRR -27.8 %.  Returns the file and the glitch's line number."""
    lines, glitch = [], 0
    n = 1
    for k in range(1, N_STEPS + 1):
        minute = 10 * (k - 1)
        lines += [f"Step {n} started at 07/06/2019 {10 + minute // 60:02d}:{minute % 60:02d}:00",
                  "Step type\tTraction\tStep description\t25mms 8-0-8%",
                  "Zero traction force (N)\t0.5289\t(measured at the start of this step)",
                  "Disc track radius used for this step (mm)\t20.979", HEAD]
        for i, srr in enumerate(SWEEP):
            if k == glitch_step and i == 3:
                lines.append(_row(6 * i + 6, -27.807, 0.022, v=29.54))
                glitch = len(lines)
            lines.append(_row(6 * i + 6, srr, _mu(k, srr)))
        lines.append("")
        n += 1
        if k == 6:
            lines += [f"Step {n} started at 07/06/2019 10:55:00",
                      "Step type\tMapper\tStep description\t10",
                      "Camera window load = 198.652 N", ""]
            n += 1
    lines.append("All steps completed, test completed normally at 07/06/2019 12:10:00")
    path.write_bytes("\r\n".join(lines).encode("utf-8"))
    return path, glitch


def test_series_glitch_flagged_and_left_out(tmp_path):
    from torlab.instruments import reduce_file

    src, line = _series(tmp_path / "series.txt")
    red = reduce_file(src)
    d = red.detail.curves["traction"]
    assert d["speed_outlier"].sum() == 1
    assert d.loc[d["speed_outlier"], "line"].tolist() == [line]
    (note,) = [n for n in red.notes if "glitch of the speed control" in n]
    assert f"step 5 line {line} (29.54 mm/s against 25, SRR -27.8 %)" in note
    curves = red.traction_curves()
    assert len(curves) == N_STEPS and all(np.all(c.x <= 0.08) for c in curves)
    assert len(curves[4].x) == len(SWEEP)  # the glitch is not in step 5's curve


def test_traction_map_holds_each_steps_bin_medians(tmp_path):
    from torlab.instruments import reduce_file

    src, _ = _series(tmp_path / "series.txt")
    red = reduce_file(src)
    tm = red.tables["traction_map"]
    # 0-8 % SRR: 1 % bins (about twelve over the range, from 1, 2, 2.5, 5 x 10^k)
    assert tm["srr_high"].iloc[0] - tm["srr_low"].iloc[0] == pytest.approx(0.01)
    assert tm["step"].nunique() == N_STEPS
    for k, st in enumerate(sorted(tm["step"].unique()), start=1):
        sub = tm[tm["step"] == st].set_index("srr_low")
        # the bins read: 0 (the reading at 0), 2, 4, 6, 8 % (two readings each but 8 and 0)
        assert sorted(np.round(sub.index * 100).astype(int)) == [0, 2, 4, 6, 8]
        for lo in (4, 6, 8):
            assert sub.loc[lo / 100, "traction_coefficient"] == pytest.approx(_mu(k, lo))
        assert sub.loc[0.04, "n_points"] == 2 and sub.loc[0.08, "n_points"] == 2
    # hours from the first step's start, ten minutes apart
    assert sorted(tm.groupby("step")["time_h"].first()) == pytest.approx(
        [k / 6 for k in range(N_STEPS)])
    other = red.detail.other_steps
    assert other["step_type"].tolist() == ["mapper"] and other["time_h"].iloc[0] == \
        pytest.approx(55 / 60)


def test_traction_map_and_evolution_figures(tmp_path):
    """The new views are drawn with symbols and units on both axes, every text inside the
    canvas, and no legend entry twice."""
    from torlab.instruments import reduce_file
    from torlab.reports.plotting import finish

    src, _ = _series(tmp_path / "series.txt")
    red = reduce_file(src)
    figs = red.figures()
    assert {"traction", "traction_map", "traction_evolution"} <= set(figs)
    for name in ("traction_map", "traction_evolution"):
        fig = finish(figs[name])
        ax = fig.axes[0]
        assert "(" in ax.get_xlabel() and "(" in ax.get_ylabel()
        assert "μ" in ax.get_ylabel() or "SRR" in ax.get_ylabel()
        fig.canvas.draw()  # the axis labels take their place from the tick labels
        # everything drawn (the figure's own layout: its tight box) lies on the canvas
        tight = fig.get_tightbbox(fig.canvas.get_renderer())
        w, h = fig.get_size_inches()
        assert tight.x0 >= -0.01 and tight.y0 >= -0.01 and tight.x1 <= w + 0.01 \
            and tight.y1 <= h + 0.01, (name, tight, (w, h))
        lg = ax.get_legend()
        if lg is not None:
            labels = [t.get_text() for t in lg.get_texts()]
            assert len(labels) == len(set(labels))
    ev = finish(figs["traction_evolution"]).axes[0]
    assert "time" in ev.get_xlabel() and "(h)" in ev.get_xlabel()
    labels = [t.get_text() for t in ev.get_legend().get_texts()]
    assert "mapper step" in labels and sum(x.startswith("SRR ") for x in labels) == 4


def test_few_traction_steps_keep_their_figure(tmp_path):
    """Below ten sweeps no map: the steps are drawn one by one, the glitch as a cross."""
    from torlab.instruments import reduce_file

    src = DATA / "pcs" / "etm_quirks.txt"
    red = reduce_file(src)
    assert "traction_map" not in red.tables and red.detail.traction_map is None


def test_ehd2_fringe_order_misassignment_flagged(tmp_path):
    """The hand-made EHD2 export with one reading moved by a fringe: order 4 and 10 times
    the film at a faster speed."""
    from torlab.instruments import reduce_file

    raw = (DATA / "pcs" / "ehd2_quirks.txt").read_bytes().decode("cp1252")
    nl = "\r\n" if "\r\n" in raw else "\n"
    lines = raw.split(nl)
    head = next(ln for ln in lines if ln.startswith("Rolling Speed")).split("\t")
    io, ih = head.index("Order"), len(head) - 1 - head[::-1].index("Average Film (nm)")
    rows = [i for i, ln in enumerate(lines) if ln[:1].isdigit() and len(ln.split("\t")) == len(head)]
    f = lines[rows[1]].split("\t")  # the second film reading (50 mm/s, 52.1 nm)
    f[io], f[ih], f[1] = "4", "800.0", "800.0"
    lines[rows[1]] = "\t".join(f)
    src = tmp_path / "ehd2.txt"
    src.write_bytes(nl.join(lines).encode("cp1252"))
    red = reduce_file(src)
    film = red.detail.curves["film"]
    assert film["interference_order_outlier"].tolist() == [False, True, False, False]
    (note,) = [n for n in red.notes if "fringe-order" in n]
    assert f"line {rows[1] + 1}" in note and "order 4 where the step's others are at 3" in note
    (c,) = red.film_curves()
    assert c.y.tolist() == pytest.approx([24.4e-9, 82.2e-9, 136.5e-9])


def test_film_temperature_scaling_recovers_a_known_law():
    """Films of h = C0 exp(b (T - 40)) v^0.7 at 40, 60, 80 degC with 1 % noise: the fitted
    b holds the true -0.02 1/K, the exponents are one, the ratio of viscosities for a
    constant alpha is exp(b dT / 0.67)."""
    from torlab.fit.film import fit_film_temperature, fit_film_thickness

    rng = np.random.default_rng(7)
    v = np.geomspace(0.1, 1.0, 12)
    fits, temps = [], [40.0, 60.0, 80.0]
    for T in temps:
        h = 40e-9 * math.exp(-0.02 * (T - 40.0)) * v**0.7 * np.exp(rng.normal(0, 0.01, v.size))
        fits.append(fit_film_thickness(v, h))
    r = fit_film_temperature(fits, temps)
    lo, hi = r.ci95["film_temperature_coefficient"]
    assert lo < -0.02 < hi and hi - lo < 0.01
    assert r.meta["reference_speed_m_s"] == pytest.approx(math.sqrt(0.1 * 1.0))
    h_ref = 40e-9 * math.sqrt(0.1) ** 0.7
    lo, hi = r.ci95["film_at_reference"]
    assert lo < h_ref < hi
    assert r.meta["speed_exponents"]["p_one_exponent"] > 0.01
    ratio = r.meta["viscosity_ratio_if_alpha_constant"]["80.0"]
    assert ratio == pytest.approx(math.exp(r.params["film_temperature_coefficient"] * 40 / 0.67))
    # the new figure: on its canvas (the figure's own tight box), no legend entry twice
    from torlab.reports.plotting import finish

    fig = finish(r.plot())
    fig.canvas.draw()
    tight = fig.get_tightbbox(fig.canvas.get_renderer())
    w, h = fig.get_size_inches()
    assert tight.x0 >= -0.01 and tight.y0 >= -0.01 and tight.x1 <= w + 0.01 and tight.y1 <= h + 0.01
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert len(labels) == len(set(labels)) and "95 % interval of each fit" in labels
    assert "(°C)" in fig.axes[-1].get_xlabel() and "(nm)" in fig.axes[0].get_ylabel()


def test_film_temperature_scaling_refuses_what_it_cannot_do():
    from torlab.errors import TorlabInputError
    from torlab.fit.film import fit_film_temperature, fit_film_thickness

    v = np.geomspace(0.1, 1.0, 8)
    a = fit_film_thickness(v, 40e-9 * v**0.7 * (1 + 0.01 * np.sin(7 * v)))
    with pytest.raises(TorlabInputError, match="at least two"):
        fit_film_temperature([a], [40.0])
    with pytest.raises(TorlabInputError, match="at least 2 K"):
        fit_film_temperature([a, a], [40.0, 41.0])
    b = fit_film_thickness(v * 20, 40e-9 * (20 * v) ** 0.7 * (1 + 0.01 * np.cos(7 * v)))
    with pytest.raises(TorlabInputError, match="share no speed range"):
        fit_film_temperature([a, b], [40.0, 60.0])


def test_fit_film_cli_temperature_scaling_from_csvs(cli, tmp_path):
    """Two CSVs at 40 and 80 degC (a temperature_C column): one fit each and temperature/,
    with the known law's coefficient in its interval and the exponents compared."""
    import json

    import pandas as pd

    rng = np.random.default_rng(11)
    v = np.geomspace(0.1, 1.0, 12)
    files = []
    for T in (40.0, 80.0):
        h = 40e-9 * math.exp(-0.02 * (T - 40.0)) * v**0.7 * np.exp(rng.normal(0, 0.01, v.size))
        f = tmp_path / f"film_{T:.0f}C.csv"
        pd.DataFrame({"speed_m_s": v, "film_thickness_m": h, "temperature_C": T}).to_csv(
            f, index=False)
        files.append(f)
    r = cli("fit", "film", *files, "-o", tmp_path / "out")
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "out" / "temperature" / "summary.json").read_text())
    lo, hi = s["ci95"]["film_temperature_coefficient"]
    assert lo < -0.02 < hi
    e = s["meta"]["speed_exponents"]
    said = "rejected" if e["p_one_exponent"] < 0.05 else "not rejected"
    assert f"one common exponent {said} (Welch's F {e['welch_f']:.3g}" in " ".join(
        r.output.split())
    assert sorted(p.parent.name for p in (tmp_path / "out").glob("*/params.yaml")) == \
        ["film_40C", "film_80C", "temperature"]


@pytest.mark.slow  # 300 simulated campaigns of three film fits; the test's parts are quick above
def test_one_exponent_test_rejects_a_true_common_exponent_at_its_level():
    """Three curves of one law (exponent 0.7), 12 speeds, 1 % scatter: Welch's test of one
    common exponent rejects at p < 0.05 in 5 % of campaigns (binomial 95 % range over 300:
    2.7-7.7 %); a chi-squared with the fits' estimated variances taken as known would not."""
    from torlab._stats import chi2_sf
    from torlab.fit.film import fit_film_temperature, fit_film_thickness

    v = np.geomspace(0.1, 1.0, 12)
    welch = chi2 = 0
    for seed in range(300):
        rng = np.random.default_rng(seed)
        fits = [fit_film_thickness(v, 40e-9 * math.exp(-0.02 * (T - 40.0)) * v**0.7
                                   * np.exp(rng.normal(0, 0.01, v.size)))
                for T in (40.0, 60.0, 80.0)]
        e = fit_film_temperature(fits, [40.0, 60.0, 80.0]).meta["speed_exponents"]
        welch += e["p_one_exponent"] < 0.05
        chi2 += chi2_sf(e["chi2_one_exponent"], 2) < 0.05
    assert 8 <= welch <= 23
    assert chi2 > welch

