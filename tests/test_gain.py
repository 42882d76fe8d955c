"""The loop's gain measured through its set-point moves (:mod:`stictionbench.diagnosis.gain`)
and the diagnosis naming ``valve_characteristic`` from it where nothing else was named."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pi_loop import velocity_pi_loop  # noqa: E402

from stictionbench.diagnosis import NominalModel, diagnose  # noqa: E402
from stictionbench.diagnosis.diagnose import compare  # noqa: E402
from stictionbench.diagnosis.gain import GAIN_TOLERANCE, setpoint_gain  # noqa: E402
from stictionbench.diagnosis.report import summary_markdown  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402

K, TAU, THETA, KC, TI = 2.0, 10.0, 4.0, 0.3, 10.0


def _loop(gain: float, seed: int = 5, n: int = 3000, steps: bool = True,
          load_sd: float = 0.05) -> Recording:
    """A FOPDT of gain ``gain`` under a velocity PI executed every second, the valve
    linear; PV noise (σ 0.2) and a random-walk load fed back through the loop (so OP is
    correlated with it: what biases a least-squares gain in closed loop); the set point
    steps by 4 every 400 s when ``steps``."""
    rng = np.random.default_rng(seed)
    sp = 100.0 + (4.0 * ((np.arange(n) // 400) % 2) if steps else 0.0 * np.arange(n))
    load = np.cumsum(rng.normal(0.0, load_sd, n))
    noise = rng.normal(0.0, 0.2, n)
    return velocity_pi_loop(sp, gain, TAU, THETA, KC, TI, load, noise, 100.0 / gain)


MODEL = NominalModel(K, TAU, THETA, KC, TI, 1.0, op_range=(-1e6, 1e6))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_right_gain_is_not_flagged(seed):
    t = setpoint_gain(compare(_loop(K, seed), MODEL))
    assert t.applicable and not t.significant
    assert t.interval[0] <= 1.0 <= t.interval[1] or abs(math.log(t.ratio)) < 0.05


def test_a_gain_error_is_measured_through_the_set_point():
    t = setpoint_gain(compare(_loop(1.5 * K), MODEL))
    assert t.applicable and t.significant
    assert t.ratio == pytest.approx(1.5, rel=0.05)
    assert t.interval[0] < t.ratio < t.interval[1]
    assert t.nrmse_measured < t.nrmse_given


def test_a_gain_error_under_the_tolerance_is_not_named():
    t = setpoint_gain(compare(_loop(1.07 * K), MODEL))
    assert t.ratio == pytest.approx(1.07, rel=0.03)
    assert abs(math.log(t.ratio)) < math.log(GAIN_TOLERANCE) and not t.significant


def test_no_setpoint_move_no_test():
    t = setpoint_gain(compare(_loop(1.5 * K, steps=False), MODEL))
    assert not t.applicable and "set point" in t.reason


def test_no_model_no_test():
    t = setpoint_gain(compare(_loop(1.5 * K)))
    assert not t.applicable and "no model" in t.reason


def test_diagnosis_names_the_gain_error_with_its_interval():
    d = diagnose(_loop(0.6 * K), MODEL)
    assert d.missing_physics == "valve_characteristic"
    g = d.tests["setpoint_gain"]
    assert g["named"] and d.parameters["gain_ratio"] == pytest.approx(0.6, rel=0.05)
    lo, hi = d.uncertainty["gain_ratio"]
    assert lo < d.parameters["gain_ratio"] < hi
    assert d.fit["improved"] < d.fit["nominal"]
    # the summary says which check named it, and the ranking does not claim it
    assert d.details["decided_by"] == "setpoint_gain"
    text = summary_markdown(d)
    assert "Decided by the set-point gain test" in text
    assert "Named by the set-point gain test: the loop's gain measured" in text
    assert "| yes (setpoint gain) |" in text


def test_diagnosis_of_the_right_gain_reports_the_test_and_names_nothing():
    d = diagnose(_loop(K, 4), MODEL)
    assert d.missing_physics == "none"
    assert d.tests["setpoint_gain"]["applicable"] and not d.tests["setpoint_gain"]["named"]


def test_json_of_a_test_that_did_not_apply_is_strict():
    import json

    d = diagnose(_loop(K, steps=False), MODEL)
    g = d.to_json()["tests"]["setpoint_gain"]
    assert not g["applicable"] and g["interval"] == [None, None]
    json.dumps(d.to_json(), allow_nan=False)
