"""MATLAB-compatible time-delay and bicoherence routines of the HOSA toolbox.

This module plays the role that :mod:`control.matlab` plays in python-control: the
functions keep the names, positional arguments and defaults of the Higher-Order Spectral
Analysis toolbox (A. Swami, v2.0.3) so that a MATLAB call such as
``tder(x, y, 30, 64, 0, 64)`` can be written unchanged, and they reproduce its outputs
(to ~1e-14 relative on the reference data in ``shared/reference/hosa``). ``None`` or an
empty list ``[]`` in any optional position means "use the default", as ``[]`` does in
MATLAB.

- :func:`tder` — delay from the cross-correlation weighted by the Hannan–Thomson
  maximum-likelihood window, with three-point peak interpolation (paper eqs. 5–8).
- :func:`tde` — delay from third-order cross-cumulants (paper eqs. 9–11; the paper
  calls it "tder3").
- :func:`bicoher` — direct (FFT) estimate of the squared bicoherence.

The toolbox itself is proprietary; everything here is written from the algorithm
description in ``shared/notes/algorithms.md`` and the published help texts. All routines
are vectorised: segment matrices are strided views, spectra are batched real FFTs and
the cumulant sums are FFT cross-correlations.

Sign convention: a positive delay means **y lags x**, ``y(n) ≈ A·x(n − D)``. With ``x``
the controller output (OP) and ``y`` the valve position (MV), stiction makes the delay
positive.

Bad input raises :class:`stictionbench.errors.InputError` with a one-line message.
"""

from __future__ import annotations

import math
import re
from typing import Any, NamedTuple

import numpy as np
from numpy.lib.stride_tricks import as_strided, sliding_window_view
from scipy import fft as sfft
from scipy.signal.windows import hann

from .errors import InputError

__all__ = [
    "BicoherResult",
    "TdeResult",
    "TderResult",
    "TderSettings",
    "bicoher",
    "bicoher_peak",
    "hanning",
    "tde",
    "tder",
    "tder_curve",
    "tder_settings",
]


# ---------------------------------------------------------------------------- results
class TderResult(NamedTuple):
    """Output of :func:`tder`; unpacks as ``delay, rxy``.

    Attributes
    ----------
    delay : float
        Estimated delay in samples (positive: y lags x).
    rxy : ndarray
        ML-windowed cross-correlation at lags ``-nfft/2 .. nfft/2 - 1``.
    """

    delay: float
    rxy: np.ndarray

    @property
    def lags(self) -> np.ndarray:
        """Lag axis of ``rxy`` in samples, ``-nfft/2 .. nfft/2 - 1``."""
        n = self.rxy.size
        return np.arange(n) - n // 2

    @property
    def at_edge(self) -> bool:
        """True when the peak of ``|rxy|`` is at either end of the lag window."""
        i = int(np.argmax(np.abs(self.rxy)))
        return i == 0 or i == self.rxy.size - 1


class TdeResult(NamedTuple):
    """Output of :func:`tde`; unpacks as ``delay, avec``.

    Attributes
    ----------
    delay : int
        Estimated delay in samples (positive: y lags x).
    avec : ndarray
        Model coefficients ``a(k)``, ``k = -max_delay .. max_delay``.
    """

    delay: int
    avec: np.ndarray

    @property
    def lags(self) -> np.ndarray:
        """Lag axis of ``avec``, ``-max_delay .. max_delay``."""
        m = self.avec.size // 2
        return np.arange(-m, m + 1)

    @property
    def at_edge(self) -> bool:
        """True when the estimate sits at ``±max_delay`` (not a measured delay)."""
        return abs(self.delay) >= self.avec.size // 2


class BicoherResult(NamedTuple):
    """Output of :func:`bicoher`; unpacks as ``bic, waxis``.

    Attributes
    ----------
    bic : ndarray, shape (nfft, nfft)
        Squared bicoherence, fftshifted (zero frequency at index ``nfft // 2``).
    waxis : ndarray, shape (nfft,)
        Frequency axis in cycles per sample, ``(-nfft/2 .. nfft/2 - 1) / nfft``.
    """

    bic: np.ndarray
    waxis: np.ndarray


class TderSettings(NamedTuple):
    """Resolved Welch settings of :func:`tder` (see :func:`tder_settings`)."""

    segsamp: int
    noverlap: int
    nfft: int
    nseg: int


# ---------------------------------------------------------------------------- helpers
def hanning(n: int) -> np.ndarray:
    """MATLAB ``hanning(n)``: ``0.5·(1 − cos(2πk/(n+1)))``, ``k = 1..n`` (no zero ends).

    numpy's and Octave's ``hanning`` have zero end points and differ at the 1e-4 level.
    """
    return hann(int(n) + 2)[1:-1]


def _is_default(v: Any) -> bool:
    """``None`` or an empty sequence/array (MATLAB ``[]``)."""
    if v is None:
        return True
    if isinstance(v, (list, tuple)) and len(v) == 0:
        return True
    return isinstance(v, np.ndarray) and v.size == 0


def _nextpow2(n: int) -> int:
    """MATLAB ``2^nextpow2(n)`` for a positive integer ``n``."""
    return 1 << max(int(n) - 1, 0).bit_length()


def _number(v: Any, fn: str, name: str) -> float:
    if isinstance(v, (bool, np.bool_)):
        raise InputError(f"{fn}: {name}={v!r} must be a number")
    try:
        f = float(np.asarray(v, dtype=float).reshape(()))
    except (TypeError, ValueError):
        raise InputError(f"{fn}: {name}={v!r} must be a number") from None
    if not math.isfinite(f):
        raise InputError(f"{fn}: {name}={v!r} must be finite")
    return f


def _int_param(v: Any, fn: str, name: str, default: int | None, minimum: int) -> int:
    if _is_default(v):
        if default is None:
            raise InputError(f"{fn}: {name} is required")
        v = default
    f = _number(v, fn, name)
    if f != int(f):
        raise InputError(f"{fn}: {name}={v!r} must be an integer")
    i = int(f)
    if i < minimum:
        raise InputError(f"{fn}: {name}={i} must be at least {minimum}")
    return i


def _overlap(v: Any, fn: str) -> float:
    """Overlap in per cent, default 50, clipped to [0, 99] as in the toolbox."""
    if _is_default(v):
        return 50.0
    return min(max(_number(v, fn, "overlap"), 0.0), 99.0)


def _vector(v: Any, fn: str, name: str) -> np.ndarray:
    """A finite, non-constant real vector (row, column or 1-D)."""
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{fn}: {name} must be a real numeric vector") from None
    if a.ndim == 2 and 1 in a.shape:
        a = a.reshape(-1)
    if a.ndim != 1:
        raise InputError(f"{fn}: {name} must be a vector, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{fn}: {name} contains NaN or infinite values")
    if a.size == 0:
        raise InputError(f"{fn}: {name} is empty")
    if np.ptp(a) == 0.0:
        raise InputError(f"{fn}: {name} is constant (spectra and coherence are undefined)")
    return a


def _pair(x: Any, y: Any, fn: str) -> tuple[np.ndarray, np.ndarray]:
    x = _vector(x, fn, "x")
    y = _vector(y, fn, "y")
    if x.size != y.size:
        raise InputError(f"{fn}: x and y have different lengths ({x.size} and {y.size})")
    return x, y


def _detrend_basis(n: int) -> np.ndarray:
    """Orthonormal basis (n, 2) of constants and straight lines on ``0..n-1``."""
    t = np.arange(n, dtype=float)
    q, _ = np.linalg.qr(np.column_stack([np.ones(n), t - t.mean()]))
    return q


# ---------------------------------------------------------------------------- tder
def tder_settings(
    n: int, max_delay: Any, segsamp: Any = None, overlap: Any = 50, nfft: Any = None
) -> TderSettings:
    """Resolve the defaults of :func:`tder` for a record of ``n`` samples.

    Parameters
    ----------
    n : int
        Number of samples.
    max_delay, segsamp, overlap, nfft
        As in :func:`tder`.

    Returns
    -------
    TderSettings
        ``segsamp``, ``noverlap`` (samples), ``nfft`` and the number of segments
        ``nseg``.

    Raises
    ------
    InputError
        When the record is shorter than two segments.
    """
    m = _int_param(max_delay, "tder", "max_delay", None, 1)
    seg = _int_param(segsamp, "tder", "segsamp", _nextpow2(4 * m + 1), 4)
    ov = _overlap(overlap, "tder")
    nov = int(math.trunc(ov / 100.0 * seg))
    nf = _nextpow2(seg) if _is_default(nfft) else _int_param(nfft, "tder", "nfft", None, 1)
    if nf < seg:
        nf = _nextpow2(seg)
    if nf % 2:
        raise InputError(f"tder: nfft={nf} must be even")
    if n < seg:
        raise InputError(
            f"tder: {n} samples are too short for segsamp={seg} (max_delay={m}); "
            f"give a longer record or a smaller max_delay/segsamp"
        )
    nseg = (n - nov) // (seg - nov)
    if nseg < 2:
        raise InputError(
            f"tder: {n} samples give only {nseg} segment of {seg} samples; the coherence "
            f"of one segment is identically 1 (C/(1-C) divides by zero); need >= 2 segments"
        )
    return TderSettings(seg, nov, nf, nseg)


def _welch_cross(
    x: np.ndarray, y: np.ndarray, st: TderSettings
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sxy = Σ Y·conj(X), Sxx, Syy on bins 0..nfft/2 (segments detrended and windowed)."""
    seg, nov, nf, k = st
    step = seg - nov
    q = _detrend_basis(seg)
    w = hanning(seg)
    xy = np.stack([x, y])                                   # (2, N)
    s = sliding_window_view(xy, seg, axis=1)[:, ::step][:, :k]   # (2, K, seg) view
    s = s - (s @ q) @ q.T                                   # remove LS straight line
    s *= w
    f = sfft.rfft(s, nf, axis=-1)                           # (2, K, nf/2+1)
    fx, fy = f[0], f[1]
    sxy = np.einsum("kf,kf->f", fy, fx.conj())
    sxx = np.einsum("kf,kf->f", fx.real, fx.real) + np.einsum("kf,kf->f", fx.imag, fx.imag)
    syy = np.einsum("kf,kf->f", fy.real, fy.real) + np.einsum("kf,kf->f", fy.imag, fy.imag)
    return sxy, sxx, syy


def tder(
    x: Any,
    y: Any,
    max_delay: Any,
    segsamp: Any = None,
    overlap: Any = 50,
    nfft: Any = None,
) -> TderResult:
    """Delay by cross-correlation with the Hannan–Thomson ML window (HOSA ``tder``).

    The auto- and cross-spectra are Welch averages over segments of ``segsamp``
    samples (each with its least-squares line removed and a MATLAB ``hanning`` window);
    the squared coherence ``C = |Sxy|²/(Sxx·Syy)`` gives the maximum-likelihood weight
    ``R(f) = C/(1 − C)·exp(j∠Sxy(f))`` (``R(0) = 0``), whose inverse FFT is the
    generalised cross-correlation. The delay is the location of the peak of ``|rxy|``,
    refined by the three-point parabola through the signed values (paper eq. 8); a peak
    at either end of the lag window is returned as an integer lag.

    Parameters
    ----------
    x, y : array_like, shape (N,)
        The two signals; ``y`` is modelled as a delayed copy of ``x``.
    max_delay : int
        Largest expected delay (samples). It only sets the default ``segsamp``; the
        peak search covers the whole lag window ``-nfft/2 .. nfft/2 - 1``.
    segsamp : int, optional
        Samples per segment; default ``2^nextpow2(4·max_delay + 1)``.
    overlap : float, optional
        Segment overlap in per cent, clipped to [0, 99]; default 50.
    nfft : int, optional
        FFT length; default (or when smaller than ``segsamp``) ``2^nextpow2(segsamp)``.
        Must be even.

    Returns
    -------
    TderResult
        Named tuple ``(delay, rxy)``: the delay in samples (positive: y lags x) and the
        windowed cross-correlation; ``.lags`` gives its lag axis and ``.at_edge`` tells
        whether the peak is at an end of the lag window.

    Raises
    ------
    InputError
        Different lengths, NaN/inf, a constant signal, a record shorter than two
        segments, or a coherence of exactly 1 (the ML weight would divide by zero).

    References
    ----------
    .. [1] A. Swami, J. M. Mendel, C. L. Nikias, *Higher-Order Spectral Analysis
       Toolbox for use with MATLAB*, v2.0.3, help text of ``tder``.
    .. [2] E. J. Hannan, P. J. Thomson, "Estimating group delay", *Biometrika* 60(2),
       241–253, 1973.
    .. [3] E. G. Kumar, S. Manoharan, "A novel approach for detection of valve stiction
       by time delay estimation", eqs. (5)–(8) (``shared/paper/``).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> s = rng.exponential(size=4096 + 16) - 1.0
    >>> x = s[16:] + 0.3 * rng.standard_normal(4096)
    >>> y = s[:-16] + 0.3 * rng.standard_normal(4096)   # y(n) = s(n - 16) lags x
    >>> delay, rxy = tder(x, y, 30)
    >>> round(delay)
    16
    """
    x, y = _pair(x, y, "tder")
    st = tder_settings(x.size, max_delay, segsamp, overlap, nfft)
    sxy, sxx, syy = _welch_cross(x, y, st)
    den = sxx[1:] * syy[1:]
    if np.any(den == 0.0):
        raise InputError("tder: zero auto-spectrum at some frequency; coherence undefined")
    c = np.empty_like(sxx)
    c[0] = 0.0
    c[1:] = (sxy[1:].real ** 2 + sxy[1:].imag ** 2) / den
    if np.any(c[1:] >= 1.0):
        raise InputError(
            "tder: coherence is exactly 1 at some frequency (y is a noiseless linear "
            "function of x); the ML weight C/(1-C) would divide by zero"
        )
    r = c / (1.0 - c) * np.exp(1j * np.angle(sxy))
    r[0] = 0.0
    nf = st.nfft
    rxy = sfft.fftshift(sfft.irfft(r, nf))
    d = int(np.argmax(np.abs(rxy)))
    half = nf // 2
    delay = float(d - half)
    if 0 < d < nf - 1:
        curv = rxy[d + 1] - 2.0 * rxy[d] + rxy[d - 1]
        if curv != 0.0:
            delay = d - half - 0.5 - (rxy[d] - rxy[d - 1]) / curv
    return TderResult(float(delay), rxy)


def tder_curve(
    x: Any,
    y: Any,
    max_delay: Any,
    segsamp: Any = None,
    overlap: Any = 50,
    nfft: Any = None,
) -> tuple[float, np.ndarray, np.ndarray]:
    """:func:`tder` with the lag axis: returns ``(delay, lags, rxy)``.

    Parameters and errors as in :func:`tder`.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> x = rng.standard_normal(2048)
    >>> y = np.roll(x, 5) + rng.standard_normal(2048)
    >>> delay, lags, rxy = tder_curve(x, y, 10)
    >>> int(lags[np.argmax(np.abs(rxy))])
    5
    """
    res = tder(x, y, max_delay, segsamp, overlap, nfft)
    return res.delay, res.lags, res.rxy


# ---------------------------------------------------------------------------- tde
def _cumulants(
    x: np.ndarray, y: np.ndarray, m: int, nsamp: int
) -> tuple[np.ndarray, np.ndarray]:
    """Rxxx(τ, s), |τ| <= 2m, and Rxyx(τ, s), |τ| <= m, for s = -1, 0, 1.

    ``R··x(τ, s) = Σ_n x(n)·x(n+s)·v(n−τ)`` summed within records (zeros beyond the
    record edges), over records, divided by N. Computed as FFT cross-correlations.
    """
    n = x.size
    nrec = n // nsamp
    xr = x[: nrec * nsamp].reshape(nrec, nsamp)
    yr = y[: nrec * nsamp].reshape(nrec, nsamp)
    xr = xr - xr.mean(axis=1, keepdims=True)
    yr = yr - yr.mean(axis=1, keepdims=True)
    z = np.zeros((3, nrec, nsamp))
    lag1 = xr[:, 1:] * xr[:, :-1]
    z[0, :, 1:] = lag1                      # s = -1: x(n)·x(n-1)
    np.multiply(xr, xr, out=z[1])           # s =  0
    z[2, :, :-1] = lag1                     # s = +1: x(n)·x(n+1)
    nf = sfft.next_fast_len(nsamp + 2 * m, real=True)
    fz = sfft.rfft(z, nf, axis=-1)                          # (3, R, F)
    fxy = sfft.rfft(np.stack([xr, yr]), nf, axis=-1).conj()  # (2, R, F)
    # Σ_records Z·conj(V): one (R)-contraction per (s, v, f)
    cross = np.einsum("srf,vrf->svf", fz, fxy)
    c = sfft.irfft(cross, nf, axis=-1) / n                 # c[s, v, τ mod F]
    rxxx = c[:, 0, np.arange(-2 * m, 2 * m + 1) % nf]
    rxyx = c[:, 1, np.arange(-m, m + 1) % nf]
    return rxxx, rxyx


def _normal_equations(
    rxxx: np.ndarray, rxyx: np.ndarray, m: int
) -> tuple[np.ndarray, np.ndarray]:
    """``A = Σ_s T_sᵀT_s`` and ``Σ_s T_sᵀ·Rxyx_s`` for the Toeplitz ``T_s(i, j) = Rxxx(i−j, s)``.

    ``A`` is built in O(p²) from its Toeplitz displacement,
    ``A(j+1, k+1) = A(j, k) + Σ_s [r_s(−1−j)·r_s(−1−k) − r_s(p−1−j)·r_s(p−1−k)]``:
    the first row by dot products, the rest by cumulative sums along the diagonals
    (read and written through skewed strided views). This avoids a (3p × p)ᵀ(3p × p)
    BLAS product, which OpenBLAS splits across threads and which then stalls for a
    scheduler time slice whenever another process holds the other cores.
    """
    p = 2 * m + 1
    i = np.arange(p)
    t = rxxx[:, i[:, None] - i[None, :] + 2 * m]            # (3, p, p) Toeplitz
    rhs = np.einsum("sij,si->j", t, rxyx)
    row0 = np.einsum("si,sik->k", t[:, :, 0], t)            # A(0, δ)
    u = rxxx[:, 2 * m - 1 :: -1]                            # r_s(−1−j), j = 0..p−2
    v = rxxx[:, 4 * m : 2 * m : -1]                         # r_s(p−1−j)
    dpad = np.zeros((p - 1, 2 * p))
    dpad[:, : p - 1] = np.einsum("sj,sk->jk", u, u) - np.einsum("sj,sk->jk", v, v)
    s0, s1 = dpad.strides
    diag = as_strided(dpad, shape=(p - 1, p), strides=(s0 + s1, s1), writeable=False)
    upper = np.empty((p, p))                                # upper[j, δ] = A(j, j+δ)
    upper[0] = row0
    np.cumsum(diag, axis=0, out=upper[1:])
    upper[1:] += row0
    apad = np.zeros((p, 2 * p))
    s0, s1 = apad.strides
    as_strided(apad, shape=(p, p), strides=(s0 + s1, s1))[...] = upper
    au = apad[:, :p]                                        # upper triangle of A
    return au + np.triu(au, 1).T, rhs


def tde_system(x: np.ndarray, y: np.ndarray, m: int, nsamp: int) -> tuple[np.ndarray, np.ndarray]:
    """The normal equations ``A·b = r`` that :func:`tde` solves (``A`` is ``(2m+1)²``).

    Exposed so that callers can judge the solve: ``np.linalg.cond(A)`` near 1e10 or
    more means the third-order cumulants of ``x`` carry almost no information (a
    nearly symmetric ``x``) and the arg-max of ``|a(k)|`` is decided by round-off.
    """
    rxxx, rxyx = _cumulants(np.asarray(x, float), np.asarray(y, float), m, nsamp)
    if not np.any(rxyx):
        raise InputError("tde: all cross-cumulants of y with x are zero (y constant per record)")
    return _normal_equations(rxxx, rxyx, m)


def tde(x: Any, y: Any, max_delay: Any, nsamp: Any = None, rank: Any = None) -> TdeResult:
    """Delay from third-order cross-cumulants (HOSA ``tde``; the paper's "tder3").

    ``y`` is modelled as ``y(n) = Σ_{k=-M..M} a(k)·x(n−k)`` (``M = max_delay``). For
    ``s ∈ {−1, 0, +1}`` the cumulants ``Rxyx(τ, s) = Σ x(n)x(n+s)y(n−τ)`` (``|τ| ≤ M``)
    and ``Rxxx(τ, s) = Σ x(n)x(n+s)x(n−τ)`` (``|τ| ≤ 2M``) give the Toeplitz systems
    ``T_s·b = Rxyx_s`` with ``T_s(i, j) = Rxxx(i − j, s)``; the normal equations
    ``(Σ T_sᵀT_s)·b = Σ T_sᵀ·Rxyx_s`` are solved and ``a`` is ``b`` reversed. The
    delay is the first argmax of ``|a(k)|`` — an integer, no interpolation. Gaussian
    noise, even correlated between the sensors, has zero third-order cumulants, so
    the estimate is not pulled by it as the cross-correlation is.

    Parameters
    ----------
    x, y : array_like, shape (N,)
        The two signals; ``x`` must be non-Gaussian (skewed).
    max_delay : int
        ``M``: the delays searched are ``-M .. M``. An estimate at ``±M`` is on the edge
        of the window, not a measured delay (see ``TdeResult.at_edge``).
    nsamp : int, optional
        Samples per record; default ``N``. ``fix(N/nsamp)`` records are used (leftover
        samples dropped), each with its mean removed.
    rank : int, optional
        Keep only the ``rank`` largest singular values of the normal-equation matrix
        (low-rank approximation for robustness to noise; the original asks for it
        interactively). Default: full rank, plain solve.

    Returns
    -------
    TdeResult
        Named tuple ``(delay, avec)``: the integer delay (positive: y lags x) and the
        coefficients ``a(k)``, ``k = -M .. M``; ``.lags`` gives that axis.

    Raises
    ------
    InputError
        Different lengths, NaN/inf, a constant signal, records shorter than
        ``2·max_delay + 1``, ``rank`` out of range or a singular cumulant matrix.

    References
    ----------
    .. [1] A. Swami, J. M. Mendel, C. L. Nikias, *Higher-Order Spectral Analysis
       Toolbox for use with MATLAB*, v2.0.3, help text of ``tde``.
    .. [2] E. G. Kumar, S. Manoharan, "A novel approach for detection of valve stiction
       by time delay estimation", eqs. (9)–(11) (``shared/paper/``).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> s = rng.exponential(size=4096 + 16) - 1.0
    >>> x, y = s[16:], s[:-16]        # y(n) = x(n - 16)
    >>> delay, avec = tde(x, y, 30)
    >>> delay
    16
    """
    x, y = _pair(x, y, "tde")
    n = x.size
    m = _int_param(max_delay, "tde", "max_delay", None, 1)
    ns = _int_param(nsamp, "tde", "nsamp", n, 1)
    if ns > n:
        raise InputError(f"tde: nsamp={ns} is longer than the {n} samples given")
    if ns < 2 * m + 1:
        raise InputError(
            f"tde: records of {ns} samples are too short for max_delay={m} "
            f"(need at least {2 * m + 1}); give more samples or a smaller max_delay"
        )
    p = 2 * m + 1
    rk = None if _is_default(rank) else _int_param(rank, "tde", "rank", None, 1)
    if rk is not None and rk > p:
        raise InputError(f"tde: rank={rk} exceeds the matrix size 2*max_delay+1 = {p}")

    a_mat, rhs = tde_system(x, y, m, ns)
    if rk is None:
        try:
            b = np.linalg.solve(a_mat, rhs)
        except np.linalg.LinAlgError:
            raise InputError(
                "tde: the cumulant matrix is singular (x has no third-order structure)"
            ) from None
    else:
        u, sv, vt = np.linalg.svd(a_mat)
        if sv[rk - 1] <= 0.0:
            raise InputError(f"tde: rank={rk} exceeds the numerical rank of the matrix")
        b = vt[:rk].T @ ((u[:, :rk].T @ rhs) / sv[:rk])
    if not np.all(np.isfinite(b)):
        raise InputError("tde: the cumulant matrix is singular (x has no third-order structure)")
    avec = b[::-1].copy()
    return TdeResult(int(np.argmax(np.abs(avec))) - m, avec)


# ---------------------------------------------------------------------------- bicoher
def bicoher(
    y: Any,
    nfft: Any = 128,
    wind: Any = None,
    nsamp: Any = None,
    overlap: Any = 50,
) -> BicoherResult:
    """Squared bicoherence by the direct (FFT) method (HOSA ``bicoher``).

    Each segment has its mean removed, is multiplied by ``wind`` and transformed,
    ``Y = fft(·, nfft)/nsamp``. Over the segments the toolbox averages the power
    ``P(k) = |Y(k)|²`` and the triple product ``B(k, l) = Y(k)·Y(l)·conj(Y(k+l))``
    (indices mod ``nfft``) and returns ``|B|²/(P(k)·P(l)·P(k+l))``, fftshifted.

    Parameters
    ----------
    y : array_like
        A vector (segmented with ``nsamp`` and ``overlap``) or a matrix holding one
        record per column (no overlap; ``nsamp`` and ``overlap`` are then ignored).
    nfft : int, optional
        FFT length, default 128; raised to ``2^nextpow2(nsamp)`` when smaller than
        ``nsamp``.
    wind : array_like, optional
        Time window of length ``nsamp``; default MATLAB ``hanning(nsamp)``.
    nsamp : int, optional
        Samples per segment; default ``fix(N/(8 − 7·overlap/100))``.
    overlap : float, optional
        Segment overlap in per cent, clipped to [0, 99]; default 50.

    Returns
    -------
    BicoherResult
        Named tuple ``(bic, waxis)``: the (nfft, nfft) squared bicoherence, rows and
        columns on the frequency axis ``waxis = (-nfft/2 .. nfft/2 - 1)/nfft``
        (cycles per sample). See :func:`bicoher_peak` for the peak.

    Raises
    ------
    InputError
        NaN/inf, a constant signal, fewer than two segments (the bicoherence of one
        segment is identically 1), ``nsamp`` longer than the data, a window of the
        wrong length, or zero power at some frequency.

    References
    ----------
    .. [1] A. Swami, J. M. Mendel, C. L. Nikias, *Higher-Order Spectral Analysis
       Toolbox for use with MATLAB*, v2.0.3, help text of ``bicoher``.
    .. [2] Y. C. Kim, E. J. Powers, "Digital bispectral analysis and its applications
       to nonlinear wave interactions", *IEEE Trans. Plasma Sci.* 7(2), 1979.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> bic, waxis = bicoher(rng.standard_normal(4096), 128, [], 128, 50)
    >>> bic.shape, float(waxis[0])
    ((128, 128), -0.5)
    """
    fn = "bicoher"
    try:
        a = np.asarray(y, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{fn}: y must be a real numeric vector or matrix") from None
    if a.ndim == 2 and 1 in a.shape:
        a = a.reshape(-1)
    if a.ndim not in (1, 2) or a.size == 0:
        raise InputError(f"{fn}: y must be a vector or a matrix, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{fn}: y contains NaN or infinite values")
    if np.ptp(a) == 0.0:
        raise InputError(f"{fn}: y is constant (the bicoherence is undefined)")
    nf = _int_param(nfft, fn, "nfft", 128, 1)
    if a.ndim == 2:
        ns, nrec = a.shape
        segs = a.T                                               # (K, nsamp)
    else:
        n = a.size
        ov = _overlap(overlap, fn)
        ns = _int_param(nsamp, fn, "nsamp", int(math.trunc(n / (8.0 - 7.0 * ov / 100.0))), 2)
        if ns > n:
            raise InputError(f"{fn}: nsamp={ns} is longer than the {n} samples given")
        nov = int(math.trunc(ns * ov / 100.0))
        step = ns - nov
        nrec = (n - nov) // step
        segs = sliding_window_view(a, ns)[::step][:nrec]
    if nrec < 2:
        raise InputError(
            f"{fn}: only {nrec} segment of {ns} samples; the bicoherence of one segment "
            f"is identically 1; use a smaller nsamp or more data"
        )
    if nf < ns:
        nf = _nextpow2(ns)
    if _is_default(wind):
        w = hanning(ns)
    else:
        w = np.asarray(wind, dtype=float).reshape(-1)
        if w.size != ns:
            raise InputError(f"{fn}: wind has {w.size} points, nsamp is {ns}")
    segs = (segs - segs.mean(axis=1, keepdims=True)) * w
    f = sfft.fft(segs, nf, axis=1) / ns                          # (K, nf)
    p = np.einsum("kf,kf->f", f.real, f.real) + np.einsum("kf,kf->f", f.imag, f.imag)
    if np.any(p == 0.0):
        raise InputError(f"{fn}: zero power at some frequency; the bicoherence is undefined")
    p /= nrec
    bsp = _triple_product_mean(f, nf)
    k = np.arange(nf)
    pk = p[(k[:, None] + k[None, :]) % nf]
    bic = (bsp.real ** 2 + bsp.imag ** 2) / (p[:, None] * p[None, :] * pk)
    waxis = (np.arange(nf) - nf // 2) / nf
    return BicoherResult(sfft.fftshift(bic), waxis)


def _triple_product_mean(f: np.ndarray, nf: int) -> np.ndarray:
    """Mean over segments of ``Y(k)·Y(l)·conj(Y(k+l mod nf))``, shape (nf, nf).

    Rows ``k = 0..nf/2`` are computed (the ``(k, l)`` pairs read ``conj(Y)`` through a
    strided window over ``[Y, Y]``, no gather); the other rows follow from the Hermitian
    symmetry of a real signal's spectrum, ``B(−k, −l) = conj(B(k, l))``.
    """
    nrec = f.shape[0]
    h = nf // 2 + 1
    ft = np.ascontiguousarray(f.T)                               # (nf, K)
    cext = np.concatenate([ft, ft], axis=0).conj()               # (2nf, K)
    ckl = sliding_window_view(cext, nf, axis=0)[:h].transpose(0, 2, 1)   # [k, l, i]
    q = ckl * ft[None, :, :]                                     # Y_i(l)·conj(Y_i(k+l))
    half = (q @ ft[:h, :, None])[..., 0] / nrec                  # Σ_i ·Y_i(k), (h, nf)
    out = np.empty((nf, nf), dtype=complex)
    out[:h] = half
    k = np.arange(nf)
    rows = np.arange(h, nf)
    out[h:] = half[nf - rows][:, (-k) % nf].conj()
    return out


def bicoher_peak(
    bic: Any, waxis: Any, rtol: float = 1e-12
) -> tuple[float, float, float]:
    """Largest squared bicoherence and its frequencies ``(value, f_row, f_col)``.

    The bicoherence is symmetric (12 equal copies of each value on the full plane);
    like MATLAB's ``max(bic(:))`` the first maximum in column-major order is taken,
    treating values within ``rtol`` of the maximum as ties so that rounding does not
    decide between symmetric copies.

    Parameters
    ----------
    bic : array_like, shape (nfft, nfft)
        As returned by :func:`bicoher`.
    waxis : array_like, shape (nfft,)
        Its frequency axis.
    rtol : float
        Relative tolerance for ties.

    Returns
    -------
    tuple of float
        Peak value, its row frequency and its column frequency (cycles per sample).

    Examples
    --------
    >>> b = np.array([[0.1, 0.5], [0.5, 0.2]])
    >>> bicoher_peak(b, np.array([-0.5, 0.0]))
    (0.5, 0.0, -0.5)
    """
    b = np.asarray(bic, dtype=float)
    w = np.asarray(waxis, dtype=float)
    top = float(np.max(b))
    cand = b >= top - rtol * abs(top)
    j = int(np.argmax(cand.ravel(order="F")))
    r, c = np.unravel_index(j, b.shape, order="F")
    return top, float(w[r]), float(w[c])


# ------------------------------------------------------------------ MATLAB call strings
_CALL = re.compile(r"^\s*(\w+)\s*\((.*)\)\s*$")


def parse_call(call: str, signals: dict[str, np.ndarray]) -> tuple[Any, list[Any]]:
    """Turn a MATLAB call as written in the reference files into ``(function, args)``.

    ``"tde(y, x, 30, 128)"`` → ``(tde, [y, x, 30, 128])``; names are looked up in
    ``signals``, ``[]`` becomes ``None`` (MATLAB's "default"), numbers stay numbers.

    Raises
    ------
    InputError
        When the string is not a call of a function of this module.
    """
    m = _CALL.match(call)
    fn = globals().get(m.group(1)) if m else None
    if m is None or m.group(1) not in ("tder", "tde", "bicoher") or fn is None:
        raise InputError(f"cannot parse MATLAB call {call!r}")
    args: list[Any] = []
    for tok in (t.strip() for t in m.group(2).split(",") if t.strip()):
        if tok in signals:
            args.append(signals[tok])
        elif tok == "[]":
            args.append(None)
        else:
            v = float(tok)
            args.append(int(v) if v == int(v) else v)
    return fn, args


def read_signals(path: str) -> dict[str, np.ndarray]:
    """Reference input signals: ``{"x", "y"}`` columns of a headed CSV, or
    ``{"y": matrix}`` (one record per column) for a bare one."""
    with open(path) as fh:
        first = fh.readline()
    if first[:1].isalpha():
        data = np.genfromtxt(path, delimiter=",", names=True)
        return {k: np.asarray(data[k], float) for k in data.dtype.names}
    return {"y": np.loadtxt(path, delimiter=",", ndmin=2)}
