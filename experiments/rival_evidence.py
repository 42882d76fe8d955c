"""Does ``tests.rival`` say when an answer is one of two the record cannot tell apart?
Vuong's test of the answer against its closest rival, read against the sets' truth.

Why: the diagnosis names the significant hypothesis of lowest BIC. Where another also
passed every gate, the lower BIC says which fits better, not whether the record could tell
the two apart. On the independent sets, level 1, 11 of 132 true dead-time changes were
named ``sensor_lag`` "of lower BIC", with the true dead time passing every gate; on one
(set D, ``rec_aeaaae1f28``) the two hypotheses' validation likelihood-ratio statistics
against the nominal were 30.3 and 29.8. ``diagnose`` now reports, beside the answer,
Vuong's (1989) test of it against the closest significant rival
(:mod:`stictionbench.diagnosis.rival`); it informs, it does not decide. Here it is read
against the truth.

Design (written before the run; nothing here changes the package or sets a threshold):

- every recording of the eleven independent sets (A–I, X, Y), diagnosed with its model
  YAML as ``stictionbench diagnose`` does (package defaults, alpha 0.05);
- per recording: the answer, the rival, Vuong's p-value, ``distinguishable``;
- reported: answers with a rival and without; among physics answers with a rival, the
  share named right when ``distinguishable`` and when not (Fisher's exact test); of the
  wrong answers whose true class is the rival, the share flagged not distinguishable;
  healthy loops called physics, by the flag. Wilson 95 % intervals.

Predictions (written before the run):

1. every verdict equals the set's stored verdict (``reports/concealed/independent_set_S.csv``
   of ``make independent``): the rival test and the stage-5 refactor change no answer;
2. among physics answers with a rival, the distinguishable ones are named right more
   often than the others (Fisher's exact test, one-sided, p < 0.05);
3. of the wrong answers whose true class is the rival, at least half are flagged not
   distinguishable.

Output: ``reports/concealed/rival_evidence.{md,csv}``. ``--reuse`` re-makes the report from
the CSV. About 25 minutes on 2 cores.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
from scipy.stats import fisher_exact

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import set_truths, stored_experiment  # noqa: E402

from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
STEM = OUT / "rival_evidence"
DATA = ROOT / ".cache" / "blindgen"
SETS = ("a", "b", "c", "d", "e", "f", "g", "h", "i", "x", "y")


def cases() -> list[tuple]:
    """``(set, name, class, level)`` of every recording of the sets."""
    truths = set_truths(SETS, STEM.name, DATA)
    if truths is None:
        raise SystemExit(2)
    return [(s, r["name"], r["class"], int(r.level)) for s in SETS
            for _, r in truths[s].iterrows()]


def one(set_: str, name: str, cls: str, level: int) -> dict:
    """One recording diagnosed with its model YAML at the package's defaults."""
    from stictionbench.diagnosis import diagnose, load_model
    from stictionbench.io import read_recording

    d = DATA / f"set_{set_}"
    res = diagnose(read_recording(str(d / f"{name}.csv"), warn=False),
                   load_model(d / f"{name}.model.yaml"))
    t = res.tests["rival"]
    return {"set": set_, "name": name, "class": cls, "level": level,
            "predicted": res.missing_physics, "rival": t.get("rival"),
            "p_value": t.get("p_value"), "statistic": t.get("statistic"),
            "distinguishable": t.get("distinguishable")}


def stored_verdicts() -> pd.DataFrame:
    return pd.concat([pd.read_csv(OUT / f"independent_set_{s}.csv")[["name", "predicted"]]
                      .assign(set=s) for s in SETS])


def report(df: pd.DataFrame) -> str:
    st = stored_verdicts().rename(columns={"predicted": "stored"})
    m = df.merge(st, on=["set", "name"], how="left", validate="one_to_one")
    same = int((m.predicted == m.stored).sum())
    phys = m[m.predicted != "none"]
    with_rival = phys[phys.rival.notna()]
    right = with_rival.predicted == with_rival["class"]
    dist = with_rival.distinguishable.astype(bool)
    a, b = int((right & dist).sum()), int((~right & dist).sum())
    c, d = int((right & ~dist).sum()), int((~right & ~dist).sum())
    p_f = float(fisher_exact([[a, b], [c, d]], alternative="greater")[1]) if a + b and c + d \
        else float("nan")
    wrong_to_rival = with_rival[(~right) & (with_rival.rival == with_rival["class"])]
    flagged = int((~wrong_to_rival.distinguishable.astype(bool)).sum())
    healthy = phys[phys["class"] == "none"]
    healthy_flagged = int((healthy.rival.notna()
                           & ~healthy.distinguishable.fillna(True).astype(bool)).sum())
    pred1 = same == len(m)
    pred2 = p_f < 0.05 and a / max(a + b, 1) > c / max(c + d, 1)
    pred3 = len(wrong_to_rival) > 0 and flagged >= len(wrong_to_rival) / 2
    word = {True: "**held**", False: "**failed**"}
    rows = []
    for lv, g in with_rival.groupby("level"):
        ok, di = g.predicted == g["class"], g.distinguishable.astype(bool)
        rows.append({"level": lv, "physics answers with a rival": len(g),
                     "named right, distinguishable": rate_text(int((ok & di).sum()),
                                                               int(di.sum())),
                     "named right, not distinguishable": rate_text(int((ok & ~di).sum()),
                                                                   int((~di).sum()))})
    pairs = (wrong_to_rival.assign(pair=wrong_to_rival["class"] + " named "
                                   + wrong_to_rival.predicted)
             .groupby("pair").distinguishable
             .agg(recordings="size", flagged_not=lambda x: int((~x.astype(bool)).sum()))
             .reset_index().sort_values("recordings", ascending=False))
    lines = [
        "# The answer's closest rival, read against the truth",
        "",
        "Generated by `experiments/rival_evidence.py` (design and predictions in its "
        "docstring, written before the run): every recording of the independent sets A–I, X "
        "and Y diagnosed with its model YAML at the package's defaults; `tests.rival` is "
        "Vuong's (1989) test of the answer against the closest other hypothesis that passed "
        "every gate (`stictionbench/diagnosis/rival.py`). Wilson 95 % intervals. Nothing is "
        "tuned here.",
        "",
        f"- recordings: {len(m)}; physics answers: {len(phys)}, of which with a rival "
        f"{len(with_rival)} ({rate_text(len(with_rival), len(phys))});",
        f"- among them, named right when distinguishable {rate_text(a, a + b)}, when not "
        f"{rate_text(c, c + d)} (Fisher's exact test, one-sided, p = {p_f:.2g});",
        f"- wrong answers whose true class is the rival: {len(wrong_to_rival)}, flagged not "
        f"distinguishable {rate_text(flagged, len(wrong_to_rival))};",
        f"- healthy loops called physics: {len(healthy)}, with a rival "
        f"{int(healthy.rival.notna().sum())}, of them not distinguishable "
        f"{healthy_flagged}.",
        "",
        "## By level",
        "",
        to_markdown(pd.DataFrame(rows)),
        "",
        "## Wrong answers whose truth was the rival",
        "",
        to_markdown(pairs) if len(pairs) else "(none)",
        "",
        "## The predictions",
        "",
        f"1. Verdicts equal to the stored ones: {same} of {len(m)}: {word[pred1]}.",
        f"2. Distinguishable answers right more often: {rate_text(a, a + b)} against "
        f"{rate_text(c, c + d)}, p = {p_f:.2g}: {word[pred2]}.",
        f"3. Wrong answers to the rival flagged not distinguishable: "
        f"{rate_text(flagged, len(wrong_to_rival))}: {word[pred3]}.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    return stored_experiment(__doc__, STEM, one, cases, ["set", "name"], report, argv)


if __name__ == "__main__":
    raise SystemExit(main())
