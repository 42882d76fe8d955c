"""The set-point gate on short windows: a periodic set point seen by its change times.

The question. The batch benchmark (``benchmarks/test_bench_batch.py``: 40 simulated loops
of the paper's four cases cut into windows of 750–2000 samples) showed the shipped
consensus calling stiction on 33 of 40 healthy windows of the ``linear`` case and 33 of 40
of the ``disturbance`` case (200 windows; He's curve fit and the area ratio said
"triangular"). Those loops follow the paper's square-wave set point (steps every 250 s):
the control error is a train of step responses, which the shape tests read as stiction.
The gate that should hand them back as inconclusive
(:func:`stictionbench.estimators.detector.forced_by_setpoint`) fired on 14 of those 80: it
needs the set point's period, and the ACF test finds none in a window that holds two or
three of its periods (too few for the regularity test), though every change repeats the
one a period before.

The change (:func:`~stictionbench.estimators.detector.setpoint_period`): where the ACF test
finds no oscillation of SP, the period of its change times
(:func:`~stictionbench.estimators.detector.step_period`: the smallest q ≤ 4 for which
every change q later comes the same time after, with the same step, within the gate's
existing tolerance ``HARMONIC_TOL``; at least two spans). Nothing else in the gate
changes (set-point changes per oscillation period, harmonic 1–5 within ``HARMONIC_TOL``).
No new threshold.

Seen before the predictions were written (in-sample, the design set): the benchmark's 200
windows (seeds 0–39, the paper's set point): with the change the gate fires on 66 of the
80 healthy ``linear``/``disturbance`` windows (was 14) and on 7 of 50 ``stiction``-case
windows (their limit cycle then has the set point's third harmonic for period, 160–172 s
against 500 s: entrained by the set point).

Held-out sets (never looked at), windows of 750–2000 samples as ``batch`` reads them,
t, PV, OP and SP only (MV withheld), measurement noise 0.05 and a random-walk load:

1. **periodic set points**: 80 loops, seeds 3000–3079, the paper's four cases, every
   fifth with a Kano valve (S 2–8 %, J 1 %); the set point a square wave whose half period
   is drawn from 120–450 s and whose step from 4–10 % (not the paper's 250 s and 10 %),
   starting at a random time in the first 100 s; three windows per loop (240);
2. **irregular set points**: the same 80 loops' set point moved at random times (gaps
   drawn from 60–500 s) by random steps (±2–10 %); three windows per loop (240);
3. **real loops**: the 14 ISDB loops and the 18 refinery loops of ``make real``
   (``reports/real/comparison_*.csv`` before and after the change).

Every window is judged by every published method and the shipped consensus twice, with
the gate as it was (``step_period`` answering None) and with the change.

Predictions (written before the run), on the held-out windows:

1. periodic set points: healthy windows called stiction by the consensus fall by at least
   half;
2. periodic set points: stiction windows found fall by at most 10 percentage points;
3. periodic set points: balanced accuracy of the consensus up by at least 0.10;
4. irregular set points: every method's verdict identical on all 240 windows (no period
   from irregular changes);
5. real loops: every method's loop verdict identical on all 32 loops (no periodic set
   point in them).

Decision (set before the run): the change stays in the package when 1, 2 and 4 hold and no
real loop's consensus verdict moves away from its label; otherwise it is reverted and this
report says why.

The stored report was made before the step-response gate
(``experiments/setpoint_response_scope.py``); both arms switch that gate off, so a run
again reproduces it.

Run: ``.venv/bin/python experiments/setpoint_period.py [--loops 80] [--jobs 2]``; writes
``reports/real/setpoint_period.{md,csv}``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import stictionbench as sb  # noqa: E402
from stictionbench.estimators import detector  # noqa: E402
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text, wilson  # noqa: E402
from stictionbench.realdata.compare import PUBLISHED, window_calls  # noqa: E402
from stictionbench.realdata.consensus import Consensus  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

CASES = ("linear", "tight", "disturbance", "stiction")
SEED0 = 3000
WINDOWS_PER_LOOP = 3
DURATION = 2200.0


#: the gaps (s) between the moves of an ``irregular`` and an ``occasional`` set point
GAPS = {"irregular": (60.0, 500.0), "occasional": (600.0, 1500.0)}


def setpoint_steps(i: int, kind: str, seed0: int = SEED0) -> list[list[float]]:
    """The set point's ``[time, step]`` list of loop ``i``: a square wave of random half
    period and step (``periodic``) or moves at random times by random steps
    (``irregular``, ``occasional``: gaps drawn from :data:`GAPS`)."""
    rng = np.random.default_rng([seed0 + i, 7])
    t = float(rng.uniform(10.0, 100.0))
    out = []
    if kind == "periodic":
        half = float(rng.uniform(120.0, 450.0))
        size = float(rng.uniform(4.0, 10.0))
        k = 0
        while t < DURATION:
            out.append([t, size if k % 2 == 0 else -size])
            t += half
            k += 1
        return out
    level = 0.0
    while t < DURATION:
        step = float(rng.uniform(2.0, 10.0)) * (1 if rng.random() < 0.5 else -1)
        if abs(level + step) > 15.0:
            step = -step
        level += step
        out.append([t, step])
        t += float(rng.uniform(*GAPS[kind]))
    return out


def make_windows(i: int, kind: str,
                 seed0: int = SEED0) -> list[tuple[str, str, str, sb.Recording]]:
    """Loop ``i``'s windows under a ``kind`` set point: (name, case, label, recording)."""
    case = CASES[i % 4]
    kano = i % 5 == 4
    kw = {"valve": "kano", "valve__S": 2.0 + i % 7, "valve__J": 1.0} if kano else {}
    full = sb.simulate(case, duration=DURATION, seed=seed0 + i, sample_time=1.0,
                       sensor="noisy", disturbance="load", disturbance__load_std=0.5,
                       setpoint__steps=setpoint_steps(i, kind, seed0), **kw)
    label = "stiction" if case == "stiction" or kano else "no_stiction"
    rng = np.random.default_rng([seed0 + i, 11])
    out = []
    for w in range(WINDOWS_PER_LOOP):
        m = int(rng.integers(750, 2001))
        k0 = int(rng.integers(0, len(full) - m + 1))
        pv = full.PV[k0:k0 + m] + 0.05 * rng.standard_normal(m)
        rec = sb.Recording.from_arrays(np.arange(m, dtype=float), pv, full.OP[k0:k0 + m],
                                       SP=full.SP[k0:k0 + m])
        out.append((f"{kind}_{i:02d}_{w}", case + ("+kano" if kano else ""), label, rec))
    return out


def _no_step_period(rec, tol=detector.HARMONIC_TOL):
    return None


def judge_loop(i: int, kind: str) -> list[dict]:
    """Every published method's call and the consensus on loop ``i``'s windows, with the
    gate as it was (``old``) and with the change (``new``)."""
    cons = Consensus.load()
    rows = []
    for name, case, label, rec in make_windows(i, kind):
        row = {"window": name, "kind": kind, "case": case, "label": label,
               "samples": len(rec), "sp_period": detector.step_period(rec)}
        for arm in ("old", "new"):
            keep = detector.step_period, detector.STEP_RESPONSE_GATE
            detector.STEP_RESPONSE_GATE = False
            if arm == "old":
                detector.step_period = _no_step_period
            try:
                calls = window_calls(rec, name, methods=PUBLISHED)
            finally:
                detector.step_period, detector.STEP_RESPONSE_GATE = keep
            for m in PUBLISHED:
                row[f"{arm}_{m}"] = calls[m].verdict
            row[f"{arm}_consensus"] = cons.decide({m: calls[m].verdict
                                                   for m in cons.methods})[0]
        rows.append(row)
    return rows


def rates(df: pd.DataFrame, arm: str) -> dict:
    """Found, false alarms and balanced accuracy of the consensus in ``arm``."""
    sick = df[df.label == "stiction"]
    ok = df[df.label == "no_stiction"]
    k1 = int((sick[f"{arm}_consensus"] == "stiction").sum())
    k0 = int((ok[f"{arm}_consensus"] == "stiction").sum())
    return {"found": k1, "stiction": len(sick), "false_alarms": k0, "healthy": len(ok),
            "balanced_accuracy": 0.5 * (k1 / max(len(sick), 1) + 1 - k0 / max(len(ok), 1))}


def real_changes(before: Path, after: Path | None = None) -> tuple[int, list[str]]:
    """Loops of the comparison tables in ``after`` (default: the stored ones of
    ``make real``) against ``before`` (the tables of the commit before the change): the
    number compared and what moved."""
    moved = []
    n = 0
    after = after or ROOT / "reports" / "real"
    for ds in ("isdb", "plant"):
        new = pd.read_csv(after / f"comparison_{ds}.csv")
        old = pd.read_csv(before / f"comparison_{ds}.csv")
        cols = [c for c in new.columns if c in [*PUBLISHED, "consensus"]]
        merged = old.merge(new, on="loop", suffixes=("_old", "_new"))
        n += len(merged)
        for _, r in merged.iterrows():
            for c in cols:
                if r[f"{c}_old"] != r[f"{c}_new"]:
                    moved.append(f"{ds} {r['loop']} {c}: {r[f'{c}_old']} → {r[f'{c}_new']}"
                                 f" (label {r['label_new']})")
    return n, moved


def per_case_lines(df: pd.DataFrame) -> list[str]:
    """The report's table of windows called stiction by set point, case and arm (each
    published method and the consensus)."""
    per_case = []
    for (kind, case), d in df.groupby(["kind", "case"]):
        for arm in ("old", "new"):
            per_case.append({"set point": kind, "case": case, "gate": arm,
                             "windows": len(d), "label": d.label.iloc[0],
                             "consensus stiction": int((d[f"{arm}_consensus"]
                                                        == "stiction").sum()),
                             **{m: int((d[f"{arm}_{m}"] == "stiction").sum())
                                for m in PUBLISHED}})
    return ["Windows called stiction, by case (each method and the consensus):", "",
            to_markdown(pd.DataFrame(per_case)), ""]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--loops", type=int, default=80)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--before", default=None,
                    help="folder of the comparison_*.csv of the commit before the change")
    ap.add_argument("--out", default=str(ROOT / "reports" / "real"))
    a = ap.parse_args(argv)
    import setpoint_period as me  # workers call the module's function by reference
    from joblib import Parallel, delayed
    from tqdm import tqdm

    jobs = [(i, k) for k in ("periodic", "irregular") for i in range(a.loops)]
    rows = [r for loop in tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(
        delayed(me.judge_loop)(i, k) for i, k in jobs), total=len(jobs), desc="loops")
        for r in loop]
    df = pd.DataFrame(rows)
    lines = ["# The set-point gate on short windows: a periodic set point seen by its "
             "change times", "",
             "Generated by `experiments/setpoint_period.py` (design, predictions and the "
             "decision in its docstring, written before the run). Windows of 750–2000 "
             f"samples of {a.loops} simulated loops (seeds {SEED0}–{SEED0 + a.loops - 1}), "
             "never looked at; the shipped consensus (`conf/consensus/default.yaml`); "
             "`old`: the gate as it was, `new`: with the set point's period from its "
             "change times. Wilson 95 % intervals.", ""]
    table = []
    for kind in ("periodic", "irregular"):
        d = df[df.kind == kind]
        for arm in ("old", "new"):
            r = rates(d, arm)
            table.append({"set point": kind, "gate": arm,
                          "stiction found": rate_text(r["found"], r["stiction"]),
                          "healthy called stiction": rate_text(r["false_alarms"],
                                                               r["healthy"]),
                          "balanced_accuracy": round(r["balanced_accuracy"], 4),
                          "gate period found": int(d.sp_period.notna().sum())})
    tab = pd.DataFrame(table)
    lines += [to_markdown(tab), ""]
    lines += per_case_lines(df)

    per = df[df.kind == "periodic"]
    old, new = rates(per, "old"), rates(per, "new")
    irr = df[df.kind == "irregular"]
    cols = [f"{m}" for m in [*PUBLISHED, "consensus"]]
    irr_moved = int(sum((irr[f"old_{c}"] != irr[f"new_{c}"]).any() for c in cols))
    irr_windows = int((irr[[f"old_{c}" for c in cols]].to_numpy()
                       != irr[[f"new_{c}" for c in cols]].to_numpy()).any(axis=1).sum())
    fa_old = old["false_alarms"] / max(old["healthy"], 1)
    fa_new = new["false_alarms"] / max(new["healthy"], 1)
    tp_old = old["found"] / max(old["stiction"], 1)
    tp_new = new["found"] / max(new["stiction"], 1)
    lo, hi = wilson(new["false_alarms"], new["healthy"])
    checks = [
        ("1", "periodic: healthy called stiction falls by at least half",
         f"{fa_old:.0%} → {fa_new:.0%} [{lo:.0%}, {hi:.0%}]", fa_new <= 0.5 * fa_old),
        ("2", "periodic: stiction found falls by at most 10 points",
         f"{tp_old:.0%} → {tp_new:.0%}", tp_new >= tp_old - 0.10),
        ("3", "periodic: balanced accuracy up by at least 0.10",
         f"{old['balanced_accuracy']:.3f} → {new['balanced_accuracy']:.3f}",
         new["balanced_accuracy"] >= old["balanced_accuracy"] + 0.10),
        ("4", "irregular: every verdict identical",
         f"{irr_windows} of {len(irr)} windows moved ({irr_moved} methods)",
         irr_windows == 0),
    ]
    real_ok = True
    if a.before:
        n, moved = real_changes(Path(a.before))
        away = [m for m in moved if " consensus: " in m
                and not m.split(" → ")[1].startswith(
                    "stiction" if "label stiction" in m else "no_stiction")]
        real_ok = not away
        checks.append(("5", "real loops: every method's loop verdict identical",
                       f"{len(moved)} verdicts moved on {n} loops"
                       + (": " + "; ".join(moved) if moved else ""), not moved))
    pred = pd.DataFrame(checks, columns=["prediction", "what", "measured", "held"])
    decided = bool(pred.held[pred.prediction.isin(["1", "2", "4"])].all()) and real_ok
    lines += ["## Predictions", "", to_markdown(pred), "",
              f"Decision (1, 2 and 4 hold, no real consensus verdict moved away from its "
              f"label): **{'met — the change stays' if decided else 'not met'}**.", ""]
    out = Path(a.out)
    write_text(out / "setpoint_period.md", "\n".join(lines))
    write_text(out / "setpoint_period.csv", df.to_csv(index=False, lineterminator="\n",
                                                      float_format="%.6g"))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
