"""``experiments/refinery_rate_loops.py``: pressure draws are lambda-tuned self-regulating
loops slower than the 10-s sampling, set-point steps stay inside the record, and bad
arguments exit 2 with one line."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import refinery_rate_loops as rr  # noqa: E402


def test_pressure_draws_are_lambda_tuned_and_slower_than_the_sampling():
    for i in range(5):
        ov, p = rr.draw_pressure("load", i)
        assert 10.0 <= p["tau"] <= 120.0 and p["tau"] > rr.SAMPLE_TIME
        assert p["kc"] == pytest.approx(p["tau"] / (p["K"] * (p["lambda"] + p["theta"])))
        assert p["ti"] == p["tau"] and "setpoint=constant" in ov
    _, tight = rr.draw_pressure("tight", 0)
    assert tight["ti"] == pytest.approx(tight["tau"] / 4.0)


def test_setpoint_steps_fall_inside_the_record_and_are_reproducible():
    ov = rr.setpoint_steps("F", "load", 3)
    assert ov[0] == "setpoint=step" and ov == rr.setpoint_steps("F", "load", 3)
    pairs = [p.strip("[]").split(",") for p in ov[1].split("=", 1)[1][1:-1].split("],[")]
    times = [float(t) for t, _ in pairs]
    sizes = [abs(float(s)) for _, s in pairs]
    assert times == sorted(times) and 0 < times[0] and times[-1] < rr.DURATION
    assert all(1.0 <= s <= 5.0 for s in sizes) and len(times) >= rr.DURATION // 600 - 1


def test_bad_arguments_exit_2(tmp_path, capsys):
    assert rr.main(["--per-kind", "0", "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.count("\n") == 1 and not (tmp_path / "o").exists()
