"""Recording validation and CSV/Parquet round trips, including every bad-input rule."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest

from stictionbench import InputError, Recording
from stictionbench.io import read_recording, write_recording


def _frame_text(n=200, dt=1.0, extra=""):
    rows = ["t,SP,PV,OP"]
    for i in range(n):
        rows.append(f"{i * dt},1,{np.sin(i / 7):.6f},{np.cos(i / 5):.6f}")
    return "\n".join(rows) + "\n" + extra


def test_round_trip_csv_and_parquet(tmp_path):
    t = np.arange(300) * 0.5
    rec = Recording.from_arrays(t, np.sin(t), np.cos(t), SP=np.zeros_like(t), MV=np.cos(t - 1))
    for ext in ("csv", "parquet"):
        p = write_recording(rec, tmp_path / f"r.{ext}")
        back = read_recording(p)
        assert back.columns == ("t", "SP", "PV", "OP", "MV")
        for c in back.columns:
            np.testing.assert_array_equal(getattr(back, c), getattr(rec, c))
        assert back.Ts == pytest.approx(0.5)


def test_optional_sp_and_mv(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("t,PV,OP\n" + "".join(f"{i},{i % 7},{i % 5}\n" for i in range(150)))
    rec = read_recording(p)
    assert rec.SP is None and rec.MV is None
    with pytest.raises(InputError, match="MV is not recorded"):
        rec.signal("MV")


def test_missing_columns(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("t,SP,PV\n" + "".join(f"{i},1,2\n" for i in range(150)))
    with pytest.raises(InputError, match="missing column.*OP"):
        read_recording(p)


def test_text_in_numeric_column_names_row_and_column(tmp_path):
    lines = _frame_text().splitlines()
    parts = lines[11].split(",")
    parts[2] = "oops"
    lines[11] = ",".join(parts)
    p = tmp_path / "bad.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"row 12, column PV: not a number"):
        read_recording(p)


@pytest.mark.parametrize("value", ["inf", "-inf"])
def test_infinite(tmp_path, value):
    lines = _frame_text().splitlines()
    parts = lines[21].split(",")
    parts[3] = value
    lines[21] = ",".join(parts)
    p = tmp_path / "bad.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"row 22, column OP: infinite"):
        read_recording(p)


def test_time_not_increasing_and_not_uniform():
    t = np.arange(200.0)
    x = np.sin(t)
    t2 = t.copy()
    t2[50] = t2[49]
    with pytest.raises(InputError, match="row 50, column t: time is not strictly increasing"):
        Recording.from_arrays(t2, x, x)
    t3 = t.copy()
    t3[100:] += 0.5
    with pytest.raises(InputError, match="not uniform.*resample"):
        Recording.from_arrays(t3, x, x)
    t4 = t * (1 + 0.004 * np.sin(t))  # jitter below 1 % is accepted
    Recording.from_arrays(np.cumsum(np.r_[0, np.diff(t4).clip(0.995, 1.005)]), x, x)


def test_too_few_samples():
    t = np.arange(99.0)
    with pytest.raises(InputError, match="99 samples; at least 100"):
        Recording.from_arrays(t, t, t)


def test_short_gaps_interpolated_long_gap_error(tmp_path, capsys):
    t = np.arange(200.0)
    pv = np.sin(t / 9)
    pv_gap = pv.copy()
    pv_gap[30:35] = np.nan
    rec = Recording.from_arrays(t, pv_gap, pv)
    assert np.all(np.isfinite(rec.PV))
    np.testing.assert_allclose(rec.PV[30:35], np.interp(t[30:35], t[[29, 35]], pv[[29, 35]]))
    assert "interpolated 5 missing values" in capsys.readouterr().err
    pv_gap[60:66] = np.nan
    with pytest.raises(InputError, match="row 60, column PV: gap of 6"):
        Recording.from_arrays(t, pv_gap, pv)
    # from a CSV file: the message names the file row (header is row 1)
    lines = _frame_text().splitlines()
    for i in range(40, 47):
        parts = lines[i + 1].split(",")
        parts[3] = ""
        lines[i + 1] = ",".join(parts)
    p = tmp_path / "gap.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"row 42, column OP: gap of 7"):
        read_recording(p)


def test_empty_binary_directory_missing(tmp_path):
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(InputError, match="empty file"):
        read_recording(empty)
    binary = tmp_path / "bin.csv"
    binary.write_bytes(bytes(range(256)) * 20)
    with pytest.raises(InputError, match="binary"):
        read_recording(binary)
    with pytest.raises(InputError, match="is a directory"):
        read_recording(tmp_path)
    with pytest.raises(InputError, match="no such file"):
        read_recording(tmp_path / "nope.csv")
    header_only = tmp_path / "h.csv"
    header_only.write_text("t,PV,OP\n")
    with pytest.raises(InputError, match="0 samples"):
        read_recording(header_only)
    bad_parquet = tmp_path / "x.parquet"
    bad_parquet.write_text("not parquet at all")
    with pytest.raises(InputError, match="not a readable Parquet"):
        read_recording(bad_parquet)


def test_recording_is_read_only():
    t = np.arange(150.0)
    rec = Recording.from_arrays(t, t, t)
    with pytest.raises(ValueError):
        rec.PV[0] = 3.0
    with pytest.raises(AttributeError):
        rec.Ts = 2.0  # type: ignore[misc]


def test_long_gaps_cut_the_record_into_usable_stretches(tmp_path, capsys):
    # an outage of 64 samples and one of 23 (with a stretch of 7 between them, too
    # short to use): the strict reader refuses, the stretch reader keeps both long parts
    from stictionbench.io import read_longest_stretch, read_stretches
    from stictionbench.stretches import stretches

    n = 1200
    t = np.arange(n, dtype=float)
    pv = np.sin(t / 15.0)
    op = np.cos(t / 15.0)
    pv[700:764] = np.nan
    pv[771:794] = np.nan
    pv[300] = np.nan  # a short gap inside a stretch: interpolated as before
    p = tmp_path / "outage.csv"
    pd.DataFrame({"t": t, "PV": pv, "OP": op}).to_csv(p, index=False)
    with pytest.raises(InputError, match="gap of 64"):
        read_recording(p)
    parts = read_stretches(p, warn=False)
    assert [r.meta["rows"] for r in parts] == [[2, 701], [796, 1201]]  # file rows
    assert len(parts[0]) == 700 and np.isfinite(parts[0].PV).all()
    assert parts[0].t[0] == 0.0 and parts[1].t[0] == 794.0
    best = read_longest_stretch(p)
    assert best is not None and len(best) == 700
    err = capsys.readouterr().err
    assert "2 usable stretches" in err and "rows 796–1201" in err
    # a record without long gaps is read whole, unchanged
    pv2 = np.sin(t / 15.0)
    q = tmp_path / "clean.csv"
    pd.DataFrame({"t": t, "PV": pv2, "OP": op}).to_csv(q, index=False)
    (whole,) = read_stretches(q)
    assert len(whole) == n and "rows" not in whole.meta
    # nothing long enough between outages: the strict reader's message
    m = np.zeros(150, bool)
    m[60:70] = True
    assert stretches(m) == []


def test_a_set_point_logged_only_when_it_changes_is_held(tmp_path, capsys):
    """Blank SP cells between logged changes are held (a step signal), by both readers,
    with a warning, and PV and OP are kept whole; a long blank start makes SP unknown
    there, so it is read as not recorded. A first version refused the file ("gap of 49
    missing values") or cut PV and OP to the rows where SP was logged."""
    from stictionbench.io import read_longest_stretch

    n = 1000
    t = np.arange(n, dtype=float)
    sp = np.full(n, np.nan)
    sp[0], sp[400], sp[700] = 50.0, 55.0, 52.0
    pv, op = np.sin(t / 15.0), np.cos(t / 15.0)
    p = tmp_path / "sp_on_change.csv"
    pd.DataFrame({"t": t, "SP": sp, "PV": pv, "OP": op}).to_csv(p, index=False)
    for rec in (read_recording(p), read_longest_stretch(p)):
        assert len(rec) == n
        assert rec.SP[:400].tolist() == [50.0] * 400
        assert rec.SP[400:700].tolist() == [55.0] * 300 and rec.SP[-1] == 52.0
    assert "holding the last logged set point" in capsys.readouterr().err
    late = sp.copy()
    late[0] = np.nan  # nothing logged before row 400
    q = tmp_path / "sp_late.csv"
    pd.DataFrame({"t": t, "SP": late, "PV": pv, "OP": op}).to_csv(q, index=False)
    rec = read_recording(q)
    assert rec.SP is None and len(rec) == n
    assert "SP is read as not recorded" in capsys.readouterr().err


def test_rows_absent_from_the_file_are_gaps_like_empty_cells(tmp_path, capsys):
    """An outage exported as absent rows (time jumps by whole sampling intervals) is read
    as the same outage exported as empty cells: short ones interpolated, long ones cut,
    file rows reported; uneven steps are still refused by the strict reader's rule."""
    from stictionbench.io import read_longest_stretch, read_stretches

    n = 1200
    t = np.arange(n, dtype=float)
    frame = pd.DataFrame({"t": t, "PV": np.sin(t / 15.0), "OP": np.cos(t / 15.0)})
    cells, rows = frame.copy(), frame.drop(index=list(range(700, 764)) + [300, 301])
    cells.loc[700:763, ["PV", "OP"]] = np.nan
    cells.loc[300:301, ["PV", "OP"]] = np.nan
    pc, pr = tmp_path / "cells.csv", tmp_path / "rows.csv"
    cells.to_csv(pc, index=False)
    rows.to_csv(pr, index=False)
    with pytest.raises(InputError, match="row 302, column t: the time jumps by 3 sampling "
                                         "intervals.*only the commands that read a "
                                         "record's usable stretches"):
        read_recording(pr)  # the strict reader refuses, saying what it met
    a, b = read_stretches(pc, warn=False), read_stretches(pr, warn=True)
    assert len(a) == len(b) == 2
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.t, y.t)
        np.testing.assert_allclose(x.PV, y.PV)
    # file rows of the absent-row file: the data row before the outage is index 697
    # there (two rows dropped at 300), file row 699; after it, index 698 -> row 700
    assert [r.meta["rows"] for r in b] == [[2, 699], [700, 1135]]
    err = capsys.readouterr().err
    assert "66 rows absent from the file" in err and "after row 699" in err
    # a step of 1.5 intervals is not a missing row: refused as before
    frame.loc[500, "t"] = 500.5
    frame.to_csv(pr, index=False)
    with pytest.raises(InputError, match="row 502, column t: sampling is not uniform"):
        read_longest_stretch(pr)


def test_iso_8601_timestamps_in_t_read_as_seconds(tmp_path):
    """Historian exports stamp samples with date-times; t becomes seconds since the first
    (across midnight, with a UTC offset, and from a datetime64 Parquet column)."""
    start = pd.Timestamp("2024-06-09 23:58:00")
    stamps = [start + pd.Timedelta(seconds=5 * i) for i in range(200)]
    rows = ["t,SP,PV,OP"] + [f"{s.isoformat()}+02:00,1,{np.sin(i / 7):.6f},{np.cos(i / 5):.6f}"
                             for i, s in enumerate(stamps)]
    p = tmp_path / "stamped.csv"
    p.write_text("\n".join(rows) + "\n")
    rec = read_recording(p)
    np.testing.assert_allclose(rec.t, 5.0 * np.arange(200))
    assert rec.Ts == pytest.approx(5.0)
    frame = pd.DataFrame({"t": stamps, "SP": 1.0, "PV": rec.PV, "OP": rec.OP})
    frame.to_parquet(tmp_path / "stamped.parquet")
    np.testing.assert_allclose(read_recording(tmp_path / "stamped.parquet").t, rec.t)


def test_a_bad_timestamp_names_its_row(tmp_path):
    rows = ["t,SP,PV,OP"] + [f"2024-06-09T10:{i // 60:02d}:{i % 60:02d},1,{i % 7},{i % 5}"
                             for i in range(200)]
    rows[31] = "2024-06-09T10:00:30 or so,1,2,3"
    p = tmp_path / "bad.csv"
    p.write_text("\n".join(rows) + "\n")
    with pytest.raises(InputError, match=r"row 32, column t: not a number or ISO 8601"):
        read_recording(p)


@pytest.mark.parametrize("bad, row", [("t,SP,PV,OP", 52), ("end of export", 202)])
def test_a_text_line_among_numeric_times_names_its_own_row(tmp_path, bad, row):
    """A second header part-way or a note at the end: the bad line is named, not the
    first sample (which is no date-time, the column being numbers)."""
    rows = ["t,SP,PV,OP"] + [f"{i},1,{i % 7},{i % 5}" for i in range(200)]
    if row == 202:
        rows.append(bad)
    else:
        rows[row - 1] = bad
    p = tmp_path / "bad.csv"
    p.write_text("\n".join(rows) + "\n")
    with pytest.raises(InputError, match=rf"row {row}, column t: not a number"):
        read_recording(p)


@pytest.mark.parametrize("sep", [";", "\t", "|"])
def test_semicolon_tab_and_decimal_comma_csv_read_as_the_comma_one(tmp_path, sep):
    """A spreadsheet export from a European locale (``;`` or tab, decimal comma) and a
    pipe-separated export give the same numbers as the plain CSV."""
    plain = tmp_path / "plain.csv"
    plain.write_text(_frame_text())
    lines = _frame_text().splitlines()
    text = "\n".join(line.replace(",", sep) if sep != ";" else
                     ";".join(v.replace(".", ",") for v in line.split(",")) for line in lines)
    other = tmp_path / "other.csv"
    other.write_text(text + "\n", encoding="utf-8-sig")  # with a byte-order mark
    a, b = read_recording(plain), read_recording(other)
    for c in ("t", "SP", "PV", "OP"):
        np.testing.assert_array_equal(getattr(a, c), getattr(b, c))


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be"])
def test_utf16_spreadsheet_export_read_as_the_utf8_one(tmp_path, encoding):
    """A spreadsheet's "Unicode text" export (UTF-16 with a byte-order mark, tab, decimal
    comma, a unit such as ``°C`` in the header) and UTF-16 without a mark give the same
    numbers as the plain CSV; a NUL byte that fits no UTF-16 pattern stays binary."""
    plain = tmp_path / "plain.csv"
    plain.write_text(_frame_text())
    lines = _frame_text().splitlines()
    lines[0] = "t [s]\tSP (°C)\tPV (°C)\tOP [%]"
    text = "\r\n".join([lines[0]] + ["\t".join(v.replace(".", ",") for v in line.split(","))
                                     for line in lines[1:]]) + "\r\n"
    other = tmp_path / "unicode.txt"
    other.write_bytes(text.encode(encoding))
    a, b = read_recording(plain), read_recording(other)
    for c in ("t", "SP", "PV", "OP"):
        np.testing.assert_array_equal(getattr(a, c), getattr(b, c))
    broken = bytearray(text.encode("utf-16-le"))
    broken[1] = 0x41  # a non-NUL high byte in the first character: no UTF-16 pattern
    bad = tmp_path / "broken.csv"
    bad.write_bytes(bytes(broken))
    with pytest.raises(InputError, match="binary data"):
        read_recording(bad)


@pytest.mark.parametrize("header, clash, message", [
    ("Time,sp,pv,Op", "t,pv,Pv,OP,x", "pv, Pv could each be PV"),
    # historian exports put the unit after the name; CO (controller output) is the
    # paper's name for OP; a unit never makes two columns one signal
    ("t [s],SP (degC),PV (degC),CO [%]", "t,SP,PV,OP (%),CO", "OP (%), CO could each be OP"),
])
def test_column_names_matched_without_case_unit_or_alias(tmp_path, header, clash, message):
    base = _frame_text().splitlines()
    p = tmp_path / "names.csv"
    p.write_text("\n".join([header] + base[1:]) + "\n")
    rec = read_recording(p)
    assert rec.columns == ("t", "SP", "PV", "OP")
    np.testing.assert_allclose(rec.PV[:3], [np.sin(i / 7) for i in range(3)], atol=1e-6)
    q = tmp_path / "two.csv"
    q.write_text("\n".join([clash] + [r + ",0" for r in base[1:]]) + "\n")
    with pytest.raises(InputError, match=re.escape(message)):
        read_recording(q)


def test_historian_status_words_are_missing_samples(tmp_path, capsys):
    """'Bad Input', 'I/O Timeout' (OSIsoft PI digital states) are gaps, interpolated when
    short; other text is still an error naming its row."""
    lines = _frame_text().splitlines()
    for row, word in ((11, "Bad Input"), (12, "I/O Timeout"), (40, "shutdown")):
        parts = lines[row].split(",")
        parts[2] = word
        lines[row] = ",".join(parts)
    p = tmp_path / "pi.csv"
    p.write_text("\n".join(lines) + "\n")
    rec = read_recording(p)
    assert np.isfinite(rec.PV).all() and len(rec) == 200
    assert "interpolated" in capsys.readouterr().err


def test_an_empty_optional_column_is_a_signal_not_recorded(tmp_path):
    lines = _frame_text().splitlines()
    p = tmp_path / "empty_sp.csv"
    p.write_text("\n".join(["t,SP,PV,OP,MV"] + [",".join(r.split(",")[:1] + [""] +
                                                      r.split(",")[2:] + [""])
                                                for r in lines[1:]]) + "\n")
    rec = read_recording(p)
    assert rec.SP is None and rec.MV is None and len(rec) == 200
    q = tmp_path / "empty_pv.csv"  # a required one is still refused
    q.write_text("\n".join(["t,SP,PV,OP"] + [",".join(r.split(",")[:2] + [""] +
                                                   r.split(",")[3:]) for r in lines[1:]]))
    with pytest.raises(InputError, match="column PV: gap"):
        read_recording(q)


def test_an_outage_longer_than_the_grid_bridges_is_named_as_an_outage(tmp_path):
    """A one-hour outage in a 1000-sample, 1 s record (rows absent from the file) is
    longer than the stretch readers bridge; the message says so, not "sampling is not
    uniform" (a first version's message, which hid the cause)."""
    from stictionbench.io import read_longest_stretch

    t = np.arange(1000.0)
    t[600:] += 3600.0
    p = tmp_path / "outage.csv"
    pd.DataFrame({"t": t, "PV": np.sin(t / 15.0), "OP": np.cos(t / 15.0)}).to_csv(
        p, index=False)
    with pytest.raises(InputError, match=r"row 602, column t: the time jumps by 3601 "
                                         r"sampling intervals \(3601 s\).*cut the file"):
        read_longest_stretch(p)
