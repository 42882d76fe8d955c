"""Estimator registry: built-ins by name, third parties through an entry-point group.

A third-party package registers an estimator by declaring, in its ``pyproject.toml``::

    [project.entry-points."stictionbench.estimators"]
    myname = "mypackage.module:MyEstimator"

where ``MyEstimator`` subclasses :class:`stictionbench.estimators.base.Estimator`.
"""

from __future__ import annotations

import functools
from importlib import import_module
from importlib.metadata import entry_points
from typing import Any

from ..errors import InputError
from .base import Estimator

GROUP = "stictionbench.estimators"

#: built-in estimators: name -> "module:Class" (loaded lazily)
BUILTIN = {
    "xcorr": "stictionbench.estimators.xcorr:XCorr",
    "xcum": "stictionbench.estimators.xcum:XCum",
    "bicoherence": "stictionbench.estimators.bicoherence:Bicoherence",
    "oscillation": "stictionbench.estimators.oscillation:Oscillation",
    "ellipse": "stictionbench.estimators.ellipse:Ellipse",
    "horch": "stictionbench.estimators.horch:Horch",
    "he": "stictionbench.estimators.he:He",
    "area_ratio": "stictionbench.estimators.area_ratio:AreaRatio",
    "kano": "stictionbench.estimators.kano:Kano",
    "yamashita": "stictionbench.estimators.yamashita:Yamashita",
    "hagglund": "stictionbench.estimators.hagglund:Hagglund",
}


@functools.cache
def _load(spec: str) -> type[Estimator]:
    module, _, attr = spec.partition(":")
    return getattr(import_module(module), attr)


def available() -> dict[str, str]:
    """All registered estimators: name -> ``"module:Class"``; entry points included.

    The entry-point scan reads every installed distribution's metadata (milliseconds),
    so it is done once per process; :func:`refresh` forgets it after an install.
    """
    return dict(_scan())


@functools.lru_cache(maxsize=1)
def _scan() -> tuple[tuple[str, str], ...]:
    out = dict(BUILTIN)
    for ep in entry_points(group=GROUP):
        out.setdefault(ep.name, ep.value)
    return tuple(out.items())


def refresh() -> None:
    """Forget the cached entry points (after installing a plug-in in this process)."""
    _scan.cache_clear()


def get_class(name: str) -> type[Estimator]:
    """Return the estimator class registered under ``name``.

    Raises
    ------
    InputError
        When no estimator has that name.
    """
    reg = available()
    if name not in reg:
        raise InputError(f"unknown estimator {name!r}; available: {', '.join(sorted(reg))}")
    cls = _load(reg[name])
    if not (isinstance(cls, type) and issubclass(cls, Estimator)):
        raise InputError(f"estimator {name!r} ({reg[name]}) is not an Estimator subclass")
    return cls


def make(name: str, **params: Any) -> Estimator:
    """Instantiate estimator ``name`` with ``params``, checking their names and the
    class's declared constraints (``_parameter_constraints``)."""
    cls = get_class(name)
    allowed = cls.param_names()
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise InputError(
            f"estimator {name!r}: unknown parameter(s) {', '.join(unknown)}; "
            f"known: {', '.join(allowed) or 'none'}"
        )
    est = cls(**params)
    est.check_params()
    return est
