"""experiments/healthy_false_alarms_d.py: its variants and its summary."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import healthy_false_alarms_d as hd  # noqa: E402


def _scenario() -> dict:
    return {"_noise": np.ones(5), "_din": np.full(5, 2.0), "_dout": np.full(5, 3.0),
            "quant_step": 0.5, "hist_op_mode": "mean"}


def test_each_variant_removes_only_its_source_and_leaves_the_scenario_alone():
    sc = _scenario()
    nn, nl, both, snap = (hd._vary(sc, v) for v in ("no noise", "no load", "neither",
                                                    "snapshot OP"))
    assert not nn["_noise"].any() and nn["quant_step"] == 0.0 and nn["_din"].all()
    assert not nl["_din"].any() and not nl["_dout"].any() and nl["_noise"].all()
    assert not both["_noise"].any() and not both["_din"].any() and not both["_dout"].any()
    assert snap["hist_op_mode"] == "snapshot" and snap["_noise"].all()
    # the drawn scenario itself is untouched (every variant starts from it)
    assert sc["_noise"].all() and sc["_din"].all() and sc["hist_op_mode"] == "mean"
    assert hd._vary(sc, "recorded") == sc


def _frame(called: dict[str, set[int]], n: int = 48) -> pd.DataFrame:
    rows = []
    for variant in hd.VARIANTS:
        for i in range(n):
            rows.append({"name": f"r{i}", "variant": variant, "identical_to_stored": True,
                         "predicted": "deadband" if i in called.get(variant, set())
                         else "none", "controller_period": 0.25 if i % 4 else 1.0,
                         "nominal_nrmse": 0.01, "improved_nrmse": 0.005,
                         "hist_op_mode": "snapshot", "kc_K": 2.0, "tau": 10.0})
    return pd.DataFrame(rows)


def test_summary_counts_and_checks_the_prediction():
    rec = set(range(1, 17))                              # 16 called, as stored
    df = _frame({"recorded": rec, "no load": set(range(1, 9)), "no noise": rec,
                 "neither": {1, 2, 3}, "snapshot OP": rec})
    tab, checks = hd.summary(df)
    assert list(tab["variant"]) == list(hd.VARIANTS)
    assert tab.loc[tab["variant"] == "no load", "newly called / no longer called"].item() \
        .startswith("0 / 8")
    assert all("**held**" in c for c in checks)
    # one more loop called without the load, and a neither-loop with the PI at 1 s (r4)
    bad = _frame({"recorded": rec, "no load": set(range(1, 10)), "no noise": rec,
                  "neither": {1, 4}, "snapshot OP": rec})
    _, checks = hd.summary(bad)
    assert [("**failed**" in c) for c in checks] == [False, True, False, True, False]
