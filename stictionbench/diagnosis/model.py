"""The nominal model a user believes in: a FOPDT process under an ideal PI controller,
read from YAML or identified from the recording itself.

YAML contract (``stictionbench diagnose --model MODEL.yaml``)::

    process: {gain: 2.0, time_constant: 11.5, dead_time: 3.0}   # PV units per % OP; s
    controller: {kc: 0.29, ti: 11.5}                              # u = kc*(e + (1/ti)∫e dt)
    sample_time: 1.0
    op_range: [0, 100]    # optional: OP's 0 and 100 % (recognised from the data if absent)
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .. import strict_yaml
from ..errors import InputError
from ..recording import Recording


@dataclass(frozen=True)
class NominalModel:
    """FOPDT process ``K e^{−θs}/(τs + 1)`` with an ideal PI controller.

    ``source`` is ``"given"`` (from YAML) or ``"identified"`` (from the recording).
    ``kc``/``ti`` may be ``None`` when unknown (no closed-loop replay then).
    """

    gain: float
    time_constant: float
    dead_time: float
    kc: float | None = None
    ti: float | None = None
    sample_time: float | None = None
    source: str = "given"
    #: OP's 0 and 100 % in its own units (``op_range: [lo, hi]`` in the YAML); ``None``:
    #: recognised from the recording (:func:`.op_range.infer_op_range`)
    op_range: tuple[float, float] | None = None
    #: the PI's execution period in seconds (``controller.sample_time`` in the YAML), when
    #: the user knows it; ``None``: unknown (:func:`.diagnose.controller_rate_warning`)
    controller_period: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)



def _num(path: str, key: str, value: Any, *, positive: bool = False,
         nonneg: bool = False) -> float:
    if isinstance(value, bool) or value is None:
        raise InputError(f"{path}: {key}: expected a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{path}: {key}: expected a number, got {value!r}") from None
    except OverflowError:  # an integer beyond a float's range
        raise InputError(f"{path}: {key}: must be finite") from None
    if not math.isfinite(v):
        raise InputError(f"{path}: {key}: must be finite")
    if positive and v <= 0:
        raise InputError(f"{path}: {key}: must be positive, got {value!r}")
    if nonneg and v < 0:
        raise InputError(f"{path}: {key}: must not be negative, got {value!r}")
    return v


def load_model(path: str | Path) -> NominalModel:
    """Read and validate a nominal-model YAML file.

    Raises
    ------
    InputError
        Missing file, broken YAML, missing keys, text where numbers belong,
        non-positive time constants or gains of zero, negative dead time.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{p}: " + ("is a directory, expected a model YAML file"
                                     if p.is_dir() else "not a regular file, expected a "
                                     "model YAML file" if p.exists() else
                                     "no such model file"))
    try:
        doc = strict_yaml.load(p.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else "parse error"
        raise InputError(f"{p}: not valid YAML ({first})") from None
    if not isinstance(doc, dict):
        raise InputError(f"{p}: expected a mapping with process, controller, sample_time")
    proc = doc.get("process")
    if not isinstance(proc, dict):
        raise InputError(f"{p}: missing key 'process' (gain, time_constant, dead_time)")
    for k in ("gain", "time_constant", "dead_time"):
        if k not in proc:
            raise InputError(f"{p}: missing key 'process.{k}'")
    extra = set(proc) - {"gain", "time_constant", "dead_time"}
    if extra:
        raise InputError(f"{p}: unknown key(s) in process: "
                         f"{', '.join(sorted(map(str, extra)))} (gain, time_constant, "
                         "dead_time)")
    kc = ti = period = None
    ctrl = doc.get("controller")
    if ctrl is not None:
        if not isinstance(ctrl, dict):
            raise InputError(f"{p}: controller: expected a mapping with kc and ti")
        for k in ("kc", "ti"):
            if k not in ctrl:
                raise InputError(f"{p}: missing key 'controller.{k}'")
        extra = set(ctrl) - {"kc", "ti", "sample_time"}
        if extra:
            raise InputError(f"{p}: unknown key(s) in controller: "
                             f"{', '.join(sorted(map(str, extra)))} (kc, ti, sample_time)")
        kc, ti, period = ctrl["kc"], ctrl["ti"], ctrl.get("sample_time")
        for key, value in (("kc", kc), ("ti", ti), ("sample_time", period)):
            if value is None and key in ctrl:  # written, but empty (null)
                raise InputError(f"{p}: controller.{key}: expected a number, got None")
    r = doc.get("op_range")
    if r is not None and (not isinstance(r, list | tuple) or len(r) != 2):
        raise InputError(f"{p}: op_range: expected [lo, hi], got {r!r}")
    if "sample_time" in doc and doc["sample_time"] is None:
        raise InputError(f"{p}: sample_time: expected a number, got None")
    unknown = set(doc) - {"process", "controller", "sample_time", "op_range"}
    if unknown:
        raise InputError(f"{p}: unknown key(s) {', '.join(sorted(map(str, unknown)))}")
    raw = NominalModel(proc["gain"], proc["time_constant"], proc["dead_time"], kc, ti,
                       doc.get("sample_time"), "given", None if r is None else tuple(r),
                       period)
    return _checked(raw, str(p), YAML_KEYS)


def checked_model(model: Any) -> NominalModel:
    """A model given to :func:`.diagnose.diagnose` from Python, held to the rules
    :func:`load_model` applies to a YAML file (a path is read with it): finite numbers, a
    gain other than zero, positive time constant, integral time and periods, a dead time
    not negative, ``op_range`` ascending. A first version took any
    :class:`NominalModel` as built: a gain of 0 or NaN gave the same confident verdict
    as the true one, a time constant of 0 a ``ZeroDivisionError``.

    Raises
    ------
    InputError
        Naming the field and the rule.

    Examples
    --------
    >>> checked_model(NominalModel(3.0, 10.0, 10.0, 0.2, 10.0)).gain
    3.0
    >>> try:
    ...     checked_model(NominalModel(0.0, 10.0, 10.0))
    ... except InputError as exc:
    ...     print(exc)
    model: gain: must not be zero
    """
    if isinstance(model, str | Path):
        return load_model(model)
    if not isinstance(model, NominalModel):
        raise InputError(f"model: expected a NominalModel or a model YAML path, got "
                         f"{type(model).__name__}")
    return _checked(model, "model", {})


#: the model's fields as a model YAML file names them (its messages use these)
YAML_KEYS = {"gain": "process.gain", "time_constant": "process.time_constant",
             "dead_time": "process.dead_time", "kc": "controller.kc",
             "ti": "controller.ti", "controller_period": "controller.sample_time"}


def _checked(m: NominalModel, where: str, names: dict[str, str]) -> NominalModel:
    """``m`` with its numbers as floats, or the :class:`InputError` of the first rule it
    breaks (the rules of :func:`checked_model`), naming the field by ``names``."""
    def num(key: str, optional: bool = True, **rule: bool) -> float | None:
        value = getattr(m, key)
        if value is None and optional:
            return None
        return _num(where, names.get(key, key), value, **rule)

    gain = num("gain", optional=False)
    if gain == 0:
        raise InputError(f"{where}: {names.get('gain', 'gain')}: must not be zero")
    op_range = None
    if m.op_range is not None:
        lo, hi = (_num(where, "op_range", v) for v in m.op_range)
        if hi <= lo:
            raise InputError(f"{where}: op_range: hi must exceed lo, got {m.op_range!r}")
        op_range = (lo, hi)
    return replace(m, gain=gain,
                   time_constant=num("time_constant", optional=False, positive=True),
                   dead_time=num("dead_time", optional=False, nonneg=True), kc=num("kc"),
                   ti=num("ti", positive=True), sample_time=num("sample_time", positive=True),
                   controller_period=num("controller_period", positive=True),
                   op_range=op_range)


#: share of the OP moves a PI fit must explain to count as the loop's controller
MIN_PI_R2 = 0.5


@dataclass(frozen=True)
class PIFit:
    """An ideal PI ``u = kc·(e + (1/ti)∫e dt)`` identified from a recording's samples.

    ``r2`` is the share of the OP moves the velocity form explains; ``lag`` the recording
    lag (OP stored 0 or 1 sample late); ``setpoint`` the set point (the mean of the
    recorded SP, or the fit's estimate of a constant one when SP was not recorded)."""

    kc: float
    ti: float
    r2: float
    lag: int
    setpoint: float
    setpoint_recorded: bool

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def fit_pi(pv: np.ndarray, op: np.ndarray, Ts: float,
           sp: np.ndarray | None = None) -> PIFit | None:
    """Least-squares fit of the PI velocity form ``ΔOP[k] = kc·Δe[k−l] + kc·Ts/ti·e[k−l]``,
    ``e = SP − PV``, for a recording lag ``l ∈ {0, 1}`` (historians often store OP one
    execution late).

    Without a recorded SP the set point is taken constant and unknown (a regulatory
    loop): ``ΔOP = −kc·ΔPV − (kc·Ts/ti)·PV + c`` with ``c = (kc·Ts/ti)·SP``, linear in
    its three coefficients.

    Returns ``None`` when the best fit is not a PI controller: it explains less than
    :data:`MIN_PI_R2` of the OP moves (``1 − SSE/ΣΔOP²``), or its integral action is not
    positive. A PI executed faster than the historian, filtered or compressed OP data,
    or a controller with other terms usually fail the first condition.

    Examples
    --------
    >>> import numpy as np
    >>> pv = np.sin(np.arange(300) / 7.0)
    >>> op = 20 + np.cumsum(0.5 * (np.r_[0, -np.diff(pv)] + 0.1 * (0.3 - pv)))
    >>> f = fit_pi(pv, op, 1.0)
    >>> round(f.kc, 3), round(f.ti, 3), round(f.setpoint, 3)
    (0.5, 10.0, 0.3)
    """
    pv, op = np.asarray(pv, float), np.asarray(op, float)
    dop = np.diff(op)
    if sp is None:
        X0 = np.column_stack([-np.diff(pv), -pv[1:], np.ones(pv.size - 1)])
    else:
        e = np.asarray(sp, float) - pv
        X0 = np.column_stack([np.diff(e), e[1:]])
    best = None
    for lag in (0, 1):
        X, y = (X0[:-1], dop[1:]) if lag else (X0, dop)
        if np.linalg.matrix_rank(X) < X.shape[1]:
            continue
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        r2 = 1 - float(np.sum((y - X @ coef) ** 2)) / max(float(np.sum(y * y)), 1e-300)
        if best is None or r2 > best[0]:
            best = (r2, coef, lag)
    if best is None or best[0] < MIN_PI_R2:
        return None
    r2, coef, lag = best
    a, b = float(coef[0]), float(coef[1])
    if a == 0 or b / a <= 0:
        return None
    setpoint = float(np.mean(sp)) if sp is not None else float(coef[2]) / b
    return PIFit(a, a * Ts / b, float(r2), int(lag), setpoint, sp is not None)


def identify_pi(rec: Recording) -> tuple[float, float] | None:
    """Estimate an ideal PI ``(kc, ti)`` from SP, PV, OP (:func:`fit_pi`); ``None`` when
    SP is absent or the best fit is not a PI controller."""
    if rec.SP is None:
        return None
    f = fit_pi(rec.PV, rec.OP, rec.Ts, rec.SP)
    return None if f is None else (f.kc, f.ti)
