"""Reading and writing Recordings: CSV, Parquet; atomic output files.

Every reader builds its Recording through :meth:`Recording.from_arrays`, so the same
validation rules apply whatever the format. Every writer goes through
:func:`atomic_path`: output appears complete or not at all.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .errors import InputError, user_warning
from .recording import MAX_INTERPOLATED_GAP, REQUIRED, SIGNALS, Recording

COLUMNS = ("t",) + SIGNALS


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is left untouched,
    so no half-written output is ever visible. An existing ``path`` that is not a regular
    file (``/dev/null``, a named pipe, a terminal) is written into, never replaced: the
    output is staged in a private temporary directory and copied there on success.
    """
    target = Path(path)
    if target.exists() and not target.is_file() and not target.is_dir():
        with tempfile.TemporaryDirectory(prefix="stictionbench-") as staging:
            staged = Path(staging) / (target.name or "output")
            yield staged
            with open(staged, "rb") as src, open(target, "wb") as dst:
                shutil.copyfileobj(src, dst)
        return
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; outputs are ordinary files
    try:
        yield Path(tmp)
        os.replace(tmp, target)
    except OSError as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise _named(exc, {tmp: target}) from None
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _named(exc: OSError, staged: dict) -> OSError:
    """``exc`` naming the user's output where it names a staging path or nothing (a full
    disk names no file; a first version said "No space left on device" alone, or named
    ``.summary.md.7w1tfhts.tmp``); an error about any other file is kept as it is."""
    where = {str(k): v for k, v in staged.items()}
    name = None if exc.filename is None else str(exc.filename)
    if name is not None and name not in where:
        for stage, target in where.items():  # a file inside a staging directory
            if name.startswith(stage + os.sep):
                return OSError(exc.errno, exc.strerror or str(exc),
                               str(Path(target) / os.path.relpath(name, stage)))
        return exc
    target = where[name] if name is not None else next(iter(where.values()))
    return OSError(exc.errno, exc.strerror or str(exc), str(target))


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield an empty staging directory; on success its files replace those in ``path``.

    Every file written under the staging directory is moved into ``path`` (same relative
    name) only after the ``with`` block ends without an exception; on any exception the
    staging directory is removed and ``path`` keeps its previous content. Files already in
    ``path`` that the block did not write are left alone, so a partial run (one table)
    never deletes the others. Each file is moved with :func:`os.replace`, so readers see
    old or new content, never a half-written file.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_directory(d / "out") as stage:
    ...     _ = (stage / "a.txt").write_text("x")
    >>> sorted(p.name for p in (d / "out").iterdir())
    ['a.txt']
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".staging",
                                  dir=target.parent))
    umask = os.umask(0)
    os.umask(umask)
    try:
        yield stage
        files = [src for src in sorted(stage.rglob("*")) if not src.is_dir()]
        for src in files:  # every conflict is found before the first file is moved
            dst = target / src.relative_to(stage)
            if dst.is_dir() or (target.exists() and not target.is_dir()):
                raise OSError(errno.EISDIR if dst.is_dir() else errno.ENOTDIR,
                              "Is a directory" if dst.is_dir() else "Not a directory",
                              str(dst if dst.is_dir() else target))
        for src in files:
            dst = target / src.relative_to(stage)
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.chmod(src, 0o666 & ~umask)
            os.replace(src, dst)
    except OSError as exc:
        raise _named(exc, {stage: target}) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)


#: the output name that means standard output (``--json -``, as Unix tools read it)
STDOUT = "-"

#: where an output named :data:`STDOUT` goes: the command line's standard output, which
#: :func:`stictionbench.cli.main` sets while it sends the command's own printing to
#: stderr (``None``: ``sys.stdout``)
stdout_stream: Any = None


def write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to ``path`` atomically (UTF-8); to standard output when ``path``
    is :data:`STDOUT` (``-``)."""
    if str(path) == STDOUT:
        import sys

        stream = stdout_stream or sys.stdout
        stream.write(text)
        stream.flush()
        return
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def check_input_file(path: str | os.PathLike[str], expected: str = "a recording file"
                     ) -> Path:
    """``path`` as a Path, or a one-line InputError when it is missing, a directory
    (the message names what was ``expected``) or empty."""
    p = Path(path)
    if not p.exists():
        raise InputError(f"{p}: no such file")
    if p.is_dir():
        raise InputError(f"{p}: is a directory, expected {expected}")
    if not p.is_file():  # a pipe, a device or a socket: not read (a read could block)
        raise InputError(f"{p}: not a regular file, expected {expected}")
    if p.stat().st_size == 0:
        raise InputError(f"{p}: empty file")
    return p


def read_recording(path: str | os.PathLike[str], *, warn: bool = True) -> Recording:
    """Read a Recording from a ``.csv`` or ``.parquet`` file.

    Parameters
    ----------
    path : path-like
        File with columns ``t, PV, OP`` and optionally ``SP``, ``MV``.
    warn : bool
        Print interpolation warnings on stderr.

    Raises
    ------
    InputError
        Missing path, directory, empty or binary file, missing columns, text in a
        numeric column, and every rule of :meth:`Recording.from_arrays`.
    """
    source, cols, first_row = _read_columns(path)
    return Recording.from_arrays(cols["t"], cols["PV"], cols["OP"], SP=cols.get("SP"),
                                 MV=cols.get("MV"), source=source, first_row=first_row,
                                 warn=warn)


def read_stretches(path: str | os.PathLike[str], *, warn: bool = True) -> list[Recording]:
    """Read a recording that may have long gaps: one Recording per usable stretch
    between gaps longer than the interpolation limit (:mod:`stictionbench.stretches`),
    the whole record when it has none.

    Raises
    ------
    InputError
        As :func:`read_recording`, and when no stretch is long enough.
    """
    from .stretches import split_at_gaps

    source, cols, first_row = _read_columns(path)
    return split_at_gaps(cols, source=source, first_row=first_row, warn=warn)


def read_longest_stretch(path: str | os.PathLike[str], *, warn: bool = True) -> Recording:
    """The longest usable stretch of a recording (:func:`read_stretches`); a warning on
    stderr names the rows used and the stretches left out, or the rows used when a long
    gap at the start or the end was cut off."""
    parts = read_stretches(path, warn=warn)
    best = max(parts, key=len)
    if len(parts) > 1 and warn:
        rows = best.meta["rows"]
        others = ", ".join(f"rows {r.meta['rows'][0]}–{r.meta['rows'][1]}"
                           for r in parts if r is not best)
        user_warning(f"{path}: gaps of more than {MAX_INTERPOLATED_GAP} missing samples cut "
                     f"the record into {len(parts)} usable stretches; using the longest, "
                     f"rows {rows[0]}–{rows[1]} ({len(best)} samples); not used: {others}")
    elif "rows" in best.meta and warn:  # one stretch: a long gap at the start or the end
        rows = best.meta["rows"]
        user_warning(f"{path}: using rows {rows[0]}–{rows[1]} ({len(best)} samples); the "
                     f"rows before or after them are a gap of more than "
                     f"{MAX_INTERPOLATED_GAP} missing samples")
    return best


def _read_columns(path: str | os.PathLike[str]) -> tuple[str, dict[str, Any], int]:
    """``(source, columns, first row)`` of a ``.csv`` or ``.parquet`` recording file."""
    p = check_input_file(path)
    suffix = p.suffix.lower()
    if suffix == ".parquet":
        return _read_parquet(p)
    if suffix in (".csv", ".txt", ""):
        return _read_csv(p)
    raise InputError(f"{p}: unknown format {suffix!r}; use .csv or .parquet")


def csv_frame(p: Path, nrows: int | None = None, fields: int = len(REQUIRED)
              ) -> tuple[pd.DataFrame, str]:
    """A CSV file as text cells (``nrows`` data rows; all when None), its delimiter
    sniffed from the header line (:func:`_delimiter`, a header of at least ``fields``
    names), a byte-order mark dropped and the column names stripped;
    ``(frame, delimiter)``."""
    head = p.read_bytes()[:4096]
    encoding = _text_encoding(head)
    if encoding is None:
        raise InputError(f"{p}: binary data, not a CSV text file")
    sep = _delimiter(head, encoding, fields)
    try:
        frame = pd.read_csv(p, sep=sep, dtype=str, keep_default_na=False, nrows=nrows,
                            skipinitialspace=True, encoding=encoding)
    except UnicodeError:
        what = "UTF-16" if encoding.startswith("utf-16") else "UTF-8"
        raise InputError(f"{p}: not {what} text, not a CSV file") from None
    except pd.errors.EmptyDataError:
        raise InputError(f"{p}: empty file") from None
    except pd.errors.ParserError as exc:
        raise InputError(f"{p}: not a valid CSV file ({str(exc).splitlines()[0]})") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    # pandas renames a repeated header name X to X.1, X.2: refuse the ambiguity instead
    # of reading one of the columns silently
    names = set(frame.columns)
    for c in frame.columns:
        base, dot, num = c.rpartition(".")
        if dot and num.isdigit() and base in names:
            raise InputError(f"{p}: column {base!r} appears more than once in the header")
    return frame, sep


def _read_csv(p: Path) -> tuple[str, dict[str, Any], int]:
    frame, sep = csv_frame(p)
    if sep != ",":
        # a CSV written with ';' or a tab is usually one with a decimal comma (the
        # spreadsheet export of a European locale): "1,5" is read as 1.5
        frame = frame.apply(lambda c: c.str.replace(r"^(\s*[-+]?\d*),(\d+\s*)$", r"\1.\2",
                                                    regex=True))
    return str(p), _frame_columns(frame, str(p), first_row=2, text=True), 2


def csv_columns(path: str | os.PathLike[str]) -> list[str] | None:
    """The header of a CSV file as :func:`read_recording` reads it (:func:`csv_frame`,
    names made canonical by :func:`_canonical_columns`), or None when it cannot be read
    as text or is ambiguous (:func:`read_recording` then gives the precise message)."""
    try:
        frame, _ = csv_frame(Path(path), nrows=0)
        return [str(c) for c in _canonical_columns(frame, str(path)).columns]
    except (InputError, OSError, ValueError):
        return None


#: status words a historian writes in place of a value (OSIsoft PI's system digital
#: states and their like in other historians' exports), compared without case: read as a
#: missing sample, like an empty cell, so the gap rules of :class:`Recording` apply
HISTORIAN_STATES = frozenset({
    "bad", "bad input", "bad data", "bad quality", "bad value", "i/o timeout",
    "comm fail", "calc failed", "calc timeout", "no data", "no sample", "not connected",
    "scan off", "scan timeout", "shutdown", "pt created", "over range", "under range",
    "out of service", "invalid data", "#n/a", "n/a"})

#: column delimiters recognised in a CSV's header line, in order of preference
DELIMITERS = (",", ";", "\t", "|")


def _text_encoding(head: bytes) -> str | None:
    """The encoding of a text file from its first bytes, or None when they are binary.

    UTF-16 is recognised by its byte-order mark (what a spreadsheet's "Unicode text"
    export writes, tab-separated) or, without one, by text with a NUL byte after
    (little-endian) or before (big-endian) every character (ASCII and Latin-1 text such
    as ``°C``); any other NUL byte is binary data. Everything else is read as UTF-8, a
    UTF-8 byte-order mark dropped.

    Examples
    --------
    >>> _text_encoding("t\\tPV\\tOP\\n".encode("utf-16")), _text_encoding(b"t,PV,OP\\n")
    ('utf-16', 'utf-8-sig')
    >>> _text_encoding("t,PV,OP\\n".encode("utf-16-le")), _text_encoding(bytes(range(9)))
    ('utf-16-le', None)
    """
    if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return "utf-16"
    if b"\x00" not in head:
        return "utf-8-sig"
    even = head[: len(head) // 2 * 2]
    for order, text, zeros in (("le", even[0::2], even[1::2]),
                               ("be", even[1::2], even[0::2])):
        if text and zeros == bytes(len(zeros)) and b"\x00" not in text:
            return f"utf-16-{order}"
    return None


def _delimiter(head: bytes, encoding: str = "utf-8", fields: int = len(REQUIRED)) -> str:
    """The delimiter of a CSV from its header line: the first of :data:`DELIMITERS` that
    splits it into at least ``fields`` fields (a recording's three, ``t``, ``PV``,
    ``OP``), else ``,``; ``head`` is decoded with ``encoding`` (:func:`_text_encoding`).

    Examples
    --------
    >>> _delimiter(b"t;SP;PV;OP\\n0;1,5;2;3\\n"), _delimiter(b"t,PV,OP\\n")
    (';', ',')
    """
    line = head.decode(encoding, errors="replace").lstrip("\ufeff").splitlines()[:1]
    for sep in DELIMITERS:
        if line and len(line[0].split(sep)) >= fields:
            return sep
    return ","


#: other names of the time column (compared without case)
TIME_ALIASES = ("time", "timestamp", "datetime", "date_time", "time_s", "t_s")
#: other names of the signals (compared without case): CO, the controller output, is the
#: paper's own name for OP
SIGNAL_ALIASES = {"co": "OP"}
#: a unit after a column's name, ``PV (degC)``, ``OP [%]``: not part of the name
_UNIT = re.compile(r"\s*(\([^()]*\)|\[[^\[\]]*\])\s*$")


def _column_key(name: str) -> str:
    """A column's name as matched: without a trailing unit, stripped, lower case."""
    return _UNIT.sub("", name).strip().lower()


def _canonical_columns(frame: pd.DataFrame, source: str) -> pd.DataFrame:
    """Rename columns that match a signal's name up to case (``pv``, ``Op``), with a unit
    after it (``PV (degC)``, ``OP [%]``), or an alias (:data:`TIME_ALIASES`,
    :data:`SIGNAL_ALIASES`) to the canonical ``t, SP, PV, OP, MV``; a name matched by two
    columns (``PV`` and ``pv``, ``t`` and ``time``) is an error, an exact name is never
    renamed."""
    names = [str(c) for c in frame.columns]
    wanted = {c.lower(): c for c in COLUMNS}
    wanted.update({a: "t" for a in TIME_ALIASES})
    wanted.update(SIGNAL_ALIASES)
    rename: dict[str, str] = {}
    for canon in COLUMNS:
        hits = [c for c in names if wanted.get(_column_key(c)) == canon]
        if canon in names and len(hits) == 1:
            continue
        if len(hits) > 1:
            raise InputError(f"{source}: columns {', '.join(hits)} could each be {canon}; "
                             f"rename one")
        if hits:
            rename[hits[0]] = canon
    return frame.rename(columns=rename) if rename else frame


def _read_parquet(p: Path) -> tuple[str, dict[str, Any], int]:
    try:
        frame = pd.read_parquet(p)
    except Exception as exc:  # pyarrow raises several types for corrupt files
        raise InputError(f"{p}: not a readable Parquet file ({type(exc).__name__})") from None
    return str(p), _frame_columns(frame, str(p), first_row=0, text=False), 0


def _frame_columns(frame: pd.DataFrame, source: str, *, first_row: int, text: bool
                   ) -> dict[str, Any]:
    frame = _canonical_columns(frame, source)
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise InputError(
            f"{source}: missing column(s) {', '.join(missing)}; found "
            f"{', '.join(map(str, frame.columns)) or 'none'}"
        )
    cols: dict[str, np.ndarray] = {}
    for name in COLUMNS:
        if name not in frame.columns:
            continue
        col = frame[name]
        if text:
            s = col.astype(str).str.strip()
            empty = s.isin(["", "nan", "NaN", "NA", "null", "None"]) | \
                s.str.lower().isin(HISTORIAN_STATES)
            num = pd.to_numeric(s.where(~empty, None), errors="coerce")
            bad = num.isna() & ~empty
            # date-times, unless most cells are numbers (then the rest are bad cells: a
            # second header part-way, a note at the end)
            if name == "t" and bad.any() and num.notna().sum() < bad.sum():
                stamps = _timestamps(s.where(~empty, None))
                if np.isfinite(stamps).any():  # date-times: name the first that is not one
                    bad = pd.Series(np.isnan(stamps) & ~empty.to_numpy())
                    if not bad.any():
                        cols[name] = stamps
                        continue
            if bad.any():
                i = int(np.argmax(bad.to_numpy()))
                raise InputError(
                    f"{source}: row {i + first_row}, column {name}: not a number"
                    f"{' or ISO 8601 date-time' if name == 't' else ''} "
                    f"({s.iloc[i][:20]!r})"
                )
            cols[name] = num.to_numpy(dtype=float)
        elif name == "t" and (pd.api.types.is_datetime64_any_dtype(col)
                              or isinstance(col.dtype, pd.DatetimeTZDtype)):
            stamps = _timestamps(col)
            if (np.isnan(stamps) & col.notna().to_numpy()).any():
                raise InputError(f"{source}: column t: timestamps not readable")
            cols[name] = stamps
        elif name == "t" and pd.api.types.is_timedelta64_dtype(col):
            # durations since the record's start: seconds, as a numeric t is
            cols[name] = col.dt.total_seconds().to_numpy(dtype=float)
        else:
            if pd.api.types.is_bool_dtype(col):  # as from CSV, where true/false is text
                raise InputError(f"{source}: column {name} holds true/false values, not "
                                 "numbers")
            try:
                cols[name] = pd.to_numeric(col, errors="raise").to_numpy(dtype=float)
            except (ValueError, TypeError):
                raise InputError(f"{source}: column {name} is not numeric") from None
    # an optional signal's column with no value at all (an export's empty SP or MV) is a
    # signal not recorded, not a gap that cuts the whole record
    for name in ("SP", "MV"):
        if name in cols and np.isnan(cols[name]).all():
            del cols[name]
    return cols


def _timestamps(col: pd.Series) -> np.ndarray:
    """Seconds since the first timestamp of a column of ISO 8601 date-times (text or
    datetime64); NaN where an entry is missing or not a date-time. Offsets such as
    ``+01:00`` are honoured (every stamp is converted to UTC, so a change of
    daylight-saving time in a record with offsets is no jump).

    Examples
    --------
    >>> _timestamps(pd.Series(["2024-06-09 09:57:00", "2024-06-09T09:57:10", None]))
    array([ 0., 10., nan])
    >>> _timestamps(pd.Series(["2024-06-09 09:57:00", "soon"]))
    array([ 0., nan])
    """
    try:
        stamps = pd.to_datetime(col, errors="coerce", format="ISO8601", utc=True)
    except (ValueError, TypeError):
        return np.full(len(col), np.nan)
    if stamps.isna().all():
        return np.full(len(col), np.nan)
    first = stamps[stamps.notna()].iloc[0]
    return (stamps - first).dt.total_seconds().to_numpy(dtype=float)


def write_recording(rec: Recording, path: str | os.PathLike[str]) -> Path:
    """Write a Recording to ``.csv`` or ``.parquet`` atomically.

    CSV is written with shortest round-trip float formatting so that a
    reloaded Recording is bit-identical. Returns the path written.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".parquet"):
        raise InputError(f"{p}: unknown output format {suffix!r}; use .csv or .parquet")
    frame = rec.to_frame()
    with atomic_path(p) as tmp:
        if suffix == ".csv":
            frame.to_csv(tmp, index=False, lineterminator="\n")
        else:
            frame.to_parquet(tmp, index=False)
    return p
