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
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .errors import InputError, user_warning
from .recording import REQUIRED, SIGNALS, Recording
from .stretches import FAULTS

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
    source, cols, first_row = _read_columns(path, warn=warn)
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

    source, cols, first_row = _read_columns(path, warn=warn)
    return split_at_gaps(cols, source=source, first_row=first_row, warn=warn)


def read_longest_stretch(path: str | os.PathLike[str], *, warn: bool = True) -> Recording:
    """The longest usable stretch of a recording (:func:`read_stretches`); a warning on
    stderr names the rows used and the stretches left out, or the rows used when a long
    gap at the start or the end was cut off."""
    from .stretches import longest_stretch

    return longest_stretch(read_stretches(path, warn=warn), str(path), warn)


def _read_columns(path: str | os.PathLike[str], *, warn: bool = True
                  ) -> tuple[str, dict[str, Any], int]:
    """``(source, columns, first row)`` of a ``.csv`` or ``.parquet`` recording file."""
    p = check_input_file(path)
    suffix = p.suffix.lower()
    if suffix == ".parquet":
        return _read_parquet(p, warn=warn)
    if suffix in CSV_SUFFIXES + ("",):
        return _read_csv(p, warn=warn)
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
    # index_col=False: a delimiter at the end of every data row (not of the header) is
    # an empty last field, not a first column that pandas would make the index
    kw = dict(sep=sep, dtype=str, keep_default_na=False, nrows=nrows,
              skipinitialspace=True, index_col=False)
    try:
        try:
            frame = _read_fields(p, encoding, kw)
        except UnicodeError:
            if encoding.startswith("utf-16"):
                raise
            # not UTF-8: a Windows spreadsheet's export ("PV (°C)" in code page 1252)
            frame = _read_fields(p, "cp1252", kw)
    except UnicodeError:
        what = "UTF-16" if encoding.startswith("utf-16") else "UTF-8 or Windows-1252"
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
    # rows with every cell empty at the end: what a spreadsheet writes below its data
    last = len(frame)
    while last > 0 and all(not str(v).strip() for v in frame.iloc[last - 1]):
        last -= 1
    if last < len(frame):
        frame = frame.iloc[:last]
    return frame, sep


def _read_fields(p: Path, encoding: str, kw: dict[str, Any]) -> pd.DataFrame:
    """``pandas.read_csv`` of a CSV whose data rows may end in delimiters the header does
    not: the empty fields after the named ones are dropped; a value there is refused
    (which column would it be?)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", pd.errors.ParserWarning)
        try:
            return pd.read_csv(p, encoding=encoding, **kw)
        except pd.errors.ParserWarning:  # more fields in a row than names in the header
            names = pd.read_csv(p, encoding=encoding, **{**kw, "nrows": 0}).columns
    raw = pd.read_csv(p, encoding=encoding, header=None, skiprows=1,
                      **{k: v for k, v in kw.items() if k != "index_col"})
    extra = raw.iloc[:, len(names):]
    if (extra.apply(lambda c: c.str.strip()) != "").to_numpy().any():
        raise InputError(f"{p}: data rows have more fields than the header has names; "
                         f"name every column")
    frame = raw.iloc[:, :len(names)]
    frame.columns = names
    return frame


def _read_csv(p: Path, *, warn: bool = True) -> tuple[str, dict[str, Any], int]:
    frame, sep = csv_frame(p)
    frame = _canonical_columns(frame, str(p))
    frame = numbers_as_written(frame, sep, [c for c in COLUMNS if c in frame.columns],
                               str(p))
    return str(p), _frame_columns(frame, str(p), first_row=2, text=True, warn=warn), 2


#: a number written with a thousands separator ``,`` or ``.`` (``1,003``, ``12.500,5``)
_GROUPED = {k: re.compile(rf"[-+]?[1-9]\d{{0,2}}(\{k}\d{{3}})+(\{d}\d+)?")
            for k, d in ((",", "."), (".", ","))}
#: a number with a decimal mark ``.`` or ``,`` (and an exponent)
_DECIMAL = {m: re.compile(rf"[-+]?\d*\{m}\d+([eE][-+]?\d+)?") for m in ".,"}


def _jumps(values: np.ndarray) -> int:
    """How many neighbouring samples differ by a factor of more than 100 (a number read
    with the wrong decimal mark is a thousand times too large or too small)."""
    a = np.abs(values[np.isfinite(values) & (values != 0)])
    return int((np.abs(np.diff(np.log10(a))) > 2).sum()) if a.size > 1 else 0


def numbers_as_written(frame: pd.DataFrame, sep: str, columns: list[str], source: str
                       ) -> pd.DataFrame:
    """Text cells of ``columns`` with their decimal mark made ``.`` and thousands
    separators removed, the marks read from the file itself.

    A cell such as ``40.25`` or ``0,998`` shows the file's decimal mark (the other mark
    is then a thousands separator: ``1,234.5``, ``1.234,5``); a file showing both is
    refused. When no cell shows it (``1,003`` beside ``999``: 1.003 or 1003?) the file
    takes the reading under which its columns' neighbouring samples jump by a factor of
    a thousand less often, one mark for every column, and on a tie the locale's: a
    decimal comma in a ``;`` or tab separated file with a comma in it (a European
    spreadsheet's export), else a point. A ``,`` separated file without a comma inside a
    cell is read as written.

    Raises
    ------
    InputError
        Both marks used as decimal marks in one file.

    Examples
    --------
    >>> f = pd.DataFrame({"PV": ["999", "1,003", "1,001"], "OP": ["40.5", "41", "40"]})
    >>> numbers_as_written(f, "\t", ["PV", "OP"], "x")["PV"].tolist()
    ['999', '1003', '1001']
    >>> f = pd.DataFrame({"PV": ["1.006", "5,5"], "OP": ["40", "41,25"]})
    >>> numbers_as_written(f, ";", ["PV", "OP"], "x")["PV"].tolist()
    ['1006', '5.5']
    >>> f = pd.DataFrame({"PV": ["999", "1,000"], "OP": ["50.000", "49.975"]})
    >>> numbers_as_written(f, "\t", ["PV", "OP"], "x").to_numpy().tolist()
    [['999', '50.000'], ['1000', '49.975']]
    >>> f = pd.DataFrame({"PV": ["990", "998", "1.000", "1.003"]})  # no comma at all
    >>> numbers_as_written(f, ";", ["PV"], "x")["PV"].tolist()
    ['990', '998', '1000', '1003']
    """
    cells = {c: frame[c].astype(str).str.strip() for c in columns}
    commas = any("," in "".join(s.tolist()) for s in cells.values())
    if not commas and (sep == "," or not any(s.str.fullmatch(_GROUPED["."]).any()
                                             for s in cells.values())):
        return frame  # numbers as pandas reads them, a point the decimal mark

    def shown(mark: str) -> str | None:
        other = "," if mark == "." else "."
        for s in cells.values():
            hit = (s.str.fullmatch(_DECIMAL[mark]) & ~s.str.fullmatch(_GROUPED[mark])) | \
                s.str.fullmatch(_GROUPED[other]) & s.str.contains(mark, regex=False)
            if hit.any():
                return str(s[hit].iloc[0])
        return None

    def read(s: pd.Series, mark: str) -> pd.Series:
        group = "," if mark == "." else "."
        text = s.where(~s.str.fullmatch(_GROUPED[group]), s.str.replace(group, "", regex=False))
        return text.str.replace(",", ".", regex=False) if mark == "," else text

    point, comma = shown("."), shown(",")
    if point is not None and comma is not None:
        raise InputError(f"{source}: numbers written with a decimal point ({point!r}) and "
                         f"with a decimal comma ({comma!r}); export the file with one")
    if point is not None or comma is not None:
        mark = "." if point is not None else ","
    else:  # one mark for the whole file: the reading whose samples do not jump
        default = "," if sep != "," and commas else "."
        other = "." if default == "," else ","
        jumps = {m: sum(_jumps(pd.to_numeric(read(s, m), errors="coerce")
                               .to_numpy(dtype=float)) for s in cells.values())
                 for m in (default, other)}
        mark = other if jumps[other] < jumps[default] else default
    out = frame.copy()
    for c, s in cells.items():
        out[c] = read(s, mark)
    return out


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
    "out of service", "invalid data", "#n/a", "n/a", "intf shut", "arc off-line",
    "configure", "no good data for calculation", "null", "none", "nan"})
#: the words of :data:`HISTORIAN_STATES` that say no value was written, not that a value
#: was bad (compared without case)
NO_VALUE = frozenset({"null", "none", "nan"})
#: a PI error code before its text, ``[-11059] No Good Data For Calculation``
_ERROR_CODE = r"^\[-?\d+\]"

#: the suffixes of CSV text files (compared without case; a historian's export is often
#: ``.txt``, a Windows one ``.CSV``)
CSV_SUFFIXES = (".csv", ".txt", ".tsv")

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
#: paper's own name for OP; SV (set value) is Yokogawa's name for the set point
SIGNAL_ALIASES = {"co": "OP", "setpoint": "SP", "set point": "SP", "set_point": "SP",
                  "set-point": "SP", "sv": "SP"}
#: a unit after a column's name, ``PV (degC)``, ``OP [%]``: not part of the name
_UNIT = re.compile(r"\s*(\([^()]*\)|\[[^\[\]]*\])\s*$")
#: a historian tag before a signal's name: ``FIC101.PV``, ``2111FIC51001:SP``,
#: ``LYCDU.FIC10112/OP`` (a tag: no space, letters and a digit; ``Max.SP``, ``Alarm SP``,
#: ``PV/SP`` are no tags)
_TAGGED = re.compile(r"^(?P<tag>(?=[^ ]*\d)(?=[^ ]*[a-z])[^ ]+?)[.:/](?P<signal>[a-z]+)$")
#: a column that looks like a set point (named in a warning when no column is read as SP)
_SP_LIKE = re.compile(r"(^|[^a-z])(sp|sv|spt|set.?point|set.?value|target)([^a-z]|$)")


def _column_key(name: str) -> str:
    """A column's name as matched: without a trailing unit, stripped, lower case."""
    return _UNIT.sub("", name).strip().lower()


def _canonical_columns(frame: pd.DataFrame, source: str) -> pd.DataFrame:
    """Rename columns that match a signal's name up to case (``pv``, ``Op``), with a unit
    after it (``PV (degC)``, ``OP [%]``), or an alias (:data:`TIME_ALIASES`,
    :data:`SIGNAL_ALIASES`) to the canonical ``t, SP, PV, OP, MV``; a name matched by two
    columns (``PV`` and ``pv``, ``t`` and ``time``) is an error, an exact name is never
    renamed. A signal no column names so is looked for after a historian tag
    (``FIC101.PV``, ``FIC101:SP``), the tag the same for every signal so found and PV or
    OP among them, or in the file's name: a file of two loops' tags is refused, and
    another loop's tagged SP beside untagged PV and OP is not read (a warning names it).

    Examples
    --------
    >>> f = pd.DataFrame(columns=["Time", "FIC101.PV", "FIC101.OP", "FIC101.SP [m3/h]"])
    >>> list(_canonical_columns(f, "x").columns)
    ['t', 'PV', 'OP', 'SP']
    >>> list(_canonical_columns(pd.DataFrame(columns=["t", "PV", "OP", "SV"]), "x").columns)
    ['t', 'PV', 'OP', 'SP']
    """
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
    found = set(rename.values()) | {c for c in names if c in COLUMNS}
    tagged: dict[str, list[tuple[str, str]]] = {}
    for c in names:
        m = _TAGGED.match(_column_key(c))
        canon = wanted.get(m["signal"]) if m and c not in rename else None
        if canon and canon != "t" and canon not in found:
            tagged.setdefault(canon, []).append((c, m["tag"]))
    tags = {tag for hits in tagged.values() for _, tag in hits}
    stem = Path(source).stem.lower()
    if not {"PV", "OP"} & set(tagged) and not all(t in stem for t in tags):
        # a tagged SP or MV beside untagged PV and OP: the loop's own only when its tag is
        # in the file's name (FIC51001.SP in 2111FIC51001_0610.csv), else whose is it?
        tagged = {}
    for canon, hits in tagged.items():
        if len(hits) > 1 or len(tags) > 1:
            shown = ", ".join(c for hs in tagged.values() for c, _ in hs)
            raise InputError(f"{source}: columns {shown} are the signals of more than one "
                             f"loop; give one loop per file, its columns named t, PV, OP, SP")
        rename[hits[0][0]] = canon
    return frame.rename(columns=rename) if rename else frame


def _unread_setpoint(columns: list[str]) -> str | None:
    """A column that looks like a set point, when none is read as SP."""
    if "SP" in columns:
        return None
    return next((c for c in columns if c not in COLUMNS
                 and _SP_LIKE.search(_column_key(c))), None)


def _read_parquet(p: Path, *, warn: bool = True) -> tuple[str, dict[str, Any], int]:
    try:
        frame = pd.read_parquet(p)
    except Exception as exc:  # pyarrow raises several types for corrupt files
        raise InputError(f"{p}: not a readable Parquet file ({type(exc).__name__})") from None
    frame = _canonical_columns(frame, str(p))
    return str(p), _frame_columns(frame, str(p), first_row=0, text=False, warn=warn), 0


def _frame_columns(frame: pd.DataFrame, source: str, *, first_row: int, text: bool,
                   warn: bool = True) -> dict[str, Any]:
    unread = _unread_setpoint([str(c) for c in frame.columns])
    if unread is not None and warn:
        user_warning(f"{source}: column {unread!r} is not read as the set point; name it "
                     f"SP to use it")
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise InputError(
            f"{source}: missing column(s) {', '.join(missing)}; found "
            f"{', '.join(map(str, frame.columns)) or 'none'}"
        )
    cols: dict[str, Any] = {}
    faults: dict[str, np.ndarray] = {}
    for name in COLUMNS:
        if name not in frame.columns:
            continue
        col = frame[name]
        if text:
            s = col.astype(str).str.strip()
            num = pd.to_numeric(s, errors="coerce")
            # the words are looked for among the cells that are no number (few, or none)
            words = num.isna().to_numpy()
            fault = np.zeros(len(s), bool)
            empty = np.zeros(len(s), bool)
            if words.any():
                w = s[words]
                low = w.str.lower()
                # a fault the historian wrote (Bad, I/O Timeout): a sample known to be
                # bad, never a value left out because it did not change
                # (stretches.hold_on_change)
                fault[words] = (low.isin(HISTORIAN_STATES - NO_VALUE)
                                | w.str.contains(_ERROR_CODE, regex=True)).to_numpy()
                empty[words] = (w.isin(["", "NA"]) | low.isin(NO_VALUE)).to_numpy()
            empty |= fault
            if fault.any() and name in ("PV", "OP", "MV"):
                faults[name] = fault
            empty = pd.Series(empty, index=s.index)
            num = num.where(~empty)
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
            faults.pop(name, None)
    if faults:
        cols[FAULTS] = faults
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
