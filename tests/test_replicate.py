"""The replication pipeline: every table and figure is written, twice byte-identically."""

from __future__ import annotations

import hashlib

import pandas as pd
import pytest

from stictionbench.cli import main

SMALL = ["robustness.seeds=3", "robustness.sample_times=[1.0]",
         "robustness.sample_time_seeds=1", "robustness.stiction_scales=[1.0]",
         "robustness.scale_seeds=2"]


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
    assert t7.loc["stiction", "xcum_delay_samples"] != 0


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
