"""``experiments/fresh_recordings.py``'s shared pieces of the re-make experiments: the
cases drawn from the stored independent sets, and the pairs of loops drawn alike."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import fresh_recordings as fr  # noqa: E402


def test_set_cases_lists_each_kept_recording_once_per_variant():
    stored = pd.read_csv(ROOT / "reports" / "concealed" / "independent_set_c.csv")
    valves = stored[stored["class"].isin(("deadband",)) & (stored.level == 1)]
    todo = fr.set_cases({"C": ("c",)}, ("deadband",), (1.0, 3.0))
    assert len(todo) == 2 * len(valves)
    assert {t[2] for t in todo} == set(valves.name)
    assert all(t[0] == "C" and t[1] == "c" and t[4] == "deadband" for t in todo)
    first = valves.name.iloc[0]
    kept = fr.set_cases({"C": ("c",)}, ("deadband",), ("x",), keep=lambda r: r["name"] == first)
    assert kept == [("C", "c", first, int(valves.seed.iloc[0]), "deadband", "x")]


def test_drawn_alike_keeps_loops_present_and_drawn_alike_at_every_value():
    df = pd.DataFrame({"generator": ["A"] * 5, "name": ["a", "a", "b", "b", "c"],
                       "v": [1, 2, 1, 2, 1], "attempts": [1, 1, 1, 2, 1]})
    assert sorted(set(fr.drawn_alike(df, "v").name)) == ["a"]
