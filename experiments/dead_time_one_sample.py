"""Generator C's dead-time changes that are never named: is it because they sit within
one sample of the nominal's? The same loops re-made with the change one second longer.

Why: on sets C, E, G, I, 14 of generator C's 48 level-1 dead-time recordings (24 of 48 at
level 2) have a pure dead-time change under one sample (true against model, e.g. 1.0 →
1.8 s), and none of them is named ``dead_time`` (12 answered ``none``, 2 ``deadband`` at
level 1). The generator sizes the change it draws as pure delay plus half its second lag
(``τ₂/2``); so measured, the level-1 changes are a median 1.0003 s, one sample, its own
floor. The diagnosis aligns the nominal model within ±1 sample before any hypothesis is
fitted, because when OP is read (before or after the controller executes, or between two
executions of a faster PI) moves the apparent delay by up to a sample, and it treats a dead
time within one sample of the nominal's as bookkeeping (``DeadTime.at_bound``). The
explanation written in ``docs/diagnosis.md``: these changes are out of the test's reach by
that design. It is checked here by varying what it depends on, the size of the change.

Design (written before the run; nothing here changes the package or sets a threshold):

- loops: every dead-time recording of sets C, E, G, I, both levels, whose pure change
  ``|true_dead_time − model_dead_time|`` is under 1 s;
- each re-made by generator C from its own seed twice: as drawn, and with one second added
  to the true dead time it draws (``draw_effect``'s ``theta_true``; every other draw is on
  its own stream and stays the same); each diagnosed with its model YAML at the package's
  defaults;
- reported per level: named ``dead_time`` and the other answers, as drawn and one second
  longer; the as-drawn verdicts against the stored ones. Wilson 95 % intervals.

Predictions:

1. as drawn, the re-made recordings give the stored verdicts (none named ``dead_time``);
2. level 1, one second longer: at least half are named ``dead_time``.

If 2 fails, the explanation in the docs is wrong or incomplete, and the report says so.

Output: ``reports/concealed/dead_time_one_sample.{md,csv}``. ``--reuse`` re-makes the report
from the CSV. About a minute on 2 cores.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import generator_module, stored_experiment  # noqa: E402

from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
STEM = OUT / "dead_time_one_sample"
SETS = ("c", "e", "g", "i")
EXTRA = (0.0, 1.0)


def cases() -> list[tuple]:
    """``(set, name, seed, level, extra)`` for every loop re-made."""
    todo = []
    for s in SETS:
        d = pd.read_csv(OUT / f"independent_set_{s}.csv")
        d = d[(d["class"] == "dead_time")
              & ((d.true_dead_time - d.model_dead_time).abs() < 1.0)]
        todo += [(s, r["name"], int(r.seed), int(r.level), x) for _, r in d.iterrows()
                 for x in EXTRA]
    return todo


def one(set_: str, name: str, seed: int, level: int, extra: float) -> dict:
    """The recording re-made with ``extra`` s more true dead time, diagnosed."""
    from stictionbench.diagnosis import diagnose, load_model
    from stictionbench.io import read_recording

    g = generator_module("blind_generator_c")
    draw_effect = g.draw_effect

    def longer(seed_, level_, cls, loop, cond):
        e = draw_effect(seed_, level_, cls, loop, cond)
        return e | {"theta_true": e["theta_true"] + extra} if cls == "dead_time" else e

    g.draw_effect = longer
    res = g.make_recording(seed, level, "dead_time")
    if res["name"] != name:
        raise RuntimeError(f"generator C seed {seed} does not make {name}")
    with tempfile.TemporaryDirectory() as tmp:
        g.write_recording(tmp, res)
        d = Path(tmp)
        r = diagnose(read_recording(str(d / f"{name}.csv"), warn=False),
                     load_model(d / f"{name}.model.yaml"))
    return {"set": set_, "name": name, "seed": seed, "level": level, "extra_s": extra,
            "predicted": r.missing_physics,
            "fitted_dead_time": r.parameters.get("dead_time")}


def report(df: pd.DataFrame) -> str:
    stored = pd.concat([pd.read_csv(OUT / f"independent_set_{s}.csv")[
        ["name", "predicted", "model_dead_time", "true_dead_time", "true_tau2"]]
        for s in SETS]).rename(columns={"predicted": "stored"})
    m = df.merge(stored, on="name", how="left", validate="many_to_one")
    drawn = m[m.extra_s == 0.0]
    same = int((drawn.predicted == drawn.stored).sum())
    rows = []
    for (lv, x), g in m.groupby(["level", "extra_s"]):
        eff = g.true_dead_time + x + g.true_tau2 / 2 - g.model_dead_time
        rows.append({"level": lv, "added (s)": x, "loops": len(g),
                     "change with τ₂/2, median (s)": round(float(eff.median()), 3),
                     "named dead_time": rate_text(int((g.predicted == "dead_time").sum()),
                                                  len(g)),
                     "answers": ", ".join(f"{k} ×{v}" for k, v in
                                          g.predicted.value_counts().items())})
    one_l1 = m[(m.level == 1) & (m.extra_s == 1.0)]
    k1 = int((one_l1.predicted == "dead_time").sum())
    named_drawn = int((drawn.predicted == "dead_time").sum())
    pred1 = same == len(drawn) and named_drawn == 0
    pred2 = k1 >= len(one_l1) / 2
    word = {True: "**held**", False: "**failed**"}
    reading = (
        "The same loops are named once the change is a second longer: what kept them unnamed "
        "is their size, a change of one sample, within the band the diagnosis leaves to the "
        "historian's timing convention. The explanation in the docs stands."
        if pred2 else
        "A second more dead time did not make most of them named: the one-sample band is "
        "not the whole reason, and the explanation in the docs is incomplete.")
    lines = [
        "# Generator C's one-sample dead-time changes, made a second longer",
        "",
        "Generated by `experiments/dead_time_one_sample.py` (design and predictions in its "
        "docstring, written before the run): every dead-time recording of sets C, E, G, I "
        "whose pure change is under 1 s, re-made by generator C as drawn and with one second "
        "added to its true dead time, each diagnosed with its model YAML at the package's "
        "defaults. Wilson 95 % intervals. Nothing is tuned here.",
        "",
        to_markdown(pd.DataFrame(rows)),
        "",
        "## The predictions",
        "",
        f"1. As drawn, the stored verdict reproduced on {same} of {len(drawn)}, "
        f"`dead_time` named on {named_drawn}: {word[pred1]}.",
        f"2. Level 1, one second longer: `dead_time` named on "
        f"{rate_text(k1, len(one_l1))}: {word[pred2]}.",
        "",
        reading,
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    return stored_experiment(__doc__, STEM, one, cases, ["level", "set", "name", "extra_s"],
                             report, argv)


if __name__ == "__main__":
    raise SystemExit(main())
