#!/usr/bin/env python
"""Independent closed-loop test-data generator ("blindgen2").

Simulates single PI loops on a self-regulating process with one effect per recording
(8 classes x 2 levels) and writes historian-style records t,SP,PV,OP at 1 s, the
nominal FOPDT model of each loop (without the effect) and a truth table.

Usage
  python generate.py --out DIR --per-class N --first-seed S [--checks FILE] [--plots DIR]
                     [--jobs J]

--checks / --plots only add diagnostics outside DIR; they never change the files in DIR.
Only numpy, scipy and pyyaml are used for the data (matplotlib only for --plots).
"""
import argparse
import csv
import hashlib
import math
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import yaml
from scipy.optimize import brentq
from scipy.signal import lfilter

CLASSES = ["none", "stiction", "deadband", "sensor_lag", "dead_time",
           "valve_characteristic", "saturation", "oscillatory_disturbance"]
LEVELS = (1, 2)

DT = 0.1            # integration step, s
T_REC = 3000        # recorded length, s (samples t = 0 .. 2999)
T_WARM = 400.0      # simulated before t = 0 (not recorded)
OP_LO, OP_HI = 0.0, 100.0

TRUTH_COLUMNS = [
    "name", "level", "class", "seed",
    # effect parameters
    "stiction_model", "stiction_S", "stiction_J",
    "deadband",
    "sensor_lag_tc", "sensor_lag_rel_tcl",
    "dead_time_true_over_model", "dead_time_effect_true",
    "valve_char_type", "valve_rangeability", "valve_authority", "valve_gain_ratio",
    "sat_mode", "sat_side", "sat_limit", "sat_target_frac", "sat_frac_at_limit", "sat_frac_near_limit",
    "osc_period", "osc_period_rel_tcl", "osc_amplitude_pv", "osc_entry", "osc_h2", "osc_h3",
    # loop parameters
    "model_gain", "model_time_constant", "model_dead_time", "kc", "ti",
    "tuning_rule", "lambda", "t_cl", "ctrl_period",
    "true_gain", "true_tau1", "true_tau2", "true_dead_time",
    "noise_detuned", "op_noise_p",
    "pv0", "op0", "sp_step", "n_sp_steps",
    "noise_sd", "noise_rel_sp_step", "noise_coloured_frac", "noise_tc",
    "load_drift_op", "load_tc", "load_step_op", "load_step_time", "load_attempt",
]


# ----------------------------------------------------------------------------- helpers
def loguniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def sig(x, n=3):
    """Round to n significant digits, return a plain float."""
    if x == 0:
        return 0.0
    return float(f"{x:.{n}g}")


def fmt_num(x):
    return repr(float(x))


def stream(seed, tag):
    """Independent deterministic random stream for (seed, tag)."""
    return np.random.default_rng(np.random.SeedSequence([int(seed), int(tag)]))


# ----------------------------------------------------------------------------- valve characteristic
def q_equal_pct(x, R, a):
    g = R ** (x - 1.0)
    return g / np.sqrt(a + (1.0 - a) * g * g)


def q_quick(x, a):
    # linear inherent characteristic installed with low authority -> quick-opening
    return x / np.sqrt(a + (1.0 - a) * x * x)


def char_fn(kind, R, a):
    if kind == "equal_percentage":
        return lambda x: q_equal_pct(x, R, a)
    return lambda x: q_quick(x, a)


def slope(f, x, h=1e-4):
    return (f(x + h) - f(x - h)) / (2 * h)


def solve_authority(kind, R, x_lo, x_hi, target):
    """Authority a such that the installed-gain ratio over [x_lo, x_hi] equals target.
    equal-% -> ratio = slope(hi)/slope(lo); quick-opening -> slope(lo)/slope(hi)."""
    def ratio(a):
        f = char_fn(kind, R, a)
        if kind == "equal_percentage":
            return slope(f, x_hi) / slope(f, x_lo)
        return slope(f, x_lo) / slope(f, x_hi)
    grid = np.exp(np.linspace(math.log(1.0), math.log(0.002), 300))
    prev = grid[0]
    if kind == "equal_percentage":
        if ratio(1.0) <= target:
            return 1.0, ratio(1.0)
        for a in grid[1:]:
            if ratio(a) < target:
                r = brentq(lambda z: ratio(z) - target, a, prev, xtol=1e-10)
                return r, ratio(r)
            prev = a
    else:
        for a in grid[1:]:
            if ratio(a) > target:
                r = brentq(lambda z: ratio(z) - target, a, prev, xtol=1e-10)
                return r, ratio(r)
            prev = a
    a = grid[-1]
    return a, ratio(a)


# ----------------------------------------------------------------------------- frequency-domain margins
def margins(kc, ti, K, tau1, tau2, theta, tau_s=0.0, tc=1.0):
    """Phase margin (deg) and gain margin of the continuous loop incl. half-period
    controller delay."""
    w = np.exp(np.linspace(math.log(1e-5), math.log(20.0), 40000))
    s = 1j * w
    L = (kc * (1 + 1 / (ti * s)) * K * np.exp(-s * (theta + tc / 2))
         / ((tau1 * s + 1) * (tau2 * s + 1) * (tau_s * s + 1)))
    mag = np.abs(L)
    ph = np.unwrap(np.angle(L))
    ic = np.where((mag[:-1] >= 1) & (mag[1:] < 1))[0]
    pm = float(180 + np.degrees(ph[ic[0]])) if len(ic) else 180.0
    ip = np.where((ph[:-1] > -np.pi) & (ph[1:] <= -np.pi))[0]
    gm = float(1 / mag[ip[0]]) if len(ip) else float("inf")
    return pm, gm


# ----------------------------------------------------------------------------- loop draw
def tune(rule, K, tau, theta, lam):
    if rule == "SIMC":
        kc = tau / (K * (lam + theta))
        ti = min(tau, 4 * (lam + theta))
    else:
        kc = (tau + theta / 2) / (K * (lam + theta / 2))
        ti = tau + theta / 2
    return sig(kc, 3), round(ti, 1)


def draw_loop(seed):
    rng = stream(seed, 1)
    for _ in range(200):
        K = sig(loguniform(rng, 0.4, 4.0), 2)
        tau = round(loguniform(rng, 5.0, 50.0), 1)
        theta = round(min(max(tau * loguniform(rng, 0.08, 1.0), 1.0), 25.0), 1)
        lam = max(rng.uniform(0.8, 2.5) * theta, rng.uniform(0.3, 0.8) * tau)
        rule = "SIMC" if rng.uniform() < 0.5 else "IMC-PI"
        kc, ti = tune(rule, K, tau, theta, lam)
        tc = float(rng.choice([0.2, 0.5, 1.0], p=[0.3, 0.4, 0.3]))
        pm, gm = margins(kc, ti, K, tau, 0.0, theta, 0.0, tc)
        if pm >= 45 and gm >= 2.0:
            break
    # true process = model with small identification error and a little extra lag
    f2 = rng.uniform(0.0, 0.08)
    tau2 = f2 * tau
    K_t = K * (1 + rng.uniform(-0.08, 0.08))
    tau1 = tau * (1 + rng.uniform(-0.08, 0.08)) - tau2 / 2
    theta_t = max(theta * (1 + rng.uniform(-0.06, 0.06)) - tau2 / 2, 0.3)
    op0 = rng.uniform(35, 65)
    pv0 = round(loguniform(rng, 20, 300), 1)
    dop = rng.uniform(6, 14)
    sp_step = sig(K * dop, 2)
    return dict(K=K, tau=tau, theta=theta, lam=lam, rule=rule, kc=kc, ti=ti, tc=tc,
                t_cl=lam + theta, K_t=K_t, tau1=tau1, tau2=tau2, theta_t=theta_t,
                op0=op0, pv0=pv0, sp_step=sp_step, pm_nom=pm, gm_nom=gm, detuned=0)


def draw_conditions(seed, level, loop):
    """Noise and load magnitudes (level dependent) and the set-point schedule."""
    rng = stream(seed, 2)
    nr = rng.uniform(0.02, 0.04) if level == 1 else rng.uniform(0.04, 0.08)
    cond = dict(noise_rel=nr, noise_sd=nr * loop["sp_step"],
                noise_cf=rng.uniform(0.0, 0.6), noise_tc=rng.uniform(1.0, 5.0),
                load_drift=rng.uniform(2.0, 5.0) if level == 1 else rng.uniform(3.0, 7.0),
                load_tc=loop["tau"] * rng.uniform(0.5, 3.0))
    # an engineer does not leave a loop whose OP jitters by several per cent: if the
    # proportional action on the measurement noise exceeds a cap, lambda is raised
    cap = rng.uniform(0.5, 1.2)
    if loop["kc"] * cond["noise_sd"] > cap:
        K, tau, theta = loop["K"], loop["tau"], loop["theta"]
        kc_cap = cap / cond["noise_sd"]
        if loop["rule"] == "SIMC":
            lam = tau / (K * kc_cap) - theta
        else:
            lam = (tau + theta / 2) / (K * kc_cap) - theta / 2
        lam = max(lam, loop["lam"])
        loop["kc"], loop["ti"] = tune(loop["rule"], K, tau, theta, lam)
        loop["lam"] = lam
        loop["t_cl"] = lam + theta
        loop["detuned"] = 1
    cond["op_noise"] = loop["kc"] * cond["noise_sd"]
    if rng.uniform() < 0.35:
        cond["load_step"] = float(rng.choice([-1, 1]) * rng.uniform(1.0, 3.0))
        cond["load_step_time"] = float(round(rng.uniform(100, 2900)))
    else:
        cond["load_step"] = 0.0
        cond["load_step_time"] = None
    # set-point schedule
    ssp = loop["sp_step"]
    res = 10 ** math.floor(math.log10(ssp)) / 10
    gap = max(4 * loop["t_cl"], 150.0)
    n = int(rng.integers(3, 7))
    for _ in range(50):
        times = np.sort(rng.uniform(150, 2750, n))
        if n == 1 or np.min(np.diff(times)) >= gap:
            break
        if _ % 10 == 9:
            n -= 1
    times = [float(round(t)) for t in times]
    pv0 = loop["pv0"]
    sp = pv0
    steps = []
    for t in times:
        mag = ssp * rng.uniform(0.5, 1.0)
        sgn = rng.choice([-1, 1])
        if abs(sp + sgn * mag - pv0) > 1.6 * ssp:
            sgn = -sgn
        sp = round((sp + sgn * mag) / res) * res
        steps.append((t, float(sp)))
    cond["sp_steps"] = steps
    return cond


def band(rng, L1, op_noise, abs1, abs2):
    """Stiction / dead-band width in % of travel: an absolute size, but never below a
    multiple of the OP jitter that the controller passes on from the PV noise."""
    if L1:
        return min(max(rng.uniform(*abs1), rng.uniform(4.0, 8.0) * op_noise), 8.0)
    return min(max(rng.uniform(*abs2), rng.uniform(1.5, 3.0) * op_noise), 5.0)


def draw_effect(seed, level, cls, loop, cond):
    rng = stream(seed, 3)
    e = {"class": cls}
    L1 = level == 1
    if cls == "stiction":
        e["model"] = "He2007" if rng.uniform() < 0.5 else "Kano2004"
        S = band(rng, L1, cond["op_noise"], (2.0, 5.0), (0.6, 1.5))
        e["S"] = S
        e["J"] = S * rng.uniform(0.2, 1.0)
    elif cls == "deadband":
        e["d"] = band(rng, L1, cond["op_noise"], (1.5, 4.0), (0.5, 1.2))
    elif cls == "sensor_lag":
        for _ in range(100):
            r = rng.uniform(0.3, 0.8) if L1 else rng.uniform(0.1, 0.2)
            ts = max(r * loop["t_cl"], 2.5 if L1 else 1.2)
            pm, gm = margins(loop["kc"], loop["ti"], loop["K_t"], loop["tau1"], loop["tau2"],
                             loop["theta_t"], ts, loop["tc"])
            if pm >= 15 and gm >= 1.3:
                break
        e["tau_s"] = ts
        e["rel"] = ts / loop["t_cl"]
    elif cls == "dead_time":
        for _ in range(100):
            longer = rng.uniform() < 2 / 3
            if L1:
                ratio = rng.uniform(1.5, 2.2) if longer else rng.uniform(0.35, 0.6)
            else:
                ratio = rng.uniform(1.25, 1.45) if longer else rng.uniform(0.65, 0.8)
            # the change must be at least a fraction of the closed-loop time constant and
            # not below the sampling resolution; short dead times are lengthened instead
            floor = max(0.12 * loop["t_cl"], 1.0) if L1 else max(0.06 * loop["t_cl"], 0.6)
            if abs(ratio - 1) * loop["theta"] < floor:
                ratio = max(ratio if ratio > 1 else 1.0, 1 + floor / loop["theta"])
            th = loop["theta"] * ratio - loop["tau2"] / 2
            th = max(th, 0.2)
            pm, gm = margins(loop["kc"], loop["ti"], loop["K_t"], loop["tau1"], loop["tau2"],
                             th, 0.0, loop["tc"])
            if pm >= 15 and gm >= 1.3:
                break
        e["ratio"] = ratio
        e["theta_true"] = th
    elif cls == "valve_characteristic":
        kind = "equal_percentage" if rng.uniform() < 0.6 else "quick_opening"
        R = rng.uniform(30, 50) if kind == "equal_percentage" else None
        target = rng.uniform(2.2, 4.0) if L1 else rng.uniform(1.35, 1.8)
        x_lo = (loop["op0"] - 20) / 100
        x_hi = (loop["op0"] + 20) / 100
        a, r = solve_authority(kind, R, x_lo, x_hi, target)
        e.update(kind=kind, R=R, a=a, ratio=r)
    elif cls == "saturation":
        e["mode"] = "op_limit" if rng.uniform() < 0.5 else "travel_stop"
        e["side"] = "high" if rng.uniform() < 0.65 else "low"
        e["frac"] = rng.uniform(0.08, 0.2) if L1 else rng.uniform(0.02, 0.05)
    elif cls == "oscillatory_disturbance":
        rel = loguniform(rng, 3.0, 25.0)
        P = min(max(rel * loop["t_cl"], 25.0), 500.0)
        e["period"] = P
        e["rel"] = P / loop["t_cl"]
        e["amp"] = loop["sp_step"] * (rng.uniform(0.15, 0.4) if L1 else rng.uniform(0.05, 0.12))
        e["entry"] = "input" if rng.uniform() < 0.5 else "output"
        e["h2"] = rng.uniform(0.0, 0.15)
        e["h3"] = rng.uniform(0.0, 0.15)
        e["ph2"] = rng.uniform(0, 2 * np.pi)
        e["ph3"] = rng.uniform(0, 2 * np.pi)
    return e


# ----------------------------------------------------------------------------- exogenous signals
def exogenous(seed, loop, cond, eff, attempt):
    n = int(round((T_WARM + T_REC) / DT))
    t = np.arange(n) * DT - T_WARM
    # set point on the fine grid
    sp = np.full(n, loop["pv0"])
    for ts, v in cond["sp_steps"]:
        sp[t >= ts - 1e-9] = v
    # measurement noise at the controller instants (white + AR(1) coloured part)
    rn = stream(seed, 4)
    m = int(round(loop["tc"] / DT))
    nc = n // m + 1
    cf = cond["noise_cf"]
    phi = math.exp(-loop["tc"] / cond["noise_tc"])
    ar = lfilter([math.sqrt(1 - phi * phi)], [1, -phi], rn.standard_normal(nc))
    noise = cond["noise_sd"] * (math.sqrt(1 - cf) * rn.standard_normal(nc) + math.sqrt(cf) * ar)
    # load: random walk (OP-equivalent %) through a first-order load path, + optional step
    rl = stream(seed, 100 + attempt)
    sig_rw = cond["load_drift"] / math.sqrt(T_WARM + T_REC)
    rw = np.cumsum(rl.standard_normal(n)) * sig_rw * math.sqrt(DT)
    a = math.exp(-DT / cond["load_tc"])
    load = lfilter([1 - a], [1, -a], rw)
    if cond["load_step"]:
        load = load + cond["load_step"] * (t >= cond["load_step_time"])
    # oscillatory disturbance
    osc_in = np.zeros(n)
    osc_out = np.zeros(n)
    if eff["class"] == "oscillatory_disturbance":
        ro = stream(seed, 5)
        # slowly wandering frequency (+-3 %) and amplitude (+-15 %): OU processes
        def ou(tc_, sd):
            b = math.exp(-DT / tc_)
            return lfilter([math.sqrt(1 - b * b) * sd], [1, -b], ro.standard_normal(n))
        f0 = 1.0 / eff["period"]
        fr = f0 * (1 + ou(5 * eff["period"], 0.03))
        ph = 2 * np.pi * np.cumsum(fr) * DT + ro.uniform(0, 2 * np.pi)
        am = 1 + ou(3 * eff["period"], 0.15)
        w = (np.sin(ph) + eff["h2"] * np.sin(2 * ph + eff["ph2"])
             + eff["h3"] * np.sin(3 * ph + eff["ph3"]))
        w = am * w
        if eff["entry"] == "output":
            osc_out = eff["amp"] * w
        else:
            om = 2 * np.pi * f0
            g = loop["K_t"] / abs((1j * om * loop["tau1"] + 1) * (1j * om * loop["tau2"] + 1))
            osc_in = (eff["amp"] / g) * w
    return dict(t=t, sp=sp, noise=noise, load=load, osc_in=osc_in, osc_out=osc_out, m=m)


# ----------------------------------------------------------------------------- simulation
def simulate(loop, eff, exo, effect_on=True, op0=None, clamp=True):
    cls = eff["class"] if effect_on else "none"
    K_t, tau1, tau2 = loop["K_t"], loop["tau1"], loop["tau2"]
    theta = eff["theta_true"] if cls == "dead_time" else loop["theta_t"]
    tau_s = eff["tau_s"] if cls == "sensor_lag" else 0.0
    op0 = loop["op0"] if op0 is None else op0
    kc, ti, tc = loop["kc"], loop["ti"], loop["tc"]
    lo, hi = (OP_LO, OP_HI) if clamp else (-1e9, 1e9)
    m = exo["m"]
    sp, noise, load = exo["sp"].tolist(), exo["noise"].tolist(), exo["load"].tolist()
    if cls == "oscillatory_disturbance":
        osc_in, osc_out = exo["osc_in"].tolist(), exo["osc_out"].tolist()
    else:
        osc_in = osc_out = [0.0] * len(sp)
    n = len(sp)
    nd = int(round(theta / DT))
    buf = [0.0] * (nd + 1)
    nb = nd + 1
    a1 = math.exp(-DT / tau1)
    a2 = math.exp(-DT / tau2) if tau2 > 1e-6 else 0.0
    a_s = math.exp(-DT / tau_s) if tau_s > 1e-6 else 0.0
    pv0 = loop["pv0"]

    # valve model set-up
    vkind = 0
    if cls == "stiction":
        vkind = 1 if eff["model"] == "He2007" else 2
        S, J = eff["S"], eff["J"]
        fs, fd = (S + J) / 2, (S - J) / 2
    elif cls == "deadband":
        vkind = 3
        hb = eff["d"] / 2
    stop = None
    if cls == "saturation" and eff["mode"] == "travel_stop":
        stop = eff["limit"]
    if cls == "valve_characteristic":
        f = char_fn(eff["kind"], eff["R"], eff["a"])
        xlo, xhi = (op0 - 20) / 100, (op0 + 20) / 100
        s_avg = (f(xhi) - f(xlo)) / (xhi - xlo)
        f0 = f(op0 / 100)
        # tabulate for speed
        grid = np.linspace(0, 1, 20001)
        tab = ((f(grid) - f0) / s_avg * 100).tolist()

        def flow_of(mv):
            x = min(max(mv, 0.0), 100.0) * 200.0
            i = int(x)
            if i >= 20000:
                return tab[20000]
            return tab[i] + (x - i) * (tab[i + 1] - tab[i])
    else:
        flow_of = None

    op = op0
    mv = op0
    e_prev = None
    ur = 0.0          # He model accumulator
    kstp, kd, kus = 1, 1.0, op0   # Kano state: stopped, direction, stick point
    op_prev = op0
    dop_prev = 0.0
    x1 = x2 = 0.0
    ym = pv0
    flow = 0.0
    jn = 0
    rec_i = int(round(T_WARM / DT))
    stride = int(round(1.0 / DT))
    T, SPr, PVr, OPr, MVr, Yr = [], [], [], [], [], []
    kc_tc_ti = kc * tc / ti
    for i in range(n):
        y = pv0 + x2 + osc_out[i]
        if a_s:
            ym = a_s * ym + (1 - a_s) * y
        else:
            ym = y
        if i % m == 0:
            pvm = ym + noise[jn]
            jn += 1
            e = sp[i] - pvm
            if e_prev is None:
                e_prev = e
            op = op + kc * (e - e_prev) + kc_tc_ti * e
            if op > hi:
                op = hi
            elif op < lo:
                op = lo
            e_prev = e
            # valve
            if vkind == 0:
                mv = op
            elif vkind == 1:      # He et al. 2007
                ur += op - op_prev
                if abs(ur) > fs:
                    sg = 1.0 if ur > 0 else -1.0
                    mv = mv + ur - sg * fd
                    ur = sg * fd
            elif vkind == 2:      # Kano et al. 2004
                du = op - op_prev
                if kstp == 0 and du * dop_prev <= 0:
                    kstp = 1
                    kus = op_prev
                if kstp == 1:
                    if -kd * (op - kus) > S:
                        kd = -kd
                        kstp = 0
                    elif kd * (op - kus) > J:
                        kstp = 0
                    if kstp == 0:
                        mv = op - kd * (S - J) / 2
                else:
                    mv = op - kd * (S - J) / 2
                dop_prev = du
            elif vkind == 3:      # backlash / dead band
                if op - mv > hb:
                    mv = op - hb
                elif mv - op > hb:
                    mv = op + hb
            op_prev = op
            mvp = mv
            if stop is not None:
                if eff["side"] == "high":
                    mvp = min(mv, stop)
                else:
                    mvp = max(mv, stop)
            flow = flow_of(mvp) if flow_of else (mvp - op0)
            if i >= rec_i and (i - rec_i) % stride == 0:
                T.append((i - rec_i) // stride)
                SPr.append(sp[i])
                PVr.append(pvm)
                OPr.append(op)
                MVr.append(mvp)
                Yr.append(y)
        u = flow + load[i] + osc_in[i]
        buf[i % nb] = u
        ud = buf[(i - nd) % nb]
        x1 = a1 * x1 + (1 - a1) * K_t * ud
        x2 = a2 * x2 + (1 - a2) * x1 if a2 else x1
    return dict(t=np.array(T), SP=np.array(SPr), PV=np.array(PVr), OP=np.array(OPr),
                MV=np.array(MVr), Y=np.array(Yr))


# ----------------------------------------------------------------------------- one recording
def make_recording(seed, level, cls, want_checks=False):
    loop = draw_loop(seed)
    cond = draw_conditions(seed, level, loop)
    eff = draw_effect(seed, level, cls, loop, cond)
    attempt = 0
    load_scale = 1.0
    base_drift = cond["load_drift"]
    while True:
        cond["load_drift"] = base_drift * load_scale
        exo = exogenous(seed, loop, cond, eff, attempt)
        if cls == "saturation":
            free = simulate(loop, eff, exo, effect_on=False, clamp=False)
            ok = (free["OP"].min() > 3 and free["OP"].max() < 97) or attempt >= 40
            if ok:
                f = eff["frac"]
                if eff["mode"] == "op_limit":
                    if eff["side"] == "high":
                        shift = OP_HI - np.quantile(free["OP"], 1 - f)
                    else:
                        shift = OP_LO - np.quantile(free["OP"], f)
                    op0_new = loop["op0"] + shift
                    # op0 is the OP needed at the initial set point; it may lie beyond
                    # the limit (valve saturated at the start), the quantile fixes how long
                    ok = -30.0 < op0_new < 130.0
                    if ok:
                        loop["op0"] = op0_new
                        eff["limit"] = OP_HI if eff["side"] == "high" else OP_LO
                else:
                    if eff["side"] == "high":
                        eff["limit"] = float(np.quantile(free["MV"], 1 - f))
                    else:
                        eff["limit"] = float(np.quantile(free["MV"], f))
            if ok:
                rec = simulate(loop, eff, exo)
                break
        else:
            rec = simulate(loop, eff, exo)
            if (rec["OP"].min() > 1.0 and rec["OP"].max() < 99.0) or attempt >= 60:
                break
        attempt += 1
        if attempt % 10 == 0:
            load_scale *= 0.7
    cond["load_attempt"] = attempt

    if cls == "saturation":
        if eff["mode"] == "op_limit":
            at = np.abs(rec["OP"] - eff["limit"]) < 1e-9
        else:
            at = np.abs(rec["MV"] - eff["limit"]) < 1e-9
        eff["frac_at_limit"] = float(np.mean(at))
        sig_ = rec["OP"] if eff["mode"] == "op_limit" else rec["MV"]
        eff["frac_near_limit"] = float(np.mean(np.abs(sig_ - eff["limit"]) <= 1.0))

    name = "r" + hashlib.sha256(f"blindgen2:{seed}".encode()).hexdigest()[:12]
    truth = truth_row(name, seed, level, cls, loop, cond, eff)
    out = dict(name=name, rec=rec, loop=loop, truth=truth)
    if want_checks:
        out["checks"] = checks(seed, level, cls, loop, cond, eff, exo, rec)
    return out


def truth_row(name, seed, level, cls, loop, cond, eff):
    r = {c: "" for c in TRUTH_COLUMNS}
    r.update(name=name, level=level, seed=seed)
    r["class"] = cls
    g = lambda x, n=4: f"{x:.{n}g}"
    if cls == "stiction":
        r.update(stiction_model=eff["model"], stiction_S=g(eff["S"]), stiction_J=g(eff["J"]))
    elif cls == "deadband":
        r["deadband"] = g(eff["d"])
    elif cls == "sensor_lag":
        r.update(sensor_lag_tc=g(eff["tau_s"]), sensor_lag_rel_tcl=g(eff["rel"]))
    elif cls == "dead_time":
        r.update(dead_time_true_over_model=g(eff["ratio"]), dead_time_effect_true=g(eff["theta_true"]))
    elif cls == "valve_characteristic":
        r.update(valve_char_type=eff["kind"], valve_rangeability=g(eff["R"]) if eff["R"] else "",
                 valve_authority=g(eff["a"]), valve_gain_ratio=g(eff["ratio"]))
    elif cls == "saturation":
        r.update(sat_mode=eff["mode"], sat_side=eff["side"], sat_limit=g(eff["limit"]),
                 sat_target_frac=g(eff["frac"]), sat_frac_at_limit=g(eff["frac_at_limit"]),
                 sat_frac_near_limit=g(eff["frac_near_limit"]))
    elif cls == "oscillatory_disturbance":
        r.update(osc_period=g(eff["period"]), osc_period_rel_tcl=g(eff["rel"]),
                 osc_amplitude_pv=g(eff["amp"]), osc_entry=eff["entry"],
                 osc_h2=g(eff["h2"], 3), osc_h3=g(eff["h3"], 3))
    r.update(model_gain=fmt_num(loop["K"]), model_time_constant=fmt_num(loop["tau"]),
             model_dead_time=fmt_num(loop["theta"]), kc=fmt_num(loop["kc"]), ti=fmt_num(loop["ti"]),
             tuning_rule=loop["rule"], **{"lambda": g(loop["lam"])}, t_cl=g(loop["t_cl"]),
             ctrl_period=g(loop["tc"]), true_gain=g(loop["K_t"]), true_tau1=g(loop["tau1"]),
             true_tau2=g(loop["tau2"]),
             true_dead_time=g(eff["theta_true"] if cls == "dead_time" else loop["theta_t"]),
             noise_detuned=loop["detuned"], op_noise_p=g(cond["op_noise"]),
             pv0=g(loop["pv0"], 5), op0=g(loop["op0"]), sp_step=g(loop["sp_step"]),
             n_sp_steps=len(cond["sp_steps"]), noise_sd=g(cond["noise_sd"]),
             noise_rel_sp_step=g(cond["noise_rel"]), noise_coloured_frac=g(cond["noise_cf"], 3),
             noise_tc=g(cond["noise_tc"], 3), load_drift_op=g(cond["load_drift"]),
             load_tc=g(cond["load_tc"]), load_step_op=g(cond["load_step"]) if cond["load_step"] else "",
             load_step_time=g(cond["load_step_time"]) if cond["load_step"] else "",
             load_attempt=cond["load_attempt"])
    return r


# ----------------------------------------------------------------------------- diagnostics (not in DIR)
def checks(seed, level, cls, loop, cond, eff, exo, rec):
    c = dict(seed=seed, level=level, cls=cls)
    err = rec["SP"] - rec["PV"]
    c["err_sd_rel"] = float(np.std(err) / loop["sp_step"])
    c["max_abs_err_rel"] = float(np.max(np.abs(err)) / loop["sp_step"])
    # error away from set-point transients (> 5 closed-loop time constants after a step)
    since = np.full(len(err), 1e9)
    last = 0.0
    chg = [-T_WARM] + [ts for ts, _ in cond["sp_steps"]]
    for k, t in enumerate(rec["t"]):
        while chg and chg[0] <= t:
            last = chg.pop(0)
        since[k] = t - last
    settled = since > 5 * loop["t_cl"]
    c["settled_frac"] = float(np.mean(settled))
    c["settled_err_sd_over_noise"] = float(np.std(err[settled]) / cond["noise_sd"])
    c["settled_max_abs_err_rel"] = float(np.max(np.abs(err[settled])) / loop["sp_step"])
    c["op_min"] = float(rec["OP"].min())
    c["op_max"] = float(rec["OP"].max())
    c["op_sd"] = float(np.std(rec["OP"]))
    # linear margins of the true loop (the local gain range for the valve characteristic)
    theta = eff["theta_true"] if cls == "dead_time" else loop["theta_t"]
    tau_s = eff["tau_s"] if cls == "sensor_lag" else 0.0
    gmul = 1.0
    if cls == "valve_characteristic":
        f = char_fn(eff["kind"], eff["R"], eff["a"])
        op0 = loop["op0"]
        s_avg = (f((op0 + 20) / 100) - f((op0 - 20) / 100)) / 0.4
        mvs = np.clip(rec["MV"], 0.5, 99.5) / 100
        loc = slope(f, mvs) / s_avg
        c["local_gain_min"] = float(loc.min())
        c["local_gain_max"] = float(loc.max())
        gmul = float(loc.max())
    pm, gm = margins(loop["kc"], loop["ti"], loop["K_t"] * gmul, loop["tau1"], loop["tau2"],
                     theta, tau_s, loop["tc"])
    c["pm_true"] = pm
    c["gm_true"] = gm
    # twin run with identical exogenous signals and the effect switched off
    twin = simulate(loop, eff, exo, effect_on=False, clamp=(cls != "saturation"))
    nsd = cond["noise_sd"]
    c["dPV_rms_over_noise"] = float(np.sqrt(np.mean((rec["PV"] - twin["PV"]) ** 2)) / nsd)
    c["dOP_rms"] = float(np.sqrt(np.mean((rec["OP"] - twin["OP"]) ** 2)))
    c["dOP_rms_over_op_sd"] = float(c["dOP_rms"] / np.std(twin["OP"]))
    if cls in ("stiction", "deadband"):
        dmv = np.abs(np.diff(rec["MV"]))
        c["frac_valve_stuck"] = float(np.mean(dmv < 1e-12))
        if cls == "stiction":
            c["n_slips"] = int(np.sum(dmv > 0.5 * eff["J"]))
    if cls == "saturation":
        c["frac_at_limit"] = eff["frac_at_limit"]
        c["frac_near_limit"] = eff["frac_near_limit"]
    if cls == "oscillatory_disturbance":
        c["osc_amp_over_noise"] = eff["amp"] / nsd
    return c


# ----------------------------------------------------------------------------- writing
def write_recording(outdir, res):
    name, rec, loop = res["name"], res["rec"], res["loop"]
    with open(os.path.join(outdir, name + ".csv"), "w", newline="") as fh:
        fh.write("t,SP,PV,OP\n")
        for t, s, p, o in zip(rec["t"], rec["SP"], rec["PV"], rec["OP"]):
            fh.write(f"{int(t)},{s:.4f},{p:.4f},{o:.3f}\n")
    txt = (f"process: {{gain: {fmt_num(loop['K'])}, time_constant: {fmt_num(loop['tau'])}, "
           f"dead_time: {fmt_num(loop['theta'])}}}\n"
           f"controller: {{kc: {fmt_num(loop['kc'])}, ti: {fmt_num(loop['ti'])}}}\n"
           f"sample_time: 1.0\n"
           f"op_range: [0, 100]\n")
    yaml.safe_load(txt)  # format self-check
    with open(os.path.join(outdir, name + ".model.yaml"), "w") as fh:
        fh.write(txt)


def job(args):
    seed, level, cls, want_checks = args
    return make_recording(seed, level, cls, want_checks)


def make_plots(plotdir, results):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    os.makedirs(plotdir, exist_ok=True)
    for level in LEVELS:
        fig, axes = plt.subplots(len(CLASSES), 2, figsize=(15, 2.3 * len(CLASSES)), sharex=True)
        for k, cls in enumerate(CLASSES):
            res = next(r for r in results if r["truth"]["class"] == cls and r["truth"]["level"] == level)
            rec = res["rec"]
            ax = axes[k, 0]
            ax.plot(rec["t"], rec["PV"], lw=0.5, label="PV")
            ax.plot(rec["t"], rec["SP"], lw=1.0, label="SP")
            ax.set_ylabel(f"{cls}\n{res['name']}", fontsize=7)
            ax2 = axes[k, 1]
            ax2.plot(rec["t"], rec["OP"], lw=0.5, label="OP")
            ax2.plot(rec["t"], rec["MV"], lw=0.8, label="MV (not recorded)")
            if k == 0:
                ax.legend(fontsize=7, loc="upper right")
                ax2.legend(fontsize=7, loc="upper right")
        axes[-1, 0].set_xlabel("t [s]")
        axes[-1, 1].set_xlabel("t [s]")
        fig.suptitle(f"blindgen2: level {level}, first recording of each class")
        fig.tight_layout()
        fig.savefig(os.path.join(plotdir, f"overview_level{level}.png"), dpi=90)
        plt.close(fig)
    # zoomed OP-MV and OP-PV maps for the valve classes, level 1 and 2
    for cls in ("stiction", "deadband", "saturation", "valve_characteristic"):
        fig, axes = plt.subplots(2, 2, figsize=(11, 7))
        for j, level in enumerate(LEVELS):
            res = next(r for r in results if r["truth"]["class"] == cls and r["truth"]["level"] == level)
            rec = res["rec"]
            sl = slice(0, 3000) if cls == "saturation" else slice(1000, 1600)
            axes[j, 0].plot(rec["t"][sl], rec["OP"][sl], lw=0.7, label="OP")
            axes[j, 0].plot(rec["t"][sl], rec["MV"][sl], lw=0.9, label="MV")
            axes[j, 0].legend(fontsize=7)
            axes[j, 0].set_title(f"{cls} level {level} ({res['name']})", fontsize=9)
            axes[j, 1].plot(rec["OP"], rec["MV"], lw=0.3)
            axes[j, 1].set_xlabel("OP [%]")
            axes[j, 1].set_ylabel("MV [%]")
        fig.tight_layout()
        fig.savefig(os.path.join(plotdir, f"valve_{cls}.png"), dpi=90)
        plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--per-class", type=int, required=True)
    ap.add_argument("--first-seed", type=int, required=True)
    ap.add_argument("--checks", default=None, help="write per-recording sanity numbers to this CSV")
    ap.add_argument("--plots", default=None, help="write a few PNGs into this directory")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    want = a.checks is not None
    tasks = []
    idx = 0
    for level in LEVELS:
        for cls in CLASSES:
            for _ in range(a.per_class):
                tasks.append((a.first_seed + idx, level, cls, want))
                idx += 1
    if a.jobs > 1:
        with ProcessPoolExecutor(a.jobs) as ex:
            results = list(ex.map(job, tasks, chunksize=1))
    else:
        results = [job(t) for t in tasks]
    names = [r["name"] for r in results]
    assert len(set(names)) == len(names), "name collision"
    for r in results:
        write_recording(a.out, r)
    rows = sorted((r["truth"] for r in results), key=lambda r: r["name"])
    with open(os.path.join(a.out, "truth.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=TRUTH_COLUMNS, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {len(results)} recordings to {a.out}")
    if want:
        ch = [dict(name=r["name"], **r["checks"]) for r in results]
        keys = []
        for c in ch:
            for k in c:
                if k not in keys:
                    keys.append(k)
        with open(a.checks, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=keys, lineterminator="\n")
            w.writeheader()
            for c in ch:
                w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in c.items()})
        print_summary(ch)
    if a.plots:
        make_plots(a.plots, results)
        print(f"plots in {a.plots}")


def print_summary(ch):
    def q(vals):
        v = np.array([x for x in vals if x is not None and np.isfinite(x)], float)
        if len(v) == 0:
            return "-"
        return f"{v.min():.3g}/{np.median(v):.3g}/{v.max():.3g}"
    cols = ["err_sd_rel", "settled_err_sd_over_noise", "settled_max_abs_err_rel", "op_min", "op_max",
            "pm_true", "gm_true", "dPV_rms_over_noise", "dOP_rms", "dOP_rms_over_op_sd"]
    print("\nsummary (min/median/max over recordings)")
    for level in LEVELS:
        for cls in CLASSES:
            sub = [c for c in ch if c["level"] == level and c["cls"] == cls]
            print(f"L{level} {cls} (n={len(sub)})")
            for k in cols + ["frac_valve_stuck", "n_slips", "frac_at_limit", "frac_near_limit", "osc_amp_over_noise",
                             "local_gain_min", "local_gain_max"]:
                vals = [c[k] for c in sub if k in c]
                if vals:
                    print(f"    {k:24s} {q(vals)}")


if __name__ == "__main__":
    main()
