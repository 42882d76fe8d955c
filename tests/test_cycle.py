"""The closed-loop cycle check: the loop's PI identified from a recording without SP, the
fitted valve closed with it, and the verdict rule that names a significant valve whose
closed loop reproduces the recorded oscillation."""

from __future__ import annotations

import math

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.diagnosis import NominalModel, diagnose
from stictionbench.diagnosis.cycle import CycleCheck, check_cycle, closed_loop
from stictionbench.diagnosis.evidence import select
from stictionbench.diagnosis.hammerstein import _exp_within
from stictionbench.diagnosis.model import fit_pi, identify_pi

#: the paper's loop (K 3, τ 10 s, θ 10 s, PI 0.2 / 10 s) executed at the historian rate,
#: a constant set point (a regulatory loop: no SP column is needed)
BASE = dict(duration=3000.0, sample_time=1.0, controller__sample_time=1.0, sensor="noisy",
            sensor__noise_std=0.02, sensor__time_constant=0.0, setpoint="constant")
PROCESS = (3.0, 10.0, 10.0)
F_HP = 0.3 / (2 * math.pi * 20.0)


@pytest.fixture(scope="module")
def sticky():
    # a Kano valve (S 3 %, J 1.5 %) under a slow load: a stick-slip limit cycle
    return sb.simulate("linear", seed=3, valve="kano", valve__S=3.0, valve__J=1.5,
                       disturbance="load", disturbance__load_std=0.5, **BASE)


def test_pi_identified_without_a_setpoint(sticky):
    f = fit_pi(sticky.PV, sticky.OP, sticky.Ts)
    assert f is not None and not f.setpoint_recorded
    assert (f.kc, f.ti, f.setpoint) == pytest.approx((0.2, 10.0, 50.0), rel=1e-6)
    assert f.r2 > 0.999 and f.lag == 1  # the kernel records OP before the PI executes
    # with SP recorded, identify_pi's (kc, ti) are the same fit
    assert identify_pi(sticky) == pytest.approx((0.2, 10.0), rel=1e-6)
    # an OP no PI made (a random walk) is not a controller
    rng = np.random.default_rng(0)
    assert fit_pi(sticky.PV, 50 + np.cumsum(rng.normal(size=len(sticky))), 1.0) is None


def test_true_valve_reproduces_the_cycle_and_a_wrong_one_does_not(sticky):
    pi = fit_pi(sticky.PV, sticky.OP, 1.0)
    c = check_cycle(sticky.PV, sticky.OP, 1.0, F_HP, 3.0, 1.5, PROCESS, pi)
    assert c.applicable and c.reproduced, c.reason
    assert abs(c.log_ratios["period"]) < 0.05 and abs(c.log_ratios["pv_amplitude"]) < 0.2
    # the amplitude tells the valve's size: a quarter of S, or three times S, is rejected
    for S, J in ((0.75, 0.375), (9.0, 4.5)):
        c = check_cycle(sticky.PV, sticky.OP, 1.0, F_HP, S, J, PROCESS, pi)
        assert c.applicable and not c.reproduced
    # a dead band (J = 0) does not sustain a cycle in this self-regulating loop
    c = check_cycle(sticky.PV, sticky.OP, 1.0, F_HP, 3.0, 0.0, PROCESS, pi)
    assert not c.reproduced and c.reason == "the fitted loop does not cycle by itself"
    # no controller, or a positive-feedback pair, leaves the check inapplicable
    assert not check_cycle(sticky.PV, sticky.OP, 1.0, F_HP, 3.0, 1.5, PROCESS, None).applicable
    c = check_cycle(sticky.PV, sticky.OP, 1.0, F_HP, 3.0, 1.5, (-3.0, 10.0, 10.0), pi)
    assert not c.applicable and "negative feedback" in c.reason


def test_external_line_far_from_the_loops_cycle_is_not_reproduced():
    # a linear valve under external lines of 60 s and 300 s: no valve size closes the
    # loop into a cycle of the recorded period and amplitudes
    for amp, period in ((1.0, 60.0), (3.0, 300.0)):
        rec = sb.simulate("linear", seed=3, valve="linear", disturbance="sinusoidal",
                          disturbance__amplitude=amp, disturbance__period=period, **BASE)
        pi = fit_pi(rec.PV, rec.OP, 1.0)
        assert pi is not None
        for S in (0.1, 0.5, 1.0, 2.0, 4.0):
            assert not check_cycle(rec.PV, rec.OP, 1.0, F_HP, S, S / 2, PROCESS, pi).reproduced


def test_a_line_near_the_loops_own_cycle_is_rejected_by_its_waveform():
    # a 150 s sinusoid in a loop whose stick-slip cycle is about 117 s: a valve sized to
    # its amplitude matches period (within 30 %) and amplitudes, as the first version of
    # the check found on 7 of 96 disturbances; a sinusoid has no third harmonic, a
    # stick-slip cycle has one
    rec = sb.simulate("linear", seed=3, valve="linear", disturbance="sinusoidal",
                      disturbance__amplitude=2.0, disturbance__period=150.0, **BASE)
    pi = fit_pi(rec.PV, rec.OP, 1.0)
    for S in (1.0, 1.5, 2.0):
        c = check_cycle(rec.PV, rec.OP, 1.0, F_HP, S, S / 2, PROCESS, pi)
        lr = c.log_ratios
        assert abs(lr["period"]) <= math.log(1.3) and abs(lr["pv_amplitude"]) <= math.log(2)
        assert lr["pv_harmonic_ratio"] > math.log(2) and not c.reproduced


def test_closed_loop_is_the_simulators_kernel():
    # the check's loop is the simulator's: a linear valve's closed loop settles at the
    # set point, a sticky one keeps cycling
    pv, op = closed_loop(1e-9, 0.0, 3.0, 10.0, 10.0, 0.2, 10.0, 1.0, 2000, 1.0)
    assert abs(pv[-1] - 1.0) < 1e-3 and np.ptp(pv[-500:]) < 1e-3
    pv, _ = closed_loop(3.0, 1.5, 3.0, 10.0, 10.0, 0.2, 10.0, 1.0, 2000, 1.0)
    assert np.ptp(pv[-500:]) > 1.0


def _rows(stiction_p=1e-9):
    return [{"physics": "none", "p_value": 1.0, "improvement": 0.0, "raw_score": 0.0,
             "parameters": {}},
            {"physics": "oscillatory_disturbance", "p_value": 1e-20, "improvement": 0.5,
             "raw_score": -120.0, "parameters": {"period": 140.0, "amplitude": 1.0}},
            {"physics": "stiction", "p_value": stiction_p, "improvement": 0.3,
             "raw_score": -60.0, "parameters": {"S": 2.0, "J": 1.0}},
            {"physics": "deadband", "p_value": 1.0, "improvement": 0.0, "raw_score": -10.0,
             "parameters": {"deadband": 2.0}}]


def test_select_names_a_valve_that_reproduces_the_cycle():
    rows = _rows()
    assert select(rows, 1e-6, alpha=0.05, min_improvement=0.1) == "oscillatory_disturbance"
    assert select(rows, 1e-6, alpha=0.05, min_improvement=0.1,
                  cycle_reproduced=True) == "stiction"
    # the nested slip-jump rule still decides within the valve family
    assert select(rows, 0.5, alpha=0.05, min_improvement=0.1,
                  cycle_reproduced=True) == "deadband"
    # it never makes a valve significant by itself
    assert select(_rows(stiction_p=0.2), 1e-6, alpha=0.05, min_improvement=0.1,
                  cycle_reproduced=True) == "oscillatory_disturbance"


def test_diagnose_reports_the_cycle_check(sticky):
    d = diagnose(sticky)  # regulatory, model-free: the PI is identified, SP estimated
    c = d.to_json()["tests"]["closed_loop_cycle"]
    assert set(c) >= {"applicable", "reproduced", "reason", "recorded", "simulated",
                      "log_ratios", "controller", "tolerances"}
    assert c["controller"]["kc"] == pytest.approx(0.2, rel=1e-6)
    # the given model's PI is used as it is
    d = diagnose(sticky, NominalModel(3.0, 10.0, 10.0, 0.2, 10.0, 1.0))
    c = d.tests["closed_loop_cycle"]
    assert c["controller"] == {"kc": 0.2, "ti": 10.0}
    assert d.missing_physics == "stiction" and c["reproduced"]


def test_exp_within_never_overflows():
    # Nelder–Mead's unbounded simplex reached a log-coordinate whose exponential
    # overflowed on a simulated regulatory loop (OverflowError from math.exp)
    assert _exp_within(1e4, 1.0, 10.0) == 10.0
    assert _exp_within(-1e4, 1.0, 10.0) == 1.0
    assert _exp_within(math.log(3.0), 1.0, 10.0) == pytest.approx(3.0)


def test_check_is_strict_json_and_names_an_unstable_loop():
    import json

    # the ACF regularity of a perfectly periodic cycle is infinite (equal crossing
    # intervals): the CLI writes strict JSON (allow_nan=False), so it reads null
    c = CycleCheck(True, True, "reproduced", {"period": 60.0, "regularity": math.inf},
                   {"period": 60.0, "regularity": math.inf}, {"period": 0.0})
    d = json.loads(json.dumps(c.to_dict(), allow_nan=False))
    assert d["recorded"]["regularity"] is None and d["recorded"]["period"] == 60.0
    # a controller far too aggressive for the fitted process: the closed loop diverges
    t = np.arange(3000.0)
    pv, op = np.sin(2 * np.pi * t / 60.0), 50 + np.cos(2 * np.pi * t / 60.0)
    c = check_cycle(pv, op, 1.0, F_HP, 3.0, 1.5, PROCESS, (20.0, 1.0))
    assert c.applicable and not c.reproduced
    assert c.reason == "the fitted loop is unstable with this controller"
    json.dumps(c.to_dict(), allow_nan=False)
