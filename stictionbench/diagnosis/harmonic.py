"""Thomson's harmonic F-test: is there a sinusoid (a line) in what the nominal model
leaves unexplained?

A periodic external disturbance leaves a line in the nominal residual; a drifting load,
measurement noise and the slow wander of a random walk leave a smooth spectrum. The
multitaper harmonic F-test (Thomson 1982) tells the two apart by the phase coherence of
the ``K`` Slepian-taper eigencoefficients at one frequency: a line has the same complex
amplitude under every taper, smooth noise does not. Under a spectrum that is locally
flat across the taper bandwidth ``±W`` (``W = NW/(N·Ts)``), the statistic is ``F(2,
2K − 2)`` at a given frequency, whatever the noise's colour elsewhere.

:func:`line_test` scans the oscillatory disturbance's search range, keeps the frequency
of the largest statistic and corrects its p-value for the scan (Bonferroni over every
grid frequency tested, valid whatever their dependence; over the range's Rayleigh
frequencies alone it is not: on white noise the corrected p fell below 0.05 on 14 % of
300 series, the F statistic at neighbouring frequencies decorrelating faster than the
taper bandwidth suggests). Defaults are the method's published ones:
``NW = 4``, ``K = 2NW − 1 = 7`` tapers.

References
----------
D. J. Thomson, "Spectrum estimation and harmonic analysis", Proc. IEEE 70 (1982)
1055–1096, §XIII; D. B. Percival & A. T. Walden, *Spectral Analysis for Physical
Applications* (1993), §10.11, eqs. (499a)–(499c).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.fft import next_fast_len, rfft
from scipy.signal.windows import dpss
from scipy.stats import f as f_dist

#: time–half-bandwidth product and its number of tapers (Thomson 1982; Percival &
#: Walden 1993, §10.11 use the same)
NW = 4.0
#: frequency-grid oversampling against the Rayleigh resolution ``1/(N·Ts)``
OVERSAMPLE = 4


def harmonic_f(x: np.ndarray, Ts: float, nw: float = NW,
               oversample: int = OVERSAMPLE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Thomson's harmonic F statistic on a grid of frequencies.

    Parameters
    ----------
    x : ndarray
        The series (its mean is removed).
    Ts : float
        Sample time (s).
    nw : float
        Time–half-bandwidth product; ``K = round(2·nw) − 1`` tapers.
    oversample : int
        The grid's density in multiples of ``N`` (zero-padded FFT).

    Returns
    -------
    freqs, F, p : ndarray
        Frequencies (Hz) from 0 to Nyquist, the statistic and its single-frequency
        p-value under ``F(2, 2K − 2)``.

    References
    ----------
    Percival & Walden (1993), eq. (499a): ``F = (K − 1)|Ĉ|² ΣH_k(0)² /
    Σ|J_k − Ĉ H_k(0)|²`` with ``Ĉ = ΣJ_k H_k(0) / ΣH_k(0)²``.
    """
    x = np.asarray(x, float)
    x = x - x.mean()
    n = x.size
    k = int(round(2 * nw)) - 1
    if n < 4 * k or k < 2:
        raise ValueError(f"harmonic_f needs at least {4 * max(k, 2)} samples, got {n}")
    tapers = dpss(n, nw, k)
    h0 = tapers.sum(axis=1)
    nfft = next_fast_len(max(1, oversample) * n)
    j = rfft(tapers * x[None, :], nfft, axis=1)
    c = (j * h0[:, None]).sum(axis=0) / np.sum(h0 * h0)
    resid = np.sum(np.abs(j - c[None, :] * h0[:, None]) ** 2, axis=0)
    stat = (k - 1) * np.abs(c) ** 2 * np.sum(h0 * h0) / np.maximum(resid, 1e-300)
    freqs = np.arange(stat.size) / (nfft * Ts)
    return freqs, stat, f_dist.sf(stat, 2, 2 * k - 2)


@dataclass(frozen=True)
class LineTest:
    """The outcome of :func:`line_test`."""

    frequency_hz: float
    statistic: float
    p_single: float
    n_frequencies: float
    p_value: float
    bandwidth_hz: float
    nw: float
    range_hz: tuple[float, float]
    #: the scanned grid's frequencies (Hz) and single-frequency p-values
    grid_hz: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    grid_p: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def period_s(self) -> float:
        return 1.0 / self.frequency_hz

    def significant(self, alpha: float) -> bool:
        """Whether the scan's corrected p-value is below ``alpha``."""
        return self.p_value < alpha

    def matches(self, period_s: float | None) -> bool:
        """Whether a fitted period is this line: within the taper bandwidth ``±W``."""
        if period_s is None or not period_s > 0:
            return False
        return abs(1.0 / period_s - self.frequency_hz) <= self.bandwidth_hz

    def p_at(self, period_s: float | None) -> float:
        """The scan-corrected p-value at the grid frequency nearest ``1/period_s`` (1 off
        the scanned range): the Bonferroni bound covers every grid frequency, so it holds
        for a frequency chosen from the data, such as a fitted disturbance's."""
        if period_s is None or not period_s > 0 or not self.grid_hz.size:
            return 1.0
        f = 1.0 / period_s
        lo, hi = self.range_hz
        if f < lo - self.bandwidth_hz or f > hi + self.bandwidth_hz:
            return 1.0
        i = int(np.argmin(np.abs(self.grid_hz - f)))
        return float(min(1.0, self.grid_p[i] * self.n_frequencies))

    def to_dict(self) -> dict[str, Any]:
        return {"period_s": self.period_s, "frequency_hz": self.frequency_hz,
                "statistic": self.statistic, "p_single": self.p_single,
                "n_frequencies": self.n_frequencies, "p_value": self.p_value,
                "bandwidth_hz": self.bandwidth_hz, "nw": self.nw,
                "range_hz": list(self.range_hz), "method": "thomson_harmonic_f"}


def line_test(x: np.ndarray, Ts: float, f_lo: float, f_hi: float,
              nw: float = NW) -> LineTest | None:
    """The strongest line of ``x`` between ``f_lo`` and ``f_hi`` (Hz) by Thomson's
    harmonic F-test, its p-value Bonferroni-corrected for the scan (see the module
    docstring); ``None`` when the range holds no grid frequency at least ``2W`` from 0
    (closer, the tapers' band reaches the mean and the test's flat-spectrum premise
    fails) or the series is too short.

    Parameters
    ----------
    x : ndarray
        The series, e.g. the nominal residual after the burn-in.
    Ts : float
        Sample time (s).
    f_lo, f_hi : float
        The scanned range (Hz).
    nw : float
        Time–half-bandwidth product (default :data:`NW`).

    Returns
    -------
    LineTest or None
    """
    x = np.asarray(x, float)
    n = x.size
    if n < 4 * (int(round(2 * nw)) - 1):
        return None
    w = nw / (n * Ts)
    lo, hi = max(float(f_lo), 2.0 * w), min(float(f_hi), 0.5 / Ts)
    freqs, stat, p = harmonic_f(x, Ts, nw)
    inside = np.flatnonzero((freqs >= lo) & (freqs <= hi))
    if not inside.size:
        return None
    i = int(inside[np.argmax(stat[inside])])
    n_freq = float(inside.size)
    return LineTest(float(freqs[i]), float(stat[i]), float(p[i]), float(n_freq),
                    float(min(1.0, p[i] * n_freq)), float(w), float(nw),
                    (float(lo), float(hi)), freqs[inside], p[inside])
