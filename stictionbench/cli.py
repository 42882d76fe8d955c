"""The ``stictionbench`` command line.

Bad input ends with one line on stderr, ``stictionbench: error: <what and where>``, and
exit code 2; no traceback, no half-written output file.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from importlib import import_module
from pathlib import Path

from .errors import InputError

EXIT_BAD_INPUT = 2

#: modules that add a sub-command: each has ``add_command(subparsers)`` which adds its
#: parser and sets ``func`` (one module per line)
COMMAND_MODULES: tuple[str, ...] = (
    "stictionbench.diagnosis.command",
    "stictionbench.sweep.command",
    "stictionbench.quality_command",
    "stictionbench.batch_command",
)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse's own usage errors: exit 2, one line
        raise InputError(message)


def _split_kv(tokens: Sequence[str]) -> tuple[dict[str, str], list[str]]:
    special: dict[str, str] = {}
    rest: list[str] = []
    for tok in tokens:
        if "=" not in tok:
            raise InputError(f"expected key=value, got {tok!r}")
        key, _, value = tok.partition("=")
        if key in ("out", "case", "duration", "seed"):
            special[key] = value
        else:
            rest.append(tok)
    return special, rest


def cmd_simulate(args: argparse.Namespace) -> int:
    from .io import write_recording
    from .sim.compose import config_for, simulate_config

    special, overrides = _split_kv(args.params)
    out = special.get("out")
    if not out:
        raise InputError("simulate needs out=PATH.csv or out=PATH.parquet")
    if Path(out).suffix.lower() not in (".csv", ".parquet"):
        raise InputError(f"out={out}: use a .csv or .parquet file")
    case = special.get("case", "stiction")
    if "duration" in special:
        try:
            d = float(special["duration"])
        except ValueError:
            raise InputError(f"duration: not a number ({special['duration']!r})") from None
        if not d > 0:
            raise InputError(f"duration: must be positive, got {special['duration']}")
        overrides.append(f"duration={d}")
    if "seed" in special:
        try:
            s = int(special["seed"])
        except ValueError:
            raise InputError(f"seed: not an integer ({special['seed']!r})") from None
        if s < 0:
            raise InputError(f"seed: must be ≥ 0, got {s}")
        overrides.append(f"seed={s}")
    rec = simulate_config(config_for(case, overrides))
    write_recording(rec, out)
    print(f"wrote {out}: {len(rec)} samples, Ts = {rec.Ts:g} s, case {rec.meta['case']}")
    return 0


def cmd_estimate(args: argparse.Namespace) -> int:
    from .estimators import make
    from .io import read_recording, write_text

    params = {}
    for tok in args.param or []:
        if "=" not in tok:
            raise InputError(f"--param expects key=value, got {tok!r}")
        k, _, v = tok.partition("=")
        params[k] = _parse_value(v)
    est = make(args.method, **params)
    rec = read_recording(args.recording)
    res = est.estimate(rec, x=args.x, y=args.y)
    payload = res.to_dict()
    payload["recording"] = str(args.recording)
    payload["estimator"] = repr(est)
    if args.json:
        write_text(args.json, json.dumps(payload, indent=2) + "\n")
    rows = [("method", res.method), ("value", f"{res.value:.6g} {res.units}"),
            ("decision", f"{res.decision} ({res.meaning})")]
    rows += [(k, f"{v:.6g}" if isinstance(v, float) else str(v))
             for k, v in payload["diagnostics"].items() if not isinstance(v, (list, dict))]
    w = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{w}}  {v}")
    return 0


def _parse_value(v: str):
    import yaml

    try:
        return yaml.safe_load(v)
    except yaml.YAMLError:
        return v


def cmd_replicate(args: argparse.Namespace) -> int:
    from .reports.replicate import replicate

    replicate(overrides=args.overrides)
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="stictionbench", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    s = sub.add_parser("simulate", help="simulate a closed loop and write t,SP,PV,OP,MV")
    s.add_argument("params", nargs="*",
                   help="case=NAME duration=SECONDS seed=N out=PATH.csv|.parquet and any "
                        "Hydra override key=value (controller.kc=0.5, valve=kano, ...)")
    s.set_defaults(func=cmd_simulate)

    e = sub.add_parser("estimate", help="run one estimator on a recording")
    e.add_argument("recording")
    e.add_argument("--method", required=True)
    e.add_argument("--x", default=None, help="first signal (default: the estimator's)")
    e.add_argument("--y", default=None, help="second signal (default: the estimator's)")
    e.add_argument("--param", action="append", metavar="KEY=VALUE")
    e.add_argument("--json", metavar="OUT", help="write the result as JSON")
    e.set_defaults(func=cmd_estimate)

    r = sub.add_parser("replicate", help="regenerate the paper's tables and figures")
    r.add_argument("overrides", nargs="*", help="Hydra overrides of conf/experiment/paper.yaml")
    r.set_defaults(func=cmd_replicate)
    for name in COMMAND_MODULES:
        import_module(name).add_command(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``stictionbench`` console script."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return int(args.func(args) or 0)
    except InputError as exc:
        msg = " ".join(str(exc).split())
        print(f"stictionbench: error: {msg}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("stictionbench: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
