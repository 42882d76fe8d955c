"""Diagnose the gap between a nominal simulation and a recording.

compare → locate → hypothesise → fit → validate:

1. **Compare.** Replay the nominal model open loop from the recorded OP (and closed loop
   from SP when the controller is known) and form the residual PV − PV̂. Slow unmeasured
   loads are removed from PV and from every model output by the same zero-phase
   high-pass (cut-off a fifteenth of the loop's natural frequency ``1/(2π(τ+θ))``): a
   drift slower than the loop cannot be mistaken for physics.
2. **Locate.** Windows in time where the residual's rolling RMS exceeds twice the
   white-noise floor; the band in frequency where its spectrum exceeds four times the
   floor; its coherence with OP in that band.
3. **Hypothesise and fit.** Each vocabulary entry (:mod:`.hypotheses`) is fitted on the
   first 60 % of the record (after a burn-in of θ + 3τ) by a coarse grid and Nelder–Mead.
4. **Validate.** On the last 40 %: the candidate must beat the nominal model with an
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
from .openloop import fopdt_response, highpass

TRAIN_FRACTION = 0.6


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
            "details": self.details,
        }


def identify_fopdt(rec: Recording, f_hp_factor: float = 1 / 15) -> NominalModel:
    """Identify a FOPDT ``(K, τ, θ)`` from OP → PV by output-error least squares on
    high-passed signals: a grid over τ and θ (gain solved linearly), then Nelder–Mead."""
    Ts = rec.Ts
    n = len(rec)
    T = n * Ts
    op = rec.OP
    taus = np.geomspace(Ts, max(2 * Ts, T / 8), 14)
    thetas = np.arange(0.0, min(T / 8, 60 * Ts) + 1e-9, max(Ts, T / 8 / 30))

    def cost(tau: float, theta: float) -> tuple[float, float]:
        f_hp = f_hp_factor / (2 * math.pi * (tau + theta))
        y = highpass(rec.PV, Ts, f_hp)
        g = highpass(fopdt_response(op, Ts, tau, theta), Ts, f_hp)
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
    res = minimize(lambda z: cost(math.exp(z[0]), max(z[1], 0.0))[0],
                   [math.log(best[1]), best[2]], method="Nelder-Mead",
                   options={"xatol": 1e-3, "fatol": 1e-10, "maxiter": 200})
    tau, theta = math.exp(res.x[0]), max(float(res.x[1]), 0.0)
    if res.fun > best[0]:
        tau, theta = best[1], best[2]
    _, K = cost(tau, theta)
    pi = identify_pi(rec)
    return NominalModel(K, tau, theta, pi[0] if pi else None, pi[1] if pi else None, Ts,
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
             min_improvement: float = 0.05, hp_factor: float = 1 / 15,
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
    burn = min(int(math.ceil((theta + 3 * tau) / Ts)), n // 5)
    split = int(TRAIN_FRACTION * n)
    if split - burn < 50 or n - split < 50:
        raise InputError(f"{rec.meta.get('source', 'recording')}: too short for the "
                         f"model's time scales (θ + 3τ = {theta + 3 * tau:g} s)")
    ctx = Context(rec.t - rec.t[0], np.asarray(rec.OP, float), np.asarray(rec.PV, float),
                  Ts, tau, theta)
    prob = Problem(ctx, f_hp, slice(burn, split), slice(split, n))
    nominal = fit_hypothesis(prob, Nominal())
    ctx.resid_periods = dominant_periods(nominal.resid[burn:split], Ts)
    names = hypotheses or tuple(HYPOTHESES)
    fits: dict[str, Fit] = {"none": nominal}
    for name in names:
        fits[name] = fit_hypothesis(prob, HYPOTHESES[name])
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
    # ---- locate (nominal residual over the whole record after the burn-in)
    r_nom = base.resid
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
        "train_samples": [int(burn), int(split)],
        "validation_samples": [int(split), int(n)],
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
        burn=burn,
    )
    if cl is not None:
        diag.details["_cl_arrays"] = cl
    diag.details["seconds"] = time.perf_counter() - t0
    return diag
