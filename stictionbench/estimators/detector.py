"""What the published stiction detectors share: a three-way verdict, the control error,
the oscillation gate and the half cycles of an oscillating signal.

Each detector (``horch``, ``he``, ``area_ratio``, ``kano``, ``yamashita``, ``hagglund``)
subclasses :class:`StictionDetector` and returns an :class:`~.base.EstimateResult` whose
``decision`` is True (stiction), False (no stiction) or None (inconclusive), with the
``verdict`` (``"stiction"``, ``"no_stiction"``, ``"inconclusive"``) and a short
``reason`` in its diagnostics.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
from scipy import signal as sps
from scipy.linalg import lstsq, toeplitz

from ..errors import InputError
from ..op_range import infer_op_range, op_range_of
from ..recording import Recording
from ..validation import check_signal
from .base import EstimateResult, Estimator
from .oscillation import MIN_SAMPLES, AcfOscillation, acf_oscillation, bandpass

#: the verdict names of a three-way decision
VERDICTS = {True: "stiction", False: "no_stiction", None: "inconclusive"}
MEANING = "valve stiction (None: inconclusive)"


def verdict(decision: bool | None) -> str:
    """``"stiction"``, ``"no_stiction"`` or ``"inconclusive"`` for True, False, None.

    Examples
    --------
    >>> verdict(True), verdict(None)
    ('stiction', 'inconclusive')
    """
    return VERDICTS[decision]


def three_way(index: float, low: float, high: float) -> bool | None:
    """The rule "``index <= low``: no stiction, ``index >= high``: stiction, else
    inconclusive" (None also for a NaN index).

    Examples
    --------
    >>> three_way(0.7, 0.4, 0.6), three_way(0.5, 0.4, 0.6), three_way(0.1, 0.4, 0.6)
    (True, None, False)
    """
    if not math.isfinite(index):
        return None
    if index >= high:
        return True
    if index <= low:
        return False
    return None


def control_error(y: np.ndarray, rec: Recording, use_error: bool) -> np.ndarray:
    """The control error ``SP − y`` when ``use_error`` and the set point is recorded,
    else ``y`` itself.

    Most detectors were published for regulatory loops at a constant set point, where
    PV and the control error differ only in sign and mean. Under set-point changes the
    error is the signal that still carries the loop's own dynamics (PV also carries
    the set-point steps).
    """
    if use_error and rec.SP is not None:
        return np.asarray(rec.SP, dtype=float) - y
    return y


def loop_signals(name: str, x: np.ndarray, y: np.ndarray | None, rec: Recording,
                 use_error: bool) -> tuple[np.ndarray, np.ndarray]:
    """Checked OP (``x``) and control error (:func:`control_error` of ``y``, the PV; OP
    itself when ``y`` is None) of a detector named ``name``.

    Raises
    ------
    InputError
        On a non-finite, constant or too short signal.
    """
    x = check_signal(x, f"{name} OP", min_len=MIN_SAMPLES)
    y = check_signal(x if y is None else y, f"{name} PV", min_len=MIN_SAMPLES)
    return x, control_error(y, rec, use_error)


def ordered(name: str, low_name: str, low: float, high_name: str, high: float) -> None:
    """One-line InputError unless ``low <= high`` (the two edges of an inconclusive band)."""
    if low > high:
        raise InputError(f"{name}: parameter {low_name}={low!r} must not exceed "
                         f"{high_name}={high!r}")


def oscillation(x: np.ndarray) -> AcfOscillation:
    """Thornhill, Huang & Zhang (2003) oscillation detection with the defaults of
    :func:`~.oscillation.acf_oscillation` (ACF zero crossings, regularity ``r > 1``)."""
    return acf_oscillation(x)


#: set-point changes per oscillation period from which the set point can drive what
#: looks like the loop's oscillation
SERVO_CHANGES_PER_PERIOD = 0.5
#: largest distance of the set point's period / the oscillation's period from a whole
#: number (1–5) for the oscillation to be that periodic set point's response
HARMONIC_TOL = 0.15


def forced_by_setpoint(x: np.ndarray, rec: Recording, osc: AcfOscillation) -> float | None:
    """The harmonic number ``k`` when the oscillation ``osc`` of ``x`` is the loop's
    response to a periodic set point (its period is the set point's period over ``k``,
    :func:`setpoint_period`, within :data:`HARMONIC_TOL`, and the set point changes at least
    :data:`SERVO_CHANGES_PER_PERIOD` times per oscillation period), else None.

    The published detectors judge the *self-sustained* oscillation of a loop in regulatory
    operation (Jelali & Huang 2010, ch. 2 and 13). Under a periodic (square-wave) set
    point the control error of a linear loop is a train of step responses: periodic with
    the set point, so its ACF period is the set point's period or one of its harmonics,
    and the asymmetric shape of a step response reads as stiction in the shape-based tests.
    A limit cycle (stiction, tight tuning) has its own period, in general not a harmonic
    of the set point's.

    Examples
    --------
    >>> n = np.arange(2000)
    >>> sp = 50 + 10 * (np.sin(2 * np.pi * n / 400) > 0)
    >>> e = np.sin(2 * np.pi * n / 400) + 0.1 * np.cos(2 * np.pi * n / 40)
    >>> rec = Recording.from_arrays(n * 1.0, sp - e, np.zeros(2000), SP=sp)
    >>> forced_by_setpoint(e, rec, oscillation(e))
    1
    >>> cycle = np.sin(2 * np.pi * n / 110)          # a limit cycle of its own period
    >>> forced_by_setpoint(cycle, rec, oscillation(cycle)) is None
    True
    """
    if rec.SP is None or not osc.oscillating:
        return None
    if setpoint_changes(rec).size * osc.period_samples / max(len(x), 1) \
            < SERVO_CHANGES_PER_PERIOD:
        return None
    period = setpoint_period(rec)
    if period is None:
        return None
    r = period / osc.period_samples
    k = round(r)
    return int(k) if 1 <= k <= 5 and abs(r - k) <= HARMONIC_TOL else None


#: most set-point changes in one period of a periodic set point that
#: :func:`step_period` looks for (a square wave has 2, a staircase up and down 4)
MAX_CHANGES_PER_PERIOD = 4


def setpoint_period(rec: Recording) -> float | None:
    """The period in samples of a periodic set point, else None: the ACF period of SP
    (:func:`oscillation`) when its test finds an oscillation, else the period of its
    change times (:func:`step_period`).

    The ACF test needs several periods in the window; a square-wave set point of period
    500 s in a 1000-sample window has two, too few for the regularity test, though every
    change repeats the one a period before. The change times see that periodicity
    (``experiments/setpoint_period.py``).
    """
    if rec.SP is None:
        return None
    sp = oscillation(np.asarray(rec.SP, dtype=float))
    if sp.oscillating:
        return float(sp.period_samples)
    return step_period(rec)


def step_period(rec: Recording, tol: float = HARMONIC_TOL) -> float | None:
    """The period in samples of a piecewise-constant set point whose changes repeat,
    else None.

    The smallest ``q`` (1 to :data:`MAX_CHANGES_PER_PERIOD`) for which every change
    ``i + q`` comes the same time after change ``i`` (spans within ``tol`` of their
    median) with the same step (within ``tol`` of the largest step); the period is the
    median span. Two spans at least are needed (``q + 2`` changes): one span cannot show
    a repetition. Irregular moves (an operator's, a cascade master's output) give None.

    Examples
    --------
    >>> n = np.arange(1100)
    >>> sp = 50 + 10 * ((n // 250) % 2)                    # square wave, period 500
    >>> step_period(Recording.from_arrays(n * 1.0, sp, sp, SP=sp))
    500.0
    >>> sp = 50 + 10 * (n >= 130) - 4 * (n >= 400) + 7 * (n >= 820)
    >>> step_period(Recording.from_arrays(n * 1.0, sp, sp, SP=sp)) is None
    True
    """
    if rec.SP is None:
        return None
    idx = setpoint_changes(rec)
    sp = np.asarray(rec.SP, dtype=float)
    steps = sp[idx] - sp[idx - 1]
    for q in range(1, MAX_CHANGES_PER_PERIOD + 1):
        if idx.size < q + 2:
            return None
        spans = (idx[q:] - idx[:-q]).astype(float)
        med = float(np.median(spans))
        if np.max(np.abs(spans - med)) <= tol * med and \
                np.max(np.abs(steps[q:] - steps[:-q])) <= tol * np.max(np.abs(steps)):
            return med
    return None


def self_oscillation(x: np.ndarray, rec: Recording) -> tuple[AcfOscillation, str | None]:
    """:func:`oscillation` of ``x`` and why the detectors' premise fails (``"no
    oscillation"``, ``"set point moves as often as the loop oscillates"``: a periodic set
    point's response, :func:`forced_by_setpoint`; with :data:`STEP_RESPONSE_GATE` (on),
    ``"the oscillation is the response to the set point's steps"``:
    :func:`step_response_oscillation`), or None when it holds."""
    osc = oscillation(x)
    if not osc.oscillating:
        return osc, "no oscillation"
    if forced_by_setpoint(x, rec, osc) is not None:
        return osc, "set point moves as often as the loop oscillates"
    if STEP_RESPONSE_GATE and step_response_oscillation(x, rec, osc):
        return osc, "the oscillation is the response to the set point's steps"
    return osc, None


#: whether :func:`self_oscillation` hands back an oscillation that is the response to
#: the set point's steps (:func:`step_response_oscillation`). On since the pre-set
#: decision of ``experiments/setpoint_response_scope.py`` was met: on held-out windows
#: under irregular set-point moves it cut healthy windows called stiction from 28 % to
#: 15 % (stiction found 78 % -> 76 %), left occasional moves unchanged (balanced accuracy
#: 0.727 both) and square waves a little better (0.832 -> 0.844), and moved no verdict
#: of the 32 real loops (``reports/real/setpoint_response_scope.md``). The first try,
#: without :data:`STEP_RESPONSE_MIN_CHANGES`, did not meet its decision
#: (``reports/real/setpoint_response.md``)
STEP_RESPONSE_GATE = True
#: length of the linear step response :func:`step_response_oscillation` removes, in
#: oscillation periods: a well-damped loop's transient is over within one, two cover a
#: loop that rings longer; on the design windows of ``experiments/setpoint_response.py``
#: one and two periods left the same limit cycles (47 of 48), three began to absorb them
STEP_RESPONSE_PERIODS = 2.0
#: set-point changes per oscillation period from which :func:`step_response_oscillation`
#: applies: the periodic gate's scope (:data:`SERVO_CHANGES_PER_PERIOD`), set by
#: ``experiments/setpoint_response_scope.py`` (0 in ``setpoint_response.py``, the first try)
STEP_RESPONSE_MIN_CHANGES = SERVO_CHANGES_PER_PERIOD
#: share of the error's variance above which the response to the set point's steps is
#: what the detectors would judge (most of it: a half)
FORCED_SHARE = 0.5


def isolated_steps(rec: Recording, osc: AcfOscillation, n: int) -> bool:
    """True when the set point moves in isolated steps: at least one change, and at most
    one per oscillation period of ``osc`` on average over the ``n`` samples (a cascade
    slave's set point, the master's output, changes every sample and is not steps)."""
    k = setpoint_changes(rec).size
    return k >= 1 and k * osc.period_samples <= n


def setpoint_residual(x: np.ndarray, rec: Recording, length: int) -> np.ndarray:
    """What of ``x`` a linear response to the set point's steps does not explain: ``x``
    minus its least-squares fit by a constant and an FIR filter of ``length`` taps on the
    set point's increments (the step response of the closed loop from SP to the error,
    one ``length``-sample transient shared by every step, scaled by its size); beyond
    :data:`MAX_RESPONSE_TAPS` taps the response is a piecewise-linear curve through
    :data:`RESPONSE_KNOTS` knots (:func:`_step_design`).

    Examples
    --------
    >>> n = np.arange(1200)
    >>> sp = 50.0 + 10 * (n >= 300) - 10 * (n >= 800)
    >>> g = np.exp(-np.arange(200) / 30) * np.cos(np.arange(200) / 8)
    >>> e = np.convolve(np.r_[0, np.diff(sp)], g)[:1200]
    >>> rec = Recording.from_arrays(n * 1.0, sp - e, np.zeros(1200), SP=sp)
    >>> bool(np.abs(setpoint_residual(e, rec, 200)).max() < 1e-9)
    True

    The last answer is kept (:data:`_RESIDUAL`): the shape detectors judge one window's
    control error in turn, and each asks for the same fit.
    """
    x = np.asarray(x, dtype=float)
    held = _RESIDUAL[0]
    if held is not None and held[0] is rec and held[1] == length and \
            np.array_equal(held[2], x):
        return held[3].copy()
    d = np.r_[0.0, np.diff(np.asarray(rec.SP, dtype=float))]
    if length <= MAX_RESPONSE_TAPS:
        design = np.column_stack([np.ones(d.size), toeplitz(d, np.zeros(length))])
    else:
        design = np.column_stack([np.ones(d.size), _step_design(d, length)])
    coef = lstsq(design, x, lapack_driver="gelsy")[0]
    rest = x - design @ coef
    _RESIDUAL[0] = (rec, length, x.copy(), rest.copy())
    return rest


#: taps of the step response :func:`setpoint_residual` fits one by one; a longer
#: response (a window sampled fast: two oscillation periods of the README's tour
#: recording, 2000 s at 0.1 s, are 2905 samples) is fitted as a piecewise-linear curve
#: through :data:`RESPONSE_KNOTS` knots. The dense fit of every tap took 20-28 s and
#: 1.1 GB on that recording (n × n/3 design), the knots 0.26 s, with the same decision
#: (the residual's share of the error's variance 0.8978 exact, 0.8979 by knots). Every
#: window of the real and simulated studies (at most 3000 samples, so at most 1000 taps)
#: keeps the exact fit
MAX_RESPONSE_TAPS = 1024
#: knots of the piecewise-linear step response beyond :data:`MAX_RESPONSE_TAPS` taps
RESPONSE_KNOTS = 256


def _step_design(d: np.ndarray, length: int, knots: int = RESPONSE_KNOTS) -> np.ndarray:
    """The design of a ``length``-tap response to the increments ``d``, the response a
    piecewise-linear curve through ``knots`` evenly spaced taps: ``D·B`` with ``D`` the
    increments' Toeplitz matrix and ``B`` the hat functions, built step by step (``d`` is
    zero between the set point's changes), never as the ``n × length`` matrix.

    Examples
    --------
    >>> d = np.zeros(3000); d[[100, 1700]] = [2.0, -1.0]
    >>> B = _step_design(d, 1001, 11)  # knots every 100 taps
    >>> B.shape, float(B[100, 0]), float(B[200, 1]), float(B[1700, 0])
    ((3000, 11), 2.0, 2.0, -1.0)
    """
    pos = np.linspace(0.0, length - 1.0, knots)
    t = np.arange(length, dtype=float)
    hats = np.clip(1.0 - np.abs(t[:, None] - pos[None, :]) / (pos[1] - pos[0]), 0.0, None)
    out = np.zeros((d.size, knots))
    for s in np.flatnonzero(d):
        m = min(length, d.size - s)
        out[s:s + m] += d[s] * hats[:m]
    return out


#: the last :func:`setpoint_residual`, as ``(recording, length, x, residual)``: one
#: window's Horch, He, area-ratio and Hägglund tests each asked for this least-squares fit
#: (up to four of them per window, 0.15-0.9 s each at 1800 samples). The recording itself
#: is held, not its ``id`` (a freed recording's id can be reused; a Recording's arrays are
#: read-only), and the whole entry is replaced at once, so a reader never mixes two entries
_RESIDUAL: list[tuple[Recording, int, np.ndarray, np.ndarray] | None] = [None]


def step_response_oscillation(x: np.ndarray, rec: Recording, osc: AcfOscillation) -> bool:
    """True when the oscillation ``osc`` of ``x`` is the loop's response to the set
    point's steps: the set point moves in :func:`isolated_steps`, at least
    :data:`STEP_RESPONSE_MIN_CHANGES` times per oscillation period, and what a linear step
    response of :data:`STEP_RESPONSE_PERIODS` oscillation periods (at most a third of
    the record) does not explain (:func:`setpoint_residual`) no
    longer oscillates (:func:`oscillation`, the same test) or is less than half the
    error's variance (:data:`FORCED_SHARE`: the steps' response is most of what the
    shape tests would judge; the ACF test is blind to scale, and the tail of a slowly
    decaying transient stays regular however small).

    Under set-point steps a healthy loop's error rings after every step and the ACF test
    reads the train of transients as an oscillation, which the shape tests then judge
    (a step response is asymmetric: "triangular"). The published detectors presuppose
    a self-sustained oscillation in regulatory operation and data segments free of
    set-point changes (Jelali & Huang 2010, ch. 2 and 13); removing the linear response
    to the steps is that segment selection done by least squares. A limit cycle (stiction,
    a tight loop) is not a linear response to the steps and stays
    (``experiments/setpoint_response.py``).
    """
    if rec.SP is None or not isolated_steps(rec, osc, len(x)) or \
            setpoint_changes(rec).size * osc.period_samples < \
            STEP_RESPONSE_MIN_CHANGES * len(x):
        return False
    x = np.asarray(x, dtype=float)
    length = int(min(STEP_RESPONSE_PERIODS * osc.period_samples, len(x) / 3))
    rest = setpoint_residual(x, rec, length)
    return bool(np.var(rest) < (1.0 - FORCED_SHARE) * np.var(x)
                or not oscillation(rest).oscillating)


def harmonic_filter(x: np.ndarray, period: float, harmonics: float = 10.0) -> np.ndarray:
    """Zero-phase band-pass from half the oscillation frequency to ``harmonics`` times
    it: drift and noise go, the harmonics that make a wave triangular or square stay.

    Parameters
    ----------
    x : ndarray
        Signal.
    period : float
        Oscillation period in samples.
    harmonics : float
        Upper band edge as a multiple of the oscillation frequency (capped at 0.5).
    """
    f0 = 1.0 / float(period)
    return bandpass(sps.detrend(x), (0.5 * f0, min(0.5, harmonics * f0)))


def setpoint_changes(rec: Recording) -> np.ndarray:
    """Indices ``i`` where the recorded set point differs from sample ``i − 1`` (empty
    when SP is not recorded)."""
    if rec.SP is None:
        return np.empty(0, dtype=int)
    sp = np.asarray(rec.SP, dtype=float)
    return np.flatnonzero(np.abs(np.diff(sp)) > 1e-9 * (1.0 + np.abs(sp[1:]))) + 1


def half_cycles(x: np.ndarray, period: float, min_fraction: float = 0.25,
                exclude: np.ndarray | None = None) -> list[tuple[float, int, int, float]]:
    """Half cycles of an oscillating, zero-mean signal between successive sign changes.

    Sign changes closer than ``min_fraction`` of a half period to the previous kept one
    are noise and are skipped; the stretch before the first and after the last crossing
    is incomplete and dropped, and so is every half cycle holding an index of
    ``exclude`` (set-point changes: a forced response, not the loop's own oscillation).

    Returns
    -------
    list of (z0, a, b, z1)
        Interpolated crossing times ``z0 < a`` and ``z1 >= b − 1`` (fractional samples)
        around the samples ``x[a:b]`` of the half cycle, which have one sign (up to
        skipped noise).

    Examples
    --------
    >>> x = np.sin(2 * np.pi * np.arange(200) / 50 + 0.1)
    >>> [(round(z0, 2), a, b) for z0, a, b, z1 in half_cycles(x, 50.0)]
    [(24.2, 25, 50), (49.2, 50, 75), (74.2, 75, 100), (99.2, 100, 125), (124.2, 125, 150), \
(149.2, 150, 175)]
    """
    x = np.asarray(x, dtype=float)
    pos = x > 0
    cross = np.flatnonzero(pos[1:] != pos[:-1]) + 1
    gap = min_fraction * 0.5 * float(period)
    kept: list[int] = []
    for c in cross:
        if not kept or c - kept[-1] >= gap:
            kept.append(int(c))
    # crossing between samples c − 1 and c, linearly interpolated
    z = [c - 1 + x[c - 1] / (x[c - 1] - x[c]) for c in kept]
    skip = np.asarray([] if exclude is None else exclude, dtype=int)
    out = []
    for i in range(len(kept) - 1):
        a, b = kept[i], kept[i + 1]
        if skip.size and np.any((skip >= a) & (skip < b)):
            continue
        out.append((float(z[i]), a, b, float(z[i + 1])))
    return out


class StictionDetector(Estimator):
    """Base class of the published stiction detectors.

    Subclasses implement ``_estimate`` and build their result with :meth:`_result`.
    ``optional_y`` detectors (those needing MV) return an inconclusive verdict instead
    of an error when their second signal is not recorded.
    """

    optional_y: ClassVar[bool] = False

    def estimate(self, rec: Recording, x: str | None = None, y: str | None = None
                 ) -> EstimateResult:
        """As :meth:`Estimator.estimate`; a missing optional ``y`` signal is passed as
        None (the detector decides what that means)."""
        yname = y or self.default_y
        if self.optional_y and yname and getattr(rec, yname, None) is None:
            self.check_params()
            xs = np.asarray(rec.signal(x or self.default_x), float)
            return self._estimate(xs, None, rec)
        return super().estimate(rec, x, y)

    def _result(self, value: float, decision: bool | None, reason: str, *,
                units: str = "-", **diagnostics: Any) -> EstimateResult:
        """The EstimateResult with ``verdict`` and ``reason`` first in diagnostics."""
        diag = {"verdict": verdict(decision), "reason": reason, **diagnostics}
        return EstimateResult(method=self.name, value=float(value), units=units,
                              decision=decision, meaning=MEANING, diagnostics=diag)

    def valve_signal(self, y: np.ndarray | None, rec: Recording
                     ) -> tuple[np.ndarray | None, str | None]:
        """The valve position and where it comes from: MV as recorded (``"MV"``), PV
        standing in for an unrecorded MV in a flow loop (the detector's ``flow_loop``;
        ``"PV"``: the flow follows the valve without dynamics), else ``(None, None)``."""
        if y is not None:
            return y, "MV"
        if getattr(self, "flow_loop", False):
            return np.asarray(rec.PV, dtype=float), "PV"
        return None, None

    @staticmethod
    def op_percent(op: np.ndarray, rec: Recording | None = None) -> float:
        """One per cent of OP's span in OP's units: 0.01 for an OP recognised as a
        fraction of the valve's travel (:func:`~stictionbench.op_range.infer_op_range`),
        else 1 (per cent, or units that cannot be recognised: mean-removed, milliamps);
        the range the user gave (``rec.meta["op_range"]``) first.
        The tolerances "OP moved by 1 %" are physical (a good valve's resolution) and
        must not turn an OP in 0–1 into an "OP constant" verdict."""
        span = infer_op_range(op) if rec is None else op_range_of(rec, op)
        return 1.0 if span is None else (span[1] - span[0]) / 100.0

    @staticmethod
    def op_constant(op: np.ndarray, rec: Recording | None = None) -> str:
        """The reason "OP constant"; where OP's units are not recognised (milliamps,
        engineering units, mean-removed) it says that 1 % was read as one of OP's own
        units (:meth:`op_percent`), which the user can correct by giving OP in per cent."""
        if (infer_op_range(op) if rec is None else op_range_of(rec, op)) is None:
            return ("OP constant (OP's units not recognised as per cent or a fraction: "
                    "1 unit read as 1 %)")
        return "OP constant"

    def _error_half_cycles(self, x: np.ndarray, y: np.ndarray | None, rec: Recording,
                           measure: Callable[..., np.ndarray]
                           ) -> tuple[AcfOscillation, np.ndarray, str | None]:
        """The control error's oscillation and ``measure(e, period, exclude=...)`` of its
        half cycles: the error (:func:`loop_signals`, the detector's ``use_error``)
        filtered around the oscillation (:func:`harmonic_filter`), the half cycles
        holding a set-point change left out. When the premise fails
        (:func:`self_oscillation`) the values are empty and the reason is returned."""
        _, e = loop_signals(self.name, x, y, rec, getattr(self, "use_error", True))
        osc, why = self_oscillation(e, rec)
        if why:
            return osc, np.empty(0), why
        values = measure(harmonic_filter(e, osc.period_samples), osc.period_samples,
                         exclude=setpoint_changes(rec))
        return osc, values, None

    def _no_oscillation(self, osc: AcfOscillation, reason: str = "no oscillation",
                        **diagnostics: Any) -> EstimateResult:
        """The inconclusive result of a loop without a self-sustained oscillation."""
        return self._result(float("nan"), None, reason,
                            regularity=osc.regularity, period_samples=osc.period_samples,
                            **diagnostics)
