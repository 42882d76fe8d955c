"""Simulation blocks and the closed-loop kernel."""

from .compose import simulate, simulate_config

__all__ = ["simulate", "simulate_config"]
