"""Regulatory limit cycles: does the closed-loop cycle check tell a sticky valve from an
external oscillation, and where does it apply? Vary what it depends on.

``stictionbench diagnose`` names a significant valve hypothesis over the other significant
ones when the identified valve, closed with the loop's PI, reproduces the recorded
oscillation by itself (:mod:`stictionbench.diagnosis.cycle`). That check was added after
the ISDB loops (``reports/diagnose/isdb/``) showed limit cycles named an oscillatory
disturbance or a travel limit; its tolerances were fixed a priori. This experiment tests
it on loops nobody tuned it on, in the regime of those loops: **regulatory** (a constant
set point, no SP column, as in the ISDB) closed loops of the three generator families of
``experiments/concealed.py`` (``sim_physical``: Choudhury's physical valve;
``sim_he``: He's model with a quantising historian; ``lsim_choudhury``: an independent
loop with Choudhury's flowchart model, AR(1) noise, random-walk and step loads), five
classes:

- ``stiction`` (S 1–8 %, J 0.3–0.9 S) and ``deadband`` (1–8 %), the sticky valves;
- ``none`` (a linear valve under a drifting load), ``tight`` (the same loop with the PI
  1.5–2.2× too aggressive, a poorly damped loop that rings) and
  ``oscillatory_disturbance`` (a line of 2–50 closed-loop time constants), which a
  sticky-valve verdict would get wrong.

Plants as in the benchmark (K 0.5–3, τ 2–40 s, θ 1–12 s, SIMC PI), noise 0.5–5 % and
load 2–30 % of the PV response to 4 % of OP, 2700 s at 1 s after a 300 s warm-up.
What the check depends on is varied: the controller's rate — at the historian's 1 s
(the PI is then identifiable from the recording) or at the family's own faster rate
(0.2 s, 0.5 s: it is not, and the check should not apply) — and whether the model
(plant and PI) is given. Each recording is diagnosed once; the ablation (the same
evidence re-decided without the cycle rule, :func:`~stictionbench.diagnosis.evidence.
select`) is the earlier behaviour. Rates carry Wilson 95 % intervals.

A second part asks the same of the benchmark's own regime, where the first version of the
rule failed: the four generator families of ``experiments/fresh_recordings.py`` (the three
of the benchmark and the holdout family: set-point steps, a drifting load, the model and
its PI given) at seeds neither the benchmark (0–3) nor ``disturbance_band.py`` (4–15)
draws (:data:`FRESH_SEEDS`), for oscillatory disturbances, sticky valves and ``none``:
how many verdicts the rule changes, and to what. The check's waveform criterion was
added after ``disturbance_band.py`` showed the period-and-amplitude check "reproduce"
7 of its 96 disturbances; these seeds were never looked at before it was added.

Run: ``.venv/bin/python experiments/limit_cycles.py [--seeds 8] [--jobs 2]``; writes
``reports/diagnose/limit_cycles.md``, ``.csv`` and ``.png``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.patches import Rectangle

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import concealed_families as cf  # noqa: E402
import fresh_recordings as fresh  # noqa: E402
from concealed import decide, decision_row  # noqa: E402

from stictionbench.diagnosis import NominalModel, diagnose  # noqa: E402
from stictionbench.diagnosis.cycle import (  # noqa: E402
    AMPLITUDE_TOLERANCE,
    BAND,
    PERIOD_TOLERANCE,
)
from stictionbench.diagnosis.diagnose import Diagnosis, cycle_evidence  # noqa: E402
from stictionbench.diagnosis.evidence import (  # noqa: E402
    ALPHA,
    MIN_IMPROVEMENT,
)
from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.figures import new_figure, save_png  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "diagnose"
CLASSES = ("stiction", "deadband", "none", "tight", "oscillatory_disturbance")
STICKY = ("stiction", "deadband")
#: seconds simulated before the record starts (the loops start from rest)
WARM_UP = 300
#: seeds of the benchmark families' part (never drawn by the benchmark or disturbance_band)
FRESH_SEEDS = range(16, 28)
FRESH_CLASSES = ("oscillatory_disturbance", "stiction", "deadband", "none")
#: controller conditions: the PI at the historian's rate, or at the family's own
RATES = ("historian", "family")
MODES = ("model-free", "model given")


def draw(family: str, cls: str, seed: int) -> cf.Case:
    """A regulatory loop of ``family`` hiding ``cls`` (see the module docstring)."""
    rng = np.random.default_rng([97, cf.FAMILIES.index(family), CLASSES.index(cls), seed])
    K, tau, theta = rng.uniform(0.5, 3.0), rng.uniform(2.0, 40.0), rng.uniform(1.0, 12.0)
    lam = theta * rng.uniform(0.8, 2.0)
    kc, ti = tau / (K * (lam + theta)), min(tau, 4 * (lam + theta))
    u = 4.0 * K  # PV scale: the response to 4 % of OP
    noise_frac = rng.uniform(0.005, 0.05)
    load = u * rng.uniform(0.02, 0.3)
    effect = rng.uniform(0.0, 1.0)
    c = cf.Case(family, "none", 1, seed, K, tau, theta, kc, ti, lam + theta, [],
                noise_frac * u, noise_frac, load, effect)
    if cls == "tight":
        c.kc, c.ti = kc * rng.uniform(1.5, 2.2), ti * rng.uniform(0.7, 1.0)
    elif cls == "stiction":
        S = 1.0 + 7.0 * effect
        c.cls, c.truth = cls, {"S": S, "J": S * rng.uniform(0.3, 0.9)}
    elif cls == "deadband":
        c.cls, c.truth = cls, {"deadband": 1.0 + 7.0 * effect}
    elif cls == "oscillatory_disturbance":
        c.cls = cls
        c.truth = {"period": float(c.lam_cl * math.exp(rng.uniform(math.log(2), math.log(50)))),
                   "amplitude": float(u * (0.1 + 0.9 * effect))}
    return c


def simulate(c: cf.Case, rate: str) -> dict[str, np.ndarray]:
    """The loop's t, SP, PV, OP at 1 s after the warm-up. ``lsim_choudhury`` steps its
    whole loop every 0.5 s in either condition (its PI is never at the historian rate)."""
    if c.family == "lsim_choudhury":
        sig = cf._lsim_loop(c, np.random.default_rng([c.seed, CLASSES.index(c.cls), 3]))
    else:
        sig = cf._simulate_family(c, controller_s=1.0 if rate == "historian" else None)
    sig = {k: np.asarray(v[WARM_UP:], float) for k, v in sig.items() if k != "MV"}
    sig["t"] = sig["t"] - sig["t"][0]
    return sig


def _evidence(d: Diagnosis) -> dict:
    """The shipped verdict, its ablation without the cycle rule, the cycle check, and the
    check and verdict with phase-drift-robust amplitudes (``amplitude="band"``: the
    variation behind the explanation of the check's low sensitivity)."""
    cyc = d.tests.get("closed_loop_cycle", {})
    ham = d.details.get("hammerstein")
    band = cycle_evidence(d.rec, d.model, ham, d.details["highpass_hz"], amplitude="band") \
        if ham else None
    lr = cyc.get("log_ratios", {})
    # re-decided from the stored evidence as diagnose decided (the dead time's rule, the
    # scaled NRMSE gate, the second look and the range hypotheses' full-data test kept
    # in every variant: concealed.decide), the cycle rule varied
    row = decision_row(d)

    def decided(cycle: bool = False) -> str:
        return decide(pd.Series({**row, "cycle_reproduced": cycle}), ALPHA, MIN_IMPROVEMENT)

    return {"shipped": d.missing_physics,
            "ablation": decided(),
            "band": decided(bool(band is not None and band.reproduced)),
            "cycle_applicable": bool(cyc.get("applicable", False)),
            "cycle_reproduced": bool(cyc.get("reproduced", False)),
            "band_reproduced": bool(band is not None and band.reproduced),
            "cycle_reason": cyc.get("reason", "no valve identification"),
            **{f"{k}_ratio": lr.get(k, np.nan) for k in
               ("period", "pv_amplitude", "op_amplitude", "pv_harmonic_ratio")}}


def one(family: str, cls: str, seed: int, rate: str, mode: str) -> dict:
    """Simulate one loop and diagnose it (``mode``: with or without its model)."""
    c = draw(family, cls, seed)
    sig = simulate(c, rate)
    rec = Recording.from_arrays(sig["t"], sig["PV"], sig["OP"], warn=False)
    model = None if mode == "model-free" else NominalModel(c.K, c.tau, c.theta, c.kc, c.ti, 1.0)
    return {"family": family, "class": cls, "seed": seed, "rate": rate, "mode": mode,
            "effect": c.effect, "tau": c.tau, "lam_cl": c.lam_cl,
            "period_true": c.truth.get("period", np.nan), **_evidence(diagnose(rec, model))}


def one_fresh(family: str, cls: str, level: int, seed: int) -> dict:
    """A benchmark-family recording (set-point steps, model given) at a fresh seed."""
    c, model, rec = fresh.recording(family, cls, level, seed)
    return {"family": family, "class": cls, "level": level, "seed": seed,
            **_evidence(diagnose(rec, model))}


def _hits(s: pd.DataFrame, col: str, cls: str) -> int:
    """Stiction named on the stiction loops; a sticky valve (stiction or dead band) on
    every other class."""
    return int((s[col] == "stiction").sum()) if cls == "stiction" else \
        int(s[col].isin(STICKY).sum())


def summary(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (rate, mode), g in df.groupby(["rate", "mode"], sort=False):
        for cls in CLASSES:
            s = g[g["class"] == cls]
            row = {"controller": rate, "mode": mode, "class": cls,
                   "measure": "stiction named" if cls == "stiction" else
                   "sticky valve named"}
            for col in ("shipped", "ablation", "band"):
                row[col] = rate_text(_hits(s, col, cls), len(s))
            row["check applied"] = rate_text(int(s["cycle_applicable"].sum()), len(s))
            row["check reproduced"] = rate_text(int(s["cycle_reproduced"].sum()), len(s))
            row["band: reproduced"] = rate_text(int(s["band_reproduced"].sum()), len(s))
            row["verdicts changed"] = int((s["shipped"] != s["ablation"]).sum())
            rows.append(row)
    return pd.DataFrame(rows)


def figure(df: pd.DataFrame, path: Path) -> None:
    fig, axes = new_figure(1, 2, figsize=(11, 4.4))
    colours = {"stiction": "C3", "deadband": "C1", "none": "C0", "tight": "C2",
               "oscillatory_disturbance": "C4"}
    lp, la = math.log(PERIOD_TOLERANCE), math.log(AMPLITUDE_TOLERANCE)
    for ax, mode in zip(axes, MODES, strict=True):
        g = df[(df["mode"] == mode) & np.isfinite(df["period_ratio"])]
        for cls, colour in colours.items():
            s = g[g["class"] == cls]
            amp = np.maximum.reduce([np.abs(s[k]) for k in (
                "pv_amplitude_ratio", "op_amplitude_ratio", "pv_harmonic_ratio_ratio")])
            ax.scatter(s["period_ratio"], amp, s=18, color=colour, label=cls, alpha=0.8)
        ax.add_patch(Rectangle((-lp, 0), 2 * lp, la, fill=False, ls="--", color="k", lw=1))
        ax.set_xlabel("ln(simulated / recorded period)")
        ax.set_ylabel("largest |ln(simulated / recorded)|: PV, OP amplitude, waveform")
        ax.set_title(f"{mode}: loops the check could simulate", fontsize=9)
        ax.set_xlim(-2, 2)
        ax.set_ylim(0, 5)
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle("Closed-loop cycle check on regulatory loops: inside the dashed box the "
                 "fitted valve reproduces the recorded oscillation (tolerances fixed a "
                 "priori)", fontsize=9)
    save_png(fig, path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    # lsim_choudhury has one controller rate only: it is not repeated
    todo = [(f, c, s, r, m) for r in RATES for f in cf.FAMILIES for c in CLASSES
            for s in range(a.seeds) for m in MODES
            if not (r == "family" and f == "lsim_choudhury")]
    df = fresh.run(one, todo, a.jobs)
    tab = summary(df)
    bench = fresh.run(one_fresh, [(f, c, lvl, s) for f in fresh.FAMILIES for c in FRESH_CLASSES
                                  for lvl in (1, 2) for s in FRESH_SEEDS], a.jobs)
    OUT.mkdir(parents=True, exist_ok=True)
    with atomic_path(OUT / "limit_cycles.csv") as p:
        df.round(6).to_csv(p, index=False, lineterminator="\n")
    with atomic_path(OUT / "limit_cycles_benchmark_families.csv") as p:
        bench.to_csv(p, index=False, lineterminator="\n")
    figure(df, OUT / "limit_cycles.png")
    write_text(OUT / "limit_cycles.md", "\n".join(_report(df, tab) + _report_fresh(bench)))
    print(to_markdown(tab))
    return 0


def _report(df: pd.DataFrame, tab: pd.DataFrame) -> list[str]:
    doc = __doc__.split("\n\n")
    hist = df[df["rate"] == "historian"]
    fast = df[df["rate"] == "family"]
    bad = df[df["class"].isin(("none", "tight", "oscillatory_disturbance"))]
    gained = df[(df["shipped"] != df["ablation"])]
    classes = [line.strip() if line.strip().startswith("- ") else "  " + line.strip()
               for line in doc[2].splitlines()]
    lines = ["# Regulatory limit cycles: the closed-loop cycle check", "",
             "Generated by `experiments/limit_cycles.py`. " + " ".join(doc[1].split()), "",
             *classes, "", " ".join(doc[3].split()), "", "![check](limit_cycles.png)", "",
             "## Findings", "",
             f"- verdicts the cycle rule changed: {len(gained)} of {len(df)} diagnoses"
             + (": " + "; ".join(f"{r.family} {r['class']} seed {r.seed} ({r.rate} PI, "
                                 f"{r['mode']}): {r.ablation} → {r.shipped}"
                                 for _, r in gained.iterrows()) if len(gained) else "") + ";",
             "- non-sticky loops (none, tight, oscillatory disturbance) named a sticky valve: "
             f"shipped {rate_text(int(bad['shipped'].isin(STICKY).sum()), len(bad))}, "
             f"ablation {rate_text(int(bad['ablation'].isin(STICKY).sum()), len(bad))};",
             "- the check applied (a regular recorded oscillation, a PI, a valve): PI at the "
             f"historian rate {rate_text(int(hist['cycle_applicable'].sum()), len(hist))}, "
             f"at the family's faster rate "
             f"{rate_text(int(fast['cycle_applicable'].sum()), len(fast))};",
             "- reproduced, by class (all conditions): " + ", ".join(
                 f"{c} {rate_text(int(g['cycle_reproduced'].sum()), len(g))}"
                 for c, g in ((c, df[df['class'] == c]) for c in CLASSES)) + ";",
             "- the check's low sensitivity here, varied: the shipped check measures each "
             "amplitude by the least-squares sinusoid at the period, which reads a cycle "
             "whose phase drifts over the record (a stick-slip driven by a drifting load) "
             "smaller than its periodic simulation; with amplitudes from the power in a "
             f"±{int(100 * BAND)} % band around each harmonic instead (column *band*), "
             "reproduced by class: " + ", ".join(
                 f"{c} {rate_text(int(g['band_reproduced'].sum()), len(g))}"
                 for c, g in ((c, df[df['class'] == c]) for c in CLASSES))
             + "; non-sticky loops named a sticky valve with it "
             f"{rate_text(int(bad['band'].isin(STICKY).sum()), len(bad))}.", "",
             "## Per class, controller rate and mode", "", to_markdown(tab), ""]
    return lines


def _report_fresh(bench: pd.DataFrame) -> list[str]:
    changed = bench[bench["shipped"] != bench["ablation"]]
    rows = []
    for cls in FRESH_CLASSES:
        g = bench[bench["class"] == cls]
        rows.append({"class": cls, "recordings": len(g),
                     "shipped: named correctly": rate_text(int((g["shipped"] == cls).sum()),
                                                           len(g)),
                     "ablation: named correctly": rate_text(int((g["ablation"] == cls).sum()),
                                                            len(g)),
                     "check applied": rate_text(int(g["cycle_applicable"].sum()), len(g)),
                     "check reproduced": rate_text(int(g["cycle_reproduced"].sum()), len(g)),
                     "verdicts changed": int((g["shipped"] != g["ablation"]).sum()),
                     "band: named correctly": rate_text(int((g["band"] == cls).sum()), len(g)),
                     "band: reproduced": rate_text(int(g["band_reproduced"].sum()), len(g))})
    doc = " ".join(__doc__.split("\n\n")[4].split())
    return ["## The benchmark families at fresh seeds (set-point steps, model given)", "",
            doc, "",
            f"- verdicts the cycle rule changed: {len(changed)} of {len(bench)}"
            + (": " + "; ".join(f"{r.family} L{r.level} {r['class']} seed {r.seed}: "
                                f"{r.ablation} → {r.shipped}" for _, r in changed.iterrows())
               if len(changed) else "") + ".", "", to_markdown(pd.DataFrame(rows)), ""]


if __name__ == "__main__":
    sys.exit(main())
