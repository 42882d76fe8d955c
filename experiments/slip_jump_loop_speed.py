"""Is the loop's speed why dead bands are named stiction? Generator C's level-1 dead-band
and stiction loops re-made three times slower, nothing else changed.

Why: ``slip_jump_pi_rate.md`` found that the PI's rate does not change how often a dead
band is named stiction on the same loops. In the sets, though, the confusions sit on slow
loops (generator A: 0 of 21 dead bands with τ ≤ 10 s named stiction, 5 of 23 with
τ > 30 s). The loop's speed was binned there, not varied.

Design (written before the run; nothing here changes the package or sets a threshold):

- loops: every level-1 dead-band and stiction recording of generator C's sets C, E, G, I
  (96). Generator C draws from a stream per purpose, so a change to the loop leaves every
  other draw as it was;
- the one change: every time of the loop multiplied by 3. That is the process's τ, its
  second lag and dead time (true and nominal), the PI's integral time, and the tuning's
  λ and closed-loop time; the load's time constant follows τ. The gains, the PI's period,
  the record (3000 s at 1 s), the noise and the valve stay. The loop's shape in its own
  time is the same; the record holds a third as many of its time constants and cycles;
- factor 1 is the generator unchanged, and it must reproduce the sets' stored verdicts
  (checked in the report);
- each recording diagnosed with its model YAML at the package's defaults;
- reported per class and speed, with Wilson 95 % intervals and McNemar's exact test on
  the pairs: named ``stiction``, named ``deadband``, ``none``, the slip-jump test's p < 0.05,
  and the median in-band degrees of freedom (``details.band_dof``);
- the reading: if the loop's speed is the cause, the slower loops' dead bands are named
  stiction more often, and the test rejects J = 0 on them more often.

Output: ``reports/concealed/slip_jump_loop_speed.{md,csv}``. ``--reuse`` re-makes the
report from the CSV. About 4 minutes on 2 cores.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import (  # noqa: E402
    generator_module,
    jobs_reuse_args,
    paired_change,
    publish,
    stored_or_run,
    valve_verdicts,
)

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
STEM = OUT / "slip_jump_loop_speed"
SETS = ("c", "e", "g", "i")
CLASSES = ("deadband", "stiction")
FACTORS = (1.0, 3.0)
#: generator C's loop entries that are times (s); its gains and the PI's period are not
TIMES = ("tau", "theta", "ti", "lam", "t_cl", "tau1", "tau2", "theta_t")


def cases() -> list[tuple]:
    """``(set, name, seed, class, factor)`` for every recording re-made."""
    todo = []
    for s in SETS:
        d = pd.read_csv(OUT / f"independent_set_{s}.csv")
        d = d[d["class"].isin(CLASSES) & (d.level == 1)]
        todo += [(s, r["name"], int(r.seed), r["class"], f) for _, r in d.iterrows()
                 for f in FACTORS]
    return todo


def remake(seed: int, cls: str, factor: float, out: Path) -> str:
    """Generator C's level-1 recording of ``cls`` with every time of its loop multiplied by
    ``factor``, written to ``out``; its name."""
    g = generator_module("blind_generator_c")
    draw_loop = g.draw_loop

    def slowed(seed_: int) -> dict:
        lp = draw_loop(seed_)
        return lp | {k: lp[k] * factor for k in TIMES}

    g.draw_loop = slowed
    res = g.make_recording(seed, 1, cls)
    g.write_recording(str(out), res)
    return res["name"]


def one(set_: str, name: str, seed: int, cls: str, factor: float) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        made = remake(seed, cls, factor, Path(tmp))
        if made != name:
            raise RuntimeError(f"generator C seed {seed} does not make {name}")
        rec = read_recording(str(Path(tmp) / f"{name}.csv"), warn=False)
        r = diagnose(rec, load_model(Path(tmp) / f"{name}.model.yaml"))
    return {"set": set_, "name": name, "seed": seed, "class": cls, "factor": factor,
            "predicted": r.missing_physics,
            "slip_jump_p": r.tests.get("slip_jump_zero", {}).get("p_value"),
            "band_dof": r.details.get("band_dof")}


def summary(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for cls, g in df.groupby("class", sort=True):
        w = g.pivot(index="name", columns="factor", values="predicted")
        row = {"valve (truth)": cls, "loops": len(w)}
        for f in FACTORS:
            gf = g[g.factor == f]
            row[f"band dof (median), ×{f:g}"] = round(float(gf.band_dof.median()), 1)
            row |= valve_verdicts(gf, f"×{f:g}")
        rows.append(row | paired_change(w == "stiction", *FACTORS,
                                        "stiction only slower / only as drawn"))
    return pd.DataFrame(rows)


def reproduced(df: pd.DataFrame) -> tuple[int, int]:
    """Recordings at factor 1 whose verdict is the set's stored one, and how many there are."""
    stored = pd.concat([pd.read_csv(OUT / f"independent_set_{s}.csv",
                                    usecols=["name", "predicted"]) for s in SETS])
    m = df[df.factor == FACTORS[0]].merge(stored, on="name", suffixes=("", "_stored"),
                                          validate="one_to_one")
    return int((m.predicted == m.predicted_stored).sum()), len(m)


def report(df: pd.DataFrame) -> str:
    same, n = reproduced(df)
    s = summary(df).set_index("valve (truth)")
    d_fast = s.loc["deadband", "named stiction, ×1"]
    d_slow = s.loc["deadband", "named stiction, ×3"]
    r_fast = s.loc["deadband", "slip-jump p < 0.05, ×1"]
    r_slow = s.loc["deadband", "slip-jump p < 0.05, ×3"]
    k_fast = s.loc["stiction", "slip-jump p < 0.05, ×1"]
    k_slow = s.loc["stiction", "slip-jump p < 0.05, ×3"]
    w = df[df["class"] == "deadband"].pivot(index="name", columns="factor",
                                             values="slip_jump_p") < 0.05
    rejected = paired_change(w, *FACTORS, "j")["j"]
    return "\n".join([
        "# The loop's speed and the dead bands named stiction", "",
        "Generated by `experiments/slip_jump_loop_speed.py` (the design is in its "
        "docstring). Generator C's level-1 dead-band and stiction loops of sets C, E, G, I "
        "are re-made with every time of the loop multiplied by 3 (gains, PI period, record, "
        "noise and valve kept). Each is diagnosed with its model YAML at the package's "
        "defaults. Wilson 95 % intervals. Nothing is tuned here.", "",
        f"The generator unchanged (×1) reproduces the sets' stored verdict on {same} of {n} "
        "recordings.", "",
        to_markdown(s.reset_index()), "",
        f"- true dead bands named stiction: {d_fast} as drawn, {d_slow} three times slower;",
        f"- the slip-jump test rejects J = 0 (p < 0.05) on true dead bands in {r_fast} as "
        f"drawn and {r_slow} slower (only slower / only as drawn: {rejected}); on true "
        f"sticky valves in {k_fast} and {k_slow}.",
        "",
        "Reading: a test that tells the two valves apart rejects J = 0 far more often on "
        "sticky valves than on dead bands. Compare the two rejection rates at each speed: "
        "where the gap closes on the slower loops, the slip-jump test loses its power to "
        "discriminate as the record holds fewer of the loop's time constants (fewer "
        "in-band degrees of freedom). The McNemar column says whether the named-stiction "
        "change is established at this size.", ""])


def main(argv: list[str] | None = None) -> int:
    args = jobs_reuse_args(__doc__, "re-make the report from the stored CSV", argv)
    df = stored_or_run(STEM, args.reuse, one, cases, args.jobs,
                       ["set", "name", "factor"])
    publish(df, report(df), STEM)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
