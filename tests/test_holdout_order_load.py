"""``experiments/holdout_order_load.py``: a loop recorded at its own speed with its drawn
load is the holdout family's own recording, a scaled load changes the load alone, and the
tables count each order's verdicts and the discordant pairs."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import holdout_family as hf  # noqa: E402
import holdout_order_load as hol  # noqa: E402


def test_the_drawn_load_is_the_familys_recording_and_a_tenth_changes_the_load_alone():
    drawn = hf.draw("deadband", 2, hol.FIRST_SEED)
    _, own = hf.make_recording("deadband", 2, hol.FIRST_SEED)
    c1, same = hf.at_speed("deadband", 2, hol.FIRST_SEED, drawn.tau, load_scale=1.0)
    for k in ("t", "SP", "PV", "OP"):
        np.testing.assert_array_equal(same[k], own[k])
    c, low = hf.at_speed("deadband", 2, hol.FIRST_SEED, drawn.tau, load_scale=0.1)
    assert c.load == 0.1 * c1.load and c.truth == c1.truth
    np.testing.assert_array_equal(low["SP"], own["SP"])
    assert not np.array_equal(low["PV"], own["PV"])


def test_table_counts_each_order_and_the_pairs():
    rows = []
    for scale in hol.LOAD_SCALES:
        for i, cls in enumerate(("none", "stiction", "stiction", "dead_time")):
            o2 = cls
            o0 = cls if (scale != 1.0 or i == 0) else "none"  # order 0 loses 3 at full load
            rows.append({"load_scale": scale, "class": cls, "seed": i,
                         "order_2": o2, "order_0": o0})
    df = pd.DataFrame(rows)
    t = hol.table(df).set_index(["load (× drawn)", "order"])
    assert t.loc[(1.0, 0), "physics named"].startswith("0/3")
    assert t.loc[(1.0, 2), "physics named"].startswith("3/3")
    assert t.loc[(1.0, 0), "right only with this order / only with order 2"].startswith("0 / 3")
    assert t.loc[(0.1, 0), "right only with this order / only with order 2"].startswith("0 / 0")
    assert t.loc[(1.0, 0), "healthy called physics"].startswith("0/1")
    text = hol.reading(df)
    assert "-3 of 3 at 1× the drawn load; +0 of 3 at 0.1×" in text and "shrinks" in text
    worse = df.assign(order_0=df.order_0.where(df.load_scale == 1.0, "none"))
    assert "does not shrink" in hol.reading(worse)
    df["integrated_2"] = False
    df["integrated_0"] = df["class"] == "stiction"
    assert "named only by order 2 2/3" in hol.noise_reading(df)
    b = hol.by_class(df).set_index("class")
    assert b.loc["stiction", "load 1, order 0"] == "0/2"


def test_the_speed_axis_moves_the_time_constant_alone_and_its_reading_follows_the_loss():
    drawn = hf.draw("sensor_lag", 2, hol.FIRST_SEED)
    c, _ = hf.at_speed("sensor_lag", 2, hol.FIRST_SEED, hol.TAUS[-1])
    assert c.tau == hol.TAUS[-1] and c.load == drawn.load
    assert c.truth["time_constant"] / c.tau == drawn.truth["time_constant"] / drawn.tau
    assert (1.0, None) in hol.variants() and (1.0, hol.TAUS[0]) in hol.variants()

    def rows(fast_lost: int, slow_lost: int) -> pd.DataFrame:
        out = []
        for tau, lost in ((hol.TAUS[0], fast_lost), (hol.TAUS[-1], slow_lost)):
            for i in range(6):
                cls = "none" if i == 0 else "stiction"
                out.append({"load_scale": 1.0, "tau": tau, "class": cls, "seed": i,
                            "order_2": cls, "order_0": "none" if 0 < i <= lost else cls})
        return pd.DataFrame(out)

    grows = hol.speed_reading(rows(1, 4))
    assert "-1 of 5 at τ 8 s (0 / 1, p = 1), -4 of 5 at τ 60 s (0 / 4" in grows
    assert "grows" in grows
    assert "does not grow" in hol.speed_reading(rows(3, 4))
    assert "loses nothing" in hol.speed_reading(rows(2, 0))
    t = hol.table(rows(1, 4)).set_index(["τ (s)", "order"])
    assert t.loc[("60", 0), "physics named"].startswith("1/5")
    assert hol.by_class(rows(1, 4)).set_index("class").loc["stiction", "τ 8 s, order 0"] == "4/5"
    # the drawn-speed rows alone are what the load's reading counts
    assert hol.speed_reading(rows(1, 4).assign(tau=float("nan"))) == ""
