"""A combined stiction verdict from the published detectors, fitted on one dataset and
scored on another.

The model has three settings: which methods vote, the share of stiction votes among
the methods that decided (``threshold``) and how many must have decided
(``min_votes``); fewer decided methods give ``inconclusive``. :func:`fit` chooses them by
exhaustive search on the training loops (balanced accuracy by loop; ties go to more
methods, a threshold nearer one half, fewer required votes — the least tuned choice).
:func:`cross_dataset` trains on each dataset and scores on the other; :func:`lolo`
leaves one loop out within a dataset.
"""

from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..errors import InputError
from .compare import balanced_accuracy
from .panel import PUBLISHED

THRESHOLDS = (1 / 3, 0.5, 2 / 3, 1.0)
MIN_VOTES = (1, 2)


@dataclass(frozen=True)
class Consensus:
    """Vote of ``methods``: stiction when at least ``min_votes`` decided and the share of
    stiction votes among them is ≥ ``threshold``."""

    methods: tuple[str, ...] = PUBLISHED
    threshold: float = 0.5
    min_votes: int = 1

    def decide(self, row: pd.Series | dict[str, Any]) -> tuple[str, str]:
        """``(verdict, reason)`` for one loop or window of method verdicts.

        Examples
        --------
        >>> Consensus(("a", "b", "c")).decide({"a": "stiction", "b": "no_stiction",
        ...                                    "c": "inconclusive"})
        ('stiction', '1 of 2 deciding methods say stiction (a)')
        """
        votes = {m: row[m] for m in self.methods if row[m] in ("stiction", "no_stiction")}
        if len(votes) < self.min_votes:
            return "inconclusive", f"{len(votes)} method(s) decided, {self.min_votes} needed"
        yes = [m for m, v in votes.items() if v == "stiction"]
        verdict = "stiction" if len(yes) / len(votes) >= self.threshold else "no_stiction"
        return verdict, (f"{len(yes)} of {len(votes)} deciding methods say stiction"
                         + (f" ({', '.join(yes)})" if yes else ""))

    def apply(self, loops: pd.DataFrame) -> pd.Series:
        return pd.Series([self.decide(r)[0] for _, r in loops.iterrows()], index=loops.index)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["methods"] = list(self.methods)
        return d

    @classmethod
    def load(cls, path: str | Path | None = None) -> Consensus:
        """The consensus in ``path`` (default: the shipped ``conf/consensus/default.yaml``)."""
        import yaml

        from .. import strict_yaml
        from ..config import conf_dir

        p = Path(path) if path else conf_dir() / "consensus" / "default.yaml"
        try:
            d = strict_yaml.load(p.read_text(encoding="utf-8")) or {}
            c = cls(tuple(d["methods"]), float(d["threshold"]), int(d["min_votes"]))
        except KeyError as exc:
            raise InputError(f"{p}: not a consensus file (no {exc} key)") from None
        except (OSError, TypeError, ValueError, yaml.YAMLError) as exc:
            raise InputError(f"{p}: not a consensus file ({exc})") from None
        unknown = [m for m in c.methods if m not in PUBLISHED]
        if not c.methods or unknown:
            raise InputError(f"{p}: methods must be some of {', '.join(PUBLISHED)}"
                             + (f"; unknown: {', '.join(map(str, unknown))}" if unknown
                                else "; none given"))
        if not 0.0 < c.threshold <= 1.0:  # NaN fails too
            raise InputError(f"{p}: threshold is a share of the deciding methods' votes, "
                             f"in (0, 1]; got {c.threshold}")
        if c.min_votes < 1:
            raise InputError(f"{p}: min_votes must be at least 1; got {c.min_votes}")
        return c


def _tie_key(c: Consensus) -> tuple[float, float, int]:
    return (-len(c.methods), abs(c.threshold - 0.5), c.min_votes)


def _votes(loops: pd.DataFrame, candidates: tuple[str, ...]) -> np.ndarray:
    """+1 stiction, −1 no stiction, 0 otherwise: loops × candidates."""
    v = loops[list(candidates)].to_numpy(dtype=object)
    return (v == "stiction").astype(int) - (v == "no_stiction").astype(int)


def _ba(labels: np.ndarray, flagged: np.ndarray) -> float:
    rec = [float(np.mean(flagged[labels == 1])) if np.any(labels == 1) else None,
           float(np.mean(~flagged[labels == 0])) if np.any(labels == 0) else None]
    rec = [r for r in rec if r is not None]
    return float(np.mean(rec)) if rec else float("nan")


def fit(loops: pd.DataFrame, candidates: tuple[str, ...] = PUBLISHED) -> Consensus:
    """The consensus with the best balanced accuracy on ``loops`` (labelled rows),
    searched exhaustively over method subsets, thresholds and vote counts."""
    loops = loops[loops["label"].notna()]
    votes = _votes(loops, candidates)
    labels = (loops["label"] == "stiction").to_numpy().astype(int)
    best: tuple[float, tuple, Consensus] | None = None
    for k in range(1, len(candidates) + 1):
        for idx in itertools.combinations(range(len(candidates)), k):
            sub = votes[:, list(idx)]
            yes = (sub == 1).sum(axis=1)
            dec = (sub != 0).sum(axis=1)
            share = np.divide(yes, dec, out=np.zeros(len(yes)), where=dec > 0)
            for th in THRESHOLDS:
                for mv in MIN_VOTES:
                    if mv > k:
                        continue
                    flagged = (dec >= mv) & (share >= th - 1e-12)
                    c = Consensus(tuple(candidates[i] for i in idx), th, mv)
                    ba = _ba(labels, flagged)
                    key = (-ba if np.isfinite(ba) else 1.0, _tie_key(c))
                    if best is None or key < (best[0], best[1]):
                        best = (key[0], key[1], c)
    assert best is not None
    return best[2]


def score(c: Consensus, loops: pd.DataFrame) -> dict[str, Any]:
    """Balanced accuracy, detections, false alarms and inconclusive loops of ``c``."""
    v = c.apply(loops)
    lab = loops["label"]
    return {"balanced_accuracy": balanced_accuracy(lab, v),
            "detected": f"{int(((lab == 'stiction') & (v == 'stiction')).sum())}/"
                        f"{int((lab == 'stiction').sum())}",
            "false_alarms": f"{int(((lab == 'no_stiction') & (v == 'stiction')).sum())}/"
                            f"{int((lab == 'no_stiction').sum())}",
            "inconclusive": int((v == "inconclusive").sum())}


def lolo(loops: pd.DataFrame, candidates: tuple[str, ...] = PUBLISHED) -> pd.Series:
    """Leave-one-loop-out verdicts: each loop judged by a consensus fitted without it."""
    out = {}
    for i in loops.index:
        c = fit(loops.drop(index=i), candidates)
        out[i] = c.decide(loops.loc[i])[0]
    return pd.Series(out)


def cross_dataset(sets: dict[str, pd.DataFrame],
                  candidates: tuple[str, ...] = PUBLISHED) -> pd.DataFrame:
    """Train on each dataset, score on every dataset (the diagonal is in-sample), plus
    leave-one-loop-out within each and the untrained majority of all methods."""
    rows = []
    for train, tl in sets.items():
        c = fit(tl, candidates)
        for test, sl in sets.items():
            rows.append({"trained_on": train, "scored_on": test,
                         "out_of_sample": train != test, **score(c, sl),
                         "consensus": f"{'+'.join(c.methods)}, share ≥ {c.threshold:.2f}, "
                                      f"≥ {c.min_votes} vote(s)"})
    for name, sl in sets.items():
        v = lolo(sl, candidates)
        lab = sl["label"]
        rows.append({"trained_on": f"{name} minus the held-out loop", "scored_on": name,
                     "out_of_sample": True,
                     "balanced_accuracy": balanced_accuracy(lab, v.reindex(sl.index)),
                     "detected": f"{int(((lab == 'stiction') & (v == 'stiction')).sum())}/"
                                 f"{int((lab == 'stiction').sum())}",
                     "false_alarms": f"{int(((lab == 'no_stiction') & (v == 'stiction')).sum())}"
                                     f"/{int((lab == 'no_stiction').sum())}",
                     "inconclusive": int((v == "inconclusive").sum()),
                     "consensus": "refitted for every held-out loop"})
    plain = Consensus(candidates)
    for name, sl in sets.items():
        rows.append({"trained_on": "nothing (majority of all published methods)",
                     "scored_on": name, "out_of_sample": True, **score(plain, sl),
                     "consensus": f"{'+'.join(plain.methods)}, share ≥ 0.50, ≥ 1 vote"})
    return pd.DataFrame(rows)
