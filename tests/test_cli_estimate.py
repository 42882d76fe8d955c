"""The estimate command: JSON output, the table on stdout, bad input with exit 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hydra.utils import instantiate
from omegaconf import OmegaConf

from stictionbench import Recording
from stictionbench.cli import main
from stictionbench.config import conf_dir
from stictionbench.estimators import available
from stictionbench.io import write_recording


@pytest.fixture
def rec_path(tmp_path):
    import stictionbench as sb

    rec = sb.simulate("stiction", duration=2000.0, seed=0, sample_time=1.0)
    return write_recording(rec, tmp_path / "stiction.csv")


@pytest.mark.parametrize("method, x, y", [("xcorr", "OP", "MV"), ("xcum", "OP", "MV"),
                                          ("bicoherence", "PV", None),
                                          ("oscillation", "PV", None), ("ellipse", "OP", "PV")])
def test_estimate_json_and_table(rec_path, tmp_path, capsys, method, x, y):
    out = tmp_path / f"{method}.json"
    args = ["estimate", str(rec_path), "--method", method, "--x", x, "--json", str(out)]
    if y:
        args += ["--y", y]
    assert main(args) == 0
    res = json.loads(out.read_text())
    assert res["method"] == method and "value" in res and "diagnostics" in res
    first = capsys.readouterr().out.splitlines()[0].split()
    assert first == ["method", method]


def test_stiction_cumulant_delay_is_flagged_not_reported_as_a_delay(rec_path, tmp_path):
    """On the stiction limit cycle CO is nearly symmetric: tde's lag is an artefact of a
    near-singular solve that moves with the window. It must be flagged, and no call made."""
    out = tmp_path / "x.json"
    assert main(["estimate", str(rec_path), "--method", "xcum", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    d = res["diagnostics"]
    assert d["condition_number"] > 1e9
    assert d["unstable"] is True and res["decision"] is None
    assert d["wide_delay"] != res["value"] or d["tsvd_delay"] != res["value"]


@pytest.mark.parametrize("args, needle", [
    (["--method", "nope"], "unknown estimator 'nope'"),
    (["--method", "xcorr", "--param", "bogus=1"], "unknown parameter(s) bogus"),
    (["--method", "xcorr", "--y", "XX"], "unknown signal 'XX'"),
])
def test_estimate_bad_arguments(rec_path, tmp_path, capsys, args, needle):
    out = tmp_path / "o.json"
    assert main(["estimate", str(rec_path), *args, "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1
    assert not out.exists()


def test_estimate_constant_and_missing_signal(tmp_path, capsys):
    t = np.arange(500.0)
    rec = Recording.from_arrays(t, np.sin(t / 10), np.sin(t / 10), MV=np.ones_like(t))
    p = write_recording(rec, tmp_path / "c.csv")
    assert main(["estimate", str(p), "--method", "xcorr"]) == 2
    assert "constant" in capsys.readouterr().err
    rec2 = Recording.from_arrays(t, np.sin(t / 10), np.sin(t / 10))
    p2 = write_recording(rec2, tmp_path / "nomv.csv")
    assert main(["estimate", str(p2), "--method", "xcum"]) == 2
    err = capsys.readouterr().err
    assert "MV is not recorded" in err and "horch" in err and err.count("\n") == 1


def test_estimate_bad_file(tmp_path, capsys):
    assert main(["estimate", str(tmp_path / "missing.csv"), "--method", "xcorr"]) == 2
    assert "no such file" in capsys.readouterr().err


def test_every_estimator_has_a_hydra_config():
    for name in available():
        if name == "peak_lag":  # the test plug-in, when installed
            continue
        cfg = OmegaConf.load(conf_dir() / "estimator" / f"{name}.yaml")
        est = instantiate(cfg)
        assert est.name == name
        assert set(est.get_params()) == set(cfg) - {"_target_"}


def test_estimate_kano_reads_pv_for_mv_on_a_flow_loop(tmp_path, capsys):
    """Without MV, Kano refuses (and says how: flow_loop=true); with it, PV stands in and
    the slip check can be asked for; a method without that parameter is not offered it."""
    rng = np.random.default_rng(0)
    t = np.arange(1000.0)
    op = 50 + np.cumsum(rng.normal(0, 0.5, t.size))
    pv = np.round(op / 4) * 4 + rng.normal(0, 0.01, t.size)   # a valve moving in steps
    p = write_recording(Recording.from_arrays(t, pv, op), tmp_path / "flow.csv")
    assert main(["estimate", str(p), "--method", "kano"]) == 2
    assert "flow_loop=true" in capsys.readouterr().err
    assert main(["estimate", str(p), "--method", "xcorr"]) == 2
    assert "flow_loop" not in capsys.readouterr().err
    out = tmp_path / "k.json"
    assert main(["estimate", str(p), "--method", "kano", "--param", "flow_loop=true",
                 "--param", "slip_exit=true", "--json", str(out)]) == 0
    d = json.loads(out.read_text())["diagnostics"]
    assert d["valve"] == "PV" and d["slip_exit"] is True and "direction" in d
