"""The replication pipeline: every table and figure is written, twice byte-identically."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from stictionbench.cli import main
from stictionbench.config import compose
from stictionbench.paper import mechanism

SWEEPS = Path(__file__).resolve().parents[1] / "reports" / "sweeps"
SMALL = [f"sweeps_dir={SWEEPS}"]


def _digest(root):
    return {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    a = tmp_path_factory.mktemp("a")
    b = tmp_path_factory.mktemp("b")
    assert main(["replicate", f"out_dir={a}", *SMALL]) == 0
    assert main(["replicate", f"out_dir={b}", *SMALL]) == 0
    return a, b


def test_outputs_complete(two_runs):
    a, _ = two_runs
    for n in range(3, 8):
        assert (a / "tables" / f"table{n}.md").is_file()
        assert (a / "tables" / f"table{n}.csv").is_file()
    for n in range(1, 22):
        assert (a / "figures" / f"fig{n:02d}.png").stat().st_size > 5000
    assert (a / "REPLICATION.md").is_file()


def test_byte_identical(two_runs):
    a, b = two_runs
    assert _digest(a) == _digest(b)


def test_table7_columns_and_stiction_separation(two_runs):
    a, _ = two_runs
    t7 = pd.read_csv(a / "tables" / "table7.csv").set_index("case")
    for col in ("xcorr_delay_samples", "xcum_delay_samples", "xcorr_delay_s", "xcum_delay_s",
                "paper_xcorr", "paper_xcum", "bicoherence_ngi", "bicoherence_nli"):
        assert col in t7.columns
    assert list(t7.index) == ["linear", "tight", "disturbance", "stiction"]
    # no delay without stiction; a delay of many samples with it
    for case in ("linear", "tight", "disturbance"):
        assert abs(t7.loc[case, "xcorr_delay_samples"]) < 0.5
        assert t7.loc[case, "xcum_delay_samples"] == 0
    assert abs(t7.loc["stiction", "xcorr_delay_samples"]) > 5
    # the cumulant "delay" of the stiction case is flagged, not reported as a delay
    assert t7.loc["stiction", "xcum_at_edge"] or t7.loc["stiction", "xcum_unstable"]
    # the paper's literal sign rule is reported beside ours
    assert t7.loc["stiction", "sign_rule_paper"] == "stiction"
    assert t7.loc["stiction", "sign_rule_xcorr"] == "no stiction"


def test_remarks_are_measured(two_runs):
    a, _ = two_runs
    t6 = pd.read_csv(a / "tables" / "table6.csv")
    assert list(t6["agrees"]) == [True, True, True, True]
    assert set(t6.columns) >= {"measure", "value", "threshold", "Remarks (ours)"}
    t3 = pd.read_csv(a / "tables" / "table3.csv")
    assert "not available" in t3.loc[0, "Remarks (ours)"]


def test_bad_override_exits_2(tmp_path, capsys):
    assert main(["replicate", f"out_dir={tmp_path}", "nonsense.key=1"]) == 2
    assert "unknown config key" in capsys.readouterr().err


@pytest.mark.parametrize("override, said", [
    ("seed=abc", "seed: not an integer"),
    ("seed=1.5", "seed: not an integer"),
    ("duration=abc", "duration: not a number"),
    ("sample_time=0", "sample_time: must be positive"),
    ("thresholds.linear_r2=abc", "thresholds.linear_r2: not a number"),
    ("thresholds.swing_fraction=2", "thresholds.swing_fraction: must be at most 1"),
    ("thresholds.oscillation_swings=0", "thresholds.oscillation_swings: must be ≥ 1"),
    ("estimators.xcorr.max_delay=abc", "max_delay"),
    ("estimators.xcorr=abc", "estimators.xcorr: expected a mapping"),
])
def test_bad_values_are_one_line_before_any_work(tmp_path, capsys, override, said):
    """Checked where the config is composed: no progress bar, no traceback, no output."""
    assert main(["replicate", f"out_dir={tmp_path / 'x'}", override]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and said in err[0], err
    assert not (tmp_path / "x").exists()


def test_an_out_dir_that_is_a_file_is_refused_first(tmp_path, capsys):
    (tmp_path / "f").write_text("keep")
    assert main(["replicate", f"out_dir={tmp_path / 'f'}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists and is not a directory" in err[0]
    assert (tmp_path / "f").read_text() == "keep"


def test_partial_replicate_touches_only_its_case(two_runs, tmp_path):
    a, _ = two_runs
    out = tmp_path / "r"
    import shutil

    shutil.copytree(a, out)
    before = _digest(out)
    (out / "tables" / "table6.md").write_text("old")
    assert main(["replicate", f"out_dir={out}", "cases=[stiction]", *SMALL]) == 0
    after = _digest(out)
    changed = {k for k in after if after[k] != before.get(k)}
    assert "tables/table6.md" in changed or after["tables/table6.md"] == before[
        "tables/table6.md"]
    assert (out / "tables" / "table6.md").read_text() != "old"
    untouched = [k for k in before if k.startswith(("tables/table3", "tables/table7",
                                                    "REPLICATION", "figures/fig01"))]
    assert untouched and all(after[k] == before[k] for k in untouched)


def test_unknown_case_exits_2_and_writes_nothing(tmp_path, capsys):
    assert main(["replicate", f"out_dir={tmp_path / 'x'}", "cases=[sticky]"]) == 2
    assert "unknown case 'sticky'" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_backward_path_follows_dead_time():
    """The stiction-case xcorr lag and the slip→CO-reversal time both follow θ."""
    cfg = compose([], config_name="experiment/paper")
    d = mechanism.dead_time_study(cfg, dead_times=(10.0, 20.0), segments=(128,))
    for row in d.itertuples():
        assert row.dead_time_s <= row.slip_to_reversal_median_s <= row.dead_time_s + 5
        assert -(row.dead_time_s + 10) <= row.xcorr_seg128_delay_s <= -row.dead_time_s


def test_slip_and_reversal_detection():
    t = np.arange(0, 100, 0.1)
    op = np.abs((t % 40) - 20)  # triangle, reversals at 20, 40, 60, 80
    mv = np.where((t % 40) < 25, 1.0, 0.0)  # jumps 5 s after the reversals at 20, 60, ...
    slips, signs = mechanism.slip_times(t, mv)
    assert np.allclose(slips, [24.9, 39.9, 64.9, 79.9], atol=0.11)
    assert list(signs) == [-1, 1, -1, 1]
    rev = mechanism.reversal_times(t, op)
    assert np.allclose(rev[:2], [20.0, 40.0], atol=0.11)
