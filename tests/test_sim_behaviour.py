"""Closed-loop behaviour of the paper's four cases (section III), shown on simulations."""

from __future__ import annotations

import numpy as np
import pytest

import stictionbench as sb
from stictionbench.errors import InputError


@pytest.fixture(scope="module")
def cases():
    return {c: sb.simulate(c, duration=1000.0, seed=0) for c in
            ("linear", "tight", "disturbance", "stiction")}


def _lag_s(x, y, Ts, max_lag_s=60.0):
    """Lag (s) of y behind x at the cross-correlation peak of the differenced signals."""
    dx = np.diff(x) - np.diff(x).mean()
    dy = np.diff(y) - np.diff(y).mean()
    m = int(max_lag_s / Ts)
    lags = np.arange(-m, m + 1)
    c = [np.dot(dx[max(0, -k): len(dx) - max(0, k)], dy[max(0, k): len(dy) - max(0, -k)])
         for k in lags]
    return lags[int(np.argmax(c))] * Ts


def _tail_amplitude(rec, t0, t1):
    m = (rec.t >= t0) & (rec.t < t1)
    e = rec.PV[m] - rec.SP[m]
    return np.ptp(e)


def _peaks(x):
    return np.flatnonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:])) + 1


def test_linear_case_settles(cases):
    rec = cases["linear"]
    # last 90 s before each set-point change: PV within 5 % of the 10-unit step
    for t_change in (260.0, 510.0, 760.0, 1010.0):
        assert _tail_amplitude(rec, t_change - 90, t_change) < 0.5


def test_tight_case_rings_then_decays(cases):
    rec = cases["tight"]
    m = (rec.t >= 10) & (rec.t < 260)
    e = rec.PV[m] - rec.SP[m]
    big = [p for p in _peaks(np.abs(e)) if abs(e[p]) > 1.0]
    assert len(big) >= 4  # at least four swings larger than 10 % of the step
    assert np.ptp(e[-300:]) < np.ptp(e[:1000])


def test_disturbance_case_oscillates_at_disturbance_period(cases):
    rec = sb.simulate("disturbance", duration=1000.0, seed=0, setpoint="constant")
    pv = rec.PV[2000:] - rec.PV[2000:].mean()
    spec = np.abs(np.fft.rfft(pv))
    f = np.fft.rfftfreq(pv.size, rec.Ts)
    assert 1 / f[np.argmax(spec[1:]) + 1] == pytest.approx(100.0, rel=0.05)
    assert np.ptp(pv) > 2.0


@pytest.mark.parametrize("case", ["tight", "disturbance"])
def test_mv_follows_co_without_lag(cases, case):
    rec = cases[case]
    assert abs(_lag_s(rec.OP, rec.MV, rec.Ts)) <= 1.0


def test_stiction_limit_cycle_stick_then_jump(cases):
    rec = cases["stiction"]
    # sustained oscillation: PV error large right before every set-point change
    for t_change in (260.0, 510.0, 760.0, 1010.0):
        assert _tail_amplitude(rec, t_change - 120, t_change) > 5.0
    dmv = np.abs(np.diff(rec.MV))
    assert np.mean(dmv < 1e-9) > 0.5          # the valve is stuck most of the time
    S, J = rec.meta["true_S"], rec.meta["true_J"]
    assert dmv.max() > 0.5 * J                # and moves in slip jumps
    # CO-MV plot is a parallelogram: the loop encloses an area ~ S x amplitude
    op, mv = rec.OP, rec.MV
    area = 0.5 * abs(np.sum(op[:-1] * mv[1:] - op[1:] * mv[:-1]))
    lin = cases["linear"]
    lin_area = 0.5 * abs(np.sum(lin.OP[:-1] * lin.MV[1:] - lin.OP[1:] * lin.MV[:-1]))
    assert area > 20 * lin_area
    assert S == pytest.approx(26.23, abs=0.01) and J == pytest.approx(11.24, abs=0.01)


def test_stiction_mv_lags_co(cases):
    rec = cases["stiction"]
    assert _lag_s(rec.OP, rec.MV, rec.Ts) > 2.0


def test_same_seed_same_output_and_noise_seeded():
    a = sb.simulate("linear", duration=300.0, seed=3, sensor="noisy")
    b = sb.simulate("linear", duration=300.0, seed=3, sensor="noisy")
    c = sb.simulate("linear", duration=300.0, seed=4, sensor="noisy")
    np.testing.assert_array_equal(a.PV, b.PV)
    assert not np.array_equal(a.PV, c.PV)


def test_overrides_and_errors():
    rec = sb.simulate("stiction", duration=300.0, valve="kano", valve__S=3.0, valve__J=1.0)
    assert rec.meta["config"]["valve"]["S"] == 3.0
    with pytest.raises(InputError, match="unknown case"):
        sb.simulate("nope", duration=300.0)
    with pytest.raises(InputError, match="unknown config key 'controller.bogus'"):
        sb.simulate("linear", duration=300.0, controller__bogus=1)
    with pytest.raises(InputError, match="duration"):
        sb.simulate("linear", duration=-1.0)
    with pytest.raises(InputError, match="process.time_constant"):
        sb.simulate("linear", duration=300.0, process__time_constant=0.0)
    with pytest.raises(InputError, match="fewer than 100 samples"):
        sb.simulate("linear", duration=5.0)


def test_fractional_dead_time_is_exact():
    """Open-loop check of the ZOH discretisation with a dead time off the step grid."""
    from stictionbench.sim.blocks import FOPDT

    p = FOPDT(gain=2.0, time_constant=5.0, dead_time=1.234).coefficients(0.1)
    K, a, w_old, w_new, d = p
    n = 200
    u = np.ones(n)  # unit step applied at t = 0
    y = np.zeros(n + 1)
    for k in range(n):
        uk_d = u[k - int(d)] if k - int(d) >= 0 else 0.0
        uk_d1 = u[k - int(d) - 1] if k - int(d) - 1 >= 0 else 0.0
        y[k + 1] = a * y[k] + K * (w_old * uk_d1 + w_new * uk_d)
    t = np.arange(n + 1) * 0.1
    exact = np.where(t > 1.234, 2.0 * (1 - np.exp(-(t - 1.234) / 5.0)), 0.0)
    np.testing.assert_allclose(y, exact, atol=1e-12)
