"""``experiments/first_release.py`` runs the package as it was at the first release on a
recording, as a user ran it then, and compares it with today's verdicts: the old code is
taken from git and gives a verdict through its own command line, the model YAML is cut
to the keys it read, the paired comparison counts the right discordant recordings, and
the projection onto the judged set moves with today's rates where the first release
missed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import first_release as fr  # noqa: E402

CLASSES = {"none", "stiction", "deadband", "sensor_lag", "dead_time",
           "valve_characteristic", "saturation", "oscillatory_disturbance"}


def _has_commit(commit: str) -> bool:
    return subprocess.run(["git", "-C", str(ROOT), "cat-file", "-e", f"{commit}^{{commit}}"],
                          capture_output=True, check=False).returncode == 0


@pytest.mark.skipif(not _has_commit(fr.FIRST),
                    reason=f"the first release's commit {fr.FIRST} is not in this clone "
                           "(a shallow clone)")
def test_first_release_diagnoses_through_its_own_command(tmp_path):
    code = fr.extract(fr.FIRST, tmp_path / "code")
    # the old diagnosis, not today's, is what runs
    old = (code / "stictionbench" / "diagnosis").exists() or \
        (code / "stictionbench" / "diagnosis.py").exists()
    assert old and not (code / "stictionbench" / "diagnosis" / "line.py").exists()
    sys.path.insert(0, str(ROOT / "experiments"))
    import concealed

    job = concealed.generate("stiction", 1, 3, tmp_path)
    data = tmp_path / "data"
    data.mkdir()
    name = "rec"
    (data / f"{name}.csv").write_text(Path(job["csv"]).read_text())
    (data / f"{name}.model.yaml").write_text(Path(job["model"]).read_text()
                                             + "op_range: [0, 100]\n")
    work = tmp_path / "work"
    work.mkdir()
    row = fr.diagnose_first(str(code), str(data), str(work), name)
    assert row["first_error"] == "" and row["first"] in CLASSES
    assert "op_range" not in (work / f"{name}.yaml").read_text()
    out = json.loads((work / f"{name}.json").read_text())
    assert out["missing_physics"] == row["first"]
    # the old command wrote it (run from this checkout, today's package must not shadow it)
    assert not set(out) & set(fr.TODAY_ONLY)


def test_first_model_keeps_only_the_keys_the_first_release_read():
    text = ("process: {gain: 2, time_constant: 10, dead_time: 3}\n"
            "controller:\n  kc: 0.2\n  ti: 10\nop_range:\n  - 0\n  - 100\n"
            "sample_time: 1.0\n")
    out = fr.first_model(text)
    assert "op_range" not in out and "- 100" not in out
    assert "  kc: 0.2" in out and "sample_time: 1.0" in out


def test_paired_counts_the_discordant_recordings():
    df = pd.DataFrame({"class": ["stiction"] * 4 + ["none"] * 2,
                       "predicted": ["stiction", "stiction", "stiction", "none", "none",
                                     "none"],
                       "first": ["stiction", "none", "none", "none", "none", "deadband"]})
    row = fr.paired(df)
    assert row["right only today / only first"] == "3 / 0"  # rows 1, 2 and 5
    assert row["`none` called physics, first"].startswith("1/2")
    assert row["`none` called physics, today"].startswith("0/2")
    # stiction 3/4 and none 2/2 today: 16 * (0.75 + 1) / 2 = 14
    assert row["today, of 16"].startswith("14.0 ")


def test_projection_follows_todays_rate_where_the_first_release_missed():
    first = ["a"] * 30 + ["x"] * 30
    good = pd.DataFrame({"class": "a", "first": first, "predicted": ["a"] * 60})
    bad = pd.DataFrame({"class": "a", "first": first, "predicted": ["a"] * 30 + ["x"] * 30})
    # the first release named one of the judged set's two right
    hi = fr.projected(good, {"a": 1}, draws=2000)
    lo = fr.projected(bad, {"a": 1}, draws=2000)
    assert np.median(hi) == 16 and np.median(lo) == 8
    # where the first release named both right, today's misses elsewhere do not matter
    assert np.median(fr.projected(bad, {"a": 2}, draws=2000)) == 16


def test_stored_first_verdicts_are_checked_against_the_recordings(tmp_path):
    data = tmp_path / "set_a"
    data.mkdir()
    for n, body in (("r1", "t,PV\n0,1\n"), ("r2", "t,PV\n0,2\n")):
        (data / f"{n}.csv").write_text(body)
        (data / f"{n}.model.yaml").write_text("sample_time: 1.0\n")
    def hashes(names):
        return pd.Series({n: fr.recording_sha256(data, n) for n in names})

    rows = pd.DataFrame({"set": "a", "name": ["r1", "r2"], "first": ["none", "stiction"],
                         "first_error": ["", ""]})
    old = tmp_path / "old.csv"
    rows.to_csv(old, index=False)
    got, verified = fr.stored_first(old, "a", hashes(["r1", "r2"]))
    assert list(got["first"]) == ["none", "stiction"] and not verified
    rows["recording_sha256"] = [fr.recording_sha256(data, n) for n in rows["name"]]
    rows.to_csv(old, index=False)
    got, verified = fr.stored_first(old, "a", hashes(["r1", "r2"]))
    assert verified and list(got["name"]) == ["r1", "r2"]
    # a recording changed since its verdict was made, or one the file lacks: refused
    (data / "r2.csv").write_text("t,PV\n0,3\n")
    with pytest.raises(ValueError, match="differs"):
        fr.stored_first(old, "a", hashes(["r1", "r2"]))
    (data / "r3.csv").write_text("t,PV\n0,4\n")
    (data / "r3.model.yaml").write_text("sample_time: 1.0\n")
    with pytest.raises(ValueError, match="lacks"):
        fr.stored_first(old, "a", hashes(["r1", "r3"]))


def test_holdout_anchor_summary_counts_both_diagnoses_per_level():
    import first_release_holdout as frh

    rows = []
    for lvl in (1, 2):
        for cls in sorted(CLASSES):
            for i in range(4):
                rows.append({"level": lvl, "class": cls, "name": f"{lvl}{cls}{i}",
                             "first": cls if i < 2 else "none" if cls != "none" else "x",
                             "predicted": cls})
    t = frh.summary(pd.DataFrame(rows)).set_index("level")
    # the first release names half of every class, today all of them
    assert t.loc[1, "first release here, of 16"].startswith("8.0")
    assert t.loc[2, "today here, of 16"].startswith("16.0")
    # today right wherever the first release was and was not: projected high, more likely
    # to reach the goal than a diagnosis that repeats the first release's misses
    assert float(t.loc[1, "today projected onto the judged set"].split()[0]) >= 12
    same = frh.summary(pd.DataFrame(rows).assign(predicted=lambda d: d["first"]))
    assert float(t.loc[1, "P(projection ≥ goal)"]) > float(same.iloc[0]["P(projection ≥ goal)"])


def test_holdout_anchor_writes_the_recordings_of_holdout_fresh(tmp_path, monkeypatch):
    import first_release_holdout as frh

    monkeypatch.setattr(frh, "SEEDS", 1)
    monkeypatch.setattr(frh, "NONE_SEEDS", 1)
    monkeypatch.setattr(frh, "CLASSES", ["none", "deadband"])
    block = frh.write_block(tmp_path)
    assert list(block.name) == ["holdout_sync_L1_none_21000", "holdout_sync_L1_deadband_21000",
                                "holdout_sync_L2_none_21000", "holdout_sync_L2_deadband_21000"]
    for n in block.name:
        assert (tmp_path / f"{n}.csv").is_file() and (tmp_path / f"{n}.model.yaml").is_file()


def test_holdout_anchor_writes_any_block_and_marks_it(tmp_path, monkeypatch):
    import first_release_holdout as frh

    monkeypatch.setattr(frh, "SEEDS", 1)
    monkeypatch.setattr(frh, "NONE_SEEDS", 1)
    monkeypatch.setattr(frh, "CLASSES", ["stiction"])
    block = frh.write_block(tmp_path, 22000)
    assert list(block.name) == ["holdout_sync_L1_stiction_22000",
                                "holdout_sync_L2_stiction_22000"]
    assert set(block.block) == {22000}


def test_holdout_anchor_cells_split_each_class_by_the_first_release():
    import first_release_holdout as frh

    df = pd.DataFrame({"level": [1] * 4, "class": ["deadband"] * 4,
                       "first": ["deadband", "deadband", "stiction", "stiction"],
                       "predicted": ["deadband", "none", "deadband", "deadband"]})
    row = frh.cells(df).iloc[0]
    assert row["today, where the first release was right"].startswith("1/2")
    assert row["today, where the first release missed"].startswith("2/2")
    # the judged set: one level-1 dead band named right by the first release, one missed
    assert (row["judged set: first release right"], row["judged set: first release missed"]) \
        == (1, 1)


def test_holdout_anchor_refuses_a_block_that_is_not_a_first_seed(capsys):
    import first_release_holdout as frh

    assert frh.main(["--blocks", "21500"]) == 2
    assert "multiples of 1000" in capsys.readouterr().err
