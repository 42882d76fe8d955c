"""The smallest effects a recording can show: the minimum detectable effect of each
OP-driven hypothesis under the diagnosis's own tests.

A diagnosis that answers ``none`` says the nominal model explains the record; it does not
say how large a dead-time error, a transmitter lag or a sticky valve could be and still
go unseen. That depends on the record: how much OP moved and at which frequencies, how
long it is, and the noise and load the noise model describes. This module answers it for
the record at hand, without knowing any truth, by asking what the tests the diagnosis
ran would have seen had the effect been there.

For an effect of size ``s`` (a dead time longer or shorter by ``s`` seconds, a sensor lag
of ``s`` seconds, a dead band of width ``s`` or stiction with ``S = s`` and ``J = s/2``,
in OP's units), the prediction it adds to the nominal model's is replayed from the
recorded OP through the nominal dynamics, at the nominal model's fitted gain, and passed
through the tests' own filter and noise model (:mod:`.evidence`):

- **power of the likelihood-ratio test.** Under a local alternative the statistic
  ``N·ln(V₀/V₁)`` is approximately non-central χ² with the alternative's degrees of
  freedom and non-centrality ``λ = Σ ε_d² / σ²``, ``ε_d`` the effect's one-step
  prediction errors on the validation blocks and ``σ²`` the nominal model's innovation
  variance there (Ljung, *System Identification*, 1999, ch. 9.2 and 16.4; Lehmann &
  Romano, *Testing Statistical Hypotheses*, 2005, ch. 13.2); likewise the ``k``-step test
  with ``N/k`` samples. The diagnosis takes the smaller of the two p-values, Bonferroni-
  corrected, so each is referred to ``alpha/2`` and the larger power is kept (a lower
  bound of the pair's);
- **what the nominal model absorbs.** The diagnosis aligns the nominal model within
  one sample of its dead time and refits its gain (:data:`.hypotheses.NOMINAL_ALIGNMENT`):
  only the part of the effect's prediction that none of those nominal predictions
  explains is seen (the non-centrality of a test with nuisance parameters), which
  matters for lags and delays of a sample or two;
- **the NRMSE gate.** With the effect present the nominal model's validation error grows
  from ``v`` (its present mean square in the comparison band) to ``v + mean(d²)``, ``d``
  the effect's band-passed prediction: the hypothesis improves the NRMSE by
  ``1 − √(v / (v + mean(d²)))``, which must reach the gate the diagnosis applied (for a
  dead time judged by its own resolution, :func:`.evidence.passes`, a change of more than
  one sample instead).

The minimum detectable effect is the smallest ``s`` whose power reaches :data:`POWER` and
that clears the gate (a geometric scan over the hypothesis's search range, then a
bisection); ``None`` when none in that range does. ``limited_by`` says what a slightly
smaller effect fails: the power (a longer or quieter record would show it) or the gate
(which a longer record does not lower: the NRMSE gate asks the effect for a share of
the residual, not a number of samples), or the resolution (a dead time within one
sample of the model's is never named); ``range`` when the smallest effect scanned
already passes. It assumes the fitted parameters land
near the true ones and that no rival hypothesis explains the effect better: it bounds the
*test*, not the naming (a dead time the test sees may still be named a sensor lag).
``experiments/detectable_effects.py`` checks it against the truth of the independent
concealed sets, where nothing here was set: the minimum read from each recording's
healthy twin (the same loop, noise and load without the effect) against the effect the
faulty recording carries, and the noise varied on the paper's loop
(``reports/concealed/detectable_effects.md``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.stats import chi2, ncx2

from .evidence import Verdict, output_error
from .fit import Fit
from .hypotheses import HYPOTHESES, NOMINAL_ALIGNMENT, Context, Nominal
from .openloop import fopdt_response, likelihood_highpass

#: power at which an effect counts as detectable (the usual convention of power analysis)
POWER = 0.8
#: stiction's slip jump as a fraction of ``S`` for its minimum detectable ``S`` (Kano's
#: model, stopping on OP reversals)
STICTION_J_OVER_S = 0.5
#: points of the geometric scan over each effect's range, and bisection steps after it
SCAN_POINTS = 12
BISECTIONS = 7

#: the effects scanned: key in the output, hypothesis, unit
EFFECTS = (("dead_time_longer", "dead_time", "s"), ("dead_time_shorter", "dead_time", "s"),
           ("sensor_lag", "sensor_lag", "s"), ("deadband", "deadband", "OP"),
           ("stiction_S", "stiction", "OP"))


def _range(key: str, name: str, ctx: Context) -> tuple[float, float] | None:
    """The effect sizes scanned: the hypothesis's own search range (its bounds), a
    dead-time change from a quarter sample up to the range's end either way."""
    lo, hi = HYPOTHESES[name].bounds(ctx)[0]
    if key == "dead_time_longer":
        return ctx.Ts / 4, hi - ctx.theta
    if key == "dead_time_shorter":
        return (ctx.Ts / 4, ctx.theta - lo) if ctx.theta > ctx.Ts else None
    return lo, hi


def _parameters(key: str, ctx: Context, s: float) -> np.ndarray:
    if key == "dead_time_longer":
        return np.array([ctx.theta + s])
    if key == "dead_time_shorter":
        return np.array([max(ctx.theta - s, 0.0)])
    if key == "stiction_S":
        return np.array([s, STICTION_J_OVER_S * s, 0.0])
    return np.array([s])


def minimum_detectable(ctx: Context, band, f_hp: float | None, f_lp: float | None,
                       nominal: Fit, verdict: Verdict, val: np.ndarray, *, alpha: float,
                       gate: float, highpass_order: int = 2,
                       power: float = POWER) -> dict[str, Any]:
    """The smallest dead-time change, sensor lag, dead band and stiction ``S`` that the
    diagnosis's tests would have seen on this record (see the module docstring).

    Parameters
    ----------
    ctx : Context
        The recording and the nominal dynamics (:class:`.hypotheses.Context`).
    band : callable
        The comparison band ``band(x, Ts, f_hp, f_lp)`` (:func:`.openloop.band_of`).
    f_hp, f_lp : float or None
        Its corners (Hz).
    nominal : Fit
        The nominal model's fit (its gain and its band-passed residual).
    verdict : Verdict
        The tests' outcome (:class:`.evidence.Verdict`): their noise model, the nominal
        model's innovation variance on the validation blocks and the hypotheses judged by
        their own resolution (:func:`.evidence.passes`).
    val : ndarray
        Indices of the validation samples.
    alpha, gate : float
        The tests' level and the NRMSE gate the diagnosis applied.
    highpass_order : int
        The high-pass of the output errors the tests whitened (2: the band's).
    power : float
        Power at which an effect counts as detectable.

    Returns
    -------
    dict
        ``power``, ``alpha``, ``gate`` and ``effects``: per effect ``{"minimum": value or
        None, "unit": "s" or "OP", "searched_up_to": the range's end, "limited_by": the
        conditions a slightly smaller effect fails}``; the dead-time changes also give
        ``from_dead_time_s`` (the delay the record shows: the model's, aligned by the
        nominal fit's timing shift, from which the change is counted) and
        ``model_dead_time_s``.

    References
    ----------
    Ljung, *System Identification* (1999), ch. 9.2 and 16.4; Lehmann & Romano, *Testing
    Statistical Hypotheses* (2005), ch. 13.2.
    """
    theta_model = ctx.theta  # the dead time's resolution is judged against the model's
    ctx = nominal.ctx if nominal.ctx is not None else ctx  # with its timing alignment
    Ts = ctx.Ts
    beta = float(nominal.beta[0])
    horizon = max(1, int(round((ctx.tau + ctx.theta) / Ts)))
    if highpass_order == 2:
        def test_filter(x):
            return band(x, Ts, f_hp)
    else:
        def test_filter(x):
            return likelihood_highpass(x, Ts, f_hp, highpass_order)
    noise, own_resolution = verdict.noise, verdict.own_resolution
    s1 = verdict.variances["none"]["validation"] or 1e-300
    sk = 0.0
    if horizon > 1:
        e0 = output_error(nominal, ctx.pv, Ts, f_hp, highpass_order)
        sk = float(np.mean(noise.kstep(e0, horizon)[val] ** 2)) or 1e-300
    v = float(np.mean(nominal.resid[val] ** 2)) or 1e-300
    level = alpha / 2 if horizon > 1 else alpha

    # the nuisance: the nominal model, its gain refitted, at every alignment the
    # diagnosis tries (.hypotheses.NOMINAL_ALIGNMENT); an effect is seen only in the part
    # of it that none of them absorbs (the non-centrality of a test with nuisance
    # parameters)
    views = {"one": lambda x: noise.whiten(test_filter(x))[val],
             "band": lambda x: band(x, Ts, f_hp, f_lp)[val]}
    if horizon > 1:
        views["k"] = lambda x: noise.kstep(test_filter(x), horizon)[val]
    nuisance = {k: [] for k in views}
    for a in NOMINAL_ALIGNMENT:
        if theta_model + a * Ts < 0:
            continue
        x0 = fopdt_response(ctx.op, Ts, ctx.tau, theta_model + a * Ts)
        for k, f in views.items():
            b = f(x0)
            nuisance[k].append(b / (math.sqrt(float(b @ b)) or 1.0))

    def unexplained(k: str, d: np.ndarray) -> float:
        """Mean square of the view ``k`` of ``d`` left by its best nominal alignment."""
        a = views[k](d)
        # a residual energy: never below 0, which rounding reaches when d lies in the
        # nuisance's span (a noise-free record replayed exactly: a math domain error before)
        return max(0.0, float(a @ a) - max(float(a @ b) ** 2 for b in nuisance[k])) / a.size

    def failing(key: str, name: str, s: float) -> list[str]:
        """The conditions an effect of size ``s`` fails (empty: detectable)."""
        h = HYPOTHESES[name]
        p = _parameters(key, ctx, s)
        if name == "dead_time" and abs(float(p[0]) - theta_model) <= Ts:
            return ["resolution"]  # within a sample of the model's: never named (at_bound)
        d = h.regressors(ctx, p)[:, 0] * beta
        df = max(1, h.n_params() - Nominal().n_params())
        crit = chi2.isf(level, df)
        pw = float(ncx2.sf(crit, df, val.size * unexplained("one", d) / s1))
        if horizon > 1:
            lam_k = (val.size / horizon) * unexplained("k", d) / sk
            pw = max(pw, float(ncx2.sf(crit, df, lam_k)))
        improvement = 1.0 - math.sqrt(v / (v + unexplained("band", d)))
        cleared = improvement > 0.0 if name in own_resolution else improvement >= gate
        return ([] if pw >= power else ["power"]) + ([] if cleared else ["gate"])

    effects: dict[str, Any] = {}
    for key, name, unit in EFFECTS:
        rng = _range(key, name, ctx)
        if rng is None or rng[1] <= rng[0]:
            continue
        found, prev, why = None, None, ["range"]
        for s in np.geomspace(rng[0], rng[1], SCAN_POINTS):
            w = failing(key, name, float(s))
            if not w:
                found = float(s)
                break
            prev, why = float(s), w
        if found is not None and prev is not None:
            lo, hi = prev, found
            for _ in range(BISECTIONS):
                mid = math.sqrt(lo * hi)
                w = failing(key, name, mid)
                if w:
                    lo, why = mid, w
                else:
                    hi = mid
            found = hi
        if name == "dead_time":
            # the change is from the delay the record shows (the model's, aligned by the
            # timing shift the nominal fit chose), not from the model's own
            effects[key] = {"from_dead_time_s": float(ctx.theta),
                            "model_dead_time_s": float(theta_model)}
        effects[key] = {**effects.get(key, {}), "minimum": found, "unit": unit,
                        "searched_up_to": float(rng[1]),
                        # what a slightly smaller effect fails: "power" (a longer or
                        # quieter record would show it), "gate" (the NRMSE gate, which
                        # record length does not lower), "resolution" (one sample);
                        # "range": the smallest effect scanned already passes
                        "limited_by": why}
    return {"power": power, "alpha": alpha, "gate": gate, "effects": effects}
