"""The line-test comparison (``experiments/harmonic_line.py``) on hand-made verdicts: its
prediction and report decide as its docstring says."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import harmonic_line as hl  # noqa: E402


def _frame(lines_named: int, healthy_called: int) -> pd.DataFrame:
    """Sets A–I: 108 level-2 disturbances, 51 named by the shipped diagnosis and
    ``lines_named`` with the line test; 216 healthy loops, 22 called physics shipped and
    ``healthy_called`` with the line test. One fresh healthy loop per family."""
    rows = []

    def add(part, name, cls, lv, fam, pred, waived=False):
        rows.append({"part": part, "generator": "A", "set": "x", "name": name,
                     "class": cls, "level": lv, "family": fam, "predicted": pred,
                     "seconds": 0.8, "line_p": 0.01 if waived else 0.5,
                     "gate_waived": waived})

    for i in range(108):
        add("A–I", f"o{i}", "oscillatory_disturbance", 2, "ar",
            "oscillatory_disturbance" if i < 51 else "none")
        add("A–I", f"o{i}", "oscillatory_disturbance", 2, "line_test",
            "oscillatory_disturbance" if i < lines_named else "none", waived=i < lines_named)
    for i in range(216):
        add("A–I", f"h{i}", "none", 1 + i % 2, "ar", "deadband" if i < 22 else "none")
        add("A–I", f"h{i}", "none", 1 + i % 2, "line_test",
            "deadband" if i < healthy_called else "none")
    for fam in hl.LINE.families:
        add("fresh", "f0", "none", 1, fam, "none")
    return pd.DataFrame(rows)


def test_the_prediction_holds_only_with_enough_lines_and_few_new_false_alarms():
    assert hl.prediction(hl.verdicts(_frame(60, 25), hl.LINE))[0]
    assert not hl.prediction(hl.verdicts(_frame(59, 22), hl.LINE))[0]
    assert not hl.prediction(hl.verdicts(_frame(70, 26), hl.LINE))[0]


def test_the_report_counts_where_the_gate_was_waived():
    df = _frame(60, 22)
    w = hl.waived(df)
    row = w[(w.part == "A–I") & (w["class"] == "oscillatory_disturbance")].iloc[0]
    assert (row["gate waived"], row["waived and named a disturbance"]) == (60, 60)
    text = hl.report(df)
    assert "Held: level-2 disturbances named 51 → 60 of 108" in text
