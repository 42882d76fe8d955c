"""``experiments/invariance.py``'s report: the fitted S and J are compared apart for the
loops named a sticky valve (a finding) and the rest (a loose fit nobody reads), the report
made from the CSV as written, and ``--reuse`` without a CSV is exit 2."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import invariance as inv  # noqa: E402


def _frame() -> pd.DataFrame:
    rows = []
    for loop, diag, s0, s1 in (("A", "stiction", 2.0, 2.1), ("B", "none", 0.1, 0.2)):
        rows.append({"dataset": "d", "loop": loop, "label": "x", "rewrite": "recorded",
                     "diagnosis": diag, "S": s0, "J": s0, "batch": "no_stiction"})
        rows.append({"dataset": "d", "loop": loop, "label": "x", "rewrite": "minutes",
                     "diagnosis": diag, "S": s1, "J": s0, "batch": "no_stiction"})
    return pd.DataFrame(rows)


def test_sticky_loops_are_reported_apart():
    (text,) = inv._valve_sentence(_frame().drop(columns="dataset"))
    # A: |2.1 - 2.0| / 2.0 = 0.05; B: |0.2 - 0.1| / 0.1 = 1
    assert "1 recordings named a sticky valve as recorded, by at most 0.05 and 0" in text
    assert "1 recordings named no sticky valve as recorded, by at most 1 and 0" in text


def test_reuse_gives_the_report_of_the_run(tmp_path):
    assert inv._write(tmp_path, _frame()) == 0
    first = (tmp_path / "invariance.md").read_text()
    assert inv.main(["--out", str(tmp_path), "--reuse"]) == 0
    assert (tmp_path / "invariance.md").read_text() == first
    assert "by at most 0.05 and 0 of its S" in first


def test_reuse_without_a_csv_is_exit_2(tmp_path, capsys):
    assert inv.main(["--out", str(tmp_path), "--reuse"]) == 2
    assert "not present" in capsys.readouterr().err
