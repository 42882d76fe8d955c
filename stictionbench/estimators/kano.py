"""Kano, Maruta, Kugemoto & Shimizu's stiction index: how long does the valve stay put
while the controller output moves?

With the valve position (MV) recorded, stiction shows directly: MV stays constant over
stretches in which OP keeps changing. Method A of Kano et al. (2004) finds the
stretches of constant MV, keeps those over which OP changed, and reports the fraction
of the record they cover. In a flow loop the flow (PV) follows the valve without
dynamics and may stand in for an unrecorded MV; "constant" is then judged against PV's
own noise, never against a band in OP's units (PV is in engineering units).
"""

from __future__ import annotations

from numbers import Real
from typing import ClassVar

import numba
import numpy as np

from ..errors import InputError
from ..recording import Recording
from ..validation import Constraint, Interval, TypeOf
from .base import EstimateResult
from .detector import StictionDetector
from .noise_floor import difference_noise
from .slip_exit import NO_DIRECTION, controller_direction, slip_ended, slip_note


@numba.njit(cache=True)
def _constant_sections(mv: np.ndarray, tol: float) -> np.ndarray:  # pragma: no cover
    """``(start, stop)`` rows of the maximal stretches, two samples or more, over which
    ``|mv − mv[start]| <= tol`` (numba: one pass)."""
    n = mv.size
    out = np.empty((n, 2), dtype=np.int64)
    k = 0
    i = 0
    while i < n:
        j = i + 1
        while j < n and abs(mv[j] - mv[i]) <= tol:
            j += 1
        if j - i >= 2:
            out[k, 0] = i
            out[k, 1] = j
            k += 1
        i = j
    return out[:k]


def sticky_sections(op: np.ndarray, mv: np.ndarray, mv_tol: float, op_tol: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Stretches of constant MV, and which of them are sticky (OP moved over them).

    Parameters
    ----------
    op, mv : ndarray
        Controller output and valve position (same length, same units).
    mv_tol : float
        MV counts as constant while within ``mv_tol`` of its value at the start of the
        stretch (absolute units).
    op_tol : float
        A stretch is sticky when OP's range over it exceeds ``op_tol``.

    Returns
    -------
    sections : ndarray, shape (k, 2)
        ``(start, stop)`` of each stretch (``stop`` exclusive).
    sticky : ndarray of bool, shape (k,)

    Examples
    --------
    >>> op = np.r_[np.linspace(0, 5, 50), np.linspace(5, 10, 50)]
    >>> mv = np.r_[np.zeros(50), np.linspace(5, 10, 50)]
    >>> sec, sticky = sticky_sections(op, mv, 0.01, 0.5)
    >>> sec[sticky].tolist()
    [[0, 50]]
    """
    sections = _constant_sections(np.ascontiguousarray(mv, dtype=float), float(mv_tol))
    if sections.shape[0] == 0:
        return sections, np.zeros(0, dtype=bool)
    start, stop = sections[:, 0], sections[:, 1]
    op_max = np.maximum.reduceat(op, start)
    op_min = np.minimum.reduceat(op, start)
    # reduceat runs to the next start; clip each to its own stop where they differ
    gaps = np.flatnonzero(np.r_[start[1:], op.size] != stop)
    for g in gaps:
        seg = op[start[g]:stop[g]]
        op_max[g], op_min[g] = seg.max(), seg.min()
    return sections, (op_max - op_min) > op_tol


class Kano(StictionDetector):
    """Stiction index of Kano et al. (2004), method A (needs the valve position MV).

    Steps: find the maximal stretches over which MV stays within a band of its value at
    the stretch's start; call a stretch sticky when OP's range over it exceeds
    ``op_tolerance``; the stiction index is ``ρ = Σ τ_sticky / T``, the fraction of the
    record ``T`` covered by sticky stretches of lengths ``τ``. ``ρ > threshold`` is
    stiction, else no stiction. Inconclusive when MV is not recorded and the loop is not
    a flow loop ("MV not recorded"; with ``flow_loop=True`` PV stands in for it) or OP
    does not move ("OP constant").

    The band: Kano et al. set their thresholds from the noise level of the plant
    signals. A recorded MV (% of span) is constant within ``max(mv_tolerance,
    noise_factor·σ_Δ)``; PV standing in for MV within ``noise_factor·σ_Δ`` alone, σ_Δ
    being the robust noise of its first differences
    (:func:`~.noise_floor.difference_noise`), because ``mv_tolerance`` is in OP's units
    and PV is not (a first version applied 0.25 to PV in t/h, bar or %: its verdict on
    8 of the 9 ISDB flow loops and 33 of the 36 usable refinery flow windows changed
    when PV was rescaled by 10⁻³ or 10³).
    OP must move by more than the 1 % dead band a good control valve is allowed (EnTech
    control valve dynamic specification, 1998) and by more than its own noise floor
    (``noise_factor·σ_Δ`` of OP: a PI passes PV's noise to OP), while MV stays within a
    quarter of that: our a-priori choices, not fitted to data, as is the noise factor 3
    (Yamashita's floor here). The OP floor was added after the PV one; on the 360
    simulated flow loops of ``experiments/flow_loops.py`` it lowered Kano's false alarms
    from 79 to 60 of 144 and left its detections at 120 of 216. The threshold 0.25 is
    the cut-off Yamashita (2006) publishes for his closely related time fraction; we
    could not confirm a value of Kano et al.'s own.

    Parameters
    ----------
    mv_tolerance : float
        A recorded MV counts as constant within this distance (% of span) or within the
        noise floor, whichever is larger.
    op_tolerance : float
        OP has moved when its range over a stretch exceeds this and OP's noise floor
        (% of span; an OP
        recognised as a fraction of the travel is read as such,
        :meth:`~.detector.StictionDetector.op_percent`).
    threshold : float
        ``ρ`` above which the valve is called sticky.
    flow_loop : bool
        The loop controls a flow: PV may replace an unrecorded MV.
    noise_factor : float
        The noise floor in standard deviations of the first differences' noise.
    slip_exit : bool
        Where PV stands in for MV, count only the sticky stretches that end in a slip
        the way OP pushed (:mod:`.slip_exit`: a PI holding a flow against a load also
        moves OP while PV stays in its band; only a sticky valve ends the stretch with
        a jump). Our addition, off by default (``reports/real/slip_exit.md``).

    References
    ----------
    M. Kano, H. Maruta, H. Kugemoto, K. Shimizu, "Practical model and detection
    algorithm for valve stiction", Proc. IFAC DYCOPS 7, Cambridge MA (2004).
    M. Jelali, B. Huang (eds.), *Detection and Diagnosis of Stiction in Control Loops*,
    Springer (2010) (methods using the valve position).
    """

    name = "kano"
    default_x = "OP"
    default_y = "MV"
    optional_y = True

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "mv_tolerance": [Interval(Real, 0, None, closed="neither")],
        "op_tolerance": [Interval(Real, 0, None, closed="neither")],
        "threshold": [Interval(Real, 0, 1)],
        "flow_loop": [TypeOf(bool)],
        "noise_factor": [Interval(Real, 0, None)],
        "slip_exit": [TypeOf(bool)],
    }

    def __init__(self, mv_tolerance: float = 0.25, op_tolerance: float = 1.0,
                 threshold: float = 0.25, flow_loop: bool = False,
                 noise_factor: float = 3.0, slip_exit: bool = False) -> None:
        self.mv_tolerance = mv_tolerance
        self.op_tolerance = op_tolerance
        self.threshold = threshold
        self.flow_loop = flow_loop
        self.noise_factor = noise_factor
        self.slip_exit = slip_exit

    def _estimate(self, x: np.ndarray, y: np.ndarray | None, rec: Recording
                  ) -> EstimateResult:
        rule = {"threshold": self.threshold, "mv_tolerance": self.mv_tolerance,
                "op_tolerance": self.op_tolerance, "flow_loop": self.flow_loop,
                "noise_factor": self.noise_factor, "slip_exit": self.slip_exit}
        nan = float("nan")
        y, valve = self.valve_signal(y, rec)
        if y is None:
            return self._result(nan, None, "MV not recorded", valve=None, **rule)
        finite_pair(self.name, x, y)
        pct = self.op_percent(x, rec)
        # OP "moved" beyond a good valve's resolution and beyond its own noise (a PI
        # passes PV's noise to OP: that jitter is not a move the valve should follow)
        op_tol = max(self.op_tolerance * pct, self.noise_factor * difference_noise(x))
        if np.ptp(x) <= op_tol:
            return self._result(nan, None, self.op_constant(x, rec), valve=valve, **rule)
        floor = self.noise_factor * difference_noise(y)
        band = floor if valve == "PV" else max(self.mv_tolerance * pct, floor)
        sections, sticky = sticky_sections(x, y, band, op_tol)
        lengths = sections[:, 1] - sections[:, 0]
        checked, reason = {}, None
        if self.slip_exit and valve == "PV":
            direction = controller_direction(x, y, rec.SP)
            if direction == 0:
                return self._result(nan, None, NO_DIRECTION, valve=valve, **rule)
            steady = float(lengths[sticky].sum() / x.size)
            sticky = sticky.copy()
            sticky[sticky] = slip_ended(x, y, sections[sticky], band, direction)
            checked, reason = slip_note(steady, float(lengths[sticky].sum() / x.size),
                                        self.threshold, direction)
        rho = float(lengths[sticky].sum() / x.size)
        decision = rho > self.threshold
        return self._result(
            rho, decision, reason or ("MV stuck while OP moves" if decision
                                      else "MV follows OP"),
            valve=valve, band=band, **checked, n_sections=int(sections.shape[0]),
            n_sticky=int(sticky.sum()),
            constant_fraction=float(lengths.sum() / x.size), **rule,
            sections=sections[sticky])


def finite_pair(name: str, x: np.ndarray, y: np.ndarray) -> None:
    """One-line InputError unless ``x`` and ``y`` are finite 1-D signals of one length
    (a constant signal is allowed: a stuck valve is what these methods look for)."""
    for label, s in (("x", x), ("y", y)):
        if s.ndim != 1 or not np.all(np.isfinite(s)):
            raise InputError(f"{name} {label}: expected a finite 1-D signal")
    if x.size != y.size:
        raise InputError(f"{name}: x has {x.size} samples, y {y.size}")
