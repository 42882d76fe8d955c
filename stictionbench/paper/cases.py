"""The paper's four cases: simulate, apply the estimators, measure what the remarks say.

Reference: Govinda Kumar & Manoharan (``../shared/paper/``), section III (cases A–D,
Tables III–VI) and section V (Table VII).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from omegaconf import OmegaConf

from ..errors import InputError
from ..estimators import EstimateResult, make
from ..recording import Recording
from ..sim.compose import simulate
from ..validation import number, positive, whole_number

CASES = ("linear", "tight", "disturbance", "stiction")
NON_STICTION = ("linear", "tight", "disturbance")
CASE_TITLES = {
    "linear": "PI controller, linear valve",
    "tight": "tightly tuned controller",
    "disturbance": "oscillatory disturbance",
    "stiction": "valve stiction",
}
METHOD_TITLES = {"xcorr": "Cross-correlation", "xcum": "Cross-cumulant"}
TABLE_NUMBER = {"linear": 3, "tight": 4, "disturbance": 5, "stiction": 6}
PAPER_TABLE = {"linear": "III", "tight": "IV", "disturbance": "V", "stiction": "VI"}


@dataclass
class CaseResult:
    """One simulated case with every estimate and remark measure."""

    case: str
    rec: Recording
    xcorr: EstimateResult
    xcum: EstimateResult
    bic: EstimateResult
    ellipse: EstimateResult
    swings: int
    r2: float
    hysteresis: float


def error_swings(rec: Recording, window: float, fraction: float) -> tuple[int, float]:
    """Count swings of the control error after the first set-point step.

    A swing is a crossing of the error from below ``−h`` to above ``+h`` or back, with
    ``h = fraction × |step|``; returns ``(swings, step)``.

    Examples
    --------
    >>> t = np.arange(400.0)
    >>> sp = np.where(t >= 10, 60.0, 50.0)
    >>> pv = sp - 10 * np.exp(-(t - 10).clip(0) / 40) * np.cos((t - 10).clip(0) / 8)
    >>> error_swings(Recording.from_arrays(t, pv, pv, SP=sp), 250, 0.05)[0]
    5
    """
    sp = rec.signal("SP")
    jumps = np.flatnonzero(np.abs(np.diff(sp)) > 0)
    if jumps.size == 0:
        return 0, 0.0
    k0 = int(jumps[0]) + 1
    step = float(sp[k0] - sp[k0 - 1])
    k1 = int(jumps[1]) + 1 if jumps.size > 1 else sp.size
    k1 = min(k1, k0 + int(round(window / rec.Ts)))
    e = rec.PV[k0:k1] - sp[k0:k1]
    h = fraction * abs(step)
    state, swings = 0, 0
    for v in e:
        if v > h and state <= 0:
            swings, state = swings + 1, 1
        elif v < -h and state >= 0:
            swings, state = swings + 1, -1
    return swings, step


def linearity(op: np.ndarray, mv: np.ndarray) -> tuple[float, float]:
    """R² of the straight line MV = a + b·OP, and the MV–OP loop area per cycle as a
    fraction of the bounding box (0 for a single-valued characteristic)."""
    r = np.corrcoef(op, mv)[0, 1]
    area = 0.5 * abs(float(np.sum(op[:-1] * mv[1:] - op[1:] * mv[:-1])))
    n_cycles = max(1.0, half_cycles(op) / 2.0)
    box = float(np.ptp(op) * np.ptp(mv)) or 1.0
    return float(r * r), area / n_cycles / box


def half_cycles(x: np.ndarray) -> int:
    """Number of reversals of direction of ``x`` (flat stretches ignored)."""
    d = np.sign(np.diff(x))
    d = d[d != 0]
    return int(np.count_nonzero(np.diff(d) != 0))


def estimator_params(cfg: Any) -> dict[str, dict[str, Any]]:
    """``cfg.estimators`` of ``conf/experiment/paper.yaml`` as plain dicts."""
    return OmegaConf.to_container(cfg.estimators, resolve=True)  # type: ignore[return-value]


def check_config(cfg: Any) -> None:
    """Check the replication's config (``conf/experiment/paper.yaml`` with the user's
    overrides) where it is composed, before any case runs: the seed a whole number, the
    times positive, the remark thresholds numbers in range and each estimator's
    parameters accepted by that estimator (:func:`~stictionbench.estimators.make`).

    Raises
    ------
    InputError
        One line naming the key, e.g. ``seed: not a whole number ('abc')``.
    """
    whole_number("seed", cfg.seed)
    for key in ("duration", "sample_time", "servo_window"):
        positive(key, cfg[key])
    th = cfg.thresholds
    whole_number("thresholds.oscillation_swings", th.oscillation_swings, low=1)
    for key in ("swing_fraction", "linear_r2"):
        if number(f"thresholds.{key}", th[key], low=0.0, strict=True) > 1:
            raise InputError(f"thresholds.{key}: must be at most 1, got {th[key]!r}")
    number("thresholds.delay_samples", th.delay_samples, low=0.0)
    for name, params in estimator_params(cfg).items():
        if not isinstance(params, dict):
            raise InputError(f"estimators.{name}: expected a mapping of parameters, got "
                             f"{params!r}")
        make(name, **params)


def run_case(case: str, cfg: Any, seed: int | None = None, **overrides: Any) -> CaseResult:
    """Simulate one case and apply the paper's estimators and the remark measures."""
    rec = simulate(case, duration=float(cfg.duration),
                   seed=int(cfg.seed if seed is None else seed),
                   sample_time=float(cfg.sample_time), **overrides)
    est = estimator_params(cfg)
    xcorr = make("xcorr", **est["xcorr"]).estimate(rec, x="OP", y="MV")
    xcum = make("xcum", **est["xcum"]).estimate(rec, x="OP", y="MV")
    bic = make("bicoherence", **est["bicoherence"]).estimate(rec, x="PV")
    ell = make("ellipse", **est["ellipse"]).estimate(rec, x="OP", y="PV")
    th = cfg.thresholds
    swings, _ = error_swings(rec, float(cfg.servo_window), float(th.swing_fraction))
    r2, hyst = linearity(rec.OP, rec.MV)
    return CaseResult(case, rec, xcorr, xcum, bic, ell, swings, r2, hyst)
