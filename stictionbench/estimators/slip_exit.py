"""Do the valve's stuck stretches end in slips? The premise check of PV standing in for MV.

Kano et al. (2004) and Yamashita (2006) read stiction from the valve position MV: it stays
put while the controller output OP moves. In a flow loop without a recorded MV the flow
PV stands in for it, and there a second cause gives the same picture: a PI that holds the
flow at its set point against a load moves OP while PV stays within its noise band. The
controller's law cannot tell the two apart (over any stretch, OP's integral move is
``Kc/Ti·∫e`` whatever kept PV where it was). What can is the end of the stretch: a
sticky valve ends it with a **slip**, a jump of PV beyond its noise band by the second
sample after the stretch, the way OP pushed (OP's net move over the stretch, times the
loop's direction); a regulated PV leaves its band by drifting, not by a jump.

A stretch ``[start, stop)`` of steady valve ends in a slip when

``d · sign(OP[stop−1] − OP[start]) · (valve[stop+lag−1] − median(valve[start:stop]))``

exceeds ``SIZE`` times the band, with ``lag = 2`` samples (a transmitter lag of a second
or two spreads a jump over two samples at a 1 s historian) and ``d`` the loop's
direction: ``+1`` when OP up moves PV up (the sign of the PI's integral action,
:func:`controller_direction`), always ``+1`` for a recorded MV. The band is the
detector's own steady band and ``SIZE`` is 1, so no threshold is added.

This check is our addition, not the papers' (``experiments/slip_exit.py`` and
``reports/real/slip_exit.md`` measure it); the detectors apply it only when asked
(``slip_exit=True``) and only where PV stands in for MV.

References
----------
M. Kano, H. Maruta, H. Kugemoto, K. Shimizu, "Practical model and detection algorithm for
valve stiction", Proc. IFAC DYCOPS 7 (2004) (the stick-slip valve: stuck, then a jump).
Y. Yamashita, "An automatic method for detection of valve stiction in process control
loops", Control Engineering Practice 14 (2006) 503–510.
K. J. Åström, T. Hägglund, *Advanced PID Control*, ISA (2006) (the velocity form of the
PI law used by :func:`controller_direction`).
"""

from __future__ import annotations

import numpy as np

#: samples after a stretch's last steady sample within which a slip must show
LAG = 2
#: the slip's least size in steady bands (1: the detector's own band, no new threshold;
#: ``experiments/slip_exit.py`` varies it)
SIZE = 1.0


#: a detector's reason when the loop's direction cannot be read from the record
NO_DIRECTION = "loop direction not identified"
#: its reason when the check alone turned a stiction verdict away
REGULATED = ("flow steady while OP moves, but too little of that ends in a slip: a flow "
             "regulated against its load, or slips within the noise")


def slip_note(steady: float, kept: float, threshold: float, direction: int
              ) -> tuple[dict[str, float], str | None]:
    """What a detector that applied the check adds to its diagnostics (the loop's
    ``direction``, its index before the check ``rho_unchecked``, and the check's
    ``slip_size`` and ``slip_lag``: :data:`SIZE`, :data:`LAG`), and its reason
    when the check alone turned the verdict: the index ``steady`` above ``threshold``
    and the index ``kept`` over the slip-ended stretches not.

    Examples
    --------
    >>> slip_note(0.6, 0.1, 0.25, 1)[1] == REGULATED
    True
    >>> slip_note(0.6, 0.4, 0.25, -1)
    ({'direction': -1, 'rho_unchecked': 0.6, 'slip_size': 1.0, 'slip_lag': 2}, None)
    """
    return ({"direction": direction, "rho_unchecked": steady, "slip_size": SIZE,
             "slip_lag": LAG}, REGULATED if steady > threshold >= kept else None)


def controller_direction(op: np.ndarray, pv: np.ndarray, sp: np.ndarray | None = None
                         ) -> int:
    """The loop's direction: ``+1`` when the PI raises OP while PV is below its set point
    (so OP up moves PV up in a stable loop), ``-1`` for the reverse, ``0`` when the
    record cannot tell.

    The sign of the integral term in the PI's velocity form
    ``ΔOP_k = a·ΔPV_k + b·ΔPV_{k−1} + c·(e_{k−1} − ē) + c₀`` fitted by least squares,
    with ``e = SP − PV`` (``−PV`` without a set point) and ``ΔX_k = X_k − X_{k−1}``; the
    direction is the sign of ``c``. The integral term is used rather than
    the proportional kick: in a fast loop the process answers OP within the same sample,
    which biases the kick's coefficient and not the integral's.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> pv = np.cumsum(rng.normal(size=500)) * 0.1
    >>> op = 0.5 * (0 - pv) + 0.05 * np.cumsum(0 - pv)
    >>> controller_direction(op, pv), controller_direction(-op, pv)
    (1, -1)
    """
    op = np.asarray(op, dtype=float)
    pv = np.asarray(pv, dtype=float)
    if op.size < 8:
        return 0
    e = (np.asarray(sp, dtype=float) - pv) if sp is not None else -pv
    dop, dpv = np.diff(op), np.diff(pv)
    X = np.column_stack([dpv[1:], dpv[:-1], e[1:-1] - e.mean(), np.ones(dpv.size - 1)])
    if not np.all(np.isfinite(X)) or np.linalg.matrix_rank(X) < X.shape[1]:
        return 0
    coef, *_ = np.linalg.lstsq(X, dop[1:], rcond=None)
    return int(np.sign(coef[2]))


def slip_ended(op: np.ndarray, valve: np.ndarray, stretches: np.ndarray, band: float,
               direction: int, lag: int = LAG) -> np.ndarray:
    """Which stretches of steady valve end in a slip the way OP pushed.

    Parameters
    ----------
    op, valve : ndarray
        Controller output and valve position (or PV standing in for it), one length.
    stretches : ndarray, shape (k, 2)
        ``(start, stop)`` of each stretch, ``stop`` exclusive (the first sample after).
    band : float
        The steady band: a slip moves the valve further than ``SIZE`` times this.
    direction : int
        ``+1`` when OP up moves the valve signal up, ``-1`` for the reverse
        (:func:`controller_direction`).
    lag : int
        The valve is read at sample ``stop + lag − 1`` alone (``lag = 1``: the first
        sample after the stretch, ``stop``; ``lag = 2``: the second, so that a jump
        spread over two samples by a transmitter lag counts and a spike at ``stop`` that
        falls back does not).

    Returns
    -------
    ndarray of bool, shape (k,)
        ``False`` for a stretch that runs to the record's end (its end is not seen).

    Examples
    --------
    >>> op = np.r_[np.linspace(0, 5, 20), np.full(10, 5.0)]
    >>> slip = np.r_[np.zeros(20), np.full(10, 5.0)]       # stuck, then a jump up
    >>> drift = np.r_[np.zeros(20), -np.linspace(1, 5, 10)]  # leaves the band the other way
    >>> s = np.array([[0, 20]])
    >>> slip_ended(op, slip, s, 0.5, 1).tolist(), slip_ended(op, drift, s, 0.5, 1).tolist()
    ([True], [False])
    """
    op = np.asarray(op, dtype=float)
    valve = np.asarray(valve, dtype=float)
    out = np.zeros(len(stretches), dtype=bool)
    n = valve.size
    for i, (a, b) in enumerate(np.asarray(stretches, dtype=np.int64).reshape(-1, 2)):
        if b >= n or b - a < 1:
            continue
        after = valve[min(b + lag - 1, n - 1)]
        jump = after - float(np.median(valve[a:b]))
        push = np.sign(op[b - 1] - op[a]) * direction
        out[i] = push * jump > SIZE * band
    return out
