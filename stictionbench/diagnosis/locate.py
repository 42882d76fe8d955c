"""Locating a mismatch in time (windows where the residual rises above the noise floor)
and in frequency (residual spectrum against the noise floor, coherence with OP)."""

from __future__ import annotations

import numpy as np
from scipy.signal import coherence, periodogram, welch


def noise_floor(r: np.ndarray) -> float:
    """Standard deviation of the white part of a residual: robust (MAD) scale of its
    first differences divided by √2; smooth model errors barely enter it."""
    d = np.diff(r)
    mad = np.median(np.abs(d - np.median(d)))
    return float(1.4826 * mad / np.sqrt(2.0))


def rolling_rms(r: np.ndarray, w: int) -> np.ndarray:
    w = max(1, min(w, r.size))
    c = np.cumsum(np.r_[0.0, r * r])
    ms = (c[w:] - c[:-w]) / w
    pad_l = (w - 1) // 2
    out = np.empty(r.size)
    out[pad_l: pad_l + ms.size] = np.sqrt(ms)
    out[:pad_l] = out[pad_l]
    out[pad_l + ms.size:] = out[pad_l + ms.size - 1]
    return out


def mismatch_windows(t: np.ndarray, r: np.ndarray, sigma: float, w: int,
                     factor: float = 2.0, start: int = 0) -> list[list[float]]:
    """Time windows ``[t0, t1]`` where the rolling RMS of ``r`` exceeds ``factor·σ``
    (merged when closer than ``w`` samples, at least ``w`` samples long)."""
    rms = rolling_rms(r, w)
    above = rms > factor * max(sigma, 1e-300)
    above[:start] = False
    idx = np.flatnonzero(above)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > w)
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]]
    return [[float(t[a]), float(t[b])] for a, b in zip(starts, ends, strict=True)
            if b - a + 1 >= w]


def mismatch_band(r: np.ndarray, Ts: float, sigma: float, op: np.ndarray | None = None,
                  excess: float = 4.0) -> tuple[list[float], dict]:
    """Frequency band (Hz) around the largest excess of the residual PSD over the white
    noise floor ``2σ²Ts`` (one-sided); empty when nothing exceeds ``excess``× the floor.
    Also returns the spectrum and the residual–OP coherence for reporting, and
    ``open_below``: the band reaches the lowest frequency the Welch segments resolve
    (``1/(nperseg·Ts)``), so its lower edge is that resolution, and the excess may extend
    to slower periods than the band says."""
    nper = int(min(256, max(16, r.size // 4)))
    f, P = welch(r, fs=1.0 / Ts, nperseg=nper, detrend="constant")
    floor = 2.0 * sigma * sigma * Ts
    info: dict = {"f": f, "psd": P, "floor": floor}
    if op is not None:
        # a spectrum exactly zero at a frequency (OP held flat, e.g. at a travel limit,
        # through a whole segment) gives 0/0 there: NaN, reported as such, not a warning
        with np.errstate(invalid="ignore", divide="ignore"):
            fc, C = coherence(r, op, fs=1.0 / Ts, nperseg=nper)
        info["coherence_f"] = fc
        info["coherence"] = C
    ratio = P / max(floor, 1e-300)
    ratio[0] = 0.0
    k = int(np.argmax(ratio))
    if ratio[k] < excess:
        return [], info
    lo = k
    while lo > 1 and ratio[lo - 1] >= excess:
        lo -= 1
    hi = k
    while hi < f.size - 1 and ratio[hi + 1] >= excess:
        hi += 1
    band = [float(f[max(lo - 1, 0)] if lo > 1 else f[lo]), float(f[min(hi + 1, f.size - 1)])]
    info["open_below"] = bool(lo <= 1)
    if op is not None:
        sel = (info["coherence_f"] >= band[0]) & (info["coherence_f"] <= band[1])
        info["band_coherence"] = float(np.mean(info["coherence"][sel])) if sel.any() else None
    return band, info


def _psd(x: np.ndarray, Ts: float) -> tuple[np.ndarray, np.ndarray]:
    """Welch PSD of a signal with segments of a third of it (16 to 512 samples)."""
    return welch(x, fs=1.0 / Ts, nperseg=int(min(512, max(16, x.size // 3))))


def dominant_periods(r: np.ndarray, Ts: float, n: int = 3) -> list[float]:
    """Periods (s) of the ``n`` largest local maxima of the residual's Welch PSD."""
    f, P = _psd(r, Ts)
    peaks = [i for i in range(1, f.size - 1) if P[i] >= P[i - 1] and P[i] >= P[i + 1]]
    peaks.sort(key=lambda i: -P[i])
    return [float(1.0 / f[i]) for i in peaks[:n] if f[i] > 0]


def tone_periods(r: np.ndarray, rows: np.ndarray, Ts: float, lo: float, hi: float,
                 n: int = 3, pad: int = 8) -> list[float]:
    """Periods (s, within ``[lo, hi]``) of the ``n`` largest peaks of the periodogram of
    ``r`` on the sample indices ``rows`` (other samples zeroed), zero-padded ``pad``-fold.

    The least-squares fit of one sinusoid has a cost basin about ``1/T`` wide in
    frequency (``T`` the span of ``rows``); the periodogram's peak is its maximum-
    likelihood frequency (Rife & Boorstyn, IEEE Trans. Inf. Theory 20(5), 1974), to a
    fraction ``1/pad`` of a bin, which a smoothed (Welch) spectrum cannot resolve.
    """
    x = np.zeros(r.size)
    x[rows] = r[rows] - np.mean(r[rows])
    f, P = periodogram(x, fs=1.0 / Ts, window="boxcar", nfft=pad * r.size,
                       detrend=False)
    ok = (f >= 1.0 / hi) & (f <= 1.0 / lo)
    idx = np.flatnonzero(ok[1:-1] & (P[1:-1] >= P[:-2]) & (P[1:-1] >= P[2:])) + 1
    idx = idx[np.argsort(-P[idx])][:n]
    return [float(1.0 / f[i]) for i in idx]


def oscillation_frequency(x: np.ndarray, Ts: float, min_ratio: float = 10.0) -> float | None:
    """Frequency (Hz) of the largest local maximum of the Welch PSD of ``x`` when it stands
    at least ``min_ratio`` times above the median PSD (a clear oscillation), else ``None``.
    The peak must also stand three times above the PSD at and below half its frequency: a
    drifting load's red spectrum rises towards low frequencies without any oscillation
    (and the two lowest bins, periods of half the Welch segment or more, are not
    candidates).

    Examples
    --------
    >>> t = np.arange(3000.0)
    >>> noise = np.random.default_rng(0).standard_normal(3000)
    >>> x = np.sign(np.sin(2 * np.pi * t / 125)) + 0.1 * noise
    >>> round(1 / oscillation_frequency(x, 1.0))
    128
    >>> oscillation_frequency(np.random.default_rng(1).standard_normal(3000), 1.0) is None
    True
    >>> walk = np.cumsum(np.random.default_rng(2).standard_normal(3000))  # red, no line
    >>> oscillation_frequency(walk - walk.mean(), 1.0) is None
    True
    """
    f, P = _psd(x, Ts)
    peaks = np.flatnonzero((P[2:-1] >= P[1:-2]) & (P[2:-1] >= P[3:])) + 2
    if peaks.size == 0:
        return None
    i = int(peaks[np.argmax(P[peaks])])
    clear = P[i] >= min_ratio * float(np.median(P[1:]))
    isolated = P[i] >= 3.0 * float(np.max(P[1: i // 2 + 1]))
    return float(f[i]) if clear and isolated else None
