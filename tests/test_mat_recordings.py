"""``diagnose`` and ``estimate`` read a loop of an ISDB-layout ``.mat`` file (``--loop``)
as they read the same loop from a CSV; the wrong file, loop or layout is exit 2, one line,
no output."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.io

import stictionbench as sb
from stictionbench.cli import main
from stictionbench.io import write_recording


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A two-loop ISDB-layout file (a sticking valve and a healthy loop), the sticking
    loop as CSV, and an OP-only file like the oscillation benchmark."""
    d = tmp_path_factory.mktemp("mat")
    sticky = sb.simulate("stiction", duration=1500.0, seed=3, sample_time=1.0)
    healthy = sb.simulate("linear", duration=1500.0, seed=4, sample_time=1.0)
    loops = {f"loop{i}": {"PV": r.PV, "OP": r.OP, "SP": r.SP, "Ts": r.Ts}
             for i, r in ((1, healthy), (10, sticky))}
    mat = d / "isdb.mat"
    scipy.io.savemat(mat, {"cdata": {"chemicals": loops}})
    csv = write_recording(sb.Recording.from_arrays(sticky.t - sticky.t[0], sticky.PV,
                                                   sticky.OP, SP=sticky.SP),
                          d / "CHEM10.csv")
    op_only = d / "bench.mat"
    scipy.io.savemat(op_only, {"cdata": {"chemicals": {"loop1": {"OP": sticky.OP,
                                                                 "Ts": 1.0}}}})
    return {"mat": mat, "csv": csv, "op_only": op_only, "dir": d}


@pytest.mark.parametrize("loop", ["CHEM10", "chemicals.loop10", "chem10"])
def test_diagnose_mat_loop_matches_the_csv(files, tmp_path, capsys, loop):
    a, b = tmp_path / "mat.json", tmp_path / "csv.json"
    assert main(["diagnose", str(files["mat"]), "--loop", loop, "--json", str(a)]) == 0
    assert main(["diagnose", str(files["csv"]), "--json", str(b)]) == 0
    ja, jb = json.loads(a.read_text()), json.loads(b.read_text())
    assert ja["loop"] == "CHEM10" and "loop" not in jb
    assert ja["missing_physics"] == jb["missing_physics"]
    assert ja["fit"] == jb["fit"] and ja["parameters"] == jb["parameters"]


def test_estimate_mat_loop(files, tmp_path, capsys):
    out = tmp_path / "h.json"
    assert main(["estimate", str(files["mat"]), "--loop", "CHEM1", "--method", "horch",
                 "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["loop"] == "CHEM1" and res["method"] == "horch"


@pytest.mark.parametrize("command", ["diagnose", "estimate"])
@pytest.mark.parametrize("which, loop, needle", [
    ("mat", None, "holds 2 loops; pick one with --loop NAME (CHEM1, CHEM10)"),
    ("mat", "CHEM7", "no loop 'CHEM7'; it holds CHEM1, CHEM10"),
    ("csv", "CHEM10", "--loop picks a loop of a .mat file"),
    ("op_only", None, "OP but no PV"),
])
def test_mat_bad_choice_exit_2_one_line_no_output(files, tmp_path, capsys, command, which,
                                                 loop, needle):
    out = tmp_path / "o.json"
    args = [command, str(files[which]), "--json", str(out)]
    args += ["--loop", loop] if loop else []
    args += ["--method", "horch"] if command == "estimate" else []
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err
    assert not out.exists()


def test_single_loop_mat_needs_no_loop_name(files, tmp_path, capsys):
    k = np.arange(600.0)
    one = files["dir"] / "one.mat"
    scipy.io.savemat(one, {"cdata": {"pulpPapers": {"loop5": {
        "PV": np.sin(k / 20) + 0.01 * np.cos(k), "OP": np.cos(k / 20), "Ts": 2.0}}}})
    out = tmp_path / "o.json"
    assert main(["estimate", str(one), "--method", "horch", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["loop"] == "PAP5"
    out.unlink()
    assert main(["estimate", str(one), "--loop", "pulppapers.loop5", "--method", "horch",
                 "--json", str(out)]) == 0
    assert json.loads(out.read_text())["loop"] == "PAP5"
