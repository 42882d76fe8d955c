"""Usable stretches of a recording whose historian lost data for a while.

Plant exports often hold a week of data with an outage in it: a transmitter dropped out,
a link to the historian went down. A gap of at most :data:`~.recording.MAX_INTERPOLATED_GAP`
samples is interpolated (:meth:`.Recording.from_arrays`); a longer one cannot be filled
without inventing dynamics, so the record is cut there and each stretch between long
gaps that is long enough (:data:`~.recording.MIN_SAMPLES`) is analysed on its own —
rather than refusing the whole file for one outage.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .recording import MAX_INTERPOLATED_GAP, MIN_SAMPLES, Recording


def stretches(missing: np.ndarray, *, max_gap: int = MAX_INTERPOLATED_GAP,
              min_len: int = MIN_SAMPLES) -> list[tuple[int, int]]:
    """``[start, stop)`` row ranges between runs of more than ``max_gap`` missing
    samples (runs at either end are cut as well), of at least ``min_len`` rows.

    Examples
    --------
    >>> m = np.zeros(300, bool); m[120:130] = True; m[200:203] = True
    >>> stretches(m)
    [(0, 120), (130, 300)]
    """
    missing = np.asarray(missing, bool)
    cuts = [(a, b) for a, b in true_runs(missing)
            if b - a > max_gap or a == 0 or b == missing.size]
    out, start = [], 0
    for a, b in cuts:
        if a - start >= min_len:
            out.append((start, int(a)))
        start = int(b)
    if missing.size - start >= min_len:
        out.append((start, int(missing.size)))
    return out


def split_at_gaps(cols: Mapping[str, np.ndarray | None], *, source: str, first_row: int,
                  warn: bool, meta: Mapping[str, Any] | None = None) -> list[Recording]:
    """One :class:`.Recording` per usable stretch of ``cols`` (``t, PV, OP`` and optional
    ``SP, MV``): the whole record when no gap is longer than
    :data:`~.recording.MAX_INTERPOLATED_GAP`, else each stretch between long gaps, with
    its rows in ``meta["rows"]`` (file rows, first and last) and in its source name.

    Raises
    ------
    InputError
        When no stretch is :data:`~.recording.MIN_SAMPLES` long (the message names the
        longest gap), or from :meth:`.Recording.from_arrays`.
    """
    present = {k: np.asarray(v, float) for k, v in cols.items() if v is not None}
    missing = np.zeros(len(present["t"]), bool)
    for k, v in present.items():
        if k != "t":
            missing |= np.isnan(v)
    spans = stretches(missing)
    if not spans or not any(b - a > MAX_INTERPOLATED_GAP for a, b in true_runs(missing)):
        # no long gap (or nothing usable): the strict reader's answer, message included
        return [Recording.from_arrays(cols["t"], cols["PV"], cols["OP"], SP=cols.get("SP"),
                                      MV=cols.get("MV"), meta=meta, source=source,
                                      first_row=first_row, warn=warn)]
    out = []
    for a, b in spans:
        rows = [a + first_row, b - 1 + first_row]
        md = {**(meta or {}), "rows": rows, "stretch_of": source}
        part = {k: (None if v is None else np.asarray(v, float)[a:b]) for k, v in cols.items()}
        out.append(Recording.from_arrays(
            part["t"], part["PV"], part["OP"], SP=part.get("SP"), MV=part.get("MV"),
            meta=md, source=f"{source} (rows {rows[0]}–{rows[1]})", first_row=rows[0],
            warn=warn))
    return out


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` of every run of True in ``mask``.

    Examples
    --------
    >>> true_runs(np.array([True, True, False, True]))
    [(0, 2), (3, 4)]
    """
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]
