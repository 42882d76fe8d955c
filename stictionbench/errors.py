"""Exceptions that the command line turns into a one-line message and exit code 2, and
the warnings it prints.

A command's warnings (:func:`user_warning`) are held while it runs
(:func:`held_warnings`): on success they are printed, one line each, after its result;
when the command then fails on bad input they are folded into its one error line, so a
user never sees a warning followed by an error, and a script reading stderr gets one
line.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator

#: the held warnings of the running command, or None (printed at once: library use)
_held: list[str] | None = None


class InputError(ValueError):
    """Bad input from a user: a file, a column, a config key or a parameter.

    The message is one short line that names the offending file, row, column or key.
    The command line prints it as ``stictionbench: error: <message>`` and exits with 2.
    """


def user_warning(message: str) -> None:
    """Print ``stictionbench: warning: <message>`` on stderr, or hold it while a command
    runs (:func:`held_warnings`)."""
    text = " ".join(str(message).split())
    if _held is not None:
        _held.append(text)
    else:
        print(f"stictionbench: warning: {text}", file=sys.stderr)


@contextlib.contextmanager
def held_warnings() -> Iterator[list[str]]:
    """Hold :func:`user_warning`'s messages in the yielded list for the ``with`` block."""
    global _held
    outer, _held = _held, []
    try:
        yield _held
    finally:
        _held = outer


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds like Ctrl-C: joblib's
    workers are shut down and no output file is left half-written; the command line
    exits 143 (128 + SIGTERM), not Ctrl-C's 130."""


def interrupt_cause(exc: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C or SIGTERM (:class:`Terminated`) that an exception was raised while
    handling, if any: a library that catches it (Hydra composing a config) raises its own
    error instead, which must not read as a failure of the run."""
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return cause
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return None
