"""A verdict voted over three block splits, scored on the sets it came from and on two
fresh sets drawn for it, against a criterion written before either run.

Why: ``block_layout.py`` found the healthy loops' line false alarms fragile to the split:
6 of the 8 that five interleaved blocks name go with three or with nine blocks, while the
true disturbances are named about as often under every interleaved split. The cross-
validation estimate of one split is a random variable of that split (Arlot & Celisse,
*Statistics Surveys* 4 (2010) 40, on the variance of cross-validation and averaging over
splits), and a verdict decided on one split carries its accident. The rule tried here:

- **vote**: ``diagnose`` under 5 (shipped), 3 and 9 interleaved blocks
  (``n_blocks``; :mod:`stictionbench.diagnosis.blocks`), the physics two of the three
  name, else ``none``. The three splits were fixed in ``block_layout.py``'s design before
  its run; nothing is tuned here.
- **confirm** (secondary, reported only): the shipped verdict where at least one of the
  other two splits names the same physics, else ``none``.

Recordings: every recording of the independent sets A–I (1728; in-sample: the idea came
from their healthy and disturbance loops) and two fresh sets, generator A from seed 75000
and generator C from seed 77000, 12 recordings per class and level each (384; drawn for
this run, out of sample). The shipped verdicts of sets A–I are the stored ones
(``independent_set_*.csv``).

**Criterion, written before the run.** The vote becomes the default only if on the fresh
sets pooled (1) fewer healthy loops are called physics than by the shipped rule, (2) the
score of 16 at each level is not lower than the shipped rule's by more than 0.25, and (3)
both also hold on sets A–I; and (4) a diagnosis under it stays within the issue's 2 s per
3000-sample recording (median here). Otherwise it is not adopted, and the report says
which part failed.

Run: ``.venv/bin/python experiments/split_vote.py [--jobs 2] [--reuse]`` after ``make
independent`` (the sets in ``.cache/blindgen``; the fresh sets are generated here);
writes ``reports/concealed/split_vote.{md,csv}`` (about 35 minutes on 2 cores).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import jobs_reuse_args, publish, run  # noqa: E402
from verdict_scores import (  # noqa: E402
    DATA,
    PER_CLASS,
    draw_sets,
    level_score,
    level_scores,
    per_class_rates,
)

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
SETS = {"A": ("a", "b", "d", "f", "h"), "C": ("c", "e", "g", "i")}
#: fresh set → (generator folder, first seed): drawn for this experiment
FRESH = {"vote_a": ("blind_generator", 75000), "vote_c": ("blind_generator_c", 77000)}
SPLITS = {"interleaved": 5, "n3": 3, "n9": 9}
RULES = ("shipped", "vote", "confirm")
#: the criterion's largest loss of score of 16 at a level
MAX_LOSS = 0.25
#: the issue's time per 3000-sample recording
MAX_SECONDS = 2.0


def fresh_sets() -> None:
    """Write the fresh sets with their generators (same seed, byte-identical files)."""
    draw_sets(FRESH, PER_CLASS)


def one(part: str, gen: str, set_: str, name: str, cls: str, level: int,
        split: str) -> dict:
    """One recording diagnosed with its model YAML under ``split``."""
    src = DATA / (set_ if part == "fresh" else f"set_{set_}")
    rec = read_recording(str(src / f"{name}.csv"), warn=False)
    t0 = time.perf_counter()
    r = diagnose(rec, load_model(src / f"{name}.model.yaml"), n_blocks=SPLITS[split])
    return {"part": part, "generator": gen, "set": set_, "name": name, "class": cls,
            "level": level, "split": split, "predicted": r.missing_physics,
            "seconds": time.perf_counter() - t0}


def cases() -> tuple[list[tuple], pd.DataFrame]:
    """Every job, and the stored shipped verdicts of sets A–I."""
    todo, stored = [], []
    for gen, sets in SETS.items():
        for s in sets:
            d = pd.read_csv(OUT / f"independent_set_{s}.csv")
            stored.append(pd.DataFrame({"part": "A–I", "generator": gen, "set": s,
                                        "name": d["name"], "class": d["class"],
                                        "level": d.level, "split": "interleaved",
                                        "predicted": d.predicted}))
            todo += [("A–I", gen, s, r["name"], r["class"], int(r.level), sp)
                     for _, r in d.iterrows() for sp in SPLITS if sp != "interleaved"]
    for s, (folder, _) in FRESH.items():
        gen = "A" if folder == "blind_generator" else "C"
        t = pd.read_csv(DATA / s / "truth.csv")
        todo += [("fresh", gen, s, r["name"], r["class"], int(r.level), sp)
                 for _, r in t.iterrows() for sp in SPLITS]
    return todo, pd.concat(stored, ignore_index=True)


def vote(row: pd.Series) -> str:
    """The physics two of the three splits name, else ``none``."""
    v = [row[s] for s in SPLITS]
    best = max(set(v), key=v.count)
    return best if v.count(best) >= 2 else "none"


def confirm(row: pd.Series) -> str:
    """The shipped verdict where another split names it too, else ``none``."""
    s = row["interleaved"]
    return s if s == "none" or s in (row["n3"], row["n9"]) else "none"


def verdicts(df: pd.DataFrame) -> pd.DataFrame:
    """One row per recording: each split's verdict and each rule's."""
    w = df.pivot_table(index=["part", "generator", "set", "name", "class", "level"],
                       columns="split", values="predicted", aggfunc="first").reset_index()
    w = w.dropna(subset=list(SPLITS))
    return w.assign(shipped=w["interleaved"], vote=w.apply(vote, axis=1),
                    confirm=w.apply(confirm, axis=1))


def scores(w: pd.DataFrame) -> pd.DataFrame:
    """Per part, generator and level: each rule's score of 16 and healthy loops called
    physics, and the paired changes of the vote against the shipped rule."""
    return level_scores(w, RULES, "vote", "shipped", "right only by vote / only shipped")


def per_class(w: pd.DataFrame) -> pd.DataFrame:
    """Named right per class and level, shipped against vote, each part pooled."""
    return per_class_rates(w, ("shipped", "vote", "confirm"))


def criterion(w: pd.DataFrame, seconds: float) -> list[tuple[str, bool, str]]:
    """The four parts of the criterion: (what, met, the numbers)."""
    out = []
    for part, label in (("fresh", "fresh sets"), ("A–I", "sets A–I")):
        g = w[w.part == part]
        h = g[g["class"] == "none"]
        fs, fv = int((h.shipped != "none").sum()), int((h.vote != "none").sum())
        out.append((f"{label}: fewer healthy loops called physics", fv < fs,
                    f"{fs} → {fv} of {len(h)}"))
        losses = {lv: level_score(g, "shipped", lv) - level_score(g, "vote", lv) for lv in (1, 2)}
        out.append((f"{label}: score of 16 lost at most {MAX_LOSS} at each level",
                    all(x <= MAX_LOSS for x in losses.values()),
                    ", ".join(f"level {lv} {level_score(g, 'shipped', lv):.2f} → "
                              f"{level_score(g, 'vote', lv):.2f}" for lv in (1, 2))))
    out.append((f"a voted diagnosis within {MAX_SECONDS:g} s (median)",
                seconds <= MAX_SECONDS, f"{seconds:.2f} s"))
    return out


def report(df: pd.DataFrame) -> str:
    w = verdicts(df)
    fresh = df[df.part == "fresh"]
    per_rec = fresh.groupby("name").seconds.sum()
    voted = float(per_rec.median())
    one_split = float(fresh[fresh.split == "interleaved"].seconds.median())
    crit = criterion(w, voted)
    adopted = all(ok for _, ok, _ in crit)
    lines = [
        "# A verdict voted over three block splits", "",
        "Generated by `experiments/split_vote.py` (the rule, the recordings and the "
        "criterion, written before the run, in its docstring). **vote**: the physics two of "
        "`diagnose`'s verdicts under 5 (shipped), 3 and 9 interleaved blocks name, else "
        "`none`; **confirm**: the shipped verdict where another split names it too. Sets "
        "A–I are in-sample for the idea (it came from their healthy loops, "
        "[block_layout.md](block_layout.md)); the two fresh sets were drawn for this run. "
        "Scores of 16 weigh the eight classes equally (95 % intervals); Wilson 95 % "
        "intervals; McNemar's exact test on the recordings whose verdict changed.", "",
        f"- Recordings: {int((w.part == 'A–I').sum())} of sets A–I, "
        f"{int((w.part == 'fresh').sum())} fresh.",
        f"- Time per recording on the fresh sets (median): {one_split:.2f} s for one "
        f"diagnosis, {voted:.2f} s for the three a vote needs.", "",
        to_markdown(scores(w)), "",
        "## The criterion", "",
        to_markdown(pd.DataFrame([{"part": what, "met": "yes" if ok else "no",
                                   "measured": text} for what, ok, text in crit])), "",
        ("**Adopted**: every part met." if adopted else
         "**Not adopted**: " + "; ".join(what for what, ok, _ in crit if not ok)
         + " failed. The shipped rule is unchanged."), "",
        "## Per class", "", to_markdown(per_class(w)), "",
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = jobs_reuse_args(__doc__, "re-make the report from the stored CSV", argv)
    stem = OUT / "split_vote"
    if args.reuse and stem.with_suffix(".csv").exists():
        df = pd.read_csv(stem.with_suffix(".csv"))
    else:
        fresh_sets()
        todo, stored = cases()
        df = pd.concat([stored, run(one, todo, args.jobs)], ignore_index=True)
        df = df.sort_values(["part", "generator", "set", "name", "split"],
                            kind="stable").reset_index(drop=True)
    publish(df, report(df), stem)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
