"""Scattered samples at OP's range end as a hold: what it does to the *answers*, on
recordings drawn for this run.

Why: ``held_limit_scattered.md`` tried the candidate (``held_at_limit(...,
scattered=True)``) against a criterion written before its run. On the eleven independent
sets it changed 31 verdicts, every one a saturation loop answered ``none`` now named. Its
second prediction was about *holds*, not answers: on fresh seeds of the package's four
families the candidate found new holds on 12 recordings of other classes, so it failed and
the candidate was not adopted. A hold changes an answer only where the comparison named
nothing (:func:`stictionbench.diagnosis.diagnose.after_comparison`). Whether those holds
change answers was not measured. It is measured here, on recordings no experiment had
drawn, with the criterion written first. The shipped rule stays as it is unless this
criterion holds. The reading of that earlier failure stays in its report.

Design (written before the run):

- recordings: the package's four families (``sim_physical``, ``sim_he``,
  ``lsim_choudhury``, the holdout family), seeds 62000–62011 of every class and level
  (768), and two fresh sets of the independent generators, drawn here: generator A from
  seed 95000 and generator C from seed 97000, 12 per class and level (``.cache/blindgen/
  set_s``, ``set_t``);
- each diagnosed with its model as ``stictionbench diagnose`` does (package defaults,
  shipped hold rule); its verdict re-decided from the stored evidence
  (``concealed.decide``) with the candidate's hold, computed from the recording's OP and
  the OP range the diagnosis used (``details.op_range``);
- reported: every verdict the candidate changes, by family, class and level; saturation
  named right and healthy loops called physics, shipped and candidate. Wilson 95 %
  intervals.

Criterion for adoption (both):

1. on all of these recordings together, the candidate changes no verdict of a class other
   than ``saturation``;
2. saturation named right is at least as often as shipped on each generator's recordings.

Output: ``reports/concealed/held_limit_verdicts.{md,csv}``. ``--reuse`` re-makes the report
from the CSV. About 15 minutes on 2 cores.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from concealed import decide, decision_row  # noqa: E402
from fresh_recordings import (  # noqa: E402
    CLASSES,
    FAMILIES,
    recording,
    set_truths,
    stored_experiment,
)
from held_limit_scattered import decision  # noqa: E402

from stictionbench.diagnosis.evidence import ALPHA, MIN_IMPROVEMENT  # noqa: E402
from stictionbench.diagnosis.op_limit import held_at_limit  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
STEM = OUT / "held_limit_verdicts"
DATA = ROOT / ".cache" / "blindgen"
SEEDS = range(62000, 62012)
#: set -> (generator folder, first seed)
FRESH = {"s": ("blind_generator", 95000), "t": ("blind_generator_c", 97000)}


def _row(group: str, name: str, cls: str, level: int, d, op: np.ndarray) -> dict:
    row = pd.Series({**decision_row(d), "predicted": d.missing_physics})
    rng = d.details.get("op_range")
    cand = row.copy()
    cand["op_held"] = bool(held_at_limit(op, None if rng is None else tuple(rng),
                                         scattered=True)["held"])
    return {"group": group, "name": name, "class": cls, "level": level,
            "shipped": d.missing_physics, "redecided": decide(row, ALPHA, MIN_IMPROVEMENT),
            "held_shipped": bool(row["op_held"]), "held_candidate": bool(cand["op_held"]),
            "candidate": decide(cand, ALPHA, MIN_IMPROVEMENT)}


def family_case(family: str, cls: str, level: int, seed: int) -> dict:
    from stictionbench.diagnosis import diagnose

    _, model, rec = recording(family, cls, level, seed)
    return _row(family, f"{family}/{cls}/{level}/{seed}", cls, level, diagnose(rec, model),
                np.asarray(rec.OP, float))


def set_case(set_: str, name: str, cls: str, level: int) -> dict:
    from stictionbench.diagnosis import diagnose, load_model
    from stictionbench.io import read_recording

    d = DATA / f"set_{set_}"
    rec = read_recording(str(d / f"{name}.csv"), warn=False)
    return _row(f"set_{set_}", name, cls, level,
                diagnose(rec, load_model(d / f"{name}.model.yaml")),
                np.asarray(rec.OP, float))


def _draw_sets() -> None:
    for s, (gen, seed) in FRESH.items():
        out = DATA / f"set_{s}"
        if not (out / "truth.csv").exists():
            subprocess.run([sys.executable, str(ROOT / "experiments" / gen / "generate.py"),
                            "--out", str(out), "--per-class", "12", "--first-seed",
                            str(seed)], check=True, stdout=subprocess.DEVNULL)


def cases() -> list[tuple]:
    _draw_sets()
    todo: list[tuple] = [("family", f, c, lv, s) for f in FAMILIES for c in CLASSES
                         for lv in (1, 2) for s in SEEDS]
    truths = set_truths(FRESH, STEM.name, DATA)
    if truths is None:
        raise SystemExit(2)
    todo += [("set", s, r["name"], r["class"], int(r.level)) for s in FRESH
             for _, r in truths[s].iterrows()]
    return todo


def one(kind: str, *args) -> dict:
    return family_case(*args) if kind == "family" else set_case(*args)


def report(df: pd.DataFrame) -> str:
    reproduced = int((df.redecided == df.shipped).sum())
    moved = df[df.candidate != df.shipped]
    other = moved[moved["class"] != "saturation"]
    rows = []
    ok2 = True
    for g, x in df.groupby("group"):
        sat, h = x[x["class"] == "saturation"], x[x["class"] == "none"]
        a, b = int((sat.shipped == "saturation").sum()), int((sat.candidate == "saturation").sum())
        ok2 &= b >= a
        rows.append({"group": g, "recordings": len(x),
                     "saturation named, shipped": rate_text(a, len(sat)),
                     "saturation named, candidate": rate_text(b, len(sat)),
                     "none called physics, shipped": rate_text(
                         int((h.shipped != "none").sum()), len(h)),
                     "none called physics, candidate": rate_text(
                         int((h.candidate != "none").sum()), len(h)),
                     "new holds, other classes": int(
                         (x.held_candidate & ~x.held_shipped & (x["class"] != "saturation"))
                         .sum())})
    ok1 = other.empty
    tab = (moved.groupby(["group", "level", "class", "shipped", "candidate"]).size()
           .rename("recordings").reset_index())
    word = {True: "**held**", False: "**failed**"}
    lines = [
        "# Scattered samples at OP's range end as a hold: the answers",
        "",
        "Generated by `experiments/held_limit_verdicts.py` (design and criterion in its "
        "docstring, written before the run; the earlier test of the same candidate, whose "
        "second prediction failed, is [held_limit_scattered.md](held_limit_scattered.md)). "
        "Recordings drawn for this run: the package's four families at seeds 62000–62011 "
        "and fresh sets S (generator A, from 95000) and T (generator C, from 97000). Each "
        "diagnosed as shipped; its verdict re-decided with the candidate's hold. Wilson "
        "95 % intervals.",
        "",
        f"- shipped verdicts reproduced by the re-decision: {reproduced} of {len(df)};",
        f"- verdicts the candidate changes: {len(moved)}, of classes other than saturation: "
        f"{len(other)}.",
        "",
        to_markdown(pd.DataFrame(rows)),
        "",
        to_markdown(tab) if len(tab) else "(no verdict changes)",
        "",
        "## The criterion",
        "",
        f"1. No verdict of another class changed: {len(other)} changed: {word[ok1]}.",
        f"2. Saturation named at least as often as shipped in every group: {word[ok2]}.",
        "",
        decision(ok1 and ok2),
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    return stored_experiment(__doc__, STEM, one, cases, ["group", "name"], report, argv)


if __name__ == "__main__":
    raise SystemExit(main())
