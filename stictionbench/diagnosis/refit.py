"""Is the valve named against a given model the model's own error? The process refitted.

With a model given, every error of that model is read as one of the vocabulary's physics:
the paper's plant with its time constant 11.5–14 s or its gain ±20 % against a model that
says 10 s and 3 was named a valve on 87 of 120 loops whose valve was ideal
(``reports/concealed/process_refit_gate.md``). The check here re-identifies the model's
FOPDT process from the recording, starting from the model (the closed-loop Hammerstein
identification's linear loop: the prediction-error fit the model-free diagnosis uses for
its own process), diagnoses the recording again against the model with that process, and
says where the valve is then no longer named.

It informs and does not decide. As a rule (the valve answer held to ``none`` there) it
removed the valve on all 87 of those loops, but on the independent sets it removed 11 of
the 38 false alarms of healthy loops and lost 116 right answers — valve characteristics,
dead bands and sticky valves a refitted gain or time constant absorbs — so it failed its
criterion (same report). A valve whose answer does not survive the refit is one the
record cannot tell from a model error of gain, time constant or dead time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

from ..recording import Recording
from .evidence import MIN_IMPROVEMENT
from .model import NominalModel
from .result import Diagnosis

#: the answers the check is made for: a valve acting on OP. A dead-time mismatch or a
#: sensor lag is a model error by definition and is not checked
REFIT_CLASSES = ("stiction", "deadband", "saturation", "valve_characteristic")
#: the refitted process alone "explains it as well" as the valve when its validation NRMSE
#: is at most this much above the valve's: the diagnosis's own NRMSE gate
#: (:data:`.evidence.MIN_IMPROVEMENT`). Added after a newcomer's case (the paper's
#: sticky valve: the refit answered ``none`` at NRMSE 2.0 against the valve's 0.23); the
#: experiment's rule did not have it
EXPLAINS_AS_WELL = MIN_IMPROVEMENT
#: the check's default in ``diagnose`` and the command (off: it adds a valve
#: identification and a second diagnosis to every valve answer, about 1–2 s)
PROCESS_REFIT = False


def refitted_model(rec: Recording, model: NominalModel) -> NominalModel:
    """``model`` with its FOPDT process (gain, time constant, dead time) re-identified
    from ``rec``, starting from it: the linear loop of
    :func:`.hammerstein.fit_hammerstein` with the process free (its ``S = 0`` limit, a
    prediction-error fit; Srinivasan et al. 2005; Ljung 1999, ch. 7). The PI, the OP
    range and the controller period are the model's."""
    from .hammerstein import fit_hammerstein

    h = fit_hammerstein(rec, linear=(model.gain, model.time_constant, model.dead_time),
                        fix_process=False)
    lp = h.linear_process
    return replace(model, gain=float(lp["gain"]), time_constant=float(lp["time_constant"]),
                   dead_time=max(float(lp["dead_time"]), 0.0))


def process_refit_check(d: Diagnosis, rec: Recording, model: NominalModel,
                        rediagnose: Callable[[NominalModel], Diagnosis]) -> Diagnosis:
    """``details.process_refit`` (the refitted process, the answer against it,
    ``valve_kept``, and the validation NRMSE of the refitted process alone) and, where a
    valve answer is not named again, ``details.refit_warning``, in place; ``d`` unchanged
    where its answer is not one of :data:`REFIT_CLASSES` or the model was not given.
    ``rediagnose`` diagnoses ``rec`` against another model with ``d``'s settings. Where
    the refit sits on the identification's search limit or its model cannot be
    diagnosed, ``valve_kept`` is ``None`` and ``reason`` says why: no conclusion, and the
    answer stands.

    Examples
    --------
    >>> from stictionbench.recording import Recording
    >>> import numpy as np
    >>> d = Diagnosis(True, "none", {}, {"nominal": 0.5, "improved": 0.5}, [], [], [],
    ...               NominalModel(1.0, 10.0, 1.0), {})
    >>> rec = Recording.from_arrays(np.arange(300.0), np.zeros(300), np.arange(300.0))
    >>> process_refit_check(d, rec, NominalModel(1.0, 10.0, 1.0), None).details
    {}
    """
    if d.missing_physics not in REFIT_CLASSES or model.source != "given":
        return d
    from ..errors import InputError
    from .process import search_limits

    m2 = refitted_model(rec, model)
    info: dict[str, Any] = {"gain": m2.gain, "time_constant": m2.time_constant,
                            "dead_time": m2.dead_time, "missing_physics": None,
                            "valve_kept": None}
    d.details["process_refit"] = info
    tau_max, theta_max = search_limits(len(rec.PV), rec.Ts)
    if m2.time_constant >= 0.99 * tau_max or m2.dead_time >= 0.99 * theta_max:
        # no optimum inside the identification's range: the refit says nothing
        info["reason"] = (f"the refit's time constant ({m2.time_constant:.4g} s) or dead "
                          f"time ({m2.dead_time:.4g} s) sits on its search limit (half and a "
                          f"quarter of the record): no conclusion")
        return d
    try:
        second = rediagnose(m2)
    except InputError as exc:  # the refitted process too slow for the record, say
        info["reason"] = f"the refitted model could not be diagnosed: {exc}"
        return d
    kept = second.missing_physics in REFIT_CLASSES
    nrmse_refit = float(second.fit.get("nominal", float("nan")))
    nrmse_valve = float(d.fit.get("improved", float("nan")))
    info |= {"missing_physics": second.missing_physics, "valve_kept": bool(kept),
             "nrmse_refit_nominal": nrmse_refit}
    if not kept and not nrmse_refit <= (1.0 + EXPLAINS_AS_WELL) * nrmse_valve:
        # the refitted process names nothing but explains PV worse than the valve did
        info["valve_kept"] = None
        info["reason"] = (f"the refitted process answers {second.missing_physics} but fits "
                          f"the validation blocks worse than the {d.missing_physics} "
                          f"(NRMSE {nrmse_refit:.3g} against {nrmse_valve:.3g}): no "
                          "conclusion")
        return d
    if not kept:
        d.details["refit_warning"] = (
            f"the given model's process refitted from the recording (gain {m2.gain:.3g}, "
            f"time constant {m2.time_constant:.3g} s, dead time {m2.dead_time:.3g} s; "
            f"given {model.gain:.3g}, {model.time_constant:.3g} s, {model.dead_time:.3g} s)"
            f" is answered {second.missing_physics} (validation NRMSE "
            f"{second.fit.get('nominal', float('nan')):.3g}, against "
            f"{d.fit.get('improved', float('nan')):.3g} with the {d.missing_physics} on the "
            f"given model): the record cannot tell the {d.missing_physics} from an error of "
            "the model's gain, time constant or dead time; check the model "
            "(reports/concealed/process_refit_gate.md)")
    return d
