"""Closed-loop Hammerstein identification of a sticky valve from PV and OP alone.

The loop's forward path is modelled as a two-parameter stick-slip valve (Kano et al. 2004:
dead band plus stick band ``S``, slip jump ``J``, both in % of OP) in series with a FOPDT
process ``K e^{−θs}/(τs + 1)``; the valve position MV is never needed. For every valve
candidate the process is identified again from the valve output it implies — the process
is never identified through the valve that may stick (Srinivasan, Rengaswamy, Narasimhan &
Miller, *Ind. Eng. Chem. Res.* 44 (2005) 6719; Jelali, *J. Process Control* 18 (2008)
632; Karra & Karim, *Control Eng. Practice* 17 (2009) 939: Hammerstein structure, valve
parameters by a global search, the linear part re-identified for each).

Criterion: the prediction-error method (Ljung, *System Identification*, 1999, ch. 7):
the one-step prediction errors ``ε = H⁻¹(q)(y − K·G(valve(OP)))`` with an AR (or
integrated AR) noise model ``H`` (:mod:`.noise`) times a fixed causal high-pass prefilter
at ``0.3/(2π(τ + θ))`` (2nd-order Butterworth, applied to PV and every regressor) so that
a load slower than the loop is not fitted as physics. Steps:

1. output-error fits (``H = 1``): the linear loop (``S = J = 0``), then a grid over
   ``S``, ``J/S``, the valve's stop rule and the process time constant, and Nelder–Mead
   over ``(S, J, τ, θ)`` from the best grid points, ``K`` solved by least squares at
   every evaluation (a separable problem);
2. the noise model ``H`` of the valve model's output error (the larger model: a limit
   cycle the linear model leaves unexplained is not absorbed into ``H``), then both the
   linear and the valve model refined under it;
3. the likelihood-ratio test of the valve against the linear loop on the whitened
   innovations (``N·ln(V_lin/V_valve)``, χ² with 3 degrees of freedom: S, J and the stop
   rule), and the profile-likelihood ``1 − α`` intervals of ``S`` and ``J`` (``J = 0``
   tested by its own profile: stiction rather than a dead band when it is excluded);
4. the simulation NRMSE users understand on held-out blocks (after a burn-in the record
   is cut in five blocks; 1, 3, 5 train, 2 and 4 validate).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize
from scipy.signal import butter, lfilter
from scipy.stats import chi2

from ..errors import InputError
from ..recording import Recording
from .blocks import N_BLOCKS, split_blocks
from .noise import WHITE, NoiseModel, fit_noise_model, input_independence, ljung_box, lr_test
from .openloop import fopdt_biquad, fopdt_coefficients, stiction_valve
from .process import fit_fopdt

#: a slip jump smaller than this fraction of S is below what sampled closed-loop data
#: resolve against the model error of a discrete replay (set on the ``sim_physical``
#: benchmark family, see ``experiments/concealed.py``): the diagnosis calls such a valve a
#: dead band (:func:`.evidence.select`)
MIN_SLIP_FRACTION = 0.1

#: ``tests.slip_jump_zero.method`` of the default test: the likelihood ratio of ``J = 0``
#: referred to χ²₁. Not calibrated on closed-loop data: true dead bands reject ``J = 0``
#: far more often than α (``reports/concealed/slip_jump_calibration.md``); a calibrated
#: p-value is ``diagnose --slip-jump-bootstrap B`` (``method = "bootstrap"``).
SLIP_JUMP_ASYMPTOTIC = "chi2_asymptotic"

#: stop rules of the sampled stick-slip valve (see :func:`.openloop.stiction_valve`):
#: stop only when OP reverses (Kano), or at every sample (a valve driven by a noisy
#: controller output, whose OP reverses between two recorded samples), or on reversals
#: with Choudhury et al.'s (2005) restart: after a reversal ``S`` either way, not ``J``.
#: The every-sample rule is also He et al.'s (2007) residual-force law on sampled data
#: (:class:`stictionbench.sim.valves.HeValve` gives the same positions to rounding,
#: ``tests/test_hammerstein.py``): the search covers the Kano and He types
STOP_RULES = ("reversal", "every_sample", "choudhury")
CHOUDHURY = STOP_RULES.index("choudhury")
#: Choudhury's restart is searched with ``J ≥ CHOUDHURY_MIN_SLIP·S`` only: at ``J = 0`` the
#: two-parameter model is a dead band by its own definition (Choudhury et al. 2005), and
#: the dead band the diagnosis tests is the play operator (the other rules' ``J = 0``),
#: not a valve that, under a jittering OP, advances in steps of ``S``. The floor is
#: :data:`MIN_SLIP_FRACTION`, the resolution below which a fitted slip jump is
#: called a dead band anyway
CHOUDHURY_MIN_SLIP = MIN_SLIP_FRACTION
#: high-pass cut-off in units of 1/(2π(τ+θ)) of the linear loop (slow-load rejection)
HP_FACTOR = 0.3


def searched_rules(process_held: bool) -> tuple[int, ...]:
    """The stop rules searched: Choudhury's restart only with the process held at a
    given model (see :func:`fit_hammerstein`)."""
    return tuple(r for r in range(len(STOP_RULES)) if process_held or r != CHOUDHURY)


def _j_floor(rule: int) -> float:
    """The least ``J/S`` searched with a stop rule (:data:`CHOUDHURY_MIN_SLIP`)."""
    return CHOUDHURY_MIN_SLIP if rule == CHOUDHURY else 0.0


def rule_valve(op: np.ndarray, S: float, J: float, rule: int) -> np.ndarray:
    """The sampled stick-slip valve of stop rule ``STOP_RULES[rule]`` driven by ``op``
    (:func:`.openloop.stiction_valve`)."""
    name = STOP_RULES[rule]
    return stiction_valve(op, S, J, math.inf if name == "every_sample" else 0.0,
                          name == "choudhury")


@dataclass
class HammersteinResult:
    """The fitted valve and process, the evidence for the valve and its intervals."""

    S: float
    J: float
    S_interval: list[float]
    J_interval: list[float]
    stop_rule: str
    process: dict[str, float]
    linear_process: dict[str, float]
    innovation_variance: dict[str, float]
    tests: dict[str, Any]
    fit: dict[str, Any]
    noise_model: dict[str, Any]
    alpha: float
    seconds: float = 0.0
    mv: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    #: the valve model's process is physically the linear loop's: same sign of gain (a
    #: sticky valve does not reverse the process) and a time constant off the lower end
    #: of its search range (there the optimiser found no process, only a fast fit)
    consistent: bool = True
    #: the identification's criterion and estimate ``(S, J, rule, τ, θ)``, for a test that
    #: refits around them (:mod:`.slip_bootstrap`); not serialised
    criterion: Any = field(default=None, repr=False)
    estimate: tuple = field(default=(), repr=False)

    @property
    def stiction(self) -> bool:
        """Valve significantly better than the linear loop *and* the ``1 − α`` interval of
    ``J`` excludes 0 (the profile test of ``J = 0`` at level ``α``), with a
    :attr:`consistent` process."""
        return bool(self.sticky and self.tests["slip_jump_zero"]["p_value"] <= self.alpha)

    @property
    def sticky(self) -> bool:
        """Valve significantly better than the linear loop (stiction or a dead band), with
        a :attr:`consistent` process."""
        return bool(self.tests["valve_vs_linear"]["p_value"] < self.alpha
                    and self.fit["improvement"] > 0.0 and self.consistent)

    def to_dict(self) -> dict[str, Any]:
        return {"S": self.S, "J": self.J, "S_interval": self.S_interval,
                "J_interval": self.J_interval, "stop_rule": self.stop_rule,
                "process": self.process, "linear_process": self.linear_process,
                "innovation_variance": self.innovation_variance, "tests": self.tests,
                "fit": self.fit, "noise_model": self.noise_model, "alpha": self.alpha,
                "interval_level": 1.0 - self.alpha,
                "stiction": self.stiction, "sticky_valve": self.sticky,
                "process_consistent": self.consistent,
                "seconds": self.seconds}


class _Criterion:
    """Prediction-error criterion of one recording for a given noise model."""

    def __init__(self, op: np.ndarray, pv: np.ndarray, Ts: float, f_hp: float,
                 train: np.ndarray, val: np.ndarray) -> None:
        self.op, self.Ts, self.f_hp = op, Ts, f_hp
        # causal 2nd-order Butterworth high-pass: a fixed part of the noise model
        # (prefiltering ≡ noise model, Ljung ch. 14.4), folded into every regressor's
        # filter so that one lfilter call per evaluation does both
        self.hp = butter(2, min(f_hp * 2 * Ts, 0.5), "highpass")
        self.y = lfilter(*self.hp, pv - pv[0])
        self.train, self.val = train, val
        self.span = float(np.ptp(op)) or 1.0
        self.set_noise(WHITE)
        self.evaluations = 0
        #: hold the process at the given (τ, θ) (a nominal model the user trusts)
        self.fixed = False
        #: the given model's dead time (the held process's shifts are around it)
        self.theta_given = 0.0
        #: the best dead band found by :func:`_restart_from_dead_band` (J0_RESTART)
        self.dead_band_v = math.inf

    def set_noise(self, h: NoiseModel) -> None:
        self.noise = h
        self.yw = h.whiten(self.y)

    def valve(self, S: float, J: float, rule: int) -> np.ndarray:
        if S <= 0:
            return self.op
        return rule_valve(self.op, S, min(max(J, 0.0), 1.5 * S), rule)

    def regressor(self, mv: np.ndarray, tau: float, theta: float) -> np.ndarray:
        """High-passed unit-gain FOPDT response to the valve output ``mv``."""
        b, a = fopdt_coefficients(self.Ts, tau, theta)
        d = int(b.size - 3)
        x = mv if mv.ndim == 2 else mv[:, None]
        out = fopdt_biquad(np.ascontiguousarray(x, dtype=float), -a[1], b[d + 1], b[d + 2], d,
                           self.hp[0], self.hp[1])
        return out if mv.ndim == 2 else out[:, 0]

    def cost(self, S: float, J: float, rule: int, tau: float, theta: float) -> float:
        """Innovation variance on the training samples (``K`` by least squares)."""
        self.evaluations += 1
        g = self.regressor(self.valve(S, J, rule), tau, theta)
        gw = self.noise.whiten(g)[self.train]
        yw = self.yw[self.train]
        gg = float(np.dot(gw, gw))
        if gg <= 0 or not math.isfinite(gg):
            return 1e300
        K = float(np.dot(gw, yw)) / gg
        e = yw - K * gw
        return float(np.dot(e, e)) / e.size

    def simulate(self, S: float, J: float, rule: int, tau: float,
                 theta: float) -> tuple[float, np.ndarray, np.ndarray]:
        """Gain, simulated (high-passed) PV and valve output of a parameter set."""
        mv = self.valve(S, J, rule)
        g = self.regressor(mv, tau, theta)
        gw = self.noise.whiten(g)[self.train]
        K = float(np.dot(gw, self.yw[self.train])) / max(float(np.dot(gw, gw)), 1e-300)
        return K, K * g, mv


def _bounds(crit: _Criterion, tau0: float, theta0: float):
    T = crit.op.size * crit.Ts
    return (crit.Ts * 0.2, max(4 * tau0, T / 4)), (0.0, max(2 * theta0 + 5 * crit.Ts, T / 20))


def _exp_within(z: float, lo: float, hi: float) -> float:
    """``exp(z)`` clipped to ``[lo, hi]``: a search coordinate in logarithms mapped back.
    Nelder–Mead's simplex is unbounded, and on a flat criterion it can wander to a ``z``
    whose exponential overflows a float (seen on a simulated regulatory loop); the
    exponent is capped there, which maps to ``hi`` as any large ``z`` does."""
    return min(max(math.exp(min(z, 700.0)), lo), hi)


def _nelder_mead(crit: _Criterion, f, z0: np.ndarray, steps, maxiter: int
                 ) -> tuple[float, np.ndarray]:
    """Nelder–Mead of ``f`` from ``z0``, initial simplex ``z0 + steps[i]·eᵢ``; ``f`` is
    divided by the mean square of the (whitened) training PV, so that the stopping
    tolerance is relative and the search does not depend on PV's units. Returns ``(f at
    the optimum, its z)``."""
    scale = float(np.mean(crit.yw[crit.train] ** 2)) or 1.0
    simplex = np.vstack([z0, z0 + np.diag(np.asarray(steps, float))])
    res = minimize(lambda z: f(z) / scale, z0, method="Nelder-Mead",
                   options={"xatol": 1e-3, "fatol": 1e-12, "maxiter": maxiter,
                            "initial_simplex": simplex})
    return float(res.fun) * scale, res.x


def _held_shifts(crit: _Criterion) -> tuple[float, ...]:
    """Dead-time shifts searched with the process held at a given model: up to one sample
    either way, on a half-sample grid, around the model's ``θ`` — the recording
    convention (OP stored before or after the controller executed), the freedom the
    nominal model's alignment has (:func:`.diagnose.compare`). Not around the nominal's
    aligned ``θ``: a valve's own lag biases that alignment (a dead band of 0.4 % aligned
    the linear nominal one sample late), and the shifts would add up; a wider search
    credited a valve with a dead-time mismatch (a dead band of 0.01 % carrying 3 s)."""
    return tuple(d * crit.Ts for d in (0.0, -0.5, 0.5, -1.0, 1.0))


def _linear(crit: _Criterion, tau0: float, theta0: float) -> tuple[float, float, float]:
    """Linear loop under the current noise model: Nelder–Mead over ``(ln τ, θ/Ts)``
    (dimensionless coordinates: the search does not depend on the unit of time)."""
    if crit.fixed:
        return min((crit.cost(0.0, 0.0, 0, tau0, theta0 + d), tau0, theta0 + d)
                   for d in _held_shifts(crit) if theta0 + d >= 0)
    (tlo, thi), (dlo, dhi) = _bounds(crit, tau0, theta0)

    def unpack(z):
        return _exp_within(z[0], tlo, thi), min(max(z[1] * crit.Ts, dlo), dhi)

    z0 = np.array([math.log(max(tau0, tlo)), theta0 / crit.Ts])
    fun, z = _nelder_mead(crit, lambda z: crit.cost(0.0, 0.0, 0, *unpack(z)), z0,
                          (0.3, 1.0), 150)
    return fun, *unpack(z)


def _batch(crit: _Criterion, valves: list[tuple[float, float, int]],
           processes: list[tuple[float, float]]) -> list[tuple[float, tuple]]:
    """Criterion of every valve against every process, in one batch per process: the
    valve outputs are filtered and high-passed as the columns of one matrix."""
    M = np.column_stack([crit.valve(*v) for v in valves])
    y = crit.yw[crit.train]
    yy = float(np.dot(y, y))
    out = []
    for tau, theta in processes:
        G = crit.noise.whiten(crit.regressor(M, tau, theta))[crit.train]
        gy, gg = G.T @ y, np.einsum("ij,ij->j", G, G)
        cost = (yy - gy * gy / np.maximum(gg, 1e-300)) / y.size
        out += [(float(c), (*v, tau, theta)) for c, v in zip(cost, valves, strict=True)]
    crit.evaluations += len(out)
    out.sort(key=lambda e: e[0])
    return out


def _valve_grid(crit: _Criterion, tau0: float, theta0: float) -> list[tuple[float, tuple]]:
    """Global search: every ``(S, J/S, stop rule)`` of a grid against nine process
    candidates (the linear loop's ``τ`` and ``θ`` shrunk, since through a sticky valve
    the linear fit absorbs the valve's lag), and two more for every factor of 4 that
    ``0.08 τ`` lies above twice the sample time."""
    Ss = np.geomspace(0.01 * crit.span, 0.8 * crit.span, 24)
    js = (0.0, 0.1, 0.2, 0.35, 0.5, 0.7, 0.9, 1.1, 1.3)
    valves = [(float(S), float(j * S), rule) for rule in searched_rules(crit.fixed)
              for S in Ss for j in js if j >= _j_floor(rule)]
    if crit.fixed:
        # a given model: only the recording convention (OP stored before or after the
        # controller executed) is left open, the freedom of the nominal's alignment
        return _batch(crit, valves, [(tau0, theta0 + d) for d in _held_shifts(crit)
                                     if theta0 + d >= 0])
    taus = sorted({max(tau0 * f, 0.5 * crit.Ts) for f in (1.0, 0.3, 0.08)})
    thetas = sorted({theta0, 0.5 * theta0, 0.0})
    processes = [(a, b) for a in taus for b in thetas]
    # a limit cycle read through a linear model can inflate τ by orders of magnitude (an
    # integrator-like fit of the valve's ramps): the grid continues down to the sample
    # time in factors of 4, at the linear loop's θ and half of it (refined jointly
    # afterwards)
    tau = taus[0]
    for _ in range(12):  # 4¹² ≈ 1.7e7: bounded even for a degenerate τ
        if not tau > 2.0 * crit.Ts:
            break
        tau = max(tau / 4.0, 0.5 * crit.Ts)
        processes += [(tau, theta0), (tau, 0.5 * theta0)]
    return _batch(crit, valves, processes)


def _scan(crit: _Criterion, p: tuple) -> tuple[float, tuple]:
    """Dense local scan of ``(S, J)`` at a fixed stop rule and process: the criterion is
    rugged in ``J`` (a slip one sample early shifts the whole cycle)."""
    S, _, rule, tau, theta = p
    valves = [(float(s), float(j * s), rule) for s in S * np.geomspace(0.7, 1.4, 11)
              for j in np.linspace(_j_floor(rule), 1.4, 29)]
    return _batch(crit, valves, [(tau, theta)])[0]


def _seeds(grid: list[tuple[float, tuple]], k: int = 4) -> list[tuple[float, tuple]]:
    """The best grid point of every stop rule, then the next best that differ by more than
    20 % in S from those already taken, ``k`` in all."""
    out = [next(e for e in grid if e[1][2] == rule) for rule in sorted({e[1][2] for e in grid})]
    for e in grid:
        if len(out) >= k:
            break
        if all(e[1][2] != q[1][2] or abs(math.log(e[1][0] / q[1][0])) > 0.2 for q in out):
            out.append(e)
    return out


def _refine(crit: _Criterion, p0: tuple, tau0: float, theta0: float) -> tuple[float, tuple]:
    """Nelder–Mead over ``(ln S, J/S, ln τ, θ/Ts)`` at a fixed stop rule (over ``(ln S,
    J/S)`` when the process is held)."""
    rule = p0[2]
    if crit.fixed:
        def unpack2(z):
            S = _exp_within(z[0], 1e-3 * crit.span, 1.2 * crit.span)
            return (S, min(max(z[1], _j_floor(rule)), 1.5) * S, rule, p0[3], p0[4])
        z0 = np.array([math.log(p0[0]), p0[1] / p0[0]])
        fun, z = _nelder_mead(crit, lambda z: crit.cost(*unpack2(z)), z0, (0.3, 0.25), 120)
        return fun, unpack2(z)
    (tlo, thi), (dlo, dhi) = _bounds(crit, tau0, theta0)
    slo, shi = 1e-3 * crit.span, 1.2 * crit.span

    def unpack(z):
        S = _exp_within(z[0], slo, shi)
        return (S, min(max(z[1], _j_floor(rule)), 1.5) * S, rule,
                _exp_within(z[2], tlo, thi), min(max(z[3] * crit.Ts, dlo), dhi))

    # θ in sample times: the search does not depend on the unit of time
    z0 = np.array([math.log(p0[0]), p0[1] / p0[0], math.log(p0[3]), p0[4] / crit.Ts])
    fun, z = _nelder_mead(crit, lambda z: crit.cost(*unpack(z)), z0, (0.3, 0.25, 0.3, 1.0),
                          250)
    return fun, unpack(z)


#: relative steps of the profile walk away from an estimate
_STEPS = (0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0)


def _profile(crit: _Criterion, p: tuple, v_min: float, which: str,
             level: float) -> tuple[list[float], float]:
    """Profile-likelihood interval (confidence ``level``) of ``S`` or ``J`` (the other
    valve parameter re-optimised, the process held at its estimate) and the profile statistic at
    ``J = 0`` (``which="J"``; for ``"S"``: the linear loop, ``S = J = 0``).

    The profile ``N·ln(V(v)/V_min)`` is walked away from the estimate in relative steps
    until it exceeds ``χ²₁(level)``; the interval ends at the first point outside
    (conservative on a rugged criterion), or at 0 / twice the estimate if none is."""
    S, J, rule, tau, theta = p
    n = crit.train.size
    thr = chi2.ppf(level, 1)

    def stat(v: float) -> float:
        # the criterion is rugged: the other parameter by a dense batched scan (and its
        # estimate, a candidate of the minimum) rather than a local search
        if which == "J":
            # below Choudhury's slip floor the valve is the dead band (Kano's rule at J
            # = 0, the play operator) and the slips between (:data:`CHOUDHURY_MIN_SLIP`)
            valves = [(float(x), v, rule if v >= _j_floor(rule) * x else 0) for x in
                      np.r_[S, max(S, v / 1.5) * np.geomspace(0.7, 1.45, 48)]]
        else:
            valves = [(v, float(x), rule if x >= _j_floor(rule) * v else 0)
                      for x in np.r_[min(J, 1.5 * v), np.linspace(0.0, 1.5 * v, 48)]]
        best = _batch(crit, valves, [(tau, theta)])[0][0]
        return n * math.log(max(best, 1e-300) / v_min)

    est = J if which == "J" else S
    unit = max(est, 0.05 * S)
    if which == "J":
        v0 = _dead_band_fit(crit, p)[0] if J0_NUISANCE and crit.fixed else math.inf
        v0 = min(v0, crit.dead_band_v)
        stat0 = min(stat(0.0), n * math.log(max(v0, 1e-300) / v_min))
    else:
        stat0 = n * math.log(max(crit.cost(0.0, 0.0, 0, tau, theta), 1e-300) / v_min)
    lower = 0.0
    for f in _STEPS:
        v = est - f * unit
        if v <= 0.0:
            break
        if stat(v) > thr:
            lower = v
            break
    upper = est + 2.0 * unit
    for f in _STEPS:
        if stat(est + f * unit) > thr:
            upper = est + f * unit
            break
    if which == "J":
        # J = 0 inside the confidence set (its own test) → the interval reaches 0, so that
        # "the interval excludes 0" and "J = 0 rejected" say the same thing
        lower = max(lower, 1e-12) if stat0 > thr else 0.0
    return [float(lower), float(upper)], float(stat0)


#: the ``J = 0`` end of the slip-jump test also re-optimises the nuisance parameters
#: (:func:`_dead_band_fit`; with a given model only); False, the default: the
#: process held at the valve's estimate and ``S`` scanned around the fitted ``S`` only.
#: ``experiments/slip_jump_nuisance.py`` scored it: its criterion, stated before the run on
#: the holdout family's blind blocks, was met by one verdict, but on the three tuning
#: families it turned 3 of 24 sticky valves into dead bands. There (as on ISDB CHEM23
#: without a model) the refitted dead band beat the stick-slip fit's own optimum: a
#: one-sided refit exposes a search failure of the alternative as "no slip jump". Not
#: adopted; both ends searched with the same effort is the lead
J0_NUISANCE = False


def _dead_band_fit(crit: _Criterion, p: tuple) -> tuple[float, tuple]:
    """The best dead band (``J = 0``, the play operator) against a held process, with the
    nuisance parameters re-optimised: the restricted fit of a profile likelihood ratio
    (Pawitan, *In All Likelihood*, 2001, ch. 3.4; Ljung 1999, ch. 16.4: both models
    fitted by the same criterion with the same effort). Returns ``(variance, parameters)``.

    A stick-slip valve ``(S, J)`` moving lags OP by ``(S − J)/2``, so the dead band it
    mimics has width about ``S − J``, not ``S``: the band's width is searched from half
    of ``S − J`` to 1.45 ``S`` (48 points, then Nelder–Mead in ``ln S``), against every
    held shift of the given model's dead time (:func:`_held_shifts`: a slip jump moves
    the valve's timing)."""
    S, J, _, tau, _ = p
    lo = 0.5 * max(S - min(J, 1.5 * S), 0.05 * S)
    valves = [(float(s), 0.0, 0) for s in np.geomspace(lo, 1.45 * S, 48)]
    base = crit.theta_given
    procs = [(tau, base + d) for d in _held_shifts(crit) if base + d >= 0]
    v, q = _batch(crit, valves, procs)[0]
    _, _, _, tau0, theta0 = q

    def unpack(z):
        return (_exp_within(z[0], 1e-3 * crit.span, 1.2 * crit.span), 0.0, 0, tau0, theta0)

    fun, z = _nelder_mead(crit, lambda z: crit.cost(*unpack(z)), np.array([math.log(q[0])]),
                          (0.1,), 150)
    return (v, q) if v <= fun else (fun, unpack(z))


def _validation_nrmse(crit: _Criterion, sim: np.ndarray) -> float:
    yv = crit.y[crit.val]
    return float(np.sqrt(np.mean((yv - sim[crit.val]) ** 2)) / (float(np.std(yv)) or 1.0))


def _check(rec: Recording) -> tuple[np.ndarray, np.ndarray]:
    op = np.asarray(rec.OP, float)
    pv = np.asarray(rec.PV, float)
    src = rec.meta.get("source", "recording")
    if len(rec) < 200:
        raise InputError(f"{src}: {len(rec)} samples; valve identification needs >= 200")
    if np.ptp(op) <= 0 or np.ptp(pv) <= 0:
        raise InputError(f"{src}: OP or PV is constant; nothing to identify")
    return op, pv


def fit_hammerstein(rec: Recording, *, alpha: float = 0.01,
                    linear: tuple[float, float, float] | None = None,
                    fix_process: bool = False,
                    hp_factor: float = HP_FACTOR, n_blocks: int = N_BLOCKS,
                    block_layout: str = "interleaved",
                    noise_family: str = "ar") -> HammersteinResult:
    """Identify a stick-slip valve and a FOPDT process jointly from ``rec.OP`` → ``rec.PV``.

    Parameters
    ----------
    rec : Recording
        ``t, PV, OP`` (``SP`` and ``MV`` are not used).
    alpha : float
        Level of the likelihood-ratio tests behind :attr:`HammersteinResult.stiction`.
    linear : (K, τ, θ), optional
        A known linear process to start from (otherwise identified output-error).
    fix_process : bool
        Hold ``τ`` and ``θ`` at ``linear`` (up to a ±1 sample recording shift of ``θ``):
        the valve alone is identified against a nominal model the user gave. Only then
        is Choudhury's restart searched as a third stop rule and the rule chosen by the
        innovations. Without a model every rule comes with its own re-identified
        process, and both additions moved verdicts by trading the valve against the
        process: on simulated Kano valves under a PI faster than the historian
        (``reports/diagnose/fast_loops.md``, model-free: sticky valves named stiction
        33 → 26 of 84) and on ISDB CHEM23 (stiction, S 25.2 and J 4.75 → a dead band:
        the every-sample rule with J 0.35). That choice was made on those recordings
        (in-sample for them).
    hp_factor : float
        The prefilter's high-pass cut-off as a fraction of ``1/(2π(τ+θ))`` of the linear
        loop it starts from (default :data:`HP_FACTOR`; :func:`.diagnose.diagnose` passes
        its own, so that the valve and the other hypotheses see the same band).
    n_blocks, block_layout : int, str
        The training and validation blocks after the burn-in (:func:`.blocks.split_blocks`;
        default five, interleaved; :func:`.diagnose.diagnose` passes its own).
    noise_family : {"ar", "arma"}
        The noise model's family (:func:`.noise.fit_noise_model`; default ``"ar"``).

    Returns
    -------
    HammersteinResult
        ``S``, ``J`` (% of OP) with ``1 − alpha`` profile intervals, the process re-identified with
        the valve, the linear process, innovation variances, LR and residual tests, and
        the validation NRMSE of both.

    References
    ----------
    Srinivasan et al. (2005); Jelali (2008); Karra & Karim (2009); Kano et al. (2004);
    Ljung (1999) ch. 7 and 16.
    """
    t0 = time.perf_counter()
    op, pv = _check(rec)
    Ts = rec.Ts
    _, tau0, theta0 = linear if linear is not None else fit_fopdt(op, pv, Ts)
    if not hp_factor > 0:
        raise InputError(f"hp_factor must be positive, got {hp_factor!r}")
    f_hp = hp_factor / (2 * math.pi * (tau0 + theta0))
    burn = min(int(math.ceil((theta0 + 3 * tau0) / Ts)), op.size // 5)
    split = split_blocks(op.size, burn, n_blocks, block_layout)
    crit = _Criterion(op, pv, Ts, f_hp, split.train, split.val)
    crit.fixed = bool(fix_process and linear is not None)
    crit.theta_given = theta0
    # 1. output-error fits (white H): the linear loop, then the valve on a grid and by
    #    joint refinement of valve and process
    _, tau_l, theta_l = _linear(crit, tau0, theta0)
    # with the process held, the valve's timing is searched around the given θ, not
    # around the linear loop's shifted one (the shifts would add up: _held_shifts)
    grid = _valve_grid(crit, tau_l, theta0 if crit.fixed else theta_l)
    per_rule: dict[int, tuple[float, tuple]] = {}  # the best valve of every stop rule
    for _, q in _seeds(grid, len(searched_rules(crit.fixed)) + 1):
        _, q = _refine(crit, q, tau_l, theta_l)
        e = _refine(crit, _scan(crit, q)[1], tau_l, theta_l)
        if e[0] < per_rule.get(e[1][2], (math.inf,))[0]:
            per_rule[e[1][2]] = e
    p = min(per_rule.values(), key=lambda e: e[0])[1]
    # 2. the noise model of the larger (valve) model's output error — an oscillation the
    #    linear model leaves unexplained must not be absorbed into H — then both models
    #    refined under it (prediction-error method with H fixed). With the process held,
    #    every stop rule's valve is refined and the rule chosen by the criterion it is
    #    tested with (the output error can prefer another rule than the innovations do);
    #    with the process re-identified, the output error's rule is refined alone
    _, sim, _ = crit.simulate(*p)
    crit.set_noise(fit_noise_model((crit.y - sim)[crit.train], family=noise_family))
    v_lin, tau_l, theta_l = _linear(crit, *((tau0, theta0) if crit.fixed else (tau_l, theta_l)))
    candidates = [q for _, q in per_rule.values()] if crit.fixed else [p]
    v_valve, p = min((_refine(crit, q, tau_l, theta_l) for q in candidates),
                     key=lambda e: e[0])
    if J0_RESTART and crit.fixed and p[0] > 0:
        v_valve, p = _restart_from_dead_band(crit, p, v_valve, tau_l, theta_l)
    if v_valve > v_lin:  # the linear loop is the S → 0 limit of the valve
        v_valve, p = v_lin, (0.0, 0.0, 0, tau_l, theta_l)
    return _result(rec, crit, p, v_valve, v_lin, (tau_l, theta_l), alpha, t0)


#: with a given model, search both ends of the slip-jump test with the same effort: the
#: dead band refitted with its nuisance parameters (:func:`_dead_band_fit`) and the
#: stick-slip valve restarted from that dead band under every stop rule, the better of
#: all kept (:func:`_restart_from_dead_band`). Scored by
#: ``experiments/slip_jump_symmetric.py`` against a criterion fixed before its run: blind
#: holdout blocks level 2 341 → 342 of 432 named right, level 1 and false alarms equal,
#: but the tuning families' level 1 117 → 116 of 120 (an oscillatory disturbance named
#: a dead band, a physical-model sticky valve whose slip the 1 s signals do not hold
#: named a dead band): not met, not adopted
J0_RESTART = False


def _restart_from_dead_band(crit: _Criterion, p: tuple, v: float, tau_l: float,
                            theta_l: float) -> tuple[float, tuple]:
    """The stick-slip fit ``(v, p)`` compared with the dead band refitted around it and
    with the stick-slip valve restarted from that dead band (``J = 0.2 S`` under every
    searched stop rule, Nelder–Mead as in the search): the nested models searched with the
    same effort, so that the best of all is the unrestricted optimum. A dead band that
    fits better than every stick-slip fit found is returned as the valve (``J = 0``)."""
    v0, q0 = _dead_band_fit(crit, p)
    best = min([(v, p), (v0, q0)]
               + [_refine(crit, (q0[0], 0.2 * q0[0], rule, q0[3], q0[4]), tau_l, theta_l)
                  for rule in searched_rules(crit.fixed)], key=lambda e: e[0])
    crit.dead_band_v = min(v0, crit.dead_band_v)
    return best


def _result(rec: Recording, crit: _Criterion, p: tuple, v_valve: float, v_lin: float,
            lin: tuple[float, float], alpha: float, t0: float) -> HammersteinResult:
    """Tests, intervals and the validation fit of the chosen parameter set."""
    n = crit.train.size
    S, J, rule, tau, theta = p
    K, sim, mv = crit.simulate(*p)
    K_l, sim_l, _ = crit.simulate(0.0, 0.0, 0, *lin)
    if S > 0:
        S_int, _ = _profile(crit, p, v_valve, "S", 1.0 - alpha)
        J_int, stat_j = _profile(crit, p, v_valve, "J", 1.0 - alpha)
    else:
        S_int, J_int, stat_j = [0.0, 0.0], [0.0, 0.0], 0.0
    e = crit.noise.whiten(crit.y - sim)[crit.train]
    u = lfilter(*crit.hp, crit.op - crit.op[0])[crit.train]  # pre-whitened in the test
    nr_l, nr_v = _validation_nrmse(crit, sim_l), _validation_nrmse(crit, sim)
    tests = {
        "valve_vs_linear": lr_test(v_lin, v_valve, n, 3),
        "slip_jump_zero": {"statistic": stat_j, "p_value": float(chi2.sf(max(stat_j, 0), 1)),
                           "df": 1, "method": SLIP_JUMP_ASYMPTOTIC},
        "whiteness": ljung_box(e),
        "independence_from_op": input_independence(e, u),
    }
    return HammersteinResult(
        S=float(S), J=float(min(J, 1.5 * S)), S_interval=S_int, J_interval=J_int,
        stop_rule=STOP_RULES[rule],
        process={"gain": K, "time_constant": float(tau), "dead_time": float(theta)},
        linear_process={"gain": K_l, "time_constant": float(lin[0]),
                        "dead_time": float(lin[1])},
        innovation_variance={"linear": v_lin, "valve": v_valve},
        tests=tests,
        fit={"metric": "nrmse", "segment": "validation", "linear": nr_l, "valve": nr_v,
             "improvement": 1.0 - nr_v / max(nr_l, 1e-300)},
        noise_model=crit.noise.to_dict(), alpha=alpha,
        seconds=time.perf_counter() - t0, mv=mv,
        criterion=crit, estimate=tuple(p),
        consistent=bool(S <= 0 or (K * K_l > 0 and (crit.fixed
                                                   or tau > 1.05 * _bounds(crit, tau, 0)[0][0]))))
