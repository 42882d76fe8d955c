"""Healthy loops called sticky on the independent set: the controller's rate, varied alone.

On the independent concealed set (``experiments/independent_set.py``, generator
``experiments/blind_generator``) healthy (``none``) loops were named ``deadband`` or
``stiction`` with valve parameters far larger than anything the loops show (a 10–15 %
dead band, S = 13 %), most of them with the PI running five times faster than the 1 s
historian. The explanation on offer: the historian stores a *snapshot* of an OP that the
PI moves on every controller step in answer to PV noise (its proportional kick,
``kc × noise``), while the process integrates the OP of every step in between. The
recorded OP then carries input noise the process never felt as recorded
(errors-in-variables), and a dead band, which ignores small OP moves, fits that better
than the linear valve. If so, the false alarms follow the controller's rate, and vanish
when the PI runs at the historian's rate (its OP is then exactly what the process got
for the whole second).

The check: ``none`` loops of the blind generator at fresh seeds (:data:`FIRST_SEED`,
unused by ``set_a`` and ``set_b``), each made twice: as drawn (PI every 0.1–1 s) and with
only the PI's period set to 1 s (the same process, tuning, set point and effect sizes; the
noise and load drawn at the new controller rate are new draws of the same distributions).
Each is diagnosed with its model as the command does. Nothing is tuned here; Wilson 95 %
intervals.

Run: ``.venv/bin/python experiments/snapshot_op.py [--loops 24] [--jobs 2]``; writes
``reports/concealed/snapshot_op.{md,csv}``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))
sys.path.insert(0, str(ROOT / "experiments" / "blind_generator"))

import generate as bg  # noqa: E402
from fresh_recordings import publish, run  # noqa: E402

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.rates import fisher_p, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
#: a seed block neither ``set_a`` (1000–1191) nor ``set_b`` (5000–5191) draws
FIRST_SEED = 20000
VALVES = ("deadband", "stiction")


def make(seed: int, level: int, period: float | None) -> tuple[dict, dict, dict]:
    """The blind generator's ``none`` loop of ``seed``, its PI period replaced by
    ``period`` (``None``: as drawn)."""
    draw = bg.draw_loop

    def forced(rng):
        lp = draw(rng)
        return lp if period is None else lp | {"Tc": float(period)}

    bg.draw_loop = forced
    try:
        res, nominal, tr, _ = bg.make_recording(seed, level, "none")
    finally:
        bg.draw_loop = draw
    return res, nominal, tr


def one(seed: int, level: int, period: float | None) -> dict:
    """Make, write (as the generator does), read back and diagnose one loop."""
    res, nominal, tr = make(seed, level, period)
    with tempfile.TemporaryDirectory() as tmp:
        bg.write_recording(tmp, "rec", res, nominal)
        rec = read_recording(str(Path(tmp) / "rec.csv"), warn=False)
        d = diagnose(rec, load_model(Path(tmp) / "rec.model.yaml"))
    params = d.parameters
    size = params.get("deadband", params.get("S"))
    return {"seed": seed, "level": level,
            "condition": "as drawn" if period is None else f"PI every {period:g} s",
            "controller_period": tr["controller_period"], "tau": tr["tau"],
            "theta": tr["theta"], "kc": tr["kc"], "noise_sigma": tr["noise_sigma"],
            "kick_over_step": tr["kc"] * tr["noise_sigma"] / (tr["sp_step_mean"] / tr["K"]),
            "attempts": tr["attempts"], "predicted": d.missing_physics, "valve_size": size}


def report(df: pd.DataFrame) -> str:
    rows = []
    for (lvl, cond), g in df.groupby(["level", "condition"], sort=False):
        fast = g[g["controller_period"] < 1.0]
        rows.append({"level": lvl, "condition": cond, "loops": len(g),
                     "called physics": rate_text(int((g["predicted"] != "none").sum()),
                                                 len(g)),
                     "called a sticky valve": rate_text(
                         int(g["predicted"].isin(VALVES).sum()), len(g)),
                     "of them with the PI faster than 1 s":
                         rate_text(int(fast["predicted"].isin(VALVES).sum()), len(fast))
                         if len(fast) else "–"})
    tab = pd.DataFrame(rows)
    drawn = df[(df["condition"] == "as drawn") & (df["controller_period"] < 1.0)]
    slow = df[(df["condition"] != "as drawn") & df["seed"].isin(drawn["seed"])]
    k1, n1 = int(drawn["predicted"].isin(VALVES).sum()), len(drawn)
    k2, n2 = int(slow["predicted"].isin(VALVES).sum()), len(slow)
    valves = df[df["predicted"].isin(VALVES)]
    lines = ["# Healthy loops called sticky: the controller's rate varied alone", "",
             "Generated by `experiments/snapshot_op.py` (see its docstring): `none` loops of "
             "the blind generator at seeds from "
             f"{FIRST_SEED}, as drawn and with the PI every 1 s (the historian's rate), each "
             "diagnosed with its model as `stictionbench diagnose` does.", "",
             to_markdown(tab), "",
             f"- Loops whose PI was drawn faster than the historian: called a sticky valve "
             f"{rate_text(k1, n1)} as drawn, {rate_text(k2, n2)} with the same loops' PI at "
             f"1 s (Fisher p = {fisher_p(k1, n1, k2, n2):.2g}).",
             f"- Valve sizes fitted on healthy loops: median {valves['valve_size'].median():.3g} "
             f"% of OP (n = {len(valves)}); the median proportional kick on PV noise is "
             f"{df['kick_over_step'].median():.2g} of the OP move of a set-point step."
             if len(valves) else "- No healthy loop was called a sticky valve.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--loops", type=int, default=24, help="loops per level")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    todo = [(FIRST_SEED + 100 * level + i, level, period) for level in (1, 2)
            for i in range(args.loops) for period in (None, 1.0)]
    df = run(one, todo, args.jobs)
    publish(df, report(df), OUT / "snapshot_op")
    return 0


if __name__ == "__main__":
    sys.exit(main())
