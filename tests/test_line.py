"""The line test (:mod:`stictionbench.diagnosis.line`): where a fit's improvement lies in
frequency, and the oscillatory disturbance named in place of an OP-driven pick that gains
at the residual's line alone."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from pi_loop import velocity_pi_loop

from stictionbench.diagnosis import diagnose
from stictionbench.diagnosis.line import (
    LINE_SHARE,
    line_confinement,
    line_share,
    named_line,
    residual_line,
)
from stictionbench.diagnosis.model import NominalModel

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import concealed  # noqa: E402

RNG = np.random.default_rng(7)
T = np.arange(3000.0)
NOISE = RNG.standard_normal(T.size)
LINE = 2.0 * np.sin(2 * np.pi * T / 60.0)


def test_residual_line_finds_the_strongest_peak():
    assert abs(1.0 / residual_line(NOISE + LINE, 1.0) - 60.0) < 1.0
    assert math.isnan(residual_line(np.ones(100), 1.0))


def test_share_is_one_for_a_line_removed_alone_and_small_for_a_broadband_gain():
    assert abs(line_share(NOISE + LINE, NOISE, 1.0, 1 / 60) - 1.0) < 0.05
    broad = 0.7 * RNG.standard_normal(T.size)
    assert line_share(NOISE + LINE + broad, NOISE + LINE, 1.0, 1 / 60) < 0.1
    # a fit that gains nothing overall has no share
    assert math.isnan(line_share(NOISE, NOISE + broad, 1.0, 1 / 60))


def test_only_an_op_driven_pick_is_replaced_and_only_at_or_above_the_threshold():
    e0 = NOISE + LINE
    errors = {"dead_time": NOISE, "oscillatory_disturbance": NOISE,
              "deadband": e0 - 0.5 * LINE + 0.3 * RNG.standard_normal(T.size)}
    t = line_confinement(e0, errors, 1.0, "dead_time")
    assert t["hypothesis"] == "dead_time" and abs(t["share"] - 1.0) < 0.05
    t = line_confinement(e0, {"dead_time": NOISE - 0.3 * RNG.standard_normal(T.size)}, 1.0,
                         "dead_time")  # the line removed, the rest made worse
    assert t["named"] and t["share"] > LINE_SHARE
    assert "oscillatory_disturbance" not in t["shares"]
    assert not line_confinement(e0, errors, 1.0, "oscillatory_disturbance")["named"]
    assert not line_confinement(e0, errors, 1.0, "none")["named"]
    assert not named_line("dead_time", {"dead_time": None})
    assert named_line("sensor_lag", {"sensor_lag": LINE_SHARE + 1e-9})
    assert not named_line("sensor_lag", {"sensor_lag": LINE_SHARE})
    json.dumps(t, allow_nan=False)  # the CLI's strict JSON


def _loop_with_wandering_line(seed: int) -> tuple:
    """A FOPDT loop, PI every second, with set-point steps, a random-walk load and an
    oscillation added to PV whose frequency and amplitude wander (±3 %, ±15 %): the model
    given is the loop's own, so the line is the only physics missing."""
    rng = np.random.default_rng(seed)
    n, K, tau, theta = 3000, 1.5, 12.0, 3.0
    kc, ti = tau / (K * (6.0 + theta)), tau
    sp = np.full(n, 50.0)
    for k0 in (300, 1100, 1900, 2500):
        sp[k0:] += rng.choice([-1, 1]) * rng.uniform(3, 6)

    def ou(tc: float, sd: float) -> np.ndarray:
        b = math.exp(-1.0 / tc)
        x = np.zeros(n)
        for k in range(1, n):
            x[k] = b * x[k - 1] + math.sqrt(1 - b * b) * sd * rng.standard_normal()
        return x

    period = 45.0
    ph = 2 * np.pi * np.cumsum((1 + ou(5 * period, 0.03)) / period)
    line = 1.5 * (1 + ou(3 * period, 0.15)) * np.sin(ph)
    load = np.cumsum(rng.standard_normal(n)) * 0.02
    noise = 0.15 * rng.standard_normal(n)
    rec = velocity_pi_loop(sp, K, tau, theta, kc, ti, load + line, noise, op0=50.0 / K)
    model = NominalModel(gain=K, time_constant=tau, dead_time=theta, kc=kc, ti=ti,
                         sample_time=1.0)
    return rec, model, period


def test_a_wandering_external_line_is_named_a_line_not_op_driven_physics():
    rec, model, period = _loop_with_wandering_line(3)
    d = diagnose(rec, model)
    test = d.tests["line_confined"]
    # the comparison's best fit was OP-driven physics (a lag shifting OP's echo of the
    # line), whose gain lies at the line: the line is named, at its period
    assert test["hypothesis"] in ("sensor_lag", "dead_time")
    assert test["named"] and test["share"] > LINE_SHARE
    assert d.missing_physics == "oscillatory_disturbance"
    assert abs(d.parameters["period"] / period - 1.0) < 0.15
    assert abs(test["line_period_s"] / period - 1.0) < 0.15


def test_stored_rows_are_re_decided_with_the_line_test():
    ev = [{"physics": "none", "p_value": 1.0, "improvement": 0.0, "score": 30.0,
           "at_bound": False, "parameters": {}},
          {"physics": "dead_time", "p_value": 1e-9, "improvement": 0.5, "score": 0.0,
           "at_bound": False, "parameters": {"dead_time": 9.0}}]
    row = pd.Series({"evidence": json.dumps(ev), "slip_jump_p": float("nan"),
                     "dead_time_own_resolution": True,
                     "line_shares": json.dumps({"dead_time": 1.2})})
    assert concealed.decide(row, 0.05, 0.1) == "oscillatory_disturbance"
    row["line_shares"] = json.dumps({"dead_time": 0.3})
    assert concealed.decide(row, 0.05, 0.1) == "dead_time"
    assert concealed.decide(row.drop("line_shares"), 0.05, 0.1) == "dead_time"


def test_a_line_named_without_a_sinusoid_fitted_keeps_the_nominal_fit(tmp_path):
    from stictionbench.diagnosis.report import write_report

    rec, model, period = _loop_with_wandering_line(3)
    d = diagnose(rec, model, hypotheses=("sensor_lag", "dead_time"))
    assert d.tests["line_confined"]["named"]
    assert d.missing_physics == "oscillatory_disturbance"
    # no improvement claimed: the line's period read off the residual, the nominal's fit
    assert d.fit["improved"] == d.fit["nominal"] and d.uncertainty == {}
    assert abs(d.parameters["period"] / period - 1.0) < 0.15
    paths = write_report(d, tmp_path)
    assert "echo of an external oscillation" in (tmp_path / "summary.md").read_text()
    assert all(p.exists() for p in paths)


def test_only_a_linear_lag_on_pv_is_replaced():
    shares = {"stiction": 1.7, "deadband": 1.7, "dead_time": 1.7, "sensor_lag": 1.7,
              "valve_characteristic": 1.7, "saturation": 1.7}
    # a valve in a limit cycle gains at its line by nature: the cycle check judges it
    assert [h for h in shares if named_line(h, shares)] == ["dead_time", "sensor_lag"]
    t = line_confinement(NOISE + LINE, {"stiction": NOISE - 0.3 * RNG.standard_normal(
        T.size)}, 1.0, "stiction")
    assert t["share"] > LINE_SHARE and not t["named"]
