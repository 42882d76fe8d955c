"""The linear-input gate (``diagnosis.linear_input``): a valve named against a given model
must beat, by its likelihood-ratio test, the nominal model with a four-tap FIR on OP, the
valve keeping its fitted size; the FIR family nests its base, a sticky valve passes, and
the gate's p-value is in the ranking."""

from __future__ import annotations

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.diagnosis import NominalModel, diagnose
from stictionbench.diagnosis.diagnose import compare
from stictionbench.diagnosis.evidence import ALPHA
from stictionbench.diagnosis.fit import fit_at
from stictionbench.diagnosis.hypotheses import HYPOTHESES, Nominal
from stictionbench.diagnosis.linear_input import SHIFTS, WithLinearInput, linear_input_test
from stictionbench.diagnosis.noise import fit_noise_model

NOM = NominalModel(3.0, 10.0, 10.0, 0.2, 10.0, 1.0)


def _rec(**ov):
    base = dict(duration=3000.0, seed=4, sample_time=1.0, sensor="noisy", valve="linear",
                controller__sample_time=1.0, sensor__noise_std=0.05,
                sensor__time_constant=0.0)
    return sb.simulate("linear", **(base | ov))


@pytest.fixture(scope="module")
def sticky():
    return _rec(valve="physical", valve__Fs=120.0, valve__Fc=65.0)


def test_the_fir_family_nests_its_base(sticky):
    cmp = compare(sticky, NOM)
    base = fit_at(cmp.prob, Nominal(), np.zeros(0))
    wide = fit_at(cmp.prob, WithLinearInput(Nominal()), np.zeros(0))
    assert wide.beta.size == base.beta.size + len(SHIFTS)
    assert wide.cost_train <= base.cost_train * (1 + 1e-12)
    # the FIR's own columns are the process responses to OP moved by whole samples
    X = WithLinearInput(Nominal()).regressors(cmp.ctx, np.zeros(0))
    assert X.shape == (len(sticky), 1 + len(SHIFTS))
    assert np.allclose(X[3:, 2], X[2:-1, 0])  # one sample behind


def test_a_sticky_valve_is_nonlinear_beyond_the_fir(sticky):
    off = diagnose(sticky, NOM, linear_input_gate=False)
    assert off.details["linear_input_gate"] is False
    assert next(r for r in off.ranking if r["physics"] == "stiction")["p_gate"] is None
    d = diagnose(sticky, NOM)  # the gate is the default with a model
    assert d.details["linear_input_gate"] is True
    assert d.missing_physics == "stiction"
    row = next(r for r in d.ranking if r["physics"] == "stiction")
    assert row["p_gate"] is not None and row["p_gate"] < ALPHA
    assert row["p_value"] < ALPHA


def test_the_test_gives_a_linear_loop_no_valve():
    # an ideal valve: a dead band fitted to it is no better than the FIR on OP
    rec = _rec(seed=7)
    cmp = compare(rec, NOM)
    noise = fit_noise_model(cmp.nominal.resid[cmp.prob.train])
    prob = cmp.prob.with_noise(noise)
    h = HYPOTHESES["deadband"]
    ft = fit_at(prob, h, np.array([1.0]))
    base = fit_at(prob, Nominal(), np.zeros(0))
    t = linear_input_test(cmp.prob, noise, Nominal(), base, h, ft)
    assert t["df"] == 1
    assert t["p_value"] > 0.01


def test_the_command_takes_the_gate(tmp_path, sticky):
    import json

    from stictionbench.cli import main
    from stictionbench.io import write_recording

    csv = tmp_path / "r.csv"
    write_recording(sticky, csv)
    model = tmp_path / "m.yaml"
    model.write_text("process: {gain: 3.0, time_constant: 10.0, dead_time: 10.0}\n"
                     "controller: {kc: 0.2, ti: 10.0}\nsample_time: 1.0\n")
    for flag, on in (("--linear-input-gate", True), (None, True),
                     ("--no-linear-input-gate", False)):
        out = tmp_path / f"d{flag}.json"
        assert main(["diagnose", str(csv), "--model", str(model), "--json", str(out),
                     *([flag] if flag else [])]) == 0
        d = json.loads(out.read_text())
        assert d["details"]["linear_input_gate"] is on
        assert d["missing_physics"] == "stiction"
        p_gate = next(r for r in d["ranking"] if r["physics"] == "stiction")["p_gate"]
        assert (p_gate < ALPHA) if on else p_gate is None


def test_the_gate_without_a_model_is_refused(tmp_path, sticky, capsys):
    import json

    from stictionbench.cli import main
    from stictionbench.io import write_recording

    csv = tmp_path / "r.csv"
    write_recording(sticky, csv)
    out = tmp_path / "d.json"
    for flag in ("--linear-input-gate", "--no-linear-input-gate"):
        assert main(["diagnose", str(csv), "--json", str(out), flag]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{flag} needs --model" in err[0]
        assert not out.exists()
    # without a model and without the flag the gate does not apply (and is not refused)
    assert main(["diagnose", str(csv), "--json", str(out)]) == 0
    assert json.loads(out.read_text())["details"]["linear_input_gate"] is False


def test_flags_that_need_the_other_mode_are_refused(tmp_path, sticky, capsys):
    """--intersample / --no-intersample reconstruct a given model's controller and
    --detection is the no-model route: given in the other mode they did nothing and said
    nothing (a newcomer pass); now one line and exit 2, before any output."""
    from stictionbench.cli import main
    from stictionbench.io import write_recording

    csv = tmp_path / "r.csv"
    write_recording(sticky, csv)
    model = tmp_path / "m.yaml"
    model.write_text("process: {gain: 3.0, time_constant: 10.0, dead_time: 10.0}\n"
                     "controller: {kc: 0.2, ti: 10.0}\n")
    out = tmp_path / "d.json"
    cases = [([flag], f"{flag} needs --model") for flag in ("--intersample",
                                                           "--no-intersample")]
    cases.append((["--model", str(model), "--detection"], "--detection is for a recording "
                                                          "without --model"))
    for args, message in cases:
        assert main(["diagnose", str(csv), "--json", str(out), *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err
        assert not out.exists()
