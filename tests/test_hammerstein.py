"""Closed-loop Hammerstein identification: S, J and the process from PV and OP only."""

from __future__ import annotations

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.diagnosis.hammerstein import HammersteinResult, fit_hammerstein
from stictionbench.diagnosis.openloop import stiction_valve
from stictionbench.errors import InputError
from stictionbench.recording import Recording
from stictionbench.sim.valves import ChoudhuryValve, KanoValve, respond


def _rec(valve: str, seed: int = 3, **ov) -> Recording:
    base = dict(duration=3000.0, seed=seed, sample_time=1.0, sensor="noisy",
                controller__sample_time=1.0, sensor__noise_std=0.05, sensor__time_constant=0.0)
    base.update(ov)
    # MV is recorded by the simulator, but the identification never reads it
    return sb.simulate("linear", valve=valve, **base)


@pytest.fixture(scope="module")
def kano_fit() -> tuple[Recording, HammersteinResult]:
    rec = _rec("kano", valve__S=4.0, valve__J=2.0)
    return rec, fit_hammerstein(rec)


def test_stiction_found_with_slip_jump(kano_fit):
    rec, r = kano_fit
    assert r.stiction and r.sticky
    assert r.S == pytest.approx(4.0, rel=0.3)
    assert r.J_interval[0] > 0.0
    assert r.S_interval[0] <= r.S <= r.S_interval[1]
    assert r.J_interval[0] <= r.J <= r.J_interval[1]
    assert r.fit["valve"] < 0.8 * r.fit["linear"]
    assert r.tests["valve_vs_linear"]["p_value"] < 1e-6
    # the process is re-identified with the valve: the valve's lag is no longer in τ
    assert r.process["time_constant"] <= r.linear_process["time_constant"] * 1.05
    d = r.to_dict()
    assert {"S", "J", "S_interval", "J_interval", "process", "tests", "noise_model"} <= set(d)
    assert r.mv.size == len(rec)


def test_valve_with_a_contradicting_process_is_not_a_valve(kano_fit):
    from dataclasses import replace
    _, r = kano_fit
    assert r.consistent and r.process["gain"] * r.linear_process["gain"] > 0
    # the same evidence with the valve model's process reversing the linear gain's sign
    # (or its τ on the search floor) is not read as a sticky valve
    bad = replace(r, consistent=False)
    assert not bad.sticky and not bad.stiction
    assert bad.to_dict()["process_consistent"] is False


def test_stick_band_that_inflates_the_linear_tau_is_still_found():
    # a stick band of a quarter of the OP span: the linear loop fitted through the valve
    # reads its ramps as a process 15x slower than the true τ = 10 s, beyond the old
    # process grid (down to 0.08 τ_lin), which ended on J = 0 here (a dead band)
    rec = _rec("kano", seed=2, duration=1500.0, valve__S=25.0, valve__J=5.0)
    r = fit_hammerstein(rec)
    assert r.linear_process["time_constant"] > 10 * 10.0
    assert r.stiction and r.J_interval[0] > 0.0
    assert r.S == pytest.approx(25.0, rel=0.1)
    assert r.process["time_constant"] == pytest.approx(10.0, rel=0.3)


def test_linear_loop_not_called_stiction():
    r = fit_hammerstein(_rec("linear", seed=5))
    assert not r.stiction
    assert r.tests["valve_vs_linear"]["p_value"] > 1e-3


def test_deadband_is_sticky_but_has_no_slip_jump():
    r = fit_hammerstein(_rec("deadband", valve__deadband=3.0))
    assert r.sticky and not r.stiction
    assert r.J_interval[0] == 0.0
    assert r.S == pytest.approx(3.0, rel=0.25)


def test_constant_op_is_input_error():
    t = np.arange(500.0)
    rec = Recording.from_arrays(t=t, PV=np.sin(t / 10), OP=np.full(500, 40.0))
    with pytest.raises(InputError, match="constant"):
        fit_hammerstein(rec)


def test_choudhury_restart_is_the_simulators_choudhury_valve():
    rng = np.random.default_rng(1)
    op = 50.0 + 10.0 * np.sin(np.arange(3000) / 80.0) + rng.normal(0.0, 0.4, 3000)
    op[1000:1200] = np.round(op[1000:1200])  # quantised: OP halts as well as reverses
    for valve, choudhury in ((ChoudhuryValve(S=3.0, J=1.0), True),
                             (KanoValve(S=3.0, J=1.0), False)):
        # the replay and the simulator agree once both have left their initial rest
        np.testing.assert_array_equal(stiction_valve(op, 3.0, 1.0, 0.0, choudhury)[100:],
                                      respond(valve, op)[100:])
    # under a jittering OP Choudhury's valve advances in steps of about S, Kano's of J
    steps = {ch: np.abs(np.diff(stiction_valve(op, 3.0, 1.0, 0.0, ch))) for ch in (True, False)}
    assert np.median(steps[True][steps[True] > 0]) == pytest.approx(3.0, rel=0.15)
    assert np.median(steps[False][steps[False] > 0]) < 1.5


def test_choudhury_valve_identified_with_its_restart_rule_against_a_given_model():
    # with Kano's restart only, this valve was read as S 3.3, J 0.93 and the valve model
    # halved the linear loop's validation error; with the rule, S and J are recovered
    rec = _rec("choudhury", valve__S=4.0, valve__J=1.5)
    r = fit_hammerstein(rec, linear=(3.0, 10.0, 10.0), fix_process=True)
    assert r.stop_rule == "choudhury" and r.stiction
    assert r.S == pytest.approx(4.0, rel=0.1)
    assert r.J == pytest.approx(1.5, rel=0.2)
    assert r.J_interval[0] > 0.0
    assert r.fit["valve"] < 0.2 * r.fit["linear"]
    # without a model the process is re-identified and the rule is not searched
    assert fit_hammerstein(rec).stop_rule != "choudhury"


def test_held_process_keeps_the_given_dead_time_within_a_sample():
    # a linear valve whose loop has 3 s more dead time than the model says: with the
    # process held, the valve search may move the timing by one sample at most (the
    # recording convention, the nominal's own freedom), not credit a valve with the
    # delay; the shifts of the linear loop and the valve grid used to add up (12 s here)
    rec = _rec("linear", process__dead_time=13.0)
    r = fit_hammerstein(rec, linear=(3.0, 10.0, 10.0), fix_process=True)
    for p in (r.process, r.linear_process):
        assert abs(p["dead_time"] - 10.0) <= 1.0 + 1e-9
    assert r.process["time_constant"] == 10.0


def test_kano_valve_under_a_faster_pi_stays_stiction_with_choudhurys_rule_searched():
    # a Kano valve (S 4, J 2) in a fast loop (τ 2 s, θ 1 s) whose PI executes every 0.2 s
    # (reports/diagnose/fast_loops.md): with the stop rule chosen by the output error,
    # Choudhury's restart at J = 0 won and the valve was named a dead band; the rule is
    # now chosen by the innovations and Choudhury's restart needs a slip jump
    from stictionbench.diagnosis import diagnose
    from stictionbench.diagnosis.model import NominalModel

    tau, theta = 2.0, 1.0
    kc, ti = tau / (2 * theta), tau
    ov = ["process.gain=1.0", f"process.time_constant={tau}", f"process.dead_time={theta}",
          f"controller.kc={kc}", f"controller.ti={ti}", "controller.sample_time=0.2",
          "sensor=noisy", "sensor.time_constant=0.0", "sensor.noise_std=0.1",
          "disturbance=load", "disturbance.load_std=2.0", "disturbance.load_time_constant=300.0",
          "setpoint=constant", "valve=kano", "valve.S=4.0", "valve.J=2.0"]
    sim = sb.simulate("linear", duration=3000.0, seed=0, sample_time=1.0, overrides=ov)
    rec = Recording.from_arrays(sim.t, sim.PV, sim.OP, SP=sim.SP, warn=False)
    d = diagnose(rec, NominalModel(1.0, tau, theta, kc, ti, 1.0))
    h = d.details["hammerstein"]
    assert d.missing_physics == "stiction"
    assert h["J"] >= 0.1 * h["S"]


def test_dead_band_refit_searches_the_band_the_slip_jump_mimics(monkeypatch):
    # a stick-slip valve (S, J) moving lags OP by (S − J)/2: with a given model the
    # restricted (J = 0) fit of the slip-jump test searches widths down to (S − J)/2,
    # below the 0.7 S the profile's own scan starts at, and re-chooses the dead-time
    # shift; it is never worse than that scan, and the test's statistic never higher
    from stictionbench.diagnosis import hammerstein as H

    rec = _rec("deadband", valve__deadband=2.0)
    cap = {}
    shipped = H._result

    def spy(rec_, crit, p, *a, **k):
        cap["crit"], cap["p"] = crit, p
        return shipped(rec_, crit, p, *a, **k)

    monkeypatch.setattr(H, "_result", spy)
    runs = {}
    for fixed in (True, False):
        for flag in (False, True):
            monkeypatch.setattr(H, "J0_NUISANCE", flag)
            runs[fixed, flag] = H.fit_hammerstein(
                rec, linear=(3.0, 10.0, 10.0) if fixed else None, fix_process=fixed)
            if fixed and flag:
                crit, p = cap["crit"], cap["p"]
    S, J, rule, tau, theta = p
    v, q = H._dead_band_fit(crit, p)
    assert q[1] == 0.0 and q[2] == 0
    scan = min(crit.cost(float(s), 0.0, 0, tau, theta)
               for s in max(S, J / 1.5) * np.geomspace(0.7, 1.45, 48))
    assert v <= scan * (1 + 1e-12)
    a, b = (runs[True, f].tests["slip_jump_zero"] for f in (False, True))
    assert b["statistic"] <= a["statistic"] + 1e-9
    assert b["p_value"] >= a["p_value"] - 1e-12
    # without a model (not scored there) the test is the held-process profile as before
    assert (runs[False, True].tests["slip_jump_zero"]
            == runs[False, False].tests["slip_jump_zero"])
    # the interval of J reaches 0 exactly when J = 0 is not rejected
    for r in runs.values():
        assert (r.J_interval[0] == 0.0) == (r.tests["slip_jump_zero"]["p_value"] >= r.alpha)


def test_restart_from_the_dead_band_keeps_the_best_of_both_ends(monkeypatch):
    # with a given model and J0_RESTART, the stick-slip valve is also restarted from the
    # refitted dead band: the valve kept fits the training innovations at least as well
    # as without the restart, and J = 0 is rejected only against that optimum
    from stictionbench.diagnosis import hammerstein as H

    rec = _rec("kano", valve__S=3.0, valve__J=1.0)
    runs = {}
    for flag in (False, True):
        monkeypatch.setattr(H, "J0_RESTART", flag)
        monkeypatch.setattr(H, "J0_NUISANCE", flag)
        runs[flag] = H.fit_hammerstein(rec, linear=(3.0, 10.0, 10.0), fix_process=True)
    off, on = runs[False], runs[True]
    assert on.innovation_variance["valve"] <= off.innovation_variance["valve"] * (1 + 1e-12)
    assert on.stiction and on.J_interval[0] > 0.0
    assert on.S == pytest.approx(3.0, rel=0.3)


def test_every_sample_rule_is_he_et_als_law():
    # He et al.'s (2007) residual-force model on sampled data stops after every sample
    # and slips after J more travel the same way or S back: the every-sample rule, so the
    # identification's search covers the He type the issue names beside Kano's
    from stictionbench.sim.valves import HeValve

    for seed in range(3):
        rng = np.random.default_rng(seed)
        op = np.clip(50.0 + np.cumsum(rng.normal(0.0, 0.5, 3000)), 5.0, 95.0)
        for S, J in ((3.0, 1.0), (4.0, 1.5), (2.0, 2.0), (5.0, 0.5)):
            np.testing.assert_allclose(stiction_valve(op, S, J, np.inf),
                                       respond(HeValve(S=S, J=J), op), atol=1e-9)
