"""The PI's outputs between samples reconstructed: does it remove the fast-PI false alarms?

``reports/concealed/fast_pi_healthy.md`` (part B) found healthy tight loops called sticky
24 of 24 with neither noise nor load when the PI executed four times per historian sample,
and 1 of 24 with it at 1 s: the zero-order hold of the recorded OP is not the input a
faster PI gave the process. ``diagnose(..., intersample=True)`` replays instead the PI's
mean output over each sample, reconstructed from its own law between the recorded samples
(:mod:`stictionbench.diagnosis.intersample`), the historian's convention (OP read after or
before the PI executes at the sample) and the recorded OP itself chosen by the nominal
model's training fit. It needs the PI's period, the model's new ``controller.sample_time``.
Seen while writing it (the package's loops, τ = 4 and 16 s, seeds 100–105, not scored
here): with noise and load, called physics 9 → 5 of 12 under the PI at 0.25 s, the
convention the simulator uses ("before") picked on 11 of 12.

Part A, the package's simulator (``fast_pi_healthy``'s loops: K = 2, θ = 1 s, SIMC τc = θ,
noise 0.1, load 1, four set-point steps): τ = 4, 8, 16 and 32 s, the PI every 0.25 s and
1 s, an ideal valve (healthy) and a Kano valve S = 2 %, J = 1 %, seeds 200–211 (fresh).
Part B, the independent sets of the three generators written by others (A–I and X, Y),
every healthy, stiction and dead-band recording whose PI executes faster than 1 s (its
period read from the set's ``truth.csv``, as a user who knows it would write it in the
model), each diagnosed with its model YAML and that period, with and without the
reconstruction. Wilson 95 % intervals; McNemar's exact test on the recordings whose
correctness changed.

**Prediction and criterion, written before the run.** Part A: with the PI at 0.25 s the
healthy loops called physics fall by at least a third (pooled over τ), and the Kano valves
named stiction or a dead band lose at most 2 of 48; at 1 s nothing changes (the
reconstruction does not apply). Part B: healthy recordings called physics do not rise,
and stiction and dead bands named right fall by at most 3 % of those recordings.
``intersample`` becomes the default for models that give ``controller.sample_time`` only
if every part holds; otherwise it stays an option.

Part C, added after that run (it held, and the reconstruction became the default): the
healthy loops of part A under the PI at 0.25 s with neither noise nor load, a check of the
explanation first written for what remains (that the reconstruction cannot know the fresh
PV noise the PI answered between samples). If that were all, these loops would no longer be
called physics. No prediction; the criterion above does not read it.

Run: ``.venv/bin/python experiments/intersample_op.py [--jobs 2]``; writes
``reports/concealed/intersample_op.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import fast_pi_healthy as fph  # noqa: E402
from fast_loops import run_loops  # noqa: E402
from fresh_recordings import publish  # noqa: E402

from stictionbench.diagnosis import NominalModel, diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.rates import mcnemar_p, rate_text  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
DATA = ROOT / ".cache" / "blindgen"
SETS = {"A": "abdfh", "C": "cegi", "D": "xy"}
TAUS = (4.0, 8.0, 16.0, 32.0)
PERIODS = (0.25, 1.0)
SEEDS = range(200, 212)
STICKY = ("stiction", "deadband")


#: the Kano valve of part A's sticky loops
KANO = ("valve=kano", "valve.S=2.0", "valve.J=1.0")


def _both(rec: Recording, model: NominalModel) -> dict:
    off = diagnose(rec, model, intersample=False)
    on = diagnose(rec, model, intersample=True)
    inter = on.details.get("intersample") or {}
    return {"off": off.missing_physics, "on": on.missing_physics, "op": inter.get("op")}


def job_a(tau: float, period: float, seed: int, valve: str, quiet: bool = False) -> dict:
    """Part A's loop (part C's with ``quiet``: no noise and no load)."""
    rec = fph.loop(tau, period, seed, *((0.0, 0.0) if quiet else (fph.NOISE, fph.LOAD)),
                   valve=("valve=linear",) if valve == "ideal" else KANO)
    kc, ti = fph.simc(tau)
    model = NominalModel(fph.GAIN, tau, fph.DEAD_TIME, kc, ti, 1.0, controller_period=period)
    return {"part": "C" if quiet else "A", "tau_s": tau, "pi_period_s": period,
            "seed": seed, "class": "none" if valve == "ideal" else "stiction",
            **_both(rec, model)}


def job_b(gen: str, s: str, name: str, cls: str, level: int, period: float) -> dict:
    d = DATA / f"set_{s}"
    rec = read_recording(str(d / f"{name}.csv"), warn=False)
    model = replace(load_model(d / f"{name}.model.yaml"), controller_period=period)
    return {"part": "B", "generator": gen, "set": s, "name": name, "class": cls,
            "level": level, "pi_period_s": period, **_both(rec, model)}


def _period(t: pd.Series) -> pd.Series:
    for col in ("controller_period", "ctrl_period"):
        if col in t and pd.notna(t[col]):
            return float(t[col])
    return float("nan")


def jobs_b() -> list[tuple]:
    out = []
    for gen, sets in SETS.items():
        for s in sets:
            truth = pd.read_csv(DATA / f"set_{s}" / "truth.csv")
            for _, t in truth.iterrows():
                period = _period(t)
                if t["class"] in ("none", *STICKY) and period < 1.0:
                    out.append((gen, s, t["name"], t["class"], int(t["level"]), period))
    return out


def _right(df: pd.DataFrame, col: str) -> pd.Series:
    sticky = df["class"].isin(STICKY)
    named = df[col]
    return (df["class"] == named) | (sticky & (df["part"] == "A") & named.isin(STICKY))


def summary(df: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    rows, verdicts = [], []
    for keys, g in df.groupby(["part", "grp", "class"], sort=True):
        ok_off, ok_on = _right(g, "off"), _right(g, "on")
        gained, lost = int((ok_on & ~ok_off).sum()), int((ok_off & ~ok_on).sum())
        rows.append({"part": keys[0], "loops": keys[1], "class": keys[2], "n": len(g),
                     "right without": rate_text(int(ok_off.sum()), len(g)),
                     "right with": rate_text(int(ok_on.sum()), len(g)),
                     "right only with / only without":
                         f"{gained} / {lost} (p = {mcnemar_p(gained, lost):.2g})",
                     "reconstruction kept": ", ".join(
                         f"{k} ×{v}" for k, v in g["op"].fillna("none").value_counts().items())})
    a = df[df["part"] == "A"]
    fast = a[a["pi_period_s"] == 0.25]
    h = fast[fast["class"] == "none"]
    fa_off, fa_on = int((h["off"] != "none").sum()), int((h["on"] != "none").sum())
    st = fast[fast["class"] == "stiction"]
    st_off, st_on = int(st["off"].isin(STICKY).sum()), int(st["on"].isin(STICKY).sum())
    slow = a[a["pi_period_s"] == 1.0]
    same_slow = bool((slow["off"] == slow["on"]).all())
    b = df[df["part"] == "B"]
    hb = b[b["class"] == "none"]
    fb_off, fb_on = int((hb["off"] != "none").sum()), int((hb["on"] != "none").sum())
    sb = b[b["class"].isin(STICKY)]
    rb_off, rb_on = int((sb["off"] == sb["class"]).sum()), int((sb["on"] == sb["class"]).sum())
    checks = [
        (f"A: healthy loops called physics, PI 0.25 s, fall by a third ({fa_off} → {fa_on})",
         fa_on <= fa_off * 2 / 3),
        (f"A: Kano valves named sticky, PI 0.25 s, lose at most 2 ({st_off} → {st_on})",
         st_on >= st_off - 2),
        (f"A: PI at 1 s unchanged ({'yes' if same_slow else 'no'})", same_slow),
        (f"B: healthy called physics do not rise ({fb_off} → {fb_on} of {len(hb)})",
         fb_on <= fb_off),
        (f"B: stiction and dead bands named right fall by at most 3 % ({rb_off} → {rb_on} "
         f"of {len(sb)})", rb_on >= rb_off - 0.03 * len(sb)),
    ]
    verdicts = [f"- {text}: **{'held' if ok else 'failed'}**" for text, ok in checks]
    adopted = all(ok for _, ok in checks)
    verdicts += ["", "**Adopted as the default for models that give `controller.sample_time`.**"
                 if adopted else "**Not adopted**: it stays `diagnose(..., intersample=True)` "
                                 "/ `--intersample`."]
    return pd.DataFrame(rows), verdicts


def part_c(df: pd.DataFrame) -> list[str]:
    """Part C's lines: the noise-free loops' false alarms without and with the
    reconstruction, beside part A's noisy ones at the same τ and PI period."""
    c = df[df["part"] == "C"]
    if c.empty:
        return []
    a = df[(df["part"] == "A") & (df["class"] == "none") & (df["pi_period_s"] == 0.25)]

    def called(g: pd.DataFrame, col: str) -> str:
        return rate_text(int((g[col] != "none").sum()), len(g))

    return ["## Part C: neither noise nor load (added after the run)", "",
            f"- Healthy loops called physics, PI 0.25 s, noise and load as in part A: "
            f"{called(a, 'off')} without, {called(a, 'on')} with the reconstruction.",
            f"- The same loops with neither: {called(c, 'off')} without, "
            f"{called(c, 'on')} with (per τ in the table above).", ""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if a.jobs < 1:
        print("intersample_op.py: --jobs must be ≥ 1", file=sys.stderr)
        return 2
    ja = [(tau, p, s, v) for tau in TAUS for p in PERIODS for s in SEEDS
          for v in ("ideal", "kano")]
    rows = run_loops(job_a, ja, a.jobs, "part A")
    rows += run_loops(job_b, jobs_b(), a.jobs, "part B")
    jc = [(tau, 0.25, s, "ideal", True) for tau in TAUS for s in SEEDS]
    rows += run_loops(job_a, jc, a.jobs, "part C")
    df = pd.DataFrame(rows)
    df["grp"] = df.apply(lambda r: (f"τ {r['tau_s']:g} s, PI {r['pi_period_s']:g} s"
                                    if r["part"] in "AC" else f"generator {r['generator']}"),
                         axis=1)
    df = df.sort_values(["part", "grp", "class", "seed", "name"], kind="stable",
                        na_position="last").reset_index(drop=True)
    tab, verdicts = summary(df)
    lines = [
        "# The PI's outputs between samples reconstructed",
        "",
        "Generated by `experiments/intersample_op.py` (the change, the recordings, the "
        "prediction and the criterion, written before the run, are in its docstring). "
        "*without*: `diagnose` as shipped, with the model's PI period given (so it warns); "
        "*with*: `diagnose(..., intersample=True)`. Part A counts a Kano valve named right "
        "when a sticky valve (stiction or dead band) is named. Wilson 95 % intervals; "
        "McNemar's exact test on the recordings whose correctness changed.",
        "",
        to_markdown(tab),
        "",
        "## The prediction and the criterion",
        "",
        *verdicts,
        "",
        *part_c(df),
    ]
    publish(df, "\n".join(lines), OUT / "intersample_op", float_format="%.6g", echo=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
