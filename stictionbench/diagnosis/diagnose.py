"""Diagnose the gap between a nominal simulation and a recording.

compare → locate → hypothesise → fit → validate:

1. **Compare.** Replay the nominal model open loop from the recorded OP (and closed loop
   from SP when the controller is known) and form the residual PV − PV̂. Slow unmeasured
   loads are removed from PV and from every model output by the same zero-phase
   high-pass (cut-off ``0.3/(2π(τ+θ))`` ≈ one cycle per 20 (τ+θ)): a
   drift slower than the loop cannot be mistaken for physics.
2. **Locate.** Windows in time where the residual's rolling RMS exceeds twice the
   white-noise floor; the band in frequency where its spectrum exceeds four times the
   floor; its coherence with OP in that band.
3. **Hypothesise and fit.** Each vocabulary entry (:mod:`.hypotheses`) is fitted on the
   training blocks (after a burn-in of θ + 3τ the record is cut into five blocks:
   blocks 1, 3, 5 train, blocks 2, 4 validate) by a coarse grid and Nelder–Mead; the
   simulation always runs through the whole record, only the scoring is split.
4. **Validate.** On the validation blocks: the candidate must beat the nominal model with an
   F-test (p < ``alpha`` at the effective sample size) and by at least ``min_improvement``
   in NRMSE; among those the lowest BIC-style score (``n·ln MSE + k·ln n`` on the training
   part plus the same on the validation part) wins, otherwise the answer is ``none``.
5. **Uncertainty.** Profile-likelihood intervals of every fitted parameter.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize
from scipy.stats import f as f_dist

from ..errors import InputError
from ..recording import Recording
from .fit import Fit, Problem, fit_hypothesis, n_effective
from .hypotheses import HYPOTHESES, Context, Nominal
from .locate import dominant_periods, mismatch_band, mismatch_windows, noise_floor
from .model import NominalModel, identify_pi
from .openloop import fopdt_response, highpass, play, stiction_valve

TRAIN_FRACTION = 0.6
#: the record after the burn-in is cut into this many blocks, alternately training and
#: validation (training first and last): an event that happens only late in the record
#: (a saturation, a slip) is then seen by both parts
N_BLOCKS = 5
#: valve hypotheses for which the process is re-identified from the estimated valve
#: output when no nominal model was given
REIDENTIFY = ("stiction", "deadband")


def valve_output(name: str, p: np.ndarray, ctx: Context) -> np.ndarray:
    """The valve position implied by a fitted valve hypothesis."""
    if name == "stiction":
        return stiction_valve(ctx.op, float(p[0]), float(min(p[1], 1.5 * p[0])),
                              HYPOTHESES["stiction"]._delta(ctx, p[2]))
    if name == "deadband":
        return play(ctx.op, float(p[0]))
    raise ValueError(name)


@dataclass
class Diagnosis:
    """The result of :func:`diagnose`; :meth:`to_json` gives the CLI's JSON."""

    mismatch_detected: bool
    missing_physics: str
    parameters: dict[str, Any]
    fit: dict[str, Any]
    mismatch_windows: list[list[float]]
    mismatch_band_hz: list[float]
    ranking: list[dict[str, Any]]
    model: NominalModel
    uncertainty: dict[str, list[float]]
    details: dict[str, Any] = field(default_factory=dict)
    # arrays for the report (not in JSON)
    rec: Recording | None = field(default=None, repr=False)
    fits: dict[str, Fit] = field(default_factory=dict, repr=False)
    spectrum: dict[str, Any] = field(default_factory=dict, repr=False)
    train_end: int = 0
    val_blocks: list[list[float]] = field(default_factory=list)
    burn: int = 0

    def to_json(self) -> dict[str, Any]:
        return {
            "mismatch_detected": bool(self.mismatch_detected),
            "missing_physics": self.missing_physics,
            "parameters": self.parameters,
            "fit": self.fit,
            "mismatch_windows": self.mismatch_windows,
            "mismatch_band_hz": self.mismatch_band_hz,
            "ranking": self.ranking,
            "uncertainty": self.uncertainty,
            "nominal_model": self.model.to_dict(),
            "details": {k: v for k, v in self.details.items() if not k.startswith("_")},
        }


def fit_fopdt(u: np.ndarray, pv: np.ndarray, Ts: float,
              f_hp_factor: float = 1 / 15) -> tuple[float, float, float]:
    """Output-error FOPDT fit ``u → pv``: a grid over τ and θ with the gain solved
    linearly on high-passed signals, then Nelder–Mead. Returns ``(K, τ, θ)``."""
    n = u.size
    T = n * Ts
    taus = np.geomspace(Ts, max(2 * Ts, T / 8), 14)
    thetas = np.arange(0.0, min(T / 8, 60 * Ts) + 1e-9, max(Ts, T / 8 / 30))

    def cost(tau: float, theta: float) -> tuple[float, float]:
        f_hp = f_hp_factor / (2 * math.pi * (tau + theta))
        y = highpass(pv, Ts, f_hp)
        g = highpass(fopdt_response(u, Ts, tau, theta), Ts, f_hp)
        burn = min(int((theta + 3 * tau) / Ts), n // 5)
        gg = float(np.dot(g[burn:], g[burn:]))
        if gg <= 0:
            return math.inf, 0.0
        K = float(np.dot(g[burn:], y[burn:]) / gg)
        r = y[burn:] - K * g[burn:]
        # normalise by the PV energy in the same band so that cut-offs compare fairly
        yy = float(np.dot(y[burn:], y[burn:])) or 1.0
        return float(np.dot(r, r) / yy), K

    best = (math.inf, Ts, 0.0)
    for tau in taus:
        for th in thetas:
            c, _ = cost(tau, th)
            if c < best[0]:
                best = (c, tau, th)
    tau_max, theta_max = max(2 * Ts, T / 2), max(Ts, T / 4)

    def clip(z):
        return (min(math.exp(min(z[0], 50.0)), tau_max), min(max(z[1], 0.0), theta_max))

    res = minimize(lambda z: cost(*clip(z))[0],
                   [math.log(best[1]), best[2]], method="Nelder-Mead",
                   options={"xatol": 1e-3, "fatol": 1e-10, "maxiter": 200})
    tau, theta = clip(res.x)
    if res.fun > best[0]:
        tau, theta = best[1], best[2]
    _, K = cost(tau, theta)
    return K, tau, theta


def identify_fopdt(rec: Recording, f_hp_factor: float = 1 / 15) -> NominalModel:
    """Identify a FOPDT nominal model from OP → PV (see :func:`fit_fopdt`) and a PI
    controller from SP, PV, OP when SP is recorded."""
    K, tau, theta = fit_fopdt(np.asarray(rec.OP, float), np.asarray(rec.PV, float), rec.Ts,
                              f_hp_factor)
    pi = identify_pi(rec)
    return NominalModel(K, tau, theta, pi[0] if pi else None, pi[1] if pi else None, rec.Ts,
                        "identified")


def closed_loop_replay(rec: Recording, m: NominalModel) -> dict[str, Any] | None:
    """Replay the nominal loop from the recorded SP (PI velocity form at Ts, linear valve,
    no disturbance); return NRMSE of PV and OP against the recording."""
    if rec.SP is None or m.kc is None or m.ti is None:
        return None
    n = len(rec)
    Ts = rec.Ts
    a = math.exp(-Ts / m.time_constant)
    d = int(round(m.dead_time / Ts))
    op = np.empty(n)
    pv = np.empty(n)
    u = rec.OP[0]
    y = rec.PV[0]
    e_prev = rec.SP[0] - y
    hist = np.full(n + d + 1, u)
    for k in range(n):
        pv[k] = y
        e = rec.SP[k] - y
        if k > 0:
            u = min(max(u + m.kc * ((e - e_prev) + Ts / m.ti * e), 0.0), 100.0)
        e_prev = e
        op[k] = u
        hist[k + d] = u
        y = a * y + (1 - a) * (rec.PV[0] + m.gain * (hist[k] - rec.OP[0]))

    def nrmse(x, ref):
        s = float(np.std(ref)) or 1.0
        return float(np.sqrt(np.mean((x - ref) ** 2)) / s)

    return {"pv_nrmse": nrmse(pv, rec.PV), "op_nrmse": nrmse(op, rec.OP),
            "pv": pv, "op": op}


def diagnose(rec: Recording, model: NominalModel | None = None, *, alpha: float = 0.01,
             min_improvement: float = 0.05, hp_factor: float = 0.3, lp_factor: float = 5.0,
             hypotheses: tuple[str, ...] | None = None) -> Diagnosis:
    """Name the physics missing from ``model`` that best explains ``rec``.

    Parameters
    ----------
    rec : Recording
        Needs ``t, PV, OP``; ``SP`` enables the closed-loop replay; ``MV`` is not used.
    model : NominalModel, optional
        The user's nominal model; identified from the recording when ``None``.
    alpha : float
        Significance level of the F-test against the nominal model on validation data.
    min_improvement : float
        Smallest relative NRMSE improvement on validation data that counts.
    hp_factor : float
        High-pass cut-off as a fraction of ``1/(2π(τ+θ))`` (slow-load rejection).
    lp_factor : float
        Low-pass cut-off in multiples of the process corner ``1/(2πτ)`` (noise rejection).
    hypotheses : tuple of str, optional
        Restrict the library (default: the whole vocabulary).

    Returns
    -------
    Diagnosis

    References
    ----------
    Choudhury, Thornhill & Shah, Control Eng. Practice 13 (2005) (two-parameter valve
    model); Kano et al., DYCOPS 2004; Ljung, *System Identification* (1999), ch. 16
    (validation on fresh data, F-test model comparison).
    """
    t0 = time.perf_counter()
    n = len(rec)
    if np.ptp(rec.OP) <= 1e-9 * max(1.0, float(np.max(np.abs(rec.OP)))):
        raise InputError(f"{rec.meta.get('source', 'recording')}: OP is constant; a "
                         "diagnosis needs the controller output to move")
    if np.ptp(rec.PV) <= 0:
        raise InputError(f"{rec.meta.get('source', 'recording')}: PV is constant; "
                         "nothing to diagnose")
    if n < 200:
        raise InputError(f"{rec.meta.get('source', 'recording')}: {n} samples; a diagnosis "
                         "needs at least 200 (a training and a validation part)")
    if model is None:
        model = identify_fopdt(rec, hp_factor)
    elif model.kc is None and rec.SP is not None:
        pi = identify_pi(rec)
        if pi:
            model = NominalModel(model.gain, model.time_constant, model.dead_time, pi[0],
                                 pi[1], model.sample_time, model.source)
    Ts = rec.Ts
    tau, theta = model.time_constant, model.dead_time
    f_hp = hp_factor / (2 * math.pi * (tau + theta))
    # above ~5 corner frequencies of the process, PV content caused by OP is attenuated
    # more than five-fold: what is left there is measurement noise
    f_lp = min(0.4 / Ts, lp_factor / (2 * math.pi * tau))
    burn = min(int(math.ceil((theta + 3 * tau) / Ts)), n // 5)
    edges = np.linspace(burn, n, N_BLOCKS + 1).round().astype(int)
    blocks = [np.arange(edges[i], edges[i + 1]) for i in range(N_BLOCKS)]
    train_idx = np.concatenate(blocks[0::2])
    val_idx = np.concatenate(blocks[1::2])
    val_blocks = [[float(rec.t[b[0]]), float(rec.t[b[-1]])] for b in blocks[1::2]]
    split = int(edges[1])
    if edges[1] - edges[0] < 40:
        raise InputError(f"{rec.meta.get('source', 'recording')}: too short for the "
                         f"model's time scales (θ + 3τ = {theta + 3 * tau:g} s)")
    ctx = Context(rec.t - rec.t[0], np.asarray(rec.OP, float), np.asarray(rec.PV, float),
                  Ts, tau, theta, f_hp)
    prob = Problem(ctx, f_hp, train_idx, val_idx, f_lp)
    # recording convention: historians store OP either before or after the controller
    # executes, which shifts the apparent dead time by one sample. That is bookkeeping,
    # not physics: every hypothesis (the nominal one included) may absorb a shift of ±1
    # sample, chosen by its own training fit (a valve that adds lag must not bias the
    # alignment of the others).
    shifts = [s for s in (0.0, -Ts, Ts) if theta + s >= 0]

    def fit_aligned(h) -> Fit:
        best: Fit | None = None
        for shift in shifts if h.name != "dead_time" else (0.0,):
            ctx_s = Context(ctx.t, ctx.op, ctx.pv, Ts, tau, theta + shift, f_hp,
                            ctx.resid_periods)
            ft = fit_hypothesis(Problem(ctx_s, f_hp, prob.train, prob.val, f_lp), h)
            ft.extra = {**ft.extra, "timing_shift_s": shift}
            if best is None or ft.cost_train < best.cost_train * (1 - 1e-9):
                best = ft
        assert best is not None
        return best

    nominal = fit_aligned(Nominal())
    ctx.resid_periods = dominant_periods(nominal.resid[burn:], Ts)
    names = hypotheses or tuple(HYPOTHESES)
    fits: dict[str, Fit] = {"none": nominal}
    for name in names:
        fits[name] = fit_aligned(HYPOTHESES[name])
    if model.source == "identified":
        # the nominal dynamics were identified through the very valve we suspect: a
        # sticky valve's lag is absorbed into τ and θ. For the valve hypotheses, identify
        # the process again from the fitted valve output, then refit the valve.
        for name in REIDENTIFY:
            if name not in fits:
                continue
            h = HYPOTHESES[name]
            for _round in range(2):
                mv = valve_output(name, fits[name].p, ctx)
                _, tau_h, theta_h = fit_fopdt(mv, ctx.pv, Ts, hp_factor)
                ctx_h = Context(ctx.t, ctx.op, ctx.pv, Ts, tau_h, theta_h, f_hp,
                                ctx.resid_periods)
                prob_h = Problem(ctx_h, f_hp, prob.train, prob.val, f_lp)
                refit = fit_hypothesis(prob_h, h)
                refit.n_params += 2  # τ and θ were fitted for this hypothesis
                refit.extra = {**refit.extra, "time_constant": tau_h, "dead_time": theta_h}
                if refit.cost_train < fits[name].cost_train:
                    fits[name] = refit
                else:
                    break
    # ---- validation
    yv = prob.y[prob.val]
    sy = float(np.std(yv)) or 1.0
    for ft in fits.values():
        r = ft.resid[prob.val]
        ft.mse_val = float(np.mean(r * r))
        ft.nrmse_val = math.sqrt(ft.mse_val) / sy
        ft.n_eff_val = n_effective(r)
    base = fits["none"]
    rows = []
    for name, ft in fits.items():
        n_eff = ft.n_eff_val
        n_tr = n_effective(ft.resid[prob.train])
        # BIC-style score on the training part plus the same on the validation part:
        # a candidate must both explain the data it was fitted on (many samples: the
        # penalty separates nested models such as deadband ⊂ stiction) and hold up on
        # data it did not see
        score = (n_tr * math.log(max(ft.cost_train, 1e-300)) + ft.n_params * math.log(n_tr)
                 + n_eff * math.log(max(ft.mse_val, 1e-300)) + ft.n_params * math.log(n_eff))
        if name == "none":
            pval, improvement = 1.0, 0.0
        else:
            F = base.mse_val / max(ft.mse_val, 1e-300)
            pval = float(f_dist.sf(F, n_eff, n_eff))
            improvement = 1.0 - ft.nrmse_val / max(base.nrmse_val, 1e-300)
        rows.append({"physics": name, "raw_score": score, "p_value": pval,
                     "improvement": improvement, "nrmse_validation": ft.nrmse_val,
                     "parameters": ft.params,
                     "significant": bool(name != "none" and pval < alpha
                                         and improvement >= min_improvement)})
    cands = [r for r in rows if r["significant"]]
    pick = min(cands, key=lambda r: r["raw_score"])["physics"] if cands else "none"
    best_score = min(r["raw_score"] for r in rows)
    ranking = sorted(({"physics": r["physics"], "score": r["raw_score"] - best_score,
                       "improvement": r["improvement"], "p_value": r["p_value"],
                       "nrmse_validation": r["nrmse_validation"],
                       "significant": r["significant"], "parameters": r["parameters"]}
                      for r in rows), key=lambda r: r["score"])
    chosen = fits[pick]
    # ---- locate: the nominal residual over the whole record after the burn-in, high-
    # passed only (the white measurement noise sets the floor it is compared with)
    h0 = Nominal()
    ctx0 = Context(ctx.t, ctx.op, ctx.pv, Ts, tau, theta + base.extra.get("timing_shift_s", 0.0),
                   f_hp)
    X0 = highpass(h0.regressors(ctx0, np.zeros(0)), Ts, f_hp)
    r_nom = highpass(ctx.pv, Ts, f_hp) - X0 @ base.beta
    sigma = noise_floor(r_nom[burn:])
    w = max(10, int(round((tau + theta) / Ts)))
    windows = mismatch_windows(rec.t, r_nom, sigma, w, start=burn)
    band, spec = mismatch_band(r_nom[burn:], Ts, sigma, rec.OP[burn:])
    ratio = float(np.var(r_nom[burn:]) / max(sigma * sigma, 1e-300))
    detected = bool(pick != "none" or ratio > 2.0)
    cl = closed_loop_replay(rec, model)
    details: dict[str, Any] = {
        "model_source": model.source,
        "residual_to_noise_variance": ratio,
        "noise_floor": sigma,
        "highpass_hz": f_hp,
        "lowpass_hz": f_lp,
        "timing_shift_s": nominal.extra.get("timing_shift_s", 0.0),
        "burn_in_samples": int(burn),
        "validation_windows": val_blocks,
        "band_coherence_with_op": spec.get("band_coherence"),
        "closed_loop_replay": None if cl is None else
        {"pv_nrmse": cl["pv_nrmse"], "op_nrmse": cl["op_nrmse"]},
        "seconds": None,
    }
    if model.source == "identified":
        details["note"] = ("no --model given: a FOPDT nominal model was identified from "
                           "the recording (OP → PV) and used as the nominal model")
    diag = Diagnosis(
        mismatch_detected=detected,
        missing_physics=pick,
        parameters=dict(chosen.params) if pick != "none" else {},
        fit={"metric": "nrmse", "segment": "validation", "nominal": base.nrmse_val,
             "improved": chosen.nrmse_val},
        mismatch_windows=windows,
        mismatch_band_hz=band,
        ranking=ranking,
        model=model,
        uncertainty=chosen.intervals if pick != "none" else {},
        details=details,
        rec=rec,
        fits=fits,
        spectrum=spec,
        train_end=split,
        val_blocks=val_blocks,
        burn=burn,
    )
    if cl is not None:
        diag.details["_cl_arrays"] = cl
    diag.details["seconds"] = time.perf_counter() - t0
    return diag
