"""The sweep on a real SLURM cluster through Hydra's ``submitit_slurm`` launcher.

Needs ``sbatch`` and a running cluster (``make test-slurm`` starts the one-node cluster of
``../shared/tools/slurm-local.sh``, runs this file and stops it); skipped otherwise.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

pytestmark = pytest.mark.slurm


def _cluster_up() -> str | None:
    if shutil.which("sbatch") is None:
        return "sbatch is not installed (make test-slurm starts a one-node cluster)"
    try:
        out = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True,
                             timeout=20)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"sinfo failed: {exc}"
    if "idle" not in out.stdout and "mix" not in out.stdout:
        return f"no idle SLURM node (sinfo: {out.stdout.strip() or out.stderr.strip()})"
    return None


def _sweep(tmp: Path) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "stictionbench.cli", "sweep", "sweep=smoke",
           "hydra/launcher=submitit_slurm", "hydra.launcher.partition=cpu",
           "hydra.launcher.timeout_min=10", "hydra.launcher.cpus_per_task=1",
           f"hydra.launcher.submitit_folder={tmp / 'submitit'}",
           f"out_dir={tmp / 'out'}", f"work_dir={tmp / 'work'}", "progress=false"]
    env = dict(os.environ, MPLBACKEND="Agg")
    return subprocess.run(cmd, capture_output=True, text=True, timeout=900, env=env)


def test_smoke_sweep_on_slurm_and_resume(tmp_path):
    reason = _cluster_up()
    if reason:
        pytest.skip(reason)
    first = _sweep(tmp_path)
    assert first.returncode == 0, first.stderr[-2000:]
    df = pd.read_csv(tmp_path / "out" / "results.csv")
    assert len(df) == 16 and df["run_id"].is_unique and (df["status"] == "ok").all()
    assert len(list((tmp_path / "submitit").glob("*_log.out"))) >= 1  # jobs went through SLURM
    stamps = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "out" / "runs").glob("*.json")}
    assert len(stamps) == 16

    again = _sweep(tmp_path)
    assert again.returncode == 0, again.stderr[-2000:]
    assert "16 finished, 0 to run" in again.stdout
    after = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "out" / "runs").glob("*.json")}
    assert after == stamps  # the resumed rerun repeated no run
    pd.testing.assert_frame_equal(pd.read_csv(tmp_path / "out" / "results.csv"), df)
