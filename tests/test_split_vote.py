"""The verdict voted over block splits (``experiments/split_vote.py``) on hand-made
verdicts: the vote, the confirmation and the criterion decide as their docstrings say."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import split_vote as sv  # noqa: E402


def _row(a: str, b: str, c: str) -> pd.Series:
    return pd.Series({"interleaved": a, "n3": b, "n9": c})


def test_the_vote_takes_two_of_three_and_none_without_a_majority():
    assert sv.vote(_row("stiction", "stiction", "none")) == "stiction"
    assert sv.vote(_row("none", "deadband", "deadband")) == "deadband"
    assert sv.vote(_row("stiction", "deadband", "none")) == "none"
    assert sv.vote(_row("none", "none", "stiction")) == "none"


def test_confirm_keeps_the_shipped_verdict_only_where_another_split_names_it():
    assert sv.confirm(_row("stiction", "none", "stiction")) == "stiction"
    assert sv.confirm(_row("stiction", "deadband", "none")) == "none"
    # it never names what the shipped split did not
    assert sv.confirm(_row("none", "deadband", "deadband")) == "none"


def _frame(fresh_healthy_vote: str) -> pd.DataFrame:
    """Both parts: per level one recording of each of the eight classes named right under
    every split, plus one healthy loop the shipped split calls a dead band and the other
    two name ``fresh_healthy_vote`` (``none``: the vote clears it)."""
    rows = []
    classes = ("none", "stiction", "deadband", "sensor_lag", "dead_time",
               "valve_characteristic", "saturation", "oscillatory_disturbance")
    for part in ("A–I", "fresh"):
        for lv in (1, 2):
            for cls in classes:
                for sp in sv.SPLITS:
                    rows.append({"part": part, "generator": "A", "set": "x",
                                 "name": f"{part}{lv}{cls}", "class": cls, "level": lv,
                                 "split": sp, "predicted": cls, "seconds": 0.5})
            for sp in sv.SPLITS:
                rows.append({"part": part, "generator": "A", "set": "x",
                             "name": f"{part}{lv}h", "class": "none", "level": lv,
                             "split": sp,
                             "predicted": "deadband" if sp == "interleaved"
                             else fresh_healthy_vote, "seconds": 0.5})
    return pd.DataFrame(rows)


def test_the_criterion_adopts_a_vote_that_clears_a_false_alarm_and_loses_nothing():
    w = sv.verdicts(_frame("none"))
    crit = sv.criterion(w, 1.5)
    assert all(ok for _, ok, _ in crit)
    assert "**Adopted**" in sv.report(_frame("none"))


def test_the_criterion_refuses_a_vote_that_is_too_slow_or_clears_nothing():
    w = sv.verdicts(_frame("deadband"))
    crit = dict((what, ok) for what, ok, _ in sv.criterion(w, 1.5))
    assert not crit["fresh sets: fewer healthy loops called physics"]
    slow = dict((what, ok) for what, ok, _ in sv.criterion(sv.verdicts(_frame("none")), 2.5))
    assert not slow[f"a voted diagnosis within {sv.MAX_SECONDS:g} s (median)"]
    text = sv.report(_frame("deadband"))
    assert "**Not adopted**" in text and "The shipped rule is unchanged." in text
