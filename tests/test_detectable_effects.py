"""``experiments/detectable_effects.py``: each generator's truth read as the effect its
minimum is compared with, and the tables' counting."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import detectable_effects as de  # noqa: E402


def test_true_effect_reads_each_generator_s_columns():
    a = pd.DataFrame({"class": ["dead_time", "dead_time", "sensor_lag", "deadband", "stiction"],
                      "true_dead_time": [13.0, 4.0, 5.0, 5.0, 5.0],
                      "nominal_dead_time": [10.0, 9.3, 5.0, 5.0, 5.0],
                      "lag": [np.nan, np.nan, 11.9, np.nan, np.nan],
                      "deadband": [np.nan, np.nan, np.nan, 1.02, np.nan],
                      "S": [np.nan, np.nan, np.nan, np.nan, 3.3]})
    t = de.true_effect(a, "A")
    assert np.allclose(t.effect, [3.0, 5.3, 11.9, 1.02, 3.3])
    assert t.key.tolist() == ["dead_time_longer", "dead_time_shorter", "sensor_lag",
                              "deadband", "stiction_S"]
    c = pd.DataFrame({"class": ["dead_time", "sensor_lag", "stiction"],
                      "true_dead_time": [2.0, 5.0, 10.6], "model_dead_time": [1.0, 5.0, 11.8],
                      "sensor_lag_tc": [np.nan, 1.9, np.nan], "deadband": [np.nan] * 3,
                      "stiction_S": [np.nan, np.nan, 2.7]})
    t = de.true_effect(c, "C")
    assert np.allclose(t.effect, [1.0, 1.9, 2.7])
    assert t.key.tolist() == ["dead_time_longer", "sensor_lag", "stiction_S"]


def test_tables_count_above_and_below_the_minimum():
    ratio = np.array([0.2, 0.7, 1.5, 3.0, 5.0, 1.2])
    df = pd.DataFrame({"generator": ["A"] * 6, "level": [2] * 6, "class": ["sensor_lag"] * 6,
                       "ratio": ratio, "bin": pd.cut(ratio, de.EDGES, right=False,
                                                     labels=de.LABELS),
                       "true_significant": [False, False, True, True, True, False],
                       "named": [False, False, True, True, True, False],
                       "limited_by": ["gate"] * 6})
    lv = de.level_table(df).iloc[0]
    assert lv["below the record's minimum"].startswith("2/6")
    assert lv["named, above"].startswith("3/4")
    cal = de.calibration(df).set_index("effect / minimum")
    assert cal.loc["1–2", "recordings"] == 2
    assert cal.loc["1–2", "true hypothesis passes its gates"].startswith("1/2")
    cls = de.by_class(df).iloc[0]
    assert cls["below: named"].startswith("0/2")
