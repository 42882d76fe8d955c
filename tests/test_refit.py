"""The process-refit check: a valve named against a model whose time constant is wrong is
flagged as possibly the model's own error; the check informs and never changes the answer."""

from __future__ import annotations

import pytest

from stictionbench.diagnosis import diagnose
from stictionbench.diagnosis.model import NominalModel
from stictionbench.diagnosis.refit import REFIT_CLASSES, refitted_model
from stictionbench.sim import simulate

MODEL = NominalModel(3.0, 10.0, 10.0, 0.2, 10.0, controller_period=1.0)


def _loop(tau: float, seed: int = 5):
    return simulate("linear", duration=3000.0, seed=seed, overrides=[
        "valve=linear", "sensor=noisy", "sensor.time_constant=0.01", "sensor.noise_std=0.2",
        "setpoint=servo", "sample_time=1.0", "controller.sample_time=1.0",
        f"process.time_constant={tau}"])


@pytest.fixture(scope="module")
def wrong_tau():
    return _loop(14.0)


def test_the_refit_recovers_the_plants_time_constant(wrong_tau):
    m = refitted_model(wrong_tau, MODEL)
    assert m.time_constant == pytest.approx(14.0, rel=0.1)
    assert (m.kc, m.ti, m.controller_period) == (MODEL.kc, MODEL.ti, 1.0)


def test_a_valve_named_from_a_wrong_time_constant_is_flagged_not_changed(wrong_tau):
    plain = diagnose(wrong_tau, MODEL)
    checked = diagnose(wrong_tau, MODEL, process_refit=True)
    assert plain.missing_physics in REFIT_CLASSES  # the model's error read as a valve
    assert checked.missing_physics == plain.missing_physics  # informs, does not decide
    info = checked.details["process_refit"]
    assert not info["valve_kept"] and info["missing_physics"] == "none"
    warning = checked.details["refit_warning"]
    assert "cannot tell" in warning and "validation NRMSE" in warning
    assert 0.0 < info["nrmse_refit_nominal"] < plain.fit["nominal"]
    assert "process_refit" not in plain.details and "refit_warning" not in plain.details


def test_a_right_model_gets_no_refit_and_no_warning():
    d = diagnose(_loop(10.0), MODEL, process_refit=True)
    assert d.missing_physics == "none"
    assert "process_refit" not in d.details and "refit_warning" not in d.details


def test_a_refit_on_its_search_limit_or_undiagnosable_concludes_nothing(wrong_tau,
                                                                        monkeypatch):
    from dataclasses import replace

    from stictionbench.diagnosis import refit
    from stictionbench.errors import InputError

    d = diagnose(wrong_tau, MODEL)
    limit = replace(MODEL, time_constant=len(wrong_tau) * wrong_tau.Ts)  # the record long
    monkeypatch.setattr(refit, "refitted_model", lambda rec, model: limit)
    out = refit.process_refit_check(d, wrong_tau, MODEL, lambda m: pytest.fail("rerun"))
    assert out.details["process_refit"]["valve_kept"] is None
    assert "search limit" in out.details["process_refit"]["reason"]
    assert "refit_warning" not in out.details

    monkeypatch.setattr(refit, "refitted_model", lambda rec, model: MODEL)

    def too_short(m):
        raise InputError("too short for the model's time scales")

    d = diagnose(wrong_tau, MODEL)
    out = refit.process_refit_check(d, wrong_tau, MODEL, too_short)
    assert out.details["process_refit"]["valve_kept"] is None
    assert "could not be diagnosed: too short" in out.details["process_refit"]["reason"]
    assert out.missing_physics == d.missing_physics


def test_process_refit_without_a_model_is_one_line_exit_2(tmp_path, wrong_tau, capsys):
    from stictionbench.cli import main
    from stictionbench.io import write_recording

    csv = write_recording(wrong_tau, tmp_path / "r.csv")
    out = tmp_path / "o.json"
    assert main(["diagnose", str(csv), "--process-refit", "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--process-refit needs --model" in err[0]
    assert not out.exists()


def test_a_refit_that_names_nothing_but_fits_worse_concludes_nothing(wrong_tau, monkeypatch):
    from dataclasses import replace

    from stictionbench.diagnosis import refit

    d = diagnose(wrong_tau, MODEL)
    monkeypatch.setattr(refit, "refitted_model", lambda rec, model: MODEL)
    worse = replace(d, missing_physics="none",
                    fit={**d.fit, "nominal": 3.0 * d.fit["improved"]}, details={})
    out = refit.process_refit_check(d, wrong_tau, MODEL, lambda m: worse)
    assert out.details["process_refit"]["valve_kept"] is None
    assert "fits the validation blocks worse" in out.details["process_refit"]["reason"]
    assert "refit_warning" not in out.details
