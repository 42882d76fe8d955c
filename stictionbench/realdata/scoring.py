"""Scoring verdicts against labels by physical loop (group), never by window, with
leave-one-group-out (LOGO) re-tuning of the rule's thresholds."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import pandas as pd

from .verdict import StictionRule

AXIS_GRID = tuple(np.round(np.arange(0.10, 0.71, 0.05), 2))
RESIDUAL_GRID = (0.3, 0.35, 0.4, 0.45, 0.5, 0.6, 1.0)


def binary_label(label: Any) -> str | None:
    """``stiction`` stays; every other diagnosis (disturbance, tuning, dead zone ...) is
    ``no_stiction``; missing labels give None."""
    if label is None or (isinstance(label, float) and np.isnan(label)):
        return None
    return "stiction" if str(label).strip().lower() == "stiction" else "no_stiction"


def group_verdicts(entries: Sequence[dict], rule: StictionRule) -> pd.DataFrame:
    """One row per group: the majority verdict of its usable windows (a tie counts as
    stiction), ``unusable`` when none is usable, and the group's label."""
    rows = []
    df = pd.DataFrame(entries)
    for g, sub in df.groupby("group", sort=True):
        verdicts = [rule.decide(e) for e in sub.to_dict("records")]
        usable = [v for v in verdicts if v != "unusable"]
        if not usable:
            v = "unusable"
        else:
            v = "stiction" if sum(x == "stiction" for x in usable) * 2 >= len(usable) \
                else "no_stiction"
        labels = {binary_label(x) for x in sub["label"]} - {None}
        rows.append({"group": g, "windows": len(sub), "usable_windows": len(usable),
                     "label": labels.pop() if len(labels) == 1 else None, "verdict": v})
    return pd.DataFrame(rows)


def balanced_accuracy(groups: pd.DataFrame) -> tuple[float, pd.DataFrame]:
    """Balanced accuracy over labelled groups with a verdict, and the confusion matrix
    (rows: label, columns: verdict, unusable shown but not scored)."""
    conf = pd.crosstab(groups["label"], groups["verdict"]).reindex(
        index=["stiction", "no_stiction"], columns=["stiction", "no_stiction", "unusable"],
        fill_value=0)
    recalls = []
    for lab in ("stiction", "no_stiction"):
        tot = conf.loc[lab, "stiction"] + conf.loc[lab, "no_stiction"]
        if tot:
            recalls.append(conf.loc[lab, lab] / tot)
    return (float(np.mean(recalls)) if recalls else float("nan")), conf


def tune(entries: Sequence[dict], base: StictionRule) -> StictionRule:
    """The grid thresholds with the best group balanced accuracy (ties: closest to the
    default rule, so the defaults win unless the data say otherwise)."""
    best = None
    for a, r in itertools.product(AXIS_GRID, RESIDUAL_GRID):
        rule = replace(base, min_axis_ratio=float(a), max_residual=float(r))
        ba, _ = balanced_accuracy(group_verdicts(entries, rule))
        key = (-(ba if np.isfinite(ba) else -1), abs(a - base.min_axis_ratio)
               + abs(r - base.max_residual))
        if best is None or key < best[0]:
            best = (key, rule)
    assert best is not None
    return best[1]


def logo(entries: Sequence[dict], base: StictionRule) -> tuple[float, pd.DataFrame]:
    """Leave-one-group-out: for each group, tune the thresholds on the other groups and
    give the held-out group the verdict of that rule."""
    groups = sorted({e["group"] for e in entries})
    rows = []
    for g in groups:
        train = [e for e in entries if e["group"] != g]
        test = [e for e in entries if e["group"] == g]
        rule = tune(train, base)
        gv = group_verdicts(test, rule).iloc[0].to_dict()
        gv.update(min_axis_ratio=rule.min_axis_ratio, max_residual=rule.max_residual)
        rows.append(gv)
    out = pd.DataFrame(rows)
    ba, _ = balanced_accuracy(out)
    return ba, out
