"""``experiments/order_by_speed.py``: the paired verdicts are counted per speed bin, the
reading says whether order 0's losses and order 2's extra false alarms share bins, and a
missing order-0 commit is a one-line error with exit 2."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import order_by_speed as obs  # noqa: E402


def _frame(fa_slow: bool) -> pd.DataFrame:
    rows = []
    for dof, lost in ((10.0, 2), (500.0, 0)):
        b = str(pd.cut(pd.Series([dof]), list(obs.EDGES), right=False).astype(str)[0])
        for i in range(4):
            cls = "stiction"
            rows.append({"source": "s", "class": cls, "level": 2, "band_dof": dof,
                         "band_dof_bin": b, "order_2": cls,
                         "order_0": "none" if i < lost else cls})
        fa_here = fa_slow == (dof < 100)
        rows.append({"source": "s", "class": "none", "level": 2, "band_dof": dof,
                     "band_dof_bin": b, "order_2": "deadband" if fa_here else "none",
                     "order_0": "none"})
    return pd.DataFrame(rows)


def test_table_and_reading_count_each_bin():
    df = _frame(fa_slow=True)
    t = obs.table(df).set_index("band_dof")
    assert t.loc["[0.0, 30.0)", "physics named, order 2"].startswith("4/4")
    assert t.loc["[0.0, 30.0)", "physics named, order 0"].startswith("2/4")
    assert t.loc["[0.0, 30.0)", "only order 0 / only order 2"].startswith("0 / 2")
    assert t.loc["[0.0, 30.0)", "healthy called physics, order 2"].startswith("1/1")
    assert t.loc["[250.0, inf)", "healthy called physics, order 2"].startswith("0/1")
    text = obs.reading(df)
    assert "[0.0, 30.0) -2" in text and "bins with both: [0.0, 30.0)" in text
    assert "no split by speed keeps both" in text
    apart = obs.reading(_frame(fa_slow=False))
    assert "bins with both: none" in apart and "could keep both" in apart


def test_a_missing_order0_commit_keeps_the_report(capsys):
    report = obs.OUT / "order_by_speed.md"
    before = report.read_bytes()
    assert obs.main(["--order0-ref", "0000000000000000000000000000000000000000"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("order_by_speed:") and "order0" in err[0]
    assert "kept as committed" in err[0]
    assert report.read_bytes() == before
