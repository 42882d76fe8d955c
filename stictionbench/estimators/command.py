"""``stictionbench estimate``: run one registered estimator on a recording.

The estimator is named either ``--method NAME`` with ``--param KEY=VALUE`` options, or
Hydra-style from ``conf/estimator/NAME.yaml``: ``estimator=xcum estimator.max_delay=50``.
Its declared parameters are checked before any work (exit 2 with one line otherwise).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from typing import Any

from ..errors import InputError
from .base import Estimator


def parse_value(v: str) -> Any:
    """A ``--param`` value parsed as YAML (``30`` → int, ``0.5`` → float, ``[1, 2]`` → list).

    Examples
    --------
    >>> parse_value("30"), parse_value("0.5"), parse_value("hann"), parse_value("[0.1, 0.2]")
    (30, 0.5, 'hann', [0.1, 0.2])
    """
    import yaml

    try:
        return yaml.safe_load(v)
    except yaml.YAMLError:
        return v


def from_config(overrides: Sequence[str]) -> Estimator:
    """Instantiate the estimator of ``conf/estimator/`` chosen by Hydra overrides
    (``estimator=xcum``, ``estimator.max_delay=50``)."""
    from hydra.errors import InstantiationException
    from hydra.utils import instantiate
    from omegaconf.errors import OmegaConfBaseException

    from ..config import compose

    for tok in overrides:
        if "=" not in tok or not tok.split("=", 1)[0].startswith("estimator"):
            raise InputError(f"expected estimator=NAME or estimator.KEY=VALUE, got {tok!r}")
    cfg = compose(list(overrides), config_name="estimate")
    if cfg.get("estimator") is None:
        raise InputError("name the estimator: estimator=NAME or --method NAME")
    try:
        est = instantiate(cfg.estimator, _convert_="all")
    except InstantiationException as exc:
        msg = str(exc).strip().splitlines()[-1]
        raise InputError(f"estimator config: {msg}") from None
    except OmegaConfBaseException as exc:  # e.g. an interpolation ${...} to no key
        msg = str(exc).strip().splitlines()[0]
        raise InputError(f"estimator config: {msg}") from None
    if not isinstance(est, Estimator):
        raise InputError(f"estimator config {cfg.estimator.get('_target_')!r} is not an "
                         "Estimator")
    est.check_params()
    return est


def build_estimator(method: str | None, params: Sequence[str] | None,
                    overrides: Sequence[str]) -> Estimator:
    """The estimator named by ``--method``/``--param`` or by Hydra ``overrides``."""
    from .registry import make

    if overrides:
        if method or params:
            raise InputError("give either --method/--param or estimator=... overrides, "
                             "not both")
        return from_config(overrides)
    if not method:
        raise InputError("name the estimator: --method NAME or estimator=NAME")
    kw: dict[str, Any] = {}
    for tok in params or []:
        if "=" not in tok:
            raise InputError(f"--param expects key=value, got {tok!r}")
        k, _, v = tok.partition("=")
        if k in kw:  # which one was meant? (a model YAML's repeated key is refused too)
            raise InputError(f"--param {k} given twice ({kw[k]!r} and {parse_value(v)!r}); "
                             "give it once")
        kw[k] = parse_value(v)
    return make(method, **kw)


def cmd_estimate(args: argparse.Namespace) -> int:
    """Run ``estimate``: print a table, optionally write the result as JSON."""
    from ..io import write_text
    from ..op_range import check_op_range, given_range
    from ..realdata.datasets import read_one, source_keys, with_meta
    from ..validation import check_writable, refuse_overwrite

    refuse_overwrite([args.json], [args.recording])
    check_writable([args.json])
    est = build_estimator(args.method, args.param, args.overrides)
    rec = read_one(args.recording, loop=args.loop)
    if args.op_range is not None:
        span = given_range(*args.op_range, "--op-range")
        check_op_range(rec.OP, span, "--op-range")
        rec = with_meta(rec, {"op_range": span})
    rec.signal(args.x or est.default_x)              # an unknown name is said before MV's absence
    yname = args.y or est.default_y
    pv_for_mv = getattr(est, "flow_loop", False) and args.y is None  # PV stands in
    if yname == "MV" and getattr(rec, "MV", None) is None and not pv_for_mv:
        # the paper's estimators compare OP with the valve position, which plants rarely
        # record: say what can be done instead of only what is missing
        flow = ("`--param flow_loop=true` on a flow loop (PV for MV), "
                if "flow_loop" in est.get_params() else "")
        raise InputError(f"{args.recording}: {est.name} compares {args.x or est.default_x} "
                         "with the valve position MV; MV is not recorded: use a method that "
                         "needs only OP and PV (horch, he, area_ratio, bicoherence, ...), "
                         f"{flow}or `diagnose`")
    res = est.estimate(rec, x=args.x, y=args.y)
    payload = res.to_dict()
    payload.update(source_keys(args.recording, rec))
    payload["estimator"] = repr(est)
    if args.json:
        write_text(args.json, json.dumps(payload, indent=2) + "\n")
    rows = [("method", res.method), ("value", f"{res.value:.6g} {res.units}"),
            ("decision", f"{res.decision} (True means: {res.meaning})" if res.meaning
             else str(res.decision))]
    rows += [(k, f"{v:.6g}" if isinstance(v, float) else str(v))
             for k, v in payload["diagnostics"].items() if not isinstance(v, (list, dict))]
    w = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{w}}  {v}")
    return 0


def add_command(sub: argparse._SubParsersAction) -> None:
    """Add the ``estimate`` sub-command."""
    e = sub.add_parser("estimate", help="run one estimator on a recording")
    e.add_argument("recording", help="CSV/Parquet with t, PV, OP (SP, MV optional), or an "
                                     "ISDB-layout .mat file (with --loop)")
    e.add_argument("--loop", metavar="NAME",
                   help="the loop of a .mat file holding several: its book name (CHEM10) "
                        "or sector.loopN (chemicals.loop10)")
    e.add_argument("overrides", nargs="*", metavar="estimator=NAME",
                   help="Hydra-style choice from conf/estimator/: estimator=xcum "
                        "estimator.max_delay=50 (instead of --method/--param)")
    e.add_argument("--method", default=None, metavar="NAME",
                   help="a registered estimator (xcorr, xcum, bicoherence, oscillation, "
                        "ellipse, horch, he, area_ratio, kano, yamashita, hagglund, ...)")
    e.add_argument("--x", default=None, help="first signal (default: the estimator's)")
    e.add_argument("--y", default=None, help="second signal (default: the estimator's)")
    e.add_argument("--param", action="append", metavar="KEY=VALUE",
                   help="an estimator parameter (repeat for several): --param max_delay=50")
    e.add_argument("--json", metavar="OUT", help="write the result as JSON")
    e.add_argument("--op-range", nargs=2, type=float, metavar=("LO", "HI"),
                   help="OP's 0 and 100 %% in its own units (4 20 for milliamps), for the "
                        "detectors' 'OP moved by 1 %%' (default: per cent or a fraction "
                        "recognised from OP, else 1 %% read as 1 unit)")
    e.set_defaults(func=cmd_estimate)
