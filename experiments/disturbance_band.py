"""Oscillatory disturbances of a few closed-loop time constants, with and without the
comparison band widened for a line in the nominal residual.

The diagnosis compares PV with the nominal model in a band whose low-pass corner is cut
from the process time constant (five corner frequencies, :func:`~stictionbench.diagnosis.
hypotheses.lowpass_corner`); the oscillatory disturbance's shortest period follows that
corner. A tightly tuned slow loop (closed-loop time constant well below τ) can carry a
disturbance faster than the band: the issue's independent set missed disturbances "with
periods of a few closed-loop time constants". The band was already widened for a clear
oscillation in PV; set-point responses and the OP-driven part can hide the line in PV,
and the nominal residual shows it (:func:`stictionbench.diagnosis.diagnose.
_band_for_residual_line`).

Here, in the same run, every recording is diagnosed as a user would (recording + model,
package defaults) twice: *shipped* (band widened for a clear residual line) and
*tau_band* (the earlier rule: τ and PV alone; an ablation). Recordings: oscillatory
disturbances and ``none`` recordings of the three tuning families
(``experiments/concealed_families.py``) and of the holdout family
(``experiments/holdout_family.py``), at seeds the benchmark never draws (disturbances
from seed 4, ``none`` from seed 12). Disturbance periods are each family's own draw,
2–50 closed-loop time constants. Nothing here sets a threshold. Writes
``reports/concealed/disturbance_band.{md,csv,png}``.

Run: ``.venv/bin/python experiments/disturbance_band.py [--seeds 12] [--none-seeds 12]``.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import fresh_recordings as fresh  # noqa: E402

from stictionbench.diagnosis import diagnose  # noqa: E402
from stictionbench.diagnosis.hypotheses import lowpass_corner  # noqa: E402
from stictionbench.io import atomic_path, write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
#: the diagnosis module itself (the package exports its function under the same name)
dmod = importlib.import_module("stictionbench.diagnosis.diagnose")
FAMILIES = fresh.FAMILIES
OSC = "oscillatory_disturbance"
#: period bins in closed-loop time constants (the families draw 2–50)
BINS = ((2.0, 5.0), (5.0, 15.0), (15.0, 50.0))
FIRST_OSC_SEED, FIRST_NONE_SEED = 4, 12


def cases(seeds: int, none_seeds: int) -> list[tuple[str, str, int, int]]:
    """``(family, class, level, seed)`` of every recording, at seeds the benchmark never
    draws."""
    out = []
    for fam in FAMILIES:
        for level in (1, 2):
            out += [(fam, OSC, level, FIRST_OSC_SEED + s) for s in range(seeds)]
            out += [(fam, "none", level, FIRST_NONE_SEED + s) for s in range(none_seeds)]
    return out


def one(family: str, cls: str, level: int, seed: int) -> dict:
    c, m, rec = fresh.recording(family, cls, level, seed)
    period = c.truth.get("period", np.nan)
    row = {"family": family, "class": cls, "level": level, "seed": seed,
           "period": period, "lam_cl": c.lam_cl, "tau": c.tau,
           "period_over_lam_cl": period / c.lam_cl,
           # the shortest period the band cut from τ alone keeps (Ts = 1 s)
           "tau_band_min_period": 0.5 / lowpass_corner(1.0, m.time_constant)}
    # the rule is patched through its module (a worker process gets the module by
    # reference; a function named in this script would be pickled by value, a copy)
    shipped = dmod._band_for_residual_line
    for label, rule in (("shipped", shipped), ("tau_band", lambda *a: None)):
        dmod._band_for_residual_line = rule
        try:
            d = diagnose(rec, m)
        finally:
            dmod._band_for_residual_line = shipped
        row[label] = d.missing_physics
        row[f"{label}_period"] = d.parameters.get("period", np.nan)
        row[f"{label}_lowpass_hz"] = d.details["lowpass_hz"]
    return row


def _named(g: pd.DataFrame, label: str) -> str:
    if g["class"].iloc[0] == "none":
        return "physics named " + rate_text(int((g[label] != "none").sum()), len(g))
    return "named " + rate_text(int((g[label] == OSC).sum()), len(g))


def summary(df: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per family, class and level; and the disturbances per period bin."""
    rows = []
    for (fam, cls, level), g in df.groupby(["family", "class", "level"], sort=False):
        rows.append({"family": fam, "class": cls, "level": level, "recordings": len(g),
                     "shipped": _named(g, "shipped"), "tau_band": _named(g, "tau_band")})
    osc = df[df["class"] == OSC]
    bins = []
    for level in (1, 2):
        for lo, hi in BINS:
            g = osc[(osc["level"] == level) & (osc["period_over_lam_cl"] >= lo)
                    & (osc["period_over_lam_cl"] < hi)]
            for short in (True, False):
                h = g[(g["period"] < g["tau_band_min_period"]) == short]
                if len(h):
                    bins.append({"level": level,
                                 "period / closed-loop time constant": f"{lo:g}–{hi:g}",
                                 "period vs the τ band": "shorter" if short else "within",
                                 "recordings": len(h), "shipped": _named(h, "shipped"),
                                 "tau_band": _named(h, "tau_band")})
    return pd.DataFrame(rows), pd.DataFrame(bins)


def figure(df: pd.DataFrame, path: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(9.0, 3.6), sharey=True)
    x = np.arange(len(BINS))
    for ax, level in zip(axes, (1, 2), strict=True):
        osc = df[(df["class"] == OSC) & (df["level"] == level)]
        fresh.rate_bars(
            ax, [osc[(osc["period_over_lam_cl"] >= lo) & (osc["period_over_lam_cl"] < hi)]
                 for lo, hi in BINS],
            lambda g, col: int((g[col] == OSC).sum()),
            [("shipped", "C0", "band widened for a residual line (shipped)"),
             ("tau_band", "C7", "band from τ and PV alone")])
        ax.set_xticks(x, [f"{lo:g}–{hi:g}" for lo, hi in BINS])
        ax.set_xlabel("disturbance period / closed-loop time constant")
        ax.set_ylim(0, 1.05)
        ax.set_title(f"level {level}, four families (Wilson 95 %)", fontsize=9)
    axes[0].set_ylabel("named oscillatory_disturbance")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=2, frameon=False)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    with atomic_path(path) as p:
        fig.savefig(p, dpi=120, format="png")
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=12)
    ap.add_argument("--none-seeds", type=int, default=12)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    df = fresh.run(one, cases(args.seeds, args.none_seeds), args.jobs)
    tab, bins = summary(df)
    OUT.mkdir(parents=True, exist_ok=True)
    with atomic_path(OUT / "disturbance_band.csv") as p:
        df.to_csv(p, index=False)
    figure(df, OUT / "disturbance_band.png")
    osc, none = df[df["class"] == OSC], df[df["class"] == "none"]
    text = "\n".join([
        "# Oscillatory disturbances and the comparison band", "",
        "Generated by `experiments/disturbance_band.py` (`make concealed`; described in its "
        "docstring). Oscillatory disturbances (seeds "
        f"{FIRST_OSC_SEED}–{FIRST_OSC_SEED + args.seeds - 1}) and `none` recordings (seeds "
        f"{FIRST_NONE_SEED}–{FIRST_NONE_SEED + args.none_seeds - 1}) of the three tuning "
        "families and the holdout family, at levels 1 and 2: seeds the benchmark never "
        "draws. Each diagnosed with the model and the package defaults, twice in the same "
        "run: *shipped* (the comparison band widened for a clear line in the nominal "
        "residual) and *tau_band* (the band from τ and PV alone, the earlier rule). Rates "
        "carry Wilson 95 % intervals; nothing here sets a threshold.", "",
        "- disturbances named, all families and levels: shipped "
        + rate_text(int((osc["shipped"] == OSC).sum()), len(osc)) + "; tau_band "
        + rate_text(int((osc["tau_band"] == OSC).sum()), len(osc)),
        "- `none` recordings called physics: shipped "
        + rate_text(int((none["shipped"] != "none").sum()), len(none)) + "; tau_band "
        + rate_text(int((none["tau_band"] != "none").sum()), len(none)),
        "- recordings whose verdict differs between the two: "
        + (", ".join(f"`{r.family}_L{r.level}_{r['class']}_{r.seed:02d}` "
                     f"({r.tau_band} → {r.shipped})"
                     for _, r in df[df["shipped"] != df["tau_band"]].iterrows()) or "none"),
        "", "![named rate by period](disturbance_band.png)", "",
        "## By period", "",
        "A period *shorter* than the τ band is one below half the period of the band's "
        "low-pass corner cut from τ alone (`0.5/f_lp`, `f_lp = 5/(2πτ)`): outside the "
        "earlier rule's range unless PV itself oscillated clearly.", "",
        to_markdown(bins), "",
        "## By family, class and level", "",
        to_markdown(tab), ""])
    write_text(OUT / "disturbance_band.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
