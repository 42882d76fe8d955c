"""The one data type every stage passes around: a sampled control-loop record.

A :class:`Recording` holds uniformly sampled ``t, SP, PV, OP`` and an optional valve
position ``MV``, the sample time ``Ts`` and free-form metadata (source, case, seed, true
parameters when simulated). Validation happens once, in :meth:`Recording.from_arrays`;
nothing downstream re-checks shapes.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from .errors import InputError, user_warning

SIGNALS = ("SP", "PV", "OP", "MV")
REQUIRED = ("t", "PV", "OP")
MIN_SAMPLES = 100
MAX_INTERPOLATED_GAP = 5
#: a historian's hold (a value repeated, or written only when it changed) is bridged up
#: to this share of the record; a longer one is no compression artefact to undo
HOLD_SHARE = 0.02

#: rows absent from a file (whole sampling intervals missing) are put on the uniform grid
#: as missing samples up to this many times the file's rows (an outage of weeks in a record
#: of hours is not a gap to bridge: :func:`.stretches.missing_rows_as_gaps`)
MAX_GRID_GROWTH = 4.0
#: largest magnitude accepted in the time column: beyond it squares and variances
#: overflow double precision (no clock records such numbers; epoch nanoseconds are 1e18)
MAX_MAGNITUDE = 1e100
#: largest magnitude accepted in a signal column (SP, PV, OP, MV): the fits square,
#: multiply and sum them over the record, and at 1e90 they overflowed to a wrong delay or
#: a failed logarithm; no instrument reads beyond 1e15 in any unit
MAX_SIGNAL_MAGNITUDE = 1e15
#: shortest sampling interval accepted (s): process data sampled faster than a
#: microsecond is a mistaken time column (at 1e-18 s the FOPDT grid never finished)
MIN_SAMPLE_TIME = 1e-6
UNIFORM_TOLERANCE = 0.01


@dataclass(frozen=True, eq=False)
class Recording:
    """A uniformly sampled closed-loop record.

    Attributes
    ----------
    t : ndarray
        Time in seconds, strictly increasing and uniform (``Ts`` apart within 1 %).
    PV, OP : ndarray
        Process variable and controller output (OP usually in % of span).
    SP : ndarray or None
        Set point; ``None`` when the source does not have it.
    MV : ndarray or None
        Valve position (stem travel, % of span); ``None`` when not recorded.
    Ts : float
        Sample time in seconds.
    meta : Mapping
        Read-only metadata: ``source``, ``case``, ``seed``, true parameters, warnings.

    Build one with :meth:`from_arrays` (which validates); the constructor itself
    trusts its arguments.
    """

    t: np.ndarray
    PV: np.ndarray
    OP: np.ndarray
    SP: np.ndarray | None = None
    MV: np.ndarray | None = None
    Ts: float = 1.0
    meta: Mapping[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------------ building
    @classmethod
    def from_arrays(
        cls,
        t: Any,
        PV: Any,
        OP: Any,
        SP: Any = None,
        MV: Any = None,
        *,
        meta: Mapping[str, Any] | None = None,
        source: str = "<arrays>",
        first_row: int = 0,
        warn: bool = True,
    ) -> Recording:
        """Validate arrays and build a Recording.

        Parameters
        ----------
        t, PV, OP : array_like
            Time (s), process variable and controller output; required.
        SP, MV : array_like, optional
            Set point and valve position.
        meta : Mapping, optional
            Metadata stored read-only on the Recording.
        source : str
            Name used in error messages (a file path for loaded data).
        first_row : int
            Row number of the first sample in ``source`` (for messages; a CSV with a
            header has its first sample on line 2).
        warn : bool
            Print a warning on stderr when short gaps are interpolated.

        Returns
        -------
        Recording

        Raises
        ------
        InputError
            On ±inf or magnitudes beyond :data:`MAX_MAGNITUDE`, non-monotone or
            non-uniform time, fewer than 100 samples, a gap
            of missing values longer than 5 samples, or arrays of different lengths.
            Gaps of up to 5 missing samples are interpolated linearly.
        """
        arrays = _as_columns({"t": t, "SP": SP, "PV": PV, "OP": OP, "MV": MV}, source)
        notes = _fill_missing(arrays, source, first_row)
        tt = arrays["t"]
        assert tt is not None
        Ts = _uniform_step(tt, source, first_row)
        if warn:
            for note in notes:
                user_warning(note)
        md = dict(meta or {})
        md.setdefault("source", source)
        if notes:
            md["warnings"] = tuple(md.get("warnings", ())) + tuple(notes)
        for arr in arrays.values():
            if arr is not None:
                arr.setflags(write=False)
        return cls(
            t=tt,
            PV=arrays["PV"],
            OP=arrays["OP"],
            SP=arrays["SP"],
            MV=arrays["MV"],
            Ts=Ts,
            meta=MappingProxyType(md),
        )

    # ------------------------------------------------------------------ access
    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def columns(self) -> tuple[str, ...]:
        """Names of the signals present, in the order ``t, SP, PV, OP, MV``."""
        return ("t",) + tuple(s for s in SIGNALS if getattr(self, s) is not None)

    def signal(self, name: str) -> np.ndarray:
        """Return a signal by name, with a clear error when it is absent.

        Parameters
        ----------
        name : {"t", "SP", "PV", "OP", "MV"}

        Raises
        ------
        InputError
            When the name is unknown or the signal was not recorded.
        """
        if name not in ("t",) + SIGNALS:
            raise InputError(f"unknown signal {name!r}; use one of t, SP, PV, OP, MV")
        value = getattr(self, name)
        if value is None:
            raise InputError(
                f"{self.meta.get('source', 'recording')}: signal {name} is not recorded"
            )
        return value

    def to_frame(self):  # -> pandas.DataFrame
        """Return the signals as a pandas DataFrame with columns ``t, SP, PV, OP[, MV]``."""
        import pandas as pd

        return pd.DataFrame({c: getattr(self, c) for c in self.columns})

    def slice(self, start: int, stop: int) -> Recording:
        """Return samples ``start:stop`` as a new Recording (no re-validation)."""
        def cut(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else a[start:stop]

        return Recording(
            t=self.t[start:stop],
            PV=self.PV[start:stop],
            OP=self.OP[start:stop],
            SP=cut(self.SP),
            MV=cut(self.MV),
            Ts=self.Ts,
            meta=self.meta,
        )

    def __repr__(self) -> str:
        src = self.meta.get("source", "?")
        return (
            f"Recording(n={len(self)}, Ts={self.Ts:g}, columns={','.join(self.columns)}, "
            f"source={src!r})"
        )


def _as_columns(raw: dict[str, Any], source: str) -> dict[str, np.ndarray | None]:
    """Float copies of the given columns, all of one length of at least MIN_SAMPLES."""
    arrays: dict[str, np.ndarray | None] = {}
    n = None
    for name, value in raw.items():
        if value is None:
            if name in REQUIRED:  # a Recording has them all
                raise InputError(f"{source}: column {name} is required (t, PV and OP are; "
                                 "SP and MV are optional)")
            arrays[name] = None
            continue
        raw_arr = np.asarray(value)
        if sum(k > 1 for k in raw_arr.shape) > 1:
            raise InputError(f"{source}: column {name} is a {raw_arr.shape} array, not one "
                             "signal")
        if np.iscomplexobj(raw_arr):
            if np.any(np.imag(raw_arr) != 0):
                raise InputError(f"{source}: column {name} holds complex numbers, not a "
                                 "measurement")
            raw_arr = np.real(raw_arr)
        try:
            arr = np.asarray(raw_arr, dtype=float).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{source}: column {name} is not numeric ({exc})") from None
        if n is None:
            n = arr.size
        elif arr.size != n:
            raise InputError(f"{source}: column {name} has {arr.size} samples, expected {n}")
        arrays[name] = arr.copy()
    assert n is not None
    if n < MIN_SAMPLES:
        raise InputError(f"{source}: {n} samples; at least {MIN_SAMPLES} are needed")
    return arrays


def last_written(missing: np.ndarray) -> np.ndarray:
    """For each sample, the index of the last one not ``missing`` at or before it (0
    before the first): the index a hold of the last written value reads.

    >>> last_written(np.array([False, True, True, False, True])).tolist()
    [0, 0, 0, 3, 3]
    """
    missing = np.asarray(missing, bool)
    return np.maximum.accumulate(np.where(missing, 0, np.arange(missing.size)))


def hold_setpoint(sp: np.ndarray | None, source: str, first_row: int = 0
                  ) -> tuple[np.ndarray | None, str | None]:
    """The set point with its blank cells filled by holding the last logged value
    (``(SP, note)``; ``note`` is ``None`` where nothing was blank).

    A set point is a held signal: historians often log it only when it changes (report
    by exception), leaving blank cells between the changes, which a linear interpolation
    would turn into ramps and which the gap limit for measured signals
    (:data:`MAX_INTERPOLATED_GAP`) would refuse or cut the record at. Its value before
    the first logged one is unknown: a short leading gap is filled with that first
    value; a longer one, or a column with no value, makes SP not recorded (``None``),
    and the loop is read as one with a constant, unknown set point.

    Examples
    --------
    >>> sp, note = hold_setpoint(np.array([50.0, np.nan, np.nan, 52.0, np.nan]), "f.csv", 2)
    >>> sp.tolist()
    [50.0, 50.0, 50.0, 52.0, 52.0]
    >>> note.split(": ", 2)[2]
    '3 blank cells filled by holding the last logged set point (logged only when it changed?)'

    >>> hold_setpoint(np.r_[np.full(10, np.nan), 1.0, 1.0], "f.csv", 2)[0] is None
    True
    """
    if sp is None:
        return None, None
    sp = np.asarray(sp, float)
    blank = np.isnan(sp)
    if not blank.any():
        return sp, None
    if blank.all():
        return None, f"{source}: column SP has no values; read as not recorded"
    first = int(np.argmax(~blank))
    if first > MAX_INTERPOLATED_GAP:
        return None, (f"{source}: column SP: rows {first_row}–{first_row + first - 1} are "
                      "blank, so the set point before its first logged value is unknown; "
                      "SP is read as not recorded")
    held = sp[last_written(blank)]
    held[:first] = sp[first]
    return held, (f"{source}: column SP: {int(blank.sum())} blank cells filled by holding "
                  "the last logged set point (logged only when it changed?)")


def _fill_missing(arrays: dict[str, np.ndarray | None], source: str,
                  first_row: int) -> list[str]:
    """Refuse infinities and missing times; hold the set point over its blank cells
    (:func:`hold_setpoint`); interpolate short gaps of the other signals in place
    (notes)."""
    notes: list[str] = []
    if arrays.get("SP") is not None and not np.isinf(arrays["SP"]).any():
        arrays["SP"], note = hold_setpoint(arrays["SP"], source, first_row)
        if note:
            notes.append(note)
    for name, arr in arrays.items():
        if arr is None:
            continue
        bad = np.isinf(arr)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(f"{source}: row {i + first_row}, column {name}: infinite value")
        limit = MAX_MAGNITUDE if name == "t" else MAX_SIGNAL_MAGNITUDE
        with np.errstate(invalid="ignore"):
            huge = np.abs(arr) > limit
        if huge.any():
            i = int(np.argmax(huge))
            raise InputError(f"{source}: row {i + first_row}, column {name}: {arr[i]:g} is "
                             f"beyond ±{limit:g}, not a measurement")
        missing = np.isnan(arr)
        if missing.any():
            if name == "t":
                i = int(np.argmax(missing))
                raise InputError(f"{source}: row {i + first_row}, column t: missing time")
            _fill_gaps(arr, missing, name, source, first_row, notes)
    return notes


def _uniform_step(tt: np.ndarray, source: str, first_row: int) -> float:
    """The sampling interval of a strictly increasing, uniform time column."""
    dt = np.diff(tt)
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0)) + 1
        raise InputError(
            f"{source}: row {i + first_row}, column t: time is not strictly increasing")
    Ts = float(np.median(dt))
    if Ts < MIN_SAMPLE_TIME:
        raise InputError(f"{source}: column t: sampling interval {Ts:g} s is below "
                         f"{MIN_SAMPLE_TIME:g} s; give t in seconds")
    off = np.abs(dt - Ts) > UNIFORM_TOLERANCE * Ts
    if off.any():
        i = int(np.argmax(off)) + 1
        k = np.rint(dt / Ts)
        if np.all(np.abs(dt - k * Ts) <= UNIFORM_TOLERANCE * Ts):  # whole intervals absent
            grid = int(k.sum()) + 1
            why = (f"longer than the stretch readers bridge ({MAX_GRID_GROWTH:g} times "
                   "the file's rows)" if grid > MAX_GRID_GROWTH * tt.size else
                   "which only the commands that read a record's usable stretches bridge")
            raise InputError(
                f"{source}: row {i + first_row}, column t: the time jumps by "
                f"{int(k[i - 1])} sampling intervals ({dt[i - 1]:g} s): rows absent from "
                f"the file, an outage {why}; cut the file at it")
        raise InputError(
            f"{source}: row {i + first_row}, column t: sampling is not uniform "
            f"(step {dt[i - 1]:g} s vs median {Ts:g} s); resample to a uniform grid "
            f"first, e.g. pandas DataFrame.resample or numpy.interp")
    return Ts


def _fill_gaps(
    arr: np.ndarray,
    missing: np.ndarray,
    name: str,
    source: str,
    first_row: int,
    notes: list[str],
) -> None:
    """Interpolate runs of NaN up to MAX_INTERPOLATED_GAP long, in place."""
    idx = np.flatnonzero(missing)
    # split into runs of consecutive indices
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[breaks + 1]]
    ends = np.r_[idx[breaks], idx[-1]]
    lengths = ends - starts + 1
    long_ = lengths > MAX_INTERPOLATED_GAP
    if long_.any():
        j = int(np.argmax(long_))
        raise InputError(
            f"{source}: row {starts[j] + first_row}, column {name}: gap of {lengths[j]} "
            f"missing values (at most {MAX_INTERPOLATED_GAP} are interpolated)"
        )
    if missing.all() or (~missing).sum() < 2:
        raise InputError(f"{source}: column {name} has no values")
    good = np.flatnonzero(~missing)
    arr[missing] = np.interp(idx, good, arr[good])
    notes.append(
        f"{source}: column {name}: interpolated {idx.size} missing values in "
        f"{starts.size} gap(s), first at row {starts[0] + first_row}"
    )
