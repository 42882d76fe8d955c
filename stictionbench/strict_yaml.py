"""YAML input files read strictly: a key given twice in one mapping is an error.

PyYAML's safe loader keeps the last of two equal keys without a word, so a model with two
``gain`` lines, or a consensus file with two ``threshold`` lines, would be read with one of
them. Used for every YAML file a user hands the command line (``diagnose --model``,
``batch --consensus``).
"""

from __future__ import annotations

from typing import Any

import yaml


class UniqueKeyLoader(yaml.SafeLoader):
    """PyYAML's safe loader, refusing a key given twice in one mapping."""

    def construct_mapping(self, node, deep=False):  # type: ignore[no-untyped-def]
        seen: set = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} appears twice", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


def load(text: str) -> Any:
    """``yaml.safe_load`` with :class:`UniqueKeyLoader` (raises ``yaml.YAMLError`` on a
    repeated key, as on any other malformed document).

    >>> load("a: 1\\nb: 2")
    {'a': 1, 'b': 2}
    """
    return yaml.load(text, Loader=UniqueKeyLoader)  # noqa: S506 (a SafeLoader subclass)
