"""Everything under benchmarks/ is a pytest-benchmark suite: marked so `make test` skips it."""

import pytest


def pytest_collection_modifyitems(items):
    for item in items:
        item.add_marker(pytest.mark.benchmark)
