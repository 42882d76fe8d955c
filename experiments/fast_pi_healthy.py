"""Healthy fast loops called sticky: the PI's rate varied alone, across the loop's speed.

Generator D's healthy loops (``reports/concealed/independent_set_x.md`` and ``_y``) were
called physics in 16 of 48 recordings, three times the rate on generators A and C; the one
read closely was a tightly tuned fast loop whose PI ran four times per historian sample
(``docs/diagnosis.md``, "Sets written by someone else"). A check while writing this script
(the package's simulator, K = 2, θ = 1 s, SIMC tuning with τc = θ, seeds 0–11, not part of
the scored run) put healthy loops with τ = 4 and 8 s under a PI at 0.25 s and at the
historian's 1 s, everything else the same: called physics 12 of 24 against 0 of 24. (A
first try with Ziegler–Nichols tuning was void: at 1 s that loop is unstable and OP swings
between its limits, so it compared nothing.)

This script maps the effect: the same healthy loops (ideal valve, model given, exact) over
τ = 4, 8, 16 and 32 s and the PI every 0.1, 0.25, 0.5 and 1 s, historian 1 s, PV noise 0.1,
a slow load of standard deviation 1, four set-point steps of ±3; seeds 100–111 for every
cell (the same seed gives the same set-point times in every cell). Each recording is
diagnosed with its true model as ``stictionbench diagnose --model`` does. Wilson 95 %
intervals; McNemar's exact test on the loops whose verdict changed between the PI at
0.25 s and at 1 s. Nothing is tuned here.

**Prediction, written before the run**: (1) with the PI at 1 s at most 2 of 12 loops are
called physics in every τ; (2) with the PI at 0.25 s at least 4 of 12 for τ = 4 and 8 s;
(3) the rate at 0.25 s falls as the loop slows (τ = 32 s below τ = 8 s), since the
snapshot's jitter then carries less of PV's motion in the comparison band.

**Part B, added after the first run** (its question came from it, so no prediction): is
the measurement noise the cause? τ = 8 and 16 s, the PI at 0.25 s and at 1 s, with the
noise and the load of part A, a tenth of either, and neither (set-point steps only), the
same seeds. The nominal model's validation NRMSE beside the rates shows what the faster PI
adds to the replay's error.

Run: ``.venv/bin/python experiments/fast_pi_healthy.py [--seeds 12] [--jobs 2]``; writes
``reports/concealed/fast_pi_healthy.md``, ``.csv`` and ``.png``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fast_loops import parse_args, run_loops  # noqa: E402
from fresh_recordings import publish  # noqa: E402

from stictionbench.diagnosis import NominalModel, diagnose  # noqa: E402
from stictionbench.rates import mcnemar_p, rate_text, wilson  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402
from stictionbench.sim import simulate  # noqa: E402

OUT = ROOT / "reports" / "concealed"
TAUS = (4.0, 8.0, 16.0, 32.0)
PI_PERIODS = (0.1, 0.25, 0.5, 1.0)
GAIN, DEAD_TIME, NOISE, LOAD, STEP = 2.0, 1.0, 0.1, 1.0, 3.0
DURATION = 3000.0
FIRST_SEED = 100
STICKY = ("stiction", "deadband")


def simc(tau: float) -> tuple[float, float]:
    """SIMC PI with τc = θ (Skogestad 2003): ``kc = τ/(K(τc + θ))``,
    ``ti = min(τ, 4(τc + θ))``."""
    return tau / (GAIN * 2 * DEAD_TIME), min(tau, 8 * DEAD_TIME)


def loop(tau: float, period: float, seed: int, noise: float = NOISE,
         load: float = LOAD, valve: tuple[str, ...] = ("valve=linear",)) -> Recording:
    """One loop under the PI executed every ``period`` seconds, the historian at 1 s, PV
    noise and load of standard deviations ``noise`` and ``load``; four set-point steps of
    ±:data:`STEP` at times drawn from ``seed``; the valve's overrides ``valve`` (default
    the ideal valve: a healthy loop)."""
    kc, ti = simc(tau)
    rng = np.random.default_rng(seed)
    times = np.sort(rng.choice(np.arange(200, 2800, 50), 4, replace=False))
    steps = ",".join(f"[{t:g},{STEP if i % 2 == 0 else -STEP:g}]" for i, t in enumerate(times))
    ov = [f"process.gain={GAIN}", f"process.time_constant={tau}",
          f"process.dead_time={DEAD_TIME}", f"controller.kc={kc:.6g}",
          f"controller.ti={ti:.6g}", f"controller.sample_time={period:g}", "sensor=noisy",
          "sensor.time_constant=0.0", f"sensor.noise_std={noise:g}", "disturbance=load",
          f"disturbance.load_std={load:g}", "disturbance.load_time_constant=300.0",
          "setpoint=constant", f"setpoint.steps=[{steps}]", *valve]
    r = simulate("linear", duration=DURATION, seed=seed, sample_time=1.0, overrides=ov)
    return Recording.from_arrays(r.t, r.PV, r.OP, SP=r.SP, warn=False)


#: part B: (PV noise, load) variants, at the part's loop speeds and PI periods
NOISE_LOAD = ((NOISE, LOAD), (NOISE / 10, LOAD), (NOISE, LOAD / 10), (0.0, 0.0))
TAUS_B = (8.0, 16.0)
PI_PERIODS_B = (0.25, 1.0)


def _job(tau: float, period: float, seed: int, noise: float = NOISE,
         load: float = LOAD) -> dict:
    rec = loop(tau, period, seed, noise, load)
    kc, ti = simc(tau)
    d = diagnose(rec, NominalModel(GAIN, tau, DEAD_TIME, kc, ti, 1.0))
    return {"tau_s": tau, "pi_period_s": period, "seed": seed, "noise": noise, "load": load,
            "named": d.missing_physics, "nrmse_nominal": d.fit["nominal"],
            "op_step_sd": float(np.std(np.diff(rec.OP)))}


def summarise_b(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (tau, period, noise, load), g in df.groupby(["tau_s", "pi_period_s", "noise", "load"],
                                                    sort=True):
        rows.append({"τ (s)": tau, "PI period (s)": period, "PV noise": noise, "load": load,
                     "called physics": rate_text(int((g["named"] != "none").sum()), len(g)),
                     "named": ", ".join(f"{k} ×{v}" for k, v in
                                        g.loc[g["named"] != "none", "named"]
                                        .value_counts().items()) or "—",
                     "nominal NRMSE (median)": round(float(g["nrmse_nominal"].median()), 4)})
    return pd.DataFrame(rows)


def summarise(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (tau, period), g in df.groupby(["tau_s", "pi_period_s"]):
        rows.append({"τ (s)": tau, "PI period (s)": period, "loops": len(g),
                     "called physics": rate_text(int((g["named"] != "none").sum()), len(g)),
                     "called a sticky valve": rate_text(int(g["named"].isin(STICKY).sum()),
                                                        len(g)),
                     "named": ", ".join(f"{k} ×{v}" for k, v in
                                        g.loc[g["named"] != "none", "named"]
                                        .value_counts().items()) or "—",
                     "nominal NRMSE (median)": round(float(g["nrmse_nominal"].median()), 3),
                     "OP step s.d. (median, %)": round(float(g["op_step_sd"].median()), 3)})
    return pd.DataFrame(rows)


def verdicts(df: pd.DataFrame) -> list[str]:
    """The module docstring's three predictions, and McNemar's test of 0.25 s against 1 s."""
    def called(tau: float, period: float) -> int:
        g = df[(df["tau_s"] == tau) & (df["pi_period_s"] == period)]
        return int((g["named"] != "none").sum())

    n = int(df.groupby(["tau_s", "pi_period_s"]).size().min())
    at1 = {t: called(t, 1.0) for t in TAUS}
    at25 = {t: called(t, 0.25) for t in TAUS}
    ok1 = all(v <= 2 for v in at1.values())
    ok2 = at25[4.0] >= 4 and at25[8.0] >= 4
    ok3 = at25[32.0] < at25[8.0]
    word = {True: "held", False: "failed"}
    a = df[df["pi_period_s"] == 0.25].set_index(["tau_s", "seed"])["named"] != "none"
    b = df[df["pi_period_s"] == 1.0].set_index(["tau_s", "seed"])["named"] != "none"
    only_fast, only_slow = int((a & ~b).sum()), int((~a & b).sum())
    return [
        f"- (1) PI at 1 s, at most 2 of {n} called physics at every τ: **{word[ok1]}** ("
        + ", ".join(f"τ {t:g} s: {v}" for t, v in at1.items()) + ");",
        f"- (2) PI at 0.25 s, at least 4 of {n} at τ = 4 and 8 s: **{word[ok2]}** ("
        f"{at25[4.0]} and {at25[8.0]});",
        f"- (3) at 0.25 s fewer at τ = 32 s than at 8 s: **{word[ok3]}** ({at25[32.0]} "
        f"against {at25[8.0]}).",
        f"- Called physics only with the PI at 0.25 s / only at 1 s: {only_fast} / "
        f"{only_slow} (McNemar p = {mcnemar_p(only_fast, only_slow):.2g}).",
    ]


def figure(df: pd.DataFrame, out: Path) -> None:
    fig, ax = new_figure(figsize=(7.0, 4.2))
    for period in PI_PERIODS:
        ys, lo, hi = [], [], []
        for tau in TAUS:
            g = df[(df["tau_s"] == tau) & (df["pi_period_s"] == period)]
            k, n = int((g["named"] != "none").sum()), len(g)
            p, (a, b) = k / n, wilson(k, n)
            ys.append(p)
            lo.append(p - a)
            hi.append(b - p)
        ax.errorbar(TAUS, ys, yerr=[lo, hi], marker="o", capsize=3,
                    label=f"PI every {period:g} s")
    ax.set_xscale("log")
    ax.set_xticks(TAUS, [f"{t:g}" for t in TAUS])
    ax.set_xlabel("process time constant τ (s); historian 1 s, θ = 1 s")
    ax.set_ylabel("healthy loops called physics")
    ax.set_ylim(-0.02, 1.02)
    ax.legend()
    save_png(fig, out)


def main(argv=None) -> int:
    a = parse_args("fast_pi_healthy.py", __doc__, argv, seeds=12, out=OUT)
    if a is None:
        return 2
    out = Path(a.out)
    seeds = range(FIRST_SEED, FIRST_SEED + a.seeds)
    jobs = [(tau, p, s) for tau in TAUS for p in PI_PERIODS for s in seeds]
    jobs_b = [(tau, p, s, nz, ld) for tau in TAUS_B for p in PI_PERIODS_B
              for nz, ld in NOISE_LOAD[1:] for s in seeds]
    both = pd.DataFrame(run_loops(_job, jobs + jobs_b, a.jobs, "fast PI, healthy loops"))
    both = both.sort_values(["tau_s", "pi_period_s", "noise", "load", "seed"],
                            kind="stable").reset_index(drop=True)
    part_a = (both["noise"] == NOISE) & (both["load"] == LOAD)
    df = both[part_a].reset_index(drop=True)
    b = both[both["tau_s"].isin(TAUS_B) & both["pi_period_s"].isin(PI_PERIODS_B)]
    figure(df, out / "fast_pi_healthy.png")
    lines = [
        "# Healthy fast loops called sticky: the PI's rate varied alone",
        "",
        "Generated by `experiments/fast_pi_healthy.py` (the question, the design and the "
        "prediction, written before the run, are in its docstring). Healthy loops (ideal "
        f"valve), K = {GAIN:g}, θ = {DEAD_TIME:g} s, SIMC PI (τc = θ), PV noise {NOISE:g}, "
        f"slow load {LOAD:g}, four set-point steps of ±{STEP:g}; historian 1 s; seeds "
        f"{FIRST_SEED}–{FIRST_SEED + a.seeds - 1} in every cell; each diagnosed with its "
        "exact model. Wilson 95 % intervals. Nothing is tuned here.",
        "",
        "![healthy loops called physics](fast_pi_healthy.png)",
        "",
        to_markdown(summarise(df)),
        "",
        "## The prediction",
        "",
        *verdicts(df),
        "",
        "## Part B: the noise and the load varied",
        "",
        f"Same loops and seeds; the rows with PV noise {NOISE:g} and load {LOAD:g} are part A's.",
        "",
        to_markdown(summarise_b(b)),
        "",
    ]
    publish(both, "\n".join(lines), out / "fast_pi_healthy", float_format="%.6g",
            echo=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
