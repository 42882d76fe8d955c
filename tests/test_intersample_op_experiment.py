"""experiments/intersample_op.py: the criterion its report applies."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import intersample_op as io  # noqa: E402


def _rows(b_healthy_on: str) -> pd.DataFrame:
    rows = []
    for tau in io.TAUS:
        for period in io.PERIODS:
            for seed in range(6):
                fast = period < 1.0
                rows.append({"part": "A", "tau_s": tau, "pi_period_s": period, "seed": seed,
                             "class": "none", "off": "deadband" if fast else "none",
                             "on": "deadband" if fast and seed == 0 else "none",
                             "op": "before" if fast else None})
                rows.append({"part": "A", "tau_s": tau, "pi_period_s": period, "seed": seed,
                             "class": "stiction", "off": "stiction",
                             "on": "deadband" if fast else "stiction",
                             "op": "before" if fast else None})
    for k in range(10):
        rows.append({"part": "B", "generator": "A", "name": f"h{k}", "class": "none",
                     "off": "none", "on": b_healthy_on if k == 0 else "none", "op": "after"})
        rows.append({"part": "B", "generator": "A", "name": f"s{k}", "class": "stiction",
                     "off": "stiction", "on": "stiction", "op": "after"})
    df = pd.DataFrame(rows)
    df["grp"] = "g"
    return df


def test_adopted_only_when_every_part_holds():
    tab, lines = io.summary(_rows("none"))
    assert all("**held**" in line for line in lines[:5])
    assert lines[-1].startswith("**Adopted")
    _, lines = io.summary(_rows("stiction"))  # one more healthy loop called physics
    assert "**failed**" in lines[3] and lines[-1].startswith("**Not adopted")
    assert set(tab.columns) >= {"right without", "right with", "reconstruction kept"}
