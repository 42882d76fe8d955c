"""He, Wang, Pottmann & Qin's curve-fitting stiction index: triangle or sinusoid?

A sticky valve in a self-regulating loop turns the control error into a near square
wave, which the controller's integral action turns into a *triangular* controller
output; an oscillation from a disturbance or aggressive tuning is close to a
*sinusoid*. Fitting both shapes to each half cycle and comparing the fits gives the
stiction index ``SI = MSE_sin / (MSE_sin + MSE_tri)`` in ``[0, 1]``.
"""

from __future__ import annotations

import math
from numbers import Integral, Real
from typing import ClassVar

import numpy as np
from scipy import optimize

from ..recording import Recording
from ..validation import Constraint, Interval, TypeOf
from .base import EstimateResult
from .detector import (
    StictionDetector,
    half_cycles,
    harmonic_filter,
    loop_signals,
    ordered,
    self_oscillation,
    setpoint_changes,
    three_way,
)


def _profile_sse(designs: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Residual sum of squares of ``z`` on each design matrix of a stack (K, n, p)."""
    gram = np.einsum("kni,knj->kij", designs, designs)
    rhs = np.einsum("kni,n->ki", designs, z)
    gram = gram + 1e-12 * np.trace(gram, axis1=1, axis2=2)[:, None, None] * np.eye(
        designs.shape[2])
    coef = np.linalg.solve(gram, rhs[..., None])[..., 0]
    resid = z[None, :] - np.einsum("knp,kp->kn", designs, coef)
    return np.sum(resid * resid, axis=1)


def _grid_then_refine(design, grid: np.ndarray, z: np.ndarray) -> float:
    """Smallest profile SSE over a 1-D nonlinear parameter: the best of ``grid``, then a
    bounded scalar search between its neighbours (``design(p)`` gives the (n, k) matrix
    of the linear parameters for the nonlinear one ``p``)."""
    sse = _profile_sse(np.stack([design(p) for p in grid]), z)
    i = int(np.argmin(sse))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    if hi <= lo:
        return float(sse[i])
    res = optimize.minimize_scalar(lambda p: float(_profile_sse(design(p)[None], z)[0]),
                                   bounds=(lo, hi), method="bounded",
                                   options={"xatol": 1e-3 * (hi - lo)})
    return float(min(sse[i], res.fun))


def fit_triangle(z: np.ndarray) -> float:
    """Smallest residual sum of squares of a triangle (two straight lines meeting at an
    apex ``t_p``) fitted to ``z``.

    The model ``a + b·t + c·max(0, t − t_p)`` is linear once ``t_p`` is fixed: every
    interior sample is tried as the apex, then the apex is refined between the best
    one's neighbours.

    Examples
    --------
    >>> t = np.arange(40.0)
    >>> round(fit_triangle(np.minimum(t, 30.5 - 0.5 * t)), 6)
    0.0
    """
    t = np.arange(z.size, dtype=float)
    one = np.ones_like(t)

    def design(tp: float) -> np.ndarray:
        return np.column_stack([one, t, np.maximum(0.0, t - tp)])

    return _grid_then_refine(design, t[1:-1], z)


def fit_sinusoid(z: np.ndarray, n_freq: int = 31) -> float:
    """Smallest residual sum of squares of ``A·sin(ω t + φ) + b`` fitted to ``z``.

    ``ω`` runs over ``n_freq`` values from 0.5 to 2 times ``π/n`` (half a cycle in the
    window) and is refined between the best one's neighbours; ``A, φ, b`` are the
    least-squares fit at each ``ω``.

    Examples
    --------
    >>> t = np.arange(50.0)
    >>> round(fit_sinusoid(3 * np.sin(np.pi * t / 47) + 1), 6)
    0.0
    """
    t = np.arange(z.size, dtype=float)
    one = np.ones_like(t)

    def design(w: float) -> np.ndarray:
        return np.column_stack([np.sin(w * t), np.cos(w * t), one])

    return _grid_then_refine(design, np.linspace(0.5, 2.0, n_freq) * math.pi / z.size, z)


def stiction_index(s: np.ndarray, period: float, max_points: int = 100,
                   exclude: np.ndarray | None = None) -> tuple[float, float, float, int]:
    """He et al.'s stiction index of an oscillating signal.

    The signal is cut into half cycles at its zero crossings
    (:func:`~.detector.half_cycles`); each half cycle is resampled to at most
    ``max_points`` samples (the fit is of a shape) and fitted by a triangle and a
    sinusoid; the mean squared errors are pooled over all half cycles. Half cycles
    holding an index of ``exclude`` (set-point changes) are left out.

    Returns
    -------
    (si, mse_sin, mse_tri, n_half_cycles)
        ``SI = MSE_sin / (MSE_sin + MSE_tri)`` (NaN without half cycles or when both
        fits are exact).
    """
    sse_sin = sse_tri = 0.0
    points = 0
    cycles = half_cycles(s, period, exclude=exclude)
    for _, a, b, _ in cycles:
        idx = np.unique(np.round(np.linspace(a, b - 1, min(b - a, max_points))).astype(int))
        if idx.size < 5:
            continue
        z = s[idx]
        sse_sin += fit_sinusoid(z)
        sse_tri += fit_triangle(z)
        points += idx.size
    if points == 0:
        nan = float("nan")
        return nan, nan, nan, 0
    mse_sin, mse_tri = sse_sin / points, sse_tri / points
    total = mse_sin + mse_tri
    si = mse_sin / total if total > 0 else float("nan")
    return si, mse_sin, mse_tri, len(cycles)


class He(StictionDetector):
    """Curve-fitting stiction index of He, Wang, Pottmann & Qin (2007).

    Steps: check that the loop oscillates (ACF regularity of the control error
    ``SP − PV``, Thornhill et al. 2003; else inconclusive, "no oscillation"); take OP
    for a self-regulating loop or the control error (PV) for an ``integrating`` one,
    filter it around the oscillation keeping ten harmonics
    (:func:`~.detector.harmonic_filter`, which keeps the triangle's corners), cut it into
    half cycles at its zero crossings (leaving out those holding a set-point change, a
    forced response rather than the loop's oscillation: our addition, the paper treats
    regulatory data), fit a triangle and a sinusoid to each half cycle by least squares
    (:func:`fit_triangle`, :func:`fit_sinusoid`) and compute
    ``SI = MSE_sin / (MSE_sin + MSE_tri)``. Published rule: ``SI <= 0.4`` no stiction,
    ``SI >= 0.6`` stiction, in between inconclusive. ``value`` is SI.

    Parameters
    ----------
    integrating : bool
        The process is integrating (a level): fit the control error instead of OP.
    use_error : bool
        Use ``SP − PV`` (when SP is recorded) for the oscillation check and, in an
        integrating loop, for the fit.
    low, high : float
        SI at or below ``low``: no stiction; at or above ``high``: stiction.
    min_half_cycles : int
        Fewer complete half cycles: inconclusive ("too short").

    References
    ----------
    Q. P. He, J. Wang, M. Pottmann, S. J. Qin, "A curve fitting method for detecting
    valve stiction in oscillating control loops", Ind. Eng. Chem. Res. 46 (2007)
    4549–4560.
    """

    name = "he"
    default_x = "OP"
    default_y = "PV"

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "integrating": [TypeOf(bool)],
        "use_error": [TypeOf(bool)],
        "low": [Interval(Real, 0, 1)],
        "high": [Interval(Real, 0, 1)],
        "min_half_cycles": [Interval(Integral, 1, None)],
    }

    def __init__(self, integrating: bool = False, use_error: bool = True, low: float = 0.4,
                 high: float = 0.6, min_half_cycles: int = 4) -> None:
        self.integrating = integrating
        self.use_error = use_error
        self.low = low
        self.high = high
        self.min_half_cycles = min_half_cycles

    def _estimate(self, x: np.ndarray, y: np.ndarray | None, rec: Recording
                  ) -> EstimateResult:
        ordered(self.name, "low", self.low, "high", self.high)
        x, e = loop_signals(self.name, x, y, rec, self.use_error)
        rule = {"low": self.low, "high": self.high, "fitted": "PV" if self.integrating
                else "OP"}
        osc, why = self_oscillation(e, rec)
        if why:
            return self._no_oscillation(osc, why, **rule)
        s = harmonic_filter(e if self.integrating else x, osc.period_samples)
        si, mse_sin, mse_tri, n_half = stiction_index(s, osc.period_samples,
                                                      exclude=setpoint_changes(rec))
        if n_half < self.min_half_cycles:
            decision, reason = None, "too short"
        else:
            decision = three_way(si, self.low, self.high)
            reason = {True: "triangular", False: "sinusoidal", None: "between shapes"
                      }[decision]
        return self._result(si, decision, reason, mse_sin=mse_sin, mse_tri=mse_tri,
                            n_half_cycles=n_half, period_samples=osc.period_samples,
                            regularity=osc.regularity, **rule)
