"""A FOPDT driven by a wandering OP with set-point-like steps, for tests of the diagnosis's
plumbing that need a recording and its (right) nominal model, not a closed loop."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.signal import lfilter

from stictionbench.diagnosis.model import NominalModel
from stictionbench.recording import Recording


def fopdt_record(seed: int = 3, n: int = 1500,
                 load: float = 0.0) -> tuple[Recording, NominalModel]:
    """PV of ``2·e^{−3s}/(10s + 1)`` (1 s samples) on OP, white noise of 0.05 and, with
    ``load`` > 0, a random walk of that step spread through a slow lag; the model given."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    op = np.cumsum(rng.normal(0, 0.3, n)) * 0.1 + 50 + 5 * (np.sin(t / 40) > 0)
    a = np.exp(-1 / 10.0)
    pv = np.zeros(n)
    for k in range(3, n):
        pv[k] = a * pv[k - 1] + 2.0 * (1 - a) * (op[k - 3] - 50)
    if load > 0:
        pv += lfilter([0.05], [1.0, -0.98], np.cumsum(rng.normal(0, load, n)))
    pv += rng.normal(0, 0.05, n)
    model = NominalModel(gain=2.0, time_constant=10.0, dead_time=3.0, source="given")
    return Recording.from_arrays(t, pv, op, warn=False), model


def write_files(rec: Recording, folder: Path) -> tuple[Path, Path]:
    """``rec`` as ``folder/r.csv`` and the model of :func:`fopdt_record` as
    ``folder/m.yaml``, for tests of the command line."""
    from stictionbench.io import write_recording

    csv, model = folder / "r.csv", folder / "m.yaml"
    write_recording(rec, csv)
    model.write_text("process: {gain: 2.0, time_constant: 10.0, dead_time: 3.0}\n")
    return csv, model
