"""The real-data sub-commands (listed in ``stictionbench.cli.COMMAND_MODULES``):
``screen``, ``oscillation-benchmark`` (:mod:`.screening`), ``batch`` (:mod:`.batch`) and
``compare`` (:mod:`.comparison`)."""

from __future__ import annotations

import argparse
from typing import Any

from ..validation import count_arg, jobs_count


def _lazy(module: str, name: str):
    """The command function ``name`` of ``module``, imported when the command runs."""
    def run(args: argparse.Namespace) -> int:
        from importlib import import_module

        return getattr(import_module(f"stictionbench.realdata.{module}"), name)(args)
    return run


def add_command(subparsers: Any) -> None:
    """Add ``screen``, ``oscillation-benchmark``, ``batch`` and ``compare``."""
    sub = subparsers
    # -- screening
    s = sub.add_parser(
        "screen", help="screen recordings for data-quality problems before diagnosis")
    s.add_argument("paths", nargs="+", metavar="PATH",
                   help="recording files (.csv, .parquet, .mat) or folders of them")
    s.add_argument("--json", metavar="OUT", help="write all reports as JSON")
    s.set_defaults(func=_lazy("screening", "cmd_screen"))

    o = sub.add_parser(
        "oscillation-benchmark",
        help="score ACF oscillation detection on the OP of the 93 ISDB loops")
    o.add_argument("mat", nargs="?", default=None,
                   help="benchmark.mat (default: ../shared/data/isdb-oscillation/"
                        "benchmark.mat beside the repository)")
    o.add_argument("--out", default=None, metavar="DIR",
                   help="output folder (default: reports/real/oscillation)")
    o.add_argument("--null-reps", type=count_arg, default=200, metavar="N",
                   help="synthetic noise records per kind for the false-alarm check "
                        "(0 skips it)")
    o.add_argument("--progress", action="store_true", help="show a progress bar")
    o.set_defaults(func=_lazy("screening", "cmd_oscillation_benchmark"))

    # -- batch
    p = sub.add_parser("batch", help="stiction verdicts for a folder of recordings")
    p.add_argument("directory", help="folder of CSV recordings (t, PV, OP; SP, MV "
                                     "optional); not searched recursively")
    p.add_argument("--labels", help="labels CSV (loop, label[, group]); default: the "
                                    "folder's labels.csv when there is one")
    p.add_argument("--json", metavar="OUT.json", help="write the verdicts here (required)")
    p.add_argument("--report", metavar="DIR", help="write tables and figures here")
    p.add_argument("--jobs", type=jobs_count, default=2,
                   help="parallel workers (default 2; -1: every core)")
    p.add_argument("--diagnose", choices=("none", "flagged", "all"), default="none",
                   help="also run the model-free diagnosis (missing_physics, fitted S and "
                        "J; seconds per recording) on none of the recordings (default: "
                        "the detectors take ~0.2 s each), on those flagged stiction, or "
                        "on all")
    p.add_argument("--consensus", metavar="FILE.yaml",
                   help="consensus of the detectors (default: conf/consensus/default.yaml)")
    p.add_argument("--op-range", nargs=2, type=float, metavar=("LO", "HI"),
                   help="OP's 0 and 100 %% in its own units for every recording (4 20 for "
                        "milliamps): the detectors' 'OP moved by 1 %%' and J's per cent "
                        "(default: per cent or a fraction recognised from each OP, else "
                        "1 %% read as 1 unit); a recording whose OP leaves it is refused")
    p.set_defaults(func=_lazy("batch", "cmd_batch"))

    # -- comparison
    p = sub.add_parser("compare", help="published stiction detectors, loop by loop, on "
                                       "labelled folders; consensus trained across them")
    p.add_argument("directories", nargs="+", metavar="DIR",
                   help="folders of recordings with labels.csv (e.g. ../shared/data/isdb)")
    p.add_argument("--out", required=True, metavar="DIR", help="report directory")
    p.add_argument("--consensus", metavar="OUT.yaml",
                   help="write the consensus trained on all folders here")
    p.add_argument("--jobs", type=jobs_count, default=2,
                   help="parallel workers (default 2; -1: every core)")
    p.set_defaults(func=_lazy("comparison", "cmd_compare"))
