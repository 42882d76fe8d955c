"""Process, controller, sensor and disturbance blocks: small objects with parameters.

Each block validates its own parameters (raising :class:`~stictionbench.errors.InputError`
that names the config key) and turns them into the numbers the numba kernel steps.
Exogenous signals (set point, noise, disturbances) do not depend on the loop, so they
are generated here with vectorised numpy from an explicit random generator.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..validation import number


@dataclass(frozen=True)
class FOPDT:
    """First-order plus dead-time process ``K e^{-θs}/(τs + 1)`` in deviation form.

    ``PV = pv0 + y``, where ``y`` responds to ``flow − flow0`` and ``flow0`` is the
    flow at the initial operating point. Discretised exactly for a zero-order-hold
    input, including a fractional dead time (modified z-transform).

    Parameters
    ----------
    gain : float
        K, PV units per % flow.
    time_constant : float
        τ > 0, seconds.
    dead_time : float
        θ ≥ 0, seconds.
    pv0 : float
        PV at the initial steady state.
    """

    gain: float = 3.0
    time_constant: float = 10.0
    dead_time: float = 10.0
    pv0: float = 50.0

    def coefficients(self, dt: float) -> np.ndarray:
        """Return ``[K, a, w_old, w_new, d]`` for step ``dt``.

        ``y[k+1] = a·y[k] + K·(w_old·u[k−d−1] + w_new·u[k−d])`` with ``a = e^{−dt/τ}``,
        ``θ = (d + f)·dt``, ``w_old = a^{1−f} − a``, ``w_new = 1 − a^{1−f}``.
        """
        K = number("process.gain", self.gain)
        tau = number("process.time_constant", self.time_constant, low=0.0, strict=True)
        theta = number("process.dead_time", self.dead_time, low=0.0)
        a = math.exp(-dt / tau)
        d_real = theta / dt
        d = int(math.floor(d_real + 1e-9))
        f = max(0.0, d_real - d)
        af = a ** (1.0 - f)
        return np.array([K, a, af - a, 1.0 - af, float(d)])


@dataclass(frozen=True)
class PIController:
    """PI controller in ideal form ``u = Kc·(e + (1/Ti)∫e dt)``, velocity algorithm.

    Executed every ``sample_time`` seconds. The output is clamped to
    ``[op_low, op_high]``; the velocity form with a clamped output is an anti-windup
    scheme in itself (the integral stops at the limit).

    Parameters
    ----------
    kc : float
        Proportional gain Kc (% OP per PV unit).
    ti : float
        Integral time Ti > 0, seconds.
    sample_time : float
        Controller execution period, seconds.
    op_low, op_high : float
        Output limits, %.
    op0 : float
        Output at the initial steady state (bumpless start), %.
    """

    kc: float = 0.2
    ti: float = 10.0
    sample_time: float = 0.1
    op_low: float = 0.0
    op_high: float = 100.0
    op0: float = 50.0

    def params(self) -> np.ndarray:
        kc = number("controller.kc", self.kc)
        ti = number("controller.ti", self.ti, low=0.0, strict=True)
        hc = number("controller.sample_time", self.sample_time, low=0.0, strict=True)
        lo = number("controller.op_low", self.op_low)
        hi = number("controller.op_high", self.op_high)
        if not lo < hi:
            raise InputError("controller.op_low must be below controller.op_high")
        op0 = min(max(number("controller.op0", self.op0), lo), hi)
        return np.array([kc, ti, hc, lo, hi, op0])


@dataclass(frozen=True)
class Sensor:
    """Measurement: first-order lag (``time_constant`` s, 0 = none) plus white noise
    of standard deviation ``noise_std`` (PV units) at every controller sample."""

    time_constant: float = 0.0
    noise_std: float = 0.0

    def lag_factor(self, dt: float) -> float:
        tau = number("sensor.time_constant", self.time_constant, low=0.0)
        return 0.0 if tau == 0.0 else math.exp(-dt / tau)

    def noise(self, n: int, rng: np.random.Generator) -> np.ndarray:
        sd = number("sensor.noise_std", self.noise_std, low=0.0)
        return sd * rng.standard_normal(n) if sd > 0 else np.zeros(n)


@dataclass(frozen=True)
class Disturbance:
    """Output disturbances added to PV before the sensor.

    Parameters
    ----------
    amplitude, period, phase : float
        Sinusoid ``amplitude·sin(2π t/period + phase)`` (PV units, s, rad);
        amplitude 0 disables it.
    start : float
        Time (s) at which the sinusoid starts.
    load_std : float
        Standard deviation (PV units) of the stationary load: a random walk filtered
        by a first-order lag of ``load_time_constant`` seconds, scaled so that its
        steady-state standard deviation is ``load_std`` (0 disables it).
    load_time_constant : float
        Correlation time of the load, seconds.
    """

    amplitude: float = 0.0
    period: float = 100.0
    phase: float = 0.0
    start: float = 0.0
    load_std: float = 0.0
    load_time_constant: float = 200.0

    def generate(self, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        amp = number("disturbance.amplitude", self.amplitude)
        out = np.zeros_like(t)
        if amp != 0.0:
            period = number("disturbance.period", self.period, low=0.0, strict=True)
            start = number("disturbance.start", self.start, low=0.0)
            on = t >= start
            out[on] = amp * np.sin(2 * np.pi * (t[on] - start) / period + float(self.phase))
        sd = number("disturbance.load_std", self.load_std, low=0.0)
        if sd > 0.0:
            out += load_walk(t, sd, number("disturbance.load_time_constant",
                                         self.load_time_constant, low=0.0, strict=True), rng)
        return out


def load_walk(t: np.ndarray, std: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """A random walk through a first-order lag (an integrated then lagged white noise),
    mean-removed and scaled to standard deviation ``std``: a slow, drifting load."""
    from scipy.signal import lfilter

    if t.size < 2:
        return np.zeros_like(t)
    h = float(t[1] - t[0])
    walk = np.cumsum(rng.standard_normal(t.size))
    a = math.exp(-h / tau)
    lagged = lfilter([1 - a], [1, -a], walk)
    lagged -= lagged.mean()
    s = lagged.std()
    return lagged * (std / s) if s > 0 else lagged


@dataclass(frozen=True)
class SetPoint:
    """Set point: ``initial`` plus a list of ``[time_s, size]`` steps."""

    initial: float = 50.0
    steps: Sequence[Sequence[float]] = field(default_factory=list)

    def generate(self, t: np.ndarray) -> np.ndarray:
        sp = np.full_like(t, number("setpoint.initial", self.initial))
        for i, step in enumerate(self.steps or []):
            try:
                when, size = step
            except (TypeError, ValueError):
                raise InputError(f"setpoint.steps[{i}]: expected [time, size]") from None
            when = number(f"setpoint.steps[{i}][0]", when)
            sp[t >= when] += number(f"setpoint.steps[{i}][1]", size)
        return sp
