"""Healthy loops called faulty, against the loop's speed: checked by varying the speed
alone, and then the load and the record length that might explain it.

The holdout family's seed blocks call a few ``none`` recordings physics, and those few
are slow loops: over the blocks 1000-13000 (``holdout_family.SEEN_FRESH``), the ``none``
recordings whose drawn time constant exceeded 30 s were called physics several times as
often as the faster ones. Here the loop's speed is varied alone, then the two causes that
were on the table: the integrated random-walk load, whose slow swings sit in a slow
loop's band (the high-pass corner ``0.3/(2π(τ+θ))`` follows the loop down), and the few
independent in-band samples a slow loop leaves in a 3000 s record, over which a 10 %
NRMSE improvement comes by chance.

Design (nothing tuned here): ``none`` recordings of the holdout family
(``experiments/holdout_family.py``: its own loop code, PI in step with the 1 s historian,
white noise and an integrated random-walk load at the issue's two levels), seeds from
:data:`FIRST_SEED` (a block no other experiment draws), :data:`SEEDS` per level. Each drawn
loop is slowed or sped up to each time constant of :data:`TAUS`, its dead time and
closed-loop time constant scaled with it (the drawn ``θ/τ`` and ``λ/τ`` kept, ``θ`` at
least 1 s; lambda tuning ``kc = τ/(K(λ + θ))``, ``ti = τ``), everything else as drawn,
and diagnosed against its true model as a user would. Three conditions:

- **as drawn**: 3000 s, noise and load as drawn;
- **no load**: the load's spread set to 0, noise the same;
- **three times longer**: 9000 s (set-point steps continuing by the family's rule),
  noise and load as drawn. (Until the loops were moved by
  :func:`holdout_family.at_speed`, the longer record drew its noise level and load
  again after its longer set-point schedule: the same distribution, not the same loop.
  The report was regenerated when that was fixed.)

If the load explains the false alarms, they fall without it; if the record's in-band
samples do, they fall with the longer record. Reported: ``none`` called physics by time
constant and condition (Wilson 95 %) with the NRMSE gate as set (each diagnosis
re-decided from its evidence) and with the shipped gate, which grows where the band
holds few samples (:func:`stictionbench.diagnosis.evidence.scaled_gate`, its reference
read off this experiment), what was named, and the in-band degrees of freedom
of the validation blocks (``2 · n_val · Ts · (f_lp − f_hp)``, the independent samples
a band of that width holds).

Run: ``.venv/bin/python experiments/slow_loops.py [--seeds 24] [--jobs 2]``; writes
``reports/concealed/slow_loops.md``, ``slow_loops.csv`` and ``slow_loops.png``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import fresh_recordings as fresh  # noqa: E402
import holdout_family as hf  # noqa: E402
from concealed import decide, run_one, write_job  # noqa: E402
from concealed_families import DURATION  # noqa: E402

from stictionbench.diagnosis.evidence import ALPHA, MIN_IMPROVEMENT  # noqa: E402
from stictionbench.diagnosis.evidence import BAND_DOF as SHIPPED_BAND_DOF  # noqa: E402
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text, wilson  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import csv_text, to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
TAUS = (3.0, 10.0, 30.0, 60.0, 120.0)
FIRST_SEED = 20000
SEEDS = 24
#: in-band degrees of freedom the report splits the recordings at
BAND_DOF = int(SHIPPED_BAND_DOF)
#: condition -> (record length in s, the load's spread scaled by)
CONDITIONS = {"as drawn": (DURATION, 1.0), "no load": (DURATION, 0.0),
              "three times longer": (3 * DURATION, 1.0)}


def scaled_recording(level: int, seed: int, tau: float, duration: float,
                     load_scale: float):
    """The holdout family's ``none`` case at ``seed`` moved to time constant ``tau``
    (:func:`holdout_family.at_speed`); returns ``(case, signals)``."""
    return hf.at_speed("none", level, seed, tau, duration, load_scale)


def jobs(seeds: int, out: Path) -> list[dict]:
    """Every (condition, time constant, level, seed) written as a recording and model."""
    todo = []
    for cond, (duration, load_scale) in CONDITIONS.items():
        for tau in TAUS:
            sub = out / f"{cond.replace(' ', '_')}_{tau:g}"
            sub.mkdir(parents=True, exist_ok=True)
            for level in (1, 2):
                for seed in range(FIRST_SEED, FIRST_SEED + seeds):
                    c, sig = scaled_recording(level, seed, tau, duration, load_scale)
                    todo.append(write_job(c, sig, sub) | {
                        "condition": cond, "tau": tau, "theta": c.theta})
    return todo


def run(job: dict) -> dict:
    """One healthy loop diagnosed against its true model (``pick``, the shipped verdict)
    and re-decided from its stored evidence with the NRMSE gate as set, unscaled by the
    band's degrees of freedom (``pick_unscaled``: the rule before
    :func:`stictionbench.diagnosis.evidence.scaled_gate`)."""
    row = pd.Series(run_one(job))
    named = next((r for r in json.loads(row["evidence"])
                  if r["physics"] == row["predicted_default"]), {})
    return {k: job[k] for k in ("condition", "tau", "theta", "level", "seed")} | {
        "pick": row["predicted_default"],
        "pick_unscaled": decide(row.drop("band_dof"), ALPHA, MIN_IMPROVEMENT),
        "p_value": named.get("p_value"), "improvement": named.get("improvement"),
        "band_dof": row["band_dof"], "seconds": row["seconds"]}


def rates(df: pd.DataFrame) -> pd.DataFrame:
    """``none`` called physics by condition and time constant, levels apart and pooled."""
    rows = []
    for (cond, tau), g in df.groupby(["condition", "tau"], sort=False):
        row = {"condition": cond, "tau_s": tau,
               "band_dof_median": round(float(g.band_dof.median()), 1)}
        for level in (1, 2):
            gl = g[g.level == level]
            row[f"level {level}"] = rate_text(int((gl.pick != "none").sum()), len(gl))
        row["both levels"] = rate_text(int((g.pick != "none").sum()), len(g))
        row["both levels, gate unscaled"] = rate_text(int((g.pick_unscaled != "none").sum()),
                                                      len(g))
        named = g.pick[g.pick != "none"].value_counts()
        row["named"] = ", ".join(f"{k} {v}" for k, v in named.items()) or "–"
        rows.append(row)
    return pd.DataFrame(rows)


def figure(df: pd.DataFrame, path: Path) -> Path:
    fig, ax = new_figure(1, 1, figsize=(6.4, 3.6))
    for (cond, g), style in zip(df.groupby("condition", sort=False), ("o-", "s--", "^:"),
                                strict=True):
        by = (g.pick_unscaled != "none").groupby(g.tau)
        k, n = by.sum(), by.size()
        rate = (k / n).to_numpy()
        lo, hi = np.array([wilson(int(a), int(b)) for a, b in zip(k, n, strict=True)]).T
        x = k.index.to_numpy() * {"as drawn": 1.0, "no load": 0.93,
                                  "three times longer": 1.07}[cond]
        ax.errorbar(x, rate, yerr=[rate - lo, hi - rate], fmt=style, capsize=3,
                    label=f"{cond} (gate as set)")
    g = df[df.condition == "as drawn"]
    shipped = (g.pick != "none").groupby(g.tau).mean()
    ax.plot(shipped.index, shipped.to_numpy(), "kx-", lw=0.8,
            label="as drawn, the shipped gate (scaled)")
    ax.axhline(0.05, color="grey", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_xticks(TAUS, [f"{t:g}" for t in TAUS])
    ax.minorticks_off()
    ax.set_xlabel("process time constant τ (s), sampled every 1 s")
    ax.set_ylabel("healthy loops called faulty (Wilson 95 %)")
    ax.legend(loc="upper left")
    return save_png(fig, path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=SEEDS, help="healthy loops per level")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if a.seeds < 1:
        print("slow_loops: --seeds must be at least 1", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        df = fresh.run(run, [(j,) for j in jobs(a.seeds, Path(tmp))], a.jobs)
    df = df.sort_values(["condition", "tau", "level", "seed"], kind="stable")
    df = df.round({"p_value": 6, "improvement": 6, "band_dof": 3})
    write_text(OUT / "slow_loops.csv", csv_text(df.drop(columns="seconds")))
    figure(df, OUT / "slow_loops.png")
    tab = rates(df)
    def called(g: pd.DataFrame, col: str = "pick_unscaled") -> str:
        return rate_text(int((g[col] != "none").sum()), len(g))

    def gated(g: pd.DataFrame, col: str = "pick_unscaled") -> str:
        # what the gate governs: `saturation` here is OP held at its limit, named from
        # OP after the comparison named nothing (diagnosis.op_limit), not through the gate
        return rate_text(int((~g[col].isin(["none", "saturation"])).sum()), len(g))

    slow = df[df.tau >= 30]
    by_cond = "; ".join(f"{cond}: {called(g)}" for cond, g in slow.groupby("condition",
                                                                           sort=False))
    base = df[df.condition == "as drawn"]
    few = df.band_dof < BAND_DOF
    lines = [
        "# Healthy loops called faulty, against the loop's speed", "",
        "Generated by `experiments/slow_loops.py` (the design is in its docstring): "
        f"`none` recordings of the holdout family, seeds {FIRST_SEED}–"
        f"{FIRST_SEED + a.seeds - 1} per level, each loop moved to every time constant "
        "with its dead time and closed-loop speed scaled alike, diagnosed against its true "
        "model; Wilson 95 % intervals; nothing tuned here.", "",
        "![slow loops](slow_loops.png)", "", to_markdown(tab), "",
        f"- as drawn, called physics at τ ≤ 10 s: {called(base[base.tau <= 10])}; at "
        f"τ ≥ 30 s: {called(base[base.tau >= 30])};",
        f"- τ ≥ 30 s under each condition: {by_cond};",
        f"- all conditions, by the validation blocks' in-band degrees of freedom "
        f"(`band_dof`: `2 · n_val · Ts · (f_lp − f_hp)`, the independent samples a band "
        f"of that width holds; the 10 % NRMSE gate is an effect size measured on it): "
        f"under {BAND_DOF} {called(df[few])}, {BAND_DOF} or more {called(df[~few])}; "
        f"leaving out `saturation` (OP held at its limit, named from OP, not through the "
        f"gate): under {BAND_DOF} {gated(df[few])}, {BAND_DOF} or more {gated(df[~few])};",
        f"- these rates are the gate's as set (`gate unscaled`); the shipped rule scales "
        f"it by the band's degrees of freedom below {BAND_DOF:g} "
        f"(`evidence.scaled_gate`, whose reference was read off this report): called "
        f"physics under {BAND_DOF} {called(df[few], 'pick')}, {BAND_DOF} or more "
        f"{called(df[~few], 'pick')}.",
        "- of the shipped calls, `saturation` (the loop's OP held at 0 or 100 % by the "
        "random-walk load, named by the OP-hold check, `diagnosis.op_limit`; no healthy "
        "loop here was called saturation before it): "
        + "; ".join(f"{cond} {rate_text(int((g['pick'] == 'saturation').sum()), len(g))}"
                    for cond, g in df.groupby("condition", sort=False)) + ".", "",
        "Reading: if the slow load explained the false alarms they would fall without "
        "it; if the few in-band samples of a slow loop's record did, they would fall with "
        "the longer record. The rows above say which; where neither condition brings the "
        "rate down, the cause is open.", ""]
    write_text(OUT / "slow_loops.md", "\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
