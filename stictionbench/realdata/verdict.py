"""Stiction verdicts for real recordings: the batch entry of one recording window.

For every window: the data-quality screen (:mod:`stictionbench.realdata.quality`) decides
whether it can support a verdict; every published detector gives its call
(:mod:`.panel`) and their consensus (:mod:`.consensus`) the verdict; the entry adds the
oscillation, bicoherence and ellipse indices and, on the windows asked for, the model-free
diagnosis (:mod:`.entry`), and notes where the verdict is weak (a tie, one method, a daily
period). The first release's ellipse rule (:mod:`.ellipse_rule`) is reported beside the
detectors and does not vote.
"""

from __future__ import annotations

import math
from typing import Any

from ..recording import Recording
from .consensus import Consensus
from .ellipse_rule import StictionRule, assess, rule_dict
from .entry import MAX_DIAGNOSE_SAMPLES, base_entry, decimate_mean, diagnosis_fields, features
from .panel import FAST, window_calls
from .quality import prepare

#: names other modules and scripts import from here
__all__ = ["MAX_DIAGNOSE_SAMPLES", "VERDICTS", "StictionRule", "assess", "decimate_mean",
           "diagnosis_fields", "features", "judge", "lone_notes", "period_notes",
           "rule_dict", "slip_notes", "tie_notes"]

VERDICTS = ("stiction", "no_stiction", "unusable")


def judge(rec: Recording, name: str, consensus=None, *,
          diagnose: str = "flagged") -> dict[str, Any]:
    """The batch entry: every published detector's call (``methods``) and their
    consensus (:mod:`.consensus`, shipped default ``conf/consensus/default.yaml``).

    ``verdict`` is ``stiction`` when the consensus says so, ``unusable`` when the data
    cannot support a verdict, else ``no_stiction`` (``consensus`` then says whether the
    methods agreed on it or were inconclusive). ``confidence`` is the share of deciding
    methods that agree with the verdict (1.0 for unusable data). The model-free
    diagnosis (``missing_physics``, fitted S and J) runs on ``diagnose = "all"``
    windows, on the windows flagged stiction (``"flagged"``), or on none.
    """
    c = consensus or Consensus.load()
    calls = window_calls(rec, name, methods=tuple(dict.fromkeys([*c.methods, *FAST])))
    rec, q, released = prepare(rec)
    entry = base_entry(rec, name, q)
    entry["holds_released"] = released
    entry["methods"] = {m: {"verdict": calls[m].verdict, "reason": calls[m].reason,
                            "value": calls[m].value,
                            **({"evidence": calls[m].evidence} if calls[m].evidence else {})}
                        for m in calls if hasattr(calls[m], "verdict")}
    if not q.usable:
        entry.update(verdict="unusable", consensus="unusable", confidence=1.0,
                     reason="; ".join(q.reasons), notes=[])
        return entry
    r = decimate_mean(rec)
    entry.update(features(r))
    v1 = StictionRule()
    entry["methods"]["ellipse_v1"] = {"verdict": v1.decide(entry), "value":
                                      entry.get("ellipse_axis_ratio"),
                                      "reason": "first-release ellipse rule (in-sample)"}
    v, why = c.decide({m: calls[m].verdict for m in c.methods})
    deciding = [m for m in c.methods if calls[m].verdict in VERDICTS[:2]]
    votes = [calls[m].verdict for m in deciding]
    entry.update(verdict="stiction" if v == "stiction" else "no_stiction", consensus=v,
                 reason=why)
    final = entry["verdict"]
    entry["confidence"] = (sum(x == final for x in votes) / len(votes)) if votes else 0.5
    entry["notes"] = (period_notes(entry.get("oscillation_period_s")) + tie_notes(votes)
                      + lone_notes(deciding) + slip_notes(rec, calls, final))
    if diagnose == "all" or (diagnose == "flagged" and final == "stiction"):
        entry.update(diagnosis_fields(r))
    return entry


#: a day, in seconds, and how close an oscillation period must be to it to be noted
DAY_S = 86400.0
DAY_TOLERANCE = 0.1


def period_notes(period_s: float | None) -> list[str]:
    """Notes on an oscillation period that points away from the valve: a period within
    10 % of a day is the signature of a daily external cycle (ambient temperature, a
    production schedule), which the published detectors, built on the shape and phase
    of a cycle, cannot tell from a limit cycle. A note, not a verdict: no labelled loop
    here has a daily cycle to set a rule on. The period is in ``t``'s unit, read as
    seconds (a day is 86 400 of them); the note says so, since a ``t`` in milliseconds
    turns an 86-second cycle into "a day".

    >>> period_notes(86400.0 * 1.03)[0][:60]
    'oscillation period 24.7 h (t read as seconds), about a day: '
    >>> period_notes(600.0)
    []
    """
    if period_s is None or not math.isfinite(period_s) or \
            abs(period_s / DAY_S - 1.0) > DAY_TOLERANCE:
        return []
    return [f"oscillation period {period_s / 3600:.1f} h (t read as seconds), about a "
            "day: a daily external "
            "cycle (ambient temperature, a production schedule) is a likelier cause than "
            "a valve limit cycle; the detectors cannot tell them apart"]


def tie_notes(votes: list[str]) -> list[str]:
    """A note when the consensus's deciding methods are split evenly: the verdict then
    rests on the tie rule (share ≥ threshold), not on agreement. On a loop that neither
    oscillates nor has set-point moves most methods abstain, and such a tie is what a
    single method whose premise fails decides (``reports/real/flow_loops.md``: Yamashita
    with PV for MV on regulatory flow loops). A note, not a verdict.

    >>> tie_notes(["stiction", "no_stiction"])[0][:52]
    'a tie: 1 of 2 deciding methods say stiction, so the '
    >>> tie_notes(["stiction", "stiction", "no_stiction"])
    []
    """
    k = sum(v == "stiction" for v in votes)
    if not votes or 2 * k != len(votes):
        return []
    return [f"a tie: {k} of {len(votes)} deciding methods say stiction, so the verdict "
            "rests on the consensus's tie rule; confirm with a look at the loop (see the "
            "README's caveat for batch)"]


#: the methods that read PV for an unrecorded valve position in a flow loop
PV_FOR_MV = ("kano", "yamashita")


def slip_notes(rec: Recording, calls: dict[str, Any], final: str) -> list[str]:
    """A note when a stiction verdict has Kano's or Yamashita's vote with PV standing in
    for the unrecorded valve, and none of those votes survives the slip check
    (:mod:`~stictionbench.estimators.slip_exit`: only stuck stretches that end in a slip
    the way OP pushed count). A PI holding a flow at its set point against a load moves
    OP while PV stays in its noise band, the picture those methods read as a stuck
    valve; a sticky valve ends the stretch with a slip. The check is not part of the
    verdict: it cut the false alarms on simulated regulatory flow loops but turned away
    a labelled sticky refinery loop whose slips are smaller than PV's noise band
    (``reports/real/slip_exit.md``). A note, not a verdict.
    """
    from ..estimators import make
    from .panel import loop_type

    if final != "stiction" or rec.MV is not None or loop_type(rec) != "F":
        return []
    voted = [m for m in PV_FOR_MV if getattr(calls.get(m), "verdict", None) == "stiction"]
    if not voted:
        return []
    for m in voted:
        if make(m, flow_loop=True, slip_exit=True).estimate(rec, x="OP").decision:
            return []
    return [f"{' and '.join(voted)} read PV for the unrecorded valve, and few of the "
            "stretches where PV stays put while OP moves end in a slip the way OP pushed: "
            "so does a PI holding the flow against a load, and a sticky valve whose slips "
            "are smaller than PV's noise; check the load's changes before the valve (the "
            "slip check, reports/real/slip_exit.md)"]


def lone_notes(deciding: list[str]) -> list[str]:
    """A note when a single method of the consensus decided: its ``confidence`` of 1.0
    is then one method agreeing with itself. On simulated oscillating level loops, where
    only the area ratio decides, that was a false alarm on 10 of 23 decided healthy
    loops (``reports/real/level_loops.md``). A note, not a verdict.

    >>> lone_notes(["area_ratio"])[0][:44]
    'the verdict rests on one method (area_ratio)'
    >>> lone_notes(["horch", "area_ratio"]), lone_notes([])
    ([], [])
    """
    if len(deciding) != 1:
        return []
    return [f"the verdict rests on one method ({deciding[0]}); the consensus's other "
            "methods were inconclusive, so its confidence is that method's alone; confirm "
            "with a look at the loop"]
