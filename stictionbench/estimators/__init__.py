"""Estimators behind one interface, registered by name (see :mod:`.registry`)."""

from .base import EstimateResult, Estimator
from .registry import available, get_class, make

__all__ = ["EstimateResult", "Estimator", "available", "get_class", "make"]
