"""Valve blocks: linear, Choudhury's physical force-balance model, the two-parameter
data-driven stiction models (Choudhury 2005, Kano 2004, He 2007), deadband/backlash,
travel saturation and the installed flow characteristic.

Each block is a small frozen dataclass with parameters; :meth:`encode` packs it into the
integer code and float arrays that the numba closed-loop kernel steps. The step functions
below are the physics, compiled with ``numba.njit(cache=True)``.

Units: controller output OP and valve position MV in % of span. The physical model works
in SI units (Pa, m, N) and maps OP to actuator pressure and stem travel to MV % through a
linear calibration documented in ``conf/valve/physical.yaml``.

References
----------
Choudhury, Thornhill & Shah, "Modelling valve stiction", Control Eng. Practice 13 (2005)
641–658 (physical model eqs. 1–2 and the two-parameter model). Kano, Maruta, Kugemoto &
Shimizu, DYCOPS 2004. He, Wang, Pottmann & Qin, Ind. Eng. Chem. Res. 46 (2007) 4797–4807.
Govinda Kumar & Manoharan (seed paper), eqs. 1–2, Tables I–II.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numba import njit

from ..errors import InputError
from ..validation import number

# valve kind codes used by the kernel
LINEAR, PHYSICAL, CHOUDHURY, KANO, HE, BACKLASH = 0, 1, 2, 3, 4, 5
# characteristic codes
CHAR_LINEAR, CHAR_EQUAL_PERCENTAGE, CHAR_QUICK_OPENING = 0, 1, 2
CHARACTERISTICS = {
    "linear": CHAR_LINEAR,
    "equal_percentage": CHAR_EQUAL_PERCENTAGE,
    "quick_opening": CHAR_QUICK_OPENING,
}

STATE_SIZE = 6


def _positive(name: str, value: float, *, allow_zero: bool = False) -> float:
    """A valve parameter ≥ 0 (> 0 unless ``allow_zero``), checked by the blocks' rule."""
    return number(f"valve.{name}", value, low=0.0, strict=not allow_zero)


@dataclass(frozen=True)
class Valve:
    """Base of all valve blocks: travel limits and installed characteristic.

    Parameters
    ----------
    travel_low, travel_high : float
        Mechanical travel limits of the stem, % (travel saturation).
    characteristic : {"linear", "equal_percentage", "quick_opening"}
        Installed flow characteristic mapping stem travel (MV %) to flow (% of max).
    rangeability : float
        Rangeability R of the equal-percentage characteristic, f = R**(x/100 - 1).
    """

    travel_low: float = 0.0
    travel_high: float = 100.0
    characteristic: str = "linear"
    rangeability: float = 50.0

    kind: ClassVar[int] = LINEAR

    def model_params(self) -> np.ndarray:
        """Float parameters of the stiction/friction model, in kernel order."""
        return np.zeros(1)

    def encode(self) -> tuple[int, np.ndarray, np.ndarray]:
        """Return ``(kind, model_params, post_params)`` for the kernel.

        ``post_params`` = [travel_low, travel_high, characteristic code, rangeability].
        """
        if self.characteristic not in CHARACTERISTICS:
            raise InputError(
                f"valve.characteristic: unknown {self.characteristic!r}; use "
                f"{', '.join(CHARACTERISTICS)}"
            )
        if not self.travel_low < self.travel_high:
            raise InputError("valve.travel_low must be below valve.travel_high")
        if self.characteristic == "equal_percentage" and self.rangeability <= 1:
            raise InputError("valve.rangeability: must be > 1")
        post = np.array(
            [
                float(self.travel_low),
                float(self.travel_high),
                float(CHARACTERISTICS[self.characteristic]),
                float(self.rangeability),
            ]
        )
        return self.kind, np.asarray(self.model_params(), dtype=float), post


@dataclass(frozen=True)
class LinearValve(Valve):
    """An ideal valve: MV = OP (then travel limits and characteristic)."""

    kind: ClassVar[int] = LINEAR


@dataclass(frozen=True)
class PhysicalValve(Valve):
    """Choudhury's physical model of a pneumatic sliding-stem valve (paper eqs. 1–2).

    ``M ẍ = A·u − k·x + F_f`` with friction ``F_f = −Fc·sgn(v) − Fv·v`` while moving,
    ``−(A·u − k·x)`` while stuck and ``|A·u − k·x| ≤ Fs``, breakaway otherwise.
    Between stick/slip events the stem dynamics are linear and integrated *exactly*
    (closed-form solution of the second-order ODE under a constant input); the
    velocity zero crossing is located analytically, so there is no Euler chatter.

    Parameters
    ----------
    mass, spring, area : float
        M (kg), k (N/m), diaphragm area A (m²). Table I: 1.36, 52 500, 0.0645.
    Fs, Fc, Fv : float
        Static and Coulomb friction (N), viscous coefficient (N·s/m). Table II.
    pressure_low, pressure_high : float
        Actuator pressure (Pa) at OP = 0 % and OP = 100 % (calibration of the I/P
        converter; default the standard 3–15 psi pneumatic signal).
    """

    mass: float = 1.36
    spring: float = 52500.0
    area: float = 0.0645
    Fs: float = 1000.0
    Fc: float = 400.0
    Fv: float = 612.0
    pressure_low: float = 20684.0
    pressure_high: float = 103421.0

    kind: ClassVar[int] = PHYSICAL

    def model_params(self) -> np.ndarray:
        for n in ("mass", "spring", "area"):
            _positive(n, getattr(self, n))
        for n in ("Fs", "Fc", "Fv"):
            _positive(n, getattr(self, n), allow_zero=True)
        if self.Fc > self.Fs:
            raise InputError(f"valve.Fc ({self.Fc}) must not exceed valve.Fs ({self.Fs})")
        if not self.pressure_high > self.pressure_low:
            raise InputError("valve.pressure_high must exceed valve.pressure_low")
        return np.array(
            [self.mass, self.spring, self.area, self.Fs, self.Fc, self.Fv,
             self.pressure_low, self.pressure_high]
        )

    @property
    def travel_span(self) -> float:
        """Stem travel (m) between OP = 0 % and 100 % at friction-free equilibrium."""
        return self.area * (self.pressure_high - self.pressure_low) / self.spring

    def friction_for(self, S: float, J: float) -> tuple[float, float]:
        """Static and Coulomb friction ``(Fs, Fc)`` (N) giving quasi-static ``(S, J)``.

        The inverse of :meth:`equivalent_two_parameter`: ``Fs = k·span·(S + J)/200``,
        ``Fc = k·span·(S − J)/200`` with ``S``, ``J`` in % of travel span
        (Choudhury et al. 2005, section 4). This is the one place where the
        (S, J) ↔ (Fs, Fc) arithmetic lives.

        Examples
        --------
        >>> v = PhysicalValve()
        >>> Fs, Fc = v.friction_for(*v.equivalent_two_parameter())
        >>> round(Fs, 6), round(Fc, 6)
        (1000.0, 400.0)
        """
        per_percent = self.spring * self.travel_span / 100.0
        return 0.5 * (S + J) * per_percent, 0.5 * (S - J) * per_percent

    def with_two_parameter(self, S: float, J: float) -> PhysicalValve:
        """A copy of this valve whose friction gives quasi-static ``(S, J)`` (% of span)."""
        Fs, Fc = self.friction_for(S, J)
        return dataclasses.replace(self, Fs=Fs, Fc=Fc)

    def equivalent_two_parameter(self) -> tuple[float, float]:
        """Quasi-static equivalent ``(S, J)`` in % of travel span.

        ``S = (Fs + Fc)/k`` and ``J = (Fs − Fc)/k`` in stem travel (m), divided by the
        travel span (Choudhury et al. 2005, section 4).
        """
        span = self.travel_span
        return (
            100.0 * (self.Fs + self.Fc) / self.spring / span,
            100.0 * (self.Fs - self.Fc) / self.spring / span,
        )


@dataclass(frozen=True)
class ChoudhuryValve(Valve):
    """Choudhury et al. (2005) two-parameter data-driven stiction model.

    ``S`` = deadband + stickband and ``J`` = slip jump, both in % of span.
    J < S undershoot; J = S no offset; J > S overshoot. J = 0 is a pure dead band only
    for a smooth input: the model sticks at every reversal with the full band ``S``
    armed in *both* directions (``|op − op_stick| > S``), so under a noisy OP a brief
    reversal followed by motion the original way slips with a jump of up to ``S`` and
    the valve lags OP by up to ``1.5 S`` (``tests/test_valves.py``). For a dead band
    under noise use :class:`BacklashValve` or :class:`HeValve` with ``J = 0``.
    """

    S: float = 5.0
    J: float = 2.0
    kind: ClassVar[int] = CHOUDHURY

    def model_params(self) -> np.ndarray:
        return np.array([_positive("S", self.S, allow_zero=True),
                         _positive("J", self.J, allow_zero=True)])


@dataclass(frozen=True)
class KanoValve(ChoudhuryValve):
    """Kano et al. (2004) two-parameter stiction model (state machine on OP)."""

    kind: ClassVar[int] = KANO


@dataclass(frozen=True)
class HeValve(ChoudhuryValve):
    """He et al. (2007) two-parameter model: ``fs = (S + J)/2``, ``fd = (S − J)/2``."""

    kind: ClassVar[int] = HE

    def model_params(self) -> np.ndarray:
        p = super().model_params()
        if p[1] > p[0]:
            raise InputError("valve.J must not exceed valve.S for the He model")
        return p


@dataclass(frozen=True)
class BacklashValve(Valve):
    """Backlash / deadband (play) of total width ``deadband`` % : the stem follows OP
    only after the input has crossed the play; ``MV = OP ∓ deadband/2`` while moving.

    It is what the two-parameter models with J = 0 mean by a "pure deadband" (He's and
    Kano's are this under any input; Choudhury's only under a smooth one: see
    :class:`ChoudhuryValve`).
    """

    deadband: float = 2.0
    kind: ClassVar[int] = BACKLASH

    def model_params(self) -> np.ndarray:
        return np.array([_positive("deadband", self.deadband, allow_zero=True)])


# --------------------------------------------------------------------------- physics
@njit(cache=True)
def _sgn(v: float) -> float:
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def stem_propagate(x0, v0, f, t, M, k, Fv):
    """Exact solution of ``M ẍ + Fv ẋ + k x = f`` after time ``t`` from ``(x0, v0)``.

    Returns ``(x, v, tz)`` where ``tz`` is the first time in (0, ∞) at which the velocity
    returns to zero (``inf`` if never); callers compare it with ``t``.
    """
    xe = f / k
    e0 = x0 - xe
    c = Fv / M
    w2 = k / M
    disc = c * c - 4.0 * w2
    eps = 1e-12 * max(c * c, w2)
    tz = math.inf
    if disc > eps:  # overdamped: two real roots
        sq = math.sqrt(disc)
        l1 = 0.5 * (-c + sq)
        l2 = 0.5 * (-c - sq)
        a1 = (v0 - l2 * e0) / (l1 - l2)
        a2 = e0 - a1
        E1 = math.exp(l1 * t)
        E2 = math.exp(l2 * t)
        x = xe + a1 * E1 + a2 * E2
        v = l1 * a1 * E1 + l2 * a2 * E2
        num = -l2 * a2
        den = l1 * a1
        if den != 0.0 and num / den > 0.0:
            tc = math.log(num / den) / (l1 - l2)
            if tc > 1e-15:
                tz = tc
    elif disc < -eps:  # underdamped
        sg = -0.5 * c
        om = 0.5 * math.sqrt(-disc)
        C1 = e0
        C2 = (v0 - sg * e0) / om
        ex = math.exp(sg * t)
        co = math.cos(om * t)
        si = math.sin(om * t)
        x = xe + ex * (C1 * co + C2 * si)
        P = sg * C1 + om * C2  # v = e^{σt}(P cos ωt + Q sin ωt)
        Q = sg * C2 - om * C1
        v = ex * (P * co + Q * si)
        # first positive root of P cos + Q sin = 0
        th = math.atan2(-P, Q)  # angle where P cos θ + Q sin θ = 0
        while th <= 1e-15:
            th += math.pi
        tz = th / om
    else:  # critically damped
        lam = -0.5 * c
        C1 = e0
        C2 = v0 - lam * e0
        ex = math.exp(lam * t)
        x = xe + (C1 + C2 * t) * ex
        v = (lam * C1 + C2 + lam * C2 * t) * ex
        if lam * C2 != 0.0:
            tc = -(lam * C1 + C2) / (lam * C2)
            if tc > 1e-15:
                tz = tc
    return x, v, tz


@njit(cache=True)
def physical_step(op, state, p, h):
    """Advance the physical valve by ``h`` seconds under constant controller output ``op``.

    ``state`` = [x (m), v (m/s), stuck (0/1), events]; ``p`` from
    :meth:`PhysicalValve.model_params`. Returns MV in % of travel span.
    """
    M, k, A, Fs, Fc, Fv, plo, phi = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]
    u = plo + 0.01 * op * (phi - plo)
    x = state[0]
    v = state[1]
    stuck = state[2] > 0.5
    t_rem = h
    for _ in range(64):
        if t_rem <= 0.0:
            break
        if stuck:
            F = A * u - k * x
            if abs(F) <= Fs:
                break  # stays stuck for the rest of the step (u is constant)
            stuck = False
            v = 0.0
            s = _sgn(F)
        else:
            s = _sgn(v)
        xn, vn, tz = stem_propagate(x, v, A * u - Fc * s, t_rem, M, k, Fv)
        if tz >= t_rem:
            x = xn
            v = vn
            t_rem = 0.0
        else:
            # velocity returns to zero inside the step: land exactly on the event
            x, v, _tz = stem_propagate(x, v, A * u - Fc * s, tz, M, k, Fv)
            v = 0.0
            t_rem -= tz
            state[3] += 1.0
            stuck = True  # re-examined at the top of the loop (stick or break away)
    state[0] = x
    state[1] = v
    state[2] = 1.0 if stuck else 0.0
    x0 = A * plo / k
    span = A * (phi - plo) / k
    return 100.0 * (x - x0) / span


@njit(cache=True)
def choudhury_step(op, state, p):
    """Choudhury et al. (2005) two-parameter model, one controller sample.

    ``state`` = [mv, op_prev, slope_prev, op_stick, stuck, reversal].
    """
    S = p[0]
    J = p[1]
    mv = state[0]
    dv = op - state[1]
    sv = _sgn(dv)
    sprev = state[2]
    if state[4] < 0.5:  # moving
        if sv == 0.0:
            state[4] = 1.0
            state[3] = state[1]
            state[5] = 0.0
        elif sprev != 0.0 and sv != sprev:
            state[4] = 1.0
            state[3] = state[1]
            state[5] = 1.0
    else:
        if sprev != 0.0 and sv != 0.0 and sv != sprev:
            state[5] = 1.0  # input reversed while stuck: the full band S applies
    if state[4] > 0.5:
        band = S if state[5] > 0.5 else J
        if abs(op - state[3]) > band:
            state[4] = 0.0
            mv = op - sv * (S - J) * 0.5
    else:
        mv = op - sv * (S - J) * 0.5
    state[0] = mv
    state[1] = op
    if sv != 0.0:
        state[2] = sv
    return mv


@njit(cache=True)
def kano_step(op, state, p):
    """Kano et al. (2004) stiction model, one controller sample.

    ``state`` = [mv, op_prev, du_prev, u_s, stp, d].
    """
    S = p[0]
    J = p[1]
    mv = state[0]
    du = op - state[1]
    if state[4] < 0.5 and du * state[2] <= 0.0 and state[2] != 0.0:
        state[4] = 1.0  # stop; remember the input where the valve stopped
        state[3] = state[1]
    if state[4] > 0.5:
        d = state[5]
        if -d * (op - state[3]) > S:  # breaks free after a reversal
            state[5] = -d
            state[4] = 0.0
            mv = op - state[5] * (S - J) * 0.5
        elif d * (op - state[3]) > J:  # breaks free in the same direction
            state[4] = 0.0
            mv = op - d * (S - J) * 0.5
    else:
        mv = op - state[5] * (S - J) * 0.5
    state[0] = mv
    state[1] = op
    if du != 0.0:
        state[2] = du
    return mv


@njit(cache=True)
def he_step(op, state, p):
    """He et al. (2007) two-parameter model; ``state`` = [mv, op_prev, u_r, ...]."""
    fs = 0.5 * (p[0] + p[1])
    fd = 0.5 * (p[0] - p[1])
    mv = state[0]
    state[2] += op - state[1]
    ur = state[2]
    if abs(ur) > fs:
        mv = mv + ur - _sgn(ur) * fd
        state[2] = _sgn(ur) * fd
    state[0] = mv
    state[1] = op
    return mv


@njit(cache=True)
def backlash_step(op, state, p):
    """Play operator of width ``p[0]``: MV stays within ±width/2 of OP."""
    half = 0.5 * p[0]
    mv = state[0]
    if op - mv > half:
        mv = op - half
    elif mv - op > half:
        mv = op + half
    state[0] = mv
    return mv


@njit(cache=True)
def characteristic(mv, code, R):
    """Installed flow characteristic: stem travel % → flow % of maximum."""
    if code == 1:
        return 100.0 * R ** (0.01 * mv - 1.0)
    if code == 2:
        z = max(0.0, 0.01 * mv)
        return 100.0 * math.sqrt(z)
    return mv


def init_state(kind: int, p: np.ndarray, op0: float) -> np.ndarray:
    """Valve state at rest with MV = OP = ``op0`` (friction-free equilibrium)."""
    s = np.zeros(STATE_SIZE)
    s[0] = op0
    s[1] = op0
    if kind == PHYSICAL:
        A, k, plo, phi = p[2], p[1], p[6], p[7]
        s[0] = A * (plo + 0.01 * op0 * (phi - plo)) / k
        s[1] = 0.0
        s[2] = 1.0
        s[3] = 0.0
    elif kind == CHOUDHURY:
        s[4] = 1.0
        s[3] = op0
        s[5] = 0.0
    elif kind == KANO:
        s[4] = 1.0
        s[3] = op0
        s[5] = 1.0
    elif kind == HE:
        s[2] = 0.0
    return s


@njit(cache=True)
def valve_model_step(kind, op, state, p, h):
    """Dispatch one valve update (``h`` is used by the physical model only)."""
    if kind == PHYSICAL:
        return physical_step(op, state, p, h)
    if kind == CHOUDHURY:
        return choudhury_step(op, state, p)
    if kind == KANO:
        return kano_step(op, state, p)
    if kind == HE:
        return he_step(op, state, p)
    if kind == BACKLASH:
        return backlash_step(op, state, p)
    return op


def respond(valve: Valve, op: np.ndarray, h: float = 1.0) -> np.ndarray:
    """Open-loop valve response: MV for an OP sequence sampled every ``h`` seconds.

    Useful for phase plots and tests; travel limits are applied, the characteristic
    is not (MV is stem travel).
    """
    kind, p, post = valve.encode()
    op = np.asarray(op, dtype=float)
    return _respond(kind, op, init_state(kind, p, float(op[0])), p, post, h)


@njit(cache=True)
def _respond(kind, op, state, p, post, h):
    out = np.empty(op.size)
    for i in range(op.size):
        mv = valve_model_step(kind, op[i], state, p, h)
        out[i] = min(max(mv, post[0]), post[1])
    return out
