"""``experiments/slip_jump_bootstrap_sets.py`` counts each way (defaults, bootstrap) apart,
pairs the two verdicts of each recording, and reports the times it measured."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import slip_jump_bootstrap_sets as sbs  # noqa: E402


def _frame() -> pd.DataFrame:
    rows = []
    for name, cls, default, boot, p_d, p_b in (
            ("a", "deadband", "stiction", "deadband", 1e-4, 0.4),
            ("b", "deadband", "deadband", "deadband", 0.3, 0.9),
            ("c", "stiction", "stiction", "deadband", 1e-9, 0.1),
            ("d", "stiction", "stiction", "stiction", 1e-9, 0.05)):
        rows.append({"generator": "A", "set": "a", "name": name, "class": cls,
                     "default": default, "bootstrap": boot, "slip_jump_p_default": p_d,
                     "slip_jump_p_bootstrap": p_b, "seconds_default": 1.0,
                     "seconds_bootstrap": 9.0})
    return pd.DataFrame(rows)


def test_summary_counts_each_way_and_pairs_the_verdicts():
    s = sbs.summary(_frame()).set_index("valve (truth)")
    assert s.loc["deadband", "stiction, default"].startswith("1/2")
    assert s.loc["deadband", "stiction, bootstrap"].startswith("0/2")
    assert s.loc["deadband", "right only with / only without the bootstrap"].startswith("1 / 0")
    assert s.loc["stiction", "right only with / only without the bootstrap"].startswith("0 / 1")
    # the bootstrap's Monte Carlo p rejects at alpha when it is <= alpha
    assert s.loc["stiction", "p ≤ 0.05, bootstrap"].startswith("1/2")


def test_report_states_the_totals_and_times():
    text = sbs.report(_frame())
    assert "named right together: 3 → 3 of 4" in text
    assert "median 1.00 s" in text and "median 9.00 s" in text
