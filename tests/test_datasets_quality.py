"""Loaders for real data, data-quality screening and the oscillation benchmark.

Shared-data tests read ``../shared/data`` in place through the ``data_dir`` fixture and
skip when it is absent; everything else runs on synthetic signals and small ``.mat``
files written with ``scipy.io.savemat``.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest
import scipy.io

from stictionbench import InputError, Recording
from stictionbench.cli import main
from stictionbench.realdata import oscillation_benchmark
from stictionbench.realdata.datasets import (
    load_csv_dir,
    load_isdb_mat,
    load_oscillation_benchmark,
    read_any,
    read_labels,
    scan_isdb_mat,
)
from stictionbench.realdata.quality import (
    estimate_quantum,
    held_fraction,
    release_holds,
    screen,
)
from stictionbench.sim.measurement import (
    boxcar_compress,
    compress_to_share,
    historian_compression,
)

ISDB_LOOPS = {"CHEM1", "CHEM2", "CHEM10", "CHEM11", "CHEM12", "CHEM13", "CHEM23", "CHEM24",
              "CHEM29", "PAP2", "PAP4", "PAP5", "PAP7", "PAP9"}
DEAD_PV = ("RHT-7050-342_FIC10112_0630_0002", "RHT-7050-342_FIC10112_0702_0009")


# --------------------------------------------------------------------------- shared data
def test_isdb_csv_dir_loads_14_loops_and_skips_tables(data_dir):
    recs, skipped = load_csv_dir(data_dir / "isdb", warn=False)
    assert set(recs) == ISDB_LOOPS
    assert {f for f, _ in skipped} == {"labels.csv", "isdb_index.csv"}
    assert all("not a recording" in why for _, why in skipped)
    chem1 = recs["CHEM1"]
    assert chem1.meta["label"] == "stiction" and chem1.meta["group"] == "CHEM1"
    assert recs["PAP4"].meta["label"] == "deadzone+tight_tuning"
    assert recs["PAP7"].Ts == pytest.approx(0.2)


def test_read_labels(data_dir):
    isdb = read_labels(data_dir / "isdb" / "labels.csv")
    assert set(isdb.index) == ISDB_LOOPS
    assert (isdb["group"] == isdb["loop"]).all()  # no group column: group = loop
    plant = read_labels(data_dir / "plant" / "labels.csv")
    assert len(plant) == 47
    assert plant.loc["2411FIC20102_1009_0004", "group"] == "2411FIC20102"
    assert plant["group"].nunique() == 18


def test_isdb_mean_removed_loops_are_flagged_not_unusable(data_dir):
    recs, _ = load_csv_dir(data_dir / "isdb", warn=False)
    normalised = {n for n, r in recs.items() if screen(r).flags["normalised"]}
    assert normalised == {"CHEM10", "CHEM11", "CHEM12", "CHEM13"}
    assert screen(recs["CHEM13"]).flags["unit_variance"]
    assert all(screen(recs[n]).usable for n in normalised)


def test_plant_windows_dead_pv_and_held_fractions(data_dir):
    recs, skipped = load_csv_dir(data_dir / "plant", warn=False)
    assert len(recs) == 47
    assert [f for f, _ in skipped] == ["labels.csv"]
    reports = {n: screen(r) for n, r in recs.items()}
    for name in DEAD_PV:
        rep = reports[name]
        assert not rep.usable
        assert rep.reasons[0].startswith("PV dead")
        assert rep.flags["PV_dead"]
    for name, rep in reports.items():
        assert rep.flags["held_frac"] == pytest.approx(
            recs[name].meta["labels"]["held_frac"], abs=0.02), name
    # only the dead tags are unusable; the 54 %-held window is graded, not turned away
    unusable = {n for n, rep in reports.items() if not rep.usable}
    assert unusable == set(DEAD_PV)
    held = reports["2111LIC42502_0620_0010"]
    assert held.flags["grade"] == "poor" and any("compression" in w for w in held.warnings)
    assert any("compression" in w for w in reports["2111FIC46005_0614_0003"].warnings)


# --------------------------------------------------------------------------- .mat files
def _isdb_struct(rng):
    k = np.arange(300.0)
    loop = {"PV": np.sin(k / 8) + 0.01 * rng.normal(size=k.size),
            "OP": np.cos(k / 8), "SP": np.zeros_like(k), "Ts": 2.0, "t": k * 2,
            "Comments": "Flow loop. Has a stiction problem.", "BriefComments": "FC1"}
    loop2 = {"PV": k % 17, "OP": k % 13, "SP": np.array([]), "Ts": 0.5,
             "Comments": "no SP"}
    bad = {"OP": k, "Ts": 1.0}  # no PV
    return {"cdata": {"chemicals": {"loop1": loop, "loop2": loop2},
                      "pulpPapers": {"loop3": loop2, "loop4": bad}}}


def test_isdb_mat_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    f = tmp_path / "isdb.mat"
    data = _isdb_struct(rng)
    scipy.io.savemat(f, data)
    recs, skipped = scan_isdb_mat(f, warn=False)
    assert list(recs) == ["CHEM1", "CHEM2", "PAP3"]
    assert [n for n, _ in skipped] == ["PAP4"] and "no PV" in skipped[0][1]
    r = recs["CHEM1"]
    src = data["cdata"]["chemicals"]["loop1"]
    np.testing.assert_array_equal(r.PV, src["PV"])
    np.testing.assert_array_equal(r.OP, src["OP"])
    np.testing.assert_array_equal(r.SP, src["SP"])
    np.testing.assert_allclose(r.t, np.arange(300) * 2.0)
    assert r.Ts == 2.0
    assert r.meta["comments"] == "Flow loop. Has a stiction problem."
    assert r.meta["briefcomments"] == "FC1"
    assert r.meta["sector"] == "chemicals" and r.meta["loop"] == "loop1"
    assert recs["CHEM2"].SP is None and recs["CHEM2"].Ts == 0.5
    with pytest.raises(InputError, match="loop4: no PV"):
        load_isdb_mat(f)
    assert list(load_isdb_mat(f, errors="skip", warn=False)) == ["CHEM1", "CHEM2", "PAP3"]
    assert list(read_any(f, warn=False)) == ["CHEM1", "CHEM2", "PAP3"]


def _benchmark_struct(rng, n=600):
    k = np.arange(n)
    osc = np.sin(2 * np.pi * k / 40) + 0.2 * rng.normal(size=n)
    osc2 = 50 + 5 * np.sign(np.sin(2 * np.pi * k / 60)) + 0.3 * rng.normal(size=n)
    return {"benchmark": {
        "chemicals": {"loop1": {"oscillation": 1, "Ts": 1, "OP": osc},
                      "loop2": {"oscillation": 0, "Ts": 1, "OP": rng.normal(size=n)},
                      "loop10": {"Type": 1, "Ts": 20, "OP": osc2}},
        "metals": {"loop1": {"oscillation": 0, "Ts": 0.05,
                             "OP": np.cumsum(rng.normal(size=n)) * 0.01 + 3}},
    }}


def test_oscillation_benchmark_mat_round_trip(tmp_path):
    rng = np.random.default_rng(2)
    f = tmp_path / "bench.mat"
    data = _benchmark_struct(rng)
    scipy.io.savemat(f, data)
    loops = load_oscillation_benchmark(f)
    assert [lp.name for lp in loops] == ["CHEM1", "CHEM2", "CHEM10", "MET1"]
    assert [lp.flag for lp in loops] == [1, 0, 1, 0]
    assert loops[2].flag_field == "Type" and loops[2].Ts == 20
    assert loops[3].Ts == pytest.approx(0.05)
    np.testing.assert_array_equal(loops[0].op, data["benchmark"]["chemicals"]["loop1"]["OP"])
    rec = loops[0].as_recording()
    assert rec.meta["op_only"] and np.array_equal(rec.PV, rec.OP)
    assert set(read_any(f)) == {"CHEM1", "CHEM2", "CHEM10", "MET1"}
    with pytest.raises(InputError, match="load_oscillation_benchmark"):
        load_isdb_mat(f)


def test_unreadable_mat_is_one_line_input_error(tmp_path):
    f = tmp_path / "bad.mat"
    f.write_bytes(b"this is not a MATLAB file at all" * 20)
    with pytest.raises(InputError) as exc:
        load_isdb_mat(f)
    assert "\n" not in str(exc.value) and "bad.mat" in str(exc.value)
    g = tmp_path / "other.mat"
    scipy.io.savemat(g, {"x": np.arange(5)})
    with pytest.raises(InputError, match="no struct"):
        load_oscillation_benchmark(g)


def test_csv_dir_labels_and_bad_files(tmp_path):
    t = np.arange(200.0)
    pd.DataFrame({"t": t, "PV": np.sin(t / 9), "OP": np.cos(t / 9)}).to_csv(
        tmp_path / "A_1.csv", index=False)
    pd.DataFrame({"t": t[:50], "PV": t[:50], "OP": t[:50]}).to_csv(
        tmp_path / "short.csv", index=False)
    pd.DataFrame({"loop": ["A_1"], "group": ["A"], "label": ["stiction"]}).to_csv(
        tmp_path / "labels.csv", index=False)
    recs, skipped = load_csv_dir(tmp_path, warn=False)
    assert list(recs) == ["A_1"]
    assert recs["A_1"].meta["group"] == "A" and recs["A_1"].meta["label"] == "stiction"
    why = dict(skipped)
    assert "not a recording" in why["labels.csv"]
    assert "50 samples" in why["short.csv"]
    recs2, _ = load_csv_dir(tmp_path, labels=False, warn=False)
    assert recs2["A_1"].meta["group"] == "A_1" and "label" not in recs2["A_1"].meta


# --------------------------------------------------------------------------- screening
def _rec(pv, op, Ts=1.0, **kw):
    return Recording.from_arrays(np.arange(len(pv)) * Ts, pv, op, warn=False, **kw)


@pytest.fixture
def clean():
    rng = np.random.default_rng(3)
    n = 3000
    k = np.arange(n)
    op = 50 + 5 * np.sin(2 * np.pi * k / 100) + 0.2 * rng.normal(size=n)
    pv = 20 + 3 * np.sin(2 * np.pi * (k - 10) / 100) + 0.1 * rng.normal(size=n)
    return pv, op


def test_clean_signal_is_usable_without_warnings(clean):
    rep = screen(_rec(*clean))
    assert rep.usable and rep.reasons == [] and rep.warnings == []
    assert rep.flags["held_frac"] == 0 and not rep.flags["normalised"]
    assert rep.flags["n_periods"] == pytest.approx(30, rel=0.05)
    json.dumps(rep.to_dict(), allow_nan=False)


def test_constant_and_dead_signals(clean):
    pv, op = clean
    rep = screen(_rec(np.full(pv.size, 7.0), op))
    assert not rep.usable and rep.reasons[0].startswith("PV constant")
    rep = screen(_rec(pv, np.full(op.size, 3.5e-44)))
    assert not rep.usable and rep.reasons[0].startswith("OP dead")


def test_quantised_signal(clean):
    pv, op = clean
    q = 0.25  # PV spans about 6/0.25 = 24 quanta: warning
    rep = screen(_rec(np.round(pv / q) * q, op))
    assert rep.usable and rep.flags["PV_quantised"]
    assert rep.flags["PV_quantum"] == pytest.approx(q)
    assert any("PV quantised" in w for w in rep.warnings)
    rep = screen(_rec(np.round(pv / 1.8) * 1.8, op))  # about 4 steps: unusable
    assert not rep.usable and "quantised too coarsely" in rep.reasons[0]
    assert estimate_quantum(pv) is None


def test_compressed_signal(clean):
    pv, op = clean
    rng = np.random.default_rng(4)

    def boxcar(p_hold):
        hold = rng.random(pv.size) < p_hold
        hold[0] = False
        idx = np.where(hold, 0, np.arange(pv.size))
        idx = np.maximum.accumulate(idx)
        return pv[idx], op[idx], float(np.mean(hold[1:]))

    pv6, op6, frac6 = boxcar(0.6)
    rep = screen(_rec(pv6, op6))
    assert rep.flags["held_frac"] == pytest.approx(frac6, abs=1e-9)
    assert held_fraction(pv6, op6) == pytest.approx(frac6, abs=1e-9)
    # graded, not a cliff: usable, a poor score, the reason in the warnings
    assert rep.usable and rep.flags["grade"] == "poor" and rep.flags["score"] < 0.5
    assert any("compression" in w for w in rep.warnings)
    released, k = release_holds(_rec(pv6, op6))
    assert k > 0 and screen(released).flags["held_frac"] < 0.1
    pv9, op9, _ = boxcar(0.95)
    rep = screen(_rec(pv9, op9))
    assert not rep.usable and "historian fill" in rep.reasons[0]
    pv3, op3, frac3 = boxcar(0.3)
    rep = screen(_rec(pv3, op3))
    assert rep.usable and rep.flags["compressed"]
    assert any("compression" in w for w in rep.warnings)
    # linear interpolation between every 4th sample: 3 of 4 steps on straight lines
    k = np.arange(pv.size)
    keep = k[::4]
    rep = screen(_rec(np.interp(k, keep, pv[keep]), np.interp(k, keep, op[keep])))
    assert rep.flags["linear_frac"] == pytest.approx(0.75, abs=0.01)
    assert rep.usable and rep.flags["score_compression"] < 0.25


def test_historian_boxcar_model(clean):
    """The exception historian of experiments/compression.py: every read-back value is
    within the dead band of the truth, the dead band is set for the asked hold share,
    tags are compressed independently, and a share of 1 is refused."""
    pv, op = clean
    for share in (0.3, 0.7):
        c = compress_to_share(pv, share)
        assert held_fraction(c) == pytest.approx(share, abs=0.01)
        band = np.min(np.abs(np.diff(c)[np.diff(c) != 0]))  # every stored jump exceeds it
        assert np.max(np.abs(c - pv)) <= band
    assert np.max(np.abs(boxcar_compress(pv, 0.5) - pv)) <= 0.5
    out = historian_compression(_rec(pv, op), 0.6)
    assert held_fraction(out.PV) == pytest.approx(0.6, abs=0.01)
    assert held_fraction(out.OP) == pytest.approx(0.6, abs=0.01)
    assert held_fraction(out.PV, out.OP) < 0.6  # independent tags: fewer joint holds
    with pytest.raises(InputError, match="below 1"):
        compress_to_share(pv, 1.0)


def test_one_tag_compressed(clean):
    """A PV compressed on its own (OP intact) is not a PV-and-OP hold: the record is not
    flagged compressed, a warning names the tag, and only ``joint=False`` bridges it."""
    pv, op = clean
    rec = _rec(compress_to_share(pv, 0.5), op)
    rep = screen(rec)
    assert rep.usable and not rep.flags["compressed"]
    assert rep.flags["PV_compressed_frac"] == pytest.approx(0.5, abs=0.02)
    assert any("historian compression of PV alone" in w for w in rep.warnings)
    assert release_holds(rec)[1] == 0
    bridged, k = release_holds(rec, joint=False)
    assert k > 0.3 * pv.size and held_fraction(bridged.PV) < 0.05
    assert np.array_equal(bridged.OP, op)
    # a saturated OP holds at its limit: not counted as compression
    assert screen(_rec(pv, np.minimum(op, 52.0))).flags["OP_compressed_frac"] < 0.01


def test_saturated_op(clean):
    pv, op = clean
    rep = screen(_rec(pv, np.minimum(op, 52.0)))  # clipped ~ 35 % of the time
    assert rep.usable and rep.warnings[0].startswith("OP saturated at its maximum")
    assert rep.flags["OP_sat_high_frac"] > 0.2 and rep.flags["score_saturation"] < 1
    rep = screen(_rec(pv, np.minimum(op, np.quantile(op, 0.1))))  # pinned 90 %
    assert not rep.usable and rep.reasons[0].startswith("OP saturated at its maximum")


def test_normalised_interpolated_short_and_few_periods(clean):
    pv, op = clean
    z = lambda x: (x - x.mean()) / x.std()  # noqa: E731
    rep = screen(_rec(z(pv), z(op)))
    assert rep.usable and rep.flags["mean_removed"] and rep.flags["unit_variance"]
    gappy = pv.copy()
    gappy[100:103] = np.nan
    rep = screen(_rec(gappy, op))
    assert rep.usable and rep.flags["interpolated_values"] == 3
    assert any("interpolated" in w for w in rep.warnings)
    rep = screen(_rec(pv[:250], op[:250]))  # 2.5 periods of 100 samples
    assert rep.flags["few_periods"] and rep.flags["short"]
    assert rep.usable


# --------------------------------------------------------------------------- benchmark
def test_oscillation_benchmark_writes_its_files(tmp_path):
    rng = np.random.default_rng(5)
    f = tmp_path / "bench.mat"
    scipy.io.savemat(f, _benchmark_struct(rng))
    out = tmp_path / "out"
    res = oscillation_benchmark.run(f, out, null_reps=2)
    for name in ("results.csv", "summary.md", "confusion.png"):
        assert (out / name).stat().st_size > 0
    table = pd.read_csv(out / "results.csv")
    assert list(table["name"]) == ["CHEM1", "CHEM2", "CHEM10", "MET1"]
    assert {"default", "trend_removed"} <= set(res)
    assert res["default"]["tp"] + res["default"]["fn"] == 2
    assert res["trend_removed"]["accuracy"] == 1.0
    text = (out / "summary.md").read_text()
    assert "balanced accuracy" in text and "Per sector" in text


def test_cli_screen_and_benchmark(tmp_path, capsys):
    rng = np.random.default_rng(6)
    t = np.arange(400.0)
    pd.DataFrame({"t": t, "PV": np.full(400, 3.5e-44), "OP": rng.normal(size=400)}).to_csv(
        tmp_path / "dead.csv", index=False)
    pd.DataFrame({"t": t, "PV": np.sin(t / 7) + rng.normal(size=400) * 0.1,
                  "OP": np.cos(t / 7)}).to_csv(tmp_path / "good.csv", index=False)
    pd.DataFrame({"loop": ["good"], "label": ["no_stiction"]}).to_csv(
        tmp_path / "labels.csv", index=False)
    mat = tmp_path / "bench.mat"
    scipy.io.savemat(mat, _benchmark_struct(rng))
    js = tmp_path / "screen.json"
    assert main(["screen", str(tmp_path), "--json", str(js)]) == 0
    out = capsys.readouterr().out
    assert "dead" in out and "UNUSABLE" in out and "skipped" in out
    # the graded score is on the console too, not only in the JSON
    good = next(line for line in out.splitlines() if line.startswith("good "))
    assert re.search(r"usable\s+(good|fair|poor) \d\.\d\d", good), good
    payload = json.loads(js.read_text())
    by = {r["name"]: r for r in payload["recordings"]}
    assert not by["dead"]["usable"] and by["good"]["usable"]
    assert by["good"]["label"] == "no_stiction"
    assert {"CHEM1", "MET1"} <= set(by)  # the .mat in the folder, OP only
    assert by["CHEM1"]["flags"]["op_only"]
    assert main(["screen", str(tmp_path / "missing.csv")]) == 2
    assert main(["oscillation-benchmark", str(mat), "--out", str(tmp_path / "ob"),
                 "--null-reps", "0"]) == 0
    assert (tmp_path / "ob" / "summary.md").exists()
