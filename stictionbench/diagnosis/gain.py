"""The loop's gain measured through its set-point moves, against the model's gain.

Every hypothesis of the diagnosis fits the process gain freely (:mod:`.hypotheses`), so
that a gain error is never blamed on a valve, a sensor or a disturbance. That leaves one
piece of missing physics unseen: an installed valve characteristic whose slope at the
operating point differs from the model's linear valve, over an OP range too narrow for
the curve itself to show — to the recording, a gain error. The gain a fit estimates from
closed-loop data is not a measurement of it: OP reacts to the unmeasured load and to the
measurement noise, and a least-squares (or prediction-error) gain under a misspecified
noise model is biased by that correlation (Ljung, *System Identification*, 1999,
§13.4); a test of that gain against the model's rejected healthy loops 8–50 % of the
time at α = 0.001 (the closing note of the issue that added this module).

The instrumental-variable method removes that bias (Söderström & Stoica, *System
Identification*, 1989, ch. 8; Ljung 1999, §7.6): the instrument is a signal correlated
with the regressor and not with the load or the noise. The set point is such a signal in
closed loop — it is chosen by the operator, outside the loop (Gilson & Van den Hof,
*Automatica* 41 (2005) 241). Here the instrument is the nominal model's response to the
recorded OP that the nominal loop (the model's process under its PI, no load, no noise)
would have produced from the recorded set point alone: the noise-free part of the
regressor, the near-optimal instrument. The estimate is refined under the AR noise model
of its own residual (:func:`.noise.fit_noise_model`: instruments, regressor and PV
pre-filtered by ``H⁻¹``, the simplified refined IV of Young, *Automatica* 12 (1976)),
whose residual variance gives its standard error.

Decision, used only where the comparison named nothing (:func:`.diagnose.name_gain_error`):
``valve_characteristic`` when the gain ratio differs from 1 at level :data:`GAIN_ALPHA`
*and* by at least :data:`GAIN_TOLERANCE`. Both were set on the three tuning families of
``experiments/concealed.py`` before the rule met any other data: across 72 of their
healthy loops (seeds 100–111) the largest ``|ln(ratio)|`` was 0.107 (a ratio of 0.90 or
1.11), so a 15 % gain error is the smallest the rule names. At the benchmark's own seeds
(0–11, ``experiments/setpoint_gain.py``) the largest is 0.136, just under the
tolerance's 0.140: the margin is thin, and no healthy loop there is flagged. Before the
tolerance was fixed its flags on the independent sets A–C were also looked at, at 1.10
and at 1.15 (1.10 added four false alarms there, 1.15 one), so those sets are in-sample
for it; the holdout family's block
40000 and the independent sets D and E (fresh seeds of the same two generators) were drawn
after it was fixed (``experiments/setpoint_gain.py``, ``make independent``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.stats import norm

from ..sim.blocks import FOPDT
from ..sim.kernel import run_loop
from ..sim.valves import LinearValve, init_state
from .noise import fit_noise_model
from .openloop import fopdt_response
from .strict_json import finite_or_none, finite_values

if TYPE_CHECKING:  # pragma: no cover
    from .diagnose import Comparison

#: level of the test of ``gain ratio = 1`` (two-sided)
GAIN_ALPHA = 0.01
#: the smallest gain ratio (either way) the rule names: set on the tuning families'
#: healthy loops (module docstring)
GAIN_TOLERANCE = 1.15
#: the interval's coverage
INTERVAL_LEVEL = 0.95
#: travel and output limits of the simulated nominal loop: none
_FREE = 1e12


@dataclass
class GainTest:
    """Outcome of :func:`setpoint_gain`; ``reason`` says why it did not apply."""

    applicable: bool
    reason: str
    gain_given: float = math.nan
    gain_measured: float = math.nan
    ratio: float = math.nan
    interval: tuple[float, float] = (math.nan, math.nan)
    p_value: float = 1.0
    #: correlation of the pre-filtered instrument with the pre-filtered regressor (how
    #: much of OP's effect the set point explains; a weak instrument gives a wide interval)
    instrument_correlation: float = math.nan
    #: validation NRMSE of the nominal model with the given gain and with the measured
    nrmse_given: float = math.nan
    nrmse_measured: float = math.nan
    significant: bool = False
    #: band-passed PV and the nominal model's prediction with the measured gain (for the
    #: report's figures; not in JSON)
    y: np.ndarray | None = field(default=None, repr=False)
    pred: np.ndarray | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        out = finite_values({f.name: getattr(self, f.name) for f in fields(self) if f.repr})
        out["interval"] = [finite_or_none(float(v)) for v in self.interval]
        return out | {"alpha": GAIN_ALPHA, "tolerance": GAIN_TOLERANCE}


def setpoint_response_op(sp: np.ndarray, gain: float, tau: float, theta: float, kc: float,
                         ti: float, Ts: float) -> np.ndarray:
    """OP (deviation) of the nominal loop — FOPDT ``(gain, τ, θ)`` under the PI
    ``(kc, ti)`` executed at ``Ts``, linear valve, no load and no noise — driven by the
    set point's moves ``sp − sp[0]`` (:func:`stictionbench.sim.kernel.run_loop`)."""
    proc = FOPDT(gain=gain, time_constant=tau, dead_time=theta).coefficients(Ts)
    ctrl = np.array([kc, ti, Ts, -_FREE, _FREE, 0.0])
    kind, vp, post = LinearValve(travel_low=-_FREE, travel_high=_FREE).encode()
    state = init_state(kind, vp, 0.0)
    zero = np.zeros(sp.size)
    out = run_loop(np.asarray(sp, float) - float(sp[0]), zero, zero, 1, Ts, 1, proc, ctrl,
                   kind, vp, state, post, 0.0, 0.0)
    return out[:, 2]


def setpoint_gain(cmp: Comparison) -> GainTest:
    """The process gain by instrumental variables with the set point as the instrument,
    against the given model's gain (see the module docstring).

    Applies to a given model with its PI (or the PI identified from the recording) on a
    recording whose set point moves. The regressor and the instrument are the nominal
    model's unit-gain response (its time constant, its aligned dead time) to the recorded
    OP and to the nominal loop's OP, band-passed like PV for the comparison; samples
    after the burn-in.
    """
    rec, m, ctx, prob = cmp.rec, cmp.model, cmp.ctx, cmp.prob
    if m.source != "given":
        return GainTest(False, "no model given: the gain is identified from the recording")
    if rec.SP is None or np.ptp(np.asarray(rec.SP, float)) <= 0:
        return GainTest(False, "the set point does not move: nothing outside the loop "
                               "to measure the gain with")
    if m.kc is None or m.ti is None or not (m.kc * m.gain > 0 and m.ti > 0):
        return GainTest(False, "no PI controller forming a negative feedback loop with "
                               "the model")
    theta = ctx.theta + cmp.nominal.extra.get("timing_shift_s", 0.0)
    op_sp = setpoint_response_op(np.asarray(rec.SP, float), m.gain, m.time_constant,
                                 m.dead_time, m.kc, m.ti, rec.Ts)
    if not np.all(np.isfinite(op_sp)):
        return GainTest(False, "the nominal loop is unstable under its PI")

    def regressor(u: np.ndarray) -> np.ndarray:
        return prob.band(fopdt_response(u, ctx.Ts, ctx.tau, theta), ctx.Ts, prob.f_hp,
                         prob.f_lp)

    x, z, y = regressor(ctx.op), regressor(op_sp), prob.y
    idx = np.arange(cmp.burn, y.size)
    den = float(z[idx] @ x[idx])
    if not den or not np.isfinite(den):
        return GainTest(False, "the set point's moves do not reach OP")
    k = float(z[idx] @ y[idx]) / den
    noise = fit_noise_model((y - k * x)[idx], family=cmp.noise_family)
    yw, xw, zw = noise.whiten(y), noise.whiten(x), noise.whiten(z)
    iw = idx[idx >= cmp.burn + noise.inverse().size]
    den = float(zw[iw] @ xw[iw])
    if not den:
        return GainTest(False, "the set point's moves do not reach OP")
    k = float(zw[iw] @ yw[iw]) / den
    e = yw[iw] - k * xw[iw]
    se = math.sqrt(float(np.mean(e * e)) * float(zw[iw] @ zw[iw])) / abs(den)
    g = float(m.gain)
    q = norm.ppf(0.5 + INTERVAL_LEVEL / 2)
    lo, hi = sorted(((k - q * se) / g, (k + q * se) / g))
    p = float(2 * norm.sf(abs(k - g) / se)) if se > 0 else (0.0 if k != g else 1.0)
    ratio = k / g
    val = prob.val
    sy = float(np.std(y[val])) or 1.0

    def nrmse(gain: float) -> float:
        return math.sqrt(float(np.mean((y[val] - gain * x[val]) ** 2))) / sy

    sig = bool(p < GAIN_ALPHA and ratio > 0
               and abs(math.log(ratio)) >= math.log(GAIN_TOLERANCE))
    return GainTest(True, "measured", g, k, ratio, (lo, hi), p,
                    float(np.corrcoef(zw[iw], xw[iw])[0, 1]), nrmse(g), nrmse(k), sig,
                    y, k * x)
