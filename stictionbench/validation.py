"""Checks at the boundary: numbers, signals, declared parameters, JSON values, paths.

Everything a user hands to stictionbench (config values, estimator parameters, signals,
output paths) is checked here, once, with a one-line :class:`~stictionbench.errors.InputError`
naming what was wrong; the CLI turns it into ``stictionbench: error: …`` and exit code 2.

Declared parameters follow scikit-learn's ``_parameter_constraints`` (``sklearn.utils.
_param_validation``): a class maps each parameter name to a list of accepted forms, and
:func:`validate_params` checks a value against them before any work is done.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError

# --------------------------------------------------------------------------- numbers


def number(key: str, value: object, *, low: float | None = None, strict: bool = False) -> float:
    """A finite number from a config value, ``≥ low`` (``> low`` when ``strict``).

    Raises
    ------
    InputError
        Naming ``key`` when ``value`` is not a finite number in range.

    Examples
    --------
    >>> number("valve.Fs", "1000", low=0)
    1000.0
    """
    if isinstance(value, bool):
        raise InputError(f"{key}: not a number ({value!r})")
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"{key}: not a number ({value!r})") from None
    if not math.isfinite(v):
        raise InputError(f"{key}: must be finite, got {value!r}")
    if low is not None and (v < low or (strict and v == low)):
        need = "positive" if strict and low == 0 else f"{'>' if strict else '≥'} {low:g}"
        raise InputError(f"{key}: must be {need}, got {value!r}")
    return v


def positive(key: str, value: object) -> float:
    """A finite number ``> 0`` (see :func:`number`)."""
    return number(key, value, low=0.0, strict=True)


def whole_number(key: str, value: object, low: int = 0) -> int:
    """A seed or a count from a config value or command-line text: a whole number
    ``≥ low`` (``3``, ``"3"``, ``3.0``); ``1.5``, ``"abc"`` or ``True`` are refused rather
    than rounded, so that the run a user names is the run they get.

    Raises
    ------
    InputError
        Naming ``key``, one line.

    Examples
    --------
    >>> whole_number("seed", "7"), whole_number("seed", 7.0)
    (7, 7)
    >>> whole_number("seed", 1.5)
    Traceback (most recent call last):
    ...
    stictionbench.errors.InputError: seed: not an integer (1.5)
    """
    if isinstance(value, bool):
        raise InputError(f"{key}: not an integer ({value!r})")
    try:
        v = float(str(value).strip()) if isinstance(value, str) else float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"{key}: not an integer ({value!r})") from None
    if not math.isfinite(v) or v != int(v):
        raise InputError(f"{key}: not an integer ({value!r})")
    if v < low:
        raise InputError(f"{key}: must be ≥ {low}, got {value!r}")
    return int(v)


# --------------------------------------------------------------------------- signals


def check_signal(x: np.ndarray, name: str, *, min_len: int = 1) -> np.ndarray:
    """Check a 1-D float signal: finite, long enough, not constant.

    Raises
    ------
    InputError
        With a one-line message naming the signal.

    Examples
    --------
    >>> check_signal([1.0, 2.0, 3.0], "OP").tolist()
    [1.0, 2.0, 3.0]
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise InputError(f"{name}: expected a 1-D signal, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise InputError(f"{name}: contains NaN or infinite values")
    if x.size < min_len:
        raise InputError(f"{name}: {x.size} samples, at least {min_len} needed")
    if np.ptp(x) == 0.0:
        raise InputError(f"{name}: constant signal (spectra and coherence are undefined)")
    return x


def check_pair(name: str, x: np.ndarray, y: np.ndarray | None, *,
               min_len: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Check the two signals of a two-signal estimator (``x`` = OP, ``y`` = MV) with
    :func:`check_signal`; a missing ``y`` is an InputError naming the estimator."""
    if y is None:
        raise InputError(f"{name}: needs two signals (x = OP, y = MV)")
    return (check_signal(x, f"{name} x", min_len=min_len),
            check_signal(y, f"{name} y", min_len=min_len))


# --------------------------------------------------------------------------- JSON


def jsonable(v: Any) -> Any:
    """Plain-Python, JSON-ready copy of ``v``: numpy scalars become Python scalars,
    non-finite floats become ``None`` (JSON has no inf/NaN), containers are walked.

    Examples
    --------
    >>> jsonable({"a": np.float64(1.5), "b": [np.int64(2), float("nan")], "c": np.bool_(True)})
    {'a': 1.5, 'b': [2, None], 'c': True}
    """
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, Mapping):
        return {str(k): jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [jsonable(x) for x in v]
    return v


# --------------------------------------------------------------------------- paths


#: files an input directory may hold that a command reads (recordings, labels, models)
DATA_SUFFIXES = (".csv", ".parquet", ".mat", ".yaml", ".yml", ".json")


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


#: the kinds of file a report directory is written with (tables, summaries, figures): an
#: output of such a kind inside a report directory could be overwritten by one of them,
#: or overwrite it; a JSON beside the report (``--json rep/batch.json --report rep``, as
#: ``make real`` writes) cannot, and is allowed
REPORT_SUFFIXES = (".md", ".csv", ".png", ".svg", ".pdf")


def refuse_overwrite(outputs: Iterable[str | os.PathLike[str] | None],
                     inputs: Iterable[str | os.PathLike[str] | None]) -> None:
    """Refuse an output path that is an input file (same path, symlink or hard link),
    an input directory itself or a data file inside one (:data:`DATA_SUFFIXES`), that is
    named twice among the outputs, or that lies inside another output with a name a report
    file could have (:data:`REPORT_SUFFIXES`: ``--json rep/summary.md --report rep``).

    Raises
    ------
    InputError
        ``"<out>: is the input file <in>; refusing to overwrite it"``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "rec.csv"; _ = f.write_text("t\\n")
    >>> refuse_overwrite([f.parent / "out.json"], [f])
    >>> refuse_overwrite([f.parent / "." / "rec.csv"], [f])
    Traceback (most recent call last):
    ...
    stictionbench.errors.InputError: ... is the input file ...; refusing to overwrite it
    """
    ins = [Path(p) for p in inputs if p is not None]
    outs = [Path(p) for p in outputs if p is not None and str(p) != "-"]  # "-": stdout
    for out in outs:
        for src in ins:
            if src.is_dir():
                if _same_file(out, src):
                    raise InputError(f"{out}: is the input directory; refusing to write "
                                     "into it")
                inside = Path(os.path.realpath(out)).is_relative_to(os.path.realpath(src))
                if inside and out.is_file() and out.suffix.lower() in DATA_SUFFIXES:
                    raise InputError(f"{out}: is a data file inside the input directory "
                                     f"{src}; refusing to overwrite it")
            elif _same_file(out, src):
                raise InputError(f"{out}: is the input file {src}; refusing to overwrite it")
    real = [os.path.realpath(p) for p in outs]
    for i, r in enumerate(real):
        if r in real[:i]:
            raise InputError(f"{outs[i]}: named twice as an output")
        for j, other in enumerate(real):
            if (j != i and r != other and Path(r).is_relative_to(other)
                    and Path(r).suffix.lower() in REPORT_SUFFIXES):
                raise InputError(f"{outs[i]}: is inside the output {outs[j]}, whose files "
                                 "would overwrite it; give it another place")


def check_writable(files: Iterable[str | os.PathLike[str] | None] = (),
                   dirs: Iterable[str | os.PathLike[str] | None] = ()) -> None:
    """Refuse, before any work, an output that cannot be written: a file output that is
    an existing directory, a directory output that is an existing file, a path under a
    file, or a place where no file can be created. Nothing is created: the test file
    goes into the nearest existing ancestor and is removed at once.

    Raises
    ------
    InputError
        ``"<out>: cannot write there (<reason>)"`` and the like, one line.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> check_writable([d / "new" / "out.json"], [d / "report"])
    >>> check_writable([d])
    Traceback (most recent call last):
    ...
    stictionbench.errors.InputError: ...: is a directory, expected a file name
    """
    import tempfile

    todo = [(Path(f), False) for f in files if f is not None and str(f) != "-"]
    todo += [(Path(d), True) for d in dirs if d is not None]
    for out, is_dir in todo:
        if out.exists():
            if is_dir and not out.is_dir():
                raise InputError(f"{out}: exists and is not a directory")
            if not is_dir and out.is_dir():
                raise InputError(f"{out}: is a directory, expected a file name")
        anc = out if (is_dir and out.is_dir()) else out.parent
        while not anc.exists() and anc != anc.parent:
            anc = anc.parent
        if not anc.is_dir():
            raise InputError(f"{out}: {anc} is not a directory")
        try:
            fd, tmp = tempfile.mkstemp(prefix=".stictionbench-probe.", dir=anc)
        except OSError as exc:
            raise InputError(f"{out}: cannot write there ({exc.strerror or exc})") from None
        os.close(fd)
        os.unlink(tmp)


def jobs_count(text: str) -> int:
    """``--jobs`` (an argparse ``type``): a worker count (≥ 1) or a negative count
    joblib-style (-1: every core), capped at the machine's cores: more workers than cores
    only wait, and a huge count would try to start that many processes.

    >>> jobs_count("1")
    1
    """
    import argparse

    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if n == 0:
        raise argparse.ArgumentTypeError("0 workers; give a count ≥ 1, or -1 for every "
                                         "core")
    cores = os.cpu_count() or 1
    return min(n, cores) if n > 0 else max(cores + 1 + n, 1)


def count_arg(text: str) -> int:
    """A count of repetitions on the command line (an argparse ``type``): a whole
    number ``≥ 0`` (:func:`whole_number`).

    >>> count_arg("200")
    200
    """
    import argparse

    try:
        return whole_number("count", text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("count: ")) from None


# --------------------------------------------------------------------------- parameters


@dataclass(frozen=True)
class Interval:
    """A numeric range constraint (scikit-learn's ``Interval``).

    Parameters
    ----------
    kind : type
        ``numbers.Integral`` or ``numbers.Real``: integers are accepted for Real,
        floats with an integral value are not accepted for Integral.
    left, right : float or None
        Bounds; ``None`` is unbounded.
    closed : {"both", "left", "right", "neither"}
        Which bounds are included.
    """

    kind: type
    left: float | None
    right: float | None
    closed: str = "both"

    def accepts(self, v: Any) -> bool:
        if isinstance(v, bool) or not isinstance(v, self.kind):
            return False
        if isinstance(v, numbers.Real) and not math.isfinite(float(v)):
            return False
        lo_ok = self.left is None or (
            v >= self.left if self.closed in ("both", "left") else v > self.left)
        hi_ok = self.right is None or (
            v <= self.right if self.closed in ("both", "right") else v < self.right)
        return bool(lo_ok and hi_ok)

    def __str__(self) -> str:
        kind = "an integer" if self.kind is numbers.Integral else "a real number"
        lb = "[" if self.closed in ("both", "left") and self.left is not None else "("
        rb = "]" if self.closed in ("both", "right") and self.right is not None else ")"
        lo = "-inf" if self.left is None else f"{self.left:g}"
        hi = "inf" if self.right is None else f"{self.right:g}"
        return f"{kind} in {lb}{lo}, {hi}{rb}"


@dataclass(frozen=True)
class Options:
    """A constraint accepting one of a fixed set of values (scikit-learn's ``StrOptions``)."""

    values: tuple[Any, ...]

    def accepts(self, v: Any) -> bool:
        return any(v == o and type(v) is type(o) for o in self.values)

    def __str__(self) -> str:
        return "one of " + ", ".join(repr(o) for o in self.values)


@dataclass(frozen=True)
class TypeOf:
    """A constraint accepting instances of a type (``bool``, ``str``, ``dict`` …)."""

    kind: type | tuple[type, ...]

    def accepts(self, v: Any) -> bool:
        if self.kind is not bool and isinstance(v, bool):
            return False
        return isinstance(v, self.kind)

    def __str__(self) -> str:
        kinds = self.kind if isinstance(self.kind, tuple) else (self.kind,)
        return " or ".join(f"a {k.__name__}" for k in kinds)


@dataclass(frozen=True)
class Band:
    """A constraint accepting an increasing pair ``(low, high)`` of finite reals inside
    ``[left, right]`` (a frequency band, an axis range)."""

    left: float | None = None
    right: float | None = None

    def accepts(self, v: Any) -> bool:
        if isinstance(v, (str, bytes)) or not isinstance(v, Sequence) or len(v) != 2:
            return False
        item = Interval(numbers.Real, self.left, self.right)
        return item.accepts(v[0]) and item.accepts(v[1]) and v[0] < v[1]

    def __str__(self) -> str:
        lo = "-inf" if self.left is None else f"{self.left:g}"
        hi = "inf" if self.right is None else f"{self.right:g}"
        return f"a pair [low, high] with {lo} <= low < high <= {hi}"


Constraint = Interval | Options | TypeOf | Band | None


def _accepts(c: Constraint, v: Any) -> bool:
    return v is None if c is None else c.accepts(v)


def _describe(c: Constraint) -> str:
    return "None" if c is None else str(c)


def validate_params(owner: str, constraints: Mapping[str, Sequence[Constraint]],
                    params: Mapping[str, Any]) -> None:
    """Check ``params`` against declared ``constraints`` (each a list of accepted forms).

    Parameters without a declaration are not checked (third-party classes that declare
    nothing keep working).

    Raises
    ------
    InputError
        ``"<owner>: parameter max_delay must be an integer in [1, inf); got 'abc'"``.

    Examples
    --------
    >>> c = {"max_delay": [Interval(numbers.Integral, 1, None)]}
    >>> validate_params("xcorr", c, {"max_delay": 30})
    >>> validate_params("xcorr", c, {"max_delay": "abc"})
    Traceback (most recent call last):
    ...
    stictionbench.errors.InputError: xcorr: parameter max_delay must be an integer ...; got 'abc'
    """
    for name, value in params.items():
        forms = constraints.get(name)
        if forms is None:
            continue
        if not any(_accepts(c, value) for c in forms):
            allowed = " or ".join(_describe(c) for c in forms)
            raise InputError(f"{owner}: parameter {name} must be {allowed}; got {value!r}")
