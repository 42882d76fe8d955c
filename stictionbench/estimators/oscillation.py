"""Oscillation detection from the zero crossings of the autocorrelation function.

Thornhill, Huang & Zhang (2003): a regular oscillation makes the autocorrelation
function (ACF) of a signal cross zero at nearly equal intervals of half a period. The
mean of the periods ``Tp = 2·interval`` gives the oscillation period and the spread of
the periods its regularity ``r = mean(Tp) / (3·std(Tp))``; ``r > 1`` means "regular
oscillation".

The module also holds the two small helpers the other spectral estimators share:
:func:`bandpass` (zero-phase Butterworth) and :func:`dominant_frequency`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real
from typing import ClassVar

import numpy as np
from scipy import signal as sps

from ..errors import InputError
from ..recording import Recording
from ..validation import Band, Constraint, Interval, TypeOf, check_signal
from .base import EstimateResult, Estimator

#: fewest samples the ACF method accepts
MIN_SAMPLES = 32


# --------------------------------------------------------------------------- helpers
def bandpass(x: np.ndarray, band: tuple[float, float], order: int = 2) -> np.ndarray:
    """Zero-phase Butterworth band-pass filter.

    Parameters
    ----------
    x : ndarray
        Signal (1-D).
    band : (float, float)
        Pass band ``(f_lo, f_hi)`` as fractions of the sampling frequency,
        ``0 <= f_lo < f_hi <= 0.5``. ``f_lo = 0`` gives a low-pass and
        ``f_hi = 0.5`` a high-pass filter.
    order : int
        Order of the Butterworth prototype; :func:`scipy.signal.sosfiltfilt` runs it
        forwards and backwards, so the magnitude response is squared and the phase zero.

    Returns
    -------
    ndarray
        The filtered signal, same length as ``x``.

    Raises
    ------
    InputError
        When the band is not inside ``[0, 0.5]`` or is empty.

    Examples
    --------
    >>> import numpy as np
    >>> n = np.arange(2000)
    >>> x = np.sin(2 * np.pi * 0.02 * n) + np.sin(2 * np.pi * 0.3 * n)
    >>> y = bandpass(x, (0.01, 0.04))
    >>> bool(np.std(y[200:-200]) < 0.75)
    True
    """
    sos = _butter_sos(band, order)
    x = np.asarray(x, dtype=float)
    if sos is None:
        return x.copy()
    # Pad by about three periods of the lowest pass frequency to tame edge transients.
    padlen = 3 * (2 * sos.shape[0] + 1)
    if band[0] > 0.0:
        padlen = max(padlen, int(math.ceil(3.0 / float(band[0]))))
    padlen = min(x.size - 1, padlen)
    return sps.sosfiltfilt(sos, x, padlen=padlen)


def bandpass_gain(band: tuple[float, float], f: float, order: int = 2) -> float:
    """Gain of :func:`bandpass` at frequency ``f`` (fraction of the sampling frequency).

    The filter runs forwards and backwards, so the gain is ``|H(f)|²`` and the phase 0.

    Examples
    --------
    >>> round(bandpass_gain((0.01, 0.04), 0.02), 6)
    1.0
    """
    sos = _butter_sos(band, order)
    if sos is None:
        return 1.0
    _, h = sps.sosfreqz(sos, worN=[float(f)], fs=1.0)
    return float(np.abs(h[0]) ** 2)


def _butter_sos(band: tuple[float, float], order: int) -> np.ndarray | None:
    """Second-order sections of the Butterworth filter for ``band``; None: all-pass."""
    f_lo, f_hi = (float(band[0]), float(band[1]))
    if not (0.0 <= f_lo < f_hi <= 0.5):
        raise InputError(
            f"band-pass band ({f_lo:g}, {f_hi:g}) must satisfy 0 <= f_lo < f_hi <= 0.5 "
            "(fractions of the sampling frequency)"
        )
    if not (isinstance(order, (int, np.integer)) and order >= 1):
        raise InputError(f"band-pass order={order!r} must be a positive integer")
    # Normalised to Nyquist for scipy; keep edges strictly inside (0, 1).
    lo, hi = 2.0 * f_lo, 2.0 * f_hi
    if lo <= 0.0 and hi >= 1.0:
        return None
    if lo <= 0.0:
        return sps.butter(order, min(hi, 0.999), btype="lowpass", output="sos")
    if hi >= 1.0:
        return sps.butter(order, lo, btype="highpass", output="sos")
    return sps.butter(order, [lo, hi], btype="bandpass", output="sos")


def _acf(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Biased autocorrelation (normalised to 1 at lag 0) of a zero-mean signal via FFT."""
    n = x.size
    nfft = 1 << int(math.ceil(math.log2(2 * n - 1)))
    spec = np.fft.rfft(x, nfft)
    r = np.fft.irfft(spec * np.conj(spec), nfft)[: max_lag + 1]
    return r / r[0]


def _zero_crossings(r: np.ndarray) -> np.ndarray:
    """Linearly interpolated lags (fractional samples) where ``r`` changes sign."""
    pos = r > 0.0
    i = np.flatnonzero(pos[:-1] != pos[1:])
    return i + r[i] / (r[i] - r[i + 1])


def dominant_frequency(x: np.ndarray, nperseg: int | None = None) -> float:
    """Frequency of the largest Welch power-spectrum peak, excluding DC.

    Parameters
    ----------
    x : ndarray
        Signal.
    nperseg : int, optional
        Welch segment length; default ``min(N, 1024)``.

    Returns
    -------
    float
        Peak frequency as a fraction of the sampling frequency, refined by a
        three-point parabola on the log spectrum.

    Examples
    --------
    >>> import numpy as np
    >>> n = np.arange(4096)
    >>> round(dominant_frequency(np.sin(2 * np.pi * n / 64)), 3)
    0.016
    """
    x = np.asarray(x, dtype=float)
    x = sps.detrend(x)
    nper = int(nperseg or min(x.size, 1024))
    f, p = sps.welch(x, nperseg=nper, detrend="linear")
    k = 1 + int(np.argmax(p[1:]))
    if 1 < k < p.size - 1 and np.all(p[k - 1 : k + 2] > 0):
        a, b, c = np.log(p[k - 1 : k + 2])
        den = a - 2.0 * b + c
        delta = 0.5 * (a - c) / den if den != 0 else 0.0
        return float(f[k] + delta * (f[1] - f[0]))
    return float(f[k])


# --------------------------------------------------------------------------- the method
@dataclass(frozen=True)
class AcfOscillation:
    """Result of :func:`acf_oscillation`.

    Attributes
    ----------
    oscillating : bool
        ``regularity > r_threshold``, at least ``min_crossings`` zero crossings and a
        period of at least ``min_period`` samples.
    period : float
        Mean period in seconds (``Ts`` × ``period_samples``); NaN with too few crossings.
    period_samples : float
        Mean period in samples.
    regularity : float
        ``mean(Tp) / (3·std(Tp))``; ``inf`` for perfectly equal intervals, NaN with too
        few crossings.
    n_crossings : int
        Zero crossings used (at most ``max_crossings``).
    crossings : ndarray
        Interpolated lags (samples) of the crossings used.
    periods : ndarray
        ``Tp_i = 2·(crossing_{i+1} − crossing_i)`` in samples.
    acf : ndarray
        The ACF at lags ``0 .. max_lag``.
    acf_peak : float
        ACF at its first positive peak after lag 0 (≈ one period); NaN if none.
    acf_decay : float
        Ratio of the second positive ACF peak (≈ two periods) to the first; NaN if
        either is absent. Near 1 for a sustained oscillation, small for a decaying one.
    """

    oscillating: bool
    period: float
    period_samples: float
    regularity: float
    n_crossings: int
    crossings: np.ndarray
    periods: np.ndarray
    acf: np.ndarray
    acf_peak: float
    acf_decay: float


def _positive_peaks(r: np.ndarray, crossings: np.ndarray, count: int) -> list[float]:
    """Maxima of ``r`` in its positive lobes after the first (≈ 1, 2, ... periods)."""
    peaks: list[float] = []
    # r starts positive; lobes between crossings (z0, z1) are negative, (z1, z2)
    # positive (≈ one period), (z3, z4) positive (≈ two periods), ...
    for j in range(1, crossings.size - 1, 2):
        lo = int(math.ceil(crossings[j]))
        hi = int(math.floor(crossings[j + 1])) + 1
        if hi > lo:
            peaks.append(float(np.max(r[lo:hi])))
        if len(peaks) == count:
            break
    return peaks


def acf_oscillation(
    x: np.ndarray,
    Ts: float = 1.0,
    *,
    band: tuple[float, float] | None = None,
    detrend: bool = True,
    max_lag: int | None = None,
    max_crossings: int = 10,
    min_crossings: int = 4,
    r_threshold: float = 1.0,
    min_period: float = 4.0,
) -> AcfOscillation:
    """Detect a regular oscillation from the zero crossings of the ACF.

    Steps (Thornhill, Huang & Zhang 2003, section 3): remove the mean (and a straight
    line when ``detrend``), optionally band-pass filter, compute the ACF through the
    FFT, find its zero crossings by linear interpolation and keep the first
    ``max_crossings``. Successive crossings are half a period apart, so the period
    estimates are ``Tp_i = 2·(z_{i+1} − z_i)``; then

    ``Tp = mean(Tp_i)``, ``r = Tp / (3·σ_Tp)``,

    and the signal is called oscillating when ``r > r_threshold`` (1 in the paper), at
    least ``min_crossings`` crossings were found and the period is at least
    ``min_period`` samples. The last condition is ours: the ACF of white noise crosses
    zero about every two samples, and its rare "regular" runs have periods of 2–4
    samples; an oscillation sampled fewer than four times a cycle is not resolved.

    Parameters
    ----------
    x : ndarray
        Signal (1-D, finite, not constant, at least 32 samples).
    Ts : float
        Sample time in seconds; only scales ``period``.
    band : (float, float), optional
        Band-pass ``(f_lo, f_hi)`` in fractions of the sampling frequency applied
        before the ACF (the paper filters out noise and slow trends first).
    detrend : bool
        Remove a least-squares straight line rather than only the mean.
    max_lag : int, optional
        Largest ACF lag searched for crossings; default ``N // 2`` (the biased
        estimate grows unreliable beyond).
    max_crossings : int
        Crossings used (the paper uses the first ten).
    min_crossings : int
        Fewer crossings than this: "not oscillating", period NaN.
    r_threshold : float
        Regularity threshold.
    min_period : float
        Shortest period (samples) accepted as an oscillation.

    Returns
    -------
    AcfOscillation

    Raises
    ------
    InputError
        On a non-finite, constant or too short signal or bad parameters.

    References
    ----------
    N. F. Thornhill, B. Huang, H. Zhang, "Detection of multiple oscillations in control
    loops", J. Process Control 13 (2003) 91–100 (regularity factor ``r``).

    Examples
    --------
    >>> import numpy as np
    >>> n = np.arange(2000)
    >>> res = acf_oscillation(np.sin(2 * np.pi * n / 50), Ts=0.5)
    >>> res.oscillating, round(res.period, 2)
    (True, 25.0)
    """
    x = check_signal(x, "oscillation input", min_len=MIN_SAMPLES)
    if not Ts > 0:
        raise InputError(f"oscillation: sample time Ts={Ts!r} must be positive")
    if min_crossings < 3 or max_crossings < min_crossings:
        raise InputError(
            f"oscillation: need 3 <= min_crossings <= max_crossings, got "
            f"{min_crossings}, {max_crossings}"
        )
    x = sps.detrend(x, type="linear" if detrend else "constant")
    if band is not None:
        x = bandpass(x, band)
        x = x - x.mean()
    n = x.size
    lag = n // 2 if max_lag is None else int(max_lag)
    if not 2 <= lag < n:
        raise InputError(f"oscillation: max_lag={max_lag} must be in [2, {n - 1}]")
    if not np.any(x):
        raise InputError("oscillation input: nothing left after detrending/filtering")
    r = _acf(x, lag)
    z_all = _zero_crossings(r)
    z = z_all[:max_crossings]
    nan = float("nan")
    if z.size < min_crossings:
        return AcfOscillation(False, nan, nan, nan, int(z.size), z, np.empty(0), r, nan, nan)
    tp = 2.0 * np.diff(z)
    mean_tp = float(tp.mean())
    sd = float(tp.std(ddof=1))
    reg = mean_tp / (3.0 * sd) if sd > 0 else math.inf
    peaks = _positive_peaks(r, z_all, 2)
    peak1 = peaks[0] if peaks else nan
    decay = peaks[1] / peaks[0] if len(peaks) == 2 and peaks[0] > 0 else nan
    return AcfOscillation(
        oscillating=bool(reg > r_threshold and mean_tp >= min_period),
        period=mean_tp * Ts,
        period_samples=mean_tp,
        regularity=reg,
        n_crossings=int(z.size),
        crossings=z,
        periods=tp,
        acf=r,
        acf_peak=peak1,
        acf_decay=decay,
    )


class Oscillation(Estimator):
    """Regular-oscillation detector (ACF zero crossings, Thornhill et al. 2003).

    ``value`` is the mean oscillation period in seconds (NaN with too few ACF zero
    crossings); ``decision`` is "oscillating": regularity ``r > r_threshold`` with at
    least ``min_crossings`` crossings and a period of at least ``min_period`` samples.
    See :func:`acf_oscillation` for the steps.

    Parameters
    ----------
    band : (float, float), optional
        Band-pass before the ACF, fractions of the sampling frequency; default none.
    detrend : bool
        Remove a straight line (else only the mean).
    max_lag : int, optional
        Largest ACF lag searched; default half the record.
    max_crossings : int
        Zero crossings used (10, as in the paper).
    min_crossings : int
        Fewer crossings → not oscillating.
    r_threshold : float
        Regularity threshold (1, as in the paper).
    min_period : float
        Shortest period in samples accepted as an oscillation (4).
    """

    name = "oscillation"
    default_x = "PV"
    default_y = None

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "band": [Band(0, 0.5), None],
        "detrend": [TypeOf(bool)],
        "max_lag": [Interval(Integral, 2, None), None],
        "max_crossings": [Interval(Integral, 2, None)],
        "min_crossings": [Interval(Integral, 2, None)],
        "r_threshold": [Interval(Real, 0, None)],
        "min_period": [Interval(Real, 2, None)],
    }

    def __init__(
        self,
        band: tuple[float, float] | None = None,
        detrend: bool = True,
        max_lag: int | None = None,
        max_crossings: int = 10,
        min_crossings: int = 4,
        r_threshold: float = 1.0,
        min_period: float = 4.0,
    ) -> None:
        self.band = band
        self.detrend = detrend
        self.max_lag = max_lag
        self.max_crossings = max_crossings
        self.min_crossings = min_crossings
        self.r_threshold = r_threshold
        self.min_period = min_period

    def _estimate(
        self, x: np.ndarray, y: np.ndarray | None, rec: Recording
    ) -> EstimateResult:
        res = acf_oscillation(
            x,
            Ts=float(rec.Ts),
            band=None if self.band is None else tuple(self.band),
            detrend=self.detrend,
            max_lag=self.max_lag,
            max_crossings=self.max_crossings,
            min_crossings=self.min_crossings,
            r_threshold=self.r_threshold,
            min_period=self.min_period,
        )
        return EstimateResult(
            method=self.name,
            value=res.period,
            units="s",
            decision=res.oscillating,
            meaning="regular oscillation",
            diagnostics={
                "period_samples": res.period_samples,
                "regularity": res.regularity,
                "n_crossings": res.n_crossings,
                "acf_peak": res.acf_peak,
                "acf_decay": res.acf_decay,
                "r_threshold": self.r_threshold,
                "min_period": self.min_period,
                "crossings": res.crossings,
                "acf": res.acf,
            },
        )
