"""``stictionbench simulate``: simulate a closed loop from the Hydra configs and write
``t, SP, PV, OP, MV`` to CSV or Parquet."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from ..errors import InputError
from ..validation import number

#: keys of ``simulate`` that are not Hydra overrides of ``conf/config.yaml``
SPECIAL_KEYS = ("out", "case", "duration", "seed")


def split_overrides(tokens: Sequence[str]) -> tuple[dict[str, str], list[str]]:
    """Split ``key=value`` tokens into the special keys and Hydra overrides.

    Examples
    --------
    >>> split_overrides(["case=linear", "controller.kc=0.5", "out=x.csv"])
    ({'case': 'linear', 'out': 'x.csv'}, ['controller.kc=0.5'])
    """
    special: dict[str, str] = {}
    rest: list[str] = []
    for tok in tokens:
        if "=" not in tok:
            raise InputError(f"expected key=value, got {tok!r}")
        key, _, value = tok.partition("=")
        if key in SPECIAL_KEYS:
            special[key] = value
        else:
            rest.append(tok)
    return special, rest


def cmd_simulate(args: argparse.Namespace) -> int:
    """Run ``simulate``: compose the case, simulate, write the recording atomically."""
    from ..io import write_recording
    from .compose import config_for, simulate_config

    special, overrides = split_overrides(args.params)
    out = special.get("out")
    if not out:
        raise InputError("simulate needs out=PATH.csv or out=PATH.parquet")
    if Path(out).suffix.lower() not in (".csv", ".parquet"):
        raise InputError(f"out={out}: use a .csv or .parquet file")
    from ..validation import check_writable, whole_number

    check_writable([out])
    case = special.get("case", "stiction")
    if "duration" in special:
        d = number("duration", special["duration"], low=0.0, strict=True)
        overrides.append(f"duration={d}")
    if "seed" in special:
        overrides.append(f"seed={whole_number('seed', special['seed'])}")
    cfg = config_for(case, overrides)
    rec = simulate_config(cfg)  # sizes checked before any array is made (check_size)
    write_recording(rec, out)
    print(f"wrote {out}: {len(rec)} samples, Ts = {rec.Ts:g} s, case {rec.meta['case']}")
    return 0


def add_command(sub: argparse._SubParsersAction) -> None:
    """Add the ``simulate`` sub-command."""
    s = sub.add_parser("simulate", help="simulate a closed loop and write t,SP,PV,OP,MV")
    s.add_argument("params", nargs="*",
                   help="case=NAME duration=SECONDS seed=N out=PATH.csv|.parquet and any "
                        "Hydra override key=value (controller.kc=0.5, valve=kano, ...)")
    s.set_defaults(func=cmd_simulate)
