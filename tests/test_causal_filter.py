"""The diagnosis's causal comparison band (``openloop.comparison_band``) against the
zero-phase band it replaced (``openloop.highpass``): same magnitude target, but no sample
depends on a later one; and how ``experiments/causal_filter.py`` sets and pairs the two."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import causal_filter as cf  # noqa: E402

from stictionbench.diagnosis.openloop import comparison_band, highpass  # noqa: E402


def test_the_causal_band_never_looks_ahead_and_the_zero_phase_band_does():
    rng = np.random.default_rng(5)
    x = rng.normal(size=1500)
    y = x.copy()
    y[1000:] += rng.normal(size=500)  # change only the future of sample 999
    kw = dict(Ts=1.0, f_c=0.002, f_lp=0.05)
    np.testing.assert_array_equal(comparison_band(x, **kw)[:1000], comparison_band(y, **kw)[:1000])
    assert np.max(np.abs(highpass(x, **kw)[:1000] - highpass(y, **kw)[:1000])) > 1e-3


def test_the_causal_band_is_linear_column_by_column_and_removes_a_constant():
    rng = np.random.default_rng(6)
    X = rng.normal(size=(800, 3))
    out = comparison_band(X, 1.0, 0.01, 0.1)
    np.testing.assert_allclose(out[:, 1], comparison_band(X[:, 1], 1.0, 0.01, 0.1))
    np.testing.assert_allclose(comparison_band(np.full(800, 7.0), 1.0, 0.01), 0.0)


def test_band_sos_is_the_butterworth_whose_magnitude_highpass_applies():
    from scipy.signal import sosfreqz

    from stictionbench.diagnosis.openloop import _hp_gain, band_sos

    m, Ts, f_c, f_lp = 4096, 1.0, 0.004, 0.05
    f = np.fft.rfftfreq(m, Ts)
    _, h = sosfreqz(band_sos(Ts, f_c, f_lp), worN=f, fs=1.0 / Ts)
    low = f < 0.1  # the bilinear transform's warping grows towards Nyquist
    np.testing.assert_allclose(np.abs(h[low]) ** 2, _hp_gain(m, Ts, f_c, f_lp)[low],
                               atol=0.02)


def test_use_band_swaps_the_band_every_comparison_stage_takes_and_back():
    from stictionbench.diagnosis import openloop

    try:
        cf.use_band("zero_phase")
        assert openloop.band_of(True) is highpass
    finally:
        cf.use_band("causal")
    assert openloop.band_of(True) is comparison_band
    assert openloop.band_of(False) is highpass


def test_side_by_side_pairs_each_recording_with_its_two_verdicts():
    rows = []
    for band, pick in (("zero_phase", "stiction"), ("causal", "none")):
        rows.append({"set": "holdout", "class": "none", "level": 2, "seed": 7,
                     "band_dof": 30.0, "band": band, "pick": pick})
        rows.append({"set": "slow_loops", "condition": "no load", "tau": 60.0,
                     "class": "none", "level": 1, "seed": 7, "band_dof": 20.0,
                     "band": band, "pick": "none"})
    df = cf.side_by_side(rows)
    assert len(df) == 2
    h = df[df.set == "holdout"].iloc[0]
    assert (h.shipped, h.causal, h.band_dof) == ("stiction", "none", 30.0)
    s = df[df.set == "slow_loops"].iloc[0]
    assert (s.condition, s.tau, s.shipped, s.causal) == ("no load", 60.0, "none", "none")


def test_a_corner_above_nyquist_is_held_below_it():
    # a loop fast against its sampling: f_hp = 0.3 / (2π·1 s) at Ts = 10 s is above 0.05 Hz
    x = np.random.default_rng(7).normal(size=500)
    y = comparison_band(x, 10.0, 0.3 / (2 * np.pi), 0.2)
    assert np.all(np.isfinite(y)) and 0 < np.std(y) < np.std(x)


def test_the_causal_band_is_used_against_a_given_model_only():
    from stictionbench.diagnosis.openloop import band_of

    assert band_of(True) is comparison_band
    assert band_of(False) is highpass


def test_side_by_side_re_decides_the_causal_evidence_at_other_thresholds():
    from concealed import picks

    ev = pd.read_csv(Path(__file__).resolve().parents[1] / "reports" / "concealed"
                     / "results.csv").head(6)
    rows = []
    for i, r in ev.iterrows():
        for band in ("zero_phase", "causal"):
            rows.append({"set": "holdout", "class": r["class"], "level": int(r["level"]),
                         "seed": i, "band_dof": 50.0, "band": band,
                         "pick": r["predicted_default"], "_row": r})
    df = cf.side_by_side(rows, (0.1, 0.1)).sort_values("seed")
    assert list(df.retuned) == list(picks(ev, 0.1, 0.1))
    assert df.shipped.notna().all() and df.causal.notna().all()
