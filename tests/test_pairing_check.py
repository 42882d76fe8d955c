"""The pairing check: Haugh's independence test of OP and PV (noise.series_independence)
and the diagnosis's answer where OP does not drive PV (routes.pairing_answer)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

import stictionbench as sb
from stictionbench.diagnosis import diagnose
from stictionbench.diagnosis.model import NominalModel
from stictionbench.diagnosis.noise import series_independence
from stictionbench.diagnosis.result import Diagnosis
from stictionbench.diagnosis.routes import pairing_answer, pairing_test


def _independent(seed: int, n: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """A coloured PV (AR(1), φ 0.9) and a drifting OP (random walk), independent."""
    rng = np.random.default_rng(seed)
    return (lfilter([1.0], [1.0, -0.9], rng.normal(size=n)),
            50 + np.cumsum(0.3 * rng.normal(size=n)))


def test_size_on_independent_coloured_series():
    """Pre-whitened by their own noise models, independent coloured and drifting series
    are rejected at about the test's level (5 %), not at the rate raw cross-correlations
    of such series give."""
    p = np.array([series_independence(*_independent(s))["p_value"] for s in range(40)])
    assert np.mean(p < 0.05) <= 0.15


def test_a_closed_loop_is_dependent_and_a_delay_is_located():
    rec = sb.simulate("linear", duration=2000.0, seed=1, sample_time=1.0)
    t = series_independence(rec.PV, rec.OP)
    assert t["p_value"] < 1e-10 and 9 <= t["peak_lag"] <= 12  # the paper's 10 s dead time
    rng = np.random.default_rng(2)
    u = rng.normal(size=3000)
    y = 0.4 * np.concatenate([np.zeros(30), u[:-30]]) + rng.normal(size=3000)
    t = series_independence(y, u)
    assert t["p_value"] < 1e-6 and t["peak_lag"] == 30  # OP leads PV by 30 samples


def _named(tests: dict) -> Diagnosis:
    return Diagnosis(True, "stiction", {"S": 2.0, "J": 1.0}, {"nominal": 0.8, "improved": 0.5},
                     [], [], [], NominalModel(1.0, 10.0, 1.0), {"S": [1.0, 3.0]},
                     tests=tests)


def test_pairing_answer_holds_back_only_where_independent():
    d = pairing_answer(_named({"op_pv_dependence": {"p_value": 0.3, "independent": True}}),
                       0.05)
    assert d.missing_physics == "none" and d.parameters == {} and d.uncertainty == {}
    assert d.fit["improved"] == 0.8
    held = d.details["op_pv_independent"]
    assert held["named_before"] == "stiction" and held["parameters_before"]["S"] == 2.0
    assert d.details["decided_by"] == "op_pv_independent"
    kept = pairing_answer(_named({"op_pv_dependence": {"p_value": 1e-9,
                                                       "independent": False}}), 0.05)
    assert kept.missing_physics == "stiction"
    limit = pairing_answer(_named({"op_pv_dependence": {"p_value": 0.3, "independent": True},
                                   "op_held_at_limit": {"named": True}}), 0.05)
    assert limit.missing_physics == "stiction"  # read off OP itself


@pytest.mark.parametrize("seed", [0, 1])
def test_diagnose_reports_the_test_and_the_check_holds_back(seed):
    y, u = _independent(seed, 3000)
    rec = sb.Recording.from_arrays(np.arange(3000.0), y, u, warn=False)
    off = diagnose(rec)
    t = off.tests["op_pv_dependence"]
    assert set(t) >= {"statistic", "p_value", "lags", "peak_lag", "independent"}
    on = diagnose(rec, pairing_check=True)
    if t["independent"]:
        assert "check the tags" in off.details["pairing_warning"]
        assert on.missing_physics == "none"
        if off.missing_physics != "none":
            assert on.details["op_pv_independent"]["named_before"] == off.missing_physics
    else:
        assert on.missing_physics == off.missing_physics


def test_pairing_test_warning_names_the_p_value():
    y, u = _independent(3)
    rec = sb.Recording.from_arrays(np.arange(y.size, dtype=float), y, u, warn=False)
    t = pairing_test(rec, 0.05)
    assert t["independent"] == (t["p_value"] >= 0.05)
    assert ("warning" in t) == t["independent"]
    if t["independent"]:
        assert f"p = {t['p_value']:.2g}" in t["warning"]


def test_cli_flag_and_warning(tmp_path, capsys):
    import json

    from stictionbench.cli import main
    from stictionbench.io import write_recording

    y, u = _independent(0, 3000)
    rec = sb.Recording.from_arrays(np.arange(3000.0), y, u, warn=False)
    csv = write_recording(rec, tmp_path / "wrong_tag.csv")
    out = tmp_path / "o.json"
    assert main(["diagnose", str(csv), "--pairing-check", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    t = res["tests"]["op_pv_dependence"]
    assert t["independent"] is True and res["missing_physics"] == "none"
    err = capsys.readouterr().err
    assert "check the tags" in err and "frozen transmitter" in err


def test_screen_warns_on_an_independent_pair_only():
    from stictionbench.realdata.quality import screen

    y, u = _independent(0, 3000)
    rep = screen(sb.Recording.from_arrays(np.arange(3000.0), y, u, warn=False))
    assert rep.usable and rep.flags["op_pv_independence_p"] >= 0.05
    assert any("OP and PV independent" in w for w in rep.warnings)
    loop = screen(sb.simulate("linear", duration=2000.0, seed=1, sample_time=1.0))
    assert loop.flags["op_pv_independence_p"] < 1e-10
    assert not any("independent" in w for w in loop.warnings)


def test_the_lags_reach_the_loops_dead_time():
    """The paper's sticky loop recorded for 600 s at its 0.1 s sampling: OP reaches PV
    100 samples later. The fixed ±50-sample window cannot reject independence there
    (p = 1), so ``--pairing-check`` turned the named stiction into ``none``; the windows
    reaching (θ + 2τ)/Ts reject it, with the model given and with the one identified."""
    r = sb.simulate("stiction", duration=600.0, seed=0)
    rec = sb.Recording.from_arrays(r.t, r.PV, r.OP, SP=r.SP, warn=False)
    assert series_independence(rec.PV, rec.OP)["p_value"] > 0.5  # the fixed window
    t = pairing_test(rec, 0.05, dead_time=10.0, time_constant=10.0)
    assert t["windows"] == [50, 100, 200, 300] and not t["independent"]
    d = diagnose(rec, NominalModel(3.0, 10.0, 10.0, kc=0.2, ti=10.0), pairing_check=True)
    assert not d.tests["op_pv_dependence"]["independent"]
    assert d.missing_physics == "stiction"
    assert not diagnose(rec).tests["op_pv_dependence"]["independent"]
