"""Is the loop's speed why dead bands are named stiction? The independent sets' level-1
dead-band and stiction loops re-made three times slower, nothing else changed.

Why: ``slip_jump_pi_rate.md`` found that the PI's rate does not change how often a dead
band is named stiction on the same loops. In the sets, though, the confusions sit on slow
loops (generator A: 0 of 21 dead bands with τ ≤ 10 s named stiction, 5 of 23 with
τ > 30 s). The loop's speed was binned there, not varied.

Design (written before the run; nothing here changes the package or sets a threshold):

- loops: every level-1 dead-band and stiction recording of generator C's sets C, E, G, I
  (96) and, added after the first run on generator C alone, of generator A's sets A, B,
  D, F, H (120), so that the reading is checked on the other generator. Generator C
  draws from a stream per purpose, so a change to the loop leaves every other draw as it
  was. Generator A draws from one stream, and its set-point schedule, noise and load are
  sized by the loop's times, so here they come from sub-streams of one draw each; the
  valve's S, J or width stay the same. A pair whose gain-margin screen redrew the loop
  at one speed is dropped;
- the one change: every time of the loop multiplied by 3. That is the process's τ, its
  second lag and dead time (true and nominal), the PI's integral time, and the tuning's
  λ and closed-loop time (generator A: τ, the true and nominal dead times, the integral
  time and λ); the load's time constant follows τ. The gains, the PI's period,
  the record (3000 s at 1 s), the noise and the valve stay. The loop's shape in its own
  time is the same; the record holds a third as many of its time constants and cycles;
- factor 1 is generator C unchanged, and it must reproduce the sets' stored verdicts
  (checked in the report); generator A's factor 1 is its sub-stream remake;
- each recording diagnosed with its model YAML at the package's defaults;
- reported per class and speed, with Wilson 95 % intervals and McNemar's exact test on
  the pairs: named ``stiction``, named ``deadband``, ``none``, the slip-jump test's p < 0.05,
  and the median in-band degrees of freedom (``details.band_dof``);
- the reading: if the loop's speed is the cause, the slower loops' dead bands are named
  stiction more often, and the test rejects J = 0 on them more often.

Output: ``reports/concealed/slip_jump_loop_speed.{md,csv}``. ``--reuse`` re-makes the
report from the CSV. About 8 minutes on 2 cores.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import (  # noqa: E402
    drawn_alike,
    paired_change,
    remade_verdict,
    set_cases,
    stored_experiment,
    valve_verdicts,
)
from fresh_recordings import remake as fresh_remake  # noqa: E402

from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
STEM = OUT / "slip_jump_loop_speed"
SETS = {"C": ("c", "e", "g", "i"), "A": ("a", "b", "d", "f", "h")}
CLASSES = ("deadband", "stiction")
FACTORS = (1.0, 3.0)
#: each generator's loop entries that are times (s); its gains and the PI's period are not
TIMES = {"C": ("tau", "theta", "ti", "lam", "t_cl", "tau1", "tau2", "theta_t"),
         "A": ("tau", "theta", "theta_true", "ti", "lam")}


def cases() -> list[tuple]:
    """``(generator, set, name, seed, class, factor)`` for every recording re-made."""
    return set_cases(SETS, CLASSES, FACTORS)


#: generator A's draws sized by the loop's times, put on sub-streams
SUBSTREAMS = ("draw_sp", "draw_noise", "draw_load")


def slowed(gen: str, factor: float):
    """The loop patch: every time of generator ``gen``'s loop multiplied by ``factor``."""
    def patch(lp: dict) -> dict:
        # a loop tuned by no λ rule has λ None: nothing to scale there
        return lp | {k: lp[k] * factor for k in TIMES[gen] if lp[k] is not None}
    return patch


def remake(gen: str, seed: int, cls: str, factor: float, out: Path,
           name: str | None = None) -> tuple[str, int]:
    """The level-1 recording of ``cls`` with every time of its loop multiplied by
    ``factor`` (generator A: its set point, noise and load from sub-streams), written to
    ``out``: its name and the loop's draw attempts."""
    return fresh_remake(gen, seed, cls, out, slowed(gen, factor), SUBSTREAMS, name)


def one(gen: str, set_: str, name: str, seed: int, cls: str, factor: float) -> dict:
    r = remade_verdict(gen, seed, cls, name, slowed(gen, factor), SUBSTREAMS)
    return {"generator": gen, "set": set_, "name": name, "seed": seed, "class": cls,
            "factor": factor, **r}


def paired(df: pd.DataFrame) -> pd.DataFrame:
    """The recordings whose loop was drawn alike at both speeds."""
    return drawn_alike(df, "factor")


def summary(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (gen, cls), g in df.groupby(["generator", "class"], sort=True):
        w = g.pivot(index="name", columns="factor", values="predicted")
        row = {"generator": gen, "valve (truth)": cls, "loops": len(w)}
        for f in FACTORS:
            gf = g[g.factor == f]
            row[f"band dof (median), ×{f:g}"] = round(float(gf.band_dof.median()), 1)
            row |= valve_verdicts(gf, f"×{f:g}")
        w_j = g.pivot(index="name", columns="factor", values="slip_jump_p") < 0.05
        rows.append(row | paired_change(w == "stiction", *FACTORS,
                                        "stiction only slower / only as drawn")
                    | paired_change(w_j, *FACTORS, "J = 0 rejected only slower / only as drawn"))
    return pd.DataFrame(rows)


def reproduced(df: pd.DataFrame) -> tuple[int, int]:
    """Generator C's recordings at factor 1 whose verdict is the set's stored one, and how
    many there are."""
    stored = pd.concat([pd.read_csv(OUT / f"independent_set_{s}.csv",
                                    usecols=["name", "predicted"]) for s in SETS["C"]])
    m = df[(df.generator == "C") & (df.factor == FACTORS[0])].merge(
        stored, on="name", suffixes=("", "_stored"), validate="one_to_one")
    return int((m.predicted == m.predicted_stored).sum()), len(m)


def report(df: pd.DataFrame) -> str:
    same, n = reproduced(df)
    pr = paired(df)
    s = summary(pr).set_index(["generator", "valve (truth)"])
    kept = ", ".join(f"generator {g} {pr[pr.generator == g].name.nunique()} of "
                     f"{df[df.generator == g].name.nunique()} loops" for g in SETS)
    lines = []
    for gen in SETS:
        d, k = s.loc[(gen, "deadband")], s.loc[(gen, "stiction")]
        lines.append(
            f"- generator {gen}: true dead bands named stiction {d['named stiction, ×1']} as "
            f"drawn, {d['named stiction, ×3']} slower; the slip-jump test rejects J = 0 on "
            f"them in {d['slip-jump p < 0.05, ×1']} and {d['slip-jump p < 0.05, ×3']} (only "
            f"slower / only as drawn: {d['J = 0 rejected only slower / only as drawn']}), on "
            f"true sticky valves in {k['slip-jump p < 0.05, ×1']} and "
            f"{k['slip-jump p < 0.05, ×3']}.")
    return "\n".join([
        "# The loop's speed and the dead bands named stiction", "",
        "Generated by `experiments/slip_jump_loop_speed.py` (the design is in its "
        "docstring). The level-1 dead-band and stiction loops of generator C's sets C, E, "
        "G, I and generator A's sets A, B, D, F, H are re-made with every time of the loop "
        "multiplied by 3 (gains, PI period, record, noise and valve kept). Each is "
        "diagnosed with its model YAML at the package's defaults. Wilson 95 % intervals. "
        "Nothing is tuned here.", "",
        f"Generator C unchanged (×1) reproduces the sets' stored verdict on {same} of {n} "
        "recordings. Generator A's ×1 is its sub-stream remake (the same loop and valve, "
        f"other noise and load draws). Pairs kept: {kept} "
        "(a loop redrawn by the gain-margin screen at one speed is dropped).", "",
        to_markdown(s.reset_index()), "",
        *lines, "",
        "Reading: a test that tells the two valves apart rejects J = 0 far more often on "
        "sticky valves than on dead bands. Compare the two rejection rates at each speed "
        "and generator: where the gap closes on the slower loops, the slip-jump test loses "
        "its power to discriminate as the record holds fewer of the loop's time constants "
        "(fewer in-band degrees of freedom). The McNemar columns say which changes are "
        "established at this size.", ""])


def main(argv: list[str] | None = None) -> int:
    return stored_experiment(__doc__, STEM, one, cases,
                             ["generator", "set", "name", "factor"], report, argv)


if __name__ == "__main__":
    raise SystemExit(main())
