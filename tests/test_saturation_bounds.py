"""A loop at rest is not a saturation; an identified model on its search limit is said; one
direction of Haugh's test (``experiments/saturation_bounds.py``, ``op_drives_pv.py``)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from stictionbench.diagnosis import diagnose
from stictionbench.diagnosis.diagnose import _at_search_limit
from stictionbench.diagnosis.hypotheses import HYPOTHESES
from stictionbench.diagnosis.process import search_limits
from stictionbench.diagnosis.routes import pairing_test
from stictionbench.sim import simulate


def test_saturation_limits_stop_at_the_median():
    ctx = SimpleNamespace(op=np.r_[np.arange(10.0), 100.0])
    (lo_min, lo_max), (hi_min, hi_max) = HYPOTHESES["saturation"].bounds(ctx)
    assert (lo_min, lo_max, hi_min, hi_max) == (0.0, 5.0, 5.0, 100.0)


def test_a_loop_at_rest_is_not_named_a_saturation():
    # the newcomer pass's loop: OP jitters on PV noise by 0.1 %, the valve never moves;
    # the saturation's refinement used to put op_low at OP's 99.97th percentile
    rec = simulate("linear", duration=3000.0, seed=0,
                   overrides=["sensor=noisy", "setpoint=constant"])
    assert np.ptp(rec.MV) < 1e-9
    d = diagnose(rec)
    assert d.missing_physics != "saturation", d.parameters
    row = next(r for r in d.ranking if r["physics"] == "saturation")
    assert row["parameters"].get("op_low", -np.inf) <= np.median(rec.OP) + 1e-12


def test_op_that_does_not_reach_pv_is_told_apart():
    rng = np.random.default_rng(1)
    n = 3000
    pv = rng.normal(size=n)
    # a controller answering PV: OP follows PV, nothing goes back
    op = 50.0 - 0.3 * np.cumsum(pv) * 0.1 - 0.3 * pv
    rec = SimpleNamespace(PV=pv, OP=op, Ts=1.0)
    t = pairing_test(rec, 0.05, 5.0, 10.0)
    assert not t["independent"] and not t["op_drives_pv"]
    # and a process: PV follows OP five samples later
    u = rng.normal(size=n)
    y = np.r_[np.zeros(5), u[:-5]] + 0.5 * rng.normal(size=n)
    t = pairing_test(SimpleNamespace(PV=y, OP=u, Ts=1.0), 0.05, 5.0, 10.0)
    assert t["op_drives_pv"] and t["p_op_leads"] < 1e-6


def test_an_identified_time_constant_on_its_search_limit_is_said():
    n, Ts = 3000, 1.0
    tau_max, theta_max = search_limits(n, Ts)
    rec = SimpleNamespace(PV=np.zeros(n), Ts=Ts)
    at = SimpleNamespace(rec=rec, model=SimpleNamespace(time_constant=tau_max, dead_time=3.0))
    said = _at_search_limit(at)
    assert said is not None and "τ = 1500 s" in said and "θ" not in said.split("sits")[0]
    inside = SimpleNamespace(rec=rec, model=SimpleNamespace(time_constant=40.0,
                                                            dead_time=theta_max))
    assert "θ = 750 s" in _at_search_limit(inside)
    fine = SimpleNamespace(rec=rec, model=SimpleNamespace(time_constant=40.0, dead_time=3.0))
    assert _at_search_limit(fine) is None


def _at_rest_1s():
    from stictionbench.recording import Recording

    rec = simulate("linear", duration=3000.0, seed=0,
                   overrides=["sensor=noisy", "setpoint=constant"])
    k = 10
    return Recording.from_arrays(rec.t[::k], rec.PV[::k], rec.OP[::k], SP=rec.SP[::k])


def test_a_controller_answering_pv_through_a_valve_at_rest_is_dependent_but_not_driving():
    # at the simulator's 0.1 s the controller's answer to PV noise makes OP and PV
    # dependent (the pairing test rejects independence); OP leads PV at no lag
    rec = simulate("linear", duration=3000.0, seed=0,
                   overrides=["sensor=noisy", "setpoint=constant"])
    dep = pairing_test(rec, 0.05, 10.0, 10.0)
    assert not dep["independent"] and not dep["op_drives_pv"]


def test_the_drive_check_holds_back_physics_named_through_an_op_that_does_not_reach_pv():
    rec = _at_rest_1s()
    off = diagnose(rec, drive_check=False)
    assert not off.tests["op_pv_dependence"]["op_drives_pv"]
    assert off.missing_physics != "none"  # the false alarm the check is for
    on = diagnose(rec, drive_check=True)
    assert on.missing_physics == "none"
    assert on.details["decided_by"] == "op_not_driving_pv"
    assert on.details["op_not_driving_pv"]["named_before"] == off.missing_physics


def test_the_drive_check_is_a_command_line_switch(tmp_path):
    import json

    from stictionbench.cli import main

    rec = _at_rest_1s()
    csv = tmp_path / "rest.csv"
    rec.to_frame().to_csv(csv, index=False)
    out = tmp_path / "d.json"
    assert main(["diagnose", str(csv), "--drive-check", "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["missing_physics"] == "none"
    assert d["details"]["decided_by"] == "op_not_driving_pv"
    assert d["tests"]["op_pv_dependence"]["op_drives_pv"] is False
