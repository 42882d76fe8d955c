"""`stictionbench sweep`: rows, resume, error rows, launchers, bad input (exit 2, one line)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from stictionbench.cli import main
from stictionbench.sweep import make_plan, roc_curve

#: a tiny grid: valve kano, paper tuning, no noise, the command line picks S
TINY = ["run.valve=kano", "run.kc=0.2", "run.noise=0", "run.duration=600"]


def _sweep(tmp: Path, *args: str) -> int:
    return main(["sweep", *args, f"out_dir={tmp / 'out'}", f"work_dir={tmp / 'work'}",
                 "progress=false"])


def test_smoke_writes_16_rows_and_a_rerun_skips_them(tmp_path, capsys):
    assert _sweep(tmp_path, "sweep=smoke", "hydra/launcher=joblib") == 0
    out = tmp_path / "out"
    df = pd.read_csv(out / "results.csv")
    assert len(df) == 16 and df["run_id"].is_unique
    assert (df["status"] == "ok").all()
    assert len(pd.read_parquet(out / "results.parquet")) == 16
    assert len(list((out / "runs").glob("*.json"))) == 16
    for name in ("summary.md", "summary.csv", "detection_rate.png", "roc.png"):
        assert (out / name).stat().st_size > 0, name
    assert df["label_stiction"].sum() == 8  # S = 4 (J = 2) in half of the runs
    for p in ("xcorr", "xcum", "bicoherence", "oscillation", "ellipse"):
        assert {f"{p}_value", f"{p}_decision", f"{p}_error", f"{p}_time_s"} <= set(df.columns)
    assert (df["wall_time_s"] > 0).all()
    assert not list(out.rglob(".*.tmp"))
    capsys.readouterr()
    stamps = {p.name: p.stat().st_mtime_ns for p in (out / "runs").glob("*.json")}

    # a rerun runs nothing: the per-run files are not rewritten (no wall-clock test)
    assert _sweep(tmp_path, "sweep=smoke", "hydra/launcher=joblib") == 0
    assert "16 finished, 0 to run" in capsys.readouterr().out
    pd.testing.assert_frame_equal(pd.read_csv(out / "results.csv"), df)
    assert {p.name: p.stat().st_mtime_ns for p in (out / "runs").glob("*.json")} == stamps


def test_failing_run_records_an_error_row(tmp_path, capsys):
    assert _sweep(tmp_path, "sweep=smoke", "hydra/launcher=basic", *TINY,
                  "run.S=0,-1,3") == 0
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    assert list(df["S"]) == [0.0, -1.0, 3.0]
    assert list(df["status"]) == ["ok", "error", "ok"]
    assert "valve.S" in df.loc[1, "error"]
    assert df.loc[[0, 2], "xcum_value"].notna().all()
    # the error row is a finished run; retry_errors=true runs it again
    capsys.readouterr()
    assert _sweep(tmp_path, "sweep=smoke", "hydra/launcher=basic", *TINY, "run.S=0,-1,3",
                  "retry_errors=true") == 0
    assert "2 finished, 1 to run" in capsys.readouterr().out


def test_submitit_local_runs_a_two_run_sweep(tmp_path):
    pytest.importorskip("submitit")
    assert _sweep(tmp_path, "sweep=smoke", "hydra/launcher=submitit_local", *TINY,
                  "run.S=0,3") == 0
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    assert len(df) == 2 and (df["status"] == "ok").all()
    assert df["worker"].nunique() == 2  # one process per Hydra job
    assert list(df["label_stiction"]) == [False, True]


def test_killed_sweep_keeps_finished_runs(tmp_path):
    args = [sys.executable, "-m", "stictionbench.cli", "sweep", "sweep=smoke",
            "hydra/launcher=basic", "run.duration=600", f"out_dir={tmp_path / 'out'}",
            f"work_dir={tmp_path / 'work'}", "progress=false"]
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    runs = tmp_path / "out" / "runs"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and len(list(runs.glob("*.json"))) < 3:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    kept = sorted(runs.glob("*.json"))
    assert 3 <= len(kept) < 16
    for p in kept:  # every file that exists is a complete row
        assert json.loads(p.read_text())["status"] == "ok"
    n = len(kept)
    res = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert f"{n} finished, {16 - n} to run" in res.stdout
    assert len(pd.read_csv(tmp_path / "out" / "results.csv")) == 16


@pytest.mark.parametrize(
    "args, needle",
    [
        (["sweep=nope"], "unknown sweep 'nope'"),
        ([], "sweep needs sweep=NAME"),
        (["sweep=smoke", "hydra/launcher=nope"], "unknown launcher 'nope'"),
        (["sweep=smoke", "run.nope=1"], "unknown config key 'run.nope'"),
        (["sweep=smoke", "run.S=["], "bad override 'run.S=['"),
        (["sweep=smoke", "run.S=abc"], "run.S: expected float"),
        (["sweep=smoke", "run.valve=nothing,kano"], "unknown valve 'nothing'"),
        (["sweep=smoke", "out_dir=a,b"], "only run.* and estimators.* keys can be swept"),
        (["sweep=smoke", "noequals"], "expected key=value"),
    ],
)
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, args, needle):
    assert main(["sweep", *args, f"work_dir={tmp_path / 'work'}"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("stictionbench: error:") and "\n" not in err
    assert needle in err
    assert not (tmp_path / "work").exists()


def test_default_grid_has_at_least_1000_runs_and_stable_ids():
    plan = make_plan("default", [])
    assert len(plan.runs) >= 1000
    assert {"run.S", "run.J_ratio", "run.kc", "run.noise", "run.dist_amp", "run.dist_period",
            "run.valve"} <= set(plan.grid)
    again = make_plan("default", [])
    assert [r.id for r in plan.runs] == [r.id for r in again.runs]
    assert len({r.spec["run"]["seed"] for r in plan.runs}) == len(plan.runs)
    small = make_plan("smoke", ["run.noise=0.2"])  # a plain value fixes a swept key
    assert len(small.runs) == 8 and "run.noise" not in small.grid
    assert len(make_plan("smoke", ["run.noise=0,0.1,0.2"]).runs) == 24


def test_roc_curve_against_mann_whitney():
    rng = np.random.default_rng(0)
    labels = rng.random(200) < 0.4
    scores = rng.normal(size=200) + labels
    scores[::17] = np.nan
    fpr, tpr, auc = roc_curve(scores, labels)
    s = np.where(np.isfinite(scores), scores, -np.inf)
    pos, neg = s[labels], s[~labels]
    mw = ((pos[:, None] > neg[None, :]).sum() + 0.5 * (pos[:, None] == neg[None, :]).sum())
    assert auc == pytest.approx(mw / (pos.size * neg.size), abs=1e-12)
    assert fpr[0] == tpr[0] == 0 and fpr[-1] == tpr[-1] == 1
    assert np.all(np.diff(fpr) >= 0) and np.all(np.diff(tpr) >= 0)


@pytest.mark.parametrize("launcher", ["joblib", "basic"])
def test_sigterm_stops_a_sweep_with_143(tmp_path, launcher):
    """SIGTERM (``kill``, a scheduler's stop) ends a sweep with 143 and "terminated",
    as every other command; the sweep's own handler used to raise Ctrl-C's interrupt
    (130, "interrupted")."""
    import signal
    import subprocess
    import sys
    import time

    p = subprocess.Popen([sys.executable, "-m", "stictionbench.cli", "sweep", "sweep=smoke",
                          f"hydra/launcher={launcher}", f"out_dir={tmp_path / 'out'}",
                          f"work_dir={tmp_path / 'work'}", "progress=false"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # signal once the runs are launched (before it, a loaded machine may still be
    # importing Python's modules, when no handler is installed yet)
    for line in p.stdout:
        if "launching" in line:
            break
    time.sleep(0.5)
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=120)
    if p.returncode == 0 or " rows (" in out:
        return  # finished before the signal (a fast machine), or exiting when it came
    assert p.returncode == 128 + signal.SIGTERM, out + err
    assert err.strip().splitlines()[-1] == "stictionbench: terminated"


def test_help_names_every_sweep(capsys):
    """``sweep --help`` lists the grids of conf/sweep/ (it named three of nine)."""
    from stictionbench.sweep.plan import sweep_names

    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert all(name in text for name in sweep_names())
