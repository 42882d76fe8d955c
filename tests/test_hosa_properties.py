"""Properties of stictionbench.hosa and the xcorr/xcum estimators.

Hypothesis draws seeds, delays, scales and offsets; the signals themselves come from
numpy generators (a centred-exponential, i.e. skewed, source seen by two sensors with
independent Gaussian noise), so every example is a realistic delay-estimation problem.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stictionbench import hosa
from stictionbench.errors import InputError
from stictionbench.estimators import make
from stictionbench.estimators.xcorr import XCorr
from stictionbench.estimators.xcum import XCum
from stictionbench.recording import Recording

FAST = settings(max_examples=20, deadline=None)
SEEDS = st.integers(0, 2**32 - 1)
DELAYS = st.integers(-20, 20)
SCALES = st.floats(0.01, 100.0).flatmap(lambda a: st.sampled_from([a, -a]))
OFFSETS = st.floats(-1000.0, 1000.0)


def delayed_pair(
    seed: int, d: int, n: int = 4096, noise: float = 0.3
) -> tuple[np.ndarray, np.ndarray]:
    """x(n) = s(n) + w1, y(n) = s(n - d) + w2 with s centred exponential i.i.d."""
    rng = np.random.default_rng(seed)
    pad = abs(d)
    s = rng.exponential(size=n + 2 * pad) - 1.0
    x = s[pad : pad + n] + noise * rng.standard_normal(n)
    y = s[pad - d : pad - d + n] + noise * rng.standard_normal(n)
    return x, y


# ------------------------------------------------------------------ symmetry
@FAST
@given(seed=SEEDS, d=DELAYS)
def test_tder_swap_negates(seed: int, d: int) -> None:
    x, y = delayed_pair(seed, d)
    a = hosa.tder(x, y, 30)
    b = hosa.tder(y, x, 30)
    assert b.delay == pytest.approx(-a.delay, abs=1e-9)
    assert abs(a.delay - d) < 0.5
    # the swapped curve is the original read at the negated lags (-lag mod nfft)
    np.testing.assert_allclose(b.rxy, np.roll(a.rxy[::-1], 1), rtol=0,
                               atol=1e-12 * np.max(np.abs(a.rxy)))


@FAST
@given(seed=SEEDS, d=DELAYS)
def test_tde_swap_negates(seed: int, d: int) -> None:
    x, y = delayed_pair(seed, d)
    assert hosa.tde(x, y, 30).delay == d
    assert hosa.tde(y, x, 30).delay == -d


# ------------------------------------------------------------------ invariance
@FAST
@given(seed=SEEDS, d=DELAYS, ax=SCALES, bx=OFFSETS, ay=SCALES, by=OFFSETS)
def test_tder_scale_offset_invariant(
    seed: int, d: int, ax: float, bx: float, ay: float, by: float
) -> None:
    x, y = delayed_pair(seed, d)
    ref = hosa.tder(x, y, 30, 64, 50)
    got = hosa.tder(ax * x + bx, ay * y + by, 30, 64, 50)
    assert got.delay == pytest.approx(ref.delay, abs=1e-9)
    np.testing.assert_allclose(np.sign(ax * ay) * got.rxy, ref.rxy, rtol=0,
                               atol=1e-9 * np.max(np.abs(ref.rxy)))


@FAST
@given(seed=SEEDS, d=DELAYS, ax=SCALES, bx=OFFSETS, ay=SCALES, by=OFFSETS,
       nsamp=st.sampled_from([None, 512]))
def test_tde_scale_offset_invariant(
    seed: int, d: int, ax: float, bx: float, ay: float, by: float, nsamp: int | None
) -> None:
    x, y = delayed_pair(seed, d)
    ref = hosa.tde(x, y, 30, nsamp)
    got = hosa.tde(ax * x + bx, ay * y + by, 30, nsamp)
    assert got.delay == ref.delay
    # a(k) scales as (y scale)/(x scale)
    np.testing.assert_allclose(got.avec * ax / ay, ref.avec, rtol=0,
                               atol=1e-8 * np.max(np.abs(ref.avec)))


# ------------------------------------------------------------------ recovery
@FAST
@given(seed=SEEDS, d=st.integers(-25, 25), nsamp=st.sampled_from([None, 256, 1000]),
       n=st.integers(2048, 4096))
def test_tde_recovers_integer_shift(seed: int, d: int, nsamp: int | None, n: int) -> None:
    x, y = delayed_pair(seed, d, n=n, noise=0.0)
    res = hosa.tde(x, y, 30, nsamp)
    assert res.delay == d
    assert res.lags[np.argmax(np.abs(res.avec))] == d
    assert 0.5 < res.avec[d + 30] < 1.5          # a(D) ≈ 1 (edge losses in short records)


@settings(max_examples=10, deadline=None)
@given(seed=SEEDS, m=st.integers(1, 6), n=st.integers(40, 160),
       nrec=st.integers(1, 3))
def test_cumulant_sums_match_direct_loops(seed: int, m: int, n: int, nrec: int) -> None:
    """The FFT cumulants equal the defining sums (within records, zeros outside)."""
    rng = np.random.default_rng(seed)
    nsamp = max(n // nrec, 2 * m + 1)
    x = rng.exponential(size=n) - 1
    y = rng.standard_normal(n)
    rxxx, rxyx = hosa._cumulants(x, y, m, nsamp)
    ex = np.zeros((3, 4 * m + 1))
    ey = np.zeros((3, 2 * m + 1))
    for r in range(n // nsamp):
        xs = x[r * nsamp : (r + 1) * nsamp]
        ys = y[r * nsamp : (r + 1) * nsamp]
        xs, ys = xs - xs.mean(), ys - ys.mean()
        for si, s in enumerate((-1, 0, 1)):
            for tau in range(-2 * m, 2 * m + 1):
                for i in range(nsamp):
                    if 0 <= i + s < nsamp and 0 <= i - tau < nsamp:
                        ex[si, tau + 2 * m] += xs[i] * xs[i + s] * xs[i - tau]
                        if abs(tau) <= m:
                            ey[si, tau + m] += xs[i] * xs[i + s] * ys[i - tau]
    np.testing.assert_allclose(rxxx, ex / n, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(rxyx, ey / n, rtol=1e-9, atol=1e-12)


def test_full_rank_svd_equals_solve() -> None:
    x, y = delayed_pair(3, 9)
    full = hosa.tde(x, y, 20)
    svd = hosa.tde(x, y, 20, None, 41)
    assert svd.delay == full.delay == 9
    np.testing.assert_allclose(svd.avec, full.avec, rtol=1e-6, atol=1e-9)
    low = hosa.tde(x, y, 20, [], 30)
    assert low.avec.shape == (41,)


def test_corrnoise_case_tde_finds_16_tder_pulled_to_5(reference_dir: Path) -> None:
    data = np.genfromtxt(reference_dir / "signals" / "syn3_exp_corrnoise_d16.csv",
                         delimiter=",", names=True)
    x, y = np.asarray(data["x"], float), np.asarray(data["y"], float)
    assert hosa.tde(x, y, 30).delay == 16
    assert hosa.tde(x, y, 30, 128).delay == 16
    assert abs(hosa.tder(x, y, 30).delay - 5) < 0.5
    assert abs(hosa.tder(x, y, 30, 64, 0, 64).delay - 5) < 0.5


# ------------------------------------------------------------------ defaults
def test_empty_list_means_default() -> None:
    x, y = delayed_pair(5, 7)
    a = hosa.tder(x, y, 30)
    b = hosa.tder(x, y, 30, [], [], [])
    c = hosa.tder(x, y, 30, 128, 50, 128)
    assert a.delay == b.delay == c.delay
    assert hosa.tde(x, y, 30, []).delay == hosa.tde(x, y, 30).delay
    bic1, w1 = hosa.bicoher(x)
    bic2, w2 = hosa.bicoher(x, 128, [], [], 50)
    np.testing.assert_array_equal(bic1, bic2)
    assert bic1.shape == (1024, 1024)          # nsamp = fix(4096/4.5) = 910 -> nfft 1024


def test_overlap_clipped_and_small_nfft_raised() -> None:
    x, y = delayed_pair(6, 4)
    assert hosa.tder(x, y, 10, 64, 150).delay == hosa.tder(x, y, 10, 64, 99).delay
    assert hosa.tder(x, y, 10, 64, -5).delay == hosa.tder(x, y, 10, 64, 0).delay
    assert hosa.tder(x, y, 10, 64, 50, 16).rxy.size == 64
    assert hosa.tder(x, y, 10, 64, 50, 256).rxy.size == 256
    assert hosa.tder_settings(4096, 30) == hosa.TderSettings(128, 64, 128, 63)


def test_vector_shapes_accepted() -> None:
    x, y = delayed_pair(8, 3)
    a = hosa.tde(x, y, 10)
    b = hosa.tde(x[:, None], y[None, :], 10)
    assert a.delay == b.delay == 3
    assert hosa.tder(list(x), list(y), 10).delay == hosa.tder(x, y, 10).delay


def test_bicoher_matrix_input_is_one_record_per_column() -> None:
    rng = np.random.default_rng(2)
    y = rng.exponential(size=(64, 32))
    bic, w = hosa.bicoher(y)
    segs = (y - y.mean(0)) * hosa.hanning(64)[:, None]
    f = np.fft.fft(segs, 128, axis=0).T / 64
    p = np.mean(np.abs(f) ** 2, axis=0)
    k = np.arange(128)
    kl = (k[:, None] + k[None, :]) % 128
    b = np.mean(f[:, :, None] * f[:, None, :] * np.conj(f[:, kl]), axis=0)
    expect = np.fft.fftshift(np.abs(b) ** 2 / (p[:, None] * p[None, :] * p[kl]))
    np.testing.assert_allclose(bic, expect, rtol=1e-10, atol=1e-14)
    assert w[0] == -0.5 and w[-1] == 0.5 - 1 / 128
    np.testing.assert_allclose(bic, bic.T, rtol=1e-12)


def test_hanning_is_matlab() -> None:
    k = np.arange(1, 8)
    np.testing.assert_allclose(hosa.hanning(7), 0.5 * (1 - np.cos(2 * np.pi * k / 8)))


# ------------------------------------------------------------------ bad input
def _one_line(exc: pytest.ExceptionInfo) -> str:
    msg = str(exc.value)
    assert msg and "\n" not in msg
    return msg


GOOD = delayed_pair(11, 5)


@pytest.mark.parametrize("fn", [lambda x, y: hosa.tder(x, y, 30),
                                lambda x, y: hosa.tde(x, y, 30)], ids=["tder", "tde"])
def test_bad_pairs(fn) -> None:
    x, y = GOOD
    with pytest.raises(InputError, match="different lengths") as e:
        fn(x, y[:-1])
    _one_line(e)
    with pytest.raises(InputError, match="too short") as e:
        fn(x[:50], y[:50])
    _one_line(e)
    with pytest.raises(InputError, match="constant") as e:
        fn(np.full_like(x, 2.5), y)
    _one_line(e)
    with pytest.raises(InputError, match="constant"):
        fn(x, np.zeros_like(y))
    bad = x.copy()
    bad[100] = np.nan
    with pytest.raises(InputError, match="NaN") as e:
        fn(bad, y)
    _one_line(e)
    bad[100] = np.inf
    with pytest.raises(InputError, match="NaN or infinite"):
        fn(x, bad)
    with pytest.raises(InputError, match="vector"):
        fn(np.ones((3, 3)), np.ones((3, 3)))


def test_bad_parameters() -> None:
    x, y = GOOD
    with pytest.raises(InputError, match="max_delay"):
        hosa.tder(x, y, 2.5)
    with pytest.raises(InputError, match="max_delay"):
        hosa.tde(x, y, 0)
    with pytest.raises(InputError, match="max_delay is required"):
        hosa.tde(x, y, None)
    with pytest.raises(InputError, match="even"):
        hosa.tder(x, y, 30, 128, 50, 129)
    with pytest.raises(InputError, match="nsamp"):
        hosa.tde(x, y, 30, 8192)
    with pytest.raises(InputError, match="rank"):
        hosa.tde(x, y, 10, None, 22)
    with pytest.raises(InputError, match="number"):
        hosa.tder(x, y, "thirty")


def test_coherence_of_one_is_guarded() -> None:
    x, y = GOOD
    # a single segment: the coherence is identically 1 and C/(1-C) divides by zero
    with pytest.raises(InputError, match="coherence") as e:
        hosa.tder(x[:128], y[:128], 30)
    _one_line(e)
    with pytest.raises(InputError, match="divides by zero"):
        hosa.tder(x, y, 30, 4096, 0)
    # y = 2x exactly: every coherence is 1 to the last bit
    with pytest.raises(InputError, match="coherence is exactly 1") as e:
        hosa.tder(x, 2.0 * x, 30)
    _one_line(e)


def test_bicoher_bad_input() -> None:
    x, _ = GOOD
    with pytest.raises(InputError, match="constant"):
        hosa.bicoher(np.ones(1024))
    with pytest.raises(InputError, match="NaN"):
        hosa.bicoher(np.r_[x[:-1], np.nan])
    with pytest.raises(InputError, match="segment"):
        hosa.bicoher(x, 128, [], x.size, 0)
    with pytest.raises(InputError, match="wind"):
        hosa.bicoher(x, 128, np.ones(5), 128)
    with pytest.raises(InputError, match="longer"):
        hosa.bicoher(x[:100], 128, [], 128)


# ------------------------------------------------------------------ estimators
def loop_recording(d: int, n: int = 4096, seed: int = 0, Ts: float = 0.5) -> Recording:
    """OP = x, MV = y lagging it by ``d`` samples; PV a filtered copy of MV."""
    x, y = delayed_pair(seed, d, n=n)
    pv = np.convolve(y, np.ones(5) / 5, mode="same")
    t = np.arange(n) * Ts
    return Recording.from_arrays(t, pv, x, MV=y)


def test_xcum_estimator() -> None:
    rec = loop_recording(12)
    est = XCum()
    assert est.get_params() == {"max_delay": 30, "nsamp": None, "rank": None,
                                "threshold": 0.5, "stability_check": True,
                                "svd_rcond": 1e-8}
    res = est.estimate(rec)
    assert res.method == "xcum" and res.units == "samples"
    assert res.value == 12 and res.decision is True
    assert res.meaning == "y lags x (stiction indicated)"
    dg = res.diagnostics
    assert dg["delay_s"] == pytest.approx(6.0)
    assert dg["at_edge"] is False and dg["edge_check_delay"] is None
    assert dg["threshold"] == 0.5 and dg["max_delay"] == 30
    np.testing.assert_array_equal(dg["lags"], np.arange(-30, 31))
    assert dg["curve"].shape == (61,) and dg["peaks"][0][0] == 12
    json.dumps(res.to_dict(curves=True))
    assert res.flat()["xcum_value"] == 12


def test_xcorr_estimator() -> None:
    rec = loop_recording(12)
    est = XCorr(max_delay=20)
    res = est.estimate(rec)
    assert res.method == "xcorr" and res.units == "samples"
    assert res.value == pytest.approx(12, abs=0.5) and res.decision is True
    dg = res.diagnostics
    assert dg["delay_s"] == pytest.approx(res.value * 0.5)
    assert dg["at_edge"] is False and dg["beyond_max_delay"] is False
    assert dg["segsamp"] == 128 and dg["nfft"] == 128 and dg["max_delay"] == 20
    assert dg["lags"][0] == -64 and dg["curve"].shape == (128,)
    assert dg["peaks"][0][0] == 12
    json.dumps(res.to_dict(curves=True))


def test_estimators_negative_delay_no_stiction() -> None:
    rec = loop_recording(-6)
    for est in (XCorr(), XCum()):
        res = est.estimate(rec)
        assert res.value == pytest.approx(-6, abs=0.5)
        assert res.decision is False


def test_xcum_flags_edge_and_rechecks() -> None:
    rec = loop_recording(10)
    res = XCum(max_delay=10).estimate(rec)
    assert res.value == 10 and res.diagnostics["at_edge"] is True
    assert res.diagnostics["edge_check_max_delay"] == 20
    assert res.diagnostics["edge_check_delay"] == 10


def test_estimators_via_registry_and_swapped_signals() -> None:
    rec = loop_recording(8)
    est = make("xcum", max_delay=15, rank=31)
    assert isinstance(est, XCum) and est.rank == 31
    assert est.estimate(rec).value == 8
    assert est.estimate(rec, x="MV", y="OP").value == -8
    xc = make("xcorr", segsamp=64, overlap=0, nfft=64)
    assert isinstance(xc, XCorr) and xc.segsamp == 64
    assert xc.estimate(rec).value == pytest.approx(8, abs=0.5)


def test_estimator_bad_input() -> None:
    x, y = delayed_pair(1, 3, n=4096)
    t = np.arange(x.size)
    no_mv = Recording.from_arrays(t, y, x)
    with pytest.raises(InputError, match="MV"):
        XCum().estimate(no_mv)
    flat = Recording.from_arrays(t, y, x, MV=np.full(x.size, 40.0))
    for est in (XCorr(), XCum()):
        with pytest.raises(InputError, match="constant"):
            est.estimate(flat)
    short = Recording.from_arrays(t[:120], y[:120], x[:120], MV=y[:120])
    with pytest.raises(InputError, match="too short"):
        XCorr().estimate(short)
    with pytest.raises(InputError, match="too short"):
        XCum(max_delay=70).estimate(short)
