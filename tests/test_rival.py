"""The answer's closest rival (``tests.rival``, Vuong's test) and stage 5's end
(:func:`~stictionbench.diagnosis.diagnose.answer`): the stages run one by one give the
diagnosis, and the rival test says when the data cannot tell two explanations apart."""

from __future__ import annotations

import json

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.diagnosis import NominalModel, diagnose
from stictionbench.diagnosis.diagnose import (
    answer,
    compare,
    fit,
    floor_answer,
    hypothesise,
    locate,
    validate,
)
from stictionbench.diagnosis.rival import rival_test

NOM = NominalModel(3.0, 10.0, 10.0, 0.2, 10.0, 1.0)


def _rows(*specs):
    return [{"physics": p, "score": s, "significant": sig, "df": df}
            for p, s, sig, df in specs]


def test_a_clearly_better_answer_is_distinguishable():
    rng = np.random.default_rng(0)
    e = {"dead_time": rng.normal(size=800), "sensor_lag": 1.3 * rng.normal(size=800)}
    rows = _rows(("dead_time", 0.0, True, 1), ("sensor_lag", 90.0, True, 1))
    t = rival_test("dead_time", rows, e, np.arange(800), 0.05)
    assert t["rival"] == "sensor_lag" and t["distinguishable"] and t["p_value"] < 1e-6
    assert t["n"] == 800


@pytest.mark.parametrize("apart", [0.05, 1.0])
def test_level_under_the_null(apart):
    # two models equally close to the truth, many draws: the one-sided test rejects at
    # about alpha (Vuong 1989: z is standard normal under equivalence), whether the two
    # models' errors nearly coincide (``apart`` small: a dead time and a lag that explain
    # a record alike) or are independent
    rng = np.random.default_rng(2)
    rows = _rows(("a", 0.0, True, 1), ("b", 0.0, True, 1))
    hits = 0
    for _ in range(400):
        w = rng.normal(size=600)
        e = {"a": w + apart * rng.normal(size=600), "b": w + apart * rng.normal(size=600)}
        hits += rival_test("a", rows, e, np.arange(600), 0.05)["distinguishable"]
    assert 0.02 <= hits / 400 <= 0.09


def test_who_is_a_rival():
    rng = np.random.default_rng(3)
    e = {k: rng.normal(size=200) for k in ("none", "stiction", "deadband", "dead_time")}
    val = np.arange(200)
    # the nested partner (decided by the slip jump) and the insignificant are not rivals
    rows = _rows(("stiction", 0.0, True, 3), ("deadband", 1.0, True, 1),
                 ("dead_time", 5.0, False, 1), ("none", 9.0, False, 0))
    assert rival_test("stiction", rows, e, val, 0.05) == {
        "method": "vuong", "rival": None, "reason": "no other hypothesis passed the gates"}
    rows[2]["significant"] = True
    assert rival_test("stiction", rows, e, val, 0.05)["rival"] == "dead_time"
    assert rival_test("none", rows, e, val, 0.05)["rival"] is None


def test_schwarz_correction_charges_the_larger_model():
    # identical innovations: the model with two more parameters loses the tie
    rng = np.random.default_rng(4)
    w = rng.normal(size=500)
    e = {"big": w + 1e-3 * rng.normal(size=500), "small": w + 1e-3 * rng.normal(size=500)}
    rows = _rows(("big", 0.0, True, 3), ("small", 0.1, True, 1))
    t = rival_test("big", rows, e, np.arange(500), 0.05)
    assert t["statistic"] < 0 and t["p_value"] > 0.5


@pytest.fixture(scope="module")
def lag_rec():
    return sb.simulate("linear", duration=3000.0, seed=4, sample_time=1.0, sensor="noisy",
                       valve="linear", controller__sample_time=1.0, sensor__noise_std=0.05,
                       sensor__time_constant=6.0)


def test_the_stages_one_by_one_give_the_diagnosis(lag_rec):
    cmp = compare(lag_rec, NOM)
    loc = locate(cmp)
    fits, ham = fit(cmp, hypothesise(cmp, loc))
    d = answer(cmp, loc, fits, ham, validate(cmp, fits))
    whole = diagnose(lag_rec, NOM)
    assert d.missing_physics == whole.missing_physics == "sensor_lag"
    assert d.parameters == pytest.approx(whole.parameters)
    assert d.tests["rival"] == whole.tests["rival"]


def test_the_answer_carries_its_rival_test(lag_rec):
    js = diagnose(lag_rec, NOM).to_json()
    t = js["tests"]["rival"]
    assert t["method"] == "vuong"
    if t["rival"] is not None:
        assert 0.0 <= t["p_value"] <= 1.0 and t["rival"] != js["missing_physics"]
        assert t["distinguishable"] == (t["p_value"] < 0.05)
    json.dumps(js, allow_nan=False)


def test_the_floor_withdraws_the_rival_with_the_answer():
    d = diagnose(sb.simulate("linear", duration=3000.0, seed=4, sample_time=1.0,
                             sensor="noisy", valve="linear", controller__sample_time=1.0,
                             sensor__noise_std=0.05, sensor__time_constant=6.0), NOM)
    assert d.missing_physics != "none"
    floored = floor_answer(d, floor=10.0)
    assert floored.missing_physics == "none" and floored.tests["rival"]["rival"] is None


def test_the_report_says_when_the_rival_cannot_be_told_apart(lag_rec):
    from stictionbench.diagnosis.report import summary_markdown

    d = diagnose(lag_rec, NOM)
    d.tests["rival"] = {"method": "vuong", "rival": "dead_time", "statistic": 0.2,
                        "p_value": 0.42, "distinguishable": False, "n": 1000}
    text = summary_markdown(d)
    assert "Closest rival: dead_time" in text and "fits both about alike" in text
    d.tests["rival"] = {"method": "vuong", "rival": None, "reason": "none passed"}
    assert "Closest rival" not in summary_markdown(d)
