"""The opt-in slip-jump bootstrap on the independent sets: does a calibrated test of
``J = 0`` stop dead bands being named stiction at level 1, and what does it cost?

Why: at level 1 on the independent sets A–I, 17 of 108 dead-band recordings are named
``stiction`` and 17 of 108 sticky valves ``deadband``. The χ²₁ reference of the slip-jump
test rejects ``J = 0`` on about half of the true dead bands
(``slip_jump_calibration.md``, ``slip_jump_pi_rate.md``). ``diagnose --slip-jump-bootstrap
B`` replaces that reference by a closed-loop parametric bootstrap, which held its size on
level-2 recordings of the holdout and tuning families (``slip_jump_bootstrap.md``). It
has not been tried on the independent generators, nor at level 1, where most of the
confusions are.

Design (written before the run; nothing here changes the package or sets a threshold):

- recordings: every level-1 dead-band and stiction recording of sets A–I
  (``.cache/blindgen``, generators A and C), each with its model YAML;
- each diagnosed twice in the same run: at the package's defaults, and with
  ``slip_jump_bootstrap=19`` (``bootstrap_seed=0``) and nothing else changed;
- reported per generator and class, with Wilson 95 % intervals: named ``stiction``,
  named ``deadband``, named any sticky valve, and the slip-jump test's p ≤ 0.05 each way.
  McNemar's exact test is applied to each class named right. The median and the largest
  time per diagnosis are measured each way;
- the reading: if the bootstrap is the remedy, true dead bands are named stiction far
  less often, and sticky valves lose less than dead bands gain.

Output: ``reports/concealed/slip_jump_bootstrap_sets.{md,csv}``. ``--reuse`` re-makes the
report from the CSV. About 30 minutes on 2 cores.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fresh_recordings import stored_experiment  # noqa: E402
from linear_input_gate import DATA, set_recording  # noqa: E402

from stictionbench.diagnosis import diagnose  # noqa: E402
from stictionbench.rates import mcnemar_p, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

STEM = ROOT / "reports" / "concealed" / "slip_jump_bootstrap_sets"
SETS = {"A": ("a", "b", "d", "f", "h"), "C": ("c", "e", "g", "i")}
CLASSES = ("deadband", "stiction")
B = 19
WAYS = ("default", "bootstrap")


def cases() -> list[tuple]:
    """``(generator, set, name, class)`` of every level-1 dead band and sticky valve."""
    todo = []
    for gen, sets in SETS.items():
        for s in sets:
            t = pd.read_csv(DATA / f"set_{s}" / "truth.csv")
            t = t[t["class"].isin(CLASSES) & (t.level == 1)]
            todo += [(gen, s, n, c) for n, c in zip(t["name"], t["class"], strict=True)]
    return todo


def one(gen: str, set_: str, name: str, cls: str) -> dict:
    rec, model = set_recording(set_, name)
    row = {"generator": gen, "set": set_, "name": name, "class": cls}
    for way, b in zip(WAYS, (0, B), strict=True):
        t0 = time.perf_counter()
        d = diagnose(rec, model, slip_jump_bootstrap=b, bootstrap_seed=0)
        row[f"seconds_{way}"] = time.perf_counter() - t0
        row[way] = d.missing_physics
        row[f"slip_jump_p_{way}"] = d.tests.get("slip_jump_zero", {}).get("p_value")
    return row


def summary(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (gen, cls), g in df.groupby(["generator", "class"], sort=True):
        row = {"generator": gen, "valve (truth)": cls, "recordings": len(g)}
        for way in WAYS:
            for label, hit in (("stiction", g[way] == "stiction"),
                               ("deadband", g[way] == "deadband"),
                               ("sticky valve", g[way].isin(CLASSES)),
                               ("p ≤ 0.05", g[f"slip_jump_p_{way}"] <= 0.05)):
                row[f"{label}, {way}"] = rate_text(int(hit.sum()), len(g))
        right_d, right_b = g.default == cls, g.bootstrap == cls
        a, b = int((right_b & ~right_d).sum()), int((right_d & ~right_b).sum())
        row["right only with / only without the bootstrap"] = (
            f"{a} / {b} (McNemar p = {mcnemar_p(a, b):.2g})")
        rows.append(row)
    return pd.DataFrame(rows)


def report(df: pd.DataFrame) -> str:
    lines = []
    for cls in CLASSES:
        g = df[df["class"] == cls]
        d, b = int((g.default == cls).sum()), int((g.bootstrap == cls).sum())
        wrong = "stiction" if cls == "deadband" else "deadband"
        wd, wb = int((g.default == wrong).sum()), int((g.bootstrap == wrong).sum())
        lines.append(f"- true {cls}, both generators: named right {rate_text(d, len(g))} at "
                     f"the defaults, {rate_text(b, len(g))} with the bootstrap; named "
                     f"{wrong} {wd} → {wb}.")
    right_d = int((df.default == df["class"]).sum())
    right_b = int((df.bootstrap == df["class"]).sum())
    sec = {w: (df[f"seconds_{w}"].median(), df[f"seconds_{w}"].max()) for w in WAYS}
    lines.append(f"- dead bands and sticky valves named right together: {right_d} → "
                 f"{right_b} of {len(df)}.")
    lines.append(f"- time per diagnosis (this run, 2 workers): median "
                 f"{sec['default'][0]:.2f} s, largest {sec['default'][1]:.2f} s at the "
                 f"defaults; median {sec['bootstrap'][0]:.2f} s, largest "
                 f"{sec['bootstrap'][1]:.2f} s with B = {B}.")
    return "\n".join([
        "# The slip-jump bootstrap on the independent sets, level 1", "",
        "Generated by `experiments/slip_jump_bootstrap_sets.py` (the design is in its "
        "docstring). Every level-1 dead-band and stiction recording of sets A–I is "
        "diagnosed with its model YAML twice: at the package's defaults (the χ²₁ slip-jump "
        f"test) and with `--slip-jump-bootstrap {B}` (seed 0), nothing else changed. "
        "Wilson 95 % intervals. Nothing is tuned here. The sets were looked at while the "
        "decision's rules were chosen (`docs/diagnosis.md`), but not for the bootstrap, "
        "which has no parameter set on any recording.", "",
        to_markdown(summary(df)), "",
        *lines, ""])


def main(argv: list[str] | None = None) -> int:
    return stored_experiment(__doc__, STEM, one, cases, ["generator", "set", "name"], report,
                             argv)


if __name__ == "__main__":
    raise SystemExit(main())
