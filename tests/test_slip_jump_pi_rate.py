"""``experiments/slip_jump_pi_rate.py`` re-makes a loop with only the PI's period changed:
the set point, the nominal model and the valve's draw stay, OP and PV change; pairs whose
loop was redrawn are dropped; the summary counts each period apart."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import slip_jump_pi_rate as sjr  # noqa: E402


def test_generator_a_remake_changes_only_the_pi_period(tmp_path):
    got = {}
    for period in sjr.PERIODS:
        d = tmp_path / str(period)
        d.mkdir()
        attempts = sjr.remake("A", 1007, "deadband", period, d, "r")
        got[period] = (pd.read_csv(d / "r.csv"), yaml.safe_load((d / "r.model.yaml").read_text()),
                       attempts)
    (fast, m_fast, a_fast), (slow, m_slow, a_slow) = got[0.2], got[1.0]
    assert a_fast == a_slow == 1
    assert m_fast == m_slow                      # the same loop and PI tuning
    assert fast.SP.equals(slow.SP)               # the same set-point schedule
    assert len(fast) == len(slow)
    assert not fast.OP.equals(slow.OP)           # a controller at another rate


def test_paired_drops_redrawn_loops_and_summary_counts_each_period():
    rows = []
    for name, att, fast, slow in (("a", (1, 1), "stiction", "stiction"),
                                  ("b", (1, 1), "deadband", "stiction"),
                                  ("c", (1, 2), "stiction", "deadband")):
        for p, a, named in zip(sjr.PERIODS, att, (fast, slow), strict=True):
            rows.append({"generator": "A", "name": name, "class": "deadband", "period": p,
                         "attempts": a, "predicted": named, "slip_jump_p": 0.01})
    pr = sjr.paired(pd.DataFrame(rows))
    assert sorted(pr.name.unique()) == ["a", "b"]
    s = sjr.summary(pr).iloc[0]
    assert s["loops"] == 2
    assert s["named stiction, PI 0.2 s"].startswith("1/2")
    assert s["named stiction, PI 1 s"].startswith("2/2")
    assert s["stiction only at 1 s / only at 0.2 s"].startswith("1 / 0")
    assert sjr.pooled(pr, "deadband", "stiction")[2] == "1 / 0"
