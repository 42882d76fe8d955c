"""Exceptions that the command line turns into a one-line message and exit code 2."""

from __future__ import annotations


class InputError(ValueError):
    """Bad input from a user: a file, a column, a config key or a parameter.

    The message is one short line that names the offending file, row, column or key.
    The command line prints it as ``stictionbench: error: <message>`` and exits with 2.
    """
