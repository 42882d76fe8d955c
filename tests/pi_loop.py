"""A FOPDT under a velocity PI executed every second, for tests that need a closed loop
simulated independently of the package's own simulator."""

from __future__ import annotations

import math

import numpy as np

from stictionbench.recording import Recording


def velocity_pi_loop(sp: np.ndarray, gain: float, tau: float, theta: float, kc: float,
                     ti: float, load: np.ndarray, noise: np.ndarray, op0: float,
                     op_limits: tuple[float, float] | None = None) -> Recording:
    """PV = FOPDT(OP) + ``load`` + ``noise`` at 1 s (dead time ``theta`` whole seconds,
    zero-order hold); OP from the velocity PI ``kc·(Δe + e/ti)`` on ``e = SP − PV``,
    clamped to ``op_limits`` when given, the valve following OP exactly; the loop starts
    at rest at ``op0``."""
    n = sp.size
    a = math.exp(-1.0 / tau)
    d = int(theta)
    x, op, e_prev = gain * op0, op0, 0.0
    buf = [op] * (d + 1)
    pv, ops = np.empty(n), np.empty(n)
    for k in range(n):
        pv[k] = x + load[k] + noise[k]
        e = sp[k] - pv[k]
        if k:
            op = op + kc * ((e - e_prev) + e / ti)
            if op_limits is not None:
                op = min(max(op, op_limits[0]), op_limits[1])
        e_prev = e
        ops[k] = op
        buf.append(op)
        x = a * x + (1 - a) * gain * buf.pop(0)
    return Recording.from_arrays(np.arange(n, dtype=float), pv, ops, SP=sp)
