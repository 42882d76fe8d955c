"""Simulation blocks and the closed-loop kernel.

``simulate`` and ``simulate_config`` (Hydra-composed runs, :mod:`.compose`) are imported
on first use (PEP 562), so that the blocks and the kernel — which the diagnosis uses to
close a fitted loop (:mod:`stictionbench.diagnosis.cycle`) — do not pull in Hydra.
"""

from __future__ import annotations

from typing import Any

__all__ = ["simulate", "simulate_config"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from . import compose

        return getattr(compose, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
