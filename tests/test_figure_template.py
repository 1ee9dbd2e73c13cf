"""A fit figure drawn into a kept figure shows exactly what a new figure shows.

:func:`torlab.reports.render.draw_task` draws a fit's figure (``result_figure``) into a
figure of the same layout kept from an earlier fit (:func:`torlab.reports.fit.
redraw_result_figure`), as a campaign draws one per fitted set.  Here a sequence of fits --
other data ranges (other ticks, tick labels and offsets), other titles and legend labels
(another legend width, so another figure width), one and several curves, dense and sparse
points, linear and log-log axes, residuals on one side of zero, a layout seen again after
another, one that is never refilled -- is drawn both ways and every PNG compared with the
one of a new figure, pixel for pixel and byte for byte; the test also checks that the kept
figures were in fact refilled, where and only where the layouts agree.
"""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest

import torlab.reports.fit as fitfig
import torlab.reports.render as render
from torlab.fit.result import FitResult
from torlab.reports.fit import result_figure
from torlab.reports.render import draw_task, plot, render_all


def _result(kind: str, data: pd.DataFrame, params: dict[str, float], *, names=None,
            meta=None, residual_unit: str = "-") -> FitResult:
    names = tuple(names or params)
    return FitResult(kind=kind, names=names, params=params,
                     stderr={n: 0.05 * abs(params[n]) for n in names},
                     ci95={n: (0.9 * params[n], 1.1 * params[n]) for n in names},
                     correlation=np.eye(len(names)), residual_norm=0.01, n_points=len(data),
                     warnings=[], data=data, meta=meta or {}, residual_unit=residual_unit)


def _hpt(seed: int, curves: int, points: int, stress: float, reach: float, *, names=None,
         source: str = "", shift: float = 0.0) -> FitResult:
    """An HPT layer fit of ``curves`` curves of ``points`` points: displacements up to
    ``reach`` [m], stresses up to ``stress`` [Pa]; ``shift > 0``: every residual above
    zero (its size plus ``shift * stress``)."""
    rng = np.random.default_rng(seed)
    rows = []
    for c in range(curves):
        u = np.sort(rng.uniform(0.0, reach, points))
        model = stress * (1 - np.exp(-u / (0.2 * reach))) * (1 + 0.05 * c)
        meas = model + rng.normal(0.0, 0.02 * stress, points)
        res = meas - model
        rows.append(pd.DataFrame({"curve": c, "displacement_m": u,
                                  "shear_stress_measured_Pa": meas,
                                  "shear_stress_model_Pa": model,
                                  "residual_Pa": np.abs(res) + shift * stress if shift else res}))
    data = pd.concat(rows, ignore_index=True)
    if curves == 1:
        data = data.drop(columns="curve")
    meta = {"source": source}
    if names is not None:
        meta["curves"] = names
    params = {"mu_c1": 0.1 + 0.01 * seed, "mu_c2": 0.3, "L_mue": 0.2 * reach,
              "L_mup": 2.0 * reach}
    return _result("layer_hpt", data, params, meta=meta, residual_unit="Pa")


def _temperature(seed: int, t0: float, t1: float, level: float) -> FitResult:
    rng = np.random.default_rng(seed)
    t = np.linspace(t0, t1, 7)
    d = {"temperature_C": t}
    for key, mu in (("mu_c1", level), ("mu_c2", 2.5 * level)):
        model = mu * (1 - 4e-3 * (t - 25.0))
        meas = model + rng.normal(0.0, 0.01 * mu, t.size)
        d |= {f"{key}_measured": meas, f"{key}_model": model, f"residual_{key}": meas - model}
    params = {"mu_c1_T": -4e-3 * level, "mu_c2_T": -1e-2 * level, "mu_c1_Tref": level,
              "mu_c2_Tref": 2.5 * level}
    return _result("temperature", pd.DataFrame(d), params)


def _film(seed: int, v0: float, v1: float, h: float, alpha: float) -> FitResult:
    rng = np.random.default_rng(seed)
    v = np.geomspace(v0, v1, 12)
    model = h * (v / v0) ** 0.67
    meas = model * np.exp(rng.normal(0.0, 0.05, v.size))
    data = pd.DataFrame({"speed_m_s": v, "film_thickness_measured_m": meas,
                         "film_thickness_model_m": model, "residual_m": meas - model,
                         "film_thickness_hamrock_dowson_m": 1.1 * model})
    return _result("film", data, {"film_prefactor": h, "speed_exponent": 0.67, "alpha": alpha},
                   names=("film_prefactor", "speed_exponent"), residual_unit="m")


def _film_temperature(seed: int) -> FitResult:
    rng = np.random.default_rng(seed)
    t = np.array([20.0, 40.0, 60.0, 80.0])
    model = 200e-9 * np.exp(-0.02 * (t - 40.0))
    meas = model * np.exp(rng.normal(0.0, 0.03, t.size))
    data = pd.DataFrame({"temperature_C": t, "film_thickness_measured_m": meas,
                         "film_thickness_model_m": model, "residual_m": meas - model,
                         "film_thickness_se_ln": np.full(t.size, 0.04)})
    r = _result("film_temperature", data, {"film_at_reference": 200e-9,
                                           "film_temperature_coefficient": -0.02},
                meta={"reference_temperature_C": 40.0, "reference_speed_m_s": 1.0},
                residual_unit="m")
    return r


def _png_pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))


#: (fit, whether its figure is drawn into a kept one: a layout seen before, still kept)
SEQUENCE = [
    ("hpt one curve", lambda: _hpt(1, 1, 40, 60e6, 20e-6, source="a.txt"), False),
    ("hpt one curve, other ranges", lambda: _hpt(2, 1, 40, 3e3, 2e-3, source="b_4uL.txt"), True),
    ("hpt four dense curves", lambda: _hpt(3, 4, 250, 80e6, 30e-6, source="c.txt"), False),
    ("temperature", lambda: _temperature(4, 10.0, 70.0, 0.12), False),
    ("hpt four dense curves, named, wider legend",
     lambda: _hpt(5, 4, 300, 1e6, 5e-5, names=["x.txt", "a much longer file name.txt",
                                                "y_2uL.txt", "z.txt"]), True),
    ("temperature, other ranges", lambda: _temperature(6, -20.0, 150.0, 0.9), True),
    ("hpt one curve, residuals all just above zero",
     lambda: _hpt(7, 1, 40, 50e6, 10e-6, shift=1e-6, source="d.txt"), True),
    ("film, log-log", lambda: _film(8, 0.01, 3.0, 20e-9, 15e-9), False),
    ("film, log-log, other decades", lambda: _film(9, 1e-3, 30.0, 300e-9, 22e-9), True),
    ("hpt three curves", lambda: _hpt(10, 3, 50, 40e6, 15e-6), False),
    ("film temperature (never kept)", lambda: _film_temperature(11), False),
    ("film temperature again", lambda: _film_temperature(12), False),
    ("hpt one curve, seen again", lambda: _hpt(13, 1, 40, 7e7, 3e-5, source="e.txt"), True),
]


#: the quick suite's part of :data:`SEQUENCE`: the HPT layer fits' layouts (other ranges,
#: a wider legend, residuals just above zero)
QUICK = ("hpt one curve", "hpt one curve, other ranges", "hpt four dense curves",
         "hpt four dense curves, named, wider legend",
         "hpt one curve, residuals all just above zero")


@pytest.mark.parametrize("part", [QUICK, pytest.param(None, marks=pytest.mark.slow)],
                         ids=["hpt", "all"])  # all: 13 fits drawn twice, about 3 s
def test_a_refilled_fit_figure_is_pixel_for_pixel_a_new_one(monkeypatch, part):
    monkeypatch.setattr(render, "_KEPT", {})
    refilled: list[str] = []
    real = fitfig._refill

    def spy(fig, spec):
        refilled.append(current[0])
        return real(fig, spec)

    monkeypatch.setattr(fitfig, "_refill", spy)
    current = [""]
    for name, make, expect_refill in SEQUENCE:
        if part is not None and name not in part:
            continue
        current[0] = name
        result = make()
        p = plot(result_figure, result)
        reused = draw_task((p, ("png",), None))["png"]
        fresh = render_all(p.draw(), ("png",), None)["png"]
        a, b = _png_pixels(reused), _png_pixels(fresh)
        assert a.shape == b.shape, f"{name}: {a.shape} against a new figure's {b.shape}"
        differ = int(np.any(a != b, axis=-1).sum())
        assert differ == 0, f"{name}: {differ} pixels differ from a new figure's"
        assert reused == fresh, name
        assert (name in refilled) == expect_refill, (name, refilled)
    assert len(render._KEPT) <= render.KEEP


def test_kept_figures_are_bounded_and_only_for_png(monkeypatch):
    monkeypatch.setattr(render, "_KEPT", {})
    monkeypatch.setattr(render, "KEEP", 2)
    refilled: list[int] = []
    real = fitfig._refill
    monkeypatch.setattr(fitfig, "_refill", lambda fig, s: (refilled.append(1), real(fig, s)))
    one, four, temp = (_hpt(1, 1, 30, 6e7, 2e-5), _hpt(2, 4, 30, 6e7, 2e-5),
                       _temperature(3, 10.0, 60.0, 0.1))
    for r in (one, four, temp):  # three layouts, two kept: the first one is dropped
        draw_task((plot(result_figure, r), ("png",), None))
    assert len(render._KEPT) == 2 and not refilled
    draw_task((plot(result_figure, _hpt(4, 1, 30, 6e7, 2e-5)), ("png",), None))
    assert not refilled  # its layout was dropped: drawn anew
    draw_task((plot(result_figure, _temperature(5, 0.0, 50.0, 0.2)), ("png",), None))
    assert len(refilled) == 1
    # SVG and PDF, and PNG with them, always from a new figure, byte for byte as before
    p = plot(result_figure, _temperature(6, 0.0, 90.0, 0.3))
    both = draw_task((p, ("png", "svg"), None))
    assert len(refilled) == 1
    assert both == render_all(p.draw(), ("png", "svg"), None)
    # another resolution: drawn anew (and kept under it)
    draw_task((plot(result_figure, _temperature(7, 0.0, 50.0, 0.2)), ("png",), 100.0))
    assert len(refilled) == 1 and len(render._KEPT) == 2
    # a kept figure holds no renderer (its pixels): neither its canvas nor its texts
    from matplotlib.text import Text

    for _, fig in render._KEPT.values():
        assert "renderer" not in vars(fig.canvas)
        assert all(getattr(t, "_renderer", None) is None for t in fig.findobj(Text))


def test_a_failed_drawing_leaves_no_kept_figure(monkeypatch):
    monkeypatch.setattr(render, "_KEPT", {})
    draw_task((plot(result_figure, _hpt(1, 1, 30, 6e7, 2e-5)), ("png",), None))
    assert len(render._KEPT) == 1
    bad = _hpt(2, 1, 30, 6e7, 2e-5)
    monkeypatch.setattr(fitfig, "_refill", lambda fig, s: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        draw_task((plot(result_figure, bad), ("png",), None))
    assert not render._KEPT  # the half-refilled figure is not used again
