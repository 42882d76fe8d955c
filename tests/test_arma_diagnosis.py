"""The AR-against-ARMA comparison of the diagnosis (``experiments/arma_diagnosis.py``) on
hand-made verdicts: the criterion and the whiteness prediction decide as its docstring
says."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import arma_diagnosis as ad  # noqa: E402

CLASSES = ("none", "stiction", "deadband", "sensor_lag", "dead_time",
           "valve_characteristic", "saturation", "oscillatory_disturbance")


def _frame(healthy_arma: str, seconds_arma: float = 1.0,
           lost_class: str | None = None) -> pd.DataFrame:
    """Both parts, per level one recording of each class named right under both families
    (``lost_class`` missed under ARMA), plus one healthy loop AR calls a dead band and
    ARMA ``healthy_arma``; fresh loops whiter under ARMA."""
    rows = []
    for part in ("A–I", "fresh"):
        for lv in (1, 2):
            for cls in CLASSES:
                for f in ad.FAMILIES:
                    miss = f == "arma" and cls == lost_class
                    rows.append({"part": part, "generator": "A", "set": "x",
                                 "name": f"{part}{lv}{cls}", "class": cls, "level": lv,
                                 "family": f, "predicted": "none" if miss else cls,
                                 "seconds": seconds_arma if f == "arma" else 0.7,
                                 "noise": "ARMA" if f == "arma" else "AR",
                                 "whiteness_p": 0.5 if f == "arma" else 0.01})
            for f in ad.FAMILIES:
                rows.append({"part": part, "generator": "A", "set": "x",
                             "name": f"{part}{lv}h", "class": "none", "level": lv,
                             "family": f,
                             "predicted": "deadband" if f == "ar" else healthy_arma,
                             "seconds": seconds_arma if f == "arma" else 0.7,
                             "noise": "ARMA" if f == "arma" else "AR",
                             "whiteness_p": 0.5 if f == "arma" else 0.01})
    return pd.DataFrame(rows)


def _crit(df: pd.DataFrame, seconds: float = 1.0) -> dict[str, bool]:
    return {what: ok for what, ok, _ in ad.criterion(ad.verdicts(df), seconds)}


def test_arma_that_clears_a_false_alarm_and_loses_nothing_is_adopted():
    df = _frame("none")
    assert all(_crit(df).values())
    text = ad.report(df)
    assert "**Every part met.**" in text
    assert "Held: Ljung–Box rejected the healthy loops' validation innovations on " \
        "4/4 = 100 % [51, 100] under AR and 0/4 = 0 %" in text


def test_arma_that_changes_nothing_or_loses_a_class_or_is_slow_is_not_adopted():
    same = _crit(_frame("deadband"))
    assert same["fresh sets: no more healthy loops called physics"]
    assert not same["fresh sets: a gain (fewer healthy loops called physics, or a "
                    f"level's score up by {ad.MIN_GAIN})"]
    lost = _crit(_frame("none", lost_class="stiction"))
    assert not lost[f"fresh sets: score of 16 lost at most {ad.MAX_LOSS} at each level"]
    assert not lost[f"sets A–I: score of 16 lost at most {ad.MAX_LOSS} at each level"]
    slow = _crit(_frame("none"), seconds=2.5)
    assert not slow[f"a diagnosis under ARMA within {ad.MAX_SECONDS:g} s (median)"]
    text = ad.report(_frame("none", seconds_arma=2.5))
    assert "**Not adopted**" in text and "The shipped noise model is unchanged." in text
    assert "ratio 3.57" in text
