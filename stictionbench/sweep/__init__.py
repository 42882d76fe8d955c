"""Sweeps that scale out: a Hydra multirun of simulations × estimators.

``stictionbench sweep sweep=NAME [hydra/launcher=joblib|submitit_local|submitit_slurm]
[overrides]`` composes ``conf/sweep_app.yaml`` with ``conf/sweep/NAME.yaml``, expands the
grid (:mod:`.plan`), launches the unfinished runs as Hydra jobs (:mod:`.launch`), each
run simulating one loop and applying every registered estimator (:mod:`.runner`), then
writes ``results.csv``/``.parquet``, a summary and figures (:mod:`.aggregate`,
:mod:`.figures`).
"""

from ..rates import roc_curve
from .aggregate import aggregate, summary_table
from .launch import run_sweep
from .plan import Plan, make_plan
from .runner import execute

__all__ = ["Plan", "aggregate", "execute", "make_plan", "roc_curve", "run_sweep",
           "summary_table"]
