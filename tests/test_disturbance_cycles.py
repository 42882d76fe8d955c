"""``experiments/disturbance_cycles.py``: its recordings vary the line's period alone, and
its reading says only what its table bears out; ``holdout_pooled.by_cycles`` bins the
blind blocks' disturbances by the cycles in the record."""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import disturbance_cycles as dc  # noqa: E402
import holdout_pooled as hp  # noqa: E402

from stictionbench.io import read_recording  # noqa: E402


def test_jobs_vary_the_period_alone(tmp_path):
    todo = dc.jobs(1, tmp_path)
    assert len(todo) == 2 * len(dc.CYCLES) + len(dc.CYCLES_NO_LOAD)
    level1 = [j for j in todo if j["level"] == 1]
    periods = sorted(j["truth"]["period"] for j in level1)
    assert periods == pytest.approx(sorted(3000.0 / c for c in dc.CYCLES))
    # the same loop (model) at every period; the level-2 runs without load differ
    models = {Path(j["model"]).read_text() for j in level1}
    assert len(models) == 1
    a, b = (read_recording(j["csv"], warn=False) for j in level1[:2])
    assert (a.SP == b.SP).all() and not (a.PV == b.PV).all()
    assert {j["load_scale"] for j in todo if j["level"] == 2} == {0.0, 1.0}


def _frame(named_short: bool, rising: bool, load_matters: bool) -> pd.DataFrame:
    rows = []
    for seed in range(4):
        for level in (1, 2):
            for cycles in dc.CYCLES:
                hit = cycles > 2 if level == 1 else (cycles >= 4 if rising else cycles == 2.5)
                if cycles < 2 and named_short and seed == 0:
                    hit = True
                rows.append({"level": level, "seed": seed, "cycles": cycles,
                             "load_scale": 1.0, "period_s": 3000.0 / cycles,
                             "corner_period_s": 3000.0,
                             "verdict": dc.LINE if hit else "none"})
        for cycles in dc.CYCLES_NO_LOAD:
            hit = load_matters or cycles >= 4
            rows.append({"level": 2, "seed": seed, "cycles": cycles, "load_scale": 0.0,
                         "period_s": 3000.0 / cycles, "corner_period_s": 3000.0,
                         "verdict": dc.LINE if hit else "none"})
    return pd.DataFrame(rows)


def test_reading_states_only_what_the_table_shows():
    text = dc.reading(_frame(named_short=False, rising=True, load_matters=True))
    assert "below two cycles nothing is named" in text
    assert "named more often the more cycles" in text
    assert "hides part of the slow lines" in text
    text = dc.reading(_frame(named_short=True, rising=False, load_matters=False))
    assert "below two cycles 4 of 16 are named" in text
    assert "does not rise steadily" in text
    assert "does not show the load hiding them" in text


def test_bad_arguments_exit_2(capsys):
    assert dc.main(["--loops", "0"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_pooled_cycles_bins():
    df = pd.DataFrame({
        "class": ["oscillatory_disturbance"] * 4 + ["none"],
        "level": [1, 1, 1, 2, 2],
        "predicted_default": ["none", "oscillatory_disturbance", "oscillatory_disturbance",
                              "none", "none"],
        "disturbance_cycles": [1.5, 2.0, 12.0, 5.0, float("nan")]})
    t = hp.by_cycles(df).set_index(["level", "cycles in the record"])
    assert t.loc[(1, "0–2"), "disturbances named"].startswith("0/1")
    assert t.loc[(1, "0–2"), "misses named"] == "none ×1"
    assert t.loc[(1, "2–3"), "disturbances named"].startswith("1/1")
    assert t.loc[(1, "6 and more"), "disturbances named"].startswith("1/1")
    assert t.loc[(2, "4–6"), "disturbances named"].startswith("0/1")
    assert len(t) == 4  # the `none` row is left out
