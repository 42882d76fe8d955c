"""``experiments/slip_jump_calibration.py``: the rejection rates it tabulates."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import slip_jump_calibration as sjc  # noqa: E402


def test_rates_count_rejections_and_cross_verdicts_per_family_level_and_valve():
    df = pd.DataFrame({
        "family": ["f"] * 5, "class": ["deadband"] * 4 + ["stiction"], "level": [2] * 5,
        "seed": range(5), "slip_jump_p": [0.001, 0.02, 0.3, 1.0, 1e-6],
        "predicted_default": ["stiction", "deadband", "none", "deadband", "deadband"]})
    tab = sjc.table(df).set_index("valve (truth)")
    db = tab.loc["deadband"]
    assert db["recordings"] == 4
    assert db["p < 0.05"].startswith("2/4") and db["p < 0.01"].startswith("1/4")
    assert db["p < 0.001"].startswith("0/4")
    assert db["named a sticky valve"].startswith("3/4")
    assert db["of those, named stiction"].startswith("1/3")
    assert tab.loc["stiction", "of those, named deadband"].startswith("1/1")
