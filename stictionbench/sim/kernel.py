"""The closed-loop kernel: one numba function that steps controller, valve, process and
sensor. Exogenous signals arrive as arrays at the controller rate; the valve and process
are advanced in ``n_sub`` sub-steps per controller sample.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .valves import PHYSICAL, characteristic, valve_model_step


@njit(cache=True)
def _clamp_travel(kind, mv, state, vp, lo, hi):
    """Apply mechanical travel limits; a physical stem hitting an end stop stops there."""
    if mv < lo or mv > hi:
        lim = lo if mv < lo else hi
        if kind == PHYSICAL:
            A, k, plo, phi = vp[2], vp[1], vp[6], vp[7]
            x0 = A * plo / k
            span = A * (phi - plo) / k
            state[0] = x0 + 0.01 * lim * span
            state[1] = 0.0
            state[2] = 1.0
        else:
            state[0] = lim
        return lim
    return mv


@njit(cache=True)
def run_loop(sp, noise, dist, n_sub, dt, rec_every, proc, ctrl, kind, vp, vstate, post,
             sensor_b, pv0):
    """Simulate the loop for ``sp.size`` controller samples.

    Parameters
    ----------
    sp, noise, dist : float64[:]
        Set point, measurement noise and output disturbance per controller sample.
    n_sub : int
        Sub-steps of length ``dt`` per controller sample.
    rec_every : int
        Record every ``rec_every``-th controller sample.
    proc : float64[:]
        ``[K, a, w_old, w_new, d]`` from :meth:`FOPDT.coefficients`.
    ctrl : float64[:]
        ``[kc, ti, hc, op_low, op_high, op0]`` from :meth:`PIController.params`.
    kind, vp, vstate, post
        Valve code, model parameters, state (modified in place), post parameters
        ``[travel_low, travel_high, characteristic, rangeability]``.
    sensor_b : float
        Sensor lag factor ``exp(−dt/τs)`` (0 for none).
    pv0 : float
        Initial PV (process steady state).

    Returns
    -------
    out : float64[n_rec, 4]
        Columns SP, PV (measured), OP, MV at the recorded samples.
    """
    N = sp.size
    K, a, w_old, w_new = proc[0], proc[1], proc[2], proc[3]
    d = int(proc[4])
    kc, ti, hc, lo, hi, op = ctrl[0], ctrl[1], ctrl[2], ctrl[3], ctrl[4], ctrl[5]
    tlo, thi, ccode, R = post[0], post[1], int(post[2]), post[3]
    mv = min(max(op, tlo), thi)
    flow0 = characteristic(mv, ccode, R)
    nb = d + 2
    buf = np.zeros(nb)  # ring buffer of process inputs (deviation from flow0)
    head = 0
    y = 0.0
    ym = pv0  # sensor state
    n_rec = (N + rec_every - 1) // rec_every
    out = np.empty((n_rec, 4))
    e_prev = 0.0
    r = 0
    for n in range(N):
        pvm = ym + noise[n]
        # all signals are sampled at the same instant, before the controller executes:
        # OP is the output held since the previous execution, MV its valve's response
        if n % rec_every == 0:
            out[r, 0] = sp[n]
            out[r, 1] = pvm
            out[r, 2] = op
            out[r, 3] = mv
            r += 1
        e = sp[n] - pvm
        if n > 0:
            op = op + kc * ((e - e_prev) + hc / ti * e)
            if op < lo:
                op = lo
            elif op > hi:
                op = hi
        e_prev = e
        if kind != PHYSICAL:
            mv = _clamp_travel(kind, valve_model_step(kind, op, vstate, vp, hc),
                               vstate, vp, tlo, thi)
        for _j in range(n_sub):
            mv_in = mv
            if kind == PHYSICAL:
                mv_old = mv
                mv = _clamp_travel(kind, valve_model_step(kind, op, vstate, vp, dt),
                                   vstate, vp, tlo, thi)
                # the stem moves continuously within the sub-step: feed the process the
                # (trapezoidal) mean position, not the end value, so that a fast slip
                # does not reach the process half a sub-step early
                mv_in = 0.5 * (mv_old + mv)
            flow = characteristic(mv_in, ccode, R) - flow0
            head = (head + 1) % nb
            buf[head] = flow
            u_new = buf[(head - d) % nb]
            u_old = buf[(head - d - 1) % nb]
            y = a * y + K * (w_old * u_old + w_new * u_new)
            yo = pv0 + y + dist[n]
            ym = sensor_b * ym + (1.0 - sensor_b) * yo
    return out
