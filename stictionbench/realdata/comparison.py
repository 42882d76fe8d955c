"""``stictionbench compare DIR [DIR ...] --out DIR [--consensus OUT.yaml]``: the published
stiction detectors compared loop by loop on labelled folders (Jelali & Huang 2010,
ch. 13), the combined verdict trained on each folder and scored on the others.

Writes ``comparison.md`` (method × loop tables, per-method rates with Wilson
intervals, the cross-dataset table), ``comparison_<dataset>.csv``, ``methods.csv``,
``cross_dataset.csv`` and ``comparison.png`` into ``--out`` (atomically), and with
``--consensus`` the consensus trained on all folders (the shipped default).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..errors import InputError, user_warning

#: Damarla et al. (2026) on the ISDB loops that are also in ../shared/data/isdb: their
#: published false alarms (every stiction loop of their test set was found)
DAMARLA_FALSE_ALARMS = ("PAP4", "PAP9")
COLOURS = {"stiction": "#d62728", "no_stiction": "#2ca02c", "inconclusive": "#dddddd",
           "unusable": "#777777"}


def load_folder(directory: str | Path) -> dict[str, Any]:
    """The recordings of one labelled folder (``labels.csv`` inside), checked before any
    work is done on any folder."""
    from .datasets import load_csv_dir, read_labels

    d = Path(directory)
    labels = d / "labels.csv"
    if not d.is_dir():
        raise InputError(f"{d}: no such directory")
    if not labels.is_file():
        raise InputError(f"{d}: no labels.csv (compare needs labelled loops)")
    recs, skipped = load_csv_dir(d, labels=str(labels), warn=False)
    if not recs:
        raise InputError(f"{d}: no recordings")
    table = read_labels(labels)
    from .compare import binary

    classes = {binary(r.meta.get("label")) for r in recs.values()} - {None}
    if classes != {"stiction", "no_stiction"}:
        raise InputError(f"{d}: compare needs labelled loops of both classes (a sticky "
                         f"valve and not); the labels here give "
                         f"{' and '.join(sorted(classes)) or 'no recording a label'} only")
    lost = [(f, why) for f, why in skipped if Path(f).stem in table.index]
    if lost:  # a labelled loop left out changes every rate: say which and why
        user_warning(f"{d}: {len(lost)} labelled loop(s) left out of the comparison: "
                     + "; ".join(f"{f} ({why})" for f, why in lost[:3])
                     + (" …" if len(lost) > 3 else ""))
    return recs


def run_folder(directory: str | Path, jobs: int = 2, recs: dict[str, Any] | None = None,
               ) -> tuple[list[dict[str, Any]], pd.DataFrame]:
    """Window calls and loop verdicts of one labelled folder (``labels.csv`` inside;
    ``recs``: its recordings, when :func:`load_folder` has read them)."""
    from joblib import Parallel, delayed
    from tqdm import tqdm

    from .compare import loop_verdicts
    from .panel import METHODS, window_calls

    d = Path(directory)
    recs = load_folder(d) if recs is None else recs
    names = list(recs)
    gen = Parallel(n_jobs=jobs, return_as="generator_unordered")(
        delayed(window_calls)(recs[n], n) for n in names)
    done = {w["name"]: w for w in tqdm(gen, total=len(names), desc=d.name, unit="rec",
                                                disable=None)}
    windows = [done[n] for n in names]
    return windows, loop_verdicts(windows, METHODS)


def figure(sets: dict[str, pd.DataFrame], methods: list[str], path: Path) -> Path:
    """Method × loop verdict map, one panel per dataset, the label as the first row."""
    from matplotlib.patches import Patch

    from ..reports.figures import new_figure, save_png

    codes = {v: i for i, v in enumerate(COLOURS)}
    fig, axs = new_figure(len(sets), 1, figsize=(12, 2.2 + 2.6 * len(sets)), squeeze=False,
                          constrained_layout=True)
    from matplotlib.colors import ListedColormap

    cmap = ListedColormap(list(COLOURS.values()))
    for ax, (name, loops) in zip(axs[:, 0], sets.items(), strict=True):
        rows = ["label", *methods, "consensus"]
        grid = np.array([[codes.get(str(v), 2) for v in loops[r]] for r in rows])
        ax.imshow(grid, cmap=cmap, vmin=0, vmax=len(COLOURS) - 1, aspect="auto")
        ax.set_yticks(range(len(rows)), rows)
        ax.set_xticks(range(len(loops)), [_short_tag(str(s)) for s in loops["loop"]],
                      rotation=60, ha="right", fontsize=6)
        ax.set_title(f"{name}: verdict per physical loop")
        ax.grid(False)
    axs[0, 0].legend(handles=[Patch(color=c, label=v) for v, c in COLOURS.items()],
                     loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)
    return save_png(fig, path)


def report_md(sets, rates, cross, default, methods) -> str:
    """``comparison.md``."""
    from ..reports.tables import to_markdown

    lines = ["# Published stiction detectors, loop by loop", "",
             "Generated by `make real` (`stictionbench compare`). One verdict per physical "
             "loop (majority of its usable windows; a tie is inconclusive). Every method "
             "uses its paper's rule and published thresholds (see "
             "`stictionbench/realdata/panel.py`); `ellipse_v1` is this project's first "
             "rule, whose thresholds were chosen on these loops: its numbers are "
             "**in-sample** and it takes no part in the consensus.", "",
             "![verdicts](comparison.png)", ""]
    for name, loops in sets.items():
        cols = ["loop", "label", "loop_type", "windows", *methods, "consensus"]
        lines += [f"## {name}: method × loop", "", to_markdown(loops[cols]), "",
                  f"Per method on {name} (Wilson 95 % intervals; balanced accuracy counts "
                  "an inconclusive verdict as 'not flagged'):", "",
                  to_markdown(rates[name].drop(columns=["correct_lo", "correct_hi"])), ""]
    if "isdb" in sets:
        lines += _damarla(sets["isdb"], methods)
    lines += ["## The combined verdict, out of sample", "",
              "A vote of the published methods; which methods vote, the share of "
              "stiction votes needed and the number of deciding methods needed are fitted "
              "on one dataset (`stictionbench/realdata/consensus.py`) and scored on the "
              "other, by the one-standard-error rule: of the settings within one standard "
              "error of the best training score, the one nearest the untrained majority of "
              "all published methods ([consensus_one_se.md](consensus_one_se.md) compares "
              "it with the best-score fit). Rows with `out_of_sample = False` are "
              "in-sample.", "",
              to_markdown(cross), "",
              f"Shipped default (trained on all datasets here, used by `batch`): "
              f"`{default.to_dict()}`.", ""]
    return "\n".join(lines + _unreached_lines(sets)) + "\n"


def _unreached_lines(sets: dict[str, pd.DataFrame]) -> list[str]:
    """The stiction loops no published method flags, and the bound they set on any vote
    (:func:`.compare.unreached`)."""
    from ..reports.tables import to_markdown
    from .compare import unreached
    from .panel import PUBLISHED

    lines = ["## What no vote of these methods can reach", "",
             "A combined verdict can flag only a loop that at least one published method "
             "flags. The labelled stiction loops that none flags, with every method's "
             "reason, and the highest balanced accuracy by loop that any vote of the "
             "published methods could reach (all the others found, no false alarm):", ""]
    for name, loops in sets.items():
        table, bound = unreached(loops, PUBLISHED)
        if math.isnan(bound):
            continue
        lines += [f"**{name}**: at most {bound:.3f}."
                  + ("" if table.empty else f" Not flagged by any method: {len(table)} of "
                     f"{int((loops['label'] == 'stiction').sum())} stiction loops."), ""]
        if not table.empty:
            lines += [to_markdown(table), ""]
    return lines


def _damarla(isdb: pd.DataFrame, methods: list[str]) -> list[str]:
    st = isdb[isdb.label == "stiction"]
    ns = isdb[isdb.label == "no_stiction"]
    rows = []
    for m in [*methods, "consensus"]:
        rows.append({"method": m,
                     "stiction found": f"{int((st[m] == 'stiction').sum())}/{len(st)}",
                     "false alarms": ", ".join(ns.loop[ns[m] == "stiction"]) or "none",
                     "inconclusive": int((~isdb[m].isin(['stiction', 'no_stiction'])).sum())})
    rows.append({"method": "Damarla et al. (2026), published",
                 "stiction found": f"{len(st)}/{len(st)}",
                 "false alarms": ", ".join(DAMARLA_FALSE_ALARMS), "inconclusive": 0})
    from ..reports.tables import to_markdown

    return ["## Against Damarla et al. (2026) on the 14 ISDB loops here", "",
            "Their optimal-transport images + Deep CORAL found all stiction loops of "
            "their 20-loop ISDB test set with 2 false alarms (PAP4, PAP9); on the 14 of "
            "those loops in `../shared/data/isdb`:", "",
            to_markdown(pd.DataFrame(rows)), ""]


def run_compare(dirs: list[str], out: str, consensus_out: str | None, jobs: int) -> None:
    from ..io import atomic_directory, atomic_path
    from ..reports.tables import csv_text
    from ..validation import check_writable, refuse_overwrite
    from .compare import method_rates
    from .consensus import cross_dataset, fit
    from .panel import METHODS, PUBLISHED

    refuse_overwrite([out, consensus_out], dirs)
    check_writable([consensus_out], [out])
    sets, windows = {}, {}
    loaded = {d: load_folder(d) for d in dirs}  # every folder checked before any work
    for d in dirs:
        name = Path(d).resolve().name
        windows[name], sets[name] = run_folder(d, jobs, loaded[d])
    methods = list(METHODS)
    cross = cross_dataset(sets)
    default = fit(pd.concat(sets.values(), ignore_index=True))
    rates = {}
    for name, loops in sets.items():
        loops["consensus"] = default.apply(loops)
        rates[name] = method_rates(loops, [*methods, "consensus"])
    with atomic_directory(out) as stage:
        for name, loops in sets.items():
            (stage / f"comparison_{name}.csv").write_text(csv_text(loops), encoding="utf-8")
        allr = pd.concat([r.assign(dataset=n) for n, r in rates.items()], ignore_index=True)
        (stage / "methods.csv").write_text(csv_text(allr), encoding="utf-8")
        (stage / "cross_dataset.csv").write_text(csv_text(cross), encoding="utf-8")
        figure(sets, methods, stage / "comparison.png")
        (stage / "comparison.md").write_text(report_md(sets, rates, cross, default, methods),
                                             encoding="utf-8")
    if consensus_out:
        import yaml

        with atomic_path(consensus_out) as tmp:
            Path(tmp).write_text(
                "# The combined stiction verdict of `stictionbench batch`: a vote of the\n"
                "# published detectors, trained on " + ", ".join(sets) + " by `make real`\n"
                "# (stictionbench compare; the one-standard-error rule of consensus.fit);\n"
                "# see reports/real/comparison.md.\n"
                + yaml.safe_dump(default.to_dict(), sort_keys=True), encoding="utf-8")
    for row in cross.itertuples():
        print(f"consensus trained on {row.trained_on}, scored on {row.scored_on}: balanced "
              f"accuracy {row.balanced_accuracy:.3f} (detected {row.detected}, false alarms "
              f"{row.false_alarms}, inconclusive {row.inconclusive})")
    print(f"published methods: {', '.join(PUBLISHED)}; report in {out}/comparison.md")


def cmd_compare(args: argparse.Namespace) -> int:
    run_compare(list(args.directories), args.out, args.consensus, args.jobs)
    return 0


def _short_tag(loop: str, width: int = 14) -> str:
    """A loop's name for a figure's axis: a long historian path shortened to its tag, the
    part after the last ``_`` or ``.`` (``LYCDU.RHT.7050-342_FIC10112`` → ``FIC10112``),
    not cut at a fixed width (which left ``0-342_FIC10112``).

    >>> _short_tag("LYCDU.RHT.7050-342_FIC10112"), _short_tag("2111FIC46005")
    ('FIC10112', '2111FIC46005')
    """
    if len(loop) <= width:
        return loop
    tail = loop.replace(".", "_").rsplit("_", 1)[-1]
    return tail if tail else loop[-width:]
