"""``experiments/linear_input_gate.py``: the class-balanced score it reports, its summary's
paired counts, and one holdout recording diagnosed under both settings."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import linear_input_gate as lig  # noqa: E402


def _frame() -> pd.DataFrame:
    rows = [("none", "none", "deadband"), ("none", "stiction", "none"),
            ("none", "none", "none"),
            ("stiction", "stiction", "stiction"), ("stiction", "stiction", "none")]
    return pd.DataFrame([{"part": "p", "level": 1, "class": c, "default": d, "gate": g}
                         for c, d, g in rows])


def test_score_weighs_classes_equally():
    row = lig.summary(_frame()).iloc[0]
    # default: none 2/3, stiction 2/2 -> 16 x 5/6 = 13.3 (pooled 4/5 would give 12.8);
    # gate: none 2/3, stiction 1/2 -> 16 x 7/12 = 9.3
    assert row["named right of 16, default"].startswith("13.3 [")
    assert row["named right, gate"].startswith("9.3 [")


def test_summary_counts_the_changed_recordings():
    row = lig.summary(_frame()).iloc[0]
    assert row["right only with the gate / only default"].startswith("1 / 2")
    assert row["healthy loops called physics, default"].startswith("1/3")
    assert row["healthy called physics, gate"].startswith("1/3")


def test_one_holdout_recording_under_both_settings():
    r = lig.one_holdout("stiction", 1, lig.HOLDOUT_FIRST)
    assert r["class"] == "stiction" and r["level"] == 1
    assert {r["default"], r["gate"]} <= {"none", "stiction", "deadband", "sensor_lag",
                                         "dead_time", "valve_characteristic", "saturation",
                                         "oscillatory_disturbance"}
    assert r["seconds_gate"] > 0 and r["seconds_default"] > 0
