"""Output paths and out-of-range input across the commands: one line, exit 2, nothing
written (found by fuzzing the command line: unwritable paths, an output that is the
input, magnitudes no measurement has, worker counts that mean nothing)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from stictionbench.cli import main
from stictionbench.diagnosis.hypotheses import DeadTime


def _recording(path: Path, scale_pv: float = 1.0, n: int = 300) -> Path:
    rng = np.random.default_rng(0)
    t = np.arange(n, dtype=float)
    op = 50 + 5 * np.sign(np.sin(2 * np.pi * t / 60)) + 0.1 * rng.standard_normal(n)
    pv = np.zeros(n)
    for k in range(1, n):
        pv[k] = 0.9 * pv[k - 1] + 0.1 * (op[k - 1] - 50)
    pv = scale_pv * (pv + 0.05 * rng.standard_normal(n))
    lines = ["t,PV,OP"] + [f"{a:g},{float(b)!r},{float(c)!r}"
                          for a, b, c in zip(t, pv, op, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    return path


def _one_line_exit_2(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("stictionbench: error:"), err
    return err[0]


def _diagnose_with_model(tmp_path: Path, capsys, *, time_constant: float,
                         dead_time: float) -> str:
    """``diagnose`` with a FOPDT model of these constants: its one error line."""
    rec = _recording(tmp_path / "rec.csv")
    model = tmp_path / "m.yaml"
    model.write_text(f"process: {{gain: 0.5, time_constant: {time_constant!r}, "
                     f"dead_time: {dead_time!r}}}\n"
                     "controller: {kc: 0.2, ti: 10.0}\nsample_time: 1.0\n")
    return _one_line_exit_2(capsys, ["diagnose", str(rec), "--model", str(model), "--json",
                                     str(tmp_path / "o.json")])


def test_json_into_an_existing_directory_is_refused_before_any_report(tmp_path, capsys):
    rec = _recording(tmp_path / "rec.csv")
    (tmp_path / "out").mkdir()
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--json", str(tmp_path / "out"),
                                    "--report", str(tmp_path / "rep")])
    assert "is a directory" in msg
    assert not (tmp_path / "rep").exists()


def test_an_output_under_a_file_is_refused(tmp_path, capsys):
    rec = _recording(tmp_path / "rec.csv")
    (tmp_path / "afile").write_text("x")
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--json",
                                    str(tmp_path / "afile" / "o.json")])
    assert "not a directory" in msg
    assert (tmp_path / "afile").read_text() == "x"


def test_a_report_directory_that_is_a_file_is_refused(tmp_path, capsys):
    rec = _recording(tmp_path / "rec.csv")
    (tmp_path / "rep").write_text("x")
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--json", str(tmp_path / "o.json"),
                                    "--report", str(tmp_path / "rep")])
    assert "not a directory" in msg
    assert not (tmp_path / "o.json").exists()


def test_screen_refuses_to_overwrite_its_input(tmp_path, capsys):
    rec = _recording(tmp_path / "rec.csv")
    before = rec.read_text()
    msg = _one_line_exit_2(capsys, ["screen", str(rec), "--json", str(rec)])
    assert "refusing to overwrite" in msg
    assert rec.read_text() == before


@pytest.mark.parametrize("jobs", ["0", "-0", "x"])
def test_batch_refuses_a_meaningless_worker_count(tmp_path, capsys, jobs):
    _recording(tmp_path / "rec.csv")
    msg = _one_line_exit_2(capsys, ["batch", str(tmp_path), "--json",
                                    str(tmp_path / "o.json"), "--jobs", jobs])
    assert "--jobs" in msg


def test_magnitudes_no_measurement_has_are_refused_with_their_row(tmp_path, capsys):
    rec = _recording(tmp_path / "huge.csv", scale_pv=1e300)
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--json", str(tmp_path / "o.json")])
    assert "column PV" in msg and "row" in msg
    assert not (tmp_path / "o.json").exists()


def test_dead_time_grid_does_not_build_past_its_400_points():
    class Ctx:
        theta, tau, Ts = 1e9, 10.0, 1.0

    grid = DeadTime().grid(Ctx())
    assert len(grid) == 400 and float(grid[-1][0]) == pytest.approx(199.5)


def test_a_model_dead_time_longer_than_the_recording_is_refused(tmp_path, capsys):
    msg = _diagnose_with_model(tmp_path, capsys, time_constant=10.0, dead_time=1.0e9)
    assert "dead_time" in msg and "longer than the recording" in msg


def _diagnose_with_extra_column(tmp_path: Path, capsys, name: str) -> str:
    """``diagnose`` on a recording with one more column ``name``: its one error line."""
    rec = _recording(tmp_path / "rec.csv")
    rows = rec.read_text().splitlines()
    extra = tmp_path / "extra.csv"
    extra.write_text("\n".join([rows[0] + f",{name}"] + [r + ",1" for r in rows[1:]]) + "\n")
    return _one_line_exit_2(capsys, ["diagnose", str(extra), "--json",
                                     str(tmp_path / "o.json")])


def test_a_repeated_column_name_is_refused(tmp_path, capsys):
    msg = _diagnose_with_extra_column(tmp_path, capsys, "PV")
    assert "'PV' appears more than once" in msg


@pytest.mark.parametrize("section", ["process", "controller"])
def test_an_unknown_key_inside_a_model_section_is_refused(tmp_path, capsys, section):
    rec = _recording(tmp_path / "rec.csv")
    proc = "{gain: 0.5, time_constant: 10.0, dead_time: 1.0%s}"
    ctrl = "{kc: 0.2, ti: 10.0%s}"
    extra = ", zeta: 2"
    model = tmp_path / "m.yaml"
    model.write_text(f"process: {proc % (extra if section == 'process' else '')}\n"
                     f"controller: {ctrl % (extra if section == 'controller' else '')}\n"
                     "sample_time: 1.0\n")
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--model", str(model), "--json",
                                    str(tmp_path / "o.json")])
    assert f"unknown key(s) in {section}: zeta" in msg


# ---- second fuzz pass: special files, held warnings, limits, late checks, labels ----

def test_an_output_that_is_a_named_pipe_is_written_into_not_replaced(tmp_path, capsys):
    import os
    import threading

    rec = _recording(tmp_path / "rec.csv")
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    assert main(["estimate", str(rec), "--method", "xcorr", "--x", "OP", "--y", "PV",
                 "--json", str(fifo)]) == 0
    reader.join(timeout=30)
    assert fifo.is_fifo() and b'"method": "xcorr"' in got[0]


def test_a_warning_before_an_error_is_folded_into_the_one_error_line(tmp_path, capsys):
    rec = _recording(tmp_path / "rec.csv", n=330)
    rows = rec.read_text().splitlines()
    for i in range(151, 161):  # PV and OP missing for ten rows: the record is cut
        t = rows[i].split(",")[0]
        rows[i] = f"{t},,"
    rec.write_text("\n".join(rows) + "\n")
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--json", str(tmp_path / "o.json")])
    assert "at least 200" in msg and "(after:" in msg and "usable stretches" in msg


def test_signal_magnitudes_beyond_1e15_and_sub_microsecond_steps_are_refused(tmp_path,
                                                                            capsys):
    rec = _recording(tmp_path / "big.csv", scale_pv=1e90)
    msg = _one_line_exit_2(capsys, ["estimate", str(rec), "--method", "xcorr", "--x", "OP",
                                    "--y", "PV"])
    assert "column PV" in msg and "1e+15" in msg
    fast = _recording(tmp_path / "fast.csv")
    rows = fast.read_text().splitlines()
    fast.write_text("\n".join([rows[0]] + [f"{k * 1e-18:g}," + r.split(",", 1)[1]
                                            for k, r in enumerate(rows[1:])]) + "\n")
    msg = _one_line_exit_2(capsys, ["diagnose", str(fast), "--json", str(tmp_path / "o.json")])
    assert "sampling interval" in msg


def test_a_model_time_constant_of_many_records_is_refused(tmp_path, capsys):
    msg = _diagnose_with_model(tmp_path, capsys, time_constant=1.0e10, dead_time=1.0)
    assert "time_constant" in msg and "times the recording" in msg


def test_a_simulation_too_long_to_hold_and_a_dangling_interpolation_are_refused(tmp_path,
                                                                               capsys):
    out = tmp_path / "s.csv"
    msg = _one_line_exit_2(capsys, ["simulate", "case=stiction", "duration=1e15",
                                    f"out={out}"])
    assert "samples" in msg and not out.exists()
    rec = _recording(tmp_path / "rec.csv")
    msg = _one_line_exit_2(capsys, ["estimate", str(rec), "estimator=xcum",
                                    "estimator.max_delay=${nosuch}"])
    assert "nosuch" in msg


def test_an_output_inside_another_output_is_refused(tmp_path, capsys):
    rec = _recording(tmp_path / "rec.csv")
    rep = tmp_path / "rep"
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--json", str(rep / "summary.md"),
                                    "--report", str(rep)])
    assert "inside the output" in msg and not rep.exists()


def test_a_json_beside_its_report_inside_the_report_directory_is_written(tmp_path, capsys):
    # the layout `make real` uses (--json reports/real/isdb/batch.json --report
    # reports/real/isdb): a report writes no JSON, so nothing can overwrite it
    rec = _recording(tmp_path / "rec.csv")
    rep = tmp_path / "rep"
    assert main(["diagnose", str(rec), "--json", str(rep / "out.json"), "--report",
                 str(rep)]) == 0
    assert (rep / "out.json").is_file() and (rep / "summary.md").is_file()
    assert json.loads((rep / "out.json").read_text())["missing_physics"]


def test_compare_checks_every_folder_before_any_work(tmp_path, capsys):
    a = tmp_path / "A"
    a.mkdir()
    _recording(a / "L1.csv")
    _recording(a / "L2.csv")
    (a / "labels.csv").write_text("loop,label\nL1,stiction\nL2,no_stiction\n")
    msg = _one_line_exit_2(capsys, ["compare", str(a), str(tmp_path / "nope"), "--out",
                                    str(tmp_path / "out"), "--jobs", "1"])
    assert "nope: no such directory" in msg


def test_labels_are_normalised_and_an_ambiguous_or_missing_label_is_refused(tmp_path):
    from stictionbench.errors import InputError
    from stictionbench.realdata.datasets import read_labels

    f = tmp_path / "labels.csv"
    f.write_text("loop,label\na, Stiction\nb,No-Stiction\nc,disturbance\n")
    assert list(read_labels(f).label) == ["stiction", "no_stiction", "disturbance"]
    f.write_text("loop,label\na,sticky valve I think\n")
    with pytest.raises(InputError, match="ambiguous"):
        read_labels(f)
    f.write_text("loop,kind\na,stiction\n")
    with pytest.raises(InputError, match="'label' column"):
        read_labels(f)


def test_screen_with_nothing_readable_is_an_error_not_an_empty_screen(tmp_path, capsys):
    bad = tmp_path / "bin.csv"
    bad.write_bytes(bytes(range(256)))
    out = tmp_path / "s.json"
    msg = _one_line_exit_2(capsys, ["screen", str(bad), "--json", str(out)])
    assert "bin.csv" in msg and not out.exists()


def test_screen_skips_an_unreadable_mat_file_beside_readable_recordings(tmp_path, capsys):
    # a corrupt .mat and one without the ISDB layout in a folder of recordings: each is
    # skipped with its reason, the rest screened (it used to refuse the whole folder)
    import scipy.io as sio

    _recording(tmp_path / "rec.csv")
    (tmp_path / "bad.mat").write_bytes(b"MATLAB 5.0 garbage" * 10)
    sio.savemat(tmp_path / "other.mat", {"x": np.arange(10.0)})
    out = tmp_path / "s.json"
    assert main(["screen", str(tmp_path), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "skipped " + str(tmp_path / "bad.mat") in text and "other.mat" in text
    assert "1 recording(s)" in text and "2 file(s) skipped" in text
    assert [r["name"] for r in json.loads(out.read_text())["recordings"]] == ["rec"]


def test_a_model_sample_time_other_than_the_recordings_is_a_warning_after_the_result(
        tmp_path, capsys):
    rec = _recording(tmp_path / "rec.csv")
    model = tmp_path / "m.yaml"
    model.write_text("process: {gain: 0.5, time_constant: 10.0, dead_time: 1.0}\n"
                     "controller: {kc: 0.2, ti: 10.0}\nsample_time: 7.0\n")
    assert main(["diagnose", str(rec), "--model", str(model), "--json",
                 str(tmp_path / "o.json")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert "sample_time 7 s differs" in err[0]
    # the other lines are the diagnosis's own warnings, one line each (this short
    # recording holds few in-band samples: details.record_warning)
    d = json.loads((tmp_path / "o.json").read_text())["details"]
    assert err[1:] == [f"stictionbench: warning: {d[k]}" for k in ("warning", "model_warning",
                                                                  "record_warning")
                       if d.get(k)]


def test_an_exact_column_name_beside_a_variant_of_it_is_refused(tmp_path, capsys):
    msg = _diagnose_with_extra_column(tmp_path, capsys, "pv")
    assert "PV, pv could each be PV" in msg


def test_a_labelled_loop_without_its_recording_is_named_in_one_warning(tmp_path, capsys):
    from stictionbench.realdata.datasets import load_csv_dir

    _recording(tmp_path / "a.csv")
    (tmp_path / "labels.csv").write_text("loop,label\na,stiction\nzz,no_stiction\n")
    recs, _ = load_csv_dir(tmp_path, warn=False)
    assert list(recs) == ["a"]
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "with no recording in the folder: zz" in err[0]


def test_a_model_key_given_twice_is_refused(tmp_path, capsys):
    rec = _recording(tmp_path / "rec.csv")
    model = tmp_path / "m.yaml"
    model.write_text("process: {gain: 0.5, gain: 5.0, time_constant: 10.0, dead_time: 1.0}\n"
                     "controller: {kc: 0.2, ti: 10.0}\nsample_time: 1.0\n")
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--model", str(model), "--json",
                                    str(tmp_path / "o.json")])
    assert "'gain' appears twice" in msg


def test_a_complex_or_two_dimensional_signal_is_refused_not_cast():
    from stictionbench.errors import InputError
    from stictionbench.recording import Recording

    t = np.arange(200.0)
    x = np.sin(t / 5)
    with pytest.raises(InputError, match="complex"):
        Recording.from_arrays(t, x + 1j * x, x, warn=False)
    with pytest.raises(InputError, match="not one signal"):
        Recording.from_arrays(t, np.c_[x, x], x, warn=False)
    assert len(Recording.from_arrays(t, x.reshape(1, -1), x + 0j, warn=False)) == 200


def test_a_consensus_file_with_a_key_given_twice_is_refused(tmp_path):
    from stictionbench.errors import InputError
    from stictionbench.realdata.consensus import Consensus

    f = tmp_path / "cons.yaml"
    f.write_text("methods: [horch]\nthreshold: 0.5\nthreshold: 0.9\nmin_votes: 1\n")
    with pytest.raises(InputError, match="'threshold' appears twice"):
        Consensus.load(f)
    f.write_text("methods: [horch]\nthreshold: 0.5\nmin_votes: 1\n")
    assert Consensus.load(f).threshold == 0.5


def test_a_true_false_column_is_refused_from_parquet_as_from_csv(tmp_path):
    import pandas as pd

    from stictionbench.errors import InputError
    from stictionbench.io import read_recording

    n = 200
    frame = pd.DataFrame({"t": np.arange(n, dtype=float), "PV": np.arange(n) % 2 == 0,
                          "OP": np.sin(np.arange(n) / 5)})
    frame.to_parquet(tmp_path / "b.parquet")
    with pytest.raises(InputError, match="true/false"):
        read_recording(tmp_path / "b.parquet")
    frame.to_csv(tmp_path / "b.csv", index=False)
    with pytest.raises(InputError, match="not a number"):
        read_recording(tmp_path / "b.csv")


def test_a_report_that_cannot_be_written_whole_leaves_nothing_and_names_the_path(
        tmp_path, capsys):
    """A report file that cannot be written (here a directory in the way of
    summary.md) fails the command before any file is moved into the report directory,
    and the error names the user's path, not a staging file (a first version left three
    figures behind and named '.summary.md.7w1tfhts.tmp')."""
    rec = _recording(tmp_path / "rec.csv")
    rep = tmp_path / "rep"
    (rep / "summary.md").mkdir(parents=True)
    msg = _one_line_exit_2(capsys, ["diagnose", str(rec), "--json", str(tmp_path / "o.json"),
                                    "--report", str(rep)])
    assert f"{rep / 'summary.md'}: Is a directory" in msg and ".tmp" not in msg
    assert sorted(p.name for p in rep.iterdir()) == ["summary.md"]
    assert not (tmp_path / "o.json").exists()
    assert not list(tmp_path.glob(".rep.*"))  # the staging directory is gone


def test_a_full_disk_names_the_output():
    """An error with no file name (a full disk) names the output it was writing."""
    import errno

    from stictionbench.io import _named

    exc = _named(OSError(errno.ENOSPC, "No space left on device"), {"/x/.o.json.1.tmp": "o.json"})
    assert (exc.filename, exc.strerror) == ("o.json", "No space left on device")
    other = OSError(errno.ENOENT, "No such file", "input.csv")
    assert _named(other, {"/x/.o.json.1.tmp": "o.json"}) is other


def test_labels_that_are_numbers_are_refused_and_odd_classes_named(tmp_path, capsys):
    """0/1 labels would all be scored as no stiction; they are refused. A class other
    than stiction and no_stiction (a typo such as 'stiktion') and a recording without a
    label each get one warning line."""
    from stictionbench.errors import InputError
    from stictionbench.realdata.datasets import load_csv_dir, read_labels

    f = tmp_path / "labels.csv"
    for value in ("1", "0", "yes", "TRUE", "1.0"):
        f.write_text(f"loop,label\na,{value}\n")
        with pytest.raises(InputError, match="number or a yes/no"):
            read_labels(f)
    for name in ("a", "b", "c"):
        _recording(tmp_path / f"{name}.csv")
    f.write_text("loop,label\na,stiction\nb,stiktion\n")
    recs, _ = load_csv_dir(tmp_path, warn=False)
    assert recs["b"].meta["label"] == "stiktion"
    err = capsys.readouterr().err
    assert "scored as no stiction: stiktion" in err
    assert "1 recording(s) without a label, left out of the scores: c" in err


def test_balanced_accuracy_needs_both_classes(tmp_path, capsys):
    """A batch whose labelled loops are all sticky computes no balanced accuracy (a
    first version printed the sticky loops' recall as one) and says why."""
    for name in ("a", "b"):
        _recording(tmp_path / f"{name}.csv")
    (tmp_path / "labels.csv").write_text("loop,label\na,stiction\nb,stiction\n")
    out = tmp_path / "o.json"
    assert main(["batch", str(tmp_path), "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["scores"]["balanced_accuracy_by_group"] is None
    assert "of one class only" in capsys.readouterr().err


def test_compare_refuses_loops_of_one_class(tmp_path, capsys):
    """A consensus cannot be trained or scored on sticky loops alone (a first version
    trained one and reported exit 0)."""
    a = tmp_path / "A"
    a.mkdir()
    _recording(a / "L1.csv")
    (a / "labels.csv").write_text("loop,label\nL1,stiction\n")
    msg = _one_line_exit_2(capsys, ["compare", str(a), "--out", str(tmp_path / "out"),
                                    "--jobs", "1"])
    assert "both classes" in msg and "stiction only" in msg
    assert not (tmp_path / "out").exists()


def test_an_unusable_batch_entry_has_the_keys_every_entry_has(tmp_path):
    """An entry whose data cannot support a verdict (a dead PV) keeps the entry's keys
    with their types: ``notes`` an empty list (a first version left it out, read as
    null), ``confidence`` 1.0 (sure that the data are unusable)."""
    import stictionbench as sb
    from stictionbench.realdata.verdict import judge

    t = np.arange(800.0)
    rec = sb.Recording.from_arrays(t, np.full(800, 3.5e-44), 50 + np.sin(t / 9.0),
                                   warn=False)
    e = judge(rec, "dead")
    assert e["verdict"] == "unusable" and e["notes"] == [] and e["confidence"] == 1.0


def test_json_dash_writes_the_json_alone_to_stdout(tmp_path, capsys):
    """``--json -`` puts the JSON, and nothing else, on standard output (a pipe into jq);
    the command's own printing goes to stderr, and no file named '-' is written (a
    first version wrote one)."""
    import os

    rec = _recording(tmp_path / "rec.csv")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        for argv in (["estimate", str(rec), "--method", "xcorr", "--x", "OP", "--y", "PV"],
                     ["diagnose", str(rec)], ["batch", str(tmp_path)]):
            assert main([*argv, "--json", "-"]) == 0
            out, err = capsys.readouterr()
            assert isinstance(json.loads(out), dict), argv
            assert err.strip(), argv  # the table or summary line went to stderr
            assert not (tmp_path / "-").exists()
        assert main(["diagnose", str(tmp_path / "missing.csv"), "--json", "-"]) == 2
        out, err = capsys.readouterr()
        assert out == "" and len(err.strip().splitlines()) == 1
    finally:
        os.chdir(cwd)


def test_labels_are_read_as_recordings_are(tmp_path):
    """A labels table saved by a spreadsheet (';' separated, or UTF-16 with tabs) is
    read like a recording saved the same way (a first version refused both), and its
    numbers stay numbers."""
    from stictionbench.realdata.datasets import read_labels

    f = tmp_path / "labels.csv"
    f.write_text("loop;label;Ts\na;stiction;10.5\nb;No-Stiction;1\n")
    t = read_labels(f)
    assert list(t.label) == ["stiction", "no_stiction"] and t.Ts.tolist() == [10.5, 1.0]
    f.write_bytes("loop\tlabel\na\tstiction\nb\tdisturbance\n".encode("utf-16"))
    assert list(read_labels(f).label) == ["stiction", "disturbance"]
