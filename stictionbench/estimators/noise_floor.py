"""The measurement-noise floor of a signal, the unit-free yardstick of "steady".

Detectors that ask whether a signal stays put (Kano et al. 2004; Yamashita 2006) need a
band below which a change is noise. A band in the signal's own units ties the verdict to
those units (a flow in t/h and the same flow in kg/s would disagree); both papers set the
band from the signals' noise instead, which is what :func:`difference_noise` measures.

Historians store a value only when it leaves a dead band (exception or box-car
compression) and ``batch`` bridges short PV-and-OP holds with straight lines. Held and
bridged samples carry no noise of their own: measured over them, the noise of a
half-compressed record is zero to rounding and every change reads as a move
(``experiments/compression.py``: Kano's detections on the real stiction windows went
from 6 to 0 of 15 at half the steps held, Yamashita's from 9 to 2). The noise is
therefore measured on the samples the historian stored: those neither equal to the
previous one nor on the straight line through their neighbours.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

#: ``Recording.meta`` key of the boolean mask of samples a reader filled in (the
#: straight lines :func:`stictionbench.realdata.quality.release_holds` draws over holds)
FILLED = "filled_samples"

#: fewest stored samples to measure the noise on, in number and as a share of the record
#: (else every sample is used: a noise-free piecewise-linear signal, a hand-made triangle
#: wave, would otherwise be measured on its corners alone)
MIN_STORED = 8
MIN_STORED_SHARE = 0.1


def stored_samples(x: np.ndarray) -> np.ndarray:
    """Mask of the samples a historian stored: not equal to the previous sample (a
    hold) and not on the straight line through both neighbours (a bridged hold), to
    ``1e-9`` of the signal's range. The first and last samples count as stored.

    Examples
    --------
    >>> stored_samples(np.array([0.0, 1.0, 1.0, 1.0, 2.0, 3.0, 4.0, 2.0])).tolist()
    [True, True, False, False, False, False, True, True]
    """
    x = np.asarray(x, dtype=float)
    keep = np.ones(x.size, dtype=bool)
    if x.size < 3:
        return keep
    tol = 1e-9 * (float(np.ptp(x)) or 1.0)
    keep[1:] &= np.abs(np.diff(x)) > tol
    keep[1:-1] &= np.abs(np.diff(x, 2)) > tol
    keep[-1] = True
    return keep


def difference_noise(x: np.ndarray) -> float:
    """Robust standard deviation of the measurement noise in the first differences of
    ``x``, measured on the stored samples (:func:`stored_samples`; all samples when
    fewer than ``MIN_STORED`` or than ``MIN_STORED_SHARE`` of them are): white noise of
    variance σ² gives second differences of variance 6σ² and first differences of 2σ²;
    the MAD of the second differences ignores the few large ones a smooth signal has at
    its corners.

    Examples
    --------
    >>> e = np.random.default_rng(0).standard_normal(20000)
    >>> round(float(difference_noise(np.linspace(0, 50, 20000) + e) / np.sqrt(2)), 1)
    1.0
    >>> held = np.repeat(np.linspace(0, 50, 10000) + e[:10000], 2)   # every value twice
    >>> round(float(difference_noise(held) / np.sqrt(2)), 1)
    1.0
    >>> float(difference_noise(np.tile(np.r_[np.arange(50.0), np.arange(50.0, 0, -1)], 20)))
    0.0
    """
    x = np.asarray(x, dtype=float)
    keep = stored_samples(x)
    if keep.sum() >= max(MIN_STORED, MIN_STORED_SHARE * x.size):
        x = x[keep]
    d2 = np.diff(x, 2)
    if d2.size == 0:
        return 0.0
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return mad / 0.6745 / np.sqrt(6.0) * np.sqrt(2.0)


def measured_samples(meta: Mapping[str, Any], n: int) -> np.ndarray | None:
    """Mask of the ``n`` samples that were measured (not filled in, ``meta[FILLED]``);
    ``None`` when nothing is marked as filled or the mask does not fit a record of
    ``n`` samples (a resampled record).

    Examples
    --------
    >>> measured_samples({FILLED: np.array([0, 0, 1, 1, 0, 0], bool)}, 6).tolist()
    [True, True, False, False, True, True]
    >>> measured_samples({}, 6) is None
    True
    """
    mask = meta.get(FILLED)
    if mask is None:
        return None
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (n,) or not mask.any():
        return None
    return ~mask
