#!/usr/bin/env python
"""blindgen_d -- an independent closed-loop simulator that writes test recordings
(t, SP, PV, OP at 1 s) for a control-loop fault-diagnosis tool.

Written from scratch from general process-control knowledge and the public
literature (Choudhury/Shah/Thornhill physical and two-parameter stiction models,
Kano 2004, He 2007), without reading the diagnosis tool's code.

Usage:
    python generate.py --out DIR --per-class N --first-seed S [--check]

See README.md next to this file for the precise specification.
"""
import argparse
import csv
import hashlib
import math
import os
import time

import numpy as np
import scipy.optimize
import scipy.signal
import yaml
from numba import njit

CLASSES = ["none", "stiction", "deadband", "sensor_lag", "dead_time",
           "valve_characteristic", "saturation", "oscillatory_disturbance"]
LEVELS = (1, 2)
H = 0.01            # simulation sub-step [s]
SPS = 100           # sub-steps per second (1/H)
DG = 0.1            # grid of the precomputed disturbance signals [s]
DGS = 10            # sub-steps per disturbance grid point
T_END = 3000        # record length [s]
TC_CHOICES = np.array([0.1, 0.2, 0.25, 0.5, 1.0])
MAX_ATTEMPTS = 60

# valve model codes
V_LINEAR, V_BACKLASH, V_CHOUDHURY, V_KANO, V_HE, V_PHYSICAL = 0, 1, 2, 3, 4, 5
VALVE_NAMES = {V_CHOUDHURY: "choudhury2005", V_KANO: "kano2004", V_HE: "he2007",
               V_PHYSICAL: "physical"}
# characteristic codes
C_LINEAR, C_EQPCT, C_QUICK = 0, 1, 2

# float parameter vector layout for the simulation kernel
FP = ["K", "tau", "theta", "kc", "ti", "Tc", "b", "op0", "v0", "sens_tau",
      "quant", "S", "J", "d", "M", "Fs", "Fc", "Fv", "vs", "cpar", "auth",
      "blend", "vlo", "vhi", "oplo", "ophi", "dir0"]
IP = ["nT", "nwarm", "vmodel", "ctype", "hist_mean", "nmicro"]
F = {n: i for i, n in enumerate(FP)}
I = {n: i for i, n in enumerate(IP)}
(F_K, F_TAU, F_THETA, F_KC, F_TI, F_TC, F_B, F_OP0, F_V0, F_SENS, F_QUANT, F_S,
 F_J, F_D, F_M, F_FS, F_FC, F_FV, F_VS, F_CPAR, F_AUTH, F_BLEND, F_VLO, F_VHI,
 F_OPLO, F_OPHI, F_DIR0) = range(len(FP))
I_NT, I_NWARM, I_VMODEL, I_CTYPE, I_HMEAN, I_NMICRO = range(len(IP))


# ----------------------------------------------------------------------------
# numba kernels
# ----------------------------------------------------------------------------
@njit(cache=True)
def charac(v, ctype, cpar, auth, blend):
    """Installed valve characteristic: valve travel v [%] -> flow [% of max]."""
    vn = v / 100.0
    if vn < 0.0:
        vn = 0.0
    elif vn > 1.0:
        vn = 1.0
    if ctype == C_LINEAR:
        return 100.0 * vn
    if ctype == C_EQPCT:
        fi = (cpar ** vn - 1.0) / (cpar - 1.0)
    else:
        fi = 1.0 - (1.0 - vn) ** cpar
    fa = fi / math.sqrt(auth + (1.0 - auth) * fi * fi)
    return 100.0 * ((1.0 - blend) * vn + blend * fa)


@njit(cache=True)
def phys_micro(x, vel, stuck, sdir, u, M, Fs, Fc, Fv, vs, hv):
    """One micro-step of the force-balance valve (A = k = 1, forces in % travel).
    M x'' = u - x + Ff,  Ff = -sdir*(Fc + (Fs-Fc) exp(-(v/vs)^2)) - Fv v  when moving;
    stuck while |u - x| <= Fs.  Viscous term implicit; velocity zero-crossing -> stick."""
    Fnet = u - x
    if stuck:
        if abs(Fnet) > Fs:
            stuck = False
            sdir = 1.0 if Fnet > 0.0 else -1.0
            vel = 0.0
        else:
            return x, 0.0, True, sdir
    if vs > 0.0:
        fr = Fc + (Fs - Fc) * math.exp(-(vel / vs) ** 2)
    else:
        fr = Fc
    vnew = (vel + hv * (Fnet - sdir * fr) / M) / (1.0 + hv * Fv / M)
    if vnew * sdir <= 0.0:
        # velocity reaches zero inside this micro-step: stop there and stick
        if vel != vnew:
            tz = hv * vel / (vel - vnew)
        else:
            tz = 0.0
        x += 0.5 * vel * tz
        return x, 0.0, True, sdir
    x += hv * vnew
    return x, vnew, False, sdir


@njit(cache=True)
def simulate(fp, ip, sp_t, sp_v, din, dout, noise, Ad, Bd):
    K = fp[F_K]
    kc = fp[F_KC]
    ti = fp[F_TI]
    Tc = fp[F_TC]
    b = fp[F_B]
    op0 = fp[F_OP0]
    theta = fp[F_THETA]
    sens = fp[F_SENS] > 0.0
    quant = fp[F_QUANT]
    S = fp[F_S]
    J = fp[F_J]
    dband = fp[F_D]
    M = fp[F_M]
    Fs = fp[F_FS]
    Fc = fp[F_FC]
    Fv = fp[F_FV]
    vs = fp[F_VS]
    cpar = fp[F_CPAR]
    auth = fp[F_AUTH]
    blend = fp[F_BLEND]
    vlo = fp[F_VLO]
    vhi = fp[F_VHI]
    oplo = fp[F_OPLO]
    ophi = fp[F_OPHI]
    nT = ip[I_NT]
    nwarm = ip[I_NWARM]
    vmodel = ip[I_VMODEL]
    ctype = ip[I_CTYPE]
    hmean = ip[I_HMEAN]
    nmicro = ip[I_NMICRO]
    hv = H / nmicro

    N = (nwarm + T_END) * SPS
    i0 = nwarm * SPS
    dsteps = theta / H
    m = int(math.floor(dsteps))
    frac = dsteps - m
    qbuf = np.empty(N + 1)

    # --- initial steady state
    v = fp[F_V0]
    vl = min(max(v, vlo), vhi)
    q0 = charac(vl, ctype, cpar, auth, blend)
    x1 = K * (q0 + din[0])
    x2 = x1 + b + dout[0]
    Iint = op0 * ti / kc
    op = op0
    dirn = fp[F_DIR0]
    stuck = True
    us = op0
    uprev = op0
    duprev = 0.0
    ur = dirn * 0.5 * (S - J)          # He model residual (y = u - ur)
    xv = v
    vel = 0.0
    sdir = dirn

    nrec = T_END + 1
    sp_h = np.empty(nrec)
    pv_h = np.empty(nrec)
    op_h = np.empty(nrec)
    v_h = np.empty(nrec)
    acc = 0.0
    cnt = 0
    ktick = 0
    opmin = 1e9
    opmax = -1e9
    nsp = sp_t.shape[0]
    ng = din.shape[0]
    sp = sp_v[0]
    isp = 0

    for i in range(N + 1):
        t = -nwarm + i * H
        j = i // DGS
        r = (i - j * DGS) / DGS
        if j + 1 < ng:
            dI = din[j] + r * (din[j + 1] - din[j])
            dO = dout[j] + r * (dout[j + 1] - dout[j])
        else:
            dI = din[ng - 1]
            dO = dout[ng - 1]

        if i % nT == 0:
            # ---- measurement and PI controller tick
            ytrue = x1 + b + dO
            ym = x2 if sens else ytrue
            ym += noise[ktick]
            if quant > 0.0:
                ym = quant * math.floor(ym / quant + 0.5)
            ktick += 1
            while isp < nsp and t >= sp_t[isp] - 1e-9:
                isp += 1
                sp = sp_v[isp]
            e = sp - ym
            Inew = Iint + e * Tc
            u = kc * (e + Inew / ti)
            if u > ophi and e > 0.0:
                Inew = Iint
                u = kc * (e + Inew / ti)
            elif u < oplo and e < 0.0:
                Inew = Iint
                u = kc * (e + Inew / ti)
            if u > ophi:
                u = ophi
            elif u < oplo:
                u = oplo
            Iint = Inew
            op = u

            # ---- discrete-time valve models (act on each new OP)
            if vmodel == V_LINEAR:
                v = op
            elif vmodel == V_BACKLASH:
                if op - v > 0.5 * dband:
                    v = op - 0.5 * dband
                elif op - v < -0.5 * dband:
                    v = op + 0.5 * dband
            elif vmodel == V_CHOUDHURY:
                dv = op - uprev
                sv = 1.0 if dv > 0.0 else (-1.0 if dv < 0.0 else 0.0)
                if not stuck:
                    if sv != dirn:
                        stuck = True
                        us = uprev
                    else:
                        v = op - dirn * 0.5 * (S - J)
                if stuck:
                    dev = op - us
                    if dev * dirn > J:
                        stuck = False
                        v = op - dirn * 0.5 * (S - J)
                    elif -dev * dirn > S:
                        dirn = -dirn
                        stuck = False
                        v = op - dirn * 0.5 * (S - J)
                uprev = op
            elif vmodel == V_KANO:
                du = op - uprev
                if not stuck:
                    if du * duprev <= 0.0:
                        stuck = True
                        us = uprev
                if stuck:
                    if -dirn * (op - us) > S:
                        dirn = -dirn
                        stuck = False
                    elif dirn * (op - us) > J:
                        stuck = False
                if not stuck:
                    v = op - dirn * 0.5 * (S - J)
                uprev = op
                duprev = du
            elif vmodel == V_HE:
                fs_ = 0.5 * (S + J)
                fd_ = 0.5 * (S - J)
                ur += op - uprev
                if abs(ur) > fs_:
                    sg = 1.0 if ur > 0.0 else -1.0
                    v = v + ur - sg * fd_
                    ur = sg * fd_
                uprev = op

            # ---- historian (whole seconds)
            acc += op
            cnt += 1
            if i % SPS == 0:
                if i >= i0:
                    k = i // SPS - nwarm
                    sp_h[k] = sp
                    pv_h[k] = ym
                    op_h[k] = acc / cnt if hmean == 1 else op
                    v_h[k] = v
                acc = 0.0
                cnt = 0
            if i >= i0:
                if op < opmin:
                    opmin = op
                if op > opmax:
                    opmax = op

        # ---- physical valve: continuous integration with OP held
        if vmodel == V_PHYSICAL:
            for _ in range(nmicro):
                xv, vel, stuck, sdir = phys_micro(xv, vel, stuck, sdir, op, M, Fs, Fc, Fv, vs, hv)
            v = xv
        vl = min(max(v, vlo), vhi)
        qbuf[i] = charac(vl, ctype, cpar, auth, blend)

        # ---- transport delay (exact average of the ZOH flow over the sub-step)
        ia = i - m
        ib = i - m - 1
        qa = qbuf[ia] if ia >= 0 else q0
        qb = qbuf[ib] if ib >= 0 else q0
        uin = (1.0 - frac) * qa + frac * qb + dI
        # ---- exact ZOH discretisation of process lag + sensor lag
        x1n = Ad[0, 0] * x1 + Ad[0, 1] * x2 + Bd[0, 0] * uin + Bd[0, 1] * dO + Bd[0, 2]
        x2n = Ad[1, 0] * x1 + Ad[1, 1] * x2 + Bd[1, 0] * uin + Bd[1, 1] * dO + Bd[1, 2]
        x1 = x1n
        x2 = x2n
    return sp_h, pv_h, op_h, v_h, opmin, opmax


@njit(cache=True)
def phys_triangle(M, Fs, Fc, Fv, vs, nmicro, amp, speed):
    """Drive the physical valve alone with a slow triangle (around 50 %, +-amp,
    ramp speed [%/s]); return u and x sampled every H seconds."""
    half = 2.0 * amp / speed
    T = 4.0 * half + amp / speed
    n = int(T / H)
    us = np.empty(n)
    xs = np.empty(n)
    hv = H / nmicro
    x = 50.0 - Fc          # at rest after moving up
    vel = 0.0
    stuck = True
    sdir = 1.0
    for i in range(n):
        t = i * H
        # start at 50 going up to 50+amp, then triangle between 50-amp and 50+amp
        tt = t + amp / speed
        ph = (tt % (2.0 * half)) / half
        if ph < 1.0:
            u = 50.0 - amp + 2.0 * amp * ph
        else:
            u = 50.0 + amp - 2.0 * amp * (ph - 1.0)
        for _ in range(nmicro):
            x, vel, stuck, sdir = phys_micro(x, vel, stuck, sdir, u, M, Fs, Fc, Fv, vs, hv)
        us[i] = u
        xs[i] = x
    return us, xs


@njit(cache=True)
def nominal_step(K, tau, theta, kc, ti, Tc, horizon):
    """Noise-free nominal loop, unit SP step at t = 0; returns PV at 0.05 s."""
    h = 0.05
    n = int(horizon / h)
    nT = int(round(Tc / h))
    m = theta / h
    mi = int(math.floor(m))
    fr = m - mi
    a = math.exp(-h / tau)
    ubuf = np.zeros(n + 1)
    y = 0.0
    Ii = 0.0
    u = 0.0
    out = np.empty(n + 1)
    for i in range(n + 1):
        if i % nT == 0:
            e = 1.0 - y
            Ii += e * Tc
            u = kc * (e + Ii / ti)
        ubuf[i] = u
        out[i] = y
        ia = i - mi
        ib = i - mi - 1
        ua = ubuf[ia] if ia >= 0 else 0.0
        ub = ubuf[ib] if ib >= 0 else 0.0
        y = a * y + (1.0 - a) * K * ((1.0 - fr) * ua + fr * ub)
    return out


# ----------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------
def logu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def sig4(x):
    """Round to 4 significant digits (the YAML holds exactly the simulated values)."""
    if x == 0:
        return 0.0
    return float(f"{x:.4g}")


def gain_margin(K, tau, theta, kc, ti, Tc):
    th = theta + Tc / 2.0          # ZOH of the sampled controller ~ half a period delay

    def phase(w):
        return -math.atan(1.0 / (ti * w)) - math.atan(tau * w) - w * th + math.pi

    w180 = scipy.optimize.brentq(phase, 1e-7, 1e3)
    mag = kc * math.sqrt(1.0 + 1.0 / (ti * w180) ** 2) * K / math.sqrt(1.0 + (tau * w180) ** 2)
    return 1.0 / mag


def closed_loop_tc(K, tau, theta, kc, ti, Tc):
    """Closed-loop time constant: time for the nominal loop to reach 63 % of a SP step."""
    horizon = min(6000.0, 30.0 * (tau + theta) + 100.0)
    y = nominal_step(K, tau, theta, kc, ti, Tc, horizon)
    idx = np.nonzero(y >= 0.632)[0]
    if idx.size == 0:
        return horizon
    return float(idx[0] * 0.05)


def plant_matrices(K, tau, sens_tau):
    """Exact ZOH discretisation (scipy) of  tau x1' = -x1 + K u ;
    ts x2' = -x2 + x1 + b + dout  (inputs: u, dout, b)."""
    ts = sens_tau if sens_tau > 0 else 1.0
    A = np.array([[-1.0 / tau, 0.0], [1.0 / ts, -1.0 / ts]])
    B = np.array([[K / tau, 0.0, 0.0], [0.0, 1.0 / ts, 1.0 / ts]])
    C = np.eye(2)
    D = np.zeros((2, 3))
    Ad, Bd, _, _, _ = scipy.signal.cont2discrete((A, B, C, D), H, method="zoh")
    return np.ascontiguousarray(Ad), np.ascontiguousarray(Bd)


def measure_physical_SJ(M, Fs, Fc, Fv, vs, nmicro):
    """Equivalent two-parameter S and J (% travel) of the physical valve from a slow
    triangular OP: S = OP travel from a reversal until the stem moves; J = stem jump at
    break-away minus the OP travel during the jump (first 2 s after break-away)."""
    S_nom = Fs + Fc
    amp = max(2.5 * S_nom, 2.0)
    speed = 0.05
    u, x = phys_triangle(M, Fs, Fc, Fv, vs, nmicro, amp, speed)
    du = np.diff(u)
    rev = np.nonzero(np.sign(du[1:]) != np.sign(du[:-1]))[0] + 1
    Ss, Js = [], []
    for r in rev:
        seg = x[r:]
        still = np.nonzero(np.abs(np.diff(seg)) < 1e-12)[0]
        if still.size == 0:
            continue
        k1 = r + still[0]
        moved = np.nonzero(np.abs(x[k1:] - x[k1]) > 1e-6)[0]
        if moved.size == 0:
            continue
        kb = k1 + moved[0] - 1
        Ss.append(abs(u[kb] - u[r]))
        s = -np.sign(du[r - 1])
        w = slice(kb, min(len(u), kb + int(2.0 / H)))
        Js.append(float(np.max(s * (x[w] - x[kb]) - s * (u[w] - u[kb]))))
    if not Ss:
        return float("nan"), float("nan")
    return float(np.mean(Ss)), float(np.mean(Js))


def waveform(shape, t, w, ph, extra):
    if shape == "sine":
        return np.sin(w * t + ph)
    if shape == "square":
        beta = extra["osc_beta"]
        return np.tanh(beta * np.sin(w * t + ph)) / math.tanh(beta)
    if shape == "triangle":
        return (2.0 / math.pi) * np.arcsin(np.sin(w * t + ph))
    # harmonics
    a2, a3, p2, p3 = extra["osc_a2"], extra["osc_a3"], extra["osc_p2"], extra["osc_p3"]
    g = np.linspace(0.0, 2.0 * math.pi, 4001)
    peak = np.max(np.abs(np.sin(g) + a2 * np.sin(2 * g + p2) + a3 * np.sin(3 * g + p3)))
    z = w * t + ph
    return (np.sin(z) + a2 * np.sin(2 * z + p2) + a3 * np.sin(3 * z + p3)) / peak


# ----------------------------------------------------------------------------
# scenario drawing
# ----------------------------------------------------------------------------
def draw_scenario(rng, level, cls):
    sc = {}
    L1 = level == 1
    # --- process
    K = sig4(logu(rng, 0.3, 5.0))
    tau = sig4(logu(rng, 3.0, 150.0))
    theta = sig4(max(1.0, tau * logu(rng, 0.05, 1.0)))
    Tc = float(TC_CHOICES[rng.integers(0, len(TC_CHOICES))])
    # --- tuning
    rsel = rng.uniform()
    if rsel < 0.4:
        rule = "imc_lambda"
        lam = max(theta, tau * logu(rng, 0.3, 2.0))
        kc = tau / (K * (lam + theta))
        ti = tau
        tpar = lam
    elif rsel < 0.75:
        rule = "simc"
        tpar = theta * logu(rng, 0.7, 3.0)
        kc = tau / (K * (tpar + theta))
        ti = min(tau, 4.0 * (tpar + theta))
    else:
        rule = "zn_reaction_curve"
        tpar = float("nan")
        kc = 0.9 * tau / (K * theta)
        ti = 3.33 * theta
    gm = gain_margin(K, tau, theta, kc, ti, Tc)
    detuned = 0
    if gm < 1.7:
        target = rng.uniform(1.7, 2.2)
        kc = kc * gm / target
        detuned = 1
    kc = sig4(kc)
    ti = sig4(ti)
    gm = gain_margin(K, tau, theta, kc, ti, Tc)
    Tcl = closed_loop_tc(K, tau, theta, kc, ti, Tc)
    sc.update(K=K, tau=tau, theta_model=theta, theta_plant=theta, Tc=Tc, tuning_rule=rule,
              tuning_par=tpar, kc=kc, ti=ti, gain_margin=gm, gm_detuned=detuned, T_cl=Tcl)
    sc["hist_op_mode"] = "mean" if rng.uniform() < 0.25 else "snapshot"
    warm = int(min(1500, 300 + 5 * max(tau, Tcl)))
    sc["warmup"] = warm

    # --- set-point path (steps in OP-equivalent %, converted with K)
    kcK = kc * K
    ref_op = logu(rng, 3.0, 12.0)
    ref_op = min(ref_op, 25.0 / (1.5 * kcK))
    nsp = int(rng.integers(2, 7))
    slot = 2700.0 / nsp
    sp_times = [int(round(150 + slot * (j + rng.uniform(0.1, 0.9)))) for j in range(nsp)]
    offs = [0.0]
    for _ in range(nsp):
        s = ref_op * rng.uniform(0.5, 1.5) * (1 if rng.uniform() < 0.5 else -1)
        if abs(offs[-1] + s) > 12.0:
            s = -s
        offs.append(offs[-1] + s)
    sp0 = rng.uniform(20.0, 80.0)
    sc.update(sp0=sp0, sp_step_ref=K * ref_op, sp_step_ref_op=ref_op, n_sp_steps=nsp,
              sp_step_times=sp_times,
              sp_step_sizes=[K * (offs[j + 1] - offs[j]) for j in range(nsp)])
    sc["_offs"] = offs
    sc["op0"] = rng.uniform(35.0, 65.0)

    # --- measurement noise
    nfrac = logu(rng, 0.01, 0.05) if L1 else logu(rng, 0.03, 0.10)
    sigma = nfrac * K * ref_op
    nsel = rng.uniform()
    ntype = "white" if nsel < 0.45 else ("coloured" if nsel < 0.8 else "quantised")
    sc.update(noise_type=ntype, noise_frac=nfrac, noise_std=sigma)
    nticks = int(round((warm + T_END) / Tc)) + 1
    if ntype == "white":
        noise = sigma * rng.standard_normal(nticks)
        sc["quant_step"] = 0.0
    elif ntype == "coloured":
        tn = logu(rng, 1.0, 10.0)
        phi = math.exp(-Tc / tn)
        sc["noise_corr_time"] = tn
        w = rng.standard_normal(nticks)
        sc_ = 0.95 * sigma
        noise = scipy.signal.lfilter([sc_ * math.sqrt(1 - phi * phi)], [1.0, -phi], w,
                                     zi=[phi * sc_ * rng.standard_normal()])[0]
        noise = noise + 0.31 * sigma * rng.standard_normal(nticks)
        sc["quant_step"] = 0.0
    else:
        q = sigma * rng.uniform(1.5, 3.5)
        sw = math.sqrt(max(sigma ** 2 - q * q / 12.0, (0.2 * sigma) ** 2))
        noise = sw * rng.standard_normal(nticks)
        sc["quant_step"] = q
        sc["noise_white_std"] = sw

    # --- load: random walk (integrated white noise) smoothed by a first-order lag, + steps
    ng = (warm + T_END) * DGS + 2
    tg = -warm + DG * np.arange(ng)
    spread = logu(rng, 0.5, 3.0) if L1 else logu(rng, 1.5, 5.0)
    sig_rw = spread / math.sqrt(T_END)
    tl = logu(rng, 20.0, 300.0)
    rw = np.cumsum(sig_rw * math.sqrt(DG) * rng.standard_normal(ng))
    rw -= rw[0]
    a = math.exp(-DG / tl)
    load = scipy.signal.lfilter([1 - a], [1.0, -a], rw)
    nls = 0
    if rng.uniform() < (0.25 if L1 else 0.4):
        nls = int(rng.integers(1, 3))
    lst = [int(rng.uniform(200, 2800)) for _ in range(nls)]
    lss = [logu(rng, 1.0, 4.0) * (1 if rng.uniform() < 0.5 else -1) for _ in range(nls)]
    for ts_, ss_ in zip(lst, lss, strict=False):
        load = load + ss_ * (tg >= ts_)
    lentry = "input" if rng.uniform() < 0.7 else "output"
    sc.update(load_entry=lentry, load_rw_spread=spread, load_rw_sigma=sig_rw,
              load_filter_tau=tl, n_load_steps=nls, load_step_times=lst,
              load_step_sizes=lss)
    din = np.zeros(ng)
    dout = np.zeros(ng)
    if lentry == "input":
        din += load
    else:
        dout += K * load

    # --- effect defaults
    sc.update(vmodel=V_LINEAR, ctype=C_LINEAR, cpar=1.0, auth=1.0, blend=0.0,
              vlo=0.0, vhi=100.0, oplo=0.0, ophi=100.0, sens_tau=0.0, S=0.0, J=0.0,
              d=0.0, M=1.0, Fs=0.0, Fc=0.0, Fv=0.0, vs=0.0, nmicro=1,
              dir0=1.0 if rng.uniform() < 0.5 else -1.0)

    if cls == "stiction":
        S = logu(rng, 1.0, 6.0) if L1 else logu(rng, 0.2, 1.5)
        if rng.uniform() < 0.5:
            sc["stiction_model"] = "physical"
            J = S * rng.uniform(0.2, 0.9)
            wn = rng.uniform(10.0, 40.0)
            zeta = rng.uniform(0.9, 1.5)
            Fs_, Fc_ = 0.5 * (S + J), 0.5 * (S - J)
            # Stribeck velocity [%/s] for half of the physical valves, pure Karnopp otherwise
            vs = logu(rng, 0.005, 0.05) if rng.uniform() < 0.5 else 0.0
            sc.update(vmodel=V_PHYSICAL, M=1.0 / wn ** 2, Fv=2.0 * zeta / wn, Fs=Fs_, Fc=Fc_,
                      vs=vs, phys_wn=wn, phys_zeta=zeta, nmicro=int(math.ceil(H * wn / 0.02)),
                      S_nominal=S, J_nominal=J)
            Se, Je = measure_physical_SJ(sc["M"], Fs_, Fc_, sc["Fv"], vs, sc["nmicro"])
            sc.update(S_eq=Se, J_eq=Je)
        else:
            J = S * rng.uniform(0.2, 1.0)
            vm = [V_CHOUDHURY, V_KANO, V_HE][int(rng.integers(0, 3))]
            sc.update(vmodel=vm, stiction_model=VALVE_NAMES[vm], S=S, J=J, S_nominal=S,
                      J_nominal=J, S_eq=S, J_eq=J)
    elif cls == "deadband":
        d = logu(rng, 1.0, 6.0) if L1 else logu(rng, 0.2, 1.5)
        sc.update(vmodel=V_BACKLASH, d=d, deadband=d)
    elif cls == "sensor_lag":
        ratio = logu(rng, 0.3, 1.0) if L1 else logu(rng, 0.05, 0.25)
        sc.update(sens_tau=ratio * tau, sensor_tau_ratio=ratio)
    elif cls == "dead_time":
        if rng.uniform() < 0.6:
            fct = rng.uniform(1.5, 3.0) if L1 else rng.uniform(1.15, 1.45)
        else:
            fct = rng.uniform(0.3, 0.6) if L1 else rng.uniform(0.65, 0.87)
        sc.update(theta_plant=theta * fct, theta_factor=fct)
        if abs(theta * fct - theta) < 1.0:
            sc["_reject"] = "dtheta<1s"
    elif cls == "valve_characteristic":
        if rng.uniform() < 0.6:
            ctype, cpar = C_EQPCT, (logu(rng, 20.0, 50.0) if L1 else logu(rng, 10.0, 30.0))
        else:
            ctype, cpar = C_QUICK, (rng.uniform(2.0, 4.0) if L1 else rng.uniform(1.5, 3.0))
        auth = rng.uniform(0.3, 1.0)
        blend = rng.uniform(0.6, 1.0) if L1 else rng.uniform(0.2, 0.5)
        sc.update(ctype=ctype, cpar=cpar, auth=auth, blend=blend,
                  valve_char_type="equal_percentage" if ctype == C_EQPCT else "quick_opening",
                  op0=rng.uniform(20.0, 80.0))
    elif cls == "saturation":
        msel = rng.uniform()
        mode = ("op_high" if msel < 0.35 else "op_low" if msel < 0.6 else
                "valve_travel_limit" if msel < 0.8 else "op_clamp_reduced")
        E = logu(rng, 2.0, 10.0) if L1 else logu(rng, 0.3, 2.0)
        sc.update(sat_mode=mode, sat_excess=E)
        # one SP segment (j*) requires OP/valve travel beyond the limit by E; the other
        # segments are clipped so that they stay >= 3 % inside the limit
        if mode == "op_high" or mode == "op_low":
            lim = 100.0 if mode == "op_high" else 0.0
        elif mode == "valve_travel_limit":
            lim = rng.uniform(60.0, 92.0)
            sc["vhi"] = lim
        else:
            lim = rng.uniform(70.0, 95.0)
            sc["ophi"] = lim
        sc["sat_limit"] = lim
        off_star = E + rng.uniform(3.0, 20.0)
        jstar = int(rng.integers(1, nsp + 1))
        offs = np.array(offs)
        if mode == "op_low":
            op0 = off_star - E
            offs = np.clip(offs, -(off_star - E - 3.0), 95.0 - op0)
            offs[jstar] = -off_star
        else:
            op0 = lim + E - off_star
            offs = np.clip(offs, 5.0 - op0, off_star - E - 3.0)
            offs[jstar] = off_star
        offs[0] = 0.0
        sc["op0"] = op0
        sc["sat_segment"] = jstar
        sc["sp_step_sizes"] = [K * (offs[j + 1] - offs[j]) for j in range(nsp)]
    elif cls == "oscillatory_disturbance":
        mult = logu(rng, 2.0, 50.0)
        P = min(max(mult * Tcl, 8.0), 750.0)
        shp = rng.uniform()
        shape = ("sine" if shp < 0.35 else "square" if shp < 0.6 else
                 "harmonics" if shp < 0.85 else "triangle")
        extra = dict(osc_beta=rng.uniform(2.0, 8.0), osc_a2=rng.uniform(0.1, 0.5),
                     osc_a3=rng.uniform(0.1, 0.5), osc_p2=rng.uniform(0, 2 * math.pi),
                     osc_p3=rng.uniform(0, 2 * math.pi))
        entry = "input" if rng.uniform() < 0.5 else "output"
        rr = logu(rng, 1.5, 6.0) if L1 else logu(rng, 0.3, 1.5)
        w = 2 * math.pi / P
        if entry == "output":
            amp = rr * sigma
        else:
            amp = rr * sigma * math.sqrt(1.0 + (w * tau) ** 2) / K
        ph = rng.uniform(0, 2 * math.pi)
        osc = amp * waveform(shape, tg, w, ph, extra)
        if entry == "input":
            din += osc
        else:
            dout += osc
        sc.update(osc_entry=entry, osc_shape=shape, osc_period=P, osc_period_over_Tcl=P / Tcl,
                  osc_amp_over_noise=rr, osc_amplitude=amp, osc_phase=ph)
        if shape == "square":
            sc["osc_beta"] = extra["osc_beta"]
        if shape == "harmonics":
            sc.update({k: extra[k] for k in ("osc_a2", "osc_a3", "osc_p2", "osc_p3")})

    # initial valve position (at rest, resting against the side of direction dir0)
    vm = sc["vmodel"]
    op0 = sc["op0"]
    if vm == V_BACKLASH:
        v0 = op0 - sc["dir0"] * 0.5 * sc["d"]
    elif vm in (V_CHOUDHURY, V_KANO, V_HE):
        v0 = op0 - sc["dir0"] * 0.5 * (sc["S"] - sc["J"])
    elif vm == V_PHYSICAL:
        v0 = op0 - sc["dir0"] * sc["Fc"]
    else:
        v0 = op0
    sc["v0"] = v0
    q0 = charac(min(max(v0, sc["vlo"]), sc["vhi"]), sc["ctype"], sc["cpar"], sc["auth"],
                sc["blend"])
    sc["b"] = sp0 - K * q0
    if cls == "valve_characteristic":
        dq = (charac(op0 + 0.5, sc["ctype"], sc["cpar"], sc["auth"], sc["blend"]) -
              charac(op0 - 0.5, sc["ctype"], sc["cpar"], sc["auth"], sc["blend"]))
        sc["valve_local_gain_ratio"] = dq
    sc["_din"], sc["_dout"], sc["_noise"] = din, dout, noise
    return sc


def run_scenario(sc):
    fp = np.zeros(len(FP))
    vals = dict(K=sc["K"], tau=sc["tau"], theta=sc["theta_plant"], kc=sc["kc"], ti=sc["ti"],
                Tc=sc["Tc"], b=sc["b"], op0=sc["op0"], v0=sc["v0"], sens_tau=sc["sens_tau"],
                quant=sc["quant_step"], S=sc["S"], J=sc["J"], d=sc["d"], M=sc["M"], Fs=sc["Fs"],
                Fc=sc["Fc"], Fv=sc["Fv"], vs=sc["vs"], cpar=sc["cpar"], auth=sc["auth"],
                blend=sc["blend"], vlo=sc["vlo"], vhi=sc["vhi"], oplo=sc["oplo"],
                ophi=sc["ophi"], dir0=sc["dir0"])
    for k, v in vals.items():
        fp[F[k]] = v
    ip = np.zeros(len(IP), dtype=np.int64)
    ip[I_NT] = int(round(sc["Tc"] / H))
    ip[I_NWARM] = sc["warmup"]
    ip[I_VMODEL] = sc["vmodel"]
    ip[I_CTYPE] = sc["ctype"]
    ip[I_HMEAN] = 1 if sc["hist_op_mode"] == "mean" else 0
    ip[I_NMICRO] = sc["nmicro"]
    sp_t = np.array(sc["sp_step_times"], dtype=float)
    sp_v = sc["sp0"] + np.concatenate([[0.0], np.cumsum(sc["sp_step_sizes"])])
    Ad, Bd = plant_matrices(sc["K"], sc["tau"], sc["sens_tau"])
    return simulate(fp, ip, sp_t, sp_v, sc["_din"], sc["_dout"], sc["_noise"], Ad, Bd)


def saturation_fraction(sc, op):
    mode = sc.get("sat_mode")
    if mode == "op_high":
        return float(np.mean(op >= 100.0 - 1e-6))
    if mode == "op_low":
        return float(np.mean(op <= 1e-6))
    if mode == "op_clamp_reduced":
        return float(np.mean(op >= sc["sat_limit"] - 1e-6))
    if mode == "valve_travel_limit":
        return float(np.mean(op > sc["sat_limit"] + 1e-6))
    return 0.0


def make_recording(seed, level, cls):
    rng = np.random.default_rng(seed)
    for attempt in range(1, MAX_ATTEMPTS + 1):
        sc = draw_scenario(rng, level, cls)
        if "_reject" in sc:
            continue
        sp, pv, op, vpos, opmin, opmax = run_scenario(sc)
        if not (np.all(np.isfinite(pv)) and np.all(np.isfinite(op))):
            continue
        if cls == "saturation":
            fsat = saturation_fraction(sc, op)
            sc["sat_fraction"] = fsat
            if not (0.01 <= fsat <= 0.6):
                continue
        elif opmin < 2.0 or opmax > 98.0:
            continue
        sc.update(attempts=attempt, op_min=opmin, op_max=opmax)
        return sc, sp, pv, op
    raise RuntimeError(f"seed {seed} ({cls}, level {level}): no valid scenario")


# ----------------------------------------------------------------------------
# output
# ----------------------------------------------------------------------------
TRUTH_COLS = [
    "name", "level", "class", "seed", "attempts",
    "K", "tau", "theta_model", "theta_plant", "tuning_rule", "tuning_par", "kc", "ti",
    "gain_margin", "gm_detuned", "T_cl", "controller_period", "hist_op_mode", "warmup",
    "op0", "sp0", "sp_step_ref", "sp_step_ref_op", "n_sp_steps", "sp_step_times", "sp_step_sizes",
    "noise_type", "noise_frac", "noise_std", "noise_corr_time", "quant_step", "noise_white_std",
    "load_entry", "load_rw_spread", "load_rw_sigma", "load_filter_tau", "n_load_steps",
    "load_step_times", "load_step_sizes",
    "stiction_model", "S_nominal", "J_nominal", "S_eq", "J_eq", "phys_Fs", "phys_Fc",
    "phys_Fv", "phys_M", "phys_vs", "phys_wn", "phys_zeta",
    "deadband", "sensor_tau", "sensor_tau_ratio", "theta_factor",
    "valve_char_type", "valve_char_param", "valve_authority", "valve_blend",
    "valve_local_gain_ratio",
    "sat_mode", "sat_limit", "sat_excess", "sat_segment", "sat_fraction",
    "osc_entry", "osc_shape", "osc_period", "osc_period_over_Tcl", "osc_amplitude",
    "osc_amp_over_noise", "osc_phase", "osc_beta", "osc_a2", "osc_a3", "osc_p2", "osc_p3",
    "dir0", "op_min", "op_max",
]


def fmt(v):
    if v is None:
        return ""
    if isinstance(v, (list, tuple)):
        return ";".join(fmt(x) for x in v)
    if isinstance(v, (bool, np.bool_)):
        return str(int(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            return ""
        s = f"{float(v):.6f}".rstrip("0").rstrip(".")
        return "0" if s in ("-0", "") else s
    return str(v)


def truth_row(name, level, cls, seed, sc):
    row = dict(sc)
    row.update(name=name, level=level, seed=seed)
    row["class"] = cls
    row["controller_period"] = sc["Tc"]
    if sc["vmodel"] == V_PHYSICAL:
        row.update(phys_Fs=sc["Fs"], phys_Fc=sc["Fc"], phys_Fv=sc["Fv"], phys_M=sc["M"],
                   phys_vs=sc["vs"])
    if cls == "sensor_lag":
        row["sensor_tau"] = sc["sens_tau"]
    if cls == "valve_characteristic":
        row.update(valve_char_param=sc["cpar"], valve_authority=sc["auth"], valve_blend=sc["blend"])
    if cls != "stiction" and cls != "deadband":
        row["dir0"] = None
    return [fmt(row.get(c)) for c in TRUTH_COLS]


def write_recording(out, name, sc, sp, pv, op):
    t = np.arange(T_END + 1)
    with open(os.path.join(out, name + ".csv"), "w") as f:
        f.write("t,SP,PV,OP\n")
        for k in range(T_END + 1):
            f.write(f"{t[k]},{sp[k]:.6f},{pv[k]:.6f},{op[k]:.6f}\n")
    with open(os.path.join(out, name + ".model.yaml"), "w") as f:
        f.write(f"process: {{gain: {sc['K']!r}, time_constant: {sc['tau']!r}, "
                f"dead_time: {sc['theta_model']!r}}}\n")
        f.write(f"controller: {{kc: {sc['kc']!r}, ti: {sc['ti']!r}}}\n")
        f.write("sample_time: 1.0\n")
        f.write("op_range: [0, 100]\n")


def rec_name(seed):
    return "d_" + hashlib.sha256(f"blindgen-d-{seed}".encode()).hexdigest()[:10]


def generate(out, per_class, first_seed):
    os.makedirs(out, exist_ok=True)
    rows = []
    seed = first_seed
    t0 = time.time()
    for level in LEVELS:
        for cls in CLASSES:
            for _ in range(per_class):
                name = rec_name(seed)
                sc, sp, pv, op = make_recording(seed, level, cls)
                write_recording(out, name, sc, sp, pv, op)
                rows.append(truth_row(name, level, cls, seed, sc))
                seed += 1
            print(f"level {level} {cls:24s} done  ({time.time() - t0:6.1f} s)", flush=True)
    with open(os.path.join(out, "truth.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(TRUTH_COLS)
        w.writerows(rows)
    print(f"wrote {len(rows)} recordings to {out} in {time.time() - t0:.1f} s")


# ----------------------------------------------------------------------------
# --check
# ----------------------------------------------------------------------------
def check(out):
    with open(os.path.join(out, "truth.csv")) as f:
        truth = list(csv.DictReader(f))
    groups = {}
    problems = 0
    for r in truth:
        data = np.loadtxt(os.path.join(out, r["name"] + ".csv"), delimiter=",", skiprows=1)
        with open(os.path.join(out, r["name"] + ".model.yaml")) as f:
            model = yaml.safe_load(f)
        t, sp, pv, op = data.T
        ok = (data.shape == (T_END + 1, 4) and np.allclose(t, np.arange(T_END + 1)) and
              model["sample_time"] == 1.0 and model["op_range"] == [0, 100] and
              model["process"]["gain"] > 0 and model["controller"]["kc"] > 0)
        if not ok:
            problems += 1
        ref = float(r["sp_step_ref"])
        err = pv - sp
        dop = np.diff(op)
        st = dict(
            err_std_over_step=np.std(err[50:-50]) / ref,
            dpv_over_noise=1.4826 * np.median(np.abs(np.diff(pv) - np.median(np.diff(pv))))
            / math.sqrt(2.0) / float(r["noise_std"]),
            op_std=np.std(op),
            op_min=op.min(), op_max=op.max(),
            op_at_limit=np.mean((op <= 1e-6) | (op >= 100 - 1e-6)),
            op_rev_per_min=60.0 * np.mean(np.sign(dop[1:]) * np.sign(dop[:-1]) < 0),
            noise_frac=float(r["noise_frac"]),
            attempts=float(r["attempts"]),
            n_sp=len(np.nonzero(np.diff(sp))[0]),
        )
        groups.setdefault((int(r["level"]), r["class"]), []).append(st)
    keys = list(next(iter(groups.values()))[0].keys())
    print(f"{len(truth)} recordings, {problems} with format problems")
    hdr = f"{'lvl':>3} {'class':24s} {'n':>3} " + " ".join(f"{k[:13]:>13s}" for k in keys)
    print(hdr)
    for level in LEVELS:
        for cls in CLASSES:
            g = groups.get((level, cls))
            if not g:
                continue
            vals = [np.mean([s[k] for s in g]) if k not in ("op_min",)
                    else np.min([s[k] for s in g])
                    for k in keys]
            vals[keys.index("op_max")] = np.max([s["op_max"] for s in g])
            print(f"{level:>3} {cls:24s} {len(g):>3} " + " ".join(f"{v:13.4g}" for v in vals))
    # class-specific summaries
    print("\nclass-specific effect sizes (median [min, max]):")
    for level in LEVELS:
        for cls, col in [("stiction", "S_eq"), ("stiction", "J_eq"), ("deadband", "deadband"),
                         ("sensor_lag", "sensor_tau_ratio"), ("dead_time", "theta_factor"),
                         ("valve_characteristic", "valve_local_gain_ratio"),
                         ("saturation", "sat_fraction"), ("saturation", "sat_excess"),
                         ("oscillatory_disturbance", "osc_period_over_Tcl"),
                         ("oscillatory_disturbance", "osc_amp_over_noise")]:
            v = np.array([float(r[col]) for r in truth
                          if r["class"] == cls and int(r["level"]) == level
                          and r[col] != ""])
            if v.size:
                print(f"  L{level} {cls:24s} {col:24s} {np.median(v):8.3g} "
                      f"[{v.min():.3g}, {v.max():.3g}]")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--per-class", type=int, required=True)
    ap.add_argument("--first-seed", type=int, required=True)
    ap.add_argument("--check", action="store_true", help="read the files back and print statistics")
    a = ap.parse_args(argv)
    generate(a.out, a.per_class, a.first_seed)
    if a.check:
        check(a.out)


if __name__ == "__main__":
    main()
