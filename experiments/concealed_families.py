"""Generator families of the concealed-data benchmark (``experiments/concealed.py``).

Three independent ways of making a closed-loop recording ``t, SP, PV, OP`` at 1 s (MV is
never written) in which exactly one physical effect is hidden:

``sim_physical``
    :mod:`stictionbench.sim` (numba kernel): PI every 0.2 s, valve and process in 0.01 s
    sub-steps; stiction from Choudhury's *physical* force-balance valve (S, J are its
    quasi-static equivalents), dead band from the play operator, white measurement noise,
    a stationary random-walk-through-lag load.
``sim_he``
    :mod:`stictionbench.sim` with He et al.'s (2007) two-layer stiction model, and the
    same model with ``J = 0`` (``fs = fd``) for the dead band; PI every 0.5 s;
    white noise; the recorded PV and OP quantised by a historian (resolution half the
    noise standard deviation, 0.05 % of OP).
``lsim_choudhury``
    Written here and sharing no code with the simulator or the fitter: the loop stepped
    every 0.5 s with the process as a continuous FOPDT discretised by
    ``scipy.signal.cont2discrete`` (zero-order hold) and a delay line; Choudhury et
    al.'s (2005) two-parameter stiction model (its own flowchart: after any stop, the
    valve needs ``S`` of OP travel); coloured AR(1) measurement noise seen by the
    controller; an integrated random-walk load plus random step loads.

Effect sizes are drawn from a continuous ``effect`` in [0, 1] (level 1: 0.4–1, level 2:
0–0.5): barely detectable to large. Measurement noise is 1–10 % of the mean set-point
step (level 1: 1–4 %, level 2: 3–10 %); oscillatory disturbances have periods of 2–50
closed-loop time constants.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import cont2discrete

from stictionbench.diagnosis import NominalModel
from stictionbench.sim import simulate
from stictionbench.sim.valves import PhysicalValve

FAMILIES = ("sim_physical", "sim_he", "lsim_choudhury")
CLASSES = ("none", "stiction", "deadband", "sensor_lag", "dead_time", "valve_characteristic",
           "saturation", "oscillatory_disturbance")
DURATION = 3000.0
PHYS = PhysicalValve()


@dataclass
class Case:
    """One drawn recording: plant, controller, effect and its truth."""

    family: str
    cls: str
    level: int
    seed: int
    K: float
    tau: float
    theta: float
    kc: float
    ti: float
    lam_cl: float
    steps: list[tuple[float, float]]
    noise: float
    noise_frac: float
    load: float
    effect: float
    truth: dict = field(default_factory=dict)


def draw(family: str, cls: str, level: int, seed: int) -> Case:
    """Plant, SIMC-tuned PI, set-point steps, noise, load and effect of one recording."""
    rng = np.random.default_rng([FAMILIES.index(family), CLASSES.index(cls), level, seed])
    K, tau, theta = rng.uniform(0.5, 3.0), rng.uniform(5.0, 40.0), rng.uniform(1.0, 12.0)
    lam = theta * rng.uniform(0.8, 2.0)
    kc, ti = tau / (K * (lam + theta)), min(tau, 4 * (lam + theta))
    t, steps = 20.0, []
    while t < DURATION - 100:
        steps.append((round(t, 1), float(rng.choice([-1, 1]) * K * rng.uniform(2, 6))))
        t += rng.uniform(150, 400)
    mean_step = float(np.mean([abs(s) for _, s in steps]))
    noise_frac = rng.uniform(0.01, 0.04) if level == 1 else rng.uniform(0.03, 0.10)
    effect = rng.uniform(0.4, 1.0) if level == 1 else rng.uniform(0.0, 0.5)
    load = mean_step * (rng.uniform(0.05, 0.2) if level == 1 else rng.uniform(0.3, 1.0))
    c = Case(family, cls, level, seed, K, tau, theta, kc, ti, lam + theta, steps,
             noise_frac * mean_step, noise_frac, load, effect)
    c.truth = _truth(c, rng)
    return c


def nominal_model(c: Case) -> NominalModel:
    """The nominal model the diagnosis is given: the case's plant and PI at the six
    significant digits of the benchmark's model YAML (``concealed.generate``), so that a
    re-generated recording is diagnosed exactly as in the benchmark."""
    K, tau, theta, kc, ti = (float(f"{v:.6g}") for v in (c.K, c.tau, c.theta, c.kc, c.ti))
    return NominalModel(K, tau, theta, kc, ti, 1.0)


def _truth(c: Case, rng: np.random.Generator) -> dict:
    e = c.effect
    if c.cls == "stiction":
        S = 0.5 + 5.5 * e
        return {"S": S, "J": S * rng.uniform(0.3, 0.9)}
    if c.cls == "deadband":
        return {"deadband": 0.5 + 4.5 * e}
    if c.cls == "sensor_lag":
        return {"time_constant": c.tau * (0.2 + 1.0 * e)}
    if c.cls == "dead_time":
        return {"dead_time": c.theta + c.theta * (0.3 + 1.2 * e) + 1.0}
    if c.cls == "valve_characteristic":
        return {"rangeability": 5.0 + 45.0 * e}
    if c.cls == "saturation":
        return {"quantile": 0.95 - 0.25 * e}
    if c.cls == "oscillatory_disturbance":
        return {"period": float(c.lam_cl * math.exp(rng.uniform(math.log(2), math.log(50)))),
                "amplitude": float(c.noise / max(c.noise_frac, 1e-9) * (0.05 + 0.5 * e))}
    return {}


def _sim_overrides(c: Case, controller_s: float | None = None,
                   characteristic: str = "equal_percentage") -> list[str]:
    rate = controller_s or (0.2 if c.family == "sim_physical" else 0.5)
    ov = {"process.gain": c.K, "process.time_constant": c.tau, "process.dead_time": c.theta,
          "controller.kc": c.kc, "controller.ti": c.ti, "controller.sample_time": rate,
          "sensor": "noisy", "sensor.time_constant": 0.0, "sensor.noise_std": c.noise,
          "valve": "linear", "disturbance": "load", "disturbance.load_std": c.load,
          "disturbance.load_time_constant": 500.0}
    tr = c.truth
    if c.cls == "stiction":
        if c.family == "sim_physical":
            Fs, Fc = PHYS.friction_for(tr["S"], tr["J"])
            ov.update({"valve": "physical", "valve.Fs": Fs, "valve.Fc": Fc})
        else:
            ov.update({"valve": "he", "valve.S": tr["S"], "valve.J": tr["J"]})
    elif c.cls == "deadband":
        if c.family == "sim_physical":
            ov.update({"valve": "deadband", "valve.deadband": tr["deadband"]})
        else:
            # He's model with J = 0 (fs = fd): a dead band under any input. Choudhury's
            # model with J = 0 is one only for a smooth input: under a noisy OP a reversal
            # arms the full band S in both directions, and a return the original way
            # slips with a jump (tests/test_valves.py), so it is not a dead band here
            ov.update({"valve": "he", "valve.S": tr["deadband"], "valve.J": 0.0})
    elif c.cls == "sensor_lag":
        ov["sensor.time_constant"] = tr["time_constant"]
    elif c.cls == "dead_time":
        ov["process.dead_time"] = tr["dead_time"]
    elif c.cls == "valve_characteristic":
        ov.update({"valve.characteristic": characteristic,
                   "valve.rangeability": tr["rangeability"]})
    elif c.cls == "oscillatory_disturbance":
        ov.update({"disturbance.amplitude": tr["amplitude"], "disturbance.period": tr["period"]})
    out = [f"{k}={v}" for k, v in ov.items()]
    out.append("setpoint=constant")
    out.append("setpoint.steps=[" + ",".join(f"[{a},{b:.6g}]" for a, b in c.steps) + "]")
    return out


def _simulate_family(c: Case, controller_s: float | None = None,
                     characteristic: str = "equal_percentage",
                     quantise: bool = True) -> dict[str, np.ndarray]:
    sim_seed = 10_000 * FAMILIES.index(c.family) + 1000 * c.level + c.seed
    ov = _sim_overrides(c, controller_s, characteristic)
    if c.cls == "saturation":
        base = simulate("linear", duration=DURATION, seed=sim_seed, sample_time=1.0,
                        overrides=ov)
        hi = float(np.quantile(base.OP, c.truth.pop("quantile")))
        c.truth["op_high"] = hi
        ov = ov + [f"valve.travel_high={hi}"]
    rec = simulate("linear", duration=DURATION, seed=sim_seed, sample_time=1.0, overrides=ov)
    pv, op = np.asarray(rec.PV, float), np.asarray(rec.OP, float)
    if c.family == "sim_he" and quantise:
        q = 0.5 * c.noise
        pv, op = np.round(pv / q) * q, np.round(op / 0.05) * 0.05
    # MV (the valve position) is returned for checks that need the truth; the benchmark
    # never writes it (``concealed.write_job`` keeps t, SP, PV, OP)
    return {"t": np.asarray(rec.t, float), "SP": np.asarray(rec.SP, float), "PV": pv, "OP": op,
            "MV": np.asarray(rec.MV, float)}


# ---------------------------------------------------------------- the independent loop
def choudhury_valve_step(x: float, state: dict, S: float, J: float) -> float:
    """Choudhury, Thornhill & Shah (2005) two-parameter stiction model, one step.

    The valve sticks whenever the input's velocity changes sign or vanishes; it slips
    once the input has moved more than ``S`` from where it stuck, to ``x − d·(S − J)/2``.
    """
    v = x - state["x_prev"]
    if v * state["v_prev"] <= 0.0 or v == 0.0:
        if not state["stuck"]:
            state["stuck"], state["x_ss"] = True, state["x_prev"]
    if state["stuck"] and abs(x - state["x_ss"]) > S:
        state["stuck"] = False
    if not state["stuck"]:
        d = 1.0 if x > state["x_ss"] else -1.0
        state["y"] = x - d * (S - J) / 2.0
    state["x_prev"] = x
    if v != 0.0:
        state["v_prev"] = v
    return state["y"]


def _valve(c: Case, op: float, vs: dict) -> float:
    tr = c.truth
    if c.cls == "stiction":
        return choudhury_valve_step(op, vs, tr["S"], tr["J"])
    if c.cls == "deadband":
        h = tr["deadband"] / 2.0
        vs["y"] = min(max(vs["y"], op - h), op + h)
        return vs["y"]
    if c.cls == "saturation" and "op_high" in tr:
        return min(op, tr["op_high"])
    if c.cls == "valve_characteristic":
        return 100.0 * tr["rangeability"] ** (min(max(op, 0.0), 100.0) / 100.0 - 1.0)
    return op


def _lsim_loop(c: Case, rng: np.random.Generator) -> dict[str, np.ndarray]:
    h, rec_every = 0.5, 2
    n = int(DURATION / h) + 1
    theta = c.truth.get("dead_time", c.theta)
    Ad, Bd, *_ = cont2discrete((np.array([[-1.0 / c.tau]]), np.array([[c.K / c.tau]]),
                                np.eye(1), np.zeros((1, 1))), h, method="zoh")
    a, b = float(Ad[0, 0]), float(Bd[0, 0])
    delay = int(round(theta / h))
    sp_t = np.zeros(n)
    for ts, s in c.steps:
        sp_t[int(ts / h):] += s
    e_ar = np.zeros(n)
    w = rng.normal(size=n) * c.noise * math.sqrt(1 - 0.8 ** 2)
    e_ar[0] = w[0] / math.sqrt(1 - 0.8 ** 2)
    for k in range(1, n):
        e_ar[k] = 0.8 * e_ar[k - 1] + w[k]
    load = np.cumsum(rng.normal(size=n)) * c.load / math.sqrt(n / 4)
    for _ in range(3):
        load[int(rng.uniform(0.1, 0.9) * n):] += rng.normal() * c.load
    tr = c.truth
    if c.cls == "oscillatory_disturbance":
        load += tr["amplitude"] * np.sin(2 * math.pi * np.arange(n) * h / tr["period"])
    lag = math.exp(-h / tr["time_constant"]) if c.cls == "sensor_lag" else 0.0
    op0 = 50.0
    vs = {"x_prev": op0, "v_prev": 0.0, "stuck": True, "x_ss": op0, "y": op0}
    mv0 = _valve(c, op0, vs)
    buf = [mv0] * (delay + 1)
    x, ym, op, e_prev = 0.0, 0.0, op0, 0.0
    out = np.empty((n, 3))
    for k in range(n):
        pvm = ym + e_ar[k]
        out[k] = (sp_t[k], pvm, op)
        e = sp_t[k] - pvm
        if k:
            op = min(max(op + c.kc * ((e - e_prev) + h / c.ti * e), 0.0), 100.0)
        e_prev = e
        buf.append(_valve(c, op, vs))
        x = a * x + b * (buf.pop(0) - mv0)
        y = x + load[k]
        ym = lag * ym + (1 - lag) * y
    rows = out[::rec_every]
    return {"t": np.arange(rows.shape[0], dtype=float), "SP": rows[:, 0], "PV": rows[:, 1],
            "OP": rows[:, 2]}


def _lsim_family(c: Case) -> dict[str, np.ndarray]:
    seed = [FAMILIES.index(c.family), CLASSES.index(c.cls), c.level, c.seed, 7]
    if c.cls == "saturation":
        q = c.truth.pop("quantile")
        base = _lsim_loop(c, np.random.default_rng(seed))
        c.truth["op_high"] = float(np.quantile(base["OP"], q))
    return _lsim_loop(c, np.random.default_rng(seed))


def make_recording(family: str, cls: str, level: int, seed: int,
                   controller_s: float | None = None,
                   characteristic: str = "equal_percentage", quantise: bool = True
                   ) -> tuple[Case, dict[str, np.ndarray]]:
    """Draw a case of ``family`` and simulate it: ``(case, {t, SP, PV, OP})``.
    ``controller_s`` replaces the family's controller period and ``characteristic`` the
    ``valve_characteristic`` class's installed curve (``quick_opening``: concave; the
    two ``sim_`` families only; ``lsim_choudhury`` steps its whole loop every 0.5 s
    with its own equal-percentage valve); ``quantise=False`` leaves out ``sim_he``'s
    historian quantisation (the other families have none)."""
    c = draw(family, cls, level, seed)
    if family == "lsim_choudhury":
        if controller_s is not None or characteristic != "equal_percentage":
            raise ValueError("lsim_choudhury has no separate controller period and its "
                             "own valve characteristic")
        return c, _lsim_family(c)
    return c, _simulate_family(c, controller_s, characteristic, quantise)


def library_main(doc: str, path: str) -> None:
    """The command line of a module of shared pieces: ``--help`` shows its docstring;
    run without it, it says it is imported, not run (it has no experiment of its own)."""
    import argparse

    argparse.ArgumentParser(
        description=doc, epilog="A module of shared pieces: the experiments that import it "
        "run it.", formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    name = path.replace("\\", "/").rsplit("/", 1)[-1]
    print(f"experiments/{name} is imported by the experiments, not run; see --help",
          file=sys.stderr)
    raise SystemExit(2)


if __name__ == "__main__":
    library_main(__doc__, __file__)
