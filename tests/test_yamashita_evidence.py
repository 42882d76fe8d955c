"""``experiments/yamashita_evidence.py`` on hand-made flow loops: it lists each decided
window with the number of moving samples ρ rests on, skips loops that are not flow loops,
and refuses a folder without labels (exit 2, one line)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import yamashita_evidence as ye  # noqa: E402


def _write(folder: Path, loops: dict[str, tuple[str, str, int, int]]) -> None:
    """Each loop ``name: (label, loop type, OP moves, PV moves)``: OP steps ``moves``
    times and PV (the flow) steps with the first ``PV moves`` of them, so Yamashita's ρ
    is ``(moves − PV moves)/moves`` from ``moves`` moving samples."""
    folder.mkdir(parents=True)
    t = np.arange(600.0)
    rows = []
    for name, (label, kind, moves, pv_moves) in loops.items():
        at = np.linspace(0, 600, moves + 2)[1:-1].round()
        op = 40.0 + 2.0 * np.searchsorted(at, t, side="right") + 0.001 * np.cos(t)
        pv = 0.001 * np.sin(t) + np.searchsorted(at[:pv_moves], t, side="right")
        pd.DataFrame({"t": t, "PV": pv, "OP": op}).to_csv(folder / f"{name}.csv",
                                                          index=False)
        rows.append({"loop": name, "group": name, "label": label, "loop_type": kind})
    pd.DataFrame(rows).to_csv(folder / "labels.csv", index=False)


def test_moving_samples_per_window(tmp_path):
    _write(tmp_path / "isdb", {"FIC1": ("stiction", "F", 40, 0),
                               "LIC2": ("stiction", "L", 40, 0)})
    _write(tmp_path / "plant", {"FIC3": ("no_stiction", "F", 12, 8)})
    out = tmp_path / "out"
    assert ye.main(["--data", str(tmp_path), "--out", str(out)]) == 0
    df = pd.read_csv(out / "yamashita_evidence.csv").set_index("window")
    assert sorted(df.index) == ["FIC1", "FIC3"]                 # the level loop is skipped
    assert df.loc["FIC1", "moving"] == 40 and df.loc["FIC3", "moving"] == 12
    assert df.loc["FIC1", "rho"] == 1.0 and abs(df.loc["FIC3", "rho"] - 1 / 3) < 1e-3
    assert (df["verdict"] == "stiction").all()                 # both above 0.25 ...
    assert not df.loc["FIC1", "interval_holds_threshold"]      # 40 of 40: clear of it
    assert df.loc["FIC3", "interval_holds_threshold"]          # 4 of 12: not
    assert "1/1 = 100 %" in (out / "yamashita_evidence.md").read_text()


def test_missing_labels_exit_2(tmp_path, capsys):
    assert ye.main(["--data", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no labelled data" in err
    assert not (tmp_path / "o").exists()
