"""``experiments/oracle_ceiling.py`` puts the physics an independent generator hid through
the diagnosis's own test: the regenerated recording is the stored one, a sticky valve's
true position beats the nominal model on a level-1 recording, the recorded OP itself
as the "oracle" changes nothing, the hypothesis registry is left as it was, and the
replay of generator C's valves between samples is rate-independent where the models are
(a dead band, Kano's valve) and moved by the jitter."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import oracle_ceiling as oc  # noqa: E402

from stictionbench.diagnosis import load_model  # noqa: E402
from stictionbench.diagnosis.hypotheses import HYPOTHESES  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402

GEN = ROOT / "experiments" / "blind_generator_c" / "generate.py"


def test_oracle_of_a_sticky_valve_and_of_no_effect(tmp_path):
    out = tmp_path / "set"
    subprocess.run([sys.executable, str(GEN), "--out", str(out), "--per-class", "1",
                    "--first-seed", "11000"], check=True, capture_output=True)
    truth = pd.read_csv(out / "truth.csv")
    row = truth[(truth["class"] == "stiction") & (truth["level"] == 1)].iloc[0]
    before = dict(HYPOTHESES)
    res = oc.oracle_row("e", {"name": row["name"], "class": "stiction", "level": 1,
                              "seed": int(row["seed"]), "predicted": "none"}, data=out)
    assert HYPOTHESES == before  # the oracle was registered only while judged
    assert res["oracle"] == "replayed"  # regenerated OP within 0.01 of the CSV's
    assert res["ours"] is False
    # a level-1 sticky valve's true position explains PV far better than OP does
    assert res["oracle_passes"] and res["oracle_p"] < 1e-6
    assert res["oracle_improvement"] > 0.1 and res["footprint"] > 0.3
    # the recorded OP as the "valve position" is the nominal model: nothing to name
    rec = read_recording(str(out / f"{row['name']}.csv"), warn=False)
    null = oc.judge(rec, load_model(out / f"{row['name']}.model.yaml"), "stiction",
                    {"series": np.asarray(rec.OP, float)})
    assert not null["oracle_passes"] and not null["oracle_p_only"]
    assert null["footprint"] < 1e-6 and abs(null["oracle_improvement"]) < 1e-6


def test_ceiling_keeps_ours_and_adds_the_oracle():
    oracle = pd.DataFrame({"name": ["s1", "s2"], "oracle": ["replayed", "replayed"],
                           "oracle_passes": [True, False]})
    ind = pd.DataFrame({"name": ["s1", "s2", "n1", "n2"], "generator": "g", "level": 1,
                        "class": ["stiction", "stiction", "none", "none"],
                        "predicted": ["none", "stiction", "none", "stiction"]})
    row = oc.ceiling(oracle, ind).iloc[0]
    # ours: stiction 1/2, none 1/2 -> 8.0 of 16; with the oracle stiction 2/2 -> 12.0
    assert row["ours, of 16"].startswith("8.0 ")
    assert row["ours or the oracle, of 16"].startswith("12.0 ")


def test_valves_between_samples():
    t = np.arange(400.0)
    op = 50 + 10 * np.sin(2 * np.pi * t / 100) + 0.3 * np.sin(2 * np.pi * t / 7)
    for eff in ({"class": "deadband", "d": 3.0},
                {"class": "stiction", "model": "Kano2004", "S": 3.0, "J": 1.0}):
        calm = oc.replays(op, eff, 5, 0.0)
        # OP interpolated linearly: the same path, only finer; a play operator and
        # Kano's valve depend on the path, not on its speed
        np.testing.assert_allclose(calm["expected"], calm["sampled"], atol=1e-12)
        assert np.ptp(calm["sampled"] - op) > 1.0  # the valve lags OP: not OP itself
        shaken = oc.replays(op, eff, 5, 1.0)
        assert np.max(np.abs(shaken["expected"] - shaken["sampled"])) > 0.1
    band = oc.replays(op, {"class": "deadband", "d": 3.0}, 1, 0.0)["sampled"]
    assert np.max(np.abs(band - op)) <= 1.5 + 1e-9  # never further than half the band
