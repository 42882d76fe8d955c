"""Batch verdicts: the rule on simulated loops, the CLI, real data."""

from __future__ import annotations

import json

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.cli import main
from stictionbench.io import write_recording
from stictionbench.realdata.verdict import StictionRule, assess

COMMON = dict(duration=3000.0, sample_time=1.0, sensor="noisy", setpoint="constant",
              controller__sample_time=1.0)


@pytest.fixture(scope="module")
def loops():
    return {
        "sticky": sb.simulate("stiction", seed=1, valve__Fs=300.0, valve__Fc=150.0, **COMMON),
        # tuning oscillation near the loop crossover (Kc close to the ultimate 0.524)
        "tight": sb.simulate("tight", seed=1, valve="linear", controller__kc=0.5, **COMMON),
    }


def test_rule_on_simulated_loops(loops):
    assert assess(loops["sticky"], "sticky", run_diagnosis=False)["verdict"] == "stiction"
    e = assess(loops["tight"], "tight", run_diagnosis=False)
    assert e["verdict"] == "no_stiction", e


@pytest.mark.parametrize("period", [60.0, 100.0, 300.0])
def test_cycle_opening_is_set_by_the_controller(period):
    """The PV–OP phase is ∠C(jω) = atan(1/(ω·Ti)) whatever the cause (plus one sample of
    the simulator's recording convention, OP stored before the controller executes):
    the documented limit of the rule — a disturbance slower than ~4·Ti is called
    stiction."""
    import math

    rec = sb.simulate("disturbance", seed=2, valve="linear", disturbance__period=period,
                      **COMMON)
    e = assess(rec, "d", run_diagnosis=False)
    expected = math.degrees(math.atan(period / (2 * math.pi * 10.0))) + 360.0 / period
    assert e["op_pv_phase_deg"] == pytest.approx(expected, abs=4.0)
    assert e["verdict"] == "stiction"


def test_batch_cli(loops, tmp_path, capsys):
    d = tmp_path / "data"
    d.mkdir()
    # the published detectors need a regular oscillation: the paper's stiction loop has one
    cli_loops = {"sticky": sb.simulate("stiction", seed=1, duration=3000, sample_time=1.0,
                                       sensor="noisy"), "tight": loops["tight"]}
    for name, rec in cli_loops.items():
        write_recording(rec, d / f"{name}.csv")
    (d / "notes.csv").write_text("a,b\n1,2\n")
    (d / "export.parquet").write_bytes(b"")  # a format batch does not read: named
    (d / "labels.csv").write_text("loop,label\nsticky,stiction\ntight,no_stiction\n")
    out = tmp_path / "b.json"
    rep = tmp_path / "rep"
    assert main(["batch", str(d), "--labels", str(d / "labels.csv"), "--json", str(out),
                 "--report", str(rep), "--jobs", "1"]) == 0
    res = json.loads(out.read_text())
    names = {r["name"]: r for r in res["recordings"]}
    assert set(names) == {"sticky", "tight"}
    for r in names.values():
        assert {"name", "verdict", "missing_physics", "confidence", "fitted_S", "fitted_J",
                "oscillation_period_s", "apparent_stiction", "methods"} <= set(r)
        assert {"horch", "he", "area_ratio", "kano", "yamashita", "choudhury"} <= set(
            r["methods"])
        assert all(v["verdict"] in ("stiction", "no_stiction", "inconclusive")
                   and v["reason"] for v in r["methods"].values())
    assert names["sticky"]["verdict"] == "stiction"
    assert names["tight"]["verdict"] == "no_stiction"
    assert {s["file"] for s in res["skipped"]} == {"notes.csv", "labels.csv",
                                                   "export.parquet"}
    assert res["scores"]["balanced_accuracy_by_group"] == 1.0
    # each loop says how close its majority is
    groups = {g["group"]: g for g in res["scores"]["groups"]}
    assert (groups["sticky"]["stiction_windows"], groups["sticky"]["decided_windows"]) == (1, 1)
    assert (groups["tight"]["stiction_windows"], groups["tight"]["decided_windows"]) == (0, 1)
    for f in ("entries.md", "methods.md", "groups.csv", "logo.csv", "confusion.md", "summary.md",
              "timeseries.png", "phase.png"):
        assert (rep / f).is_file()
    assert "balanced accuracy by loop" in capsys.readouterr().out
    assert main(["batch", str(tmp_path / "nothing"), "--json", str(out)]) == 2


def test_isdb_balanced_accuracy(data_dir):
    """The first-release ellipse rule (``ellipse_v1`` of the comparison, in-sample: its
    thresholds were chosen on these loops) scored by loop with the comparison's own
    loop aggregation."""
    from stictionbench.realdata.compare import balanced_accuracy, loop_verdicts
    from stictionbench.realdata.datasets import load_csv_dir

    recs, _ = load_csv_dir(data_dir / "isdb", warn=False)
    windows = []
    for name, rec in recs.items():
        e = assess(rec, name, StictionRule(), run_diagnosis=False)
        windows.append({"group": rec.meta["group"], "label": rec.meta["label"],
                        "loop_type": "", "ellipse": {"verdict": e["verdict"]}})
    loops = loop_verdicts(windows, ["ellipse"])
    ba = balanced_accuracy(loops["label"], loops["ellipse"])
    assert len(loops) == 14 and ba >= 0.9


def test_a_file_cut_by_an_outage_gives_windows_of_one_loop(loops, tmp_path):
    # a historian outage longer than the interpolation limit no longer skips the file:
    # each usable stretch is a window of the file's loop, and keeps the file's label
    import numpy as np

    from stictionbench.realdata.datasets import load_csv_dir

    frame = loops["sticky"].to_frame()[["t", "SP", "PV", "OP"]]
    frame.loc[1500:1559, ["PV", "OP"]] = np.nan
    frame.to_csv(tmp_path / "outage.csv", index=False)
    (tmp_path / "labels.csv").write_text("loop,label\noutage,stiction\n")
    recs, skipped = load_csv_dir(tmp_path, warn=False)
    assert [s[0] for s in skipped] == ["labels.csv"]
    assert list(recs) == ["outage@2-1501", "outage@1562-3002"]  # file rows
    for r in recs.values():
        assert r.meta["group"] == "outage" and r.meta["label"] == "stiction"
    assert len(recs["outage@2-1501"]) == 1500


def test_a_european_spreadsheet_export_is_a_recording_of_the_folder(loops, tmp_path):
    # ';' as the delimiter, a decimal comma and lower-case names: loaded, not skipped as
    # "a table without t, PV, OP", and read as the same numbers
    from stictionbench.realdata.datasets import load_csv_dir

    frame = loops["sticky"].to_frame()[["t", "SP", "PV", "OP"]]
    frame.to_csv(tmp_path / "plain.csv", index=False)
    frame.rename(columns=str.lower).to_csv(tmp_path / "export.csv", index=False, sep=";",
                                           decimal=",")
    recs, skipped = load_csv_dir(tmp_path, warn=False)
    assert skipped == [] and sorted(recs) == ["export", "plain"]
    for c in ("t", "SP", "PV", "OP"):
        assert (getattr(recs["export"], c) == getattr(recs["plain"], c)).all()


def test_without_a_labels_table_the_flow_methods_read_the_tag(loops, tmp_path):
    # a folder of plant exports without labels.csv: Kano's and Yamashita's methods (flow
    # loops only) take the loop type from the ISA-5.1 tag in the file name, as they take
    # it from the labels table's loop_type; a name without a tag leaves it unknown
    from stictionbench.realdata.compare import loop_type
    from stictionbench.realdata.datasets import load_csv_dir

    frame = loops["sticky"].to_frame()[["t", "SP", "PV", "OP"]]  # MV not recorded
    for name in ("2411FIC20102_0609", "loop7"):
        frame.to_csv(tmp_path / f"{name}.csv", index=False)
    recs, _ = load_csv_dir(tmp_path, warn=False)
    assert loop_type(recs["2411FIC20102_0609"]) == "F"
    assert loop_type(recs["loop7"]) == "?"
    out = tmp_path / "b.json"
    assert main(["batch", str(tmp_path), "--json", str(out), "--jobs", "1"]) == 0
    meth = {r["name"]: r["methods"] for r in json.loads(out.read_text())["recordings"]}
    assert meth["loop7"]["kano"]["reason"] == "MV not recorded and not a flow loop"
    assert meth["2411FIC20102_0609"]["kano"]["reason"] != "MV not recorded and not a flow loop"
    assert "evidence" not in meth["loop7"]["yamashita"]   # undecided: nothing to rest on


def test_yamashita_evidence_reaches_the_batch_json(tmp_path):
    # a flow loop whose valve sticks (PV, the flow, moves in steps while OP ramps):
    # Yamashita's verdict comes with the number of moving samples it rests on
    t = np.arange(1500.0)
    op = 50.0 + 10.0 * np.abs(((t / 150.0) % 2.0) - 1.0) * 2.0 - 10.0
    pv = np.round(op / 4.0) * 4.0 + 0.01 * np.sin(t)
    sb.Recording.from_arrays(t, pv, op, warn=False).to_frame()[["t", "PV", "OP"]].to_csv(
        tmp_path / "FIC101.csv", index=False)
    out = tmp_path / "b.json"
    assert main(["batch", str(tmp_path), "--json", str(out), "--jobs", "1"]) == 0
    yam = json.loads(out.read_text())["recordings"][0]["methods"]["yamashita"]
    assert yam["verdict"] == "stiction", yam
    assert "moving samples" in yam["evidence"] and "95 %" in yam["evidence"]


def _rewritten(rec, how):
    """The same loop written down differently: t in minutes, or PV and SP reversed."""
    if how == "minutes":
        return sb.Recording.from_arrays(rec.t / 60.0, rec.PV, rec.OP, SP=rec.SP, MV=rec.MV)
    return sb.Recording.from_arrays(rec.t, -rec.PV, rec.OP, SP=-rec.SP, MV=rec.MV)


@pytest.mark.parametrize("how", ["minutes", "pv_negated"])
def test_every_method_is_blind_to_how_the_loop_is_written_down(loops, how):
    # the unit of time and the sign of the transmitter are bookkeeping, not physics
    # (experiments/invariance.py checks the same on the ISDB loops)
    from stictionbench.realdata.verdict import judge

    for name, rec in loops.items():
        a, b = judge(rec, name), judge(_rewritten(rec, how), name)
        assert b["verdict"] == a["verdict"], name
        assert ({m: v["verdict"] for m, v in b["methods"].items()}
                == {m: v["verdict"] for m, v in a["methods"].items()}), name


def test_a_tie_of_the_deciding_methods_is_noted(loops):
    # the batch entry says when its verdict rests on the tie rule: two methods that
    # disagree on the same loop vote alone (the failure mode of reports/real/flow_loops.md)
    # (the tightly tuned loop: the area ratio reads its cycle as stiction, He et al.'s
    # curve fit as a sine)
    from stictionbench.realdata.compare import FAST
    from stictionbench.realdata.consensus import Consensus
    from stictionbench.realdata.verdict import judge

    rec = sb.Recording.from_arrays(loops["tight"].t, loops["tight"].PV, loops["tight"].OP,
                                   SP=loops["tight"].SP)
    calls = judge(rec, "tight", Consensus(FAST), diagnose="none")["methods"]
    yes = next(m for m, c in calls.items() if c["verdict"] == "stiction")
    no = next(m for m, c in calls.items() if c["verdict"] == "no_stiction")
    tie = judge(rec, "tight", Consensus((yes, no), 0.5, 1), diagnose="none")
    assert (tie["verdict"], tie["confidence"]) == ("stiction", 0.5)
    assert any(n.startswith("a tie: 1 of 2 deciding methods") for n in tie["notes"])
    agreed = judge(rec, "tight", Consensus((yes,), 0.5, 1), diagnose="none")
    assert agreed["confidence"] == 1.0
    assert not any(n.startswith("a tie") for n in agreed["notes"])
    # one deciding method: its confidence of 1.0 is said to be that method's alone
    assert any(n.startswith(f"the verdict rests on one method ({yes})")
               for n in agreed["notes"])
    assert not any(n.startswith("the verdict rests on one") for n in tie["notes"])
