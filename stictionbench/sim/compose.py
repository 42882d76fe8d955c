"""From a composed config to a Recording: build the blocks, generate the exogenous
signals, run the numba kernel.

``stictionbench.simulate(case="stiction", duration=2000.0, seed=0, **overrides)`` and the
``stictionbench simulate`` command share this composition.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from hydra.utils import get_class, instantiate
from omegaconf import DictConfig, OmegaConf

from ..config import compose
from ..errors import InputError
from ..recording import Recording
from ..validation import number, whole_number
from .blocks import FOPDT, Disturbance, PIController, Sensor, SetPoint
from .kernel import run_loop
from .valves import Valve, init_state

GROUPS = ("process", "controller", "valve", "sensor", "disturbance", "setpoint", "case")


def overrides_from_kwargs(kwargs: Mapping[str, Any]) -> list[str]:
    """Turn Python keyword overrides into Hydra override strings.

    ``valve="kano"`` selects a group option; ``valve__S=4`` or ``{"valve.S": 4}`` sets a
    key (``__`` stands for ``.``); lists become YAML lists.
    """
    out = []
    for key, value in kwargs.items():
        k = key.replace("__", ".")
        if isinstance(value, bool):
            v = "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            v = "[" + ",".join(
                "[" + ",".join(repr(float(x)) for x in item) + "]"
                if isinstance(item, (list, tuple)) else repr(item) for item in value) + "]"
        else:
            v = str(value)
        out.append(f"{k}={v}")
    return out


def config_for(case: str = "stiction", overrides: Sequence[str] = ()) -> DictConfig:
    """Compose the config of ``case`` with Hydra ``overrides``."""
    return compose([f"case={case}", *overrides])


def simulate(
    case: str = "stiction",
    duration: float | None = None,
    seed: int = 0,
    overrides: Sequence[str] = (),
    **kwargs: Any,
) -> Recording:
    """Simulate a closed loop and return a Recording with ``t, SP, PV, OP, MV``.

    Parameters
    ----------
    case : str
        A file of ``conf/case/`` (``linear``, ``tight``, ``disturbance``, ``stiction``).
    duration : float, optional
        Simulated seconds (default from the config, 2000 s).
    seed : int
        Seed of the noise and load generator.
    overrides : sequence of str
        Hydra override strings, e.g. ``["controller.kc=0.5", "valve=kano"]``.
    **kwargs
        More overrides as keywords (``valve="kano"``, ``valve__S=4``).

    Returns
    -------
    Recording

    Examples
    --------
    >>> rec = simulate("stiction", duration=500.0, seed=0)
    >>> rec.columns
    ('t', 'SP', 'PV', 'OP', 'MV')
    """
    if isinstance(overrides, str):  # one override, not its characters
        overrides = [overrides]
    ov = list(overrides) + overrides_from_kwargs(kwargs)
    cfg = config_for(case, ov)  # composed once per distinct override set (cached)
    # numpy numbers (np.arange's seeds, a duration computed with numpy) as Python's
    if duration is not None:
        cfg.duration = duration.item() if isinstance(duration, np.generic) else duration
    cfg.seed = seed.item() if isinstance(seed, np.generic) else seed
    return simulate_config(cfg)


def _number(cfg: DictConfig, key: str, *, positive: bool = True) -> float:
    return number(key, OmegaConf.select(cfg, key), low=0.0 if positive else None,
                  strict=positive)


def _instantiate_flat(node: Any) -> Any:
    """``hydra.utils.instantiate`` for a block config: a flat ``_target_`` mapping is
    built directly from its plain-Python parameters (a block is a frozen dataclass of
    numbers and lists), skipping the OmegaConf re-wrapping that made building the six
    blocks cost more than simulating them; nested ``_target_`` configs go to Hydra."""
    params = OmegaConf.to_container(node, resolve=True) if OmegaConf.is_config(node) else node
    if not isinstance(params, dict) or "_target_" not in params or any(
            isinstance(v, dict) and "_target_" in v for v in params.values()):
        return instantiate(node)
    params = dict(params)
    cls = get_class(params.pop("_target_"))
    return cls(**params)


def build(cfg: DictConfig) -> dict[str, Any]:
    """Instantiate the blocks of a composed config (``_target_`` objects)."""
    blocks: dict[str, Any] = {}
    expected = {
        "process": FOPDT, "controller": PIController, "valve": Valve,
        "sensor": Sensor, "disturbance": Disturbance, "setpoint": SetPoint,
    }
    for name, cls in expected.items():
        try:
            obj = _instantiate_flat(cfg[name])
        except InputError:
            raise
        except Exception as exc:  # instantiate wraps TypeErrors for unknown parameters
            msg = str(exc).strip().splitlines()[-1]
            raise InputError(f"{name}: cannot build the block ({msg})") from None
        if not isinstance(obj, cls):
            raise InputError(f"{name}: _target_ must build a {cls.__name__}")
        blocks[name] = obj
    return blocks


#: the most recorded samples, controller executions or dead-time delay steps one
#: simulation holds in memory (a few arrays of this many floats: under a gigabyte)
MAX_SAMPLES = 10_000_000
#: the most integration steps one simulation runs (about a minute of the numba loop)
MAX_STEPS = 2_000_000_000


def check_size(duration: float, Ts: float, dt: float, n: int, n_sub: int,
               dead_time: float) -> None:
    """Refuse, before any array is made, a simulation too large to hold or to run: more
    than :data:`MAX_SAMPLES` recorded samples, controller executions or delay-line steps,
    or more than :data:`MAX_STEPS` integration steps (the command line checked the first
    alone; ``sb.simulate(duration=1e12)`` asked numpy for 73 TiB and ``dt=1e-12`` ended in
    a ``MemoryError`` traceback).

    Examples
    --------
    >>> check_size(2000.0, 0.1, 0.01, 20001, 10, 10.0)
    >>> try:
    ...     check_size(1e12, 0.1, 0.01, 10**13, 10, 10.0)
    ... except InputError as exc:
    ...     print(str(exc)[:60])
    duration=1e+12 s at sample_time=0.1 s is 1e+13 samples; at m
    """
    if duration / Ts > MAX_SAMPLES:
        raise InputError(f"duration={duration:g} s at sample_time={Ts:g} s is "
                         f"{duration / Ts:.3g} samples; at most {MAX_SAMPLES:.0e} are "
                         "simulated (split a longer study into several runs)")
    if n > MAX_SAMPLES:
        raise InputError(f"duration={duration:g} s is {n:.3g} controller executions; at "
                         f"most {MAX_SAMPLES:.0e} are simulated (a slower controller."
                         "sample_time, or a shorter run)")
    # a dead time longer than the run is refused as such by simulate_config
    if n * n_sub > MAX_STEPS or (dead_time <= duration and dead_time / dt > MAX_SAMPLES):
        raise InputError(f"dt={dt:g} s is too fine for duration={duration:g} s and "
                         f"dead_time={dead_time:g} s ({n * n_sub:.3g} integration steps, "
                         f"{dead_time / dt:.3g} delay steps; at most {MAX_STEPS:.0e} and "
                         f"{MAX_SAMPLES:.0e})")


def simulate_config(cfg: DictConfig) -> Recording:
    """Run the closed loop described by a composed config."""
    duration = _number(cfg, "duration")
    dt = _number(cfg, "dt")
    Ts = _number(cfg, "sample_time")
    seed = whole_number("seed", cfg.seed)
    b = build(cfg)
    ctrl = b["controller"].params()
    hc = float(ctrl[2])
    n_sub = round(hc / dt)
    if n_sub < 1 or abs(n_sub * dt - hc) > 1e-9 * hc:
        raise InputError(f"controller.sample_time ({hc:g}) must be a multiple of dt ({dt:g})")
    rec_every = round(Ts / hc)
    if rec_every < 1 or abs(rec_every * hc - Ts) > 1e-9 * Ts:
        raise InputError(f"sample_time ({Ts:g}) must be a multiple of controller.sample_time "
                         f"({hc:g})")
    n = int(math.floor(duration / hc + 1e-9)) + 1
    check_size(duration, Ts, dt, n, n_sub,
               number("process.dead_time", cfg.process.dead_time, low=0.0))
    if n // rec_every < 100:
        raise InputError(f"duration: {duration:g} s gives fewer than 100 samples at "
                         f"sample_time {Ts:g} s")
    t = np.arange(n) * hc
    rng = np.random.Generator(np.random.PCG64(seed))
    noise = b["sensor"].noise(n, rng)
    dist = b["disturbance"].generate(t, rng)
    sp = b["setpoint"].generate(t)
    kind, vp, post = b["valve"].encode()
    proc = b["process"].coefficients(dt)
    if proc[4] * dt > duration:  # its delay line would be longer than the run itself
        raise InputError(f"process.dead_time ({proc[4] * dt:g} s) is longer than the "
                         f"simulation (duration {duration:g} s): PV would never answer OP")
    vstate = init_state(kind, vp, float(ctrl[5]))
    pv0 = float(b["process"].pv0)
    out = run_loop(sp, noise, dist, n_sub, dt, rec_every, proc, ctrl, kind, vp, vstate, post,
                   b["sensor"].lag_factor(dt), pv0)
    t_rec = t[::rec_every]
    meta = {
        "source": f"simulate:{cfg.get('case_name', 'custom')}",
        "case": str(cfg.get("case_name", "custom")),
        "seed": seed,
        "config": OmegaConf.to_container(cfg, resolve=True),
    }
    if hasattr(b["valve"], "equivalent_two_parameter"):
        S, J = b["valve"].equivalent_two_parameter()
        meta["true_S"] = S
        meta["true_J"] = J
    return Recording.from_arrays(t_rec, out[:, 1], out[:, 2], SP=out[:, 0], MV=out[:, 3],
                                 meta=meta, source=meta["source"], warn=False)
