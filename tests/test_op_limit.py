"""OP held at a limit: the data check (:mod:`stictionbench.diagnosis.op_limit`) and the
diagnosis naming ``saturation`` from it where the comparison with the model sees nothing."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pi_loop import velocity_pi_loop  # noqa: E402

from stictionbench.diagnosis import NominalModel, diagnose  # noqa: E402
from stictionbench.diagnosis.op_limit import MIN_RUN, held_at_limit  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402

K, TAU, THETA, KC, TI = 2.0, 10.0, 4.0, 0.6, 10.0


def _loop(sp_high: float, seed: int = 3, n: int = 3000) -> Recording:
    """A FOPDT under a PI whose output (the recorded OP) is clamped to 0–100 %, the valve
    following it; PV noise and a random-walk load; the set point steps to ``sp_high``
    and back every 500 s (out of the valve's reach when ``K·100 < sp_high``)."""
    rng = np.random.default_rng(seed)
    sp = np.where((np.arange(n) // 500) % 2 == 1, sp_high, 100.0)
    load = np.cumsum(rng.normal(0.0, 0.05, n))
    noise = rng.normal(0.0, 0.5, n)
    return velocity_pi_loop(sp, K, TAU, THETA, KC, TI, load, noise, 50.0, (0.0, 100.0))


MODEL = NominalModel(K, TAU, THETA, KC, TI, 1.0, op_range=(0.0, 100.0))


def test_held_at_the_top_of_the_range():
    op = np.r_[np.linspace(40.0, 99.0, 50), [100.0] * 6, np.linspace(99.0, 60.0, 50)]
    r = held_at_limit(op, (0.0, 100.0))
    assert r["held"] and r["side"] == "high" and r["limit"] == 100.0
    assert r["fraction"] == pytest.approx(6 / op.size)


def test_too_short_a_hold_is_not_one():
    op = np.r_[np.linspace(40.0, 99.0, 50), [100.0] * (MIN_RUN - 1), np.linspace(99, 60, 50)]
    assert not held_at_limit(op, (0.0, 100.0))["held"]


def test_a_compressed_op_holds_everywhere_and_counts_only_at_its_range_end():
    rng = np.random.default_rng(0)
    op = np.repeat(rng.uniform(30.0, 80.0, 100), 4)  # every value held four samples
    assert held_at_limit(op)["runs"] > 0  # a hold at the extreme, as anywhere else
    assert not held_at_limit(op)["held"]
    assert not held_at_limit(op, (0.0, 100.0))["held"]  # 80 is not an end of 0–100
    top = np.r_[op, [100.0] * 8]
    assert held_at_limit(top, (0.0, 100.0))["held"]


def test_a_clamped_op_is_named_saturation_at_its_limit():
    rec = _loop(sp_high=260.0)  # beyond K·100 = 200: OP runs to 100 % and stays
    d = diagnose(rec, MODEL)
    t = d.tests["op_held_at_limit"]
    assert t["held"] and t["named"] and t["side"] == "high"
    assert d.missing_physics == "saturation"
    assert d.parameters == {"op_high": 100.0}
    assert d.uncertainty == {"op_high": [100.0, 100.0]}
    # the model driven by the clamped OP already reproduces PV: no fit improves on it
    assert d.fit["improved"] == d.fit["nominal"]
    assert d.to_json()["tests"]["op_held_at_limit"]["named"] is True


def test_the_same_loop_within_reach_is_none():
    rec = _loop(sp_high=150.0)  # OP stays inside 0–100 %
    d = diagnose(rec, MODEL)
    assert not d.tests["op_held_at_limit"]["held"]
    assert d.missing_physics == "none"


def test_scattered_samples_at_a_range_end_count_only_when_asked():
    # a PI faster than the historian: its snapshots touch 100 % in ones and twos
    rng = np.random.default_rng(1)
    op = rng.uniform(80.0, 99.0, 400)
    op[[50, 51, 120, 300]] = 100.0
    shipped = held_at_limit(op, (0.0, 100.0))
    assert not shipped["held"] and shipped["by"] is None and shipped["longest_run"] == 2
    r = held_at_limit(op, (0.0, 100.0), scattered=True)
    assert r["held"] and r["by"] == "scattered" and r["side"] == "high"
    assert r["samples_at_end"] == 4
    # not at an end of the known range, or fewer than MIN_RUN samples: no hold
    assert not held_at_limit(op, (0.0, 120.0), scattered=True)["held"]
    op[300] = 99.5
    op[120] = 99.0
    assert not held_at_limit(op, (0.0, 100.0), scattered=True)["held"]
