"""``stictionbench batch DIR [--labels labels.csv] --json OUT.json [--report DIR]``:
a verdict for every recording in a folder, scored by physical loop against labels."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..errors import InputError, user_warning


def run_batch(directory: str, labels: str | None, *, jobs: int = 2,
              diagnose: str = "none", consensus: str | None = None,
              op_range: tuple[float, float] | None = None
              ) -> tuple[list[dict], list, dict]:
    """Judge every recording of ``directory``; returns entries, skipped files, scores.

    Scores (with labels) are by physical loop: the balanced accuracy of the shipped
    consensus (in-sample for a folder it was trained on: see its ``trained_on``), of a
    consensus refitted leaving each loop out, and of one fitted on this folder
    (in-sample, optimistic).
    """
    from joblib import Parallel, delayed
    from tqdm import tqdm

    from ..op_range import check_op_range
    from .compare import balanced_accuracy, loop_verdicts
    from .consensus import Consensus, fit, lolo
    from .datasets import load_csv_dir, with_meta
    from .panel import METHODS, PUBLISHED
    from .verdict import judge

    d = Path(directory)
    if not d.is_dir():
        raise InputError(f"{d}: not a directory")
    recs, skipped = load_csv_dir(d, labels=labels if labels else None, warn=False)
    if op_range is not None:  # OP's 0 and 100 % given for every recording of the folder
        for n, rec in recs.items():
            check_op_range(rec.OP, op_range, f"--op-range, {n}")
        recs = {n: with_meta(r, {"op_range": op_range}) for n, r in recs.items()}
    # recordings in formats batch does not read are named, not passed over in silence
    skipped += [(f.name, "batch reads CSV files; convert it, or screen it with `screen`")
                for f in sorted(d.iterdir())
                if f.is_file() and f.suffix.lower() in (".parquet", ".mat")]
    if not recs:
        name, reason = skipped[0] if skipped else ("", "")
        why = "" if not skipped else f"; {reason}" if name in reason else \
            f"; {name}: {reason}"
        more = f" (and {len(skipped) - 1} more file(s) skipped)" if len(skipped) > 1 else ""
        raise InputError(f"{d}: no usable recordings (CSV files with t, PV, OP){why}{more}")
    rule = Consensus.load(consensus)
    names = list(recs)
    results = Parallel(n_jobs=jobs, return_as="generator_unordered")(
        delayed(judge)(recs[n], n, rule, diagnose=diagnose) for n in names)
    # the bar moves when a recording is finished, not when it is dispatched
    done = {e["name"]: e for e in tqdm(results, total=len(names), desc="batch",
                                       unit="rec", disable=None)}
    entries = [done[n] for n in names]
    for e in entries:
        meta = recs[e["name"]].meta
        e["group"] = str(meta.get("group", e["name"]))
        e["label"] = meta.get("label")
    scores: dict[str, Any] = {"rule": rule.to_dict()}
    if labels or any(e["label"] is not None for e in entries):
        windows = [{"name": e["name"], "group": e["group"], "label": e["label"],
                    "loop_type": "", **e["methods"],
                    "verdict": {"verdict": e["verdict"], "reason": e.get("reason", "")}}
                   for e in entries]
        # batch runs the consensus methods and the fast ones (compare runs them all)
        ran = [m for m in METHODS if all(m in w for w in windows)]
        # the consensus's votes per loop say how close its majority is (a loop of 23
        # windows decided by 12 against 11 is a knife edge, not a finding)
        loops = loop_verdicts(windows, [*ran, "verdict"], counts=["verdict"])
        usable = loops[loops["verdict"] != "unusable"]
        gv = loops.rename(columns={"loop": "group", "verdict_stiction_windows":
                                   "stiction_windows", "verdict_decided_windows":
                                   "decided_windows"})[
            ["group", "windows", "label", "verdict", "stiction_windows", "decided_windows"]]
        candidates = tuple(m for m in PUBLISHED if m in ran)
        left_out = lolo(usable, candidates)
        tuned = fit(usable, candidates)
        conf = pd.crosstab(gv["label"], gv["verdict"]).reindex(
            index=["stiction", "no_stiction"],
            columns=["stiction", "no_stiction", "inconclusive", "unusable"], fill_value=0)
        scores.update(
            balanced_accuracy_by_group=balanced_accuracy(usable["label"], usable["verdict"]),
            confusion=conf.to_dict(orient="index"), groups=gv.to_dict(orient="records"),
            balanced_accuracy_logo=balanced_accuracy(usable["label"],
                                                     left_out.reindex(usable.index)),
            logo=[{"group": g, "label": lab, "verdict": v} for g, lab, v in zip(
                usable["loop"], usable["label"], left_out.reindex(usable.index),
                strict=True)],
            tuned_rule=tuned.to_dict(),
            balanced_accuracy_tuned_in_sample=balanced_accuracy(usable["label"],
                                                                tuned.apply(usable)),
            methods=loops.drop(columns=["verdict", "verdict_stiction_windows",
                                          "verdict_decided_windows"]).to_dict(orient="records"),
            unusable_groups=list(loops["loop"][loops["verdict"] == "unusable"]))
    return entries, skipped, scores


def cmd_batch(args: argparse.Namespace) -> int:
    from ..io import atomic_directory, write_text
    from ..op_range import given_range
    from ..validation import check_writable, jsonable, refuse_overwrite

    if not args.json:
        raise InputError("batch needs --json OUT.json")
    if args.labels and not Path(args.labels).is_file():
        raise InputError(f"{args.labels}: no such labels file")
    refuse_overwrite([args.json, args.report], [args.directory, args.labels, args.consensus])
    check_writable([args.json], [args.report])
    op_range = None if args.op_range is None else given_range(*args.op_range, "--op-range")
    entries, skipped, scores = run_batch(args.directory, args.labels, jobs=args.jobs,
                                         diagnose=args.diagnose, consensus=args.consensus,
                                         op_range=op_range)
    payload = {"directory": str(args.directory), "op_range": op_range, "recordings": entries,
               "skipped": [{"file": f, "reason": r} for f, r in skipped], "scores": scores}
    if args.report:
        with atomic_directory(args.report) as stage:  # all report files, or none
            write_report(entries, skipped, scores, stage, args.directory)
    write_text(args.json, json.dumps(jsonable(payload), indent=2) + "\n")
    counts = pd.Series([e["verdict"] for e in entries]).value_counts().to_dict()
    print(f"{args.directory}: {len(entries)} recordings "
          + ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
          + (f"; skipped {len(skipped)} ({', '.join(f for f, _ in skipped)})" if skipped else ""))
    if "balanced_accuracy_by_group" in scores:
        if np.isnan(scores["balanced_accuracy_by_group"]):
            user_warning(f"{args.directory}: the labelled loops are of one class only, so "
                         "no balanced accuracy is computed (it needs sticky valves and "
                         "others)")
        else:
            print(f"balanced accuracy by loop: {scores['balanced_accuracy_by_group']:.3f} "
                  f"(leave-one-group-out {scores['balanced_accuracy_logo']:.3f}); "
                  f"unusable loops: {', '.join(scores['unusable_groups']) or 'none'}")
    return 0


def write_report(entries, skipped, scores, out_dir, directory) -> None:
    """Tables and small-multiple figures of a batch into ``out_dir``."""
    from ..io import write_text
    from ..reports.figures import new_figure, save_png
    from ..reports.tables import to_markdown, write_table
    from .datasets import load_csv_dir

    out = Path(out_dir)
    cols = ["name", "group", "label", "verdict", "consensus", "confidence", "missing_physics",
            "op_pv_phase_deg", "ellipse_axis_ratio", "ellipse_residual", "apparent_stiction",
            "oscillation_period_s", "oscillation_regularity", "ngi", "nli", "fitted_S",
            "fitted_J", "xcorr_delay_est_mv", "xcum_delay_est_mv", "reason", "notes"]
    df = pd.DataFrame(entries)
    for c in cols:
        if c not in df.columns:
            df[c] = None
    df["notes"] = df["notes"].map(lambda n: "; ".join(n) if isinstance(n, list) else "")
    methods = sorted({m for e in entries for m in e.get("methods", {})})
    calls = pd.DataFrame([{"name": e["name"], **{m: e.get("methods", {}).get(m, {}).get(
        "verdict") for m in methods}} for e in entries])
    write_table(calls, out / "methods", title=f"Each detector's verdict per recording: "
                f"{directory}", note="Reasons and values are in the batch JSON (`methods`).")
    write_table(df[cols], out / "entries", title=f"Verdicts: {directory}",
                note="verdict: the consensus of the published detectors "
                     "(stictionbench/realdata/verdict.py `judge`); missing_physics and "
                     "fitted S/J from the model-free diagnosis; *_delay_est_mv: the "
                     "paper's CO→MV delay estimators applied with MV estimated from "
                     "the fitted stiction model (samples).", digits=3)
    lines = [f"# Batch verdicts: `{directory}`", "",
             f"{len(entries)} recordings; skipped: "
             + (", ".join(f"`{f}` ({r})" for f, r in skipped) or "none") + ".", "",
             f"Verdict: the consensus {scores['rule']} of the published detectors "
             "(`conf/consensus/default.yaml`; each detector's verdict in "
             "[methods.md](methods.md)).", ""]
    if "groups" in scores:
        gv = pd.DataFrame(scores["groups"])
        lg = pd.DataFrame(scores["logo"])
        write_table(gv, out / "groups", title="Verdicts by physical loop (majority of "
                    "usable windows)")
        write_table(lg, out / "logo", title="Leave-one-group-out verdicts (consensus "
                    "refitted without the held-out loop)")
        conf = pd.DataFrame(scores["confusion"]).T
        write_table(conf.reset_index().rename(columns={"index": "label"}), out / "confusion",
                    title="Confusion by physical loop (rows: label, columns: verdict)")
        lines += [f"- balanced accuracy by loop (shipped consensus; in-sample when this "
                  f"folder was among its training sets): "
                  f"**{scores['balanced_accuracy_by_group']:.3f}**",
                  f"- leave-one-group-out balanced accuracy: "
                  f"**{scores['balanced_accuracy_logo']:.3f}**",
                  f"- consensus fitted on all loops here: {scores['tuned_rule']} → balanced "
                  f"accuracy {scores['balanced_accuracy_tuned_in_sample']:.3f} (optimistic)",
                  "- unusable loops (not scored): "
                  + (", ".join(scores["unusable_groups"]) or "none"),
                  "", "## Confusion by loop", "", to_markdown(conf.reset_index().rename(
                      columns={"index": "label"})), ""]
    lines += paper_method_lines(entries)
    lines += ["![time series](timeseries.png)", "![phase plots](phase.png)", ""]
    write_text(out / "summary.md", "\n".join(lines))
    recs, _ = load_csv_dir(directory, labels=False, warn=False)
    names = [e["name"] for e in entries]
    n = len(names)
    ncol = min(6, n)
    nrow = int(math.ceil(n / ncol))
    verdict = {e["name"]: e["verdict"] for e in entries}
    label = {e["name"]: e.get("label") for e in entries}
    colour = {"stiction": "tab:red", "no_stiction": "tab:green", "unusable": "tab:gray"}
    for kind in ("timeseries", "phase"):
        fig, axs = new_figure(nrow, ncol, figsize=(3.0 * ncol, 2.2 * nrow), squeeze=False)
        for ax in axs.flat[n:]:
            ax.axis("off")
        for ax, name in zip(axs.flat, names, strict=False):
            r = recs[name]
            if kind == "timeseries":
                ax.plot(r.t, r.PV - np.mean(r.PV), lw=0.5, label="PV")
                ax.plot(r.t, r.OP - np.mean(r.OP), lw=0.5, label="OP")
            else:
                ax.plot(r.OP, r.PV, lw=0.4)
            ax.set_title(f"{name[:22]}\n{verdict[name]} (label {label[name]})", fontsize=6,
                         color=colour.get(verdict[name], "k"))
            ax.tick_params(labelsize=5)
        save_png(fig, out / f"{kind}.png", dpi=80)


def paper_method_lines(entries) -> list[str]:
    """How the seed paper's CO→MV delay rule fares when MV is estimated from the fitted
    stiction model (plants do not record MV): share of windows with delay > 0.5 samples,
    by label."""
    from .compare import binary

    df = pd.DataFrame(entries)
    if "xcum_delay_est_mv" not in df.columns:
        return []
    df["lab"] = [binary(x) for x in df.get("label", [None] * len(df))]
    out = ["## The paper's method with an estimated MV", "",
           "MV is not recorded; it is estimated with the stiction model fitted by the "
           "model-free diagnosis, then `xcorr`/`xcum` (max_delay 30) estimate the CO→MV "
           "delay; the paper's rule calls stiction when the delay is positive "
           "(> 0.5 samples).", "", "| label | windows | xcorr > 0.5 | xcum > 0.5 |",
           "|---|---|---|---|"]
    for lab in ("stiction", "no_stiction"):
        g = df[(df.lab == lab) & df.xcum_delay_est_mv.notna()]
        if len(g):
            xc = (pd.to_numeric(g.xcorr_delay_est_mv, errors="coerce") > 0.5).mean()
            xq = (pd.to_numeric(g.xcum_delay_est_mv, errors="coerce") > 0.5).mean()
            out.append(f"| {lab} | {len(g)} | {xc:.0%} | {xq:.0%} |")
    out += ["", "A valve model fitted to the data makes its own MV lag OP by construction, so "
            "the delay mostly reflects the fitted stick band, not an independent "
            "measurement.", ""]
    return out
