"""Detection, then quantification, where no model is given: the published stiction
detectors' combined verdict (the one ``stictionbench batch`` gives) as the detection
stage, the diagnosis's own stiction fit as the quantification.

Without a model the process is identified from OP and PV in closed loop, through the
valve that sticks and, on regulatory data, with OP the controller's answer to the load:
the likelihood tests against that identified nominal then rarely carry a sticky valve
past their gates (``reports/diagnose/isdb/summary.md``; the cause checked in
``reports/diagnose/regulatory_bias.md``). Jelali & Huang recommend the two-stage route for
plant data: detect stiction with the data-driven methods first, then quantify it with a
Hammerstein-type fit (*Detection and Diagnosis of Stiction in Control Loops*, Springer
2010, ch. 13–14). :func:`detect` runs the detectors of the shipped consensus
(:class:`~stictionbench.realdata.consensus.Consensus`, ``conf/consensus/default.yaml``)
on the recording; :func:`name_detected` names ``stiction`` where they find it and the
stiction fit's slip jump has an interval that excludes 0 (the nested rule of the dead
band: a sticky valve whose ``J`` may be 0 is not shown to be stiction).

The detection stage leaves out the detectors in :data:`QUANTIFIER_KIN`: the panel's
Hammerstein detector fits the same kind of model (a stick-slip valve in series with a
low-order process) to the same PV and OP as the quantification, so where its vote
decides the two stages test one hypothesis twice rather than give two pieces of
evidence. The consensus's other methods, its threshold and its minimum number of votes
are the shipped ones; ``batch`` keeps the whole consensus.

Measured before it was shipped: ``experiments/two_stage_diagnose.py`` (the route with
the whole consensus; ``reports/diagnose/two_stage_diagnose.md``) and
``experiments/detection_independent.py`` (the Hammerstein detector left out, on
recordings the first never saw; ``reports/diagnose/detection_independent.md``). Each has
its design, predictions and criterion in its docstring. The route stays off by default.
"""

from __future__ import annotations

from typing import Any

from ..recording import Recording
from .result import Diagnosis

__all__ = ["QUANTIFIER_KIN", "detect", "name_detected"]

#: detectors left out of the detection stage: they fit the quantification's own model
#: kind, so their vote is not independent of the slip-jump evidence that follows
#: (``reports/diagnose/detection_independent.md``)
QUANTIFIER_KIN = ("hammerstein",)


def detect(rec: Recording, consensus_path: str | None = None) -> dict[str, Any]:
    """The combined verdict of the published detectors on ``rec``.

    Parameters
    ----------
    rec : Recording
        The recording the diagnosis runs on (the loop type is read from its labels or
        its name's controller tag, :func:`~stictionbench.realdata.panel.loop_type`).
    consensus_path : str, optional
        A consensus YAML (default: the shipped ``conf/consensus/default.yaml``); its
        methods in :data:`QUANTIFIER_KIN` are left out, its threshold and minimum votes
        kept.

    Returns
    -------
    dict
        ``verdict`` (stiction, no_stiction or inconclusive), ``reason``, ``consensus``
        (its settings), ``loop_type`` and ``methods`` (each detector's verdict and
        reason).

    References
    ----------
    Jelali & Huang (2010), ch. 13; the detectors' own papers in
    :mod:`stictionbench.realdata.panel`.
    """
    from ..realdata.consensus import Consensus
    from ..realdata.panel import window_calls

    shipped = Consensus.load(consensus_path)
    c = Consensus(tuple(m for m in shipped.methods if m not in QUANTIFIER_KIN),
                  shipped.threshold, shipped.min_votes)
    if not c.methods:
        return {"verdict": "inconclusive", "reason": "no detector outside the "
                f"quantification's kind ({', '.join(QUANTIFIER_KIN)}) in the consensus",
                "consensus": c.to_dict(), "loop_type": "", "methods": {}}
    calls = window_calls(rec, str(rec.meta.get("name", "")), c.methods)
    verdict, reason = c.decide({m: calls[m].verdict for m in c.methods})
    return {"verdict": verdict, "reason": reason, "consensus": c.to_dict(),
            "loop_type": calls["loop_type"],
            "methods": {m: {"verdict": calls[m].verdict, "reason": calls[m].reason}
                        for m in c.methods}}


def name_detected(d: Diagnosis, detection: dict[str, Any]) -> Diagnosis:
    """Name ``stiction`` where ``detection`` (:func:`detect`) found it, the diagnosis did
    not, and the diagnosis's stiction fit has a slip jump whose interval excludes 0; in
    place. The check is reported under ``tests["detection"]`` either way (``named``,
    and the answer it replaced under ``named_before``).

    A saturation read off OP held at a limit is left alone: its evidence is OP itself.
    The answer's parameters and fit are the stiction fit's (``S`` and ``J`` with their
    intervals; ``fit.improved`` its validation NRMSE, which need not beat the nominal:
    the detection, not the fit's improvement, is the evidence here).
    """
    ft = d.fits.get("stiction")
    j = (ft.intervals.get("J") if ft is not None else None) or []
    slip = len(j) == 2 and float(j[0]) > 0.0
    test = {**detection, "named": False, "slip_jump_interval": [float(x) for x in j],
            "slip_jump_excludes_0": slip}
    d.tests["detection"] = test
    held = d.tests.get("op_held_at_limit", {}).get("named")
    if (detection["verdict"] != "stiction" or d.missing_physics == "stiction" or held
            or ft is None or not slip):
        return d
    test["named"], test["named_before"] = True, d.missing_physics
    d.missing_physics, d.mismatch_detected = "stiction", True
    d.parameters, d.uncertainty = dict(ft.params), dict(ft.intervals)
    d.fit = {**d.fit, "improved": ft.nrmse_val}
    if "rival" in d.tests:
        d.tests["rival"] = {"method": d.tests["rival"].get("method", "vuong"), "rival": None,
                            "reason": "the answer is the detectors' (detection route)"}
    d.details["detection"] = (
        f"the published detectors found a sticky valve ({detection['reason']}) and the "
        f"stiction fit's slip jump J = {ft.params.get('J', float('nan')):.3g} has an "
        f"interval [{j[0]:.3g}, {j[1]:.3g}] that excludes 0: detection, then "
        "quantification (no model given)")
    return d
