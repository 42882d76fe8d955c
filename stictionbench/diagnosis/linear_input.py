"""Is a fitted valve nonlinear, or would a linear change of the process input do as well?

A dead band or stiction hypothesis turns OP into the valve position by a nonlinear map
whose effect on PV is partly linear in OP's recent moves (the valve lags OP by half its
band in the direction OP last moved). Two things a valve did not cause leave such a
linear trace in a healthy loop's output error:

- a PI executing faster than the historian: the recorded OP is a snapshot, and the
  process received, between samples, moves the snapshot does not hold
  (``experiments/healthy_false_alarms.py``, generator A: with the PI at the historian's
  rate the false alarms fall from 14 to 3 of 120);
- an unmeasured load OP reacts to (same experiment, generator C: without the load they
  fall from 14 to 4 of 96). Not always linearly: at a tenth of the PV noise that load
  makes 43 of 96 healthy loops look like dead bands, and this gate removes 4 of them.

:class:`WithLinearInput` adds to a hypothesis's regressors the process response to OP one
sample ahead and one and two samples behind: a four-tap FIR in place of the zero-order
hold of ``OP_k``, which can average a snapshot over its sample, shift it by a fraction of
a sample and weigh its recent moves. :func:`linear_input_test` is then the
likelihood-ratio test of the valve within that larger linear family (the valve plus the
FIR against the FIR alone, nested at a valve of zero size): evidence that the valve's
gain over the nominal model is nonlinear (Ljung, *System Identification*, 1999, ch. 16:
testing a model structure against a richer one; the same intersection–union use as the
re-identified process's ``valve_vs_linear`` gate).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .fit import Fit, Problem, fit_at
from .hypotheses import Context, Hypothesis
from .noise import NoiseModel, lr_test
from .openloop import fopdt_response

#: OP's shifts (samples; negative: ahead) whose process responses join the regressors
SHIFTS = (-1, 1, 2)


def shifted(x: np.ndarray, s: int) -> np.ndarray:
    """``x`` delayed by ``s`` samples (ahead for ``s < 0``), its end values held.

    Examples
    --------
    >>> shifted(np.arange(4.0), 1).tolist(), shifted(np.arange(4.0), -1).tolist()
    ([0.0, 0.0, 1.0, 2.0], [1.0, 2.0, 3.0, 3.0])
    """
    if s > 0:
        return np.r_[np.full(s, x[0]), x[:-s]]
    if s < 0:
        return np.r_[x[-s:], np.full(-s, x[-1])]
    return x


class WithLinearInput(Hypothesis):
    """``base`` with the process responses to OP's shifts :data:`SHIFTS` as further
    free linear regressors."""

    def __init__(self, base: Hypothesis) -> None:
        self.base = base
        self.name = f"{base.name}+linear_input"
        self.params = base.params
        self.extra_linear = base.extra_linear + len(SHIFTS)

    def regressors(self, ctx: Context, p: np.ndarray) -> np.ndarray:
        X = np.asarray(self.base.regressors(ctx, p), float)
        X = X[:, None] if X.ndim == 1 else X
        extra = [fopdt_response(shifted(ctx.op, s), ctx.Ts, ctx.tau, ctx.theta)
                 for s in SHIFTS]
        return np.column_stack([X, *extra])


def linear_input_test(prob: Problem, noise: NoiseModel, base: Hypothesis, base_fit: Fit,
                      h: Hypothesis, ft: Fit) -> dict[str, Any]:
    """LR test of hypothesis ``h`` (fitted: ``ft``) against ``base`` (``base_fit``), both
    with OP's FIR of :class:`WithLinearInput`, on the validation blocks' innovations under
    ``noise``; ``h`` keeps its fitted parameters, every linear coefficient is refitted on
    the training blocks. ``df`` is ``h``'s extra parameters over ``base``."""
    def innovations(hyp: Hypothesis, fit: Fit) -> float:
        pr = prob.with_ctx(fit.ctx if fit.ctx is not None else prob.ctx).with_noise(noise)
        lin = fit_at(pr, WithLinearInput(hyp), fit.p)
        e = noise.whiten(lin.resid)[prob.val]
        return float(np.mean(e * e))

    v0, v1 = innovations(base, base_fit), innovations(h, ft)
    df = max(1, ft.n_params - base_fit.n_params)
    return lr_test(v0, v1, prob.val.size, df)
