"""The process input between recorded samples, for a PI faster than the historian.

A historian that stores the controller output once a sample while the PI executes ``m``
times in it keeps one of ``m`` outputs, and the replay of the recorded OP as a zero-order
hold gives the process an input it did not receive. On tightly tuned healthy loops this
alone, without noise or load, made the diagnosis name a dead band or stiction on 24 of 24
(``reports/concealed/fast_pi_healthy.md``, part B).

With the PI known (``kc``, ``ti``, its execution period ``h = Ts/m``: the model's
``controller.sample_time``) the outputs between two recorded samples follow from its
velocity law, ``Δu = kc·(e_i − e_{i−1}) + kc·(h/ti)·e_i``, on PV taken on the straight
line between the two samples and the set point held, anchored at the recorded OP. Where
the anchor sits depends on when the historian reads OP (:data:`CONVENTIONS`):

- ``"after"``: OP is the output the PI computed at the sample from that sample's PV, held
  for the ``m`` executions that follow; the interval's outputs run forward from it;
- ``"before"``: OP is read before the PI executes, the output held since the previous
  execution, so it is the *last* of the interval that ends at the sample; the interval's
  outputs run backward from it.

:func:`effective_op` returns the mean of the interval's outputs, which the zero-order hold
of the replay then applies: to first order in ``Ts/τ`` the input the process saw. The line
between two PV samples carries their measurement noise, so the reconstruction is exact only
for the deterministic part. On part B's noise-free loops the right convention cut the
nominal replay's error from 0.012 and 0.036 of PV's spread to 0.0002 and 0.0005 (τ = 4 and
16 s), and the wrong one made it larger, so :func:`.diagnose.diagnose` lets the nominal
model's fit choose among the snapshot and the two conventions.

References
----------
K. J. Åström, B. Wittenmark, *Computer-Controlled Systems*, 3rd ed. (1997), ch. 7 and 8
(sampling, the velocity form of the PI, behaviour between samples).
"""

from __future__ import annotations

import numpy as np

#: when the historian reads OP relative to the PI's execution at a sample
CONVENTIONS = ("after", "before")


def effective_op(sp: np.ndarray, pv: np.ndarray, op: np.ndarray, Ts: float, kc: float,
                 ti: float, period: float, convention: str = "after") -> np.ndarray:
    """Mean output of a PI ``(kc, ti)`` executing every ``period`` seconds over each
    recorded sample interval, anchored at the recorded OP by ``convention`` (see the
    module docstring): with ``"after"`` entry ``k`` is the mean over ``[t_k, t_{k+1})``,
    with ``"before"`` over ``[t_{k−1}, t_k)``, so that either is replayed from sample
    ``k`` as the recorded OP was. ``op`` itself when the PI runs no faster than the
    recording (``round(Ts/period) ≤ 1``); clipped to the recorded OP's range.

    Examples
    --------
    >>> import numpy as np
    >>> pv, op = np.r_[0.0, 1.0, 1.0], np.array([0.0, -1.0, -1.0])
    >>> out = effective_op(np.zeros(3), pv, op, 1.0, 1.0, 1e9, 0.25)
    >>> round(float(out[0]), 3)  # forward from 0 as PV rises: mean of 0, −¼, −½, −¾
    -0.375
    >>> out = effective_op(np.zeros(3), pv, op, 1.0, 1.0, 1e9, 0.25, "before")
    >>> round(float(out[1]), 3)  # backward from −1: mean of −¼, −½, −¾, −1
    -0.625
    """
    if convention not in CONVENTIONS:
        raise ValueError(f"convention must be one of {CONVENTIONS}, got {convention!r}")
    sp, pv, op = (np.asarray(x, float) for x in (sp, pv, op))
    m = int(round(Ts / period))
    if m <= 1 or op.size < 2:
        return op.copy()
    h = Ts / m
    g = kc * h / ti
    j = np.arange(m, dtype=float)
    c2 = float((j * (j + 1) / 2).mean())  # mean of j(j+1)/2
    out = op.copy()
    if convention == "after":
        dpv = np.r_[np.diff(pv), 0.0]
        e0 = sp - pv
        out = op - kc * dpv * float(j.mean()) / m + g * (e0 * float(j.mean()) - dpv * c2 / m)
    else:
        # the interval ending at sample k: PV from PV_{k−1} to PV_k, set point SP_{k−1}
        dpv = np.diff(pv)
        e0 = (sp - pv)[:-1]
        a = -kc * dpv / m + g * e0           # the increments' part linear in the count
        tri = (m - 1) * m / 2 - c2           # mean over j of Σ_{i>j} i
        out[1:] = op[1:] - (m - 1) / 2 * a + g * dpv / m * tri
    return np.clip(out, float(op.min()), float(op.max()))
