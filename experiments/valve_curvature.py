"""Valve characteristics the benchmark families never make: concave, and the valve opening
against OP.

The three families of ``experiments/concealed.py`` hide one installed characteristic:
equal-percentage (convex in OP) on a valve that opens with OP. Plants also have

- **concave installed curves**: a linear or quick-opening valve whose pressure drop falls
  as it opens (little valve authority); here the simulator's ``quick_opening`` valve,
  flow = 100·√(travel/100), a curve the diagnosis does not contain;
- **valves that open against OP**: an air-to-close valve with the controller's output
  signal recorded (opening = 100 % − OP); here each family's equal-percentage recording
  written as ``100 − OP``, with the model's process gain and controller gain negated
  (the loop is the same loop).

Controls: each family's ``none`` recordings written the same way (``100 − OP``, gains
negated): the wider hypothesis must not name physics on them.

Each recording is diagnosed as a user would (recording + model, package defaults) twice
in the same run: with the shipped ``valve_characteristic`` hypothesis (equal-percentage
with OP or against it, one signed curvature parameter:
:class:`stictionbench.diagnosis.hypotheses.ValveCharacteristic`) and with the earlier
one-branch hypothesis (with OP only; an ablation, its grid restricted). Nothing here sets
a threshold. Writes ``reports/concealed/valve_curvature.{md,csv}``.

Run: ``.venv/bin/python experiments/valve_curvature.py [--seeds 4] [--jobs 2]``.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import concealed_families as cf  # noqa: E402

import stictionbench.diagnosis.hypotheses as hyp  # noqa: E402
from stictionbench.diagnosis import diagnose  # noqa: E402
from stictionbench.diagnosis.hypotheses import ValveCharacteristic  # noqa: E402
from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"


class OneBranch(ValveCharacteristic):
    """The earlier hypothesis: equal-percentage, the valve opening with OP only."""

    def grid(self, ctx):
        return [g for g in super().grid(ctx) if int(g[1]) == 0]


def cases(seeds: int) -> list[tuple[str, str, int, int]]:
    """``(case, family, level, seed)`` of every recording."""
    out = []
    for level in (1, 2):
        for seed in range(seeds):
            out += [("quick_opening", fam, level, seed) for fam in ("sim_physical", "sim_he")]
            out += [("against_op", fam, level, seed) for fam in cf.FAMILIES]
            out += [("none_against_op", fam, level, seed) for fam in cf.FAMILIES]
    return out


def one(case: str, family: str, level: int, seed: int) -> dict:
    cls = "none" if case.startswith("none") else "valve_characteristic"
    kw = {"characteristic": "quick_opening"} if case == "quick_opening" else {}
    c, sig = cf.make_recording(family, cls, level, seed, **kw)
    m = cf.nominal_model(c)
    op = np.asarray(sig["OP"], float)
    if case.endswith("against_op"):
        op = 100.0 - op
        m = replace(m, gain=-m.gain, kc=-m.kc)
    rec = Recording.from_arrays(sig["t"], sig["PV"], op, SP=sig["SP"])
    row = {"case": case, "family": family, "level": level, "seed": seed, "truth": cls}
    # the package's registry through its module (a worker process gets the module by
    # reference; a dict named in this script would be pickled by value, a copy)
    shipped = hyp.HYPOTHESES["valve_characteristic"]
    for label, h in (("shipped", shipped), ("one_branch", OneBranch())):
        hyp.HYPOTHESES["valve_characteristic"] = h
        try:
            d = diagnose(rec, m)
        finally:
            hyp.HYPOTHESES["valve_characteristic"] = shipped
        row[label] = d.missing_physics
        row[f"{label}_opening"] = d.details.get("valve_opening", "")
        row[f"{label}_rangeability"] = d.parameters.get("rangeability", np.nan)
    return row


def summary(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (case, level), g in df.groupby(["case", "level"], sort=False):
        truth = g["truth"].iloc[0]
        row = {"case": case, "level": level, "recordings": len(g)}
        for label in ("shipped", "one_branch"):
            if truth == "none":
                row[label] = "physics named " + rate_text(int((g[label] != "none").sum()),
                                                          len(g))
            else:
                row[label] = "named " + rate_text(int((g[label] == truth).sum()), len(g))
        rows.append(row)
    return pd.DataFrame(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    from joblib import Parallel, delayed
    from tqdm import tqdm

    todo = cases(args.seeds)
    gen = Parallel(n_jobs=args.jobs, return_as="generator")(delayed(one)(*c) for c in todo)
    df = pd.DataFrame(list(tqdm(gen, total=len(todo), desc="diagnose", unit="rec")))
    tab = summary(df)
    OUT.mkdir(parents=True, exist_ok=True)
    with atomic_path(OUT / "valve_curvature.csv") as p:
        df.to_csv(p, index=False)
    text = "\n".join([
        "# Valve characteristics the benchmark families never make", "",
        "Generated by `experiments/valve_curvature.py` (`make concealed`; the cases are "
        "described in its docstring): concave installed curves (the simulator's "
        "quick-opening valve, `sim_physical` and `sim_he`) and each family's "
        "equal-percentage valve recorded as `100 − OP` with the model's gains negated "
        "(opening against OP), plus each family's `none` recordings written that way. "
        f"{args.seeds} seeds per family and level, the same draws as the benchmark. Each "
        "diagnosed with the model, package defaults: *shipped* (equal-percentage with OP "
        "or against it) and *one_branch* (with OP only, the earlier hypothesis), same "
        "run. Rates carry Wilson 95 % intervals; no threshold was set here.", "",
        to_markdown(tab), "",
        "Opening direction the shipped hypothesis reports where it names the "
        "characteristic: "
        + ", ".join(f"{case}: " + ", ".join(f"{k} {int(v)}" for k, v in
                                         g["shipped_opening"].value_counts().items())
                    for case, g in df[df["shipped"] == "valve_characteristic"]
                    .groupby("case", sort=False)) + ".", ""])
    write_text(OUT / "valve_curvature.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
