"""The estimator interface: scikit-learn-style objects returning a frozen result.

Parameters go in ``__init__`` (stored as attributes of the same name, no work done
there); :meth:`Estimator.estimate` takes a :class:`~stictionbench.recording.Recording`
and the names of the signals to use and returns an :class:`EstimateResult`.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np

from ..errors import InputError
from ..recording import Recording
from ..validation import Constraint, jsonable, validate_params


@dataclass(frozen=True)
class EstimateResult:
    """What an estimator returns.

    Attributes
    ----------
    method : str
        Registered name of the estimator.
    value : float
        The headline number (a delay, an index, a period ...).
    units : str
        Units of ``value`` (``"samples"``, ``"s"``, ``"%"``, ``"-"``).
    decision : bool or None
        The estimator's yes/no call (stiction indicated, nonlinear, oscillating);
        ``None`` when it cannot decide.
    meaning : str
        What ``decision = True`` means, e.g. ``"nonlinear"``.
    diagnostics : Mapping
        Further numbers (secondary indices, thresholds used, curves as lists).
    """

    method: str
    value: float
    units: str
    decision: bool | None
    meaning: str = ""
    diagnostics: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "diagnostics", MappingProxyType(dict(self.diagnostics)))

    def to_dict(self, *, curves: bool = False) -> dict[str, Any]:
        """Return a JSON-ready dict; arrays in diagnostics are dropped unless ``curves``."""
        diag: dict[str, Any] = {}
        for k, v in self.diagnostics.items():
            if isinstance(v, np.ndarray):
                if curves:
                    diag[k] = v.tolist()
                continue
            diag[k] = jsonable(v)
        return {
            "method": self.method,
            "value": jsonable(self.value),
            "units": self.units,
            "decision": self.decision,
            "meaning": self.meaning,
            "diagnostics": diag,
        }

    def flat(self, prefix: str | None = None) -> dict[str, Any]:
        """Return scalar outputs as a flat dict, keys prefixed with the method name."""
        p = (prefix or self.method) + "_"
        out: dict[str, Any] = {p + "value": self.value, p + "decision": self.decision}
        for k, v in self.diagnostics.items():
            scalar = (int, float, bool, str, np.integer, np.floating, np.bool_)
            if v is None or isinstance(v, scalar):
                out[p + k] = jsonable(v)
        return out


class Estimator:
    """Base class for estimators.

    Subclasses set ``name``, declare every parameter as a keyword argument of
    ``__init__`` stored under the same attribute name, and implement
    :meth:`_estimate` on two validated float arrays.
    """

    name: ClassVar[str] = ""
    #: declared parameters, scikit-learn style: name -> accepted forms
    #: (:class:`~stictionbench.validation.Interval`, ``Options``, ``TypeOf`` or ``None``);
    #: :meth:`estimate` checks them before any work. Undeclared names are not checked.
    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {}
    #: signals used when the caller does not name them
    default_x: ClassVar[str] = "OP"
    default_y: ClassVar[str | None] = "MV"

    @classmethod
    def param_names(cls) -> list[str]:
        """Names of the constructor parameters."""
        sig = inspect.signature(cls.__init__)
        return [p for p in sig.parameters if p != "self" and sig.parameters[p].kind
                not in (inspect.Parameter.VAR_KEYWORD, inspect.Parameter.VAR_POSITIONAL)]

    def get_params(self) -> dict[str, Any]:
        """Current parameters as a dict (as in scikit-learn)."""
        return {k: getattr(self, k) for k in self.param_names()}

    def check_params(self) -> None:
        """Check the current parameters against ``_parameter_constraints``.

        Raises
        ------
        InputError
            One line naming the parameter, what it accepts and what it got.
        """
        validate_params(self.name or type(self).__name__, self._parameter_constraints,
                        self.get_params())

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    def estimate(
        self, rec: Recording, x: str | None = None, y: str | None = None
    ) -> EstimateResult:
        """Run the estimator on signals ``x`` (and ``y``) of a Recording.

        Parameters
        ----------
        rec : Recording
        x, y : str, optional
            Signal names (``"OP"``, ``"MV"``, ``"PV"``, ``"SP"``); defaults are the
            estimator's ``default_x`` / ``default_y``.
        """
        self.check_params()
        for name in (x, y):
            if name == "t":  # the time column: no estimator reads it as a signal
                raise InputError("t is the time column, not a signal; use one of SP, PV, "
                                 "OP, MV")
        xs = rec.signal(x or self.default_x)
        yname = y or self.default_y
        ys = rec.signal(yname) if yname else None
        return self._estimate(np.asarray(xs, float), None if ys is None else np.asarray(ys, float),
                              rec)

    def _estimate(
        self, x: np.ndarray, y: np.ndarray | None, rec: Recording
    ) -> EstimateResult:  # pragma: no cover - abstract
        raise NotImplementedError
