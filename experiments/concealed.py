"""Concealed-data benchmark for ``stictionbench diagnose`` (issue 6).

Generates closed-loop recordings for every class of the vocabulary at two levels, writes
each as a CSV with only ``t, SP, PV, OP`` plus the user's nominal-model YAML, and runs
the diagnosis blind on them (the same code path as ``stictionbench diagnose``).

- level 1: moderate effects, small PV noise;
- level 2: concealed — MV not recorded, PV noise and an unmeasured slow load, the effect
  small against both;
- randomised plant (K, τ, θ), SIMC tuning with a random closed-loop time constant, random
  set-point steps, explicit seeds.

How the generator differs from the fitter (so the test is not circular): recordings come
from the closed-loop simulator (:mod:`stictionbench.sim`): PI executed every second,
valve and process advanced in 0.01 s sub-steps, stiction from Choudhury's *physical*
force-balance valve integrated exactly between stick/slip events (S and J are its
quasi-static equivalents), deadband from the play operator of the simulator, sensor lag
and dead time inside the loop. The fitter replays the recorded OP open loop at the
recording's sample time through its own discrete models (:mod:`stictionbench.diagnosis.
openloop`: lfilter FOPDT, a Kano-type two-parameter valve), never calling the simulator.

Run: ``.venv/bin/python experiments/concealed.py [--seeds N] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from stictionbench.diagnosis import VOCABULARY, diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording, write_text  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402
from stictionbench.sim import simulate  # noqa: E402
from stictionbench.sim.valves import PhysicalValve  # noqa: E402

DURATION = 3000.0
TS = 1.0
PHYS = PhysicalValve()


def physical_friction(S: float, J: float) -> tuple[float, float]:
    """Fs, Fc (N) of the physical valve whose quasi-static S, J (% of span) are given."""
    span = PHYS.travel_span
    a = S / 100 * span * PHYS.spring
    b = J / 100 * span * PHYS.spring
    return 0.5 * (a + b), 0.5 * (a - b)


def make_case(cls: str, level: int, seed: int) -> tuple[dict, list[str], dict]:
    """Plant, overrides for the simulator and the truth, for one recording."""
    rng = np.random.default_rng([level, seed, VOCABULARY.index(cls)])
    K = rng.uniform(0.5, 3.0)
    tau = rng.uniform(5.0, 40.0)
    theta = rng.uniform(1.0, 12.0)
    lam = theta * rng.uniform(0.8, 2.0)
    kc = tau / (K * (lam + theta))
    ti = min(tau, 4 * (lam + theta))
    # set-point steps: random times and sizes, in PV units ~ a few % of OP through K
    t, steps = 20.0, []
    while t < DURATION - 100:
        steps.append([round(t, 1), round(float(rng.choice([-1, 1]) * K * rng.uniform(2, 6)), 3)])
        t += rng.uniform(150, 400)
    noise = (0.02 if level == 1 else 0.08) * K * 3
    ov = {
        "process.gain": K, "process.time_constant": tau, "process.dead_time": theta,
        "controller.kc": kc, "controller.ti": ti, "controller.sample_time": 1.0,
        "sensor": "noisy", "sensor.time_constant": 0.0, "sensor.noise_std": noise,
        "valve": "linear", "disturbance": "none",
    }
    if level == 2:
        ov.update({"disturbance": "load", "disturbance.load_std": 1.0 * K,
                   "disturbance.load_time_constant": float(rng.uniform(300, 800))})
    truth: dict = {}
    small = level == 2
    if cls == "stiction":
        S = rng.uniform(0.8, 2.0) if small else rng.uniform(2.0, 6.0)
        J = S * rng.uniform(0.3, 0.9)
        Fs, Fc = physical_friction(S, J)
        ov.update({"valve": "physical", "valve.Fs": Fs, "valve.Fc": Fc})
        truth = {"S": S, "J": J}
    elif cls == "deadband":
        d = rng.uniform(0.8, 2.0) if small else rng.uniform(2.0, 5.0)
        ov.update({"valve": "deadband", "valve.deadband": d})
        truth = {"deadband": d}
    elif cls == "sensor_lag":
        tl = tau * (rng.uniform(0.3, 0.6) if small else rng.uniform(0.6, 1.2))
        ov.update({"sensor.time_constant": tl})
        truth = {"time_constant": tl}
    elif cls == "dead_time":
        extra = theta * (rng.uniform(0.4, 0.7) if small else rng.uniform(0.8, 1.5)) + 2.0
        ov["process.dead_time"] = theta + extra
        truth = {"dead_time": theta + extra}
    elif cls == "valve_characteristic":
        R = rng.uniform(8, 20) if small else rng.uniform(20, 50)
        ov.update({"valve": "linear", "valve.characteristic": "equal_percentage",
                   "valve.rangeability": R})
        truth = {"rangeability": R}
    elif cls == "saturation":
        truth = {"quantile": 0.85 if small else 0.75}
    elif cls == "oscillatory_disturbance":
        period = rng.uniform(3, 8) * (tau + theta)
        period = min(period, 300.0)
        amp = K * (rng.uniform(0.5, 1.0) if small else rng.uniform(1.0, 2.5))
        if level == 2:
            ov.update({"disturbance.amplitude": amp, "disturbance.period": period})
        else:
            ov.update({"disturbance": "sinusoidal", "disturbance.amplitude": amp,
                       "disturbance.period": period})
        truth = {"period": period, "amplitude": amp}
    plant = {"gain": K, "time_constant": tau, "dead_time": theta, "kc": kc, "ti": ti}
    strs = [f"{k}={v}" for k, v in ov.items()]
    strs.append("setpoint=constant")
    strs.append("setpoint.steps=[" + ",".join(f"[{a},{b}]" for a, b in steps) + "]")
    return plant, strs, truth


def generate(cls: str, level: int, seed: int, out: Path) -> dict:
    plant, ov, truth = make_case(cls, level, seed)
    sim_seed = 1000 * level + seed
    if cls == "saturation":
        base = simulate("linear", duration=DURATION, seed=sim_seed, sample_time=TS,
                        overrides=ov)
        hi = float(np.quantile(base.OP, truth.pop("quantile")))
        ov = ov + [f"valve.travel_high={hi}"]
        truth["op_high"] = hi
    rec = simulate("linear", duration=DURATION, seed=sim_seed, sample_time=TS, overrides=ov)
    name = f"L{level}_{cls}_{seed:02d}"
    csv = out / f"{name}.csv"
    frame = rec.to_frame()[["t", "SP", "PV", "OP"]]  # MV is never given to the fitter
    frame.to_csv(csv, index=False)
    model = out / f"{name}.yaml"
    model.write_text(
        f"process: {{gain: {plant['gain']:.6g}, time_constant: {plant['time_constant']:.6g}, "
        f"dead_time: {plant['dead_time']:.6g}}}\n"
        f"controller: {{kc: {plant['kc']:.6g}, ti: {plant['ti']:.6g}}}\nsample_time: {TS}\n")
    return {"name": name, "class": cls, "level": level, "seed": seed, "csv": str(csv),
            "model": str(model), "truth": truth}


def run_one(job: dict) -> dict:
    t0 = time.perf_counter()
    rec = read_recording(job["csv"], warn=False)
    d = diagnose(rec, load_model(job["model"]))
    el = time.perf_counter() - t0
    f = d.fit
    return {"name": job["name"], "class": job["class"], "level": job["level"],
            "seed": job["seed"], "predicted": d.missing_physics,
            "correct": d.missing_physics == job["class"],
            "nrmse_nominal": f["nominal"], "nrmse_improved": f["improved"],
            "improvement": 1 - f["improved"] / f["nominal"] if f["nominal"] else 0.0,
            "truth": json.dumps(job["truth"]), "fitted": json.dumps(d.parameters),
            "seconds": el}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "reports" / "concealed"))
    a = ap.parse_args(argv)
    from joblib import Parallel, delayed
    from tqdm import tqdm

    out = Path(a.out)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmpd = Path(tmp)
        jobs = [generate(c, lvl, s, tmpd) for lvl in (1, 2) for c in VOCABULARY
                for s in range(a.seeds)]
        rows = Parallel(n_jobs=a.jobs)(delayed(run_one)(j) for j in tqdm(jobs, desc="diagnose"))
    df = pd.DataFrame(rows)
    write_text(out / "parameters.csv", df.to_csv(index=False, lineterminator="\n"))
    conf = pd.crosstab([df["level"], df["class"]], df["predicted"]).reindex(
        columns=list(VOCABULARY), fill_value=0)
    write_text(out / "confusion.csv", conf.to_csv(lineterminator="\n"))
    fig, axs = new_figure(1, 2, figsize=(14, 5.5))
    for ax, lvl in zip(axs, (1, 2), strict=True):
        m = pd.crosstab(df[df.level == lvl]["class"], df[df.level == lvl]["predicted"]).reindex(
            index=list(VOCABULARY), columns=list(VOCABULARY), fill_value=0)
        ax.imshow(m.to_numpy(), cmap="Blues")
        for i in range(m.shape[0]):
            for j in range(m.shape[1]):
                if m.iat[i, j]:
                    ax.text(j, i, m.iat[i, j], ha="center", va="center", fontsize=8)
        ax.set_xticks(range(len(VOCABULARY)), VOCABULARY, rotation=60, ha="right")
        ax.set_yticks(range(len(VOCABULARY)), VOCABULARY)
        acc = df[df.level == lvl]["correct"].mean()
        ax.set(xlabel="diagnosed", ylabel="true", title=f"level {lvl}: {acc:.0%} named correctly")
    save_png(fig, out / "confusion.png")
    # goals
    lines = ["# Concealed-data benchmark", "",
             f"{len(df)} recordings ({a.seeds} seeds × {len(VOCABULARY)} classes × 2 levels), "
             f"{DURATION:.0f} s at {TS:g} s; generated by `experiments/concealed.py` "
             "(see its docstring for how the generator differs from the fitter).", ""]
    for lvl in (1, 2):
        g = df[df.level == lvl]
        acc = g["correct"].mean()
        lines.append(f"- level {lvl}: **{acc:.0%}** named correctly "
                     f"(goal {'≥ 90 %' if lvl == 1 else '≥ 75 %'}).")
    none1 = df[(df.level == 1) & (df["class"] == "none")]
    lines.append(f"- level 1 `none` called physics: {int((~none1.correct).sum())} of "
                 f"{len(none1)} (goal 0).")
    good = df[df.correct & (df["class"] != "none")]
    lines.append(f"- correctly named cases improving validation NRMSE by ≥ 20 %: "
                 f"{(good.improvement >= 0.2).mean():.0%} (goal 100 %; median improvement "
                 f"{good.improvement.median():.0%}).")
    st = df[(df.level == 1) & (df["class"] == "stiction") & df.correct]
    if len(st):
        err = [abs(json.loads(f)["S"] / json.loads(t)["S"] - 1)
               for f, t in zip(st.fitted, st.truth, strict=True)]
        lines.append(f"- level-1 stiction S within 25 % of the truth: "
                     f"{np.mean(np.array(err) <= 0.25):.0%} (median error {np.median(err):.0%}).")
    lines.append(f"- time per recording: median {df.seconds.median():.1f} s, max "
                 f"{df.seconds.max():.1f} s (diagnose only); total wall "
                 f"{time.perf_counter() - t0:.0f} s with {a.jobs} workers.")
    lines += ["", "## Accuracy per class", ""]
    per = df.groupby(["level", "class"])["correct"].mean().unstack(0)
    per.columns = [f"level {c}" for c in per.columns]
    lines.append(to_markdown(per.reset_index()))
    lines += ["", "## Confusion (rows: true class, columns: diagnosed)", "",
              to_markdown(conf.reset_index()), "", "![confusion](confusion.png)", ""]
    write_text(out / "summary.md", "\n".join(lines))
    print("\n".join(lines[:12]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
