"""Collect the run rows of a sweep into ``results.csv``/``.parquet``, a summary and figures.

One row per run of the plan, in grid order: the knobs, the ground truth (``true_S``,
``true_J``, ``label_stiction``), every estimator's outputs in columns prefixed with its
name (``xcorr_value``, ``xcorr_decision``, ``xcorr_error``, ``xcorr_time_s``, ...) and
the wall time. Every file is written atomically.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from ..io import atomic_directory, atomic_path, write_text
from ..rates import auc_interval, decided, roc_curve, wilson
from ..reports.tables import write_table
from .plan import KNOBS, Plan
from .runner import variants

HEAD = ["run_id", "status", "error"]
TRUTH = ["J", "valve_Fs", "valve_Fc", "true_S", "true_J", "label_stiction"]
TAIL = ["sim_time_s", "wall_time_s", "worker"]


def prefixes(plan: Plan) -> list[str]:
    """Column prefixes of the estimator variants, in the order the runs apply them."""
    if not plan.runs:
        return []
    try:
        return [v[0] for v in variants(plan.runs[0].spec["estimators"])]
    except Exception:
        return []


def collect(plan: Plan) -> pd.DataFrame:
    """The rows of the plan's finished runs, in grid order, columns in a fixed order."""
    rows = []
    for run in plan.runs:
        try:
            rows.append(json.loads(plan.result_path(run.id).read_text(encoding="utf-8")))
        except FileNotFoundError:
            continue
    df = pd.DataFrame(rows)
    if df.empty:
        return pd.DataFrame(columns=HEAD)
    cols = [c for c in HEAD + list(KNOBS) + TRUTH if c in df.columns]
    pre = prefixes(plan)
    for p in pre:
        own = [c for c in df.columns if c.startswith(p + "_") and c not in cols
               and not any(c.startswith(q + "_") and len(q) > len(p) for q in pre)]
        first = [f"{p}_{k}" for k in ("value", "decision", "error", "time_s")]
        cols += [c for c in first if c in own] + [c for c in own if c not in first]
    tail = [c for c in TAIL if c in df.columns]
    cols += [c for c in df.columns if c not in cols and c not in tail] + tail
    return df[cols]


def _typed_frame(df: pd.DataFrame) -> pd.DataFrame:
    """Columns Parquet can store: bool / float / string for object columns."""
    out = df.copy()
    for c in out.columns:
        if out[c].dtype != object:
            continue
        vals = out[c].dropna()
        if vals.empty:
            out[c] = out[c].astype("string")
        elif all(isinstance(v, (bool, np.bool_)) for v in vals):
            out[c] = out[c].astype("boolean")
        elif all(isinstance(v, (int, float, np.number)) and not isinstance(v, bool)
                 for v in vals):
            out[c] = pd.to_numeric(out[c], errors="coerce").astype(float)
        else:
            out[c] = out[c].map(lambda v: None if v is None or v is pd.NA else str(v),
                                na_action="ignore").astype("string")
    return out


def write_results(df: pd.DataFrame, out_dir: Path) -> tuple[Path, Path]:
    csv, parquet = out_dir / "results.csv", out_dir / "results.parquet"
    write_text(csv, df.to_csv(index=False, lineterminator="\n"))
    with atomic_path(parquet) as tmp:
        _typed_frame(df).to_parquet(tmp, index=False)
    return csv, parquet


def summary_table(df: pd.DataFrame, prefixes: list[str]) -> pd.DataFrame:
    """Per estimator variant: detection rate on stiction runs, false alarms, AUC."""
    ok = df[df["status"] == "ok"] if "status" in df else df
    if ok.empty or "label_stiction" not in ok:
        return pd.DataFrame(columns=["estimator"])
    label = ok["label_stiction"].map(lambda v: v is True or v == 1).to_numpy(dtype=bool)
    valves = sorted(ok["valve"].dropna().unique()) if "valve" in ok else []
    rows = []
    for p in prefixes:
        if f"{p}_decision" not in ok:
            continue
        dec = decided(ok[f"{p}_decision"])
        err = ok[f"{p}_error"].notna().to_numpy() if f"{p}_error" in ok else np.zeros(len(ok), bool)
        vals = pd.to_numeric(ok[f"{p}_value"], errors="coerce").to_numpy(dtype=float)
        auc, auc_lo, auc_hi = auc_interval(vals, label)
        _, _, auc_valid = roc_curve(vals[~err], label[~err])
        det_lo, det_hi = wilson(int(dec[label].sum()), int(label.sum()))
        fa_lo, fa_hi = wilson(int(dec[~label].sum()), int((~label).sum()))
        row = {
            "estimator": p,
            "runs": len(ok),
            "errors": int(err.sum()),
            "detection_rate": float(dec[label].mean()) if label.any() else float("nan"),
            "detection_low": det_lo,
            "detection_high": det_hi,
            "false_alarm_rate": float(dec[~label].mean()) if (~label).any() else float("nan"),
            "false_alarm_low": fa_lo,
            "false_alarm_high": fa_hi,
            "accuracy": float((dec == label).mean()),
            "auc": auc,
            "auc_low": auc_lo,
            "auc_high": auc_hi,
            "auc_no_errors": auc_valid,
        }
        for v in valves:
            m = label & (ok["valve"] == v).to_numpy()
            row[f"detection_{v}"] = float(dec[m].mean()) if m.any() else float("nan")
        row["median_ms"] = (float(pd.to_numeric(ok[f"{p}_time_s"], errors="coerce").median()
                                  * 1e3) if f"{p}_time_s" in ok else float("nan"))
        rows.append(row)
    return pd.DataFrame(rows)


def aggregate(plan: Plan, *, figures: bool = True) -> pd.DataFrame:
    """Write ``results.csv``, ``results.parquet``, ``summary.md``/``.csv`` and figures.

    Nothing is written when no run of the plan has finished (e.g. ``runs/`` is absent).
    """
    df = collect(plan)
    if df.empty:  # nothing finished: leave earlier results alone
        return df
    with atomic_directory(plan.out_dir) as out:  # all files appear together, or none
        _write_aggregate(plan, df, out, figures=figures)
    return df


def _write_aggregate(plan: Plan, df: pd.DataFrame, out: Path, *, figures: bool) -> None:
    write_results(df, out)
    pre = [p for p in prefixes(plan) if f"{p}_decision" in df.columns]
    table = summary_table(df, pre)
    made: list[str] = []
    if figures and len(df) and (df["status"] == "ok").any():
        from .figures import detection_heatmaps, roc_figure

        made.append(detection_heatmaps(df, pre, out / "detection_rate.png").name)
        made.append(roc_figure(df, pre, out / "roc.png").name)
    n_err = int((df["status"] != "ok").sum()) if len(df) else 0
    grid = "\n".join(f"- `{k}`: {', '.join(map(str, v))}" for k, v in plan.grid.items())
    wall = pd.to_numeric(df.get("wall_time_s", pd.Series(dtype=float)), errors="coerce")
    lines = [
        f"{len(df)} of {len(plan.runs)} runs finished ({n_err} error rows). One run = one "
        "simulated loop and every registered estimator; `detection_rate` is the share of "
        "runs with stiction (`label_stiction`: S > 0 and J > 0) where the estimator's "
        "decision is True, `false_alarm_rate` the same share among stiction-free runs, "
        "`auc` the area under the ROC of the estimator's `value` (larger = stiction; "
        "below 0.5 means the value points the other way; an estimator error ranks "
        "lowest, `auc_no_errors` leaves those runs out). `*_low`/`*_high` are 95 % "
        "intervals: Wilson score for rates, percentile bootstrap (1000 resamples, "
        "seed 0) for the AUC.",
        "",
        f"Per-run wall time: median {wall.median() * 1e3:.0f} ms, total "
        f"{wall.sum():.1f} s of worker time." if wall.notna().any() else "",
        "",
        "Grid (`hydra.sweeper.params` of `conf/sweep/" + plan.name + ".yaml` and the "
        "command line):",
        "",
        grid or "- (a single run)",
        "",
        "Columns of `results.csv`: run knobs (`valve, S, J_ratio, kc, ti, noise, dist_amp, "
        "dist_period, load, setpoint, duration, sample_time, seed, sim`), truth (`J, "
        "valve_Fs, valve_Fc, true_S, true_J, label_stiction`), then per estimator "
        "`<prefix>_value, _decision, _error, _time_s` and its scalar diagnostics.",
        "",
        *(f"![{m}]({m})" for m in made),
    ]
    write_table(table, out / "summary", title=f"Sweep `{plan.name}`", note="\n".join(lines))
