"""Coverage of the 95 % intervals of the traction, temperature and film fits, for noise of
constant size and for noise proportional to the signal (200 seeds each).

Each sweep draws synthetic data from the fit's own model at known parameters, fits it, and
counts how often each parameter's 95 % interval holds the truth.  Binomial spread for 200
seeds at 95 %: standard deviation 1.5 %, so >= 90 % is a 3-sigma floor.  The numbers are the
table in docs/fit.md (run with ``-s`` to print it).
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import ROOT
from torlab.fit.film import fit_film_thickness
from torlab.fit.result import FitResult
from torlab.fit.temperature import fit_temperature_coefficients
from torlab.fit.traction import fit_layer_traction, traction_model
from torlab.scene import load_scene

SEEDS = 200
FLOOR = 0.90


def _report(title: str, cover: dict[str, float]) -> None:
    print(f"\n{title}: " + ", ".join(f"{k} {100 * v:.1f} %" for k, v in cover.items()))


def _coverage(fit, truth: dict[str, float], seeds: int = SEEDS) -> dict[str, float]:
    hits = dict.fromkeys(truth, 0)
    for seed in range(seeds):
        res = fit(np.random.default_rng(seed))
        for k, v in truth.items():
            lo, hi = res.ci95[k]
            assert lo > 0 or k not in res.log_scale  # positive parameters: positive bounds
            hits[k] += lo <= v <= hi
    return {k: h / seeds for k, h in hits.items()}


# --- traction -------------------------------------------------------------------------------
TRACTION_TRUTH = {"mu_c1": 0.16, "mu_c2": 0.26, "L_mue": 6e-6, "L_mup": 12e-6}
#: 40 log-spaced creepages, as a traction measurement steps its SRR
XI = np.geomspace(0.0005, 0.08, 40)


def _traction_setup():
    sc = load_scene(ROOT / "protocols" / "scenes" / "optical_paper_a_rough.yaml")
    # dry, and the coarse FASTSIM grid (n = 4, m = 3, error 2e-4) so that 200 fits take
    # seconds: the data come from the same model, so the grid's error does not enter
    sc = sc.model_copy(update={"lubricant": None, "roughness": None,
                               "grid": sc.grid.model_copy(update={"n": 4, "m": 3})})
    return sc, traction_model(sc)(TRACTION_TRUTH, XI)


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["constant", "proportional"])
def test_traction_fit_coverage(noise):
    """Constant: 0.003 absolute (1 % of the plateau); proportional: 2 % of mu, which makes the
    first points ~75 times more precise than the plateau (where ordinary least squares with one
    variance covered mu_c2 and L_mup 86 % of the time, 100 seeds)."""
    sc, mu0 = _traction_setup()

    def fit(rng):
        e = rng.standard_normal(XI.size)
        y = mu0 + 0.003 * e if noise == "constant" else mu0 * (1 + 0.02 * e)
        return fit_layer_traction(sc, XI, y)

    cover = _coverage(fit, TRACTION_TRUTH)
    _report(f"traction, {noise} noise", cover)
    assert min(cover.values()) >= FLOOR, cover


# --- temperature ----------------------------------------------------------------------------
T_C = np.array([25.0, 45.0, 65.0, 85.0, 105.0])
TEMP_TRUTH = {"mu_c1_T": -0.003, "mu_c2_T": -0.004, "mu_c1_Tref": 0.30, "mu_c2_Tref": 0.45}


@pytest.mark.slow
@pytest.mark.parametrize("noise", ["constant", "proportional"])
def test_temperature_fit_coverage(noise):
    """Five temperatures, the run-to-run scatter either of constant size (0.008 and 0.012 in
    mu_c1, mu_c2, independent) or proportional (3 %, the same factor for both limits of a run,
    as the sample generator draws it).  Every coefficient kept (``selection="none"``: the
    coverage of the full model's intervals)."""
    m1 = 0.30 * np.exp(-0.003 * (T_C - 25.0))
    m2 = 0.45 * np.exp(-0.004 * (T_C - 25.0))

    def fit(rng):
        if noise == "constant":
            e = rng.standard_normal((2, T_C.size))
            a, b = m1 + 0.008 * e[0], m2 + 0.012 * e[1]
        else:
            e = rng.standard_normal(T_C.size)
            a, b = m1 * (1 + 0.03 * e), m2 * (1 + 0.03 * e)
        fits = [FitResult("layer_hpt", ("mu_c1", "mu_c2"), {"mu_c1": x, "mu_c2": y}, {}, {},
                          np.eye(2), 0.0, 1, [], None) for x, y in zip(a, b, strict=True)]
        return fit_temperature_coefficients(fits, temperatures_K=T_C + 273.15,
                                            selection="none")

    cover = _coverage(fit, TEMP_TRUTH)
    _report(f"temperature, {noise} noise", cover)
    assert min(cover.values()) >= FLOOR, cover


# --- film -----------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("noise", ["constant", "proportional"])
def test_film_fit_coverage(noise):
    """Hamrock-Dowson films (alpha = 18 1/GPa) at 20 speeds 0.05-3 m/s (45-700 nm) with 10 nm
    of constant scatter (22 % of the thinnest film) or 5 % proportional scatter; the truth of
    the exponent and the prefactor is the exact power law through them."""
    from torlab.model.contact import build_contact
    from torlab.model.ehl import hc_piezo

    sc = load_scene(ROOT / "protocols" / "scenes" / "mtm_paper_b.yaml")
    c = build_contact(sc)
    v = np.geomspace(0.05, 3.0, 20)
    h0 = hc_piezo(v, sc.contact.load, c.E_star, c.rx, sc.lubricant.eta0, 18e-9,
                  c.patch.b / c.patch.a)
    slope, ln_c = np.polyfit(np.log(v), np.log(h0), 1)
    truth = {"speed_exponent": slope, "film_prefactor": float(np.exp(ln_c)), "alpha": 18e-9}

    def fit(rng):
        e = rng.standard_normal(v.size)
        h = h0 + 10e-9 * e if noise == "constant" else h0 * (1 + 0.05 * e)
        return fit_film_thickness(v, h, scene=sc)

    cover = _coverage(fit, truth)
    _report(f"film, {noise} noise", cover)
    assert min(cover.values()) >= FLOOR, cover
