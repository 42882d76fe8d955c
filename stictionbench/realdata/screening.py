"""Sub-commands ``stictionbench screen`` and ``stictionbench oscillation-benchmark``.

``screen PATH... [--json OUT]`` reads recordings (CSV, Parquet, ISDB ``.mat``; folders are
searched for those files, not recursively), runs :func:`stictionbench.realdata.quality.screen` on
each and prints one line per recording: name, usable or not, its grade and score (good,
fair, poor) and why. Files that are not recordings (label tables) or that cannot be read
are listed as skipped.

``oscillation-benchmark [MAT] [--out DIR]`` runs
:func:`stictionbench.realdata.oscillation_benchmark.run`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from ..errors import InputError

_RECORDING_SUFFIXES = (".csv", ".parquet", ".mat")


def _collect(paths: list[str]) -> tuple[list[tuple[str, Any]], list[tuple[str, str]]]:
    """Read every PATH: ``[(name, Recording)]`` and ``[(file, reason)]`` skipped."""
    from .datasets import load_csv_dir, read_any, read_labels, scan_isdb_mat

    recs: list[tuple[str, Any]] = []
    skipped: list[tuple[str, str]] = []

    def add_file(f: Path) -> None:
        # one unreadable file is skipped with its reason, not the whole screen refused
        try:
            if f.suffix.lower() == ".mat":
                from .datasets import is_oscillation_benchmark

                if not is_oscillation_benchmark(f):
                    got, bad = scan_isdb_mat(f, warn=False)
                    recs.extend(got.items())
                    skipped.extend((f"{f.name}:{n}", r) for n, r in bad)
                    return
            recs.extend(read_any(f, warn=False).items())
        except InputError as exc:
            skipped.append((str(f), str(exc)))

    for raw in paths:
        p = Path(raw)
        if not p.exists():
            raise InputError(f"{p}: no such file or directory")
        if p.is_dir():
            labels: bool | None = None
            if (p / "labels.csv").is_file():
                try:
                    read_labels(p / "labels.csv")
                except InputError as exc:
                    skipped.append((str(p / "labels.csv"), f"labels not used: {exc}"))
                    labels = False
            got, bad = load_csv_dir(p, labels=labels, warn=False, label_warnings=False)
            recs.extend(got.items())
            skipped.extend((str(p / f), r) for f, r in bad)
            for f in sorted(p.iterdir()):
                if f.is_file() and f.suffix.lower() in (".parquet", ".mat"):
                    add_file(f)
        else:
            add_file(p)
    return recs, skipped


def cmd_screen(args: argparse.Namespace) -> int:
    from ..io import write_text
    from ..validation import check_writable, refuse_overwrite
    from .quality import screen

    refuse_overwrite([args.json], args.paths)
    check_writable([args.json])
    recs, skipped = _collect(args.paths)
    if not recs and not skipped:
        raise InputError("no CSV, Parquet or .mat files found in " + ", ".join(args.paths))
    if not recs:  # nothing could be read: an error, as in batch, not an empty screen
        more = f" (and {len(skipped) - 1} more file(s) unreadable)" if len(skipped) > 1 else ""
        f, reason = skipped[0]
        raise InputError((reason if reason.startswith(str(f)) else f"{f}: {reason}") + more)
    reports = []
    for name, rec in recs:
        rep = screen(rec)
        reports.append((name, rec, rep))
    w = max((len(n) for n, _, _ in reports), default=10)
    for name, _, rep in reports:
        status = "usable" if rep.usable else "UNUSABLE"
        # the graded score (quality.grade) beside the yes/no: good, fair, poor
        graded = f"{rep.flags.get('grade', '')} {rep.flags.get('score', float('nan')):.2f}" \
            if rep.usable else ""
        print(f"{name:<{w}}  {status:<8}  {graded:<9}  {rep.summary()}")
    for f, reason in skipped:
        print(f"skipped {f}: {reason}")
    n_bad = sum(not rep.usable for _, _, rep in reports)
    print(f"{len(reports)} recording(s): {len(reports) - n_bad} usable, {n_bad} unusable; "
          f"{len(skipped)} file(s) skipped")
    if args.json:
        payload = {
            "recordings": [
                {**rep.to_dict(), "name": name, "source": str(rec.meta.get("source", "")),
                 "label": rec.meta.get("label"), "group": rec.meta.get("group")}
                for name, rec, rep in reports
            ],
            "skipped": [{"file": f, "reason": r} for f, r in skipped],
        }
        write_text(args.json, json.dumps(payload, indent=2, allow_nan=False) + "\n")
    return 0


def cmd_oscillation_benchmark(args: argparse.Namespace) -> int:
    from .oscillation_benchmark import DEFAULT, TREND_REMOVED, default_mat_path, run

    mat = Path(args.mat) if args.mat else default_mat_path()
    if not mat.exists():
        raise InputError(f"{mat}: no such file (pass the path of benchmark.mat)")
    res = run(mat, args.out, null_reps=args.null_reps, progress=args.progress)
    for st in (DEFAULT, TREND_REMOVED):
        s = res[st.name]
        print(f"{st.name:<14} accuracy {s['accuracy']:.3f}  balanced {s['balanced_accuracy']:.3f}"
              f"  TP {s['tp']} FN {s['fn']} FP {s['fp']} TN {s['tn']}")
    from .oscillation_benchmark import default_out_dir

    print(f"wrote {Path(args.out) if args.out else default_out_dir()}/"
          "{results.csv,summary.md,confusion.png}")
    return 0
