"""The ``stictionbench sweep`` sub-command (listed in ``stictionbench.cli.COMMAND_MODULES``)."""

from __future__ import annotations

import argparse


def cmd_sweep(args: argparse.Namespace) -> int:
    from .launch import run_sweep

    return run_sweep(list(args.overrides))


def add_command(subparsers) -> None:
    """Add the ``sweep`` parser to the CLI's sub-parsers."""
    p = subparsers.add_parser(
        "sweep",
        help="run a sweep of simulations x estimators as a Hydra multirun",
        description="Run conf/sweep/NAME.yaml as a Hydra multirun: every run simulates "
                    "one loop and applies every registered estimator; results go to "
                    "reports/sweeps/NAME/ (results.csv, results.parquet, summary.md, "
                    "figures). Finished runs are skipped on a rerun.",
    )
    p.add_argument(
        "overrides", nargs="*", metavar="KEY=VALUE",
        help="sweep=NAME (a file of conf/sweep/: smoke, default, sensitivity and the "
             "paper's paper_cases, paper_magnitude, paper_margin, paper_noise, "
             "paper_period, paper_sampling); hydra/launcher=joblib|submitit_local|"
             "submitit_slurm; n_jobs=N; run.KNOB=a,b (grid) or run.KNOB=v (fixed); "
             "out_dir=DIR; batch_size=N; limit=N; retry_errors=true; aggregate_only=true; "
             "any hydra.launcher.* key",
    )
    p.set_defaults(func=cmd_sweep)
