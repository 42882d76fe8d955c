"""diagnose: the JSON contract, the verdicts on simulated loops, and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.cli import main
from stictionbench.diagnosis import VOCABULARY, NominalModel, diagnose
from stictionbench.io import write_recording

MODEL = "process: {gain: 3.0, time_constant: 10.0, dead_time: 10.0}\n" \
        "controller: {kc: 0.2, ti: 10.0}\nsample_time: 1.0\n"
NOM = NominalModel(3.0, 10.0, 10.0, 0.2, 10.0, 1.0)


def _rec(**ov):
    base = dict(duration=3000.0, seed=4, sample_time=1.0, sensor="noisy", valve="linear",
                controller__sample_time=1.0, sensor__noise_std=0.05)
    base.update(ov)
    return sb.simulate("linear", **base)


@pytest.fixture(scope="module")
def stiction_rec():
    # physical valve with S ≈ 3.5 %, J ≈ 1.3 % of span
    return _rec(valve="physical", valve__Fs=120.0, valve__Fc=65.0)


def test_stiction_named_and_sized(stiction_rec):
    d = diagnose(stiction_rec, NOM)
    assert d.missing_physics == "stiction"
    S, J = stiction_rec.meta["true_S"], stiction_rec.meta["true_J"]
    assert d.parameters["S"] == pytest.approx(S, rel=0.25)
    assert d.parameters["J"] == pytest.approx(J, rel=0.5)
    assert d.fit["improved"] < 0.8 * d.fit["nominal"]
    assert d.mismatch_detected and d.mismatch_windows
    lo, hi = d.uncertainty["S"]
    assert lo <= d.parameters["S"] <= hi


def test_linear_loop_is_none():
    d = diagnose(_rec(), NOM)
    assert d.missing_physics == "none"
    assert d.parameters == {}


@pytest.mark.parametrize("cls, ov, key, true", [
    ("sensor_lag", {"sensor__time_constant": 8.0}, "time_constant", 8.0),
    ("dead_time", {"process__dead_time": 16.0}, "dead_time", 16.0),
    ("deadband", {"valve": "deadband", "valve__deadband": 2.5}, "deadband", 2.5),
    ("oscillatory_disturbance", {"disturbance": "sinusoidal", "disturbance__amplitude": 1.0,
                                 "disturbance__period": 90.0}, "period", 90.0),
])
def test_other_physics(cls, ov, key, true):
    d = diagnose(_rec(**ov), NOM)
    assert d.missing_physics == cls
    assert d.parameters[key] == pytest.approx(true, rel=0.15)


def test_slow_load_is_not_physics():
    rec = _rec(disturbance="load", disturbance__load_std=2.0,
               disturbance__load_time_constant=600.0)
    assert diagnose(rec, NOM).missing_physics == "none"


def test_cli_contract_and_report(stiction_rec, tmp_path, capsys):
    csv = tmp_path / "rec.csv"
    frame = stiction_rec.to_frame()[["t", "SP", "PV", "OP"]]
    frame.to_csv(csv, index=False)
    model = tmp_path / "m.yaml"
    model.write_text(MODEL)
    out = tmp_path / "out.json"
    rep = tmp_path / "report"
    assert main(["diagnose", str(csv), "--model", str(model), "--json", str(out),
                 "--report", str(rep)]) == 0
    res = json.loads(out.read_text())
    for key in ("mismatch_detected", "missing_physics", "parameters", "fit",
                "mismatch_windows", "mismatch_band_hz", "ranking"):
        assert key in res
    assert res["missing_physics"] in VOCABULARY
    assert res["fit"]["metric"] == "nrmse" and res["fit"]["segment"] == "validation"
    assert {"physics", "score"} <= set(res["ranking"][0])
    assert res["ranking"][0]["score"] == 0.0
    for f in ("replay.png", "residual.png", "spectrum.png", "phase.png", "summary.md"):
        assert (rep / f).is_file()
    # without a model: identified, and said so
    out2 = tmp_path / "out2.json"
    assert main(["diagnose", str(csv), "--json", str(out2)]) == 0
    res2 = json.loads(out2.read_text())
    assert res2["nominal_model"]["source"] == "identified"
    assert "identified" in res2["details"]["note"]


@pytest.mark.parametrize("text, needle", [
    ("process: {gain: 2.0, time_constant: [1\n", "not valid YAML"),
    ("controller: {kc: 1, ti: 2}\n", "missing key 'process'"),
    ("process: {gain: 2.0, time_constant: 5.0}\n", "missing key 'process.dead_time'"),
    ("process: {gain: abc, time_constant: 5.0, dead_time: 1}\n", "process.gain: expected a number"),
    ("process: {gain: 2, time_constant: 0, dead_time: 1}\n", "time_constant: must be positive"),
    ("process: {gain: 2, time_constant: 5, dead_time: -1}\n", "dead_time: must not be negative"),
    ("process: {gain: 2, time_constant: 5, dead_time: 1}\ncontroller: {kc: 1}\n",
     "missing key 'controller.ti'"),
])
def test_bad_model_yaml(tmp_path, capsys, stiction_rec, text, needle):
    csv = write_recording(stiction_rec, tmp_path / "r.csv")
    model = tmp_path / "m.yaml"
    model.write_text(text)
    out = tmp_path / "o.json"
    assert main(["diagnose", str(csv), "--model", str(model), "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1
    assert not out.exists()


def test_unsupportable_recordings(tmp_path, capsys):
    t = np.arange(1000.0)
    flat = sb.Recording.from_arrays(t, np.sin(t / 20), np.full_like(t, 40.0), SP=np.zeros_like(t))
    p = write_recording(flat, tmp_path / "flat.csv")
    assert main(["diagnose", str(p), "--json", str(tmp_path / "o.json")]) == 2
    assert "OP is constant" in capsys.readouterr().err
    short = sb.Recording.from_arrays(t[:150], np.sin(t[:150]), np.cos(t[:150]))
    p2 = write_recording(short, tmp_path / "short.csv")
    assert main(["diagnose", str(p2), "--json", str(tmp_path / "o.json")]) == 2
    assert "at least 200" in capsys.readouterr().err
    assert main(["diagnose", str(tmp_path / "nope.csv"), "--json",
                 str(tmp_path / "o.json")]) == 2
    assert not (tmp_path / "o.json").exists()
