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
