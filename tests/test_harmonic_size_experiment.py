"""The line scan's size-and-power experiment (``experiments/harmonic_size.py``): its
cells, seeds and noise kinds do what its docstring says."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import harmonic_size as hs  # noqa: E402


def test_every_cell_has_its_own_seed_and_the_bands_come_last():
    todo = hs.cases(2, 2)
    seeds = [c[6] for c in todo]
    assert len(set(seeds)) == len(todo)
    assert len(todo) == (len(hs.NOISES) * len(hs.LENGTHS) * len(hs.NWS)
                         + len(hs.POWER_NOISES) * len(hs.LENGTHS) * len(hs.NWS)
                         * len(hs.AMPLITUDES) + 2 * len(hs.AMPLITUDES) * 2)
    assert {c[7] for c in todo if c[0] == "band"} == {"short", "long"}


@pytest.mark.parametrize("kind", hs.NOISES)
def test_noise_is_standardised(kind):
    x = hs.noise(kind, 800, np.random.default_rng(0))
    assert x.size == 800 and abs(x.mean()) < 1e-9 and abs(x.std() - 1) < 1e-9


def test_unknown_noise_is_refused():
    with pytest.raises(ValueError):
        hs.noise("pink", 100, np.random.default_rng(0))


def test_a_strong_line_is_found_and_white_noise_rarely_flagged():
    found = hs.cell("power", "white", 600, 4.0, 2.0, 12, 1)
    assert found["rate"] == 1.0 and found["lo"] <= 1.0 <= found["hi"]
    size = hs.cell("size", "white", 600, 4.0, 0.0, 40, 2)
    assert size["rate"] <= 0.15
    # the same seed gives the same cell
    assert hs.cell("size", "white", 600, 4.0, 0.0, 40, 2) == size
