"""``experiments/slip_jump_loop_speed.py`` re-makes generator C's loop with every time
multiplied by the factor: the nominal model's time constant, dead time and integral time
scale, its gains do not, and the recording keeps its name, length and sampling; the
summary pairs the two speeds of each loop."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import slip_jump_loop_speed as sls  # noqa: E402


def test_remake_scales_the_loops_times_and_nothing_else(tmp_path):
    got = {}
    for f in sls.FACTORS:
        d = tmp_path / str(f)
        d.mkdir()
        name, _ = sls.remake("C", 7103, "deadband", f, d)
        got[f] = (name, pd.read_csv(d / f"{name}.csv"),
                  yaml.safe_load((d / f"{name}.model.yaml").read_text()))
    (n1, r1, m1), (n3, r3, m3) = got[1.0], got[3.0]
    assert n1 == n3 and len(r1) == len(r3)
    assert np.allclose(np.diff(r1.t), 1.0) and np.allclose(np.diff(r3.t), 1.0)
    p1, p3 = m1["process"], m3["process"]
    assert p3["gain"] == p1["gain"] and m3["controller"]["kc"] == m1["controller"]["kc"]
    assert p3["time_constant"] == pytest.approx(3 * p1["time_constant"], rel=0.02)
    assert p3["dead_time"] == pytest.approx(3 * p1["dead_time"], rel=0.02, abs=0.05)
    assert m3["controller"]["ti"] == pytest.approx(3 * m1["controller"]["ti"], rel=0.02)


def test_generator_a_remake_scales_the_loops_times(tmp_path):
    models = {}
    for f in sls.FACTORS:
        d = tmp_path / str(f)
        d.mkdir()
        assert sls.remake("A", 1007, "deadband", f, d, "r") == ("r", 1)
        models[f] = yaml.safe_load((d / "r.model.yaml").read_text())
    m1, m3 = models[1.0], models[3.0]
    assert m3["process"]["gain"] == m1["process"]["gain"]
    assert m3["controller"]["kc"] == m1["controller"]["kc"]
    assert m3["process"]["time_constant"] == pytest.approx(3 * m1["process"]["time_constant"],
                                                           rel=0.02)
    assert m3["controller"]["ti"] == pytest.approx(3 * m1["controller"]["ti"], rel=0.02)


def test_summary_pairs_the_two_speeds():
    rows = []
    for name, base, slow in (("a", "deadband", "stiction"), ("b", "stiction", "stiction")):
        for f, named in zip(sls.FACTORS, (base, slow), strict=True):
            rows.append({"generator": "C", "set": "c", "name": name, "seed": 1,
                         "class": "deadband", "factor": f, "attempts": 1,
                         "predicted": named, "slip_jump_p": 0.01 if f > 1 else 0.5,
                         "band_dof": 100 / f})
    rows.append(rows[0] | {"name": "redrawn", "attempts": 2})
    rows.append(rows[1] | {"name": "redrawn"})
    pr = sls.paired(pd.DataFrame(rows))
    assert "redrawn" not in set(pr.name)
    s = sls.summary(pr).iloc[0]
    assert s["named stiction, ×1"].startswith("1/2")
    assert s["named stiction, ×3"].startswith("2/2")
    assert s["stiction only slower / only as drawn"].startswith("1 / 0")
    assert s["band dof (median), ×3"] == pytest.approx(33.3)
    assert s["J = 0 rejected only slower / only as drawn"].startswith("2 / 0")
