"""A third-party estimator registers through the entry point and runs unchanged."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from stictionbench import Recording
from stictionbench.io import write_recording

PKG = Path(__file__).parent / "plugin_pkg"


@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory):
    target = tmp_path_factory.mktemp("site")
    r = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
         "--no-build-isolation", "--target", str(target), str(PKG)],
        capture_output=True, text=True)
    if r.returncode != 0:
        pytest.fail(f"pip could not install the plug-in package: {r.stderr[-500:]}")
    return target


def test_plugin_estimator_via_cli(plugin_path, tmp_path):
    t = np.arange(1000.0)
    rng = np.random.default_rng(0)
    x = rng.standard_normal(1000)
    rec = Recording.from_arrays(t, x, x, MV=np.roll(x, 7))
    path = write_recording(rec, tmp_path / "r.csv")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(plugin_path), os.environ.get("PYTHONPATH", "")]))
    out = tmp_path / "o.json"
    r = subprocess.run([sys.executable, "-m", "stictionbench.cli", "estimate", str(path),
                        "--method", "peak_lag", "--x", "OP", "--y", "MV", "--param",
                        "max_lag=15", "--json", str(out)],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    res = json.loads(out.read_text())
    assert res["method"] == "peak_lag" and res["value"] == 7.0
    assert res["diagnostics"]["max_lag"] == 15
    # without the plug-in on the path the name is unknown: exit 2, one line
    r2 = subprocess.run([sys.executable, "-m", "stictionbench.cli", "estimate", str(path),
                         "--method", "peak_lag"], capture_output=True, text=True)
    assert r2.returncode == 2 and "unknown estimator 'peak_lag'" in r2.stderr


def test_every_builtin_estimator_is_an_entry_point():
    """The README says every estimator is registered in the entry-point group; the
    built-in table and pyproject.toml's group must name the same classes."""
    import tomllib
    from pathlib import Path

    from stictionbench.estimators.registry import BUILTIN, GROUP

    meta = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    assert meta["project"]["entry-points"][GROUP] == BUILTIN
