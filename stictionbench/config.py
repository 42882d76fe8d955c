"""Composing Hydra configs from the ``conf/`` tree, with user errors turned into
:class:`~stictionbench.errors.InputError` that names the offending key."""

from __future__ import annotations

import functools
import os
import re
from collections.abc import Sequence
from pathlib import Path

from omegaconf import DictConfig, OmegaConf

from .errors import InputError


def conf_dir() -> Path:
    """The ``conf/`` directory: ``$STICTIONBENCH_CONF`` or the one beside the package."""
    env = os.environ.get("STICTIONBENCH_CONF")
    p = Path(env) if env else Path(__file__).resolve().parents[1] / "conf"
    if not (p / "config.yaml").is_file():
        raise InputError(f"{p}: no config.yaml (set STICTIONBENCH_CONF to the conf/ directory)")
    return p


def group_options(group: str) -> list[str]:
    """Names of the options of a config group, e.g. ``group_options("case")``."""
    return sorted(f.stem for f in (conf_dir() / group).glob("*.yaml"))


@functools.lru_cache(maxsize=256)
def _compose_cached(config_name: str, overrides: tuple[str, ...]) -> DictConfig:
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    try:
        with initialize_config_dir(config_dir=str(conf_dir()), version_base="1.3"):
            cfg = compose(config_name=config_name, overrides=list(overrides))
    except (HydraException, OmegaConfBaseException) as exc:
        raise InputError(_explain(str(exc), overrides)) from None
    return cfg


def compose(overrides: Sequence[str] = (), config_name: str = "config") -> DictConfig:
    """Compose ``conf/<config_name>.yaml`` with Hydra override strings.

    Returns a fresh (mutable copy of a cached) DictConfig. Unknown keys, unknown
    group options and malformed overrides raise InputError naming the key.
    """
    cfg = _compose_cached(config_name, tuple(overrides))
    return OmegaConf.create(OmegaConf.to_container(cfg))  # type: ignore[return-value]


def _explain(msg: str, overrides: Sequence[str]) -> str:
    first = msg.strip().splitlines()[0] if msg.strip() else "invalid configuration"
    m = re.search(r"Could not override '([^']+)'", msg) or re.search(
        r"Key '([^']+)' is not in struct", msg
    )
    if m:
        return f"unknown config key {m.group(1)!r}"
    m = re.search(r"Could not find '([^']+)'", msg)
    if m:
        name = m.group(1)
        group, _, option = name.rpartition("/")
        group = group.strip("/")
        if group:
            opts = ", ".join(group_options(group)) if (conf_dir() / group).is_dir() else ""
            return f"unknown {group} {option!r}" + (f"; available: {opts}" if opts else "")
        return f"unknown config {name!r}"
    return first
