"""Singhal & Salsbury's area ratio: where in each half cycle does the error peak?

With a sticky valve in a self-regulating loop the control error jumps when the valve
slips and then creeps towards its extreme while the valve stays stuck: the peak of
each half cycle comes late, the area under the error before the peak (``A1``) exceeds
the area after it (``A2``). A sinusoid gives ``A1 = A2``.
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


def area_ratios(e: np.ndarray, period: float, exclude: np.ndarray | None = None
                ) -> np.ndarray:
    """``R = A1 / A2`` of every complete half cycle of a zero-mean oscillating signal.

    In each half cycle (:func:`~.detector.half_cycles`, which leaves out those holding
    an index of ``exclude``) the peak is at the sample of largest ``|e|``, refined by a
    three-point parabola (a peak off by half a sample would move a sinusoid's ratio by
    about 5 % at 50 samples per half cycle); ``A1`` is the area of ``|e|`` from the
    interpolated zero crossing that opens the half cycle to the peak and ``A2`` from the
    peak to the closing crossing (trapezoidal rule). Half cycles with ``A2 = 0`` are
    skipped.

    Examples
    --------
    >>> n = np.arange(1000)
    >>> r = area_ratios(np.sin(2 * np.pi * n / 100 + 0.1), 100.0)
    >>> bool(np.all(np.abs(r - 1) < 0.05))
    True
    """
    out = []
    for z0, a, b, z1 in half_cycles(e, period, exclude=exclude):
        t = np.concatenate([[z0], np.arange(a, b, dtype=float), [z1]])
        seg = np.concatenate([[0.0], np.abs(e[a:b]), [0.0]])
        k = 1 + int(np.argmax(seg[1:-1]))
        y0, y1, y2 = seg[k - 1], seg[k], seg[k + 1]
        den = y0 - 2.0 * y1 + y2
        # parabolic vertex between the neighbours (their spacing is at most 1 sample)
        frac = 0.5 * (y0 - y2) / den if den < 0 else 0.0
        tp = t[k] + frac * (t[k + 1] - t[k] if frac > 0 else t[k] - t[k - 1])
        area = np.concatenate([[0.0], np.cumsum(0.5 * (seg[1:] + seg[:-1]) * np.diff(t))])
        a1 = float(np.interp(tp, t, area))
        a2 = float(area[-1]) - a1
        if a2 > 0:
            out.append(a1 / a2)
    return np.asarray(out, dtype=float)


class AreaRatio(StictionDetector):
    """Area-ratio stiction test of Singhal & Salsbury (2005).

    Steps: take the control error ``SP − PV`` (``use_error``; PV when no set point is
    recorded), check it oscillates (ACF regularity, Thornhill et al. 2003; else
    inconclusive, "no oscillation"), filter it around the oscillation keeping ten
    harmonics (noise would move the peak; :func:`~.detector.harmonic_filter`), cut it
    into half cycles at its zero crossings, leave out those holding a set-point change
    (a forced response, not the loop's oscillation: our addition, the paper treats
    regulatory data) and compute ``R = A1/A2`` for each (:func:`area_ratios`);
    ``value`` is the mean ``R``.

    Published rule: ``R > 1`` stiction, ``R ≈ 1`` (a sinusoid) no stiction. A noisy
    sinusoid scatters ``R`` around 1, so a band is kept: ``R <= 1`` no stiction,
    ``1 < R <= 1 + margin`` inconclusive, ``R > 1 + margin`` stiction. ``margin = 0.1``
    is our choice (not from the paper), a tolerance, not fitted to any data.

    Parameters
    ----------
    use_error : bool
        Use ``SP − PV`` when the set point is recorded, else PV.
    margin : float
        Width of the inconclusive band above ``R = 1``.
    min_half_cycles : int
        Fewer complete half cycles: inconclusive ("too short").

    References
    ----------
    A. Singhal, T. I. Salsbury, "A simple method for detecting valve stiction in
    oscillating control loops", Journal of Process Control 15 (2005) 371–382.
    """

    name = "area_ratio"
    default_x = "OP"
    default_y = "PV"

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "use_error": [TypeOf(bool)],
        "margin": [Interval(Real, 0, None)],
        "min_half_cycles": [Interval(Integral, 1, None)],
    }

    def __init__(self, use_error: bool = True, margin: float = 0.1,
                 min_half_cycles: int = 4) -> None:
        self.use_error = use_error
        self.margin = margin
        self.min_half_cycles = min_half_cycles

    def _estimate(self, x: np.ndarray, y: np.ndarray | None, rec: Recording
                  ) -> EstimateResult:
        osc, ratios, why = self._error_half_cycles(x, y, rec, area_ratios)
        if why:
            return self._no_oscillation(osc, why, margin=self.margin)
        r = float(np.mean(ratios)) if ratios.size else float("nan")
        if ratios.size < self.min_half_cycles:
            decision, reason = None, "too short"
        elif r > 1.0 + self.margin:
            decision, reason = True, "late peaks"
        elif r <= 1.0:
            decision, reason = False, "symmetric or early peaks"
        else:
            decision, reason = None, "ratio within the margin"
        return self._result(
            r, decision, reason, median_ratio=float(np.median(ratios)) if ratios.size
            else math.nan, n_half_cycles=int(ratios.size), margin=self.margin,
            period_samples=osc.period_samples, regularity=osc.regularity, ratios=ratios)
