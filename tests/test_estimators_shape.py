"""Shape-based estimators: ACF oscillation, bicoherence NGI/NLI, ellipse apparent stiction."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import lfilter

from stictionbench.errors import InputError
from stictionbench.estimators import make
from stictionbench.estimators.bicoherence import (
    Bicoherence,
    kim_powers_bicoherence,
    nonlinearity_indices,
)
from stictionbench.estimators.ellipse import Ellipse, apparent_stiction, fit_ellipse
from stictionbench.estimators.oscillation import Oscillation, acf_oscillation, bandpass
from stictionbench.recording import Recording

N = 4096


def _rec(pv: np.ndarray, op: np.ndarray | None = None, Ts: float = 1.0) -> Recording:
    op = pv if op is None else op
    t = np.arange(pv.size) * Ts
    return Recording.from_arrays(t, pv, op, warn=False)


def _ar1(seed: int, n: int = N, a: float = 0.8) -> np.ndarray:
    e = np.random.default_rng(seed).standard_normal(n + 200)
    x = lfilter([1.0], [1.0, -a], e)[200:]
    return x / x.std()


# --------------------------------------------------------------------------- oscillation
def test_noisy_sinusoid_period_and_regularity():
    rng = np.random.default_rng(1)
    n = np.arange(3000)
    Ts = 0.5
    pv = np.sin(2 * np.pi * n / 50.0) + 0.5 * rng.standard_normal(n.size)
    res = Oscillation().estimate(_rec(pv, Ts=Ts))
    assert res.decision is True
    assert res.units == "s"
    assert res.value == pytest.approx(50.0 * Ts, rel=0.02)
    assert res.diagnostics["period_samples"] == pytest.approx(50.0, rel=0.02)
    assert res.diagnostics["regularity"] > 1.0
    assert res.diagnostics["n_crossings"] == 10
    assert 0.3 < res.diagnostics["acf_decay"] <= 1.05


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_white_noise_not_oscillating(seed):
    pv = np.random.default_rng(seed).standard_normal(3000)
    res = Oscillation().estimate(_rec(pv))
    assert res.decision is False
    assert res.diagnostics["regularity"] < 1.0


def test_gaussian_ar_not_oscillating():
    res = acf_oscillation(_ar1(3, a=0.9))
    assert not res.oscillating
    assert res.regularity < 1.0


def test_too_few_crossings_gives_nan():
    n = np.arange(400)
    pv = np.sin(2 * np.pi * n / 1000.0) + 0.01 * n  # far less than one period, on a ramp
    res = Oscillation().estimate(_rec(pv))
    assert res.decision is False
    assert math.isnan(res.value)


def test_band_pass_before_acf_rejects_slow_drift():
    n = np.arange(4000)
    x = np.sin(2 * np.pi * n / 40.0) + 3.0 * np.sin(2 * np.pi * n / 1500.0)
    res = acf_oscillation(x, band=(0.01, 0.05))
    assert res.oscillating
    assert res.period_samples == pytest.approx(40.0, rel=0.02)


def test_bandpass_rejects_bad_band():
    with pytest.raises(InputError):
        bandpass(np.ones(100), (0.3, 0.2))


# --------------------------------------------------------------------------- bicoherence
def test_kim_powers_shape_domain_and_range():
    bic2, freqs, K = kim_powers_bicoherence(_ar1(0), nfft=64, overlap=50)
    assert bic2.shape == (33, 33)
    assert freqs[1] == pytest.approx(1 / 64)
    assert K == (N - 32) // 32
    k, l = np.nonzero(np.isfinite(bic2))
    assert np.all((l >= 1) & (l <= k) & (k + l <= 32))
    assert np.isnan(bic2[0, 0]) and np.isnan(bic2[5, 6]) and np.isnan(bic2[30, 5])
    vals = bic2[np.isfinite(bic2)]
    assert vals.size == k.size and np.all((vals >= 0) & (vals <= 1 + 1e-12))


def test_kim_powers_detects_quadratic_phase_coupling():
    rng = np.random.default_rng(5)
    n = np.arange(N)
    p1, p2 = rng.uniform(0, 2 * np.pi, 2)
    f1, f2 = 12 / 128, 20 / 128  # on bins 12 and 20 of a 128-point FFT
    x = (np.cos(2 * np.pi * f1 * n + p1) + np.cos(2 * np.pi * f2 * n + p2)
         + 0.5 * np.cos(2 * np.pi * (f1 + f2) * n + p1 + p2)
         + 0.5 * rng.standard_normal(N))
    bic2, freqs, K = kim_powers_bicoherence(x)
    assert np.unravel_index(np.nanargmax(bic2), bic2.shape) == (20, 12)
    assert np.nanmax(bic2) > 0.9


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gaussian_ar_is_linear(seed):
    res = Bicoherence().estimate(_rec(_ar1(seed)))
    assert res.decision is False
    assert res.diagnostics["ngi"] < 0.001
    assert res.diagnostics["k_segments"] == 63
    assert res.diagnostics["bic2_threshold"] == pytest.approx(5.9915 / 126, rel=1e-4)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_quadratic_ar_is_nonlinear(seed):
    x = _ar1(seed)
    lin = nonlinearity_indices(x)
    nl = Bicoherence().estimate(_rec(x + 0.8 * x**2))
    d = nl.diagnostics
    assert nl.decision is True
    assert d["ngi"] > 0.001 and d["nli"] > 0.01
    assert nl.value == d["nli"]
    assert d["ngi"] > lin.ngi + 0.03
    assert d["n_significant"] > 5 * lin.n_significant
    assert d["tnli"] > 5 * lin.tnli


def test_significant_reading_of_ngi_is_positive_even_for_gaussian_data():
    # documents why "domain" is the default: the mean of the significant bic² alone
    # exceeds the threshold by construction
    res = nonlinearity_indices(_ar1(0), ngi_average="significant")
    assert res.ngi > 0.001


def test_bicoherence_uses_last_max_samples_and_decimates():
    x = np.concatenate([np.zeros(1000), _ar1(4)])
    res = nonlinearity_indices(x, max_samples=4096)
    assert res.n_samples == 4096
    res2 = nonlinearity_indices(_ar1(4, n=3 * N), decimate=3, max_samples=None)
    assert res2.n_samples == N


def test_auto_prefilter_band_around_oscillation():
    rng = np.random.default_rng(2)
    n = np.arange(N)
    x = np.sin(2 * np.pi * n / 40.0) + 0.3 * rng.standard_normal(N)
    res = nonlinearity_indices(x, prefilter="auto")
    assert res.band is not None
    assert res.band[0] == pytest.approx(0.5 / 40, rel=0.03)
    assert res.band[1] == pytest.approx(0.25, rel=0.03)
    assert nonlinearity_indices(_ar1(0), prefilter="auto").band is None


# --------------------------------------------------------------------------- ellipse
def _sines(phi_deg: float, A: float = 4.0, B: float = 1.5, period: float = 80.0,
           noise: float = 0.05, seed: int = 0, n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    op = A * np.sin(2 * np.pi * t / period) + noise * A * rng.standard_normal(n)
    pv = (B * np.sin(2 * np.pi * t / period - np.radians(phi_deg))
          + noise * B * rng.standard_normal(n))
    return op, pv


@pytest.mark.parametrize("phi", [30.0, 60.0, 90.0])
def test_ellipse_chord_matches_analytic(phi):
    A = 4.0
    op, pv = _sines(phi, A=A)
    res = Ellipse().estimate(_rec(pv, op))
    expected = 2 * A * math.sin(math.radians(phi))
    assert res.value == pytest.approx(expected, rel=0.05)
    assert res.decision is True
    d = res.diagnostics
    assert d["axis_ratio"] == pytest.approx(math.tan(math.radians(phi) / 2), rel=0.05)
    assert d["residual"] < 0.1
    assert d["ellipse"].shape == (200, 2)
    assert d["centre"][0] == pytest.approx(0.0, abs=0.05 * A)
    assert 1 / d["f0"] == pytest.approx(80.0, rel=0.02)
    assert d["chord_fraction"] == pytest.approx(math.sin(math.radians(phi)), rel=0.05)
    json.dumps(res.to_dict())  # arrays dropped, everything else JSON-ready


def test_ellipse_in_phase_is_degenerate():
    op, pv = _sines(0.0)
    res = Ellipse().estimate(_rec(pv, op))
    assert res.decision is False
    assert res.diagnostics["degenerate"] is True
    assert res.value < 0.05 * 8.0


def test_ellipse_exact_line_has_no_fit():
    t = np.arange(2000)
    op = np.sin(2 * np.pi * t / 50.0)
    res = apparent_stiction(op, 2 * op + 1)
    assert res.fit is None and math.isnan(res.stiction)
    est = Ellipse().estimate(_rec(2 * op + 1, op))
    assert est.decision is False and math.isnan(est.value)


def test_ellipse_small_stiction_below_threshold():
    op, pv = _sines(3.0, A=4.0, noise=0.01)  # chord 2·4·sin 3° ≈ 0.42 < 0.5
    res = Ellipse(min_axis_ratio=0.0).estimate(_rec(pv, op))
    assert res.value == pytest.approx(0.42, rel=0.1)
    assert res.decision is False


def test_fit_ellipse_recovers_rotated_ellipse():
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False)
    a, b, ang, cx, cy = 3.0, 1.2, 0.6, 5.0, -2.0
    x = cx + a * np.cos(t) * math.cos(ang) - b * np.sin(t) * math.sin(ang)
    y = cy + a * np.cos(t) * math.sin(ang) + b * np.sin(t) * math.cos(ang)
    fit = fit_ellipse(x, y)
    assert fit is not None
    assert fit.centre == pytest.approx((cx, cy), abs=1e-9)
    assert fit.axes == pytest.approx((a, b), rel=1e-9)
    assert fit.angle == pytest.approx(ang, abs=1e-9)
    chord = 2 * a * b / math.sqrt(a**2 * math.sin(ang) ** 2 + b**2 * math.cos(ang) ** 2)
    assert fit.chord_x == pytest.approx(chord, rel=1e-9)
    assert fit.residual < 1e-9
    assert fit.points(50).shape == (50, 2)


@settings(max_examples=25, deadline=None)
@given(
    a=st.floats(0.5, 20.0), ratio=st.floats(0.05, 1.0), ang=st.floats(-1.5, 1.5),
    cx=st.floats(-50, 50), cy=st.floats(-50, 50),
)
def test_fit_ellipse_property(a, ratio, ang, cx, cy):
    b = a * ratio
    t = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    x = cx + a * np.cos(t) * math.cos(ang) - b * np.sin(t) * math.sin(ang)
    y = cy + a * np.cos(t) * math.sin(ang) + b * np.sin(t) * math.cos(ang)
    fit = fit_ellipse(x, y)
    assert fit is not None
    assert fit.centre == pytest.approx((cx, cy), abs=1e-6 * (1 + abs(cx) + abs(cy)))
    assert sorted(fit.axes) == pytest.approx(sorted((a, b)), rel=1e-6)
    chord = 2 * a * b / math.sqrt(a**2 * math.sin(ang) ** 2 + b**2 * math.cos(ang) ** 2)
    assert fit.chord_x == pytest.approx(chord, rel=1e-6)


# --------------------------------------------------------------------------- interface
@pytest.mark.parametrize(
    ("name", "cls"), [("bicoherence", Bicoherence), ("oscillation", Oscillation),
                      ("ellipse", Ellipse)],
)
def test_registry_and_params(name, cls):
    est = make(name)
    assert type(est) is cls and est.name == name
    assert cls(**est.get_params()).get_params() == est.get_params()
    assert repr(est).startswith(cls.__name__ + "(")
    with pytest.raises(InputError):
        make(name, no_such_param=1)


BAD = {
    "constant": np.full(5000, 3.0),
    "nan": np.where(np.arange(5000) == 100, np.nan, np.sin(np.arange(5000) / 7.0)),
    "inf": np.where(np.arange(5000) == 100, np.inf, np.sin(np.arange(5000) / 7.0)),
}


@pytest.mark.parametrize("kind", sorted(BAD))
def test_bad_input_raises(kind):
    x = BAD[kind]
    good = np.sin(np.arange(5000) / 7.0)
    with pytest.raises(InputError, match="NaN|constant"):
        acf_oscillation(x)
    with pytest.raises(InputError, match="NaN|constant"):
        nonlinearity_indices(x)
    with pytest.raises(InputError, match="NaN|constant"):
        kim_powers_bicoherence(x)
    with pytest.raises(InputError, match="NaN|constant"):
        apparent_stiction(x, good)
    with pytest.raises(InputError, match="NaN|constant"):
        apparent_stiction(good, x)


def test_constant_signal_through_recording_raises():
    pv = np.full(5000, 2.0)
    op = np.sin(np.arange(5000) / 7.0)
    rec = _rec(pv, op)
    for est in (Bicoherence(), Oscillation(), Ellipse()):
        with pytest.raises(InputError, match="constant"):
            est.estimate(rec)


def test_too_short_raises():
    x = np.sin(np.arange(300) / 5.0)
    with pytest.raises(InputError, match="at least"):
        Bicoherence().estimate(_rec(x))  # 300 samples < 8 segments of 128
    with pytest.raises(InputError, match="at least"):
        acf_oscillation(x[:20])
    with pytest.raises(InputError, match="at least"):
        apparent_stiction(x[:40], x[:40])
    with pytest.raises(InputError):
        apparent_stiction(x, x[:200])


@pytest.mark.parametrize(
    "params",
    [{"nfft": 100.5}, {"nfft": 7}, {"overlap": 100}, {"alpha": 0.0}, {"decimate": 0},
     {"prefilter": "nope"}, {"ngi_average": "median"}, {"max_samples": 10}],
)
def test_bad_bicoherence_params_raise(params):
    with pytest.raises(InputError):
        Bicoherence(**params).estimate(_rec(_ar1(0)))


def test_xcum_stable_on_a_skewed_delayed_signal():
    """A skewed input with a clean 7-sample delay: the lag survives both checks."""
    import numpy as np

    from stictionbench import Recording
    from stictionbench.estimators import make

    rng = np.random.default_rng(1)
    s = rng.exponential(size=3000 + 7) - 1.0
    t = np.arange(3000.0)
    rec = Recording.from_arrays(t, PV=s[:-7], OP=s[7:])
    res = make("xcum", max_delay=20).estimate(rec, "OP", "PV")
    d = res.diagnostics
    assert res.value == 7 and d["unstable"] is False and d["at_edge"] is False
    assert d["wide_delay"] == 7 and d["tsvd_delay"] == 7 and res.decision is True


def test_xcorr_reports_the_loops_backward_path():
    import stictionbench as sb
    from stictionbench.estimators import make

    rec = sb.simulate("stiction", duration=2000.0, seed=0, sample_time=1.0)
    d = make("xcorr").estimate(rec, "OP", "MV").diagnostics
    assert d["backward_path_window"] == [-20.0, -10.0]   # θ = τ = 10 s at Ts = 1 s
    assert d["on_backward_path"] is True and d["second_peak_lag"] is not None
