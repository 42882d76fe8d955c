"""``experiments/size_power.py``: the frontier, the power at a false-alarm rate, and the
operating points re-decided from stored evidence agreeing with the stored verdicts."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

import concealed as cc  # noqa: E402
import size_power as sp  # noqa: E402

STORED = ROOT / "reports" / "concealed" / "independent_set_a.csv"


def test_frontier_keeps_only_undominated_settings():
    t = pd.DataFrame({"fa_rate": [0.02, 0.02, 0.05, 0.05, 0.10, 0.12],
                      "power": [0.50, 0.55, 0.54, 0.70, 0.69, 0.80]})
    f = sp.frontier(t)
    assert list(zip(f.fa_rate, f.power, strict=True)) == [(0.02, 0.55), (0.05, 0.70),
                                                         (0.12, 0.80)]


def test_power_at_a_false_alarm_rate():
    t = pd.DataFrame({"fa_rate": [0.02, 0.05, 0.10], "power": [0.5, 0.7, 0.8]})
    assert sp.power_at(t, 0.05) == 0.7
    assert sp.power_at(t, 0.09) == 0.7
    assert sp.power_at(t, 0.01) != sp.power_at(t, 0.01)  # nan: no setting that strict


@pytest.mark.skipif(not STORED.exists(), reason="reports/concealed/independent_set_a.csv "
                    "(made by make independent) is absent")
def test_operating_points_reproduce_the_stored_verdicts(monkeypatch):
    d = pd.read_csv(STORED).assign(group="a", order=2, generator="A")
    d = pd.concat([d[d["class"] == c].head(6) for c in d["class"].unique()],
                  ignore_index=True)
    assert sp.check_defaults(d) == 0
    monkeypatch.setattr(sp, "ALPHAS", (cc.DEFAULTS[0],))
    monkeypatch.setattr(sp, "GATES", (cc.DEFAULTS[1], 1e9))
    pts = sp.operating_points(d).set_index("gate")
    h = d["class"] == "none"
    shipped = pts.loc[cc.DEFAULTS[1]]
    assert shipped.healthy_called == int((d.predicted[h] != "none").sum())
    assert shipped.physics_named == int((d.predicted[~h] == d["class"][~h]).sum())
    # a gate no improvement passes: the main band names nothing, so only what the
    # checks after the comparison name remains and it cannot name more
    assert pts.loc[1e9].physics_named <= shipped.physics_named


def test_seeds_are_make_independents():
    # the sets this experiment makes when missing are the ones `make independent` makes
    import re

    text = (ROOT / "Makefile").read_text()
    made = {s: (g, int(n)) for s, g, n in re.findall(r"\b([a-k]):(blind_generator\w*):(\d+)",
                                                     text)}
    assert len(made) == 9
    assert {s: sp.SEEDS[s] for s in made} == made


def test_command_line_of_the_experiments():
    from fresh_recordings import jobs_reuse_args

    a = jobs_reuse_args(sp.__doc__, "re-make only", [])
    assert (a.jobs, a.reuse) == (2, False)
    a = jobs_reuse_args(sp.__doc__, "re-make only", ["--jobs", "3", "--reuse"])
    assert (a.jobs, a.reuse) == (3, True)
    with pytest.raises(SystemExit):
        jobs_reuse_args(sp.__doc__, "re-make only", ["--jobs", "two"])


def test_per_recording_ceiling_counts_a_recording_right_under_any_order(monkeypatch):
    # two recordings per class and level on each generator; order 2 right on the first,
    # order 0 right on the second, order 1 on neither: each order scores 8 of 16, the
    # ceiling of a per-recording choice 16 of 16
    monkeypatch.setattr(cc, "picks", lambda x, a, m: x.predicted)
    monkeypatch.setattr(sp, "ORDERS", (2, 1, 0))
    rows = []
    for g in sp.GENERATORS:
        for lv in (1, 2):
            for c in ("none", "stiction"):
                for i in range(2):
                    name = f"{g}{lv}{c}{i}"
                    for o in (2, 1, 0):
                        right = (o == 2 and i == 0) or (o == 0 and i == 1)
                        wrong = "deadband" if c == "none" else "none"
                        rows.append({"generator": g, "level": lv, "class": c, "name": name,
                                     "order": o, "predicted": c if right else wrong})
    t = sp.per_recording_ceiling(pd.DataFrame(rows))
    assert len(t) == 2 * len(sp.GENERATORS)
    assert all(v.startswith("8.0") for v in t["order 2, of 16"])
    assert all(v.startswith("0.0") for v in t["order 1, of 16"])
    assert all(v.startswith("16.0") for v in t["right under some order (oracle), of 16"])
