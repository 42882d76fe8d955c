"""``stictionbench diagnose REC.csv [--model MODEL.yaml] --json OUT.json [--report DIR]``."""

from __future__ import annotations

import argparse
import json
import math

from ..errors import InputError, user_warning


def cmd_diagnose(args: argparse.Namespace) -> int:
    from ..io import write_text
    from ..op_range import check_op_range, given_range
    from ..realdata.datasets import read_one, source_keys
    from ..validation import check_writable, refuse_overwrite
    from .diagnose import RESOLUTION_FLOOR, WARNING_KEYS, diagnose
    from .model import load_model
    from .refit import PROCESS_REFIT
    from .routes import DRIVE_CHECK

    if not args.json:
        raise InputError("diagnose needs --json OUT.json")
    refuse_overwrite([args.json, args.report], [args.recording, args.model])
    check_writable([args.json], [args.report])
    model = load_model(args.model) if args.model else None
    rec = read_one(args.recording, loop=args.loop)
    if model is not None and model.sample_time and not math.isclose(
            model.sample_time, rec.Ts, rel_tol=0.01):
        user_warning(f"{args.model}: sample_time {model.sample_time:g} s differs from the "
                     f"recording's {rec.Ts:g} s{_unit_hint(rec.Ts / model.sample_time)}; "
                     "the model is continuous-time and is used as given")
    op_range = None
    if args.op_range:
        op_range = given_range(*args.op_range, "--op-range")
        check_op_range(rec.OP, op_range, "--op-range")
    elif model is not None and model.op_range is not None:
        check_op_range(rec.OP, model.op_range, f"{args.model}: op_range")
    if args.linear_input_gate is not None and model is None:
        flag = "--linear-input-gate" if args.linear_input_gate else "--no-linear-input-gate"
        raise InputError(f"{flag} needs --model: it tests a valve against a given model")
    if args.test_highpass_order != 2 and model is None:
        raise InputError("--test-highpass-order needs --model: without one the "
                         "comparison keeps its zero-phase band")
    if args.intersample is not None and model is None:
        flag = "--intersample" if args.intersample else "--no-intersample"
        raise InputError(f"{flag} needs --model: it reconstructs the OP of a given model's "
                         "controller between samples")
    if args.detection and model is not None:
        raise InputError("--detection is for a recording without --model: with a model "
                         "the diagnosis tests the valve against it")
    if args.line_test and model is None:
        raise InputError("--line-test needs --model: it tests the residual of a given "
                         "model for a line")
    floor = RESOLUTION_FLOOR if args.resolution_floor is None else args.resolution_floor
    if not (floor >= 0 and math.isfinite(floor)):
        raise InputError(f"--resolution-floor: expected a validation NRMSE >= 0, got {floor}")
    if args.process_refit and model is None:
        raise InputError("--process-refit needs --model: it re-identifies a given model's "
                         "process")
    if args.slip_jump_bootstrap < 0:
        raise InputError(f"--slip-jump-bootstrap: expected a number of null recordings "
                         f">= 0, got {args.slip_jump_bootstrap}")
    d = diagnose(rec, model, op_range=op_range, slip_jump_bootstrap=args.slip_jump_bootstrap,
                 bootstrap_seed=args.bootstrap_seed,
                 linear_input_gate=args.linear_input_gate is not False,
                 test_highpass_order=args.test_highpass_order,
                 test_noise_family=args.test_noise_family, line_test=args.line_test,
                 intersample=args.intersample is not False, resolution_floor=floor,
                 detection=args.detection, pairing_check=args.pairing_check,
                 drive_check=DRIVE_CHECK if args.drive_check is None else args.drive_check,
                 process_refit=(PROCESS_REFIT if args.process_refit is None
                                else args.process_refit))
    payload = d.to_json()
    payload.update(source_keys(args.recording, rec))
    try:  # serialised before anything is written: no report without its JSON
        text = json.dumps(payload, indent=2, allow_nan=False, default=_safe) + "\n"
    except ValueError:
        raise InputError(f"{args.recording}: the diagnosis produced non-finite numbers "
                         "(values or times too large for its arithmetic?)") from None
    if args.report:
        # the figures' plotting stack is imported only when asked for (about 0.6 s of
        # a 3000-sample diagnosis's 3 s otherwise; benchmarks/test_bench_cli.py)
        from ..io import atomic_directory
        from .report import write_report

        with atomic_directory(args.report) as stage:  # every figure and summary, or none
            write_report(d, stage)
    write_text(args.json, text)
    f = d.fit
    params = ", ".join(f"{k}={v:.3g}" for k, v in d.parameters.items())
    print(f"{args.recording}: {d.missing_physics}" + (f" ({params})" if params else "")
          + f"; validation NRMSE {f['nominal']:.3f} -> {f['improved']:.3f}; "
          f"model {d.model.source}; {d.details['seconds']:.1f} s")
    for key in WARNING_KEYS:
        if d.details.get(key):
            user_warning(d.details[key])
    return 0


#: ratios of the recording's step to the model's sample time that say ``t`` was written in
#: another unit than the model's seconds (a 1 s sampling logged in ms steps by 1000)
UNIT_RATIOS = {1000.0: "milliseconds", 1 / 60: "minutes", 1 / 3600: "hours"}


def _unit_hint(ratio: float) -> str:
    """`` (is t in milliseconds?)`` when ``ratio`` (recording step / model sample time) is
    within 1 % of one of :data:`UNIT_RATIOS`, else ``""``.

    Examples
    --------
    >>> _unit_hint(1000.0), _unit_hint(1 / 60), _unit_hint(60.0)
    (' (is t in milliseconds?)', ' (is t in minutes?)', '')
    """
    for r, unit in UNIT_RATIOS.items():
        if math.isclose(ratio, r, rel_tol=0.01):
            return f" (is t in {unit}?)"
    return ""


def _safe(o):
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON-serialisable: {type(o).__name__}")


def add_command(sub) -> None:
    p = sub.add_parser("diagnose", help="locate and explain the gap between a nominal "
                                        "model and a recording")
    p.add_argument("recording", help="CSV/Parquet with t, PV, OP (SP, MV optional), or an "
                                     "ISDB-layout .mat file (with --loop)")
    p.add_argument("--loop", metavar="NAME",
                   help="the loop of a .mat file holding several: its book name (CHEM10) "
                        "or sector.loopN (chemicals.loop10)")
    p.add_argument("--model", help="nominal model YAML (identified from the data if absent)")
    p.add_argument("--json", required=False, metavar="OUT.json",
                   help="write the diagnosis here (required)")
    p.add_argument("--report", metavar="DIR", help="write figures and summary.md here")
    p.add_argument("--op-range", nargs=2, type=float, metavar=("LO", "HI"),
                   help="OP's 0 and 100 %% in its own units, for the valve characteristic "
                        "(default: the model's op_range, else per cent or a fraction "
                        "recognised from the data, else that hypothesis is not tested)")
    p.add_argument("--slip-jump-bootstrap", type=int, default=0, metavar="B",
                   help="decide stiction against dead band by a closed-loop parametric "
                        "bootstrap of the slip-jump test with B >= 19 null recordings "
                        "(needs --model with kc, ti and a set point; about 0.4 s each); "
                        "default 0: the chi-square test")
    p.add_argument("--bootstrap-seed", type=int, default=0, metavar="SEED",
                   help="seed of the bootstrap's resampling (default 0)")
    p.add_argument("--linear-input-gate", action=argparse.BooleanOptionalAction,
                   default=None,
                   help="with --model, name a dead band or stiction only where it also "
                        "beats the model with a linear four-tap FIR on OP (a PI faster "
                        "than the historian, a load OP answers); on by default with a "
                        "model, --no-linear-input-gate for the earlier rule")
    p.add_argument("--test-highpass-order", type=int, default=2, choices=(0, 1, 2),
                   metavar="{0,1,2}",
                   help="with --model, the high-pass order of the output errors the "
                        "likelihood-ratio tests whiten: 2 (default) the comparison band's, "
                        "1 first order, 0 none (an integrated noise model does the "
                        "differencing; fewer healthy loops called faulty, less physics "
                        "named)")
    p.add_argument("--test-noise-family", choices=("ar", "arma"), default="ar",
                   help="the family of the likelihood tests' noise model: ar (default) "
                        "an AR or integrated AR model; arma also ARMA / ARIMA models of "
                        "low order by BIC, the fits keeping AR models (whiter innovations; "
                        "the verdicts about unchanged on six fresh benchmark sets, "
                        "reports/concealed/arma_tests.md)")
    p.add_argument("--line-test", action="store_true",
                   help="with --model, scan the nominal residual for a line by Thomson's "
                        "harmonic F-test (tests.harmonic_line): a significant line seeds "
                        "the oscillatory disturbance's fit and, at the fitted period, "
                        "replaces its 10%% NRMSE gate by any improvement (off by default; "
                        "reports/concealed/harmonic_line.md)")
    p.add_argument("--intersample", action=argparse.BooleanOptionalAction, default=None,
                   help="with a model whose controller.sample_time is faster than the "
                        "recording, replay the PI's mean output between samples, "
                        "reconstructed from its law, in place of the recorded OP "
                        "(details.intersample; on by default, --no-intersample replays "
                        "the recorded OP; reports/concealed/intersample_op.md)")
    p.add_argument("--resolution-floor", type=float, default=None, metavar="NRMSE",
                   help="answer none where the nominal model's validation NRMSE is below "
                        "this (default 0.005, diagnose.RESOLUTION_FLOOR: the model explains "
                        "PV to within 0.5 %% of its spread; 0 turns it off; "
                        "details.resolution_floor; reports/concealed/resolution_floor.md)")
    p.add_argument("--detection", action="store_true",
                   help="without --model, also run the published detectors of batch's "
                        "consensus (less the Hammerstein detector, the fit's own kind) "
                        "and name stiction where they find a sticky valve and the "
                        "stiction fit's slip jump J has an interval excluding 0 "
                        "(tests.detection; off by default: it names more ISDB stiction "
                        "loops but renames healthy and other simulated loops too, "
                        "reports/diagnose/detection_independent.md)")
    p.add_argument("--pairing-check", action="store_true",
                   help="answer none where OP and PV are independent by Haugh's test "
                        "(tests.op_pv_dependence, always given with a warning: a tag of "
                        "another loop, or a frozen PV); off by default: on "
                        "wrong-tag recordings it halved the physics named with a model, not "
                        "quite without one (reports/diagnose/pairing_check.md)")
    p.add_argument("--drive-check", action=argparse.BooleanOptionalAction, default=None,
                   help="answer none where OP does not drive PV: OP leads PV at no lag by "
                        "one direction of Haugh's test (tests.op_pv_dependence.op_drives_pv, "
                        "always given): a valve at rest, a controller whose output goes "
                        "elsewhere, but also a regulatory loop whose valve moves PV, whose "
                        "OP only the controller moves (default: off; reports/diagnose/"
                        "op_drives_pv.md, drive_check_regulation.md)")
    p.add_argument("--process-refit", action=argparse.BooleanOptionalAction, default=None,
                   help="with --model, where a valve is named: re-identify the model's "
                        "process from the recording and diagnose again; a warning where "
                        "the valve is then not named (it may be the model's own error; "
                        "details.process_refit; default: off, about 1-2 s more; "
                        "reports/concealed/process_refit_gate.md)")
    p.set_defaults(func=cmd_diagnose)
