"""When the PI's period is given: does choosing the historian's convention by the nominal's
cost lose against knowing it?

With ``controller.sample_time`` in the model, ``diagnose`` replays the PI's mean output
between samples and lets the nominal's training cost choose among the recorded OP and the
two conventions of when the historian reads OP (``"after"`` or ``"before"`` the PI
executes at the sample; :mod:`stictionbench.diagnosis.intersample`). Searching the period
the same way failed because, with noise and load, that cost did not find the true period
(``reports/concealed/unknown_pi_period*.md``); on generator D's healthy loops, whose
historian reads OP after the PI executes, the convention chosen was "before" on 22 of 36
(``intersample_op.md``, part B). Here every recording of ``intersample_op``'s parts A and B
whose simulator's convention is known — the package's own loops (part A, noise and load,
the PI every 0.25 s: OP read before the PI executes) and generators A and D (every healthy,
stiction and dead-band recording with a PI faster than 1 s: OP read after) — is diagnosed
with its period given three ways: the convention *chosen* (shipped), and each convention
*forced* (the reconstruction always replayed, the recorded OP not a candidate).

**Prediction and criterion, written before the run.** A model key for the convention
(``controller.historian``) is worth adding only if forcing the true convention names right
at least 5 % more of the recordings than the choice does on each of the three sources,
with McNemar p < 0.05 pooled. Predicted: it does not; the forced true convention and the
choice differ by less than 3 % of the recordings on each source, and the forced wrong one
names fewer right than either.

Run: ``.venv/bin/python experiments/intersample_convention.py [--jobs 2]``; writes
``reports/concealed/intersample_convention.md`` and ``.csv``. Needs ``.cache/blindgen``.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import fast_pi_healthy as fph  # noqa: E402
import intersample_op as iop  # noqa: E402
from fast_loops import run_loops  # noqa: E402
from fresh_recordings import comparison_patched, publish  # noqa: E402

from stictionbench.diagnosis import NominalModel, diagnose, load_model  # noqa: E402
from stictionbench.diagnosis.intersample import effective_op  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.rates import mcnemar_p, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
#: the convention each source's simulator uses (read from its code)
TRUE_CONVENTION = {"package": "before", "generator A": "after", "generator D": "after"}
MODES = ("chosen", "after", "before")

_D = importlib.import_module("stictionbench.diagnosis.diagnose")
_SHIPPED = _D._compare_intersample


def _forced(convention: str):
    def compare_forced(rec, model, kw):
        m = _D.compare(rec, model, **kw).model
        op = effective_op(np.asarray(rec.SP, float), np.asarray(rec.PV, float),
                          np.asarray(rec.OP, float), rec.Ts, m.kc, m.ti,
                          m.controller_period, convention)
        return _D.compare(replace(rec, OP=op), model, **kw), {
            "controller_period_s": float(m.controller_period), "op": convention}
    return compare_forced


def _three(rec, model) -> dict:
    out = {}
    for mode in MODES:
        with comparison_patched(_SHIPPED if mode == "chosen" else _forced(mode)):
            res = diagnose(rec, model)
        out[mode] = res.missing_physics
        if mode == "chosen":
            out["picked"] = (res.details.get("intersample") or {}).get("op")
    return out


def job_package(tau: float, seed: int, valve: str) -> dict:
    rec = fph.loop(tau, 0.25, seed, fph.NOISE, fph.LOAD,
                   valve=("valve=linear",) if valve == "ideal" else iop.KANO)
    kc, ti = fph.simc(tau)
    model = NominalModel(fph.GAIN, tau, fph.DEAD_TIME, kc, ti, 1.0, controller_period=0.25)
    return {"source": "package", "name": f"tau{tau:g}_seed{seed}",
            "class": "none" if valve == "ideal" else "stiction", **_three(rec, model)}


def job_generator(gen: str, s: str, name: str, cls: str, level: int, period: float) -> dict:
    d = iop.DATA / f"set_{s}"
    rec = read_recording(str(d / f"{name}.csv"), warn=False)
    model = replace(load_model(d / f"{name}.model.yaml"), controller_period=period)
    return {"source": f"generator {gen}", "name": name, "class": cls, "level": level,
            **_three(rec, model)}


def _right(df: pd.DataFrame, col: str) -> pd.Series:
    named = df[col]
    sticky = df["class"].isin(iop.STICKY)
    # the package's Kano valves count as right when a sticky valve is named (as in
    # intersample_op's part A)
    return (named == df["class"]) | (sticky & (df["source"] == "package")
                                     & named.isin(iop.STICKY))


def summary(df: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    rows, worth, pooled = [], [], {"gained": 0, "lost": 0}
    for source, g in df.groupby("source", sort=True):
        true = TRUE_CONVENTION[source]
        wrong = "before" if true == "after" else "after"
        ok = {m: _right(g, m) for m in MODES}
        gained = int((ok[true] & ~ok["chosen"]).sum())
        lost = int((ok["chosen"] & ~ok[true]).sum())
        pooled["gained"] += gained
        pooled["lost"] += lost
        rows.append({"source": source, "n": len(g), "true convention": true,
                     "right, chosen": rate_text(int(ok["chosen"].sum()), len(g)),
                     "right, true forced": rate_text(int(ok[true].sum()), len(g)),
                     "right, wrong forced": rate_text(int(ok[wrong].sum()), len(g)),
                     "true over chosen: gained / lost":
                         f"{gained} / {lost} (p = {mcnemar_p(gained, lost):.2g})",
                     "chosen": ", ".join(f"{k} ×{v}" for k, v in
                                         g["picked"].fillna("none").value_counts().items())})
        worth.append((source, int(ok[true].sum()) - int(ok["chosen"].sum()), len(g),
                      int(ok[wrong].sum()), int(ok["chosen"].sum())))
    p = mcnemar_p(pooled["gained"], pooled["lost"])
    adopted = all(d >= 0.05 * n for _, d, n, _, _ in worth) and p < 0.05
    lines = [f"- criterion: the true convention forced names right at least 5 % more than the "
             f"choice on every source ({', '.join(f'{s}: {d:+d} of {n}' for s, d, n, *_ in worth)}"
             f"), pooled McNemar p < 0.05 (p = {p:.2g}): **{'held' if adopted else 'failed'}**",
             f"- predicted: true forced and chosen within 3 % on every source: "
             f"**{'held' if all(abs(d) < 0.03 * n for _, d, n, *_ in worth) else 'failed'}**",
             f"- predicted: the wrong convention forced names fewer right than both: "
             f"**{'held' if all(w < c and w < c + d for _, d, _, w, c in worth) else 'failed'}**",
             "", "**A convention key is worth adding.**" if adopted else
             "**No convention key**: the choice by the nominal's cost stays."]
    return pd.DataFrame(rows), lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if a.jobs < 1:
        print("intersample_convention.py: --jobs must be ≥ 1", file=sys.stderr)
        return 2
    jobs_b = [j for j in iop.jobs_b() if j[0] in ("A", "D")]
    rows = run_loops(job_package, [(tau, s, v) for tau in iop.TAUS for s in iop.SEEDS
                                   for v in ("ideal", "kano")], a.jobs, "package loops")
    rows += run_loops(job_generator, jobs_b, a.jobs, "generators A and D")
    df = pd.DataFrame(rows).sort_values(["source", "class", "name"], kind="stable")
    df = df.reset_index(drop=True)
    tab, lines = summary(df)
    text = "\n".join([
        "# The historian's convention: chosen by the nominal's cost, or known", "",
        "Generated by `experiments/intersample_convention.py` (the recordings, the "
        "prediction and the criterion, written before the run, are in its docstring). "
        "Every recording diagnosed with its PI's period given: the convention *chosen* "
        "among the recorded OP and the two reconstructions (shipped), and each convention "
        "*forced*. The package's Kano valves count as right when a sticky valve is named. "
        "Wilson 95 % intervals; McNemar's exact test on the recordings whose correctness "
        "changed.", "", to_markdown(tab), "", "## The prediction and the criterion", "",
        *lines, ""])
    publish(df, text, OUT / "intersample_convention")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
