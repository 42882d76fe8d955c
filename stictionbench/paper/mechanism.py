"""What the stiction-case estimates measure, checked by varying what they depend on.

The paper reads a positive CO→MV delay as stiction. In the closed loop of its stiction
case the estimators see something else:

- **cross-correlation** (HOSA ``tder``): every MV slip moves PV after the 10 s dead time
  and the PI controller (``Ti = τ``, so ``C·G = 0.06·e^(−10s)/s``) reverses CO a little
  over 10 s after the slip; the Hannan–Thomson weighting (which favours the coherent,
  linear part of the cross-spectrum) locks onto this MV → PV → CO path and returns a
  *negative* lag inside ``[−(θ+τ), −θ]`` (:func:`slip_to_reversal`,
  :func:`harmonic_lags`);
- **cross-cumulant** (HOSA ``tde``): the triangular CO of a limit cycle is almost
  symmetric (skewness near 0), its third-order cumulants nearly vanish, the normal
  equations are near-singular and the arg-max moves with the window (:func:`xcum_windows`);
- **bicoherence**: the steady cycle has odd harmonics only, invisible to third-order
  statistics, and its period is close to one FFT bin unless decimated (:func:`bicoherence_study`).

:func:`open_loop_test` checks the paper's premise directly: with a known CO driving the
valve alone, does stiction delay MV behind CO?

References: Govinda Kumar & Manoharan (``../shared/paper/``); Hannan & Thomson, *JASA*
54 (1973) for the ML window; Choudhury, Shah & Thornhill, *Automatica* 40 (2004) for
bicoherence on decimated data; Nikias & Petropulu, *Higher-Order Spectra Analysis*
(1993), ch. 11 for cumulant delay estimation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
from scipy.stats import skew

from ..config import compose
from ..estimators import make
from ..recording import Recording
from ..reports.tables import magnitude
from ..sim.compose import simulate
from ..sim.valves import PhysicalValve, respond

#: windows of the cumulant study (the paper uses 30)
WINDOWS = (10, 20, 30, 50, 80)


def slip_times(t: np.ndarray, mv: np.ndarray, *, min_stuck: float = 1.0,
               tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Onsets of the valve's slips and their directions.

    A slip is the first sample at which the stem moves after having been still
    (``|ΔMV| ≤ tol``) for at least ``min_stuck`` seconds.

    Examples
    --------
    >>> t = np.arange(0, 10, 0.5)
    >>> mv = np.r_[np.zeros(6), np.ones(8), np.zeros(6)]
    >>> slip_times(t, mv, min_stuck=1.0)
    (array([2.5, 6.5]), array([ 1, -1]))
    """
    dt = float(np.median(np.diff(t)))
    moving = np.abs(np.diff(mv)) > tol
    need = max(1, int(round(min_stuck / dt)))
    onsets, signs = [], []
    still = 0
    for i, m in enumerate(moving):
        if m:
            if still >= need:
                onsets.append(t[i])
                signs.append(int(np.sign(mv[i + 1] - mv[i])))
            still = 0
        else:
            still += 1
    return np.asarray(onsets, float), np.asarray(signs, int)


def reversal_times(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Times at which ``x`` changes direction (flat stretches skipped).

    Examples
    --------
    >>> reversal_times(np.arange(7.0), np.array([0, 1, 2, 1, 0, 1, 2.0]))
    array([2., 4.])
    """
    d = np.diff(x)
    idx = np.flatnonzero(d != 0)
    s = np.sign(d[idx])
    flips = np.flatnonzero(np.diff(s) != 0)
    return t[idx[flips] + 1]


def slip_to_reversal(t: np.ndarray, op: np.ndarray, mv: np.ndarray) -> np.ndarray:
    """Seconds from each slip of the valve to the next reversal of CO."""
    slips, _ = slip_times(t, mv)
    rev = reversal_times(t, op)
    out = []
    for s in slips:
        later = rev[rev > s]
        if later.size:
            out.append(later[0] - s)
    return np.asarray(out, float)


def cycle_period(t: np.ndarray, mv: np.ndarray) -> float:
    """Median time between slips in the same direction (the limit cycle's period), s."""
    slips, signs = slip_times(t, mv)
    gaps = [np.diff(slips[signs == s]) for s in (-1, 1)]
    gaps = np.concatenate([g for g in gaps if g.size]) if any(g.size for g in gaps) else []
    return float(np.median(gaps)) if len(gaps) else float("nan")


def plain_correlation_lag(x: np.ndarray, y: np.ndarray, max_lag: int) -> tuple[int, float]:
    """Lag (samples, positive: ``y`` lags ``x``) of the largest correlation coefficient
    between ``x(t)`` and ``y(t + k)``, ``|k| ≤ max_lag``, with no spectral weighting."""
    x = (x - x.mean()) / x.std()
    y = (y - y.mean()) / y.std()
    n = x.size
    lags = np.arange(-max_lag, max_lag + 1)
    r = np.array([np.dot(x[max(0, -k):n - max(0, k)], y[max(0, k):n - max(0, -k)])
                  / (n - abs(k)) for k in lags])
    i = int(np.argmax(r))
    return int(lags[i]), float(r[i])


def harmonic_lags(t: np.ndarray, x: np.ndarray, y: np.ndarray, period: float,
                  harmonics: tuple[int, ...] = (1, 2, 3, 5)) -> pd.DataFrame:
    """Amplitude of ``x`` and ``y`` and the lag of ``y`` behind ``x`` at harmonics of
    the cycle, from Fourier coefficients over a whole number of periods.

    The lag at harmonic ``h`` is ``−Δφ / (2π h f0)`` with the phase difference wrapped to
    ``(−π, π]``, so it is defined modulo ``period / h``.
    """
    n_per = int((t[-1] - t[0]) // period)
    keep = t - t[0] < n_per * period
    tt, xx, yy = t[keep], x[keep] - x[keep].mean(), y[keep] - y[keep].mean()
    rows = []
    for h in harmonics:
        e = np.exp(-2j * np.pi * h * tt / period)
        cx, cy = 2 * np.mean(xx * e), 2 * np.mean(yy * e)
        dphi = float(np.angle(cy / cx))
        rows.append({"harmonic": h, "frequency_hz": h / period,
                     "amplitude_x": float(abs(cx)), "amplitude_y": float(abs(cy)),
                     "phase_y_minus_x_deg": np.degrees(dphi),
                     "lag_y_behind_x_s": -dphi / (2 * np.pi * h / period)})
    return pd.DataFrame(rows)


def xcum_windows(rec: Recording, windows: tuple[int, ...] = WINDOWS) -> pd.DataFrame:
    """``tde`` delay, stability checks and condition number for several windows."""
    rows = []
    for m in windows:
        r = make("xcum", max_delay=m).estimate(rec, x="OP", y="MV")
        d = r.diagnostics
        rows.append({"max_delay": m, "delay_samples": int(r.value),
                     "at_edge": bool(d["at_edge"]), "wide_delay": d["wide_delay"],
                     "tsvd_delay": d["tsvd_delay"], "unstable": bool(d["unstable"]),
                     "condition_number": magnitude(d["condition_number"]),
                     "decision": r.decision})
    return pd.DataFrame(rows)


def stiction_evidence(cfg: Any) -> dict[str, Any]:
    """Measurements behind the explanation of the stiction-case estimates.

    The loop is simulated at 0.1 s (the controller's rate) so that slips and CO
    reversals are timed to 0.1 s; the estimators see the 1 s recording of the report.
    """
    fine = simulate("stiction", duration=float(cfg.duration), seed=int(cfg.seed),
                    sample_time=0.1)
    rec = simulate("stiction", duration=float(cfg.duration), seed=int(cfg.seed),
                   sample_time=float(cfg.sample_time))
    lags = slip_to_reversal(fine.t, fine.OP, fine.MV)
    period = cycle_period(fine.t, fine.MV)
    half = int(round(period / 2 / rec.Ts))
    plain_lag, plain_r = plain_correlation_lag(rec.OP, rec.MV, half)
    proc = compose(["case=stiction"]).process
    xc = make("xcorr", max_delay=int(cfg.estimators.xcorr.max_delay),
              loop_dead_time=float(proc.dead_time),
              loop_time_constant=float(proc.time_constant)).estimate(rec, x="OP", y="MV")
    return {
        "period_s": period,
        "slip_to_reversal_s": lags,
        "plain_lag_samples": plain_lag,
        "plain_r": plain_r,
        "harmonics": harmonic_lags(fine.t, fine.OP, fine.MV, period),
        "skew": {s: float(skew(fine.signal(s))) for s in ("OP", "MV", "PV")},
        "xcorr": xc,
        "xcum": xcum_windows(rec),
        "dead_time": float(proc.dead_time),
        "time_constant": float(proc.time_constant),
    }


def bicoherence_study(cfg: Any, durations: tuple[float, ...] = (2000.0, 8000.0),
                      decimations: tuple[int, ...] = (1, 2, 3, 4)) -> pd.DataFrame:
    """NGI/NLI of the stiction case's PV against record length and decimation.

    Shows whether "linear" on the stiction case is the method's limit (odd harmonics
    only) or the record's (the cycle near FFT bin 1, too few segments once decimated).
    """
    params = dict(cfg.estimators.bicoherence or {})
    rows = []
    for dur in durations:
        rec = simulate("stiction", duration=dur, seed=int(cfg.seed),
                       sample_time=float(cfg.sample_time))
        period = cycle_period(rec.t, rec.MV)
        for dec in decimations:
            est = make("bicoherence", **{**params, "decimate": dec})
            row: dict[str, Any] = {"duration_s": dur, "decimate": dec,
                                   "cycle_bin": est.nfft * dec * rec.Ts / period}
            try:
                r = est.estimate(rec, x="PV")
                d = r.diagnostics
                row.update(segments=int(d["k_segments"]), ngi=float(d["ngi"]),
                           nli=float(d["nli"]), verdict="nonlinear" if r.decision
                           else "linear or Gaussian")
            except Exception as exc:  # a record too short for this decimation
                row.update(segments=0, ngi=np.nan, nli=np.nan,
                           verdict=" ".join(str(exc).split())[:80])
            rows.append(row)
    return pd.DataFrame(rows)


def open_loop_test(cfg: Any, period: float = 137.0, amplitude: float = 20.0,
                   h: float = 0.01) -> pd.DataFrame:
    """The valve alone driven by a known CO: does stiction delay MV behind CO?

    CO is a sine and a triangle of ``amplitude`` % around 50 % with the closed-loop
    cycle's period; the Table II stiction valve and the "linear" valve respond
    (:func:`stictionbench.sim.valves.respond`, 0.01 s steps, recorded at the report's
    sampling). The true delay is the time the stem stays stuck after each CO reversal.
    """
    ts = float(cfg.sample_time)
    t = np.arange(0.0, float(cfg.duration), h)
    phase = 2 * np.pi * t / period
    shapes = {"sine": np.sin(phase),
              "triangle": 2 / np.pi * np.arcsin(np.sin(phase))}
    every = int(round(ts / h))
    rows = []
    for case in ("stiction", "linear"):
        v = compose([f"case={case}"]).valve
        valve = PhysicalValve(**{k: x for k, x in v.items() if k != "_target_"})
        for shape, wave in shapes.items():
            op = 50 + amplitude * wave
            mv = respond(valve, op, h)
            slips, _ = slip_times(t, mv, min_stuck=0.5)
            rev = reversal_times(t, op)
            stuck = [s - rev[rev < s][-1] for s in slips if np.any(rev < s)]
            rec = Recording.from_arrays(t[::every], mv[::every], op[::every],
                                        MV=mv[::every])
            xc = make("xcorr", **dict(cfg.estimators.xcorr)).estimate(rec, x="OP", y="MV")
            xq = make("xcum", **dict(cfg.estimators.xcum)).estimate(rec, x="OP", y="MV")
            plain, _r = plain_correlation_lag(op[::every], mv[::every],
                                              int(period / 2 / ts))
            rows.append({"valve": case, "co_shape": shape,
                         "plain_corr_lag_s": plain * ts,
                         "stuck_after_reversal_s": float(np.median(stuck)) if stuck
                         else 0.0,
                         "xcorr_delay_s": float(xc.value) * ts,
                         "xcum_delay_s": float(xq.value) * ts,
                         "xcum_flagged": bool(xq.diagnostics["at_edge"]
                                              or xq.diagnostics["unstable"]),
                         "co_skewness": float(skew(op))})
    return pd.DataFrame(rows)


def dead_time_study(cfg: Any, dead_times: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0),
                    segments: tuple[int, ...] = (128, 256)) -> pd.DataFrame:
    """The stiction case with the process dead time θ changed (all else as the paper).

    If the cross-correlation's negative lag is the MV → PV → CO path, it follows θ (and
    so does the slip → CO-reversal time); a valve delay would not. The estimate is taken
    with the paper's ``max_delay`` and with segments shorter (128) and longer (256) than
    the cycle.
    """
    md = int(cfg.estimators.xcorr.max_delay)
    rows = []
    for theta in dead_times:
        kw = {"process__dead_time": theta}
        fine = simulate("stiction", duration=float(cfg.duration), seed=int(cfg.seed),
                        sample_time=0.1, **kw)
        rec = simulate("stiction", duration=float(cfg.duration), seed=int(cfg.seed),
                       sample_time=float(cfg.sample_time), **kw)
        lags = slip_to_reversal(fine.t, fine.OP, fine.MV)
        row: dict[str, Any] = {"dead_time_s": theta,
                               "cycle_period_s": cycle_period(fine.t, fine.MV),
                               "slip_to_reversal_median_s": float(np.median(lags))
                               if lags.size else np.nan}
        for seg in segments:
            xc = make("xcorr", max_delay=md, segsamp=seg).estimate(rec, x="OP", y="MV")
            row[f"xcorr_seg{seg}_delay_s"] = float(xc.value) * rec.Ts
        rows.append(row)
    return pd.DataFrame(rows)


def magnitude_study(cfg: Any, sizes: tuple[float, ...] = (1.0, 2.0, 4.0, 8.0, 15.0, 30.0),
                    j_ratio: float = 600.0 / 1400.0) -> pd.DataFrame:
    """The stiction case with the stiction band S changed (J/S as in Table II).

    Checks the explanation of the non-monotone detection rate against S: the sign of
    the cross-correlation estimate is set by how the limit cycle compares with the
    segment length (section 2), and the cycle's period and the slip→reversal time
    depend on S. Columns: the cycle period, slips per cycle, slip→reversal time, the
    estimate with segments of 128 and 512 samples, and the plain correlation lag.
    """
    v = compose(["case=stiction"]).valve
    valve = PhysicalValve(**{k: x for k, x in v.items() if k != "_target_"})
    rows = []
    for S in sizes:
        Fs, Fc = valve.friction_for(S, j_ratio * S)
        kw = {"valve__Fs": Fs, "valve__Fc": Fc}
        fine = simulate("stiction", duration=float(cfg.duration), seed=int(cfg.seed),
                        sample_time=0.1, **kw)
        rec = simulate("stiction", duration=float(cfg.duration), seed=int(cfg.seed),
                       sample_time=float(cfg.sample_time), **kw)
        period = cycle_period(fine.t, fine.MV)
        lags = slip_to_reversal(fine.t, fine.OP, fine.MV)
        half = int(round((period if np.isfinite(period) else 200.0) / 2 / rec.Ts))
        plain, _r = plain_correlation_lag(rec.OP, rec.MV, max(2, half))
        row: dict[str, Any] = {"S_percent": S, "cycle_period_s": period,
                               "slips": int(slip_times(fine.t, fine.MV)[0].size),
                               "slip_to_reversal_median_s": float(np.median(lags))
                               if lags.size else np.nan,
                               "plain_corr_lag_s": plain * rec.Ts}
        for seg in (128, 512):
            xc = make("xcorr", max_delay=int(cfg.estimators.xcorr.max_delay),
                      segsamp=seg).estimate(rec, x="OP", y="MV")
            row[f"xcorr_seg{seg}_delay_s"] = float(xc.value) * rec.Ts
        rows.append(row)
    return pd.DataFrame(rows)
