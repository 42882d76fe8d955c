"""Why are concealed sticky valves missed? Vary the controller's rate, nothing else.

The concealed benchmark (``reports/concealed/summary.md``) names stiction on level 2 in
0 of 4 recordings of the ``sim_physical`` family and 0 of 4 of ``sim_he``, with the model
given. In both families the PI executes faster than the historian (every 0.2 s and
0.5 s; one sample a second is recorded), so the valve moves on controller outputs the
historian never keeps, and the valve the diagnosis replays from the recorded OP (Kano's
two-parameter model at 1 s, :func:`stictionbench.diagnosis.openloop.stiction_valve`)
is not the valve that moved. Suspected cause: that intersample motion, not the effect's
size or the noise. (Answer, in the report: the misses follow the controller's rate, and
at the faster rate the slip jump is often absent from the 1 s signals themselves, MV
included.)

The check re-generates the benchmark's own stiction, dead-band and ``none`` recordings
of those two families (both levels, seeds 0–3: same plant, set-point steps, effect,
noise and load) with only the controller's period changed to the historian's 1 s, and
diagnoses both versions with the true model. Per family, level, class and controller
period: the rate of recordings named correctly (Wilson 95 % intervals) and, for the
sticky valves, the median relative error of the S and J of the closed-loop valve
identification whatever the verdict (is the valve found at all?). Nothing is tuned here.

A second check asks whether the slip jump is in the sampled signals at all. For every
sticky valve, the sampled two-parameter model (every stop rule of the
identification) is fitted by least squares to the *true* valve position MV, recorded at
1 s, from the recorded OP: no process, no measurement noise, no load. If even this fit
finds ``J`` near 0 (below :data:`stictionbench.diagnosis.hammerstein.MIN_SLIP_FRACTION` of
``S``, the resolution at which ``diagnose`` calls a fitted valve a dead band), no test on
PV and OP can tell the stiction from a dead band at the historian's rate.

Run: ``.venv/bin/python experiments/stiction_controller_rate.py [--seeds 4] [--jobs 2]``;
writes ``stiction_controller_rate.md`` and ``.csv`` to ``--out``
(default ``reports/concealed/``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from concealed_families import make_recording, nominal_model  # noqa: E402
from fast_loops import parse_args, run_loops  # noqa: E402

from stictionbench.diagnosis import diagnose  # noqa: E402
from stictionbench.diagnosis.hammerstein import (  # noqa: E402
    MIN_SLIP_FRACTION,  # noqa: E402
    STOP_RULES,
    rule_valve,
)
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

FAMILIES = ("sim_physical", "sim_he")
CLASSES = ("stiction", "deadband", "none")
#: the family's own controller period (None) and the historian's 1 s
PERIODS = (None, 1.0)
DEFAULT_PERIOD = {"sim_physical": 0.2, "sim_he": 0.5}


def valve_from_mv(op: np.ndarray, mv: np.ndarray, burn: int = 200) -> dict[str, float]:
    """The sampled stick-slip model fitted to the true valve position: a grid over
    ``S`` (2–40 % of OP's span, 40 points), ``J/S`` (0–1.4, 29 points) and the stop rule,
    least squares on ``mv`` after ``burn`` samples with the offset removed. Returns the
    best ``S``, ``J``, stop rule and RMS error."""
    span = float(np.ptp(op)) or 1.0
    best = (np.inf, 0.0, 0.0, 0)
    for rule in range(len(STOP_RULES)):
        for S in np.geomspace(0.02 * span, 0.4 * span, 40):
            for j in np.linspace(0.0, 1.4, 29):
                e = (mv - rule_valve(op, float(S), float(j * S), rule))[burn:]
                c = float(np.var(e))
                if c < best[0]:
                    best = (c, float(S), float(j * S), rule)
    return {"mv_S": best[1], "mv_J": best[2], "mv_stop_rule": STOP_RULES[best[3]],
            "mv_rms": float(np.sqrt(best[0]))}


def one(family: str, cls: str, level: int, seed: int, period: float | None) -> dict:
    """Generate one benchmark recording (controller period ``period``, the family's own
    when None) and diagnose it with the true model."""
    c, sig = make_recording(family, cls, level, seed, controller_s=period)
    rec = Recording.from_arrays(sig["t"], sig["PV"], sig["OP"], SP=sig["SP"], warn=False)
    d = diagnose(rec, nominal_model(c))
    h = d.details.get("hammerstein") or {}
    row = {"family": family, "class": cls, "level": level, "seed": seed,
           "controller_s": period or DEFAULT_PERIOD[family], "diagnosis": d.missing_physics,
           "fitted_S": h.get("S"), "fitted_J": h.get("J"), "stop_rule": h.get("stop_rule")}
    if cls == "stiction":
        row |= {"true_S": c.truth["S"], "true_J": c.truth["J"],
                **valve_from_mv(sig["OP"], sig["MV"])}
    return row


def summarise(df: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for (fam, lev, cls, per), g in df.groupby(["family", "level", "class", "controller_s"]):
        row = {"family": fam, "level": lev, "class": cls, "controller_s": per,
               "named correctly": rate_text(int((g.diagnosis == cls).sum()), len(g))}
        if cls == "stiction":
            for p in ("S", "J"):
                err = np.median(np.abs(g[f"fitted_{p}"] / g[f"true_{p}"] - 1))
                row[f"median error of fitted {p}"] = f"{100 * err:.0f} %"
        rows.append(row)
    return pd.DataFrame(rows)


def findings(df: pd.DataFrame) -> list[str]:
    out = []
    st = df[df["class"] == "stiction"]
    for fam in FAMILIES:
        for lev in (1, 2):
            g = st[(st.family == fam) & (st.level == lev)]
            parts = []
            for per in sorted(g.controller_s.unique()):
                x = g[g.controller_s == per]
                err = float(np.median(np.abs(x.fitted_S / x.true_S - 1)))
                parts.append(f"PI every {per:g} s: "
                             f"{rate_text(int((x.diagnosis == 'stiction').sum()), len(x))}, "
                             f"median S error {100 * err:.0f} %")
            out.append(f"- `{fam}`, level {lev}, stiction named: " + "; ".join(parts))
    for cls in ("deadband", "none"):
        g = df[df["class"] == cls]
        parts = [f"{what}: {rate_text(int((x.diagnosis == cls).sum()), len(x))}"
                 for what, x in (("PI faster than the historian", g[g.controller_s < 1.0]),
                                 ("PI every 1 s", g[g.controller_s == 1.0]))]
        out.append(f"- `{cls}` named correctly, both families and levels: " + "; ".join(parts))
    fast = st[st.controller_s < 1.0]
    slow = st[st.controller_s == 1.0]
    out += ["", "Sticky valves named over both families and levels: "
            f"{rate_text(int((fast.diagnosis == 'stiction').sum()), len(fast))} with the PI "
            "faster than the historian, "
            f"{rate_text(int((slow.diagnosis == 'stiction').sum()), len(slow))} with the PI at "
            "the historian's rate (same recordings otherwise)."]
    if "mv_J" in st:
        out += ["", "Is the slip jump in the sampled signals? The sampled two-parameter model "
                "(every stop rule of the identification) fitted to "
                "the true valve position MV at 1 s (no process, noise or load):", ""]
        for what, x in (("PI faster than the historian", fast), ("PI every 1 s", slow)):
            flat = int((x.mv_J < MIN_SLIP_FRACTION * x.mv_S).sum())
            errj = float(np.median(np.abs(x.mv_J / x.true_J - 1)))
            out.append(f"- {what}: fitted J below {MIN_SLIP_FRACTION:g} S (a dead band) for "
                       f"{rate_text(flat, len(x))} of the sticky valves; median error of "
                       f"J {100 * errj:.0f} %, median RMS error "
                       f"{float(np.median(x.mv_rms)):.2f} % of OP")
    return out


def main(argv=None) -> int:
    a = parse_args("stiction_controller_rate", __doc__, argv, seeds=4,
                   out=ROOT / "reports" / "concealed")
    if a is None:
        return 2
    jobs = [(fam, cls, lev, seed, per) for fam in FAMILIES for cls in CLASSES
            for lev in (1, 2) for seed in range(a.seeds) for per in PERIODS]
    df = pd.DataFrame(run_loops(one, jobs, a.jobs, "recordings"))
    df = df.sort_values(["family", "class", "level", "seed", "controller_s"],
                        kind="stable").reset_index(drop=True)
    out = Path(a.out)
    text = "\n".join([
        "# Concealed sticky valves and the controller's rate", "",
        "The benchmark's own `sim_physical` and `sim_he` recordings (stiction, dead band, "
        f"`none`; levels 1 and 2; seeds 0–{a.seeds - 1}) generated twice: with the "
        "family's controller period (0.2 s and 0.5 s, historian 1 s) and with the PI at "
        "the historian's 1 s, everything else unchanged; diagnosed with the true model. "
        "Generated by `experiments/stiction_controller_rate.py` (`make concealed`).", "",
        *findings(df), "", to_markdown(summarise(df)), ""])
    write_text(out / "stiction_controller_rate.md", text)
    write_text(out / "stiction_controller_rate.csv",
               df.to_csv(index=False, lineterminator="\n", float_format="%.6g"))
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
