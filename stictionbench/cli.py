"""The ``stictionbench`` command line.

Bad input ends with one line on stderr, ``stictionbench: error: <what and where>``, and
exit code 2; no traceback, no half-written output file.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import signal
import sys
import threading
import warnings
from collections.abc import Sequence
from importlib import import_module

from .errors import InputError, Terminated, held_warnings, interrupt_cause

EXIT_BAD_INPUT = 2
#: 128 + SIGPIPE, what a shell reports for a filter killed by a closed pipe
EXIT_BROKEN_PIPE = 141

#: modules that add sub-commands, each with the commands it adds: every module has
#: ``add_command(subparsers)`` which adds their parsers and sets ``func``. A command
#: line naming one of these commands imports only its module (the others pull in
#: simulation, Hydra and plotting stacks that take about a second to import);
#: ``tests/test_cli.py`` checks that each module adds exactly the commands listed here.
COMMAND_MODULES: dict[str, tuple[str, ...]] = {
    "stictionbench.paper.command": ("replicate",),
    "stictionbench.sim.command": ("simulate",),
    "stictionbench.estimators.command": ("estimate",),
    "stictionbench.diagnosis.command": ("diagnose",),
    "stictionbench.sweep.command": ("sweep",),
    "stictionbench.realdata.command": ("screen", "oscillation-benchmark", "batch",
                                       "compare"),
}


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        # A negative number in any float spelling (-1e3, -.5, -2.5E-1, -inf) is a value, not an
        # option: Python 3.11's argparse knows only -12 and -1.5, so `--op-range -1e3 100`
        # failed with "expected 2 arguments" (later Pythons widened the same pattern).
        self._negative_number_matcher = re.compile(
            r"^-((\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|[iI][nN][fF]([iI][nN][iI][tT][yY])?)$")

    def error(self, message: str) -> None:  # argparse's own usage errors: exit 2, one line
        raise InputError(message)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The CLI parser with every sub-command, or only ``command``'s when it is one of
    :data:`COMMAND_MODULES` (the others are then not imported)."""
    p = _Parser(prog="stictionbench", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    modules = [m for m, names in COMMAND_MODULES.items() if command in names] \
        or list(COMMAND_MODULES)
    for name in modules:
        import_module(name).add_command(sub)
    return p


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``stictionbench`` console script (SIGTERM handled as
    :class:`Terminated` while it runs; the previous handler restored after)."""
    _quiet_worker_cleanup()
    if threading.current_thread() is not threading.main_thread():
        return _main(argv)
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        return _main(argv)
    finally:
        signal.signal(signal.SIGTERM, previous)


#: joblib's process pool (loky) cleans up with a helper process that warns when a stopped
#: run's workers already removed what it was to remove: a line on stderr after the
#: command's own one-line message, telling the user nothing
WORKER_CLEANUP_WARNING = "ignore:resource_tracker:UserWarning"


def _quiet_worker_cleanup() -> None:
    """Pass :data:`WORKER_CLEANUP_WARNING` to the child processes (through
    ``PYTHONWARNINGS``, which they read at start), keeping any filter already set."""
    have = os.environ.get("PYTHONWARNINGS", "")
    if WORKER_CLEANUP_WARNING not in have.split(","):
        os.environ["PYTHONWARNINGS"] = ",".join(filter(None, [have, WORKER_CLEANUP_WARNING]))


def _main(argv: Sequence[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    held: list[str] = []
    try:
        # numerical warnings of numpy/scipy on extreme but accepted data are not the
        # user's business on the command line (one line per message is); the package's
        # own warnings are held and printed after the result (:func:`.errors.warn`)
        with warnings.catch_warnings(), held_warnings() as held:
            warnings.simplefilter("ignore", RuntimeWarning)  # numpy's ComplexWarning too
            # the sub-command is the first argument (the top level has no options of its
            # own but --help, which lists every sub-command)
            parser = build_parser(argv[0] if argv else None)
            args = parser.parse_args(argv)
            if getattr(args, "json", None) == "-":
                # the JSON alone on stdout (for a pipe into jq); what the command prints
                # besides goes to stderr
                code = _json_to_stdout(args)
            else:
                code = int(args.func(args) or 0)
            sys.stdout.flush()  # a closed pipe raises here, not at the interpreter's exit
        for w in held:
            print(f"stictionbench: warning: {w}", file=sys.stderr)
        return code
    except InputError as exc:
        return _error(" ".join(str(exc).split()), held)
    except BrokenPipeError:
        # the reader of stdout went away (``| head``): quiet, as Unix filters are; the
        # interpreter's final flush must not raise again (Python docs, "Note on SIGPIPE")
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as exc:  # a file that vanished or a disk that filled mid-run
        where = f"{exc.filename}: " if getattr(exc, "filename", None) else ""
        return _error(f"{where}{exc.strerror or exc}", held)
    except KeyboardInterrupt as exc:
        return _stopped(exc)
    except Exception as exc:
        # a library that caught the signal and raised its own error: still a stop
        if (stop := interrupt_cause(exc)) is None:
            raise
        return _stopped(stop)


def _stopped(exc: KeyboardInterrupt) -> int:
    """One line and the exit code of a run stopped by SIGTERM (143) or Ctrl-C (130)."""
    if isinstance(exc, Terminated):
        print("stictionbench: terminated", file=sys.stderr)
        return 128 + signal.SIGTERM
    print("stictionbench: interrupted", file=sys.stderr)
    return 130


def _json_to_stdout(args: argparse.Namespace) -> int:
    """Run the command with ``--json -``: its JSON on stdout, its other printing on
    stderr."""
    from . import io as sio

    sio.stdout_stream = sys.stdout
    try:
        with contextlib.redirect_stdout(sys.stderr):
            return int(args.func(args) or 0)
    finally:
        sio.stdout_stream = None


def _error(msg: str, held: list[str]) -> int:
    """The one error line, with the warnings the command had given before it failed."""
    after = f" (after: {'; '.join(held)})" if held else ""
    print(f"stictionbench: error: {msg}{after}", file=sys.stderr)
    return EXIT_BAD_INPUT


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
