"""The ``stictionbench`` command line.

Bad input ends with one line on stderr, ``stictionbench: error: <what and where>``, and
exit code 2; no traceback, no half-written output file.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from importlib import import_module

from .errors import InputError

EXIT_BAD_INPUT = 2

#: modules that add a sub-command: each has ``add_command(subparsers)`` which adds its
#: parser and sets ``func`` (one module per line)
COMMAND_MODULES: tuple[str, ...] = (
    "stictionbench.paper.command",
    "stictionbench.sim.command",
    "stictionbench.estimators.command",
    "stictionbench.diagnosis.command",
    "stictionbench.sweep.command",
    "stictionbench.realdata.command",
)


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse's own usage errors: exit 2, one line
        raise InputError(message)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="stictionbench", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
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
