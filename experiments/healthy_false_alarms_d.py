"""Why generator D's healthy loops are called faulty: each disturbance source removed in turn.

``reports/concealed/independent_set_x.md`` and ``_y.md`` scored the third clean-room
generator (``experiments/blind_generator_d``) once: 16 of its 48 healthy recordings were
called physics (33 %, the goal is 5 %), the false alarms spread over loop speeds, PI rates
and named classes. Reading them one by one did not show a common cause. This experiment
re-runs the generator's own simulation of every healthy recording of sets X and Y (its
scenario drawn from the recording's seed exactly as ``generate.py`` draws it) with one
thing changed at a time, and diagnoses each variant with the recording's own model YAML,
as the command does:

- *recorded*: nothing changed (must reproduce the stored file byte for byte and its
  verdict);
- *no noise*: the measurement noise and its quantisation removed;
- *no load*: the unmeasured load (random walk, its lag and its steps, at the process input
  or output) removed;
- *neither*: both removed (the loop then moves only with its set-point steps);
- *snapshot OP*: the historian's OP the snapshot at the second where the recording stored
  the mean over the second (only the 25 % of loops that store the mean differ).

**Prediction, written before the run.** The recorded variant reproduces 16 of 48 called
physics. Removing the load removes at least half of them (≤ 8 left); removing the noise
removes fewer (≥ 10 left); with neither, at most 6 are left, and those all have a PI
executing faster than the historian's 1 s (the deterministic cause of
``reports/concealed/fast_pi_healthy.md`` part B). Reading the mean OP as a snapshot changes
at most 2 verdicts. Nothing is adopted from this run: it says where to look.

Run: ``.venv/bin/python experiments/healthy_false_alarms_d.py [--jobs 2]``; writes
``reports/concealed/healthy_false_alarms_d.md`` and ``.csv``. It needs
``.cache/blindgen/set_x`` and ``set_y`` (``make independent`` draws them).
"""

from __future__ import annotations

import argparse
import filecmp
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from fast_loops import run_loops  # noqa: E402
from fresh_recordings import generator_module, publish, set_truths  # noqa: E402

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.io import read_recording  # noqa: E402
from stictionbench.rates import mcnemar_p, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
DATA = ROOT / ".cache" / "blindgen"
SETS = ("x", "y")
VARIANTS = ("recorded", "no noise", "no load", "neither", "snapshot OP")


def _vary(sc: dict, variant: str) -> dict:
    sc = dict(sc)
    if variant in ("no noise", "neither"):
        sc["_noise"] = np.zeros_like(sc["_noise"])
        sc["quant_step"] = 0.0
    if variant in ("no load", "neither"):
        sc["_din"] = np.zeros_like(sc["_din"])
        sc["_dout"] = np.zeros_like(sc["_dout"])
    if variant == "snapshot OP":
        sc["hist_op_mode"] = "snapshot"
    return sc


def job(s: str, name: str, seed: int, level: int) -> list[dict]:
    """Every variant of one healthy recording, diagnosed with its model YAML."""
    gen = generator_module("blind_generator_d")
    sc, *_ = gen.make_recording(seed, level, "none")
    src = DATA / f"set_{s}"
    model = load_model(src / f"{name}.model.yaml")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for variant in VARIANTS:
            v = _vary(sc, variant)
            sp, pv, op, *_ = gen.run_scenario(v)
            gen.write_recording(tmp, name, v, sp, pv, op)
            path = Path(tmp) / f"{name}.csv"
            same = filecmp.cmp(path, src / f"{name}.csv", shallow=False)
            res = diagnose(read_recording(str(path), warn=False), model)
            rows.append({"set": s, "name": name, "level": level, "variant": variant,
                         "identical_to_stored": same, "predicted": res.missing_physics,
                         # the verdict without the resolution floor (resolution_floor.py)
                         "predicted_unfloored": res.details.get("resolution_floor", {}).get(
                             "named_before", res.missing_physics),
                         "nominal_nrmse": res.fit["nominal"],
                         "improved_nrmse": res.fit["improved"],
                         "controller_period": sc["Tc"], "hist_op_mode": sc["hist_op_mode"],
                         "kc_K": sc["kc"] * sc["K"], "tau": sc["tau"],
                         "noise_type": sc["noise_type"], "noise_frac": sc["noise_frac"],
                         "load_entry": sc["load_entry"],
                         "n_load_steps": sc.get("n_load_steps", 0)})
    return rows


def healthy_jobs(truths: dict[str, pd.DataFrame]) -> list[tuple]:
    """``(set, name, seed, level)`` of every healthy recording of the sets."""
    return [(s, r["name"], int(r["seed"]), int(r["level"]))
            for s, t in truths.items() for _, r in t[t["class"] == "none"].iterrows()]


def summary(df: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    base = df[df["variant"] == "recorded"].set_index("name")["predicted"] != "none"
    rows = []
    for variant in VARIANTS:
        g = df[df["variant"] == variant].set_index("name")
        called = g["predicted"] != "none"
        gained, lost = int((called & ~base).sum()), int((~called & base).sum())
        fast = g["controller_period"] < 1.0
        rows.append({"variant": variant, "n": len(g),
                     "called physics": rate_text(int(called.sum()), len(g)),
                     "of which PI faster than 1 s": f"{int((called & fast).sum())}",
                     "newly called / no longer called": f"{gained} / {lost} "
                                                         f"(p = {mcnemar_p(gained, lost):.2g})",
                     "named": ", ".join(f"{k} ×{v}" for k, v in
                                        g.loc[called, "predicted"].value_counts().items())})

    def n_called(variant: str) -> int:
        return int((df[df["variant"] == variant]["predicted"] != "none").sum())

    rec = df[df["variant"] == "recorded"]
    neither = df[(df["variant"] == "neither") & (df["predicted"] != "none")]
    snap = df[df["variant"] == "snapshot OP"].set_index("name")["predicted"]
    changed = int((snap != df[df["variant"] == "recorded"].set_index("name")["predicted"]).sum())
    checks = [
        (f"recorded reproduces the stored files ({int(rec['identical_to_stored'].sum())} of "
         f"{len(rec)}) and 16 called physics ({n_called('recorded')})",
         bool(rec["identical_to_stored"].all()) and n_called("recorded") == 16),
        (f"no load: at most 8 called ({n_called('no load')})", n_called("no load") <= 8),
        (f"no noise: at least 10 called ({n_called('no noise')})", n_called("no noise") >= 10),
        (f"neither: at most 6 called, all with the PI faster than 1 s ({len(neither)}, "
         f"{int((neither['controller_period'] < 1.0).sum())} fast)",
         len(neither) <= 6 and bool((neither["controller_period"] < 1.0).all())),
        (f"snapshot OP changes at most 2 verdicts ({changed})", changed <= 2),
    ]
    return pd.DataFrame(rows), [f"- {t}: **{'held' if ok else 'failed'}**" for t, ok in checks]


def reading(df: pd.DataFrame) -> list[str]:
    """Added after the run (no prediction): the variants' false alarms by the PI's period,
    and how large the nominal's error is on the loops called physics with neither noise
    nor load (an exact model, so any error there is the replay's, not the plant's)."""
    fast = df["controller_period"] < 1.0
    called = df["predicted"] != "none"
    by = (df.assign(pi=np.where(fast, "PI faster than 1 s", "PI at 1 s"), called=called)
          .groupby(["variant", "pi"], sort=False)["called"]
          .agg(lambda c: rate_text(int(c.sum()), len(c))).unstack("pi").reset_index())
    clean = df[(df["variant"] == "neither") & called]
    cols = ["name", "predicted", "nominal_nrmse", "improved_nrmse", "controller_period",
            "hist_op_mode", "kc_K", "tau"]
    big = clean[clean["nominal_nrmse"] >= 0.05]
    quiet = df[(df["variant"] == "neither") & ~called]["nominal_nrmse"].median()
    snap = int(((big["controller_period"] < 1.0) & (big["hist_op_mode"] == "snapshot")).sum())
    return ["## Reading (added after the run, no prediction)", "",
            "Called physics by the PI's period:", "", to_markdown(by), "",
            f"With neither noise nor load the model is exact, so the nominal's validation "
            f"NRMSE is the replay's own error. On the {len(clean)} loops still called "
            f"physics its median is {clean['nominal_nrmse'].median():.2g} (the loops "
            f"answered `none`: {quiet:.2g}); {len(big)} have an error of 5 % of PV's "
            f"spread or more, {snap} of them the snapshot of a PI faster than the "
            f"historian:", "",
            to_markdown(clean.sort_values("nominal_nrmse")[cols].round(
                {"controller_period": 3, "kc_K": 3, "tau": 4}).assign(
                **{c: lambda d, c=c: d[c].map(lambda x: f"{x:.2g}")
                   for c in ("nominal_nrmse", "improved_nrmse")})), ""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if a.jobs < 1:
        print("healthy_false_alarms_d.py: --jobs must be ≥ 1", file=sys.stderr)
        return 2
    truths = set_truths(SETS, "healthy_false_alarms_d.py", DATA)
    if truths is None:
        return 2
    jobs = healthy_jobs(truths)
    rows = [r for rs in run_loops(job, jobs, a.jobs, "healthy recordings") for r in rs]
    df = pd.DataFrame(rows)
    df["variant"] = pd.Categorical(df["variant"], VARIANTS, ordered=True)
    df = df.sort_values(["variant", "set", "name"], kind="stable").reset_index(drop=True)
    df["variant"] = df["variant"].astype(str)
    tab, verdicts = summary(df)
    lines = ["# Generator D's healthy loops, each disturbance source removed in turn", "",
             "Generated by `experiments/healthy_false_alarms_d.py` (the variants, the "
             "prediction and its criteria, written before the run, are in its docstring). "
             "The 48 healthy "
             "recordings of sets X and Y re-simulated by the generator's own code, one thing "
             "changed at a time, each diagnosed with its model YAML. Wilson 95 % intervals; "
             "McNemar's exact test against the recorded variant.", "",
             to_markdown(tab), "", "## The prediction", "", *verdicts, "", *reading(df)]
    publish(df, "\n".join(lines), OUT / "healthy_false_alarms_d", float_format="%.6g")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
