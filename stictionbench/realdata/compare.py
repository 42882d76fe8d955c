"""One verdict per physical loop from the published detectors' window calls
(:mod:`.panel`), and each method scored on labelled loops (Jelali & Huang 2010, ch. 13):
:func:`loop_verdicts` takes the majority of a loop's decided windows, and
:func:`method_rates` gives every method's success, wrong and inconclusive rates with
Wilson intervals and its balanced accuracy.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable
from typing import Any

import numpy as np
import pandas as pd

from ..rates import rate_text, wilson
from .panel import (
    FAST,
    METHODS,
    PUBLISHED,
    VERDICTS,
    Call,
    as_call,
    loop_type,
    tag_type,
    window_calls,
)

#: names other modules and scripts import from here (the panel's among them)
__all__ = ["FAST", "METHODS", "PUBLISHED", "VERDICTS", "Call", "balanced_accuracy", "binary",
           "loop_type", "loop_verdicts", "method_rates", "tag_type", "window_calls"]


def binary(label: Any) -> str | None:
    """``stiction`` / ``no_stiction`` of a dataset label (ISDB's dead zone, disturbance
    and tuning labels are non-stiction); None when unlabelled."""
    if label is None or (isinstance(label, float) and math.isnan(label)):
        return None
    return "stiction" if str(label).strip().lower() == "stiction" else "no_stiction"


def loop_verdicts(windows: list[dict[str, Any]], methods: Iterable[str],
                  counts: Iterable[str] = ()) -> pd.DataFrame:
    """One row per physical loop (windows hold a :class:`Call` or a ``{"verdict",
    "reason"}`` dict per method): each method's majority over its decided windows
    (a tie, or no decided window, is inconclusive — with the commonest reason). For the
    methods in ``counts`` the row also gives the votes behind the majority:
    ``{m}_stiction_windows`` of ``{m}_decided_windows``."""
    counts = set(counts)
    rows = []
    by: dict[str, list[dict[str, Any]]] = {}
    for w in windows:
        by.setdefault(w["group"], []).append(w)
    for group, ws in by.items():
        row: dict[str, Any] = {"loop": group, "label": binary(ws[0]["label"]),
                               "loop_type": ws[0]["loop_type"], "windows": len(ws)}
        for m in methods:
            calls = [as_call(w[m]) for w in ws]
            votes = Counter(c.verdict for c in calls if c.verdict in VERDICTS[:2])
            if m in counts:
                row[f"{m}_stiction_windows"] = votes["stiction"]
                row[f"{m}_decided_windows"] = votes["stiction"] + votes["no_stiction"]
            if votes["stiction"] > votes["no_stiction"]:
                row[m] = "stiction"
            elif votes["no_stiction"] > votes["stiction"]:
                row[m] = "no_stiction"
            elif all(c.verdict == "unusable" for c in calls):
                row[m] = "unusable"
            else:
                row[m] = "inconclusive"
            reasons = Counter(c.reason for c in calls if c.verdict == row[m]
                              or row[m] == "inconclusive")
            row[f"{m}_reason"] = reasons.most_common(1)[0][0] if reasons else ""
        rows.append(row)
    return pd.DataFrame(rows).sort_values("loop", kind="stable").reset_index(drop=True)


def balanced_accuracy(labels: Iterable[str | None], verdicts: Iterable[str]) -> float:
    """Mean of the recall on stiction loops and on non-stiction loops; a verdict other
    than ``stiction`` counts as "not flagged". Unlabelled loops are left out; ``nan``
    unless both classes are there (a first version gave the one class's recall, which
    read as a balanced accuracy).

    Examples
    --------
    >>> balanced_accuracy(["stiction", "no_stiction"], ["stiction", "inconclusive"])
    1.0
    >>> balanced_accuracy(["stiction", "stiction", None], ["stiction", "no_stiction", "x"])
    nan
    """
    pairs = [(lab, v == "stiction") for lab, v in zip(labels, verdicts, strict=True)
             if lab is not None]
    rec = []
    for cls, flag in (("stiction", True), ("no_stiction", False)):
        hits = [f == flag for lab, f in pairs if lab == cls]
        if hits:
            rec.append(float(np.mean(hits)))
    return float(np.mean(rec)) if len(rec) == 2 else float("nan")


def method_rates(loops: pd.DataFrame, methods: Iterable[str]) -> pd.DataFrame:
    """Per method: correct / wrong / inconclusive loops (Wilson intervals), the
    detection and false-alarm rates, and the balanced accuracy."""
    rows = []
    lab = loops["label"]
    for m in methods:
        v = loops[m]
        decided = v.isin(VERDICTS[:2])
        correct = decided & (v == lab)
        n = int(lab.notna().sum())
        st, ns = lab == "stiction", lab == "no_stiction"
        det, fa = int((st & (v == "stiction")).sum()), int((ns & (v == "stiction")).sum())
        rows.append({
            "method": m,
            "in_sample": m not in PUBLISHED,
            "correct": rate_text(int(correct.sum()), n),
            "wrong": rate_text(int((decided & (v != lab)).sum()), n),
            "inconclusive": rate_text(int((~decided).sum()), n),
            "detected": rate_text(det, int(st.sum())),
            "false_alarms": rate_text(fa, int(ns.sum())),
            "balanced_accuracy": balanced_accuracy(lab, v),
            "correct_lo": wilson(int(correct.sum()), n)[0],
            "correct_hi": wilson(int(correct.sum()), n)[1],
        })
    return pd.DataFrame(rows)


def unreached(loops: pd.DataFrame, methods: Iterable[str]) -> tuple[pd.DataFrame, float]:
    """The labelled stiction loops that none of ``methods`` calls stiction, with each
    method's reason, and the balanced accuracy no vote of those methods can exceed.

    A vote (any subset, share or number of votes, :mod:`.consensus`) can flag only a loop
    that at least one voter flags, so it detects at most the ``k`` of ``n`` stiction loops
    some method flags, and its balanced accuracy (an inconclusive verdict counted as not
    flagged) is at most ``(k / n + 1) / 2``, the value with no false alarm at all.

    Returns
    -------
    (table, bound)
        One row per stiction loop no method flags (``loop``, ``loop_type``, ``reasons``:
        the distinct reasons, each with the methods that gave it), and the bound (nan
        when there is no labelled stiction loop).

    Examples
    --------
    >>> loops = pd.DataFrame({"loop": ["a", "b"], "label": ["stiction"] * 2,
    ...                       "loop_type": ["F", "A"], "m": ["stiction", "inconclusive"],
    ...                       "m_reason": ["", "no oscillation"]})
    >>> table, bound = unreached(loops, ["m"])
    >>> list(table.loop), bound
    (['b'], 0.75)
    """
    methods = list(methods)
    sticky = loops[loops["label"].map(binary) == "stiction"]
    if sticky.empty:
        return pd.DataFrame(columns=["loop", "loop_type", "reasons"]), float("nan")
    flagged = (sticky[methods] == "stiction").any(axis=1)
    rows = []
    for _, r in sticky[~flagged].iterrows():
        why: dict[str, list[str]] = {}
        for m in methods:
            text = str(r.get(f"{m}_reason", "") or r[m])
            why.setdefault(text, []).append(m)
        rows.append({"loop": r["loop"], "loop_type": r.get("loop_type", ""),
                     "reasons": "; ".join(f"{t} ({', '.join(ms)})" for t, ms in why.items())})
    bound = 0.5 * (float(flagged.sum()) / len(sticky) + 1.0)
    return pd.DataFrame(rows, columns=["loop", "loop_type", "reasons"]), bound
