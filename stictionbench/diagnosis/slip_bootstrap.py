"""A closed-loop parametric bootstrap of the slip-jump test (stiction against dead band).

The test of ``J = 0`` from the closed-loop valve identification
(:func:`.hammerstein.fit_hammerstein`) compares its profile likelihood ratio with χ²₁.
In closed loop, with a drifting load, a rugged criterion over ``J`` and three stop rules,
that reference is far off: on loops simulated with a dead band by construction the
identification rejects ``J = 0`` at the 5 % level about half the time
(``reports/concealed/slip_jump_bootstrap.md``). The calibrated alternative simulates the
null (Efron & Tibshirani, *An Introduction to the Bootstrap*, 1993, ch. 16; the AR sieve
of Bühlmann, *Bernoulli* 3 (1997) 123): the loop as the dead-band hypothesis says it is —
the given FOPDT with the gain and dead-time shift the dead band's fit chose, behind a play
operator of the fitted width, under the given PI on the recorded set point — with an
output disturbance resampled from the dead band's own residual, identified ``B`` times
exactly as the recording was. The p-value ``(1 + #{null statistic ≥ observed})/(B + 1)``
gives an exact Monte Carlo test: reject ``J = 0`` at level α when it is ``≤ α``
(Davison & Hinkley, *Bootstrap Methods and their Application*, 1997, ch. 4.2).

It needs a given model with its PI (``kc``, ``ti``) and the set point, and costs ``B``
identifications (about 0.4 s each for 3000 samples): ``diagnose --slip-jump-bootstrap B``
asks for it; the default stays the χ²₁ test.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.signal import lfilter

from ..errors import InputError
from ..recording import Recording
from .hammerstein import HammersteinResult, _dead_band_fit, fit_hammerstein, rule_valve
from .model import NominalModel
from .noise import fit_noise_model
from .openloop import fopdt_coefficients, fopdt_response

#: the least number of null recordings: with fewer, a p-value of 0.05 is out of reach
MIN_B = 19
#: the most null recordings a request may ask for: at about 0.4 s each, 9999 take an hour
#: (999 give a p-value resolved to 0.001, Davison & Hinkley 1997, ch. 4.2)
MAX_B = 9999


def sieve_disturbance(r: np.ndarray, n: int, rng: np.random.Generator,
                      d_extra: int = 0, burn: int = 200) -> np.ndarray:
    """An output disturbance like ``r`` by the AR sieve (Bühlmann 1997): ``r``'s noise model
    (:func:`.noise.fit_noise_model`, AR order by BIC, integrated or not) driven by its own
    innovations resampled with replacement, integrated ``d_extra`` more times than fitted.

    Examples
    --------
    >>> r = np.cumsum(np.random.default_rng(0).normal(size=500))
    >>> v = sieve_disturbance(r, 500, np.random.default_rng(1))
    >>> v.shape, float(v[0]) == float(r[0])
    ((500,), True)
    """
    nm = fit_noise_model(r)
    x = np.diff(r) if nm.integrated else r
    for _ in range(d_extra):
        x = np.diff(x)
    eps = lfilter(nm.ar, [1.0], x - x.mean())[nm.order:]
    v = lfilter([1.0], nm.ar, rng.choice(eps, size=n + burn))
    for _ in range(int(nm.integrated) + d_extra):
        v = np.cumsum(v)
    v = v[burn:]
    return v - v[0] + r[0]


def dead_band_loop(K: float, tau: float, theta: float, kc: float, ti: float, width: float,
                   sp: np.ndarray, v: np.ndarray, op0: float, pv0: float,
                   Ts: float) -> tuple[np.ndarray, np.ndarray]:
    """PV and OP of a loop with a dead band: ``PV = pv0 + K·G(MV − op0) + v``, ``MV`` the
    play operator of ``width`` on OP, a PI (velocity form, OP clipped to 0–100) acting on
    ``SP − PV`` every sample; ``G`` the FOPDT ``e^{−θs}/(τs + 1)`` with a zero-order hold.
    """
    b, a = fopdt_coefficients(Ts, tau, theta)
    d = b.size - 3
    b1, b2, pole = float(b[d + 1]), float(b[d + 2]), float(-a[1])
    n = sp.size
    u, y, dm = np.empty(n), np.empty(n), np.zeros(n)
    x = e_prev = 0.0
    mv, h = op0, 0.5 * width
    for k in range(n):
        acc = (b1 * dm[k - d - 1] if k > d else 0.0) + (b2 * dm[k - d - 2] if k > d + 1
                                                         else 0.0)
        x = pole * x + acc
        y[k] = pv0 + K * x + v[k]
        e = sp[k] - y[k]
        u[k] = op0 if k == 0 else min(max(u[k - 1] + kc * ((e - e_prev) + Ts * e / ti),
                                          0.0), 100.0)
        mv = min(max(mv, u[k] - h), u[k] + h)
        dm[k] = mv - op0
        e_prev = e
    return y, u


def check_request(rec: Recording, model: NominalModel | None, B: int,
                  seed: int = 0) -> None:
    """Refuse a bootstrap that cannot run, before any fitting: fewer than :data:`MIN_B`
    or more than :data:`MAX_B` null recordings, a negative seed, no given model with its
    PI, or no set point."""
    if B < MIN_B:
        raise InputError(f"--slip-jump-bootstrap needs at least {MIN_B} null recordings, "
                         f"got {B}")
    if B > MAX_B:
        raise InputError(f"--slip-jump-bootstrap: at most {MAX_B} null recordings (about "
                         f"0.4 s each), got {B}")
    if seed < 0:
        raise InputError(f"--bootstrap-seed: expected a seed >= 0, got {seed}")
    if model is None or model.kc is None or model.ti is None or rec.SP is None:
        raise InputError("--slip-jump-bootstrap needs --model with the PI (kc, ti) and a "
                         "recorded set point: the null loop is the given model's")


def bootstrap_slip_jump(rec: Recording, model: NominalModel, h: HammersteinResult, *,
                        B: int, hp_factor: float, seed: int = 0,
                        keep_null: bool = False) -> dict[str, Any]:
    """The bootstrap p-value of ``J = 0`` for the identification ``h`` of ``rec`` against
    ``model`` (held process; see the module docstring).

    Parameters
    ----------
    rec : Recording
        Needs ``SP``.
    model : NominalModel
        The given model, with ``kc`` and ``ti``.
    h : HammersteinResult
        :func:`.hammerstein.fit_hammerstein` of ``rec`` with the process held at
        ``model`` (as :func:`.diagnose.diagnose` runs it); a valve identified (``S > 0``).
    B : int
        Null recordings (at least :data:`MIN_B`).
    hp_factor : float
        The identification's high-pass factor (the one ``h`` was fitted with).
    seed : int
        Seed of the resampling (the same inputs give the same p-value).
    keep_null : bool
        Also return the null statistics (``null``).

    Returns
    -------
    dict
        ``p_bootstrap``, ``B``, ``null_q95`` (the null statistic's 95th percentile),
        ``dead_band_width`` (the null loop's band, % of OP), ``seed``.
    """
    check_request(rec, model, B)
    if h.criterion is None or h.S <= 0:
        raise InputError("the slip-jump bootstrap needs an identified valve")
    _, q0 = _dead_band_fit(h.criterion, h.estimate)
    width, theta0 = float(q0[0]), float(q0[4])
    K0 = float(h.criterion.simulate(*q0)[0])
    pv, op, sp = (np.asarray(a, float) for a in (rec.PV, rec.OP, rec.SP))
    mv = rule_valve(op, width, 0.0, 0)
    r = pv - pv[0] - K0 * fopdt_response(mv - mv[0], rec.Ts, model.time_constant, theta0)
    rng = np.random.default_rng([seed, B])
    stat = float(h.tests["slip_jump_zero"]["statistic"])
    linear = (model.gain, model.time_constant, model.dead_time)
    null = np.empty(B)
    for i in range(B):
        y, u = dead_band_loop(K0, model.time_constant, theta0, model.kc, model.ti, width, sp,
                              sieve_disturbance(r, pv.size, rng), float(op[0]),
                              float(pv[0]), rec.Ts)
        hn = fit_hammerstein(Recording.from_arrays(rec.t, y, u, sp, warn=False),
                             alpha=h.alpha, linear=linear, fix_process=True,
                             hp_factor=hp_factor)
        null[i] = float(hn.tests["slip_jump_zero"]["statistic"])
    out: dict[str, Any] = {
        "p_bootstrap": float((1 + int((null >= stat).sum())) / (B + 1)), "B": int(B),
        "null_q95": float(np.quantile(null, 0.95)), "dead_band_width": width,
        "seed": int(seed)}
    if keep_null:
        out["null"] = null.tolist()
    return out
