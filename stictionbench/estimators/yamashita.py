"""Yamashita's qualitative-shape stiction index from the OP–MV plot.

Each sample of the controller output (OP) and valve position (MV) is described by a
symbol — I (increasing), D (decreasing) or S (steady) — and each sample of the pair by
two symbols, OP's then MV's. A sticky valve spends long stretches in IS and DS (OP moves,
the valve does not); a healthy valve moves with OP (II, DD). In a flow loop the flow
(PV) follows the valve without dynamics, so PV may stand in for an unrecorded MV.
"""

from __future__ import annotations

from numbers import Real
from typing import ClassVar

import numpy as np

from ..rates import wilson
from ..recording import Recording
from ..validation import Constraint, Interval, TypeOf
from .base import EstimateResult
from .detector import StictionDetector
from .kano import finite_pair
from .noise_floor import difference_noise, measured_samples
from .slip_exit import NO_DIRECTION, controller_direction, slip_ended, slip_note

SYMBOLS = ("D", "S", "I")


def symbols(x: np.ndarray, tolerance: float, noise_factor: float = 3.0) -> np.ndarray:
    """Qualitative symbol of each first difference of ``x``: ``-1`` (D), ``0`` (S), ``1``
    (I). A difference is steady when ``|Δx|`` is within ``tolerance·std(Δx)`` or within
    ``noise_factor`` times the noise of the differences (:func:`difference_noise`), so
    that measurement noise alone reads as steady.

    Examples
    --------
    >>> x = np.r_[np.arange(6.0), np.full(4, 5.0), np.arange(4.0, 1.0, -1)]
    >>> "".join("DSI"[q + 1] for q in symbols(x, 0.1))
    'IIIIISSSSDDD'
    """
    d = np.diff(np.asarray(x, dtype=float))
    band = steady_band(x, tolerance, noise_factor)
    q = np.zeros(d.size, dtype=int)
    q[d > band] = 1
    q[d < -band] = -1
    return q


def steady_band(x: np.ndarray, tolerance: float, noise_factor: float = 3.0) -> float:
    """The band within which a first difference of ``x`` reads as steady
    (:func:`symbols`): ``tolerance`` standard deviations of the differences or
    ``noise_factor`` times their noise level, whichever is larger."""
    d = np.diff(np.asarray(x, dtype=float))
    return max(tolerance * float(d.std()), noise_factor * difference_noise(x))


def slip_ended_stuck(op: np.ndarray, mv: np.ndarray, tolerance: float, direction: int,
                     measured: np.ndarray | None = None) -> int:
    """Samples of OP moving while the valve stays steady (IS, DS) that lie in runs of
    steady valve ending in a slip the way OP pushed (:func:`.slip_exit.slip_ended`, the
    valve's steady band as the slip's size); counted as :func:`pattern_times` counts
    them, over the measured samples where a historian's holds were filled in (the slip's
    two samples are then measured ones).

    The slip's size is this detector's steady band (:func:`steady_band`), a band on
    *first differences*, here compared with a move of the *level* from the run's
    median: a slip is a move larger than one difference may be, the way OP pushed.

    Examples
    --------
    >>> op = np.r_[np.arange(10.0), np.full(5, 9.0)]
    >>> mv = np.r_[np.zeros(10), np.full(5, 9.0)]     # stuck while OP rises, then a jump
    >>> slip_ended_stuck(op, mv, 0.1, 1), slip_ended_stuck(op, -mv, 0.1, 1)
    (9, 0)
    """
    weights = None
    if measured is not None:
        at = np.flatnonzero(measured)
        op, mv, weights = np.asarray(op)[at], np.asarray(mv)[at], np.diff(at)
    qo, qm = symbols(op, tolerance), symbols(mv, tolerance)
    stuck = (qo != 0) & (qm == 0)
    w = np.ones(qm.size) if weights is None else np.asarray(weights, dtype=float)
    # runs of steady valve over the differences a..k-1: the samples a..k are steady
    edges = np.diff(np.r_[0, (qm == 0).astype(np.int8), 0])
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    slipped = slip_ended(op, mv, np.column_stack([starts, stops + 1]),
                         steady_band(mv, tolerance), direction)
    total = sum(float(w[a:b][stuck[a:b]].sum())
                for a, b, ok in zip(starts, stops, slipped, strict=True) if ok)
    return int(round(total))


def pattern_times(op: np.ndarray, mv: np.ndarray, tolerance: float,
                  measured: np.ndarray | None = None) -> dict[str, int]:
    """Samples spent in each of the nine OP–MV symbol pairs (``"IS"``: OP increasing,
    MV steady, ...).

    ``measured`` (a mask of the samples) reads a record whose historian holds were
    filled in: the symbols are those of the changes from one measured sample to the
    next (the steady band measured on those changes), each counted for the samples it
    spans. A straight line drawn over a hold
    spreads a change over many samples, each step below the steady band, and moves OP
    and the valve together by construction; the change across the gap is what was
    measured (OP moved beyond its band while the valve did not: a stick).

    Examples
    --------
    >>> op = np.arange(10.0)
    >>> mv = np.r_[np.zeros(5), np.arange(5.0)]
    >>> t = pattern_times(op, mv, 0.1)
    >>> t["IS"], t["II"], t["SS"]
    (5, 4, 0)
    >>> keep = np.ones(10, bool); keep[1:4] = False    # samples 1-3 filled in
    >>> t = pattern_times(op, mv, 0.1, keep)
    >>> t["IS"], t["II"], t["SS"]
    (5, 4, 0)
    """
    weights = None
    if measured is not None:
        at = np.flatnonzero(measured)
        op, mv, weights = np.asarray(op)[at], np.asarray(mv)[at], np.diff(at)
    qo, qm = symbols(op, tolerance), symbols(mv, tolerance)
    code = (qo + 1) * 3 + (qm + 1)
    counts = np.bincount(code, weights=weights, minlength=9)
    return {SYMBOLS[i // 3] + SYMBOLS[i % 3]: int(round(counts[i])) for i in range(9)}


class Yamashita(StictionDetector):
    """Stiction index of Yamashita (2006) from the qualitative shape of the OP–MV plot.

    Steps: describe each first difference of OP and of MV by I, D or S
    (:func:`symbols`: steady within ``tolerance`` standard deviations of the signal's
    differences or within three times their noise level), count the samples in each
    OP–MV pair (:func:`pattern_times`) and form

    ``ρ = (τ_IS + τ_DS) / (τ_total − τ_SS)``,

    the share of the time in which something moves that OP moves while the valve stays
    put. Where a historian's holds were filled in (the recording's ``meta[FILLED]``,
    :func:`~.noise_floor.measured_samples`), the symbols are those of the changes
    between measured samples, each counted for the samples it spans
    (:func:`pattern_times`). Published rule: ``ρ > 0.25`` stiction, else no
    stiction. The verdict is the published rule's; its diagnostics add how many moving
    samples ``ρ`` rests on and its Wilson 95 % interval (``moving``, ``rho_interval``,
    in words ``evidence``: on noisy records sampled slowly, few differences leave the
    noise band — 2 to 56 of 750 on the refinery's stiction flow loop,
    ``reports/real/yamashita_evidence.md`` — and ``ρ`` is then a ratio of small counts;
    the samples are not independent, so the interval understates the uncertainty).
    Inconclusive when OP's range is within ``op_tolerance`` ("OP constant": movements
    inside a good valve's 1 % dead band cannot tell), when nothing moves ("no
    movement") or when MV is not recorded and the loop is not a flow loop ("not a flow
    loop"); in a flow loop (``flow_loop=True``) PV stands in for a missing MV.

    With ``slip_exit=True`` and PV standing in for MV, only the IS and DS samples of runs
    of steady PV that end in a slip the way OP pushed count as stuck
    (:func:`slip_ended_stuck`, :mod:`.slip_exit`): a PI holding a flow against a load
    also moves OP while PV stays in its band, and only a sticky valve ends such a run
    with a jump. Our addition, off by default (``reports/real/slip_exit.md``).

    The steady band (``tolerance = 0.1`` and the 3-σ noise floor) and ``op_tolerance``
    are our a-priori choices (as in :class:`~.kano.Kano`); the paper sets the band from
    the signals' noise.

    Parameters
    ----------
    flow_loop : bool
        The loop controls a flow: PV may replace an unrecorded MV.
    tolerance : float
        Steady band of the differences, in standard deviations of the differences.
    threshold : float
        ``ρ`` above which the valve is called sticky (0.25).
    op_tolerance : float
        OP range (% of span; an OP recognised as a fraction of the travel is read as
        such, :meth:`~.detector.StictionDetector.op_percent`) at or below which OP
        counts as constant.
    slip_exit : bool
        Where PV stands in for MV, count only the stuck runs that end in a slip.

    References
    ----------
    Y. Yamashita, "An automatic method for detection of valve stiction in process
    control loops", Control Engineering Practice 14 (2006) 503–510.
    """

    name = "yamashita"
    default_x = "OP"
    default_y = "MV"
    optional_y = True

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "flow_loop": [TypeOf(bool)],
        "tolerance": [Interval(Real, 0, None)],
        "threshold": [Interval(Real, 0, 1)],
        "op_tolerance": [Interval(Real, 0, None)],
        "slip_exit": [TypeOf(bool)],
    }

    def __init__(self, flow_loop: bool = False, tolerance: float = 0.1,
                 threshold: float = 0.25, op_tolerance: float = 1.0,
                 slip_exit: bool = False) -> None:
        self.flow_loop = flow_loop
        self.tolerance = tolerance
        self.threshold = threshold
        self.op_tolerance = op_tolerance
        self.slip_exit = slip_exit

    def _estimate(self, x: np.ndarray, y: np.ndarray | None, rec: Recording
                  ) -> EstimateResult:
        rule = {"threshold": self.threshold, "tolerance": self.tolerance,
                "op_tolerance": self.op_tolerance, "flow_loop": self.flow_loop,
                "slip_exit": self.slip_exit}
        nan = float("nan")
        y, valve = self.valve_signal(y, rec)
        if y is None:
            return self._result(nan, None, "not a flow loop", valve=None, **rule)
        finite_pair(self.name, x, y)
        if np.ptp(x) <= self.op_tolerance * self.op_percent(x, rec):
            return self._result(nan, None, self.op_constant(x, rec), valve=valve, **rule)
        measured = measured_samples(rec.meta, x.size)
        times = pattern_times(x, y, self.tolerance, measured)
        moving = sum(times.values()) - times["SS"]
        if moving <= 0:
            return self._result(nan, None, "no movement", valve=valve, **rule)
        stuck = times["IS"] + times["DS"]
        checked, reason = {}, None
        if self.slip_exit and valve == "PV":
            direction = controller_direction(x, y, rec.SP)
            if direction == 0:
                return self._result(nan, None, NO_DIRECTION, valve=valve, **rule)
            steady = stuck
            stuck = slip_ended_stuck(x, y, self.tolerance, direction, measured)
            checked, reason = slip_note(steady / moving, stuck / moving, self.threshold,
                                        direction)
        rho = stuck / moving
        decision = rho > self.threshold
        lo, hi = wilson(stuck, moving)
        return self._result(
            rho, decision, reason or ("valve steady while OP moves" if decision
                                      else "valve moves with OP"),
            valve=valve, moving=int(moving), rho_interval=(lo, hi), **checked,
            filled_samples=0 if measured is None else int((~measured).sum()),
            evidence=f"ρ = {rho:.2f} from {moving} moving samples, 95 % [{lo:.2f}, {hi:.2f}]",
            **{f"time_{k}": v for k, v in times.items()}, **rule)
