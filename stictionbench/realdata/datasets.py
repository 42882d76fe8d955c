"""Loaders for real loop data: ISDB MATLAB files, folders of CSV files, label tables.

Three layouts are read in place (nothing is copied):

- the International Stiction Data Base (ISDB) MATLAB struct ``cdata.<sector>.loopN``
  with fields ``PV, OP, SP, Ts`` (and ``t``, ``Comments``, ``BriefComments``, ``Type``)
  — :func:`load_isdb_mat`, one :class:`~stictionbench.recording.Recording` per loop;
- the OP-only oscillation benchmark ``benchmark.<sector>.loopN`` with ``OP, Ts`` and an
  ``oscillation`` flag — :func:`load_oscillation_benchmark`, one :class:`OscillationLoop`
  per loop (there is no PV, so it is not a Recording);
- a folder of ``t, [SP,] PV, OP`` CSV files with an optional ``labels.csv`` —
  :func:`load_csv_dir` and :func:`read_labels`.

:func:`read_any` reads one file of any supported format (``.csv``, ``.parquet``, ``.mat``).

Loops are named as in the book: sector prefix and loop number (``chemicals.loop10`` →
``CHEM10``), so that names match ``isdb/labels.csv``.

References
----------
M. Jelali, B. Huang (eds.), *Detection and Diagnosis of Stiction in Control Loops: State
of the Art and Advanced Methods*, Springer, London 2010 (the ISDB and its MATLAB layout).
"""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from ..errors import InputError, user_warning
from ..io import CSV_SUFFIXES, check_input_file, csv_columns, csv_frame, read_stretches
from ..recording import REQUIRED, Recording
from ..stretches import longest_stretch, split_at_gaps

#: ISDB sector field -> loop-name prefix used in the book (Jelali & Huang 2010)
SECTOR_PREFIX = {
    "buildings": "BAS",
    "chemicals": "CHEM",
    "pulpPapers": "PAP",
    "power": "POW",
    "mining": "MIN",
    "metals": "MET",
    "test": "TEST",
}

#: fields of an ISDB loop that hold text
_TEXT_FIELDS = ("Comments", "BriefComments", "comments", "Type", "type")
#: names under which the OP-only benchmark stores its oscillation flag
_FLAG_FIELDS = ("oscillation", "Oscillation", "Type")

Skipped = list[tuple[str, str]]


# --------------------------------------------------------------------------- types
@dataclass(frozen=True, eq=False)
class OscillationLoop:
    """One loop of the OP-only oscillation benchmark.

    Attributes
    ----------
    name : str
        Book-style name, e.g. ``"CHEM10"``.
    sector : str
        Sector field of the MATLAB struct (``"chemicals"``, ...).
    loop : str
        Loop field (``"loop10"``).
    Ts : float
        Sample time in seconds.
    op : ndarray
        Controller output (read-only float array).
    flag : int
        ``1``: the loop oscillates, ``0``: it does not (the benchmark's ground truth).
    flag_field : str
        Field the flag was read from (``"oscillation"``; one loop of the published file
        stores it as ``"Type"``).
    """

    name: str
    sector: str
    loop: str
    Ts: float
    op: np.ndarray
    flag: int
    flag_field: str = "oscillation"
    meta: Mapping[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.op.size)

    def as_recording(self, *, warn: bool = False) -> Recording:
        """The OP as a :class:`Recording` with ``PV`` set to a copy of ``OP``.

        ``meta["op_only"]`` is ``True`` so that PV-based checks know there is no PV.

        Raises
        ------
        InputError
            From :meth:`Recording.from_arrays` (e.g. fewer than 100 samples).
        """
        t = np.arange(self.op.size, dtype=float) * self.Ts
        meta = {"name": self.name, "sector": self.sector, "loop": self.loop,
                "oscillation": self.flag, "op_only": True, **dict(self.meta)}
        return Recording.from_arrays(t, self.op, self.op, meta=meta,
                                     source=str(self.meta.get("source", self.name)), warn=warn)


# --------------------------------------------------------------------------- MATLAB
def _loadmat(path: str | os.PathLike[str]) -> dict[str, Any]:
    """``scipy.io.loadmat`` with one-line errors."""
    from scipy.io import loadmat

    p = check_input_file(path, "a .mat file")
    try:
        return loadmat(p, squeeze_me=True, struct_as_record=False)
    except NotImplementedError:
        raise InputError(
            f"{p}: MATLAB v7.3 (HDF5) files are not supported; save with -v7 in MATLAB"
        ) from None
    except Exception as exc:  # scipy raises ValueError, TypeError, OSError... on bad files
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{p}: not a readable MATLAB file ({msg[:80]})") from None


def _is_struct(v: Any) -> bool:
    return hasattr(v, "_fieldnames")


def _unwrap(v: Any) -> Any:
    """A 1×1 struct array or object array → its element."""
    if isinstance(v, np.ndarray) and v.dtype == object and v.size == 1:
        return v.reshape(-1)[0]
    return v


def _fields(s: Any) -> list[str]:
    return list(getattr(s, "_fieldnames", []) or [])


def _loop_sort_key(name: str) -> tuple[str, int]:
    m = re.match(r"(.*?)(\d+)$", name)
    return (m.group(1), int(m.group(2))) if m else (name, -1)


def _book_name(sector: str, loop: str) -> str:
    prefix = SECTOR_PREFIX.get(sector, sector)
    m = re.search(r"(\d+)$", loop)
    return f"{prefix}{m.group(1)}" if m else f"{prefix}_{loop}"


def _iter_loops(root: Any) -> Iterable[tuple[str, str, Any]]:
    """Yield ``(sector, loop, struct)`` for every ``root.<sector>.<loop>``."""
    for sector in _fields(root):
        sec = _unwrap(getattr(root, sector))
        if not _is_struct(sec):
            continue
        for loop in sorted(_fields(sec), key=_loop_sort_key):
            ls = _unwrap(getattr(sec, loop))
            if _is_struct(ls):
                yield sector, loop, ls


def _find_root(data: Mapping[str, Any], path: Path, var: str | None) -> tuple[str, Any]:
    """The top-level struct holding sectors of loops; ``var`` names it explicitly."""
    names = [k for k in data if not k.startswith("__")]
    if var is not None:
        if var not in data:
            raise InputError(f"{path}: no variable {var!r}; found {', '.join(names) or 'none'}")
        cand = [var]
    else:
        cand = names
    for name in cand:
        root = _unwrap(data[name])
        if _is_struct(root) and any(True for _ in _iter_loops(root)):
            return name, root
    raise InputError(
        f"{path}: no struct of the form <var>.<sector>.loopN found "
        f"(variables: {', '.join(names) or 'none'})"
    )


def _array(v: Any) -> np.ndarray | None:
    """A numeric field as a 1-D float array; ``None`` when empty or absent."""
    if v is None:
        return None
    try:
        a = np.asarray(v, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        return None
    return a if a.size else None


def _text(v: Any) -> str:
    """A MATLAB char array / cell array of strings as one string."""
    if v is None:
        return ""
    if isinstance(v, str):
        return v.strip()
    if isinstance(v, np.ndarray):
        if v.dtype.kind in "US":
            return " ".join(str(x).strip() for x in v.reshape(-1))
        if v.dtype == object:
            return " ".join(_text(x) for x in v.reshape(-1)).strip()
        if v.size == 0:
            return ""
    if isinstance(v, (int, float, np.number)):
        return str(v.item() if isinstance(v, np.generic) else v)
    return str(v).strip()


def _scalar(v: Any) -> float | None:
    a = _array(v)
    return float(a[0]) if a is not None and a.size == 1 and np.isfinite(a[0]) else None


def scan_isdb_mat(
    path: str | os.PathLike[str], *, var: str | None = None, warn: bool = True
) -> tuple[dict[str, Recording], Skipped]:
    """Read every loop of an ISDB-layout ``.mat`` file, collecting the loops that fail.

    Like :func:`load_isdb_mat` but never raises for a single loop: loops without PV or
    OP, without a sample time or rejected by :meth:`Recording.from_arrays` are returned
    in ``skipped`` as ``(name, reason)``.

    Returns
    -------
    recordings : dict
        Book-style name (``"CHEM10"``) → Recording.
    skipped : list of (str, str)
    """
    p = Path(path)
    data = _loadmat(p)
    varname, root = _find_root(data, p, var)
    recs: dict[str, Recording] = {}
    skipped: Skipped = []
    for sector, loop, ls in _iter_loops(root):
        name = _book_name(sector, loop)
        where = f"{p}:{varname}.{sector}.{loop}"
        fields = _fields(ls)
        matrix = next((f"{f} is a {' × '.join(map(str, np.shape(v)))} array, not a vector"
                       if np.ndim(v) >= 2 else f"{f} holds complex numbers"
                       for f in ("PV", "OP", "SP", "t")
                       if (v := getattr(ls, f, None)) is not None
                       and ((np.ndim(v) >= 2 and sorted(np.shape(v))[-2] > 1)
                            or np.iscomplexobj(v))), None)
        if matrix is not None:  # a time column beside the values, or several signals
            skipped.append((name, f"{where}: {matrix}; give one signal per field"))
            continue
        pv = _array(getattr(ls, "PV", None))
        op = _array(getattr(ls, "OP", None))
        if pv is None or op is None:
            missing = [s for s, a in (("PV", pv), ("OP", op)) if a is None]
            skipped.append((name, f"{where}: no {' or '.join(missing)} "
                                  f"(fields: {', '.join(fields)})"))
            continue
        sp = _array(getattr(ls, "SP", None))
        if sp is not None and sp.size != op.size:
            if warn:
                user_warning(f"{where}: SP has {sp.size} samples and OP {op.size}; SP is "
                             "not used")
            sp = None
        Ts = _scalar(getattr(ls, "Ts", None))
        if Ts is None:
            t_raw = _array(getattr(ls, "t", None))
            if t_raw is not None and t_raw.size == op.size and t_raw.size > 1:
                Ts = float(np.median(np.diff(t_raw)))
        if Ts is None or not Ts > 0:
            skipped.append((name, f"{where}: no valid sample time Ts"))
            continue
        # ISDB time vectors are missing or in other units for some loops: use k·Ts.
        t = np.arange(op.size, dtype=float) * Ts
        meta: dict[str, Any] = {"name": name, "sector": sector, "loop": loop,
                                "dataset": "ISDB", "Ts_declared": Ts}
        for f in _TEXT_FIELDS:
            if f in fields:
                meta[f.lower()] = _text(getattr(ls, f))
        try:
            # gaps (NaN) handled as in a CSV: cut at long ones, the longest stretch kept
            parts = split_at_gaps({"t": t, "PV": pv, "OP": op, "SP": sp}, source=where,
                                  first_row=0, warn=warn, meta=meta)
        except InputError as exc:
            skipped.append((name, str(exc)))
            continue
        recs[name] = longest_stretch(parts, where, warn)
    return recs, skipped


def load_isdb_mat(
    path: str | os.PathLike[str], *, var: str | None = None, errors: str = "raise",
    warn: bool = True,
) -> dict[str, Recording]:
    """Load an ISDB-style MATLAB file ``<var>.<sector>.loopN`` as Recordings.

    Each loop needs fields ``PV``, ``OP`` and ``Ts``; ``SP`` is kept when present and of
    the same length, text fields (``Comments``, ``BriefComments``, ``Type``) go to
    ``meta`` in lower case, with ``sector``, ``loop`` and the book-style ``name``. Time
    is rebuilt as ``t = k·Ts``.

    Parameters
    ----------
    path : path-like
        A MATLAB v5/v7 ``.mat`` file (read with ``scipy.io.loadmat(squeeze_me=True,
        struct_as_record=False)``).
    var : str, optional
        Top-level variable (``"cdata"`` in the ISDB); default: the first struct of
        sectors of loops.
    errors : {"raise", "skip"}
        What to do with a loop that cannot be loaded: raise :class:`InputError`, or drop
        it with a warning on stderr (use :func:`scan_isdb_mat` to get the reasons).
    warn : bool
        Print interpolation warnings of :meth:`Recording.from_arrays`.

    Returns
    -------
    dict
        Book-style name (``"CHEM10"``) → Recording, in file order.

    Raises
    ------
    InputError
        Unreadable or non-MATLAB file, MATLAB v7.3, no struct of loops, an OP-only file
        (see :func:`load_oscillation_benchmark`), or — with ``errors="raise"`` — a bad loop.

    References
    ----------
    M. Jelali, B. Huang (eds.), *Detection and Diagnosis of Stiction in Control Loops*,
    Springer 2010, chapter 13 and appendix (the ISDB).

    Examples
    --------
    >>> import numpy as np, scipy.io, tempfile, os
    >>> k = np.arange(200.0)
    >>> loop = {"PV": np.sin(k / 9), "OP": np.cos(k / 9), "SP": 0 * k, "Ts": 2.0,
    ...         "Comments": "flow loop"}
    >>> f = os.path.join(tempfile.mkdtemp(), "isdb.mat")
    >>> scipy.io.savemat(f, {"cdata": {"chemicals": {"loop1": loop}}})
    >>> recs = load_isdb_mat(f)
    >>> list(recs), recs["CHEM1"].Ts, recs["CHEM1"].meta["comments"]
    (['CHEM1'], 2.0, 'flow loop')
    """
    if errors not in ("raise", "skip"):
        raise InputError(f"errors={errors!r}: use 'raise' or 'skip'")
    recs, skipped = scan_isdb_mat(path, var=var, warn=warn)
    if skipped and not recs and all(" no PV" in r for _, r in skipped):
        raise InputError(f"{path}: loops have OP but no PV; this looks like the OP-only "
                         f"oscillation benchmark — use load_oscillation_benchmark")
    if skipped:
        if errors == "raise":
            raise InputError(skipped[0][1])
        for _, reason in skipped:
            user_warning(f"skipped {reason}")
    return recs


def load_oscillation_benchmark(
    path: str | os.PathLike[str], *, var: str | None = None
) -> list[OscillationLoop]:
    """Load the OP-only oscillation benchmark ``benchmark.<sector>.loopN``.

    Every loop has ``OP``, ``Ts`` and an oscillation flag (``oscillation``; one loop
    of the published file, ``chemicals.loop16``, names it ``Type``).

    Parameters
    ----------
    path : path-like
        MATLAB v5/v7 file.
    var : str, optional
        Top-level variable (``"benchmark"``); default: the first struct of loops.

    Returns
    -------
    list of OscillationLoop
        In file order (sector, then loop number).

    Raises
    ------
    InputError
        Unreadable file, no struct of loops, or a loop without ``OP``, ``Ts`` or flag.

    References
    ----------
    M. Jelali, B. Huang (eds.), *Detection and Diagnosis of Stiction in Control Loops*,
    Springer 2010 (the 93 loops of the book; OP and oscillation labels).

    Examples
    --------
    >>> import numpy as np, scipy.io, tempfile, os
    >>> f = os.path.join(tempfile.mkdtemp(), "bench.mat")
    >>> op = np.sin(np.arange(300) / 5)
    >>> scipy.io.savemat(f, {"benchmark": {"power": {"loop1": {"OP": op, "Ts": 5,
    ...                                                        "oscillation": 1}}}})
    >>> [(lp.name, lp.Ts, lp.flag, len(lp)) for lp in load_oscillation_benchmark(f)]
    [('POW1', 5.0, 1, 300)]
    """
    p = Path(path)
    data = _loadmat(p)
    varname, root = _find_root(data, p, var)
    out: list[OscillationLoop] = []
    for sector, loop, ls in _iter_loops(root):
        name = _book_name(sector, loop)
        where = f"{p}:{varname}.{sector}.{loop}"
        fields = _fields(ls)
        op = _array(getattr(ls, "OP", None))
        if op is None:
            raise InputError(f"{where}: no OP (fields: {', '.join(fields)})")
        Ts = _scalar(getattr(ls, "Ts", None))
        if Ts is None or not Ts > 0:
            raise InputError(f"{where}: no valid sample time Ts")
        flag_field = next((f for f in _FLAG_FIELDS if f in fields), None)
        flag = None if flag_field is None else _scalar(getattr(ls, flag_field))
        if flag is None or flag not in (0.0, 1.0):
            raise InputError(f"{where}: no 0/1 oscillation flag (fields: {', '.join(fields)})")
        op = op.copy()
        op.setflags(write=False)
        out.append(OscillationLoop(name=name, sector=sector, loop=loop, Ts=Ts, op=op,
                                   flag=int(flag), flag_field=flag_field,
                                   meta=MappingProxyType({"source": where})))
    return out


def is_oscillation_benchmark(path: str | os.PathLike[str]) -> bool:
    """True when a ``.mat`` file's loops have ``OP`` but no ``PV`` (the OP-only layout)."""
    p = Path(path)
    data = _loadmat(p)
    _, root = _find_root(data, p, None)
    loops = [ls for _, _, ls in _iter_loops(root)]
    return bool(loops) and all("PV" not in _fields(ls) and "OP" in _fields(ls)
                               for ls in loops)


# --------------------------------------------------------------------------- CSV
def read_labels(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a labels table keyed by ``loop``.

    Parameters
    ----------
    path : path-like
        CSV with a ``loop`` column (``isdb/labels.csv``, ``plant/labels.csv``).

    Returns
    -------
    DataFrame
        Indexed by ``loop`` (as str); column ``group`` is the physical loop when the
        table has one (windows of one group are not independent), else equal to ``loop``.

    Raises
    ------
    InputError
        Missing or unreadable file, no ``loop`` column, duplicate loops.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: no such file")
    # read as recordings are (io.csv_frame): ';' or tab separated, UTF-8 or UTF-16 (a
    # spreadsheet's export), a byte-order mark; a first version took ',' and UTF-8 only
    frame, _ = csv_frame(p, fields=2)  # loop, label
    df = frame.apply(lambda c: c.str.strip()).replace("", np.nan)
    for c in df.columns:  # numbers as numbers (a labels table's Ts, n, held_frac, ...)
        if c not in ("loop", "group", "label"):
            num = pd.to_numeric(df[c], errors="coerce")
            if num.notna().sum() == df[c].notna().sum():
                df[c] = num
    if "loop" not in df.columns:
        raise InputError(f"{p}: labels need a 'loop' column; found {', '.join(df.columns)}")
    if "label" not in df.columns:
        raise InputError(f"{p}: labels need a 'label' column (stiction, or the loop's "
                         f"other class); found {', '.join(df.columns)}")
    df["label"] = df["label"].map(lambda v: _label(v, p), na_action="ignore")
    df["loop"] = df["loop"].astype(str).str.strip()
    dup = df["loop"][df["loop"].duplicated()]
    if not dup.empty:
        raise InputError(f"{p}: loop {dup.iloc[0]!r} appears more than once")
    if "group" not in df.columns:
        df["group"] = df["loop"]
    else:
        df["group"] = df["group"].fillna(df["loop"]).astype(str)
    return df.set_index("loop", drop=False).rename_axis(None)


#: labels that say yes or no without saying to what (refused: a 1 or a "yes" would be
#: scored as no stiction, since only ``stiction`` is)
_YES_NO = frozenset({"true", "false", "yes", "no", "y", "n", "t", "f"})


def _label(value: Any, path: Path) -> str:
    """A label as scored: case, spaces and hyphens normalised (``Stiction`` and
    ``no stiction`` are ``stiction`` and ``no_stiction``); a label that mentions
    stiction otherwise (``sticky valve?``, ``stiction suspected``) is refused as
    ambiguous, since anything but ``stiction`` is scored as no stiction (the ISDB's
    classes ``deadzone+tight_tuning``, ``disturbance`` and the like); so is a number or
    a yes/no (``1``, ``0``, ``true``).

    Examples
    --------
    >>> _label(" No-Stiction ", Path("l.csv")), _label("disturbance", Path("l.csv"))
    ('no_stiction', 'disturbance')
    >>> try:
    ...     _label("1", Path("l.csv"))
    ... except InputError as exc:
    ...     print(str(exc)[:45])
    l.csv: label '1' is a number or a yes/no: wri
    """
    text = "_".join(str(value).strip().lower().replace("-", " ").split())
    if text in _YES_NO or text.replace(".", "", 1).lstrip("+-").isdigit():
        raise InputError(f"{path}: label {str(value)!r} is a number or a yes/no: write "
                         "'stiction' for a sticking valve and 'no_stiction' (or the "
                         "loop's class, e.g. 'disturbance') otherwise; a 1 would be "
                         "scored as no stiction")
    if "stic" in text and text not in ("stiction", "no_stiction"):
        raise InputError(f"{path}: label {str(value)!r} is ambiguous: write 'stiction' "
                         "for a sticking valve and 'no_stiction' (or the loop's class, "
                         "e.g. 'disturbance') otherwise")
    return text


def with_meta(rec: Recording, extra: Mapping[str, Any]) -> Recording:
    """The same Recording with ``extra`` merged into its metadata (no re-validation)."""
    md = dict(rec.meta)
    md.update(extra)
    return dataclasses.replace(rec, meta=MappingProxyType(md))


def _label_meta(labels: pd.DataFrame | None, name: str) -> dict[str, Any]:
    if labels is None or name not in labels.index:
        return {}
    row = labels.loc[name]
    out: dict[str, Any] = {}
    for k, v in row.items():
        if isinstance(v, float) and np.isnan(v):
            continue
        out[str(k)] = v.item() if isinstance(v, np.generic) else v
    out.pop("loop", None)
    return {"labels": out, "label": out.get("label"), "group": out.get("group", name)}


def load_csv_dir(
    directory: str | os.PathLike[str],
    labels: str | os.PathLike[str] | pd.DataFrame | bool | None = None,
    *,
    warn: bool = True,
    label_warnings: bool = True,
) -> tuple[dict[str, Recording], Skipped]:
    """Load every CSV recording in a folder (``*.csv``, ``*.txt``, ``*.tsv``, in any case).

    Files without the columns ``t, PV, OP`` (label tables, indexes) are skipped with a
    note, as are recordings that :meth:`Recording.from_arrays` rejects (the reason is its
    one-line message).

    Parameters
    ----------
    directory : path-like
        Folder of CSV files (not searched recursively).
    labels : path, DataFrame, bool or None
        Labels table (see :func:`read_labels`). ``None`` (default): use
        ``directory/labels.csv`` when it exists; ``False``: no labels. A matching row
        goes into ``meta["labels"]`` (all columns), ``meta["label"]`` and
        ``meta["group"]`` (the file stem when the table has no group or no row).
    warn : bool
        Print interpolation warnings on stderr.
    label_warnings : bool
        Name in one warning each the labelled loops without a recording in the folder,
        the label classes scored as no stiction and the recordings without a label
        (:func:`label_notes`); ``False`` for a command that scores nothing (``screen``).

    Returns
    -------
    recordings : dict
        File stem → Recording (``meta["name"]`` is the stem), sorted by name.
    skipped : list of (str, str)
        ``(file name, reason)`` for every CSV that is not loaded.

    Raises
    ------
    InputError
        When ``directory`` is not a folder or the labels table is unreadable.
    """
    d = Path(directory)
    if not d.is_dir():
        raise InputError(f"{d}: not a directory")
    table: pd.DataFrame | None
    if labels is None:
        table = read_labels(d / "labels.csv") if (d / "labels.csv").is_file() else None
    elif labels is False:
        table = None
    elif isinstance(labels, pd.DataFrame):
        table = labels
    elif labels is True:
        table = read_labels(d / "labels.csv")
    else:
        table = read_labels(labels)
    recs: dict[str, Recording] = {}
    skipped: Skipped = []
    for f in _text_files(d):
        if not f.is_file():  # a pipe, socket or device would block the read; a folder
            skipped.append((f.name, "not a regular file"))
            continue
        cols = csv_columns(f)
        if cols is not None:
            missing = [c for c in REQUIRED if c not in cols]
            if missing:
                what = "labels table" if f.name.lower() == "labels.csv" else "table"
                skipped.append((f.name, f"not a recording ({what} without column(s) "
                                        f"{', '.join(missing)})"))
                continue
        try:
            parts = read_stretches(f, warn=warn)
        except InputError as exc:
            skipped.append((f.name, str(exc)))
            continue
        for name, rec in _stretch_names(f.stem, parts):
            recs[name] = with_meta(rec, {"name": name, "group": f.stem,
                                          **_label_meta(table, f.stem)})
    if table is not None and label_warnings:
        label_notes(table, recs, d)
    if table is not None and label_warnings:  # a labelled loop without its file
        stems = {f.stem for f in _text_files(d)}
        orphans = [str(k) for k in table.index if str(k) not in stems]
        if orphans:
            shown = ", ".join(orphans[:5]) + (" …" if len(orphans) > 5 else "")
            user_warning(f"{d}: {len(orphans)} labelled loop(s) with no recording in the "
                         f"folder: {shown}")
    return recs, skipped


def _text_files(d: Path) -> list[Path]:
    """The CSV text files of a folder, their suffix (:data:`~stictionbench.io.CSV_SUFFIXES`)
    compared without case: a Windows export's ``.CSV``, a historian's ``.txt``."""
    return sorted(f for f in d.iterdir() if f.suffix.lower() in CSV_SUFFIXES)


def label_notes(table: pd.DataFrame, recs: Mapping[str, Recording], where: Any) -> None:
    """One warning line each: the label classes scored as no stiction that are not
    ``no_stiction`` (a typo such as ``stiktion`` would be one), and the recordings
    the labels table does not label (left out of every score)."""
    other = sorted({str(v) for v in table["label"].dropna()} - {"stiction", "no_stiction"})
    if other:
        user_warning(f"{where}: label(s) scored as no stiction: {', '.join(other[:6])}"
                     + (" …" if len(other) > 6 else "") + " (only 'stiction' is a sticky "
                     "valve)")
    unlabelled = sorted(n for n, r in recs.items() if r.meta.get("label") is None)
    if unlabelled:
        shown = ", ".join(unlabelled[:5]) + (" …" if len(unlabelled) > 5 else "")
        user_warning(f"{where}: {len(unlabelled)} recording(s) without a label, left out "
                     f"of the scores: {shown}")


def _stretch_names(stem: str, parts: list[Recording]) -> list[tuple[str, Recording]]:
    """A file cut by long gaps gives one window per usable stretch, named by its file
    rows (``stem@first-last``); all of them belong to the file's loop."""
    return [(stem if "rows" not in r.meta else f"{stem}@{r.meta['rows'][0]}-"
             f"{r.meta['rows'][1]}", r) for r in parts]


# --------------------------------------------------------------------------- any file
def read_any(path: str | os.PathLike[str], *, warn: bool = True) -> dict[str, Recording]:
    """Read one file of any supported format as ``name → Recording``.

    ``.mat`` files go to :func:`load_isdb_mat` (loops that fail are skipped with a
    warning), or — when their loops have OP but no PV — to
    :func:`load_oscillation_benchmark`, whose loops become Recordings with ``PV = OP``
    and ``meta["op_only"] = True``. Every other file goes to
    :func:`stictionbench.io.read_stretches` and is named by its stem (``stem@first-last``
    for each usable stretch of a file cut by long gaps).

    Raises
    ------
    InputError
        From the reader used.
    """
    p = Path(path)
    if p.suffix.lower() == ".mat":
        if is_oscillation_benchmark(p):
            out: dict[str, Recording] = {}
            for lp in load_oscillation_benchmark(p):
                try:
                    out[lp.name] = lp.as_recording(warn=warn)
                except InputError as exc:
                    user_warning(f"skipped {lp.name}: {exc}")
            return out
        return load_isdb_mat(p, errors="skip", warn=warn)
    return {n: with_meta(r, {"name": n, "group": p.stem})
            for n, r in _stretch_names(p.stem, read_stretches(p, warn=warn))}


def read_one(path: str | os.PathLike[str], *, loop: str | None = None,
             warn: bool = True) -> Recording:
    """One recording from a file of any supported format, for the commands that read one
    (``diagnose``, ``estimate``).

    A ``.csv`` or ``.parquet`` file gives its longest usable stretch
    (:func:`stictionbench.io.read_longest_stretch`). An ISDB-layout ``.mat`` file
    (:func:`load_isdb_mat`) gives the loop named ``loop``, by its book name
    (``CHEM10``) or as ``sector.loopN`` (``chemicals.loop10``); ``loop`` may be left out
    when the file holds one loop.

    Parameters
    ----------
    path : path-like
        The recording file.
    loop : str, optional
        The loop of a ``.mat`` file; refused for any other file.
    warn : bool
        Print the readers' warnings on stderr.

    Raises
    ------
    InputError
        From the reader; ``loop`` given for a file that is not ``.mat``; a ``.mat`` file
        of several loops without ``loop``, a loop it does not hold (the message lists
        those it does) or one that cannot be read (the reason); an OP-only file (the
        oscillation benchmark has no PV).

    Examples
    --------
    >>> import numpy as np, scipy.io, tempfile, os
    >>> k = np.arange(300.0)
    >>> loops = {f"loop{i}": {"PV": np.sin(k / 9 + i), "OP": np.cos(k / 9), "Ts": 1.0}
    ...          for i in (1, 2)}
    >>> f = os.path.join(tempfile.mkdtemp(), "isdb.mat")
    >>> scipy.io.savemat(f, {"cdata": {"chemicals": loops}})
    >>> read_one(f, loop="CHEM2").meta["name"], read_one(f, loop="chemicals.loop1").meta["name"]
    ('CHEM2', 'CHEM1')
    """
    from ..io import read_longest_stretch

    p = Path(path)
    if p.suffix.lower() != ".mat":
        if loop is not None:
            raise InputError(f"{p}: --loop picks a loop of a .mat file; this file is one "
                             f"recording")
        return read_longest_stretch(p, warn=warn)
    recs, skipped = scan_isdb_mat(p, warn=warn)
    if not recs and skipped and all(" no PV" in r for _, r in skipped):
        raise InputError(f"{p}: its loops have OP but no PV (the OP-only oscillation "
                         f"benchmark?); a diagnosis needs PV: use `stictionbench screen` "
                         f"or `oscillation-benchmark`")
    names = list(recs) + [n for n, _ in skipped if n not in recs]
    if loop is None:
        if len(names) == 1 and recs:
            return next(iter(recs.values()))
        if len(names) == 1:
            raise InputError(skipped[0][1])
        shown = ", ".join(names[:12]) + (", ..." if len(names) > 12 else "")
        raise InputError(f"{p}: holds {len(names)} loops; pick one with --loop NAME "
                         f"({shown})")
    wanted = loop.strip()
    sector, dot, lp = wanted.partition(".")
    sector = {k.lower(): k for k in SECTOR_PREFIX}.get(sector.lower(), sector)
    key = (_book_name(sector, lp) if dot else wanted).lower()
    for name, rec in recs.items():
        if name.lower() == key:
            return rec
    for name, reason in skipped:
        if name.lower() == key:
            raise InputError(reason)
    shown = ", ".join(names[:12]) + (", ..." if len(names) > 12 else "")
    raise InputError(f"{p}: no loop {wanted!r}; it holds {shown}")


def source_keys(path: str | os.PathLike[str], rec: Recording) -> dict[str, Any]:
    """What a command's JSON says about where ``rec`` came from (read by
    :func:`read_one`): ``recording`` (the path given), ``loop`` for a ``.mat`` loop, and
    ``rows`` (first and last file row) for the longest stretch of a file cut by gaps."""
    out: dict[str, Any] = {"recording": str(path)}
    if Path(path).suffix.lower() == ".mat":
        out["loop"] = rec.meta.get("name")
    if "rows" in rec.meta:
        out["rows"] = list(rec.meta["rows"])
    return out
