"""The second look for a slow external line: checked by varying the line's period against
the main band's high-pass, and by where it is allowed to name the line.

``diagnose`` compares every hypothesis in one band whose 2nd-order slow-load high-pass sits
at ``0.3/(2π(τ+θ))`` (:data:`stictionbench.diagnosis.hammerstein.HP_FACTOR`). A line
slower than that corner keeps ``(f/f_hp)²`` of its amplitude there, and the prediction-
error noise model fitted to what the band leaves treats its frequencies as load; past
twice the corner period it is not searched at all. Against a given model, where the main
band names nothing, :func:`stictionbench.diagnosis.diagnose.second_look` fits the
oscillatory disturbance again with a third of that high-pass and names it when its period
is slower than the main band's corner and it passes its gates there
(:func:`stictionbench.diagnosis.evidence.slow_line_named`).

Two checks, nothing tuned here:

1. **The period, varied alone.** Oscillatory-disturbance recordings of the holdout family
   (``experiments/holdout_family.py``: its own loop code, PI in step with the historian,
   noise and an integrated random-walk load at the issue's two levels), seeds from 7000
   (a block no other experiment draws), the loops whose four-corner period fits in half
   the record; each loop simulated with its line's period set to ``ratio`` × the main
   band's corner period, everything else the same. Named rate of the main band alone and
   with the second look, by ratio and level. If the explanation holds, the main band
   loses the line as the ratio grows past 1 and the look recovers it there; below 1 the
   look never runs on a line the main band names.
2. **Where the look may name the line.** On the three tuning families (seeds 0–3, ``none``
   0–11) and the holdout family's seeds 0–3 (``none`` 0–7), every recording's look is
   forced whatever the main band says: *shipped* names the slow line only where the main
   band named nothing; *anywhere* names it wherever it passes, over the main band's
   verdict. In the wider band the slow part of other physics and of the load enters too.
3. **The load, varied alone, on healthy loops.** The look's false alarms were put down to
   the integrated random-walk load leaking into the wider band. Level-2 ``none``
   recordings of the holdout family (seeds from :data:`FIRST_SEED`, and
   ``holdout_sync_L2_none_5000``, the blind block's false alarm), each simulated with the
   load's spread scaled by 0, 1 and 2, the noise and everything else the same; the look
   forced on each: how often its line passes its gates (any period) and how often it
   would be named.

Run: ``.venv/bin/python experiments/slow_line.py [--loops 8] [--jobs 2]``; writes
``reports/concealed/slow_line.md``, ``slow_line.csv`` and ``slow_line.png``.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import fresh_recordings as fresh  # noqa: E402
import holdout_family as hf  # noqa: E402
from concealed import generate, write_job  # noqa: E402
from concealed_families import CLASSES, DURATION, FAMILIES  # noqa: E402

from stictionbench.diagnosis import load_model  # noqa: E402
from stictionbench.diagnosis.diagnose import (  # noqa: E402
    compare,
    fit,
    hypothesise,
    locate,
    second_look,
    validate,
)
from stictionbench.diagnosis.hammerstein import HP_FACTOR  # noqa: E402
from stictionbench.io import read_recording, write_text  # noqa: E402
from stictionbench.rates import rate_text, wilson  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import csv_text, to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
RATIOS = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0)
FIRST_SEED = 7000
LINE = "oscillatory_disturbance"
LOAD_SCALES = (0.0, 1.0, 2.0)
#: the blind holdout block's `none` recording the look called a line
FALSE_ALARM_SEED = 5000


def corner_period(tau: float, theta: float) -> float:
    """The main band's high-pass corner period (s) for a model's ``τ + θ``."""
    return 2 * math.pi * (tau + theta) / HP_FACTOR


def sweep_jobs(loops: int, out: Path) -> list[dict]:
    """The first ``loops`` holdout disturbance loops per level (seeds from
    :data:`FIRST_SEED`) whose largest swept period fits in half the record, each at
    every ratio of :data:`RATIOS`."""
    todo = []
    for level in (1, 2):
        seed, kept = FIRST_SEED, 0
        while kept < loops:
            c = hf.draw(LINE, level, seed)
            corner = corner_period(c.tau, c.theta)
            if max(RATIOS) * corner <= DURATION / 2:
                for ratio in RATIOS:
                    ci = hf.draw(LINE, level, seed)
                    ci.truth["period"] = ratio * corner
                    todo.append(_simulated(ci, level, seed, out, f"r{ratio:g}",
                                           part="period", ratio=ratio,
                                           corner_period_s=corner))
                kept += 1
            seed += 1
    return todo


def _simulated(c, level: int, seed: int, out: Path, sub: str, **extra) -> dict:
    """Case ``c`` simulated with the holdout family's noise seed and written as a job."""
    sig = hf.simulate(c, hf.noise_rng(c))
    (out / sub).mkdir(exist_ok=True)
    return write_job(c, sig, out / sub) | extra


def load_jobs(loops: int, out: Path) -> list[dict]:
    """Level-2 holdout ``none`` loops (:data:`FALSE_ALARM_SEED` and ``loops`` seeds from
    :data:`FIRST_SEED`), each with its load's spread scaled by :data:`LOAD_SCALES`."""
    todo = []
    for seed in (FALSE_ALARM_SEED, *range(FIRST_SEED, FIRST_SEED + loops)):
        for scale in LOAD_SCALES:
            c = hf.draw("none", 2, seed)
            c.load *= scale
            todo.append(_simulated(c, 2, seed, out, f"load{scale:g}", part="load",
                                   load_scale=scale))
    return todo


def where_jobs(out: Path) -> list[dict]:
    """The three tuning families (seeds 0–3, ``none`` 0–11) and the holdout family
    (seeds 0–3, ``none`` 0–7)."""
    todo = [generate(c, lvl, s, out, fam) | {"part": "where"}
            for fam in FAMILIES for lvl in (1, 2) for c in CLASSES
            for s in range(12 if c == "none" else 4)]
    todo += [hf.generate(c, lvl, s, out) | {"part": "where"}
             for lvl in (1, 2) for c in CLASSES for s in range(8 if c == "none" else 4)]
    return todo


def run(job: dict) -> dict:
    """The main band's verdict, the look forced whatever it says, and both ways of
    using the look."""
    rec = read_recording(job["csv"], warn=False)
    cmp = compare(rec, load_model(job["model"]))
    loc = locate(cmp)
    fits, ham = fit(cmp, hypothesise(cmp, loc))
    main = validate(cmp, fits, ham)
    look = second_look(cmp, replace(main, pick="none"))
    passed = bool(look is not None and look.named)
    row = look.to_dict()[LINE] if look is not None else {}
    return {k: job.get(k) for k in ("part", "name", "family", "class", "level", "seed",
                                    "ratio", "corner_period_s", "load_scale")} | {
        "truth_period": job["truth"].get("period"), "main": main.pick,
        "look_period": row.get("parameters", {}).get("period"), "look_passes": passed,
        "look_gates_pass": bool(row.get("significant", False)),
        "look_p": row.get("p_value"), "look_improvement": row.get("improvement"),
        "shipped": main.pick if main.pick != "none" else (LINE if passed else "none"),
        "anywhere": LINE if passed else main.pick}


def sweep_table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (level, ratio), g in df.groupby(["level", "ratio"]):
        rows.append({"level": level, "period / corner": ratio, "loops": len(g),
                     "main band alone": rate_text(int((g.main == LINE).sum()), len(g)),
                     "with the second look (shipped)": rate_text(
                         int((g.shipped == LINE).sum()), len(g)),
                     "named by the look": int(((g.shipped == LINE) & (g.main != LINE)).sum())})
    return pd.DataFrame(rows)


def load_table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for scale, g in df.groupby("load_scale"):
        case = g[g.seed == FALSE_ALARM_SEED].iloc[0]
        rows.append({"load spread × ": scale, "recordings": len(g),
                     "look's line passes its gates (any period)": rate_text(
                         int(g.look_gates_pass.sum()), len(g)),
                     "named (shipped rule)": rate_text(int((g.shipped == LINE).sum()), len(g)),
                     "median look p": f"{g.look_p.median():.2g}",
                     f"seed {FALSE_ALARM_SEED}: p, improvement, verdict": (
                         f"{case.look_p:.2g}, {case.look_improvement:.0%}, {case.shipped}")})
    return pd.DataFrame(rows)


def where_table(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for fam, g in [*df.groupby("family", sort=False), ("all", df)]:
        nn = g["class"] == "none"
        row = {"family": fam, "recordings": len(g)}
        for rule in ("main", "shipped", "anywhere"):
            ok = g[rule] == g["class"]
            row[f"{rule}: named"] = rate_text(int(ok.sum()), len(g))
            row[f"{rule}: none called physics"] = rate_text(int((g[rule][nn] != "none").sum()),
                                                            int(nn.sum()))
        rows.append(row)
    return pd.DataFrame(rows)


def figure(df: pd.DataFrame, path: Path) -> Path:
    fig, axes = new_figure(1, 2, figsize=(9, 3.4), sharey=True)
    for ax, (level, g) in zip(axes, df.groupby("level"), strict=True):
        for col, label, style in (("main", "main band alone", "o--"),
                                  ("shipped", "with the second look", "s-")):
            by = (g[col] == LINE).groupby(g.ratio)
            k, n = by.sum(), by.size()
            rate = (k / n).to_numpy()
            lo, hi = np.array([wilson(int(a), int(b)) for a, b in zip(k, n, strict=True)]).T
            ax.errorbar(k.index, rate, yerr=[rate - lo, hi - rate], fmt=style, capsize=3,
                        label=label)
        ax.axvline(1.0, color="grey", lw=0.8)
        ax.axvline(2.0, color="grey", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_xticks(RATIOS, [f"{r:g}" for r in RATIOS])
        ax.minorticks_off()
        ax.set_xlabel("line period / main band's high-pass corner period")
        ax.set_title(f"level {level}")
    axes[0].set_ylabel("disturbance named (Wilson 95 %)")
    axes[0].legend(loc="lower left")
    return save_png(fig, path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--loops", type=int, default=8, help="disturbance loops per level")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        todo = (sweep_jobs(a.loops, Path(tmp)) + where_jobs(Path(tmp))
                + load_jobs(3 * a.loops, Path(tmp)))
        df = fresh.run(run, [(j,) for j in todo], a.jobs)
    write_text(OUT / "slow_line.csv", csv_text(df))
    sweep, where, load = (df[df.part == p] for p in ("period", "where", "load"))
    figure(sweep, OUT / "slow_line.png")
    text = "\n".join([
        "# The second look for a slow line", "",
        "Generated by `experiments/slow_line.py` (the design is in its docstring); "
        "Wilson 95 % intervals; nothing tuned here.", "",
        "## The line's period against the main band's high-pass", "",
        f"Holdout-family disturbance loops from seed {FIRST_SEED} ({a.loops} per level), "
        "each simulated at every period ratio with all else the same.", "",
        "![slow line](slow_line.png)", "", to_markdown(sweep_table(sweep)), "",
        "## Where the look may name the line", "",
        "The look forced on every recording of the three tuning families and the "
        "holdout family's seeds 0–3: *main*, the main band alone; *shipped*, the line "
        "named only where the main band names nothing; *anywhere*, wherever the look's "
        "line passes.", "", to_markdown(where_table(where)), "",
        "## The load, varied alone, on healthy loops", "",
        f"Level-2 `none` loops of the holdout family ({3 * a.loops} from seed "
        f"{FIRST_SEED}, and seed {FALSE_ALARM_SEED}, the blind block's false alarm), "
        "each with its random-walk load's spread scaled, noise and all else the same; the "
        "look forced on each. If the false alarms come from the load leaking into the "
        "wider band, the look's line passes more often as the load grows and not without "
        "it.", "", to_markdown(load_table(load)), ""])
    write_text(OUT / "slow_line.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
