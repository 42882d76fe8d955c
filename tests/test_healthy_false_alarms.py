"""``experiments/healthy_false_alarms.py`` re-makes the generators' healthy recordings with one
ingredient changed: the unchanged generator reproduces the set's recording, each variant
changes what it names and nothing else, and the OP the process received is the mean of
the controller's executions in each second."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import healthy_false_alarms as hfa  # noqa: E402

SEED, LEVEL = 5103, 2        # a level-2 healthy loop of set B: PI every 0.2 s, white PV noise


def _read(d: Path) -> pd.DataFrame:
    return pd.read_csv(next(d.glob("*.csv")))


def test_second_means_average_each_recorded_second():
    Tc, t_warm = 0.25, 2.0
    ctrl = np.arange(40, dtype=float)            # executions from -2 s, 4 per second
    idx = np.arange(0, 40, 4)[int(t_warm / Tc) // 4:]
    res = {"ctrl_op": ctrl, "op": ctrl[idx], "t_warm": t_warm}
    got = hfa.second_means(res, Tc)
    assert np.allclose(got, ctrl[idx] + 1.5)     # the mean of k, k+1, k+2, k+3
    res["op"] = res["op"] + 0.5                  # the log no longer matches the recording
    with pytest.raises(RuntimeError, match="not aligned"):
        hfa.second_means(res, Tc)


def test_variants_change_only_their_ingredient(tmp_path):
    out = {}
    for v in ("as_recorded", "pi_1s", "op_average", "kick_out_true_noise"):
        d = tmp_path / v
        d.mkdir()
        info = hfa.remake(SEED, LEVEL, v, d, "r")
        out[v] = (_read(d), info)
    base, info = out["as_recorded"]
    assert info["controller_period"] == 0.2
    assert out["pi_1s"][1]["controller_period"] == 1.0
    for v in ("op_average", "kick_out_true_noise"):
        d = out[v][0]
        # the same loop, noise and set point: only OP differs
        assert np.array_equal(d.PV, base.PV) and np.array_equal(d.SP, base.SP)
        assert not np.allclose(d.OP, base.OP)
    # with white PV noise the kick on the snapshot's noise is most of the snapshot's error
    assert out["op_average"][1]["kick_r2"] > 0.5
    assert np.std(np.diff(out["op_average"][0].OP)) < np.std(np.diff(base.OP))


@pytest.mark.skipif(not (hfa.DATA / "set_b" / "truth.csv").exists(),
                    reason="generator A's set B is not generated (make independent)")
def test_as_recorded_reproduces_the_set(tmp_path):
    truth = pd.read_csv(hfa.DATA / "set_b" / "truth.csv")
    name = truth.loc[truth.seed == SEED, "name"].item()
    hfa.remake(SEED, LEVEL, "as_recorded", tmp_path, name)
    assert (tmp_path / f"{name}.csv").read_bytes() == \
        (hfa.DATA / "set_b" / f"{name}.csv").read_bytes()


def test_generator_c_load_parts_compose(tmp_path):
    # a level-2 healthy loop of generator C's set C with a load step (seed 7103): the
    # drift and the step removed together are the load removed, byte for byte; each alone
    # changes PV; order0 changes the diagnosis only, never the recording
    csv = {}
    for v in ("as_recorded", "no_drift", "no_step", "no_drift+no_step", "no_load", "order0"):
        d = tmp_path / v.replace("+", "_")
        d.mkdir()
        hfa.remake_c(7103, 2, v, d)
        csv[v] = next(d.glob("*.csv")).read_bytes()
    assert csv["no_drift+no_step"] == csv["no_load"]
    assert csv["order0"] == csv["as_recorded"]
    assert len({csv[v] for v in ("as_recorded", "no_drift", "no_step", "no_load")}) == 4


def test_generator_a_variants_compose(tmp_path):
    # order0 changes the diagnosis only; a joined variant is its recording's ingredients
    csv = {}
    for v in ("no_load", "no_load+order0", "pi_1s+no_load", "pi_1s"):
        d = tmp_path / v.replace("+", "_")
        d.mkdir()
        info = hfa.remake(SEED, LEVEL, v, d, "r")
        csv[v] = (_read(d), info)
    assert csv["no_load+order0"][0].equals(csv["no_load"][0])
    both = csv["pi_1s+no_load"]
    assert both[1]["controller_period"] == 1.0
    assert not both[0].PV.equals(csv["pi_1s"][0].PV)
    assert not both[0].PV.equals(csv["no_load"][0].PV)


@pytest.mark.skipif(not (hfa.DATA / "set_c" / "truth.csv").exists(),
                    reason="generator C's set C is not generated (make independent)")
def test_generator_c_faulty_class_remade(tmp_path):
    # a faulty recording of set C re-made unchanged is the set's, byte for byte; without
    # the drift its PV differs and its OP too (the loop answers a different load)
    truth = pd.read_csv(hfa.DATA / "set_c" / "truth.csv")
    row = truth[truth["class"] == "stiction"].iloc[0]
    for v in ("as_recorded", "no_drift"):
        d = tmp_path / v
        d.mkdir()
        assert hfa.remake_c(int(row.seed), int(row.level), v, d, "stiction")["name"] \
            == row["name"]
    recorded = (hfa.DATA / "set_c" / f"{row['name']}.csv").read_bytes()
    assert (tmp_path / "as_recorded" / f"{row['name']}.csv").read_bytes() == recorded
    assert (tmp_path / "no_drift" / f"{row['name']}.csv").read_bytes() != recorded
