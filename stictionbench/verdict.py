"""Stiction verdicts for real recordings: screening, indices and one simple rule.

For every recording: the data-quality screen (:mod:`stictionbench.quality`) decides
whether it can support a diagnosis; then the indices are computed — ACF oscillation
(period, regularity), bicoherence NGI/NLI, the ellipse fitted to the band-passed PV–OP
cycle (apparent stiction, fit residual, axis ratio), the model-free diagnosis
(:func:`stictionbench.diagnosis.diagnose`, fitted S/J) — and the verdict follows from
the rule :class:`StictionRule`.

The rule (Horch 1999; Choudhury et al. 2006): in a self-regulating loop a *linear*
oscillation (tight tuning, an external disturbance) keeps OP and PV in counter-phase, so
the band-passed PV–OP cycle collapses to a line; a sticking valve makes OP (the integral
of the error) and PV (the valve's square-ish position through the process) move about a
quarter cycle apart, and the cycle opens into an ellipse. The ellipse's minor/major
axis ratio in standardised coordinates is ``tan(φ/2)`` for a phase lag ``φ``; the rule
calls stiction when the cycle is an ellipse (fit residual at most ``max_residual``) that
is open enough (``axis_ratio ≥ min_axis_ratio``, default 0.3 ≈ 33°). Known limit:
integrating (level) loops oscillate a quarter cycle apart without stiction; their
ellipses are narrower in the data here but the rule has no special case for them.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from .errors import InputError
from .estimators import make
from .quality import screen
from .recording import Recording

VERDICTS = ("stiction", "no_stiction", "unusable")
MAX_DIAGNOSE_SAMPLES = 4000


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


def decimate_mean(rec: Recording, n_max: int = MAX_DIAGNOSE_SAMPLES) -> Recording:
    """Block-average a long recording to at most ``n_max`` samples (anti-aliased)."""
    n = len(rec)
    if n <= n_max:
        return rec
    k = int(math.ceil(n / n_max))
    m = n // k * k

    def f(a):
        return None if a is None else np.asarray(a[:m]).reshape(-1, k).mean(axis=1)

    return Recording.from_arrays(rec.t[:m:k], f(rec.PV), f(rec.OP), SP=f(rec.SP),
                                 MV=f(rec.MV), meta=dict(rec.meta), warn=False)


def _safe(fn, default=None):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fn()
    except (InputError, ValueError, np.linalg.LinAlgError):
        return default


def assess(rec: Recording, name: str, rule: StictionRule | None = None, *,
           run_diagnosis: bool = True) -> dict[str, Any]:
    """One batch entry: name, verdict, missing_physics, confidence and key indices."""
    rule = rule or StictionRule()
    q = screen(rec)
    entry: dict[str, Any] = {"name": name, "verdict": None, "missing_physics": None,
                             "confidence": None, "n": len(rec), "Ts": rec.Ts,
                             "quality_reasons": list(q.reasons),
                             "quality_warnings": list(getattr(q, "warnings", []))}
    if not q.usable:
        entry.update(verdict="unusable", reason="; ".join(q.reasons))
        entry["confidence"] = 1.0
        return entry
    r = decimate_mean(rec)
    osc = _safe(lambda: make("oscillation").estimate(r, x="PV"))
    bic = _safe(lambda: make("bicoherence").estimate(r, x="PV"))
    ell = _safe(lambda: make("ellipse").estimate(r, x="OP", y="PV"))
    if osc is not None:
        entry.update(oscillation_period_s=osc.value,
                     oscillation_regularity=osc.diagnostics["regularity"],
                     oscillating=osc.decision)
    if bic is not None:
        entry.update(ngi=bic.diagnostics["ngi"], nli=bic.diagnostics["nli"],
                     bicoherence_nonlinear=bic.decision)
    if ell is not None and ell.diagnostics.get("fitted"):
        d = ell.diagnostics
        entry.update(apparent_stiction=ell.value, ellipse_residual=d["residual"],
                     ellipse_axis_ratio=d["axis_ratio"],
                     op_pv_phase_deg=math.degrees(2 * math.atan(d["axis_ratio"])))
    if run_diagnosis:
        from .diagnosis import diagnose
        from .diagnosis.diagnose import valve_output
        from .diagnosis.hypotheses import Context

        dg = _safe(lambda: diagnose(r))
        if dg is None:
            entry["diagnosis_error"] = "recording cannot support a model-based diagnosis"
        else:
            st = dg.fits["stiction"]
            entry.update(missing_physics=dg.missing_physics,
                         fitted_S=st.params.get("S"), fitted_J=st.params.get("J"),
                         fit_nominal=dg.fit["nominal"], fit_improved=dg.fit["improved"])
            # the paper's method on real data: the CO→MV delay with MV estimated from
            # the fitted valve model (plants do not record MV)
            ctx = Context(r.t, np.asarray(r.OP, float), np.asarray(r.PV, float), r.Ts,
                          dg.model.time_constant, dg.model.dead_time)
            mv = valve_output("stiction", st.p, ctx)
            if np.ptp(mv) > 0:
                est = Recording(t=r.t, PV=r.PV, OP=r.OP, MV=mv, Ts=r.Ts, meta=r.meta)
                xc = _safe(lambda: make("xcorr").estimate(est, "OP", "MV"))
                xq = _safe(lambda: make("xcum").estimate(est, "OP", "MV"))
                entry["xcorr_delay_est_mv"] = None if xc is None else xc.value
                entry["xcum_delay_est_mv"] = None if xq is None else xq.value
    entry["verdict"] = rule.decide(entry)
    entry["confidence"] = rule.confidence(entry)
    return entry


def rule_dict(rule: StictionRule) -> dict[str, float]:
    return asdict(rule)
