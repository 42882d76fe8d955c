"""Usable stretches of a recording whose historian lost data for a while.

Plant exports often hold a week of data with an outage in it: a transmitter dropped out,
a link to the historian went down. A gap of at most :data:`~.recording.MAX_INTERPOLATED_GAP`
samples is interpolated (:meth:`.Recording.from_arrays`); a longer one cannot be filled
without inventing dynamics, so the record is cut there and each stretch between long
gaps that is long enough (:data:`~.recording.MIN_SAMPLES`) is analysed on its own —
rather than refusing the whole file for one outage.

Many historians export an outage as *absent rows* rather than empty cells: the time column
then jumps by a whole number of sampling intervals. Such rows are put back on the uniform
grid as missing samples (:func:`missing_rows_as_gaps`), so that the same rules apply to
both spellings of a gap.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .errors import user_warning
from .recording import (
    HOLD_SHARE,
    MAX_GRID_GROWTH,
    MAX_INTERPOLATED_GAP,
    MIN_SAMPLES,
    UNIFORM_TOLERANCE,
    Recording,
    hold_setpoint,
    last_written,
)


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
    cols = dict(cols)
    faults = cols.pop(FAULTS, None) or {}

    def strict(c: Mapping[str, Any]) -> list[Recording]:
        """The whole record by the strict reader (its message where it cannot be one)."""
        return [Recording.from_arrays(c["t"], c["PV"], c["OP"], SP=c.get("SP"),
                                      MV=c.get("MV"), meta=meta, source=source,
                                      first_row=first_row, warn=warn)]

    if len({np.size(v) for v in cols.values() if v is not None}) > 1:
        return strict(cols)  # signals of different lengths: the strict reader says which
    cols, grid_rows = missing_rows_as_gaps(cols, source=source, first_row=first_row,
                                           warn=warn)
    if grid_rows is not None:  # the historian's faults on the grid (inserted rows: none)
        faults = {k: np.where(grid_rows >= 0, f[np.maximum(grid_rows, 0)], False)
                  for k, f in faults.items()}
    cols, note = hold_on_change(cols, faults)
    if note and warn:
        user_warning(f"{source}: {note}")
    if cols.get("SP") is not None:
        # a set point logged only when it changes is held, not cut at (its blank cells
        # are no gap in a measurement); the note is the strict reader's, given once here
        sp, note = hold_setpoint(cols["SP"], source, first_row)
        cols = {**cols, "SP": sp}
        if note and warn:
            user_warning(note)
    present = {k: np.asarray(v, float) for k, v in cols.items() if v is not None}
    missing = np.zeros(len(present["t"]), bool)
    for k, v in present.items():
        if k != "t":
            missing |= np.isnan(v)
    spans = stretches(missing)
    if not spans or not any(b - a > MAX_INTERPOLATED_GAP for a, b in true_runs(missing)):
        return strict(cols)  # no long gap (or nothing usable): the strict reader's answer
    out = []
    for a, b in spans:
        ends = (a, b - 1) if grid_rows is None else (grid_rows[a], grid_rows[b - 1])
        rows = [int(ends[0]) + first_row, int(ends[1]) + first_row]
        md = {**(meta or {}), "rows": rows, "stretch_of": source}
        part = {k: (None if v is None else np.asarray(v, float)[a:b]) for k, v in cols.items()}
        out.append(Recording.from_arrays(
            part["t"], part["PV"], part["OP"], SP=part.get("SP"), MV=part.get("MV"),
            meta=md, source=f"{source} (rows {rows[0]}–{rows[1]})", first_row=rows[0],
            warn=warn))
    return out


#: a signal missing in at least this many separate places is one written only when it
#: changed (a historian's "recorded values" export: rows absent, or a merged table's blank
#: cells, between changes), not one with that many outages
ON_CHANGE_GAPS = 10


#: the key of a reader's columns under which it gives, per signal, the samples the
#: historian wrote a fault word for (``Bad``, ``I/O Timeout``): missing, never held
FAULTS = "faults"


def hold_on_change(cols: Mapping[str, np.ndarray | None],
                   faults: Mapping[str, np.ndarray] | None = None
                   ) -> tuple[dict[str, np.ndarray | None], str | None]:
    """``cols`` with each measured signal (``PV, OP, MV``) that is missing in at least
    :data:`ON_CHANGE_GAPS` separate places held at its last value over its gaps, and a
    note naming them (``None`` when none is).

    A historian that writes a value only when it changes (exception reporting, box-car
    compression) leaves rows or cells out between the changes; their value is the last
    one written. Held so, the record is the one the same historian exports with every
    row written (its held samples; :func:`~stictionbench.realdata.quality.release_holds`
    then treats both alike), for gaps up to :data:`~.recording.HOLD_SHARE` of the record
    (the longest hold that is bridged there); a longer gap, and every gap of a signal
    missing in fewer places, is an outage and stays a gap (interpolated when short, cut
    at when long). Missing values before a signal's first value stay missing, and so do
    the samples ``faults`` marks (a fault word the historian wrote: a bad value, not an
    unchanged one).

    Examples
    --------
    >>> pv = np.arange(40.0); pv[1::3] = np.nan
    >>> held, note = hold_on_change({"t": np.arange(40.0), "PV": pv, "OP": np.ones(40)})
    >>> held["PV"][:6].tolist()
    [0.0, 0.0, 2.0, 3.0, 3.0, 5.0]
    >>> note
    'PV held over 13 missing samples in 13 places (written only when it changed?)'
    """
    out = dict(cols)
    notes = []
    for name in ("PV", "OP", "MV"):
        v = cols.get(name)
        if v is None:
            continue
        v = np.asarray(v, float)
        fault = np.asarray((faults or {}).get(name, np.zeros(v.size, bool)), bool)
        blank = np.isnan(v) & ~fault
        if not blank.any() or np.isnan(v).all():
            continue
        first = int(np.argmax(~np.isnan(v)))
        runs = [r for r in true_runs(blank) if r[0] > first]
        if len(runs) < ON_CHANGE_GAPS:
            continue
        limit = max(MAX_INTERPOLATED_GAP, int(HOLD_SHARE * v.size))
        held = [(a, b) for a, b in runs if b - a <= limit]
        if not held:
            continue
        short = np.zeros(v.size, bool)
        for a, b in held:
            short[a:b] = True
        out[name] = np.where(short, v[last_written(np.isnan(v))], v)
        notes.append(f"{name} held over {int(short.sum())} missing samples in {len(held)} "
                     "places")
        if len(held) < len(runs) or fault.any():
            notes[-1] += (f" (gaps longer than {limit} samples, {HOLD_SHARE:.0%} of the "
                          "record, and the historian's fault words stay gaps)")
    return out, ("; ".join(notes) + " (written only when it changed?)") if notes else None


def missing_rows_as_gaps(cols: Mapping[str, np.ndarray | None], *, source: str,
                         first_row: int = 0, warn: bool = True
                         ) -> tuple[dict[str, np.ndarray | None], np.ndarray | None]:
    """``cols`` on the uniform time grid where rows are absent from the file: every time
    step that is a whole number ``k ≥ 2`` of the median step (within
    :data:`~.recording.UNIFORM_TOLERANCE` of it) gets ``k − 1`` rows of missing values
    (NaN), with a warning on stderr. Returns the columns and, for each grid row, its
    index among the file's data rows (``-1`` where inserted; ``first_row`` is the file
    row of index 0, for the warning), or ``(cols, None)`` unchanged when no row is
    absent, or when the time column is anything else (missing or decreasing times,
    uneven steps, an outage longer than :data:`MAX_GRID_GROWTH` times the record), which
    the strict reader then refuses with its own message.

    Examples
    --------
    >>> c = {"t": np.array([0.0, 1, 2, 5, 6]), "PV": np.arange(5.0), "OP": np.ones(5)}
    >>> g, rows = missing_rows_as_gaps(c, source="x", warn=False)
    >>> g["t"].tolist(), rows.tolist()
    ([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0], [0, 1, 2, -1, -1, 3, 4])
    >>> g["PV"].tolist()
    [0.0, 1.0, 2.0, nan, nan, 3.0, 4.0]
    """
    t = np.asarray(cols["t"], float)
    if t.size < 3 or not np.all(np.isfinite(t)):
        return dict(cols), None
    dt = np.diff(t)
    if np.any(dt <= 0):
        return dict(cols), None
    Ts = float(np.median(dt))
    k = np.rint(dt / Ts)
    if (np.all(k == 1) or np.any(np.abs(dt - k * Ts) > UNIFORM_TOLERANCE * Ts)
            or k.sum() + 1 > MAX_GRID_GROWTH * t.size):
        return dict(cols), None
    pos = np.r_[0, np.cumsum(k)].astype(int)
    n = int(pos[-1]) + 1
    out: dict[str, np.ndarray | None] = {}
    for name, v in cols.items():
        if v is None:
            out[name] = None
            continue
        g = np.full(n, np.nan)
        g[pos] = np.asarray(v, float)
        out[name] = g
    out["t"] = t[0] + Ts * np.arange(n)
    out["t"][pos] = t  # the file's own times where it has them
    rows = np.full(n, -1)
    rows[pos] = np.arange(t.size)
    if warn:
        big = int(np.argmax(k))
        m = n - t.size
        user_warning(f"{source}: {m} row{'s' * (m > 1)} absent from the file (time steps "
                     f"of whole multiples of {Ts:g} s, the longest {dt[big]:g} s after row "
                     f"{big + first_row}) treated as missing samples")
    return out, rows


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` of every run of True in ``mask``.

    Examples
    --------
    >>> true_runs(np.array([True, True, False, True]))
    [(0, 2), (3, 4)]
    """
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def longest_stretch(parts: list[Recording], where: str, warn: bool) -> Recording:
    """The longest of a record's usable stretches (:func:`split_at_gaps`), with one
    warning on stderr naming the rows used and the stretches left out, or the rows used
    when a long gap at the start or the end was cut off."""
    best = max(parts, key=len)
    if "rows" not in best.meta or not warn:
        return best
    rows = best.meta["rows"]
    if len(parts) > 1:
        others = ", ".join(f"rows {r.meta['rows'][0]}–{r.meta['rows'][1]}"
                           for r in parts if r is not best)
        user_warning(f"{where}: gaps of more than {MAX_INTERPOLATED_GAP} missing samples cut "
                     f"the record into {len(parts)} usable stretches; using the longest, "
                     f"rows {rows[0]}–{rows[1]} ({len(best)} samples); not used: {others}")
    else:  # one stretch: a long gap at the start or the end
        user_warning(f"{where}: using rows {rows[0]}–{rows[1]} ({len(best)} samples); the "
                     f"rows before or after them are a gap of more than "
                     f"{MAX_INTERPOLATED_GAP} missing samples")
    return best
