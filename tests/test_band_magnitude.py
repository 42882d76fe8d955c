"""``experiments/band_magnitude.py``'s third band: the comparison band's sections run
forwards twice — causal, with the zero-phase band's magnitude ``|H|²`` — and the claim
it was built on: the shipped causal band (forwards once, ``|H|``) passes more slow load."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import band_magnitude as bm  # noqa: E402

from stictionbench.diagnosis.openloop import band_sos, comparison_band, highpass  # noqa: E402


def test_the_matched_band_is_causal_with_the_zero_phase_magnitude():
    from scipy.signal import sosfreqz

    Ts, f_c, f_lp = 1.0, 0.004, 0.05
    sos = band_sos(Ts, f_c, f_lp)
    f = np.linspace(1e-4, 0.1, 400)
    _, h1 = sosfreqz(sos, worN=f, fs=1.0 / Ts)
    _, h2 = sosfreqz(np.vstack([sos, sos]), worN=f, fs=1.0 / Ts)
    np.testing.assert_allclose(np.abs(h2), np.abs(h1) ** 2, rtol=1e-9)
    rng = np.random.default_rng(3)
    x = rng.normal(size=1200)
    y = x.copy()
    y[900:] += 1.0  # only the future of sample 899 changes
    np.testing.assert_array_equal(bm.matched_causal_band(x, Ts, f_c, f_lp)[:900],
                                  bm.matched_causal_band(y, Ts, f_c, f_lp)[:900])


def test_on_a_random_walk_the_shipped_causal_band_passes_more_than_the_other_two():
    rw = np.cumsum(np.random.default_rng(0).normal(size=8192))
    v = {name: float(np.var(band(rw, 1.0, 0.01)[2000:]))
         for name, band in (("zero", highpass), ("causal", comparison_band),
                            ("matched", bm.matched_causal_band))}
    assert abs(v["matched"] / v["zero"] - 1.0) < 0.05
    assert v["causal"] / v["zero"] > 1.2


def test_the_criterion_needs_all_three_items():
    # two holdout `none` recordings, one level-2 physics recording, two regulatory loops
    base = {"family": "", "rate": "", "seed": 0}
    rows = [{**base, "set": "holdout", "class": "none", "level": 1,
             "zero_phase": "none", "causal": "none", "matched": "none"},
            {**base, "set": "holdout", "class": "stiction", "level": 2,
             "zero_phase": "stiction", "causal": "stiction", "matched": "stiction"},
            {**base, "set": "regulatory", "class": "none", "level": 0,
             "zero_phase": "none", "causal": "deadband", "matched": "none"},
            {**base, "set": "regulatory", "class": "stiction", "level": 0,
             "zero_phase": "stiction", "causal": "stiction", "matched": "stiction"}]
    met, items = bm.verdict(pd.DataFrame(rows))
    assert met and all(i.split(". ", 1)[1].startswith("holds") for i in items)
    rows[2]["matched"] = "deadband"  # no fewer regulatory false alarms than causal
    met, items = bm.verdict(pd.DataFrame(rows))
    assert not met and items[0].startswith("1. fails")
