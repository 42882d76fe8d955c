"""Does a fast loop hide a sticky valve from the model-free diagnosis? Vary τ in samples.

``reports/diagnose/isdb/summary.md`` explains part of the ISDB shortfall by the loops'
speed: real flow loops have a time constant of a few historian samples, so most of what
the valve does between two samples is invisible. This experiment checks that explanation
by varying the parameter it depends on, the process time constant in historian samples
``τ/Ts``, everything else held: simulated regulatory loops (constant set point, a
random-walk load, white measurement noise on PV, the PI executing every 0.2 s and the
historian every 1 s, MV withheld) with a two-parameter stiction valve (Kano et al. 2004)
of ``S`` = 2 % or 4 % (``J = S/2``) and with an ideal linear valve (MV = OP). The PI is
retuned for every ``τ`` (SIMC: ``λ = max(θ, τ/2)``), so the loop is the same loop at
another speed. Every
loop is diagnosed twice: *without* a model (``stictionbench diagnose REC.csv``: the
process identified through the valve, as on the ISDB loops) and *with* the true FOPDT
given (``--model``), which separates "the valve is invisible at this speed" from "the
process cannot be identified through the valve at this speed".

Per ``τ/Ts`` and mode: the rate at which stiction is named, the rate at which a sticky
valve of either kind (stiction or dead band) is named, and on the linear-valve loops the
rate at which either is named (false alarms), all with Wilson 95 % intervals, as a table
and a figure. Nothing is tuned here.

Run: ``.venv/bin/python experiments/fast_loops.py [--seeds 6] [--jobs 2]``; writes
``reports/diagnose/fast_loops.md``, ``.csv`` and ``.png``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from tqdm import tqdm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from stictionbench.diagnosis import NominalModel, diagnose  # noqa: E402
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402
from stictionbench.sim import simulate  # noqa: E402

#: process time constants in historian samples (Ts = 1 s)
TAUS = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0)
#: valves: (label, S in % of OP; 0 is the linear valve)
VALVES = (("linear", 0.0), ("stiction S=2", 2.0), ("stiction S=4", 4.0))
DURATION = 3000.0
DEAD_TIME = 1.0
STICKY = ("stiction", "deadband")
#: seconds between the set-point steps of :func:`run_one`'s square wave
SP_STEP_EVERY = 250.0


def simulate_loop(tau: float, S: float, seed: int, load: float = 2.0, *,
                  sp_step: float = 0.0, controller_rate: float = 0.2,
                  noise: float = 0.1) -> tuple[Recording, float, float]:
    """One loop of :func:`run_one` (its arguments), with MV withheld: ``(recording, kc,
    ti)``, the PI tuned by the λ rule with λ = max(θ, τ/2)."""
    lam = max(DEAD_TIME, 0.5 * tau)
    kc, ti = tau / (lam + DEAD_TIME), min(tau, 4 * (lam + DEAD_TIME))
    ov = [f"process.gain={1.0}", f"process.time_constant={tau}",
          f"process.dead_time={DEAD_TIME}", f"controller.kc={kc:.6g}",
          f"controller.ti={ti:.6g}", f"controller.sample_time={controller_rate:g}",
          "sensor=noisy",
          "sensor.time_constant=0.0", f"sensor.noise_std={noise:g}", "disturbance=load",
          f"disturbance.load_std={load}", "disturbance.load_time_constant=300.0",
          "setpoint=constant"]
    if sp_step > 0:
        times = np.arange(SP_STEP_EVERY, DURATION, SP_STEP_EVERY)
        steps = ",".join(f"[{t:g},{sp_step * (1 if i % 2 == 0 else -1):g}]"
                         for i, t in enumerate(times))
        ov.append(f"setpoint.steps=[{steps}]")
    # the "linear" case's default valve is the paper's low-friction physical valve: the
    # ideal valve (MV = OP) instead, or the Kano valve
    ov += ["valve=kano", f"valve.S={S}", f"valve.J={0.5 * S}"] if S > 0 else ["valve=linear"]
    rec = simulate("linear", duration=DURATION, seed=seed, sample_time=1.0, overrides=ov)
    return Recording.from_arrays(rec.t, rec.PV, rec.OP, SP=rec.SP, warn=False), kc, ti


def run_one(tau: float, valve: str, S: float, seed: int, load: float = 2.0, *,
            sp_step: float = 0.0, controller_rate: float = 0.2, given: bool = True,
            noise: float = 0.1) -> dict:
    """Simulate one loop (load rms ``load`` PV units) and diagnose it without a model
    (and, when ``given``, with the true FOPDT). ``sp_step`` > 0 adds a set-point square
    wave of that amplitude (PV units, a step every :data:`SP_STEP_EVERY` seconds);
    ``controller_rate`` is the PI's execution period in seconds; ``noise`` the standard
    deviation of the white PV measurement noise."""
    rec, kc, ti = simulate_loop(tau, S, seed, load, sp_step=sp_step,
                                controller_rate=controller_rate, noise=noise)
    t0 = time.perf_counter()
    free = diagnose(rec)
    seconds = time.perf_counter() - t0
    with_model = diagnose(rec, NominalModel(1.0, tau, DEAD_TIME, kc, ti, 1.0)) if given \
        else None
    ham = free.details.get("hammerstein") or {}
    return {"tau_samples": tau, "valve": valve, "S": S, "seed": seed, "load": load,
            "diagnosis": free.missing_physics,
            "diagnosis_model_given": with_model.missing_physics if given else None,
            "seconds": round(seconds, 2), "fitted_S": ham.get("S"), "fitted_J": ham.get("J"),
            "identified_tau_s": free.model.time_constant,
            "identified_theta_s": free.model.dead_time, "op_std": float(np.std(rec.OP)),
            "identified_gain": free.model.gain,
            "setpoint_excitation": free.details["setpoint_excitation"]}


MODES = (("model-free", "diagnosis"), ("model given", "diagnosis_model_given"))


def _rate(sub: pd.DataFrame, col: str, names: tuple[str, ...]) -> tuple[int, int]:
    return int(sub[col].isin(names).sum()), len(sub)


def summarise(df: pd.DataFrame) -> pd.DataFrame:
    """Rates per loop speed, valve and mode."""
    rows = []
    for (tau, valve), sub in df.groupby(["tau_samples", "valve"], sort=True):
        for mode, col in MODES:
            row = {"tau/Ts": tau, "valve": valve, "mode": mode, "loops": len(sub)}
            for label, names in (("stiction named", ("stiction",)),
                                 ("sticky valve named", STICKY)):
                k, n = _rate(sub, col, names)
                row[label] = rate_text(k, n)
                row[f"{label} rate"] = k / n
            row["answers"] = ", ".join(f"{a} {c}" for a, c in
                                       sub[col].value_counts().sort_index().items())
            rows.append(row)
    return pd.DataFrame(rows)


def findings(df: pd.DataFrame) -> list[str]:
    """The explanation's check in words, every number computed here: sticky valves
    found on fast (τ ≤ 2 samples) against slow (τ ≥ 8 samples) loops, in both modes."""
    st = df[df["S"] > 0]
    out = []
    for mode, col in MODES:
        parts = []
        for label, sel in (("τ ≤ 2 samples", st["tau_samples"] <= 2),
                           ("τ ≥ 8 samples", st["tau_samples"] >= 8)):
            k, n = _rate(st[sel], col, STICKY)
            parts.append(f"{label}: {rate_text(k, n)}")
        lin = df[df["S"] == 0]
        k, n = _rate(lin, col, STICKY)
        k_any = int((lin[col] != "none").sum())
        out.append(f"- {mode}: sticky valve named on {'; '.join(parts)}; ideal valves "
                   f"called sticky {rate_text(k, n)}, any physics named on them "
                   f"{rate_text(k_any, n)}.")
    slow = df["tau_samples"] >= 8
    theta = {k: df[slow & sel]["identified_theta_s"].median()
             for k, sel in (("stiction", df["S"] > 0), ("linear", df["S"] == 0))}
    out.append(f"- the FOPDT identified from OP → PV on the slow loops (τ ≥ 8 samples): "
               f"median dead time {theta['stiction']:.1f} s with the stiction valves and "
               f"{theta['linear']:.1f} s with the ideal valve, against the true "
               f"{DEAD_TIME:g} s.")
    return out


def figure(tab: pd.DataFrame, out: Path) -> None:
    fig, axes = new_figure(1, 2, figsize=(11, 4), sharey=True)
    for ax, (mode, _) in zip(axes, MODES, strict=True):
        for valve, sub in tab[tab["mode"] == mode].groupby("valve", sort=False):
            style = "--" if valve == "linear" else "-"
            ax.plot(sub["tau/Ts"], sub["sticky valve named rate"], style, marker="o",
                    label=f"{valve}: stiction or dead band named")
            if valve != "linear":
                ax.plot(sub["tau/Ts"], sub["stiction named rate"], ":", marker="s",
                        label=f"{valve}: stiction named")
        ax.set_xscale("log", base=2)
        ax.set_xlabel("process time constant τ / historian sample Ts")
        ax.set_ylim(-0.03, 1.03)
        ax.grid(alpha=0.3)
        ax.set_title(mode)
    axes[0].set_ylabel("rate")
    axes[1].legend(fontsize=7)
    save_png(fig, out, dpi=110)


def parse_args(prog: str, doc: str, argv, seeds: int,
               out: Path = ROOT / "reports" / "diagnose") -> argparse.Namespace | None:
    """``--seeds``, ``--jobs`` and ``--out`` (default ``out``) of a simulated-loop
    experiment; None (after a one-line message) when a count is below 1."""
    ap = argparse.ArgumentParser(prog=prog, description=doc.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=seeds)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(out))
    a = ap.parse_args(argv)
    if a.seeds < 1 or a.jobs < 1:
        print(f"{prog}: --seeds and --jobs must be ≥ 1", file=sys.stderr)
        return None
    return a


def run_loops(fn, jobs: list[tuple], n_jobs: int, desc: str) -> list[dict]:
    """``fn(*job)`` for every job on ``n_jobs`` workers, the bar moving as loops finish."""
    res = Parallel(n_jobs=n_jobs, return_as="generator_unordered")(
        delayed(fn)(*j) for j in jobs)
    return list(tqdm(res, total=len(jobs), desc=desc, unit="loop"))


def main(argv=None) -> int:
    a = parse_args("fast_loops", __doc__, argv, seeds=6)
    if a is None:
        return 2
    jobs = [(tau, v, S, seed) for tau in TAUS for v, S in VALVES for seed in range(a.seeds)]
    t0 = time.perf_counter()
    rows = run_loops(run_one, jobs, a.jobs, "fast loops")
    df = pd.DataFrame(rows).sort_values(["tau_samples", "S", "seed"]).reset_index(drop=True)
    df = df.round(6)
    tab = summarise(df)
    out = Path(a.out)
    figure(tab, out / "fast_loops.png")
    shown = tab.drop(columns=["stiction named rate", "sticky valve named rate"])
    lines = [
        "# Sticky valves against loop speed, with and without the model", "",
        "Generated by `experiments/fast_loops.py`: the check of the ISDB explanation "
        "\"real flow loops are fast (τ of a few samples)\" given by earlier versions of "
        "`reports/diagnose/isdb/summary.md`. Simulated regulatory loops "
        f"(Ts = 1 s, PI every 0.2 s, θ = {DEAD_TIME:g} s, SIMC-retuned for each τ, "
        "random-walk load, white PV noise, MV withheld), Kano stiction valves with "
        f"J = S/2 and linear valves, {a.seeds} seeds each, each diagnosed without a model "
        "and with the true FOPDT given. "
        "Rates with Wilson 95 % intervals; nothing tuned.", "",
        *findings(df), "",
        "What this says about the explanation: given the true model, the diagnosis names "
        "the sticky valve on most slow loops too (second line), identified through the "
        "valve rarely (first line); so the loop's speed alone does not hide the valve (the "
        "smaller valve on the slowest loops is partly missed even with the model). What "
        "fails is the identification: with no set-point steps the "
        "controller output is the loop's answer to the unmeasured load, and a FOPDT fitted "
        "from OP to PV on such closed-loop data is biased (Ljung 1999, ch. 13: without an "
        "external excitation the direct method needs a noise model of the load and enough "
        "excitation, which the stick-slip itself supplies only on fast loops). The valve "
        "hypotheses are then fitted on a wrong process.", "",
        "![rates](fast_loops.png)", "",
        to_markdown(shown), "",
        f"{len(df)} loops, each diagnosed twice.", ""]
    write_text(out / "fast_loops.md", "\n".join(lines))
    write_text(out / "fast_loops.csv",
               df.drop(columns="seconds").to_csv(index=False, lineterminator="\n"))
    print("\n".join(findings(df)))
    print(f"{len(df)} loops in {time.perf_counter() - t0:.0f} s (median "
          f"{df['seconds'].median():.2f} s per model-free diagnosis)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
