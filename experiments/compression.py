"""Historian compression against the real-loop verdicts: the compression varied, nothing else.

Issue 11 met a stiction loop turned away because 51 % of its samples were historian
holds; ``batch`` now treats held samples as missing (``realdata.quality.prepare``) and keeps
``unusable`` for records above 90 % holds. Whether the *verdicts* survive compression was
never measured. Compression is known to create apparent nonlinearity and flat stretches
that look like a sticking valve (Thornhill, Choudhury & Shah 2004), so both directions are
checked: stiction loops still found, and healthy loops not turned into stiction.

Each source window is re-recorded through a box-car exception historian
(:func:`stictionbench.sim.measurement.historian_compression`, stepped retrieval) holding a
share ``h`` = 0, 0.3, 0.5, 0.7 and 0.85 of each signal's steps, in three ways
(:data:`TREATMENTS`): rows of PV and OP stored together (the pattern of the shared
refinery records, whose holds are PV-and-OP holds), or each tag compressed on its own,
read as ``batch`` reads it, or with every signal bridged over its own holds. Each version
goes to every published method and to the shipped consensus
(``conf/consensus/default.yaml``) exactly as ``batch`` would give it.
Sources, all labelled:

- the real windows of ``../shared/data/isdb`` and ``../shared/data/plant`` that the
  historian had not already compressed (PV-and-OP hold share below 5 %), at most
  three windows per physical loop, so one loop with many windows does not dominate;
- the simulated loops of ``experiments/simulated_loops.py`` (servo and regulatory).

Nothing is tuned here. The h = 0 rows are the uncompressed verdicts; "same" is the share
of windows whose verdict at ``h`` equals that one. Rates are by window with Wilson 95 %
intervals. Writes ``reports/real/compression.md``, ``.csv`` and ``.png``.

Run: ``.venv/bin/python experiments/compression.py [--data ../shared/data] [--jobs 2]``
(about 5 minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from simulated_loops import make_loop  # noqa: E402

from stictionbench.errors import InputError  # noqa: E402
from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import rate_text  # noqa: E402
from stictionbench.realdata.compare import PUBLISHED, binary, window_calls  # noqa: E402
from stictionbench.realdata.consensus import Consensus  # noqa: E402
from stictionbench.realdata.datasets import load_csv_dir  # noqa: E402
from stictionbench.realdata.quality import held_fraction, release_holds  # noqa: E402
from stictionbench.recording import Recording  # noqa: E402
from stictionbench.reports.tables import to_markdown  # noqa: E402
from stictionbench.sim.measurement import historian_compression  # noqa: E402

SHARES = (0.0, 0.3, 0.5, 0.7, 0.85)
#: windows whose own PV-and-OP hold share is above this are left out (already compressed)
MAX_OWN_HOLDS = 0.05
PER_LOOP = 3
#: how the record is compressed and read: PV and OP rows stored together (the holds of
#: ``plant/labels.csv``) or each tag on its own, read by ``batch`` (PV-and-OP holds
#: bridged when the screen finds compression) or with every signal bridged over its own
#: holds (:func:`release_holds` with ``joint=False``)
TREATMENTS = ("rows held together, batch", "tags held apart, batch",
              "tags held apart, each bridged")


def real_windows(folder: Path) -> list[tuple[str, str, Recording]]:
    """(source, name, recording) of the uncompressed windows of a labelled folder."""
    recs, _ = load_csv_dir(folder, labels=str(folder / "labels.csv"), warn=False)
    out, per = [], {}
    for name in sorted(recs):
        rec = recs[name]
        if binary(rec.meta.get("label")) is None:
            continue
        if held_fraction(rec.PV, rec.OP) >= MAX_OWN_HOLDS:
            continue
        g = str(rec.meta.get("group", name))
        per[g] = per.get(g, 0) + 1
        if per[g] <= PER_LOOP:
            out.append((folder.name, name, rec))
    return out


def sim_windows(n: int) -> list[tuple[str, str, Recording]]:
    out = []
    for mode in ("servo", "regulatory"):
        for i in range(n):
            rec, _ = make_loop(i, mode)
            out.append((f"simulated {mode}", f"{mode}_{i:02d}", rec))
    return out


def one(source: str, name: str, rec: Recording, share: float, treatment: str,
        cons: Consensus) -> dict:
    """Every published method's verdict and the consensus on ``rec`` compressed to
    ``share`` and read back with ``treatment`` (see :data:`TREATMENTS`)."""
    joint = treatment == TREATMENTS[0]
    comp = historian_compression(rec, share, joint=joint) if share > 0 else rec
    given = release_holds(comp, joint=False)[0] if treatment == TREATMENTS[2] else comp
    calls = window_calls(given, name, methods=PUBLISHED)
    row = {"source": source, "window": name, "group": calls["group"],
           "label": binary(rec.meta.get("label")), "share": share, "treatment": treatment,
           "pv_held": held_fraction(comp.PV), "op_held": held_fraction(comp.OP),
           "joint_held": held_fraction(comp.PV, comp.OP),
           "holds_released": calls["holds_released"]}
    verdicts = {m: calls[m].verdict for m in PUBLISHED}
    row.update(verdicts)
    row["consensus"] = ("unusable" if all(v == "unusable" for v in verdicts.values())
                        else cons.decide(verdicts)[0])
    return row


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """Per source, label and hold share: windows flagged, unusable, verdict unchanged."""
    base = df[df.share == 0].set_index(["source", "window", "treatment"]).consensus
    df = df.assign(same=[v == base[k] for k, v in
                         zip(zip(df.source, df.window, df.treatment, strict=True), df.consensus,
                             strict=True)])
    rows = []
    for (src, lab, t, h), g in df.groupby(["source", "label", "treatment", "share"],
                                           sort=True):
        n = len(g)
        rows.append({"source": src, "label": lab, "treatment": t, "hold_share": h,
                     "joint_hold_share_median": round(float(g.joint_held.median()), 3),
                     "windows": n,
                     "called_stiction": rate_text(int((g.consensus == "stiction").sum()), n),
                     "unusable": int((g.consensus == "unusable").sum()),
                     "inconclusive": int((g.consensus == "inconclusive").sum()),
                     "verdict_unchanged": rate_text(int(g.same.sum()), n)})
    return pd.DataFrame(rows)


def per_method(df: pd.DataFrame) -> pd.DataFrame:
    """Per method and hold share, pooled over the real windows: stiction windows called
    stiction, non-stiction windows called stiction."""
    real = df[~df.source.str.startswith("simulated")]
    rows = []
    for t, m in itertools.product(TREATMENTS, [*PUBLISHED, "consensus"]):
        row = {"treatment": t, "method": m}
        sub = real[real.treatment == t]
        for h, g in sub.groupby("share"):
            st, ns = g[g.label == "stiction"], g[g.label == "no_stiction"]
            row[f"h={h:g} detected"] = f"{int((st[m] == 'stiction').sum())}/{len(st)}"
            row[f"h={h:g} false"] = f"{int((ns[m] == 'stiction').sum())}/{len(ns)}"
        rows.append(row)
    return pd.DataFrame(rows)


def pooled(df: pd.DataFrame) -> pd.DataFrame:
    """Real windows pooled (ISDB and refinery), per treatment and hold share: stiction
    windows called stiction, non-stiction windows called stiction, balanced accuracy."""
    from stictionbench.realdata.compare import balanced_accuracy

    real = df[~df.source.str.startswith("simulated")]
    rows = []
    for (t, h), g in real.groupby(["treatment", "share"], sort=False):
        st, ns = g[g.label == "stiction"], g[g.label == "no_stiction"]
        rows.append({"treatment": t, "hold_share": h,
                     "joint_hold_share_median": round(float(g.joint_held.median()), 3),
                     "detected": rate_text(int((st.consensus == "stiction").sum()), len(st)),
                     "false_alarms": rate_text(int((ns.consensus == "stiction").sum()),
                                               len(ns)),
                     "balanced_accuracy": round(balanced_accuracy(g.label, g.consensus), 3)})
    return pd.DataFrame(rows).sort_values(["treatment", "hold_share"], kind="stable")


def figure(df: pd.DataFrame, path: Path) -> None:
    """Windows called stiction against the hold share: one row of panels per treatment,
    one column per source, stiction and non-stiction windows, Wilson 95 % bars."""
    from stictionbench.rates import wilson
    from stictionbench.reports.figures import new_figure, save_png

    sources = list(dict.fromkeys(df.source))
    fig, axs = new_figure(len(TREATMENTS), len(sources),
                          figsize=(3.2 * len(sources), 2.6 * len(TREATMENTS)),
                          squeeze=False, sharex=True, sharey=True)
    for (i, t), (j, src) in itertools.product(enumerate(TREATMENTS), enumerate(sources)):
        ax = axs[i][j]
        d = df[(df.source == src) & (df.treatment == t)]
        for lab, colour in (("stiction", "tab:red"), ("no_stiction", "tab:blue")):
            g = d[d.label == lab].groupby("share")
            k = g.consensus.apply(lambda v: int((v == "stiction").sum()))
            n = g.size()
            if n.empty:
                continue
            lo, hi = np.array([wilson(int(a), int(b)) for a, b in zip(k, n, strict=True)]).T
            p = (k / n).to_numpy()
            ax.errorbar(n.index, p, yerr=[p - lo, hi - p], marker="o", capsize=3,
                        color=colour, label=f"{lab} (n={int(n.iloc[0])})")
        ax.set_ylim(-0.03, 1.03)
        if i == 0:
            ax.set_title(src, fontsize=9)
        if j == 0:
            ax.set_ylabel(f"{t}\ncalled stiction", fontsize=8)
        if i == len(TREATMENTS) - 1:
            ax.set_xlabel("hold share of each signal")
        if i == 0:
            ax.legend(fontsize=7, loc="best")
    save_png(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--sim-loops", type=int, default=20,
                    help="simulated loops per mode (servo, regulatory)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "reports" / "real"))
    a = ap.parse_args(argv)
    from joblib import Parallel, delayed
    from tqdm import tqdm

    data = Path(a.data)
    try:
        src = [w for d in ("isdb", "plant") for w in real_windows(data / d)]
    except InputError as exc:
        print(f"compression: {exc}", file=sys.stderr)
        return 2
    src += sim_windows(a.sim_loops)
    cons = Consensus.load()
    jobs = [(s, n, r, h, t) for s, n, r in src for h in SHARES for t in TREATMENTS]
    rows = list(tqdm(Parallel(n_jobs=a.jobs, return_as="generator")(
        delayed(one)(s, n, r, h, t, cons) for s, n, r, h, t in jobs), total=len(jobs),
        desc="windows"))
    df = pd.DataFrame(rows)
    out = Path(a.out)
    write_text(out / "compression.csv", df.to_csv(index=False, lineterminator="\n",
                                                  float_format="%.6g"))
    summ = summary(df)
    meth = per_method(df)
    figure(df, out / "compression.png")
    lines = ["# Historian compression against the verdicts", "",
             "Generated by `experiments/compression.py` (`make real`). Each window is "
             "re-recorded through a box-car exception historian holding the given share of "
             "each signal's steps, values read back as the last stored one "
             "(`stictionbench.sim.measurement.historian_compression`): *rows held "
             "together*: PV and OP stored together whenever either leaves its dead band "
             "(the refinery records' own pattern: their holds are PV-and-OP holds); *tags "
             "held apart*: each tag compressed on its own. *batch*: read as `batch` reads "
             "it (PV-and-OP holds treated as missing and short gaps bridged when the "
             "screen finds compression); *each bridged*: every signal bridged over its "
             "own holds first (`release_holds(joint=False)`). The verdict is the shipped "
             "consensus (`conf/consensus/default.yaml`). Real windows: "
             f"those of `isdb` and `plant` with under {MAX_OWN_HOLDS:.0%} PV-and-OP holds of "
             f"their own, at most {PER_LOOP} per loop; simulated: "
             "`experiments/simulated_loops.py` loops. Nothing is tuned here; rates are by "
             "window, with Wilson 95 % intervals. `verdict_unchanged`: the verdict equals "
             "the window's uncompressed one. The joint hold share (PV and OP both "
             "unchanged) is the measure of `plant/labels.csv` `held_frac`.", "",
             "![compression](compression.png)", "",
             "## Real windows pooled (ISDB and refinery), the consensus", "",
             to_markdown(pooled(df)), "",
             "## By source and label", "",
             to_markdown(summ), "",
             "## Per method, real windows pooled (stiction windows called stiction; "
             "non-stiction windows called stiction)", "",
             to_markdown(meth), ""]
    write_text(out / "compression.md", "\n".join(lines))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
