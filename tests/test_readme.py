"""The README's "A short tour" runs as written: every shell command and the Python block."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from stictionbench.cli import main

README = Path(__file__).resolve().parents[1] / "README.md"


def _tour() -> tuple[list[str], str]:
    text = README.read_text(encoding="utf-8")
    section = text.split("## A short tour", 1)[1].split("\n## ", 1)[0]
    bash = re.findall(r"```bash\n(.*?)```", section, flags=re.S)
    python = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    commands = [line.split("#", 1)[0].strip() for block in bash for line in block.splitlines()]
    return [c for c in commands if c], "\n".join(python)


def test_tour_has_commands_and_python():
    commands, python = _tour()
    assert len(commands) >= 3 and all(c.startswith(".venv/bin/stictionbench ") for c in commands)
    assert "import stictionbench" in python


def test_tour_commands_run(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    commands, _ = _tour()
    for cmd in commands:
        argv = shlex.split(cmd)[1:]
        assert main(argv) == 0, f"README command failed: {cmd}\n{capsys.readouterr().err}"
    assert list(tmp_path.iterdir()), "the tour writes its outputs in the working directory"


def test_tour_python_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _, python = _tour()
    namespace: dict = {}
    exec(compile(python, str(README), "exec"), namespace)  # noqa: S102
    assert "rec" in namespace


@pytest.mark.parametrize("target", ["make replicate", "make test"])
def test_readme_names_the_two_setup_commands(target):
    assert target in README.read_text(encoding="utf-8")


def test_readme_model_yaml_loads(tmp_path):
    """The model file the README shows is one ``diagnose --model`` reads as written."""
    from stictionbench.diagnosis import load_model

    blocks = re.findall(r"```yaml\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)
    assert blocks, "the README shows a model file"
    for i, block in enumerate(blocks):
        path = tmp_path / f"model{i}.yaml"
        path.write_text(block, encoding="utf-8")
        m = load_model(path)
        assert m.gain > 0 and m.time_constant > 0 and m.kc is not None
