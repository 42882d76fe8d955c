"""One run of a sweep: simulate one loop, apply every registered estimator, write a row.

:func:`execute` never raises for a bad run: a simulation that fails gives a row with
``status = "error"`` and the message in ``error``; an estimator that fails gives its
``<prefix>_error`` column. The row is written atomically to ``runs/<id>.json``, so a
killed sweep leaves finished runs complete and unfinished ones absent.

:func:`run_batch` is the Hydra task function: one Hydra job runs one batch of the plan
the command wrote (several runs per job keep Hydra's per-job cost, a config
composition in the launcher and one in the job, small against the runs themselves).
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import socket
import time
from pathlib import Path
from typing import Any

from omegaconf import DictConfig

from ..io import write_text
from ..sim.valves import PhysicalValve
from ..validation import jsonable

#: valves of conf/valve/ whose stiction band the knob S sets
TWO_PARAMETER = ("choudhury", "kano", "he")
WORKER = f"{socket.gethostname()}:{os.getpid()}"


def _one_line(exc: BaseException) -> str:
    msg = " ".join(str(exc).split()) or type(exc).__name__
    return f"{type(exc).__name__}: {msg}"[:300]


@contextlib.contextmanager
def _outside_hydra_job():
    """Let :func:`stictionbench.config.compose` initialise Hydra inside a Hydra job.

    A job runs with Hydra's global state initialised (by the launcher); composing a
    config needs it clear. The state is set aside and put back afterwards.
    """
    from hydra.core.global_hydra import GlobalHydra

    gh = GlobalHydra.instance()
    saved = gh.hydra
    if saved is None:
        yield
        return
    gh.clear()
    try:
        yield
    finally:
        GlobalHydra.instance().hydra = saved


def sim_config(run: dict[str, Any]):
    """The composed simulation config (conf/config.yaml) of a run's knobs.

    Group choices (valve, set point, ``run.sim``) go through Hydra's composition (cached
    per distinct set); the numbers are then set on the composed config.
    """
    from omegaconf import open_dict

    from ..sim.compose import config_for

    if run.get("case"):
        return _case_config(run)
    valve = run["valve"]
    overrides = [f"valve={valve}", "disturbance=sinusoidal", "sensor=ideal",
                 f"setpoint={run['setpoint']}", *run["sim"]]
    with _outside_hydra_job():
        cfg = config_for("linear", overrides)
    S = run["S"]
    J = run["J_ratio"] * S
    with open_dict(cfg):
        cfg.case_name = "sweep"
        cfg.description = "stictionbench sweep run"
        cfg.duration = run["duration"]
        cfg.sample_time = run["sample_time"]
        cfg.seed = run["seed"]
        cfg.controller.kc = run["kc"]
        cfg.controller.ti = run["ti"]
        cfg.sensor.noise_std = run["noise"]
        cfg.disturbance.amplitude = run["dist_amp"]
        cfg.disturbance.period = run["dist_period"]
        cfg.disturbance.load_std = run["load"]
        if valve == "physical":
            v = cfg.valve
            phys = PhysicalValve(mass=float(v.mass), spring=float(v.spring),
                                 area=float(v.area), pressure_low=float(v.pressure_low),
                                 pressure_high=float(v.pressure_high))
            cfg.valve.Fs, cfg.valve.Fc = phys.friction_for(S, J)
        elif valve in TWO_PARAMETER:
            cfg.valve.S = S
            cfg.valve.J = J
        elif valve == "deadband":
            cfg.valve.deadband = S
    return cfg


def _case_config(run: dict[str, Any]):
    """A paper case of ``conf/case/`` as it is, with the run's noise, load and sampling.

    The valve, controller and disturbance knobs are not used: the case sets them.
    """
    from omegaconf import open_dict

    from ..sim.compose import config_for

    with _outside_hydra_job():
        cfg = config_for(run["case"], [f"setpoint={run['setpoint']}", *run["sim"]])
    with open_dict(cfg):
        cfg.description = f"stictionbench sweep run, paper case {run['case']}"
        cfg.duration = run["duration"]
        cfg.sample_time = run["sample_time"]
        cfg.seed = run["seed"]
        cfg.sensor.noise_std = run["noise"]
        cfg.disturbance.load_std = run["load"]
    return cfg


def truth(run: dict[str, Any], cfg, meta: dict[str, Any] | None) -> dict[str, Any]:
    """Ground truth of a run: the valve's S and J (% of span) and the stiction label.

    Stiction is present when the valve sticks and slips: ``S > 0`` and ``J > 0``
    (physical valve: ``Fs > Fc`` and friction above zero). Pure deadband (``J = 0``),
    a linear valve and Table II's "linear" friction (Fs = Fc) are stiction-free.
    """
    valve = run["valve"]
    S = J = 0.0
    if run.get("case") and cfg is not None:
        valve = str(cfg.valve._target_).rsplit(".", 1)[-1]
        S, J = _case_truth(cfg.valve)
    elif meta is not None and "true_S" in meta:
        S, J = float(meta["true_S"]), float(meta["true_J"])
    elif valve in TWO_PARAMETER or valve == "physical":
        S, J = run["S"], run["J_ratio"] * run["S"]
    elif valve == "deadband":
        S = run["S"]
    out: dict[str, Any] = {"true_S": S, "true_J": J,
                           "label_stiction": bool(S > 1e-9 and J > 1e-9)}
    if valve.lower().startswith("physical") and cfg is not None:
        out["valve_Fs"] = float(cfg.valve.Fs)
        out["valve_Fc"] = float(cfg.valve.Fc)
    return out


def _case_truth(valve_cfg) -> tuple[float, float]:
    """S and J (% of span) of a case's valve: the physical valve's equivalent two
    parameters, a two-parameter model's own, a deadband's width; 0 for a linear valve."""
    params = {k: v for k, v in valve_cfg.items() if k != "_target_"}
    target = str(valve_cfg._target_)
    if target.endswith("PhysicalValve"):
        return PhysicalValve(**params).equivalent_two_parameter()
    if "S" in params:
        return float(params["S"]), float(params.get("J", 0.0))
    return float(params.get("deadband", 0.0)), 0.0


def variants(estimators: dict[str, Any]) -> list[tuple[str, str, str | None, str | None]]:
    """``(prefix, estimator, x, y)`` for every registered estimator.

    Entries of ``estimators.signals`` first; registered estimators they do not name run
    on their own default signals under their own name.
    """
    from ..errors import InputError
    from ..estimators import available

    reg = available()
    out: list[tuple[str, str, str | None, str | None]] = []
    named = set()
    for prefix, entry in (estimators.get("signals") or {}).items():
        if entry is None:
            continue
        entry = list(entry) + [None] * (3 - len(entry))
        name, x, y = entry[0], entry[1], entry[2]
        if name not in reg:
            raise InputError(f"estimators.signals.{prefix}: unknown estimator {name!r}; "
                             f"available: {', '.join(sorted(reg))}")
        out.append((str(prefix), str(name), x, y))
        named.add(name)
    for name in sorted(reg):
        if name not in named:
            out.append((name, name, None, None))
    only = estimators.get("only")
    if only is not None:
        only = [only] if isinstance(only, str) else list(only)
        missing = sorted(set(only) - {v[0] for v in out})
        if missing:
            raise InputError(f"estimators.only: unknown column prefix {missing[0]!r}; "
                             f"known: {', '.join(v[0] for v in out)}")
        out = [v for v in out if v[0] in only]
    return out


def variant_params(estimators: dict[str, Any], prefix: str, name: str,
                   Ts: float) -> dict[str, Any]:
    """Constructor parameters of one variant.

    ``estimators.params.<prefix>`` when it exists, else ``estimators.params.<name>``;
    then ``estimators.in_seconds`` (parameter -> seconds) converted to samples of the
    recording (``round(seconds / Ts)``, at least 1) for every variant that has the
    parameter, so a window fixed in seconds stays fixed when the sampling changes.
    """
    from ..estimators import get_class

    params = dict((estimators.get("params") or {}).get(prefix)
                  or (estimators.get("params") or {}).get(name) or {})
    seconds = estimators.get("in_seconds") or {}
    if seconds:
        names = get_class(name).param_names()
        for key, sec in seconds.items():
            if key in names:
                params[key] = max(1, int(round(float(sec) / Ts)))
    return params


def execute(run_id: str, spec: dict[str, Any]) -> dict[str, Any]:
    """Run one point of the grid; return its row (never raises for a bad run)."""
    from ..estimators import make
    from ..sim.compose import simulate_config

    run = spec["run"]
    t0 = time.perf_counter()
    row: dict[str, Any] = {"run_id": run_id, "status": "ok", "error": None}
    row.update({k: (json.dumps(v) if isinstance(v, list) else v) for k, v in run.items()})
    row["J"] = run["J_ratio"] * run["S"]
    rec = None
    cfg = None
    try:
        cfg = sim_config(run)
        ts = time.perf_counter()
        rec = simulate_config(cfg)
        row["sim_time_s"] = time.perf_counter() - ts
    except Exception as exc:  # the run fails, the sweep goes on
        row["status"] = "error"
        row["error"] = _one_line(exc)
    try:
        row.update(truth(run, cfg, None if rec is None else rec.meta))
    except Exception as exc:
        row.update({"true_S": None, "true_J": None, "label_stiction": None})
        row["error"] = row["error"] or _one_line(exc)
        row["status"] = "error"
    if rec is not None and (run.get("noise_op") or run.get("noise_mv")):
        from ..sim.measurement import add_measurement_noise

        try:
            rec = add_measurement_noise(rec, {"OP": run.get("noise_op") or 0.0,
                                              "MV": run.get("noise_mv") or 0.0},
                                        seed=int(run["seed"]))
        except Exception as exc:
            row["status"] = "error"
            row["error"] = _one_line(exc)
            rec = None
    if rec is not None:
        try:
            todo = variants(spec["estimators"])
        except Exception as exc:
            todo = []
            row["status"] = "error"
            row["error"] = _one_line(exc)
        for prefix, name, x, y in todo:
            te = time.perf_counter()
            try:
                params = variant_params(spec["estimators"], prefix, name, rec.Ts)
                res = make(name, **params).estimate(rec, x=x, y=y)
                row.update({k: jsonable(v) for k, v in res.flat(prefix).items()})
                row[f"{prefix}_error"] = None
            except Exception as exc:
                row[f"{prefix}_value"] = None
                row[f"{prefix}_decision"] = None
                row[f"{prefix}_error"] = _one_line(exc)
            row[f"{prefix}_time_s"] = time.perf_counter() - te
    row["wall_time_s"] = time.perf_counter() - t0
    row["worker"] = WORKER
    return {k: jsonable(v) for k, v in row.items()}


def write_row(path: Path, row: dict[str, Any]) -> None:
    """Write a row as JSON, atomically."""
    write_text(path, json.dumps(row, allow_nan=False, default=str) + "\n")


@functools.lru_cache(maxsize=4)
def _load_plan(path: str, mtime: float) -> dict[str, Any]:
    return json.loads(Path(path).read_text(encoding="utf-8"))


def load_plan(path: str | os.PathLike[str]) -> dict[str, Any]:
    p = Path(path)
    return _load_plan(str(p), p.stat().st_mtime)


def run_batch(cfg: DictConfig) -> dict[str, int]:
    """Hydra task: run batch ``cfg.batch`` of the plan ``cfg.plan_file``.

    A run whose result file exists is skipped (another job or an earlier sweep finished
    it); with ``retry_errors`` an error row is run again.
    """
    plan = load_plan(str(cfg.plan_file))
    runs_dir = Path(plan["out_dir"]) / "runs"
    retry = bool(plan.get("retry_errors", False))
    counts = {"ran": 0, "skipped": 0, "errors": 0}
    for rid in plan["batches"][int(cfg.batch)]:
        path = runs_dir / f"{rid}.json"
        if path.exists() and not (retry and _is_error(path)):
            counts["skipped"] += 1
            continue
        row = execute(rid, plan["runs"][rid])
        write_row(path, row)
        counts["ran"] += 1
        counts["errors"] += row["status"] != "ok"
    return counts


def _is_error(path: Path) -> bool:
    try:
        return json.loads(path.read_text(encoding="utf-8")).get("status") != "ok"
    except (OSError, ValueError):
        return True
