"""Rates with intervals and ROC curves: the statistics every report shares.

A detection rate is a binomial proportion and is reported with its Wilson score interval
(Wilson 1927; recommended over the Wald interval by Brown, Cai & DasGupta 2001); an ROC
area carries a percentile bootstrap interval (Efron & Tibshirani 1993, ch. 13) computed
with a fixed seed, so reports are reproducible.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.stats import binomtest, fisher_exact, norm


def decided(s: pd.Series) -> np.ndarray:
    """A decision column as booleans: True only where the method said True.

    Examples
    --------
    >>> decided(pd.Series([True, False, None, "True", 1])).tolist()
    [True, False, False, True, True]
    """
    return s.map(lambda v: v is True or v == 1 or v == "True").to_numpy(dtype=bool)


def wilson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``k/n``.

    Returns ``(nan, nan)`` for ``n = 0``.

    Examples
    --------
    >>> [round(v, 3) for v in wilson(0, 50)]
    [0.0, 0.071]
    >>> [round(v, 3) for v in wilson(22, 50)]
    [0.312, 0.577]
    """
    if n <= 0:
        return float("nan"), float("nan")
    z = float(norm.ppf(0.5 + level / 2))
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * float(np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))) / den
    lo = 0.0 if k == 0 else max(0.0, centre - half)
    hi = 1.0 if k == n else min(1.0, centre + half)
    return lo, hi


def rate_text(k: int, n: int, level: float = 0.95) -> str:
    """``"22/50 = 44 % [31, 58]"``: a count, its rate and its Wilson interval in per cent."""
    if n <= 0:
        return "0/0"
    lo, hi = wilson(k, n, level)
    return f"{k}/{n} = {100 * k / n:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}]"


def balanced_score(correct: pd.Series, stratum: pd.Series, total: int = 16,
                   level: float = 0.95) -> tuple[float, float, float]:
    """A score out of ``total`` recordings drawn equally from every stratum (class), with
    its interval: ``total`` times the mean of the per-class rates.

    A benchmark that draws more recordings of one class than another (twice as many
    ``none``, say) overweights that class in the pooled rate; a test set made of equal
    numbers per class is estimated by the stratified mean instead (Cochran, *Sampling
    Techniques*, 1977, ch. 5). The interval is the normal one of the stratified mean, its
    variance from Agresti–Coull-adjusted rates ``(k + 2)/(n + 4)`` (Agresti & Coull 1998)
    so that a class named right every time still contributes, clipped to
    ``[0, total]``.

    Returns ``(score, low, high)``.

    Examples
    --------
    >>> ok = pd.Series([True] * 4 + [False] * 4 + [True] * 2)
    >>> cls = pd.Series(["a"] * 4 + ["b"] * 4 + ["b"] * 2)
    >>> [round(v, 2) for v in balanced_score(ok, cls)]
    [10.67, 6.05, 15.29]
    """
    ok = pd.Series(np.asarray(correct, dtype=bool), index=stratum.index)
    g = ok.groupby(stratum.to_numpy())
    k, n = g.sum().to_numpy(float), g.size().to_numpy(float)
    if k.size == 0:
        return float("nan"), float("nan"), float("nan")
    w = total / k.size
    score = float(w * np.sum(k / n))
    pa = (k + 2.0) / (n + 4.0)
    half = float(norm.ppf(0.5 + level / 2)) * w * float(np.sqrt(np.sum(pa * (1 - pa) / n)))
    return score, max(0.0, score - half), min(float(total), score + half)


def balanced_text(correct: pd.Series, stratum: pd.Series, total: int = 16,
                  digits: int = 1) -> str:
    """``"12.0 [11.3, 12.7]"``: :func:`balanced_score` as text, the score to ``digits``
    decimals (the interval to one)."""
    s, lo, hi = balanced_score(correct, stratum, total)
    return f"{s:.{digits}f} [{lo:.1f}, {hi:.1f}]"


def fisher_p(k1: int, n1: int, k2: int, n2: int) -> float:
    """Two-sided p-value of Fisher's exact test that ``k1/n1`` and ``k2/n2`` are the same
    rate (``scipy.stats.fisher_exact`` on the 2 × 2 table; Fisher 1935).

    Examples
    --------
    >>> round(fisher_p(24, 288, 11, 288), 3)
    0.035
    >>> fisher_p(3, 10, 3, 10)
    1.0
    """
    return float(fisher_exact([[k1, n1 - k1], [k2, n2 - k2]])[1])


def mcnemar_p(only_b: int, only_a: int) -> float:
    """Two-sided exact McNemar p-value for paired verdicts: ``only_b`` pairs right only
    under condition B, ``only_a`` only under A (the discordant pairs), against a
    fair coin (``scipy.stats.binomtest``; McNemar 1947). 1.0 without discordant pairs.

    Examples
    --------
    >>> round(mcnemar_p(13, 1), 4)
    0.0018
    >>> mcnemar_p(0, 0)
    1.0
    """
    n = only_b + only_a
    return float(binomtest(only_b, n, 0.5).pvalue) if n else 1.0


def roc_curve(scores: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """ROC of a continuous score (larger = positive) against boolean labels.

    Missing scores (NaN) rank below every finite score. Returns ``(fpr, tpr, auc)``,
    the curve through every distinct threshold, from (0, 0) to (1, 1); the AUC is the
    trapezoidal area (ties count one half, as the Mann–Whitney statistic). NaN AUC when
    one of the classes is empty.

    Examples
    --------
    >>> roc_curve(np.array([0.9, 0.8, 0.1]), np.array([True, False, False]))[2]
    1.0
    """
    s = np.asarray(scores, dtype=float)
    y = np.asarray(labels, dtype=bool)
    finite = np.isfinite(s)
    low = (np.min(s[finite]) - 1.0) if finite.any() else 0.0
    s = np.where(finite, s, low)
    order = np.argsort(-s, kind="mergesort")
    s, y = s[order], y[order]
    npos, nneg = int(y.sum()), int((~y).sum())
    if npos == 0 or nneg == 0:
        return np.array([0.0, 1.0]), np.array([0.0, 1.0]), float("nan")
    last = np.r_[np.nonzero(np.diff(s))[0], y.size - 1]
    tps = np.cumsum(y)[last]
    fps = (last + 1) - tps
    tpr = np.r_[0.0, tps / npos]
    fpr = np.r_[0.0, fps / nneg]
    return fpr, tpr, float(np.trapezoid(tpr, fpr))


def auc_interval(scores: np.ndarray, labels: np.ndarray, *, level: float = 0.95,
                 n_boot: int = 1000, seed: int = 0) -> tuple[float, float, float]:
    """AUC and its percentile bootstrap interval, resampling each class separately.

    Returns ``(auc, low, high)``; NaNs when a class is empty. The seed is fixed, so the
    interval is reproducible.

    Examples
    --------
    >>> a, lo, hi = auc_interval(np.r_[np.ones(20), np.zeros(20)], np.r_[[True] * 20, [False] * 20])
    >>> (a, lo, hi)
    (1.0, 1.0, 1.0)
    """
    s = np.asarray(scores, dtype=float)
    y = np.asarray(labels, dtype=bool)
    auc = roc_curve(s, y)[2]
    if not np.isfinite(auc):
        return auc, float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    pos, neg = s[y], s[~y]
    boots = np.empty(n_boot)
    for b in range(n_boot):
        bp = pos[rng.integers(0, pos.size, pos.size)]
        bn = neg[rng.integers(0, neg.size, neg.size)]
        boots[b] = roc_curve(np.r_[bp, bn], np.r_[np.ones(bp.size, bool),
                                                  np.zeros(bn.size, bool)])[2]
    lo, hi = np.quantile(boots, [(1 - level) / 2, (1 + level) / 2])
    return auc, float(lo), float(hi)
