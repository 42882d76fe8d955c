"""OP on its limit in ones and twos: should scattered samples exactly at an end of OP's
range count as a hold?

Why: ``controller_rate_classes.md`` re-made generator C's level-1 saturation loops with the
PI every 0.2 s and every 1 s: saturation was named on 29 of 47 at 0.2 s and 41 of 47 at
1 s, the misses answered ``none``. Read on two of them (``r06eb0dddd750``,
``r8233ff71003a``, set E, by hand): with the PI at 0.2 s OP sits exactly on 0 or 100 % on
0.03–1.3 % of the samples, but never on three in a row (longest run 1–2), so the hold rule
(:func:`stictionbench.diagnosis.op_limit.held_at_limit`: at least ``MIN_RUN`` = 3
consecutive samples) does not fire; at 1 s it does. A PI executing five times per sample
is clamped between samples and kicked off the limit by PV noise, so its snapshots land on
the limit in ones and twos. An output that moves is exactly on an end of its range only
when clamped, so the candidate (``held_at_limit(..., scattered=True)``) also counts an
extreme that is an end of the known range where OP sits exactly on at least ``MIN_RUN``
samples, consecutive or not. No new threshold: ``MIN_RUN`` is the rule's own.

Design (written before the run; the candidate was read on generator C's re-made loops
only):

- part A, the eleven independent sets (2112 recordings, generators A, C and D): the hold
  recomputed from each recording's OP and its model's ``op_range`` with and without the
  candidate, and the verdict re-decided from the stored evidence
  (``concealed.decide``, which reproduces the stored verdict from the stored flags) with
  the new flag: score of 16 per generator and level, saturation named right, healthy loops
  called physics, and every verdict that changes, by class;
- part B, the package's four families (``sim_physical``, ``sim_he``, ``lsim_choudhury``,
  the holdout family), fresh seeds 60000–60011 of every class and level: where the
  candidate finds a hold the shipped rule does not, by class;
- part C, the real loops of ``../shared/data/isdb`` and ``../shared/data/plant`` (whole
  recordings, OP's range recognised from the data as ``diagnose`` does without a model):
  the same, by label. Reported, nothing predicted.

Predictions (criterion for adoption: 1 and 2):

1. part A: no verdict of a class other than ``saturation`` changes, and saturation named
   right rises on generator A's and on generator C's sets;
2. part B: the candidate finds a new hold on no recording of a class other than
   ``saturation``.

Output: ``reports/concealed/held_limit_scattered.{md,csv}``. A few minutes on 2 cores.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from concealed import decide  # noqa: E402
from fresh_recordings import (  # noqa: E402
    CLASSES,
    FAMILIES,
    called_physics,
    jobs_reuse_args,
    publish,
    recording,
    run,
    score_text,
)

from stictionbench.diagnosis.evidence import ALPHA, MIN_IMPROVEMENT  # noqa: E402
from stictionbench.diagnosis.op_limit import held_at_limit  # noqa: E402
from stictionbench.op_range import infer_op_range  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
STEM = OUT / "held_limit_scattered"
DATA = ROOT / ".cache" / "blindgen"
SETS = {"A": ("a", "b", "d", "f", "h"), "C": ("c", "e", "g", "i"), "D": ("x", "y")}
SEEDS = range(60000, 60012)
REAL = ROOT.parent / "shared" / "data"


def _holds(op: np.ndarray, op_range) -> tuple[bool, bool]:
    return (bool(held_at_limit(op, op_range)["held"]),
            bool(held_at_limit(op, op_range, scattered=True)["held"]))


def part_a() -> pd.DataFrame:
    rows = []
    for gen, sets in SETS.items():
        for s in sets:
            st = pd.read_csv(OUT / f"independent_set_{s}.csv")
            for _, r in st.iterrows():
                d = DATA / f"set_{s}"
                op = pd.read_csv(d / f"{r['name']}.csv").OP.to_numpy(float)
                m = yaml.safe_load((d / f"{r['name']}.model.yaml").read_text())
                rng = tuple(m["op_range"]) if "op_range" in m else infer_op_range(op)
                old, new = _holds(op, rng)
                again = decide(r, ALPHA, MIN_IMPROVEMENT)
                candidate = r.copy()
                candidate["op_held"] = new
                after = decide(candidate, ALPHA, MIN_IMPROVEMENT)
                rows.append({"part": "A", "group": gen, "set": s, "name": r["name"],
                             "class": r["class"], "level": int(r.level),
                             "stored": r.predicted, "redecided": again,
                             "held_stored": bool(r.op_held), "held_shipped": old,
                             "held_candidate": new, "candidate": after})
    return pd.DataFrame(rows)


def _family_case(family: str, cls: str, level: int, seed: int) -> dict:
    c, model, rec = recording(family, cls, level, seed)
    op = np.asarray(rec.OP, float)
    old, new = _holds(op, model.op_range or infer_op_range(op))
    return {"part": "B", "group": family, "name": f"{family}/{cls}/{level}/{seed}",
            "class": cls, "level": level, "held_shipped": old, "held_candidate": new}


def part_b(jobs: int) -> pd.DataFrame:
    todo = [(f, c, lv, s) for f in FAMILIES for c in CLASSES for lv in (1, 2) for s in SEEDS]
    return run(_family_case, todo, jobs)


def part_c() -> pd.DataFrame:
    from stictionbench.realdata.datasets import load_csv_dir

    rows = []
    for source in ("isdb", "plant"):
        folder = REAL / source
        if not folder.is_dir():
            continue
        recs, _ = load_csv_dir(folder, warn=False)
        for name, rec in recs.items():
            op = np.asarray(rec.OP, float)
            old, new = _holds(op, infer_op_range(op))
            rows.append({"part": "C", "group": source, "name": name,
                         "class": rec.meta.get("label"), "held_shipped": old,
                         "held_candidate": new})
    return pd.DataFrame(rows)


def decision(adopted: bool) -> str:
    """The report's last line: whether the candidate becomes the default."""
    return "Decision: " + ("**adopted** (`op_limit.SCATTERED = True`)." if adopted
                           else "**not adopted**.")


def _scores(a: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (gen, lv), g in a.groupby(["group", "level"]):
        row = {"generator": gen, "level": lv, "recordings": len(g)}
        for col, label in (("stored", "shipped"), ("candidate", "candidate")):
            row[f"of 16, {label}"] = score_text(g[col], g["class"])
            sat = g[g["class"] == "saturation"]
            row[f"saturation named, {label}"] = rate_text(
                int((sat[col] == "saturation").sum()), len(sat))
            row[f"none called physics, {label}"] = called_physics(g[col], g["class"])
        rows.append(row)
    return pd.DataFrame(rows)


def report(df: pd.DataFrame) -> str:
    a, b, c = (df[df.part == p] for p in "ABC")
    reproduced = int((a.redecided == a.stored).sum())
    same_flag = int((a.held_shipped == a.held_stored).sum())
    moved = a[a.candidate != a.stored]
    moved_tab = (moved.groupby(["group", "level", "class", "stored", "candidate"]).size()
                 .rename("recordings").reset_index())
    other = moved[moved["class"] != "saturation"]
    sat = a[a["class"] == "saturation"]
    gains = {g: int(((x.candidate == "saturation") & (x.stored != "saturation")).sum())
             - int(((x.stored == "saturation") & (x.candidate != "saturation")).sum())
             for g, x in sat.groupby("group")}
    pred1 = other.empty and gains.get("A", 0) > 0 and gains.get("C", 0) > 0
    new_b = b[b.held_candidate & ~b.held_shipped]
    new_b_other = new_b[new_b["class"] != "saturation"]
    pred2 = new_b_other.empty
    word = {True: "**held**", False: "**failed**"}
    tab_b = (b.assign(new=b.held_candidate & ~b.held_shipped)
             .groupby(["class"]).agg(recordings=("new", "size"),
                                     held_shipped=("held_shipped", "sum"),
                                     new_holds=("new", "sum")).reset_index())
    tab_c = (c.assign(new=c.held_candidate & ~c.held_shipped)
             .groupby(["group", "class"]).agg(loops=("new", "size"),
                                              held_shipped=("held_shipped", "sum"),
                                              new_holds=("new", "sum")).reset_index()
             if len(c) else pd.DataFrame())
    lines = [
        "# OP on its limit in ones and twos: scattered samples at a range end as a hold",
        "",
        "Generated by `experiments/held_limit_scattered.py` (the candidate, the design and "
        "the predictions are in its docstring, written before the run). The candidate: "
        "`held_at_limit(..., scattered=True)` also counts an end of OP's known range on which "
        "OP sits exactly on at least `MIN_RUN` = 3 samples, not necessarily consecutive. "
        "Wilson 95 % intervals; the score of 16 weighs the classes equally.",
        "",
        "## Part A: the independent sets, verdicts re-decided",
        "",
        f"- the stored verdict re-decided from the stored evidence: {reproduced} of {len(a)} "
        f"reproduced; the shipped hold recomputed from OP equals the stored flag on "
        f"{same_flag} of {len(a)};",
        f"- verdicts the candidate changes: {len(moved)}, of classes other than saturation: "
        f"{len(other)}; net saturation named right by generator: "
        + ", ".join(f"{g} {v:+d}" for g, v in sorted(gains.items())) + ".",
        "",
        to_markdown(_scores(a)),
        "",
        to_markdown(moved_tab) if len(moved_tab) else "(no verdict changes)",
        "",
        "## Part B: the package's four families, fresh seeds 60000–60011",
        "",
        to_markdown(tab_b),
        "",
        "## Part C: real loops (whole recordings, OP's range recognised from the data)",
        "",
        to_markdown(tab_c) if len(tab_c) else "(`../shared/data` not found)",
        "",
        "## The predictions",
        "",
        f"1. Part A: verdicts of other classes changed {len(other)}; saturation named right "
        + ", ".join(f"generator {g} {v:+d}" for g, v in sorted(gains.items()))
        + f": {word[pred1]}.",
        f"2. Part B: new holds on other classes {len(new_b_other)} of "
        f"{int((b['class'] != 'saturation').sum())}: {word[pred2]}.",
        "",
        decision(pred1 and pred2),
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = jobs_reuse_args(__doc__, "re-make the report from the stored CSV", argv)
    if args.reuse:
        df = pd.read_csv(STEM.with_suffix(".csv"))
    else:
        df = pd.concat([part_a(), part_b(args.jobs), part_c()], ignore_index=True)
    publish(df, report(df), STEM)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
