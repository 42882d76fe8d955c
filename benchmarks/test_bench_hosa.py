"""Timing of stictionbench.hosa against the HOSA toolbox under Octave and naive numpy.

1. One benchmark per row of ``delays.csv`` and ``bicoherence.csv``: our call is timed
   (best round of pytest-benchmark's ``pedantic``, or timeit best-of-N when benchmarks
   are disabled) and checked against the reference output. ``test_summary_vs_octave``
   then prints our time, the reference ``octave_best_s`` (computation only, best of 5)
   and their ratio per row, and the median ratio.
2. Each method against a straightforward numpy implementation (per-segment Python
   loops, loop-based cumulant sums) measured in the same run; the ratio is printed.

Nothing is asserted about timing, only that results are correct. Run with ``-s`` to see
the tables. Skipped when the shared reference data are absent.
"""

from __future__ import annotations

import csv
import os
import statistics
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from stictionbench import hosa

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("STICTIONBENCH_SHARED", ROOT.parent / "shared"))
REFERENCE = SHARED / "reference" / "hosa"

pytestmark = pytest.mark.skipif(
    not REFERENCE.exists(), reason=f"shared data not present: {REFERENCE}"
)


#: our best time per case, filled by the per-row benchmarks, read by the summary
TIMES: dict[str, float] = {}


# ----------------------------------------------------------------------- reading
def read_rows(name: str) -> list[dict[str, str]]:
    path = REFERENCE / name
    if not path.exists():
        return []
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r["table"] = name
    return rows


def load_signals(name: str) -> dict[str, np.ndarray]:
    return hosa.read_signals(str(REFERENCE / "signals" / f"{name}.csv"))


parse_call = hosa.parse_call


ROWS = read_rows("delays.csv") + read_rows("bicoherence.csv")


def check_row(row: dict[str, str], result: Any) -> None:
    """The result of a row's call agrees with the reference output."""
    if row["table"] == "delays.csv":
        delay, curve = result
        assert abs(delay - float(row["estimate"])) <= 1e-9, row["call"]
        ref = np.genfromtxt(REFERENCE / row["curve_file"], delimiter=",", names=True)
        values = np.asarray(ref[ref.dtype.names[1]], float)
        np.testing.assert_allclose(curve, values, rtol=1e-10,
                                   atol=1e-12 * np.max(np.abs(values)))
    else:
        bic, waxis = result
        ref = np.loadtxt(REFERENCE / row["bic_file"], delimiter=",")
        np.testing.assert_allclose(bic, ref, rtol=1e-10, atol=1e-12 * np.max(ref))
        value, f_row, f_col = hosa.bicoher_peak(bic, waxis)
        assert value == pytest.approx(float(row["max_value"]), rel=1e-10)
        assert (f_row, f_col) == (float(row["f_row"]), float(row["f_col"]))


def best_time(fn: Callable[[], Any], repeat: int = 7, target: float = 0.02) -> float:
    """timeit best-of-``repeat``, each repeat running about ``target`` seconds."""
    number, _ = timeit.Timer(fn).autorange()
    t1 = timeit.Timer(fn).timeit(number) / number
    number = max(1, int(target / max(t1, 1e-9)))
    return min(timeit.Timer(fn).repeat(repeat=repeat, number=number)) / number


# ----------------------------------------------------------------- per row
@pytest.mark.parametrize("row", ROWS or [None], ids=[r["case"] for r in ROWS] or ["absent"])
def test_row(benchmark, row: dict[str, str] | None) -> None:
    assert row is not None
    fn, args = parse_call(row["call"], load_signals(row["signal"]))
    fn(*args)                                               # warm up
    t1 = best_time(lambda: fn(*args), repeat=1, target=0.005)
    iterations = max(1, int(0.002 / max(t1, 1e-9)))
    benchmark.extra_info["octave_best_s"] = float(row["octave_best_s"])
    result = benchmark.pedantic(fn, args=tuple(args), rounds=25, iterations=iterations,
                                warmup_rounds=1)
    check_row(row, result)
    stats = getattr(benchmark, "stats", None)
    if stats is not None and getattr(stats, "stats", None) is not None:
        TIMES[row["case"]] = float(stats.stats.min)
    else:                                                   # --benchmark-disable
        TIMES[row["case"]] = best_time(lambda: fn(*args))


def test_summary_vs_octave() -> None:
    assert ROWS
    lines = [f"{'case':<28} {'call':<30} {'ours ms':>9} {'octave ms':>10} {'speed-up':>9}"]
    ratios = []
    for row in ROWS:
        case = row["case"]
        if case not in TIMES:                               # run alone: measure here
            fn, args = parse_call(row["call"], load_signals(row["signal"]))
            check_row(row, fn(*args))
            TIMES[case] = best_time(lambda fn=fn, args=args: fn(*args))
        ours = TIMES[case]
        octave = float(row["octave_best_s"])
        ratios.append(octave / ours)
        lines.append(f"{case:<28} {row['call']:<30} {ours * 1e3:9.3f} {octave * 1e3:10.3f} "
                     f"{octave / ours:8.1f}x")
    lines.append(f"median speed-up over Octave: {statistics.median(ratios):.1f}x "
                 f"(min {min(ratios):.1f}x, max {max(ratios):.1f}x, {len(ratios)} calls)")
    print("\n" + "\n".join(lines))


# ------------------------------------------------------------ naive numpy
def naive_tder(x: np.ndarray, y: np.ndarray, max_delay: int) -> tuple[float, np.ndarray]:
    """tder with defaults, one segment at a time (scipy detrend, full complex FFTs)."""
    seg = int(2 ** np.ceil(np.log2(4 * max_delay + 1)))
    nov = seg // 2
    nfft = seg
    step = seg - nov
    nseg = (x.size - nov) // step
    w = 0.5 * (1 - np.cos(2 * np.pi * np.arange(1, seg + 1) / (seg + 1)))
    sxy = np.zeros(nfft, complex)
    sxx = np.zeros(nfft)
    syy = np.zeros(nfft)
    for k in range(nseg):
        xs = scipy.signal.detrend(x[k * step : k * step + seg]) * w
        ys = scipy.signal.detrend(y[k * step : k * step + seg]) * w
        fx = np.fft.fft(xs, nfft)
        fy = np.fft.fft(ys, nfft)
        sxy += fy * np.conj(fx)
        sxx += np.abs(fx) ** 2
        syy += np.abs(fy) ** 2
    h = nfft // 2 + 1
    c = np.abs(sxy[:h]) ** 2 / (sxx[:h] * syy[:h])
    r = c / (1 - c) * np.exp(1j * np.angle(sxy[:h]))
    r[0] = 0
    full = np.concatenate([r, np.conj(r[-2:0:-1])])
    rxy = np.fft.fftshift(np.real(np.fft.ifft(full)))
    d = int(np.argmax(np.abs(rxy)))
    delay = d - nfft / 2 - 0.5 - (rxy[d] - rxy[d - 1]) / (rxy[d + 1] - 2 * rxy[d] + rxy[d - 1])
    return delay, rxy


def naive_tde(x: np.ndarray, y: np.ndarray, m: int, nsamp: int) -> tuple[int, np.ndarray]:
    """tde with cumulant sums by a loop over records, s and lags (one dot product each)."""
    n = x.size
    rxxx = np.zeros((3, 4 * m + 1))
    rxyx = np.zeros((3, 2 * m + 1))
    for r in range(n // nsamp):
        xs = x[r * nsamp : (r + 1) * nsamp]
        ys = y[r * nsamp : (r + 1) * nsamp]
        xs = xs - xs.mean()
        ys = ys - ys.mean()
        for si, s in enumerate((-1, 0, 1)):
            for tau in range(-2 * m, 2 * m + 1):
                lo = max(0, -s, tau)
                hi = min(nsamp, nsamp - s, nsamp + tau)
                z = xs[lo:hi] * xs[lo + s : hi + s]
                rxxx[si, tau + 2 * m] += z @ xs[lo - tau : hi - tau]
                if abs(tau) <= m:
                    rxyx[si, tau + m] += z @ ys[lo - tau : hi - tau]
    rxxx /= n
    rxyx /= n
    a = np.zeros((2 * m + 1, 2 * m + 1))
    b = np.zeros(2 * m + 1)
    for si in range(3):
        col = rxxx[si, 2 * m :]                     # Rxxx(i - j) for i >= j
        row = rxxx[si, 2 * m :: -1]                 # Rxxx(i - j) for i <= j
        t = scipy.linalg.toeplitz(col, row)
        a += t.T @ t
        b += t.T @ rxyx[si]
    avec = np.linalg.solve(a, b)[::-1]
    return int(np.argmax(np.abs(avec))) - m, avec


def naive_bicoher(x: np.ndarray, nfft: int, nsamp: int, overlap: float):
    """bicoher one segment at a time with full (nfft, nfft) products."""
    nov = int(nsamp * overlap / 100)
    step = nsamp - nov
    nrec = (x.size - nov) // step
    w = 0.5 * (1 - np.cos(2 * np.pi * np.arange(1, nsamp + 1) / (nsamp + 1)))
    k = np.arange(nfft)
    kl = (k[:, None] + k[None, :]) % nfft
    p = np.zeros(nfft)
    b = np.zeros((nfft, nfft), complex)
    for r in range(nrec):
        s = x[r * step : r * step + nsamp]
        f = np.fft.fft((s - s.mean()) * w, nfft) / nsamp
        p += np.abs(f) ** 2
        b += np.outer(f, f) * np.conj(f[kl])
    p /= nrec
    b /= nrec
    bic = np.abs(b) ** 2 / (p[:, None] * p[None, :] * p[kl])
    return np.fft.fftshift(bic), (k - nfft // 2) / nfft


NAIVE = {
    "tder(x, y, 30)": (lambda x, y: hosa.tder(x, y, 30), lambda x, y: naive_tder(x, y, 30)),
    "tde(x, y, 30)": (lambda x, y: hosa.tde(x, y, 30), lambda x, y: naive_tde(x, y, 30, x.size)),
    "tde(x, y, 30, 128)": (lambda x, y: hosa.tde(x, y, 30, 128),
                           lambda x, y: naive_tde(x, y, 30, 128)),
    "bicoher(x, 128, [], 128, 50)": (lambda x, y: hosa.bicoher(x, 128, [], 128, 50),
                                     lambda x, y: naive_bicoher(x, 128, 128, 50)),
}
NAIVE_RATIOS: dict[str, tuple[float, float]] = {}


@pytest.mark.parametrize("call", list(NAIVE))
def test_vs_naive_numpy(benchmark, call: str) -> None:
    sig = load_signals("syn2_u3arma_d16")
    x, y = sig["x"], sig["y"]
    ours_fn, naive_fn = NAIVE[call]
    ours = ours_fn(x, y)
    naive = naive_fn(x, y)
    assert ours[0] == pytest.approx(naive[0], abs=1e-9)
    np.testing.assert_allclose(ours[1], naive[1], rtol=1e-9,
                               atol=1e-12 * np.max(np.abs(naive[1])))
    t_ours = best_time(lambda: ours_fn(x, y))
    t_naive = best_time(lambda: naive_fn(x, y), repeat=3)
    NAIVE_RATIOS[call] = (t_ours, t_naive)
    benchmark.extra_info.update(naive_s=t_naive, ours_s=t_ours, ratio=t_naive / t_ours)
    benchmark.pedantic(ours_fn, args=(x, y), rounds=10, iterations=1)
    print(f"\n{call:<30} ours {t_ours * 1e3:8.3f} ms   naive numpy {t_naive * 1e3:8.3f} ms"
          f"   speed-up {t_naive / t_ours:6.1f}x")
