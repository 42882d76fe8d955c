"""The model's optional ``controller.sample_time`` and the controller-rate warning."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

import stictionbench as sb
from stictionbench.cli import main
from stictionbench.diagnosis import NominalModel, diagnose, load_model
from stictionbench.errors import InputError
from stictionbench.io import write_recording

MODEL = ("process: {gain: 3.0, time_constant: 10.0, dead_time: 10.0}\n"
         "controller: {kc: 0.2, ti: 10.0, sample_time: 0.2}\nsample_time: 1.0\n")


def test_controller_sample_time_is_read_and_validated(tmp_path):
    p = tmp_path / "m.yaml"
    p.write_text(MODEL)
    assert load_model(p).controller_period == 0.2
    p.write_text(MODEL.replace("sample_time: 0.2", "sample_time: 0"))
    with pytest.raises(InputError, match="controller.sample_time: must be positive"):
        load_model(p)
    p.write_text(MODEL.replace(", sample_time: 0.2", ""))
    assert load_model(p).controller_period is None


@pytest.fixture(scope="module")
def rec():
    return sb.simulate("linear", duration=1500.0, seed=3, sample_time=1.0, valve="linear",
                       controller__sample_time=1.0, sensor="noisy", sensor__noise_std=0.05)


def test_warning_only_for_a_pi_faster_than_the_recording(rec):
    nom = NominalModel(3.0, 10.0, 10.0, 0.2, 10.0, 1.0)
    assert "controller_rate_warning" not in diagnose(rec, nom).details
    slow = diagnose(rec, replace(nom, controller_period=1.0))
    assert "controller_rate_warning" not in slow.details
    fast = diagnose(rec, replace(nom, controller_period=0.25))
    assert fast.details["controller_rate_warning"].startswith("the PI executes every 0.25 s")
    # the outputs between samples are reconstructed by default, and the warning says so
    assert "intersample" in fast.details
    assert "reconstructed from the PI's law" in fast.details["controller_rate_warning"]
    # without the reconstruction: a warning, not a different verdict
    plain = diagnose(rec, replace(nom, controller_period=0.25), intersample=False)
    assert "intersample" not in plain.details
    assert "reconstructed" not in plain.details["controller_rate_warning"]
    assert plain.missing_physics == slow.missing_physics


def test_command_prints_the_warning_and_keeps_the_json(rec, tmp_path, capsys):
    csv, yml, out = tmp_path / "r.csv", tmp_path / "r.model.yaml", tmp_path / "o.json"
    write_recording(rec, csv)
    yml.write_text(MODEL)
    assert main(["diagnose", str(csv), "--model", str(yml), "--json", str(out)]) == 0
    assert "the PI executes every 0.2 s" in capsys.readouterr().err
    d = json.loads(out.read_text())
    assert d["nominal_model"]["controller_period"] == 0.2
    assert "controller_rate_warning" in d["details"]
