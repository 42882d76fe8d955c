"""Third-order cross-cumulant delay estimator ``xcum`` (HOSA ``tde``, paper eqs. 9–11).

The delay of the valve position (MV, ``y``) behind the controller output (OP, ``x``)
from third-order cross-cumulants, via :func:`stictionbench.hosa.tde`. Gaussian noise
(even when correlated between the two signals) does not bias it, unlike the
cross-correlation. A delay above ``threshold`` samples (MV lags OP) is read as stiction.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import hosa
from ..errors import InputError
from ..recording import Recording
from .base import EstimateResult, Estimator, check_pair
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

    Notes
    -----
    ``value`` is the integer delay in samples (positive: ``y`` = MV lags ``x`` = OP);
    ``decision`` is ``value > threshold``. Diagnostics hold the delay in seconds, the
    coefficient curve ``a(k)`` and its lags, ``at_edge``, the edge check and the three
    largest peaks of ``|a(k)|``.
    """

    name = "xcum"
    default_x = "OP"
    default_y = "MV"

    def __init__(
        self,
        max_delay: int = 30,
        nsamp: int | None = None,
        rank: int | None = None,
        threshold: float = 0.5,
    ) -> None:
        self.max_delay = max_delay
        self.nsamp = nsamp
        self.rank = rank
        self.threshold = threshold

    def _estimate(
        self, x: np.ndarray, y: np.ndarray | None, rec: Recording
    ) -> EstimateResult:
        x, y = check_pair(self.name, x, y)
        res = hosa.tde(x, y, self.max_delay, self.nsamp, self.rank)
        delay = int(res.delay)
        max_delay = int(self.max_delay)
        threshold = float(self.threshold)
        edge_md: int | None = None
        edge_delay: int | None = None
        nsamp = x.size if hosa._is_default(self.nsamp) else int(self.nsamp)
        rank = None if hosa._is_default(self.rank) else int(self.rank)
        if res.at_edge:
            md2 = 2 * max_delay
            if nsamp >= 2 * md2 + 1:
                try:
                    edge_delay = int(hosa.tde(x, y, md2, self.nsamp, self.rank).delay)
                    edge_md = md2
                except InputError:
                    edge_delay = None
        diag: dict[str, Any] = {
            "delay_s": delay * rec.Ts,
            "at_edge": bool(res.at_edge),
            "edge_check_max_delay": edge_md,
            "edge_check_delay": edge_delay,
            "peak_value": float(res.avec[delay + max_delay]),
            "peaks": top_peaks(res.lags, res.avec),
            "threshold": threshold,
            "max_delay": max_delay,
            "nsamp": nsamp,
            "rank": rank,
            "lags": res.lags,
            "curve": res.avec,
        }
        return EstimateResult(
            method=self.name,
            value=float(delay),
            units="samples",
            decision=bool(delay > threshold),
            meaning=MEANING,
            diagnostics=diag,
        )
