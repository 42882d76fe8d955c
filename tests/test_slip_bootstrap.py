"""The closed-loop parametric bootstrap of the slip-jump test (``diagnose
--slip-jump-bootstrap B``)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.diagnosis import diagnose
from stictionbench.diagnosis.model import NominalModel
from stictionbench.diagnosis.slip_bootstrap import MIN_B, dead_band_loop, sieve_disturbance
from stictionbench.errors import InputError

MODEL = NominalModel(gain=3.0, time_constant=10.0, dead_time=10.0, kc=0.2, ti=10.0,
                     sample_time=1.0, source="given")


def _rec(**ov):
    base = dict(duration=2000.0, seed=5, sample_time=1.0, sensor="noisy",
                controller__sample_time=1.0, sensor__noise_std=0.05, sensor__time_constant=0.0)
    base.update(ov)
    return sb.simulate("linear", **base)


def test_dead_band_loop_at_rest_stays_at_rest_and_a_band_delays_the_answer():
    n = 400
    sp = np.full(n, 20.0)
    y, u = dead_band_loop(3.0, 10.0, 10.0, 0.2, 10.0, 4.0, sp, np.zeros(n), 50.0, 20.0, 1.0)
    assert np.allclose(y, 20.0) and np.allclose(u, 50.0)
    sp[50:] = 23.0
    y0, _ = dead_band_loop(3.0, 10.0, 10.0, 0.2, 10.0, 0.0, sp, np.zeros(n), 50.0, 20.0, 1.0)
    y4, u4 = dead_band_loop(3.0, 10.0, 10.0, 0.2, 10.0, 4.0, sp, np.zeros(n), 50.0, 20.0, 1.0)
    # OP must cross half the band before the valve moves: PV answers later
    first = [int(np.argmax(np.abs(y - 20.0) > 1e-9)) for y in (y0, y4)]
    assert first[1] > first[0]
    assert abs(u4[-1] - u4[0]) > 0.5


def test_sieve_resample_is_seeded_and_keeps_the_scale():
    r = np.cumsum(np.random.default_rng(0).normal(size=2000)) * 0.1
    a = sieve_disturbance(r, 2000, np.random.default_rng(3))
    b = sieve_disturbance(r, 2000, np.random.default_rng(3))
    assert np.array_equal(a, b)
    assert 0.2 < np.std(np.diff(a)) / np.std(np.diff(r)) < 5.0


def test_requests_that_cannot_run_are_refused_before_fitting():
    rec = _rec(valve="deadband", valve__deadband=2.0)
    with pytest.raises(InputError, match="at least 19"):
        diagnose(rec, MODEL, slip_jump_bootstrap=MIN_B - 1)
    with pytest.raises(InputError, match="needs --model"):
        diagnose(rec, None, slip_jump_bootstrap=MIN_B)


@pytest.mark.parametrize("model", [MODEL, None], ids=["model", "model-free"])
def test_default_test_says_it_is_asymptotic(model):
    """Without the bootstrap the slip-jump p-value is χ²₁, and the JSON says so, so no
    reader takes it for a calibrated one (reports/concealed/slip_jump_calibration.md)."""
    d = diagnose(_rec(valve="kano", valve__S=3.0, valve__J=1.5), model)
    t = d.tests["slip_jump_zero"]
    assert t["method"] == "chi2_asymptotic" and "p_asymptotic" not in t
    assert t["df"] == 1 and 0.0 <= t["p_value"] <= 1.0


def test_bootstrap_p_value_replaces_chi_square_in_the_decision():
    rec = _rec(valve="kano", valve__S=3.0, valve__J=1.5)
    d = diagnose(rec, MODEL, slip_jump_bootstrap=MIN_B, bootstrap_seed=1)
    t = d.tests["slip_jump_zero"]
    assert t["method"] == "bootstrap"
    b = t["bootstrap"]
    assert b["B"] == MIN_B and b["seed"] == 1
    # a Monte Carlo p-value: (1 + k)/(B + 1)
    k = t["p_value"] * (MIN_B + 1) - 1
    assert abs(k - round(k)) < 1e-9 and 0 <= round(k) <= MIN_B
    assert t["p_value"] == b["p_bootstrap"] and 0.0 <= t["p_asymptotic"] <= 1.0
    # a clear slip jump: beyond every null recording, and the verdict is stiction
    assert t["p_value"] == pytest.approx(1.0 / (MIN_B + 1))
    assert d.missing_physics == "stiction"


def test_cli_option_bad_values_exit_2_with_one_line(tmp_path):
    rec = _rec(valve="deadband", valve__deadband=2.0)
    csv = tmp_path / "r.csv"
    rec.to_frame()[["t", "SP", "PV", "OP"]].to_csv(csv, index=False)
    out = tmp_path / "o.json"
    for extra in (["--slip-jump-bootstrap", "-1"], ["--slip-jump-bootstrap", "19"]):
        p = subprocess.run([sys.executable, "-m", "stictionbench.cli", "diagnose", str(csv),
                            "--json", str(out), *extra], capture_output=True, text=True)
        assert p.returncode == 2, p.stderr
        assert len(p.stderr.strip().splitlines()) == 1 and not out.exists()
