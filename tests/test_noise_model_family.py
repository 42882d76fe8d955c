"""The AR-against-ARMA report of ``experiments/noise_model_family.py`` on hand-made rows:
its counts and its reading follow the numbers."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import noise_model_family as nmf  # noqa: E402


def _rows(ratio: float, lb_arma: float) -> pd.DataFrame:
    rows = []
    for k in range(10):
        rows.append({"generator": "A" if k < 5 else "C", "set": "a", "name": f"r{k}",
                     "level": 1 + k % 2, "ar_order": 3, "integrated": k % 3 == 0,
                     "arma_order": "(2, 0, 1)", "bic_ar": 100.0,
                     "bic_arma": 80.0 if k < 4 else 105.0, "var_ratio_val": ratio,
                     "lb_p_ar": 0.01 if k < 6 else 0.5, "lb_p_arma": lb_arma,
                     "lrv_ar": 1.5, "lrv_arma": 1.2,
                     "band_dof_train": 1500})
    return pd.DataFrame(rows)


def test_the_report_counts_bic_and_whiteness_and_reads_a_gap_only_where_there_is_one():
    text = nmf.report(_rows(0.9, 0.5))
    assert "lower by more than 10 on 4 of 10 loops" in text
    assert "on 6 of 10 loops with the AR model" in text and "0 with the ARMA" in text
    assert "whitens the validation blocks better" in text
    assert "median 1.50, 90th percentile 1.50 with the AR model; 1.20 and 1.20" in text
    same = nmf.report(_rows(1.0, 0.01))
    assert "adds little" in same
    table = nmf.summary(_rows(0.9, 0.5))
    both = table[table.generator == "both"].iloc[0]
    assert both["loops"] == 10 and both["integrated (AR)"].startswith("4/10")


def test_the_long_run_ratio_sees_serial_correlation():
    import numpy as np
    from scipy.signal import lfilter

    e = np.random.default_rng(1).normal(size=20000)
    assert abs(nmf.long_run_ratio(e) - 1.0) < 0.1
    # an AR(1) of 0.5: its long-run ratio (1 + φ)/(1 − φ) = 3, shrunk by the window
    assert 2.0 < nmf.long_run_ratio(lfilter([1.0], [1.0, -0.5], e)) < 3.1
