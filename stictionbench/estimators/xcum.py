"""Third-order cross-cumulant delay estimator ``xcum`` (HOSA ``tde``, paper eqs. 9–11).

The delay of the valve position (MV, ``y``) behind the controller output (OP, ``x``)
from third-order cross-cumulants, via :func:`stictionbench.hosa.tde`. Gaussian noise
(even when correlated between the two signals) does not bias it, unlike the
cross-correlation. A delay above ``threshold`` samples (MV lags OP) is read as stiction.
"""

from __future__ import annotations

from numbers import Integral, Real
from typing import Any, ClassVar

import numpy as np

from .. import hosa
from ..errors import InputError
from ..recording import Recording
from ..validation import Constraint, Interval, TypeOf, check_pair
from .base import EstimateResult, Estimator
from .xcorr import MEANING, top_peaks


class XCum(Estimator):
    """Delay by third-order cross-cumulants (HOSA ``tde``; the paper's "tder3").

    Parameters
    ----------
    max_delay : int
        Delays ``-max_delay .. max_delay`` are searched. An estimate at ``±max_delay``
        sits on the edge of the window and is not a measured delay: it is flagged
        (``at_edge``) and re-estimated with ``2·max_delay`` to show how it moves.
    nsamp : int, optional
        Samples per record (default: the whole signal).
    rank : int, optional
        Low-rank SVD truncation of the normal-equation matrix (default: full rank).
    threshold : float
        Delay in samples above which stiction is indicated.
    stability_check : bool
        Re-estimate with a window twice as wide and with a truncated-SVD solve, and
        report the condition number of the normal equations (:func:`stability`).
    svd_rcond : float
        Singular values below ``svd_rcond × σ_max`` are dropped in the truncated solve.

    Notes
    -----
    ``value`` is HOSA ``tde``'s integer delay in samples, unchanged (positive: ``y`` = MV
    lags ``x`` = OP). ``decision`` is ``value > threshold`` when the estimate is a
    measured delay and ``None`` when it is not: ``at_edge`` (on the edge of the search
    window or one sample inside it) or ``unstable`` (the lag moves when the window is
    doubled or when the near-singular directions of the normal equations are dropped).
    Diagnostics hold the delay in seconds, the coefficient curve ``a(k)`` and its lags,
    the condition number, both re-estimates and the three largest peaks of ``|a(k)|``.
    """

    name = "xcum"
    default_x = "OP"
    default_y = "MV"

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "max_delay": [Interval(Integral, 1, None)],
        "nsamp": [Interval(Integral, 2, None), None],
        "rank": [Interval(Integral, 1, None), None],
        "threshold": [Interval(Real, 0, None)],
        "stability_check": [TypeOf(bool)],
        "svd_rcond": [Interval(Real, 0, 1, closed="neither")],
    }

    def __init__(
        self,
        max_delay: int = 30,
        nsamp: int | None = None,
        rank: int | None = None,
        threshold: float = 0.5,
        stability_check: bool = True,
        svd_rcond: float = 1e-8,
    ) -> None:
        self.max_delay = max_delay
        self.nsamp = nsamp
        self.rank = rank
        self.threshold = threshold
        self.stability_check = stability_check
        self.svd_rcond = svd_rcond

    def _estimate(
        self, x: np.ndarray, y: np.ndarray | None, rec: Recording
    ) -> EstimateResult:
        x, y = check_pair(self.name, x, y)
        res = hosa.tde(x, y, self.max_delay, self.nsamp, self.rank)
        delay = int(res.delay)
        max_delay = int(self.max_delay)
        threshold = float(self.threshold)
        nsamp = x.size if hosa._is_default(self.nsamp) else int(self.nsamp)
        rank = None if hosa._is_default(self.rank) else int(self.rank)
        diag: dict[str, Any] = {
            "delay_s": delay * rec.Ts,
            "at_edge": bool(abs(delay) >= max_delay - 1),
            "peak_value": float(res.avec[delay + max_delay]),
            "peaks": top_peaks(res.lags, res.avec),
            "threshold": threshold,
            "max_delay": max_delay,
            "nsamp": nsamp,
            "rank": rank,
            "lags": res.lags,
            "curve": res.avec,
        }
        if self.stability_check:
            diag.update(stability(x, y, delay, max_delay, nsamp, float(self.svd_rcond)))
        else:
            diag.update(unstable=None, stable_reason="not checked")
        # Kept from the first release: the re-estimate with the doubled window, reported
        # only for an estimate on the window's edge (None otherwise).
        edge_md = 2 * max_delay if diag["at_edge"] else None
        edge_delay = diag.get("wide_delay") if diag["at_edge"] else None
        if diag["at_edge"] and not self.stability_check and nsamp >= 4 * max_delay + 1:
            edge_delay = int(hosa.tde(x, y, 2 * max_delay, nsamp).delay)
        diag.update(edge_check_max_delay=edge_md, edge_check_delay=edge_delay)
        decision: bool | None = bool(delay > threshold)
        if diag["at_edge"] or diag["unstable"]:
            decision = None  # not a measured delay: the value is kept, the call is not made
        return EstimateResult(
            method=self.name,
            value=float(delay),
            units="samples",
            decision=decision,
            meaning=MEANING,
            diagnostics=diag,
        )


def stability(x: np.ndarray, y: np.ndarray, delay: int, max_delay: int, nsamp: int,
              rcond: float = 1e-8) -> dict[str, Any]:
    """Does the ``tde`` lag survive a wider window and a better-conditioned solve?

    A nearly symmetric ``x`` (a triangular controller output in a limit cycle has
    skewness near zero) has almost no third-order cumulants: the normal equations of
    ``tde`` are then near-singular (condition numbers of 1e10 and more) and the arg-max
    of ``|a(k)|`` is set by round-off, often on the window's edge. The estimate is
    called stable when the same lag comes back (i) with the window doubled and (ii)
    from a truncated-SVD solve that keeps singular values above ``rcond × σ_max``
    (Hansen, *Rank-Deficient and Discrete Ill-Posed Problems*, SIAM 1998, ch. 3).

    Returns
    -------
    dict
        ``condition_number``, ``wide_max_delay``, ``wide_delay`` (None when the record
        is too short), ``tsvd_rank``, ``tsvd_delay``, ``unstable`` and ``stable_reason``.
    """
    a_mat, rhs = hosa.tde_system(x, y, max_delay, nsamp)
    u, sv, vt = np.linalg.svd(a_mat)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    k = max(1, int(np.sum(sv > rcond * sv[0])))
    b = vt[:k].T @ ((u[:, :k].T @ rhs) / sv[:k])
    tsvd_delay = int(np.argmax(np.abs(b[::-1]))) - max_delay
    wide_md = 2 * max_delay
    wide_delay: int | None = None
    if nsamp >= 2 * wide_md + 1:
        try:
            wide_delay = int(hosa.tde(x, y, wide_md, nsamp).delay)
        except InputError:
            wide_delay = None
    reasons = []
    if wide_delay is not None and wide_delay != delay:
        reasons.append(f"moves to {wide_delay} with max_delay {wide_md}")
    if tsvd_delay != delay:
        reasons.append(f"moves to {tsvd_delay} with a rank-{k} solve")
    return {
        "condition_number": cond,
        "wide_max_delay": wide_md if wide_delay is not None else None,
        "wide_delay": wide_delay,
        "tsvd_rank": k,
        "tsvd_delay": tsvd_delay,
        "unstable": bool(reasons),
        "stable_reason": "; ".join(reasons) if reasons else "same lag in both checks",
    }
