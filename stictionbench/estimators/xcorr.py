"""Cross-correlation delay estimator ``xcorr`` (HOSA ``tder``, paper eqs. 5–8).

The delay of the valve position (MV, ``y``) behind the controller output (OP, ``x``)
from the Hannan–Thomson ML-windowed cross-correlation, via
:func:`stictionbench.hosa.tder`. A delay above ``threshold`` samples (MV lags OP) is
read as stiction, as in the seed paper's Table VII.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import hosa
from ..recording import Recording
from .base import EstimateResult, Estimator, check_pair

MEANING = "y lags x (stiction indicated)"


def top_peaks(lags: np.ndarray, curve: np.ndarray, n: int = 3) -> list[tuple[int, float]]:
    """The ``n`` largest local maxima of ``|curve|`` as ``(lag, signed value)``, largest first.

    In a closed loop OP and MV are also linked backwards through the process, so the
    curve can show peaks at the loop's own delays; listing them says which one the
    estimate picked.
    """
    a = np.abs(np.asarray(curve, dtype=float))
    if a.size < 3:
        i = np.arange(a.size)
    else:
        left = np.r_[True, a[1:] >= a[:-1]]
        right = np.r_[a[:-1] >= a[1:], True]
        i = np.flatnonzero(left & right)
    i = i[np.argsort(-a[i], kind="stable")][:n]
    return [(int(lags[j]), float(curve[j])) for j in i]


class XCorr(Estimator):
    """Delay by ML-weighted cross-correlation (HOSA ``tder``).

    Parameters
    ----------
    max_delay : int
        Largest expected delay in samples; sets the default segment length
        ``2^nextpow2(4·max_delay + 1)``. It does not limit the peak search, which covers
        ``-nfft/2 .. nfft/2 - 1``.
    segsamp : int, optional
        Samples per Welch segment (default from ``max_delay``).
    overlap : float
        Segment overlap in per cent (clipped to [0, 99]).
    nfft : int, optional
        FFT length (default ``2^nextpow2(segsamp)``).
    threshold : float
        Delay in samples above which stiction is indicated.

    Notes
    -----
    ``value`` is the interpolated delay in samples (positive: ``y`` = MV lags
    ``x`` = OP); ``decision`` is ``value > threshold``. Diagnostics hold the delay in
    seconds, the curve and its lags, ``at_edge`` (peak at an end of the lag window,
    i.e. not a measured delay), ``beyond_max_delay`` and the three largest peaks.
    """

    name = "xcorr"
    default_x = "OP"
    default_y = "MV"

    def __init__(
        self,
        max_delay: int = 30,
        segsamp: int | None = None,
        overlap: float = 50,
        nfft: int | None = None,
        threshold: float = 0.5,
    ) -> None:
        self.max_delay = max_delay
        self.segsamp = segsamp
        self.overlap = overlap
        self.nfft = nfft
        self.threshold = threshold

    def _estimate(
        self, x: np.ndarray, y: np.ndarray | None, rec: Recording
    ) -> EstimateResult:
        x, y = check_pair(self.name, x, y)
        st = hosa.tder_settings(x.size, self.max_delay, self.segsamp, self.overlap, self.nfft)
        res = hosa.tder(x, y, self.max_delay, st.segsamp, self.overlap, st.nfft)
        delay = float(res.delay)
        threshold = float(self.threshold)
        max_delay = int(self.max_delay)
        lags = res.lags
        diag: dict[str, Any] = {
            "delay_s": delay * rec.Ts,
            "at_edge": bool(res.at_edge),
            "beyond_max_delay": bool(abs(delay) > max_delay),
            "peak_value": float(res.rxy[int(np.argmax(np.abs(res.rxy)))]),
            "peaks": top_peaks(lags, res.rxy),
            "threshold": threshold,
            "max_delay": max_delay,
            "segsamp": st.segsamp,
            "noverlap": st.noverlap,
            "nfft": st.nfft,
            "nseg": st.nseg,
            "lags": lags,
            "curve": res.rxy,
        }
        return EstimateResult(
            method=self.name,
            value=delay,
            units="samples",
            decision=bool(delay > threshold),
            meaning=MEANING,
            diagnostics=diag,
        )
