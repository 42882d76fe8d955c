"""Fresh blind-generator sets and the scores of competing verdict rules on them, shared by
the experiments that score a variant of the diagnosis against the shipped rule
(``split_vote.py``, ``arma_diagnosis.py``, ``arma_tests.py``).

A *verdict table* has one row per recording with ``part``, ``generator``, ``class``,
``level`` and one column of predicted physics per rule.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from stictionbench.rates import (  # noqa: E402
    balanced_score,
    balanced_text,
    mcnemar_p,
    rate_text,
)

DATA = ROOT / ".cache" / "blindgen"
#: recordings per class and level of a fresh set
PER_CLASS = 12


def draw_sets(sets: dict[str, tuple[str, int]], per_class: int = PER_CLASS) -> None:
    """Write each fresh set ``name → (generator folder, first seed)`` under :data:`DATA`
    with its generator, unless it is there (same seed, byte-identical files)."""
    for name, (gen, seed) in sets.items():
        out = DATA / name
        if (out / "truth.csv").exists():
            continue
        subprocess.run([sys.executable, str(ROOT / "experiments" / gen / "generate.py"),
                        "--out", str(out), "--per-class", str(per_class),
                        "--first-seed", str(seed)], check=True, stdout=subprocess.DEVNULL)


def level_score(g: pd.DataFrame, rule: str, level: int) -> float:
    """``rule``'s score of 16 (the eight classes weighed equally) at ``level``."""
    gl = g[g.level == level]
    return balanced_score(gl[rule] == gl["class"], gl["class"])[0]


def level_scores(w: pd.DataFrame, rules: tuple[str, ...], new: str, base: str,
                 paired_label: str, pooled: str = "both") -> pd.DataFrame:
    """Per part, generator (and the generators pooled) and level: each rule's score of 16 and
    healthy loops called physics, and McNemar's test of ``new`` against ``base`` on the
    recordings right under one only (column ``paired_label``); the generators pooled
    are labelled ``pooled``."""
    rows = []
    for (part, gen), g in [*w.groupby(["part", "generator"]),
                           *[((p, pooled), g) for p, g in w.groupby("part")]]:
        for lv in (1, 2):
            gl = g[g.level == lv]
            h = gl[gl["class"] == "none"]
            row = {"part": part, "generator": gen, "level": lv}
            for rule in rules:
                row[f"{rule}: of 16"] = balanced_text(gl[rule] == gl["class"], gl["class"])
                row[f"{rule}: healthy called physics"] = rate_text(
                    int((h[rule] != "none").sum()), len(h))
            a, b = gl[new] == gl["class"], gl[base] == gl["class"]
            only_new, only_base = int((a & ~b).sum()), int((b & ~a).sum())
            row[paired_label] = (f"{only_new} / {only_base} "
                                 f"(p = {mcnemar_p(only_new, only_base):.2g})")
            rows.append(row)
    return pd.DataFrame(rows)


def per_class_rates(w: pd.DataFrame, rules: tuple[str, ...]) -> pd.DataFrame:
    """Named right per class and level under each rule, each part pooled."""
    rows = []
    for (part, cls, lv), g in w.groupby(["part", "class", "level"]):
        rows.append({"part": part, "class": cls, "level": lv,
                     **{r: rate_text(int((g[r] == cls).sum()), len(g)) for r in rules}})
    return pd.DataFrame(rows)


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).parent))
    from concealed_families import library_main

    library_main(__doc__, __file__)
