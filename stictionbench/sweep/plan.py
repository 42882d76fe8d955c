"""Planning a sweep: compose ``conf/sweep_app.yaml``, expand the grid, name every run.

The grid is ``hydra.sweeper.params`` of ``conf/sweep/<name>.yaml`` plus the sweep
overrides of the command line, expanded with Hydra's own override parser and the basic
sweeper's rule (a command-line key replaces the config key of the same name; the product
over keys, in order, gives the runs). Every run gets a stable id, the hash of its
resolved ``run`` and ``estimators`` nodes, which names its result file
``<out_dir>/runs/<id>.json``: a run whose file exists is finished.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import itertools
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from ..config import _explain, conf_dir, group_options
from ..errors import InputError
from ..validation import number

#: version of the row format; part of every run id, so changing it reruns everything
SCHEMA = 1
APP = "sweep_app"
#: keys of ``run`` and their types (the id hashes the normalised values)
KNOBS: dict[str, type] = {
    "case": str, "valve": str, "S": float, "J_ratio": float, "kc": float, "ti": float,
    "noise": float, "dist_amp": float, "dist_period": float, "load": float, "setpoint": str,
    "duration": float, "sample_time": float, "seed": int, "sim": list,
    "noise_op": float, "noise_mv": float,
}
#: knobs the command consumes (never sent to the runs)
COMMAND_KEYS = ("n_jobs", "batch_size", "limit", "retry_errors", "aggregate_only", "progress")
MAX_BATCH = 50


@dataclass(frozen=True)
class Run:
    """One point of the grid: its id, the grid values and the resolved spec."""

    id: str
    params: dict[str, Any]
    spec: dict[str, Any]


@dataclass
class Plan:
    """The expanded sweep."""

    name: str
    cfg: DictConfig                    # composed app config, hydra node included
    grid: dict[str, list[Any]]         # key -> values, in product order
    runs: list[Run]
    overrides: list[str]               # the plain (non-sweep) overrides, as given
    out_dir: Path = field(init=False)

    def __post_init__(self) -> None:
        self.out_dir = Path(str(self.cfg.out_dir)).resolve()

    @property
    def runs_dir(self) -> Path:
        return self.out_dir / "runs"

    def result_path(self, run_id: str) -> Path:
        return self.runs_dir / f"{run_id}.json"

    def finished(self, *, retry_errors: bool = False) -> set[str]:
        """Ids of the runs whose result file exists (error rows excluded if retrying)."""
        try:
            names = {e.name for e in os.scandir(self.runs_dir) if e.name.endswith(".json")}
        except FileNotFoundError:
            return set()
        done = {r.id for r in self.runs if f"{r.id}.json" in names}
        if retry_errors:
            done = {i for i in done if _status(self.result_path(i)) == "ok"}
        return done


def _status(path: Path) -> str:
    try:
        return str(json.loads(path.read_text(encoding="utf-8")).get("status", "error"))
    except (OSError, ValueError):
        return "error"


# ------------------------------------------------------------------------- composing
def sweep_names() -> list[str]:
    return sorted(p.stem for p in (conf_dir() / "sweep").glob("*.yaml"))


def launcher_names() -> list[str]:
    """Options of ``hydra/launcher``: Hydra's plugins and ``conf/hydra/launcher/``."""
    from hydra.core.global_hydra import GlobalHydra

    with _hydra():
        loader = GlobalHydra.instance().config_loader()
        return sorted(loader.get_group_options("hydra/launcher"))


def _hydra():
    from hydra import initialize_config_dir

    return initialize_config_dir(config_dir=str(conf_dir()), version_base="1.3",
                                 job_name="sweep")


def parse_overrides(tokens: Sequence[str]):
    """Parse ``key=value`` tokens with Hydra's grammar; InputError names a bad one."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import OverrideParseException

    parser = OverridesParser.create()
    out = []
    for tok in tokens:
        if "=" not in tok and not tok.startswith("~"):
            raise InputError(f"expected key=value, got {tok!r}")
        try:
            out.extend(parser.parse_overrides([tok]))
        except OverrideParseException as exc:
            lines = [ln for ln in str(exc).strip().splitlines()
                     if ln.strip() and not ln.startswith(("See ", "Error parsing"))]
            raise InputError(f"bad override {tok!r}: {lines[0] if lines else 'syntax error'}"
                             ) from None
    return out


def compose_app(overrides: Sequence[str]) -> DictConfig:
    """Compose ``conf/sweep_app.yaml`` (hydra node included) with plain overrides."""
    from hydra import compose
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    try:
        with _hydra():
            cfg = compose(config_name=APP, overrides=list(overrides), return_hydra_config=True)
    except (HydraException, OmegaConfBaseException) as exc:
        raise InputError(_explain(str(exc), list(overrides))) from None
    return cfg


def _typed(key: str, value: Any) -> Any:
    """Normalise a knob of ``run`` to its type (ints and floats hash alike)."""
    kind = KNOBS.get(key)
    if value is None:
        return None
    try:
        if kind is float:
            v = float(value)
            if not math.isfinite(v):
                raise ValueError
            return v
        if kind is int:
            if isinstance(value, float) and not value.is_integer():
                raise ValueError
            return int(value)
        if kind is str:
            return str(value)
        if kind is list:
            if isinstance(value, str):
                return [value]
            return [str(v) for v in value]
    except (TypeError, ValueError):
        raise InputError(f"run.{key}: expected {kind.__name__}, got {value!r}") from None
    return value


def normalise_run(run: dict[str, Any]) -> dict[str, Any]:
    """Typed knobs of ``run``; unknown keys and unknown valve/set-point options are errors."""
    unknown = sorted(set(run) - set(KNOBS))
    if unknown:
        raise InputError(f"unknown config key 'run.{unknown[0]}'")
    out = {k: _typed(k, run.get(k)) for k in KNOBS}
    for key, group in (("valve", "valve"), ("setpoint", "setpoint"), ("case", "case")):
        options = _options(group)
        if key == "case" and out[key] is None:
            continue  # no paper case: the valve/controller/disturbance knobs build the loop
        if out[key] not in options:
            raise InputError(f"run.{key}: unknown {group} {out[key]!r}; available: "
                             f"{', '.join(options)}")
    return out


@functools.lru_cache(maxsize=8)
def _options(group: str) -> tuple[str, ...]:
    return tuple(group_options(group))


#: knobs and estimator options added after the first release: left out of the hash at
#: their default values, so the runs of an existing sweep keep their ids (and files)
LATER_DEFAULTS = {"run": ("case", "noise_op", "noise_mv"),
                  "estimators": ("only", "in_seconds")}


def run_id(spec: dict[str, Any]) -> str:
    """Stable id of a run: hash of the schema version and the resolved spec."""
    hashed = {}
    for node, value in spec.items():
        later = LATER_DEFAULTS.get(node, {})
        if isinstance(value, dict):
            value = {k: v for k, v in value.items() if not (k in later and not v)}
        hashed[node] = value
    blob = json.dumps({"schema": SCHEMA, **hashed}, sort_keys=True, separators=(",", ":"),
                      default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


#: override keys under these mappings name estimator parameters, which are open (any
#: constructor parameter of any column may be set)
OPEN_KEYS = ("estimators.params.", "estimators.in_seconds.")


def _set(tree: dict[str, Any], key: str, value: Any) -> None:
    parts = key.split(".")
    node = tree
    for p in parts[:-1]:
        nxt = node.get(p) if isinstance(node, dict) else None
        if nxt is None and parts[:2] == ["estimators", "params"] and isinstance(node, dict):
            nxt = node[p] = {}  # estimators.params.<name>.<param>: parameters are open
        if not isinstance(nxt, dict):
            raise InputError(f"unknown config key {key!r}")
        node = nxt
    if parts[-1] not in node and parts[0] == "run":
        raise InputError(f"unknown config key {key!r}")
    node[parts[-1]] = value


# ------------------------------------------------------------------------- planning
def make_plan(name: str, tokens: Sequence[str]) -> Plan:
    """Compose the app for sweep ``name`` with ``tokens`` and expand the grid.

    ``tokens`` are Hydra overrides (``run.S=0,4``, ``hydra/launcher=joblib``, ...);
    sweep overrides (``a,b``, ``range()``) join the grid, the others are composed.
    """
    if name not in sweep_names():
        raise InputError(f"unknown sweep {name!r}; available: {', '.join(sweep_names())}")
    parsed = parse_overrides(tokens)
    plain: list[str] = []
    cli_grid: list[Any] = []
    for ov in parsed:
        if ov.is_sweep_override():
            cli_grid.append(ov)
        elif ov.key_or_group.startswith(OPEN_KEYS) and not ov.input_line.startswith("+"):
            # estimator parameters are open mappings: a key is added or replaced, as the
            # README writes it (Hydra alone wanted a "+" before a key not yet there)
            plain.append("++" + ov.input_line)
        else:
            plain.append(ov.input_line)
    for ov in parsed:
        key = ov.get_key_element()
        if key == "hydra/launcher" and not ov.is_sweep_override():
            choice = str(ov.value())
            names = launcher_names()
            if choice not in names:
                raise InputError(f"unknown launcher {choice!r}; available: {', '.join(names)}")
    cfg = compose_app([f"sweep={name}", *plain])
    params = OmegaConf.select(cfg, "hydra.sweeper.params")
    lines = [f"{k}={v}" for k, v in (OmegaConf.to_container(params) if params else {}).items()]
    overrides = parse_overrides(lines) + cli_grid
    fixed = {ov.key_or_group for ov in parsed if not ov.is_sweep_override()}
    grid: dict[str, list[Any]] = {}
    for ov in overrides:  # config keys first, then the command line's (basic sweeper rule)
        key = ov.key_or_group
        if key in fixed:
            continue  # a plain command-line value replaces the config's sweep
        if not (key.startswith("run.") or key.startswith("estimators.")):
            raise InputError(f"{key}: only run.* and estimators.* keys can be swept")
        if ov.is_sweep_override() and not ov.is_discrete_sweep():
            raise InputError(f"{key}: use a list (a,b,c) or range(); intervals need a "
                             "different sweeper")
        grid[key] = list(ov.sweep_iterator()) if ov.is_sweep_override() else [ov.value()]
    base = {
        "run": OmegaConf.to_container(cfg.run, resolve=True),
        "estimators": OmegaConf.to_container(cfg.estimators, resolve=True),
    }
    runs: list[Run] = []
    keys = list(grid)
    for combo in itertools.product(*(grid[k] for k in keys)):
        tree = copy.deepcopy(base)
        for k, v in zip(keys, combo, strict=True):
            _set(tree, k, v)
        spec = {"run": normalise_run(tree["run"]), "estimators": tree["estimators"]}
        rid = run_id(spec)
        if spec["run"]["seed"] is None:
            spec["run"]["seed"] = int(rid[:8], 16) % (2**31)
        runs.append(Run(rid, dict(zip(keys, combo, strict=True)), spec))
    if not runs:  # no grid at all: one run with the config's values
        spec = {"run": normalise_run(base["run"]), "estimators": base["estimators"]}
        rid = run_id(spec)
        if spec["run"]["seed"] is None:
            spec["run"]["seed"] = int(rid[:8], 16) % (2**31)
        runs.append(Run(rid, {}, spec))
    limit = cfg.get("limit")
    if limit is not None:
        try:
            n = int(limit)
        except (TypeError, ValueError):
            raise InputError(f"limit: not an integer ({limit!r})") from None
        if n < 1:
            raise InputError(f"limit: must be ≥ 1, got {n}")
        runs = runs[:n]
    _check_estimators(runs)
    seen: dict[str, Run] = {}
    for r in runs:  # identical points (a key swept twice) are one run
        seen.setdefault(r.id, r)
    return Plan(name=name, cfg=cfg, grid=grid, runs=list(seen.values()), overrides=plain)


def _check_estimators(runs: list[Run]) -> None:
    """Estimator names, parameters and signal choices are checked once, before running."""
    from ..estimators import make
    from .runner import variants

    done: set[str] = set()
    for r in runs:
        est = r.spec["estimators"]
        key = json.dumps(est, sort_keys=True, default=str)
        if key in done:
            continue
        done.add(key)
        by_prefix = {prefix: name for prefix, name, _x, _y in variants(est)}
        for key, params in (est.get("params") or {}).items():
            if not isinstance(params, dict):
                raise InputError(f"estimators.params.{key}: expected a mapping of parameters")
            make(by_prefix.get(key, key), **params)
        for key, sec in (est.get("in_seconds") or {}).items():
            # a window in seconds is a positive number (a typo became an error in every
            # run's estimator columns, and the sweep still ended "ok")
            number(f"estimators.in_seconds.{key}", sec, low=0.0, strict=True)


def batch_size(cfg: DictConfig, pending: int, workers: int) -> int:
    """Runs per Hydra job: ``cfg.batch_size``, or ``auto``: one job per worker, ≤ 50 runs.

    A Hydra job costs about 0.35 s besides its runs (the launcher composes its config in
    the launching process, one job after the other, and the job sets up its logging and
    output directory), eight runs' worth at 2000 s and 1 s sampling: few large batches
    keep that serial cost small. Runs of one sweep take about the same time, so one
    batch per worker balances well. A killed job loses only its unfinished runs, since
    every run writes its own file.
    """
    value = cfg.get("batch_size", "auto")
    if value in (None, "auto"):
        return max(1, min(MAX_BATCH, math.ceil(pending / max(1, workers))))
    try:
        n = int(value)
    except (TypeError, ValueError):
        raise InputError(f"batch_size: expected an integer or auto, got {value!r}") from None
    if n < 1:
        raise InputError(f"batch_size: must be ≥ 1, got {n}")
    return n
