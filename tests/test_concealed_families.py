"""The concealed benchmark's generator families (``experiments/concealed_families.py``):
the factors the calibration check varies (``experiments/lr_calibration.py``)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import concealed_families as cf  # noqa: E402


def _on_grid(x: np.ndarray, q: float) -> bool:
    return bool(np.allclose(x / q, np.round(x / q), atol=1e-6))


def test_sim_he_quantisation_can_be_left_out_and_nothing_else_changes():
    c, q = cf.make_recording("sim_he", "none", 1, 0)
    _, raw = cf.make_recording("sim_he", "none", 1, 0, quantise=False)
    step = 0.5 * c.noise
    assert _on_grid(q["PV"], step) and _on_grid(q["OP"], 0.05)
    assert not _on_grid(raw["PV"], step)
    # the same simulation underneath: quantising the raw signals gives the recorded ones
    np.testing.assert_allclose(np.round(raw["PV"] / step) * step, q["PV"])
    np.testing.assert_array_equal(raw["MV"], q["MV"])


def test_lsim_family_has_no_separate_controller_period():
    with pytest.raises(ValueError, match="no separate controller period"):
        cf.make_recording("lsim_choudhury", "none", 1, 0, controller_s=1.0)
