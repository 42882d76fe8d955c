"""The fields of a real recording's batch entry: its screen, its oscillation, bicoherence
and PV–OP ellipse indices, and the model-free diagnosis (missing physics, fitted S and J,
the paper's CO→MV delays on the estimated MV), computed on the recording block-averaged
to at most :data:`MAX_DIAGNOSE_SAMPLES` samples."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from ..errors import InputError
from ..estimators import make
from ..recording import Recording

MAX_DIAGNOSE_SAMPLES = 4000


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


def base_entry(rec: Recording, name: str, q) -> dict[str, Any]:
    """The entry's name, its verdict fields (empty) and the screen's grade and reasons."""
    return {"name": name, "verdict": None, "missing_physics": None, "confidence": None,
            "fitted_S": None, "fitted_J": None,
            "n": len(rec), "Ts": rec.Ts, "quality_reasons": list(q.reasons),
            "quality_warnings": list(getattr(q, "warnings", [])),
            "quality_score": q.flags.get("score"), "quality_grade": q.flags.get("grade")}


def features(r: Recording) -> dict[str, Any]:
    """Oscillation, bicoherence and PV–OP ellipse indices of a (decimated) recording."""
    out: dict[str, Any] = {}
    osc = _safe(lambda: make("oscillation").estimate(r, x="PV"))
    bic = _safe(lambda: make("bicoherence").estimate(r, x="PV"))
    ell = _safe(lambda: make("ellipse").estimate(r, x="OP", y="PV"))
    if osc is not None:
        out.update(oscillation_period_s=osc.value,
                   oscillation_regularity=osc.diagnostics["regularity"],
                   oscillating=osc.decision)
    if bic is not None:
        out.update(ngi=bic.diagnostics["ngi"], nli=bic.diagnostics["nli"],
                   bicoherence_nonlinear=bic.decision)
    if ell is not None and ell.diagnostics.get("fitted"):
        d = ell.diagnostics
        out.update(apparent_stiction=ell.value, ellipse_residual=d["residual"],
                   ellipse_axis_ratio=d["axis_ratio"],
                   op_pv_phase_deg=math.degrees(2 * math.atan(d["axis_ratio"])))
    return out


def diagnosis_fields(r: Recording) -> dict[str, Any]:
    """The model-free diagnosis: missing physics, fitted S and J, and the paper's CO→MV
    delays with MV estimated from the fitted valve (plants do not record MV)."""
    from ..diagnosis import diagnose
    from ..diagnosis.diagnose import valve_output
    from ..diagnosis.hypotheses import Context

    dg = _safe(lambda: diagnose(r))
    if dg is None:
        return {"diagnosis_error": "recording cannot support a model-based diagnosis"}
    st = dg.fits["stiction"]
    out: dict[str, Any] = {"missing_physics": dg.missing_physics,
                           "fitted_S": st.params.get("S"), "fitted_J": st.params.get("J"),
                           "fit_nominal": dg.fit["nominal"], "fit_improved": dg.fit["improved"]}
    ctx = Context(r.t, np.asarray(r.OP, float), np.asarray(r.PV, float), r.Ts,
                  dg.model.time_constant, dg.model.dead_time)
    mv = valve_output("stiction", st.p, ctx)
    if np.ptp(mv) > 0:
        est = Recording(t=r.t, PV=r.PV, OP=r.OP, MV=mv, Ts=r.Ts, meta=r.meta)
        xc = _safe(lambda: make("xcorr").estimate(est, "OP", "MV"))
        xq = _safe(lambda: make("xcum").estimate(est, "OP", "MV"))
        out["xcorr_delay_est_mv"] = None if xc is None else xc.value
        out["xcum_delay_est_mv"] = None if xq is None else xq.value
    return out
