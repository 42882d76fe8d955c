"""Score the shipped diagnosis on a labelled concealed set made by someone else's simulator.

The issue's goals are judged on "an independent concealed set made by a different
simulator". Every family of this repository's benchmark (``concealed_families``,
``holdout_family``) was written by the same hands as the diagnosis, so each shares its
author's reading of what a class *is* (what "saturation" or "valve characteristic" means
on a plant, how big a level-2 effect is). This script scores a set written without
sight of the package: ``experiments/blind_generator/generate.py`` (sets A and B) and
``experiments/blind_generator_c/generate.py`` (set C) were each written by a separate
agent that was given the issue's description of the independent set, the paper and the
valve-model notes, and was not allowed to read this repository (the second not the first
generator either); set C was kept sealed until the code it scored was final, and scored
once. ``experiments/blind_generator_d/generate.py`` (sets X and Y, 2026-12-03) was written
the same way by a third agent, and its two sets were scored once, after a prediction was
committed (its README). Their output is scored exactly as a user runs the command (CSV
and model YAML read by the command's own readers, :func:`stictionbench.diagnosis.diagnose`
with the model, the package's defaults). Nothing is tuned here.

Any directory with a ``truth.csv`` (columns ``name``, ``level``, ``class``, ``seed``)
and, per row, ``NAME.csv`` and ``NAME.model.yaml`` can be scored the same way.

Run: ``make independent`` (the three sets), or ``.venv/bin/python
experiments/independent_set.py --data DIR --name NAME [--jobs 2]``; writes
``reports/concealed/NAME.{md,csv}``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from concealed import decision_row, miss_reason  # noqa: E402
from concealed_families import CLASSES  # noqa: E402
from fresh_recordings import run  # noqa: E402

from stictionbench.diagnosis import diagnose, load_model  # noqa: E402
from stictionbench.diagnosis.diagnose import WARNING_KEYS  # noqa: E402
from stictionbench.diagnosis.evidence import BAND_DOF  # noqa: E402
from stictionbench.io import atomic_path, read_recording, write_text  # noqa: E402
from stictionbench.rates import balanced_text, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
#: per class, the truth columns (of ``experiments/blind_generator``'s,
#: ``experiments/blind_generator_c``'s and ``experiments/blind_generator_d``'s
#: ``truth.csv``) that measure the effect's size, the
#: first present is used; a ratio (true over nominal) is read as ``|ln|``; a class whose
#: columns a set lacks is left out of the detectability table
EFFECT = {"stiction": ("S", "stiction_S", "S_eq"), "deadband": ("deadband",),
          "sensor_lag": ("lag_over_tau", "sensor_lag_rel_tcl", "sensor_tau_ratio"),
          "dead_time": ("dead_time_ratio", "dead_time_true_over_model", "theta_factor"),
          "valve_characteristic": ("char_max_dev", "valve_gain_ratio",
                                   "valve_local_gain_ratio"),
          "saturation": ("saturation_fraction_of_time", "sat_frac_at_limit", "sat_fraction"),
          "oscillatory_disturbance": ("disturbance_amplitude_frac", "osc_amp_over_noise")}
RATIOS = ("dead_time_ratio", "dead_time_true_over_model", "valve_gain_ratio", "theta_factor",
          "valve_local_gain_ratio")


def diagnose_one(data: str, name: str, test_highpass_order: int = 2) -> dict:
    """Diagnose ``DATA/NAME.csv`` with ``DATA/NAME.model.yaml`` as the command does (with
    ``--test-highpass-order``, default the command's); the verdict, the warnings and the
    stored evidence :func:`concealed.miss_reason` reads and :func:`concealed.decide`
    re-decides from."""
    t0 = time.perf_counter()
    d = Path(data)
    rec = read_recording(str(d / f"{name}.csv"), warn=False)
    res = diagnose(rec, load_model(d / f"{name}.model.yaml"),
                   test_highpass_order=test_highpass_order)
    row = {"name": name, "predicted": res.missing_physics,
           "band_dof": res.details.get("band_dof"),
           "op_held": bool(res.tests["op_held_at_limit"]["held"]),
           "gain_named": bool(res.tests.get("setpoint_gain", {}).get("named", False)),
           "decided_by": res.details.get("decided_by"),
           "warnings": ";".join(k for k in WARNING_KEYS if res.details.get(k)),
           "seconds": time.perf_counter() - t0}
    # every field concealed.decide re-decides from (the second look's line, the OP held
    # at a limit, the set-point gain test, the line test), so that it reproduces the verdict
    return row | decision_row(res)


def score(truth: pd.DataFrame, found: pd.DataFrame) -> pd.DataFrame:
    """The truth joined to the verdicts, with ``ok`` and, for a missed physics class, why
    (:func:`concealed.miss_reason`)."""
    df = truth.merge(found, on="name", validate="one_to_one")
    df["ok"] = df["predicted"] == df["class"]
    df["miss_reason"] = [miss_reason(r, r["predicted"]) if not r["ok"] and r["class"] != "none"
                         else "" for _, r in df.iterrows()]
    return df


def report(df: pd.DataFrame, data: str, wall: float) -> str:
    """Markdown: per level the score of 16 (classes weighted equally) and the false-alarm
    rate; class by class what was named; the misses' reasons."""
    lines = [f"# Independent concealed set: `{Path(data).name}`", "",
             f"Generated by `experiments/independent_set.py --data {data}`: {len(df)} "
             "recordings, each diagnosed with its model YAML as `stictionbench diagnose` "
             "does, package defaults. The set's generator shares no code and no author "
             "with the package (see the script's docstring). Nothing was tuned on it (the "
             "set-point gain test's tolerance was looked at on sets A–C before it was "
             "fixed: `stictionbench/diagnosis/gain.py`). "
             "Wilson 95 % intervals; the score of 16 weighs classes equally "
             "(`rates.balanced_score`).", ""]
    rows = []
    for lvl, g in df.groupby("level"):
        none = g[g["class"] == "none"]
        phys = g[g["class"] != "none"]
        rows.append({"level": lvl, "recordings": len(g),
                     "of 16 (95 % interval)": balanced_text(g["ok"], g["class"]),
                     "physics classes named": rate_text(int(phys["ok"].sum()), len(phys)),
                     "`none` called physics": rate_text(int((~none["ok"]).sum()), len(none)),
                     "record warnings": rate_text(int((g["warnings"] != "").sum()), len(g))})
    lines += [to_markdown(pd.DataFrame(rows)), ""]
    crow = []
    order = {c: i for i, c in enumerate(CLASSES)}
    for (lvl, cls), g in sorted(df.groupby(["level", "class"]),
                                key=lambda kv: (kv[0][0], order.get(kv[0][1], 99))):
        miss = g.loc[~g["ok"], "predicted"].value_counts()
        crow.append({"level": lvl, "class": cls,
                     "named correctly": rate_text(int(g["ok"].sum()), len(g)),
                     "OP held at a limit": rate_text(int(g["op_held"].sum()), len(g)),
                     "named by the set-point gain test": int(
                         g.get("gain_named", pd.Series(False, index=g.index)).sum()),
                     "misses named": ", ".join(f"{k} ×{v}" for k, v in miss.items()) or "–"})
    lines += ["## Class by class", "", to_markdown(pd.DataFrame(crow)), ""]
    lines += _by_route(df)
    why = df.loc[df["miss_reason"] != ""].groupby(["level", "class"])["miss_reason"] \
        .agg(lambda s: ", ".join(f"{k} ×{v}" for k, v in s.value_counts().items()))
    if len(why):
        lines += ["## Why the physics misses were missed", "",
                  "Read from each recording's stored evidence by `concealed.miss_reason`: "
                  "the gates the true hypothesis failed, or what beat it.", "",
                  to_markdown(why.reset_index()), ""]
    lines += _by_record(df) + _by_effect(df)
    lines += [f"Diagnosis time: median {df['seconds'].median():.2f} s, max "
              f"{df['seconds'].max():.2f} s per recording; wall {wall:.0f} s.", ""]
    return "\n".join(lines)


def _by_route(df: pd.DataFrame) -> list[str]:
    """Per check that set the verdict (``details.decided_by``), the verdicts it gave, how
    many were right, and how many were healthy loops called physics."""
    if "decided_by" not in df:
        return []
    rows = []
    for route, g in df.groupby("decided_by"):
        rows.append({"decided by": route, "verdicts": len(g),
                     "right": rate_text(int(g["ok"].sum()), len(g)),
                     "of them physics named": int((g["predicted"] != "none").sum()),
                     "healthy loops called physics": int(
                         ((g["class"] == "none") & (g["predicted"] != "none")).sum())})
    return ["## By the check that set the verdict", "",
            "`details.decided_by` of each verdict: the likelihood tests' ranking, or the "
            "check that named physics where it did not.", "",
            to_markdown(pd.DataFrame(rows)), ""]


def _by_record(df: pd.DataFrame) -> list[str]:
    """Score of 16 and false alarms on records long enough for their loop (``band_dof`` of
    at least :data:`BAND_DOF`, where ``diagnose`` does not warn) and on short ones."""
    rows = []
    for lvl, g in df.groupby("level"):
        for what, part in (("long enough (no warning)", g[g["band_dof"] >= BAND_DOF]),
                           ("short for the loop (warned)", g[g["band_dof"] < BAND_DOF])):
            if part.empty:
                continue
            none = part[part["class"] == "none"]
            rows.append({"level": lvl, "record": what, "recordings": len(part),
                         "of 16": balanced_text(part["ok"], part["class"]),
                         "`none` called physics":
                             rate_text(int((~none["ok"]).sum()), len(none))})
    return ["## Against the record's length for its loop", "",
            f"`band_dof`: the independent validation samples the comparison band holds; "
            f"below {BAND_DOF} `diagnose` warns that the record is short for the loop.", "",
            to_markdown(pd.DataFrame(rows)), ""]


def _by_effect(df: pd.DataFrame) -> list[str]:
    """Detectability: each physics class named against its effect size (the lower and
    upper half of what the set drew at each level)."""
    rows = []
    for (lvl, cls), g in df[df["class"] != "none"].groupby(["level", "class"]):
        col = next((c for c in EFFECT.get(cls, ()) if c in g and g[c].notna().any()), None)
        if col is None:
            continue
        x = g[col].astype(float)
        if col in RATIOS:
            x = np.abs(np.log(x))
        cut = float(x.median())
        for what, part in (("smaller half", g[x <= cut]), ("larger half", g[x > cut])):
            xs = x[part.index]
            rows.append({"level": lvl, "class": cls,
                         "effect": col + (" (|ln|)" if col in RATIOS else ""),
                         "half": what, "range": f"{xs.min():.3g}–{xs.max():.3g}",
                         "named": rate_text(int(part["ok"].sum()), len(part))})
    if not rows:
        return []
    return ["## Against the effect's size", "",
            "Each class's recordings split at the median of the effect the set drew (its "
            "generator's truth column).", "", to_markdown(pd.DataFrame(rows)), ""]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="directory with truth.csv and recordings")
    ap.add_argument("--name", required=True, help="report name under reports/concealed/")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    truth_path = Path(args.data) / "truth.csv"
    if not truth_path.is_file():
        print(f"independent_set: {truth_path}: no such file", file=sys.stderr)
        return 2
    truth = pd.read_csv(truth_path)
    t0 = time.perf_counter()
    found = run(diagnose_one, [(args.data, n) for n in truth["name"]], args.jobs)
    df = score(truth, found)
    wall = time.perf_counter() - t0
    OUT.mkdir(parents=True, exist_ok=True)
    with atomic_path(OUT / f"{args.name}.csv") as tmp:
        df.drop(columns=["seconds"]).to_csv(tmp, index=False)
    write_text(OUT / f"{args.name}.md", report(df, args.data, wall))
    print(report(df, args.data, wall))
    return 0


if __name__ == "__main__":
    sys.exit(main())
