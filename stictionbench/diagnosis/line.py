"""Whether a named OP-driven physics explains only one line of the residual: the closed
loop's echo of an external oscillation.

A dead time, a sensor lag, a valve nonlinearity, a characteristic or a travel limit acts
on the replay of the recorded OP, so it changes the prediction wherever OP has power (a
valve nonlinearity at its cycle's harmonics as well). In closed loop, OP also carries the
controller's answer to an external oscillation on PV, at that oscillation's frequency and
with its wandering phase; an OP-driven hypothesis can then reproduce the oscillation by
shifting or reshaping that echo (a dead time of a quarter period does), and reproduce it
better than a sinusoid of fixed phase, which a real disturbance's wandering period
defeats. Such a fit improves the residual at the oscillation's line alone.

:func:`line_confinement` measures where a hypothesis's improvement lies: the
reduction of the residual's periodogram inside ``±LINE_BAND`` of the nominal residual's
dominant line, over the whole reduction (the record after the burn-in). Where the pick
is a dead time or a sensor lag (:data:`LINE_REPLACES`), a share above :data:`LINE_SHARE`
(the fit gains at the line and loses everywhere else) names the line, an oscillatory
disturbance, in its place.

References
----------
Ljung, *System Identification* (1999), ch. 13.4 (closed-loop data: the input is
correlated with the output disturbance) and 16.6 (residual analysis in frequency);
Thornhill, Huang & Zhang, *J. Process Control* 13 (2003) 477 (plant-wide oscillations
of wandering period, detected from the residual's spectrum).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.signal import periodogram

from .strict_json import finite_or_none

#: the hypotheses whose prediction is the replay of the recorded OP through the physics
#: (their shares are reported)
OP_DRIVEN = ("dead_time", "sensor_lag", "deadband", "stiction", "valve_characteristic",
             "saturation")

#: the picks the line may replace: the linear lags on PV, whose change to the prediction
#: spreads over every frequency OP moves at. A valve nonlinearity in a limit cycle changes
#: the prediction at the cycle's line and harmonics, and a fit that misses elsewhere (a
#: re-identified process, a valve replayed on a sampled OP) says nothing about the
#: cycle's source; whether a valve explains a cycle from inside the loop is the
#: closed-loop cycle check's question (:mod:`.cycle`). Renaming valves, characteristics
#: and limits too cost sticky valves in regulatory limit cycles (fast_loops, a model
#: given, loops of 8 samples or slower: 18 → 12 of 36 named sticky)
LINE_REPLACES = ("dead_time", "sensor_lag")

#: half-width of the line's band, relative to its frequency: an external oscillation's
#: period wanders by a few per cent over a record
LINE_BAND = 0.15

#: the share of a hypothesis's improvement at the residual's line from which the line, not
#: the hypothesis, is named: above 1 the fit makes the residual worse everywhere but at the
#: line. A physics that is there improves the prediction wherever it changes it (where
#: the data carry the change, removing it helps); one that only reproduces OP's echo of a
#: line changes the prediction elsewhere too, and there it only adds error. No threshold
#: is fitted: at 1, on the holdout family's fresh block 41000 (216 recordings), one
#: correct verdict of 128 OP-driven ones is lost (a level-2 sensor lag), where 0.8 lost
#: 18 (``experiments/line_confinement.py``)
LINE_SHARE = 1.0

#: zero-padding of the periodograms (a line's frequency resolved within its ``1/T`` bin)
PAD = 8


def residual_line(e: np.ndarray, Ts: float) -> float:
    """Frequency (Hz) of the largest peak of the Hann-windowed, zero-padded periodogram of
    ``e`` (:func:`scipy.signal.periodogram`); ``nan`` when ``e`` is too short or flat."""
    e = np.asarray(e, dtype=float)
    if e.size < 8 or not np.any(e != e[0]):
        return float("nan")
    f, P = periodogram(e, fs=1.0 / Ts, window="hann", nfft=PAD * e.size, detrend="constant")
    P[0] = 0.0
    return float(f[int(np.argmax(P))])


def line_share(e0: np.ndarray, e1: np.ndarray, Ts: float, f_line: float,
               band: float = LINE_BAND) -> float:
    """The share of the reduction of the residual's power from ``e0`` (nominal) to ``e1``
    (a hypothesis) that lies within ``±band·f_line`` of ``f_line`` (at least the Hann
    window's main lobe, ``±2/(N·Ts)``): periodograms (Hann, zero-padded) of the whole
    series. ``nan`` where the hypothesis reduces nothing overall; above 1 where it makes
    the rest worse. A description of where the fit's gain lies, not a test: the fit's
    significance is the likelihood-ratio test's.

    Examples
    --------
    >>> t = np.arange(2000.0)
    >>> rng = np.random.default_rng(0)
    >>> noise = rng.standard_normal(t.size)
    >>> e0 = noise + np.sin(2 * np.pi * t / 50)
    >>> round(line_share(e0, noise, 1.0, 0.02), 2)  # the line removed alone
    1.0
    >>> broadband = 0.5 * rng.standard_normal(t.size)
    >>> line_share(e0 + broadband, e0, 1.0, 0.02) < 0.2  # a broadband improvement
    True
    """
    e0, e1 = np.asarray(e0, dtype=float), np.asarray(e1, dtype=float)
    if not (np.isfinite(f_line) and f_line > 0) or e0.size < 8:
        return float("nan")
    kw = {"fs": 1.0 / Ts, "window": "hann", "nfft": PAD * e0.size, "detrend": "constant"}
    f, A = periodogram(e0, **kw)
    _, B = periodogram(e1, **kw)
    d = A - B
    total = float(d.sum())
    half = max(band * f_line, 2.0 / (e0.size * Ts))
    inside = float(d[np.abs(f - f_line) <= half].sum())
    return inside / total if total > 0 else float("nan")


def line_confinement(e0: np.ndarray, errors: dict[str, np.ndarray], Ts: float, pick: str,
                     threshold: float = LINE_SHARE) -> dict[str, Any]:
    """The line test: ``e0`` the nominal's band-passed output error after the burn-in,
    ``errors`` the same of each fitted hypothesis. For every OP-driven hypothesis
    (:data:`OP_DRIVEN`) the share of its improvement at the nominal residual's dominant
    line (:func:`residual_line`, :func:`line_share`); ``named`` when ``pick`` is a linear
    lag on PV (:data:`LINE_REPLACES`) and its share is above ``threshold``."""
    f = residual_line(e0, Ts)
    # a share is None where it is undefined (the hypothesis gains nothing overall)
    shares = {h: finite_or_none(line_share(e0, e, Ts, f)) for h, e in errors.items()
              if h in OP_DRIVEN}
    return {"hypothesis": pick if pick in OP_DRIVEN else None,
            "line_period_s": 1.0 / f if f > 0 else None, "band": LINE_BAND,
            "share": shares.get(pick), "threshold": threshold, "shares": shares,
            "named": named_line(pick, shares, threshold)}


def named_line(pick: str, shares: dict[str, float | None],
               threshold: float = LINE_SHARE) -> bool:
    """Whether the line is named in place of ``pick``: a linear lag on PV
    (:data:`LINE_REPLACES`) whose share of its improvement at the line (``shares[pick]``,
    ``None`` where undefined) is above ``threshold``."""
    share = shares.get(pick) if pick in LINE_REPLACES else None
    return share is not None and share > threshold
