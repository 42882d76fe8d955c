"""The detectors compared loop by loop, and the consensus fitted on one dataset."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import stictionbench as sb
from stictionbench.cli import main
from stictionbench.io import write_recording
from stictionbench.realdata.compare import Call, balanced_accuracy, loop_verdicts
from stictionbench.realdata.consensus import Consensus, cross_dataset, fit, lolo


def _loops(verdicts: dict[str, list[str]], labels: list[str]) -> pd.DataFrame:
    df = pd.DataFrame({"loop": [f"L{i}" for i in range(len(labels))], "label": labels})
    for m, v in verdicts.items():
        df[m] = v
    return df


def test_loop_majority_and_ties():
    w = [{"name": f"w{i}", "group": "A", "label": "stiction", "loop_type": "F",
          "m": Call(v, "r")} for i, v in enumerate(["stiction", "stiction", "no_stiction"])]
    w += [{"name": "x", "group": "B", "label": "no_stiction", "loop_type": "L",
           "m": Call("stiction", "r")},
          {"name": "y", "group": "B", "label": "no_stiction", "loop_type": "L",
           "m": {"verdict": "no_stiction", "reason": "r"}}]
    lv = loop_verdicts(w, ["m"]).set_index("loop")
    assert lv.loc["A", "m"] == "stiction" and lv.loc["A", "windows"] == 3
    assert lv.loc["B", "m"] == "inconclusive"  # one window each way
    # the votes behind each majority, only where asked for
    assert "m_stiction_windows" not in lv.columns
    lc = loop_verdicts(w, ["m"], counts=["m"]).set_index("loop")
    assert (lc.loc["A", "m_stiction_windows"], lc.loc["A", "m_decided_windows"]) == (2, 3)
    assert (lc.loc["B", "m_stiction_windows"], lc.loc["B", "m_decided_windows"]) == (1, 2)


def test_consensus_fit_prefers_the_informative_method():
    labels = ["stiction"] * 4 + ["no_stiction"] * 4
    good = ["stiction"] * 4 + ["no_stiction"] * 4
    noise = ["stiction", "no_stiction"] * 4
    loops = _loops({"good": good, "noise": noise, "mute": ["inconclusive"] * 8}, labels)
    c = fit(loops, ("good", "noise", "mute"))
    assert "good" in c.methods
    assert balanced_accuracy(loops["label"], c.apply(loops)) == 1.0
    v = lolo(loops, ("good", "noise", "mute"))
    assert balanced_accuracy(loops["label"], v) == 1.0


def test_consensus_needs_votes_and_says_why():
    c = Consensus(("a", "b"), threshold=0.5, min_votes=2)
    assert c.decide({"a": "stiction", "b": "inconclusive"})[0] == "inconclusive"
    assert c.decide({"a": "stiction", "b": "no_stiction"}) == (
        "stiction", "1 of 2 deciding methods say stiction (a)")


def test_cross_dataset_marks_in_sample_rows():
    labels = ["stiction", "no_stiction"] * 3
    a = _loops({"m": labels, "n": ["stiction"] * 6}, labels)
    b = _loops({"m": labels[::-1], "n": ["stiction"] * 6}, labels)
    cross = cross_dataset({"a": a, "b": b}, ("m", "n"))
    ab = cross[(cross.trained_on == "a") & (cross.scored_on == "b")].iloc[0]
    assert bool(ab.out_of_sample) and ab.balanced_accuracy == 0.0  # m flips between sets
    aa = cross[(cross.trained_on == "a") & (cross.scored_on == "a")].iloc[0]
    assert not bool(aa.out_of_sample) and aa.balanced_accuracy == 1.0


def test_shipped_consensus_loads():
    c = Consensus.load()
    assert c.methods and 0 < c.threshold <= 1 and c.min_votes >= 1


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    root = tmp_path_factory.mktemp("cmp")
    cases = {"st": ("stiction", "stiction"), "li": ("tight", "no_stiction")}
    out = []
    for k in ("one", "two"):
        d = root / k
        d.mkdir()
        rows = []
        for i, (name, (case, label)) in enumerate(cases.items()):
            rec = sb.simulate(case, seed=i + (k == "two"), duration=2000, sample_time=1.0,
                              sensor="noisy")
            write_recording(sb.Recording.from_arrays(rec.t, rec.PV, rec.OP, SP=rec.SP),
                            d / f"{name}.csv")
            rows.append(f"{name},{label},F")
        (d / "labels.csv").write_text("loop,label,loop_type\n" + "\n".join(rows) + "\n")
        out.append(d)
    return out


def test_compare_cli(folders, tmp_path, capsys):
    out, cons = tmp_path / "rep", tmp_path / "c.yaml"
    assert main(["compare", *map(str, folders), "--out", str(out), "--consensus", str(cons),
                 "--jobs", "1"]) == 0
    md = (out / "comparison.md").read_text()
    assert "method × loop" in md and "out of sample" in md
    cross = pd.read_csv(out / "cross_dataset.csv")
    assert {"trained_on", "scored_on", "out_of_sample", "balanced_accuracy"} <= set(cross)
    assert (out / "comparison.png").stat().st_size > 5000
    assert Consensus.load(cons).methods
    assert "scored on" in capsys.readouterr().out
    # the trained consensus drives batch
    j = tmp_path / "b.json"
    assert main(["batch", str(folders[0]), "--labels", str(folders[0] / "labels.csv"),
                 "--json", str(j), "--consensus", str(cons), "--jobs", "1"]) == 0
    res = json.loads(j.read_text())
    assert {r["verdict"] for r in res["recordings"]} <= {"stiction", "no_stiction", "unusable"}
    assert np.isfinite(res["scores"]["balanced_accuracy_logo"])


def test_compare_refuses_unlabelled_folder(tmp_path, capsys):
    (tmp_path / "d").mkdir()
    assert main(["compare", str(tmp_path / "d"), "--out", str(tmp_path / "o")]) == 2
    assert "labels.csv" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
    assert main(["compare", str(tmp_path / "typo"), "--out", str(tmp_path / "o")]) == 2
    assert "typo: no such directory" in capsys.readouterr().err


def test_hammerstein_methods_fit_each_window_afresh():
    """The two model-based methods share one fit per window; a later window (which may
    reuse a freed window's memory address) must never get an earlier window's fit."""
    from stictionbench.diagnosis.hammerstein import fit_hammerstein
    from stictionbench.realdata import panel
    from stictionbench.realdata.panel import METHODS

    for seed, case in ((3, "stiction"), (4, "linear")):
        rec = sb.simulate(case, duration=1500, seed=seed, sample_time=1.0, sensor="noisy",
                          setpoint="constant", disturbance="load",
                          disturbance__load_std=0.5)
        rec = sb.Recording.from_arrays(rec.t, rec.PV, rec.OP)
        call = METHODS["hammerstein"](rec, "F")
        # the cache holds the window itself, so no later window can share its id
        assert panel._FIT[0] is rec
        h = fit_hammerstein(rec)
        assert call.value == pytest.approx(h.J if h.stiction or h.sticky else h.S)
        del rec


def test_a_method_that_fails_on_a_short_window_says_why_in_words():
    """A window too short for the valve identification gets that as its reason, without
    the file's path the input error starts with and not cut mid-word (a first version
    printed "../shared/data/plant/….csv: 126 samples; valve id")."""
    from stictionbench.realdata.panel import window_calls

    rec = sb.simulate("stiction", duration=150, seed=3, sample_time=1.0, sensor="noisy")
    src = "some/folder/LIC63001_0628_1642.csv"
    rec = sb.Recording.from_arrays(rec.t, rec.PV, rec.OP, SP=rec.SP, meta={"source": src})
    calls = window_calls(rec, "LIC63001", methods=("hammerstein",))
    call = calls["hammerstein"]
    assert call.verdict == "inconclusive"
    assert call.reason.startswith("151 samples; valve identification needs >= 200"), call.reason
    assert src not in call.reason


def test_model_based_methods_do_not_rule_a_valve_out_on_regulatory_data():
    """Without set-point excitation the process identified from OP → PV is biased
    (experiments/regulatory_bias.py), so a valve not found is inconclusive; with
    set-point steps the same linear loop is judged: no stiction."""
    from stictionbench.realdata.compare import METHODS

    kw = dict(duration=1500, seed=4, sample_time=1.0, sensor="noisy", disturbance="load",
              disturbance__load_std=0.5)
    reg = sb.simulate("linear", setpoint="constant", **kw)
    servo = sb.simulate("linear", **kw)
    for name in ("hammerstein", "delay_est_mv"):
        call = METHODS[name](sb.Recording.from_arrays(reg.t, reg.PV, reg.OP, SP=reg.SP), "F")
        assert call.verdict == "inconclusive" and "regulatory data" in call.reason
    call = METHODS["hammerstein"](sb.Recording.from_arrays(servo.t, servo.PV, servo.OP,
                                                           SP=servo.SP), "F")
    assert call.verdict == "no_stiction", call.reason


def test_choudhury_gaussian_answer_is_not_evidence_against_a_sticky_valve():
    """At 1000 samples (K = 14 segments) the Gaussianity test calls a Kano stick-slip limit
    cycle Gaussian (experiments/bicoherence_power.py: 0 of 96 found non-Gaussian up to
    4096 samples), so that answer is inconclusive, never 'no_stiction'."""
    from stictionbench.realdata.compare import METHODS

    rec = sb.simulate("linear", duration=1200, seed=501, sample_time=1.0, sensor="noisy",
                      setpoint="constant", disturbance="load", disturbance__load_std=0.5,
                      valve="kano", valve__S=6.0, valve__J=3.0)
    rec = sb.Recording.from_arrays(rec.t[-1000:], rec.PV[-1000:], rec.OP[-1000:])
    bic = sb.estimators.make("bicoherence").estimate(rec, x="PV")
    assert not bic.diagnostics["non_gaussian"]
    call = METHODS["choudhury"](rec, "F")
    assert call.verdict == "inconclusive" and "no power" in call.reason, call


def test_one_se_rule_keeps_the_untrained_vote_on_weak_evidence():
    # two sticky loops: "lucky" is right on all six loops, but the untrained vote of all
    # three (share >= 0.5) is right on five: within one standard error, so it stays
    from stictionbench.errors import InputError
    from stictionbench.realdata.consensus import prior_distance

    labels = ["stiction"] * 2 + ["no_stiction"] * 4
    lucky = ["stiction"] * 2 + ["no_stiction"] * 4
    other = ["stiction", "stiction", "stiction", "no_stiction", "no_stiction", "no_stiction"]
    mute = ["inconclusive"] * 6
    loops = _loops({"lucky": lucky, "other": other, "mute": mute}, labels)
    cands = ("lucky", "other", "mute")
    best = fit(loops, cands, rule="best")
    one = fit(loops, cands, rule="one_se")
    assert balanced_accuracy(loops["label"], best.apply(loops)) == 1.0
    assert prior_distance(one, cands) < prior_distance(best, cands)
    assert one == Consensus(cands)
    # strong evidence moves it: with twenty loops the same pattern drops the noisy vote
    many = pd.concat([loops] * 10, ignore_index=True)
    many["other"] = (["stiction", "stiction"] + ["stiction"] * 4) * 10
    moved = fit(many, cands, rule="one_se")
    assert "other" not in moved.methods or moved.threshold > 0.5
    with pytest.raises(InputError, match="fit rule"):
        fit(loops, cands, rule="tuned")
