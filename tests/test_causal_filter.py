"""The causal comparison band of ``experiments/causal_filter.py`` against the shipped
zero-phase band: same magnitude target, but no sample depends on a later one."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import causal_filter as cf  # noqa: E402

from stictionbench.diagnosis.openloop import highpass  # noqa: E402


def test_the_causal_band_never_looks_ahead_and_the_shipped_band_does():
    rng = np.random.default_rng(5)
    x = rng.normal(size=1500)
    y = x.copy()
    y[1000:] += rng.normal(size=500)  # change only the future of sample 999
    kw = dict(Ts=1.0, f_c=0.002, f_lp=0.05)
    np.testing.assert_array_equal(cf.causal_band(x, **kw)[:1000], cf.causal_band(y, **kw)[:1000])
    assert np.max(np.abs(highpass(x, **kw)[:1000] - highpass(y, **kw)[:1000])) > 1e-3


def test_the_causal_band_is_linear_column_by_column_and_removes_a_constant():
    rng = np.random.default_rng(6)
    X = rng.normal(size=(800, 3))
    out = cf.causal_band(X, 1.0, 0.01, 0.1)
    np.testing.assert_allclose(out[:, 1], cf.causal_band(X[:, 1], 1.0, 0.01, 0.1))
    np.testing.assert_allclose(cf.causal_band(np.full(800, 7.0), 1.0, 0.01), 0.0)


def test_band_sos_is_the_butterworth_whose_magnitude_highpass_applies():
    from scipy.signal import sosfreqz

    from stictionbench.diagnosis.openloop import _hp_gain, band_sos

    m, Ts, f_c, f_lp = 4096, 1.0, 0.004, 0.05
    f = np.fft.rfftfreq(m, Ts)
    _, h = sosfreqz(band_sos(Ts, f_c, f_lp), worN=f, fs=1.0 / Ts)
    low = f < 0.1  # the bilinear transform's warping grows towards Nyquist
    np.testing.assert_allclose(np.abs(h[low]) ** 2, _hp_gain(m, Ts, f_c, f_lp)[low],
                               atol=0.02)
