"""Squared bicoherence and the Choudhury–Shah–Thornhill nonlinearity test.

The test asks two questions of one signal (usually the PV or the control error of an
oscillating loop): is it non-Gaussian (NGI), and is the non-Gaussianity nonlinear, i.e.
does the squared bicoherence show peaks above a flat level (NLI)? A loop that oscillates
because of valve stiction is nonlinear; one driven by a sinusoidal disturbance or by
aggressive tuning is (to second order) linear.

Version implemented (Choudhury, Shah & Thornhill, Automatica 40 (2004), with the total
nonlinearity index of the 2006 revision):

- Kim–Powers squared bicoherence, segment averaged (``E`` over K segments)::

      bic²(f1, f2) = |E[X(f1)·X(f2)·X*(f1+f2)]|² / (E[|X(f1)·X(f2)|²] · E[|X(f1+f2)|²])

  on the principal domain ``0 < f2 <= f1``, ``f1 + f2 <= fs/2`` (DC excluded).
- Significance: ``bic² > c_α = χ²₂(α)/(2K)``; ``χ²₂(0.05) = 5.99`` is the (1 − α)
  quantile of the central χ² with two degrees of freedom (under Gaussianity,
  ``2K·bic²`` is asymptotically χ²₂).
- ``NGI = Σ_sig bic² / L − c_α``, L = number of bifrequencies in the principal domain
  (non-significant points count as zero; see ``ngi_average`` below for the other
  reading of "mean of the significant bic²").
- ``NLI = |max bic² − (mean bic² + 2·std bic²)|``, mean and std over the principal domain.
- ``TNLI = Σ_sig bic²`` (total nonlinearity index of Choudhury, Shook & Shah 2006).
- Nonlinear when ``NGI > 0.001`` and ``NLI > 0.01``; ``NGI <= 0.001``: Gaussian, hence
  linear.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real
from typing import ClassVar, Literal

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy import signal as sps
from scipy import stats

from ..errors import InputError
from ..recording import Recording
from ..validation import Band, Constraint, Interval, Options, TypeOf, check_signal
from .base import EstimateResult, Estimator
from .oscillation import acf_oscillation, bandpass

#: fewest segments the test accepts (the χ² threshold needs a few averages)
MIN_SEGMENTS = 8


def _matlab_hanning(n: int) -> np.ndarray:
    """MATLAB ``hanning(n)``: Hann window without the zero end points."""
    return sps.windows.hann(n + 2)[1:-1]


def _principal_domain(nfft: int) -> tuple[np.ndarray, np.ndarray]:
    """Bin indices ``(k, l)``: ``1 <= l <= k``, ``k + l <= nfft/2``."""
    half = nfft // 2
    k, l = np.meshgrid(np.arange(half + 1), np.arange(half + 1), indexing="ij")
    mask = (l >= 1) & (l <= k) & (k + l <= half)
    return k[mask], l[mask]


def _check_segmentation(nfft: int, overlap: float) -> tuple[int, int]:
    """Validate ``nfft`` and ``overlap``; return ``nfft`` and the segment step."""
    if not (isinstance(nfft, (int, np.integer)) and nfft >= 8 and nfft % 2 == 0):
        raise InputError(f"bicoherence: nfft={nfft!r} must be an even integer >= 8")
    if not (isinstance(overlap, (int, float, np.number)) and 0 <= overlap <= 99):
        raise InputError(f"bicoherence: overlap={overlap!r} must be in [0, 99] per cent")
    nfft = int(nfft)
    return nfft, nfft - int(math.floor(overlap / 100.0 * nfft))


def kim_powers_bicoherence(
    x: np.ndarray,
    nfft: int = 128,
    overlap: float = 50,
    *,
    window: Literal["hann", "boxcar"] = "hann",
) -> tuple[np.ndarray, np.ndarray, int]:
    """Segment-averaged squared bicoherence with the Kim–Powers normalisation.

    Each segment of ``nfft`` samples (``overlap`` per cent shared with the next) has
    its mean removed and is multiplied by the window before the FFT. With ``E`` the
    average over the K segments,

    ``bic²(k, l) = |E[X_k X_l X*_{k+l}]|² / (E[|X_k X_l|²] · E[|X_{k+l}|²])``,

    which lies in ``[0, 1]`` by the Cauchy–Schwarz inequality. It is evaluated on the
    principal domain ``1 <= l <= k``, ``k + l <= nfft/2`` only; vectorised (strided
    segments, one batched FFT, index arrays for the triple products).

    Parameters
    ----------
    x : ndarray
        Signal (1-D, finite, not constant, at least ``nfft`` samples).
    nfft : int
        Segment length and FFT length (even).
    overlap : float
        Overlap of successive segments in per cent, ``[0, 99]``.
    window : {"hann", "boxcar"}
        Segment window; ``"hann"`` is MATLAB's ``hanning(nfft)`` (no zero end points).

    Returns
    -------
    bic2 : ndarray, shape (nfft/2 + 1, nfft/2 + 1)
        ``bic2[k, l]`` at frequencies ``(freqs[k], freqs[l])``; NaN outside the
        principal domain.
    freqs : ndarray, shape (nfft/2 + 1,)
        Bin frequencies ``k/nfft`` as fractions of the sampling frequency.
    K : int
        Number of segments averaged.

    Raises
    ------
    InputError
        On bad input or parameters.

    References
    ----------
    Y. C. Kim, E. J. Powers, "Digital bispectral analysis and its applications to
    nonlinear wave interactions", IEEE Trans. Plasma Sci. 7 (1979) 120–131.
    M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, "Diagnosis of poor control-loop
    performance using higher-order statistics", Automatica 40 (2004) 1719–1728, eq. (6).

    Examples
    --------
    >>> import numpy as np
    >>> x = np.random.default_rng(0).standard_normal(4096)
    >>> bic2, f, K = kim_powers_bicoherence(x)
    >>> bic2.shape, K, bool(np.nanmax(bic2) < 0.3)
    ((65, 65), 63, True)
    """
    nfft, step = _check_segmentation(nfft, overlap)
    x = check_signal(x, "bicoherence input", min_len=nfft)
    seg = sliding_window_view(x, nfft)[::step]
    K = seg.shape[0]
    seg = seg - seg.mean(axis=1, keepdims=True)
    if window == "hann":
        seg = seg * _matlab_hanning(nfft)
    elif window != "boxcar":
        raise InputError(f"bicoherence: window={window!r} must be 'hann' or 'boxcar'")
    X = np.fft.fft(seg, axis=1) / nfft
    k, l = _principal_domain(nfft)
    X1, X2, X3 = X[:, k], X[:, l], X[:, k + l]
    X12 = X1 * X2
    num = np.abs(np.mean(X12 * np.conj(X3), axis=0)) ** 2
    den = np.mean(np.abs(X12) ** 2, axis=0) * np.mean(np.abs(X3) ** 2, axis=0)
    vals = np.divide(num, den, out=np.zeros_like(num), where=den > 0)
    half = nfft // 2
    bic2 = np.full((half + 1, half + 1), np.nan)
    bic2[k, l] = vals
    freqs = np.arange(half + 1) / nfft
    return bic2, freqs, K


@dataclass(frozen=True)
class NonlinearityIndices:
    """Result of :func:`nonlinearity_indices`.

    Attributes
    ----------
    ngi, nli, tnli : float
        Non-Gaussianity, nonlinearity and total nonlinearity indices.
    n_significant : int
        Bifrequencies with ``bic² > threshold``.
    n_points : int
        Bifrequencies in the principal domain.
    threshold : float
        Significance level ``χ²₂(α)/(2K)`` for ``bic²``.
    k_segments : int
        K, segments averaged.
    bic2_max : float
        Largest ``bic²``; ``f_max`` its bifrequency (fractions of fs).
    f_max : tuple of float
    band : tuple of float or None
        Pre-filter band used, fractions of fs.
    n_samples : int
        Samples analysed (after ``max_samples``).
    bic2, freqs : ndarray
        As returned by :func:`kim_powers_bicoherence`.
    """

    ngi: float
    nli: float
    tnli: float
    n_significant: int
    n_points: int
    threshold: float
    k_segments: int
    bic2_max: float
    f_max: tuple[float, float]
    band: tuple[float, float] | None
    n_samples: int
    bic2: np.ndarray
    freqs: np.ndarray


def auto_band(x: np.ndarray) -> tuple[float, float] | None:
    """Pre-filter band around a regular oscillation, harmonics kept.

    When :func:`~stictionbench.estimators.oscillation.acf_oscillation` finds a regular
    oscillation of period ``Tp`` samples (``f0 = 1/Tp``), the band is
    ``(f0/2, min(0.5, 10·f0))``: it removes drift below the oscillation and noise well
    above it, and keeps the harmonics up to the tenth, whose phase coupling with the
    fundamental is what the bicoherence detects (a narrow band around ``f0`` alone
    would make any oscillation look linear). When ``10·f0 >= 0.5`` only the high-pass
    part remains. Without a regular oscillation there is no band to centre on and
    None is returned (no filtering): the Kim–Powers ``bic²`` is, up to leakage,
    invariant to linear filtering, so a guessed band would only remove information.

    Parameters
    ----------
    x : ndarray
        Signal.

    Returns
    -------
    (float, float) or None
        ``(f_lo, f_hi)`` in fractions of the sampling frequency, or None.

    Examples
    --------
    >>> import numpy as np
    >>> n = np.arange(4096)
    >>> lo, hi = auto_band(np.sin(2 * np.pi * n / 100))
    >>> round(lo, 4), round(hi, 3)
    (0.005, 0.1)
    """
    osc = acf_oscillation(x)
    if not osc.oscillating:
        return None
    f0 = 1.0 / osc.period_samples
    return (0.5 * f0, min(0.5, 10.0 * f0))


def nonlinearity_indices(
    x: np.ndarray,
    nfft: int = 128,
    overlap: float = 50,
    *,
    alpha: float = 0.05,
    prefilter: tuple[float, float] | Literal["auto"] | None = None,
    detrend: bool = True,
    max_samples: int | None = 4096,
    window: Literal["hann", "boxcar"] = "hann",
    ngi_average: Literal["domain", "significant"] = "domain",
    decimate: int = 1,
) -> NonlinearityIndices:
    """NGI, NLI and TNLI of a signal from its squared bicoherence.

    Version: Choudhury, Shah & Thornhill (2004), TNLI from the 2006 revision.
    With ``c_α = χ²₂(α)/(2K)`` and the Kim–Powers ``bic²`` over the L points of the
    principal domain (:func:`kim_powers_bicoherence`):

    - ``NGI = Σ_{bic² > c_α} bic² / L − c_α``  (``ngi_average="domain"``), or
      ``NGI = mean_{bic² > c_α} bic² − c_α``  (``ngi_average="significant"``);
    - ``NLI = |max bic² − (mean bic² + 2·std bic²)|``;
    - ``TNLI = Σ_{bic² > c_α} bic²``.

    Why ``"domain"`` is the default: the mean of only the significant values exceeds
    ``c_α`` by construction (about ``c_α + 1/K`` for Gaussian data, since ``2K·bic²``
    is then exponential), so the ``"significant"`` reading makes NGI positive for any
    signal with one significant point and cannot separate Gaussian from non-Gaussian
    data. Averaging over the whole domain gives ``NGI ≈ −0.93·c_α < 0`` for Gaussian
    data and ``NGI > 0`` when the significant bicoherence outweighs the threshold —
    the behaviour the published tables show (NGI <= 0 for linear Gaussian loops).

    Parameters
    ----------
    x : ndarray
        Signal (1-D, finite, not constant).
    nfft : int
        Segment and FFT length (128 as recommended).
    overlap : float
        Segment overlap in per cent (50).
    alpha : float
        Significance level of the per-point test (0.05 → ``χ²₂ = 5.99``).
    prefilter : (float, float), "auto" or None
        Band-pass ``(f_lo, f_hi)`` in fractions of the (decimated) sampling frequency
        applied before the test (zero-phase Butterworth, :func:`.oscillation.bandpass`);
        ``"auto"`` uses :func:`auto_band` (a band only when a regular oscillation is
        found); None: no filter.
    detrend : bool
        Remove a least-squares straight line from the record first (segment means
        are always removed).
    max_samples : int or None
        Analyse only the last ``max_samples`` samples after decimation (4096
        recommended; the most recent part of a record is the one past start-up
        transients). None: all.
    decimate : int
        Integer down-sampling factor applied first (:func:`scipy.signal.decimate`,
        zero-phase FIR anti-alias filter). An oscillation slower than ``nfft/4``
        samples per cycle puts its fundamental in the lowest one or two bins, where
        the bicoherence cannot resolve the harmonic coupling; decimating until a
        segment holds about four cycles restores it (at the cost of fewer segments).
    window : {"hann", "boxcar"}
        Segment window.
    ngi_average : {"domain", "significant"}
        Divisor of the NGI sum, see above.

    Returns
    -------
    NonlinearityIndices

    Raises
    ------
    InputError
        On bad input (too short for 8 segments, constant, non-finite) or parameters.

    References
    ----------
    M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, "Diagnosis of poor control-loop
    performance using higher-order statistics", Automatica 40 (2004) 1719–1728.
    M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, *Diagnosis of Process
    Nonlinearities and Valve Stiction*, Springer (2008), ch. 6.
    M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, D. S. Shook, "Automatic
    detection and quantification of stiction in control valves", Control Eng. Practice
    14 (2006) 1395–1412 (TNLI).

    Examples
    --------
    >>> import numpy as np
    >>> e = np.random.default_rng(1).standard_normal(4096)
    >>> res = nonlinearity_indices(e)
    >>> bool(res.ngi < 0.001), res.k_segments
    (True, 63)
    """
    if not 0 < alpha < 1:
        raise InputError(f"bicoherence: alpha={alpha} must be in (0, 1)")
    if ngi_average not in ("domain", "significant"):
        raise InputError(
            f"bicoherence: ngi_average={ngi_average!r} must be 'domain' or 'significant'"
        )
    nfft, step = _check_segmentation(nfft, overlap)
    x = check_signal(x, "bicoherence input", min_len=1)
    if not (isinstance(decimate, (int, np.integer)) and decimate >= 1):
        raise InputError(f"bicoherence: decimate={decimate!r} must be a positive integer")
    q = int(decimate)
    if q > 1:
        if x.size < 32 * q:
            raise InputError(
                f"bicoherence input: {x.size} samples are too few to decimate by {q}"
            )
        x = sps.decimate(sps.detrend(x), q, ftype="fir", zero_phase=True)
    if max_samples is not None:
        if not (isinstance(max_samples, (int, np.integer)) and max_samples >= nfft):
            raise InputError(f"bicoherence: max_samples={max_samples} is below nfft={nfft}")
        x = x[-int(max_samples):]
    need = nfft + (MIN_SEGMENTS - 1) * step
    x = check_signal(x, "bicoherence input", min_len=need)
    x = sps.detrend(x, type="linear" if detrend else "constant")
    band: tuple[float, float] | None
    if prefilter is None:
        band = None
    elif isinstance(prefilter, str):
        if prefilter != "auto":
            raise InputError(
                f"bicoherence: prefilter={prefilter!r} must be None, 'auto' or (f_lo, f_hi)"
            )
        band = auto_band(x)
    else:
        band = (float(prefilter[0]), float(prefilter[1]))
    if band is not None:
        x = bandpass(x, band)
    bic2, freqs, K = kim_powers_bicoherence(x, nfft, overlap, window=window)
    vals = bic2[np.isfinite(bic2)]
    thr = float(stats.chi2.ppf(1.0 - alpha, 2) / (2.0 * K))
    sig = vals[vals > thr]
    n_sig = int(sig.size)
    if ngi_average == "domain":
        ngi = float(sig.sum() / vals.size) - thr
    else:
        ngi = (float(sig.mean()) if n_sig else 0.0) - thr
    nli = abs(float(vals.max()) - (float(vals.mean()) + 2.0 * float(vals.std())))
    kmax, lmax = np.unravel_index(np.nanargmax(bic2), bic2.shape)
    return NonlinearityIndices(
        ngi=ngi,
        nli=nli,
        tnli=float(sig.sum()),
        n_significant=n_sig,
        n_points=int(vals.size),
        threshold=thr,
        k_segments=int(K),
        bic2_max=float(vals.max()),
        f_max=(float(freqs[kmax]), float(freqs[lmax])),
        band=band,
        n_samples=int(x.size),
        bic2=bic2,
        freqs=freqs,
    )


class Bicoherence(Estimator):
    """Choudhury–Shah–Thornhill bicoherence test for loop nonlinearity.

    ``value`` is NLI; ``decision`` is "nonlinear": ``NGI > ngi_threshold`` and
    ``NLI > nli_threshold``. With ``NGI <= ngi_threshold`` the signal is taken as
    Gaussian, hence linear, and the decision is False whatever NLI says. See
    :func:`nonlinearity_indices` for the equations and the version implemented.

    Parameters
    ----------
    nfft : int
        Segment and FFT length (128).
    overlap : float
        Segment overlap, per cent (50).
    alpha : float
        Significance level of the ``bic²`` test (0.05).
    ngi_threshold : float
        NGI above this: non-Gaussian (0.001).
    nli_threshold : float
        NLI above this: nonlinear (0.01).
    prefilter : (float, float), "auto" or None
        Band-pass before the test, fractions of fs; ``"auto"`` (default) is
        ``(f0/2, min(0.5, 10·f0))`` around a regular oscillation ``f0`` found by the
        ACF (:func:`auto_band`), no filter when there is none: it removes drift and
        high-frequency noise and keeps the harmonics.
    detrend : bool
        Remove a straight line first (True).
    max_samples : int or None
        Use the last ``max_samples`` samples (4096, the recommended data length).
    window : {"hann", "boxcar"}
        Segment window.
    ngi_average : {"domain", "significant"}
        NGI divisor, see :func:`nonlinearity_indices` (``"domain"``).
    decimate : int
        Integer down-sampling factor applied first (1: none); use it when the
        oscillation period exceeds about ``nfft/4`` samples.
    """

    name = "bicoherence"
    default_x = "PV"
    default_y = None

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "nfft": [Interval(Integral, 8, None)],
        "overlap": [Interval(Real, 0, 99)],
        "alpha": [Interval(Real, 0, 1, closed="neither")],
        "ngi_threshold": [Interval(Real, None, None)],
        "nli_threshold": [Interval(Real, None, None)],
        "prefilter": [Band(0, 0.5), Options(("auto",)), None],
        "detrend": [TypeOf(bool)],
        "max_samples": [Interval(Integral, 8, None), None],
        "window": [Options(("hann", "boxcar"))],
        "ngi_average": [Options(("domain", "significant"))],
        "decimate": [Interval(Integral, 1, None)],
    }

    def __init__(
        self,
        nfft: int = 128,
        overlap: float = 50,
        alpha: float = 0.05,
        ngi_threshold: float = 0.001,
        nli_threshold: float = 0.01,
        prefilter: tuple[float, float] | Literal["auto"] | None = "auto",
        detrend: bool = True,
        max_samples: int | None = 4096,
        window: Literal["hann", "boxcar"] = "hann",
        ngi_average: Literal["domain", "significant"] = "domain",
        decimate: int = 1,
    ) -> None:
        self.nfft = nfft
        self.overlap = overlap
        self.alpha = alpha
        self.ngi_threshold = ngi_threshold
        self.nli_threshold = nli_threshold
        self.prefilter = prefilter
        self.detrend = detrend
        self.max_samples = max_samples
        self.window = window
        self.ngi_average = ngi_average
        self.decimate = decimate

    def _estimate(
        self, x: np.ndarray, y: np.ndarray | None, rec: Recording
    ) -> EstimateResult:
        pre = self.prefilter
        if pre is not None and not isinstance(pre, str):
            pre = (float(pre[0]), float(pre[1]))
        res = nonlinearity_indices(
            x,
            self.nfft,
            self.overlap,
            alpha=self.alpha,
            prefilter=pre,
            detrend=self.detrend,
            max_samples=self.max_samples,
            window=self.window,
            ngi_average=self.ngi_average,
            decimate=self.decimate,
        )
        non_gaussian = res.ngi > self.ngi_threshold
        decision = bool(non_gaussian and res.nli > self.nli_threshold)
        return EstimateResult(
            method=self.name,
            value=res.nli,
            units="-",
            decision=decision,
            meaning="nonlinear (non-Gaussian and nonlinear)",
            diagnostics={
                "ngi": res.ngi,
                "nli": res.nli,
                "tnli": res.tnli,
                "non_gaussian": bool(non_gaussian),
                "n_significant": res.n_significant,
                "n_points": res.n_points,
                "k_segments": res.k_segments,
                "bic2_threshold": res.threshold,
                "bic2_max": res.bic2_max,
                "f_max": res.f_max,
                "ngi_threshold": self.ngi_threshold,
                "nli_threshold": self.nli_threshold,
                "band": res.band,
                "n_samples": res.n_samples,
                "decimate": self.decimate,
                "bic2": res.bic2,
                "freqs": res.freqs,
            },
        )
