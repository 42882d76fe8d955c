"""The line test (``stictionbench/diagnosis/line.py``) measured: what it renames, on
which data, and what the threshold costs elsewhere.

The question. On the independent generators, oscillatory disturbances whose period and
amplitude wander (generator C: ±3 % and ±15 %, as real plant oscillations do) were named
a dead time, a dead band or a sensor lag: a fixed-phase sinusoid does not fit them, while
a shifted or reshaped replay of OP follows the controller's echo of the oscillation in
OP. Such a fit gains at the residual's line alone and adds error everywhere else; a
physics that is there gains wherever it changes the prediction. The shipped rule names
the line when a dead time's or sensor lag's share of its improvement at the line is
above ``LINE_SHARE`` = 1, a bound from that argument, not fitted.

Where each number comes from, and which are in-sample:

* the idea came from looking at the level-1 misses of sets A–E (``make independent``)
  and at 120 of their recordings (both generators) through a prototype of the share, so
  **A–E are in-sample for the idea**;
* the threshold was checked, not tuned, on a fresh block of the package author's holdout
  family (block :data:`HOLDOUT_BLOCK`, never used before): there 0.8, the first value
  tried, lost 18 correct verdicts, whose loops' OP itself is dominated by one line (the
  holdout family's loops), and the bound 1 lost one;
* **sets F and G are out of sample**: fresh seeds of the two independent generators
  (13000 and 15000), drawn and diagnosed after the rule and its bound were fixed;
* one amendment came after F and G were scored: the rule first replaced any OP-driven
  pick (valves, characteristic, travel limit too). On the package's own regulatory limit
  cycles that renamed sticky valves (``experiments/fast_loops.py``, a model given, loops
  of 8 samples or slower: 18 → 12 of 36 named sticky; the ISDB loop CHEM10 too, until a
  reproduced cycle was made to keep it): a valve in a limit cycle gains at the cycle's
  line by nature, and whether it explains the cycle from inside the loop is the
  closed-loop cycle check's question. So only a dead time or a sensor lag is replaced.
  On F and G that gives back 3 of the 5 recordings the first rule gained there;
* **sets H and I are out of sample for the amended (shipped) rule**: fresh seeds again
  (17000 and 19000), drawn and diagnosed after the amendment, and scored once.

Every verdict here is re-decided from the stored evidence (``concealed.decide``) with
and without the line test, so the comparison is of the rule alone, on the same fits;
``decide`` reproduces the stored verdicts (checked, and printed). Writes
``reports/concealed/line_confinement.{md,csv,png}``. Run: ``.venv/bin/python
experiments/line_confinement.py [--jobs 2]`` after ``make independent`` (the holdout
block is run once, about 5 minutes on 2 cores, and cached in ``.cache/holdout_blocks``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

from concealed import decide  # noqa: E402
from holdout_pooled import block_rows  # noqa: E402

from stictionbench.diagnosis.evidence import ALPHA, MIN_IMPROVEMENT  # noqa: E402
from stictionbench.diagnosis.line import LINE_SHARE, OP_DRIVEN  # noqa: E402
from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import balanced_text, rate_text  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

HOLDOUT_BLOCK = 41000
#: the independent sets, their generator and whether the line test was looked at on them
SETS = {"a": ("A", "in-sample"), "b": ("A", "in-sample"), "c": ("C", "in-sample"),
        "d": ("A", "in-sample"), "e": ("C", "in-sample"), "f": ("A", "out of sample"),
        "g": ("C", "out of sample"), "h": ("A", "fresh"), "i": ("C", "fresh")}
THRESHOLDS = (0.6, 0.8, 1.0, 1.2, 1.5)
OSC = "oscillatory_disturbance"


def redecide(df: pd.DataFrame) -> pd.DataFrame:
    """Each stored row decided without the line test (``before``), with it (``after``)
    and with it at every bound of :data:`THRESHOLDS` (``at <bound>``), with the share of
    the line of the verdict before (``share``; NaN where that verdict is not OP-driven or
    the share is undefined; a verdict named after the comparison, from OP held at a
    limit or the set-point gain test, is never tested)."""
    out: dict[str, list] = {"before": [], "after": [], "share": []}
    out |= {f"at {th:g}": [] for th in THRESHOLDS}
    for _, r in df.iterrows():
        b = decide(r.drop("line_shares"), ALPHA, MIN_IMPROVEMENT)
        out["before"].append(b)
        at = {th: decide(r, ALPHA, MIN_IMPROVEMENT, line_share=th) for th in THRESHOLDS}
        # the shipped bound is among those swept: its verdict is not decided twice
        out["after"].append(at[LINE_SHARE] if LINE_SHARE in at
                            else decide(r, ALPHA, MIN_IMPROVEMENT))
        for th in THRESHOLDS:
            out[f"at {th:g}"].append(at[th])
        s = json.loads(r["line_shares"]).get(b) if b in OP_DRIVEN else None
        out["share"].append(np.nan if s is None else float(s))
    return df.assign(**out)


def load(jobs: int) -> pd.DataFrame:
    """The holdout block and the independent sets, re-decided, in one frame."""
    parts = []
    h = block_rows(HOLDOUT_BLOCK, ROOT / ".cache" / "holdout_blocks", jobs)
    h = h.rename(columns={"predicted_default": "predicted"})
    parts.append(redecide(h).assign(data=f"holdout block {HOLDOUT_BLOCK}",
                                    generator="holdout", sample="threshold checked"))
    for s, (gen, sample) in SETS.items():
        csv = ROOT / "reports" / "concealed" / f"independent_set_{s}.csv"
        if not csv.is_file():
            raise SystemExit(f"{csv} missing: run make independent first")
        df = pd.read_csv(csv)
        parts.append(redecide(df).assign(data=f"set {s.upper()}", generator=gen,
                                         sample=sample))
    cols = ["data", "generator", "sample", "name", "class", "level", "predicted", "before",
            "after", "share"] + [f"at {th:g}" for th in THRESHOLDS]
    return pd.concat([p[cols] for p in parts], ignore_index=True)


def score_rows(df: pd.DataFrame) -> list[dict]:
    """Per data group and level: the score of 16 and the `none` false alarms without and
    with the line test."""
    rows = []
    groups = [("holdout block", df["generator"] == "holdout"),
              ("sets A–E (in-sample for the idea)", df["sample"] == "in-sample"),
              ("sets F, G (out of sample)", df["sample"] == "out of sample"),
              ("set F (generator A)", df["data"] == "set F"),
              ("set G (generator C)", df["data"] == "set G"),
              ("sets H, I (out of sample for the amended rule)", df["sample"] == "fresh"),
              ("set H (generator A)", df["data"] == "set H"),
              ("set I (generator C)", df["data"] == "set I")]
    for label, m in groups:
        for lvl, g in df[m].groupby("level"):
            none = g["class"] == "none"
            ok_b, ok_a = g["before"] == g["class"], g["after"] == g["class"]
            rows.append({
                "data": label, "level": lvl, "recordings": len(g),
                "of 16 without": balanced_text(ok_b, g["class"]),
                "of 16 with": balanced_text(ok_a, g["class"]),
                "named right without": int(ok_b.sum()), "named right with": int(ok_a.sum()),
                "renamed": int((g["before"] != g["after"]).sum()),
                "oscillatory disturbances named": rate_text(
                    int(ok_a[g["class"] == OSC].sum()), int((g["class"] == OSC).sum())),
                "`none` called physics (with)": rate_text(
                    int((g.loc[none, "after"] != "none").sum()), int(none.sum()))})
    return rows


def sweep_rows(df: pd.DataFrame) -> list[dict]:
    """Named right at other bounds, re-decided from the same stored evidence (the
    shipped bound among them)."""
    rows = []
    for label, m in (("holdout block", df["generator"] == "holdout"),
                     ("sets A–E", df["sample"] == "in-sample"),
                     ("sets F, G", df["sample"] == "out of sample"),
                     ("sets H, I", df["sample"] == "fresh")):
        g = df[m]
        row = {"data": label, "recordings": len(g),
               "no line test": int((g["before"] == g["class"]).sum())}
        for th in THRESHOLDS:
            row[f"> {th:g}"] = int((g[f"at {th:g}"] == g["class"]).sum())
        rows.append(row)
    return rows


def figure(df: pd.DataFrame, out: Path) -> Path:
    """The share of the line of every OP-driven verdict before the line test: right
    verdicts against oscillatory disturbances named OP-driven physics, by data group."""
    fig, ax = new_figure(figsize=(8.5, 4.2))
    op = df[df["before"].isin(OP_DRIVEN) & df["share"].notna()]
    groups = [("holdout block", op["generator"] == "holdout"),
              ("sets A–E", op["sample"] == "in-sample"),
              ("sets F, G", op["sample"] == "out of sample"),
              ("sets H, I", op["sample"] == "fresh")]
    rng = np.random.default_rng(0)
    for i, (_label, m) in enumerate(groups):
        g = op[m]
        for kind, sel, colour in (("right OP-driven verdict", g["before"] == g["class"],
                                   "tab:blue"),
                                  ("an oscillatory disturbance", g["class"] == OSC,
                                   "tab:red"),
                                  ("other wrong verdict",
                                   (g["before"] != g["class"]) & (g["class"] != OSC),
                                   "tab:grey")):
            y = np.clip(g.loc[sel, "share"].to_numpy(), -0.5, 2.5)
            x = i + rng.uniform(-0.25, 0.25, y.size)
            ax.scatter(x, y, s=12, color=colour, alpha=0.7,
                       label=kind if i == 0 else None)
    ax.axhline(LINE_SHARE, color="k", lw=1, ls="--", label=f"LINE_SHARE = {LINE_SHARE:g}")
    ax.set_xticks(range(len(groups)), [lbl for lbl, _ in groups])
    ax.set_ylabel("share of the improvement at the residual's line (clipped to [−0.5, 2.5])")
    ax.set_title("OP-driven verdicts: where their improvement lies")
    ax.legend(fontsize=8, loc="upper left")
    return save_png(fig, out)


def report(df: pd.DataFrame, wall: float) -> str:
    moved = df[df["before"] != df["after"]]
    lines = ["# The line test: OP-driven physics that only explains an external line", "",
             f"Generated by `experiments/line_confinement.py` (its docstring has the "
             f"question and which data saw what). Every verdict re-decided from the stored "
             f"evidence without and with the line test (`LINE_SHARE` = {LINE_SHARE:g}, "
             "`stictionbench/diagnosis/line.py`). **Sets A–E are in-sample for the idea** "
             "(their misses suggested it); the holdout block checked the bound; **sets F "
             "and G are out of sample** (fresh seeds of both independent generators, drawn "
             "after the rule was fixed), except for one amendment made after they were "
             "scored: only a dead time or a sensor lag is replaced, no longer a valve, "
             "characteristic or travel limit (renaming sticky valves in the package's own "
             "regulatory limit cycles prompted it; on F and G it gives back 3 of the 5 "
             "recordings the first rule gained). **Sets H and I are out of sample for the "
             "shipped, amended rule** (fresh seeds drawn after the amendment, scored once). "
             "Wilson 95 % intervals; the score of 16 "
             "weighs classes equally.", "",
             "![shares](line_confinement.png)", "",
             to_markdown(pd.DataFrame(score_rows(df))), "",
             "## Named right at other bounds (same shares)", "",
             "A check of the bound, not its choice: 1 follows from the argument in "
             "`line.py` (above it the fit gains at the line and loses everywhere else).", "",
             to_markdown(pd.DataFrame(sweep_rows(df))), "",
             "## Every verdict the line test changed", ""]
    if len(moved):
        t = moved[["data", "name", "level", "class", "before", "after", "share"]].copy()
        t["share"] = t["share"].round(3)
        lines += [to_markdown(t.sort_values(["data", "level", "class"])), ""]
    else:
        lines += ["None.", ""]
    agree = float((df["after"] == df["predicted"]).mean())
    lines += [f"`decide` with the line test reproduces {agree:.1%} of the stored verdicts "
              f"(the diagnoses were run by the shipped code). Wall {wall:.0f} s.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "reports" / "concealed"))
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    df = load(a.jobs)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / "line_confinement.csv") as tmp:
        df.round({"share": 6}).to_csv(tmp, index=False, lineterminator="\n")
    figure(df, out / "line_confinement.png")
    text = report(df, time.perf_counter() - t0)
    write_text(out / "line_confinement.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
