"""The FOPDT identification's two criteria (``stictionbench.diagnosis.process``)."""

from __future__ import annotations

import numpy as np
import pytest

from stictionbench.diagnosis.openloop import fopdt_response
from stictionbench.diagnosis.process import CRITERIA, fit_fopdt, fit_fopdt_pem


def _open_loop(seed: int, drift: float) -> tuple[np.ndarray, np.ndarray]:
    """An open-loop FOPDT (K 2, τ 10 s, θ 4 s) driven by a random binary OP, white PV
    noise, and a random-walk load of step size ``drift``."""
    rng = np.random.default_rng(seed)
    n = 2000
    u = np.repeat(rng.choice([-1.0, 1.0], n // 20), 20)
    y = 2.0 * fopdt_response(u, 1.0, 10.0, 4.0)
    y = y + 0.05 * rng.standard_normal(n) + drift * np.cumsum(rng.standard_normal(n))
    return u, y


@pytest.mark.parametrize("criterion", CRITERIA)
def test_both_criteria_recover_an_open_loop_fopdt(criterion):
    u, y = _open_loop(0, 0.0)
    K, tau, theta = fit_fopdt(u, y, 1.0, criterion=criterion)
    assert K == pytest.approx(2.0, rel=0.05)
    assert tau == pytest.approx(10.0, rel=0.1)
    assert theta == pytest.approx(4.0, abs=0.6)


def test_prediction_error_takes_a_drifting_load():
    # the integrated noise model takes the random walk the output error has to explain
    u, y = _open_loop(1, 0.05)
    K, tau, theta = fit_fopdt_pem(u, y, 1.0)
    assert K == pytest.approx(2.0, rel=0.1)
    assert tau == pytest.approx(10.0, rel=0.2)
    assert theta == pytest.approx(4.0, abs=1.0)


def test_unknown_criterion_is_refused():
    u, y = _open_loop(0, 0.0)
    with pytest.raises(ValueError, match="criterion must be one of"):
        fit_fopdt(u, y, 1.0, criterion="maximum_likelihood")


def test_prediction_error_beats_the_output_error_under_a_drifting_load():
    # summed relative errors of (K, τ, θ) over four draws: the integrated noise model
    # takes the drift that the output error's fixed high-pass leaves in
    def err(est):
        K, tau, theta = est
        return abs(K / 2.0 - 1) + abs(tau / 10.0 - 1) + abs(theta / 4.0 - 1)

    draws = [_open_loop(seed, 0.05) for seed in range(4)]
    pem = sum(err(fit_fopdt(u, y, 1.0, criterion="prediction_error")) for u, y in draws)
    oe = sum(err(fit_fopdt(u, y, 1.0)) for u, y in draws)
    assert pem < 0.5 * oe
