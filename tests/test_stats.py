"""torlab._stats against scipy.stats (bit for bit) and scipy.signal (to round-off), without
importing them."""

import subprocess
import sys

import numpy as np
import pytest
from scipy import signal, stats

from torlab._stats import ar1_recursion, chi2_sf, f_sf, norm_cdf, norm_ppf, t_cdf, t_ppf

Q = np.array([1e-12, 1e-6, 0.001, 0.025, 0.05, 0.3, 0.5, 0.7, 0.95, 0.975, 0.999, 1 - 1e-9])
DF = np.array([1.0, 1.5, 2.0, 3.0, 7.0, 30.0, 1e3, 1e6, np.inf])
X = np.array([-40.0, -5.0, -1.96, -0.1, 0.0, 0.3, 2.0, 8.0, 60.0])


def _same(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    assert np.array_equal(a, b, equal_nan=True), np.max(np.abs(a - b))


@pytest.mark.parametrize("df", DF)
def test_student_t(df):
    _same(t_ppf(Q, df), stats.t.ppf(Q, df))
    _same(t_cdf(X, df), stats.t.cdf(X, df))
    assert float(t_ppf(0.975, df)) == float(stats.t.ppf(0.975, df))


def test_student_t_broadcasts_like_scipy():
    q, nu = 0.975, np.array([1.0, 4.0, 12.0])
    _same(t_ppf(q, nu), stats.t.ppf(q, nu))


def test_normal_and_f():
    _same(norm_ppf(Q), stats.norm.ppf(Q))
    _same(norm_cdf(X), stats.norm.cdf(X))
    for d1, d2 in ((1, 1), (1, 5), (2, 30), (3, 1e4)):
        x = np.array([0.0, 0.01, 0.5, 1.0, 4.0, 50.0])
        _same(f_sf(x, d1, d2), stats.f.sf(x, d1, d2))
    for k in (1, 2, 5, 30):
        x = np.array([0.0, 0.01, 0.5, 1.0, 4.0, 50.0])
        _same(chi2_sf(x, k), stats.chi2.sf(x, k))


@pytest.mark.parametrize("rho", [0.0, 0.3, 0.9, 0.999, -0.5])
def test_ar1_recursion_is_lfilter(rho):
    rng = np.random.default_rng(3)

    def close(a, b):  # a banded solve, not lfilter's loop: equal to round-off
        scale = np.max(np.abs(b)) or 1.0
        assert a.shape == b.shape
        assert np.max(np.abs(a - b)) <= 1e-13 * scale

    x = rng.standard_normal((500, 4))
    close(ar1_recursion(x, rho), signal.lfilter([1.0], [1.0, -rho], x, axis=0))
    v = rng.standard_normal(300)
    close(ar1_recursion(v, rho), signal.lfilter([1.0], [1.0, -rho], v))
    close(ar1_recursion(v[::-1], rho)[::-1], signal.lfilter([1.0], [1.0, -rho], v[::-1])[::-1])
    assert ar1_recursion(np.empty((0, 3)), rho).shape == (0, 3)


def test_a_fit_loads_neither_scipy_stats_nor_signal():
    code = ("import sys\n"
            "from torlab.fit.layer import fit_layer_hpt\n"
            "from torlab.parsers.hpt import read_hpt\n"
            "from torlab.reduce.hpt import reduce_hpt\n"
            "r = fit_layer_hpt([reduce_hpt(*read_hpt('sample_data/hpt/hpt_OFM1_4uL_25C.txt'))])\n"
            "print(sorted(m for m in ('scipy.stats', 'scipy.signal') if m in sys.modules))\n")
    root = __file__.rsplit("/tests/", 1)[0]
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                       cwd=root)
    assert r.stdout.strip() == "[]"
