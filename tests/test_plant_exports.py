"""Messy but valid plant exports, read as the same recording as a clean file (a newcomer
pass with historian exports found each of these read wrongly or refused)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.io

from stictionbench.errors import InputError
from stictionbench.io import read_longest_stretch, read_recording, read_stretches
from stictionbench.realdata.datasets import load_csv_dir, scan_isdb_mat


def _clean(n: int = 400) -> pd.DataFrame:
    k = np.arange(n, dtype=float)
    return pd.DataFrame({"t": 10.0 * k, "SP": 1000.0 + 50 * (k > 150),
                         "PV": 990.0 + 40 * np.sin(k / 9), "OP": 40 + 5 * np.cos(k / 7)})


@pytest.mark.parametrize("name", ["Setpoint", "Set Point", "SV", "set_point [m3/h]"])
def test_set_point_under_its_common_names(tmp_path, name):
    """Yokogawa's SV and spelled-out names are the set point; before, the column was
    dropped in silence and the verdict changed."""
    frame = _clean()
    p = tmp_path / "a.csv"
    frame.rename(columns={"SP": name}).to_csv(p, index=False)
    np.testing.assert_array_equal(read_recording(p).SP, frame.SP)


def test_historian_tags_before_the_signal_names(tmp_path, capsys):
    """``FIC101.PV`` is PV, for one loop's tags; two loops' tags are refused."""
    frame = _clean()
    p = tmp_path / "tags.csv"
    frame.rename(columns={s: f"FIC101.{s}" for s in ("SP", "PV", "OP")}).to_csv(p, index=False)
    rec = read_recording(p)
    np.testing.assert_array_equal(rec.PV, frame.PV)
    np.testing.assert_array_equal(rec.SP, frame.SP)
    two = frame.assign(x=frame.PV).rename(
        columns={"PV": "FIC101.PV", "OP": "FIC101.OP", "x": "FIC102.PV"})
    two.to_csv(p, index=False)
    with pytest.raises(InputError, match="more than one loop"):
        read_recording(p)
    # a column that looks like a set point but is none of its names is named
    frame.rename(columns={"SP": "SP_target"}).to_csv(p, index=False)
    assert read_recording(p).SP is None
    assert "'SP_target' is not read as the set point" in capsys.readouterr().err


def test_thousands_separators_are_not_decimal_commas(tmp_path):
    """'1,003' beside '999' and '40.5' in a tab-separated file is 1003 (the file's
    decimal mark is the point); in a ';' file with decimal commas, '1.006' is 1006."""
    frame = _clean()
    us = frame.copy()
    us["PV"] = frame.PV.round().astype(int).map("{:,}".format)
    us["SP"] = frame.SP.astype(int).map("{:,}".format)
    p = tmp_path / "us.txt"
    us.to_csv(p, sep="\t", index=False)
    rec = read_recording(p)
    np.testing.assert_array_equal(rec.PV, frame.PV.round())
    de = frame.copy()
    de["t"] = frame.t.astype(int)
    for c in ("PV", "SP", "OP"):
        de[c] = frame[c].map(lambda v: f"{v:,.2f}".replace(",", "_").replace(".", ",")
                             .replace("_", "."))
    q = tmp_path / "de.csv"
    de.to_csv(q, sep=";", index=False)
    np.testing.assert_allclose(read_recording(q).PV, frame.PV.round(2))
    # with no cell showing the mark, the reading whose samples do not jump a thousandfold
    amb = frame.copy()
    amb["PV"] = frame.PV.round().astype(int).map("{:,}".format)
    amb["OP"] = frame.OP.round().astype(int)
    amb["SP"] = frame.SP.astype(int)
    r = tmp_path / "amb.txt"
    amb.to_csv(r, sep="\t", index=False)
    np.testing.assert_array_equal(read_recording(r).PV, frame.PV.round())
    # both marks as decimal marks: refused
    both = de.copy()
    both.loc[5, "OP"] = "40.25"
    both.to_csv(q, sep=";", index=False)
    with pytest.raises(InputError, match="decimal point .* and with a decimal comma"):
        read_recording(q)


def test_spreadsheet_leftovers(tmp_path):
    """Empty rows below the data, a delimiter ending every data row, a header in
    Windows-1252 ("°C") are read; a data row with more values than names is refused."""
    frame = _clean()
    text = frame.to_csv(index=False)
    p = tmp_path / "x.csv"
    p.write_text(text + ",,,\n" * 5)
    assert len(read_recording(p)) == len(frame)
    lines = text.splitlines()
    p.write_text("\n".join([lines[0]] + [r + "," for r in lines[1:]]) + "\n")
    np.testing.assert_array_equal(read_recording(p).OP, frame.OP)
    p.write_bytes(("t,SP,PV (°C),OP\n" + "\n".join(lines[1:]) + "\n").encode("cp1252"))
    np.testing.assert_array_equal(read_recording(p).PV, frame.PV)
    p.write_text("\n".join([lines[0]] + [r + ",7" for r in lines[1:]]) + "\n")
    with pytest.raises(InputError, match="more fields than the header has names"):
        read_recording(p)


def test_rows_written_only_on_change_are_held(tmp_path):
    """A historian export that writes a row (or a cell) only when the value changed is
    the record with its held samples; an outage (a few gaps) is still a gap."""
    frame = _clean(600)
    frame["OP"] = (frame.OP / 3).round(0) * 3  # coarse, and PV held: many repeats
    frame["PV"] = frame.PV.round(0).where(np.arange(600) % 3 != 1).ffill()
    same = (frame[["PV", "OP"]].diff() == 0).all(axis=1)
    assert same.sum() > 50
    full, rows, cells = tmp_path / "full.csv", tmp_path / "rows.csv", tmp_path / "cells.csv"
    frame.to_csv(full, index=False)
    frame[~same].to_csv(rows, index=False)
    blank = frame.copy()
    blank.loc[same, ["PV", "OP"]] = np.nan
    blank.to_csv(cells, index=False)
    a = read_longest_stretch(full, warn=False)
    for p in (rows, cells):
        b = read_longest_stretch(p, warn=False)
        n = len(b)  # rows written on change end at the last change
        assert n > len(a) - 20
        np.testing.assert_array_equal(a.PV[:n], b.PV)
        np.testing.assert_array_equal(a.OP[:n], b.OP)
    # two outages of 40 rows: cut, not held
    out = frame.drop(index=list(range(100, 140)) + list(range(400, 440)))
    out.to_csv(rows, index=False)
    assert len(read_stretches(rows, warn=False)) == 3
    # written on change, and an outage of 40 rows (beyond 2 % of the record): the holds
    # are held, the outage cuts the record
    frame[~same].drop(index=range(300, 340), errors="ignore").to_csv(rows, index=False)
    parts = read_stretches(rows, warn=False)
    assert len(parts) == 2 and all(np.isfinite(p.PV).all() for p in parts)


def test_folder_reads_upper_case_and_txt_exports(tmp_path):
    frame = _clean()
    for name in ("a.CSV", "b.csv", "c.txt", "d.tsv"):
        frame.to_csv(tmp_path / name, index=False, sep="\t" if name.endswith("tsv") else ",")
    recs, skipped = load_csv_dir(tmp_path, labels=False, warn=False)
    assert sorted(recs) == ["a", "b", "c", "d"] and skipped == []


def test_mat_matrix_field_and_gaps(tmp_path):
    """A .mat field of two columns (time beside the values) is refused with its shape,
    not flattened into PV; a gap is cut as in a CSV, not the loop refused."""
    frame = _clean()
    t = frame.t.to_numpy()
    f = tmp_path / "tw.mat"
    scipy.io.savemat(f, {"cdata": {"plant": {"loop1": {
        "PV": np.c_[t, frame.PV], "OP": np.c_[t, frame.OP], "Ts": 10.0}}}})
    recs, skipped = scan_isdb_mat(f, warn=False)
    assert not recs and "PV is a 400 × 2 array, not a vector" in skipped[0][1]
    pv = frame.PV.to_numpy().copy()
    pv[200:230] = np.nan
    scipy.io.savemat(f, {"cdata": {"plant": {"loop1": {
        "PV": pv, "OP": frame.OP.to_numpy(), "Ts": 10.0}}}})
    recs, skipped = scan_isdb_mat(f, warn=False)
    assert skipped == [] and len(next(iter(recs.values()))) == 200


def test_screen_scores_nothing_so_says_nothing_of_labels(tmp_path, capsys):
    """``screen`` reads a folder's labels for the names but scores nothing: the label
    warnings that ``batch`` gives (an odd class, an unlabelled recording) are not its
    business; an index table beside the recordings is a table, not a labels table."""
    from stictionbench.cli import main

    frame = _clean()
    for name in ("a", "b"):
        frame.to_csv(tmp_path / f"{name}.csv", index=False)
    pd.DataFrame({"loop": ["a", "c"], "label": ["disturbance", "stiction"]}).to_csv(
        tmp_path / "labels.csv", index=False)
    pd.DataFrame({"loop": ["a"], "sector": ["x"]}).to_csv(tmp_path / "index.csv", index=False)
    assert main(["screen", str(tmp_path), "--json", str(tmp_path / "s.json")]) == 0
    err = capsys.readouterr().err
    assert "label" not in err.replace("labels table", "").lower(), err
    _, skipped = load_csv_dir(tmp_path, warn=False, label_warnings=False)
    assert dict(skipped)["index.csv"].startswith("not a recording (table without")


def test_more_historian_states_are_missing_samples(tmp_path):
    """OSIsoft PI's 'Intf Shut', 'Arc Off-line', 'Configure', an error code with its text
    and NULL in any case are missing samples (interpolated when short), not refusals."""
    frame = _clean().astype({"PV": str})
    for row, word in ((20, "Intf Shut"), (40, "Arc Off-line"), (60, "Configure"),
                      (80, "[-11059] No Good Data For Calculation"), (100, "NULL")):
        frame.loc[row, "PV"] = word
    p = tmp_path / "pi.csv"
    frame.to_csv(p, index=False)
    rec = read_recording(p, warn=False)
    assert np.isfinite(rec.PV).all() and len(rec) == len(frame)


def test_op_in_milliamps_with_its_range_given(tmp_path, capsys):
    """OP in 4–20 mA looks like a per-cent OP near closed, so a detector's "OP moved by
    1 %" read 1 mA (6 % of travel) and called a moving OP constant; ``--op-range 4 20``
    (``estimate`` and ``batch``) gives OP's 0 and 100 %, and an OP that leaves the range
    given is refused."""
    import json

    import stictionbench as sb
    from stictionbench.cli import main

    r = sb.simulate("linear", duration=1500, seed=3, sample_time=1.0,
                    overrides=["valve=kano", "valve.S=4.0", "valve.J=2.0"])
    op = 4 + 16 * (0.5 * (r.OP - r.OP.mean()) + 12) / 100   # ~12 % open, in milliamps
    folder = tmp_path / "ma"
    folder.mkdir()
    csv = folder / "FIC101.csv"
    pd.DataFrame({"t": r.t, "SP": r.SP, "PV": r.PV, "OP": op, "MV": op}).to_csv(
        csv, index=False)
    assert np.ptp(op) < 1.0 < np.ptp(r.OP)   # under 1 "per cent" read in milliamps
    reasons = {}
    for extra in ([], ["--op-range", "4", "20"]):
        out = tmp_path / f"k{len(extra)}.json"
        assert main(["estimate", str(csv), "--method", "kano", "--json", str(out),
                     *extra]) == 0
        reasons[bool(extra)] = json.loads(out.read_text())["diagnostics"]["reason"]
    assert reasons[False] == "OP constant" and reasons[True] != "OP constant"
    out = tmp_path / "b.json"
    assert main(["batch", str(folder), "--json", str(out), "--op-range", "4", "20"]) == 0
    payload = json.loads(out.read_text())
    assert payload["op_range"] == [4.0, 20.0]
    assert payload["recordings"][0]["methods"]["kano"]["reason"] != "OP constant"
    capsys.readouterr()
    assert main(["batch", str(folder), "--json", str(out), "--op-range", "0", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--op-range, FIC101: OP runs from" in err[0]


def test_fault_words_are_never_held(tmp_path):
    """A historian's fault word ('Bad') marks a bad sample, not an unchanged one: in 12
    places it stays a gap (cut at when long), where blank cells in 12 places are held
    (a second newcomer pass: held, the flat PV beside a moving OP read as a stuck valve)."""
    frame = _clean(1500)
    starts = np.linspace(20, 1450, 12).astype(int)
    bad = frame.astype({"PV": object})
    blank = frame.copy()
    for s in starts:
        bad.loc[s:s + 29, "PV"] = "Bad"
        blank.loc[s:s + 29, "PV"] = np.nan
    pb, pn = tmp_path / "bad.csv", tmp_path / "blank.csv"
    bad.to_csv(pb, index=False)
    blank.to_csv(pn, index=False)
    assert len(read_stretches(pb, warn=False)) == 11      # cut at every fault run (the
    # stretches before the first and after the last are under 100 samples)
    assert len(read_stretches(pn, warn=False)) == 1       # held: written on change


def test_one_decimal_mark_for_the_whole_file(tmp_path):
    """A mark settled by one column holds for all: PV '1,001' (thousands) beside OP
    '50.000' is 1001 and 50.0, not 50000; with no comma anywhere, '1.000' after '998'
    in a ';' file is 1000 (German thousands), not 1.0."""
    k = np.arange(200)
    pv, op = 1000 + 5 * np.sin(k / 10), 45 + 5 * np.cos(k / 10)
    p = tmp_path / "d1.tsv"
    p.write_text("t\tPV\tOP\n" + "".join(f"{10 * a}\t{round(b):,}\t{c:.3f}\n"
                                           for a, b, c in zip(k, pv, op, strict=True)))
    rec = read_recording(p)
    np.testing.assert_allclose(rec.PV, np.round(pv))
    np.testing.assert_allclose(rec.OP, np.round(op, 3))
    de = np.round(990 + 20 * np.sin(k / 10)).astype(int)
    q = tmp_path / "b1.csv"
    q.write_text("t;PV;OP\n" + "".join(f"{10 * a};{f'{b:,}'.replace(',', '.')};45\n"
                                        for a, b in zip(k, de, strict=True)))
    np.testing.assert_array_equal(read_recording(q).PV, de)


@pytest.mark.parametrize("extra", ["Alarm SP", "HI_ALM_SP", "Max.SP", "PV/SP",
                                   "TIC200.SP", "Tracking MV"])
def test_only_a_tag_and_its_own_loop_name_a_signal(tmp_path, extra):
    """A limit, an alarm, a ratio or another loop's tag beside PV and OP is not read as a
    signal (the prefix before a signal's name must be the same loop's tag)."""
    frame = _clean()[["t", "PV", "OP"]].assign(x=99.0).rename(columns={"x": extra})
    p = tmp_path / "x.csv"
    frame.to_csv(p, index=False)
    rec = read_recording(p, warn=False)
    assert rec.SP is None and rec.MV is None


def test_mat_signals_of_different_lengths_are_refused_in_one_line(tmp_path):
    k = np.arange(600.0)
    f = tmp_path / "m.mat"
    scipy.io.savemat(f, {"cdata": {"chemicals": {"loop1": {
        "PV": 50 + np.sin(k / 9)[:-10], "OP": 40 + np.cos(k / 9), "Ts": 1.0}}}})
    recs, skipped = scan_isdb_mat(f, warn=False)
    assert not recs and "column PV has 590 samples, expected 600" in skipped[0][1]


def test_the_cycle_check_is_named_where_it_chose():
    """Where the closed-loop cycle check names a valve over a significant rival of lower
    score (ISDB CHEM10: saturation ranked first), ``decided_by`` says so instead of
    "likelihood_tests" (a newcomer pass)."""
    from stictionbench.diagnosis.model import NominalModel
    from stictionbench.diagnosis.result import Diagnosis
    from stictionbench.diagnosis.routes import decided_by

    rows = [{"physics": "saturation", "significant": True, "score": 0.0},
            {"physics": "stiction", "significant": True, "score": 4.0}]
    d = Diagnosis(True, "stiction", {}, {}, [], [], rows, NominalModel(1.0, 10.0, 1.0), {},
                  tests={"closed_loop_cycle": {"reproduced": True}})
    assert decided_by(d) == "closed_loop_cycle"
    d.tests["closed_loop_cycle"]["reproduced"] = False
    assert decided_by(d) == "likelihood_tests"
    rows[1]["score"] = -1.0  # the valve ranked first anyway: the ranking chose it
    d.tests["closed_loop_cycle"]["reproduced"] = True
    assert decided_by(d) == "likelihood_tests"


def test_a_tagged_set_point_of_the_files_own_loop(tmp_path):
    """``FIC51001.SP`` beside plain PV and OP is the loop's own set point when the file is
    named for that loop; ``TIC200.SP`` in the same file is not."""
    frame = _clean()
    p = tmp_path / "2111FIC51001_0610_0004.csv"
    frame.rename(columns={"SP": "FIC51001.SP"}).to_csv(p, index=False)
    np.testing.assert_array_equal(read_recording(p).SP, frame.SP)
    frame.rename(columns={"SP": "TIC200.SP"}).to_csv(p, index=False)
    assert read_recording(p, warn=False).SP is None
