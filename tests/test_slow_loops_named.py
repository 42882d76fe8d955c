"""``holdout_family.at_speed`` moves one drawn loop to another speed and record length and
keeps everything else; ``experiments/slow_loops_named.py`` pairs its verdicts and reads
only what they show; ``holdout_pooled.by_tau`` bins the blind blocks by τ."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import holdout_family as hf  # noqa: E402
import holdout_pooled as hp  # noqa: E402
import slow_loops_named as sln  # noqa: E402


@pytest.mark.parametrize("cls", ["dead_time", "sensor_lag", "oscillatory_disturbance",
                                 "deadband"])
def test_at_speed_keeps_the_loop_and_scales_speed_bound_effects(cls):
    drawn = hf.draw(cls, 2, 46001)
    c, sig = hf.at_speed(cls, 2, 46001, drawn.tau * 4.0)
    assert c.tau == pytest.approx(4.0 * drawn.tau)
    assert c.theta / c.tau == pytest.approx(max(1.0, 4 * drawn.theta) / (4 * drawn.tau))
    assert (c.noise_frac, c.load, c.effect) == (drawn.noise_frac, drawn.load, drawn.effect)
    assert sig["t"].size == int(hf.DURATION) + 1
    if cls == "sensor_lag":
        assert c.truth["time_constant"] == pytest.approx(4 * drawn.truth["time_constant"])
    if cls == "oscillatory_disturbance":
        assert c.truth["period"] / c.lam_cl == pytest.approx(drawn.truth["period"]
                                                             / drawn.lam_cl)
    if cls == "dead_time":
        extra = drawn.truth["dead_time"] - drawn.theta - 1.0
        assert c.truth["dead_time"] - c.theta - 1.0 == pytest.approx(
            extra * c.theta / drawn.theta)
    if cls == "deadband":
        assert c.truth == drawn.truth


def test_a_longer_record_continues_the_same_loop():
    a, sa = hf.at_speed("stiction", 2, 46002, 60.0)
    b, sb = hf.at_speed("stiction", 2, 46002, 60.0, duration=3 * hf.DURATION)
    assert hf.DURATION == 3000.0  # restored
    assert (a.noise, a.load, a.effect, a.truth) == (b.noise, b.load, b.effect, b.truth)
    assert b.steps[:len(a.steps)] == a.steps and len(b.steps) > len(a.steps)
    assert b.steps[-1][0] < 3 * hf.DURATION - 150 <= b.steps[-1][0] + 600
    assert sb["t"].size == 3 * int(hf.DURATION) + 1
    # the set point is the same where both records run
    assert np.array_equal(sa["SP"], sb["SP"][:sa["SP"].size])


def test_setpoint_steps_follow_the_rule():
    steps = hf.setpoint_steps(np.random.default_rng(1), 2.0, 30.0, 3000.0)
    t = np.array([s[0] for s in steps])
    assert t[0] == 30.0 and t[-1] < 3000.0
    assert np.all((np.diff(t) >= 199.9) & (np.diff(t) <= 600.1))
    assert all(4.0 <= abs(s[1]) <= 16.0 for s in steps)


def _frame(long_helps: bool) -> pd.DataFrame:
    rows = []
    for rec in sln.RECORDS.values():
        for tau in sln.TAUS:
            for cls in sln.PHYSICS:
                for seed in range(3):
                    ok = tau < sln.SLOW or (long_helps and rec == "9000 s")
                    rows.append({"record": rec, "tau": tau, "class": cls, "seed": seed,
                                 "pick": cls if ok else "none", "band_dof": 100.0})
    return pd.DataFrame(rows)


def test_paired_counts_and_reading():
    gained, lost, n, p = sln.paired(_frame(True))
    assert (gained, lost, n) == (3 * 3 * len(sln.PHYSICS), 0, 3 * 3 * len(sln.PHYSICS))
    assert p < 1e-6
    text = sln.reading(_frame(True))
    assert "falls with the loop's speed alone" in text
    assert "account for the misses" in text
    text = sln.reading(_frame(False))
    assert "does not show the record's length" in text
    t = sln.table(_frame(True))
    assert t[(t.record == "3000 s") & (t["τ (s)"] == 120.0)]["all classes"].iloc[0] \
        .startswith("0/21")


def test_bad_arguments_exit_2(capsys):
    assert sln.main(["--seeds", "0"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_pooled_tau_bins():
    df = pd.DataFrame({"class": ["stiction", "none", "stiction", "none"],
                       "level": [2, 2, 2, 2], "tau": [5.0, 8.0, 90.0, 100.0],
                       "predicted_default": ["stiction", "none", "none", "deadband"]})
    t = hp.by_tau(df).set_index(["level", "process time constant τ (s)"])
    assert t.loc[(2, "3–10"), "of 16, classes weighted equally"].startswith("16.0")
    assert t.loc[(2, "60–120"), "of 16, classes weighted equally"].startswith("0.0")
    assert t.loc[(2, "60–120"), "`none` called physics"].startswith("1/1")
    assert t.loc[(2, "60–120"), "record length / τ"] == "30–33"
