"""stictionbench.hosa against the HOSA toolbox outputs in shared/reference/hosa.

Every row of ``delays.csv`` and ``bicoherence.csv`` is replayed from its ``call`` column
(e.g. ``tder(x, y, 30, 64, 0, 64)``): delays must agree within 1e-9, curves and
bicoherence matrices within 1e-10 relative (the files are read in place; the tests skip
when the shared data are absent).
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np
import pytest

from stictionbench import hosa

DELAY_ATOL = 1e-9
RTOL = 1e-10
#: absolute tolerance as a fraction of max |curve| (for entries near zero)
ATOL_FRAC = 1e-12



def read_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def load_signals(ref: Path, name: str) -> dict[str, np.ndarray]:
    return hosa.read_signals(str(ref / "signals" / f"{name}.csv"))


parse_call = hosa.parse_call


def run_call(ref: Path, row: dict[str, str]):
    fn, args = parse_call(row["call"], load_signals(ref, row["signal"]))
    return fn(*args)


def rel_err(ours: np.ndarray, theirs: np.ndarray) -> float:
    return float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs)))


def _case_ids(table: str) -> list[str]:
    """Case names for parametrisation (same location rule as conftest's reference_dir)."""
    shared = Path(os.environ.get("STICTIONBENCH_SHARED", Path(__file__).resolve().parents[2]
                                 / "shared"))
    p = shared / "reference" / "hosa" / table
    return [r["case"] for r in read_rows(p)] if p.exists() else []


def _row(ref: Path, table: str, case: str) -> dict[str, str]:
    rows = [r for r in read_rows(ref / table) if r["case"] == case]
    assert len(rows) == 1, f"{table}: case {case} not found once"
    return rows[0]


# ----------------------------------------------------------------------- delays
@pytest.mark.parametrize("case", _case_ids("delays.csv") or ["absent"])
def test_delay_row(reference_dir: Path, case: str) -> None:
    row = _row(reference_dir, "delays.csv", case)
    res = run_call(reference_dir, row)
    delay, curve = res                       # must unpack as (delay, curve)
    expected = float(row["estimate"])
    assert abs(delay - expected) <= DELAY_ATOL, (row["call"], delay, expected)
    if row["method"] == "tde":
        assert isinstance(delay, int) and delay == int(expected)

    ref_curve = np.genfromtxt(reference_dir / row["curve_file"], delimiter=",", names=True)
    col = ref_curve.dtype.names[1]
    assert col == ("rxy" if row["method"] == "tder" else "avec")
    lags = np.asarray(ref_curve["lag"], float)
    values = np.asarray(ref_curve[col], float)
    np.testing.assert_array_equal(res.lags, lags)
    np.testing.assert_allclose(
        curve, values, rtol=RTOL, atol=ATOL_FRAC * np.max(np.abs(values)), err_msg=row["call"]
    )


def test_delay_table_complete(reference_dir: Path) -> None:
    rows = read_rows(reference_dir / "delays.csv")
    assert len(rows) == len(_case_ids("delays.csv")) >= 18
    assert {r["method"] for r in rows} == {"tder", "tde"}


def test_tder_curve_helper(reference_dir: Path) -> None:
    row = _row(reference_dir, "delays.csv", "02_tde1_demo")
    sig = load_signals(reference_dir, row["signal"])
    delay, lags, rxy = hosa.tder_curve(sig["x"], sig["y"], 30)
    assert abs(delay - float(row["estimate"])) <= DELAY_ATOL
    assert lags[0] == -64 and lags[-1] == 63 and rxy.shape == (128,)


# ----------------------------------------------------------------- bicoherence
@pytest.mark.parametrize("case", _case_ids("bicoherence.csv") or ["absent"])
def test_bicoherence_row(reference_dir: Path, case: str) -> None:
    row = _row(reference_dir, "bicoherence.csv", case)
    bic, waxis = run_call(reference_dir, row)
    ref_bic = np.loadtxt(reference_dir / row["bic_file"], delimiter=",")
    ref_w = np.genfromtxt(reference_dir / row["waxis_file"], delimiter=",", names=True)
    ref_w = np.asarray(ref_w[ref_w.dtype.names[0]], float)
    nfft = int(row["nfft"])
    assert bic.shape == ref_bic.shape == (nfft, nfft)
    np.testing.assert_allclose(waxis, ref_w, rtol=RTOL, atol=1e-15)
    np.testing.assert_allclose(
        bic, ref_bic, rtol=RTOL, atol=ATOL_FRAC * np.max(ref_bic), err_msg=row["call"]
    )
    value, f_row, f_col = hosa.bicoher_peak(bic, waxis)
    assert value == pytest.approx(float(row["max_value"]), rel=RTOL)
    assert f_row == float(row["f_row"]) and f_col == float(row["f_col"])
