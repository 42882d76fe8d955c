"""The PI's mean output between samples (``stictionbench.diagnosis.intersample``) and its
use by ``diagnose(..., intersample=True)``."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import fast_pi_healthy as fp  # noqa: E402

from stictionbench.diagnosis import NominalModel, diagnose  # noqa: E402
from stictionbench.diagnosis.intersample import effective_op  # noqa: E402
from stictionbench.diagnosis.openloop import fopdt_response  # noqa: E402


def _replay_error(rec, u, tau):
    pv = np.asarray(rec.PV, float) - rec.PV[0]
    best = np.inf
    for shift in np.arange(-1.0, 1.01, 0.25):  # the nominal model's own alignments
        g = fp.GAIN * fopdt_response(u - u[0], 1.0, tau, fp.DEAD_TIME + shift)
        r = pv[100:] - g[100:]
        best = min(best, float(np.std(r)) / float(np.std(pv[100:])))
    return best


@pytest.fixture(scope="module")
def quiet_fast_loop():
    # no noise, no load: the replay's only error is the PI's moves between samples
    return fp.loop(16.0, 0.25, 100, noise=0.0, load=0.0)


def test_the_right_convention_removes_the_replay_error(quiet_fast_loop):
    rec = quiet_fast_loop
    kc, ti = fp.simc(16.0)
    args = (np.asarray(rec.SP), np.asarray(rec.PV), np.asarray(rec.OP), 1.0, kc, ti, 0.25)
    snapshot = _replay_error(rec, np.asarray(rec.OP, float), 16.0)
    before = _replay_error(rec, effective_op(*args, "before"), 16.0)
    after = _replay_error(rec, effective_op(*args, "after"), 16.0)
    # the package's simulator reads OP before the PI executes
    assert before < snapshot / 20 and after > snapshot


def test_no_reconstruction_at_the_historians_rate_or_with_an_unknown_convention():
    sp, pv, op = np.zeros(5), np.arange(5.0), -np.arange(5.0)
    np.testing.assert_array_equal(effective_op(sp, pv, op, 1.0, 1.0, 10.0, 1.0), op)
    with pytest.raises(ValueError, match="convention must be one of"):
        effective_op(sp, pv, op, 1.0, 1.0, 10.0, 0.25, "during")


def test_diagnose_chooses_the_convention_by_the_nominal_fit(quiet_fast_loop):
    kc, ti = fp.simc(16.0)
    model = NominalModel(fp.GAIN, 16.0, fp.DEAD_TIME, kc, ti, 1.0, controller_period=0.25)
    d = diagnose(quiet_fast_loop, model, intersample=True)
    info = d.details["intersample"]
    assert info["op"] == "before"
    costs = info["nominal_training_cost"]
    assert costs["before"] < costs["recorded"] < costs["after"]
    # without the PI's period there is nothing to reconstruct
    plain = NominalModel(fp.GAIN, 16.0, fp.DEAD_TIME, kc, ti, 1.0)
    assert "intersample" not in diagnose(quiet_fast_loop, plain, intersample=True).details
