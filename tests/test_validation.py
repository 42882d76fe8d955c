"""Boundary checks: declared estimator parameters, outputs that would destroy inputs,
the Hydra-style estimator choice; each bad input is one line and exit 2."""

from __future__ import annotations

import json
import os
from numbers import Integral, Real

import pytest

from stictionbench.cli import main
from stictionbench.errors import InputError
from stictionbench.estimators import available, make
from stictionbench.validation import (
    Band,
    Interval,
    Options,
    TypeOf,
    jsonable,
    refuse_overwrite,
    validate_params,
)

BUILTIN = ("xcorr", "xcum", "bicoherence", "oscillation", "ellipse", "horch", "he", "area_ratio",
           "kano", "yamashita", "hagglund")


@pytest.fixture(scope="module")
def rec_path(tmp_path_factory):
    import stictionbench as sb
    from stictionbench.io import write_recording

    rec = sb.simulate("stiction", duration=600.0, seed=0, sample_time=1.0)
    return write_recording(rec, tmp_path_factory.mktemp("rec") / "rec.csv")


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("stictionbench: error:") and err.count("\n") == 1, err
    return err


def test_interval_and_options():
    i = Interval(Integral, 1, None)
    assert i.accepts(3) and not i.accepts(0) and not i.accepts(2.0) and not i.accepts(True)
    r = Interval(Real, 0, 1, closed="neither")
    assert r.accepts(0.5) and r.accepts(1) is False and not r.accepts(float("nan"))
    assert Options(("hann", "boxcar")).accepts("hann") and not Options(("a",)).accepts("b")
    assert TypeOf(bool).accepts(False) and not TypeOf(int).accepts(True)
    assert Band(0, 0.5).accepts([0.1, 0.2]) and not Band(0, 0.5).accepts([0.2, 0.1])
    assert not Band(0, 0.5).accepts([0.1]) and not Band(0, 0.5).accepts("ab")


def test_validate_params_names_parameter_and_range():
    c = {"nfft": [Interval(Integral, 8, None)], "window": [Options(("hann",))]}
    validate_params("bic", c, {"nfft": 64, "window": "hann", "other": object()})
    with pytest.raises(InputError, match=r"bic: parameter nfft must be an integer in \[8, inf\)"):
        validate_params("bic", c, {"nfft": 4})


@pytest.mark.parametrize("name", BUILTIN)
def test_every_builtin_declares_every_parameter(name):
    est = make(name)
    assert set(est._parameter_constraints) == set(est.param_names())
    est.check_params()  # the defaults satisfy their own declarations


@pytest.mark.parametrize("name, key, bad", [
    ("xcorr", "threshold", "abc"), ("xcorr", "max_delay", 0), ("xcorr", "overlap", 150),
    ("xcum", "max_delay", 2.5), ("bicoherence", "alpha", 1.5),
    ("bicoherence", "window", "hamming"), ("oscillation", "band", [0.3, 0.1]),
    ("ellipse", "order", "two"),
])
def test_bad_parameter_is_one_line_exit_2(rec_path, tmp_path, capsys, name, key, bad):
    out = tmp_path / "o.json"
    args = ["estimate", str(rec_path), "--method", name, "--param", f"{key}={bad}",
            "--json", str(out)]
    assert main(args) == 2
    err = _one_line_error(capsys)
    assert f"parameter {key} must be" in err and repr(bad) in err
    assert not out.exists()


def test_estimate_checks_parameters_set_after_construction(rec_path):
    import stictionbench as sb

    est = make("xcorr")
    est.threshold = "abc"
    with pytest.raises(InputError, match="parameter threshold"):
        est.estimate(sb.io.read_recording(rec_path))


def test_output_onto_input_is_refused(rec_path, capsys):
    before = rec_path.read_bytes()
    args = ["estimate", str(rec_path), "--method", "xcorr", "--x", "OP", "--y", "MV",
            "--json", str(rec_path)]
    assert main(args) == 2
    assert "refusing to overwrite" in _one_line_error(capsys)
    assert rec_path.read_bytes() == before


def test_output_onto_input_through_a_link_is_refused(rec_path, tmp_path, capsys):
    link = tmp_path / "alias.json"
    os.link(rec_path, link)
    assert main(["estimate", str(rec_path), "--method", "xcorr", "--json", str(link)]) == 2
    assert "refusing to overwrite" in _one_line_error(capsys)


def test_refuse_overwrite_directory_rules(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    (data / "loop.csv").write_text("t\n")
    refuse_overwrite([data / "new.json"], [data])          # a new file is fine
    with pytest.raises(InputError, match="data file inside the input directory"):
        refuse_overwrite([data / "loop.csv"], [data])
    with pytest.raises(InputError, match="input directory"):
        refuse_overwrite([data], [data])
    with pytest.raises(InputError, match="named twice"):
        refuse_overwrite([tmp_path / "a.json", tmp_path / "." / "a.json"], [])


def test_diagnose_refuses_json_onto_recording(rec_path, capsys):
    before = rec_path.read_bytes()
    assert main(["diagnose", str(rec_path), "--json", str(rec_path)]) == 2
    assert "refusing to overwrite" in _one_line_error(capsys)
    assert rec_path.read_bytes() == before


def test_hydra_style_estimator(rec_path, tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    assert main(["estimate", str(rec_path), "estimator=xcum", "estimator.max_delay=50",
                 "--json", str(a)]) == 0
    assert main(["estimate", str(rec_path), "--method", "xcum", "--param", "max_delay=50",
                 "--json", str(b)]) == 0
    ja, jb = json.loads(a.read_text()), json.loads(b.read_text())
    assert ja["estimator"] == jb["estimator"] and "max_delay=50" in ja["estimator"]
    assert ja["value"] == jb["value"]


@pytest.mark.parametrize("args, needle", [
    (["estimator=nope"], "unknown estimator 'nope'"),
    (["estimator=xcum", "estimator.bogus=1"], "unknown config key"),
    (["estimator=xcum", "estimator.max_delay=abc"], "parameter max_delay must be"),
    (["estimator=xcum", "--method", "xcorr"], "either --method"),
    ([], "name the estimator"),
])
def test_hydra_style_estimator_bad_input(rec_path, capsys, args, needle):
    assert main(["estimate", str(rec_path), *args]) == 2
    assert needle in _one_line_error(capsys)


def test_every_registered_estimator_has_a_config_usable_by_estimate():
    from stictionbench.estimators.command import from_config

    for name in available():
        if name == "peak_lag":  # the test plug-in, when installed
            continue
        est = from_config([f"estimator={name}"])
        assert est.name == name


def test_jsonable_cleans_numpy_and_non_finite():
    import numpy as np

    out = jsonable({"x": np.float32(0.5), "y": (np.inf, 1), "z": {"w": np.int8(3)}})
    assert out == {"x": 0.5, "y": [None, 1], "z": {"w": 3}}
    json.dumps(out, allow_nan=False)
