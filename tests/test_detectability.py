"""The minimum detectable effects of a diagnosis (stictionbench.diagnosis.detectability)."""

from __future__ import annotations

import json

import pytest

import stictionbench as sb
from stictionbench.cli import main
from stictionbench.diagnosis import NominalModel, diagnose
from stictionbench.io import write_recording

NOM = NominalModel(3.0, 10.0, 10.0, 0.2, 10.0, 1.0)
KEYS = {"dead_time_longer", "dead_time_shorter", "sensor_lag", "deadband", "stiction_S"}


def _rec(noise: float, duration: float = 3000.0, **ov):
    base = dict(duration=duration, seed=4, sample_time=1.0, sensor="noisy", valve="linear",
                controller__sample_time=1.0, sensor__noise_std=noise,
                sensor__time_constant=0.0)
    base.update(ov)
    return sb.simulate("linear", **base)


def _minimum(rec, key: str) -> float:
    d = diagnose(rec, NOM)
    m = d.details["minimum_detectable"]
    assert set(m["effects"]) == KEYS
    assert m["power"] == pytest.approx(0.8) and m["gate"] == d.details["nrmse_gate"]
    return m["effects"][key]["minimum"]


@pytest.fixture(scope="module")
def quiet_and_noisy():
    return {k: _minimum(_rec(noise), k2) for k, noise in (("quiet", 0.05), ("noisy", 0.4))
            for k2 in ("sensor_lag",)} | {
        "quiet_S": _minimum(_rec(0.05), "stiction_S"),
        "noisy_S": _minimum(_rec(0.4), "stiction_S")}


def test_more_noise_hides_larger_effects(quiet_and_noisy):
    # λ ∝ effect² / σ²: eight times the noise, several times the smallest visible lag and S
    m = quiet_and_noisy
    assert m["noisy"] > 2.0 * m["quiet"]
    assert m["noisy_S"] > 2.0 * m["quiet_S"]


def test_a_longer_record_shows_smaller_effects_where_power_limits_them():
    # without the NRMSE gate (a share of the residual, whatever the length) only the
    # likelihood-ratio test's power limits: λ grows with the validation samples (here
    # by less than √4, as the set-point moves that excite the lag are not four times as
    # many: 0.55 → 0.49 s)
    def lag(T):
        d = diagnose(_rec(0.2, duration=T), NOM, min_improvement=0.0)
        e = d.details["minimum_detectable"]["effects"]["sensor_lag"]
        assert e["limited_by"] == ["power"]
        return e["minimum"]

    assert lag(6000.0) < lag(1500.0)


def test_an_effect_well_above_its_minimum_is_seen_and_one_well_below_is_not():
    lag = _minimum(_rec(0.2), "sensor_lag")
    above = diagnose(_rec(0.2, sensor__time_constant=3.0 * lag), NOM)
    below = diagnose(_rec(0.2, sensor__time_constant=0.2 * lag), NOM)
    assert above.missing_physics == "sensor_lag"
    assert below.missing_physics == "none"


def test_model_free_diagnosis_has_none_and_can_switch_it_off():
    rec = _rec(0.05)
    assert "minimum_detectable" not in diagnose(rec).details
    assert "minimum_detectable" not in diagnose(rec, NOM, detectability=False).details


def test_the_command_writes_it_in_the_json(tmp_path):
    rec = _rec(0.05)
    csv, model, out = tmp_path / "r.csv", tmp_path / "m.yaml", tmp_path / "o.json"
    write_recording(rec, csv)
    model.write_text("process: {gain: 3.0, time_constant: 10.0, dead_time: 10.0}\n"
                     "controller: {kc: 0.2, ti: 10.0}\nsample_time: 1.0\n")
    assert main(["diagnose", str(csv), "--model", str(model), "--json", str(out)]) == 0
    eff = json.loads(out.read_text())["details"]["minimum_detectable"]["effects"]
    assert set(eff) == KEYS
    dt = eff["dead_time_longer"]
    # counted from the delay the record shows, within a sample of the model's 10 s
    assert dt["model_dead_time_s"] == 10.0 and abs(dt["from_dead_time_s"] - 10.0) <= 1.0
    # beyond one sample of the model's delay: a smaller change is never named
    assert dt["minimum"] is None or dt["from_dead_time_s"] + dt["minimum"] > 11.0
