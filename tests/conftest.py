"""Shared fixtures: where the read-only shared data lives, and skips when it is absent."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("STICTIONBENCH_SHARED", ROOT.parent / "shared"))
REFERENCE = SHARED / "reference" / "hosa"
DATA = SHARED / "data"


def require(path: Path) -> Path:
    """Return ``path`` or skip the test with the reason that it is absent."""
    if not path.exists():
        pytest.skip(f"shared data not present: {path} (set STICTIONBENCH_SHARED)")
    return path


@pytest.fixture
def reference_dir() -> Path:
    return require(REFERENCE)


@pytest.fixture
def data_dir() -> Path:
    return require(DATA)
