"""Detection, then quantification, in the model-free diagnosis
(:mod:`stictionbench.diagnosis.detection`, ``diagnose(..., detection=)``)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.diagnosis import NominalModel, diagnose
from stictionbench.diagnosis.detection import detect, name_detected
from stictionbench.diagnosis.fit import Fit
from stictionbench.diagnosis.result import Diagnosis
from stictionbench.diagnosis.routes import DECISION_ROUTES, decided_by


def _diagnosis(answer: str, j_interval: list[float], held: bool = False) -> Diagnosis:
    z = np.zeros(4)
    st = Fit("stiction", np.array([2.0, 1.0]), z, 1.0, {"S": 2.0, "J": 1.0}, 2, z, z,
             intervals={"S": [1.8, 2.2], "J": j_interval}, nrmse_val=0.3)
    d = Diagnosis(answer != "none", answer, {}, {"nominal": 0.4, "improved": 0.4}, [], [],
                  [], NominalModel(1.0, 10.0, 1.0), {}, fits={"stiction": st},
                  tests={"op_held_at_limit": {"named": held}})
    return d


FOUND = {"verdict": "stiction", "reason": "2 of 2 deciding methods say stiction (he, kano)",
         "consensus": {}, "loop_type": "F", "methods": {}}


def test_a_detected_valve_with_a_slip_jump_is_named_stiction_with_its_fit():
    d = name_detected(_diagnosis("none", [0.4, 1.6]), FOUND)
    assert d.missing_physics == "stiction" and d.mismatch_detected
    assert d.parameters == {"S": 2.0, "J": 1.0} and d.uncertainty["J"] == [0.4, 1.6]
    assert d.fit["improved"] == 0.3 and d.fit["nominal"] == 0.4
    t = d.tests["detection"]
    assert t["named"] and t["named_before"] == "none" and t["slip_jump_excludes_0"]
    assert decided_by(d) == "detection" and "detection" in DECISION_ROUTES
    assert "excludes 0" in d.details["detection"]


@pytest.mark.parametrize("answer, j, found, held", [
    ("none", [0.0, 1.6], FOUND, False),                            # J may be 0: a dead band
    ("none", [0.4, 1.6], {**FOUND, "verdict": "no_stiction"}, False),  # not detected
    ("none", [0.4, 1.6], {**FOUND, "verdict": "inconclusive"}, False),
    ("saturation", [0.4, 1.6], FOUND, True),                        # OP held at a limit
])
def test_the_route_leaves_the_answer_alone_otherwise(answer, j, found, held):
    d = name_detected(_diagnosis(answer, j, held), found)
    assert d.missing_physics == answer and not d.tests["detection"]["named"]
    assert "named_before" not in d.tests["detection"]
    assert d.tests["detection"]["verdict"] == found["verdict"]


def _sticky_flow_loop(seed: int = 3):
    r = sb.simulate("linear", duration=1500, seed=seed, sample_time=1.0,
                    overrides=["valve=kano", "valve.S=4.0", "valve.J=2.0",
                               "disturbance.load_std=0.3"])
    return sb.Recording.from_arrays(r.t, r.PV, r.OP, SP=r.SP, warn=False,
                                    meta={"name": "FIC101", "labels": {"loop_type": "F"}})


def test_detect_reports_every_consensus_method_and_the_loop_type():
    det = detect(_sticky_flow_loop())
    assert det["verdict"] in ("stiction", "no_stiction", "inconclusive")
    assert set(det["methods"]) == set(det["consensus"]["methods"])
    assert det["loop_type"] == "F"
    assert all(v["verdict"] in ("stiction", "no_stiction", "inconclusive")
               for v in det["methods"].values())


def test_detection_leaves_out_the_quantifications_kin_and_keeps_the_vote_rule(tmp_path):
    from stictionbench.diagnosis.detection import QUANTIFIER_KIN
    from stictionbench.realdata.consensus import Consensus

    shipped = Consensus.load()
    det = detect(_sticky_flow_loop())
    assert not set(QUANTIFIER_KIN) & set(det["consensus"]["methods"])
    assert set(det["consensus"]["methods"]) == set(shipped.methods) - set(QUANTIFIER_KIN)
    assert det["consensus"]["threshold"] == shipped.threshold
    assert det["consensus"]["min_votes"] == shipped.min_votes
    only = tmp_path / "only.yaml"
    only.write_text("methods: [hammerstein]\nthreshold: 0.5\nmin_votes: 1\n")
    det = detect(_sticky_flow_loop(), str(only))
    assert det["verdict"] == "inconclusive" and det["methods"] == {}
    assert "quantification" in det["reason"]


def test_model_free_diagnose_carries_the_detection_and_a_model_turns_it_off():
    rec = _sticky_flow_loop()
    d = diagnose(rec, detection=True)
    t = d.tests["detection"]
    assert t["verdict"] == detect(rec)["verdict"]
    if t["named"]:
        assert d.missing_physics == "stiction" and d.details["decided_by"] == "detection"
    json.dumps(d.to_json(), allow_nan=False)
    off = diagnose(rec, detection=False)
    assert "detection" not in off.tests
    assert off.missing_physics == t.get("named_before", d.missing_physics)
    given = diagnose(rec, NominalModel(1.0, 5.0, 1.0), detection=True)
    assert "detection" not in given.tests


def test_cli_detection_is_opt_in_and_lands_in_the_json(tmp_path):
    import subprocess
    import sys

    import pandas as pd

    rec = _sticky_flow_loop()
    csv = tmp_path / "FIC101.csv"
    pd.DataFrame({"t": rec.t, "SP": rec.SP, "PV": rec.PV, "OP": rec.OP}).to_csv(csv,
                                                                             index=False)
    outs = {}
    for flag in ([], ["--detection"]):
        out = tmp_path / f"out{len(flag)}.json"
        r = subprocess.run([sys.executable, "-m", "stictionbench.cli", "diagnose", str(csv),
                            "--json", str(out), *flag], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        outs[bool(flag)] = json.loads(out.read_text())
    assert "detection" not in outs[False]["tests"]
    det = outs[True]["tests"]["detection"]
    assert set(det["methods"]) == set(det["consensus"]["methods"])
    assert det["verdict"] in ("stiction", "no_stiction", "inconclusive")
    assert (outs[True]["missing_physics"] == "stiction") if det["named"] else \
        outs[True]["missing_physics"] == outs[False]["missing_physics"]
