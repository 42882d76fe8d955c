"""The slip check of PV standing in for MV (:mod:`stictionbench.estimators.slip_exit`):
a regulated flow under load is not a stuck valve; a sticky valve's stretches end in
slips the way OP pushed."""

from __future__ import annotations

import numpy as np
import pytest

from stictionbench.estimators import make, slip_exit
from stictionbench.estimators.slip_exit import controller_direction, slip_ended
from stictionbench.estimators.yamashita import slip_ended_stuck
from stictionbench.recording import Recording
from stictionbench.sim.compose import simulate


def _flow(valve: list[str], seed: int, load: float) -> Recording:
    """A flow loop (τ 1 s, θ 0.5 s, PI 0.3 / 10 s every 0.2 s), noise 0.05, a random-walk
    load of standard deviation ``load``, constant set point, 1 s historian."""
    ov = ["process.gain=1.0", "process.time_constant=1.0", "process.dead_time=0.5",
          "controller.kc=0.3", "controller.ti=10.0", "controller.sample_time=0.2",
          "sensor=noisy", "sensor.noise_std=0.05", "setpoint=constant",
          "disturbance=load", f"disturbance.load_std={load}",
          "disturbance.load_time_constant=300.0", *valve]
    r = simulate("linear", duration=3000.0, seed=seed, sample_time=1.0, overrides=ov)
    return Recording.from_arrays(r.t, r.PV, r.OP, SP=r.SP, warn=False)


def test_slip_ended_needs_a_jump_the_way_op_pushed():
    op = np.r_[np.linspace(0, 5, 20), np.full(10, 5.0)]
    stretch = np.array([[0, 20]])
    up = np.r_[np.zeros(20), np.full(10, 5.0)]
    assert slip_ended(op, up, stretch, 0.5, 1).tolist() == [True]
    assert slip_ended(op, up, stretch, 0.5, -1).tolist() == [False]   # reverse loop
    assert slip_ended(op, -up, stretch, 0.5, 1).tolist() == [False]   # the other way
    small = np.r_[np.zeros(20), np.full(10, 0.3)]                     # within the band
    assert slip_ended(op, small, stretch, 0.5, 1).tolist() == [False]
    # a stretch running to the record's end: its end is not seen
    assert slip_ended(op, np.zeros(30), np.array([[10, 30]]), 0.5, 1).tolist() == [False]


def test_slip_size_scales_the_band(monkeypatch):
    op = np.r_[np.linspace(0, 5, 20), np.full(10, 5.0)]
    small = np.r_[np.zeros(20), np.full(10, 0.3)]
    monkeypatch.setattr(slip_exit, "SIZE", 0.5)
    assert slip_ended(op, small, np.array([[0, 20]]), 0.5, 1).tolist() == [True]


@pytest.mark.parametrize("sign", [1, -1])
def test_controller_direction_from_the_integral_action(sign):
    rec = _flow(["valve=linear"], seed=1, load=0.3)
    op, pv = np.asarray(rec.OP), np.asarray(rec.PV)
    # a reverse-acting loop: OP mirrored, the process gain negative
    assert controller_direction(50 + sign * (op - 50), pv, rec.SP) == sign
    assert controller_direction(op[:5], pv[:5]) == 0


def test_yamashita_slip_ended_stuck_counts_runs_ending_in_a_slip():
    op = np.r_[np.arange(10.0), np.full(5, 9.0)]
    mv = np.r_[np.zeros(10), np.full(5, 9.0)]
    assert slip_ended_stuck(op, mv, 0.1, 1) == 9
    assert slip_ended_stuck(op, -mv, 0.1, 1) == 0
    assert slip_ended_stuck(op, mv, 0.1, -1) == 0


def test_regulated_flow_under_load_is_not_called_sticky():
    """An ideal valve under a load: the PI moves OP while the flow stays in its band.
    Kano and Yamashita call it sticky as published; with the check they do not, and
    say why."""
    rec = _load_loop()
    for name in ("kano", "yamashita"):
        plain = make(name, flow_loop=True).estimate(rec)
        checked = make(name, flow_loop=True, slip_exit=True).estimate(rec)
        assert plain.decision is True, (name, plain.diagnostics)
        assert checked.decision is False, (name, checked.diagnostics)
        assert checked.diagnostics["reason"] == slip_exit.REGULATED
        assert checked.diagnostics["slip_size"] == 1.0 and checked.diagnostics["slip_lag"] == 2
        assert checked.diagnostics["direction"] == 1
        assert checked.diagnostics["rho_unchecked"] == pytest.approx(plain.value)


def test_sticky_valve_keeps_its_verdict_with_the_check():
    rec = _sticky_loop()
    for name in ("kano", "yamashita"):
        res = make(name, flow_loop=True, slip_exit=True).estimate(rec)
        assert res.decision is True, (name, res.diagnostics)


def test_recorded_mv_is_not_checked():
    """With MV recorded the published rule stands: the check is for PV standing in."""
    rec = _flow(["valve=linear"], seed=3, load=1.0)
    mv = Recording.from_arrays(rec.t, rec.PV, rec.OP, SP=rec.SP, MV=rec.OP, warn=False)
    a = make("kano", slip_exit=True).estimate(mv)
    b = make("kano").estimate(mv)
    assert a.decision == b.decision and "direction" not in a.diagnostics


def _load_loop() -> Recording:
    """Loop 0 of the healthy `load` loops of experiments/flow_loops.py: an ideal valve,
    which both published rules call sticky there (reports/real/flow_loops.csv)."""
    ov = ["process.gain=1.59878", "process.time_constant=3.42379",
          "process.dead_time=0.781878", "controller.kc=0.357655", "controller.ti=14.703",
          "controller.sample_time=1", "sensor=noisy", "sensor.time_constant=0.5",
          "sensor.noise_std=0.0583604", "setpoint=constant", "disturbance=load",
          "disturbance.load_std=0.430979", "disturbance.load_time_constant=300.0",
          "valve=linear"]
    r = simulate("linear", duration=3000.0, seed=20000, sample_time=1.0, overrides=ov)
    return Recording.from_arrays(r.t, r.PV, r.OP, SP=r.SP, warn=False,
                                 meta={"group": "FIC101"})


def _sticky_loop() -> Recording:
    """Loop 4 of the Kano-valve loops of experiments/flow_loops.py (S 4 %, J 2.9 %)."""
    ov = ["process.gain=1.33617", "process.time_constant=2.74402",
          "process.dead_time=1.14951", "controller.kc=0.0874472", "controller.ti=2.23172",
          "controller.sample_time=0.5", "sensor=noisy", "sensor.time_constant=0",
          "sensor.noise_std=0.0593522", "setpoint=constant", "disturbance=load",
          "disturbance.load_std=0.274096", "disturbance.load_time_constant=300.0",
          "valve=kano", "valve.S=4", "valve.J=2.87331"]
    r = simulate("linear", duration=3000.0, seed=20004, sample_time=1.0, overrides=ov)
    return Recording.from_arrays(r.t, r.PV, r.OP, SP=r.SP, warn=False,
                                 meta={"group": "FIC102"})


def test_batch_notes_a_verdict_resting_on_stretches_without_slips():
    """batch's verdict is unchanged (the check is not adopted), but a stiction verdict
    whose PV-for-MV votes do not survive the slip check carries a note saying so; a
    level loop, or a verdict of no stiction, does not."""
    from stictionbench.realdata.verdict import judge, slip_notes

    rec = _load_loop()
    entry = judge(rec, "regulated", diagnose="none")
    assert entry["verdict"] == "stiction", entry["reason"]
    notes = [n for n in entry["notes"] if "slip check" in n]
    assert len(notes) == 1 and notes[0].startswith("kano and yamashita"), entry["notes"]
    calls = {m: type("C", (), {"verdict": v["verdict"]})() for m, v in entry["methods"].items()}
    assert slip_notes(rec, calls, "no_stiction") == []
    level = Recording.from_arrays(rec.t, rec.PV, rec.OP, SP=rec.SP, warn=False,
                                  meta={"group": "LIC101"})
    assert slip_notes(level, calls, "stiction") == []


def test_batch_does_not_note_a_sticky_valve_whose_stretches_end_in_slips():
    from stictionbench.realdata.verdict import judge

    entry = judge(_sticky_loop(), "sticky", diagnose="none")
    assert entry["verdict"] == "stiction", entry["reason"]
    assert not [n for n in entry["notes"] if "slip check" in n], entry["notes"]
