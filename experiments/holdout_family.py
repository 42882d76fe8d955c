"""A fourth generator family held out of all tuning: the shipped defaults scored on it.

The three families of ``experiments/concealed.py`` set the diagnosis's thresholds (pooled)
and give its leave-one-family-out numbers; they share one draw of plant, tuning, set-point
steps and effect sizes (:func:`concealed_families.draw`) and their controllers run 2–5 ×
faster than the 1 s historian. This family changes what those hold fixed and was never
used to choose anything:

- **loop**: written here, sharing no code with the simulator or the fitter. The PI runs
  every 1 s, *in step with the historian* (velocity form, OP held between updates); the
  process is a FOPDT integrated exactly in 0.1 s sub-steps with its dead time as a delay
  line, so PV between controller instants is continuous;
- **plant and tuning**: gain 0.3–5, time constant 3–120 s and dead time 5–80 % of it
  (log-uniform; at least 1 s), lambda tuning ``kc = τ/(K(λ + θ))``, ``ti = τ`` with λ
  0.5–2 τ (slower loops than SIMC's), set-point steps every 200–600 s;
- **valves**: each sticky valve is one of Kano et al.'s (2004), He et al.'s (2007) or
  Choudhury et al.'s (2005) two-parameter models, drawn per recording, with ``J/S``
  0.2–1 (Kano's and He's written again here from the papers' descriptions; Choudhury's
  step is the one of the ``lsim_choudhury`` tuning family,
  :func:`concealed_families.choudhury_valve_step`); each dead band is a play operator
  (backlash);
- **disturbances**: white measurement noise (1–4 % of the mean set-point step at level 1,
  3–10 % at level 2) and an integrated random-walk load (its spread 5–20 % of a step at
  level 1, 30–100 % at level 2), as in the issue's description of the independent set.

Every recording is diagnosed exactly as a user would (CSV + model YAML, the package's
default thresholds). Outputs: ``reports/concealed/holdout.md`` and ``holdout.csv``.

Run: ``.venv/bin/python experiments/holdout_family.py [--seeds 4] [--none-seeds 8]
[--first-seed 0] [--name holdout]``. ``make concealed`` runs it twice: at seeds 0–3
(``none`` 0–7: ``holdout.md``, the recordings several rules were checked on, see the
report) and at seeds from 21000 (``holdout_fresh.md``: seeds no experiment had drawn when
that report was written, 12 per class and level, 24 for ``none``; the blocks from 1000
to 19000 were looked at first, see :data:`SEEN_FRESH`; 7000 is ``slow_line.py``'s, 20000
``slow_loops.py``'s).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from concealed import (  # noqa: E402
    miss_reason,
    parameter_error,
    run_one,
    timing_line,
    write_job,
)
from concealed_families import CLASSES, DURATION, Case, choudhury_valve_step  # noqa: E402

from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import balanced_score, rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

FAMILY = "holdout_sync"
#: what was looked at on seeds 0–3 (``holdout.md``), and which verdicts that made in-sample
SEEN_FIRST = (
    "Looked at since it was built, so not every number is blind any more: "
    "(1) a Diebold–Mariano test on the validation simulation errors, tried and "
    "rejected (one more `none` recording called physics here, level 2 "
    "unchanged); (2) the oscillatory disturbance's longest period, T/4 → T/2 with "
    "a given model, chosen on the three families (one more disturbance named "
    "there and here, no more false alarms on either; without a model it stays "
    "T/4: T/2 called slow loads oscillations on the regulatory loops of "
    "`reports/diagnose/`); (3) stiction named only when the stiction "
    "fit itself passes its test against the nominal model: prompted by this "
    "family's `holdout_sync_L2_deadband_01` (named stiction with a stiction "
    "fit 4 % *worse* than the nominal), checked on the three families (no "
    "change with the model; "
    "4 model-free recordings of other physics no longer called stiction, no "
    "sticky valve lost) — that recording's verdict is in-sample for the rule; "
    "(4) its missed disturbances were read while the comparison band was "
    "widened for a line in the nominal residual "
    "(`disturbance_band.md`, which also runs this family at other seeds): the "
    "two here have periods above twice the slow-load high-pass period, outside "
    "the hypothesis, and stay missed; no verdict here changed; (5) the dead "
    "time's practical significance became its own resolution (more than one "
    "sample from the nominal, the NRMSE improving at all) instead of the 10 % "
    "NRMSE gate: prompted by the issue's independent set (dead time → none) and "
    "by this family's level-2 dead-time misses (p 0.001–0.008, NRMSE "
    "improvements 2–4 %), checked on the three families and on all four at fresh "
    "seeds (`dead_time_gate.md`): this family's two dead-time recordings it "
    "turned are in-sample for the rule. "
    "No threshold was set on this family.")
#: fresh seed blocks (``--first-seed``) already looked at, and what seeing them changed:
#: a report at one of these seeds is no longer blind. make concealed's
#: ``holdout_fresh.md`` runs a block nobody has drawn; before a rule is changed with its
#: numbers in view, enter it here and move make concealed on to a new block
SEEN_FRESH = {
    1000: "the shipped defaults scored 102/108 at level 1 and 81/108 at level 2 there, "
          "`none` called physics 0/48; one miss (`holdout_sync_L1_valve_characteristic_"
          "1004`, OP shut at 0 for 81 % of the record) showed that OP's range was not "
          "recognised when OP's median sits on the bottom of its range, so the valve "
          "characteristic was never tested; `infer_op_range` was fixed for it (no real "
          "recording's range changed; that recording's hypothesis is now tested and "
          "improves the validation NRMSE by less than the 10 % gate, so it stays `none`).",
    2000: "drawn blind after the OP-range fix (make concealed's `holdout_fresh.md` "
          "then): 102/108 at level 1, 78/108 at level 2, `none` called physics 1/24 at "
          "each level. Its two level-1 sticky valves named a dead band (both made by the "
          "Choudhury valve, J/S 0.23 and 0.26; fitted J 0 and a slip-jump p of 1) showed "
          "that the identification had no stop rule for Choudhury's restart (S either "
          "way after a reversal, where Kano's model needs only J the way the valve was "
          "going); the package's own simulator's ChoudhuryValve was read as S 3.3, J 0.93 "
          "for a true 4, 1.5. With the rule as first added: 104/108 at level 1 (both named "
          "stiction), level 2 and `none` unchanged; the three tuning families and the "
          "seeds 0–3 kept every verdict. With the rule as shipped (after the 3000 "
          "block): 104/108 and 79/108, `none` unchanged, three verdicts changed, all "
          "three sticky valves named a dead band before.",
    3000: "drawn blind with the rule as first added: 100/108 at level 1 (oscillatory "
          "disturbances 6/12, none of their misses beaten by another hypothesis), 77/108 "
          "at level 2, `none` called physics 1/24 at each level. Not a reason for a "
          "change; the change after it came from `reports/diagnose/fast_loops.md`, where "
          "5 sticky Kano valves under a PI faster than the historian turned from "
          "stiction to a dead band: the stop rule was chosen by the output error and "
          "Choudhury's restart at J = 0 (not the play operator) won it. Now, against a "
          "given model, the rule is chosen by the innovations it is tested with, "
          "Choudhury's restart is searched with J ≥ 0.1 S and the slip jump is tested "
          "against the play operator (without a model the identification is as before: "
          "see `fit_hammerstein`). The block's verdicts with the rule as shipped are those "
          "of the code before the rule, all 216.",
    4000: "drawn blind with the rules of 3000 (make concealed's `holdout_fresh.md` "
          "then): 102/108 at level 1, 83/108 at level 2, `none` called physics 0/24 at "
          "each level. Its missed oscillatory disturbances showed the main band's "
          "slow-load high-pass hiding lines slower than its corner (a 325 s line on a "
          "loop of τ + θ = 8 s: the prediction-error search settled on a 21 s noise "
          "line; 222 s and 402 s lines beyond the periods searched), and the second look "
          "(`diagnose.second_look`) was built on them; its period rule (only lines "
          "slower than the main band's corner) came after the look without it named a "
          "41 s line on this block's `holdout_sync_L2_none_4004`. With the look as "
          "shipped: 103/108 and 85/108, `none` unchanged; the three families 210/240 "
          "against 208 (the look named 2 disturbances, no `none` recording).",
    5000: "drawn blind with the second look (make concealed's `holdout_fresh.md` then): "
          "104/108 at level 1, 76/108 at level 2, `none` called physics 0/24 and 3/24. "
          "Nothing was changed after it.",
    6000: "drawn blind with the rules of 5000 (scratch, not a report): 101/108 at level "
          "1, 77/108 at level 2, `none` called physics 2/24 and 1/24. Five of its level-2 "
          "sensor lags were named a dead time: the sensor lag had the lower BIC and the "
          "smaller p-value but improved the validation NRMSE by less than 10 %, while the "
          "dead time passed on its own-resolution exemption (any improvement). The rival "
          "rule (`evidence.select`, `rivals_on_own_standard`: a dead time named only by "
          "that exemption gives way to a sensor lag that meets the same standard with "
          "the lower BIC) was built on them; a first version that let any hypothesis be "
          "the rival lost three dead times on the three families and seeds 0-3, so the "
          "rival is the sensor lag alone. With the rule as shipped: 182/216 against 178 "
          "(five sensor lags gained, one dead time lost), `none` unchanged; on the seen "
          "blocks 1000-5000: +3, +1, +3, 0 (one gained, one lost), 0; the three "
          "families 210/240 unchanged; seeds 0-3 64 -> 63/72 (one dead time lost).",
    8000: "drawn blind with the rival rule (make concealed's `holdout_fresh.md` then): "
          "105/108 at level 1, 83/108 at level 2, `none` called physics 1/24 and 2/24. "
          "Two of its level-2 dead times named a dead band (`holdout_sync_L2_dead_time_"
          "8000`: a dead band of 0.01 %, the bottom of its range, improving the validation "
          "NRMSE by 15 %) showed that against a given model the valve identification's "
          "timing shifts added up (the nominal's alignment, then the linear loop's ±1 "
          "sample, then the valve grid's ±1 sample around that): the valve hypotheses "
          "carried a dead time 3 s longer than the model's. A first repair (half a sample "
          "around the nominal's aligned dead time) read a 0.4 % dead band of the package's "
          "own simulator as stiction: the linear nominal aligns one sample late there, "
          "biased by the valve's own lag. As shipped the held process moves by at most one "
          "sample, on a half-sample grid, around the model's dead time "
          "(`hammerstein._held_shifts`). With it: 192/216 against 188 (three dead times "
          "and a dead band gained, one dead time now a dead band), `none` unchanged; the "
          "seen blocks 1000-6000: -2, 0, 0, +2, +2, +3, `none` called physics +1 at 1000 "
          "and -1 at 2000; the three families 214/240 against 210 (in-sample); seeds 0-3 "
          "unchanged.",
    9000: "drawn blind after the held-process timing fix (make concealed's "
          "`holdout_fresh.md` then): 104/108 at level 1, 86/108 at level 2, `none` called "
          "physics 2/24 and 1/24. Read with the other blocks for a change not shipped: "
          "stiction refined under the common noise model from the valve identification's "
          "S, J and from the dead band's optimum (it nests the dead band, which there often "
          "fitted better). Here 105 and 87/108, `none` 1/24 and 1/24; pooled over the seen "
          "blocks 1000-6000, 8000, 9000 level 1 826 -> 833/864, level 2 668 -> 674/864, "
          "`none` called physics 8 -> 6 and 8 -> 4 of 192; seeds 0-3 +2, the three "
          "families unchanged; but the next blind block (10000) unchanged, fresh seeds of "
          "four families +1 named and +1 `none` called physics, and on regulatory loops "
          "stiction lost: ISDB model-free 3 -> 2 of 10 (CHEM10 named saturation, its J "
          "refined from 2.1 to 0.1), limit_cycles' historian stiction with the model 14 -> "
          "11/24, regulatory_bias sticky 4 -> 2/24. Not shipped; nothing else changed.",
    10000: "drawn blind after the stiction refinement was rejected (make concealed's "
           "`holdout_fresh.md` then): 106/108 at level 1, 81/108 at level 2, `none` called "
           "physics 0/24 and 1/24. Its level-2 travel limits and valve characteristics "
           "named `none` (5/12 each), their limit or rangeability fitted close to the "
           "truth, prompted the range hypotheses' full-data test "
           "(`evidence.range_fallback`, level 1e-10 set on the three families): here "
           "81 -> 87/108 at level 2, `none` unchanged.",
    11000: "drawn blind to score the range hypotheses' full-data test, nothing changed "
           "after: level 1 107/108, level 2 70 -> 73/108, `none` called physics 0/24 and "
           "1/24 with and without it.",
    12000: "drawn blind with 11000: level 1 99/108 (`none` called physics 5/24: slow "
           "loops, τ 61-114 s), level 2 84 -> 87/108, `none` 1/24 with and without the "
           "full-data test. Its level-1 false alarms prompted a look at the tests' "
           "calibration on slow loops.",
    13000: "drawn blind with 11000: level 1 104/108, level 2 92 -> 93/108, `none` called "
           "physics 1/24 and 0/24 with and without the full-data test.",
    14000: "drawn blind with the range hypotheses' full-data test (make concealed's "
           "`holdout_fresh.md` then): 98/108 at level 1, 82/108 at level 2 (79 without "
           "the test), `none` called physics 5/24 and 4/24, mostly slow loops again. The "
           "NRMSE gate scaled by the band's degrees of freedom (`evidence.scaled_gate`, its "
           "reference of 100 read off `slow_loops.md` before this block was scored with "
           "it) scored 99/108 and 82/108 here, `none` called physics 4/24 and 2/24, and "
           "was shipped.",
    15000: "drawn blind after the scaled gate and the full-data test (make concealed's "
           "`holdout_fresh.md`): 107/108 at level 1, 87/108 at level 2, `none` called "
           "physics 0/24 and 3/24. Then looked at, with no rule changed: its false alarms "
           "bootstrapped (`bootstrap_null.md`) and a causal comparison band scored on it "
           "(`causal_filter.md`, then scored blind on 16000-19000 and shipped).",
    16000: "drawn blind at `f45f3d5` for `holdout_pooled.md` (level 1 15.1 of 16, level 2 "
           "11.7, `none` called physics 3/24 and 1/24), then used with 17000-19000 to "
           "score two fixed variants of the comparison band against the shipped one "
           "(`causal_blind.md`): the causal band replaced the zero-phase one there, against "
           "a given model.",
    17000: "drawn with 16000 (level 1 14.8, level 2 13.6, `none` called physics 1/24 and "
           "2/24); scored the causal band with it (`causal_blind.md`).",
    18000: "drawn with 16000 (level 1 15.4, level 2 11.6, `none` called physics 0/24 and "
           "5/24); scored the causal band with it (`causal_blind.md`).",
    19000: "drawn with 16000 (level 1 15.3, level 2 11.9, `none` called physics 1/24 and "
           "2/24); scored the causal band with it (`causal_blind.md`).",
    21000: "drawn blind after the causal comparison band (make concealed's "
           "`holdout_fresh.md`, and `holdout_pooled.md` with 22000-24000): level 1 15.0 of "
           "16, level 2 12.4, `none` called physics 2/24 and 1/24. No rule changed after; "
           "the next rule change is scored on 25000.",
    22000: "drawn with 21000 for `holdout_pooled.md` (level 1 15.3, level 2 12.3, `none` "
           "called physics 1/24 and 0/24); no rule changed after.",
    23000: "drawn with 21000 (level 1 15.6, level 2 11.4, `none` called physics 0/24 and "
           "1/24); no rule changed after.",
    24000: "drawn with 21000 (level 1 15.1, level 2 11.7, `none` called physics 1/24 and "
           "0/24); no rule changed after.",
    25000: "drawn with 26000 for `band_magnitude.py`, which scored a causal band of the "
           "zero-phase band's magnitude against the shipped causal band and the zero-phase "
           "band by a criterion stated before the run (not met); with the shipped band: "
           "level 2 of 16 12.8 over both blocks (the pooled rate; 12.5 with the classes "
           "weighted equally), `none` called physics 5/96. No rule changed after; the "
           "next rule change is scored on 27000.",
    26000: "drawn with 25000 for `band_magnitude.py` (see 25000); no rule changed after.",
    27000: "drawn with 28000-30000 at 6d08099 as blind blocks (shipped code, the classes "
           "weighted equally: level 1 15.8, level 2 12.0 of 16, `none` called physics 2/96 "
           "and 4/96), then the score of `slip_jump_nuisance.py`'s J = 0 refit with a "
           "model, by a criterion stated before (met by one verdict; not adopted after "
           "the tuning families, `slip_jump_nuisance.md`). The next rule change is scored "
           "on 31000 (`slip_jump_symmetric.py`: 31000-34000).",
    28000: "drawn with 27000 (see 27000).",
    29000: "drawn with 27000 (see 27000).",
    30000: "drawn with 27000 (see 27000); its level-2 dead band 30001 is the verdict the "
           "J = 0 refit would have moved (stiction → deadband).",
    31000: "drawn with 32000-34000 for `slip_jump_symmetric.py` (both ends of the "
           "slip-jump test searched; its criterion, stated before, not met on the tuning "
           "families: not adopted); shipped code, the classes weighted equally: level 1 "
           "15.5, level 2 12.2 of 16, `none` called physics 3/96 and 2/96. The next rule "
           "change is scored on 35000.",
    32000: "drawn with 31000 (see 31000).",
    33000: "drawn with 31000 (see 31000).",
    34000: "drawn with 31000 (see 31000).",
    35000: "drawn with 36000-38000 at 2ff1e80 as blind blocks with no candidate rule, "
           "to narrow the blind estimate (`holdout_pooled.md`); the next rule change is "
           "scored on 39000.",
    36000: "drawn with 35000 (see 35000).",
    37000: "drawn with 35000 (see 35000).",
    38000: "drawn with 35000 (see 35000).",
    39000: "drawn to score the OP-hold check (`stictionbench.diagnosis.op_limit`: a "
           "controller output held at its limit names saturation where the comparison "
           "named nothing), found on the independent set (`independent_set.py`); it "
           "changed no verdict of the block: level 1 15.4, level 2 11.8 of 16, `none` "
           "called physics 3/24 and 1/24. The next rule change is scored on 40000.",
    40000: "drawn to score the set-point gain test (`stictionbench.diagnosis.gain`: the "
           "loop's gain measured by instrumental variables through the set point names a "
           "valve characteristic where the comparison named nothing), found on the "
           "independent sets; it changed no verdict of the block (run again without it): "
           "level 1 14.7, level 2 12.2 of 16, `none` called physics 0/24 and 0/24. The "
           "next rule change is scored on 41000.",
    45000: "`disturbance_cycles.py`'s disturbance loops (16 per level from 45000, each "
           "at several periods); the other classes there are undrawn.",
    46000: "`slow_loops_named.py`'s level-2 loops of every physics class (8 per class "
           "from 46000, each at several speeds and two record lengths).",
    20000: "`slow_loops.py`'s healthy loops (seeds 20000-20023 of `none`, their speed "
           "varied); the other classes there are undrawn.",
}
SUB = 10  # process sub-steps per 1 s controller/historian period
VALVE_MODELS = ("kano", "he", "choudhury")


def draw(cls: str, level: int, seed: int) -> Case:
    """Plant, lambda-tuned PI, steps, noise, load and effect of one holdout recording."""
    rng = np.random.default_rng([97, CLASSES.index(cls), level, seed])
    K = math.exp(rng.uniform(math.log(0.3), math.log(5.0)))
    tau = math.exp(rng.uniform(math.log(3.0), math.log(120.0)))
    theta = max(1.0, tau * math.exp(rng.uniform(math.log(0.05), math.log(0.8))))
    lam = tau * rng.uniform(0.5, 2.0)
    kc, ti = tau / (K * (lam + theta)), tau
    steps = setpoint_steps(rng, K, 30.0, DURATION - 150)
    mean_step = float(np.mean([abs(s) for _, s in steps]))
    # the two levels, drawn here again on purpose: the family shares no draw
    # with the tuning families (concealed_families.draw)
    noise_frac = rng.uniform(0.01, 0.04) if level == 1 else rng.uniform(0.03, 0.10)
    effect = rng.uniform(0.4, 1.0) if level == 1 else rng.uniform(0.0, 0.5)
    load = mean_step * (rng.uniform(0.05, 0.2) if level == 1 else rng.uniform(0.3, 1.0))
    c = Case(FAMILY, cls, level, seed, K, tau, theta, kc, ti, lam + theta, steps,
             noise_frac * mean_step, noise_frac, load, effect)
    e = effect
    if cls == "stiction":
        S = 0.5 + 5.5 * e
        c.truth = {"S": S, "J": S * rng.uniform(0.2, 1.0),
                   "model": VALVE_MODELS[int(rng.integers(len(VALVE_MODELS)))]}
    elif cls == "deadband":
        c.truth = {"deadband": 0.5 + 4.5 * e}
    elif cls == "sensor_lag":
        c.truth = {"time_constant": tau * (0.2 + 1.0 * e)}
    elif cls == "dead_time":
        c.truth = {"dead_time": theta + theta * (0.3 + 1.2 * e) + 1.0}
    elif cls == "valve_characteristic":
        c.truth = {"rangeability": 5.0 + 45.0 * e}
    elif cls == "saturation":
        c.truth = {"quantile": 0.95 - 0.25 * e}
    elif cls == "oscillatory_disturbance":
        c.truth = {"period": float(c.lam_cl * math.exp(rng.uniform(math.log(2), math.log(50)))),
                   "amplitude": float(mean_step * (0.05 + 0.5 * e))}
    return c


def setpoint_steps(rng: np.random.Generator, K: float, start: float,
                   end: float) -> list[tuple[float, float]]:
    """The family's set-point schedule from ``start`` until ``end`` (s): a step every
    200–600 s, of either sign, 2–8 times the process gain."""
    t, steps = start, []
    while t < end:
        steps.append((round(t, 1), float(rng.choice([-1, 1]) * K * rng.uniform(2, 8))))
        t += rng.uniform(200, 600)
    return steps


def kano_step(u: float, s: dict, S: float, J: float) -> float:
    """Kano et al. (2004): the valve stops when OP's velocity changes sign or vanishes;
    from rest it moves once OP has travelled ``S`` the other way or ``J`` the same way,
    to ``u − d·(S − J)/2``."""
    du = u - s["u_prev"]
    if s["moving"] and (du == 0.0 or du * s["d"] < 0.0):
        s["moving"], s["u_stop"] = False, s["u_prev"]
    if not s["moving"]:
        if s["d"] == 0.0:
            go = abs(u - s["u_stop"]) > 0.5 * (S + J)
            if go:
                s["d"] = 1.0 if u > s["u_stop"] else -1.0
        elif -s["d"] * (u - s["u_stop"]) > S:
            s["d"], go = -s["d"], True
        else:
            go = s["d"] * (u - s["u_stop"]) > J
        s["moving"] = go
    if s["moving"]:
        s["y"] = u - s["d"] * 0.5 * (S - J)
    s["u_prev"] = u
    return s["y"]


def he_step(u: float, s: dict, S: float, J: float) -> float:
    """He et al. (2007): the force ``u_r`` accumulated since the last move slips the
    valve when it exceeds ``fs = (S + J)/2``, leaving ``fd = (S − J)/2`` behind."""
    fs, fd = 0.5 * (S + J), 0.5 * (S - J)
    s["ur"] += u - s["u_prev"]
    if abs(s["ur"]) > fs:
        sg = math.copysign(1.0, s["ur"])
        s["y"] += s["ur"] - sg * fd
        s["ur"] = sg * fd
    s["u_prev"] = u
    return s["y"]


def _valve(c: Case, u: float, s: dict) -> float:
    tr = c.truth
    if c.cls == "stiction":
        if tr["model"] == "kano":
            return kano_step(u, s, tr["S"], tr["J"])
        if tr["model"] == "he":
            return he_step(u, s, tr["S"], tr["J"])
        return choudhury_valve_step(u, s, tr["S"], tr["J"])
    if c.cls == "deadband":
        h = 0.5 * tr["deadband"]
        s["y"] = min(max(s["y"], u - h), u + h)
        return s["y"]
    if c.cls == "saturation" and "op_high" in tr:
        return min(u, tr["op_high"])
    if c.cls == "valve_characteristic":
        return 100.0 * tr["rangeability"] ** (min(max(u, 0.0), 100.0) / 100.0 - 1.0)
    return u


#: the loop's steady operating point (OP, valve position and flow start here)
OP0 = 50.0


def valve_state(op0: float = OP0) -> dict[str, float | bool]:
    """The valve models' state at rest at ``op0`` (:func:`_valve`)."""
    return {"u_prev": op0, "moving": False, "u_stop": op0, "d": 0.0, "y": op0, "ur": 0.0,
            "x_prev": op0, "v_prev": 0.0, "stuck": True, "x_ss": op0}


def valve_positions(c: Case, op: np.ndarray) -> np.ndarray:
    """What case ``c``'s valve did under the recorded ``op``: the PI runs in step with
    the historian, so its valve saw exactly the recorded samples (:func:`simulate`)."""
    s = valve_state()
    _valve(c, OP0, s)
    return np.array([_valve(c, float(u), s) for u in op])


def simulate(c: Case, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """The loop at 0.1 s sub-steps, the PI and the historian every 1 s."""
    n = int(DURATION) + 1
    h = 1.0 / SUB
    tr = c.truth
    theta = tr.get("dead_time", c.theta)
    a = math.exp(-h / c.tau)
    lag = math.exp(-h / tr["time_constant"]) if c.cls == "sensor_lag" else 0.0
    delay = int(round(theta / h))
    sp = np.zeros(n)
    for ts, step in c.steps:
        sp[int(ts):] += step
    noise = rng.normal(size=n) * c.noise
    # integrated random walk, scaled so that its spread over the record is `load`
    load = np.cumsum(np.cumsum(rng.normal(size=n)))
    load = (load - load[0]) * c.load / max(float(np.std(load)), 1e-12)
    osc = np.zeros(n)
    if c.cls == "oscillatory_disturbance":
        osc = tr["amplitude"] * np.sin(2 * math.pi * np.arange(n) / tr["period"]
                                       + rng.uniform(0, 2 * math.pi))
    op0 = OP0
    s = valve_state(op0)
    mv0 = _valve(c, op0, s)
    line = [mv0] * delay  # MV applied θ ago (0.1 s resolution)
    x, ym, op, e_prev = 0.0, 0.0, op0, 0.0
    out = np.empty((n, 3))
    for k in range(n):
        pv = ym + noise[k]
        e = sp[k] - pv
        if k:
            op = min(max(op + c.kc * ((e - e_prev) + e / c.ti), 0.0), 100.0)
        e_prev = e
        out[k] = (sp[k], pv, op)
        mv = _valve(c, op, s)
        for j in range(SUB):
            line.append(mv)
            x = a * x + (1.0 - a) * c.K * (line.pop(0) - mv0)
            d = load[k] + (load[min(k + 1, n - 1)] - load[k]) * j / SUB + osc[k]
            ym = lag * ym + (1.0 - lag) * (x + d)
    return {"t": np.arange(n, dtype=float), "SP": out[:, 0], "PV": out[:, 1],
            "OP": out[:, 2]}


def noise_rng(c: Case) -> np.random.Generator:
    """The generator of case ``c``'s noise and load: seeded by its class, level and seed
    only, so a case whose physics an experiment varies keeps the same noise and load."""
    return np.random.default_rng([97, CLASSES.index(c.cls), c.level, c.seed, 1])


def make_recording(cls: str, level: int, seed: int) -> tuple[Case, dict[str, np.ndarray]]:
    """Draw and simulate one holdout recording: ``(case, {t, SP, PV, OP})``."""
    return _recorded(draw(cls, level, seed))


def _recorded(c: Case) -> tuple[Case, dict[str, np.ndarray]]:
    """Case ``c`` simulated with its own noise and load; a saturation's travel limit is
    first read off the loop's OP without it (the drawn quantile)."""
    if c.cls == "saturation":
        q = c.truth.pop("quantile")
        base = simulate(c, noise_rng(c))
        c.truth["op_high"] = float(np.quantile(base["OP"], q))
    return c, simulate(c, noise_rng(c))


def at_speed(cls: str, level: int, seed: int, tau: float, duration: float = DURATION,
             load_scale: float = 1.0) -> tuple[Case, dict[str, np.ndarray]]:
    """The drawn case moved to time constant ``tau``, recorded for ``duration`` s with its
    load's spread scaled by ``load_scale``: the same loop slowed or sped up. The drawn
    ``θ/τ`` and ``λ/τ`` are kept (``θ`` at least 1 s; lambda tuning ``kc = τ/(K(λ+θ))``,
    ``ti = τ``), and so are the effects drawn in units of the loop's speed (a sensor
    lag's time constant, the extra dead time, a disturbance's period in closed-loop time
    constants). Everything is drawn as for the family's own record length; a longer
    record continues the set-point schedule by the same rule (:func:`setpoint_steps`,
    its own seed), so the loop, its effect, noise and load are the same in both. Returns
    ``(case, signals)`` as :func:`make_recording`."""
    global DURATION
    c = draw(cls, level, seed)  # at the family's record length: the same draws
    if duration > DURATION:
        rng = np.random.default_rng([97, CLASSES.index(cls), level, seed, 2])
        start = c.steps[-1][0] + rng.uniform(200, 600) if c.steps else 30.0
        c.steps += setpoint_steps(rng, c.K, start, duration - 150)
    saved, DURATION = DURATION, duration
    try:
        theta0, lam_cl0 = c.theta, c.lam_cl
        lam = (c.lam_cl - c.theta) * tau / c.tau
        f = tau / c.tau
        c.theta, c.tau = max(1.0, c.theta * f), tau
        c.kc, c.ti, c.lam_cl = tau / (c.K * (lam + c.theta)), tau, lam + c.theta
        c.load *= load_scale
        if cls == "sensor_lag":
            c.truth["time_constant"] *= f
        elif cls == "dead_time":
            extra = c.truth["dead_time"] - theta0 - 1.0
            c.truth["dead_time"] = c.theta + extra * c.theta / theta0 + 1.0
        elif cls == "oscillatory_disturbance":
            c.truth["period"] *= c.lam_cl / lam_cl0
        return _recorded(c)
    finally:
        DURATION = saved


def generate(cls: str, level: int, seed: int, out: Path) -> dict:
    """Write one recording (CSV, no MV) and its model YAML; return the job."""
    c, sig = make_recording(cls, level, seed)
    job = write_job(c, sig, out)
    job["truth"] = {k: v for k, v in c.truth.items() if k != "model"}
    return job | {"valve_model": c.truth.get("model", "")}


def report(df: pd.DataFrame, args: argparse.Namespace, wall: float) -> str:
    """The holdout family under the shipped defaults, per class and level."""
    ok = df.predicted_default == df["class"]
    err = parameter_error(df, df.predicted_default)
    rows = []
    for (cls, lvl), g in df.groupby(["class", "level"], sort=False):
        e = err[g.index].dropna()
        wrong = g[~ok[g.index]]
        rows.append({"class": cls, "level": lvl,
                     "named correctly": rate_text(int(ok[g.index].sum()), len(g)),
                     "median parameter error": f"{e.median():.0%}" if len(e) else "–",
                     "misses named": ", ".join(
                         f"{p} ×{n}" if n > 1 else p
                         for p, n in sorted(Counter(wrong.predicted_default).items(),
                                           key=lambda kv: (-kv[1], kv[0]))) or "–"})
    tab = pd.DataFrame(rows)
    fresh = args.first_seed > 0
    blind = ", blind" if fresh and args.first_seed not in SEEN_FRESH else ""
    title = (f"# Holdout family at fresh seeds: the shipped defaults{blind}" if fresh else
             "# Holdout family: the shipped defaults on a generator never used for tuning")
    seeds = (f"seeds {args.first_seed}–{args.first_seed + args.seeds - 1} per class and "
             f"level ({args.first_seed}–{args.first_seed + args.none_seeds - 1} for `none`)"
             if fresh else f"{args.seeds} seeds per class and level, {args.none_seeds} for "
             "`none`")
    seen = SEEN_FRESH.get(args.first_seed)
    looked = (
        f"These seeds were looked at before: {seen}" if seen else
        "These seeds were drawn for this report after every rule of the package was "
        "fixed; nothing was changed after seeing them, so every number here is out of "
        "sample. Seed blocks looked at before: " + "; ".join(
            f"from {k}: {v}" for k, v in SEEN_FRESH.items())
        + " The rules checked on seeds 0–3 are listed in `holdout.md`.")
    lines = [title,
             "", f"Generated and diagnosed by `experiments/holdout_family.py` (`make "
             f"concealed`; the family is described in its docstring): {len(df)} recordings "
             f"of {DURATION:.0f} s at 1 s, PI in step with the historian, {seeds}. Each is "
             "diagnosed as `stictionbench diagnose REC.csv --model REC.yaml` with the "
             "package's default thresholds, which were set on the three families of "
             "`summary.md`, never on this one. Rates carry Wilson 95 % intervals.", "",
             SEEN_FIRST if not fresh else looked, ""]
    for lvl in (1, 2):
        g = df.level == lvl
        phys, none = g & (df["class"] != "none"), g & (df["class"] == "none")
        per16 = balanced_score(ok[g], df["class"][g], 16)[0]
        lines.append(f"- level {lvl}: named {rate_text(int(ok[g].sum()), int(g.sum()))} "
                     f"(≈ {per16:.1f} of 16 with the classes weighted equally); physics "
                     "classes "
                     f"{rate_text(int(ok[phys].sum()), int(phys.sum()))}; `none` called "
                     f"physics {rate_text(int((~ok[none]).sum()), int(none.sum()))}")
    st = df[df["class"] == "stiction"]
    by_model = [f"{m}: {rate_text(int(ok[g.index].sum()), len(g))}"
                for m, g in st.groupby("valve_model")]
    lines += [f"- sticky valves named `stiction`, by the valve model that made them: "
              f"{'; '.join(by_model)}", "", to_markdown(tab), ""]
    miss = df[~ok & (df["class"] != "none")]
    if len(miss):
        why = pd.DataFrame({"class": miss["class"], "level": miss.level, "reason": [
            miss_reason(r, r.predicted_default) for _, r in miss.iterrows()]})
        rows = [{"class": c, "level": lvl, "misses": len(g), "why (the true hypothesis's "
                 "own evidence, or what beat it)": ", ".join(
                     f"{k} ×{n}" if n > 1 else k for k, n in sorted(
                         Counter(g.reason).items(), key=lambda kv: (-kv[1], kv[0])))}
                for (c, lvl), g in why.groupby(["class", "level"], sort=False)]
        lines += ["## Why the misses were missed", "",
                  "Read from each missed recording's stored evidence with the shipped rule "
                  "(`concealed.miss_reason`): the true hypothesis's fit on the end of its "
                  "search range, its p-value at or above alpha, its validation NRMSE "
                  "improving by less than the gate, or, when it passed all three, what beat "
                  "it. `not tested`: the hypothesis was not fitted (the diagnosis says why "
                  "in its summary).", "", to_markdown(pd.DataFrame(rows)), ""]
    lines.append(timing_line(df, wall, args.jobs))
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--none-seeds", type=int, default=8)
    ap.add_argument("--first-seed", type=int, default=0,
                    help="seeds run from here (0: the recordings holdout.md reports)")
    ap.add_argument("--name", default="holdout", help="output stem in --out")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "reports" / "concealed"))
    a = ap.parse_args(argv)
    from joblib import Parallel, delayed
    from tqdm import tqdm

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        jobs = [generate(c, lvl, s, Path(tmp)) for lvl in (1, 2) for c in CLASSES
                for s in range(a.first_seed,
                               a.first_seed + (a.none_seeds if c == "none" else a.seeds))]
        rows = list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(
            delayed(run_one)(j) for j in jobs), total=len(jobs), desc="diagnose"))
    df = pd.DataFrame(rows)
    df["valve_model"] = [j["valve_model"] for j in jobs]
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / f"{a.name}.csv") as tmp_csv:
        df.round({"effect": 6, "noise_frac": 6, "seconds": 3}).to_csv(
            tmp_csv, index=False, lineterminator="\n", float_format="%.6g")
    text = report(df, a, time.perf_counter() - t0)
    write_text(out / f"{a.name}.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
