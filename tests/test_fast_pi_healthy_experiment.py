"""experiments/fast_pi_healthy.py: its loops, its summary and its verdicts."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import fast_pi_healthy as fp  # noqa: E402


def test_loop_runs_the_pi_at_the_period_asked_and_records_at_one_second():
    slow, fast = fp.loop(8.0, 1.0, 100), fp.loop(8.0, 0.25, 100)
    assert slow.Ts == fast.Ts == 1.0 and len(slow) == len(fast)
    np.testing.assert_array_equal(slow.SP, fast.SP)  # same set-point steps
    assert np.ptp(slow.SP) == 2 * fp.STEP or np.ptp(slow.SP) == fp.STEP


def _frame(called: dict[tuple[float, float], int], n: int = 12) -> pd.DataFrame:
    rows = []
    for tau in fp.TAUS:
        for period in fp.PI_PERIODS:
            k = called.get((tau, period), 0)
            for seed in range(n):
                rows.append({"tau_s": tau, "pi_period_s": period, "seed": seed,
                             "named": "deadband" if seed < k else "none",
                             "nrmse_nominal": 0.2, "op_step_sd": 0.3})
    return pd.DataFrame(rows)


def test_verdicts_follow_the_counts():
    good = _frame({(4.0, 0.25): 5, (8.0, 0.25): 6, (32.0, 0.25): 1, (4.0, 1.0): 1})
    lines = fp.verdicts(good)
    assert all("**held**" in line for line in lines[:3])
    # seed 0 of τ = 4 s is called at both rates: 11 called only at 0.25 s, none only at 1 s
    assert "only at 1 s: 11 / 0" in lines[3]
    bad = _frame({(4.0, 0.25): 5, (8.0, 0.25): 6, (32.0, 0.25): 7, (16.0, 1.0): 3})
    out = fp.verdicts(bad)
    assert "**failed**" in out[0] and "**failed**" in out[2]
    tab = fp.summarise(good)
    assert len(tab) == len(fp.TAUS) * len(fp.PI_PERIODS)
    row = tab[(tab["τ (s)"] == 4.0) & (tab["PI period (s)"] == 0.25)].iloc[0]
    assert row["called physics"].startswith("5/12") and row["named"] == "deadband ×5"


def test_a_record_the_model_replays_exactly_does_not_break_the_diagnosis():
    # no noise, no load, the PI at the historian's rate: the nominal replay is exact, and
    # rounding made an effect's residual energy negative in the detectability scan (a math
    # domain error, found by this experiment's part B)
    from stictionbench.diagnosis import NominalModel, diagnose

    rec = fp.loop(8.0, 1.0, 102, noise=0.0, load=0.0)
    kc, ti = fp.simc(8.0)
    d = diagnose(rec, NominalModel(fp.GAIN, 8.0, fp.DEAD_TIME, kc, ti, 1.0))
    assert d.fit["nominal"] < 1e-9
    assert "minimum_detectable" in d.details
