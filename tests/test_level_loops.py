"""``experiments/level_loops.py``: its draws are integrating loops under SIMC-tuned PIs,
its loops are judged as level loops (Horch's test declines them), and bad arguments
exit 2 with one line."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import level_loops as ll  # noqa: E402

from stictionbench.realdata.consensus import Consensus  # noqa: E402


def _value(ov: list[str], key: str) -> str:
    return next(o.split("=", 1)[1] for o in ov if o.startswith(key + "="))


def test_draws_are_integrating_loops_with_simc_tuning():
    ov, p = ll.draw("load", 3)
    assert float(_value(ov, "process.time_constant")) == ll.TAU_INTEGRATOR
    k = float(_value(ov, "process.gain")) / ll.TAU_INTEGRATOR
    assert abs(k - p["k_int"]) < 1e-6 * k and 0.002 <= k <= 0.02
    assert p["ti"] == pytest.approx(4.0 * (p["lambda"] + p["theta"]))
    assert p["kc"] == pytest.approx(1.0 / (p["k_int"] * (p["lambda"] + p["theta"])))
    _, tight = ll.draw("tight", 3)
    assert tight["ti"] == pytest.approx(0.5 * (tight["lambda"] + tight["theta"]))
    ov, p = ll.draw("kano", 7)
    assert p["S"] in ll.LEVEL_BANDS and 0.25 * p["S"] <= p["J"] <= p["S"]
    assert _value(ov, "valve") == "kano"


def test_a_level_loop_is_judged_as_one():
    out = ll.level_loop("sinusoid", 0, Consensus.load())
    assert out["label"] == "no_stiction" and out["horch"] == "inconclusive"
    assert out["horch_reason"] == "integrating loop"
    assert out["consensus"] in ("stiction", "no_stiction", "inconclusive")


def test_bad_arguments_exit_2(tmp_path, capsys):
    assert ll.main(["--per-cell", "0", "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.count("\n") == 1 and not (tmp_path / "o").exists()


def test_deciders_count_who_decided():
    import pandas as pd

    cons = Consensus(("a", "b"), 0.5, 1)
    df = pd.DataFrame([
        {"label": "stiction", "consensus": "stiction", "a": "stiction", "b": "inconclusive"},
        {"label": "no_stiction", "consensus": "stiction", "a": "stiction", "b": "stiction"},
        {"label": "no_stiction", "consensus": "inconclusive", "a": "inconclusive",
         "b": "inconclusive"},
    ])
    out = ll.deciders(df, cons).set_index(["deciding methods", "alone", "label"])["loops"]
    assert out.to_dict() == {(1, "a", "stiction"): 1, (2, "—", "no_stiction"): 1}
