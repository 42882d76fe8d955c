#!/usr/bin/env python3
"""Independent ("blind") test-data generator for control-loop fault diagnosis.

Written from scratch, sharing no code with the diagnosing tool.  Simulates a
FOPDT process under a digital PI controller with measurement noise and an
unmeasured integrated-random-walk load, with exactly one effect per recording
(8 classes x 2 levels).  Only numpy / scipy / pyyaml are used for generation;
matplotlib is imported only by --check (plots).

Usage
    python generate.py --out DIR --per-class N --first-seed S [--check] [--plots PLOTDIR]

Outputs per recording: DIR/<name>.csv (t,SP,PV,OP at 1 s, t = 0..3000) and
DIR/<name>.model.yaml (nominal model = loop WITHOUT the effect), and DIR/truth.csv.
Same seed -> byte-identical files.
"""
import argparse
import csv
import hashlib
import math
import os

import numpy as np
from scipy.signal import lfilter

CLASSES = ["none", "stiction", "deadband", "sensor_lag", "dead_time",
           "valve_characteristic", "saturation", "oscillatory_disturbance"]
LEVELS = (1, 2)
T_REC = 3000                 # recorded span, s (rows t = 0..3000)
H = 0.05                     # integration sub-step, s
CTRL_PERIODS = (0.1, 0.2, 0.25, 0.5, 1.0)
SUB_PER_SEC = 20             # 1 / H
OP_MARGIN = 2.0              # non-saturation classes keep OP inside [2, 98] %

TRUTH_COLUMNS = [
    "name", "level", "class", "seed", "attempts",
    # process / controller (true plant; nominal equals true except the effect)
    "K", "tau", "theta", "kc", "ti", "controller_period", "controller_form",
    "tuning_rule", "tuning_lambda", "gain_margin_nominal", "gain_margin_true",
    "closed_loop_tc", "op0",
    # excitation
    "sp0", "n_sp_steps", "sp_step_mean", "noise_frac", "noise_sigma", "noise_type",
    "noise_corr_time", "quantum", "load_scale", "load_pp_op",
    # effects
    "valve_model", "S", "J", "J_over_S", "deadband", "stuck_fraction", "n_valve_moves",
    "lag", "lag_over_tau",
    "true_dead_time", "nominal_dead_time", "dead_time_ratio",
    "characteristic", "char_param", "char_authority", "char_max_dev",
    "char_local_gain_op0", "char_local_gain_min", "char_local_gain_max",
    "saturation_side", "saturation_target", "saturation_fraction_of_time",
    "disturbance_period", "disturbance_period_over_tcl", "disturbance_entry",
    "disturbance_waveform", "disturbance_input_amplitude", "disturbance_amplitude",
    "disturbance_amplitude_frac",
    # recorded-data summary
    "op_min", "op_max",
]


# ----------------------------------------------------------------------------
# small helpers
# ----------------------------------------------------------------------------
def sig(x, n=3):
    """Round to n significant digits (returns a clean float)."""
    if x == 0:
        return 0.0
    return float(f"{x:.{n}g}")


def logu(rng, a, b):
    return float(math.exp(rng.uniform(math.log(a), math.log(b))))


def nice_res(delta):
    """Resolution used for set points: one decade below the step size."""
    return 10.0 ** (math.floor(math.log10(delta)) - 1)


def rnd(x, res):
    return float(f"{round(x / res) * res:.10g}")


def fmt(x):
    """Number formatting for yaml: shortest repr of an already-rounded float."""
    x = float(x)
    return repr(x)


def rec_name(seed):
    return "rec_" + hashlib.sha256(f"blindgen-{seed}".encode()).hexdigest()[:10]


# ----------------------------------------------------------------------------
# valve models (input: OP %, output: valve position MV %)
# ----------------------------------------------------------------------------
class LinearValve:
    def __init__(self, y0):
        self.y = y0

    def step(self, u):
        self.y = u
        return u


class Backlash:
    """Dead band / backlash (play operator) of total width `width` (% travel)."""

    def __init__(self, y0, width):
        self.y = y0
        self.h = width / 2.0

    def step(self, u):
        if u > self.y + self.h:
            self.y = u - self.h
        elif u < self.y - self.h:
            self.y = u + self.h
        return self.y


class ChoudhuryValve:
    """Two-parameter data-driven model, Choudhury, Thornhill & Shah (CEP 2005).

    The valve sticks when the input changes direction or comes to rest, and
    remembers the input x_ss at which it stuck.  It slips when |x - x_ss|
    exceeds S (after a reversal) or J (after a rest in the same direction);
    while moving, y = x - d*(S-J)/2.
    Interpretation used here (stated in README): a reversal of the input while
    the valve is already stuck does not move the stick point x_ss - the stick
    point is where the valve stopped.  (Without this the published flow chart
    re-arms the dead band at every reversal of a noisy OP and the valve never
    moves until the error becomes huge.)
    """

    def __init__(self, y0, S, J):
        self.S, self.J = S, J
        self.y = y0
        self.u_prev = y0
        self.x_ss = y0
        self.d_old = 1          # direction of last movement
        self.I = 0              # 1: stopped by zero velocity, 0: by reversal
        self.moving = False

    def step(self, u):
        S, J = self.S, self.J
        du = u - self.u_prev
        d = (du > 0) - (du < 0)
        if self.moving:
            if d == self.d_old:
                self.y = u - d * (S - J) / 2.0
            elif d == 0:                       # input at rest: valve stops
                self.moving = False
                self.x_ss = self.u_prev
                self.I = 1
            else:                              # reversal: valve sticks
                self.moving = False
                self.x_ss = self.u_prev
                self.I = 0
                self.d_old = d
                if abs(u - self.x_ss) > S:
                    self.y = u - d * (S - J) / 2.0
                    self.moving = True
        else:
            if d != 0:
                off = u - self.x_ss
                do = (off > 0) - (off < 0)
                if do == self.d_old:
                    thr = J if self.I else S
                else:                          # heading the other way: full band
                    thr = S
                if abs(off) > thr:
                    if do != self.d_old:
                        self.I = 0
                    self.d_old = do
                    self.y = u - do * (S - J) / 2.0
                    self.moving = True
        self.u_prev = u
        self.y = min(max(self.y, 0.0), 100.0)
        return self.y


class KanoValve:
    """Kano, Maruta, Kugemoto & Shimizu (DYCOPS 2004) stiction model."""

    def __init__(self, y0, S, J):
        self.S, self.J = S, J
        self.y = y0
        self.u_prev = y0
        self.du_prev = 0.0
        self.us = y0
        self.stp = 1
        self.d = 1

    def step(self, u):
        S, J = self.S, self.J
        du = u - self.u_prev
        if self.stp == 0:
            if du * self.du_prev <= 0.0:           # direction change or rest
                self.us = self.u_prev
                self.stp = 1
            else:
                self.y = u - self.d * (S - J) / 2.0
        if self.stp == 1:
            if -self.d * (u - self.us) > S:        # opposite direction
                self.d = -self.d
                self.y = u - self.d * (S - J) / 2.0
                self.stp = 0
            elif self.d * (u - self.us) > J:       # same direction
                self.y = u - self.d * (S - J) / 2.0
                self.stp = 0
        self.u_prev = u
        self.du_prev = du
        self.y = min(max(self.y, 0.0), 100.0)
        return self.y


class HeValve:
    """He, Wang, Pottmann & Qin (I&ECR 2007) two-parameter stiction model.
    fs = (S+J)/2 static, fd = (S-J)/2 kinetic friction band (needs J <= S)."""

    def __init__(self, y0, S, J):
        self.fs = (S + J) / 2.0
        self.fd = (S - J) / 2.0
        self.y = y0
        self.u_prev = y0
        self.ur = 0.0

    def step(self, u):
        self.ur += u - self.u_prev
        self.u_prev = u
        if abs(self.ur) > self.fs:
            s = 1.0 if self.ur > 0 else -1.0
            self.y += self.ur - s * self.fd
            self.ur = s * self.fd
        self.y = min(max(self.y, 0.0), 100.0)
        return self.y


def make_valve(kind, y0, S=0.0, J=0.0, width=0.0):
    if kind == "linear":
        return LinearValve(y0)
    if kind == "backlash":
        return Backlash(y0, width)
    if kind == "choudhury":
        return ChoudhuryValve(y0, S, J)
    if kind == "kano":
        return KanoValve(y0, S, J)
    if kind == "he":
        return HeValve(y0, S, J)
    raise ValueError(kind)


# ----------------------------------------------------------------------------
# installed valve characteristics: position x in [0,1] -> flow fraction in [0,1]
# ----------------------------------------------------------------------------
def char_fraction(family, R, beta, x):
    x = np.clip(x, 0.0, 1.0)
    if family == "equal_percentage":
        e = (R ** (x - 1.0) - 1.0 / R) / (1.0 - 1.0 / R)
    elif family == "quick_opening":
        e = x
    elif family == "parabolic":           # R is the exponent n here
        e = x ** R
    else:
        raise ValueError(family)
    return e / np.sqrt(beta + (1.0 - beta) * e * e)


def char_dev(family, R, beta):
    x = np.linspace(0, 1, 2001)
    q = char_fraction(family, R, beta, x)
    return float(np.max(np.abs(q - x)))


def solve_authority(family, R, target):
    """Authority beta giving max |q(x)-x| = target (bisection on a branch where
    the deviation is monotone in beta)."""
    x = np.linspace(0, 1, 2001)
    f = lambda b: float(np.max(np.abs(char_fraction(family, R, b, x) - x)))
    if family == "equal_percentage":
        # |dev| falls as beta decreases from 1 (curve straightens), reaches a
        # minimum, then rises again (curve turns quick-opening): use the upper branch
        grid = np.logspace(-2.5, 0, 300)
        b0 = float(grid[int(np.argmin([f(b) for b in grid]))])
        lo, hi = b0, 1.0
        if f(hi) <= target:
            return 1.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if f(mid) < target:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)
    # linear inherent: q >= x everywhere, deviation decreasing in beta
    lo, hi = 0.005, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if f(mid) > target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def ep_min_dev(R):
    x = np.linspace(0, 1, 2001)
    grid = np.logspace(-2.5, 0, 300)
    return float(min(np.max(np.abs(char_fraction("equal_percentage", R, b, x) - x)) for b in grid))


def solve_exponent(target):
    """Exponent n of x^n with max(x - x^n) = target."""
    lo, hi = 1.0, 6.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if char_dev("parabolic", mid, 1.0) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def char_local_gain(family, R, beta, x_pct):
    """d(flow%)/d(position%) at x (per cent)."""
    x = np.asarray(x_pct, dtype=float) / 100.0
    dx = 1e-4
    return (char_fraction(family, R, beta, x + dx) - char_fraction(family, R, beta, x - dx)) / (2 * dx)


# ----------------------------------------------------------------------------
# frequency-domain helpers (continuous approximation, half controller period
# added as delay for the zero-order hold)
# ----------------------------------------------------------------------------
_W = np.logspace(-5, 1.5, 40000)


def loop_tf(K, tau, theta, kc, ti, Tc, lag=0.0, w=_W):
    s = 1j * w
    G = K * np.exp(-(theta + Tc / 2.0) * s) / (tau * s + 1.0) / (lag * s + 1.0)
    C = kc * (1.0 + 1.0 / (ti * s))
    return G, C


def gain_margin(K, tau, theta, kc, ti, Tc, lag=0.0):
    G, C = loop_tf(K, tau, theta, kc, ti, Tc, lag)
    L = G * C
    ph = np.unwrap(np.angle(L))
    idx = np.nonzero(ph <= -np.pi)[0]
    if len(idx) == 0:
        return float("inf")
    i = idx[0]
    if i == 0:
        return 0.0
    f = (-np.pi - ph[i - 1]) / (ph[i] - ph[i - 1])
    mag = abs(L[i - 1]) * (1 - f) + abs(L[i]) * f
    return float(1.0 / mag)


# ----------------------------------------------------------------------------
# the closed-loop simulator
# ----------------------------------------------------------------------------
def simulate(p, sp_ctrl, noise_ctrl, uadd_sub, yadd_sub, t_warm, t_rec=T_REC, want_mv=False):
    """Simulate the loop.

    Time runs from -t_warm to t_rec in sub-steps of H; the controller acts every
    Tc; the historian stores (SP, PV, OP) at integer seconds t >= 0, PV being the
    very measurement the controller used at that instant.
    sp_ctrl, noise_ctrl: per controller instant; uadd_sub: additive process-input
    signal (load + input-entry disturbance, % valve-equivalent) per sub-step;
    yadd_sub: additive PV-side signal per sub-step.
    """
    K, tau, theta = p["K"], p["tau"], p["theta_true"]
    kc, ti, Tc = p["kc"], p["ti"], p["Tc"]
    ce = int(round(Tc / H))
    n_sub = int(round((t_warm + t_rec) / H))
    n_warm = int(round(t_warm / H))
    a = math.exp(-H / tau)
    b1 = (1.0 - a) * K
    nd = int(round(theta / H))
    lag = p.get("lag", 0.0)
    al = math.exp(-H / lag) if lag > 0 else 0.0
    q = p.get("quantum", 0.0)
    velocity = p["form"] == "velocity"
    kit = kc * Tc / ti
    op0 = p["op0"]
    bias = p["bias"]

    char = p.get("char")
    if char is not None:
        fam, R, beta = char
        # tabulate f on a fine grid for speed (linear interpolation)
        xg = np.linspace(0.0, 100.0, 20001)
        fg = (100.0 * char_fraction(fam, R, beta, xg / 100.0)).tolist()

        def flow_of(mv):
            pos = mv * 200.0
            i = int(pos)
            if i >= 20000:
                return fg[20000]
            fr = pos - i
            return fg[i] * (1.0 - fr) + fg[i + 1] * fr
    else:
        flow_of = None

    valve = make_valve(p["valve"], op0, p.get("S", 0.0), p.get("J", 0.0), p.get("width", 0.0))
    op0 = float(op0)
    mv = op0
    flow = flow_of(mv) if flow_of else mv
    u_ss = flow + float(uadd_sub[0])
    y = K * u_ss
    # bias chosen by caller so that PV(start) == SP(start) when bias is None
    if bias is None:
        bias = float(sp_ctrl[0]) - y - float(yadd_sub[0])
    z = bias + y + float(yadd_sub[0])
    nb = nd + 1
    buf = [u_ss] * nb
    op = op0
    integ = op0
    e_prev = 0.0          # loop starts at steady state (e = 0)

    n_rec = t_rec + 1
    out_sp = np.empty(n_rec)
    out_pv = np.empty(n_rec)
    out_op = np.empty(n_rec)
    out_mv = np.empty(n_rec) if want_mv else None
    n_ctrl_after = 0
    n_stuck = 0
    n_moves = 0
    n_sat = 0
    op_lo, op_hi = 1e9, -1e9
    mv_prev = mv

    uadd = np.asarray(uadd_sub, dtype=float).tolist()
    yadd = np.asarray(yadd_sub, dtype=float).tolist()
    sp_l = np.asarray(sp_ctrl, dtype=float).tolist()
    nz_l = np.asarray(noise_ctrl, dtype=float).tolist()
    for i in range(n_sub + 1):
        if i % ce == 0:
            k = i // ce
            pv_true = bias + y + yadd[i]
            meas = (z if lag > 0 else pv_true) + nz_l[k]
            if q > 0:
                meas = round(meas / q) * q
            sp = sp_l[k]
            e = sp - meas
            if velocity:
                op = op + kc * (e - e_prev) + kit * e
                if op > 100.0:
                    op = 100.0
                elif op < 0.0:
                    op = 0.0
            else:
                un = kc * e + integ
                op = 100.0 if un > 100.0 else (0.0 if un < 0.0 else un)
                if not ((un >= 100.0 and e > 0) or (un <= 0.0 and e < 0)):
                    integ += kit * e
            e_prev = e
            mv = valve.step(op)
            flow = flow_of(mv) if flow_of else mv
            if i >= n_warm:
                n_ctrl_after += 1
                if mv == mv_prev:
                    n_stuck += 1
                else:
                    n_moves += 1
                if op <= 0.0 or op >= 100.0:
                    n_sat += 1
                if op < op_lo:
                    op_lo = op
                if op > op_hi:
                    op_hi = op
                if (i - n_warm) % SUB_PER_SEC == 0:
                    r = (i - n_warm) // SUB_PER_SEC
                    out_sp[r] = sp
                    out_pv[r] = meas
                    out_op[r] = op
                    if want_mv:
                        out_mv[r] = mv
            mv_prev = mv
        if i == n_sub:
            break
        buf[i % nb] = flow + uadd[i]
        y = a * y + b1 * buf[(i + 1) % nb]
        if lag > 0:
            z = al * z + (1.0 - al) * (bias + y + yadd[i + 1])
    return {
        "t": np.arange(n_rec), "sp": out_sp, "pv": out_pv, "op": out_op, "mv": out_mv,
        "stuck_fraction": n_stuck / max(n_ctrl_after, 1), "n_moves": n_moves,
        "sat_fraction_ctrl": n_sat / max(n_ctrl_after, 1),
        "op_min_ctrl": op_lo, "op_max_ctrl": op_hi, "bias": bias,
    }


# ----------------------------------------------------------------------------
# scenario drawing
# ----------------------------------------------------------------------------
def draw_loop(rng):
    """Process, tuning, controller period and form."""
    u = rng.uniform()
    if u < 0.10:                                      # the paper's loop
        K, tau, theta = 3.0, 10.0, 10.0
        kc, ti, rule, lam = 0.2, 10.0, "paper", None
    else:
        if u < 0.22:                                  # paper neighbourhood
            K = sig(3.0 * logu(rng, 0.75, 1.33), 3)
            tau = round(10.0 * logu(rng, 0.75, 1.33), 1)
            theta = round(10.0 * logu(rng, 0.75, 1.33), 1)
        else:                                         # general process loops
            K = sig(logu(rng, 0.3, 5.0), 3)
            tau = sig(logu(rng, 3.0, 150.0), 3)
            tau = round(tau, 1)
            theta = tau * logu(rng, 0.05, 1.0)
            theta = round(min(max(theta, 1.0), 90.0), 1)
        if rng.uniform() < 0.5:                       # lambda (IMC-PI) tuning
            rule = "lambda"
            lam = max(tau * logu(rng, 0.5, 3.0), 0.7 * theta)
            kc = tau / (K * (lam + theta))
            ti = tau
        else:                                         # SIMC
            rule = "simc"
            lam = theta * logu(rng, 0.7, 3.0)
            lam = max(lam, 0.2 * tau) if rng.uniform() < 0.5 else lam
            kc = tau / (K * (lam + theta))
            ti = min(tau, 4.0 * (lam + theta))
        kc = sig(kc, 3)
        ti = sig(ti, 3)
        lam = round(lam, 2)
    allowed = [c for c in CTRL_PERIODS if c <= max(0.1, min(tau, theta + tau) / 5.0)]
    Tc = float(allowed[rng.integers(len(allowed))])
    form = "velocity" if rng.uniform() < 0.6 else "position"
    return dict(K=K, tau=tau, theta=theta, theta_true=theta, kc=kc, ti=ti, rule=rule,
                lam=lam, Tc=Tc, form=form)


def closed_loop_tc(p):
    """63 % rise time of the nominal noise-free closed loop after a unit SP step."""
    D = int(min(3000, max(200, 30 * (p["tau"] + p["theta"]))))
    q = dict(p, valve="linear", lag=0.0, quantum=0.0, op0=50.0, bias=0.0,
             theta_true=p["theta"], char=None)
    ce = int(round(p["Tc"] / H))
    n_ctrl = int(round(D / H)) // ce + 1
    sp = np.ones(n_ctrl)
    n_sub = int(round(D / H)) + 1
    # bias 0 and K*50 initial output: shift SP so that the step is +1 from y0
    y0 = p["K"] * 50.0
    sp = sp + y0
    r = simulate(q, sp, np.zeros(n_ctrl), np.zeros(n_sub), np.zeros(n_sub), 0, D)
    pv = r["pv"] - y0
    idx = np.nonzero(pv >= 0.632)[0]
    if len(idx) == 0:
        return float(D)
    i = idx[0]
    if i == 0:
        return 0.5
    return float(i - 1 + (0.632 - pv[i - 1]) / (pv[i] - pv[i - 1]))


def draw_sp(rng, K, tcl, t_warm, Tc):
    """Set-point schedule: a few steps on integer seconds."""
    dop = rng.uniform(4.0, 12.0)                      # OP move per step (linear valve), %
    delta = sig(K * dop, 2)
    res = nice_res(delta)
    sp0 = rnd(10 ** rng.uniform(math.log10(5 * delta), math.log10(100 * delta)), res)
    gap = min(max(4.0 * tcl, 150.0), 900.0)
    n_target = int(rng.integers(2, 7))
    times = []
    t = rng.uniform(100.0, 400.0)
    while len(times) < n_target and t < T_REC - 200:
        times.append(int(t))
        t = t + gap * rng.uniform(1.0, 2.0)
    if len(times) < 2:                                # squeeze in a second step
        times = [int(rng.uniform(100, 300)), int(rng.uniform(1500, 2700))]
    levels = [sp0]
    cur = sp0
    for _ in times:
        mag = delta * rng.uniform(0.6, 1.4)
        sgn = 1.0 if rng.uniform() < 0.5 else -1.0
        if abs(cur + sgn * mag - sp0) > 1.6 * delta:
            sgn = -sgn
        cur = rnd(cur + sgn * mag, res)
        levels.append(cur)
    steps = np.abs(np.diff(levels))
    return dict(delta=delta, sp0=sp0, times=times, levels=levels, step_mean=float(np.mean(steps)))


def sp_on_ctrl_grid(spd, t_warm, Tc, t_rec=T_REC):
    ce = int(round(Tc / H))
    n_sub = int(round((t_warm + t_rec) / H))
    n_ctrl = n_sub // ce + 1
    tc = -t_warm + np.arange(n_ctrl) * Tc
    sp = np.full(n_ctrl, spd["levels"][0])
    for tt, lv in zip(spd["times"], spd["levels"][1:]):
        sp[tc >= tt - 1e-9] = lv
    return sp


def draw_noise(rng, n_ctrl, Tc, sigma):
    u = rng.uniform()
    w = rng.standard_normal(n_ctrl)
    if u < 0.6:
        return w * sigma, "white", None, 0.0
    if u < 0.85:
        tcor = round(rng.uniform(1.0, 5.0), 2)
        phi = math.exp(-Tc / tcor)
        e = np.empty(n_ctrl)
        e[0] = w[0]
        e[1:] = lfilter([math.sqrt(1 - phi * phi)], [1.0, -phi], w[1:], zi=[phi * w[0]])[0]
        return e * sigma, "ar1", tcor, 0.0
    qv = sigma * rng.uniform(0.5, 1.5)
    # quantum: a "nice" number (1, 2 or 5 x 10^k)
    ex = math.floor(math.log10(qv))
    m = qv / 10 ** ex
    m = 1.0 if m < 1.5 else (2.0 if m < 3.5 else 5.0)
    qv = float(f"{m * 10 ** ex:.6g}")
    return w * sigma, "white_quantised", None, qv


def draw_load(rng, t_warm, K, delta, level):
    """Integrated random walk (double-integrated white noise) at process input,
    in % valve-equivalent, scaled so its peak-to-peak over the record equals
    load_scale * delta / K."""
    n = t_warm + T_REC + 1
    w = rng.standard_normal(n)
    irw = np.cumsum(np.cumsum(w))
    rec = irw[t_warm:]
    pp = float(rec.max() - rec.min())
    load_scale = rng.uniform(0.2, 0.8) if level == 1 else rng.uniform(0.5, 1.5)
    pp_op = load_scale * delta / K
    L = (irw - irw[t_warm]) * (pp_op / pp)
    # to sub-step resolution
    ts = np.arange(int(round((t_warm + T_REC) / H)) + 1) * H
    Ls = np.interp(ts, np.arange(n, dtype=float), L)
    return Ls, load_scale, pp_op


def nominal_open_loop(m, op):
    """PV predicted by the nominal FOPDT from the recorded 1-s OP (ZOH, dead time
    rounded to whole seconds), up to a constant."""
    K = m["process"]["gain"]
    tau = m["process"]["time_constant"]
    nd = int(round(m["process"]["dead_time"]))
    a = math.exp(-1.0 / tau)
    u = np.concatenate([np.full(nd, op[0]), op])[:len(op)]
    y = lfilter([K * (1 - a)], [1.0, -a], u - op[0], zi=[0.0])[0]
    return y - np.mean(y) + 0.0


def fit_sine(x, w):
    t = np.arange(len(x), dtype=float)
    A = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t), t / len(t)])
    c, *_ = np.linalg.lstsq(A, x, rcond=None)
    return float(math.hypot(c[0], c[1]))


# ----------------------------------------------------------------------------
# one recording
# ----------------------------------------------------------------------------
def make_recording(seed, level, cls, want_mv=False):
    rng = np.random.default_rng(seed)
    attempts = 0
    while True:
        attempts += 1
        if attempts > 200:
            raise RuntimeError(f"seed {seed}: no valid scenario")
        lp = draw_loop(rng)
        gm_nom = gain_margin(lp["K"], lp["tau"], lp["theta"], lp["kc"], lp["ti"], lp["Tc"])
        if gm_nom < 1.7:
            continue
        tcl = closed_loop_tc(lp)
        t_warm = int(max(300, min(1200, 5 * (lp["tau"] + lp["theta"]) + 3 * tcl)))
        ce = int(round(lp["Tc"] / H))
        n_sub = int(round((t_warm + T_REC) / H))
        n_ctrl = n_sub // ce + 1

        spd = draw_sp(rng, lp["K"], tcl, t_warm, lp["Tc"])
        sp_ctrl = sp_on_ctrl_grid(spd, t_warm, lp["Tc"])
        noise_frac = rng.uniform(0.01, 0.05) if level == 1 else rng.uniform(0.03, 0.10)
        sigma = noise_frac * spd["step_mean"]
        noise, ntype, ncorr, quantum = draw_noise(rng, n_ctrl, lp["Tc"], sigma)
        load_sub, load_scale, load_pp_op = draw_load(rng, t_warm, lp["K"], spd["delta"], level)
        op0 = round(rng.uniform(30.0, 70.0), 2)

        p = dict(lp, valve="linear", lag=0.0, quantum=quantum, op0=op0, bias=None, char=None)
        uadd = load_sub.copy()
        yadd = np.zeros(n_sub + 1)
        tr = {c: None for c in TRUTH_COLUMNS}
        gm_true = gm_nom

        if cls == "stiction":
            model = ["choudhury", "kano", "he"][int(rng.integers(3))]
            S = logu(rng, 1.0, 6.0) if level == 1 else logu(rng, 0.2, 1.0)
            r = rng.uniform()
            if r < 0.5:
                js = rng.uniform(0.1, 0.9)
            elif r < 0.7:
                js = 1.0
            else:
                js = rng.uniform(1.05, 1.6)
            if model == "he" and js > 1.0:
                js = 1.0 / js
            S = round(S, 3)
            J = round(S * js, 3)
            p.update(valve=model, S=S, J=J)
            tr.update(valve_model=model, S=S, J=J, J_over_S=round(J / S, 3))
        elif cls == "deadband":
            d = round(logu(rng, 1.0, 6.0) if level == 1 else logu(rng, 0.2, 1.0), 3)
            p.update(valve="backlash", width=d)
            tr.update(valve_model="backlash", deadband=d)
        elif cls == "sensor_lag":
            r = logu(rng, 0.25, 0.8) if level == 1 else logu(rng, 0.07, 0.25)
            lag = round(max(2.0 if level == 1 else 1.0, r * lp["tau"]), 2)
            p["lag"] = lag
            gm_true = gain_margin(lp["K"], lp["tau"], lp["theta"], lp["kc"], lp["ti"], lp["Tc"], lag)
            if gm_true < 1.4:
                continue
            tr.update(lag=lag, lag_over_tau=round(lag / lp["tau"], 4))
        elif cls == "dead_time":
            th = lp["theta"]
            longer = rng.uniform() < 0.7
            if level == 1:
                ratio = logu(rng, 1.3, 2.0) if longer else rng.uniform(0.4, 0.75)
                dmin = 2.0
            else:
                ratio = rng.uniform(1.1, 1.3) if longer else rng.uniform(0.75, 0.9)
                dmin = 1.0
            if not longer and th * ratio < 0.5 + 1e-9 or (not longer and th - dmin < 0.5):
                longer = True              # too short to shorten: mirror the change
                ratio = 2.0 - ratio
            diff = th * (ratio - 1.0)
            if abs(diff) < dmin:
                diff = dmin if longer else -dmin
            th_true = round(th + diff, 1)
            if th_true < 0.5:
                continue
            p["theta_true"] = th_true
            gm_true = gain_margin(lp["K"], lp["tau"], th_true, lp["kc"], lp["ti"], lp["Tc"])
            if gm_true < 1.4:
                continue
            tr.update(true_dead_time=th_true, nominal_dead_time=th,
                      dead_time_ratio=round(th_true / th, 4))
        elif cls == "valve_characteristic":
            concave = rng.uniform() < 0.55          # flow lags opening (EP-like)
            target = rng.uniform(0.12, 0.30) if level == 1 else rng.uniform(0.04, 0.12)
            Rr = round(rng.uniform(20.0, 50.0), 1)
            if concave:
                fam, par = "equal_percentage", Rr
                if target < ep_min_dev(Rr) + 0.005:
                    # an installed EP valve cannot be this close to linear:
                    # use a modified-parabolic inherent characteristic x^n instead
                    fam, par, beta = "parabolic", solve_exponent(target), 1.0
                else:
                    beta = solve_authority(fam, par, target)
            else:
                fam, par = "quick_opening", 0.0
                beta = solve_authority(fam, par, target)
            beta = round(beta, 4)
            par = round(par, 4)
            dev = char_dev(fam, par, beta)
            p["char"] = (fam, par, beta)
            tr.update(characteristic=fam, char_param=(par if fam != "quick_opening" else None),
                      char_authority=beta, char_max_dev=round(dev, 4),
                      char_local_gain_op0=round(float(char_local_gain(fam, par, beta, op0)), 4))
        elif cls == "saturation":
            side = "high" if rng.uniform() < 0.6 else "low"
            target = rng.uniform(0.06, 0.25) if level == 1 else rng.uniform(0.01, 0.05)
            tr.update(saturation_side=side, saturation_target=round(target, 4))
        elif cls == "oscillatory_disturbance":
            m = logu(rng, 2.0, 50.0)
            period = min(max(m * tcl, 6.0), max(600.0, 2.0 * tcl))   # >= 5 cycles unless tcl > 300 s
            period = round(period, 1)
            wd = 2 * math.pi / period
            entry = "input" if rng.uniform() < 0.5 else "output"
            wave = "sine" if rng.uniform() < 0.7 else "distorted"
            amp_frac = logu(rng, 0.04, 0.25) if level == 1 else logu(rng, 0.01, 0.05)
            amp_pv = amp_frac * spd["step_mean"]
            G, C = loop_tf(lp["K"], lp["tau"], lp["theta"], lp["kc"], lp["ti"], lp["Tc"],
                           w=np.array([wd]))
            Sens = 1.0 / (1.0 + G * C)
            if entry == "input":
                path = G
                taud = None
            else:
                taud = round(lp["tau"] * logu(rng, 0.2, 2.0), 2)
                path = np.array([1.0 / (1j * wd * taud + 1.0)])
            ain = float(amp_pv / abs(Sens[0] * path[0]))
            op_amp = float(abs((C * Sens * path)[0]) * ain)
            if op_amp > 15.0:
                continue
            phase = rng.uniform(0, 2 * math.pi)
            ts = -t_warm + np.arange(n_sub + 1) * H
            sig_d = np.sin(wd * ts + phase)
            if wave == "distorted":
                r3 = rng.uniform(0.1, 0.3)
                sig_d = sig_d + r3 * np.sin(3 * (wd * ts + phase) + rng.uniform(0, 2 * math.pi))
                wave = f"sine+{r3:.2f}*3rd"
            sig_d = sig_d * ain
            if entry == "input":
                uadd = uadd + sig_d
                dist_in, dist_out = sig_d, np.zeros(n_sub + 1)
            else:
                ad = math.exp(-H / taud)
                yd = lfilter([1 - ad], [1, -ad], sig_d)
                yadd = yadd + yd
                dist_in, dist_out = np.zeros(n_sub + 1), yd
            tr.update(disturbance_period=period, disturbance_period_over_tcl=round(period / tcl, 3),
                      disturbance_entry=entry if entry == "input" else f"output(lag {taud})",
                      disturbance_waveform=wave, disturbance_input_amplitude=sig(ain, 4))

        # ---- simulate -----------------------------------------------------
        if cls == "saturation":
            res, op0 = saturate_search(p, sp_ctrl, noise, uadd, yadd, t_warm,
                                       tr["saturation_side"], tr["saturation_target"])
            p["op0"] = op0
            sat_frac = float(np.mean((res["op"] <= 0.0) | (res["op"] >= 100.0)))
            if sat_frac < 0.5 * tr["saturation_target"] or sat_frac <= 0.0:
                continue
            tr["saturation_fraction_of_time"] = round(sat_frac, 4)
        else:
            res = simulate(p, sp_ctrl, noise, uadd, yadd, t_warm, want_mv=want_mv)
            if res["op_min_ctrl"] < OP_MARGIN or res["op_max_ctrl"] > 100.0 - OP_MARGIN:
                continue            # keep saturation out of the other classes
            tr["saturation_fraction_of_time"] = None
        if want_mv and res["mv"] is None:
            res = simulate(p, sp_ctrl, noise, uadd, yadd, t_warm, want_mv=True)

        if cls == "valve_characteristic":
            fam, R, beta = p["char"]
            xs = np.linspace(res["op_min_ctrl"], res["op_max_ctrl"], 200)
            lg = char_local_gain(fam, R, beta, xs)
            gmin, gmax = float(lg.min()), float(lg.max())
            if gm_nom / gmax < 1.4:
                continue
            gm_true = gm_nom / gmax
            tr.update(char_local_gain_min=round(gmin, 4), char_local_gain_max=round(gmax, 4))
        if cls in ("stiction", "deadband"):
            tr.update(stuck_fraction=round(res["stuck_fraction"], 4), n_valve_moves=res["n_moves"])
        if cls == "oscillatory_disturbance":
            # closed-loop PV amplitude of the fundamental, from a disturbance-only run
            q = dict(p, quantum=0.0)
            spc = np.full_like(sp_ctrl, sp_ctrl[0])
            rd = simulate(q, spc, np.zeros_like(noise), dist_in, dist_out, t_warm)
            amp = fit_sine(rd["pv"] - spc[0], wd)
            tr.update(disturbance_amplitude=sig(amp, 4),
                      disturbance_amplitude_frac=round(amp / spd["step_mean"], 4))
        break

    tr.update(level=level, **{"class": cls}, seed=seed, attempts=attempts,
              K=lp["K"], tau=lp["tau"], theta=p["theta_true"], kc=lp["kc"], ti=lp["ti"],
              controller_period=lp["Tc"], controller_form=lp["form"], tuning_rule=lp["rule"],
              tuning_lambda=lp["lam"], gain_margin_nominal=round(gm_nom, 3),
              gain_margin_true=round(gm_true, 3), closed_loop_tc=round(tcl, 2),
              op0=round(p["op0"], 3), sp0=spd["sp0"], n_sp_steps=len(spd["times"]),
              sp_step_mean=sig(spd["step_mean"], 6), noise_frac=round(noise_frac, 5),
              noise_sigma=sig(sigma, 5), noise_type=ntype, noise_corr_time=ncorr,
              quantum=quantum if quantum > 0 else None, load_scale=round(load_scale, 4),
              load_pp_op=round(load_pp_op, 4),
              op_min=round(float(res["op"].min()), 4), op_max=round(float(res["op"].max()), 4))
    if cls == "dead_time":
        tr["theta"] = p["theta_true"]
    nominal = dict(gain=lp["K"], time_constant=lp["tau"], dead_time=lp["theta"],
                   kc=lp["kc"], ti=lp["ti"])
    return res, nominal, tr, p


def saturate_search(p, sp_ctrl, noise, uadd, yadd, t_warm, side, target):
    """Bisection on the operating point so that OP sits at a limit for about
    `target` of the recorded samples (all random signals held fixed)."""
    lo, hi = (40.0, 99.5) if side == "high" else (0.5, 60.0)

    def frac(op0):
        q = dict(p, op0=op0)
        r = simulate(q, sp_ctrl, noise, uadd, yadd, t_warm)
        return float(np.mean((r["op"] <= 0.0) | (r["op"] >= 100.0))), r

    best = None
    for _ in range(16):
        mid = round(0.5 * (lo + hi), 3)
        f, r = frac(mid)
        if best is None or abs(f - target) < abs(best[0] - target):
            best = (f, r, mid)
        toward_limit_more = f < target
        if side == "high":
            if toward_limit_more:
                lo = mid
            else:
                hi = mid
        else:
            if toward_limit_more:
                hi = mid
            else:
                lo = mid
        if abs(f - target) < 0.1 * target:
            break
    return best[1], best[2]


# ----------------------------------------------------------------------------
# writing
# ----------------------------------------------------------------------------
def write_recording(out, name, res, nominal):
    lines = ["t,SP,PV,OP"]
    t, sp, pv, op = res["t"], res["sp"], res["pv"], res["op"]
    for i in range(len(t)):
        lines.append(f"{int(t[i])},{sp[i]:.10g},{pv[i]:.8g},{op[i]:.4f}")
    with open(os.path.join(out, name + ".csv"), "w", newline="\n") as f:
        f.write("\n".join(lines) + "\n")
    y = (f"process: {{gain: {fmt(nominal['gain'])}, time_constant: {fmt(nominal['time_constant'])}, "
         f"dead_time: {fmt(nominal['dead_time'])}}}\n"
         f"controller: {{kc: {fmt(nominal['kc'])}, ti: {fmt(nominal['ti'])}}}\n"
         f"sample_time: 1.0\n"
         f"op_range: [0, 100]\n")
    with open(os.path.join(out, name + ".model.yaml"), "w", newline="\n") as f:
        f.write(y)


def cell(v):
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.10g}"
    return str(v)


def plan(per_class, first_seed):
    jobs = []
    s = first_seed
    for level in LEVELS:
        for cls in CLASSES:
            for _ in range(per_class):
                jobs.append((s, level, cls))
                s += 1
    return jobs


def generate(out, per_class, first_seed, quiet=False):
    os.makedirs(out, exist_ok=True)
    rows = []
    for seed, level, cls in plan(per_class, first_seed):
        res, nominal, tr, _ = make_recording(seed, level, cls)
        name = rec_name(seed)
        tr["name"] = name
        write_recording(out, name, res, nominal)
        rows.append(tr)
        if not quiet:
            print(f"{name} L{level} {cls:24s} seed={seed} attempts={tr['attempts']}", flush=True)
    with open(os.path.join(out, "truth.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(TRUTH_COLUMNS)
        for r in rows:
            w.writerow([cell(r[c]) for c in TRUTH_COLUMNS])
    return rows


# ----------------------------------------------------------------------------
# sanity checks (reads the written files; re-simulates a few for MV plots)
# ----------------------------------------------------------------------------
def check(out, plotdir=None, per_class_plots=1):
    import yaml
    with open(os.path.join(out, "truth.csv")) as f:
        truth = list(csv.DictReader(f))
    print(f"\n=== sanity check of {out}: {len(truth)} recordings ===")
    stats = {}
    for r in truth:
        d = np.loadtxt(os.path.join(out, r["name"] + ".csv"), delimiter=",", skiprows=1)
        with open(os.path.join(out, r["name"] + ".model.yaml")) as f:
            m = yaml.safe_load(f)
        assert set(m) == {"process", "controller", "sample_time", "op_range"}, m
        assert d.shape == (T_REC + 1, 4)
        t, sp, pv, op = d.T
        e = sp - pv
        pv = pv - np.mean(pv)
        sat = float(np.mean((op <= 0) | (op >= 100)))
        step = float(r["sp_step_mean"])
        # error statistics away from SP steps (> 3 tcl after a step)
        ch = np.nonzero(np.diff(sp) != 0)[0] + 1
        mask = np.ones_like(t, dtype=bool)
        tcl = float(r["closed_loop_tc"])
        for c in ch:
            mask[c:int(c + 4 * tcl) + 1] = False
        mask[:50] = False
        e_std = float(np.std(e[mask])) / step if mask.sum() > 100 else float("nan")
        key = (int(r["level"]), r["class"])
        row = dict(op_min=op.min(), op_max=op.max(), sat=sat, e_std_rel=e_std,
                   noise=float(r["noise_frac"]))
        if r["class"] == "oscillatory_disturbance":
            P = float(r["disturbance_period"])
            # residual of the nominal open-loop model driven by the recorded OP
            # (contains load + disturbance + noise); amplitude at P against the
            # median amplitude at 24 nearby periods (0.55..1.8 P, |P'/P-1| > 0.15)
            res_ = pv - nominal_open_loop(m, op)
            tt = np.arange(len(res_)) / len(res_)
            res_ = res_ - np.polyval(np.polyfit(tt, res_, 3), tt)
            wP = 2 * math.pi / P
            a_res = fit_sine(res_, wP)
            others = [p_ for p_ in np.geomspace(0.55 * P, 1.8 * P, 40) if abs(p_ / P - 1) > 0.15][:24]
            ref = np.median([fit_sine(res_, 2 * math.pi / p_) for p_ in others])
            row["osc_fit_rel"] = a_res / step
            row["osc_snr"] = a_res / ref
            row["osc_true_rel"] = float(r["disturbance_amplitude_frac"])
        stats.setdefault(key, []).append((r, row))
    hdr = f"{'L':>1} {'class':24s} {'n':>2} {'OPmin':>6} {'OPmax':>6} {'sat%':>6} {'std(e)/step':>11} {'noise/step':>10}  effect"
    print(hdr)
    for level in LEVELS:
        for cls in CLASSES:
            lst = stats.get((level, cls), [])
            if not lst:
                continue
            R = [x[1] for x in lst]
            T = [x[0] for x in lst]
            opmin = min(x["op_min"] for x in R)
            opmax = max(x["op_max"] for x in R)
            sat = np.mean([x["sat"] for x in R]) * 100
            es = np.nanmedian([x["e_std_rel"] for x in R])
            nz = np.median([x["noise"] for x in R])
            if cls == "stiction":
                eff = ("S %.2f-%.2f, J/S %.2f-%.2f, stuck frac %.2f-%.2f, models %s" % (
                    min(float(t["S"]) for t in T), max(float(t["S"]) for t in T),
                    min(float(t["J_over_S"]) for t in T), max(float(t["J_over_S"]) for t in T),
                    min(float(t["stuck_fraction"]) for t in T), max(float(t["stuck_fraction"]) for t in T),
                    ",".join(sorted(set(t["valve_model"] for t in T)))))
            elif cls == "deadband":
                eff = "db %.2f-%.2f, stuck frac %.2f-%.2f" % (
                    min(float(t["deadband"]) for t in T), max(float(t["deadband"]) for t in T),
                    min(float(t["stuck_fraction"]) for t in T), max(float(t["stuck_fraction"]) for t in T))
            elif cls == "sensor_lag":
                eff = "lag %.1f-%.1f s, lag/tau %.2f-%.2f" % (
                    min(float(t["lag"]) for t in T), max(float(t["lag"]) for t in T),
                    min(float(t["lag_over_tau"]) for t in T), max(float(t["lag_over_tau"]) for t in T))
            elif cls == "dead_time":
                eff = "ratio %.2f-%.2f, |diff| %.1f-%.1f s, GMtrue min %.2f" % (
                    min(float(t["dead_time_ratio"]) for t in T), max(float(t["dead_time_ratio"]) for t in T),
                    min(abs(float(t["true_dead_time"]) - float(t["nominal_dead_time"])) for t in T),
                    max(abs(float(t["true_dead_time"]) - float(t["nominal_dead_time"])) for t in T),
                    min(float(t["gain_margin_true"]) for t in T))
            elif cls == "valve_characteristic":
                eff = "maxdev %.3f-%.3f, local gain %.2f-%.2f, %s" % (
                    min(float(t["char_max_dev"]) for t in T), max(float(t["char_max_dev"]) for t in T),
                    min(float(t["char_local_gain_min"]) for t in T), max(float(t["char_local_gain_max"]) for t in T),
                    ",".join(sorted(set(t["characteristic"] for t in T))))
            elif cls == "saturation":
                eff = "sat frac %.3f-%.3f (targets %.3f-%.3f)" % (
                    min(x["sat"] for x in R), max(x["sat"] for x in R),
                    min(float(t["saturation_target"]) for t in T), max(float(t["saturation_target"]) for t in T))
            elif cls == "oscillatory_disturbance":
                eff = "P %.0f-%.0f s (%.1f-%.1f tcl), amp/step true %.3f-%.3f, open-loop residual amp/step %.3f-%.3f, peak/neighbours %.1f-%.1f" % (
                    min(float(t["disturbance_period"]) for t in T), max(float(t["disturbance_period"]) for t in T),
                    min(float(t["disturbance_period_over_tcl"]) for t in T), max(float(t["disturbance_period_over_tcl"]) for t in T),
                    min(x["osc_true_rel"] for x in R), max(x["osc_true_rel"] for x in R),
                    min(x["osc_fit_rel"] for x in R), max(x["osc_fit_rel"] for x in R),
                    min(x["osc_snr"] for x in R), max(x["osc_snr"] for x in R))
            else:
                eff = ""
            print(f"{level:>1} {cls:24s} {len(R):>2} {opmin:6.1f} {opmax:6.1f} {sat:6.2f} {es:11.4f} {nz:10.4f}  {eff}")
    if plotdir:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        os.makedirs(plotdir, exist_ok=True)
        for (level, cls), lst in sorted(stats.items()):
            for r, _ in lst[:per_class_plots]:
                seed = int(r["seed"])
                res, nominal, tr, p = make_recording(seed, level, cls, want_mv=True)
                fig, ax = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
                ax[0].plot(res["t"], res["pv"], lw=0.6, label="PV")
                ax[0].plot(res["t"], res["sp"], lw=1.0, label="SP")
                ax[0].legend(loc="upper right")
                ax[1].plot(res["t"], res["op"], lw=0.6, label="OP")
                ax[1].plot(res["t"], res["mv"], lw=0.8, label="MV (hidden)")
                ax[1].legend(loc="upper right")
                ax[0].set_title(f"{r['name']} L{level} {cls} seed {seed}")
                ax[1].set_xlabel("t [s]")
                fig.tight_layout()
                fig.savefig(os.path.join(plotdir, f"L{level}_{cls}_{seed}.png"), dpi=80)
                plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--per-class", type=int, required=True)
    ap.add_argument("--first-seed", type=int, required=True)
    ap.add_argument("--check", action="store_true", help="print sanity statistics after generating")
    ap.add_argument("--plots", default=None, help="directory for PNG plots (implies --check)")
    ap.add_argument("--plots-per-class", type=int, default=1)
    ap.add_argument("--check-only", action="store_true", help="do not generate, only check DIR")
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    if not a.check_only:
        generate(a.out, a.per_class, a.first_seed, quiet=a.quiet)
    if a.check or a.plots or a.check_only:
        check(a.out, a.plots, a.plots_per_class)


if __name__ == "__main__":
    main()
