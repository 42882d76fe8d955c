"""A combined stiction verdict from the published detectors, fitted on one dataset and
scored on another.

The model has three settings: which methods vote, the share of stiction votes among
the methods that decided (``threshold``) and how many must have decided
(``min_votes``); fewer decided methods give ``inconclusive``. :func:`fit` chooses them by
exhaustive search on the training loops. By default (``rule="one_se"``) it applies the
one-standard-error rule (Breiman et al., *Classification and Regression Trees*, 1984,
§3.4.3; Hastie, Tibshirani & Friedman, *The Elements of Statistical Learning*, 2nd ed.,
§7.10): of the settings whose training balanced accuracy is within one standard error of
the best, the one nearest the untrained vote of all methods (:func:`prior_distance`), so
that a handful of labelled loops moves the vote only as far as their evidence reaches.
``rule="best"`` is the first release's fit: the best balanced accuracy by loop, ties to
more methods, a threshold nearer one half, fewer required votes (the least tuned choice).
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
#: the ways :func:`fit` may choose: the best training score, or the one-standard-error rule
FIT_RULES = ("best", "one_se")


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


def prior_distance(c: Consensus, candidates: tuple[str, ...]) -> int:
    """How far ``c`` is from the untrained vote of all ``candidates`` (share ≥ 0.5, one
    vote): the methods it leaves out, plus one for another threshold, plus one for
    another vote count.

    Examples
    --------
    >>> prior_distance(Consensus(("a", "b"), 2 / 3, 1), ("a", "b", "c"))
    2
    """
    return (len(set(candidates) - set(c.methods)) + int(abs(c.threshold - 0.5) > 1e-12)
            + int(c.min_votes != 1))


def ba_standard_error(labels: np.ndarray, flagged: np.ndarray) -> float:
    """Standard error of a balanced accuracy: half the root of the two rates' binomial
    variances, each rate Laplace-smoothed (``(k + 1) / (n + 2)``) so that a perfect score
    on four loops is not read as certain.

    Examples
    --------
    >>> round(ba_standard_error(np.array([1, 1, 0, 0]), np.array([True, True, False, False])), 3)
    0.217
    """
    var = 0.0
    for cls, hit in ((1, flagged), (0, ~flagged)):
        n = int(np.sum(labels == cls))
        if n:
            p = (float(np.sum(hit[labels == cls])) + 1.0) / (n + 2.0)
            var += p * (1.0 - p) / n
    return 0.5 * float(np.sqrt(var))


def _votes(loops: pd.DataFrame, candidates: tuple[str, ...]) -> np.ndarray:
    """+1 stiction, −1 no stiction, 0 otherwise: loops × candidates."""
    v = loops[list(candidates)].to_numpy(dtype=object)
    return (v == "stiction").astype(int) - (v == "no_stiction").astype(int)


def _ba(labels: np.ndarray, flagged: np.ndarray) -> float:
    rec = [float(np.mean(flagged[labels == 1])) if np.any(labels == 1) else None,
           float(np.mean(~flagged[labels == 0])) if np.any(labels == 0) else None]
    rec = [r for r in rec if r is not None]
    return float(np.mean(rec)) if rec else float("nan")


def fit(loops: pd.DataFrame, candidates: tuple[str, ...] = PUBLISHED,
        rule: str = "one_se") -> Consensus:
    """The consensus chosen on ``loops`` (labelled rows), searched exhaustively over
    method subsets, thresholds and vote counts.

    ``rule="one_se"`` (the default since 2026-12-04): the one-standard-error rule
    (module docstring): among the settings within one standard error
    (:func:`ba_standard_error` of the best) of the best balanced accuracy, the one of
    least :func:`prior_distance`, then the higher score. It held better on loops the fit
    never saw (``experiments/consensus_one_se.py``, ``reports/real/consensus_one_se.md``:
    mean of the four out-of-sample balanced accuracies 0.738 → 0.757, its criterion
    written before the run). ``rule="best"``: the best balanced accuracy (ties to the
    least tuned setting), the first release's fit.
    """
    if rule not in FIT_RULES:
        raise InputError(f"consensus fit rule must be one of {', '.join(FIT_RULES)}; "
                         f"got {rule!r}")
    loops = loops[loops["label"].notna()]
    votes = _votes(loops, candidates)
    labels = (loops["label"] == "stiction").to_numpy().astype(int)
    if rule == "one_se":
        return _fit_one_se(votes, labels, candidates)
    best: tuple[float, tuple, Consensus] | None = None
    for c, flagged in _settings(votes, candidates):
        ba = _ba(labels, flagged)
        key = (-ba if np.isfinite(ba) else 1.0, _tie_key(c))
        if best is None or key < (best[0], best[1]):
            best = (key[0], key[1], c)
    assert best is not None
    return best[2]


def _settings(votes: np.ndarray, candidates: tuple[str, ...]):
    """Every setting of the search with the loops it flags."""
    for k in range(1, len(candidates) + 1):
        for idx in itertools.combinations(range(len(candidates)), k):
            sub = votes[:, list(idx)]
            yes = (sub == 1).sum(axis=1)
            dec = (sub != 0).sum(axis=1)
            share = np.divide(yes, dec, out=np.zeros(len(yes)), where=dec > 0)
            for th in THRESHOLDS:
                for mv in MIN_VOTES:
                    if mv <= k:
                        yield (Consensus(tuple(candidates[i] for i in idx), th, mv),
                               (dec >= mv) & (share >= th - 1e-12))


def _fit_one_se(votes: np.ndarray, labels: np.ndarray,
                candidates: tuple[str, ...]) -> Consensus:
    scored = [(c, _ba(labels, f), f) for c, f in _settings(votes, candidates)]
    finite = [s for s in scored if np.isfinite(s[1])]
    if not finite:
        return Consensus(candidates)
    top = max(finite, key=lambda s: s[1])
    floor = top[1] - ba_standard_error(labels, top[2]) - 1e-12
    near = [s for s in finite if s[1] >= floor]
    return min(near, key=lambda s: (prior_distance(s[0], candidates), -s[1],
                                    _tie_key(s[0])))[0]


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


def lolo(loops: pd.DataFrame, candidates: tuple[str, ...] = PUBLISHED,
         rule: str = "one_se") -> pd.Series:
    """Leave-one-loop-out verdicts: each loop judged by a consensus fitted without it."""
    out = {}
    for i in loops.index:
        c = fit(loops.drop(index=i), candidates, rule)
        out[i] = c.decide(loops.loc[i])[0]
    return pd.Series(out)


def cross_dataset(sets: dict[str, pd.DataFrame],
                  candidates: tuple[str, ...] = PUBLISHED, rule: str = "one_se"
                  ) -> pd.DataFrame:
    """Train on each dataset, score on every dataset (the diagonal is in-sample), plus
    leave-one-loop-out within each and the untrained majority of all methods."""
    rows = []
    for train, tl in sets.items():
        c = fit(tl, candidates, rule)
        for test, sl in sets.items():
            rows.append({"trained_on": train, "scored_on": test,
                         "out_of_sample": train != test, **score(c, sl),
                         "consensus": f"{'+'.join(c.methods)}, share ≥ {c.threshold:.2f}, "
                                      f"≥ {c.min_votes} vote(s)"})
    for name, sl in sets.items():
        v = lolo(sl, candidates, rule)
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
