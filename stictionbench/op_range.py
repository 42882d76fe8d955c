"""The controller output's range: the span the valve characteristic, the closed-loop
replay and the stiction detectors' "OP moved by 1 %" tolerances need.

OP is a percentage of the valve's travel on most plants, a fraction (0–1) on some, in
milliamps or engineering units on others, and mean-removed in some published data sets
(ISDB CHEM10–13). In the diagnosis only the equal-percentage characteristic ``R^(x − 1)`` and the
replay's output limits depend on where OP's 0 and 100 % are; every other hypothesis is
invariant to OP's units. The range comes from the user (``op_range: [lo, hi]`` in the
model YAML) or is recognised from the data when that is unambiguous; otherwise it is
unknown and the valve characteristic is not tested (the diagnosis says so).
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: OP in per cent of the valve's travel; in a fraction of it
PERCENT = (0.0, 100.0)
FRACTION = (0.0, 1.0)
#: an output may over- or under-shoot its range by this share of the span (many control
#: systems allow −5 … 105 %; Honeywell's controllers −6.9 … 106.9 % by default)
OVERSHOOT = 0.069
#: the median of a recognised OP lies above this share of the span (a mean-removed OP
#: has its median near 0)
MIN_MEDIAN = 0.01


def _within(op: np.ndarray, span: tuple[float, float]) -> bool:
    lo, hi = span
    margin = OVERSHOOT * (hi - lo)
    return bool(op.min() >= lo - margin and op.max() <= hi + margin)


def infer_op_range(op: np.ndarray) -> tuple[float, float] | None:
    """Recognise OP's units from its values.

    Per cent when every sample lies in −6.9 … 106.9 and some exceed 1.069 (so it is not a
    fraction); a fraction when every sample lies in −0.069 … 1.069. In both cases the
    median must exceed 1 % of the span (a mean-removed OP has its median near 0), unless
    OP never falls below the range's bottom and rises above that 1 % (a valve shut for
    most of the record, which a signal centred on 0 cannot be).
    Anything else (engineering units, mean-removed or normalised data) is unknown. An
    OP in 4–20 mA lies in 0–100 and is read as per cent (a valve 4–20 % open writes the
    same numbers): give the range (``--op-range``, or ``op_range`` in the model YAML).

    Parameters
    ----------
    op : ndarray
        The recorded controller output.

    Returns
    -------
    tuple of float or None
        ``(0, 100)``, ``(0, 1)`` or ``None``.

    Examples
    --------
    >>> import numpy as np
    >>> infer_op_range(np.array([20.0, 35.0, 60.0])), infer_op_range(np.array([0.2, 0.6]))
    ((0.0, 100.0), (0.0, 1.0))
    >>> infer_op_range(np.array([-1.2, 0.1, 1.3])) is None  # mean-removed
    True
    >>> infer_op_range(np.r_[np.zeros(80), np.linspace(0, 50, 20)])  # shut for most of it
    (0.0, 100.0)
    """
    op = np.asarray(op, float)
    med = float(np.median(op))
    for span in (PERCENT, FRACTION):
        floor = span[0] + MIN_MEDIAN * (span[1] - span[0])
        # off zero: the median above 1 % of the span, or an output clamped at the bottom
        # of its range for most of the record (never below it, and moving above it): a
        # mean-removed signal is centred on 0 and has samples on both sides of it
        off_zero = med > floor or (op.min() >= span[0] and op.max() > floor)
        if _within(op, span) and off_zero and (
                span is FRACTION or op.max() > FRACTION[1] + OVERSHOOT):
            return span
    return None


def check_op_range(op: np.ndarray, span: tuple[float, float], what: str) -> None:
    """Refuse a given OP range that the recorded OP does not fit: a units mistake
    (``--op-range 0 1`` on an OP in per cent) would otherwise fit the valve
    characteristic on OP values far outside 0–100 %.

    OP may over- or under-shoot the range by :data:`OVERSHOOT` of its span, as in
    :func:`infer_op_range`.

    Raises
    ------
    InputError
        When OP leaves ``span`` by more than that; the message names ``what`` (the
        option or file that gave the range) and OP's recorded span.

    Examples
    --------
    >>> check_op_range(np.array([10.0, 60.0]), (0.0, 100.0), "--op-range")
    >>> try:
    ...     check_op_range(np.array([10.0, 60.0]), (0.0, 1.0), "--op-range")
    ... except Exception as exc:
    ...     print(str(exc)[:46])
    --op-range: OP runs from 10 to 60, outside the
    """
    from .errors import InputError

    op = np.asarray(op, dtype=float)
    if not _within(op, span):
        lo, hi = span
        out = max(lo - op.min(), op.max() - hi) / (hi - lo)
        raise InputError(f"{what}: OP runs from {op.min():.4g} to {op.max():.4g}, outside "
                         f"the range {lo:g} to {hi:g} given by {100 * out:.3g} % of it "
                         f"(over- and undershoot of up to {OVERSHOOT * 100:g} % are "
                         "allowed); give OP's 0 and 100 % in OP's own units")


def given_range(lo: float, hi: float, what: str) -> tuple[float, float]:
    """``(lo, hi)`` as OP's 0 and 100 % given by the user, refused unless finite with
    ``hi > lo`` (the message names ``what``, the option that gave them).

    Examples
    --------
    >>> given_range(4, 20, "--op-range")
    (4.0, 20.0)
    """
    from .errors import InputError

    lo, hi = float(lo), float(hi)
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise InputError(f"{what}: expected two finite numbers LO HI with HI > LO, got "
                         f"{lo:g} {hi:g}")
    return lo, hi


def op_range_of(rec: Any, op: np.ndarray | None = None) -> tuple[float, float] | None:
    """OP's range for a recording: the one the user gave (``rec.meta["op_range"]``: the
    ``--op-range`` of ``batch`` and ``estimate``), else :func:`infer_op_range` of ``op``
    (the recording's OP when None).

    Examples
    --------
    >>> import dataclasses
    >>> from stictionbench.recording import Recording
    >>> t = np.arange(200.0)
    >>> rec = Recording.from_arrays(t, np.sin(t), 12 + np.sin(t / 9))
    >>> ma = dataclasses.replace(rec, meta={"op_range": (4, 20)})  # OP in milliamps
    >>> op_range_of(rec), op_range_of(ma)
    ((0.0, 100.0), (4.0, 20.0))
    """
    given = rec.meta.get("op_range")
    if given is not None:
        lo, hi = given
        return float(lo), float(hi)
    return infer_op_range(rec.OP if op is None else op)
