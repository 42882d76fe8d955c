"""The first release on the holdout family: is that family as hard as the judged set, and
what does today's diagnosis project onto the judged set through it?

``first_release.py`` anchors the independent sets to the judged set through the first
release (the only diagnosis scored on both) and finds them much harder: the first release
names 7.2 and 2.4 of 16 there against 12 and 7 on the judged set. The same anchor on the
package's own holdout family (``experiments/holdout_family.py``; its fresh block, seeds
from 21000: the recordings of ``holdout_fresh.md``) says how far that family stands from
the judged set, and projects today's verdicts on it onto the judged set by the same method
(:func:`first_release.projected`; :func:`first_release.tail_at_least` for how likely the
first release's judged scores are on a set as hard as this one).

Method: every recording of the block written as ``holdout_family.py`` writes it (CSV and
model YAML), the first release run on it as a user ran it then
(:func:`first_release.diagnose_first`, cached per recording in
``.cache/first_release/holdout_21000/``), today's verdicts read from ``--today`` (default
``reports/concealed/holdout_fresh.csv``, written by ``make concealed``; any diagnosis's
verdicts on the same recordings can be projected, e.g. another high-pass order's).

Several blocks pool into one projection (``--blocks 21000 22000 …`` with ``--today
reports/concealed/holdout_pooled.csv``, whose verdicts ``make holdout-pooled`` writes for
every block): a block holds 12 recordings per class and level, so the cells the projection
reads (a class's recordings the first release missed) are often empty in one block, and
an empty cell contributes only its prior.

Run: ``.venv/bin/python experiments/first_release_holdout.py [--today CSV] [--blocks
SEED ...] [--name STEM] [--jobs 2]``; writes ``reports/concealed/STEM.{md,csv}`` (default
stem ``first_release_holdout``, default block 21000).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import first_release as fr  # noqa: E402
import holdout_family as hf  # noqa: E402
from concealed import recording_name  # noqa: E402
from concealed_families import CLASSES  # noqa: E402
from fresh_recordings import run  # noqa: E402

from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import balanced_text, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

#: the default holdout block (``make concealed``'s ``holdout_fresh``): seeds per class, for
#: none
BLOCK, SEEDS, NONE_SEEDS = 21000, 12, 24


def here(block: int) -> Path:
    """The block's working folder (recordings, the first release's cached verdicts)."""
    return fr.WORK / f"holdout_{block}"


def write_block(data: Path, block: int = BLOCK) -> pd.DataFrame:
    """The block's recordings in ``data`` (written once); one row per recording."""
    data.mkdir(parents=True, exist_ok=True)
    rows = []
    for lvl in (1, 2):
        for cls in CLASSES:
            for seed in range(block, block + (NONE_SEEDS if cls == "none" else SEEDS)):
                name = recording_name(hf.draw(cls, lvl, seed))
                if not (data / f"{name}.model.yaml").is_file():
                    job = hf.generate(cls, lvl, seed, data)
                    Path(job["model"]).replace(data / f"{name}.model.yaml")
                rows.append({"name": name, "level": lvl, "class": cls, "seed": seed,
                             "block": block})
    return pd.DataFrame(rows)


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """Per level: the first release's score here against its judged score, how likely that
    judged score is on a set as hard as this one, today's score, and today's projection
    onto the judged set."""
    out = []
    for lvl, g in df.groupby("level"):
        counts = [(int((x["first"] == c).sum()), len(x)) for c, x in g.groupby("class")]
        draws = fr.projected(g, fr.JUDGED_RIGHT[lvl])
        lo, hi = np.percentile(draws, [2.5, 97.5])
        out.append({
            "level": lvl,
            "first release here, of 16": balanced_text(g["first"] == g["class"], g["class"]),
            "first release on the judged set": f"{fr.JUDGED[lvl]} of 16",
            "P(first release ≥ its judged score) on a set this hard":
                f"{fr.tail_at_least(counts, fr.JUDGED[lvl]):.2f}",
            "today here, of 16": balanced_text(g["predicted"] == g["class"], g["class"]),
            "today projected onto the judged set":
                f"{np.median(draws):.1f} [{lo:.1f}, {hi:.1f}]",
            "goal": f"{fr.GOAL[lvl]} of 16",
            "P(projection ≥ goal)": f"{(draws >= fr.GOAL[lvl]).mean():.2f}"})
    return pd.DataFrame(out)


def cells(df: pd.DataFrame) -> pd.DataFrame:
    """Per level and class: today's named-right rate on the recordings the first release
    named right and on those it missed, beside the judged set's count of each."""
    out = []
    for (lvl, cls), g in df.groupby(["level", "class"]):
        ok, hit = g["predicted"] == cls, g["first"] == cls
        right = fr.JUDGED_RIGHT[lvl][cls]
        out.append({"level": lvl, "class": cls,
                    "today, where the first release was right": rate_text(
                        int(ok[hit].sum()), int(hit.sum())),
                    "judged set: first release right": right,
                    "today, where the first release missed": rate_text(
                        int(ok[~hit].sum()), int((~hit).sum())),
                    "judged set: first release missed": fr.JUDGED_PER_CLASS - right})
    return pd.DataFrame(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--today", type=Path, default=fr.OUT / "holdout_fresh.csv",
                    help="today's verdicts on the block (name, predicted_default)")
    ap.add_argument("--blocks", type=int, nargs="+", default=[BLOCK],
                    help="first seeds of the holdout blocks pooled (default 21000)")
    ap.add_argument("--name", default="first_release_holdout", help="output stem")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if not a.name or Path(a.name).name != a.name:
        print(f"first_release_holdout: --name {a.name!r}: a file stem, not a path",
              file=sys.stderr)
        return 2
    if not a.today.is_file():
        print(f"first_release_holdout: {a.today}: no such file (run `make concealed`)",
              file=sys.stderr)
        return 2
    today = pd.read_csv(a.today, usecols=["name", "predicted_default"]).rename(
        columns={"predicted_default": "predicted"})
    if any(b % 1000 or b < 0 for b in a.blocks) or len(set(a.blocks)) < len(a.blocks):
        print(f"first_release_holdout: --blocks {a.blocks}: distinct non-negative "
              "multiples of 1000 (a block's first seed)", file=sys.stderr)
        return 2
    blocks = pd.concat([write_block(here(b) / "data", b) for b in a.blocks],
                       ignore_index=True)
    missing = sorted(set(blocks.name) - set(today.name))
    if missing:
        print(f"first_release_holdout: {a.today}: lacks {len(missing)} recording(s) of the "
              f"block(s), e.g. {missing[0]}", file=sys.stderr)
        return 2
    code = str(fr.extract(fr.FIRST, fr.WORK / "code"))
    jobs = []
    for b in a.blocks:
        (here(b) / "work").mkdir(parents=True, exist_ok=True)
        jobs += [(code, str(here(b) / "data"), str(here(b) / "work"), n)
                 for n in blocks.name[blocks.block == b]]
    first = run(fr.diagnose_first, jobs, a.jobs)
    df = blocks.merge(first, on="name", validate="one_to_one").merge(
        today, on="name", validate="one_to_one")
    if a.blocks == [BLOCK]:
        df = df.drop(columns="block")
        what = (f"the holdout family's block from seed {BLOCK} ({len(df)} recordings, the "
                "ones of `holdout_fresh.md`)")
    else:
        what = (f"the holdout family's blocks from seeds {', '.join(map(str, a.blocks))} "
                f"({len(df)} recordings)")
    with atomic_path(fr.OUT / f"{a.name}.csv") as tmp:
        df.to_csv(tmp, index=False)
    text = "\n".join([
        "# The first release on the holdout family, and the projection through it", "",
        "Generated by `experiments/first_release_holdout.py` (method in its docstring): "
        f"{what}, the first release (`{fr.FIRST}`) run on each as a user ran it "
        f"then, today's verdicts from `{a.today.name}`. Scores of 16 weigh classes equally, "
        "95 % intervals.", "",
        to_markdown(summary(df)), "",
        *([] if a.blocks == [BLOCK] else [
            "The cells the projection reads: today's verdicts right, per class and level, "
            "on the recordings the first release named right and on those it missed, and "
            "how many of each the judged set holds (the issue's misses).", "",
            to_markdown(cells(df)), ""]),
        "Reading: where the first release's judged scores are likely on a set as hard as "
        f"{'this block, the block is' if a.blocks == [BLOCK] else 'these blocks, they are'} "
        "a nearer stand-in for the judged set than the "
        "independent sets (`first_release.md`), and the projection through it the nearer "
        "estimate of what today's diagnosis would score there.", "",
        f"The first release refused {int((df['first'] == 'error').sum())} of {len(df)} "
        "recordings.", ""])
    write_text(fr.OUT / f"{a.name}.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
