"""``stictionbench sweep``: plan, launch the unfinished runs as a Hydra multirun, aggregate.

Resume and safety: every run writes ``runs/<id>.json`` atomically when it finishes, and
the plan only launches runs whose file is absent, so a rerun of a finished sweep launches
nothing and a killed sweep loses only the runs that were in progress.
"""

from __future__ import annotations

import json
import math
import os
import signal
import sys
import threading
import time
from datetime import datetime
from pathlib import Path
from typing import Any

from omegaconf import OmegaConf

from ..errors import InputError, interrupt_cause
from ..io import write_text
from .plan import Plan, Run, batch_size, make_plan, sweep_names


def _quote(value: str) -> str:
    return "'" + value.replace("\\", "\\\\").replace("'", "\\'") + "'"


def launcher_choice(plan: Plan) -> str:
    choices = OmegaConf.select(plan.cfg, "hydra.runtime.choices") or {}
    return str(choices.get("hydra/launcher", "joblib"))


def _bool(plan: Plan, key: str) -> bool:
    value = plan.cfg.get(key)
    if isinstance(value, bool):
        return value
    raise InputError(f"{key}: expected true or false, got {value!r}")


def _workers(plan: Plan, launcher: str, extra: list[str]) -> int | None:
    """Parallel workers of the launcher (None: as many as there are jobs)."""
    if launcher == "joblib":
        given = any(o.startswith("hydra.launcher.n_jobs=") for o in plan.overrides)
        if given:
            n = int(plan.cfg.hydra.launcher.n_jobs)
        else:
            try:
                n = int(plan.cfg.n_jobs)
            except (TypeError, ValueError):
                raise InputError(f"n_jobs: not an integer ({plan.cfg.n_jobs!r})") from None
            if n == 0:
                raise InputError("n_jobs: must be ≥ 1 or negative (-1 = all cores)")
            extra.append(f"hydra.launcher.n_jobs={n}")
        return n if n > 0 else max(1, (os.cpu_count() or 1) + 1 + n)
    if launcher == "basic":
        return 1
    return None


def _progress(plan: Plan, pending: list[Run], enabled: bool):
    """A thread that counts result files of pending runs into a tqdm bar."""
    from tqdm import tqdm

    stop = threading.Event()
    ids = {f"{r.id}.json" for r in pending}
    bar = tqdm(total=len(ids), unit="run", file=sys.stderr, disable=None if enabled else True,
               desc=f"sweep {plan.name}", dynamic_ncols=True)

    def poll() -> None:
        seen = 0
        while True:
            try:
                names = {e.name for e in os.scandir(plan.runs_dir)}
            except FileNotFoundError:
                names = set()
            n = len(ids & names)
            if n > seen:
                bar.update(n - seen)
                seen = n
            if stop.wait(0.5):
                break
        bar.close()

    thread = threading.Thread(target=poll, daemon=True)
    thread.start()

    def finish() -> None:
        stop.set()
        thread.join(timeout=5)

    return finish


def _terminate_as_interrupt():
    """Treat SIGTERM (``kill``, a scheduler's stop) like Ctrl-C while jobs run, so the
    launcher stops its workers instead of leaving them to finish their batches."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None

    from ..errors import Terminated

    def handler(signum, frame):
        raise Terminated

    previous = signal.signal(signal.SIGTERM, handler)
    return lambda: signal.signal(signal.SIGTERM, previous)


def _multirun(hydra: Any, overrides: list[str], task: Any) -> Any:
    """``Hydra.multirun`` of ``sweep_app`` with the batch jobs validated once, not per job.

    Hydra's basic sweeper composes every job's config in the launching process before
    launching any (``Sweeper.validate_batch_is_legal``), about 0.35 s each, one after
    the other: with 2 jobs per worker that serial start-up was the main reason 2 workers
    were only 1.3–1.7× faster than 1. Our jobs differ only in ``batch=<index>`` (the
    runs themselves were checked when the plan was made), so composing the first job of
    each batch proves them all; everything else is Hydra's own ``multirun``.
    """
    from hydra._internal.callbacks import Callbacks
    from hydra.core.plugins import Plugins
    from hydra.plugins.sweeper import Sweeper
    from hydra.types import HydraContext, RunMode
    from omegaconf import OmegaConf

    cfg = hydra.compose_config(config_name="sweep_app", overrides=overrides,
                               with_log_configuration=False, run_mode=RunMode.MULTIRUN)

    callbacks = Callbacks(cfg)
    callbacks.on_multirun_start(config=cfg, config_name="sweep_app")
    sweeper = Plugins.instance().instantiate_sweeper(
        config=cfg, hydra_context=HydraContext(config_loader=hydra.config_loader,
                                               callbacks=callbacks),
        task_function=task)

    def validate_first(batch: Any) -> None:
        Sweeper.validate_batch_is_legal(sweeper, list(batch)[:1])

    sweeper.validate_batch_is_legal = validate_first  # type: ignore[method-assign]
    ret = sweeper.sweep(arguments=OmegaConf.to_container(cfg.hydra.overrides.task,
                                                         resolve=False))
    callbacks.on_multirun_end(config=cfg, config_name="sweep_app")
    return ret


def launch(plan: Plan, pending: list[Run]) -> dict[str, Any]:
    """Run ``pending`` as a Hydra multirun (one job per batch); return counts and timing."""
    from hydra.core.global_hydra import GlobalHydra
    from hydra.errors import HydraException

    from .plan import _hydra
    from .runner import run_batch

    launcher = launcher_choice(plan)
    extra: list[str] = []
    workers = _workers(plan, launcher, extra)
    # a cluster launcher runs every job at once: at least 2 jobs, about 50 runs each
    size = batch_size(plan.cfg, len(pending), workers or 2 * math.ceil(len(pending) / 100))
    batches = [[r.id for r in pending[i:i + size]] for i in range(0, len(pending), size)]
    work = Path(str(plan.cfg.work_dir)).resolve()
    stamp = datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
    sweep_dir = work / stamp
    k = 1
    while sweep_dir.exists():
        sweep_dir = work / f"{stamp}-{k}"
        k += 1
    sweep_dir.mkdir(parents=True)
    plan_file = sweep_dir / "plan.json"
    write_text(plan_file, json.dumps({
        "sweep": plan.name,
        "out_dir": str(plan.out_dir),
        "retry_errors": _bool(plan, "retry_errors"),
        "runs": {r.id: r.spec for r in pending},
        "batches": batches,
    }))
    plan.runs_dir.mkdir(parents=True, exist_ok=True)
    overrides = [
        *plan.overrides, *extra,
        f"sweep={plan.name}",
        "hydra.sweeper.params=null",     # the grid is in the plan; Hydra sweeps batches
        f"plan_file={_quote(str(plan_file))}",
        f"hydra.sweep.dir={_quote(str(sweep_dir))}",
        f"batch=range(0,{len(batches)})",
    ]
    print(f"sweep {plan.name}: launching {len(pending)} run(s) as {len(batches)} Hydra "
          f"job(s) of ≤ {size} run(s) ({launcher}"
          + (f", {min(workers, len(batches))} worker(s)" if workers else "")
          + f"); Hydra dir {sweep_dir}", flush=True)
    finish = _progress(plan, pending, _bool(plan, "progress"))
    t0 = time.perf_counter()
    restore = _terminate_as_interrupt()
    try:
        with _hydra():
            returns = _multirun(GlobalHydra.instance().hydra, overrides, run_batch)
    except (HydraException, RuntimeError, OSError) as exc:  # e.g. no SLURM on this machine
        if (stop := interrupt_cause(exc)) is not None:
            raise stop from None  # a signal while Hydra composed a config: not an error
        msg = " ".join(str(exc).split())
        raise InputError(f"sweep {plan.name} stopped ({launcher}): {type(exc).__name__}: "
                         f"{msg[:300]}; finished runs are kept, rerun to resume") from None
    finally:
        restore()
        finish()
    wall = time.perf_counter() - t0
    counts = {"ran": 0, "skipped": 0, "errors": 0}
    for batch in returns or []:
        for ret in batch:
            for key, n in (ret.return_value or {}).items():
                counts[key] = counts.get(key, 0) + int(n)
    counts.update(wall_s=wall, jobs=len(batches), batch_size=size, launcher=launcher,
                  workers=workers)
    return counts


def run_sweep(tokens: list[str]) -> int:
    """The ``stictionbench sweep`` command (tokens: ``sweep=NAME`` and Hydra overrides)."""
    from .aggregate import aggregate

    names = [t.partition("=")[2] for t in tokens if t.startswith("sweep=")]
    if not names:
        raise InputError(f"sweep needs sweep=NAME; available: {', '.join(sweep_names())}")
    if len(names) > 1:
        raise InputError("give sweep=NAME once")
    rest = [t for t in tokens if not t.startswith("sweep=")]
    t0 = time.perf_counter()
    plan = make_plan(names[0], rest)
    if not _bool(plan, "aggregate_only"):
        done = plan.finished(retry_errors=_bool(plan, "retry_errors"))
        pending = [r for r in plan.runs if r.id not in done]
        print(f"sweep {plan.name}: {len(plan.runs)} runs, {len(plan.runs) - len(pending)} "
              f"finished, {len(pending)} to run; results in {plan.out_dir}", flush=True)
        if pending:
            counts = launch(plan, pending)
            print(f"sweep {plan.name}: ran {counts['ran']} runs ({counts['errors']} error rows)"
                  f" in {counts['wall_s']:.1f} s", flush=True)
    df = aggregate(plan)
    if df.empty:
        raise InputError(f"{plan.runs_dir}: no finished run of sweep {plan.name} to aggregate; "
                         "run the sweep without aggregate_only=true first")
    ok = int((df["status"] == "ok").sum()) if len(df) else 0
    print(f"sweep {plan.name}: {len(df)} rows ({ok} ok, {len(df) - ok} errors) -> "
          f"{plan.out_dir / 'results.csv'} ({time.perf_counter() - t0:.1f} s in all)",
          flush=True)
    return 0
