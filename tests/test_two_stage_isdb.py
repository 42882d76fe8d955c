"""``experiments/two_stage_isdb.py`` on hand-made comparison and diagnosis tables: a loop
is named only when the consensus detects it and J's interval excludes 0 (strict: and the
stiction fit improves); forbidden loops are listed by name."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import two_stage_isdb as ts  # noqa: E402

from stictionbench.realdata.compare import PUBLISHED  # noqa: E402


def _verdicts(loops: dict[str, tuple[str, str]]) -> pd.DataFrame:
    """One row per loop: its label and every published method voting ``verdict``."""
    return pd.DataFrame([{"loop": k, "label": lab, **{m: v for m in PUBLISHED}}
                         for k, (lab, v) in loops.items()])


def test_named_needs_detection_a_slip_jump_and_for_strict_an_improvement(tmp_path):
    real = tmp_path / "real"
    real.mkdir()
    _verdicts({"CHEM1": ("stiction", "stiction"), "CHEM2": ("stiction", "stiction"),
               "CHEM3": ("stiction", "no_stiction"), "PAP4": ("no_stiction", "stiction"),
               }).to_csv(real / "comparison_isdb.csv", index=False)
    _verdicts({"F1": ("stiction", "stiction"), "F2": ("no_stiction", "no_stiction")}
              ).to_csv(real / "comparison_plant.csv", index=False)
    diag = tmp_path / "summary.csv"
    pd.DataFrame({
        "loop": ["CHEM1", "CHEM2", "CHEM3", "PAP4"],
        "diagnosis": ["stiction", "none", "none", "none"],
        "S": [1.0, 1.0, 1.0, 1.0], "J": [0.5, 0.5, 0.5, 0.5],
        "J_interval": ["[0.2, 0.8]", "[0.1, 0.9]", "[0.2, 0.8]", "[0.1, 0.6]"],
        "stiction_improvement": [0.2, -0.1, 0.2, 0.1],
    }).to_csv(diag, index=False)
    out = tmp_path / "out"
    assert ts.main(["--real", str(real), "--diagnosis", str(diag), "--out", str(out)]) == 0
    tab = pd.read_csv(out / "two_stage_isdb.csv")
    assert tab.set_index("loop")["J_excludes_0"].all()
    text = (out / "two_stage_isdb.md").read_text()
    # every version detects CHEM1, CHEM2 and PAP4 (all methods vote stiction there)
    assert "2/3 = 67 %" in text and "1/3 = 33 %" in text      # J rule; strict
    assert "| 2/3 = 67 % [21, 94] | PAP4 | CHEM1, CHEM2 |" in text   # PAP4: forbidden
    assert "`diagnose` alone (the shipped rule) names stiction on 1 of 3" in text
