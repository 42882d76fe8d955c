"""Numbers for the CLI's strict JSON (``allow_nan=False``): a non-finite float becomes
``None``."""

from __future__ import annotations

import math
from typing import Any


def finite_or_none(v: Any) -> Any:
    """``v``, or ``None`` when it is a non-finite float.

    Examples
    --------
    >>> finite_or_none(float("inf")), finite_or_none(2.5), finite_or_none("x")
    (None, 2.5, 'x')
    """
    return None if isinstance(v, float) and not math.isfinite(v) else v


def finite_values(d: dict[str, Any]) -> dict[str, Any]:
    """``d`` with every non-finite float value replaced by ``None`` (one level deep)."""
    return {k: finite_or_none(v) for k, v in d.items()}
