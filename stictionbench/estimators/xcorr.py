"""Cross-correlation delay estimator ``xcorr`` (HOSA ``tder``, paper eqs. 5–8).

The delay of the valve position (MV, ``y``) behind the controller output (OP, ``x``)
from the Hannan–Thomson ML-windowed cross-correlation, via
:func:`stictionbench.hosa.tder`. A delay above ``threshold`` samples (MV lags OP) is
read as stiction, as in the seed paper's Table VII.
"""

from __future__ import annotations

from numbers import Integral, Real
from typing import Any, ClassVar

import numpy as np

from .. import hosa
from ..recording import Recording
from ..validation import Constraint, Interval, check_pair
from .base import EstimateResult, Estimator

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
    loop_dead_time, loop_time_constant : float, optional
        Dead time θ and time constant τ (s) of the process, when known; default: read
        from a simulated Recording's config, else unknown. They place the loop's
        backward path (see :func:`backward_path`).

    Notes
    -----
    ``value`` is the interpolated delay in samples (positive: ``y`` = MV lags
    ``x`` = OP); ``decision`` is ``value > threshold``. Diagnostics hold the delay in
    seconds, the curve and its lags, ``at_edge`` (peak at an end of the lag window,
    i.e. not a measured delay), ``beyond_max_delay``, the three largest peaks, the second
    peak, and where the loop's backward path MV → PV → CO would put a peak.
    """

    name = "xcorr"
    default_x = "OP"
    default_y = "MV"

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "max_delay": [Interval(Integral, 1, None)],
        "segsamp": [Interval(Integral, 4, None), None],
        "overlap": [Interval(Real, 0, 99)],
        "nfft": [Interval(Integral, 2, None), None],
        "threshold": [Interval(Real, 0, None)],
        "loop_dead_time": [Interval(Real, 0, None), None],
        "loop_time_constant": [Interval(Real, 0, None), None],
    }

    def __init__(
        self,
        max_delay: int = 30,
        segsamp: int | None = None,
        overlap: float = 50,
        nfft: int | None = None,
        threshold: float = 0.5,
        loop_dead_time: float | None = None,
        loop_time_constant: float | None = None,
    ) -> None:
        self.max_delay = max_delay
        self.segsamp = segsamp
        self.overlap = overlap
        self.nfft = nfft
        self.threshold = threshold
        self.loop_dead_time = loop_dead_time
        self.loop_time_constant = loop_time_constant

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
        peaks = top_peaks(lags, res.rxy)
        diag: dict[str, Any] = {
            "delay_s": delay * rec.Ts,
            "at_edge": bool(res.at_edge),
            "beyond_max_delay": bool(abs(delay) > max_delay),
            "peak_value": float(res.rxy[int(np.argmax(np.abs(res.rxy)))]),
            "peaks": peaks,
            "second_peak_lag": peaks[1][0] if len(peaks) > 1 else None,
            "second_peak_value": peaks[1][1] if len(peaks) > 1 else None,
            **backward_path(delay, rec, self.loop_dead_time, self.loop_time_constant),
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


def backward_path(delay: float, rec: Recording, dead_time: float | None = None,
                  time_constant: float | None = None) -> dict[str, Any]:
    """Where the loop's own backward path puts a cross-correlation peak of MV on CO.

    In a closed loop CO also follows MV: a change of MV reaches PV after the process
    dead time θ (and its lag τ), and the controller turns it into CO at once. A peak of
    the CO→MV cross-correlation at a *negative* lag between ``−(θ + τ)/Ts`` and
    ``−θ/Ts`` is that linear path (CO lagging MV), not a delay of the valve.

    Returns
    -------
    dict
        ``backward_path_lag`` (``−θ/Ts``), ``backward_path_window`` (``[−(θ+τ)/Ts,
        −θ/Ts]``) and ``on_backward_path`` (delay inside the window ± 1 sample); Nones
        when θ is unknown.
    """
    if dead_time is None:
        proc = (rec.meta.get("config") or {}).get("process") or {}
        dead_time = proc.get("dead_time")
        time_constant = proc.get("time_constant") if time_constant is None else time_constant
    if dead_time is None:
        return {"backward_path_lag": None, "backward_path_window": None,
                "on_backward_path": None}
    tau = float(time_constant or 0.0)
    lo, hi = -(float(dead_time) + tau) / rec.Ts, -float(dead_time) / rec.Ts
    return {"backward_path_lag": hi, "backward_path_window": [lo, hi],
            "on_backward_path": bool(lo - 1.0 <= delay <= hi + 1.0)}
