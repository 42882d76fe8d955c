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
