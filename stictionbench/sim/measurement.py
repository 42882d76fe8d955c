"""Measurement noise on recorded signals, outside the loop.

The simulator's sensor noise (``conf/sensor/``) enters the loop: the controller sees it.
Noise on a *recorded* controller output (historian quantisation, a re-read analogue
output) or on a valve-position transmitter does not: it changes what an estimator sees,
not what the loop does. :func:`add_measurement_noise` adds such white Gaussian noise to
a :class:`~stictionbench.recording.Recording`.

A process historian does not store every sample either. :func:`boxcar_compress` is its
commonest archive filter, exception (box-car) reporting: a new value is stored only when it
differs from the last stored one by more than a dead band, and the value read back between
stored points is the last stored one (stepped retrieval), so a compressed tag shows runs
of identical samples. :func:`historian_compression` applies it to chosen signals with the
dead band set for a given share of held steps (references: Thornhill, Choudhury & Shah,
"The impact of compression on data-driven process analyses", *J. Process Control* 14
(2004) 389–398; Jelali & Huang (eds.), *Detection and Diagnosis of Stiction in Control
Loops*, Springer 2010, ch. 4).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
from numba import njit

from ..errors import InputError
from ..recording import Recording
from ..validation import number

#: recorded signals that can carry measurement noise
NOISY_SIGNALS = ("PV", "OP", "MV", "SP")


def add_measurement_noise(rec: Recording, std: Mapping[str, float], seed: int) -> Recording:
    """Return ``rec`` with white Gaussian noise of ``std[name]`` (signal units, rms) added
    to each named recorded signal.

    Each signal gets its own stream, ``numpy.random.default_rng([seed, i])`` with ``i``
    its index in :data:`NOISY_SIGNALS`, so the noise on MV does not change when the
    noise on OP does.

    Examples
    --------
    >>> import numpy as np
    >>> rec = Recording.from_arrays(np.arange(200.0), np.zeros(200), np.zeros(200))
    >>> noisy = add_measurement_noise(rec, {"OP": 0.5}, seed=1)
    >>> round(float(noisy.OP.std()), 1), float(noisy.PV.std())
    (0.5, 0.0)
    """
    changes = {}
    for name, value in std.items():
        if name not in NOISY_SIGNALS:
            raise InputError(f"measurement noise: unknown signal {name!r}; "
                             f"known: {', '.join(NOISY_SIGNALS)}")
        s = number(f"measurement noise on {name}", value, low=0.0)
        if s == 0.0:
            continue
        x = getattr(rec, name)
        if x is None:
            raise InputError(f"measurement noise on {name}: the recording has no {name}")
        rng = np.random.default_rng([int(seed), NOISY_SIGNALS.index(name)])
        changes[name] = x + s * rng.standard_normal(x.size)
    if not changes:
        return rec
    meta = {**rec.meta, "measurement_noise": {k: float(v) for k, v in std.items()}}
    return dataclasses.replace(rec, meta=meta, **changes)


@njit(cache=True)
def _boxcar(x: np.ndarray, deadband: float) -> np.ndarray:
    out = np.empty_like(x)
    last = x[0]
    for i in range(x.size):
        if abs(x[i] - last) > deadband:
            last = x[i]
        out[i] = last
    return out


def boxcar_compress(x: np.ndarray, deadband: float) -> np.ndarray:
    """Exception (box-car) reporting with stepped retrieval: ``x[i]`` is stored when it
    differs from the last stored value by more than ``deadband``; otherwise the last
    stored value is read back.

    Examples
    --------
    >>> boxcar_compress(np.array([0.0, 0.2, 0.6, 0.7, 1.5]), 0.5).tolist()
    [0.0, 0.0, 0.6, 0.6, 1.5]
    """
    x = np.ascontiguousarray(x, dtype=float)
    if x.size == 0:
        return x.copy()
    return _boxcar(x, float(number("deadband", deadband, low=0.0)))


def held_fraction(*signals: np.ndarray) -> float:
    """Share of sample-to-sample steps in which every signal is exactly unchanged.

    With PV and OP this is ``held_frac`` of ``plant/labels.csv``: the historian's
    hold-last-value (box-car) fill.

    Examples
    --------
    >>> held_fraction(np.array([1., 1, 2, 2, 3]), np.array([5., 5, 6, 7, 8]))
    0.25
    """
    same = np.ones(max(signals[0].size - 1, 0), dtype=bool)
    for x in signals:
        same &= np.diff(x) == 0
    return float(same.mean()) if same.size else 0.0


def compress_to_share(x: np.ndarray, share: float, *, iterations: int = 40) -> np.ndarray:
    """:func:`boxcar_compress` with the smallest dead band (bisection) that holds at
    least ``share`` of the steps; ``share = 0`` returns ``x`` unchanged.

    Examples
    --------
    >>> x = np.cumsum(np.random.default_rng(0).standard_normal(2000))
    >>> round(held_fraction(compress_to_share(x, 0.5)), 2)
    0.5
    """
    share = number("hold share", share, low=0.0)
    if share >= 1.0:
        raise InputError(f"hold share {share} must be below 1")
    x = np.asarray(x, dtype=float)
    if share == 0.0 or held_fraction(x) >= share:
        return x.copy()
    lo, hi = 0.0, float(np.ptp(x))
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if held_fraction(boxcar_compress(x, mid)) >= share:
            hi = mid
        else:
            lo = mid
    return boxcar_compress(x, hi)


@njit(cache=True)
def _row_boxcar(x: np.ndarray, bands: np.ndarray) -> np.ndarray:
    out = np.empty_like(x)
    last = x[0].copy()
    for i in range(x.shape[0]):
        for j in range(x.shape[1]):
            if abs(x[i, j] - last[j]) > bands[j]:
                last[:] = x[i]
                break
        out[i] = last
    return out


def historian_compression(rec: Recording, share: float,
                          signals: tuple[str, ...] = ("PV", "OP"), *,
                          joint: bool = False, iterations: int = 40) -> Recording:
    """``rec`` as a compressing historian would return it, with ``share`` of the steps
    held.

    ``joint=False``: each of ``signals`` box-car compressed on its own
    (:func:`compress_to_share`), as a historian compresses each tag; the share of steps
    in which *all* of them hold is then smaller. ``joint=True``: rows are stored
    together, whenever any of ``signals`` leaves its dead band (dead bands proportional
    to the median size of each signal's steps, one factor set by bisection for
    ``share`` of held rows), so every signal holds on the same steps — the
    PV-and-OP holds of ``plant/labels.csv``.

    Examples
    --------
    >>> t = np.arange(1000.0)
    >>> rng = np.random.default_rng(1)
    >>> rec = Recording.from_arrays(t, np.cumsum(rng.standard_normal(1000)),
    ...                             np.cumsum(rng.standard_normal(1000)))
    >>> out = historian_compression(rec, 0.6)
    >>> round(held_fraction(out.PV), 1), round(held_fraction(out.OP), 1)
    (0.6, 0.6)
    >>> out.meta["historian_hold_share"]
    0.6
    >>> out = historian_compression(rec, 0.6, joint=True)
    >>> round(held_fraction(out.PV), 2), round(held_fraction(out.OP), 2)
    (0.6, 0.6)
    """
    share = number("hold share", share, low=0.0)
    if share >= 1.0:
        raise InputError(f"hold share {share} must be below 1")
    xs = []
    for name in signals:
        x = getattr(rec, name, None)
        if name not in NOISY_SIGNALS or x is None:
            raise InputError(f"historian compression: the recording has no {name!r}")
        xs.append(np.asarray(x, dtype=float))
    if not joint:
        changes = {name: compress_to_share(x, share) for name, x in zip(signals, xs,
                                                                         strict=True)}
    else:
        x = np.ascontiguousarray(np.column_stack(xs))
        scale = np.array([np.median(np.abs(np.diff(c))) or np.ptp(c) or 1.0 for c in xs])
        out = x.copy()
        if share > 0:
            lo, hi = 0.0, float(np.max(np.ptp(x, axis=0) / scale)) + 1.0
            for _ in range(iterations):
                mid = 0.5 * (lo + hi)
                if held_fraction(_row_boxcar(x, mid * scale)[:, 0]) >= share:
                    hi = mid
                else:
                    lo = mid
            out = _row_boxcar(x, hi * scale)
        changes = {name: out[:, j] for j, name in enumerate(signals)}
    meta = {**rec.meta, "historian_hold_share": float(share), "historian_joint": joint}
    return dataclasses.replace(rec, meta=meta, **changes)
