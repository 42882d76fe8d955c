"""The first release's stiction rule for real recordings (``ellipse_v1``): the ellipse
fitted to the band-passed PV–OP cycle. Its thresholds were chosen after looking at the
ISDB and refinery loops, so its scores there are in-sample; ``batch`` reports it beside
the published detectors and does not let it vote.

The rule, and what it measures. With a constant set point the controller ties OP to PV
by a *linear* map, ``OP = −C(s)·PV``, whatever causes the oscillation; for an ideal PI
``∠C(jω) = −atan(1/(ω·Ti))``. The band-passed PV–OP cycle is therefore an ellipse whose
opening is set by how slow the oscillation is compared with the integral time: its
minor/major axis ratio in standardised coordinates is ``tan(φ/2)`` with
``φ ≈ atan(1/(ω·Ti))``. Oscillations caused by tight tuning sit near the loop's
crossover, where the proportional action dominates (φ small, a thin cycle: Horch's
even cross-correlation, Horch 1999); a sticking valve produces a limit cycle much slower
than the integral time, because the integrator has to wind the controller output
through the whole stick band (φ → 90°, an open ellipse; Choudhury et al. 2006 quantify
stiction on this ellipse). The rule calls stiction when the cycle is an ellipse (fit
residual at most ``max_residual``) that is open enough (``axis_ratio ≥ min_axis_ratio``;
the default 0.3 means φ ≥ 33°, i.e. a period longer than about 4·Ti for a PI loop).

Known limits, stated rather than hidden: an external disturbance *slower* than about
4·Ti opens the ellipse as well and is called stiction (``tests/test_batch.py`` shows
it); integrating (level) loops add another 90° of their own; a historian that stores OP
one scan late adds ``360°·Ts/P``, which opens fast cycles. The defaults were chosen
after looking at the ISDB and refinery loops; ``stictionbench batch`` reports
leave-one-group-out scores with the thresholds re-tuned without each held-out loop.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from ..recording import Recording
from .entry import base_entry, decimate_mean, diagnosis_fields, features
from .quality import screen


@dataclass(frozen=True)
class StictionRule:
    """``stiction`` ⇔ ellipse fitted ∧ residual ≤ max_residual ∧ axis ratio ≥ min_axis_ratio."""

    min_axis_ratio: float = 0.3
    max_residual: float = 0.45

    def decide(self, entry: dict[str, Any]) -> str:
        if entry.get("verdict") == "unusable":
            return "unusable"
        ar, res = entry.get("ellipse_axis_ratio"), entry.get("ellipse_residual")
        if ar is None or res is None or not (math.isfinite(ar) and math.isfinite(res)):
            return "no_stiction"
        return "stiction" if (res <= self.max_residual and ar >= self.min_axis_ratio) \
            else "no_stiction"

    def confidence(self, entry: dict[str, Any]) -> float:
        """0.5 on the decision boundary, 1 far from it (distance in axis ratio / 0.3)."""
        ar = entry.get("ellipse_axis_ratio")
        if entry.get("verdict") == "unusable" or ar is None or not math.isfinite(ar):
            return 1.0 if entry.get("verdict") == "unusable" else 0.5
        return float(0.5 + 0.5 * min(1.0, abs(ar - self.min_axis_ratio) / 0.3))


def assess(rec: Recording, name: str, rule: StictionRule | None = None, *,
           run_diagnosis: bool = True) -> dict[str, Any]:
    """One entry of the first-release rule (``ellipse_v1``): name, verdict,
    missing_physics, confidence and key indices."""
    rule = rule or StictionRule()
    q = screen(rec)
    entry = base_entry(rec, name, q)
    if not q.usable:
        entry.update(verdict="unusable", reason="; ".join(q.reasons), confidence=1.0)
        return entry
    r = decimate_mean(rec)
    entry.update(features(r))
    if run_diagnosis:
        entry.update(diagnosis_fields(r))
    entry["verdict"] = rule.decide(entry)
    entry["confidence"] = rule.confidence(entry)
    return entry


def rule_dict(rule: StictionRule) -> dict[str, float]:
    """The rule's thresholds as a dict (for a report)."""
    return asdict(rule)
