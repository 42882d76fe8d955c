"""The simulate command: output files and bad input (exit 2, one line, no file)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from stictionbench.cli import main
from stictionbench.io import read_recording


def test_simulate_writes_csv_and_parquet(tmp_path, capsys):
    for ext in ("csv", "parquet"):
        out = tmp_path / f"s.{ext}"
        assert main(["simulate", "case=stiction", "duration=300", "seed=1", f"out={out}"]) == 0
        rec = read_recording(out)
        assert rec.columns == ("t", "SP", "PV", "OP", "MV")
        assert len(rec) == 3001
    assert not list(tmp_path.glob(".*tmp"))


@pytest.mark.parametrize(
    "args, needle",
    [
        (["case=nope"], "unknown case 'nope'"),
        (["duration=-5"], "duration: must be positive"),
        (["duration=abc"], "duration: not a number"),
        (["seed=x"], "seed: not an integer"),
        (["bogus=1"], "unknown config key 'bogus'"),
        (["controller.kc=abc"], "controller.kc: not a number"),
        (["valve=nothing"], "unknown valve 'nothing'"),
        (["noequals"], "expected key=value"),
        (["sample_time=0"], "sample_time: must be positive"),
        (["duration=200", "process.dead_time=1e9"], "longer than the simulation"),
    ],
)
def test_simulate_bad_input(tmp_path, capsys, args, needle):
    out = tmp_path / "x.csv"
    assert main(["simulate", *args, f"out={out}"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("stictionbench: error:") and needle in err
    assert "\n" not in err and "Traceback" not in err
    assert not out.exists()


def test_console_script_exit_code(tmp_path):
    r = subprocess.run([sys.executable, "-m", "stictionbench.cli", "simulate", "case=nope",
                        f"out={tmp_path / 'x.csv'}"], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
