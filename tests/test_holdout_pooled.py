"""The pooled holdout report's tables (``experiments/holdout_pooled.py``) and the null loop
of ``experiments/bootstrap_null.py`` on hand-made inputs."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import bootstrap_null as bn  # noqa: E402
import holdout_pooled as hp  # noqa: E402

from stictionbench.diagnosis.model import NominalModel  # noqa: E402
from stictionbench.diagnosis.openloop import fopdt_response  # noqa: E402

BLIND = hp.BLIND[0]


def _frame() -> pd.DataFrame:
    rows = []
    for block in (1000, BLIND):
        for lvl in (1, 2):
            for i in range(8):
                cls = "none" if i < 2 else "stiction"
                # level 1: every verdict right; level 2: one physics miss and, in the
                # blind block, one none called physics
                pred = cls
                if lvl == 2 and i == 7:
                    pred = "none"
                if lvl == 2 and i == 0 and block == BLIND:
                    pred = "deadband"
                rows.append({"name": f"{block}_{lvl}_{i}", "class": cls, "level": lvl,
                             "seed": block + i, "predicted_default": pred,
                             "band_dof": 20.0 if i % 2 else 150.0, "block": block,
                             "effect": 0.0 if cls == "none" else 0.12 * i,
                             "noise_frac": (0.02 if i < 4 else 0.03) if lvl == 1
                             else (0.04 if i < 4 else 0.09)})
    return pd.DataFrame(rows)


def test_level_rows_count_named_and_false_alarms():
    rows = {r["level"]: r for r in hp.level_rows(_frame())}
    assert rows[1]["named correctly"].startswith("16/16")
    key = "of 16, classes weighted equally (95 % interval)"
    assert rows[1][key].startswith("16.0")
    assert rows[2]["named correctly"].startswith("13/16")
    # level 2: none 3/4, stiction 10/12 → 16 × (0.75 + 0.833)/2 = 12.7 with the classes
    # weighted equally, where the pooled rate 13/16 weighs `none` 4/16
    assert rows[2][key].startswith("12.7")
    assert rows[2]["pooled rate × 16 (`none` weighed 2/9)"] == 13.0
    assert rows[2]["`none` called physics"].startswith("1/4")


def test_blocks_and_dof_bins_split_the_same_verdicts():
    df = _frame()
    blocks = hp.by_block(df).set_index("block")
    # none 2/2 and stiction 5/6, weighted equally: 16 × (1 + 5/6)/2
    assert blocks.loc[1000, "level 2 of 16"] == 14.7
    assert blocks.loc[BLIND, "level 2 none called physics"] == "1/2"
    assert blocks.loc[BLIND, "status"] == "blind"
    dof = hp.by_dof(df)
    # every recording lands in exactly one bin
    assert int(dof._n.sum() + dof._nn.sum()) == len(df)
    slow = dof[(dof.level == 2) & (dof.band_dof.str.startswith("0"))].iloc[0]
    # odd i at 20 dof: i = 3, 5 named and i = 7 missed in each block; i = 1 is `none`
    assert (slow._k, slow._n, slow._nn) == (4, 6, 2)


def test_seen_and_blind_false_alarms_are_compared_per_level():
    lines = hp.seen_against_blind(_frame())
    assert len(lines) == 2
    assert "seen blocks 0/2" in lines[0] and "blind blocks 0/2" in lines[0]
    # level 2: the blind block's one `none` called physics, none in the seen block
    assert "seen blocks 0/2" in lines[1] and "blind blocks 1/2" in lines[1]
    assert "Fisher p = 1" in lines[1]


def test_noise_bins_score_each_level_in_its_own_bins():
    t = hp.by_noise(_frame()).set_index(["level", "PV noise, % of the set-point step"])
    # every recording lands in one bin of its level's edges
    assert int(t.recordings.sum()) == len(_frame())
    assert set(t.index) == {(1, "1–2.5"), (1, "2.5–4"), (2, "3–5"), (2, "7.5–10")}
    # level 2, low noise (i < 4): none 3/4 (the blind block's false alarm), stiction 4/4
    low = t.loc[(2, "3–5")]
    assert low["`none` called physics"].startswith("1/4")
    assert low["of 16, classes weighted equally"].startswith("14.0")
    # level 2, high noise (i ≥ 4): stiction 6/8 (i = 7 missed in both blocks), no none
    high = t.loc[(2, "7.5–10")]
    assert high["of 16, classes weighted equally"].startswith("12.0")
    assert high["`none` called physics"].startswith("0/0")


def test_the_detectability_table_leaves_none_out_and_bins_by_effect():
    eff = hp.by_effect(_frame())
    assert int(eff._n.sum()) == 24  # 6 physics recordings per level and block
    # level 2: the one miss per block (i = 7, effect 0.84) sits in the top bin
    top = eff[(eff.level == 2) & (eff.effect == "0.8–1.0")].iloc[0]
    assert (top._k, top._n) == (0, 2)


def test_the_null_loop_without_disturbance_settles_on_the_set_point():
    m = NominalModel(2.0, 10.0, 3.0, 0.3, 10.0, 1.0, "given")
    n = 600
    sp = np.where(np.arange(n) < 50, 1.0, 3.0)
    y, u = bn.closed_loop(m, sp, np.zeros(n), 50.0, 1.0, 1.0)
    assert abs(y[-1] - 3.0) < 1e-3
    # PV is the model's response to the simulated OP: the loop and the FOPDT agree
    np.testing.assert_allclose(y, 1.0 + 2.0 * fopdt_response(u, 1.0, 10.0, 3.0), atol=1e-9)


def test_the_sieve_disturbance_keeps_its_scale_and_start():
    rng = np.random.default_rng(0)
    r = np.cumsum(rng.normal(size=2000)) * 0.1 + rng.normal(size=2000)
    v = bn.null_disturbance(r, 2000, np.random.default_rng(1))
    assert v[0] == r[0]
    assert 0.2 < np.std(np.diff(v)) / np.std(np.diff(r)) < 5.0


def test_matched_table_counts_recordings_and_nulls_per_condition_and_speed():
    mt = pd.DataFrame({"condition": ["no load"] * 4 + ["as drawn"] * 2,
                       "tau": [120.0] * 4 + [30.0] * 2,
                       "level": [1, 1, 2, 2, 1, 2], "seed": [0, 1, 0, 1, 0, 0],
                       "band_dof": [9.0, 11.0, 10.0, 12.0, 60.0, 70.0],
                       "recording": ["stiction", "none", "none", "none", "none", "none"],
                       "null": ["deadband", "stiction", "none", "none", "none", "none"]})
    tab = bn.matched_table(mt).set_index(["condition", "tau_s"])
    row = tab.loc[("no load", 120.0)]
    assert row["recordings called physics"].startswith("1/4")
    assert row["their nulls called physics"].startswith("2/4")
    assert row["median band_dof"] == 10.5
    assert tab.loc[("as drawn", 30.0), "their nulls called physics"].startswith("0/2")


def test_bootstrap_report_counts_nulls_held_at_a_limit_apart() -> None:
    """Nulls whose OP the drift holds at a limit are saturated loops: the report counts
    them apart and says when no null is left to test the gate with."""
    rows = []
    for kind, cls in (("false alarm", "none"), ("true positive", "stiction")):
        for seed in range(2):
            rows.append({"kind": kind, "class": cls, "level": 1, "seed": seed,
                         "band_dof": 30.0, "predicted_default": "stiction",
                         "pick": "stiction", "improvement": 0.3,
                         "d0_null_max": 0.1, "d0_p_boot": 0.05, "d0_null_named": 0.1,
                         "d0_null_held": 0.0, "d0_null_named_free": 0.1,
                         "d1_null_max": 0.2, "d1_p_boot": 0.05, "d1_null_named": 1.0,
                         "d1_null_held": 1.0, "d1_null_named_free": 0.0})
    text = bn.report(pd.DataFrame(rows), 10, None)
    assert "20/20 = 100 %" in text  # d1: every null held at a limit
    assert "tests nothing about the gate" in text
    assert "2/20 = 10 %" in text  # d0: named, none held
