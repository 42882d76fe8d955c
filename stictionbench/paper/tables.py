"""Tables III–VII of the paper, every remark decided by a measured number.

Reference: Govinda Kumar & Manoharan (``../shared/paper/``), Tables III–VII.
"""

from __future__ import annotations

from typing import Any

import pandas as pd

from ..reports.tables import magnitude
from .cases import CaseResult

PAPER_REMARKS = {
    "linear": ["Oscillations are not available",
               "Time delay is not observed in between stem position and controller output",
               "Observed the linear characteristics of valve"],
    "tight": ["Oscillations are available",
              "Time delay is not observed in between stem position and controller output",
              "Observed the linear characteristics of valve"],
    "disturbance": ["Oscillations are available",
                    "Time delay is not observed in between stem position and controller output",
                    "Observe the linear characteristics of valve"],
    "stiction": ["Oscillations are available",
                 "Time delay is observed in between stem position and controller output",
                 "Observed the non linear characteristics of valve",
                 "Observed the ellipse formation"],
}


def _same(paper: str, ours: str) -> bool:
    def norm(s: str) -> str:
        return s.lower().replace("observe ", "observed ")
    return norm(paper) == norm(ours)


def remark_table(res: CaseResult, cfg: Any) -> pd.DataFrame:
    """Table III–VI for one case: paper remark, our remark, the measure behind it.

    Row 2 ("time delay observed") is decided on ``|delay|``: the sign is ignored, which
    is *our* choice (the paper's rule reads the sign, see Table VII's ``sign_rule``).
    """
    th = cfg.thresholds
    osc = res.swings >= int(th.oscillation_swings)
    delay = float(res.xcorr.value)
    observed = abs(delay) > float(th.delay_samples)
    linear = res.r2 >= float(th.linear_r2)
    rows = [
        ("Servo response",
         "Oscillations are available" if osc else "Oscillations are not available",
         "error swings after the first SP step", res.swings,
         f">= {int(th.oscillation_swings)} swings beyond ±{float(th.swing_fraction):.0%} "
         "of the step (ours)"),
        ("Stem position and controller output",
         ("Time delay is observed" if observed else "Time delay is not observed")
         + " in between stem position and controller output",
         "CO→MV delay, xcorr (samples)", round(delay, 4),
         f"|delay| > {float(th.delay_samples):g} samples (ours; sign ignored)"),
        ("Controller output Vs Manipulated variable",
         "Observed the linear characteristics of valve" if linear
         else "Observed the non linear characteristics of valve",
         f"R² of MV = a + b·CO (hysteresis area fraction {res.hysteresis:.3f})",
         round(res.r2, 4), f"R² >= {float(th.linear_r2):g} (ours)"),
    ]
    if res.case == "stiction":
        d = res.ellipse.diagnostics
        rows.append(("Controller output Vs Process variable",
                     "Observed the ellipse formation" if res.ellipse.decision
                     else "No ellipse formation",
                     f"ellipse fit on band-passed PV–CO: apparent stiction (%), residual "
                     f"{d['residual']:.3f}, axis ratio {d['axis_ratio']:.2f}",
                     round(float(res.ellipse.value), 3),
                     f"residual <= {d['max_residual']:g}, axis ratio >= "
                     f"{d['min_axis_ratio']:g}, stiction > {d['min_stiction']:g} %"))
    paper = PAPER_REMARKS[res.case]
    return pd.DataFrame({
        "S.No": range(1, len(rows) + 1),
        "Responses": [r[0] for r in rows],
        "Remarks (paper)": paper[: len(rows)],
        "Remarks (ours)": [r[1] for r in rows],
        "agrees": [_same(p, r[1]) for p, r in zip(paper, rows, strict=False)],
        "measure": [r[2] for r in rows],
        "value": [r[3] for r in rows],
        "threshold": [r[4] for r in rows],
    })


def table7(results: list[CaseResult], cfg: Any) -> pd.DataFrame:
    """Table VII with both decision rules and the cumulant estimate's stability flags."""
    paper = cfg.paper.table7
    rows = []
    for r in results:
        Ts = r.rec.Ts
        xq = r.xcum.diagnostics
        rows.append({
            "case": r.case,
            "xcorr_delay_samples": float(r.xcorr.value),
            "paper_xcorr": float(paper[r.case].xcorr),
            "xcum_delay_samples": int(r.xcum.value),
            "paper_xcum": float(paper[r.case].xcum),
            "xcorr_delay_s": float(r.xcorr.value) * Ts,
            "xcum_delay_s": float(r.xcum.value) * Ts,
            "sign_rule_xcorr": "stiction" if r.xcorr.value > 0 else "no stiction",
            "sign_rule_paper": "stiction" if float(paper[r.case].xcorr) > 0
            else "no stiction",
            "threshold_rule_xcorr": "stiction" if r.xcorr.decision else "no stiction",
            "xcum_at_edge": bool(xq["at_edge"]),
            "xcum_unstable": bool(xq["unstable"]),
            "xcum_wide_delay": xq["wide_delay"],
            "xcum_condition_number": magnitude(xq["condition_number"]),
            "bicoherence_ngi": float(r.bic.diagnostics["ngi"]),
            "bicoherence_nli": float(r.bic.diagnostics["nli"]),
            "bicoherence_nonlinear": bool(r.bic.decision),
        })
    return pd.DataFrame(rows)
