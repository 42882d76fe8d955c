"""Thomson's harmonic F-test (stictionbench.diagnosis.harmonic) and its use by diagnose."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from stictionbench.diagnosis.harmonic import harmonic_f, line_test


def _red(n: int, rng: np.random.Generator) -> np.ndarray:
    # a random walk through a first-order lag: the smooth, steep spectrum of a drifting
    # load on PV, plus white measurement noise
    walk = np.cumsum(rng.normal(size=n)) * 0.05
    return lfilter([0.1], [1, -0.9], walk) + rng.normal(size=n)


def test_single_frequency_statistic_is_f_distributed_under_white_noise():
    # at a fixed frequency the p-value of F(2, 2K-2) is uniform under H0: its 5 % tail
    # holds about 5 % of the draws
    rng = np.random.default_rng(1)
    ps = []
    for _ in range(400):
        f, _, p = harmonic_f(rng.normal(size=512), 1.0)
        ps.append(p[np.argmin(np.abs(f - 0.123))])
    rate = np.mean(np.asarray(ps) < 0.05)
    assert 0.025 < rate < 0.08


def test_finds_a_weak_line_at_its_frequency_in_red_noise():
    rng = np.random.default_rng(2)
    n, Ts, period = 3000, 1.0, 71.4
    t = np.arange(n) * Ts
    x = _red(n, rng) + 0.5 * np.sin(2 * np.pi * t / period + 0.3)
    lt = line_test(x, Ts, 1 / 600, 1 / 8)
    assert lt is not None and lt.p_value < 1e-3
    assert abs(lt.period_s - period) / period < 0.02
    assert lt.matches(period) and not lt.matches(period * 1.2)


def test_scan_is_conservative_on_red_noise_without_a_line():
    # the scan's Bonferroni-corrected p-value falls below 0.05 on at most about 5 % of
    # line-free series whose spectrum is steep at low frequency
    rng = np.random.default_rng(3)
    hits = sum(line_test(_red(2000, rng), 1.0, 1 / 500, 1 / 8).p_value < 0.05
               for _ in range(150))
    assert hits <= 8


def test_no_testable_frequency_gives_none():
    x = np.random.default_rng(4).normal(size=400)
    # the whole range lies within 2W of zero frequency
    assert line_test(x, 1.0, 1e-4, 5e-3) is None
    assert line_test(x[:10], 1.0, 0.01, 0.4) is None
    with pytest.raises(ValueError):
        harmonic_f(x[:10], 1.0)


def test_p_at_a_chosen_period_carries_the_scan_correction():
    rng = np.random.default_rng(6)
    n, period = 3000, 40.0
    x = _red(n, rng) + 0.6 * np.sin(2 * np.pi * np.arange(n) / period)
    lt = line_test(x, 1.0, 1 / 600, 1 / 8)
    assert lt.p_at(period) < 0.01
    # a frequency far from the line: no evidence there, and the correction applies
    assert lt.p_at(13.0) > 0.05
    assert lt.p_at(None) == 1.0 and lt.p_at(5000.0) == 1.0


def _with_line(amplitude: float):
    from fopdt_record import fopdt_record

    from stictionbench.recording import Recording

    rec, model = fopdt_record(load=0.02)
    pv = np.asarray(rec.PV) + amplitude * np.sin(2 * np.pi * np.asarray(rec.t) / 45.0)
    return Recording.from_arrays(np.asarray(rec.t), pv, np.asarray(rec.OP), warn=False), model


def test_diagnose_reports_the_line_and_waives_the_gate_only_on_it():
    from stictionbench.diagnosis import diagnose

    rec, model = _with_line(0.08)
    d = diagnose(rec, model, line_test=True, detectability=False)
    h = d.tests["harmonic_line"]
    assert abs(h["period_s"] - 45.0) < 2.0 and h["p_value"] < 0.05
    assert h["gate_waived"] == (h["p_at_fitted_period"] < 0.05)
    assert d.details["line_test"] is True
    off = diagnose(rec, model, detectability=False)
    assert "harmonic_line" not in off.tests and off.details["line_test"] is False
    # without a model there is no trusted residual to scan
    free = diagnose(rec, None, line_test=True, detectability=False)
    assert "harmonic_line" not in free.tests and free.details["line_test"] is False


def test_line_waiver_needs_the_fitted_period_on_a_significant_line():
    from types import SimpleNamespace

    from stictionbench.diagnosis.diagnose import line_waiver

    rng = np.random.default_rng(7)
    x = _red(3000, rng) + 0.6 * np.sin(2 * np.pi * np.arange(3000) / 40.0)
    lt = line_test(x, 1.0, 1 / 600, 1 / 8)
    fits = {"oscillatory_disturbance": SimpleNamespace(params={"period": 40.0})}
    assert line_waiver(lt, fits, 0.05) == {"oscillatory_disturbance"}
    fits_off = {"oscillatory_disturbance": SimpleNamespace(params={"period": 13.0})}
    assert line_waiver(lt, fits_off, 0.05) == frozenset()
    assert line_waiver(None, fits, 0.05) == frozenset()
    assert line_waiver(lt, {}, 0.05) == frozenset()


def test_the_command_takes_the_line_test_and_refuses_it_without_a_model(tmp_path, capsys):
    import json

    from fopdt_record import write_files

    from stictionbench.cli import main

    csv, model = write_files(_with_line(0.08)[0], tmp_path)
    out = tmp_path / "d.json"
    assert main(["diagnose", str(csv), "--model", str(model), "--json", str(out),
                 "--line-test"]) == 0
    payload = json.loads(out.read_text())
    assert payload["tests"]["harmonic_line"]["method"] == "thomson_harmonic_f"
    capsys.readouterr()
    bad = tmp_path / "bad.json"
    assert main(["diagnose", str(csv), "--json", str(bad), "--line-test"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--line-test" in err[0] and not bad.exists()
