"""Timing of the spectral estimators against straightforward numpy implementations.

Signal: ``stictionbench.simulate("stiction", duration=4096, sample_time=1, sensor="noisy")``,
the last 4096 samples of PV and OP (a regular stick-slip oscillation, period ≈ 135 s).
For each row our call is timed (best round of pytest-benchmark's ``pedantic``, or
timeit best-of-N when benchmarks are disabled), the baseline written below is timed in
the same run (timeit best-of-N), and the baseline is checked to give the same numbers:

- ``kim_powers_bicoherence``: :func:`naive_bicoherence` — one Python iteration and one
  FFT per segment, then an explicit double loop over the frequency pairs ``(k, l)`` of
  the principal domain, each averaging the triple product over the segments.
  Same ``bic²`` to ``rtol 1e-9``.
- ``nonlinearity_indices`` (``prefilter="auto"``, as the ``bicoherence`` estimator):
  :func:`naive_nonlinearity` — polyfit detrend, the band from
  :func:`naive_acf_oscillation`, our ``bandpass`` (the same scipy ``sosfiltfilt``; not
  what is being compared), :func:`naive_bicoherence`, the χ²₂ threshold in closed form
  ``−2 ln α / (2K)``. Same NGI, NLI, TNLI to ``rtol 1e-9``.
- ``acf_oscillation``: :func:`naive_acf_oscillation` — polyfit detrend, the full ACF from
  ``np.correlate(x, x, "full")`` (O(N²)), a Python loop over the lags for the linearly
  interpolated zero crossings and one over the lobes for the ACF peaks. Same crossings,
  period and regularity to ``1e-9``.
- ``fit_ellipse`` (on the band-passed, trimmed (OP, PV) cloud ``apparent_stiction``
  fits): :func:`plain_fitzgibbon` — the original direct fit, design matrix
  ``[x², xy, y², x, y, 1]`` in data units (not standardised), ``S a = λ C a`` solved with
  ``scipy.linalg.eig(S, C)`` on the 6×6 scatter and constraint matrices, the eigenvector
  of the positive finite eigenvalue. Same centre, axes and OP chord to ``rtol 1e-9``
  (the unnormalised scatter matrix has a condition number of about 1e12 here; the two
  agree to about 1e-13 all the same).
- ``apparent_stiction``: :func:`naive_apparent_stiction` — f0 from
  :func:`naive_acf_oscillation` of OP (else PV), our ``bandpass`` and ``bandpass_gain``,
  the same trimming, :func:`plain_fitzgibbon`. Same apparent stiction to ``rtol 1e-9``.

Nothing is asserted about timing. ``test_summary`` prints the table (ours, baseline,
baseline/ours) and writes ``reports/benchmarks/estimators.md``. Run with ``-s``.
"""

from __future__ import annotations

import math
import os
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.linalg

import stictionbench
from stictionbench.estimators.bicoherence import kim_powers_bicoherence, nonlinearity_indices
from stictionbench.estimators.ellipse import apparent_stiction, fit_ellipse
from stictionbench.estimators.oscillation import (
    acf_oscillation,
    bandpass,
    bandpass_gain,
    dominant_frequency,
)
from stictionbench.io import write_text

ROOT = Path(__file__).resolve().parents[1]
REPORT = ROOT / "reports" / "benchmarks" / "estimators.md"
N = 4096

#: case -> (ours seconds, baseline seconds, agreement note), filled by the tests
TIMES: dict[str, tuple[float, float, str]] = {}


# --------------------------------------------------------------------------- signal
_SIGNAL: dict[str, np.ndarray] = {}


def signals() -> dict[str, np.ndarray]:
    if not _SIGNAL:
        rec = stictionbench.simulate("stiction", duration=float(N), sample_time=1.0,
                                     sensor="noisy")
        _SIGNAL["PV"] = np.asarray(rec.PV, float)[-N:].copy()
        _SIGNAL["OP"] = np.asarray(rec.OP, float)[-N:].copy()
    return _SIGNAL


def best_time(fn: Callable[[], Any], repeat: int = 7, target: float = 0.02) -> float:
    """timeit best-of-``repeat``, each repeat running about ``target`` seconds."""
    number, _ = timeit.Timer(fn).autorange()
    t1 = timeit.Timer(fn).timeit(number) / number
    number = max(1, int(target / max(t1, 1e-9)))
    return min(timeit.Timer(fn).repeat(repeat=repeat, number=number)) / number


# --------------------------------------------------------------------------- baselines
def linear_detrend(x: np.ndarray) -> np.ndarray:
    t = np.arange(x.size, dtype=float)
    return x - np.polyval(np.polyfit(t, x, 1), t)


def naive_bicoherence(x: np.ndarray, nfft: int = 128,
                      overlap: float = 50) -> tuple[np.ndarray, np.ndarray, int]:
    """Kim–Powers bic² one segment at a time, then one frequency pair at a time."""
    step = nfft - int(math.floor(overlap / 100.0 * nfft))
    w = 0.5 * (1.0 - np.cos(2.0 * np.pi * np.arange(1, nfft + 1) / (nfft + 1)))  # hanning
    spectra = []
    for start in range(0, x.size - nfft + 1, step):
        s = x[start:start + nfft]
        spectra.append(np.fft.fft((s - s.mean()) * w) / nfft)
    F = np.array(spectra)                                   # (K, nfft)
    half = nfft // 2
    bic2 = np.full((half + 1, half + 1), np.nan)
    for k in range(1, half + 1):
        for l in range(1, k + 1):
            if k + l > half:
                break
            x12 = F[:, k] * F[:, l]
            x3 = F[:, k + l]
            num = abs(np.mean(x12 * np.conj(x3))) ** 2
            den = np.mean(np.abs(x12) ** 2) * np.mean(np.abs(x3) ** 2)
            bic2[k, l] = num / den if den > 0 else 0.0
    return bic2, np.arange(half + 1) / nfft, len(spectra)


def naive_acf_oscillation(x: np.ndarray, max_crossings: int = 10, min_crossings: int = 4,
                          r_threshold: float = 1.0, min_period: float = 4.0) -> dict:
    """Thornhill's ACF zero-crossing test with np.correlate and Python loops."""
    x = linear_detrend(np.asarray(x, float))
    n = x.size
    lag = n // 2
    full = np.correlate(x, x, mode="full")
    r = full[n - 1:n + lag] / full[n - 1]
    crossings = []
    for i in range(lag):
        if (r[i] > 0.0) != (r[i + 1] > 0.0):
            crossings.append(i + r[i] / (r[i] - r[i + 1]))
    z = np.array(crossings[:max_crossings])
    out = {"acf": r, "crossings": z, "oscillating": False, "period_samples": math.nan,
           "regularity": math.nan, "acf_peak": math.nan, "acf_decay": math.nan}
    if z.size < min_crossings:
        return out
    tp = [2.0 * (z[i + 1] - z[i]) for i in range(z.size - 1)]
    mean_tp = sum(tp) / len(tp)
    sd = math.sqrt(sum((p - mean_tp) ** 2 for p in tp) / (len(tp) - 1))
    reg = mean_tp / (3.0 * sd) if sd > 0 else math.inf
    peaks = []
    for j in range(1, len(crossings) - 1, 2):                # positive lobes
        lo, hi = math.ceil(crossings[j]), math.floor(crossings[j + 1]) + 1
        if hi > lo:
            peaks.append(max(r[lo:hi]))
        if len(peaks) == 2:
            break
    out.update(oscillating=bool(reg > r_threshold and mean_tp >= min_period),
               period_samples=mean_tp, regularity=reg,
               acf_peak=peaks[0] if peaks else math.nan,
               acf_decay=peaks[1] / peaks[0] if len(peaks) == 2 and peaks[0] > 0
               else math.nan)
    return out


def naive_nonlinearity(x: np.ndarray, nfft: int = 128, overlap: float = 50,
                       alpha: float = 0.05) -> dict:
    """NGI, NLI, TNLI as ``nonlinearity_indices(x, prefilter="auto")``, naively."""
    x = linear_detrend(np.asarray(x, float)[-4096:])
    osc = naive_acf_oscillation(x)
    band = None
    if osc["oscillating"]:
        f0 = 1.0 / osc["period_samples"]
        band = (0.5 * f0, min(0.5, 10.0 * f0))
        x = bandpass(x, band)
    bic2, _, K = naive_bicoherence(x, nfft, overlap)
    vals = bic2[np.isfinite(bic2)]
    thr = -2.0 * math.log(alpha) / (2.0 * K)                # χ²₂(1 − α) = −2 ln α
    sig = vals[vals > thr]
    return {"ngi": float(sig.sum() / vals.size) - thr,
            "nli": abs(float(vals.max()) - (float(vals.mean()) + 2.0 * float(vals.std()))),
            "tnli": float(sig.sum()), "band": band, "k": K}


def plain_fitzgibbon(x: np.ndarray, y: np.ndarray) -> dict:
    """Fitzgibbon, Pilu & Fisher (1999) as published: generalised eigenproblem S a = λ C a."""
    D = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    S = D.T @ D
    C = np.zeros((6, 6))
    C[0, 2] = C[2, 0] = 2.0
    C[1, 1] = -1.0
    lam, vec = scipy.linalg.eig(S, C)
    ok = np.isfinite(lam) & (np.real(lam) > 0)
    j = int(np.flatnonzero(ok)[0])
    a = np.real(vec[:, j])
    a = a / math.sqrt(4.0 * a[0] * a[2] - a[1] ** 2)
    A, B, Cq, Dl, E, F = a
    centre = np.linalg.solve([[2.0 * A, B], [B, 2.0 * Cq]], [-Dl, -E])
    cx, cy = centre
    F0 = A * cx * cx + B * cx * cy + Cq * cy * cy + Dl * cx + E * cy + F
    ev = np.linalg.eigvalsh([[A, B / 2.0], [B / 2.0, Cq]])
    return {"centre": (float(cx), float(cy)), "axes": tuple(np.sqrt(-F0 / ev)),
            "chord_x": 2.0 * math.sqrt(-F0 / A), "cond_S": float(np.linalg.cond(S))}


def naive_apparent_stiction(op: np.ndarray, pv: np.ndarray, order: int = 2) -> dict:
    osc = naive_acf_oscillation(op)
    if not osc["oscillating"]:
        osc = naive_acf_oscillation(pv)
    f0 = 1.0 / osc["period_samples"] if osc["oscillating"] else dominant_frequency(op)
    band = (0.5 * f0, min(0.5, 2.0 * f0))
    gain = bandpass_gain(band, f0, order)
    opf = bandpass(op - op.mean(), band, order) / gain + op.mean()
    pvf = bandpass(pv - pv.mean(), band, order) / gain + pv.mean()
    trim = min(int(round(3.0 / f0)), op.size // 6)
    if trim:
        opf, pvf = opf[trim:-trim], pvf[trim:-trim]
    fit = plain_fitzgibbon(opf, pvf)
    return {"stiction": fit["chord_x"], "f0": f0, "fit": fit}


# --------------------------------------------------------------------------- cases
def _case_bicoherence() -> tuple[Callable, Callable, Callable]:
    x = linear_detrend(signals()["PV"])

    def check(ours, base) -> str:
        np.testing.assert_allclose(ours[0], base[0], rtol=1e-9, atol=1e-15)
        assert ours[2] == base[2]
        return "bic² rtol 1e-9"

    return (lambda: kim_powers_bicoherence(x), lambda: naive_bicoherence(x), check)


def _case_nonlinearity() -> tuple[Callable, Callable, Callable]:
    x = signals()["PV"]

    def check(ours, base) -> str:
        assert base["band"] is not None and ours.band is not None
        np.testing.assert_allclose(ours.band, base["band"], rtol=1e-9)
        assert ours.k_segments == base["k"]
        for key in ("ngi", "nli", "tnli"):
            assert getattr(ours, key) == pytest.approx(base[key], rel=1e-9, abs=1e-12), key
        return "NGI, NLI, TNLI rtol 1e-9"

    return (lambda: nonlinearity_indices(x, prefilter="auto"), lambda: naive_nonlinearity(x),
            check)


def _case_oscillation() -> tuple[Callable, Callable, Callable]:
    x = signals()["PV"]

    def check(ours, base) -> str:
        assert ours.oscillating and base["oscillating"]
        np.testing.assert_allclose(ours.acf, base["acf"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(ours.crossings, base["crossings"], rtol=0, atol=1e-9)
        for key in ("period_samples", "regularity", "acf_peak", "acf_decay"):
            assert getattr(ours, key) == pytest.approx(base[key], rel=1e-9), key
        return "ACF atol 1e-12; crossings, period, r rtol 1e-9"

    return (lambda: acf_oscillation(x), lambda: naive_acf_oscillation(x), check)


def _case_fit_ellipse() -> tuple[Callable, Callable, Callable]:
    s = signals()
    res = apparent_stiction(s["OP"], s["PV"])
    u, v = res.op, res.pv

    def check(ours, base) -> str:
        assert ours is not None
        np.testing.assert_allclose(ours.centre, base["centre"], rtol=1e-9)
        np.testing.assert_allclose(ours.axes, base["axes"], rtol=1e-9)
        assert ours.chord_x == pytest.approx(base["chord_x"], rel=1e-9)
        return (f"centre, axes, chord rtol 1e-9 ({u.size} points, cond S = "
                f"{base['cond_S']:.1e})")

    return (lambda: fit_ellipse(u, v), lambda: plain_fitzgibbon(u, v), check)


def _case_apparent_stiction() -> tuple[Callable, Callable, Callable]:
    s = signals()
    op, pv = s["OP"], s["PV"]

    def check(ours, base) -> str:
        assert ours.f0_source == "acf"
        assert ours.f0 == pytest.approx(base["f0"], rel=1e-9)
        assert ours.stiction == pytest.approx(base["stiction"], rel=1e-9)
        return f"apparent stiction {ours.stiction:.3f} % rtol 1e-9"

    return (lambda: apparent_stiction(op, pv), lambda: naive_apparent_stiction(op, pv), check)


CASES: dict[str, Callable[[], tuple[Callable, Callable, Callable]]] = {
    "bicoherence: kim_powers_bicoherence": _case_bicoherence,
    "bicoherence: nonlinearity_indices (auto band)": _case_nonlinearity,
    "oscillation: acf_oscillation": _case_oscillation,
    "ellipse: fit_ellipse": _case_fit_ellipse,
    "ellipse: apparent_stiction": _case_apparent_stiction,
}


def measure(case: str, benchmark=None) -> tuple[float, float, str]:
    ours_fn, base_fn, check = CASES[case]()
    note = check(ours_fn(), base_fn())
    t_base = best_time(base_fn, repeat=3)
    t_ours = None
    if benchmark is not None:
        t1 = best_time(ours_fn, repeat=1, target=0.005)
        iterations = max(1, int(0.002 / max(t1, 1e-9)))
        benchmark.pedantic(ours_fn, rounds=25, iterations=iterations, warmup_rounds=1)
        stats = getattr(benchmark, "stats", None)
        if stats is not None and getattr(stats, "stats", None) is not None:
            t_ours = float(stats.stats.min)
    if t_ours is None:                                      # run alone / --benchmark-disable
        t_ours = best_time(ours_fn)
    if benchmark is not None:
        benchmark.extra_info.update(baseline_s=t_base, ours_s=t_ours, ratio=t_base / t_ours)
    TIMES[case] = (t_ours, t_base, note)
    return TIMES[case]


def _ms(t: float) -> str:
    return f"{t * 1e3:.3f}"


# --------------------------------------------------------------------------- tests
@pytest.mark.parametrize("case", list(CASES))
def test_estimator_vs_numpy_baseline(benchmark, case: str) -> None:
    t_ours, t_base, note = measure(case, benchmark)
    print(f"\n{case:<46} ours {_ms(t_ours):>8} ms   baseline {_ms(t_base):>8} ms   "
          f"ratio {t_base / t_ours:6.1f}x   ({note})")


def test_summary() -> None:
    for case in CASES:
        if case not in TIMES:                               # run alone: measure here
            measure(case)
    head = f"{'estimator: call':<46} {'ours ms':>9} {'baseline ms':>12} {'ratio':>8}"
    lines = [head]
    rows = ["| estimator: call | ours | baseline | baseline / ours | baseline agrees |",
            "|---|---|---|---|---|"]
    for case in CASES:
        t_ours, t_base, note = TIMES[case]
        lines.append(f"{case:<46} {_ms(t_ours):>9} {_ms(t_base):>12} "
                     f"{t_base / t_ours:7.1f}x")
        rows.append(f"| `{case}` | {_ms(t_ours)} ms | {_ms(t_base)} ms "
                    f"| **{t_base / t_ours:.1f}×** | {note} |")
    print("\n" + "\n".join(lines))
    text = "\n".join([
        "# Estimators against straightforward numpy (4096 samples)\n",
        "Written by `benchmarks/test_bench_estimators.py` (its docstring describes each "
        "baseline). Signal: the last 4096 samples of PV (and OP) from "
        "`stictionbench.simulate(\"stiction\", duration=4096, sample_time=1, "
        "sensor=\"noisy\")`. Ours: best round of pytest-benchmark; baseline: timeit best "
        f"of 3, same run, {os.cpu_count()} CPU(s). Each baseline is first checked to give "
        "the same numbers as ours, to the tolerance in the last column.\n",
        *rows,
        "",
        "- bicoherence baseline: one FFT per segment in a Python loop, then an explicit "
        "double loop over the frequency pairs of the principal domain.",
        "- oscillation baseline: full ACF by `np.correlate` (O(N²)), zero crossings in a "
        "Python loop.",
        "- ellipse baseline: the original (non-normalised) Fitzgibbon fit, "
        "`scipy.linalg.eig(S, C)` on the 6×6 scatter and constraint matrices; the band-pass "
        "filtering in `apparent_stiction` is the same scipy `sosfiltfilt` in both. Ours "
        "`fit_ellipse` does more per call (standardisation, a condition check of S3, axes, "
        "angle and the radial residual of every point), so on one 6×6 eigenproblem the "
        "plain fit is the faster of the two (its scatter matrix is far worse conditioned).",
        "",
    ])
    write_text(REPORT, text)
