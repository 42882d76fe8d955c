"""Inputs that once ended in a traceback or a hang: each now gets one clear error (exit 2
through the CLI) or is skipped with its reason."""

from __future__ import annotations

import os
import sys

import numpy as np
import pandas as pd
import pytest
from pi_loop import velocity_pi_loop

from stictionbench.cli import main
from stictionbench.diagnosis import diagnose
from stictionbench.diagnosis.model import load_model
from stictionbench.diagnosis.slip_bootstrap import MAX_B, check_request
from stictionbench.errors import InputError
from stictionbench.io import read_recording, write_recording
from stictionbench.realdata.consensus import Consensus
from stictionbench.realdata.datasets import load_csv_dir


def _loop(n: int = 600):
    rng = np.random.default_rng(1)
    sp = np.full(n, 50.0)
    sp[200:] = 55.0
    return velocity_pi_loop(sp, 2.0, 10.0, 2.0, 0.4, 10.0, np.zeros(n),
                            0.1 * rng.standard_normal(n), op0=25.0)


MODEL = "process: {gain: 2.0, time_constant: 10.0, dead_time: 2.0}\n" \
        "controller: {kc: 0.4, ti: 10.0}\nsample_time: 1.0\n"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes (POSIX)")
def test_a_named_pipe_in_a_folder_is_skipped_not_read(tmp_path):
    write_recording(_loop(), tmp_path / "good.csv")
    os.mkfifo(tmp_path / "pipe.csv")  # reading it would block forever
    recs, skipped = load_csv_dir(tmp_path, labels=False, warn=False)
    assert list(recs) == ["good"]
    assert skipped == [("pipe.csv", "not a regular file")]


def test_a_pv_too_small_for_the_arithmetic_is_refused(tmp_path):
    rec = _loop()
    tiny = type(rec).from_arrays(rec.t, rec.PV * 1e-200, rec.OP, SP=rec.SP * 1e-200)
    with pytest.raises(InputError, match="too little for the diagnosis's arithmetic"):
        diagnose(tiny)


def test_an_integer_beyond_a_float_in_the_model_is_one_error(tmp_path):
    p = tmp_path / "m.yaml"
    p.write_text(MODEL.replace("gain: 2.0", "gain: " + "9" * 400))
    with pytest.raises(InputError, match="process.gain: must be finite"):
        load_model(p)


def test_bootstrap_requests_are_checked_before_any_fitting():
    rec = _loop()
    model = type("M", (), {"kc": 0.4, "ti": 10.0})()
    with pytest.raises(InputError, match="--bootstrap-seed"):
        check_request(rec, model, 19, seed=-1)
    with pytest.raises(InputError, match=f"at most {MAX_B}"):
        check_request(rec, model, MAX_B + 1)
    check_request(rec, model, 19, seed=0)


def test_cli_bad_bootstrap_seed_is_one_line_exit_2(tmp_path, capsys):
    write_recording(_loop(), tmp_path / "r.csv")
    (tmp_path / "m.yaml").write_text(MODEL)
    rc = main(["diagnose", str(tmp_path / "r.csv"), "--model", str(tmp_path / "m.yaml"),
               "--slip-jump-bootstrap", "19", "--bootstrap-seed", "-5",
               "--json", str(tmp_path / "o.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--bootstrap-seed" in err[0]
    assert not (tmp_path / "o.json").exists()


@pytest.mark.parametrize("text, what", [
    ("methods: [horch, nope]\nthreshold: 0.5\nmin_votes: 1\n", "unknown: nope"),
    ("methods: []\nthreshold: 0.5\nmin_votes: 1\n", "none given"),
    ("methods: [horch]\nthreshold: 2\nmin_votes: 1\n", "in \\(0, 1\\]"),
    ("methods: [horch]\nthreshold: .nan\nmin_votes: 1\n", "in \\(0, 1\\]"),
    ("methods: [horch]\nthreshold: 0.5\nmin_votes: 0\n", "at least 1"),
    ("threshold: 0.5\nmin_votes: 1\n", "no 'methods' key"),
])
def test_a_consensus_file_is_checked(tmp_path, text, what):
    p = tmp_path / "c.yaml"
    p.write_text(text)
    with pytest.raises(InputError, match=what):
        Consensus.load(p)


def test_the_shipped_consensus_loads():
    assert Consensus.load().methods


@pytest.mark.skipif("pyarrow" not in sys.modules and
                    __import__("importlib").util.find_spec("pyarrow") is None,
                    reason="needs pyarrow for Parquet")
def test_parquet_durations_are_seconds(tmp_path):
    rec = _loop()
    frame = pd.DataFrame({"t": pd.to_timedelta(rec.t, unit="s"), "PV": rec.PV,
                          "OP": rec.OP, "SP": rec.SP})
    frame.to_parquet(tmp_path / "r.parquet", index=False)
    back = read_recording(tmp_path / "r.parquet", warn=False)
    assert np.allclose(back.t, rec.t)


def test_a_folder_with_no_usable_recording_says_why(tmp_path):
    from stictionbench.realdata.batch import run_batch

    write_recording(_loop(), tmp_path / "short.csv")
    (tmp_path / "short.csv").write_text(
        "\n".join((tmp_path / "short.csv").read_text().splitlines()[:40]) + "\n")
    with pytest.raises(InputError, match="no usable recordings.*short.csv"):
        run_batch(str(tmp_path), None)


def test_seeds_are_whole_numbers_everywhere(tmp_path, capsys):
    from stictionbench.validation import whole_number

    assert whole_number("seed", "3") == 3 and whole_number("seed", 3.0) == 3
    for bad in ("1.5", 1.5, "abc", True, -1, float("nan")):
        with pytest.raises(InputError, match="seed"):
            whole_number("seed", bad)
    assert main(["simulate", "seed=1.5", f"out={tmp_path / 's.csv'}"]) == 2
    assert "not an integer" in capsys.readouterr().err
    assert not (tmp_path / "s.csv").exists()


def test_a_long_gap_at_the_start_is_said(tmp_path, capsys):
    from stictionbench.io import read_longest_stretch

    rec = _loop()
    frame = rec.to_frame()
    frame.loc[: 99, "PV"] = np.nan                       # 100 empty rows before the data
    frame.to_csv(tmp_path / "r.csv", index=False)
    got = read_longest_stretch(tmp_path / "r.csv")
    err = capsys.readouterr().err
    assert len(got) == len(frame) - 100
    assert "using rows 102–" in err and "gap of more than" in err


def test_compare_says_which_labelled_loop_it_left_out(tmp_path, capsys):
    from stictionbench.realdata.comparison import load_folder

    write_recording(_loop(), tmp_path / "good.csv")
    write_recording(_loop(), tmp_path / "fine.csv")
    (tmp_path / "bad.csv").write_text("t,PV,OP\n0,abc,1\n1,2,3\n")
    (tmp_path / "labels.csv").write_text("loop,label\ngood,stiction\nbad,no_stiction\n"
                                         "fine,no_stiction\n")
    assert list(load_folder(tmp_path)) == ["fine", "good"]
    err = capsys.readouterr().err
    assert "1 labelled loop(s) left out" in err and "bad.csv" in err


@pytest.mark.parametrize("reps", ["-3", "x"])
def test_null_reps_is_a_count(tmp_path, capsys, reps):
    assert main(["oscillation-benchmark", "--null-reps", reps, "--out", str(tmp_path / "o")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_estimate_names_an_unknown_signal_first(tmp_path, capsys):
    write_recording(_loop(), tmp_path / "r.csv")
    assert main(["estimate", str(tmp_path / "r.csv"), "--method", "xcorr", "--x", "ZZ"]) == 2
    assert "unknown signal 'ZZ'" in capsys.readouterr().err


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs named pipes (POSIX)")
def test_a_pipe_or_a_folder_where_a_file_belongs_is_named_for_what_it_is(tmp_path, capsys):
    """A named pipe given as the recording is refused as not a regular file (a first
    version called it an empty file), and a folder given as the model as a folder (was
    'no such model file')."""
    os.mkfifo(tmp_path / "pipe.csv")
    assert main(["estimate", str(tmp_path / "pipe.csv"), "--method", "horch"]) == 2
    assert "pipe.csv: not a regular file, expected a recording file" in \
        capsys.readouterr().err
    write_recording(_loop(), tmp_path / "r.csv")
    assert main(["diagnose", str(tmp_path / "r.csv"), "--model", str(tmp_path), "--json",
                 str(tmp_path / "o.json")]) == 2
    assert "is a directory, expected a model YAML file" in capsys.readouterr().err


def test_a_param_given_twice_is_refused(tmp_path, capsys):
    """``--param k=1 --param k=2`` kept the last value silently; which was meant?"""
    write_recording(_loop(), tmp_path / "r.csv")
    assert main(["estimate", str(tmp_path / "r.csv"), "--method", "xcorr", "--param",
                 "max_delay=10", "--param", "max_delay=20"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--param max_delay given twice (10 and 20)" in err[0]


def test_the_time_column_is_not_a_signal_to_estimate_on(tmp_path, capsys):
    """``--x t`` ran the estimator on the time stamps; it is refused in one line."""
    write_recording(_loop(), tmp_path / "r.csv")
    assert main(["estimate", str(tmp_path / "r.csv"), "--method", "xcorr", "--x", "t",
                 "--y", "PV"]) == 2
    assert "t is the time column, not a signal" in capsys.readouterr().err


def test_a_long_step_response_is_fitted_by_knots_with_the_exact_fits_decision():
    """Beyond MAX_RESPONSE_TAPS taps the gate's step response is a piecewise-linear
    curve (the dense fit of every tap took 20-28 s and 1.1 GB on the README's tour
    recording); on a window where both fit, they leave residuals of about the same
    size and the same oscillation answer."""
    from scipy.linalg import lstsq, toeplitz

    from stictionbench.estimators import detector
    from stictionbench.recording import Recording

    rng = np.random.default_rng(0)
    n, length = 4000, 1300
    k = np.arange(n)
    sp = 50.0 + 5.0 * (k >= 500) - 8.0 * (k >= 2100) + 4.0 * (k >= 3300)
    lag = np.arange(1300)
    ring = np.exp(-lag / 300) * np.cos(2 * np.pi * lag / 420)
    e = np.convolve(np.r_[0, np.diff(sp)], ring)[:n] + 0.3 * np.sin(2 * np.pi * k / 150) \
        + 0.05 * rng.standard_normal(n)
    rec = Recording.from_arrays(k * 1.0, sp - e, np.zeros(n), SP=sp, warn=False)
    assert length > detector.MAX_RESPONSE_TAPS
    detector._RESIDUAL[0] = None
    ours = detector.setpoint_residual(e, rec, length)
    d = np.r_[0.0, np.diff(sp)]
    design = np.column_stack([np.ones(n), toeplitz(d, np.zeros(length))])
    exact = e - design @ lstsq(design, e, lapack_driver="gelsy")[0]
    assert abs(np.var(ours) - np.var(exact)) < 0.05 * np.var(e)
    assert detector.oscillation(ours).oscillating == detector.oscillation(exact).oscillating


def test_a_model_built_in_python_meets_the_yaml_rules():
    """diagnose() took any NominalModel as built: a gain of 0 or NaN gave the same
    confident verdict as the true one, a time constant of 0 a ZeroDivisionError."""
    from stictionbench.diagnosis.model import NominalModel

    rec = _loop()
    for model, what in ((NominalModel(float("nan"), 10.0, 1.0), "gain: must be finite"),
                        (NominalModel(0.0, 10.0, 1.0), "gain: must not be zero"),
                        (NominalModel(1.0, 0.0, 1.0), "time_constant: must be positive"),
                        (NominalModel(1.0, 10.0, 1.0, 0.5, -3.0), "ti: must be positive"),
                        ({"gain": 1.0}, "expected a NominalModel")):
        with pytest.raises(InputError, match=what):
            diagnose(rec, model)
    with pytest.raises(InputError, match="alpha"):
        diagnose(rec, alpha=2.0)


def test_a_recording_needs_t_pv_and_op():
    from stictionbench.recording import Recording

    t = np.arange(300.0)
    with pytest.raises(InputError, match="column PV is required"):
        Recording.from_arrays(t, None, np.cos(t))
    with pytest.raises(InputError, match="column t is required"):
        Recording.from_arrays(None, t, t)


def test_simulate_takes_numpy_numbers_and_refuses_what_cannot_be_held():
    import stictionbench as sb

    assert len(sb.simulate(duration=np.float64(300.0), seed=np.int64(4))) == 3001
    with pytest.raises(InputError, match="at most 1e\\+07 are simulated"):
        sb.simulate(duration=1e12)
    with pytest.raises(InputError, match="too fine"):
        sb.simulate(duration=300.0, dt=1e-12)
    rec = sb.simulate(duration=300.0, overrides="valve=kano")  # one override, not letters
    assert rec.meta["config"]["valve"]["_target_"].endswith("KanoValve")


def test_sweep_estimator_parameters_as_the_readme_writes_them(tmp_path):
    """estimators.in_seconds.max_delay=30 and estimators.params.xcorr.max_delay=20 were
    refused as unknown keys unless prefixed with '+'; a window in seconds that is not a
    number is refused before any run."""
    from stictionbench.sweep.plan import make_plan

    plan = make_plan("smoke", ["limit=1", "estimators.in_seconds.max_delay=30",
                               "estimators.params.xcorr.max_delay=20"])
    est = plan.runs[0].spec["estimators"]
    assert est["in_seconds"]["max_delay"] == 30 and est["params"]["xcorr"]["max_delay"] == 20
    with pytest.raises(InputError, match="estimators.in_seconds.max_delay: not a number"):
        make_plan("smoke", ["limit=1", "estimators.in_seconds.max_delay=abc"])
