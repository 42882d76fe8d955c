"""Hägglund's shape analysis: is each half period of the control error closer to a square
wave or to a sine wave?

In a flow loop the process is fast against the oscillation, so the control error follows
the valve position: with a sticky valve it sits still while the valve is stuck and jumps
when it slips, a square wave (the loop behaves as a relay feedback system, the controller
output ramping between the jumps). An oscillation from tight tuning or an external
disturbance is close to a sine wave. Each half period is compared with both shapes.
"""

from __future__ import annotations

import math
from numbers import Integral, Real
from typing import ClassVar

import numpy as np

from ..recording import Recording
from ..validation import Constraint, Interval, TypeOf
from .base import EstimateResult
from .detector import StictionDetector, half_cycles


def shape_indices(e: np.ndarray, period: float, exclude: np.ndarray | None = None
                  ) -> np.ndarray:
    """Hägglund's stiction index ``(V_sin − V_sq)/(V_sin + V_sq)`` of every complete half
    period of a zero-mean oscillating signal.

    For the half period between the interpolated zero crossings ``z0`` and ``z1``
    (:func:`~.detector.half_cycles`, which leaves out those holding an index of
    ``exclude``), of length ``T = z1 − z0`` and with ``IAE`` the area of ``|e|``
    (trapezoidal, zero at both crossings): the square wave of the same ``IAE`` has the
    height ``IAE/T``, the sine half wave the amplitude ``π·IAE/(2T)``; ``V_sq`` and
    ``V_sin`` are the sums of squared deviations of ``|e|`` from them at the samples of
    the half period. The index is +1 for a square wave, −1 for a sine wave, 0 when ``|e|``
    is equally far from both.

    Examples
    --------
    >>> n = np.arange(1000)
    >>> bool(np.all(shape_indices(np.sin(2 * np.pi * n / 100 + 0.1), 100.0) < -0.99))
    True
    >>> square = np.sign(np.sin(2 * np.pi * (n + 0.5) / 100))
    >>> bool(np.all(shape_indices(square, 100.0) > 0.9))
    True
    """
    out = []
    for z0, a, b, z1 in half_cycles(e, period, exclude=exclude):
        t = np.arange(a, b, dtype=float)
        mag = np.abs(np.asarray(e[a:b], dtype=float))
        T = z1 - z0
        if T <= 0 or mag.size < 2:
            continue
        tt = np.concatenate([[z0], t, [z1]])
        yy = np.concatenate([[0.0], mag, [0.0]])
        iae = float(np.sum(0.5 * (yy[1:] + yy[:-1]) * np.diff(tt)))
        v_sq = float(np.sum((mag - iae / T) ** 2))
        v_sin = float(np.sum((mag - 0.5 * math.pi * iae / T
                              * np.sin(math.pi * (t - z0) / T)) ** 2))
        if v_sq + v_sin > 0:
            out.append((v_sin - v_sq) / (v_sin + v_sq))
    return np.asarray(out, dtype=float)


class Hagglund(StictionDetector):
    """Shape-analysis stiction test of Hägglund (2011).

    Steps: take the control error ``SP − PV`` (``use_error``; PV when no set point is
    recorded), check it oscillates (ACF regularity, Thornhill et al. 2003; else
    inconclusive, "no oscillation"), filter it around the oscillation keeping ten
    harmonics (:func:`~.detector.harmonic_filter`; the odd harmonics up to the ninth
    keep a square wave square), cut it into half periods at its zero crossings, leave
    out those holding a set-point change, and compute the stiction index of each
    (:func:`shape_indices`); ``value`` is the mean index.

    Decision: index above ``threshold`` (0, where the error is as close to a square wave
    as to a sine wave: the index's own boundary) stiction, else no stiction. The premise
    is a process fast against the oscillation, so the test is applied to flow loops
    (``flow_loop``); elsewhere a sticky valve gives a triangular or sinusoidal error and
    the verdict is inconclusive ("not a flow loop").

    Hägglund's online version counts only half periods whose IAE exceeds his load
    detector's limit (Hägglund 1995); here the oscillation gate and the harmonic filter
    play that part (our substitution, as for the other shape-based detectors).

    Parameters
    ----------
    use_error : bool
        Use ``SP − PV`` when the set point is recorded, else PV.
    flow_loop : bool
        The loop controls a flow (a process fast against the oscillation).
    threshold : float
        Mean index above which the verdict is stiction.
    min_half_cycles : int
        Fewer complete half periods: inconclusive ("too short").

    References
    ----------
    T. Hägglund, "A shape-analysis approach for diagnosis of stiction in control valves",
    Control Engineering Practice 19 (2011) 782–789; T. Hägglund, "A control-loop
    performance monitor", Control Engineering Practice 3 (1995) 1543–1551.
    """

    name = "hagglund"
    default_x = "OP"
    default_y = "PV"

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "use_error": [TypeOf(bool)],
        "flow_loop": [TypeOf(bool)],
        "threshold": [Interval(Real, -1, 1)],
        "min_half_cycles": [Interval(Integral, 1, None)],
    }

    def __init__(self, use_error: bool = True, flow_loop: bool = False,
                 threshold: float = 0.0, min_half_cycles: int = 4) -> None:
        self.use_error = use_error
        self.flow_loop = flow_loop
        self.threshold = threshold
        self.min_half_cycles = min_half_cycles

    def _estimate(self, x: np.ndarray, y: np.ndarray | None, rec: Recording
                  ) -> EstimateResult:
        osc, idx, why = self._error_half_cycles(x, y, rec, shape_indices)
        if why:
            return self._no_oscillation(osc, why, threshold=self.threshold)
        value = float(np.mean(idx)) if idx.size else math.nan
        if not self.flow_loop:
            decision, reason = None, "not a flow loop"
        elif idx.size < self.min_half_cycles:
            decision, reason = None, "too short"
        elif value > self.threshold:
            decision, reason = True, "square-wave control error"
        else:
            decision, reason = False, "sine-wave control error"
        return self._result(
            value, decision, reason, median_index=float(np.median(idx)) if idx.size
            else math.nan, n_half_cycles=int(idx.size), threshold=self.threshold,
            flow_loop=self.flow_loop, period_samples=osc.period_samples,
            regularity=osc.regularity, indices=idx)
