"""Every experiment script parses its command line before it does anything, so that
``--help`` (or a typo) never runs an experiment and rewrites committed reports (a
newcomer pass found five that ignored ``--help`` and ran)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

EXPERIMENTS = Path(__file__).parents[1] / "experiments"
def _scripts() -> list[Path]:
    return sorted(p for p in EXPERIMENTS.glob("*.py")
                  if '__name__ == "__main__"' in p.read_text())


def _main_body(text: str) -> str:
    """The script's ``main`` (to the next top-level statement), or the ``__main__`` block."""
    called = re.search(r'__name__ == "__main__":\s*\n\s*(?:raise SystemExit|sys\.exit)\((\w+)\(',
                       text)
    name = called.group(1) if called else "main"
    m = re.search(rf"^def {name}\(.*?(?=^\S)", text + "\nEND", re.M | re.S)
    return m.group(0) if m else text[text.index('__name__ == "__main__"'):]


@pytest.mark.parametrize("script", _scripts(), ids=lambda p: p.name)
def test_a_script_parses_its_arguments(script):
    """``main`` parses the command line (``parse_args``) or hands ``argv`` on to a
    shared parser (``stored_experiment``, ``jobs_reuse_args`` ...); a module of shared
    pieces answers through ``concealed_families.library_main``."""
    body = _main_body(script.read_text())
    head, _, rest = body.partition("\n")
    assert "parse_args(" in body or "library_main(" in body or \
        re.search(r"[(,\s]argv[),]", rest), \
        f"{script.name} runs without reading its command line"


def test_help_of_a_script_that_used_to_run():
    r = subprocess.run([sys.executable, str(EXPERIMENTS / "decision_rules.py"), "--help"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.startswith("usage: decision_rules.py")
    assert "wrote" not in r.stdout + r.stderr
