"""Closed-loop Hammerstein identification: S, J and the process from PV and OP only."""

from __future__ import annotations

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.diagnosis.hammerstein import HammersteinResult, fit_hammerstein
from stictionbench.errors import InputError
from stictionbench.recording import Recording


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
