"""The stage-wise ARMA follow-up (``experiments/arma_stages.py``): on hand-made verdicts its
table and prediction count the loops as its docstring says, and each variant keeps the ARMA
family where its name says."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import arma_stages as st  # noqa: E402


def _frame(tests_only: str, all_but_tests: str) -> pd.DataFrame:
    """Three healthy loops: h1 called a dead band only under ``arma`` (an added false
    alarm) and by each variant as given, h2 a line under every family, h3 none."""
    rows = []
    for name, verdicts in (("h1", {"ar": "none", "arma": "deadband", "tests_only": tests_only,
                                   "all_but_tests": all_but_tests}),
                           ("h2", dict.fromkeys(st.ORDER, "oscillatory_disturbance")),
                           ("h3", dict.fromkeys(st.ORDER, "none"))):
        for v, p in verdicts.items():
            rows.append({"part": "fresh", "generator": "A", "set": "arma_a", "name": name,
                         "level": 1, "variant": v, "predicted": p})
    return pd.DataFrame(rows)


def test_the_added_false_alarm_kept_by_all_but_tests_holds_the_prediction():
    text = st.report(_frame("none", "deadband"))
    assert "`tests_only` keeps 0 and `all_but_tests` 1" in text
    assert "**Prediction held**" in text
    row = st.table(_frame("none", "deadband")).set_index("part").loc["fresh"]
    assert row["arma: called physics"].startswith("2/3")
    assert row["ar: called physics"].startswith("1/3")
    assert row["all_but_tests: keeps of the added"] == "1 of 1"


def test_the_added_false_alarm_kept_by_the_tests_fails_the_prediction():
    assert "**Prediction not held**" in st.report(_frame("deadband", "none"))


def test_each_variant_keeps_the_arma_family_where_its_name_says():
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from fopdt_record import fopdt_record

    from stictionbench.diagnosis import diagnose

    rec, model = fopdt_record(load=0.02)
    got = {v: diagnose(rec, model, detectability=False, **kw).details
           for v, kw in st.VARIANTS.items()}
    assert (got["tests_only"]["noise_family"], got["tests_only"]["test_noise_family"]) \
        == ("ar", "arma")
    assert (got["all_but_tests"]["noise_family"],
            got["all_but_tests"]["test_noise_family"]) == ("arma", "ar")
