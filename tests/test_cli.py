"""The command-line entry point: sub-commands, lazy loading, one-line errors."""

from __future__ import annotations

import argparse
import subprocess
import sys
from importlib import import_module

import pytest

from stictionbench.cli import COMMAND_MODULES, build_parser, main


def _added_by(module: str) -> set[str]:
    p = argparse.ArgumentParser()
    sub = p.add_subparsers()
    import_module(module).add_command(sub)
    return set(sub.choices)


@pytest.mark.parametrize("module", list(COMMAND_MODULES))
def test_each_module_adds_exactly_the_commands_listed(module):
    assert _added_by(module) == set(COMMAND_MODULES[module])


def test_full_parser_has_every_command_once():
    names = [n for names in COMMAND_MODULES.values() for n in names]
    assert len(names) == len(set(names))
    sub = next(a for a in build_parser()._actions
               if isinstance(a, argparse._SubParsersAction))
    assert set(sub.choices) == set(names)


def test_a_command_imports_only_its_own_module():
    # `diagnose` must not pay for the simulation, paper and sweep stacks
    code = ("import sys; from stictionbench.cli import build_parser; "
            "build_parser('diagnose'); "
            "print(sorted(m for m in ('stictionbench.paper.command', "
            "'stictionbench.sweep.command', 'stictionbench.sim.command', 'hydra') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"


def test_unknown_command_is_one_line_exit_2(capsys):
    assert main(["no-such-command"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("stictionbench: error:")
    assert "diagnose" in err[0]  # the full list of choices is offered


def test_no_command_is_one_line_exit_2(capsys):
    assert main([]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "required" in err[0]


def test_diagnose_without_report_does_not_import_the_plotting_stack(tmp_path):
    # the figures' stack (matplotlib) costs about 0.6 s of a diagnosis command's wall
    # time; it is imported only with --report (benchmarks/test_bench_diagnose.py times
    # the whole command against the import floor)
    import stictionbench as sb
    from stictionbench.io import write_recording

    rec = sb.simulate("linear", duration=600.0, seed=1, sample_time=1.0)
    csv = write_recording(rec, tmp_path / "r.csv")
    model = tmp_path / "m.yaml"
    model.write_text("process: {gain: 3.0, time_constant: 10.0, dead_time: 10.0}\n"
                     "controller: {kc: 0.2, ti: 10.0}\nsample_time: 1.0\n")
    code = ("import sys; from stictionbench.cli import main; "
            f"rc = main(['diagnose', {str(csv)!r}, '--model', {str(model)!r}, "
            f"'--json', {str(tmp_path / 'o.json')!r}]); "
            "print(rc, 'matplotlib' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip().splitlines()[-1]
    assert out == "0 False"
    assert (tmp_path / "o.json").is_file()


def test_a_closed_pipe_ends_the_command_quietly(tmp_path):
    # ``stictionbench screen DIR | head -1``: the reader goes away; a Unix filter stops
    # with no traceback and no "error" line (exit 128 + SIGPIPE)
    import numpy as np
    import pandas as pd

    t = np.arange(300.0)
    for i in range(3):
        pd.DataFrame({"t": t, "PV": np.sin(t / (9.0 + i)), "OP": np.cos(t / 9.0)}).to_csv(
            tmp_path / f"r{i}.csv", index=False)
    code = ("import sys; from stictionbench.cli import main; "
            f"sys.exit(main(['screen', {str(tmp_path)!r}]))")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()  # nothing read: every write to stdout meets a closed pipe
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141
    assert err == ""


def test_sigterm_stops_a_batch_cleanly(tmp_path):
    """SIGTERM unwinds like Ctrl-C: exit 143, one line, no output, no worker left."""
    import signal
    import subprocess
    import sys
    import time

    import pandas as pd

    import stictionbench as sb

    data = tmp_path / "loops"
    data.mkdir()
    for i in range(40):
        r = sb.simulate("stiction", duration=2000, seed=i, sample_time=1.0)
        pd.DataFrame({"t": r.t, "SP": r.SP, "PV": r.PV, "OP": r.OP}).to_csv(
            data / f"FIC{i:03d}.csv", index=False)
    out = tmp_path / "o.json"
    p = subprocess.Popen([sys.executable, "-m", "stictionbench.cli", "batch", str(data),
                          "--json", str(out), "--jobs", "2"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    time.sleep(4.0)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    if p.returncode == 0:  # finished before the signal on a fast machine
        assert out.exists()
        return
    assert p.returncode == 128 + signal.SIGTERM, err
    assert err.strip().splitlines()[-1] == "stictionbench: terminated"
    assert not out.exists()


def test_a_signal_wrapped_by_a_library_is_still_a_stop(monkeypatch, capsys):
    """Hydra catches a SIGTERM that arrives while it composes a config and raises its own
    error: the command still exits 143 with one line, not as a failed run (a sweep
    signalled 0.1 s after launching said "ConfigCompositionException", exit 2)."""
    import signal

    from stictionbench import cli
    from stictionbench.errors import Terminated, interrupt_cause

    def wrapped(_args):
        try:
            raise Terminated
        except BaseException as exc:
            raise RuntimeError("composition failed") from exc

    monkeypatch.setattr(cli, "build_parser", lambda *_: _Parser(wrapped))
    assert cli.main(["x"]) == 128 + signal.SIGTERM
    assert capsys.readouterr().err.strip() == "stictionbench: terminated"
    assert interrupt_cause(ValueError("plain")) is None


class _Parser:
    def __init__(self, func):
        self.func = func

    def parse_args(self, argv):
        import argparse

        return argparse.Namespace(func=self.func, json=None)


def test_worker_cleanup_warnings_stay_off_stderr(monkeypatch):
    """The warning joblib's resource tracker (a child process) prints when a stopped
    run's workers already removed what it cleans up is filtered in child processes, so a
    stopped command's stderr stays one line (a loaded run of the sweep's SIGTERM test)."""
    import subprocess
    import sys

    from stictionbench import cli

    monkeypatch.setenv("PYTHONWARNINGS", "default::DeprecationWarning")
    cli._quiet_worker_cleanup()
    cli._quiet_worker_cleanup()  # once only
    import os

    assert os.environ["PYTHONWARNINGS"] == ("default::DeprecationWarning,"
                                            + cli.WORKER_CLEANUP_WARNING)
    code = ("import warnings; warnings.warn('resource_tracker: /dev/shm/x: "
            "FileNotFoundError()'); warnings.warn('another warning')")
    err = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stderr
    assert "resource_tracker" not in err and "another warning" in err


@pytest.mark.parametrize("command", ["diagnose", "estimate", "batch"])
@pytest.mark.parametrize("lo", ["-1e3", "-.5", "-2.5E-1", "-1000", "-12.5"])
def test_a_negative_op_range_is_read_in_any_float_spelling(command, lo):
    argv = {"diagnose": ["diagnose", "r.csv", "--json", "o.json"],
            "estimate": ["estimate", "r.csv"],
            "batch": ["batch", "d", "--json", "o.json"]}[command]
    args = build_parser(command).parse_args([*argv, "--op-range", lo, "100"])
    assert args.op_range == [float(lo), 100.0]


def test_an_op_range_missing_its_high_end_is_still_a_usage_error(capsys):
    assert main(["diagnose", "r.csv", "--op-range", "-1e3", "--json", "o.json"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "expected 2 arguments" in err[0]


@pytest.mark.parametrize("lo", ["-inf", "-Infinity"])
def test_an_infinite_op_range_is_refused_as_a_range_not_as_an_option(lo, tmp_path,
                                                                      capsys):
    csv = tmp_path / "r.csv"
    csv.write_text("t,PV,OP\n" + "".join(f"{k},{k % 7},{k % 5}\n" for k in range(300)))
    out = tmp_path / "o.json"
    assert main(["diagnose", str(csv), "--op-range", lo, "100", "--json", str(out)]) == 2
    assert not out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "two finite numbers" in err[0]
