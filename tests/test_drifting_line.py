"""``experiments/drifting_line.py``: its paired counts, the criterion it prints, the
disturbances by their cycles, and one recording diagnosed under both line structures."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import drifting_line as dl  # noqa: E402

OSC = "oscillatory_disturbance"


def _frame(drift_for_healthy: str = "none") -> pd.DataFrame:
    rows = [("none", "none", drift_for_healthy), ("none", "none", "none"),
            (OSC, "deadband", OSC), (OSC, OSC, OSC), ("stiction", "stiction", "deadband")]
    return pd.DataFrame([{"group": "l", "generator": "C", "name": f"r{i}", "level": 1,
                          "class": c, "constant": a, "drifting": b,
                          "period": 100.0 if c == OSC else None, "span": 3000.0}
                         for i, (c, a, b) in enumerate(rows)])


def test_summary_counts_the_pairs_and_the_disturbances():
    s = dl.summary(_frame())
    row = s[s.recordings == "C"].iloc[0]
    assert row["right only drifting / only constant"].startswith("1 / 1")
    assert row["disturbances named, constant"].startswith("1/2")
    assert row["disturbances named, drifting"].startswith("2/2")
    assert row["named right, constant"].startswith("4 (") and \
        row["named right, drifting"].startswith("4 (")
    assert (s.recordings == "pooled").sum() == 1


def test_the_criterion_fails_on_a_new_healthy_false_alarm():
    assert "is **met**" in dl.report(_frame())
    # the same counts of right verdicts, but a healthy loop now called physics
    assert "is **not met**" in dl.report(_frame(drift_for_healthy=OSC))


def test_disturbances_are_binned_by_their_cycles():
    t = dl.by_cycles(_frame())
    assert list(t["cycles in the record"]) == ["[30.0, inf)"] and t.n.iloc[0] == 2


def test_one_holdout_disturbance_under_both_structures():
    row = dl.one_holdout(OSC, 1, dl.HOLDOUT_FIRST)
    assert set(dl.STRUCTURES) <= set(row) and row["period"] > 0
    assert row["constant"] in {OSC, "none", "deadband", "stiction", "dead_time",
                               "sensor_lag", "valve_characteristic", "saturation"}
    # the worker's switch is undone: the shipped structure is in place afterwards
    from stictionbench.diagnosis import hypotheses
    assert hypotheses.line_knots((0.0, 600.0, 1200.0), 100.0) == 3
