"""Could the record tell the answer from its closest rival? Vuong's test of two non-nested
models on the validation blocks' one-step innovations.

The diagnosis names the significant hypothesis of lowest BIC (:func:`.evidence.select`).
Where another also passed every gate, a lower BIC says which fits better, not whether the
data could tell the two apart: a dead-time change and a sensor lag of a few seconds, say,
explain a slow loop almost alike. :func:`rival_test` says so in the answer
(``tests.rival``), without changing it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.stats import norm

from .evidence import VALVE_HYPOTHESES

#: pairs decided by a test of their own (stiction against the dead band it contains: the
#: slip jump, :func:`.evidence.select`), never each other's rival here
NESTED_PAIRS = (frozenset(VALVE_HYPOTHESES),)


def rival_test(pick: str, ranking: list[dict[str, Any]],
               innovations: dict[str, np.ndarray], val: np.ndarray,
               alpha: float) -> dict[str, Any]:
    """Vuong's (1989) test of the answer ``pick`` against its closest significant rival.

    The rival is the hypothesis of lowest BIC (``ranking``'s ``score``) among the others
    that passed every gate (``significant``), the other member of a nested pair
    (:data:`NESTED_PAIRS`) left out. With ``ℓᵢ`` each validation sample's Gaussian
    log-likelihood of the whitened innovations under its model's own variance, and ``k``
    the models' extra parameters (``df``),
    ``z = (Σᵢ (ℓᵢ,pick − ℓᵢ,rival) − (k_pick − k_rival)·ln(n)/2) / (√n · sd(ℓ_pick − ℓ_rival))``
    is standard normal where both models are equally close to the truth (Vuong's
    Schwarz-corrected statistic). ``p_value = P(Z ≥ z)``: evidence that the pick is the
    closer one; ``distinguishable`` is ``p_value < alpha``.

    Parameters
    ----------
    pick : str
        The answer (``missing_physics``).
    ranking : list of dict
        The diagnosis's ranking rows (``physics``, ``score``, ``significant``, ``df``).
    innovations : dict of str to ndarray
        Each hypothesis's whitened one-step prediction errors, full length.
    val : ndarray of int
        The validation samples.
    alpha : float
        The diagnosis's level.

    Returns
    -------
    dict
        ``method`` ("vuong"), ``rival`` (``None`` with a ``reason`` where there is none),
        ``statistic``, ``p_value``, ``distinguishable``, ``n``.

    References
    ----------
    Vuong, Q. H., "Likelihood ratio tests for model selection and non-nested hypotheses",
    *Econometrica* 57 (1989) 307–333, section 5.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> e = {"a": rng.normal(size=500), "b": 1.5 * rng.normal(size=500)}
    >>> rows = [{"physics": "a", "score": 0.0, "significant": True, "df": 1},
    ...         {"physics": "b", "score": 40.0, "significant": True, "df": 1}]
    >>> t = rival_test("a", rows, e, np.arange(500), 0.05)
    >>> t["rival"], t["distinguishable"]
    ('b', True)
    """
    if pick == "none":
        return {"method": "vuong", "rival": None,
                "reason": "the answer is the nominal model (tested against it)"}
    nested = next((p for p in NESTED_PAIRS if pick in p), frozenset())
    rivals = [r for r in ranking if r.get("significant") and r["physics"] != pick
              and r["physics"] not in nested and r["physics"] in innovations]
    if pick not in innovations or not rivals:
        return {"method": "vuong", "rival": None,
                "reason": "no other hypothesis passed the gates"}
    rival = min(rivals, key=lambda r: float(r["score"]))["physics"]
    k = {r["physics"]: int(r.get("df", 0)) for r in ranking}
    ep = np.asarray(innovations[pick], float)[val]
    er = np.asarray(innovations[rival], float)[val]
    vp, vr = float(np.mean(ep ** 2)), float(np.mean(er ** 2))
    d = (-0.5 * math.log(vp) - ep ** 2 / (2.0 * vp)) - (-0.5 * math.log(vr) - er ** 2 / (2.0 * vr))
    n = int(d.size)
    sd = float(np.std(d, ddof=1)) if n > 1 else 0.0
    lr = float(np.sum(d)) - (k.get(pick, 0) - k.get(rival, 0)) * math.log(max(n, 1)) / 2.0
    if sd > 0:
        z: float | None = lr / (math.sqrt(n) * sd)
        p = float(norm.sf(z))
    else:  # identical per-sample likelihood differences: the sign decides
        z, p = None, (0.0 if lr > 0 else 1.0)
    return {"method": "vuong", "rival": rival, "statistic": z, "p_value": p,
            "distinguishable": bool(p < alpha), "n": n}
