"""The published stiction detectors and the shipped consensus on randomised simulated
level (integrating) loops.

The refinery loops include level loops, and a level loop that oscillates is where the
first release called healthy loops sticky. The shared real level loops do not oscillate
(every method is inconclusive on them, ``reports/real/comparison.md``), so nothing
measured on real data says what the detectors do on an oscillating level loop. Two
published methods declare their scope there: Horch's test assumes a self-regulating
process (inconclusive on a level), and He et al. fit the control error instead of OP.
This experiment measures every method, with its paper's defaults and loop type ``L``, on
level loops made by :func:`stictionbench.simulate` (the same code path as
``experiments/flow_loops.py``), randomised over:

- process: an integrator ``k'·e^{−θs}/s`` with ``k'`` 0.002–0.02 PV units per second per
  % OP and ``θ`` 1–10 s (simulated as a first-order lag of time constant 10⁵ s and gain
  ``k'·10⁵``: over a 7500-s record it departs from the integrator by under 8 %);
- PI: SIMC tuning for an integrating process, ``Kc = 1/(k'(λ+θ))``, ``Ti = 4(λ+θ)``, with
  ``λ`` 20–150 s, executing every 0.1, 0.2, 0.5 or 1 s; the historian keeps one sample
  every 10 s for 7500 s (751 samples, a window of the refinery's loops);
- transmitter white noise 0.01–0.3 PV units, first-order lag 0–2 s; a first-order random
  walk load of standard deviation 0–1;
- sticky valves: Kano, He and Choudhury models, stick band ``S`` 0.5, 1, 2, 4 and 8 %
  with ``J/S`` 0.25–1;
- healthy loops: an ideal valve under the load only; under a sinusoidal disturbance of
  period 100–1500 s and amplitude 0.5–5; a dead band of 0.5–4 % (a valve fault, not
  stiction; with a PI on an integrator it can sustain a slow limit cycle); a
  PI with its integral time cut to ``(λ+θ)/2``, oscillating on its own.

Every loop is given only ``t, SP, PV, OP`` (MV withheld). Per method and for the shipped
consensus (``conf/consensus/default.yaml``, trained on the shared real loops: out of
sample here): detection by stick band, false alarms by healthy cause and overall rates,
with Wilson 95 % intervals, and a figure. Nothing is tuned here.

Run: ``.venv/bin/python experiments/level_loops.py [--per-cell 4] [--jobs 2]``; writes
``reports/real/level_loops.{md,csv,png}``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from flow_loops import (  # noqa: E402
    BANDS,
    HEALTHY,
    STICKY,
    figure,
    loop_draw,
    one_loop,
    overall,
    summarise,
)

from stictionbench.io import write_text  # noqa: E402
from stictionbench.realdata.consensus import Consensus  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

SEED0 = 40000
#: a window of the refinery's level loops: 751 samples at 10 s
DURATION, SAMPLE_TIME = 7500.0, 10.0
#: the integrator's stand-in: a lag this slow is an integrator over the record
TAU_INTEGRATOR = 1e5
#: level loops use the bands from 0.5 % up (a quarter per cent is below what a level
#: shows through an integrator within the record)
LEVEL_BANDS = tuple(b for b in BANDS if b >= 0.5)


def draw(kind: str, i: int) -> tuple[list[str], dict]:
    """The overrides of level loop ``i`` of ``kind`` and its drawn parameters."""
    rng = np.random.default_rng([SEED0, (STICKY + HEALTHY).index(kind), i])
    k = float(np.exp(rng.uniform(np.log(0.002), np.log(0.02))))
    theta = float(rng.uniform(1.0, 10.0))
    lam = float(rng.uniform(20.0, 150.0))
    rate = float(rng.choice([0.1, 0.2, 0.5, 1.0]))
    kc, ti = 1.0 / (k * (lam + theta)), 4.0 * (lam + theta)
    if kind == "tight":
        ti = 0.5 * (lam + theta)
    p = {"kind": kind, "k_int": k, "theta": theta, "lambda": lam, "pi_period": rate,
         "kc": kc, "ti": ti}
    return loop_draw(kind, i, rng, p, (k * TAU_INTEGRATOR, TAU_INTEGRATOR, theta),
                     LEVEL_BANDS, (100.0, 1500.0))


def level_loop(kind: str, i: int, consensus: Consensus) -> dict:
    return one_loop(kind, i, consensus, drawn=draw(kind, i), loop_type="L", seed0=SEED0,
                    duration=DURATION, sample_time=SAMPLE_TIME)


def deciders(df: pd.DataFrame, consensus: Consensus) -> pd.DataFrame:
    """How many of the consensus's methods decided (stiction or no stiction) on the loops
    where the consensus gave a verdict, and which method decided alone."""
    decided = df[df["consensus"].isin(["stiction", "no_stiction"])]
    rows = []
    for _, r in decided.iterrows():
        who = [m for m in consensus.methods if r[m] in ("stiction", "no_stiction")]
        rows.append({"label": r["label"], "consensus": r["consensus"],
                     "deciding methods": len(who),
                     "alone": who[0] if len(who) == 1 else "—"})
    if not rows:
        return pd.DataFrame(columns=["deciding methods", "alone", "label", "loops"])
    out = pd.DataFrame(rows).groupby(["deciding methods", "alone", "label"]).size()
    return out.rename("loops").reset_index()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-cell", type=int, default=4,
                    help="sticky loops per valve model and stick band")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", type=Path, default=ROOT / "reports" / "real")
    a = ap.parse_args(argv)
    if a.per_cell < 1 or a.jobs < 1:
        print("level_loops: --per-cell and --jobs must be at least 1", file=sys.stderr)
        return 2
    from joblib import Parallel, delayed
    from tqdm import tqdm

    cons = Consensus.load()
    n_sticky = a.per_cell * len(LEVEL_BANDS)
    jobs = [(k, i) for k in STICKY for i in range(n_sticky)]
    jobs += [(k, i) for k in HEALTHY for i in range(n_sticky)]
    rows = list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(
        delayed(level_loop)(k, i, cons) for k, i in jobs), total=len(jobs),
        desc="level loops"))
    df = pd.DataFrame(rows)
    det, fa = summarise(df)
    tot = overall(df)
    a.out.mkdir(parents=True, exist_ok=True)
    figure(df, a.out / "level_loops.png",
           title="Published detectors on randomised simulated level loops")
    n_st, n_h = int((df["label"] == "stiction").sum()), int((df["label"] != "stiction").sum())
    lines = [
        "# Published detectors on randomised simulated level loops\n",
        f"Generated by `experiments/level_loops.py` (`make real`): {len(df)} simulated "
        f"level loops ({n_st} with a sticky valve, {n_h} healthy; {DURATION:g} s sampled "
        f"every {SAMPLE_TIME:g} s, as a window of the refinery's loops), "
        "an integrating process under a SIMC-tuned PI, randomised as the script's "
        "docstring lists. Loop type `L`, MV withheld, every detector with its paper's "
        "defaults; nothing was tuned on these loops. `consensus` is the shipped verdict of "
        "`batch` (`conf/consensus/default.yaml`), trained on the shared real loops, whose "
        "level loops do not oscillate: every number here is out of sample. Rates with "
        "Wilson 95 % intervals; the balanced accuracy counts an inconclusive answer as "
        "wrong.\n",
        "![detection against the stick band](level_loops.png)\n",
        "## Overall\n", to_markdown(tot), "",
        "## Sticky valves: stiction named, by stick band\n", to_markdown(det), "",
        "## Healthy loops: stiction named (false alarms), by cause\n", to_markdown(fa), "",
        "## What the consensus's verdicts rest on\n",
        f"Of the {len(df)} loops the consensus gave a verdict on "
        f"{int(df['consensus'].isin(['stiction', 'no_stiction']).sum())}; how many of its "
        f"methods ({', '.join(cons.methods)}) decided there, and which decided alone:\n",
        to_markdown(deciders(df, cons)), "",
        "The flow-loop counterpart is [flow_loops.md](flow_loops.md); the paper's "
        "self-regulating loops are in [simulated.md](simulated.md).",
    ]
    write_text(a.out / "level_loops.md", "\n".join(lines) + "\n")
    write_text(a.out / "level_loops.csv", df.round(6).to_csv(index=False,
                                                            lineterminator="\n"))
    print(tot.to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
