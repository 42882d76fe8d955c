"""The measurement-noise floor of a signal, the unit-free yardstick of "steady".

Detectors that ask whether a signal stays put (Kano et al. 2004; Yamashita 2006) need a
band below which a change is noise. A band in the signal's own units ties the verdict to
those units (a flow in t/h and the same flow in kg/s would disagree); both papers set the
band from the signals' noise instead, which is what :func:`difference_noise` measures.
"""

from __future__ import annotations

import numpy as np


def difference_noise(x: np.ndarray) -> float:
    """Robust standard deviation of the measurement noise in the first differences of
    ``x``: white noise of variance σ² gives second differences of variance 6σ² and first
    differences of 2σ²; the MAD of the second differences ignores the few large ones a
    smooth signal has at its corners.

    Examples
    --------
    >>> e = np.random.default_rng(0).standard_normal(20000)
    >>> round(float(difference_noise(np.linspace(0, 50, 20000) + e) / np.sqrt(2)), 1)
    1.0
    """
    d2 = np.diff(np.asarray(x, dtype=float), 2)
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return mad / 0.6745 / np.sqrt(6.0) * np.sqrt(2.0)
