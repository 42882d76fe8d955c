"""The line test across the package's families (``experiments/harmonic_families.py``):
its cases and its prediction decide as its docstring says, on hand-made verdicts."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import harmonic_families as hf  # noqa: E402


def _frame(lost: int, extra_healthy: int, gained: bool) -> pd.DataFrame:
    rows = []
    for fam in ("f1", "f2"):
        for i in range(hf.PER_CLASS):
            named = "oscillatory_disturbance"
            rows.append({"generator": fam, "class": "oscillatory_disturbance", "level": 2,
                         "ar": named if i < 6 else "none",
                         "line_test": named if i < 6 + (gained and fam == "f1") else "none"})
            rows.append({"generator": fam, "class": "none", "level": 1, "ar": "none",
                         "line_test": "deadband" if fam == "f1" and i < extra_healthy
                         else "none"})
            rows.append({"generator": fam, "class": "stiction", "level": 1,
                         "ar": "stiction",
                         "line_test": "deadband" if fam == "f2" and i < lost else "stiction"})
    return pd.DataFrame(rows)


def test_cases_cover_every_family_class_level_and_seed():
    c = hf.cases()
    assert len(c) == len(hf.FAMILIES) * len(hf.CLASSES) * 2 * hf.PER_CLASS
    assert len(set(c)) == len(c)
    assert min(s for *_, s in c) == hf.FIRST_SEED


def test_prediction_holds_only_with_a_gain_no_extra_false_alarm_and_few_losses():
    assert hf.prediction(_frame(0, 0, True))[0]
    assert hf.prediction(_frame(hf.MAX_LOST, 0, True))[0]
    assert not hf.prediction(_frame(hf.MAX_LOST + 1, 0, True))[0]
    assert not hf.prediction(_frame(0, 1, True))[0]
    held, text = hf.prediction(_frame(0, 0, False))
    assert not held and "f1 6 → 6" in text
