"""Why are concealed sticky valves missed? Vary the controller's rate, nothing else.

The concealed benchmark (``reports/concealed/summary.md``) names stiction on level 2 in
0 of 4 recordings of the ``sim_physical`` family and 0 of 4 of ``sim_he``, with the model
given. In both families the PI executes faster than the historian (every 0.2 s and
0.5 s; one sample a second is recorded), so the valve moves on controller outputs the
historian never keeps, and the valve the diagnosis replays from the recorded OP (Kano's
two-parameter model at 1 s, :func:`stictionbench.diagnosis.openloop.stiction_valve`)
is not the valve that moved. Suspected cause: that intersample motion, not the effect's
size or the noise.

The check re-generates the benchmark's own stiction, dead-band and ``none`` recordings
of those two families (both levels, seeds 0–3: same plant, set-point steps, effect,
noise and load) with only the controller's period changed to the historian's 1 s, and
diagnoses both versions with the true model. Per family, level, class and controller
period: the rate of recordings named correctly (Wilson 95 % intervals) and, for the
sticky valves, the median relative error of the S and J of the closed-loop valve
identification whatever the verdict (is the valve found at all?). Nothing is tuned here.

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
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

FAMILIES = ("sim_physical", "sim_he")
CLASSES = ("stiction", "deadband", "none")
#: the family's own controller period (None) and the historian's 1 s
PERIODS = (None, 1.0)
DEFAULT_PERIOD = {"sim_physical": 0.2, "sim_he": 0.5}


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
        row |= {"true_S": c.truth["S"], "true_J": c.truth["J"]}
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
