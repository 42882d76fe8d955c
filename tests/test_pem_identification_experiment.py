"""experiments/pem_identification.py: its summary and its verdicts on the prediction."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))

import pem_identification as pe  # noqa: E402


def _frame(gain_by_estimator: dict[tuple[float, float, str], float]) -> pd.DataFrame:
    rows = []
    for (rate, sp, est), gain in gain_by_estimator.items():
        for valve in ("ideal", "kano S=2"):
            for seed in range(3):
                rows.append({"tau_samples": 8.0, "valve": valve, "seed": seed,
                             "controller_period_s": rate, "sp_step": sp, "estimator": est,
                             "gain": gain, "tau_s": 8.0, "theta_s": 1.0})
    return pd.DataFrame(rows)


def test_summary_and_verdicts_follow_the_gains():
    gains = {}
    for rate in (0.2, 1.0):
        gains[(rate, 0.0, "output_error")] = 0.1
        gains[(rate, 0.0, "prediction_error")] = -0.5  # wrong sign: error 5
        gains[(rate, 0.0, "pem_ari8")] = 1.1 if rate == 1.0 else 0.05
        for est in pe.ESTIMATORS:
            gains[(rate, pe.SP_STEP, est)] = 1.05
    tab = pe.summarise(_frame(gains))
    ideal = tab[(tab["valve"] == "ideal") & (tab["estimator"] == "prediction_error")
                & (tab["set-point steps"] == 0.0)]
    assert (ideal["gain error (median)"] == pe.BAD_SIGN).all()
    assert (tab[tab["set-point steps"] == pe.SP_STEP]["gain within ×1.5"] == "3/3").all()
    lines = pe.verdicts(tab)
    assert all("**held**" in line for line in lines)
    # a restricted noise model as wrong at the historian's rate fails prediction (2)
    gains[(1.0, 0.0, "pem_ari8")] = 0.05
    assert "**failed**" in pe.verdicts(pe.summarise(_frame(gains)))[1]


def test_restricted_noise_model_fit_recovers_an_open_loop_fopdt_under_drift():
    from stictionbench.diagnosis.openloop import fopdt_response

    rng = np.random.default_rng(0)
    u = np.repeat(rng.choice([-1.0, 1.0], 100), 20)
    y = 2.0 * fopdt_response(u, 1.0, 10.0, 4.0) + 0.05 * rng.standard_normal(u.size)
    # the integrated noise model is for a drifting load (it over-differences white noise)
    y += 0.05 * np.cumsum(rng.standard_normal(u.size))
    K, tau, theta = pe.fit_ari8(u, y, 1.0)
    assert abs(K - 2.0) < 0.1 and abs(tau - 10.0) < 1.0 and abs(theta - 4.0) < 0.6
