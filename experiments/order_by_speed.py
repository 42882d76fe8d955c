"""The likelihood tests' high-pass order against the loop's speed, over every recording
both orders were run on: where order 0's level-2 loss and order 2's false alarms lie.

``holdout_order_load.py`` varies the time constant of 84 level-2 effects and finds order
0's loss against order 2 growing with it (4 of 84 at τ = 8 s, 15 at τ = 60 s). If the
loss were confined to slow loops and order 2's false alarms to fast ones (or the other way
round), a rule choosing the order by the record's speed could keep both orders' strengths.
This report reads the two full regenerations that exist, order 2 (commit
:data:`ORDER2_REF`, the package's default then) and order 0 (commit :data:`ORDER0_REF`,
branch ``order0``, where every report was regenerated with order 0 as the default),
recording by recording:

- the holdout family's blind blocks (``holdout_pooled.csv``, blocks of
  ``holdout_pooled.BLIND``; 4320 recordings) and
- the independent concealed sets A–I (``independent_set_?.csv``; 1728 recordings),

binned by ``band_dof`` (the independent samples the comparison band leaves in the
validation blocks: the record's length in units of the loop's speed; the bin edges are
fixed below, not fitted). Per source, bin and level: physics recordings named right under
each order, the paired change (exact McNemar test), and healthy recordings called physics
under each order (Wilson 95 %). Nothing is tuned: the report describes where each
order's errors are.

Both sides are read from git, so the report is the same whatever the working tree holds
(the defaults changed after it: ``default_candidates.py``). Run:
``.venv/bin/python experiments/order_by_speed.py [--order0-ref REF]``; needs the order-0
commit in the clone (``git fetch`` the branch ``order0``); without it the committed report
is kept and the script says so (exit 0, so that ``make independent`` goes on); writes
``reports/concealed/order_by_speed.{md,csv}``.
"""

from __future__ import annotations

import argparse
import io
import subprocess
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

from holdout_pooled import BLIND  # noqa: E402

from stictionbench.io import write_text  # noqa: E402
from stictionbench.rates import mcnemar_p, rate_text  # noqa: E402
from stictionbench.reports.tables import csv_text, to_markdown  # noqa: E402

OUT = ROOT / "reports" / "concealed"
#: the order-0 regeneration (README: "Order 0 was tried as the default and not adopted")
ORDER0_REF = "e0678f4"
#: the order-2 regeneration it was compared with (the reports at the order-0 experiment)
ORDER2_REF = "74fed1d"
#: ``band_dof`` bin edges (independent validation samples in the comparison band)
EDGES = (0.0, 30.0, 60.0, 120.0, 250.0, float("inf"))
SETS = "abcdefghi"


def _git_csv(ref: str, path: str) -> pd.DataFrame:
    out = subprocess.run(["git", "-C", str(ROOT), "show", f"{ref}:{path}"],
                         capture_output=True, text=True)
    if out.returncode:
        raise FileNotFoundError(f"{ref}:{path}")
    return pd.read_csv(io.StringIO(out.stdout))


def paired(ref: str) -> pd.DataFrame:
    """One row per recording: source, class, level, band_dof and the verdict under each
    order (order 2 from :data:`ORDER2_REF`, order 0 from ``ref``)."""
    rows = []
    path = "reports/concealed/holdout_pooled.csv"
    two, zero = _git_csv(ORDER2_REF, path), _git_csv(ref, path)
    j = two.merge(zero[["name", "predicted_default"]], on="name", suffixes=("", "_0"),
                  validate="one_to_one")
    j = j[j.block.isin(BLIND)]
    rows.append(pd.DataFrame({"source": "holdout blind blocks", "name": j.name,
                              "class": j["class"], "level": j.level, "band_dof": j.band_dof,
                              "order_2": j.predicted_default,
                              "order_0": j.predicted_default_0}))
    for s in SETS:
        path = f"reports/concealed/independent_set_{s}.csv"
        two, zero = _git_csv(ORDER2_REF, path), _git_csv(ref, path)
        j = two.merge(zero[["name", "predicted"]], on="name", suffixes=("", "_0"),
                      validate="one_to_one")
        rows.append(pd.DataFrame({"source": "independent sets A–I", "name": j.name,
                                  "class": j["class"], "level": j.level,
                                  "band_dof": j.band_dof, "order_2": j.predicted,
                                  "order_0": j.predicted_0}))
    df = pd.concat(rows, ignore_index=True)
    df["band_dof_bin"] = pd.cut(df.band_dof, list(EDGES), right=False).astype(str)
    return df


def table(df: pd.DataFrame) -> pd.DataFrame:
    """Per source, ``band_dof`` bin and level: physics named right under each order, the
    discordant pairs, and healthy recordings called physics under each order."""
    rows = []
    for (src, b, lvl), g in df.groupby(["source", "band_dof_bin", "level"], sort=False,
                                       observed=True):
        phys, h = g[g["class"] != "none"], g[g["class"] == "none"]
        ok2, ok0 = phys.order_2 == phys["class"], phys.order_0 == phys["class"]
        gained, lost = int((ok0 & ~ok2).sum()), int((ok2 & ~ok0).sum())
        rows.append({
            "source": src, "band_dof": b, "level": lvl,
            "physics named, order 2": rate_text(int(ok2.sum()), len(phys)),
            "physics named, order 0": rate_text(int(ok0.sum()), len(phys)),
            "only order 0 / only order 2": f"{gained} / {lost} (p = "
                                           f"{mcnemar_p(gained, lost):.2g})",
            "healthy called physics, order 2": rate_text(int((h.order_2 != "none").sum()),
                                                         len(h)),
            "healthy called physics, order 0": rate_text(int((h.order_0 != "none").sum()),
                                                         len(h))})
    out = pd.DataFrame(rows)
    order = {str(pd.Interval(a, b, closed="left")): i
             for i, (a, b) in enumerate(zip(EDGES[:-1], EDGES[1:], strict=True))}
    return out.sort_values(["source", "level", "band_dof"],
                           key=lambda c: c.map(order) if c.name == "band_dof" else c,
                           kind="stable").reset_index(drop=True)


def _bins() -> list[str]:
    return [str(pd.Interval(a, b, closed="left"))
            for a, b in zip(EDGES[:-1], EDGES[1:], strict=True)]


def reading(df: pd.DataFrame) -> str:
    """Per source: the net level-2 physics order 0 loses against order 2, and the net
    healthy recordings order 2 calls physics beyond order 0, bin by bin; and whether
    the bins of the two overlap (where they do, choosing the order by the record's speed
    trades one for the other)."""
    parts, shared = [], []
    for src, g in df.groupby("source", sort=False):
        l2 = g[(g.level == 2) & (g["class"] != "none")]
        h = g[g["class"] == "none"]
        loss, fa = {}, {}
        for b in _bins():
            x = l2[l2.band_dof_bin == b]
            loss[b] = (int(((x.order_0 == x["class"]) & (x.order_2 != x["class"])).sum())
                       - int(((x.order_2 == x["class"]) & (x.order_0 != x["class"])).sum()))
            y = h[h.band_dof_bin == b]
            fa[b] = int((y.order_2 != "none").sum()) - int((y.order_0 != "none").sum())
        both = [b for b in _bins() if loss[b] < 0 and fa[b] > 0]
        shared.append(bool(both))
        parts.append(
            f"{src}, level-2 physics named by order 0 minus order 2 per band_dof bin: "
            + ", ".join(f"{b} {v:+d}" for b, v in loss.items())
            + "; healthy recordings order 2 calls physics beyond order 0: "
            + ", ".join(f"{b} {v:+d}" for b, v in fa.items())
            + f" (bins with both: {', '.join(both) if both else 'none'})")
    verdict = ("in every source some bins hold both order 0's losses and order 2's extra "
               "false alarms: there a choice of order by the record's speed trades one for "
               "the other, so no split by speed keeps both orders' strengths"
               if all(shared) else
               "in at least one source the two fall in different bins: a split by speed "
               "could keep both there (to be set on one source and scored on the other)")
    return "Reading: " + "; ".join(parts) + f". So {verdict}."


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--order0-ref", default=ORDER0_REF,
                    help="commit holding the order-0 regeneration (default %(default)s)")
    a = ap.parse_args(argv)
    try:
        df = paired(a.order0_ref)
    except FileNotFoundError as exc:
        print(f"order_by_speed: {exc}: not in this clone (git fetch the branch order0, "
              "or pass --order0-ref); reports/concealed/order_by_speed.md kept as committed",
              file=sys.stderr)
        return 0
    t = table(df)
    write_text(OUT / "order_by_speed.csv", csv_text(t))
    text = "\n".join([
        "# The high-pass order against the loop's speed, recording by recording", "",
        "Generated by `experiments/order_by_speed.py` (design in its docstring): every "
        "recording of the holdout family's blind blocks and of the independent sets A–I "
        f"under order 2 (commit `{ORDER2_REF}`) and under order 0 (commit "
        f"`{a.order0_ref}`, branch `order0`), binned by `band_dof` (fixed edges); "
        "Wilson 95 % intervals, exact McNemar tests; nothing tuned.", "",
        to_markdown(t), "",
        reading(df), "",
    ])
    write_text(OUT / "order_by_speed.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
