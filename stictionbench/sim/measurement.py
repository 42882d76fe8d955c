"""Measurement noise on recorded signals, outside the loop.

The simulator's sensor noise (``conf/sensor/``) enters the loop: the controller sees it.
Noise on a *recorded* controller output (historian quantisation, a re-read analogue
output) or on a valve-position transmitter does not: it changes what an estimator sees,
not what the loop does. :func:`add_measurement_noise` adds such white Gaussian noise to
a :class:`~stictionbench.recording.Recording`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

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
